//! Measurement sets as data: TOML files, validated on load.
//!
//! Why data and not code: a fitting room, a survey and the paper each want
//! their own list of measurements, and an engineer must be able to add one
//! (or fix a landmark) without rebuilding the program. The built-in sets live
//! in `host/measure/sets/*.toml` and are embedded in the binary with
//! `include_str!`, so the program works from any directory; a user's own file
//! has the same format.
//!
//! # File format
//!
//! ```toml
//! [set]
//! name = "quick"
//! description = "What the set is for."
//!
//! [[measurement]]
//! name = "waist"                 # snake_case, unique in the set
//! label = "Waist circumference"  # for people
//! description = "Tape horizontal around the trunk at navel level, ..."  # operator instruction
//! kind = "circumference"         # see below
//! anchor = "omphalion"
//! normal = [0.0, 0.0, 1.0]
//! parts = ["torso"]
//! tolerance = "large_girth"      # ISO 20685-1 class, see Tolerance
//! class = "girth"                # optional, inferred from the kind
//! ansur = "waistcircumference"   # optional ANSUR II column
//! group = "..."                  # optional: entries summed in tables
//! note = "..."                   # optional: where it departs from its definition
//! ```
//!
//! Kinds and their fields (landmark and part names are resolved against an
//! [`tapeshape_mesh::Anatomy`] when the set is compiled):
//!
//! | kind | fields | value |
//! |---|---|---|
//! | `euclidean` | `from`, `to` | straight distance |
//! | `path` | `landmarks` (>= 2) | sum of straight segments along the list (open) |
//! | `geodesic` | `from`, `to`, optional `method` | shortest path on the edge graph (Dijkstra; `method = "unfolded"` also steps straight across triangle pairs) |
//! | `geodesic_path` | `landmarks` (>= 2) | sum of geodesics along the list (open) |
//! | `geodesic_loop` | `landmarks` (>= 2) | sum of geodesics around the list, closed |
//! | `circumference` | `anchor`, `normal`, `parts`, optional `through` (2 landmarks) | perimeter of the convex hull of the plane cut |
//! | `height` | `landmark`, optional `floor` | vertical distance from the floor landmark |
//! | `breadth`, `depth` | `anchor`, `normal`, `parts`, `axis` | hull extent of the plane cut along `axis` |

use crate::error::MeasureError;
pub use crate::geodesic::GeodesicMethod;
use tapeshape_common::suggest::did_you_mean;
use tapeshape_mesh::Vec3;

mod parse;
use parse::{parse_definition, Fields};

/// The built-in sets: `(name, TOML text)`.
pub const BUILTIN_SETS: &[(&str, &str)] = &[
    ("paper34", include_str!("../sets/paper34.toml")),
    ("ansur", include_str!("../sets/ansur.toml")),
    ("quick", include_str!("../sets/quick.toml")),
    ("face7", include_str!("../sets/face7.toml")),
];

/// Landmark used as the floor by `height` entries that do not name one: the
/// lower (smaller z) of the two, chosen per body when measuring.
pub const DEFAULT_FLOOR: [&str; 2] = ["heel_bottom_left", "heel_bottom_right"];

/// The ANSUR II column names (`shared/data/ansur2/definitions.csv`), for
/// validating the `ansur` field. Kept in the code because the program must run
/// without `shared/`.
pub const ANSUR_COLUMNS: &[&str] = &[
    "abdominalextensiondepthsitting",
    "acromialheight",
    "acromionradialelength",
    "anklecircumference",
    "axillaheight",
    "balloffootcircumference",
    "balloffootlength",
    "biacromialbreadth",
    "bicepscircumferenceflexed",
    "bicristalbreadth",
    "bideltoidbreadth",
    "bimalleolarbreadth",
    "bitragionchinarc",
    "bitragionsubmandibulararc",
    "bizygomaticbreadth",
    "buttockcircumference",
    "buttockdepth",
    "buttockheight",
    "buttockkneelength",
    "buttockpopliteallength",
    "calfcircumference",
    "cervicaleheight",
    "chestbreadth",
    "chestcircumference",
    "chestdepth",
    "chestheight",
    "crotchheight",
    "crotchlengthomphalion",
    "crotchlengthposterioromphalion",
    "earbreadth",
    "earlength",
    "earprotrusion",
    "elbowrestheight",
    "eyeheightsitting",
    "footbreadthhorizontal",
    "footlength",
    "forearmcenterofgriplength",
    "forearmcircumferenceflexed",
    "forearmforearmbreadth",
    "forearmhandlength",
    "functionalleglength",
    "handbreadth",
    "handcircumference",
    "handlength",
    "headbreadth",
    "headcircumference",
    "headlength",
    "heelanklecircumference",
    "heelbreadth",
    "hipbreadth",
    "hipbreadthsitting",
    "iliocristaleheight",
    "interpupillarybreadth",
    "interscyei",
    "interscyeii",
    "kneeheightmidpatella",
    "kneeheightsitting",
    "lateralfemoralepicondyleheight",
    "lateralmalleolusheight",
    "lowerthighcircumference",
    "mentonsellionlength",
    "neckcircumference",
    "neckcircumferencebase",
    "overheadfingertipreachsitting",
    "palmlength",
    "poplitealheight",
    "radialestylionlength",
    "shouldercircumference",
    "shoulderelbowlength",
    "shoulderlength",
    "sittingheight",
    "sleevelengthspinewrist",
    "sleeveoutseam",
    "span",
    "stature",
    "suprasternaleheight",
    "tenthribheight",
    "thighcircumference",
    "thighclearance",
    "thumbtipreach",
    "tibialheight",
    "tragiontopofhead",
    "trochanterionheight",
    "verticaltrunkcircumferenceusa",
    "waistbacklength",
    "waistbreadth",
    "waistcircumference",
    "waistdepth",
    "waistfrontlengthsitting",
    "waistheightomphalion",
    "weightkg",
    "wristcircumference",
    "wristheight",
];

