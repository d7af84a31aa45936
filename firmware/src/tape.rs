//! The tape's serial line format (RENPHO RF-BMF01 style): parse, assemble, format.
//!
//! A line is 19 printable ASCII characters and a terminator:
//!
//! ```text
//! *02050;00000;0000PM\n
//! │└─f1─┘ └─f2─┘ └f3┘││
//! │                  │└ unit shown on the tape's display: M metric, I imperial
//! │                  └─ P live value, S value confirmed with the tape's button
//! └─ start
//! ```
//!
//! `f1` is the length in hundredths of a centimetre, which is exactly tenths of a millimetre,
//! so it goes on the wire unchanged. `f2` and `f3` are digits whose meaning is not known; they
//! are checked (digits only) and kept for diagnostics. A line whose three fields are all zero
//! with the `P` flag is a heartbeat. See `docs/tape-format.md` for what is known and what is
//! assumed.
//!
//! Why by hand: the format is fixed-width ASCII; a 19-byte check is smaller in flash and
//! stricter than any general parser, and reports exactly which field was wrong.

use tapeshape_protocol::{RejectReason, UnitShown};

/// Characters in a line, terminator excluded.
pub const LINE_LEN: usize = 19;

/// Bytes of a formatted line, `\n` terminator included.
pub const LINE_BYTES: usize = LINE_LEN + 1;

/// Longest length the tape can measure, hundredths of a centimetre (300.00 cm, also tenths of
/// a millimetre). The RF-BMF01's tape is 150 cm long; the bound leaves room for tapes of other
/// lengths while still rejecting values no body measurement can have.
pub const MAX_TAPE_HUNDREDTHS_CM: u32 = 30_000;

/// The heartbeat line, newline included.
pub const HEARTBEAT_LINE: [u8; LINE_BYTES] = *b"*00000;00000;0000PM\n";

/// Whether a value is live or was confirmed with the tape's button.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Kind {
    /// `P`: the tape's current value, sent continuously while it changes.
    Live,
    /// `S`: the operator pressed the tape's button to confirm this value.
    Confirmed,
}

/// A valid value line.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct TapeLine {
    /// Length, hundredths of a centimetre (= tenths of a millimetre), 0..=[`MAX_TAPE_HUNDREDTHS_CM`].
    pub value_hundredths_cm: u32,
    /// Live or confirmed.
    pub kind: Kind,
    /// Unit on the tape's display (informational: the value is always centimetres).
    pub unit_shown: UnitShown,
    /// Second field (meaning unknown, 0..=99999), kept for diagnostics.
    pub field2: u32,
    /// Third field (meaning unknown, 0..=9999), kept for diagnostics.
    pub field3: u16,
}

/// A parsed line.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Line {
    /// A live or confirmed value.
    Value(TapeLine),
    /// The all-zero line the tape sends now and then.
    Heartbeat,
}

/// Why a value is impossible.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Impossible {
    /// A minus sign in the length field.
    Negative,
    /// Longer than [`MAX_TAPE_HUNDREDTHS_CM`].
    TooLong {
        /// The value, hundredths of a centimetre.
        value_hundredths_cm: u32,
    },
    /// A confirmed (`S`) reading of zero length.
    ConfirmedZero,
}

/// Why a line was rejected. Rejected lines are counted and reported, never forwarded.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum LineError {
    /// Not a tape line: control or non-ASCII bytes, no `*` start, wrong separators.
    #[error("not a tape line (bad start, separator or non-printable byte)")]
    Garbage,
    /// The line ended before its 19 characters.
    #[error("partial line of {len} characters (19 expected)")]
    Partial {
        /// Characters received (capped at 255).
        len: u8,
    },
    /// More than 19 characters before a terminator.
    #[error("line longer than 19 characters")]
    Overlong,
    /// A numeric field held a non-digit, or a flag letter was unknown. `field`: 1..=3 the
    /// numeric fields, 4 the `P`/`S` flag, 5 the `M`/`I` unit.
    #[error("bad field {field}")]
    BadField {
        /// 1-based field index.
        field: u8,
    },
    /// A well-formed line with a value no tape can produce.
    #[error("impossible value: {why:?}")]
    Impossible {
        /// What was impossible.
        why: Impossible,
    },
}

