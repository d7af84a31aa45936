//! [`Estimator`]: a trained model with its measurement set compiled for its
//! template, and the estimate itself (checks, then the model's stages).

use std::path::{Path, PathBuf};
use std::sync::{Arc, OnceLock};
use std::time::Instant;

use tapeshape_measure::{CompiledSet, MeasurementSet};
use tapeshape_mesh::{Mesh, Topology};
use tapeshape_model::{
    Control, ModelError, ModelFile, PredictObserver, PredictProgress, PredictStage, Target,
};

use crate::cache;
use crate::checks::RealStats;
use crate::file::{load_model_bytes, DEFAULT_MODEL};
use crate::priors::{ANSUR_SUMS, CANNOT_FOLLOW_ANSUR};
use crate::warning::Warning;
use crate::{Estimate, EstimateReport, Inputs, ModelSummary, PredictError, PredictOptions};

/// Where [`Estimator::default_model`] keeps its decoded cache.
static CACHE_DIR: OnceLock<PathBuf> = OnceLock::new();

/// How the default model is named in reports and errors.
const DEFAULT_SOURCE: &str = "embedded default model";

/// A trained model with its measurement set compiled for its template:
/// compiled once, then [`Estimator::predict`] as often as wanted.
pub struct Estimator {
    pub(crate) file: ModelFile,
    pub(crate) source: String,
    pub(crate) set: MeasurementSet,
    pub(crate) compiled: CompiledSet,
    pub(crate) topology: Arc<Topology>,
    pub(crate) stats: Vec<(f64, f64)>,
    pub(crate) real: OnceLock<RealStats>,
    pub(crate) real_male: OnceLock<RealStats>,
    pub(crate) real_female: OnceLock<RealStats>,
}

impl std::fmt::Debug for Estimator {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Estimator")
            .field("source", &self.source)
            .field("set", &self.set.name)
            .finish_non_exhaustive()
    }
}

