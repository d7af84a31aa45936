//! What every experiment shares: training data from datasets, the
//! measurement sets the paper samples (S_close, S_k), running every method
//! on every case in parallel with a progress bar, and the per-result
//! metrics (errors per dimension, vertex distances, plausibility, flipped
//! triangles).
//!
//! Units: metres inside, millimetres in every reported number.

use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Arc;
use std::time::Instant;

use nalgebra::{DMatrix, DVector};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};
use rayon::prelude::*;
use tapeshape_measure::{CompiledSet, MeasurementSet};
use tapeshape_mesh::{Anatomy, Topology, Vec3};
use tapeshape_model::pca::Pca;
use tapeshape_model::predict::{chi2_quantile, triangle_changes, PlausibilityLabel};

use super::EvalError;
use crate::{Method, TrainingData};

/// Compiles `set` for `topology` (with `anatomy`'s landmarks and parts) and
/// measures every body (`N x V` vertices, metres) with it.
pub fn training_data(
    meshes: Vec<Vec<Vec3>>,
    topology: &Arc<Topology>,
    set: &MeasurementSet,
    anatomy: &Anatomy,
) -> Result<TrainingData, EvalError> {
    let compiled = Arc::new(set.compile(topology, anatomy)?);
    let bodies: Vec<&[Vec3]> = meshes.iter().map(Vec::as_slice).collect();
    let mut measurements = Vec::with_capacity(bodies.len());
    for (i, m) in compiled.measure_batch(&bodies).into_iter().enumerate() {
        let m = m.map_err(|e| EvalError::Data(format!("measuring training body {i}: {e}")))?;
        measurements.push(m.iter().map(|x| x.value).collect());
    }
    Ok(TrainingData {
        meshes,
        measurements,
        compiled,
        topology: topology.clone(),
    })
}

/// Measures `vertices` with every measurement of `compiled` (metres; NaN
/// where a measurement fails on a broken shape, so one bad result never
/// stops an experiment).
pub fn measure_all(compiled: &CompiledSet, vertices: &[Vec3]) -> Vec<f64> {
    match compiled.measure(vertices) {
        Ok(m) => m.iter().map(|x| x.value).collect(),
        Err(_) => (0..compiled.len())
            .map(|j| {
                compiled
                    .measure_one(j, vertices)
                    .map_or(f64::NAN, |m| m.value)
            })
            .collect(),
    }
}

/// The reported dimensions of a measurement set: each measurement alone,
/// except members of a group (knee and arm circumferences as 4 geodesics),
/// which form one dimension whose error is the sum of the members' errors
/// (the paper's Table of S_real).
#[derive(Debug, Clone)]
pub struct Dimensions {
    /// Name of each dimension (the group name for groups).
    pub names: Vec<String>,
    /// Measurement indices of each dimension.
    pub members: Vec<Vec<usize>>,
}

impl Dimensions {
    /// Dimensions of the measurements `used` (indices into `set`), in the
    /// set's order; a group appears where its first member is.
    pub fn of(set: &MeasurementSet, used: &[usize]) -> Self {
        let mut names: Vec<String> = Vec::new();
        let mut members: Vec<Vec<usize>> = Vec::new();
        for &j in used {
            let d = &set.definitions[j];
            match &d.group {
                Some(g) => match names.iter().position(|n| n == g) {
                    Some(k) => members[k].push(j),
                    None => {
                        names.push(g.clone());
                        members.push(vec![j]);
                    }
                },
                None => {
                    names.push(d.name.clone());
                    members.push(vec![j]);
                }
            }
        }
        Self { names, members }
    }

    /// Number of dimensions.
    pub fn len(&self) -> usize {
        self.names.len()
    }

    /// True when there are none.
    pub fn is_empty(&self) -> bool {
        self.names.is_empty()
    }

    /// Error per dimension, mm: sum over its members of |achieved - target|
    /// (both metres, indexed by measurement). NaN if a member is missing.
    pub fn errors_mm(&self, targets: &[Option<f64>], achieved: &[f64]) -> Vec<f64> {
        self.members
            .iter()
            .map(|m| {
                m.iter()
                    .map(|&j| match targets[j] {
                        Some(t) => (achieved[j] - t).abs() * 1000.0,
                        None => f64::NAN,
                    })
                    .sum()
            })
            .collect()
    }
}

