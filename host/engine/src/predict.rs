//! Training and prediction for the station: the engine facade over
//! `tapeshape-model` (the paper's method) and `tapeshape-measure` (the
//! operators).
//!
//! Why a facade: the model crate knows measurements only as indices and
//! metres, the station knows names, units and operators. This module holds a
//! trained model together with its measurement set **compiled once** for the
//! template, checks what an operator entered before the optimiser sees it
//! (unknown names, impossible values, unit slips, contradictions), and turns
//! the model's report into one the station can print and store.
//!
//! * [`train`]: measures every body of a [`Dataset`] with the union of the
//!   named sets (deduplicated by name; the union's definitions are stored in
//!   the model file so a station needs nothing else) and fits the model.
//! * [`Engine::predict`]: any subset of the model's measurements, each with
//!   an optional tolerance, gives a mesh in the template topology and an
//!   [`EstimateReport`]; what can be chosen for it is [`PredictOptions`]
//!   (the pipeline and the paper's `l`, `lambda`, `s`), resolved once per
//!   estimate into the model's configuration.
//! * [`Engine::default_model`]: the model that ships inside the program
//!   (`host/engine/models/default.tsm.gz`, rebuilt with
//!   `scripts/rebuild-default-model.sh`; see `docs/prediction.md`).
//!
//! Input checks (each an error with a message an operator can act on, unless
//! said otherwise):
//!
//! * unknown name: the closest known names are suggested;
//! * zero, negative, NaN or infinite value or tolerance;
//! * unit slip: a value more than [`MARGINAL_Z_ERROR`] SDs from the mean
//!   that becomes typical when read in another unit ("stature 1.76 cm looks
//!   like metres"); a value that far out with no such explanation is refused
//!   as outside the population the model knows. Mean and SD are those of
//!   real people (ANSUR II train split) for measurements that follow an
//!   ANSUR column, else the training population's; the training
//!   population must agree (for the reason given below);
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
//!   Readings without an ANSUR column are only warned about;
//! * an implausible but possible set is predicted, with a warning and its
//!   plausibility (Mahalanobis distances) in the report.

pub mod input;
pub mod options;

use std::sync::{Arc, OnceLock};
use std::time::{Duration, Instant};

use serde::{Deserialize, Serialize};
use tapeshape_measure::{CompiledSet, MeasureError, MeasurementSet, BUILTIN_SETS};
use tapeshape_mesh::{Anatomy, Mesh, Topology, Vec3};
pub use tapeshape_model::predict::PredictionReport;
use tapeshape_model::regress::JointGaussian;
pub use tapeshape_model::{
    Control, FitSettings, ModelError, ModelFile, PredictConfig, PredictObserver, PredictProgress,
    PredictSettings, PredictStage, Round, SettingsError, ShapeModel, Target,
};
use tapeshape_model::{MeasurementSetText, Provenance, TemplateInfo};

use crate::dataset::{Dataset, DatasetError, DatasetKind};
pub use input::{parse_length, Input, Inputs, Length, Unit};
pub use options::{Pipeline, PredictOptions};

/// A reading further than this many training SDs from the training mean is
/// refused (as a unit slip when another unit explains it).
pub const MARGINAL_Z_ERROR: f64 = 6.0;
/// A reading further than this many SDs from what the other readings predict
/// is refused as a contradiction.
pub const CONDITIONAL_Z_ERROR: f64 = 6.0;
/// ... and above this it is a warning.
pub const CONDITIONAL_Z_WARN: f64 = 4.0;
/// The sets the default model carries.
pub const DEFAULT_SETS: [&str; 3] = ["paper34", "ansur", "quick"];

