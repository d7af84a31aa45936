//! Tape-station firmware logic (no_std): tape line parsing, reading queue, host protocol; tested on the host.
//!
//! Why a library: the boards (`firmware/boards/`: nRF52840 and QEMU mps2-an386) only wire
//! UARTs and a timer to [`run`]; everything that decides what happens to a byte from the tape
//! or the host lives here, runs on the host, and is tested there.
//!
//! * [`tape`]: the tape's line format (RENPHO RF-BMF01 style): [`tape::parse_line`],
//!   [`tape::LineAssembler`], [`tape::format_line`] (for the simulator).
//! * [`Device`]: the sans-IO state machine: `feed_tape`, `feed_host`, `poll` / `poll_frame`,
//!   `next_deadline`. Numbering, the bounded retransmit queue, acknowledgements, queue-full,
//!   tape silence, rate-limited live values, handshake and ping.
//! * [`run`]: the async loop over `embedded-io-async` streams and a [`Clock`].
//!
//! # Calling it from a board or a harness
//!
//! ```text
//! pub async fn run<TR: Read, HR: Read, HW: Write, C: Clock>(
//!     device: &mut Device, tape_rx: &mut TR, host_rx: &mut HR, host_tx: &mut HW, clock: &C,
//! ) -> RunEnd
//! ```
//!
//! ```
//! use tapeshape_firmware::{run, Clock, Config, Device, RunEnd};
//!
//! struct Uptime(std::time::Instant);
//! impl Clock for Uptime {
//!     fn now_ms(&self) -> u64 { self.0.elapsed().as_millis() as u64 }
//!     async fn sleep_until(&self, deadline_ms: u64) {
//!         while self.now_ms() < deadline_ms { std::thread::yield_now() } // a board: Timer::at
//!     }
//! }
//!
//! // The tape's UART: here two lines and then end of stream.
//! let mut tape: &[u8] = b"*08520;00000;0000PM\n*08520;00000;0000SM\n";
//! let mut host_rx: &[u8] = &[]; // no host: end of stream at once
//! let mut host_tx = Vec::new();
//! let clock = Uptime(std::time::Instant::now());
//! let mut device = Device::new(Config::new(0xC0FFEE, 42), clock.now_ms());
//! let end = embassy_futures::block_on(run(&mut device, &mut tape, &mut host_rx, &mut host_tx, &clock));
//! assert!(matches!(end, RunEnd::TapeClosed | RunEnd::HostClosed));
//! // The first frame out is the device hello.
//! let mut decoder = tapeshape_protocol::FrameDecoder::<tapeshape_protocol::DeviceMsg>::new();
//! let first = decoder.feed(&host_tx).next();
//! assert!(matches!(first, Some(Ok(tapeshape_protocol::DeviceMsg::Hello(_)))));
//! ```
//!
//! The wire rules are in `docs/wire-format.md`, the tape format in `docs/tape-format.md`.
#![no_std]

#[cfg(test)]
extern crate std;

mod device;
mod run;
pub mod tape;

pub use device::{Config, Device, FIRMWARE_VERSION, QUEUE_CAPACITY};
pub use run::{run, Clock, RunEnd};
pub use tapeshape_protocol as protocol;
