//! The demo's simulated tape and simulated operator.
//!
//! Why: `tapeshape demo` must run a whole session by itself (for a visitor,
//! a screenshot, CI) and yet be the real program. The simulated tape
//! ([`SimTape`]) writes tape lines into the firmware harness's tape port,
//! pulling the tape out to the customer's true value and pressing hold, so
//! every reading takes the real path: firmware logic, pty, link, store. The
//! simulated operator ([`SimOperator`]) looks at the [`App`] on each tick and
//! answers with the keys a careful operator would press. [`Autopilot`] is
//! the demo's keyboard: it hands the simulated operator's keys to the app
//! until a person presses one, and then only the person's (the app hears of
//! the takeover as [`Event::TakenOver`], and knows nothing else of the
//! simulated operator).

use std::collections::HashMap;
use std::time::{Duration, Instant};

use crossterm::event::{KeyCode, KeyEvent};
use tapeshape_population::ansur::Sex;
use tapeshape_protocol::UnitShown;
use tapeshape_sim::pty::TtyStream;
use tapeshape_sim::tape::{play, Script, Step, TapeLine, TapeTiming};
use tokio::io::AsyncWriteExt;
use tokio::sync::mpsc;

use crate::i18n::tr;
use crate::tui::app::{App, Event, FormField, Item, ItemState, Screen};

/// The simulated tape could not measure.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum SimTapeError {
    /// The simulated customer has no value for the measurement.
    #[error("the simulated customer has no value for {0}; take it with Enter instead")]
    NoValue(String),
    /// The simulated tape's task ended.
    #[error("the simulated tape stopped; start the demo again")]
    Stopped,
}

/// The simulated tape: measures a named measurement on the simulated
/// customer when asked.
#[derive(Clone, Debug)]
pub struct SimTape {
    values: HashMap<String, u32>,
    tx: mpsc::UnboundedSender<u32>,
}

impl SimTape {
    /// Starts the tape on `port` (the harness's tape port), with the
    /// customer's true values (name -> tenths of a mm). `speedup` divides
    /// the tape's timing (1.5 s pull at 1.0). Must run inside a tokio
    /// runtime.
    pub fn start(mut port: TtyStream, values: HashMap<String, u32>, speedup: f64) -> Self {
        let (tx, mut rx) = mpsc::unbounded_channel::<u32>();
        tokio::spawn(async move {
            let heartbeat = TapeLine {
                value_tenth_mm: 0,
                confirmed: false,
                unit: UnitShown::Metric,
            }
            .to_bytes()
            .unwrap_or_default();
            loop {
                match tokio::time::timeout(Duration::from_millis(800), rx.recv()).await {
                    Ok(Some(v)) => {
                        let script = Script {
                            steps: vec![
                                Step::Pull {
                                    to_tenth_mm: v,
                                    over: Duration::from_millis(1500),
                                },
                                Step::Hold,
                                Step::Pull {
                                    to_tenth_mm: 0,
                                    over: Duration::from_millis(300),
                                },
                            ],
                        };
                        let Ok(timeline) = script.timeline(TapeTiming::default()) else {
                            continue;
                        };
                        if play(&timeline, speedup, &mut port, |_| {}).await.is_err() {
                            break;
                        }
                    }
                    Ok(None) => break,
                    // Idle: a real tape sends a heartbeat now and then.
                    Err(_) => {
                        if port.write_all(&heartbeat).await.is_err() {
                            break;
                        }
                    }
                }
            }
        });
        Self { values, tx }
    }

    /// The customer's true value of `name`, tenths of a mm.
    pub fn truth(&self, name: &str) -> Option<u32> {
        self.values.get(name).copied()
    }

    /// Pulls the tape to the customer's `name` and holds. With `slip`, the
    /// value is read off the inch scale as if it were centimetres (a unit
    /// slip, to show the check at work).
    pub fn measure(&self, name: &str, slip: bool) -> Result<(), SimTapeError> {
        let v = self
            .truth(name)
            .ok_or_else(|| SimTapeError::NoValue(name.to_string()))?;
        let v = if slip {
            (f64::from(v) / 2.54).round() as u32
        } else {
            v
        };
        self.tx.send(v).map_err(|_| SimTapeError::Stopped)
    }
}

/// The simulated operator's plan: what it does next given the app.
#[derive(Debug)]
pub struct SimOperator {
    sex: Option<Sex>,
    pace: Duration,
    last: Option<Instant>,
    /// Item being measured, its value then, and when the tape was asked.
    waiting: Option<(String, Option<u32>, Instant)>,
    /// Items already retaken once after a flag.
    retaken: Vec<String>,
    exported: bool,
    sex_set: bool,
    /// When the resume offer was first seen.
    resume_seen: Option<Instant>,
}

impl SimOperator {
    /// An operator for a customer of `sex` (`None`: not given), acting at
    /// most every `pace`.
    pub fn new(sex: Option<Sex>, pace: Duration) -> Self {
        Self {
            sex,
            pace,
            last: None,
            waiting: None,
            retaken: Vec::new(),
            exported: false,
            sex_set: false,
            resume_seen: None,
        }
    }

