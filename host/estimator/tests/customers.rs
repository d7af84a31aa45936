//! Real customers through the estimator (issue 12): the customer's sex as
//! an input, soft targets from real people for what was not measured,
//! readings the operator kept after a flag, and loop totals as one reading.
//!
//! Each test asks for a property that a wrong answer breaks: a kept
//! reading that is still refused, a man's soft targets that equal a
//! woman's, a total whose pieces do not add up to it.

use tapeshape_estimator::{Estimator, Inputs, PredictError, PredictOptions, Warning};
use tapeshape_model::Warning as ModelWarning;
use tapeshape_population::ansur::{Ansur, Sex, Split};

fn estimator() -> &'static Estimator {
    Estimator::default_model().expect("the embedded model loads")
}

fn entered(pairs: &[&str]) -> Inputs {
    let mut i = Inputs::new();
    for p in pairs {
        i.add_assignment(p).unwrap();
    }
    i
}

/// `pairs` as survey values taken as ANSUR II takes them
/// (`Inputs::ansur_survey`).
fn surveyed(pairs: &[&str]) -> Inputs {
    let mut i = entered(pairs);
    i.ansur_survey = true;
    i
}

/// The report's entry for measurement `name` of an estimate.
fn measured(est: &tapeshape_estimator::Estimate, name: &str) -> tapeshape_model::MeasurementReport {
    est.report
        .prediction
        .measurements
        .iter()
        .find(|m| m.name == name)
        .unwrap()
        .clone()
}

/// Every reading entered (not a soft target) of `est` ends within its ISO
/// 20685-1 allowable error.
fn assert_readings_within_iso(e: &Estimator, est: &tapeshape_estimator::Estimate) {
    for m in est
        .report
        .prediction
        .measurements
        .iter()
        .filter(|m| m.target_mm.is_some() && !m.soft)
    {
        let j = e.set().index_of(&m.name).unwrap();
        let iso = e.set().definitions[j].tolerance.mm();
        assert!(
            m.error_mm.unwrap() <= iso,
            "{}: missed by {:?} mm, ISO allows {iso} mm",
            m.name,
            m.error_mm
        );
    }
}

/// A typical man's quick readings.
const MAN: [&str; 9] = [
    "stature=176cm",
    "chest=100cm",
    "waist=88cm",
    "hip=100cm",
    "neck=39cm",
    "inside_leg=82cm",
    "arm_length=60cm",
    "thigh=58cm",
    "upper_arm=33cm",
];

fn with(base: &[&'static str], replace: &[&'static str]) -> Vec<&'static str> {
    base.iter()
        .map(|b| {
            let name = b.split('=').next().unwrap();
            *replace
                .iter()
                .find(|r| r.split('=').next().unwrap() == name)
                .unwrap_or(b)
        })
        .collect()
}

#[test]
fn sex_changes_what_real_people_predict_for_the_unmeasured() {
    let e = estimator();
    let mut man = entered(&["stature=170cm", "chest=95cm", "hip=100cm"]);
    let mut woman = man.clone();
    man.sex = Some(Sex::Male);
    woman.sex = Some(Sex::Female);
    let r = tapeshape_estimator::RealPeople::default();
    let sm = e.soft_targets(&man, &r).unwrap();
    let sw = e.soft_targets(&woman, &r).unwrap();
    let pooled = e.soft_targets(&entered(&["stature=170cm", "chest=95cm", "hip=100cm"]), &r);
    assert!(!sm.is_empty() && sm.len() == sw.len() && sm.len() == pooled.unwrap().len());
    // None of them is a measurement that was given.
    for (_, _, t) in &sm {
        assert!(
            !["stature", "chest", "hip"].contains(&t.name.as_str()),
            "{}",
            t.name
        );
        assert!(t.sd_mm > 0.0 && t.tolerance_mm >= t.sd_mm, "{t:?}");
    }
    // At the same stature, chest and hip, ANSUR II men have thicker wrists
    // than women: the conditional differs in the right direction.
    let get = |v: &Vec<(
        usize,
        tapeshape_estimator::Target,
        tapeshape_estimator::SoftTarget,
    )>,
               name: &str| {
        v.iter()
            .find(|(_, _, t)| t.name == name)
            .map(|(_, _, t)| t.value_mm)
            .unwrap()
    };
    let (m, w) = (
        get(&sm, "wristcircumference"),
        get(&sw, "wristcircumference"),
    );
    assert!(m > w + 8.0, "wrist man {m:.1} mm, woman {w:.1} mm");
    // And the estimate reports the sex it used.
    let est = e.predict(&man, &PredictOptions::default()).unwrap();
    assert_eq!(est.report.sex, Some(Sex::Male));
    assert_eq!(est.report.soft_targets.len(), sm.len());
}

