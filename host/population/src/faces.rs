//! Face datasets: the head region of bodies whose face local changes vary,
//! and the remapping of the template's anatomy onto that region.

use std::collections::BTreeMap;
use std::sync::Arc;

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;
use tapeshape_body::{age_from_years, BodyModel, LocalChanges, Phenotype};
use tapeshape_mesh::{Topology, Vec3};

use crate::ansur::Sex;
use crate::format::{created_by, BodyRecord, Dataset, DatasetHeader, DatasetKind, FORMAT_VERSION};
use crate::generate::PopulationSettings;
use crate::{seeded, DatasetError};

/// Regions of the local changes that shape the face.
pub const FACE_REGIONS: &[&str] = &[
    "cheek", "chin", "ears", "eyebrows", "eyes", "forehead", "head", "mouth", "nose",
];

/// Labels of the local changes in the [`FACE_REGIONS`], read from the
/// committed `local_changes.tsv` (column 3 is the region).
pub fn face_local_changes() -> Vec<String> {
    const TSV: &str = include_str!("../../body/assets/makehuman/local_changes.tsv");
    TSV.lines()
        .filter(|l| !l.starts_with('#'))
        .filter_map(|l| {
            let cols: Vec<&str> = l.split('\t').collect();
            (cols.len() > 2 && FACE_REGIONS.contains(&cols[2])).then(|| cols[1].to_string())
        })
        .collect()
}

/// The head region of the template: the `head` part's triangles, re-indexed.
/// Returns (vertex map: new -> template index, faces in new indices).
pub fn head_region(
    topology: &Topology,
    anatomy: &tapeshape_mesh::Anatomy,
) -> Result<(Vec<u32>, Vec<[u32; 3]>), DatasetError> {
    let tris = anatomy
        .parts
        .get("head")
        .ok_or_else(|| DatasetError::Settings("the template anatomy has no `head` part".into()))?;
    let mut map: Vec<u32> = tris
        .iter()
        .flat_map(|&t| topology.faces()[t as usize])
        .collect();
    map.sort_unstable();
    map.dedup();
    let faces = tris
        .iter()
        .map(|&t| {
            topology.faces()[t as usize]
                .map(|v| map.binary_search(&v).expect("vertex of a head triangle") as u32)
        })
        .collect();
    Ok((map, faces))
}

/// Remaps a template anatomy onto a sub-mesh given by `vertex_map` (new ->
/// template vertex) and the sub-mesh's faces: landmarks outside the region
/// are dropped, parts keep the triangles whose three vertices are inside.
pub fn remap_anatomy(
    anatomy: &tapeshape_mesh::Anatomy,
    template: &Topology,
    vertex_map: &[u32],
    faces: &[[u32; 3]],
) -> tapeshape_mesh::Anatomy {
    let new_of = |v: u32| vertex_map.binary_search(&v).ok().map(|i| i as u32);
    let landmarks = anatomy
        .landmarks
        .iter()
        .filter_map(|(k, &v)| Some((k.clone(), new_of(v)?)))
        .collect();
    let face_index: BTreeMap<[u32; 3], u32> = faces
        .iter()
        .enumerate()
        .map(|(i, f)| (*f, i as u32))
        .collect();
    let parts = anatomy
        .parts
        .iter()
        .map(|(k, tris)| {
            let kept: Vec<u32> = tris
                .iter()
                .filter_map(|&t| {
                    let f = template.faces()[t as usize];
                    let g = [new_of(f[0])?, new_of(f[1])?, new_of(f[2])?];
                    face_index.get(&g).copied()
                })
                .collect();
            (k.clone(), kept)
        })
        .filter(|(_, v): &(String, Vec<u32>)| !v.is_empty())
        .collect();
    tapeshape_mesh::Anatomy { landmarks, parts }
}

