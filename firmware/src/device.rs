//! The device logic as a sans-IO state machine: tape bytes and host bytes in, messages out.
//!
//! Why sans-IO: every rule of the protocol (numbering, retransmission, acknowledgements,
//! queue-full, silence, rate limits) lives here as plain code driven by byte slices and a
//! millisecond clock value, so it is unit-tested on the host with a fake clock and no
//! executor. [`crate::run`] is the thin async loop that connects it to UARTs and a timer.
//!
//! Memory: about 1.5 KiB, all fixed-size (`heapless`); no allocation.

use heapless::Deque;
use tapeshape_protocol::{
    encode, ButtonKind, DeviceHello, DeviceMsg, Fault, FrameDecoder, HostMsg, Live, Reading,
    RejectCounts, RejectReason, SoftwareVersion, Status, UnitShown, MAX_FRAME, PROTOCOL_VERSION,
};

use crate::tape::{Kind, Line, LineAssembler, LineError};

/// How many unacknowledged confirmed readings the device holds.
pub const QUEUE_CAPACITY: usize = 32;

/// How many control messages (hello, pong, status, faults, buttons) wait to be sent at most.
const OUTBOX: usize = 16;

/// This library's version, the default firmware version in [`Config`].
pub const FIRMWARE_VERSION: SoftwareVersion = SoftwareVersion {
    major: parse_u8(env!("CARGO_PKG_VERSION_MAJOR")),
    minor: parse_u8(env!("CARGO_PKG_VERSION_MINOR")),
    patch: parse_u8(env!("CARGO_PKG_VERSION_PATCH")),
};

const fn parse_u8(s: &str) -> u8 {
    let b = s.as_bytes();
    let mut v: u8 = 0;
    let mut i = 0;
    while i < b.len() {
        v = v * 10 + (b[i] - b'0');
        i += 1;
    }
    v
}

/// Settings of a [`Device`]. All times in milliseconds.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Config {
    /// Stable identity of the device (e.g. the MCU's factory id).
    pub device_id: u64,
    /// Must differ on every boot (hardware RNG, uninitialised RAM, a counter in flash...):
    /// the host tells a reboot, whose sequence numbers restart at 0, by it.
    pub boot_id: u32,
    /// Firmware version announced in the hello.
    pub firmware: SoftwareVersion,
    /// Unacknowledged readings are all sent again, oldest first, this long after the last
    /// (re)transmission or acknowledgement progress. Default 300.
    pub retransmit_ms: u32,
    /// Live values are sent at most once per this interval, and only when they change; the
    /// latest value is always sent once the interval has passed. Default 100 (10 per second).
    pub live_interval_ms: u32,
    /// No valid line (value or heartbeat) from the tape for this long raises
    /// [`Fault::TapeSilent`]. Default 5000.
    pub tape_silent_ms: u32,
    /// A [`Status`] is sent this often; 0 sends one only on request. Default 1000.
    pub status_interval_ms: u32,
    /// Until a compatible host hello is seen, the device hello is repeated this often.
    /// Default 1000.
    pub hello_interval_ms: u32,
    /// A confirmed line repeating the previous confirmed value within this window of it is
    /// the same button press (tapes may repeat the `S` line), counted in
    /// `Status::confirm_repeats`, not a new reading. 0 disables. Default 300.
    pub confirm_repeat_ms: u32,
}

impl Config {
    /// Defaults (see each field) for a device id and boot id.
    pub const fn new(device_id: u64, boot_id: u32) -> Self {
        Self {
            device_id,
            boot_id,
            firmware: FIRMWARE_VERSION,
            retransmit_ms: 300,
            live_interval_ms: 100,
            tape_silent_ms: 5000,
            status_interval_ms: 1000,
            hello_interval_ms: 1000,
            confirm_repeat_ms: 300,
        }
    }
}

/// A control message waiting in the outbox; Status is built when it is sent, so it reports
/// the counters of that moment (and the outbox stays small).
#[derive(Debug, Clone, Copy)]
enum Report {
    Hello,
    Status,
    Pong(u32),
    Fault(Fault),
    Button(ButtonKind),
}

#[derive(Debug, Default, Clone, Copy)]
struct Counters {
    lines_ok: u32,
    heartbeats: u32,
    rejected: RejectCounts,
    readings_refused: u32,
    confirm_repeats: u32,
    host_frames_bad: u32,
    acks_ignored: u32,
    tape_io_errors: u32,
    host_io_errors: u32,
    reports_dropped: u32,
}

