//! Gaussian RBF interpolation: exact at the training points without
//! regularisation, better than the mean body, subsets, bad targets.

mod methods_common;

use methods_common::{all_given, fixture, mean_body, mean_error_mm};
use tapeshape_eval::methods::{training_weights, RbfInterpolation, RbfSettings, Width};
use tapeshape_eval::Method;

#[test]
fn interpolates_training_points_exactly_without_regularisation() {
    let f = fixture();
    let rbf = RbfInterpolation::fit(
        &f.data,
        RbfSettings {
            width: Width::Factor(1.0),
            regularisation: 0.0,
        },
    )
    .unwrap();
    let ours = tapeshape_eval::methods::Ours::fit(&f.data, Default::default()).unwrap();
    let wt = training_weights(ours.model(), &f.data);
    for i in [0usize, 11, 39] {
        let out = rbf.predict(&all_given(&f.data.measurements[i])).unwrap();
        let w = out.weights.unwrap();
        let worst = w
            .iter()
            .zip(&wt[i])
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max);
        assert!(worst < 1e-6, "body {i}: weight error {worst}");
        // And so the mesh is the training body's projection (PCA keeps all
        // N - 1 components, so the body itself up to f32 storage).
        let d = out
            .vertices
            .iter()
            .zip(&f.data.meshes[i])
            .map(|(a, b)| (0..3).map(|c| (a[c] - b[c]).powi(2)).sum::<f64>().sqrt())
            .fold(0.0, f64::max);
        assert!(d < 1e-5, "body {i}: vertex distance {d} m");
    }
}

#[test]
fn default_width_by_leave_one_out_reproduces_bodies_better_than_the_mean() {
    let f = fixture();
    let rbf = RbfInterpolation::fit(&f.data, RbfSettings::default()).unwrap();
    assert!(rbf.width_factor() > 0.0 && rbf.width() > 0.0);
    let mean = mean_body(&f.data);
    let set = &f.data.compiled;
    for i in [3usize, 17] {
        let row = &f.data.measurements[i];
        let out = rbf.predict(&all_given(row)).unwrap();
        assert_eq!(out.vertices.len(), f.data.topology.n_vertices());
        let (e, e_mean) = (
            mean_error_mm(set, &out.vertices, row),
            mean_error_mm(set, &mean, row),
        );
        eprintln!(
            "RBF body {i}: {e:.3} mm, mean body {e_mean:.3} mm (c = {})",
            rbf.width_factor()
        );
        assert!(e < 0.2 * e_mean, "{e} vs {e_mean}");
    }
    // A held-out body, all and a third of the measurements.
    let row = &f.heldout_measurements[1];
    let e_mean = mean_error_mm(set, &mean, row);
    let out = rbf.predict(&all_given(row)).unwrap();
    let e = mean_error_mm(set, &out.vertices, row);
    eprintln!("RBF held out: {e:.3} mm, mean body {e_mean:.3} mm");
    assert!(e < e_mean);
    let some: Vec<Option<f64>> = row
        .iter()
        .enumerate()
        .map(|(j, &x)| (j % 3 == 0).then_some(x))
        .collect();
    let out = rbf.predict(&some).unwrap();
    assert_eq!(out.vertices.len(), f.data.topology.n_vertices());
    let got = methods_common::measure(set, &out.vertices);
    let mean_m = methods_common::measure(set, &mean);
    let err = |m: &[f64]| {
        (0..row.len())
            .filter(|j| j % 3 == 0)
            .map(|j| (m[j] - row[j]).abs())
            .sum::<f64>()
    };
    assert!(
        err(&got) < err(&mean_m),
        "{} vs {}",
        err(&got),
        err(&mean_m)
    );
}

#[test]
fn bad_targets_and_settings_are_errors() {
    let f = fixture();
    let rbf = RbfInterpolation::fit(&f.data, RbfSettings::default()).unwrap();
    let m = f.data.compiled.len();
    assert!(rbf.predict(&vec![Some(1.0); m + 1]).is_err());
    assert!(rbf.predict(&vec![None; m]).is_err());
    let mut t = all_given(&f.data.measurements[0]);
    t[0] = Some(f64::INFINITY);
    assert!(rbf.predict(&t).is_err());
    let bad = RbfSettings {
        width: Width::Factor(-1.0),
        regularisation: 0.0,
    };
    assert!(RbfInterpolation::fit(&f.data, bad).is_err());
}
