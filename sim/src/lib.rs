//! Simulated tape measure, fault injection and pseudo-terminal wiring for tests and the demo.
//!
//! Why: the station must never lose or double a customer's reading, whatever the serial line
//! does. That can only be shown by running the real pieces (the firmware logic or the real
//! board binary, the station's tokio-serial link, its SQLite store) against a tape and a line
//! that misbehave on purpose, reproducibly. This crate provides the misbehaving world; the
//! end-to-end tests in `tests/` and the `tapeshape demo` command put it together.
//!
//! ```text
//! tape (script) --pty--> firmware (harness | QEMU) --pty--> proxy (faults) --pty--> station
//! ```
//!
//! * [`tape`]: a RENPHO-style tape driven by a [`tape::Script`] (pulls with live lines, holds,
//!   pauses, unit changes, raw lines), played in real time or faster.
//! * [`faults`]: seeded fault plans (bit flips, dropped and doubled bytes, garbage lines,
//!   silences, unplugs) applied to a byte stream, with counts of what was done.
//! * [`pty`]: raw-mode pseudo-terminals, and a port path that can be unplugged and replugged.
//! * [`proxy`]: the fault-injecting proxy between the firmware's host port and the station.
//! * [`harness`]: the firmware logic (`tapeshape_firmware::run`) on a host thread between two
//!   ptys.
//! * `qemu` (feature `qemu`, which the end-to-end tests turn on and the station's demo does
//!   not): the real `mps2-an386` firmware under QEMU, with the same two ptys.
//!
//! The simulated customer of `tapeshape demo` (an ANSUR II test-split person read by the tape)
//! is the station's demo command (`host/station/src/cli/demo.rs`), its simulated tape and
//! operator the station's `tui/operator.rs` (both in the station's `demo` feature), built on
//! [`tape`] and [`harness`]; the end-to-end tests' customers with known bodies are in
//! `tests/tests/known_bodies`.

pub mod faults;
pub mod harness;
pub mod proxy;
pub mod pty;
#[cfg(feature = "qemu")]
pub mod qemu;
pub mod tape;
