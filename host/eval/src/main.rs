//! `tapeshape-eval NAME --out DIR [--quick]`: the paper's experiments, its
//! baselines and real measurements (issue 6), as a program of their own.
//!
//! Why not a subcommand of `tapeshape`: the kiosk program carries the kiosk.
//! The experiments bring SGPLVM, RBF interpolation and figure rendering that
//! no fitting room needs, so they live in this crate's binary and the
//! station's dependency tree stays free of them. Run it as
//! `cargo run --release -p tapeshape-eval -- NAME --out DIR [--quick]`.
//!
//! This file parses the command line, runs one experiment (or `all`), prints
//! the headline numbers and, in `--quick` mode, fails when a check (the
//! method beats feature analysis and SGPLVM) does not hold.

use std::io::Write as _;
use std::process::ExitCode;

use anyhow::Context as _;
use clap::Parser;
use tapeshape_eval::experiments::{self as exp, all_methods, Experiment, Options};

/// Run one of the paper's experiments (and its baselines) and write its tables and figures.
#[derive(Parser, Debug)]
#[command(name = "tapeshape-eval", version)]
struct Args {
    /// Experiment to run: body-synthetic, body-real-table, small-train,
    /// face, ansur, ansur-holdout, or `all` (each into DIR/NAME).
    name: String,

    /// Folder for the tables (Markdown, CSV, JSON) and figures (PNG).
    #[arg(long)]
    out: std::path::PathBuf,

    /// Few bodies and samples (CI, a few minutes); checks that the method
    /// beats feature analysis and SGPLVM and fails if not.
    #[arg(long)]
    quick: bool,
}

fn run(args: &Args) -> anyhow::Result<()> {
    let list: Vec<Experiment> = if args.name == "all" {
        Experiment::ALL.to_vec()
    } else {
        vec![Experiment::parse(&args.name)?]
    };
    let mut stdout = std::io::stdout().lock();
    let mut failed = Vec::new();
    for e in list {
        let out = if args.name == "all" {
            args.out.join(e.name())
        } else {
            args.out.clone()
        };
        let command = format!(
            "cargo run --release -p tapeshape-eval -- {} --out {}{}",
            e.name(),
            out.display(),
            if args.quick { " --quick" } else { "" }
        );
        let opts = Options {
            out: out.clone(),
            quick: args.quick,
            command,
        };
        let res =
            exp::run(e, &opts, &all_methods).with_context(|| format!("experiment {}", e.name()))?;
        writeln!(
            stdout,
            "{}: done in {:.1} min, results in {}",
            e.name(),
            res.seconds / 60.0,
            out.display()
        )?;
        for h in &res.headline {
            writeln!(stdout, "{h}")?;
        }
        for c in &res.checks {
            writeln!(
                stdout,
                "check: {} — {}",
                c.what,
                if c.passed { "ok" } else { "FAILED" }
            )?;
            if !c.passed {
                failed.push(format!("{}: {}", e.name(), c.what));
            }
        }
    }
    if !failed.is_empty() {
        anyhow::bail!("quick-mode checks failed:\n  {}", failed.join("\n  "));
    }
    Ok(())
}

fn main() -> ExitCode {
    let args = match Args::try_parse() {
        Ok(a) => a,
        Err(e) => {
            let _ = e.print();
            return ExitCode::from(u8::try_from(e.exit_code()).unwrap_or(2));
        }
    };
    match run(&args) {
        Ok(()) => ExitCode::SUCCESS,
        // The reader of our output went away (`| head`): end quietly.
        Err(e)
            if e.chain().any(|c| {
                c.downcast_ref::<std::io::Error>()
                    .is_some_and(|e| e.kind() == std::io::ErrorKind::BrokenPipe)
            }) =>
        {
            ExitCode::SUCCESS
        }
        Err(e) => {
            eprintln!("error: {e:#}");
            ExitCode::FAILURE
        }
    }
}
