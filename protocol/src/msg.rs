//! The message types in both directions and the protocol version.
//!
//! Units: every length is an integer in tenths of a millimetre (`*_tenth_mm`), every time an
//! integer in milliseconds of device uptime (`*_ms`). Nothing here is a float, so both ends
//! agree exactly on every value.
//!
//! Compatibility: postcard encodes enum variants by their index and struct fields in order.
//! Appending a new variant at the END of an enum is a minor version bump (an older peer fails
//! to decode it, counts a bad frame and carries on); anything else (reordering, removing,
//! adding a field) is a major bump. See `docs/wire-format.md`.

use serde::{Deserialize, Serialize};

/// Version of this wire protocol. Peers talk only when the `major` numbers are equal.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub struct ProtocolVersion {
    /// Changed on any change that an older peer cannot decode correctly.
    pub major: u8,
    /// Changed when messages are appended that an older peer may ignore.
    pub minor: u8,
}

impl ProtocolVersion {
    /// Whether a peer speaking `other` can talk with one speaking `self` (same major).
    pub const fn is_compatible(&self, other: &ProtocolVersion) -> bool {
        self.major == other.major
    }
}

/// The protocol version implemented by this crate.
pub const PROTOCOL_VERSION: ProtocolVersion = ProtocolVersion { major: 1, minor: 0 };

/// A software version (semantic versioning).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub struct SoftwareVersion {
    /// Major version.
    pub major: u8,
    /// Minor version.
    pub minor: u8,
    /// Patch version.
    pub patch: u8,
}

/// The unit the tape's own display shows. Informational only: the value on the wire is
/// always in tenths of a millimetre whatever the display shows.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum UnitShown {
    /// Display in centimetres (`M` on the tape's line).
    Metric,
    /// Display in inches (`I` on the tape's line).
    Imperial,
}

/// Why the firmware refused a line from the tape. None of these is ever forwarded as a
/// reading.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum RejectReason {
    /// Not a tape line: wrong start character, wrong separators, control or non-ASCII bytes.
    Garbage,
    /// The line ended (newline, or a new `*` start) before its 19 characters: `len` is how
    /// many characters it had (capped at 255).
    Partial {
        /// Characters received before the line ended.
        len: u8,
    },
    /// More than 19 characters before the newline.
    Overlong,
    /// A field that must be digits was not, or a flag letter was unknown. `field` is the
    /// 1-based field: 1..=3 the numeric fields, 4 the live/confirmed flag, 5 the unit flag.
    BadField {
        /// 1-based field index (see above).
        field: u8,
    },
    /// The length field held a minus sign: a tape cannot measure a negative length.
    Negative,
    /// The length is beyond what the tape can measure (see `MAX_TAPE_TENTH_MM` in the
    /// firmware), or a confirmed reading of zero.
    OutOfRange {
        /// The offending value, tenths of a millimetre (= hundredths of a centimetre).
        value_tenth_mm: u32,
    },
}

/// A button on the device (not the tape's own confirm button, whose presses arrive as
/// [`Reading`]s).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum ButtonKind {
    /// Go on to the next measurement.
    Next,
    /// Go back to the previous measurement.
    Back,
    /// Discard the current measurement and take it again.
    Redo,
}

/// Device hello: sent at boot, every `hello_interval` until a compatible host hello is seen,
/// and in answer to every host hello.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub struct DeviceHello {
    /// Protocol version the device speaks.
    pub protocol: ProtocolVersion,
    /// Firmware version.
    pub firmware: SoftwareVersion,
    /// Stable identity of the device (e.g. the MCU's factory id).
    pub device_id: u64,
    /// Differs on every boot; sequence numbers restart at 0 with a new boot id.
    pub boot_id: u32,
    /// How many unacknowledged readings the device can hold.
    pub queue_capacity: u16,
}

/// A live tape value: what the tape shows now. Best effort (not numbered, not acknowledged,
/// rate limited); for display only, never stored as a measurement.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub struct Live {
    /// Length, tenths of a millimetre.
    pub value_tenth_mm: u32,
    /// Unit on the tape's display.
    pub unit_shown: UnitShown,
}

/// A reading the operator confirmed with the tape's button. Numbered per boot, retransmitted
/// until acknowledged with [`HostMsg::Ack`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub struct Reading {
    /// Boot this reading belongs to (same as the device hello's `boot_id`).
    pub boot_id: u32,
    /// Sequence number: 0, 1, 2, ... per boot, without gaps.
    pub seq: u32,
    /// Length, tenths of a millimetre (the tape's hundredths of a centimetre, unchanged).
    pub value_tenth_mm: u32,
    /// Device uptime when the tape's line arrived, milliseconds.
    pub timestamp_ms: u64,
    /// Unit on the tape's display.
    pub unit_shown: UnitShown,
}

/// Counters of rejected tape lines, by reason.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub struct RejectCounts {
    /// [`RejectReason::Garbage`].
    pub garbage: u32,
    /// [`RejectReason::Partial`].
    pub partial: u32,
    /// [`RejectReason::Overlong`].
    pub overlong: u32,
    /// [`RejectReason::BadField`].
    pub bad_field: u32,
    /// [`RejectReason::Negative`] and [`RejectReason::OutOfRange`].
    pub impossible: u32,
}

