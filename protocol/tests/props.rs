//! Property tests of the wire format: every message round-trips through a frame, and no byte
//! stream (random, corrupted, truncated) panics the decoder or stops it from decoding the
//! next valid frame.

use proptest::prelude::*;
use tapeshape_protocol::*;

fn version() -> impl Strategy<Value = ProtocolVersion> {
    (any::<u8>(), any::<u8>()).prop_map(|(major, minor)| ProtocolVersion { major, minor })
}

fn software() -> impl Strategy<Value = SoftwareVersion> {
    (any::<u8>(), any::<u8>(), any::<u8>()).prop_map(|(major, minor, patch)| SoftwareVersion {
        major,
        minor,
        patch,
    })
}

fn unit() -> impl Strategy<Value = UnitShown> {
    prop_oneof![Just(UnitShown::Metric), Just(UnitShown::Imperial)]
}

fn reason() -> impl Strategy<Value = RejectReason> {
    prop_oneof![
        Just(RejectReason::Garbage),
        any::<u8>().prop_map(|len| RejectReason::Partial { len }),
        Just(RejectReason::Overlong),
        any::<u8>().prop_map(|field| RejectReason::BadField { field }),
        Just(RejectReason::Negative),
        any::<u32>().prop_map(|value_tenth_mm| RejectReason::OutOfRange { value_tenth_mm }),
    ]
}

fn counts() -> impl Strategy<Value = RejectCounts> {
    any::<[u32; 5]>().prop_map(|c| RejectCounts {
        garbage: c[0],
        partial: c[1],
        overlong: c[2],
        bad_field: c[3],
        impossible: c[4],
    })
}

fn status() -> impl Strategy<Value = Status> {
    (
        (
            any::<u32>(),
            any::<u64>(),
            any::<u16>(),
            any::<u16>(),
            any::<u32>(),
        ),
        (
            any::<bool>(),
            any::<bool>(),
            any::<u32>(),
            any::<u32>(),
            counts(),
        ),
        any::<[u32; 7]>(),
    )
        .prop_map(
            |(
                (boot_id, uptime_ms, queue_len, queue_capacity, next_seq),
                (host_seen, tape_silent, lines_ok, heartbeats, rejected),
                c,
            )| Status {
                boot_id,
                uptime_ms,
                queue_len,
                queue_capacity,
                next_seq,
                host_seen,
                tape_silent,
                lines_ok,
                heartbeats,
                rejected,
                readings_refused: c[0],
                confirm_repeats: c[1],
                host_frames_bad: c[2],
                acks_ignored: c[3],
                tape_io_errors: c[4],
                host_io_errors: c[5],
                reports_dropped: c[6],
            },
        )
}

fn fault() -> impl Strategy<Value = Fault> {
    prop_oneof![
        (any::<u16>(), any::<u32>(), any::<u32>()).prop_map(|(capacity, v, t)| {
            Fault::QueueFull {
                capacity,
                refused_value_tenth_mm: v,
                refused_total: t,
            }
        }),
        any::<u16>().prop_map(|queue_len| Fault::QueueRecovered { queue_len }),
        any::<u32>().prop_map(|silent_ms| Fault::TapeSilent { silent_ms }),
        Just(Fault::TapeRecovered),
        (reason(), any::<u32>()).prop_map(|(reason, rejected_total)| Fault::LineRejected {
            reason,
            rejected_total
        }),
        (version(), version()).prop_map(|(host, device)| Fault::VersionMismatch { host, device }),
        any::<u32>().prop_map(|total| Fault::HostFrameBad { total }),
    ]
}

fn device_msg() -> impl Strategy<Value = DeviceMsg> {
    prop_oneof![
        (
            version(),
            software(),
            any::<u64>(),
            any::<u32>(),
            any::<u16>()
        )
            .prop_map(|(protocol, firmware, device_id, boot_id, queue_capacity)| {
                DeviceMsg::Hello(DeviceHello {
                    protocol,
                    firmware,
                    device_id,
                    boot_id,
                    queue_capacity,
                })
            }),
        (any::<u32>(), unit()).prop_map(|(value_tenth_mm, unit_shown)| DeviceMsg::Live(Live {
            value_tenth_mm,
            unit_shown
        })),
        (
            any::<u32>(),
            any::<u32>(),
            any::<u32>(),
            any::<u64>(),
            unit()
        )
            .prop_map(|(boot_id, seq, value_tenth_mm, timestamp_ms, unit_shown)| {
                DeviceMsg::Reading(Reading {
                    boot_id,
                    seq,
                    value_tenth_mm,
                    timestamp_ms,
                    unit_shown,
                })
            }),
        prop_oneof![
            Just(ButtonKind::Next),
            Just(ButtonKind::Back),
            Just(ButtonKind::Redo)
        ]
        .prop_map(|kind| DeviceMsg::Button { kind }),
        status().prop_map(DeviceMsg::Status),
        fault().prop_map(DeviceMsg::Fault),
        any::<u32>().prop_map(|nonce| DeviceMsg::Pong { nonce }),
    ]
}

