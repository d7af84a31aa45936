//! The tapeshape station program: tape link, session store, session layer,
//! services, the kiosk terminal interface and the command line.
//!
//! # Module map
//!
//! The station is built in layers; a module may import the modules of its
//! own layer and those below it, never one above (`tests/layers.rs` checks
//! every `crate::` path in `src/` against this table):
//!
//! | layer | modules | what | may import |
//! |---|---|---|---|
//! | 0 words | [`text`] | lengths, times, device faults, digests as the station writes them | nothing of the station |
//! | 1 bottom | [`store`], [`link`] | the SQLite session store (the only writer of the file; its writes are crate-private); the serial link to the tape (frames, acks, reconnects) | `text` (the link also the store's types) |
//! | 2 session | [`session`] | what a session is: creating, opening, resuming; readings from the tape (through the link's `ReadingSink`) or the keyboard; undo, skip, marks; the stored estimate. Every change is one transaction of `Sessions::change` | layers 0-1 |
//! | 3 services | [`check`], [`estimate`], [`services`] | the work every front end asks for: checking a reading, estimating and exporting a body, showing a stored estimate | layers 0-2 |
//! | 4 front ends | [`tui`] | the kiosk interface: `app` (router), one module per screen, the runner, the demo's simulated operator | layers 0-3 |
//! | 5 commands | [`cli`] | the subcommands of the `tapeshape` binary (`src/main.rs` is a thin dispatcher over them): the line-mode station, the demo, sessions, measure, predict, ... | everything |

pub mod check;
pub mod cli;
pub mod estimate;
pub mod link;
pub mod services;
pub mod session;
pub mod store;
pub mod text;
pub mod tui;
