//! Prediction settings: the record ([`PredictSettings`], serde) and the
//! configuration it resolves into ([`PredictConfig`]), once.
//!
//! Why two levels (ripgrep's low and high arguments): the record is what a
//! report stores and what a command line or experiment fills; every value
//! sits inside the stage, and the variant, it belongs to, so a setting that
//! would be ignored (a reading weight with the paper's step-2 weighting, a
//! Gauss-Newton noise for L-BFGS) cannot be written. [`PredictSettings::resolve`]
//! then checks every value (l > 0, lambda in [0, 1], ...) and resolves every
//! default and cross-stage rule into one typed configuration per stage
//! ([`StartConfig`], [`Step1Config`], [`Step2Config`], [`RoundsConfig`],
//! [`ReportConfig`]); the stages read only their own, and nothing re-derives
//! a setting while predicting.
//!
//! Reports written before this form (one flat record of 18 fields) read
//! back: [`PredictSettings`]' `Deserialize` accepts the old form and
//! converts it (the two L-BFGS implementation switches are dropped: there
//! is one L-BFGS now; the continuation's old wall-clock budget becomes the
//! default evaluation budget).

use serde::{Deserialize, Serialize};

use crate::gauss_newton::GaussNewtonStop;
use crate::lbfgs::{Lbfgs, LineSearch, StopRule};
use crate::MM_PER_M;

/// The settings of a prediction (see the module docs): the paper's `l`
/// and `s`, and one part per stage. [`PredictSettings::paper`] is the
/// paper's method exactly; `Default` is what the station uses.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct PredictSettings {
    /// Clamp every normalised weight to `[-l, l]` (paper: 3 synthetic, 10 real).
    pub l: f64,
    /// Rounds of support recomputation per step (paper: 3). 0 = start only.
    pub s: usize,
    /// A reading with this tolerance (metres) is trusted as an exact one
    /// (energy weight 1; default 1 mm).
    pub reference_tolerance: f64,
    /// Step 1, over the weights.
    pub step1: Step1Settings,
    /// Step 2, over the vertices.
    pub step2: Step2Settings,
    /// More rounds while readings miss their allowable error (see
    /// [`Continuation`]). `None` (the paper): exactly `s` rounds per step.
    pub continuation: Option<Continuation>,
    /// Warn about any given measurement whose final error exceeds this (mm).
    pub warn_error_mm: f64,
}

/// Step 1 (over the K normalised weights).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Step1Settings {
    /// What each of the `s` rounds minimises, and how.
    pub solver: Step1Solver,
    /// How every L-BFGS round of step 1 weights the readings' energies
    /// (all rounds with [`Step1Solver::Lbfgs`]; with
    /// [`Step1Solver::GaussNewtonMap`] its continuation rounds and a round
    /// whose Gauss-Newton step lowered nothing).
    pub weighting: EnergyWeighting,
    /// Where the weights are held to `[-l, l]`.
    pub clamp: Step1Clamp,
    /// `Some(k)`: step 1 moves only the first k PCA components (the rest keep
    /// their start values). `None` (the paper): all.
    pub components: Option<usize>,
    /// L-BFGS stopping rules (paper: 100 iterations, gradient 1e-8, relative
    /// change 1e8 eps; history 7). With Gauss-Newton, `max_iters` also caps
    /// its iterations per round.
    pub stop: StopRule,
}

/// What step 1's rounds minimise.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub enum Step1Solver {
    /// The paper: each round, L-BFGS on `E_m` over the weights.
    Lbfgs {
        /// `Some(tau)`: add the training Gaussian's prior `tau^2 |w|^2` to
        /// `E_m` (a MAP estimate with reading noise tau mm). `None`: the
        /// paper's `E_m` alone, except that with per-measurement weighting a
        /// reading given with a tolerance brings in the prior with the
        /// reference tolerance (else its tolerance would mean nothing once
        /// step 1 converges).
        prior_mm: Option<f64>,
    },
    /// Each of the `s` rounds is the MAP estimate
    /// `sum_j ((m_j - T_j) / sd_j)^2 + |w|^2` solved by Gauss-Newton on the
    /// readings' values with the round's supports held ([`crate::map`]),
    /// each step backtracked on the re-measured objective (a round whose
    /// step lowers nothing runs L-BFGS on `E_m` instead); continuation
    /// rounds run L-BFGS on `E_m` with the same prior.
    GaussNewtonMap {
        /// The reading noise `tau` (mm) of an exact reading; a reading with
        /// a tolerance gets `tau` times its tolerance over the reference
        /// tolerance. `None`: the reference tolerance (1 mm). Measured on 50
        /// held-out bodies: `docs/results/predict-sreal.md`.
        tau_mm: Option<f64>,
        /// A round whose Gauss-Newton solve (supports held) lowers the
        /// objective by at most what an error of this many millimetres on
        /// one exact reading costs, `(min_decrease_mm / tau)^2`, keeps its
        /// weights without measuring the step (0: every step is measured,
        /// what reports older than this field ran). Why: the last of the
        /// `s` rounds mostly finds the previous round's answer again, and
        /// measuring its step (a pass over the basis and every support,
        /// twice where the backtracking halves it) cost more than the
        /// round gained (`docs/results/predict-bench.md`, 2026-12-07).
        #[serde(default)]
        min_decrease_mm: f64,
    },
}

