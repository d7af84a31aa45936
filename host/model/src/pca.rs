//! PCA of registered meshes from the N x N Gram matrix.
//!
//! The training data are N bodies of V vertices each, stacked as columns of a
//! 3V x N matrix (metres). Since N (hundreds) is far below 3V (tens of
//! thousands), the principal directions come from the eigen-decomposition of
//! the Gram matrix `G = Xc^T Xc` (N x N) of the centred data `Xc`: for
//! `G v = lambda v`, `a = Xc v / sqrt(lambda)` is a unit principal direction and
//! the body's weight along it is `sqrt(lambda) v[i]`. This is the thin SVD of
//! `Xc` computed at the cost of one N x N eigen-problem and two 3V x N x N
//! products.

use std::sync::OnceLock;

use nalgebra::{DMatrix, SymmetricEigen};

use crate::{ModelError, Result};

/// PCA of a data matrix (the learned part of [`crate::ShapeModel`]'s shape space).
///
/// The basis `A` (D x K, **row-major**, `basis[r * K + k]`, orthonormal
/// columns) is held as f64 values, or as f32 values where the model was
/// stored so ([`Pca::set_basis_f32`], as the embedded default is). Why both:
/// [`Pca::reconstruct`] and [`Pca::project`] stream the whole basis (33 MB
/// at f64 for the default model) and are memory-bound, and a model loaded
/// from f32 values need never widen them (12 % of a whole `tapeshape
/// predict`, measured): [`Pca::basis`] widens on first use only, and
/// [`Pca::basis_row`] reads either. Results are bit for bit the same, since
/// every f32 value is exactly the f64 it stands for.
#[derive(Debug, Clone, serde::Deserialize)]
#[serde(from = "PcaRepr<Vec<f64>, Vec<f64>>")]
pub struct Pca {
    /// Mean `mu`, length D (= 3V, metres, vertex-major `[x0, y0, z0, x1, ...]`).
    pub mean: Vec<f64>,
    /// Number of components K.
    pub n_components: usize,
    /// Standard deviation of the training weights along each component,
    /// `sigma_k = sqrt(eigenvalue_k / (N - 1))`, metres; descending.
    pub sigma: Vec<f64>,
    /// The basis as f64; set from the start, or widened from `narrow` on the
    /// first [`Pca::basis`]. At least one of the two is always set.
    wide: OnceLock<Vec<f64>>,
    /// The basis as f32 where every entry is exactly an f32: set by
    /// [`Pca::set_basis_f32`], or found on first use from `wide` (`None`
    /// inside where some entry is not).
    narrow: OnceLock<Option<Vec<f32>>>,
}

/// The serialised form of [`Pca`] (the model file's layout: the basis as f64).
#[derive(serde::Serialize, serde::Deserialize)]
struct PcaRepr<V, B> {
    mean: V,
    basis: B,
    n_components: usize,
    sigma: V,
}

impl From<PcaRepr<Vec<f64>, Vec<f64>>> for Pca {
    fn from(r: PcaRepr<Vec<f64>, Vec<f64>>) -> Self {
        Pca::new(r.mean, r.basis, r.n_components, r.sigma)
    }
}

impl serde::Serialize for Pca {
    fn serialize<S: serde::Serializer>(&self, s: S) -> std::result::Result<S::Ok, S::Error> {
        // Borrowed, so saving a model copies nothing; the same bytes as the Vec form.
        PcaRepr {
            mean: &self.mean[..],
            basis: self.basis(),
            n_components: self.n_components,
            sigma: &self.sigma[..],
        }
        .serialize(s)
    }
}

/// Result of [`Pca::fit`]: the PCA and the training bodies' normalised weights.
#[derive(Debug, Clone)]
pub struct PcaFit {
    /// The PCA.
    pub pca: Pca,
    /// Normalised weights `w = W / sigma` of the training bodies, N x K.
    pub weights: DMatrix<f64>,
}