/// Indices of the measurements that vary on the training rows (SD above
/// 1e-9 of the largest SD): a constant one carries no information and
/// cannot be sampled.
pub fn informative(rows: &[Vec<f64>]) -> Vec<usize> {
    let m = rows.first().map_or(0, Vec::len);
    let sd: Vec<f64> = (0..m)
        .map(|j| {
            let n = rows.len() as f64;
            let mean = rows.iter().map(|r| r[j]).sum::<f64>() / n;
            (rows.iter().map(|r| (r[j] - mean).powi(2)).sum::<f64>() / (n - 1.0).max(1.0)).sqrt()
        })
        .collect();
    let max = sd.iter().copied().fold(0.0, f64::max);
    (0..m)
        .filter(|&j| sd[j] > 1e-9 * max && sd[j] > 0.0)
        .collect()
}

/// The Gaussian N(mu, Sigma) of the training measurements `used` (metres)
/// with a Cholesky factor L (L L^T = Sigma).
#[derive(Debug, Clone)]
pub struct MeasurementGaussian {
    /// Measurement indices modelled.
    pub used: Vec<usize>,
    /// Mean, metres.
    pub mean: DVector<f64>,
    /// Lower Cholesky factor of the covariance, metres.
    pub chol: DMatrix<f64>,
    /// Jitter added to the covariance diagonal (m^2) to make it positive
    /// definite (0 when it already was).
    pub jitter: f64,
}

impl MeasurementGaussian {
    /// Fits mean and (unbiased) covariance of `rows[.][used]`.
    pub fn fit(rows: &[Vec<f64>], used: &[usize]) -> Result<Self, EvalError> {
        let n = rows.len();
        let m = used.len();
        if n < 2 || m == 0 {
            return Err(EvalError::Data(format!(
                "a Gaussian of {m} measurements needs at least 2 training rows, got {n}"
            )));
        }
        let x = DMatrix::from_fn(n, m, |i, j| rows[i][used[j]]);
        let mean = DVector::from_fn(m, |j, _| x.column(j).mean());
        let mut c = x.clone();
        for j in 0..m {
            let mj = mean[j];
            c.column_mut(j).add_scalar_mut(-mj);
        }
        let cov = c.tr_mul(&c) / (n as f64 - 1.0);
        let scale = cov.diagonal().max();
        let mut jitter = 0.0;
        loop {
            let mut s = cov.clone();
            for j in 0..m {
                s[(j, j)] += jitter;
            }
            if let Some(ch) = s.cholesky() {
                return Ok(Self {
                    used: used.to_vec(),
                    mean,
                    chol: ch.l(),
                    jitter,
                });
            }
            jitter = if jitter == 0.0 {
                1e-12 * scale
            } else {
                jitter * 10.0
            };
            if jitter > 1e-3 * scale {
                return Err(EvalError::Data(
                    "the covariance of the training measurements is not positive definite even with jitter".into(),
                ));
            }
        }
    }

    /// A full target vector (length `m_total`, `None` outside `used`) from a
    /// standard-space vector `z`: `mu + L z`.
    fn targets(&self, z: &DVector<f64>, m_total: usize) -> Vec<Option<f64>> {
        let x = &self.mean + &self.chol * z;
        let mut t = vec![None; m_total];
        for (k, &j) in self.used.iter().enumerate() {
            t[j] = Some(x[k]);
        }
        t
    }

