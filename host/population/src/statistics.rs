//! Statistics of a population beside ANSUR II's train split: the check
//! that generated bodies follow real people (per sex, means within 2 %, SDs
//! within 15 %, correlations within 0.15 on [`CHECKED_COLUMNS`]), and the
//! small descriptive statistics it uses.

use rayon::prelude::*;
use serde::Serialize;
use tapeshape_body::BodyModel;
use tapeshape_measure::MeasurementSet;

use crate::ansur::{Ansur, Sex, Split, Subject};
use crate::format::Dataset;
use crate::DatasetError;

/// ANSUR columns whose statistics a population must follow (issue 3: per
/// sex, means within 2 %, SDs within 15 %, correlations within 0.15).
pub const CHECKED_COLUMNS: &[&str] = &[
    "stature",
    "chestcircumference",
    "waistcircumference",
    "buttockcircumference",
];

/// Statistics of one sex: population (measured on the meshes) beside ANSUR
/// II's train split. Units: metres; correlations dimensionless.
#[derive(Debug, Clone, Serialize)]
pub struct SexStatistics {
    /// Which sex.
    pub sex: Sex,
    /// Bodies of this sex in the dataset.
    pub n_bodies: usize,
    /// Train-split subjects of this sex aged 18-90.
    pub n_ansur: usize,
    /// Column names, in order.
    pub columns: Vec<String>,
    /// Population mean per column.
    pub mean: Vec<f64>,
    /// ANSUR train mean per column.
    pub ansur_mean: Vec<f64>,
    /// Population SD per column.
    pub sd: Vec<f64>,
    /// ANSUR train SD per column.
    pub ansur_sd: Vec<f64>,
    /// Population correlation matrix.
    pub corr: Vec<Vec<f64>>,
    /// ANSUR train correlation matrix.
    pub ansur_corr: Vec<Vec<f64>>,
}

impl SexStatistics {
    /// Largest relative mean difference, largest relative SD difference and
    /// largest absolute correlation difference.
    pub fn worst(&self) -> (f64, f64, f64) {
        let k = self.columns.len();
        let dm = (0..k)
            .map(|j| (self.mean[j] / self.ansur_mean[j] - 1.0).abs())
            .fold(0.0, f64::max);
        let ds = (0..k)
            .map(|j| (self.sd[j] / self.ansur_sd[j] - 1.0).abs())
            .fold(0.0, f64::max);
        let dc = (0..k)
            .flat_map(|a| (0..k).map(move |b| (a, b)))
            .map(|(a, b)| (self.corr[a][b] - self.ansur_corr[a][b]).abs())
            .fold(0.0, f64::max);
        (dm, ds, dc)
    }

    /// True when the bounds hold (2 %, 15 %, 0.15).
    pub fn within_bounds(&self) -> bool {
        let (dm, ds, dc) = self.worst();
        dm <= 0.02 && ds <= 0.15 && dc <= 0.15
    }
}

/// Measures [`CHECKED_COLUMNS`] on every body of a population (with the
/// `ansur` set) and compares per sex with ANSUR II's train split.
pub fn population_statistics(dataset: &Dataset) -> Result<Vec<SexStatistics>, DatasetError> {
    let body = BodyModel::shared()?;
    let anatomy = tapeshape_body::anatomy::anatomy();
    if dataset.topology.n_vertices() != body.topology().n_vertices() {
        return Err(DatasetError::Settings(
            "population statistics need bodies in the template topology".into(),
        ));
    }
    let set = MeasurementSet::builtin("ansur")?.compile(body.topology(), &anatomy)?;
    let idx: Vec<usize> = CHECKED_COLUMNS
        .iter()
        .map(|c| {
            set.set()
                .index_of(c)
                .ok_or_else(|| DatasetError::Settings(format!("the ansur set has no {c:?}")))
        })
        .collect::<Result<_, _>>()?;
    let values: Vec<Result<Vec<f64>, DatasetError>> = dataset
        .bodies
        .par_iter()
        .map(|b| {
            idx.iter()
                .map(|&i| Ok(set.measure_one(i, b)?.value))
                .collect()
        })
        .collect();
    let values: Vec<Vec<f64>> = values.into_iter().collect::<Result<_, _>>()?;
    let ansur = Ansur::get()?;
    let mut out = Vec::new();
    for sex in [Sex::Male, Sex::Female] {
        let rows: Vec<Vec<f64>> = dataset
            .header
            .bodies
            .iter()
            .zip(&values)
            .filter(|(r, _)| r.sex == Some(sex))
            .map(|(_, v)| v.clone())
            .collect();
        if rows.len() < 3 {
            continue;
        }
        let subjects: Vec<&Subject> = ansur
            .subjects(Some(sex), Split::Train)
            .filter(|s| (18.0..=90.0).contains(&s.age_years))
            .collect();
        let (mean, sd, corr) = mean_sd_corr(&rows);
        let (ansur_mean, ansur_sd, ansur_corr) =
            crate::ansur::statistics(&subjects, CHECKED_COLUMNS);
        out.push(SexStatistics {
            sex,
            n_bodies: rows.len(),
            n_ansur: subjects.len(),
            columns: CHECKED_COLUMNS.iter().map(|c| c.to_string()).collect(),
            mean,
            ansur_mean,
            sd,
            ansur_sd,
            corr,
            ansur_corr,
        });
    }
    Ok(out)
}

