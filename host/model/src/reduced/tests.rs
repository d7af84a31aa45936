//! The reduced step 2 against finite differences, against the full
//! objective, and against L-BFGS on the same problem.

use super::*;
use crate::energy::tests::lcg;
use crate::gauss_newton::tests::{grid, terms};
use crate::lbfgs::{minimise, Lbfgs, LineSearch, StopRule};
use crate::refine::VertexObjective;

fn converged_lbfgs() -> Lbfgs {
    Lbfgs {
        stop: StopRule {
            max_iters: 200_000,
            grad_tol: 1e-9,
            rel_cost_tol: 0.0,
            history: 5,
        },
        line_search: LineSearch::Backtracking,
    }
}

fn random(n: usize, seed: u64, scale: f64) -> Vec<f64> {
    let mut s = seed;
    (0..n).map(|_| scale * lcg(&mut s)).collect()
}

/// The reduced energy is the full step-2 energy at `x0 + B C`, and its
/// gradient is `B^T` of the full one (chain rule), at random coefficients.
#[test]
fn reduced_energy_and_gradient_are_the_full_ones_in_the_basis() {
    let w = 8;
    let (reference, edges) = grid(w, 5);
    let n = reference.len() / 3;
    let basis = SmoothBasis::compute(n, &edges, 20).unwrap();
    let terms = terms(&reference, w, 1.03);
    // A start away from the reference, so that E_s's linear term counts.
    let x0: Vec<f64> = reference
        .iter()
        .zip(random(reference.len(), 4, 0.5))
        .map(|(a, b)| a + b)
        .collect();
    let obj = ReducedObjective::new(terms.clone(), &basis, &edges, &reference, &x0, 0.1);
    let full = VertexObjective::new(terms, &edges, &reference, 0.1);
    let c = random(obj.len(), 3, 2.0);
    let mut g = vec![0.0; obj.len()];
    let f = obj.eval(&c, &mut g);
    // x0 + B C with the basis itself (`vertices` reads its f32 copy).
    let k = basis.k();
    let x: Vec<f64> = (0..reference.len())
        .map(|j| {
            let (v, a) = (j / 3, j % 3);
            x0[j] + (0..k).map(|i| basis.row(v)[i] * c[a * k + i]).sum::<f64>()
        })
        .collect();
    let mut gx = vec![0.0; x.len()];
    let fx = full.eval(&x, &mut gx);
    assert!((f - fx).abs() <= 1e-9 * fx.abs(), "{f} vs {fx}");
    // And at the f32 basis's vertices, to the basis's rounding.
    let mut x32 = vec![0.0; reference.len()];
    obj.vertices(&x0, &c, &mut x32);
    let f32_energy = full.eval(&x32, &mut vec![0.0; x.len()]);
    assert!(
        (f - f32_energy).abs() <= 1e-6 * fx.abs(),
        "{f} vs {f32_energy}"
    );
    for a in 0..3 {
        for i in 0..k {
            let want: f64 = (0..n).map(|v| basis.row(v)[i] * gx[3 * v + a]).sum();
            let got = g[a * k + i];
            assert!(
                (got - want).abs() <= 1e-8 * want.abs().max(1.0),
                "coordinate {a} mode {i}: {got} vs {want}"
            );
        }
    }
    // And against central differences of the reduced energy itself.
    let h = 1e-6;
    for j in [0, 5, k + 3, 2 * k + 7, 3 * k - 1] {
        let (mut cp, mut cm) = (c.clone(), c.clone());
        cp[j] += h;
        cm[j] -= h;
        let mut scratch = vec![0.0; obj.len()];
        let fd = (obj.eval(&cp, &mut scratch) - obj.eval(&cm, &mut scratch)) / (2.0 * h);
        assert!(
            (fd - g[j]).abs() <= 1e-5 * g[j].abs().max(1.0),
            "{j}: {fd} vs {}",
            g[j]
        );
    }
}

