//! The size-chart file: TOML in, a validated [`Chart`] out (lengths in mm).
//!
//! A chart file (format in `docs/size-charts.md`) names its units, and per
//! garment its primary dimensions (those that choose the size) and
//! secondary dimensions (those that only say how the chosen size sits), and
//! per size label the interval `[lo, hi)` of each dimension. Validation
//! runs once, here: a [`Chart`] that exists is one on which every reading
//! along a primary dimension falls in exactly one column of the garment's
//! grid, so the recommendation never has to re-check it.
//!
//! Overlap and gap, for any number of primary dimensions: along each
//! primary dimension, the intervals the garment's sizes give it must be,
//! taken as a set, a partition of one range: two of them are either the
//! same interval or share no length (**overlap** otherwise), and sorted,
//! each ends exactly where the next begins (**gap** otherwise). Sizes are
//! then cells of a grid (one primary dimension: a row of intervals;
//! trousers: waist columns by inside-leg rows; a dress: bust, waist and hip
//! moving together along the diagonal), and two sizes with the same
//! interval along every primary dimension are the same cell: an overlap
//! too. A grid need not be full: a missing cell (no `W100/L76`) is
//! allowed, and a customer there is reported as between sizes.
//!
//! Intervals are half-open: `lo` belongs to the size, `hi` to the next one.
//! Bounds are compared exactly as written in the file (before the unit is
//! converted), so two edges meet only when they are the same number.

use std::collections::BTreeMap;
use std::fmt;
use std::path::Path;

use serde::{Deserialize, Serialize};

use crate::error::{ChartError, ChartProblem, Written};

/// The unit a chart's bounds are written in.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Units {
    /// Millimetres.
    Mm,
    /// Centimetres.
    Cm,
}

impl Units {
    /// The units a chart may name, as written in the file.
    pub const NAMES: [&'static str; 2] = ["mm", "cm"];

    /// Millimetres per unit.
    pub fn mm(self) -> f64 {
        match self {
            Units::Mm => 1.0,
            Units::Cm => 10.0,
        }
    }

    /// The unit as written in a chart file (`mm`, `cm`).
    pub fn symbol(self) -> &'static str {
        match self {
            Units::Mm => "mm",
            Units::Cm => "cm",
        }
    }

    fn parse(text: &str) -> Option<Units> {
        match text {
            "mm" => Some(Units::Mm),
            "cm" => Some(Units::Cm),
            _ => None,
        }
    }
}

impl fmt::Display for Units {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.symbol())
    }
}

/// What sort of body dimension a name is, so that a misfit is worded as
/// a person would say it ("tight at the chest", "too short for the inside
/// leg"). The station maps its measurement classes onto it: girth to
/// [`Girth`](Self::Girth); length, height and surface arc to
/// [`Length`](Self::Length); breadth and depth to [`Breadth`](Self::Breadth).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum DimensionKind {
    /// A closed girth (chest, waist, hip, neck, thigh).
    Girth,
    /// A length or height (stature, inside leg, arm length).
    Length,
    /// A breadth or depth (shoulder breadth).
    Breadth,
}

/// A dimension a chart may name: the caller's list of these (the
/// station's measurement names) is what a chart is validated against.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct KnownDimension {
    /// The measurement name (`chest`, `inside_leg`, `waistcircumference`).
    pub name: String,
    /// How a misfit along it is worded.
    pub kind: DimensionKind,
}

impl KnownDimension {
    /// A known dimension.
    pub fn new(name: impl Into<String>, kind: DimensionKind) -> Self {
        Self {
            name: name.into(),
            kind,
        }
    }
}

/// The interval `[lo, hi)` of one dimension in one size, millimetres:
/// `lo` belongs to the size, `hi` does not.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Interval {
    lo_mm: f64,
    hi_mm: f64,
}

impl Interval {
    /// `[lo_mm, hi_mm)`; the caller ensures finite bounds with lo < hi
    /// (charts are validated before they build intervals).
    #[cfg(test)]
    pub(crate) fn new(lo_mm: f64, hi_mm: f64) -> Interval {
        assert!(lo_mm.is_finite() && hi_mm.is_finite() && lo_mm < hi_mm);
        Interval { lo_mm, hi_mm }
    }

    /// Lower bound (inclusive), mm.
    pub fn lo_mm(&self) -> f64 {
        self.lo_mm
    }

    /// Upper bound (exclusive), mm.
    pub fn hi_mm(&self) -> f64 {
        self.hi_mm
    }