    /// `n` samples: S_close (`k = None`: draws of N(mu, Sigma)) or S_k
    /// (`k = Some(k)`: `mu + k L u`, u uniform on the unit sphere, i.e.
    /// points at Mahalanobis distance exactly k). Samples with a
    /// non-positive length are drawn again; returns the samples and how many
    /// were redrawn.
    pub fn sample(
        &self,
        n: usize,
        k: Option<f64>,
        m_total: usize,
        seed: u64,
    ) -> (Vec<Vec<Option<f64>>>, usize) {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let m = self.used.len();
        let mut out = Vec::with_capacity(n);
        let mut redrawn = 0;
        while out.len() < n {
            let mut z = DVector::from_fn(m, |_, _| StandardNormal.sample(&mut rng));
            if let Some(k) = k {
                let norm = z.norm();
                if norm == 0.0 {
                    continue;
                }
                z *= k / norm;
            }
            let t = self.targets(&z, m_total);
            if t.iter().flatten().all(|v| *v > 0.0 && v.is_finite()) {
                out.push(t);
            } else {
                redrawn += 1;
            }
        }
        (out, redrawn)
    }

    /// Mahalanobis radius of the ellipsoid through `mu + k sigma` (sigma =
    /// the per-measurement standard deviations): the literal reading of the
    /// paper's "ellipsoidal surface x^T Sigma^-1 x where x = mu + k Sigma_d"
    /// (with the diagonal's square roots, so that units agree). It equals
    /// `k sqrt(1^T R^-1 1)` with R the correlation matrix.
    pub fn radius_through_sd(&self, k: f64) -> f64 {
        let m = self.used.len();
        // sigma_j = norm of row j of L (Sigma = L L^T).
        let sd = DVector::from_fn(m, |j, _| self.chol.row(j).norm());
        match self.chol.solve_lower_triangular(&sd) {
            Some(z) => k * z.norm(),
            None => f64::NAN,
        }
    }

    /// Typical Mahalanobis radius of N(mu, Sigma) draws: sqrt(dimension).
    pub fn typical_radius(&self) -> f64 {
        (self.used.len() as f64).sqrt()
    }

    /// Mahalanobis distance of a full target vector (its `used` entries).
    pub fn mahalanobis(&self, t: &[Option<f64>]) -> f64 {
        let x = DVector::from_fn(self.used.len(), |k, _| {
            t[self.used[k]].unwrap_or(f64::NAN) - self.mean[k]
        });
        match self.chol.solve_lower_triangular(&x) {
            Some(z) => z.norm(),
            None => f64::NAN,
        }
    }
}

/// What results are compared against, learned from the training meshes
/// only: the PCA of the training bodies (all components) for plausibility,
/// the training mean body for flipped triangles, and how many triangles the
/// training bodies themselves flip relative to that mean (fingers and toes
/// differ from body to body).
pub struct Reference {
    /// PCA of the training meshes (metres; all components).
    pub pca: Pca,
    /// Training mean body, metres.
    pub mean: Vec<Vec3>,
    /// Topology.
    pub topology: Arc<Topology>,
    /// Most triangles any training body flips relative to the mean.
    pub train_flips_max: usize,
    /// Leading components explaining 99 % of the training variance: the
    /// Mahalanobis distance is taken over these only (the trailing
    /// components' SDs are underestimated from N bodies, so a held-out body
    /// projects onto them with large normalised weights and every body,
    /// the true ones included, would look implausible).
    pub n_lead: usize,
}

impl Reference {
    /// Learns the reference from the training meshes.
    pub fn new(data: &TrainingData) -> Result<Self, EvalError> {
        let n = data.meshes.len();
        let d = data.topology.n_vertices() * 3;
        let x = DMatrix::from_fn(d, n, |r, c| data.meshes[c][r / 3][r % 3]);
        let fit = Pca::fit(&x, 1e-9, None).map_err(|e| EvalError::Data(e.to_string()))?;
        let mean: Vec<Vec3> = fit
            .pca
            .mean
            .chunks_exact(3)
            .map(|c| [c[0], c[1], c[2]])
            .collect();
        let train_flips_max = data
            .meshes
            .par_iter()
            .map(|m| triangle_changes(&data.topology, &mean, m).0)
            .max()
            .unwrap_or(0);
        let var: Vec<f64> = fit.pca.sigma.iter().map(|x| x * x).collect();
        let total: f64 = var.iter().sum();
        let mut acc = 0.0;
        let mut n_lead = var.len();
        for (k, v) in var.iter().enumerate() {
            acc += v;
            if acc >= 0.99 * total {
                n_lead = k + 1;
                break;
            }
        }
        Ok(Self {
            pca: fit.pca,
            mean,
            topology: data.topology.clone(),
            train_flips_max,
            n_lead,
        })
    }

