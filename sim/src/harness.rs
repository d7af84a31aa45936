//! The firmware logic running on the host, between two real pseudo-terminals.
//!
//! Why: most end-to-end runs need the firmware's behaviour (numbering, retransmission,
//! rejection of bad tape lines) without the cost and the extra moving parts of an emulator.
//! [`FirmwareHarness`] runs `tapeshape_firmware::run` (the very function the boards run) on a
//! thread of its own, as a separate device would, with its two UARTs on pty masters: the tape
//! simulator writes to [`FirmwareHarness::tape_path`], the station side (through the proxy, or
//! directly) opens [`FirmwareHarness::host_path`]. That is the same shape as the board under
//! QEMU (`qemu::QemuBoard`, feature `qemu`), so tests can swap one for the other.
//!
//! UART semantics on a pty master (what [`PtyUartRx`] and [`PtyUartTx`] add over
//! `embedded-io-adapters`' plain tokio adapter): a UART with nothing attached receives nothing
//! and transmits into the void. A pty master instead fails reads with `EIO` while no process
//! has the slave open, and buffers writes for whoever opens it later. So the reader waits
//! quietly while the peer is absent, and the writer drops (and counts) bytes while it is,
//! which is also what `run`'s contract asks of `host_tx` ("must not block forever when no host
//! listens").

use std::io;
use std::path::PathBuf;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Arc;
use std::time::Duration;

use tapeshape_firmware::{Clock, Config, Device, RunEnd};
use tokio::io::{AsyncReadExt, AsyncWriteExt};
use tokio::sync::mpsc;

use crate::pty::{is_peer_gone, PtyPair, TtyStream};

/// Read half of a simulated UART on a pty master.
#[derive(Debug)]
pub struct PtyUartRx {
    tty: TtyStream,
}

/// Write half of a simulated UART on a pty master.
#[derive(Debug)]
pub struct PtyUartTx {
    tty: TtyStream,
    dropped: Arc<AtomicU64>,
}

/// Splits a pty master into UART halves. `dropped` counts bytes written while no peer had the
/// slave open.
pub fn pty_uart(master: TtyStream, dropped: Arc<AtomicU64>) -> io::Result<(PtyUartRx, PtyUartTx)> {
    let rx = master.try_clone()?;
    Ok((
        PtyUartRx { tty: rx },
        PtyUartTx {
            tty: master,
            dropped,
        },
    ))
}

impl embedded_io_async::ErrorType for PtyUartRx {
    type Error = io::Error;
}

impl embedded_io_async::ErrorType for PtyUartTx {
    type Error = io::Error;
}

/// How long the reader waits before looking again while nobody has the slave open.
const ABSENT_POLL: Duration = Duration::from_millis(5);

impl embedded_io_async::Read for PtyUartRx {
    /// Cancel-safe (as `run` requires): no byte is taken out of the kernel unless the call
    /// completes.
    async fn read(&mut self, buf: &mut [u8]) -> Result<usize, io::Error> {
        if buf.is_empty() {
            return Ok(0);
        }
        loop {
            match self.tty.read(buf).await {
                // A master does not see end-of-file; the slave closing shows as EIO.
                Ok(0) => tokio::time::sleep(ABSENT_POLL).await,
                Ok(n) => return Ok(n),
                Err(e) if is_peer_gone(&e) => tokio::time::sleep(ABSENT_POLL).await,
                Err(e) => return Err(e),
            }
        }
    }
}

impl embedded_io_async::Write for PtyUartTx {
    async fn write(&mut self, buf: &[u8]) -> Result<usize, io::Error> {
        if buf.is_empty() {
            return Ok(0);
        }
        if !self.tty.peer_present()? {
            self.dropped.fetch_add(buf.len() as u64, Ordering::Relaxed);
            return Ok(buf.len());
        }
        // Bounded: a peer that holds the port open but never reads must not stall the
        // firmware forever; its bytes are lost like a UART's into a full receiver.
        match tokio::time::timeout(Duration::from_millis(500), self.tty.write(buf)).await {
            Ok(Ok(n)) => Ok(n),
            Ok(Err(e)) if is_peer_gone(&e) => {
                self.dropped.fetch_add(buf.len() as u64, Ordering::Relaxed);
                Ok(buf.len())
            }
            Ok(Err(e)) => Err(e),
            Err(_) => {
                self.dropped.fetch_add(buf.len() as u64, Ordering::Relaxed);
                Ok(buf.len())
            }
        }
    }

