//! Device logic with a fake clock and in-memory bytes: handshake, numbering, retransmission,
//! cumulative and duplicate acknowledgements, queue-full without silent loss, ping, live rate
//! limit, tape silence, rejected lines; and a property test with a lossy, corrupting link
//! and a host that follows the wire rules, which must end up with every confirmed reading,
//! in order, exactly once.

use proptest::prelude::*;
use tapeshape_firmware::tape::{format_line, Kind, HEARTBEAT_LINE};
use tapeshape_firmware::{Config, Device, QUEUE_CAPACITY};
use tapeshape_protocol::*;

const BOOT: u32 = 0x5EED_0001;

fn frame(msg: &HostMsg) -> Vec<u8> {
    let mut buf = [0u8; MAX_FRAME];
    encode(msg, &mut buf).unwrap().to_vec()
}

fn host_hello_v(major: u8) -> Vec<u8> {
    frame(&HostMsg::Hello(HostHello {
        protocol: ProtocolVersion { major, minor: 3 },
        software: SoftwareVersion {
            major: 0,
            minor: 1,
            patch: 0,
        },
    }))
}

fn host_hello() -> Vec<u8> {
    host_hello_v(PROTOCOL_VERSION.major)
}

fn ack(seq: u32) -> Vec<u8> {
    frame(&HostMsg::Ack { boot_id: BOOT, seq })
}

fn confirmed(v: u32) -> [u8; 20] {
    format_line(v, Kind::Confirmed, UnitShown::Metric).unwrap()
}

fn live(v: u32) -> [u8; 20] {
    format_line(v, Kind::Live, UnitShown::Metric).unwrap()
}

/// A device with periodic status and hello off (so tests see only what they provoke) and
/// tape silence far away.
fn quiet_config() -> Config {
    let mut c = Config::new(0xD1, BOOT);
    c.status_interval_ms = 0;
    c.hello_interval_ms = 1_000_000;
    c.tape_silent_ms = 1_000_000;
    c
}

fn drain(dev: &mut Device, now: u64) -> Vec<DeviceMsg> {
    let mut out = Vec::new();
    while let Some(m) = dev.poll(now) {
        out.push(m);
        assert!(out.len() < 1000, "poll never ends");
    }
    // Every message must also encode as a frame.
    for m in &out {
        let mut buf = [0u8; MAX_FRAME];
        encode(m, &mut buf).unwrap();
    }
    out
}

fn seqs(msgs: &[DeviceMsg]) -> Vec<u32> {
    msgs.iter()
        .filter_map(|m| match m {
            DeviceMsg::Reading(r) => Some(r.seq),
            _ => None,
        })
        .collect()
}

/// A booted device that has done the handshake at t = 0; its hellos drained.
fn linked() -> Device {
    let mut d = Device::new(quiet_config(), 0);
    d.feed_host(&host_hello(), 0);
    let out = drain(&mut d, 0);
    assert!(
        out.iter().all(|m| matches!(m, DeviceMsg::Hello(_))),
        "{out:?}"
    );
    assert!(d.host_seen());
    d
}

#[test]
fn hello_at_boot_repeats_until_host_hello_then_answers_each() {
    let mut c = quiet_config();
    c.hello_interval_ms = 1000;
    let mut d = Device::new(c, 0);
    match drain(&mut d, 0).as_slice() {
        [DeviceMsg::Hello(h)] => {
            assert_eq!(h.protocol, PROTOCOL_VERSION);
            assert_eq!(h.device_id, 0xD1);
            assert_eq!(h.boot_id, BOOT);
            assert_eq!(h.queue_capacity as usize, QUEUE_CAPACITY);
        }
        other => panic!("{other:?}"),
    }
    assert!(drain(&mut d, 999).is_empty());
    assert!(matches!(drain(&mut d, 1000)[..], [DeviceMsg::Hello(_)]));
    d.feed_host(&host_hello(), 1500);
    assert!(matches!(drain(&mut d, 1500)[..], [DeviceMsg::Hello(_)]));
    // No more unsolicited hellos once the host is known.
    assert!(drain(&mut d, 10_000).is_empty());
    // But every host hello is answered.
    d.feed_host(&host_hello(), 10_001);
    assert!(matches!(drain(&mut d, 10_001)[..], [DeviceMsg::Hello(_)]));
}

