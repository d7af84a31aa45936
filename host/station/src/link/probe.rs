//! Finding the tape station among the computer's serial ports.
//!
//! Why: an operator does not know which of `/dev/ttyACM0`, `/dev/ttyACM1`
//! and `/dev/ttyUSB0` is the tape. `tapeshape station` without `--port`
//! and `tapeshape ports` ask this module: it lists the serial ports
//! ([`PortLister`]; on a real machine [`SystemPorts`], through the
//! `serialport` crate), orders the likely ones first by their USB identity
//! (the firmware's descriptor, [`tapeshape_protocol::usb`]), says hello on
//! each likely one ([`probe_port`]) and reports who answered ([`Survey`]).
//! The lister is a trait so that tests run the whole search over
//! pseudo-terminals, which are not USB ports.
//!
//! Which ports are probed ([`Rank`]): a USB port whose product string is
//! the station's, then one with the station's vendor:product id (pid.codes'
//! test id, which other development boards share), then ports named by the
//! caller (`tapeshape ports --also PATH`, tests). Other devices (another
//! USB device, a PCI or platform UART, Bluetooth) are not sent a byte
//! unless [`ProbeConfig::probe_all`] is set: a hello means nothing to a
//! modem or a 3D printer and could disturb it.
//!
//! What a probe does to a port, and nothing more: open it exclusively (as
//! the link does; a port another program holds is reported busy and left
//! alone), write one frame delimiter and one host hello, read until a
//! device hello arrives or [`ProbeConfig::timeout`] passes, close. The
//! hello acknowledges nothing: the firmware keeps every unacknowledged
//! reading until a host sends an `Ack` (`firmware/src/device.rs`), and
//! resends them all to the next host that says hello, so probing a tape
//! never loses a reading (tested in `tests/probe.rs`). The framing is the
//! link's (`open_port`, `write_msg` in [`super`], the protocol
//! crate's [`FrameDecoder`]).
//!
//! Candidates are probed concurrently, so a survey takes one timeout
//! however many ports there are.

use std::fmt;
use std::path::{Path, PathBuf};
use std::time::Duration;

use tapeshape_protocol::{
    usb, DeviceHello, DeviceMsg, FrameDecoder, HostHello, HostMsg, ProtocolVersion,
    SoftwareVersion, PROTOCOL_VERSION,
};
use tokio::io::{AsyncReadExt, AsyncWriteExt};

use crate::i18n::{self, msg, tr, FluentArgs, Lang};

use super::events::host_software_version;
use super::{open_port, write_msg};

/// How a serial port is attached.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum PortKind {
    /// A USB device (CDC-ACM, or a USB-serial bridge).
    Usb,
    /// A pseudo-terminal (a simulator's port; never a real tape).
    Pty,
    /// A PCI serial card or a motherboard UART.
    Pci,
    /// A Bluetooth serial link.
    Bluetooth,
    /// Anything else (a platform UART, a path of unknown kind).
    Other,
}

impl fmt::Display for PortKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            PortKind::Usb => "USB",
            PortKind::Pty => "pty",
            PortKind::Pci => "PCI",
            PortKind::Bluetooth => "Bluetooth",
            PortKind::Other => "other",
        })
    }
}

/// A USB port's identity, as its device descriptor gives it.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct UsbIdentity {
    /// Vendor id.
    pub vid: u16,
    /// Product id.
    pub pid: u16,
    /// Serial number string (the station's is its device id in hex).
    pub serial: Option<String>,
    /// Manufacturer string.
    pub manufacturer: Option<String>,
    /// Product string.
    pub product: Option<String>,
}

impl UsbIdentity {
    /// `vvvv:pppp` in hex, as `lsusb` writes it.
    pub fn vid_pid(&self) -> String {
        format!("{:04x}:{:04x}", self.vid, self.pid)
    }

