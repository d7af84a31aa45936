//! What the tape did not measure, from real people.
//!
//! Why: the shape model's own relations between measurements come from a
//! generated population, and for the dimensions a customer was not
//! measured on they predict real people far worse than a plain regression
//! on real people does (issue 12: 20.6 mm against 9.2 mm mean absolute
//! error over 35 ANSUR II dimensions). So every model measurement that
//! follows an ANSUR II column that no reading gives becomes a **soft target**:
//! the Gaussian conditional of the ANSUR II train split (of the customer's
//! sex when it is known) given the readings that were taken, with each
//! reading's own error as noise, and with the conditional SD (times
//! [`RealPeople::sd_scale`], at least the measurement's ISO 20685-1
//! allowable error) as its tolerance. The model weighs a target by
//! `(reference / tolerance)^2`, so a real reading (a few mm) dominates
//! and a soft target only pulls where nothing was measured. Step 2 aims a
//! soft target [`tapeshape_model::Step2Settings::soft_pull`] of the way
//! from the value step 1 gave it to its own (the station: the default,
//! three quarters of the way; see that setting for why),
//! and its fold repair neither holds a soft target's landmarks nor keeps
//! it within a tolerance: a statistic is not the customer.
//!
//! The conditional is one [`tapeshape_model::regress::JointGaussian::conditional`]
//! of all soft targets at once (one Cholesky per estimate).

use serde::{Deserialize, Serialize};
use tapeshape_model::Target;
use tapeshape_population::ansur::Sex;

use crate::checks::RealStats;
use crate::{Estimator, Inputs, PredictError};

/// ANSUR II columns the estimator fitted no soft target to (and fits none
/// with [`RealPeople::breadths_and_depths`] off; with it on, only
/// [`CANNOT_FOLLOW_ANSUR`] get none), because the mesh's measurement was
/// not taken to be ANSUR's quantity: on bodies fitted to their
/// subjects on every `ansur` dimension (`tapeshape dataset generate --n 100
/// --seed 3 --fit ansur`, then the population crate's `fit_report` example;
/// docs/results/real-customers/population-fit-ansur.md) the generator misses
/// most of these by 10-30 mm on average with the same sign on nearly every body
/// (chest breadth +28 mm, bicristal breadth +29 mm, waist depth +20 mm, ...;
/// since the population fit leaves out the compressing calipers, fitted
/// bodies meet chest depth, waist depth and breadth and interscye I within
/// 8 mm on average, but the embedded model's population is not fitted on
/// them: they keep no soft target until it is).
/// A soft target there would fit a different quantity under ANSUR's name and
/// pull the readings off (a 4-reading chest missed by 2 mm). It holds
/// [`CANNOT_FOLLOW_ANSUR`] (the A-pose mesh cannot take them as ANSUR does)
/// and the dimensions whose offset is not explained yet. The definitions
/// audit of issue 12 (docs/measurements.md) took off the neck base,
/// cervicale and suprasternale heights, shoulder length and biacromial
/// breadth, whose mean offset on fitted bodies fell from 14-31 mm to under
/// 5 mm.
/// A reading of any of them given by an operator is still fitted, except a
/// survey's reading of one of [`CANNOT_FOLLOW_ANSUR`].
pub const NOT_YET_ANSUR: &[&str] = &[
    "bicepscircumferenceflexed",
    "bicristalbreadth",
    "chestbreadth",
    "chestdepth",
    "forearmcircumferenceflexed",
    "hipbreadth",
    "interscyei",
    "waistbreadth",
    "waistdepth",
];

/// The columns of [`NOT_YET_ANSUR`] that a standing A-pose skin mesh cannot
/// measure as ANSUR II defines them: the biceps and forearm girths are
/// taken flexed (elbow at 90 degrees, fist clenched), chest breadth and
/// bicristal breadth with the caliper compressing the tissue (chest breadth
/// at maximum inspiration). docs/measurements.md says the same per
/// dimension. The measurement sets' descriptions ask the operator for what
/// the mesh measures (skin to skin, relaxed), so a station's reading is
/// fitted; a survey's reading taken as ANSUR takes it
/// ([`crate::Inputs::ansur_survey`]) is checked and recorded, and informs
/// the soft targets (real people's statistics are of ANSUR's own quantity),
/// but the body is not fitted to it ([`crate::Estimator::cannot_follow`]):
/// fitting the mesh's different quantity to it folded the chest and arms.
pub const CANNOT_FOLLOW_ANSUR: &[&str] = &[
    "bicepscircumferenceflexed",
    "bicristalbreadth",
    "chestbreadth",
    "forearmcircumferenceflexed",
];

