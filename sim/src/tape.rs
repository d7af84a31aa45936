//! A simulated RENPHO-style tape measure, driven by a script.
//!
//! Why a script: a test must know exactly which readings the operator confirmed, in which
//! order, so it can check the store against them; and it must be able to replay a realistic
//! measuring rhythm (pull the tape out, let the live value settle, press hold) much faster than
//! real time. A [`Script`] is a list of [`Step`]s; [`Script::timeline`] turns it into the tape's
//! line output with timestamps; [`play`] writes that output to a port at a chosen speed.
//!
//! The tape's line (see `docs/tape-format.md`) is 20 ASCII bytes, `*DDDDD;00000;0000KU\n`:
//! `DDDDD` the length in hundredths of a centimetre (= tenths of a millimetre), `K` = `P` for a
//! live value or `S` for a confirmed (held) one, `U` = `M` or `I` for the unit on the tape's
//! display. The all-zero live line is the tape's heartbeat. Lines are formatted by the
//! firmware crate's own formatter ([`tapeshape_firmware::tape::format_line`]) so the simulator
//! and the parser cannot drift apart.

use std::time::Duration;

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use tokio::io::{AsyncWrite, AsyncWriteExt};
use tokio::time::Instant;

pub use tapeshape_firmware::tape::ValueTooWide;
use tapeshape_firmware::tape::{format_line, Kind};
pub use tapeshape_protocol::UnitShown;

/// Largest value the tape line can carry (five digits of hundredths of a centimetre).
pub const MAX_LINE_VALUE_TENTH_MM: u32 = 99_999;

/// The heartbeat line: what the tape sends while idle.
pub const HEARTBEAT: TapeLine = TapeLine {
    value_tenth_mm: 0,
    confirmed: false,
    unit: UnitShown::Metric,
};

/// One line of tape output, before formatting.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct TapeLine {
    /// Length, tenths of a millimetre (0..=99_999).
    pub value_tenth_mm: u32,
    /// `true` for a confirmed (held) value, `false` for a live one.
    pub confirmed: bool,
    /// Unit on the tape's display.
    pub unit: UnitShown,
}

impl TapeLine {
    /// The 20 bytes the tape sends for this line, newline included. Fails for a value wider
    /// than the line's five digits.
    pub fn to_bytes(&self) -> Result<Vec<u8>, ValueTooWide> {
        let kind = if self.confirmed {
            Kind::Confirmed
        } else {
            Kind::Live
        };
        format_line(self.value_tenth_mm, kind, self.unit).map(|l| l.to_vec())
    }
}

/// One step of a tape script.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Step {
    /// Pull (or retract) the tape from its current length to `to_tenth_mm` over `over`,
    /// sending live lines every [`TapeTiming::live_interval`] on the way.
    Pull {
        /// Target length, tenths of a millimetre.
        to_tenth_mm: u32,
        /// How long the pull takes (script time).
        over: Duration,
    },
    /// Press the tape's hold button: send the current length as a confirmed line.
    Hold,
    /// Leave the tape alone for this long: heartbeat lines only.
    Pause(Duration),
    /// Switch the tape's display unit.
    Unit(UnitShown),
    /// Send these raw bytes as they are (a garbage or corrupted line written by the script).
    Raw(Vec<u8>),
}

/// Line timing of the simulated tape (script time; [`play`] can compress it).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct TapeTiming {
    /// Interval between live lines while the tape moves.
    pub live_interval: Duration,
    /// Interval between heartbeats while the tape is idle.
    pub heartbeat_interval: Duration,
}

impl Default for TapeTiming {
    /// Roughly what a RENPHO-style tape does: 10 live lines a second, a heartbeat a second.
    fn default() -> Self {
        Self {
            live_interval: Duration::from_millis(100),
            heartbeat_interval: Duration::from_secs(1),
        }
    }
}

/// What the tape sends at one moment.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct TimedOutput {
    /// Script time since the start.
    pub at: Duration,
    /// The bytes.
    pub bytes: Vec<u8>,
    /// If this is a confirmed line: its index among the script's confirmations (0, 1, ...)
    /// and its value, tenths of a millimetre.
    pub confirmation: Option<(usize, u32)>,
}

/// A tape script: the steps, from a tape at length 0 showing centimetres.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct Script {
    /// The steps in order.
    pub steps: Vec<Step>,
}

