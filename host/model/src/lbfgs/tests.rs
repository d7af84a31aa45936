//! Tests of `lbfgs`, in a file of their own so that the module stays short.

use super::*;
use std::cell::{Cell, RefCell};

struct Rosenbrock;
impl Objective for Rosenbrock {
    fn eval(&self, x: &[f64], g: &mut [f64]) -> f64 {
        let (a, b) = (x[0], x[1]);
        g[0] = -2.0 * (1.0 - a) - 400.0 * a * (b - a * a);
        g[1] = 200.0 * (b - a * a);
        (1.0 - a).powi(2) + 100.0 * (b - a * a).powi(2)
    }
}

const BOTH: [LineSearch; 2] = [LineSearch::Backtracking, LineSearch::StrongWolfe];

fn solver(line_search: LineSearch, stop: StopRule) -> Lbfgs {
    Lbfgs { stop, line_search }
}

#[test]
fn lbfgs_with_paper_rules_solves_rosenbrock() {
    for ls in BOTH {
        let (x, info) = minimise(
            &Rosenbrock,
            vec![-1.2, 1.0],
            &solver(ls, StopRule::default()),
        )
        .unwrap();
        assert!(
            (x[0] - 1.0).abs() < 1e-4 && (x[1] - 1.0).abs() < 1e-4,
            "{ls:?}: {x:?} {info:?}"
        );
        assert!(info.iterations <= 100);
        assert!(info.cost_end < 1e-8, "{ls:?}: {info:?}");
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

fn quad(decades: f64) -> Quad {
    Quad(
        (0..50)
            .map(|i| 10f64.powf(decades * i as f64 / 49.0))
            .collect(),
    )
}

/// A convex quadratic in 50 variables with condition number 100: both
/// line searches reach the minimum within the paper's 100 iterations.
#[test]
fn lbfgs_solves_a_conditioned_quadratic() {
    for ls in BOTH {
        let (x, info) =
            minimise(&quad(2.0), vec![0.0; 50], &solver(ls, StopRule::default())).unwrap();
        let err = x.iter().map(|v| (v - 1.0).abs()).fold(0.0, f64::max);
        assert!(err < 1e-4, "{ls:?}: max error {err}, {info:?}");
    }
}

/// The energy's scale must not matter: the conditioned quadratic times
/// 1e12 (curvature 1e12 to 1e14, as step 1's energies in mm^4 have)
/// takes the same iterations as at scale 1. A curvature-pair test with
/// a fixed tolerance (`s . y > 1e-10 y . y`, as this solver had) drops
/// every pair there and degrades to steepest descent.
#[test]
fn the_energys_scale_does_not_change_the_iterations() {
    for ls in BOTH {
        let run = |scale: f64| {
            let q = Quad(quad(2.0).0.iter().map(|c| c * scale).collect());
            minimise(&q, vec![0.0; 50], &solver(ls, StopRule::default()))
                .unwrap()
                .1
        };
        let (unit, stiff) = (run(1.0), run(1e12));
        assert!(
            stiff.iterations <= unit.iterations + 2,
            "{ls:?}: scale 1e12 {stiff:?} vs scale 1 {unit:?}"
        );
        assert!(
            stiff.cost_end < 1e-9 * stiff.cost_start,
            "{ls:?}: {stiff:?}"
        );
    }
}

#[test]
fn iteration_cap_is_respected() {
    for ls in BOTH {
        let stop = StopRule {
            max_iters: 3,
            ..StopRule::default()
        };
        let (_, info) = minimise(&Rosenbrock, vec![-1.2, 1.0], &solver(ls, stop)).unwrap();
        assert_eq!(info.iterations, 3, "{ls:?}");
        assert_eq!(info.reason, Termination::MaxIterations);
    }
}

struct NanAt;
impl Objective for NanAt {
    fn eval(&self, x: &[f64], g: &mut [f64]) -> f64 {
        g[0] = 2.0 * x[0];
        if x[0] < 0.5 {
            f64::NAN
        } else {
            x[0] * x[0]
        }
    }
}

#[test]
fn non_finite_energy_never_becomes_the_result() {
    for ls in BOTH {
        let s = solver(ls, StopRule::default());
        let (x, info) = minimise(&NanAt, vec![3.0], &s).unwrap();
        assert!(x[0].is_finite() && x[0] >= 0.5, "{ls:?}: {x:?} {info:?}");
        assert!(info.cost_end <= 9.0);
        assert_eq!(
            minimise(&NanAt, vec![0.0], &s).unwrap_err(),
            MinimiseError::NonFiniteStart
        );
    }
}

/// A one-dimensional objective that records every trial point.
struct Traced<'a, O> {
    inner: O,
    trials: &'a RefCell<Vec<(f64, f64, f64)>>,
}
impl<O: Objective> Objective for Traced<'_, O> {
    fn eval(&self, x: &[f64], g: &mut [f64]) -> f64 {
        let f = self.inner.eval(x, g);
        self.trials.borrow_mut().push((x[0], f, g[0]));
        f
    }
}

