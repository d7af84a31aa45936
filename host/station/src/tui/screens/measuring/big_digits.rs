//! The live tape value in digits five rows tall, to be read from a step
//! away.
//!
//! Why by hand: `tui-big-text` (the ratatui widget for this) 0.8 builds on
//! `derive_builder` 0.20 and so on `darling` 0.20, beside the `darling`
//! 0.24 the workspace already has, and `cargo deny` refuses a second version
//! of a crate (`deny.toml`); its 8x8 font is also twice as wide as an 80x24
//! screen leaves room for. A number needs thirteen glyphs: a 3x5 block font.

/// The glyphs, three pixels wide (`.` and ` ` one) and five tall; `#` is a
/// lit pixel.
fn glyph(c: char) -> Option<[&'static str; 5]> {
    Some(match c {
        '0' => ["###", "# #", "# #", "# #", "###"],
        '1' => [" # ", "## ", " # ", " # ", "###"],
        '2' => ["###", "  #", "###", "#  ", "###"],
        '3' => ["###", "  #", " ##", "  #", "###"],
        '4' => ["# #", "# #", "###", "  #", "  #"],
        '5' => ["###", "#  ", "###", "  #", "###"],
        '6' => ["###", "#  ", "###", "# #", "###"],
        '7' => ["###", "  #", "  #", "  #", "  #"],
        '8' => ["###", "# #", "###", "# #", "###"],
        '9' => ["###", "# #", "###", "  #", "###"],
        '-' => ["   ", "   ", "###", "   ", "   "],
        '.' => [" ", " ", " ", " ", "#"],
        ' ' => [" ", " ", " ", " ", " "],
        _ => return None,
    })
}

/// Rows the big digits take.
pub const ROWS: u16 = 5;

/// `text` (digits, `.`, `-`, spaces) in the block font, each pixel `scale`
/// columns wide and one row tall, glyphs one column apart: [`ROWS`]
/// strings of full blocks and spaces, all of one width. `None` when `text`
/// has another character.
pub fn render(text: &str, scale: usize) -> Option<[String; 5]> {
    let glyphs: Vec<[&str; 5]> = text.chars().map(glyph).collect::<Option<_>>()?;
    let mut rows: [String; 5] = Default::default();
    for (k, g) in glyphs.iter().enumerate() {
        for (row, pixels) in rows.iter_mut().zip(g) {
            if k > 0 {
                row.push(' ');
            }
            for px in pixels.chars() {
                let cell = if px == '#' { '█' } else { ' ' };
                row.extend(std::iter::repeat_n(cell, scale));
            }
        }
    }
    Some(rows)
}

/// Columns [`render`] takes for `text` at `scale`; `None` when it cannot
/// draw `text`.
pub fn width(text: &str, scale: usize) -> Option<usize> {
    render(text, scale).map(|r| r[0].chars().count())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn digits_are_five_rows_of_one_width_and_tell_apart() {
        let all = "0123456789";
        let mut seen = std::collections::BTreeSet::new();
        for c in all.chars() {
            let r = render(&c.to_string(), 1).unwrap();
            assert!(r.iter().all(|row| row.chars().count() == 3), "{c}: {r:?}");
            assert!(seen.insert(r.clone()), "{c} looks like another digit");
        }
        let r = render("183.7", 2).unwrap();
        // four digits of 6, a point of 2, four gaps.
        assert_eq!(width("183.7", 2), Some(4 * 6 + 2 + 4));
        assert!(r.iter().all(|row| row.chars().count() == 30));
        // The point sits on the bottom row only.
        let point_col = 3 * 7;
        assert!(r[..4]
            .iter()
            .all(|row| row.chars().nth(point_col) == Some(' ')));
        assert_eq!(r[4].chars().nth(point_col), Some('█'));
    }

    #[test]
    fn other_characters_are_refused() {
        assert_eq!(render("98.2 cm", 1), None);
        assert_eq!(width("x", 1), None);
        assert_eq!(render("--", 1).unwrap()[2], "███ ███");
    }
}
