//! Commands that are not in this build of `tapeshape`, with where they are.
//!
//! Why keep the names: an operator or a script that types `tapeshape eval`
//! (the research experiments, now their own program) or `tapeshape demo` on
//! a kiosk built without the demo should be told where the command went,
//! not "unrecognized subcommand".

/// Arguments of a command that moved: whatever was typed after it.
#[derive(clap::Args, Debug, Clone)]
pub struct Args {
    /// Everything after the command name, passed on in the message.
    #[arg(trailing_var_arg = true, allow_hyphen_values = true)]
    pub rest: Vec<String>,
}

/// `tapeshape eval ...`: the experiments are the `tapeshape-eval` program.
pub fn eval(args: Args) -> anyhow::Result<()> {
    anyhow::bail!(
        "the experiments are no longer part of the station program (the kiosk carries the kiosk): run `cargo run --release -p tapeshape-eval -- {}` from the repository",
        if args.rest.is_empty() {
            "NAME --out DIR [--quick]".to_string()
        } else {
            args.rest.join(" ")
        }
    )
}

/// `tapeshape demo ...` in a build without the `demo` feature.
#[cfg(not(feature = "demo"))]
pub fn demo(_args: Args) -> anyhow::Result<()> {
    anyhow::bail!(
        "this tapeshape was built without the demo (the kiosk build, --no-default-features): run the demo from the repository with `cargo run --release -p tapeshape -- demo`"
    )
}