#[test]
fn readings_wait_for_the_handshake_and_are_numbered_from_zero() {
    let mut d = Device::new(quiet_config(), 0);
    drain(&mut d, 0);
    d.feed_tape(&confirmed(8520), 10);
    d.feed_tape(&confirmed(4410), 20);
    assert!(
        seqs(&drain(&mut d, 30)).is_empty(),
        "no readings before host hello"
    );
    assert_eq!(d.queue_len(), 2);
    d.feed_host(&host_hello(), 40);
    let out = drain(&mut d, 40);
    assert!(matches!(out[0], DeviceMsg::Hello(_)));
    let readings: Vec<_> = out
        .iter()
        .filter_map(|m| match m {
            DeviceMsg::Reading(r) => Some(*r),
            _ => None,
        })
        .collect();
    assert_eq!(
        readings,
        [
            Reading {
                boot_id: BOOT,
                seq: 0,
                value_tenth_mm: 8520,
                timestamp_ms: 10,
                unit_shown: UnitShown::Metric
            },
            Reading {
                boot_id: BOOT,
                seq: 1,
                value_tenth_mm: 4410,
                timestamp_ms: 20,
                unit_shown: UnitShown::Metric
            },
        ]
    );
}

#[test]
fn version_mismatch_is_reported_and_blocks_readings() {
    let mut d = Device::new(quiet_config(), 0);
    drain(&mut d, 0);
    d.feed_tape(&confirmed(1000), 1);
    d.feed_host(&host_hello_v(PROTOCOL_VERSION.major + 1), 2);
    let out = drain(&mut d, 2);
    assert!(matches!(out[0], DeviceMsg::Hello(_)));
    assert_eq!(
        out[1],
        DeviceMsg::Fault(Fault::VersionMismatch {
            host: ProtocolVersion {
                major: PROTOCOL_VERSION.major + 1,
                minor: 3
            },
            device: PROTOCOL_VERSION,
        })
    );
    assert!(seqs(&out).is_empty());
    assert!(!d.host_seen());
    assert!(seqs(&drain(&mut d, 5000)).is_empty());
    // A compatible host afterwards gets the reading.
    d.feed_host(&host_hello(), 6000);
    assert_eq!(seqs(&drain(&mut d, 6000)), [0]);
}

#[test]
fn retransmits_all_unacked_oldest_first_until_acked() {
    let mut d = linked();
    d.feed_tape(&confirmed(1000), 100);
    d.feed_tape(&confirmed(2000), 100);
    d.feed_tape(&confirmed(3000), 100);
    assert_eq!(seqs(&drain(&mut d, 100)), [0, 1, 2]);
    assert_eq!(d.next_deadline(), 400, "retransmit 300 ms after the round");
    assert!(drain(&mut d, 399).is_empty());
    assert_eq!(seqs(&drain(&mut d, 400)), [0, 1, 2]);
    assert_eq!(seqs(&drain(&mut d, 700)), [0, 1, 2]);
    // Ack 0: the next round starts at 1, 300 ms after the ack.
    d.feed_host(&ack(0), 750);
    assert!(drain(&mut d, 1049).is_empty());
    assert_eq!(seqs(&drain(&mut d, 1050)), [1, 2]);
    // Cumulative: ack 2 acknowledges 1 as well.
    d.feed_host(&ack(2), 1100);
    assert_eq!(d.queue_len(), 0);
    assert!(drain(&mut d, 100_000).is_empty());
    // Only the (distant) tape-silence timer is left.
    assert_eq!(d.next_deadline(), 100 + 1_000_000);
}

#[test]
fn a_new_reading_goes_out_at_once_and_joins_the_round() {
    let mut d = linked();
    d.feed_tape(&confirmed(1000), 0);
    assert_eq!(seqs(&drain(&mut d, 0)), [0]);
    d.feed_tape(&confirmed(2000), 100);
    assert_eq!(seqs(&drain(&mut d, 100)), [1]);
    assert_eq!(seqs(&drain(&mut d, 400)), [0, 1]);
}

