//! An estimate's warnings in the operator's language.
//!
//! The estimator and the model say what happened as a code with its values
//! ([`tapeshape_estimator::Warning`]); their English text stays in the JSON
//! report. Here each code is worded from the catalogue (`warn-*` keys of
//! `locales/<lang>/station.ftl`). The English catalogue says exactly what the
//! codes' own English text says (a test holds them together), so an English
//! station shows the same words as the report.
//!
//! Layer: words, beside [`crate::text`]; it imports nothing of the station
//! but the catalogue.

use tapeshape_estimator::warning::{AgainstOthers, ModelWarning, OutOfRange, Step1Objective};
use tapeshape_estimator::{PredictError, PredictStage, Unit, Warning};

use crate::i18n::{self, msg, FluentArgs, Lang};

/// `w` in the chosen language ([`i18n::lang`]).
pub fn warning_text(w: &Warning) -> String {
    warning_text_in(i18n::lang(), w)
}

/// `w` in `lang`: the catalogue's `warn-*` message with the warning's
/// values (numbers to the precision the English report uses).
pub fn warning_text_in(lang: Lang, w: &Warning) -> String {
    let t = |id: &str, args: &FluentArgs| i18n::text_in(lang, id, Some(args));
    let mut a = FluentArgs::new();
    match w {
        Warning::NoUnit { measurements, unit } => {
            a.set("names", measurements.join(", "));
            a.set("unit", unit_word(lang, *unit));
            t(msg!("warn-no-unit"), &a)
        }
        Warning::KeptOutOfRange(o) => {
            a.set("what", out_of_range(lang, o));
            t(msg!("warn-kept"), &a)
        }
        Warning::KeptAgainstOthers(o) => {
            a.set("what", against_others(lang, o));
            t(msg!("warn-kept"), &a)
        }
        Warning::CheckAgainstOthers(o) => {
            a.set("what", against_others(lang, o));
            t(msg!("warn-check-reading"), &a)
        }
        Warning::UnusualSet {
            mahalanobis,
            readings,
            percent_closer,
        } => {
            a.set("distance", format!("{mahalanobis:.1}"));
            a.set("n", *readings);
            a.set("percent", format!("{percent_closer:.1}"));
            t(msg!("warn-unusual-set"), &a)
        }
        Warning::EstimatedWithKept {
            measurements,
            percent_closer,
            mahalanobis,
        } => {
            a.set("names", measurements.join(", "));
            a.set("percent", format!("{percent_closer:.1}"));
            a.set("distance", format!("{mahalanobis:.1}"));
            t(msg!("warn-estimated-with-kept"), &a)
        }
        Warning::RecordedNotFitted { measurements } => {
            a.set("names", measurements.join(", "));
            a.set("n", measurements.len());
            t(msg!("warn-recorded-not-fitted"), &a)
        }
        Warning::RecordedSumOfParts { measurement, parts } => {
            a.set("name", measurement.as_str());
            a.set("parts", parts.join(" + "));
            t(msg!("warn-recorded-sum-of-parts"), &a)
        }
        Warning::Model(m) => model_warning(lang, m),
    }
}

/// A refusal of the estimator in the chosen language, where it is one the
/// operator can act on (a reading beyond the population, readings that
/// contradict each other); `None` for the others, whose English text
/// stands.
pub fn refusal_text(e: &PredictError) -> Option<String> {
    refusal_text_in(i18n::lang(), e)
}

/// [`refusal_text`] in `lang`.
pub fn refusal_text_in(lang: Lang, e: &PredictError) -> Option<String> {
    let mut a = FluentArgs::new();
    match e {
        PredictError::OutOfPopulation { reading, kept } => {
            let what = out_of_range(lang, reading);
            if *kept {
                a.set("what", what);
                Some(i18n::text_in(lang, msg!("refuse-kept-beyond"), Some(&a)))
            } else {
                Some(what)
            }
        }
        PredictError::Contradiction(list) => {
            let list: Vec<String> = list.iter().map(|o| against_others(lang, o)).collect();
            a.set("list", list.join("; "));
            Some(i18n::text_in(lang, msg!("refuse-contradiction"), Some(&a)))
        }
        _ => None,
    }
}

