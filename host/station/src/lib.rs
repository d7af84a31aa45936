//! The tapeshape station program: tape link, session store, session layer,
//! services, the kiosk terminal interface and the command line.
//!
//! # Module map
//!
//! The station is built in layers. In the order below, a module may import
//! only the modules before it, never one after it (`tests/layers.rs` checks
//! every `crate::` path in `src/` against this order; `check`,
//! `estimate` and `sync` share a place and do not import each other):
//!
//! | order | layer | module | what |
//! |---|---|---|---|
//! | 0 | process | `alloc` | the binary's memory allocator (Linux): huge pages for large blocks, glibc tuned to keep freed memory; imports nothing |
//! | 0 | words | [`i18n`] | the operator text's message catalogue (Fluent, `locales/<lang>/station.ftl`, embedded) and the language chosen at start |
//! | 1 | words | [`text`] | lengths, times, device faults, digests as the station writes them |
//! | 1 | words | [`warning_text`] | the estimate's coded warnings and refusals worded from the catalogue |
//! | 2 | bottom | [`store`] | the SQLite session store: rows, migrations (`migrations/`), reads; its writes are crate-private steps of one transaction |
//! | 3 | bottom | [`link`] | the serial link to the tape (frames, acks, reconnects); commits through its `ReadingSink` trait |
//! | 4 | session | [`session`] | what a session is: start, open, resume; readings from the tape (it is the link's `ReadingSink`) or the keyboard; undo, skip, marks; the stored estimate. Every change is one transaction of `Sessions::change` |
//! | 5 | services | [`check`], [`estimate`], [`sync`] | checking a captured reading; estimating on a thread and exporting a body, the customer's card (`estimate::card`); pushing the outbox to the chain's hub and the returning-customer lookup |
//! | 6 | services | [`services`] | the one boundary the front ends use (`Services`), and `StationServices` over the estimator and the session layer |
//! | 7 | front end | [`tui`] | the kiosk interface: `app` (router), one module per screen, the runner, the demo's simulated operator (`demo` feature) |
//! | 8 | commands | [`cli`] | the subcommands of the `tapeshape` binary (`src/main.rs` dispatches): the line-mode station, the demo (`demo` feature), sessions, measure, predict, a customer's data, the hub (`hub` feature), ...; `moved` says where `eval` (now `tapeshape-eval`) went |

#[cfg(target_os = "linux")]
pub mod alloc;
pub mod check;
pub mod cli;
pub mod estimate;
pub mod i18n;
pub mod link;
pub mod services;
pub mod session;
pub mod store;
pub mod sync;
pub mod text;
pub mod tui;
pub mod warning_text;