/// What a measurement does (see the module docs for the table).
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum Kind {
    /// Straight distance between two landmarks.
    Euclidean {
        /// Start landmark.
        from: String,
        /// End landmark.
        to: String,
    },
    /// Sum of straight segments along an open list of landmarks.
    Path {
        /// Landmarks in order (at least two).
        landmarks: Vec<String>,
    },
    /// Shortest path on the mesh's edge graph between two landmarks.
    Geodesic {
        /// Start landmark.
        from: String,
        /// End landmark.
        to: String,
        /// How the path is computed (`method = "edges"` (default) or `"unfolded"`).
        method: GeodesicMethod,
    },
    /// Sum of geodesics along an open list of landmarks.
    GeodesicPath {
        /// Landmarks in order (at least two).
        landmarks: Vec<String>,
        /// How each leg is computed.
        method: GeodesicMethod,
    },
    /// Sum of geodesics around a closed list of landmarks (last back to first).
    GeodesicLoop {
        /// Landmarks in order (at least two).
        landmarks: Vec<String>,
        /// How each leg is computed.
        method: GeodesicMethod,
    },
    /// Perimeter of the convex hull of the plane cut through `anchor`.
    Circumference {
        /// Landmark the plane passes through (the cut curve nearest to it is used).
        anchor: String,
        /// Plane normal, station frame (normalised on load). With `through`,
        /// only its sign matters: the computed normal is turned to agree with it.
        normal: Vec3,
        /// Body parts the plane cuts (others are ignored).
        parts: Vec<String>,
        /// Empty, or two more landmarks: the plane then passes through the
        /// anchor and these two on each body (e.g. the neck base through the
        /// suprasternale and both neck sides), instead of having a fixed normal.
        through: Vec<String>,
    },
    /// Vertical distance (along +Z) from the floor landmark to `landmark`.
    Height {
        /// The measured landmark.
        landmark: String,
        /// Floor landmark; `None` = the lower of [`DEFAULT_FLOOR`].
        floor: Option<String>,
    },
    /// Caliper breadth: extent of the cut's convex hull along `axis`.
    Breadth {
        /// Landmark the plane passes through.
        anchor: String,
        /// Plane normal, station frame (normalised).
        normal: Vec3,
        /// Body parts the plane cuts.
        parts: Vec<String>,
        /// Caliper axis, in the plane (normalised).
        axis: Vec3,
    },
    /// Caliper depth: as [`Kind::Breadth`], front-to-back by convention.
    Depth {
        /// Landmark the plane passes through.
        anchor: String,
        /// Plane normal, station frame (normalised).
        normal: Vec3,
        /// Body parts the plane cuts.
        parts: Vec<String>,
        /// Caliper axis, in the plane (normalised).
        axis: Vec3,
    },
}

