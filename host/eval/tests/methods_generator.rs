//! Generator fit: recovers the measurements of a body the generator made
//! (inside its parameter space), reproduces a population body better than
//! the mean body, keeps parameters in range, refuses bad input.

mod methods_common;

use std::time::Instant;

use methods_common::{all_given, fixture, mean_body, mean_error_mm, measure};
use tapeshape_body::{BodyModel, LocalChanges, Phenotype};
use tapeshape_eval::methods::{GeneratorFit, GeneratorFitSettings};
use tapeshape_eval::Method;

#[test]
fn recovers_the_measurements_of_a_generated_body() {
    let f = fixture();
    let gf = GeneratorFit::new(&f.data, GeneratorFitSettings::default()).unwrap();
    let body = BodyModel::shared().unwrap();
    let ph = Phenotype {
        gender: 0.2,
        weight: 0.68,
        height: 0.45,
        muscle: 0.4,
        proportions: 0.6,
        ..Phenotype::default()
    };
    let mut lc = LocalChanges::new();
    lc.set("measure-waist-circ-incr", 0.3).unwrap();
    lc.set("measure-upperarm-length-incr", -0.2).unwrap();
    lc.set("measure-thigh-circ-incr", 0.25).unwrap();
    let truth = body.generate(&ph, &lc).unwrap().vertices;
    let target = measure(&f.data.compiled, &truth);
    let t0 = Instant::now();
    let sol = gf.fit_parameters(&all_given(&target)).unwrap();
    eprintln!(
        "generator fit: rms {:.3} mm after {} iterations in {:.2?}; {:?}",
        sol.rms_mm,
        sol.iterations,
        t0.elapsed(),
        sol.phenotype
    );
    let e = mean_error_mm(&f.data.compiled, &sol.vertices, &target);
    let e_mean = mean_error_mm(&f.data.compiled, &mean_body(&f.data), &target);
    assert!(e < 1.0, "mean error {e} mm (mean body {e_mean} mm)");
    assert!(sol.phenotype.validate().is_ok());
    assert!(sol
        .local_changes
        .iter()
        .all(|(_, v)| (-1.0..=1.0).contains(&v)));
    // The macro parameters that the measurements pin down come back.
    assert!(
        (sol.phenotype.height - ph.height).abs() < 0.05,
        "{:?}",
        sol.phenotype
    );
    assert_eq!(sol.vertices.len(), f.data.topology.n_vertices());
}

#[test]
fn population_body_better_than_the_mean_and_bad_input() {
    let f = fixture();
    let gf = GeneratorFit::new(&f.data, GeneratorFitSettings::default()).unwrap();
    let row = &f.heldout_measurements[3];
    let out = gf.predict(&all_given(row)).unwrap();
    assert!(out.weights.is_none());
    let e = mean_error_mm(&f.data.compiled, &out.vertices, row);
    let e_mean = mean_error_mm(&f.data.compiled, &mean_body(&f.data), row);
    eprintln!("generator fit, held-out body: {e:.3} mm (mean body {e_mean:.3} mm)");
    assert!(e < 0.5 * e_mean, "{e} vs {e_mean}");
    // Only the waist given (8 cm above this body's): a body with that waist.
    let j = f
        .data
        .compiled
        .set()
        .index_of("waist_circumference")
        .expect("paper34 has the waist");
    let mut only = vec![None; row.len()];
    only[j] = Some(row[j] + 0.08);
    let out = gf.predict(&only).unwrap();
    let got = measure(&f.data.compiled, &out.vertices)[j];
    assert!(
        (got - row[j] - 0.08).abs() < 0.002,
        "waist {got} for {}",
        row[j] + 0.08
    );
    // Bad targets and settings.
    assert!(gf.predict(&vec![Some(1.0); row.len() + 3]).is_err());
    assert!(gf.predict(&vec![None; row.len()]).is_err());
    let mut bad = all_given(row);
    bad[0] = Some(-1.0);
    assert!(gf.predict(&bad).is_err());
    let s = GeneratorFitSettings {
        prior_weight: f64::NAN,
        ..GeneratorFitSettings::default()
    };
    assert!(GeneratorFit::new(&f.data, s).is_err());
}
