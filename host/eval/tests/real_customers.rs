//! A reduced `real_customers` run, as CI can afford it (issue 12): the first
//! 12 ANSUR II test-split men and 12 women through the embedded default
//! model with their `quick` values and sex.
//!
//! What it holds the estimator to (each fails on a real regression, none is
//! the final target, which `docs/results/real-customers.md` shows
//! is not met yet):
//! * nobody is refused, every quick reading is met within its ISO 20685-1
//!   allowable error on the body;
//! * the soft targets from real people lower the error of the dimensions
//!   nobody measured against the model alone, on the same people;
//! * least squares with sex, fitted on the train split in the same run, is
//!   the reference: the body's error is reported against it, and it must be
//!   a sane regression (under 12 mm).

use tapeshape_estimator::{Estimate, Estimator, PredictOptions, Warning};
use tapeshape_eval::customers::{
    entered_readings, inputs_of, measuring_set, run, with_soft_pull, within_iso, CustomersOptions,
};
use tapeshape_model::Warning as ModelWarning;
use tapeshape_population::ansur::Ansur;

#[test]
fn soft_targets_lower_the_unmeasured_error_and_readings_stay_within_iso() {
    let estimator = Estimator::default_model().expect("embedded model");
    let mut opts = CustomersOptions {
        input_set: "quick".into(),
        with_sex: true,
        per_sex: Some(12),
        leave_out: Vec::new(),
        ansur_survey: false,
        options: PredictOptions::default(),
    };
    let with = run(estimator, &opts).expect("run with soft targets");
    opts.options.real_people = Some(None);
    let without = run(estimator, &opts).expect("run without");
    assert_eq!(with.people.len(), 24);
    assert_eq!(
        with.refused(),
        0,
        "refused: {:?}",
        with.people
            .iter()
            .filter_map(|p| p.refused.as_ref())
            .collect::<Vec<_>>()
    );
    let (iso, per) = with.iso_pass();
    assert!(iso >= 1.0 - 1e-12, "quick within ISO: {iso}: {per:?}");
    let (b_with, ols_sex, _) = with.overall();
    let (b_without, ols_sex_2, _) = without.overall();
    assert!(
        (ols_sex - ols_sex_2).abs() < 1e-9,
        "the regression does not depend on the estimator"
    );
    assert!(
        ols_sex > 3.0 && ols_sex < 12.0,
        "least squares with sex {ols_sex:.2} mm"
    );
    assert!(
        b_with < b_without - 0.5,
        "soft targets {b_with:.2} mm, model alone {b_without:.2} mm (least squares with sex {ols_sex:.2} mm)"
    );
    assert_eq!(with.dims.len(), 35, "the other ansur dimensions");
}

/// The `ansur` half of the second point, reduced: the first 6 test-split
/// men and 6 women with all 44 of their real `ansur` values as survey
/// values (`--ansur-survey`). The four dimensions the standing mesh cannot
/// take as ANSUR II does, and the sleeve outseam (on the body the sum of
/// the two arm segments, which are given too), are recorded, not fitted;
/// the rest is met within ISO 20685-1 on at least 99 % of the readings (the
/// issue's target). Fitting the three arm lengths together missed the
/// acromion-radiale length on 40 % of people: here it is met on everyone.
#[test]
fn an_ansur_survey_is_met_within_iso_with_the_sleeve_outseam_recorded() {
    let estimator = Estimator::default_model().expect("embedded model");
    let opts = CustomersOptions {
        input_set: "ansur".into(),
        with_sex: true,
        per_sex: Some(6),
        leave_out: Vec::new(),
        ansur_survey: true,
        options: PredictOptions::default(),
    };
    let r = run(estimator, &opts).expect("ansur survey run");
    assert_eq!(r.people.len(), 12);
    assert_eq!(r.refused(), 0);
    let (iso, per) = r.iso_pass();
    assert!(iso >= 0.99, "ansur survey within ISO: {iso}: {per:?}");
    let sleeve = r.names.iter().position(|n| n == "sleeveoutseam").unwrap();
    for p in &r.people {
        assert!(
            p.recorded_only.contains(&sleeve),
            "subject {}: sleeve outseam fitted",
            p.id
        );
        assert_eq!(p.recorded_only.len(), 5, "subject {}", p.id);
    }
    for arm in ["acromionradialelength", "radialestylionlength"] {
        let (share, n) = per[arm];
        assert_eq!(n, 12);
        assert!(share >= 1.0 - 1e-12, "{arm}: {share}");
    }
}