/// Step 1's Gauss-Newton `min_decrease_mm` where not chosen otherwise: the
/// same tenth of a millimetre as step 2's smooth basis
/// ([`DEFAULT_SMOOTH_MIN_DECREASE_MM`]).
pub const DEFAULT_STEP1_MIN_DECREASE_MM: f64 = 0.1;

/// Where step 1 holds the weights to `[-l, l]`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum Step1Clamp {
    /// The paper: one clamp after step 1, which undoes whatever fit the
    /// clamped components carried.
    AfterStep,
    /// Before every round after the first, the weights beyond `l` are
    /// clamped and held there, so the following rounds refit the other
    /// components to the readings (an active-set method); then the clamp
    /// after step 1 as well.
    InsideBox,
}

/// Step 2 (over the vertices).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Step2Settings {
    /// Weight of the smoothness energy, in `[0, 1]` (paper: 0.1).
    pub lambda: f64,
    /// Weight `mu` of the bending term added to the smoothness energy,
    /// `E_s + mu E_b` ([`crate::energy::bending_of_displacement`]); 0 (the
    /// default and the paper): none. The L-BFGS and Gauss-Newton solvers
    /// take it (not the smooth basis).
    /// Why: with many readings that the learned space cannot follow, step
    /// 2's membrane term lets the displacement bend sharply along the
    /// readings' paths and the surface creases
    /// (`docs/results/real-customers/surface-check.md`); the bending term
    /// penalises the displacement's curvature instead of its slope.
    pub bending: f64,
    /// How the readings' energies are weighted.
    pub weighting: Step2Weighting,
    /// What minimises each round.
    pub solver: Step2Solver,
    /// A solver tried first (`None`: none). Its result is kept when every
    /// reading ends within its threshold (the continuation's share of its
    /// ISO 20685-1 allowable error, at least its tolerance; the whole
    /// allowable error without continuation) and step 2 did not have to
    /// fall back to an earlier shape; otherwise `solver` minimises the same
    /// objective starting from the first solver's body (from the step-1
    /// shape where that fell back). Why: the smooth basis solves a few
    /// readings' step 2 in a tenth of L-BFGS's time but misses many real
    /// readings that L-BFGS meets (`docs/results/predict-bench.md`); where
    /// it misses, L-BFGS from its body meets more readings and folds less
    /// than from the step-1 shape (`docs/results/real-customers.md`).
    pub first: Option<Step2Solver>,
    /// Smooth out folds: where step 2's body flipped or collapsed triangles
    /// of the step-1 shape, the displacement of the folded triangles'
    /// neighbourhood is smoothed (each free vertex given its neighbours'
    /// mean displacement) until no triangle is folded or the rounds run
    /// out; the landmarks of straight readings (heights, straight lengths)
    /// stay where step 2 put them, and the result is kept where it folds
    /// fewer triangles and no reading within its allowable error falls out
    /// of it ([`super::Warning::FoldsSmoothed`]). Why: on real
    /// people many readings ask the template's surface for what it cannot
    /// follow as ANSUR II defines it, and step 2 met them by folding a few
    /// triangles at the crotch, the navel and the armpits. A reading
    /// within its ISO 20685-1 allowable error that the smoothing pushes
    /// out has its support held too and the smoothing starts again. A
    /// triangle still folded is then moved as one piece, and the held
    /// landmarks of the triangles still folded are let go (all or part of
    /// the way, on the same terms). On all 1,505 ANSUR II test-split people
    /// entered with their `ansur` survey values the flipped triangles went
    /// from 4,466 to 1,078, the share within ISO unchanged (99.6 %, every
    /// dimension's) (`docs/results/real-customers.md`). Since 2026-12-07
    /// (evening) it also runs before step 2: a step-1 shape that flips
    /// more than 20 triangles of the model's mean shape is smoothed the
    /// same way against the mean (far along a few components the linear
    /// space folds the head or the feet). Since 2026-12-08, last, on the
    /// body the soft-pull tries kept: where triangles are still folded,
    /// the surface wins over the readings. Their neighbourhood is moved as
    /// one piece (by its straight readings' landmarks where it holds any),
    /// blended into the body around it over up to 8 rings, or smoothed
    /// with nothing held first, whichever folds fewer and then gives up
    /// fewer readings; the readings pushed beyond their allowable error are
    /// named ([`super::Warning::SurfaceOverReadings`]). It is kept only
    /// where it unfolds all that was left, or at least half. On the same
    /// 1,505 people: 814 flipped triangles on 199 bodies -> none, 99.7 ->
    /// 99.5 % within ISO 20685-1 (`docs/results/real-customers.md`, "No
    /// flipped triangles").
    pub fold_repair: bool,
    /// Where step 2 aims a soft target ([`super::Target::soft`]) that is
    /// looser than the reference tolerance, in `[0, 1]`: its step-1 value
    /// plus this share of the way to the target's own value (0: held at
    /// the step-1 value, as a doubtful reading is; 1: the target itself,
    /// weighted by its tolerance as in step 1). Why: step 1 moves only in
    /// the learned shape space, whose relations between dimensions come
    /// from a generated population, so it leaves the unmeasured
    /// dimensions short of what real people with the same readings have
    /// (a soft target's value); step 2 can follow them locally
    /// (`docs/results/real-customers.md`, "Step 2 and the soft targets").
    /// Where the body (after the fold repair) still folds triangles or is
    /// creased (more than 20 edges whose fold grew by more than 30 degrees
    /// from the step-1 shape), step 2 runs again with half and then none of
    /// this share and keeps the body that folds least
    /// ([`super::Warning::SoftPullReduced`]).
    pub soft_pull: f64,
}

