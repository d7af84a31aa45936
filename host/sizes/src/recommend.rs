//! The recommendation: for each garment of a chart, the best size, how
//! each dimension sits in it, whether the customer is between two sizes,
//! and how likely each size is.
//!
//! Readings ([`Readings`]) are the customer's dimensions in mm, each with
//! where it came from ([`Source`]): `Measured` (the operator's tape) or
//! `Estimated` (read off the estimated body). Both carry a standard
//! deviation: for a measured reading the caller passes the ISO 20685-1
//! allowable error of the measurement's tolerance class (4 mm heights,
//! breadths and small girths, 5 mm segment lengths, 9 mm large girths),
//! taken as one SD. That is deliberately generous (the allowable error is
//! the largest acceptable difference, not a typical one), so a reading a
//! few millimetres from a size edge is reported as between sizes rather
//! than as a certain fit. An estimated reading carries the model's
//! conditional spread. An SD of 0 treats a reading as exact.
//!
//! The rules, all in [`recommend`]:
//!
//! * **Probability** of a size: the product over its primary dimensions of
//!   `P(lo ≤ X < hi)`, each dimension an independent normal
//!   `N(value, sd²)` ([`interval_probability`]). Independence of the
//!   readings' errors is an assumption (fair for separate tape readings,
//!   an approximation for dimensions estimated from one body, whose errors
//!   correlate), stated wherever the number is shown.
//!   Sizes of a validated chart are disjoint cells, so a garment's
//!   probabilities sum to at most 1 (less when part of the normal lies
//!   beyond the chart or in a missing cell).
//! * **Best size**: the highest probability; sizes within
//!   [`PROBABILITY_TIE`] of it are ordered by, in turn, whether the size
//!   holds every reading (lo included, hi not), the smallest total distance
//!   of the readings outside its intervals, the larger size (greater sum of
//!   interval centres: when in doubt, the looser garment), and chart order.
//!   The same order ranks the **runner-up**.
//! * **Between** two sizes (best and runner-up), with the reason: when no
//!   size holds every reading although each lies within the chart's range
//!   ([`BetweenReason::NoSizeHoldsAll`], "tight at the hip in 38, loose at
//!   the bust in 40"), or when the runner-up is at least [`BETWEEN_RATIO`]
//!   times as likely as the best ([`BetweenReason::NearEdge`]: the
//!   dimension whose reading is nearest, in SDs, to the edge of the best
//!   size facing the runner-up).
//! * **Beyond the chart**: a primary reading below the smallest or at or
//!   above the largest interval of its dimension ([`Beyond`]); the best
//!   size is then the nearest one.
//! * **Missing**: a dimension the garment uses that has no reading. A
//!   missing primary dimension leaves the garment without a size
//!   (`best: None`); nothing is skipped silently.
//!
//! Secondary dimensions never choose or weigh a size; the chosen size's
//! (and the runner-up's) placement lists them after the primary ones.

use std::collections::BTreeMap;

use serde::Serialize;

use crate::chart::{Chart, DimensionKind, Garment, Interval, Role, Size};
use crate::error::ReadingError;
use crate::normal::interval_probability;
use crate::words::fit_words;

/// Probabilities closer than this count as equal when ranking sizes (so a
/// reading exactly on an edge between two equally wide sizes goes to the
/// size that holds it, the upper one, rather than to rounding).
pub const PROBABILITY_TIE: f64 = 1e-9;

/// The runner-up is reported as "between" when its probability is at
/// least this fraction of the best size's.
pub const BETWEEN_RATIO: f64 = 0.5;

/// Where a reading came from, with its standard deviation (mm).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
#[serde(tag = "source", rename_all = "snake_case")]
pub enum Source {
    /// Taken by the operator; `sd_mm` is the measurement's ISO 20685-1
    /// allowable error (module docs), 0 for exact.
    Measured {
        /// One standard deviation, mm.
        sd_mm: f64,
    },
    /// Read off the estimated body; `sd_mm` is the model's conditional
    /// spread given the measured readings.
    Estimated {
        /// One standard deviation, mm.
        sd_mm: f64,
    },
}

impl Source {
    /// The standard deviation, mm.
    pub fn sd_mm(self) -> f64 {
        match self {
            Source::Measured { sd_mm } | Source::Estimated { sd_mm } => sd_mm,
        }
    }

