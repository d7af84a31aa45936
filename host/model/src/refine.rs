//! The two refinement objectives the L-BFGS runs of a prediction minimise.
//!
//! * [`WeightObjective`] (step 1): `E_m` over the K normalised PCA weights,
//!   optionally with the training Gaussian's prior and held components.
//! * [`VertexObjective`] (step 2): `(1 - lambda) E_m + lambda E_s` over the
//!   3V vertex coordinates (optionally `E_s + mu E_b`, the bending term).
//!
//! Both evaluate the energy and its gradient together and allocate nothing
//! per evaluation. The solver is [`crate::lbfgs`] (re-exported here, where
//! callers have found it so far).

use std::cell::RefCell;

use crate::energy::{
    bending_of_displacement, measurement_energy, smoothness_of_displacement, SegmentTerm,
};
use crate::lbfgs::{axpy, dot};
pub use crate::lbfgs::{
    minimise, minimise_watched, Control, Lbfgs, LineSearch, MinimiseError, Objective, RunInfo,
    StopRule, Termination,
};

/// Step 1: `E_m` as a function of the normalised weights `w` (length K).
///
/// Every segment vector is linear in the weights, `d_e(w) = c_e + C_e w`,
/// where `C_e` (3 x K, mm per unit weight) combines the rows of
/// `1000 * A diag(sigma)` of the (up to four) vertices of the segment's end
/// points with their interpolation weights, and `c_e` the same combination of
/// the mean shape. These are built once per round, so an evaluation costs
/// O(3 K) per segment and never touches the rest of the mesh; the gradient is
/// `sum_e C_e^T dE/dd_e`, the chain rule through the PCA basis.
pub struct WeightObjective {
    k: usize,
    /// Per segment, 3 rows of K entries (`C_e`, row-major).
    rows: Vec<f64>,
    /// Per segment, `c_e` (3 entries).
    base: Vec<f64>,
    /// The terms (targets, weights and axes; their points are not used after construction).
    terms: Vec<SegmentTerm>,
    /// Coefficient of the Gaussian prior term `prior |w|^2` (0: none).
    prior: f64,
    /// `held[i]`: weight i does not move (its gradient is zeroed); empty: all move.
    held: Vec<bool>,
}

impl WeightObjective {
    /// Builds the objective from the rows of the scaled basis of the vertices
    /// the terms use: `vertex_rows` is (3 n_local) x K row-major (mm per unit
    /// weight), `vertex_base` their mean positions (flat, 3 n_local, mm), and
    /// the terms' points index these local vertices.
    pub fn new(
        k: usize,
        vertex_rows: &[f64],
        vertex_base: &[f64],
        terms: Vec<SegmentTerm>,
    ) -> Self {
        let (rows, base) = segment_rows(k, vertex_rows, vertex_base, &terms);
        Self {
            k,
            rows,
            base,
            terms,
            prior: 0.0,
            held: Vec::new(),
        }
    }

    /// Adds the Gaussian prior of the normalised weights, `prior |w|^2`, to
    /// the objective (a MAP estimate when the measurement energy is a
    /// log-likelihood, see [`crate::predict::Step1Solver`]).
    pub fn with_prior(mut self, prior: f64) -> Self {
        self.prior = prior;
        self
    }

    /// Holds the weights with `held[i] = true` at their start values (their
    /// gradient is reported as zero, so L-BFGS, whose steps are combinations
    /// of gradients, never moves them). `held` has K entries.
    pub fn with_held(mut self, held: Vec<bool>) -> Self {
        debug_assert_eq!(held.len(), self.k);
        self.held = held;
        self
    }
}

/// Each term's segment vector `d_e(w) = C_e w + c_e` as an affine function of
/// the K weights: returns the rows of `C_e` (3 per term, K entries each,
/// row-major) and `c_e` (3 per term), from the scaled basis rows
/// `vertex_rows` ((3 n_local) x K) and mean positions `vertex_base` (flat,
/// 3 n_local) of the local vertices the terms' points index.
pub(crate) fn segment_rows(
    k: usize,
    vertex_rows: &[f64],
    vertex_base: &[f64],
    terms: &[SegmentTerm],
) -> (Vec<f64>, Vec<f64>) {
    let mut rows = vec![0.0; terms.len() * 3 * k];
    let mut base = vec![0.0; terms.len() * 3];
    for (e, t) in terms.iter().enumerate() {
        let parts = [
            (t.p1.a, 1.0 - t.p1.t),
            (t.p1.b, t.p1.t),
            (t.p0.a, -(1.0 - t.p0.t)),
            (t.p0.b, -t.p0.t),
        ];
        for (v, coef) in parts {
            if coef == 0.0 {
                continue;
            }
            let v = v as usize;
            for c in 0..3 {
                base[3 * e + c] += coef * vertex_base[3 * v + c];
                let src = &vertex_rows[(3 * v + c) * k..(3 * v + c + 1) * k];
                axpy(coef, src, &mut rows[(3 * e + c) * k..(3 * e + c + 1) * k]);
            }
        }
    }
    (rows, base)
}

