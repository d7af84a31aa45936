//! `tapeshape eval NAME --out DIR [--quick]`: the paper's experiments, its
//! baselines and real measurements (issue 6). The experiments live in
//! `tapeshape-eval`; this file parses the command line, runs one (or
//! `all`), prints the headline numbers and, in `--quick` mode, fails when a
//! check (the method beats feature analysis and SGPLVM) does not hold.

use anyhow::Context as _;
use tapeshape_eval::experiments::{self as exp, all_methods, Experiment, Options};

/// Arguments of `tapeshape eval`.
#[derive(clap::Args, Clone, Debug)]
pub struct Args {
    /// Experiment to run: body-synthetic, body-real-table, small-train,
    /// face, ansur, ansur-holdout, or `all` (each into DIR/NAME).
    pub name: String,

    /// Folder for the tables (Markdown, CSV, JSON) and figures (PNG).
    #[arg(long)]
    pub out: std::path::PathBuf,

    /// Few bodies and samples (CI, a few minutes); checks that the method
    /// beats feature analysis and SGPLVM and fails if not.
    #[arg(long)]
    pub quick: bool,
}

/// Runs one experiment (or all).
pub fn run_cmd(args: &Args) -> anyhow::Result<()> {
    let list: Vec<Experiment> = if args.name == "all" {
        Experiment::ALL.to_vec()
    } else {
        vec![Experiment::parse(&args.name)?]
    };
    let mut failed = Vec::new();
    for e in list {
        let out = if args.name == "all" {
            args.out.join(e.name())
        } else {
            args.out.clone()
        };
        let command = format!(
            "cargo run --release -p tapeshape -- eval {} --out {}{}",
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
        outln!(
            "{}: done in {:.1} min, results in {}",
            e.name(),
            res.seconds / 60.0,
            out.display()
        )?;
        for h in &res.headline {
            outln!("{h}")?;
        }
        for c in &res.checks {
            outln!(
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

/// Runs one experiment.
pub fn run(args: Args, _global: &super::Global) -> anyhow::Result<()> {
    run_cmd(&args)
}
