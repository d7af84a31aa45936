//! Model file: round trip, and every kind of damage is a clear error.

mod common;

use common::*;
use tapeshape_model::file::{FORMAT_VERSION, MAGIC};
use tapeshape_model::{MeasurementSetText, ModelError, ModelFile, Provenance, TemplateInfo};

fn model_file() -> ModelFile {
    let model = train(30, 21);
    let topo = topology();
    let mut anatomy = tapeshape_mesh::Anatomy::default();
    anatomy.landmarks.insert("top_front".into(), vid(NZ - 1, 4));
    anatomy
        .parts
        .insert("ring5".into(), (0..NT as u32).collect());
    ModelFile {
        provenance: Provenance {
            dataset: "synthetic tubes".into(),
            trained_by: "tapeshape-model tests".into(),
            created: "2026-01-01T00:00:00Z".into(),
            notes: "seed 21".into(),
        },
        template: TemplateInfo {
            n_vertices: topo.n_vertices(),
            faces: topo.faces().to_vec(),
            anatomy,
        },
        measurement_set: MeasurementSetText {
            name: "tubes7".into(),
            format: "toml".into(),
            text: "# seven tube measurements\n".into(),
        },
        model,
    }
}

fn tmp(name: &str) -> std::path::PathBuf {
    let dir = std::env::temp_dir().join(format!("tapeshape-model-test-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir.join(name)
}

#[test]
fn save_load_round_trip_is_exact() {
    let f = model_file();
    let path = tmp("round.tsm");
    f.save(&path).unwrap();
    assert!(
        !path.with_extension("tsm.tmp").exists(),
        "temporary file left behind"
    );
    let g = ModelFile::load(&path).unwrap();
    assert_eq!(g.provenance, f.provenance);
    assert_eq!(g.template, f.template);
    assert_eq!(g.measurement_set, f.measurement_set);
    assert_eq!(g.model.pca.mean, f.model.pca.mean);
    assert_eq!(g.model.pca.basis(), f.model.pca.basis());
    assert_eq!(g.model.pca.sigma, f.model.pca.sigma);
    assert_eq!(g.model.feature_map.b, f.model.feature_map.b);
    assert_eq!(g.model.joint.cov, f.model.joint.cov);
    assert_eq!(g.model.measurement_names, f.model.measurement_names);
    // Same model, same prediction.
    let mut s = 3;
    let body = tube(&random_params(&mut s));
    let targets: Vec<_> = measure_all(&body)
        .into_iter()
        .map(|v| Some(tapeshape_model::Target::exact(v)))
        .collect();
    let settings = tapeshape_model::PredictConfig::default();
    let topo = topology();
    let a = f
        .model
        .predict(&targets, &TubeMeasurer, &topo, &settings)
        .unwrap();
    let b = g
        .model
        .predict(&targets, &TubeMeasurer, &topo, &settings)
        .unwrap();
    assert_eq!(a.vertices, b.vertices);
    std::fs::remove_file(&path).unwrap();
}

fn expect_file_error(bytes: &[u8], needle: &str) {
    match ModelFile::from_bytes(bytes, "x.tsm") {
        Err(ModelError::File { message, .. }) => {
            assert!(message.contains(needle), "'{message}' lacks '{needle}'")
        }
        Err(e) => panic!("wrong error kind: {e}"),
        Ok(_) => panic!("damaged file accepted"),
    }
}

#[test]
fn damaged_files_are_clear_errors() {
    let bytes = model_file().to_bytes().unwrap();
    assert_eq!(&bytes[..8], &MAGIC);
    assert!(ModelFile::from_bytes(&bytes, "ok").is_ok());

    expect_file_error(b"v 0 0 0\nf 1 2 3\n", "not a tapeshape model");
    expect_file_error(&[], "not a tapeshape model");

    let mut newer = bytes.clone();
    newer[8..12].copy_from_slice(&(FORMAT_VERSION + 1).to_le_bytes());
    expect_file_error(&newer, "format version");

    expect_file_error(&bytes[..bytes.len() / 2], "truncated");

    let mut flipped = bytes.clone();
    let mid = 20 + (bytes.len() - 24) / 2;
    flipped[mid] ^= 0x40;
    expect_file_error(&flipped, "checksum");

    let mut longer = bytes.clone();
    longer.push(0);
    expect_file_error(&longer, "trailing");

    let missing = ModelFile::load(std::path::Path::new("/nonexistent/dir/model.tsm"));
    assert!(matches!(missing, Err(ModelError::Io { .. })));
}

#[test]
fn inconsistent_contents_are_refused() {
    let mut f = model_file();
    f.template.n_vertices += 1;
    let bytes = f.to_bytes().unwrap();
    expect_file_error(&bytes, "vertices");

    let mut g = model_file();
    g.model.pca.basis_mut().pop();
    expect_file_error(&g.to_bytes().unwrap(), "inconsistent model");

    let mut h = model_file();
    h.model.joint.mean[0] = f64::NAN;
    expect_file_error(&h.to_bytes().unwrap(), "NaN");
}
