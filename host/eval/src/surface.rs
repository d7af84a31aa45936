//! A numeric surface check (issue 12, "Show"): does an estimated body fold
//! its surface more than real-looking bodies do?
//!
//! **Fold.** For an interior edge (exactly two triangles), the fold is the
//! angle between the unit normals of its two triangles, radians in
//! `[0, pi]`: 0 where the surface is flat across the edge, the bend angle
//! where it is bent along the edge, near `pi` where a triangle is flipped
//! over its neighbour. It is unsigned (a crease and a ridge count alike) and
//! depends only on the directions of the normals, so it does not change
//! with the body's size. A triangle of zero area has no normal: its edges
//! count as folded by `pi`.
//!
//! **Envelope.** Per interior edge, the largest fold over a set of training
//! bodies (registered meshes of one template topology, e.g. the generated
//! population a model was trained on): `E` values, radians. Where bodies
//! are naturally creased (fingers, ears, eyelids, the navel) the envelope
//! is large; across the chest or the skull it is small.
//!
//! **Excess.** A body's edges whose fold exceeds the envelope by more than
//! a margin `delta` (radians), as a share of all interior edges, and its
//! worst excess angle `max(fold - envelope)` over all edges (radians; 0 or
//! less when no edge folds more than on the training bodies).
//!
//! **Rule** ([`SurfaceRule`]): a body passes when its share of interior
//! edges that fold more than `delta` beyond the envelope is at most
//! `max_share`. Both numbers come from generated bodies only, never from
//! ANSUR II test-split people (ids divisible by 4):
//! [`SurfaceRule::calibrate`] takes the envelope of the model's training
//! population and held-out generated bodies of the same generator with
//! another seed, and picks the smallest margin at which the median
//! held-out body has no edge beyond (a typical body the model could have
//! been trained on sits inside), then the largest held-out share at that
//! margin rounded up to 0.05 % (every held-out body passes). Why a share
//! and not "no edge at all": held-out generated bodies themselves exceed
//! the envelope on a few edges (the largest body of 60: 0.21 % of the
//! edges beyond 5 degrees against 400 training bodies; over all 60, 212
//! edges, 91 on the torso and 53 on the head), and a body that looks
//! smooth may still have one edge, usually on the torso, folding tens of
//! degrees beyond (so the worst single angle says little on its own),
//! while a crease across the chest or a pointed head bends hundreds of
//! edges at once. Why a
//! margin: an envelope of finitely many bodies is a little tight
//! everywhere; the margin keeps edges that fold a degree or two more than
//! any training body from counting. For the embedded default model (400
//! training bodies, 60 held-out) this gives 5 degrees and 0.25 %
//! ([`SurfaceRule::CALIBRATED`]); a larger population gives a wider
//! envelope and so a smaller margin (2,100 bodies fitted to the `ansur`
//! set, 60 held-out: 2 degrees, 0.10 %). Sanity check, not calibration:
//! test-split subject 10032, whom issue 12 reports creased when entered
//! with all 44 `ansur` readings, has 1.76 % of edges beyond (7 x the
//! allowed share) and fails; with his 9 `quick` readings 0.03 %, a pass.
//! See `docs/results/real-customers/surface-check.md` for the runs.
//!
//! Units and frame: vertex positions in metres, station frame (Z up, +Y
//! front); angles in radians inside, degrees only on pages.

use std::sync::Arc;

use tapeshape_mesh::{Topology, Vec3};
use tapeshape_population::Dataset;

/// Fold angle (radians, `[0, pi]`) between triangles with unnormalised
/// normals `n1`, `n2` (any length > 0): `atan2(|n1 x n2|, n1 . n2)`, which
/// stays accurate near 0 and `pi`. `pi` when either normal is zero (a
/// degenerate triangle has no direction, so it counts as fully folded).
pub fn fold_between(n1: Vec3, n2: Vec3) -> f64 {
    use tapeshape_mesh::vec3::{cross, dot, norm};
    if norm(n1) == 0.0 || norm(n2) == 0.0 {
        return std::f64::consts::PI;
    }
    norm(cross(n1, n2)).atan2(dot(n1, n2))
}

/// The interior edges of a template topology (edges used by exactly two
/// triangles) and their folds on meshes of it.
#[derive(Debug, Clone)]
pub struct InteriorEdges {
    topology: Arc<Topology>,
    /// Index in [`Topology::edges`] of each interior edge, ascending.
    edge: Vec<usize>,
    /// The two triangles of each interior edge.
    faces: Vec<[u32; 2]>,
}

