//! The input checks: what an operator entered, judged against real people
//! and the training population before the optimiser sees it (see the crate
//! docs for the rules), the one unit-slip rule and the one refusal rule.

use serde::{Deserialize, Serialize};
use tapeshape_measure::MeasurementSet;
use tapeshape_model::regress::JointGaussian;

use tapeshape_population::ansur::Sex;

use crate::warning::{AgainstOthers, OutOfRange, Warning};
use crate::{Estimator, Input, Inputs, Length, PredictError, Unit};

/// A reading further than this many training SDs from the training mean is
/// refused (as a unit slip when another unit explains it).
pub const MARGINAL_Z_ERROR: f64 = 6.0;
/// A reading further than this many SDs from what the other readings predict
/// is refused as a contradiction.
pub const CONDITIONAL_Z_ERROR: f64 = 6.0;
/// ... and above this it is a warning.
pub const CONDITIONAL_Z_WARN: f64 = 4.0;
/// A reading this many SDs or more from its prediction may be a unit slip
/// ([`unit_slip`]; 3 SD: about 1 honest reading in 370 under a Gaussian).
pub const SLIP_SUSPECT_Z: f64 = 3.0;
/// A suspect reading is a unit slip when its number, read in another unit,
/// lies within this many SDs of the same prediction (95 % of honest
/// readings do).
pub const SLIP_Z: f64 = 2.0;

/// Even a reading the operator kept is refused when it is further than this
/// many SDs from real people (or the training population): no adult is
/// (the tallest and the heaviest people on record are within about 15 SD).
pub const BEYOND_HUMAN_Z: f64 = 25.0;
/// ... or longer than this (metres): no human girth or length is.
pub const BEYOND_HUMAN_M: f64 = 3.5;

/// The reading's number read in another unit fits the prediction.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct UnitSlip {
    /// The unit that makes the number typical.
    pub unit: Unit,
    /// The number as entered or shown (in the reading's own unit).
    pub number: f64,
    /// The number read in `unit`, metres.
    pub metres: f64,
    /// Its z-score under the same prediction.
    pub z: f64,
}

/// The one unit-slip rule, for the estimate's checks and the station's
/// capture-time check alike: `reading` (its number in its unit, and
/// metres) is a slip when it lies more than [`SLIP_SUSPECT_Z`] SDs from the
/// prediction `mean` +/- `sd` (metres) and its number read in another unit
/// lies within [`SLIP_Z`] of it; the closest such unit is returned. `None`:
/// no slip (also for an `sd` that is not positive).
pub fn unit_slip(reading: &Length, mean: f64, sd: f64) -> Option<UnitSlip> {
    if sd.is_nan() || sd <= 0.0 || ((reading.metres - mean) / sd).abs() <= SLIP_SUSPECT_Z {
        return None;
    }
    Unit::ALL
        .iter()
        .filter(|&&u| u != reading.unit)
        .map(|&u| {
            let metres = reading.number * u.metres();
            UnitSlip {
                unit: u,
                number: reading.number,
                metres,
                z: (metres - mean) / sd,
            }
        })
        .filter(|s| s.z.abs() <= SLIP_Z)
        .min_by(|a, b| a.z.abs().total_cmp(&b.z.abs()))
}

/// The one refusal rule: would the estimate refuse a reading `z` SDs from
/// its prediction under `reference`, and `z_training` SDs under the
/// training population, given `conditioned_on` other readings?
///
/// Alone (`conditioned_on == 0`, the marginal) it is refused beyond
/// [`MARGINAL_Z_ERROR`] under both; given others, beyond
/// [`CONDITIONAL_Z_ERROR`] under both, and only when the prediction is real
/// people's (a reading without an ANSUR column is only warned about, see the
/// crate docs for why both references must agree).
pub fn refused(z: f64, z_training: f64, conditioned_on: usize, reference: Reference) -> bool {
    let limit = if conditioned_on == 0 {
        MARGINAL_Z_ERROR
    } else if reference == Reference::RealPeople {
        CONDITIONAL_Z_ERROR
    } else {
        return false;
    };
    z.abs() > limit && z_training.abs() > limit
}

