//! Measurement operators on triangle meshes, with exact supports.
//!
//! Every operator returns the measured value **and its support**: the points
//! it used, each a convex combination of at most two mesh vertices, and the
//! segments between them. The value is always the sum of the segment lengths,
//! so gradients with respect to the vertices (and the paper's per-edge
//! energies) follow exactly from the support.
//!
//! Units: metres, station frame (Z up, +Y front), as in `tapeshape-mesh`.

pub mod support;

pub use support::{Measured, Support, SupportPoint};
