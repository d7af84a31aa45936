//! Link tests against a device played by the test over a real pseudo-terminal.
//!
//! The link opens the pty's slave through a symlink, exactly as it opens a
//! real serial port; the test holds the master and speaks the protocol with
//! the protocol crate. Unplugging closes the master and removes the symlink,
//! as pulling a USB adapter does.

use std::path::{Path, PathBuf};
use std::time::Duration;

use tapeshape::link::{Link, LinkConfig, LinkEvent, LinkHandle, Naming, Unassigned};
use tapeshape::session::Sessions;
use tapeshape::store::{SessionId, Store};
use tapeshape_protocol::{
    encode, DeviceHello, DeviceMsg, FrameDecoder, HostMsg, ProtocolVersion, Reading,
    SoftwareVersion, UnitShown, MAX_FRAME, PROTOCOL_VERSION,
};
use tokio::io::{AsyncReadExt, AsyncWriteExt};
use tokio::sync::mpsc;
use tokio_serial::{SerialPort, SerialStream};

const WAIT: Duration = Duration::from_secs(5);
const QUIET: Duration = Duration::from_millis(600);
const DEVICE_ID: u64 = 0xDEAD_BEEF_0042_0001;

/// The device end: a pty master behind a stable symlink path.
struct Device {
    master: SerialStream,
    // The pty pair's own slave handle, kept open so the pty stays usable
    // while the link (re)opens the path.
    _slave: SerialStream,
    decoder: FrameDecoder<HostMsg>,
}

struct Port {
    _dir: tempfile::TempDir,
    path: PathBuf,
}

impl Port {
    fn new() -> Port {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("tape");
        Port { _dir: dir, path }
    }

    fn plug(&self) -> Device {
        let (master, slave) = SerialStream::pair().unwrap();
        let slave_path = slave.name().unwrap();
        let tmp = self.path.with_extension("tmp");
        std::os::unix::fs::symlink(slave_path, &tmp).unwrap();
        std::fs::rename(&tmp, &self.path).unwrap();
        Device {
            master,
            _slave: slave,
            decoder: FrameDecoder::new(),
        }
    }

    fn unplug(&self, device: Device) {
        drop(device);
        std::fs::remove_file(&self.path).unwrap();
    }
}

impl Device {
    async fn send(&mut self, msg: DeviceMsg) {
        let mut buf = [0u8; MAX_FRAME];
        let frame = encode(&msg, &mut buf).unwrap();
        self.master.write_all(frame).await.unwrap();
    }

    /// Next host message, or None after `within`.
    async fn recv_within(&mut self, within: Duration) -> Option<HostMsg> {
        let deadline = tokio::time::Instant::now() + within;
        let mut byte = [0u8; 1];
        loop {
            let n = tokio::time::timeout_at(deadline, self.master.read(&mut byte))
                .await
                .ok()?
                .unwrap();
            assert!(n > 0, "link closed the port");
            if let Some(r) = self.decoder.push(byte[0]) {
                return Some(r.expect("link sent a bad frame"));
            }
        }
    }

    async fn recv(&mut self) -> HostMsg {
        self.recv_within(WAIT)
            .await
            .expect("no message from the link")
    }

    /// Waits for an Ack, skipping hellos and pings; None if none comes
    /// within `within`.
    async fn ack_within(&mut self, within: Duration) -> Option<(u32, u32)> {
        let deadline = tokio::time::Instant::now() + within;
        loop {
            let left = deadline.saturating_duration_since(tokio::time::Instant::now());
            match self.recv_within(left).await? {
                HostMsg::Ack { boot_id, seq } => return Some((boot_id, seq)),
                _ => continue,
            }
        }
    }

    async fn ack(&mut self) -> (u32, u32) {
        self.ack_within(WAIT).await.expect("no ack")
    }