/// One reading's check against the training statistics.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct InputCheck {
    /// Measurement name.
    pub name: String,
    /// Value, mm.
    pub value_mm: f64,
    /// The unit the value was read in, and whether it was typed.
    pub unit: Unit,
    /// False when a bare number was read in the default unit.
    pub unit_typed: bool,
    /// Tolerance given, mm.
    pub tolerance_mm: Option<f64>,
    /// Training mean and SD of the measurement, mm.
    pub training_mean_mm: f64,
    /// Training SD, mm.
    pub training_sd_mm: f64,
    /// `(value - mean) / sd` under the training marginal.
    pub z: f64,
    /// What the other readings predict for it (mean, mm), if any others were given.
    pub predicted_mm: Option<f64>,
    /// SD of that prediction with reading errors added, mm.
    pub predicted_sd_mm: Option<f64>,
    /// `(value - predicted) / predicted_sd`.
    pub conditional_z: Option<f64>,
    /// The checks would refuse it, but the operator kept it
    /// ([`Inputs::kept`]): estimated with a warning.
    #[serde(default)]
    pub kept_unusual: bool,
}

/// Which population a reading's prediction comes from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum Reference {
    /// Real people: ANSUR II train split (the reading follows an ANSUR column).
    RealPeople,
    /// The model's training population (the joint Gaussian of the model).
    Training,
}

/// What other readings predict for one measurement ([`Estimator::predict_reading`]).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct ReadingPrediction {
    /// Predicted value, metres.
    pub mean: f64,
    /// SD of the prediction with the reading's own error added, metres.
    pub sd: f64,
    /// The population the prediction comes from.
    pub reference: Reference,
    /// Number of other readings it is conditioned on (0: the marginal).
    pub conditioned_on: usize,
    /// The same prediction under the training population (mean, SD with the
    /// reading's error, metres): [`Estimator::check`] refuses a reading only when
    /// both references find it far off.
    pub training: (f64, f64),
}

impl ReadingPrediction {
    /// `(value - mean) / sd` for `value` in metres.
    pub fn z(&self, value: f64) -> f64 {
        (value - self.mean) / self.sd
    }

    /// Whether the estimate would refuse `value` (metres) among the readings
    /// this prediction was conditioned on: [`refused`] under this
    /// prediction and the training population's.
    pub fn refuses(&self, value: f64) -> bool {
        let z_training = (value - self.training.0) / self.training.1;
        refused(
            self.z(value),
            z_training,
            self.conditioned_on,
            self.reference,
        )
    }
}

/// Statistics of real people (ANSUR II **train split**, both sexes) for the
/// model's measurements that follow an ANSUR column: the reference for
/// "could a person have these readings". The generated population's
/// relations between measurements are much tighter than real people's (a
/// generator with few degrees of freedom), so judging a real customer's
/// readings by them refuses real people (measured: every ANSUR test-split
/// subject with the full ansur set was refused).
///
/// The statistics are a [`JointGaussian`] of the ANSUR columns alone (no
/// weights), so a reading's prediction from the others is the model's one
/// Gaussian conditional, [`JointGaussian::conditional`].
#[derive(Debug, Clone, serde::Serialize, serde::Deserialize)]
pub(crate) struct RealStats {
    /// Per model measurement: its index in `joint`, if it has an ANSUR column.
    row: Vec<Option<usize>>,
    /// Means (metres) and covariance (metres^2) of those columns.
    joint: JointGaussian,
}

impl RealStats {
    /// No measurement has real-people statistics (no ANSUR data, or too few
    /// complete subjects): every reading is judged by the training population.
    fn none(set: &MeasurementSet) -> RealStats {
        RealStats {
            row: vec![None; set.len()],
            joint: JointGaussian {
                n_measurements: 0,
                n_weights: 0,
                mean: Vec::new(),
                cov: Vec::new(),
            },
        }
    }

