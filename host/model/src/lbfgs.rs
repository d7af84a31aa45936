//! The one L-BFGS of the prediction (and of the evaluation's SGPLVM), with
//! the paper's stopping rules and two line searches.
//!
//! Written by hand, allocation-free per iteration, because the step-2
//! problem has 41,154 variables (3 V on the template) and argmin's `Vec<f64>`
//! backend allocates a fresh vector for every vector operation (about
//! 4 m + 10 per iteration for history m), which was most of an iteration's
//! time there. argmin stays the reference this solver is tested against
//! (`tests/lbfgs_reference.rs`, a dev-dependency); nothing in production
//! runs it.
//!
//! * **Stopping** ([`StopRule`], the paper's three rules): relative energy
//!   change below `rel_cost_tol` (paper: `1e8` machine epsilons), gradient
//!   norm below `grad_tol` (1e-8), or `max_iters` iterations (100). Why a
//!   run ended is a [`Termination`].
//! * **Line search** ([`LineSearch`]): [`LineSearch::Backtracking`] (Armijo
//!   with safeguarded quadratic interpolation) is what step 2 runs: on its
//!   smooth vertex energy L-BFGS's unit step is accepted almost always
//!   (about 1.3 evaluations per iteration), so a cheaper test buys nothing
//!   to give up. [`LineSearch::StrongWolfe`] (bracketing and zoom with
//!   cubic interpolation, Nocedal & Wright algorithms 3.5 and 3.6) is what
//!   step 1 runs: its energy over the weights is stiff and quartic, where
//!   backtracking takes steps too short to build a useful curvature
//!   history; the curvature condition makes every pair `s . y > 0` and the
//!   steps long enough, as argmin's More-Thuente search did before (measured
//!   against it in `tests/lbfgs_reference.rs` and on the paper's pipeline in
//!   `docs/results/predict-sreal.md`).
//! * **Interrupting**: [`minimise_watched`] asks a watcher before every
//!   objective evaluation; when it answers [`Control::Cancel`], the run ends
//!   at once with [`Termination::Interrupted`] and the best point so far
//!   (the prediction then returns "cancelled" and no body).
//!
//! Non-finite energies never become the result: a non-finite trial point
//! counts as "no decrease" (backtracking) or as "too far" (Wolfe), and a
//! run whose start is not finite is a [`MinimiseError`].

/// What a watcher asks a running solver (or prediction) to do next.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Control {
    /// Go on.
    Continue,
    /// Stop as soon as possible.
    Cancel,
}

/// A smooth objective: returns `f(x)` and writes `df/dx` into `grad`.
pub trait Objective {
    /// Evaluates the objective at `x`; `grad` has the length of `x`.
    fn eval(&self, x: &[f64], grad: &mut [f64]) -> f64;
}

/// Stopping rules and memory of one L-BFGS run.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct StopRule {
    /// At most this many iterations (paper: 100).
    pub max_iters: u64,
    /// Stop when the gradient's Euclidean norm is below this (paper: 1e-8;
    /// energies in mm^4, gradients per mm or per normalised weight).
    pub grad_tol: f64,
    /// Stop when `|f_prev - f| <= rel_cost_tol * max(|f_prev|, |f|)`
    /// (paper: `1e8 * f64::EPSILON`, about 2.2e-8).
    pub rel_cost_tol: f64,
    /// Number of correction pairs L-BFGS keeps (at least 1).
    pub history: usize,
}

impl Default for StopRule {
    fn default() -> Self {
        Self {
            max_iters: 100,
            grad_tol: 1e-8,
            rel_cost_tol: 1e8 * f64::EPSILON,
            history: 7,
        }
    }
}

/// The line search of an L-BFGS run (see the module docs).
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub enum LineSearch {
    /// Armijo backtracking (`c1 = 1e-4`) with safeguarded quadratic
    /// interpolation, at most 40 trials.
    Backtracking,
    /// Strong Wolfe conditions (`c1 = 1e-4`, `c2 = 0.9`): bracketing with
    /// extrapolation, then zoom with safeguarded cubic interpolation, at
    /// most [`WOLFE_MAX_EVALUATIONS`] trials.
    StrongWolfe,
}

