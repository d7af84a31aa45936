//! The async loop that connects a [`Device`] to the tape UART, the host link and a timer.
//!
//! Why a plain async function over traits: the boards (nRF52840, QEMU mps2-an386) and the
//! host-side test harness each supply only their byte streams and clock; the loop itself is
//! the same everywhere and is tested on the host. No executor is named here; a board spawns
//! a task that awaits [`run`].

use embassy_futures::select::{select3, Either3};
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
/// Requirements on the streams (embassy's `BufferedUart`/`BufferedUarte` and USB CDC-ACM
/// halves meet them):
/// * the two readers are cancel-safe: a pending `read` is dropped whenever another event
///   comes first, and no byte may be lost by that;
/// * the tape reader buffers while frames are written (at least 64 bytes: one retransmission
///   round of the full queue takes about 60 ms at 115200 baud, during which the tape sends
///   up to 60 bytes at 9600 baud);
/// * `host_tx.write_all` must not block forever when no host listens (drop bytes instead).
///
/// Read and write errors are counted in the device status (`tape_io_errors`,
/// `host_io_errors`) and the loop goes on; a frame whose write failed is a reading that will
/// be retransmitted, or a report whose counters the next status repeats.
///
/// ```ignore
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
        let now = clock.now_ms();
        let mut wrote = false;
        while let Some(f) = device.poll_frame(now, &mut frame) {
            if host_tx.write_all(f).await.is_err() {
                device.host_io_error();
            }
            wrote = true;
        }
        if wrote && host_tx.flush().await.is_err() {
            device.host_io_error();
        }
        let deadline = device.next_deadline();
        let event = select3(
            tape_rx.read(&mut tape_buf),
            host_rx.read(&mut host_buf),
            clock.sleep_until(deadline),
        )
        .await;
        match event {
            Either3::First(Ok(0)) => return RunEnd::TapeClosed,
            Either3::First(Ok(n)) => device.feed_tape(&tape_buf[..n], clock.now_ms()),
            Either3::First(Err(_)) => {
                device.tape_io_error();
                clock
                    .sleep_until(clock.now_ms().saturating_add(ERROR_PAUSE_MS))
                    .await;
            }
            Either3::Second(Ok(0)) => return RunEnd::HostClosed,
            Either3::Second(Ok(n)) => device.feed_host(&host_buf[..n], clock.now_ms()),
            Either3::Second(Err(_)) => {
                device.host_io_error();
                clock
                    .sleep_until(clock.now_ms().saturating_add(ERROR_PAUSE_MS))
                    .await;
            }
            Either3::Third(()) => {}
        }
    }
}
