//! How step 2's solvers go on every ANSUR II test-split person (issue 12
//! and 13): their real values of an input set entered into the station's
//! estimator (embedded default model, default settings, with sex), and
//! from each report: whether the smooth basis's body was kept
//! (`tapeshape_model::Step2First`) or L-BFGS had to run after it, step 2's
//! objective evaluations, flipped triangles, how many bodies step 2 pulled
//! the soft targets less for (`soft-pull-reduced`), and each prediction's
//! wall time (the people run on every core, so a body's time is not one
//! core's; `predict` in the estimator's bench is; a refused person's time
//! counts too).
//!
//! The evaluations are those of the runs the report keeps: the kept
//! body's. Where L-BFGS ran after the smooth basis, its runs (about 100
//! evaluations a round) replace the smooth basis's in the report; a body
//! a soft-pull retry replaced is not counted. So the total moves with how
//! many bodies needed L-BFGS as much as with the smooth basis's own work.
//!
//! ```text
//! cargo run --release -p tapeshape-eval --example step2_survey -- --set quick [--soft-pull S] [--ansur-survey]
//! ```
//!
//! Options: `--help` lists them. Prints one line. Why it exists: a change
//! to step 2's solver moves these counts over real people, not only on the
//! bench's one generated body (`docs/results/predict-bench.md`,
//! 2026-12-07).

use std::process::ExitCode;
use std::time::Instant;

use clap::Parser;
use rayon::prelude::*;
use tapeshape_estimator::{Estimator, PredictOptions};
use tapeshape_eval::customers::{
    entered_readings, inputs_of, test_people, with_soft_pull, CustomersOptions,
};
use tapeshape_model::Warning;
use tapeshape_population::ansur::Ansur;

/// How step 2's solvers go on every ANSUR II test-split person.
#[derive(Parser)]
// A flag given twice takes its last value, as the hand-written loop did.
#[command(args_override_self = true)]
struct Args {
    /// The input set: `quick` or `ansur` (or another built-in set or a set
    /// file); its measurements with an ANSUR column are entered.
    #[arg(long, default_value = "quick", value_parser = tapeshape_eval::customers::known_set)]
    set: String,
    /// The values are ANSUR's own, as `tapeshape predict --ansur-survey`
    /// takes them: the dimensions the standing mesh cannot take as ANSUR
    /// does are recorded, not fitted.
    #[arg(long)]
    ansur_survey: bool,
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

/// One person's prediction, as counted.
struct Counted {
    refused: bool,
    first_kept: bool,
    evaluations: u64,
    flipped: usize,
    pull_reduced: bool,
    seconds: f64,
}

fn real_main(args: Args) -> Result<(), String> {
    let Args {
        set,
        ansur_survey: survey,
        soft_pull,
    } = args;
    let mut options = PredictOptions::default();
    if let Some(pull) = soft_pull {
        options = with_soft_pull(&options, pull).map_err(|e| format!("--soft-pull {pull}: {e}"))?;
    }
    let estimator = Estimator::default_model().map_err(|e| e.to_string())?;
    let opts = CustomersOptions {
        input_set: set,
        with_sex: true,
        per_sex: None,
        leave_out: Vec::new(),
        ansur_survey: survey,
        options: options.clone(),
    };
    let entered = entered_readings(estimator, &opts).map_err(|e| e.to_string())?;
    let ansur = Ansur::get().map_err(|e| e.to_string())?;
    let people = test_people(ansur, None);
    let wall = Instant::now();
    let counted: Vec<Counted> = people
        .par_iter()
        .map(|s| {
            let mut inputs = inputs_of(s, &entered, true);
            inputs.ansur_survey = survey;
            let t = Instant::now();
            let estimate = estimator.predict(&inputs, &options);
            let seconds = t.elapsed().as_secs_f64();
            match estimate {
                Ok(e) => {
                    let r = &e.report.prediction;
                    Counted {
                        refused: false,
                        first_kept: r.step2_first.as_ref().is_some_and(|f| f.kept),
                        evaluations: r.step2_runs.iter().map(|x| x.evaluations).sum(),
                        flipped: r.plausibility.flipped_triangles,
                        pull_reduced: r
                            .warnings
                            .iter()
                            .any(|w| matches!(w, Warning::SoftPullReduced { .. })),
                        seconds,
                    }
                }
                Err(_) => Counted {
                    refused: true,
                    first_kept: false,
                    evaluations: 0,
                    flipped: 0,
                    pull_reduced: false,
                    seconds,
                },
            }
        })
        .collect();
    let n = counted.len();
    if n == 0 {
        return Err("no test-split people".into());
    }
    let count = |f: &dyn Fn(&Counted) -> bool| counted.iter().filter(|c| f(c)).count();
    let mut times: Vec<f64> = counted.iter().map(|c| c.seconds * 1e3).collect();
    times.sort_by(f64::total_cmp);
    println!(
        "people {n}, refused {}, smooth basis kept {}, step-2 evaluations {}, flipped triangles {} on {} bodies, soft pull reduced {} | ms per body: mean {:.1}, median {:.1}, p95 {:.1} | wall {:.0} s",
        count(&|c| c.refused),
        count(&|c| c.first_kept),
        counted.iter().map(|c| c.evaluations).sum::<u64>(),
        counted.iter().map(|c| c.flipped).sum::<usize>(),
        count(&|c| c.flipped > 0),
        count(&|c| c.pull_reduced),
        times.iter().sum::<f64>() / n as f64,
        times[n / 2],
        times[(n * 95 / 100).min(n - 1)],
        wall.elapsed().as_secs_f64(),
    );
    Ok(())
}