    /// Plausibility of a body: Mahalanobis distance of its normalised PCA
    /// weights (projection onto the training PCA) over the leading
    /// [`Reference::n_lead`] components, its chi-square quantile with that
    /// many degrees of freedom and label, and the RMS distance (mm) of the
    /// body from its projection (how far it left the training space).
    pub fn plausibility(&self, vertices: &[Vec3]) -> (f64, f64, PlausibilityLabel, f64) {
        let flat: Vec<f64> = vertices.iter().flat_map(|p| p.iter().copied()).collect();
        let w = self.pca.project(&flat);
        let lead = &w[..self.n_lead.min(w.len())];
        let maha = lead.iter().map(|x| x * x).sum::<f64>().sqrt();
        let q = chi2_quantile(maha * maha, lead.len());
        let back = self.pca.reconstruct(&w);
        let rms = (flat
            .iter()
            .zip(&back)
            .map(|(a, b)| (a - b).powi(2))
            .sum::<f64>()
            / vertices.len() as f64)
            .sqrt()
            * 1000.0;
        (maha, q, PlausibilityLabel::from_quantile(q), rms)
    }

    /// Triangles of `vertices` facing the other way than in the training mean.
    pub fn flips(&self, vertices: &[Vec3]) -> usize {
        triangle_changes(&self.topology, &self.mean, vertices).0
    }
}

/// Average and maximum vertex-to-vertex distance, mm.
pub fn vertex_distance_mm(a: &[Vec3], b: &[Vec3]) -> (f64, f64) {
    let d: Vec<f64> = a
        .iter()
        .zip(b)
        .map(|(p, q)| tapeshape_mesh::vec3::distance(*p, *q) * 1000.0)
        .collect();
    (
        d.iter().sum::<f64>() / d.len().max(1) as f64,
        d.iter().copied().fold(0.0, f64::max),
    )
}

/// One input to predict from.
#[derive(Debug, Clone)]
pub struct Case {
    /// Targets, metres, one per measurement of the set (`None` = not given).
    pub targets: Vec<Option<f64>>,
    /// The true body, where known (S_real, small-train).
    pub truth: Option<Vec<Vec3>>,
    /// Keep the predicted vertices (for figures).
    pub keep: bool,
}

/// The result of one method on one case.
#[derive(Debug, Clone)]
pub struct Outcome {
    /// All measurements of the set on the result, metres (NaN where failed).
    pub achieved: Vec<f64>,
    /// Error per reported dimension, mm (see [`Dimensions`]).
    pub errors: Vec<f64>,
    /// Seconds the prediction took.
    pub seconds: f64,
    /// Plausibility: Mahalanobis distance, quantile, label, out-of-space RMS mm.
    pub plausibility: (f64, f64, PlausibilityLabel, f64),
    /// Triangles flipped relative to the training mean.
    pub flips: usize,
    /// Average and maximum vertex distance to the truth, mm.
    pub vertex_distance: Option<(f64, f64)>,
    /// The predicted vertices, when the case asked to keep them.
    pub vertices: Option<Vec<Vec3>>,
    /// The method's error, if it failed (then the numbers are NaN).
    pub failure: Option<String>,
}

/// A progress bar on stderr (hidden when stderr is not a terminal; a line
/// per finished stage is printed either way by the callers).
pub fn progress_bar(len: u64, message: &str) -> indicatif::ProgressBar {
    let pb = indicatif::ProgressBar::new(len);
    pb.set_style(
        indicatif::ProgressStyle::with_template(
            "{msg:>28} [{bar:30}] {pos}/{len} {elapsed_precise} eta {eta}",
        )
        .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar())
        .progress_chars("=> "),
    );
    pb.set_message(message.to_string());
    pb
}

