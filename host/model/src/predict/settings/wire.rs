//! The serde forms of the settings: this version's, and the ones older
//! reports hold (the flat record of 18 fields; step 2's L-BFGS stopping
//! rule as `stop`), converted on reading (see the parent module's docs).

use serde::Deserialize;

use super::{
    Continuation, EnergyWeighting, PredictSettings, Step1Clamp, Step1Settings, Step1Solver,
    Step2Settings, Step2Solver, Step2Weighting,
};
use crate::lbfgs::StopRule;

/// The serde form of [`Step2Settings`]: this version's (`solver`), or the
/// one before, which held the L-BFGS stopping rule as `stop`.
#[derive(Deserialize)]
struct Step2Wire {
    lambda: f64,
    #[serde(default)]
    bending: f64,
    weighting: Step2Weighting,
    #[serde(default)]
    solver: Option<Step2Solver>,
    #[serde(default)]
    stop: Option<StopRule>,
    #[serde(default)]
    first: Option<Step2Solver>,
    /// Reports before the fold repair ran without it.
    #[serde(default)]
    fold_repair: bool,
    /// Reports before it held soft targets at their step-1 value.
    #[serde(default)]
    soft_pull: f64,
}

impl<'de> Deserialize<'de> for Step2Settings {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let w = Step2Wire::deserialize(d)?;
        let solver = match (w.solver, w.stop) {
            (Some(s), _) => s,
            (None, Some(stop)) => Step2Solver::Lbfgs { stop },
            (None, None) => Step2Solver::paper(),
        };
        Ok(Self {
            lambda: w.lambda,
            bending: w.bending,
            weighting: w.weighting,
            solver,
            first: w.first,
            fold_repair: w.fold_repair,
            soft_pull: w.soft_pull,
        })
    }
}

/// The serde form of [`PredictSettings`]: this version's, or the flat
/// record of older reports.
#[derive(Deserialize)]
#[serde(untagged)]
enum SettingsWire {
    Current(Box<CurrentWire>),
    Flat(Box<FlatWire>),
}

#[derive(Deserialize)]
struct CurrentWire {
    l: f64,
    s: usize,
    reference_tolerance: f64,
    step1: Step1Settings,
    step2: Step2Settings,
    continuation: Option<Continuation>,
    warn_error_mm: f64,
}

/// The flat record reports held before the settings had one part per stage.
#[derive(Deserialize)]
struct FlatWire {
    l: f64,
    lambda: f64,
    s: usize,
    stop: StopRule,
    step2_stop: StopRule,
    reference_tolerance: f64,
    warn_error_mm: f64,
    #[serde(default = "paper_weighting")]
    step1_weighting: EnergyWeighting,
    #[serde(default = "paper_weighting")]
    step2_weighting: EnergyWeighting,
    #[serde(default = "unit_weight")]
    step2_reading_weight: f64,
    #[serde(default)]
    step1_prior_mm: Option<f64>,
    #[serde(default)]
    step1_components: Option<usize>,
    #[serde(default)]
    step1_gauss_newton: bool,
    #[serde(default)]
    step1_box: bool,
    #[serde(default)]
    continuation: Option<Continuation>,
}

fn paper_weighting() -> EnergyWeighting {
    EnergyWeighting::Paper
}

fn unit_weight() -> f64 {
    1.0
}

impl From<FlatWire> for PredictSettings {
    fn from(f: FlatWire) -> Self {
        Self {
            l: f.l,
            s: f.s,
            reference_tolerance: f.reference_tolerance,
            step1: Step1Settings {
                solver: if f.step1_gauss_newton {
                    Step1Solver::GaussNewtonMap {
                        tau_mm: f.step1_prior_mm,
                        min_decrease_mm: 0.0,
                    }
                } else {
                    Step1Solver::Lbfgs {
                        prior_mm: f.step1_prior_mm,
                    }
                },
                weighting: f.step1_weighting,
                clamp: if f.step1_box {
                    Step1Clamp::InsideBox
                } else {
                    Step1Clamp::AfterStep
                },
                components: f.step1_components,
                stop: f.stop,
            },
            step2: Step2Settings {
                lambda: f.lambda,
                bending: 0.0,
                weighting: match f.step2_weighting {
                    EnergyWeighting::Paper => Step2Weighting::Paper,
                    EnergyWeighting::PerMeasurement => Step2Weighting::PerMeasurement {
                        reading_weight: f.step2_reading_weight,
                    },
                },
                solver: Step2Solver::Lbfgs { stop: f.step2_stop },
                first: None,
                fold_repair: false,
                soft_pull: 0.0,
            },
            continuation: f.continuation,
            warn_error_mm: f.warn_error_mm,
        }
    }
}

impl<'de> Deserialize<'de> for PredictSettings {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        Ok(match SettingsWire::deserialize(d)? {
            SettingsWire::Current(c) => Self {
                l: c.l,
                s: c.s,
                reference_tolerance: c.reference_tolerance,
                step1: c.step1,
                step2: c.step2,
                continuation: c.continuation,
                warn_error_mm: c.warn_error_mm,
            },
            SettingsWire::Flat(f) => (*f).into(),
        })
    }
}
