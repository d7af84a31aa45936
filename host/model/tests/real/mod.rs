//! Real pieces for integration tests and the benchmark: MakeHuman
//! bodies from tapeshape-body, measured with a tapeshape-measure set.

#![allow(dead_code)]

use tapeshape_body::{age_from_years, BodyModel, LocalChanges, Phenotype};
use tapeshape_measure::{CompiledSet, MeasurementSet};
use tapeshape_mesh::Vec3;

/// Deterministic uniform numbers in [0, 1) (test data only).
pub struct Lcg(pub u64);

impl Lcg {
    pub fn next(&mut self) -> f64 {
        self.0 = self
            .0
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((self.0 >> 11) as f64) / ((1u64 << 53) as f64)
    }
    pub fn range(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * self.next()
    }
}

/// A random adult body: phenotype within moderate ranges plus a few random
/// local changes (shape detail a small PCA does not fully span).
pub fn random_body(model: &BodyModel, rng: &mut Lcg) -> Vec<Vec3> {
    let ph = Phenotype {
        gender: rng.next(),
        age: age_from_years(rng.range(20.0, 70.0)).unwrap(),
        muscle: rng.range(0.2, 0.8),
        weight: rng.range(0.2, 0.8),
        height: rng.range(0.2, 0.8),
        proportions: rng.range(0.0, 0.5),
        cupsize: rng.range(0.3, 0.7),
        firmness: rng.range(0.3, 0.7),
        african: rng.next(),
        asian: rng.next(),
        caucasian: rng.next(),
    };
    let labels = LocalChanges::labels();
    let mut lc = LocalChanges::new();
    for _ in 0..6 {
        let i = (rng.next() * labels.len() as f64) as usize % labels.len();
        lc.set(&labels[i], rng.range(-0.4, 0.4)).unwrap();
    }
    model.generate(&ph, &lc).unwrap().vertices
}

pub struct Real {
    pub body: &'static BodyModel,
    pub set: CompiledSet,
}

pub fn setup(set: &str) -> Real {
    let body = BodyModel::shared().unwrap();
    let anatomy = tapeshape_body::anatomy::anatomy();
    let set = MeasurementSet::builtin(set)
        .unwrap()
        .compile(body.topology(), &anatomy)
        .unwrap();
    Real { body, set }
}

impl Real {
    pub fn values(&self, v: &[Vec3]) -> Vec<f64> {
        self.set
            .measure(v)
            .unwrap()
            .iter()
            .map(|m| m.value)
            .collect()
    }

    pub fn names(&self) -> Vec<String> {
        self.set
            .set()
            .definitions
            .iter()
            .map(|d| d.name.clone())
            .collect()
    }

    /// `n` random bodies and their measurements.
    pub fn population(&self, n: usize, seed: u64) -> (Vec<Vec<Vec3>>, Vec<Vec<f64>>) {
        let mut rng = Lcg(seed);
        let bodies: Vec<Vec<Vec3>> = (0..n).map(|_| random_body(self.body, &mut rng)).collect();
        let meas = bodies.iter().map(|b| self.values(b)).collect();
        (bodies, meas)
    }
}
