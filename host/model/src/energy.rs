//! The paper's energies and their analytic gradients.
//!
//! `E_e`, `E_g` and `E_c` share one form over the segments of a measurement's
//! support ([`tapeshape_measure::Support`]): for a segment between points
//! `q0 = (1 - t0) p_a0 + t0 p_b0` and `q1 = (1 - t1) p_a1 + t1 p_b1`, with
//! `d = q1 - q0`,
//!
//! `e = c (|d|^2 - l_t^2)^2` (or `c ((n . d)^2 - l_t^2)^2` for a support with
//! projection axis `n`),
//!
//! where `l_t` is the segment's target length (the whole target for a one-segment
//! Euclidean measurement; `l_t(P) l_g(e) / l_g(P)` for an edge of a geodesic path
//! or a circumference hull, held fixed during one L-BFGS run) and `c` the
//! measurement's weight. The gradient is `de/dd = 4 c r d` (`4 c r (n . d) n`
//! with an axis), `r = |d|^2 - l_t^2`, pushed to the four vertices with the
//! weights `-(1 - t0), -t0, (1 - t1), t1` (t held fixed in a run, as the paper's
//! circumference derivation says).
//!
//! `E_s = sum_i sum_{j in N(i)} |D_i - D_j|^2` with `D = X - X_ref` counts every
//! undirected edge twice, so `E_s = 2 sum_edges |D_a - D_b|^2` and its gradient
//! is `4 sum_{j in N(i)} (D_i - D_j)`.
//!
//! All functions here work on whatever length unit their inputs use; the
//! refinement calls them in millimetres.

use tapeshape_measure::{Support, SupportPoint};
use tapeshape_mesh::vec3::{dot, sub};
use tapeshape_mesh::Vec3;

/// One segment term of `E_m` (see the module docs).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SegmentTerm {
    /// Start point of the segment.
    pub p0: SupportPoint,
    /// End point of the segment.
    pub p1: SupportPoint,
    /// Projection axis (unit), or `None` for the Euclidean length.
    pub axis: Option<Vec3>,
    /// Target length squared, `l_t^2`.
    pub target_sq: f64,
    /// Weight `c` of the term.
    pub weight: f64,
}

/// Builds the segment terms of one measurement: each segment `e` gets the
/// target `l_t(e) = target * l_g(e) / l_g` where `l_g` is the support's
/// current length (the paper's rule for geodesic and circumference edges; a
/// one-segment Euclidean measurement gets `target` itself).
///
/// `p` are the positions the support was measured on (same unit as
/// `target`). Returns `None` if the support has no length (`l_g = 0`), for
/// which no per-segment target exists.
pub fn segment_terms(
    support: &Support,
    p: &[Vec3],
    target: f64,
    weight: f64,
) -> Option<Vec<SegmentTerm>> {
    let lens: Vec<f64> = support
        .segments
        .iter()
        .map(|s| {
            let d = sub(
                support.points[s[1] as usize].position(p),
                support.points[s[0] as usize].position(p),
            );
            seg_len(d, support.axis)
        })
        .collect();
    let total: f64 = lens.iter().sum();
    if total <= 0.0 || !total.is_finite() {
        return None;
    }
    Some(
        support
            .segments
            .iter()
            .zip(&lens)
            .map(|(s, &l)| {
                let lt = target * l / total;
                SegmentTerm {
                    p0: support.points[s[0] as usize],
                    p1: support.points[s[1] as usize],
                    axis: support.axis,
                    target_sq: lt * lt,
                    weight,
                }
            })
            .collect(),
    )
}

fn seg_len(d: Vec3, axis: Option<Vec3>) -> f64 {
    match axis {
        Some(n) => dot(n, d).abs(),
        None => dot(d, d).sqrt(),
    }
}

/// Position of a support point in flat positions `p` (`[x0, y0, z0, x1, ...]`).
#[inline]
fn point(p: &[f64], q: &SupportPoint) -> Vec3 {
    let (a, b) = (3 * q.a as usize, 3 * q.b as usize);
    let s = 1.0 - q.t;
    [
        s * p[a] + q.t * p[b],
        s * p[a + 1] + q.t * p[b + 1],
        s * p[a + 2] + q.t * p[b + 2],
    ]
}

#[inline]
fn add_scaled(grad: &mut [f64], v: u32, s: f64, g: Vec3) {
    let i = 3 * v as usize;
    grad[i] += s * g[0];
    grad[i + 1] += s * g[1];
    grad[i + 2] += s * g[2];
}

