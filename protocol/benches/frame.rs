//! Frame encode + decode throughput (criterion benchmark, not a test).
//!
//! Why: the station's link runs at 115200 baud (about 11.5 kB/s); this shows how far the
//! framing code is from being the bottleneck on the host, and what one frame costs on the
//! CPU. The batch is a realistic mix of device-to-host messages (mostly live values and
//! readings, some status), so its byte count is what a busy link would carry.
//!
//! Run: `cargo bench -p tapeshape-protocol --bench frame`
//! Figures and machine: `docs/results/protocol-bench.md`.

use std::hint::black_box;

use criterion::{BatchSize, Criterion, Throughput};
use tapeshape_protocol::{
    encode, DeviceMsg, Fault, FrameDecoder, Live, Reading, RejectCounts, RejectReason, Status,
    UnitShown, MAX_FRAME,
};

/// 1,000 messages: 60 % live values, 30 % readings, 5 % status, 5 % faults.
fn batch() -> Vec<DeviceMsg> {
    (0..1000u32)
        .map(|i| match i % 20 {
            0 => DeviceMsg::Status(Status {
                boot_id: 0xDEAD_BEEF,
                uptime_ms: 3_600_000 + u64::from(i) * 100,
                queue_len: 2,
                queue_capacity: 32,
                next_seq: i,
                host_seen: true,
                tape_silent: false,
                lines_ok: 10 * i,
                heartbeats: i,
                rejected: RejectCounts {
                    garbage: 1,
                    partial: 2,
                    overlong: 0,
                    bad_field: 0,
                    impossible: 0,
                },
                readings_refused: 0,
                confirm_repeats: 0,
                host_frames_bad: 0,
                acks_ignored: 0,
                tape_io_errors: 0,
                host_io_errors: 0,
                reports_dropped: 0,
            }),
            1 => DeviceMsg::Fault(Fault::LineRejected {
                reason: RejectReason::Partial { len: 7 },
                rejected_total: i,
            }),
            2..=7 => DeviceMsg::Reading(Reading {
                boot_id: 0xDEAD_BEEF,
                seq: i,
                value_tenth_mm: 5_000 + i * 7,
                timestamp_ms: 3_600_000 + u64::from(i) * 100,
                unit_shown: UnitShown::Metric,
            }),
            _ => DeviceMsg::Live(Live {
                value_tenth_mm: 5_000 + i * 3,
                unit_shown: UnitShown::Imperial,
            }),
        })
        .collect()
}

fn encode_all(msgs: &[DeviceMsg], stream: &mut Vec<u8>) {
    let mut buf = [0u8; MAX_FRAME];
    for m in msgs {
        stream.extend_from_slice(encode(m, &mut buf).expect("bench messages fit"));
    }
}

fn decode_all(stream: &[u8]) -> usize {
    let mut dec = FrameDecoder::<DeviceMsg>::new();
    let mut ok = 0;
    for r in dec.feed(stream) {
        ok += usize::from(r.is_ok());
    }
    ok
}

fn bench(c: &mut Criterion) {
    let msgs = batch();
    let mut stream = Vec::with_capacity(msgs.len() * MAX_FRAME);
    encode_all(&msgs, &mut stream);
    let n = msgs.len() as u64;
    let bytes = stream.len() as u64;
    assert_eq!(decode_all(&stream), msgs.len(), "every frame decodes");
    println!(
        "batch: {n} messages, {bytes} frame bytes ({:.1} bytes/frame)",
        bytes as f64 / n as f64
    );

    for (unit, tp) in [
        ("msgs", Throughput::Elements(n)),
        ("bytes", Throughput::BytesDecimal(bytes)),
    ] {
        let mut g = c.benchmark_group(format!("frame_{unit}"));
        g.throughput(tp);
        g.bench_function("encode", |b| {
            let mut out = Vec::with_capacity(stream.len());
            b.iter(|| {
                out.clear();
                encode_all(black_box(&msgs), &mut out);
                black_box(out.len())
            })
        });
        g.bench_function("decode", |b| b.iter(|| decode_all(black_box(&stream))));
        g.bench_function("encode_decode", |b| {
            b.iter_batched_ref(
                || Vec::with_capacity(stream.len()),
                |out| {
                    encode_all(black_box(&msgs), out);
                    decode_all(out)
                },
                BatchSize::SmallInput,
            )
        });
        g.finish();
    }
}

fn main() {
    // Written out instead of `criterion_group!`, whose generated function has no docs.
    let mut c = Criterion::default().configure_from_args();
    bench(&mut c);
    c.final_summary();
}
