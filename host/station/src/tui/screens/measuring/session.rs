//! The measuring screen's state: the session being measured, item by item,
//! and what happens to it when a session is opened, a reading is stored and
//! a check answers.

use tapeshape_estimator::Unit;
use tapeshape_protocol::UnitShown;

use crate::i18n::{self, tr};
use crate::services::{CheckOutcome, CheckRequest, EstimateRequest};
use crate::session::careful::{self, Round, Tem};
use crate::session::{MeasurementInfo, SessionView};
use crate::store::{Mark, ReadingId, SessionId, SessionStatus, StoredReading};
use crate::tui::app::{AfterOpen, App, Effect, Level, Screen, ShowLength as _};
use crate::tui::screens::estimating::EstimateState;
use crate::tui::screens::result::ResultScreen;

/// State of one measurement in the session.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ItemState {
    /// Not taken yet.
    Todo,
    /// Taken; the check is running.
    Checking,
    /// Taken and accepted.
    Done,
    /// Taken, but the check found it far off: measure again or keep (Enter).
    Flagged,
    /// Skipped by the operator.
    Skipped,
}

/// One measurement of the session.
#[derive(Clone, Debug, PartialEq)]
pub struct Item {
    /// Set entry.
    pub info: MeasurementInfo,
    /// State.
    pub state: ItemState,
    /// The reading in use (tenths of a mm), if any.
    pub value: Option<u32>,
    /// Earlier readings of this measurement (retakes), oldest first.
    pub previous: Vec<u32>,
    /// The check's message (flag), if any.
    pub flag: Option<String>,
    /// The check's unit slip message, if any.
    pub unit_slip: Option<String>,
    /// The operator kept a flagged reading.
    pub kept_flagged: bool,
    /// Careful mode: its readings and allowable error (`None`: the session
    /// takes each measurement once). `value` is then the kept value.
    pub careful: Option<CarefulItem>,
}

/// A measurement of a careful session (see `crate::session::careful`).
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct CarefulItem {
    /// Allowable difference of the first two readings of a round, tenths
    /// of a mm (`None`: the set does not know the measurement).
    pub allowed: Option<u32>,
    /// Its readings, oldest first (the store's chain: undone ones left out).
    pub chain: Vec<u32>,
}

impl CarefulItem {
    /// The round the next reading goes to.
    pub fn open_round(&self) -> Round {
        careful::open_round(&self.chain, self.allowed)
    }
}

impl Item {
    /// Careful mode: the line that tells the operator which reading is
    /// expected ("reading 2 of 2", "third reading needed: the two differ by
    /// 7 mm (allowed 5 mm)"), or what was kept; `None` outside careful mode.
    pub fn careful_status(&self, unit: Unit) -> Option<String> {
        let c = self.careful.as_ref()?;
        let round = c.open_round();
        let shown: Vec<String> = round.readings.iter().map(|v| unit.format(*v)).collect();
        Some(match (round.readings.len(), round.apart(), c.allowed) {
            (2, Some(apart), Some(allowed)) => tr!(
                "careful-third-needed",
                apart = difference(unit, apart),
                allowed = difference(unit, allowed)
            ),
            (0, _, _) => match (self.value, careful::rounds(&c.chain, c.allowed).last()) {
                (Some(v), Some(last)) => tr!(
                    "careful-kept",
                    value = unit.format(v),
                    readings = last
                        .readings
                        .iter()
                        .map(|r| unit.format(*r))
                        .collect::<Vec<_>>()
                        .join(", ")
                ),
                _ => tr!("careful-first", needed = round.needed()),
            },
            (n, _, _) => tr!(
                "careful-next",
                n = n + 1,
                needed = round.needed(),
                so_far = shown.join(", ")
            ),
        })
    }

    /// Careful mode: the round's two readings differ by more than the
    /// allowable error, so a third is needed (the status line warns).
    pub fn careful_third_needed(&self) -> bool {
        self.careful.as_ref().is_some_and(|c| {
            let round = c.open_round();
            round.readings.len() == 2 && round.apart().is_some() && c.allowed.is_some()
        })
    }
}

/// What undoing a step changes in the store, so that a resumed session
/// looks as the operator left it.
#[derive(Clone, Debug, PartialEq)]
pub enum StoreRevert {
    /// Withdraw this reading (it stays in the history).
    Withdraw(ReadingId),
    /// Set this measurement's mark back to this.
    Mark(String, Option<Mark>),
}

