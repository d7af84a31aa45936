//! Shared fixtures of the interface tests: an app driven into each state
//! through `update` only (the way the runner drives it), with link events
//! and effect results written out by hand.

#![allow(dead_code)]

use crossterm::event::{KeyCode, KeyEvent, KeyModifiers};
use tapeshape::link::{Disconnect, LinkCounters, LinkEvent};
use tapeshape::services::CheckOutcome;
use tapeshape::store::{ReadingId, ReadingSource, SessionId, StoredReading, TapeOrigin};
use tapeshape::tui::app::{App, AppConfig, Effect, Event, MeasurementInfo, SessionView};
use tapeshape::tui::update;
use tapeshape_protocol::{DeviceHello, Live, SoftwareVersion, UnitShown, PROTOCOL_VERSION};

/// Device id of the fixture tape.
pub const DEVICE: u64 = 0x7a9e_da70_0000_0001;

/// A fresh app (fixed id seed so customer ids are reproducible).
pub fn app(demo: bool) -> App {
    let mut app = App::new(AppConfig {
        port: "/dev/ttyACM0".into(),
        demo,
        mono: false,
        id_seed: 42,
        default_set: "quick".into(),
    });
    app.start();
    app
}

/// A key press.
pub fn key(code: KeyCode) -> Event {
    Event::Key(KeyEvent::new(code, KeyModifiers::NONE))
}

/// A character key.
pub fn ch(c: char) -> Event {
    key(KeyCode::Char(c))
}

/// Applies events, collecting the effects.
pub fn send(app: &mut App, events: impl IntoIterator<Item = Event>) -> Vec<Effect> {
    events.into_iter().flat_map(|e| update(app, e)).collect()
}

/// The tape says hello.
pub fn connect(app: &mut App) {
    send(
        app,
        [
            Event::Link(LinkEvent::PortOpened {
                path: "/dev/ttyACM0".into(),
            }),
            Event::Link(LinkEvent::Connected(DeviceHello {
                protocol: PROTOCOL_VERSION,
                firmware: SoftwareVersion {
                    major: 0,
                    minor: 1,
                    patch: 0,
                },
                device_id: DEVICE,
                boot_id: 7,
                queue_capacity: 32,
            })),
        ],
    );
}

/// The tape shows a live value.
pub fn live(app: &mut App, value_tenth_mm: u32) {
    send(
        app,
        [Event::Link(LinkEvent::Live(Live {
            value_tenth_mm,
            unit_shown: UnitShown::Metric,
        }))],
    );
}

/// The built-in quick set as the runner loads it.
pub fn quick() -> Vec<MeasurementInfo> {
    tapeshape_measure::MeasurementSet::builtin("quick")
        .unwrap()
        .definitions
        .into_iter()
        .map(|d| MeasurementInfo {
            name: d.name,
            label: d.label,
            description: d.description,
        })
        .collect()
}

/// Session 3 of customer c-test on the quick set, opened with `readings`.
///
/// The resumed readings are checked again (an unanswered flag must come
/// back after a restart); like the runner, this answers every such check,
/// here with a pass, and returns the effects of both steps.
pub fn open_session(app: &mut App, readings: &[(&str, u32)]) -> Vec<Effect> {
    let mut fx = send(
        app,
        [Event::SessionReady(SessionView {
            id: SessionId(3),
            customer: "c-test".into(),
            set: "quick".into(),
            notes: Some("sex: female, age: 34".into()),
            measurements: quick(),
            readings: readings.iter().map(|(n, v)| (n.to_string(), *v)).collect(),
            superseded: Vec::new(),
            marks: Vec::new(),
            estimate: None,
            careful: None,
            status: tapeshape::store::SessionStatus::Open,
        })],
    );
    let answers: Vec<Event> = fx
        .iter()
        .filter_map(|f| match f {
            Effect::Check(r) => Some(Event::Checked {
                name: r.name.clone(),
                value_tenth_mm: (r.value_mm * 10.0).round() as u32,
                outcome: CheckOutcome::default(),
            }),
            _ => None,
        })
        .collect();
    fx.retain(|f| !matches!(f, Effect::Check(_)));
    fx.extend(send(app, answers));
    fx
}

/// The link committed a reading of `name` to session 3.
pub fn committed(app: &mut App, seq: u32, name: &str, value_tenth_mm: u32) -> Vec<Effect> {
    send(
        app,
        [Event::Link(LinkEvent::ReadingCommitted {
            reading: StoredReading {
                id: ReadingId(100 + i64::from(seq)),
                session_id: SessionId(3),
                measurement: name.into(),
                value_tenth_mm,
                source: ReadingSource::Tape(TapeOrigin {
                    device_id: DEVICE,
                    boot_id: 7,
                    seq,
                    device_time_ms: 1000 * u64::from(seq),
                }),
                received_at_ms: 1_700_000_000_000,
                superseded_by: None,
                withdrawn_at_ms: None,
            },
            unit_shown: UnitShown::Metric,
        })],
    )
}

/// The check's answer for a reading.
pub fn checked(app: &mut App, name: &str, value_tenth_mm: u32, flag: Option<&str>) -> Vec<Effect> {
    send(
        app,
        [Event::Checked {
            name: name.into(),
            value_tenth_mm,
            outcome: CheckOutcome {
                flag: flag.map(str::to_string),
                ..CheckOutcome::default()
            },
        }],
    )
}

/// A reading committed and checked fine.
pub fn take(app: &mut App, seq: u32, name: &str, value_tenth_mm: u32) {
    committed(app, seq, name, value_tenth_mm);
    checked(app, name, value_tenth_mm, None);
}

/// The link lost the tape.
pub fn unplug(app: &mut App) {
    send(
        app,
        [Event::Link(LinkEvent::Disconnected {
            reason: Disconnect::Read(std::sync::Arc::new(std::io::Error::other(
                "device unplugged",
            ))),
            counters: LinkCounters {
                disconnects: 1,
                ..LinkCounters::default()
            },
        })],
    );
}

/// Name of the measurement the tape's next reading goes to.
pub fn current(app: &App) -> Option<String> {
    app.current_item().map(|i| i.info.name.clone())
}

/// The last naming the app asked the link for, among `effects`.
pub fn naming(effects: &[Effect]) -> Option<Option<String>> {
    effects.iter().rev().find_map(|e| match e {
        Effect::SetNaming(n) => Some(n.clone()),
        _ => None,
    })
}