    async fn flush(&mut self) -> Result<(), io::Error> {
        // A pty write hands the bytes to the kernel: nothing to flush.
        Ok(())
    }
}

/// The device's uptime clock on the host (tokio timers).
#[derive(Debug, Clone, Copy)]
pub struct HostClock {
    start: tokio::time::Instant,
}

impl HostClock {
    /// A clock starting at 0 now.
    pub fn new() -> Self {
        Self {
            start: tokio::time::Instant::now(),
        }
    }
}

impl Default for HostClock {
    fn default() -> Self {
        Self::new()
    }
}

impl Clock for HostClock {
    fn now_ms(&self) -> u64 {
        self.start.elapsed().as_millis() as u64
    }

    async fn sleep_until(&self, deadline_ms: u64) {
        tokio::time::sleep_until(self.start + Duration::from_millis(deadline_ms)).await;
    }
}

/// Settings of a [`FirmwareHarness`].
#[derive(Debug, Clone, Copy)]
pub struct HarnessConfig {
    /// The firmware's configuration (device id, boot id, timers).
    pub firmware: Config,
}

impl HarnessConfig {
    /// Defaults for a device id and a first boot id; the firmware's timers shortened for
    /// tests (retransmit after 20 ms, status every 500 ms, hello every 200 ms).
    pub fn fast(device_id: u64, boot_id: u32) -> Self {
        let mut firmware = Config::new(device_id, boot_id);
        firmware.retransmit_ms = 20;
        firmware.status_interval_ms = 500;
        firmware.hello_interval_ms = 200;
        Self { firmware }
    }
}

enum Control {
    Reboot { boot_id: u32 },
    Stop,
}

/// Errors of the harness.
#[derive(Debug, thiserror::Error)]
pub enum HarnessError {
    /// Creating the ptys or the runtime failed.
    #[error("firmware harness: {what}: {source}")]
    Io {
        /// What failed.
        what: &'static str,
        /// The error.
        source: io::Error,
    },
    /// The harness thread is gone.
    #[error("firmware harness thread ended unexpectedly")]
    Gone,
}

/// The firmware logic running on its own thread between two ptys. Stopped on drop.
#[derive(Debug)]
pub struct FirmwareHarness {
    tape_path: PathBuf,
    host_path: PathBuf,
    control: mpsc::UnboundedSender<Control>,
    host_bytes_dropped: Arc<AtomicU64>,
    boots: Arc<AtomicU64>,
    thread: Option<std::thread::JoinHandle<()>>,
}

impl FirmwareHarness {
    /// Starts the firmware. Returns once both ports exist.
    pub fn start(config: HarnessConfig) -> Result<Self, HarnessError> {
        let (ready_tx, ready_rx) = std::sync::mpsc::channel();
        let (ctl_tx, ctl_rx) = mpsc::unbounded_channel();
        let dropped = Arc::new(AtomicU64::new(0));
        let boots = Arc::new(AtomicU64::new(0));
        let (d2, b2) = (dropped.clone(), boots.clone());
        let thread = std::thread::Builder::new()
            .name("sim-firmware".into())
            .spawn(move || firmware_thread(config, ready_tx, ctl_rx, d2, b2))
            .map_err(|source| HarnessError::Io {
                what: "spawning the firmware thread",
                source,
            })?;
        let (tape_path, host_path) =
            ready_rx
                .recv()
                .map_err(|_| HarnessError::Gone)?
                .map_err(|source| HarnessError::Io {
                    what: "creating the firmware's ptys",
                    source,
                })?;
        Ok(Self {
            tape_path,
            host_path,
            control: ctl_tx,
            host_bytes_dropped: dropped,
            boots,
            thread: Some(thread),
        })
    }

