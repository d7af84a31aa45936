//! Databases of registered bodies: generation from ANSUR II, faces, import of
//! a user's own meshes, and the dataset file format.
//!
//! # Population
//!
//! [`generate_population`] makes adult bodies whose measurements follow ANSUR
//! II's **train split**. For each body it draws a train-split subject aged
//! 18-90 (sex by `male_fraction`), sets sex, age and race from the record,
//! adds small random local variation (every non-`measure-*` local change
//! drawn from N(0, `local_variation_sd`)), then fits the generator's
//! continuous parameters to that subject's real dimensions ([`FIT_TARGETS`])
//! with the one generator fitter ([`crate::fit`]: damped Gauss-Newton with
//! exact derivatives, measurement gradients from the supports chained with
//! the generator's Jacobian). The result records, per body, the subject id, the
//! parameters and the fitted and achieved values.
//!
//! # File format (`.tsd`, version 1)
//!
//! Little endian throughout.
//!
//! | bytes | content |
//! |---|---|
//! | 8 | magic `TSDATAST` |
//! | 4 | format version (u32) = 1 |
//! | 8 | header length H (u64) |
//! | H | header, UTF-8 JSON ([`DatasetHeader`]): kind, recipe (seed, settings), per-body records, template counts |
//! | 12 F | faces, `F x 3` u32 (F = `header.n_faces`) |
//! | 12 N V | vertices, body-major, `N x V x 3` f32, **metres, station frame (Z up, +Y front, +X the body's right, feet at z = 0)** |
//!
//! f32 storage keeps a 400-body file at 66 MB; its round-off (< 0.25 um for
//! coordinates below 2 m) is far below any tolerance the engine works to.
//! Files are written atomically (temporary file, fsync, rename).

use std::collections::BTreeMap;
use std::io::Read;
use std::path::{Path, PathBuf};
use std::sync::Arc;

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use tapeshape_body::{age_from_years, BodyModel, LocalChanges, Param, Phenotype};
use tapeshape_measure::{CompiledSet, MeasurementSet};
use tapeshape_mesh::{Mesh, Topology, Vec3};

use crate::ansur::{Ansur, Sex, Split, Subject};
use crate::fit::{FitOptions, Free, GeneratorFitter, Stop};
use crate::seeded;

/// Magic bytes at the start of a dataset file.
pub const MAGIC: &[u8; 8] = b"TSDATAST";
/// Current dataset format version.
pub const FORMAT_VERSION: u32 = 1;

/// ANSUR dimensions the population fit matches, each with the generator
/// parameter that mainly drives it (`None`: a macro parameter below).
///
/// Every name is both an ANSUR II column and a measurement of the `ansur` set.
pub const FIT_TARGETS: &[(&str, &str)] = &[
    ("stature", "@height"),
    ("chestcircumference", "measure-bust-circ-incr"),
    ("waistcircumference", "measure-waist-circ-incr"),
    ("buttockcircumference", "measure-hips-circ-incr"),
    ("crotchheight", "measure-upperleg-height-incr"),
    ("kneeheightmidpatella", "measure-lowerleg-height-incr"),
    ("thighcircumference", "measure-thigh-circ-incr"),
    ("calfcircumference", "measure-calf-circ-incr"),
    ("biacromialbreadth", "measure-shoulder-dist-incr"),
    ("acromionradialelength", "measure-upperarm-length-incr"),
    ("radialestylionlength", "measure-lowerarm-length-incr"),
    ("wristcircumference", "measure-wrist-circ-incr"),
];

/// Macro parameters the fit may move besides height, with their prior SD.
const FREE_MACROS: &[(Param, f64)] = &[
    (Param::Weight, 0.35),
    (Param::Muscle, 0.35),
    (Param::Proportions, 0.35),
];

/// Local changes the fit may also move (prior SD 0.5): a belly, which the
/// `measure-*` changes and the weight cannot give a body whose waist reaches
/// its chest.
const FREE_LOCALS: &[&str] = &["stomach-pregnant-incr"];

/// Errors making, reading or writing datasets.
#[derive(Debug, thiserror::Error)]
pub enum DatasetError {
    /// File system error with the path involved.
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// The error.
        source: std::io::Error,
    },
    /// Not a dataset file, or a damaged one.
    #[error("{path} is not a readable tapeshape dataset: {message}")]
    Format {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        message: String,
    },
    /// An imported mesh does not match the others.
    #[error("{path}: {message}")]
    Import {
        /// The offending file.
        path: PathBuf,
        /// What is wrong.
        message: String,
    },
    /// Bad settings.
    #[error("invalid setting: {0}")]
    Settings(String),
    /// The body generator failed.
    #[error(transparent)]
    Body(#[from] tapeshape_body::BodyError),
    /// A measurement failed.
    #[error(transparent)]
    Measure(#[from] tapeshape_measure::MeasureError),
    /// ANSUR II could not be read.
    #[error(transparent)]
    Ansur(#[from] crate::ansur::AnsurError),
    /// The generator fit failed.
    #[error(transparent)]
    Fit(#[from] crate::fit::FitError),
}

/// What a dataset holds.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum DatasetKind {
    /// Whole adult bodies in the template topology.
    Population,
    /// The head region of bodies whose faces vary; `vertex_map` says which
    /// template vertex each vertex is.
    Faces,
    /// A user's own registered meshes.
    Imported,
}

/// How a population or face dataset was made.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PopulationSettings {
    /// Number of bodies.
    pub n: usize,
    /// Random seed (the same seed and settings give the same file).
    pub seed: u64,
    /// Share of men, 0..=1.
    pub male_fraction: f64,
    /// SD of the random local variation added before fitting (local-change units).
    pub local_variation_sd: f64,
    /// Gauss-Newton iterations at most per body.
    pub max_iterations: usize,
}

impl Default for PopulationSettings {
    fn default() -> Self {
        Self {
            n: 400,
            seed: 1,
            male_fraction: 0.5,
            local_variation_sd: 0.15,
            max_iterations: 25,
        }
    }
}

/// The result of fitting one body to its subject.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct FitRecord {
    /// Target per fitted dimension (mm, the subject's real value).
    pub target_mm: BTreeMap<String, f64>,
    /// Value measured on the generated body (mm).
    pub achieved_mm: BTreeMap<String, f64>,
    /// Largest |achieved - target| (mm).
    pub max_error_mm: f64,
    /// Gauss-Newton iterations used.
    pub iterations: usize,
}

