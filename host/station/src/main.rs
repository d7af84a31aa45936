//! `tapeshape`: the fitting-room station's command-line program.
//!
//! A thin dispatcher: every subcommand lives in `tapeshape::cli::<name>`
//! with an `Args` struct and a `run` function. To add one, add a variant to
//! [`Command`] and a line to the `match` in `main`.

use std::process::ExitCode;

use clap::{Parser, Subcommand};
use tapeshape::cli;

/// Large blocks on transparent huge pages (see the module's docs: a fifth
/// of a whole prediction was page faults).
#[cfg(target_os = "linux")]
#[global_allocator]
static ALLOC: tapeshape::alloc::HugePageHint = tapeshape::alloc::HugePageHint;

/// Fitting-room measurement station: tape link, session store and shape estimation.
#[derive(Parser, Debug)]
#[command(name = "tapeshape", version, propagate_version = true)]
struct Cli {
    #[command(flatten)]
    global: cli::Global,

    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand, Debug)]
enum Command {
    /// Connect to the tape (found by itself, or --port) and run the kiosk, or record a session line by line.
    Station(cli::station::Args),
    /// List the serial ports and say which one is a tape station (the hello each answered, or why not).
    Ports(cli::ports::Args),
    /// List the stored sessions.
    Sessions(cli::sessions::Args),
    /// Show, close or delete one session.
    Session(cli::session::Args),
    /// Record a session from a simulated tape through the real firmware logic and link.
    #[cfg(feature = "demo")]
    Demo(cli::demo::Args),
    /// The demo is not in this build (the kiosk build): says where it is.
    #[cfg(not(feature = "demo"))]
    #[command(hide = true)]
    Demo(cli::moved::Args),
    /// Take a measurement set (paper34, ansur, quick, face7 or a file) on a body mesh; --help lists the sets.
    Measure(cli::measure::Args),
    /// Make, import and inspect databases of registered bodies (training data).
    Dataset(cli::dataset::Args),
    /// Learn a shape model from a dataset of bodies (for `predict --model`).
    Train(cli::train::Args),
    /// Estimate a body mesh from tape measurements (any subset of the model's); --help for units and files.
    Predict(cli::predict::Args),
    /// Estimate a body for every person of a survey CSV, on all cores (resumable, shardable).
    Batch(cli::batch::Args),
    /// The paper's experiments moved to `tapeshape-eval`: says how to run them.
    #[command(hide = true)]
    Eval(cli::moved::Args),
    /// A customer's data at this station: export it, erase it (here and in the chain), look them up.
    Customer(cli::customer::Args),
    /// Send this station's unsent changes to the chain's hub and carry out the erasures it sends, then exit.
    Sync(cli::sync::Args),
    /// The chain's head-office hub: serve it (PostgreSQL), add stations and users, a customer in the chain.
    #[cfg(feature = "hub")]
    Hub(cli::hub::Args),
}

fn main() -> ExitCode {
    #[cfg(target_os = "linux")]
    tapeshape::alloc::tune();
    let args = match Cli::try_parse() {
        Ok(a) => a,
        Err(e) => {
            // Help, version or a usage error; printing it to a closed pipe
            // (`tapeshape --help | head`) is not an error of ours.
            let _ = e.print();
            return ExitCode::from(u8::try_from(e.exit_code()).unwrap_or(2));
        }
    };
    cli::init_logging(args.global.verbose);
    // The operator text's language, once for the whole run (`--lang`, else
    // the locale). The first choice cannot clash with an earlier one.
    if let Err(e) = tapeshape::i18n::choose(args.global.lang()) {
        tracing::warn!("{e}");
    }
    // Everything the program writes may hold customer data (the store, its
    // exports, cards, logs): owner-only, 0600 files and 0700 folders.
    rustix::process::umask(rustix::fs::Mode::from_raw_mode(0o077));
    // The embedded model decoded once per machine, kept in the data
    // directory (tapeshape_estimator::cache): a start costs milliseconds.
    if let Ok(dir) = args.global.data_dir() {
        tapeshape_estimator::Estimator::use_cache_dir(dir.join("cache"));
    }
    let result = match args.command {
        Command::Station(a) => cli::station::run(a, &args.global),
        Command::Ports(a) => cli::ports::run(a, &args.global),
        Command::Sessions(a) => cli::sessions::run(a, &args.global),
        Command::Session(a) => cli::session::run(a, &args.global),
        #[cfg(feature = "demo")]
        Command::Demo(a) => cli::demo::run(a, &args.global),
        #[cfg(not(feature = "demo"))]
        Command::Demo(a) => cli::moved::demo(a),
        Command::Measure(a) => cli::measure::run(a, &args.global),
        Command::Dataset(a) => cli::dataset::run(a, &args.global),
        Command::Train(a) => cli::train::run(a, &args.global),
        Command::Predict(a) => cli::predict::run(a, &args.global),
        Command::Batch(a) => cli::batch::run(a, &args.global),
        Command::Eval(a) => cli::moved::eval(a),
        Command::Customer(a) => cli::customer::run(a, &args.global),
        Command::Sync(a) => cli::sync::run(a, &args.global),
        #[cfg(feature = "hub")]
        Command::Hub(a) => cli::hub::run(a, &args.global),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        // The reader of our output went away (`| head`): it has what it
        // wanted; end quietly, as grep and ripgrep do.
        Err(e) if cli::is_broken_pipe(&e) => ExitCode::SUCCESS,
        Err(e) => {
            // The error with its context chain on one line, no backtrace,
            // each cause once.
            eprintln!("error: {}", cli::error_line(&e));
            ExitCode::FAILURE
        }
    }
}
