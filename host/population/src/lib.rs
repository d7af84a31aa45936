//! Populations of registered bodies: where the training data comes from.
//!
//! Why a crate of its own: the paper's method (`tapeshape-model`) learns
//! from bodies and their measurements and knows nothing of where they come
//! from; the station's estimator (`tapeshape-estimator`) uses a trained
//! model. Between them sits everything about bodies as data: the real people
//! of ANSUR II, generated populations fitted to them, faces, a user's own
//! meshes, and the file that holds them.
//!
//! | module | what |
//! |---|---|
//! | [`ansur`] | the embedded ANSUR II survey (6,068 U.S. Army personnel, `data/ansur2/`), its fixed train/test split |
//! | [`generate`] | populations of adults fitted to ANSUR II train-split subjects |
//! | [`fit`] | the one generator fitter (MakeHuman parameters to measurements), used here and by the evaluation's generator-fit baseline |
//! | [`faces`] | face datasets (the head region) and the anatomy remapped onto it |
//! | [`import`] | a folder of the user's registered OBJ/PLY meshes as a dataset |
//! | [`format`](mod@format) | the dataset file format (`.tsd`) and [`Dataset`] in memory |
//! | [`statistics`] | a population's statistics beside ANSUR II's (issue 3's four checked dimensions) |
//! | [`dimensions`] | every `ansur` dimension beside ANSUR II, and each body against its own subject within ISO 20685-1 (issue 12) |
//! | [`seeded`] | random draws whose streams do not change with the `rand` release |
//!
//! Units: metres inside, station frame (Z up, feet at z = 0, +Y front, +X the
//! body's right).

pub mod ansur;
pub mod dimensions;
mod error;
pub mod faces;
pub mod fit;
pub mod format;
pub mod generate;
pub mod import;
pub mod sections;
pub mod seeded;
pub mod statistics;

pub use dimensions::{dimension_markdown, dimension_statistics, DimensionReport};
pub use error::DatasetError;
pub use faces::{face_local_changes, generate_faces, head_region, remap_anatomy, FACE_REGIONS};
pub use format::{
    BodyRecord, Dataset, DatasetHeader, DatasetKind, FitRecord, FORMAT_VERSION, MAGIC,
};
pub use generate::{
    generate_population, race_weights, FitScope, PopulationSettings, EXTRA_FIT_TARGETS, FIT_TARGETS,
};
pub use import::{import_dir, read_mesh};
pub use statistics::{population_statistics, statistics_markdown, SexStatistics, CHECKED_COLUMNS};