/// Errors in a script.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum ScriptError {
    /// A pull to a length the tape cannot show.
    #[error(
        "step {step}: pull to {value} tenths of a mm, beyond the tape line's 5 digits \
         (at most {MAX_LINE_VALUE_TENTH_MM}); use a shorter length"
    )]
    OutOfRange {
        /// Step index.
        step: usize,
        /// The value.
        value: u32,
    },
    /// A hold at length 0 (the tape refuses to confirm nothing).
    #[error("step {step}: hold at length 0; pull the tape out before holding")]
    HoldAtZero {
        /// Step index.
        step: usize,
    },
}

impl Script {
    /// A measuring session of `n` confirmed readings with values drawn from `range`
    /// (tenths of a millimetre), seeded. Each reading: a pull over `pull` with live lines,
    /// then a hold. Consecutive readings always differ by at least 1 mm, so none can be
    /// mistaken for a repeated confirmation of the previous one.
    pub fn session(n: usize, seed: u64, range: std::ops::Range<u32>, pull: Duration) -> Self {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let mut steps = Vec::with_capacity(2 * n);
        let mut last = 0u32;
        for _ in 0..n {
            let v = loop {
                let v = rng.random_range(range.clone());
                if v.abs_diff(last) >= 10 {
                    break v;
                }
            };
            last = v;
            steps.push(Step::Pull {
                to_tenth_mm: v,
                over: pull,
            });
            steps.push(Step::Hold);
        }
        Self { steps }
    }

    /// The confirmed values in order (tenths of a millimetre).
    pub fn confirmed_values(&self) -> Vec<u32> {
        let mut cur = 0;
        let mut out = Vec::new();
        for s in &self.steps {
            match s {
                Step::Pull { to_tenth_mm, .. } => cur = *to_tenth_mm,
                Step::Hold => out.push(cur),
                _ => {}
            }
        }
        out
    }

    /// The tape's output for this script, in time order.
    pub fn timeline(&self, timing: TapeTiming) -> Result<Vec<TimedOutput>, ScriptError> {
        let live = timing.live_interval.max(Duration::from_micros(1));
        let hb = timing.heartbeat_interval.max(Duration::from_micros(1));
        let mut out = Vec::new();
        let mut t = Duration::ZERO;
        let mut cur = 0u32;
        let mut unit = UnitShown::Metric;
        let mut confirmations = 0usize;
        let line = |v: u32, confirmed: bool, unit: UnitShown| {
            TapeLine {
                value_tenth_mm: v,
                confirmed,
                unit,
            }
            .to_bytes()
            .map_err(|e| ScriptError::OutOfRange {
                step: 0,
                value: e.0,
            })
        };
        let heartbeat = line(0, false, UnitShown::Metric)?;
        for (i, step) in self.steps.iter().enumerate() {
            match step {
                Step::Pull { to_tenth_mm, over } => {
                    let to = *to_tenth_mm;
                    if to > MAX_LINE_VALUE_TENTH_MM {
                        return Err(ScriptError::OutOfRange { step: i, value: to });
                    }
                    let n = (over.as_nanos() / live.as_nanos()).max(1) as u64;
                    for k in 1..=n {
                        let v = cur as i64 + (to as i64 - cur as i64) * k as i64 / n as i64;
                        t += live;
                        out.push(TimedOutput {
                            at: t,
                            bytes: line(v as u32, false, unit)?,
                            confirmation: None,
                        });
                    }
                    cur = to;
                }
                Step::Hold => {
                    if cur == 0 {
                        return Err(ScriptError::HoldAtZero { step: i });
                    }
                    t += live;
                    out.push(TimedOutput {
                        at: t,
                        bytes: line(cur, true, unit)?,
                        confirmation: Some((confirmations, cur)),
                    });
                    confirmations += 1;
                }
                Step::Pause(d) => {
                    let end = t + *d;
                    while t + hb <= end {
                        t += hb;
                        out.push(TimedOutput {
                            at: t,
                            bytes: heartbeat.clone(),
                            confirmation: None,
                        });
                    }
                    t = end;
                }
                Step::Unit(u) => unit = *u,
                Step::Raw(bytes) => out.push(TimedOutput {
                    at: t,
                    bytes: bytes.clone(),
                    confirmation: None,
                }),
            }
        }
        Ok(out)
    }
}

/// Something [`play`] reports as it goes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Confirmed {
    /// Index among the script's confirmations.
    pub index: usize,
    /// The confirmed value, tenths of a millimetre.
    pub value_tenth_mm: u32,
    /// When its last byte was handed to the port.
    pub written_at: Instant,
}

