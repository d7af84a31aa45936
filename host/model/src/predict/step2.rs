//! Step 2: local deformation beyond the learned space (paper, section Shape
//! Refinement: "minimizing E_m with respect to p_i").
//!
//! `s` rounds ([`super::rounds`]) of: measure the shape, set per-segment
//! targets, minimise `(1 - lambda) E_m + lambda E_s` over all 3V vertex
//! coordinates with L-BFGS, `E_s` the smoothness of the displacement from
//! the step-1 shape. A reading with a tolerance wider than the reference
//! was weighed against the prior and the other readings in step 1; step 2
//! keeps the value step 1 gave it (as its target) instead of bending the
//! surface towards the doubtful reading, which a strong per-measurement
//! weight would otherwise do. A soft target (a statistic of real people
//! for what was not measured) is aimed
//! [`super::Step2Settings::soft_pull`] of the way from its step-1 value to
//! its own, so step 2 can carry the unmeasured dimensions where the learned
//! space could not; a soft breadth or depth (a caliper) is held at its
//! step-1 value instead (see `is_caliper`).
//!
//! Each round starts from a re-measured shape, and where supports jump
//! (a hull gains points, a cut curve moves to the shoulder) a round can end
//! worse than it began. A step 2 that ends with a higher `E_m` than step 1
//! left (each evaluated with targets set on its own shape) keeps, with a
//! warning, the shape with the lowest `E_m` it measured: a round's start,
//! or the step-1 shape. (Before, the step-1 shape was the only fallback, so
//! one last round that went wrong threw away all of step 2: 3 of 40 ANSUR
//! II subjects then missed nearly every reading,
//! `docs/results/predict-iso.md`.) A non-finite mesh is an error.
//!
//! A solver tried first ([`super::Step2Settings::first`]; the default tries
//! the smooth basis) runs all of the above once; its body is kept only when
//! every reading ends within its continuation threshold and it did not fall
//! back to an earlier shape ([`Step2First`] in the report says which).
//! Otherwise the step runs again with the solver on the same objective
//! (`E_s` from the step-1 shape, the result compared with step 1's
//! energy), its rounds starting from the first solver's body, which meets
//! most readings with a smooth displacement and leaves the solver only the
//! rest: on 50 ANSUR II test-split people entered with their 39 fitted
//! `ansur` survey values, 99.74 % of the readings within ISO 20685-1 and 108
//! triangles flipped, against 99.54 % and 136 starting again from the
//! step-1 shape (`docs/results/real-customers.md`). A first body that fell
//! back to an earlier shape is no start: the solver then starts from the
//! step-1 shape.
//!
//! Last, the fold repair ([`super::Step2Settings::fold_repair`],
//! `predict/folds.rs`): where the body folds triangles of the step-1 shape,
//! their neighbourhood's displacement is smoothed, the landmarks of
//! straight readings held, and kept where no reading within its allowable
//! error falls out; what is still folded is then moved as one piece, and
//! the held landmarks of the triangles still folded are let go (part of
//! the way where all the way pushes a reading out). On the 50 people
//! above: 108 flipped triangles -> 17, 99.7 % of the readings within ISO
//! 20685-1 either way; on all 1,505, 4,466 -> 1,078, 99.6 % either way.
//!
//! Where soft targets were pulled ([`super::Step2Settings::soft_pull`] above
//! 0) and the repaired body still folds (flipped or collapsed triangles, or
//! more than `folds::CREASES_ALLOWED` edges whose fold grew by more than
//! `folds::CREASE_DEG` from the step-1 shape: ridges the repair does not
//! see), all of the above runs again with a smaller share of the pull
//! (`SOFT_PULL_SHARES`), and the body that folds least is kept (fewest
//! folded triangles, then fewest creased edges beyond those allowed), with
//! [`Warning::SoftPullReduced`] when it is not the first: the readings are
//! the customer, the soft targets a statistic.
//!
//! Then, on the body kept, the fold repair's last resort
//! (`ShapeModel::unfold_over_readings`): where triangles are still folded,
//! their neighbourhood is moved as one piece and blended into the body
//! around it, the readings it pushes beyond their allowable error named
//! ([`Warning::SurfaceOverReadings`]): the surface wins over the readings
//! (a smaller soft pull, which costs no reading, was tried first).
//!
//! Before all of this, with the fold repair on, a step-1 shape that flips
//! more than `UNFOLD_STEP1_ABOVE` triangles of the model's mean shape is
//! smoothed there (`ShapeModel::unfold_step1`): a linear shape space can
//! fold the surface far along a few components. The report's step-1 values
//! are measured on that shape.

use tapeshape_measure::Measured;
use tapeshape_mesh::vec3::{add, scale, sub};
use tapeshape_mesh::{Topology, Vec3};

use super::folds;
use super::progress::{in_run, in_run_every, PredictObserver, PredictProgress, PredictStage};
use super::readings::Readings;
use super::rounds::{run_rounds, thresholds, RoundEnd, RoundLog, RoundStep, RoundsSummary};
use super::settings::{EnergyWeighting, RoundsConfig, SmoothFit, Step2Config, Step2Method};
use super::step1::Step1Shape;
use super::terms::{to_m, to_mm};
use super::warning::Warning;
use super::Measurer;
use crate::gauss_newton::{minimise_vertices, SymbolicCache};
use crate::lbfgs::{minimise_watched, RunInfo, Termination};
use crate::reduced::{minimise_reduced, ReducedObjective};
use crate::refine::VertexObjective;
use crate::smooth_basis::SmoothBasis;
use crate::{ModelError, Result, ShapeModel, MM_PER_M};

