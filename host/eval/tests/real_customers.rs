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

use tapeshape_estimator::{Estimator, PredictOptions};
use tapeshape_eval::customers::{run, CustomersOptions};

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
