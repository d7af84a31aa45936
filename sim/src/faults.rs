//! Fault plans: what goes wrong on a byte stream, deterministic from a seed.
//!
//! Why a seeded plan instead of ad-hoc randomness in each test: when an end-to-end run fails,
//! the same seed replays the same flipped bits, dropped bytes and unplugs, so the failure can
//! be reproduced and debugged. ChaCha8 (`rand_chacha`) is portable: the same seed gives the
//! same faults on every machine and every build.
//!
//! A [`FaultPlan`] says *how often* each fault happens; a [`FaultInjector`] applies it to the
//! bytes that pass through it, chunk by chunk, and keeps [`FaultStats`] of what it did, so a
//! test can check that the faults really happened (a fault test whose faults never fire would
//! prove nothing).
//!
//! Byte faults (flipped bits, dropped and duplicated bytes) hit any byte. Line faults (garbage
//! lines) are inserted only right after a `\n`, which is where a tape line can start. Events
//! that the *driver* must carry out (a silence, an unplug) come out of
//! [`FaultInjector::process`] as [`Segment::Event`] in stream order; see [`FaultEvent`].

use std::time::Duration;

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// Something the driver of the stream must do at a point in the stream.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FaultEvent {
    /// Send nothing for this long.
    Silence(Duration),
    /// Unplug the receiving side, wait this long, plug it in again.
    Unplug {
        /// How long the port stays unplugged.
        down: Duration,
    },
}

/// A fault event placed at a byte offset of the *input* stream: it happens just before the
/// input byte with that index is processed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ScheduledEvent {
    /// Index of the input byte before which the event happens.
    pub at_byte: u64,
    /// What happens.
    pub event: FaultEvent,
}

/// How often each fault happens. All rates are probabilities in `[0, 1]`.
#[derive(Debug, Clone, PartialEq)]
pub struct FaultPlan {
    /// Seed of the random choices.
    pub seed: u64,
    /// Per input byte: probability that one of its bits (chosen at random) is flipped.
    pub bit_flip_rate: f64,
    /// Per input byte: probability that it is dropped.
    pub drop_rate: f64,
    /// Per input byte: probability that it is sent twice.
    pub duplicate_rate: f64,
    /// Per `\n` in the input: probability that a garbage line is inserted after it.
    pub garbage_line_rate: f64,
    /// Events at fixed points of the input stream, in any order.
    pub events: Vec<ScheduledEvent>,
}

/// Errors in a fault plan.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum FaultPlanError {
    /// A rate outside `[0, 1]` (or NaN).
    #[error("fault rate `{name}` is {value}; a rate is a probability and must lie in [0, 1]")]
    BadRate {
        /// Which rate.
        name: &'static str,
        /// Its value.
        value: f64,
    },
    /// The byte fault rates add up to more than 1.
    #[error(
        "byte fault rates add up to {sum} (bit flips + drops + duplicates); \
         each byte gets at most one fault, so the sum must be at most 1"
    )]
    RatesOverOne {
        /// The sum.
        sum: f64,
    },
}

impl FaultPlan {
    /// A plan with no faults.
    pub fn clean(seed: u64) -> Self {
        Self {
            seed,
            bit_flip_rate: 0.0,
            drop_rate: 0.0,
            duplicate_rate: 0.0,
            garbage_line_rate: 0.0,
            events: Vec::new(),
        }
    }

    /// A plan that corrupts a fraction `rate` of the bytes: 60 % of the corrupted bytes get a
    /// flipped bit, 20 % are dropped and 20 % are duplicated.
    pub fn corrupt_bytes(seed: u64, rate: f64) -> Self {
        Self {
            bit_flip_rate: rate * 0.6,
            drop_rate: rate * 0.2,
            duplicate_rate: rate * 0.2,
            ..Self::clean(seed)
        }
    }

    /// Checks that every rate is a probability and that the byte fault rates sum to at most 1.
    pub fn validate(&self) -> Result<(), FaultPlanError> {
        for (name, value) in [
            ("bit_flip_rate", self.bit_flip_rate),
            ("drop_rate", self.drop_rate),
            ("duplicate_rate", self.duplicate_rate),
            ("garbage_line_rate", self.garbage_line_rate),
        ] {
            if !(0.0..=1.0).contains(&value) {
                return Err(FaultPlanError::BadRate { name, value });
            }
        }
        let sum = self.bit_flip_rate + self.drop_rate + self.duplicate_rate;
        if sum > 1.0 + 1e-12 {
            return Err(FaultPlanError::RatesOverOne { sum });
        }
        Ok(())
    }
}

/// Counts of the faults an injector has applied.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct FaultStats {
    /// Input bytes processed.
    pub bytes_in: u64,
    /// Bytes emitted (input bytes kept, duplicates and garbage included).
    pub bytes_out: u64,
    /// Bytes with a flipped bit.
    pub bits_flipped: u64,
    /// Bytes dropped.
    pub bytes_dropped: u64,
    /// Bytes sent twice.
    pub bytes_duplicated: u64,
    /// Garbage lines inserted.
    pub garbage_lines: u64,
    /// Events emitted.
    pub events: u64,
}

