//! What an estimate tells the operator besides the body: the checks' notes
//! on the readings and the model's own warnings, each a code with its
//! values ([`Warning`]) so that the station words it in the operator's
//! language; [`std::fmt::Display`] gives the English text the JSON report
//! and logs carry.

use serde::{Deserialize, Serialize};

use crate::input::Unit;

pub use tapeshape_model::predict::warning::{
    list_from_either, Step1Objective, Warning as ModelWarning,
};

/// A reading far from what the population the model knows holds for it
/// (the marginal check): its words for a refusal and for a reading the
/// operator kept.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct OutOfRange {
    /// The measurement's name.
    pub measurement: String,
    /// The number as typed.
    pub number: f64,
    /// The unit it was read in.
    pub unit: Unit,
    /// False when the number had no unit and `unit` was taken.
    pub unit_typed: bool,
    /// The reading, centimetres.
    pub cm: f64,
    /// Its distance from the population's mean, SD (signed).
    pub z: f64,
    /// The population's mean, centimetres.
    pub typical_cm: f64,
    /// The population's SD, centimetres.
    pub typical_sd_cm: f64,
    /// Another unit that makes the number typical (the likely slip), if any.
    pub slip: Option<Unit>,
}

impl std::fmt::Display for OutOfRange {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let typed = format!("{} {}", self.number, self.unit.symbol());
        let typical = format!("{:.1} cm +/- {:.1}", self.typical_cm, self.typical_sd_cm);
        match self.slip {
            Some(u) => {
                write!(
                    f,
                    "{} {typed} looks like {}: write {}{} (typical: {typical})",
                    self.measurement,
                    u.word(),
                    self.number,
                    u.symbol()
                )?;
                if !self.unit_typed {
                    write!(
                        f,
                        "; a number without a unit is read as {}",
                        self.unit.word()
                    )?;
                }
                Ok(())
            }
            None => write!(
                f,
                "{} {typed} ({:.1} cm) is {:.0} SD {} the population the model knows (typical: {typical}): check the reading and its unit",
                self.measurement,
                self.cm,
                self.z.abs(),
                above_below(self.z)
            ),
        }
    }
}

/// A reading far from what the customer's other readings predict for it
/// (the conditional check).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct AgainstOthers {
    /// The measurement's name.
    pub measurement: String,
    /// The reading, centimetres.
    pub cm: f64,
    /// Its distance from the prediction, SD (signed).
    pub z: f64,
    /// The first few of the other readings (names).
    pub others: Vec<String>,
    /// How many other readings there are beyond `others`.
    pub more: usize,
    /// The prediction from them, centimetres.
    pub predicted_cm: f64,
    /// Its SD (with the tape's noise), centimetres.
    pub sd_cm: f64,
}

impl std::fmt::Display for AgainstOthers {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let mut others = self.others.join(", ");
        if self.more > 0 {
            others = format!("{others} and {} more", self.more);
        }
        let one = self.others.len() + self.more == 1;
        write!(
            f,
            "{} {:.1} cm is {:.0} SD {} what {others} predict{} ({:.1} +/- {:.1} cm)",
            self.measurement,
            self.cm,
            self.z.abs(),
            above_below(self.z),
            if one { "s" } else { "" },
            self.predicted_cm,
            self.sd_cm
        )
    }
}

fn above_below(z: f64) -> &'static str {
    if z > 0.0 {
        "above"
    } else {
        "below"
    }
}

/// One thing an estimate says about its readings or its result.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "code", rename_all = "kebab-case")]
pub enum Warning {
    /// Readings typed without a unit, read in `unit`.
    NoUnit {
        /// The measurements' names.
        measurements: Vec<String>,
        /// The unit they were read in.
        unit: Unit,
    },
    /// A reading far from the population, kept by the operator.
    KeptOutOfRange(OutOfRange),
    /// A reading far from what the other readings predict, kept by the
    /// operator.
    KeptAgainstOthers(AgainstOthers),
    /// A reading somewhat far from what the other readings predict: worth a
    /// second look, not a refusal.
    CheckAgainstOthers(AgainstOthers),
    /// The set of readings is unusual for the population (plausible, but
    /// worth checking).
    UnusualSet {
        /// Mahalanobis distance of the readings.
        mahalanobis: f64,
        /// How many readings.
        readings: usize,
        /// Share of the population closer to the mean, percent.
        percent_closer: f64,
    },
    /// The estimate ran with unusual readings the operator kept.
    EstimatedWithKept {
        /// The kept readings' names.
        measurements: Vec<String>,
        /// Share of the training population closer to the mean, percent.
        percent_closer: f64,
        /// Mahalanobis distance of the readings.
        mahalanobis: f64,
    },
    /// Readings recorded but not fitted: ANSUR II dimensions that the
    /// standing body model cannot take as ANSUR defines them (flexed girths,
    /// calipers that compress the tissue; [`crate::priors::CANNOT_FOLLOW_ANSUR`]).
    RecordedNotFitted {
        /// The readings' names.
        measurements: Vec<String>,
    },
    /// A survey's reading recorded but not fitted because the body measures
    /// it as the sum of other readings of the survey, which are fitted
    /// ([`crate::priors::ANSUR_SUMS`]: ANSUR II's sleeve outseam is 10 mm
    /// shorter than its acromion-radiale plus radiale-stylion lengths on
    /// average).
    RecordedSumOfParts {
        /// The reading's name.
        measurement: String,
        /// The readings whose sum it is on the body.
        parts: Vec<String>,
    },
    /// The model's own warning (its code is the model's).
    #[serde(untagged)]
    Model(tapeshape_model::Warning),
}

