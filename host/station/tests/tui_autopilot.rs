//! The demo's simulated operator drives the app from a new customer to an
//! exported body by itself, and stops at the first key a person presses.
//! The effects are answered here as the runner, tape, check and estimate
//! would answer them.

mod tui_fixture;

use std::time::{Duration, Instant};

use crossterm::event::{KeyCode, KeyEvent};
use tapeshape::services::{EstimateEvent, EstimateSummary};
use tapeshape::store::{ReadingSource, SessionId, TapeOrigin};
use tapeshape::tui::app::{App, Effect, Event, Screen, SessionView};
use tapeshape::tui::operator::{Autopilot, SimOperator};
use tapeshape::tui::update;
use tapeshape_population::ansur::Sex;
use tui_fixture::*;

/// Plays the runner: performs `fx` with fixtures, returning the answers.
fn answer(fx: Vec<Effect>, seq: &mut u32, log: &mut Vec<Effect>) -> Vec<Event> {
    let mut out = Vec::new();
    for e in fx {
        log.push(e.clone());
        match e {
            Effect::CreateSession {
                customer,
                set,
                notes,
                ..
            } => out.push(Event::SessionReady(SessionView {
                id: SessionId(1),
                customer,
                set,
                notes,
                measurements: quick(),
                readings: Vec::new(),
                superseded: Vec::new(),
                marks: Vec::new(),
                estimate: None,
                careful: None,
                status: tapeshape::store::SessionStatus::Open,
            })),
            Effect::SimTape { name, slip } => {
                assert!(!slip);
                // A true value per measurement: 100 cm + 1 cm per letter.
                let v = 10_000 + 100 * name.len() as u32;
                out.push(Event::Link(tapeshape::link::LinkEvent::ReadingCommitted {
                    reading: tapeshape::store::StoredReading {
                        id: tapeshape::store::ReadingId(i64::from(*seq)),
                        session_id: SessionId(1),
                        measurement: name.clone(),
                        value_tenth_mm: v,
                        source: ReadingSource::Tape(TapeOrigin {
                            device_id: DEVICE,
                            boot_id: 1,
                            seq: *seq,
                            device_time_ms: 0,
                        }),
                        received_at_ms: 0,
                        superseded_by: None,
                        withdrawn_at_ms: None,
                    },
                    unit_shown: tapeshape_protocol::UnitShown::Metric,
                }));
                *seq += 1;
            }
            Effect::Check(req) => out.push(Event::Checked {
                name: req.name.clone(),
                value_tenth_mm: (req.value_mm * 10.0).round() as u32,
                outcome: Default::default(),
            }),
            Effect::StartEstimate(request) => out.push(Event::Estimate(EstimateEvent::Done(
                Box::new(EstimateSummary {
                    session: request.session,
                    rows: Vec::new(),
                    plausibility: "typical".into(),
                    warnings: Vec::new(),
                    silhouettes: Default::default(),
                    seconds: 0.1,
                    sizes: Vec::new(),
                }),
            ))),
            Effect::Export { .. } => out.push(Event::Exported(Ok(vec!["/x/body.glb".into()]))),
            _ => {}
        }
    }
    out
}

fn drive(app: &mut App, pilot: &mut Autopilot, steps: usize, log: &mut Vec<Effect>) {
    let mut now = Instant::now();
    let mut seq = 0;
    for _ in 0..steps {
        now += Duration::from_millis(500);
        let mut queue: Vec<Event> = pilot.tick(app, now);
        while let Some(ev) = queue.pop() {
            let fx = update(app, ev);
            queue.extend(answer(fx, &mut seq, log));
        }
    }
}

#[test]
fn the_simulated_operator_runs_a_session_to_an_export() {
    let mut a = app(true);
    connect(&mut a);
    let mut pilot = Autopilot::new(SimOperator::new(
        Some(Sex::Male),
        Duration::from_millis(400),
    ));
    let mut log = Vec::new();
    drive(&mut a, &mut pilot, 200, &mut log);
    assert_eq!(a.screen, Screen::Result);
    assert!(
        a.result.exported.is_some(),
        "the operator exports the result"
    );
    let created = log
        .iter()
        .find_map(|e| match e {
            Effect::CreateSession { notes, .. } => notes.clone(),
            _ => None,
        })
        .unwrap();
    assert_eq!(created, "sex: male");
    let measured: Vec<String> = log
        .iter()
        .filter_map(|e| match e {
            Effect::SimTape { name, .. } => Some(name.clone()),
            _ => None,
        })
        .collect();
    let names: Vec<String> = quick().into_iter().map(|m| m.name).collect();
    assert_eq!(measured, names, "each measurement once, in order");
}

#[test]
fn a_key_press_stops_the_simulated_operator() {
    let mut a = app(true);
    connect(&mut a);
    let mut pilot = Autopilot::new(SimOperator::new(
        Some(Sex::Female),
        Duration::from_millis(400),
    ));
    let mut log = Vec::new();
    drive(&mut a, &mut pilot, 5, &mut log);
    assert_eq!(a.screen, Screen::Measuring);
    let key = pilot.person_key(KeyEvent::from(KeyCode::Char('z')));
    send(&mut a, [key]);
    let before = a.session.as_ref().unwrap().accepted().len();
    assert!(before >= 1, "the operator measured before the takeover");
    let n = log.len();
    drive(&mut a, &mut pilot, 50, &mut log);
    assert_eq!(a.screen, Screen::Measuring);
    assert_eq!(a.session.as_ref().unwrap().accepted().len(), before);
    assert!(
        !log[n..].iter().any(|e| matches!(e, Effect::SimTape { .. })),
        "no tape after the takeover"
    );
}