    /// Where the tape is plugged in: write tape lines to this tty.
    pub fn tape_path(&self) -> &std::path::Path {
        &self.tape_path
    }

    /// The firmware's host UART: open this tty to talk to the firmware.
    pub fn host_path(&self) -> &std::path::Path {
        &self.host_path
    }

    /// Bytes the firmware sent while nobody had its host port open.
    pub fn host_bytes_dropped(&self) -> u64 {
        self.host_bytes_dropped.load(Ordering::Relaxed)
    }

    /// Boots so far (the first one included).
    pub fn boots(&self) -> u64 {
        self.boots.load(Ordering::Relaxed)
    }

    /// Reboots the firmware with a new boot id: its unacknowledged readings are lost, as on
    /// a real power cycle (the host sees a new hello and sequence numbers from 0).
    pub fn reboot(&self, boot_id: u32) -> Result<(), HarnessError> {
        self.control
            .send(Control::Reboot { boot_id })
            .map_err(|_| HarnessError::Gone)
    }
}

impl Drop for FirmwareHarness {
    fn drop(&mut self) {
        let _ = self.control.send(Control::Stop);
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

type Ready = std::sync::mpsc::Sender<io::Result<(PathBuf, PathBuf)>>;

fn firmware_thread(
    config: HarnessConfig,
    ready: Ready,
    mut control: mpsc::UnboundedReceiver<Control>,
    dropped: Arc<AtomicU64>,
    boots: Arc<AtomicU64>,
) {
    let rt = match tokio::runtime::Builder::new_current_thread()
        .enable_all()
        .build()
    {
        Ok(rt) => rt,
        Err(e) => {
            let _ = ready.send(Err(e));
            return;
        }
    };
    rt.block_on(async move {
        let (tape, host) = match (PtyPair::open(), PtyPair::open()) {
            (Ok(t), Ok(h)) => (t, h),
            (Err(e), _) | (_, Err(e)) => {
                let _ = ready.send(Err(e));
                return;
            }
        };
        let (tape_path, host_path) = (tape.slave_path.clone(), host.slave_path.clone());
        let uarts = pty_uart(tape.master, Arc::new(AtomicU64::new(0)))
            .and_then(|t| Ok((t, pty_uart(host.master, dropped)?)));
        let ((mut tape_rx, _tape_tx), (mut host_rx, mut host_tx)) = match uarts {
            Ok(u) => u,
            Err(e) => {
                let _ = ready.send(Err(e));
                return;
            }
        };
        if ready.send(Ok((tape_path, host_path))).is_err() {
            return;
        }
        let clock = HostClock::new();
        let mut fw = config.firmware;
        loop {
            boots.fetch_add(1, Ordering::Relaxed);
            let mut device = Device::new(fw, clock.now_ms());
            let run = tapeshape_firmware::run(
                &mut device,
                &mut tape_rx,
                &mut host_rx,
                &mut host_tx,
                &clock,
            );
            tokio::select! {
                end = run => {
                    // Pty UARTs never report end of stream (see PtyUartRx); if the firmware
                    // returns anyway, wait for orders rather than spin.
                    tracing::warn!(?end, "firmware run returned");
                    let _: RunEnd = end;
                    match control.recv().await {
                        Some(Control::Reboot { boot_id }) => fw.boot_id = boot_id,
                        Some(Control::Stop) | None => return,
                    }
                }
                c = control.recv() => match c {
                    Some(Control::Reboot { boot_id }) => fw.boot_id = boot_id,
                    Some(Control::Stop) | None => return,
                },
            }
        }
    });
}

#[cfg(test)]
mod tests {
    use super::*;
    use tapeshape_protocol::{
        encode, DeviceMsg, FrameDecoder, HostHello, HostMsg, MAX_FRAME, PROTOCOL_VERSION,
    };
    use tokio::io::{AsyncReadExt, AsyncWriteExt};

    async fn next_msg(
        host: &mut TtyStream,
        dec: &mut FrameDecoder<DeviceMsg>,
        pending: &mut std::collections::VecDeque<DeviceMsg>,
        want: impl Fn(&DeviceMsg) -> bool,
    ) -> DeviceMsg {
        let deadline = tokio::time::Instant::now() + Duration::from_secs(5);
        loop {
            while let Some(m) = pending.pop_front() {
                if want(&m) {
                    return m;
                }
            }
            let mut buf = [0u8; 256];
            let n = tokio::time::timeout_at(deadline, host.read(&mut buf))
                .await
                .expect("no matching message from the firmware within 5 s")
                .unwrap();
            for m in dec.feed(&buf[..n]) {
                pending.push_back(m.expect("clean link: every frame decodes"));
            }
        }
    }

    /// The harness runs the real firmware logic: hello at boot, a confirmed tape line becomes
    /// reading 0 with the line's value, retransmitted until acknowledged; a garbage line is
    /// rejected and reported, never a reading.
    #[tokio::test]
    async fn firmware_logic_over_ptys() {
        let fw = FirmwareHarness::start(HarnessConfig::fast(0xAB, 7)).unwrap();
        // Open the ports late, so the first hello goes out while nobody listens (dropped):
        // the firmware must carry on and repeat it.
        tokio::time::sleep(Duration::from_millis(100)).await;
        let mut tape = TtyStream::open_path(fw.tape_path()).unwrap();
        let mut host = TtyStream::open_path(fw.host_path()).unwrap();
        let mut dec = FrameDecoder::<DeviceMsg>::new();
        let mut q = Default::default();
        tokio::time::sleep(Duration::from_millis(1000)).await;
        let hello = next_msg(&mut host, &mut dec, &mut q, |m| {
            matches!(m, DeviceMsg::Hello(_))
        })
        .await;
        let DeviceMsg::Hello(h) = hello else {
            unreachable!()
        };
        assert_eq!((h.device_id, h.boot_id), (0xAB, 7));
        let mut buf = [0u8; MAX_FRAME];
        let f = encode(
            &HostMsg::Hello(HostHello {
                protocol: PROTOCOL_VERSION,
                software: h.firmware,
            }),
            &mut buf,
        )
        .unwrap();
        host.write_all(f).await.unwrap();
        tape.write_all(b"*12x45;00000;0000SM\n*04321;00000;0000SM\n")
            .await
            .unwrap();
        let r = next_msg(&mut host, &mut dec, &mut q, |m| {
            matches!(m, DeviceMsg::Reading(_))
        })
        .await;
        let DeviceMsg::Reading(r) = r else {
            unreachable!()
        };
        assert_eq!((r.boot_id, r.seq, r.value_tenth_mm), (7, 0, 4321));
        // Not acknowledged: it comes again.
        let again = next_msg(&mut host, &mut dec, &mut q, |m| {
            matches!(m, DeviceMsg::Reading(_))
        })
        .await;
        assert!(matches!(again, DeviceMsg::Reading(x) if x.seq == 0));
        let f = encode(&HostMsg::Ack { boot_id: 7, seq: 0 }, &mut buf).unwrap();
        host.write_all(f).await.unwrap();
        let st = next_msg(
            &mut host,
            &mut dec,
            &mut q,
            |m| matches!(m, DeviceMsg::Status(s) if s.queue_len == 0),
        )
        .await;
        let DeviceMsg::Status(st) = st else {
            unreachable!()
        };
        assert_eq!(st.rejected.total(), 1, "{st:?}");
        assert_eq!(st.next_seq, 1);
    }

    /// A reboot starts a new boot: a hello with the new boot id.
    #[tokio::test]
    async fn reboot_announces_a_new_boot() {
        let fw = FirmwareHarness::start(HarnessConfig::fast(0xCD, 1)).unwrap();
        let mut host = TtyStream::open_path(fw.host_path()).unwrap();
        let mut dec = FrameDecoder::<DeviceMsg>::new();
        let mut q = Default::default();
        let is_hello =
            |b: u32| move |m: &DeviceMsg| matches!(m, DeviceMsg::Hello(h) if h.boot_id == b);
        next_msg(&mut host, &mut dec, &mut q, is_hello(1)).await;
        fw.reboot(2).unwrap();
        next_msg(&mut host, &mut dec, &mut q, is_hello(2)).await;
        assert_eq!(fw.boots(), 2);
    }
}
