//! Garment sizes for an estimate from a store's size chart (issue 14,
//! `tapeshape-sizes`).
//!
//! A dimension the operator measured counts as measured, with its ISO
//! 20685-1 allowable error (or the reading's own tolerance) as its SD; one
//! that was not measured is read off the estimated body, with its spread:
//! the real-people conditional SD of its soft target where it has one
//! (`tapeshape_estimator::priors`), else what the other readings predict
//! for it ([`Estimator::predict_reading`]).

use tapeshape_estimator::{EstimateReport, Estimator};
use tapeshape_measure::Class;
use tapeshape_sizes::{
    recommend, Chart, ChartError, DimensionKind, KnownDimension, Placement, Position, Readings,
    Recommendation,
};

use crate::i18n::{self, tr, Lang};

/// The chart's dimension names the estimator knows, with their kinds.
pub fn known_dimensions(estimator: &Estimator) -> Vec<KnownDimension> {
    estimator
        .set()
        .definitions
        .iter()
        .map(|d| {
            let kind = match d.class {
                Class::Girth => DimensionKind::Girth,
                Class::Length | Class::Height | Class::Arc => DimensionKind::Length,
                Class::Breadth | Class::Depth => DimensionKind::Breadth,
            };
            KnownDimension::new(d.name.clone(), kind)
        })
        .collect()
}

/// Loads and checks a size chart against the estimator's measurement names.
pub fn load_chart(path: &std::path::Path, estimator: &Estimator) -> Result<Chart, ChartError> {
    Chart::from_path(path, &known_dimensions(estimator))
}

/// The sizes of every garment of `chart` for the estimate whose report is
/// `report` (see the module docs): an estimate just made, or one stored
/// with its session.
pub fn sizes(estimator: &Estimator, report: &EstimateReport, chart: &Chart) -> Recommendation {
    let mut readings = Readings::new();
    let wanted: Vec<&str> = chart
        .garments()
        .iter()
        .flat_map(|g| g.dimensions().map(|d| d.name()))
        .collect();
    for c in &report.inputs {
        if !wanted.contains(&c.name.as_str()) {
            continue;
        }
        let sd = c.tolerance_mm.unwrap_or_else(|| {
            estimator
                .set()
                .index_of(&c.name)
                .map_or(0.0, |j| estimator.set().definitions[j].tolerance.mm())
        });
        // Names are unique among the inputs and values positive: the
        // estimator checked them.
        let _ = readings.insert_measured(&c.name, c.value_mm, sd);
    }
    let others = taken_m(report);
    for m in &report.prediction.measurements {
        let name = m.name.as_str();
        if !wanted.contains(&name) || report.inputs.iter().any(|c| c.name == name) {
            continue;
        }
        let Some(value) = m.step2_mm else { continue };
        if let Some(sd) = body_sd_mm(estimator, report, &others, name) {
            let _ = readings.insert_estimated(name, value, sd);
        }
    }
    recommend(chart, &readings)
}

/// The readings of `report` as (name, metres): what a dimension read off
/// the body is predicted from ([`body_sd_mm`]).
pub fn taken_m(report: &EstimateReport) -> Vec<(&str, f64)> {
    report
        .inputs
        .iter()
        .map(|c| (c.name.as_str(), c.value_mm / 1000.0))
        .collect()
}

/// The spread (one SD, mm) of a dimension `name` that was not measured but
/// read off the body of `report` (see the module docs): its soft target's
/// real-people conditional SD, else what the readings `others` ([`taken_m`])
/// predict for it; `None` when neither is known (a name the model lacks).
/// The sizes and the customer's card use the same spread.
pub fn body_sd_mm(
    estimator: &Estimator,
    report: &EstimateReport,
    others: &[(&str, f64)],
    name: &str,
) -> Option<f64> {
    report
        .soft_targets
        .iter()
        .find(|t| t.name == name)
        .map(|t| t.sd_mm)
        .or_else(|| {
            estimator
                .predict_reading(name, others)
                .ok()
                .map(|p| p.sd * 1000.0)
        })
}

/// One line per garment for the result screen, in the operator's language:
/// the best size with its probability, the other size when the customer is
/// between two, and the primary dimensions that do not fit it ("tight at
/// the chest"), or what is missing. (The JSON report and `predict --chart`
/// keep the recommendation's own English words, [`Placement::words`]: they
/// are read by scripts.)
pub fn screen_lines(rec: &Recommendation) -> Vec<String> {
    rec.garments
        .iter()
        .map(|g| match &g.best {
            None => tr!(
                "sizes-no-size",
                garment = g.garment.clone(),
                missing = g
                    .missing
                    .iter()
                    .map(|m| m.dimension.as_str())
                    .collect::<Vec<_>>()
                    .join(", ")
            ),
            Some(best) => {
                let mut line = tr!(
                    "sizes-best",
                    garment = g.garment.clone(),
                    size = best.label.clone(),
                    percent = format!("{:.0}", 100.0 * best.probability)
                );
                if let Some(b) = &g.between {
                    line.push_str(&format!(
                        " {}",
                        tr!("sizes-or", size = b.other.label.clone())
                    ));
                }
                let misfits: Vec<String> = best
                    .placements
                    .iter()
                    .filter(|p| {
                        p.role == tapeshape_sizes::Role::Primary && !p.interval.contains(p.value_mm)
                    })
                    .map(misfit_words)
                    .collect();
                if !misfits.is_empty() {
                    line.push_str(&format!("; {}", misfits.join(", ")));
                }
                line
            }
        })
        .collect()
}

/// How a primary reading misses its size, in the operator's language: the
/// same words as [`tapeshape_sizes::fit_words`] in English ("tight at the
/// hip", "too short for the inside leg"), the catalogue's in another.
fn misfit_words(p: &Placement) -> String {
    // English phrases name the dimension in lower case inside the sentence
    // (`inside leg`), as the report does; another language uses the
    // operator's name of the measurement (the quick set's, whose names the
    // charts use), else the same lower-case name.
    let plain = tapeshape_sizes::words::place(&p.dimension);
    let place = match i18n::lang() {
        Lang::En => plain,
        _ => i18n::measurement_label("quick", &p.dimension, &plain),
    };
    match (p.position, p.kind) {
        (Position::Above { .. }, DimensionKind::Girth) => tr!("sizes-tight", place = place),
        (Position::Above { .. }, DimensionKind::Length) => tr!("sizes-too-short", place = place),
        (Position::Above { .. }, DimensionKind::Breadth) => tr!("sizes-narrow", place = place),
        (Position::Below { .. }, DimensionKind::Girth) => tr!("sizes-loose", place = place),
        (Position::Below { .. }, DimensionKind::Length) => tr!("sizes-too-long", place = place),
        (Position::Below { .. }, DimensionKind::Breadth) => tr!("sizes-wide", place = place),
        // Not a misfit (the caller passes only readings outside their
        // interval): the recommendation's own words.
        (Position::Inside { .. }, _) => p.words.clone(),
    }
}
