//! The serial link to the tape firmware.
//!
//! Why a task with channels: the station's front ends (the kiosk interface,
//! the line-mode printer of `tapeshape station`, tests) must keep drawing while the link
//! waits for bytes, writes acknowledgements, commits readings and reopens a
//! port that was pulled out. [`Link::spawn`] starts one tokio task that owns
//! the port; the application talks to it through a [`LinkHandle`] (commands)
//! and receives [`LinkEvent`]s on a channel. The link knows nothing of how
//! events are shown.
//!
//! Rules (see `docs/wire-format.md` for the wire side):
//!
//! * **Handshake.** On opening the port the link sends a host hello; it
//!   answers every device hello whose `boot_id` it has not greeted on this
//!   connection. A device hello with an incompatible protocol version (a
//!   different major) yields [`LinkEvent::VersionMismatch`], whose message
//!   names both versions; readings from that device are ignored (never
//!   acknowledged) until a compatible hello arrives.
//! * **Commit before acknowledge.** A reading is committed through the
//!   [`ReadingSink`] (the session layer, [`crate::session::Sessions`]) on a
//!   blocking thread; only after the commit returned does the
//!   link write the cumulative `Ack`. A crash between the two costs nothing:
//!   the device retransmits, the store recognises the duplicate and the link
//!   acknowledges it again.
//! * **Duplicates** (`seq` at or below the last committed one for the device
//!   boot) are not stored; the link re-acknowledges the last committed
//!   sequence number. **Gaps** (a reading after a missing one) are neither
//!   stored nor acknowledged: the device sends the missing one first.
//! * **Where a reading's measurement name comes from.** The device only
//!   measures lengths; the host application decides what was measured. The
//!   link holds a target session ([`LinkHandle::set_session`]) and a
//!   [`Naming`] ([`LinkHandle::set_naming`]): the name of the measurement the
//!   operator is taking now, a scripted list (tests and the demo), or
//!   automatic `reading-N` names. A reading that arrives while there is no
//!   open session or no name is **held**: not stored, not acknowledged
//!   ([`LinkEvent::ReadingUnassigned`]); the device keeps retransmitting it
//!   and it is committed as soon as a target is set.
//! * **Reconnect.** A read error, end-of-file, a failed write, or the port's
//!   path vanishing or pointing at another device ends the connection
//!   ([`LinkEvent::Disconnected`]); the link then tries to reopen the path
//!   every [`LinkConfig::reconnect_poll`] and handshakes again. Readings the
//!   device still holds are retransmitted and land in the same session.
//!   A device that stays silent for [`LinkConfig::silence_timeout`] is
//!   pinged; one silent for three times that is treated as disconnected.
//! * **Bad frames** (COBS, CRC, undecodable) are counted and dropped
//!   ([`LinkEvent::BadFrame`]); the decoder resynchronises at the next
//!   delimiter.
//!
//! Which port: the caller's. [`probe`] finds it when the operator gave
//! none (the serial ports that look like a tape station, each sent one
//! hello with the same opening and framing as here, nothing acknowledged).

use std::collections::HashSet;
use std::path::{Path, PathBuf};
use std::sync::Arc;

use tapeshape_protocol::{
    encode, DeviceHello, DeviceMsg, FrameDecoder, FrameError, HostHello, HostMsg, Reading,
    MAX_FRAME,
};
use tokio::io::{AsyncReadExt, AsyncWriteExt};
use tokio::sync::mpsc;
use tokio::task::JoinHandle;
use tokio::time::Instant;
use tokio_serial::{DataBits, FlowControl, Parity, SerialStream, StopBits};

use crate::store::{CommitOutcome, DeviceReading, SessionId, StoreError};

mod events;
pub mod probe;

pub use events::{
    host_software_version, CommitError, Disconnect, LinkConfig, LinkCounters, LinkEvent, Naming,
    PortError, ReadingSink, Unassigned, VersionMismatch,
};

/// Commands to a running link (sent through [`LinkHandle`]).
#[derive(Clone, Debug)]
enum Command {
    SetSession(Option<SessionId>),
    SetNaming(Naming),
    Ping,
    GetStatus,
    Shutdown,
}

