//! The report of a prediction: each reading through the stages, the
//! plausibility of the inputs and the result, stage times, the solver runs
//! and the settings used (serde, so a station or an engineer can store and
//! read it back).

use std::time::Duration;

use tapeshape_mesh::{Topology, Vec3};

use super::folds::{fold_of, Fold};
use super::readings::Readings;
use super::rounds::RoundsSummary;
use super::settings::{PredictConfig, PredictSettings};
use super::start::{StartMethod, StartShape};
use super::step1::Step1Shape;
use super::step2::{Step2First, Step2Shape};
use super::warning::Warning;
use super::Measurer;
use crate::lbfgs::RunInfo;
use crate::{Result, ShapeModel, MM_PER_M};

/// One measurement through the stages (millimetres).
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct MeasurementReport {
    /// Measurement name.
    pub name: String,
    /// Target, mm (`None` if not given).
    pub target_mm: Option<f64>,
    /// Tolerance given with the target, mm.
    pub tolerance_mm: Option<f64>,
    /// Value on the start shape, mm (given measurements only).
    pub start_mm: Option<f64>,
    /// Value after step 1, mm (given measurements only).
    pub step1_mm: Option<f64>,
    /// Value on the final mesh, mm (all measurements; `None` if measuring failed).
    pub step2_mm: Option<f64>,
    /// `|step2 - target|`, mm.
    pub error_mm: Option<f64>,
    /// The target was a soft one ([`super::Target::soft`]), not a reading.
    #[serde(default)]
    pub soft: bool,
    /// A reading recorded but not fitted: the caller gave the model no
    /// target for it and filled `target_mm` (and `error_mm`) in afterwards
    /// so that the report keeps what was entered beside the body's value
    /// (the estimator does this for ANSUR II dimensions the standing mesh
    /// cannot take as ANSUR defines them).
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub recorded_only: bool,
}

/// Plausibility label from a chi-square quantile: below 0.95 typical, below
/// 0.999 unusual, else implausible.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub enum PlausibilityLabel {
    /// Quantile below 0.95.
    Typical,
    /// Quantile in [0.95, 0.999).
    Unusual,
    /// Quantile 0.999 or above.
    Implausible,
}

impl PlausibilityLabel {
    /// The label for a chi-square quantile.
    pub fn from_quantile(q: f64) -> Self {
        if q < 0.95 {
            Self::Typical
        } else if q < 0.999 {
            Self::Unusual
        } else {
            Self::Implausible
        }
    }
}

/// How plausible the result and its inputs are.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Plausibility {
    /// Mahalanobis distance of the step-1 weights, `|w|` (normalised weights are
    /// independent with unit variance on the training set).
    pub mahalanobis: f64,
    /// Chi-square quantile of `mahalanobis^2` with K degrees of freedom
    /// (Wilson-Hilferty approximation, about 1e-3 accurate).
    pub quantile: f64,
    /// Label of `quantile`.
    pub label: PlausibilityLabel,
    /// Mahalanobis distance of the given measurements under their training
    /// marginal Gaussian, each reading's tolerance (or the reference
    /// tolerance) added as observation noise.
    pub measurements_mahalanobis: f64,
    /// Its chi-square quantile (degrees of freedom = number given).
    pub measurements_quantile: f64,
    /// Label of `measurements_quantile`.
    pub measurements_label: PlausibilityLabel,
    /// RMS distance (mm) between the final mesh and its projection onto the
    /// PCA space: how far step 2 left the learned shape space.
    pub out_of_space_rms_mm: f64,
    /// Largest such vertex distance, mm.
    pub out_of_space_max_mm: f64,
    /// Components clamped to `l` at the start.
    pub clamped_start: Vec<usize>,
    /// Components clamped to `l` after step 1.
    pub clamped_step1: Vec<usize>,
    /// Triangles whose normal turned by more than 90 degrees from the step-1 shape.
    pub flipped_triangles: usize,
    /// Triangles whose area fell below 1% of their step-1 area.
    pub degenerate_triangles: usize,
}

/// Wall-clock time of each stage: the only values of a report that differ
/// between two predictions of the same readings.
#[derive(Debug, Clone, Copy, PartialEq, Default, serde::Serialize, serde::Deserialize)]
pub struct StageTimings {
    /// Start weights, clamping and measuring the start shape.
    pub start: Duration,
    /// Step 1 (all rounds, clamping, measuring the result).
    pub step1: Duration,
    /// Step 2 (all rounds, measuring the result, checks).
    pub step2: Duration,
    /// Whole prediction.
    pub total: Duration,
}