    /// The statistics of the train split's people of `sex` (`None`: both).
    pub(crate) fn compute(set: &MeasurementSet, sex: Option<Sex>) -> RealStats {
        let Ok(ansur) = tapeshape_population::ansur::Ansur::get() else {
            return RealStats::none(set);
        };
        let mut row = vec![None; set.len()];
        let mut columns: Vec<&str> = Vec::new();
        for (j, d) in set.definitions.iter().enumerate() {
            if let Some(c) = d.ansur.as_deref() {
                if ansur.check_column(c).is_ok() {
                    row[j] = Some(columns.len());
                    columns.push(c);
                }
            }
        }
        let subjects: Vec<&tapeshape_population::ansur::Subject> = ansur
            .subjects(sex, tapeshape_population::ansur::Split::Train)
            .filter(|s| columns.iter().all(|c| s.dim(c).is_some_and(f64::is_finite)))
            .collect();
        if subjects.len() < columns.len() + 2 {
            return RealStats::none(set);
        }
        let (mean, sd, corr) = tapeshape_population::ansur::statistics(&subjects, &columns);
        let k = columns.len();
        let cov = (0..k * k)
            .map(|i| {
                let (a, b) = (i / k, i % k);
                corr[a][b] * sd[a] * sd[b]
            })
            .collect();
        RealStats {
            row,
            joint: JointGaussian {
                n_measurements: k,
                n_weights: 0,
                mean,
                cov,
            },
        }
    }

    #[cfg(test)]
    pub(crate) fn row_for_tests(&self) -> &[Option<usize>] {
        &self.row
    }

    #[cfg(test)]
    pub(crate) fn joint_for_tests(&self) -> &JointGaussian {
        &self.joint
    }

    /// The row of model measurement `j`, if it follows an ANSUR column.
    pub(crate) fn row(&self, j: usize) -> Option<usize> {
        self.row.get(j).copied().flatten()
    }

    /// Whether no measurement has statistics.
    pub(crate) fn is_empty(&self) -> bool {
        self.joint.n_measurements == 0
    }

    /// Conditional means (metres) and variances (metres^2) of `rows` given
    /// `observed` (row, value, noise variance); `None` as for
    /// [`RealStats::conditional`].
    pub(crate) fn conditional_many(
        &self,
        rows: &[usize],
        observed: &[(usize, f64, f64)],
    ) -> Option<(Vec<f64>, Vec<f64>)> {
        let c = self.joint.conditional(rows, observed).ok()?;
        Some((
            c.mean.iter().copied().collect(),
            (0..rows.len()).map(|i| c.cov[(i, i)]).collect(),
        ))
    }

    /// Mean and SD (metres) of row `r`.
    fn marginal(&self, r: usize) -> (f64, f64) {
        let k = self.joint.n_measurements;
        (
            self.joint.mean[r],
            self.joint.cov[r * k + r].max(0.0).sqrt(),
        )
    }

    /// Conditional mean and variance (metres, metres^2) of row `a` given
    /// `observed` (row, value, noise variance), by
    /// [`JointGaussian::conditional`]. `None` if even its ridge leaves the
    /// observed covariance singular: the caller then judges by the training
    /// population.
    fn conditional(&self, a: usize, observed: &[(usize, f64, f64)]) -> Option<(f64, f64)> {
        let c = self.joint.conditional(&[a], observed).ok()?;
        Some((c.mean[0], c.cov[(0, 0)].max(0.0)))
    }
}

impl Estimator {
    fn unknown(&self, name: &str) -> PredictError {
        // A group total (`tapeshape measure` prints e.g. the knee loop's sum
        // as `knee_circumference_left`) is derived, not a measurement.
        if let Some((_, members)) = self.set.groups().into_iter().find(|(g, _)| g == name) {
            let names: Vec<&str> = members
                .iter()
                .map(|&i| self.set.definitions[i].name.as_str())
                .collect();
            return PredictError::UnknownMeasurement {
                name: name.to_string(),
                suggestion: format!(
                    ": it is a derived total (the sum of {} measurements); give those instead: {}",
                    names.len(),
                    names.join(", ")
                ),
            };
        }
        let close = tapeshape_common::suggest::did_you_mean(
            name,
            self.set.definitions.iter().map(|d| d.name.as_str()),
        );
        let suggestion = if close.is_empty() {
            format!(
                "; the model knows {} measurements (`tapeshape predict --list` shows them)",
                self.set.len()
            )
        } else {
            close
        };
        PredictError::UnknownMeasurement {
            name: name.to_string(),
            suggestion,
        }
    }

