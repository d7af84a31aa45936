//! Checking each reading the moment it is captured: does it fit what the
//! readings already taken predict?
//!
//! Why here and not at the end: an operator who hears "chest 58.0 cm is 6.1
//! SD below what the other readings predict (88 ± 5 cm): measure again"
//! while the tape is still round the customer re-measures in seconds; found
//! at the estimate, the customer may be gone.
//!
//! The statistics are the estimator's ([`Estimator::predict_reading`]): the
//! Gaussian of real people (ANSUR II train split) conditioned on the other
//! readings when the measurement follows an ANSUR column, else the model's
//! joint Gaussian of the training population (the same conditional as
//! `ShapeModel::conditional_measurements`), every reading's ISO 20685-1
//! tolerance added as noise, exactly as [`Estimator::check`] judges a whole set
//! before estimating. The first reading is judged by the marginal. Only the
//! new reading is judged (one small conditional per capture), so a reading
//! kept earlier despite a flag does not blame every later one.
//!
//! Levels: `|z| <= `[`WARN_Z`] is [`Flag::Ok`]; up to [`FLAG_Z`] a
//! [`Flag::Warn`] ("check it"); beyond, a [`Flag::Flag`] ("measure again"),
//! the level at which the estimate warns (`CONDITIONAL_Z_WARN`). A value
//! far off that becomes typical when its number is read in another unit is
//! a unit slip ("waist 32.0 cm fits 32.0 in (81.3 cm): check the tape's
//! unit"), flagged. Both the unit slip and "the estimate will refuse it"
//! are the estimator's own rules ([`tapeshape_estimator::unit_slip`],
//! [`ReadingPrediction::refuses`]), so the capture-time check and the
//! estimate cannot disagree about either.

use serde::Serialize;
pub use tapeshape_estimator::UnitSlip;
use tapeshape_estimator::{
    unit_slip, Estimator, Length, PredictError, ReadingPrediction, Reference, Unit,
    CONDITIONAL_Z_WARN,
};

use crate::i18n::{self, msg, FluentArgs, Lang};

/// Above this many SDs from the prediction a reading is a [`Flag::Warn`]
/// (3 SD: about 1 honest reading in 370 under a Gaussian).
pub const WARN_Z: f64 = 3.0;
/// Above this many SDs it is a [`Flag::Flag`] (the estimator's warning level).
pub const FLAG_Z: f64 = CONDITIONAL_Z_WARN;

/// How a reading fits.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub enum Flag {
    /// Within [`WARN_Z`] SDs of the prediction.
    Ok,
    /// Unusual: worth a second look.
    Warn,
    /// Far off or a unit slip: measure again.
    Flag,
}

/// The verdict on one captured reading.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ReadingCheck {
    /// Measurement name.
    pub name: String,
    /// The reading, metres.
    pub value: f64,
    /// `(value - predicted_mean) / predicted_sd`.
    pub z: f64,
    /// What the other readings (or the population) predict, metres.
    pub predicted_mean: f64,
    /// Its SD with the reading's own tolerance added, metres.
    pub predicted_sd: f64,
    /// The population the prediction comes from.
    pub reference: Reference,
    /// Number of readings the prediction is conditioned on (0: the marginal).
    pub conditioned_on: usize,
    /// The level.
    pub flag: Flag,
    /// A unit that explains a far-off value, if any.
    pub unit_slip: Option<UnitSlip>,
    /// The unit the tape showed (the messages' numbers are in it).
    #[serde(skip)]
    pub shown: Unit,
    /// True when the estimate would refuse the set with this reading in it
    /// (both references place it beyond the estimator's refusal level).
    pub estimate_refuses: bool,
    /// One line for the operator (in the shown unit).
    pub message: String,
}

/// [`check_reading_shown`] with the reading shown in centimetres.
pub fn check_reading(
    estimator: &Estimator,
    taken: &[(&str, f64)],
    new: (&str, f64),
) -> Result<ReadingCheck, PredictError> {
    check_reading_shown(estimator, taken, new, Unit::Cm)
}

