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
//! Options: `--set quick|ansur` (the input; default quick), `--per-sex N`
//! (the first N of each sex by id; default all), `--out FILE` (the
//! Markdown page; default: print it), `--png FILE` (score histograms),
//! `--csv FILE` (every person's scores), `--model FILE` (a model file
//! instead of the embedded default), `--population FILE` (the model's
//! training population as a population table,
//! `tapeshape_eval::poptable`, made by the `population_table` example:
//! adds the two axes fitted on it; the embedded default's is
//! `host/eval/data/default-population.csv`), `--soft-pull SHARE` (step 2's
//! `tapeshape_model::Step2Settings::soft_pull` instead of the station's).

use std::path::Path;
use std::process::ExitCode;

use tapeshape_eval::customers::{run, CustomersOptions};
use tapeshape_eval::poptable::PopulationTable;
use tapeshape_eval::sexcheck::{csv, histogram, markdown, score_run, Group, SexAxis};
use tapeshape_population::ansur::Ansur;

fn main() -> ExitCode {
    match real_main() {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::FAILURE
        }
    }
}

fn real_main() -> Result<(), String> {
    let mut set = "quick".to_string();
    let mut per_sex = None;
    let (mut out, mut png, mut csv_out) = (None, None, None);
    let (mut model, mut population) = (None, None);
    let mut options = tapeshape_estimator::PredictOptions::default();
    let args: Vec<String> = std::env::args().skip(1).collect();
    let mut it = args.iter();
    while let Some(a) = it.next() {
        let mut value = |what: &str| {
            it.next()
                .cloned()
                .ok_or_else(|| format!("{a} needs {what}"))
        };
        match a.as_str() {
            "--set" => set = value("a set name")?,
            "--per-sex" => {
                let v = value("a count")?;
                per_sex = Some(v.parse().map_err(|e| format!("--per-sex {v}: {e}"))?);
            }
            "--out" => out = Some(value("a file")?),
            "--png" => png = Some(value("a file")?),
            "--csv" => csv_out = Some(value("a file")?),
            "--model" => model = Some(value("a model file")?),
            "--population" => population = Some(value("a population table")?),
            "--soft-pull" => {
                let v = value("a share in [0, 1]")?;
                let pull: f64 = v.parse().map_err(|e| format!("--soft-pull {v}: {e}"))?;
                options = tapeshape_eval::customers::with_soft_pull(&options, pull)
                    .map_err(|e| format!("--soft-pull {v}: {e}"))?;
            }
            other => return Err(format!("unknown argument {other} (see the file's docs)")),
        }
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
        args.join(" ")
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
