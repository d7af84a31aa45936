//! Plane cuts of body parts, cut curves and their convex hulls.
//!
//! The paper's circumference: intersect (part of) the mesh with the plane
//! through an anchor vertex with a given normal, take the polygonal chain of
//! the intersection nearest the anchor, and measure the perimeter of its
//! convex hull (a tape bridges concavities).
//!
//! Robustness. Vertices are classified by their signed distance
//! `d = n . (p - anchor)` with `d >= 0` counted as positive (a symbolic
//! perturbation of the plane towards `-n`). Then no vertex lies "on" the
//! plane, every triangle with vertices on both sides has exactly two crossing
//! edges, every crossing is a proper interpolant `(1 - t) p_a + t p_b` with
//! `t` in `[0, 1]`, and the crossings chain through shared edges into closed
//! loops (or open chains ending on the part's boundary) with no special cases.
//! The anchor itself has `d = 0` exactly, so the chosen curve passes through
//! it or next to it; the curve nearest the anchor point is taken.
//!
//! The 2D convex hull is Andrew's monotone chain, written by hand: it is
//! thirty lines, and the support (which edge, which `t`) must be carried
//! through the hull, which general-purpose geometry crates do not do.

use tapeshape_mesh::vec3::{cross, dot, sub};
use tapeshape_mesh::{Topology, Vec3};

/// How far (metres) from the anchor a cut curve may pass and still count as
/// "through the anchor": about one ring of template edges (10-20 mm on the
/// trunk). Within this reach the longest curve is taken.
pub(crate) const ANCHOR_REACH: f64 = 0.025;

/// Per-topology data for cutting one set of parts: built once, used for
/// every body.
#[derive(Debug, Clone)]
pub(crate) struct PartCut {
    /// Global vertex index of each local vertex.
    vertices: Vec<u32>,
    /// Edges as pairs of local vertex indices.
    edges: Vec<[u32; 2]>,
    /// The three local edges of each triangle of the parts.
    tri_edges: Vec<[u32; 3]>,
}

/// A point of a cut curve on mesh edge `(a, b)` (global indices): `(1 - t) p_a + t p_b`.
#[derive(Debug, Clone, Copy)]
pub(crate) struct CutPoint {
    pub a: u32,
    pub b: u32,
    pub t: f64,
    pub pos: Vec3,
}

/// Why a cut failed.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) enum CutError {
    /// The plane does not cut the parts.
    Misses,
    /// This vertex has a non-finite coordinate.
    NonFinite(u32),
}