impl InteriorEdges {
    /// The interior edges of `topology` (boundary and non-manifold edges
    /// have no single fold and are left out).
    pub fn new(topology: Arc<Topology>) -> Self {
        let mut edge = Vec::new();
        let mut faces = Vec::new();
        for e in 0..topology.edges().len() {
            if topology.edge_face_count(e) == 2 {
                let mut it = topology.edge_faces(e);
                if let (Some(a), Some(b)) = (it.next(), it.next()) {
                    edge.push(e);
                    faces.push([a, b]);
                }
            }
        }
        Self {
            topology,
            edge,
            faces,
        }
    }

    /// How many interior edges.
    pub fn len(&self) -> usize {
        self.edge.len()
    }

    /// True when the topology has no interior edge.
    pub fn is_empty(&self) -> bool {
        self.edge.is_empty()
    }

    /// The topology.
    pub fn topology(&self) -> &Arc<Topology> {
        &self.topology
    }

    /// The vertex pair `[a, b]` (`a < b`) of interior edge `i`.
    pub fn vertices_of(&self, i: usize) -> [u32; 2] {
        self.topology.edges()[self.edge[i]]
    }

    /// Folds of `vertices` (`V` points, metres, this topology): one per
    /// interior edge, radians, in the order of the interior edges.
    /// Errors when the vertex count does not match the topology.
    pub fn folds(&self, vertices: &[Vec3]) -> Result<Vec<f64>, SurfaceError> {
        if vertices.len() != self.topology.n_vertices() {
            return Err(SurfaceError::Vertices {
                got: vertices.len(),
                expected: self.topology.n_vertices(),
            });
        }
        let faces = self.topology.faces();
        let normal = |f: u32| {
            let [a, b, c] = faces[f as usize].map(|i| vertices[i as usize]);
            tapeshape_mesh::vec3::triangle_normal(a, b, c)
        };
        Ok(self
            .faces
            .iter()
            .map(|&[f, g]| fold_between(normal(f), normal(g)))
            .collect())
    }
}

/// What went wrong in a surface check.
#[derive(Debug, thiserror::Error)]
pub enum SurfaceError {
    /// A body has a different vertex count from the topology.
    #[error("a body has {got} vertices, the template {expected}")]
    Vertices {
        /// The body's.
        got: usize,
        /// The topology's.
        expected: usize,
    },
    /// A body's topology is not the envelope's.
    #[error("the body's topology is not the envelope's ({0})")]
    Topology(String),
    /// An envelope of no bodies, or a calibration on none.
    #[error("an envelope or a calibration needs at least one body")]
    Empty,
}

/// The per-edge largest fold over a set of training bodies (see the module
/// docs).
#[derive(Debug, Clone)]
pub struct Envelope {
    edges: InteriorEdges,
    /// Per interior edge, radians.
    max_fold: Vec<f64>,
    bodies: usize,
}