impl Pca {
    /// Fits the PCA of `data` (D x N, one body per column, metres).
    ///
    /// Keeps the components whose eigenvalue exceeds `rel_threshold` times the
    /// largest (at most N - 1 and at most `max_components`). Signs are fixed so
    /// that each basis column's largest-magnitude entry is positive, which makes
    /// the result deterministic.
    ///
    /// Errors if N < 2, D < 1, the data are not finite, or all bodies are equal.
    pub fn fit(
        data: &DMatrix<f64>,
        rel_threshold: f64,
        max_components: Option<usize>,
    ) -> Result<PcaFit> {
        Self::fit_with_variance(data, rel_threshold, max_components, None)
    }

    /// [`Pca::fit`], additionally keeping only the fewest leading components
    /// whose eigenvalues sum to at least `variance_fraction` (in (0, 1]) of
    /// the total, if given.
    pub fn fit_with_variance(
        data: &DMatrix<f64>,
        rel_threshold: f64,
        max_components: Option<usize>,
        variance_fraction: Option<f64>,
    ) -> Result<PcaFit> {
        let (d, n) = data.shape();
        if n < 2 {
            return Err(ModelError::InvalidTraining(format!(
                "PCA needs at least 2 bodies, got {n}"
            )));
        }
        if d == 0 {
            return Err(ModelError::InvalidTraining(
                "bodies have no vertices".into(),
            ));
        }
        if data.iter().any(|x| !x.is_finite()) {
            return Err(ModelError::NonFinite(
                "training meshes contain NaN or infinite coordinates".into(),
            ));
        }
        let mean = data.column_mean();
        let mut centred = data.clone();
        for mut col in centred.column_iter_mut() {
            col -= &mean;
        }
        let gram = centred.tr_mul(&centred);
        let eig = SymmetricEigen::try_new(gram, f64::EPSILON, 0).ok_or_else(|| {
            ModelError::Numerical("eigen-decomposition of the Gram matrix did not converge".into())
        })?;
        let mut order: Vec<usize> = (0..n).collect();
        order.sort_by(|&a, &b| eig.eigenvalues[b].total_cmp(&eig.eigenvalues[a]));
        let lambda_max = eig.eigenvalues[order[0]];
        if lambda_max <= 0.0 {
            return Err(ModelError::InvalidTraining(
                "all training bodies are identical: no shape variation to learn".into(),
            ));
        }
        let mut cap = max_components.unwrap_or(usize::MAX).min(n - 1);
        if let Some(frac) = variance_fraction {
            if !(frac > 0.0 && frac <= 1.0) {
                return Err(ModelError::InvalidInput(format!(
                    "variance fraction must lie in (0, 1], got {frac}"
                )));
            }
            let total: f64 = order.iter().map(|&i| eig.eigenvalues[i].max(0.0)).sum();
            let mut acc = 0.0;
            for (j, &i) in order.iter().enumerate() {
                acc += eig.eigenvalues[i].max(0.0);
                if acc >= frac * total * (1.0 - 1e-12) {
                    cap = cap.min(j + 1);
                    break;
                }
            }
        }
        let kept: Vec<usize> = order
            .into_iter()
            .filter(|&i| eig.eigenvalues[i] > rel_threshold * lambda_max)
            .take(cap)
            .collect();
        let k = kept.len();
        let mut v = DMatrix::<f64>::zeros(n, k);
        let mut lambdas = Vec::with_capacity(k);
        for (j, &i) in kept.iter().enumerate() {
            let mut col = eig.eigenvectors.column(i).into_owned();
            let imax = col.iamax();
            if col[imax] < 0.0 {
                col.neg_mut();
            }
            v.set_column(j, &col);
            lambdas.push(eig.eigenvalues[i]);
        }
        // A = Xc V diag(1 / sqrt(lambda)).
        let mut a = &centred * &v;
        for (j, mut col) in a.column_iter_mut().enumerate() {
            col /= lambdas[j].sqrt();
        }
        // Sign rule on the basis itself (v's sign rule is not the same thing).
        for j in 0..k {
            let imax = a.column(j).iamax();
            if a[(imax, j)] < 0.0 {
                a.column_mut(j).neg_mut();
                v.column_mut(j).neg_mut();
            }
        }
        let sigma: Vec<f64> = lambdas
            .iter()
            .map(|l| (l / (n as f64 - 1.0)).sqrt())
            .collect();
        // Normalised weights: W = sqrt(lambda) v, w = W / sigma = sqrt(N - 1) v.
        let weights = v * (n as f64 - 1.0).sqrt();
        let mut basis = vec![0.0; d * k];
        for r in 0..d {
            for j in 0..k {
                basis[r * k + j] = a[(r, j)];
            }
        }
        Ok(PcaFit {
            pca: Pca::new(mean.as_slice().to_vec(), basis, k, sigma),
            weights,
        })
    }

