//! `tapeshape dataset`: make, import and inspect databases of registered
//! bodies (the training data of the shape model).
//!
//! The file format is documented in `tapeshape_population` and
//! `docs/datasets.md`.

use std::path::PathBuf;

use anyhow::Context as _;
use tapeshape_estimator::priors::CANNOT_FOLLOW_ANSUR;
use tapeshape_population::{self as dataset, Dataset, PopulationSettings};

use super::Global;

/// Arguments of `tapeshape dataset`.
#[derive(clap::Args, Debug)]
pub struct Args {
    #[command(subcommand)]
    command: Command,
}

#[derive(clap::Subcommand, Debug)]
enum Command {
    /// Generate adult bodies (both sexes) fitted to ANSUR II train-split subjects.
    ///
    /// Each body is a MakeHuman blend whose height, weight, muscle,
    /// proportions and `measure-*` local changes are fitted to one ANSUR II
    /// subject's stature, girths and lengths (subjects with ids divisible by 4
    /// are never used), plus small random local variation. The file records
    /// the seed, the settings, every body's parameters and its subject id.
    Generate {
        /// Number of bodies.
        #[arg(long, default_value_t = 400)]
        n: usize,
        /// Random seed: the same seed and settings give the same file.
        #[arg(long, default_value_t = 1)]
        seed: u64,
        /// Share of men (0..=1).
        #[arg(long, default_value_t = 0.5)]
        male_fraction: f64,
        /// SD of the random local variation (local-change units, 0 = none).
        #[arg(long, default_value_t = 0.15)]
        local_variation: f64,
        /// Which ANSUR II dimensions each body is fitted to: `twelve`
        /// (stature, girths, main lengths), `ansur` (also breadths,
        /// depths, landmark heights, head; issue 12) or `ansur-sections`
        /// (`ansur`, the buttock height, and hip and waist sections that
        /// can be as square as real people's: the default model's).
        #[arg(long, default_value = "twelve", value_parser = parse_fit)]
        fit: dataset::FitScope,
        /// Output file (.tsd).
        #[arg(long, short = 'o')]
        out: PathBuf,
    },
    /// Generate faces: the head region of random adults with random face local changes.
    GenerateFaces {
        /// Number of faces.
        #[arg(long, default_value_t = 50)]
        n: usize,
        /// Random seed.
        #[arg(long, default_value_t = 1)]
        seed: u64,
        /// Output file (.tsd).
        #[arg(long, short = 'o')]
        out: PathBuf,
    },
    /// Import a folder of registered meshes (OBJ or PLY, identical topology, metres, Z up).
    Import {
        /// Folder with the meshes (read in file-name order).
        dir: PathBuf,
        /// Output file (.tsd).
        #[arg(long, short = 'o')]
        out: PathBuf,
    },
    /// Summarise a dataset; for populations, compare its statistics with ANSUR II.
    ///
    /// Without `--all`: issue 3's check on stature, chest, waist and buttock
    /// circumference (per sex, means within 2 %, SDs within 15 %,
    /// correlations within 0.15 of ANSUR II's train split, subjects aged
    /// 18-90). With `--all`, then every dimension of the `ansur`
    /// measurement set that follows an ANSUR II column, measured on each
    /// body's mesh: per sex the means and SDs beside ANSUR II's (mm, %), a
    /// summary of the correlation gaps and the 10 worst pairs, and each
    /// body against its own ANSUR II subject within the ISO 20685-1
    /// allowable error (share per dimension; bodies within on every fitted
    /// dimension, on every followable one, on all). Dimensions marked `*`
    /// cannot be taken on a standing skin mesh as ANSUR II takes them.
    Stats {
        /// Dataset file.
        file: PathBuf,
        /// Also compare every `ansur` dimension, and each body with its
        /// subject (populations only; measures 44 dimensions on every body).
        #[arg(long)]
        all: bool,
        /// Print the comparison as JSON instead of Markdown (with `--all`:
        /// an object with `checked`, issue 3's array, and `all_dimensions`).
        #[arg(long)]
        json: bool,
    },
}

fn progress_bar(n: usize, what: &str) -> indicatif::ProgressBar {
    let bar = indicatif::ProgressBar::new(n as u64);
    bar.set_style(
        indicatif::ProgressStyle::with_template(
            "{msg} {bar:40} {pos}/{len} [{elapsed_precise}, eta {eta}]",
        )
        .expect("valid template"),
    );
    bar.set_message(what.to_string());
    bar
}