fn host_msg() -> impl Strategy<Value = HostMsg> {
    prop_oneof![
        (version(), software())
            .prop_map(|(protocol, software)| HostMsg::Hello(HostHello { protocol, software })),
        (any::<u32>(), any::<u32>()).prop_map(|(boot_id, seq)| HostMsg::Ack { boot_id, seq }),
        any::<u32>().prop_map(|nonce| HostMsg::Ping { nonce }),
        Just(HostMsg::GetStatus),
    ]
}

fn frame_of<T: serde::Serialize>(msg: &T) -> Vec<u8> {
    let mut buf = [0u8; MAX_FRAME];
    encode(msg, &mut buf).expect("every message fits").to_vec()
}

fn decode_all<T: serde::de::DeserializeOwned>(
    dec: &mut FrameDecoder<T>,
    bytes: &[u8],
) -> Vec<Result<T, FrameError>> {
    dec.feed(bytes).collect()
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(2000))]

    #[test]
    fn device_msgs_round_trip(msg in device_msg()) {
        let frame = frame_of(&msg);
        prop_assert!(frame.len() <= MAX_FRAME);
        prop_assert_eq!(frame.last(), Some(&0));
        prop_assert!(!frame[..frame.len() - 1].contains(&0), "only the delimiter is zero");
        let mut dec = FrameDecoder::<DeviceMsg>::new();
        prop_assert_eq!(decode_all(&mut dec, &frame), vec![Ok(msg)]);
        // Byte at a time gives the same.
        let mut dec = FrameDecoder::<DeviceMsg>::new();
        let got: Vec<_> = frame.iter().filter_map(|&b| dec.push(b)).collect();
        prop_assert_eq!(got, vec![Ok(msg)]);
    }

    #[test]
    fn host_msgs_round_trip(msg in host_msg()) {
        let frame = frame_of(&msg);
        prop_assert!(frame.len() <= MAX_FRAME);
        let mut dec = FrameDecoder::<HostMsg>::new();
        prop_assert_eq!(decode_all(&mut dec, &frame), vec![Ok(msg)]);
    }

    #[test]
    fn sequences_round_trip_in_order(msgs in prop::collection::vec(device_msg(), 0..20)) {
        let stream: Vec<u8> = msgs.iter().flat_map(frame_of).collect();
        let mut dec = FrameDecoder::<DeviceMsg>::new();
        let expect: Vec<_> = msgs.into_iter().map(Ok).collect();
        prop_assert_eq!(decode_all(&mut dec, &stream), expect);
    }

    /// Where the link splits the byte stream into reads does not matter: feeding it in
    /// random chunks gives exactly what feeding it whole gives, errors included.
    #[test]
    fn chunking_does_not_matter(
        msgs in prop::collection::vec(device_msg(), 1..10),
        junk in prop::collection::vec(any::<u8>(), 0..60),
        cuts in prop::collection::vec(any::<prop::sample::Index>(), 0..12),
    ) {
        let mut stream = junk;
        for m in &msgs {
            stream.extend(frame_of(m));
        }
        let whole = decode_all(&mut FrameDecoder::<DeviceMsg>::new(), &stream);
        let mut points: Vec<usize> = cuts.iter().map(|c| c.index(stream.len() + 1)).collect();
        points.push(0);
        points.push(stream.len());
        points.sort_unstable();
        let mut dec = FrameDecoder::<DeviceMsg>::new();
        let mut pieces = Vec::new();
        for w in points.windows(2) {
            pieces.extend(dec.feed(&stream[w[0]..w[1]]));
        }
        prop_assert_eq!(pieces, whole);
    }

    /// Random bytes never panic either decoder; after them, a delimiter and a valid frame,
    /// the valid frame always decodes (and is the last thing yielded).
    #[test]
    fn recovers_after_random_garbage(
        garbage in prop::collection::vec(any::<u8>(), 0..600),
        msg in device_msg(),
        host in host_msg(),
    ) {
        let mut dec = FrameDecoder::<DeviceMsg>::new();
        let _ = decode_all(&mut dec, &garbage);
        let mut tail = vec![0u8];
        tail.extend(frame_of(&msg));
        let out = decode_all(&mut dec, &tail);
        prop_assert_eq!(out.last(), Some(&Ok(msg)));

        let mut dec = FrameDecoder::<HostMsg>::new();
        let mut stream = garbage.clone();
        stream.push(0);
        stream.extend(frame_of(&host));
        let out = decode_all(&mut dec, &stream);
        prop_assert_eq!(out.last(), Some(&Ok(host)));
    }

    /// A frame corrupted anywhere (a byte changed, dropped or inserted) never panics the
    /// decoder, yields at most two outcomes (a changed byte may become a delimiter and split
    /// the frame), and the next good frame always decodes.
    #[test]
    fn corrupted_frame_then_recovery(
        a in device_msg(),
        b in device_msg(),
        pos in any::<prop::sample::Index>(),
        flip in 1u8..=255,
        mode in 0u8..3,
    ) {
        let good = frame_of(&a);
        let mut bad = good.clone();
        let i = pos.index(bad.len() - 1); // keep the delimiter
        match mode {
            0 => bad[i] ^= flip,
            1 => { bad.remove(i); }
            _ => bad.insert(i, flip),
        }
        let mut stream = bad;
        stream.extend(frame_of(&b));
        let mut dec = FrameDecoder::<DeviceMsg>::new();
        let out = decode_all(&mut dec, &stream);
        prop_assert!(out.len() >= 2 && out.len() <= 3, "{:?}", out);
        prop_assert_eq!(out.last(), Some(&Ok(b)), "the following good frame decodes");
    }

    /// A single flipped bit in a data byte (not a COBS code byte) is always caught by the
    /// CRC (CRC-16 detects every single-bit error): the frame is reported as a CRC error,
    /// never returned as a message.
    #[test]
    fn single_bit_error_is_always_detected(
        a in device_msg(),
        pos in any::<prop::sample::Index>(),
        bit in 0u8..8,
    ) {
        let good = frame_of(&a);
        // COBS code bytes: position 0, then each code points to the next.
        let mut codes = vec![];
        let mut k = 0usize;
        while k < good.len() - 1 {
            codes.push(k);
            k += good[k] as usize;
        }
        let data: Vec<usize> = (0..good.len() - 1).filter(|i| !codes.contains(i)).collect();
        prop_assume!(!data.is_empty());
        let i = data[pos.index(data.len())];
        let mut bad = good.clone();
        bad[i] ^= 1 << bit;
        prop_assume!(bad[i] != 0); // that would be a delimiter, covered above
        let mut dec = FrameDecoder::<DeviceMsg>::new();
        let out = decode_all(&mut dec, &bad);
        prop_assert!(matches!(out[..], [Err(FrameError::Crc { .. })]), "{:?}", out);
    }

    /// A frame cut short (the link dropped the tail, then the next frame starts) never panics,
    /// the truncated one is reported as an error or swallowed into the next, and the frame
    /// after that decodes.
    #[test]
    fn truncated_frame_then_recovery(
        a in device_msg(),
        b in device_msg(),
        c in device_msg(),
        cut in any::<prop::sample::Index>(),
    ) {
        let fa = frame_of(&a);
        let cut = cut.index(fa.len() - 1); // drop at least the delimiter
        let mut stream = fa[..cut].to_vec();
        stream.extend(frame_of(&b));
        stream.extend(frame_of(&c));
        let mut dec = FrameDecoder::<DeviceMsg>::new();
        let out = decode_all(&mut dec, &stream);
        prop_assert_eq!(out.last(), Some(&Ok(c)));
        prop_assert!(out.len() >= 2);
        if cut == 0 {
            prop_assert_eq!(&out[..], &[Ok(b), Ok(c)][..]);
        }
    }
}

/// Dropping the `feed` iterator early still consumes the rest of the slice, so the decoder
/// stays in step with the stream.
#[test]
fn dropping_feed_early_keeps_the_decoder_in_step() {
    let a = DeviceMsg::Pong { nonce: 1 };
    let b = DeviceMsg::Pong { nonce: 2 };
    let c = DeviceMsg::Pong { nonce: 3 };
    let mut stream = frame_of(&a);
    stream.extend(frame_of(&b));
    let cut = frame_of(&c);
    stream.extend_from_slice(&cut[..3]);
    let mut dec = FrameDecoder::<DeviceMsg>::new();
    let first = dec.feed(&stream).next();
    assert_eq!(first, Some(Ok(a)));
    // `b` was consumed without being reported; the start of `c` is pending.
    assert_eq!(dec.pending_len(), 3);
    assert_eq!(decode_all(&mut dec, &cut[3..]), vec![Ok(c)]);
}