    /// Dimension D (= 3V).
    pub fn dim(&self) -> usize {
        self.mean.len()
    }

    /// A PCA from its parts: mean (length D, metres), basis (D x K,
    /// row-major, f64), K and the components' standard deviations (length
    /// K, metres). Lengths are checked by [`crate::ShapeModel::validate`].
    pub fn new(mean: Vec<f64>, basis: Vec<f64>, n_components: usize, sigma: Vec<f64>) -> Self {
        Self {
            mean,
            n_components,
            sigma,
            wide: OnceLock::from(basis),
            narrow: OnceLock::new(),
        }
    }

    /// The basis `A`, D x K, row-major (`basis[r * K + k]`), f64. A basis
    /// set from f32 values is widened on the first call (and kept): code on
    /// a hot path reads [`Pca::basis_row`] or [`Pca::basis_f32`] instead.
    pub fn basis(&self) -> &[f64] {
        self.wide.get_or_init(|| {
            let narrow = self.narrow.get().and_then(Option::as_deref);
            // Invariant: `wide` unset means `narrow` was set with values.
            let narrow = narrow.expect("a PCA basis is held as f64 or as f32");
            narrow.iter().map(|&v| f64::from(v)).collect()
        })
    }

    /// Number of basis values (D x K where consistent), without widening.
    pub fn basis_len(&self) -> usize {
        match self.narrow.get() {
            Some(Some(n)) => n.len(),
            _ => self.basis().len(),
        }
    }