/// Step 2's result: the final mesh and the readings measured on it.
#[derive(Debug, Clone)]
pub struct Step2Shape {
    /// The mesh (V vertices, metres, station frame, template topology).
    pub vertices: Vec<Vec3>,
    /// The given readings measured on it, in the order of the readings.
    pub measured: Vec<Measured>,
    /// The targets step 2 fitted (a doubtful reading's step-1 value, see
    /// the module docs).
    pub readings: Readings,
    /// One per L-BFGS run.
    pub runs: Vec<RunInfo>,
    /// How the rounds went.
    pub rounds: RoundsSummary,
    /// Things the operator or engineer should know.
    pub warnings: Vec<Warning>,
    /// How the solver tried first went ([`Step2Config`]'s `first`; `None`
    /// where none was).
    pub first: Option<Step2First>,
}

/// How step 2's first solver went ([`super::Step2Settings::first`]).
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Step2First {
    /// Its result was kept (every reading within its threshold).
    pub kept: bool,
    /// Readings (not soft targets) its result left beyond their threshold.
    pub misses: usize,
    /// Why it could not run, where it could not (then step 2 ran the
    /// solver alone).
    #[serde(default)]
    pub error: Option<String>,
}

/// Step 2 as the round driver sees it.
struct Step2Rounds<'a> {
    model: &'a ShapeModel,
    measurer: &'a dyn Measurer,
    readings: &'a Readings,
    which: Vec<usize>,
    config: &'a Step2Config,
    edges: &'a [[u32; 2]],
    /// The readings measured on the shape the rounds start from.
    start_measured: &'a [Measured],
    /// The step-1 shape (flat, 3V, mm), `E_s`'s reference.
    reference_mm: Vec<f64>,
    /// The current vertices (flat, 3V, mm) and as points.
    x_mm: Vec<f64>,
    p_mm: Vec<Vec3>,
    /// The lowest `E_m` among the rounds' starts (round > 0): the round,
    /// the energy, the shape (mm) and its readings.
    best: Option<(usize, f64, Vec<f64>, Vec<Measured>)>,
    /// The Gauss-Newton solver's symbolic factorisation, kept between rounds.
    symbolic: SymbolicCache,
    /// The smooth-basis solver's basis (each round solves for `x = x_mm + B C`).
    smooth: Option<std::sync::Arc<SmoothBasis>>,
    /// Without polishing: the coefficients of `x_mm - reference_mm` in it.
    smooth_c: Option<Vec<f64>>,
}

impl RoundStep for Step2Rounds<'_> {
    const STAGE: PredictStage = PredictStage::Step2;

    fn max_iterations(&self) -> u64 {
        self.config.solver.max_iters()
    }

    fn measure(&mut self, round: usize) -> Result<Vec<Measured>> {
        self.p_mm = self
            .x_mm
            .chunks_exact(3)
            .map(|c| [c[0], c[1], c[2]])
            .collect();
        if round == 0 {
            return Ok(self.start_measured.to_vec());
        }
        let measured = self
            .model
            .measure_checked(self.measurer, &to_m(&self.p_mm), &self.which)?;
        let e =
            self.model
                .stage_energy_mm(self.readings, &measured, &self.p_mm, self.config.weighting);
        if self.best.as_ref().is_none_or(|b| e < b.1) {
            self.best = Some((round, e, self.x_mm.clone(), measured.clone()));
        }
        Ok(measured)
    }

    fn minimise(
        &mut self,
        _round: usize,
        measured: &[Measured],
        at: PredictProgress,
        observer: &dyn PredictObserver,
        log: &mut RoundLog,
    ) -> Result<RoundEnd> {
        let (terms, owner) = self.model.build_terms_owned(
            self.readings,
            measured,
            &self.p_mm,
            self.config.weighting,
            &mut log.warnings,
            PredictStage::Step2,
        );
        if terms.is_empty() {
            return Ok(RoundEnd::NothingToFit);
        }
        let lambda = self.config.lambda;
        let watch = in_run_every(observer, at, 1);
        let run = match (&self.config.solver, self.smooth.as_mut()) {
            (Step2Method::Lbfgs(solver), _) => minimise_watched(
                &VertexObjective::new(terms, self.edges, &self.reference_mm, lambda)
                    .with_bending(self.config.bending),
                self.x_mm.clone(),
                solver,
                &in_run(observer, at),
            ),
            (Step2Method::GaussNewton(stop), _) => minimise_vertices(
                &VertexObjective::new(terms, self.edges, &self.reference_mm, lambda)
                    .with_bending(self.config.bending),
                self.x_mm.clone(),
                stop,
                &mut self.symbolic,
                &watch,
            ),
            (
                Step2Method::SmoothBasis {
                    stop,
                    polish,
                    fit,
                    min_decrease_mm,
                    ..
                },
                Some(basis),
            ) => {
                // Without polishing every shape of the rounds is
                // reference + B c: the smoothness terms follow from c.
                let mut obj = match (&self.smooth_c, polish) {
                    (Some(c0), None) => {
                        ReducedObjective::with_offset(terms.clone(), basis, &self.x_mm, c0, lambda)
                    }
                    _ => ReducedObjective::new(
                        terms.clone(),
                        basis,
                        self.edges,
                        &self.reference_mm,
                        &self.x_mm,
                        lambda,
                    ),
                };
                if *fit == SmoothFit::Readings {
                    obj = obj.fit_readings(&owner);
                }
                // The settings checked `w` positive.
                if let (EnergyWeighting::PerMeasurement, w) = self.config.weighting {
                    obj = obj.with_reading_energy(w);
                }
                match minimise_reduced(&obj, vec![0.0; obj.len()], stop, *min_decrease_mm, &watch) {
                    Ok((c, info)) if info.reason != Termination::Interrupted => {
                        let mut x = vec![0.0; self.x_mm.len()];
                        obj.vertices(&self.x_mm, &c, &mut x);
                        if let Some(c0) = self.smooth_c.as_mut() {
                            c0.iter_mut().zip(&c).for_each(|(t, d)| *t += d);
                        }
                        match polish {
                            Some(solver) => {
                                log.runs.push(info);
                                minimise_watched(
                                    &VertexObjective::new(
                                        terms,
                                        self.edges,
                                        &self.reference_mm,
                                        lambda,
                                    ),
                                    x,
                                    solver,
                                    &in_run(observer, at),
                                )
                            }
                            None => Ok((x, info)),
                        }
                    }
                    other => other,
                }
            }
            (Step2Method::SmoothBasis { .. }, None) => {
                return Err(ModelError::Numerical(
                    "step 2: the smooth basis was not prepared".into(),
                ))
            }
        };
        match run {
            Ok((_, info)) if info.reason == Termination::Interrupted => {
                Err(ModelError::Cancelled(at.to_string()))
            }
            Ok((x_new, info)) => {
                self.x_mm = x_new;
                log.runs.push(info);
                Ok(RoundEnd::Ran)
            }
            Err(e) => Ok(RoundEnd::Failed(e)),
        }
    }
}

