//! Measurement operators on triangle meshes, with exact supports, and
//! measurement sets as data.
//!
//! Every operator returns the measured value **and its support**: the points
//! it used, each a convex combination of at most two mesh vertices, and the
//! segments between them. The value is always the sum of the segment lengths
//! ([`Support::length`]), so gradients with respect to the vertices (and the
//! paper's per-edge energies) follow exactly from the support
//! ([`Support::gradient`]).
//!
//! Units: metres, station frame (Z up, +Y front, +X the body's right), as in
//! `tapeshape-mesh`.
//!
//! # Kinds
//!
//! - `euclidean {from, to}`: the straight segment between two landmarks.
//! - `path {landmarks}`: straight segments along an open landmark list (a
//!   tape laid over the outside of a straight limb).
//! - `geodesic {from, to}`: the shortest path on the mesh's edge graph
//!   (Dijkstra, as in the paper); support = the path's vertices. It is
//!   about 5.7% longer than the true surface geodesic on an icosphere
//!   (`docs/measurements.md`). `method = "unfolded"` also steps straight
//!   across each pair of triangles sharing an edge (support = vertices and
//!   edge crossings) and converges to the surface geodesic.
//! - `geodesic_path {landmarks}` / `geodesic_loop {landmarks}`: geodesics
//!   along an open or closed landmark list (the paper's knee and arm
//!   circumferences are loops of four geodesics).
//! - `circumference {anchor, normal, parts}`: the plane through the anchor
//!   landmark with the given normal is cut with the given body parts only;
//!   the cut curve (closed, or open where the parts' boundary cuts it)
//!   nearest the anchor is taken, and the value is the perimeter of its
//!   convex hull in the plane (a tape bridges concavities). Support = the
//!   hull's corners as edge interpolants, segments closing the loop. With
//!   `through = [b, c]` the plane passes through the anchor and landmarks
//!   `b`, `c` of each body instead of having a fixed normal.
//! - `height {landmark, floor?}`: `z(landmark) - z(floor)`, support = the two
//!   points with axis +Z. The floor is the named landmark or, by default, the
//!   lower of `heel_bottom_left` / `heel_bottom_right` on that body (so a
//!   body that is not standing at z = 0 during optimisation still measures
//!   from its own soles).
//! - `breadth` / `depth {anchor, normal, parts, axis}`: a caliper: the extent
//!   of the cut's convex hull along `axis` (in the plane), support = the two
//!   extreme hull points with that axis.
//!
//! # Use
//!
//! ```ignore
//! let set = MeasurementSet::builtin("paper34")?;
//! let compiled = set.compile(&topology, &anatomy)?; // once per template
//! let values = compiled.measure(&body.vertices)?;    // per body
//! ```
//!
//! Robustness notes (symbolic perturbation of vertices on the plane, the
//! hand-written hull) are in the `cut` module source.

mod compiled;
mod cut;
pub mod error;
mod geodesic;
pub mod set;
pub mod support;

pub use compiled::CompiledSet;
pub use error::MeasureError;
pub use set::{Class, Definition, GeodesicMethod, Kind, MeasurementSet, Tolerance, BUILTIN_SETS};
pub use support::{Measured, Support, SupportPoint};