impl Kind {
    /// The kind's name as written in the files.
    pub fn name(&self) -> &'static str {
        match self {
            Kind::Euclidean { .. } => "euclidean",
            Kind::Path { .. } => "path",
            Kind::Geodesic { .. } => "geodesic",
            Kind::GeodesicPath { .. } => "geodesic_path",
            Kind::GeodesicLoop { .. } => "geodesic_loop",
            Kind::Circumference { .. } => "circumference",
            Kind::Height { .. } => "height",
            Kind::Breadth { .. } => "breadth",
            Kind::Depth { .. } => "depth",
        }
    }

    /// Every landmark name the kind refers to (the default floor included).
    pub fn landmarks(&self) -> Vec<&str> {
        match self {
            Kind::Euclidean { from, to } | Kind::Geodesic { from, to, .. } => vec![from, to],
            Kind::Path { landmarks }
            | Kind::GeodesicPath { landmarks, .. }
            | Kind::GeodesicLoop { landmarks, .. } => {
                landmarks.iter().map(String::as_str).collect()
            }
            Kind::Circumference {
                anchor, through, ..
            } => std::iter::once(anchor.as_str())
                .chain(through.iter().map(String::as_str))
                .collect(),
            Kind::Breadth { anchor, .. } | Kind::Depth { anchor, .. } => vec![anchor],
            Kind::Height { landmark, floor } => {
                let mut v = vec![landmark.as_str()];
                match floor {
                    Some(f) => v.push(f),
                    None => v.extend(DEFAULT_FLOOR),
                }
                v
            }
        }
    }

    fn default_class(&self) -> Class {
        match self {
            Kind::Euclidean { .. } | Kind::Path { .. } => Class::Length,
            Kind::Geodesic { .. } | Kind::GeodesicPath { .. } => Class::Arc,
            Kind::GeodesicLoop { .. } | Kind::Circumference { .. } => Class::Girth,
            Kind::Height { .. } => Class::Height,
            Kind::Breadth { .. } => Class::Breadth,
            Kind::Depth { .. } => Class::Depth,
        }
    }
}

/// What sort of body dimension a measurement is (for tables and checks).
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Class {
    /// A straight segment length.
    Length,
    /// A vertical distance from the floor.
    Height,
    /// A left-right caliper distance.
    Breadth,
    /// A front-back caliper distance.
    Depth,
    /// A closed girth.
    Girth,
    /// An open surface arc.
    Arc,
}

impl Class {
    const ALL: [(&'static str, Class); 6] = [
        ("length", Class::Length),
        ("height", Class::Height),
        ("breadth", Class::Breadth),
        ("depth", Class::Depth),
        ("girth", Class::Girth),
        ("arc", Class::Arc),
    ];
}

/// ISO 20685-1 tolerance class: the largest acceptable difference between a
/// measurement taken from a 3D body and the same one taken by hand.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Tolerance {
    /// Heights: 4 mm.
    Height,
    /// Breadths and depths: 4 mm.
    Breadth,
    /// Small girths (neck, wrist, arm, head, ...): 4 mm.
    SmallGirth,
    /// Segment lengths: 5 mm.
    SegmentLength,
    /// Large girths (chest, waist, hip): 9 mm.
    LargeGirth,
}

impl Tolerance {
    const ALL: [(&'static str, Tolerance); 5] = [
        ("height", Tolerance::Height),
        ("breadth", Tolerance::Breadth),
        ("small_girth", Tolerance::SmallGirth),
        ("segment_length", Tolerance::SegmentLength),
        ("large_girth", Tolerance::LargeGirth),
    ];

    /// The tolerance in millimetres.
    pub fn mm(self) -> f64 {
        match self {
            Tolerance::Height | Tolerance::Breadth | Tolerance::SmallGirth => 4.0,
            Tolerance::SegmentLength => 5.0,
            Tolerance::LargeGirth => 9.0,
        }
    }
}

/// One measurement of a set, validated.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Definition {
    /// Unique snake_case name.
    pub name: String,
    /// Human label.
    pub label: String,
    /// An instruction a fitting-room operator can follow.
    pub description: String,
    /// What to compute.
    #[serde(flatten)]
    pub kind: Kind,
    /// Dimension class.
    pub class: Class,
    /// ISO 20685-1 tolerance class.
    pub tolerance: Tolerance,
    /// ANSUR II column this follows, if any.
    pub ansur: Option<String>,
    /// Group whose members are summed in tables (the paper's knee/arm loops).
    pub group: Option<String>,
    /// Where the measurement departs from its reference definition.
    pub note: Option<String>,
}

/// A validated measurement set (independent of any topology).
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct MeasurementSet {
    /// Set name.
    pub name: String,
    /// What the set is for.
    pub description: String,
    /// The measurements, in file order.
    pub definitions: Vec<Definition>,
}

impl MeasurementSet {
    /// A built-in set by name (`paper34`, `ansur`, `quick`, `face7`).
    pub fn builtin(name: &str) -> Result<Self, MeasureError> {
        match BUILTIN_SETS.iter().find(|(n, _)| *n == name) {
            Some((n, text)) => Self::from_toml_str(text, n),
            None => Err(unknown_set(name)),
        }
    }