/// Whether a measurement's support is a caliper: an extent along a
/// horizontal axis (a breadth or depth; a height's axis is +Z). Its value
/// is the distance between the two extreme points of a cut's hull, so
/// step 2, which moves the vertices of those two points, lets the cut's
/// other points bulge past them, and with the cut's girth given a
/// narrower breadth is a deeper section: a soft target pulled half the
/// way on hip breadth (364 -> 354 mm, hip girth held at 1,000 mm) left
/// buttock depth 20 mm deeper, away from its own target, step 2 ended
/// above step 1's energy and kept the step-1 shape. So step 2 holds a soft
/// caliper target at its step-1 value; step 1, which moves the whole body
/// in the learned space, has already followed it as far as the body can
/// (`docs/results/real-customers.md`, 2026-12-06).
fn is_caliper(support: &tapeshape_measure::Support) -> bool {
    support.axis.is_some_and(|a| a[2].abs() < 0.5)
}

/// Whether step 2 pulls reading `g` (measured `m` on the step-1 shape) as a
/// soft target: a soft target looser than the reference tolerance that is
/// not a caliper. Every other reading looser than the reference, a caliper
/// soft target among them, is held at its step-1 value.
fn soft_and_pulled(g: &super::readings::Reading, m: &Measured) -> bool {
    g.soft && g.weight < 1.0 && !is_caliper(&m.support)
}

/// The shares of [`super::Step2Settings::soft_pull`] step 2 runs with, in
/// turn, while its body (after the fold repair) still folds triangles of the
/// step-1 shape or has more than `folds::CREASES_ALLOWED` creased edges;
/// the body that folds least is kept (fewest flipped or collapsed
/// triangles, then fewest creased edges beyond those allowed), the first
/// of equals.
/// Why: a soft target is a statistic of real people, not the customer, and
/// following it all the way can pull the surface through itself (the crotch
/// path, the navel, the head: on all 1,505 ANSUR II test-split people
/// entered with their `quick` values and sex, a full pull folded 90
/// triangles on 11 bodies of the embedded model); the readings are met
/// either way, so such a body follows the statistics as far as its surface
/// allows (docs/results/sex-check.md, "Soft targets all the way, where the
/// surface allows").
const SOFT_PULL_SHARES: [f64; 3] = [1.0, 0.5, 0.0];

/// How many times the fold repair starts again with more supports held.
const FOLD_REPAIR_ATTEMPTS: usize = 3;

/// How many times the fold repair lets go of the held landmarks of the
/// triangles still folded.
const FOLD_RELEASE_PASSES: usize = 2;

/// The parts of the way towards the body smoothed with those landmarks let
/// go that the repair tries, the largest first.
const FOLD_RELEASE_PARTS: [f64; 8] = [1.0, 0.875, 0.75, 0.625, 0.5, 0.375, 0.25, 0.125];

/// The widest neighbourhood (rings around the folded triangles) the fold
/// repair's last resort moves as one piece (`folds::translate_regions`).
const LAST_RESORT_RINGS: usize = 8;

/// How many triangles of the model's mean shape the step-1 shape may fold
/// before it is smoothed (`ShapeModel::unfold_step1`). Why 20: a few of the
/// template's slivers flip on many bodies, generated ones too (the 50
/// held-out generated bodies of `docs/results/predict-sreal.md` flip 154
/// against the mean between them), and smoothing those moved the S_real
/// vertex distance from 13.89 to 13.90 mm; on 1,500 ANSUR II
/// *train-split* people (`quick`, with sex;
/// `host/eval/examples/train_creases.rs`)
/// the step-1 shape flips none on 1,008, at most 6 on nine in ten, more than
/// 20 on 33, and 81 and 96 on the two whose bodies failed the surface check.
const UNFOLD_STEP1_ABOVE: usize = 20;

