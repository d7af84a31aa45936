//! A device that follows the firmware's rules (docs/wire-format.md), played
//! by the tests over a pseudo-terminal, for tests that drive the real
//! `tapeshape` binary: it answers every host hello, retransmits every
//! unacknowledged reading every 50 ms while a host is there, and forgets
//! readings when they are acknowledged.

// Each test binary uses a different part of this module.
#![allow(dead_code)]

use std::collections::VecDeque;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::sync::{Arc, Mutex};
use std::time::Duration;

use tapeshape_protocol::{
    encode, DeviceHello, DeviceMsg, FrameDecoder, HostMsg, ProtocolVersion, Reading,
    SoftwareVersion, UnitShown, MAX_FRAME, PROTOCOL_VERSION,
};
use tokio::io::{AsyncReadExt, AsyncWriteExt};
use tokio_serial::{SerialPort, SerialStream};

/// Boot id the simulated device uses.
pub const BOOT: u32 = 11;

/// What the device holds.
#[derive(Default)]
pub struct DeviceState {
    /// Sequence number of the next reading.
    pub next_seq: u32,
    /// Readings not acknowledged yet, oldest first.
    pub unacked: VecDeque<Reading>,
    /// Highest acknowledged sequence number.
    pub acked: Option<u32>,
}

impl DeviceState {
    /// The operator confirms a value: it is numbered and queued.
    pub fn take(&mut self, value_tenth_mm: u32) {
        let seq = self.next_seq;
        self.unacked.push_back(Reading {
            boot_id: BOOT,
            seq,
            value_tenth_mm,
            timestamp_ms: u64::from(seq) * 100,
            unit_shown: UnitShown::Metric,
        });
        self.next_seq += 1;
    }
}

/// A simulated device on a pty; the station opens [`SimDevice::port`].
pub struct SimDevice {
    _dir: tempfile::TempDir,
    /// Path the station opens (a symlink to the pty's slave).
    pub port: PathBuf,
    /// Shared state.
    pub state: Arc<Mutex<DeviceState>>,
    task: tokio::task::JoinHandle<()>,
}

impl Drop for SimDevice {
    fn drop(&mut self) {
        self.task.abort();
    }
}

impl SimDevice {
    /// Starts a device speaking `protocol`. Call inside a tokio runtime.
    pub fn start(protocol: ProtocolVersion) -> SimDevice {
        let dir = tempfile::tempdir().unwrap();
        let (master, slave) = SerialStream::pair().unwrap();
        let port = dir.path().join("tape");
        std::os::unix::fs::symlink(slave.name().unwrap(), &port).unwrap();
        drop(slave);
        let state = Arc::new(Mutex::new(DeviceState::default()));
        let task = tokio::spawn(run(master, state.clone(), protocol));
        SimDevice {
            _dir: dir,
            port,
            state,
            task,
        }
    }
}

async fn run(mut master: SerialStream, state: Arc<Mutex<DeviceState>>, protocol: ProtocolVersion) {
    let mut decoder = FrameDecoder::<HostMsg>::new();
    let mut host_seen = false;
    let mut buf = [0u8; 256];
    let mut tick = tokio::time::interval(Duration::from_millis(50));
    let hello = DeviceMsg::Hello(DeviceHello {
        protocol,
        firmware: SoftwareVersion {
            major: 1,
            minor: 2,
            patch: 3,
        },
        device_id: 77,
        boot_id: BOOT,
        queue_capacity: 64,
    });
    loop {
        let mut out: Vec<DeviceMsg> = Vec::new();
        tokio::select! {
            r = master.read(&mut buf) => match r {
                Ok(n) if n > 0 => {
                    for msg in decoder.feed(&buf[..n]) {
                        match msg {
                            Ok(HostMsg::Hello(h)) => {
                                host_seen = h.protocol.is_compatible(&protocol);
                                out.push(hello);
                            }
                            Ok(HostMsg::Ack { boot_id: BOOT, seq }) => {
                                let mut st = state.lock().unwrap();
                                assert!(seq < st.next_seq, "ack of a reading never sent");
                                st.unacked.retain(|r| r.seq > seq);
                                st.acked = Some(st.acked.map_or(seq, |a| a.max(seq)));
                            }
                            // A station killed mid-write leaves half a frame:
                            // dropped, as the firmware does.
                            Ok(_) | Err(_) => {}
                        }
                    }
                }
                // No slave open (station killed or not started yet): EIO or
                // EOF. Wait for the next station.
                _ => {
                    host_seen = false;
                    decoder.reset();
                    tokio::time::sleep(Duration::from_millis(20)).await;
                }
            },
            _ = tick.tick() => {
                if host_seen {
                    let st = state.lock().unwrap();
                    out.extend(st.unacked.iter().map(|r| DeviceMsg::Reading(*r)));
                }
            }
        }
        for msg in out {
            let mut frame = [0u8; MAX_FRAME];
            let frame = encode(&msg, &mut frame).unwrap();
            // A write fails while no station holds the port; the reading
            // stays queued and goes out with the next retransmission.
            let _ = master.write_all(frame).await;
        }
    }
}

/// The device speaking this build's protocol.
pub fn compatible() -> ProtocolVersion {
    PROTOCOL_VERSION
}

/// `tapeshape` with `args` and the data directory `data`, stdout and stderr
/// piped.
pub fn tapeshape(data: &Path, args: &[&str]) -> Command {
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_tapeshape"));
    // The data directory through the environment, so that `args` may end
    // with an option that takes a value.
    cmd.args(args)
        .env("TAPESHAPE_DATA_DIR", data)
        .env_remove("TAPESHAPE_LOG")
        // Operator text in English whatever the developer's locale.
        .env("LC_ALL", "C")
        .stdout(Stdio::piped())
        .stderr(Stdio::piped());
    cmd
}

/// Starts `tapeshape station --port <port>` with `args`, output discarded.
pub fn station(port: &Path, data: &Path, args: &[&str]) -> Child {
    let mut cmd = tapeshape(data, &["station"]);
    cmd.arg("--port")
        .arg(port)
        .args(args)
        .stdout(Stdio::null())
        .stderr(Stdio::null());
    cmd.spawn().unwrap()
}

/// Estimates `session` from `readings` (name, tenths of a millimetre) with
/// the station's services, as the kiosk does when the operator presses `e`,
/// and waits for it (two minutes at most); the estimate is then stored with
/// its session. Panics when it fails or is cancelled.
pub fn estimate_and_wait(
    sessions: &tapeshape::session::Sessions,
    session: tapeshape::store::SessionId,
    readings: &[(String, u32)],
) -> tapeshape::services::EstimateSummary {
    use tapeshape::services::station::StationServices;
    use tapeshape::services::{EstimateEvent, EstimateRequest, Services as _};
    let services = StationServices::new(sessions.clone(), None);
    let (tx, rx) = std::sync::mpsc::channel();
    let _cancel = services.start_estimate(
        EstimateRequest {
            session,
            readings: readings
                .iter()
                .map(|(n, v)| (n.clone(), f64::from(*v) / 10.0))
                .collect(),
            sex: None,
            kept: Vec::new(),
        },
        Box::new(move |ev| {
            let _ = tx.send(ev);
        }),
    );
    loop {
        match rx.recv_timeout(Duration::from_secs(120)).unwrap() {
            EstimateEvent::Done(s) => return *s,
            EstimateEvent::Stage { .. } => {}
            other => panic!("the estimate did not finish: {other:?}"),
        }
    }
}
