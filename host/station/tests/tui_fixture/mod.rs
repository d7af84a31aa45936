//! Shared fixtures of the interface tests: an app driven into each state
//! through `update` only (the way the runner drives it), with link events
//! and effect results written out by hand.

#![allow(dead_code)]

use crossterm::event::{KeyCode, KeyEvent, KeyModifiers};
use tapeshape::link::{Disconnect, LinkCounters, LinkEvent};
use tapeshape::services::{CheckOutcome, EstimateEvent, EstimateSummary, ResultRow, Silhouettes};
use tapeshape::session::{allowed_errors, CarefulView};
use tapeshape::store::{
    ReadingId, ReadingSource, Session, SessionId, SessionStatus, SessionSummary, StoredReading,
    TapeOrigin,
};
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

// The apps the snapshot tests (English `tui_screens`, German
// `tui_german`) draw.

/// A session with stature and chest taken and waist current.
pub fn measuring() -> App {
    let mut a = app(false);
    connect(&mut a);
    open_session(&mut a, &[]);
    take(&mut a, 0, "stature", 17_650);
    take(&mut a, 1, "chest", 9_820);
    live(&mut a, 8_374);
    a
}

/// Session 3 on the quick set in careful mode, nothing taken yet.
pub fn open_careful(app: &mut App) {
    send(
        app,
        [Event::SessionReady(SessionView {
            id: SessionId(3),
            customer: "c-test".into(),
            set: "quick".into(),
            notes: Some("sex: female, age: 34".into()),
            measurements: quick(),
            readings: Vec::new(),
            superseded: Vec::new(),
            marks: Vec::new(),
            estimate: None,
            careful: Some(CarefulView {
                allowed: allowed_errors("quick").unwrap(),
                chains: Vec::new(),
            }),
            status: SessionStatus::Open,
        })],
    );
}

/// A body-like figure in metres (station frame): head, torso, arms, legs
/// as filled ellipses, sampled on a 1 cm grid. A rendering fixture, not an
/// estimate.
pub fn figure() -> Silhouettes {
    let parts_front: [(f64, f64, f64, f64); 6] = [
        (0.0, 1.62, 0.08, 0.11),   // head
        (0.0, 1.22, 0.17, 0.30),   // torso
        (-0.24, 1.18, 0.04, 0.28), // right arm
        (0.24, 1.18, 0.04, 0.28),  // left arm
        (-0.09, 0.45, 0.07, 0.45), // right leg
        (0.09, 0.45, 0.07, 0.45),  // left leg
    ];
    let parts_side: [(f64, f64, f64, f64); 3] = [
        (0.01, 1.62, 0.10, 0.11),
        (0.0, 1.22, 0.12, 0.30),
        (0.0, 0.45, 0.08, 0.45),
    ];
    let sample = |parts: &[(f64, f64, f64, f64)]| {
        let mut pts = Vec::new();
        for i in -40..=40 {
            for k in 0..=180 {
                let (x, z) = (f64::from(i) * 0.01, f64::from(k) * 0.01);
                if parts.iter().any(|(cx, cz, rx, rz)| {
                    ((x - cx) / rx).powi(2) + ((z - cz) / rz).powi(2) <= 1.0
                }) {
                    pts.push((x, z));
                }
            }
        }
        pts
    };
    Silhouettes {
        front: sample(&parts_front),
        side: sample(&parts_side),
    }
}

/// [`measuring`] estimated: the result screen of stature and chest.
pub fn result_app() -> App {
    let mut a = measuring();
    send(&mut a, [ch('e')]);
    send(
        &mut a,
        [Event::Estimate(EstimateEvent::Done(Box::new(
            EstimateSummary {
                session: SessionId(3),
                rows: vec![
                    ResultRow {
                        name: "stature".into(),
                        target_mm: 1765.0,
                        achieved_mm: 1764.6,
                    },
                    ResultRow {
                        name: "chest".into(),
                        target_mm: 982.0,
                        achieved_mm: 979.1,
                    },
                ],
                plausibility: "typical body (mahalanobis 6.5), readings typical (1.2)".into(),
                warnings: vec!["'chest' could not be fitted within 2 mm (error 2.9 mm)".into()],
                silhouettes: figure(),
                seconds: 0.41,
                sizes: Vec::new(),
            },
        )))],
    );
    a
}

/// Three stored sessions for the history: 3 open, 2 done, 1 abandoned.
pub fn summaries() -> Vec<SessionSummary> {
    let s = |id: i64, customer: &str, status, n, minute: i64| SessionSummary {
        session: Session {
            id: SessionId(id),
            customer_id: customer.into(),
            created_at_ms: 1_790_000_000_000 + minute * 60_000,
            updated_at_ms: 1_790_000_000_000 + minute * 60_000 + 180_000,
            status,
            measurement_set: Some("quick".into()),
            notes: None,
            consent: None,
        },
        current_readings: n,
        total_readings: n + 1,
        estimate_made_at_ms: None,
    };
    vec![
        s(3, "c-test", SessionStatus::Open, 2, 30),
        s(2, "c-8f3k2a", SessionStatus::Done, 9, 20),
        s(1, "c-0q9z7m", SessionStatus::Abandoned, 4, 10),
    ]
}