/// Generates `settings.n` faces: random adults (sex, age 18-90, race mix)
/// whose face local changes ([`FACE_REGIONS`]) are drawn uniformly from
/// [-0.8, 0.8], cropped to the template's head region. The dataset's
/// `vertex_map` gives each vertex's template index, so the template's
/// landmarks (and the `face7` set) carry over with [`remap_anatomy`].
pub fn generate_faces(
    settings: &PopulationSettings,
    progress: &(dyn Fn(usize, usize) + Sync),
) -> Result<Dataset, DatasetError> {
    if settings.n == 0 {
        return Err(DatasetError::Settings("--n must be at least 1".into()));
    }
    let body = BodyModel::shared()?;
    let anatomy = tapeshape_body::anatomy::anatomy();
    let (map, faces) = head_region(body.topology(), &anatomy)?;
    let labels = face_local_changes();
    let done = std::sync::atomic::AtomicUsize::new(0);
    let results: Vec<Result<(BodyRecord, Vec<Vec3>), DatasetError>> = (0..settings.n)
        .into_par_iter()
        .map(|i| {
            let mut rng = ChaCha8Rng::seed_from_u64(
                settings.seed ^ (0xd1b5_4a32_d192_ed03u64.wrapping_mul(i as u64 + 1)),
            );
            let male = rng.random_bool(settings.male_fraction);
            let years = seeded::uniform_inclusive(&mut rng, 18.0..=90.0);
            let ph = Phenotype {
                gender: if male { 0.0 } else { 1.0 },
                age: age_from_years(years).expect("adult age"),
                african: rng.random_range(0.0..1.0),
                asian: rng.random_range(0.0..1.0),
                caucasian: rng.random_range(0.0..1.0),
                muscle: rng.random_range(0.3..0.7),
                weight: rng.random_range(0.3..0.7),
                ..Phenotype::default()
            };
            let mut lc = LocalChanges::new();
            for l in &labels {
                lc.set(l, seeded::uniform_inclusive(&mut rng, -0.8..=0.8))
                    .expect("label from the list");
            }
            let mesh = body.generate(&ph, &lc)?;
            let vertices = map.iter().map(|&v| mesh.vertices[v as usize]).collect();
            progress(
                done.fetch_add(1, std::sync::atomic::Ordering::Relaxed) + 1,
                settings.n,
            );
            Ok((
                BodyRecord {
                    name: format!("face-{i:04}"),
                    sex: Some(if male { Sex::Male } else { Sex::Female }),
                    ansur_subject: None,
                    age_years: Some(years),
                    phenotype: Some(ph),
                    local_changes: lc.iter().map(|(k, v)| (k.to_string(), v)).collect(),
                    fit: None,
                    section_fields: Vec::new(),
                    source_file: None,
                },
                vertices,
            ))
        })
        .collect();
    let mut records = Vec::new();
    let mut bodies = Vec::new();
    for r in results {
        let (rec, v) = r?;
        records.push(rec);
        bodies.push(v);
    }
    let topology = Arc::new(
        Topology::new(map.len(), faces).map_err(|e| DatasetError::Settings(e.to_string()))?,
    );
    Ok(Dataset {
        header: DatasetHeader {
            format_version: FORMAT_VERSION,
            kind: DatasetKind::Faces,
            created_by: created_by(),
            n_vertices: map.len(),
            n_faces: topology.faces().len(),
            vertex_map: Some(map),
            settings: Some(settings.clone()),
            bodies: records,
        },
        topology,
        bodies,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use tapeshape_measure::MeasurementSet;

    #[test]
    fn faces_vary_only_in_the_head_and_carry_the_face_landmarks() {
        let s = PopulationSettings {
            n: 3,
            seed: 5,
            ..Default::default()
        };
        let d = generate_faces(&s, &|_, _| {}).unwrap();
        let map = d.header.vertex_map.clone().unwrap();
        assert_eq!(map.len(), d.header.n_vertices);
        assert!(
            map.len() < 13_718 / 2,
            "head region too large: {}",
            map.len()
        );
        assert_ne!(d.bodies[0], d.bodies[1]);
        let body = BodyModel::shared().unwrap();
        let anatomy = tapeshape_body::anatomy::anatomy();
        let sub = remap_anatomy(&anatomy, body.topology(), &map, d.topology.faces());
        for l in ["pronasale", "menton", "tragion_left", "exocanthion_right"] {
            assert!(
                sub.landmarks.contains_key(l),
                "{l} missing from the head region"
            );
        }
        let face7 = MeasurementSet::builtin("face7")
            .unwrap()
            .compile(&d.topology, &sub)
            .unwrap();
        let v = face7.measure(&d.bodies[0]).unwrap();
        assert_eq!(v.len(), 7);
        assert!(v.iter().all(|m| m.value > 0.01 && m.value < 0.5));
        assert!(face_local_changes().iter().any(|l| l.starts_with("nose-")));
    }
}
