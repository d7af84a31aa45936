//! The chain's head-office hub: an HTTP service in front of PostgreSQL that
//! the stores' stations push their sessions to, that answers a station's
//! returning-customer lookup, carries a customer's erasure to every station
//! that holds them, and shows head-office users a page per store and per
//! session with the body in a 3D viewer.
//!
//! Why this shape: a station's SQLite stays the source of truth for its own
//! sessions (it works offline); the hub is a follower that applies each
//! station's events in the station's order, once (`apply`), so whatever
//! the network does (lost answers, retries, duplicated or reordered
//! requests) its record of a station is a prefix of that station's outbox.
//! It keeps no state of its own outside PostgreSQL, so several hub
//! processes can serve one database, and a hub killed at any moment loses
//! nothing a station was told was committed.
//!
//! Modules: [`db`] (the pool, the schema migrations in `migrations/`, the
//! head office's commands: stations, users, a customer's export and
//! erasure, retention; `db::reads`: what the pages and the lookup read),
//! [`apply`] (one batch of a station's events, one
//! transaction), [`server`] (the HTTP API and pages, plain or TLS), [`web`]
//! (the pages and the vendored three.js viewer), [`pgtest`] (a throwaway
//! PostgreSQL cluster for tests and benchmarks). `docs/hub.md` has the
//! schema, the API, the rules and how it would partition for thousands of
//! stores.

pub mod apply;
pub mod db;
pub mod pgtest;
pub mod server;
pub mod web;

pub use db::{Db, DbTarget, HubError};
pub use server::{serve, serve_listener, ServeConfig};
