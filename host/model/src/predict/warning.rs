//! What a prediction tells the operator or an engineer besides the body: a
//! code with its values ([`Warning`]), so that the station can word it in
//! the operator's language, and its English text ([`std::fmt::Display`]) for
//! the JSON report, logs and tests.
//!
//! Reports of versions before the codes carried plain strings; they read
//! back as [`Warning::Text`] ([`list_from_either`]).

use serde::{Deserialize, Deserializer, Serialize};

use super::progress::PredictStage;

/// The objective a step-1 result was judged by (its value's unit in words).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Step1Objective {
    /// The Gauss-Newton step's MAP objective (dimensionless).
    MapObjective,
    /// The paper's measurement energy `E_m`, mm^4.
    MeasurementEnergy,
}

impl std::fmt::Display for Step1Objective {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Self::MapObjective => "MAP objective",
            Self::MeasurementEnergy => "measurement energy E_m (mm^4)",
        })
    }
}

/// One thing the model's prediction says about its result. Lengths are
/// millimetres, energies mm^4 (the paper's `E_m`) unless a variant says
/// otherwise.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "code", rename_all = "kebab-case")]
pub enum Warning {
    /// A round's solver stopped with an error; the rounds after it were not
    /// run and the step kept what it had.
    SolverStopped {
        /// The step (step 1 or step 2).
        stage: PredictStage,
        /// The round (0-based, as the report's runs count them).
        round: usize,
        /// The solver's error, in English.
        reason: String,
    },
    /// A measurement had zero length on the shape a round started from and
    /// was left out of that round.
    ZeroLength {
        /// The step (step 1 or step 2).
        stage: PredictStage,
        /// The measurement's name.
        measurement: String,
    },
    /// Step 1 ended with a higher objective than its start: the start
    /// shape was kept.
    Step1KeptStart {
        /// The objective compared.
        objective: Step1Objective,
        /// Its value at the end of step 1.
        end: f64,
        /// Its value at the start.
        start: f64,
    },
    /// Step 2 ended with a higher `E_m` than step 1: the shape kept is the
    /// one at the start of `kept_round` (1-based), or the step-1 shape when
    /// `None`.
    Step2KeptEarlier {
        /// `E_m` at the end of step 2, mm^4.
        end: f64,
        /// `E_m` of the step-1 shape, mm^4.
        step1: f64,
        /// The round whose start was kept (1-based) and its `E_m`.
        kept_round: Option<(usize, f64)>,
    },
    /// Step 2 flipped or collapsed triangles of the step-1 shape.
    TrianglesChanged {
        /// Triangles whose normal turned over.
        flipped: usize,
        /// Triangles collapsed to (near) zero area.
        collapsed: usize,
    },
    /// The step-1 shape folded `folded` triangles of the model's mean
    /// shape and was smoothed there before step 2, which left `left`
    /// folded (see `ShapeModel::unfold_step1`); step 2 started from the
    /// smoothed shape.
    Step1Smoothed {
        /// Triangles of the mean shape the step-1 shape had flipped or
        /// collapsed.
        folded: usize,
        /// Triangles still flipped or collapsed after smoothing.
        left: usize,
    },
    /// Step 2 folded `folded` triangles of the step-1 shape and their
    /// neighbourhood was smoothed, which left `left` folded (see
    /// [`super::Step2Settings::fold_repair`]); the readings were measured
    /// again on the smoothed body.
    FoldsSmoothed {
        /// Triangles step 2 had flipped or collapsed.
        folded: usize,
        /// Triangles still flipped or collapsed after smoothing.
        left: usize,
    },
    /// The fold repair could not unfold `folded` triangles without a
    /// reading falling out of its allowable error, so it smoothed them with
    /// nothing held (see [`super::Step2Settings::fold_repair`]), which left
    /// `left` folded and pushed `readings` beyond their allowable error: the
    /// body follows them as far as a surface that does not pass through
    /// itself allows.
    SurfaceOverReadings {
        /// Triangles still flipped or collapsed after the repair that held
        /// the readings.
        folded: usize,
        /// Triangles still flipped or collapsed after this smoothing.
        left: usize,
        /// The readings (measurement names) within their allowable error
        /// before this smoothing and beyond it after; may be empty.
        readings: Vec<String>,
    },
    /// Following the real-people soft targets `asked` of the way in step 2
    /// folded or creased the surface, so the body kept follows them `pull`
    /// of the way (see [`super::Step2Settings::soft_pull`]); the readings
    /// are fitted the same.
    SoftPullReduced {
        /// The share of the way the body kept was pulled, in `[0, 1]`.
        pull: f64,
        /// The share the settings asked for.
        asked: f64,
    },
    /// The readings are far from the training population: the shape is
    /// held to `held_sd` standard deviations and may not fit them all.
    FarFromPopulation {
        /// Mahalanobis distance of the readings.
        mahalanobis: f64,
        /// How many readings it is over.
        readings: usize,
        /// The clamp on the shape weights, SD.
        held_sd: f64,
    },
    /// A reading the body could not meet within the report's limit.
    NotFitted {
        /// The measurement's name.
        measurement: String,
        /// The limit, mm.
        limit_mm: f64,
        /// The body's error, mm.
        error_mm: f64,
    },
    /// Measuring the set's other measurements on the body failed; the body
    /// stands, the report lacks them.
    MeasuringFailed {
        /// Why, in English.
        reason: String,
    },
    /// A warning of a report written before the codes (English text only).
    Text {
        /// The text.
        text: String,
    },
}

