//! A measurement set compiled against one topology and anatomy.
//!
//! Compiling resolves every landmark and part name to indices, checks them
//! against the topology, and precomputes what depends only on the topology
//! (the Dijkstra edge graph, each part set's edge and triangle lists for
//! plane cuts), so measuring a body, or a batch of bodies sharing the
//! template, does only per-body work.

use std::sync::Arc;

use rayon::prelude::*;
use tapeshape_common::suggest::did_you_mean;
use tapeshape_mesh::vec3::{cross, dot, norm, sub};
use tapeshape_mesh::{Anatomy, Topology, Vec3};

use crate::cut::{convex_hull, CutError, CutPoint, PartCut};
use crate::error::MeasureError;
use crate::geodesic::{EdgeGraph, GeodesicMethod, PathError};
use crate::set::{Kind, MeasurementSet, DEFAULT_FLOOR};
use crate::support::{Measured, Support, SupportPoint};

/// What to take from a plane cut.
#[derive(Debug, Clone, Copy)]
enum CutMode {
    /// Perimeter of the convex hull.
    Hull,
    /// Extent of the hull along a unit axis (caliper).
    Extent(Vec3),
}

#[derive(Debug, Clone)]
enum Op {
    /// Landmark chain: straight segments or geodesics, open or closed.
    Chain {
        points: Vec<u32>,
        names: Vec<String>,
        /// `None` for straight segments.
        geodesic: Option<GeodesicMethod>,
        closed: bool,
    },
    /// Vertical distance from the lowest of `floors` to `landmark`.
    Height { landmark: u32, floors: Vec<u32> },
    /// Plane cut through `anchor`.
    Cut {
        anchor: u32,
        anchor_name: String,
        normal: Vec3,
        parts: Vec<String>,
        cut: usize,
        mode: CutMode,
        /// Empty, or two landmarks the plane also passes through (normal computed per body).
        through: Vec<(u32, String)>,
    },
}

/// A [`MeasurementSet`] compiled for one topology: call [`CompiledSet::measure`]
/// with each body's vertex positions.
#[derive(Debug, Clone)]
pub struct CompiledSet {
    set: MeasurementSet,
    n_vertices: usize,
    ops: Vec<Op>,
    cuts: Vec<PartCut>,
    graph: Arc<EdgeGraph>,
}