/// `t + ms`, saturating: a board clock near `u64::MAX` must not panic the firmware.
fn after(t: u64, ms: u32) -> u64 {
    t.saturating_add(u64::from(ms))
}

/// Whether a timer set for `t` has expired at `now`. A timer that saturated at `u64::MAX`
/// never expires, so a clock at the end of its range cannot make a timer fire on every poll.
fn due(now: u64, t: u64) -> bool {
    t != u64::MAX && now >= t
}

fn bump(c: &mut u32) {
    *c = c.saturating_add(1);
}

/// The device: feed it tape bytes, host bytes and button presses with the current time,
/// and [`Device::poll`] it for messages to send to the host.
///
/// ```
/// use tapeshape_firmware::{Config, Device};
/// use tapeshape_firmware::tape::{format_line, Kind};
/// use tapeshape_protocol::{encode, DeviceMsg, HostHello, HostMsg, UnitShown, MAX_FRAME,
///     PROTOCOL_VERSION, SoftwareVersion};
///
/// let mut dev = Device::new(Config::new(0x1234, 7), 0);
/// assert!(matches!(dev.poll(0), Some(DeviceMsg::Hello(_))));
///
/// // The host says hello; the device answers with its own.
/// let mut buf = [0u8; MAX_FRAME];
/// let hello = HostMsg::Hello(HostHello {
///     protocol: PROTOCOL_VERSION,
///     software: SoftwareVersion { major: 0, minor: 1, patch: 0 },
/// });
/// dev.feed_host(encode(&hello, &mut buf).unwrap(), 10);
/// assert!(matches!(dev.poll(10), Some(DeviceMsg::Hello(_))));
///
/// // The operator confirms 85.20 cm on the tape.
/// dev.feed_tape(&format_line(8520, Kind::Confirmed, UnitShown::Metric).unwrap(), 20);
/// match dev.poll(20) {
///     Some(DeviceMsg::Reading(r)) => {
///         assert_eq!((r.seq, r.value_tenth_mm, r.timestamp_ms), (0, 8520, 20));
///     }
///     other => panic!("{other:?}"),
/// }
/// ```
#[derive(Debug)]
pub struct Device {
    cfg: Config,
    assembler: LineAssembler,
    host_dec: FrameDecoder<HostMsg>,
    /// Unacknowledged readings, oldest first, sequence numbers contiguous.
    queue: Deque<Reading, QUEUE_CAPACITY>,
    /// Index in `queue` of the next reading to (re)send in the current round.
    send_from: usize,
    next_retransmit_ms: u64,
    next_seq: u32,
    host_seen: bool,
    outbox: Deque<Report, OUTBOX>,
    pending_live: Option<Live>,
    last_live: Option<(Live, u64)>,
    pending_reject: Option<RejectReason>,
    pending_host_bad: bool,
    last_valid_line_ms: u64,
    tape_silent: bool,
    queue_full: bool,
    last_confirm: Option<(u32, u64)>,
    next_status_ms: u64,
    next_hello_ms: u64,
    boot_ms: u64,
    now_ms: u64,
    n: Counters,
}

impl Device {
    /// A device booted at `now_ms` (device uptime clock). Its hello is the first message
    /// [`Device::poll`] returns.
    pub fn new(config: Config, now_ms: u64) -> Self {
        let mut d = Self {
            cfg: config,
            assembler: LineAssembler::new(),
            host_dec: FrameDecoder::new(),
            queue: Deque::new(),
            send_from: 0,
            next_retransmit_ms: now_ms,
            next_seq: 0,
            host_seen: false,
            outbox: Deque::new(),
            pending_live: None,
            last_live: None,
            pending_reject: None,
            pending_host_bad: false,
            last_valid_line_ms: now_ms,
            tape_silent: false,
            queue_full: false,
            last_confirm: None,
            next_status_ms: after(now_ms, config.status_interval_ms),
            next_hello_ms: after(now_ms, config.hello_interval_ms),
            boot_ms: now_ms,
            now_ms,
            n: Counters::default(),
        };
        d.report(Report::Hello);
        d
    }

    /// The configuration.
    pub fn config(&self) -> &Config {
        &self.cfg
    }

