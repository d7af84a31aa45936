//! Writes every ANSUR II subject (both splits, 6,068 people) as a survey
//! CSV for `tapeshape batch`: `id`, `sex` and the real values of a
//! measurement set's ANSUR columns (default: quick), in millimetres as the
//! survey recorded them. The batch benchmark's input
//! (`docs/results/predict-bench.md`).
//!
//! ```text
//! cargo run --release -p tapeshape-population --example ansur_survey_csv -- [SET] > ansur-quick.csv
//! ```
//!
//! A subject without a value for one of the columns gets an empty cell
//! (not measured), as a survey file would have it.

use std::io::Write as _;

use clap::Parser;
use tapeshape_measure::MeasurementSet;
use tapeshape_population::ansur::{Ansur, Sex, Split};

/// Writes every ANSUR II subject (both splits) as a survey CSV for
/// `tapeshape batch` on standard output: `id`, `sex` and the real values of
/// a measurement set's ANSUR columns, in millimetres.
#[derive(Parser)]
struct Args {
    /// The measurement set whose ANSUR columns are written: `quick` or
    /// `ansur` (or another built-in set or a set file).
    #[arg(default_value = "quick", value_parser = measurement_set)]
    set: String,
}

/// `SET`'s value, checked: a set `MeasurementSet::load` takes.
fn measurement_set(name: &str) -> Result<String, String> {
    MeasurementSet::load(name)
        .map(|_| name.to_string())
        .map_err(|e| e.to_string())
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args = tapeshape_common::cli::parse_or_exit::<Args>();
    let set_name = args.set;
    let set = MeasurementSet::load(&set_name)?;
    let columns: Vec<(&str, &str)> = set
        .definitions
        .iter()
        .filter_map(|d| d.ansur.as_deref().map(|c| (d.name.as_str(), c)))
        .collect();
    let ansur = Ansur::get()?;
    let mut out = std::io::BufWriter::new(std::io::stdout().lock());
    let names: Vec<&str> = columns.iter().map(|c| c.0).collect();
    writeln!(out, "id,sex,{}", names.join(","))?;
    let mut n = 0;
    for split in [Split::Train, Split::Test] {
        for s in ansur.subjects(None, split) {
            let sex = match s.sex {
                Sex::Male => "m",
                Sex::Female => "f",
            };
            let cells: Vec<String> = columns
                .iter()
                .map(|(_, c)| {
                    s.dim(c)
                        .filter(|v| v.is_finite())
                        .map_or_else(String::new, |v| format!("{:.0}mm", v * 1000.0))
                })
                .collect();
            writeln!(out, "ansur-{},{sex},{}", s.id, cells.join(","))?;
            n += 1;
        }
    }
    out.flush()?;
    eprintln!("{n} subjects, set {set_name}: {}", names.join(", "));
    Ok(())
}
