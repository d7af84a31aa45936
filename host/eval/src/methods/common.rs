//! Checks and conversions every method shares: target validation (so that
//! a wrong-length or non-finite target is an error, never a panic), training
//! data validation, and the PCA weights of the training bodies.

use tapeshape_model::ShapeModel;

use crate::{MethodError, TrainingData};

/// A training error of method `method`.
pub(crate) fn train_err(method: &str, message: impl Into<String>) -> MethodError {
    MethodError::Train {
        method: method.to_string(),
        message: message.into(),
    }
}

/// A prediction error of method `method`.
pub(crate) fn predict_err(method: &str, message: impl Into<String>) -> MethodError {
    MethodError::Predict {
        method: method.to_string(),
        message: message.into(),
    }
}

/// Checks `targets` (length `names.len()`, metres, `None` = not given) and
/// returns the given ones as `(index, value in metres)`.
///
/// Errors if the length is wrong, nothing is given, or a value is not a
/// positive finite length (the message names the measurement).
pub(crate) fn given_targets(
    method: &str,
    targets: &[Option<f64>],
    names: &[String],
) -> Result<Vec<(usize, f64)>, MethodError> {
    if targets.len() != names.len() {
        return Err(predict_err(
            method,
            format!(
                "{} targets given, the method was trained on {} measurements: pass one entry per measurement of the set, None where not measured",
                targets.len(),
                names.len()
            ),
        ));
    }
    let mut given = Vec::new();
    for (j, t) in targets.iter().enumerate() {
        if let Some(x) = *t {
            if !(x.is_finite() && x > 0.0) {
                return Err(predict_err(
                    method,
                    format!(
                        "target '{}' is {x}: a measurement must be a positive finite length in metres",
                        names[j]
                    ),
                ));
            }
            given.push((j, x));
        }
    }
    if given.is_empty() {
        return Err(predict_err(
            method,
            "no measurement given: give at least one target",
        ));
    }
    Ok(given)
}

/// Checks the shape of `data` (at least `min_bodies` bodies, `N x V`
/// vertices and `N x M` finite measurements, `M` and `V` matching the
/// compiled set and topology).
pub(crate) fn check_training(
    method: &str,
    data: &TrainingData,
    min_bodies: usize,
) -> Result<(), MethodError> {
    let n = data.meshes.len();
    if n < min_bodies {
        return Err(train_err(
            method,
            format!("{n} training bodies given, at least {min_bodies} needed"),
        ));
    }
    if data.measurements.len() != n {
        return Err(train_err(
            method,
            format!(
                "{n} meshes but {} measurement rows",
                data.measurements.len()
            ),
        ));
    }
    let v = data.topology.n_vertices();
    let m = data.compiled.len();
    if data.compiled.n_vertices() != v {
        return Err(train_err(
            method,
            format!(
                "the measurement set was compiled for {} vertices, the topology has {v}",
                data.compiled.n_vertices()
            ),
        ));
    }
    for (i, (mesh, row)) in data.meshes.iter().zip(&data.measurements).enumerate() {
        if mesh.len() != v {
            return Err(train_err(
                method,
                format!("body {i} has {} vertices, the topology {v}", mesh.len()),
            ));
        }
        if row.len() != m {
            return Err(train_err(
                method,
                format!("body {i} has {} measurements, the set {m}", row.len()),
            ));
        }
        if let Some(j) = row.iter().position(|x| !x.is_finite()) {
            return Err(train_err(
                method,
                format!(
                    "measurement '{}' of body {i} is {}",
                    data.compiled.set().definitions[j].name,
                    row[j]
                ),
            ));
        }
    }
    Ok(())
}

/// Names of the measurements of `data`'s set, in order.
pub(crate) fn measurement_names(data: &TrainingData) -> Vec<String> {
    data.compiled
        .set()
        .definitions
        .iter()
        .map(|d| d.name.clone())
        .collect()
}

/// Fits the paper's shape model (PCA, feature map, joint Gaussian) on `data`
/// with the default fit settings (all components).
pub(crate) fn fit_model(method: &str, data: &TrainingData) -> Result<ShapeModel, MethodError> {
    check_training(method, data, 2)?;
    let meshes: Vec<&[tapeshape_mesh::Vec3]> = data.meshes.iter().map(|m| m.as_slice()).collect();
    ShapeModel::fit(
        &meshes,
        &data.measurements,
        &measurement_names(data),
        &tapeshape_model::FitSettings::default(),
    )
    .map_err(|e| train_err(method, e.to_string()))
}

/// Checks that `model` was fitted on `data`'s measurement set and template
/// (same measurement names in the same order, same vertex count).
pub(crate) fn check_model(
    method: &str,
    model: &ShapeModel,
    data: &TrainingData,
) -> Result<(), MethodError> {
    if model.measurement_names != measurement_names(data) {
        return Err(train_err(
            method,
            "the model was trained on another measurement set than the data's: fit it on the same data",
        ));
    }
    if model.n_vertices() != data.topology.n_vertices() {
        return Err(train_err(
            method,
            format!(
                "the model has {} vertices, the data's topology {}",
                model.n_vertices(),
                data.topology.n_vertices()
            ),
        ));
    }
    Ok(())
}

/// Normalised PCA weights of every training body under `model`'s PCA,
/// `N x K` (row per body; `w_k = a_k . (x - mu) / sigma_k`, dimensionless).
pub fn training_weights(model: &ShapeModel, data: &TrainingData) -> Vec<Vec<f64>> {
    data.meshes
        .iter()
        .map(|m| model.pca.project(m.as_flattened()))
        .collect()
}

/// Per-measurement training mean and standard deviation (metres) from the
/// rows of `p` (`N x M`). A measurement constant on the training set gets
/// SD 0: callers leave it out of distances (it carries no information).
pub(crate) fn column_stats(p: &[Vec<f64>]) -> Vec<(f64, f64)> {
    let n = p.len() as f64;
    let m = p.first().map_or(0, Vec::len);
    (0..m)
        .map(|j| {
            let mean = p.iter().map(|r| r[j]).sum::<f64>() / n;
            let var = p.iter().map(|r| (r[j] - mean).powi(2)).sum::<f64>() / (n - 1.0).max(1.0);
            (mean, var.sqrt())
        })
        .collect()
}

/// A column SD below this fraction of the largest is treated as constant.
pub(crate) const CONSTANT_SD_FRACTION: f64 = 1e-9;

/// Whether measurement `j` varies on the training set (see [`column_stats`]).
pub(crate) fn informative(stats: &[(f64, f64)], j: usize) -> bool {
    let max = stats.iter().map(|s| s.1).fold(0.0, f64::max);
    stats[j].1 > CONSTANT_SD_FRACTION * max && stats[j].1 > 0.0
}

/// The training set's measurement names, per-measurement (mean, SD) (see
/// [`column_stats`]) and the indices of the informative measurements, the
/// ones a method standardises and uses. Errors (naming `method`) if every
/// measurement is constant on the training set.
#[allow(clippy::type_complexity)]
pub(crate) fn informative_columns(
    method: &str,
    data: &TrainingData,
) -> Result<(Vec<String>, Vec<(f64, f64)>, Vec<usize>), MethodError> {
    let names = measurement_names(data);
    let stats = column_stats(&data.measurements);
    let used: Vec<usize> = (0..names.len())
        .filter(|&j| informative(&stats, j))
        .collect();
    if used.is_empty() {
        return Err(train_err(
            method,
            "every measurement is constant on the training set",
        ));
    }
    Ok((names, stats, used))
}
