//! Every screen rendered into ratatui's `TestBackend` at 80x24 (the
//! smallest kiosk terminal) and compared with a reviewed snapshot
//! (`tests/snapshots/`, insta). The app is driven into each state through
//! `update` only, as the runner drives it. A changed screen fails here
//! until the new snapshot is reviewed (`cargo insta review`).

mod tui_fixture;

use crossterm::event::KeyCode;
use ratatui::backend::TestBackend;
use ratatui::Terminal;
use tapeshape::link::LinkEvent;
use tapeshape::services::{EstimateEvent, EstimateSummary, ResultRow, Stage};
use tapeshape::session::ResumeOffer;
use tapeshape::store::SessionId;
use tapeshape::tui::app::{App, Event};
use tapeshape::tui::draw;
use tapeshape_protocol::Fault;
use tui_fixture::*;

fn render(app: &App) -> String {
    let mut t = Terminal::new(TestBackend::new(80, 24)).unwrap();
    t.draw(|f| draw(app, f)).unwrap();
    t.backend().to_string()
}

#[test]
fn new_customer() {
    let mut a = app(false);
    connect(&mut a);
    send(&mut a, [ch('f'), key(KeyCode::Down), ch('3'), ch('4')]);
    insta::assert_snapshot!(render(&a));
}

#[test]
fn new_customer_custom_set_file_with_error() {
    let mut a = app(false);
    send(
        &mut a,
        [
            key(KeyCode::Down),
            key(KeyCode::Down),
            key(KeyCode::Left),
            key(KeyCode::Down),
            key(KeyCode::Enter),
        ],
    );
    insta::assert_snapshot!(render(&a));
}

#[test]
fn resume_offer() {
    let mut a = app(false);
    connect(&mut a);
    send(
        &mut a,
        [Event::Resumable(ResumeOffer {
            session: SessionId(12),
            customer: "c-8f3k2a".into(),
            set: Some("quick".into()),
            readings: 4,
        })],
    );
    insta::assert_snapshot!(render(&a));
}

#[test]
fn measuring_screen() {
    insta::assert_snapshot!(render(&measuring()));
}

/// The live estimate's body beside the instructions once it is done.
#[test]
fn measuring_with_the_live_body() {
    let mut a = measuring();
    let generation = a.live.generation;
    send(
        &mut a,
        [Event::Live {
            generation,
            event: EstimateEvent::Done(Box::new(EstimateSummary {
                session: SessionId(3),
                rows: Vec::new(),
                plausibility: "typical".into(),
                warnings: Vec::new(),
                silhouettes: figure(),
                seconds: 0.2,
                sizes: Vec::new(),
            })),
        }],
    );
    insta::assert_snapshot!(render(&a));
}

#[test]
fn measuring_in_inches() {
    let mut a = measuring();
    send(&mut a, [ch('i')]);
    insta::assert_snapshot!(render(&a));
}

#[test]
fn flagged_reading() {
    let mut a = measuring();
    committed(&mut a, 2, "waist", 5_800);
    checked(
        &mut a,
        "waist",
        5_800,
        Some("waist 58.0 cm is 6 SD below what stature, chest predict (84.1 +/- 4.3 cm)"),
    );
    insta::assert_snapshot!(render(&a));
}

#[test]
fn unit_slip() {
    let mut a = measuring();
    committed(&mut a, 2, "waist", 3_300);
    send(
        &mut a,
        [Event::Checked {
            name: "waist".into(),
            value_tenth_mm: 3_300,
            outcome: tapeshape::services::CheckOutcome {
                unit_slip: Some(
                    "waist 33.0 cm fits 33.0 in (83.8 cm): check the tape's unit".into(),
                ),
                ..Default::default()
            },
        }],
    );
    insta::assert_snapshot!(render(&a));
}

#[test]
fn disconnected_while_measuring() {
    let mut a = measuring();
    unplug(&mut a);
    insta::assert_snapshot!(render(&a));
}

#[test]
fn device_screen_with_faults() {
    let mut a = measuring();
    send(
        &mut a,
        [
            Event::Link(LinkEvent::Fault(Fault::TapeSilent { silent_ms: 3200 })),
            Event::Link(LinkEvent::Fault(Fault::TapeRecovered)),
            ch('d'),
        ],
    );
    insta::assert_snapshot!(render(&a));
}

#[test]
fn device_screen_disconnected() {
    let mut a = measuring();
    unplug(&mut a);
    send(
        &mut a,
        [
            Event::Link(LinkEvent::WaitingForPort {
                error: tapeshape::link::PortError {
                    path: "/dev/ttyACM0".into(),
                    error: std::sync::Arc::new(tokio_serial::Error::new(
                        tokio_serial::ErrorKind::NoDevice,
                        "No such file or directory",
                    )),
                },
            }),
            ch('d'),
        ],
    );
    insta::assert_snapshot!(render(&a));
}

#[test]
fn estimating_progress() {
    let mut a = measuring();
    send(
        &mut a,
        [
            ch('e'),
            Event::Estimate(EstimateEvent::Stage {
                stage: Stage::Check,
                fraction: 0.0,
            }),
            Event::Estimate(EstimateEvent::Stage {
                stage: Stage::Start,
                fraction: 0.01,
            }),
            Event::Estimate(EstimateEvent::Stage {
                stage: Stage::Step1,
                fraction: 0.42,
            }),
        ],
    );
    insta::assert_snapshot!(render(&a));
}