impl LineError {
    /// The reason as sent to the host.
    pub fn reason(&self) -> RejectReason {
        match *self {
            LineError::Garbage => RejectReason::Garbage,
            LineError::Partial { len } => RejectReason::Partial { len },
            LineError::Overlong => RejectReason::Overlong,
            LineError::BadField { field } => RejectReason::BadField { field },
            LineError::Impossible {
                why: Impossible::Negative,
            } => RejectReason::Negative,
            LineError::Impossible {
                why:
                    Impossible::TooLong {
                        value_hundredths_cm,
                    },
            } => RejectReason::OutOfRange {
                value_tenth_mm: value_hundredths_cm,
            },
            LineError::Impossible {
                why: Impossible::ConfirmedZero,
            } => RejectReason::OutOfRange { value_tenth_mm: 0 },
        }
    }
}

fn digits(field: &[u8]) -> Option<u32> {
    let mut v = 0u32;
    for &b in field {
        if !b.is_ascii_digit() {
            return None;
        }
        v = v * 10 + u32::from(b - b'0');
    }
    Some(v)
}

/// Parses one line's characters, terminator (`\r`, `\n`) already removed.
///
/// Checks, in order: printable ASCII only (else [`LineError::Garbage`]); length (shorter:
/// [`LineError::Partial`], longer: [`LineError::Overlong`]); `*` start and `;` separators
/// (Garbage); a minus sign in field 1 ([`Impossible::Negative`]); digits in the three fields
/// and known flag letters ([`LineError::BadField`]); the value range
/// ([`Impossible::TooLong`], [`Impossible::ConfirmedZero`]).
pub fn parse_line(line: &[u8]) -> Result<Line, LineError> {
    if line.iter().any(|b| !(0x20..=0x7e).contains(b)) {
        return Err(LineError::Garbage);
    }
    if line.len() < LINE_LEN {
        return Err(LineError::Partial {
            len: line.len() as u8,
        });
    }
    if line.len() > LINE_LEN {
        return Err(LineError::Overlong);
    }
    if line[0] != b'*' || line[6] != b';' || line[12] != b';' {
        return Err(LineError::Garbage);
    }
    let f1 = &line[1..6];
    if f1[0] == b'-' && digits(&f1[1..]).is_some() {
        return Err(LineError::Impossible {
            why: Impossible::Negative,
        });
    }
    let value = digits(f1).ok_or(LineError::BadField { field: 1 })?;
    let field2 = digits(&line[7..12]).ok_or(LineError::BadField { field: 2 })?;
    let field3 = digits(&line[13..17]).ok_or(LineError::BadField { field: 3 })? as u16;
    let kind = match line[17] {
        b'P' => Kind::Live,
        b'S' => Kind::Confirmed,
        _ => return Err(LineError::BadField { field: 4 }),
    };
    let unit_shown = match line[18] {
        b'M' => UnitShown::Metric,
        b'I' => UnitShown::Imperial,
        _ => return Err(LineError::BadField { field: 5 }),
    };
    if value == 0 && field2 == 0 && field3 == 0 && kind == Kind::Live {
        return Ok(Line::Heartbeat);
    }
    if value > MAX_TAPE_HUNDREDTHS_CM {
        return Err(LineError::Impossible {
            why: Impossible::TooLong {
                value_hundredths_cm: value,
            },
        });
    }
    if value == 0 && kind == Kind::Confirmed {
        return Err(LineError::Impossible {
            why: Impossible::ConfirmedZero,
        });
    }
    Ok(Line::Value(TapeLine {
        value_hundredths_cm: value,
        kind,
        unit_shown,
        field2,
        field3,
    }))
}

/// Splits the tape's byte stream into lines and parses them; bounded to one line of memory.
///
/// * `\n` and `\r` end a line (so `\n`, `\r\n` and `\r` endings all work); empty lines
///   carry nothing and are skipped.
/// * `*` always starts a new line: characters before it (a line whose end was lost) are
///   reported as [`LineError::Partial`] (or Garbage), and the new line is read normally. This
///   is how the assembler gets back in step after lost bytes.
/// * The 20th character without a terminator is reported at once as
///   [`LineError::Overlong`]; the rest up to the next terminator or `*` is skipped.
#[derive(Debug, Clone, Default)]
pub struct LineAssembler {
    buf: [u8; LINE_LEN],
    len: usize,
    overflowed: bool,
}

