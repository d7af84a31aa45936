//! [`ShapeModel`]: the learned state (PCA, feature map, joint statistics).

use nalgebra::DMatrix;
use tapeshape_mesh::Vec3;

use crate::pca::Pca;
use crate::regress::{FeatureMap, JointGaussian};
use crate::{ModelError, Result};

/// Settings of [`ShapeModel::fit`].
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct FitSettings {
    /// Keep PCA components whose eigenvalue exceeds this fraction of the
    /// largest (default 1e-9, i.e. a standard deviation above ~3e-5 of the
    /// first component's: below that the Gram-matrix route loses orthogonality).
    pub rel_eigen_threshold: f64,
    /// Keep at most this many components (default: all, i.e. at most N - 1).
    pub max_components: Option<usize>,
    /// Keep only the fewest leading components explaining at least this
    /// fraction of the variance (default `None`: all). The basis is 3V x K
    /// doubles (about 0.33 MB per component on the 13,718-vertex template),
    /// so this bounds the model file.
    pub variance_fraction: Option<f64>,
}

impl Default for FitSettings {
    fn default() -> Self {
        Self {
            rel_eigen_threshold: 1e-9,
            max_components: None,
            variance_fraction: None,
        }
    }
}

/// The learned shape model: PCA of the training meshes, the feature-analysis
/// map from measurements to normalised weights, and the joint Gaussian of
/// (measurements, weights). Learned state only; settings live in
/// [`FitSettings`] and [`crate::PredictSettings`].
#[derive(Debug, Clone, serde::Serialize, serde::Deserialize)]
pub struct ShapeModel {
    /// Names of the M measurements, in the order of every measurement vector.
    pub measurement_names: Vec<String>,
    /// PCA of the meshes (metres).
    pub pca: Pca,
    /// Feature analysis `w = B [P; 1]`.
    pub feature_map: FeatureMap,
    /// Mean and covariance of `(P, w)` on the training set.
    pub joint: JointGaussian,
    /// Number of training bodies N.
    pub n_training: usize,
}

impl ShapeModel {
    /// Learns the model from `meshes` (N bodies, each V vertices in template
    /// order, metres, station frame) and `measurements` (N rows of M values,
    /// metres, in the order of `names`).
    ///
    /// Errors if the arrays are ragged, empty, non-finite, or N < 2.
    pub fn fit(
        meshes: &[&[Vec3]],
        measurements: &[Vec<f64>],
        names: &[String],
        settings: &FitSettings,
    ) -> Result<Self> {
        let n = meshes.len();
        if n < 2 {
            return Err(ModelError::InvalidTraining(format!(
                "need at least 2 training bodies, got {n}"
            )));
        }
        if measurements.len() != n {
            return Err(ModelError::InvalidTraining(format!(
                "{n} meshes but {} measurement rows",
                measurements.len()
            )));
        }
        let v = meshes[0].len();
        let m = names.len();
        if m == 0 {
            return Err(ModelError::InvalidTraining(
                "no measurements: the model needs at least one measurement to map from".into(),
            ));
        }
        if v == 0 {
            return Err(ModelError::InvalidTraining(
                "the meshes have no vertices".into(),
            ));
        }
        for (i, mesh) in meshes.iter().enumerate() {
            if mesh.len() != v {
                return Err(ModelError::InvalidTraining(format!(
                    "body {i} has {} vertices, body 0 has {v}: meshes must share the template",
                    mesh.len()
                )));
            }
        }
        for (i, row) in measurements.iter().enumerate() {
            if row.len() != m {
                return Err(ModelError::InvalidTraining(format!(
                    "body {i} has {} measurements, expected {m} ({})",
                    row.len(),
                    names.join(", ")
                )));
            }
            if let Some(j) = row.iter().position(|x| !x.is_finite()) {
                return Err(ModelError::NonFinite(format!(
                    "measurement '{}' of body {i} is {}",
                    names[j], row[j]
                )));
            }
        }
        let data = DMatrix::from_fn(3 * v, n, |r, i| meshes[i][r / 3][r % 3]);
        let fit = Pca::fit_with_variance(
            &data,
            settings.rel_eigen_threshold,
            settings.max_components,
            settings.variance_fraction,
        )?;
        let p = DMatrix::from_fn(n, m, |i, j| measurements[i][j]);
        let feature_map = FeatureMap::fit(&p, &fit.weights)?;
        let joint = JointGaussian::fit(&p, &fit.weights)?;
        Ok(Self {
            measurement_names: names.to_vec(),
            pca: fit.pca,
            feature_map,
            joint,
            n_training: n,
        })
    }

    /// Number of template vertices V.
    pub fn n_vertices(&self) -> usize {
        self.pca.dim() / 3
    }

    /// Number of PCA components K.
    pub fn n_components(&self) -> usize {
        self.pca.n_components
    }

    /// Number of measurements M.
    pub fn n_measurements(&self) -> usize {
        self.measurement_names.len()
    }

    /// Index of the measurement called `name`.
    pub fn measurement_index(&self, name: &str) -> Option<usize> {
        self.measurement_names.iter().position(|n| n == name)
    }

