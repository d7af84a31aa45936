//! Progress reports and cancelling of a prediction
//! ([`ShapeModel::predict_observed`]) on the synthetic tube family: the
//! observer sees every stage in order with a non-decreasing fraction that
//! ends at 1, cancelling at a boundary or inside an optimiser run stops the
//! prediction with `ModelError::Cancelled`, and observing changes nothing.

mod common;

use std::cell::{Cell, RefCell};

use common::*;
use tapeshape_measure::Measured;
use tapeshape_mesh::Vec3;
use tapeshape_model::predict::MeasureError;
use tapeshape_model::{
    Control, Measurer, ModelError, PredictConfig, PredictProgress, PredictStage, Round, ShapeModel,
    Target,
};

/// A progress report of step `stage`'s round `index` of `of`.
fn round(stage: PredictStage, index: usize, of: usize) -> (PredictStage, Option<Round>) {
    (stage, Some(Round { index, of }))
}

fn setup() -> (ShapeModel, Vec<Option<Target>>) {
    let model = train(40, 3);
    let mut s = 77;
    let mut truth = random_params(&mut s);
    truth.bump = 0.01;
    let targets = measure_all(&tube(&truth))
        .into_iter()
        .map(|v| Some(Target::exact(v)))
        .collect();
    (model, targets)
}

#[test]
fn progress_is_monotone_covers_every_stage_and_ends_at_one() {
    let (model, targets) = setup();
    let topo = topology();
    let settings = PredictConfig::default();
    let seen: RefCell<Vec<PredictProgress>> = RefCell::new(Vec::new());
    let observer = |p: &PredictProgress| {
        seen.borrow_mut().push(*p);
        Control::Continue
    };
    let observed = model
        .predict_observed(&targets, &TubeMeasurer, &topo, &settings, &observer)
        .unwrap();
    let seen = seen.into_inner();
    let fractions: Vec<f64> = seen.iter().map(|p| p.fraction()).collect();
    for w in fractions.windows(2) {
        assert!(w[1] >= w[0], "fraction went back: {fractions:?}");
    }
    assert_eq!(seen.first().unwrap().stage, PredictStage::Start);
    assert_eq!(seen.last().unwrap().stage, PredictStage::Done);
    assert_eq!(*fractions.last().unwrap(), 1.0);
    assert!(fractions.iter().all(|f| (0.0..=1.0).contains(f)));
    // Every round of both steps is announced at its boundary, in order.
    let boundaries: Vec<(PredictStage, Option<Round>)> = seen
        .iter()
        .filter(|p| {
            p.evaluations == 0 && !matches!(p.stage, PredictStage::Start | PredictStage::Done)
        })
        .map(|p| (p.stage, p.round))
        .collect();
    // Continuation rounds (run >= s) are announced too, one per L-BFGS run.
    let s = settings.rounds().s();
    let (n1, n2) = (
        observed.report.step1_runs.len(),
        observed.report.step2_runs.len(),
    );
    assert!(n1 >= s && n2 >= s, "{n1} and {n2} runs for s = {s}");
    let mut expected: Vec<(PredictStage, Option<Round>)> = (0..n1)
        .map(|run| round(PredictStage::Step1, run, s))
        .collect();
    expected.extend((0..n2).map(|run| round(PredictStage::Step2, run, s)));
    // The first in-run report (evaluation 0) has the same shape as the
    // boundary's; keep one per stage.
    let mut dedup = boundaries.clone();
    dedup.dedup();
    assert_eq!(dedup, expected);
    // Reports from inside the optimiser runs (evaluations > 0) arrive.
    assert!(seen.iter().any(|p| p.evaluations > 0));
    // Observing changes nothing.
    let plain = model
        .predict(&targets, &TubeMeasurer, &topo, &settings)
        .unwrap();
    assert_eq!(plain.vertices, observed.vertices);
}

