//! SGPLVM: analytic gradients against central differences (learning and
//! latent search), training on the fixture, better than the mean body,
//! subsets, bad targets.

mod methods_common;

use methods_common::{all_given, fixture, mean_body, mean_error_mm};
use nalgebra::DMatrix;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use tapeshape_eval::methods::sgplvm::{JointLikelihood, Kernel, LatentObjective};
use tapeshape_eval::methods::{Sgplvm, SgplvmSettings};
use tapeshape_eval::Method;
use tapeshape_model::refine::Objective;

/// Largest |analytic - central difference| relative to max(1, |gradient|).
fn gradient_check(obj: &dyn Objective, x: &[f64]) -> f64 {
    let mut g = vec![0.0; x.len()];
    obj.eval(x, &mut g);
    let mut worst = 0.0f64;
    let mut scratch = vec![0.0; x.len()];
    for i in 0..x.len() {
        let h = 1e-5 * x[i].abs().max(1.0);
        let mut xp = x.to_vec();
        xp[i] += h;
        let fp = obj.eval(&xp, &mut scratch);
        xp[i] -= 2.0 * h;
        let fm = obj.eval(&xp, &mut scratch);
        let fd = (fp - fm) / (2.0 * h);
        worst = worst.max((fd - g[i]).abs() / g[i].abs().max(1.0));
    }
    worst
}

#[test]
fn joint_likelihood_gradient_matches_finite_differences() {
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    let (n, q) = (12, 3);
    let spaces = vec![
        DMatrix::from_fn(n, 5, |_, _| rng.random_range(-1.0..1.0)),
        DMatrix::from_fn(n, 7, |_, _| rng.random_range(-2.0..2.0)),
    ];
    let obj = JointLikelihood { spaces, q };
    let mut theta: Vec<f64> = (0..n * q).map(|_| rng.random_range(-1.0..1.0)).collect();
    theta.extend([0.1, -0.3, -2.0, -1.5, 0.5, 0.2, -3.0, -1.0]);
    assert_eq!(theta.len(), obj.n_params());
    let worst = gradient_check(&obj, &theta);
    assert!(worst < 1e-5, "relative gradient error {worst}");
}

#[test]
fn latent_objective_gradient_matches_finite_differences() {
    let mut rng = ChaCha8Rng::seed_from_u64(4);
    let (n, q, d) = (15, 3, 4);
    let x = DMatrix::from_fn(n, q, |_, _| rng.random_range(-1.5..1.5));
    let y = DMatrix::from_fn(n, d, |_, _| rng.random_range(-1.0..1.0));
    let kernel = Kernel {
        alpha: 1.3,
        gamma: 0.8,
        bias: 0.05,
        noise: 0.02,
    };
    let chol = kernel.matrix(&x).cholesky().unwrap();
    let kinv = chol.inverse();
    let alpha = chol.solve(&y).select_columns([0usize, 2, 3].iter());
    let obj = LatentObjective {
        x: &x,
        kernel,
        kinv: &kinv,
        alpha,
        y: vec![0.3, -0.7, 1.1],
    };
    for start in [[0.2, -0.4, 0.9], [1.0, 1.0, -1.0], [0.0, 0.0, 0.0]] {
        let worst = gradient_check(&obj, &start);
        assert!(worst < 1e-5, "relative gradient error {worst} at {start:?}");
    }
}

#[test]
fn learns_and_reproduces_bodies_better_than_the_mean() {
    let f = fixture();
    let sg = Sgplvm::fit(&f.data, SgplvmSettings::default()).unwrap();
    let info = sg.fit_info();
    eprintln!(
        "SGPLVM: {info:?}, {} weight dims, kernels {:?}",
        sg.weight_dims(),
        sg.kernels()
    );
    // The learning really ran and improved the likelihood.
    assert!(
        info.cost_end.is_finite() && info.iterations > 10,
        "{info:?}"
    );
    assert!(info.cost_end < info.cost_start - 0.05, "{info:?}");
    let set = &f.data.compiled;
    let mean = mean_body(&f.data);
    let v = f.data.topology.n_vertices();
    for i in [3usize, 17] {
        let row = &f.data.measurements[i];
        let out = sg.predict(&all_given(row)).unwrap();
        assert_eq!(out.vertices.len(), v);
        let (e, e_mean) = (
            mean_error_mm(set, &out.vertices, row),
            mean_error_mm(set, &mean, row),
        );
        eprintln!("SGPLVM body {i}: {e:.3} mm, mean body {e_mean:.3} mm");
        assert!(e < 0.5 * e_mean, "{e} vs {e_mean}");
    }
    let row = &f.heldout_measurements[2];
    let some: Vec<Option<f64>> = row
        .iter()
        .enumerate()
        .map(|(j, &x)| (j % 2 == 0).then_some(x))
        .collect();
    let out = sg.predict(&some).unwrap();
    assert_eq!(out.vertices.len(), v);
    let got = methods_common::measure(set, &out.vertices);
    let mean_m = methods_common::measure(set, &mean);
    let err = |m: &[f64]| {
        (0..row.len())
            .filter(|j| j % 2 == 0)
            .map(|j| (m[j] - row[j]).abs())
            .sum::<f64>()
    };
    eprintln!(
        "SGPLVM held out, half given: {:.4} m vs mean {:.4} m",
        err(&got),
        err(&mean_m)
    );
    assert!(err(&got) < err(&mean_m));
    // Bad targets.
    let m = row.len();
    assert!(sg.predict(&vec![Some(1.0); m - 2]).is_err());
    assert!(sg.predict(&vec![None; m]).is_err());
    let mut bad = all_given(row);
    bad[5] = Some(f64::NAN);
    assert!(sg.predict(&bad).is_err());
    // Bad settings.
    let s = SgplvmSettings {
        latent_dim: 0,
        ..SgplvmSettings::default()
    };
    assert!(Sgplvm::fit(&f.data, s).is_err());
}
