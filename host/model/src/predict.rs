//! Prediction: the paper's start, step 1 (over weights) and step 2 (over
//! vertices), with a report of every stage.
//!
//! 1. **Start.** Feature analysis `w = B [P; 1]` when every measurement is
//!    given exactly (the paper); otherwise the Gaussian conditional of the
//!    weights on the given measurements (tolerances enter as observation
//!    noise). Each normalised weight is clamped to `[-l, l]`.
//! 2. **Step 1.** `s` rounds of: measure the shape (the measurer returns each
//!    measurement's support), set per-segment targets
//!    `l_t(e) = l_t(P) l_g(e) / l_g(P)`, minimise `E_m` over the weights with
//!    L-BFGS; then clamp again.
//! 3. **Step 2.** `s` rounds of the same over the vertex positions with
//!    `(1 - lambda) E_m + lambda E_s`, `E_s` measured from the step-1 shape.
//!    The default weighs each reading's terms so its energy is about
//!    `step2_reading_weight` (1e4) x (error in mm)^2 instead of the paper's
//!    unit weights, and keeps the step-1 value of a reading with a wide
//!    tolerance (see [`PredictSettings::step2_reading_weight`]).
//!
//! [`PredictSettings::paper`] runs exactly that. The default departs in how
//! step 1 solves: each of its `s` rounds is a MAP estimate under the training
//! Gaussian, `sum_j ((m_j - T_j) / sd_j)^2 + |w|^2` with readings trusted to
//! 1 mm (or their tolerance), solved by Gauss-Newton on the readings' values
//! ([`crate::map`], `step1_gauss_newton`; backtracked on the re-measured
//! objective): it shrinks the weights the readings do not inform, which
//! feature analysis's least-squares map fills with noise, and brought the
//! vertex distance to held-out bodies below feature analysis's. It also
//! clamps inside step 1 and refits the rest (`step1_box`), and adds rounds
//! while a reading misses half its allowable error ([`Continuation`]; in
//! step 1 these are L-BFGS rounds on `E_m` with the same prior, weighted per
//! measurement, [`EnergyWeighting::PerMeasurement`]: the paper's quartic
//! energy weighs a 1 mm stature error ~1e5 times a 1 mm error of a
//! 30-segment girth). Why and the measured effect: `docs/prediction.md`,
//! `docs/results/predict-iso.md`, `docs/results/predict-sreal.md`.
//!
//! The optimiser works in millimetres (see the crate docs). A measurement's
//! energy terms are weighted by `c = (reference_tolerance / tolerance)^2`
//! (1 for a reading without tolerance): since `(l^2 - l_t^2)^2 ~ 4 l^2 (l - l_t)^2`,
//! this is the Gaussian log-likelihood weighting of each reading's error.
//!
//! Progress and cancelling: [`ShapeModel::predict_observed`] calls a
//! [`PredictObserver`] at every stage boundary (start, each round of step 1
//! and step 2, done) and every [`OBSERVE_EVERY`] objective evaluations inside
//! the L-BFGS runs; the observer may answer [`Control::Cancel`], and the
//! prediction then returns [`ModelError::Cancelled`] without a body. Inside a
//! run, cancelling makes the watched objective return NaN from then on,
//! which both L-BFGS implementations treat as the end of the run (no change
//! to the solvers was needed); the pipeline then sees the flag and stops.
//!
//! Robustness: a stage that ends with a higher `E_m` than it started from
//! (each stage's `E_m` evaluated with per-segment targets set on its own
//! shape, so stages compare like for like) is undone with a warning; a non-finite energy ends
//! an L-BFGS run at its best point; a non-finite final mesh is an error.

use std::time::{Duration, Instant};

use tapeshape_measure::Measured;
use tapeshape_mesh::{Topology, Vec3};

use crate::energy::{measurement_energy, segment_terms, SegmentTerm};
use crate::map::MapProblem;
use std::cell::Cell;

use crate::refine::{
    minimise, LbfgsImpl, Objective, RunInfo, StopRule, VertexObjective, WeightObjective,
};
use crate::{ModelError, Result, ShapeModel, MM_PER_M};

/// Error type a [`Measurer`] returns.
pub type MeasureError = Box<dyn std::error::Error + Send + Sync>;

/// Measures a mesh with a measurement set whose order matches the model's
/// measurement names. Implemented by the engine with the real operators.
pub trait Measurer {
    /// Number of measurements M in the set.
    fn n_measurements(&self) -> usize;

    /// Measures the measurements `which` (indices into the set) on `vertices`
    /// (template order, metres, station frame); returns one [`Measured`] per
    /// index, in the order of `which`, each with its support.
    fn measure(&self, vertices: &[Vec3], which: &[usize]) -> Result<Vec<Measured>, MeasureError>;

    /// The largest error (metres) a re-measured value of measurement `j` may
    /// show against its target, e.g. the ISO 20685-1 class of the set's
    /// definition; `None` if the measurer does not know (then
    /// [`Continuation::default_allowable_mm`] applies).
    fn allowable_error(&self, _j: usize) -> Option<f64> {
        None
    }
}

/// The real operators: a measurement set compiled for the template.
impl Measurer for tapeshape_measure::CompiledSet {
    fn n_measurements(&self) -> usize {
        self.len()
    }

    fn measure(&self, vertices: &[Vec3], which: &[usize]) -> Result<Vec<Measured>, MeasureError> {
        which
            .iter()
            .map(|&j| self.measure_one(j, vertices).map_err(Into::into))
            .collect()
    }

    /// The ISO 20685-1 maximum allowable error of the definition's class.
    fn allowable_error(&self, j: usize) -> Option<f64> {
        self.set()
            .definitions
            .get(j)
            .map(|d| d.tolerance.mm() / MM_PER_M)
    }
}

/// One measurement to fit: value and optional tolerance, metres.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Target {
    /// Target value, metres.
    pub value: f64,
    /// Standard uncertainty of the reading, metres (`None`: as trusted as
    /// [`PredictSettings::reference_tolerance`]).
    pub tolerance: Option<f64>,
}

impl Target {
    /// A reading trusted at the reference tolerance.
    pub fn exact(value: f64) -> Self {
        Self {
            value,
            tolerance: None,
        }
    }

    /// A reading with a standard uncertainty `tolerance` (metres).
    pub fn with_tolerance(value: f64, tolerance: f64) -> Self {
        Self {
            value,
            tolerance: Some(tolerance),
        }
    }
}

