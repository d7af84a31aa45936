//! Words and numbers as the station shows them: lengths, times, device
//! faults, digests.
//!
//! Why a module of its own at the bottom of the station: the line mode, the
//! terminal interface and the `session` commands print the same things, and
//! a front end must not import another front end to share a format (that is
//! how `tui -> cli` import circles start). It imports nothing of the station
//! but the catalogue of its words ([`crate::i18n`]).

use tapeshape_protocol::{Fault, RejectReason};

use crate::i18n::tr;

/// Formats milliseconds since the Unix epoch as an RFC 3339 UTC time to the
/// second (`2026-11-22T05:30:00Z`).
pub fn format_time_ms(ms: i64) -> String {
    let t =
        std::time::UNIX_EPOCH + std::time::Duration::from_millis(u64::try_from(ms).unwrap_or(0));
    humantime::format_rfc3339_seconds(t).to_string()
}

/// A length in millimetres in `unit` with its symbol, to the tape's
/// resolution in that unit (`98.2 cm`, `38.66 in`, `982 mm`, `0.982 m`).
pub fn format_length_mm(unit: tapeshape_estimator::Unit, mm: f64) -> String {
    use tapeshape_estimator::Unit;
    match unit {
        Unit::Mm => format!("{mm:.0} mm"),
        Unit::Cm => format!("{:.1} cm", mm / 10.0),
        Unit::M => format!("{:.3} m", mm / 1000.0),
        Unit::In => format!("{:.2} in", mm / 25.4),
    }
}

/// Formats a length in tenths of a millimetre as millimetres (`951.2 mm`).
pub fn format_tenth_mm(v: u32) -> String {
    format!("{}.{} mm", v / 10, v % 10)
}

/// A device fault in operator words (what happened and what to do): the
/// fault's fixed word (`queue-full`, `tape-silent`, ...: English in every
/// language, the line mode's scripts match it), a colon, then the words in
/// the chosen language ([`crate::i18n`]).
pub fn describe_fault(f: &Fault) -> String {
    match *f {
        Fault::QueueFull {
            capacity,
            refused_value_tenth_mm,
            ..
        } => format!(
            "queue-full: {}",
            tr!(
                "fault-queue-full",
                capacity = capacity,
                value = format_tenth_mm(refused_value_tenth_mm)
            )
        ),
        Fault::QueueRecovered { queue_len } => format!(
            "queue-recovered ({})",
            tr!("fault-queue-recovered", held = queue_len)
        ),
        Fault::TapeSilent { silent_ms } => format!(
            "tape-silent: {}",
            tr!(
                "fault-tape-silent",
                seconds = format!("{:.1}", f64::from(silent_ms) / 1000.0)
            )
        ),
        Fault::TapeRecovered => "tape-recovered".to_string(),
        Fault::LineRejected {
            reason,
            rejected_total,
        } => format!(
            "line-rejected: {}",
            tr!(
                "fault-line-rejected",
                what = reject_words(reason),
                total = rejected_total
            )
        ),
        Fault::VersionMismatch { host, device } => format!(
            "version-mismatch: {}",
            tr!(
                "fault-version-mismatch",
                device = format!("{}.{}", device.major, device.minor),
                host = format!("{}.{}", host.major, host.minor)
            )
        ),
        Fault::HostFrameBad { total } => format!(
            "host-frame-bad: {}",
            tr!("fault-host-frame-bad", total = total)
        ),
    }
}

/// Why the firmware refused a tape line, in words (the chosen language).
pub fn reject_words(reason: RejectReason) -> String {
    match reason {
        RejectReason::Garbage => tr!("reject-garbage"),
        RejectReason::Partial { len } => tr!("reject-partial", len = len),
        RejectReason::Overlong => tr!("reject-overlong"),
        RejectReason::BadField { field } => tr!("reject-bad-field", field = field),
        RejectReason::Negative => tr!("reject-negative"),
        RejectReason::OutOfRange { value_tenth_mm } => tr!(
            "reject-out-of-range",
            value = format_tenth_mm(value_tenth_mm)
        ),
    }
}

/// SHA-256 of `bytes` as 64 lower-case hex digits.
pub fn sha256_hex(bytes: &[u8]) -> String {
    use sha2::Digest as _;
    sha2::Sha256::digest(bytes)
        .iter()
        .map(|b| format!("{b:02x}"))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn formats() {
        assert_eq!(format_tenth_mm(9512), "951.2 mm");
        assert_eq!(format_tenth_mm(7), "0.7 mm");
        assert_eq!(format_time_ms(0), "1970-01-01T00:00:00Z");
        assert_eq!(format_time_ms(1_000_000_000_123), "2001-09-09T01:46:40Z");
    }

    #[test]
    fn sha256_of_a_known_text() {
        // FIPS 180-2, appendix B.1.
        assert_eq!(
            sha256_hex(b"abc"),
            "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad"
        );
    }

    #[test]
    fn a_full_queue_says_the_value_was_not_recorded() {
        let t = describe_fault(&Fault::QueueFull {
            capacity: 32,
            refused_value_tenth_mm: 9_512,
            refused_total: 1,
        });
        assert!(t.contains("951.2 mm was NOT recorded"), "{t}");
        let t = describe_fault(&Fault::LineRejected {
            reason: RejectReason::Partial { len: 7 },
            rejected_total: 3,
        });
        assert!(
            t.contains("cut-off line (7 of 19") && t.contains("3 since boot"),
            "{t}"
        );
    }
}