    /// Handshake from the device side: expects the host hello, answers.
    async fn handshake(&mut self, boot_id: u32, protocol: ProtocolVersion) {
        match self.recv().await {
            HostMsg::Hello(h) => assert_eq!(h.protocol, PROTOCOL_VERSION),
            other => panic!("expected a host hello first, got {other:?}"),
        }
        self.send(DeviceMsg::Hello(hello(boot_id, protocol))).await;
    }

    async fn reading(&mut self, boot_id: u32, seq: u32, value: u32) {
        self.send(DeviceMsg::Reading(Reading {
            boot_id,
            seq,
            value_tenth_mm: value,
            timestamp_ms: 1000 + u64::from(seq),
            unit_shown: UnitShown::Metric,
        }))
        .await;
    }
}

fn hello(boot_id: u32, protocol: ProtocolVersion) -> DeviceHello {
    DeviceHello {
        protocol,
        firmware: SoftwareVersion {
            major: 3,
            minor: 4,
            patch: 5,
        },
        device_id: DEVICE_ID,
        boot_id,
        queue_capacity: 8,
    }
}

fn config() -> LinkConfig {
    LinkConfig {
        reconnect_poll: Duration::from_millis(50),
        ..LinkConfig::default()
    }
}

struct Rig {
    _data: tempfile::TempDir,
    data_dir: PathBuf,
    store: Store,
    sessions: Sessions,
    session: SessionId,
    link: LinkHandle,
    events: mpsc::Receiver<LinkEvent>,
}

fn rig(port: &Path) -> Rig {
    let data = tempfile::tempdir().unwrap();
    let data_dir = data.path().to_path_buf();
    let sessions = Sessions::open(&data_dir).unwrap();
    let store = sessions.store().clone();
    let session = sessions.create("cust-1", None, None).unwrap().id;
    let (link, events, _task) = Link::spawn(port, config(), sessions.clone());
    Rig {
        _data: data,
        data_dir,
        store,
        sessions,
        session,
        link,
        events,
    }
}

/// Next event satisfying `pred` (others are skipped), or a panic naming
/// `what`.
async fn wait_for(
    events: &mut mpsc::Receiver<LinkEvent>,
    what: &str,
    mut pred: impl FnMut(&LinkEvent) -> bool,
) -> LinkEvent {
    let deadline = tokio::time::Instant::now() + WAIT;
    loop {
        match tokio::time::timeout_at(deadline, events.recv()).await {
            Ok(Some(ev)) if pred(&ev) => return ev,
            Ok(Some(_)) => continue,
            Ok(None) => panic!("event channel closed while waiting for {what}"),
            Err(_) => panic!("timed out waiting for {what}"),
        }
    }
}

fn values(store: &Store, session: SessionId) -> Vec<(String, u32, u32)> {
    store
        .open_session(session)
        .unwrap()
        .readings
        .into_iter()
        .map(|r| (r.tape().unwrap().seq, r.value_tenth_mm, r.measurement))
        .map(|(seq, v, name)| (name, seq, v))
        .collect()
}

