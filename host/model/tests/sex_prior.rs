//! The sex prior (tapeshape_model::sexprior) end to end on the synthetic
//! tube family: two "sexes" that differ in the tube's ellipticity, which
//! the one reading given (the height) says nothing about. Given the sex,
//! the estimate must take that sex's ellipticity; without it, a shape
//! between the two; a model trained without sexes must ignore the sex.

mod common;

use common::*;
use tapeshape_mesh::Vec3;
use tapeshape_model::{FitSettings, PredictSettings, Sex, ShapeModel, Target};

/// 60 tubes, even ones "male" (ellipticity 0.25-0.30), odd ones "female"
/// (0.00-0.05); the width at ring 5 (measurement 6) follows the
/// ellipticity.
fn population() -> (Vec<Vec<Vec3>>, Vec<Option<Sex>>) {
    let mut s = 5;
    let mut bodies = Vec::new();
    let mut sexes = Vec::new();
    for i in 0..60 {
        let mut p = random_params(&mut s);
        let male = i % 2 == 0;
        p.e = if male { 0.25 } else { 0.0 } + 0.05 * (p.e / 0.2);
        bodies.push(tube(&p));
        sexes.push(Some(if male { Sex::Male } else { Sex::Female }));
    }
    (bodies, sexes)
}

fn fit(sexes: Option<&[Option<Sex>]>) -> ShapeModel {
    let (bodies, _) = population();
    let meas: Vec<Vec<f64>> = bodies.iter().map(|b| measure_all(b)).collect();
    let refs: Vec<&[Vec3]> = bodies.iter().map(|b| b.as_slice()).collect();
    let settings = FitSettings {
        max_components: Some(8),
        ..Default::default()
    };
    ShapeModel::fit_with_sexes(&refs, &meas, &names(), sexes, &settings).unwrap()
}

/// Width at ring 5 (mm) of the estimate from the height alone.
fn width(model: &ShapeModel, height: f64, sex: Option<Sex>) -> f64 {
    let mut targets: Vec<Option<Target>> = vec![None; 7];
    targets[0] = Some(Target::exact(height));
    let config = PredictSettings::default().resolve().unwrap().with_sex(sex);
    let p = model
        .predict(&targets, &TubeMeasurer, &topology(), &config)
        .unwrap();
    assert!(
        p.report.measurements[0].error_mm.unwrap().abs() < 1.0,
        "the height is met: {:?}",
        p.report.measurements[0].error_mm
    );
    measure_all(&p.vertices)[6] * 1000.0
}

#[test]
fn the_given_sex_sets_what_the_readings_leave_open() {
    let (bodies, sexes) = population();
    let model = fit(Some(&sexes));
    let priors = model.sex_priors.as_ref().expect("30 of each sex, K = 8");
    assert_eq!((priors.male.n, priors.female.n), (30, 30));
    let mean_width = |sex: Sex| {
        let w: Vec<f64> = bodies
            .iter()
            .zip(&sexes)
            .filter(|(_, s)| **s == Some(sex))
            .map(|(b, _)| measure_all(b)[6] * 1000.0)
            .collect();
        w.iter().sum::<f64>() / w.len() as f64
    };
    let (male_w, female_w) = (mean_width(Sex::Male), mean_width(Sex::Female));
    assert!(male_w - female_w > 20.0, "{male_w} vs {female_w}");
    for h in [1.55, 1.7, 1.85] {
        let m = width(&model, h, Some(Sex::Male));
        let f = width(&model, h, Some(Sex::Female));
        let none = width(&model, h, None);
        // Each within a fifth of the gap of its sex's mean; without the sex,
        // nearer the middle than either.
        let gap = male_w - female_w;
        assert!(
            (m - male_w).abs() < 0.2 * gap,
            "h {h}: male {m} vs {male_w}"
        );
        assert!(
            (f - female_w).abs() < 0.2 * gap,
            "h {h}: female {f} vs {female_w}"
        );
        assert!(f < none && none < m, "h {h}: {f} < {none} < {m}");
    }
}

#[test]
fn a_model_without_sexes_ignores_the_sex() {
    let model = fit(None);
    assert!(model.sex_priors.is_none());
    let a = width(&model, 1.7, Some(Sex::Male));
    let b = width(&model, 1.7, None);
    assert_eq!(a.to_bits(), b.to_bits());
}