/// Handle to a running link. Dropping every clone stops the link.
#[derive(Clone, Debug)]
pub struct LinkHandle {
    cmd: mpsc::UnboundedSender<Command>,
}

impl LinkHandle {
    fn send(&self, c: Command) {
        // An error means the link task has ended (it reported `Stopped`).
        let _ = self.cmd.send(c);
    }

    /// Sets the session that incoming readings are committed to (`None`:
    /// hold them).
    pub fn set_session(&self, session: Option<SessionId>) {
        self.send(Command::SetSession(session));
    }

    /// Sets how incoming readings are named (see [`Naming`]).
    pub fn set_naming(&self, naming: Naming) {
        self.send(Command::SetNaming(naming));
    }

    /// Pings the device; the answer arrives as [`LinkEvent::Pong`].
    pub fn ping(&self) {
        self.send(Command::Ping);
    }

    /// Asks the device for a [`LinkEvent::Status`] now.
    pub fn request_status(&self) {
        self.send(Command::GetStatus);
    }

    /// Asks the link to stop; it closes the port and sends
    /// [`LinkEvent::Stopped`]. Readings not yet acknowledged stay with the
    /// device.
    pub fn shutdown(&self) {
        self.send(Command::Shutdown);
    }
}

/// The serial link (see the module docs).
#[derive(Debug)]
pub struct Link;

impl Link {
    /// Starts the link on `port` (a device path such as `/dev/ttyACM0`, or a
    /// pseudo-terminal's path) committing readings through `sink` (the
    /// session layer). Returns the
    /// command handle, the event receiver and the task (which ends after
    /// [`LinkEvent::Stopped`]). Must be called inside a tokio runtime with
    /// time and I/O enabled.
    ///
    /// The port need not exist yet: the link waits for it.
    pub fn spawn(
        port: impl Into<PathBuf>,
        config: LinkConfig,
        sink: impl ReadingSink,
    ) -> (LinkHandle, mpsc::Receiver<LinkEvent>, JoinHandle<()>) {
        let (cmd_tx, cmd_rx) = mpsc::unbounded_channel();
        let (ev_tx, ev_rx) = mpsc::channel(config.event_capacity.max(1));
        let task = LinkTask {
            path: port.into(),
            config,
            sink: Arc::new(sink),
            cmds: cmd_rx,
            events: ev_tx,
            session: None,
            naming: Naming::None,
            counters: LinkCounters::default(),
            reported_unassigned: HashSet::new(),
            reported_failures: HashSet::new(),
        };
        let join = tokio::spawn(task.run());
        (LinkHandle { cmd: cmd_tx }, ev_rx, join)
    }
}

/// Opens a serial port (8N1, no flow control) as the link does; the
/// prober ([`probe`]) opens candidates the same way.
///
/// serialport opens exclusively (TIOCEXCL + flock) by default, so a second
/// station on the same port fails here instead of stealing half the frames.
fn open_port(path: &Path, baud_rate: u32) -> Result<SerialStream, PortError> {
    let name = path.to_string_lossy();
    let builder = tokio_serial::new(name.as_ref(), baud_rate)
        .data_bits(DataBits::Eight)
        .parity(Parity::None)
        .stop_bits(StopBits::One)
        .flow_control(FlowControl::None);
    SerialStream::open(&builder).map_err(|e| PortError {
        path: path.to_path_buf(),
        error: Arc::new(e),
    })
}

/// Frames `msg` (COBS + CRC, `tapeshape_protocol::encode`) and writes it.
async fn write_msg(port: &mut SerialStream, msg: &HostMsg) -> Result<(), Disconnect> {
    let mut out = [0u8; MAX_FRAME];
    // Every HostMsg fits a frame (checked by the protocol crate's
    // largest-message test); an error here would be a protocol bug.
    let frame = encode(msg, &mut out).map_err(|error| Disconnect::Encode {
        message: format!("{msg:?}"),
        error,
    })?;
    port.write_all(frame)
        .await
        .map_err(|e| Disconnect::Write(Arc::new(e)))
}