#[test]
fn a_lost_reading_is_resent_even_while_the_tape_keeps_confirming() {
    // The tape confirms every 100 ms, faster than the 300 ms retransmission
    // interval, and the host acknowledges nothing (reading 0 was lost). The
    // oldest reading must still go out again 300 ms after it was sent: new
    // readings must not keep pushing the timer away.
    let mut d = linked();
    let mut resent_at = None;
    for i in 0..10u32 {
        let t = u64::from(i) * 100;
        d.feed_tape(&confirmed(1000 + 10 * i), t);
        let s = seqs(&drain(&mut d, t));
        if i > 0 && s.contains(&0) {
            resent_at = Some(t);
            break;
        }
    }
    assert_eq!(
        resent_at,
        Some(300),
        "reading 0 was not resent 300 ms after it was sent"
    );
}

#[test]
fn duplicate_stale_and_future_acks_change_nothing() {
    let mut d = linked();
    for v in [1000, 2000, 3000] {
        d.feed_tape(&confirmed(v), 0);
    }
    drain(&mut d, 0);
    d.feed_host(&ack(0), 10);
    d.feed_host(&ack(0), 11); // duplicate
    assert_eq!(d.queue_len(), 2);
    assert_eq!(
        d.status(11).acks_ignored,
        0,
        "a duplicate ack is normal, not an error"
    );
    // Another boot's ack.
    d.feed_host(
        &frame(&HostMsg::Ack {
            boot_id: BOOT ^ 1,
            seq: 2,
        }),
        12,
    );
    // An ack for a reading never sent.
    d.feed_host(&ack(3), 13);
    assert_eq!(d.queue_len(), 2);
    assert_eq!(d.status(13).acks_ignored, 2);
    assert_eq!(
        d.unacked().map(|r| r.seq).collect::<Vec<_>>(),
        [1, 2],
        "nothing dropped by bad acks"
    );
}

#[test]
fn full_queue_refuses_and_reports_without_losing_accepted_readings() {
    let mut d = linked();
    let n = QUEUE_CAPACITY as u32;
    for i in 0..n {
        d.feed_tape(&confirmed(1000 + i), u64::from(i) * 1000);
    }
    assert!(d.queue_full());
    drain(&mut d, u64::from(n) * 1000);
    // One more confirmed value: refused, reported with its value, not numbered.
    d.feed_tape(&confirmed(7777), 50_000);
    let out = drain(&mut d, 50_000);
    assert!(
        out.contains(&DeviceMsg::Fault(Fault::QueueFull {
            capacity: QUEUE_CAPACITY as u16,
            refused_value_tenth_mm: 7777,
            refused_total: 1,
        })),
        "{out:?}"
    );
    let st = d.status(50_000);
    assert_eq!(st.readings_refused, 1);
    assert_eq!(st.next_seq, n, "the refused value got no sequence number");
    assert_eq!(d.queue_len(), QUEUE_CAPACITY);
    // Every accepted reading is still there, in order.
    let held: Vec<_> = d.unacked().map(|r| (r.seq, r.value_tenth_mm)).collect();
    let want: Vec<_> = (0..n).map(|i| (i, 1000 + i)).collect();
    assert_eq!(held, want);
    // The host acknowledges some: recovery is reported and the next reading is numbered on.
    d.feed_host(&ack(4), 51_000);
    let out = drain(&mut d, 51_000);
    assert!(
        out.contains(&DeviceMsg::Fault(Fault::QueueRecovered {
            queue_len: QUEUE_CAPACITY as u16 - 5
        })),
        "{out:?}"
    );
    d.feed_tape(&confirmed(7777), 52_000);
    let out = drain(&mut d, 52_000);
    let last = out.iter().rev().find_map(|m| match m {
        DeviceMsg::Reading(r) => Some(*r),
        _ => None,
    });
    assert_eq!(last.map(|r| (r.seq, r.value_tenth_mm)), Some((n, 7777)));
}

