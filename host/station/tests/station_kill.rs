//! Kill-safety of the real `tapeshape station` binary: the station is
//! SIGKILLed again and again at random moments while a device (played by
//! this test over a pseudo-terminal, retransmitting every reading until it is
//! acknowledged, as the protocol requires) keeps taking readings. Afterwards
//! the session must hold every reading exactly once, in order: nothing
//! acknowledged is lost and nothing retransmitted is doubled.

use std::collections::VecDeque;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::sync::{Arc, Mutex};
use std::time::Duration;

use tapeshape::store::{SessionStatus, Store};
use tapeshape_protocol::{
    encode, DeviceHello, DeviceMsg, FrameDecoder, HostMsg, Reading, SoftwareVersion, UnitShown,
    MAX_FRAME, PROTOCOL_VERSION,
};
use tokio::io::{AsyncReadExt, AsyncWriteExt};
use tokio_serial::{SerialPort, SerialStream};

const BOOT: u32 = 11;
const TOTAL: u32 = 60;

#[derive(Default)]
struct DeviceState {
    next_seq: u32,
    unacked: VecDeque<Reading>,
    /// Highest acknowledged sequence number.
    acked: Option<u32>,
}

fn value_of(seq: u32) -> u32 {
    5000 + seq * 7
}

/// The device: answers hellos, retransmits unacknowledged readings every
/// 50 ms while a host is there, forgets readings when acknowledged.
async fn device(mut master: SerialStream, state: Arc<Mutex<DeviceState>>) {
    let mut decoder = FrameDecoder::<HostMsg>::new();
    let mut host_seen = false;
    let mut buf = [0u8; 256];
    let mut tick = tokio::time::interval(Duration::from_millis(50));
    loop {
        let mut out: Vec<DeviceMsg> = Vec::new();
        tokio::select! {
            r = master.read(&mut buf) => match r {
                Ok(n) if n > 0 => {
                    for msg in decoder.feed(&buf[..n]) {
                        match msg {
                            Ok(HostMsg::Hello(h)) if h.protocol.is_compatible(&PROTOCOL_VERSION) => {
                                host_seen = true;
                                out.push(DeviceMsg::Hello(DeviceHello {
                                    protocol: PROTOCOL_VERSION,
                                    firmware: SoftwareVersion { major: 1, minor: 0, patch: 0 },
                                    device_id: 77,
                                    boot_id: BOOT,
                                    queue_capacity: 64,
                                }));
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

fn station(port: &Path, data: &Path, first: bool) -> Child {
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_tapeshape"));
    cmd.arg("station")
        .arg("--port")
        .arg(port)
        .arg("--data-dir")
        .arg(data);
    if first {
        cmd.args(["--customer", "kill-test"]);
    } else {
        cmd.arg("--resume");
    }
    cmd.stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap()
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn station_killed_at_random_keeps_every_reading_once() {
    let tmp = tempfile::tempdir().unwrap();
    let data = tmp.path().join("data");
    let (master, slave) = SerialStream::pair().unwrap();
    let port: PathBuf = tmp.path().join("tape");
    std::os::unix::fs::symlink(slave.name().unwrap(), &port).unwrap();
    drop(slave);
    let state = Arc::new(Mutex::new(DeviceState::default()));
    let dev = tokio::spawn(device(master, state.clone()));

    // A small deterministic pseudo-random sequence of kill delays.
    let mut rng: u64 = 0x9E37_79B9_7F4A_7C15;
    let mut next_delay = move || {
        rng ^= rng << 13;
        rng ^= rng >> 7;
        rng ^= rng << 17;
        Duration::from_millis(30 + rng % 400)
    };
    let mut kills = 0;
    let mut first = true;
    while state.lock().unwrap().next_seq < TOTAL {
        let mut child = station(&port, &data, first);
        first = false;
        let deadline = tokio::time::Instant::now() + next_delay();
        while tokio::time::Instant::now() < deadline {
            {
                let mut st = state.lock().unwrap();
                if st.next_seq < TOTAL {
                    let seq = st.next_seq;
                    st.unacked.push_back(Reading {
                        boot_id: BOOT,
                        seq,
                        value_tenth_mm: value_of(seq),
                        timestamp_ms: u64::from(seq) * 100,
                        unit_shown: UnitShown::Metric,
                    });
                    st.next_seq += 1;
                }
            }
            tokio::time::sleep(Duration::from_millis(15)).await;
        }
        child.kill().unwrap(); // SIGKILL
        child.wait().unwrap();
        kills += 1;
        let st = state.lock().unwrap();
        eprintln!(
            "kill {kills}: {} taken, acked up to {:?}, {} waiting",
            st.next_seq,
            st.acked,
            st.unacked.len()
        );
    }
    // A last station run until the device has nothing left unacknowledged.
    let mut child = station(&port, &data, false);
    let deadline = tokio::time::Instant::now() + Duration::from_secs(20);
    while state.lock().unwrap().acked != Some(TOTAL - 1) {
        assert!(
            tokio::time::Instant::now() < deadline,
            "station did not acknowledge everything"
        );
        tokio::time::sleep(Duration::from_millis(20)).await;
    }
    child.kill().unwrap();
    child.wait().unwrap();
    dev.abort();
    assert!(kills >= 3, "only {kills} kills");

    let store = Store::open(&data).unwrap();
    let sessions = store.list_sessions().unwrap();
    assert_eq!(sessions.len(), 1, "resume must reuse the one session");
    let s = &sessions[0].session;
    assert_eq!(s.status, SessionStatus::Open);
    let got: Vec<(u32, u32)> = store
        .open_session(s.id)
        .unwrap()
        .readings
        .iter()
        .map(|r| (r.device.seq, r.device.value_tenth_mm))
        .collect();
    let want: Vec<(u32, u32)> = (0..TOTAL).map(|seq| (seq, value_of(seq))).collect();
    assert_eq!(got, want);
}