/// Why a connection ended.
enum End {
    Shutdown,
    Lost(Disconnect),
}

struct LinkTask {
    path: PathBuf,
    config: LinkConfig,
    sink: Arc<dyn ReadingSink>,
    cmds: mpsc::UnboundedReceiver<Command>,
    events: mpsc::Sender<LinkEvent>,
    session: Option<SessionId>,
    naming: Naming,
    counters: LinkCounters,
    /// (boot, seq) of readings reported unassigned, so that retransmissions
    /// are not reported again; cleared when the target changes.
    reported_unassigned: HashSet<(u32, u32)>,
    /// (boot, seq, error) of failed commits already reported.
    reported_failures: HashSet<(u32, u32, String)>,
}

/// Per-connection state.
struct Conn {
    port: SerialStream,
    /// Identity of the path's target when opened, to notice it vanishing or
    /// being replaced by another device.
    identity: Option<(u64, u64)>,
    decoder: FrameDecoder<DeviceMsg>,
    /// Boot ids greeted with a host hello on this connection.
    greeted: HashSet<u32>,
    /// The compatible device on the other end, once it said hello.
    device: Option<DeviceHello>,
    last_rx: Instant,
    last_hello_tx: Instant,
    pinged_for_silence: bool,
    ping_nonce: u32,
    pings: Vec<(u32, Instant)>,
}

fn path_identity(path: &Path) -> Option<(u64, u64)> {
    use std::os::unix::fs::MetadataExt;
    std::fs::metadata(path).ok().map(|m| (m.dev(), m.rdev()))
}

impl LinkTask {
    async fn emit(&self, ev: LinkEvent) {
        // If the application dropped its receiver it no longer wants events;
        // the link keeps committing and acknowledging regardless.
        let _ = self.events.send(ev).await;
    }

    /// Applies a command; returns false on shutdown.
    fn apply(&mut self, cmd: Option<Command>) -> bool {
        match cmd {
            None | Some(Command::Shutdown) => return false,
            Some(Command::SetSession(s)) => {
                self.session = s;
                self.reported_unassigned.clear();
                self.reported_failures.clear();
            }
            Some(Command::SetNaming(n)) => {
                self.naming = n;
                self.reported_unassigned.clear();
            }
            // Only meaningful while connected; handled there.
            Some(Command::Ping) | Some(Command::GetStatus) => {}
        }
        true
    }

    async fn run(mut self) {
        let mut last_open_error: Option<String> = None;
        loop {
            match self.open() {
                Ok(port) => {
                    last_open_error = None;
                    self.emit(LinkEvent::PortOpened {
                        path: self.path.clone(),
                    })
                    .await;
                    let end = self.connection(port).await;
                    match end {
                        End::Shutdown => break,
                        End::Lost(reason) => {
                            self.counters.disconnects += 1;
                            tracing::warn!(path = %self.path.display(), %reason, "link lost");
                            self.emit(LinkEvent::Disconnected {
                                reason,
                                counters: self.counters,
                            })
                            .await;
                        }
                    }
                }
                Err(error) => {
                    let text = error.to_string();
                    if last_open_error.as_deref() != Some(text.as_str()) {
                        tracing::info!(path = %self.path.display(), %error, "waiting for port");
                        self.emit(LinkEvent::WaitingForPort { error }).await;
                        last_open_error = Some(text);
                    }
                }
            }
            // Wait before (re)opening, still obeying commands.
            let deadline = Instant::now() + self.config.reconnect_poll;
            loop {
                tokio::select! {
                    cmd = self.cmds.recv() => {
                        if !self.apply(cmd) {
                            self.emit(LinkEvent::Stopped).await;
                            return;
                        }
                    }
                    _ = tokio::time::sleep_until(deadline) => break,
                }
            }
        }
        self.emit(LinkEvent::Stopped).await;
    }

    fn open(&self) -> Result<SerialStream, PortError> {
        open_port(&self.path, self.config.baud_rate)
    }

