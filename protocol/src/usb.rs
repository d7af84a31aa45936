//! How the tape station introduces itself on USB.
//!
//! Why here: the nRF52840 board (`firmware/boards/nrf52840`) puts these in its USB device
//! descriptor, and the host (`tapeshape station` without `--port`, `tapeshape ports`) looks
//! for them among the computer's serial ports. One definition, so the two cannot drift apart.
//!
//! The vendor:product id is pid.codes' open-source vendor id with its *test* product id,
//! which other development boards share; the product string is what tells a tape station
//! apart (the host checks both, and in the end only a device hello over the port counts).

/// USB vendor id: pid.codes, the open-source vendor id.
pub const VID: u16 = 0x1209;

/// USB product id: pid.codes' test id 0x0001 (for development; a product registers its own).
pub const PID: u16 = 0x0001;

/// USB manufacturer string.
pub const MANUFACTURER: &str = "tapeshape";

/// USB product string: the name under which the host finds the station's port (Linux shows
/// it in `/dev/serial/by-id/usb-tapeshape_tapeshape_tape_station_<SERIAL>-if00`).
pub const PRODUCT: &str = "tapeshape tape station";