impl FaultStats {
    /// Input bytes that were corrupted (flipped, dropped or duplicated).
    pub fn bytes_corrupted(&self) -> u64 {
        self.bits_flipped + self.bytes_dropped + self.bytes_duplicated
    }
}

/// A piece of the faulty output stream.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Segment {
    /// Bytes to send.
    Bytes(Vec<u8>),
    /// An event to carry out before sending what follows.
    Event(FaultEvent),
}

/// Applies a [`FaultPlan`] to a byte stream.
#[derive(Debug)]
pub struct FaultInjector {
    plan: FaultPlan,
    rng: ChaCha8Rng,
    pos: u64,
    next_event: usize,
    stats: FaultStats,
}

/// Garbage line shapes: what a confused tape, a loose connector or line noise produces.
fn garbage_line(rng: &mut ChaCha8Rng) -> Vec<u8> {
    let kind = rng.random_range(0..6u32);
    let mut line: Vec<u8> = match kind {
        // Printable noise.
        0 => (0..rng.random_range(1..40usize))
            .map(|_| rng.random_range(0x21..0x7fu8))
            .collect(),
        // Binary noise without newlines.
        1 => (0..rng.random_range(1..30usize))
            .map(|_| loop {
                let b: u8 = rng.random();
                if b != b'\n' {
                    break b;
                }
            })
            .collect(),
        // A truncated tape line.
        2 => b"*01234;00000;00"[..rng.random_range(1..15usize)].to_vec(),
        // An overlong tape line.
        3 => b"*012345;00000;0000SM9".to_vec(),
        // A tape line with a letter in a digit field.
        4 => b"*01A34;00000;0000SM".to_vec(),
        // A tape line with an unknown flag.
        _ => b"*01234;00000;0000XM".to_vec(),
    };
    line.push(b'\n');
    line
}

impl FaultInjector {
    /// Creates an injector. Fails if the plan is invalid.
    pub fn new(plan: FaultPlan) -> Result<Self, FaultPlanError> {
        plan.validate()?;
        let mut plan = plan;
        plan.events.sort_by_key(|e| e.at_byte);
        Ok(Self {
            rng: ChaCha8Rng::seed_from_u64(plan.seed),
            plan,
            pos: 0,
            next_event: 0,
            stats: FaultStats::default(),
        })
    }

    /// What the injector has done so far.
    pub fn stats(&self) -> FaultStats {
        self.stats
    }

    /// The plan.
    pub fn plan(&self) -> &FaultPlan {
        &self.plan
    }

