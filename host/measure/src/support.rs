//! The support of a measurement: points as convex combinations of at most two
//! vertices, and the segments whose lengths add up to the value.

use tapeshape_mesh::vec3::{dot, norm, sub};
use tapeshape_mesh::Vec3;

/// A point `q = (1 - t) * p[a] + t * p[b]` on the mesh. A vertex itself is
/// `a == b`, `t == 0`. `t` lies in `[0, 1]`.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct SupportPoint {
    /// First vertex index.
    pub a: u32,
    /// Second vertex index.
    pub b: u32,
    /// Weight of `b` (0 = exactly at `a`).
    pub t: f64,
}

impl SupportPoint {
    /// The point at vertex `v`.
    pub fn vertex(v: u32) -> Self {
        Self { a: v, b: v, t: 0.0 }
    }

    /// Position of the point for vertex positions `p` (metres).
    pub fn position(&self, p: &[Vec3]) -> Vec3 {
        let (pa, pb) = (p[self.a as usize], p[self.b as usize]);
        let s = 1.0 - self.t;
        [
            s * pa[0] + self.t * pb[0],
            s * pa[1] + self.t * pb[1],
            s * pa[2] + self.t * pb[2],
        ]
    }
}

/// The points a measurement used and the segments between them.
///
/// Without an axis, a segment's length is the Euclidean distance of its end
/// points. With `axis = Some(n)` (a unit vector, station frame), every segment's
/// length is `|n . (q1 - q0)|`: heights from the floor (n = +Z) and caliper
/// breadths/depths are projected lengths. An optimiser differentiates
/// `(n . d)^2` instead of `d . d` for such supports.
#[derive(Debug, Clone, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Support {
    /// Points on the mesh.
    pub points: Vec<SupportPoint>,
    /// Segments as pairs of indices into `points`; the value is the sum of their lengths.
    pub segments: Vec<[u32; 2]>,
    /// Optional unit projection axis (see the type docs).
    pub axis: Option<Vec3>,
}

impl Support {
    /// Sum of the segment lengths for vertex positions `p` (metres).
    pub fn length(&self, p: &[Vec3]) -> f64 {
        self.segments
            .iter()
            .map(|s| {
                let q0 = self.points[s[0] as usize].position(p);
                let q1 = self.points[s[1] as usize].position(p);
                let d = sub(q1, q0);
                match self.axis {
                    Some(n) => dot(n, d).abs(),
                    None => norm(d),
                }
            })
            .sum()
    }

    /// The segments as they are measured, end points in metres (station
    /// frame), for drawing a measurement where the engine takes it.
    ///
    /// Without an axis these are the support's segments themselves. With
    /// an axis `n`, a segment `q0 -> q1` is measured as its projection on
    /// `n`, so it is returned as the line `q1 - n (n . (q1 - q0)) -> q1`
    /// along `n`, ending at `q1`: a height is the vertical line from the
    /// floor's level up to the landmark, a caliper depth the line along its
    /// axis to the far extreme point. The lengths of the returned segments
    /// add up to [`Support::length`] (to rounding; `n` is a unit vector).
    pub fn measured_segments(&self, p: &[Vec3]) -> Vec<[Vec3; 2]> {
        self.segments
            .iter()
            .map(|s| {
                let q0 = self.points[s[0] as usize].position(p);
                let q1 = self.points[s[1] as usize].position(p);
                match self.axis {
                    Some(n) => {
                        let along = dot(n, sub(q1, q0));
                        let start = [
                            q1[0] - along * n[0],
                            q1[1] - along * n[1],
                            q1[2] - along * n[2],
                        ];
                        [start, q1]
                    }
                    None => [q0, q1],
                }
            })
            .collect()
    }

    /// Adds `scale * d length / d p` to `grad` (one entry per vertex, same
    /// length as `p`), with the support held fixed: the points' vertex pairs
    /// and weights `t` do not move, as in the paper's energies. For a
    /// Euclidean segment the derivative with respect to its end `q1` is the
    /// unit vector `(q1 - q0) / |q1 - q0|`; with an axis it is
    /// `sign(n . (q1 - q0)) n`. A point `(a, b, t)` passes `(1 - t)` of its
    /// derivative to vertex `a` and `t` to vertex `b`. Zero-length segments
    /// contribute nothing (the length is not differentiable there).
    pub fn add_gradient(&self, p: &[Vec3], scale: f64, grad: &mut [Vec3]) {
        for s in &self.segments {
            let (s0, s1) = (self.points[s[0] as usize], self.points[s[1] as usize]);
            let (q0, q1) = (s0.position(p), s1.position(p));
            let d = sub(q1, q0);
            let g = match self.axis {
                Some(n) => {
                    let proj = dot(n, d);
                    if proj == 0.0 {
                        continue;
                    }
                    let sgn = proj.signum();
                    [sgn * n[0], sgn * n[1], sgn * n[2]]
                }
                None => {
                    let l = norm(d);
                    if l == 0.0 {
                        continue;
                    }
                    [d[0] / l, d[1] / l, d[2] / l]
                }
            };
            for (pt, sign) in [(s1, scale), (s0, -scale)] {
                for (v, w) in [(pt.a, 1.0 - pt.t), (pt.b, pt.t)] {
                    let gv = &mut grad[v as usize];
                    for k in 0..3 {
                        gv[k] += sign * w * g[k];
                    }
                }
            }
        }
    }

    /// `d length / d p` for positions `p` (see [`Support::add_gradient`]):
    /// one 3-vector per vertex, dimensionless (metres per metre).
    pub fn gradient(&self, p: &[Vec3]) -> Vec<Vec3> {
        let mut g = vec![[0.0; 3]; p.len()];
        self.add_gradient(p, 1.0, &mut g);
        g
    }
}

/// One measurement's value (metres) and its support.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Measured {
    /// The measured value, metres. Equals `support.length(vertices)`.
    pub value: f64,
    /// Points and segments used.
    pub support: Support,
}
