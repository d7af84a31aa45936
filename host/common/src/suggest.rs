//! "Did you mean ...?": the known names closest to a name that is not known.
//!
//! One rule and one message style for every unknown name the programs
//! report (measurements, measurement sets, landmarks, body parts, local
//! changes, ANSUR II columns), so a typo reads the same wherever it is made:
//!
//! ```text
//! unknown measurement `statur`; did you mean `stature`?
//! ```
//!
//! Similarity is the larger of two `strsim` scores, each in `[0, 1]`: the
//! normalised Damerau-Levenshtein similarity (a swap of two neighbouring
//! letters counts as one edit, the commonest typo) and the Jaro-Winkler
//! similarity (which rewards a shared start, so `waist` finds
//! `waist_circumference`). A name is suggested when it scores above
//! [`MIN_SIMILARITY`] and within [`TIE_MARGIN`] of the best; at most
//! [`MAX_SUGGESTIONS`] are named, best first.

/// A known name scoring at or below this is never suggested (a guess that
/// far off confuses more than it helps).
pub const MIN_SIMILARITY: f64 = 0.6;
/// Names this close to the best score are named with it ("`a` or `b`").
/// Small because Jaro-Winkler rewards a shared start: every local change
/// begins `measure-...`, and at 0.05 `measure-wiast-circ-incr` also named
/// `measure-hips-circ-incr` (0.956 against 0.991).
pub const TIE_MARGIN: f64 = 0.03;
/// At most this many names are suggested.
pub const MAX_SUGGESTIONS: usize = 3;

/// Similarity of `a` and `b` in `[0, 1]` (1: equal), see the module docs.
pub fn similarity(a: &str, b: &str) -> f64 {
    strsim::normalized_damerau_levenshtein(a, b).max(strsim::jaro_winkler(a, b))
}

/// The names of `known` closest to `name`, best first (ties in `known`'s
/// order): those scoring above [`MIN_SIMILARITY`] and within [`TIE_MARGIN`]
/// of the best, at most [`MAX_SUGGESTIONS`]. Empty when none is close.
pub fn closest<'a>(name: &str, known: impl IntoIterator<Item = &'a str>) -> Vec<&'a str> {
    let mut scored: Vec<(f64, &str)> = known
        .into_iter()
        .map(|k| (similarity(name, k), k))
        .collect();
    // Stable: equal scores keep the order of `known`.
    scored.sort_by(|a, b| b.0.total_cmp(&a.0));
    let best = scored.first().map_or(0.0, |s| s.0);
    scored
        .into_iter()
        .take(MAX_SUGGESTIONS)
        .filter(|s| s.0 > MIN_SIMILARITY && s.0 >= best - TIE_MARGIN)
        .map(|s| s.1)
        .collect()
}

/// `"; did you mean `a`?"` or `"; did you mean `a` or `b`?"` for the
/// [`closest`] names, or an empty string when none is close: the tail of
/// an "unknown ..." message.
pub fn did_you_mean<'a>(name: &str, known: impl IntoIterator<Item = &'a str>) -> String {
    phrase(&closest(name, known))
}

/// The tail [`did_you_mean`] writes for `names` (empty for none).
pub fn phrase(names: &[&str]) -> String {
    if names.is_empty() {
        return String::new();
    }
    let quoted: Vec<String> = names.iter().map(|n| format!("`{n}`")).collect();
    format!("; did you mean {}?", quoted.join(" or "))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_swap_of_two_letters_finds_the_name() {
        assert_eq!(
            did_you_mean("acromion_rigth", ["acromion_right", "acromion_left"]),
            "; did you mean `acromion_right`?"
        );
        assert_eq!(
            closest("statur", ["waist", "stature", "chest"]),
            ["stature"]
        );
    }

    #[test]
    fn nothing_close_suggests_nothing() {
        assert_eq!(did_you_mean("zzzz", ["acromion_right"]), "");
        assert!(closest("x", std::iter::empty()).is_empty());
    }

    #[test]
    fn near_ties_are_named_together_best_first() {
        let known = [
            "waist",
            "knee_circumference_left",
            "knee_circumference_right",
        ];
        let got = closest("kne_circ", known);
        assert_eq!(got, ["knee_circumference_left", "knee_circumference_right"]);
        assert_eq!(
            phrase(&got),
            "; did you mean `knee_circumference_left` or `knee_circumference_right`?"
        );
        // A shared start alone does not make a tie.
        assert_eq!(
            closest(
                "measure-wiast-circ-incr",
                ["measure-hips-circ-incr", "measure-waist-circ-incr"]
            ),
            ["measure-waist-circ-incr"]
        );
        let many: Vec<String> = (0..10).map(|i| format!("name{i}")).collect();
        assert_eq!(
            closest("name", many.iter().map(String::as_str)).len(),
            MAX_SUGGESTIONS
        );
    }
}