/// Runs every method on every case (all pairs in parallel on the rayon
/// pool) and measures the results. Returns `[method][case]`.
pub fn run_all(
    methods: &[Box<dyn Method>],
    cases: &[Case],
    compiled: &CompiledSet,
    dims: &Dimensions,
    reference: &Reference,
    label: &str,
) -> Vec<Vec<Outcome>> {
    let pairs: Vec<(usize, usize)> = (0..methods.len())
        .flat_map(|m| (0..cases.len()).map(move |c| (m, c)))
        .collect();
    let pb = progress_bar(pairs.len() as u64, label);
    let done = AtomicUsize::new(0);
    let t0 = Instant::now();
    let results: Vec<Outcome> = pairs
        .par_iter()
        .map(|&(m, c)| {
            let case = &cases[c];
            let t = Instant::now();
            let r = methods[m].predict(&case.targets);
            let seconds = t.elapsed().as_secs_f64();
            let out = match r {
                Ok(o) => {
                    let achieved = measure_all(compiled, &o.vertices);
                    let errors = dims.errors_mm(&case.targets, &achieved);
                    Outcome {
                        errors,
                        seconds,
                        plausibility: reference.plausibility(&o.vertices),
                        flips: reference.flips(&o.vertices),
                        vertex_distance: case
                            .truth
                            .as_ref()
                            .map(|t| vertex_distance_mm(&o.vertices, t)),
                        vertices: case.keep.then_some(o.vertices),
                        achieved,
                        failure: None,
                    }
                }
                Err(e) => Outcome {
                    achieved: vec![f64::NAN; compiled.len()],
                    errors: vec![f64::NAN; dims.len()],
                    seconds,
                    plausibility: (f64::NAN, f64::NAN, PlausibilityLabel::Implausible, f64::NAN),
                    flips: 0,
                    vertex_distance: None,
                    vertices: None,
                    failure: Some(e.to_string()),
                },
            };
            pb.inc(1);
            done.fetch_add(1, Ordering::Relaxed);
            out
        })
        .collect();
    pb.finish_and_clear();
    eprintln!(
        "{label}: {} predictions ({} methods x {} cases) in {:.1} s",
        pairs.len(),
        methods.len(),
        cases.len(),
        t0.elapsed().as_secs_f64()
    );
    let mut by_method: Vec<Vec<Outcome>> = (0..methods.len()).map(|_| Vec::new()).collect();
    for ((m, _), o) in pairs.into_iter().zip(results) {
        by_method[m].push(o);
    }
    by_method
}

/// Mean of the finite values (NaN if none).
pub fn mean(v: impl IntoIterator<Item = f64>) -> f64 {
    let (s, n) = v
        .into_iter()
        .filter(|x| x.is_finite())
        .fold((0.0, 0usize), |(s, n), x| (s + x, n + 1));
    if n == 0 {
        f64::NAN
    } else {
        s / n as f64
    }
}

/// Maximum of the finite values (NaN if none).
pub fn max(v: impl IntoIterator<Item = f64>) -> f64 {
    v.into_iter()
        .filter(|x| x.is_finite())
        .fold(f64::NAN, |a, x| if a.is_nan() { x } else { a.max(x) })
}

/// Summary numbers of one method over a list of outcomes.
#[derive(Debug, Clone, Copy)]
pub struct Summary {
    /// Average error over all dimensions and cases, mm.
    pub mean_error: f64,
    /// Results that failed.
    pub failures: usize,
    /// Share of results labelled implausible (quantile >= 0.999).
    pub implausible: f64,
    /// Mean out-of-space RMS, mm.
    pub out_of_space: f64,
    /// Results with more flipped triangles than any training body.
    pub folded: usize,
    /// Mean seconds per prediction.
    pub seconds: f64,
    /// Mean of the average vertex distances, mm (NaN without truth).
    pub vertex_mean: f64,
    /// Largest vertex distance, mm.
    pub vertex_max: f64,
}