    /// Checks `inputs` against the model (names, values, units, consistency).
    /// Returns the per-reading checks and warnings, or the first problem as an
    /// error (see the module docs).
    pub fn check(&self, inputs: &Inputs) -> Result<(Vec<InputCheck>, Vec<Warning>), PredictError> {
        if inputs.readings.is_empty() {
            return Err(PredictError::Input(
                "no measurements given: give at least one, e.g. --measure stature=176.5cm".into(),
            ));
        }
        if let Some(k) = inputs
            .kept
            .iter()
            .find(|k| !inputs.readings.iter().any(|r| r.name == **k))
        {
            return Err(PredictError::Input(format!(
                "'{k}' is to be kept but no such reading was given: keep only measurements that were entered"
            )));
        }
        let mut warnings = Vec::new();
        let mut checks = Vec::new();
        let mut index = Vec::new();
        let bare: Vec<&str> = inputs
            .readings
            .iter()
            .filter(|r| !r.value.unit_typed)
            .map(|r| r.name.as_str())
            .collect();
        if !bare.is_empty() {
            warnings.push(Warning::NoUnit {
                measurements: bare.iter().map(|s| s.to_string()).collect(),
                unit: inputs
                    .readings
                    .iter()
                    .find(|r| !r.value.unit_typed)
                    .map_or(Unit::Cm, |r| r.value.unit),
            });
        }
        for r in &inputs.readings {
            let j = self
                .set
                .index_of(&r.name)
                .ok_or_else(|| self.unknown(&r.name))?;
            let v = r.value.metres;
            let shown = format!("{} {}", r.value.number, r.value.unit.symbol());
            if !v.is_finite() {
                return Err(PredictError::BadValue(format!(
                    "{} is {shown}: give a number",
                    r.name
                )));
            }
            if v <= 0.0 {
                return Err(PredictError::BadValue(format!(
                    "{} is {shown}: a length must be positive; leave a measurement out rather than enter 0",
                    r.name
                )));
            }
            if let Some(t) = r.tolerance {
                if !(t.is_finite() && t > 0.0) {
                    return Err(PredictError::BadValue(format!(
                        "the tolerance of {} is {t} m: it must be a positive length",
                        r.name
                    )));
                }
            }
            let real = self.real_stats(inputs.sex);
            let (mean, sd) = match real.row[j] {
                Some(r) => real.marginal(r),
                None => self.stats[j],
            };
            let z = if sd > 0.0 { (v - mean) / sd } else { 0.0 };
            // Refused only when the training population agrees: some
            // measurements of generated bodies differ systematically from
            // ANSUR's, and the model can still fit what it was trained on.
            let (tm, ts) = self.stats[j];
            let z_train = if ts > 0.0 { (v - tm) / ts } else { 0.0 };
            let reference = match real.row[j] {
                Some(_) => Reference::RealPeople,
                None => Reference::Training,
            };
            let kept = inputs.kept.contains(&r.name);
            let mut kept_unusual = false;
            if refused(z, z_train, 0, reference) {
                let msg = self.out_of_range(r, mean, sd, z);
                if !kept || z.abs().min(z_train.abs()) > BEYOND_HUMAN_Z || v > BEYOND_HUMAN_M {
                    return Err(PredictError::OutOfPopulation {
                        reading: Box::new(msg),
                        kept,
                    });
                }
                kept_unusual = true;
                warnings.push(Warning::KeptOutOfRange(msg));
            }
            index.push(j);
            checks.push(InputCheck {
                name: r.name.clone(),
                value_mm: v * 1000.0,
                unit: r.value.unit,
                unit_typed: r.value.unit_typed,
                tolerance_mm: r.tolerance.map(|t| t * 1000.0),
                training_mean_mm: mean * 1000.0,
                training_sd_mm: sd * 1000.0,
                z,
                predicted_mm: None,
                predicted_sd_mm: None,
                conditional_z: None,
                kept_unusual,
            });
        }
        // Each reading against what the others predict. Each reading's own
        // error (its tolerance, else its ISO 20685-1 class) enters as noise,
        // so near-deterministic relations in a generated population do not
        // turn a normal tape error into a "contradiction".
        let noise: Vec<f64> = inputs
            .readings
            .iter()
            .zip(&index)
            .map(|(r, &j)| {
                r.tolerance
                    .unwrap_or(self.set.definitions[j].tolerance.mm() / 1000.0)
            })
            .collect();
        let mut bad = Vec::new();
        // A kept reading is known to be unusual: it is not evidence about
        // the others (short legs kept must not make a normal stature look
        // wrong).
        let is_kept: Vec<bool> = inputs
            .readings
            .iter()
            .map(|r| inputs.kept.contains(&r.name))
            .collect();
        if index.len() >= 2 {
            for a in 0..index.len() {
                let observed: Vec<(usize, f64, f64)> = (0..index.len())
                    .filter(|&b| b != a && !is_kept[b])
                    .map(|b| (index[b], inputs.readings[b].value.metres, noise[b].powi(2)))
                    .collect();
                let real = self.real_stats(inputs.sex);
                // Readings with an ANSUR column are judged against real
                // people (given the other such readings); the others against
                // the training population, as a warning only.
                let real_obs: Vec<(usize, f64, f64)> = (0..index.len())
                    .filter(|&b| b != a && !is_kept[b])
                    .filter_map(|b| {
                        real.row[index[b]]
                            .map(|r| (r, inputs.readings[b].value.metres, noise[b].powi(2)))
                    })
                    .collect();
                let value = inputs.readings[a].value.metres;
                let cond = self.file.model.joint.conditional(&[index[a]], &observed)?;
                let (mu_t, sd_t) = (
                    cond.mean[0],
                    (cond.cov[(0, 0)].max(0.0) + noise[a].powi(2)).sqrt(),
                );
                let z_t = (value - mu_t) / sd_t;
                let real_cond = match real.row[index[a]] {
                    Some(r) if !real_obs.is_empty() => real.conditional(r, &real_obs),
                    _ => None,
                };
                // Refused only when neither real people nor the training
                // population explain the reading; the message uses the
                // real-people prediction where there is one.
                let (mu, sd, zc, reference) = match real_cond {
                    Some((m, v)) => {
                        let sd = (v + noise[a].powi(2)).sqrt();
                        let z = (value - m) / sd;
                        (m, sd, z, Reference::RealPeople)
                    }
                    None => (mu_t, sd_t, z_t, Reference::Training),
                };
                let c = &mut checks[a];
                c.predicted_mm = Some(mu * 1000.0);
                c.predicted_sd_mm = Some(sd * 1000.0);
                c.conditional_z = Some(zc);
                let others: Vec<String> = inputs
                    .readings
                    .iter()
                    .enumerate()
                    .filter(|&(b, _)| b != a)
                    .map(|(_, r)| r.name.clone())
                    .take(4)
                    .collect();
                let msg = AgainstOthers {
                    measurement: c.name.clone(),
                    cm: c.value_mm / 10.0,
                    z: zc,
                    more: inputs.readings.len() - 1 - others.len(),
                    others,
                    predicted_cm: mu * 100.0,
                    sd_cm: sd * 100.0,
                };
                let kept = inputs.kept.contains(&c.name);
                if refused(zc, z_t, index.len() - 1, reference) && kept {
                    c.kept_unusual = true;
                    warnings.push(Warning::KeptAgainstOthers(msg));
                } else if refused(zc, z_t, index.len() - 1, reference) {
                    bad.push(msg);
                } else if zc.abs() > CONDITIONAL_Z_WARN {
                    warnings.push(Warning::CheckAgainstOthers(msg));
                }
            }
        }
        if !bad.is_empty() {
            bad.sort_by(|a: &AgainstOthers, b| b.z.abs().total_cmp(&a.z.abs()));
            return Err(PredictError::Contradiction(bad));
        }
        Ok((checks, warnings))
    }