/// An L-BFGS solver: stopping rules, memory and line search.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Lbfgs {
    /// Stopping rules and history.
    pub stop: StopRule,
    /// The line search.
    pub line_search: LineSearch,
}

/// Why a solver run ended.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub enum Termination {
    /// The gradient norm fell below `grad_tol`.
    GradientBelowTolerance,
    /// The relative energy change fell below `rel_cost_tol`.
    RelativeChangeBelowTolerance,
    /// `max_iters` iterations were done.
    MaxIterations,
    /// The line search found no acceptable step (the run ends at its best
    /// point).
    LineSearchFailed,
    /// The watcher answered [`Control::Cancel`].
    Interrupted,
    /// There was nothing to move (no variables).
    NoVariables,
    /// A Gauss-Newton MAP round of step 1 (`crate::map`): the share
    /// `step` of the full Gauss-Newton step was accepted on the re-measured
    /// objective.
    GaussNewton {
        /// Accepted share of the Gauss-Newton step, in (0, 1].
        step: f64,
    },
    /// A Gauss-Newton MAP round whose step lowered no re-measured
    /// objective; the round ran L-BFGS on `E_m` instead (the next run).
    GaussNewtonFellBack,
    /// A step gained, or the Gauss-Newton model promised, less energy than
    /// a small error on one reading costs (the smooth basis's
    /// `min_decrease_mm`, [`crate::reduced::minimise_reduced`]).
    DecreaseBelowReading,
    /// Read from a report of an older version that recorded the reason as
    /// text this version does not know.
    Recorded(String),
}

impl std::fmt::Display for Termination {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Self::GradientBelowTolerance => f.write_str("gradient norm below tolerance"),
            Self::RelativeChangeBelowTolerance => {
                f.write_str("relative energy change below tolerance")
            }
            Self::MaxIterations => f.write_str("maximum number of iterations reached"),
            Self::LineSearchFailed => f.write_str("line search found no decrease"),
            Self::Interrupted => f.write_str("interrupted"),
            Self::NoVariables => f.write_str("no variables"),
            Self::GaussNewton { step } => write!(f, "Gauss-Newton MAP, step {step}"),
            Self::GaussNewtonFellBack => f.write_str(
                "Gauss-Newton MAP: no step lowered the re-measured objective; L-BFGS on E_m this round",
            ),
            Self::DecreaseBelowReading => {
                f.write_str("energy change below what a reading error of min_decrease_mm costs")
            }
            Self::Recorded(text) => f.write_str(text),
        }
    }
}

/// Reports of older versions stored the reason as text (one of the
/// built-in solver's, argmin's or the Gauss-Newton round's): read those
/// back as the variant they name, anything else as [`Termination::Recorded`].
impl<'de> serde::Deserialize<'de> for Termination {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        #[derive(serde::Deserialize)]
        enum Tagged {
            GradientBelowTolerance,
            RelativeChangeBelowTolerance,
            MaxIterations,
            LineSearchFailed,
            Interrupted,
            NoVariables,
            GaussNewton { step: f64 },
            GaussNewtonFellBack,
            DecreaseBelowReading,
            Recorded(String),
        }
        #[derive(serde::Deserialize)]
        #[serde(untagged)]
        enum Wire {
            Tagged(Tagged),
            Text(String),
        }
        Ok(match Wire::deserialize(d)? {
            Wire::Tagged(t) => match t {
                Tagged::GradientBelowTolerance => Self::GradientBelowTolerance,
                Tagged::RelativeChangeBelowTolerance => Self::RelativeChangeBelowTolerance,
                Tagged::MaxIterations => Self::MaxIterations,
                Tagged::LineSearchFailed => Self::LineSearchFailed,
                Tagged::Interrupted => Self::Interrupted,
                Tagged::NoVariables => Self::NoVariables,
                Tagged::GaussNewton { step } => Self::GaussNewton { step },
                Tagged::GaussNewtonFellBack => Self::GaussNewtonFellBack,
                Tagged::DecreaseBelowReading => Self::DecreaseBelowReading,
                Tagged::Recorded(s) => Self::Recorded(s),
            },
            Wire::Text(s) => Self::from_legacy_text(s),
        })
    }
}