/// `f(x) = x^4 / 4 - x` (minimum at 1): from 0.1 the unit first step
/// lands far short, from 3 far beyond; every accepted Wolfe step meets
/// both strong Wolfe conditions (checked on the recorded trials).
#[test]
fn strong_wolfe_steps_meet_both_conditions() {
    struct Quartic;
    impl Objective for Quartic {
        fn eval(&self, x: &[f64], g: &mut [f64]) -> f64 {
            g[0] = x[0].powi(3) - 1.0;
            x[0].powi(4) / 4.0 - x[0]
        }
    }
    for x0 in [0.1, 3.0, -2.0] {
        let trials = RefCell::new(Vec::new());
        let obj = Traced {
            inner: Quartic,
            trials: &trials,
        };
        let stop = StopRule {
            max_iters: 1,
            ..StopRule::default()
        };
        let (x, info) = minimise(&obj, vec![x0], &solver(LineSearch::StrongWolfe, stop)).unwrap();
        assert_eq!(info.iterations, 1, "{x0}: {info:?}");
        let t = trials.borrow();
        let (_, f0, g0) = t[0];
        let d = -g0.signum(); // the first direction: unit length along -g
        let a = (x[0] - x0) / d;
        let (_, fa, ga) = *t.iter().find(|p| p.0 == x[0]).unwrap();
        assert!(fa <= f0 + 1e-4 * a * g0 * d, "{x0}: sufficient decrease");
        assert!((ga * d).abs() <= 0.9 * (g0 * d).abs(), "{x0}: curvature");
    }
}

/// With condition number 1e4 neither line search reaches the minimum in
/// 100 iterations; strong Wolfe gets at least as far as backtracking.
#[test]
fn wolfe_keeps_up_with_backtracking_on_a_hard_quadratic() {
    let q = quad(4.0);
    let run = |ls| {
        minimise(&q, vec![0.0; 50], &solver(ls, StopRule::default()))
            .unwrap()
            .1
    };
    let (bt, wolfe) = (run(LineSearch::Backtracking), run(LineSearch::StrongWolfe));
    assert!(wolfe.cost_end < 1e-3 * wolfe.cost_start, "{wolfe:?}");
    assert!(wolfe.cost_end <= 2.0 * bt.cost_end, "{wolfe:?} vs {bt:?}");
}

/// The watcher sees every evaluation number in order; cancelling ends
/// the run at once, with no further evaluation, at a finite iterate.
#[test]
fn cancelling_interrupts_the_run_at_once() {
    for ls in BOTH {
        let evaluated = Cell::new(0u64);
        struct Counting<'a>(&'a Cell<u64>);
        impl Objective for Counting<'_> {
            fn eval(&self, x: &[f64], g: &mut [f64]) -> f64 {
                self.0.set(self.0.get() + 1);
                Rosenbrock.eval(x, g)
            }
        }
        let seen = RefCell::new(Vec::new());
        let watch = |n: u64| {
            seen.borrow_mut().push(n);
            if n == 7 {
                Control::Cancel
            } else {
                Control::Continue
            }
        };
        let (x, info) = minimise_watched(
            &Counting(&evaluated),
            vec![-1.2, 1.0],
            &solver(ls, StopRule::default()),
            &watch,
        )
        .unwrap();
        assert_eq!(info.reason, Termination::Interrupted, "{ls:?}");
        assert_eq!(evaluated.get(), 7, "{ls:?}");
        assert_eq!(*seen.borrow(), (0..=7).collect::<Vec<u64>>());
        assert!(x.iter().all(|v| v.is_finite()));
    }
}

/// Reports written before the reason was an enum read back.
#[test]
fn legacy_reason_texts_read_back() {
    let read = |s: &str| -> Termination {
        serde::Deserialize::deserialize(
            serde::de::value::StrDeserializer::<serde::de::value::Error>::new(s),
        )
        .unwrap()
    };
    assert_eq!(
        read("maximum number of iterations reached"),
        Termination::MaxIterations
    );
    assert_eq!(
        read("Gauss-Newton MAP, step 0.5"),
        Termination::GaussNewton { step: 0.5 }
    );
    assert_eq!(
        read("Solver converged"),
        Termination::Recorded("Solver converged".into())
    );
}
