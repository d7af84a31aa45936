//! The async `run` loop on the host: in-memory pipes for the tape UART and the host link, a
//! fake clock moved by the test, and `embassy_futures` to drive both sides. Checks the whole
//! path a board runs: hello, handshake, a confirmed reading framed to the host,
//! retransmission on the clock, the ack, a ping, and the end when the tape stream closes.

use std::cell::{Cell, RefCell};
use std::collections::VecDeque;
use std::convert::Infallible;
use std::future::poll_fn;
use std::rc::Rc;
use std::task::Poll;

use embassy_futures::join::join;
use embedded_io_async::{ErrorType, Read, Write};
use tapeshape_firmware::tape::{format_line, Kind};
use tapeshape_firmware::{run, Clock, Config, Device, RunEnd};
use tapeshape_protocol::*;

/// One direction of an in-memory byte pipe.
#[derive(Clone, Default)]
struct Pipe(Rc<RefCell<(VecDeque<u8>, bool)>>);

impl Pipe {
    fn send(&self, bytes: &[u8]) {
        self.0.borrow_mut().0.extend(bytes);
    }
    fn close(&self) {
        self.0.borrow_mut().1 = true;
    }
    fn take_all(&self) -> Vec<u8> {
        self.0.borrow_mut().0.drain(..).collect()
    }
}

impl ErrorType for Pipe {
    type Error = Infallible;
}

impl Read for Pipe {
    async fn read(&mut self, buf: &mut [u8]) -> Result<usize, Infallible> {
        poll_fn(|_| {
            let mut p = self.0.borrow_mut();
            if p.0.is_empty() {
                return if p.1 {
                    Poll::Ready(Ok(0))
                } else {
                    Poll::Pending
                };
            }
            let n = buf.len().min(p.0.len());
            for (slot, b) in buf.iter_mut().zip(p.0.drain(..n)) {
                *slot = b;
            }
            Poll::Ready(Ok(n))
        })
        .await
    }
}

impl Write for Pipe {
    async fn write(&mut self, buf: &[u8]) -> Result<usize, Infallible> {
        self.send(buf);
        Ok(buf.len())
    }
    async fn flush(&mut self) -> Result<(), Infallible> {
        Ok(())
    }
}

/// A host-link writer that can be made to stall, like a USB host that does not collect.
#[derive(Clone, Default)]
struct StallWriter {
    inner: Pipe,
    stalled: Rc<Cell<bool>>,
}

impl ErrorType for StallWriter {
    type Error = Infallible;
}

impl Write for StallWriter {
    async fn write(&mut self, buf: &[u8]) -> Result<usize, Infallible> {
        poll_fn(|_| {
            if self.stalled.get() {
                Poll::Pending
            } else {
                Poll::Ready(())
            }
        })
        .await;
        self.inner.write(buf).await
    }
    async fn flush(&mut self) -> Result<(), Infallible> {
        Ok(())
    }
}

/// A clock that only moves when the test says so. `embassy_futures::block_on` polls
/// continuously, so pending futures need no waker.
#[derive(Default)]
struct FakeClock(Cell<u64>);

impl Clock for FakeClock {
    fn now_ms(&self) -> u64 {
        self.0.get()
    }
    async fn sleep_until(&self, deadline_ms: u64) {
        poll_fn(|_| {
            if self.0.get() >= deadline_ms {
                Poll::Ready(())
            } else {
                Poll::Pending
            }
        })
        .await
    }
}

/// Lets the other future run a few polls.
async fn settle() {
    for _ in 0..20 {
        let mut yielded = false;
        poll_fn(|_| {
            if yielded {
                Poll::Ready(())
            } else {
                yielded = true;
                Poll::Pending
            }
        })
        .await;
    }
}

fn frame(msg: &HostMsg) -> Vec<u8> {
    let mut buf = [0u8; MAX_FRAME];
    encode(msg, &mut buf).unwrap().to_vec()
}

