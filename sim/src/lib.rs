//! Simulated tape measure, fault injection and pseudo-terminal wiring for tests and the demo.

pub mod faults;
pub mod harness;
pub mod proxy;
pub mod pty;
pub mod qemu;
pub mod tape;