impl MeasurementSet {
    /// Resolves names against `anatomy`, checks indices against `topology`
    /// and precomputes the per-topology data. Errors name the measurement and
    /// suggest the closest known landmark or part name.
    pub fn compile(
        &self,
        topology: &Topology,
        anatomy: &Anatomy,
    ) -> Result<CompiledSet, MeasureError> {
        let n_vertices = topology.n_vertices();
        let n_faces = topology.faces().len();
        let mut ops = Vec::with_capacity(self.definitions.len());
        let mut cuts: Vec<PartCut> = Vec::new();
        let mut cut_keys: Vec<Vec<String>> = Vec::new();
        for def in &self.definitions {
            let lm =
                |name: &str| -> Result<u32, MeasureError> {
                    let v = *anatomy.landmarks.get(name).ok_or_else(|| {
                        MeasureError::UnknownLandmark {
                            measurement: def.name.clone(),
                            landmark: name.to_string(),
                            suggestion: did_you_mean(
                                name,
                                anatomy.landmarks.keys().map(String::as_str),
                            ),
                        }
                    })?;
                    if v as usize >= n_vertices {
                        return Err(MeasureError::LandmarkOutOfRange {
                            measurement: def.name.clone(),
                            landmark: name.to_string(),
                            vertex: v,
                            n_vertices,
                        });
                    }
                    Ok(v)
                };
            let mut cut_index = |parts: &[String]| -> Result<usize, MeasureError> {
                let mut key = parts.to_vec();
                key.sort();
                key.dedup();
                if let Some(i) = cut_keys.iter().position(|k| *k == key) {
                    return Ok(i);
                }
                let mut tris = Vec::new();
                for part in &key {
                    let t = anatomy
                        .parts
                        .get(part)
                        .ok_or_else(|| MeasureError::UnknownPart {
                            measurement: def.name.clone(),
                            part: part.clone(),
                            suggestion: did_you_mean(
                                part,
                                anatomy.parts.keys().map(String::as_str),
                            ),
                        })?;
                    if let Some(&bad) = t.iter().find(|&&f| f as usize >= n_faces) {
                        return Err(MeasureError::PartTriangleOutOfRange {
                            measurement: def.name.clone(),
                            part: part.clone(),
                            triangle: bad,
                            n_faces,
                        });
                    }
                    tris.extend_from_slice(t);
                }
                cuts.push(PartCut::new(topology, &tris));
                cut_keys.push(key);
                Ok(cuts.len() - 1)
            };
            let chain = |names: Vec<&String>,
                         geodesic: Option<GeodesicMethod>,
                         closed: bool|
             -> Result<Op, MeasureError> {
                Ok(Op::Chain {
                    points: names.iter().map(|n| lm(n)).collect::<Result<_, _>>()?,
                    names: names.into_iter().cloned().collect(),
                    geodesic,
                    closed,
                })
            };
            let op = match &def.kind {
                Kind::Euclidean { from, to } => chain(vec![from, to], None, false)?,
                Kind::Geodesic { from, to, method } => chain(vec![from, to], Some(*method), false)?,
                Kind::Path { landmarks } => chain(landmarks.iter().collect(), None, false)?,
                Kind::GeodesicPath { landmarks, method } => {
                    chain(landmarks.iter().collect(), Some(*method), false)?
                }
                Kind::GeodesicLoop { landmarks, method } => {
                    chain(landmarks.iter().collect(), Some(*method), true)?
                }
                Kind::Height { landmark, floor } => Op::Height {
                    landmark: lm(landmark)?,
                    floors: match floor {
                        Some(f) => vec![lm(f)?],
                        None => DEFAULT_FLOOR
                            .iter()
                            .map(|f| lm(f))
                            .collect::<Result<_, _>>()?,
                    },
                },
                Kind::Circumference {
                    anchor,
                    normal,
                    parts,
                    through,
                } => Op::Cut {
                    anchor: lm(anchor)?,
                    anchor_name: anchor.clone(),
                    normal: *normal,
                    parts: parts.clone(),
                    cut: cut_index(parts)?,
                    mode: CutMode::Hull,
                    through: through
                        .iter()
                        .map(|n| Ok((lm(n)?, n.clone())))
                        .collect::<Result<_, MeasureError>>()?,
                },
                Kind::Breadth {
                    anchor,
                    normal,
                    parts,
                    axis,
                }
                | Kind::Depth {
                    anchor,
                    normal,
                    parts,
                    axis,
                } => Op::Cut {
                    anchor: lm(anchor)?,
                    anchor_name: anchor.clone(),
                    normal: *normal,
                    parts: parts.clone(),
                    cut: cut_index(parts)?,
                    mode: CutMode::Extent(*axis),
                    through: Vec::new(),
                },
            };
            ops.push(op);
        }
        Ok(CompiledSet {
            set: self.clone(),
            n_vertices,
            ops,
            cuts,
            graph: Arc::new(EdgeGraph::new(topology)),
        })
    }
}

/// Unit normal of the plane through `p[a]`, `p[b]`, `p[c]`, turned to agree
/// with `hint`; `None` when the three points are (nearly) collinear or not finite.
fn plane_normal(p: &[Vec3], a: u32, b: u32, c: u32, hint: Vec3) -> Option<Vec3> {
    let (pa, pb, pc) = (p[a as usize], p[b as usize], p[c as usize]);
    let (u, v) = (sub(pb, pa), sub(pc, pa));
    let n = cross(u, v);
    let l = norm(n);
    let scale = norm(u) * norm(v);
    if !l.is_finite() || l <= 1e-9 * scale || l == 0.0 {
        return None;
    }
    let s = if dot(n, hint) < 0.0 { -1.0 } else { 1.0 };
    Some([s * n[0] / l, s * n[1] / l, s * n[2] / l])
}