/// What minimises each round of step 2.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub enum Step2Solver {
    /// The paper: L-BFGS with Armijo backtracking.
    Lbfgs {
        /// The paper's stopping rules, with history 5 (each pair is
        /// 2 x 3V doubles streamed twice per iteration; 5 instead of 7
        /// pairs cut the step-2 time by about a fifth, see
        /// `docs/results/predict-bench.md`).
        stop: StopRule,
    },
    /// Damped Gauss-Newton with a sparse Cholesky factorisation of the
    /// 3V x 3V system ([`crate::gauss_newton`]): the same objective solved
    /// in a few iterations instead of 100.
    GaussNewton {
        /// Its stopping rules.
        stop: GaussNewtonStop,
    },
    /// Damped Gauss-Newton over the displacement in the template's `modes`
    /// smoothest deformations ([`crate::reduced`], the basis from
    /// [`crate::smooth_basis`], computed once per template and process):
    /// the same objective restricted to a 3 x `modes`-dimensional space,
    /// a dense solve per iteration instead of a sparse one over 3V unknowns.
    SmoothBasis {
        /// The number of modes k (per coordinate; at least 1, at most V).
        modes: usize,
        /// What the reduced solve fits: the paper's per-segment `E_m`, or
        /// each reading's length.
        #[serde(default)]
        fit: SmoothFit,
        /// After each round's reduced solve, this many iterations of the
        /// paper's L-BFGS over all vertices for what the modes cannot
        /// express (0: none).
        #[serde(default)]
        polish: u64,
        /// Its stopping rules (those of [`Step2Solver::GaussNewton`]).
        stop: GaussNewtonStop,
        /// A round also ends when an accepted step lowers the energy by
        /// less than an error of this many millimetres on one reading
        /// (at the reference tolerance) costs, or when the Gauss-Newton
        /// model predicts less than that for the next step (0: only
        /// `stop`'s rules). Applies with the per-measurement weighting,
        /// whose energy is about `(1 - lambda) reading_weight` per mm^2
        /// of a reading's error; the paper's `E_m` has no such scale.
        /// Why: where the readings and soft targets contradict each other
        /// the energy levels off far above zero and the first-order model
        /// of each length takes a step after step that each gains under
        /// 1e-4 of it, moving the body by hundredths of a millimetre
        /// (`docs/results/predict-bench.md`, 2026-12-06, night).
        #[serde(default)]
        min_decrease_mm: f64,
    },
}

/// What step 2 in the smooth basis fits ([`Step2Solver::SmoothBasis`]).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
pub enum SmoothFit {
    /// The paper's `E_m`: every segment to its per-segment target.
    #[default]
    Segments,
    /// Each reading's length to its target, weighted as its segment terms
    /// weigh an error spread over the reading ([`crate::reduced`]): the
    /// smooth modes then need not redistribute length along a support.
    Readings,
}

/// The smooth-basis solver's modes where not chosen otherwise
/// ([`Step2Solver::smooth_basis`]).
pub const DEFAULT_SMOOTH_MODES: usize = 200;

/// The smooth-basis solver's L-BFGS iterations after each reduced solve
/// where not chosen otherwise ([`Step2Solver::smooth_basis`]).
pub const DEFAULT_SMOOTH_POLISH: u64 = 0;

/// The smooth-basis solver's `min_decrease_mm` where not chosen otherwise
/// ([`Step2Solver::smooth_basis`]): a step worth less than a tenth of a
/// millimetre on one reading ends the round.
pub const DEFAULT_SMOOTH_MIN_DECREASE_MM: f64 = 0.1;

impl Step2Solver {
    /// [`Step2Solver::SmoothBasis`] with [`DEFAULT_SMOOTH_MODES`] modes and
    /// the Gauss-Newton stopping rules.
    pub fn smooth_basis() -> Self {
        Self::SmoothBasis {
            modes: DEFAULT_SMOOTH_MODES,
            fit: SmoothFit::Readings,
            polish: DEFAULT_SMOOTH_POLISH,
            stop: GaussNewtonStop::default(),
            min_decrease_mm: DEFAULT_SMOOTH_MIN_DECREASE_MM,
        }
    }

