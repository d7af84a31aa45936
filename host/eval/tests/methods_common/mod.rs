//! Shared fixture of the method tests: 40 generated bodies (seed 7) and 4
//! held-out ones (seed 8), measured with `paper34`, cached as dataset files
//! under the target's temporary folder so the test binaries share one
//! generation (each file written to a temporary name and renamed by
//! `Dataset::write`, so concurrent test binaries never read a partial file).

#![allow(dead_code)] // each test binary uses part of the fixture

use std::path::PathBuf;
use std::sync::{Arc, OnceLock};

use tapeshape_eval::TrainingData;
use tapeshape_measure::{CompiledSet, MeasurementSet};
use tapeshape_mesh::Vec3;
use tapeshape_population::{generate_population, Dataset, PopulationSettings};

/// The fixture: training data and held-out bodies with their measurements.
pub struct Fixture {
    /// 40 training bodies.
    pub data: TrainingData,
    /// Held-out bodies (another seed).
    pub heldout: Vec<Vec<Vec3>>,
    /// Their measurements (metres).
    pub heldout_measurements: Vec<Vec<f64>>,
    /// The training dataset (records with phenotypes).
    pub dataset: Dataset,
}

fn cached(n: usize, seed: u64) -> Dataset {
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR"));
    let path = dir.join(format!("methods-fixture-n{n}-seed{seed}.tsd"));
    if let Ok(d) = Dataset::read(&path) {
        if d.len() == n {
            return d;
        }
    }
    let d = generate_population(
        &PopulationSettings {
            n,
            seed,
            ..PopulationSettings::default()
        },
        &|_, _| {},
    )
    .expect("generate the fixture population");
    d.write(&path).expect("cache the fixture");
    d
}

/// Measures `body` with every measurement of `set` (metres).
pub fn measure(set: &CompiledSet, body: &[Vec3]) -> Vec<f64> {
    set.measure(body)
        .expect("measure")
        .iter()
        .map(|m| m.value)
        .collect()
}

/// The shared fixture.
pub fn fixture() -> &'static Fixture {
    static F: OnceLock<Fixture> = OnceLock::new();
    F.get_or_init(|| {
        let train = cached(40, 7);
        let held = cached(4, 8);
        let anatomy = tapeshape_body::anatomy::anatomy();
        let compiled = Arc::new(
            MeasurementSet::builtin("paper34")
                .expect("paper34")
                .compile(&train.topology, &anatomy)
                .expect("compile"),
        );
        let measurements = train.bodies.iter().map(|b| measure(&compiled, b)).collect();
        let heldout_measurements = held.bodies.iter().map(|b| measure(&compiled, b)).collect();
        Fixture {
            data: TrainingData {
                meshes: train.bodies.clone(),
                measurements,
                compiled,
                topology: train.topology.clone(),
            },
            heldout: held.bodies.clone(),
            heldout_measurements,
            dataset: train,
        }
    })
}

/// Mean absolute error (mm) between `targets` and the same measurements of `body`.
pub fn mean_error_mm(set: &CompiledSet, body: &[Vec3], targets: &[f64]) -> f64 {
    let got = measure(set, body);
    got.iter()
        .zip(targets)
        .map(|(a, b)| (a - b).abs())
        .sum::<f64>()
        / targets.len() as f64
        * 1000.0
}

/// The mean training body (vertex-wise).
pub fn mean_body(data: &TrainingData) -> Vec<Vec3> {
    let n = data.meshes.len() as f64;
    let v = data.meshes[0].len();
    let mut mean = vec![[0.0; 3]; v];
    for m in &data.meshes {
        for (a, b) in mean.iter_mut().zip(m) {
            for c in 0..3 {
                a[c] += b[c] / n;
            }
        }
    }
    mean
}

/// All measurements of training body `i` as given targets.
pub fn all_given(row: &[f64]) -> Vec<Option<f64>> {
    row.iter().map(|&x| Some(x)).collect()
}