impl Envelope {
    /// The envelope of `bodies` (each `V` points, metres, of `topology`).
    /// Errors on no bodies or a vertex count that does not match.
    pub fn from_bodies<'a>(
        topology: Arc<Topology>,
        bodies: impl IntoIterator<Item = &'a [Vec3]>,
    ) -> Result<Self, SurfaceError> {
        let edges = InteriorEdges::new(topology);
        let mut max_fold = vec![f64::NEG_INFINITY; edges.len()];
        let mut n = 0;
        for b in bodies {
            for (m, f) in max_fold.iter_mut().zip(edges.folds(b)?) {
                *m = m.max(f);
            }
            n += 1;
        }
        if n == 0 {
            return Err(SurfaceError::Empty);
        }
        Ok(Self {
            edges,
            max_fold,
            bodies: n,
        })
    }

    /// The interior edges it is defined on.
    pub fn edges(&self) -> &InteriorEdges {
        &self.edges
    }

    /// Per interior edge, the largest fold over the training bodies, radians.
    pub fn max_fold(&self) -> &[f64] {
        &self.max_fold
    }

    /// How many training bodies.
    pub fn bodies(&self) -> usize {
        self.bodies
    }

    /// Checks that `topology` has the envelope's triangles (the same
    /// template), so that edges correspond.
    pub fn check_topology(&self, topology: &Topology) -> Result<(), SurfaceError> {
        let mine = self.edges.topology();
        if mine.n_vertices() != topology.n_vertices() || mine.faces() != topology.faces() {
            return Err(SurfaceError::Topology(format!(
                "{} vertices / {} triangles against {} / {}",
                topology.n_vertices(),
                topology.faces().len(),
                mine.n_vertices(),
                mine.faces().len()
            )));
        }
        Ok(())
    }

    /// Where a body folds beyond the envelope: of `folds` (per interior
    /// edge, radians, [`InteriorEdges::folds`]) the edges beyond envelope +
    /// `delta` (radians), counted per body part of `anatomy` (an edge counts
    /// for the part of its first triangle; `other` when that has none),
    /// largest count first.
    pub fn beyond_by_part(
        &self,
        folds: &[f64],
        delta: f64,
        anatomy: &tapeshape_mesh::Anatomy,
    ) -> Vec<(String, usize)> {
        let mut part_of = vec![None; self.edges.topology().faces().len()];
        for (name, faces) in &anatomy.parts {
            for &f in faces {
                if let Some(p) = part_of.get_mut(f as usize) {
                    *p = Some(name.as_str());
                }
            }
        }
        let mut counts = std::collections::BTreeMap::<&str, usize>::new();
        for (i, (f, m)) in folds.iter().zip(&self.max_fold).enumerate() {
            if f - m > delta {
                let face = self.edges.faces[i][0] as usize;
                *counts.entry(part_of[face].unwrap_or("other")).or_default() += 1;
            }
        }
        let mut v: Vec<(String, usize)> = counts
            .into_iter()
            .map(|(k, n)| (k.to_string(), n))
            .collect();
        v.sort_by(|a, b| b.1.cmp(&a.1).then(a.0.cmp(&b.0)));
        v
    }

    /// The excess of `vertices` (`V` points, metres, the envelope's
    /// topology) over the envelope with margin `delta` (radians).
    pub fn excess(&self, vertices: &[Vec3], delta: f64) -> Result<Excess, SurfaceError> {
        Ok(Excess::of(
            &self.edges.folds(vertices)?,
            &self.max_fold,
            delta,
        ))
    }
}

/// One body against an envelope (see the module docs).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Excess {
    /// Interior edges whose fold exceeds the envelope by more than the margin.
    pub count: usize,
    /// All interior edges.
    pub edges: usize,
    /// The margin it was counted with, radians.
    pub delta: f64,
    /// The largest `fold - envelope` over all edges, radians (0 or less:
    /// no edge folds more than on every training body).
    pub worst: f64,
    /// The interior edge of [`Excess::worst`].
    pub worst_edge: usize,
}

impl Excess {
    /// From per-edge `folds` and the `envelope` (same order, radians) with
    /// margin `delta` (radians).
    pub fn of(folds: &[f64], envelope: &[f64], delta: f64) -> Self {
        let mut e = Excess {
            count: 0,
            edges: folds.len(),
            delta,
            worst: f64::NEG_INFINITY,
            worst_edge: 0,
        };
        for (i, (f, m)) in folds.iter().zip(envelope).enumerate() {
            let d = f - m;
            if d > delta {
                e.count += 1;
            }
            if d > e.worst {
                e.worst = d;
                e.worst_edge = i;
            }
        }
        e
    }

    /// [`Excess::count`] over [`Excess::edges`], 0..=1.
    pub fn share(&self) -> f64 {
        self.count as f64 / self.edges.max(1) as f64
    }
}

/// The pass rule: a body passes when the share of its interior edges that
/// fold more than `delta` beyond the envelope is at most `max_share`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SurfaceRule {
    /// Margin over the envelope, radians.
    pub delta: f64,
    /// Largest share of edges allowed beyond envelope + margin, 0..=1.
    pub max_share: f64,
}

impl SurfaceRule {
    /// The margins [`SurfaceRule::calibrate`] tries, degrees, smallest first.
    pub const MARGINS_DEG: [f64; 10] = [0.0, 1.0, 2.0, 3.0, 5.0, 7.5, 10.0, 15.0, 20.0, 30.0];

    /// The step [`SurfaceRule::calibrate`] rounds the allowed share up to:
    /// 0.05 % of the edges (about 20 of the template's 41,130).
    pub const SHARE_STEP: f64 = 0.0005;