    /// Whether the product string is the station's ([`usb::PRODUCT`]).
    pub fn is_station_product(&self) -> bool {
        self.product
            .as_deref()
            .is_some_and(|p| p.trim().eq_ignore_ascii_case(usb::PRODUCT))
    }

    /// Whether the vendor:product id is the station's ([`usb::VID`],
    /// [`usb::PID`]).
    pub fn is_station_id(&self) -> bool {
        self.vid == usb::VID && self.pid == usb::PID
    }
}

/// A serial port that might be the tape station.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Candidate {
    /// The path to open.
    pub path: PathBuf,
    /// How it is attached.
    pub kind: PortKind,
    /// Its USB identity, for a USB port.
    pub usb: Option<UsbIdentity>,
    /// Named by the caller (not found by listing): probed whatever it is.
    pub named: bool,
}

impl Candidate {
    /// A port named by the caller: its kind from the path (a pty when it
    /// resolves under `/dev/pts`, else other), no USB identity, probed.
    pub fn named(path: impl Into<PathBuf>) -> Candidate {
        let path = path.into();
        let kind = match std::fs::canonicalize(&path) {
            Ok(real) if real.starts_with("/dev/pts") => PortKind::Pty,
            _ => PortKind::Other,
        };
        Candidate {
            path,
            kind,
            usb: None,
            named: true,
        }
    }

    /// A port as `serialport::available_ports` lists it.
    pub fn from_info(info: &tokio_serial::SerialPortInfo) -> Candidate {
        use tokio_serial::SerialPortType as T;
        let (kind, usb) = match &info.port_type {
            T::UsbPort(u) => (
                PortKind::Usb,
                Some(UsbIdentity {
                    vid: u.vid,
                    pid: u.pid,
                    serial: u.serial_number.clone(),
                    manufacturer: u.manufacturer.clone(),
                    product: u.product.clone(),
                }),
            ),
            T::PciPort => (PortKind::Pci, None),
            T::BluetoothPort => (PortKind::Bluetooth, None),
            T::Unknown => (PortKind::Other, None),
        };
        Candidate {
            path: PathBuf::from(&info.port_name),
            kind,
            usb,
            named: false,
        }
    }

    /// How likely this port is the station (see [`Rank`]).
    pub fn rank(&self) -> Rank {
        match &self.usb {
            Some(u) if u.is_station_product() => Rank::StationProduct,
            Some(u) if u.is_station_id() => Rank::StationUsbId,
            _ if self.named => Rank::Named,
            _ => Rank::OtherDevice,
        }
    }
}

/// How likely a port is the tape station; candidates are probed in this
/// order, and [`Rank::OtherDevice`] not at all unless asked.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Rank {
    /// A USB port whose product string is the station's.
    StationProduct,
    /// A USB port with the station's vendor:product id but another (or
    /// no) product string.
    StationUsbId,
    /// A port the caller named.
    Named,
    /// Another device.
    OtherDevice,
}

/// Where the candidates come from. A closure returning the list works
/// too, which is how tests inject pseudo-terminals.
pub trait PortLister {
    /// The serial ports there are now.
    fn list(&self) -> Result<Vec<Candidate>, ProbeError>;
}

impl<F> PortLister for F
where
    F: Fn() -> Result<Vec<Candidate>, ProbeError>,
{
    fn list(&self) -> Result<Vec<Candidate>, ProbeError> {
        self()
    }
}

/// The computer's serial ports (`serialport::available_ports`), plus the
/// paths in `also`.
#[derive(Clone, Debug, Default)]
pub struct SystemPorts {
    /// Paths to consider besides the listed ports (a simulator's pty).
    pub also: Vec<PathBuf>,
}

impl PortLister for SystemPorts {
    fn list(&self) -> Result<Vec<Candidate>, ProbeError> {
        let mut all: Vec<Candidate> = system_ports()?.iter().map(Candidate::from_info).collect();
        all.extend(self.also.iter().map(Candidate::named));
        Ok(all)
    }
}