/// One body of a dataset.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct BodyRecord {
    /// Stable name within the dataset.
    pub name: String,
    /// Sex, where known.
    pub sex: Option<Sex>,
    /// ANSUR II subject the body was fitted to.
    pub ansur_subject: Option<u32>,
    /// Age in years, where known.
    pub age_years: Option<f64>,
    /// Generator macro parameters (generated datasets).
    pub phenotype: Option<Phenotype>,
    /// Generator local changes, label -> value (generated datasets).
    pub local_changes: BTreeMap<String, f64>,
    /// Fit of the body to its subject (populations).
    pub fit: Option<FitRecord>,
    /// The file an imported mesh came from.
    pub source_file: Option<String>,
}

/// The JSON header of a dataset file.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct DatasetHeader {
    /// [`FORMAT_VERSION`] of the writer.
    pub format_version: u32,
    /// What the dataset holds.
    pub kind: DatasetKind,
    /// Program and version that wrote it.
    pub created_by: String,
    /// Vertices per body.
    pub n_vertices: usize,
    /// Triangles of the shared topology.
    pub n_faces: usize,
    /// For [`DatasetKind::Faces`]: template vertex index of each vertex.
    pub vertex_map: Option<Vec<u32>>,
    /// How it was made (generated datasets).
    pub settings: Option<PopulationSettings>,
    /// One record per body, in storage order.
    pub bodies: Vec<BodyRecord>,
}

/// A dataset in memory: bodies over one shared topology.
#[derive(Debug, Clone)]
pub struct Dataset {
    /// Header (records, provenance).
    pub header: DatasetHeader,
    /// Shared topology of every body.
    pub topology: Arc<Topology>,
    /// Vertex positions per body, metres, station frame; `N x V`.
    pub bodies: Vec<Vec<Vec3>>,
}

impl Dataset {
    /// Number of bodies.
    pub fn len(&self) -> usize {
        self.bodies.len()
    }

    /// True when the dataset has no bodies.
    pub fn is_empty(&self) -> bool {
        self.bodies.is_empty()
    }

    /// Body `i` as a mesh.
    pub fn mesh(&self, i: usize) -> Mesh {
        Mesh {
            vertices: self.bodies[i].clone(),
            topology: self.topology.clone(),
        }
    }

    /// Writes the dataset to `path` with the one atomic, fsynced write
    /// ([`tapeshape_common::fs::write_atomic_with`], streamed: a 400-body
    /// file is 66 MB).
    pub fn write(&self, path: &Path) -> Result<(), DatasetError> {
        let header = serde_json::to_vec(&self.header).expect("dataset header serialises");
        tapeshape_common::fs::write_atomic_with(path, |w| {
            w.write_all(MAGIC)?;
            w.write_all(&FORMAT_VERSION.to_le_bytes())?;
            w.write_all(&(header.len() as u64).to_le_bytes())?;
            w.write_all(&header)?;
            for f in self.topology.faces() {
                for &v in f {
                    w.write_all(&v.to_le_bytes())?;
                }
            }
            for body in &self.bodies {
                for p in body {
                    for &c in p {
                        w.write_all(&(c as f32).to_le_bytes())?;
                    }
                }
            }
            Ok(())
        })
        .map_err(|source| DatasetError::Io {
            path: path.to_path_buf(),
            source,
        })
    }

    /// Reads a dataset file, checking magic, version and sizes.
    pub fn read(path: &Path) -> Result<Dataset, DatasetError> {
        let bad = |message: String| DatasetError::Format {
            path: path.to_path_buf(),
            message,
        };
        let mut bytes = Vec::new();
        std::fs::File::open(path)
            .and_then(|mut f| f.read_to_end(&mut bytes))
            .map_err(|source| DatasetError::Io {
                path: path.to_path_buf(),
                source,
            })?;
        if bytes.len() < 20 || &bytes[..8] != MAGIC {
            return Err(bad("it does not start with the dataset magic bytes (make one with `tapeshape dataset generate` or `tapeshape dataset import`)".into()));
        }
        let version = u32::from_le_bytes(bytes[8..12].try_into().expect("4 bytes"));
        if version != FORMAT_VERSION {
            return Err(bad(format!(
                "format version {version}; this program reads version {FORMAT_VERSION}"
            )));
        }
        let hlen = u64::from_le_bytes(bytes[12..20].try_into().expect("8 bytes")) as usize;
        let hend = 20usize
            .checked_add(hlen)
            .filter(|&e| e <= bytes.len())
            .ok_or_else(|| bad("the header runs past the end of the file".into()))?;
        let header: DatasetHeader =
            serde_json::from_slice(&bytes[20..hend]).map_err(|e| bad(format!("header: {e}")))?;
        let (nv, nf, nb) = (header.n_vertices, header.n_faces, header.bodies.len());
        let expected = nf
            .checked_mul(12)
            .and_then(|f| nb.checked_mul(nv)?.checked_mul(12)?.checked_add(f))
            .and_then(|x| x.checked_add(hend))
            .ok_or_else(|| bad("sizes in the header overflow".into()))?;
        if bytes.len() != expected {
            return Err(bad(format!("{} bytes, but the header ({nb} bodies, {nv} vertices, {nf} faces) needs {expected}: the file is truncated or damaged", bytes.len())));
        }
        let mut at = hend;
        let u32_at = |at: &mut usize| {
            let v = u32::from_le_bytes(bytes[*at..*at + 4].try_into().expect("4 bytes"));
            *at += 4;
            v
        };
        let faces: Vec<[u32; 3]> = (0..nf)
            .map(|_| [u32_at(&mut at), u32_at(&mut at), u32_at(&mut at)])
            .collect();
        let topology = Topology::new(nv, faces).map_err(|e| bad(format!("faces: {e}")))?;
        let mut bodies = Vec::with_capacity(nb);
        for b in 0..nb {
            let mut body = Vec::with_capacity(nv);
            for _ in 0..nv {
                let mut p = [0.0; 3];
                for c in &mut p {
                    *c = f32::from_le_bytes(bytes[at..at + 4].try_into().expect("4 bytes")) as f64;
                    at += 4;
                }
                if !p.iter().all(|c| c.is_finite()) {
                    return Err(bad(format!("body {b} has a non-finite coordinate")));
                }
                body.push(p);
            }
            bodies.push(body);
        }
        Ok(Dataset {
            header,
            topology: Arc::new(topology),
            bodies,
        })
    }
}

