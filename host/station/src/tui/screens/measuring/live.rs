//! The live estimate: while the operator measures, the station estimates
//! the body from the readings accepted so far, in the background, and the
//! measuring screen shows its silhouette.
//!
//! Why: the body should be there the moment the last reading lands. After
//! every change of the accepted readings (a check passed, a flagged reading
//! kept, an undo) [`sync`] asks for a new estimate ([`Effect::LiveEstimate`],
//! numbered by a generation); the runner cancels the one still running
//! (the estimator stops within one objective evaluation). Answers of an
//! older generation are ignored. When the operator asks for the estimate
//! (`e`) and the live one of exactly these readings is done, the result
//! screen shows it at once; while it is still running, the runner adopts
//! it as the estimate (its progress becomes the estimating screen's), so
//! nothing is computed twice. The interface never waits: all of this is
//! effects and events.

use crate::services::{EstimateEvent, EstimateRequest, EstimateSummary};
use crate::store::SessionId;
use crate::tui::app::{App, Effect, Screen};
use crate::tui::screens::measuring::ItemState;

/// Readings as the live estimate keeps them: (name, millimetres).
pub type LiveReadings = Vec<(String, f64)>;

/// The live estimate's state (plain data, like the rest of the app).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct LiveEstimate {
    /// Number of the latest request; answers of other numbers are old.
    pub generation: u64,
    /// The session and readings (name, mm) of the latest request.
    pub session: Option<SessionId>,
    /// The readings of the latest request.
    pub readings: LiveReadings,
    /// The kept flagged readings of the latest request (keeping one asks
    /// for a new estimate: it may have been refused before).
    pub kept: Vec<String>,
    /// The latest request is running.
    pub running: bool,
    /// The latest finished estimate and the readings it was made from
    /// (shown while a newer one runs).
    pub shown: Option<(LiveReadings, Vec<String>, Box<EstimateSummary>)>,
    /// Why the latest request produced no body (the readings so far
    /// contradict each other, say).
    pub error: Option<String>,
}

impl LiveEstimate {
    /// The finished estimate of exactly `request` (its session, readings
    /// and kept readings), if there is one.
    pub fn ready(&self, request: &EstimateRequest) -> Option<&EstimateSummary> {
        self.shown
            .as_ref()
            .filter(|(r, k, s)| {
                s.session == request.session && *r == request.readings && *k == request.kept
            })
            .map(|(_, _, s)| s.as_ref())
    }
}

/// Asks for a new live estimate when the accepted readings changed (see
/// the module docs); called after every event.
pub fn sync(app: &mut App, fx: &mut Vec<Effect>) {
    let want = match (&app.session, app.screen) {
        (Some(s), Screen::Measuring) if !s.items.iter().any(|i| i.state == ItemState::Checking) => {
            Some(s.estimate_request())
        }
        (Some(_), _) => return, // keep what there is while elsewhere
        (None, _) => None,
    };
    let live = &mut app.live;
    match want {
        Some(request) if !request.readings.is_empty() => {
            let session = request.session;
            if live.session == Some(session)
                && live.readings == request.readings
                && live.kept == request.kept
            {
                return;
            }
            if live.session != Some(session) {
                live.shown = None;
            }
            live.generation += 1;
            live.session = Some(session);
            live.readings = request.readings.clone();
            live.kept = request.kept.clone();
            live.running = true;
            live.error = None;
            fx.push(Effect::LiveEstimate {
                generation: live.generation,
                request,
            });
        }
        _ => {
            if live.session.is_some() || live.running {
                if live.running {
                    fx.push(Effect::CancelLive);
                }
                let generation = live.generation + 1;
                *live = LiveEstimate {
                    generation,
                    ..LiveEstimate::default()
                };
            }
        }
    }
}

/// An answer of the live estimate number `generation`.
pub fn on_live(app: &mut App, generation: u64, event: EstimateEvent) {
    let live = &mut app.live;
    if generation != live.generation {
        return; // an older request's answer
    }
    match event {
        EstimateEvent::Stage { .. } => {}
        EstimateEvent::Done(summary) => {
            live.running = false;
            live.error = None;
            live.shown = Some((live.readings.clone(), live.kept.clone(), summary));
        }
        EstimateEvent::Failed(msg) => {
            live.running = false;
            live.error = Some(msg);
        }
        EstimateEvent::Cancelled => live.running = false,
    }
}