/// Errors of training and prediction. The message says what was wrong and
/// what to do.
#[derive(Debug, thiserror::Error)]
pub enum PredictError {
    /// A measurement name the model does not know.
    #[error("unknown measurement `{name}`{suggestion}")]
    UnknownMeasurement {
        /// The name given.
        name: String,
        /// "; did you mean `x`?" or a pointer to the list.
        suggestion: String,
    },
    /// A value that is no length (zero, negative, NaN, infinite).
    #[error("{0}")]
    BadValue(String),
    /// A value that only makes sense in another unit, or far outside the population.
    #[error("{0}")]
    OutOfRange(String),
    /// Readings that contradict each other.
    #[error("the readings contradict each other: {0}")]
    Contradiction(String),
    /// Malformed input (syntax, duplicates, files).
    #[error("{0}")]
    Input(String),
    /// A prediction option out of its range ("lambda must lie in [0, 1], got 2").
    #[error(transparent)]
    Settings(#[from] SettingsError),
    /// The prediction was cancelled by its observer
    /// ([`Engine::predict_observed`]); the text names the stage.
    #[error("estimate cancelled ({0})")]
    Cancelled(String),
    /// Training failed or was asked for something impossible.
    #[error("training: {0}")]
    Training(String),
    /// The model (file, fit or prediction) failed.
    #[error(transparent)]
    Model(#[from] ModelError),
    /// A measurement set could not be loaded or compiled.
    #[error(transparent)]
    Measure(#[from] MeasureError),
    /// A dataset problem.
    #[error(transparent)]
    Dataset(#[from] DatasetError),
    /// I/O with the file it concerns.
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: String,
        /// The error.
        #[source]
        source: std::io::Error,
    },
}

/// Settings of [`train`] (default: all components, f64, no notes).
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct TrainSettings {
    /// The model's fit settings (PCA threshold, components).
    pub fit: FitSettings,
    /// Keep the fewest PCA components explaining at least this share of the
    /// training variance (e.g. 0.999); `None`: keep all that `fit` keeps.
    pub variance_kept: Option<f64>,
    /// Round the PCA mean and basis to f32 precision (so that a compressed
    /// file is about half the size; the effect on accuracy is measured in
    /// `docs/results/predict-sreal.md`).
    pub round_to_f32: bool,
    /// Free-form provenance notes (dataset recipe, command).
    pub notes: String,
}

/// The union of measurement sets, deduplicated by name (first definition
/// kept), as TOML text that [`MeasurementSet::from_toml_str`] reads back.
///
/// Errors if a set is unknown or two sets define the same name differently
/// in what they compute (the kind and its parameters).
pub fn union_set_text(sets: &[&str]) -> Result<String, PredictError> {
    if sets.is_empty() {
        return Err(PredictError::Training(
            "no measurement set named: give at least one, e.g. --set paper34".into(),
        ));
    }
    let mut entries: Vec<toml::Value> = Vec::new();
    let mut names: Vec<String> = Vec::new();
    let mut parsed = Vec::new();
    for &set in sets {
        // Validate first (a clear error for an unknown or broken set).
        let ms = MeasurementSet::load(set)?;
        let text = match BUILTIN_SETS.iter().find(|(n, _)| *n == set) {
            Some((_, t)) => t.to_string(),
            None => std::fs::read_to_string(set).map_err(|source| PredictError::Io {
                path: set.to_string(),
                source,
            })?,
        };
        let table: toml::Table =
            toml::from_str(&text).map_err(|e| PredictError::Training(format!("set {set}: {e}")))?;
        let list = table
            .get("measurement")
            .and_then(|m| m.as_array())
            .cloned()
            .unwrap_or_default();
        for (entry, def) in list.into_iter().zip(&ms.definitions) {
            if let Some(i) = names.iter().position(|n| *n == def.name) {
                let (prev_set, prev): &(String, MeasurementSet) = &parsed[i];
                let prev_def = &prev.definitions[prev.index_of(&def.name).expect("present")];
                if prev_def.kind != def.kind {
                    return Err(PredictError::Training(format!(
                        "sets {prev_set} and {} both define '{}' but differently: train them separately or rename one",
                        ms.name, def.name
                    )));
                }
                continue;
            }
            names.push(def.name.clone());
            parsed.push((ms.name.clone(), ms.clone()));
            entries.push(entry);
        }
    }
    let mut header = toml::Table::new();
    header.insert("name".into(), toml::Value::String(sets.join("+")));
    header.insert(
        "description".into(),
        toml::Value::String(format!(
            "Union of the measurement sets {} (deduplicated by name).",
            sets.join(", ")
        )),
    );
    let mut root = toml::Table::new();
    root.insert("set".into(), toml::Value::Table(header));
    root.insert("measurement".into(), toml::Value::Array(entries));
    toml::to_string(&root).map_err(|e| PredictError::Training(format!("writing the union: {e}")))
}

/// The template the engine predicts in: the body generator's topology and anatomy.
fn body_template() -> Result<(Arc<Topology>, Anatomy), PredictError> {
    let body = tapeshape_body::BodyModel::shared()
        .map_err(|e| PredictError::Training(format!("loading the body template: {e}")))?;
    Ok((body.topology().clone(), tapeshape_body::anatomy::anatomy()))
}

/// Trains a model on `dataset` (a population in the template topology) with
/// the union of `sets` (built-in names or set files).
///
/// Every body is measured with the compiled union (in parallel); the model
/// is fitted to the meshes (metres, station frame) and measurements; the
/// file carries the template's faces and anatomy and the union's text.
pub fn train(
    dataset: &Dataset,
    sets: &[&str],
    settings: &TrainSettings,
) -> Result<ModelFile, PredictError> {
    if dataset.header.kind == DatasetKind::Faces {
        return Err(PredictError::Training(
            "a faces dataset holds head regions only; train on a population or an import of whole bodies".into(),
        ));
    }
    if dataset.len() < 3 {
        return Err(PredictError::Training(format!(
            "the dataset has {} bodies; training needs at least 3 (the paper used hundreds)",
            dataset.len()
        )));
    }
    let (topology, anatomy) = body_template()?;
    if dataset.topology.n_vertices() != topology.n_vertices()
        || dataset.topology.faces() != topology.faces()
    {
        return Err(PredictError::Training(format!(
            "the dataset's topology ({} vertices, {} faces) is not the template's ({} vertices, {} faces): register the meshes to the template first",
            dataset.topology.n_vertices(),
            dataset.topology.faces().len(),
            topology.n_vertices(),
            topology.faces().len()
        )));
    }
    let text = union_set_text(sets)?;
    let set = MeasurementSet::from_toml_str(&text, &sets.join("+"))?;
    let compiled = set.compile(&topology, &anatomy)?;
    let bodies: Vec<&[Vec3]> = dataset.bodies.iter().map(Vec::as_slice).collect();
    let measured = compiled.measure_batch(&bodies);
    let mut rows = Vec::with_capacity(bodies.len());
    for (i, m) in measured.into_iter().enumerate() {
        let m = m.map_err(|e| {
            PredictError::Training(format!(
                "measuring body {i} ({}): {e}",
                dataset
                    .header
                    .bodies
                    .get(i)
                    .map_or("?", |b| b.name.as_str())
            ))
        })?;
        rows.push(m.iter().map(|x| x.value).collect::<Vec<f64>>());
    }
    let names: Vec<String> = set.definitions.iter().map(|d| d.name.clone()).collect();
    let mut model = ShapeModel::fit(&bodies, &rows, &names, &settings.fit)?;
    if let Some(share) = settings.variance_kept {
        if !(share > 0.0 && share <= 1.0) {
            return Err(PredictError::Training(format!(
                "variance share {share} is not in (0, 1]"
            )));
        }
        let var: Vec<f64> = model.pca.sigma.iter().map(|s| s * s).collect();
        let total: f64 = var.iter().sum();
        let mut acc = 0.0;
        let mut keep = var.len();
        for (k, v) in var.iter().enumerate() {
            acc += v;
            if acc >= share * total {
                keep = k + 1;
                break;
            }
        }
        if keep < model.n_components() {
            // Refit with fewer components: the model crate fits the feature
            // map and statistics for the components it keeps.
            let fit = FitSettings {
                max_components: Some(keep),
                ..settings.fit.clone()
            };
            model = ShapeModel::fit(&bodies, &rows, &names, &fit)?;
        }
    }
    if settings.round_to_f32 {
        for x in model.pca.basis.iter_mut().chain(model.pca.mean.iter_mut()) {
            *x = *x as f32 as f64;
        }
    }
    let file = ModelFile {
        provenance: Provenance {
            dataset: format!(
                "{} bodies ({:?}{})",
                dataset.len(),
                dataset.header.kind,
                dataset
                    .header
                    .settings
                    .as_ref()
                    .map(|s| format!(", generated with seed {} and n {}", s.seed, s.n))
                    .unwrap_or_default()
            ),
            trained_by: format!("tapeshape-engine {}", env!("CARGO_PKG_VERSION")),
            created: String::new(),
            notes: format!(
                "sets: {}; components: {}; variance kept: {:?}; f32-rounded basis: {}; {}",
                sets.join(", "),
                model.n_components(),
                settings.variance_kept,
                settings.round_to_f32,
                settings.notes
            ),
        },
        template: TemplateInfo {
            n_vertices: topology.n_vertices(),
            faces: topology.faces().to_vec(),
            anatomy,
        },
        measurement_set: MeasurementSetText {
            name: sets.join("+"),
            format: "toml".into(),
            text,
        },
        model,
    };
    file.validate()?;
    Ok(file)
}

/// Writes a model file gzip-compressed when `path` ends in `.gz`, plain
/// otherwise, with the one atomic, fsynced write
/// ([`tapeshape_common::fs::write_atomic`]).
pub fn save_model(file: &ModelFile, path: &std::path::Path) -> Result<(), PredictError> {
    let gz = path.extension().is_some_and(|e| e == "gz");
    if !gz {
        return Ok(file.save(path)?);
    }
    let bytes = file.to_bytes()?;
    let io = |source| PredictError::Io {
        path: path.display().to_string(),
        source,
    };
    let mut enc = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::best());
    std::io::Write::write_all(&mut enc, &bytes).map_err(io)?;
    let compressed = enc.finish().map_err(io)?;
    tapeshape_common::fs::write_atomic(path, &compressed).map_err(io)
}

/// Reads a model file, plain or gzip-compressed (detected by its magic).
pub fn load_model_bytes(bytes: &[u8], origin: &str) -> Result<ModelFile, PredictError> {
    if bytes.starts_with(&[0x1f, 0x8b]) {
        let mut out = Vec::new();
        std::io::Read::read_to_end(&mut flate2::read::GzDecoder::new(bytes), &mut out).map_err(
            |e| PredictError::Input(format!("{origin}: damaged compressed model file: {e}")),
        )?;
        Ok(ModelFile::from_bytes(&out, origin)?)
    } else {
        Ok(ModelFile::from_bytes(bytes, origin)?)
    }
}

/// One reading's check against the training statistics.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct InputCheck {
    /// Measurement name.
    pub name: String,
    /// Value, mm.
    pub value_mm: f64,
    /// The unit the value was read in, and whether it was typed.
    pub unit: Unit,
    /// False when a bare number was read in the default unit.
    pub unit_typed: bool,
    /// Tolerance given, mm.
    pub tolerance_mm: Option<f64>,
    /// Training mean and SD of the measurement, mm.
    pub training_mean_mm: f64,
    /// Training SD, mm.
    pub training_sd_mm: f64,
    /// `(value - mean) / sd` under the training marginal.
    pub z: f64,
    /// What the other readings predict for it (mean, mm), if any others were given.
    pub predicted_mm: Option<f64>,
    /// SD of that prediction with reading errors added, mm.
    pub predicted_sd_mm: Option<f64>,
    /// `(value - predicted) / predicted_sd`.
    pub conditional_z: Option<f64>,
}

/// Which population a reading's prediction comes from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum Reference {
    /// Real people: ANSUR II train split (the reading follows an ANSUR column).
    RealPeople,
    /// The model's training population (the joint Gaussian of the model).
    Training,
}

