//! Subcommands of the `tapeshape` binary, one module each.
//!
//! Why in the library: `src/main.rs` stays a thin dispatcher, and each
//! subcommand's arguments and behaviour can be tested without spawning the
//! binary. To add a subcommand `foo`: write `cli/foo.rs` with a
//! `#[derive(clap::Args)] pub struct Args` and
//! `pub fn run(args: Args, global: &Global) -> anyhow::Result<()>`, add
//! `pub mod foo;` here, one variant to `Command` in `main.rs` and one
//! dispatch line.

use std::path::PathBuf;

use anyhow::Context as _;

use crate::store::{resolve_data_dir, Store};

pub mod dataset;
pub mod demo;
pub mod eval;
pub mod measure;
pub mod predict;
pub mod session;
pub mod sessions;
pub mod station;
pub mod train;

/// Options every subcommand takes.
#[derive(clap::Args, Clone, Debug, Default)]
pub struct Global {
    /// Directory holding the session database [default: $TAPESHAPE_DATA_DIR,
    /// else the user's data directory, e.g. ~/.local/share/tapeshape].
    #[arg(long, global = true, value_name = "DIR")]
    pub data_dir: Option<PathBuf>,

    /// More log output on stderr (-v info, -vv debug, -vvv trace). The
    /// TAPESHAPE_LOG environment variable (tracing filter syntax) overrides.
    #[arg(short, long, global = true, action = clap::ArgAction::Count)]
    pub verbose: u8,
}

impl Global {
    /// Opens the session store in the chosen data directory.
    pub fn open_store(&self) -> anyhow::Result<Store> {
        let dir = resolve_data_dir(self.data_dir.as_deref())?;
        Store::open(&dir).with_context(|| format!("opening the session store in {}", dir.display()))
    }
}

/// Sets up logging to stderr: level from `-v` unless `TAPESHAPE_LOG` is set.
pub fn init_logging(verbose: u8) {
    let default = match verbose {
        0 => "warn",
        1 => "info",
        2 => "debug",
        _ => "trace",
    };
    let filter = tracing_subscriber::EnvFilter::try_from_env("TAPESHAPE_LOG")
        .unwrap_or_else(|_| tracing_subscriber::EnvFilter::new(default));
    // Ignore the error of a second initialisation (tests may call this).
    let _ = tracing_subscriber::fmt()
        .with_env_filter(filter)
        .with_writer(std::io::stderr)
        .try_init();
}

/// Formats milliseconds since the Unix epoch as an RFC 3339 UTC time to the
/// second (`2026-11-22T05:30:00Z`).
pub fn format_time_ms(ms: i64) -> String {
    let t =
        std::time::UNIX_EPOCH + std::time::Duration::from_millis(u64::try_from(ms).unwrap_or(0));
    humantime::format_rfc3339_seconds(t).to_string()
}

/// Formats a length in tenths of a millimetre as millimetres (`951.2 mm`).
pub fn format_tenth_mm(v: u32) -> String {
    format!("{}.{} mm", v / 10, v % 10)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn formats() {
        assert_eq!(format_tenth_mm(9512), "951.2 mm");
        assert_eq!(format_tenth_mm(7), "0.7 mm");
        assert_eq!(format_time_ms(0), "1970-01-01T00:00:00Z");
        assert_eq!(format_time_ms(1_000_000_000_123), "2001-09-09T01:46:40Z");
    }
}
