//! Writes a model's training population as a population table
//! (`tapeshape_eval::poptable`): every body of known sex measured with the
//! `ansur` set, one CSV row per body, for the sex check's population axes.
//!
//! ```text
//! cargo run --release -p tapeshape-eval --example population_table -- \
//!     POP.tsd --out host/eval/data/default-population.csv \
//!     [--model host/estimator/models/default.tsm.gz] [--source TEXT]
//! ```
//!
//! Options: `--help` lists them (the CSV file, the model whose sha256 the
//! table records, the population's description).

use std::path::Path;
use std::process::ExitCode;

use clap::Parser;
use sha2::{Digest, Sha256};
use tapeshape_eval::poptable::PopulationTable;
use tapeshape_population::Dataset;

/// Writes a model's training population as a population table: every body
/// of known sex measured with the `ansur` set, one CSV row per body.
#[derive(Parser)]
// A flag given twice takes its last value, as the hand-written loop did.
#[command(args_override_self = true)]
struct Args {
    /// The model's training population (a dataset file).
    #[arg(value_name = "POP.tsd")]
    input: String,
    /// The population table to write.
    #[arg(long, value_name = "FILE.csv")]
    out: String,
    /// The model trained on the population: the table records its sha256
    /// (the CI test checks that the committed table belongs to the
    /// embedded model).
    #[arg(long, value_name = "FILE")]
    model: Option<String>,
    /// What the population is (default: the file's name and its
    /// generation settings).
    #[arg(long, value_name = "TEXT")]
    source: Option<String>,
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

fn real_main(args: Args) -> Result<(), String> {
    let Args {
        input,
        out,
        model,
        source,
    } = args;
    let dataset = Dataset::read(Path::new(&input)).map_err(|e| format!("{input}: {e}"))?;
    let source = source.unwrap_or_else(|| {
        let name = Path::new(&input)
            .file_name()
            .map_or(input.clone(), |n| n.to_string_lossy().into_owned());
        match &dataset.header.settings {
            Some(s) => format!("{name} ({} bodies, seed {}, fit {:?})", s.n, s.seed, s.fit),
            None => name,
        }
    });
    let mut table = PopulationTable::measure(&dataset, &source).map_err(|e| e.to_string())?;
    if let Some(m) = &model {
        let bytes = std::fs::read(m).map_err(|e| format!("reading {m}: {e}"))?;
        table.model_sha256 = Some(format!("{:x}", Sha256::digest(&bytes)));
    }
    tapeshape_common::fs::write_atomic(Path::new(&out), table.to_csv().as_bytes())
        .map_err(|e| format!("writing {out}: {e}"))?;
    eprintln!(
        "{out}: {} bodies, {} columns",
        table.rows.len(),
        table.columns.len()
    );
    Ok(())
}