/// `serialport::available_ports`, without its panic: on Linux (without
/// libudev, as this build has it) it scans `/sys/class/tty` and panics
/// when that cannot be read (a container without sysfs), and nothing
/// from outside may panic the station.
fn system_ports() -> Result<Vec<tokio_serial::SerialPortInfo>, ProbeError> {
    #[cfg(target_os = "linux")]
    if let Err(source) = std::fs::read_dir("/sys/class/tty") {
        return Err(ProbeError::NoSysfs { source });
    }
    tokio_serial::available_ports().map_err(|source| ProbeError::List { source })
}

/// Why the serial ports could not be listed.
#[derive(Debug, thiserror::Error)]
pub enum ProbeError {
    /// The serial port library failed.
    #[error("cannot list the serial ports: {source}; give the tape's port with --port PATH")]
    List {
        /// The library's error.
        source: tokio_serial::Error,
    },
    /// Linux's list of ttys is not readable.
    #[error(
        "cannot list the serial ports: /sys/class/tty is not readable ({source}); \
         give the tape's port with --port PATH"
    )]
    NoSysfs {
        /// The error reading it.
        source: std::io::Error,
    },
}

/// How to probe.
#[derive(Clone, Copy, Debug)]
pub struct ProbeConfig {
    /// How long to wait for a device hello on one port.
    pub timeout: Duration,
    /// Baud rate to open with (a USB CDC port ignores it).
    pub baud_rate: u32,
    /// The protocol version this host speaks (sent in the hello).
    pub protocol: ProtocolVersion,
    /// This host's software version (sent in the hello).
    pub software: SoftwareVersion,
    /// Probe every port, other devices too (see the module docs).
    pub probe_all: bool,
}

impl Default for ProbeConfig {
    /// Half a second per port: the firmware answers a hello at once (a few
    /// milliseconds over USB); the rest is slack for a busy computer.
    fn default() -> Self {
        Self {
            timeout: Duration::from_millis(500),
            baud_rate: 115_200,
            protocol: PROTOCOL_VERSION,
            software: host_software_version(),
            probe_all: false,
        }
    }
}

/// What probing a port found.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Outcome {
    /// A tape station speaking a compatible protocol answered.
    Answered(DeviceHello),
    /// A tape station answered with a protocol of another major version.
    Incompatible {
        /// Its hello.
        device: DeviceHello,
        /// The version this host speaks.
        host: ProtocolVersion,
    },
    /// Not probed: another device (see [`Rank::OtherDevice`]).
    NotProbed,
    /// Nothing came back.
    Silent {
        /// How long it waited.
        waited: Duration,
    },
    /// Bytes came back, but no valid frame.
    NotTheProtocol {
        /// Bytes received.
        bytes: usize,
        /// Frames that failed to decode (COBS, CRC, message).
        bad_frames: u32,
        /// How long it waited.
        waited: Duration,
    },
    /// Valid frames came back, but no hello.
    NoHello {
        /// Valid frames received.
        frames: u32,
        /// How long it waited.
        waited: Duration,
    },
    /// Opening was refused by permissions.
    PermissionDenied,
    /// Another program has the port open.
    Busy,
    /// The path does not exist (any more).
    Gone,
    /// Opening failed otherwise.
    OpenFailed(String),
    /// Reading or writing failed after opening.
    Io(String),
}

impl Outcome {
    /// The hello of a compatible station, if this is one.
    pub fn station(&self) -> Option<&DeviceHello> {
        match self {
            Outcome::Answered(h) => Some(h),
            _ => None,
        }
    }
}

/// The firmware's version as `major.minor.patch`.
pub fn firmware_text(h: &DeviceHello) -> String {
    format!(
        "{}.{}.{}",
        h.firmware.major, h.firmware.minor, h.firmware.patch
    )
}