/// Settings of [`ShapeModel::predict`] (the paper's parameters and stopping rules).
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct PredictSettings {
    /// Clamp every normalised weight to `[-l, l]` (paper: 3 synthetic, 10 real).
    pub l: f64,
    /// Weight of the smoothness energy in step 2, in `[0, 1]` (paper: 0.1).
    pub lambda: f64,
    /// Rounds of support recomputation per step (paper: 3). 0 = start only.
    pub s: usize,
    /// L-BFGS stopping rules of step 1 (paper: 100 iterations, gradient
    /// 1e-8, relative change 1e8 eps; history 7).
    pub stop: StopRule,
    /// L-BFGS stopping rules of step 2: the paper's, with history 5 (each
    /// pair is 2 x 3V doubles streamed twice per iteration; 5 instead of 7
    /// pairs cut the step-2 time by about a fifth, see
    /// `docs/results/predict-bench.md`).
    pub step2_stop: StopRule,
    /// L-BFGS implementation of step 1 (K variables; default argmin: its
    /// More-Thuente line search makes better progress on the stiff quartic
    /// energies and its per-iteration allocations cost nothing at this size).
    pub step1_solver: LbfgsImpl,
    /// L-BFGS implementation of step 2 (3V variables; default the built-in
    /// allocation-free one, see [`crate::refine`]).
    pub step2_solver: LbfgsImpl,
    /// A reading with this tolerance (metres) gets energy weight 1 (default 1 mm).
    pub reference_tolerance: f64,
    /// Warn about any given measurement whose final error exceeds this (mm).
    pub warn_error_mm: f64,
    /// How step 1 weights the measurements' energies (see [`EnergyWeighting`]).
    #[serde(default = "paper_weighting")]
    pub step1_weighting: EnergyWeighting,
    /// How step 2 weights the measurements' energies (see [`EnergyWeighting`]).
    #[serde(default = "paper_weighting")]
    pub step2_weighting: EnergyWeighting,
    /// With [`EnergyWeighting::PerMeasurement`] in step 2: each reading's
    /// energy is about this times (its error in mm)^2, against
    /// `lambda E_s` (mm^2). Default 1e4: on 40 ANSUR II subjects with the
    /// ansur set, 1e2 / 1e3 / 1e4 / 1e5 passed 76.2 / 90.7 / 92.7 / 91.0 % of
    /// readings within ISO 20685-1 (weight 1 leaves smoothness in charge:
    /// 51 %); `docs/results/predict-iso.md`. Ignored with the paper's weighting.
    #[serde(default = "unit_weight")]
    pub step2_reading_weight: f64,
    /// The reading noise `tau` (mm) of step 1 as a MAP estimate under the
    /// training Gaussian of the normalised weights: the objective is
    /// `sum_j (error_j / sd_j)^2 + |w|^2` with `sd_j = tau` for an exact
    /// reading, scaled by a reading's tolerance over the reference tolerance.
    /// With `step1_gauss_newton` (the default) `None` means the reference
    /// tolerance (1 mm). Without it (L-BFGS on `E_m`), `Some(tau)` adds
    /// `tau^2 |w|^2` to `E_m`, and `None` is the paper's `E_m` alone, except
    /// that with per-measurement weighting a reading with a tolerance brings
    /// in the prior with the reference tolerance (else its tolerance would
    /// mean nothing once step 1 converges). Measured on 50 held-out bodies:
    /// `docs/results/predict-sreal.md`.
    #[serde(default)]
    pub step1_prior_mm: Option<f64>,
    /// `Some(k)`: step 1 moves only the first k PCA components (the rest keep
    /// their start values). `None` (the paper): all.
    #[serde(default)]
    pub step1_components: Option<usize>,
    /// Step 1's `s` rounds as the MAP estimate
    /// `sum_j ((m_j - T_j) / sd_j)^2 + |w|^2` solved by Gauss-Newton on the
    /// readings' values with the round's supports held ([`crate::map`]),
    /// each step backtracked on the re-measured objective (a round whose step
    /// cannot lower it runs L-BFGS instead); `sd_j` as in `step1_prior_mm`.
    /// Continuation rounds run L-BFGS on `E_m` with the same prior.
    /// `false` (the paper): L-BFGS on `E_m` in every round.
    #[serde(default)]
    pub step1_gauss_newton: bool,
    /// Step 1 inside the box `|w_i| <= l`: before every round after the
    /// first, the weights beyond `l` are clamped and held there, so the
    /// following rounds refit the other components to the readings (an
    /// active-set method). `false` (the paper): one clamp after step 1,
    /// which undoes whatever fit the clamped components carried.
    #[serde(default)]
    pub step1_box: bool,
    /// More rounds while readings miss their allowable error (see
    /// [`Continuation`]). `None` (the paper): exactly `s` rounds per step.
    #[serde(default)]
    pub continuation: Option<Continuation>,
}

/// Rounds beyond `s` (each: recompute the supports, one more L-BFGS run) while
/// a given reading's error on the current shape exceeds `share` times its
/// allowable error ([`Measurer::allowable_error`], at least its tolerance if
/// it has one), as long as each round cuts the summed excess by at least 5 %
/// and the step has not used up `time_budget_s`. Applies to both steps.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Continuation {
    /// At most this many rounds beyond `s`, per step.
    pub max_extra_rounds: usize,
    /// A reading misses when its error exceeds this share of its allowable error.
    pub share: f64,
    /// Allowable error (mm) of a measurement the measurer gives none for.
    pub default_allowable_mm: f64,
    /// No new round once the step has run this long (seconds).
    pub time_budget_s: f64,
}

impl Default for Continuation {
    fn default() -> Self {
        Self {
            max_extra_rounds: 10,
            share: 0.5,
            default_allowable_mm: 4.0,
            time_budget_s: 1.0,
        }
    }
}

fn paper_weighting() -> EnergyWeighting {
    EnergyWeighting::Paper
}

fn unit_weight() -> f64 {
    1.0
}

/// How the segment terms of one measurement are weighted in `E_m`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub enum EnergyWeighting {
    /// The paper's `E_m`: every segment term `(l^2 - l_t^2)^2` with weight 1
    /// (times the reading's tolerance weight). A measurement of length `L`
    /// split into `n` hull or path segments then costs about
    /// `4 L^2 D^2 / n^3` for an error `D`: a 1 mm error of the stature
    /// (one segment) weighs about 1e5 times a 1 mm error of a 30-segment
    /// waist, so L-BFGS fits heights and lengths first and girths last.
    Paper,
    /// Each measurement's terms scaled by `L_t^2 / (4 sum_e l_t(e)^4)`, so that
    /// its energy is about `D^2` (mm^2) whatever its length and number of
    /// segments: every millimetre of error weighs the same. The same
    /// minimisers where all targets can be met; a better-conditioned problem.
    PerMeasurement,
}

impl Default for PredictSettings {
    fn default() -> Self {
        Self {
            l: 3.0,
            lambda: 0.1,
            s: 3,
            stop: StopRule::default(),
            step2_stop: StopRule {
                history: 5,
                ..StopRule::default()
            },
            step1_solver: LbfgsImpl::Argmin,
            step2_solver: LbfgsImpl::Builtin,
            reference_tolerance: 0.001,
            warn_error_mm: 5.0,
            step1_weighting: EnergyWeighting::PerMeasurement,
            step2_weighting: EnergyWeighting::PerMeasurement,
            step2_reading_weight: 1e4,
            step1_prior_mm: None,
            step1_components: None,
            step1_gauss_newton: true,
            step1_box: true,
            continuation: Some(Continuation::default()),
        }
    }
}

impl PredictSettings {
    /// Step 2's weighting and per-measurement scale.
    fn step2_terms(&self) -> (EnergyWeighting, f64) {
        (self.step2_weighting, self.step2_reading_weight)
    }

    /// The paper's method exactly: `E_m` weighted as the paper writes it,
    /// one clamp after step 1, exactly `s` rounds per step (l = 3,
    /// lambda = 0.1, s = 3, the paper's stopping rules). The default differs
    /// in five settings, measured in `docs/results/predict-iso.md` and
    /// `docs/results/predict-sreal.md`: `step1_gauss_newton`,
    /// [`EnergyWeighting::PerMeasurement`] in step 1 and in step 2 (with
    /// `step2_reading_weight`), `step1_box` and a [`Continuation`].
    pub fn paper() -> Self {
        Self {
            step1_weighting: EnergyWeighting::Paper,
            step2_weighting: EnergyWeighting::Paper,
            step1_prior_mm: None,
            step1_gauss_newton: false,
            step1_box: false,
            continuation: None,
            ..Self::default()
        }
    }
}

/// How the start weights were found.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub enum StartMethod {
    /// Feature analysis `B [P; 1]` (every measurement given, no tolerances).
    FeatureAnalysis,
    /// Gaussian conditional of the weights on the given measurements.
    Conditional,
}

/// One measurement through the stages (millimetres).
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct MeasurementReport {
    /// Measurement name.
    pub name: String,
    /// Target, mm (`None` if not given).
    pub target_mm: Option<f64>,
    /// Tolerance given with the target, mm.
    pub tolerance_mm: Option<f64>,
    /// Value on the start shape, mm (given measurements only).
    pub start_mm: Option<f64>,
    /// Value after step 1, mm (given measurements only).
    pub step1_mm: Option<f64>,
    /// Value on the final mesh, mm (all measurements; `None` if measuring failed).
    pub step2_mm: Option<f64>,
    /// `|step2 - target|`, mm.
    pub error_mm: Option<f64>,
}