fn model_warning(lang: Lang, w: &ModelWarning) -> String {
    let t = |id: &str, args: &FluentArgs| i18n::text_in(lang, id, Some(args));
    let mut a = FluentArgs::new();
    match w {
        ModelWarning::SolverStopped {
            stage,
            round,
            reason,
        } => {
            a.set("stage", stage_word(lang, *stage));
            a.set("round", *round);
            a.set("reason", reason.clone());
            t(msg!("warn-solver-stopped"), &a)
        }
        ModelWarning::ZeroLength { stage, measurement } => {
            a.set("stage", stage_word(lang, *stage));
            a.set("name", measurement.clone());
            t(msg!("warn-zero-length"), &a)
        }
        ModelWarning::Step1KeptStart {
            objective,
            end,
            start,
        } => {
            let o = match objective {
                Step1Objective::MapObjective => msg!("warn-objective-map"),
                Step1Objective::MeasurementEnergy => msg!("warn-objective-energy"),
            };
            a.set("objective", i18n::text_in(lang, o, None));
            a.set("end", format!("{end:.4e}"));
            a.set("start", format!("{start:.4e}"));
            t(msg!("warn-step1-kept-start"), &a)
        }
        ModelWarning::Step2KeptEarlier {
            end,
            step1,
            kept_round,
        } => {
            a.set("end", format!("{end:.4e}"));
            a.set("step1", format!("{step1:.4e}"));
            match kept_round {
                Some((round, e)) => {
                    a.set("round", *round);
                    a.set("kept", format!("{e:.4e}"));
                    t(msg!("warn-step2-kept-round"), &a)
                }
                None => t(msg!("warn-step2-kept-step1"), &a),
            }
        }
        ModelWarning::TrianglesChanged { flipped, collapsed } => {
            a.set("flipped", *flipped);
            a.set("collapsed", *collapsed);
            t(msg!("warn-triangles"), &a)
        }
        ModelWarning::Step1Smoothed { folded, left } => {
            a.set("folded", *folded);
            a.set("left", *left);
            t(msg!("warn-step1-smoothed"), &a)
        }
        ModelWarning::FoldsSmoothed { folded, left } => {
            a.set("folded", *folded);
            a.set("left", *left);
            t(msg!("warn-folds-smoothed"), &a)
        }
        ModelWarning::SurfaceOverReadings {
            folded,
            left,
            readings,
        } => {
            a.set("folded", *folded);
            a.set("left", *left);
            if readings.is_empty() {
                t(msg!("warn-surface-over-readings-none"), &a)
            } else {
                a.set("names", readings.join(", "));
                t(msg!("warn-surface-over-readings"), &a)
            }
        }
        ModelWarning::SoftPullReduced { pull, asked } => {
            a.set("pull", format!("{:.0}", 100.0 * pull));
            a.set("asked", format!("{:.0}", 100.0 * asked));
            t(msg!("warn-soft-pull-reduced"), &a)
        }
        ModelWarning::FarFromPopulation {
            mahalanobis,
            readings,
            held_sd,
        } => {
            a.set("distance", format!("{mahalanobis:.1}"));
            a.set("n", *readings);
            a.set("sd", format!("{held_sd}"));
            t(msg!("warn-far-from-population"), &a)
        }
        ModelWarning::NotFitted {
            measurement,
            limit_mm,
            error_mm,
        } => {
            a.set("name", measurement.clone());
            a.set("limit", format!("{limit_mm}"));
            a.set("error", format!("{error_mm:.1}"));
            t(msg!("warn-not-fitted"), &a)
        }
        ModelWarning::MeasuringFailed { reason } => {
            a.set("reason", reason.clone());
            t(msg!("warn-measuring-failed"), &a)
        }
        // Older reports: English text only, shown as it is.
        ModelWarning::Text { text } => text.clone(),
    }
}

fn out_of_range(lang: Lang, o: &OutOfRange) -> String {
    let mut a = FluentArgs::new();
    a.set("name", o.measurement.clone());
    a.set("typed", format!("{} {}", o.number, o.unit.symbol()));
    a.set(
        "typical",
        format!("{:.1} cm +/- {:.1}", o.typical_cm, o.typical_sd_cm),
    );
    let id = match o.slip {
        Some(u) => {
            a.set("unit", unit_word(lang, u));
            a.set("number", format!("{}", o.number));
            a.set("symbol", u.symbol());
            if o.unit_typed {
                msg!("warn-unit-slip")
            } else {
                a.set("bare", unit_word(lang, o.unit));
                msg!("warn-unit-slip-bare")
            }
        }
        None => {
            a.set("cm", format!("{:.1}", o.cm));
            a.set("z", format!("{:.0}", o.z.abs()));
            if o.z > 0.0 {
                msg!("warn-out-of-range-above")
            } else {
                msg!("warn-out-of-range-below")
            }
        }
    };
    i18n::text_in(lang, id, Some(&a))
}

