//! The generator reproduces the 8 reference bodies made by anny 0.6.2
//! (copied from the MakeHuman pack's `reference/`, see
//! `tests/data/reference/ORIGIN.md`) to within 1e-5 m, after the same frame
//! conversion: anny (X, Y, Z) -> station (-X, -Y, Z), then z shifted so the
//! lowest skin vertex is at z = 0.

use tapeshape_body::{BodyModel, LocalChanges, Phenotype};

#[derive(serde::Deserialize)]
struct Reference {
    name: String,
    phenotype: Phenotype,
    local_changes: LocalChanges,
    stats_m: Stats,
}

#[derive(serde::Deserialize)]
struct Stats {
    stature_zmax_minus_zmin: f64,
}

const N_BODY: usize = 13_348;

fn reference(n: usize) -> (Reference, Vec<[f64; 3]>) {
    let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/data/reference");
    let json = std::fs::read_to_string(format!("{dir}/body{n}.json")).unwrap();
    let r: Reference = serde_json::from_str(&json).unwrap();
    let bytes = std::fs::read(format!("{dir}/body{n}.f32")).unwrap();
    assert_eq!(bytes.len(), 13_718 * 12);
    let anny: Vec<[f64; 3]> = bytes
        .chunks_exact(12)
        .map(|c| {
            let f = |k: usize| f32::from_le_bytes(c[4 * k..4 * k + 4].try_into().unwrap()) as f64;
            [f(0), f(1), f(2)]
        })
        .collect();
    let station: Vec<[f64; 3]> = anny.iter().map(|p| [-p[0], -p[1], p[2]]).collect();
    let z0 = station[..N_BODY]
        .iter()
        .map(|p| p[2])
        .fold(f64::INFINITY, f64::min);
    (
        r,
        station
            .into_iter()
            .map(|p| [p[0], p[1], p[2] - z0])
            .collect(),
    )
}

#[test]
fn all_eight_reference_bodies_within_1e_5_m() {
    let model = BodyModel::shared().unwrap();
    for n in 1..=8 {
        let (r, expected) = reference(n);
        let body = model.generate(&r.phenotype, &r.local_changes).unwrap();
        let max_err = body
            .vertices
            .iter()
            .zip(&expected)
            .flat_map(|(a, b)| (0..3).map(move |k| (a[k] - b[k]).abs()))
            .fold(0.0, f64::max);
        println!("body{n} ({}): max |error| = {max_err:.3e} m", r.name);
        assert!(
            max_err < 1e-5,
            "body{n} ({}): max error {max_err} m",
            r.name
        );
        let bb = body.bounding_box().unwrap();
        let stature = bb.max[2] - bb.min[2];
        assert!(
            (stature - r.stats_m.stature_zmax_minus_zmin).abs() < 1e-5,
            "body{n}: stature {stature} vs {}",
            r.stats_m.stature_zmax_minus_zmin
        );
        assert_eq!(bb.min[2], 0.0, "feet at z = 0");
    }
}

#[test]
fn the_reference_with_local_changes_really_uses_them() {
    // Guards the test above: body 8 without its local changes is far off.
    let model = BodyModel::shared().unwrap();
    let (r, expected) = reference(8);
    assert!(r.local_changes.len() >= 20);
    let plain = model.generate(&r.phenotype, &LocalChanges::new()).unwrap();
    let max_err = plain
        .vertices
        .iter()
        .zip(&expected)
        .flat_map(|(a, b)| (0..3).map(move |k| (a[k] - b[k]).abs()))
        .fold(0.0, f64::max);
    assert!(max_err > 1e-3, "{max_err}");
}
