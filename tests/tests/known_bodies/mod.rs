//! Customers whose true body is known, for `demo_e2e.rs` and the example
//! `demo_measure` (`tests/examples/demo_measure.rs`): generated bodies held
//! out from the default model's training (population seed 2; the model was
//! trained on seed 1), their measurements on the true mesh, tape values with
//! a novice's noise, and distances between bodies.
//!
//! Included with `#[path]` by both (one copy of the rules they share); each
//! uses only part of it.
#![allow(dead_code)]

use std::sync::OnceLock;

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};
use tapeshape_estimator::Estimator;
use tapeshape_mesh::Vec3;
use tapeshape_population::{generate_population, Dataset, PopulationSettings};

/// Novice-operator noise per reading, metres: the paper's real-measurement
/// experiment cites repeatability of about 1 cm for trained measurers
/// (Gordon et al.), so a novice is at least that.
pub const NOVICE_SD_M: f64 = 0.01;

/// The seed of a body's noise: body index + this (fixed so that runs agree).
pub const NOISE_SEED: u64 = 5;

/// The embedded default model.
pub fn estimator() -> &'static Estimator {
    Estimator::default_model().expect("embedded default model")
}

/// At least `n` held-out generated bodies (seed 2, as in
/// `docs/results/predict-sreal.md`); the first 20 are generated in any case,
/// so the test and the example see the same bodies.
pub fn held_out(n: usize) -> &'static Dataset {
    static DATA: OnceLock<Dataset> = OnceLock::new();
    let d = DATA.get_or_init(|| {
        generate_population(
            &PopulationSettings {
                n: n.max(20),
                seed: 2,
                ..PopulationSettings::default()
            },
            &|_, _| {},
        )
        .expect("generating held-out bodies")
    });
    assert!(d.len() >= n);
    d
}

/// A set's values on `body` (name, metres), in set order, measured with the
/// default model's compiled operators.
pub fn set_values(body: &[Vec3], set: &str) -> Vec<(String, f64)> {
    let e = estimator();
    e.set_members(set)
        .expect("the default model carries the set")
        .into_iter()
        .map(|name| {
            let j = e.set().index_of(&name).expect("member");
            let v = e.compiled().measure_one(j, body).expect("measures").value;
            (name, v)
        })
        .collect()
}

/// The ISO 20685-1 maximum allowable error of a measurement of the default
/// model's set, millimetres.
pub fn iso_tolerance_mm(name: &str) -> f64 {
    let e = estimator();
    let j = e.set().index_of(name).expect("a measurement of the model");
    e.set().definitions[j].tolerance.mm()
}

/// Tape values in tenths of a millimetre, with optional Gaussian noise
/// `(SD metres, seed)`.
pub fn tape_values(values: &[(String, f64)], noise: Option<(f64, u64)>) -> Vec<(String, u32)> {
    let mut rng = noise.map(|(_, seed)| ChaCha8Rng::seed_from_u64(seed));
    let normal = noise.map(|(sd, _)| Normal::new(0.0, sd).expect("positive SD"));
    values
        .iter()
        .map(|(n, v)| {
            let e = match (&mut rng, &normal) {
                (Some(r), Some(d)) => d.sample(r),
                _ => 0.0,
            };
            (n.clone(), ((v + e) * 10_000.0).round() as u32)
        })
        .collect()
}

/// Mean distance (mm) between corresponding vertices.
pub fn mean_distance_mm(a: &[Vec3], b: &[Vec3]) -> f64 {
    assert_eq!(a.len(), b.len());
    let sum: f64 = a
        .iter()
        .zip(b)
        .map(|(p, q)| tapeshape_mesh::vec3::distance(*p, *q))
        .sum();
    1000.0 * sum / a.len() as f64
}

/// The model's PCA mean: the answer with no readings.
pub fn mean_shape() -> Vec<Vec3> {
    estimator()
        .file()
        .model
        .pca
        .mean
        .chunks_exact(3)
        .map(|c| [c[0], c[1], c[2]])
        .collect()
}

/// How far an estimate's measurements are from `targets` (name, metres):
/// the largest `|estimate - target|` in mm, and the largest in units of each
/// measurement's ISO 20685-1 allowable error.
pub fn worst_misfit(estimate: &[Vec3], targets: &[(String, f64)], set: &str) -> (f64, f64) {
    let got = set_values(estimate, set);
    let mut worst = (0.0f64, 0.0f64);
    for ((name, want), (name2, have)) in targets.iter().zip(&got) {
        assert_eq!(name, name2);
        let mm = (have - want).abs() * 1000.0;
        worst.0 = worst.0.max(mm);
        worst.1 = worst.1.max(mm / iso_tolerance_mm(name));
    }
    worst
}
