//! Every ANSUR II test-split person through the station's estimator (the
//! embedded default model, default settings), writing a results page.
//!
//! ```text
//! cargo run --release -p tapeshape-eval --example real_customers -- \
//!     --set quick --sex --out docs/results/real-customers-quick.md [--per-sex N]
//! ```
//!
//! Options: `--help` lists them (the input set, with or without each
//! person's sex, how many people, columns left out, step 2's settings, the
//! real-people soft targets, a model file instead of the embedded default,
//! the surface check, where the page goes).

use std::process::ExitCode;

use clap::{Parser, ValueEnum};
use tapeshape_eval::customers::{markdown, run_with_surface, surface_markdown, CustomersOptions};
use tapeshape_eval::surface::SurfaceCheck;

/// Every ANSUR II test-split person through the station's estimator (the
/// embedded default model, default settings), writing a results page.
#[derive(Parser)]
// A flag given twice takes its last value, as the hand-written loop did.
#[command(args_override_self = true)]
struct Args {
    /// The input set: `quick` or `ansur` (or another built-in set or a set
    /// file); its measurements with an ANSUR column are entered.
    #[arg(long, default_value = "quick", value_parser = tapeshape_eval::customers::known_set)]
    set: String,
    /// Give each person's sex.
    #[arg(long)]
    sex: bool,
    /// The first N of each sex by id (default: all).
    #[arg(long, value_name = "N")]
    per_sex: Option<usize>,
    /// An ANSUR column not entered (repeatable).
    #[arg(long, value_name = "COLUMN")]
    leave_out: Vec<String>,
    /// The values are ANSUR's own, as `tapeshape predict --ansur-survey`
    /// takes them: the dimensions the standing mesh cannot take as ANSUR
    /// does are recorded, not fitted, and left out of the ISO share.
    #[arg(long)]
    ansur_survey: bool,
    /// No real-people soft targets: the model alone (whatever
    /// `--breadths-and-depths` says).
    #[arg(long)]
    no_real_people: bool,
    /// Step 2's solver tried first (`tapeshape_model::Step2Settings::first`):
    /// `none` (step 2's solver alone) or `smooth` (the template's smooth
    /// basis).
    #[arg(long, value_enum)]
    first: Option<First>,
    /// Step 2's soft pull, a share in [0, 1]
    /// (`tapeshape_model::Step2Settings::soft_pull`).
    #[arg(long, value_name = "SHARE", allow_negative_numbers = true)]
    soft_pull: Option<f64>,
    /// Soft targets for chest depth, hip and waist breadth, waist depth and
    /// interscye I too (`tapeshape_estimator::RealPeople::breadths_and_depths`;
    /// on by default).
    #[arg(long, overrides_with = "no_breadths_and_depths")]
    breadths_and_depths: bool,
    /// No soft targets for those breadths and depths.
    #[arg(long, overrides_with = "breadths_and_depths")]
    no_breadths_and_depths: bool,
    /// A model file instead of the embedded default: measure a candidate
    /// before `scripts/rebuild-default-model.sh` embeds it.
    #[arg(long, value_name = "FILE")]
    model: Option<String>,
    /// The Markdown page (default: print it).
    #[arg(long, value_name = "FILE")]
    out: Option<String>,
    /// Check every body's surface against the envelope of that dataset's
    /// bodies with the calibrated rule (`tapeshape_eval::surface`): the
    /// model's training population.
    #[arg(long, value_name = "FILE.tsd")]
    surface_train: Option<String>,
    /// Calibrate the surface check's rule on those generated held-out
    /// bodies instead of using the embedded model's.
    #[arg(long, value_name = "FILE.tsd")]
    surface_held: Option<String>,
}

/// `--first`'s values.
#[derive(Clone, Copy, ValueEnum)]
enum First {
    None,
    Smooth,
}

fn main() -> ExitCode {
    // The command as given, for the page.
    let given: Vec<String> = std::env::args().skip(1).collect();
    let args = Args::parse();
    let mut opts = CustomersOptions {
        input_set: args.set,
        with_sex: args.sex,
        per_sex: args.per_sex,
        leave_out: args.leave_out,
        ansur_survey: args.ansur_survey,
        options: tapeshape_estimator::PredictOptions::default(),
    };
    // The options that change `opts.options` are applied in one fixed
    // order: --no-real-people, --first, --soft-pull, then
    // --breadths-and-depths / --no-breadths-and-depths (the last of the
    // two given wins). The hand-written loop applied them in the order
    // given, with the same result in every order: --first and --soft-pull
    // set different fields of step 2's settings and each keeps the soft
    // targets as they were; --breadths-and-depths changes only the soft
    // targets and leaves none when there are none; --no-real-people
    // leaves none whatever came before or after it.
    if args.no_real_people {
        opts.options.real_people = Some(None);
    }
    if let Some(first) = args.first {
        let mut settings = opts.options.settings();
        settings.step2.first = match first {
            First::None => None,
            First::Smooth => Some(tapeshape_model::Step2Solver::smooth_basis()),
        };
        // The station's real-people soft targets stay on.
        opts.options.real_people = Some(opts.options.real_people());
        opts.options.pipeline = tapeshape_estimator::Pipeline::Custom(Box::new(settings));
    }
    if let Some(pull) = args.soft_pull {
        match tapeshape_eval::customers::with_soft_pull(&opts.options, pull) {
            Ok(o) => opts.options = o,
            Err(e) => {
                eprintln!("error: --soft-pull {pull}: {e}");
                return ExitCode::from(2);
            }
        }
    }
    if args.breadths_and_depths || args.no_breadths_and_depths {
        let r = opts
            .options
            .real_people()
            .map(|r| tapeshape_estimator::RealPeople {
                breadths_and_depths: args.breadths_and_depths,
                ..r
            });
        opts.options.real_people = Some(r);
    }
    let (out, model) = (args.out, args.model);
    let (surface_train, surface_held) = (args.surface_train, args.surface_held);
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
        given.join(" ")
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