    /// The paper's L-BFGS with its stopping rules (history 5).
    pub fn paper() -> Self {
        Self::Lbfgs {
            stop: StopRule {
                history: 5,
                ..StopRule::default()
            },
        }
    }

    /// The iteration cap of a run.
    pub fn max_iters(&self) -> u64 {
        match self {
            Self::Lbfgs { stop } => stop.max_iters,
            Self::GaussNewton { stop } | Self::SmoothBasis { stop, .. } => stop.max_iters,
        }
    }

    /// The iteration cap of a run, to change it (experiments, tests).
    pub fn max_iters_mut(&mut self) -> &mut u64 {
        match self {
            Self::Lbfgs { stop } => &mut stop.max_iters,
            Self::GaussNewton { stop } | Self::SmoothBasis { stop, .. } => &mut stop.max_iters,
        }
    }
}

/// How step 2 weights the readings' energies.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub enum Step2Weighting {
    /// The paper's `E_m` (see [`EnergyWeighting::Paper`]).
    Paper,
    /// Each reading's energy is about `reading_weight` times (its error in
    /// mm)^2, against `lambda E_s` (mm^2); a reading with a tolerance wider
    /// than the reference keeps the value step 1 gave it (else the strong
    /// weight would bend the surface to a doubtful reading).
    PerMeasurement {
        /// Default 1e4: on 40 ANSUR II subjects with the ansur set, 1e2 /
        /// 1e3 / 1e4 / 1e5 passed 76.2 / 90.7 / 92.9 / 91.0 % of readings
        /// within ISO 20685-1 (weight 1 leaves smoothness in charge: 51 %);
        /// `docs/results/predict-iso.md`.
        reading_weight: f64,
    },
}

/// Rounds beyond `s` (each: recompute the supports, one more minimisation)
/// while a given reading's error on the current shape exceeds `share` times
/// its allowable error ([`crate::predict::Measurer::allowable_error`], at
/// least its tolerance if it has one), as long as each round cuts the
/// summed excess by at least 5 % and the step's solver runs have used fewer
/// than `max_evaluations` objective evaluations. Applies to both steps.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Continuation {
    /// At most this many rounds beyond `s`, per step.
    pub max_extra_rounds: usize,
    /// A reading misses when its error exceeds this share of its allowable error.
    pub share: f64,
    /// Allowable error (mm) of a measurement the measurer gives none for.
    pub default_allowable_mm: f64,
    /// No new round once the step's runs have used this many objective
    /// evaluations (counted, so a prediction does the same work under any
    /// load; reports older than this held a wall-clock budget instead).
    #[serde(default = "default_max_evaluations")]
    pub max_evaluations: u64,
    /// L-BFGS iterations of a step-1 continuation round (`None`: step 1's
    /// `stop.max_iters`, 100, what reports older than this field ran).
    /// A continuation round there mostly nudges a reading whose support
    /// jumps under the step (the neck's cut curve); on generated bodies 10
    /// iterations met every reading that 100 did, step 2 then kept its
    /// smooth basis as often, and a paper34 estimate took about 20 ms less
    /// (`docs/results/predict-iso.md`, `docs/results/predict-bench.md`).
    #[serde(default)]
    pub step1_max_iters: Option<u64>,
}

/// The evaluation budget of a step's continuation: about what the old 1 s
/// wall-clock budget allowed step 2 on the bench machine (0.5 ms per
/// evaluation on the 13,718-vertex template, `docs/results/predict-bench.md`),
/// and more than the 10 extra rounds of 100 iterations use there.
pub const DEFAULT_MAX_EVALUATIONS: u64 = 2000;

fn default_max_evaluations() -> u64 {
    DEFAULT_MAX_EVALUATIONS
}

impl Default for Continuation {
    fn default() -> Self {
        Self {
            max_extra_rounds: 10,
            share: 0.5,
            default_allowable_mm: 4.0,
            max_evaluations: DEFAULT_MAX_EVALUATIONS,
            step1_max_iters: Some(DEFAULT_STEP1_CONTINUATION_ITERS),
        }
    }
}

/// [`Continuation::step1_max_iters`] of the default.
pub const DEFAULT_STEP1_CONTINUATION_ITERS: u64 = 10;

