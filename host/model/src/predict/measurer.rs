//! What a prediction measures its shapes with: the [`Measurer`] trait
//! (`tapeshape-measure`'s operators implement it) and the checks on what it returns.

use tapeshape_measure::Measured;
use tapeshape_mesh::Vec3;

use crate::{ModelError, Result, ShapeModel, MM_PER_M};

/// Error type a [`Measurer`] returns.
pub type MeasureError = Box<dyn std::error::Error + Send + Sync>;

/// Measures a mesh with a measurement set whose order matches the model's
/// measurement names. Implemented for `tapeshape-measure`'s compiled sets.
pub trait Measurer {
    /// Number of measurements M in the set.
    fn n_measurements(&self) -> usize;

    /// Measures the measurements `which` (indices into the set) on `vertices`
    /// (template order, metres, station frame); returns one [`Measured`] per
    /// index, in the order of `which`, each with its support.
    fn measure(&self, vertices: &[Vec3], which: &[usize]) -> Result<Vec<Measured>, MeasureError>;

    /// The largest error (metres) a re-measured value of measurement `j` may
    /// show against its target, e.g. the ISO 20685-1 class of the set's
    /// definition; `None` if the measurer does not know (then
    /// [`super::Continuation::default_allowable_mm`] applies).
    fn allowable_error(&self, _j: usize) -> Option<f64> {
        None
    }
}

/// The real operators: a measurement set compiled for the template.
impl Measurer for tapeshape_measure::CompiledSet {
    fn n_measurements(&self) -> usize {
        self.len()
    }

    fn measure(&self, vertices: &[Vec3], which: &[usize]) -> Result<Vec<Measured>, MeasureError> {
        which
            .iter()
            .map(|&j| self.measure_one(j, vertices).map_err(Into::into))
            .collect()
    }

    /// The ISO 20685-1 maximum allowable error of the definition's class.
    fn allowable_error(&self, j: usize) -> Option<f64> {
        self.set()
            .definitions
            .get(j)
            .map(|d| d.tolerance.mm() / MM_PER_M)
    }
}

impl ShapeModel {
    /// Measures the readings `which` on `x` and checks what the measurer
    /// returned (count, supports inside the mesh, finite values).
    pub(crate) fn measure_checked(
        &self,
        measurer: &dyn Measurer,
        x: &[Vec3],
        which: &[usize],
    ) -> Result<Vec<Measured>> {
        crate::kernels::clear_upper_registers();
        let out = measurer
            .measure(x, which)
            .map_err(|e| ModelError::Measure(e.to_string()))?;
        if out.len() != which.len() {
            return Err(ModelError::Measure(format!(
                "asked for {} measurements, got {}",
                which.len(),
                out.len()
            )));
        }
        let v = x.len() as u32;
        for (m, &j) in out.iter().zip(which) {
            let name = &self.measurement_names[j];
            let s = &m.support;
            let bad_point = s
                .points
                .iter()
                .any(|p| p.a >= v || p.b >= v || !(0.0..=1.0).contains(&p.t));
            let bad_seg = s
                .segments
                .iter()
                .any(|g| g[0] as usize >= s.points.len() || g[1] as usize >= s.points.len());
            let bad_axis = s.axis.is_some_and(|n| n.iter().any(|c| !c.is_finite()));
            if bad_point || bad_seg || bad_axis || !m.value.is_finite() {
                return Err(ModelError::Measure(format!(
                    "measurement '{name}' returned an invalid support or value"
                )));
            }
        }
        Ok(out)
    }
}