    /// Row `r` of the basis (coordinate `r` of D; its K values, f64), from
    /// whichever form is held, without widening the whole basis. Panics if
    /// `r >= D`.
    pub fn basis_row(&self, r: usize) -> impl Iterator<Item = f64> + '_ {
        let k = self.n_components;
        let (narrow, wide): (&[f32], &[f64]) = match self.basis_f32() {
            Some(n) => (&n[r * k..(r + 1) * k], &[]),
            None => (&[], &self.basis()[r * k..(r + 1) * k]),
        };
        narrow
            .iter()
            .map(|&v| f64::from(v))
            .chain(wide.iter().copied())
    }

    /// Whether every basis value is finite, without widening.
    pub fn basis_is_finite(&self) -> bool {
        // In chunks without a branch per value, which vectorises (a plain
        // short-circuiting `all` over the 4M values took 4 % of a whole
        // `tapeshape predict`).
        fn all_finite<T: Copy>(v: &[T], finite: impl Fn(T) -> bool) -> bool {
            v.chunks(4096)
                .all(|c| c.iter().fold(true, |ok, &x| ok & finite(x)))
        }
        match self.basis_f32() {
            Some(n) => all_finite(n, f32::is_finite),
            None => all_finite(self.basis(), f64::is_finite),
        }
    }

    /// The basis to change in place (f64, D x K row-major); any f32 form
    /// is dropped and found again on next use.
    pub fn basis_mut(&mut self) -> &mut Vec<f64> {
        self.basis();
        self.narrow = OnceLock::new();
        self.wide.get_mut().expect("widened just above")
    }

    /// Sets the basis from f64 values (D x K, row-major).
    pub fn set_basis(&mut self, basis: Vec<f64>) {
        self.wide = OnceLock::from(basis);
        self.narrow = OnceLock::new();
    }

    /// Sets the basis from f32 values (a model stored with f32 values): the
    /// basis holds exactly their values, kept as f32 (see the type's docs),
    /// with no check to run. Errors if the length is not D x K.
    pub fn set_basis_f32(&mut self, basis: Vec<f32>) -> Result<()> {
        if basis.len() != self.dim() * self.n_components {
            return Err(ModelError::InvalidInput(format!(
                "a basis of {} values for D x K = {} x {}",
                basis.len(),
                self.dim(),
                self.n_components
            )));
        }
        self.narrow = OnceLock::from(Some(basis));
        self.wide = OnceLock::new();
        Ok(())
    }

    /// The basis as f32 values (D x K, row-major) where every entry is
    /// exactly an f32; `None` otherwise. Found once from the f64 basis when
    /// that is what was set.
    pub fn basis_f32(&self) -> Option<&[f32]> {
        self.narrow
            .get_or_init(|| {
                let wide = self.basis();
                let narrow: Vec<f32> = wide.iter().map(|&v| v as f32).collect();
                narrow
                    .iter()
                    .zip(wide)
                    .all(|(&n, &v)| f64::from(n) == v)
                    .then_some(narrow)
            })
            .as_deref()
    }

    /// The shape `X = mu + A (sigma .* w)` for normalised weights `w` (length
    /// K), as a flat vector of length D in metres.
    pub fn reconstruct(&self, w: &[f64]) -> Vec<f64> {
        let k = self.n_components;
        assert_eq!(w.len(), k, "weights must have K entries");
        let scaled: Vec<f64> = w.iter().zip(&self.sigma).map(|(a, b)| a * b).collect();
        fn rows<T: Copy + Into<f64>>(mean: &[f64], basis: &[T], k: usize, s: &[f64]) -> Vec<f64> {
            crate::kernels::clear_upper_registers();
            mean.iter()
                .zip(basis.chunks_exact(k.max(1)))
                .map(|(m, row)| m + crate::lbfgs::dot_widened(row, s))
                .collect()
        }
        if k == 0 {
            return self.mean.clone();
        }
        match self.basis_f32() {
            Some(b) => rows(&self.mean, b, k, &scaled),
            None => rows(&self.mean, self.basis(), k, &scaled),
        }
    }

    /// [`Pca::reconstruct`] as points: `D / 3` entries `[x, y, z]` (metres),
    /// bit for bit the same values, without the flat vector in between (a
    /// prediction reconstructs a shape in every round).
    ///
    /// Panics if `w` does not have K entries or D is not a multiple of 3.
    pub fn reconstruct_points(&self, w: &[f64]) -> Vec<[f64; 3]> {
        let k = self.n_components;
        assert_eq!(w.len(), k, "weights must have K entries");
        assert!(self.dim().is_multiple_of(3), "shapes must be points");
        if k == 0 {
            return self
                .mean
                .chunks_exact(3)
                .map(|m| [m[0], m[1], m[2]])
                .collect();
        }
        let scaled: Vec<f64> = w.iter().zip(&self.sigma).map(|(a, b)| a * b).collect();
        match self.basis_f32() {
            Some(b) => crate::kernels::points(&self.mean, b, k, &scaled),
            None => crate::kernels::points(&self.mean, self.basis(), k, &scaled),
        }
    }

    /// Normalised weights of a shape `x` (flat, length D, metres):
    /// `w = A^T (x - mu) / sigma` (orthogonal projection onto the PCA space).
    pub fn project(&self, x: &[f64]) -> Vec<f64> {
        let k = self.n_components;
        assert_eq!(x.len(), self.dim(), "shape must have D entries");
        let mut w = vec![0.0; k];
        match self.basis_f32() {
            Some(b) => crate::kernels::accumulate_rows(x, &self.mean, b, &mut w),
            None => crate::kernels::accumulate_rows(x, &self.mean, self.basis(), &mut w),
        }
        for (wj, s) in w.iter_mut().zip(&self.sigma) {
            *wj /= s;
        }
        w
    }
}

