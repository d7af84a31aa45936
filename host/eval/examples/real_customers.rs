//! Every ANSUR II test-split person through the station's estimator (the
//! embedded default model, default settings), writing a results page.
//!
//! ```text
//! cargo run --release -p tapeshape-eval --example real_customers -- \
//!     --set quick --sex --out docs/results/real-customers-quick.md [--per-sex N]
//! ```
//!
//! Options: `--set quick|ansur` (the input), `--sex` (give each person's
//! sex), `--per-sex N` (the first N of each sex by id; default all),
//! `--leave-out COLUMN` (repeatable: an ANSUR column not entered),
//! `--model FILE` (a model file instead of the embedded default: measure a
//! candidate before `scripts/rebuild-default-model.sh` embeds it),
//! `--out FILE` (the Markdown page; default: print it).

use std::process::ExitCode;

use tapeshape_eval::customers::{markdown, run, CustomersOptions};

fn main() -> ExitCode {
    let mut opts = CustomersOptions {
        input_set: "quick".into(),
        with_sex: false,
        per_sex: None,
        leave_out: Vec::new(),
        options: tapeshape_estimator::PredictOptions::default(),
    };
    let mut out = None;
    let mut model: Option<String> = None;
    let args: Vec<String> = std::env::args().skip(1).collect();
    let mut it = args.iter();
    while let Some(a) = it.next() {
        let mut value = |what: &str| {
            it.next()
                .cloned()
                .ok_or_else(|| format!("{a} needs {what}"))
        };
        let r: Result<(), String> = match a.as_str() {
            "--set" => value("a set name").map(|v| opts.input_set = v),
            "--sex" => {
                opts.with_sex = true;
                Ok(())
            }
            "--per-sex" => value("a count").and_then(|v| {
                v.parse()
                    .map(|n| opts.per_sex = Some(n))
                    .map_err(|e| format!("--per-sex {v}: {e}"))
            }),
            "--no-real-people" => {
                opts.options.real_people = Some(None);
                Ok(())
            }
            "--leave-out" => value("an ANSUR column").map(|v| opts.leave_out.push(v)),
            "--out" => value("a file").map(|v| out = Some(v)),
            "--model" => value("a model file").map(|v| model = Some(v)),
            other => Err(format!("unknown argument {other} (see the file's docs)")),
        };
        if let Err(e) = r {
            eprintln!("error: {e}");
            return ExitCode::from(2);
        }
    }
    let owned;
    let loaded = match &model {
        None => tapeshape_estimator::Estimator::default_model(),
        Some(path) => match tapeshape_estimator::Estimator::load(std::path::Path::new(path)) {
            Ok(e) => {
                owned = e;
                Ok(&owned)
            }
            Err(e) => Err(e),
        },
    };
    let estimator = match loaded {
        Ok(e) => e,
        Err(e) => {
            eprintln!("error: {e}");
            return ExitCode::FAILURE;
        }
    };
    let result = match run(estimator, &opts) {
        Ok(r) => r,
        Err(e) => {
            eprintln!("error: {e}");
            return ExitCode::FAILURE;
        }
    };
    let command = format!(
        "cargo run --release -p tapeshape-eval --example real_customers -- {}",
        args.join(" ")
    );
    let page = markdown(&result, &opts, &command);
    let (iso, _) = result.iso_pass();
    let held = if result.dims.is_empty() {
        "no dimension held out".to_string()
    } else {
        let (b, s, p) = result.overall();
        let followable = match result.overall_followable() {
            None => "none the mesh can follow".to_string(),
            Some(f) => format!(
                "the {} the mesh can follow: {:.2} / {:.2} = {:.3}, worst {} {:.2} x",
                f.count,
                f.body_mm,
                f.ols_sex_mm,
                f.ratio(),
                f.worst_column,
                f.worst_ratio
            ),
        };
        format!(
            "other dims MAE: body {b:.2} mm, LS with sex {s:.2}, pooled {p:.2}, ratio {:.3} | {followable}",
            b / s
        )
    };
    eprintln!(
        "people {} refused {} | {held} | ISO {:.1} % | {:.0} s",
        result.people.len(),
        result.refused(),
        100.0 * iso,
        result.seconds
    );
    match out {
        Some(f) => {
            if let Err(e) =
                tapeshape_common::fs::write_atomic(std::path::Path::new(&f), page.as_bytes())
            {
                eprintln!("error: writing {f}: {e}");
                return ExitCode::FAILURE;
            }
        }
        None => print!("{page}"),
    }
    ExitCode::SUCCESS
}