    /// `measured` or `estimated`.
    pub fn word(self) -> &'static str {
        match self {
            Source::Measured { .. } => "measured",
            Source::Estimated { .. } => "estimated",
        }
    }
}

/// One dimension of the customer: a value in mm and its source.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Reading {
    value_mm: f64,
    #[serde(flatten)]
    source: Source,
}

impl Reading {
    /// The value, mm.
    pub fn value_mm(&self) -> f64 {
        self.value_mm
    }

    /// Its source and SD.
    pub fn source(&self) -> Source {
        self.source
    }
}

/// The customer's readings by dimension name, each checked when added.
///
/// A measured reading takes precedence over an estimated one of the same
/// name whatever the order they are added in (the station adds what the
/// operator measured and the estimated body's value of every dimension).
#[derive(Debug, Clone, Default, PartialEq, Serialize)]
#[serde(transparent)]
pub struct Readings {
    by_name: BTreeMap<String, Reading>,
}

impl Readings {
    /// No readings.
    pub fn new() -> Self {
        Self::default()
    }

    /// Adds what the operator measured: `value_mm` with `sd_mm` (the ISO
    /// 20685-1 allowable error of its tolerance class, or 0 for exact).
    pub fn insert_measured(
        &mut self,
        name: &str,
        value_mm: f64,
        sd_mm: f64,
    ) -> Result<(), ReadingError> {
        self.insert(name, value_mm, Source::Measured { sd_mm })
    }

    /// Adds a dimension read off the estimated body, with the model's
    /// conditional SD; ignored when `name` was measured.
    pub fn insert_estimated(
        &mut self,
        name: &str,
        value_mm: f64,
        sd_mm: f64,
    ) -> Result<(), ReadingError> {
        self.insert(name, value_mm, Source::Estimated { sd_mm })
    }

    fn insert(&mut self, name: &str, value_mm: f64, source: Source) -> Result<(), ReadingError> {
        if !(value_mm.is_finite() && value_mm > 0.0) {
            return Err(ReadingError::Value {
                name: name.to_string(),
                value_mm,
            });
        }
        let sd_mm = source.sd_mm();
        if !(sd_mm.is_finite() && sd_mm >= 0.0) {
            return Err(ReadingError::Spread {
                name: name.to_string(),
                sd_mm,
            });
        }
        let reading = Reading { value_mm, source };
        match self.by_name.get(name).map(|r| r.source) {
            None => {}
            Some(old) if std::mem::discriminant(&old) == std::mem::discriminant(&source) => {
                return Err(ReadingError::Twice {
                    name: name.to_string(),
                    provenance: source.word(),
                })
            }
            Some(Source::Measured { .. }) => return Ok(()),
            Some(Source::Estimated { .. }) => {}
        }
        self.by_name.insert(name.to_string(), reading);
        Ok(())
    }

    /// The reading of `name`.
    pub fn get(&self, name: &str) -> Option<&Reading> {
        self.by_name.get(name)
    }

    /// Number of readings.
    pub fn len(&self) -> usize {
        self.by_name.len()
    }

    /// Whether there are none.
    pub fn is_empty(&self) -> bool {
        self.by_name.is_empty()
    }
}

/// Which edge of an interval a reading inside it is nearer to.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Edge {
    /// `lo` (ties, the exact middle, count as lower).
    Lower,
    /// `hi`.
    Upper,
}

/// Where a reading sits against one interval `[lo, hi)`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
#[serde(tag = "where", rename_all = "snake_case")]
pub enum Position {
    /// `lo ≤ value < hi`, `distance_mm` from the nearer edge.
    Inside {
        /// The nearer edge.
        nearer: Edge,
        /// Distance to it, mm (≥ 0).
        distance_mm: f64,
    },
    /// `value < lo` by `by_mm` (> 0): the garment is larger than the body.
    Below {
        /// `lo − value`, mm.
        by_mm: f64,
    },
    /// `value ≥ hi` by `by_mm` (≥ 0; 0 exactly on `hi`): the garment is
    /// smaller than the body.
    Above {
        /// `value − hi`, mm.
        by_mm: f64,
    },
}