/// How the segment terms of one measurement are weighted in `E_m`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
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
            s: 3,
            reference_tolerance: 0.001,
            step1: Step1Settings {
                solver: Step1Solver::GaussNewtonMap {
                    tau_mm: None,
                    min_decrease_mm: DEFAULT_STEP1_MIN_DECREASE_MM,
                },
                weighting: EnergyWeighting::PerMeasurement,
                clamp: Step1Clamp::InsideBox,
                components: None,
                stop: StopRule::default(),
            },
            step2: Step2Settings {
                lambda: 0.1,
                bending: 0.0,
                weighting: Step2Weighting::PerMeasurement {
                    reading_weight: 1e4,
                },
                // The paper's L-BFGS. The sparse Gauss-Newton solver
                // (`Step2Solver::GaussNewton`) ends every round at the
                // round's minimum and fits generated bodies closer (S_real
                // circumferences 0.008 -> 0.000 mm), but on real people
                // (ANSUR II, ansur set) the exact minimum with the held
                // supports bends the surface where supports then jump:
                // 92.8 % -> 81.9 % of readings within ISO 20685-1
                // (docs/results/predict-iso.md). L-BFGS's 100 iterations
                // stay smooth. Step 2 in the smooth basis
                // (`Step2Solver::SmoothBasis`) is about ten times faster
                // and as good on generated bodies, but fails real people
                // the same way (ansur 92.8 % -> 78.1 %).
                solver: Step2Solver::paper(),
                // The smooth basis first: where it meets every reading
                // (the quick set on generated bodies and on real people,
                // paper34 on generated bodies) step 2 takes 22-25 ms
                // instead of about 200 ms, with the same readings met
                // (docs/results/predict-bench.md); where it misses one
                // (many ANSUR II readings of real people) L-BFGS runs from
                // the step-1 shape as before, so the result is the
                // L-BFGS one.
                first: Some(Step2Solver::smooth_basis()),
                fold_repair: true,
                // Soft targets followed part of the way, a breadth or depth
                // held at its step-1 value (step 2's `is_caliper`).
                // 2026-12-06, half the way, rounds undamped: all
                // 1,505 ANSUR II test-split people, quick input with sex,
                // with the estimator's `RealPeople::breadths_and_depths`:
                // the mean absolute error over the 32 dimensions the mesh
                // can follow 14.60 (held) -> 11.61 mm (least squares with
                // sex 9.54), none folded; 0.75 gave 10.98 mm with 4
                // flipped triangles, 1 gave 10.72 mm with 71. With the
                // calipers pulled too (11.50 mm) four readings without sex
                // made step 2's smooth basis give way to L-BFGS, 0.58 s a
                // body instead of 0.09 s (issue 13's target: 120 ms)
                // (docs/results/real-customers.md). Since 2026-12-07
                // three quarters of the way: with the smooth basis's rounds
                // started damped (`crate::reduced`) it costs no more than
                // half did, the 32 followable 11.64 -> 10.95 mm, none
                // folded, and no woman's estimate on the men's side of the
                // whole-body discriminant axis (6 at 0.5). All the way
                // gives 0 too, but a folding body then runs step 2 again,
                // and the bench's paper34 body does: 65 ms on one core
                // before the damped start, 64-69 ms after it (criterion),
                // past issue 13's 40 ms
                // (docs/results/sex-check.md).
                soft_pull: 0.75,
            },
            continuation: Some(Continuation::default()),
            warn_error_mm: 5.0,
        }
    }
}

impl PredictSettings {
    /// The paper's method exactly: L-BFGS on `E_m` weighted as the paper
    /// writes it in both steps, one clamp after step 1, exactly `s` rounds
    /// per step (l = 3, lambda = 0.1, s = 3, the paper's stopping rules).
    /// The default differs in eight places, measured in
    /// `docs/results/predict-iso.md`, `docs/results/predict-sreal.md` and
    /// `docs/results/real-customers.md`: the Gauss-Newton MAP step 1,
    /// per-measurement weighting in step 1 and in step 2, the box inside
    /// step 1, the [`Continuation`], step 2's smooth basis tried first
    /// ([`Step2Settings::first`], for speed), the fold repair
    /// ([`Step2Settings::fold_repair`]) and soft targets followed in step 2
    /// ([`Step2Settings::soft_pull`]).
    pub fn paper() -> Self {
        let d = Self::default();
        Self {
            step1: Step1Settings {
                solver: Step1Solver::Lbfgs { prior_mm: None },
                weighting: EnergyWeighting::Paper,
                clamp: Step1Clamp::AfterStep,
                ..d.step1
            },
            step2: Step2Settings {
                weighting: Step2Weighting::Paper,
                solver: Step2Solver::paper(),
                first: None,
                fold_repair: false,
                soft_pull: 0.0,
                ..d.step2
            },
            continuation: None,
            ..d
        }
    }

    /// Checks every value and resolves the settings into the configuration
    /// of each stage (see the module docs).
    pub fn resolve(&self) -> Result<PredictConfig, SettingsError> {
        PredictConfig::new(self)
    }
}

