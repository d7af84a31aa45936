//! Typed errors of the measurement crate.
//!
//! Every error that concerns one measurement names it, so an operator or an
//! engineer reading a log knows which line of which set to look at, and every
//! unknown name comes with the closest known name as a suggestion.

/// Everything that can go wrong loading, compiling or taking measurements.
#[derive(Debug, thiserror::Error)]
pub enum MeasureError {
    /// A measurement-set file could not be read.
    #[error("cannot read measurement set file {path}: {source}")]
    Io {
        /// The file path as given.
        path: String,
        /// The I/O error.
        source: std::io::Error,
    },
    /// The TOML text does not parse, or has fields of the wrong type.
    #[error("measurement set `{set}` is not valid TOML for a measurement set: {message}")]
    Parse {
        /// Set name or file path.
        set: String,
        /// What the TOML parser said (with line and column).
        message: String,
    },
    /// An entry of a set is malformed (missing field, unknown kind, duplicate name, ...).
    #[error("measurement set `{set}`, entry #{index} `{name}`: {problem}")]
    Definition {
        /// Set name or file path.
        set: String,
        /// 1-based position of the entry in the file.
        index: usize,
        /// The entry's name (or `?` when it has none).
        name: String,
        /// What is wrong and what to do.
        problem: String,
    },
    /// The set as a whole is malformed (no entries, no `[set]` table, ...).
    #[error("measurement set `{set}`: {problem}")]
    Set {
        /// Set name or file path.
        set: String,
        /// What is wrong and what to do.
        problem: String,
    },
    /// No built-in set has this name and no file exists at this path.
    #[error("unknown measurement set `{name}`: not a built-in set ({available}) and no such file{suggestion}")]
    UnknownSet {
        /// What was asked for.
        name: String,
        /// Built-in set names, comma-separated.
        available: String,
        /// `"; did you mean `x`?"` or empty.
        suggestion: String,
    },
    /// A landmark name of a measurement is not in the anatomy.
    #[error(
        "measurement `{measurement}`: landmark `{landmark}` is not in the anatomy{suggestion}"
    )]
    UnknownLandmark {
        /// Measurement name.
        measurement: String,
        /// The unknown landmark name.
        landmark: String,
        /// `"; did you mean `x`?"` or empty.
        suggestion: String,
    },
    /// A body-part name of a measurement is not in the anatomy.
    #[error("measurement `{measurement}`: body part `{part}` is not in the anatomy{suggestion}")]
    UnknownPart {
        /// Measurement name.
        measurement: String,
        /// The unknown part name.
        part: String,
        /// `"; did you mean `x`?"` or empty.
        suggestion: String,
    },
    /// A landmark's vertex index does not exist in the topology.
    #[error("measurement `{measurement}`: landmark `{landmark}` is vertex {vertex}, but the mesh has only {n_vertices} vertices (anatomy and topology do not belong together)")]
    LandmarkOutOfRange {
        /// Measurement name.
        measurement: String,
        /// Landmark name.
        landmark: String,
        /// Its vertex index.
        vertex: u32,
        /// Vertices in the topology.
        n_vertices: usize,
    },
    /// A body part refers to a triangle that does not exist.
    #[error("measurement `{measurement}`: body part `{part}` lists triangle {triangle}, but the mesh has only {n_faces} triangles (anatomy and topology do not belong together)")]
    PartTriangleOutOfRange {
        /// Measurement name.
        measurement: String,
        /// Part name.
        part: String,
        /// Offending triangle index.
        triangle: u32,
        /// Triangles in the topology.
        n_faces: usize,
    },
    /// The vertex array does not have the compiled topology's length.
    #[error("{got} vertices given, but the measurement set was compiled for a topology of {expected} vertices")]
    VertexCount {
        /// Vertices given.
        got: usize,
        /// Vertices expected.
        expected: usize,
    },
    /// A vertex the measurement uses has a NaN or infinite coordinate.
    #[error("measurement `{measurement}`: vertex {vertex} has a non-finite coordinate {position:?}; the mesh is broken (check the file or the optimiser step)")]
    NonFinite {
        /// Measurement name.
        measurement: String,
        /// Offending vertex.
        vertex: u32,
        /// Its position.
        position: [f64; 3],
    },
    /// The measurement plane does not cut the measurement's body parts.
    #[error("measurement `{measurement}`: the plane through landmark `{anchor}` with normal {normal:?} does not cut the body part(s) {parts:?}; the anchor is probably not on those parts (check the set's `anchor`, `normal` and `parts`)")]
    PlaneMissesPart {
        /// Measurement name.
        measurement: String,
        /// Anchor landmark name.
        anchor: String,
        /// Plane normal (unit, station frame).
        normal: [f64; 3],
        /// Part names.
        parts: Vec<String>,
    },
    /// The three landmarks that define a measurement's plane are collinear (or not finite).
    #[error("measurement `{measurement}`: the landmarks {landmarks:?} that define its plane are collinear or not finite on this body")]
    DegeneratePlane {
        /// Measurement name.
        measurement: String,
        /// Anchor and the two `through` landmarks.
        landmarks: [String; 3],
    },
    /// No surface path joins two landmarks (they lie on different components).
    #[error("measurement `{measurement}`: no surface path from `{from}` to `{to}` (the landmarks lie on different connected components of the mesh)")]
    NoPath {
        /// Measurement name.
        measurement: String,
        /// Start landmark.
        from: String,
        /// End landmark.
        to: String,
    },
    /// A measurement index passed to [`crate::CompiledSet::measure_one`] does not exist.
    #[error("measurement index {index} out of range: the set has {len} measurements")]
    IndexOutOfRange {
        /// Index asked for.
        index: usize,
        /// Number of measurements.
        len: usize,
    },
}