/// The report of one prediction (everything but the mesh); serialisable to JSON.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct PredictionReport {
    /// How the start was found.
    pub start_method: StartMethod,
    /// Start weights after clamping (normalised).
    pub weights_start: Vec<f64>,
    /// Step-1 weights after clamping (normalised). Their shape is step 1's;
    /// where it folded the model's mean shape, step 2 started from it
    /// smoothed (`ShapeModel::unfold_step1`), and the step-1 values below
    /// are measured on that.
    pub weights_step1: Vec<f64>,
    /// Per measurement, in the model's order.
    pub measurements: Vec<MeasurementReport>,
    /// Plausibility of the inputs and the result.
    pub plausibility: Plausibility,
    /// Stage times.
    pub timings: StageTimings,
    /// Solver runs of step 1 (one per round; a Gauss-Newton round that
    /// falls back to L-BFGS adds two).
    pub step1_runs: Vec<RunInfo>,
    /// L-BFGS runs of step 2, one per round.
    pub step2_runs: Vec<RunInfo>,
    /// How step 1's rounds went (`None` in reports of older versions).
    #[serde(default)]
    pub step1_rounds: Option<RoundsSummary>,
    /// How step 2's rounds went (`None` in reports of older versions).
    #[serde(default)]
    pub step2_rounds: Option<RoundsSummary>,
    /// How step 2's first solver went, where one was tried
    /// ([`super::Step2Settings::first`]; `None` in reports from before).
    #[serde(default)]
    pub step2_first: Option<Step2First>,
    /// Things the operator or engineer should know (coded; the plain
    /// strings of older reports read as [`Warning::Text`]).
    #[serde(deserialize_with = "super::warning::list_from_either")]
    pub warnings: Vec<Warning>,
    /// Settings used.
    pub settings: PredictSettings,
}

impl PredictionReport {
    /// The report as a plain-text table for engineers, logs and tests: one
    /// line per measurement (target, value after the start, step 1 and step 2,
    /// error; millimetres, `-` where not given), then plausibility, stage
    /// times and warnings.
    pub fn to_text(&self) -> String {
        use std::fmt::Write;
        let opt = |v: Option<f64>, prec: usize| match v {
            Some(x) => format!("{x:.prec$}"),
            None => "-".to_string(),
        };
        let width = self
            .measurements
            .iter()
            .map(|m| m.name.len())
            .max()
            .unwrap_or(0)
            .max(11);
        let mut out = String::new();
        let _ = writeln!(
            out,
            "{:width$}  {:>9}  {:>9}  {:>9}  {:>9}  {:>8}",
            "measurement", "target mm", "start", "step 1", "step 2", "error mm"
        );
        for m in &self.measurements {
            let _ = writeln!(
                out,
                "{:width$}  {:>9}  {:>9}  {:>9}  {:>9}  {:>8}",
                m.name,
                opt(m.target_mm, 1),
                opt(m.start_mm, 2),
                opt(m.step1_mm, 2),
                opt(m.step2_mm, 2),
                opt(m.error_mm, 3)
            );
        }
        let p = &self.plausibility;
        let _ = writeln!(
            out,
            "plausibility: weights Mahalanobis {:.2} over {} components (quantile {:.3}, {:?}); readings Mahalanobis {:.2} (quantile {:.3}, {:?})",
            p.mahalanobis,
            self.weights_step1.len(),
            p.quantile,
            p.label,
            p.measurements_mahalanobis,
            p.measurements_quantile,
            p.measurements_label
        );
        let _ = writeln!(
            out,
            "out of PCA space: RMS {:.2} mm, max {:.2} mm; clamped at start {:?}, after step 1 {:?}; flipped triangles {}, collapsed {}",
            p.out_of_space_rms_mm,
            p.out_of_space_max_mm,
            p.clamped_start,
            p.clamped_step1,
            p.flipped_triangles,
            p.degenerate_triangles
        );
        let ms = |d: Duration| d.as_secs_f64() * 1e3;
        let t = &self.timings;
        let _ = writeln!(
            out,
            "time: start {:.1} ms, step 1 {:.1} ms, step 2 {:.1} ms, total {:.1} ms ({:?} start)",
            ms(t.start),
            ms(t.step1),
            ms(t.step2),
            ms(t.total),
            self.start_method
        );
        for w in &self.warnings {
            let _ = writeln!(out, "warning: {w}");
        }
        out
    }
}

/// A predicted body and its report.
#[derive(Debug, Clone)]
pub struct Prediction {
    /// Vertex positions, template order, metres, station frame.
    pub vertices: Vec<Vec3>,
    /// The report.
    pub report: PredictionReport,
}

