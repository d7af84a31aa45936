//! The kiosk terminal interface (ratatui + crossterm) of `tapeshape station`
//! and `tapeshape demo` (issue 5).
//!
//! Why this layout (the one ratatui's well-kept apps use): [`app`] holds the
//! state and the one transition `update(&mut App, Event) -> Vec<Effect>`, with
//! no I/O; [`ui`] draws an `&App` into a frame; [`runner`] owns the terminal,
//! the tape link and the engine services, turns what happens into
//! [`app::Event`]s and performs the [`app::Effect`]s. The demo's simulated
//! operator ([`operator`]) is one more event source, switched off by the
//! first key a person presses. Checking and estimating sit behind
//! [`crate::services::Services`], so the interface thread never waits on the engine
//! and tests run without one.

pub mod app;
pub mod operator;
pub mod runner;
pub mod ui;

pub use app::{update, App, AppConfig, Effect, Event};
pub use ui::draw;