/// Plausibility label from a chi-square quantile: below 0.95 typical, below
/// 0.999 unusual, else implausible.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub enum PlausibilityLabel {
    /// Quantile below 0.95.
    Typical,
    /// Quantile in [0.95, 0.999).
    Unusual,
    /// Quantile 0.999 or above.
    Implausible,
}

impl PlausibilityLabel {
    /// The label for a chi-square quantile.
    pub fn from_quantile(q: f64) -> Self {
        if q < 0.95 {
            Self::Typical
        } else if q < 0.999 {
            Self::Unusual
        } else {
            Self::Implausible
        }
    }
}

/// How plausible the result and its inputs are.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Plausibility {
    /// Mahalanobis distance of the step-1 weights, `|w|` (normalised weights are
    /// independent with unit variance on the training set).
    pub mahalanobis: f64,
    /// Chi-square quantile of `mahalanobis^2` with K degrees of freedom
    /// (Wilson-Hilferty approximation, about 1e-3 accurate).
    pub quantile: f64,
    /// Label of `quantile`.
    pub label: PlausibilityLabel,
    /// Mahalanobis distance of the given measurements under their training
    /// marginal Gaussian, each reading's tolerance (or the reference
    /// tolerance) added as observation noise.
    pub measurements_mahalanobis: f64,
    /// Its chi-square quantile (degrees of freedom = number given).
    pub measurements_quantile: f64,
    /// Label of `measurements_quantile`.
    pub measurements_label: PlausibilityLabel,
    /// RMS distance (mm) between the final mesh and its projection onto the
    /// PCA space: how far step 2 left the learned shape space.
    pub out_of_space_rms_mm: f64,
    /// Largest such vertex distance, mm.
    pub out_of_space_max_mm: f64,
    /// Components clamped to `l` at the start.
    pub clamped_start: Vec<usize>,
    /// Components clamped to `l` after step 1.
    pub clamped_step1: Vec<usize>,
    /// Triangles whose normal turned by more than 90 degrees from the step-1 shape.
    pub flipped_triangles: usize,
    /// Triangles whose area fell below 1% of their step-1 area.
    pub degenerate_triangles: usize,
}

/// Wall-clock time of each stage.
#[derive(Debug, Clone, Copy, PartialEq, Default, serde::Serialize, serde::Deserialize)]
pub struct StageTimings {
    /// Start weights, clamping and measuring the start shape.
    pub start: Duration,
    /// Step 1 (all rounds, clamping, measuring the result).
    pub step1: Duration,
    /// Step 2 (all rounds, measuring the result, checks).
    pub step2: Duration,
    /// Whole prediction.
    pub total: Duration,
}

/// The report of one prediction (everything but the mesh); serialisable to JSON.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct PredictionReport {
    /// How the start was found.
    pub start_method: StartMethod,
    /// Start weights after clamping (normalised).
    pub weights_start: Vec<f64>,
    /// Step-1 weights after clamping (normalised).
    pub weights_step1: Vec<f64>,
    /// Per measurement, in the model's order.
    pub measurements: Vec<MeasurementReport>,
    /// Plausibility of the inputs and the result.
    pub plausibility: Plausibility,
    /// Stage times.
    pub timings: StageTimings,
    /// L-BFGS runs of step 1, one per round.
    pub step1_runs: Vec<RunInfo>,
    /// L-BFGS runs of step 2, one per round.
    pub step2_runs: Vec<RunInfo>,
    /// Things the operator or engineer should know.
    pub warnings: Vec<String>,
    /// Settings used.
    pub settings: PredictSettings,
}

impl PredictionReport {
    /// The report as a plain-text table for engineers, logs and tests: one
    /// line per measurement (target, value after the start, step 1 and step 2,
    /// error; millimetres, `-` where not given), then plausibility, stage
    /// times and warnings.
    pub fn to_text(&self) -> String {
        use std::fmt::Write;
        let opt = |v: Option<f64>, prec: usize| match v {
            Some(x) => format!("{x:.prec$}"),
            None => "-".to_string(),
        };
        let width = self
            .measurements
            .iter()
            .map(|m| m.name.len())
            .max()
            .unwrap_or(0)
            .max(11);
        let mut out = String::new();
        let _ = writeln!(
            out,
            "{:width$}  {:>9}  {:>9}  {:>9}  {:>9}  {:>8}",
            "measurement", "target mm", "start", "step 1", "step 2", "error mm"
        );
        for m in &self.measurements {
            let _ = writeln!(
                out,
                "{:width$}  {:>9}  {:>9}  {:>9}  {:>9}  {:>8}",
                m.name,
                opt(m.target_mm, 1),
                opt(m.start_mm, 2),
                opt(m.step1_mm, 2),
                opt(m.step2_mm, 2),
                opt(m.error_mm, 3)
            );
        }
        let p = &self.plausibility;
        let _ = writeln!(
            out,
            "plausibility: weights Mahalanobis {:.2} over {} components (quantile {:.3}, {:?}); readings Mahalanobis {:.2} (quantile {:.3}, {:?})",
            p.mahalanobis,
            self.weights_step1.len(),
            p.quantile,
            p.label,
            p.measurements_mahalanobis,
            p.measurements_quantile,
            p.measurements_label
        );
        let _ = writeln!(
            out,
            "out of PCA space: RMS {:.2} mm, max {:.2} mm; clamped at start {:?}, after step 1 {:?}; flipped triangles {}, collapsed {}",
            p.out_of_space_rms_mm,
            p.out_of_space_max_mm,
            p.clamped_start,
            p.clamped_step1,
            p.flipped_triangles,
            p.degenerate_triangles
        );
        let ms = |d: Duration| d.as_secs_f64() * 1e3;
        let t = &self.timings;
        let _ = writeln!(
            out,
            "time: start {:.1} ms, step 1 {:.1} ms, step 2 {:.1} ms, total {:.1} ms ({:?} start)",
            ms(t.start),
            ms(t.step1),
            ms(t.step2),
            ms(t.total),
            self.start_method
        );
        for w in &self.warnings {
            let _ = writeln!(out, "warning: {w}");
        }
        out
    }
}

/// A predicted body and its report.
#[derive(Debug, Clone)]
pub struct Prediction {
    /// Vertex positions, template order, metres, station frame.
    pub vertices: Vec<Vec3>,
    /// The report.
    pub report: PredictionReport,
}

/// Where a prediction is (see [`PredictProgress`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub enum PredictStage {
    /// Finding the start weights and measuring the start shape.
    Start,
    /// Step 1 (over the weights), round `run` (0-based) of `of` (`run >= of`:
    /// a continuation round, see [`Continuation`]).
    Step1 {
        /// Round, 0-based.
        run: usize,
        /// Number of rounds (the settings' `s`).
        of: usize,
    },
    /// Step 2 (over the vertices), round `run` (0-based) of `of` (`run >= of`:
    /// a continuation round).
    Step2 {
        /// Round, 0-based.
        run: usize,
        /// Number of rounds (the settings' `s`).
        of: usize,
    },
    /// The body is ready (the report is being finished).
    Done,
}

impl std::fmt::Display for PredictStage {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Self::Start => write!(f, "start"),
            Self::Step1 { run, of } if run >= of => {
                write!(f, "step 1, extra round {}", run - of + 1)
            }
            Self::Step2 { run, of } if run >= of => {
                write!(f, "step 2, extra round {}", run - of + 1)
            }
            Self::Step1 { run, of } => write!(f, "step 1, round {} of {of}", run + 1),
            Self::Step2 { run, of } => write!(f, "step 2, round {} of {of}", run + 1),
            Self::Done => write!(f, "done"),
        }
    }
}

