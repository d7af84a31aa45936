//! A model's training population measured as ANSUR II measures people: one
//! row per body (its sex and every ANSUR II column the `ansur` set
//! measures), written as a small CSV so that checks can use the population
//! without its 70-370 MB dataset file.
//!
//! Why: the sex check's population axes ([`crate::sexcheck::SexAxis::whole_body_population`])
//! are fitted on the bodies the model learned from, measured with the same
//! definitions as an estimate. An axis fitted on real people reads every
//! systematic offset of a mesh measurement (a crotch length that the mesh
//! measures 90 mm short on women and 25 mm short on men) as a difference
//! between the sexes; the population's own axis shares those offsets and
//! reads what sex does to the body's shape.
//!
//! The file (`host/eval/data/default-population.csv` for the embedded
//! default model, made by `scripts/rebuild-default-model.sh`):
//!
//! ```text
//! # tapeshape population table: each body measured with the `ansur` set, mm
//! # source: pop400s1.tsd (n 400, seed 1, fit twelve)
//! # model sha256: 1e03...
//! name,sex,subject,stature,acromialheight,...
//! body-0000,male,29194,1754.3,1441.0,...
//! ```
//!
//! Values are millimetres with one decimal (the tables' tolerances are
//! 4-9 mm); an empty field is a value the body lacks. Comment lines start
//! with `#`.

use rayon::prelude::*;
use tapeshape_measure::MeasurementSet;
use tapeshape_population::ansur::Sex;
use tapeshape_population::Dataset;

/// What can go wrong making or reading a population table.
#[derive(Debug, thiserror::Error)]
pub enum TableError {
    /// The text is not a population table.
    #[error("population table, line {line}: {what}")]
    Parse {
        /// 1-based line.
        line: usize,
        /// What was wrong and what was expected.
        what: String,
    },
    /// The `ansur` set could not be loaded or compiled, or a body could not
    /// be measured.
    #[error(transparent)]
    Measure(#[from] tapeshape_measure::MeasureError),
    /// The dataset has no body of known sex.
    #[error(
        "the dataset has no body of known sex: a population table needs generated bodies \
fitted to ANSUR II subjects (tapeshape dataset generate)"
    )]
    NoSex,
}

/// One body of the table.
#[derive(Debug, Clone, PartialEq)]
pub struct TableRow {
    /// The body's name in its dataset.
    pub name: String,
    /// Its sex.
    pub sex: Sex,
    /// The ANSUR II subject it was fitted to, if any.
    pub subject: Option<u32>,
    /// Per column of [`PopulationTable::columns`]: metres, `None` where the
    /// body has no value.
    pub values: Vec<Option<f64>>,
}

/// A training population's ANSUR II dimensions (see the module docs).
#[derive(Debug, Clone, PartialEq)]
pub struct PopulationTable {
    /// Where the bodies came from (free text, kept in the file's comments).
    pub source: String,
    /// The sha256 (hex) of the model trained on them, where known.
    pub model_sha256: Option<String>,
    /// ANSUR II column names, in the `ansur` set's order.
    pub columns: Vec<String>,
    /// One row per body of known sex.
    pub rows: Vec<TableRow>,
}

const HEAD: &str = "# tapeshape population table: each body measured with the `ansur` set, mm";

impl PopulationTable {
    /// Measures every body of `dataset` with a known sex with the `ansur`
    /// set (the first definition of each ANSUR II column), on all cores.
    /// `source` describes the dataset for the file's comments.
    ///
    /// Errors: the set does not compile on the dataset's topology, a body
    /// cannot be measured, no body has a sex.
    pub fn measure(dataset: &Dataset, source: &str) -> Result<PopulationTable, TableError> {
        let set = MeasurementSet::load("ansur")?;
        let compiled = set.compile(&dataset.topology, &tapeshape_body::anatomy::anatomy())?;
        let mut columns: Vec<String> = Vec::new();
        let mut index: Vec<usize> = Vec::new();
        for (j, d) in set.definitions.iter().enumerate() {
            if let Some(c) = &d.ansur {
                if !columns.contains(c) {
                    columns.push(c.clone());
                    index.push(j);
                }
            }
        }
        let rows: Vec<TableRow> = dataset
            .header
            .bodies
            .par_iter()
            .zip(dataset.bodies.par_iter())
            .filter_map(|(rec, body)| Some((rec, rec.sex?, body)))
            .map(|(rec, sex, body)| {
                let values = index
                    .iter()
                    .map(|&j| compiled.measure_one(j, body).map(|m| Some(m.value)))
                    .collect::<Result<Vec<_>, _>>()?;
                Ok(TableRow {
                    name: rec.name.clone(),
                    sex,
                    subject: rec.ansur_subject,
                    values,
                })
            })
            .collect::<Result<_, TableError>>()?;
        if rows.is_empty() {
            return Err(TableError::NoSex);
        }
        Ok(PopulationTable {
            source: source.to_string(),
            model_sha256: None,
            columns,
            rows,
        })
    }

    /// The table as CSV (see the module docs).
    pub fn to_csv(&self) -> String {
        use std::fmt::Write as _;
        let mut s = String::new();
        let _ = writeln!(s, "{HEAD}");
        let _ = writeln!(s, "# source: {}", self.source.replace('\n', " "));
        if let Some(h) = &self.model_sha256 {
            let _ = writeln!(s, "# model sha256: {h}");
        }
        let _ = writeln!(s, "name,sex,subject,{}", self.columns.join(","));
        for r in &self.rows {
            let _ = write!(
                s,
                "{},{},{}",
                r.name,
                r.sex.word(),
                r.subject.map(|i| i.to_string()).unwrap_or_default()
            );
            for v in &r.values {
                match v {
                    Some(v) => {
                        let _ = write!(s, ",{:.1}", v * 1000.0);
                    }
                    None => s.push(','),
                }
            }
            s.push('\n');
        }
        s
    }

