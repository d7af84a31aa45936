//! The one L-BFGS of the prediction (`tapeshape_model::lbfgs`) against a
//! reference: argmin's L-BFGS with the More-Thuente line search (what step
//! 1 ran before, a dev-dependency now) under the same paper stopping rules.
//!
//! The built-in solver with the strong-Wolfe line search must reach what
//! the reference reaches, within the paper's 100 iterations, on the
//! classic test function, on ill-conditioned quadratics, and on quartic
//! energies of the step-1 kind (squared differences of squared segment
//! lengths over weights, `tapeshape_model::refine::WeightObjective`).

use std::cell::{Cell, RefCell};

use argmin::core::{
    CostFunction, Error as ArgminError, Executor, Gradient, IterState, Problem, Solver, State,
    TerminationReason, TerminationStatus, KV,
};
use argmin::solver::linesearch::MoreThuenteLineSearch;
use argmin::solver::quasinewton::LBFGS;
use tapeshape_measure::SupportPoint;
use tapeshape_model::energy::SegmentTerm;
use tapeshape_model::lbfgs::{minimise, Lbfgs, LineSearch, Objective, StopRule};
use tapeshape_model::refine::WeightObjective;

struct Cache {
    x: Vec<f64>,
    f: f64,
    g: Vec<f64>,
}

/// argmin problem over an [`Objective`], caching the last evaluation
/// (argmin asks for the cost and the gradient in separate calls).
struct Adapter<'a> {
    obj: &'a dyn Objective,
    cache: RefCell<Option<Cache>>,
    evaluations: &'a Cell<u64>,
}

impl Adapter<'_> {
    fn eval(&self, x: &[f64]) -> Result<(f64, Vec<f64>), ArgminError> {
        if let Some(c) = self.cache.borrow().as_ref() {
            if c.x == x {
                return Ok((c.f, c.g.clone()));
            }
        }
        let mut g = vec![0.0; x.len()];
        let f = self.obj.eval(x, &mut g);
        self.evaluations.set(self.evaluations.get() + 1);
        if !f.is_finite() || g.iter().any(|v| !v.is_finite()) {
            return Err(ArgminError::msg("energy or gradient is not finite"));
        }
        *self.cache.borrow_mut() = Some(Cache {
            x: x.to_vec(),
            f,
            g: g.clone(),
        });
        Ok((f, g))
    }
}

impl CostFunction for Adapter<'_> {
    type Param = Vec<f64>;
    type Output = f64;
    fn cost(&self, x: &Vec<f64>) -> Result<f64, ArgminError> {
        Ok(self.eval(x)?.0)
    }
}

impl Gradient for Adapter<'_> {
    type Param = Vec<f64>;
    type Gradient = Vec<f64>;
    fn gradient(&self, x: &Vec<f64>) -> Result<Vec<f64>, ArgminError> {
        Ok(self.eval(x)?.1)
    }
}

type St = IterState<Vec<f64>, Vec<f64>, (), (), (), f64>;

/// argmin's solver with the paper's stopping rules instead of its own
/// absolute cost test.
struct PaperStop<S> {
    inner: S,
    grad_tol: f64,
    rel_cost_tol: f64,
}

impl<O, S: Solver<O, St>> Solver<O, St> for PaperStop<S> {
    fn name(&self) -> &str {
        "L-BFGS (paper stopping rules)"
    }
    fn init(
        &mut self,
        problem: &mut Problem<O>,
        state: St,
    ) -> Result<(St, Option<KV>), ArgminError> {
        self.inner.init(problem, state)
    }
    fn next_iter(
        &mut self,
        problem: &mut Problem<O>,
        state: St,
    ) -> Result<(St, Option<KV>), ArgminError> {
        self.inner.next_iter(problem, state)
    }
    fn terminate(&mut self, state: &St) -> TerminationStatus {
        if let Some(g) = state.get_gradient() {
            if g.iter().map(|v| v * v).sum::<f64>().sqrt() < self.grad_tol {
                return TerminationStatus::Terminated(TerminationReason::SolverConverged);
            }
        }
        let (prev, cur) = (state.get_prev_cost(), state.get_cost());
        if prev.is_finite()
            && cur.is_finite()
            && (prev - cur).abs() <= self.rel_cost_tol * prev.abs().max(cur.abs())
        {
            return TerminationStatus::Terminated(TerminationReason::SolverConverged);
        }
        TerminationStatus::NotTerminated
    }
}