/// `E_m = sum of the terms' energies` at flat positions `p`
/// (`[x0, y0, z0, x1, ...]`, length 3V); if `grad` is given (same length),
/// adds `dE_m/dp` to it.
pub fn measurement_energy(terms: &[SegmentTerm], p: &[f64], mut grad: Option<&mut [f64]>) -> f64 {
    let mut e = 0.0;
    for term in terms {
        let d = sub(point(p, &term.p1), point(p, &term.p0));
        let (len2, dlen2_half) = match term.axis {
            Some(n) => {
                let nd = dot(n, d);
                (nd * nd, [nd * n[0], nd * n[1], nd * n[2]])
            }
            None => (dot(d, d), d),
        };
        let r = len2 - term.target_sq;
        e += term.weight * r * r;
        if let Some(g) = grad.as_deref_mut() {
            // de/dd = 2 c r * d(len2)/dd = 4 c r * dlen2_half.
            let s = 4.0 * term.weight * r;
            let gd = [s * dlen2_half[0], s * dlen2_half[1], s * dlen2_half[2]];
            add_scaled(g, term.p1.a, 1.0 - term.p1.t, gd);
            add_scaled(g, term.p1.b, term.p1.t, gd);
            add_scaled(g, term.p0.a, -(1.0 - term.p0.t), gd);
            add_scaled(g, term.p0.b, -term.p0.t, gd);
        }
    }
    e
}

/// `E_s = sum_i sum_{j in N(i)} |D_i - D_j|^2`, `D = p - p_ref` (flat, 3V), over the
/// undirected `edges` (each counted twice, as in the paper's double sum); if
/// `grad` is given, adds `scale * dE_s/dp` to it and returns `E_s` unscaled.
pub fn smoothness_energy(
    edges: &[[u32; 2]],
    p: &[f64],
    p_ref: &[f64],
    grad: Option<(&mut [f64], f64)>,
) -> f64 {
    let disp: Vec<f64> = p.iter().zip(p_ref).map(|(a, b)| a - b).collect();
    smoothness_of_displacement(edges, &disp, grad)
}

/// [`smoothness_energy`] from the displacement `D = p - p_ref` (flat, 3V),
/// for callers that keep `D` in a buffer (one gather per edge end instead of two).
pub fn smoothness_of_displacement(
    edges: &[[u32; 2]],
    disp: &[f64],
    mut grad: Option<(&mut [f64], f64)>,
) -> f64 {
    let mut e = 0.0;
    for &[a, b] in edges {
        let (a, b) = (3 * a as usize, 3 * b as usize);
        let dd = [
            disp[a] - disp[b],
            disp[a + 1] - disp[b + 1],
            disp[a + 2] - disp[b + 2],
        ];
        e += 2.0 * dot(dd, dd);
        if let Some((g, scale)) = grad.as_mut() {
            let s = 4.0 * *scale;
            for c in 0..3 {
                g[a + c] += s * dd[c];
                g[b + c] -= s * dd[c];
            }
        }
    }
    e
}

/// The bending of a displacement: `E_b = sum_i |sum_{j in N(i)} (D_i - D_j)|^2`,
/// the squared umbrella Laplacian of `D` (flat, 3V, mm) over the undirected
/// `edges`, mm^2. Where [`smoothness_of_displacement`] (the paper's `E_s`)
/// charges the displacement's slope across each edge, this charges its
/// curvature at each vertex: zero for a displacement that is constant (or
/// varies linearly across a regular patch), large for one that kinks along
/// a line, which is a crease in the surface. If `grad` is given, adds
/// `scale * dE_b/dD` (`2 scale L^T L D`) to it. `scratch` holds the
/// Laplacian (resized to 3V), so evaluations allocate nothing.
pub fn bending_of_displacement(
    edges: &[[u32; 2]],
    disp: &[f64],
    scratch: &mut Vec<f64>,
    grad: Option<(&mut [f64], f64)>,
) -> f64 {
    scratch.clear();
    scratch.resize(disp.len(), 0.0);
    let u = scratch;
    for &[a, b] in edges {
        let (a, b) = (3 * a as usize, 3 * b as usize);
        for c in 0..3 {
            let d = disp[a + c] - disp[b + c];
            u[a + c] += d;
            u[b + c] -= d;
        }
    }
    let e = u.iter().map(|x| x * x).sum();
    if let Some((g, scale)) = grad {
        let s = 2.0 * scale;
        for &[a, b] in edges {
            let (a, b) = (3 * a as usize, 3 * b as usize);
            for c in 0..3 {
                let d = s * (u[a + c] - u[b + c]);
                g[a + c] += d;
                g[b + c] -= d;
            }
        }
    }
    e
}