    /// Whether `value_mm` lies in `[lo, hi)`.
    pub fn contains(&self, value_mm: f64) -> bool {
        self.lo_mm <= value_mm && value_mm < self.hi_mm
    }

    /// Midpoint, mm.
    pub fn centre_mm(&self) -> f64 {
        0.5 * (self.lo_mm + self.hi_mm)
    }
}

impl fmt::Display for Interval {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "[{}, {}) mm", self.lo_mm, self.hi_mm)
    }
}

/// Whether a dimension chooses the size or only says how it sits.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Role {
    /// Chooses the size: every size gives an interval; the intervals form
    /// the garment's grid (module docs).
    Primary,
    /// Says how the chosen size sits (a shirt's sleeve); a size may leave
    /// it out; never chooses the size.
    Secondary,
}

/// A dimension a garment uses.
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
pub struct Dimension {
    name: String,
    kind: DimensionKind,
    role: Role,
}

impl Dimension {
    /// The measurement name.
    pub fn name(&self) -> &str {
        &self.name
    }

    /// Its kind (for wording).
    pub fn kind(&self) -> DimensionKind {
        self.kind
    }

    /// Primary or secondary.
    pub fn role(&self) -> Role {
        self.role
    }
}

/// One size of a garment: its label and its intervals.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Size {
    label: String,
    intervals: BTreeMap<String, Interval>,
}

impl Size {
    /// The label (`M`, `50`, `W88/L80`).
    pub fn label(&self) -> &str {
        &self.label
    }

    /// The interval of `dimension`, if this size gives one (every primary
    /// dimension has one).
    pub fn interval(&self, dimension: &str) -> Option<Interval> {
        self.intervals.get(dimension).copied()
    }
}

/// One garment type of a chart.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Garment {
    name: String,
    primary: Vec<Dimension>,
    secondary: Vec<Dimension>,
    sizes: Vec<Size>,
}

impl Garment {
    /// The garment type as the chart names it (`shirt`, `trousers`).
    pub fn name(&self) -> &str {
        &self.name
    }

    /// The primary dimensions, in file order (at least one).
    pub fn primary(&self) -> &[Dimension] {
        &self.primary
    }

    /// The secondary dimensions, in file order.
    pub fn secondary(&self) -> &[Dimension] {
        &self.secondary
    }

    /// Primary then secondary dimensions.
    pub fn dimensions(&self) -> impl Iterator<Item = &Dimension> {
        self.primary.iter().chain(&self.secondary)
    }

    /// The sizes, in file order (at least one).
    pub fn sizes(&self) -> &[Size] {
        &self.sizes
    }
}

/// A validated size chart (module docs); lengths in mm.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Chart {
    name: String,
    description: Option<String>,
    units: Units,
    garments: Vec<Garment>,
}

impl Chart {
    /// The chart's name (`[chart] name`).
    pub fn name(&self) -> &str {
        &self.name
    }

    /// Its description, if the file gives one.
    pub fn description(&self) -> Option<&str> {
        self.description.as_deref()
    }

    /// The units the file is written in (inside, everything is mm).
    pub fn units(&self) -> Units {
        self.units
    }

    /// The garments, in file order (at least one).
    pub fn garments(&self) -> &[Garment] {
        &self.garments
    }

    /// The garment named `name`.
    pub fn garment(&self, name: &str) -> Option<&Garment> {
        self.garments.iter().find(|g| g.name == name)
    }

    /// Reads and validates the chart file at `path` against `known`.
    pub fn from_path(path: &Path, known: &[KnownDimension]) -> Result<Chart, ChartError> {
        let origin = path.display().to_string();
        let text = std::fs::read_to_string(path).map_err(|e| ChartError {
            origin: origin.clone(),
            problem: Box::new(ChartProblem::Read {
                message: e.to_string(),
            }),
        })?;
        Chart::from_toml_str(&text, &origin, known)
    }

    /// Parses and validates a chart; `origin` (a file path or a name) is
    /// named in errors; `known` lists the dimensions it may use.
    pub fn from_toml_str(
        text: &str,
        origin: &str,
        known: &[KnownDimension],
    ) -> Result<Chart, ChartError> {
        parse(text, known).map_err(|problem| ChartError {
            origin: origin.to_string(),
            problem,
        })
    }
}

/// Internal results: the problem boxed, as in [`ChartError`] (an overlap's
/// two sizes and intervals make it large).
type Fallible<T> = Result<T, Box<ChartProblem>>;

fn fail<T>(problem: ChartProblem) -> Fallible<T> {
    Err(Box::new(problem))
}