fn created_by() -> String {
    format!("tapeshape-engine {}", env!("CARGO_PKG_VERSION"))
}

/// Race weights from an ANSUR `DODRace` code (1 White, 2 Black, 3 Hispanic,
/// 4 Asian, others mixed): (african, asian, caucasian). The MakeHuman race
/// targets are coarse; Hispanic is taken as mostly caucasian with some of
/// both others, every other code as an equal mix.
pub fn race_weights(dod_race: u32) -> (f64, f64, f64) {
    match dod_race {
        1 => (0.0, 0.0, 1.0),
        2 => (1.0, 0.0, 0.0),
        3 => (0.2, 0.2, 0.6),
        4 => (0.0, 1.0, 0.0),
        _ => (1.0 / 3.0, 1.0 / 3.0, 1.0 / 3.0),
    }
}

/// The population's generator fit: the [`FIT_TARGETS`] of the `ansur` set
/// (compiled for the template) and the parameters they drive, with their
/// prior SDs: 1 for the height, 0.6 for each `measure-*` driver, the
/// [`FREE_MACROS`] and [`FREE_LOCALS`] with theirs. Returns each target's
/// index in `set` and the free parameters.
fn fit_problem(set: &CompiledSet) -> Result<(Vec<usize>, Vec<Free>), DatasetError> {
    let mut index = Vec::new();
    let mut free = Vec::new();
    let local =
        |label: &str| Param::local(label).map_err(|e| DatasetError::Settings(e.to_string()));
    for (column, driver) in FIT_TARGETS {
        index.push(set.set().index_of(column).ok_or_else(|| {
            DatasetError::Settings(format!("the ansur measurement set has no {column:?}"))
        })?);
        free.push(if *driver == "@height" {
            Free {
                param: Param::Height,
                prior_sd: 1.0,
            }
        } else {
            Free {
                param: local(driver)?,
                prior_sd: 0.6,
            }
        });
    }
    for &(param, prior_sd) in FREE_MACROS {
        free.push(Free { param, prior_sd });
    }
    for l in FREE_LOCALS {
        free.push(Free {
            param: local(l)?,
            prior_sd: 0.5,
        });
    }
    Ok((index, free))
}

/// A population body stops fitting when every target is within this many
/// metres of its subject's value (0.2 mm).
const FIT_TOLERANCE_M: f64 = 0.2e-3;

/// Draws `n` train-split subjects aged 18..=90, men with probability
/// `male_fraction`, without replacement per sex while subjects last.
fn draw_subjects<'a>(
    ansur: &'a Ansur,
    settings: &PopulationSettings,
    rng: &mut ChaCha8Rng,
) -> Vec<&'a Subject> {
    let mut pools: BTreeMap<Sex, Vec<&Subject>> = BTreeMap::new();
    for sex in [Sex::Male, Sex::Female] {
        let mut v: Vec<&Subject> = ansur
            .subjects(Some(sex), Split::Train)
            .filter(|s| (18.0..=90.0).contains(&s.age_years))
            .collect();
        // Fisher-Yates with our seeded generator, drawing each index with
        // `seeded` so that the order does not depend on rand's internals.
        for i in (1..v.len()).rev() {
            let j = seeded::index_in_inclusive(rng, 0..=i);
            v.swap(i, j);
        }
        pools.insert(sex, v);
    }
    let mut next: BTreeMap<Sex, usize> = BTreeMap::new();
    (0..settings.n)
        .map(|_| {
            let sex = if rng.random_bool(settings.male_fraction) {
                Sex::Male
            } else {
                Sex::Female
            };
            let pool = &pools[&sex];
            let k = next.entry(sex).or_insert(0);
            let s = pool[*k % pool.len()];
            *k += 1;
            s
        })
        .collect()
}