#[test]
fn ping_pong_and_status_on_request() {
    let mut d = linked();
    d.feed_host(&frame(&HostMsg::Ping { nonce: 0xABCD }), 5);
    d.feed_host(&frame(&HostMsg::GetStatus), 6);
    let out = drain(&mut d, 7);
    assert_eq!(out[0], DeviceMsg::Pong { nonce: 0xABCD });
    match out[1] {
        DeviceMsg::Status(s) => {
            assert_eq!(s.boot_id, BOOT);
            assert_eq!(s.uptime_ms, 7);
            assert!(s.host_seen);
            assert_eq!(s.queue_capacity as usize, QUEUE_CAPACITY);
        }
        ref other => panic!("{other:?}"),
    }
}

#[test]
fn periodic_status() {
    let mut c = quiet_config();
    c.status_interval_ms = 1000;
    let mut d = Device::new(c, 0);
    drain(&mut d, 0);
    assert!(drain(&mut d, 999).is_empty());
    let out = drain(&mut d, 1000);
    assert!(matches!(out[..], [DeviceMsg::Status(_)]), "{out:?}");
    assert!(drain(&mut d, 1999).is_empty());
    assert_eq!(drain(&mut d, 2000).len(), 1);
}

#[test]
fn live_values_only_on_change_and_at_most_every_100_ms() {
    let mut d = linked();
    let mut sent = Vec::new();
    // The tape streams a new value every 10 ms for one second.
    for i in 0..100u64 {
        let t = 1000 + i * 10;
        d.feed_tape(&live(5000 + i as u32), t);
        for m in drain(&mut d, t) {
            if let DeviceMsg::Live(l) = m {
                sent.push((t, l.value_tenth_mm));
            }
        }
    }
    // Then it stays on the last value.
    for i in 0..50u64 {
        let t = 2000 + i * 10;
        d.feed_tape(&live(5099), t);
        for m in drain(&mut d, t) {
            if let DeviceMsg::Live(l) = m {
                sent.push((t, l.value_tenth_mm));
            }
        }
    }
    assert!(sent.len() >= 10 && sent.len() <= 11, "{sent:?}");
    for w in sent.windows(2) {
        assert!(w[1].0 - w[0].0 >= 100, "{sent:?}");
        assert_ne!(w[1].1, w[0].1, "only changes are sent");
    }
    assert_eq!(
        sent.last().unwrap().1,
        5099,
        "the final value always goes out"
    );
}

#[test]
fn tape_silence_is_reported_once_and_recovery_too() {
    let mut c = quiet_config();
    c.tape_silent_ms = 5000;
    let mut d = Device::new(c, 0);
    drain(&mut d, 0);
    d.feed_tape(&HEARTBEAT_LINE, 1000);
    assert_eq!(d.next_deadline(), 6000);
    assert!(drain(&mut d, 5999).is_empty());
    assert_eq!(
        drain(&mut d, 6000),
        [DeviceMsg::Fault(Fault::TapeSilent { silent_ms: 5000 })]
    );
    assert!(d.tape_silent());
    assert!(drain(&mut d, 20_000).is_empty(), "reported once");
    d.feed_tape(&HEARTBEAT_LINE, 21_000);
    assert_eq!(
        drain(&mut d, 21_000),
        [DeviceMsg::Fault(Fault::TapeRecovered)]
    );
    let st = d.status(21_000);
    assert!(!st.tape_silent);
    assert_eq!((st.lines_ok, st.heartbeats), (2, 2));
    // Garbage does not count as the tape being alive.
    d.feed_tape(b"garbage\n", 25_000);
    drain(&mut d, 25_000);
    let out = drain(&mut d, 26_000);
    assert_eq!(
        out,
        [DeviceMsg::Fault(Fault::TapeSilent { silent_ms: 5000 })]
    );
}