impl std::fmt::Display for Warning {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Self::SolverStopped {
                stage,
                round,
                reason,
            } => write!(f, "{stage} round {round}: optimiser stopped: {reason}"),
            Self::ZeroLength { stage, measurement } => write!(
                f,
                "{stage}: measurement '{measurement}' has zero length on the current shape and was left out of this round"
            ),
            Self::Step1KeptStart {
                objective,
                end,
                start,
            } => write!(
                f,
                "step 1 ended with a higher {objective} than the start ({end:.4e} vs {start:.4e}): kept the start shape"
            ),
            Self::Step2KeptEarlier {
                end,
                step1,
                kept_round,
            } => {
                write!(
                    f,
                    "step 2 ended with a higher measurement energy than step 1 (E_m {end:.4e} vs {step1:.4e} mm^4): "
                )?;
                match kept_round {
                    Some((round, e)) => {
                        write!(f, "kept its shape at the start of round {round} (E_m {e:.4e})")
                    }
                    None => f.write_str("kept the step-1 shape"),
                }
            }
            Self::TrianglesChanged { flipped, collapsed } => write!(
                f,
                "step 2 flipped {flipped} and collapsed {collapsed} triangles: the measurements may be inconsistent"
            ),
            Self::Step1Smoothed { folded, left } => write!(
                f,
                "the shape space's fit folded {folded} triangles of the surface: smoothed them out before refining, {left} left"
            ),
            Self::FoldsSmoothed { folded, left } => write!(
                f,
                "step 2 folded {folded} triangles of the surface: smoothed them out, {left} left"
            ),
            Self::SurfaceOverReadings {
                folded,
                left,
                readings,
            } => {
                write!(
                    f,
                    "{folded} triangles of the surface stayed folded where the body met the readings: smoothed them out, {left} left"
                )?;
                if readings.is_empty() {
                    f.write_str("; no reading left its allowable error")
                } else {
                    write!(
                        f,
                        "; these readings are now outside their allowable error: {}",
                        readings.join(", ")
                    )
                }
            }
            Self::SoftPullReduced { pull, asked } => write!(
                f,
                "following real people's statistics for the dimensions not measured {:.0} % of the way folded or creased the surface: followed them {:.0} %",
                100.0 * asked,
                100.0 * pull
            ),
            Self::FarFromPopulation {
                mahalanobis,
                readings,
                held_sd,
            } => write!(
                f,
                "the measurements are far from the training population (Mahalanobis distance {mahalanobis:.1} over {readings} measurements): the shape is held to {held_sd} SD and may not fit them all"
            ),
            Self::NotFitted {
                measurement,
                limit_mm,
                error_mm,
            } => write!(
                f,
                "'{measurement}' could not be fitted within {limit_mm} mm (error {error_mm:.1} mm)"
            ),
            Self::MeasuringFailed { reason } => {
                write!(f, "measuring the measurements not given failed: {reason}")
            }
            Self::Text { text } => f.write_str(text),
        }
    }
}

/// A list of warnings as a report holds it, read from either form: coded
/// objects (this version) or the plain strings of older reports
/// ([`Warning::Text`]). For `#[serde(deserialize_with = ...)]`.
pub fn list_from_either<'de, D, W>(d: D) -> Result<Vec<W>, D::Error>
where
    D: Deserializer<'de>,
    W: Deserialize<'de> + From<String>,
{
    #[derive(Deserialize)]
    #[serde(untagged)]
    enum Item<W> {
        Coded(W),
        Text(String),
    }
    let items = Vec::<Item<W>>::deserialize(d)?;
    Ok(items
        .into_iter()
        .map(|i| match i {
            Item::Coded(w) => w,
            Item::Text(t) => W::from(t),
        })
        .collect())
}

impl From<String> for Warning {
    fn from(text: String) -> Self {
        Self::Text { text }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[derive(Debug, Deserialize, Serialize)]
    struct Holder {
        #[serde(deserialize_with = "list_from_either")]
        warnings: Vec<Warning>,
    }

    #[test]
    fn coded_warnings_round_trip_and_old_strings_read_as_text() {
        let all = vec![
            Warning::SolverStopped {
                stage: PredictStage::Step2,
                round: 1,
                reason: "line search failed".into(),
            },
            Warning::Step2KeptEarlier {
                end: 3.0,
                step1: 2.0,
                kept_round: Some((2, 1.5)),
            },
            Warning::NotFitted {
                measurement: "chest".into(),
                limit_mm: 2.0,
                error_mm: 2.94,
            },
        ];
        let json = serde_json::to_string(&Holder {
            warnings: all.clone(),
        })
        .unwrap();
        assert!(json.contains(r#""code":"not-fitted""#), "{json}");
        let back: Holder = serde_json::from_str(&json).unwrap();
        assert_eq!(back.warnings, all);
        let old: Holder =
            serde_json::from_str(r#"{"warnings":["step 2 flipped 1 and collapsed 0 triangles"]}"#)
                .unwrap();
        assert_eq!(
            old.warnings,
            vec![Warning::Text {
                text: "step 2 flipped 1 and collapsed 0 triangles".into()
            }]
        );
    }

    #[test]
    fn the_english_text_is_the_one_reports_had() {
        let w = Warning::NotFitted {
            measurement: "chest".into(),
            limit_mm: 2.0,
            error_mm: 2.94,
        };
        assert_eq!(
            w.to_string(),
            "'chest' could not be fitted within 2 mm (error 2.9 mm)"
        );
        let w = Warning::Step2KeptEarlier {
            end: 1234.5,
            step1: 1000.0,
            kept_round: None,
        };
        assert_eq!(
            w.to_string(),
            "step 2 ended with a higher measurement energy than step 1 (E_m 1.2345e3 vs 1.0000e3 mm^4): kept the step-1 shape"
        );
    }
}