/// Marks the vertices of `m`'s support points (both ends of each point's
/// edge) in `pinned`.
fn hold(pinned: &mut [bool], m: &Measured) {
    for p in &m.support.points {
        pinned[p.a as usize] = true;
        pinned[p.b as usize] = true;
    }
}

/// The vertices (of `n`) a smoothing holds: the landmarks of the straight
/// readings (one segment or none) among `readings`, measured as `measured`.
/// A straight reading's value is its landmarks' positions: they stay. A
/// girth's hull or a path's route is found again on the smoothed body. A
/// soft target is a statistic, not the customer: its landmarks are not
/// held.
fn straight_landmarks(readings: &Readings, measured: &[Measured], n: usize) -> Vec<bool> {
    let mut pinned = vec![false; n];
    for (_, m) in readings
        .iter()
        .zip(measured)
        .filter(|(g, m)| !g.soft && m.support.segments.len() <= 1)
    {
        hold(&mut pinned, m);
    }
    pinned
}

/// Per reading of `readings` (measured as `measured`, one per reading),
/// whether it is within its allowable error: the measurer's, else
/// [`FOLD_REPAIR_DEFAULT_MM`]; a soft target always counts as within.
fn within_allowable(
    readings: &Readings,
    measured: &[Measured],
    measurer: &dyn Measurer,
) -> Vec<bool> {
    readings
        .iter()
        .zip(measured)
        .map(|(g, m)| {
            if g.soft {
                return true;
            }
            let allowable = measurer
                .allowable_error(g.index)
                .map_or(FOLD_REPAIR_DEFAULT_MM, |a| a * MM_PER_M);
            (m.value * MM_PER_M - g.target_mm).abs() <= allowable
        })
        .collect()
}

/// The readings (indices) within their allowable error `before` and not
/// `now` (one flag per reading each, as [`within_allowable`] gives them).
fn fallen_out(before: &[bool], now: &[bool]) -> Vec<usize> {
    before
        .iter()
        .zip(now)
        .enumerate()
        .filter(|(_, (b, n))| **b && !**n)
        .map(|(i, _)| i)
        .collect()
}

/// How many of `readings` (soft targets left out) `measured` (one per
/// reading) leaves beyond their limit in `limits` (mm, one per reading, as
/// [`thresholds`] gives them).
pub(crate) fn misses(readings: &Readings, measured: &[Measured], limits: &[f64]) -> usize {
    readings
        .iter()
        .zip(measured)
        .zip(limits)
        .filter(|((g, m), t)| !g.soft && (m.value * MM_PER_M - g.target_mm).abs() > **t)
        .count()
}

/// How much a soft-pull try's body folds, to be compared as a tuple (less
/// is better): its `folded` triangles (flipped or collapsed) first, then
/// its `creased` edges where more than `folds::CREASES_ALLOWED`. Why this
/// order: a flipped triangle is a surface through itself, which no reading
/// excuses; a few creases more are a rougher surface.
fn fold_rank(folded: usize, creased: usize) -> (usize, usize) {
    let excess = if creased > folds::CREASES_ALLOWED {
        creased
    } else {
        0
    };
    (folded, excess)
}

/// The fold repair's last resort on `x` (V vertices, metres), which folds
/// `left` triangles of `reference` (the step-1 shape) that smoothing with
/// the readings held could not unfold: smoothed first with nothing held
/// where `smooth_first`, then the neighbourhood of what is still folded
/// moved as one piece (`folds::translate_regions`, the mean of its `held`
/// vertices where it has any), blended over 0 to [`LAST_RESORT_RINGS`]
/// rings, each kept while it folds fewer. Returns the smallest part of the
/// way towards that body ([`FOLD_RELEASE_PARTS`]) that folds no more, and
/// how many it folds; `None` where it does not unfold all of what was left
/// or at least half of it (then no reading is given up for it).
fn last_resort(
    topology: &Topology,
    reference: &[Vec3],
    x: &[Vec3],
    left: usize,
    smooth_first: bool,
    held: &[bool],
) -> Option<(Vec<Vec3>, usize)> {
    let mut y = x.to_vec();
    let mut now = if smooth_first {
        folds::smooth_folds(topology, reference, &mut y, &vec![false; x.len()]).1
    } else {
        left
    };
    // What the smoothing leaves (mostly the template's slivers, whose
    // neighbours it moves apart again): the neighbourhood as one piece,
    // blended over a ring more each time, while that folds fewer.
    for rings in 0..=LAST_RESORT_RINGS {
        if now == 0 {
            break;
        }
        let mut z = y.clone();
        let n = folds::translate_regions(topology, reference, &mut z, held, rings);
        if n < now {
            y = z;
            now = n;
        }
    }
    if now > 0 && 2 * now > left {
        return None;
    }
    // The readings move as little as the surface allows; the whole way (1)
    // always qualifies.
    FOLD_RELEASE_PARTS.iter().rev().find_map(|&part| {
        let z: Vec<Vec3> = if part == 1.0 {
            y.clone()
        } else {
            x.iter()
                .zip(&y)
                .map(|(&a, &b)| add(a, scale(sub(b, a), part)))
                .collect()
        };
        let n = folds::folded_faces(topology, reference, &z).len();
        (n <= now).then_some((z, n))
    })
}

