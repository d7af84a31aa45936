//! What an operator or engineer chooses for an estimate, and how it becomes
//! the model's configuration.
//!
//! Why the facade has its own options: the station and `tapeshape predict`
//! let people choose the paper's three parameters (`l`, `lambda`, `s`) and
//! nothing else; experiments choose a whole pipeline. [`PredictOptions`]
//! records what was chosen (`None`: not said, the pipeline's value) and
//! [`PredictOptions::resolve`] turns it, once per estimate, into the
//! model's [`PredictConfig`], refusing values out of range before any
//! reading is checked.

use serde::{Deserialize, Serialize};
use tapeshape_model::{PredictConfig, PredictSettings};

use crate::{PredictError, RealPeople};

/// Which of the model's pipelines an estimate runs.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub enum Pipeline {
    /// What the station uses ([`PredictSettings::default`]: the paper's
    /// parameters with the refinements measured in `docs/prediction.md`).
    #[default]
    Station,
    /// The paper's method exactly ([`PredictSettings::paper`]).
    Paper,
    /// Any settings (experiments, e.g. `predict_eval`'s flags).
    Custom(Box<PredictSettings>),
}

/// What an operator or engineer chose for an estimate (see the module docs).
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct PredictOptions {
    /// The pipeline.
    pub pipeline: Pipeline,
    /// Clamp of the normalised PCA weights, in SDs (paper: 3 synthetic, 10
    /// real); `None`: the pipeline's (3).
    pub l: Option<f64>,
    /// Weight of the smoothness energy in step 2, in `[0, 1]` (paper: 0.1);
    /// `None`: the pipeline's.
    pub lambda: Option<f64>,
    /// Rounds of support recomputation per step (paper: 3; 0 = the start
    /// only); `None`: the pipeline's.
    pub s: Option<usize>,
    /// Weight of step 2's bending term (the displacement's curvature, which
    /// keeps a body entered with many readings from creasing; see
    /// [`tapeshape_model::Step2Settings::bending`]); `None`: the pipeline's
    /// (0, none). Above 0 it also drops step 2's smooth basis tried first
    /// (which does not take the term): step 2 is L-BFGS alone.
    #[serde(default)]
    pub bending: Option<f64>,
    /// Whether step 2 tries the template's smooth basis first
    /// ([`tapeshape_model::Step2Settings::first`]): `None`: the pipeline's
    /// (the station's: yes; the paper's: no); `Some(false)`: step 2 is its
    /// solver alone (L-BFGS, the paper's); `Some(true)`: the smooth basis
    /// first, kept where it meets every reading. A bending term above 0
    /// drops it whatever this says.
    #[serde(default)]
    pub smooth_first: Option<bool>,
    /// How real people guide what was not measured ([`crate::priors`]):
    /// `None`: the pipeline's (the station's: [`RealPeople::default`]; the
    /// paper's and custom pipelines: nothing, the model alone);
    /// `Some(None)`: nothing; `Some(Some(r))`: `r`.
    #[serde(default)]
    pub real_people: Option<Option<RealPeople>>,
    /// Whether step 2 smooths out the triangles it folded
    /// ([`tapeshape_model::Step2Settings::fold_repair`]): `None`: the
    /// pipeline's (the station's: yes; the paper's: no); `Some(false)`:
    /// step 2's body as its solver left it.
    #[serde(default)]
    pub fold_repair: Option<bool>,
}

impl PredictOptions {
    /// The paper's method with its parameters.
    pub fn paper() -> Self {
        Self {
            pipeline: Pipeline::Paper,
            ..Self::default()
        }
    }

    /// Exactly `settings` (for experiments).
    pub fn custom(settings: PredictSettings) -> Self {
        Self {
            pipeline: Pipeline::Custom(Box::new(settings)),
            ..Self::default()
        }
    }

