//! Size charts and the garment-size recommendation.
//!
//! Why a crate of its own: a fitting room measures people to choose sizes.
//! What a store's chart says (garments, their dimensions, the interval of
//! each per size) and how a customer's dimensions, some measured by the
//! operator and some read off the estimated body, become "M, close to L"
//! is a small, pure piece of logic that the station's CLI, TUI, JSON report
//! and printed card all show. It knows nothing of meshes or models: the
//! caller passes the names of the dimensions a chart may use
//! ([`KnownDimension`]) and the readings in millimetres ([`Readings`]).
//!
//! | module | what |
//! |---|---|
//! | [`chart`] | the chart file (TOML, `docs/size-charts.md`): [`Chart::from_toml_str`], [`Chart::from_path`], validation (overlap, gap, unknown names) |
//! | [`recommend`](mod@recommend) | [`recommend`](fn@recommend): best size, placements, between two sizes, probabilities, missing dimensions |
//! | [`normal`] | [`interval_probability`]: a normal reading in `[lo, hi)` |
//! | [`words`] | [`fit_words`]: "tight at the hip", the one place phrases are made |
//! | [`text`] | `Display` for [`Recommendation`] (the CLI's text) |
//!
//! Units: millimetres inside (f64); a chart file says whether it is written
//! in `mm` or `cm`. Intervals are `[lo, hi)`: lo included, hi not.

pub mod chart;
mod error;
pub mod normal;
pub mod recommend;
pub mod text;
pub mod words;

pub use chart::{
    Chart, Dimension, DimensionKind, Garment, Interval, KnownDimension, Role, Size, Units,
};
pub use error::{ChartError, ChartProblem, ReadingError, Written};
pub use normal::interval_probability;
pub use recommend::{
    recommend, recommend_garment, Between, BetweenReason, Beyond, Edge, GarmentFit, Missing,
    Placement, Position, Reading, Readings, Recommendation, Side, SizeFit, SizeProbability, Source,
    UsedReading, BETWEEN_RATIO, PROBABILITY_TIE,
};
pub use words::fit_words;
