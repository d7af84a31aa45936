//! Careful mode: each measurement taken twice, a third time when the two
//! differ by more than the measurement's allowable error, the median kept;
//! the session's technical error of measurement (TEM).
//!
//! Why: anthropometric practice (ISO 20685-1, ISO 7250-1) repeats every
//! measurement to catch a misplaced tape and to state how repeatable the
//! measurer was. The allowable error is the set's ISO 20685-1 tolerance of
//! the measurement (`tapeshape_measure::Tolerance`: 4 mm for heights,
//! breadths and small girths, 5 mm for segment lengths, 9 mm for large
//! girths).
//!
//! Nothing here is stored: every reading is an ordinary reading of the
//! store, and a careful reading supersedes the one before it, as a retake
//! does, so undo (withdraw) works unchanged. What careful mode adds is read
//! off a measurement's *chain*, its current reading and the readings it
//! superseded, oldest first ([`chains`]): the chain is cut into rounds
//! ([`rounds`]) of two readings, three when the first two differ by more
//! than the allowable error. Only the last round can be unfinished; the
//! kept value is the median of the last finished round ([`kept`]), so a
//! retake started and not finished keeps the value accepted before it. A
//! median of two readings is their mean, to the nearest tenth of a
//! millimetre (a half rounded up). A measurement the set does not know has
//! no allowable error: each of its readings is a round of its own.
//!
//! The TEM follows ISO 20685-1 for two readings per subject:
//! `TEM = sqrt(sum(d_i^2) / 2n)` over `n` pairs, relative TEM = TEM / mean
//! of the paired readings * 100 %. The pair of a round is its first two
//! readings (the ones whose difference asked for a third; the third does
//! not make the measurer look more repeatable than they were); a
//! measurement has one pair per finished or unfinished round with two
//! readings, the session all of them.

use serde::Serialize;

use crate::store::{ReadingId, SessionDetail, StoredReading};

/// Readings a round takes when the first two agree.
pub const READINGS: usize = 2;

/// Readings a round takes when the first two differ by more than the
/// allowable error.
pub const READINGS_IF_APART: usize = 3;

/// One round of a careful measurement: its readings (tenths of a mm, in
/// the order taken) and the allowable error between the first two.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Round {
    /// Readings, tenths of a millimetre, oldest first (1 to 3).
    pub readings: Vec<u32>,
    /// Allowable difference between the first two, tenths of a mm
    /// (`None`: the measurement has none; the round is one reading).
    pub allowed: Option<u32>,
}

impl Round {
    /// Readings this round takes: 1 without an allowable error, else 2, or
    /// 3 when the first two differ by more than it.
    pub fn needed(&self) -> usize {
        match (self.allowed, self.pair()) {
            (None, _) => 1,
            (Some(allowed), Some((a, b))) if a.abs_diff(b) > allowed => READINGS_IF_APART,
            (Some(_), _) => READINGS,
        }
    }

    /// Has it all its readings?
    pub fn complete(&self) -> bool {
        self.readings.len() >= self.needed()
    }

    /// The first two readings, once taken.
    pub fn pair(&self) -> Option<(u32, u32)> {
        match self.readings.as_slice() {
            [a, b, ..] => Some((*a, *b)),
            _ => None,
        }
    }

    /// How far apart the first two are, tenths of a mm, once taken.
    pub fn apart(&self) -> Option<u32> {
        self.pair().map(|(a, b)| a.abs_diff(b))
    }

    /// The median of its readings, once it is complete.
    pub fn kept(&self) -> Option<u32> {
        self.complete().then(|| median(&self.readings)).flatten()
    }

    /// The number (1-based) of the reading it waits for, or `None` when it
    /// is complete.
    pub fn next_reading(&self) -> Option<usize> {
        (!self.complete()).then_some(self.readings.len() + 1)
    }
}

/// The median of `values` (tenths of a mm): the middle one of an odd
/// count, the mean of the middle two of an even count to the nearest tenth
/// of a mm (a half rounded up). `None` for no values.
pub fn median(values: &[u32]) -> Option<u32> {
    let mut v = values.to_vec();
    v.sort_unstable();
    let n = v.len();
    match n {
        0 => None,
        _ if n % 2 == 1 => Some(v[n / 2]),
        _ => {
            let (a, b) = (u64::from(v[n / 2 - 1]), u64::from(v[n / 2]));
            u32::try_from((a + b).div_ceil(2)).ok()
        }
    }
}