/// ANSUR II dimensions that the mesh measures as the sum of others: the
/// `ansur` set's sleeve outseam is the path acromion - radiale - stylion,
/// on the mesh exactly the acromion-radiale length plus the radiale-stylion
/// length. ANSUR II takes the three with different instruments and
/// postures (a tape with the arm straight and the palm forward; two beam
/// calipers parallel to the arm segments with the palms to the thighs), and
/// its sleeve outseam is shorter than the sum of its two segment lengths:
/// by 10.0 mm for men (SD 8.5, 3,064 train-split subjects) and 9.1 mm for
/// women (SD 8.1, 1,499), shorter for 88 % of the men and 87 % of the
/// women. A survey that gives all three asks the body for a
/// contradiction; fitting it missed the
/// acromion-radiale length by more than ISO 20685-1 allows on 40 % of the
/// ANSUR II test split (docs/results/real-customers.md). So a survey's
/// reading of the sum is recorded, not fitted, when every part is given
/// and fitted ([`crate::Estimator::sum_of_given`]); given without its
/// parts, it is fitted (it is then the only arm length the body has).
pub const ANSUR_SUMS: &[(&str, &[&str])] = &[(
    "sleeveoutseam",
    &["acromionradialelength", "radialestylionlength"],
)];

/// How real people guide the unmeasured dimensions.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct RealPeople {
    /// A soft target's tolerance is this many conditional SDs (at least
    /// the measurement's ISO 20685-1 allowable error).
    pub sd_scale: f64,
    /// The columns of [`NOT_YET_ANSUR`] that the mesh can measure as
    /// ANSUR II defines them (all but [`CANNOT_FOLLOW_ANSUR`]: chest
    /// depth, hip and waist breadth, waist depth, interscye I) get soft
    /// targets too. On by default: step 1 follows them in the learned
    /// space; step 2 holds them at their step-1 value
    /// ([`tapeshape_model::Step2Settings::soft_pull`] pulls the other soft
    /// targets three quarters of the way, half before 2026-12-07). All
    /// 1,505 ANSUR II test-split people, quick
    /// input with sex, the mean absolute error over the 32 dimensions the
    /// mesh can follow went from 12.96 mm without them to 11.61 mm (least
    /// squares 9.54 mm), none folded. Pulled in step 2 as well they gave
    /// 11.50 mm, but the mesh's hip and waist girths do not have ANSUR's
    /// relation to their breadths and depths: a narrower hip bulged the
    /// buttocks and step 2 gave way to L-BFGS or kept the step-1 shape
    /// (docs/results/real-customers.md, "Step 2 and the soft targets").
    /// Reports from before 2026-12-06 were made without.
    #[serde(default)]
    pub breadths_and_depths: bool,
}

impl Default for RealPeople {
    fn default() -> Self {
        Self {
            sd_scale: 1.0,
            breadths_and_depths: true,
        }
    }
}

/// One soft target, as the report lists it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SoftTarget {
    /// Measurement name.
    pub name: String,
    /// What real people with these readings have on average, mm.
    pub value_mm: f64,
    /// Its conditional SD, mm.
    pub sd_mm: f64,
    /// The tolerance the fit was given, mm.
    pub tolerance_mm: f64,
}

impl Estimator {
    /// Real-people statistics for `sex` (`None`: pooled), computed on first
    /// use.
    pub(crate) fn real_stats(&self, sex: Option<Sex>) -> &RealStats {
        match sex {
            None => self
                .real
                .get_or_init(|| RealStats::compute(&self.set, None)),
            Some(Sex::Male) => self
                .real_male
                .get_or_init(|| RealStats::compute(&self.set, sex)),
            Some(Sex::Female) => self
                .real_female
                .get_or_init(|| RealStats::compute(&self.set, sex)),
        }
    }