#[cfg(test)]
#[allow(clippy::needless_range_loop)] // index loops compare arrays entry by entry
pub(crate) mod tests {
    use super::*;

    pub(crate) fn lcg(seed: &mut u64) -> f64 {
        *seed = seed
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((*seed >> 11) as f64) / ((1u64 << 53) as f64) - 0.5
    }

    fn points(n: usize, seed: u64) -> Vec<Vec3> {
        let mut s = seed;
        (0..n)
            .map(|_| {
                [
                    lcg(&mut s) * 100.0,
                    lcg(&mut s) * 100.0,
                    lcg(&mut s) * 100.0,
                ]
            })
            .collect()
    }

    /// Central finite differences of `f` against the analytic gradient `g`.
    pub(crate) fn check_gradient(
        f: &dyn Fn(&[Vec3]) -> f64,
        g: &dyn Fn(&[Vec3]) -> Vec<Vec3>,
        p: &[Vec3],
    ) {
        let analytic = g(p);
        let mut q = p.to_vec();
        let mut worst = 0.0f64;
        let scale = analytic
            .iter()
            .flat_map(|v| v.iter())
            .fold(0.0f64, |m, x| m.max(x.abs()))
            .max(1e-12);
        for v in 0..p.len() {
            for c in 0..3 {
                let h = 1e-5 * (1.0 + p[v][c].abs());
                q[v][c] = p[v][c] + h;
                let fp = f(&q);
                q[v][c] = p[v][c] - h;
                let fm = f(&q);
                q[v][c] = p[v][c];
                let fd = (fp - fm) / (2.0 * h);
                worst = worst.max((fd - analytic[v][c]).abs() / scale);
            }
        }
        assert!(worst < 1e-6, "relative gradient error {worst}");
    }

    fn check_terms(terms: &[SegmentTerm], p: &[Vec3]) {
        check_gradient(
            &|x| measurement_energy(terms, x.as_flattened(), None),
            &|x| {
                let mut g = vec![[0.0; 3]; x.len()];
                measurement_energy(terms, x.as_flattened(), Some(g.as_flattened_mut()));
                g
            },
            p,
        );
    }

    #[test]
    fn euclidean_term_value_and_gradient() {
        let p = points(2, 1);
        let support = Support {
            points: vec![SupportPoint::vertex(0), SupportPoint::vertex(1)],
            segments: vec![[0, 1]],
            axis: None,
        };
        let terms = segment_terms(&support, &p, 50.0, 2.0).unwrap();
        assert_eq!(terms.len(), 1);
        let l2 = dot(sub(p[1], p[0]), sub(p[1], p[0]));
        let want = 2.0 * (l2 - 2500.0).powi(2);
        assert!((measurement_energy(&terms, p.as_flattened(), None) - want).abs() < 1e-9 * want);
        check_terms(&terms, &p);
    }

    #[test]
    fn geodesic_terms_keep_relative_edge_lengths_and_have_exact_gradients() {
        let p = points(5, 2);
        let support = Support {
            points: (0..5).map(SupportPoint::vertex).collect(),
            segments: vec![[0, 1], [1, 2], [2, 3], [3, 4]],
            axis: None,
        };
        let lg = support.length(&p);
        let terms = segment_terms(&support, &p, 1.3 * lg, 1.0).unwrap();
        let sum: f64 = terms.iter().map(|t| t.target_sq.sqrt()).sum();
        assert!((sum - 1.3 * lg).abs() < 1e-9);
        // Scaling every point by 1.3 about the origin fits all targets: E = 0.
        let scaled: Vec<Vec3> = p
            .iter()
            .map(|v| [1.3 * v[0], 1.3 * v[1], 1.3 * v[2]])
            .collect();
        assert!(measurement_energy(&terms, scaled.as_flattened(), None) < 1e-6);
        check_terms(&terms, &p);
    }

    #[test]
    fn circumference_terms_with_interpolated_points() {
        let p = points(8, 3);
        let support = Support {
            points: vec![
                SupportPoint {
                    a: 0,
                    b: 1,
                    t: 0.25,
                },
                SupportPoint { a: 2, b: 3, t: 0.6 },
                SupportPoint::vertex(4),
                SupportPoint { a: 5, b: 6, t: 0.9 },
                SupportPoint { a: 7, b: 0, t: 0.5 },
            ],
            segments: vec![[0, 1], [1, 2], [2, 3], [3, 4], [4, 0]],
            axis: None,
        };
        let terms = segment_terms(&support, &p, 0.9 * support.length(&p), 0.5).unwrap();
        check_terms(&terms, &p);
    }

