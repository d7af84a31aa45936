//! The dataset file format (`.tsd`) and a dataset in memory.
//!
//! # File format (`.tsd`, version 1)
//!
//! Little endian throughout.
//!
//! | bytes | content |
//! |---|---|
//! | 8 | magic `TSDATAST` |
//! | 4 | format version (u32) = 1 |
//! | 8 | header length H (u64) |
//! | H | header, UTF-8 JSON ([`DatasetHeader`]): kind, recipe (seed, settings), per-body records, template counts |
//! | 12 F | faces, `F x 3` u32 (F = `header.n_faces`) |
//! | 12 N V | vertices, body-major, `N x V x 3` f32, **metres, station frame (Z up, +Y front, +X the body's right, feet at z = 0)** |
//!
//! f32 storage keeps a 400-body file at 66 MB; its round-off (< 0.25 um for
//! coordinates below 2 m) is far below any tolerance the programs work to.
//! Files are written atomically (temporary file, fsync, rename).

use std::collections::BTreeMap;
use std::io::Read;
use std::path::Path;
use std::sync::Arc;

use serde::{Deserialize, Serialize};
use tapeshape_body::Phenotype;
use tapeshape_mesh::{Mesh, Topology, Vec3};

use crate::ansur::Sex;
use crate::generate::PopulationSettings;
use crate::DatasetError;

/// Magic bytes at the start of a dataset file.
pub const MAGIC: &[u8; 8] = b"TSDATAST";
/// Current dataset format version.
pub const FORMAT_VERSION: u32 = 1;

/// What a dataset holds.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum DatasetKind {
    /// Whole adult bodies in the template topology.
    Population,
    /// The head region of bodies whose faces vary; `vertex_map` says which
    /// template vertex each vertex is.
    Faces,
    /// A user's own registered meshes.
    Imported,
}

/// The result of fitting one body to its subject.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct FitRecord {
    /// Target per fitted dimension (mm, the subject's real value).
    pub target_mm: BTreeMap<String, f64>,
    /// Value measured on the generated body (mm).
    pub achieved_mm: BTreeMap<String, f64>,
    /// Largest |achieved - target| (mm).
    pub max_error_mm: f64,
    /// Gauss-Newton iterations used.
    pub iterations: usize,
}

/// One body of a dataset.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct BodyRecord {
    /// Stable name within the dataset.
    pub name: String,
    /// Sex, where known.
    pub sex: Option<Sex>,
    /// ANSUR II subject the body was fitted to.
    pub ansur_subject: Option<u32>,
    /// Age in years, where known.
    pub age_years: Option<f64>,
    /// Generator macro parameters (generated datasets).
    pub phenotype: Option<Phenotype>,
    /// Generator local changes, label -> value (generated datasets).
    pub local_changes: BTreeMap<String, f64>,
    /// Fit of the body to its subject (populations).
    pub fit: Option<FitRecord>,
    /// Coefficients of the section fields added to the generated body
    /// (`crate::sections`: hip, waist; units of 10 mm at the sections'
    /// diagonals), where the population was made with them; files written
    /// before they existed read back empty.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub section_fields: Vec<f64>,
    /// The file an imported mesh came from.
    pub source_file: Option<String>,
}

/// The JSON header of a dataset file.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct DatasetHeader {
    /// [`FORMAT_VERSION`] of the writer.
    pub format_version: u32,
    /// What the dataset holds.
    pub kind: DatasetKind,
    /// Program and version that wrote it.
    pub created_by: String,
    /// Vertices per body.
    pub n_vertices: usize,
    /// Triangles of the shared topology.
    pub n_faces: usize,
    /// For [`DatasetKind::Faces`]: template vertex index of each vertex.
    pub vertex_map: Option<Vec<u32>>,
    /// How it was made (generated datasets).
    pub settings: Option<PopulationSettings>,
    /// One record per body, in storage order.
    pub bodies: Vec<BodyRecord>,
}

/// A dataset in memory: bodies over one shared topology.
#[derive(Debug, Clone)]
pub struct Dataset {
    /// Header (records, provenance).
    pub header: DatasetHeader,
    /// Shared topology of every body.
    pub topology: Arc<Topology>,
    /// Vertex positions per body, metres, station frame; `N x V`.
    pub bodies: Vec<Vec<Vec3>>,
}

impl Dataset {
    /// Number of bodies.
    pub fn len(&self) -> usize {
        self.bodies.len()
    }

    /// True when the dataset has no bodies.
    pub fn is_empty(&self) -> bool {
        self.bodies.is_empty()
    }

    /// Body `i` as a mesh.
    pub fn mesh(&self, i: usize) -> Mesh {
        Mesh {
            vertices: self.bodies[i].clone(),
            topology: self.topology.clone(),
        }
    }

