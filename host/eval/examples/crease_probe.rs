//! Where do the creases of bodies estimated from many readings come from?
//! For the first N ANSUR II test-split people of each sex (their real
//! values of an input set, with their sex), the estimate's step-1 shape
//! (inside the PCA space) and final shape are mixed, and each mix is judged
//! by the surface check (`tapeshape_eval::surface`, the envelope of the
//! model's training population, the rule calibrated on held-out generated
//! bodies) and by the ISO 20685-1 pass share of the entered readings
//! re-measured on it.
//!
//! ```text
//! cargo run --release -p tapeshape-eval --example crease_probe -- \
//!     --train POP.tsd --held HELD.tsd --set ansur --per-sex 8 \
//!     [--variant blend|shrink|trunc] [--l L] [--lambda X] [--bending MU] [--solver2 lbfgs|gn]
//!     [--leave-out COL,COL]
//! ```
//!
//! Options: `--help` lists them (the two datasets, the input set, how many
//! people, the way of mixing, step 1's clamp, step 2's smoothness, bending
//! and solver, columns left out). Also printed: how many of step 1's
//! weights sit at the clamp (|w| > 0.999 l). The embedded default model.

use std::path::Path;
use std::process::ExitCode;

use clap::{Parser, ValueEnum};
use rayon::prelude::*;
use tapeshape_eval::customers::{
    entered_readings, inputs_of, measuring_set, test_people, within_iso, CustomersOptions,
};
use tapeshape_eval::surface::SurfaceCheck;
use tapeshape_population::ansur::Ansur;
use tapeshape_population::Dataset;

/// Where the creases of bodies estimated from many readings come from: the
/// estimate's step-1 shape and final shape mixed, each mix judged by the
/// surface check and the ISO 20685-1 pass share of the entered readings.
#[derive(Parser)]
// A flag given twice takes its last value (the hand-written lookup took
// the first).
#[command(args_override_self = true)]
struct Args {
    /// The model's training population: the surface check's envelope.
    #[arg(long, value_name = "POP.tsd")]
    train: String,
    /// Held-out generated bodies: the surface check's rule is calibrated
    /// on them.
    #[arg(long, value_name = "HELD.tsd")]
    held: String,
    /// The input set: `ansur` or `quick` (or another built-in set or a set
    /// file); its measurements with an ANSUR column are entered, with each
    /// person's sex.
    #[arg(long, default_value = "ansur", value_parser = tapeshape_eval::customers::known_set)]
    set: String,
    /// The first N test-split people of each sex by id.
    #[arg(long, value_name = "N", default_value_t = 8)]
    per_sex: usize,
    /// How step 1's shape and the result are mixed, for a mixing factor
    /// `a` from 1 to 0.
    #[arg(long, value_enum, default_value_t = Variant::Blend)]
    variant: Variant,
    /// Step 1's clamp of the normalised PCA weights, in SDs
    /// (`tapeshape_estimator::PredictOptions::l`; default: the station's).
    #[arg(long, value_name = "L", allow_negative_numbers = true)]
    l: Option<f64>,
    /// Step 2's smoothness weight
    /// (`tapeshape_estimator::PredictOptions::lambda`; default: the
    /// station's).
    #[arg(long, value_name = "X", allow_negative_numbers = true)]
    lambda: Option<f64>,
    /// Step 2's bending term
    /// (`tapeshape_estimator::PredictOptions::bending`; default: the
    /// station's).
    #[arg(long, value_name = "MU", allow_negative_numbers = true)]
    bending: Option<f64>,
    /// Step 2's solver: `lbfgs` (the station's) or `gn` (sparse
    /// Gauss-Newton); the rest as the station's, its real-people soft
    /// targets kept.
    #[arg(long, value_enum, default_value_t = Solver2::Lbfgs)]
    solver2: Solver2,
    /// ANSUR II columns not entered, separated by commas (`A,B`).
    #[arg(
        long,
        value_name = "COL,COL",
        value_delimiter = ',',
        action = clap::ArgAction::Set
    )]
    leave_out: Vec<String>,
}

/// `--variant`'s values.
#[derive(Clone, Copy, ValueEnum)]
enum Variant {
    /// The vertices `x1 + a (x2 - x1)` between step 1's shape `x1` and the
    /// result `x2`.
    Blend,
    /// The PCA shape of `a` times step 1's weights.
    Shrink,
    /// The PCA shape of step 1's first `100 a` weights.
    Trunc,
}

impl Variant {
    /// The name `--variant` takes, for the printed heading.
    fn name(self) -> &'static str {
        match self {
            Variant::Blend => "blend",
            Variant::Shrink => "shrink",
            Variant::Trunc => "trunc",
        }
    }
}