/// The rounds of a chain of readings (tenths of a mm, oldest first) with
/// allowable error `allowed` (tenths of a mm): two readings each, three when
/// the first two differ by more than `allowed`; only the last may be
/// unfinished.
pub fn rounds(chain: &[u32], allowed: Option<u32>) -> Vec<Round> {
    let mut out: Vec<Round> = Vec::new();
    for &v in chain {
        match out.last_mut() {
            Some(r) if !r.complete() => r.readings.push(v),
            _ => out.push(Round {
                readings: vec![v],
                allowed,
            }),
        }
    }
    out
}

/// The kept value of a chain: the median of its last finished round
/// (`None` while the first round is unfinished).
pub fn kept(chain: &[u32], allowed: Option<u32>) -> Option<u32> {
    rounds(chain, allowed).iter().rev().find_map(Round::kept)
}

/// The round the next reading of a chain goes to: the unfinished last
/// round, or a new empty one.
pub fn open_round(chain: &[u32], allowed: Option<u32>) -> Round {
    match rounds(chain, allowed).pop() {
        Some(r) if !r.complete() => r,
        _ => Round {
            readings: Vec::new(),
            allowed,
        },
    }
}

/// The allowable error of a measurement in tenths of a mm (its ISO
/// 20685-1 tolerance in mm).
pub fn allowed_tenth_mm(tolerance: tapeshape_measure::Tolerance) -> u32 {
    (tolerance.mm() * 10.0).round() as u32
}

/// Each measurement's chain in `detail`: its current reading and the
/// readings it superseded, one after another, oldest first; measurements in
/// the order of their current readings. Withdrawn readings are not in any
/// chain. (Should a measurement have two current readings, the newest one
/// heads its chain.)
pub fn chains(detail: &SessionDetail) -> Vec<(String, Vec<&StoredReading>)> {
    let mut heads: Vec<&StoredReading> = Vec::new();
    for r in detail.current_readings() {
        match heads.iter_mut().find(|h| h.measurement == r.measurement) {
            Some(h) => *h = r, // readings are in id order: the newer one
            None => heads.push(r),
        }
    }
    heads
        .into_iter()
        .map(|head| {
            let mut chain = vec![head];
            let mut cur = head;
            while let Some(prev) = detail.readings.iter().rev().find(|p| {
                p.superseded_by == Some(cur.id)
                    && p.withdrawn_at_ms.is_none()
                    && !chain.iter().any(|c| c.id == p.id)
            }) {
                chain.push(prev);
                cur = prev;
            }
            chain.reverse();
            (head.measurement.clone(), chain)
        })
        .collect()
}

/// A technical error of measurement (ISO 20685-1, two readings per
/// subject) over `pairs` pairs.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Tem {
    /// Pairs it is computed over.
    pub pairs: usize,
    /// `sqrt(sum(d_i^2) / 2n)`, millimetres.
    pub tem_mm: f64,
    /// Mean of the paired readings, millimetres.
    pub mean_mm: f64,
    /// `TEM / mean * 100`, per cent.
    pub relative_percent: f64,
}

/// The TEM of `pairs` (tenths of a mm), or `None` for no pairs.
pub fn tem(pairs: &[(u32, u32)]) -> Option<Tem> {
    if pairs.is_empty() {
        return None;
    }
    let n = pairs.len() as f64;
    let mm = |v: u32| f64::from(v) / 10.0;
    let sum_d2: f64 = pairs.iter().map(|&(a, b)| (mm(a) - mm(b)).powi(2)).sum();
    let mean_mm = pairs.iter().map(|&(a, b)| mm(a) + mm(b)).sum::<f64>() / (2.0 * n);
    let tem_mm = (sum_d2 / (2.0 * n)).sqrt();
    Some(Tem {
        pairs: pairs.len(),
        tem_mm,
        mean_mm,
        relative_percent: if mean_mm > 0.0 {
            tem_mm / mean_mm * 100.0
        } else {
            0.0
        },
    })
}