impl Outcome {
    /// What probing found, in words of `lang` (the kiosk's search screen
    /// uses the chosen language; the line mode and `tapeshape ports` print
    /// English, [`Outcome`]'s `Display`).
    pub fn words_in(&self, lang: Lang) -> String {
        let mut args = FluentArgs::new();
        let id = match self {
            Outcome::Answered(h) => {
                args.set("device", format!("{:016x}", h.device_id));
                args.set("boot", h.boot_id.to_string());
                args.set("firmware", firmware_text(h));
                args.set(
                    "protocol",
                    format!("{}.{}", h.protocol.major, h.protocol.minor),
                );
                msg!("probe-answered")
            }
            Outcome::Incompatible { device, host } => {
                args.set("device", format!("{:016x}", device.device_id));
                args.set(
                    "protocol",
                    format!("{}.{}", device.protocol.major, device.protocol.minor),
                );
                args.set("firmware", firmware_text(device));
                args.set("host", format!("{}.{}", host.major, host.minor));
                msg!("probe-incompatible")
            }
            Outcome::NotProbed => msg!("probe-not-probed"),
            Outcome::Silent { waited } => {
                args.set("ms", waited.as_millis().to_string());
                msg!("probe-silent")
            }
            Outcome::NotTheProtocol {
                bytes,
                bad_frames,
                waited,
            } => {
                args.set("bytes", bytes.to_string());
                args.set("bad", bad_frames.to_string());
                args.set("ms", waited.as_millis().to_string());
                msg!("probe-not-the-protocol")
            }
            Outcome::NoHello { frames, waited } => {
                args.set("frames", frames.to_string());
                args.set("ms", waited.as_millis().to_string());
                msg!("probe-no-hello")
            }
            Outcome::PermissionDenied => msg!("probe-permission-denied"),
            Outcome::Busy => msg!("probe-busy"),
            Outcome::Gone => msg!("probe-gone"),
            Outcome::OpenFailed(e) => {
                args.set("error", e.clone());
                msg!("probe-open-failed")
            }
            Outcome::Io(e) => {
                args.set("error", e.clone());
                msg!("probe-io")
            }
        };
        i18n::text_in(lang, id, Some(&args))
    }
}

impl fmt::Display for Outcome {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.words_in(Lang::En))
    }
}

/// A candidate and what probing it found.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Probed {
    /// The port.
    pub candidate: Candidate,
    /// What it did.
    pub outcome: Outcome,
}

/// Says hello on `path` and waits for a device hello (see the module docs
/// for exactly what it does to the port). Must run inside a tokio runtime
/// with I/O and time enabled.
pub async fn probe_port(path: &Path, config: &ProbeConfig) -> Outcome {
    let mut port = match open_port(path, config.baud_rate) {
        Ok(p) => p,
        Err(e) => return open_failure(path, &e.error),
    };
    let started = tokio::time::Instant::now();
    let deadline = started + config.timeout;
    // A lone delimiter ends any partial frame the device holds, as the
    // link does on connecting; then the hello.
    if let Err(e) = port.write_all(&[0]).await {
        return Outcome::Io(format!("write error: {e}"));
    }
    let hello = HostMsg::Hello(HostHello {
        protocol: config.protocol,
        software: config.software,
    });
    if let Err(e) = write_msg(&mut port, &hello).await {
        return Outcome::Io(e.to_string());
    }
    let mut decoder = FrameDecoder::<DeviceMsg>::new();
    let (mut bytes, mut frames, mut bad_frames) = (0usize, 0u32, 0u32);
    let mut buf = [0u8; 512];
    loop {
        let n = match tokio::time::timeout_at(deadline, port.read(&mut buf)).await {
            Err(_) => break,
            Ok(Ok(0)) => return Outcome::Gone,
            Ok(Ok(n)) => n,
            Ok(Err(e)) => return Outcome::Io(format!("read error: {e}")),
        };
        bytes += n;
        for msg in decoder.feed(&buf[..n]) {
            match msg {
                Ok(DeviceMsg::Hello(device)) => {
                    return if config.protocol.is_compatible(&device.protocol) {
                        Outcome::Answered(device)
                    } else {
                        Outcome::Incompatible {
                            device,
                            host: config.protocol,
                        }
                    };
                }
                Ok(_) => frames += 1,
                Err(_) => bad_frames += 1,
            }
        }
    }
    let waited = started.elapsed();
    if frames > 0 {
        Outcome::NoHello { frames, waited }
    } else if bytes > 0 {
        Outcome::NotTheProtocol {
            bytes,
            bad_frames,
            waited,
        }
    } else {
        Outcome::Silent {
            waited: config.timeout,
        }
    }
}