impl Position {
    /// Where `value_mm` sits against `interval`.
    pub fn of(value_mm: f64, interval: Interval) -> Position {
        if value_mm < interval.lo_mm() {
            Position::Below {
                by_mm: interval.lo_mm() - value_mm,
            }
        } else if value_mm >= interval.hi_mm() {
            Position::Above {
                by_mm: value_mm - interval.hi_mm(),
            }
        } else {
            let to_lo = value_mm - interval.lo_mm();
            let to_hi = interval.hi_mm() - value_mm;
            if to_lo <= to_hi {
                Position::Inside {
                    nearer: Edge::Lower,
                    distance_mm: to_lo,
                }
            } else {
                Position::Inside {
                    nearer: Edge::Upper,
                    distance_mm: to_hi,
                }
            }
        }
    }

    /// How far outside the interval, mm (0 inside).
    pub fn outside_mm(self) -> f64 {
        match self {
            Position::Inside { .. } => 0.0,
            Position::Below { by_mm } | Position::Above { by_mm } => by_mm,
        }
    }

    /// Whether the reading lies in the interval.
    pub fn is_inside(self) -> bool {
        matches!(self, Position::Inside { .. })
    }
}

/// How one reading sits in one size.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Placement {
    /// The dimension.
    pub dimension: String,
    /// Primary or secondary in this garment.
    pub role: Role,
    /// Its kind (for wording).
    pub kind: DimensionKind,
    /// The reading, mm.
    pub value_mm: f64,
    /// Measured or estimated, with SD.
    #[serde(flatten)]
    pub source: Source,
    /// The size's interval.
    pub interval: Interval,
    /// Where the reading sits in it.
    pub position: Position,
    /// The same in words ("tight at the hip"), from [`fit_words`].
    pub words: String,
}

/// One size with how the readings sit in it.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SizeFit {
    /// The size's label.
    pub label: String,
    /// The probability that every primary interval holds (independent
    /// normals).
    pub probability: f64,
    /// Whether every primary reading lies in the size's interval.
    pub holds_readings: bool,
    /// Primary dimensions then the secondary ones the size gives and the
    /// customer has a reading of.
    pub placements: Vec<Placement>,
}

/// Why the customer is between the best size and another.
#[derive(Debug, Clone, PartialEq, Serialize)]
#[serde(tag = "reason", rename_all = "snake_case")]
pub enum BetweenReason {
    /// No size holds every primary reading although each lies within the
    /// chart's range: the dimensions point at different sizes (the two
    /// sizes' placements say which way each misses).
    NoSizeHoldsAll,
    /// The readings sit close enough (in SDs) to an edge that the other
    /// size is nearly as likely.
    NearEdge {
        /// The primary dimension nearest the edge.
        dimension: String,
        /// Its reading, mm.
        value_mm: f64,
        /// The best size's edge facing the other size, mm.
        edge_mm: f64,
        /// `|value − edge|`, mm.
        distance_mm: f64,
        /// The reading's source and SD.
        #[serde(flatten)]
        source: Source,
    },
}

/// The other size when the customer falls between two.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Between {
    /// The runner-up and how the readings sit in it.
    pub other: SizeFit,
    /// Why.
    #[serde(flatten)]
    pub reason: BetweenReason,
}

/// Below the smallest or above the largest size.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Side {
    /// Smaller than every size's interval.
    Below,
    /// At or above every size's interval.
    Above,
}

/// A primary reading outside the range of every size of its dimension.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Beyond {
    /// The dimension.
    pub dimension: String,
    /// Which end of the chart.
    pub side: Side,
    /// How far beyond it, mm.
    pub by_mm: f64,
}

/// A reading a garment used.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct UsedReading {
    /// The dimension.
    pub dimension: String,
    /// Primary or secondary.
    pub role: Role,
    /// The value, mm.
    pub value_mm: f64,
    /// Measured or estimated, with SD.
    #[serde(flatten)]
    pub source: Source,
}

/// A dimension the garment uses that neither was measured nor estimated.
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
pub struct Missing {
    /// The dimension.
    pub dimension: String,
    /// Primary (no size can be chosen) or secondary.
    pub role: Role,
}

/// A size's label and probability.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SizeProbability {
    /// The label.
    pub label: String,
    /// The probability that its primary intervals hold.
    pub probability: f64,
}