/// One progress report of a prediction.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct PredictProgress {
    /// The stage.
    pub stage: PredictStage,
    /// Objective evaluations so far in the current L-BFGS run (0 at a stage
    /// boundary). An L-BFGS iteration takes one or a few evaluations.
    pub evaluations: u64,
    /// The iteration cap of the current run (the settings' `max_iters`).
    pub max_iterations: u64,
}

/// Share of the whole prediction at which each stage begins: start, step 1,
/// step 2, end. From measured stage times (start 3 ms, step 1 17 ms, step 2
/// 220 ms: `docs/results/predict-bench.md`), so a progress bar moves evenly.
const STAGE_SHARES: [f64; 4] = [0.0, 0.02, 0.10, 1.0];

impl PredictProgress {
    /// An estimate of the share of the prediction done, in `[0, 1]`:
    /// non-decreasing over the reports of one prediction, 1 at
    /// [`PredictStage::Done`]. A run's share grows with its evaluations
    /// (expected about 1.3 per iteration) and stays below the next run's.
    pub fn fraction(&self) -> f64 {
        let within = |evals: u64| -> f64 {
            let expected = 1.3 * self.max_iterations.max(1) as f64;
            (evals as f64 / expected).min(0.95)
        };
        let (lo, hi, run, of) = match self.stage {
            PredictStage::Start => return 0.0,
            PredictStage::Done => return 1.0,
            PredictStage::Step1 { run, of } => (STAGE_SHARES[1], STAGE_SHARES[2], run, of),
            PredictStage::Step2 { run, of } => (STAGE_SHARES[2], STAGE_SHARES[3], run, of),
        };
        let of = of.max(1);
        // Rounds beyond `of` (continuation) stay at the last round's cap, so
        // the fraction never goes back.
        let done = if run >= of {
            (of as f64 - 1.0 + within(u64::MAX)) / of as f64
        } else {
            (run as f64 + within(self.evaluations)) / of as f64
        };
        lo + (hi - lo) * done
    }
}

/// What an observer asks the prediction to do next.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Control {
    /// Go on.
    Continue,
    /// Stop as soon as possible; the prediction returns [`ModelError::Cancelled`].
    Cancel,
}

/// Watches a prediction: called at each stage boundary and every
/// [`OBSERVE_EVERY`] objective evaluations inside the optimisers, on the
/// thread that runs the prediction. Keep it cheap (set a flag, send on a
/// channel). Any `Fn(&PredictProgress) -> Control` is an observer.
pub trait PredictObserver {
    /// Takes a progress report; returns whether to go on.
    fn observe(&self, progress: &PredictProgress) -> Control;
}

impl<F: Fn(&PredictProgress) -> Control> PredictObserver for F {
    fn observe(&self, progress: &PredictProgress) -> Control {
        self(progress)
    }
}

/// Inside an L-BFGS run the observer is called on the first evaluation and
/// then every this many (an evaluation of step 2 takes about 1-2 ms).
pub const OBSERVE_EVERY: u64 = 10;

/// An objective that reports progress and, once cancelled, returns NaN so
/// the solver ends the run (see the module docs).
struct Watched<'a> {
    inner: &'a dyn Objective,
    observer: &'a dyn PredictObserver,
    stage: PredictStage,
    max_iterations: u64,
    evaluations: Cell<u64>,
    cancelled: Cell<bool>,
}

impl<'a> Watched<'a> {
    fn new(
        inner: &'a dyn Objective,
        observer: &'a dyn PredictObserver,
        stage: PredictStage,
        max_iterations: u64,
    ) -> Self {
        Self {
            inner,
            observer,
            stage,
            max_iterations,
            evaluations: Cell::new(0),
            cancelled: Cell::new(false),
        }
    }
}

impl Objective for Watched<'_> {
    fn eval(&self, x: &[f64], grad: &mut [f64]) -> f64 {
        if self.cancelled.get() {
            grad.fill(f64::NAN);
            return f64::NAN;
        }
        let n = self.evaluations.get();
        self.evaluations.set(n + 1);
        if n.is_multiple_of(OBSERVE_EVERY) {
            let p = PredictProgress {
                stage: self.stage,
                evaluations: n,
                max_iterations: self.max_iterations,
            };
            if self.observer.observe(&p) == Control::Cancel {
                self.cancelled.set(true);
                grad.fill(f64::NAN);
                return f64::NAN;
            }
        }
        self.inner.eval(x, grad)
    }
}

/// Reports a stage boundary; `Err(Cancelled)` if the observer cancels.
fn boundary(
    observer: &dyn PredictObserver,
    stage: PredictStage,
    max_iterations: u64,
) -> Result<()> {
    let p = PredictProgress {
        stage,
        evaluations: 0,
        max_iterations,
    };
    match observer.observe(&p) {
        Control::Continue => Ok(()),
        Control::Cancel => Err(ModelError::Cancelled(stage.to_string())),
    }
}

/// The observer of [`ShapeModel::predict`]: never cancels.
fn no_observer(_: &PredictProgress) -> Control {
    Control::Continue
}

struct Given {
    index: usize,
    target_mm: f64,
    weight: f64,
}

fn to_mm(x: &[Vec3]) -> Vec<Vec3> {
    x.iter()
        .map(|v| [v[0] * MM_PER_M, v[1] * MM_PER_M, v[2] * MM_PER_M])
        .collect()
}

fn to_m(x: &[Vec3]) -> Vec<Vec3> {
    x.iter()
        .map(|v| [v[0] / MM_PER_M, v[1] / MM_PER_M, v[2] / MM_PER_M])
        .collect()
}

/// Per given reading, the error (mm) above which a continuation round runs:
/// `share` times its allowable error, at least its own tolerance. Empty
/// without continuation.
fn continuation_thresholds(
    given: &[Given],
    targets: &[Option<Target>],
    measurer: &dyn Measurer,
    cont: Option<Continuation>,
) -> Vec<f64> {
    let Some(c) = cont else {
        return Vec::new();
    };
    given
        .iter()
        .map(|g| {
            let allowable = measurer
                .allowable_error(g.index)
                .map_or(c.default_allowable_mm, |a| a * MM_PER_M);
            let tol = targets[g.index]
                .and_then(|t| t.tolerance)
                .map_or(0.0, |t| t * MM_PER_M);
            (c.share * allowable).max(tol)
        })
        .collect()
}

/// Summed excess (mm) of the readings' errors over their thresholds.
fn excess_mm(given: &[Given], measured: &[Measured], thresholds: &[f64]) -> f64 {
    given
        .iter()
        .zip(measured)
        .zip(thresholds)
        .map(|((g, m), t)| ((m.value * MM_PER_M - g.target_mm).abs() - t).max(0.0))
        .sum()
}

/// The MAP objective of [`crate::map`] on real measured values:
/// `sum_j ((m_j - T_j) / sd_j)^2 + |w|^2` (`sd` per given reading, mm).
fn map_objective(given: &[Given], measured: &[Measured], sd: &[f64], w: &[f64]) -> f64 {
    given
        .iter()
        .zip(measured)
        .zip(sd)
        .map(|((g, m), s)| ((m.value * MM_PER_M - g.target_mm) / s).powi(2))
        .sum::<f64>()
        + w.iter().map(|x| x * x).sum::<f64>()
}

fn clamp(w: &mut [f64], l: f64) -> Vec<usize> {
    let mut clamped = Vec::new();
    for (k, x) in w.iter_mut().enumerate() {
        if x.abs() > l {
            *x = x.clamp(-l, l);
            clamped.push(k);
        }
    }
    clamped
}