/// Why opening failed, in the operator's terms.
fn open_failure(path: &Path, e: &tokio_serial::Error) -> Outcome {
    use std::io::ErrorKind as Io;
    use tokio_serial::ErrorKind as K;
    match e.kind() {
        K::Io(Io::PermissionDenied) => Outcome::PermissionDenied,
        K::Io(Io::NotFound) => Outcome::Gone,
        // serialport reports a port held exclusively by another program
        // (TIOCEXCL or flock) as NoDevice; a path that is gone too.
        K::NoDevice if !path.exists() => Outcome::Gone,
        K::NoDevice => Outcome::Busy,
        _ => Outcome::OpenFailed(e.to_string()),
    }
}

/// Every port seen in one survey, likely ones first, with what each did.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Survey {
    /// The ports in [`Rank`] order (then by path).
    pub ports: Vec<Probed>,
}

/// What a survey means for the station.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Decision<'a> {
    /// Exactly one station answered: connect to it.
    One(&'a Probed),
    /// Several stations answered: the operator chooses.
    Several(Vec<&'a Probed>),
    /// None answered.
    None,
}

impl Survey {
    /// The ports where a compatible station answered, in rank order; one
    /// device seen through two paths counts once.
    pub fn stations(&self) -> Vec<&Probed> {
        let mut seen = std::collections::HashSet::new();
        self.ports
            .iter()
            .filter(|p| {
                p.outcome
                    .station()
                    .is_some_and(|h| seen.insert(h.device_id))
            })
            .collect()
    }

    /// Connect, ask, or keep looking.
    pub fn decision(&self) -> Decision<'_> {
        let mut stations = self.stations();
        match stations.len() {
            0 => Decision::None,
            1 => Decision::One(stations.remove(0)),
            _ => Decision::Several(stations),
        }
    }

    /// What to tell the operator when no station answered, in the chosen
    /// language (the kiosk's search screen): what to plug in, then each
    /// port seen and why it was not taken (one per line, no trailing
    /// newline).
    pub fn nothing_found(&self) -> String {
        let lang = i18n::lang();
        let mut text = tr!("search-nothing-answered");
        if self.ports.is_empty() {
            text.push_str(&format!("\n{}", tr!("search-no-ports")));
        } else {
            text.push_str(&format!("\n{}", tr!("search-ports-seen")));
            for p in &self.ports {
                text.push_str(&format!("\n  {}", describe_in(p, lang)));
            }
        }
        text
    }
}

/// One line about a probed port: path, kind, USB identity, outcome, and a
/// hint for the board's debug port (English: the line mode's `seen` lines).
pub fn describe(p: &Probed) -> String {
    describe_in(p, Lang::En)
}

/// [`describe`] in words of `lang`.
pub fn describe_in(p: &Probed, lang: Lang) -> String {
    let c = &p.candidate;
    let mut line = format!("{} ({}", c.path.display(), c.kind);
    if let Some(u) = &c.usb {
        line.push_str(&format!(" {}", u.vid_pid()));
        if let Some(product) = &u.product {
            line.push_str(&format!(" \"{product}\""));
        }
    }
    line.push_str(&format!("): {}", p.outcome.words_in(lang)));
    // SEGGER's vendor id: the DK's J-Link (debug) USB port, which carries
    // the tape input on the bench, not the host link.
    if c.usb.as_ref().is_some_and(|u| u.vid == 0x1366) {
        line.push_str(&format!(
            "; {}",
            i18n::text_in(lang, msg!("probe-debug-port"), None)
        ));
    }
    line
}