/// One soft target per ANSUR II column: the quick set's `neck` and the
/// ansur set's `neckcircumferencebase` follow the same column, and a
/// target on each counted one statistic twice. The one named as the column
/// is kept.
#[test]
fn one_soft_target_per_ansur_column() {
    let e = estimator();
    let mut man = entered(&["stature=170cm", "chest=95cm", "hip=100cm"]);
    man.sex = Some(Sex::Male);
    let soft = e
        .soft_targets(&man, &tapeshape_estimator::RealPeople::default())
        .unwrap();
    let column = |j: usize| e.set().definitions[j].ansur.clone();
    let mut columns: Vec<String> = soft.iter().filter_map(|(j, _, _)| column(*j)).collect();
    let n = columns.len();
    assert!(n > 10, "{n} soft targets");
    columns.sort();
    columns.dedup();
    assert_eq!(columns.len(), n, "a column twice: {soft:?}");
    let names: Vec<&str> = soft.iter().map(|(_, _, t)| t.name.as_str()).collect();
    // Both follow ANSUR's neck base girth, neither was given.
    assert_eq!(
        column(e.set().index_of("neck").unwrap()),
        column(e.set().index_of("neckcircumferencebase").unwrap())
    );
    assert!(names.contains(&"neckcircumferencebase"), "{names:?}");
    assert!(!names.contains(&"neck"), "{names:?}");
}

#[test]
fn soft_targets_follow_the_real_people_conditional() {
    // With only a stature, a soft target is ANSUR II's regression on it:
    // compare with least squares over the train split's men.
    let e = estimator();
    let mut i = entered(&["stature=180cm"]);
    i.sex = Some(Sex::Male);
    let soft = e
        .soft_targets(&i, &tapeshape_estimator::RealPeople::default())
        .unwrap();
    let crotch = soft
        .iter()
        .find(|(_, _, t)| t.name == "crotchheight")
        .map(|(_, _, t)| t.value_mm)
        .expect("crotch height has an ANSUR column");
    let men: Vec<(f64, f64)> = Ansur::get()
        .unwrap()
        .subjects(Some(Sex::Male), Split::Train)
        .filter_map(|s| Some((s.dim("stature")?, s.dim("crotchheight")?)))
        .collect();
    let n = men.len() as f64;
    let (mx, my) = (
        men.iter().map(|p| p.0).sum::<f64>() / n,
        men.iter().map(|p| p.1).sum::<f64>() / n,
    );
    let sxy: f64 = men.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum();
    let sxx: f64 = men.iter().map(|p| (p.0 - mx).powi(2)).sum();
    let ols = (my + sxy / sxx * (1.80 - mx)) * 1000.0;
    // The conditional adds the stature's ISO noise (a few mm), which
    // shrinks the slope a little; the complete-case subjects differ a bit.
    assert!(
        (crotch - ols).abs() < 3.0,
        "soft target {crotch:.1} mm, regression {ols:.1} mm"
    );
}