#[test]
fn rejected_lines_are_counted_reported_and_never_readings() {
    let mut d = linked();
    let stream: &[u8] = b"*99999;00000;0000SM\n*-0100;00000;0000SM\n*01x00;00000;0000SM\n\
        *0100\n\x01\x02\x03\n*01000;00000;0000SM0000000\n";
    d.feed_tape(stream, 10);
    let out = drain(&mut d, 10);
    assert!(seqs(&out).is_empty(), "{out:?}");
    assert_eq!(d.queue_len(), 0);
    // Bursts are coalesced into one report carrying the running total.
    let faults: Vec<_> = out
        .iter()
        .filter_map(|m| match m {
            DeviceMsg::Fault(Fault::LineRejected {
                reason,
                rejected_total,
            }) => Some((*reason, *rejected_total)),
            _ => None,
        })
        .collect();
    assert_eq!(faults, [(RejectReason::Overlong, 6)]);
    let st = d.status(10);
    assert_eq!(
        st.rejected,
        RejectCounts {
            garbage: 1,
            partial: 1,
            overlong: 1,
            bad_field: 1,
            impossible: 2
        }
    );
    assert_eq!(st.lines_ok, 0);
    // Line by line, each is reported.
    d.feed_tape(b"*30001;00000;0000SM\n", 20);
    assert_eq!(
        drain(&mut d, 20),
        [DeviceMsg::Fault(Fault::LineRejected {
            reason: RejectReason::OutOfRange {
                value_tenth_mm: 30001
            },
            rejected_total: 7
        })]
    );
}

#[test]
fn bad_host_frames_are_counted_and_reported() {
    let mut d = linked();
    let mut f = frame(&HostMsg::Ping { nonce: 1 });
    f[1] ^= 0x40;
    d.feed_host(&f, 1);
    d.feed_host(&[0x55; 300], 2);
    d.feed_host(&[0], 3);
    let out = drain(&mut d, 3);
    assert_eq!(out, [DeviceMsg::Fault(Fault::HostFrameBad { total: 2 })]);
    assert_eq!(d.status(3).host_frames_bad, 2);
    // The link still works.
    d.feed_host(&frame(&HostMsg::Ping { nonce: 2 }), 4);
    assert_eq!(drain(&mut d, 4), [DeviceMsg::Pong { nonce: 2 }]);
}

#[test]
fn repeated_confirm_lines_within_the_window_are_one_reading() {
    let mut d = linked();
    d.feed_tape(&confirmed(8520), 1000);
    d.feed_tape(&confirmed(8520), 1100);
    d.feed_tape(&confirmed(8520), 1350); // 250 ms after the previous repeat: still the same
    assert_eq!(d.queue_len(), 1);
    assert_eq!(d.status(1350).confirm_repeats, 2);
    d.feed_tape(&confirmed(8520), 2000); // a new press of the same value
    d.feed_tape(&confirmed(8530), 2010); // a different value at once
    assert_eq!(d.queue_len(), 3);
}

#[test]
fn host_restart_hello_resends_everything_unacked_at_once() {
    let mut d = linked();
    d.feed_tape(&confirmed(1000), 0);
    d.feed_tape(&confirmed(2000), 0);
    drain(&mut d, 0);
    d.feed_host(&ack(0), 10);
    d.feed_host(&host_hello(), 20);
    let out = drain(&mut d, 20);
    assert!(matches!(out[0], DeviceMsg::Hello(_)));
    assert_eq!(seqs(&out), [1]);
}

#[test]
fn buttons_are_forwarded() {
    let mut d = linked();
    d.press_button(ButtonKind::Redo, 3);
    assert_eq!(
        drain(&mut d, 3),
        [DeviceMsg::Button {
            kind: ButtonKind::Redo
        }]
    );
}

#[test]
fn poll_frame_encodes_what_poll_would_return() {
    let mut d = Device::new(quiet_config(), 0);
    let mut buf = [0u8; MAX_FRAME];
    let f = d.poll_frame(0, &mut buf).unwrap().to_vec();
    let mut dec = FrameDecoder::<DeviceMsg>::new();
    let got: Vec<_> = dec.feed(&f).collect();
    assert!(matches!(got[..], [Ok(DeviceMsg::Hello(_))]));
    assert!(d.poll_frame(0, &mut buf).is_none());
}

