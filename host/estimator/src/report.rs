//! What an estimate returns: the body and its report (the model used, every
//! reading with its checks, the model's stage report, warnings).

use std::time::Duration;

use serde::{Deserialize, Serialize};
use tapeshape_mesh::Mesh;
use tapeshape_model::predict::PredictionReport;

use tapeshape_population::ansur::Sex;

use crate::checks::InputCheck;
use crate::warning::Warning;
use crate::{SoftTarget, TotalSplit};

/// Summary of the model used.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ModelSummary {
    /// Where it came from (embedded default or a path).
    pub source: String,
    /// Measurement sets in the model.
    pub sets: String,
    /// Training bodies.
    pub n_training: usize,
    /// PCA components.
    pub n_components: usize,
    /// Template vertices.
    pub n_vertices: usize,
}

/// The report of one estimate: inputs, checks, the model's stage report, warnings.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct EstimateReport {
    /// The model used.
    pub model: ModelSummary,
    /// Every reading with its checks.
    pub inputs: Vec<InputCheck>,
    /// Stage values, plausibility and timings (from `tapeshape-model`).
    pub prediction: PredictionReport,
    /// Time to check the inputs.
    pub check_time: Duration,
    /// Everything the operator should know: input notes and the model's
    /// warnings, coded (the plain strings of older reports read back as
    /// the model's `Text`).
    #[serde(deserialize_with = "tapeshape_model::predict::warning::list_from_either")]
    pub warnings: Vec<Warning>,
    /// The customer's sex as given (`None`: not given, both sexes pooled).
    #[serde(default)]
    pub sex: Option<Sex>,
    /// Soft targets from real people for what was not measured
    /// ([`crate::priors`]); the model's report lists them among its
    /// readings too.
    #[serde(default)]
    pub soft_targets: Vec<SoftTarget>,
    /// Loop totals given as one reading and how they were shared out over
    /// their pieces ([`crate::totals`]).
    #[serde(default)]
    pub totals: Vec<TotalSplit>,
}

/// A predicted body.
#[derive(Debug, Clone)]
pub struct Estimate {
    /// The body in the template topology (metres, station frame).
    pub mesh: Mesh,
    /// The report.
    pub report: EstimateReport,
}

impl EstimateReport {
    /// The report as the JSON a user's file holds: every field as serde
    /// writes it, except that `warnings` (here and in `prediction`) is the
    /// warnings' English text, as it always was, and `warning_codes` beside
    /// it the same warnings coded (`code` and values) for scripts.
    /// [`EstimateReport`]'s `Deserialize` reads this form back (the
    /// warnings then as text).
    pub fn to_json(&self) -> serde_json::Result<serde_json::Value> {
        let mut value = serde_json::to_value(self)?;
        if let Some(obj) = value.as_object_mut() {
            put_warnings(obj, &self.warnings)?;
            if let Some(p) = obj.get_mut("prediction").and_then(|p| p.as_object_mut()) {
                put_warnings(p, &self.prediction.warnings)?;
            }
        }
        Ok(value)
    }
}

/// Sets `warnings` of `obj` to the English text of `ws` and `warning_codes`
/// to `ws` coded ([`EstimateReport::to_json`]).
fn put_warnings<W: std::fmt::Display + Serialize>(
    obj: &mut serde_json::Map<String, serde_json::Value>,
    ws: &[W],
) -> serde_json::Result<()> {
    let text: Vec<String> = ws.iter().map(ToString::to_string).collect();
    obj.insert("warnings".into(), serde_json::to_value(text)?);
    obj.insert("warning_codes".into(), serde_json::to_value(ws)?);
    Ok(())
}
