//! The readings a prediction fits: targets checked once, in millimetres,
//! with their energy weights.
//!
//! A reading's energy terms are weighted by
//! `c = (reference_tolerance / tolerance)^2` (1 for a reading without
//! tolerance): since `(l^2 - l_t^2)^2 ~ 4 l^2 (l - l_t)^2`, this is the
//! Gaussian log-likelihood weighting of each reading's error.

use super::settings::ReadingsConfig;
use super::Target;
use crate::{ModelError, Result, ShapeModel, MM_PER_M};

/// One given reading, as the stages use it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Reading {
    /// Index of the measurement in the model's order.
    pub index: usize,
    /// Target, mm.
    pub target_mm: f64,
    /// Energy weight `(reference / tolerance)^2` (1 without tolerance).
    pub weight: f64,
    /// The tolerance given with it, metres.
    pub tolerance: Option<f64>,
    /// A soft target ([`Target::soft`]), not a reading.
    pub soft: bool,
}

/// The given readings, checked ([`ShapeModel::readings`]), in the model's
/// order of measurements.
#[derive(Debug, Clone, PartialEq)]
pub struct Readings {
    given: Vec<Reading>,
    n_measurements: usize,
    reference_tolerance: f64,
}

impl Readings {
    /// The readings, in the model's order.
    pub fn iter(&self) -> std::slice::Iter<'_, Reading> {
        self.given.iter()
    }

    /// Number of readings given.
    pub fn len(&self) -> usize {
        self.given.len()
    }

    /// Whether none is given (never, for a checked set).
    pub fn is_empty(&self) -> bool {
        self.given.is_empty()
    }

    /// The model's indices of the given measurements, in order.
    pub fn indices(&self) -> Vec<usize> {
        self.given.iter().map(|g| g.index).collect()
    }

    /// Whether every measurement of the model is given, none with a
    /// tolerance (then the start is the paper's feature analysis).
    pub fn complete_and_exact(&self) -> bool {
        self.given.len() == self.n_measurements && self.given.iter().all(|g| g.tolerance.is_none())
    }

    /// Whether any reading has a tolerance.
    pub fn any_tolerance(&self) -> bool {
        self.given.iter().any(|g| g.tolerance.is_some())
    }

    /// The reference tolerance (metres) the weights were computed with.
    pub fn reference_tolerance(&self) -> f64 {
        self.reference_tolerance
    }

    /// The same readings with other targets (mm), one per reading in order
    /// (step 2 keeps a doubtful reading's step-1 value).
    pub(crate) fn with_targets(&self, targets_mm: impl Iterator<Item = f64>) -> Self {
        let mut out = self.clone();
        for (g, t) in out.given.iter_mut().zip(targets_mm) {
            g.target_mm = t;
        }
        out
    }
}

impl ShapeModel {
    /// Checks `targets` (one entry per model measurement, `None` where not
    /// given; metres) for a prediction weighted by `config`.
    ///
    /// Errors on a wrong count, a non-positive or non-finite value or
    /// tolerance, a value that looks like millimetres (over 5 m), or no
    /// target at all.
    pub fn readings(
        &self,
        targets: &[Option<Target>],
        config: &ReadingsConfig,
    ) -> Result<Readings> {
        let m = self.n_measurements();
        if targets.len() != m {
            return Err(ModelError::InvalidInput(format!(
                "{} targets given, the model has {m} measurements ({})",
                targets.len(),
                self.measurement_names.join(", ")
            )));
        }
        let mut given = Vec::new();
        for (j, t) in targets.iter().enumerate() {
            let Some(t) = t else { continue };
            let name = &self.measurement_names[j];
            if !(t.value.is_finite() && t.value > 0.0) {
                return Err(ModelError::InvalidInput(format!(
                    "target '{name}' is {}: a length in metres must be positive and finite",
                    t.value
                )));
            }
            if t.value > 5.0 {
                return Err(ModelError::InvalidInput(format!(
                    "target '{name}' is {} m, more than any body length: targets are metres (was it given in mm or cm?)",
                    t.value
                )));
            }
            let weight = match t.tolerance {
                None => 1.0,
                Some(tol) if tol.is_finite() && tol > 0.0 => {
                    (config.reference_tolerance / tol).powi(2)
                }
                Some(tol) => {
                    return Err(ModelError::InvalidInput(format!(
                        "tolerance of '{name}' is {tol}: it must be positive and finite (metres)"
                    )))
                }
            };
            given.push(Reading {
                index: j,
                target_mm: t.value * MM_PER_M,
                weight,
                tolerance: t.tolerance,
                soft: t.soft,
            });
        }
        if given.is_empty() {
            return Err(ModelError::InvalidInput(
                "no measurements given: at least one target is needed to predict a body".into(),
            ));
        }
        Ok(Readings {
            given,
            n_measurements: m,
            reference_tolerance: config.reference_tolerance,
        })
    }
}