/// The recommendation for one garment.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct GarmentFit {
    /// The garment type.
    pub garment: String,
    /// The best size; `None` when a primary dimension is [`missing`](Self::missing).
    pub best: Option<SizeFit>,
    /// The other size when the customer is between two.
    pub between: Option<Between>,
    /// Primary readings beyond every size.
    pub beyond: Vec<Beyond>,
    /// Every size in chart order with its probability (empty without a best size).
    pub probabilities: Vec<SizeProbability>,
    /// The readings used, primary then secondary, with their source.
    pub readings: Vec<UsedReading>,
    /// Dimensions without a reading.
    pub missing: Vec<Missing>,
}

/// The recommendation for every garment of a chart.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Recommendation {
    /// The chart's name.
    pub chart: String,
    /// One per garment, in chart order.
    pub garments: Vec<GarmentFit>,
}

/// The recommendation for every garment of `chart` from `readings` (mm);
/// the rules are in the module docs. Pure: the same inputs give the same
/// result.
pub fn recommend(chart: &Chart, readings: &Readings) -> Recommendation {
    Recommendation {
        chart: chart.name().to_string(),
        garments: chart
            .garments()
            .iter()
            .map(|g| recommend_garment(g, readings))
            .collect(),
    }
}

/// The recommendation for one garment (module docs).
pub fn recommend_garment(garment: &Garment, readings: &Readings) -> GarmentFit {
    let mut used = Vec::new();
    let mut missing = Vec::new();
    for d in garment.dimensions() {
        match readings.get(d.name()) {
            Some(r) => used.push(UsedReading {
                dimension: d.name().to_string(),
                role: d.role(),
                value_mm: r.value_mm,
                source: r.source,
            }),
            None => missing.push(Missing {
                dimension: d.name().to_string(),
                role: d.role(),
            }),
        }
    }
    let mut fit = GarmentFit {
        garment: garment.name().to_string(),
        best: None,
        between: None,
        beyond: Vec::new(),
        probabilities: Vec::new(),
        readings: used,
        missing,
    };
    if fit.missing.iter().any(|m| m.role == Role::Primary) {
        return fit;
    }
    // Every primary dimension has a reading from here on.
    let primary: Vec<(&str, Reading)> = garment
        .primary()
        .iter()
        .map(|d| (d.name(), readings.by_name[d.name()]))
        .collect();
    let scores: Vec<Score> = garment
        .sizes()
        .iter()
        .enumerate()
        .map(|(index, size)| Score::of(index, size, &primary))
        .collect();
    // The best and the runner-up by one scan each, not a sort: the ranking
    // treats probabilities within PROBABILITY_TIE as equal, which is not
    // transitive, and the standard sort may panic on such an order (found
    // on the ANSUR II test split). A scan is defined for any comparison.
    let first = |skip: Option<usize>| {
        scores
            .iter()
            .filter(|s| Some(s.index) != skip)
            .reduce(|best, s| if s.rank(best).is_lt() { s } else { best })
    };
    let Some(best) = first(None) else {
        return fit;
    };
    let runner_up = first(Some(best.index));

    fit.beyond = beyond(garment, &primary);
    fit.probabilities = scores
        .iter()
        .map(|s| SizeProbability {
            label: garment.sizes()[s.index].label().to_string(),
            probability: s.probability,
        })
        .collect();
    let best_fit = size_fit(garment, &garment.sizes()[best.index], best, readings);
    if let Some(other) = runner_up {
        let no_size_holds = !scores.iter().any(|s| s.holds) && fit.beyond.is_empty();
        let reason = if no_size_holds {
            Some(BetweenReason::NoSizeHoldsAll)
        } else if best.probability > 0.0 && other.probability >= BETWEEN_RATIO * best.probability {
            near_edge(garment, best.index, other.index, &primary)
        } else {
            None
        };
        fit.between = reason.map(|reason| Between {
            other: size_fit(garment, &garment.sizes()[other.index], other, readings),
            reason,
        });
    }
    fit.best = Some(best_fit);
    fit
}

/// What the ranking of sizes looks at.
struct Score {
    index: usize,
    probability: f64,
    holds: bool,
    outside_mm: f64,
    centre_sum_mm: f64,
}

