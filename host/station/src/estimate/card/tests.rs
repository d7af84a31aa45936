//! Unit tests of the card builder: the PDF's structure and text without
//! poppler (the page streams are uncompressed, so the text is in the file).
//! `tests/card.rs` turns a real card back into text and pixels.

use std::sync::OnceLock;

use tapeshape_estimator::{Estimate, Inputs, PredictOptions};

use super::*;

fn estimator() -> &'static Estimator {
    Estimator::default_model().expect("embedded model")
}

/// One estimate for every test (a third of a second each).
fn estimate() -> &'static Estimate {
    static E: OnceLock<Estimate> = OnceLock::new();
    E.get_or_init(|| {
        let mut inputs = Inputs::new();
        for (name, m) in [
            ("stature", 1.765),
            ("chest", 0.98),
            ("waist", 0.84),
            ("hip", 0.99),
        ] {
            inputs
                .push(crate::estimate::tape_input(name, m, None))
                .unwrap();
        }
        estimator()
            .predict(&inputs, &PredictOptions::default())
            .unwrap()
    })
}

fn card() -> Card {
    let e = estimate();
    Card::new(estimator(), &e.report, e.mesh.clone(), None, None)
}

fn count(hay: &[u8], needle: &[u8]) -> usize {
    hay.windows(needle.len()).filter(|w| *w == needle).count()
}

fn pages(pdf: &[u8]) -> usize {
    count(pdf, b"/Type /Page") - count(pdf, b"/Type /Pages")
}

/// The page content streams of `pdf` (every stream but the images').
fn content_streams(pdf: &[u8]) -> Vec<&[u8]> {
    let find = |hay: &[u8], from: usize, needle: &[u8]| {
        hay[from..]
            .windows(needle.len())
            .position(|w| w == needle)
            .map(|p| p + from)
    };
    let mut out = Vec::new();
    let mut at = 0;
    while let Some(s) = find(pdf, at, b"stream\n") {
        let dict_from = pdf[..s].windows(3).rposition(|w| w == b"obj").unwrap_or(0);
        let Some(e) = find(pdf, s, b"\nendstream") else {
            break;
        };
        if find(&pdf[dict_from..s], 0, b"/Image").is_none() {
            out.push(&pdf[s + 7..e]);
        }
        at = e + 10;
    }
    out
}

/// Every string the page streams show (`(...) Tj` or `<hex> Tj`),
/// unescaped and decoded from WinAnsi (Latin-1 but for the two typographic
/// characters the card writes), in stream order.
fn shown(pdf: &[u8]) -> Vec<String> {
    let decode = |b: u8| match b {
        0x85 => '…',
        0x96 => '–',
        b => char::from(b),
    };
    let mut out = Vec::new();
    for c in content_streams(pdf) {
        let mut i = 0;
        while i < c.len() {
            let mut bytes = Vec::new();
            match c[i] {
                b'(' => {
                    let mut depth = 1;
                    i += 1;
                    while i < c.len() {
                        match c[i] {
                            b'\\' => {
                                i += 1;
                                match c[i] {
                                    b'n' => bytes.push(b'\n'),
                                    b'0'..=b'7' => {
                                        let mut v = 0u32;
                                        let mut k = 0;
                                        while k < 3 && c[i].is_ascii_digit() {
                                            v = v * 8 + u32::from(c[i] - b'0');
                                            i += 1;
                                            k += 1;
                                        }
                                        i -= 1;
                                        bytes.push(v as u8);
                                    }
                                    b => bytes.push(b),
                                }
                            }
                            b'(' => {
                                depth += 1;
                                bytes.push(b'(');
                            }
                            b')' => {
                                depth -= 1;
                                if depth == 0 {
                                    break;
                                }
                                bytes.push(b')');
                            }
                            b => bytes.push(b),
                        }
                        i += 1;
                    }
                }
                b'<' => {
                    let close = c[i..].iter().position(|&b| b == b'>').unwrap() + i;
                    let hex = std::str::from_utf8(&c[i + 1..close]).unwrap();
                    bytes = (0..hex.len() / 2)
                        .map(|k| u8::from_str_radix(&hex[2 * k..2 * k + 2], 16).unwrap())
                        .collect();
                    i = close;
                }
                _ => {
                    i += 1;
                    continue;
                }
            }
            i += 1;
            if c[i..].starts_with(b" Tj") {
                out.push(bytes.into_iter().map(decode).collect());
            }
        }
    }
    out
}