impl Objective for WeightObjective {
    fn eval(&self, w: &[f64], grad: &mut [f64]) -> f64 {
        let k = self.k;
        grad.iter_mut().for_each(|g| *g = 0.0);
        let mut e = 0.0;
        for (i, t) in self.terms.iter().enumerate() {
            let r3 = &self.rows[3 * i * k..3 * (i + 1) * k];
            let d = [
                self.base[3 * i] + dot(&r3[..k], w),
                self.base[3 * i + 1] + dot(&r3[k..2 * k], w),
                self.base[3 * i + 2] + dot(&r3[2 * k..], w),
            ];
            let (len2, half) = match t.axis {
                Some(n) => {
                    let nd = n[0] * d[0] + n[1] * d[1] + n[2] * d[2];
                    (nd * nd, [nd * n[0], nd * n[1], nd * n[2]])
                }
                None => (d[0] * d[0] + d[1] * d[1] + d[2] * d[2], d),
            };
            let r = len2 - t.target_sq;
            e += t.weight * r * r;
            let s = 4.0 * t.weight * r;
            for c in 0..3 {
                let gc = s * half[c];
                if gc != 0.0 {
                    axpy(gc, &r3[c * k..(c + 1) * k], grad);
                }
            }
        }
        if self.prior != 0.0 {
            e += self.prior * dot(w, w);
            axpy(2.0 * self.prior, w, grad);
        }
        for (g, &h) in grad.iter_mut().zip(&self.held) {
            if h {
                *g = 0.0;
            }
        }
        e
    }
}

/// Step 2: `(1 - lambda) E_m + lambda E_s` over all vertex positions (flat,
/// 3V, mm), `E_s` measured from the step-1 shape `reference` (flat, mm).
/// Evaluation allocates nothing: O(terms + edges).
pub struct VertexObjective<'a> {
    terms: Vec<SegmentTerm>,
    edges: &'a [[u32; 2]],
    reference: &'a [f64],
    lambda: f64,
    /// Weight of the bending term inside the smoothness energy (0: none).
    bending: f64,
    disp: RefCell<Vec<f64>>,
    /// The bending term's Laplacian buffer.
    scratch: RefCell<Vec<f64>>,
}

impl<'a> VertexObjective<'a> {
    /// The objective for measurement `terms` over mesh vertex indices, the
    /// template's undirected `edges`, the step-1 shape `reference` (flat, 3V,
    /// mm) and the smoothness weight `lambda` in [0, 1].
    pub fn new(
        terms: Vec<SegmentTerm>,
        edges: &'a [[u32; 2]],
        reference: &'a [f64],
        lambda: f64,
    ) -> Self {
        Self {
            terms,
            edges,
            reference,
            lambda,
            bending: 0.0,
            disp: RefCell::new(vec![0.0; reference.len()]),
            scratch: RefCell::new(Vec::new()),
        }
    }

    /// Adds the bending term: the smoothness energy becomes
    /// `E_s + bending E_b` ([`crate::energy::bending_of_displacement`]).
    pub fn with_bending(mut self, bending: f64) -> Self {
        self.bending = bending;
        self
    }

    /// The measurement terms, the mesh edges, `lambda` and the bending
    /// weight (what [`crate::gauss_newton`] builds its system from).
    pub(crate) fn parts(&self) -> (&[SegmentTerm], &'a [[u32; 2]], f64, f64) {
        (&self.terms, self.edges, self.lambda, self.bending)
    }
}

