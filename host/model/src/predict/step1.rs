//! Step 1: the shape inside the learned space that best fits the readings
//! (paper, section Shape Refinement: "minimizing E_m with respect to
//! W_new").
//!
//! `s` rounds ([`super::rounds`]) of: measure the shape (each reading's
//! support), set per-segment targets `l_t(e) = l_t(P) l_g(e) / l_g(P)`, and
//! minimise over the K normalised weights, either
//!
//! * the paper's way, L-BFGS on `E_m` ([`super::Step1Solver::Lbfgs`]), or
//! * the default's, the MAP estimate `sum_j ((m_j - T_j) / sd_j)^2 + |w|^2`
//!   by Gauss-Newton on the readings' values ([`crate::map`],
//!   [`super::Step1Solver::GaussNewtonMap`]), each step backtracked on the
//!   re-measured objective (a round whose solve gains less than an error
//!   of `min_decrease_mm` on one reading costs keeps its weights without
//!   measuring the step); a round it cannot improve, and every
//!   continuation round (at most [`super::Continuation::step1_max_iters`]
//!   iterations there), run L-BFGS on `E_m` with the same prior;
//!
//! then the clamp ([`super::clamp`]). A step 1 that ends with a higher
//! objective than its start (the MAP objective for Gauss-Newton, `E_m` with
//! targets set on each shape otherwise) is undone with a warning.

use tapeshape_measure::Measured;
use tapeshape_mesh::Vec3;

use super::clamp::{clamp_weights, hold_in_box};
use super::progress::{in_run, report, PredictObserver, PredictProgress, PredictStage};
use super::readings::Readings;
use super::rounds::{run_rounds, thresholds, RoundEnd, RoundLog, RoundStep, RoundsSummary};
use super::settings::{LbfgsRounds, RoundsConfig, Step1Config, Step1Method};
use super::start::StartShape;
use super::terms::{map_objective, to_mm};
use super::warning::{Step1Objective, Warning};
use super::Measurer;
use crate::lbfgs::{minimise_watched, RunInfo, Termination};
use crate::map::MapProblem;
use crate::{ModelError, Result, ShapeModel};

/// Step 1's result: the clamped weights, their shape and the readings
/// measured on it, and what the rounds did.
#[derive(Debug, Clone)]
pub struct Step1Shape {
    /// Normalised weights (K) after the clamp.
    pub weights: Vec<f64>,
    /// Components the clamp after step 1 changed.
    pub clamped: Vec<usize>,
    /// The shape (V vertices, metres, station frame), inside the PCA space
    /// as step 1 returns it; with the fold repair on, step 2 may first
    /// smooth it where it folds the model's mean shape
    /// (`ShapeModel::unfold_step1`), and then it is that shape.
    pub vertices: Vec<Vec3>,
    /// The given readings measured on it, in the order of the readings.
    pub measured: Vec<Measured>,
    /// One per solver run.
    pub runs: Vec<RunInfo>,
    /// How the rounds went.
    pub rounds: RoundsSummary,
    /// Things the operator or engineer should know.
    pub warnings: Vec<Warning>,
}

/// Step 1 as the round driver sees it.
struct Step1Rounds<'a> {
    model: &'a ShapeModel,
    measurer: &'a dyn Measurer,
    readings: &'a Readings,
    which: Vec<usize>,
    config: &'a Step1Config,
    s: usize,
    start: &'a StartShape,
    /// The current weights and the components held.
    w: Vec<f64>,
    held: Vec<bool>,
    /// The shape the current round measured.
    x: Vec<Vec3>,
    /// Per reading, the Gauss-Newton MAP's noise (mm).
    map_sd: Vec<f64>,
    /// L-BFGS iterations of a continuation round (`None`: the solver's).
    continuation_iters: Option<u64>,
    /// The last shape measured (by a Gauss-Newton round's backtracking or
    /// at a round's start; its weights, vertices and readings), so that the
    /// next round, or the end of the step, does not reconstruct and measure
    /// the same weights again (each is a pass over the D x K basis and
    /// every support).
    trial: Option<MeasuredShape>,
}