impl Termination {
    /// The variant an older version's text names (see the Deserialize impl).
    fn from_legacy_text(s: String) -> Self {
        match s.as_str() {
            "gradient norm below tolerance" => Self::GradientBelowTolerance,
            "relative energy change below tolerance" => Self::RelativeChangeBelowTolerance,
            "maximum number of iterations reached" | "Maximum number of iterations reached" => {
                Self::MaxIterations
            }
            "line search found no decrease" => Self::LineSearchFailed,
            "no variables" => Self::NoVariables,
            t if t.starts_with("Gauss-Newton MAP: no step") => Self::GaussNewtonFellBack,
            t => match t
                .strip_prefix("Gauss-Newton MAP, step ")
                .and_then(|x| x.parse().ok())
            {
                Some(step) => Self::GaussNewton { step },
                None => Self::Recorded(s),
            },
        }
    }
}

/// What one solver run did.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct RunInfo {
    /// Iterations performed.
    pub iterations: u64,
    /// Objective evaluations (cost and gradient together; for a
    /// Gauss-Newton round, its iterations plus the re-measurements of its
    /// backtracking).
    pub evaluations: u64,
    /// Energy at the start point.
    pub cost_start: f64,
    /// Energy at the returned point.
    pub cost_end: f64,
    /// Why it stopped.
    pub reason: Termination,
}

/// Why a run could not start.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum MinimiseError {
    /// The energy or its gradient is NaN or infinite at the start point.
    #[error("at the start point: energy or gradient is not finite")]
    NonFiniteStart,
    /// The Gauss-Newton system could not be analysed (out of memory).
    #[error("the Gauss-Newton system could not be factorised (out of memory)")]
    NoFactorisation,
}

/// Most trial points of one strong-Wolfe line search.
pub const WOLFE_MAX_EVALUATIONS: usize = 20;

/// Minimises `obj` from `x0` (see the module docs); returns the best point
/// seen and what the run did.
///
/// Errors if the objective is not finite at `x0`. A failed line search
/// ends the run at the best point so far, with the reason recorded.
pub fn minimise(
    obj: &dyn Objective,
    x0: Vec<f64>,
    solver: &Lbfgs,
) -> Result<(Vec<f64>, RunInfo), MinimiseError> {
    minimise_watched(obj, x0, solver, &|_| Control::Continue)
}

/// [`minimise`], asking `watch(n)` before the objective's evaluation number
/// `n` (0-based, counted over the run): [`Control::Cancel`] ends the run at
/// once with [`Termination::Interrupted`] at the current iterate (before
/// the first evaluation: `x0`, with costs NaN).
pub fn minimise_watched(
    obj: &dyn Objective,
    x0: Vec<f64>,
    solver: &Lbfgs,
    watch: &dyn Fn(u64) -> Control,
) -> Result<(Vec<f64>, RunInfo), MinimiseError> {
    Run::new(obj, x0, solver, watch)?.solve()
}

/// Dot product with four independent partial sums: a plain `sum()` is one
/// serial dependency chain (floating-point addition is not reassociated), and
/// the two-loop recursion over 41k variables is mostly dot products.
pub(crate) fn dot(a: &[f64], b: &[f64]) -> f64 {
    dot_widened(a, b)
}

/// [`dot`] with `a`'s entries widened to f64 first (`T` = f32 or f64): for
/// f32 entries the same sums, in the same order, as [`dot`] of their f64
/// values, so the result is bit for bit the same.
pub(crate) fn dot_widened<T: Copy + Into<f64>>(a: &[T], b: &[f64]) -> f64 {
    let mut acc = [0.0; 4];
    let (ca, cb) = (a.chunks_exact(4), b.chunks_exact(4));
    let tail: f64 = ca
        .remainder()
        .iter()
        .zip(cb.remainder())
        .map(|(x, y)| (*x).into() * y)
        .sum();
    for (x, y) in ca.zip(cb) {
        for k in 0..4 {
            acc[k] += x[k].into() * y[k];
        }
    }
    (acc[0] + acc[1]) + (acc[2] + acc[3]) + tail
}