    /// The model's settings these options give (what a report records).
    pub fn settings(&self) -> PredictSettings {
        let mut s = match &self.pipeline {
            Pipeline::Station => PredictSettings::default(),
            Pipeline::Paper => PredictSettings::paper(),
            Pipeline::Custom(s) => (**s).clone(),
        };
        if let Some(l) = self.l {
            s.l = l;
        }
        if let Some(lambda) = self.lambda {
            s.step2.lambda = lambda;
        }
        if let Some(rounds) = self.s {
            s.s = rounds;
        }
        if let Some(repair) = self.fold_repair {
            s.step2.fold_repair = repair;
        }
        if let Some(first) = self.smooth_first {
            s.step2.first = first.then(tapeshape_model::Step2Solver::smooth_basis);
        }
        if let Some(bending) = self.bending {
            s.step2.bending = bending;
            // The smooth basis tried first does not take the bending term:
            // with it, step 2 is the chosen solver alone.
            if bending > 0.0
                && matches!(
                    s.step2.first,
                    Some(tapeshape_model::Step2Solver::SmoothBasis { .. })
                )
            {
                s.step2.first = None;
            }
        }
        s
    }

    /// The soft targets' settings these options give (see
    /// [`PredictOptions::real_people`]).
    pub fn real_people(&self) -> Option<RealPeople> {
        match (&self.real_people, &self.pipeline) {
            (Some(r), _) => *r,
            (None, Pipeline::Station) => Some(RealPeople::default()),
            (None, _) => None,
        }
    }

    /// The model's configuration; errors if a value is out of range
    /// ("lambda must lie in [0, 1], got 2").
    pub fn resolve(&self) -> Result<PredictConfig, PredictError> {
        Ok(self.settings().resolve()?)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn options_resolve_to_the_pipeline_with_what_was_said() {
        assert_eq!(
            PredictOptions::default().settings(),
            PredictSettings::default()
        );
        assert_eq!(PredictOptions::paper().settings(), PredictSettings::paper());
        let o = PredictOptions {
            l: Some(10.0),
            lambda: Some(1.0),
            s: Some(0),
            bending: Some(100.0),
            ..PredictOptions::paper()
        };
        let s = o.settings();
        assert_eq!(
            (s.l, s.step2.lambda, s.s, s.step2.bending),
            (10.0, 1.0, 0, 100.0)
        );
        assert_eq!(s.step1, PredictSettings::paper().step1);
        let bad = PredictOptions {
            lambda: Some(2.0),
            ..PredictOptions::default()
        };
        let err = bad.resolve().unwrap_err().to_string();
        assert!(err.contains("lambda must lie in [0, 1], got 2"), "{err}");
    }

    /// `smooth_first` overrides the pipeline's step-2 first solver both
    /// ways, and a bending term drops the smooth basis whatever it says.
    #[test]
    fn smooth_first_chooses_step_2s_first_solver() {
        let smooth = Some(tapeshape_model::Step2Solver::smooth_basis());
        assert_eq!(PredictOptions::default().settings().step2.first, smooth);
        assert_eq!(PredictOptions::paper().settings().step2.first, None);
        let off = PredictOptions {
            smooth_first: Some(false),
            ..PredictOptions::default()
        };
        assert_eq!(off.settings().step2.first, None);
        // Everything else stays the station's.
        let mut want = PredictSettings::default();
        want.step2.first = None;
        assert_eq!(off.settings(), want);
        let on = PredictOptions {
            smooth_first: Some(true),
            ..PredictOptions::paper()
        };
        assert_eq!(on.settings().step2.first, smooth);
        let bent = PredictOptions {
            smooth_first: Some(true),
            bending: Some(10.0),
            ..PredictOptions::default()
        };
        assert_eq!(bent.settings().step2.first, None);
        assert!(bent.resolve().is_ok());
    }

    /// `fold_repair` overrides the pipeline's both ways and nothing else.
    #[test]
    fn fold_repair_is_the_pipelines_unless_said() {
        assert!(PredictOptions::default().settings().step2.fold_repair);
        assert!(!PredictOptions::paper().settings().step2.fold_repair);
        let off = PredictOptions {
            fold_repair: Some(false),
            ..PredictOptions::default()
        };
        let mut want = PredictSettings::default();
        want.step2.fold_repair = false;
        assert_eq!(off.settings(), want);
        let on = PredictOptions {
            fold_repair: Some(true),
            ..PredictOptions::paper()
        };
        let mut want = PredictSettings::paper();
        want.step2.fold_repair = true;
        assert_eq!(on.settings(), want);
    }
}
