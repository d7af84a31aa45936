//! Prediction: the paper's start, step 1 (over the weights) and step 2
//! (over the vertices), each a function of its own, with a report.
//!
//! Read with the paper (Wuhrer & Shu, sections Approach and Shape
//! Refinement) and `docs/prediction.md`:
//!
//! | paper | here |
//! |---|---|
//! | check the readings | [`ShapeModel::readings`] ([`readings`]) |
//! | start: feature analysis `w = B [P; 1]`, or the Gaussian conditional for a subset | [`ShapeModel::start`] ([`start`]) |
//! | clamp each normalised weight to `[-l, l]` | [`clamp::clamp_weights`] ([`clamp`]) |
//! | step 1: minimise `E_m` over the weights | [`ShapeModel::step1`] ([`step1`]) |
//! | step 2: minimise `(1 - lambda) E_m + lambda E_s` over the vertices | [`ShapeModel::step2`] ([`step2`]) |
//! | "solve the resulting optimization problem `s` times", recomputing paths and cut curves | the round driver of both steps ([`rounds`]) |
//! | the report (errors, plausibility) | [`ShapeModel::report`] ([`report`]) |
//!
//! [`ShapeModel::predict`] runs them in that order with a
//! [`PredictConfig`], which [`PredictSettings`] resolves into once
//! ([`settings`]: the record a report stores, and the per-stage
//! configuration, checked when built). [`PredictSettings::paper`] is the
//! paper's method exactly; the default departs from it where measurements
//! showed it must (the Gauss-Newton MAP step 1, per-measurement weighting,
//! the box inside step 1, continuation rounds), each documented where it is
//! set and measured in `docs/results/predict-iso.md` and
//! `docs/results/predict-sreal.md`.
//!
//! The optimiser works in millimetres (see the crate docs). Progress and
//! cancelling: [`progress`]. Robustness: a step that ends worse than it
//! started (each judged by its own objective) is undone with a warning; a
//! non-finite energy ends a solver run at its best point; a non-finite final
//! mesh is an error. Predictions are deterministic: the same inputs give
//! bit-identical vertices and reports (but for the stage times), whatever
//! the load, since every budget counts work, not time.

pub mod clamp;
mod folds;
mod measurer;
pub mod progress;
pub mod readings;
pub mod report;
pub mod rounds;
pub mod settings;
pub mod start;
pub mod step1;
pub mod step2;
mod terms;
pub mod warning;

use std::time::Instant;

use tapeshape_mesh::Topology;

pub use measurer::{MeasureError, Measurer};
pub use progress::{Control, PredictObserver, PredictProgress, PredictStage, Round, OBSERVE_EVERY};
pub use readings::{Reading, Readings};
pub use report::{
    chi2_quantile, triangle_changes, MeasurementReport, Plausibility, PlausibilityLabel,
    Prediction, PredictionReport, StageTimings,
};
pub use rounds::{RoundsStop, RoundsSummary};
pub use settings::{
    Continuation, EnergyWeighting, PredictConfig, PredictSettings, ReadingsConfig, ReportConfig,
    RoundsConfig, SettingsError, SmoothFit, StartConfig, Step1Clamp, Step1Config, Step1Settings,
    Step1Solver, Step2Config, Step2Settings, Step2Solver, Step2Weighting, DEFAULT_MAX_EVALUATIONS,
    DEFAULT_SMOOTH_MIN_DECREASE_MM, DEFAULT_SMOOTH_MODES, DEFAULT_SMOOTH_POLISH,
    DEFAULT_STEP1_CONTINUATION_ITERS, DEFAULT_STEP1_MIN_DECREASE_MM,
};
pub use start::{StartMethod, StartShape};
pub use step1::Step1Shape;
pub use step2::{Step2First, Step2Shape};
pub use warning::{Step1Objective, Warning};

use crate::{ModelError, Result, ShapeModel};
use progress::{no_observer, report as report_progress};

/// One measurement to fit: value and optional tolerance, metres.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Target {
    /// Target value, metres.
    pub value: f64,
    /// Standard uncertainty of the reading, metres (`None`: as trusted as
    /// [`PredictSettings::reference_tolerance`]).
    pub tolerance: Option<f64>,
    /// A soft target (a statistic for something nobody measured, e.g. what
    /// real people with the given readings have): fitted like a reading
    /// with its tolerance, but left out of the readings' plausibility and
    /// of the "could not be fitted" warnings.
    #[serde(default)]
    pub soft: bool,
}

impl Target {
    /// A reading trusted at the reference tolerance.
    pub fn exact(value: f64) -> Self {
        Self {
            value,
            tolerance: None,
            soft: false,
        }
    }

    /// A reading with a standard uncertainty `tolerance` (metres).
    pub fn with_tolerance(value: f64, tolerance: f64) -> Self {
        Self {
            value,
            tolerance: Some(tolerance),
            soft: false,
        }
    }