/// `--solver2`'s values.
#[derive(Clone, Copy, ValueEnum)]
enum Solver2 {
    /// L-BFGS, the station's.
    Lbfgs,
    /// Sparse Gauss-Newton.
    Gn,
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

/// Per mixing factor: (passes the surface check, share of edges beyond,
/// readings within ISO, readings).
type Row = Vec<(bool, f64, usize, usize)>;

fn real_main(args: Args) -> Result<(), String> {
    let Args {
        train,
        held,
        set,
        per_sex,
        variant,
        l,
        lambda,
        bending,
        solver2,
        leave_out,
    } = args;
    let est = tapeshape_estimator::Estimator::default_model().map_err(|e| e.to_string())?;
    // The station's pipeline (with its real-people soft targets), with the
    // clamp and smoothness given.
    // `--solver2 gn`: step 2 by the sparse Gauss-Newton solver, the rest
    // as the station's (its real-people soft targets kept).
    let mut station = tapeshape_model::PredictSettings::default();
    match solver2 {
        Solver2::Lbfgs => {}
        Solver2::Gn => {
            station.step2.solver = tapeshape_model::Step2Solver::GaussNewton {
                stop: Default::default(),
            }
        }
    }
    let options = tapeshape_estimator::PredictOptions {
        pipeline: tapeshape_estimator::Pipeline::Custom(Box::new(station)),
        real_people: Some(Some(tapeshape_estimator::RealPeople::default())),
        l,
        lambda,
        bending,
        ..Default::default()
    };
    let l = options.settings().l;
    let opts = CustomersOptions {
        input_set: set.clone(),
        with_sex: true,
        per_sex: Some(per_sex),
        leave_out,
        ansur_survey: false,
        options,
    };
    let read = |f: &str| Dataset::read(Path::new(f)).map_err(|e| format!("{f}: {e}"));
    let check = SurfaceCheck::from_datasets(&read(&train)?, Some(&read(&held)?))
        .map_err(|e| e.to_string())?;
    let entered = entered_readings(est, &opts).map_err(|e| e.to_string())?;
    let (union, compiled) = measuring_set(est).map_err(|e| e.to_string())?;
    let ansur = Ansur::get().map_err(|e| e.to_string())?;
    let people = test_people(ansur, Some(per_sex));
    let factors = [1.0, 0.75, 0.5, 0.35, 0.25, 0.1, 0.0];
    let model = &est.file().model;
    let results: Vec<Result<(Row, usize), String>> = people
        .par_iter()
        .map(|s| {
            let e = est
                .predict(&inputs_of(s, &entered, true), &opts.options)
                .map_err(|e| format!("subject {}: {e}", s.id))?;
            let w1 = &e.report.prediction.weights_step1;
            let at_clamp = w1.iter().filter(|w| w.abs() > 0.999 * l).count();
            let x1 = model.shape(w1).map_err(|e| e.to_string())?;
            let x2 = &e.mesh.vertices;
            let row = factors
                .iter()
                .map(|&a| {
                    let x = match variant {
                        Variant::Shrink => {
                            model.shape(&w1.iter().map(|w| a * w).collect::<Vec<_>>())
                        }
                        Variant::Trunc => {
                            let keep = (a * w1.len() as f64).round() as usize;
                            let w: Vec<f64> = w1
                                .iter()
                                .enumerate()
                                .map(|(i, w)| if i < keep { *w } else { 0.0 })
                                .collect();
                            model.shape(&w)
                        }
                        Variant::Blend => Ok(x1
                            .iter()
                            .zip(x2)
                            .map(|(p, q)| std::array::from_fn(|c| p[c] + a * (q[c] - p[c])))
                            .collect()),
                    }
                    .map_err(|e| e.to_string())?;
                    let v = check.judge(&x).map_err(|e| e.to_string())?;
                    let m = compiled.measure(&x).map_err(|e| e.to_string())?;
                    let (mut ok, mut n) = (0, 0);
                    for (name, col) in &entered {
                        let (Some(val), Some(j)) = (s.dim(col), union.index_of(name)) else {
                            continue;
                        };
                        n += 1;
                        ok += usize::from(within_iso(&union, j, m[j].value, val));
                    }
                    Ok((v.pass, v.excess.share(), ok, n))
                })
                .collect::<Result<Row, String>>()?;
            Ok((row, at_clamp))
        })
        .collect();
    let results: Vec<(Row, usize)> = results.into_iter().collect::<Result<_, _>>()?;
    let mut clamp: Vec<usize> = results.iter().map(|r| r.1).collect();
    clamp.sort_unstable();
    println!(
        "`{}` input, {} people ({per_sex} per sex), variant {}, l {l}, surface rule {:.1} deg / {:.2} %; step-1 weights at the clamp per person: median {}, range {}-{}\n",
        set,
        results.len(),
        variant.name(),
        check.rule.delta.to_degrees(),
        100.0 * check.rule.max_share,
        clamp[clamp.len() / 2],
        clamp[0],
        clamp[clamp.len() - 1]
    );
    println!("| factor | surface check passes | mean share of edges beyond | entered readings within ISO |\n|---|---|---|---|");
    for (i, a) in factors.iter().enumerate() {
        let pass = results.iter().filter(|r| r.0[i].0).count();
        let share = results.iter().map(|r| r.0[i].1).sum::<f64>() / results.len() as f64;
        let ok: usize = results.iter().map(|r| r.0[i].2).sum();
        let n: usize = results.iter().map(|r| r.0[i].3).sum();
        println!(
            "| {a:.2} | {pass} of {} | {:.3} % | {:.1} % ({ok} of {n}) |",
            results.len(),
            100.0 * share,
            100.0 * ok as f64 / n.max(1) as f64
        );
    }
    Ok(())
}
