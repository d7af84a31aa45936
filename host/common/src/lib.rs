//! Small helpers that several tapeshape crates need and none owns.
//!
//! Why a crate of its own: the mesh, body, measurement, model, population,
//! estimator, evaluation and station crates each had their own copy of
//! "did you mean" and of "write a file so that a crash never leaves half of
//! it" (four and six copies, not all alike, not all of them fsyncing). One
//! copy here, below every user in the dependency graph, keeps the messages
//! alike and the writes safe. It holds nothing else: geometry lives in
//! `tapeshape-mesh` (its `vec3` module), names of measurements in
//! `tapeshape-measure`.
//!
//! * [`suggest`]: the known names closest to a mistyped one, on `strsim`.
//! * [`fs`]: [`fs::write_atomic`], the one way a file the user keeps is
//!   written, on `tempfile`.
//! * `cli` (feature `cli`, the example programs' only): one way a bad
//!   command line ends, on `clap`.

#[cfg(feature = "cli")]
pub mod cli;
pub mod fs;
pub mod suggest;