/// An operator step that `u` undoes.
#[derive(Clone, Debug, PartialEq)]
pub struct UndoEntry {
    /// What it was, in words (for the notice).
    pub what: String,
    /// What undoing it changes in the store.
    pub reverts: Vec<StoreRevert>,
    /// Item index and its state before the step.
    pub item: Option<(usize, Item)>,
    /// The current measurement before the step.
    pub current: Option<usize>,
}

/// The session being measured.
#[derive(Clone, Debug, PartialEq)]
pub struct SessionState {
    /// Session id.
    pub id: SessionId,
    /// Customer id.
    pub customer: String,
    /// Measurement set.
    pub set: String,
    /// Notes (sex, age).
    pub notes: Option<String>,
    /// The measurements.
    pub items: Vec<Item>,
    /// The one the tape's next reading goes to.
    pub current: Option<usize>,
    /// Cursor in the list.
    pub selected: usize,
    /// Undo stack.
    pub undo: Vec<UndoEntry>,
    /// The session is closed (marked done after an export, or opened only
    /// to look at it); going back to measuring opens it again, or the store
    /// would refuse new readings.
    pub marked_done: bool,
    /// Careful mode: each measurement taken twice (a third time when the
    /// two are apart), the median kept.
    pub careful: bool,
}

impl SessionState {
    /// Readings used for an estimate (name, millimetres): done and flagged
    /// ones, not skipped or undone.
    pub fn accepted(&self) -> Vec<(String, f64)> {
        self.items
            .iter()
            .filter(|i| matches!(i.state, ItemState::Done | ItemState::Flagged))
            .filter_map(|i| i.value.map(|v| (i.info.name.clone(), f64::from(v) / 10.0)))
            .collect()
    }

    /// The estimate request for these readings: the customer's sex from
    /// the session notes and the flagged readings the operator kept.
    pub fn estimate_request(&self) -> EstimateRequest {
        EstimateRequest {
            session: self.id,
            readings: self.accepted(),
            sex: crate::tui::screens::new_customer::sex_of_notes(self.notes.as_deref()),
            kept: self
                .items
                .iter()
                .filter(|i| i.kept_flagged && i.value.is_some())
                .map(|i| i.info.name.clone())
                .collect(),
        }
    }

    /// Careful mode: the session's TEM over every measurement's pairs
    /// (`crate::session::careful::tem`), if any measurement was taken twice.
    pub fn careful_tem(&self) -> Option<Tem> {
        let pairs: Vec<(u32, u32)> = self
            .items
            .iter()
            .filter_map(|i| i.careful.as_ref())
            .flat_map(|c| careful::rounds(&c.chain, c.allowed))
            .filter_map(|r| r.pair())
            .collect();
        careful::tem(&pairs)
    }

    /// Count of items in `state`.
    pub fn count(&self, state: ItemState) -> usize {
        self.items.iter().filter(|i| i.state == state).count()
    }

    pub(super) fn index_of(&self, name: &str) -> Option<usize> {
        self.items.iter().position(|i| i.info.name == name)
    }

    /// The next measurement still to take after `from` (wrapping), if any.
    pub(super) fn next_todo(&self, from: Option<usize>) -> Option<usize> {
        let n = self.items.len();
        let start = from.map_or(0, |i| i + 1);
        (0..n)
            .map(|k| (start + k) % n)
            .find(|&i| self.items[i].state == ItemState::Todo)
    }
}

/// A small difference (tenths of a mm) as the careful status shows it: in
/// millimetres (a tenth only when there is one), or inches on an inch tape.
fn difference(unit: Unit, tenth_mm: u32) -> String {
    match unit {
        Unit::In => unit.format(tenth_mm),
        _ if tenth_mm.is_multiple_of(10) => format!("{} mm", tenth_mm / 10),
        _ => format!("{:.1} mm", f64::from(tenth_mm) / 10.0),
    }
}

/// The mark the store keeps for an item in this state, if any.
pub(super) fn stored_mark(item: &Item) -> Option<Mark> {
    if item.state == ItemState::Skipped {
        Some(Mark::Skipped)
    } else if item.kept_flagged {
        Some(Mark::KeptFlagged)
    } else {
        None
    }
}

/// Clears `item`'s stored `mark` (a new reading or a retake replaces a skip
/// or a kept flag): asks the store to drop it and puts what sets it back on
/// `reverts`, for `u`.
pub(super) fn clear_mark(
    session: SessionId,
    item: &Item,
    mark: Mark,
    reverts: &mut Vec<StoreRevert>,
    fx: &mut Vec<Effect>,
) {
    reverts.push(StoreRevert::Mark(item.info.name.clone(), Some(mark)));
    fx.push(Effect::SetMark {
        session,
        name: item.info.name.clone(),
        mark: None,
    });
}

