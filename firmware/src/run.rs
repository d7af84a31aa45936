//! The async loop that connects a [`Device`] to the tape UART, the host link and a timer.
//!
//! Why a plain async function over traits: the boards (nRF52840, QEMU mps2-an386) and the
//! host-side test harness each supply only their byte streams and clock; the loop itself is
//! the same everywhere and is tested on the host. No executor is named here; a board spawns
//! a task that awaits [`run`].

use embassy_futures::select::{select, select3, Either, Either3};
use embedded_io_async::{Read, Write};
use tapeshape_protocol::MAX_FRAME;

use crate::Device;

/// A millisecond clock with an async sleep: the only timing a board must provide.
///
/// On embassy: `now_ms` is `embassy_time::Instant::now().as_millis()` and `sleep_until` is
/// `embassy_time::Timer::at(Instant::from_millis(deadline_ms)).await`.
#[allow(async_fn_in_trait)] // single-threaded executors; no Send bound wanted
pub trait Clock {
    /// Milliseconds since an arbitrary start (device boot), never decreasing.
    fn now_ms(&self) -> u64;
    /// Completes once `now_ms() >= deadline_ms` (at once if it already is). Must be
    /// cancel-safe (it is dropped whenever a byte arrives first).
    async fn sleep_until(&self, deadline_ms: u64);
}

/// Why [`run`] returned. On a board neither happens (UARTs do not close); a host harness
/// over pipes or a pseudo-terminal ends this way.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RunEnd {
    /// The tape stream reported end of stream (`read` returned 0 bytes).
    TapeClosed,
    /// The host link reported end of stream.
    HostClosed,
}

/// Pause after a read error before reading again, so a stream that fails at once every time
/// cannot spin the CPU, ms.
const ERROR_PAUSE_MS: u64 = 1;

/// Runs the device: reads the tape and the host link, sends frames to the host, and wakes up
/// for the device's timers. Returns only when a stream ends.
///
/// The tape is read even while a frame is being written, so a host that is slow to collect
/// bytes delays frames but never makes the tape's UART overflow. Host bytes that arrive
/// during a write wait in the host reader's buffer (or are lost and repaired by the
/// protocol: acks are cumulative, hellos and pings repeated).
///
/// Requirements on the streams (embassy's `BufferedUart`/`BufferedUarte` and USB CDC-ACM
/// halves meet them):
/// * the two readers are cancel-safe: a pending `read` is dropped whenever another event
///   comes first, and no byte may be lost by that;
/// * the tape reader buffers at least one line (20 bytes) between polls of the loop;
/// * `host_tx.write_all` should not block forever when no host listens (drop bytes
///   instead): the tape is still read meanwhile, but nothing else is sent.
///
/// Read and write errors are counted in the device status (`tape_io_errors`,
/// `host_io_errors`) and the loop goes on; a frame whose write failed is a reading that will
/// be retransmitted, or a report whose counters the next status repeats.
///
/// ```text
/// // On an embassy board (sketch; see firmware/boards/):
/// #[embassy_executor::task]
/// async fn link(tape: BufferedUarteRx<'static>, usb_rx: CdcRx, usb_tx: CdcTx) {
///     let mut dev = Device::new(Config::new(device_id(), boot_id()), EmbassyClock.now_ms());
///     let (mut tape, mut rx, mut tx) = (tape, usb_rx, usb_tx);
///     run(&mut dev, &mut tape, &mut rx, &mut tx, &EmbassyClock).await;
/// }
/// ```
pub async fn run<TR, HR, HW, C>(
    device: &mut Device,
    tape_rx: &mut TR,
    host_rx: &mut HR,
    host_tx: &mut HW,
    clock: &C,
) -> RunEnd
where
    TR: Read,
    HR: Read,
    HW: Write,
    C: Clock,
{
    let mut tape_buf = [0u8; 32];
    let mut host_buf = [0u8; 32];
    let mut frame = [0u8; MAX_FRAME];
    loop {
        // Send everything that is ready. The tape keeps being read while a write waits
        // (a host that is slow to collect bytes must not make the tape UART overflow).
        let mut wrote = false;
        while let Some(f) = device.poll_frame(clock.now_ms(), &mut frame) {
            let len = f.len();
            let write = host_tx.write_all(&frame[..len]);
            match while_reading_tape(write, device, tape_rx, &mut tape_buf, clock).await {
                Ok(Ok(())) => {}
                Ok(Err(_)) => device.host_io_error(),
                Err(end) => return end,
            }
            wrote = true;
        }
        if wrote {
            let flush = host_tx.flush();
            match while_reading_tape(flush, device, tape_rx, &mut tape_buf, clock).await {
                Ok(Ok(())) => {}
                Ok(Err(_)) => device.host_io_error(),
                Err(end) => return end,
            }
        }
        let deadline = device.next_deadline();
        let event = select3(
            tape_rx.read(&mut tape_buf),
            host_rx.read(&mut host_buf),
            clock.sleep_until(deadline),
        )
        .await;
        match event {
            Either3::First(r) => {
                if let Err(end) = on_tape_read(r, device, &tape_buf, clock).await {
                    return end;
                }
            }
            Either3::Second(Ok(0)) => return RunEnd::HostClosed,
            Either3::Second(Ok(n)) => device.feed_host(&host_buf[..n], clock.now_ms()),
            Either3::Second(Err(_)) => {
                device.host_io_error();
                pause_after_error(clock).await;
            }
            Either3::Third(()) => {}
        }
    }
}

async fn pause_after_error<C: Clock>(clock: &C) {
    clock
        .sleep_until(clock.now_ms().saturating_add(ERROR_PAUSE_MS))
        .await;
}

/// Feeds the outcome of one tape read to the device; `Err` when the tape stream ended.
async fn on_tape_read<E, C: Clock>(
    r: Result<usize, E>,
    device: &mut Device,
    buf: &[u8],
    clock: &C,
) -> Result<(), RunEnd> {
    match r {
        Ok(0) => Err(RunEnd::TapeClosed),
        Ok(n) => {
            device.feed_tape(&buf[..n], clock.now_ms());
            Ok(())
        }
        Err(_) => {
            device.tape_io_error();
            pause_after_error(clock).await;
            Ok(())
        }
    }
}

/// Runs `fut` to completion while feeding whatever the tape sends meanwhile to the device.
/// `Err` when the tape stream ends first.
async fn while_reading_tape<F, TR, C>(
    fut: F,
    device: &mut Device,
    tape_rx: &mut TR,
    buf: &mut [u8],
    clock: &C,
) -> Result<F::Output, RunEnd>
where
    F: core::future::Future,
    TR: Read,
    C: Clock,
{
    let pump = async {
        loop {
            let r = tape_rx.read(buf).await;
            on_tape_read(r, device, buf, clock).await?;
        }
    };
    match select(fut, pump).await {
        Either::First(out) => Ok(out),
        Either::Second(end) => end,
    }
}