/// Weights with their shape and the readings measured on it.
struct MeasuredShape {
    weights: Vec<f64>,
    vertices: Vec<Vec3>,
    measured: Vec<Measured>,
}

impl MeasuredShape {
    /// The shape and readings if they belong to exactly these weights.
    fn of(this: Option<&Self>, w: &[f64]) -> Option<(Vec<Vec3>, Vec<Measured>)> {
        this.filter(|t| t.weights == w)
            .map(|t| (t.vertices.clone(), t.measured.clone()))
    }
}

impl Step1Rounds<'_> {
    fn gauss_newton(&self) -> bool {
        matches!(self.config.solver, Step1Method::GaussNewtonMap { .. })
    }

    fn lbfgs(&self) -> &LbfgsRounds {
        match &self.config.solver {
            Step1Method::Lbfgs(r) => r,
            Step1Method::GaussNewtonMap { lbfgs, .. } => lbfgs,
        }
    }

    fn max_iters(&self) -> u64 {
        self.lbfgs().solver.stop.max_iters
    }

    /// One Gauss-Newton MAP round (see [`crate::map`]): returns whether the
    /// round is done (its step lowered the re-measured objective, or the
    /// solve found nothing worth `min_decrease` to measure); else the round
    /// runs L-BFGS.
    fn gauss_newton_round(
        &mut self,
        measured: &[Measured],
        terms: &[crate::energy::SegmentTerm],
        owner: Vec<usize>,
        (max_iters, min_decrease): (usize, f64),
        log: &mut RoundLog,
    ) -> Result<bool> {
        let (local, rows, base) = self.model.local_basis(terms);
        let problem = MapProblem::new(
            self.model.pca.n_components,
            &rows,
            &base,
            &local,
            owner,
            self.readings.iter().map(|g| g.target_mm).collect(),
            self.map_sd.clone(),
        );
        let (w_gn, run) = problem.solve(&self.w, &self.held, max_iters, 1e-12);
        if min_decrease > 0.0 && run.objective.0 - run.objective.1 <= min_decrease {
            // With the supports held the step gains at most what a tenth
            // of a millimetre on one reading costs: the weights stay and
            // nothing is measured (the gain is the same order as what
            // re-measuring moves the supports).
            log.runs.push(RunInfo {
                iterations: run.iterations as u64,
                evaluations: run.iterations as u64,
                cost_start: run.objective.0,
                cost_end: run.objective.0,
                reason: Termination::DecreaseBelowReading,
            });
            return Ok(true);
        }
        // The solve holds this round's supports fixed; where a support
        // changes under the step (a hull gains or loses points, a landmark
        // plane moves), the real values differ from the linearised ones.
        // Backtrack on the real (re-measured) objective.
        let real = |meas: &[Measured], w: &[f64]| -> f64 {
            map_objective(self.readings, meas, &self.map_sd, w)
        };
        let f_here = real(measured, &self.w);
        let mut alpha = 1.0;
        let mut lowered = true;
        let mut measures = 0u64;
        loop {
            let trial: Vec<f64> = self
                .w
                .iter()
                .zip(&w_gn)
                .map(|(a, b)| a + alpha * (b - a))
                .collect();
            let x_trial = self.model.shape_unchecked(&trial);
            let m_trial = self
                .model
                .measure_checked(self.measurer, &x_trial, &self.which)?;
            measures += 1;
            if real(&m_trial, &trial) < f_here {
                self.trial = Some(MeasuredShape {
                    weights: trial.clone(),
                    vertices: x_trial,
                    measured: m_trial,
                });
                self.w = trial;
                break;
            }
            alpha *= 0.5;
            if alpha < 1.0 / 64.0 {
                lowered = false;
                break;
            }
        }
        log.runs.push(RunInfo {
            iterations: run.iterations as u64,
            evaluations: run.iterations as u64 + measures,
            cost_start: run.objective.0,
            cost_end: run.objective.1,
            reason: if lowered {
                Termination::GaussNewton { step: alpha }
            } else {
                Termination::GaussNewtonFellBack
            },
        });
        Ok(lowered)
    }
}