    /// All built-in sets, parsed.
    pub fn builtins() -> Result<Vec<Self>, MeasureError> {
        BUILTIN_SETS
            .iter()
            .map(|(n, t)| Self::from_toml_str(t, n))
            .collect()
    }

    /// A set from a TOML file.
    pub fn from_path(path: &std::path::Path) -> Result<Self, MeasureError> {
        let text = std::fs::read_to_string(path).map_err(|source| MeasureError::Io {
            path: path.display().to_string(),
            source,
        })?;
        Self::from_toml_str(&text, &path.display().to_string())
    }

    /// A built-in set if `name_or_path` names one, else the file at that path.
    pub fn load(name_or_path: &str) -> Result<Self, MeasureError> {
        if BUILTIN_SETS.iter().any(|(n, _)| *n == name_or_path) {
            return Self::builtin(name_or_path);
        }
        let path = std::path::Path::new(name_or_path);
        if path.is_file() {
            return Self::from_path(path);
        }
        Err(unknown_set(name_or_path))
    }

    /// Parses and validates a set; `origin` (set name or file path) is used in errors.
    pub fn from_toml_str(text: &str, origin: &str) -> Result<Self, MeasureError> {
        let table: toml::Table = toml::from_str(text).map_err(|e| MeasureError::Parse {
            set: origin.to_string(),
            message: e.to_string(),
        })?;
        let set_err = |problem: String| MeasureError::Set {
            set: origin.to_string(),
            problem,
        };
        for key in table.keys() {
            if key != "set" && key != "measurement" {
                return Err(set_err(format!(
                    "unknown top-level key `{key}`; a set file has a `[set]` table and `[[measurement]]` entries{}",
                    did_you_mean(key, ["set", "measurement"])
                )));
            }
        }
        let header = table
            .get("set")
            .and_then(|v| v.as_table())
            .ok_or_else(|| set_err("missing `[set]` table with `name` and `description`".into()))?;
        let mut header_fields = Fields::new(header, origin, 0, "[set]");
        let name = header_fields.string("name")?;
        let description = header_fields.string("description")?;
        header_fields.finish()?;
        let entries = match table.get("measurement") {
            Some(toml::Value::Array(a)) => a,
            Some(_) => return Err(set_err(
                "`measurement` must be an array of tables: write each entry as `[[measurement]]`"
                    .into(),
            )),
            None => return Err(set_err("the set has no `[[measurement]]` entries".into())),
        };
        if entries.is_empty() {
            return Err(set_err("the set has no `[[measurement]]` entries".into()));
        }
        let mut definitions: Vec<Definition> = Vec::with_capacity(entries.len());
        for (i, entry) in entries.iter().enumerate() {
            let t = entry.as_table().ok_or_else(|| MeasureError::Definition {
                set: origin.to_string(),
                index: i + 1,
                name: "?".into(),
                problem: "an entry must be a table (`[[measurement]]`)".into(),
            })?;
            let def = parse_definition(t, origin, i + 1)?;
            if let Some(prev) = definitions.iter().position(|d| d.name == def.name) {
                return Err(MeasureError::Definition {
                    set: origin.to_string(),
                    index: i + 1,
                    name: def.name,
                    problem: format!("duplicate name: entry #{} has the same name", prev + 1),
                });
            }
            definitions.push(def);
        }
        Ok(Self {
            name,
            description,
            definitions,
        })
    }

    /// Number of measurements.
    pub fn len(&self) -> usize {
        self.definitions.len()
    }

    /// Whether the set has no measurements (never true for a loaded set).
    pub fn is_empty(&self) -> bool {
        self.definitions.is_empty()
    }

    /// Index of the measurement named `name`.
    pub fn index_of(&self, name: &str) -> Option<usize> {
        self.definitions.iter().position(|d| d.name == name)
    }

    /// The groups in order of first appearance: `(group name, member indices)`.
    pub fn groups(&self) -> Vec<(String, Vec<usize>)> {
        let mut out: Vec<(String, Vec<usize>)> = Vec::new();
        for (i, d) in self.definitions.iter().enumerate() {
            if let Some(g) = &d.group {
                match out.iter_mut().find(|(n, _)| n == g) {
                    Some((_, v)) => v.push(i),
                    None => out.push((g.clone(), vec![i])),
                }
            }
        }
        out
    }
}

fn unknown_set(name: &str) -> MeasureError {
    MeasureError::UnknownSet {
        name: name.to_string(),
        available: BUILTIN_SETS
            .iter()
            .map(|(n, _)| *n)
            .collect::<Vec<_>>()
            .join(", "),
        suggestion: did_you_mean(name, BUILTIN_SETS.iter().map(|(n, _)| *n)),
    }
}

#[cfg(test)]
mod tests;