#[cfg(test)]
#[allow(clippy::needless_range_loop)] // index loops compare arrays entry by entry
mod tests {
    use super::*;

    fn lcg(seed: &mut u64) -> f64 {
        *seed = seed
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((*seed >> 11) as f64) / ((1u64 << 53) as f64) - 0.5
    }

    fn random(d: usize, n: usize, seed: u64) -> DMatrix<f64> {
        let mut s = seed;
        DMatrix::from_fn(d, n, |_, _| lcg(&mut s))
    }

    /// An f32-valued basis streams as f32 with the f64 basis's results bit
    /// for bit, is widened only when asked, and an f64 basis with other
    /// values has no f32 form.
    #[test]
    fn an_f32_valued_basis_streams_as_f32_with_the_same_results() {
        let data = random(30, 8, 3);
        let mut pca = Pca::fit(&data, 1e-12, None).unwrap().pca;
        assert!(
            pca.basis_f32().is_none(),
            "a fitted basis is not f32-valued"
        );
        let rounded: Vec<f32> = pca.basis().iter().map(|&v| v as f32).collect();
        let widened: Vec<f64> = rounded.iter().map(|&v| f64::from(v)).collect();
        pca.set_basis_f32(rounded.clone()).unwrap();
        assert!(pca.wide.get().is_none(), "set from f32: not widened yet");
        assert_eq!(pca.basis_len(), widened.len());
        let r = 7;
        let k = pca.n_components;
        let row: Vec<f64> = pca.basis_row(r).collect();
        assert_eq!(row, widened[r * k..(r + 1) * k]);
        assert!(pca.wide.get().is_none(), "a row does not widen the basis");
        // The same values given as f64: the f32 form is found, not set.
        let wide = Pca::new(pca.mean.clone(), widened.clone(), k, pca.sigma.clone());
        assert_eq!(wide.basis_f32(), Some(&rounded[..]));
        let w: Vec<f64> = (0..k).map(|j| 0.3 * j as f64 - 1.0).collect();
        assert_eq!(pca.reconstruct(&w), wide.reconstruct(&w));
        assert_eq!(
            pca.reconstruct_points(&w).as_flattened(),
            &pca.reconstruct(&w)[..]
        );
        assert_eq!(
            wide.reconstruct_points(&w).as_flattened(),
            &wide.reconstruct(&w)[..]
        );
        let x = pca.reconstruct(&w);
        assert_eq!(pca.project(&x), wide.project(&x));
        assert_eq!(pca.basis(), &widened[..]);
        // Changing the basis drops the f32 form.
        let mut changed = pca.clone();
        changed.basis_mut()[0] += 1e-9;
        assert!(changed.basis_f32().is_none());
        assert!(pca.set_basis_f32(vec![0.0; 3]).is_err());
        assert!(pca.basis_is_finite() && wide.basis_is_finite());
        for bad in [f64::NAN, f64::INFINITY] {
            let mut p = pca.clone();
            p.basis_mut()[5] = bad;
            assert!(!p.basis_is_finite());
            let mut n: Vec<f32> = rounded.clone();
            n[rounded.len() - 1] = bad as f32;
            p.set_basis_f32(n).unwrap();
            assert!(!p.basis_is_finite());
        }
        // Saved as f64, whichever form is held: the same bytes.
        assert_eq!(
            postcard::to_stdvec(&pca).unwrap(),
            postcard::to_stdvec(&wide).unwrap()
        );
    }

    #[test]
    fn reconstructs_training_data_exactly() {
        let data = random(30, 8, 1);
        let fit = Pca::fit(&data, 1e-12, None).unwrap();
        assert_eq!(fit.pca.n_components, 7);
        for i in 0..8 {
            let w: Vec<f64> = fit.weights.row(i).iter().copied().collect();
            let x = fit.pca.reconstruct(&w);
            for r in 0..30 {
                assert!((x[r] - data[(r, i)]).abs() < 1e-12, "body {i} row {r}");
            }
            let back = fit.pca.project(data.column(i).as_slice());
            for (a, b) in back.iter().zip(&w) {
                assert!((a - b).abs() < 1e-10);
            }
        }
    }