    /// The mesh (V vertices, metres, station frame) for normalised weights
    /// `w` (length K); errors if `w` has the wrong length or is not finite.
    pub fn shape(&self, w: &[f64]) -> Result<Vec<Vec3>> {
        if w.len() != self.n_components() {
            return Err(ModelError::InvalidInput(format!(
                "{} weights given, the model has {} components",
                w.len(),
                self.n_components()
            )));
        }
        if w.iter().any(|x| !x.is_finite()) {
            return Err(ModelError::NonFinite("shape weights".into()));
        }
        Ok(self.shape_unchecked(w))
    }

    /// [`ShapeModel::shape`] for weights known to have length K.
    pub(crate) fn shape_unchecked(&self, w: &[f64]) -> Vec<Vec3> {
        self.pca.reconstruct_points(w)
    }

    /// Training mean and standard deviation of every measurement (metres).
    pub fn measurement_stats(&self) -> Vec<(f64, f64)> {
        let dim = self.joint.n_measurements + self.joint.n_weights;
        (0..self.n_measurements())
            .map(|j| {
                (
                    self.joint.mean[j],
                    self.joint.cov[j * dim + j].max(0.0).sqrt(),
                )
            })
            .collect()
    }

    /// Start weights from the given measurements: feature analysis when every
    /// measurement is given without tolerance (the paper), otherwise the
    /// Gaussian conditional of the weights on the given ones, tolerance
    /// entering as observation noise. `given` holds (index, value in metres,
    /// tolerance in metres or 0).
    pub fn start_weights(&self, given: &[(usize, f64, f64)]) -> Result<Vec<f64>> {
        let m = self.n_measurements();
        if given.len() == m && given.iter().all(|g| g.2 == 0.0) {
            let mut p = vec![0.0; m];
            for &(j, x, _) in given {
                p[j] = x;
            }
            return Ok(self.feature_map.apply(&p));
        }
        let wanted: Vec<usize> = (m..m + self.n_components()).collect();
        let observed: Vec<(usize, f64, f64)> =
            given.iter().map(|&(j, x, t)| (j, x, t * t)).collect();
        Ok(self
            .joint
            .conditional(&wanted, &observed)?
            .mean
            .iter()
            .copied()
            .collect())
    }

    /// For each measurement, its mean and standard deviation (metres) given the
    /// observed ones (`observed[j] = Some(value in metres)`), from the training
    /// Gaussian: an observed measurement gets `(value, 0)`. The station uses this
    /// to flag a reading that disagrees with the others ("chest 58 cm is 6 SD
    /// below what the other readings predict").
    ///
    /// Errors if `observed` does not have M entries or holds a non-finite value.
    pub fn conditional_measurements(&self, observed: &[Option<f64>]) -> Result<Vec<(f64, f64)>> {
        let m = self.n_measurements();
        if observed.len() != m {
            return Err(ModelError::InvalidInput(format!(
                "{} readings given, the model has {m} measurements",
                observed.len()
            )));
        }
        let mut obs = Vec::new();
        let mut wanted = Vec::new();
        for (j, o) in observed.iter().enumerate() {
            match o {
                Some(x) if !x.is_finite() => {
                    return Err(ModelError::NonFinite(format!(
                        "reading '{}' is {x}",
                        self.measurement_names[j]
                    )))
                }
                Some(x) => obs.push((j, *x, 0.0)),
                None => wanted.push(j),
            }
        }
        let cond = self.joint.conditional(&wanted, &obs)?;
        let mut out: Vec<(f64, f64)> = observed.iter().map(|o| (o.unwrap_or(0.0), 0.0)).collect();
        for (a, &j) in wanted.iter().enumerate() {
            out[j] = (cond.mean[a], cond.cov[(a, a)].max(0.0).sqrt());
        }
        Ok(out)
    }

    /// Checks internal consistency (array lengths, finiteness); used after
    /// loading a file so that a damaged model is an error, not a panic later.
    pub fn validate(&self) -> Result<()> {
        let bad = |what: String| {
            Err(ModelError::InvalidInput(format!(
                "inconsistent model: {what}"
            )))
        };
        let d = self.pca.dim();
        let k = self.pca.n_components;
        let m = self.measurement_names.len();
        if d == 0 || !d.is_multiple_of(3) {
            return bad(format!(
                "mean has {d} entries, not a positive multiple of 3"
            ));
        }
        if self.pca.basis_len() != d * k || self.pca.sigma.len() != k {
            return bad("basis or sigma length does not match the components".into());
        }
        if self.pca.sigma.iter().any(|s| !(s.is_finite() && *s > 0.0)) {
            return bad("a component's standard deviation is not positive".into());
        }
        let fm = &self.feature_map;
        if fm.n_measurements != m || fm.n_weights != k || fm.b.len() != k * (m + 1) {
            return bad("feature map dimensions".into());
        }
        let j = &self.joint;
        let dim = m + k;
        if j.n_measurements != m
            || j.n_weights != k
            || j.mean.len() != dim
            || j.cov.len() != dim * dim
        {
            return bad("joint statistics dimensions".into());
        }
        let all = self
            .pca
            .mean
            .iter()
            .chain(&fm.b)
            .chain(&j.mean)
            .chain(&j.cov);
        if all.into_iter().any(|x| !x.is_finite()) || !self.pca.basis_is_finite() {
            return Err(ModelError::NonFinite(
                "model contains NaN or infinite numbers".into(),
            ));
        }
        Ok(())
    }
}
