//! The one generator fitter: MakeHuman generator parameters fitted to
//! measurements, with exact derivatives.
//!
//! Two users do this job and configure it differently:
//!
//! * population generation fits each body to its ANSUR II subject (twelve
//!   dimensions, each with the parameter that mainly drives it, one start
//!   from the subject's sex, age, race and body-mass index, a prior towards
//!   that start, stop when every dimension is within 0.2 mm);
//! * the evaluation's generator-fit baseline fits the macro parameters and
//!   the `measure-*` local changes to whatever measurements are given (two
//!   starts, man and woman, a weak prior, stop when the cost stops falling).
//!
//! Both are the same problem, so there is one solver; each user chooses the
//! targets, the free parameters with their priors, the bounds (each
//! parameter's own range, [`Param::range`]), the iterations, the stopping
//! rule and the starts.
//!
//! # The problem
//!
//! Parameters `theta` (the free ones; every other generator input stays as
//! the start has it). Cost, with residuals in millimetres so that one prior
//! SD costs as much as a 1 mm misfit:
//!
//! ```text
//! C(theta) = sum_i (1000 (m_i(theta) - t_i))^2 + sum_k ((theta_k - theta0_k) / sd_k)^2
//! ```
//!
//! `m_i` is target `i`'s measurement (metres) on the generated body, with
//! the user's compiled measurement set; `theta0` is the start; `sd_k` the
//! prior SD of parameter `k` (infinite: no prior on it).
//!
//! # The solver
//!
//! Damped Gauss-Newton (Levenberg-Marquardt) with exact derivatives: the
//! generator's Jacobian ([`BodyModel::jacobian`]) chained with each
//! measurement's support gradient (`tapeshape-measure`), and bounds as an
//! active set (a parameter at a bound whose step points outwards is held for
//! that step). A step is `-(J^T J + mu (1 + diag J^T J))^-1 J^T r` over the
//! free parameters, clamped to the bounds, accepted if it lowers the cost
//! (then `mu` shrinks by 0.3, to at least 1e-7); otherwise `mu` grows tenfold
//! and the step is tried again, at most 8 times. Written by hand because no
//! well-kept crate offers bounded nonlinear least squares with a
//! user-supplied Jacobian (argmin's Gauss-Newton has neither bounds nor
//! damping; Nelder-Mead or L-BFGS with finite differences would need one
//! body generation per parameter per gradient where this needs one
//! Jacobian).
//!
//! Reproducibility: the population's files must stay byte-identical for the
//! same recipe (`tapeshape dataset generate --n 400 --seed 1` is the
//! embedded model's), so the order of every sum here is fixed; change it only
//! knowing that it changes every generated population.

use nalgebra::{DMatrix, DVector};
use tapeshape_body::{BodyError, BodyModel, LocalChanges, Param, Phenotype};
use tapeshape_measure::{CompiledSet, MeasureError};
use tapeshape_mesh::{Mesh, Vec3};

/// Errors of the generator fit.
#[derive(Debug, thiserror::Error)]
pub enum FitError {
    /// The body generator failed.
    #[error(transparent)]
    Body(#[from] BodyError),
    /// A target measurement could not be taken on a generated body.
    #[error("measuring `{name}`: {source}")]
    Measure {
        /// The measurement.
        name: String,
        /// Why (boxed: a measurement error is large, a fit error travels
        /// inside other errors).
        #[source]
        source: Box<MeasureError>,
    },
    /// The fit was asked for something impossible (the text says what).
    #[error("generator fit: {0}")]
    Settings(String),
}

/// A parameter the fit may move, with its prior.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Free {
    /// The generator parameter (bounded to [`Param::range`]).
    pub param: Param,
    /// Prior SD around the start, in the parameter's units (> 0;
    /// `f64::INFINITY`: no prior).
    pub prior_sd: f64,
}

