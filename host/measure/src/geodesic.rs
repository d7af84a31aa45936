//! Shortest paths on the mesh's edge graph (Dijkstra), as in the paper.
//!
//! The search is Dijkstra's, ordered by path length plus the straight-line
//! distance to the target (A*): every step is a surface path at least as
//! long as its chord, so that bound never over-estimates and is consistent,
//! and the search returns a shortest path, the same length Dijkstra finds,
//! while visiting far fewer vertices on long arcs.
//!
//! The graph (CSR adjacency) depends only on the topology and is built once
//! per compiled set; edge weights are the current edge lengths, computed on
//! the fly, so the same graph serves every body of the template.
//!
//! Dijkstra on the edge graph over-estimates the true surface geodesic
//! because the path must follow mesh edges; the bias on an icosphere is
//! measured in `tests/analytic.rs` and reported in `docs/measurements.md`.
//! A heap-based Dijkstra is a dozen lines over `std::collections::BinaryHeap`;
//! writing it here (rather than using a graph crate) lets it stop at the target,
//! read positions in place and report a NaN edge as an error naming the
//! measurement.

use std::cmp::Ordering;
use std::collections::BinaryHeap;

use tapeshape_mesh::vec3::{add, distance as dist, dot, scale, sub};
use tapeshape_mesh::{Topology, Vec3};

/// CSR adjacency of the edge graph, plus (for the `unfolded` method) each
/// vertex's "across" neighbours: the opposite vertex `w` of the triangle on
/// the other side of each edge `(a, b)` of the vertex's own triangles.
#[derive(Debug, Clone)]
pub(crate) struct EdgeGraph {
    offsets: Vec<u32>,
    neighbours: Vec<u32>,
    across_offsets: Vec<u32>,
    /// `[w, a, b]`: reach `w` by crossing edge `(a, b)`.
    across: Vec<[u32; 3]>,
}

/// How a geodesic is computed.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum GeodesicMethod {
    /// Dijkstra on the mesh's edges, as in the paper (default).
    #[default]
    Edges,
    /// Dijkstra on the edges plus straight paths across each pair of
    /// triangles sharing an edge (the two triangles unfolded into the plane):
    /// a surface path through edge points, with a much smaller bias.
    Unfolded,
}

/// Why no path came back.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) enum PathError {
    /// The target cannot be reached from the source.
    Unreachable,
    /// This vertex has a non-finite coordinate.
    NonFinite(u32),
}

/// A point of a surface path: `(1 - t) p_a + t p_b` (`a == b`, `t == 0` for a vertex).
pub(crate) type PathPoint = (u32, u32, f64);

#[derive(Debug, PartialEq)]
struct Item {
    /// Priority: path length so far plus the straight-line distance to the target.
    dist: f64,
    /// Path length so far.
    g: f64,
    v: u32,
}

impl Eq for Item {}

impl PartialOrd for Item {
    fn partial_cmp(&self, other: &Self) -> Option<Ordering> {
        Some(self.cmp(other))
    }
}

impl Ord for Item {
    /// Reversed so `BinaryHeap` (a max-heap) pops the smallest distance;
    /// ties broken by vertex index for deterministic paths.
    fn cmp(&self, other: &Self) -> Ordering {
        other
            .dist
            .total_cmp(&self.dist)
            .then_with(|| other.v.cmp(&self.v))
    }
}

/// The per-vertex state of one search, kept per thread from one search to
/// the next: a prediction measures a dozen geodesics per round, and clearing
/// two arrays over every vertex of the template for each (a few hundred KB)
/// cost more than the search itself, which visits a small part of the mesh
/// (issue 13). Hand-written: the same few lines as the search's own arrays,
/// with an epoch per vertex instead of a clear.
#[derive(Debug, Default)]
struct Search {
    best: Best,
    /// Predecessor vertex, and the crossed edge `(a, b)` for an across step
    /// (`u32::MAX` for a plain edge). Read only along the path found, whose
    /// every vertex this search wrote, so it is never cleared.
    pred: Vec<(u32, u32, u32)>,
    heap: BinaryHeap<Item>,
}

/// Path length so far per vertex (metres), infinite for a vertex this
/// search has not reached: an entry counts only if its stamp is the
/// current epoch.
#[derive(Debug, Default)]
struct Best {
    epoch: u32,
    stamp: Vec<u32>,
    dist: Vec<f64>,
}

impl Best {
    fn get(&self, v: u32) -> f64 {
        if self.stamp[v as usize] == self.epoch {
            self.dist[v as usize]
        } else {
            f64::INFINITY
        }
    }

    fn set(&mut self, v: u32, d: f64) {
        self.stamp[v as usize] = self.epoch;
        self.dist[v as usize] = d;
    }
}