impl std::fmt::Display for Warning {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Self::NoUnit { measurements, unit } => write!(
                f,
                "no unit given for {}: read as {}",
                measurements.join(", "),
                unit.word()
            ),
            Self::KeptOutOfRange(o) => write!(f, "kept by the operator: {o}"),
            Self::KeptAgainstOthers(a) => write!(f, "kept by the operator: {a}"),
            Self::CheckAgainstOthers(a) => write!(f, "{a}: check this reading"),
            Self::UnusualSet {
                mahalanobis,
                readings,
                percent_closer,
            } => write!(
                f,
                "unusual set of measurements (Mahalanobis distance {mahalanobis:.1} over {readings} readings, {percent_closer:.1}% of the population is closer to the mean): the result is plausible but check the readings"
            ),
            Self::EstimatedWithKept {
                measurements,
                percent_closer,
                mahalanobis,
            } => write!(
                f,
                "estimated with unusual readings the operator kept ({}): the body fits them as far as a human-looking surface allows; the set's plausibility: {percent_closer:.1}% of the training population is closer to the mean (Mahalanobis distance {mahalanobis:.1})",
                measurements.join(", ")
            ),
            Self::RecordedNotFitted { measurements } => {
                let n = measurements.len();
                let (readings, pronoun, kept) = if n == 1 {
                    ("reading", "it", "the reading is")
                } else {
                    ("readings", "them", "the readings are")
                };
                write!(
                    f,
                    "{n} {readings} recorded, not fitted: {}: the standing body model cannot take {pronoun} as ANSUR II defines {pronoun} (flexed girths, calipers that compress the tissue), so the body does not follow {pronoun}; {kept} kept in the report beside the body's own value",
                    measurements.join(", ")
                )
            }
            Self::RecordedSumOfParts { measurement, parts } => write!(
                f,
                "{measurement} recorded, not fitted: on the body it is the sum of {}, which are fitted; ANSUR II takes it with another instrument and posture (about 10 mm shorter than that sum), so fitting all of them would ask the body for a contradiction; the reading is kept in the report beside the body's own value",
                parts.join(" + ")
            ),
            Self::Model(w) => w.fmt(f),
        }
    }
}

impl From<String> for Warning {
    /// A warning of a report written before the codes.
    fn from(text: String) -> Self {
        Self::Model(tapeshape_model::Warning::Text { text })
    }
}

impl From<tapeshape_model::Warning> for Warning {
    fn from(w: tapeshape_model::Warning) -> Self {
        Self::Model(w)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[derive(Debug, Deserialize, Serialize)]
    struct Holder {
        #[serde(deserialize_with = "tapeshape_model::predict::warning::list_from_either")]
        warnings: Vec<Warning>,
    }

    fn against() -> AgainstOthers {
        AgainstOthers {
            measurement: "neck".into(),
            cm: 52.0,
            z: 13.2,
            others: vec!["stature".into()],
            more: 0,
            predicted_cm: 38.0,
            sd_cm: 1.1,
        }
    }

    #[test]
    fn estimator_and_model_warnings_round_trip_and_old_strings_read_back() {
        let all = vec![
            Warning::NoUnit {
                measurements: vec!["chest".into(), "waist".into()],
                unit: Unit::Cm,
            },
            Warning::KeptAgainstOthers(against()),
            Warning::RecordedNotFitted {
                measurements: vec!["chestbreadth".into()],
            },
            Warning::RecordedSumOfParts {
                measurement: "sleeveoutseam".into(),
                parts: vec![
                    "acromionradialelength".into(),
                    "radialestylionlength".into(),
                ],
            },
            Warning::Model(tapeshape_model::Warning::TrianglesChanged {
                flipped: 2,
                collapsed: 0,
            }),
        ];
        let json = serde_json::to_string(&Holder {
            warnings: all.clone(),
        })
        .unwrap();
        assert!(json.contains(r#""code":"kept-against-others""#), "{json}");
        assert!(json.contains(r#""code":"triangles-changed""#), "{json}");
        assert!(json.contains(r#""code":"recorded-not-fitted""#), "{json}");
        assert!(json.contains(r#""code":"recorded-sum-of-parts""#), "{json}");
        let back: Holder = serde_json::from_str(&json).unwrap();
        assert_eq!(back.warnings, all);
        let old: Holder = serde_json::from_str(r#"{"warnings":["an old warning"]}"#).unwrap();
        assert_eq!(
            old.warnings,
            vec![Warning::from("an old warning".to_string())]
        );
        assert_eq!(old.warnings[0].to_string(), "an old warning");
    }

    #[test]
    fn the_english_text_says_predicts_for_one_other_reading_and_counts_the_rest() {
        let one = against();
        assert_eq!(
            Warning::KeptAgainstOthers(one.clone()).to_string(),
            "kept by the operator: neck 52.0 cm is 13 SD above what stature predicts (38.0 +/- 1.1 cm)"
        );
        let many = AgainstOthers {
            others: vec!["a".into(), "b".into()],
            more: 3,
            z: -4.0,
            ..one
        };
        assert_eq!(
            Warning::CheckAgainstOthers(many).to_string(),
            "neck 52.0 cm is 4 SD below what a, b and 3 more predict (38.0 +/- 1.1 cm): check this reading"
        );
    }
}