/// Writes a timeline to `port`, dividing every script time by `speedup` (1.0 = real time).
/// Calls `on_confirm` right after each confirmed line has been written. Returns the number of
/// bytes written.
pub async fn play<W: AsyncWrite + Unpin>(
    timeline: &[TimedOutput],
    speedup: f64,
    port: &mut W,
    mut on_confirm: impl FnMut(Confirmed),
) -> std::io::Result<u64> {
    let start = Instant::now();
    let speedup = if speedup.is_finite() && speedup > 0.0 {
        speedup
    } else {
        1.0
    };
    let mut written = 0u64;
    for out in timeline {
        let due = start + out.at.div_f64(speedup);
        tokio::time::sleep_until(due).await;
        port.write_all(&out.bytes).await?;
        written += out.bytes.len() as u64;
        if let Some((index, value_tenth_mm)) = out.confirmation {
            on_confirm(Confirmed {
                index,
                value_tenth_mm,
                written_at: Instant::now(),
            });
        }
    }
    port.flush().await?;
    Ok(written)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn line_bytes_match_the_documented_layout() {
        let l = TapeLine {
            value_tenth_mm: 8520,
            confirmed: true,
            unit: UnitShown::Metric,
        };
        assert_eq!(l.to_bytes().unwrap(), b"*08520;00000;0000SM\n");
        let l = TapeLine {
            value_tenth_mm: 12,
            confirmed: false,
            unit: UnitShown::Imperial,
        };
        assert_eq!(l.to_bytes().unwrap(), b"*00012;00000;0000PI\n");
        assert_eq!(HEARTBEAT.to_bytes().unwrap(), b"*00000;00000;0000PM\n");
        let wide = TapeLine {
            value_tenth_mm: 100_000,
            ..l
        };
        assert!(wide.to_bytes().is_err());
    }

    #[test]
    fn session_confirms_the_values_it_lists() {
        let s = Script::session(50, 9, 2000..15000, Duration::from_millis(300));
        let values = s.confirmed_values();
        assert_eq!(values.len(), 50);
        assert!(values.windows(2).all(|w| w[0].abs_diff(w[1]) >= 10));
        let tl = s.timeline(TapeTiming::default()).unwrap();
        let confirmed: Vec<_> = tl.iter().filter_map(|o| o.confirmation).collect();
        assert_eq!(
            confirmed,
            values.iter().copied().enumerate().collect::<Vec<_>>()
        );
        for o in &tl {
            assert_eq!(o.bytes.len(), 20);
            let held = o.bytes[17] == b'S';
            assert_eq!(held, o.confirmation.is_some());
        }
        assert!(tl.windows(2).all(|w| w[0].at <= w[1].at));
    }

    #[test]
    fn pull_is_monotone_and_ends_on_target() {
        let s = Script {
            steps: vec![Step::Pull {
                to_tenth_mm: 1000,
                over: Duration::from_millis(500),
            }],
        };
        let tl = s.timeline(TapeTiming::default()).unwrap();
        assert_eq!(tl.len(), 5);
        let vals: Vec<u32> = tl
            .iter()
            .map(|o| {
                std::str::from_utf8(&o.bytes[1..6])
                    .unwrap()
                    .parse()
                    .unwrap()
            })
            .collect();
        assert_eq!(vals, vec![200, 400, 600, 800, 1000]);
    }

    #[test]
    fn pause_sends_heartbeats_and_bad_scripts_are_refused() {
        let s = Script {
            steps: vec![Step::Pause(Duration::from_millis(3500))],
        };
        let tl = s.timeline(TapeTiming::default()).unwrap();
        assert_eq!(tl.len(), 3);
        assert!(tl.iter().all(|o| o.bytes == HEARTBEAT.to_bytes().unwrap()));
        let bad = Script {
            steps: vec![Step::Hold],
        };
        assert_eq!(
            bad.timeline(TapeTiming::default()),
            Err(ScriptError::HoldAtZero { step: 0 })
        );
        let bad = Script {
            steps: vec![Step::Pull {
                to_tenth_mm: 100_000,
                over: Duration::ZERO,
            }],
        };
        assert!(matches!(
            bad.timeline(TapeTiming::default()),
            Err(ScriptError::OutOfRange { .. })
        ));
    }

    #[tokio::test]
    async fn play_writes_everything_and_reports_confirmations() {
        let s = Script::session(5, 1, 2000..3000, Duration::from_millis(200));
        let tl = s.timeline(TapeTiming::default()).unwrap();
        let mut buf = Vec::new();
        let mut seen = Vec::new();
        let n = play(&tl, 1000.0, &mut buf, |c| {
            seen.push((c.index, c.value_tenth_mm))
        })
        .await
        .unwrap();
        assert_eq!(n as usize, buf.len());
        assert_eq!(buf.len(), tl.len() * 20);
        assert_eq!(
            seen,
            s.confirmed_values()
                .into_iter()
                .enumerate()
                .collect::<Vec<_>>()
        );
    }
}