    /// Unacknowledged readings held.
    pub fn queue_len(&self) -> usize {
        self.queue.len()
    }

    /// Whether the reading queue is full (new confirmed readings are being refused). A board
    /// may light an LED with it.
    pub fn queue_full(&self) -> bool {
        self.queue.is_full()
    }

    /// Whether a compatible host hello has been seen (readings are sent only then).
    pub fn host_seen(&self) -> bool {
        self.host_seen
    }

    /// Whether the tape is currently considered silent.
    pub fn tape_silent(&self) -> bool {
        self.tape_silent
    }

    /// The unacknowledged readings, oldest first.
    pub fn unacked(&self) -> impl Iterator<Item = &Reading> {
        self.queue.iter()
    }

    /// A status snapshot at `now_ms`.
    pub fn status(&self, now_ms: u64) -> Status {
        let n = &self.n;
        Status {
            boot_id: self.cfg.boot_id,
            uptime_ms: now_ms.saturating_sub(self.boot_ms),
            queue_len: self.queue.len() as u16,
            queue_capacity: QUEUE_CAPACITY as u16,
            next_seq: self.next_seq,
            host_seen: self.host_seen,
            tape_silent: self.tape_silent,
            lines_ok: n.lines_ok,
            heartbeats: n.heartbeats,
            rejected: n.rejected,
            readings_refused: n.readings_refused,
            confirm_repeats: n.confirm_repeats,
            host_frames_bad: n.host_frames_bad,
            acks_ignored: n.acks_ignored,
            tape_io_errors: n.tape_io_errors,
            host_io_errors: n.host_io_errors,
            reports_dropped: n.reports_dropped,
        }
    }

    fn report(&mut self, r: Report) {
        if self.outbox.push_back(r).is_err() {
            bump(&mut self.n.reports_dropped);
        }
    }

    fn tick(&mut self, now_ms: u64) {
        // The clock never runs backwards for us, even if a caller's does.
        self.now_ms = self.now_ms.max(now_ms);
    }

    /// Feeds bytes received from the tape's UART at `now_ms`.
    pub fn feed_tape(&mut self, bytes: &[u8], now_ms: u64) {
        self.tick(now_ms);
        for &b in bytes {
            if let Some(outcome) = self.assembler.push(b) {
                self.on_line(outcome);
            }
        }
    }

    /// Feeds bytes received from the host link at `now_ms`.
    pub fn feed_host(&mut self, bytes: &[u8], now_ms: u64) {
        self.tick(now_ms);
        for &b in bytes {
            match self.host_dec.push(b) {
                None => {}
                Some(Ok(msg)) => self.on_host(msg),
                Some(Err(_)) => {
                    bump(&mut self.n.host_frames_bad);
                    self.pending_host_bad = true;
                }
            }
        }
    }

    /// A device button was pressed at `now_ms`.
    pub fn press_button(&mut self, kind: ButtonKind, now_ms: u64) {
        self.tick(now_ms);
        self.report(Report::Button(kind));
    }

    /// The board's tape UART reported a read error (framing, overrun, ...).
    pub fn tape_io_error(&mut self) {
        bump(&mut self.n.tape_io_errors);
    }

    /// The board's host link reported a read or write error.
    pub fn host_io_error(&mut self) {
        bump(&mut self.n.host_io_errors);
    }

    fn on_line(&mut self, outcome: Result<Line, LineError>) {
        let now = self.now_ms;
        let line = match outcome {
            Ok(line) => line,
            Err(e) => {
                let c = &mut self.n.rejected;
                bump(match e {
                    LineError::Garbage => &mut c.garbage,
                    LineError::Partial { .. } => &mut c.partial,
                    LineError::Overlong => &mut c.overlong,
                    LineError::BadField { .. } => &mut c.bad_field,
                    LineError::Impossible { .. } => &mut c.impossible,
                });
                self.pending_reject = Some(e.reason());
                return;
            }
        };
        bump(&mut self.n.lines_ok);
        self.last_valid_line_ms = now;
        if self.tape_silent {
            self.tape_silent = false;
            self.report(Report::Fault(Fault::TapeRecovered));
        }
        let l = match line {
            Line::Heartbeat => {
                bump(&mut self.n.heartbeats);
                return;
            }
            Line::Value(l) => l,
        };
        let value = l.value_hundredths_cm; // hundredths of a cm == tenths of a mm
        match l.kind {
            Kind::Live => {
                let live = Live {
                    value_tenth_mm: value,
                    unit_shown: l.unit_shown,
                };
                // Only changes are sent; a value back to the last one sent cancels a pending one.
                self.pending_live = match self.last_live {
                    Some((last, _)) if last == live => None,
                    _ => Some(live),
                };
            }
            Kind::Confirmed => {
                if let Some((v, t)) = self.last_confirm {
                    if v == value && now.saturating_sub(t) < u64::from(self.cfg.confirm_repeat_ms) {
                        bump(&mut self.n.confirm_repeats);
                        self.last_confirm = Some((v, now));
                        return;
                    }
                }
                self.last_confirm = Some((value, now));
                self.accept_reading(value, l.unit_shown);
            }
        }
    }

