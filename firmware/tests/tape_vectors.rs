//! Fixed vectors of the tape's line format, one per line kind, in
//! `tests/vectors/tape-lines.txt`: parsed and compared with the value this
//! file expects; a line that parses is formatted again from that value and
//! must give the very same bytes (with the tape's `\n`), through the whole
//! assembler as well as `parse_line`.
//!
//! Why: the unit tests in `src/tape.rs` and its round-trip property pass for
//! any consistent change of parser and formatter together (say, the kind and
//! unit letters swapped, or fields 2 and 3 exchanged); the deployed tapes do
//! not change with them. These vectors pin what the tape sends.

use std::collections::BTreeMap;

use tapeshape_firmware::protocol::{RejectReason, UnitShown};
use tapeshape_firmware::tape::{
    format_fields, parse_line, Impossible, Kind, Line, LineAssembler, LineError, TapeLine,
    HEARTBEAT_LINE, LINE_LEN,
};

fn value(v: u32, field2: u32, field3: u16, kind: Kind, unit_shown: UnitShown) -> Line {
    Line::Value(TapeLine {
        value_hundredths_cm: v,
        kind,
        unit_shown,
        field2,
        field3,
    })
}

/// What each committed line must parse to.
fn expected() -> Vec<(&'static str, Result<Line, LineError>)> {
    use Kind::{Confirmed, Live};
    use UnitShown::{Imperial, Metric};
    let impossible = |why| Err(LineError::Impossible { why });
    vec![
        ("value.live.metric", Ok(value(2050, 0, 0, Live, Metric))),
        (
            "value.live.imperial",
            Ok(value(1, 12_345, 6789, Live, Imperial)),
        ),
        (
            "value.confirmed.metric",
            Ok(value(8520, 0, 0, Confirmed, Metric)),
        ),
        (
            "value.confirmed.imperial",
            Ok(value(30_000, 12, 345, Confirmed, Imperial)),
        ),
        ("value.live.zero", Ok(value(0, 12, 0, Live, Metric))),
        ("heartbeat", Ok(Line::Heartbeat)),
        ("reject.garbage.start", Err(LineError::Garbage)),
        ("reject.garbage.separator", Err(LineError::Garbage)),
        ("reject.partial", Err(LineError::Partial { len: 5 })),
        ("reject.overlong", Err(LineError::Overlong)),
        ("reject.bad_field.1", Err(LineError::BadField { field: 1 })),
        ("reject.bad_field.2", Err(LineError::BadField { field: 2 })),
        ("reject.bad_field.3", Err(LineError::BadField { field: 3 })),
        ("reject.bad_field.4", Err(LineError::BadField { field: 4 })),
        ("reject.bad_field.5", Err(LineError::BadField { field: 5 })),
        ("reject.negative", impossible(Impossible::Negative)),
        (
            "reject.out_of_range",
            impossible(Impossible::TooLong {
                value_hundredths_cm: 30_001,
            }),
        ),
        (
            "reject.confirmed_zero",
            impossible(Impossible::ConfirmedZero),
        ),
    ]
}

/// `name -> line` from the vector file.
fn vectors() -> BTreeMap<String, Vec<u8>> {
    let mut out = BTreeMap::new();
    for (i, line) in include_str!("vectors/tape-lines.txt").lines().enumerate() {
        if line.trim().is_empty() || line.starts_with('#') {
            continue;
        }
        let (name, text) = line
            .split_once(char::is_whitespace)
            .unwrap_or_else(|| panic!("tape-lines.txt line {}: expected `NAME LINE`", i + 1));
        let old = out.insert(name.to_string(), text.trim().as_bytes().to_vec());
        assert!(old.is_none(), "tape-lines.txt: {name} twice");
    }
    out
}

#[test]
fn every_committed_line_parses_to_its_value_and_formats_back_to_the_same_bytes() {
    let vectors = vectors();
    let expected = expected();
    let names: Vec<&str> = expected.iter().map(|(n, _)| *n).collect();
    assert_eq!(
        vectors.keys().map(String::as_str).collect::<Vec<_>>(),
        {
            let mut n = names.clone();
            n.sort_unstable();
            n
        },
        "the vector file and the expected values name the same kinds"
    );
    for (name, want) in expected {
        let line = &vectors[name];
        let shown = String::from_utf8_lossy(line);
        assert_eq!(parse_line(line), want, "{name}: {shown:?}");
        // The same through the assembler, with the tape's terminator.
        let mut stream = line.clone();
        stream.push(b'\n');
        let mut assembler = LineAssembler::new();
        let out: Vec<_> = stream.iter().filter_map(|&b| assembler.push(b)).collect();
        assert_eq!(out, [want], "{name} through the assembler");
        // Format the expected value again: the same 19 characters and `\n`.
        let formatted = match want {
            Ok(Line::Value(l)) => format_fields(
                l.value_hundredths_cm,
                l.field2,
                l.field3,
                l.kind,
                l.unit_shown,
            )
            .expect("a parsed value formats"),
            Ok(Line::Heartbeat) => HEARTBEAT_LINE,
            Err(_) => continue,
        };
        assert_eq!(line.len(), LINE_LEN, "{name}");
        assert_eq!(
            String::from_utf8_lossy(&formatted),
            format!("{shown}\n"),
            "{name}: the formatter no longer writes the committed line"
        );
    }
}

#[test]
fn rejections_map_to_their_wire_reasons() {
    // The reason each rejected vector is reported with (`Fault::LineRejected`,
    // pinned byte for byte in protocol/tests/vectors/frames.txt).
    let vectors = vectors();
    let reason = |name: &str| parse_line(&vectors[name]).unwrap_err().reason();
    assert_eq!(reason("reject.garbage.start"), RejectReason::Garbage);
    assert_eq!(reason("reject.partial"), RejectReason::Partial { len: 5 });
    assert_eq!(reason("reject.overlong"), RejectReason::Overlong);
    assert_eq!(
        reason("reject.bad_field.4"),
        RejectReason::BadField { field: 4 }
    );
    assert_eq!(reason("reject.negative"), RejectReason::Negative);
    assert_eq!(
        reason("reject.out_of_range"),
        RejectReason::OutOfRange {
            value_tenth_mm: 30_001
        }
    );
    assert_eq!(
        reason("reject.confirmed_zero"),
        RejectReason::OutOfRange { value_tenth_mm: 0 }
    );
}
