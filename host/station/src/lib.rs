//! The tapeshape station program: tape link, session store, terminal interface and CLI.
//!
//! * [`store`]: the SQLite session store (sessions, readings, per-device
//!   sequence bookkeeping); durable before anything is acknowledged.
//! * [`link`]: the serial link to the tape firmware (handshake, acknowledgement
//!   after commit, reconnection).
//!
//! The `tapeshape` binary (src/main.rs, src/cli/) is a thin layer over these.

pub mod link;
pub mod store;