/// The unit the tape showed, as the check takes it.
fn tape_unit(shown: UnitShown) -> Unit {
    match shown {
        UnitShown::Metric => Unit::Cm,
        UnitShown::Imperial => Unit::In,
    }
}

/// A session was created or opened: it becomes the one measured.
pub fn on_session_ready(app: &mut App, view: SessionView, fx: &mut Vec<Effect>) {
    let careful_session = view.careful.is_some();
    let set = view.set.clone();
    let mut items: Vec<Item> = view
        .measurements
        .into_iter()
        .map(|info| MeasurementInfo {
            // The operator's name and instruction in the chosen language
            // where the catalogue has them (the quick set), else the set
            // file's: every place the kiosk shows them reads these.
            label: i18n::measurement_label(&set, &info.name, &info.label),
            description: i18n::measurement_instruction(&set, &info.name, &info.description),
            name: info.name,
        })
        .map(|info| Item {
            state: ItemState::Todo,
            value: None,
            previous: Vec::new(),
            flag: None,
            unit_slip: None,
            kept_flagged: false,
            careful: view.careful.as_ref().map(|c| CarefulItem {
                allowed: c.allowed_of(&info.name),
                chain: c.chain_of(&info.name).to_vec(),
            }),
            info,
        })
        .collect();
    for (name, v) in &view.superseded {
        if let Some(i) = items.iter_mut().find(|i| &i.info.name == name) {
            i.previous.push(*v);
        }
    }
    let mut unknown = Vec::new();
    for (name, v) in &view.readings {
        match items.iter_mut().find(|i| &i.info.name == name) {
            Some(i) => {
                i.value = Some(*v);
                i.state = ItemState::Done;
            }
            None => unknown.push(name.clone()),
        }
    }
    for (name, mark) in &view.marks {
        if let Some(i) = items.iter_mut().find(|i| &i.info.name == name) {
            match mark {
                Mark::Skipped if i.value.is_none() => i.state = ItemState::Skipped,
                Mark::KeptFlagged if i.value.is_some() => i.kept_flagged = true,
                _ => {}
            }
        }
    }
    let resumed = view.readings.len();
    let mut s = SessionState {
        id: view.id,
        customer: view.customer,
        set: view.set,
        notes: view.notes,
        items,
        current: None,
        selected: 0,
        undo: Vec::new(),
        // A closed session (opened to look at it) opens again when the
        // operator goes back to measuring it.
        marked_done: view.status != SessionStatus::Open,
        careful: careful_session,
    };
    // A careful measurement left between its readings comes first.
    s.current = s
        .items
        .iter()
        .position(|i| {
            i.careful
                .as_ref()
                .is_some_and(|c| !c.open_round().readings.is_empty())
        })
        .or_else(|| s.next_todo(None));
    s.selected = s.current.unwrap_or(0);
    let id = s.id;
    app.session = Some(s);
    app.result = ResultScreen {
        format: app.result.format,
        ..ResultScreen::default()
    };
    app.estimate = EstimateState::default();
    app.form = app.form.next_customer();
    let after = app.after_open.take().unwrap_or(AfterOpen::Measure);
    app.screen = Screen::Measuring;
    if resumed > 0 {
        let text = if unknown.is_empty() {
            tr!("measuring-opened", id = id.to_string(), n = resumed)
        } else {
            tr!(
                "measuring-opened-unknown",
                id = id.to_string(),
                n = resumed,
                unknown = unknown.len(),
                names = unknown.join(", ")
            )
        };
        app.note(Level::Info, text);
    } else {
        app.notice = None;
    }
    let stored_current = view.estimate.is_some_and(|e| e.current);
    match after {
        AfterOpen::Measure => recheck_resumed(app, fx),
        AfterOpen::Estimate => start_estimate(app, fx, false),
        // The stored body is of these very readings: export it as it is.
        AfterOpen::Export if stored_current => {
            app.after_open = Some(AfterOpen::Export);
            fx.push(Effect::LoadResult(id));
        }
        AfterOpen::Export => start_estimate(app, fx, true),
        AfterOpen::ShowResult if view.estimate.is_some() => {
            app.result.stored = view.estimate;
            fx.push(Effect::LoadResult(id));
        }
        AfterOpen::ShowResult => app.note(
            Level::Info,
            tr!("measuring-no-stored-estimate", id = id.to_string()),
        ),
    }
}