/// Lists the candidates, orders them ([`Rank`], then path; one path once),
/// probes the likely ones concurrently and returns what each did. Must run
/// inside a tokio runtime with I/O and time enabled.
pub async fn survey(lister: &dyn PortLister, config: &ProbeConfig) -> Result<Survey, ProbeError> {
    let mut candidates = lister.list()?;
    candidates.sort_by(|a, b| (a.rank(), &a.path).cmp(&(b.rank(), &b.path)));
    // One device file once, whatever paths name it (/dev/ttyACM0 and its
    // /dev/serial/by-id link): opening it twice would make the second
    // probe report it busy.
    let mut real_paths = std::collections::HashSet::new();
    candidates
        .retain(|c| real_paths.insert(std::fs::canonicalize(&c.path).unwrap_or(c.path.clone())));
    let mut tasks = tokio::task::JoinSet::new();
    for (i, c) in candidates.iter().enumerate() {
        if config.probe_all || c.rank() != Rank::OtherDevice {
            let (path, config) = (c.path.clone(), *config);
            tasks.spawn(async move { (i, probe_port(&path, &config).await) });
        }
    }
    let mut outcomes = vec![Outcome::NotProbed; candidates.len()];
    while let Some(done) = tasks.join_next().await {
        match done {
            Ok((i, outcome)) => outcomes[i] = outcome,
            // A probe does not panic; should one anyway, its port shows as
            // not probed rather than ending the station.
            Err(e) => tracing::error!(error = %e, "a port probe failed"),
        }
    }
    Ok(Survey {
        ports: candidates
            .into_iter()
            .zip(outcomes)
            .map(|(candidate, outcome)| Probed { candidate, outcome })
            .collect(),
    })
}

/// A stable name for `port`: the `/dev/serial/by-id` link that resolves to
/// the same device, if there is one, else `port` itself. Why: after an
/// unplug the kernel may give the tape another `ttyACM` number, while its
/// by-id name (from the USB serial number, the station's device id) stays,
/// so the link finds it again when it is plugged back in.
pub fn stable_path(port: &Path) -> PathBuf {
    stable_path_in(Path::new("/dev/serial/by-id"), port)
}