fn finite(p: Vec3) -> bool {
    p.iter().all(|x| x.is_finite())
}

/// Support points of a chain of segments `points[0] - points[1] - ...`, closed if asked.
fn chain_support(points: Vec<SupportPoint>, closed: bool, axis: Option<Vec3>) -> Support {
    let k = points.len() as u32;
    let mut segments: Vec<[u32; 2]> = (1..k).map(|i| [i - 1, i]).collect();
    if closed && k >= 2 {
        segments.push([k - 1, 0]);
    }
    Support {
        points,
        segments,
        axis,
    }
}

fn cut_point_support(q: &CutPoint) -> SupportPoint {
    if q.t == 0.0 {
        SupportPoint::vertex(q.a)
    } else if q.t == 1.0 {
        SupportPoint::vertex(q.b)
    } else {
        SupportPoint {
            a: q.a,
            b: q.b,
            t: q.t,
        }
    }
}

impl CompiledSet {
    /// The set this was compiled from.
    pub fn set(&self) -> &MeasurementSet {
        &self.set
    }

    /// Number of measurements.
    pub fn len(&self) -> usize {
        self.ops.len()
    }

    /// Whether the set is empty (never for a loaded set).
    pub fn is_empty(&self) -> bool {
        self.ops.is_empty()
    }

    /// Number of vertices of the topology this set was compiled for.
    pub fn n_vertices(&self) -> usize {
        self.n_vertices
    }

    fn check_len(&self, vertices: &[Vec3]) -> Result<(), MeasureError> {
        if vertices.len() != self.n_vertices {
            return Err(MeasureError::VertexCount {
                got: vertices.len(),
                expected: self.n_vertices,
            });
        }
        Ok(())
    }

    /// All measurements of one body, in set order; the first failing one is the error.
    ///
    /// `vertices`: positions in metres, station frame, one per vertex of the
    /// compiled topology. Values are metres.
    pub fn measure(&self, vertices: &[Vec3]) -> Result<Vec<Measured>, MeasureError> {
        self.check_len(vertices)?;
        (0..self.ops.len())
            .map(|i| self.eval(i, vertices))
            .collect()
    }

    /// Every measurement of one body with its own result, so one broken
    /// measurement does not hide the others (for reports and the CLI).
    pub fn measure_each(
        &self,
        vertices: &[Vec3],
    ) -> Result<Vec<Result<Measured, MeasureError>>, MeasureError> {
        self.check_len(vertices)?;
        Ok((0..self.ops.len())
            .map(|i| self.eval(i, vertices))
            .collect())
    }

    /// Measurement `index` of one body (metres, see [`CompiledSet::measure`]).
    pub fn measure_one(&self, index: usize, vertices: &[Vec3]) -> Result<Measured, MeasureError> {
        if index >= self.ops.len() {
            return Err(MeasureError::IndexOutOfRange {
                index,
                len: self.ops.len(),
            });
        }
        self.check_len(vertices)?;
        self.eval(index, vertices)
    }

    /// All measurements of many bodies sharing the compiled topology, in
    /// parallel (rayon). Result `i` belongs to `bodies[i]`.
    pub fn measure_batch(&self, bodies: &[&[Vec3]]) -> Vec<Result<Vec<Measured>, MeasureError>> {
        bodies.par_iter().map(|b| self.measure(b)).collect()
    }