#[test]
fn a_kept_13_sd_neck_gives_a_body_with_a_warning() {
    let e = estimator();
    // Neck 18 cm on an otherwise typical man: 13 SD below what the other
    // readings predict (41.8 +/- 1.8 cm). (Not 13 SD above: the generated
    // population's neck runs long, issue 12's second finding, so it does
    // not refuse a large neck and nothing needs keeping.)
    let readings = with(&MAN, &["neck=18cm"]);
    let refused = match e.predict(&entered(&readings), &PredictOptions::default()) {
        Err(err) => err,
        Ok(est) => panic!("not refused: {:?}", est.report.warnings),
    };
    assert!(
        matches!(
            refused,
            PredictError::Contradiction(_) | PredictError::OutOfPopulation { .. }
        ),
        "{refused}"
    );
    assert!(refused.to_string().contains("keep them"), "{refused}");
    let mut kept = entered(&readings);
    kept.kept.push("neck".into());
    let est = e.predict(&kept, &PredictOptions::default()).unwrap();
    let neck = est.report.inputs.iter().find(|c| c.name == "neck").unwrap();
    assert!(neck.kept_unusual, "{neck:?}");
    assert!(
        est.report.warnings.iter().any(|w| matches!(
            w,
            tapeshape_estimator::Warning::EstimatedWithKept { measurements, .. }
                if measurements.iter().any(|m| m == "neck")
        )),
        "{:?}",
        est.report.warnings
    );
    // The body moved towards the kept value: its neck is smaller than a
    // typical man's estimate.
    let typical = e
        .predict(&entered(&MAN), &PredictOptions::default())
        .unwrap();
    let neck_of = |r: &tapeshape_estimator::EstimateReport| {
        r.prediction
            .measurements
            .iter()
            .find(|m| m.name == "neck")
            .and_then(|m| m.step2_mm)
            .unwrap()
    };
    assert!(
        neck_of(&est.report) < neck_of(&typical.report) - 50.0,
        "kept {:.1} mm, typical {:.1} mm",
        neck_of(&est.report),
        neck_of(&typical.report)
    );
    assert_eq!(est.report.prediction.plausibility.flipped_triangles, 0);
}

#[test]
fn kept_short_limbs_and_a_bmi_beyond_the_population_give_bodies() {
    let e = estimator();
    for (case, replace, keep) in [
        (
            "limbs 8 SD short",
            vec!["inside_leg=55cm", "arm_length=42cm"],
            vec!["inside_leg", "arm_length"],
        ),
        (
            "BMI beyond the population",
            vec![
                "stature=160cm",
                "chest=150cm",
                "waist=160cm",
                "hip=165cm",
                "thigh=90cm",
            ],
            vec!["chest", "waist", "hip", "thigh"],
        ),
    ] {
        let readings = with(&MAN, &replace);
        let mut i = entered(&readings);
        if let Ok(est) = e.predict(&i, &PredictOptions::default()) {
            panic!(
                "{case}: not refused without keeping: {:?}",
                est.report.warnings
            );
        }
        i.kept = keep.iter().map(|k| k.to_string()).collect();
        let est = e
            .predict(&i, &PredictOptions::default())
            .unwrap_or_else(|err| panic!("{case}: {err}"));
        assert!(
            est.report.inputs.iter().any(|c| c.kept_unusual),
            "{case}: no reading marked unusual"
        );
        let w: Vec<String> = est.report.warnings.iter().map(|w| w.to_string()).collect();
        let w = w.join(" | ");
        assert!(w.contains("kept by the operator"), "{case}: {w}");
        assert!(est
            .mesh
            .vertices
            .iter()
            .all(|p| p.iter().all(|c| c.is_finite())));
    }
}

#[test]
fn impossible_values_are_refused_even_when_kept() {
    let e = estimator();
    let readings = with(&MAN, &["neck=400cm"]);
    let mut i = entered(&readings);
    i.kept.push("neck".into());
    let Err(err) = e.predict(&i, &PredictOptions::default()) else {
        panic!("a 400 cm neck was estimated");
    };
    assert!(err.to_string().contains("beyond any person"), "{err}");
    // Keeping a reading that was not given is a mistake in the request.
    let mut i = entered(&MAN);
    i.kept.push("knee".into());
    let Err(err) = e.predict(&i, &PredictOptions::default()) else {
        panic!("keeping an unknown reading was accepted");
    };
    assert!(err.to_string().contains("'knee' is to be kept"), "{err}");
}