impl ShapeModel {
    /// Mahalanobis distance of the given readings under the training
    /// Gaussian of the measurements, with each reading's own uncertainty
    /// (its tolerance, else the reference tolerance) added as noise: a tape
    /// reading is never more exact than that, and without it nearly collinear
    /// measurements (left/right pairs) make every small asymmetry look
    /// implausible.
    fn measurement_mahalanobis(&self, given: &Readings) -> Result<f64> {
        // Readings only: a soft target is a statistic, not the customer.
        let idx: Vec<usize> = given.iter().filter(|g| !g.soft).map(|g| g.index).collect();
        if idx.is_empty() {
            return Ok(0.0);
        }
        let val: Vec<f64> = given
            .iter()
            .filter(|g| !g.soft)
            .map(|g| g.target_mm / MM_PER_M)
            .collect();
        // weight = (reference / tolerance)^2, so tolerance^2 = reference^2 / weight.
        let reference = given.reference_tolerance();
        let noise: Vec<f64> = given
            .iter()
            .filter(|g| !g.soft)
            .map(|g| reference.powi(2) / g.weight)
            .collect();
        self.joint.mahalanobis(&idx, &val, &noise)
    }

    /// The report of a prediction from its stages: every measurement's
    /// target and value after each stage (those not given measured on the
    /// final mesh with `measurer`), the plausibility, the runs, the
    /// warnings of every stage and its own, `timings` and the settings of
    /// `config`.
    ///
    /// Errors only if the readings' Mahalanobis distance cannot be computed
    /// (a singular training covariance); a failure to measure what was not
    /// given is a warning.
    #[allow(clippy::too_many_arguments)]
    pub fn report(
        &self,
        readings: &Readings,
        start: &StartShape,
        step1: &Step1Shape,
        step2: &Step2Shape,
        config: &PredictConfig,
        measurer: &dyn Measurer,
        topology: &Topology,
        timings: StageTimings,
    ) -> Result<PredictionReport> {
        let rc = config.report();
        let mut warnings: Vec<Warning> = step1
            .warnings
            .iter()
            .chain(&step2.warnings)
            .cloned()
            .collect();
        let (x1, x2) = (&step1.vertices, &step2.vertices);
        let (flipped, degenerate) = triangle_changes(topology, x1, x2);
        if flipped > 0 || degenerate > 0 {
            warnings.push(Warning::TrianglesChanged {
                flipped,
                collapsed: degenerate,
            });
        }
        let back = self.shape_unchecked(&self.pca.project(x2.as_flattened()));
        let mut sum2 = 0.0;
        let mut max_d = 0.0f64;
        for (a, b) in x2.iter().zip(&back) {
            let d2 = (0..3).map(|c| (a[c] - b[c]).powi(2)).sum::<f64>();
            sum2 += d2;
            max_d = max_d.max(d2.sqrt());
        }
        let k = self.n_components();
        let mahalanobis = step1.weights.iter().map(|x| x * x).sum::<f64>().sqrt();
        let quantile = chi2_quantile(mahalanobis * mahalanobis, k);
        let meas_maha = self.measurement_mahalanobis(readings)?;
        let n_readings = readings.iter().filter(|g| !g.soft).count();
        let meas_q = chi2_quantile(meas_maha * meas_maha, n_readings.max(1));
        let meas_label =
            PlausibilityLabel::from_quantile(if meas_q.is_finite() { meas_q } else { 1.0 });
        if meas_label == PlausibilityLabel::Implausible {
            warnings.push(Warning::FarFromPopulation {
                mahalanobis: meas_maha,
                readings: n_readings,
                held_sd: rc.l,
            });
        }
        let plausibility = Plausibility {
            mahalanobis,
            quantile,
            label: PlausibilityLabel::from_quantile(quantile),
            measurements_mahalanobis: meas_maha,
            measurements_quantile: meas_q,
            measurements_label: meas_label,
            out_of_space_rms_mm: (sum2 / x2.len() as f64).sqrt() * MM_PER_M,
            out_of_space_max_mm: max_d * MM_PER_M,
            clamped_start: start.clamped.clone(),
            clamped_step1: step1.clamped.clone(),
            flipped_triangles: flipped,
            degenerate_triangles: degenerate,
        };
        let mut reports: Vec<MeasurementReport> = self
            .measurement_names
            .iter()
            .map(|name| MeasurementReport {
                name: name.clone(),
                target_mm: None,
                tolerance_mm: None,
                start_mm: None,
                step1_mm: None,
                step2_mm: None,
                error_mm: None,
                soft: false,
                recorded_only: false,
            })
            .collect();
        for (i, g) in readings.iter().enumerate() {
            let r = &mut reports[g.index];
            r.target_mm = Some(g.target_mm);
            r.tolerance_mm = g.tolerance.map(|t| t * MM_PER_M);
            r.start_mm = Some(start.measured[i].value * MM_PER_M);
            r.step1_mm = Some(step1.measured[i].value * MM_PER_M);
            let v2 = step2.measured[i].value * MM_PER_M;
            r.step2_mm = Some(v2);
            let err = (v2 - g.target_mm).abs();
            r.error_mm = Some(err);
            r.soft = g.soft;
            if err > rc.warn_error_mm && !g.soft {
                warnings.push(Warning::NotFitted {
                    measurement: r.name.clone(),
                    limit_mm: rc.warn_error_mm,
                    error_mm: err,
                });
            }
        }
        let given = readings.indices();
        let missing: Vec<usize> = (0..self.n_measurements())
            .filter(|j| !given.contains(j))
            .collect();
        if !missing.is_empty() {
            match self.measure_checked(measurer, x2, &missing) {
                Ok(ms) => {
                    for (m, &j) in ms.iter().zip(&missing) {
                        reports[j].step2_mm = Some(m.value * MM_PER_M);
                    }
                }
                Err(e) => warnings.push(Warning::MeasuringFailed {
                    reason: e.to_string(),
                }),
            }
        }
        Ok(PredictionReport {
            start_method: start.method,
            weights_start: start.weights.clone(),
            weights_step1: step1.weights.clone(),
            measurements: reports,
            plausibility,
            timings,
            step1_runs: step1.runs.clone(),
            step2_runs: step2.runs.clone(),
            step1_rounds: Some(step1.rounds),
            step2_rounds: Some(step2.rounds),
            step2_first: step2.first.clone(),
            warnings,
            settings: config.settings().clone(),
        })
    }
}