    /// The rule of the embedded default model: [`SurfaceRule::calibrate`]
    /// with the envelope of its 400 training bodies
    /// (`tapeshape dataset generate --n 400 --seed 1`) and 60 held-out
    /// generated bodies (`--n 60 --seed 2`): margin 5 degrees, at most
    /// 0.25 % of the edges (the largest held-out body: 0.209 %).
    pub const CALIBRATED: SurfaceRule = SurfaceRule {
        delta: 5.0 * std::f64::consts::PI / 180.0,
        max_share: 0.0025,
    };

    /// Calibrates the rule on generated held-out bodies (never on people):
    /// `held_out` are their folds (one `Vec` per body, per interior edge,
    /// radians, [`InteriorEdges::folds`]) against `envelope` (their
    /// template's). The margin is the smallest of
    /// [`SurfaceRule::MARGINS_DEG`] at which the median held-out body has
    /// no edge beyond envelope + margin (a typical body that the model
    /// could have been trained on sits inside); the allowed share is the
    /// largest held-out body's share at that margin, rounded up to
    /// [`SurfaceRule::SHARE_STEP`] (every held-out body passes, with at
    /// most one step of headroom). `None` for no held-out body.
    pub fn calibrate(envelope: &Envelope, held_out: &[Vec<f64>]) -> Option<SurfaceRule> {
        if held_out.is_empty() {
            return None;
        }
        let deg = std::f64::consts::PI / 180.0;
        let shares = |delta: f64| -> Vec<f64> {
            held_out
                .iter()
                .map(|f| Excess::of(f, envelope.max_fold(), delta).share())
                .collect()
        };
        let margins = Self::MARGINS_DEG.map(|m| m * deg);
        let delta = margins
            .iter()
            .copied()
            .find(|&d| quantile(&shares(d), 0.5) == 0.0)
            .unwrap_or(margins[margins.len() - 1]);
        let largest = quantile(&shares(delta), 1.0);
        // Round up to the step, and never to zero: one step at least.
        let steps = (largest / Self::SHARE_STEP - 1e-9).ceil().max(1.0);
        Some(SurfaceRule {
            delta,
            max_share: steps * Self::SHARE_STEP,
        })
    }

    /// Whether `excess` (counted with this rule's margin) passes.
    pub fn passes(&self, excess: &Excess) -> bool {
        excess.share() <= self.max_share
    }
}

/// An envelope and a rule: what is run per body.
#[derive(Debug, Clone)]
pub struct SurfaceCheck {
    /// The training bodies' envelope.
    pub envelope: Envelope,
    /// The rule.
    pub rule: SurfaceRule,
}

/// One body's verdict.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SurfaceVerdict {
    /// Its excess (counted with the rule's margin).
    pub excess: Excess,
    /// Whether it passes the rule.
    pub pass: bool,
}

impl SurfaceCheck {
    /// The envelope of `train`'s bodies, and the rule calibrated on
    /// `held`'s ([`SurfaceRule::calibrate`]; `None`:
    /// [`SurfaceRule::CALIBRATED`]). Both datasets must share a template.
    pub fn from_datasets(train: &Dataset, held: Option<&Dataset>) -> Result<Self, SurfaceError> {
        let envelope = Envelope::from_bodies(
            train.topology.clone(),
            train.bodies.iter().map(|b| b.as_slice()),
        )?;
        let rule = match held {
            None => SurfaceRule::CALIBRATED,
            Some(h) => {
                envelope.check_topology(&h.topology)?;
                let folds = h
                    .bodies
                    .iter()
                    .map(|b| envelope.edges().folds(b))
                    .collect::<Result<Vec<_>, _>>()?;
                SurfaceRule::calibrate(&envelope, &folds).ok_or(SurfaceError::Empty)?
            }
        };
        Ok(Self { envelope, rule })
    }

    /// Judges `vertices` (`V` points, metres, the envelope's topology).
    pub fn judge(&self, vertices: &[Vec3]) -> Result<SurfaceVerdict, SurfaceError> {
        let excess = self.envelope.excess(vertices, self.rule.delta)?;
        Ok(SurfaceVerdict {
            pass: self.rule.passes(&excess),
            excess,
        })
    }
}

