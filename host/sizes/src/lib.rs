//! Size charts and the garment-size recommendation.
//!
//! Why a crate of its own: a fitting room measures people to choose sizes.
//! What a store's chart says (garments, their dimensions, the interval of
//! each per size) is a small, pure piece of logic that the station's CLI,
//! TUI, JSON report and printed card all use. It knows nothing of meshes or
//! models: the caller passes the names of the dimensions a chart may use
//! ([`KnownDimension`]).
//!
//! | module | what |
//! |---|---|
//! | [`chart`] | the chart file (TOML, `docs/size-charts.md`): [`Chart::from_toml_str`], [`Chart::from_path`], validation (overlap, gap, unknown names) |
//!
//! Units: millimetres inside (f64); a chart file says whether it is written
//! in `mm` or `cm`. Intervals are `[lo, hi)`: lo included, hi not.

pub mod chart;
mod error;

pub use chart::{
    Chart, Dimension, DimensionKind, Garment, Interval, KnownDimension, Role, Size, Units,
};
pub use error::{ChartError, ChartProblem, ReadingError, Written};