    fn accept_reading(&mut self, value_tenth_mm: u32, unit_shown: UnitShown) {
        if self.queue.is_full() {
            bump(&mut self.n.readings_refused);
            self.queue_full = true;
            self.report(Report::Fault(Fault::QueueFull {
                capacity: QUEUE_CAPACITY as u16,
                refused_value_tenth_mm: value_tenth_mm,
                refused_total: self.n.readings_refused,
            }));
            return;
        }
        let reading = Reading {
            boot_id: self.cfg.boot_id,
            seq: self.next_seq,
            value_tenth_mm,
            timestamp_ms: self.now_ms.saturating_sub(self.boot_ms),
            unit_shown,
        };
        // Cannot fail: checked `is_full` above.
        let _ = self.queue.push_back(reading);
        // 2^32 readings would take a century at one per second; wrapping keeps it total.
        self.next_seq = self.next_seq.wrapping_add(1);
    }

    fn on_host(&mut self, msg: HostMsg) {
        let now = self.now_ms;
        match msg {
            HostMsg::Hello(h) => {
                self.report(Report::Hello);
                if PROTOCOL_VERSION.is_compatible(&h.protocol) {
                    self.host_seen = true;
                    // A host that just said hello may have missed everything: send all
                    // unacknowledged readings again now, oldest first.
                    self.send_from = 0;
                } else {
                    self.host_seen = false;
                    self.report(Report::Fault(Fault::VersionMismatch {
                        host: h.protocol,
                        device: PROTOCOL_VERSION,
                    }));
                }
            }
            HostMsg::Ack { boot_id, seq } => {
                let sent_any = self.next_seq != 0;
                let ack_in_range = sent_any && seq < self.next_seq;
                if boot_id != self.cfg.boot_id || !ack_in_range {
                    bump(&mut self.n.acks_ignored);
                    return;
                }
                let mut popped = 0;
                while self.queue.front().is_some_and(|r| r.seq <= seq) {
                    self.queue.pop_front();
                    popped += 1;
                }
                if popped > 0 {
                    self.send_from = self.send_from.saturating_sub(popped);
                    self.next_retransmit_ms = after(now, self.cfg.retransmit_ms);
                    if self.queue_full {
                        self.queue_full = false;
                        self.report(Report::Fault(Fault::QueueRecovered {
                            queue_len: self.queue.len() as u16,
                        }));
                    }
                }
            }
            HostMsg::Ping { nonce } => self.report(Report::Pong(nonce)),
            HostMsg::GetStatus => self.report(Report::Status),
        }
    }

    fn run_timers(&mut self) {
        let now = self.now_ms;
        let silent_for = now.saturating_sub(self.last_valid_line_ms);
        if !self.tape_silent && silent_for >= u64::from(self.cfg.tape_silent_ms) {
            self.tape_silent = true;
            self.report(Report::Fault(Fault::TapeSilent {
                silent_ms: silent_for.min(u64::from(u32::MAX)) as u32,
            }));
        }
        if !self.host_seen && due(now, self.next_hello_ms) {
            self.next_hello_ms = after(now, self.cfg.hello_interval_ms.max(1));
            self.report(Report::Hello);
        }
        if self.cfg.status_interval_ms > 0 && due(now, self.next_status_ms) {
            self.next_status_ms = after(now, self.cfg.status_interval_ms);
            self.report(Report::Status);
        }
        if self.host_seen
            && !self.queue.is_empty()
            && self.send_from >= self.queue.len()
            && due(now, self.next_retransmit_ms)
        {
            self.send_from = 0;
        }
    }