/// What other readings predict for one measurement ([`Engine::predict_reading`]).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct ReadingPrediction {
    /// Predicted value, metres.
    pub mean: f64,
    /// SD of the prediction with the reading's own error added, metres.
    pub sd: f64,
    /// The population the prediction comes from.
    pub reference: Reference,
    /// Number of other readings it is conditioned on (0: the marginal).
    pub conditioned_on: usize,
    /// The same prediction under the training population (mean, SD with the
    /// reading's error, metres): [`Engine::check`] refuses a reading only when
    /// both references find it far off.
    pub training: (f64, f64),
}

/// Summary of the model used.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ModelSummary {
    /// Where it came from (embedded default or a path).
    pub source: String,
    /// Measurement sets in the model.
    pub sets: String,
    /// Training bodies.
    pub n_training: usize,
    /// PCA components.
    pub n_components: usize,
    /// Template vertices.
    pub n_vertices: usize,
}

/// The report of one estimate: inputs, checks, the model's stage report, warnings.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct EstimateReport {
    /// The model used.
    pub model: ModelSummary,
    /// Every reading with its checks.
    pub inputs: Vec<InputCheck>,
    /// Stage values, plausibility and timings (from `tapeshape-model`).
    pub prediction: PredictionReport,
    /// Time to check the inputs.
    pub check_time: Duration,
    /// Everything the operator should know: input notes and the model's warnings.
    pub warnings: Vec<String>,
}