#[tokio::test]
async fn handshake_then_commit_then_ack() {
    let port = Port::new();
    let mut dev = port.plug();
    let mut rig = rig(&port.path);
    wait_for(&mut rig.events, "port opened", |e| {
        matches!(e, LinkEvent::PortOpened { .. })
    })
    .await;
    dev.handshake(7, PROTOCOL_VERSION).await;
    let ev = wait_for(&mut rig.events, "connected", |e| {
        matches!(e, LinkEvent::Connected(_))
    })
    .await;
    let LinkEvent::Connected(h) = ev else {
        unreachable!()
    };
    assert_eq!((h.device_id, h.boot_id), (DEVICE_ID, 7));
    // The link greets the new boot id with a hello of its own.
    assert!(matches!(dev.recv().await, HostMsg::Hello(_)));

    rig.link.set_session(Some(rig.session));
    rig.link.set_naming(Naming::Script(
        ["chest".to_string(), "waist".to_string()].into(),
    ));
    dev.reading(7, 0, 9512).await;
    assert_eq!(dev.ack().await, (7, 0));
    let ev = wait_for(&mut rig.events, "committed", |e| {
        matches!(e, LinkEvent::ReadingCommitted { .. })
    })
    .await;
    let LinkEvent::ReadingCommitted { reading, .. } = ev else {
        unreachable!()
    };
    assert_eq!(reading.measurement, "chest");
    assert_eq!(reading.tape().unwrap().device_id, DEVICE_ID);
    dev.reading(7, 1, 8120).await;
    assert_eq!(dev.ack().await, (7, 1));
    assert_eq!(
        values(&rig.store, rig.session),
        vec![("chest".into(), 0, 9512), ("waist".into(), 1, 8120)]
    );
    // The script is used up: the next reading is held, not acknowledged.
    dev.reading(7, 2, 7000).await;
    let ev = wait_for(&mut rig.events, "unassigned", |e| {
        matches!(e, LinkEvent::ReadingUnassigned { .. })
    })
    .await;
    assert!(matches!(
        ev,
        LinkEvent::ReadingUnassigned {
            why: Unassigned::NoName,
            ..
        }
    ));
    assert_eq!(dev.ack_within(QUIET).await, None);
    rig.link.set_naming(Naming::Current("hip".into()));
    dev.reading(7, 2, 7000).await; // the device's retransmission
    assert_eq!(dev.ack().await, (7, 2));
    assert_eq!(values(&rig.store, rig.session).len(), 3);
    rig.link.shutdown();
    wait_for(&mut rig.events, "stopped", |e| {
        matches!(e, LinkEvent::Stopped)
    })
    .await;
}

#[tokio::test]
async fn version_mismatch_names_both_versions_and_ignores_readings() {
    let port = Port::new();
    let mut dev = port.plug();
    let mut rig = rig(&port.path);
    rig.link.set_session(Some(rig.session));
    rig.link.set_naming(Naming::Numbered);
    let theirs = ProtocolVersion {
        major: PROTOCOL_VERSION.major + 1,
        minor: 7,
    };
    dev.handshake(1, theirs).await;
    let ev = wait_for(&mut rig.events, "version mismatch", |e| {
        matches!(e, LinkEvent::VersionMismatch(_))
    })
    .await;
    let LinkEvent::VersionMismatch(m) = ev else {
        unreachable!()
    };
    let msg = m.to_string();
    let ours = format!(
        "protocol {}.{}",
        PROTOCOL_VERSION.major, PROTOCOL_VERSION.minor
    );
    let device = format!("protocol {}.{}", theirs.major, theirs.minor);
    assert!(msg.contains(&ours), "{msg}");
    assert!(msg.contains(&device), "{msg}");
    assert!(msg.contains("firmware 3.4.5"), "{msg}");
    // Readings from an incompatible device are never acknowledged or stored.
    dev.reading(1, 0, 5000).await;
    assert_eq!(dev.ack_within(QUIET).await, None);
    assert!(values(&rig.store, rig.session).is_empty());
}

#[tokio::test]
async fn ack_waits_for_the_commit() {
    let port = Port::new();
    let mut dev = port.plug();
    let mut rig = rig(&port.path);
    rig.link.set_session(Some(rig.session));
    rig.link.set_naming(Naming::Current("neck".into()));
    dev.handshake(3, PROTOCOL_VERSION).await;
    wait_for(&mut rig.events, "connected", |e| {
        matches!(e, LinkEvent::Connected(_))
    })
    .await;
    // Another process holds the database's write lock: the commit cannot
    // finish, so no acknowledgement may be sent.
    let blocker = rusqlite_blocker(&rig.data_dir);
    dev.reading(3, 0, 3800).await;
    assert_eq!(dev.ack_within(Duration::from_millis(1500)).await, None);
    drop(blocker);
    assert_eq!(dev.ack().await, (3, 0));
    // The row is there the moment the ack arrives (another connection).
    let other = Store::open(&rig.data_dir).unwrap();
    assert_eq!(values(&other, rig.session), vec![("neck".into(), 0, 3800)]);
}

/// Holds an immediate (write) transaction on the store's database.
struct Blocker(
    std::sync::mpsc::Sender<()>,
    Option<std::thread::JoinHandle<()>>,
);