/// A reading was stored (by the link from the tape, or typed with the
/// keyboard): it goes to its measurement, is checked, and can be undone.
pub fn on_reading_stored(
    app: &mut App,
    reading: StoredReading,
    unit_shown: UnitShown,
    fx: &mut Vec<Effect>,
) {
    let Some(s) = app.session.as_mut() else {
        return;
    };
    if reading.session_id != s.id {
        return;
    }
    let v = reading.value_tenth_mm;
    let Some(i) = s.index_of(&reading.measurement) else {
        let text = tr!(
            "measuring-stored-not-in-set",
            value = app.unit.format(v),
            name = reading.measurement.clone()
        );
        app.note(Level::Warn, text);
        return;
    };
    let before = s.items[i].clone();
    let mut reverts = vec![StoreRevert::Withdraw(reading.id)];
    // Careful mode: the reading joins its round; only a finished round's
    // median goes on as the measurement's value (checked, estimated).
    let mut v = v;
    if let Some(c) = s.items[i].careful.as_mut() {
        c.chain.push(v);
        let rounds = careful::rounds(&c.chain, c.allowed);
        let round = rounds.last().cloned().unwrap_or(Round {
            readings: Vec::new(),
            allowed: c.allowed,
        });
        match round.kept() {
            Some(kept) => v = kept,
            None => {
                let mut reverts = reverts;
                if before.state == ItemState::Skipped {
                    clear_mark(s.id, &before, Mark::Skipped, &mut reverts, fx);
                    s.items[i].state = ItemState::Todo;
                }
                s.undo.push(UndoEntry {
                    what: tr!("measuring-undo-reading", name = before.info.label.clone()),
                    reverts,
                    item: Some((i, before)),
                    current: s.current,
                });
                s.current = Some(i);
                s.selected = i;
                let item = &s.items[i];
                let label = item.info.label.clone();
                let status = item.careful_status(app.unit).unwrap_or_default();
                let stored = app.unit.format(reading.value_tenth_mm);
                let level = if round.readings.len() >= 2 {
                    Level::Warn
                } else {
                    Level::Info
                };
                app.note(
                    level,
                    tr!(
                        "measuring-stored-careful-again",
                        name = label,
                        value = stored,
                        status = status
                    ),
                );
                return;
            }
        }
    }
    if let Some(mark) = stored_mark(&before) {
        // A new reading replaces a skip or a kept flag.
        clear_mark(s.id, &before, mark, &mut reverts, fx);
    }
    s.undo.push(UndoEntry {
        what: tr!("measuring-undo-reading", name = before.info.label.clone()),
        reverts,
        item: Some((i, before)),
        current: s.current,
    });
    let item = &mut s.items[i];
    if let Some(old) = item.value {
        item.previous.push(old);
    }
    item.value = Some(v);
    item.state = ItemState::Checking;
    item.flag = None;
    item.unit_slip = None;
    item.kept_flagged = false;
    let others = other_values(&s.items, i, |it| {
        matches!(it.state, ItemState::Done | ItemState::Flagged)
    });
    fx.push(Effect::Check(CheckRequest {
        set: s.set.clone(),
        name: reading.measurement.clone(),
        value_mm: f64::from(v) / 10.0,
        others,
        tape_unit: tape_unit(unit_shown),
    }));
    let label = s.items[i].info.label.clone();
    let was = s.items[i].previous.last().copied();
    let mut text = match s.items[i].careful.as_ref() {
        Some(_) => tr!(
            "measuring-stored-careful-kept",
            name = label,
            value = app.unit.format(reading.value_tenth_mm),
            kept = app.unit.format(v)
        ),
        None => tr!("measuring-stored", name = label, value = app.unit.format(v)),
    };
    if let Some(w) = was {
        let was = tr!("measuring-stored-retake", was = app.unit.format(w));
        text.push_str(&format!(" ({was})"));
    }
    if unit_shown == UnitShown::Imperial {
        text.push_str(&format!(" ({})", tr!("measuring-stored-inches")));
    }
    app.note(Level::Info, text);
}