impl RoundStep for Step1Rounds<'_> {
    const STAGE: PredictStage = PredictStage::Step1;

    fn max_iterations(&self) -> u64 {
        self.max_iters()
    }

    fn prepare(&mut self, round: usize) {
        if let Some(l) = self.config.box_l {
            if round > 0 {
                hold_in_box(&mut self.w, &mut self.held, l);
            }
        }
    }

    fn measure(&mut self, round: usize) -> Result<Vec<Measured>> {
        if round == 0 {
            self.x.clone_from(&self.start.vertices);
            return Ok(self.start.measured.clone());
        }
        if let Some((x, measured)) = MeasuredShape::of(self.trial.as_ref(), &self.w) {
            self.x = x;
            return Ok(measured);
        }
        self.x = self.model.shape_unchecked(&self.w);
        let measured = self
            .model
            .measure_checked(self.measurer, &self.x, &self.which)?;
        // A round that ends the rounds (no progress, readings met) leaves
        // these weights to the end of the step, which then measures nothing
        // again unless the clamp changes them.
        self.trial = Some(MeasuredShape {
            weights: self.w.clone(),
            vertices: self.x.clone(),
            measured: measured.clone(),
        });
        Ok(measured)
    }

    /// After Gauss-Newton rounds the first continuation round switches
    /// method, so the last rounds' progress says nothing.
    fn comparable(&self, round: usize) -> bool {
        !(self.gauss_newton() && round == self.s)
    }

    fn minimise(
        &mut self,
        round: usize,
        measured: &[Measured],
        at: PredictProgress,
        observer: &dyn PredictObserver,
        log: &mut RoundLog,
    ) -> Result<RoundEnd> {
        let weighting = self.lbfgs().weighting;
        let (terms, owner) = self.model.build_terms_owned(
            self.readings,
            measured,
            &to_mm(&self.x),
            (weighting, 1.0),
            &mut log.warnings,
            PredictStage::Step1,
        );
        if terms.is_empty() {
            return Ok(RoundEnd::NothingToFit);
        }
        // Gauss-Newton in the s regular rounds; continuation rounds (a
        // reading still misses, typically where a support changes too
        // much under the step for the linearisation to hold) are L-BFGS
        // rounds on E_m with the same prior.
        if let Step1Method::GaussNewtonMap {
            max_iters,
            min_decrease,
            ..
        } = self.config.solver
        {
            if round < self.s {
                report(observer, at)?;
                if self.gauss_newton_round(
                    measured,
                    &terms,
                    owner,
                    (max_iters, min_decrease),
                    log,
                )? {
                    return Ok(RoundEnd::Ran);
                }
            }
        }
        let mut lbfgs = self.lbfgs().clone();
        if round >= self.s {
            if let Some(n) = self.continuation_iters {
                lbfgs.solver.stop.max_iters = n;
            }
        }
        let mut obj = self.model.localise(&terms);
        if let Some(tau) = lbfgs.prior.tau_mm(self.readings.any_tolerance()) {
            obj = obj.with_prior(tau * tau);
        }
        if self.held.iter().any(|&h| h) {
            obj = obj.with_held(self.held.clone());
        }
        let watch = in_run(observer, at);
        match minimise_watched(&obj, self.w.clone(), &lbfgs.solver, &watch) {
            Ok((_, info)) if info.reason == Termination::Interrupted => {
                Err(ModelError::Cancelled(at.to_string()))
            }
            Ok((w_new, info)) => {
                self.w = w_new;
                log.runs.push(info);
                Ok(RoundEnd::Ran)
            }
            Err(e) => Ok(RoundEnd::Failed(e)),
        }
    }
}