#[test]
fn cancel_at_each_boundary_stops_there() {
    let (model, targets) = setup();
    let topo = topology();
    let settings = PredictConfig::default();
    let stages = [
        (PredictStage::Start, None),
        round(PredictStage::Step1, 0, 3),
        round(PredictStage::Step1, 2, 3),
        round(PredictStage::Step2, 1, 3),
    ];
    for (stage, rnd) in stages {
        let at = PredictProgress {
            stage,
            round: rnd,
            evaluations: 0,
            max_iterations: 0,
        };
        let later = RefCell::new(0usize);
        let cancelled = RefCell::new(false);
        let observer = |p: &PredictProgress| {
            if *cancelled.borrow() {
                *later.borrow_mut() += 1;
            }
            if (p.stage, p.round) == (stage, rnd) {
                *cancelled.borrow_mut() = true;
                Control::Cancel
            } else {
                Control::Continue
            }
        };
        let r = model.predict_observed(&targets, &TubeMeasurer, &topo, &settings, &observer);
        match r {
            Err(ModelError::Cancelled(stage)) => assert_eq!(stage, at.to_string()),
            other => panic!("cancel at {at}: expected Cancelled, got {other:?}"),
        }
        assert_eq!(
            *later.borrow(),
            0,
            "observer called after cancelling at {at}"
        );
    }
}

/// Counts measurer calls, and those made after the observer cancelled.
struct Counting<'a> {
    cancelled: &'a Cell<bool>,
    calls: Cell<usize>,
    after_cancel: Cell<usize>,
}

impl Measurer for Counting<'_> {
    fn n_measurements(&self) -> usize {
        TubeMeasurer.n_measurements()
    }
    fn measure(&self, vertices: &[Vec3], which: &[usize]) -> Result<Vec<Measured>, MeasureError> {
        self.calls.set(self.calls.get() + 1);
        if self.cancelled.get() {
            self.after_cancel.set(self.after_cancel.get() + 1);
        }
        TubeMeasurer.measure(vertices, which)
    }
}

#[test]
fn cancel_inside_an_optimiser_run_ends_it_at_once() {
    let (model, targets) = setup();
    let topo = topology();
    let settings = PredictConfig::default();
    let never = Cell::new(false);
    let full = Counting {
        cancelled: &never,
        calls: Cell::new(0),
        after_cancel: Cell::new(0),
    };
    model.predict(&targets, &full, &topo, &settings).unwrap();
    // Cancel at the first report from inside step 2's first run.
    let cancelled = Cell::new(false);
    let calls_after = Cell::new(0usize);
    let observer = |p: &PredictProgress| {
        if cancelled.get() {
            calls_after.set(calls_after.get() + 1);
        }
        if p.stage == PredictStage::Step2
            && p.round.is_some_and(|r| r.index == 0)
            && p.evaluations > 0
        {
            cancelled.set(true);
            return Control::Cancel;
        }
        Control::Continue
    };
    let counting = Counting {
        cancelled: &cancelled,
        calls: Cell::new(0),
        after_cancel: Cell::new(0),
    };
    let r = model.predict_observed(&targets, &counting, &topo, &settings, &observer);
    assert!(
        matches!(&r, Err(ModelError::Cancelled(s)) if s == "step 2, round 1 of 3"),
        "{r:?}"
    );
    assert!(cancelled.get(), "step 2 never reported from inside its run");
    // Nothing ran after the cancel: no further report, no further measuring
    // (the remaining rounds and the final checks each measure the mesh).
    assert_eq!(calls_after.get(), 0);
    assert_eq!(counting.after_cancel.get(), 0);
    assert!(counting.calls.get() < full.calls.get());
}

#[test]
fn fraction_is_monotone_over_synthetic_reports() {
    // Within a run the fraction grows with the evaluations and stays below
    // the next run's start, whatever the evaluation count.
    let of = 3;
    let mut reports = vec![PredictProgress::at(PredictStage::Start)];
    // Runs of..of + 2 are continuation rounds: the fraction holds there.
    for step in 0..2 {
        for run in 0..of + 2 {
            for evaluations in [0, 1, 10, 100, 129, 130, 500, 10_000] {
                let stage = if step == 0 {
                    PredictStage::Step1
                } else {
                    PredictStage::Step2
                };
                reports.push(PredictProgress {
                    stage,
                    round: Some(Round { index: run, of }),
                    evaluations,
                    max_iterations: 100,
                });
            }
        }
    }
    reports.push(PredictProgress::at(PredictStage::Done));
    let f: Vec<f64> = reports.iter().map(|p| p.fraction()).collect();
    for w in f.windows(2) {
        assert!(w[1] >= w[0], "{f:?}");
    }
    assert_eq!(f[0], 0.0);
    assert_eq!(*f.last().unwrap(), 1.0);
    assert!(f[f.len() - 2] < 1.0);
}