impl LineAssembler {
    /// An assembler waiting for the first line.
    pub const fn new() -> Self {
        Self {
            buf: [0; LINE_LEN],
            len: 0,
            overflowed: false,
        }
    }

    /// Characters of the line being received (0 while skipping an overlong one).
    pub fn pending_len(&self) -> usize {
        self.len
    }

    /// Pushes one byte; returns the outcome of a line it completed, if any.
    pub fn push(&mut self, b: u8) -> Option<Result<Line, LineError>> {
        match b {
            b'\n' | b'\r' => {
                let had = self.take();
                had.map(|n| parse_line(&self.buf[..n]))
            }
            b'*' => {
                let had = self.take().map(|n| parse_line(&self.buf[..n]));
                self.buf[0] = b'*';
                self.len = 1;
                had
            }
            _ if self.overflowed => None,
            _ if self.len == LINE_LEN => {
                self.overflowed = true;
                self.len = 0;
                Some(Err(LineError::Overlong))
            }
            _ => {
                self.buf[self.len] = b;
                self.len += 1;
                None
            }
        }
    }

    /// Ends the current line: `Some(len)` if there were characters to parse.
    fn take(&mut self) -> Option<usize> {
        let n = self.len;
        let skipped = self.overflowed;
        self.len = 0;
        self.overflowed = false;
        (!skipped && n > 0).then_some(n)
    }
}

/// Why a value cannot be formatted.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
#[error("value {0} does not fit the tape's 5-digit field (0..=99999)")]
pub struct ValueTooWide(pub u32);

/// Formats a line as the tape sends it, `\n` included: `*VVVVV;00000;0000KU\n`, for the
/// simulator and tests. Values up to 99999 format (including impossible ones above
/// [`MAX_TAPE_HUNDREDTHS_CM`], to test rejection); wider ones are an error.
pub fn format_line(
    value_hundredths_cm: u32,
    kind: Kind,
    unit_shown: UnitShown,
) -> Result<[u8; LINE_BYTES], ValueTooWide> {
    format_fields(value_hundredths_cm, 0, 0, kind, unit_shown)
}