#[test]
fn a_loop_total_is_shared_out_over_its_pieces() {
    let e = estimator();
    let Some((group, members)) = e.set().groups().into_iter().next() else {
        panic!("the default model has no loop groups");
    };
    let mut i = entered(&MAN[..4]);
    i.add_assignment(&format!("{group}=40cm")).unwrap();
    let (expanded, splits) = e.expand_totals(&i).unwrap();
    assert_eq!(splits.len(), 1);
    let sum: f64 = splits[0].pieces.iter().map(|p| p.1).sum();
    assert!((sum - 400.0).abs() < 1e-6, "pieces sum to {sum} mm");
    assert!(splits[0].pieces.iter().all(|p| p.1 > 0.0));
    assert_eq!(expanded.readings.len(), 4 + members.len());
    // The estimate fits the pieces: the body's total is the tape's.
    let est = e.predict(&i, &PredictOptions::default()).unwrap();
    let total: f64 = members
        .iter()
        .map(|&m| {
            let name = &e.set().definitions[m].name;
            est.report
                .prediction
                .measurements
                .iter()
                .find(|r| &r.name == name)
                .and_then(|r| r.step2_mm)
                .unwrap()
        })
        .sum();
    assert!((total - 400.0).abs() < 8.0, "body's {group} {total:.1} mm");
    assert_eq!(est.report.totals, splits);
    // A total and one of its own pieces together are a mistake.
    let mut both = i.clone();
    let piece = &e.set().definitions[members[0]].name;
    both.add_assignment(&format!("{piece}=10cm")).unwrap();
    let Err(err) = e.expand_totals(&both) else {
        panic!("a total with its piece was accepted");
    };
    assert!(err.to_string().contains("both as a total"), "{err}");
}

#[test]
fn sex_is_read_from_measurement_files() {
    let i = Inputs::from_json_value(
        &serde_json::json!({"stature": "170cm", "sex": "female"}),
        "test",
    )
    .unwrap();
    assert_eq!(i.sex, Some(Sex::Female));
    assert_eq!(i.readings.len(), 1);
    let i = Inputs::from_csv("stature,sex\n170cm,m\n", "test").unwrap();
    assert_eq!(i.sex, Some(Sex::Male));
    let err = Inputs::from_csv("stature,sex\n170cm,x\n", "test").unwrap_err();
    assert!(err.to_string().contains("sex 'x'"), "{err}");
}

/// The neck read off a body the tape did not measure it on (a shirt's
/// primary dimension) is where real people of that build and sex have it:
/// within two conditional SDs of ANSUR II's regression on the readings, and
/// inside the central 95 % of ANSUR II's train-split neck base girths of
/// that sex. The plane-cut neck before the definitions audit measured
/// 590 mm on such a man (ANSUR II men: 435 mm, SD 26), so every shirt was
/// "tight at the neck".
#[test]
fn an_unmeasured_neck_comes_out_where_real_people_have_it() {
    let e = estimator();
    for sex in [Sex::Male, Sex::Female] {
        let mut i = entered(&["stature=176.5cm", "chest=98cm", "waist=84cm", "hip=100cm"]);
        i.sex = Some(sex);
        let soft = e
            .soft_targets(&i, &tapeshape_estimator::RealPeople::default())
            .unwrap();
        let (want, sd) = soft
            .iter()
            .find(|(_, _, t)| t.name == "neckcircumferencebase")
            .map(|(_, _, t)| (t.value_mm, t.sd_mm))
            .expect("the neck base follows ANSUR: it has a soft target");
        let est = e.predict(&i, &PredictOptions::default()).unwrap();
        let got = est
            .report
            .prediction
            .measurements
            .iter()
            .find(|m| m.name == "neck")
            .and_then(|m| m.step2_mm)
            .expect("the quick set's neck is measured on the body");
        assert!(
            (got - want).abs() < 2.0 * sd,
            "{sex:?}: body {got:.1} mm, real people {want:.1} ± {sd:.1} mm"
        );
        let mut necks: Vec<f64> = Ansur::get()
            .unwrap()
            .subjects(Some(sex), Split::Train)
            .filter_map(|s| s.dim("neckcircumferencebase"))
            .map(|m| m * 1000.0)
            .collect();
        necks.sort_by(f64::total_cmp);
        let q = |p: f64| necks[((necks.len() - 1) as f64 * p).round() as usize];
        let (lo, hi) = (q(0.025), q(0.975));
        assert!(
            (lo..=hi).contains(&got),
            "{sex:?}: body {got:.1} mm outside ANSUR II's central 95 % [{lo:.0}, {hi:.0}] mm"
        );
    }
}

