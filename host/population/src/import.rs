//! Import of a user's own registered meshes (OBJ or PLY, one topology) as a
//! dataset.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use tapeshape_mesh::Mesh;

use crate::format::{created_by, BodyRecord, Dataset, DatasetHeader, DatasetKind, FORMAT_VERSION};
use crate::DatasetError;

/// Reads an OBJ or PLY mesh, chosen by extension (case-insensitive).
pub fn read_mesh(path: &Path) -> Result<Mesh, DatasetError> {
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase);
    let opts = tapeshape_mesh::io::ReadOptions::default();
    let res = match ext.as_deref() {
        Some("obj") => tapeshape_mesh::io::read_obj(path, opts),
        Some("ply") => tapeshape_mesh::io::read_ply(path, opts),
        _ => {
            return Err(DatasetError::Import {
                path: path.to_path_buf(),
                message: "not an .obj or .ply file".into(),
            })
        }
    };
    res.map_err(|e| DatasetError::Import {
        path: path.to_path_buf(),
        message: e.to_string(),
    })
}

/// Imports every `.obj` / `.ply` file in `dir` (sorted by file name) as a
/// dataset of registered meshes. All must share one topology (same vertex
/// count and the same triangles in the same order); the first file that
/// differs is named in the error. Units are taken as metres, station frame.
pub fn import_dir(dir: &Path) -> Result<Dataset, DatasetError> {
    let io = |source| DatasetError::Io {
        path: dir.to_path_buf(),
        source,
    };
    let mut files: Vec<PathBuf> = std::fs::read_dir(dir)
        .map_err(io)?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| {
            p.extension()
                .and_then(|e| e.to_str())
                .is_some_and(|e| e.eq_ignore_ascii_case("obj") || e.eq_ignore_ascii_case("ply"))
        })
        .collect();
    files.sort();
    if files.is_empty() {
        return Err(DatasetError::Import {
            path: dir.to_path_buf(),
            message: "no .obj or .ply files in this folder".into(),
        });
    }
    let first = read_mesh(&files[0])?;
    let mut records = Vec::new();
    let mut bodies = Vec::new();
    for (i, f) in files.iter().enumerate() {
        let m = if i == 0 { first.clone() } else { read_mesh(f)? };
        if m.vertices.len() != first.vertices.len() {
            return Err(DatasetError::Import {
                path: f.clone(),
                message: format!(
                    "{} vertices, but {} has {}: every mesh must be registered to the same topology",
                    m.vertices.len(),
                    files[0].display(),
                    first.vertices.len()
                ),
            });
        }
        if let Some(k) = (0..first.faces().len().max(m.faces().len()))
            .find(|&k| first.faces().get(k) != m.faces().get(k))
        {
            return Err(DatasetError::Import {
                path: f.clone(),
                message: format!(
                    "triangle {k} differs from {} ({} vs {} triangles): every mesh must share the same triangles in the same order",
                    files[0].display(),
                    m.faces().len(),
                    first.faces().len()
                ),
            });
        }
        if let Some(v) = m
            .vertices
            .iter()
            .position(|p| !p.iter().all(|c| c.is_finite()))
        {
            return Err(DatasetError::Import {
                path: f.clone(),
                message: format!("vertex {v} is not finite"),
            });
        }
        records.push(BodyRecord {
            name: f
                .file_stem()
                .map(|s| s.to_string_lossy().into_owned())
                .unwrap_or_else(|| format!("mesh-{i}")),
            sex: None,
            ansur_subject: None,
            age_years: None,
            phenotype: None,
            local_changes: BTreeMap::new(),
            fit: None,
            section_fields: Vec::new(),
            source_file: Some(f.display().to_string()),
        });
        bodies.push(m.vertices);
    }
    let topology = first.topology.clone();
    Ok(Dataset {
        header: DatasetHeader {
            format_version: FORMAT_VERSION,
            kind: DatasetKind::Imported,
            created_by: created_by(),
            n_vertices: topology.n_vertices(),
            n_faces: topology.faces().len(),
            vertex_map: None,
            settings: None,
            bodies: records,
        },
        topology,
        bodies,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use tapeshape_body::BodyModel;

    #[test]
    fn import_checks_topology_and_names_the_file() {
        let body = BodyModel::shared().unwrap();
        let dir = std::env::temp_dir().join(format!("tapeshape-import-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let a = body.template();
        let mut b = a.clone();
        b.vertices.iter_mut().for_each(|p| p[0] *= 1.1);
        tapeshape_mesh::io::write_obj(&a, dir.join("a.obj")).unwrap();
        tapeshape_mesh::io::write_ply(&b, dir.join("b.ply"), Default::default()).unwrap();
        let d = import_dir(&dir).unwrap();
        assert_eq!(d.len(), 2);
        assert_eq!(d.header.bodies[1].name, "b");
        for (p, q) in d.bodies[1].iter().zip(&b.vertices) {
            assert!((p[0] - q[0]).abs() < 1e-9);
        }
        // A mesh with other triangles is rejected, naming that file.
        let other = Mesh::from_faces(
            vec![[0.0; 3], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]],
            vec![[0, 1, 2]],
        )
        .unwrap();
        tapeshape_mesh::io::write_obj(&other, dir.join("c.obj")).unwrap();
        let e = import_dir(&dir).unwrap_err().to_string();
        assert!(e.contains("c.obj"), "{e}");
        std::fs::remove_dir_all(&dir).ok();
        let empty =
            std::env::temp_dir().join(format!("tapeshape-import-empty-{}", std::process::id()));
        std::fs::create_dir_all(&empty).unwrap();
        assert!(import_dir(&empty)
            .unwrap_err()
            .to_string()
            .contains("no .obj or .ply"));
        std::fs::remove_dir_all(&empty).ok();
    }
}