impl Score {
    fn of(index: usize, size: &Size, primary: &[(&str, Reading)]) -> Score {
        let mut score = Score {
            index,
            probability: 1.0,
            holds: true,
            outside_mm: 0.0,
            centre_sum_mm: 0.0,
        };
        for (name, r) in primary {
            let interval = size
                .interval(name)
                .expect("a validated chart gives every size every primary dimension");
            score.probability *= interval_probability(r.value_mm, r.source.sd_mm(), interval);
            let position = Position::of(r.value_mm, interval);
            score.holds &= position.is_inside();
            score.outside_mm += position.outside_mm();
            score.centre_sum_mm += interval.centre_mm();
        }
        score
    }

    /// The module docs' order: best first.
    fn rank(&self, other: &Score) -> std::cmp::Ordering {
        let by_probability = if (self.probability - other.probability).abs() <= PROBABILITY_TIE {
            std::cmp::Ordering::Equal
        } else {
            other.probability.total_cmp(&self.probability)
        };
        by_probability
            .then(other.holds.cmp(&self.holds))
            .then(self.outside_mm.total_cmp(&other.outside_mm))
            .then(other.centre_sum_mm.total_cmp(&self.centre_sum_mm))
            .then(self.index.cmp(&other.index))
    }
}

fn size_fit(garment: &Garment, size: &Size, score: &Score, readings: &Readings) -> SizeFit {
    let placements = garment
        .dimensions()
        .filter_map(|d| {
            let interval = size.interval(d.name())?;
            let r = readings.get(d.name())?;
            let position = Position::of(r.value_mm, interval);
            Some(Placement {
                dimension: d.name().to_string(),
                role: d.role(),
                kind: d.kind(),
                value_mm: r.value_mm,
                source: r.source,
                interval,
                position,
                words: fit_words(d.kind(), d.name(), position),
            })
        })
        .collect();
    SizeFit {
        label: size.label().to_string(),
        probability: score.probability,
        holds_readings: score.holds,
        placements,
    }
}

fn beyond(garment: &Garment, primary: &[(&str, Reading)]) -> Vec<Beyond> {
    primary
        .iter()
        .filter_map(|(name, r)| {
            let intervals = garment.sizes().iter().filter_map(|s| s.interval(name));
            let lo = intervals
                .clone()
                .map(|i| i.lo_mm())
                .fold(f64::INFINITY, f64::min);
            let hi = intervals
                .map(|i| i.hi_mm())
                .fold(f64::NEG_INFINITY, f64::max);
            let (side, by_mm) = if r.value_mm < lo {
                (Side::Below, lo - r.value_mm)
            } else if r.value_mm >= hi {
                (Side::Above, r.value_mm - hi)
            } else {
                return None;
            };
            Some(Beyond {
                dimension: name.to_string(),
                side,
                by_mm,
            })
        })
        .collect()
}

/// Among the primary dimensions along which the two sizes differ, the one
/// whose reading is nearest, in SDs (then mm), to the best size's edge
/// facing the other size.
fn near_edge(
    garment: &Garment,
    best: usize,
    other: usize,
    primary: &[(&str, Reading)],
) -> Option<BetweenReason> {
    let (a, b) = (&garment.sizes()[best], &garment.sizes()[other]);
    primary
        .iter()
        .filter_map(|(name, r)| {
            let (x, y) = (a.interval(name)?, b.interval(name)?);
            // Along a primary dimension a validated chart's intervals are
            // equal or disjoint.
            let edge_mm = if y.lo_mm() >= x.hi_mm() {
                x.hi_mm()
            } else if y.hi_mm() <= x.lo_mm() {
                x.lo_mm()
            } else {
                return None;
            };
            let distance_mm = (r.value_mm - edge_mm).abs();
            let sd = r.source.sd_mm();
            let in_sds = if sd > 0.0 {
                distance_mm / sd
            } else {
                f64::INFINITY
            };
            Some((in_sds, distance_mm, name, r, edge_mm))
        })
        .min_by(|p, q| p.0.total_cmp(&q.0).then(p.1.total_cmp(&q.1)))
        .map(
            |(_, distance_mm, name, r, edge_mm)| BetweenReason::NearEdge {
                dimension: name.to_string(),
                value_mm: r.value_mm,
                edge_mm,
                distance_mm,
                source: r.source,
            },
        )
}
