//! What an operator enters: measurement readings with units, from the command
//! line (`stature=176.5cm`) or a file (TOML, JSON or a one-row CSV).
//!
//! Why a unit is kept with every reading: the station never guesses a unit
//! silently. A value typed with its unit (`176.5cm`, `1765mm`, `1.765m`,
//! `69.5in`) is taken as typed; a bare number is read as **centimetres** (what
//! a fitting-room tape shows and what an operator types) and the report says
//! so. The typed text is kept so that a unit slip can be explained in the
//! operator's own words ("stature 1.76 cm looks like metres").

use std::collections::BTreeMap;
use std::path::Path;

use serde::{Deserialize, Serialize};

use tapeshape_population::ansur::Sex;

use crate::PredictError;

/// A length unit an operator may type.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Unit {
    /// Millimetres.
    Mm,
    /// Centimetres.
    Cm,
    /// Metres.
    M,
    /// Inches.
    In,
}

impl Unit {
    /// All units, for messages and unit-slip checks.
    pub const ALL: [Unit; 4] = [Unit::Mm, Unit::Cm, Unit::M, Unit::In];

    /// Metres per unit.
    pub fn metres(self) -> f64 {
        match self {
            Unit::Mm => 0.001,
            Unit::Cm => 0.01,
            Unit::M => 1.0,
            Unit::In => 0.0254,
        }
    }

    /// The unit's symbol as typed (`mm`, `cm`, `m`, `in`).
    pub fn symbol(self) -> &'static str {
        match self {
            Unit::Mm => "mm",
            Unit::Cm => "cm",
            Unit::M => "m",
            Unit::In => "in",
        }
    }

    /// The unit's name in prose ("millimetres", ...).
    pub fn word(self) -> &'static str {
        match self {
            Unit::Mm => "millimetres",
            Unit::Cm => "centimetres",
            Unit::M => "metres",
            Unit::In => "inches",
        }
    }

    /// Parses a unit symbol (`mm`, `cm`, `m`, `in`, `inch`, `inches`, `"`),
    /// case-insensitively.
    pub fn parse(text: &str) -> Option<Unit> {
        match text.trim().to_ascii_lowercase().as_str() {
            "mm" | "millimetre" | "millimetres" | "millimeter" | "millimeters" => Some(Unit::Mm),
            "cm" | "centimetre" | "centimetres" | "centimeter" | "centimeters" => Some(Unit::Cm),
            "m" | "metre" | "metres" | "meter" | "meters" => Some(Unit::M),
            "in" | "inch" | "inches" | "\"" => Some(Unit::In),
            _ => None,
        }
    }
}

/// The unit a bare number is read in (what a tape shows and an operator types).
pub const BARE_NUMBER_UNIT: Unit = Unit::Cm;

/// A length as entered: its value in metres, the unit it was read in, and
/// whether that unit was typed or assumed.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Length {
    /// Value, metres.
    pub metres: f64,
    /// The unit the number was read in.
    pub unit: Unit,
    /// False when the number had no unit and [`BARE_NUMBER_UNIT`] (or a
    /// file-level unit) was taken.
    pub unit_typed: bool,
    /// The number as typed (without its unit).
    pub number: f64,
}

/// Parses a length such as `176.5cm`, `1765 mm`, `1.765m`, `69.5in` or
/// `69.5"`. A bare number is read in `default_unit` (the file's `unit`, else
/// [`BARE_NUMBER_UNIT`]). Errors say what was wrong and how to write it.
pub fn parse_length(text: &str, default_unit: Option<Unit>) -> Result<Length, String> {
    let t = text.trim();
    if t.is_empty() {
        return Err("no value given: write it with a unit, e.g. 98cm".into());
    }
    let split = t
        .find(|c: char| !(c.is_ascii_digit() || matches!(c, '.' | '-' | '+' | 'e' | 'E' | ',')))
        .unwrap_or(t.len());
    // "1e3" is a number but "1 e" is not a unit: keep the exponent only when
    // digits follow it; otherwise let the unit parser see the letters.
    let (mut num, mut rest) = t.split_at(split);
    if num.ends_with(['e', 'E']) {
        num = &t[..split - 1];
        rest = &t[split - 1..];
    }
    if num.contains(',') {
        return Err(format!(
            "'{t}': write the decimal point as '.', e.g. {}",
            t.replace(',', ".")
        ));
    }
    let number: f64 = num.parse().map_err(|_| {
        format!("'{t}' is not a length: write a number and a unit, e.g. 176.5cm, 1765mm, 1.765m or 69.5in")
    })?;
    let rest = rest.trim();
    let (unit, unit_typed) = if rest.is_empty() {
        (default_unit.unwrap_or(BARE_NUMBER_UNIT), false)
    } else {
        match Unit::parse(rest) {
            Some(u) => (u, true),
            None => return Err(format!("'{t}': unknown unit '{rest}'; use mm, cm, m or in")),
        }
    };
    Ok(Length {
        metres: number * unit.metres(),
        unit,
        unit_typed,
        number,
    })
}

