//! Creases of the estimator's bodies on ANSUR II **train-split** people:
//! the calibration of step 2's crease count (`CREASES_ALLOWED` in
//! `host/model/src/predict/folds.rs`), which may use the train split and
//! never the test split.
//!
//! For N train-split people (every k-th by id, both sexes), their real
//! values of the `quick` set are entered with their sex into the embedded
//! default model with the default settings. Per body it prints: the
//! surface check's verdict and share of edges beyond the envelope (the
//! body, and the step-1 shape of its step-1 weights), how many interior
//! edges' folds grew from that step-1 shape by more than 15, 20, 30, 45
//! and 60 degrees, and how many of the step-1 shape's triangles are
//! flipped against the model's mean shape; then a summary of the 30-degree
//! count and of the failures.
//!
//! ```text
//! cargo run --release -p tapeshape-eval --example train_creases -- \
//!     --train pop400s1.tsd --held held60s2.tsd [--n 1500] [--rows]
//! ```
//!
//! The calibration (2026-12-07) ran on 124e5ab, where step 2 started from
//! the step-1 shape of the weights. Since then the step-1 shape is first
//! smoothed where it folds against the mean, so the growth counted here
//! also holds that smoothing's changes.

use std::path::PathBuf;

use anyhow::{Context, Result};
use clap::Parser;
use rayon::prelude::*;
use tapeshape_estimator::{Estimator, PredictOptions};
use tapeshape_eval::customers::{entered_readings, inputs_of, CustomersOptions};
use tapeshape_eval::surface::SurfaceCheck;
use tapeshape_mesh::vec3::{dot, triangle_normal};
use tapeshape_mesh::Vec3;
use tapeshape_population::ansur::{Ansur, Split};
use tapeshape_population::Dataset;

/// Creases of the estimator's bodies on ANSUR II train-split people.
#[derive(Parser)]
struct Args {
    /// The model's training population (`tapeshape dataset generate --n
    /// 400 --seed 1`): the surface check's envelope.
    #[arg(long)]
    train: PathBuf,
    /// Held-out generated bodies (`--n 60 --seed 2`): the rule's calibration.
    #[arg(long)]
    held: PathBuf,
    /// How many train-split people (spread evenly over the ids).
    #[arg(long, default_value_t = 1500)]
    n: usize,
    /// Print one row per person as well.
    #[arg(long)]
    rows: bool,
}

/// One person's counts.
struct Row {
    id: u32,
    pass: bool,
    share: f64,
    step1_share: f64,
    /// Edges grown by more than 15, 20, 30, 45, 60 degrees.
    grown: [usize; 5],
    flipped_vs_mean: usize,
}

const GROWTH_DEG: [f64; 5] = [15.0, 20.0, 30.0, 45.0, 60.0];

fn main() -> Result<()> {
    let args = Args::parse();
    let est = Estimator::default_model()?;
    let read = |p: &PathBuf| Dataset::read(p).with_context(|| format!("reading {}", p.display()));
    let check = SurfaceCheck::from_datasets(&read(&args.train)?, Some(&read(&args.held)?))?;
    let opts = CustomersOptions {
        input_set: "quick".into(),
        with_sex: true,
        per_sex: None,
        leave_out: vec![],
        ansur_survey: false,
        options: PredictOptions::default(),
    };
    let entered = entered_readings(est, &opts)?;
    let mut people: Vec<_> = Ansur::get()?.subjects(None, Split::Train).collect();
    people.sort_by_key(|s| s.id);
    let step = (people.len() / args.n.max(1)).max(1);
    let people: Vec<_> = people.into_iter().step_by(step).take(args.n).collect();
    let model = &est.file().model;
    let mean = model.shape(&vec![0.0; model.n_components()])?;
    let topology = est.topology();
    let flipped = |a: &[Vec3], b: &[Vec3]| {
        let normal = |p: &[Vec3], f: &[u32; 3]| {
            triangle_normal(p[f[0] as usize], p[f[1] as usize], p[f[2] as usize])
        };
        topology
            .faces()
            .iter()
            .filter(|f| dot(normal(a, f), normal(b, f)) < 0.0)
            .count()
    };
    let edges = check.envelope.edges();
    let rows: Vec<Row> = people
        .par_iter()
        .map(|s| -> Result<Row> {
            let e = est
                .predict(&inputs_of(s, &entered, true), &PredictOptions::default())
                .with_context(|| format!("subject {}", s.id))?;
            let x1 = model.shape(&e.report.prediction.weights_step1)?;
            let (f1, f2) = (edges.folds(&x1)?, edges.folds(&e.mesh.vertices)?);
            let grown = GROWTH_DEG.map(|d| {
                f2.iter()
                    .zip(&f1)
                    .filter(|(a, b)| (*a - *b).to_degrees() > d)
                    .count()
            });
            let v = check.judge(&e.mesh.vertices)?;
            Ok(Row {
                id: s.id,
                pass: v.pass,
                share: v.excess.share(),
                step1_share: check.judge(&x1)?.excess.share(),
                grown,
                flipped_vs_mean: flipped(&mean, &x1),
            })
        })
        .collect::<Result<_>>()?;
    if args.rows {
        println!("| id | pass | share % | step-1 share % | grown >15 | >20 | >30 | >45 | >60 | step-1 flipped vs mean |");
        println!("|---|---|---|---|---|---|---|---|---|---|");
        for r in &rows {
            let g = r.grown.map(|g| g.to_string()).join(" | ");
            println!(
                "| {} | {} | {:.4} | {:.4} | {g} | {} |",
                r.id,
                r.pass,
                100.0 * r.share,
                100.0 * r.step1_share,
                r.flipped_vs_mean
            );
        }
    }
    if rows.is_empty() {
        anyhow::bail!("no train-split people to count (--n {})", args.n);
    }
    let mut g30: Vec<usize> = rows.iter().map(|r| r.grown[2]).collect();
    g30.sort_unstable();
    let q = |p: f64| g30[((g30.len() - 1) as f64 * p).round() as usize];
    let fails: Vec<String> = rows
        .iter()
        .filter(|r| !r.pass)
        .map(|r| format!("{} ({:.3} %)", r.id, 100.0 * r.share))
        .collect();
    println!(
        "{} train-split people, quick with sex: edges grown > 30 deg from the step-1 shape: median {}, 99th percentile {}, largest {}; bodies with more than 20: {}; surface check failures: {} [{}]",
        rows.len(),
        q(0.5),
        q(0.99),
        q(1.0),
        g30.iter().filter(|&&g| g > 20).count(),
        fails.len(),
        fails.join(", ")
    );
    Ok(())
}
