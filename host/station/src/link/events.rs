//! What the link says and is told: its settings, how readings are named,
//! the events it reports and the errors in them, and the [`ReadingSink`] it
//! commits through. Apart from the task ([`super`]) so that each file stays
//! one thing.

use std::collections::VecDeque;
use std::fmt;
use std::path::PathBuf;
use std::sync::Arc;
use std::time::Duration;

use tapeshape_protocol::{
    ButtonKind, DeviceHello, Fault, FrameError, Live, ProtocolVersion, Reading, SoftwareVersion,
    Status, UnitShown, PROTOCOL_VERSION,
};

use crate::store::{CommitOutcome, DeviceReading, SessionId, StoreError, StoredReading};

/// Where the link commits the readings it receives: the session layer
/// ([`crate::session::Sessions`] implements it). A trait, so that the link,
/// a lower layer, does not import the session layer.
pub trait ReadingSink: Send + Sync + 'static {
    /// Highest sequence number committed for this device boot, if any.
    fn last_committed_seq(&self, device_id: u64, boot_id: u32) -> Result<Option<u32>, StoreError>;

    /// Commits `reading` to `session` under `measurement` (`None`:
    /// `reading-N`, numbered within the session) in one durable transaction,
    /// applying the sequence rules (duplicate, gap). Only a
    /// [`CommitOutcome::Committed`] may be acknowledged.
    fn commit_tape_reading(
        &self,
        session: SessionId,
        measurement: Option<&str>,
        reading: &DeviceReading,
    ) -> Result<CommitOutcome, StoreError>;
}

/// Why the port could not be opened (the link keeps trying).
#[derive(Clone, Debug, thiserror::Error)]
#[error("cannot open {path}: {error}", path = .path.display())]
pub struct PortError {
    /// The port's path.
    pub path: PathBuf,
    /// The serial port library's error.
    pub error: Arc<tokio_serial::Error>,
}

/// Why a connection to the tape ended (the link reopens the port).
#[derive(Clone, Debug, thiserror::Error)]
pub enum Disconnect {
    /// Reading from the port failed.
    #[error("read error: {0}")]
    Read(Arc<std::io::Error>),
    /// Writing to the port failed.
    #[error("write error: {0}")]
    Write(Arc<std::io::Error>),
    /// The port reached end-of-file.
    #[error("the port reached end-of-file (device unplugged?)")]
    EndOfFile,
    /// The port's path is gone.
    #[error("{} disappeared", .0.display())]
    PathGone(PathBuf),
    /// The port's path now names another device.
    #[error("{} now points at another device", .0.display())]
    PathReplaced(PathBuf),
    /// Nothing came from the device for this long (pinged first).
    #[error("no data from the device for {:.1} s", .0.as_secs_f64())]
    Silent(Duration),
    /// A message could not be framed (a bug in the protocol crate: every
    /// host message fits a frame).
    #[error("cannot encode {message}: {error}")]
    Encode {
        /// The message, in words.
        message: String,
        /// The framing error.
        error: tapeshape_protocol::FrameError,
    },
}

/// Why committing a reading failed (it is not acknowledged; the device keeps it).
#[derive(Clone, Debug, thiserror::Error)]
pub enum CommitError {
    /// The store refused or failed.
    #[error(transparent)]
    Store(Arc<StoreError>),
    /// The blocking task that commits died (a bug).
    #[error("the store task failed: {0}")]
    Task(String),
}

/// Settings of the link. [`LinkConfig::default`] suits the real station.
#[derive(Clone, Debug)]
pub struct LinkConfig {
    /// Baud rate of the host link (8N1, no flow control). Pseudo-terminals
    /// ignore it.
    pub baud_rate: u32,
    /// How often to try reopening a port that is gone.
    pub reconnect_poll: Duration,
    /// After opening, how long to wait for a compatible device hello before
    /// sending the host hello again.
    pub hello_retry: Duration,
    /// Silence (no frame at all) after which the device is pinged; three
    /// times this and the connection is taken as dead and reopened.
    pub silence_timeout: Duration,
    /// Protocol version the host announces. Leave at [`PROTOCOL_VERSION`];
    /// tests change it to exercise the version check.
    pub protocol: ProtocolVersion,
    /// Host software version announced in the hello.
    pub software: SoftwareVersion,
    /// Capacity of the event channel. When the application does not keep
    /// up, the link waits (bytes queue in the kernel); nothing is dropped.
    pub event_capacity: usize,
}

impl Default for LinkConfig {
    fn default() -> Self {
        LinkConfig {
            baud_rate: 115_200,
            reconnect_poll: Duration::from_millis(200),
            hello_retry: Duration::from_secs(1),
            silence_timeout: Duration::from_secs(3),
            protocol: PROTOCOL_VERSION,
            software: host_software_version(),
            event_capacity: 256,
        }
    }
}

/// This crate's version as a protocol [`SoftwareVersion`] (components above
/// 255 saturate).
pub fn host_software_version() -> SoftwareVersion {
    let part = |s: &str| {
        s.parse::<u64>()
            .map_or(0, |v| u8::try_from(v).unwrap_or(u8::MAX))
    };
    SoftwareVersion {
        major: part(env!("CARGO_PKG_VERSION_MAJOR")),
        minor: part(env!("CARGO_PKG_VERSION_MINOR")),
        patch: part(env!("CARGO_PKG_VERSION_PATCH")),
    }
}