/// `y += alpha x`.
pub(crate) fn axpy(alpha: f64, x: &[f64], y: &mut [f64]) {
    for (yi, xi) in y.iter_mut().zip(x) {
        *yi += alpha * xi;
    }
}

fn all_finite(v: &[f64]) -> bool {
    v.iter().all(|x| x.is_finite())
}

/// `y += alpha x`, returning `z . y` (after the update) in the same pass.
fn axpy_dot(alpha: f64, x: &[f64], y: &mut [f64], z: &[f64]) -> f64 {
    let mut acc = [0.0; 4];
    let n4 = y.len() / 4 * 4;
    for j in (0..n4).step_by(4) {
        for k in 0..4 {
            let v = y[j + k] + alpha * x[j + k];
            y[j + k] = v;
            acc[k] += z[j + k] * v;
        }
    }
    let mut tail = 0.0;
    for j in n4..y.len() {
        y[j] += alpha * x[j];
        tail += z[j] * y[j];
    }
    (acc[0] + acc[1]) + (acc[2] + acc[3]) + tail
}

/// The objective with the run's evaluation count and watcher.
struct Counted<'a> {
    obj: &'a dyn Objective,
    watch: &'a dyn Fn(u64) -> Control,
    evaluations: u64,
}

/// An evaluation the watcher refused.
struct Interrupt;

impl Counted<'_> {
    fn eval(&mut self, x: &[f64], g: &mut [f64]) -> Result<f64, Interrupt> {
        if (self.watch)(self.evaluations) == Control::Cancel {
            return Err(Interrupt);
        }
        self.evaluations += 1;
        Ok(self.obj.eval(x, g))
    }
}

/// How a line search ended: the accepted point is in `x_new`, `g_new`.
enum Step {
    Accepted(f64),
    Failed,
    Interrupted,
}

/// One L-BFGS run: the iterate, the ring of correction pairs and the
/// scratch buffers, all allocated once (see the module docs).
struct Run<'a> {
    f_obj: Counted<'a>,
    line_search: LineSearch,
    stop: StopRule,
    x: Vec<f64>,
    g: Vec<f64>,
    f: f64,
    f0: f64,
    x_new: Vec<f64>,
    g_new: Vec<f64>,
    d: Vec<f64>,
    /// Wolfe's best trial so far (its bracket's low end).
    x_lo: Vec<f64>,
    g_lo: Vec<f64>,
    s_hist: Vec<Vec<f64>>,
    y_hist: Vec<Vec<f64>>,
    rho: Vec<f64>,
    gamma_hist: Vec<f64>,
    head: usize,
    len: usize,
}

impl<'a> Run<'a> {
    fn new(
        obj: &'a dyn Objective,
        x0: Vec<f64>,
        solver: &Lbfgs,
        watch: &'a dyn Fn(u64) -> Control,
    ) -> Result<Self, MinimiseError> {
        let n = x0.len();
        let m = solver.stop.history.max(1);
        let wolfe = solver.line_search == LineSearch::StrongWolfe;
        let scratch = |on: bool| if on { vec![0.0; n] } else { Vec::new() };
        Ok(Self {
            f_obj: Counted {
                obj,
                watch,
                evaluations: 0,
            },
            line_search: solver.line_search,
            stop: solver.stop,
            g: vec![0.0; n],
            x: x0,
            f: f64::NAN,
            f0: f64::NAN,
            x_new: vec![0.0; n],
            g_new: vec![0.0; n],
            d: vec![0.0; n],
            x_lo: scratch(wolfe),
            g_lo: scratch(wolfe),
            s_hist: (0..m).map(|_| vec![0.0; n]).collect(),
            y_hist: (0..m).map(|_| vec![0.0; n]).collect(),
            rho: vec![0.0; m],
            gamma_hist: vec![0.0; m],
            head: 0,
            len: 0,
        })
    }

    fn info(&self, iterations: u64, reason: Termination) -> RunInfo {
        RunInfo {
            iterations,
            evaluations: self.f_obj.evaluations,
            cost_start: self.f0,
            cost_end: self.f,
            reason,
        }
    }