/// Whether one string shown is exactly `text`.
fn shows(pdf: &[u8], text: &str) -> bool {
    shown(pdf).iter().any(|s| s == text)
}

#[test]
fn a_card_is_a_one_page_pdf_with_the_readings_and_the_values_off_the_body() {
    let c = card();
    let pdf = card_pdf(&c).unwrap();
    assert!(pdf.starts_with(b"%PDF-"), "not a PDF");
    assert!(pdf.trim_ascii_end().ends_with(b"%%EOF"));
    assert_eq!(pages(&pdf), 1);
    assert_eq!(count(&pdf, b"/Subtype /Image"), 2, "front and side");
    // The four readings, as the operator gave them, in centimetres.
    assert_eq!(c.taken.len(), 4);
    for v in &c.taken {
        assert!(shows(&pdf, &v.label), "{}", v.label);
        assert!(
            shows(&pdf, &format_length_mm(Unit::Cm, v.value_mm)),
            "{v:?}"
        );
    }
    assert!(shows(&pdf, "176.5 cm") && shows(&pdf, "98.0 cm"));
    // The rest of the quick set read off the body, each marked, with its
    // spread (every quick dimension has one).
    let names: Vec<&str> = c.from_body.iter().map(|v| v.name.as_str()).collect();
    assert_eq!(
        names,
        ["neck", "inside_leg", "arm_length", "thigh", "upper_arm"]
    );
    let marks = shown(&pdf).iter().filter(|s| *s == "from the body").count();
    assert_eq!(marks, c.from_body.len());
    let measured = &estimate().report.prediction.measurements;
    for v in &c.from_body {
        let m = measured.iter().find(|m| m.name == v.name).unwrap();
        assert_eq!(Some(v.value_mm), m.step2_mm);
        let sd = v.sd_mm.expect("a spread");
        assert!(sd > 1.0 && sd < 100.0, "{v:?}");
        assert!(shows(&pdf, &format_length_mm(Unit::Cm, v.value_mm)));
        assert!(shows(
            &pdf,
            &format!("± {}", format_length_mm(Unit::Cm, sd))
        ));
    }
    assert!(shows(&pdf, "Session: no session"));
    assert!(!shows(&pdf, "Sizes"), "no chart, no sizes");
}

#[test]
fn the_session_the_date_and_the_unit_are_on_the_card() {
    let mut c = card();
    c.session = Some(42);
    // 2026-11-22T05:30:09Z
    c.made_at_ms = 1_795_325_409_000;
    c.unit = Unit::In;
    let pdf = card_pdf(&c).unwrap();
    assert!(shows(&pdf, "Session: 42"));
    assert!(shows(&pdf, "Date: 2026-11-22 05:30 UTC"));
    assert!(shows(&pdf, "Lengths in inches (in)"));
    // 1765 mm in inches.
    assert!(shows(&pdf, "69.49 in"));
    assert!(!shows(&pdf, "176.5 cm"));
}

#[test]
fn sizes_say_which_dimensions_were_measured_and_which_read_off_the_body() {
    let chart = tapeshape_sizes::Chart::from_toml_str(
        r#"
[chart]
name = "test chart"
units = "cm"
[[garment]]
name = "shirt"
primary = ["chest"]
secondary = ["neck"]
size = [
    { label = "S", chest = [90, 100], neck = [30, 70] },
    { label = "M", chest = [100, 110], neck = [30, 70] },
]
"#,
        "test chart",
        &crate::estimate::sizes::known_dimensions(estimator()),
    )
    .unwrap();
    let e = estimate();
    let rec = crate::estimate::sizes::sizes(estimator(), &e.report, &chart);
    let c = Card::new(estimator(), &e.report, e.mesh.clone(), None, Some(rec));
    let pdf = card_pdf(&c).unwrap();
    assert!(shows(&pdf, "Sizes"));
    // Chest 98 cm measured: S, two SDs of the tape from its upper edge.
    let head = (0..=100)
        .map(|p| format!("shirt: S ({p} %)"))
        .chain(["shirt: S (>99 %)".to_string()])
        .find(|h| shows(&pdf, h));
    assert!(head.is_some(), "no headline for the shirt");
    let neck = c.from_body.iter().find(|v| v.name == "neck").unwrap();
    let basis = format!(
        "from: chest measured, neck from the body ± {}",
        format_length_mm(Unit::Cm, neck.sd_mm.unwrap())
    );
    // Wrapped over lines: the lines joined hold it.
    assert!(shown(&pdf).join(" ").contains(&basis), "{basis}");
}

