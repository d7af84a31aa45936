//! ANSUR II, real measurements of 6,068 U.S. Army personnel (public domain),
//! embedded from `data/ansur2/` so every command works from any directory.
//!
//! The project's split rule lives here and nowhere else: subjects whose id is
//! divisible by 4 are the **test split** ([`Split::Test`]); they are never used
//! to train, fit or calibrate anything. Use [`Ansur::subjects`] with
//! [`Split::Train`] for anything that learns.
//!
//! Units: every dimension is returned in **metres** (the files hold
//! millimetres); `weightkg` (kg x 10 in the files) is returned in kilograms as
//! [`Subject::mass_kg`].

use std::collections::BTreeMap;
use std::sync::OnceLock;

/// Errors reading the embedded ANSUR II tables.
#[derive(Debug, thiserror::Error)]
pub enum AnsurError {
    /// The CSV could not be parsed.
    #[error("ANSUR II {file}: {message}")]
    Parse {
        /// Which file.
        file: &'static str,
        /// What went wrong.
        message: String,
    },
    /// A requested column does not exist.
    #[error("ANSUR II has no column `{column}`{hint}")]
    UnknownColumn {
        /// The column asked for.
        column: String,
        /// `"; did you mean `x`?"` for the closest columns, or empty.
        hint: String,
    },
}

/// Biological sex as recorded by ANSUR II.
#[derive(
    Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, serde::Serialize, serde::Deserialize,
)]
pub enum Sex {
    /// `male.csv`.
    Male,
    /// `female.csv`.
    Female,
}

impl Sex {
    /// Reads `m`, `f`, `male`, `female` (any case), as an operator or a
    /// survey file writes it; `None` for anything else.
    pub fn parse(text: &str) -> Option<Sex> {
        match text.trim().to_ascii_lowercase().as_str() {
            "m" | "male" => Some(Sex::Male),
            "f" | "female" => Some(Sex::Female),
            _ => None,
        }
    }

    /// `male` or `female`.
    pub fn word(self) -> &'static str {
        match self {
            Sex::Male => "male",
            Sex::Female => "female",
        }
    }
}

/// Which part of the fixed split.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Split {
    /// Ids not divisible by 4: may be used to train, fit and calibrate.
    Train,
    /// Ids divisible by 4: evaluation only.
    Test,
}

impl Split {
    /// The split of a subject id.
    pub fn of(id: u32) -> Split {
        if id.is_multiple_of(4) {
            Split::Test
        } else {
            Split::Train
        }
    }
}

/// One ANSUR II subject.
#[derive(Debug, Clone)]
pub struct Subject {
    /// `subjectid` / `SubjectId`.
    pub id: u32,
    /// Which file the subject came from.
    pub sex: Sex,
    /// Age in years.
    pub age_years: f64,
    /// `DODRace` code (1 White, 2 Black, 3 Hispanic, 4 Asian, 5 Native American, 6 Pacific Islander, 8 Other).
    pub dod_race: u32,
    /// Body mass in kilograms (`weightkg` / 10).
    pub mass_kg: f64,
    /// Measured dimensions, column name -> metres.
    pub dims: BTreeMap<String, f64>,
}

impl Subject {
    /// The subject's split.
    pub fn split(&self) -> Split {
        Split::of(self.id)
    }

    /// A dimension in metres, if the column exists.
    pub fn dim(&self, column: &str) -> Option<f64> {
        self.dims.get(column).copied()
    }
}

/// The whole survey, parsed once.
#[derive(Debug)]
pub struct Ansur {
    subjects: Vec<Subject>,
    columns: Vec<String>,
}

const MALE: &str = include_str!("../data/ansur2/male.csv");
const FEMALE: &str = include_str!("../data/ansur2/female.csv");

/// Columns that are not body dimensions in millimetres.
const NON_DIMENSIONS: &[&str] = &[
    "subjectid",
    "SubjectId",
    "Gender",
    "Date",
    "Installation",
    "Component",
    "Branch",
    "PrimaryMOS",
    "SubjectsBirthLocation",
    "SubjectNumericRace",
    "Ethnicity",
    "DODRace",
    "Age",
    "Heightin",
    "Weightlbs",
    "WritingPreference",
    "weightkg",
];

fn parse(
    file: &'static str,
    text: &str,
    sex: Sex,
) -> Result<(Vec<Subject>, Vec<String>), AnsurError> {
    let err = |message: String| AnsurError::Parse { file, message };
    let mut reader = csv::ReaderBuilder::new().from_reader(text.as_bytes());
    let headers: Vec<String> = reader
        .headers()
        .map_err(|e| err(e.to_string()))?
        .iter()
        .map(|h| h.trim().to_string())
        .collect();
    let find = |name: &str| headers.iter().position(|h| h.eq_ignore_ascii_case(name));
    let id_col = find("subjectid").ok_or_else(|| err("no subject id column".into()))?;
    let age_col = find("Age").ok_or_else(|| err("no Age column".into()))?;
    let race_col = find("DODRace").ok_or_else(|| err("no DODRace column".into()))?;
    let mass_col = find("weightkg").ok_or_else(|| err("no weightkg column".into()))?;
    let dim_cols: Vec<usize> = (0..headers.len())
        .filter(|&i| {
            !NON_DIMENSIONS
                .iter()
                .any(|n| n.eq_ignore_ascii_case(&headers[i]))
        })
        .collect();
    let mut subjects = Vec::new();
    for (row, rec) in reader.records().enumerate() {
        let rec = rec.map_err(|e| err(format!("row {}: {e}", row + 2)))?;
        let num = |col: usize| -> Result<f64, AnsurError> {
            rec.get(col)
                .unwrap_or("")
                .trim()
                .parse::<f64>()
                .map_err(|_| {
                    err(format!(
                        "row {}: column {} is not a number",
                        row + 2,
                        headers[col]
                    ))
                })
        };
        let mut dims = BTreeMap::new();
        for &c in &dim_cols {
            dims.insert(headers[c].clone(), num(c)? / 1000.0);
        }
        subjects.push(Subject {
            id: num(id_col)? as u32,
            sex,
            age_years: num(age_col)?,
            dod_race: num(race_col)? as u32,
            mass_kg: num(mass_col)? / 10.0,
            dims,
        });
    }
    let columns = dim_cols.iter().map(|&c| headers[c].clone()).collect();
    Ok((subjects, columns))
}

