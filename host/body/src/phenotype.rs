//! Body parameters: the macro [`Phenotype`] and the sparse [`LocalChanges`].
//!
//! The parameters follow **anny 0.6.2's conventions** (pack README 4.1), not
//! MakeHuman's own sliders: gender 0 = male, 1 = female; age in anny units
//! (young = 2/3, old = 1; adults are 18 to 90 years, anny age 0.77 to 0.926,
//! see [`age_from_years`]); height 0 = minheight, 1 = maxheight with no neutral
//! point; proportions 0 = ideal, 1 = uncommon.
//!
//! Out-of-range values are **errors** here (anny clamps silently): a fitter
//! or an operator should learn that a value was not used as given.

use std::collections::BTreeMap;
use std::sync::OnceLock;

/// The local-change table shipped with the crate (pack README 2.6).
pub(crate) const LOCAL_CHANGES_TSV: &str = include_str!("../assets/makehuman/local_changes.tsv");

/// Youngest accepted age in years.
pub const MIN_YEARS: f64 = 18.0;
/// Oldest accepted age in years.
pub const MAX_YEARS: f64 = 90.0;

/// anny's age calibration, (years, anny age) knots (pack README 6.2), piecewise linear.
const AGE_KNOTS: [(f64, f64); 4] = [(16.0, 0.67), (18.0, 0.77), (64.0, 0.83), (110.0, 1.0)];

/// Errors in body parameters.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum PhenotypeError {
    /// A macro parameter is outside its range or not a number.
    #[error("phenotype `{name}` = {value} is outside [{min}, {max}]")]
    OutOfRange {
        /// Parameter name.
        name: &'static str,
        /// Value given.
        value: f64,
        /// Smallest allowed value.
        min: f64,
        /// Largest allowed value.
        max: f64,
    },
    /// An age in years outside the adult range.
    #[error("age {years} years is outside the adult range {MIN_YEARS}..={MAX_YEARS} years (the model has no child or baby shapes)")]
    AgeOutOfRange {
        /// Years given.
        years: f64,
    },
    /// Race weights are negative, not finite, or all zero.
    #[error("race weights (african {african}, asian {asian}, caucasian {caucasian}) must be finite, >= 0 and not all 0")]
    BadRace {
        /// african weight.
        african: f64,
        /// asian weight.
        asian: f64,
        /// caucasian weight.
        caucasian: f64,
    },
    /// A local-change label that the model does not have.
    #[error("unknown local change `{label}`{suggestion} (see LocalChanges::labels())")]
    UnknownLocalChange {
        /// Label given.
        label: String,
        /// `"; did you mean `x`?"` for the closest known labels
        /// ([`tapeshape_common::suggest`]), or empty.
        suggestion: String,
    },
    /// A local-change value outside [-1, 1] or not a number.
    #[error("local change `{label}` = {value} is outside [-1, 1]")]
    LocalChangeOutOfRange {
        /// Label.
        label: String,
        /// Value given.
        value: f64,
    },
}

/// anny age (dimensionless, young = 2/3, old = 1) for an adult age in years,
/// by anny's morphological-age calibration (pack README 6.2): piecewise linear
/// through (18 y, 0.77), (64 y, 0.83), (110 y, 1.0). 18..=90 years map to
/// 0.77..=0.926087.
///
/// Errors for years outside 18..=90 or not finite.
pub fn age_from_years(years: f64) -> Result<f64, PhenotypeError> {
    if !(MIN_YEARS..=MAX_YEARS).contains(&years) {
        return Err(PhenotypeError::AgeOutOfRange { years });
    }
    Ok(interp(years, AGE_KNOTS))
}

/// Years for an anny age (inverse of [`age_from_years`]); errors if the anny
/// age lies outside the adult range (0.77..=0.926087).
pub fn years_from_age(age: f64) -> Result<f64, PhenotypeError> {
    let (lo, hi) = age_range();
    if !(lo..=hi).contains(&age) {
        return Err(PhenotypeError::OutOfRange {
            name: "age",
            value: age,
            min: lo,
            max: hi,
        });
    }
    Ok(interp(age, AGE_KNOTS.map(|(y, a)| (a, y))))
}

/// The accepted anny-age range: `(age_from_years(18), age_from_years(90))`.
pub fn age_range() -> (f64, f64) {
    (interp(MIN_YEARS, AGE_KNOTS), interp(MAX_YEARS, AGE_KNOTS))
}

/// Piecewise-linear interpolation through increasing knots (x, y).
fn interp(x: f64, knots: [(f64, f64); 4]) -> f64 {
    let mut j = 0;
    while j + 2 < knots.len() && x > knots[j + 1].0 {
        j += 1;
    }
    let (x0, y0) = knots[j];
    let (x1, y1) = knots[j + 1];
    y0 + (x - x0) * (y1 - y0) / (x1 - x0)
}

