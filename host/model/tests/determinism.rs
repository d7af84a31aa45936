//! Predictions are deterministic: the same readings give bit-identical
//! vertices and reports (all but the stage times), whatever the machine is
//! doing meanwhile. This matters where the continuation's budget ends the
//! rounds: it counts objective evaluations, so under load the same rounds
//! run (a wall-clock budget, as before, stopped earlier on a busy machine).

mod common;

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;

use common::*;
use tapeshape_model::predict::{Continuation, RoundsStop, Step1Solver, Step2Solver};
use tapeshape_model::{PredictSettings, Prediction, ShapeModel, StageTimings, Target};

fn setup() -> (ShapeModel, Vec<Option<Target>>) {
    let model = train(60, 5);
    let mut s = 777;
    let mut truth = random_params(&mut s);
    truth.bump = 0.02;
    let targets = measure_all(&tube(&truth))
        .into_iter()
        .map(|v| Some(Target::exact(v)))
        .collect();
    (model, targets)
}

/// Short rounds (5 iterations) and a demanding continuation, so that the
/// continuation runs many rounds; `max_evaluations` per step.
fn settings(max_evaluations: u64) -> PredictSettings {
    let mut s = PredictSettings {
        s: 1,
        continuation: Some(Continuation {
            max_extra_rounds: 30,
            share: 0.001,
            default_allowable_mm: 1.0,
            max_evaluations,
            step1_max_iters: None,
        }),
        ..PredictSettings::default()
    };
    s.step1.solver = Step1Solver::Lbfgs { prior_mm: None };
    s.step1.stop.max_iters = 5;
    // L-BFGS (the default) capped at 5 iterations leaves readings off, so
    // the continuation runs until its budget (Gauss-Newton would meet them).
    s.step2.solver = Step2Solver::paper();
    *s.step2.solver.max_iters_mut() = 5;
    s
}

fn predict(model: &ShapeModel, targets: &[Option<Target>], s: &PredictSettings) -> Prediction {
    model
        .predict(targets, &TubeMeasurer, &topology(), &s.resolve().unwrap())
        .unwrap()
}

/// `p` with the stage times zeroed (the only wall-clock values).
fn untimed(mut p: Prediction) -> Prediction {
    p.report.timings = StageTimings::default();
    p
}

/// Runs `f` while `n` threads spin.
fn busy<T>(n: usize, f: impl FnOnce() -> T) -> T {
    let stop = Arc::new(AtomicBool::new(false));
    let spinners: Vec<_> = (0..n)
        .map(|_| {
            let stop = stop.clone();
            std::thread::spawn(move || {
                let mut x = 0u64;
                while !stop.load(Ordering::Relaxed) {
                    x = std::hint::black_box(x.wrapping_mul(31).wrapping_add(7));
                }
            })
        })
        .collect();
    let out = f();
    stop.store(true, Ordering::Relaxed);
    for s in spinners {
        s.join().unwrap();
    }
    out
}

#[test]
fn the_same_readings_give_bit_identical_predictions_under_load() {
    let (model, targets) = setup();
    // How much work the rounds take unbounded, then a budget of half that,
    // so that the budget is what ends step 2's continuation.
    let free = predict(&model, &targets, &settings(u64::MAX));
    let used = free.report.step2_rounds.unwrap();
    assert!(used.rounds > 2, "{used:?}");
    let tight = settings(used.evaluations / 2);
    let quiet = untimed(predict(&model, &targets, &tight));
    let summary = quiet.report.step2_rounds.unwrap();
    assert_eq!(summary.stopped, RoundsStop::Budget, "{summary:?}");
    assert!(summary.rounds < used.rounds, "{summary:?} vs {used:?}");
    let cores = std::thread::available_parallelism().map_or(2, |n| n.get());
    let loaded = untimed(busy(cores, || predict(&model, &targets, &tight)));
    assert_eq!(quiet.vertices, loaded.vertices);
    assert_eq!(quiet.report, loaded.report);
    // And the unbounded run again, for good measure.
    let again = untimed(busy(cores, || {
        predict(&model, &targets, &settings(u64::MAX))
    }));
    assert_eq!(untimed(free).report, again.report);
}

/// Step 2 by sparse Gauss-Newton (faer's Cholesky on one thread, the kept
/// factor's conjugate gradients) gives bit-identical predictions too, with
/// other threads spinning.
#[test]
fn gauss_newton_step_2_is_bit_identical_under_load() {
    let (model, targets) = setup();
    let mut s = PredictSettings::default();
    s.step2.solver = Step2Solver::GaussNewton {
        stop: Default::default(),
    };
    let quiet = untimed(predict(&model, &targets, &s));
    let cores = std::thread::available_parallelism().map_or(2, |n| n.get());
    let loaded = untimed(busy(cores, || predict(&model, &targets, &s)));
    assert_eq!(quiet.vertices, loaded.vertices);
    assert_eq!(quiet.report, loaded.report);
}

/// Step 2 in the smooth basis (the basis computed once per process, the
/// reduced Gauss-Newton on one thread) gives bit-identical predictions
/// too, with other threads spinning, and for both of its fits.
#[test]
fn smooth_basis_step_2_is_bit_identical_under_load() {
    use tapeshape_model::SmoothFit;
    let (model, targets) = setup();
    for fit in [SmoothFit::Readings, SmoothFit::Segments] {
        let mut s = PredictSettings::default();
        // The tube has 12 x 16 vertices: 60 modes.
        s.step2.solver = Step2Solver::SmoothBasis {
            modes: 60,
            fit,
            polish: 0,
            stop: Default::default(),
            min_decrease_mm: tapeshape_model::DEFAULT_SMOOTH_MIN_DECREASE_MM,
        };
        let quiet = untimed(predict(&model, &targets, &s));
        let cores = std::thread::available_parallelism().map_or(2, |n| n.get());
        let loaded = untimed(busy(cores, || predict(&model, &targets, &s)));
        assert_eq!(quiet.vertices, loaded.vertices, "{fit:?}");
        assert_eq!(quiet.report, loaded.report, "{fit:?}");
    }
}