/// A reading flagged before a restart, and that the operator had not
/// answered (kept with Enter, or retaken), must come back flagged: the
/// store keeps only answers (`Mark::KeptFlagged`), so every resumed reading
/// without that mark is checked again against the other resumed readings.
/// The check depends only on the values, so a reading that passed passes
/// again; the tape's unit at capture is not stored, so a unit slip is looked
/// for as on a metric tape.
fn recheck_resumed(app: &mut App, fx: &mut Vec<Effect>) {
    let Some(s) = app.session.as_mut() else {
        return;
    };
    let taken: Vec<(usize, u32)> = s
        .items
        .iter()
        .enumerate()
        .filter(|(_, it)| it.state == ItemState::Done && !it.kept_flagged)
        .filter_map(|(k, it)| it.value.map(|v| (k, v)))
        .collect();
    for &(i, v) in &taken {
        let others = other_values(&s.items, i, |_| true);
        fx.push(Effect::Check(CheckRequest {
            set: s.set.clone(),
            name: s.items[i].info.name.clone(),
            value_mm: f64::from(v) / 10.0,
            others,
            tape_unit: Unit::Cm,
        }));
    }
    for &(i, _) in &taken {
        s.items[i].state = ItemState::Checking;
    }
}

/// The values (mm) of the items other than `i` that have one and pass
/// `include`: what a reading is checked against.
fn other_values(items: &[Item], i: usize, include: impl Fn(&Item) -> bool) -> Vec<(String, f64)> {
    items
        .iter()
        .enumerate()
        .filter(|(k, it)| *k != i && include(it))
        .filter_map(|(_, it)| {
            it.value
                .map(|v| (it.info.name.clone(), f64::from(v) / 10.0))
        })
        .collect()
}

/// The check of a reading answered.
pub fn on_checked(app: &mut App, name: &str, value_tenth_mm: u32, outcome: CheckOutcome) {
    let Some(s) = app.session.as_mut() else {
        return;
    };
    let Some(i) = s.index_of(name) else { return };
    let item = &mut s.items[i];
    if item.value != Some(value_tenth_mm) || item.state != ItemState::Checking {
        return; // retaken or undone meanwhile
    }
    item.flag = outcome.flag;
    item.unit_slip = outcome.unit_slip;
    if item.flag.is_some() || item.unit_slip.is_some() {
        item.state = ItemState::Flagged;
        s.current = Some(i);
        s.selected = i;
        let label = item.info.label.clone();
        let text = if item.flag.is_some() {
            tr!("measuring-flag-far-off", name = label)
        } else {
            tr!("measuring-flag-unit-slip", name = label)
        };
        app.note(Level::Warn, text);
    } else {
        item.state = ItemState::Done;
        let note = outcome.note;
        if s.current == Some(i) {
            advance(app);
        }
        if let Some(n) = note {
            app.note(Level::Warn, n);
        }
    }
}

/// Moves the current measurement to the next one still to take.
pub(super) fn advance(app: &mut App) {
    let Some(s) = app.session.as_mut() else {
        return;
    };
    s.current = s.next_todo(s.current);
    if let Some(c) = s.current {
        s.selected = c;
    } else {
        let skipped = s.count(ItemState::Skipped);
        let flagged = s.count(ItemState::Flagged);
        let text = match (skipped, flagged) {
            (0, 0) => tr!("measuring-all-taken"),
            _ => tr!(
                "measuring-all-taken-marked",
                skipped = skipped,
                flagged = flagged
            ),
        };
        app.note(Level::Info, text);
    }
}

/// Starts an estimate of the accepted readings (then an export, if asked).
pub(super) fn start_estimate(app: &mut App, fx: &mut Vec<Effect>, then_export: bool) {
    let Some(s) = &app.session else { return };
    let request = s.estimate_request();
    if request.readings.is_empty() {
        app.note(Level::Warn, tr!("measuring-no-readings"));
        app.screen = Screen::Measuring;
        return;
    }
    if s.items.iter().any(|i| i.state == ItemState::Checking) {
        app.note(Level::Info, tr!("measuring-still-checking"));
        return;
    }
    let session = s.id;
    // The live estimate of exactly these readings is done: no waiting.
    if let Some(summary) = app.live.ready(&request) {
        app.result.summary = Some(summary.clone());
        app.result.exported = None;
        app.result.card = None;
        app.result.stored = None;
        app.estimate = EstimateState::default();
        app.notice = None;
        app.screen = Screen::Result;
        if then_export {
            fx.push(Effect::Export {
                session,
                format: app.result.format,
            });
        }
        return;
    }
    app.estimate = EstimateState {
        running: true,
        ..EstimateState::default()
    };
    app.after_open = then_export.then_some(AfterOpen::Export);
    app.screen = Screen::Estimating;
    app.notice = None;
    fx.push(Effect::StartEstimate(request));
}