    #[test]
    fn gram_pca_matches_svd_and_weights_have_unit_sd() {
        let (d, n) = (25, 9);
        let data = random(d, n, 7);
        let fit = Pca::fit(&data, 1e-12, None).unwrap();
        let k = fit.pca.n_components;
        let mean = data.column_mean();
        let mut c = data.clone();
        for mut col in c.column_iter_mut() {
            col -= &mean;
        }
        let svd = c.clone().svd(true, false);
        let mut sv: Vec<(f64, usize)> = svd
            .singular_values
            .iter()
            .copied()
            .enumerate()
            .map(|(i, s)| (s, i))
            .collect();
        sv.sort_by(|a, b| b.0.total_cmp(&a.0));
        let u = svd.u.unwrap();
        for j in 0..k {
            let (s, i) = sv[j];
            let sigma = s / ((n - 1) as f64).sqrt();
            assert!((fit.pca.sigma[j] - sigma).abs() < 1e-12 * sigma.max(1.0));
            // Same direction up to sign.
            let dot: f64 = (0..d).map(|r| fit.pca.basis()[r * k + j] * u[(r, i)]).sum();
            assert!(
                (dot.abs() - 1.0).abs() < 1e-9,
                "component {j}: |dot| = {dot}"
            );
        }
        // Orthonormal columns.
        for a in 0..k {
            for b in 0..k {
                let dot: f64 = (0..d)
                    .map(|r| fit.pca.basis()[r * k + a] * fit.pca.basis()[r * k + b])
                    .sum();
                let want = if a == b { 1.0 } else { 0.0 };
                assert!((dot - want).abs() < 1e-9);
            }
        }
        // Normalised weights: zero mean, unit SD, uncorrelated.
        for a in 0..k {
            let col = fit.weights.column(a);
            assert!(col.mean().abs() < 1e-12);
            for b in 0..k {
                let cov = col.dot(&fit.weights.column(b)) / (n - 1) as f64;
                let want = if a == b { 1.0 } else { 0.0 };
                assert!((cov - want).abs() < 1e-9);
            }
        }
    }

    #[test]
    fn low_rank_data_keep_only_real_components() {
        // Data on a 2-D affine subspace: exactly 2 components survive.
        let basis = random(20, 2, 3);
        let coeffs = random(2, 10, 4);
        let data = &basis * &coeffs;
        let fit = Pca::fit(&data, 1e-10, None).unwrap();
        assert_eq!(fit.pca.n_components, 2);
        let capped = Pca::fit(&data, 1e-10, Some(1)).unwrap();
        assert_eq!(capped.pca.n_components, 1);
        let all = Pca::fit_with_variance(&data, 1e-10, None, Some(1.0)).unwrap();
        assert_eq!(all.pca.n_components, 2);
        // The first component's share of the variance decides the cut.
        let s0 = fit.pca.sigma[0].powi(2);
        let s1 = fit.pca.sigma[1].powi(2);
        let share = s0 / (s0 + s1);
        let one = Pca::fit_with_variance(&data, 1e-10, None, Some(share * 0.99)).unwrap();
        assert_eq!(one.pca.n_components, 1);
        let two = Pca::fit_with_variance(&data, 1e-10, None, Some(share * 1.01)).unwrap();
        assert_eq!(two.pca.n_components, 2);
        assert!(Pca::fit_with_variance(&data, 1e-10, None, Some(0.0)).is_err());
    }

    #[test]
    fn bad_data_are_errors() {
        assert!(Pca::fit(&random(5, 1, 1), 1e-10, None).is_err());
        let same = DMatrix::from_element(4, 3, 0.5);
        assert!(matches!(
            Pca::fit(&same, 1e-10, None),
            Err(ModelError::InvalidTraining(_))
        ));
        let mut nan = random(4, 3, 2);
        nan[(1, 1)] = f64::NAN;
        assert!(matches!(
            Pca::fit(&nan, 1e-10, None),
            Err(ModelError::NonFinite(_))
        ));
    }
}