/// The reference run: (best cost, iterations).
fn argmin_reference(obj: &dyn Objective, x0: Vec<f64>, stop: &StopRule) -> (f64, u64) {
    let evaluations = Cell::new(0);
    let adapter = Adapter {
        obj,
        cache: RefCell::new(None),
        evaluations: &evaluations,
    };
    let f0 = adapter.eval(&x0).expect("finite start").0;
    let lbfgs: LBFGS<_, Vec<f64>, Vec<f64>, f64> =
        LBFGS::new(MoreThuenteLineSearch::new(), stop.history);
    let solver = PaperStop {
        inner: lbfgs,
        grad_tol: stop.grad_tol,
        rel_cost_tol: stop.rel_cost_tol,
    };
    let res = Executor::new(adapter, solver)
        .configure(|s| s.param(x0).max_iters(stop.max_iters))
        .timer(false)
        .run()
        .expect("argmin runs");
    let best = res.state.get_best_cost();
    (best.min(f0), res.state.get_iter())
}

fn ours(obj: &dyn Objective, x0: Vec<f64>, stop: &StopRule) -> (f64, u64) {
    let solver = Lbfgs {
        stop: *stop,
        line_search: LineSearch::StrongWolfe,
    };
    let (_, info) = minimise(obj, x0, &solver).expect("finite start");
    (info.cost_end, info.iterations)
}

struct Rosenbrock;
impl Objective for Rosenbrock {
    fn eval(&self, x: &[f64], g: &mut [f64]) -> f64 {
        let (a, b) = (x[0], x[1]);
        g[0] = -2.0 * (1.0 - a) - 400.0 * a * (b - a * a);
        g[1] = 200.0 * (b - a * a);
        (1.0 - a).powi(2) + 100.0 * (b - a * a).powi(2)
    }
}

struct Quad(Vec<f64>);
impl Objective for Quad {
    fn eval(&self, x: &[f64], g: &mut [f64]) -> f64 {
        let mut f = 0.0;
        for i in 0..x.len() {
            let d = x[i] - 1.0;
            g[i] = self.0[i] * d;
            f += 0.5 * self.0[i] * d * d;
        }
        f
    }
}

#[test]
fn both_solve_rosenbrock_in_similar_iterations() {
    let stop = StopRule::default();
    let (f_ref, it_ref) = argmin_reference(&Rosenbrock, vec![-1.2, 1.0], &stop);
    let (f, it) = ours(&Rosenbrock, vec![-1.2, 1.0], &stop);
    println!("Rosenbrock: argmin {f_ref:.3e} in {it_ref}, ours {f:.3e} in {it}");
    assert!(f_ref < 1e-8 && f < 1e-8);
    assert!(it <= it_ref + 10, "ours {it} iterations, argmin {it_ref}");
}

/// Condition numbers 1e2 to 1e6 in 50 variables, 100 iterations: the
/// built-in solver ends within a factor 2 of argmin's energy (or below).
#[test]
fn ill_conditioned_quadratics_reach_the_references_energy() {
    let stop = StopRule::default();
    for decades in [2.0, 4.0, 6.0] {
        let q = Quad(
            (0..50)
                .map(|i| 10f64.powf(decades * i as f64 / 49.0))
                .collect(),
        );
        let (f_ref, _) = argmin_reference(&q, vec![0.0; 50], &stop);
        let (f, _) = ours(&q, vec![0.0; 50], &stop);
        println!("quadratic 1e{decades}: argmin {f_ref:.3e}, ours {f:.3e}");
        assert!(
            f <= 2.0 * f_ref + 1e-12,
            "1e{decades}: ours {f}, argmin {f_ref}"
        );
    }
}