/// The allowable error (mm) of a reading whose measurer does not know its
/// own (as [`super::Continuation`]'s default).
const FOLD_REPAIR_DEFAULT_MM: f64 = 4.0;

impl ShapeModel {
    /// Step 2 from `step1` (see the module docs) on the template
    /// `topology`: `rounds.s` rounds (and continuation rounds) over the
    /// vertices. `observer` as in [`ShapeModel::step1`].
    ///
    /// Errors if measuring fails, the observer cancels or the mesh is not
    /// finite; a solver that cannot start, or a result worse than step 1's,
    /// is a warning.
    #[allow(clippy::too_many_arguments)]
    pub fn step2(
        &self,
        readings: &Readings,
        step1: &Step1Shape,
        config: &Step2Config,
        rounds: &RoundsConfig,
        measurer: &dyn Measurer,
        topology: &Topology,
        observer: &dyn PredictObserver,
    ) -> Result<Step2Shape> {
        // Whether any soft target is pulled (a caliper's is held whatever
        // the share, see `step2_with`): otherwise another try would repeat
        // this one.
        let pulled = config.soft_pull > 0.0
            && readings
                .iter()
                .zip(&step1.measured)
                .any(|(g, m)| soft_and_pulled(g, m));
        let shares: &[f64] = if pulled { &SOFT_PULL_SHARES } else { &[1.0] };
        // The body that folds least, the first (largest pull) of equals:
        // flipped or collapsed triangles first, then creased edges beyond
        // those allowed (a flipped triangle is never traded for creases).
        let mut best: Option<((usize, usize), Step2Shape)> = None;
        for (i, &share) in shares.iter().enumerate() {
            let tried = Step2Config {
                soft_pull: config.soft_pull * share,
                ..*config
            };
            // A retry passes cancelling through but reports no progress of
            // its own, so that the fraction never goes back.
            let quiet =
                |_: &PredictProgress| observer.observe(&PredictProgress::at(PredictStage::Step2));
            let watch: &dyn PredictObserver = if i == 0 { observer } else { &quiet };
            let mut shape =
                self.step2_solved(readings, step1, &tried, rounds, measurer, topology, watch)?;
            if config.fold_repair {
                shape = self.repair_folds(shape, readings, step1, measurer, topology)?;
            }
            // Folded triangles and creased edges alike: the fold repair
            // unfolds triangles but can leave the surface creased where a
            // pulled statistic bent it (`folds::CREASE_DEG`). With one
            // share there is nothing to choose between: not counted.
            let creased = if shares.len() > 1 {
                folds::creased_edges(topology, &step1.vertices, &shape.vertices)
            } else {
                0
            };
            let folded = fold_rank(
                folds::folded_faces(topology, &step1.vertices, &shape.vertices).len(),
                creased,
            );
            let better = best.as_ref().is_none_or(|b| folded < b.0);
            if i > 0 && better {
                shape.warnings.push(Warning::SoftPullReduced {
                    pull: tried.soft_pull,
                    asked: config.soft_pull,
                });
            }
            if better {
                best = Some((folded, shape));
            }
            if folded == (0, 0) {
                break;
            }
        }
        let (_, shape) = best.expect("at least one share is tried");
        if config.fold_repair {
            return self.unfold_over_readings(shape, readings, step1, measurer, topology);
        }
        Ok(shape)
    }

    /// The fold repair ([`super::Step2Settings::fold_repair`]): smooths the
    /// folded triangles' neighbourhood of `shape`, the landmarks of
    /// straight readings held, and keeps the result where it folds fewer
    /// triangles and every reading within its allowable error stays within
    /// it (the readings measured again on it). A reading that the smoothing
    /// pushed out has its support held too, and the smoothing starts again
    /// from `shape`, at most [`FOLD_REPAIR_ATTEMPTS`] times. Then, at most
    /// [`FOLD_RELEASE_PASSES`] times, the held vertices of the triangles
    /// still folded are let go and the body is smoothed again; the result,
    /// or a part of the way towards it ([`FOLD_RELEASE_PARTS`]), is kept on
    /// the same terms.
    fn repair_folds(
        &self,
        mut shape: Step2Shape,
        readings: &Readings,
        step1: &Step1Shape,
        measurer: &dyn Measurer,
        topology: &Topology,
    ) -> Result<Step2Shape> {
        let folded = folds::folded_faces(topology, &step1.vertices, &shape.vertices).len();
        if folded == 0 {
            return Ok(shape);
        }
        let mut pinned = straight_landmarks(readings, &shape.measured, topology.n_vertices());
        let within = |m: &[Measured]| within_allowable(readings, m, measurer);
        let met = within(&shape.measured);
        // The readings within their allowable error on `shape` that fall
        // out of it on `measured`.
        let lost = |measured: &[Measured]| fallen_out(&met, &within(measured));
        let mut left = folded;
        for _ in 0..FOLD_REPAIR_ATTEMPTS {
            let mut x = shape.vertices.clone();
            let (_, now) = folds::smooth_folds(topology, &step1.vertices, &mut x, &pinned);
            if now >= left {
                break;
            }
            let measured = self.measure_checked(measurer, &x, &readings.indices())?;
            let out = lost(&measured);
            if out.is_empty() {
                shape.measured = measured;
                shape.vertices = x;
                left = now;
                break;
            }
            for i in out {
                hold(&mut pinned, &shape.measured[i]);
                hold(&mut pinned, &measured[i]);
            }
        }
        // What is still folded mostly has held landmarks among its
        // vertices (the crotch, the navel): they are let go there and the
        // body smoothed again; that body, or the largest part of the way
        // towards it that folds less, is kept on the same terms (fewer
        // folds, no reading falls out).
        for _ in 0..FOLD_RELEASE_PASSES {
            if left == 0 {
                break;
            }
            for f in folds::folded_faces(topology, &step1.vertices, &shape.vertices) {
                for v in topology.faces()[f] {
                    pinned[v as usize] = false;
                }
            }
            let mut x = shape.vertices.clone();
            let (_, now) = folds::smooth_folds(topology, &step1.vertices, &mut x, &pinned);
            if now < left {
                for part in FOLD_RELEASE_PARTS {
                    let y: Vec<Vec3> = shape
                        .vertices
                        .iter()
                        .zip(&x)
                        .map(|(&a, &b)| add(a, scale(sub(b, a), part)))
                        .collect();
                    let n = folds::folded_faces(topology, &step1.vertices, &y).len();
                    if n >= left {
                        continue;
                    }
                    let measured = self.measure_checked(measurer, &y, &readings.indices())?;
                    if lost(&measured).is_empty() {
                        shape.measured = measured;
                        shape.vertices = y;
                        left = n;
                        break;
                    }
                }
            }
        }
        if left < folded {
            shape.warnings.push(Warning::FoldsSmoothed { folded, left });
        }
        Ok(shape)
    }