/// One reading to fit.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Input {
    /// Measurement name (as in the model's sets).
    pub name: String,
    /// The value as entered.
    pub value: Length,
    /// Standard uncertainty of the reading, metres (a novice's tape reading
    /// is worth less than a digital one); `None`: trusted.
    pub tolerance: Option<f64>,
}

/// The readings of one customer: measurement name -> value (metres) and
/// optional tolerance. Names are unique; order is kept for reports.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct Inputs {
    /// The readings in the order entered.
    pub readings: Vec<Input>,
    /// The customer's sex when it was given: the estimate then follows the
    /// statistics of real people of that sex (ANSUR II train split) for
    /// what was not measured. `None`: both sexes pooled.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub sex: Option<Sex>,
    /// Readings the operator kept after a check flagged them (by name): an
    /// unusual value among these is estimated with a warning instead of
    /// refused; only impossible values are refused then.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub kept: Vec<String>,
    /// The values were taken as the ANSUR II survey takes them (its
    /// instruments and postures: calipers that compress the tissue, flexed
    /// girths), as in survey data. Readings of the dimensions the standing
    /// body model cannot take that way
    /// ([`crate::priors::CANNOT_FOLLOW_ANSUR`], matched by the measurement's
    /// ANSUR column) are then recorded, not fitted. `false` (the station):
    /// each reading was taken as its measurement's description asks, which
    /// the body follows.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub ansur_survey: bool,
}

impl Inputs {
    /// No readings.
    pub fn new() -> Self {
        Self::default()
    }

    /// Adds a reading already in metres (library callers and tests).
    /// Errors if the name was given before.
    pub fn insert_metres(&mut self, name: &str, metres: f64) -> Result<(), PredictError> {
        self.push(Input {
            name: name.to_string(),
            value: Length {
                metres,
                unit: Unit::M,
                unit_typed: true,
                number: metres,
            },
            tolerance: None,
        })
    }

    /// Adds a reading; errors if its name was given before.
    pub fn push(&mut self, input: Input) -> Result<(), PredictError> {
        if self.readings.iter().any(|r| r.name == input.name) {
            return Err(PredictError::Input(format!(
                "'{}' is given twice: give each measurement once",
                input.name
            )));
        }
        self.readings.push(input);
        Ok(())
    }

    /// Parses `name=value` (e.g. `stature=176.5cm`) and adds it.
    pub fn add_assignment(&mut self, text: &str) -> Result<(), PredictError> {
        let (name, value) = text.split_once('=').ok_or_else(|| {
            PredictError::Input(format!(
                "'{text}' is not name=value: write e.g. --measure stature=176.5cm"
            ))
        })?;
        let name = name.trim();
        if name.is_empty() {
            return Err(PredictError::Input(format!(
                "'{text}' has no measurement name before '='"
            )));
        }
        let value = parse_length(value, None)
            .map_err(|e| PredictError::Input(format!("measurement '{name}': {e}")))?;
        self.push(Input {
            name: name.to_string(),
            value,
            tolerance: None,
        })
    }

    /// Sets the tolerance of a reading already given from `name=value` (a
    /// bare number is millimetres here, as the option says).
    pub fn set_tolerance(&mut self, text: &str) -> Result<(), PredictError> {
        let (name, value) = text.split_once('=').ok_or_else(|| {
            PredictError::Input(format!(
                "'{text}' is not name=tolerance: write e.g. --tolerance chest=5mm"
            ))
        })?;
        let name = name.trim();
        let tol = parse_length(value, Some(Unit::Mm))
            .map_err(|e| PredictError::Input(format!("tolerance of '{name}': {e}")))?;
        if !(tol.metres.is_finite() && tol.metres > 0.0) {
            return Err(PredictError::Input(format!(
                "tolerance of '{name}' is {}: it must be a positive length, e.g. 5mm",
                value.trim()
            )));
        }
        let r = self
            .readings
            .iter_mut()
            .find(|r| r.name == name)
            .ok_or_else(|| {
                PredictError::Input(format!(
                    "--tolerance {name}=...: '{name}' has no reading; give it with --measure {name}=VALUE first"
                ))
            })?;
        r.tolerance = Some(tol.metres);
        Ok(())
    }

