//! Training a model for the estimator: a dataset of bodies measured with
//! the union of named measurement sets, fitted by `tapeshape-model`, with
//! the template and the union's definitions stored in the model file.

use std::sync::Arc;

use serde::{Deserialize, Serialize};
use tapeshape_measure::{MeasurementSet, BUILTIN_SETS};
use tapeshape_mesh::{Anatomy, Topology, Vec3};
use tapeshape_model::{
    FitSettings, MeasurementSetText, ModelFile, Provenance, ShapeModel, TemplateInfo,
};
use tapeshape_population::{Dataset, DatasetKind};

use crate::PredictError;

/// The sets the default model carries.
pub const DEFAULT_SETS: [&str; 3] = ["paper34", "ansur", "quick"];

/// Settings of [`train`] (default: all components, f64, no notes).
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct TrainSettings {
    /// The model's fit settings (PCA threshold, components).
    pub fit: FitSettings,
    /// Keep the fewest PCA components explaining at least this share of the
    /// training variance (e.g. 0.999); `None`: keep all that `fit` keeps.
    pub variance_kept: Option<f64>,
    /// Round the PCA mean and basis to f32 precision (so that a compressed
    /// file is about half the size; the effect on accuracy is measured in
    /// `docs/results/predict-sreal.md`).
    pub round_to_f32: bool,
    /// Free-form provenance notes (dataset recipe, command).
    pub notes: String,
}

/// The union of measurement sets, deduplicated by name (first definition
/// kept), as TOML text that [`MeasurementSet::from_toml_str`] reads back.
///
/// Errors if a set is unknown or two sets define the same name differently
/// in what they compute (the kind and its parameters).
pub fn union_set_text(sets: &[&str]) -> Result<String, PredictError> {
    if sets.is_empty() {
        return Err(PredictError::Training(
            "no measurement set named: give at least one, e.g. --set paper34".into(),
        ));
    }
    let mut entries: Vec<toml::Value> = Vec::new();
    let mut names: Vec<String> = Vec::new();
    let mut parsed = Vec::new();
    for &set in sets {
        // Validate first (a clear error for an unknown or broken set).
        let ms = MeasurementSet::load(set)?;
        let text = match BUILTIN_SETS.iter().find(|(n, _)| *n == set) {
            Some((_, t)) => t.to_string(),
            None => std::fs::read_to_string(set).map_err(|source| PredictError::Io {
                path: set.to_string(),
                source,
            })?,
        };
        let table: toml::Table =
            toml::from_str(&text).map_err(|e| PredictError::Training(format!("set {set}: {e}")))?;
        let list = table
            .get("measurement")
            .and_then(|m| m.as_array())
            .cloned()
            .unwrap_or_default();
        for (entry, def) in list.into_iter().zip(&ms.definitions) {
            if let Some(i) = names.iter().position(|n| *n == def.name) {
                let (prev_set, prev): &(String, MeasurementSet) = &parsed[i];
                let prev_def = &prev.definitions[prev.index_of(&def.name).expect("present")];
                if prev_def.kind != def.kind {
                    return Err(PredictError::Training(format!(
                        "sets {prev_set} and {} both define '{}' but differently: train them separately or rename one",
                        ms.name, def.name
                    )));
                }
                continue;
            }
            names.push(def.name.clone());
            parsed.push((ms.name.clone(), ms.clone()));
            entries.push(entry);
        }
    }
    let mut header = toml::Table::new();
    header.insert("name".into(), toml::Value::String(sets.join("+")));
    header.insert(
        "description".into(),
        toml::Value::String(format!(
            "Union of the measurement sets {} (deduplicated by name).",
            sets.join(", ")
        )),
    );
    let mut root = toml::Table::new();
    root.insert("set".into(), toml::Value::Table(header));
    root.insert("measurement".into(), toml::Value::Array(entries));
    toml::to_string(&root).map_err(|e| PredictError::Training(format!("writing the union: {e}")))
}

/// The template the estimator predicts in: the body generator's topology and anatomy.
fn body_template() -> Result<(Arc<Topology>, Anatomy), PredictError> {
    let body = tapeshape_body::BodyModel::shared()
        .map_err(|e| PredictError::Training(format!("loading the body template: {e}")))?;
    Ok((body.topology().clone(), tapeshape_body::anatomy::anatomy()))
}

