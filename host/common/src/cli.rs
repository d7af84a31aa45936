//! Command-line handling the example programs share (feature `cli`).

/// Parses the command line into `P`. A bad command line prints clap's
/// message and exits with status 1, as the programs' run-time errors do
/// (clap's own status is 2); `--help` and `--version` print and exit 0.
pub fn parse_or_exit<P: clap::Parser>() -> P {
    match P::try_parse() {
        Ok(p) => p,
        Err(e) if e.use_stderr() => {
            let _ = e.print();
            std::process::exit(1);
        }
        Err(e) => e.exit(),
    }
}