    /// Runs the timers at `now_ms` and returns the next message to send, if any. Call it
    /// until it returns `None` after every feed, and again at [`Device::next_deadline`].
    ///
    /// Order: control messages (hello, pong, status, faults, buttons) first, then coalesced
    /// host-frame and tape-line rejections, then readings oldest first, then the live value.
    pub fn poll(&mut self, now_ms: u64) -> Option<DeviceMsg> {
        self.tick(now_ms);
        self.run_timers();
        let now = self.now_ms;
        if let Some(r) = self.outbox.pop_front() {
            return Some(match r {
                Report::Hello => DeviceMsg::Hello(DeviceHello {
                    protocol: PROTOCOL_VERSION,
                    firmware: self.cfg.firmware,
                    device_id: self.cfg.device_id,
                    boot_id: self.cfg.boot_id,
                    queue_capacity: QUEUE_CAPACITY as u16,
                }),
                Report::Status => DeviceMsg::Status(self.status(now)),
                Report::Pong(nonce) => DeviceMsg::Pong { nonce },
                Report::Fault(f) => DeviceMsg::Fault(f),
                Report::Button(kind) => DeviceMsg::Button { kind },
            });
        }
        if core::mem::take(&mut self.pending_host_bad) {
            return Some(DeviceMsg::Fault(Fault::HostFrameBad {
                total: self.n.host_frames_bad,
            }));
        }
        if let Some(reason) = self.pending_reject.take() {
            return Some(DeviceMsg::Fault(Fault::LineRejected {
                reason,
                rejected_total: self.n.rejected.total(),
            }));
        }
        if self.host_seen {
            if let Some(r) = self.queue.iter().nth(self.send_from).copied() {
                // The retransmission timer runs from the last time the OLDEST
                // unacknowledged reading was sent (or from the last ack that made
                // progress). Restarting it for every newly confirmed reading would
                // postpone the resend of a lost one for as long as the tape keeps
                // confirming faster than `retransmit_ms`.
                if self.send_from == 0 {
                    self.next_retransmit_ms = after(now, self.cfg.retransmit_ms);
                }
                self.send_from += 1;
                return Some(DeviceMsg::Reading(r));
            }
        }
        if let Some(live) = self.pending_live {
            let due = match self.last_live {
                None => true,
                Some((_, t)) => due(now, after(t, self.cfg.live_interval_ms)),
            };
            if due {
                self.pending_live = None;
                self.last_live = Some((live, now));
                return Some(DeviceMsg::Live(live));
            }
        }
        None
    }

    /// [`Device::poll`], encoded as a frame ready to write (trailing `0x00` included) into
    /// `buf`.
    pub fn poll_frame<'b>(
        &mut self,
        now_ms: u64,
        buf: &'b mut [u8; MAX_FRAME],
    ) -> Option<&'b [u8]> {
        loop {
            let msg = self.poll(now_ms)?;
            // Every message fits a frame (tested in tapeshape-protocol); should one ever not,
            // it is counted rather than lost without trace.
            match encode(&msg, &mut buf[..]) {
                Ok(frame) => {
                    let n = frame.len();
                    return Some(&buf[..n]);
                }
                Err(_) => bump(&mut self.n.reports_dropped),
            }
        }
    }

    /// The latest time (device clock, ms) at which [`Device::poll`] must be called again even
    /// if no byte arrives: the earliest pending timer. Returns a time `<= now` when something
    /// is ready now.
    pub fn next_deadline(&self) -> u64 {
        let now = self.now_ms;
        if !self.outbox.is_empty() || self.pending_host_bad || self.pending_reject.is_some() {
            return now;
        }
        let mut t = u64::MAX;
        if self.host_seen && !self.queue.is_empty() {
            t = t.min(if self.send_from < self.queue.len() {
                now
            } else {
                self.next_retransmit_ms
            });
        }
        if self.pending_live.is_some() {
            t = t.min(match self.last_live {
                None => now,
                Some((_, last)) => after(last, self.cfg.live_interval_ms),
            });
        }
        if !self.tape_silent {
            t = t.min(after(self.last_valid_line_ms, self.cfg.tape_silent_ms));
        }
        if !self.host_seen {
            t = t.min(self.next_hello_ms);
        }
        if self.cfg.status_interval_ms > 0 {
            t = t.min(self.next_status_ms);
        }
        t
    }
}