/// Deterministic numbers in [-0.5, 0.5) (test data only).
fn lcg(s: &mut u64) -> f64 {
    *s = s
        .wrapping_mul(6364136223846793005)
        .wrapping_add(1442695040888963407);
    ((*s >> 11) as f64) / ((1u64 << 53) as f64) - 0.5
}

/// A step-1-like energy: K = 40 weights move 30 local vertices through
/// random "basis rows" (mm per unit weight, a few of them stiff); 20
/// segments between them must reach target lengths, each term
/// `(|d|^2 - l_t^2)^2` (mm^4): stiff and quartic, as step 1's `E_m`.
/// `size` scales the body (mm): 300 gives energies of 1e6-1e8 mm^4 at the
/// start, 1000 those of step 1 on the template (1e8-1e9, gradients 1e10).
fn step1_like(seed: u64, size: f64) -> WeightObjective {
    let (nl, k) = (30usize, 40usize);
    let mut s = seed;
    let rows: Vec<f64> = (0..3 * nl * k)
        .map(|i| {
            let scale = if i % k < 4 { 40.0 } else { 4.0 };
            scale * size / 300.0 * lcg(&mut s)
        })
        .collect();
    let base: Vec<f64> = (0..3 * nl).map(|_| size * lcg(&mut s)).collect();
    let terms: Vec<SegmentTerm> = (0..20)
        .map(|e| {
            let a = (e * 7) % nl;
            let b = (e * 11 + 3) % nl;
            let t = (lcg(&mut s) + 0.5).clamp(0.05, 0.95);
            SegmentTerm {
                p0: SupportPoint::vertex(a as u32),
                p1: SupportPoint {
                    a: b as u32,
                    b: ((b + 1) % nl) as u32,
                    t,
                },
                axis: None,
                target_sq: (size / 300.0 * (150.0 + 100.0 * lcg(&mut s))).powi(2),
                weight: 1.0,
            }
        })
        .collect();
    WeightObjective::new(k, &rows, &base, terms)
}

/// Ten step-1-like energies from the mean shape (w = 0), at two sizes.
/// Within the paper's 100 iterations none is solved and the end energies
/// scatter over decades between solvers (the energies are far from
/// convex), so the claim is on average: the geometric mean of ours over
/// argmin's end energy is at most 1, none is more than 10 times argmin's,
/// and with 1000 iterations both solve every one (energy below 1e-15 mm^4).
/// Measured: geometric mean 0.53 at size 300, 0.41 at size 1000 (where a
/// curvature-pair test with a fixed tolerance, as this solver had, fails).
#[test]
fn step1_like_energies_reach_the_references_energy() {
    for size in [300.0, 1000.0] {
        step1_like_at(size);
    }
}

fn step1_like_at(size: f64) {
    let stop = StopRule::default();
    let long = StopRule {
        max_iters: 1000,
        ..StopRule::default()
    };
    let mut log_ratio = 0.0;
    for seed in 0..10 {
        let obj = step1_like(seed, size);
        let (f_ref, it_ref) = argmin_reference(&obj, vec![0.0; 40], &stop);
        let (f, it) = ours(&obj, vec![0.0; 40], &stop);
        println!(
            "size {size} seed {seed}: argmin {f_ref:.4e} ({it_ref} it), ours {f:.4e} ({it} it)"
        );
        assert!(
            f <= 10.0 * f_ref,
            "size {size} seed {seed}: ours {f}, argmin {f_ref}"
        );
        log_ratio += (f / f_ref).ln() / 10.0;
        let (f_ref, _) = argmin_reference(&obj, vec![0.0; 40], &long);
        let (f, _) = ours(&obj, vec![0.0; 40], &long);
        assert!(
            f < 1e-15 && f_ref < 1e-15,
            "size {size} seed {seed}: ours {f}, argmin {f_ref}"
        );
    }
    println!(
        "size {size}: geometric mean of ours / argmin {:.3}",
        log_ratio.exp()
    );
    assert!(
        log_ratio <= 0.0,
        "size {size}: geometric mean ratio {}",
        log_ratio.exp()
    );
}