/// Like [`format_line`] with the two unknown fields given (`field2` 0..=99999, `field3`
/// 0..=9999).
pub fn format_fields(
    value_hundredths_cm: u32,
    field2: u32,
    field3: u16,
    kind: Kind,
    unit_shown: UnitShown,
) -> Result<[u8; LINE_BYTES], ValueTooWide> {
    fn put(out: &mut [u8], mut v: u32) -> Result<(), ValueTooWide> {
        let orig = v;
        for slot in out.iter_mut().rev() {
            *slot = b'0' + (v % 10) as u8;
            v /= 10;
        }
        if v != 0 {
            return Err(ValueTooWide(orig));
        }
        Ok(())
    }
    let mut line = HEARTBEAT_LINE;
    put(&mut line[1..6], value_hundredths_cm)?;
    put(&mut line[7..12], field2)?;
    put(&mut line[13..17], u32::from(field3))?;
    line[17] = match kind {
        Kind::Live => b'P',
        Kind::Confirmed => b'S',
    };
    line[18] = match unit_shown {
        UnitShown::Metric => b'M',
        UnitShown::Imperial => b'I',
    };
    Ok(line)
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::vec::Vec;

    fn lines(stream: &[u8]) -> Vec<Result<Line, LineError>> {
        let mut a = LineAssembler::new();
        stream.iter().filter_map(|&b| a.push(b)).collect()
    }

    fn value(v: u32, kind: Kind, unit_shown: UnitShown) -> Result<Line, LineError> {
        Ok(Line::Value(TapeLine {
            value_hundredths_cm: v,
            kind,
            unit_shown,
            field2: 0,
            field3: 0,
        }))
    }

    #[test]
    fn documented_example_is_20_50_cm_live_metric() {
        assert_eq!(
            parse_line(b"*02050;00000;0000PM"),
            value(2050, Kind::Live, UnitShown::Metric)
        );
        assert_eq!(
            parse_line(b"*08520;00000;0000SI"),
            value(8520, Kind::Confirmed, UnitShown::Imperial)
        );
        assert_eq!(
            parse_line(b"*30000;00000;0000SM"),
            value(30000, Kind::Confirmed, UnitShown::Metric)
        );
        assert_eq!(
            parse_line(b"*00001;12345;6789PI"),
            Ok(Line::Value(TapeLine {
                value_hundredths_cm: 1,
                kind: Kind::Live,
                unit_shown: UnitShown::Imperial,
                field2: 12345,
                field3: 6789,
            }))
        );
    }

    #[test]
    fn heartbeat_is_the_all_zero_live_line() {
        assert_eq!(parse_line(b"*00000;00000;0000PM"), Ok(Line::Heartbeat));
        assert_eq!(parse_line(b"*00000;00000;0000PI"), Ok(Line::Heartbeat));
        assert_eq!(parse_line(&HEARTBEAT_LINE[..LINE_LEN]), Ok(Line::Heartbeat));
        // Zero value with other fields set is a live zero, not a heartbeat.
        assert_eq!(
            parse_line(b"*00000;00001;0000PM").map(|l| matches!(l, Line::Value(_))),
            Ok(true)
        );
        // A confirmed zero is impossible.
        assert_eq!(
            parse_line(b"*00000;00000;0000SM"),
            Err(LineError::Impossible {
                why: Impossible::ConfirmedZero
            })
        );
    }

    #[test]
    fn each_rejection_is_typed() {
        use LineError::*;
        let cases: &[(&[u8], LineError)] = &[
            (b"*02050;00000;0000P", Partial { len: 18 }),
            (b"*0", Partial { len: 2 }),
            (b"*02050;00000;0000PMX", Overlong),
            (b"#02050;00000;0000PM", Garbage),
            (b"*02050,00000;0000PM", Garbage),
            (b"*02050;00000,0000PM", Garbage),
            (b"*02050;00000;0000P\x01", Garbage),
            (b"*02050;00000;0000P\xc3", Garbage),
            (b"*02a50;00000;0000PM", BadField { field: 1 }),
            (b"* 2050;00000;0000PM", BadField { field: 1 }),
            (b"*+2050;00000;0000PM", BadField { field: 1 }),
            (b"*02050;0000x;0000PM", BadField { field: 2 }),
            (b"*02050;00000;00-0PM", BadField { field: 3 }),
            (b"*02050;00000;0000XM", BadField { field: 4 }),
            (b"*02050;00000;0000pM", BadField { field: 4 }),
            (b"*02050;00000;0000PC", BadField { field: 5 }),
            (
                b"*-2050;00000;0000PM",
                Impossible {
                    why: super::Impossible::Negative,
                },
            ),
            (
                b"*30001;00000;0000SM",
                Impossible {
                    why: super::Impossible::TooLong {
                        value_hundredths_cm: 30001,
                    },
                },
            ),
            (
                b"*99999;00000;0000PM",
                Impossible {
                    why: super::Impossible::TooLong {
                        value_hundredths_cm: 99999,
                    },
                },
            ),
        ];
        for (line, want) in cases {
            assert_eq!(
                parse_line(line),
                Err(*want),
                "{:?}",
                core::str::from_utf8(line)
            );
        }
    }

    #[test]
    fn assembler_handles_lf_crlf_and_cr_endings() {
        let s = b"*02050;00000;0000PM\n*02060;00000;0000PM\r\n*02070;00000;0000SM\r";
        assert_eq!(
            lines(s),
            [
                value(2050, Kind::Live, UnitShown::Metric),
                value(2060, Kind::Live, UnitShown::Metric),
                value(2070, Kind::Confirmed, UnitShown::Metric),
            ]
        );
        // Blank lines carry nothing.
        assert!(lines(b"\n\r\n\n").is_empty());
    }

    #[test]
    fn assembler_resyncs_on_star_after_a_lost_line_end() {
        // The first line lost its tail and newline; the next line is read normally.
        let s = b"*0205*02060;00000;0000PM\n";
        assert_eq!(
            lines(s),
            [
                Err(LineError::Partial { len: 5 }),
                value(2060, Kind::Live, UnitShown::Metric),
            ]
        );
        // Joined mid-line: the tail is a partial line, then in step.
        let s = b"0;00000;0000PM\n*02060;00000;0000PM\n";
        assert_eq!(
            lines(s),
            [
                Err(LineError::Partial { len: 14 }),
                value(2060, Kind::Live, UnitShown::Metric),
            ]
        );
    }

    #[test]
    fn overlong_is_reported_once_at_once_then_skipped() {
        let mut a = LineAssembler::new();
        let mut out = Vec::new();
        for (i, &b) in b"*02050;00000;0000PMMMMMMMMMMMMMMMMMMM".iter().enumerate() {
            if let Some(r) = a.push(b) {
                out.push((i, r));
            }
        }
        // Reported on the 20th character, not later.
        assert_eq!(out, [(19, Err(LineError::Overlong))]);
        // The terminator ends the skipped line silently (already reported), and the next
        // line is fine.
        let rest: Vec<_> = b"MMM\n*02050;00000;0000PM\n"
            .iter()
            .filter_map(|&b| a.push(b))
            .collect();
        assert_eq!(rest, [value(2050, Kind::Live, UnitShown::Metric)]);
    }

    #[test]
    fn format_then_parse_round_trips() {
        for v in [0u32, 1, 2050, 8520, 29999, 30000] {
            for kind in [Kind::Live, Kind::Confirmed] {
                for unit in [UnitShown::Metric, UnitShown::Imperial] {
                    let line = format_line(v, kind, unit).unwrap();
                    assert_eq!(line.len(), 20);
                    assert_eq!(line[19], b'\n');
                    let got = parse_line(&line[..LINE_LEN]);
                    match (v, kind) {
                        (0, Kind::Live) => assert_eq!(got, Ok(Line::Heartbeat)),
                        (0, Kind::Confirmed) => assert!(got.is_err()),
                        _ => assert_eq!(got, value(v, kind, unit)),
                    }
                }
            }
        }
        assert_eq!(
            &format_line(2050, Kind::Live, UnitShown::Metric).unwrap(),
            b"*02050;00000;0000PM\n"
        );
        assert_eq!(
            format_line(100_000, Kind::Live, UnitShown::Metric),
            Err(ValueTooWide(100_000))
        );
        assert_eq!(
            format_fields(1, 100_000, 0, Kind::Live, UnitShown::Metric),
            Err(ValueTooWide(100_000))
        );
        assert_eq!(
            format_fields(1, 0, 10_000, Kind::Live, UnitShown::Metric),
            Err(ValueTooWide(10_000))
        );
    }

    #[test]
    fn reasons_map_to_the_wire() {
        assert_eq!(
            LineError::Impossible {
                why: Impossible::TooLong {
                    value_hundredths_cm: 31000
                }
            }
            .reason(),
            RejectReason::OutOfRange {
                value_tenth_mm: 31000
            }
        );
        assert_eq!(
            LineError::Impossible {
                why: Impossible::Negative
            }
            .reason(),
            RejectReason::Negative
        );
        assert_eq!(
            LineError::Partial { len: 3 }.reason(),
            RejectReason::Partial { len: 3 }
        );
    }

    mod props {
        use super::*;
        use proptest::prelude::*;

        proptest! {
            /// Any byte stream: no panic, bounded memory, and a valid line after a terminator
            /// always parses.
            #[test]
            fn random_bytes_never_panic_and_resync(
                junk in prop::collection::vec(any::<u8>(), 0..300),
                v in 1u32..=MAX_TAPE_HUNDREDTHS_CM,
                confirmed in any::<bool>(),
            ) {
                let mut a = LineAssembler::new();
                for &b in &junk {
                    let _ = a.push(b);
                    prop_assert!(a.pending_len() <= LINE_LEN);
                }
                let kind = if confirmed { Kind::Confirmed } else { Kind::Live };
                let mut s = std::vec![b'\n'];
                s.extend_from_slice(&format_line(v, kind, UnitShown::Metric).unwrap());
                let out: Vec<_> = s.iter().filter_map(|&b| a.push(b)).collect();
                prop_assert_eq!(out.last(), Some(&value(v, kind, UnitShown::Metric)));
            }

            /// Only well-formed lines parse as values, and then the value is what the line says.
            #[test]
            fn parse_accepts_only_what_format_writes(line in prop::collection::vec(any::<u8>(), 19)) {
                if let Ok(Line::Value(l)) = parse_line(&line) {
                    let back = format_fields(l.value_hundredths_cm, l.field2, l.field3, l.kind, l.unit_shown).unwrap();
                    prop_assert_eq!(&back[..LINE_LEN], &line[..]);
                }
            }
        }
    }
}