impl Drop for Blocker {
    fn drop(&mut self) {
        let _ = self.0.send(());
        if let Some(t) = self.1.take() {
            t.join().unwrap();
        }
    }
}

fn rusqlite_blocker(data_dir: &Path) -> Blocker {
    let path = data_dir.join(tapeshape::store::DB_FILE_NAME);
    let (tx, rx) = std::sync::mpsc::channel();
    let (locked_tx, locked_rx) = std::sync::mpsc::channel();
    let t = std::thread::spawn(move || {
        let conn = rusqlite::Connection::open(path).unwrap();
        conn.execute_batch("BEGIN IMMEDIATE").unwrap();
        locked_tx.send(()).unwrap();
        let _ = rx.recv();
        conn.execute_batch("ROLLBACK").unwrap();
    });
    locked_rx.recv().unwrap();
    Blocker(tx, Some(t))
}

#[tokio::test]
async fn duplicates_are_reacked_and_gaps_are_not() {
    let port = Port::new();
    let mut dev = port.plug();
    let mut rig = rig(&port.path);
    rig.link.set_session(Some(rig.session));
    rig.link.set_naming(Naming::Numbered);
    dev.handshake(9, PROTOCOL_VERSION).await;
    dev.reading(9, 0, 1000).await;
    assert_eq!(dev.ack().await, (9, 0));
    // Retransmission (the ack was "lost"): acknowledged again, not stored.
    dev.reading(9, 0, 1000).await;
    assert_eq!(dev.ack().await, (9, 0));
    wait_for(&mut rig.events, "duplicate", |e| {
        matches!(
            e,
            LinkEvent::Duplicate {
                seq: 0,
                last_committed_seq: 0,
                ..
            }
        )
    })
    .await;
    // Seq 1 lost on the way: 2 is a gap, neither stored nor acknowledged.
    dev.reading(9, 2, 3000).await;
    assert_eq!(dev.ack_within(QUIET).await, None);
    wait_for(&mut rig.events, "gap", |e| {
        matches!(
            e,
            LinkEvent::Gap {
                expected: 1,
                got: 2,
                ..
            }
        )
    })
    .await;
    dev.reading(9, 1, 2000).await;
    assert_eq!(dev.ack().await, (9, 1));
    dev.reading(9, 2, 3000).await;
    assert_eq!(dev.ack().await, (9, 2));
    assert_eq!(
        values(&rig.store, rig.session),
        vec![
            ("reading-1".into(), 0, 1000),
            ("reading-2".into(), 1, 2000),
            ("reading-3".into(), 2, 3000)
        ]
    );
}

#[tokio::test]
async fn bad_frames_are_counted_and_dropped() {
    let port = Port::new();
    let mut dev = port.plug();
    let mut rig = rig(&port.path);
    rig.link.set_session(Some(rig.session));
    rig.link.set_naming(Naming::Current("arm".into()));
    dev.handshake(2, PROTOCOL_VERSION).await;
    // A frame with a flipped bit, then line noise, then a good reading.
    let mut buf = [0u8; MAX_FRAME];
    let frame = encode(
        &DeviceMsg::Reading(Reading {
            boot_id: 2,
            seq: 0,
            value_tenth_mm: 1234,
            timestamp_ms: 0,
            unit_shown: UnitShown::Metric,
        }),
        &mut buf,
    )
    .unwrap()
    .to_vec();
    let mut corrupt = frame.clone();
    corrupt[3] ^= 0x10;
    dev.master.write_all(&corrupt).await.unwrap();
    dev.master.write_all(&[0x55; 300]).await.unwrap();
    dev.master.write_all(&[0x00]).await.unwrap();
    let ev = wait_for(&mut rig.events, "bad frame", |e| {
        matches!(e, LinkEvent::BadFrame { .. })
    })
    .await;
    let LinkEvent::BadFrame { counters, .. } = ev else {
        unreachable!()
    };
    assert!(counters.frames_bad >= 1);
    assert_eq!(dev.ack_within(QUIET).await, None);
    dev.master.write_all(&frame).await.unwrap();
    assert_eq!(dev.ack().await, (2, 0));
    assert_eq!(
        values(&rig.store, rig.session),
        vec![("arm".into(), 0, 1234)]
    );
}