/// Generates a population of `settings.n` bodies fitted to ANSUR II
/// train-split subjects (see the module docs). `progress(done, total)` is
/// called as bodies finish (from worker threads).
pub fn generate_population(
    settings: &PopulationSettings,
    progress: &(dyn Fn(usize, usize) + Sync),
) -> Result<Dataset, DatasetError> {
    if settings.n == 0 {
        return Err(DatasetError::Settings("--n must be at least 1".into()));
    }
    if !(0.0..=1.0).contains(&settings.male_fraction) {
        return Err(DatasetError::Settings(format!(
            "male fraction {} is not in 0..=1",
            settings.male_fraction
        )));
    }
    let body = BodyModel::shared()?;
    let ansur = Ansur::get()?;
    let set = MeasurementSet::builtin("ansur")?
        .compile(body.topology(), &tapeshape_body::anatomy::anatomy())?;
    let (index, free) = fit_problem(&set)?;
    let fitter = GeneratorFitter::new(
        body,
        &set,
        &free,
        FitOptions {
            max_iterations: settings.max_iterations,
            stop: Stop {
                misfit_m: FIT_TOLERANCE_M,
                min_relative_gain: 0.0,
                min_step: 0.0,
            },
        },
    )?;
    let mut rng = ChaCha8Rng::seed_from_u64(settings.seed);
    let subjects = draw_subjects(ansur, settings, &mut rng);
    let done = std::sync::atomic::AtomicUsize::new(0);
    let variation: Vec<&String> = LocalChanges::labels()
        .iter()
        .filter(|l| !l.starts_with("measure-") && !FREE_LOCALS.contains(&l.as_str()))
        .collect();
    let results: Vec<Result<(BodyRecord, Vec<Vec3>), DatasetError>> = subjects
        .par_iter()
        .enumerate()
        .map(|(i, s)| {
            let mut rng = ChaCha8Rng::seed_from_u64(
                settings.seed ^ (0x9e37_79b9_7f4a_7c15u64.wrapping_mul(i as u64 + 1)),
            );
            let (african, asian, caucasian) = race_weights(s.dod_race);
            let stature = s.dim("stature").unwrap_or(1.7);
            let male = s.sex == Sex::Male;
            let mut ph = Phenotype {
                gender: if male { 0.0 } else { 1.0 },
                age: age_from_years(s.age_years.clamp(18.0, 90.0))
                    .expect("age clamped to the adult range"),
                height: ((stature - if male { 1.353 } else { 1.219 }) / 1.09).clamp(0.0, 1.0),
                african,
                asian,
                caucasian,
                cupsize: if male {
                    0.5
                } else {
                    rng.random_range(0.3..0.7)
                },
                firmness: if male {
                    0.5
                } else {
                    rng.random_range(0.3..0.7)
                },
                ..Phenotype::default()
            };
            // Start (and prior centre) of the weight parameter from the
            // subject's body-mass index: 0.5 at BMI 25, 0 at 15, 1 at 35.
            let bmi = s.mass_kg / (stature * stature);
            ph.weight = (0.5 + (bmi - 25.0) / 20.0).clamp(0.0, 1.0);
            ph.muscle = 0.5;
            ph.proportions = 0.5;
            let mut lc = LocalChanges::new();
            if settings.local_variation_sd > 0.0 {
                let normal = Normal::new(0.0, settings.local_variation_sd).expect("positive sd");
                for label in &variation {
                    lc.set(label, normal.sample(&mut rng).clamp(-1.0, 1.0))
                        .expect("label from the list");
                }
            }
            let target: Vec<f64> = FIT_TARGETS
                .iter()
                .map(|(c, _)| s.dim(c).unwrap_or(f64::NAN))
                .collect();
            let targets: Vec<(usize, f64)> = index.iter().copied().zip(target.clone()).collect();
            let fitted = fitter.fit(&targets, &[(ph, lc)])?;
            let (ph, lc, mesh, achieved, iterations) = (
                fitted.phenotype,
                fitted.local_changes,
                fitted.mesh,
                fitted.values,
                fitted.iterations,
            );
            let fit = FitRecord {
                target_mm: FIT_TARGETS
                    .iter()
                    .zip(&target)
                    .map(|((c, _), t)| (c.to_string(), t * 1000.0))
                    .collect(),
                achieved_mm: FIT_TARGETS
                    .iter()
                    .zip(&achieved)
                    .map(|((c, _), v)| (c.to_string(), v * 1000.0))
                    .collect(),
                max_error_mm: achieved
                    .iter()
                    .zip(&target)
                    .map(|(a, t)| (a - t).abs() * 1000.0)
                    .fold(0.0, f64::max),
                iterations,
            };
            let record = BodyRecord {
                name: format!("body-{i:04}"),
                sex: Some(s.sex),
                ansur_subject: Some(s.id),
                age_years: Some(s.age_years),
                phenotype: Some(ph),
                local_changes: lc.iter().map(|(k, v)| (k.to_string(), v)).collect(),
                fit: Some(fit),
                source_file: None,
            };
            progress(
                done.fetch_add(1, std::sync::atomic::Ordering::Relaxed) + 1,
                settings.n,
            );
            Ok((record, mesh.vertices))
        })
        .collect();
    let mut records = Vec::with_capacity(settings.n);
    let mut bodies = Vec::with_capacity(settings.n);
    for r in results {
        let (rec, v) = r?;
        records.push(rec);
        bodies.push(v);
    }
    let topology = body.topology().clone();
    Ok(Dataset {
        header: DatasetHeader {
            format_version: FORMAT_VERSION,
            kind: DatasetKind::Population,
            created_by: created_by(),
            n_vertices: topology.n_vertices(),
            n_faces: topology.faces().len(),
            vertex_map: None,
            settings: Some(settings.clone()),
            bodies: records,
        },
        topology,
        bodies,
    })
}

/// ANSUR columns whose statistics a population must follow (issue 3: per
/// sex, means within 2 %, SDs within 15 %, correlations within 0.15).
pub const CHECKED_COLUMNS: &[&str] = &[
    "stature",
    "chestcircumference",
    "waistcircumference",
    "buttockcircumference",
];