/// Where the residuals vanish the Gauss-Newton Hessian is the Hessian:
/// `H v` against central differences of the gradient.
#[test]
fn hessian_matches_finite_differences_at_a_fit() {
    let w = 6;
    let (x, edges) = grid(w, 3);
    let n = x.len() / 3;
    let basis = SmoothBasis::compute(n, &edges, 15).unwrap();
    // Terms fitted at the reference, so residuals vanish at c = 0.
    let terms = terms(&x, w, 1.0);
    let obj = ReducedObjective::new(terms, &basis, &edges, &x, &x, 0.1);
    let c = vec![0.0; obj.len()];
    let hm = obj.hessian(&c, 0.0);
    let v = random(obj.len(), 9, 1.0);
    let h = 1e-5;
    let cp: Vec<f64> = c.iter().zip(&v).map(|(a, b)| a + h * b).collect();
    let cm: Vec<f64> = c.iter().zip(&v).map(|(a, b)| a - h * b).collect();
    let (mut gp, mut gm) = (vec![0.0; obj.len()], vec![0.0; obj.len()]);
    obj.eval(&cp, &mut gp);
    obj.eval(&cm, &mut gm);
    let hv: Vec<f64> = (0..obj.len())
        .map(|i| (0..obj.len()).map(|j| hm[(i, j)] * v[j]).sum())
        .collect();
    let scale = hv.iter().fold(0.0f64, |m, a| m.max(a.abs()));
    for i in 0..obj.len() {
        let fd = (gp[i] - gm[i]) / (2.0 * h);
        assert!(
            (fd - hv[i]).abs() < 1e-5 * scale,
            "{i}: finite differences {fd} vs assembled {}",
            hv[i]
        );
    }
}

/// The Woodbury step solves the dense Gauss-Newton system.
#[test]
fn woodbury_step_solves_the_dense_system() {
    let w = 7;
    let (reference, edges) = grid(w, 4);
    let n = reference.len() / 3;
    let basis = SmoothBasis::compute(n, &edges, 25).unwrap();
    let obj = ReducedObjective::new(
        terms(&reference, w, 1.05),
        &basis,
        &edges,
        &reference,
        &reference,
        0.1,
    );
    let c = random(obj.len(), 5, 0.3);
    let mut g = vec![0.0; obj.len()];
    obj.eval(&c, &mut g);
    let mu = 1e-3;
    let (dinv, kmat) = obj.kernel(mu);
    let delta = obj.step(&c, &g, &dinv, &kmat).unwrap();
    let h = obj.hessian(&c, mu);
    let scale = g.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    for i in 0..obj.len() {
        let hd: f64 = (0..obj.len()).map(|j| h[(i, j)] * delta[j]).sum();
        assert!(
            (hd + g[i]).abs() <= 1e-8 * scale,
            "{i}: (H delta + g) = {}",
            hd + g[i]
        );
    }
}

/// On the same problem: the reduced Gauss-Newton run reaches the minimum
/// L-BFGS finds on the reduced objective (within 1e-6 of the energy) in a
/// handful of iterations, never below the full problem's minimum, and
/// with every mode (k = V) the full problem's minimum itself.
#[test]
fn reduced_gauss_newton_reaches_the_lbfgs_minimum() {
    let w = 8;
    let (reference, edges) = grid(w, 5);
    let n = reference.len() / 3;
    let terms = terms(&reference, w, 1.03);
    let full = VertexObjective::new(terms.clone(), &edges, &reference, 0.1);
    let (_, full_lb) = minimise(&full, reference.clone(), &converged_lbfgs()).unwrap();
    for k in [24, n] {
        let basis = SmoothBasis::compute(n, &edges, k).unwrap();
        let obj = ReducedObjective::new(terms.clone(), &basis, &edges, &reference, &reference, 0.1);
        let (_, gn) = minimise_reduced(
            &obj,
            vec![0.0; obj.len()],
            &GaussNewtonStop::default(),
            0.0,
            &|_| Control::Continue,
        )
        .unwrap();
        let (_, lb) = minimise(&obj, vec![0.0; obj.len()], &converged_lbfgs()).unwrap();
        assert!(gn.cost_end < gn.cost_start * 1e-1, "k = {k}: {gn:?}");
        assert!(gn.iterations <= 12, "k = {k}: {gn:?}");
        let rel = (gn.cost_end - lb.cost_end).abs() / lb.cost_end;
        assert!(rel < 1e-6, "k = {k}: {gn:?} vs L-BFGS {lb:?}");
        assert!(
            gn.cost_end >= full_lb.cost_end * (1.0 - 1e-6),
            "k = {k}: below the full minimum: {gn:?} vs {full_lb:?}"
        );
        if k == n {
            let rel = (gn.cost_end - full_lb.cost_end).abs() / full_lb.cost_end;
            assert!(rel < 1e-6, "all modes: {gn:?} vs full {full_lb:?}");
        }
    }
}