    /// What the readings `others` (name, metres; each with its ISO 20685-1
    /// tolerance as noise, like [`Estimator::check`]) predict for measurement
    /// `name`: the Gaussian conditional of real people (ANSUR II train split)
    /// given the others that follow an ANSUR column when `name` has one, else
    /// of the training population (the model's joint Gaussian,
    /// [`tapeshape_model::ShapeModel::conditional_measurements`] with reading noise) given all
    /// others. With no others it is the marginal. The returned SD includes
    /// `name`'s own tolerance, so with others given `(value - mean) / sd` is
    /// the conditional z-score [`Estimator::check`] computes for that reading
    /// (its marginal z leaves the tolerance out). Costs one small Cholesky
    /// per reference (a capture-time check, not the whole set's).
    ///
    /// Errors: an unknown name (with suggestions), a non-finite or
    /// non-positive value among `others`, `name` among `others`.
    pub fn predict_reading(
        &self,
        name: &str,
        others: &[(&str, f64)],
    ) -> Result<ReadingPrediction, PredictError> {
        self.predict_reading_with_tolerance(name, others, None)
    }

    /// [`Estimator::predict_reading`] with every reading's error (the others'
    /// and `name`'s own) taken as `tolerance` metres instead of each
    /// measurement's ISO 20685-1 class: for an operator whose readings are
    /// known to be less exact (a novice: about 1 cm), so that honest
    /// readings are not judged by a tape expert's precision. `None` is
    /// [`Estimator::predict_reading`]. Errors also for a tolerance that is not
    /// a positive finite length.
    pub fn predict_reading_with_tolerance(
        &self,
        name: &str,
        others: &[(&str, f64)],
        tolerance: Option<f64>,
    ) -> Result<ReadingPrediction, PredictError> {
        if let Some(t) = tolerance {
            if !(t.is_finite() && t > 0.0) {
                return Err(PredictError::BadValue(format!(
                    "the readings' tolerance is {t} m: it must be a positive length"
                )));
            }
        }
        let j = self.set.index_of(name).ok_or_else(|| self.unknown(name))?;
        let noise = |k: usize| tolerance.unwrap_or(self.set.definitions[k].tolerance.mm() / 1000.0);
        let mut observed = Vec::with_capacity(others.len());
        for &(n, v) in others {
            let k = self.set.index_of(n).ok_or_else(|| self.unknown(n))?;
            if k == j {
                return Err(PredictError::Input(format!(
                    "'{name}' is both the reading checked and one of the others: give each measurement once"
                )));
            }
            if !(v.is_finite() && v > 0.0) {
                return Err(PredictError::BadValue(format!(
                    "{n} is {v} m: a length must be positive and finite"
                )));
            }
            observed.push((k, v, noise(k).powi(2)));
        }
        let own = noise(j).powi(2);
        let cond = self.file.model.joint.conditional(&[j], &observed)?;
        let training = (cond.mean[0], (cond.cov[(0, 0)].max(0.0) + own).sqrt());
        let real = self.real_stats(None);
        if let Some(r) = real.row[j] {
            let real_obs: Vec<(usize, f64, f64)> = observed
                .iter()
                .filter_map(|&(k, v, n)| real.row[k].map(|rk| (rk, v, n)))
                .collect();
            let got = if real_obs.is_empty() {
                let (m, sd) = real.marginal(r);
                Some((m, sd * sd))
            } else {
                real.conditional(r, &real_obs)
            };
            if let Some((mean, var)) = got {
                return Ok(ReadingPrediction {
                    mean,
                    sd: (var + own).sqrt(),
                    reference: Reference::RealPeople,
                    conditioned_on: real_obs.len(),
                    training,
                });
            }
        }
        Ok(ReadingPrediction {
            mean: training.0,
            sd: training.1,
            reference: Reference::Training,
            conditioned_on: observed.len(),
            training,
        })
    }