/// Statistics of one sex: population (measured on the meshes) beside ANSUR
/// II's train split. Units: metres; correlations dimensionless.
#[derive(Debug, Clone, Serialize)]
pub struct SexStatistics {
    /// Which sex.
    pub sex: Sex,
    /// Bodies of this sex in the dataset.
    pub n_bodies: usize,
    /// Train-split subjects of this sex aged 18-90.
    pub n_ansur: usize,
    /// Column names, in order.
    pub columns: Vec<String>,
    /// Population mean per column.
    pub mean: Vec<f64>,
    /// ANSUR train mean per column.
    pub ansur_mean: Vec<f64>,
    /// Population SD per column.
    pub sd: Vec<f64>,
    /// ANSUR train SD per column.
    pub ansur_sd: Vec<f64>,
    /// Population correlation matrix.
    pub corr: Vec<Vec<f64>>,
    /// ANSUR train correlation matrix.
    pub ansur_corr: Vec<Vec<f64>>,
}

impl SexStatistics {
    /// Largest relative mean difference, largest relative SD difference and
    /// largest absolute correlation difference.
    pub fn worst(&self) -> (f64, f64, f64) {
        let k = self.columns.len();
        let dm = (0..k)
            .map(|j| (self.mean[j] / self.ansur_mean[j] - 1.0).abs())
            .fold(0.0, f64::max);
        let ds = (0..k)
            .map(|j| (self.sd[j] / self.ansur_sd[j] - 1.0).abs())
            .fold(0.0, f64::max);
        let dc = (0..k)
            .flat_map(|a| (0..k).map(move |b| (a, b)))
            .map(|(a, b)| (self.corr[a][b] - self.ansur_corr[a][b]).abs())
            .fold(0.0, f64::max);
        (dm, ds, dc)
    }

    /// True when the bounds hold (2 %, 15 %, 0.15).
    pub fn within_bounds(&self) -> bool {
        let (dm, ds, dc) = self.worst();
        dm <= 0.02 && ds <= 0.15 && dc <= 0.15
    }
}

/// Measures [`CHECKED_COLUMNS`] on every body of a population (with the
/// `ansur` set) and compares per sex with ANSUR II's train split.
pub fn population_statistics(dataset: &Dataset) -> Result<Vec<SexStatistics>, DatasetError> {
    let body = BodyModel::shared()?;
    let anatomy = tapeshape_body::anatomy::anatomy();
    if dataset.topology.n_vertices() != body.topology().n_vertices() {
        return Err(DatasetError::Settings(
            "population statistics need bodies in the template topology".into(),
        ));
    }
    let set = MeasurementSet::builtin("ansur")?.compile(body.topology(), &anatomy)?;
    let idx: Vec<usize> = CHECKED_COLUMNS
        .iter()
        .map(|c| {
            set.set()
                .index_of(c)
                .ok_or_else(|| DatasetError::Settings(format!("the ansur set has no {c:?}")))
        })
        .collect::<Result<_, _>>()?;
    let values: Vec<Result<Vec<f64>, DatasetError>> = dataset
        .bodies
        .par_iter()
        .map(|b| {
            idx.iter()
                .map(|&i| Ok(set.measure_one(i, b)?.value))
                .collect()
        })
        .collect();
    let values: Vec<Vec<f64>> = values.into_iter().collect::<Result<_, _>>()?;
    let ansur = Ansur::get()?;
    let mut out = Vec::new();
    for sex in [Sex::Male, Sex::Female] {
        let rows: Vec<Vec<f64>> = dataset
            .header
            .bodies
            .iter()
            .zip(&values)
            .filter(|(r, _)| r.sex == Some(sex))
            .map(|(_, v)| v.clone())
            .collect();
        if rows.len() < 3 {
            continue;
        }
        let subjects: Vec<&Subject> = ansur
            .subjects(Some(sex), Split::Train)
            .filter(|s| (18.0..=90.0).contains(&s.age_years))
            .collect();
        let (mean, sd, corr) = crate::stats::mean_sd_corr(&rows);
        let (ansur_mean, ansur_sd, ansur_corr) =
            crate::ansur::statistics(&subjects, CHECKED_COLUMNS);
        out.push(SexStatistics {
            sex,
            n_bodies: rows.len(),
            n_ansur: subjects.len(),
            columns: CHECKED_COLUMNS.iter().map(|c| c.to_string()).collect(),
            mean,
            ansur_mean,
            sd,
            ansur_sd,
            corr,
            ansur_corr,
        });
    }
    Ok(out)
}

/// The statistics as a Markdown table (mm, relative differences, worst correlation gap).
pub fn statistics_markdown(stats: &[SexStatistics]) -> String {
    let mut s = String::new();
    for st in stats {
        let (dm, ds, dc) = st.worst();
        s += &format!(
            "\n### {:?}: {} bodies vs {} ANSUR II train-split subjects\n\n| dimension | mean (mm) | ANSUR mean | diff | SD (mm) | ANSUR SD | diff |\n|---|---:|---:|---:|---:|---:|---:|\n",
            st.sex, st.n_bodies, st.n_ansur
        );
        for j in 0..st.columns.len() {
            s += &format!(
                "| {} | {:.1} | {:.1} | {:+.2} % | {:.1} | {:.1} | {:+.1} % |\n",
                st.columns[j],
                st.mean[j] * 1000.0,
                st.ansur_mean[j] * 1000.0,
                (st.mean[j] / st.ansur_mean[j] - 1.0) * 100.0,
                st.sd[j] * 1000.0,
                st.ansur_sd[j] * 1000.0,
                (st.sd[j] / st.ansur_sd[j] - 1.0) * 100.0
            );
        }
        s += "\nCorrelations, population (ANSUR):\n\n| | ";
        s += &st.columns.join(" | ");
        s += " |\n|---|";
        s += &"---:|".repeat(st.columns.len());
        s += "\n";
        for a in 0..st.columns.len() {
            s += &format!("| {} |", st.columns[a]);
            for b in 0..st.columns.len() {
                s += &format!(" {:.2} ({:.2}) |", st.corr[a][b], st.ansur_corr[a][b]);
            }
            s += "\n";
        }
        s += &format!(
            "\nWorst: mean {:.2} % (bound 2 %), SD {:.1} % (bound 15 %), correlation {:.3} (bound 0.15): {}\n",
            dm * 100.0,
            ds * 100.0,
            dc,
            if st.within_bounds() { "within bounds" } else { "OUT OF BOUNDS" }
        );
    }
    s
}