impl Search {
    /// Starts a search over `n` vertices: every vertex unreached, the heap
    /// empty.
    fn begin(&mut self, n: usize) {
        self.heap.clear();
        let best = &mut self.best;
        if best.stamp.len() != n {
            best.stamp = vec![0; n];
            best.dist = vec![f64::INFINITY; n];
            best.epoch = 0;
            self.pred = vec![(u32::MAX, u32::MAX, u32::MAX); n];
        }
        best.epoch = best.epoch.wrapping_add(1);
        if best.epoch == 0 {
            // After 2^32 searches: every stamp is from an earlier epoch.
            best.stamp.fill(0);
            best.epoch = 1;
        }
    }
}

thread_local! {
    /// This thread's search state (see [`Search`]).
    static SEARCH: std::cell::RefCell<Search> = std::cell::RefCell::default();
}

fn finite(p: Vec3) -> bool {
    p.iter().all(|x| x.is_finite())
}

/// The straight path from `c` across edge `(a, b)` to `d` in the unfolding
/// of the two triangles `(a, b, c)` and `(b, a, d)`: `(t, length)` with the
/// crossing `q = (1 - t) p_a + t p_b`, or `None` when the straight line
/// misses the open edge (then a path through `a` or `b` is shorter).
/// `length = |c - q| + |q - d|` in 3D, because each triangle is isometric to
/// its unfolded copy and `q` lies on the shared edge.
fn across(pc: Vec3, pa: Vec3, pb: Vec3, pd: Vec3) -> Option<(f64, f64)> {
    let e = sub(pb, pa);
    let l2 = dot(e, e);
    if l2.is_nan() || l2 <= 0.0 {
        return None;
    }
    let l = l2.sqrt();
    let u = [e[0] / l, e[1] / l, e[2] / l];
    let coords = |q: Vec3| {
        let r = sub(q, pa);
        let x = dot(r, u);
        let h2 = dot(r, r) - x * x;
        (x, h2.max(0.0).sqrt())
    };
    let (xc, hc) = coords(pc);
    let (xd, hd) = coords(pd);
    if (hc + hd).is_nan() || hc + hd <= 0.0 {
        return None;
    }
    let x = xc + (xd - xc) * hc / (hc + hd);
    let t = x / l;
    if !(t > 0.0 && t < 1.0) {
        return None;
    }
    let q = add(pa, scale(e, t));
    Some((t, dist(pc, q) + dist(q, pd)))
}

impl EdgeGraph {
    /// The edge graph of `topology`.
    pub(crate) fn new(topology: &Topology) -> Self {
        let n = topology.n_vertices();
        let mut offsets = Vec::with_capacity(n + 1);
        let mut neighbours = Vec::with_capacity(2 * topology.edges().len());
        offsets.push(0);
        for v in 0..n as u32 {
            neighbours.extend_from_slice(topology.ring(v));
            offsets.push(neighbours.len() as u32);
        }
        let mut lists: Vec<Vec<[u32; 3]>> = vec![Vec::new(); n];
        for (e, &[a, b]) in topology.edges().iter().enumerate() {
            let faces: Vec<u32> = topology.edge_faces(e).collect();
            if faces.len() != 2 {
                continue;
            }
            let opposite = |f: u32| {
                topology.faces()[f as usize]
                    .into_iter()
                    .find(|&v| v != a && v != b)
            };
            if let (Some(c), Some(d)) = (opposite(faces[0]), opposite(faces[1])) {
                if c != d {
                    lists[c as usize].push([d, a, b]);
                    lists[d as usize].push([c, a, b]);
                }
            }
        }
        let mut across_offsets = Vec::with_capacity(n + 1);
        let mut across = Vec::new();
        across_offsets.push(0);
        for l in lists {
            across.extend(l);
            across_offsets.push(across.len() as u32);
        }
        Self {
            offsets,
            neighbours,
            across_offsets,
            across,
        }
    }

    /// Points of a shortest path from `from` to `to` (both included, just
    /// `[from]` when they are equal), for positions `p` (metres, one per
    /// vertex of the topology). With [`GeodesicMethod::Edges`] every point is
    /// a vertex; with [`GeodesicMethod::Unfolded`] a step across an edge adds
    /// the crossing point on that edge.
    pub(crate) fn shortest_path(
        &self,
        p: &[Vec3],
        from: u32,
        to: u32,
        method: GeodesicMethod,
    ) -> Result<Vec<PathPoint>, PathError> {
        for v in [from, to] {
            if !finite(p[v as usize]) {
                return Err(PathError::NonFinite(v));
            }
        }
        if from == to {
            return Ok(vec![(from, from, 0.0)]);
        }
        SEARCH.with(|cell| match cell.try_borrow_mut() {
            Ok(mut search) => self.search(&mut search, p, from, to, method),
            // Only if a search re-entered this thread's (it does not): a
            // fresh state, the same result.
            Err(_) => self.search(&mut Search::default(), p, from, to, method),
        })
    }