/// Checks the reading `new` (name, metres) against the readings `taken`
/// (name, metres, in capture order; a later reading of a name replaces an
/// earlier one, and readings of `new`'s own name are left out, since a
/// retake replaces them). `shown` is the unit the operator saw the number
/// in, used for messages and unit-slip detection.
///
/// Errors: an unknown measurement name (with suggestions), a value that is
/// not a positive finite length (in `new` or `taken`).
pub fn check_reading_shown(
    estimator: &Estimator,
    taken: &[(&str, f64)],
    new: (&str, f64),
    shown: Unit,
) -> Result<ReadingCheck, PredictError> {
    check_reading_with_tolerance(estimator, taken, new, shown, None)
}

/// [`check_reading_shown`] for an operator whose readings have a known
/// standard uncertainty `tolerance` (metres; e.g. 0.01 for a novice, as in
/// the paper's real-measurement experiment): every reading's error is taken
/// as `tolerance` instead of its measurement's ISO 20685-1 class (a few mm),
/// so an honest novice reading is not flagged because the other readings
/// predict it to within a centimetre (heights do: see
/// `docs/results/demo-e2e.md`). `None`: the ISO classes.
pub fn check_reading_with_tolerance(
    estimator: &Estimator,
    taken: &[(&str, f64)],
    new: (&str, f64),
    shown: Unit,
    tolerance: Option<f64>,
) -> Result<ReadingCheck, PredictError> {
    let (name, value) = new;
    if !(value.is_finite() && value > 0.0) {
        return Err(PredictError::BadValue(format!(
            "{name} is {value} m: a length must be positive and finite; measure again"
        )));
    }
    let mut others: Vec<(&str, f64)> = Vec::new();
    for &(n, v) in taken {
        if n == name {
            continue;
        }
        match others.iter_mut().find(|o| o.0 == n) {
            Some(o) => o.1 = v,
            None => others.push((n, v)),
        }
    }
    let p = estimator.predict_reading_with_tolerance(name, &others, tolerance)?;
    Ok(judge(name, value, shown, &p))
}

/// The verdict for `value` (metres) of `name` under the prediction `p`.
fn judge(name: &str, value: f64, shown: Unit, p: &ReadingPrediction) -> ReadingCheck {
    let z = p.z(value);
    let number = value / shown.metres();
    let reading = Length {
        metres: value,
        unit: shown,
        unit_typed: true,
        number,
    };
    let unit_slip = unit_slip(&reading, p.mean, p.sd);
    let flag = if unit_slip.is_some() || z.abs() > FLAG_Z {
        Flag::Flag
    } else if z.abs() > WARN_Z {
        Flag::Warn
    } else {
        Flag::Ok
    };
    let estimate_refuses = p.refuses(value);
    let sym = shown.symbol();
    let show = |m: f64| m / shown.metres();
    let source = match (p.conditioned_on, p.reference) {
        (0, Reference::RealPeople) => "what is typical for people".to_string(),
        (0, Reference::Training) => "what is typical for the model's population".to_string(),
        (1, _) => "what the other reading predicts".to_string(),
        _ => "what the other readings predict".to_string(),
    };
    let prediction = format!("({:.0} ± {:.0} {sym})", show(p.mean), show(p.sd));
    let message = if let Some(s) = unit_slip {
        format!(
            "{name} {:.1} {sym} fits {:.1} {} ({:.1} {sym}): check the tape's unit",
            number,
            s.number,
            s.unit.symbol(),
            show(s.metres)
        )
    } else {
        let side = if z > 0.0 { "above" } else { "below" };
        match flag {
            Flag::Ok => format!("{name} {:.1} {sym} fits {source} {prediction}", number),
            Flag::Warn => format!(
                "{name} {:.1} {sym} is {:.1} SD {side} {source} {prediction}: check it",
                number,
                z.abs()
            ),
            Flag::Flag => format!(
                "{name} {:.1} {sym} is {:.1} SD {side} {source} {prediction}: measure again{}",
                number,
                z.abs(),
                if estimate_refuses {
                    " (the estimate will refuse it)"
                } else {
                    ""
                }
            ),
        }
    };
    ReadingCheck {
        name: name.to_string(),
        value,
        z,
        predicted_mean: p.mean,
        predicted_sd: p.sd,
        reference: p.reference,
        conditioned_on: p.conditioned_on,
        flag,
        unit_slip,
        shown,
        estimate_refuses,
        message,
    }
}