/// Two runs give the same coefficients bit for bit.
#[test]
fn deterministic() {
    let w = 8;
    let (reference, edges) = grid(w, 7);
    let n = reference.len() / 3;
    let basis = SmoothBasis::compute(n, &edges, 30).unwrap();
    let run = || {
        let obj = ReducedObjective::new(
            terms(&reference, w, 0.97),
            &basis,
            &edges,
            &reference,
            &reference,
            0.1,
        );
        minimise_reduced(
            &obj,
            vec![0.0; obj.len()],
            &GaussNewtonStop::default(),
            0.0,
            &|_| Control::Continue,
        )
        .unwrap()
    };
    let (a, ia) = run();
    let (b, ib) = run();
    assert_eq!(a, b);
    assert_eq!(ia, ib);
}

/// A watcher that cancels ends the run at once with the start point.
#[test]
fn cancel_before_the_first_evaluation() {
    let w = 5;
    let (reference, edges) = grid(w, 2);
    let basis = SmoothBasis::compute(reference.len() / 3, &edges, 5).unwrap();
    let obj = ReducedObjective::new(
        terms(&reference, w, 1.1),
        &basis,
        &edges,
        &reference,
        &reference,
        0.1,
    );
    let c0 = vec![0.5; obj.len()];
    let (c, info) = minimise_reduced(&obj, c0.clone(), &GaussNewtonStop::default(), 0.0, &|_| {
        Control::Cancel
    })
    .unwrap();
    assert_eq!(c, c0);
    assert_eq!(info.reason, Termination::Interrupted);
}

/// The owners of [`terms`]: a length, a height, a loop of four segments.
const OWNER: [usize; 6] = [0, 1, 2, 2, 2, 2];

/// The readings' form: its gradient against central differences, and its
/// Gauss-Newton run reaching the minimum L-BFGS finds on it (within 1e-6
/// of the energy) in a handful of iterations, with the readings met far
/// closer than they started.
#[test]
fn readings_fit_gradient_and_minimum() {
    let w = 8;
    let (reference, edges) = grid(w, 5);
    let n = reference.len() / 3;
    let basis = SmoothBasis::compute(n, &edges, 24).unwrap();
    let terms = terms(&reference, w, 1.03);
    let obj = ReducedObjective::new(terms, &basis, &edges, &reference, &reference, 0.1)
        .fit_readings(&OWNER);
    let c = random(obj.len(), 8, 0.5);
    let mut g = vec![0.0; obj.len()];
    obj.eval(&c, &mut g);
    let h = 1e-6;
    let mut scratch = vec![0.0; obj.len()];
    // Relative to the largest entry: the energy is large (stiff weights),
    // so central differences of small entries lose digits to rounding.
    let gmax = g.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    for j in [0, 3, 24 + 5, 48 + 11, 71] {
        let (mut cp, mut cm) = (c.clone(), c.clone());
        cp[j] += h;
        cm[j] -= h;
        let fd = (obj.eval(&cp, &mut scratch) - obj.eval(&cm, &mut scratch)) / (2.0 * h);
        assert!((fd - g[j]).abs() <= 1e-6 * gmax, "{j}: {fd} vs {}", g[j]);
    }
    let (c_gn, gn) = minimise_reduced(
        &obj,
        vec![0.0; obj.len()],
        &GaussNewtonStop::default(),
        0.0,
        &|_| Control::Continue,
    )
    .unwrap();
    let (_, lb) = minimise(&obj, vec![0.0; obj.len()], &converged_lbfgs()).unwrap();
    assert!(gn.iterations <= 12, "{gn:?}");
    let rel = (gn.cost_end - lb.cost_end).abs() / lb.cost_end;
    assert!(rel < 1e-6, "{gn:?} vs L-BFGS {lb:?}");
    // The readings' own error: far below where it started.
    let fit = obj.readings.as_ref().unwrap();
    let error = |c: &[f64]| -> f64 {
        let mut d = vec![0.0; 3 * obj.terms.len()];
        obj.segments(c, &mut d);
        let (len, _) = obj.lengths(&d);
        let mut value = vec![0.0; fit.target.len()];
        for (&j, l) in fit.owner.iter().zip(&len) {
            value[j] += l;
        }
        value
            .iter()
            .zip(&fit.target)
            .map(|(v, t)| (v - t).abs())
            .sum()
    };
    let (before, after) = (error(&vec![0.0; obj.len()]), error(&c_gn));
    assert!(
        after < 0.05 * before,
        "reading error {before} -> {after} mm"
    );
}