/// Issue 12, item 1: a survey's reading of an ANSUR II dimension that the
/// standing mesh cannot take as ANSUR defines it (chest breadth: a caliper
/// that compresses the tissue; the biceps girth flexed, which the quick
/// set's `upper_arm` holds in ANSUR data) is checked and recorded, informs
/// what real people predict for the unmeasured, and is not fitted. A
/// station's reading, taken as the set's description asks, is fitted.
#[test]
fn a_survey_caliper_chest_breadth_is_recorded_not_fitted() {
    let e = estimator();
    let mut readings: Vec<&str> = MAN.to_vec();
    readings.push("chestbreadth=33cm");
    // The model alone (no soft targets): the body is exactly the one of the
    // other readings, so the reading moved nothing.
    let alone = PredictOptions {
        real_people: Some(None),
        ..Default::default()
    };
    let with_breadth = e.predict(&surveyed(&readings), &alone).unwrap();
    let without = e.predict(&surveyed(&MAN), &alone).unwrap();
    assert_eq!(with_breadth.mesh.vertices, without.mesh.vertices);

    let est = e
        .predict(&surveyed(&readings), &PredictOptions::default())
        .unwrap();
    let m = measured(&est, "chestbreadth");
    assert!(m.recorded_only, "{m:?}");
    assert_eq!(m.target_mm, Some(330.0));
    let body = m.step2_mm.expect("measured on the body");
    assert!((m.error_mm.unwrap() - (body - 330.0).abs()).abs() < 1e-9);
    assert!(measured(&est, "upper_arm").recorded_only);
    assert!(!measured(&est, "chest").recorded_only);
    assert!(
        est.report.inputs.iter().any(|c| c.name == "chestbreadth"),
        "the reading keeps its checks"
    );
    assert!(
        est.report.warnings.iter().any(|w| matches!(
            w,
            tapeshape_estimator::Warning::RecordedNotFitted { measurements }
                if measurements == &["upper_arm".to_string(), "chestbreadth".to_string()]
        )),
        "{:?}",
        est.report.warnings
    );
    let fitted = est
        .report
        .prediction
        .measurements
        .iter()
        .filter(|m| m.target_mm.is_some() && !m.soft && !m.recorded_only)
        .count();
    assert_eq!(fitted, MAN.len() - 1);
    // Real people's chest breadth is ANSUR's own quantity: it still moves
    // what they predict for the unmeasured.
    let typical = e
        .predict(&surveyed(&MAN), &PredictOptions::default())
        .unwrap();
    assert_ne!(
        est.report.soft_targets, typical.report.soft_targets,
        "the chest breadth informs the soft targets"
    );

    // The station's reading (no survey): fitted, and met.
    let station = e
        .predict(&entered(&readings), &PredictOptions::default())
        .unwrap();
    let m = measured(&station, "chestbreadth");
    assert!(!m.recorded_only);
    assert!(m.error_mm.unwrap() < 2.0, "{m:?}");
    assert!(!station
        .report
        .warnings
        .iter()
        .any(|w| matches!(w, tapeshape_estimator::Warning::RecordedNotFitted { .. })));

    // Given alone, there is nothing to fit: refused, saying what to do.
    let err = e
        .predict(
            &surveyed(&["chestbreadth=33cm"]),
            &PredictOptions::default(),
        )
        .unwrap_err();
    assert!(
        err.to_string()
            .contains("enter at least one other measurement"),
        "{err}"
    );
}

