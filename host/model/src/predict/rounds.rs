//! The paper's `s` rounds of "recompute the supports, then minimise", shared
//! by step 1 and step 2.
//!
//! Why one driver: both steps run the same loop (paper section "Shape
//! Refinement": "we update the geodesic paths and the circumference
//! measurements and solve the resulting optimization problem `s` times"),
//! plus the same continuation rule, progress reports and error handling.
//! In argmin's terms this is the executor: [`run_rounds`] owns the loop,
//! the stopping rules ([`RoundsStop`]) and the observer; each step is a
//! [`RoundStep`] that measures its current shape and runs one minimisation
//! with those supports held.
//!
//! Per round `r` (0-based) of at most `s + max_extra_rounds`:
//!
//! 1. for `r < s`, report the boundary (the observer may cancel);
//! 2. let the step prepare the round and measure its current shape (the
//!    supports: hull points, path edges, their per-segment targets);
//! 3. with a [`Continuation`], compare each reading's error with its
//!    threshold; for `r >= s` (a continuation round) stop when nothing
//!    misses, when the summed excess fell by less than 5 % over the last
//!    round (unless the step switched method, [`RoundStep::comparable`]),
//!    or when the step's runs used the evaluation budget; else report the
//!    boundary;
//! 4. minimise; a solver that cannot start ends the rounds with a warning
//!    (the step keeps its shape), a round with nothing to fit ends them.

use tapeshape_measure::Measured;

use super::progress::{report, PredictObserver, PredictProgress, PredictStage, Round};
use super::readings::Readings;
use super::settings::{Continuation, RoundsConfig};
use super::warning::Warning;
use crate::lbfgs::{MinimiseError, RunInfo};
use crate::{Result, MM_PER_M};

/// Why a step's rounds ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub enum RoundsStop {
    /// All `s` rounds ran and there is no continuation.
    AllRounds,
    /// A continuation round found every reading within its threshold.
    ReadingsMet,
    /// The last round cut the summed excess by less than 5 %.
    NoProgress,
    /// The step's runs used the continuation's evaluation budget.
    Budget,
    /// Every continuation round allowed ran.
    ExtraRoundsUsed,
    /// No reading had a support with length (nothing to fit).
    NothingToFit,
    /// A solver could not start (a warning says why).
    SolverFailed,
    /// `s = 0`: no rounds.
    NoRounds,
}

/// How a step's rounds went (in the report).
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct RoundsSummary {
    /// Rounds that ran a minimisation (continuation rounds included).
    pub rounds: usize,
    /// Objective evaluations of all its runs.
    pub evaluations: u64,
    /// Why they ended.
    pub stopped: RoundsStop,
}

/// What one round's minimisation did.
pub enum RoundEnd {
    /// It ran (its runs are in the log).
    Ran,
    /// No reading had a support with length.
    NothingToFit,
    /// The solver could not start.
    Failed(MinimiseError),
}

/// The runs and warnings of one step.
#[derive(Debug, Default)]
pub struct RoundLog {
    /// One per solver run (a Gauss-Newton round that falls back adds two).
    pub runs: Vec<RunInfo>,
    /// Things the operator or engineer should know.
    pub warnings: Vec<Warning>,
}

impl RoundLog {
    fn evaluations(&self) -> u64 {
        self.runs.iter().map(|r| r.evaluations).sum()
    }
}

/// One step as the round driver sees it (argmin's `Solver`, one round per
/// call). Step 1 and step 2 implement it; a new step (another solver over
/// the weights, say) implements it and calls [`run_rounds`].
pub trait RoundStep {
    /// Which step this is ([`PredictStage::Step1`] or [`PredictStage::Step2`]).
    const STAGE: PredictStage;

    /// The iteration cap of the step's solver runs (for progress).
    fn max_iterations(&self) -> u64;

    /// Before measuring round `round`: e.g. step 1's box clamp.
    fn prepare(&mut self, _round: usize) {}

    /// The given readings measured on the current shape, with their supports.
    fn measure(&mut self, round: usize) -> Result<Vec<Measured>>;

