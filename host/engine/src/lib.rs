//! The tapeshape shape engine: bodies, measurements, populations, model
//! training and prediction. No serial ports, no terminal code.
//!
//! The engine is split into small crates that are re-exported here:
//! [`mesh`] (meshes, topology, I/O), [`body`] (the MakeHuman body generator,
//! landmarks, parts), [`measure`] (measurement operators and sets). This
//! crate adds [`ansur`] (the embedded ANSUR II survey and its fixed split),
//! [`dataset`] (populations, faces, imports and the dataset file format) and
//! [`seeded`] (random draws whose streams do not change with the `rand` release).
//!
//! Units: metres inside, station frame (Z up, feet at z = 0, +Y front, +X the
//! body's right).

pub mod ansur;
pub mod dataset;
pub mod fit;
pub mod predict;
pub mod seeded;
pub mod stats;

pub use tapeshape_body as body;
pub use tapeshape_measure as measure;
pub use tapeshape_mesh as mesh;
