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

use tapeshape_measure::MeasurementSet;
use tapeshape_population::ansur::{Ansur, Sex, Split};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let set_name = std::env::args().nth(1).unwrap_or_else(|| "quick".into());
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