    /// The fold repair's last resort, on step 2's body as chosen (after the
    /// soft-pull tries, so that a smaller pull, which costs no reading, is
    /// preferred to it): where `shape` still folds triangles of the step-1
    /// shape, unfolds them at the readings' cost ([`last_resort`], two
    /// ways, the better kept: fewer folded triangles, then fewer readings
    /// given up) and names the readings within their allowable error
    /// before that are beyond it after ([`Warning::SurfaceOverReadings`]).
    /// Why: a flipped triangle is a surface through itself, no body; issue
    /// 12's kept readings are fitted "as far as a human-looking surface
    /// allows". On all 1,505 ANSUR II test-split people entered with their
    /// `ansur` survey values, 199 bodies kept 814 flipped triangles that no
    /// smoothing holding the readings could unfold
    /// (`docs/results/real-customers.md`, "No flipped triangles").
    fn unfold_over_readings(
        &self,
        mut shape: Step2Shape,
        readings: &Readings,
        step1: &Step1Shape,
        measurer: &dyn Measurer,
        topology: &Topology,
    ) -> Result<Step2Shape> {
        let left = folds::folded_faces(topology, &step1.vertices, &shape.vertices).len();
        if left == 0 {
            return Ok(shape);
        }
        let met = within_allowable(readings, &shape.measured, measurer);
        // Two ways: the neighbourhood moved as one piece by its straight
        // readings' landmarks where it holds any (a crotch point stays
        // where step 2 put it, so crotch height does), or smoothed with
        // nothing held first.
        let landmarks = straight_landmarks(readings, &shape.measured, topology.n_vertices());
        let nothing_held = vec![false; topology.n_vertices()];
        // (triangles left folded, readings given up (indices), the body).
        type Unfolded = (usize, Vec<usize>, (Vec<Vec3>, Vec<Measured>));
        let mut best: Option<Unfolded> = None;
        for (smooth_first, held) in [(false, &landmarks), (true, &nothing_held)] {
            let Some((y, n)) = last_resort(
                topology,
                &step1.vertices,
                &shape.vertices,
                left,
                smooth_first,
                held,
            ) else {
                continue;
            };
            let measured = self.measure_checked(measurer, &y, &readings.indices())?;
            let out = fallen_out(&met, &within_allowable(readings, &measured, measurer));
            if best
                .as_ref()
                .is_none_or(|b| (n, out.len()) < (b.0, b.1.len()))
            {
                best = Some((n, out, (y, measured)));
            }
        }
        if let Some((n, out, (y, measured))) = best {
            let given = readings.indices();
            shape.warnings.push(Warning::SurfaceOverReadings {
                folded: left,
                left: n,
                readings: out
                    .into_iter()
                    .map(|i| self.measurement_names[given[i]].clone())
                    .collect(),
            });
            shape.measured = measured;
            shape.vertices = y;
        }
        Ok(shape)
    }