/// A predicted body.
#[derive(Debug, Clone)]
pub struct Estimate {
    /// The body in the template topology (metres, station frame).
    pub mesh: Mesh,
    /// The report.
    pub report: EstimateReport,
}

/// A trained model with its measurement set compiled for its template:
/// compiled once, then [`Engine::predict`] as often as wanted.
pub struct Engine {
    file: ModelFile,
    source: String,
    set: MeasurementSet,
    compiled: CompiledSet,
    topology: Arc<Topology>,
    stats: Vec<(f64, f64)>,
    real: OnceLock<RealStats>,
}

/// Statistics of real people (ANSUR II **train split**, both sexes) for the
/// model's measurements that follow an ANSUR column: the reference for
/// "could a person have these readings". The generated population's
/// relations between measurements are much tighter than real people's (a
/// generator with few degrees of freedom), so judging a real customer's
/// readings by them refuses real people (measured: every ANSUR test-split
/// subject with the full ansur set was refused).
///
/// The statistics are a [`JointGaussian`] of the ANSUR columns alone (no
/// weights), so a reading's prediction from the others is the model's one
/// Gaussian conditional, [`JointGaussian::conditional`].
#[derive(Debug)]
struct RealStats {
    /// Per model measurement: its index in `joint`, if it has an ANSUR column.
    row: Vec<Option<usize>>,
    /// Means (metres) and covariance (metres^2) of those columns.
    joint: JointGaussian,
}

impl RealStats {
    /// No measurement has real-people statistics (no ANSUR data, or too few
    /// complete subjects): every reading is judged by the training population.
    fn none(set: &MeasurementSet) -> RealStats {
        RealStats {
            row: vec![None; set.len()],
            joint: JointGaussian {
                n_measurements: 0,
                n_weights: 0,
                mean: Vec::new(),
                cov: Vec::new(),
            },
        }
    }

    fn compute(set: &MeasurementSet) -> RealStats {
        let Ok(ansur) = crate::ansur::Ansur::get() else {
            return RealStats::none(set);
        };
        let mut row = vec![None; set.len()];
        let mut columns: Vec<&str> = Vec::new();
        for (j, d) in set.definitions.iter().enumerate() {
            if let Some(c) = d.ansur.as_deref() {
                if ansur.check_column(c).is_ok() {
                    row[j] = Some(columns.len());
                    columns.push(c);
                }
            }
        }
        let subjects: Vec<&crate::ansur::Subject> = ansur
            .subjects(None, crate::ansur::Split::Train)
            .filter(|s| columns.iter().all(|c| s.dim(c).is_some_and(f64::is_finite)))
            .collect();
        if subjects.len() < columns.len() + 2 {
            return RealStats::none(set);
        }
        let (mean, sd, corr) = crate::ansur::statistics(&subjects, &columns);
        let k = columns.len();
        let cov = (0..k * k)
            .map(|i| {
                let (a, b) = (i / k, i % k);
                corr[a][b] * sd[a] * sd[b]
            })
            .collect();
        RealStats {
            row,
            joint: JointGaussian {
                n_measurements: k,
                n_weights: 0,
                mean,
                cov,
            },
        }
    }

    /// Mean and SD (metres) of row `r`.
    fn marginal(&self, r: usize) -> (f64, f64) {
        let k = self.joint.n_measurements;
        (
            self.joint.mean[r],
            self.joint.cov[r * k + r].max(0.0).sqrt(),
        )
    }

