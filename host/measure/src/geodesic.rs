//! Shortest paths on the mesh's edge graph (Dijkstra), as in the paper.
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

use tapeshape_mesh::{Topology, Vec3};

/// CSR adjacency of the edge graph.
#[derive(Debug, Clone)]
pub(crate) struct EdgeGraph {
    offsets: Vec<u32>,
    neighbours: Vec<u32>,
}

/// Why no path came back.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) enum PathError {
    /// The target cannot be reached from the source.
    Unreachable,
    /// This vertex has a non-finite coordinate.
    NonFinite(u32),
}

#[derive(PartialEq)]
struct Item {
    dist: f64,
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

fn dist(p: Vec3, q: Vec3) -> f64 {
    let d = [q[0] - p[0], q[1] - p[1], q[2] - p[2]];
    (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt()
}

fn finite(p: Vec3) -> bool {
    p.iter().all(|x| x.is_finite())
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
        Self {
            offsets,
            neighbours,
        }
    }

    /// Vertices of a shortest edge path from `from` to `to` (both included,
    /// `[from]` when they are equal), for positions `p` (metres, one per
    /// vertex of the topology).
    pub(crate) fn shortest_path(
        &self,
        p: &[Vec3],
        from: u32,
        to: u32,
    ) -> Result<Vec<u32>, PathError> {
        for v in [from, to] {
            if !finite(p[v as usize]) {
                return Err(PathError::NonFinite(v));
            }
        }
        if from == to {
            return Ok(vec![from]);
        }
        let n = p.len();
        let mut best = vec![f64::INFINITY; n];
        let mut pred = vec![u32::MAX; n];
        let mut heap = BinaryHeap::new();
        best[from as usize] = 0.0;
        heap.push(Item { dist: 0.0, v: from });
        while let Some(Item { dist: d, v }) = heap.pop() {
            if d > best[v as usize] {
                continue; // stale entry
            }
            if v == to {
                let mut path = vec![to];
                let mut u = to;
                while u != from {
                    u = pred[u as usize];
                    path.push(u);
                }
                path.reverse();
                return Ok(path);
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
                if nd < best[w as usize] {
                    best[w as usize] = nd;
                    pred[w as usize] = v;
                    heap.push(Item { dist: nd, v: w });
                }
            }
        }
        Err(PathError::Unreachable)
    }
}