/// The `q`-quantile (0..=1, nearest rank on the sorted values) of `values`;
/// NaN for none.
pub fn quantile(values: &[f64], q: f64) -> f64 {
    if values.is_empty() {
        return f64::NAN;
    }
    let mut v = values.to_vec();
    v.sort_by(f64::total_cmp);
    let k = ((q.clamp(0.0, 1.0) * v.len() as f64).ceil() as usize).clamp(1, v.len()) - 1;
    v[k]
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    /// An `n x n` grid of unit squares in the XY plane, each split into two
    /// counter-clockwise triangles; returns the points and the topology.
    fn grid(n: usize) -> (Vec<Vec3>, Arc<Topology>) {
        let id = |i: usize, j: usize| (j * (n + 1) + i) as u32;
        let mut v = Vec::new();
        for j in 0..=n {
            for i in 0..=n {
                v.push([i as f64, j as f64, 0.0]);
            }
        }
        let mut f = Vec::new();
        for j in 0..n {
            for i in 0..n {
                f.push([id(i, j), id(i + 1, j), id(i + 1, j + 1)]);
                f.push([id(i, j), id(i + 1, j + 1), id(i, j + 1)]);
            }
        }
        (v, Arc::new(Topology::new((n + 1) * (n + 1), f).unwrap()))
    }

    /// The grid bent along the line x = `at` by `angle`: the part with
    /// x > at rotated about that line (around the Y axis).
    fn bend(v: &[Vec3], at: f64, angle: f64) -> Vec<Vec3> {
        v.iter()
            .map(|p| {
                if p[0] <= at {
                    *p
                } else {
                    let d = p[0] - at;
                    [at + d * angle.cos(), p[1], d * angle.sin()]
                }
            })
            .collect()
    }

    #[test]
    fn a_flat_grid_folds_nowhere() {
        let (v, topo) = grid(4);
        let edges = InteriorEdges::new(topo);
        // 4 x 4 squares: 3*4 vertical + 3*4 horizontal + 16 diagonals inside.
        assert_eq!(edges.len(), 12 + 12 + 16);
        assert!(edges.folds(&v).unwrap().iter().all(|f| *f == 0.0));
    }

    #[test]
    fn a_bent_grid_folds_by_the_bend_exactly_on_the_bend_line() {
        let (v, topo) = grid(4);
        let edges = InteriorEdges::new(topo);
        for angle in [0.1, 0.5, 1.0, 2.0] {
            let b = bend(&v, 2.0, angle);
            let folds = edges.folds(&b).unwrap();
            for (i, f) in folds.iter().enumerate() {
                let [a, c] = edges.vertices_of(i);
                let on_line = v[a as usize][0] == 2.0 && v[c as usize][0] == 2.0;
                if on_line {
                    assert!((f - angle).abs() < 1e-12, "edge {i}: {f} vs {angle}");
                } else {
                    assert!(f.abs() < 1e-12, "edge {i} off the line folds {f}");
                }
            }
            assert_eq!(folds.iter().filter(|f| **f > 1e-9).count(), 4);
        }
    }

    #[test]
    fn a_training_body_has_no_excess_and_a_sharper_bend_has_exactly_its_extra() {
        let (v, topo) = grid(4);
        let train = [bend(&v, 2.0, 0.3), bend(&v, 1.0, 0.2)];
        let env = Envelope::from_bodies(topo.clone(), train.iter().map(|b| b.as_slice())).unwrap();
        assert_eq!(env.bodies(), 2);
        for b in &train {
            let e = env.excess(b, 0.0).unwrap();
            assert_eq!(e.count, 0);
            assert!(e.worst.abs() < 1e-12, "{}", e.worst);
        }
        // Bent along x = 2 by 0.5: 0.2 beyond the envelope on the 4 edges of
        // that line.
        let e = env.excess(&bend(&v, 2.0, 0.5), 0.0).unwrap();
        assert_eq!(e.count, 4);
        assert!((e.worst - 0.2).abs() < 1e-12);
        assert!((e.share() - 4.0 / 40.0).abs() < 1e-15);
        // A margin above the extra angle counts nothing.
        assert_eq!(env.excess(&bend(&v, 2.0, 0.5), 0.25).unwrap().count, 0);
        let rule = SurfaceRule {
            delta: 0.1,
            max_share: 0.05,
        };
        let check = SurfaceCheck {
            envelope: env,
            rule,
        };
        assert!(check.judge(&train[0]).unwrap().pass);
        assert!(!check.judge(&bend(&v, 2.0, 0.5)).unwrap().pass);
    }

    #[test]
    fn calibration_takes_the_first_margin_with_a_clean_median_and_the_largest_share() {
        // 100 edges, envelope 0.1 rad everywhere; three held-out bodies.
        let env = Envelope {
            edges: InteriorEdges::new(grid(1).1),
            max_fold: vec![0.1; 100],
            bodies: 1,
        };
        let deg = PI / 180.0;
        let body = |beyond: &[(usize, f64)]| {
            let mut f = vec![0.05; 100];
            for &(n, extra) in beyond {
                for x in f.iter_mut().take(n) {
                    *x = 0.1 + extra;
                }
            }
            f
        };
        // Two bodies exceed by 1.5 deg on a few edges, the third by 2.5 deg
        // on 3 edges: at 2 deg the median body is clean, the largest share
        // is 3 %, rounded up to a whole step.
        let held = vec![
            body(&[(2, 1.5 * deg)]),
            body(&[(4, 1.5 * deg)]),
            body(&[(3, 2.5 * deg)]),
        ];
        let rule = SurfaceRule::calibrate(&env, &held).unwrap();
        assert!(
            (rule.delta - 2.0 * deg).abs() < 1e-15,
            "{}",
            rule.delta / deg
        );
        assert!((rule.max_share - 0.03).abs() < 1e-12, "{}", rule.max_share);
        // Every held-out body passes its own calibration.
        for f in &held {
            assert!(rule.passes(&Excess::of(f, env.max_fold(), rule.delta)));
        }
        // All clean: the first margin, one step.
        let clean = SurfaceRule::calibrate(&env, &[body(&[])]).unwrap();
        assert_eq!(clean.delta, 0.0);
        assert_eq!(clean.max_share, SurfaceRule::SHARE_STEP);
        assert!(SurfaceRule::calibrate(&env, &[]).is_none());
    }

    #[test]
    fn edges_beyond_are_counted_in_the_part_of_their_first_triangle() {
        let (v, topo) = grid(4);
        let env = Envelope::from_bodies(topo.clone(), [v.as_slice()]).unwrap();
        let edges = env.edges();
        let folds = edges.folds(&bend(&v, 2.0, 0.5)).unwrap();
        // The left half (x < 2) is "left"; the bend line's edges have one
        // triangle on each side.
        let mut anatomy = tapeshape_mesh::Anatomy::default();
        let left: Vec<u32> = (0..topo.faces().len() as u32)
            .filter(|&f| {
                topo.faces()[f as usize]
                    .iter()
                    .all(|&i| v[i as usize][0] <= 2.0)
            })
            .collect();
        anatomy.parts.insert("left".into(), left.clone());
        let by = env.beyond_by_part(&folds, 0.1, &anatomy);
        let total: usize = by.iter().map(|(_, n)| n).sum();
        assert_eq!(total, 4);
        let expect_left = (0..edges.len())
            .filter(|&i| folds[i] > 0.1 && left.contains(&edges.faces[i][0]))
            .count();
        let got_left = by.iter().find(|(k, _)| k == "left").map_or(0, |p| p.1);
        assert_eq!(got_left, expect_left);
        assert_eq!(
            by.iter().find(|(k, _)| k == "other").map_or(0, |p| p.1),
            4 - expect_left
        );
    }

    #[test]
    fn a_flipped_triangle_folds_by_pi_and_a_degenerate_one_counts_as_pi() {
        assert!((fold_between([0.0, 0.0, 1.0], [0.0, 0.0, -2.0]) - PI).abs() < 1e-15);
        assert_eq!(fold_between([0.0, 0.0, 1.0], [0.0; 3]), PI);
        assert!((fold_between([0.0, 0.0, 1.0], [0.0, 1.0, 1.0]) - PI / 4.0).abs() < 1e-15);
    }

    #[test]
    fn a_body_of_another_size_is_refused() {
        let (v, topo) = grid(2);
        let env = Envelope::from_bodies(topo, [v.as_slice()]).unwrap();
        assert!(matches!(
            env.excess(&v[1..], 0.0),
            Err(SurfaceError::Vertices { .. })
        ));
        let (_, other) = grid(3);
        assert!(env.check_topology(&other).is_err());
        assert!(env.check_topology(env.edges().topology()).is_ok());
        assert!(matches!(
            Envelope::from_bodies(grid(1).1, std::iter::empty()),
            Err(SurfaceError::Empty)
        ));
    }

    #[test]
    fn quantile_is_nearest_rank() {
        let v = [5.0, 1.0, 3.0, 2.0, 4.0];
        assert_eq!(quantile(&v, 0.5), 3.0);
        assert_eq!(quantile(&v, 0.0), 1.0);
        assert_eq!(quantile(&v, 1.0), 5.0);
        assert_eq!(quantile(&v, 0.99), 5.0);
        assert!(quantile(&[], 0.5).is_nan());
    }
}
