//! Fixed wire vectors: one committed byte string per message kind, in
//! `tests/vectors/frames.txt`. Each is decoded and compared with the value this
//! file expects, then that value is encoded again and must give the very same
//! bytes: postcard body first, then the whole frame.
//!
//! Why: the round-trip properties in `props.rs` pass for any field order, so a
//! reordered, retyped or inserted field, or a variant moved within its enum,
//! would pass them and still break every tape station already deployed. These
//! vectors fail first. A failing vector means the wire format changed: that is
//! a major protocol version (`docs/wire-format.md`, "Versioning rule"), not a
//! file to regenerate.
//!
//! Field values are all different from each other (and most take several
//! varint bytes), so that exchanging any two fields of a message changes its
//! bytes.

use std::collections::BTreeMap;

use tapeshape_protocol::*;

/// Which message kind a value is; the matches are exhaustive, so a new
/// variant does not compile until it is named here (and given a vector).
fn device_kind(m: &DeviceMsg) -> String {
    let fault = |f: &Fault| -> String {
        match f {
            Fault::QueueFull { .. } => "queue_full".into(),
            Fault::QueueRecovered { .. } => "queue_recovered".into(),
            Fault::TapeSilent { .. } => "tape_silent".into(),
            Fault::TapeRecovered => "tape_recovered".into(),
            Fault::LineRejected { reason, .. } => format!(
                "line_rejected.{}",
                match reason {
                    RejectReason::Garbage => "garbage",
                    RejectReason::Partial { .. } => "partial",
                    RejectReason::Overlong => "overlong",
                    RejectReason::BadField { .. } => "bad_field",
                    RejectReason::Negative => "negative",
                    RejectReason::OutOfRange { .. } => "out_of_range",
                }
            ),
            Fault::VersionMismatch { .. } => "version_mismatch".into(),
            Fault::HostFrameBad { .. } => "host_frame_bad".into(),
        }
    };
    let unit = |u: &UnitShown| match u {
        UnitShown::Metric => "metric",
        UnitShown::Imperial => "imperial",
    };
    match m {
        DeviceMsg::Hello(_) => "device.hello".into(),
        DeviceMsg::Live(l) => format!("device.live.{}", unit(&l.unit_shown)),
        DeviceMsg::Reading(r) => format!("device.reading.{}", unit(&r.unit_shown)),
        DeviceMsg::Button { kind } => format!(
            "device.button.{}",
            match kind {
                ButtonKind::Next => "next",
                ButtonKind::Back => "back",
                ButtonKind::Redo => "redo",
            }
        ),
        DeviceMsg::Status(_) => "device.status".into(),
        DeviceMsg::Fault(f) => format!("device.fault.{}", fault(f)),
        DeviceMsg::Pong { .. } => "device.pong".into(),
    }
}

/// See [`device_kind`].
fn host_kind(m: &HostMsg) -> String {
    match m {
        HostMsg::Hello(_) => "host.hello",
        HostMsg::Ack { .. } => "host.ack",
        HostMsg::Ping { .. } => "host.ping",
        HostMsg::GetStatus => "host.get_status",
    }
    .into()
}

