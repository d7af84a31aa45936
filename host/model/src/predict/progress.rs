//! Progress reports and cancelling of a prediction.
//!
//! A prediction calls its [`PredictObserver`] at every stage boundary (the
//! start, each round of step 1 and step 2, done) and, inside the solver
//! runs, before every [`OBSERVE_EVERY`]-th objective evaluation. The
//! observer may answer [`Control::Cancel`]; the running solver then stops
//! before its next evaluation (an interrupt, [`crate::lbfgs`]) and the
//! prediction returns [`crate::ModelError::Cancelled`] without a body.
//! Observing changes nothing: the solvers compute the same numbers with or
//! without an observer.

use crate::lbfgs::Control as SolverControl;
use crate::{ModelError, Result};

pub use crate::lbfgs::Control;

/// The stages of a prediction, in order. The estimator
/// (`tapeshape-estimator`) reports [`PredictStage::Check`] while it checks the readings; the model reports
/// the others.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize)]
pub enum PredictStage {
    /// The readings are being checked (names, values, units, consistency),
    /// before the model sees them.
    Check,
    /// Finding the start weights and measuring the start shape.
    Start,
    /// Step 1 (over the weights), in rounds.
    Step1,
    /// Step 2 (over the vertices), in rounds.
    Step2,
    /// The body is ready (the report is being finished).
    Done,
}

impl PredictStage {
    /// Every stage, in order.
    pub const ALL: [PredictStage; 5] = [
        PredictStage::Check,
        PredictStage::Start,
        PredictStage::Step1,
        PredictStage::Step2,
        PredictStage::Done,
    ];
}

impl std::fmt::Display for PredictStage {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Self::Check => "checking the readings",
            Self::Start => "start",
            Self::Step1 => "step 1",
            Self::Step2 => "step 2",
            Self::Done => "done",
        })
    }
}

/// A round of step 1 or step 2: `index` (0-based) of the paper's `of` = `s`;
/// `index >= of` is a continuation round (see
/// [`crate::predict::Continuation`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct Round {
    /// Round, 0-based.
    pub index: usize,
    /// The settings' `s`.
    pub of: usize,
}

/// One progress report of a prediction.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct PredictProgress {
    /// The stage.
    pub stage: PredictStage,
    /// The round, in step 1 and step 2.
    pub round: Option<Round>,
    /// Objective evaluations so far in the current solver run (0 at a stage
    /// boundary). An L-BFGS iteration takes one or a few evaluations.
    pub evaluations: u64,
    /// The iteration cap of the current run (the settings' `max_iters`).
    pub max_iterations: u64,
}

impl PredictProgress {
    /// A report at a boundary (no evaluation yet) of `stage`.
    pub fn at(stage: PredictStage) -> Self {
        Self {
            stage,
            round: None,
            evaluations: 0,
            max_iterations: 0,
        }
    }
}

/// Where a prediction is, in words: "step 2, round 1 of 3", "step 1,
/// extra round 2", "start" (what [`ModelError::Cancelled`] names).
impl std::fmt::Display for PredictProgress {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self.round {
            Some(r) if r.index >= r.of => {
                write!(f, "{}, extra round {}", self.stage, r.index - r.of + 1)
            }
            Some(r) => write!(f, "{}, round {} of {}", self.stage, r.index + 1, r.of),
            None => write!(f, "{}", self.stage),
        }
    }
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
        let (lo, hi) = match self.stage {
            PredictStage::Check | PredictStage::Start => return 0.0,
            PredictStage::Done => return 1.0,
            PredictStage::Step1 => (STAGE_SHARES[1], STAGE_SHARES[2]),
            PredictStage::Step2 => (STAGE_SHARES[2], STAGE_SHARES[3]),
        };
        let Round { index: run, of } = self.round.unwrap_or(Round { index: 0, of: 1 });
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

/// Watches a prediction: called at each stage boundary and every
/// [`OBSERVE_EVERY`] objective evaluations inside the solvers, on the
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

/// Inside a solver run the observer is called before the first evaluation
/// and then every this many (an evaluation of step 2 takes about 1-2 ms).
pub const OBSERVE_EVERY: u64 = 10;

/// Reports `progress` (a boundary); `Err(Cancelled)` if the observer cancels.
pub(crate) fn report(observer: &dyn PredictObserver, progress: PredictProgress) -> Result<()> {
    match observer.observe(&progress) {
        Control::Continue => Ok(()),
        Control::Cancel => Err(ModelError::Cancelled(progress.to_string())),
    }
}

/// The watcher a solver run of `at` (its stage and round) asks before
/// evaluation `n`: reports every [`OBSERVE_EVERY`]-th to `observer`.
pub(crate) fn in_run<'a>(
    observer: &'a dyn PredictObserver,
    at: PredictProgress,
) -> impl Fn(u64) -> SolverControl + 'a {
    move |n: u64| {
        if n.is_multiple_of(OBSERVE_EVERY) {
            observer.observe(&PredictProgress {
                evaluations: n,
                ..at
            })
        } else {
            Control::Continue
        }
    }
}

/// The observer of [`crate::ShapeModel::predict`]: never cancels.
pub(crate) fn no_observer(_: &PredictProgress) -> Control {
    Control::Continue
}