/// What happens on the simulated link in one step.
#[derive(Debug, Clone)]
enum Step {
    /// The operator confirms a value on the tape.
    Confirm(u32),
    /// The tape streams a live value.
    Live(u32),
    /// Line noise on the tape UART.
    TapeNoise(Vec<u8>),
    /// Time passes, ms.
    Wait(u16),
    /// The host restarts (forgets nothing it committed, says hello again).
    HostHello,
}

fn step() -> impl Strategy<Value = Step> {
    prop_oneof![
        2 => (1u32..=30_000).prop_map(Step::Confirm),
        2 => (0u32..=30_000).prop_map(Step::Live),
        1 => prop::collection::vec(any::<u8>(), 1..40).prop_map(Step::TapeNoise),
        4 => (1u16..700).prop_map(Step::Wait),
        1 => Just(Step::HostHello),
    ]
}

/// A host following docs/wire-format.md: commit in order, then ack; re-ack duplicates;
/// ignore gaps; restart at 0 on a new boot id.
#[derive(Default)]
struct ModelHost {
    committed: Vec<u32>,
    expected: u32,
    boot: Option<u32>,
    greeted: bool,
}

impl ModelHost {
    fn on(&mut self, msg: DeviceMsg) -> Option<HostMsg> {
        if let DeviceMsg::Hello(_) = msg {
            self.greeted = true;
        }
        let DeviceMsg::Reading(r) = msg else {
            return None;
        };
        if self.boot != Some(r.boot_id) {
            self.boot = Some(r.boot_id);
            self.expected = 0;
        }
        if r.seq == self.expected {
            self.committed.push(r.value_tenth_mm);
            self.expected += 1;
            Some(HostMsg::Ack {
                boot_id: r.boot_id,
                seq: r.seq,
            })
        } else if r.seq < self.expected {
            Some(HostMsg::Ack {
                boot_id: r.boot_id,
                seq: self.expected - 1,
            })
        } else {
            None
        }
    }
}