#[test]
fn a_long_list_flows_onto_more_pages_and_loses_no_value() {
    let mut c = card();
    c.taken = (0..70)
        .map(|i| CardValue {
            name: format!("m{i}"),
            label: format!("Measurement {i}"),
            value_mm: 500.0 + f64::from(i),
            sd_mm: None,
        })
        .collect();
    let pdf = card_pdf(&c).unwrap();
    assert_eq!(pages(&pdf), 2);
    for i in 0..70 {
        assert!(shows(&pdf, &format!("Measurement {i}")), "{i}");
        assert!(shows(
            &pdf,
            &format!("{:.1} cm", 50.0 + f64::from(i) / 10.0)
        ));
    }
    assert!(shows(&pdf, "tapeshape · page 2 of 2"));
    assert!(shows(
        &pdf,
        "Your body measurements, continued · no session"
    ));
}

#[test]
fn a_body_without_extent_is_refused() {
    let mut c = card();
    for v in &mut c.body.vertices {
        *v = [0.0, 0.0, 1.0];
    }
    assert!(matches!(card_pdf(&c), Err(CardError::EmptyBody)));
}

#[test]
fn text_is_win_ansi_and_widths_are_helveticas() {
    assert_eq!(win_ansi("± 2.0 cm"), b"\xb1 2.0 cm");
    assert_eq!(win_ansi("a – b … €"), b"a \x96 b \x85 \x80");
    assert_eq!(win_ansi("Größe"), b"Gr\xf6\xdfe");
    assert_eq!(win_ansi("→\n"), b"? ");
    // Digits are all 556/1000 em; "Hi" is 722 + 222.
    assert!((text_width("0123456789", 10.0) - 55.6).abs() < 1e-4);
    assert!((text_width("Hi", 1000.0) - 944.0).abs() < 1e-3);
}

#[test]
fn wrapping_keeps_every_word_in_order_within_the_width() {
    let text = "on the store's chart \"Example menswear (ANSUR II train-split \
                percentiles; not a brand's chart)\"; a percentage is how likely";
    let lines = wrap(text, 8.5, 120.0, false);
    assert!(lines.len() > 2, "{lines:?}");
    for l in &lines {
        assert!(text_width(l, 8.5) <= 120.0, "{l}");
    }
    assert_eq!(
        lines.join(" "),
        text.split_whitespace().collect::<Vec<_>>().join(" ")
    );
    // A word wider than the line stands alone rather than being lost.
    assert_eq!(
        wrap("a verylongword b", 10.0, 20.0, false),
        ["a", "verylongword", "b"]
    );
    assert_eq!(
        fit("Waist (at the navel)", 10.0, 40.0).chars().last(),
        Some('…')
    );
    assert!(text_width(&fit("Waist (at the navel)", 10.0, 40.0), 10.0) <= 40.0);
}

#[test]
fn the_file_name_has_the_session_and_no_customer() {
    assert_eq!(file_name(Some(7)), "session7-card.pdf");
    assert_eq!(file_name(None), "card.pdf");
}

#[test]
fn writing_replaces_the_file_whole_and_creates_the_folder() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("new").join("card.pdf");
    write_card(&path, b"%PDF-first").unwrap();
    write_card(&path, b"%PDF-second").unwrap();
    assert_eq!(std::fs::read(&path).unwrap(), b"%PDF-second");
    let names: Vec<_> = std::fs::read_dir(path.parent().unwrap())
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    assert_eq!(names, ["card.pdf"], "no temporary file left");
    // A folder that cannot be made: a clear error, nothing written.
    let blocked = dir.path().join("file");
    std::fs::write(&blocked, b"x").unwrap();
    let err = write_card(&blocked.join("card.pdf"), b"%PDF").unwrap_err();
    assert!(matches!(err, CardError::Folder { .. }), "{err}");
}
