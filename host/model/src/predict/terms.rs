//! The readings' energy terms on a shape, shared by both steps: per-segment
//! targets from each reading's support (the paper's `l_t(e)`), the
//! weighting of [`EnergyWeighting`], step 1's objective over the vertices
//! the terms touch, and the unit conversions (the optimiser works in
//! millimetres, see the crate docs).

use tapeshape_measure::Measured;
use tapeshape_mesh::Vec3;

use super::progress::PredictStage;
use super::readings::Readings;
use super::settings::EnergyWeighting;
use super::warning::Warning;
use crate::energy::{measurement_energy, segment_terms, SegmentTerm};
use crate::refine::WeightObjective;
use crate::{ShapeModel, MM_PER_M};

/// Positions from metres to millimetres.
pub(crate) fn to_mm(x: &[Vec3]) -> Vec<Vec3> {
    x.iter()
        .map(|v| [v[0] * MM_PER_M, v[1] * MM_PER_M, v[2] * MM_PER_M])
        .collect()
}

/// Positions from millimetres to metres.
pub(crate) fn to_m(x: &[Vec3]) -> Vec<Vec3> {
    x.iter()
        .map(|v| [v[0] / MM_PER_M, v[1] / MM_PER_M, v[2] / MM_PER_M])
        .collect()
}

/// The MAP objective of [`crate::map`] on real measured values:
/// `sum_j ((m_j - T_j) / sd_j)^2 + |w|^2` (`sd` per given reading, mm).
pub(crate) fn map_objective(given: &Readings, measured: &[Measured], sd: &[f64], w: &[f64]) -> f64 {
    given
        .iter()
        .zip(measured)
        .zip(sd)
        .map(|((g, m), s)| ((m.value * MM_PER_M - g.target_mm) / s).powi(2))
        .sum::<f64>()
        + w.iter().map(|x| x * x).sum::<f64>()
}

impl ShapeModel {
    /// The energy terms of every given reading on `x_mm` (mm) from its
    /// support in `measured`, weighted by `weighting` (and, per
    /// measurement, its scale); a reading whose support has no length is
    /// left out of this round with a warning naming `stage`.
    pub(crate) fn build_terms(
        &self,
        given: &Readings,
        measured: &[Measured],
        x_mm: &[Vec3],
        weighting: (EnergyWeighting, f64),
        warnings: &mut Vec<Warning>,
        stage: PredictStage,
    ) -> Vec<SegmentTerm> {
        self.build_terms_owned(given, measured, x_mm, weighting, warnings, stage)
            .0
    }

    /// [`Self::build_terms`], also returning for each term the position in
    /// `given` of the reading it belongs to.
    pub(crate) fn build_terms_owned(
        &self,
        given: &Readings,
        measured: &[Measured],
        x_mm: &[Vec3],
        weighting: (EnergyWeighting, f64),
        warnings: &mut Vec<Warning>,
        stage: PredictStage,
    ) -> (Vec<SegmentTerm>, Vec<usize>) {
        let (weighting, scale) = weighting;
        let mut terms = Vec::new();
        let mut owner = Vec::new();
        for (pos, (g, m)) in given.iter().zip(measured).enumerate() {
            match segment_terms(&m.support, x_mm, g.target_mm, g.weight) {
                Some(mut t) => {
                    if weighting == EnergyWeighting::PerMeasurement {
                        // sum_e (l_e^2 - lt_e^2)^2 ~ 4 sum_e lt_e^2 (l_e - lt_e)^2 and a
                        // change D of the whole measurement moves each segment by
                        // lt_e D / L_t: the energy is ~ 4 D^2 sum_e lt_e^4 / L_t^2.
                        let l4: f64 = t.iter().map(|s| s.target_sq * s.target_sq).sum();
                        if l4 > 0.0 && l4.is_finite() {
                            let c = scale * g.target_mm * g.target_mm / (4.0 * l4);
                            t.iter_mut().for_each(|s| s.weight *= c);
                        }
                    }
                    owner.extend(std::iter::repeat_n(pos, t.len()));
                    terms.extend(t)
                }
                None => warnings.push(Warning::ZeroLength {
                    stage,
                    measurement: self.measurement_names[g.index].clone(),
                }),
            }
        }
        (terms, owner)
    }

    /// `E_m` of a shape with its per-segment targets set on that shape (the
    /// energy a round starts from): the paper's objective, evaluated the same
    /// way at every stage, so stages can be compared.
    pub(crate) fn stage_energy(
        &self,
        given: &Readings,
        measured: &[Measured],
        x: &[Vec3],
        weighting: (EnergyWeighting, f64),
    ) -> f64 {
        self.stage_energy_mm(given, measured, &to_mm(x), weighting)
    }

    /// [`Self::stage_energy`] of a shape in millimetres.
    pub(crate) fn stage_energy_mm(
        &self,
        given: &Readings,
        measured: &[Measured],
        x_mm: &[Vec3],
        weighting: (EnergyWeighting, f64),
    ) -> f64 {
        let mut ignored = Vec::new();
        let terms = self.build_terms(
            given,
            measured,
            x_mm,
            weighting,
            &mut ignored,
            PredictStage::Done,
        );
        measurement_energy(&terms, x_mm.as_flattened(), None)
    }

    /// Step-1 objective over the vertices the terms touch.
    pub(crate) fn localise(&self, terms: &[SegmentTerm]) -> WeightObjective {
        let (local_terms, rows, base) = self.local_basis(terms);
        WeightObjective::new(self.pca.n_components, &rows, &base, local_terms)
    }

    /// The terms re-indexed to the vertices they touch, with those vertices'
    /// scaled basis rows ((3 n_local) x K, mm per unit weight) and mean
    /// positions (flat, mm).
    pub(crate) fn local_basis(
        &self,
        terms: &[SegmentTerm],
    ) -> (Vec<SegmentTerm>, Vec<f64>, Vec<f64>) {
        let k = self.pca.n_components;
        let mut local = vec![u32::MAX; self.n_vertices()];
        let mut globals: Vec<u32> = Vec::new();
        let mut map = |v: u32| -> u32 {
            if local[v as usize] == u32::MAX {
                local[v as usize] = globals.len() as u32;
                globals.push(v);
            }
            local[v as usize]
        };
        let mut local_terms = terms.to_vec();
        for t in &mut local_terms {
            for p in [&mut t.p0, &mut t.p1] {
                p.a = map(p.a);
                p.b = map(p.b);
            }
        }
        let mut rows = Vec::with_capacity(globals.len() * 3 * k);
        let mut base = Vec::with_capacity(3 * globals.len());
        for &g in &globals {
            let g = g as usize;
            for c in 0..3 {
                let r = 3 * g + c;
                rows.extend(
                    self.pca
                        .basis_row(r)
                        .zip(&self.pca.sigma)
                        .map(|(a, s)| a * s * MM_PER_M),
                );
            }
            base.extend((0..3).map(|c| self.pca.mean[3 * g + c] * MM_PER_M));
        }
        (local_terms, rows, base)
    }
}
