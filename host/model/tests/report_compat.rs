//! Reports written before the settings had one part per stage still read
//! back. `data/report-v1.json` is the `prediction` part of
//! `tapeshape predict --measure stature=176.5cm --measure chest=98cm
//! --measure waist=84cm --measure hip=100cm --tolerance chest=10mm --report`
//! as the program wrote it at commit 4bfd6cb (default settings, one flat
//! settings record, run reasons as text).

use tapeshape_model::predict::{
    Continuation, PredictSettings, Step1Clamp, Step1Solver, Step2Solver, Step2Weighting,
};
use tapeshape_model::{PredictionReport, Termination};

const V1: &str = include_str!("data/report-v1.json");

#[test]
fn a_report_of_the_flat_settings_record_reads_back_as_the_default() {
    let r: PredictionReport = serde_json::from_str(V1).expect("an old report reads back");
    // The old record held that day's default in its own form; the L-BFGS
    // implementation switches are gone and the wall-clock budget became
    // the evaluation budget. Its step 2 ran L-BFGS: it reads back as that
    // (the one solver there was), whatever the default is now.
    let mut then = PredictSettings::default();
    then.step2.solver = Step2Solver::paper();
    // Nor did it try another solver first, smooth out folds, or move soft
    // targets in step 2.
    then.step2.first = None;
    then.step2.fold_repair = false;
    then.step2.soft_pull = 0.0;
    // And its step-1 continuation rounds ran step 1's own iteration cap,
    // and its Gauss-Newton rounds measured every step.
    if let Some(c) = then.continuation.as_mut() {
        c.step1_max_iters = None;
    }
    then.step1.solver = Step1Solver::GaussNewtonMap {
        tau_mm: None,
        min_decrease_mm: 0.0,
    };
    assert_eq!(r.settings, then);
    assert!(r.settings.resolve().is_ok());
    assert_eq!(r.step1_runs.len(), 3);
    for run in &r.step1_runs {
        assert_eq!(run.reason, Termination::GaussNewton { step: 1.0 });
    }
    for run in &r.step2_runs {
        assert_eq!(run.reason, Termination::MaxIterations);
    }
    assert_eq!(r.step1_rounds, None);
    let chest = r.measurements.iter().find(|m| m.name == "chest").unwrap();
    assert_eq!(chest.tolerance_mm, Some(10.0));
    // Written again it is in this version's form, which reads back equal.
    let again = serde_json::to_string(&r).unwrap();
    assert!(again.contains("\"step1\"") && !again.contains("step1_gauss_newton"));
    let back: PredictionReport = serde_json::from_str(&again).unwrap();
    assert_eq!(back, r);
}

#[test]
fn every_old_setting_maps_to_its_stage() {
    let old = r#"{"l": 10.0, "lambda": 0.5, "s": 2,
        "stop": {"max_iters": 50, "grad_tol": 1e-8, "rel_cost_tol": 2e-8, "history": 7},
        "step2_stop": {"max_iters": 80, "grad_tol": 1e-8, "rel_cost_tol": 2e-8, "history": 5},
        "step1_solver": "Argmin", "step2_solver": "Builtin",
        "reference_tolerance": 0.002, "warn_error_mm": 4.0,
        "step1_weighting": "Paper", "step2_weighting": "PerMeasurement",
        "step2_reading_weight": 100.0, "step1_prior_mm": 3.0, "step1_components": 20,
        "step1_gauss_newton": false, "step1_box": false,
        "continuation": {"max_extra_rounds": 4, "share": 0.25, "default_allowable_mm": 2.0,
                         "time_budget_s": 1.0}}"#;
    let s: PredictSettings = serde_json::from_str(old).unwrap();
    assert_eq!(
        (s.l, s.s, s.reference_tolerance, s.warn_error_mm),
        (10.0, 2, 0.002, 4.0)
    );
    assert_eq!(
        s.step1.solver,
        Step1Solver::Lbfgs {
            prior_mm: Some(3.0)
        }
    );
    assert_eq!(s.step1.clamp, Step1Clamp::AfterStep);
    assert_eq!(s.step1.components, Some(20));
    assert_eq!(s.step1.stop.max_iters, 50);
    assert_eq!(s.step2.lambda, 0.5);
    assert_eq!(
        s.step2.weighting,
        Step2Weighting::PerMeasurement {
            reading_weight: 100.0
        }
    );
    assert_eq!(s.step2.solver.max_iters(), 80);
    assert!(matches!(s.step2.solver, Step2Solver::Lbfgs { stop } if stop.history == 5));
    assert_eq!(
        s.continuation,
        Some(Continuation {
            max_extra_rounds: 4,
            share: 0.25,
            default_allowable_mm: 2.0,
            max_evaluations: tapeshape_model::predict::DEFAULT_MAX_EVALUATIONS,
            // Older reports ran step 1's continuation rounds with its
            // stop.max_iters.
            step1_max_iters: None,
        })
    );
    // The oldest reports lack the later fields: the paper's pipeline.
    let oldest = r#"{"l": 3.0, "lambda": 0.1, "s": 3,
        "stop": {"max_iters": 100, "grad_tol": 1e-8, "rel_cost_tol": 2.220446049250313e-8, "history": 7},
        "step2_stop": {"max_iters": 100, "grad_tol": 1e-8, "rel_cost_tol": 2.220446049250313e-8, "history": 5},
        "step1_solver": "Argmin", "step2_solver": "Builtin",
        "reference_tolerance": 0.001, "warn_error_mm": 5.0}"#;
    let s: PredictSettings = serde_json::from_str(oldest).unwrap();
    assert_eq!(s, PredictSettings::paper());
    // A step-1 Gauss-Newton record from before `min_decrease_mm` measured
    // every step.
    let gn: Step1Solver = serde_json::from_str(r#"{"GaussNewtonMap": {"tau_mm": null}}"#).unwrap();
    assert_eq!(
        gn,
        Step1Solver::GaussNewtonMap {
            tau_mm: None,
            min_decrease_mm: 0.0
        }
    );
    // Garbage is an error, not a default.
    assert!(serde_json::from_str::<PredictSettings>(r#"{"l": 3.0}"#).is_err());
}
