//! `tapeshape train --dataset FILE --set paper34 [--set ansur ...] -o MODEL`:
//! learns a shape model (PCA, feature analysis, joint statistics) from a
//! dataset of registered bodies, for `tapeshape predict --model MODEL`.
//!
//! Why a subcommand: a station ships with a default model (embedded), but an
//! engineer retrains it on a new population or a customer's own scans, and
//! rebuilds the embedded one (`scripts/rebuild-default-model.sh`).

use std::path::PathBuf;
use std::time::Instant;

use anyhow::Context as _;
use tapeshape_estimator::{self as predict, FitSettings, TrainSettings, DEFAULT_SETS};
use tapeshape_population::Dataset;

use super::Global;

/// Arguments of `tapeshape train`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// Dataset of bodies in the template topology (`tapeshape dataset generate` or `import`).
    #[arg(long, value_name = "FILE")]
    pub dataset: PathBuf,

    /// Measurement set to learn (paper34, ansur, quick or a set file); repeat
    /// for several: the model carries their union (deduplicated by name) and
    /// predicts from any subset. Default: paper34, ansur and quick.
    #[arg(long = "set", value_name = "NAME|FILE")]
    pub sets: Vec<String>,

    /// Output model file (`.tsm`; `.tsm.gz` writes it gzip-compressed).
    #[arg(short, long, value_name = "MODEL")]
    pub out: PathBuf,

    /// Keep the fewest PCA components explaining this share of the variance
    /// (e.g. 0.999), to make the file smaller. Default: keep all.
    #[arg(long, value_name = "SHARE")]
    pub variance: Option<f64>,

    /// Keep at most this many PCA components.
    #[arg(long, value_name = "K")]
    pub max_components: Option<usize>,

    /// Round the PCA mean and basis to f32 precision (a compressed file is
    /// about half the size; sub-micrometre effect on the mesh).
    #[arg(long)]
    pub f32: bool,

    /// Use only the first N bodies of the dataset.
    #[arg(long, value_name = "N")]
    pub first: Option<usize>,
}

/// Runs `tapeshape train`.
pub fn run(args: Args, _global: &Global) -> anyhow::Result<()> {
    let t0 = Instant::now();
    let mut dataset = Dataset::read(&args.dataset)
        .with_context(|| format!("reading the dataset {}", args.dataset.display()))?;
    if let Some(n) = args.first {
        if n < dataset.len() {
            dataset.bodies.truncate(n);
            dataset.header.bodies.truncate(n);
        }
    }
    let sets: Vec<&str> = if args.sets.is_empty() {
        eprintln!("no --set given: training paper34, ansur and quick");
        DEFAULT_SETS.to_vec()
    } else {
        args.sets.iter().map(String::as_str).collect()
    };
    let read_s = t0.elapsed().as_secs_f64();
    let t1 = Instant::now();
    let settings = TrainSettings {
        fit: FitSettings {
            max_components: args.max_components,
            ..FitSettings::default()
        },
        variance_kept: args.variance,
        round_to_f32: args.f32,
        notes: format!(
            "tapeshape train --dataset {} {}{}{}{}",
            args.dataset
                .file_name()
                .map(|f| f.to_string_lossy().into_owned())
                .unwrap_or_default(),
            sets.iter()
                .map(|s| format!("--set {s} "))
                .collect::<String>(),
            args.variance
                .map(|v| format!("--variance {v} "))
                .unwrap_or_default(),
            args.max_components
                .map(|v| format!("--max-components {v} "))
                .unwrap_or_default(),
            if args.f32 { "--f32" } else { "" }
        ),
    };
    let file = predict::train(&dataset, &sets, &settings).context("training the model")?;
    let train_s = t1.elapsed().as_secs_f64();
    predict::save_model(&file, &args.out)
        .with_context(|| format!("writing the model {}", args.out.display()))?;
    let size = std::fs::metadata(&args.out).map(|m| m.len()).unwrap_or(0);
    outln!(
        "wrote {} ({:.1} MB): {} bodies, {} measurements ({}), {} PCA components, {} vertices; read {:.1} s, trained {:.1} s",
        args.out.display(),
        size as f64 / 1e6,
        file.model.n_training,
        file.model.n_measurements(),
        file.measurement_set.name,
        file.model.n_components(),
        file.model.n_vertices(),
        read_s,
        train_s
    )?;
    Ok(())
}