/// Standard normal CDF via erfc (Abramowitz & Stegun 7.1.26, |error| < 1.5e-7;
/// std has no erf and the plausibility label needs no more).
fn normal_cdf(z: f64) -> f64 {
    let x = z.abs() / std::f64::consts::SQRT_2;
    let t = 1.0 / (1.0 + 0.3275911 * x);
    let poly = t
        * (0.254829592
            + t * (-0.284496736 + t * (1.421413741 + t * (-1.453152027 + t * 1.061405429))));
    let erfc = poly * (-x * x).exp();
    if z >= 0.0 {
        1.0 - 0.5 * erfc
    } else {
        0.5 * erfc
    }
}

/// Chi-square CDF of `x` with `k` degrees of freedom, Wilson-Hilferty
/// approximation (`(x/k)^(1/3)` is nearly normal); about 1e-3 accurate, enough
/// for a three-way plausibility label.
pub fn chi2_quantile(x: f64, k: usize) -> f64 {
    if k == 0 {
        return 0.0;
    }
    if x <= 0.0 {
        return 0.0;
    }
    let k = k as f64;
    let v = 2.0 / (9.0 * k);
    normal_cdf(((x / k).cbrt() - (1.0 - v)) / v.sqrt())
}

impl ShapeModel {
    fn check_targets(
        &self,
        targets: &[Option<Target>],
        settings: &PredictSettings,
    ) -> Result<Vec<Given>> {
        let m = self.n_measurements();
        if targets.len() != m {
            return Err(ModelError::InvalidInput(format!(
                "{} targets given, the model has {m} measurements ({})",
                targets.len(),
                self.measurement_names.join(", ")
            )));
        }
        if !(settings.l.is_finite() && settings.l > 0.0) {
            return Err(ModelError::InvalidInput(format!(
                "l must be positive, got {}",
                settings.l
            )));
        }
        if !(0.0..=1.0).contains(&settings.lambda) {
            return Err(ModelError::InvalidInput(format!(
                "lambda must lie in [0, 1], got {}",
                settings.lambda
            )));
        }
        if !(settings.reference_tolerance.is_finite() && settings.reference_tolerance > 0.0) {
            return Err(ModelError::InvalidInput(
                "reference_tolerance must be positive (metres)".into(),
            ));
        }
        let mut given = Vec::new();
        for (j, t) in targets.iter().enumerate() {
            let Some(t) = t else { continue };
            let name = &self.measurement_names[j];
            if !(t.value.is_finite() && t.value > 0.0) {
                return Err(ModelError::InvalidInput(format!(
                    "target '{name}' is {}: a length in metres must be positive and finite",
                    t.value
                )));
            }
            if t.value > 5.0 {
                return Err(ModelError::InvalidInput(format!(
                    "target '{name}' is {} m, more than any body length: targets are metres (was it given in mm or cm?)",
                    t.value
                )));
            }
            let weight = match t.tolerance {
                None => 1.0,
                Some(tol) if tol.is_finite() && tol > 0.0 => {
                    (settings.reference_tolerance / tol).powi(2)
                }
                Some(tol) => {
                    return Err(ModelError::InvalidInput(format!(
                        "tolerance of '{name}' is {tol}: it must be positive and finite (metres)"
                    )))
                }
            };
            given.push(Given {
                index: j,
                target_mm: t.value * MM_PER_M,
                weight,
            });
        }
        if given.is_empty() {
            return Err(ModelError::InvalidInput(
                "no measurements given: at least one target is needed to predict a body".into(),
            ));
        }
        Ok(given)
    }

    fn measure_checked(
        &self,
        measurer: &dyn Measurer,
        x: &[Vec3],
        which: &[usize],
    ) -> Result<Vec<Measured>> {
        let out = measurer
            .measure(x, which)
            .map_err(|e| ModelError::Measure(e.to_string()))?;
        if out.len() != which.len() {
            return Err(ModelError::Measure(format!(
                "asked for {} measurements, got {}",
                which.len(),
                out.len()
            )));
        }
        let v = x.len() as u32;
        for (m, &j) in out.iter().zip(which) {
            let name = &self.measurement_names[j];
            let s = &m.support;
            let bad_point = s
                .points
                .iter()
                .any(|p| p.a >= v || p.b >= v || !(0.0..=1.0).contains(&p.t));
            let bad_seg = s
                .segments
                .iter()
                .any(|g| g[0] as usize >= s.points.len() || g[1] as usize >= s.points.len());
            let bad_axis = s.axis.is_some_and(|n| n.iter().any(|c| !c.is_finite()));
            if bad_point || bad_seg || bad_axis || !m.value.is_finite() {
                return Err(ModelError::Measure(format!(
                    "measurement '{name}' returned an invalid support or value"
                )));
            }
        }
        Ok(out)
    }

    #[allow(clippy::too_many_arguments)]
    fn build_terms(
        &self,
        given: &[Given],
        measured: &[Measured],
        x_mm: &[Vec3],
        weighting: (EnergyWeighting, f64),
        warnings: &mut Vec<String>,
        stage: &str,
    ) -> Vec<SegmentTerm> {
        self.build_terms_owned(given, measured, x_mm, weighting, warnings, stage)
            .0
    }

    /// [`Self::build_terms`], also returning for each term the position in
    /// `given` of the reading it belongs to.
    fn build_terms_owned(
        &self,
        given: &[Given],
        measured: &[Measured],
        x_mm: &[Vec3],
        weighting: (EnergyWeighting, f64),
        warnings: &mut Vec<String>,
        stage: &str,
    ) -> (Vec<SegmentTerm>, Vec<usize>) {
        let (weighting, scale) = weighting;
        let mut terms = Vec::new();
        let mut owner = Vec::new();
        for (pos, (g, m)) in given.iter().zip(measured).enumerate() {
            match segment_terms(&m.support, x_mm, g.target_mm, g.weight) {
                Some(mut t) => {
                    if weighting == EnergyWeighting::PerMeasurement {
                        // sum_e (l_e^2 - lt_e^2)^2 ~ 4 sum_e lt_e^2 (l_e - lt_e)^2 and a
                        // change D of the whole measurement moves each segment by
                        // lt_e D / L_t: the energy is ~ 4 D^2 sum_e lt_e^4 / L_t^2.
                        let l4: f64 = t.iter().map(|s| s.target_sq * s.target_sq).sum();
                        if l4 > 0.0 && l4.is_finite() {
                            let c = scale * g.target_mm * g.target_mm / (4.0 * l4);
                            t.iter_mut().for_each(|s| s.weight *= c);
                        }
                    }
                    owner.extend(std::iter::repeat_n(pos, t.len()));
                    terms.extend(t)
                }
                None => warnings.push(format!(
                    "{stage}: measurement '{}' has zero length on the current shape and was left out of this round",
                    self.measurement_names[g.index]
                )),
            }
        }
        (terms, owner)
    }

    /// `E_m` of a shape with its per-segment targets set on that shape (the
    /// energy a round starts from): the paper's objective, evaluated the same
    /// way at every stage, so stages can be compared.
    fn stage_energy(
        &self,
        given: &[Given],
        measured: &[Measured],
        x: &[Vec3],
        weighting: (EnergyWeighting, f64),
    ) -> f64 {
        let x_mm = to_mm(x);
        let mut ignored = Vec::new();
        let terms = self.build_terms(given, measured, &x_mm, weighting, &mut ignored, "");
        measurement_energy(&terms, x_mm.as_flattened(), None)
    }

    /// Step-1 objective over the vertices the terms touch.
    fn localise(&self, terms: &[SegmentTerm]) -> WeightObjective {
        let (local_terms, rows, base) = self.local_basis(terms);
        WeightObjective::new(self.pca.n_components, &rows, &base, local_terms)
    }

