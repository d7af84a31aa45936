//! Populations of adult bodies whose measurements follow ANSUR II's train
//! split.
//!
//! [`generate_population`] draws, for each body, a train-split subject aged
//! 18-90 (sex by `male_fraction`), sets sex, age and race from the record,
//! adds small random local variation (every non-`measure-*` local change
//! drawn from N(0, `local_variation_sd`)), then fits the generator's
//! continuous parameters to that subject's real dimensions ([`FIT_TARGETS`])
//! with the one generator fitter ([`crate::fit`]: damped Gauss-Newton with
//! exact derivatives, measurement gradients from the supports chained with
//! the generator's Jacobian). The result records, per body, the subject id,
//! the parameters and the fitted and achieved values. [`FitScope`] says
//! which dimensions: the twelve, every one the standing mesh can follow,
//! or those with the hip and waist sections squared too
//! ([`crate::sections`], whose coefficients the records hold).
//!
//! The same seed and settings give the same file, byte for byte: every
//! random draw comes from a ChaCha8 stream seeded per body, with integer and
//! inclusive draws through [`crate::seeded`].

use std::collections::BTreeMap;

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use tapeshape_body::{age_from_years, BodyModel, LocalChanges, Param, Phenotype};
use tapeshape_measure::{CompiledSet, MeasurementSet};
use tapeshape_mesh::Vec3;

use crate::ansur::{Ansur, Sex, Split, Subject};
use crate::fit::{FitOptions, Free, FreeField, GeneratorFitter, Stop};
use crate::format::{
    created_by, BodyRecord, Dataset, DatasetHeader, DatasetKind, FitRecord, FORMAT_VERSION,
};
use crate::{seeded, DatasetError};

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

/// With [`FitScope::Ansur`], these `ansur` dimensions are fitted too, each
/// with a local change that shapes it (prior SD 0.6): the breadths, depths,
/// landmark heights and lengths that the twelve leave to the generator's
/// own correlations, which differ from real people's (issue 12: a
/// regression on such a population's measurements predicts real people's
/// other dimensions no better than the body, 19.7 mm against 9.2 mm).
/// Symmetric or central changes only, so that the bodies stay symmetric.
/// Not fitted: what a standing skin mesh cannot measure as ANSUR II does
/// (chest and bicristal breadth are taken with the caliper compressing the
/// tissue, the biceps girth flexed; docs/measurements.md): fitting the
/// mesh's skin-to-skin value to them would bend the body towards a
/// different quantity (the estimator's `CANNOT_FOLLOW_ANSUR`).
pub const EXTRA_FIT_TARGETS: &[(&str, &str)] = &[
    ("chestdepth", "torso-scale-depth-incr"),
    ("hipbreadth", "hip-scale-horiz-incr"),
    ("buttockdepth", "buttocks-volume-incr"),
    ("waistdepth", "stomach-navel-out"),
    ("waistbreadth", "hip-waist-up"),
    ("neckcircumferencebase", "measure-neck-circ-incr"),
    ("suprasternaleheight", "measure-neck-height-incr"),
    ("cervicaleheight", "measure-napetowaist-dist-incr"),
    ("waistheightomphalion", "measure-waisttohip-dist-incr"),
    ("shoulderlength", "torso-vshape-incr"),
    ("interscyei", "torso-muscle-dorsi-incr"),
    ("headcircumference", "head-scale-horiz-incr"),
    ("headlength", "head-scale-depth-incr"),
    ("mentonsellionlength", "head-scale-vert-incr"),
];

/// With [`FitScope::AnsurSections`], these are fitted too, their drivers
/// free after the macro parameters and the belly: the buttock height,
/// which on the template lies 87 mm above the crotch where ANSUR II's
/// subjects have 42 mm (men) and 51 mm (women), lowered against the crotch
/// by the hip's vertical scale (docs/results/real-customers.md).
pub const SECTION_FIT_TARGETS: &[(&str, &str)] = &[("buttockheight", "hip-scale-vert-incr")];

/// Prior SD of a section field's coefficient ([`crate::sections`], units of
/// [`crate::sections::UNIT_M`]): a loose hold, since one unit moves the
/// average man's girth-to-ellipse ratio by about 0.027 (the
/// `cross_sections` example) and real people's spreads by 0.017-0.019
/// (SD) around a mean the template is 0.06 below.
const SECTION_PRIOR_SD: f64 = 1.0;

/// Bounds of a section field's coefficient: from 10 mm rounder to 30 mm
/// squarer at the diagonals.
const SECTION_RANGE: (f64, f64) = (-1.0, 3.0);

/// Which dimensions each body is fitted to.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
pub enum FitScope {
    /// The twelve [`FIT_TARGETS`] (the populations before issue 12).
    #[default]
    Twelve,
    /// [`FIT_TARGETS`] and [`EXTRA_FIT_TARGETS`].
    Ansur,
    /// [`FitScope::Ansur`]'s targets and [`SECTION_FIT_TARGETS`], with the
    /// hip and waist section fields of [`crate::sections`] free: bodies
    /// whose hip and waist sections can have a real person's girth,
    /// breadth and depth at once (docs/population.md).
    AnsurSections,
}