impl ShapeModel {
    /// Step 1 from `start` (see the module docs): `rounds.s` rounds (and
    /// continuation rounds) over the weights, then the clamp. `observer`
    /// gets every round's boundary and reports from inside the solver runs;
    /// cancelling returns [`ModelError::Cancelled`].
    ///
    /// Errors if measuring fails or the observer cancels; a solver that
    /// cannot start, or a result worse than the start, is a warning.
    pub fn step1(
        &self,
        readings: &Readings,
        start: &StartShape,
        config: &Step1Config,
        rounds: &RoundsConfig,
        measurer: &dyn Measurer,
        observer: &dyn PredictObserver,
    ) -> Result<Step1Shape> {
        let mut held = vec![false; self.n_components()];
        if let Some(k) = config.components {
            held.iter_mut().skip(k).for_each(|h| *h = true);
        }
        // Reading noise (mm) of the Gauss-Newton MAP: tau scaled by each
        // reading's tolerance (weight = (reference / tolerance)^2).
        let map_sd = match config.solver {
            Step1Method::GaussNewtonMap { tau_mm, .. } => {
                readings.iter().map(|g| tau_mm / g.weight.sqrt()).collect()
            }
            Step1Method::Lbfgs(_) => Vec::new(),
        };
        let mut step = Step1Rounds {
            model: self,
            measurer,
            readings,
            which: readings.indices(),
            config,
            s: rounds.s,
            start,
            w: start.weights.clone(),
            held,
            x: Vec::new(),
            map_sd,
            continuation_iters: rounds.continuation.and_then(|c| c.step1_max_iters),
            trial: None,
        };
        let thresholds = thresholds(
            readings,
            &|j| measurer.allowable_error(j),
            rounds.continuation,
        );
        let (log, summary) = run_rounds(&mut step, rounds, readings, &thresholds, observer)?;
        let RoundLog { runs, mut warnings } = log;
        let map_sd = std::mem::take(&mut step.map_sd);
        let mut w = step.w;
        let clamped = clamp_weights(&mut w, config.l);
        let (mut x1, mut meas1) = match MeasuredShape::of(step.trial.as_ref(), &w) {
            Some(done) => done,
            None => {
                let x1 = self.shape_unchecked(&w);
                let meas1 = self.measure_checked(measurer, &x1, &readings.indices())?;
                (x1, meas1)
            }
        };
        // The Gauss-Newton step 1 minimises its own objective, not E_m with
        // per-segment targets, so it is judged by that objective.
        let (err_start, err1, what) = match &config.solver {
            Step1Method::GaussNewtonMap { .. } => {
                let f = |meas: &[Measured], w: &[f64]| map_objective(readings, meas, &map_sd, w);
                (
                    f(&start.measured, &start.weights),
                    f(&meas1, &w),
                    Step1Objective::MapObjective,
                )
            }
            Step1Method::Lbfgs(r) => (
                self.stage_energy(
                    readings,
                    &start.measured,
                    &start.vertices,
                    (r.weighting, 1.0),
                ),
                self.stage_energy(readings, &meas1, &x1, (r.weighting, 1.0)),
                Step1Objective::MeasurementEnergy,
            ),
        };
        if err1 > err_start || err1.is_nan() {
            warnings.push(Warning::Step1KeptStart {
                objective: what,
                end: err1,
                start: err_start,
            });
            w.clone_from(&start.weights);
            x1.clone_from(&start.vertices);
            meas1.clone_from(&start.measured);
        }
        Ok(Step1Shape {
            weights: w,
            clamped,
            vertices: x1,
            measured: meas1,
            runs,
            rounds: summary,
            warnings,
        })
    }
}