impl ReadingCheck {
    /// [`ReadingCheck::message`] for the operator, in `lang`, with the
    /// measurement called `label` (the kiosk's name of it; the English
    /// message uses the measurement's name). Numbers keep a decimal point,
    /// as the tape shows them. Catalogue keys `check-*`.
    pub fn message_in(&self, lang: Lang, label: &str) -> String {
        let sym = self.shown.symbol();
        let show = |m: f64| m / self.shown.metres();
        let mut args = FluentArgs::new();
        args.set("name", label.to_string());
        args.set("value", format!("{:.1}", show(self.value)));
        args.set("unit", sym);
        if let Some(s) = &self.unit_slip {
            args.set("number", format!("{:.1}", s.number));
            args.set("other", s.unit.symbol());
            args.set("metres", format!("{:.1}", show(s.metres)));
            return i18n::text_in(lang, msg!("check-unit-slip"), Some(&args));
        }
        args.set(
            "prediction",
            format!(
                "({:.0} ± {:.0} {sym})",
                show(self.predicted_mean),
                show(self.predicted_sd)
            ),
        );
        let source = match (self.conditioned_on, self.reference) {
            (0, Reference::RealPeople) => msg!("check-source-people"),
            (0, Reference::Training) => msg!("check-source-population"),
            (1, _) => msg!("check-source-other"),
            _ => msg!("check-source-others"),
        };
        args.set("source", i18n::text_in(lang, source, None));
        args.set("z", format!("{:.1}", self.z.abs()));
        let id = match (self.flag, self.z > 0.0, self.estimate_refuses) {
            (Flag::Ok, _, _) => msg!("check-fits"),
            (Flag::Warn, true, _) => msg!("check-warn-above"),
            (Flag::Warn, false, _) => msg!("check-warn-below"),
            (Flag::Flag, true, false) => msg!("check-flag-above"),
            (Flag::Flag, false, false) => msg!("check-flag-below"),
            (Flag::Flag, true, true) => msg!("check-flag-above-refused"),
            (Flag::Flag, false, true) => msg!("check-flag-below-refused"),
        };
        i18n::text_in(lang, id, Some(&args))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use tapeshape_estimator::{Input, Inputs, Length};

    fn estimator() -> &'static Estimator {
        Estimator::default_model().expect("embedded model")
    }

    fn taken() -> Vec<(&'static str, f64)> {
        // An average-ish man (metres).
        vec![("stature", 1.76), ("hip", 1.00), ("waist", 0.88)]
    }

    #[test]
    fn the_prediction_itself_scores_zero_and_k_sd_off_scores_k() {
        let e = estimator();
        let p = e.predict_reading("chest", &taken()).expect("predicts");
        assert_eq!(p.conditioned_on, 3);
        for k in [-5.0, -2.5, 0.0, 1.0, 3.5, 6.0] {
            let v = p.mean + k * p.sd;
            let c = check_reading(e, &taken(), ("chest", v)).unwrap();
            assert!((c.z - k).abs() < 1e-9, "k {k}: z {}", c.z);
            assert_eq!(c.predicted_mean, p.mean);
            let want = if k.abs() > FLAG_Z {
                Flag::Flag
            } else if k.abs() > WARN_Z {
                Flag::Warn
            } else {
                Flag::Ok
            };
            assert_eq!(c.flag, want, "k {k}: {}", c.message);
        }
    }