/// The values the committed vectors must decode to, device -> host.
fn device_values() -> Vec<DeviceMsg> {
    let mut v = vec![
        DeviceMsg::Hello(DeviceHello {
            protocol: ProtocolVersion { major: 1, minor: 0 },
            firmware: SoftwareVersion {
                major: 2,
                minor: 3,
                patch: 4,
            },
            device_id: 0x4D50_5332_0000_0386,
            boot_id: 0xC0FF_EE42,
            queue_capacity: 32,
        }),
        DeviceMsg::Live(Live {
            value_tenth_mm: 2050,
            unit_shown: UnitShown::Metric,
        }),
        DeviceMsg::Live(Live {
            value_tenth_mm: 12_345,
            unit_shown: UnitShown::Imperial,
        }),
        DeviceMsg::Reading(Reading {
            boot_id: 0x1234_5678,
            seq: 300,
            value_tenth_mm: 8520,
            timestamp_ms: 123_456_789,
            unit_shown: UnitShown::Metric,
        }),
        DeviceMsg::Reading(Reading {
            boot_id: 0x0BAD_F00D,
            seq: 0,
            value_tenth_mm: 30_000,
            timestamp_ms: 1_700_000_000_123,
            unit_shown: UnitShown::Imperial,
        }),
        DeviceMsg::Button {
            kind: ButtonKind::Next,
        },
        DeviceMsg::Button {
            kind: ButtonKind::Back,
        },
        DeviceMsg::Button {
            kind: ButtonKind::Redo,
        },
        DeviceMsg::Status(Status {
            boot_id: 0x0102_0304,
            uptime_ms: 3_600_123,
            queue_len: 3,
            queue_capacity: 32,
            next_seq: 41,
            host_seen: true,
            tape_silent: false,
            lines_ok: 1000,
            heartbeats: 120,
            rejected: RejectCounts {
                garbage: 1,
                partial: 2,
                overlong: 4,
                bad_field: 5,
                impossible: 6,
            },
            readings_refused: 7,
            confirm_repeats: 8,
            host_frames_bad: 9,
            acks_ignored: 10,
            tape_io_errors: 11,
            host_io_errors: 12,
            reports_dropped: 13,
        }),
        DeviceMsg::Fault(Fault::QueueFull {
            capacity: 32,
            refused_value_tenth_mm: 8520,
            refused_total: 3,
        }),
        DeviceMsg::Fault(Fault::QueueRecovered { queue_len: 31 }),
        DeviceMsg::Fault(Fault::TapeSilent { silent_ms: 5001 }),
        DeviceMsg::Fault(Fault::TapeRecovered),
    ];
    for (reason, total) in [
        (RejectReason::Garbage, 1),
        (RejectReason::Partial { len: 5 }, 2),
        (RejectReason::Overlong, 3),
        (RejectReason::BadField { field: 4 }, 200),
        (RejectReason::Negative, 5),
        (
            RejectReason::OutOfRange {
                value_tenth_mm: 30_001,
            },
            6,
        ),
    ] {
        v.push(DeviceMsg::Fault(Fault::LineRejected {
            reason,
            rejected_total: total,
        }));
    }
    v.extend([
        DeviceMsg::Fault(Fault::VersionMismatch {
            host: ProtocolVersion { major: 2, minor: 1 },
            device: ProtocolVersion { major: 1, minor: 0 },
        }),
        DeviceMsg::Fault(Fault::HostFrameBad { total: 9 }),
        DeviceMsg::Pong { nonce: 0xDEAD_BEEF },
    ]);
    v
}

/// The values the committed vectors must decode to, host -> device.
fn host_values() -> Vec<HostMsg> {
    vec![
        HostMsg::Hello(HostHello {
            protocol: ProtocolVersion { major: 1, minor: 0 },
            software: SoftwareVersion {
                major: 0,
                minor: 1,
                patch: 2,
            },
        }),
        HostMsg::Ack {
            boot_id: 0x1234_5678,
            seq: 300,
        },
        HostMsg::Ping { nonce: 5 },
        HostMsg::GetStatus,
    ]
}

/// A committed vector: the postcard body and the whole frame.
struct Vector {
    body: Vec<u8>,
    frame: Vec<u8>,
}

fn hex(text: &str, what: &str) -> Vec<u8> {
    text.split_whitespace()
        .map(|b| {
            assert_eq!(b.len(), 2, "{what}: {b:?} is not a hex byte");
            u8::from_str_radix(b, 16).unwrap_or_else(|_| panic!("{what}: {b:?} is not hex"))
        })
        .collect()
}

/// Reads `tests/vectors/frames.txt`: `name | body hex | frame hex` per line.
fn vectors() -> BTreeMap<String, Vector> {
    let text = include_str!("vectors/frames.txt");
    let mut out = BTreeMap::new();
    for (i, line) in text.lines().enumerate() {
        let line = line.trim();
        if line.is_empty() || line.starts_with('#') {
            continue;
        }
        let fields: Vec<&str> = line.split('|').map(str::trim).collect();
        let [name, body, frame] = fields[..] else {
            panic!("frames.txt line {}: expected `name | body | frame`", i + 1);
        };
        let v = Vector {
            body: hex(body, name),
            frame: hex(frame, name),
        };
        assert!(
            out.insert(name.to_string(), v).is_none(),
            "frames.txt: {name} twice"
        );
    }
    out
}