    /// Writes the dataset to `path` with the one atomic, fsynced write
    /// ([`tapeshape_common::fs::write_atomic_with`], streamed: a 400-body
    /// file is 66 MB).
    pub fn write(&self, path: &Path) -> Result<(), DatasetError> {
        let header = serde_json::to_vec(&self.header).expect("dataset header serialises");
        tapeshape_common::fs::write_atomic_with(path, |w| {
            w.write_all(MAGIC)?;
            w.write_all(&FORMAT_VERSION.to_le_bytes())?;
            w.write_all(&(header.len() as u64).to_le_bytes())?;
            w.write_all(&header)?;
            for f in self.topology.faces() {
                for &v in f {
                    w.write_all(&v.to_le_bytes())?;
                }
            }
            for body in &self.bodies {
                for p in body {
                    for &c in p {
                        w.write_all(&(c as f32).to_le_bytes())?;
                    }
                }
            }
            Ok(())
        })
        .map_err(|source| DatasetError::Io {
            path: path.to_path_buf(),
            source,
        })
    }

    /// Reads a dataset file, checking magic, version and sizes.
    pub fn read(path: &Path) -> Result<Dataset, DatasetError> {
        let bad = |message: String| DatasetError::Format {
            path: path.to_path_buf(),
            message,
        };
        let mut bytes = Vec::new();
        std::fs::File::open(path)
            .and_then(|mut f| f.read_to_end(&mut bytes))
            .map_err(|source| DatasetError::Io {
                path: path.to_path_buf(),
                source,
            })?;
        if bytes.len() < 20 || &bytes[..8] != MAGIC {
            return Err(bad("it does not start with the dataset magic bytes (make one with `tapeshape dataset generate` or `tapeshape dataset import`)".into()));
        }
        let version = u32::from_le_bytes(bytes[8..12].try_into().expect("4 bytes"));
        if version != FORMAT_VERSION {
            return Err(bad(format!(
                "format version {version}; this program reads version {FORMAT_VERSION}"
            )));
        }
        let hlen = u64::from_le_bytes(bytes[12..20].try_into().expect("8 bytes")) as usize;
        let hend = 20usize
            .checked_add(hlen)
            .filter(|&e| e <= bytes.len())
            .ok_or_else(|| bad("the header runs past the end of the file".into()))?;
        let header: DatasetHeader =
            serde_json::from_slice(&bytes[20..hend]).map_err(|e| bad(format!("header: {e}")))?;
        let (nv, nf, nb) = (header.n_vertices, header.n_faces, header.bodies.len());
        let expected = nf
            .checked_mul(12)
            .and_then(|f| nb.checked_mul(nv)?.checked_mul(12)?.checked_add(f))
            .and_then(|x| x.checked_add(hend))
            .ok_or_else(|| bad("sizes in the header overflow".into()))?;
        if bytes.len() != expected {
            return Err(bad(format!("{} bytes, but the header ({nb} bodies, {nv} vertices, {nf} faces) needs {expected}: the file is truncated or damaged", bytes.len())));
        }
        let mut at = hend;
        let u32_at = |at: &mut usize| {
            let v = u32::from_le_bytes(bytes[*at..*at + 4].try_into().expect("4 bytes"));
            *at += 4;
            v
        };
        let faces: Vec<[u32; 3]> = (0..nf)
            .map(|_| [u32_at(&mut at), u32_at(&mut at), u32_at(&mut at)])
            .collect();
        let topology = Topology::new(nv, faces).map_err(|e| bad(format!("faces: {e}")))?;
        let mut bodies = Vec::with_capacity(nb);
        for b in 0..nb {
            let mut body = Vec::with_capacity(nv);
            for _ in 0..nv {
                let mut p = [0.0; 3];
                for c in &mut p {
                    *c = f32::from_le_bytes(bytes[at..at + 4].try_into().expect("4 bytes")) as f64;
                    at += 4;
                }
                if !p.iter().all(|c| c.is_finite()) {
                    return Err(bad(format!("body {b} has a non-finite coordinate")));
                }
                body.push(p);
            }
            bodies.push(body);
        }
        Ok(Dataset {
            header,
            topology: Arc::new(topology),
            bodies,
        })
    }
}

/// The writer recorded in a new file's header (`created_by`).
pub(crate) fn created_by() -> String {
    format!("tapeshape-population {}", env!("CARGO_PKG_VERSION"))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::generate::tests::small_population;

    #[test]
    fn file_round_trip_and_damage_is_detected() {
        let d = small_population(2, 3);
        let dir = std::env::temp_dir().join(format!("tapeshape-ds-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("pop.tsd");
        d.write(&path).unwrap();
        let back = Dataset::read(&path).unwrap();
        assert_eq!(back.header, d.header);
        assert_eq!(back.topology.faces(), d.topology.faces());
        for (a, b) in back.bodies.iter().zip(&d.bodies) {
            for (p, q) in a.iter().zip(b) {
                for k in 0..3 {
                    assert!((p[k] - q[k]).abs() < 2.5e-7, "f32 storage error too large");
                }
            }
        }
        // Truncated and foreign files are clear errors, not panics.
        let bytes = std::fs::read(&path).unwrap();
        std::fs::write(&path, &bytes[..bytes.len() - 5]).unwrap();
        let e = Dataset::read(&path).unwrap_err().to_string();
        assert!(e.contains("truncated"), "{e}");
        std::fs::write(&path, b"hello, not a dataset at all").unwrap();
        let e = Dataset::read(&path).unwrap_err().to_string();
        assert!(e.contains("magic"), "{e}");
        std::fs::remove_dir_all(&dir).ok();
    }
}