fn parse_fit(text: &str) -> Result<dataset::FitScope, String> {
    match text {
        "twelve" => Ok(dataset::FitScope::Twelve),
        "ansur" => Ok(dataset::FitScope::Ansur),
        "ansur-sections" => Ok(dataset::FitScope::AnsurSections),
        other => Err(format!(
            "'{other}' is not a fit scope: write twelve, ansur or ansur-sections"
        )),
    }
}

/// Runs `tapeshape dataset`.
pub fn run(args: Args, _global: &Global) -> anyhow::Result<()> {
    match args.command {
        Command::Generate {
            n,
            seed,
            male_fraction,
            local_variation,
            fit,
            out,
        } => {
            let settings = PopulationSettings {
                n,
                seed,
                male_fraction,
                local_variation_sd: local_variation,
                fit,
                ..PopulationSettings::default()
            };
            let bar = progress_bar(n, "fitting bodies to ANSUR II");
            let t = std::time::Instant::now();
            let d =
                dataset::generate_population(&settings, &|done, _| bar.set_position(done as u64))?;
            bar.finish_and_clear();
            d.write(&out)
                .with_context(|| format!("writing {}", out.display()))?;
            let worst: Vec<f64> = d
                .header
                .bodies
                .iter()
                .filter_map(|b| b.fit.as_ref().map(|f| f.max_error_mm))
                .collect();
            let mut sorted = worst.clone();
            sorted.sort_by(f64::total_cmp);
            outln!(
                "wrote {} bodies to {} in {:.1} s; fit: median worst-dimension error {:.2} mm, 90th percentile {:.2} mm",
                d.len(),
                out.display(),
                t.elapsed().as_secs_f64(),
                sorted.get(sorted.len() / 2).copied().unwrap_or(f64::NAN),
                sorted.get(sorted.len() * 9 / 10).copied().unwrap_or(f64::NAN)
            )?;
        }
        Command::GenerateFaces { n, seed, out } => {
            let settings = PopulationSettings {
                n,
                seed,
                ..PopulationSettings::default()
            };
            let bar = progress_bar(n, "generating faces");
            let d = dataset::generate_faces(&settings, &|done, _| bar.set_position(done as u64))?;
            bar.finish_and_clear();
            d.write(&out)
                .with_context(|| format!("writing {}", out.display()))?;
            outln!(
                "wrote {} faces ({} vertices each) to {}",
                d.len(),
                d.header.n_vertices,
                out.display()
            )?;
        }
        Command::Import { dir, out } => {
            let d = dataset::import_dir(&dir)?;
            d.write(&out)
                .with_context(|| format!("writing {}", out.display()))?;
            outln!(
                "imported {} meshes ({} vertices each) into {}",
                d.len(),
                d.header.n_vertices,
                out.display()
            )?;
        }
        Command::Stats { file, all, json } => {
            let d = Dataset::read(&file)?;
            let h = &d.header;
            if !json {
                outln!(
                    "{}: {:?} dataset, {} bodies, {} vertices, {} triangles, written by {}",
                    file.display(),
                    h.kind,
                    d.len(),
                    h.n_vertices,
                    h.n_faces,
                    h.created_by
                )?;
                if let Some(s) = &h.settings {
                    outln!(
                        "made with seed {}, n {}, male fraction {}, local variation {}",
                        s.seed,
                        s.n,
                        s.male_fraction,
                        s.local_variation_sd
                    )?;
                }
            }
            if all && h.kind != dataset::DatasetKind::Population {
                anyhow::bail!(
                    "{}: --all compares a population with ANSUR II, and this is a {:?} dataset; drop --all, or give a file from `tapeshape dataset generate`",
                    file.display(),
                    h.kind
                );
            }
            if h.kind == dataset::DatasetKind::Population {
                let stats = dataset::population_statistics(&d)?;
                let every = if all {
                    Some(dataset::dimension_statistics(&d, CANNOT_FOLLOW_ANSUR)?)
                } else {
                    None
                };
                match (json, every) {
                    (true, None) => outln!("{}", serde_json::to_string_pretty(&stats)?)?,
                    (true, Some(every)) => outln!(
                        "{}",
                        serde_json::to_string_pretty(&serde_json::json!({
                            "checked": stats,
                            "all_dimensions": every,
                        }))?
                    )?,
                    (false, every) => {
                        out!("{}", dataset::statistics_markdown(&stats))?;
                        if let Some(every) = every {
                            out!("{}", dataset::dimension_markdown(&every))?;
                        }
                    }
                }
            }
        }
    }
    Ok(())
}