/// Issue 12, item 1: on the body the sleeve outseam (the quick set's
/// `arm_length`, ANSUR II's `sleeveoutseam`) is the acromion-radiale length
/// plus the radiale-stylion length, exactly; ANSUR II's is 10 mm shorter on
/// average (`priors::ANSUR_SUMS`). A survey that gives all three has the
/// sum recorded and the parts fitted; without its parts, or from the
/// station, the arm length is fitted.
#[test]
fn a_survey_sleeve_outseam_with_its_parts_is_recorded_and_the_parts_met() {
    let e = estimator();
    let mut readings: Vec<&str> = MAN.to_vec();
    readings.extend(["acromionradialelength=34cm", "radialestylionlength=27cm"]);
    let est = e
        .predict(&surveyed(&readings), &PredictOptions::default())
        .unwrap();
    // The premise: on the body the three are a sum, to rounding.
    let v = |name: &str| measured(&est, name).step2_mm.unwrap();
    let sum = v("acromionradialelength") + v("radialestylionlength");
    assert!(
        (v("arm_length") - sum).abs() < 1e-6,
        "{} vs {sum}",
        v("arm_length")
    );
    assert!((v("sleeveoutseam") - sum).abs() < 1e-6);

    let arm = measured(&est, "arm_length");
    assert!(arm.recorded_only, "{arm:?}");
    assert_eq!(arm.target_mm, Some(600.0));
    for (name, want) in [
        ("acromionradialelength", 340.0),
        ("radialestylionlength", 270.0),
    ] {
        let m = measured(&est, name);
        assert!(!m.recorded_only);
        assert!((v(name) - want).abs() < 2.0, "{name}: {} mm", v(name));
    }
    assert!(
        est.report.warnings.iter().any(|w| matches!(
            w,
            tapeshape_estimator::Warning::RecordedSumOfParts { measurement, parts }
                if measurement == "arm_length"
                    && parts == &["acromionradialelength".to_string(), "radialestylionlength".to_string()]
        )),
        "{:?}",
        est.report.warnings
    );
    // The flexed biceps is recorded for its own reason, in its own warning.
    assert!(est.report.warnings.iter().any(|w| matches!(
        w,
        tapeshape_estimator::Warning::RecordedNotFitted { measurements }
            if measurements == &["upper_arm".to_string()]
    )));

    // Without its parts the survey's arm length is the only one: fitted.
    let alone = e
        .predict(&surveyed(&MAN), &PredictOptions::default())
        .unwrap();
    let arm = measured(&alone, "arm_length");
    assert!(!arm.recorded_only);
    assert!(arm.error_mm.unwrap() < 2.0, "{arm:?}");
    // One part alone is not a sum: fitted too.
    let mut one = MAN.to_vec();
    one.push("acromionradialelength=34cm");
    let est = e
        .predict(&surveyed(&one), &PredictOptions::default())
        .unwrap();
    assert!(!measured(&est, "arm_length").recorded_only);
    // The station's readings (no survey): all fitted.
    let station = e
        .predict(&entered(&readings), &PredictOptions::default())
        .unwrap();
    assert!(!measured(&station, "arm_length").recorded_only);
    assert!(!station
        .report
        .warnings
        .iter()
        .any(|w| matches!(w, tapeshape_estimator::Warning::RecordedSumOfParts { .. })));
}