    /// The kiosk's sentence comes from the catalogue: in English it is the
    /// line mode's sentence word for word (with the name given), for every
    /// kind (fits, check it, measure again, refused, a unit slip); in
    /// German every kind is German and keeps the numbers.
    #[test]
    fn the_operator_sentence_in_english_is_the_line_modes_and_german_is_german() {
        let e = estimator();
        let p = e.predict_reading("chest", &taken()).expect("predicts");
        let mut cases: Vec<ReadingCheck> = [0.5, -3.5, 4.2, 4.5, 5.0, -4.5, -7.0, 40.0]
            .iter()
            .map(|k| check_reading(e, &taken(), ("chest", p.mean + k * p.sd)).unwrap())
            .collect();
        // A waist typed as 33 cm that is 33 in: a unit slip.
        cases.push(
            check_reading_with_tolerance(e, &taken()[..2], ("waist", 0.33), Unit::Cm, None)
                .unwrap(),
        );
        cases.push(check_reading(e, &[], ("stature", 1.75)).unwrap());
        let kinds: Vec<(Flag, bool, bool)> = cases
            .iter()
            .map(|c| (c.flag, c.unit_slip.is_some(), c.estimate_refuses))
            .collect();
        for want in [
            (Flag::Ok, false, false),
            (Flag::Warn, false, false),
            (Flag::Flag, false, false),
        ] {
            assert!(kinds.contains(&want), "{want:?} not among {kinds:?}");
        }
        assert!(kinds.iter().any(|k| k.1), "a unit slip: {kinds:?}");
        assert!(
            kinds.iter().any(|k| !k.1 && k.2),
            "a refused one: {kinds:?}"
        );
        for c in &cases {
            assert_eq!(c.message_in(Lang::En, &c.name), c.message);
            let de = c.message_in(Lang::De, "Brustumfang");
            assert!(de.starts_with("Brustumfang "), "{de}");
            let german = [
                "passt zu dem",
                "SD über dem",
                "SD unter dem",
                "Einheit am Maßband",
            ];
            assert!(german.iter().any(|w| de.contains(w)), "{de}");
            // The numbers are the English sentence's.
            let number = |t: &str| {
                t.split_whitespace()
                    .filter(|w| w.chars().next().is_some_and(|ch| ch.is_ascii_digit()))
                    .map(str::to_string)
                    .collect::<Vec<_>>()
            };
            assert_eq!(number(&de), number(&c.message), "{de} / {}", c.message);
        }
    }

    #[test]
    fn agrees_with_the_engines_whole_set_check() {
        // Estimator::check judges every reading against all others; for the
        // last reading that is exactly this check's conditional.
        let e = estimator();
        let mut inputs = Inputs::new();
        let all = [
            ("stature", 1.76),
            ("hip", 1.00),
            ("waist", 0.88),
            ("chest", 0.99),
        ];
        for (n, v) in all {
            inputs
                .push(Input {
                    name: n.into(),
                    value: Length {
                        metres: v,
                        unit: Unit::Cm,
                        unit_typed: true,
                        number: v * 100.0,
                    },
                    tolerance: None,
                })
                .unwrap();
        }
        let (checks, _) = e.check(&inputs).unwrap();
        let c = check_reading(e, &all[..3], all[3]).unwrap();
        let last = &checks[3];
        assert!((last.conditional_z.unwrap() - c.z).abs() < 1e-9);
        assert!((last.predicted_mm.unwrap() - 1000.0 * c.predicted_mean).abs() < 1e-6);
        assert!((last.predicted_sd_mm.unwrap() - 1000.0 * c.predicted_sd).abs() < 1e-6);
    }

    #[test]
    fn first_reading_uses_the_marginal() {
        let e = estimator();
        let c = check_reading(e, &[], ("stature", 1.75)).unwrap();
        assert_eq!(c.conditioned_on, 0);
        assert_eq!(c.reference, Reference::RealPeople);
        // ANSUR II stature: men and women together, about 1.71 +/- 0.09 m.
        assert!(
            (1.65..1.78).contains(&c.predicted_mean),
            "{}",
            c.predicted_mean
        );
        assert!((0.06..0.12).contains(&c.predicted_sd), "{}", c.predicted_sd);
        assert_eq!(c.flag, Flag::Ok, "{}", c.message);
        assert!(c.message.contains("typical for people"), "{}", c.message);
        // A retake of the same name is not its own evidence.
        let again = check_reading(e, &[("stature", 1.20)], ("stature", 1.75)).unwrap();
        assert_eq!(again.z, c.z);
    }

