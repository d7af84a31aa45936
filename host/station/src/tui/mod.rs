//! The kiosk terminal interface (ratatui + crossterm) of `tapeshape station`
//! and `tapeshape demo`.
//!
//! Why this layout (the one ratatui's well-kept apps use): [`app`] holds the
//! state and the one transition `update(&mut App, Event) -> Vec<Effect>`, with
//! no I/O, and routes keys and events to the [`screens`], each of which owns
//! its state, keys and drawing; [`runner`] owns the terminal, the tape link,
//! the session layer and the services, turns what happens into
//! [`app::Event`]s and performs the [`app::Effect`]s. The demo's simulated
//! operator (`operator`, in the build with the `demo` feature) is one more
//! event source ([`runner::Demo`]), switched off by the first key a person
//! presses. Checking and estimating sit behind
//! [`crate::services::Services`], so the interface thread never waits on the
//! estimator and tests run without one.
//!
//! Layer: a front end. It uses the services, the session layer, the link and
//! the store, never the command line (`crate::cli`).

pub mod app;
pub mod keys;
#[cfg(feature = "demo")]
pub mod operator;
pub mod runner;
pub mod screens;
mod theme;

pub use app::{update, App, AppConfig, Effect, Event, ShowLength};
pub use screens::draw;
