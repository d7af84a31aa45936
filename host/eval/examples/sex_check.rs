//! The sex check (issue 12, item 3) on every ANSUR II test-split person:
//! their real values of an input set entered into the station's estimator
//! (embedded default model, default settings) once with their sex and once
//! without, each estimate measured with the `ansur` set and scored on the
//! discriminant axes between the sexes fitted on the train split
//! (`tapeshape_eval::sexcheck`), beside the same people's real values.
//!
//! ```text
//! cargo run --release -p tapeshape-eval --example sex_check -- \
//!     --set quick --out docs/results/sex-check/quick.md \
//!     --png docs/results/sex-check/quick.png --csv docs/results/sex-check/quick.csv
//! ```
//!
//! Options: `--help` lists them (the input set, how many people, the page,
//! histogram and CSV files, a model file, the model's training population
//! for two more axes, step 2's soft pull).

use std::path::Path;
use std::process::ExitCode;

use clap::Parser;
use tapeshape_eval::customers::{run, CustomersOptions};
use tapeshape_eval::poptable::PopulationTable;
use tapeshape_eval::sexcheck::{csv, histogram, markdown, score_run, Group, SexAxis};
use tapeshape_population::ansur::Ansur;

/// The sex check on every ANSUR II test-split person: their estimates with
/// and without their sex, scored on the discriminant axes between the sexes.
#[derive(Parser)]
// A flag given twice takes its last value, as the hand-written loop did.
#[command(args_override_self = true)]
struct Args {
    /// The input set: `quick` or `ansur` (or another built-in set or a set
    /// file); its measurements with an ANSUR column are entered.
    #[arg(long, default_value = "quick", value_parser = tapeshape_eval::customers::known_set)]
    set: String,
    /// The first N of each sex by id (default: all).
    #[arg(long, value_name = "N")]
    per_sex: Option<usize>,
    /// The Markdown page (default: print it).
    #[arg(long, value_name = "FILE")]
    out: Option<String>,
    /// Score histograms (PNG).
    #[arg(long, value_name = "FILE")]
    png: Option<String>,
    /// Every person's scores (CSV).
    #[arg(long, value_name = "FILE")]
    csv: Option<String>,
    /// A model file instead of the embedded default.
    #[arg(long, value_name = "FILE")]
    model: Option<String>,
    /// The model's training population as a population table
    /// (`tapeshape_eval::poptable`, made by the `population_table` example):
    /// adds the two axes fitted on it. The embedded default's is
    /// `host/eval/data/default-population.csv`.
    #[arg(long, value_name = "FILE")]
    population: Option<String>,
    /// Step 2's soft pull, a share in [0, 1]
    /// (`tapeshape_model::Step2Settings::soft_pull`), instead of the
    /// station's.
    #[arg(long, value_name = "SHARE", allow_negative_numbers = true)]
    soft_pull: Option<f64>,
}

fn main() -> ExitCode {
    let args = tapeshape_common::cli::parse_or_exit::<Args>();
    match real_main(args) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::FAILURE
        }
    }
}

fn real_main(args: Args) -> Result<(), String> {
    // The command as given, for the page.
    let given: Vec<String> = std::env::args().skip(1).collect();
    let Args {
        set,
        per_sex,
        out,
        png,
        csv: csv_out,
        model,
        population,
        soft_pull,
    } = args;
    let mut options = tapeshape_estimator::PredictOptions::default();
    if let Some(pull) = soft_pull {
        options = tapeshape_eval::customers::with_soft_pull(&options, pull)
            .map_err(|e| format!("--soft-pull {pull}: {e}"))?;
    }
    let ansur = Ansur::get().map_err(|e| e.to_string())?;
    let mut axes = vec![
        SexAxis::whole_body(ansur).map_err(|e| e.to_string())?,
        SexAxis::torso(ansur).map_err(|e| e.to_string())?,
    ];
    if let Some(f) = &population {
        let text = std::fs::read_to_string(f).map_err(|e| format!("reading {f}: {e}"))?;
        let table = PopulationTable::from_csv(&text).map_err(|e| format!("{f}: {e}"))?;
        axes.push(SexAxis::whole_body_population(&table).map_err(|e| e.to_string())?);
        axes.push(SexAxis::torso_population(&table).map_err(|e| e.to_string())?);
    }
    let owned;
    let estimator = match &model {
        None => tapeshape_estimator::Estimator::default_model().map_err(|e| e.to_string())?,
        Some(f) => {
            owned = tapeshape_estimator::Estimator::load(Path::new(f))
                .map_err(|e| format!("{f}: {e}"))?;
            &owned
        }
    };
    let mut groups = Vec::new();
    for (label, with_sex) in [("estimate with sex", true), ("estimate without sex", false)] {
        let opts = CustomersOptions {
            input_set: set.clone(),
            with_sex,
            per_sex,
            leave_out: Vec::new(),
            ansur_survey: false,
            options: options.clone(),
        };
        let r = run(estimator, &opts).map_err(|e| e.to_string())?;
        let people = score_run(&axes, &r, ansur).map_err(|e| e.to_string())?;
        eprintln!(
            "{label}: {} people, {} refused, {:.0} s",
            r.people.len(),
            r.refused(),
            r.seconds
        );
        groups.push(Group {
            label: label.to_string(),
            people,
            seconds: r.seconds,
        });
    }
    let command = format!(
        "cargo run --release -p tapeshape-eval --example sex_check -- {}",
        given.join(" ")
    );
    let page = markdown(&axes, &groups, &set, &command);
    let write = |f: &str, bytes: &[u8]| {
        tapeshape_common::fs::write_atomic(Path::new(f), bytes)
            .map_err(|e| format!("writing {f}: {e}"))
    };
    match &out {
        Some(f) => write(f, page.as_bytes())?,
        None => print!("{page}"),
    }
    if let Some(f) = &csv_out {
        write(f, csv(&axes, &groups).as_bytes())?;
    }
    if let Some(f) = &png {
        tapeshape_eval::figures::save(&histogram(&axes, &groups), Path::new(f))
            .map_err(|e| format!("writing {f}: {e}"))?;
    }
    for (a, rows) in axes
        .iter()
        .zip(tapeshape_eval::sexcheck::tallies(&axes, &groups))
    {
        for (label, sex, t) in rows {
            eprintln!(
                "{} | {label} | {}: {} of {} on their side, {} outside the real 99 %",
                a.name,
                sex.word(),
                t.n - t.wrong_side.len(),
                t.n,
                t.outside_99.len()
            );
        }
    }
    Ok(())
}