    #[test]
    fn a_chest_far_below_the_others_is_flagged_with_a_message() {
        let e = estimator();
        let c = check_reading(e, &taken(), ("chest", 0.58)).unwrap();
        assert_eq!(c.flag, Flag::Flag);
        assert!(c.z < -FLAG_Z, "z {}", c.z);
        assert!(c.unit_slip.is_none(), "{:?}", c.unit_slip);
        assert!(
            c.message.starts_with("chest 58.0 cm is ")
                && c.message
                    .contains("SD below what the other readings predict (")
                && c.message.ends_with("measure again")
                    | c.message.ends_with("(the estimate will refuse it)"),
            "{}",
            c.message
        );
    }

    #[test]
    fn an_inch_reading_taken_as_cm_is_a_unit_slip() {
        let e = estimator();
        // 32 in = 81.3 cm, a typical waist for this hip and stature.
        let c = check_reading(e, &taken()[..2], ("waist", 0.32)).unwrap();
        let slip = c.unit_slip.expect("inch slip detected");
        assert_eq!(slip.unit, Unit::In);
        assert!((slip.metres - 0.8128).abs() < 1e-12);
        assert_eq!(c.flag, Flag::Flag);
        assert_eq!(
            c.message,
            "waist 32.0 cm fits 32.0 in (81.3 cm): check the tape's unit"
        );
        // Shown in inches, a centimetre number read as inches slips the other way.
        let c = check_reading_shown(e, &taken()[..2], ("waist", 88.0 * 0.0254), Unit::In).unwrap();
        assert_eq!(c.unit_slip.map(|s| s.unit), Some(Unit::Cm), "{}", c.message);
        // A normal reading is no slip.
        let ok = check_reading(e, &taken()[..2], ("waist", 0.86)).unwrap();
        assert!(ok.unit_slip.is_none());
    }

    #[test]
    fn a_stated_tolerance_replaces_the_iso_class_as_reading_noise() {
        let e = estimator();
        // First reading (the marginal): sd^2 = population variance + noise^2,
        // so the two SDs differ by exactly the two noise variances.
        let iso = e.set().definitions[e.set().index_of("stature").unwrap()]
            .tolerance
            .mm()
            / 1000.0;
        let plain = check_reading(e, &[], ("stature", 1.75)).unwrap();
        let novice =
            check_reading_with_tolerance(e, &[], ("stature", 1.75), Unit::Cm, Some(0.01)).unwrap();
        assert_eq!(plain.predicted_mean, novice.predicted_mean);
        let diff = novice.predicted_sd.powi(2) - plain.predicted_sd.powi(2);
        assert!(
            (diff - (0.01f64.powi(2) - iso * iso)).abs() < 1e-12,
            "{diff}"
        );
        // Given other readings, a 1 cm tolerance widens the prediction, so
        // a reading 2 cm off scores lower.
        let p = e.predict_reading("chest", &taken()).unwrap();
        let v = p.mean + 0.02;
        let tight = check_reading(e, &taken(), ("chest", v)).unwrap();
        let loose =
            check_reading_with_tolerance(e, &taken(), ("chest", v), Unit::Cm, Some(0.01)).unwrap();
        assert!(loose.predicted_sd > tight.predicted_sd);
        assert!(loose.z.abs() < tight.z.abs());
        assert!(matches!(
            check_reading_with_tolerance(e, &[], ("stature", 1.75), Unit::Cm, Some(0.0)),
            Err(PredictError::BadValue(_))
        ));
    }

    #[test]
    fn bad_values_and_names_are_errors() {
        let e = estimator();
        assert!(matches!(
            check_reading(e, &[], ("stature", 0.0)),
            Err(PredictError::BadValue(_))
        ));
        assert!(matches!(
            check_reading(e, &[], ("stature", f64::NAN)),
            Err(PredictError::BadValue(_))
        ));
        assert!(matches!(
            check_reading(e, &[("stature", -1.0)], ("waist", 0.8)),
            Err(PredictError::BadValue(_))
        ));
        let err = check_reading(e, &[], ("statue", 1.7)).unwrap_err();
        assert!(err.to_string().contains("did you mean `stature`"), "{err}");
    }
}
