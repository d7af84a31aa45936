//! `tapeshape ports`: the computer's serial ports and which of them is a
//! tape station.
//!
//! Why: when the station does not find its tape by itself, the operator (or
//! whoever helps them on the phone) needs to see what the computer has and
//! why each port was not taken. One line per port: path, kind, USB
//! vendor:product id, serial number, product string, and what the hello
//! found ([`crate::link::probe`]). Then a line saying what to do.

use std::path::PathBuf;
use std::time::Duration;

use anyhow::Context as _;

use crate::cli::Global;
use crate::link::probe::{self, Decision, Outcome, ProbeConfig, Survey, SystemPorts};

/// Arguments of `tapeshape ports`.
#[derive(clap::Args, Clone, Debug)]
pub struct Args {
    /// How long to wait for each port's hello, milliseconds.
    #[arg(long, value_name = "MS", default_value_t = 500)]
    pub timeout_ms: u64,

    /// Say hello on every port, other devices too (a USB-serial adapter, a
    /// PCI UART); by default only ports that look like a tape station are
    /// sent anything.
    #[arg(long)]
    pub probe_all: bool,

    /// Also probe this path (a simulator's pty, a port the listing does
    /// not show); may be given more than once.
    #[arg(long, value_name = "PATH")]
    pub also: Vec<PathBuf>,

    /// Baud rate to open with (ignored by USB and pseudo-terminals).
    #[arg(long, default_value_t = 115_200)]
    pub baud: u32,
}

/// Lists and probes the ports, prints the table and the conclusion.
pub fn run(args: Args, _global: &Global) -> anyhow::Result<()> {
    let config = ProbeConfig {
        timeout: Duration::from_millis(args.timeout_ms),
        baud_rate: args.baud,
        probe_all: args.probe_all,
        ..ProbeConfig::default()
    };
    let runtime = tokio::runtime::Builder::new_current_thread()
        .enable_all()
        .build()
        .context("starting the async runtime")?;
    let lister = SystemPorts { also: args.also };
    let survey = runtime.block_on(probe::survey(&lister, &config))?;
    for line in table(&survey) {
        outln!("{line}")?;
    }
    outln!("{}", conclusion(&survey))?;
    Ok(())
}

/// The table's lines: a header, then one line per port with its columns
/// aligned; the last column is what probing found.
pub fn table(survey: &Survey) -> Vec<String> {
    let mut rows = vec![[
        "PATH".to_string(),
        "KIND".to_string(),
        "VID:PID".to_string(),
        "SERIAL".to_string(),
        "PRODUCT".to_string(),
        "HELLO".to_string(),
    ]];
    for p in &survey.ports {
        let c = &p.candidate;
        let usb = c.usb.as_ref();
        let text = |v: Option<&String>| v.cloned().unwrap_or_else(|| "-".into());
        rows.push([
            c.path.display().to_string(),
            c.kind.to_string(),
            usb.map_or("-".into(), |u| u.vid_pid()),
            text(usb.and_then(|u| u.serial.as_ref())),
            text(usb.and_then(|u| u.product.as_ref())),
            hello_column(&p.outcome),
        ]);
    }
    let mut widths = [0usize; 5];
    for row in &rows {
        for (w, cell) in widths.iter_mut().zip(row.iter()) {
            *w = (*w).max(cell.chars().count());
        }
    }
    rows.iter()
        .map(|row| {
            let mut line = String::new();
            for (cell, w) in row.iter().zip(widths) {
                line.push_str(&format!("{cell:<w$}  "));
            }
            line.push_str(&row[5]);
            line
        })
        .collect()
}

/// The last column: `answered: ...` or `no: why`.
fn hello_column(outcome: &Outcome) -> String {
    match outcome {
        Outcome::Answered(h) => format!(
            "answered: tape {:016x}, boot {}, firmware {}, protocol {}.{}",
            h.device_id,
            h.boot_id,
            probe::firmware_text(h),
            h.protocol.major,
            h.protocol.minor
        ),
        other => format!("no: {other}"),
    }
}

/// What the survey means for `tapeshape station`.
pub fn conclusion(survey: &Survey) -> String {
    match survey.decision() {
        Decision::One(p) => format!(
            "One tape station answered: `tapeshape station` connects to {} by itself.",
            p.candidate.path.display()
        ),
        Decision::Several(ps) => {
            let ports: Vec<String> = ps
                .iter()
                .map(|p| format!("--port {}", p.candidate.path.display()))
                .collect();
            format!(
                "{} tape stations answered: `tapeshape station` asks which; or give {}.",
                ps.len(),
                ports.join(" or ")
            )
        }
        Decision::None if survey.ports.is_empty() => "No serial ports are attached: plug the \
            tape station's USB cable into this computer (on the nRF52840-DK: the nRF USB \
            connector, not the debug one)."
            .to_string(),
        Decision::None => "No tape station answered: plug the tape station's USB cable into \
            this computer (on the nRF52840-DK: the nRF USB connector, not the debug one)."
            .to_string(),
    }
}
