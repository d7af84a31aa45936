//! Train and predict times of every method of the evaluation (the figures
//! in `docs/baselines.md`), with the mean measurement error on held-out
//! bodies as a sanity check.
//!
//! ```text
//! cargo run --release -p tapeshape-eval --example methods_bench -- [N_TRAIN] [N_TEST]
//! ```
//!
//! Defaults: 360 training bodies (seed 1) and 10 held-out bodies (seed 2),
//! generated once and cached under `target/methods-bench/`; measurement set
//! `paper34`, every measurement given. Train time is one run (wall clock);
//! predict time is the median over the held-out bodies. The PCA fit is
//! timed once and shared by every PCA-based method (each method's
//! `from_model`), so their train times exclude it. `--help` lists the
//! arguments.

use std::path::PathBuf;
use std::sync::Arc;
use std::time::{Duration, Instant};

use clap::Parser;
use tapeshape_eval::methods::{
    FeatureAnalysis, GeneratorFit, GeneratorFitSettings, Ours, RbfInterpolation, RbfSettings,
    Sgplvm, SgplvmSettings, StepOneOnly,
};
use tapeshape_eval::{Method, TrainingData};
use tapeshape_measure::MeasurementSet;
use tapeshape_model::PredictSettings;
use tapeshape_population::{generate_population, Dataset, PopulationSettings};

/// Train and predict times of every method of the evaluation, with the
/// mean measurement error on held-out bodies as a sanity check.
#[derive(Parser)]
struct Args {
    /// Training bodies (seed 1), generated once and cached under
    /// `target/methods-bench/`.
    #[arg(value_name = "N_TRAIN", default_value_t = 360)]
    n_train: usize,
    /// Held-out bodies (seed 2, or the environment's `TEST_SEED`), cached
    /// the same way.
    #[arg(value_name = "N_TEST", default_value_t = 10)]
    n_test: usize,
}

fn cached(n: usize, seed: u64) -> Dataset {
    let dir = PathBuf::from(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../target/methods-bench"
    ));
    std::fs::create_dir_all(&dir).expect("cache folder");
    let path = dir.join(format!("population-n{n}-seed{seed}.tsd"));
    if let Ok(d) = Dataset::read(&path) {
        return d;
    }
    let t = Instant::now();
    let d = generate_population(
        &PopulationSettings {
            n,
            seed,
            ..PopulationSettings::default()
        },
        &|_, _| {},
    )
    .expect("generate");
    eprintln!("generated {n} bodies (seed {seed}) in {:.1?}", t.elapsed());
    d.write(&path).expect("cache");
    d
}

/// An optional count from the environment (`SGPLVM_Q`, `SGPLVM_ITERS`,
/// `ONLY` = 1 to run the SGPLVM alone, for tuning its settings;
/// `TEST_SEED`: seed of the held-out bodies, default 2).
fn env_usize(name: &str) -> Option<usize> {
    std::env::var(name).ok().map(|v| {
        v.parse()
            .unwrap_or_else(|_| panic!("{name} must be a count, got {v:?}"))
    })
}

fn main() {
    let Args { n_train, n_test } = Args::parse();
    let train = cached(n_train, 1);
    let test = cached(n_test, env_usize("TEST_SEED").map_or(2, |s| s as u64));
    let anatomy = tapeshape_body::anatomy::anatomy();
    let compiled = Arc::new(
        MeasurementSet::builtin("paper34")
            .unwrap()
            .compile(&train.topology, &anatomy)
            .unwrap(),
    );
    let measure = |b: &[[f64; 3]]| -> Vec<f64> {
        compiled
            .measure(b)
            .unwrap()
            .iter()
            .map(|m| m.value)
            .collect()
    };
    let data = TrainingData {
        meshes: train.bodies.clone(),
        measurements: train.bodies.iter().map(|b| measure(b)).collect(),
        compiled: compiled.clone(),
        topology: train.topology.clone(),
    };
    let rows: Vec<Vec<f64>> = test.bodies.iter().map(|b| measure(b)).collect();

    let t = Instant::now();
    let ours = Ours::fit(&data, PredictSettings::default()).unwrap();
    let pca_time = t.elapsed();
    let model = ours.model().clone();
    println!(
        "N = {n_train} training bodies, {} components, {} held-out bodies, paper34 ({} measurements)",
        model.n_components(),
        n_test,
        compiled.len()
    );
    println!("shared model fit (PCA, feature map, joint Gaussian): {pca_time:.2?}");

    let only_sgplvm = env_usize("ONLY") == Some(1);
    let timed = |f: &dyn Fn() -> Box<dyn Method>| {
        let t = Instant::now();
        let m = f();
        (m, t.elapsed())
    };
    let sgplvm = || -> Box<dyn Method> {
        let mut settings = SgplvmSettings::default();
        if let Some(q) = env_usize("SGPLVM_Q") {
            settings.latent_dim = q;
        }
        if let Some(it) = env_usize("SGPLVM_ITERS") {
            settings.train_iterations = it as u64;
        }
        eprintln!("SGPLVM settings: {settings:?}");
        let s = Sgplvm::from_model(model.clone(), &data, settings).unwrap();
        eprintln!("SGPLVM learning: {:?}", s.fit_info());
        Box::new(s)
    };
    let methods: Vec<(Box<dyn Method>, Duration)> = if only_sgplvm {
        vec![timed(&sgplvm)]
    } else {
        vec![
            (Box::new(ours), Duration::ZERO),
            timed(&|| {
                Box::new(
                    StepOneOnly::from_model(model.clone(), &data, PredictSettings::default())
                        .unwrap(),
                )
            }),
            timed(&|| Box::new(FeatureAnalysis::from_model(model.clone(), &data, None).unwrap())),
            timed(&|| {
                Box::new(
                    RbfInterpolation::from_model(model.clone(), &data, RbfSettings::default())
                        .unwrap(),
                )
            }),
            timed(&sgplvm),
            timed(&|| Box::new(GeneratorFit::new(&data, GeneratorFitSettings::default()).unwrap())),
        ]
    };

    println!(
        "| method | train (s, excl. shared model fit) | predict median (s) | predict max (s) | mean error (mm) |"
    );
    println!("|---|---|---|---|---|");
    for (m, train_time) in &methods {
        let mut times = Vec::new();
        let mut err = 0.0;
        for row in &rows {
            let targets: Vec<Option<f64>> = row.iter().map(|&x| Some(x)).collect();
            let t = Instant::now();
            let out = m.predict(&targets).unwrap();
            times.push(t.elapsed().as_secs_f64());
            let got = measure(&out.vertices);
            err += got.iter().zip(row).map(|(a, b)| (a - b).abs()).sum::<f64>() / row.len() as f64;
        }
        times.sort_by(f64::total_cmp);
        println!(
            "| {} | {:.3} | {:.3} | {:.3} | {:.3} |",
            m.name(),
            train_time.as_secs_f64(),
            times[times.len() / 2],
            times[times.len() - 1],
            err / rows.len() as f64 * 1000.0
        );
    }
}