    /// The keys to press now (none most ticks).
    pub fn next(&mut self, app: &App, now: Instant) -> Vec<Event> {
        if self.last.is_some_and(|t| now.duration_since(t) < self.pace) {
            return Vec::new();
        }
        let key = self.decide(app, now);
        match key {
            Some(k) => {
                self.last = Some(now);
                vec![Event::Key(KeyEvent::from(k))]
            }
            None => Vec::new(),
        }
    }

    fn decide(&mut self, app: &App, now: Instant) -> Option<KeyCode> {
        if app.help {
            return Some(KeyCode::Esc);
        }
        match app.screen {
            Screen::NewCustomer => {
                if app.form.resume.is_some() {
                    // Read the offer (2 s, as a person would), then carry
                    // on: the same customer is still there.
                    let seen = *self.resume_seen.get_or_insert(now);
                    if now.duration_since(seen) < Duration::from_secs(2) {
                        return None;
                    }
                    return Some(KeyCode::Char('y'));
                }
                if !self.sex_set {
                    if app.form.field != FormField::Sex {
                        return Some(KeyCode::Up);
                    }
                    self.sex_set = true;
                    return match self.sex {
                        Some(Sex::Female) => Some(KeyCode::Char('f')),
                        Some(Sex::Male) => Some(KeyCode::Char('m')),
                        None => None,
                    };
                }
                Some(KeyCode::Enter)
            }
            Screen::Measuring => {
                let s = app.session.as_ref()?;
                let Some(c) = s.current else {
                    return Some(KeyCode::Char('e'));
                };
                let item = &s.items[c];
                match item.state {
                    ItemState::Checking => None,
                    ItemState::Flagged => {
                        if self.retaken.contains(&item.info.name) {
                            Some(KeyCode::Enter)
                        } else if self.tape_free(item, now) {
                            self.retaken.push(item.info.name.clone());
                            self.waiting = Some((item.info.name.clone(), item.value, now));
                            Some(KeyCode::Char('m'))
                        } else {
                            None
                        }
                    }
                    _ => {
                        if self.tape_free(item, now) {
                            self.waiting = Some((item.info.name.clone(), item.value, now));
                            Some(KeyCode::Char('m'))
                        } else {
                            None
                        }
                    }
                }
            }
            Screen::Result if !self.exported => {
                self.exported = true;
                Some(KeyCode::Char('x'))
            }
            Screen::Device | Screen::History => Some(KeyCode::Esc),
            _ => None,
        }
    }

    /// True unless the tape was asked for `item` less than 10 s ago and its
    /// reading has not arrived yet.
    fn tape_free(&self, item: &Item, now: Instant) -> bool {
        match &self.waiting {
            Some((n, v, t)) => {
                n != &item.info.name
                    || *v != item.value
                    || now.duration_since(*t) >= Duration::from_secs(10)
            }
            None => true,
        }
    }
}

/// The demo's keyboard: the simulated operator's keys reach the app until a
/// person presses one; that first key only takes over (so a stray press does
/// nothing else), and from then on only the person's keys count.
#[derive(Debug)]
pub struct Autopilot {
    operator: SimOperator,
    person: bool,
}

impl Autopilot {
    /// The simulated operator at the keys.
    pub fn new(operator: SimOperator) -> Self {
        Self {
            operator,
            person: false,
        }
    }

    /// Does the simulated operator still have the keys?
    pub fn driving(&self) -> bool {
        !self.person
    }

    /// A key a person pressed, as the app should hear it.
    pub fn person_key(&mut self, key: KeyEvent) -> Event {
        if self.person {
            Event::Key(key)
        } else {
            self.person = true;
            Event::TakenOver
        }
    }

    /// The simulated operator's keys for this tick (none once a person took over).
    pub fn tick(&mut self, app: &App, now: Instant) -> Vec<Event> {
        if self.person {
            Vec::new()
        } else {
            self.operator.next(app, now)
        }
    }
}

/// The demo as the runner drives it ([`crate::tui::runner::Demo`]): the
/// simulated tape and the keyboard the simulated operator holds.
#[derive(Debug)]
pub struct SimDemo {
    /// The simulated tape.
    pub tape: SimTape,
    /// The keyboard.
    pub pilot: Autopilot,
}

impl crate::tui::runner::Demo for SimDemo {
    fn person_key(&mut self, key: KeyEvent) -> Event {
        self.pilot.person_key(key)
    }

    fn tick(&mut self, app: &App, now: Instant) -> Vec<Event> {
        self.pilot.tick(app, now)
    }

    fn measure(&self, name: &str, slip: bool) -> Result<(), String> {
        // The operator's words for it (the error's own are English, for logs).
        self.tape.measure(name, slip).map_err(|e| match e {
            SimTapeError::NoValue(name) => tr!("sim-no-value", name = name),
            SimTapeError::Stopped => tr!("sim-stopped"),
        })
    }
}