    fn out_of_range(&self, r: &Input, mean: f64, sd: f64, z: f64) -> OutOfRange {
        OutOfRange {
            measurement: r.name.clone(),
            number: r.value.number,
            unit: r.value.unit,
            unit_typed: r.value.unit_typed,
            cm: r.value.metres * 100.0,
            z,
            typical_cm: mean * 100.0,
            typical_sd_cm: sd * 100.0,
            // Another unit that makes the typed number typical?
            slip: unit_slip(&r.value, mean, sd).map(|s| s.unit),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cm(number: f64) -> Length {
        Length {
            metres: number * 0.01,
            unit: Unit::Cm,
            unit_typed: true,
            number,
        }
    }

    #[test]
    fn a_unit_slip_needs_a_far_reading_and_another_unit_that_fits() {
        // Stature 1.71 +/- 0.09 m: "1.76 cm" is metres.
        let s = unit_slip(&cm(1.76), 1.71, 0.09).expect("a slip");
        assert_eq!(s.unit, Unit::M);
        assert_eq!((s.number, s.metres), (1.76, 1.76));
        assert!((s.z - 0.05 / 0.09).abs() < 1e-12);
        // Within SLIP_SUSPECT_Z of the prediction: no slip, whatever fits.
        assert!(unit_slip(&cm(171.0 + 2.9 * 9.0), 1.71, 0.09).is_none());
        // Far off, but no unit brings it within SLIP_Z: no slip.
        assert!(unit_slip(&cm(400.0), 1.71, 0.09).is_none());
        // Read as inches it would be 2.5 SD off: beyond SLIP_Z, no slip.
        let chest = 38.0 * 0.0254;
        assert!(unit_slip(&cm(38.0), chest + 2.5 * 0.05, 0.05).is_none());
        assert_eq!(
            unit_slip(&cm(38.0), chest + 1.5 * 0.05, 0.05).map(|s| s.unit),
            Some(Unit::In)
        );
        // No spread, no verdict.
        assert!(unit_slip(&cm(1.76), 1.71, 0.0).is_none());
        assert!(unit_slip(&cm(1.76), 1.71, f64::NAN).is_none());
    }

    #[test]
    fn refusal_needs_both_references_and_real_people_given_others() {
        let far = MARGINAL_Z_ERROR + 0.5;
        let near = MARGINAL_Z_ERROR - 0.5;
        // Alone: both references beyond the marginal level, either sign.
        assert!(refused(far, -far, 0, Reference::Training));
        assert!(refused(-far, -far, 0, Reference::RealPeople));
        assert!(!refused(far, near, 0, Reference::RealPeople));
        assert!(!refused(near, far, 0, Reference::RealPeople));
        // Given others: only against real people.
        let far = CONDITIONAL_Z_ERROR + 0.5;
        assert!(refused(far, far, 2, Reference::RealPeople));
        assert!(!refused(far, far, 2, Reference::Training));
        assert!(!refused(
            far,
            CONDITIONAL_Z_ERROR - 0.5,
            1,
            Reference::RealPeople
        ));
        // The prediction's own rule is the same function.
        let p = ReadingPrediction {
            mean: 1.0,
            sd: 0.01,
            reference: Reference::Training,
            conditioned_on: 3,
            training: (1.0, 0.01),
        };
        assert!(
            !p.refuses(1.2),
            "a training-only conditional warns, never refuses"
        );
        let p = ReadingPrediction {
            reference: Reference::RealPeople,
            ..p
        };
        assert!(p.refuses(1.2) && !p.refuses(1.05));
        assert_eq!(p.z(1.02), (1.02 - 1.0) / 0.01);
    }
}
