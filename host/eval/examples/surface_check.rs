//! The surface check (`tapeshape_eval::surface`, issue 12 "Show"): its
//! calibration on generated bodies, and the figure of test-split people.
//!
//! ```text
//! # calibration: envelope of TRAIN, shares of HELD (generated, another seed)
//! cargo run --release -p tapeshape-eval --example surface_check -- calibrate \
//!     --train /work/out/pop400s1.tsd --held /work/out/held60s2.tsd [--model FILE] [--synthetic N]
//! # figure: 6 men and 6 women of the test split, quick and ansur sets
//! cargo run --release -p tapeshape-eval --example surface_check -- figure \
//!     --train /work/out/pop400s1.tsd --out docs/results/real-customers/surface-12.png [--model FILE]
//! ```
//!
//! `calibrate` prints, for a grid of margins, the share of edges beyond the
//! envelope on each held-out generated body (its largest and median over
//! the bodies); with `--synthetic N`, also on the estimator's bodies from
//! the first N held-out bodies' own `quick` and `ansur` measurements (with
//! sex); and, as a sanity check of the rule (not a calibration), on
//! test-split subject 10032 entered with the `quick` and the full `ansur`
//! set, which issue 12 reports creased.
//!
//! `figure` draws 12 test-split people (6 per sex at the 0, 20, 40, 60, 80
//! and 100 % points of their sex's weight order, smallest to largest),
//! front and side, estimated from their `quick` and from their `ansur`
//! readings, with each body's verdict under the calibrated rule: `--out
//! FILE.png` the quick set, `FILE-ansur44.png` the full ansur set, and with
//! `--leave-out` `FILE-ansurN.png` the reduced one. `--ids A,B,...`
//! draws those test-split people in one row instead.
//!
//! Options: `surface_check calibrate --help` and `surface_check figure
//! --help` list them.

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use anyhow::{Context, Result};
use clap::{Parser, Subcommand};
use rayon::prelude::*;
use tapeshape_body::render::{vstack, View};
use tapeshape_estimator::{Estimator, Inputs, PredictOptions};
use tapeshape_eval::customers::{entered_readings, inputs_of, test_people, CustomersOptions};
use tapeshape_eval::figures::{body_views, common_region, expand, grid, label, save, Paint};
use tapeshape_eval::surface::{quantile, Envelope, Excess, SurfaceCheck, SurfaceRule};
use tapeshape_population::ansur::{Ansur, Sex, Subject};
use tapeshape_population::Dataset;

const DEG: f64 = std::f64::consts::PI / 180.0;

/// The surface check: its calibration on generated bodies, and the figure
/// of test-split people.
#[derive(Parser)]
// A flag given twice takes its last value, as the hand-written loop did
// (`--leave-out` and `--ids` add to the ones before); the setting holds
// for the subcommands too.
#[command(args_override_self = true)]
struct Args {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// The shares of edges beyond the envelope of `--train` on held-out
    /// generated bodies, for a grid of margins, and the rule calibrated on
    /// them; a sanity check on test-split subject 10032.
    Calibrate(Calibrate),
    /// 12 test-split people (6 per sex across their weight order), or
    /// `--ids`, estimated from their `quick` and `ansur` readings, drawn
    /// with each body's verdict.
    Figure(Figure),
}

#[derive(clap::Args)]
struct Calibrate {
    /// The model's training population: the envelope.
    #[arg(long, value_name = "FILE.tsd")]
    train: PathBuf,
    /// Held-out generated bodies (another seed): the shares and the rule
    /// calibrated on them (without it, only the sanity check).
    #[arg(long, value_name = "FILE.tsd")]
    held: Option<PathBuf>,
    /// A model file instead of the embedded default.
    #[arg(long, value_name = "FILE")]
    model: Option<PathBuf>,
    /// Also the estimator's bodies from the first N held-out bodies' own
    /// `quick` and `ansur` measurements (with sex).
    #[arg(long, value_name = "N", default_value_t = 0)]
    synthetic: usize,
    /// An ANSUR column not entered (repeatable): the sanity check also runs
    /// the `ansur` set without them.
    #[arg(long, value_name = "COLUMN")]
    leave_out: Vec<String>,
}