fn show(bytes: &[u8]) -> String {
    bytes
        .iter()
        .map(|b| format!("{b:02x}"))
        .collect::<Vec<_>>()
        .join(" ")
}

/// Decode the committed frame -> the expected value -> encode -> the same
/// body and frame.
fn check<T>(name: &str, want: &T, v: &Vector)
where
    T: serde::Serialize + serde::de::DeserializeOwned + PartialEq + std::fmt::Debug,
{
    let mut decoder = FrameDecoder::<T>::new();
    let got: Vec<Result<T, FrameError>> = decoder.feed(&v.frame).collect();
    assert_eq!(
        got.len(),
        1,
        "{name}: the committed frame is not exactly one frame"
    );
    match &got[0] {
        Ok(msg) => assert_eq!(
            msg, want,
            "{name}: the committed frame decodes to another value: the wire format changed"
        ),
        Err(e) => {
            panic!("{name}: the committed frame no longer decodes ({e}): the wire format changed")
        }
    }
    assert_eq!(
        decoder.pending_len(),
        0,
        "{name}: bytes after the delimiter"
    );
    let mut body = [0u8; MAX_PAYLOAD];
    let body = postcard::to_slice(want, &mut body).expect("the body fits");
    assert!(
        body == v.body.as_slice(),
        "{name}: postcard body is now\n  {}\nthe committed vector is\n  {}\n(a field or variant moved: a major protocol change)",
        show(body),
        show(&v.body)
    );
    let mut buf = [0u8; MAX_FRAME];
    let frame = encode(want, &mut buf).expect("the frame fits");
    assert!(
        frame == v.frame.as_slice(),
        "{name}: frame is now\n  {}\nthe committed vector is\n  {}",
        show(frame),
        show(&v.frame)
    );
}

#[test]
fn every_committed_frame_decodes_to_its_value_and_encodes_back_to_the_same_bytes() {
    let vectors = vectors();
    let mut used = Vec::new();
    for msg in device_values() {
        let name = device_kind(&msg);
        let v = vectors
            .get(&name)
            .unwrap_or_else(|| panic!("no committed vector for {name}"));
        check(&name, &msg, v);
        used.push(name);
    }
    for msg in host_values() {
        let name = host_kind(&msg);
        let v = vectors
            .get(&name)
            .unwrap_or_else(|| panic!("no committed vector for {name}"));
        check(&name, &msg, v);
        used.push(name);
    }
    let mut sorted = used.clone();
    sorted.sort();
    sorted.dedup();
    assert_eq!(sorted.len(), used.len(), "two expected values of one kind");
    let unused: Vec<&String> = vectors.keys().filter(|k| !used.contains(k)).collect();
    assert!(
        unused.is_empty(),
        "vectors without an expected value: {unused:?}"
    );
}

#[test]
fn every_variant_index_has_a_vector() {
    // The first body byte is the variant index (postcard); the vectors cover
    // each index of each enum from 0 up without a hole, so a variant inserted
    // in the middle renumbers the ones after it and fails above.
    let vectors = vectors();
    let tags = |prefix: &str, at: usize| -> Vec<u8> {
        let mut t: Vec<u8> = vectors
            .iter()
            .filter(|(k, _)| k.starts_with(prefix))
            .map(|(_, v)| v.body[at])
            .collect();
        t.sort();
        t.dedup();
        t
    };
    assert_eq!(tags("device.", 0), (0..=6).collect::<Vec<u8>>());
    assert_eq!(tags("host.", 0), (0..=3).collect::<Vec<u8>>());
    assert_eq!(tags("device.fault.", 1), (0..=6).collect::<Vec<u8>>());
    assert_eq!(
        tags("device.fault.line_rejected.", 2),
        (0..=5).collect::<Vec<u8>>()
    );
    assert_eq!(tags("device.button.", 1), (0..=2).collect::<Vec<u8>>());
}
