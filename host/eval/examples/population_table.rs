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
//! `--model FILE` records the sha256 of the model trained on the population
//! (the CI test checks that the committed table belongs to the embedded
//! model); `--source TEXT` describes the population (default: the file's
//! name and its generation settings).

use std::path::Path;
use std::process::ExitCode;

use sha2::{Digest, Sha256};
use tapeshape_eval::poptable::PopulationTable;
use tapeshape_population::Dataset;

fn main() -> ExitCode {
    match real_main() {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::FAILURE
        }
    }
}

fn real_main() -> Result<(), String> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let (mut input, mut out, mut model, mut source) = (None, None, None, None);
    let mut it = args.iter();
    while let Some(a) = it.next() {
        let mut value = |what: &str| {
            it.next()
                .cloned()
                .ok_or_else(|| format!("{a} needs {what}"))
        };
        match a.as_str() {
            "--out" => out = Some(value("a file")?),
            "--model" => model = Some(value("a model file")?),
            "--source" => source = Some(value("a description")?),
            s if !s.starts_with("--") && input.is_none() => input = Some(s.to_string()),
            other => return Err(format!("unknown argument {other} (see the file's docs)")),
        }
    }
    let input = input.ok_or("usage: population_table POP.tsd --out FILE.csv [--model FILE]")?;
    let out = out.ok_or("--out FILE.csv is needed")?;
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