#[derive(clap::Args)]
struct Figure {
    /// The model's training population: the envelope.
    #[arg(long, value_name = "FILE.tsd")]
    train: PathBuf,
    /// Calibrate the rule on those held-out generated bodies instead of
    /// using the one calibrated for the embedded default
    /// (`tapeshape_eval::surface::SurfaceRule::CALIBRATED`).
    #[arg(long, value_name = "FILE.tsd")]
    held: Option<PathBuf>,
    /// A model file instead of the embedded default.
    #[arg(long, value_name = "FILE")]
    model: Option<PathBuf>,
    /// The `quick` set's figure; the others beside it, `FILE-ansur44.png`
    /// and with `--leave-out` `FILE-ansurN.png`.
    #[arg(long, value_name = "FILE.png")]
    out: PathBuf,
    /// An ANSUR column not entered (repeatable): also a figure of the
    /// `ansur` set without them.
    #[arg(long, value_name = "COLUMN")]
    leave_out: Vec<String>,
    /// Those test-split people, separated by commas (`A,B,...`; repeatable),
    /// in one row instead of the 12.
    #[arg(long, value_name = "A,B,...", value_delimiter = ',', value_parser = id)]
    ids: Vec<u32>,
}

/// One of `--ids`'s values: a test-split id, spaces around it ignored.
fn id(s: &str) -> Result<u32, std::num::ParseIntError> {
    s.trim().parse()
}

fn estimator(model: &Option<PathBuf>) -> Result<&'static Estimator> {
    Ok(match model {
        None => Estimator::default_model()?,
        // One model per run of the example: leaking it is its lifetime.
        Some(p) => Box::leak(Box::new(Estimator::load(p)?)),
    })
}

/// The input sets run: `quick`, the full `ansur`, and `ansur` without
/// `leave_out` when that is given.
fn variants(leave_out: &[String]) -> Vec<(&'static str, Vec<String>)> {
    let mut v = vec![("quick", Vec::new()), ("ansur", Vec::new())];
    if !leave_out.is_empty() {
        v.push(("ansur", leave_out.to_vec()));
    }
    v
}

fn envelope(train: &Path) -> Result<Envelope> {
    let t0 = std::time::Instant::now();
    let ds = Dataset::read(train).with_context(|| format!("reading {}", train.display()))?;
    let env = Envelope::from_bodies(ds.topology.clone(), ds.bodies.iter().map(|b| b.as_slice()))?;
    eprintln!(
        "envelope of {} bodies ({} interior edges) from {} in {:.1} s",
        env.bodies(),
        env.edges().len(),
        train.display(),
        t0.elapsed().as_secs_f64()
    );
    Ok(env)
}

/// Per margin: (largest share %, median share %), and the worst excess.
fn table(name: &str, folds: &[Vec<f64>], env: &Envelope) {
    println!("\n{name}: {} bodies", folds.len());
    println!("| margin deg | largest share % | median share % | bodies with any edge beyond |");
    println!("|---|---|---|---|");
    for m in SurfaceRule::MARGINS_DEG {
        let ex: Vec<Excess> = folds
            .iter()
            .map(|f| Excess::of(f, env.max_fold(), m * DEG))
            .collect();
        let shares: Vec<f64> = ex.iter().map(|e| 100.0 * e.share()).collect();
        println!(
            "| {m} | {:.4} | {:.4} | {} |",
            quantile(&shares, 1.0),
            quantile(&shares, 0.5),
            ex.iter().filter(|e| e.count > 0).count()
        );
    }
    let worst: Vec<f64> = folds
        .iter()
        .map(|f| Excess::of(f, env.max_fold(), 0.0).worst / DEG)
        .collect();
    println!(
        "worst excess, deg: median {:.2}, max {:.2}",
        quantile(&worst, 0.5),
        quantile(&worst, 1.0)
    );
}

