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
//! `--ansur-survey` (the values are ANSUR's own, as `tapeshape predict
//! --ansur-survey` takes them: the dimensions the standing mesh cannot take
//! as ANSUR does are recorded, not fitted, and left out of the ISO share),
//! `--first none|smooth` (step 2's solver tried first, see
//! `tapeshape_model::Step2Settings::first`),
//! `--soft-pull SHARE` (`tapeshape_model::Step2Settings::soft_pull`),
//! `--breadths-and-depths` / `--no-breadths-and-depths` (soft targets for
//! chest depth, hip and waist breadth, waist depth, interscye I too, or
//! not: `tapeshape_estimator::RealPeople::breadths_and_depths`, on by
//! default),
//! `--model FILE` (a model file instead of the embedded default: measure a
//! candidate before `scripts/rebuild-default-model.sh` embeds it),
//! `--out FILE` (the Markdown page; default: print it),
//! `--surface-train FILE.tsd` (check every body's surface against the
//! envelope of that dataset's bodies with the calibrated rule,
//! `tapeshape_eval::surface`; the model's training population),
//! `--surface-held FILE.tsd` (calibrate the rule on those generated
//! held-out bodies instead of using the embedded model's).

use std::process::ExitCode;

use tapeshape_eval::customers::{markdown, run_with_surface, surface_markdown, CustomersOptions};
use tapeshape_eval::surface::SurfaceCheck;

fn main() -> ExitCode {
    let mut opts = CustomersOptions {
        input_set: "quick".into(),
        with_sex: false,
        per_sex: None,
        leave_out: Vec::new(),
        ansur_survey: false,
        options: tapeshape_estimator::PredictOptions::default(),
    };
    let mut out = None;
    let mut model: Option<String> = None;
    let mut surface_train: Option<String> = None;
    let mut surface_held: Option<String> = None;
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
            "--first" => value("none or smooth").and_then(|v| {
                let mut settings = opts.options.settings();
                settings.step2.first = match v.as_str() {
                    "none" => None,
                    "smooth" => Some(tapeshape_model::Step2Solver::smooth_basis()),
                    other => return Err(format!("--first {other}: none or smooth")),
                };
                // The station's real-people soft targets stay on.
                opts.options.real_people = Some(opts.options.real_people());
                opts.options.pipeline = tapeshape_estimator::Pipeline::Custom(Box::new(settings));
                Ok(())
            }),
            "--soft-pull" => value("a share in [0, 1]").and_then(|v| {
                let pull: f64 = v.parse().map_err(|e| format!("--soft-pull {v}: {e}"))?;
                opts.options = tapeshape_eval::customers::with_soft_pull(&opts.options, pull)
                    .map_err(|e| format!("--soft-pull {v}: {e}"))?;
                Ok(())
            }),
            "--breadths-and-depths" => {
                let r = opts
                    .options
                    .real_people()
                    .map(|r| tapeshape_estimator::RealPeople {
                        breadths_and_depths: true,
                        ..r
                    });
                opts.options.real_people = Some(r);
                Ok(())
            }
            "--no-breadths-and-depths" => {
                let r = opts
                    .options
                    .real_people()
                    .map(|r| tapeshape_estimator::RealPeople {
                        breadths_and_depths: false,
                        ..r
                    });
                opts.options.real_people = Some(r);
                Ok(())
            }
            "--leave-out" => value("an ANSUR column").map(|v| opts.leave_out.push(v)),
            "--ansur-survey" => {
                opts.ansur_survey = true;
                Ok(())
            }
            "--out" => value("a file").map(|v| out = Some(v)),
            "--model" => value("a model file").map(|v| model = Some(v)),
            "--surface-train" => value("a dataset file").map(|v| surface_train = Some(v)),
            "--surface-held" => value("a dataset file").map(|v| surface_held = Some(v)),
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
    let check = match &surface_train {
        None => None,
        Some(path) => {
            let read = |p: &str| {
                tapeshape_population::Dataset::read(std::path::Path::new(p))
                    .map_err(|e| format!("{p}: {e}"))
            };
            let check = read(path).and_then(|train| {
                let held = surface_held.as_deref().map(read).transpose()?;
                SurfaceCheck::from_datasets(&train, held.as_ref()).map_err(|e| e.to_string())
            });
            match check {
                Ok(c) => Some(c),
                Err(e) => {
                    eprintln!("error: the surface check: {e}");
                    return ExitCode::FAILURE;
                }
            }
        }
    };
    let result = match run_with_surface(estimator, &opts, check.as_ref()) {
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
    let mut page = markdown(&result, &opts, &command);
    if let (Some(check), Some(path)) = (&check, &surface_train) {
        let training = match &surface_held {
            None => format!("`{path}` (rule: the embedded model's)"),
            Some(h) => {
                format!("`{path}` (rule calibrated on the generated held-out bodies of `{h}`)")
            }
        };
        page.push_str(&surface_markdown(&result, check, &training));
        if let Some(sum) = result.surface_summary(5) {
            let deg = 180.0 / std::f64::consts::PI;
            eprintln!(
                "surface (margin {:.1} deg, share <= {:.3} %): {} of {} pass | share % median {:.3} p99 {:.3} max {:.3} | worst deg median {:.1} max {:.1} | worst ids {:?}",
                check.rule.delta * deg,
                100.0 * check.rule.max_share,
                sum.passed,
                sum.checked,
                100.0 * sum.share[0],
                100.0 * sum.share[1],
                100.0 * sum.share[2],
                sum.worst[0] * deg,
                sum.worst[2] * deg,
                sum.worst_people.iter().map(|p| p.0).collect::<Vec<_>>()
            );
        }
    }
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