/// Trains a model on `dataset` (a population in the template topology) with
/// the union of `sets` (built-in names or set files).
///
/// Every body is measured with the compiled union (in parallel); the model
/// is fitted to the meshes (metres, station frame) and measurements; the
/// file carries the template's faces and anatomy and the union's text.
pub fn train(
    dataset: &Dataset,
    sets: &[&str],
    settings: &TrainSettings,
) -> Result<ModelFile, PredictError> {
    if dataset.header.kind == DatasetKind::Faces {
        return Err(PredictError::Training(
            "a faces dataset holds head regions only; train on a population or an import of whole bodies".into(),
        ));
    }
    if dataset.len() < 3 {
        return Err(PredictError::Training(format!(
            "the dataset has {} bodies; training needs at least 3 (the paper used hundreds)",
            dataset.len()
        )));
    }
    let (topology, anatomy) = body_template()?;
    if dataset.topology.n_vertices() != topology.n_vertices()
        || dataset.topology.faces() != topology.faces()
    {
        return Err(PredictError::Training(format!(
            "the dataset's topology ({} vertices, {} faces) is not the template's ({} vertices, {} faces): register the meshes to the template first",
            dataset.topology.n_vertices(),
            dataset.topology.faces().len(),
            topology.n_vertices(),
            topology.faces().len()
        )));
    }
    let text = union_set_text(sets)?;
    let set = MeasurementSet::from_toml_str(&text, &sets.join("+"))?;
    let compiled = set.compile(&topology, &anatomy)?;
    let bodies: Vec<&[Vec3]> = dataset.bodies.iter().map(Vec::as_slice).collect();
    let measured = compiled.measure_batch(&bodies);
    let mut rows = Vec::with_capacity(bodies.len());
    for (i, m) in measured.into_iter().enumerate() {
        let m = m.map_err(|e| {
            PredictError::Training(format!(
                "measuring body {i} ({}): {e}",
                dataset
                    .header
                    .bodies
                    .get(i)
                    .map_or("?", |b| b.name.as_str())
            ))
        })?;
        rows.push(m.iter().map(|x| x.value).collect::<Vec<f64>>());
    }
    let names: Vec<String> = set.definitions.iter().map(|d| d.name.clone()).collect();
    let mut model = ShapeModel::fit(&bodies, &rows, &names, &settings.fit)?;
    if let Some(share) = settings.variance_kept {
        if !(share > 0.0 && share <= 1.0) {
            return Err(PredictError::Training(format!(
                "variance share {share} is not in (0, 1]"
            )));
        }
        let var: Vec<f64> = model.pca.sigma.iter().map(|s| s * s).collect();
        let total: f64 = var.iter().sum();
        let mut acc = 0.0;
        let mut keep = var.len();
        for (k, v) in var.iter().enumerate() {
            acc += v;
            if acc >= share * total {
                keep = k + 1;
                break;
            }
        }
        if keep < model.n_components() {
            // Refit with fewer components: the model crate fits the feature
            // map and statistics for the components it keeps.
            let fit = FitSettings {
                max_components: Some(keep),
                ..settings.fit.clone()
            };
            model = ShapeModel::fit(&bodies, &rows, &names, &fit)?;
        }
    }
    if settings.round_to_f32 {
        for x in model.pca.basis_mut().iter_mut() {
            *x = *x as f32 as f64;
        }
        for x in model.pca.mean.iter_mut() {
            *x = *x as f32 as f64;
        }
    }
    let file = ModelFile {
        provenance: Provenance {
            dataset: format!(
                "{} bodies ({:?}{})",
                dataset.len(),
                dataset.header.kind,
                dataset
                    .header
                    .settings
                    .as_ref()
                    .map(|s| format!(", generated with seed {} and n {}", s.seed, s.n))
                    .unwrap_or_default()
            ),
            trained_by: format!("tapeshape-estimator {}", env!("CARGO_PKG_VERSION")),
            created: String::new(),
            notes: format!(
                "sets: {}; components: {}; variance kept: {:?}; f32-rounded basis: {}; {}",
                sets.join(", "),
                model.n_components(),
                settings.variance_kept,
                settings.round_to_f32,
                settings.notes
            ),
        },
        template: TemplateInfo {
            n_vertices: topology.n_vertices(),
            faces: topology.faces().to_vec(),
            anatomy,
        },
        measurement_set: MeasurementSetText {
            name: sets.join("+"),
            format: "toml".into(),
            text,
        },
        model,
    };
    file.validate()?;
    Ok(file)
}