/// A setting that cannot be used; the message names it and its range.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SettingsError {
    /// A value that must be positive and finite is not.
    #[error("{what} must be positive and finite, got {value}")]
    NotPositive {
        /// The setting.
        what: &'static str,
        /// Its value.
        value: f64,
    },
    /// A value outside its range.
    #[error("{what} must lie in {range}, got {value}")]
    OutOfRange {
        /// The setting.
        what: &'static str,
        /// The range, as text.
        range: &'static str,
        /// Its value.
        value: f64,
    },
    /// A count that must be at least 1 is 0.
    #[error("{what} must be at least 1")]
    Zero {
        /// The setting.
        what: &'static str,
    },
    /// An L-BFGS run needs at least one correction pair.
    #[error("{what}: the L-BFGS history must keep at least one pair")]
    NoHistory {
        /// The stopping rule.
        what: &'static str,
    },
    /// Two settings that do not go together.
    #[error("{0}")]
    Unsupported(&'static str),
}

fn positive(what: &'static str, value: f64) -> Result<f64, SettingsError> {
    if value.is_finite() && value > 0.0 {
        Ok(value)
    } else {
        Err(SettingsError::NotPositive { what, value })
    }
}

fn non_negative(what: &'static str, value: f64) -> Result<f64, SettingsError> {
    if value.is_finite() && value >= 0.0 {
        Ok(value)
    } else {
        Err(SettingsError::OutOfRange {
            what,
            range: "[0, inf)",
            value,
        })
    }
}

/// The paper's step-2 L-BFGS stopping rule (history 5).
fn stop_rule_of_paper() -> StopRule {
    match Step2Solver::paper() {
        Step2Solver::Lbfgs { stop } => stop,
        _ => StopRule::default(),
    }
}

fn stop_rule(what: &'static str, stop: &StopRule) -> Result<StopRule, SettingsError> {
    non_negative(what, stop.grad_tol)?;
    non_negative(what, stop.rel_cost_tol)?;
    if stop.history == 0 {
        return Err(SettingsError::NoHistory { what });
    }
    Ok(*stop)
}

/// A prediction's configuration, resolved from [`PredictSettings`] once and
/// valid by construction: one part per stage.
#[derive(Debug, Clone, PartialEq)]
pub struct PredictConfig {
    settings: PredictSettings,
    readings: ReadingsConfig,
    start: StartConfig,
    step1: Step1Config,
    step2: Step2Config,
    rounds: RoundsConfig,
    report: ReportConfig,
}

/// How readings become energy weights and noise.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ReadingsConfig {
    /// A reading with this tolerance (metres) gets weight 1.
    pub(crate) reference_tolerance: f64,
}

/// The start: feature analysis or the Gaussian conditional, clamped.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StartConfig {
    /// The clamp `l` of the normalised weights.
    pub(crate) l: f64,
}

/// Step 1, resolved.
#[derive(Debug, Clone, PartialEq)]
pub struct Step1Config {
    pub(crate) solver: Step1Method,
    /// `Some(l)`: clamp and hold inside the box before every round after
    /// the first ([`Step1Clamp::InsideBox`]).
    pub(crate) box_l: Option<f64>,
    /// The clamp after step 1.
    pub(crate) l: f64,
    pub(crate) components: Option<usize>,
}

/// What step 1's rounds run, with every default resolved.
#[derive(Debug, Clone, PartialEq)]
pub(crate) enum Step1Method {
    /// L-BFGS on `E_m` every round.
    Lbfgs(LbfgsRounds),
    /// Gauss-Newton MAP in the `s` rounds; L-BFGS (with prior tau) in the
    /// fallback and continuation rounds.
    GaussNewtonMap {
        /// Reading noise of an exact reading, mm.
        tau_mm: f64,
        /// Gauss-Newton iterations per round.
        max_iters: usize,
        /// A round's solve lowering the objective by at most this keeps
        /// the weights unmeasured (`(min_decrease_mm / tau)^2`, 0: never).
        min_decrease: f64,
        /// The L-BFGS rounds (their prior is always `tau_mm`).
        lbfgs: LbfgsRounds,
    },
}

/// An L-BFGS round of step 1.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct LbfgsRounds {
    pub(crate) solver: Lbfgs,
    pub(crate) weighting: EnergyWeighting,
    pub(crate) prior: Step1Prior,
}

/// The prior `tau^2 |w|^2` of step 1's L-BFGS rounds.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) enum Step1Prior {
    /// None (the paper's `E_m`).
    None,
    /// Always, with this tau (mm).
    Always(f64),
    /// Only when a reading is given with a tolerance, with this tau (mm).
    WithTolerances(f64),
}

impl Step1Prior {
    /// Tau (mm) for a prediction whose readings include one with a
    /// tolerance (`any_tolerance`), or none.
    pub(crate) fn tau_mm(self, any_tolerance: bool) -> Option<f64> {
        match self {
            Self::None => None,
            Self::Always(t) => Some(t),
            Self::WithTolerances(t) => any_tolerance.then_some(t),
        }
    }
}