/// Reads an OBJ or PLY mesh, chosen by extension (case-insensitive).
pub fn read_mesh(path: &Path) -> Result<Mesh, DatasetError> {
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase);
    let opts = tapeshape_mesh::io::ReadOptions::default();
    let res = match ext.as_deref() {
        Some("obj") => tapeshape_mesh::io::read_obj(path, opts),
        Some("ply") => tapeshape_mesh::io::read_ply(path, opts),
        _ => {
            return Err(DatasetError::Import {
                path: path.to_path_buf(),
                message: "not an .obj or .ply file".into(),
            })
        }
    };
    res.map_err(|e| DatasetError::Import {
        path: path.to_path_buf(),
        message: e.to_string(),
    })
}

/// Imports every `.obj` / `.ply` file in `dir` (sorted by file name) as a
/// dataset of registered meshes. All must share one topology (same vertex
/// count and the same triangles in the same order); the first file that
/// differs is named in the error. Units are taken as metres, station frame.
pub fn import_dir(dir: &Path) -> Result<Dataset, DatasetError> {
    let io = |source| DatasetError::Io {
        path: dir.to_path_buf(),
        source,
    };
    let mut files: Vec<PathBuf> = std::fs::read_dir(dir)
        .map_err(io)?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| {
            p.extension()
                .and_then(|e| e.to_str())
                .is_some_and(|e| e.eq_ignore_ascii_case("obj") || e.eq_ignore_ascii_case("ply"))
        })
        .collect();
    files.sort();
    if files.is_empty() {
        return Err(DatasetError::Import {
            path: dir.to_path_buf(),
            message: "no .obj or .ply files in this folder".into(),
        });
    }
    let first = read_mesh(&files[0])?;
    let mut records = Vec::new();
    let mut bodies = Vec::new();
    for (i, f) in files.iter().enumerate() {
        let m = if i == 0 { first.clone() } else { read_mesh(f)? };
        if m.vertices.len() != first.vertices.len() {
            return Err(DatasetError::Import {
                path: f.clone(),
                message: format!(
                    "{} vertices, but {} has {}: every mesh must be registered to the same topology",
                    m.vertices.len(),
                    files[0].display(),
                    first.vertices.len()
                ),
            });
        }
        if let Some(k) = (0..first.faces().len().max(m.faces().len()))
            .find(|&k| first.faces().get(k) != m.faces().get(k))
        {
            return Err(DatasetError::Import {
                path: f.clone(),
                message: format!(
                    "triangle {k} differs from {} ({} vs {} triangles): every mesh must share the same triangles in the same order",
                    files[0].display(),
                    m.faces().len(),
                    first.faces().len()
                ),
            });
        }
        if let Some(v) = m
            .vertices
            .iter()
            .position(|p| !p.iter().all(|c| c.is_finite()))
        {
            return Err(DatasetError::Import {
                path: f.clone(),
                message: format!("vertex {v} is not finite"),
            });
        }
        records.push(BodyRecord {
            name: f
                .file_stem()
                .map(|s| s.to_string_lossy().into_owned())
                .unwrap_or_else(|| format!("mesh-{i}")),
            sex: None,
            ansur_subject: None,
            age_years: None,
            phenotype: None,
            local_changes: BTreeMap::new(),
            fit: None,
            source_file: Some(f.display().to_string()),
        });
        bodies.push(m.vertices);
    }
    let topology = first.topology.clone();
    Ok(Dataset {
        header: DatasetHeader {
            format_version: FORMAT_VERSION,
            kind: DatasetKind::Imported,
            created_by: created_by(),
            n_vertices: topology.n_vertices(),
            n_faces: topology.faces().len(),
            vertex_map: None,
            settings: None,
            bodies: records,
        },
        topology,
        bodies,
    })
}

/// Regions of the local changes that shape the face.
pub const FACE_REGIONS: &[&str] = &[
    "cheek", "chin", "ears", "eyebrows", "eyes", "forehead", "head", "mouth", "nose",
];

/// Labels of the local changes in the [`FACE_REGIONS`], read from the
/// committed `local_changes.tsv` (column 3 is the region).
pub fn face_local_changes() -> Vec<String> {
    const TSV: &str = include_str!("../../body/assets/makehuman/local_changes.tsv");
    TSV.lines()
        .filter(|l| !l.starts_with('#'))
        .filter_map(|l| {
            let cols: Vec<&str> = l.split('\t').collect();
            (cols.len() > 2 && FACE_REGIONS.contains(&cols[2])).then(|| cols[1].to_string())
        })
        .collect()
}

/// The head region of the template: the `head` part's triangles, re-indexed.
/// Returns (vertex map: new -> template index, faces in new indices).
pub fn head_region(
    topology: &Topology,
    anatomy: &tapeshape_mesh::Anatomy,
) -> Result<(Vec<u32>, Vec<[u32; 3]>), DatasetError> {
    let tris = anatomy
        .parts
        .get("head")
        .ok_or_else(|| DatasetError::Settings("the template anatomy has no `head` part".into()))?;
    let mut map: Vec<u32> = tris
        .iter()
        .flat_map(|&t| topology.faces()[t as usize])
        .collect();
    map.sort_unstable();
    map.dedup();
    let faces = tris
        .iter()
        .map(|&t| {
            topology.faces()[t as usize]
                .map(|v| map.binary_search(&v).expect("vertex of a head triangle") as u32)
        })
        .collect();
    Ok((map, faces))
}