/// [`stable_path`] looking in `dir` (for tests).
pub fn stable_path_in(dir: &Path, port: &Path) -> PathBuf {
    let Ok(real) = std::fs::canonicalize(port) else {
        return port.to_path_buf();
    };
    let Ok(entries) = std::fs::read_dir(dir) else {
        return port.to_path_buf();
    };
    let mut links: Vec<PathBuf> = entries
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| std::fs::canonicalize(p).is_ok_and(|r| r == real))
        .collect();
    links.sort();
    links
        .into_iter()
        .next()
        .unwrap_or_else(|| port.to_path_buf())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn usb(vid: u16, pid: u16, product: Option<&str>) -> Candidate {
        Candidate {
            path: PathBuf::from(format!("/dev/ttyACM-{vid:04x}-{pid:04x}")),
            kind: PortKind::Usb,
            usb: Some(UsbIdentity {
                vid,
                pid,
                product: product.map(str::to_string),
                ..UsbIdentity::default()
            }),
            named: false,
        }
    }

    #[test]
    fn the_station_product_ranks_first_and_other_devices_last() {
        assert_eq!(
            usb(usb::VID, usb::PID, Some(usb::PRODUCT)).rank(),
            Rank::StationProduct
        );
        // The product string counts even under another id (a production
        // run with its own product id).
        assert_eq!(
            usb(0x1234, 0x5678, Some("Tapeshape Tape Station ")).rank(),
            Rank::StationProduct
        );
        // pid.codes' test id without our product: another dev board maybe.
        assert_eq!(
            usb(usb::VID, usb::PID, Some("other board")).rank(),
            Rank::StationUsbId
        );
        assert_eq!(
            usb(0x0403, 0x6001, Some("FT232R USB UART")).rank(),
            Rank::OtherDevice
        );
        let pci = Candidate {
            path: "/dev/ttyS0".into(),
            kind: PortKind::Pci,
            usb: None,
            named: false,
        };
        assert_eq!(pci.rank(), Rank::OtherDevice);
        assert_eq!(Candidate::named("/nonexistent/tape").rank(), Rank::Named);
        assert!(Rank::StationProduct < Rank::StationUsbId);
        assert!(Rank::StationUsbId < Rank::Named);
        assert!(Rank::Named < Rank::OtherDevice);
    }

    #[test]
    fn other_devices_are_not_sent_a_byte() {
        // A path that would fail to open if it were probed: it must come
        // back as not probed, not as gone.
        let rt = tokio::runtime::Builder::new_current_thread()
            .enable_all()
            .build()
            .unwrap();
        let other = Candidate {
            path: "/nonexistent/ttyUSB9".into(),
            ..usb(0x0403, 0x6001, None)
        };
        let lister = move || Ok(vec![other.clone()]);
        let s = rt
            .block_on(survey(&lister, &ProbeConfig::default()))
            .unwrap();
        assert_eq!(s.ports.len(), 1);
        assert_eq!(s.ports[0].outcome, Outcome::NotProbed);
        assert_eq!(s.decision(), Decision::None);
        let all = ProbeConfig {
            probe_all: true,
            ..ProbeConfig::default()
        };
        let s = rt.block_on(survey(&lister, &all)).unwrap();
        assert_eq!(s.ports[0].outcome, Outcome::Gone);
    }

    #[test]
    fn a_missing_named_path_is_reported_gone() {
        let rt = tokio::runtime::Builder::new_current_thread()
            .enable_all()
            .build()
            .unwrap();
        let outcome = rt.block_on(probe_port(
            Path::new("/nonexistent/tape"),
            &ProbeConfig::default(),
        ));
        assert_eq!(outcome, Outcome::Gone);
        let text = describe(&Probed {
            candidate: Candidate::named("/nonexistent/tape"),
            outcome,
        });
        assert!(
            text.starts_with("/nonexistent/tape (other): no such port"),
            "{text}"
        );
    }

    #[test]
    fn the_debug_port_gets_a_hint() {
        let p = Probed {
            candidate: usb(0x1366, 0x1051, Some("J-Link")),
            outcome: Outcome::NotProbed,
        };
        let text = describe(&p);
        assert!(text.contains("1366:1051 \"J-Link\""), "{text}");
        assert!(text.contains("debug (J-Link) port"), "{text}");
    }

    #[test]
    fn a_stable_name_is_the_by_id_link_to_the_same_device() {
        let dir = tempfile::tempdir().unwrap();
        let by_id = dir.path().join("by-id");
        std::fs::create_dir(&by_id).unwrap();
        let dev = dir.path().join("ttyACM0");
        let other = dir.path().join("ttyACM1");
        std::fs::write(&dev, b"").unwrap();
        std::fs::write(&other, b"").unwrap();
        let link = by_id.join("usb-tapeshape_tapeshape_tape_station_0123-if00");
        std::os::unix::fs::symlink(&dev, &link).unwrap();
        std::os::unix::fs::symlink(&other, by_id.join("usb-other-if00")).unwrap();
        assert_eq!(stable_path_in(&by_id, &dev), link);
        // No link: the path itself; no folder: the path itself.
        let lone = dir.path().join("ttyACM2");
        std::fs::write(&lone, b"").unwrap();
        assert_eq!(stable_path_in(&by_id, &lone), lone);
        assert_eq!(stable_path_in(&dir.path().join("none"), &dev), dev);
    }
}
