//! The tapeshape station program: tape link, session store, terminal interface and CLI.
//!
//! * [`store`]: the SQLite session store (sessions, readings, per-device
//!   sequence bookkeeping); durable before anything is acknowledged.
//! * [`link`]: the serial link to the tape firmware (handshake, acknowledgement
//!   after commit, reconnection).
//! * [`check`]: each captured reading against what the readings already
//!   taken predict (conditional z-score, unit slips).
//! * [`estimate`]: estimating a body on its own thread (progress, cancel)
//!   and exporting it (OBJ, PLY, GLB and a JSON report).
//! * [`tui`]: the kiosk terminal interface (screens, operator flow).
//! * [`cli`]: the subcommands of the `tapeshape` binary (src/main.rs is a
//!   thin dispatcher over them).

pub mod check;
pub mod cli;
pub mod estimate;
pub mod link;
pub mod services;
pub mod store;
pub mod tui;