/// Remaps a template anatomy onto a sub-mesh given by `vertex_map` (new ->
/// template vertex) and the sub-mesh's faces: landmarks outside the region
/// are dropped, parts keep the triangles whose three vertices are inside.
pub fn remap_anatomy(
    anatomy: &tapeshape_mesh::Anatomy,
    template: &Topology,
    vertex_map: &[u32],
    faces: &[[u32; 3]],
) -> tapeshape_mesh::Anatomy {
    let new_of = |v: u32| vertex_map.binary_search(&v).ok().map(|i| i as u32);
    let landmarks = anatomy
        .landmarks
        .iter()
        .filter_map(|(k, &v)| Some((k.clone(), new_of(v)?)))
        .collect();
    let face_index: BTreeMap<[u32; 3], u32> = faces
        .iter()
        .enumerate()
        .map(|(i, f)| (*f, i as u32))
        .collect();
    let parts = anatomy
        .parts
        .iter()
        .map(|(k, tris)| {
            let kept: Vec<u32> = tris
                .iter()
                .filter_map(|&t| {
                    let f = template.faces()[t as usize];
                    let g = [new_of(f[0])?, new_of(f[1])?, new_of(f[2])?];
                    face_index.get(&g).copied()
                })
                .collect();
            (k.clone(), kept)
        })
        .filter(|(_, v): &(String, Vec<u32>)| !v.is_empty())
        .collect();
    tapeshape_mesh::Anatomy { landmarks, parts }
}