/// An offset field the fit may add to the generated body, with its
/// coefficient's prior (around 0) and bounds: `vertices += c * field`
/// (one offset per template vertex, metres per unit of `c`). The
/// generator's own changes are all blends of its targets; a field is a
/// shape change it lacks (`crate::sections`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FreeField<'a> {
    /// Offsets, one per template vertex (metres per unit coefficient).
    pub field: &'a [Vec3],
    /// Prior SD of the coefficient around 0 (> 0).
    pub prior_sd: f64,
    /// Bounds of the coefficient (lower <= 0 <= upper).
    pub range: (f64, f64),
}

/// When a start's iterations stop (besides the iteration limit and a step
/// that no damping makes lower the cost). A rule set to 0 never fires.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Stop {
    /// Every target within this many metres of its value.
    pub misfit_m: f64,
    /// The accepted step lowered the cost by less than this share of it.
    pub min_relative_gain: f64,
    /// The accepted step moved no parameter by more than this.
    pub min_step: f64,
}

/// How the fitter runs (the same for every fit it does).
#[derive(Debug, Clone, PartialEq)]
pub struct FitOptions {
    /// Gauss-Newton iterations at most per start.
    pub max_iterations: usize,
    /// When a start stops early.
    pub stop: Stop,
}

/// The result of [`GeneratorFitter::fit`]: the best start's body.
#[derive(Debug, Clone)]
pub struct Fitted {
    /// Fitted macro parameters.
    pub phenotype: Phenotype,
    /// Fitted local changes.
    pub local_changes: LocalChanges,
    /// The generated body (template topology, metres, station frame).
    pub mesh: Mesh,
    /// Each target's measurement on `mesh`, metres, in the targets' order.
    pub values: Vec<f64>,
    /// The coefficient of each [`FreeField`], in their order (empty
    /// without fields); `mesh` includes them.
    pub field_coefficients: Vec<f64>,
    /// Final cost (squared mm, prior included).
    pub cost: f64,
    /// Iterations used, all starts together.
    pub iterations: usize,
}

impl Fitted {
    /// Root-mean-square misfit of the targets, mm, for `targets` as given
    /// to [`GeneratorFitter::fit`].
    pub fn rms_mm(&self, targets: &[(usize, f64)]) -> f64 {
        let sum: f64 = self
            .values
            .iter()
            .zip(targets)
            .map(|(v, (_, t))| ((v - t) * 1000.0).powi(2))
            .sum();
        (sum / targets.len() as f64).sqrt()
    }
}

/// The fitter: a body generator, a compiled measurement set for its
/// topology, the free parameters and the options (module docs).
pub struct GeneratorFitter<'a> {
    body: &'a BodyModel,
    set: &'a CompiledSet,
    params: Vec<Param>,
    /// The fields' offsets, after the parameters in the parameter vector.
    fields: Vec<&'a [Vec3]>,
    /// Per entry of the parameter vector (parameters, then fields).
    prior_sd: Vec<f64>,
    /// Per entry of the parameter vector (parameters, then fields).
    bounds: Vec<(f64, f64)>,
    options: FitOptions,
}

impl std::fmt::Debug for GeneratorFitter<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("GeneratorFitter")
            .field("params", &self.params)
            .field("prior_sd", &self.prior_sd)
            .field("options", &self.options)
            .finish_non_exhaustive()
    }
}