    /// The terms re-indexed to the vertices they touch, with those vertices'
    /// scaled basis rows ((3 n_local) x K, mm per unit weight) and mean
    /// positions (flat, mm).
    fn local_basis(&self, terms: &[SegmentTerm]) -> (Vec<SegmentTerm>, Vec<f64>, Vec<f64>) {
        let k = self.pca.n_components;
        let mut local = vec![u32::MAX; self.n_vertices()];
        let mut globals: Vec<u32> = Vec::new();
        let mut map = |v: u32| -> u32 {
            if local[v as usize] == u32::MAX {
                local[v as usize] = globals.len() as u32;
                globals.push(v);
            }
            local[v as usize]
        };
        let mut local_terms = terms.to_vec();
        for t in &mut local_terms {
            for p in [&mut t.p0, &mut t.p1] {
                p.a = map(p.a);
                p.b = map(p.b);
            }
        }
        let mut rows = Vec::with_capacity(globals.len() * 3 * k);
        let mut base = Vec::with_capacity(3 * globals.len());
        for &g in &globals {
            let g = g as usize;
            for c in 0..3 {
                let r = 3 * g + c;
                rows.extend(
                    self.pca.basis[r * k..(r + 1) * k]
                        .iter()
                        .zip(&self.pca.sigma)
                        .map(|(a, s)| a * s * MM_PER_M),
                );
            }
            base.extend((0..3).map(|c| self.pca.mean[3 * g + c] * MM_PER_M));
        }
        (local_terms, rows, base)
    }

    /// Mahalanobis distance of the given readings under the training
    /// Gaussian of the measurements, with each reading's own uncertainty
    /// (its tolerance, else the reference tolerance) added as noise: a tape
    /// reading is never more exact than that, and without it nearly collinear
    /// measurements (left/right pairs) make every small asymmetry look
    /// implausible.
    fn measurement_mahalanobis(&self, given: &[Given], settings: &PredictSettings) -> Result<f64> {
        let idx: Vec<usize> = given.iter().map(|g| g.index).collect();
        let val: Vec<f64> = given.iter().map(|g| g.target_mm / MM_PER_M).collect();
        // weight = (reference / tolerance)^2, so tolerance^2 = reference^2 / weight.
        let noise: Vec<f64> = given
            .iter()
            .map(|g| settings.reference_tolerance.powi(2) / g.weight)
            .collect();
        self.joint.mahalanobis(&idx, &val, &noise)
    }

    /// Estimates a body from `targets` (one entry per model measurement, `None`
    /// where not given; metres) with the paper's method.
    ///
    /// `measurer` measures meshes with the model's measurement set (same order);
    /// `topology` is the template's (V vertices). Returns the mesh (metres,
    /// station frame) and a report of every stage.
    ///
    /// Errors on bad input (wrong counts, non-positive or non-finite targets,
    /// targets that look like millimetres, no target at all), on a measurer
    /// failure, and if the result is not finite. An implausible but possible
    /// set of measurements gives a result with warnings and its plausibility.
    pub fn predict(
        &self,
        targets: &[Option<Target>],
        measurer: &dyn Measurer,
        topology: &Topology,
        settings: &PredictSettings,
    ) -> Result<Prediction> {
        self.predict_observed(targets, measurer, topology, settings, &no_observer)
    }