    /// Conditional mean and variance (metres, metres^2) of row `a` given
    /// `observed` (row, value, noise variance), by
    /// [`JointGaussian::conditional`]. `None` if even its ridge leaves the
    /// observed covariance singular: the caller then judges by the training
    /// population.
    fn conditional(&self, a: usize, observed: &[(usize, f64, f64)]) -> Option<(f64, f64)> {
        let c = self.joint.conditional(&[a], observed).ok()?;
        Some((c.mean[0], c.cov[(0, 0)].max(0.0)))
    }
}

impl std::fmt::Debug for Engine {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Engine")
            .field("source", &self.source)
            .field("set", &self.set.name)
            .finish_non_exhaustive()
    }
}

impl Engine {
    /// Builds an engine from a model file: parses and compiles its
    /// measurement set for its template. `source` names it in reports.
    pub fn new(file: ModelFile, source: &str) -> Result<Self, PredictError> {
        file.validate()?;
        let set =
            MeasurementSet::from_toml_str(&file.measurement_set.text, &file.measurement_set.name)?;
        let names: Vec<&str> = set.definitions.iter().map(|d| d.name.as_str()).collect();
        if names
            != file
                .model
                .measurement_names
                .iter()
                .map(String::as_str)
                .collect::<Vec<_>>()
        {
            return Err(PredictError::Input(format!(
                "{source}: the model's measurement names do not match its set definitions; retrain it"
            )));
        }
        let topology = Arc::new(
            Topology::new(file.template.n_vertices, file.template.faces.clone())
                .map_err(|e| PredictError::Input(format!("{source}: template topology: {e}")))?,
        );
        let compiled = set.compile(&topology, &file.template.anatomy)?;
        let stats = file.model.measurement_stats();
        Ok(Self {
            file,
            source: source.to_string(),
            set,
            compiled,
            topology,
            stats,
            real: OnceLock::new(),
        })
    }

    /// Loads a model file (plain or `.gz`).
    pub fn load(path: &std::path::Path) -> Result<Self, PredictError> {
        let bytes = std::fs::read(path).map_err(|source| PredictError::Io {
            path: path.display().to_string(),
            source,
        })?;
        let origin = path.display().to_string();
        Self::new(load_model_bytes(&bytes, &origin)?, &origin)
    }