/// The macro parameters of a body (anny conventions, see the module docs).
///
/// `Default` is a gender-neutral average adult: gender 0.5, age 35 years
/// (anny 0.79217), muscle, weight, proportions, cupsize and firmness 0.5,
/// height 0.37 (between anny's calibrated adult means, 0.39 male and 0.35
/// female), equal race weights. Its stature is 1.688 m.
///
/// When read with serde, missing fields take their default values and
/// unknown field names are errors (a misspelt `hieght` is not ignored).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Phenotype {
    /// 0 = male, 1 = female.
    pub gender: f64,
    /// anny age units; adults 0.77 (18 y) ..= 0.926 (90 y); see [`age_from_years`].
    pub age: f64,
    /// 0 = min, 0.5 = average, 1 = max muscle.
    pub muscle: f64,
    /// 0 = min, 0.5 = average, 1 = max weight.
    pub weight: f64,
    /// 0 = minheight, 1 = maxheight (stature roughly linear, about +1.09 m per unit).
    pub height: f64,
    /// 0 = ideal, 1 = uncommon proportions.
    pub proportions: f64,
    /// 0 = min, 0.5 = average, 1 = max cup size (acts on female bodies only).
    pub cupsize: f64,
    /// 0 = min, 0.5 = average, 1 = max breast firmness (female only).
    pub firmness: f64,
    /// Relative african amount (>= 0; the three are normalised to sum 1).
    pub african: f64,
    /// Relative asian amount (>= 0).
    pub asian: f64,
    /// Relative caucasian amount (>= 0).
    pub caucasian: f64,
}

impl Default for Phenotype {
    fn default() -> Self {
        Self {
            gender: 0.5,
            age: age_from_years(35.0).expect("35 years is adult"),
            muscle: 0.5,
            weight: 0.5,
            height: 0.37,
            proportions: 0.5,
            cupsize: 0.5,
            firmness: 0.5,
            african: 0.5,
            asian: 0.5,
            caucasian: 0.5,
        }
    }
}

impl Phenotype {
    /// Checks every value (ranges in the field docs); the first problem found is the error.
    pub fn validate(&self) -> Result<(), PhenotypeError> {
        let unit = [
            ("gender", self.gender),
            ("muscle", self.muscle),
            ("weight", self.weight),
            ("height", self.height),
            ("proportions", self.proportions),
            ("cupsize", self.cupsize),
            ("firmness", self.firmness),
        ];
        for (name, value) in unit {
            if !(0.0..=1.0).contains(&value) {
                return Err(PhenotypeError::OutOfRange {
                    name,
                    value,
                    min: 0.0,
                    max: 1.0,
                });
            }
        }
        let (lo, hi) = age_range();
        if !(lo..=hi).contains(&self.age) {
            return Err(PhenotypeError::OutOfRange {
                name: "age",
                value: self.age,
                min: lo,
                max: hi,
            });
        }
        let race = [self.african, self.asian, self.caucasian];
        if race.iter().any(|r| !(r.is_finite() && *r >= 0.0)) || race.iter().sum::<f64>() <= 0.0 {
            return Err(PhenotypeError::BadRace {
                african: self.african,
                asian: self.asian,
                caucasian: self.caucasian,
            });
        }
        Ok(())
    }

    /// The age in years (inverse of [`age_from_years`]).
    pub fn years(&self) -> Result<f64, PhenotypeError> {
        years_from_age(self.age)
    }
}

/// The 256 local-change labels in anny's order (from `local_changes.tsv`).
pub fn local_change_labels() -> &'static [String] {
    static LABELS: OnceLock<Vec<String>> = OnceLock::new();
    LABELS.get_or_init(|| {
        crate::pack::parse_local_changes(LOCAL_CHANGES_TSV, "local_changes.tsv")
            .expect("the embedded local_changes.tsv is valid (checked by tests)")
            .into_iter()
            .map(|r| r.label)
            .collect()
    })
}

/// Index of a local-change label, or an error suggesting the closest labels
/// ([`tapeshape_common::suggest::did_you_mean`]).
pub(crate) fn local_change_index(label: &str) -> Result<usize, PhenotypeError> {
    let labels = local_change_labels();
    if let Some(i) = labels.iter().position(|l| l == label) {
        return Ok(i);
    }
    Err(PhenotypeError::UnknownLocalChange {
        label: label.to_string(),
        suggestion: tapeshape_common::suggest::did_you_mean(
            label,
            labels.iter().map(String::as_str),
        ),
    })
}

/// Local changes: label -> value in [-1, 1] (pack README 4.4). Labels not
/// present are 0. Positive values apply the label's `incr`/`up`/... target,
/// negative values its opposite, linearly.
#[derive(Debug, Clone, Default, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(transparent)]
pub struct LocalChanges {
    values: BTreeMap<String, f64>,
}

impl LocalChanges {
    /// No local changes.
    pub fn new() -> Self {
        Self::default()
    }

