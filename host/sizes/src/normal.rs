//! The probability that a normal reading lies in a size's interval.
//!
//! Each dimension is taken as an independent normal `N(value, sd²)` (the
//! recommendation's stated assumption, `docs/size-charts.md`); the chance
//! that it lies in `[lo, hi)` is `Φ((hi − value)/sd) − Φ((lo − value)/sd)`.
//! `Φ` is written with `libm::erfc` (`Φ(z) = erfc(−z/√2)/2`) rather than
//! `erf`, and the difference is taken on the tail the interval lies in, so
//! that an interval far out in a tail keeps its (small) probability instead
//! of cancelling to zero.

use crate::chart::Interval;

/// `P(Z > z)` for a standard normal `Z`.
fn upper_tail(z: f64) -> f64 {
    0.5 * libm::erfc(z / std::f64::consts::SQRT_2)
}

/// `P(lo ≤ X < hi)` for `X ~ N(value_mm, sd_mm²)`; all in mm. `sd_mm = 0`
/// is a point: 1 when `interval` contains `value_mm` (lo included, hi not),
/// else 0. The result is in `[0, 1]`.
pub fn interval_probability(value_mm: f64, sd_mm: f64, interval: Interval) -> f64 {
    if sd_mm == 0.0 {
        return if interval.contains(value_mm) {
            1.0
        } else {
            0.0
        };
    }
    let a = (interval.lo_mm() - value_mm) / sd_mm;
    let b = (interval.hi_mm() - value_mm) / sd_mm;
    let p = if a >= 0.0 {
        // Both bounds above the value: difference of upper tails.
        upper_tail(a) - upper_tail(b)
    } else if b <= 0.0 {
        // Both below: difference of lower tails, P(Z < z) = P(Z > -z).
        upper_tail(-b) - upper_tail(-a)
    } else {
        1.0 - upper_tail(-a) - upper_tail(b)
    };
    p.clamp(0.0, 1.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    // P(|Z| < k) for k = 1, 2, 3: erf(k/√2), the 68-95-99.7 rule to 15 digits.
    const WITHIN_1: f64 = 0.682_689_492_137_085_9;
    const WITHIN_2: f64 = 0.954_499_736_103_641_6;
    const WITHIN_3: f64 = 0.997_300_203_936_739_8;

    #[test]
    fn a_reading_at_the_centre_of_a_2k_sd_interval_gives_erf_k_over_root_2() {
        for (k, expected) in [(1.0, WITHIN_1), (2.0, WITHIN_2), (3.0, WITHIN_3)] {
            for sd in [4.0, 9.0, 37.5] {
                let centre = 1000.0;
                let got = interval_probability(
                    centre,
                    sd,
                    Interval::new(centre - k * sd, centre + k * sd),
                );
                assert!((got - expected).abs() < 1e-12, "k {k}, sd {sd}: {got}");
            }
        }
    }

    #[test]
    fn one_sided_and_far_tail_intervals_keep_their_probability() {
        // [value, value + sd): half of P(|Z| < 1).
        let got = interval_probability(500.0, 10.0, Interval::new(500.0, 510.0));
        assert!((got - WITHIN_1 / 2.0).abs() < 1e-12, "{got}");
        // [value + 10 sd, value + 11 sd): about 7.6e-24 = Q(10) - Q(11);
        // Φ(b) − Φ(a) on the near side would round to 0.
        let far = interval_probability(0.5, 1.0, Interval::new(10.5, 11.5));
        let q10 = 7.619_853_024_160_527e-24;
        let q11 = 1.910_659_574_498_21e-28;
        assert!((far - (q10 - q11)).abs() < 1e-30, "{far}");
        let mirrored = interval_probability(0.5, 1.0, Interval::new(-10.5, -9.5));
        assert!((far - mirrored).abs() < 1e-36, "{far} vs {mirrored}");
    }

    #[test]
    fn sd_zero_is_a_point_lo_included_hi_not() {
        let i = Interval::new(960.0, 1040.0);
        assert_eq!(interval_probability(960.0, 0.0, i), 1.0);
        assert_eq!(interval_probability(1039.999, 0.0, i), 1.0);
        assert_eq!(interval_probability(1040.0, 0.0, i), 0.0);
        assert_eq!(interval_probability(959.999, 0.0, i), 0.0);
    }
}