/// A start inside the basis (`x0 = x_ref + B c0`): the objective built
/// from `c0` is the one built from the mesh, to rounding.
#[test]
fn offset_in_the_basis_gives_the_same_objective() {
    let w = 8;
    let (reference, edges) = grid(w, 5);
    let n = reference.len() / 3;
    let basis = SmoothBasis::compute(n, &edges, 20).unwrap();
    let terms = terms(&reference, w, 1.03);
    let c0 = random(3 * basis.k(), 6, 1.5);
    let probe = ReducedObjective::new(terms.clone(), &basis, &edges, &reference, &reference, 0.1);
    let mut x0 = vec![0.0; reference.len()];
    probe.vertices(&reference, &c0, &mut x0);
    let a = ReducedObjective::new(terms.clone(), &basis, &edges, &reference, &x0, 0.1);
    let b = ReducedObjective::with_offset(terms, &basis, &x0, &c0, 0.1);
    let c = random(a.len(), 7, 0.7);
    let (mut ga, mut gb) = (vec![0.0; a.len()], vec![0.0; a.len()]);
    let (fa, fb) = (a.eval(&c, &mut ga), b.eval(&c, &mut gb));
    assert!((fa - fb).abs() <= 1e-9 * fa.abs(), "{fa} vs {fb}");
    let gmax = ga.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    for (x, y) in ga.iter().zip(&gb) {
        assert!((x - y).abs() <= 1e-9 * gmax, "{x} vs {y}");
    }
}

/// `vertices` is `x0 + B C` vertex by vertex, bit for bit the plain loop,
/// on a mesh whose vertex count is not a multiple of the four it does at
/// once.
#[test]
fn vertices_are_the_start_plus_the_basis_times_the_coefficients() {
    let w = 7;
    let (reference, edges) = grid(w, 5);
    let n = reference.len() / 3;
    assert_ne!(n % 4, 0);
    let basis = SmoothBasis::compute(n, &edges, 12).unwrap();
    let terms = terms(&reference, w, 1.03);
    let x0: Vec<f64> = reference
        .iter()
        .zip(random(reference.len(), 9, 0.5))
        .map(|(a, b)| a + b)
        .collect();
    let obj = ReducedObjective::new(terms, &basis, &edges, &reference, &x0, 0.1);
    let c = random(obj.len(), 5, 2.0);
    let mut x = vec![0.0; reference.len()];
    obj.vertices(&x0, &c, &mut x);
    let k = basis.k();
    for v in 0..n {
        for a in 0..3 {
            // The f32 basis's row, summed as `dot_widened` does (four
            // partial sums, `kernels::rows_dot3`).
            let row32 = &basis.rows_f32()[v * k..(v + 1) * k];
            let sum = crate::lbfgs::dot_widened(row32, &c[a * k..(a + 1) * k]);
            // Within the f32 rounding of the basis of the exact B c.
            let exact: f64 = (0..k).map(|i| basis.row(v)[i] * c[a * k + i]).sum();
            let size: f64 = (0..k).map(|i| (basis.row(v)[i] * c[a * k + i]).abs()).sum();
            assert!(
                (sum - exact).abs() <= 1e-7 * size + 1e-15,
                "{sum} vs {exact}"
            );
            let want = x0[3 * v + a] + sum;
            assert_eq!(
                x[3 * v + a].to_bits(),
                want.to_bits(),
                "vertex {v} coordinate {a}"
            );
        }
    }
    assert!(
        x.iter().zip(&x0).any(|(a, b)| a != b),
        "the coefficients move the mesh"
    );
}