    /// The iterations (Nocedal & Wright, algorithm 7.5 with 7.4).
    fn solve(mut self) -> Result<(Vec<f64>, RunInfo), MinimiseError> {
        let n = self.x.len();
        match self.f_obj.eval(&self.x, &mut self.g) {
            Err(Interrupt) => {
                let info = self.info(0, Termination::Interrupted);
                return Ok((self.x, info));
            }
            Ok(f) => {
                self.f = f;
                self.f0 = f;
            }
        }
        if !self.f.is_finite() || !all_finite(&self.g) {
            return Err(MinimiseError::NonFiniteStart);
        }
        let (mut s_new, mut y_new) = (vec![0.0; n], vec![0.0; n]);
        let mut iterations = 0u64;
        let reason = loop {
            let gnorm = dot(&self.g, &self.g).sqrt();
            if n == 0 {
                break Termination::NoVariables;
            }
            if gnorm < self.stop.grad_tol {
                break Termination::GradientBelowTolerance;
            }
            if iterations >= self.stop.max_iters {
                break Termination::MaxIterations;
            }
            let mut gd = self.direction(gnorm);
            if gd >= 0.0 || !gd.is_finite() {
                // Not a descent direction: forget the history, step along -g.
                self.len = 0;
                for (di, gi) in self.d.iter_mut().zip(&self.g) {
                    *di = -gi / gnorm;
                }
                gd = -gnorm;
            }
            let step = match self.line_search {
                LineSearch::Backtracking => self.backtrack(gd),
                LineSearch::StrongWolfe => self.wolfe(gd),
            };
            let f_new = match step {
                Step::Accepted(f_new) => f_new,
                Step::Failed => break Termination::LineSearchFailed,
                Step::Interrupted => break Termination::Interrupted,
            };
            iterations += 1;
            // New correction pair s = x_new - x, y = g_new - g, kept only if
            // s . y > eps y . y (L-BFGS-B's test: the pair must add positive
            // curvature; s . y / y . y is the inverse curvature along s, which
            // is tiny but real on stiff energies, so the threshold is
            // machine epsilon, not a fixed tolerance).
            let (mut sy, mut yy) = (0.0, 0.0);
            for j in 0..n {
                let (sj, yj) = (self.x_new[j] - self.x[j], self.g_new[j] - self.g[j]);
                s_new[j] = sj;
                y_new[j] = yj;
                sy += sj * yj;
                yy += yj * yj;
            }
            if sy > f64::EPSILON * yy && sy > 0.0 {
                let m = self.rho.len();
                let k = if self.len < m {
                    self.len += 1;
                    (self.head + self.len - 1) % m
                } else {
                    let k = self.head;
                    self.head = (self.head + 1) % m;
                    k
                };
                std::mem::swap(&mut self.s_hist[k], &mut s_new);
                std::mem::swap(&mut self.y_hist[k], &mut y_new);
                self.rho[k] = 1.0 / sy;
                self.gamma_hist[k] = sy / yy;
            }
            std::mem::swap(&mut self.x, &mut self.x_new);
            std::mem::swap(&mut self.g, &mut self.g_new);
            let f_old = self.f;
            self.f = f_new;
            if (f_old - self.f).abs() <= self.stop.rel_cost_tol * f_old.abs().max(self.f.abs()) {
                break Termination::RelativeChangeBelowTolerance;
            }
        };
        let info = self.info(iterations, reason);
        Ok((self.x, info))
    }