/// Standard normal CDF via erfc (Abramowitz & Stegun 7.1.26, |error| < 1.5e-7;
/// std has no erf and the plausibility label needs no more).
fn normal_cdf(z: f64) -> f64 {
    let x = z.abs() / std::f64::consts::SQRT_2;
    let t = 1.0 / (1.0 + 0.3275911 * x);
    let poly = t
        * (0.254829592
            + t * (-0.284496736 + t * (1.421413741 + t * (-1.453152027 + t * 1.061405429))));
    let erfc = poly * (-x * x).exp();
    if z >= 0.0 {
        1.0 - 0.5 * erfc
    } else {
        0.5 * erfc
    }
}

/// Chi-square CDF of `x` with `k` degrees of freedom, Wilson-Hilferty
/// approximation (`(x/k)^(1/3)` is nearly normal); about 1e-3 accurate, enough
/// for a three-way plausibility label.
pub fn chi2_quantile(x: f64, k: usize) -> f64 {
    if k == 0 {
        return 0.0;
    }
    if x <= 0.0 {
        return 0.0;
    }
    let k = k as f64;
    let v = 2.0 / (9.0 * k);
    normal_cdf(((x / k).cbrt() - (1.0 - v)) / v.sqrt())
}

/// Counts triangles of `after` whose normal turned by more than 90 degrees
/// from `before` (flipped) or whose area fell below 1% of it (degenerate).
pub fn triangle_changes(topology: &Topology, before: &[Vec3], after: &[Vec3]) -> (usize, usize) {
    let (mut flipped, mut degenerate) = (0, 0);
    for f in topology.faces() {
        match fold_of(before, after, f) {
            Some(Fold::Flipped) => flipped += 1,
            Some(Fold::Collapsed) => degenerate += 1,
            None => {}
        }
    }
    (flipped, degenerate)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn chi2_quantile_is_close_to_known_values() {
        // chi2(0.95, 10) = 18.307, chi2(0.999, 30) = 59.703, chi2(0.5, 50) = 49.335.
        assert!((chi2_quantile(18.307, 10) - 0.95).abs() < 2e-3);
        assert!((chi2_quantile(59.703, 30) - 0.999).abs() < 1e-3);
        assert!((chi2_quantile(49.335, 50) - 0.5).abs() < 2e-3);
        assert_eq!(
            PlausibilityLabel::from_quantile(0.5),
            PlausibilityLabel::Typical
        );
        assert_eq!(
            PlausibilityLabel::from_quantile(0.99),
            PlausibilityLabel::Unusual
        );
        assert_eq!(
            PlausibilityLabel::from_quantile(0.9999),
            PlausibilityLabel::Implausible
        );
    }
}