impl Ansur {
    /// The embedded survey (parsed on first use, then shared).
    pub fn get() -> Result<&'static Ansur, AnsurError> {
        static CELL: OnceLock<Result<Ansur, String>> = OnceLock::new();
        CELL.get_or_init(|| {
            let (mut subjects, columns) =
                parse("male.csv", MALE, Sex::Male).map_err(|e| e.to_string())?;
            let (female, _) =
                parse("female.csv", FEMALE, Sex::Female).map_err(|e| e.to_string())?;
            subjects.extend(female);
            Ok(Ansur { subjects, columns })
        })
        .as_ref()
        .map_err(|m| AnsurError::Parse {
            file: "male.csv/female.csv",
            message: m.clone(),
        })
    }

    /// Subjects of one sex (or both: `None`) in one split, in file order.
    pub fn subjects(&self, sex: Option<Sex>, split: Split) -> impl Iterator<Item = &Subject> + '_ {
        self.subjects
            .iter()
            .filter(move |s| s.split() == split && sex.is_none_or(|x| s.sex == x))
    }

    /// A subject by id (either split).
    pub fn subject(&self, id: u32) -> Option<&Subject> {
        self.subjects.iter().find(|s| s.id == id)
    }

    /// The dimension columns (millimetre columns of the files).
    pub fn columns(&self) -> &[String] {
        &self.columns
    }

    /// Checks that `column` exists; the error suggests the closest column.
    pub fn check_column(&self, column: &str) -> Result<(), AnsurError> {
        if self.columns.iter().any(|c| c == column) {
            return Ok(());
        }
        Err(AnsurError::UnknownColumn {
            column: column.to_string(),
            hint: tapeshape_common::suggest::did_you_mean(
                column,
                self.columns.iter().map(String::as_str),
            ),
        })
    }
}

/// Mean, standard deviation and correlation matrix of `columns` over `subjects`
/// (metres; correlation dimensionless). Shapes: mean and sd `k`, corr `k x k`.
pub fn statistics(subjects: &[&Subject], columns: &[&str]) -> (Vec<f64>, Vec<f64>, Vec<Vec<f64>>) {
    let rows: Vec<Vec<f64>> = subjects
        .iter()
        .map(|s| {
            columns
                .iter()
                .map(|c| s.dim(c).unwrap_or(f64::NAN))
                .collect()
        })
        .collect();
    crate::statistics::mean_sd_corr(&rows)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn split_sizes_and_units() {
        let a = Ansur::get().unwrap();
        let male_train = a.subjects(Some(Sex::Male), Split::Train).count();
        let male_test = a.subjects(Some(Sex::Male), Split::Test).count();
        let female = a.subjects(Some(Sex::Female), Split::Train).count()
            + a.subjects(Some(Sex::Female), Split::Test).count();
        assert_eq!(male_train + male_test, 4082);
        assert_eq!(female, 1986);
        assert_eq!((male_train, male_test), (3064, 1018));
        assert!(a.subjects(None, Split::Test).all(|s| s.id % 4 == 0));
        assert!(a.subjects(None, Split::Train).all(|s| s.id % 4 != 0));
        // The first male row: subject 10027, stature 1776 mm, 81.5 kg.
        let s = a.subject(10027).unwrap();
        assert_eq!(s.sex, Sex::Male);
        assert!((s.dim("stature").unwrap() - 1.776).abs() < 1e-12);
        assert!((s.mass_kg - 81.5).abs() < 1e-12);
        assert!(a.check_column("stature").is_ok());
        let e = a.check_column("statur").unwrap_err().to_string();
        assert!(e.contains("did you mean `stature`"), "{e}");
    }

    #[test]
    fn train_statistics_match_the_published_means() {
        // definitions.csv publishes male stature mean 1756 mm over all subjects
        // (sd 68.6); the train split must be close to it.
        let a = Ansur::get().unwrap();
        let men: Vec<&Subject> = a.subjects(Some(Sex::Male), Split::Train).collect();
        let (m, sd, corr) = statistics(&men, &["stature", "chestcircumference"]);
        assert!((m[0] - 1.7557).abs() < 0.001, "{}", m[0]);
        assert!((sd[0] - 0.0685).abs() < 0.001, "{}", sd[0]);
        assert!((corr[0][0] - 1.0).abs() < 1e-12 && corr[0][1] > 0.2 && corr[0][1] < 0.9);
    }
}