impl Estimator {
    /// Builds an estimator from a model file: parses and compiles its
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
            real_male: OnceLock::new(),
            real_female: OnceLock::new(),
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
    /// With a cache directory ([`Estimator::use_cache_dir`]) the decoded
    /// model and its ANSUR II statistics are read from there (a few
    /// milliseconds), or written there on the first start (see
    /// [`crate::cache`]).
    pub fn default_model() -> Result<&'static Estimator, PredictError> {
        static ENGINE: OnceLock<Result<Estimator, String>> = OnceLock::new();
        ENGINE
            .get_or_init(|| match CACHE_DIR.get() {
                Some(dir) => Self::default_cached(dir).map_err(|e| e.to_string()),
                None => Self::default_uncached().map_err(|e| e.to_string()),
            })
            .as_ref()
            .map_err(|e| PredictError::Input(format!("the embedded default model is broken (rebuild it, see docs/prediction.md): {e}")))
    }

    /// Keeps the decoded default model in `dir` (the station's data
    /// directory's `cache/`): call before the first
    /// [`Estimator::default_model`]. Returns false if the default model was
    /// already loaded or a directory already chosen (then nothing changes).
    pub fn use_cache_dir(dir: PathBuf) -> bool {
        CACHE_DIR.set(dir).is_ok()
    }

    fn default_uncached() -> Result<Estimator, PredictError> {
        load_model_bytes(DEFAULT_MODEL, DEFAULT_SOURCE)
            .and_then(|f| Estimator::new(f, DEFAULT_SOURCE))
    }

    /// The default model through the cache in `dir`: read it, or decode
    /// the embedded one, compute its statistics now and write the cache.
    pub(crate) fn default_cached(dir: &Path) -> Result<Estimator, PredictError> {
        match cache::read(dir, cache::DEFAULT_MODEL_SHA256) {
            Ok((file, real)) => {
                let estimator = Estimator::new(file, DEFAULT_SOURCE)?;
                let _ = estimator.real.set(real);
                Ok(estimator)
            }
            Err(why) => {
                tracing::info!(dir = %dir.display(), ?why, "decoding the embedded default model (no usable cache)");
                let estimator = Self::default_uncached()?;
                let real = estimator
                    .real
                    .get_or_init(|| RealStats::compute(&estimator.set, None));
                if let Err(e) =
                    cache::write(dir, cache::DEFAULT_MODEL_SHA256, &estimator.file, real)
                {
                    tracing::warn!(dir = %dir.display(), error = %e, "could not write the model cache (each start decodes the model again)");
                }
                Ok(estimator)
            }
        }
    }

    /// Makes ready what an estimate with `options` computes once per
    /// process: the template's smooth basis where step 2 uses it (the
    /// default tries it first), read from the cache directory where there
    /// is one and it holds the basis, else computed (about 1.3 s) and
    /// written there. The station calls it at start-up, so that its first
    /// estimate is as fast as the tenth; [`Estimator::predict`] calls it
    /// too (then it costs nothing). A basis that cannot be computed is left
    /// to the estimate, which reports it.
    pub fn warm_up(&self, options: &PredictOptions) {
        for pending in self.begin_warm_up(options) {
            pending.finish();
        }
    }

    /// Claims the preparation of the smooth bases `options`' step 2 needs
    /// and the process lacks (see [`Estimator::warm_up`]), to be finished
    /// on another thread while step 1 runs; step 2 waits for them.
    fn begin_warm_up(&self, options: &PredictOptions) -> Vec<crate::basis_cache::PendingBasis<'_>> {
        let step2 = options.settings().step2;
        let (n, edges) = (self.topology.n_vertices(), self.topology.edges());
        std::iter::once(step2.solver)
            .chain(step2.first)
            .filter_map(|solver| match solver {
                tapeshape_model::Step2Solver::SmoothBasis { modes, .. } => {
                    crate::basis_cache::begin(CACHE_DIR.get().map(|d| d.as_path()), n, edges, modes)
                }
                _ => None,
            })
            .collect()
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

    /// Whether measurement `j` of the set is an ANSUR II dimension that the
    /// standing A-pose mesh cannot take as ANSUR defines it
    /// ([`crate::priors::CANNOT_FOLLOW_ANSUR`]): a survey's reading of it
    /// ([`Inputs::ansur_survey`]) is recorded, not fitted.
    pub fn cannot_follow(&self, j: usize) -> bool {
        self.set.definitions[j]
            .ansur
            .as_deref()
            .is_some_and(|c| CANNOT_FOLLOW_ANSUR.contains(&c))
    }

    /// Whether measurement `j` is an ANSUR II dimension that the mesh
    /// measures as the sum of others ([`crate::priors::ANSUR_SUMS`]) and
    /// every one of those parts is among `fitted` (indices of the set):
    /// then the parts' indices, in the order of the sum. A survey's reading
    /// of it is recorded, not fitted ([`Inputs::ansur_survey`]).
    pub fn sum_of_given(&self, j: usize, fitted: &[usize]) -> Option<Vec<usize>> {
        let column = self.set.definitions[j].ansur.as_deref()?;
        let (_, parts) = ANSUR_SUMS.iter().find(|(sum, _)| *sum == column)?;
        parts
            .iter()
            .map(|part| {
                fitted
                    .iter()
                    .copied()
                    .find(|&k| self.set.definitions[k].ansur.as_deref() == Some(*part))
            })
            .collect()
    }

    fn names_of(&self, list: &[(usize, f64, Option<f64>)]) -> String {
        list.iter()
            .map(|&(j, _, _)| self.set.definitions[j].name.as_str())
            .collect::<Vec<_>>()
            .join(", ")
    }

    /// Estimates a body from `inputs` with `options` (the pipeline and the
    /// paper's l, lambda, s). The options are resolved and the inputs
    /// checked first ([`Estimator::check`]); the mesh is in the template
    /// topology, metres, station frame. With [`Inputs::ansur_survey`], a
    /// reading that [`Estimator::cannot_follow`] is checked and recorded but
    /// not fitted (the report's measurement says `recorded_only`, a
    /// [`Warning::RecordedNotFitted`] names it); given alone, it is refused.
    pub fn predict(
        &self,
        inputs: &Inputs,
        options: &PredictOptions,
    ) -> Result<Estimate, PredictError> {
        self.predict_observed(inputs, options, &|_: &PredictProgress| Control::Continue)
    }

    /// [`Estimator::predict`] with progress reports and cancelling (see
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
        let (expanded, totals) = self.expand_totals(inputs)?;
        let inputs = &expanded;
        let (checks, mut warnings) = self.check(inputs)?;
        let check_time = t0.elapsed();
        let mut targets: Vec<Option<Target>> = vec![None; self.set.len()];
        // Survey readings of ANSUR II dimensions that the standing mesh
        // cannot take as ANSUR defines them (issue 12, item 1) are checked
        // and recorded, and inform the real-people soft targets below (as
        // ANSUR's own quantity), but get no target: fitting the mesh's
        // different quantity to them folds the body (docs/measurements.md).
        let mut recorded_only: Vec<(usize, f64, Option<f64>)> = inputs
            .readings
            .iter()
            .filter(|_| inputs.ansur_survey)
            .filter_map(|r| {
                let j = self.set.index_of(&r.name).expect("checked");
                self.cannot_follow(j)
                    .then_some((j, r.value.metres, r.tolerance))
            })
            .collect();
        // A survey's reading that the mesh measures as the sum of other
        // readings of the same survey (sleeve outseam = acromion-radiale +
        // radiale-stylion on the mesh; ANSUR II's is 10 mm shorter on
        // average, `priors::ANSUR_SUMS`): recorded, not fitted, so that
        // the parts are met instead of all three missed by a compromise.
        let mut recorded_sums: Vec<(usize, Vec<usize>)> = Vec::new();
        if inputs.ansur_survey {
            let fitted: Vec<usize> = inputs
                .readings
                .iter()
                .map(|r| self.set.index_of(&r.name).expect("checked"))
                .filter(|j| !recorded_only.iter().any(|&(k, _, _)| k == *j))
                .collect();
            for r in &inputs.readings {
                let j = self.set.index_of(&r.name).expect("checked");
                if let Some(parts) = self.sum_of_given(j, &fitted) {
                    recorded_only.push((j, r.value.metres, r.tolerance));
                    recorded_sums.push((j, parts));
                }
            }
        }
        if recorded_only.len() == inputs.readings.len() {
            return Err(PredictError::Input(format!(
                "{} cannot be fitted: the standing body model cannot take {} as ANSUR II defines {} \
(flexed girths, calipers that compress the tissue); enter at least one other measurement",
                self.names_of(&recorded_only),
                if recorded_only.len() == 1 { "it" } else { "them" },
                if recorded_only.len() == 1 { "it" } else { "them" },
            )));
        }
        for r in &inputs.readings {
            let j = self.set.index_of(&r.name).expect("checked");
            if recorded_only.iter().any(|&(k, _, _)| k == j) {
                continue;
            }
            targets[j] = Some(Target {
                value: r.value.metres,
                tolerance: r.tolerance,
                soft: false,
            });
        }
        let soft = match options.real_people() {
            Some(r) => self.soft_targets(inputs, &r)?,
            None => Vec::new(),
        };
        let mut soft_targets = Vec::with_capacity(soft.len());
        for (j, t, entry) in soft {
            targets[j] = Some(t);
            soft_targets.push(entry);
        }
        // The smooth-basis step 2's basis: from the cache directory where
        // there is one (else computed once per process), read on another
        // thread while step 1 runs (step 2 waits for it).
        let pending = self.begin_warm_up(options);
        let mut p = std::thread::scope(|s| {
            if !pending.is_empty() {
                s.spawn(move || pending.into_iter().for_each(|p| p.finish()));
            }
            self.file.model.predict_observed(
                &targets,
                &self.compiled,
                &self.topology,
                &config,
                observer,
            )
        })
        .map_err(|e| match e {
            ModelError::Cancelled(stage) => PredictError::Cancelled(stage),
            e => PredictError::Model(e),
        })?;
        for &(j, value, tolerance) in &recorded_only {
            let name = &self.set.definitions[j].name;
            let Some(m) = p.report.measurements.iter_mut().find(|m| &m.name == name) else {
                continue;
            };
            m.target_mm = Some(value * 1000.0);
            m.tolerance_mm = tolerance.map(|t| t * 1000.0);
            m.error_mm = m.step2_mm.map(|v| (v - value * 1000.0).abs());
            m.recorded_only = true;
        }
        let cannot: Vec<String> = recorded_only
            .iter()
            .filter(|&&(j, _, _)| !recorded_sums.iter().any(|(k, _)| *k == j))
            .map(|&(j, _, _)| self.set.definitions[j].name.clone())
            .collect();
        if !cannot.is_empty() {
            warnings.push(Warning::RecordedNotFitted {
                measurements: cannot,
            });
        }
        for (j, parts) in &recorded_sums {
            warnings.push(Warning::RecordedSumOfParts {
                measurement: self.set.definitions[*j].name.clone(),
                parts: parts
                    .iter()
                    .map(|&k| self.set.definitions[k].name.clone())
                    .collect(),
            });
        }
        let pl = &p.report.plausibility;
        if pl.measurements_label == tapeshape_model::PlausibilityLabel::Unusual {
            warnings.push(Warning::UnusualSet {
                mahalanobis: pl.measurements_mahalanobis,
                readings: inputs.readings.len(),
                percent_closer: 100.0 * pl.measurements_quantile,
            });
        }
        let kept: Vec<String> = checks
            .iter()
            .filter(|c| c.kept_unusual)
            .map(|c| c.name.clone())
            .collect();
        if !kept.is_empty() {
            warnings.push(Warning::EstimatedWithKept {
                measurements: kept,
                percent_closer: 100.0 * pl.measurements_quantile,
                mahalanobis: pl.measurements_mahalanobis,
            });
        }
        warnings.extend(p.report.warnings.iter().cloned().map(Warning::Model));
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
                sex: inputs.sex,
                soft_targets,
                totals,
            },
        })
    }
}