    #[test]
    fn axis_projected_terms() {
        let p = points(4, 4);
        let n = [0.0, 0.6, 0.8];
        let support = Support {
            points: vec![SupportPoint::vertex(0), SupportPoint { a: 1, b: 2, t: 0.3 }],
            segments: vec![[0, 1]],
            axis: Some(n),
        };
        let terms = segment_terms(&support, &p, 10.0, 1.0).unwrap();
        let d = sub(support.points[1].position(&p), p[0]);
        let want = (dot(n, d).powi(2) - 100.0).powi(2);
        assert!(
            (measurement_energy(&terms, p.as_flattened(), None) - want).abs()
                < 1e-9 * want.max(1.0)
        );
        check_terms(&terms, &p);
    }

    #[test]
    fn zero_length_support_has_no_terms() {
        let p = vec![[1.0, 2.0, 3.0]; 2];
        let support = Support {
            points: vec![SupportPoint::vertex(0), SupportPoint::vertex(1)],
            segments: vec![[0, 1]],
            axis: None,
        };
        assert!(segment_terms(&support, &p, 1.0, 1.0).is_none());
    }

    #[test]
    fn smoothness_value_and_gradient() {
        let p_ref = points(5, 5);
        let p = points(5, 6);
        let edges = [[0, 1], [1, 2], [0, 2], [2, 3], [3, 4], [1, 4]];
        // Direct double sum over one-rings.
        let mut ring: Vec<Vec<usize>> = vec![vec![]; 5];
        for &[a, b] in &edges {
            ring[a as usize].push(b as usize);
            ring[b as usize].push(a as usize);
        }
        let dv = |i: usize| sub(p[i], p_ref[i]);
        let mut want = 0.0;
        for i in 0..5 {
            for &j in &ring[i] {
                let d = sub(dv(i), dv(j));
                want += dot(d, d);
            }
        }
        let got = smoothness_energy(&edges, p.as_flattened(), p_ref.as_flattened(), None);
        assert!((got - want).abs() < 1e-9 * want);
        // A rigid translation of the reference costs nothing.
        let moved: Vec<Vec3> = p_ref
            .iter()
            .map(|v| [v[0] + 3.0, v[1] - 1.0, v[2]])
            .collect();
        assert!(
            smoothness_energy(&edges, moved.as_flattened(), p_ref.as_flattened(), None) < 1e-18
        );
        check_gradient(
            &|x| smoothness_energy(&edges, x.as_flattened(), p_ref.as_flattened(), None),
            &|x| {
                let mut g = vec![[0.0; 3]; x.len()];
                smoothness_energy(
                    &edges,
                    x.as_flattened(),
                    p_ref.as_flattened(),
                    Some((g.as_flattened_mut(), 1.0)),
                );
                g
            },
            &p,
        );
    }

    #[test]
    fn bending_value_and_gradient() {
        let p = points(5, 7);
        let edges = [[0, 1], [1, 2], [0, 2], [2, 3], [3, 4], [1, 4]];
        // Direct: the umbrella vector of each vertex, squared.
        let mut ring: Vec<Vec<usize>> = vec![vec![]; 5];
        for &[a, b] in &edges {
            ring[a as usize].push(b as usize);
            ring[b as usize].push(a as usize);
        }
        let mut want = 0.0;
        for i in 0..5 {
            let mut u = [0.0; 3];
            for &j in &ring[i] {
                let d = sub(p[i], p[j]);
                u = [u[0] + d[0], u[1] + d[1], u[2] + d[2]];
            }
            want += dot(u, u);
        }
        let mut scratch = Vec::new();
        let got = bending_of_displacement(&edges, p.as_flattened(), &mut scratch, None);
        assert!((got - want).abs() < 1e-9 * want, "{got} vs {want}");
        // A constant displacement does not bend.
        let constant = [[2.0, -1.0, 0.5]; 5];
        assert!(
            bending_of_displacement(&edges, constant.as_flattened(), &mut scratch, None) < 1e-24
        );
        check_gradient(
            &|x| bending_of_displacement(&edges, x.as_flattened(), &mut Vec::new(), None),
            &|x| {
                let mut g = vec![[0.0; 3]; x.len()];
                bending_of_displacement(
                    &edges,
                    x.as_flattened(),
                    &mut Vec::new(),
                    Some((g.as_flattened_mut(), 1.0)),
                );
                g
            },
            &p,
        );
    }
}