#[tokio::test]
async fn reconnects_after_unplug_and_loses_nothing() {
    let port = Port::new();
    let mut dev = port.plug();
    let mut rig = rig(&port.path);
    rig.link.set_session(Some(rig.session));
    rig.link.set_naming(Naming::Numbered);
    dev.handshake(5, PROTOCOL_VERSION).await;
    dev.reading(5, 0, 1111).await;
    assert_eq!(dev.ack().await, (5, 0));
    // The device held reading 1 but the port vanishes before it is sent.
    port.unplug(dev);
    wait_for(&mut rig.events, "disconnected", |e| {
        matches!(e, LinkEvent::Disconnected { .. })
    })
    .await;
    wait_for(&mut rig.events, "waiting for port", |e| {
        matches!(e, LinkEvent::WaitingForPort { .. })
    })
    .await;
    tokio::time::sleep(Duration::from_millis(300)).await;
    let mut dev = port.plug();
    wait_for(&mut rig.events, "port reopened", |e| {
        matches!(e, LinkEvent::PortOpened { .. })
    })
    .await;
    // Same boot: the device retransmits everything not acknowledged. Reading
    // 0 was acknowledged before, but a device might resend it if the ack was
    // lost in the unplug: it must not be stored twice.
    dev.handshake(5, PROTOCOL_VERSION).await;
    dev.reading(5, 0, 1111).await;
    assert_eq!(dev.ack().await, (5, 0));
    dev.reading(5, 1, 2222).await;
    assert_eq!(dev.ack().await, (5, 1));
    assert_eq!(
        values(&rig.store, rig.session),
        vec![("reading-1".into(), 0, 1111), ("reading-2".into(), 1, 2222)]
    );
}

#[tokio::test]
async fn waits_for_a_port_that_does_not_exist_yet() {
    let port = Port::new();
    let mut rig = rig(&port.path);
    let ev = wait_for(&mut rig.events, "waiting for port", |e| {
        matches!(e, LinkEvent::WaitingForPort { .. })
    })
    .await;
    let LinkEvent::WaitingForPort { error } = ev else {
        unreachable!()
    };
    assert!(
        error.to_string().contains(&port.path.display().to_string()),
        "{error}"
    );
    let mut dev = port.plug();
    dev.handshake(1, PROTOCOL_VERSION).await;
    wait_for(&mut rig.events, "connected", |e| {
        matches!(e, LinkEvent::Connected(_))
    })
    .await;
}

#[tokio::test]
async fn a_device_reboot_starts_a_new_sequence_in_the_same_session() {
    let port = Port::new();
    let mut dev = port.plug();
    let mut rig = rig(&port.path);
    rig.link.set_session(Some(rig.session));
    rig.link.set_naming(Naming::Numbered);
    dev.handshake(20, PROTOCOL_VERSION).await;
    dev.reading(20, 0, 100).await;
    assert_eq!(dev.ack().await, (20, 0));
    dev.reading(20, 1, 200).await;
    assert_eq!(dev.ack().await, (20, 1));
    // Power cycle: a new boot id, numbering from 0 again.
    dev.send(DeviceMsg::Hello(hello(21, PROTOCOL_VERSION)))
        .await;
    let ev = wait_for(
        &mut rig.events,
        "connected to the new boot",
        |e| matches!(e, LinkEvent::Connected(h) if h.boot_id == 21),
    )
    .await;
    assert!(matches!(ev, LinkEvent::Connected(_)));
    dev.reading(21, 0, 300).await;
    assert_eq!(dev.ack().await, (21, 0));
    // A stale retransmission from the old boot is not taken for the new one.
    dev.reading(20, 1, 200).await;
    assert_eq!(dev.ack_within(QUIET).await, None);
    assert_eq!(
        values(&rig.store, rig.session),
        vec![
            ("reading-1".into(), 0, 100),
            ("reading-2".into(), 1, 200),
            ("reading-3".into(), 0, 300)
        ]
    );
}

