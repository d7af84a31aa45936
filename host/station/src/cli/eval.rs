//! `tapeshape eval NAME --out DIR`: the paper's experiments, its baselines
//! and real measurements (issue 6). The experiments live in
//! `tapeshape-eval`; this file only parses the command line.

/// Arguments of `tapeshape eval`.
#[derive(clap::Args, Clone, Debug)]
pub struct Args {
    /// Experiment to run.
    pub name: String,

    /// Folder for the tables and figures.
    #[arg(long)]
    pub out: std::path::PathBuf,
}

/// Runs one experiment.
pub fn run(args: Args, _global: &super::Global) -> anyhow::Result<()> {
    anyhow::bail!(
        "eval {}: no experiments are built into this program yet (out: {})",
        args.name,
        args.out.display()
    )
}