impl RejectCounts {
    /// Sum of all counters (saturating).
    pub fn total(&self) -> u32 {
        self.garbage
            .saturating_add(self.partial)
            .saturating_add(self.overlong)
            .saturating_add(self.bad_field)
            .saturating_add(self.impossible)
    }
}

/// Periodic device status. All counters count since boot and saturate.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub struct Status {
    /// Boot id (as in the hello).
    pub boot_id: u32,
    /// Device uptime, milliseconds.
    pub uptime_ms: u64,
    /// Unacknowledged readings held.
    pub queue_len: u16,
    /// Capacity of the reading queue.
    pub queue_capacity: u16,
    /// Sequence number the next reading will get.
    pub next_seq: u32,
    /// Whether a compatible host hello has been seen (readings are sent only then).
    pub host_seen: bool,
    /// Whether the tape has been silent longer than the configured limit.
    pub tape_silent: bool,
    /// Valid tape lines (live, confirmed and heartbeat).
    pub lines_ok: u32,
    /// Heartbeat lines among `lines_ok`.
    pub heartbeats: u32,
    /// Rejected tape lines by reason.
    pub rejected: RejectCounts,
    /// Confirmed readings refused because the queue was full (each one was reported with
    /// [`Fault::QueueFull`]). Zero in a healthy station.
    pub readings_refused: u32,
    /// Confirmed lines that repeated the previous confirmed value within the repeat window
    /// and were taken as the same confirmation.
    pub confirm_repeats: u32,
    /// Frames from the host that failed COBS, CRC or decoding.
    pub host_frames_bad: u32,
    /// Acknowledgements ignored: wrong boot id, or a sequence number never sent.
    pub acks_ignored: u32,
    /// Read errors on the tape UART (framing, overrun, ...) reported by the board.
    pub tape_io_errors: u32,
    /// Write or read errors on the host link reported by the board.
    pub host_io_errors: u32,
    /// Status or fault messages that could not be queued for sending (the counters above
    /// still hold what they reported).
    pub reports_dropped: u32,
}

/// Something the operator or the station's engineer must know about.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum Fault {
    /// The reading queue is full (the host has not acknowledged): this confirmed value was
    /// NOT recorded and was not numbered. The host must tell the operator to take it again.
    QueueFull {
        /// Queue capacity.
        capacity: u16,
        /// The confirmed value that was refused, tenths of a millimetre.
        refused_value_tenth_mm: u32,
        /// Readings refused since boot, this one included.
        refused_total: u32,
    },
    /// The queue has room again after a [`Fault::QueueFull`].
    QueueRecovered {
        /// Readings in the queue now.
        queue_len: u16,
    },
    /// No valid line (value or heartbeat) from the tape for `silent_ms`.
    TapeSilent {
        /// Milliseconds since the last valid line (or since boot).
        silent_ms: u32,
    },
    /// Valid lines arrive again after a [`Fault::TapeSilent`].
    TapeRecovered,
    /// A tape line was rejected. Bursts are coalesced: `rejected_total` counts every
    /// rejection since boot, so a jump of more than one says several were coalesced.
    LineRejected {
        /// Why the latest line was rejected.
        reason: RejectReason,
        /// Rejected lines since boot.
        rejected_total: u32,
    },
    /// The host's hello named an incompatible protocol version; the device does not send
    /// readings until a compatible hello arrives.
    VersionMismatch {
        /// The version the host announced.
        host: ProtocolVersion,
        /// The version this device speaks.
        device: ProtocolVersion,
    },
    /// A frame from the host failed COBS, CRC or decoding and was dropped.
    HostFrameBad {
        /// Bad host frames since boot.
        total: u32,
    },
}

/// Messages from the device (firmware) to the host.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum DeviceMsg {
    /// Handshake; see [`DeviceHello`].
    Hello(DeviceHello),
    /// Live tape value (best effort).
    Live(Live),
    /// A confirmed reading (numbered, retransmitted until acknowledged).
    Reading(Reading),
    /// A device button was pressed (best effort).
    Button {
        /// Which button.
        kind: ButtonKind,
    },
    /// Periodic status.
    Status(Status),
    /// A fault or its recovery.
    Fault(Fault),
    /// Answer to [`HostMsg::Ping`] with the same nonce.
    Pong {
        /// The ping's nonce.
        nonce: u32,
    },
}

/// Host hello: sent when the host opens the link, and in answer to every device hello whose
/// `boot_id` it has not greeted yet.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub struct HostHello {
    /// Protocol version the host speaks.
    pub protocol: ProtocolVersion,
    /// Host software version.
    pub software: SoftwareVersion,
}

/// Messages from the host to the device.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum HostMsg {
    /// Handshake; see [`HostHello`].
    Hello(HostHello),
    /// Cumulative acknowledgement: every reading of `boot_id` with a sequence number up to and
    /// including `seq` is committed on the host and may be forgotten by the device.
    Ack {
        /// Boot the acknowledged readings belong to.
        boot_id: u32,
        /// Highest acknowledged sequence number.
        seq: u32,
    },
    /// Liveness check; the device answers [`DeviceMsg::Pong`] with the same nonce.
    Ping {
        /// Any value; echoed back.
        nonce: u32,
    },
    /// Ask for a [`DeviceMsg::Status`] now.
    GetStatus,
}