#[tokio::test]
async fn a_silent_device_is_pinged_then_dropped_and_reopened() {
    let port = Port::new();
    let mut dev = port.plug();
    let data = tempfile::tempdir().unwrap();
    let sessions = Sessions::open(data.path()).unwrap();
    let config = LinkConfig {
        reconnect_poll: Duration::from_millis(50),
        silence_timeout: Duration::from_millis(300),
        ..LinkConfig::default()
    };
    let (_link, mut events, _task) = Link::spawn(&port.path, config, sessions);
    dev.handshake(1, PROTOCOL_VERSION).await;
    // The device goes quiet: the link pings it...
    let deadline = tokio::time::Instant::now() + WAIT;
    loop {
        let left = deadline.saturating_duration_since(tokio::time::Instant::now());
        match dev.recv_within(left).await.expect("no ping") {
            HostMsg::Ping { .. } => break,
            _ => continue,
        }
    }
    // ...then, still silent, gives the connection up and opens the port again.
    let ev = wait_for(&mut events, "disconnected", |e| {
        matches!(e, LinkEvent::Disconnected { .. })
    })
    .await;
    let LinkEvent::Disconnected { reason, .. } = ev else {
        unreachable!()
    };
    assert!(reason.to_string().contains("no data"), "{reason}");
    wait_for(&mut events, "reopened", |e| {
        matches!(e, LinkEvent::PortOpened { .. })
    })
    .await;
    assert!(matches!(dev.recv().await, HostMsg::Hello(_)));
}

#[tokio::test]
async fn a_second_station_cannot_take_the_port() {
    let port = Port::new();
    let _dev = port.plug();
    let mut first = rig(&port.path);
    wait_for(&mut first.events, "first opened", |e| {
        matches!(e, LinkEvent::PortOpened { .. })
    })
    .await;
    let mut second = rig(&port.path);
    let ev = wait_for(&mut second.events, "second refused", |e| {
        matches!(
            e,
            LinkEvent::WaitingForPort { .. } | LinkEvent::PortOpened { .. }
        )
    })
    .await;
    assert!(
        matches!(ev, LinkEvent::WaitingForPort { .. }),
        "second link opened a port in use: {ev:?}"
    );
}

#[tokio::test]
async fn a_closed_session_refuses_readings_until_reopened() {
    let port = Port::new();
    let mut dev = port.plug();
    let mut rig = rig(&port.path);
    rig.link.set_session(Some(rig.session));
    rig.link.set_naming(Naming::Numbered);
    dev.handshake(4, PROTOCOL_VERSION).await;
    // Another process closes the session while the station runs.
    rig.sessions
        .set_status(rig.session, tapeshape::store::SessionStatus::Done)
        .unwrap();
    for _ in 0..3 {
        dev.reading(4, 0, 700).await; // the device's retransmissions
    }
    let ev = wait_for(&mut rig.events, "commit failed", |e| {
        matches!(e, LinkEvent::CommitFailed { .. })
    })
    .await;
    let LinkEvent::CommitFailed { error, .. } = ev else {
        unreachable!()
    };
    assert!(error.to_string().contains("done"), "{error}");
    assert_eq!(dev.ack_within(QUIET).await, None);
    // Reported once, not once per retransmission.
    while let Ok(ev) = rig.events.try_recv() {
        assert!(!matches!(ev, LinkEvent::CommitFailed { .. }), "{ev:?}");
    }
    rig.sessions
        .set_status(rig.session, tapeshape::store::SessionStatus::Open)
        .unwrap();
    dev.reading(4, 0, 700).await;
    assert_eq!(dev.ack().await, (4, 0));
    assert_eq!(
        values(&rig.store, rig.session),
        vec![("reading-1".into(), 0, 700)]
    );
}