// The file as serde reads it; sizes stay TOML tables because their keys are
// dimension names, checked by hand for messages that name the size.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawFile {
    chart: RawHeader,
    #[serde(default)]
    garment: Vec<RawGarment>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawHeader {
    name: String,
    units: String,
    #[serde(default)]
    description: Option<String>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawGarment {
    name: String,
    primary: Vec<String>,
    #[serde(default)]
    secondary: Vec<String>,
    #[serde(default)]
    size: Vec<toml::Table>,
}

/// A size as written, bounds in the chart's units.
struct WrittenSize {
    label: String,
    intervals: BTreeMap<String, (f64, f64)>,
}

fn parse(text: &str, known: &[KnownDimension]) -> Fallible<Chart> {
    let raw: RawFile = toml::from_str(text).map_err(|e| ChartProblem::Toml {
        message: e.to_string(),
    })?;
    let units = Units::parse(raw.chart.units.trim()).ok_or_else(|| ChartProblem::Units {
        units: raw.chart.units.clone(),
    })?;
    if raw.chart.name.trim().is_empty() {
        return fail(ChartProblem::NoName);
    }
    if raw.garment.is_empty() {
        return fail(ChartProblem::NoGarments);
    }
    let mut garments: Vec<Garment> = Vec::with_capacity(raw.garment.len());
    for g in raw.garment {
        let garment = parse_garment(g, units, known)?;
        if garments.iter().any(|x| x.name == garment.name) {
            return fail(ChartProblem::DuplicateGarment {
                garment: garment.name,
            });
        }
        garments.push(garment);
    }
    Ok(Chart {
        name: raw.chart.name.trim().to_string(),
        description: raw.chart.description,
        units,
        garments,
    })
}

fn parse_garment(raw: RawGarment, units: Units, known: &[KnownDimension]) -> Fallible<Garment> {
    let garment = raw.name.trim().to_string();
    if garment.is_empty() {
        return fail(ChartProblem::GarmentWithoutName);
    }
    if raw.primary.is_empty() {
        return fail(ChartProblem::NoPrimary { garment });
    }
    let mut dims: Vec<Dimension> = Vec::new();
    for (names, role) in [
        (&raw.primary, Role::Primary),
        (&raw.secondary, Role::Secondary),
    ] {
        for name in names {
            let kind = known_kind(known, name).ok_or_else(|| ChartProblem::UnknownDimension {
                garment: garment.clone(),
                size: None,
                dimension: name.clone(),
                hint: hint(name, known),
            })?;
            if dims.iter().any(|d| &d.name == name) {
                return fail(ChartProblem::DimensionTwice {
                    garment,
                    dimension: name.clone(),
                });
            }
            dims.push(Dimension {
                name: name.clone(),
                kind,
                role,
            });
        }
    }
    if raw.size.is_empty() {
        return fail(ChartProblem::EmptyGarment { garment });
    }
    let mut sizes: Vec<WrittenSize> = Vec::with_capacity(raw.size.len());
    for (index, table) in raw.size.iter().enumerate() {
        let size = parse_size(&garment, index, table, &dims, known)?;
        if sizes.iter().any(|s| s.label == size.label) {
            return fail(ChartProblem::DuplicateSize {
                garment,
                size: size.label,
            });
        }
        sizes.push(size);
    }
    let primary: Vec<&str> = dims
        .iter()
        .filter(|d| d.role == Role::Primary)
        .map(|d| d.name.as_str())
        .collect();
    check_grid(&garment, &primary, &sizes, units)?;
    let (primary, secondary) = dims.into_iter().partition(|d| d.role == Role::Primary);
    let sizes = sizes
        .into_iter()
        .map(|s| Size {
            label: s.label,
            intervals: s
                .intervals
                .into_iter()
                .map(|(d, (lo, hi))| {
                    (
                        d,
                        Interval {
                            lo_mm: lo * units.mm(),
                            hi_mm: hi * units.mm(),
                        },
                    )
                })
                .collect(),
        })
        .collect();
    Ok(Garment {
        name: garment,
        primary,
        secondary,
        sizes,
    })
}

fn known_kind(known: &[KnownDimension], name: &str) -> Option<DimensionKind> {
    known.iter().find(|k| k.name == name).map(|k| k.kind)
}

fn hint(name: &str, known: &[KnownDimension]) -> String {
    tapeshape_common::suggest::did_you_mean(name, known.iter().map(|k| k.name.as_str()))
}

fn parse_size(
    garment: &str,
    index: usize,
    table: &toml::Table,
    dims: &[Dimension],
    known: &[KnownDimension],
) -> Fallible<WrittenSize> {
    let label = match table.get("label") {
        Some(toml::Value::String(s)) if !s.trim().is_empty() => s.trim().to_string(),
        _ => {
            return fail(ChartProblem::SizeWithoutLabel {
                garment: garment.to_string(),
                number: index + 1,
            })
        }
    };
    let mut intervals = BTreeMap::new();
    for (key, value) in table {
        if key == "label" {
            continue;
        }
        let at = |problem: &str| ChartProblem::BadInterval {
            garment: garment.to_string(),
            size: label.clone(),
            dimension: key.clone(),
            problem: problem.to_string(),
        };
        if !dims.iter().any(|d| &d.name == key) {
            return fail(if known_kind(known, key).is_some() {
                ChartProblem::UndeclaredDimension {
                    garment: garment.to_string(),
                    size: label,
                    dimension: key.clone(),
                }
            } else {
                ChartProblem::UnknownDimension {
                    garment: garment.to_string(),
                    size: Some(label),
                    dimension: key.clone(),
                    hint: hint(key, known),
                }
            });
        }
        let bounds = value
            .as_array()
            .filter(|a| a.len() == 2)
            .ok_or_else(|| at("is not a pair of numbers"))?;
        let number = |v: &toml::Value| match v {
            toml::Value::Integer(i) => Some(*i as f64),
            toml::Value::Float(x) => Some(*x),
            _ => None,
        };
        let (Some(lo), Some(hi)) = (number(&bounds[0]), number(&bounds[1])) else {
            return Err(Box::new(at("has a bound that is not a number")));
        };
        if !lo.is_finite() || !hi.is_finite() {
            return fail(ChartProblem::NonFinite {
                garment: garment.to_string(),
                size: label,
                dimension: key.clone(),
                lo,
                hi,
            });
        }
        if lo >= hi {
            return fail(ChartProblem::EmptyInterval {
                garment: garment.to_string(),
                size: label,
                dimension: key.clone(),
                lo,
                hi,
            });
        }
        intervals.insert(key.clone(), (lo, hi));
    }
    if let Some(d) = dims
        .iter()
        .find(|d| d.role == Role::Primary && !intervals.contains_key(&d.name))
    {
        return fail(ChartProblem::MissingPrimary {
            garment: garment.to_string(),
            size: label,
            dimension: d.name.clone(),
        });
    }
    Ok(WrittenSize { label, intervals })
}

/// The module docs' grid rule: per primary dimension, the sizes' intervals
/// are equal or disjoint and meet edge to edge; no two sizes are the same
/// cell.
fn check_grid(
    garment: &str,
    primary: &[&str],
    sizes: &[WrittenSize],
    units: Units,
) -> Fallible<()> {
    let of = |s: &WrittenSize, d: &str| s.intervals[d];
    let written = |(lo, hi): (f64, f64)| Written { lo, hi, units };
    for (i, a) in sizes.iter().enumerate() {
        for b in &sizes[i + 1..] {
            for &d in primary {
                let (x, y) = (of(a, d), of(b, d));
                if x != y && x.0 < y.1 && y.0 < x.1 {
                    return fail(ChartProblem::Overlap {
                        garment: garment.to_string(),
                        dimension: d.to_string(),
                        first: a.label.clone(),
                        first_interval: written(x),
                        second: b.label.clone(),
                        second_interval: written(y),
                    });
                }
            }
            if primary.iter().all(|&d| of(a, d) == of(b, d)) {
                return fail(ChartProblem::SameCell {
                    garment: garment.to_string(),
                    first: a.label.clone(),
                    second: b.label.clone(),
                    dimensions: primary.iter().map(|d| d.to_string()).collect(),
                });
            }
        }
    }
    for &d in primary {
        // Distinct intervals along `d` with the first size that gives each;
        // disjoint by now, so sorting by `lo` sorts them along the axis.
        let mut column: Vec<((f64, f64), &str)> = Vec::new();
        for s in sizes {
            let x = of(s, d);
            if !column.iter().any(|(y, _)| *y == x) {
                column.push((x, &s.label));
            }
        }
        column.sort_by(|a, b| a.0 .0.total_cmp(&b.0 .0));
        for pair in column.windows(2) {
            let ((below, below_label), (above, above_label)) = (pair[0], pair[1]);
            if below.1 < above.0 {
                return fail(ChartProblem::Gap {
                    garment: garment.to_string(),
                    dimension: d.to_string(),
                    below: below_label.to_string(),
                    below_interval: written(below),
                    above: above_label.to_string(),
                    above_interval: written(above),
                });
            }
        }
    }
    Ok(())
}