fn against_others(lang: Lang, o: &AgainstOthers) -> String {
    let mut a = FluentArgs::new();
    let list = o.others.join(", ");
    let others = if o.more > 0 {
        let mut m = FluentArgs::new();
        m.set("list", list);
        m.set("n", o.more);
        i18n::text_in(lang, msg!("warn-others-more"), Some(&m))
    } else {
        list
    };
    a.set("name", o.measurement.clone());
    a.set("cm", format!("{:.1}", o.cm));
    a.set("z", format!("{:.0}", o.z.abs()));
    a.set("others", others);
    a.set("mu", format!("{:.1}", o.predicted_cm));
    a.set("sd", format!("{:.1}", o.sd_cm));
    // One other reading "predicts", more "predict": two messages, since a
    // plural selector alone would drop its number from the text.
    let one = o.others.len() + o.more == 1;
    let id = match (one, o.z > 0.0) {
        (true, true) => msg!("warn-against-one-above"),
        (true, false) => msg!("warn-against-one-below"),
        (false, true) => msg!("warn-against-others-above"),
        (false, false) => msg!("warn-against-others-below"),
    };
    i18n::text_in(lang, id, Some(&a))
}

fn unit_word(lang: Lang, u: Unit) -> String {
    let id = match u {
        Unit::Mm => msg!("warn-unit-mm"),
        Unit::Cm => msg!("warn-unit-cm"),
        Unit::M => msg!("warn-unit-m"),
        Unit::In => msg!("warn-unit-in"),
    };
    i18n::text_in(lang, id, None)
}