    /// [`ShapeModel::predict`] with progress reports and cancelling: the
    /// `observer` is called at every stage boundary and now and then inside
    /// the L-BFGS runs (see the module docs). If it answers
    /// [`Control::Cancel`], returns [`ModelError::Cancelled`] (naming the
    /// stage) as soon as the current objective evaluation ends.
    pub fn predict_observed(
        &self,
        targets: &[Option<Target>],
        measurer: &dyn Measurer,
        topology: &Topology,
        settings: &PredictSettings,
        observer: &dyn PredictObserver,
    ) -> Result<Prediction> {
        let t_total = Instant::now();
        let v = self.n_vertices();
        if topology.n_vertices() != v {
            return Err(ModelError::InvalidInput(format!(
                "topology has {} vertices, the model {v}",
                topology.n_vertices()
            )));
        }
        if measurer.n_measurements() != self.n_measurements() {
            return Err(ModelError::InvalidInput(format!(
                "the measurer has {} measurements, the model {}: use the set the model was trained with",
                measurer.n_measurements(),
                self.n_measurements()
            )));
        }
        let given = self.check_targets(targets, settings)?;
        let which: Vec<usize> = given.iter().map(|g| g.index).collect();
        let mut warnings = Vec::new();

        // Start.
        boundary(observer, PredictStage::Start, 0)?;
        let t0 = Instant::now();
        let start_method = if given.len() == self.n_measurements()
            && given
                .iter()
                .all(|g| targets[g.index].is_some_and(|t| t.tolerance.is_none()))
        {
            StartMethod::FeatureAnalysis
        } else {
            StartMethod::Conditional
        };
        let observed: Vec<(usize, f64, f64)> = given
            .iter()
            .map(|g| {
                let tol = match start_method {
                    StartMethod::FeatureAnalysis => 0.0,
                    StartMethod::Conditional => {
                        targets[g.index].and_then(|t| t.tolerance).unwrap_or(0.0)
                    }
                };
                (g.index, g.target_mm / MM_PER_M, tol)
            })
            .collect();
        let mut w_start = self.start_weights(&observed)?;
        if w_start.iter().any(|x| !x.is_finite()) {
            return Err(ModelError::NonFinite("start weights".into()));
        }
        let clamped_start = clamp(&mut w_start, settings.l);
        let x_start = self.shape_unchecked(&w_start);
        let meas_start = self.measure_checked(measurer, &x_start, &which)?;
        let time_start = t0.elapsed();

        // Step 1: over the weights.
        let t1 = Instant::now();
        let mut step1_runs = Vec::new();
        let mut w = w_start.clone();
        let cont = settings.continuation.filter(|_| settings.s > 0);
        let rounds = settings.s + cont.map_or(0, |c| c.max_extra_rounds);
        let thresholds = continuation_thresholds(&given, targets, measurer, cont);
        let prior = settings.step1_prior_mm.or_else(|| {
            // Readings with a tolerance only give way to the others if
            // something pulls the other way: the training Gaussian (MAP).
            (settings.step1_weighting == EnergyWeighting::PerMeasurement
                && given
                    .iter()
                    .any(|g| targets[g.index].is_some_and(|t| t.tolerance.is_some())))
            .then_some(settings.reference_tolerance * MM_PER_M)
        });
        // Reading noise (mm) of the Gauss-Newton MAP: tau scaled by each
        // reading's tolerance (weight = (reference / tolerance)^2).
        let map_tau = settings
            .step1_prior_mm
            .unwrap_or(settings.reference_tolerance * MM_PER_M);
        let map_sd: Vec<f64> = given.iter().map(|g| map_tau / g.weight.sqrt()).collect();
        let mut held = vec![false; self.n_components()];
        if let Some(k) = settings.step1_components {
            held.iter_mut().skip(k).for_each(|h| *h = true);
        }
        let mut last_excess = f64::INFINITY;
        for round in 0..rounds {
            let stage = PredictStage::Step1 {
                run: round,
                of: settings.s,
            };
            if round < settings.s {
                boundary(observer, stage, settings.stop.max_iters)?;
            }
            if settings.step1_box && round > 0 {
                for (i, x) in w.iter_mut().enumerate() {
                    if x.abs() > settings.l {
                        *x = x.clamp(-settings.l, settings.l);
                        held[i] = true;
                    }
                }
            }
            let (x, meas);
            let (x_ref, meas_ref) = if round == 0 {
                (&x_start, &meas_start)
            } else {
                x = self.shape_unchecked(&w);
                meas = self.measure_checked(measurer, &x, &which)?;
                (&x, &meas)
            };
            if let Some(c) = cont {
                let excess = excess_mm(&given, meas_ref, &thresholds);
                // After Gauss-Newton rounds the first continuation round
                // switches method, so the last rounds' progress says nothing.
                let switched = settings.step1_gauss_newton && round == settings.s;
                if round >= settings.s {
                    if excess == 0.0
                        || (excess > 0.95 * last_excess && !switched)
                        || t1.elapsed().as_secs_f64() > c.time_budget_s
                    {
                        break;
                    }
                    boundary(observer, stage, settings.stop.max_iters)?;
                }
                last_excess = excess;
            }
            // Gauss-Newton in the s regular rounds; continuation rounds (a
            // reading still misses, typically where a support changes too
            // much under the step for the linearisation to hold) are L-BFGS
            // rounds on E_m with the same prior.
            let (terms, owner) = self.build_terms_owned(
                &given,
                meas_ref,
                &to_mm(x_ref),
                (settings.step1_weighting, 1.0),
                &mut warnings,
                "step 1",
            );
            if terms.is_empty() {
                break;
            }
            if settings.step1_gauss_newton && round < settings.s {
                if observer.observe(&PredictProgress {
                    stage,
                    evaluations: 0,
                    max_iterations: settings.stop.max_iters,
                }) == Control::Cancel
                {
                    return Err(ModelError::Cancelled(stage.to_string()));
                }
                let (local, rows, base) = self.local_basis(&terms);
                let problem = MapProblem::new(
                    self.pca.n_components,
                    &rows,
                    &base,
                    &local,
                    owner,
                    given.iter().map(|g| g.target_mm).collect(),
                    map_sd.clone(),
                );
                let (w_gn, run) = problem.solve(&w, &held, settings.stop.max_iters as usize, 1e-12);
                // The solve holds this round's supports fixed; where a support
                // changes under the step (a hull gains or loses points, a
                // landmark plane moves), the real values differ from the
                // linearised ones. Backtrack on the real (re-measured) objective.
                let real = |meas: &[Measured], w: &[f64]| -> f64 {
                    map_objective(&given, meas, &map_sd, w)
                };
                let f_here = real(meas_ref, &w);
                let mut alpha = 1.0;
                let mut lowered = true;
                let mut measures = 0u64;
                loop {
                    let trial: Vec<f64> = w
                        .iter()
                        .zip(&w_gn)
                        .map(|(a, b)| a + alpha * (b - a))
                        .collect();
                    let m_trial =
                        self.measure_checked(measurer, &self.shape_unchecked(&trial), &which)?;
                    measures += 1;
                    if real(&m_trial, &trial) < f_here {
                        w = trial;
                        break;
                    }
                    alpha *= 0.5;
                    if alpha < 1.0 / 64.0 {
                        lowered = false;
                        break;
                    }
                }
                step1_runs.push(RunInfo {
                    iterations: run.iterations as u64,
                    evaluations: run.iterations as u64 + measures,
                    cost_start: run.objective.0,
                    cost_end: run.objective.1,
                    reason: if lowered {
                        format!("Gauss-Newton MAP, step {alpha}")
                    } else {
                        "Gauss-Newton MAP: no step lowered the re-measured objective; L-BFGS on E_m this round".into()
                    },
                });
                if lowered {
                    continue;
                }
            }
            let mut obj = self.localise(&terms);
            // After Gauss-Newton MAP rounds, the L-BFGS rounds keep the
            // same prior (without it they would undo its shrinkage).
            let prior_here = if settings.step1_gauss_newton {
                Some(prior.unwrap_or(settings.reference_tolerance * MM_PER_M))
            } else {
                prior
            };
            if let Some(tau) = prior_here {
                obj = obj.with_prior(tau * tau);
            }
            if held.iter().any(|&h| h) {
                obj = obj.with_held(held.clone());
            }
            let watched = Watched::new(&obj, observer, stage, settings.stop.max_iters);
            let run = minimise(&watched, w.clone(), &settings.stop, settings.step1_solver);
            if watched.cancelled.get() {
                return Err(ModelError::Cancelled(stage.to_string()));
            }
            match run {
                Ok((w_new, info)) => {
                    w = w_new;
                    step1_runs.push(info);
                }
                Err(e) => {
                    warnings.push(format!("step 1 round {round}: optimiser stopped: {e}"));
                    break;
                }
            }
        }
        let clamped_step1 = clamp(&mut w, settings.l);
        let mut x1 = self.shape_unchecked(&w);
        let mut meas1 = self.measure_checked(measurer, &x1, &which)?;
        // The Gauss-Newton step 1 minimises its own objective, not E_m with
        // per-segment targets, so it is judged by that objective.
        let (err_start, err1, what) = if settings.step1_gauss_newton {
            let f = |meas: &[Measured], w: &[f64]| map_objective(&given, meas, &map_sd, w);
            (f(&meas_start, &w_start), f(&meas1, &w), "MAP objective")
        } else {
            (
                self.stage_energy(
                    &given,
                    &meas_start,
                    &x_start,
                    (settings.step1_weighting, 1.0),
                ),
                self.stage_energy(&given, &meas1, &x1, (settings.step1_weighting, 1.0)),
                "measurement energy E_m (mm^4)",
            )
        };
        if err1 > err_start || err1.is_nan() {
            warnings.push(format!(
                "step 1 ended with a higher {what} than the start ({err1:.4e} vs {err_start:.4e}): kept the start shape"
            ));
            w = w_start.clone();
            x1 = x_start.clone();
            meas1 = meas_start.clone();
        }
        let w_step1 = w;
        let time_step1 = t1.elapsed();

        // Step 2: over the vertices. A reading with a tolerance wider than
        // the reference was weighed against the prior and the other readings
        // in step 1; step 2 keeps the value step 1 gave it (as a target)
        // instead of bending the surface towards the doubtful reading, which
        // step 2's strong per-measurement weight would otherwise do.
        let given2: Vec<Given> = given
            .iter()
            .zip(&meas1)
            .map(|(g, m)| Given {
                index: g.index,
                target_mm: if g.weight < 1.0 {
                    m.value * MM_PER_M
                } else {
                    g.target_mm
                },
                weight: g.weight,
            })
            .collect();
        let t2 = Instant::now();
        let mut step2_runs = Vec::new();
        let reference_mm = to_mm(&x1);
        let mut x_mm: Vec<f64> = reference_mm.as_flattened().to_vec();
        let mut last_excess = f64::INFINITY;
        for round in 0..rounds {
            let stage = PredictStage::Step2 {
                run: round,
                of: settings.s,
            };
            if round < settings.s {
                boundary(observer, stage, settings.step2_stop.max_iters)?;
            }
            let p_mm: Vec<Vec3> = x_mm.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect();
            let meas;
            let meas_ref = if round == 0 {
                &meas1
            } else {
                meas = self.measure_checked(measurer, &to_m(&p_mm), &which)?;
                &meas
            };
            if let Some(c) = cont {
                let excess = excess_mm(&given2, meas_ref, &thresholds);
                if round >= settings.s {
                    if excess == 0.0
                        || excess > 0.95 * last_excess
                        || t2.elapsed().as_secs_f64() > c.time_budget_s
                    {
                        break;
                    }
                    boundary(observer, stage, settings.step2_stop.max_iters)?;
                }
                last_excess = excess;
            }
            let terms = self.build_terms(
                &given2,
                meas_ref,
                &p_mm,
                settings.step2_terms(),
                &mut warnings,
                "step 2",
            );
            if terms.is_empty() {
                break;
            }
            let obj = VertexObjective::new(
                terms,
                topology.edges(),
                reference_mm.as_flattened(),
                settings.lambda,
            );
            let watched = Watched::new(&obj, observer, stage, settings.step2_stop.max_iters);
            let run = minimise(
                &watched,
                x_mm.clone(),
                &settings.step2_stop,
                settings.step2_solver,
            );
            if watched.cancelled.get() {
                return Err(ModelError::Cancelled(stage.to_string()));
            }
            match run {
                Ok((x_new, info)) => {
                    x_mm = x_new;
                    step2_runs.push(info);
                }
                Err(e) => {
                    warnings.push(format!("step 2 round {round}: optimiser stopped: {e}"));
                    break;
                }
            }
        }
        let mut x2: Vec<Vec3> = x_mm
            .chunks_exact(3)
            .map(|c| [c[0] / MM_PER_M, c[1] / MM_PER_M, c[2] / MM_PER_M])
            .collect();
        if x2.iter().flatten().any(|c| !c.is_finite()) {
            return Err(ModelError::NonFinite(
                "step 2 produced a non-finite mesh".into(),
            ));
        }
        let mut meas2 = self.measure_checked(measurer, &x2, &which)?;
        let err2 = self.stage_energy(&given2, &meas2, &x2, settings.step2_terms());
        let err1 = self.stage_energy(&given2, &meas1, &x1, settings.step2_terms());
        if err2 > err1 || err2.is_nan() {
            warnings.push(format!(
                "step 2 ended with a higher measurement energy than step 1 (E_m {err2:.4e} vs {err1:.4e} mm^4): kept the step-1 shape"
            ));
            x2 = x1.clone();
            meas2 = meas1.clone();
        }

        // Report.
        let (flipped, degenerate) = triangle_changes(topology, &x1, &x2);
        if flipped > 0 || degenerate > 0 {
            warnings.push(format!(
                "step 2 flipped {flipped} and collapsed {degenerate} triangles: the measurements may be inconsistent"
            ));
        }
        let back = self.shape_unchecked(&self.pca.project(x2.as_flattened()));
        let mut sum2 = 0.0;
        let mut max_d = 0.0f64;
        for (a, b) in x2.iter().zip(&back) {
            let d2 = (0..3).map(|c| (a[c] - b[c]).powi(2)).sum::<f64>();
            sum2 += d2;
            max_d = max_d.max(d2.sqrt());
        }
        let k = self.n_components();
        let mahalanobis = w_step1.iter().map(|x| x * x).sum::<f64>().sqrt();
        let quantile = chi2_quantile(mahalanobis * mahalanobis, k);
        let meas_maha = self.measurement_mahalanobis(&given, settings)?;
        let meas_q = chi2_quantile(meas_maha * meas_maha, given.len());
        let meas_label =
            PlausibilityLabel::from_quantile(if meas_q.is_finite() { meas_q } else { 1.0 });
        if meas_label == PlausibilityLabel::Implausible {
            warnings.push(format!(
                "the measurements are far from the training population (Mahalanobis distance {meas_maha:.1} over {} measurements): the shape is held to {} SD and may not fit them all",
                given.len(),
                settings.l
            ));
        }
        let plausibility = Plausibility {
            mahalanobis,
            quantile,
            label: PlausibilityLabel::from_quantile(quantile),
            measurements_mahalanobis: meas_maha,
            measurements_quantile: meas_q,
            measurements_label: meas_label,
            out_of_space_rms_mm: (sum2 / v as f64).sqrt() * MM_PER_M,
            out_of_space_max_mm: max_d * MM_PER_M,
            clamped_start,
            clamped_step1,
            flipped_triangles: flipped,
            degenerate_triangles: degenerate,
        };
        let mut reports: Vec<MeasurementReport> = self
            .measurement_names
            .iter()
            .enumerate()
            .map(|(j, name)| MeasurementReport {
                name: name.clone(),
                target_mm: targets[j].map(|t| t.value * MM_PER_M),
                tolerance_mm: targets[j].and_then(|t| t.tolerance).map(|t| t * MM_PER_M),
                start_mm: None,
                step1_mm: None,
                step2_mm: None,
                error_mm: None,
            })
            .collect();
        for (i, g) in given.iter().enumerate() {
            let r = &mut reports[g.index];
            r.start_mm = Some(meas_start[i].value * MM_PER_M);
            r.step1_mm = Some(meas1[i].value * MM_PER_M);
            let v2 = meas2[i].value * MM_PER_M;
            r.step2_mm = Some(v2);
            let err = (v2 - g.target_mm).abs();
            r.error_mm = Some(err);
            if err > settings.warn_error_mm {
                warnings.push(format!(
                    "'{}' could not be fitted within {} mm (error {err:.1} mm)",
                    r.name, settings.warn_error_mm
                ));
            }
        }
        let missing: Vec<usize> = (0..self.n_measurements())
            .filter(|j| targets[*j].is_none())
            .collect();
        if !missing.is_empty() {
            match self.measure_checked(measurer, &x2, &missing) {
                Ok(ms) => {
                    for (m, &j) in ms.iter().zip(&missing) {
                        reports[j].step2_mm = Some(m.value * MM_PER_M);
                    }
                }
                Err(e) => {
                    warnings.push(format!("measuring the measurements not given failed: {e}"))
                }
            }
        }
        let time_step2 = t2.elapsed();
        // Reported last, so an observer's fraction reaches 1; too late to
        // cancel (the body is ready), so the answer is ignored.
        let _ = observer.observe(&PredictProgress {
            stage: PredictStage::Done,
            evaluations: 0,
            max_iterations: 0,
        });
        Ok(Prediction {
            vertices: x2,
            report: PredictionReport {
                start_method,
                weights_start: w_start,
                weights_step1: w_step1,
                measurements: reports,
                plausibility,
                timings: StageTimings {
                    start: time_start,
                    step1: time_step1,
                    step2: time_step2,
                    total: t_total.elapsed(),
                },
                step1_runs,
                step2_runs,
                warnings,
                settings: settings.clone(),
            },
        })
    }
}