impl<'a> GeneratorFitter<'a> {
    /// A fitter of `free` with `set` (compiled for `body`'s topology).
    ///
    /// Errors: no free parameter, a parameter twice, a prior SD that is not
    /// positive, a parameter whose range is not finite (the race weights), a
    /// set compiled for another topology.
    pub fn new(
        body: &'a BodyModel,
        set: &'a CompiledSet,
        free: &[Free],
        options: FitOptions,
    ) -> Result<Self, FitError> {
        if free.is_empty() {
            return Err(FitError::Settings("no parameter to fit".into()));
        }
        if set.n_vertices() != body.topology().n_vertices() {
            return Err(FitError::Settings(format!(
                "the measurement set is compiled for {} vertices, the body generator makes {}",
                set.n_vertices(),
                body.topology().n_vertices()
            )));
        }
        let mut bounds = Vec::with_capacity(free.len());
        for (k, f) in free.iter().enumerate() {
            if free[..k].iter().any(|g| g.param == f.param) {
                return Err(FitError::Settings(format!("{:?} is listed twice", f.param)));
            }
            if f.prior_sd.is_nan() || f.prior_sd <= 0.0 {
                return Err(FitError::Settings(format!(
                    "the prior SD of {:?} is {}: it must be positive (infinite: no prior)",
                    f.param, f.prior_sd
                )));
            }
            let (lo, hi) = f.param.range();
            if !(lo.is_finite() && hi.is_finite()) {
                return Err(FitError::Settings(format!(
                    "{:?} has no finite range to fit in",
                    f.param
                )));
            }
            bounds.push((lo, hi));
        }
        Ok(Self {
            body,
            set,
            params: free.iter().map(|f| f.param).collect(),
            fields: Vec::new(),
            prior_sd: free.iter().map(|f| f.prior_sd).collect(),
            bounds,
            options,
        })
    }