/// Step 2, resolved.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Step2Config {
    pub(crate) lambda: f64,
    pub(crate) bending: f64,
    /// The weighting and its per-measurement scale (1 with the paper's).
    pub(crate) weighting: (EnergyWeighting, f64),
    pub(crate) solver: Step2Method,
    /// Tried first; kept when it meets every reading.
    pub(crate) first: Option<Step2Method>,
    /// Smooth out folds ([`Step2Settings::fold_repair`]).
    pub(crate) fold_repair: bool,
    /// [`Step2Settings::soft_pull`], in `[0, 1]`.
    pub(crate) soft_pull: f64,
}

/// What step 2's rounds run.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) enum Step2Method {
    /// L-BFGS (backtracking line search).
    Lbfgs(Lbfgs),
    /// Sparse Gauss-Newton.
    GaussNewton(GaussNewtonStop),
    /// Gauss-Newton in the smooth basis of `modes` modes, then `polish`
    /// L-BFGS iterations over the vertices.
    SmoothBasis {
        modes: usize,
        fit: SmoothFit,
        polish: Option<Lbfgs>,
        stop: GaussNewtonStop,
        /// Energy per mm^2 of one reading's error is scaled by this many
        /// mm^2 into the absolute stopping rule (0: none).
        min_decrease_mm: f64,
    },
}

impl Step2Method {
    /// The iteration cap of a run.
    pub(crate) fn max_iters(&self) -> u64 {
        match self {
            Self::Lbfgs(l) => l.stop.max_iters,
            Self::GaussNewton(g) | Self::SmoothBasis { stop: g, .. } => g.max_iters,
        }
    }
}

/// The rounds of both steps.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RoundsConfig {
    /// The paper's `s`.
    pub(crate) s: usize,
    /// Continuation (never with `s = 0`).
    pub(crate) continuation: Option<Continuation>,
}

/// What the report warns about.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ReportConfig {
    pub(crate) warn_error_mm: f64,
    pub(crate) l: f64,
}

impl RoundsConfig {
    /// The paper's `s`.
    pub fn s(&self) -> usize {
        self.s
    }

    /// Rounds at most, continuation included.
    pub(crate) fn max_rounds(&self) -> usize {
        self.s + self.continuation.map_or(0, |c| c.max_extra_rounds)
    }
}

impl PredictConfig {
    /// Resolves `settings` (see [`PredictSettings::resolve`]).
    pub fn new(settings: &PredictSettings) -> Result<Self, SettingsError> {
        let l = positive("l", settings.l)?;
        let reference = positive("reference_tolerance (metres)", settings.reference_tolerance)?;
        let reference_mm = reference * MM_PER_M;
        let warn_error_mm = non_negative("warn_error_mm", settings.warn_error_mm)?;
        let s1 = &settings.step1;
        let stop1 = stop_rule("step 1's stopping rule", &s1.stop)?;
        let lbfgs1 = Lbfgs {
            stop: stop1,
            line_search: LineSearch::StrongWolfe,
        };
        let solver = match s1.solver {
            Step1Solver::Lbfgs { prior_mm } => Step1Method::Lbfgs(LbfgsRounds {
                solver: lbfgs1,
                weighting: s1.weighting,
                prior: match prior_mm {
                    Some(t) => Step1Prior::Always(positive("step 1's prior_mm", t)?),
                    None if s1.weighting == EnergyWeighting::PerMeasurement => {
                        Step1Prior::WithTolerances(reference_mm)
                    }
                    None => Step1Prior::None,
                },
            }),
            Step1Solver::GaussNewtonMap {
                tau_mm,
                min_decrease_mm,
            } => {
                let tau = match tau_mm {
                    Some(t) => positive("step 1's tau_mm", t)?,
                    None => reference_mm,
                };
                let min_decrease_mm =
                    non_negative("step 1's Gauss-Newton min_decrease_mm", min_decrease_mm)?;
                Step1Method::GaussNewtonMap {
                    tau_mm: tau,
                    max_iters: usize::try_from(stop1.max_iters).unwrap_or(usize::MAX),
                    min_decrease: (min_decrease_mm / tau).powi(2),
                    lbfgs: LbfgsRounds {
                        solver: lbfgs1,
                        weighting: s1.weighting,
                        prior: Step1Prior::Always(tau),
                    },
                }
            }
        };
        let s2 = &settings.step2;
        if !(0.0..=1.0).contains(&s2.lambda) {
            return Err(SettingsError::OutOfRange {
                what: "lambda",
                range: "[0, 1]",
                value: s2.lambda,
            });
        }
        if !(s2.bending.is_finite() && s2.bending >= 0.0) {
            return Err(SettingsError::OutOfRange {
                what: "bending",
                range: "[0, inf)",
                value: s2.bending,
            });
        }
        if s2.bending > 0.0
            && (matches!(s2.solver, Step2Solver::SmoothBasis { .. })
                || matches!(s2.first, Some(Step2Solver::SmoothBasis { .. })))
        {
            return Err(SettingsError::Unsupported(
                "the bending term is not taken by step 2's smooth-basis solver; set bending to 0 or the solver to L-BFGS or Gauss-Newton",
            ));
        }
        if !(0.0..=1.0).contains(&s2.soft_pull) {
            return Err(SettingsError::OutOfRange {
                what: "step 2's soft_pull",
                range: "[0, 1]",
                value: s2.soft_pull,
            });
        }
        let weighting2 = match s2.weighting {
            Step2Weighting::Paper => (EnergyWeighting::Paper, 1.0),
            Step2Weighting::PerMeasurement { reading_weight } => (
                EnergyWeighting::PerMeasurement,
                positive("step 2's reading_weight", reading_weight)?,
            ),
        };
        let continuation = match settings.continuation {
            Some(c) if settings.s > 0 => {
                positive("the continuation's share", c.share)?;
                positive(
                    "the continuation's default_allowable_mm",
                    c.default_allowable_mm,
                )?;
                if c.step1_max_iters == Some(0) {
                    return Err(SettingsError::NotPositive {
                        what: "the continuation's step1_max_iters",
                        value: 0.0,
                    });
                }
                Some(c)
            }
            _ => None,
        };
        Ok(Self {
            settings: settings.clone(),
            readings: ReadingsConfig {
                reference_tolerance: reference,
            },
            start: StartConfig { l },
            step1: Step1Config {
                solver,
                box_l: (s1.clamp == Step1Clamp::InsideBox).then_some(l),
                l,
                components: s1.components,
            },
            step2: Step2Config {
                lambda: s2.lambda,
                bending: s2.bending,
                weighting: weighting2,
                solver: step2_method(&s2.solver)?,
                first: s2.first.as_ref().map(step2_method).transpose()?,
                fold_repair: s2.fold_repair,
                soft_pull: s2.soft_pull,
            },
            rounds: RoundsConfig {
                s: settings.s,
                continuation,
            },
            report: ReportConfig { warn_error_mm, l },
        })
    }