fn stage_word(lang: Lang, s: PredictStage) -> String {
    match s {
        PredictStage::Step1 => i18n::text_in(lang, msg!("warn-stage-step1"), None),
        PredictStage::Step2 => i18n::text_in(lang, msg!("warn-stage-step2"), None),
        // The model words only step 1 and step 2 warnings; any other stage
        // keeps its English name.
        other => other.to_string(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// One warning of every code (and both branches where a code has two
    /// wordings), with values that show every number's precision.
    fn every_warning() -> Vec<Warning> {
        let oor = OutOfRange {
            measurement: "neck".into(),
            number: 52.5,
            unit: Unit::Cm,
            unit_typed: true,
            cm: 52.5,
            z: 7.26,
            typical_cm: 38.04,
            typical_sd_cm: 2.11,
            slip: None,
        };
        let ao = AgainstOthers {
            measurement: "hip".into(),
            cm: 130.04,
            z: -9.4,
            others: vec![
                "stature".into(),
                "chest".into(),
                "waist".into(),
                "neck".into(),
            ],
            more: 2,
            predicted_cm: 101.26,
            sd_cm: 3.04,
        };
        vec![
            Warning::NoUnit {
                measurements: vec!["chest".into(), "waist".into()],
                unit: Unit::Cm,
            },
            Warning::KeptOutOfRange(oor.clone()),
            Warning::KeptOutOfRange(OutOfRange {
                z: -8.0,
                ..oor.clone()
            }),
            Warning::KeptOutOfRange(OutOfRange {
                number: 1750.0,
                unit: Unit::Cm,
                slip: Some(Unit::Mm),
                ..oor.clone()
            }),
            Warning::KeptOutOfRange(OutOfRange {
                number: 175.0,
                unit: Unit::Cm,
                unit_typed: false,
                slip: Some(Unit::In),
                ..oor
            }),
            Warning::KeptAgainstOthers(ao.clone()),
            Warning::CheckAgainstOthers(AgainstOthers {
                z: 3.6,
                others: vec!["stature".into()],
                more: 0,
                ..ao
            }),
            Warning::UnusualSet {
                mahalanobis: 4.26,
                readings: 9,
                percent_closer: 99.51,
            },
            Warning::EstimatedWithKept {
                measurements: vec!["neck".into(), "hip".into()],
                percent_closer: 99.99,
                mahalanobis: 13.04,
            },
            Warning::RecordedNotFitted {
                measurements: vec!["chestbreadth".into()],
            },
            Warning::RecordedNotFitted {
                measurements: vec!["chestbreadth".into(), "bicristalbreadth".into()],
            },
            Warning::RecordedSumOfParts {
                measurement: "sleeveoutseam".into(),
                parts: vec![
                    "acromionradialelength".into(),
                    "radialestylionlength".into(),
                ],
            },
            Warning::Model(ModelWarning::SolverStopped {
                stage: PredictStage::Step2,
                round: 1,
                reason: "line search failed".into(),
            }),
            Warning::Model(ModelWarning::ZeroLength {
                stage: PredictStage::Step1,
                measurement: "wrist".into(),
            }),
            Warning::Model(ModelWarning::Step1KeptStart {
                objective: Step1Objective::MapObjective,
                end: 12.5,
                start: 3.25,
            }),
            Warning::Model(ModelWarning::Step1KeptStart {
                objective: Step1Objective::MeasurementEnergy,
                end: 1.0e6,
                start: 2.5e5,
            }),
            Warning::Model(ModelWarning::Step2KeptEarlier {
                end: 3.0e4,
                step1: 2.0e4,
                kept_round: Some((2, 1.5e4)),
            }),
            Warning::Model(ModelWarning::Step2KeptEarlier {
                end: 3.0e4,
                step1: 2.0e4,
                kept_round: None,
            }),
            Warning::Model(ModelWarning::TrianglesChanged {
                flipped: 3,
                collapsed: 1,
            }),
            Warning::Model(ModelWarning::Step1Smoothed {
                folded: 87,
                left: 0,
            }),
            Warning::Model(ModelWarning::FoldsSmoothed { folded: 9, left: 2 }),
            Warning::Model(ModelWarning::SurfaceOverReadings {
                folded: 4,
                left: 0,
                readings: vec!["waist_depth".into(), "crotch_height".into()],
            }),
            Warning::Model(ModelWarning::SurfaceOverReadings {
                folded: 2,
                left: 0,
                readings: Vec::new(),
            }),
            Warning::Model(ModelWarning::SoftPullReduced {
                pull: 0.5,
                asked: 1.0,
            }),
            Warning::Model(ModelWarning::FarFromPopulation {
                mahalanobis: 11.26,
                readings: 4,
                held_sd: 3.0,
            }),
            Warning::Model(ModelWarning::NotFitted {
                measurement: "chest".into(),
                limit_mm: 2.0,
                error_mm: 2.94,
            }),
            Warning::Model(ModelWarning::MeasuringFailed {
                reason: "support empty".into(),
            }),
            Warning::from("a warning of an older report".to_string()),
        ]
    }

    #[test]
    fn the_english_catalogue_says_what_the_report_says() {
        for w in every_warning() {
            assert_eq!(warning_text_in(Lang::En, &w), w.to_string(), "{w:?}");
        }
    }

    fn refusals() -> Vec<PredictError> {
        let ao = |name: &str, z: f64| AgainstOthers {
            measurement: name.into(),
            cm: 125.0,
            z,
            others: vec!["hip".into()],
            more: 0,
            predicted_cm: 84.26,
            sd_cm: 4.0,
        };
        let oor = OutOfRange {
            measurement: "waist".into(),
            number: 300.0,
            unit: Unit::Cm,
            unit_typed: true,
            cm: 300.0,
            z: 21.3,
            typical_cm: 86.0,
            typical_sd_cm: 11.2,
            slip: None,
        };
        vec![
            PredictError::Contradiction(vec![ao("waist", 9.8), ao("chest", -7.1)]),
            PredictError::OutOfPopulation {
                reading: Box::new(oor.clone()),
                kept: false,
            },
            PredictError::OutOfPopulation {
                reading: Box::new(oor),
                kept: true,
            },
        ]
    }

    #[test]
    fn refusals_say_in_english_what_the_estimator_says_and_german_keeps_the_numbers() {
        for e in refusals() {
            let en = refusal_text_in(Lang::En, &e).expect("worded");
            assert_eq!(en, e.to_string());
            let de = refusal_text_in(Lang::De, &e).expect("worded");
            assert_ne!(de, en);
            assert_eq!(numbers(&de), numbers(&en), "{en}\n{de}");
        }
        assert_eq!(
            refusal_text_in(Lang::De, &PredictError::Input("x".into())),
            None
        );
    }

    /// The numbers of a text, sorted (German wording, same figures).
    fn numbers(s: &str) -> Vec<String> {
        let mut v: Vec<String> = s
            .split(|c: char| !(c.is_ascii_digit() || c == '.' || c == 'e'))
            .map(|p| p.trim_matches(|c| c == '.' || c == 'e').to_string())
            .filter(|p| p.chars().any(|c| c.is_ascii_digit()))
            .collect();
        v.sort();
        v
    }

    #[test]
    fn german_words_every_code_with_its_numbers() {
        for w in every_warning() {
            let de = warning_text_in(Lang::De, &w);
            let en = w.to_string();
            if matches!(w, Warning::Model(ModelWarning::Text { .. })) {
                assert_eq!(de, en);
                continue;
            }
            assert_ne!(de, en, "{w:?} has no German wording");
            // The numbers the English text shows are in the German one too.
            assert_eq!(numbers(&de), numbers(&en), "{en}\n{de}");
        }
    }
}