/// Damages a frame the way a noisy link would: drop it, flip a byte, or cut it short.
fn damage(frame: &[u8], how: u8, at: usize) -> Vec<u8> {
    let mut f = frame.to_vec();
    match how % 8 {
        0 => Vec::new(),
        1 => {
            let i = at % (f.len() - 1);
            f[i] ^= 0x5A;
            f
        }
        2 => {
            f.truncate(at % f.len());
            f
        }
        _ => f,
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(300))]

    /// Whatever the tape does, and however the link drops, corrupts or cuts frames in both
    /// directions, once the link is clean the host has every confirmed reading exactly
    /// once and in order.
    #[test]
    fn lossy_link_loses_nothing(
        steps in prop::collection::vec(step(), 1..80),
        damage_down in prop::collection::vec((any::<u8>(), any::<usize>()), 64),
        damage_up in prop::collection::vec((any::<u8>(), any::<usize>()), 64),
    ) {
        let mut cfg = Config::new(9, BOOT);
        cfg.confirm_repeat_ms = 0; // every confirm line is a new reading in this test
        cfg.tape_silent_ms = 2_000;
        let mut d = Device::new(cfg, 0);
        let mut host = ModelHost::default();
        let mut dec = FrameDecoder::<DeviceMsg>::new();
        let mut now = 0u64;
        let mut confirmed_values = Vec::new();
        let mut k = 0usize;
        let mut buf = [0u8; MAX_FRAME];
        d.feed_host(&damage(&host_hello(), damage_up[0].0, damage_up[0].1), 0);

        let mut exchange = |d: &mut Device, now: u64, k: &mut usize, clean: bool, host: &mut ModelHost| {
            while let Some(f) = d.poll_frame(now, &mut buf) {
                let (how, at) = damage_down[*k % damage_down.len()];
                *k += 1;
                let f = if clean { f.to_vec() } else { damage(f, how, at) };
                let replies: Vec<_> = dec.feed(&f).filter_map(|r| r.ok()).filter_map(|m| host.on(m)).collect();
                for reply in replies {
                    let (how, at) = damage_up[*k % damage_up.len()];
                    let bytes = frame(&reply);
                    let bytes = if clean { bytes } else { damage(&bytes, how, at) };
                    d.feed_host(&bytes, now);
                }
            }
            // Drained: the next timer lies in the future, so the run loop sleeps instead of
            // spinning.
            assert!(d.next_deadline() > now, "deadline {} at {now}", d.next_deadline());
        };

        for s in &steps {
            match s {
                Step::Confirm(v) => {
                    if d.queue_len() < QUEUE_CAPACITY {
                        confirmed_values.push(*v);
                    }
                    d.feed_tape(&confirmed(*v), now);
                }
                Step::Live(v) => d.feed_tape(&live(*v), now),
                Step::TapeNoise(b) => {
                    d.feed_tape(b, now);
                    d.feed_tape(b"\n", now);
                }
                Step::Wait(ms) => now += u64::from(*ms),
                Step::HostHello => {
                    let (how, at) = damage_up[k % damage_up.len()];
                    d.feed_host(&damage(&host_hello(), how, at), now);
                }
            }
            exchange(&mut d, now, &mut k, false, &mut host);
        }
        // The link becomes clean; the host says hello until it gets a hello back (the host
        // rule: a hello may have been lost, or joined to the junk of a cut frame), and time
        // passes.
        host.greeted = false;
        for _ in 0..6 {
            if !host.greeted {
                d.feed_host(&host_hello(), now);
            }
            exchange(&mut d, now, &mut k, true, &mut host);
            now += 400;
        }
        prop_assert_eq!(d.queue_len(), 0, "everything acknowledged");
        prop_assert_eq!(&host.committed, &confirmed_values);
        prop_assert_eq!(d.status(now).readings_refused as usize,
            steps.iter().filter(|s| matches!(s, Step::Confirm(_))).count() - confirmed_values.len());
    }

    /// Random host bytes never panic the device, and a good frame after a delimiter is
    /// always understood.
    #[test]
    fn random_host_bytes_never_panic(junk in prop::collection::vec(any::<u8>(), 0..500), nonce in any::<u32>()) {
        let mut d = linked();
        d.feed_host(&junk, 1);
        let _ = drain(&mut d, 1);
        let mut f = vec![0u8];
        f.extend(frame(&HostMsg::Ping { nonce }));
        d.feed_host(&f, 2);
        let out = drain(&mut d, 2);
        prop_assert!(out.contains(&DeviceMsg::Pong { nonce }), "{:?}", out);
    }
}

#[test]
fn a_clock_at_the_end_of_its_range_does_not_panic() {
    let start = u64::MAX - 10;
    let mut d = Device::new(Config::new(1, BOOT), start);
    d.feed_host(&host_hello(), start);
    d.feed_tape(&confirmed(1234), start + 5);
    d.feed_tape(&live(1000), start + 5);
    let out = drain(&mut d, u64::MAX);
    assert_eq!(seqs(&out), [0]);
    assert!(d.next_deadline() >= start);
    // A clock that jumps backwards is treated as standing still.
    let _ = drain(&mut d, 0);
    assert_eq!(d.status(u64::MAX).uptime_ms, 10);
}

#[test]
fn a_ping_flood_overflows_the_outbox_counted_not_silently() {
    let mut d = linked();
    let mut flood = Vec::new();
    for nonce in 0..40 {
        flood.extend(frame(&HostMsg::Ping { nonce }));
    }
    d.feed_host(&flood, 1);
    let pongs: Vec<u32> = drain(&mut d, 1)
        .into_iter()
        .filter_map(|m| match m {
            DeviceMsg::Pong { nonce } => Some(nonce),
            _ => None,
        })
        .collect();
    // The first ones are answered in order; every unanswered one is counted.
    assert!(!pongs.is_empty());
    assert_eq!(pongs, (0..pongs.len() as u32).collect::<Vec<_>>());
    assert_eq!(d.status(1).reports_dropped as usize, 40 - pongs.len());
}

#[test]
fn io_errors_reported_by_the_board_are_counted() {
    let mut d = linked();
    d.tape_io_error();
    d.tape_io_error();
    d.host_io_error();
    let st = d.status(0);
    assert_eq!((st.tape_io_errors, st.host_io_errors), (2, 1));
}