    /// Reads readings from a file; the format follows the extension:
    ///
    /// * `.toml` / `.json`: an object of `name = value` where a value is a
    ///   number, a string with a unit (`"98cm"`), or a table
    ///   `{ value = "98cm", tolerance = "5mm" }`; an optional top-level
    ///   `unit = "cm"` says what bare numbers are.
    /// * `.csv`: a header row of names and one row of values (an optional
    ///   `unit` column gives the unit of bare numbers).
    pub fn from_file(path: &Path) -> Result<Self, PredictError> {
        let text = std::fs::read_to_string(path).map_err(|source| PredictError::Io {
            path: path.display().to_string(),
            source,
        })?;
        let ext = path
            .extension()
            .and_then(|e| e.to_str())
            .map(|e| e.to_ascii_lowercase())
            .unwrap_or_default();
        let origin = path.display().to_string();
        match ext.as_str() {
            "toml" => {
                let v: toml::Table = toml::from_str(&text)
                    .map_err(|e| PredictError::Input(format!("{origin}: not valid TOML: {e}")))?;
                let json = serde_json::to_value(v).map_err(|e| {
                    PredictError::Input(format!("{origin}: cannot read the TOML: {e}"))
                })?;
                Self::from_json_value(&json, &origin)
            }
            "json" => {
                let v: serde_json::Value = serde_json::from_str(&text)
                    .map_err(|e| PredictError::Input(format!("{origin}: not valid JSON: {e}")))?;
                Self::from_json_value(&v, &origin)
            }
            "csv" => Self::from_csv(&text, &origin),
            _ => Err(PredictError::Input(format!(
                "{origin}: unknown measurements file type '{ext}': use .toml, .json or .csv"
            ))),
        }
    }

    /// Readings from a parsed TOML or JSON object (see [`Inputs::from_file`]).
    pub fn from_json_value(v: &serde_json::Value, origin: &str) -> Result<Self, PredictError> {
        let err = |m: String| PredictError::Input(format!("{origin}: {m}"));
        let obj = v
            .as_object()
            .ok_or_else(|| err("expected a table of name = value".into()))?;
        let unit = match obj.get("unit") {
            None => None,
            Some(serde_json::Value::String(s)) => Some(
                Unit::parse(s)
                    .ok_or_else(|| err(format!("unit '{s}' is not one of mm, cm, m, in")))?,
            ),
            Some(other) => {
                return Err(err(format!(
                    "unit must be a string like \"cm\", got {other}"
                )))
            }
        };
        let length = |name: &str, v: &serde_json::Value, default: Option<Unit>| {
            match v {
                serde_json::Value::Number(n) => parse_length(&n.to_string(), default),
                serde_json::Value::String(s) => parse_length(s, default),
                other => Err(format!(
                    "expected a number or a string like \"98cm\", got {other}"
                )),
            }
            .map_err(|e| err(format!("measurement '{name}': {e}")))
        };
        let mut out = Inputs::new();
        if let Some(v) = obj.get("sex") {
            out.sex = Some(
                v.as_str()
                    .and_then(Sex::parse)
                    .ok_or_else(|| err(format!("sex is {v}: write \"female\" or \"male\"")))?,
            );
        }
        for (name, value) in obj {
            if name == "unit" || name == "sex" {
                continue;
            }
            let (value, tolerance) = match value {
                serde_json::Value::Object(t) => {
                    for k in t.keys() {
                        if k != "value" && k != "tolerance" {
                            return Err(err(format!(
                                "measurement '{name}': unknown key '{k}' (a reading has `value` and optional `tolerance`)"
                            )));
                        }
                    }
                    let v = t
                        .get("value")
                        .ok_or_else(|| err(format!("measurement '{name}' has no `value`")))?;
                    let tol = match t.get("tolerance") {
                        Some(tv) => {
                            let l = length(name, tv, Some(Unit::Mm))?;
                            if !(l.metres.is_finite() && l.metres > 0.0) {
                                return Err(err(format!(
                                    "tolerance of '{name}' must be a positive length"
                                )));
                            }
                            Some(l.metres)
                        }
                        None => None,
                    };
                    (length(name, v, unit)?, tol)
                }
                v => (length(name, v, unit)?, None),
            };
            out.push(Input {
                name: name.clone(),
                value,
                tolerance,
            })?;
        }
        mark_file_unit(&mut out, unit);
        Ok(out)
    }

