//! What can be wrong with a chart file or a reading, each saying where and
//! what to do.

use std::fmt;

use crate::chart::Units;

/// A chart file that cannot be used: which file, and what is wrong.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("size chart {origin}: {problem}")]
pub struct ChartError {
    /// The file path or name given to the parser.
    pub origin: String,
    /// What is wrong (boxed: an overlap's two sizes make it large).
    pub problem: Box<ChartProblem>,
}

/// An interval as the file writes it (for messages): `[lo, hi) unit`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Written {
    /// Lower bound, in `units`.
    pub lo: f64,
    /// Upper bound, in `units`.
    pub hi: f64,
    /// The chart's units.
    pub units: Units,
}

impl fmt::Display for Written {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "[{}, {}) {}", self.lo, self.hi, self.units)
    }
}

const UNITS_HELP: &str = "write `units = \"mm\"` or `units = \"cm\"` under `[chart]`";

/// What is wrong with a chart (see `docs/size-charts.md`).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ChartProblem {
    /// The file could not be read.
    #[error("cannot read it: {message}")]
    Read {
        /// The operating system's message.
        message: String,
    },
    /// Not TOML, or a field missing, misspelt or of the wrong type.
    #[error("{message}")]
    Toml {
        /// The TOML parser's message (with line and column).
        message: String,
    },
    /// `units` is neither `mm` nor `cm`.
    #[error("units `{units}` are not known; {UNITS_HELP}")]
    Units {
        /// As written.
        units: String,
    },
    /// `[chart] name` is empty.
    #[error("the chart has no name; give `[chart] name = \"...\"`")]
    NoName,
    /// No `[[garment]]`.
    #[error(
        "the chart has no garments; add a `[[garment]]` with its `primary` dimensions and sizes"
    )]
    NoGarments,
    /// A garment's `name` is empty.
    #[error("a garment has an empty name; give each `[[garment]]` a `name` such as \"shirt\"")]
    GarmentWithoutName,
    /// Two garments of one name.
    #[error("garment `{garment}` appears twice; give each garment type one `[[garment]]` entry")]
    DuplicateGarment {
        /// The garment.
        garment: String,
    },
    /// `primary = []`.
    #[error("garment `{garment}` has no primary dimension; name the dimensions that choose its size in `primary`, e.g. `primary = [\"chest\"]`")]
    NoPrimary {
        /// The garment.
        garment: String,
    },
    /// A dimension name the station does not know.
    #[error("garment `{garment}`{}: unknown dimension `{dimension}`{hint}; use the station's measurement names (docs/size-charts.md lists them)", size.as_ref().map(|s| format!(", size `{s}`")).unwrap_or_default())]
    UnknownDimension {
        /// The garment.
        garment: String,
        /// The size, when the name is one of its keys (`None`: in `primary`/`secondary`).
        size: Option<String>,
        /// As written.
        dimension: String,
        /// `"; did you mean `x`?"` or empty.
        hint: String,
    },
    /// A dimension listed twice (or both primary and secondary).
    #[error("garment `{garment}` lists dimension `{dimension}` twice; name each dimension once, in `primary` or in `secondary`")]
    DimensionTwice {
        /// The garment.
        garment: String,
        /// The dimension.
        dimension: String,
    },
    /// A size gives a known dimension that its garment does not declare.
    #[error("garment `{garment}`, size `{size}`: `{dimension}` is neither a primary nor a secondary dimension of `{garment}`; add it to `secondary` (or `primary`), or remove it from the size")]
    UndeclaredDimension {
        /// The garment.
        garment: String,
        /// The size.
        size: String,
        /// The dimension.
        dimension: String,
    },
    /// A garment with no sizes.
    #[error("garment `{garment}` has no sizes; add `[[garment.size]]` entries with a `label` and an interval per primary dimension")]
    EmptyGarment {
        /// The garment.
        garment: String,
    },
    /// A size without a label.
    #[error(
        "garment `{garment}`, size number {number}: no `label`; give it one, e.g. `label = \"M\"`"
    )]
    SizeWithoutLabel {
        /// The garment.
        garment: String,
        /// 1-based position among the garment's sizes.
        number: usize,
    },
    /// Two sizes of one garment with one label.
    #[error("garment `{garment}` has two sizes labelled `{size}`; give each size its own label")]
    DuplicateSize {
        /// The garment.
        garment: String,
        /// The label.
        size: String,
    },
    /// A size lacks an interval of a primary dimension.
    #[error("garment `{garment}`, size `{size}`: no interval for the primary dimension `{dimension}`; every size needs one, e.g. `{dimension} = [lo, hi]`")]
    MissingPrimary {
        /// The garment.
        garment: String,
        /// The size.
        size: String,
        /// The dimension.
        dimension: String,
    },
    /// An interval that is not two numbers.
    #[error("garment `{garment}`, size `{size}`, dimension `{dimension}`: the interval {problem}; write it `{dimension} = [lo, hi]`, lo included, hi not")]
    BadInterval {
        /// The garment.
        garment: String,
        /// The size.
        size: String,
        /// The dimension.
        dimension: String,
        /// What is wrong with it.
        problem: String,
    },
    /// A bound that is NaN or infinite.
    #[error("garment `{garment}`, size `{size}`, dimension `{dimension}`: the interval [{lo}, {hi}] has a bound that is not a finite number; give both bounds as lengths")]
    NonFinite {
        /// The garment.
        garment: String,
        /// The size.
        size: String,
        /// The dimension.
        dimension: String,
        /// Lower bound as written.
        lo: f64,
        /// Upper bound as written.
        hi: f64,
    },
    /// `lo >= hi`.
    #[error("garment `{garment}`, size `{size}`, dimension `{dimension}`: the interval [{lo}, {hi}] is empty (lo must be below hi); write the smaller bound first")]
    EmptyInterval {
        /// The garment.
        garment: String,
        /// The size.
        size: String,
        /// The dimension.
        dimension: String,
        /// Lower bound as written.
        lo: f64,
        /// Upper bound as written.
        hi: f64,
    },
    /// Two sizes whose intervals along a primary dimension share a length
    /// without being the same interval.
    #[error("garment `{garment}`: sizes `{first}` {first_interval} and `{second}` {second_interval} overlap along `{dimension}`; a customer there would fit both. Make one size's `{dimension}` end where the other's begins (or give both the same interval if they differ along another primary dimension)")]
    Overlap {
        /// The garment.
        garment: String,
        /// The primary dimension.
        dimension: String,
        /// One size.
        first: String,
        /// Its interval as written.
        first_interval: Written,
        /// The other.
        second: String,
        /// Its interval as written.
        second_interval: Written,
    },
    /// Two sizes with the same interval along every primary dimension.
    #[error("garment `{garment}`: sizes `{first}` and `{second}` have the same intervals along every primary dimension ({}), so a customer there would fit both; change one of them or remove it", dimensions.join(", "))]
    SameCell {
        /// The garment.
        garment: String,
        /// One size.
        first: String,
        /// The other.
        second: String,
        /// The garment's primary dimensions.
        dimensions: Vec<String>,
    },
    /// Consecutive intervals along a primary dimension that do not meet.
    #[error("garment `{garment}`: a gap along `{dimension}` between size `{below}` {below_interval} and size `{above}` {above_interval}; a customer from {} to {} {} would fit no size. Make `{below}` end where `{above}` begins", below_interval.hi, above_interval.lo, below_interval.units)]
    Gap {
        /// The garment.
        garment: String,
        /// The primary dimension.
        dimension: String,
        /// A size with the lower interval.
        below: String,
        /// The lower interval as written.
        below_interval: Written,
        /// A size with the upper interval.
        above: String,
        /// The upper interval as written.
        above_interval: Written,
    },
}

/// A reading that cannot be used for a recommendation.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ReadingError {
    /// Not a finite, positive length.
    #[error(
        "{name}: {value_mm} mm is not a body length; give a finite, positive value in millimetres"
    )]
    Value {
        /// The dimension.
        name: String,
        /// As given.
        value_mm: f64,
    },
    /// A standard deviation that is negative or not finite.
    #[error("{name}: a spread of {sd_mm} mm cannot be used; give a finite standard deviation of at least 0 mm")]
    Spread {
        /// The dimension.
        name: String,
        /// As given.
        sd_mm: f64,
    },
    /// Two readings of one source for one dimension.
    #[error("{name}: given twice as {provenance}; give one reading per dimension and source (take the median of repeated readings first)")]
    Twice {
        /// The dimension.
        name: String,
        /// `measured` or `estimated`.
        provenance: &'static str,
    },
}
