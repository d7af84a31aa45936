//! The estimator the station uses: a trained shape model behind names,
//! units and checks.
//!
//! Why a facade: the model crate (`tapeshape-model`, the paper's method)
//! knows measurements only as indices and metres; the station knows names,
//! units and operators. An [`Estimator`] holds a trained model together
//! with its measurement set **compiled once** for the template, checks what
//! an operator entered before the optimiser sees it (unknown names,
//! impossible values, unit slips, contradictions), and turns the model's
//! report into one the station can print and store.
//!
//! | module | what |
//! |---|---|
//! | [`estimator`] | [`Estimator`]: a model file compiled for its template; [`Estimator::predict`], [`Estimator::default_model`] |
//! | [`input`] | what an operator enters: [`Inputs`], [`Length`], [`Unit`], parsing from the command line and files |
//! | [`options`] | what may be chosen for an estimate ([`PredictOptions`]), resolved once into the model's configuration |
//! | [`checks`] | the input checks, the one unit-slip rule and the one refusal rule, [`Estimator::predict_reading`] for capture-time checks |
//! | [`priors`] | soft targets from real people for what was not measured ([`RealPeople`]) |
//! | [`totals`] | loop totals (a knee or arm girth as one tape reading) shared out over their pieces |
//! | [`report`] | [`EstimateReport`]: inputs, checks, the model's stage report, warnings |
//! | [`train`](mod@train) | [`train`](fn@train): a model from a dataset (`tapeshape-population`) and named measurement sets |
//! | [`file`](mod@file) | model files, plain or gzip ([`save_model`], [`load_model_bytes`]) and the embedded default model |
//!
//! * [`train()`]: measures every body of a dataset with the union of the
//!   named sets (deduplicated by name; the union's definitions are stored in
//!   the model file so a station needs nothing else) and fits the model.
//! * [`Estimator::predict`]: any subset of the model's measurements, each
//!   with an optional tolerance, gives a mesh in the template topology and
//!   an [`EstimateReport`]; what can be chosen for it is [`PredictOptions`]
//!   (the pipeline and the paper's `l`, `lambda`, `s`), resolved once per
//!   estimate into the model's configuration.
//! * [`Estimator::default_model`]: the model that ships inside the program
//!   (`host/estimator/models/default.tsm.gz`, rebuilt with
//!   `scripts/rebuild-default-model.sh`; see `docs/prediction.md`).
//!
//! Input checks (each an error with a message an operator can act on, unless
//! said otherwise):
//!
//! * unknown name: the closest known names are suggested;
//! * zero, negative, NaN or infinite value or tolerance;
//! * unit slip: a value more than [`MARGINAL_Z_ERROR`] SDs from the mean
//!   that becomes typical when read in another unit ("stature 1.76 cm looks
//!   like metres", by the one rule [`unit_slip`]); a value that far out
//!   with no such explanation is refused as outside the population the
//!   model knows. Mean and SD are those of real people (ANSUR II train
//!   split) for measurements that follow an ANSUR column, else the training
//!   population's; the training population must agree (for the reason given
//!   below);
//! * contradiction: each reading's z-score under the Gaussian of real people
//!   (ANSUR II train split) conditioned on the other readings that follow an
//!   ANSUR column, with every reading's own error (its tolerance, else its
//!   ISO 20685-1 class) added as noise: above [`CONDITIONAL_Z_ERROR`] it is
//!   refused ("waist 125 cm is 9 SD above what hip predicts") when the
//!   training population's conditional (all other readings) refuses it too,
//!   above [`CONDITIONAL_Z_WARN`] it is a warning. Both must agree because
//!   neither reference is right for every reading: a generated population's
//!   relations are far tighter than real people's (judged by them alone,
//!   every ANSUR II test subject's ansur set was refused), and some
//!   measurements of generated bodies differ systematically from ANSUR's
//!   (judged by ANSUR alone, generated bodies' neck readings were refused).
//!   Readings without an ANSUR column are only warned about. The rule is
//!   one function, [`refused`], which the station's capture-time check
//!   also asks;
//! * an implausible but possible set is predicted, with a warning and its
//!   plausibility (Mahalanobis distances) in the report;
//! * a reading the operator kept after a flag ([`Inputs::kept`]) is never
//!   refused as out of range or contradicting unless it is beyond any
//!   person ([`checks::BEYOND_HUMAN_Z`], [`checks::BEYOND_HUMAN_M`]): it is
//!   estimated with a warning naming it, and it does not condition the
//!   other readings' checks.
//!
//! Before the checks, a loop total given as one reading is shared out over
//! its pieces ([`totals`]); after them, what was not measured gets soft
//! targets from real people of the customer's sex ([`priors`]).
//!
//! Units: metres inside, station frame (Z up, feet at z = 0, +Y front, +X the
//! body's right).

mod basis_cache;
pub mod cache;
pub mod checks;
mod error;
pub mod estimator;
pub mod file;
pub mod input;
pub mod options;
pub mod priors;
pub mod report;
pub mod totals;
pub mod train;
pub mod warning;

pub use checks::{
    refused, unit_slip, InputCheck, ReadingPrediction, Reference, UnitSlip, CONDITIONAL_Z_ERROR,
    CONDITIONAL_Z_WARN, MARGINAL_Z_ERROR, SLIP_SUSPECT_Z, SLIP_Z,
};
pub use error::PredictError;
pub use estimator::Estimator;
pub use file::{load_model_bytes, save_model};
pub use input::{parse_length, Input, Inputs, Length, Unit, BARE_NUMBER_UNIT};
pub use options::{Pipeline, PredictOptions};
pub use priors::{RealPeople, SoftTarget};
pub use report::{Estimate, EstimateReport, ModelSummary};
pub use tapeshape_model::predict::PredictionReport;
pub use tapeshape_model::{
    Control, FitSettings, ModelError, ModelFile, PredictConfig, PredictObserver, PredictProgress,
    PredictSettings, PredictStage, Round, SettingsError, ShapeModel, Target,
};
pub use totals::TotalSplit;
pub use train::{train, union_set_text, TrainSettings, DEFAULT_SETS};
pub use warning::{AgainstOthers, OutOfRange, Warning};