/// Step 2's fold repair on real people whose survey values step 2 meets by
/// folding the surface (the first 6 + 6 of the test above do not fold, so
/// it would not exercise the repair): test-split people chosen because
/// their `ansur` survey values fold the body without the repair
/// (`tapeshape predict --no-fold-repair`). With it (the default), no
/// triangle is left flipped or collapsed, and the report says so: by the
/// smoothing that holds the readings alone, or, where that leaves some
/// folded, by the last resort (`surface-over-readings`), which names the
/// readings it pushed beyond their allowable error. Every reading that was
/// within its ISO 20685-1 allowable error without the repair still is,
/// re-measured on the repaired body by the evaluation's own measuring set,
/// except those named; and each one named is beyond it in the report.
#[test]
fn the_folds_step_2_makes_on_real_survey_values_are_smoothed_out_keeping_every_reading_not_named() {
    // (subject id, whether step 2 started from the step-1 shape smoothed
    // against the mean, whether the smoothing holding the readings leaves
    // nothing folded, whether the last resort gives a reading up), on this
    // machine, 2026-12-08: 10304, whose step-1 shape flips more than 20
    // triangles of the mean: step 2 from it smoothed
    // (`ShapeModel::unfold_step1`) ends with waist depth 285.0 mm for his
    // 268.0, outside ISO 20685-1, so the body kept is step 2's from the
    // shape as step 1 left it (15 -> 0); 10312: 4 -> 2, then 0 by the last
    // resort with every reading kept, from the unsmoothed start, which
    // misses fewer readings; 11828: 3 -> 0; 23616: 8 left, then 0 by the
    // last resort, which costs thigh circumference.
    const PEOPLE: [(u32, bool, bool, bool); 4] = [
        (10304, false, true, false),
        (10312, false, false, false),
        (11828, true, true, false),
        (23616, true, false, true),
    ];
    let estimator = Estimator::default_model().expect("embedded model");
    let opts = CustomersOptions {
        input_set: "ansur".into(),
        with_sex: true,
        per_sex: None,
        leave_out: Vec::new(),
        ansur_survey: true,
        options: PredictOptions::default(),
    };
    let entered = entered_readings(estimator, &opts).expect("entered readings");
    let (union, compiled) = measuring_set(estimator).expect("measuring set");
    let ansur = Ansur::get().expect("ANSUR II");
    let folds = |e: &Estimate| {
        let p = &e.report.prediction.plausibility;
        p.flipped_triangles + p.degenerate_triangles
    };
    let smoothed = |e: &Estimate| {
        e.report.warnings.iter().find_map(|w| match w {
            Warning::Model(ModelWarning::FoldsSmoothed { folded, left }) => Some((*folded, *left)),
            _ => None,
        })
    };
    let over_readings = |e: &Estimate| {
        e.report.warnings.iter().find_map(|w| match w {
            Warning::Model(ModelWarning::SurfaceOverReadings {
                folded,
                left,
                readings,
            }) => Some((*folded, *left, readings.clone())),
            _ => None,
        })
    };
    for (id, from_smoothed, clean, gives_up) in PEOPLE {
        assert_eq!(id % 4, 0, "{id} is not in the test split");
        let subject = ansur.subject(id).expect("subject");
        let mut inputs = inputs_of(subject, &entered, true);
        inputs.ansur_survey = true;
        let without = PredictOptions {
            fold_repair: Some(false),
            ..PredictOptions::default()
        };
        let off = estimator.predict(&inputs, &without).expect("estimate");
        let on = estimator
            .predict(&inputs, &PredictOptions::default())
            .expect("estimate");
        let (before, after) = (folds(&off), folds(&on));
        assert!(
            before > 0,
            "subject {id}: the premise, folds without the repair"
        );
        assert_eq!(smoothed(&off), None, "subject {id}");
        let step1_smoothed = on
            .report
            .warnings
            .iter()
            .any(|w| matches!(w, Warning::Model(ModelWarning::Step1Smoothed { .. })));
        assert_eq!(step1_smoothed, from_smoothed, "subject {id}");
        // With the repair on, step 2 may start from a step-1 shape smoothed
        // against the model's mean (`ShapeModel::unfold_step1`), so the
        // body it repairs need not fold as the one without the repair did:
        // the repair's own count is checked, and the end against `before`.
        let (folded, left) =
            smoothed(&on).unwrap_or_else(|| panic!("subject {id}: no folds-smoothed warning"));
        assert!(left < folded, "subject {id}: {folded} -> {left}");
        // What the repair holding the readings left folded is smoothed
        // with nothing held, and the readings that cost are named.
        let given_up = match over_readings(&on) {
            Some((still, end, names)) => {
                assert!(!clean, "subject {id}: the readings held, yet {names:?}");
                assert_eq!(still, left, "subject {id}");
                assert_eq!(end, after, "subject {id}");
                assert!(end < still, "subject {id}: {still} -> {end}");
                assert_eq!(!names.is_empty(), gives_up, "subject {id}: {names:?}");
                names
            }
            None => {
                assert!(
                    clean && !gives_up,
                    "subject {id}: no surface-over-readings warning"
                );
                assert_eq!(left, after, "subject {id}");
                Vec::new()
            }
        };
        assert!(after < before, "subject {id}: {before} -> {after}");
        assert_eq!(after, 0, "subject {id}: {before} -> {after}");
        // Each reading given up is beyond its ISO 20685-1 allowable error
        // on the body, by the estimator's own report.
        for name in &given_up {
            let m = on
                .report
                .prediction
                .measurements
                .iter()
                .find(|m| &m.name == name)
                .unwrap_or_else(|| panic!("subject {id}: {name} not in the report"));
            let j = estimator.set().index_of(name).expect("a set measurement");
            let iso = estimator.set().definitions[j].tolerance.mm();
            assert!(
                m.error_mm.expect("a given reading") > iso,
                "subject {id}: {name} named as given up, yet within {iso} mm"
            );
        }
        let measure = |e: &Estimate| compiled.measure(&e.mesh.vertices).expect("measuring");
        let (m_off, m_on) = (measure(&off), measure(&on));
        let recorded: Vec<&str> = on
            .report
            .prediction
            .measurements
            .iter()
            .filter(|m| m.recorded_only)
            .map(|m| m.name.as_str())
            .collect();
        let mut checked = 0;
        for (name, col) in &entered {
            let (Some(j), Some(real)) = (union.index_of(name), subject.dim(col)) else {
                continue;
            };
            if recorded.contains(&name.as_str()) || given_up.contains(name) {
                continue;
            }
            checked += 1;
            if within_iso(&union, j, m_off[j].value, real) {
                assert!(
                    within_iso(&union, j, m_on[j].value, real),
                    "subject {id}: {name} was within ISO without the repair ({:.1} mm for {:.1}) and is not with it ({:.1} mm)",
                    m_off[j].value * 1e3,
                    real * 1e3,
                    m_on[j].value * 1e3
                );
            }
        }
        assert!(checked >= 35, "subject {id}: {checked} readings checked");
    }
}