fn calibrate(a: &Calibrate) -> Result<()> {
    let env = envelope(&a.train)?;
    let est = estimator(&a.model)?;
    env.check_topology(est.topology())?;
    if let Some(held) = &a.held {
        let ds = Dataset::read(held).with_context(|| format!("reading {}", held.display()))?;
        env.check_topology(&ds.topology)?;
        let folds: Vec<Vec<f64>> = ds
            .bodies
            .par_iter()
            .map(|b| env.edges().folds(b))
            .collect::<Result<_, _>>()?;
        table(
            &format!("held-out generated {}", held.display()),
            &folds,
            &env,
        );
        let rule = SurfaceRule::calibrate(&env, &folds).context("no held-out body")?;
        println!(
            "\ncalibrated rule: margin {} deg, at most {:.3} % of edges",
            rule.delta / DEG,
            100.0 * rule.max_share
        );
        let mut parts = std::collections::BTreeMap::<String, usize>::new();
        for f in &folds {
            for (k, n) in env.beyond_by_part(f, rule.delta, &tapeshape_body::anatomy::anatomy()) {
                *parts.entry(k).or_default() += n;
            }
        }
        println!("held-out edges beyond envelope + margin, by part (all bodies): {parts:?}");
        if a.synthetic > 0 {
            for set in ["quick", "ansur"] {
                let names = est.set_members(set)?;
                let folds: Vec<Vec<f64>> = (0..a.synthetic.min(ds.len()))
                    .into_par_iter()
                    .map(|i| -> Result<Vec<f64>> {
                        let m = est.compiled().measure(&ds.bodies[i])?;
                        let mut inputs = Inputs::new();
                        for n in &names {
                            let j = est.set().index_of(n).context("member")?;
                            inputs.insert_metres(n, m[j].value)?;
                        }
                        inputs.sex = ds.header.bodies[i].sex;
                        let body = est.predict(&inputs, &PredictOptions::default())?;
                        Ok(env.edges().folds(&body.mesh.vertices)?)
                    })
                    .collect::<Result<_>>()?;
                table(
                    &format!("estimator from held-out bodies' own {set} measurements"),
                    &folds,
                    &env,
                );
            }
        }
    }
    // Sanity check (not calibration): subject 10032, whom issue 12 reports creased.
    let ansur = Ansur::get()?;
    let s = ansur.subject(10032).context("subject 10032")?;
    for (set, leave_out) in variants(&a.leave_out) {
        let opts = CustomersOptions {
            input_set: set.into(),
            with_sex: true,
            per_sex: None,
            leave_out,
            ansur_survey: false,
            options: PredictOptions::default(),
        };
        let entered = entered_readings(est, &opts)?;
        let body = est.predict(&inputs_of(s, &entered, true), &opts.options)?;
        let folds = env.edges().folds(&body.mesh.vertices)?;
        let rule = SurfaceRule::CALIBRATED;
        println!(
            "\nsubject 10032, {set} ({} readings): edges beyond envelope + {:.0} deg by part: {:?}",
            entered.len(),
            rule.delta / DEG,
            env.beyond_by_part(&folds, rule.delta, &tapeshape_body::anatomy::anatomy())
        );
        table(
            &format!(
                "subject 10032, {set} ({} readings), with sex",
                entered.len()
            ),
            &[folds],
            &env,
        );
    }
    Ok(())
}

/// 6 people of `sex`, at the 0, 20, ..., 100 % points of their weight order.
fn pick<'a>(people: &[&'a Subject], sex: Sex) -> Vec<&'a Subject> {
    let mut v: Vec<&Subject> = people.iter().copied().filter(|s| s.sex == sex).collect();
    v.sort_by(|a, b| a.mass_kg.total_cmp(&b.mass_kg).then(a.id.cmp(&b.id)));
    (0..6).map(|k| v[((v.len() - 1) * k + 2) / 5]).collect()
}