    /// Whether round `round`'s excess may be compared with the last
    /// round's (false where the step switches method there).
    fn comparable(&self, _round: usize) -> bool {
        true
    }

    /// One minimisation with the supports of `measured` held; runs and
    /// warnings go into `log`. `at` is the round's progress position.
    fn minimise(
        &mut self,
        round: usize,
        measured: &[Measured],
        at: PredictProgress,
        observer: &dyn PredictObserver,
        log: &mut RoundLog,
    ) -> Result<RoundEnd>;
}

/// Per given reading, the error (mm) above which a continuation round runs:
/// `share` times its allowable error, at least its own tolerance. Empty
/// without continuation.
pub fn thresholds(
    readings: &Readings,
    allowable_m: &dyn Fn(usize) -> Option<f64>,
    cont: Option<Continuation>,
) -> Vec<f64> {
    let Some(c) = cont else {
        return Vec::new();
    };
    readings
        .iter()
        .map(|g| {
            let allowable = allowable_m(g.index).map_or(c.default_allowable_mm, |a| a * MM_PER_M);
            let tol = g.tolerance.map_or(0.0, |t| t * MM_PER_M);
            (c.share * allowable).max(tol)
        })
        .collect()
}

/// Summed excess (mm) of the readings' errors over their thresholds.
fn excess_mm(readings: &Readings, measured: &[Measured], thresholds: &[f64]) -> f64 {
    readings
        .iter()
        .zip(measured)
        .zip(thresholds)
        .map(|((g, m), t)| ((m.value * MM_PER_M - g.target_mm).abs() - t).max(0.0))
        .sum()
}

/// Runs a step's rounds (see the module docs). `readings` are the targets
/// the step fits (their errors decide the continuation), `thresholds` from
/// [`thresholds`].
pub fn run_rounds<S: RoundStep>(
    step: &mut S,
    config: &RoundsConfig,
    readings: &Readings,
    thresholds: &[f64],
    observer: &dyn PredictObserver,
) -> Result<(RoundLog, RoundsSummary)> {
    let s = config.s;
    let mut log = RoundLog::default();
    let mut last_excess = f64::INFINITY;
    let mut ran = 0;
    let stopped = 'rounds: {
        if s == 0 {
            break 'rounds RoundsStop::NoRounds;
        }
        for round in 0..config.max_rounds() {
            let at = PredictProgress {
                stage: S::STAGE,
                round: Some(Round {
                    index: round,
                    of: s,
                }),
                evaluations: 0,
                max_iterations: step.max_iterations(),
            };
            if round < s {
                report(observer, at)?;
            }
            step.prepare(round);
            let measured = step.measure(round)?;
            if let Some(c) = config.continuation {
                let excess = excess_mm(readings, &measured, thresholds);
                if round >= s {
                    if excess == 0.0 {
                        break 'rounds RoundsStop::ReadingsMet;
                    }
                    if excess > 0.95 * last_excess && step.comparable(round) {
                        break 'rounds RoundsStop::NoProgress;
                    }
                    if log.evaluations() >= c.max_evaluations {
                        break 'rounds RoundsStop::Budget;
                    }
                    report(observer, at)?;
                }
                last_excess = excess;
            }
            match step.minimise(round, &measured, at, observer, &mut log)? {
                RoundEnd::Ran => ran += 1,
                RoundEnd::NothingToFit => break 'rounds RoundsStop::NothingToFit,
                RoundEnd::Failed(e) => {
                    log.warnings.push(Warning::SolverStopped {
                        stage: S::STAGE,
                        round,
                        reason: e.to_string(),
                    });
                    break 'rounds RoundsStop::SolverFailed;
                }
            }
        }
        if config.continuation.is_some() {
            RoundsStop::ExtraRoundsUsed
        } else {
            RoundsStop::AllRounds
        }
    };
    let summary = RoundsSummary {
        rounds: ran,
        evaluations: log.evaluations(),
        stopped,
    };
    Ok((log, summary))
}