/// Issue 12, item 4: step 2 follows the soft targets
/// (`Step2Settings::soft_pull`). Aimed all the way at them, the unmeasured
/// dimensions end nearer to what real people with these readings have
/// than held at step 1's values, and every reading is still met within
/// its ISO 20685-1 allowable error.
#[test]
fn step2_pulls_the_unmeasured_towards_real_people() {
    let e = estimator();
    let mut i = entered(&MAN);
    i.sex = Some(Sex::Male);
    let run = |pull: f64| {
        let mut s = PredictOptions::default().settings();
        s.step2.soft_pull = pull;
        let mut o = PredictOptions::custom(s);
        o.real_people = Some(Some(tapeshape_estimator::RealPeople {
            breadths_and_depths: true,
            ..Default::default()
        }));
        e.predict(&i, &o).unwrap()
    };
    let (held, pulled) = (run(0.0), run(1.0));
    let miss = |est: &tapeshape_estimator::Estimate| {
        let soft: Vec<f64> = est
            .report
            .prediction
            .measurements
            .iter()
            .filter(|m| m.soft)
            .map(|m| (m.step2_mm.unwrap() - m.target_mm.unwrap()).abs())
            .collect();
        assert!(soft.len() > 20, "{} soft targets", soft.len());
        soft.iter().sum::<f64>() / soft.len() as f64
    };
    let (h, p) = (miss(&held), miss(&pulled));
    assert!(
        p < 0.8 * h,
        "soft targets missed by {p:.2} mm pulled, {h:.2} mm held"
    );
    assert_readings_within_iso(e, &pulled);
}

/// `RealPeople::breadths_and_depths` gives soft targets to the breadths
/// and depths the mesh can follow, never to the dimensions it cannot
/// measure as ANSUR II does; off, none of them gets one.
#[test]
fn breadths_and_depths_get_soft_targets_only_where_the_mesh_can_follow() {
    use tapeshape_estimator::priors::{CANNOT_FOLLOW_ANSUR, NOT_YET_ANSUR};
    let e = estimator();
    let mut i = entered(&MAN);
    i.sex = Some(Sex::Female);
    let columns = |r: tapeshape_estimator::RealPeople| -> Vec<String> {
        e.soft_targets(&i, &r)
            .unwrap()
            .iter()
            .filter_map(|(j, _, _)| e.set().definitions[*j].ansur.clone())
            .collect()
    };
    let on = columns(tapeshape_estimator::RealPeople {
        breadths_and_depths: true,
        ..Default::default()
    });
    let off = columns(tapeshape_estimator::RealPeople {
        breadths_and_depths: false,
        ..Default::default()
    });
    for c in NOT_YET_ANSUR {
        let can = !CANNOT_FOLLOW_ANSUR.contains(c);
        assert_eq!(
            on.iter().any(|o| o == c),
            can,
            "{c} with breadths and depths"
        );
        assert!(!off.iter().any(|o| o == c), "{c} without");
    }
    assert_eq!(
        on.len(),
        off.len() + NOT_YET_ANSUR.len() - CANNOT_FOLLOW_ANSUR.len()
    );
}

/// Step 2 holds a soft breadth or depth at its step-1 value while it pulls
/// the other soft targets (`Step2Settings::soft_pull`): pulled, a narrower
/// hip bulged the buttocks past their own target, step 2 ended above step
/// 1's energy and gave way to L-BFGS, which kept the step-1 shape (0.58 s
/// instead of 0.09 s for `tapeshape predict` with these four readings).
/// With the defaults the smooth basis's body is kept, the soft calipers
/// stay near their step-1 values, and the readings are met.
#[test]
fn step2_holds_soft_calipers_and_keeps_the_smooth_body() {
    let e = estimator();
    let mut i = Inputs::new();
    for a in ["stature=176.5cm", "chest=98cm", "waist=84cm", "hip=100cm"] {
        i.add_assignment(a).unwrap();
    }
    let est = e.predict(&i, &PredictOptions::default()).unwrap();
    let p = &est.report.prediction;
    assert!(p.settings.step2.soft_pull > 0.0, "the default pulls");
    let first = p.step2_first.as_ref().expect("the smooth basis was tried");
    assert!(first.kept, "step 2's smooth basis gave way: {first:?}");
    assert!(
        !p.warnings
            .iter()
            .any(|w| matches!(w, tapeshape_model::Warning::Step2KeptEarlier { .. })),
        "{:?}",
        p.warnings
    );
    let calipers = ["hipbreadth", "waistbreadth", "waistdepth", "chestdepth"];
    for m in p.measurements.iter().filter(|m| m.soft) {
        let (s1, s2) = (m.step1_mm.unwrap(), m.step2_mm.unwrap());
        if calipers.contains(&m.name.as_str()) {
            assert!(
                (s2 - s1).abs() < 3.0,
                "{}: step 1 {s1:.1} mm, step 2 {s2:.1} mm (target {:.1})",
                m.name,
                m.target_mm.unwrap()
            );
        }
    }
    assert!(
        calipers
            .iter()
            .all(|c| p.measurements.iter().any(|m| m.soft && m.name == *c)),
        "every caliper has a soft target"
    );
    assert_readings_within_iso(e, &est);
}