/// The readings' Gauss-Newton step (its system formed as a lower
/// triangle, its Jacobian kept across a refused step) solves the dense
/// system `(2 (1 - lambda) J^T W J + diag(4 lambda sigma + mu)) delta = -g`
/// built here entry by entry from the same Jacobian, at two dampings.
#[test]
fn readings_step_solves_the_dense_system() {
    let w = 8;
    let (reference, edges) = grid(w, 5);
    let n = reference.len() / 3;
    let basis = SmoothBasis::compute(n, &edges, 24).unwrap();
    let obj = ReducedObjective::new(
        terms(&reference, w, 1.04),
        &basis,
        &edges,
        &reference,
        &reference,
        0.1,
    )
    .fit_readings(&OWNER);
    let fit = obj.readings.as_ref().unwrap();
    let c = random(obj.len(), 9, 0.4);
    let mut g = vec![0.0; obj.len()];
    obj.eval(&c, &mut g);
    let jac = obj.readings_jacobian(fit, &c);
    let nn = obj.len();
    let k = basis.k();
    let scale = g.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    for mu in [1e-4, 3.0] {
        let delta = obj.readings_solve(fit, &jac, &g, mu).unwrap();
        for i in 0..nn {
            let mut hd = (4.0 * 0.1 * basis.values()[i % k] + mu) * delta[i];
            for (r, w_r) in fit.weight.iter().enumerate() {
                let jr = &jac[r * nn..(r + 1) * nn];
                let jd: f64 = jr.iter().zip(&delta).map(|(a, b)| a * b).sum();
                hd += 2.0 * 0.9 * w_r * jr[i] * jd;
            }
            assert!(
                (hd + g[i]).abs() <= 1e-8 * scale,
                "mu {mu}, {i}: (H delta + g) = {}",
                hd + g[i]
            );
        }
    }
}

/// The absolute stopping rule: told its readings' energy scale, a run
/// with `min_decrease_mm` ends on it, in fewer iterations than the run to
/// the relative tolerance, at an energy above that run's by less than
/// what a few tenths of a millimetre on one reading cost; without the
/// scale (or with 0 mm) the rule is off and the run is the plain one.
#[test]
fn min_decrease_ends_the_run_within_a_reading_tolerance() {
    let w = 8;
    let (reference, edges) = grid(w, 5);
    let n = reference.len() / 3;
    let basis = SmoothBasis::compute(n, &edges, 24).unwrap();
    let make = || {
        ReducedObjective::new(
            terms(&reference, w, 1.06),
            &basis,
            &edges,
            &reference,
            &reference,
            0.1,
        )
        .fit_readings(&OWNER)
    };
    let run = |obj: &ReducedObjective<'_>, mm: f64| {
        minimise_reduced(
            obj,
            vec![0.0; obj.len()],
            &GaussNewtonStop::default(),
            mm,
            &|_| Control::Continue,
        )
        .unwrap()
    };
    let plain = make();
    let (c_full, full) = run(&plain, 0.0);
    // The rule needs the scale: without it 0.1 mm changes nothing.
    let (c_unscaled, unscaled) = run(&plain, 0.1);
    assert_eq!(c_unscaled, c_full);
    assert_eq!(unscaled.iterations, full.iterations);
    // The test's terms weigh each reading about 1e4 per mm^2 (the segment
    // weights of `terms`); with that scale a 0.1 mm step is 90 units.
    let reading_weight = 1e4;
    let scaled = make().with_reading_energy(reading_weight);
    let (c_off, off) = run(&scaled, 0.0);
    assert_eq!(c_off, c_full, "0 mm: the rule is off");
    assert_eq!(off.iterations, full.iterations);
    let (_, early) = run(&scaled, 0.1);
    let per_mm2 = 0.9 * reading_weight;
    assert!(early.cost_end >= full.cost_end - 1e-9 * full.cost_end.abs());
    assert!(
        early.cost_end - full.cost_end <= per_mm2 * 0.3 * 0.3,
        "{early:?} vs {full:?}"
    );
    assert_eq!(early.reason, Termination::DecreaseBelowReading, "{early:?}");
    assert!(early.iterations < full.iterations, "{early:?} vs {full:?}");
}
