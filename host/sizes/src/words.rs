//! How a reading sits in a size, in words: the one place the
//! recommendation's phrases are made, so the TUI, the card and the text
//! report say the same thing.
//!
//! The body's side of the misfit decides the word: a body girth above the
//! size's interval means the garment is **tight** there, below it
//! **loose**; a body length above means the garment is **too short for**
//! it, below **too long for** it; a breadth above **narrow**, below
//! **wide**.

use crate::chart::DimensionKind;
use crate::recommend::{Edge, Position};

/// The dimension's name as it reads in a phrase (`inside_leg` → `inside leg`).
pub fn place(dimension: &str) -> String {
    dimension.replace('_', " ")
}

/// The phrase for a reading of `dimension` (of `kind`) at `position` in a
/// size's interval: "fits at the chest, 4 mm from the upper edge", "fits
/// the inside leg, 9 mm from the lower edge", "tight at the hip", "loose at
/// the waist", "too short for the inside leg".
pub fn fit_words(kind: DimensionKind, dimension: &str, position: Position) -> String {
    let place = place(dimension);
    match position {
        Position::Inside {
            nearer,
            distance_mm,
        } => format!(
            "fits {} {place}, {distance_mm:.0} mm from the {} edge",
            match kind {
                DimensionKind::Length => "the",
                DimensionKind::Girth | DimensionKind::Breadth => "at the",
            },
            match nearer {
                Edge::Lower => "lower",
                Edge::Upper => "upper",
            }
        ),
        Position::Above { .. } => match kind {
            DimensionKind::Girth => format!("tight at the {place}"),
            DimensionKind::Length => format!("too short for the {place}"),
            DimensionKind::Breadth => format!("narrow at the {place}"),
        },
        Position::Below { .. } => match kind {
            DimensionKind::Girth => format!("loose at the {place}"),
            DimensionKind::Length => format!("too long for the {place}"),
            DimensionKind::Breadth => format!("wide at the {place}"),
        },
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_body_side_of_the_misfit_picks_the_word() {
        let above = Position::Above { by_mm: 12.0 };
        let below = Position::Below { by_mm: 3.0 };
        assert_eq!(
            fit_words(DimensionKind::Girth, "hip", above),
            "tight at the hip"
        );
        assert_eq!(
            fit_words(DimensionKind::Girth, "waist", below),
            "loose at the waist"
        );
        assert_eq!(
            fit_words(DimensionKind::Length, "inside_leg", above),
            "too short for the inside leg"
        );
        assert_eq!(
            fit_words(DimensionKind::Length, "arm_length", below),
            "too long for the arm length"
        );
        assert_eq!(
            fit_words(DimensionKind::Breadth, "shoulder_breadth", above),
            "narrow at the shoulder breadth"
        );
        assert_eq!(
            fit_words(
                DimensionKind::Girth,
                "chest",
                Position::Inside {
                    nearer: Edge::Upper,
                    distance_mm: 4.2
                }
            ),
            "fits at the chest, 4 mm from the upper edge"
        );
        assert_eq!(
            fit_words(
                DimensionKind::Length,
                "inside_leg",
                Position::Inside {
                    nearer: Edge::Lower,
                    distance_mm: 0.0
                }
            ),
            "fits the inside leg, 0 mm from the lower edge"
        );
    }
}