    /// [`EdgeGraph::shortest_path`] with the per-vertex state in `search`.
    fn search(
        &self,
        search: &mut Search,
        p: &[Vec3],
        from: u32,
        to: u32,
        method: GeodesicMethod,
    ) -> Result<Vec<PathPoint>, PathError> {
        search.begin(p.len());
        let Search {
            best, pred, heap, ..
        } = search;
        best.set(from, 0.0);
        let target = p[to as usize];
        heap.push(Item {
            dist: dist(p[from as usize], target),
            g: 0.0,
            v: from,
        });
        while let Some(Item { g: d, v, .. }) = heap.pop() {
            if d > best.get(v) {
                continue; // stale entry
            }
            if v == to {
                let mut rev: Vec<PathPoint> = vec![(to, to, 0.0)];
                let mut u = to;
                while u != from {
                    let (w, a, b) = pred[u as usize];
                    if a != u32::MAX {
                        // Recompute the crossing (same positions, same result).
                        let (t, _) =
                            across(p[w as usize], p[a as usize], p[b as usize], p[u as usize])
                                .expect("the crossing existed during the search");
                        rev.push((a, b, t));
                    }
                    rev.push((w, w, 0.0));
                    u = w;
                }
                rev.reverse();
                return Ok(rev);
            }
            let pv = p[v as usize];
            let (s, e) = (
                self.offsets[v as usize] as usize,
                self.offsets[v as usize + 1] as usize,
            );
            for &w in &self.neighbours[s..e] {
                let pw = p[w as usize];
                let len = dist(pv, pw);
                if !len.is_finite() {
                    return Err(PathError::NonFinite(if finite(pv) { w } else { v }));
                }
                let nd = d + len;
                if nd < best.get(w) {
                    best.set(w, nd);
                    pred[w as usize] = (v, u32::MAX, u32::MAX);
                    heap.push(Item {
                        dist: nd + dist(pw, target),
                        g: nd,
                        v: w,
                    });
                }
            }
            if method == GeodesicMethod::Unfolded {
                let (s, e) = (
                    self.across_offsets[v as usize] as usize,
                    self.across_offsets[v as usize + 1] as usize,
                );
                for &[w, a, b] in &self.across[s..e] {
                    let Some((_, len)) = across(pv, p[a as usize], p[b as usize], p[w as usize])
                    else {
                        continue; // misses the edge, or non-finite (caught by the edge steps)
                    };
                    let nd = d + len;
                    if nd < best.get(w) {
                        best.set(w, nd);
                        pred[w as usize] = (v, a, b);
                        heap.push(Item {
                            dist: nd + dist(p[w as usize], target),
                            g: nd,
                            v: w,
                        });
                    }
                }
            }
        }
        Err(PathError::Unreachable)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A bumpy `n x n` grid of unit squares, each split into two triangles.
    fn grid(n: u32, bump: f64) -> (Topology, Vec<Vec3>) {
        let at = |i: u32, j: u32| i * n + j;
        let mut faces = Vec::new();
        for i in 0..n - 1 {
            for j in 0..n - 1 {
                faces.push([at(i, j), at(i + 1, j), at(i + 1, j + 1)]);
                faces.push([at(i, j), at(i + 1, j + 1), at(i, j + 1)]);
            }
        }
        let p = (0..n * n)
            .map(|v| {
                let (x, y) = (f64::from(v / n), f64::from(v % n));
                [x, y, bump * (0.7 * x).sin() * (1.3 * y).cos()]
            })
            .collect();
        (Topology::new((n * n) as usize, faces).unwrap(), p)
    }

    /// The state kept between searches (other meshes, other sizes, the
    /// epoch wrapping around) gives exactly the paths of a fresh state.
    #[test]
    fn kept_search_state_gives_the_paths_of_a_fresh_one() {
        let mut kept = Search::default();
        for (round, (n, bump)) in [(6, 0.0), (9, 0.8), (6, 1.5), (9, 0.3)]
            .into_iter()
            .enumerate()
        {
            let (topology, p) = grid(n, bump);
            let graph = EdgeGraph::new(&topology);
            if round == 2 {
                // Two searches before the epoch counter wraps.
                kept.best.epoch = u32::MAX - 1;
            }
            for method in [GeodesicMethod::Edges, GeodesicMethod::Unfolded] {
                for (from, to) in [
                    (0, n * n - 1),
                    (n - 1, n * (n - 1)),
                    (3, 3),
                    (n + 1, 2 * n + 4),
                ] {
                    let fresh = graph.search(&mut Search::default(), &p, from, to, method);
                    let again = graph.search(&mut kept, &p, from, to, method);
                    assert_eq!(
                        fresh.as_ref().ok(),
                        again.as_ref().ok(),
                        "{n} {from}->{to} {method:?}"
                    );
                    assert_eq!(fresh, graph.shortest_path(&p, from, to, method));
                }
            }
        }
        assert!(kept.best.epoch < 100, "the epoch wrapped around");
    }
}