impl Objective for VertexObjective<'_> {
    fn eval(&self, x: &[f64], grad: &mut [f64]) -> f64 {
        grad.iter_mut().for_each(|g| *g = 0.0);
        let em = measurement_energy(&self.terms, x, Some(&mut *grad));
        grad.iter_mut().for_each(|g| *g *= 1.0 - self.lambda);
        let mut disp = self.disp.borrow_mut();
        for ((d, xi), ri) in disp.iter_mut().zip(x).zip(self.reference) {
            *d = xi - ri;
        }
        let mut es = smoothness_of_displacement(self.edges, &disp, Some((&mut *grad, self.lambda)));
        if self.bending > 0.0 {
            es += self.bending
                * bending_of_displacement(
                    self.edges,
                    &disp,
                    &mut self.scratch.borrow_mut(),
                    Some((grad, self.lambda * self.bending)),
                );
        }
        (1.0 - self.lambda) * em + self.lambda * es
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::energy::tests::lcg;
    use tapeshape_measure::SupportPoint;
    use tapeshape_mesh::Vec3;

    /// The step-1 gradient (chain rule through the basis) against finite differences.
    #[test]
    fn weight_objective_gradient() {
        let mut s = 17;
        let (nl, k) = (4, 3);
        let rows: Vec<f64> = (0..3 * nl * k).map(|_| 10.0 * lcg(&mut s)).collect();
        let base: Vec<f64> = (0..3 * nl).map(|_| 100.0 * lcg(&mut s)).collect();
        let terms = vec![
            SegmentTerm {
                p0: SupportPoint::vertex(0),
                p1: SupportPoint { a: 1, b: 2, t: 0.3 },
                axis: None,
                target_sq: 900.0,
                weight: 1.0,
            },
            SegmentTerm {
                p0: SupportPoint::vertex(3),
                p1: SupportPoint::vertex(1),
                axis: Some([0.0, 0.0, 1.0]),
                target_sq: 400.0,
                weight: 0.5,
            },
        ];
        let obj = WeightObjective {
            k,
            rows,
            base,
            terms,
            prior: 0.3,
            held: Vec::new(),
        };
        let w = vec![0.3, -0.7, 1.1];
        let mut g = vec![0.0; k];
        obj.eval(&w, &mut g);
        let mut scratch = vec![0.0; k];
        for j in 0..k {
            let h = 1e-6;
            let mut wp = w.clone();
            wp[j] += h;
            let fp = obj.eval(&wp, &mut scratch);
            wp[j] -= 2.0 * h;
            let fm = obj.eval(&wp, &mut scratch);
            let fd = (fp - fm) / (2.0 * h);
            assert!(
                (fd - g[j]).abs() < 1e-6 * g[j].abs().max(1.0),
                "{j}: {fd} vs {}",
                g[j]
            );
        }
    }

    /// Held weights get a zero gradient and L-BFGS leaves them where they were.
    #[test]
    fn held_weights_do_not_move() {
        let (nl, k) = (2, 3);
        let mut s = 5;
        let rows: Vec<f64> = (0..3 * nl * k).map(|_| 10.0 * lcg(&mut s)).collect();
        let base: Vec<f64> = (0..3 * nl).map(|_| 100.0 * lcg(&mut s)).collect();
        let terms = vec![SegmentTerm {
            p0: SupportPoint::vertex(0),
            p1: SupportPoint::vertex(1),
            axis: None,
            target_sq: 2500.0,
            weight: 1.0,
        }];
        let obj = WeightObjective::new(k, &rows, &base, terms).with_held(vec![false, true, false]);
        let w0 = vec![0.5, 1.5, -0.5];
        let mut g = vec![0.0; k];
        let f0 = obj.eval(&w0, &mut g);
        assert_eq!(g[1], 0.0);
        for line_search in [LineSearch::Backtracking, LineSearch::StrongWolfe] {
            let solver = Lbfgs {
                stop: StopRule::default(),
                line_search,
            };
            let (w, info) = minimise(&obj, w0.clone(), &solver).unwrap();
            assert_eq!(w[1], 1.5, "{line_search:?}");
            assert!(info.cost_end < f0, "{line_search:?}: {info:?}");
        }
    }

    /// The step-2 objective (weighted sum) against finite differences.
    #[test]
    fn vertex_objective_gradient() {
        let mut s = 23;
        let p: Vec<Vec3> = (0..5)
            .map(|_| {
                [
                    100.0 * lcg(&mut s),
                    100.0 * lcg(&mut s),
                    100.0 * lcg(&mut s),
                ]
            })
            .collect();
        let reference: Vec<Vec3> = p
            .iter()
            .map(|v| [v[0] + lcg(&mut s), v[1], v[2] - 2.0])
            .collect();
        let edges = [[0, 1], [1, 2], [2, 3], [3, 4], [0, 4], [1, 3]];
        // Without and with the bending term.
        for bending in [0.0, 3.0] {
            let obj = VertexObjective::new(
                vec![SegmentTerm {
                    p0: SupportPoint { a: 0, b: 1, t: 0.5 },
                    p1: SupportPoint::vertex(3),
                    axis: None,
                    target_sq: 2500.0,
                    weight: 1.0,
                }],
                &edges,
                reference.as_flattened(),
                0.1,
            )
            .with_bending(bending);
            let x: Vec<f64> = p.as_flattened().to_vec();
            let mut g = vec![0.0; x.len()];
            obj.eval(&x, &mut g);
            let mut scratch = vec![0.0; x.len()];
            let scale = g.iter().fold(0.0f64, |m, v| m.max(v.abs()));
            for j in 0..x.len() {
                let h = 1e-5;
                let mut xp = x.clone();
                xp[j] += h;
                let fp = obj.eval(&xp, &mut scratch);
                xp[j] -= 2.0 * h;
                let fm = obj.eval(&xp, &mut scratch);
                let fd = (fp - fm) / (2.0 * h);
                assert!(
                    (fd - g[j]).abs() < 1e-6 * scale,
                    "bending {bending}, {j}: {fd} vs {}",
                    g[j]
                );
            }
        }
    }
}