/// How the link names the readings it commits.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Naming {
    /// No name: readings are held (not stored, not acknowledged) until a
    /// name is set. The default.
    None,
    /// Every reading gets this name: the measurement the operator is taking
    /// now. A second reading under the same name is a retake (the first is
    /// kept, marked superseded).
    Current(String),
    /// Names used one per committed reading, in order; when the list is used
    /// up, readings are held. For scripted runs (tests, the demo).
    Script(VecDeque<String>),
    /// `reading-1`, `reading-2`, ...: the number is the session's reading
    /// count plus one. For runs where nobody says what is measured.
    Numbered,
}

/// The device spoke an incompatible protocol version.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct VersionMismatch {
    /// Protocol version in the device's hello.
    pub device: ProtocolVersion,
    /// Firmware version in the device's hello.
    pub firmware: SoftwareVersion,
    /// Protocol version this host speaks.
    pub host: ProtocolVersion,
}

impl fmt::Display for VersionMismatch {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "protocol version mismatch: the tape (firmware {}.{}.{}) speaks protocol {}.{}, \
             this station speaks protocol {}.{}; the major numbers must match: update the \
             tape's firmware or the station so they do",
            self.firmware.major,
            self.firmware.minor,
            self.firmware.patch,
            self.device.major,
            self.device.minor,
            self.host.major,
            self.host.minor
        )
    }
}

impl std::error::Error for VersionMismatch {}

/// Why a reading was not committed yet (it stays with the device, which
/// retransmits it).
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Unassigned {
    /// No session is set.
    NoSession,
    /// No measurement name (see [`Naming`]).
    NoName,
}

/// Counters of one link since it was spawned.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct LinkCounters {
    /// Frames decoded.
    pub frames_ok: u64,
    /// Frames dropped (COBS, CRC, too short, oversized, undecodable).
    pub frames_bad: u64,
    /// Readings committed.
    pub committed: u64,
    /// Duplicates re-acknowledged.
    pub duplicates: u64,
    /// Gaps seen.
    pub gaps: u64,
    /// Connections lost.
    pub disconnects: u64,
}

/// What the link reports to the application.
#[derive(Clone, Debug)]
pub enum LinkEvent {
    /// The port was opened; the handshake starts.
    PortOpened {
        /// The port's path.
        path: PathBuf,
    },
    /// A compatible device said hello (also after a device reboot, with a
    /// new `boot_id`).
    Connected(DeviceHello),
    /// The device speaks an incompatible protocol; its readings are ignored.
    VersionMismatch(VersionMismatch),
    /// Live tape value, for display only.
    Live(Live),
    /// A reading was committed to the store and acknowledged.
    ReadingCommitted {
        /// The stored reading.
        reading: StoredReading,
        /// Unit the tape displayed.
        unit_shown: UnitShown,
    },
    /// A retransmission of a reading already committed: not stored again,
    /// re-acknowledged.
    Duplicate {
        /// The duplicate's boot and sequence number.
        boot_id: u32,
        /// Its sequence number.
        seq: u32,
        /// What was acknowledged.
        last_committed_seq: u32,
    },
    /// A reading arrived before an earlier one: not stored, not
    /// acknowledged; the device resends the missing one.
    Gap {
        /// Boot id.
        boot_id: u32,
        /// Sequence number needed next.
        expected: u32,
        /// Sequence number received.
        got: u32,
    },
    /// A reading could not be assigned to a session and measurement; it is
    /// held by the device. Reported once per reading, not per
    /// retransmission.
    ReadingUnassigned {
        /// The reading as sent.
        reading: Reading,
        /// What is missing.
        why: Unassigned,
    },
    /// Committing a reading failed (for example the session was closed or
    /// the disk is full); it was not acknowledged and the device keeps it.
    /// Reported once per reading and error, not per retransmission.
    CommitFailed {
        /// The reading as sent.
        reading: Reading,
        /// Why.
        error: CommitError,
    },
    /// A device button was pressed.
    Button(ButtonKind),
    /// Periodic device status.
    Status(Status),
    /// A device fault or its recovery.
    Fault(Fault),
    /// Answer to a ping.
    Pong {
        /// Round-trip time.
        rtt: Duration,
    },
    /// A frame was dropped.
    BadFrame {
        /// Why.
        error: FrameError,
        /// Link counters after counting it.
        counters: LinkCounters,
    },
    /// The connection ended; the link will try to reopen the port.
    Disconnected {
        /// What happened.
        reason: Disconnect,
        /// Counters at that moment.
        counters: LinkCounters,
    },
    /// The port cannot be opened (yet); the link keeps trying every
    /// `reconnect_poll`. Reported once per distinct error.
    WaitingForPort {
        /// The open error.
        error: PortError,
    },
    /// The link stopped (after [`super::LinkHandle::shutdown`] or when every handle
    /// was dropped).
    Stopped,
}