fn figure(a: &Figure) -> Result<()> {
    let train = &a.train;
    let train = Dataset::read(train).with_context(|| format!("reading {}", train.display()))?;
    let held = a.held.as_deref().map(Dataset::read).transpose()?;
    let check = SurfaceCheck::from_datasets(&train, held.as_ref())?;
    drop(train);
    eprintln!(
        "rule: margin {} deg, at most {:.3} % of edges",
        check.rule.delta / DEG,
        100.0 * check.rule.max_share
    );
    let est = estimator(&a.model)?;
    check.envelope.check_topology(est.topology())?;
    let ansur = Ansur::get()?;
    let all = test_people(ansur, None);
    let chosen: Vec<&Subject> = if a.ids.is_empty() {
        let mut c = pick(&all, Sex::Male);
        c.extend(pick(&all, Sex::Female));
        c
    } else {
        a.ids
            .iter()
            .map(|id| {
                all.iter()
                    .copied()
                    .find(|s| s.id == *id)
                    .with_context(|| format!("{id} is not a test-split person"))
            })
            .collect::<Result<_>>()?
    };
    // Per input set: (name, readings entered, per person (body, verdict)).
    let mut bodies = Vec::new();
    for (set, leave_out) in variants(&a.leave_out) {
        let opts = CustomersOptions {
            input_set: set.into(),
            with_sex: true,
            per_sex: None,
            leave_out: leave_out.clone(),
            ansur_survey: false,
            options: PredictOptions::default(),
        };
        let entered = entered_readings(est, &opts)?;
        let b: Vec<_> = chosen
            .par_iter()
            .map(|s| -> Result<_> {
                let body = est.predict(&inputs_of(s, &entered, true), &opts.options)?;
                let verdict = check.judge(&body.mesh.vertices)?;
                let folds = check.envelope.edges().folds(&body.mesh.vertices)?;
                let anatomy = tapeshape_body::anatomy::anatomy();
                let mut parts = check
                    .envelope
                    .beyond_by_part(&folds, check.rule.delta, &anatomy);
                // The part of the worst edge, last.
                let worst = verdict.excess.worst;
                parts.extend(
                    check
                        .envelope
                        .beyond_by_part(&folds, worst - 1e-9 * worst.abs(), &anatomy)
                        .into_iter()
                        .map(|(k, n)| (format!("worst: {k}"), n)),
                );
                Ok((body.mesh.vertices, verdict, parts))
            })
            .collect::<Result<_>>()?;
        for (s, (_, v, parts)) in chosen.iter().zip(&b) {
            println!(
                "{set}{} {} {:?} {:.1} kg: {} edges beyond ({:.3} %), worst {:.1} deg, {} | {parts:?}",
                if leave_out.is_empty() { "" } else { "-reduced" },
                s.id,
                s.sex,
                s.mass_kg,
                v.excess.count,
                100.0 * v.excess.share(),
                v.excess.worst / DEG,
                if v.pass { "pass" } else { "FAIL" }
            );
        }
        let b: Vec<_> = b.into_iter().map(|(v, verdict, _)| (v, verdict)).collect();
        bodies.push((set, entered.len(), b));
    }
    let all_vertices: Vec<&[[f64; 3]]> = bodies
        .iter()
        .flat_map(|(_, _, b)| b.iter().map(|(v, _)| v.as_slice()))
        .collect();
    // One frame for every panel of every figure: true relative sizes.
    let region = expand(common_region(&all_vertices), 0.02);
    let topo = est.topology().clone();
    let out = a.out.clone();
    for (k, (set, n, b)) in bodies.iter().enumerate() {
        // One figure per input set: a row of men, a row of women, each cell
        // the body from the front and from its right side, its verdict under it.
        let cells = b
            .iter()
            .map(|(v, verdict)| -> Result<_> {
                let p = body_views(
                    v,
                    &topo,
                    &Paint::Shaded,
                    &[View::Front, View::Right],
                    region,
                    400,
                    420,
                )?;
                let t = format!(
                    "{} {:.2} % of edges",
                    if verdict.pass { "pass" } else { "FAIL" },
                    100.0 * verdict.excess.share()
                );
                let w = p.width();
                Ok(vstack(&[p, label(&t, w, 16, 1)]))
            })
            .collect::<Result<Vec<_>>>()?;
        let mut cells = cells.into_iter();
        let mut rows = Vec::new();
        let columns: Vec<String> = if a.ids.is_empty() {
            for sex in ["men", "women"] {
                rows.push((sex.to_string(), cells.by_ref().take(6).collect::<Vec<_>>()));
            }
            (0..6)
                .map(|i| {
                    let m = chosen[i];
                    let f = chosen[6 + i];
                    format!("{} {:.0}kg / {} {:.0}kg", m.id, m.mass_kg, f.id, f.mass_kg)
                })
                .collect()
        } else {
            rows.push((String::new(), cells.collect::<Vec<_>>()));
            chosen
                .iter()
                .map(|s| format!("{} {:?} {:.0}kg", s.id, s.sex, s.mass_kg))
                .collect()
        };
        let title = format!(
            "{set} set, {n} readings and sex entered{}; rule: at most {:.2} % of edges fold > {:.0} deg beyond the training envelope",
            if *n == 44 || set == &"quick" { "" } else { " (without what a standing mesh cannot follow)" },
            100.0 * check.rule.max_share,
            check.rule.delta / DEG
        );
        let g = grid(&columns, rows);
        let tw = g.width().max(8 * title.len() as u32 + 8);
        let img = vstack(&[label(&title, tw, 24, 1), g]);
        let path = if k == 0 {
            out.clone()
        } else {
            let stem = out
                .file_stem()
                .and_then(|s| s.to_str())
                .unwrap_or("surface");
            out.with_file_name(format!("{stem}-{set}{n}.png"))
        };
        save(&img, &path)?;
        eprintln!(
            "wrote {} ({} x {})",
            path.display(),
            img.width(),
            img.height()
        );
    }
    Ok(())
}

fn main() -> ExitCode {
    let args = tapeshape_common::cli::parse_or_exit::<Args>();
    let r = match &args.command {
        Command::Calibrate(a) => calibrate(a),
        Command::Figure(a) => figure(a),
    };
    match r {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e:#}");
            ExitCode::FAILURE
        }
    }
}
