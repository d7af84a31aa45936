//! Small descriptive statistics used by the population checks.

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
