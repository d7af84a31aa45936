//! Two datasets of bodies in one: the first whole, then the first `--take`
//! bodies of the second (all by default). Used to train a model on a
//! mixture of two generators' populations
//! (`docs/results/real-customers.md`, "Mixing the two populations").
//!
//! ```text
//! cargo run --release -p tapeshape-eval --example concat_datasets -- \
//!     pop400s1.tsd pop400s1sq.tsd --take 100 -o mix4100.tsd
//! ```
//!
//! The two must share the template topology; the second's bodies are
//! renamed `b-NAME` so names stay unique. The header (kind, settings) is
//! the first's.

use std::path::PathBuf;
use std::process::ExitCode;

use clap::Parser;
use tapeshape_population::format::Dataset;

/// Concatenate two datasets of bodies in the template topology.
#[derive(Parser)]
struct Args {
    /// The first dataset (`.tsd`), taken whole.
    first: PathBuf,
    /// The second dataset (`.tsd`).
    second: PathBuf,
    /// Take only this many bodies of the second, from its start.
    #[arg(long)]
    take: Option<usize>,
    /// The dataset to write.
    #[arg(short, long)]
    out: PathBuf,
}

fn main() -> ExitCode {
    let args = Args::parse();
    match run(&args) {
        Ok(n) => {
            println!("wrote {} ({n} bodies)", args.out.display());
            ExitCode::SUCCESS
        }
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::FAILURE
        }
    }
}

fn run(args: &Args) -> Result<usize, String> {
    let mut all = Dataset::read(&args.first).map_err(|e| e.to_string())?;
    let second = Dataset::read(&args.second).map_err(|e| e.to_string())?;
    if all.topology.faces() != second.topology.faces() {
        return Err(format!(
            "{} and {} have different topologies: both must be in the template topology",
            args.first.display(),
            args.second.display()
        ));
    }
    let take = args.take.unwrap_or(usize::MAX);
    for (mut record, body) in second
        .header
        .bodies
        .into_iter()
        .zip(second.bodies)
        .take(take)
    {
        record.name = format!("b-{}", record.name);
        all.header.bodies.push(record);
        all.bodies.push(body);
    }
    all.write(&args.out).map_err(|e| e.to_string())?;
    Ok(all.len())
}