/// Generates `settings.n` faces: random adults (sex, age 18-90, race mix)
/// whose face local changes ([`FACE_REGIONS`]) are drawn uniformly from
/// [-0.8, 0.8], cropped to the template's head region. The dataset's
/// `vertex_map` gives each vertex's template index, so the template's
/// landmarks (and the `face7` set) carry over with [`remap_anatomy`].
pub fn generate_faces(
    settings: &PopulationSettings,
    progress: &(dyn Fn(usize, usize) + Sync),
) -> Result<Dataset, DatasetError> {
    if settings.n == 0 {
        return Err(DatasetError::Settings("--n must be at least 1".into()));
    }
    let body = BodyModel::shared()?;
    let anatomy = tapeshape_body::anatomy::anatomy();
    let (map, faces) = head_region(body.topology(), &anatomy)?;
    let labels = face_local_changes();
    let done = std::sync::atomic::AtomicUsize::new(0);
    let results: Vec<Result<(BodyRecord, Vec<Vec3>), DatasetError>> = (0..settings.n)
        .into_par_iter()
        .map(|i| {
            let mut rng = ChaCha8Rng::seed_from_u64(
                settings.seed ^ (0xd1b5_4a32_d192_ed03u64.wrapping_mul(i as u64 + 1)),
            );
            let male = rng.random_bool(settings.male_fraction);
            let years = seeded::uniform_inclusive(&mut rng, 18.0..=90.0);
            let ph = Phenotype {
                gender: if male { 0.0 } else { 1.0 },
                age: age_from_years(years).expect("adult age"),
                african: rng.random_range(0.0..1.0),
                asian: rng.random_range(0.0..1.0),
                caucasian: rng.random_range(0.0..1.0),
                muscle: rng.random_range(0.3..0.7),
                weight: rng.random_range(0.3..0.7),
                ..Phenotype::default()
            };
            let mut lc = LocalChanges::new();
            for l in &labels {
                lc.set(l, seeded::uniform_inclusive(&mut rng, -0.8..=0.8))
                    .expect("label from the list");
            }
            let mesh = body.generate(&ph, &lc)?;
            let vertices = map.iter().map(|&v| mesh.vertices[v as usize]).collect();
            progress(
                done.fetch_add(1, std::sync::atomic::Ordering::Relaxed) + 1,
                settings.n,
            );
            Ok((
                BodyRecord {
                    name: format!("face-{i:04}"),
                    sex: Some(if male { Sex::Male } else { Sex::Female }),
                    ansur_subject: None,
                    age_years: Some(years),
                    phenotype: Some(ph),
                    local_changes: lc.iter().map(|(k, v)| (k.to_string(), v)).collect(),
                    fit: None,
                    source_file: None,
                },
                vertices,
            ))
        })
        .collect();
    let mut records = Vec::new();
    let mut bodies = Vec::new();
    for r in results {
        let (rec, v) = r?;
        records.push(rec);
        bodies.push(v);
    }
    let topology = Arc::new(
        Topology::new(map.len(), faces).map_err(|e| DatasetError::Settings(e.to_string()))?,
    );
    Ok(Dataset {
        header: DatasetHeader {
            format_version: FORMAT_VERSION,
            kind: DatasetKind::Faces,
            created_by: created_by(),
            n_vertices: map.len(),
            n_faces: topology.faces().len(),
            vertex_map: Some(map),
            settings: Some(settings.clone()),
            bodies: records,
        },
        topology,
        bodies,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn small_population(n: usize, seed: u64) -> Dataset {
        let s = PopulationSettings {
            n,
            seed,
            ..Default::default()
        };
        generate_population(&s, &|_, _| {}).unwrap()
    }

    #[test]
    fn population_bodies_follow_their_subjects() {
        let d = small_population(8, 11);
        let ansur = Ansur::get().unwrap();
        let mut worst = Vec::new();
        for (r, v) in d.header.bodies.iter().zip(&d.bodies) {
            let id = r.ansur_subject.unwrap();
            assert_ne!(id % 4, 0, "a test-split subject was used for fitting");
            let s = ansur.subject(id).unwrap();
            assert_eq!(Some(s.sex), r.sex);
            let fit = r.fit.as_ref().unwrap();
            // The four dimensions the population statistics are judged on.
            let w = CHECKED_COLUMNS
                .iter()
                .map(|c| (fit.achieved_mm[*c] - s.dim(c).unwrap() * 1000.0).abs())
                .fold(0.0, f64::max);
            // No body is grossly off, even where the generator's range runs out.
            assert!(w < 60.0, "{}: {w:.1} mm off", r.name);
            worst.push(w);
            // Feet on the floor.
            let minz = v.iter().map(|p| p[2]).fold(f64::INFINITY, f64::min);
            assert!(minz.abs() < 1e-9, "{minz}");
        }
        // Fitting happened: without it the errors are tens of millimetres.
        // (A smoke test on 8 bodies; the statistics of 200 bodies are checked
        // in tests/population_statistics.rs, 1,000 in docs/population.md.)
        worst.sort_by(f64::total_cmp);
        let mean = worst.iter().sum::<f64>() / worst.len() as f64;
        assert!(mean < 6.0, "mean worst error {mean:.1} mm: {worst:?}");
        assert!(
            worst.iter().filter(|&&w| w < 1.0).count() >= 3,
            "fewer than 3 of 8 bodies within 1 mm: {worst:?}"
        );
        // Deterministic: the same seed gives the same bodies.
        let again = small_population(2, 11);
        assert_eq!(again.header.bodies[..2], d.header.bodies[..2]);
        assert_eq!(again.bodies[0], d.bodies[0]);
    }

    #[test]
    fn file_round_trip_and_damage_is_detected() {
        let d = small_population(2, 3);
        let dir = std::env::temp_dir().join(format!("tapeshape-ds-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("pop.tsd");
        d.write(&path).unwrap();
        let back = Dataset::read(&path).unwrap();
        assert_eq!(back.header, d.header);
        assert_eq!(back.topology.faces(), d.topology.faces());
        for (a, b) in back.bodies.iter().zip(&d.bodies) {
            for (p, q) in a.iter().zip(b) {
                for k in 0..3 {
                    assert!((p[k] - q[k]).abs() < 2.5e-7, "f32 storage error too large");
                }
            }
        }
        // Truncated and foreign files are clear errors, not panics.
        let bytes = std::fs::read(&path).unwrap();
        std::fs::write(&path, &bytes[..bytes.len() - 5]).unwrap();
        let e = Dataset::read(&path).unwrap_err().to_string();
        assert!(e.contains("truncated"), "{e}");
        std::fs::write(&path, b"hello, not a dataset at all").unwrap();
        let e = Dataset::read(&path).unwrap_err().to_string();
        assert!(e.contains("magic"), "{e}");
        std::fs::remove_dir_all(&dir).ok();
    }

    #[test]
    fn import_checks_topology_and_names_the_file() {
        let body = BodyModel::shared().unwrap();
        let dir = std::env::temp_dir().join(format!("tapeshape-import-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let a = body.template();
        let mut b = a.clone();
        b.vertices.iter_mut().for_each(|p| p[0] *= 1.1);
        tapeshape_mesh::io::write_obj(&a, dir.join("a.obj")).unwrap();
        tapeshape_mesh::io::write_ply(&b, dir.join("b.ply"), Default::default()).unwrap();
        let d = import_dir(&dir).unwrap();
        assert_eq!(d.len(), 2);
        assert_eq!(d.header.bodies[1].name, "b");
        for (p, q) in d.bodies[1].iter().zip(&b.vertices) {
            assert!((p[0] - q[0]).abs() < 1e-9);
        }
        // A mesh with other triangles is rejected, naming that file.
        let other = Mesh::from_faces(
            vec![[0.0; 3], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]],
            vec![[0, 1, 2]],
        )
        .unwrap();
        tapeshape_mesh::io::write_obj(&other, dir.join("c.obj")).unwrap();
        let e = import_dir(&dir).unwrap_err().to_string();
        assert!(e.contains("c.obj"), "{e}");
        std::fs::remove_dir_all(&dir).ok();
        let empty =
            std::env::temp_dir().join(format!("tapeshape-import-empty-{}", std::process::id()));
        std::fs::create_dir_all(&empty).unwrap();
        assert!(import_dir(&empty)
            .unwrap_err()
            .to_string()
            .contains("no .obj or .ply"));
        std::fs::remove_dir_all(&empty).ok();
    }

    #[test]
    fn faces_vary_only_in_the_head_and_carry_the_face_landmarks() {
        let s = PopulationSettings {
            n: 3,
            seed: 5,
            ..Default::default()
        };
        let d = generate_faces(&s, &|_, _| {}).unwrap();
        let map = d.header.vertex_map.clone().unwrap();
        assert_eq!(map.len(), d.header.n_vertices);
        assert!(
            map.len() < 13_718 / 2,
            "head region too large: {}",
            map.len()
        );
        assert_ne!(d.bodies[0], d.bodies[1]);
        let body = BodyModel::shared().unwrap();
        let anatomy = tapeshape_body::anatomy::anatomy();
        let sub = remap_anatomy(&anatomy, body.topology(), &map, d.topology.faces());
        for l in ["pronasale", "menton", "tragion_left", "exocanthion_right"] {
            assert!(
                sub.landmarks.contains_key(l),
                "{l} missing from the head region"
            );
        }
        let face7 = MeasurementSet::builtin("face7")
            .unwrap()
            .compile(&d.topology, &sub)
            .unwrap();
        let v = face7.measure(&d.bodies[0]).unwrap();
        assert_eq!(v.len(), 7);
        assert!(v.iter().all(|m| m.value > 0.01 && m.value < 0.5));
        assert!(face_local_changes().iter().any(|l| l.starts_with("nose-")));
    }
}