    fn eval(&self, index: usize, p: &[Vec3]) -> Result<Measured, MeasureError> {
        let name = &self.set.definitions[index].name;
        let non_finite = |v: u32| MeasureError::NonFinite {
            measurement: name.clone(),
            vertex: v,
            position: p[v as usize],
        };
        let support = match &self.ops[index] {
            Op::Chain {
                points,
                names,
                geodesic,
                closed,
            } => {
                for &v in points {
                    if !finite(p[v as usize]) {
                        return Err(non_finite(v));
                    }
                }
                match geodesic {
                    None => {
                        let pts = points.iter().map(|&v| SupportPoint::vertex(v)).collect();
                        chain_support(pts, *closed, None)
                    }
                    Some(method) => {
                        let k = points.len();
                        let legs = if *closed { k } else { k - 1 };
                        let mut pts: Vec<SupportPoint> = vec![SupportPoint::vertex(points[0])];
                        for i in 0..legs {
                            let (a, b) = (points[i], points[(i + 1) % k]);
                            let path =
                                self.graph.shortest_path(p, a, b, *method).map_err(
                                    |e| match e {
                                        PathError::NonFinite(v) => non_finite(v),
                                        PathError::Unreachable => MeasureError::NoPath {
                                            measurement: name.clone(),
                                            from: names[i].clone(),
                                            to: names[(i + 1) % k].clone(),
                                        },
                                    },
                                )?;
                            pts.extend(path[1..].iter().map(|&(a, b, t)| {
                                if a == b {
                                    SupportPoint::vertex(a)
                                } else {
                                    SupportPoint { a, b, t }
                                }
                            }));
                        }
                        if *closed {
                            // The last leg ends where the loop started: close the
                            // loop with a segment back to point 0 instead of a
                            // duplicate point.
                            pts.pop();
                            if pts.len() == 1 {
                                pts.push(pts[0]); // degenerate loop of one vertex
                            }
                        }
                        chain_support(pts, *closed, None)
                    }
                }
            }
            Op::Height { landmark, floors } => {
                for &v in floors.iter().chain([landmark]) {
                    if !finite(p[v as usize]) {
                        return Err(non_finite(v));
                    }
                }
                let floor = floors
                    .iter()
                    .copied()
                    .min_by(|&a, &b| p[a as usize][2].total_cmp(&p[b as usize][2]))
                    .expect("at least one floor landmark");
                chain_support(
                    vec![SupportPoint::vertex(floor), SupportPoint::vertex(*landmark)],
                    false,
                    Some([0.0, 0.0, 1.0]),
                )
            }
            Op::Cut {
                anchor,
                anchor_name,
                normal,
                parts,
                cut,
                mode,
                through,
            } => {
                let normal = &match through.as_slice() {
                    [(t1, n1), (t2, n2)] => plane_normal(p, *anchor, *t1, *t2, *normal)
                        .ok_or_else(|| MeasureError::DegeneratePlane {
                            measurement: name.clone(),
                            landmarks: [anchor_name.clone(), n1.clone(), n2.clone()],
                        })?,
                    _ => *normal,
                };
                let curve =
                    self.cuts[*cut]
                        .cut_curve(p, *anchor, *normal)
                        .map_err(|e| match e {
                            CutError::NonFinite(v) => non_finite(v),
                            CutError::Misses => MeasureError::PlaneMissesPart {
                                measurement: name.clone(),
                                anchor: anchor_name.clone(),
                                normal: *normal,
                                parts: parts.clone(),
                            },
                        })?;
                let hull = convex_hull(&curve, *normal);
                match mode {
                    CutMode::Hull => {
                        let pts: Vec<SupportPoint> =
                            hull.iter().map(|&i| cut_point_support(&curve[i])).collect();
                        let closed = pts.len() >= 2;
                        chain_support(pts, closed, None)
                    }
                    CutMode::Extent(axis) => {
                        let s = |i: usize| {
                            let q = curve[i].pos;
                            axis[0] * q[0] + axis[1] * q[1] + axis[2] * q[2]
                        };
                        let lo = hull
                            .iter()
                            .copied()
                            .min_by(|&i, &j| s(i).total_cmp(&s(j)))
                            .expect("non-empty hull");
                        let hi = hull
                            .iter()
                            .copied()
                            .max_by(|&i, &j| s(i).total_cmp(&s(j)))
                            .expect("non-empty hull");
                        chain_support(
                            vec![cut_point_support(&curve[lo]), cut_point_support(&curve[hi])],
                            false,
                            Some(*axis),
                        )
                    }
                }
            }
        };
        Ok(Measured {
            value: support.length(p),
            support,
        })
    }
}