    /// The embedded default model (trained on 400 generated bodies with the
    /// `paper34`, `ansur` and `quick` sets; see `docs/prediction.md`).
    /// Decompressed and compiled on first use, then shared.
    pub fn default_model() -> Result<&'static Engine, PredictError> {
        static ENGINE: OnceLock<Result<Engine, String>> = OnceLock::new();
        ENGINE
            .get_or_init(|| {
                load_model_bytes(DEFAULT_MODEL, "embedded default model")
                    .and_then(|f| Engine::new(f, "embedded default model"))
                    .map_err(|e| e.to_string())
            })
            .as_ref()
            .map_err(|e| PredictError::Input(format!("the embedded default model is broken (rebuild it, see docs/prediction.md): {e}")))
    }

    /// The model file.
    pub fn file(&self) -> &ModelFile {
        &self.file
    }

    /// The union measurement set (the model's order).
    pub fn set(&self) -> &MeasurementSet {
        &self.set
    }

    /// The compiled set (measures meshes of the template).
    pub fn compiled(&self) -> &CompiledSet {
        &self.compiled
    }

    /// The template topology.
    pub fn topology(&self) -> &Arc<Topology> {
        &self.topology
    }

    /// The names of `set` (a built-in set) that this model carries, in the
    /// set's order; errors if the model lacks any of them.
    pub fn set_members(&self, set: &str) -> Result<Vec<String>, PredictError> {
        let ms = MeasurementSet::load(set)?;
        let mut out = Vec::new();
        for d in &ms.definitions {
            if self.set.index_of(&d.name).is_none() {
                return Err(PredictError::Input(format!(
                    "the model was not trained with set {set} (it lacks '{}'); its sets: {}",
                    d.name, self.file.measurement_set.name
                )));
            }
            out.push(d.name.clone());
        }
        Ok(out)
    }

    fn unknown(&self, name: &str) -> PredictError {
        // A group total (`tapeshape measure` prints e.g. the knee loop's sum
        // as `knee_circumference_left`) is derived, not a measurement.
        if let Some((_, members)) = self.set.groups().into_iter().find(|(g, _)| g == name) {
            let names: Vec<&str> = members
                .iter()
                .map(|&i| self.set.definitions[i].name.as_str())
                .collect();
            return PredictError::UnknownMeasurement {
                name: name.to_string(),
                suggestion: format!(
                    ": it is a derived total (the sum of {} measurements); give those instead: {}",
                    names.len(),
                    names.join(", ")
                ),
            };
        }
        let close = tapeshape_common::suggest::did_you_mean(
            name,
            self.set.definitions.iter().map(|d| d.name.as_str()),
        );
        let suggestion = if close.is_empty() {
            format!(
                "; the model knows {} measurements (`tapeshape predict --list` shows them)",
                self.set.len()
            )
        } else {
            close
        };
        PredictError::UnknownMeasurement {
            name: name.to_string(),
            suggestion,
        }
    }

    /// Checks `inputs` against the model (names, values, units, consistency).
    /// Returns the per-reading checks and warnings, or the first problem as an
    /// error (see the module docs).
    pub fn check(&self, inputs: &Inputs) -> Result<(Vec<InputCheck>, Vec<String>), PredictError> {
        if inputs.readings.is_empty() {
            return Err(PredictError::Input(
                "no measurements given: give at least one, e.g. --measure stature=176.5cm".into(),
            ));
        }
        let mut warnings = Vec::new();
        let mut checks = Vec::new();
        let mut index = Vec::new();
        let bare: Vec<&str> = inputs
            .readings
            .iter()
            .filter(|r| !r.value.unit_typed)
            .map(|r| r.name.as_str())
            .collect();
        if !bare.is_empty() {
            warnings.push(format!(
                "no unit given for {}: read as {}",
                bare.join(", "),
                inputs
                    .readings
                    .iter()
                    .find(|r| !r.value.unit_typed)
                    .map_or("cm", |r| r.value.unit.word())
            ));
        }
        for r in &inputs.readings {
            let j = self
                .set
                .index_of(&r.name)
                .ok_or_else(|| self.unknown(&r.name))?;
            let v = r.value.metres;
            let shown = format!("{} {}", r.value.number, r.value.unit.symbol());
            if !v.is_finite() {
                return Err(PredictError::BadValue(format!(
                    "{} is {shown}: give a number",
                    r.name
                )));
            }
            if v <= 0.0 {
                return Err(PredictError::BadValue(format!(
                    "{} is {shown}: a length must be positive; leave a measurement out rather than enter 0",
                    r.name
                )));
            }
            if let Some(t) = r.tolerance {
                if !(t.is_finite() && t > 0.0) {
                    return Err(PredictError::BadValue(format!(
                        "the tolerance of {} is {t} m: it must be a positive length",
                        r.name
                    )));
                }
            }
            let real = self.real.get_or_init(|| RealStats::compute(&self.set));
            let (mean, sd) = match real.row[j] {
                Some(r) => real.marginal(r),
                None => self.stats[j],
            };
            let z = if sd > 0.0 { (v - mean) / sd } else { 0.0 };
            // Refused only when the training population agrees: some
            // measurements of generated bodies differ systematically from
            // ANSUR's, and the model can still fit what it was trained on.
            let (tm, ts) = self.stats[j];
            let z_train = if ts > 0.0 { (v - tm) / ts } else { 0.0 };
            if z.abs() > MARGINAL_Z_ERROR && z_train.abs() > MARGINAL_Z_ERROR {
                return Err(PredictError::OutOfRange(self.out_of_range(r, mean, sd, z)));
            }
            index.push(j);
            checks.push(InputCheck {
                name: r.name.clone(),
                value_mm: v * 1000.0,
                unit: r.value.unit,
                unit_typed: r.value.unit_typed,
                tolerance_mm: r.tolerance.map(|t| t * 1000.0),
                training_mean_mm: mean * 1000.0,
                training_sd_mm: sd * 1000.0,
                z,
                predicted_mm: None,
                predicted_sd_mm: None,
                conditional_z: None,
            });
        }
        // Each reading against what the others predict. Each reading's own
        // error (its tolerance, else its ISO 20685-1 class) enters as noise,
        // so near-deterministic relations in a generated population do not
        // turn a normal tape error into a "contradiction".
        let noise: Vec<f64> = inputs
            .readings
            .iter()
            .zip(&index)
            .map(|(r, &j)| {
                r.tolerance
                    .unwrap_or(self.set.definitions[j].tolerance.mm() / 1000.0)
            })
            .collect();
        let mut bad = Vec::new();
        if index.len() >= 2 {
            for a in 0..index.len() {
                let observed: Vec<(usize, f64, f64)> = (0..index.len())
                    .filter(|&b| b != a)
                    .map(|b| (index[b], inputs.readings[b].value.metres, noise[b].powi(2)))
                    .collect();
                let real = self.real.get_or_init(|| RealStats::compute(&self.set));
                // Readings with an ANSUR column are judged against real
                // people (given the other such readings); the others against
                // the training population, as a warning only.
                let real_obs: Vec<(usize, f64, f64)> = (0..index.len())
                    .filter(|&b| b != a)
                    .filter_map(|b| {
                        real.row[index[b]]
                            .map(|r| (r, inputs.readings[b].value.metres, noise[b].powi(2)))
                    })
                    .collect();
                let value = inputs.readings[a].value.metres;
                let cond = self.file.model.joint.conditional(&[index[a]], &observed)?;
                let (mu_t, sd_t) = (
                    cond.mean[0],
                    (cond.cov[(0, 0)].max(0.0) + noise[a].powi(2)).sqrt(),
                );
                let z_t = (value - mu_t) / sd_t;
                let real_cond = match real.row[index[a]] {
                    Some(r) if !real_obs.is_empty() => real.conditional(r, &real_obs),
                    _ => None,
                };
                // Refused only when neither real people nor the training
                // population explain the reading; the message uses the
                // real-people prediction where there is one.
                let (mu, sd, zc, refusable) = match real_cond {
                    Some((m, v)) => {
                        let sd = (v + noise[a].powi(2)).sqrt();
                        let z = (value - m) / sd;
                        (m, sd, z, z_t.abs() > CONDITIONAL_Z_ERROR)
                    }
                    None => (mu_t, sd_t, z_t, false),
                };
                let c = &mut checks[a];
                c.predicted_mm = Some(mu * 1000.0);
                c.predicted_sd_mm = Some(sd * 1000.0);
                c.conditional_z = Some(zc);
                let others: Vec<&str> = inputs
                    .readings
                    .iter()
                    .enumerate()
                    .filter(|&(b, _)| b != a)
                    .map(|(_, r)| r.name.as_str())
                    .take(4)
                    .collect();
                let others = if inputs.readings.len() - 1 > others.len() {
                    format!(
                        "{} and {} more",
                        others.join(", "),
                        inputs.readings.len() - 1 - others.len()
                    )
                } else {
                    others.join(", ")
                };
                let msg = format!(
                    "{} {:.1} cm is {:.0} SD {} what {others} predict{} ({:.1} +/- {:.1} cm)",
                    c.name,
                    c.value_mm / 10.0,
                    zc.abs(),
                    if zc > 0.0 { "above" } else { "below" },
                    if inputs.readings.len() == 2 { "s" } else { "" },
                    mu * 100.0,
                    sd * 100.0
                );
                if refusable && zc.abs() > CONDITIONAL_Z_ERROR {
                    bad.push((zc.abs(), msg));
                } else if zc.abs() > CONDITIONAL_Z_WARN {
                    warnings.push(format!("{msg}: check this reading"));
                }
            }
        }
        if !bad.is_empty() {
            bad.sort_by(|a, b| b.0.total_cmp(&a.0));
            let list: Vec<String> = bad.into_iter().map(|b| b.1).collect();
            return Err(PredictError::Contradiction(format!(
                "{}; re-take these readings",
                list.join("; ")
            )));
        }
        Ok((checks, warnings))
    }

    /// What the readings `others` (name, metres; each with its ISO 20685-1
    /// tolerance as noise, like [`Engine::check`]) predict for measurement
    /// `name`: the Gaussian conditional of real people (ANSUR II train split)
    /// given the others that follow an ANSUR column when `name` has one, else
    /// of the training population (the model's joint Gaussian,
    /// [`ShapeModel::conditional_measurements`] with reading noise) given all
    /// others. With no others it is the marginal. The returned SD includes
    /// `name`'s own tolerance, so with others given `(value - mean) / sd` is
    /// the conditional z-score [`Engine::check`] computes for that reading
    /// (its marginal z leaves the tolerance out). Costs one small Cholesky
    /// per reference (a capture-time check, not the whole set's).
    ///
    /// Errors: an unknown name (with suggestions), a non-finite or
    /// non-positive value among `others`, `name` among `others`.
    pub fn predict_reading(
        &self,
        name: &str,
        others: &[(&str, f64)],
    ) -> Result<ReadingPrediction, PredictError> {
        self.predict_reading_with_tolerance(name, others, None)
    }

    /// [`Engine::predict_reading`] with every reading's error (the others'
    /// and `name`'s own) taken as `tolerance` metres instead of each
    /// measurement's ISO 20685-1 class: for an operator whose readings are
    /// known to be less exact (a novice: about 1 cm), so that honest
    /// readings are not judged by a tape expert's precision. `None` is
    /// [`Engine::predict_reading`]. Errors also for a tolerance that is not
    /// a positive finite length.
    pub fn predict_reading_with_tolerance(
        &self,
        name: &str,
        others: &[(&str, f64)],
        tolerance: Option<f64>,
    ) -> Result<ReadingPrediction, PredictError> {
        if let Some(t) = tolerance {
            if !(t.is_finite() && t > 0.0) {
                return Err(PredictError::BadValue(format!(
                    "the readings' tolerance is {t} m: it must be a positive length"
                )));
            }
        }
        let j = self.set.index_of(name).ok_or_else(|| self.unknown(name))?;
        let noise = |k: usize| tolerance.unwrap_or(self.set.definitions[k].tolerance.mm() / 1000.0);
        let mut observed = Vec::with_capacity(others.len());
        for &(n, v) in others {
            let k = self.set.index_of(n).ok_or_else(|| self.unknown(n))?;
            if k == j {
                return Err(PredictError::Input(format!(
                    "'{name}' is both the reading checked and one of the others: give each measurement once"
                )));
            }
            if !(v.is_finite() && v > 0.0) {
                return Err(PredictError::BadValue(format!(
                    "{n} is {v} m: a length must be positive and finite"
                )));
            }
            observed.push((k, v, noise(k).powi(2)));
        }
        let own = noise(j).powi(2);
        let cond = self.file.model.joint.conditional(&[j], &observed)?;
        let training = (cond.mean[0], (cond.cov[(0, 0)].max(0.0) + own).sqrt());
        let real = self.real.get_or_init(|| RealStats::compute(&self.set));
        if let Some(r) = real.row[j] {
            let real_obs: Vec<(usize, f64, f64)> = observed
                .iter()
                .filter_map(|&(k, v, n)| real.row[k].map(|rk| (rk, v, n)))
                .collect();
            let got = if real_obs.is_empty() {
                let (m, sd) = real.marginal(r);
                Some((m, sd * sd))
            } else {
                real.conditional(r, &real_obs)
            };
            if let Some((mean, var)) = got {
                return Ok(ReadingPrediction {
                    mean,
                    sd: (var + own).sqrt(),
                    reference: Reference::RealPeople,
                    conditioned_on: real_obs.len(),
                    training,
                });
            }
        }
        Ok(ReadingPrediction {
            mean: training.0,
            sd: training.1,
            reference: Reference::Training,
            conditioned_on: observed.len(),
            training,
        })
    }

    fn out_of_range(&self, r: &Input, mean: f64, sd: f64, z: f64) -> String {
        let v = r.value.metres;
        let typed = format!("{} {}", r.value.number, r.value.unit.symbol());
        // Another unit that makes the typed number typical?
        let best = Unit::ALL
            .iter()
            .filter(|&&u| u != r.value.unit)
            .map(|&u| (u, (r.value.number * u.metres() - mean) / sd))
            .filter(|(_, z)| z.abs() < 4.0)
            .min_by(|a, b| a.1.abs().total_cmp(&b.1.abs()));
        let typical = format!("{:.1} cm +/- {:.1}", mean * 100.0, sd * 100.0);
        match best {
            Some((u, _)) => format!(
                "{} {typed} looks like {}: write {}{} (typical: {typical}){}",
                r.name,
                u.word(),
                r.value.number,
                u.symbol(),
                if r.value.unit_typed {
                    String::new()
                } else {
                    format!("; a number without a unit is read as {}", r.value.unit.word())
                }
            ),
            None => format!(
                "{} {typed} ({:.1} cm) is {:.0} SD {} the population the model knows (typical: {typical}): check the reading and its unit",
                r.name,
                v * 100.0,
                z.abs(),
                if z > 0.0 { "above" } else { "below" }
            ),
        }
    }

    /// Estimates a body from `inputs` with `options` (the pipeline and the
    /// paper's l, lambda, s). The options are resolved and the inputs
    /// checked first ([`Engine::check`]); the mesh is in the template
    /// topology, metres, station frame.
    pub fn predict(
        &self,
        inputs: &Inputs,
        options: &PredictOptions,
    ) -> Result<Estimate, PredictError> {
        self.predict_observed(inputs, options, &|_: &PredictProgress| Control::Continue)
    }

    /// [`Engine::predict`] with progress reports and cancelling (see
    /// `tapeshape_model::predict::progress`): `observer` is called once
    /// before the input checks (stage [`PredictStage::Check`]), then by the
    /// model at every stage boundary and now and then inside its solvers, on
    /// this thread. If it answers [`Control::Cancel`], returns
    /// [`PredictError::Cancelled`] and no body.
    pub fn predict_observed(
        &self,
        inputs: &Inputs,
        options: &PredictOptions,
        observer: &dyn PredictObserver,
    ) -> Result<Estimate, PredictError> {
        let config = options.resolve()?;
        if observer.observe(&PredictProgress::at(PredictStage::Check)) == Control::Cancel {
            return Err(PredictError::Cancelled("before the input checks".into()));
        }
        let t0 = Instant::now();
        let (checks, mut warnings) = self.check(inputs)?;
        let check_time = t0.elapsed();
        let mut targets: Vec<Option<Target>> = vec![None; self.set.len()];
        for r in &inputs.readings {
            let j = self.set.index_of(&r.name).expect("checked");
            targets[j] = Some(Target {
                value: r.value.metres,
                tolerance: r.tolerance,
            });
        }
        let p = self
            .file
            .model
            .predict_observed(&targets, &self.compiled, &self.topology, &config, observer)
            .map_err(|e| match e {
                ModelError::Cancelled(stage) => PredictError::Cancelled(stage),
                e => PredictError::Model(e),
            })?;
        let pl = &p.report.plausibility;
        if pl.measurements_label == tapeshape_model::PlausibilityLabel::Unusual {
            warnings.push(format!(
                "unusual set of measurements (Mahalanobis distance {:.1} over {} readings, {:.1}% of the population is closer to the mean): the result is plausible but check the readings",
                pl.measurements_mahalanobis,
                inputs.readings.len(),
                100.0 * pl.measurements_quantile
            ));
        }
        warnings.extend(p.report.warnings.iter().cloned());
        let mesh = Mesh::new(p.vertices, self.topology.clone())
            .map_err(|e| PredictError::Input(format!("building the result mesh: {e}")))?;
        Ok(Estimate {
            mesh,
            report: EstimateReport {
                model: ModelSummary {
                    source: self.source.clone(),
                    sets: self.file.measurement_set.name.clone(),
                    n_training: self.file.model.n_training,
                    n_components: self.file.model.n_components(),
                    n_vertices: self.file.model.n_vertices(),
                },
                inputs: checks,
                prediction: p.report,
                check_time,
                warnings,
            },
        })
    }
}

/// The embedded default model (gzip of a model file).
static DEFAULT_MODEL: &[u8] = include_bytes!("../models/default.tsm.gz");
