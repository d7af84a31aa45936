//! The paper's clamp: every normalised weight to `[-l, l]`.
//!
//! "restrict W_new such that each dimension W_new\[i\] is at most l times the
//! standard deviation of the PCA space along dimension i" (paper, section
//! Approach): the start is clamped, and again the result of step 1 (method
//! notes). With normalised weights (unit variance per component on the
//! training set) the box is `|w_i| <= l`. `hold_in_box` is the same clamp
//! inside step 1 with the clamped components held (the default's
//! [`crate::predict::Step1Clamp::InsideBox`]).

/// Clamps every weight of `w` to `[-l, l]`; returns the indices it changed.
pub fn clamp_weights(w: &mut [f64], l: f64) -> Vec<usize> {
    let mut clamped = Vec::new();
    for (k, x) in w.iter_mut().enumerate() {
        if x.abs() > l {
            *x = x.clamp(-l, l);
            clamped.push(k);
        }
    }
    clamped
}

/// Clamps every weight beyond `l` and marks it held (`held[i] = true`), so
/// the following rounds of step 1 refit the others.
pub(crate) fn hold_in_box(w: &mut [f64], held: &mut [bool], l: f64) {
    for (i, x) in w.iter_mut().enumerate() {
        if x.abs() > l {
            *x = x.clamp(-l, l);
            held[i] = true;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn clamp_reports_components() {
        let mut w = vec![0.5, -4.0, 3.5, 3.0];
        assert_eq!(clamp_weights(&mut w, 3.0), vec![1, 2]);
        assert_eq!(w, vec![0.5, -3.0, 3.0, 3.0]);
    }

    #[test]
    fn hold_in_box_marks_what_it_clamps() {
        let mut w = vec![0.5, -4.0, 3.5];
        let mut held = vec![false, false, true];
        hold_in_box(&mut w, &mut held, 3.0);
        assert_eq!(w, vec![0.5, -3.0, 3.0]);
        assert_eq!(held, vec![false, true, true]);
    }
}
