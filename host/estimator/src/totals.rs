//! Loop totals as inputs: a knee or arm circumference taken as one tape
//! reading.
//!
//! The paper measures a knee or an arm girth as a loop of four geodesic
//! pieces between landmarks, and the model fits the pieces
//! (`tapeshape measure` prints their sum under the group's name, e.g.
//! `knee_circumference_left`). An operator's tape gives only the sum. So a
//! reading named after a group is split into its pieces before anything
//! else: the pieces' Gaussian conditional in the training population (the
//! model's joint Gaussian) given the other readings, then conditioned
//! exactly on the pieces summing to the reading,
//! `m' = mu + S 1 (T - 1'mu) / (1' S 1)`, so the pieces add up to the tape
//! value and are shared out as bodies with these readings share them. The
//! pieces are then checked and fitted like any reading (with the total's
//! tolerance split as `tol / sqrt(k)`, so the sum keeps the total's), and
//! the report lists the split.

use serde::{Deserialize, Serialize};

use crate::{Estimator, Input, Inputs, Length, PredictError};

/// How one total was shared out.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TotalSplit {
    /// The group (the reading's name).
    pub total: String,
    /// The reading, mm.
    pub value_mm: f64,
    /// Each piece: name and its share, mm (they sum to `value_mm`).
    pub pieces: Vec<(String, f64)>,
}

impl Estimator {
    /// `inputs` with every group total replaced by its pieces (see the
    /// module docs), and the splits made. Readings that are not totals pass
    /// unchanged; a kept total keeps its pieces.
    ///
    /// Errors: a total given together with one of its pieces; a total that
    /// is not a positive finite length (the checks' wording); a model
    /// whose Gaussian cannot be conditioned.
    pub fn expand_totals(
        &self,
        inputs: &Inputs,
    ) -> Result<(Inputs, Vec<TotalSplit>), PredictError> {
        let groups = self.set.groups();
        let is_total =
            |name: &str| self.set.index_of(name).is_none() && groups.iter().any(|(g, _)| g == name);
        if !inputs.readings.iter().any(|r| is_total(&r.name)) {
            return Ok((inputs.clone(), Vec::new()));
        }
        let direct: Vec<(usize, f64, f64)> = inputs
            .readings
            .iter()
            .filter_map(|r| {
                let j = self.set.index_of(&r.name)?;
                let noise = r
                    .tolerance
                    .unwrap_or(self.set.definitions[j].tolerance.mm() / 1000.0);
                Some((j, r.value.metres, noise * noise))
            })
            .filter(|(_, v, _)| v.is_finite() && *v > 0.0)
            .collect();
        let mut out = Inputs {
            readings: Vec::new(),
            sex: inputs.sex,
            kept: inputs.kept.clone(),
            ansur_survey: inputs.ansur_survey,
        };
        let mut splits = Vec::new();
        for r in &inputs.readings {
            if !is_total(&r.name) {
                out.push(r.clone())?;
                continue;
            }
            let (_, members) = groups
                .iter()
                .find(|(g, _)| *g == r.name)
                .expect("is_total found it");
            if let Some(&m) = members.iter().find(|&&m| direct.iter().any(|d| d.0 == m)) {
                return Err(PredictError::Input(format!(
                    "{} is given both as a total and by its piece {}: give either the total or all of its pieces",
                    r.name, self.set.definitions[m].name
                )));
            }
            let t = r.value.metres;
            if !(t.is_finite() && t > 0.0) {
                return Err(PredictError::BadValue(format!(
                    "{} is {} {}: a length must be positive",
                    r.name,
                    r.value.number,
                    r.value.unit.symbol()
                )));
            }
            let c = self.file.model.joint.conditional(members, &direct)?;
            let k = members.len();
            let s1: Vec<f64> = (0..k)
                .map(|a| (0..k).map(|b| c.cov[(a, b)]).sum())
                .collect();
            let s11: f64 = s1.iter().sum();
            let mu1: f64 = c.mean.iter().sum();
            let shares: Vec<f64> = if s11 > 0.0 {
                (0..k)
                    .map(|a| c.mean[a] + s1[a] * (t - mu1) / s11)
                    .collect()
            } else {
                // No spread to share by: in proportion to the means.
                (0..k).map(|a| c.mean[a] * t / mu1).collect()
            };
            if shares.iter().any(|v| !(v.is_finite() && *v > 0.0)) {
                return Err(PredictError::OutOfRange(format!(
                    "{} {} {} cannot be shared out over its {k} pieces as bodies with these readings are: check the reading and its unit",
                    r.name,
                    r.value.number,
                    r.value.unit.symbol()
                )));
            }
            let tol = r.tolerance.map(|x| x / (k as f64).sqrt());
            let mut pieces = Vec::with_capacity(k);
            for (&m, &v) in members.iter().zip(&shares) {
                let name = self.set.definitions[m].name.clone();
                out.push(Input {
                    name: name.clone(),
                    value: Length {
                        metres: v,
                        unit: r.value.unit,
                        unit_typed: r.value.unit_typed,
                        number: v / r.value.unit.metres(),
                    },
                    tolerance: tol,
                })?;
                if inputs.kept.contains(&r.name) {
                    out.kept.push(name.clone());
                }
                pieces.push((name, v * 1000.0));
            }
            out.kept.retain(|k| *k != r.name);
            splits.push(TotalSplit {
                total: r.name.clone(),
                value_mm: t * 1000.0,
                pieces,
            });
        }
        Ok((out, splits))
    }
}