/// Counts triangles of `after` whose normal turned by more than 90 degrees
/// from `before` (flipped) or whose area fell below 1% of it (degenerate).
pub fn triangle_changes(topology: &Topology, before: &[Vec3], after: &[Vec3]) -> (usize, usize) {
    let normal = |p: &[Vec3], f: &[u32; 3]| {
        let (a, b, c) = (p[f[0] as usize], p[f[1] as usize], p[f[2] as usize]);
        let u = [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
        let w = [c[0] - a[0], c[1] - a[1], c[2] - a[2]];
        [
            u[1] * w[2] - u[2] * w[1],
            u[2] * w[0] - u[0] * w[2],
            u[0] * w[1] - u[1] * w[0],
        ]
    };
    let (mut flipped, mut degenerate) = (0, 0);
    for f in topology.faces() {
        let (n0, n1) = (normal(before, f), normal(after, f));
        let dot = n0[0] * n1[0] + n0[1] * n1[1] + n0[2] * n1[2];
        let (a0, a1) = (
            (n0[0] * n0[0] + n0[1] * n0[1] + n0[2] * n0[2]).sqrt(),
            (n1[0] * n1[0] + n1[1] * n1[1] + n1[2] * n1[2]).sqrt(),
        );
        if dot < 0.0 {
            flipped += 1;
        } else if a1 < 0.01 * a0 {
            degenerate += 1;
        }
    }
    (flipped, degenerate)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn chi2_quantile_is_close_to_known_values() {
        // chi2(0.95, 10) = 18.307, chi2(0.999, 30) = 59.703, chi2(0.5, 50) = 49.335.
        assert!((chi2_quantile(18.307, 10) - 0.95).abs() < 2e-3);
        assert!((chi2_quantile(59.703, 30) - 0.999).abs() < 1e-3);
        assert!((chi2_quantile(49.335, 50) - 0.5).abs() < 2e-3);
        assert_eq!(
            PlausibilityLabel::from_quantile(0.5),
            PlausibilityLabel::Typical
        );
        assert_eq!(
            PlausibilityLabel::from_quantile(0.99),
            PlausibilityLabel::Unusual
        );
        assert_eq!(
            PlausibilityLabel::from_quantile(0.9999),
            PlausibilityLabel::Implausible
        );
    }

    #[test]
    fn clamp_reports_components() {
        let mut w = vec![0.5, -4.0, 3.5, 3.0];
        assert_eq!(clamp(&mut w, 3.0), vec![1, 2]);
        assert_eq!(w, vec![0.5, -3.0, 3.0, 3.0]);
    }
}