#[test]
fn run_over_in_memory_pipes() {
    let tape = Pipe::default();
    let host_in = Pipe::default();
    let host_out = Pipe::default();
    let clock = FakeClock::default();
    let mut cfg = Config::new(0xFEED, 99);
    cfg.status_interval_ms = 0;
    cfg.tape_silent_ms = 60_000;
    let mut device = Device::new(cfg, 0);

    let (mut tape_rx, mut host_rx, mut host_tx) = (tape.clone(), host_in.clone(), host_out.clone());
    let device_side = run(
        &mut device,
        &mut tape_rx,
        &mut host_rx,
        &mut host_tx,
        &clock,
    );

    let test_side = async {
        let mut dec = FrameDecoder::<DeviceMsg>::new();
        let recv = |dec: &mut FrameDecoder<DeviceMsg>| -> Vec<DeviceMsg> {
            dec.feed(&host_out.take_all()).map(|r| r.unwrap()).collect()
        };
        settle().await;
        let hello = recv(&mut dec);
        assert!(
            matches!(
                hello[..],
                [DeviceMsg::Hello(DeviceHello {
                    device_id: 0xFEED,
                    boot_id: 99,
                    ..
                })]
            ),
            "{hello:?}"
        );

        // Handshake.
        host_in.send(&frame(&HostMsg::Hello(HostHello {
            protocol: PROTOCOL_VERSION,
            software: SoftwareVersion {
                major: 0,
                minor: 1,
                patch: 0,
            },
        })));
        settle().await;
        assert!(matches!(recv(&mut dec)[..], [DeviceMsg::Hello(_)]));

        // A confirmed reading arrives in two UART chunks at t = 50.
        clock.0.set(50);
        let line = format_line(8520, Kind::Confirmed, UnitShown::Imperial).unwrap();
        tape.send(&line[..7]);
        settle().await;
        tape.send(&line[7..]);
        settle().await;
        let want = Reading {
            boot_id: 99,
            seq: 0,
            value_tenth_mm: 8520,
            timestamp_ms: 50,
            unit_shown: UnitShown::Imperial,
        };
        assert_eq!(recv(&mut dec), [DeviceMsg::Reading(want)]);

        // Not acknowledged: the loop wakes on the clock and retransmits after 300 ms.
        clock.0.set(349);
        settle().await;
        assert!(recv(&mut dec).is_empty());
        clock.0.set(350);
        settle().await;
        assert_eq!(recv(&mut dec), [DeviceMsg::Reading(want)]);

        // Acknowledged: no more retransmissions.
        host_in.send(&frame(&HostMsg::Ack {
            boot_id: 99,
            seq: 0,
        }));
        settle().await;
        clock.0.set(5_000);
        settle().await;
        assert!(recv(&mut dec).is_empty());

        // Ping.
        host_in.send(&frame(&HostMsg::Ping { nonce: 31337 }));
        settle().await;
        assert_eq!(recv(&mut dec), [DeviceMsg::Pong { nonce: 31337 }]);

        // The tape stream ends.
        tape.close();
    };

    let (end, ()) = embassy_futures::block_on(join(device_side, test_side));
    assert_eq!(end, RunEnd::TapeClosed);
    assert_eq!(device.queue_len(), 0);
    assert_eq!(device.status(5_000).lines_ok, 1);
}

#[test]
fn the_tape_is_read_while_a_host_write_is_stalled() {
    let tape = Pipe::default();
    let host_in = Pipe::default();
    let host_out = StallWriter::default();
    let clock = FakeClock::default();
    let mut cfg = Config::new(1, 2);
    cfg.status_interval_ms = 0;
    cfg.tape_silent_ms = 60_000;
    let mut device = Device::new(cfg, 0);
    let (mut tape_rx, mut host_rx, mut host_tx) = (tape.clone(), host_in.clone(), host_out.clone());
    let device_side = run(
        &mut device,
        &mut tape_rx,
        &mut host_rx,
        &mut host_tx,
        &clock,
    );

    let test_side = async {
        let mut dec = FrameDecoder::<DeviceMsg>::new();
        host_in.send(&frame(&HostMsg::Hello(HostHello {
            protocol: PROTOCOL_VERSION,
            software: SoftwareVersion {
                major: 0,
                minor: 1,
                patch: 0,
            },
        })));
        settle().await;
        let _ = dec.feed(&host_out.inner.take_all()).count();

        // The host stops collecting; the device has a pong to write and waits on it.
        host_out.stalled.set(true);
        host_in.send(&frame(&HostMsg::Ping { nonce: 5 }));
        settle().await;
        // Meanwhile the operator confirms a value at t = 77.
        clock.0.set(77);
        tape.send(&format_line(4321, Kind::Confirmed, UnitShown::Metric).unwrap());
        settle().await;
        // The host collects again at t = 500.
        clock.0.set(500);
        host_out.stalled.set(false);
        settle().await;
        let got: Vec<_> = dec
            .feed(&host_out.inner.take_all())
            .map(|r| r.unwrap())
            .collect();
        assert_eq!(got[0], DeviceMsg::Pong { nonce: 5 });
        // The line was read (and timestamped) during the stall, not after it.
        assert!(
            got.contains(&DeviceMsg::Reading(Reading {
                boot_id: 2,
                seq: 0,
                value_tenth_mm: 4321,
                timestamp_ms: 77,
                unit_shown: UnitShown::Metric,
            })),
            "{got:?}"
        );
        tape.close();
    };
    let (end, ()) = embassy_futures::block_on(join(device_side, test_side));
    assert_eq!(end, RunEnd::TapeClosed);
}