/// One measurement of a careful session, as the report states it.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct MeasurementTem {
    /// Measurement name.
    pub name: String,
    /// Its allowable error, mm (`None`: the set does not know it).
    pub allowed_mm: Option<f64>,
    /// Its readings, round by round, mm, in the order taken.
    pub rounds_mm: Vec<Vec<f64>>,
    /// The value kept (the median of the last finished round), mm.
    pub kept_mm: Option<f64>,
    /// The reading the open round waits for (`2`: the second; `3`: a
    /// third, the first two being apart), if it waits for one.
    pub waiting_for: Option<usize>,
    /// Its TEM over its pairs (one per round with two readings).
    pub tem: Option<Tem>,
}

/// The careful part of a session's report: each measurement's readings,
/// kept value and TEM, and the session's TEM over all pairs.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct CarefulReport {
    /// What the numbers are.
    pub method: String,
    /// Per measurement, in the order their readings were taken.
    pub measurements: Vec<MeasurementTem>,
    /// The session's TEM over every measurement's pairs.
    pub session_tem: Option<Tem>,
}

/// The careful report of `detail`, with `allowed(name)` the allowable
/// error of a measurement in tenths of a mm.
pub fn report(detail: &SessionDetail, allowed: impl Fn(&str) -> Option<u32>) -> CarefulReport {
    let mm = |v: u32| f64::from(v) / 10.0;
    let mut all_pairs = Vec::new();
    let measurements = chains(detail)
        .into_iter()
        .map(|(name, chain)| {
            let allowed = allowed(&name);
            let values: Vec<u32> = chain.iter().map(|r| r.value_tenth_mm).collect();
            let rs = rounds(&values, allowed);
            let pairs: Vec<(u32, u32)> = rs.iter().filter_map(Round::pair).collect();
            all_pairs.extend_from_slice(&pairs);
            MeasurementTem {
                allowed_mm: allowed.map(mm),
                rounds_mm: rs
                    .iter()
                    .map(|r| r.readings.iter().map(|&v| mm(v)).collect())
                    .collect(),
                kept_mm: kept(&values, allowed).map(mm),
                waiting_for: rs.last().and_then(Round::next_reading),
                tem: tem(&pairs),
                name,
            }
        })
        .collect();
    CarefulReport {
        method: "ISO 20685-1 careful mode: each measurement taken twice, a third time when the \
                 two differ by more than its allowable error; kept: the median (of two: their \
                 mean); TEM = sqrt(sum(d^2) / 2n) over the first two readings of each round, \
                 relative TEM = TEM / mean * 100 %"
            .into(),
        measurements,
        session_tem: tem(&all_pairs),
    }
}

/// What each reading of careful session `detail` was, for its reading
/// table (`tapeshape session show`): `careful round R, reading K of N`, and
/// on the reading that finished a round `, kept V mm` (the round's median).
/// A repeat supersedes the reading before it as a retake does; this says
/// which it was. `allowed(name)`: the allowable error in tenths of a mm.
/// Withdrawn readings are in no chain and get no note.
pub fn reading_notes(
    detail: &SessionDetail,
    allowed: impl Fn(&str) -> Option<u32>,
) -> Vec<(ReadingId, String)> {
    let mut out = Vec::new();
    for (name, chain) in chains(detail) {
        let allowed = allowed(&name);
        let mut round: Option<Round> = None;
        let mut number = 0;
        for r in chain {
            let open = match round.take() {
                Some(open) if !open.complete() => open,
                _ => {
                    number += 1;
                    Round {
                        readings: Vec::new(),
                        allowed,
                    }
                }
            };
            let mut open = open;
            open.readings.push(r.value_tenth_mm);
            // How many this round takes, as far as its readings tell.
            let of = open.needed().max(open.readings.len());
            let mut note = format!(
                "careful round {number}, reading {} of {of}",
                open.readings.len()
            );
            if let Some(kept) = open.kept() {
                note.push_str(&format!(", kept {:.1} mm", f64::from(kept) / 10.0));
            }
            out.push((r.id, note));
            round = Some(open);
        }
    }
    out
}