    /// Processes the next chunk of the input stream, returning the faulty output in order.
    /// Byte segments are never empty.
    pub fn process(&mut self, input: &[u8]) -> Vec<Segment> {
        let mut out = Vec::new();
        let mut bytes = Vec::with_capacity(input.len() + 8);
        let p = self.plan.bit_flip_rate;
        let d = p + self.plan.drop_rate;
        let u = d + self.plan.duplicate_rate;
        for &b in input {
            while let Some(ev) = self.plan.events.get(self.next_event) {
                if ev.at_byte > self.pos {
                    break;
                }
                if !bytes.is_empty() {
                    out.push(Segment::Bytes(std::mem::take(&mut bytes)));
                }
                out.push(Segment::Event(ev.event));
                self.stats.events += 1;
                self.next_event += 1;
            }
            self.pos += 1;
            self.stats.bytes_in += 1;
            let x: f64 = if u > 0.0 { self.rng.random() } else { 1.0 };
            if x < p {
                let bit = self.rng.random_range(0..8u32);
                bytes.push(b ^ (1 << bit));
                self.stats.bits_flipped += 1;
            } else if x < d {
                self.stats.bytes_dropped += 1;
            } else if x < u {
                bytes.push(b);
                bytes.push(b);
                self.stats.bytes_duplicated += 1;
            } else {
                bytes.push(b);
            }
            if b == b'\n'
                && self.plan.garbage_line_rate > 0.0
                && self.rng.random::<f64>() < self.plan.garbage_line_rate
            {
                bytes.extend(garbage_line(&mut self.rng));
                self.stats.garbage_lines += 1;
            }
        }
        self.stats.bytes_out += bytes.len() as u64;
        if !bytes.is_empty() {
            out.push(Segment::Bytes(bytes));
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn flatten(segs: &[Segment]) -> Vec<u8> {
        segs.iter()
            .flat_map(|s| match s {
                Segment::Bytes(b) => b.clone(),
                Segment::Event(_) => Vec::new(),
            })
            .collect()
    }

    #[test]
    fn clean_plan_is_identity() {
        let mut inj = FaultInjector::new(FaultPlan::clean(1)).unwrap();
        let input: Vec<u8> = (0..10_000u32).map(|i| (i * 7) as u8).collect();
        let out = flatten(&inj.process(&input));
        assert_eq!(out, input);
        assert_eq!(inj.stats().bytes_corrupted(), 0);
    }

    /// The same seed gives the same faults whatever the chunking; another seed differs.
    #[test]
    fn deterministic_from_seed_and_chunking_independent() {
        let input: Vec<u8> = (0..50_000u32).map(|i| (i % 251) as u8).collect();
        let plan = FaultPlan::corrupt_bytes(42, 0.05);
        let mut a = FaultInjector::new(plan.clone()).unwrap();
        let whole = flatten(&a.process(&input));
        let mut b = FaultInjector::new(plan).unwrap();
        let mut chunked = Vec::new();
        for c in input.chunks(97) {
            chunked.extend(flatten(&b.process(c)));
        }
        assert_eq!(whole, chunked);
        assert_eq!(a.stats(), b.stats());
        let mut c = FaultInjector::new(FaultPlan::corrupt_bytes(43, 0.05)).unwrap();
        assert_ne!(flatten(&c.process(&input)), whole);
    }

    /// The observed corruption rate is close to the plan's (binomial: 1 % of 200,000 bytes
    /// is 2,000 +- 45 at one sigma; allow 5 sigma), and the output length accounts exactly
    /// for drops and duplicates.
    #[test]
    fn rate_and_length_accounting() {
        let input = vec![0x55u8; 200_000];
        let mut inj = FaultInjector::new(FaultPlan::corrupt_bytes(7, 0.01)).unwrap();
        let out = flatten(&inj.process(&input));
        let s = inj.stats();
        assert!((s.bytes_corrupted() as i64 - 2000).abs() < 225, "{s:?}");
        assert_eq!(
            out.len() as u64,
            s.bytes_in - s.bytes_dropped + s.bytes_duplicated
        );
        let changed = out.iter().filter(|&&b| b != 0x55).count() as u64;
        assert_eq!(
            changed, s.bits_flipped,
            "each flip changes exactly one byte"
        );
        for &b in out.iter().filter(|&&b| b != 0x55) {
            assert_eq!((b ^ 0x55).count_ones(), 1, "exactly one bit flipped");
        }
    }

    #[test]
    fn events_come_out_at_their_byte_offsets() {
        let mut plan = FaultPlan::clean(0);
        plan.events = vec![
            ScheduledEvent {
                at_byte: 10,
                event: FaultEvent::Unplug {
                    down: Duration::from_millis(5),
                },
            },
            ScheduledEvent {
                at_byte: 3,
                event: FaultEvent::Silence(Duration::from_millis(1)),
            },
        ];
        let mut inj = FaultInjector::new(plan).unwrap();
        let input: Vec<u8> = (0..20).collect();
        let mut segs = inj.process(&input[..7]);
        segs.extend(inj.process(&input[7..]));
        assert_eq!(
            segs,
            vec![
                Segment::Bytes((0..3).collect()),
                Segment::Event(FaultEvent::Silence(Duration::from_millis(1))),
                Segment::Bytes((3..7).collect()),
                Segment::Bytes((7..10).collect()),
                Segment::Event(FaultEvent::Unplug {
                    down: Duration::from_millis(5)
                }),
                Segment::Bytes((10..20).collect()),
            ]
        );
    }

    /// Garbage lines follow a newline and end with one, so they never split a real line.
    #[test]
    fn garbage_lines_only_between_lines() {
        let line = b"*01234;00000;0000SM\n";
        let input: Vec<u8> = line
            .iter()
            .copied()
            .cycle()
            .take(line.len() * 500)
            .collect();
        let mut plan = FaultPlan::clean(3);
        plan.garbage_line_rate = 0.3;
        let mut inj = FaultInjector::new(plan).unwrap();
        let out = flatten(&inj.process(&input));
        let lines: Vec<&[u8]> = out.split(|&b| b == b'\n').collect();
        let good = lines.iter().filter(|l| **l == &line[..19]).count();
        assert_eq!(good, 500, "every real line survives intact");
        assert!(inj.stats().garbage_lines > 100);
        assert_eq!(lines.len() as u64 - 1, 500 + inj.stats().garbage_lines);
    }

    #[test]
    fn bad_rates_are_refused() {
        let mut p = FaultPlan::clean(0);
        p.drop_rate = 1.5;
        assert!(matches!(
            FaultInjector::new(p).unwrap_err(),
            FaultPlanError::BadRate { .. }
        ));
        let mut p = FaultPlan::clean(0);
        p.drop_rate = 0.6;
        p.bit_flip_rate = 0.6;
        assert!(matches!(
            FaultInjector::new(p).unwrap_err(),
            FaultPlanError::RatesOverOne { .. }
        ));
        let mut p = FaultPlan::clean(0);
        p.garbage_line_rate = f64::NAN;
        assert!(FaultInjector::new(p).is_err());
    }
}