/// Squared distance from `p` to segment `[a, b]`.
fn dist2_point_segment(p: Vec3, a: Vec3, b: Vec3) -> f64 {
    let ab = sub(b, a);
    let ap = sub(p, a);
    let l2 = dot(ab, ab);
    let s = if l2 > 0.0 {
        (dot(ap, ab) / l2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    let q = [a[0] + s * ab[0], a[1] + s * ab[1], a[2] + s * ab[2]];
    let d = sub(p, q);
    dot(d, d)
}

impl PartCut {
    /// Cut data for the union of the triangles `tris` (indices into `topology.faces()`,
    /// all in range; duplicates are ignored).
    pub(crate) fn new(topology: &Topology, tris: &[u32]) -> Self {
        let mut tris: Vec<u32> = tris.to_vec();
        tris.sort_unstable();
        tris.dedup();
        let faces = topology.faces();
        let mut local_of = std::collections::HashMap::new();
        let mut vertices = Vec::new();
        let mut edge_local = std::collections::HashMap::new();
        let mut edges: Vec<[u32; 2]> = Vec::new();
        let mut tri_edges = Vec::with_capacity(tris.len());
        for &f in &tris {
            let face = faces[f as usize];
            let mut te = [0u32; 3];
            for k in 0..3 {
                let (a, b) = (face[k], face[(k + 1) % 3]);
                let key = (a.min(b), a.max(b));
                let le = *edge_local.entry(key).or_insert_with(|| {
                    let mut loc = |v: u32| {
                        *local_of.entry(v).or_insert_with(|| {
                            vertices.push(v);
                            (vertices.len() - 1) as u32
                        })
                    };
                    let e = [loc(key.0), loc(key.1)];
                    edges.push(e);
                    (edges.len() - 1) as u32
                });
                te[k] = le;
            }
            tri_edges.push(te);
        }
        Self {
            vertices,
            edges,
            tri_edges,
        }
    }

    /// The points of the cut curve nearest to `p[anchor]`, in curve order,
    /// for the plane through `p[anchor]` with unit normal `n`.
    /// `p`: positions (metres) of every vertex of the topology.
    pub(crate) fn cut_curve(
        &self,
        p: &[Vec3],
        anchor: u32,
        n: Vec3,
    ) -> Result<Vec<CutPoint>, CutError> {
        let p0 = p[anchor as usize];
        if !p0.iter().all(|x| x.is_finite()) {
            return Err(CutError::NonFinite(anchor));
        }
        // Signed distances of the local vertices.
        let mut d = Vec::with_capacity(self.vertices.len());
        for &v in &self.vertices {
            let q = p[v as usize];
            let s = dot(n, sub(q, p0));
            if !s.is_finite() {
                return Err(CutError::NonFinite(v));
            }
            d.push(s);
        }
        let pos = |x: f64| x >= 0.0;
        // Crossing points per edge.
        let mut cross_of = vec![u32::MAX; self.edges.len()];
        let mut points: Vec<CutPoint> = Vec::new();
        let mut point_edge: Vec<u32> = Vec::new();
        for (e, &[la, lb]) in self.edges.iter().enumerate() {
            let (da, db) = (d[la as usize], d[lb as usize]);
            if pos(da) != pos(db) {
                let t = (da / (da - db)).clamp(0.0, 1.0);
                let (a, b) = (self.vertices[la as usize], self.vertices[lb as usize]);
                let (pa, pb) = (p[a as usize], p[b as usize]);
                let s = 1.0 - t;
                let q = [
                    s * pa[0] + t * pb[0],
                    s * pa[1] + t * pb[1],
                    s * pa[2] + t * pb[2],
                ];
                cross_of[e] = points.len() as u32;
                points.push(CutPoint { a, b, t, pos: q });
                point_edge.push(e as u32);
            }
        }
        if points.is_empty() {
            return Err(CutError::Misses);
        }
        // Link crossings through triangles: each crossed triangle has exactly two crossed edges.
        let mut link = vec![[u32::MAX; 2]; points.len()];
        let mut add = |i: u32, j: u32| {
            let l = &mut link[i as usize];
            if l[0] == u32::MAX {
                l[0] = j;
            } else {
                l[1] = j;
            }
        };
        for te in &self.tri_edges {
            // The triangle's crossed edges (no list per triangle: this loop
            // runs over every triangle of the part at every cut).
            let mut c = [u32::MAX; 3];
            let mut n = 0;
            for &e in te {
                let x = cross_of[e as usize];
                if x != u32::MAX {
                    c[n] = x;
                    n += 1;
                }
            }
            if n == 2 {
                add(c[0], c[1]);
                add(c[1], c[0]);
            }
        }
        // Walk components: open chains (a crossing with one link lies on the
        // parts' boundary) from their ends first, then closed loops.
        let mut seen = vec![false; points.len()];
        let mut found: Vec<(f64, f64, Vec<u32>)> = Vec::new();
        let mut consider = |chain: Vec<u32>, closed: bool| {
            let mut m = f64::INFINITY;
            let k = chain.len();
            let segs = if closed { k } else { k.saturating_sub(1) };
            if k == 1 {
                let q = points[chain[0] as usize].pos;
                m = dot(sub(q, p0), sub(q, p0));
            }
            let mut len = 0.0;
            for i in 0..segs {
                let (a, b) = (
                    points[chain[i] as usize].pos,
                    points[chain[(i + 1) % k] as usize].pos,
                );
                m = m.min(dist2_point_segment(p0, a, b));
                let d = sub(b, a);
                len += dot(d, d).sqrt();
            }
            found.push((m.sqrt(), len, chain));
        };
        let walk = |start: u32, seen: &mut Vec<bool>| -> Vec<u32> {
            let mut chain = vec![start];
            seen[start as usize] = true;
            let mut prev = u32::MAX;
            let mut cur = start;
            loop {
                let l = link[cur as usize];
                let next = if l[0] != u32::MAX && l[0] != prev && !seen[l[0] as usize] {
                    l[0]
                } else if l[1] != u32::MAX && l[1] != prev && !seen[l[1] as usize] {
                    l[1]
                } else {
                    break;
                };
                seen[next as usize] = true;
                chain.push(next);
                prev = cur;
                cur = next;
            }
            chain
        };
        for i in 0..points.len() {
            if !seen[i] && link[i][1] == u32::MAX {
                let chain = walk(i as u32, &mut seen);
                consider(chain, false);
            }
        }
        for i in 0..points.len() {
            if !seen[i] {
                let chain = walk(i as u32, &mut seen);
                consider(chain, true);
            }
        }
        // The curve through the anchor: the nearest one, except that a longer
        // curve passing within ANCHOR_REACH of the anchor wins over a short
        // fragment (an anchor on the parts' boundary touches slivers of the cut).
        let d_min = found.iter().map(|f| f.0).fold(f64::INFINITY, f64::min);
        let (_, _, chain) = found
            .into_iter()
            .filter(|f| f.0 <= d_min + ANCHOR_REACH)
            .max_by(|a, b| a.1.total_cmp(&b.1))
            .expect("at least one crossing");
        Ok(chain.into_iter().map(|i| points[i as usize]).collect())
    }
}

/// Indices into `pts` of the convex hull of the points projected onto the
/// plane with unit normal `n`, counter-clockwise about `n`, without collinear
/// points. One index for a single (or all-coincident) point set, two for a
/// collinear one.
pub(crate) fn convex_hull(pts: &[CutPoint], n: Vec3) -> Vec<usize> {
    // Orthonormal in-plane basis (u, v) with u x v = n.
    let helper = if n[0].abs() < 0.9 {
        [1.0, 0.0, 0.0]
    } else {
        [0.0, 1.0, 0.0]
    };
    let u = {
        let c = cross(helper, n);
        let l = dot(c, c).sqrt();
        [c[0] / l, c[1] / l, c[2] / l]
    };
    let v = cross(n, u);
    let xy: Vec<(f64, f64)> = pts.iter().map(|q| (dot(q.pos, u), dot(q.pos, v))).collect();
    let mut order: Vec<usize> = (0..pts.len()).collect();
    order.sort_by(|&i, &j| {
        xy[i]
            .0
            .total_cmp(&xy[j].0)
            .then(xy[i].1.total_cmp(&xy[j].1))
    });
    order.dedup_by(|i, j| xy[*i] == xy[*j]);
    if order.len() < 3 {
        return order;
    }
    let turn = |o: usize, a: usize, b: usize| {
        (xy[a].0 - xy[o].0) * (xy[b].1 - xy[o].1) - (xy[a].1 - xy[o].1) * (xy[b].0 - xy[o].0)
    };
    let mut hull: Vec<usize> = Vec::with_capacity(2 * order.len());
    for &i in &order {
        while hull.len() >= 2 && turn(hull[hull.len() - 2], hull[hull.len() - 1], i) <= 0.0 {
            hull.pop();
        }
        hull.push(i);
    }
    let lower = hull.len() + 1;
    for &i in order.iter().rev().skip(1) {
        while hull.len() >= lower && turn(hull[hull.len() - 2], hull[hull.len() - 1], i) <= 0.0 {
            hull.pop();
        }
        hull.push(i);
    }
    hull.pop(); // the first point again
    hull
}