    /// Before step 2, with the fold repair on: where the step-1 shape
    /// folds more than [`UNFOLD_STEP1_ABOVE`] triangles of the model's mean
    /// shape (flipped or collapsed), smooths its displacement from the mean
    /// there
    /// ([`folds::smooth_folds`], the landmarks of straight readings held)
    /// and measures the readings again on it. Returns that shape, with a
    /// [`Warning::Step1Smoothed`], where it folds fewer triangles and can
    /// be measured; `None` where the step-1 shape is to be kept as it is.
    /// Step 2 may then start from it and measure its smoothness from it
    /// (`ShapeModel::predict` keeps step 2's result from it unless it
    /// leaves more readings beyond their allowable error than step 2 from
    /// `step1` does). Why: the learned space is linear, and a shape far
    /// along a few components can fold the surface where the training
    /// bodies do not (the head's small features): ANSUR II test-split
    /// subject 14812 (`quick`, with sex) has 87 triangles of the step-1
    /// shape flipped against the mean, and its body failed the surface
    /// check (`docs/results/real-customers/surface-check.md`) whatever
    /// step 2 did. Many step-1 shapes flip a few of the template's
    /// slivers, as generated bodies do; those are left as they are.
    pub(crate) fn unfold_step1(
        &self,
        step1: &Step1Shape,
        readings: &Readings,
        measurer: &dyn Measurer,
        topology: &Topology,
    ) -> Option<Step1Shape> {
        // The mean shape (flat, 3V, metres) as points.
        let mean: Vec<Vec3> = self
            .pca
            .mean
            .chunks_exact(3)
            .map(|c| [c[0], c[1], c[2]])
            .collect();
        if folds::folded_faces(topology, &mean, &step1.vertices).len() <= UNFOLD_STEP1_ABOVE {
            return None;
        }
        let pinned = straight_landmarks(readings, &step1.measured, topology.n_vertices());
        let mut x = step1.vertices.clone();
        let (folded, left) = folds::smooth_folds(topology, &mean, &mut x, &pinned);
        if left >= folded {
            return None;
        }
        // Where the smoothed shape cannot be measured, step 2 starts from
        // the step-1 shape as it was.
        let measured = self
            .measure_checked(measurer, &x, &readings.indices())
            .ok()?;
        let mut warnings = step1.warnings.clone();
        warnings.push(Warning::Step1Smoothed { folded, left });
        Some(Step1Shape {
            vertices: x,
            measured,
            warnings,
            ..step1.clone()
        })
    }

    /// How many given readings (soft targets left out) `shape` leaves
    /// beyond their whole allowable error (the measurer's, at least the
    /// reading's own tolerance).
    pub(crate) fn misses_allowable(
        &self,
        readings: &Readings,
        shape: &Step2Shape,
        measurer: &dyn Measurer,
    ) -> usize {
        let whole = super::Continuation {
            share: 1.0,
            ..Default::default()
        };
        let limits = thresholds(readings, &|j| measurer.allowable_error(j), Some(whole));
        misses(readings, &shape.measured, &limits)
    }

    /// Step 2 without the fold repair: the first solver, then the solver
    /// where it missed (see the module docs).
    #[allow(clippy::too_many_arguments)]
    fn step2_solved(
        &self,
        readings: &Readings,
        step1: &Step1Shape,
        config: &Step2Config,
        rounds: &RoundsConfig,
        measurer: &dyn Measurer,
        topology: &Topology,
        observer: &dyn PredictObserver,
    ) -> Result<Step2Shape> {
        let Some(first) = config.first else {
            return self.step2_with(
                readings, step1, config, rounds, measurer, topology, observer,
            );
        };
        let tried = Step2Config {
            solver: first,
            first: None,
            ..*config
        };
        // The first attempt passes cancelling through but reports no
        // progress of its own (it is a few per cent of a fallback's work),
        // so that the fraction never goes back when L-BFGS runs after it.
        let quiet =
            |_: &PredictProgress| observer.observe(&PredictProgress::at(PredictStage::Step2));
        let shape =
            match self.step2_with(readings, step1, &tried, rounds, measurer, topology, &quiet) {
                Ok(shape) => shape,
                Err(e @ ModelError::Cancelled(_)) => return Err(e),
                // The first solver cannot run here (e.g. a smooth basis with
                // more modes than the mesh has vertices): the solver alone.
                Err(e) => {
                    let mut shape = self.step2_with(
                        readings, step1, config, rounds, measurer, topology, observer,
                    )?;
                    shape.first = Some(Step2First {
                        kept: false,
                        misses: 0,
                        error: Some(e.to_string()),
                    });
                    return Ok(shape);
                }
            };
        // Every reading within its threshold (the continuation's, else the
        // whole allowable error), and no fallback to an earlier shape.
        let within = rounds.continuation.unwrap_or(super::Continuation {
            share: 1.0,
            ..Default::default()
        });
        let limits = thresholds(readings, &|j| measurer.allowable_error(j), Some(within));
        let misses = misses(&shape.readings, &shape.measured, &limits);
        let fell_back = shape
            .warnings
            .iter()
            .any(|w| matches!(w, Warning::Step2KeptEarlier { .. }));
        let kept = misses == 0 && !fell_back;
        let first = Some(Step2First {
            kept,
            misses,
            error: None,
        });
        if kept {
            return Ok(Step2Shape { first, ..shape });
        }
        // The solver minimises the same objective (E_s from the step-1
        // shape) from the first solver's body, which already meets most
        // readings with a smooth displacement, so it has only the rest to
        // do; a first result that fell back to an earlier shape is no
        // start, and the solver starts from the step-1 shape.
        let start = (!fell_back).then_some((&shape.vertices[..], &shape.measured[..]));
        let mut shape = self.step2_from(
            readings, step1, start, config, rounds, measurer, topology, observer,
        )?;
        shape.first = first;
        Ok(shape)
    }

    /// Step 2 with `config.solver` alone, from the step-1 shape.
    #[allow(clippy::too_many_arguments)]
    fn step2_with(
        &self,
        readings: &Readings,
        step1: &Step1Shape,
        config: &Step2Config,
        rounds: &RoundsConfig,
        measurer: &dyn Measurer,
        topology: &Topology,
        observer: &dyn PredictObserver,
    ) -> Result<Step2Shape> {
        self.step2_from(
            readings, step1, None, config, rounds, measurer, topology, observer,
        )
    }