    /// The soft targets for `inputs` (see the module docs): one per model
    /// measurement with an ANSUR II column that `inputs` does not give.
    /// Returns (model index, target) pairs and their report entries.
    ///
    /// Errors only if `settings.sd_scale` is not a positive number.
    pub fn soft_targets(
        &self,
        inputs: &Inputs,
        settings: &RealPeople,
    ) -> Result<Vec<(usize, Target, SoftTarget)>, PredictError> {
        if !(settings.sd_scale.is_finite() && settings.sd_scale > 0.0) {
            return Err(PredictError::Input(format!(
                "the soft targets' SD scale is {}: it must be a positive number",
                settings.sd_scale
            )));
        }
        let real = self.real_stats(inputs.sex);
        let given: Vec<Option<usize>> = inputs
            .readings
            .iter()
            .map(|r| self.set.index_of(&r.name))
            .collect();
        let observed: Vec<(usize, f64, f64)> = inputs
            .readings
            .iter()
            .zip(&given)
            .filter_map(|(r, j)| {
                let j = (*j)?;
                let row = real.row(j)?;
                let noise = r
                    .tolerance
                    .unwrap_or(self.set.definitions[j].tolerance.mm() / 1000.0);
                Some((row, r.value.metres, noise * noise))
            })
            .collect();
        // A column that a reading gives is measured, whatever definition
        // took it: another measurement of the same column (the quick set's
        // `chest` and the ansur set's `chestcircumference`) gets no soft
        // target, which would only pull against the reading.
        let given_columns: Vec<&str> = given
            .iter()
            .flatten()
            .filter_map(|&j| self.set.definitions[j].ansur.as_deref())
            .collect();
        let left_out = if settings.breadths_and_depths {
            CANNOT_FOLLOW_ANSUR
        } else {
            NOT_YET_ANSUR
        };
        let wanted: Vec<(usize, usize)> = (0..self.set.len())
            .filter(|j| !given.contains(&Some(*j)))
            .filter(|&j| {
                self.set.definitions[j]
                    .ansur
                    .as_deref()
                    .is_none_or(|c| !given_columns.contains(&c) && !left_out.contains(&c))
            })
            .filter_map(|j| real.row(j).map(|r| (j, r)))
            .collect();
        // One soft target per ANSUR II column: where two measurements of
        // the model follow the same column (the quick set's `neck` and the
        // ansur set's `neckcircumferencebase`), a target on each counted
        // the same real-people statistic twice, twice the weight of any
        // other, and cost step 2 a reading more. The one named as the
        // column (the ansur set's) is kept, else the first.
        let def = |j: usize| &self.set.definitions[j];
        let named_as_column = |j: usize| def(j).ansur.as_deref() == Some(def(j).name.as_str());
        let wanted: Vec<(usize, usize)> = wanted
            .iter()
            .copied()
            .filter(|&(j, _)| {
                let Some(column) = def(j).ansur.as_deref() else {
                    return true;
                };
                let mut same = wanted
                    .iter()
                    .map(|&(i, _)| i)
                    .filter(|&i| def(i).ansur.as_deref() == Some(column));
                let keep = same
                    .clone()
                    .find(|&i| named_as_column(i))
                    .or_else(|| same.next());
                keep == Some(j)
            })
            .collect();
        if wanted.is_empty() || real.is_empty() {
            return Ok(Vec::new());
        }
        let rows: Vec<usize> = wanted.iter().map(|&(_, r)| r).collect();
        let Some((mean, var)) = real.conditional_many(&rows, &observed) else {
            return Ok(Vec::new());
        };
        Ok(wanted
            .iter()
            .enumerate()
            .filter(|&(k, _)| mean[k].is_finite() && mean[k] > 0.0 && var[k].is_finite())
            .map(|(k, &(j, _))| {
                let sd = var[k].max(0.0).sqrt();
                let iso = self.set.definitions[j].tolerance.mm() / 1000.0;
                let tol = (sd * settings.sd_scale).max(iso);
                (
                    j,
                    Target::soft(mean[k], tol),
                    SoftTarget {
                        name: self.set.definitions[j].name.clone(),
                        value_mm: mean[k] * 1000.0,
                        sd_mm: sd * 1000.0,
                        tolerance_mm: tol * 1000.0,
                    },
                )
            })
            .collect())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use tapeshape_measure::MeasurementSet;

    #[test]
    fn the_lists_name_ansur_columns_of_the_ansur_set() {
        let set = MeasurementSet::builtin("ansur").unwrap();
        let cols: Vec<&str> = set
            .definitions
            .iter()
            .filter_map(|d| d.ansur.as_deref())
            .collect();
        for c in NOT_YET_ANSUR {
            assert!(cols.contains(c), "{c} is no column of the ansur set");
        }
        for c in CANNOT_FOLLOW_ANSUR {
            assert!(NOT_YET_ANSUR.contains(c), "{c} gets a soft target");
        }
    }
}