    /// Two-loop recursion, `d = -H g`; returns `g . d`. Without history the
    /// first step is of unit length along `-g`.
    ///
    /// The recursion is the textbook one (Nocedal & Wright, algorithm 7.4)
    /// with each update pass fused with the dot product the next step
    /// needs, and `s . y`, `y . y` kept per pair: 2m + 2 passes over the
    /// variables per iteration instead of 4m + 5.
    fn direction(&mut self, gnorm: f64) -> f64 {
        let (len, m, head) = (self.len, self.rho.len(), self.head);
        let slot = |i: usize| (head + i) % m;
        let (d, g) = (&mut self.d, &self.g);
        let (s_hist, y_hist, rho) = (&self.s_hist, &self.y_hist, &self.rho);
        d.copy_from_slice(g);
        if len == 0 {
            let inv = 1.0 / gnorm;
            let mut gd = 0.0;
            for (di, gi) in d.iter_mut().zip(g) {
                *di = -gi * inv;
                gd += gi * *di;
            }
            return gd;
        }
        let mut alpha = [0.0; 64];
        let mut alpha_big;
        let alpha: &mut [f64] = if m <= alpha.len() {
            &mut alpha[..m]
        } else {
            alpha_big = vec![0.0; m];
            &mut alpha_big
        };
        // First loop, newest to oldest: alpha_i = rho_i s_i . q; q -= alpha_i y_i.
        let gamma = self.gamma_hist[slot(len - 1)];
        let mut a = rho[slot(len - 1)] * dot(&s_hist[slot(len - 1)], d);
        for t in (0..len).rev() {
            let k = slot(t);
            alpha[k] = a;
            if t > 0 {
                let kn = slot(t - 1);
                a = rho[kn] * axpy_dot(-alpha[k], &y_hist[k], d, &s_hist[kn]);
            }
        }
        // The oldest pair's update, the scaling by gamma and the first
        // dot product of the second loop in one pass.
        let k0 = slot(0);
        let mut b = 0.0;
        {
            let (y0, a0) = (&y_hist[k0], alpha[k0]);
            for (dj, yj) in d.iter_mut().zip(y0) {
                *dj = gamma * (*dj - a0 * yj);
                b += yj * *dj;
            }
        }
        let mut beta = rho[k0] * b;
        // Second loop, oldest to newest: r += (alpha_i - beta_i) s_i.
        for t in 0..len - 1 {
            let k = slot(t);
            let kn = slot(t + 1);
            beta = rho[kn] * axpy_dot(alpha[k] - beta, &s_hist[k], d, &y_hist[kn]);
        }
        // Last update, negation and g . d in one pass.
        let kl = slot(len - 1);
        let coef = alpha[kl] - beta;
        let mut gd = 0.0;
        for ((dj, sj), gj) in d.iter_mut().zip(&s_hist[kl]).zip(g) {
            *dj = -(*dj + coef * sj);
            gd += gj * *dj;
        }
        gd
    }

    /// Evaluates the trial point `x + step d` into `x_new`, `g_new`.
    fn trial(&mut self, step: f64) -> Result<f64, Interrupt> {
        for ((xn, xi), di) in self.x_new.iter_mut().zip(&self.x).zip(&self.d) {
            *xn = xi + step * di;
        }
        self.f_obj.eval(&self.x_new, &mut self.g_new)
    }

    /// Armijo backtracking (`c1 = 1e-4`) with safeguarded quadratic
    /// interpolation; a non-finite trial energy counts as "no decrease".
    fn backtrack(&mut self, gd: f64) -> Step {
        let f = self.f;
        let mut step = 1.0;
        for _ in 0..40 {
            let Ok(f_new) = self.trial(step) else {
                return Step::Interrupted;
            };
            if f_new.is_finite() && all_finite(&self.g_new) && f_new <= f + 1e-4 * step * gd {
                return Step::Accepted(f_new);
            }
            step = if f_new.is_finite() {
                let q = -gd * step * step / (2.0 * (f_new - f - gd * step));
                if q.is_finite() {
                    q.clamp(0.1 * step, 0.5 * step)
                } else {
                    0.5 * step
                }
            } else {
                0.1 * step
            };
        }
        Step::Failed
    }