    /// A soft target with standard uncertainty `tolerance` (metres).
    pub fn soft(value: f64, tolerance: f64) -> Self {
        Self {
            value,
            tolerance: Some(tolerance),
            soft: true,
        }
    }
}

impl ShapeModel {
    /// Estimates a body from `targets` (one entry per model measurement, `None`
    /// where not given; metres) with the paper's method as `config` sets it.
    ///
    /// `measurer` measures meshes with the model's measurement set (same order);
    /// `topology` is the template's (V vertices). Returns the mesh (metres,
    /// station frame) and a report of every stage.
    ///
    /// Errors on bad input (wrong counts, non-positive or non-finite targets,
    /// targets that look like millimetres, no target at all), on a measurer
    /// failure, and if the result is not finite. An implausible but possible
    /// set of measurements gives a result with warnings and its plausibility.
    pub fn predict(
        &self,
        targets: &[Option<Target>],
        measurer: &dyn Measurer,
        topology: &Topology,
        config: &PredictConfig,
    ) -> Result<Prediction> {
        self.predict_observed(targets, measurer, topology, config, &no_observer)
    }

    /// [`ShapeModel::predict`] with progress reports and cancelling: the
    /// `observer` is called at every stage boundary and now and then inside
    /// the solver runs (see [`progress`]). If it answers [`Control::Cancel`],
    /// returns [`ModelError::Cancelled`] (naming the stage) before the next
    /// objective evaluation.
    pub fn predict_observed(
        &self,
        targets: &[Option<Target>],
        measurer: &dyn Measurer,
        topology: &Topology,
        config: &PredictConfig,
        observer: &dyn PredictObserver,
    ) -> Result<Prediction> {
        let t_total = Instant::now();
        let v = self.n_vertices();
        if topology.n_vertices() != v {
            return Err(ModelError::InvalidInput(format!(
                "topology has {} vertices, the model {v}",
                topology.n_vertices()
            )));
        }
        if measurer.n_measurements() != self.n_measurements() {
            return Err(ModelError::InvalidInput(format!(
                "the measurer has {} measurements, the model {}: use the set the model was trained with",
                measurer.n_measurements(),
                self.n_measurements()
            )));
        }
        let readings = self.readings(targets, config.readings())?;

        report_progress(observer, PredictProgress::at(PredictStage::Start))?;
        let t = Instant::now();
        let start = self.start(&readings, config.start(), measurer)?;
        let time_start = t.elapsed();

        let t = Instant::now();
        let step1 = self.step1(
            &readings,
            &start,
            config.step1(),
            config.rounds(),
            measurer,
            observer,
        )?;
        let smoothed = if config.step2().fold_repair {
            self.unfold_step1(&step1, &readings, measurer, topology)
        } else {
            None
        };
        let time_step1 = t.elapsed();

        let t = Instant::now();
        let step2_from = |step1: &Step1Shape, observer: &dyn PredictObserver| {
            self.step2(
                &readings,
                step1,
                config.step2(),
                config.rounds(),
                measurer,
                topology,
                observer,
            )
        };
        let (step1, step2) = match smoothed {
            None => {
                let step2 = step2_from(&step1, observer)?;
                (step1, step2)
            }
            Some(smooth) => {
                let from_smooth = step2_from(&smooth, observer)?;
                let missed = self.misses_allowable(&readings, &from_smooth, measurer);
                if missed == 0 {
                    (smooth, from_smooth)
                } else {
                    // The smoothed start may cost a reading the shape as
                    // step 1 left it meets (ANSUR II test-split subject
                    // 10304's waist depth with the `ansur` set): step 2
                    // from that shape too, kept where it meets more. It
                    // passes cancelling through but reports no progress
                    // (the fraction already reached step 2's end).
                    let quiet = |_: &PredictProgress| {
                        observer.observe(&PredictProgress::at(PredictStage::Step2))
                    };
                    let from_step1 = step2_from(&step1, &quiet)?;
                    if self.misses_allowable(&readings, &from_step1, measurer) < missed {
                        (step1, from_step1)
                    } else {
                        (smooth, from_smooth)
                    }
                }
            }
        };
        let time_step2 = t.elapsed();

        let mut report = self.report(
            &readings,
            &start,
            &step1,
            &step2,
            config,
            measurer,
            topology,
            StageTimings {
                start: time_start,
                step1: time_step1,
                step2: time_step2,
                total: Default::default(),
            },
        )?;
        report.timings.total = t_total.elapsed();
        // Reported last, so an observer's fraction reaches 1; too late to
        // cancel (the body is ready), so the answer is ignored.
        let _ = observer.observe(&PredictProgress::at(PredictStage::Done));
        Ok(Prediction {
            vertices: step2.vertices,
            report,
        })
    }
}