    /// Step 2 with `config.solver` alone, its rounds starting from `start`
    /// (vertices, metres, and the readings measured on them; `None`: the
    /// step-1 shape). The objective is the same either way: `E_s` of the
    /// displacement from the step-1 shape, a doubtful reading kept at its
    /// step-1 value, a loose soft target moved
    /// [`super::Step2Settings::soft_pull`] of the way from its step-1 value
    /// to its own, and the result compared with step 1's energy.
    #[allow(clippy::too_many_arguments)]
    fn step2_from(
        &self,
        readings: &Readings,
        step1: &Step1Shape,
        start: Option<(&[Vec3], &[Measured])>,
        config: &Step2Config,
        rounds: &RoundsConfig,
        measurer: &dyn Measurer,
        topology: &Topology,
        observer: &dyn PredictObserver,
    ) -> Result<Step2Shape> {
        let readings2 =
            readings.with_targets(readings.iter().zip(&step1.measured).map(|(g, m)| {
                if soft_and_pulled(g, m) {
                    let at = m.value * MM_PER_M;
                    at + config.soft_pull * (g.target_mm - at)
                } else if g.weight < 1.0 {
                    m.value * MM_PER_M
                } else {
                    g.target_mm
                }
            }));
        let reference_mm = to_mm(&step1.vertices).as_flattened().to_vec();
        let smooth = match config.solver {
            Step2Method::SmoothBasis { modes, .. } => Some(
                SmoothBasis::shared(topology.n_vertices(), topology.edges(), modes)
                    .map_err(|e| ModelError::Numerical(format!("step 2: {e}")))?,
            ),
            _ => None,
        };
        let mut step = Step2Rounds {
            model: self,
            measurer,
            readings: &readings2,
            which: readings.indices(),
            config,
            edges: topology.edges(),
            start_measured: start.map_or(&step1.measured[..], |s| s.1),
            x_mm: start.map_or_else(
                || reference_mm.clone(),
                |s| to_mm(s.0).as_flattened().to_vec(),
            ),
            reference_mm,
            p_mm: Vec::new(),
            best: None,
            symbolic: SymbolicCache::default(),
            // Coefficients of x - reference: zero only where the rounds
            // start from the reference.
            smooth_c: match (&smooth, config.solver, start) {
                (Some(b), Step2Method::SmoothBasis { polish: None, .. }, None) => {
                    Some(vec![0.0; 3 * b.k()])
                }
                _ => None,
            },
            smooth,
        };
        let thresholds = thresholds(
            readings,
            &|j| measurer.allowable_error(j),
            rounds.continuation,
        );
        let (log, summary) = run_rounds(&mut step, rounds, &readings2, &thresholds, observer)?;
        let RoundLog { runs, mut warnings } = log;
        let mut x2: Vec<Vec3> = step
            .x_mm
            .chunks_exact(3)
            .map(|c| [c[0] / MM_PER_M, c[1] / MM_PER_M, c[2] / MM_PER_M])
            .collect();
        if x2.iter().flatten().any(|c| !c.is_finite()) {
            return Err(ModelError::NonFinite(
                "step 2 produced a non-finite mesh".into(),
            ));
        }
        let mut meas2 = self.measure_checked(measurer, &x2, &readings.indices())?;
        let err2 = self.stage_energy(&readings2, &meas2, &x2, config.weighting);
        let err1 = self.stage_energy(
            &readings2,
            &step1.measured,
            &step1.vertices,
            config.weighting,
        );
        // Worse than step 1: the lowest E_m step 2 measured, a round's start
        // or the step-1 shape (see the module docs).
        if err2 > err1 || err2.is_nan() {
            match step.best.take().filter(|b| b.1 < err1) {
                Some((round, e, x_mm, measured)) => {
                    warnings.push(Warning::Step2KeptEarlier {
                        end: err2,
                        step1: err1,
                        kept_round: Some((round + 1, e)),
                    });
                    x2 = x_mm
                        .chunks_exact(3)
                        .map(|c| [c[0] / MM_PER_M, c[1] / MM_PER_M, c[2] / MM_PER_M])
                        .collect();
                    meas2 = measured;
                }
                None => {
                    warnings.push(Warning::Step2KeptEarlier {
                        end: err2,
                        step1: err1,
                        kept_round: None,
                    });
                    x2.clone_from(&step1.vertices);
                    meas2.clone_from(&step1.measured);
                }
            }
        }
        Ok(Step2Shape {
            vertices: x2,
            measured: meas2,
            readings: readings2,
            runs,
            rounds: summary,
            warnings,
            first: None,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_flipped_triangle_ranks_worse_than_any_number_of_creases() {
        let allowed = folds::CREASES_ALLOWED;
        // Creases up to the allowance do not count.
        assert_eq!(fold_rank(0, allowed), (0, 0));
        assert_eq!(fold_rank(2, allowed), (2, 0));
        // Beyond it, all of them count.
        assert_eq!(fold_rank(0, allowed + 1), (0, allowed + 1));
        // One flipped triangle and a smooth surface is worse than none
        // flipped and many creases (a sum would say the reverse).
        assert!(fold_rank(0, 10 * allowed) < fold_rank(1, 0));
        // Among equal flips, fewer creases win.
        assert!(fold_rank(3, allowed + 5) < fold_rank(3, allowed + 6));
    }
}