    /// The default settings, resolved.
    pub fn station() -> Self {
        Self::new(&PredictSettings::default()).expect("the default settings are valid")
    }

    /// The paper's settings ([`PredictSettings::paper`]), resolved.
    pub fn paper() -> Self {
        Self::new(&PredictSettings::paper()).expect("the paper's settings are valid")
    }

    /// The settings this was resolved from (what a report records).
    pub fn settings(&self) -> &PredictSettings {
        &self.settings
    }

    /// How readings are weighted.
    pub fn readings(&self) -> &ReadingsConfig {
        &self.readings
    }

    /// The start.
    pub fn start(&self) -> &StartConfig {
        &self.start
    }

    /// Step 1.
    pub fn step1(&self) -> &Step1Config {
        &self.step1
    }

    /// Step 2.
    pub fn step2(&self) -> &Step2Config {
        &self.step2
    }

    /// The rounds of both steps.
    pub fn rounds(&self) -> &RoundsConfig {
        &self.rounds
    }

    /// The report.
    pub fn report(&self) -> &ReportConfig {
        &self.report
    }
}

impl Default for PredictConfig {
    /// [`PredictConfig::station`].
    fn default() -> Self {
        Self::station()
    }
}

impl TryFrom<&PredictSettings> for PredictConfig {
    type Error = SettingsError;
    fn try_from(s: &PredictSettings) -> Result<Self, SettingsError> {
        Self::new(s)
    }
}

/// Resolves one of step 2's solvers ([`Step2Settings::solver`] or
/// [`Step2Settings::first`]), refusing out-of-range stopping rules.
fn step2_method(solver: &Step2Solver) -> Result<Step2Method, SettingsError> {
    Ok(match *solver {
        Step2Solver::Lbfgs { stop } => Step2Method::Lbfgs(Lbfgs {
            stop: stop_rule("step 2's stopping rule", &stop)?,
            line_search: LineSearch::Backtracking,
        }),
        Step2Solver::GaussNewton { stop } => {
            non_negative("step 2's Gauss-Newton rel_cost_tol", stop.rel_cost_tol)?;
            non_negative("step 2's Gauss-Newton grad_tol", stop.grad_tol)?;
            Step2Method::GaussNewton(stop)
        }
        Step2Solver::SmoothBasis {
            modes,
            fit,
            polish,
            stop,
            min_decrease_mm,
        } => {
            if modes == 0 {
                return Err(SettingsError::Zero {
                    what: "step 2's smooth-basis modes",
                });
            }
            non_negative("step 2's smooth-basis rel_cost_tol", stop.rel_cost_tol)?;
            non_negative("step 2's smooth-basis grad_tol", stop.grad_tol)?;
            non_negative("step 2's smooth-basis min_decrease_mm", min_decrease_mm)?;
            Step2Method::SmoothBasis {
                modes,
                fit,
                polish: (polish > 0).then(|| Lbfgs {
                    stop: StopRule {
                        max_iters: polish,
                        ..stop_rule_of_paper()
                    },
                    line_search: LineSearch::Backtracking,
                }),
                stop,
                min_decrease_mm,
            }
        }
    })
}

mod wire;

#[cfg(test)]
mod tests;