/// Triangles of `x` whose normal turned by more than 90 degrees from the
/// same triangle of `reference` (both the template's V vertices).
fn flipped_against(
    e: &Estimator,
    reference: &[tapeshape_mesh::Vec3],
    x: &[tapeshape_mesh::Vec3],
) -> usize {
    use tapeshape_mesh::vec3::{dot, triangle_normal};
    let normal = |p: &[tapeshape_mesh::Vec3], f: &[u32; 3]| {
        triangle_normal(p[f[0] as usize], p[f[1] as usize], p[f[2] as usize])
    };
    e.topology()
        .faces()
        .iter()
        .filter(|f| dot(normal(reference, f), normal(x, f)) < 0.0)
        .count()
}

/// A shape far along a few of the learned components can fold the surface
/// where no training body does (the linear space has no notion of a
/// surface): the step-1 shape of ANSUR II train-split subject 14030's
/// `quick` readings flips 81 triangles of the model's mean shape (the feet,
/// the head, the torso), and the body kept them. It is smoothed against the
/// mean before step 2, so the body flips almost none, and its readings are
/// still met.
#[test]
fn a_step1_shape_folded_against_the_mean_is_smoothed_before_step2() {
    let e = estimator();
    // ANSUR II train-split subject 14030 (a man), his values of the
    // `quick` set's ANSUR II columns.
    let mut i = entered(&[
        "stature=168.9cm",
        "chest=127.2cm",
        "waist=101.3cm",
        "hip=101.2cm",
        "neck=50.7cm",
        "inside_leg=80.1cm",
        "arm_length=56.5cm",
        "thigh=58.3cm",
        "upper_arm=43.8cm",
    ]);
    i.sex = Some(Sex::Male);
    let est = e.predict(&i, &PredictOptions::default()).unwrap();
    let model = &e.file().model;
    let mean = model.shape(&vec![0.0; model.n_components()]).unwrap();
    let step1 = model.shape(&est.report.prediction.weights_step1).unwrap();
    let in_space = flipped_against(e, &mean, &step1);
    assert!(
        in_space > 40,
        "the case no longer folds inside the learned space ({in_space} flipped): choose another"
    );
    let body = flipped_against(e, &mean, &est.mesh.vertices);
    assert!(
        body <= 5,
        "the body flips {body} triangles of the mean shape (its step-1 shape {in_space})"
    );
    assert_readings_within_iso(e, &est);
    // The report says so, with the step-1 shape's own count (flipped or
    // collapsed, so at least the flipped ones counted here).
    let said = est.report.warnings.iter().find_map(|w| match w {
        Warning::Model(ModelWarning::Step1Smoothed { folded, left }) => Some((*folded, *left)),
        _ => None,
    });
    let (folded, left) = said.expect("a step1-smoothed warning");
    assert!(folded >= in_space, "{folded} folded, {in_space} flipped");
    assert!(left < folded, "{folded} -> {left}");
}