    async fn connection(&mut self, port: SerialStream) -> End {
        let now = Instant::now();
        let mut conn = Conn {
            port,
            identity: path_identity(&self.path),
            decoder: FrameDecoder::new(),
            greeted: HashSet::new(),
            device: None,
            last_rx: now,
            last_hello_tx: now,
            pinged_for_silence: false,
            ping_nonce: 0,
            pings: Vec::new(),
        };
        // A lone delimiter first ends any partial frame the device holds
        // from an earlier connection (docs/wire-format.md, handshake).
        if let Err(e) = conn.port.write_all(&[0]).await {
            return End::Lost(Disconnect::Write(Arc::new(e)));
        }
        if let Err(e) = self.send_hello(&mut conn).await {
            return End::Lost(e);
        }
        let mut tick = tokio::time::interval(self.config.reconnect_poll);
        tick.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Delay);
        let mut buf = [0u8; 512];
        loop {
            tokio::select! {
                r = conn.port.read(&mut buf) => match r {
                    Ok(0) => return End::Lost(Disconnect::EndOfFile),
                    Ok(n) => {
                        conn.last_rx = Instant::now();
                        conn.pinged_for_silence = false;
                        let msgs: Vec<_> = conn.decoder.feed(&buf[..n]).collect();
                        for msg in msgs {
                            if let Err(e) = self.handle_frame(&mut conn, msg).await {
                                return End::Lost(e);
                            }
                        }
                    }
                    Err(e) => return End::Lost(Disconnect::Read(Arc::new(e))),
                },
                cmd = self.cmds.recv() => {
                    let (ping, status) = (matches!(cmd, Some(Command::Ping)), matches!(cmd, Some(Command::GetStatus)));
                    if !self.apply(cmd) {
                        return End::Shutdown;
                    }
                    if ping {
                        if let Err(e) = self.send_ping(&mut conn).await { return End::Lost(e); }
                    }
                    if status {
                        if let Err(e) = self.write(&mut conn, &HostMsg::GetStatus).await { return End::Lost(e); }
                    }
                }
                _ = tick.tick() => {
                    if let Err(e) = self.housekeeping(&mut conn).await {
                        return End::Lost(e);
                    }
                }
            }
        }
    }

    /// Path check, hello retry, silence detection.
    async fn housekeeping(&mut self, conn: &mut Conn) -> Result<(), Disconnect> {
        let identity = path_identity(&self.path);
        if identity.is_none() {
            return Err(Disconnect::PathGone(self.path.clone()));
        }
        if identity != conn.identity {
            return Err(Disconnect::PathReplaced(self.path.clone()));
        }
        let now = Instant::now();
        if conn.device.is_none() && now - conn.last_hello_tx >= self.config.hello_retry {
            self.send_hello(conn).await?;
        }
        let silent = now - conn.last_rx;
        if silent >= self.config.silence_timeout * 3 {
            return Err(Disconnect::Silent(silent));
        }
        if silent >= self.config.silence_timeout && !conn.pinged_for_silence {
            conn.pinged_for_silence = true;
            self.send_ping(conn).await?;
        }
        Ok(())
    }

    async fn write(&self, conn: &mut Conn, msg: &HostMsg) -> Result<(), Disconnect> {
        write_msg(&mut conn.port, msg).await
    }

    async fn send_hello(&self, conn: &mut Conn) -> Result<(), Disconnect> {
        conn.last_hello_tx = Instant::now();
        let hello = HostMsg::Hello(HostHello {
            protocol: self.config.protocol,
            software: self.config.software,
        });
        self.write(conn, &hello).await
    }

    async fn send_ping(&self, conn: &mut Conn) -> Result<(), Disconnect> {
        conn.ping_nonce = conn.ping_nonce.wrapping_add(1);
        conn.pings.push((conn.ping_nonce, Instant::now()));
        if conn.pings.len() > 16 {
            conn.pings.remove(0);
        }
        self.write(
            conn,
            &HostMsg::Ping {
                nonce: conn.ping_nonce,
            },
        )
        .await
    }

    /// Handles one decoded frame. An `Err` ends the connection.
    async fn handle_frame(
        &mut self,
        conn: &mut Conn,
        msg: Result<DeviceMsg, FrameError>,
    ) -> Result<(), Disconnect> {
        let msg = match msg {
            Ok(m) => {
                self.counters.frames_ok += 1;
                m
            }
            Err(error) => {
                self.counters.frames_bad += 1;
                tracing::debug!(%error, "bad frame dropped");
                self.emit(LinkEvent::BadFrame {
                    error,
                    counters: self.counters,
                })
                .await;
                return Ok(());
            }
        };
        match msg {
            DeviceMsg::Hello(hello) => self.on_hello(conn, hello).await?,
            DeviceMsg::Reading(r) => self.on_reading(conn, r).await?,
            DeviceMsg::Live(l) => self.emit(LinkEvent::Live(l)).await,
            DeviceMsg::Button { kind } => self.emit(LinkEvent::Button(kind)).await,
            DeviceMsg::Status(s) => self.emit(LinkEvent::Status(s)).await,
            DeviceMsg::Fault(f) => self.emit(LinkEvent::Fault(f)).await,
            DeviceMsg::Pong { nonce } => {
                if let Some(i) = conn.pings.iter().position(|(n, _)| *n == nonce) {
                    let (_, sent) = conn.pings.remove(i);
                    self.emit(LinkEvent::Pong {
                        rtt: sent.elapsed(),
                    })
                    .await;
                }
            }
        }
        Ok(())
    }

    async fn on_hello(&mut self, conn: &mut Conn, hello: DeviceHello) -> Result<(), Disconnect> {
        let first_time = conn.greeted.insert(hello.boot_id);
        if first_time {
            self.send_hello(conn).await?;
        }
        if !self.config.protocol.is_compatible(&hello.protocol) {
            conn.device = None;
            if first_time {
                let mismatch = VersionMismatch {
                    device: hello.protocol,
                    firmware: hello.firmware,
                    host: self.config.protocol,
                };
                tracing::error!("{mismatch}");
                self.emit(LinkEvent::VersionMismatch(mismatch)).await;
            }
            return Ok(());
        }
        let changed =
            conn.device.map(|d| (d.device_id, d.boot_id)) != Some((hello.device_id, hello.boot_id));
        conn.device = Some(hello);
        if changed {
            tracing::info!(
                device_id = format_args!("{:016x}", hello.device_id),
                boot_id = hello.boot_id,
                "device connected"
            );
            self.emit(LinkEvent::Connected(hello)).await;
        }
        Ok(())
    }

    /// The name for the next reading (`None`: numbered, decided in the
    /// commit), or why there is none.
    fn next_name(&self) -> Result<Option<String>, Unassigned> {
        match &self.naming {
            Naming::None => Err(Unassigned::NoName),
            Naming::Current(n) => Ok(Some(n.clone())),
            Naming::Script(q) => q.front().cloned().map(Some).ok_or(Unassigned::NoName),
            Naming::Numbered => Ok(None),
        }
    }

    async fn on_reading(&mut self, conn: &mut Conn, r: Reading) -> Result<(), Disconnect> {
        let Some(device) = conn.device else {
            // Before a compatible hello we do not know who sent it; the
            // device retransmits after the handshake.
            tracing::debug!(seq = r.seq, "reading before a compatible hello ignored");
            return Ok(());
        };
        if r.boot_id != device.boot_id {
            tracing::debug!(
                seq = r.seq,
                boot_id = r.boot_id,
                "reading from another boot than the hello's ignored"
            );
            return Ok(());
        }
        let dev = DeviceReading {
            device_id: device.device_id,
            boot_id: r.boot_id,
            seq: r.seq,
            value_tenth_mm: r.value_tenth_mm,
            device_time_ms: r.timestamp_ms,
        };
        // Duplicates are acknowledged whether or not a session is set: the
        // store already has them.
        let last = self.blocking({
            let sink = self.sink.clone();
            move || sink.last_committed_seq(dev.device_id, dev.boot_id)
        });
        let last = match last.await {
            Ok(l) => l,
            Err(error) => {
                self.commit_failed(r, error).await;
                return Ok(());
            }
        };
        let target = match self.session {
            None => Err(Unassigned::NoSession),
            Some(s) => self.next_name().map(|n| (s, n)),
        };
        let (session, name) = match (target, last) {
            (_, Some(last)) if r.seq <= last => {
                return self.on_duplicate(conn, r, last).await;
            }
            (Ok(t), _) => t,
            (Err(why), _) => {
                // Bounded: at most the device's queue of unacknowledged
                // readings per target.
                if self.reported_unassigned.insert((r.boot_id, r.seq)) {
                    self.emit(LinkEvent::ReadingUnassigned { reading: r, why })
                        .await;
                }
                return Ok(());
            }
        };
        let outcome = self
            .blocking({
                let sink = self.sink.clone();
                let name = name.clone();
                move || sink.commit_tape_reading(session, name.as_deref(), &dev)
            })
            .await;
        match outcome {
            Ok(CommitOutcome::Committed(reading)) => {
                // The name is used whether or not the ack gets through: a
                // retransmission after a failed ack is a duplicate, and the
                // next new reading must take the next name.
                self.counters.committed += 1;
                if let Naming::Script(q) = &mut self.naming {
                    if name.is_some() && q.front() == name.as_ref() {
                        q.pop_front();
                    }
                }
                // Committed and durable: now, and only now, acknowledge.
                let acked = self
                    .write(
                        conn,
                        &HostMsg::Ack {
                            boot_id: r.boot_id,
                            seq: r.seq,
                        },
                    )
                    .await;
                self.emit(LinkEvent::ReadingCommitted {
                    reading,
                    unit_shown: r.unit_shown,
                })
                .await;
                acked?;
            }
            Ok(CommitOutcome::Duplicate { last_committed_seq }) => {
                self.on_duplicate(conn, r, last_committed_seq).await?;
            }
            Ok(CommitOutcome::Gap { expected, got }) => {
                self.counters.gaps += 1;
                tracing::debug!(expected, got, "gap: reading not stored, not acknowledged");
                self.emit(LinkEvent::Gap {
                    boot_id: r.boot_id,
                    expected,
                    got,
                })
                .await;
            }
            Err(error) => self.commit_failed(r, error).await,
        }
        Ok(())
    }

    /// Reports a failed commit once per reading and error (the device
    /// retransmits every few hundred milliseconds; one report is enough).
    async fn commit_failed(&mut self, r: Reading, error: CommitError) {
        if self.reported_failures.len() > 1024 {
            self.reported_failures.clear();
        }
        if self
            .reported_failures
            .insert((r.boot_id, r.seq, error.to_string()))
        {
            tracing::error!(seq = r.seq, %error, "commit failed; reading not acknowledged");
            self.emit(LinkEvent::CommitFailed { reading: r, error })
                .await;
        }
    }

    async fn on_duplicate(
        &mut self,
        conn: &mut Conn,
        r: Reading,
        last: u32,
    ) -> Result<(), Disconnect> {
        self.write(
            conn,
            &HostMsg::Ack {
                boot_id: r.boot_id,
                seq: last,
            },
        )
        .await?;
        self.counters.duplicates += 1;
        self.emit(LinkEvent::Duplicate {
            boot_id: r.boot_id,
            seq: r.seq,
            last_committed_seq: last,
        })
        .await;
        Ok(())
    }

    /// Runs a store call on tokio's blocking pool (SQLite calls block on
    /// fsync).
    async fn blocking<T, F>(&self, f: F) -> Result<T, CommitError>
    where
        T: Send + 'static,
        F: FnOnce() -> Result<T, StoreError> + Send + 'static,
    {
        match tokio::task::spawn_blocking(f).await {
            Ok(r) => r.map_err(|e| CommitError::Store(Arc::new(e))),
            Err(e) => Err(CommitError::Task(e.to_string())),
        }
    }
}