#[test]
fn estimate_refused() {
    let mut a = measuring();
    send(
        &mut a,
        [
            ch('e'),
            Event::Estimate(EstimateEvent::Stage {
                stage: Stage::Check,
                fraction: 0.0,
            }),
            Event::Estimate(EstimateEvent::Failed(
                "readings contradict each other: chest 58.0 cm is 9 SD below what stature predicts (98.1 +/- 4.4 cm); re-take these readings".into(),
            )),
        ],
    );
    insta::assert_snapshot!(render(&a));
}

#[test]
fn result_screen() {
    insta::assert_snapshot!(render(&result_app()));
}

#[test]
fn result_screen_with_sizes() {
    let mut a = result_app();
    if let Some(s) = a.result.summary.as_mut() {
        s.sizes = vec![
            "shirt: M (50 %) or S".into(),
            "jacket: 50 (97 %)".into(),
            "trousers: W88/L84 (49 %) or W88/L80".into(),
        ];
    }
    insta::assert_snapshot!(render(&a));
}

/// Nine readings and three garments on an 80x24 terminal: the table keeps
/// every row (the sizes and the notes take what is left), as the demo's
/// quick set shows it.
#[test]
fn result_screen_with_sizes_keeps_every_row() {
    let mut a = result_app();
    // Names outside the session's set, so each row shows its name.
    let names = [
        "row_one",
        "row_two",
        "row_three",
        "row_four",
        "row_five",
        "row_six",
        "row_seven",
        "row_eight",
        "row_nine",
    ];
    if let Some(s) = a.result.summary.as_mut() {
        s.rows = names
            .iter()
            .enumerate()
            .map(|(i, n)| ResultRow {
                name: (*n).into(),
                target_mm: 500.0 + 10.0 * i as f64,
                achieved_mm: 500.0 + 10.0 * i as f64,
            })
            .collect();
        s.sizes = vec![
            "shirt: L (100 %)".into(),
            "jacket: 56 (94 %)".into(),
            "trousers: W84/L76 (63 %) or W88/L76".into(),
        ];
    }
    let screen = render(&a);
    for n in names {
        assert!(
            screen.lines().any(|l| l.contains(n)),
            "row {n} is not on the 80x24 result screen:\n{screen}"
        );
    }
    assert!(screen.contains("trousers: W84/L76"), "{screen}");
    assert!(screen.contains("plausibility"), "{screen}");
}

#[test]
fn result_screen_exported() {
    let mut a = result_app();
    send(
        &mut a,
        [
            ch('x'),
            Event::Exported(Ok(vec![
                "/var/lib/tapeshape/exports/c-test-session3.glb".into(),
                "/var/lib/tapeshape/exports/c-test-session3-report.json".into(),
            ])),
        ],
    );
    insta::assert_snapshot!(render(&a));
}

#[test]
fn history_screen() {
    let mut a = measuring();
    send(
        &mut a,
        [ch('h'), Event::History(summaries()), key(KeyCode::Down)],
    );
    insta::assert_snapshot!(render(&a));
}

#[test]
fn history_delete_asks_first() {
    let mut a = measuring();
    send(
        &mut a,
        [
            ch('h'),
            Event::History(summaries()),
            key(KeyCode::Down),
            key(KeyCode::Delete),
        ],
    );
    insta::assert_snapshot!(render(&a));
}

#[test]
fn help_overlay_in_the_demo() {
    let mut a = app(true);
    connect(&mut a);
    open_session(&mut a, &[]);
    // A person takes over (the autopilot turns their first key into
    // TakenOver), then opens the help.
    send(&mut a, [Event::TakenOver, ch('?')]);
    insta::assert_snapshot!(render(&a));
}

#[test]
fn monochrome_draws_without_colours() {
    use ratatui::style::Color;
    let mut a = measuring();
    a.mono = true;
    committed(&mut a, 2, "waist", 5_800);
    checked(&mut a, "waist", 5_800, Some("waist 58.0 cm is 6 SD below"));
    unplug(&mut a);
    let mut screens = vec![a.clone()];
    let mut r = result_app();
    r.mono = true;
    screens.push(r);
    for app in screens {
        let mut t = Terminal::new(TestBackend::new(80, 24)).unwrap();
        t.draw(|f| draw(&app, f)).unwrap();
        for cell in t.backend().buffer().content() {
            assert!(
                matches!(cell.fg, Color::Reset) && matches!(cell.bg, Color::Reset),
                "a coloured cell {:?} in monochrome",
                cell
            );
        }
    }
    // The same screen in colour does use colour (the check above can fail).
    let a = measuring();
    let mut t = Terminal::new(TestBackend::new(80, 24)).unwrap();
    t.draw(|f| draw(&a, f)).unwrap();
    assert!(t
        .backend()
        .buffer()
        .content()
        .iter()
        .any(|c| c.fg != Color::Reset || c.bg != Color::Reset));
}