    /// The fitter with `fields` free too (after the parameters).
    ///
    /// Errors: a field not one offset per template vertex, a prior SD that
    /// is not positive and finite, bounds that do not hold 0.
    pub fn with_fields(mut self, fields: &[FreeField<'a>]) -> Result<Self, FitError> {
        for (k, f) in fields.iter().enumerate() {
            if f.field.len() != self.body.topology().n_vertices() {
                return Err(FitError::Settings(format!(
                    "field {k} has {} offsets for {} vertices",
                    f.field.len(),
                    self.body.topology().n_vertices()
                )));
            }
            if !(f.prior_sd.is_finite() && f.prior_sd > 0.0) {
                return Err(FitError::Settings(format!(
                    "field {k}: the prior SD {} must be positive and finite",
                    f.prior_sd
                )));
            }
            let (lo, hi) = f.range;
            if !(lo <= 0.0 && 0.0 <= hi && lo.is_finite() && hi.is_finite()) {
                return Err(FitError::Settings(format!(
                    "field {k}: the bounds {lo}..{hi} must be finite and hold 0"
                )));
            }
            self.fields.push(f.field);
            self.prior_sd.push(f.prior_sd);
            self.bounds.push(f.range);
        }
        Ok(self)
    }

    /// The free parameters, in the order of the parameter vector.
    pub fn parameters(&self) -> &[Param] {
        &self.params
    }

    /// The compiled measurement set the targets index.
    pub fn set(&self) -> &CompiledSet {
        self.set
    }

    /// Fits the targets `(index in the set, value in metres)` from each of
    /// `starts` (a start is also its prior's centre) and returns the start
    /// that ends with the lowest cost (the first of equals).
    ///
    /// Errors: no start, no target, a target index outside the set; the
    /// generator or a measurement failing.
    pub fn fit(
        &self,
        targets: &[(usize, f64)],
        starts: &[(Phenotype, LocalChanges)],
    ) -> Result<Fitted, FitError> {
        if targets.is_empty() {
            return Err(FitError::Settings("no measurement to fit".into()));
        }
        if let Some(&(j, _)) = targets.iter().find(|(j, _)| *j >= self.set.len()) {
            return Err(FitError::Settings(format!(
                "target {j} is not in the measurement set ({} measurements)",
                self.set.len()
            )));
        }
        let mut best: Option<Fitted> = None;
        let mut iterations = 0;
        for (ph, lc) in starts {
            let sol = self.run(targets, *ph, lc.clone())?;
            iterations += sol.iterations;
            if best.as_ref().is_none_or(|b| sol.cost < b.cost) {
                best = Some(sol);
            }
        }
        let mut best = best.ok_or_else(|| FitError::Settings("no start given".into()))?;
        best.iterations = iterations;
        Ok(best)
    }

    /// The parameter vector: the parameters' values, then the fields'
    /// coefficients `coef`.
    fn get(&self, ph: &Phenotype, lc: &LocalChanges, coef: &[f64]) -> Vec<f64> {
        self.params
            .iter()
            .map(|p| p.get(ph, lc))
            .chain(coef.iter().copied())
            .collect()
    }

    /// The generated body with the fields at `coef` added.
    fn generate(&self, ph: &Phenotype, lc: &LocalChanges, coef: &[f64]) -> Result<Mesh, FitError> {
        let mut mesh = self.body.generate(ph, lc)?;
        for (field, &c) in self.fields.iter().zip(coef) {
            if c == 0.0 {
                continue;
            }
            for (p, d) in mesh.vertices.iter_mut().zip(field.iter()) {
                for a in 0..3 {
                    p[a] += c * d[a];
                }
            }
        }
        Ok(mesh)
    }

    /// `theta` clamped to the bounds, set on a copy of `(ph, lc)`; the
    /// fields' coefficients (clamped) returned beside them.
    fn with(
        &self,
        ph: &Phenotype,
        lc: &LocalChanges,
        theta: &[f64],
    ) -> Result<(Phenotype, LocalChanges, Vec<f64>), FitError> {
        let (mut ph, mut lc) = (*ph, lc.clone());
        for ((&p, &(lo, hi)), &v) in self.params.iter().zip(&self.bounds).zip(theta) {
            p.set(&mut ph, &mut lc, v.clamp(lo, hi))?;
        }
        let np = self.params.len();
        let coef = theta[np..]
            .iter()
            .zip(&self.bounds[np..])
            .map(|(&v, &(lo, hi))| v.clamp(lo, hi))
            .collect();
        Ok((ph, lc, coef))
    }

    /// The targets' values (metres) on `vertices` and, if asked, each one's
    /// gradient as (vertex, d value / d position) over the vertices it
    /// depends on.
    #[allow(clippy::type_complexity)]
    fn measure(
        &self,
        vertices: &[Vec3],
        targets: &[(usize, f64)],
        with_gradient: bool,
    ) -> Result<(Vec<f64>, Vec<Vec<(usize, Vec3)>>), FitError> {
        let mut values = Vec::with_capacity(targets.len());
        let mut grads = Vec::new();
        for &(j, _) in targets {
            let m = self
                .set
                .measure_one(j, vertices)
                .map_err(|source| FitError::Measure {
                    name: self.set.set().definitions[j].name.clone(),
                    source: Box::new(source),
                })?;
            values.push(m.value);
            if with_gradient {
                grads.push(
                    m.support
                        .gradient(vertices)
                        .into_iter()
                        .enumerate()
                        .filter(|(_, g)| g.iter().any(|x| *x != 0.0))
                        .collect(),
                );
            }
        }
        Ok((values, grads))
    }

    fn cost(&self, values: &[f64], targets: &[(usize, f64)], theta: &[f64], theta0: &[f64]) -> f64 {
        let m: f64 = values
            .iter()
            .zip(targets)
            .map(|(v, (_, t))| ((v - t) * 1000.0).powi(2))
            .sum();
        let p: f64 = theta
            .iter()
            .zip(theta0)
            .zip(&self.prior_sd)
            .map(|((a, b), sd)| ((a - b) / sd).powi(2))
            .sum();
        m + p
    }

    /// One damped Gauss-Newton run from `(ph, lc)` (module docs).
    fn run(
        &self,
        targets: &[(usize, f64)],
        mut ph: Phenotype,
        mut lc: LocalChanges,
    ) -> Result<Fitted, FitError> {
        let nm = targets.len();
        let mut coef = vec![0.0; self.fields.len()];
        let theta0 = self.get(&ph, &lc, &coef);
        let np = theta0.len();
        let mut mu = 1e-3;
        let mut mesh = self.generate(&ph, &lc, &coef)?;
        let (mut values, _) = self.measure(&mesh.vertices, targets, false)?;
        let mut current = self.cost(&values, targets, &theta0, &theta0);
        let mut iterations = 0;
        let stop = self.options.stop;
        for _ in 0..self.options.max_iterations {
            iterations += 1;
            let jac = self.body.jacobian(&ph, &lc, &self.params)?;
            // A field's column is the field itself (the body is linear in
            // its coefficient).
            let columns: Vec<&[Vec3]> = jac
                .iter()
                .map(Vec::as_slice)
                .chain(self.fields.iter().copied())
                .collect();
            let (_, grads) = self.measure(&mesh.vertices, targets, true)?;
            let now = self.get(&ph, &lc, &coef);
            // J (nm + np) x np and the residual r, in mm and prior SDs.
            let mut j = DMatrix::<f64>::zeros(nm + np, np);
            let mut r = DVector::<f64>::zeros(nm + np);
            for i in 0..nm {
                r[i] = (values[i] - targets[i].1) * 1000.0;
                for (k, dk) in columns.iter().enumerate() {
                    let mut s = 0.0;
                    for &(v, g) in &grads[i] {
                        let d = dk[v];
                        s += g[0] * d[0] + g[1] * d[1] + g[2] * d[2];
                    }
                    j[(i, k)] = s * 1000.0;
                }
            }
            for k in 0..np {
                r[nm + k] = (now[k] - theta0[k]) / self.prior_sd[k];
                j[(nm + k, k)] = 1.0 / self.prior_sd[k];
            }
            let mut accepted = None;
            for _ in 0..8 {
                let step = self.bounded_step(&j, &r, &now, mu);
                let trial: Vec<f64> = now.iter().zip(step.iter()).map(|(a, s)| a + s).collect();
                let (ph2, lc2, coef2) = self.with(&ph, &lc, &trial)?;
                let mesh2 = self.generate(&ph2, &lc2, &coef2)?;
                let (values2, _) = self.measure(&mesh2.vertices, targets, false)?;
                let theta2 = self.get(&ph2, &lc2, &coef2);
                let c2 = self.cost(&values2, targets, &theta2, &theta0);
                if c2 < current {
                    accepted = Some((ph2, lc2, coef2, mesh2, values2, theta2, c2));
                    mu = (mu * 0.3).max(1e-7);
                    break;
                }
                mu *= 10.0;
            }
            let Some((ph2, lc2, coef2, mesh2, values2, theta2, c2)) = accepted else {
                break;
            };
            let gain = (current - c2) / current.max(1e-300);
            let moved = theta2
                .iter()
                .zip(&now)
                .map(|(a, b)| (a - b).abs())
                .fold(0.0, f64::max);
            (ph, lc, coef, mesh, values, current) = (ph2, lc2, coef2, mesh2, values2, c2);
            let worst = values
                .iter()
                .zip(targets)
                .map(|(v, (_, t))| (v - t).abs())
                .fold(0.0, f64::max);
            if worst < stop.misfit_m || gain < stop.min_relative_gain || moved < stop.min_step {
                break;
            }
        }
        Ok(Fitted {
            phenotype: ph,
            local_changes: lc,
            mesh,
            values,
            field_coefficients: coef,
            cost: current,
            iterations,
        })
    }

    /// The damped Gauss-Newton step over the parameters not held at a
    /// bound (active set): parameters at a bound whose step points outwards
    /// are held and the step is solved again without them.
    fn bounded_step(
        &self,
        j: &DMatrix<f64>,
        r: &DVector<f64>,
        now: &[f64],
        mu: f64,
    ) -> DVector<f64> {
        let np = now.len();
        let mut free = vec![true; np];
        let mut step = DVector::<f64>::zeros(np);
        for _ in 0..np {
            let idx: Vec<usize> = (0..np).filter(|&k| free[k]).collect();
            let jf = j.select_columns(idx.iter());
            let jtj = jf.transpose() * &jf;
            let g = jf.transpose() * r;
            let mut a = jtj.clone();
            for d in 0..idx.len() {
                a[(d, d)] += mu * (1.0 + jtj[(d, d)]);
            }
            let Some(sf) = a.cholesky().map(|c| c.solve(&(-&g))) else {
                break;
            };
            step.fill(0.0);
            for (d, &k) in idx.iter().enumerate() {
                step[k] = sf[d];
            }
            let blocked: Vec<usize> = idx
                .iter()
                .copied()
                .filter(|&k| {
                    (now[k] <= self.bounds[k].0 + 1e-12 && step[k] < 0.0)
                        || (now[k] >= self.bounds[k].1 - 1e-12 && step[k] > 0.0)
                })
                .collect();
            if blocked.is_empty() {
                break;
            }
            for k in blocked {
                free[k] = false;
            }
        }
        step
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use tapeshape_measure::MeasurementSet;

    fn quick() -> (&'static BodyModel, CompiledSet) {
        let body = BodyModel::shared().unwrap();
        let set = MeasurementSet::builtin("quick")
            .unwrap()
            .compile(body.topology(), &tapeshape_body::anatomy::anatomy())
            .unwrap();
        (body, set)
    }

    fn options() -> FitOptions {
        FitOptions {
            max_iterations: 20,
            stop: Stop {
                misfit_m: 0.1e-3,
                min_relative_gain: 0.0,
                min_step: 0.0,
            },
        }
    }

    #[test]
    fn recovers_the_macro_parameters_of_a_generated_body() {
        let (body, set) = quick();
        let free: Vec<Free> = [Param::Height, Param::Weight, Param::Muscle]
            .map(|param| Free {
                param,
                prior_sd: 10.0,
            })
            .to_vec();
        let fitter = GeneratorFitter::new(body, &set, &free, options()).unwrap();
        let truth = Phenotype {
            height: 0.7,
            weight: 0.35,
            muscle: 0.6,
            ..Phenotype::default()
        };
        let mesh = body.generate(&truth, &LocalChanges::new()).unwrap();
        let names = ["stature", "waist", "hip", "chest"];
        let targets: Vec<(usize, f64)> = names
            .iter()
            .map(|n| {
                let j = set.set().index_of(n).unwrap();
                (j, set.measure_one(j, &mesh.vertices).unwrap().value)
            })
            .collect();
        let start = (Phenotype::default(), LocalChanges::new());
        let fit = fitter.fit(&targets, &[start]).unwrap();
        assert!(
            fit.rms_mm(&targets) < 0.5,
            "rms {} mm",
            fit.rms_mm(&targets)
        );
        assert!(
            (fit.phenotype.height - 0.7).abs() < 0.01,
            "{:?}",
            fit.phenotype
        );
        assert!(fit.iterations >= 1 && fit.iterations <= 20);
        // Values are the body's own measurements.
        for (v, (j, _)) in fit.values.iter().zip(&targets) {
            assert_eq!(*v, set.measure_one(*j, &fit.mesh.vertices).unwrap().value);
        }
    }

    /// A field's coefficient is recovered from the measurements it moves,
    /// beside a macro parameter: the Jacobian column of a field is right.
    #[test]
    fn recovers_a_fields_coefficient_beside_a_parameter() {
        let (body, set) = quick();
        let fields = crate::sections::section_fields(body).unwrap();
        let free = [Free {
            param: Param::Height,
            prior_sd: 10.0,
        }];
        let fitter = GeneratorFitter::new(body, &set, &free, options())
            .unwrap()
            .with_fields(&[FreeField {
                field: &fields.hip,
                prior_sd: 10.0,
                range: (-1.0, 3.0),
            }])
            .unwrap();
        let truth = Phenotype {
            height: 0.6,
            ..Phenotype::default()
        };
        let mut x = body
            .generate(&truth, &LocalChanges::new())
            .unwrap()
            .vertices;
        for (p, d) in x.iter_mut().zip(&fields.hip) {
            for a in 0..3 {
                p[a] += 1.5 * d[a];
            }
        }
        let targets: Vec<(usize, f64)> = ["stature", "hip"]
            .iter()
            .map(|n| {
                let j = set.set().index_of(n).unwrap();
                (j, set.measure_one(j, &x).unwrap().value)
            })
            .collect();
        let fit = fitter
            .fit(&targets, &[(Phenotype::default(), LocalChanges::new())])
            .unwrap();
        assert!(
            fit.rms_mm(&targets) < 0.2,
            "rms {} mm",
            fit.rms_mm(&targets)
        );
        assert_eq!(fit.field_coefficients.len(), 1);
        assert!(
            (fit.field_coefficients[0] - 1.5).abs() < 0.02,
            "{:?}",
            fit.field_coefficients
        );
        assert!((fit.phenotype.height - 0.6).abs() < 0.01);
        // The fitted mesh is the generator's body plus the field.
        let mut y = body
            .generate(&fit.phenotype, &fit.local_changes)
            .unwrap()
            .vertices;
        for (p, d) in y.iter_mut().zip(&fields.hip) {
            for a in 0..3 {
                p[a] += fit.field_coefficients[0] * d[a];
            }
        }
        assert_eq!(y, fit.mesh.vertices);
    }

    #[test]
    fn bad_fields_are_refused() {
        let (body, set) = quick();
        let free = [Free {
            param: Param::Height,
            prior_sd: 1.0,
        }];
        let fitter = || GeneratorFitter::new(body, &set, &free, options()).unwrap();
        let field = vec![[0.0; 3]; body.topology().n_vertices()];
        let ok = FreeField {
            field: &field,
            prior_sd: 1.0,
            range: (-1.0, 1.0),
        };
        assert!(fitter().with_fields(&[ok]).is_ok());
        let short = vec![[0.0; 3]; 10];
        for bad in [
            FreeField {
                field: &short,
                ..ok
            },
            FreeField {
                prior_sd: 0.0,
                ..ok
            },
            FreeField {
                prior_sd: f64::INFINITY,
                ..ok
            },
            FreeField {
                range: (0.5, 1.0),
                ..ok
            },
            FreeField {
                range: (-1.0, f64::NAN),
                ..ok
            },
        ] {
            let e = fitter().with_fields(&[bad]).unwrap_err().to_string();
            assert!(e.contains("field 0"), "{e}");
        }
    }

    #[test]
    fn bounds_hold_and_the_better_start_wins() {
        let (body, set) = quick();
        let free = [Free {
            param: Param::Height,
            prior_sd: f64::INFINITY,
        }];
        let fitter = GeneratorFitter::new(body, &set, &free, options()).unwrap();
        // 2.5 m is beyond the tallest body the generator makes.
        let j = set.set().index_of("stature").unwrap();
        let short = Phenotype {
            height: 0.1,
            ..Phenotype::default()
        };
        let starts = [
            (short, LocalChanges::new()),
            (Phenotype::default(), LocalChanges::new()),
        ];
        let fit = fitter.fit(&[(j, 2.5)], &starts).unwrap();
        assert_eq!(fit.phenotype.height, 1.0, "held at its upper bound");
        assert!(fit.values[0] < 2.5);
        // Each start counted.
        assert!(fit.iterations >= 2);
    }

    #[test]
    fn impossible_requests_are_errors() {
        let (body, set) = quick();
        let h = |prior_sd| Free {
            param: Param::Height,
            prior_sd,
        };
        assert!(GeneratorFitter::new(body, &set, &[], options()).is_err());
        assert!(GeneratorFitter::new(body, &set, &[h(1.0), h(1.0)], options()).is_err());
        assert!(GeneratorFitter::new(body, &set, &[h(0.0)], options()).is_err());
        assert!(GeneratorFitter::new(body, &set, &[h(f64::NAN)], options()).is_err());
        let race = Free {
            param: Param::African,
            prior_sd: 1.0,
        };
        assert!(GeneratorFitter::new(body, &set, &[race], options()).is_err());
        let fitter = GeneratorFitter::new(body, &set, &[h(1.0)], options()).unwrap();
        let start = [(Phenotype::default(), LocalChanges::new())];
        assert!(fitter.fit(&[], &start).is_err());
        assert!(fitter.fit(&[(set.len(), 1.0)], &start).is_err());
        assert!(fitter.fit(&[(0, 1.0)], &[]).is_err());
    }
}