impl FitScope {
    /// The (ANSUR column, driving parameter) pairs fitted.
    pub fn targets(self) -> Vec<(&'static str, &'static str)> {
        match self {
            FitScope::Twelve => FIT_TARGETS.to_vec(),
            FitScope::Ansur => FIT_TARGETS
                .iter()
                .chain(EXTRA_FIT_TARGETS)
                .copied()
                .collect(),
            FitScope::AnsurSections => FIT_TARGETS
                .iter()
                .chain(EXTRA_FIT_TARGETS)
                .chain(SECTION_FIT_TARGETS)
                .copied()
                .collect(),
        }
    }

    /// Whether the section fields are free.
    pub fn sections(self) -> bool {
        self == FitScope::AnsurSections
    }
}

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
    /// Which dimensions are fitted (files written before it existed: the
    /// twelve).
    #[serde(default)]
    pub fit: FitScope,
}

impl Default for PopulationSettings {
    fn default() -> Self {
        Self {
            n: 400,
            seed: 1,
            male_fraction: 0.5,
            local_variation_sd: 0.15,
            max_iterations: 25,
            fit: FitScope::Twelve,
        }
    }
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
fn fit_problem(
    set: &CompiledSet,
    targets: &[(&str, &str)],
) -> Result<(Vec<usize>, Vec<Free>), DatasetError> {
    let mut index = Vec::new();
    let mut free = Vec::new();
    let mut last = Vec::new();
    let local =
        |label: &str| Param::local(label).map_err(|e| DatasetError::Settings(e.to_string()));
    for (column, driver) in targets {
        index.push(set.set().index_of(column).ok_or_else(|| {
            DatasetError::Settings(format!("the ansur measurement set has no {column:?}"))
        })?);
        if SECTION_FIT_TARGETS.contains(&(*column, *driver)) {
            last.push(Free {
                param: local(driver)?,
                prior_sd: 0.6,
            });
            continue;
        }
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
    free.extend(last);
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
    let fit_targets = settings.fit.targets();
    let (index, free) = fit_problem(&set, &fit_targets)?;
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
    let fitter = if settings.fit.sections() {
        let fields = crate::sections::section_fields(body)?;
        fitter.with_fields(&[&fields.hip, &fields.waist].map(|field| FreeField {
            field,
            prior_sd: SECTION_PRIOR_SD,
            range: SECTION_RANGE,
        }))?
    } else {
        fitter
    };
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
            let target: Vec<f64> = fit_targets
                .iter()
                .map(|(c, _)| s.dim(c).unwrap_or(f64::NAN))
                .collect();
            let targets: Vec<(usize, f64)> = index.iter().copied().zip(target.clone()).collect();
            let fitted = fitter.fit(&targets, &[(ph, lc)])?;
            let (ph, lc, mesh, achieved, iterations, section_fields) = (
                fitted.phenotype,
                fitted.local_changes,
                fitted.mesh,
                fitted.values,
                fitted.iterations,
                fitted.field_coefficients,
            );
            let fit = FitRecord {
                target_mm: fit_targets
                    .iter()
                    .zip(&target)
                    .map(|((c, _), t)| (c.to_string(), t * 1000.0))
                    .collect(),
                achieved_mm: fit_targets
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
                section_fields,
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

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::statistics::CHECKED_COLUMNS;

    pub(crate) fn small_population(n: usize, seed: u64) -> Dataset {
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

    /// With the section fields free, each record holds their coefficients
    /// and its mesh is the generator's body with them added; the buttock
    /// height and the breadths are fitted; without them, nothing is
    /// recorded.
    #[test]
    fn a_sections_population_records_its_fields() {
        let settings = PopulationSettings {
            n: 3,
            seed: 5,
            fit: FitScope::AnsurSections,
            ..Default::default()
        };
        let d = generate_population(&settings, &|_, _| {}).unwrap();
        let body = BodyModel::shared().unwrap();
        let fields = crate::sections::section_fields(body).unwrap();
        let mut squared = 0;
        for (r, v) in d.header.bodies.iter().zip(&d.bodies) {
            assert_eq!(r.section_fields.len(), 2, "{}", r.name);
            let (lo, hi) = SECTION_RANGE;
            assert!(r.section_fields.iter().all(|c| (lo..=hi).contains(c)));
            squared += usize::from(r.section_fields.iter().any(|c| *c > 0.1));
            let mut lc = LocalChanges::new();
            for (k, v) in &r.local_changes {
                lc.set(k, *v).unwrap();
            }
            let mut x = body.generate(&r.phenotype.unwrap(), &lc).unwrap().vertices;
            for (p, (h, w)) in x.iter_mut().zip(fields.hip.iter().zip(&fields.waist)) {
                for a in 0..3 {
                    p[a] += r.section_fields[0] * h[a] + r.section_fields[1] * w[a];
                }
            }
            // The stored mesh is f32.
            let gap = x
                .iter()
                .zip(v)
                .map(|(a, b)| (0..3).map(|k| (a[k] - b[k]).abs()).fold(0.0, f64::max))
                .fold(0.0, f64::max);
            assert!(gap < 1e-6, "{}: {gap} m", r.name);
            let fit = r.fit.as_ref().unwrap();
            for c in ["buttockheight", "hipbreadth", "waistdepth"] {
                assert!(fit.target_mm.contains_key(c), "{c} not fitted");
            }
        }
        // Real people's sections are squarer than the template's: the fit
        // uses the fields.
        assert!(
            squared >= 2,
            "{:?}",
            d.header
                .bodies
                .iter()
                .map(|r| &r.section_fields)
                .collect::<Vec<_>>()
        );
        assert!(small_population(1, 5).header.bodies[0]
            .section_fields
            .is_empty());
    }
}