/// Summarises `outcomes` (one method).
pub fn summarise(outcomes: &[Outcome], reference: &Reference) -> Summary {
    let ok: Vec<&Outcome> = outcomes.iter().filter(|o| o.failure.is_none()).collect();
    Summary {
        mean_error: mean(ok.iter().flat_map(|o| o.errors.iter().copied())),
        failures: outcomes.len() - ok.len(),
        implausible: ok
            .iter()
            .filter(|o| o.plausibility.2 == PlausibilityLabel::Implausible)
            .count() as f64
            / ok.len().max(1) as f64,
        out_of_space: mean(ok.iter().map(|o| o.plausibility.3)),
        folded: ok
            .iter()
            .filter(|o| o.flips > reference.train_flips_max)
            .count(),
        seconds: mean(outcomes.iter().map(|o| o.seconds)),
        vertex_mean: mean(ok.iter().filter_map(|o| o.vertex_distance.map(|v| v.0))),
        vertex_max: max(ok.iter().filter_map(|o| o.vertex_distance.map(|v| v.1))),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn samples_on_the_ellipsoid_have_mahalanobis_k() {
        // Correlated 3-D Gaussian from a fixed set of rows.
        let rows: Vec<Vec<f64>> = (0..200)
            .map(|i| {
                let a = (i as f64 * 0.37).sin();
                let b = (i as f64 * 1.13).cos();
                let c = (i as f64 * 0.71).sin() * (i as f64 * 0.2).cos();
                vec![1.0 + 0.1 * a, 2.0 + 0.05 * a + 0.1 * b, 0.5 + 0.02 * c]
            })
            .collect();
        let g = MeasurementGaussian::fit(&rows, &[0, 1, 2]).unwrap();
        assert_eq!(g.jitter, 0.0);
        for k in [2.0, 4.0] {
            let (s, _) = g.sample(50, Some(k), 3, 7);
            for t in &s {
                assert!((g.mahalanobis(t) - k).abs() < 1e-9);
            }
        }
        // S_close: mean squared Mahalanobis distance ~ dimension (3).
        let (s, _) = g.sample(4000, None, 3, 8);
        let m2 = s.iter().map(|t| g.mahalanobis(t).powi(2)).sum::<f64>() / s.len() as f64;
        assert!((m2 - 3.0).abs() < 0.2, "{m2}");
        // Sample mean near the training mean.
        let m0 = s.iter().map(|t| t[0].unwrap()).sum::<f64>() / s.len() as f64;
        assert!((m0 - g.mean[0]).abs() < 0.01);
    }

    #[test]
    fn radius_through_sd_matches_correlation_formula() {
        // Independent: 1^T R^-1 1 = m; perfectly correlated would give 1.
        let rows: Vec<Vec<f64>> = (0..400)
            .map(|i| {
                let a = (i as f64 * 0.37).sin();
                let b = (i as f64 * 1.13).cos();
                vec![1.0 + 0.1 * a, 2.0 + 0.3 * b]
            })
            .collect();
        let g = MeasurementGaussian::fit(&rows, &[0, 1]).unwrap();
        // The point mu + k sigma lies on the returned ellipsoid.
        let sd: Vec<f64> = (0..2).map(|j| g.chol.row(j).norm()).collect();
        let t = vec![Some(g.mean[0] + 2.0 * sd[0]), Some(g.mean[1] + 2.0 * sd[1])];
        assert!((g.mahalanobis(&t) - g.radius_through_sd(2.0)).abs() < 1e-9);
        // Nearly uncorrelated columns: radius close to k sqrt(2).
        assert!((g.radius_through_sd(1.0) - 2f64.sqrt()).abs() < 0.1);
    }

    #[test]
    fn constant_measurements_are_left_out() {
        let rows = vec![
            vec![1.0, 2.0, 3.0],
            vec![1.0, 2.5, 3.1],
            vec![1.0, 2.2, 2.9],
        ];
        assert_eq!(informative(&rows), vec![1, 2]);
    }

    #[test]
    fn vertex_distances() {
        let a = vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0]];
        let b = vec![[0.0, 0.0, 0.003], [1.0, 0.004, 0.0]];
        let (m, x) = vertex_distance_mm(&a, &b);
        assert!((m - 3.5).abs() < 1e-9 && (x - 4.0).abs() < 1e-9);
    }
}