    /// Readings from a CSV text: a header of names and exactly one row.
    pub fn from_csv(text: &str, origin: &str) -> Result<Self, PredictError> {
        let err = |m: String| PredictError::Input(format!("{origin}: {m}"));
        let mut rdr = csv::ReaderBuilder::new()
            .trim(csv::Trim::All)
            .from_reader(text.as_bytes());
        let header: Vec<String> = rdr
            .headers()
            .map_err(|e| err(format!("cannot read the header row: {e}")))?
            .iter()
            .map(str::to_string)
            .collect();
        let rows: Vec<csv::StringRecord> = rdr
            .records()
            .collect::<Result<_, _>>()
            .map_err(|e| err(format!("cannot read the rows: {e}")))?;
        let row = match rows.len() {
            1 => &rows[0],
            0 => return Err(err("no value row under the header".into())),
            n => {
                return Err(err(format!(
                    "{n} value rows: a measurements file holds one customer (one row)"
                )))
            }
        };
        let mut map = BTreeMap::new();
        let mut unit = None;
        let mut sex = None;
        for (name, value) in header.iter().zip(row.iter()) {
            if name == "unit" {
                unit =
                    Some(Unit::parse(value).ok_or_else(|| {
                        err(format!("unit '{value}' is not one of mm, cm, m, in"))
                    })?);
            } else if name == "sex" {
                if !value.is_empty() {
                    sex = Some(Sex::parse(value).ok_or_else(|| {
                        err(format!("sex '{value}' is not f, m, female or male"))
                    })?);
                }
            } else if !value.is_empty() {
                map.insert(name.clone(), value.to_string());
            }
        }
        let mut out = Inputs::new();
        out.sex = sex;
        for name in &header {
            let Some(value) = map.get(name) else { continue };
            let value =
                parse_length(value, unit).map_err(|e| err(format!("measurement '{name}': {e}")))?;
            out.push(Input {
                name: name.clone(),
                value,
                tolerance: None,
            })?;
        }
        mark_file_unit(&mut out, unit);
        Ok(out)
    }
}

/// A file-level `unit` states the unit of its bare numbers: they count as
/// typed (no "no unit given" note).
fn mark_file_unit(inputs: &mut Inputs, unit: Option<Unit>) {
    if unit.is_some() {
        for r in &mut inputs.readings {
            r.value.unit_typed = true;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lengths_parse_with_units() {
        let l = parse_length("176.5cm", None).unwrap();
        assert!((l.metres - 1.765).abs() < 1e-12 && l.unit_typed);
        assert!((parse_length("1765 mm", None).unwrap().metres - 1.765).abs() < 1e-12);
        assert!((parse_length("1.765m", None).unwrap().metres - 1.765).abs() < 1e-12);
        assert!((parse_length("69.5in", None).unwrap().metres - 1.7653).abs() < 1e-12);
        assert!((parse_length("69.5\"", None).unwrap().metres - 1.7653).abs() < 1e-12);
        let bare = parse_length("98", None).unwrap();
        assert!((bare.metres - 0.98).abs() < 1e-12 && !bare.unit_typed);
        assert!((parse_length("980", Some(Unit::Mm)).unwrap().metres - 0.98).abs() < 1e-12);
        assert!(parse_length("98 furlongs", None)
            .unwrap_err()
            .contains("unknown unit"));
        assert!(parse_length("98,5cm", None).unwrap_err().contains("'.'"));
        assert!(parse_length("abc", None).is_err());
        assert!(parse_length("", None).is_err());
    }

    #[test]
    fn files_parse_in_three_formats() {
        let toml = "unit = \"cm\"\nstature = 176.5\nchest = \"980mm\"\nwaist = { value = 85, tolerance = \"1cm\" }\n";
        let t: toml::Table = toml::from_str(toml).unwrap();
        let a = Inputs::from_json_value(&serde_json::to_value(t).unwrap(), "t").unwrap();
        let json = r#"{"unit":"cm","stature":176.5,"chest":"980mm","waist":{"value":85,"tolerance":"1cm"}}"#;
        let b = Inputs::from_json_value(&serde_json::from_str(json).unwrap(), "j").unwrap();
        for inputs in [&a, &b] {
            let get = |n: &str| inputs.readings.iter().find(|r| r.name == n).unwrap();
            assert!((get("stature").value.metres - 1.765).abs() < 1e-12);
            assert!((get("chest").value.metres - 0.98).abs() < 1e-12);
            assert!((get("waist").value.metres - 0.85).abs() < 1e-12);
            assert!((get("waist").tolerance.unwrap() - 0.01).abs() < 1e-12);
            assert!(inputs.readings.iter().all(|r| r.value.unit_typed));
        }
        let c = Inputs::from_csv("stature,chest,unit\n1765,980,mm\n", "c").unwrap();
        assert_eq!(c.readings.len(), 2);
        assert!((c.readings[0].value.metres - 1.765).abs() < 1e-12);
        assert!(Inputs::from_csv("stature\n1\n2\n", "c")
            .unwrap_err()
            .to_string()
            .contains("one customer"));
    }

    #[test]
    fn duplicates_and_tolerances() {
        let mut i = Inputs::new();
        i.add_assignment("chest=98cm").unwrap();
        assert!(i.add_assignment("chest=99cm").is_err());
        assert!(i.add_assignment("chest").is_err());
        i.set_tolerance("chest=5").unwrap();
        assert!((i.readings[0].tolerance.unwrap() - 0.005).abs() < 1e-12);
        assert!(i.set_tolerance("waist=5mm").is_err());
        assert!(i.set_tolerance("chest=-1mm").is_err());
    }
}