    /// Reads a table written by [`Self::to_csv`].
    ///
    /// Errors (with the line): no header, a sex other than male/female, a
    /// row of the wrong length, a value that is not a finite number.
    pub fn from_csv(text: &str) -> Result<PopulationTable, TableError> {
        let err = |line: usize, what: String| TableError::Parse { line, what };
        let mut source = String::new();
        let mut model_sha256 = None;
        let mut columns: Option<Vec<String>> = None;
        let mut rows = Vec::new();
        for (i, line) in text.lines().enumerate() {
            let n = i + 1;
            let line = line.trim_end_matches('\r');
            if let Some(c) = line.strip_prefix('#') {
                let c = c.trim();
                if let Some(v) = c.strip_prefix("source:") {
                    source = v.trim().to_string();
                } else if let Some(v) = c.strip_prefix("model sha256:") {
                    model_sha256 = Some(v.trim().to_string());
                }
                continue;
            }
            if line.trim().is_empty() {
                continue;
            }
            let fields: Vec<&str> = line.split(',').collect();
            let Some(cols) = &columns else {
                if fields.len() < 4 || fields[..3] != ["name", "sex", "subject"] {
                    return Err(err(
                        n,
                        "expected the header `name,sex,subject,<ANSUR II columns>`".into(),
                    ));
                }
                columns = Some(fields[3..].iter().map(|c| c.to_string()).collect());
                continue;
            };
            if fields.len() != cols.len() + 3 {
                return Err(err(
                    n,
                    format!("{} fields, the header has {}", fields.len(), cols.len() + 3),
                ));
            }
            let sex = match fields[1] {
                "male" => Sex::Male,
                "female" => Sex::Female,
                other => return Err(err(n, format!("sex `{other}`: write male or female"))),
            };
            let subject = match fields[2] {
                "" => None,
                v => Some(
                    v.parse()
                        .map_err(|_| err(n, format!("subject `{v}` is not an id")))?,
                ),
            };
            let values = fields[3..]
                .iter()
                .zip(cols)
                .map(|(v, c)| match *v {
                    "" => Ok(None),
                    v => match v.parse::<f64>() {
                        Ok(x) if x.is_finite() => Ok(Some(x / 1000.0)),
                        _ => Err(err(n, format!("{c} = `{v}` is not a length in mm"))),
                    },
                })
                .collect::<Result<_, _>>()?;
            rows.push(TableRow {
                name: fields[0].to_string(),
                sex,
                subject,
                values,
            });
        }
        let Some(columns) = columns else {
            return Err(err(
                text.lines().count().max(1),
                "no header line `name,sex,subject,...`".into(),
            ));
        };
        Ok(PopulationTable {
            source,
            model_sha256,
            columns,
            rows,
        })
    }

    /// Row `r`'s value of ANSUR II column `column`, metres.
    pub fn value(&self, r: &TableRow, column: &str) -> Option<f64> {
        let j = self.columns.iter().position(|c| c == column)?;
        r.values.get(j).copied().flatten()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn table() -> PopulationTable {
        PopulationTable {
            source: "test".into(),
            model_sha256: Some("ab12".into()),
            columns: vec!["stature".into(), "footlength".into()],
            rows: vec![
                TableRow {
                    name: "body-0000".into(),
                    sex: Sex::Male,
                    subject: Some(10001),
                    values: vec![Some(1.7543), None],
                },
                TableRow {
                    name: "body-0001".into(),
                    sex: Sex::Female,
                    subject: None,
                    values: vec![Some(1.6), Some(0.2451)],
                },
            ],
        }
    }

    #[test]
    fn csv_round_trips_to_a_tenth_of_a_millimetre() {
        let t = table();
        let back = PopulationTable::from_csv(&t.to_csv()).unwrap();
        assert_eq!(back.source, t.source);
        assert_eq!(back.model_sha256, t.model_sha256);
        assert_eq!(back.columns, t.columns);
        assert_eq!(back.rows.len(), 2);
        for (a, b) in back.rows.iter().zip(&t.rows) {
            assert_eq!((a.sex, a.subject, &a.name), (b.sex, b.subject, &b.name));
            for (x, y) in a.values.iter().zip(&b.values) {
                match (x, y) {
                    (Some(x), Some(y)) => assert!((x - y).abs() <= 0.00005, "{x} vs {y}"),
                    (None, None) => {}
                    other => panic!("{other:?}"),
                }
            }
        }
        assert_eq!(back.value(&back.rows[1], "footlength"), Some(0.2451));
        assert_eq!(back.value(&back.rows[0], "footlength"), None);
        assert_eq!(back.value(&back.rows[0], "nosuch"), None);
    }

    #[test]
    fn bad_tables_name_the_line() {
        let good = table().to_csv();
        let cases = [
            (good.replace(",female,", ",woman,"), "sex `woman`"),
            (good.replace("1600.0", "abc"), "stature = `abc`"),
            (good.replace(",245.1", ""), "fields"),
            ("# only a comment\n".to_string(), "no header"),
            ("a,b\n".to_string(), "expected the header"),
        ];
        for (text, want) in cases {
            let e = PopulationTable::from_csv(&text).unwrap_err().to_string();
            assert!(e.contains(want) && e.contains("line"), "{e}");
        }
    }
}