    /// A strong-Wolfe line search (Nocedal & Wright, algorithms 3.5 and
    /// 3.6, written as one loop over a bracket): extrapolate until the
    /// step is bracketed, then zoom with safeguarded cubic interpolation.
    /// `phi(a) = f(x + a d)`; a non-finite trial is treated as too far (it
    /// bounds the bracket from above). If the budget runs out, the best
    /// point with sufficient decrease (the bracket's low end) is taken, if
    /// there is one.
    fn wolfe(&mut self, gd0: f64) -> Step {
        const C1: f64 = 1e-4;
        const C2: f64 = 0.9;
        let f0 = self.f;
        // The bracket's low end: of the trials with sufficient decrease the
        // one with the lowest value (a = 0 at first), with value and slope;
        // the high end once one is known.
        let mut lo = (0.0, f0, gd0);
        let mut hi: Option<(f64, f64, f64)> = None;
        let mut a = 1.0;
        for _ in 0..WOLFE_MAX_EVALUATIONS {
            let Ok(fa) = self.trial(a) else {
                return Step::Interrupted;
            };
            let finite = fa.is_finite() && all_finite(&self.g_new);
            let da = if finite {
                dot(&self.g_new, &self.d)
            } else {
                f64::NAN
            };
            let prev = lo;
            if !finite || fa > f0 + C1 * a * gd0 || fa >= lo.1 {
                // Too far: [lo, a] brackets an acceptable step.
                hi = Some((a, fa, da));
            } else {
                if da.abs() <= -C2 * gd0 {
                    return Step::Accepted(fa);
                }
                let turned = match hi {
                    None => da >= 0.0,
                    Some((h, _, _)) => da * (h - a) >= 0.0,
                };
                if turned {
                    // The slope changed sign: a and the old low end bracket.
                    hi = Some(lo);
                }
                lo = (a, fa, da);
                self.x_lo.copy_from_slice(&self.x_new);
                self.g_lo.copy_from_slice(&self.g_new);
            }
            a = match hi {
                // Still descending beyond every trial: extrapolate.
                None => next_extrapolation(prev, lo),
                Some(h) => {
                    if (h.0 - lo.0).abs() <= 1e-12 * lo.0.abs().max(1e-12) {
                        break;
                    }
                    next_in_bracket(lo, h)
                }
            };
        }
        if lo.0 > 0.0 {
            std::mem::swap(&mut self.x_new, &mut self.x_lo);
            std::mem::swap(&mut self.g_new, &mut self.g_lo);
            Step::Accepted(lo.1)
        } else {
            Step::Failed
        }
    }
}

/// Minimiser of the cubic through `(a, fa, da)` and `(b, fb, db)`, if it
/// exists (Nocedal & Wright, equation 3.59).
fn cubic_min(a: f64, fa: f64, da: f64, b: f64, fb: f64, db: f64) -> Option<f64> {
    let d1 = da + db - 3.0 * (fa - fb) / (a - b);
    let disc = d1 * d1 - da * db;
    if disc.is_nan() || disc < 0.0 {
        return None;
    }
    let d2 = (b - a).signum() * disc.sqrt();
    let t = b - (b - a) * (db + d2 - d1) / (db - da + 2.0 * d2);
    t.is_finite().then_some(t)
}

/// The next trial beyond `last` (the newest trial, still descending):
/// the minimiser of the cubic through it and the trial before, `prev`
/// (both as (step, value, slope)), kept in `[1.1, 4]` times `last`'s step;
/// four times where the cubic has no minimiser beyond it.
fn next_extrapolation(prev: (f64, f64, f64), last: (f64, f64, f64)) -> f64 {
    let (low, high) = (1.1 * last.0, 4.0 * last.0);
    match cubic_min(prev.0, prev.1, prev.2, last.0, last.1, last.2) {
        Some(t) if t > last.0 => t.clamp(low, high),
        _ => high,
    }
}

/// The next trial inside the bracket between `lo` and `hi` (each as
/// (step, value, slope)): the cubic's minimiser through both ends, kept at
/// least 10 % of the bracket away from either end; bisection where the
/// cubic fails (a non-finite end).
fn next_in_bracket(lo: (f64, f64, f64), hi: (f64, f64, f64)) -> f64 {
    let (a, b) = (lo.0.min(hi.0), lo.0.max(hi.0));
    let (margin_lo, margin_hi) = (a + 0.1 * (b - a), b - 0.1 * (b - a));
    let t = if hi.1.is_finite() && hi.2.is_finite() {
        cubic_min(lo.0, lo.1, lo.2, hi.0, hi.1, hi.2)
    } else {
        None
    };
    match t {
        Some(t) => t.clamp(margin_lo, margin_hi),
        None => 0.5 * (a + b),
    }
}

#[cfg(test)]
mod tests;