/// The report as text lines (`tapeshape session show`, the result screen):
/// the session's TEM, then one line per measurement.
pub fn lines(report: &CarefulReport) -> Vec<String> {
    let tem_text = |t: &Tem| {
        format!(
            "TEM {:.1} mm ({:.2} %) over {} pair{}",
            t.tem_mm,
            t.relative_percent,
            t.pairs,
            if t.pairs == 1 { "" } else { "s" }
        )
    };
    let mut out = vec![match &report.session_tem {
        Some(t) => format!("careful mode: session {}", tem_text(t)),
        None => "careful mode: no measurement taken twice yet".to_string(),
    }];
    for m in &report.measurements {
        let rounds: Vec<String> = m
            .rounds_mm
            .iter()
            .map(|r| {
                r.iter()
                    .map(|v| format!("{v:.1}"))
                    .collect::<Vec<_>>()
                    .join(" / ")
            })
            .collect();
        let kept = m
            .kept_mm
            .map_or("none yet".to_string(), |k| format!("{k:.1} mm"));
        let mut line = format!(
            "  {:<28} kept {kept:<10} readings {} mm",
            m.name,
            rounds.join("; ")
        );
        if let Some(t) = &m.tem {
            line.push_str(&format!("  {}", tem_text(t)));
        }
        if let Some(n) = m.waiting_for {
            line.push_str(&format!("  (waits for reading {n})"));
        }
        out.push(line);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_median_of_two_is_their_mean_and_of_three_the_middle_one() {
        assert_eq!(median(&[]), None);
        assert_eq!(median(&[9_820]), Some(9_820));
        assert_eq!(median(&[9_820, 9_840]), Some(9_830));
        // 982.0 and 982.3 mm: mean 982.15, a half rounded up.
        assert_eq!(median(&[9_823, 9_820]), Some(9_822));
        assert_eq!(median(&[9_900, 9_820, 9_840]), Some(9_840));
    }

    #[test]
    fn rounds_take_two_readings_or_three_when_the_first_two_are_apart() {
        // Allowed 5 mm: 3 mm apart is one round of two; 7 mm apart needs a third.
        let r = rounds(&[4_000, 4_030], Some(50));
        assert_eq!(r.len(), 1);
        assert!(r[0].complete());
        assert_eq!(r[0].kept(), Some(4_015));
        let r = rounds(&[4_000, 4_070], Some(50));
        assert_eq!(r[0].next_reading(), Some(3));
        assert_eq!(r[0].kept(), None);
        // Exactly at the allowed difference still agrees.
        assert!(rounds(&[4_000, 4_050], Some(50))[0].complete());
        // The third reading closes it; a fourth starts a new round.
        let r = rounds(&[4_000, 4_070, 4_020, 4_100], Some(50));
        assert_eq!(r.len(), 2);
        assert_eq!(r[0].kept(), Some(4_020));
        assert_eq!(r[1].next_reading(), Some(2));
        // The kept value stays the finished round's while the new one is open.
        assert_eq!(kept(&[4_000, 4_070, 4_020, 4_100], Some(50)), Some(4_020));
        assert_eq!(
            open_round(&[4_000, 4_030], Some(50)).readings,
            Vec::<u32>::new()
        );
        // No allowable error: every reading is a round of its own.
        assert_eq!(kept(&[4_000, 4_100], None), Some(4_100));
    }

    #[test]
    fn tem_of_pairs_against_the_formula_by_hand() {
        // d = 2, 4, 0 mm: sum d^2 = 20, n = 3: TEM = sqrt(20 / 6) = 1.8257 mm;
        // mean of the six readings = (100+102+200+196+300+300) / 6 = 199.667 mm.
        let t = tem(&[(1_000, 1_020), (2_000, 1_960), (3_000, 3_000)]).unwrap();
        assert_eq!(t.pairs, 3);
        assert!((t.tem_mm - (20.0f64 / 6.0).sqrt()).abs() < 1e-12, "{t:?}");
        assert!((t.mean_mm - 1198.0 / 6.0).abs() < 1e-9, "{t:?}");
        assert!(
            (t.relative_percent - (20.0f64 / 6.0).sqrt() / (1198.0 / 6.0) * 100.0).abs() < 1e-9
        );
        assert_eq!(tem(&[]), None);
    }
}

#[cfg(test)]
mod session_tests;