    /// Every known label, in anny's order.
    pub fn labels() -> &'static [String] {
        local_change_labels()
    }

    /// Sets `label` to `value`; errors on an unknown label (suggesting the
    /// closest one) or a value outside [-1, 1]. A value of 0 removes the entry.
    pub fn set(&mut self, label: &str, value: f64) -> Result<&mut Self, PhenotypeError> {
        local_change_index(label)?;
        if !(-1.0..=1.0).contains(&value) {
            return Err(PhenotypeError::LocalChangeOutOfRange {
                label: label.to_string(),
                value,
            });
        }
        if value == 0.0 {
            self.values.remove(label);
        } else {
            self.values.insert(label.to_string(), value);
        }
        Ok(self)
    }

    /// The value of `label` (0 if unset; unknown labels also read as 0).
    pub fn get(&self, label: &str) -> f64 {
        self.values.get(label).copied().unwrap_or(0.0)
    }

    /// The non-zero entries, sorted by label.
    pub fn iter(&self) -> impl Iterator<Item = (&str, f64)> {
        self.values.iter().map(|(k, v)| (k.as_str(), *v))
    }

    /// Number of non-zero entries.
    pub fn len(&self) -> usize {
        self.values.len()
    }

    /// True when no local change is set.
    pub fn is_empty(&self) -> bool {
        self.values.is_empty()
    }

    /// Validates every entry (useful after deserialising) and returns
    /// `(label index, value)` pairs in label order.
    pub fn resolve(&self) -> Result<Vec<(usize, f64)>, PhenotypeError> {
        self.values
            .iter()
            .map(|(label, &value)| {
                let i = local_change_index(label)?;
                if !(-1.0..=1.0).contains(&value) {
                    return Err(PhenotypeError::LocalChangeOutOfRange {
                        label: label.clone(),
                        value,
                    });
                }
                Ok((i, value))
            })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn age_calibration_matches_readme() {
        assert!((age_from_years(18.0).unwrap() - 0.77).abs() < 1e-15);
        assert!((age_from_years(64.0).unwrap() - 0.83).abs() < 1e-15);
        assert!((age_from_years(90.0).unwrap() - (0.83 + 26.0 * 0.17 / 46.0)).abs() < 1e-15);
        assert!((age_from_years(90.0).unwrap() - 0.926).abs() < 1e-3);
        for y in [18.0, 25.5, 40.0, 64.0, 77.0, 90.0] {
            let a = age_from_years(y).unwrap();
            assert!((years_from_age(a).unwrap() - y).abs() < 1e-9, "{y}");
        }
        assert!(age_from_years(17.9).is_err());
        assert!(age_from_years(90.1).is_err());
        assert!(age_from_years(f64::NAN).is_err());
        assert!(years_from_age(0.7).is_err());
        assert!(years_from_age(0.95).is_err());
    }

    #[test]
    fn phenotype_validation() {
        Phenotype::default().validate().unwrap();
        let bad = Phenotype {
            weight: 1.2,
            ..Default::default()
        };
        assert!(matches!(
            bad.validate(),
            Err(PhenotypeError::OutOfRange { name: "weight", .. })
        ));
        let child = Phenotype {
            age: 0.5,
            ..Default::default()
        };
        assert!(child.validate().is_err());
        let nan = Phenotype {
            gender: f64::NAN,
            ..Default::default()
        };
        assert!(nan.validate().is_err());
        let norace = Phenotype {
            african: 0.0,
            asian: 0.0,
            caucasian: 0.0,
            ..Default::default()
        };
        assert!(matches!(
            norace.validate(),
            Err(PhenotypeError::BadRace { .. })
        ));
    }

    #[test]
    fn phenotype_json_defaults_and_typos() {
        let p: Phenotype = serde_json::from_str(r#"{"gender": 1.0, "height": 0.3}"#).unwrap();
        assert_eq!(
            p,
            Phenotype {
                gender: 1.0,
                height: 0.3,
                ..Default::default()
            }
        );
        let e = serde_json::from_str::<Phenotype>(r#"{"hieght": 0.3}"#).unwrap_err();
        assert!(e.to_string().contains("hieght"), "{e}");
    }

    #[test]
    fn local_changes_labels_and_suggestions() {
        assert_eq!(LocalChanges::labels().len(), 256);
        assert_eq!(LocalChanges::labels()[0], "l-lowerarm-scale-depth-incr");
        let mut lc = LocalChanges::new();
        lc.set("measure-waist-circ-incr", 0.5).unwrap();
        assert_eq!(lc.get("measure-waist-circ-incr"), 0.5);
        let e = lc.set("measure-wiast-circ-incr", 0.5).unwrap_err();
        assert_eq!(
            e,
            PhenotypeError::UnknownLocalChange {
                label: "measure-wiast-circ-incr".into(),
                suggestion: "; did you mean `measure-waist-circ-incr`?".into()
            }
        );
        assert!(lc.set("measure-waist-circ-incr", 1.5).is_err());
        assert!(lc.set("measure-waist-circ-incr", f64::NAN).is_err());
        lc.set("measure-waist-circ-incr", 0.0).unwrap();
        assert!(lc.is_empty());
    }
}
