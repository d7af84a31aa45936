//! Tests of `settings`, in a file of their own so that the module stays short.

use super::*;

#[test]
fn default_and_paper_resolve() {
    let d = PredictSettings::default().resolve().unwrap();
    assert!(matches!(
        d.step1().solver,
        Step1Method::GaussNewtonMap { tau_mm, max_iters: 100, min_decrease, .. }
            if tau_mm == 1.0 && (min_decrease - 0.01).abs() < 1e-15
    ));
    assert_eq!(d.step1().box_l, Some(3.0));
    assert_eq!(d.step2().weighting, (EnergyWeighting::PerMeasurement, 1e4));
    assert!(
        matches!(d.step2().solver, Step2Method::Lbfgs(l) if l.line_search == LineSearch::Backtracking && l.stop.history == 5)
    );
    assert_eq!(d.rounds().max_rounds(), 13);
    let p = PredictSettings::paper().resolve().unwrap();
    match &p.step1().solver {
        Step1Method::Lbfgs(r) => {
            assert_eq!(r.prior, Step1Prior::None);
            assert_eq!(r.weighting, EnergyWeighting::Paper);
            assert_eq!(r.solver.line_search, LineSearch::StrongWolfe);
        }
        other => panic!("{other:?}"),
    }
    assert_eq!(p.step1().box_l, None);
    assert_eq!(p.step2().weighting, (EnergyWeighting::Paper, 1.0));
    assert!(
        matches!(p.step2().solver, Step2Method::Lbfgs(l) if l.line_search == LineSearch::Backtracking && l.stop.history == 5)
    );
    assert_eq!(p.rounds().max_rounds(), 3);
    assert_eq!(p.settings(), &PredictSettings::paper());
}

#[test]
fn per_measurement_lbfgs_brings_in_the_prior_for_tolerances_only() {
    let mut s = PredictSettings::default();
    s.step1.solver = Step1Solver::Lbfgs { prior_mm: None };
    let c = s.resolve().unwrap();
    let Step1Method::Lbfgs(r) = &c.step1().solver else {
        panic!()
    };
    assert_eq!(r.prior.tau_mm(false), None);
    assert_eq!(r.prior.tau_mm(true), Some(1.0));
    s.step1.solver = Step1Solver::Lbfgs {
        prior_mm: Some(3.0),
    };
    let c = s.resolve().unwrap();
    let Step1Method::Lbfgs(r) = &c.step1().solver else {
        panic!()
    };
    assert_eq!(r.prior.tau_mm(false), Some(3.0));
}

#[test]
fn bad_values_are_refused_when_resolved_naming_the_setting() {
    let cases: Vec<(PredictSettings, &str)> = vec![
        (
            PredictSettings {
                l: 0.0,
                ..Default::default()
            },
            "l must be positive",
        ),
        (
            PredictSettings {
                l: f64::NAN,
                ..Default::default()
            },
            "l must be positive",
        ),
        (
            PredictSettings {
                step2: Step2Settings {
                    bending: 0.0,
                    lambda: 1.5,
                    ..PredictSettings::default().step2
                },
                ..Default::default()
            },
            "lambda must lie in [0, 1]",
        ),
        (
            PredictSettings {
                reference_tolerance: -0.001,
                ..Default::default()
            },
            "reference_tolerance",
        ),
        (
            PredictSettings {
                step2: Step2Settings {
                    bending: 0.0,
                    weighting: Step2Weighting::PerMeasurement {
                        reading_weight: 0.0,
                    },
                    ..PredictSettings::default().step2
                },
                ..Default::default()
            },
            "reading_weight",
        ),
        (
            PredictSettings {
                step1: Step1Settings {
                    solver: Step1Solver::GaussNewtonMap {
                        tau_mm: Some(f64::INFINITY),
                        min_decrease_mm: 0.1,
                    },
                    ..PredictSettings::default().step1
                },
                ..Default::default()
            },
            "tau_mm",
        ),
        (
            PredictSettings {
                step1: Step1Settings {
                    solver: Step1Solver::GaussNewtonMap {
                        tau_mm: None,
                        min_decrease_mm: -0.1,
                    },
                    ..PredictSettings::default().step1
                },
                ..Default::default()
            },
            "min_decrease_mm",
        ),
        (
            PredictSettings {
                step1: Step1Settings {
                    stop: StopRule {
                        history: 0,
                        ..StopRule::default()
                    },
                    ..PredictSettings::default().step1
                },
                ..Default::default()
            },
            "history",
        ),
        (
            PredictSettings {
                continuation: Some(Continuation {
                    share: -1.0,
                    ..Continuation::default()
                }),
                ..Default::default()
            },
            "share",
        ),
        (
            PredictSettings {
                continuation: Some(Continuation {
                    step1_max_iters: Some(0),
                    ..Continuation::default()
                }),
                ..Default::default()
            },
            "step1_max_iters",
        ),
        (
            PredictSettings {
                step2: Step2Settings {
                    bending: -1.0,
                    ..PredictSettings::default().step2
                },
                ..Default::default()
            },
            "bending must lie in",
        ),
        (
            PredictSettings {
                step2: Step2Settings {
                    soft_pull: 1.5,
                    ..PredictSettings::default().step2
                },
                ..Default::default()
            },
            "soft_pull must lie in [0, 1]",
        ),
        (
            PredictSettings {
                step2: Step2Settings {
                    soft_pull: f64::NAN,
                    ..PredictSettings::default().step2
                },
                ..Default::default()
            },
            "soft_pull must lie in [0, 1]",
        ),
        (
            PredictSettings {
                step2: Step2Settings {
                    bending: 10.0,
                    solver: Step2Solver::smooth_basis(),
                    ..PredictSettings::default().step2
                },
                ..Default::default()
            },
            "not taken by step 2's smooth-basis solver",
        ),
    ];
    for (s, want) in cases {
        let e = s.resolve().unwrap_err().to_string();
        assert!(e.contains(want), "{e} (wanted {want})");
    }
    // s = 0 turns the continuation off (there are no rounds to continue).
    let c = PredictSettings {
        s: 0,
        ..Default::default()
    }
    .resolve()
    .unwrap();
    assert_eq!(c.rounds().max_rounds(), 0);
}
