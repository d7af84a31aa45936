//! The support of a measurement: points as convex combinations of at most two
//! vertices, and the segments whose lengths add up to the value.

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
                let d = [q1[0] - q0[0], q1[1] - q0[1], q1[2] - q0[2]];
                match self.axis {
                    Some(n) => (n[0] * d[0] + n[1] * d[1] + n[2] * d[2]).abs(),
                    None => (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt(),
                }
            })
            .sum()
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