/// The statistics as a Markdown table (mm, relative differences, worst correlation gap).
pub fn statistics_markdown(stats: &[SexStatistics]) -> String {
    let mut s = String::new();
    for st in stats {
        let (dm, ds, dc) = st.worst();
        s += &format!(
            "\n### {:?}: {} bodies vs {} ANSUR II train-split subjects\n\n| dimension | mean (mm) | ANSUR mean | diff | SD (mm) | ANSUR SD | diff |\n|---|---:|---:|---:|---:|---:|---:|\n",
            st.sex, st.n_bodies, st.n_ansur
        );
        for j in 0..st.columns.len() {
            s += &format!(
                "| {} | {:.1} | {:.1} | {:+.2} % | {:.1} | {:.1} | {:+.1} % |\n",
                st.columns[j],
                st.mean[j] * 1000.0,
                st.ansur_mean[j] * 1000.0,
                (st.mean[j] / st.ansur_mean[j] - 1.0) * 100.0,
                st.sd[j] * 1000.0,
                st.ansur_sd[j] * 1000.0,
                (st.sd[j] / st.ansur_sd[j] - 1.0) * 100.0
            );
        }
        s += "\nCorrelations, population (ANSUR):\n\n| | ";
        s += &st.columns.join(" | ");
        s += " |\n|---|";
        s += &"---:|".repeat(st.columns.len());
        s += "\n";
        for a in 0..st.columns.len() {
            s += &format!("| {} |", st.columns[a]);
            for b in 0..st.columns.len() {
                s += &format!(" {:.2} ({:.2}) |", st.corr[a][b], st.ansur_corr[a][b]);
            }
            s += "\n";
        }
        s += &format!(
            "\nWorst: mean {:.2} % (bound 2 %), SD {:.1} % (bound 15 %), correlation {:.3} (bound 0.15): {}\n",
            dm * 100.0,
            ds * 100.0,
            dc,
            if st.within_bounds() { "within bounds" } else { "OUT OF BOUNDS" }
        );
    }
    s
}

/// Mean, sample standard deviation (n - 1) and Pearson correlation matrix of
/// the columns of `rows` (`n x k`, any unit). Shapes: `k`, `k`, `k x k`.
/// With fewer than two rows the SDs and correlations are NaN.
pub fn mean_sd_corr(rows: &[Vec<f64>]) -> (Vec<f64>, Vec<f64>, Vec<Vec<f64>>) {
    let n = rows.len();
    let k = rows.first().map_or(0, Vec::len);
    let mut mean = vec![0.0; k];
    for r in rows {
        for j in 0..k {
            mean[j] += r[j] / n as f64;
        }
    }
    let mut cov = vec![vec![0.0; k]; k];
    for r in rows {
        for a in 0..k {
            for b in 0..k {
                cov[a][b] += (r[a] - mean[a]) * (r[b] - mean[b]) / (n as f64 - 1.0);
            }
        }
    }
    let sd: Vec<f64> = (0..k).map(|j| cov[j][j].sqrt()).collect();
    let corr = (0..k)
        .map(|a| (0..k).map(|b| cov[a][b] / (sd[a] * sd[b])).collect())
        .collect();
    (mean, sd, corr)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn perfectly_correlated_and_anticorrelated_columns() {
        let rows: Vec<Vec<f64>> = (0..10)
            .map(|i| vec![i as f64, 2.0 * i as f64 + 1.0, -(i as f64)])
            .collect();
        let (m, sd, c) = mean_sd_corr(&rows);
        assert!((m[0] - 4.5).abs() < 1e-12 && (m[1] - 10.0).abs() < 1e-12);
        assert!((sd[1] - 2.0 * sd[0]).abs() < 1e-12);
        assert!((c[0][1] - 1.0).abs() < 1e-12 && (c[0][2] + 1.0).abs() < 1e-12);
    }
}