/// Step 2 with the soft targets pulled all the way
/// (`Step2Settings::soft_pull` 1) on a test-split person whose `quick`
/// values and sex fold the surface that way (test-split 25772: 14 flipped
/// triangles left after the fold repair, 2026-12-07, before the
/// fallback): the body kept is pulled less (`SoftPullReduced` says how
/// far), folds nothing, and still meets every reading within its ISO
/// 20685-1 allowable error. A person whose body does not fold (the first
/// test-split man) keeps the full pull and no such warning.
#[test]
fn a_full_soft_pull_that_folds_the_surface_pulls_less_and_says_so() {
    let estimator = Estimator::default_model().expect("embedded model");
    let options = with_soft_pull(&PredictOptions::default(), 1.0).expect("a share in [0, 1]");
    let opts = CustomersOptions {
        input_set: "quick".into(),
        with_sex: true,
        per_sex: None,
        leave_out: Vec::new(),
        ansur_survey: false,
        options: options.clone(),
    };
    let entered = entered_readings(estimator, &opts).expect("entered readings");
    let ansur = Ansur::get().expect("ANSUR II");
    let reduced = |e: &Estimate| {
        e.report.warnings.iter().find_map(|w| match w {
            Warning::Model(ModelWarning::SoftPullReduced { pull, asked }) => Some((*pull, *asked)),
            _ => None,
        })
    };
    let first_man = tapeshape_eval::customers::test_people(ansur, Some(1))
        .into_iter()
        .find(|s| s.sex == tapeshape_population::ansur::Sex::Male)
        .expect("a test-split man");
    for (id, folds_at_full_pull) in [(25772, true), (first_man.id, false)] {
        assert_eq!(id % 4, 0, "{id} is not in the test split");
        let subject = ansur.subject(id).expect("subject");
        let inputs = inputs_of(subject, &entered, true);
        let e = estimator.predict(&inputs, &options).expect("estimate");
        let p = &e.report.prediction.plausibility;
        assert_eq!(
            (p.flipped_triangles, p.degenerate_triangles),
            (0, 0),
            "subject {id}"
        );
        match reduced(&e) {
            Some((pull, asked)) => {
                assert!(folds_at_full_pull, "subject {id}: pulled {pull} of {asked}");
                assert_eq!(asked, 1.0, "subject {id}");
                assert!((0.0..1.0).contains(&pull), "subject {id}: {pull}");
            }
            None => assert!(!folds_at_full_pull, "subject {id}: no reduced pull"),
        }
        for m in e
            .report
            .prediction
            .measurements
            .iter()
            .filter(|m| m.target_mm.is_some() && !m.soft && !m.recorded_only)
        {
            let j = estimator.set().index_of(&m.name).unwrap();
            let iso = estimator.set().definitions[j].tolerance.mm();
            assert!(
                m.error_mm.unwrap() <= iso,
                "subject {id}: {} missed by {:.2} mm, ISO allows {iso} mm",
                m.name,
                m.error_mm.unwrap()
            );
        }
    }
}
