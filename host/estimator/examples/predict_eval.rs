//! Prediction experiments of issue 4, printing markdown tables.
//!
//! Why an example and not a test: these take minutes on hundreds of bodies;
//! the reduced versions run in CI (`host/estimator/tests/predict.rs`); the full
//! evaluation suite is the `tapeshape-eval` program (`host/eval`).
//!
//! ```text
//! # the paper's S_real: train on a population, predict held-out bodies from paper34
//! cargo run --release -p tapeshape-estimator --example predict_eval -- sreal \
//!     --train /work/out/pop400s1.tsd --heldout /work/out/held60s2.tsd --n 50 \
//!     [--model host/estimator/models/default.tsm.gz] [--keep-all (every reading kept by the operator)]
//! # ISO 20685-1 pass shares for quick and ansur (generated bodies and ANSUR test subjects)
//! cargo run --release -p tapeshape-estimator --example predict_eval -- iso \
//!     --heldout /work/out/held60s2.tsd --n 50 --ansur 100 --subsets 3 [--model FILE] [--l 3]
//! # why a reading misses: start / step 1 / step 2 values and the L-BFGS runs of
//! # every failing prediction (held-out bodies, or ANSUR test subjects without --heldout)
//! cargo run --release -p tapeshape-estimator --example predict_eval -- diag \
//!     [--heldout FILE] --n 10 --set quick [--bodies 0,3] [--all 1]
//! ```
//!
//! Every experiment takes the prediction settings as flags (the station's
//! by default; see `settings_from_args`): `--paper` for the paper's exact
//! pipeline, then step 1's solver, prior, weighting, components, clamp and
//! iterations, step 2's weighting, solver and iterations, the
//! continuation, and `--first none|smooth` (a step-2 solver tried first,
//! kept when it meets every reading). Options: `predict_eval sreal
//! --help`, `predict_eval iso --help` and `predict_eval diag --help` list
//! them.

use std::collections::BTreeMap;
use std::path::PathBuf;
use std::time::Instant;

use clap::{Parser, Subcommand, ValueEnum};
use rand::SeedableRng;
use tapeshape_estimator::{
    train, Estimator, Inputs, PredictError, PredictOptions, PredictSettings, TrainSettings,
};
use tapeshape_measure::Kind;
use tapeshape_mesh::Vec3;
use tapeshape_model::predict::{
    Continuation, EnergyWeighting, Step1Clamp, Step1Solver, Step2Solver, Step2Weighting,
};
use tapeshape_population::ansur::{Ansur, Split};
use tapeshape_population::seeded;
use tapeshape_population::Dataset;

/// Prediction experiments of issue 4, printing markdown tables.
#[derive(Parser)]
// A flag given twice takes its last value (the hand-written lookup took
// the first); the setting holds for the subcommands too.
#[command(args_override_self = true)]
struct Args {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// The paper's S_real: held-out generated bodies predicted from their
    /// paper34 values (feature analysis alone and the full method), by a
    /// paper34-only model trained on `--train` and by `--model`.
    Sreal(Sreal),
    /// ISO 20685-1 pass shares for the `quick` and `ansur` sets: held-out
    /// generated bodies (all measurements and random subsets of `quick`)
    /// and ANSUR II test-split subjects.
    Iso(Iso),
    /// Why a reading misses: for every prediction with a reading outside
    /// its ISO tolerance, the start, step-1 and step-2 values and what each
    /// L-BFGS run did.
    Diag(Diag),
}

#[derive(clap::Args)]
struct Sreal {
    /// Held-out generated bodies: their paper34 values are the inputs.
    #[arg(long, value_name = "FILE")]
    heldout: PathBuf,
    /// The first N held-out bodies (all where there are fewer).
    #[arg(long, value_name = "N", default_value_t = 50)]
    n: usize,
    /// Train a paper34-only model (all components) on these bodies and
    /// evaluate it (before `--model`).
    #[arg(long, value_name = "FILE")]
    train: Option<String>,
    /// Evaluate this model file.
    #[arg(long, value_name = "FILE")]
    model: Option<String>,
    /// As if the operator kept every reading after a flag (issue 12, item
    /// 6): a held-out body outside the model's population is estimated
    /// with a warning instead of refused.
    #[arg(long)]
    keep_all: bool,
    #[command(flatten)]
    settings: Settings,
}

#[derive(clap::Args)]
struct Iso {
    /// A model file instead of the embedded default.
    #[arg(long, value_name = "FILE")]
    model: Option<PathBuf>,
    /// Held-out generated bodies: their own values as inputs (without it,
    /// only ANSUR II subjects).
    #[arg(long, value_name = "FILE")]
    heldout: Option<PathBuf>,
    /// The first N held-out bodies.
    #[arg(long, value_name = "N", default_value_t = 50)]
    n: usize,
    /// The first N ANSUR II test-split subjects, their real values as
    /// input (0: none).
    #[arg(long, value_name = "N", default_value_t = 100)]
    ansur: usize,
    /// Random subsets of the `quick` set per held-out body.
    #[arg(long, value_name = "N", default_value_t = 3)]
    subsets: usize,
    #[command(flatten)]
    settings: Settings,
}

#[derive(clap::Args)]
struct Diag {
    /// A model file instead of the embedded default.
    #[arg(long, value_name = "FILE")]
    model: Option<PathBuf>,
    /// Held-out generated bodies: their values as inputs (without it,
    /// ANSUR II test-split subjects' real values).
    #[arg(long, value_name = "FILE")]
    heldout: Option<PathBuf>,
    /// The first N bodies or subjects.
    #[arg(long, value_name = "N", default_value_t = 10)]
    n: usize,
    /// The input set, every measurement of it entered (those constant on
    /// the training set left out).
    #[arg(long, default_value = "quick")]
    set: String,
    /// Only these of the first N, numbered from 0, separated by commas
    /// (`0,3`).
    #[arg(
        long,
        value_name = "I,J,...",
        value_delimiter = ',',
        action = clap::ArgAction::Set
    )]
    bodies: Option<Vec<usize>>,
    /// Print the report of every body, not only of those with a failing
    /// reading (takes a value, any: `--all 1`).
    #[arg(long, value_name = "ANY")]
    all: Option<String>,
    #[command(flatten)]
    settings: Settings,
}

/// The prediction settings (defaults: the station's), applied in this
/// order.
#[derive(clap::Args)]
struct Settings {
    /// Start from the paper's exact pipeline instead of the station's
    /// settings.
    #[arg(long)]
    paper: bool,
    /// Clamp every normalised weight to [-L, L] (`PredictSettings::l`).
    #[arg(long, value_name = "L", allow_negative_numbers = true)]
    l: Option<f64>,
    /// Step 2's smoothness weight, in [0, 1].
    #[arg(long, value_name = "X", allow_negative_numbers = true)]
    lambda: Option<f64>,
    /// Rounds of support recomputation per step (0: the start only; `sreal`
    /// runs 0 and 3 whatever it says, and prints it).
    #[arg(long, value_name = "N")]
    s: Option<usize>,
    /// Step 1 as the Gauss-Newton MAP (`on`, see `tapeshape_model::map`) or
    /// L-BFGS on `E_m` (`off`), keeping the reading noise / prior the
    /// solver had; read first, the other step-1 flags apply to the solver
    /// it picks.
    #[arg(long, value_enum)]
    gn: Option<OnOff>,
    /// Step 1's reading noise TAU mm: the Gauss-Newton MAP's, or with
    /// L-BFGS the training Gaussian's prior (a MAP with that noise).
    #[arg(long, value_name = "TAU_MM", allow_negative_numbers = true)]
    prior: Option<f64>,
    /// Step 1's Gauss-Newton `min_decrease_mm` (needs step 1's
    /// Gauss-Newton).
    #[arg(long, value_name = "MM", allow_negative_numbers = true)]
    gn_min_decrease: Option<f64>,
    /// Step 1's energy weighting.
    #[arg(long, value_enum)]
    w1: Option<Weighting>,
    /// Step 2's energy weighting.
    #[arg(long, value_enum)]
    w2: Option<Weighting>,
    /// Step 2's per-measurement reading weight (default 1e4; needs
    /// per-measurement step-2 weighting).
    #[arg(long, value_name = "W", allow_negative_numbers = true)]
    w2_scale: Option<f64>,
    /// Step 1 moves the first K components only.
    #[arg(long, value_name = "K")]
    k1: Option<usize>,
    /// Step 1 holds the weights inside [-l, l] before every round after the
    /// first (`on`) or clamps once after the step (`off`, the paper).
    #[arg(long = "box", value_name = "BOX", value_enum)]
    clamp: Option<OnOff>,
    /// The continuation's rounds beyond `s` per step (`off`: none; a number
    /// resets its other settings to their defaults).
    #[arg(long, value_name = "N|off", value_parser = cont)]
    cont: Option<Cont>,
    /// L-BFGS iterations of a step-1 continuation round (`solver`:
    /// `--iters1`'s; needs the continuation).
    #[arg(long, value_name = "N|solver", value_parser = cont_iters1)]
    cont_iters1: Option<ContIters1>,
    /// The continuation's objective-evaluation budget per step (needs the
    /// continuation).
    #[arg(long, value_name = "EVALS")]
    budget: Option<u64>,
    /// Step 1's iteration cap.
    #[arg(long, value_name = "N")]
    iters1: Option<u64>,
    /// Step 2's solver: `lbfgs` (the paper's), `gn` (sparse Gauss-Newton),
    /// `smooth` (the smooth basis, fitting each reading), `smooth-segments`
    /// (the smooth basis, fitting the paper's per-segment `E_m`) or
    /// `smooth:MODES[:POLISH]` (the smooth basis with MODES modes, fitting
    /// each reading, and POLISH L-BFGS iterations after each reduced solve,
    /// default 0).
    #[arg(long, value_name = "SOLVER", value_parser = solver2)]
    solver2: Option<Step2Solver>,
    /// Step 2's iteration cap (of the solver `--solver2` picks).
    #[arg(long, value_name = "N")]
    iters2: Option<u64>,
    /// A step-2 solver tried first, kept when it meets every reading.
    #[arg(long, value_enum)]
    first: Option<First>,
}

/// `--gn`'s and `--box`'s values.
#[derive(Clone, Copy, ValueEnum)]
enum OnOff {
    On,
    Off,
}

/// `--w1`'s and `--w2`'s values.
#[derive(Clone, Copy, ValueEnum)]
enum Weighting {
    /// The paper's `E_m`: every segment term with weight 1.
    Paper,
    /// Each measurement's terms scaled so that its energy is about its
    /// error squared (mm^2), whatever its length and number of segments.
    PerMeasurement,
}

/// `--first`'s values.
#[derive(Clone, Copy, ValueEnum)]
enum First {
    /// Step 2's solver alone.
    None,
    /// The template's smooth basis first.
    Smooth,
}

/// `--cont`'s value.
#[derive(Clone, Copy)]
enum Cont {
    Off,
    Rounds(usize),
}

fn cont(v: &str) -> Result<Cont, String> {
    match v {
        "off" => Ok(Cont::Off),
        n => n
            .parse()
            .map(Cont::Rounds)
            .map_err(|e| format!("a number or `off` ({e})")),
    }
}

/// `--cont-iters1`'s value.
#[derive(Clone, Copy)]
enum ContIters1 {
    Solver,
    Iters(u64),
}

fn cont_iters1(v: &str) -> Result<ContIters1, String> {
    match v {
        "solver" => Ok(ContIters1::Solver),
        n => n
            .parse()
            .map(ContIters1::Iters)
            .map_err(|e| format!("a number or `solver` ({e})")),
    }
}

/// `--solver2`'s value.
fn solver2(v: &str) -> Result<Step2Solver, String> {
    Ok(match v {
        "lbfgs" => Step2Solver::paper(),
        "gn" => Step2Solver::GaussNewton {
            stop: Default::default(),
        },
        "smooth" => Step2Solver::smooth_basis(),
        "smooth-segments" => match Step2Solver::smooth_basis() {
            Step2Solver::SmoothBasis {
                modes,
                polish,
                stop,
                min_decrease_mm,
                ..
            } => Step2Solver::SmoothBasis {
                modes,
                fit: tapeshape_model::SmoothFit::Segments,
                polish,
                stop,
                min_decrease_mm,
            },
            other => other,
        },
        other => {
            // smooth:MODES or smooth:MODES:POLISH
            let parts: Option<Vec<u64>> = other
                .strip_prefix("smooth:")
                .map(|r| r.split(':').map(|p| p.parse().ok()).collect())
                .and_then(|v: Option<Vec<u64>>| v);
            match parts.as_deref() {
                Some([modes]) | Some([modes, _]) => Step2Solver::SmoothBasis {
                    modes: *modes as usize,
                    fit: tapeshape_model::SmoothFit::Readings,
                    polish: parts.as_ref().and_then(|p| p.get(1).copied()).unwrap_or(0),
                    stop: Default::default(),
                    min_decrease_mm: tapeshape_model::DEFAULT_SMOOTH_MIN_DECREASE_MM,
                },
                _ => {
                    return Err(
                        "lbfgs, gn, smooth, smooth-segments or smooth:MODES[:POLISH]".into(),
                    )
                }
            }
        }
    })
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args = tapeshape_common::cli::parse_or_exit::<Args>();
    match &args.command {
        Command::Sreal(a) => sreal(a),
        Command::Iso(a) => iso(a),
        Command::Diag(a) => diag(a),
    }
}

fn vertex_distance_mm(a: &[Vec3], b: &[Vec3]) -> f64 {
    a.iter()
        .zip(b)
        .map(|(p, q)| tapeshape_mesh::vec3::distance(*p, *q))
        .sum::<f64>()
        / a.len() as f64
        * 1000.0
}

/// Root-mean-square vertex distance, mm (the quantity the Bayes bound is about).
fn vertex_rms_mm(a: &[Vec3], b: &[Vec3]) -> f64 {
    (a.iter()
        .zip(b)
        .map(|(p, q)| {
            let d = tapeshape_mesh::vec3::sub(*p, *q);
            tapeshape_mesh::vec3::dot(d, d)
        })
        .sum::<f64>()
        / a.len() as f64)
        .sqrt()
        * 1000.0
}

/// Per-class errors of one prediction from paper34: (euclidean, planar
/// circumference, geodesic loops as the sum of their 4 members).
fn paper34_errors(
    estimator: &Estimator,
    names: &[String],
    truth: &[f64],
    pred: &[f64],
) -> [Vec<f64>; 3] {
    let mut out: [Vec<f64>; 3] = Default::default();
    let mut groups: BTreeMap<String, f64> = BTreeMap::new();
    for (k, name) in names.iter().enumerate() {
        let d = &estimator.set().definitions[estimator.set().index_of(name).expect("known")];
        let e = (pred[k] - truth[k]).abs() * 1000.0;
        match (&d.kind, &d.group) {
            (_, Some(g)) => *groups.entry(g.clone()).or_default() += e,
            (Kind::Circumference { .. }, None) => out[1].push(e),
            _ => out[0].push(e),
        }
    }
    out[2] = groups.into_values().collect();
    out
}

/// Drops measurements that are constant (zero SD) on the training set, e.g.
/// a geodesic between two landmarks that fall on the same vertex: no reading
/// can inform them. Says which.
fn usable(estimator: &Estimator, names: Vec<String>) -> Vec<String> {
    let stats = estimator.file().model.measurement_stats();
    let (keep, drop): (Vec<String>, Vec<String>) = names
        .into_iter()
        .partition(|n| stats[estimator.set().index_of(n).expect("member")].1 > 1e-9);
    if !drop.is_empty() {
        eprintln!(
            "left out (constant on the training set): {}",
            drop.join(", ")
        );
    }
    keep
}

fn mean(v: &[f64]) -> f64 {
    if v.is_empty() {
        f64::NAN
    } else {
        v.iter().sum::<f64>() / v.len() as f64
    }
}

fn sreal(args: &Sreal) -> Result<(), Box<dyn std::error::Error>> {
    let heldout = Dataset::read(&args.heldout)?;
    let n = args.n.min(heldout.len());
    let mut estimators: Vec<(String, Estimator)> = Vec::new();
    if let Some(t) = &args.train {
        let data = Dataset::read(&PathBuf::from(t))?;
        let t0 = Instant::now();
        let file = train(&data, &["paper34"], &TrainSettings::default())?;
        println!(
            "trained paper34-only model on {} bodies in {:.1} s ({} components)",
            data.len(),
            t0.elapsed().as_secs_f64(),
            file.model.n_components()
        );
        estimators.push((
            format!("paper34 only, {} bodies, all components", data.len()),
            Estimator::new(file, t)?,
        ));
    }
    if let Some(m) = &args.model {
        let e = Estimator::load(&PathBuf::from(m))?;
        estimators.push((
            format!(
                "{} ({} components, {})",
                m,
                e.file().model.n_components(),
                e.file().measurement_set.name
            ),
            e,
        ));
    }
    // As if the operator kept every reading after a flag (issue 12, item 6):
    // a held-out body outside the model's population is then estimated
    // with a warning instead of refused.
    let keep_all = args.keep_all;
    let base = settings_from_args(&args.settings)?;
    println!(
        "\nS_real: {n} held-out generated bodies, inputs = their paper34 values, settings l = {}, lambda = {}, s = {}, step 1 {:?} weighted {:?}, step-1 components {:?}\n",
        base.l, base.step2.lambda, base.s, base.step1.solver, base.step1.weighting, base.step1.components
    );
    println!("| model | method | Euclidean (14) mm | circumference, planar (4) mm | circumference, geodesic loops (4) mm | all circumferences mm | vertex distance mm | flipped / degenerate vs step-1 shape | flipped / degenerate vs true body (true body vs PCA mean) | mean time s |");
    println!("|---|---|---|---|---|---|---|---|---|---|");
    for (label, estimator) in &estimators {
        let names = usable(estimator, estimator.set_members("paper34")?);
        let idx: Vec<usize> = names
            .iter()
            .map(|n| estimator.set().index_of(n).expect("member"))
            .collect();
        // The floor: no method restricted to the PCA space gets closer to a held-out body
        // than its orthogonal projection onto that space.
        let pca = &estimator.file().model.pca;
        let floor: Vec<f64> = (0..n)
            .map(|i| {
                let flat: Vec<f64> = heldout.bodies[i].iter().flatten().copied().collect();
                let back = pca.reconstruct(&pca.project(&flat));
                let back: Vec<Vec3> = back.chunks(3).map(|c| [c[0], c[1], c[2]]).collect();
                vertex_distance_mm(&back, &heldout.bodies[i])
            })
            .collect();
        println!(
            "| {label} | projection of the true body onto the PCA space (floor of step 1) | | | | | {:.2} | | | |",
            mean(&floor)
        );
        // The Bayes bound of the linear-Gaussian model: the weights' covariance
        // given the readings, pushed through the (orthonormal) basis, gives the
        // expected squared vertex error of the conditional mean (the best
        // estimate in the mean-square sense when the readings are linear in
        // the weights); no method that only uses the training Gaussian can do
        // better on average.
        {
            let model = &estimator.file().model;
            let m = model.n_measurements();
            let k = model.n_components();
            let wanted: Vec<usize> = (m..m + k).collect();
            let observed: Vec<(usize, f64, f64)> =
                idx.iter().map(|&j| (j, model.joint.mean[j], 0.0)).collect();
            let c = model.joint.conditional(&wanted, &observed)?;
            let v = model.n_vertices() as f64;
            let ms: f64 = (0..k)
                .map(|i| model.pca.sigma[i].powi(2) * c.cov[(i, i)])
                .sum::<f64>()
                / v;
            println!(
                "| {label} | Bayes bound: RMS vertex error expected from the Gaussian conditional of the weights on these readings | | | | | RMS {:.2} | | | |",
                ms.sqrt() * 1000.0
            );
        }
        // Per-body vertex distance of feature analysis, for the paired comparison.
        let mut vd_fa: Vec<f64> = Vec::new();
        for (method, s) in [
            ("feature analysis alone (start)", 0usize),
            ("full (start + steps 1, 2)", 3),
        ] {
            let settings = PredictOptions::custom(PredictSettings {
                s,
                ..settings_from_args(&args.settings)?
            });
            let (mut eu, mut ci, mut lo, mut vd, mut tt) = (vec![], vec![], vec![], vec![], vec![]);
            let mut vd1 = vec![];
            let (mut rms, mut rms1) = (vec![], vec![]);
            let (mut flipped, mut degenerate) = (0, 0);
            let (mut own_flipped, mut own_degenerate, mut truth_vs_mean) = (0, 0, 0);
            let mean_shape =
                estimator
                    .file()
                    .model
                    .shape(&vec![0.0; estimator.file().model.n_components()])?;
            for i in 0..n {
                let body = &heldout.bodies[i];
                let truth: Vec<f64> = idx
                    .iter()
                    .map(|&j| estimator.compiled().measure_one(j, body).map(|m| m.value))
                    .collect::<Result<_, _>>()?;
                let mut inputs = Inputs::new();
                for (name, v) in names.iter().zip(&truth) {
                    inputs.insert_metres(name, *v)?;
                }
                if keep_all {
                    inputs.kept = names.clone();
                }
                let t0 = Instant::now();
                let est = estimator.predict(&inputs, &settings)?;
                tt.push(t0.elapsed().as_secs_f64());
                let pred: Vec<f64> = idx
                    .iter()
                    .map(|&j| {
                        estimator
                            .compiled()
                            .measure_one(j, &est.mesh.vertices)
                            .map(|m| m.value)
                    })
                    .collect::<Result<_, _>>()?;
                let [a, b, c] = paper34_errors(estimator, &names, &truth, &pred);
                eu.extend(a);
                ci.extend(b);
                lo.extend(c);
                vd.push(vertex_distance_mm(&est.mesh.vertices, body));
                rms.push(vertex_rms_mm(&est.mesh.vertices, body));
                if s > 0 {
                    let w1 = &est.report.prediction.weights_step1;
                    let x1 = estimator.file().model.shape(w1)?;
                    vd1.push(vertex_distance_mm(&x1, body));
                    rms1.push(vertex_rms_mm(&x1, body));
                }
                let (f, d) = tapeshape_model::predict::triangle_changes(
                    estimator.topology(),
                    body,
                    &est.mesh.vertices,
                );
                flipped += f;
                degenerate += d;
                let pl = &est.report.prediction.plausibility;
                own_flipped += pl.flipped_triangles;
                own_degenerate += pl.degenerate_triangles;
                let (f0, _) = tapeshape_model::predict::triangle_changes(
                    estimator.topology(),
                    body,
                    &mean_shape,
                );
                truth_vs_mean += f0;
            }
            let all: Vec<f64> = ci.iter().chain(&lo).copied().collect();
            println!(
                "| {label} | {method} | {:.4} | {:.3} | {:.3} | {:.3} | {:.2} (RMS {:.2}) | {own_flipped} / {own_degenerate} | {flipped} / {degenerate} ({truth_vs_mean}) | {:.3} |",
                mean(&eu),
                mean(&ci),
                mean(&lo),
                mean(&all),
                mean(&vd),
                mean(&rms),
                mean(&tt)
            );
            if s == 0 {
                vd_fa = vd.clone();
            } else if vd_fa.len() == vd.len() && vd.len() > 1 {
                // Paired: the same bodies, so the body-to-body spread cancels.
                let d: Vec<f64> = vd.iter().zip(&vd_fa).map(|(a, b)| a - b).collect();
                let md = mean(&d);
                let sd =
                    (d.iter().map(|x| (x - md).powi(2)).sum::<f64>() / (d.len() - 1) as f64).sqrt();
                println!(
                    "| {label} | paired: full minus feature analysis, per body | | | | | {md:+.3} +- {:.3} (SE); closer on {}/{} bodies | | | |",
                    sd / (d.len() as f64).sqrt(),
                    d.iter().filter(|x| **x < 0.0).count(),
                    d.len()
                );
            }
            if !vd1.is_empty() {
                println!(
                    "| {label} | step-1 shape of the full run (inside the PCA space) | | | | | {:.2} (RMS {:.2}) | | | |",
                    mean(&vd1),
                    mean(&rms1)
                );
                // Paired: what step 2 did to the distance, body by body.
                let d: Vec<f64> = vd.iter().zip(&vd1).map(|(a, b)| a - b).collect();
                if d.len() > 1 {
                    let md = mean(&d);
                    let sd = (d.iter().map(|x| (x - md).powi(2)).sum::<f64>()
                        / (d.len() - 1) as f64)
                        .sqrt();
                    println!(
                        "| {label} | paired: full minus its step-1 shape, per body | | | | | {md:+.4} +- {:.4} (SE); closer on {}/{} bodies | | | |",
                        sd / (d.len() as f64).sqrt(),
                        d.iter().filter(|x| **x < 0.0).count(),
                        d.len()
                    );
                }
            }
        }
    }
    Ok(())
}

/// ISO 20685-1 pass counts per measurement: name -> (passed, total).
type Shares = BTreeMap<String, (usize, usize)>;

fn tally(
    estimator: &Estimator,
    inputs: &Inputs,
    settings: &PredictOptions,
    shares: &mut Shares,
    refused: &mut Vec<String>,
    first: &mut [usize; 2],
) -> Result<(), Box<dyn std::error::Error>> {
    let est = match estimator.predict(inputs, settings) {
        Ok(e) => e,
        Err(
            e @ (PredictError::Contradiction(_)
            | PredictError::OutOfRange(_)
            | PredictError::OutOfPopulation { .. }),
        ) => {
            refused.push(e.to_string());
            for r in &inputs.readings {
                shares.entry(r.name.clone()).or_default().1 += 1;
            }
            return Ok(());
        }
        Err(e) => return Err(e.into()),
    };
    if let Some(f) = &est.report.prediction.step2_first {
        first[usize::from(!f.kept)] += 1;
    }
    for r in &inputs.readings {
        let j = estimator.set().index_of(&r.name).expect("known");
        let tol = estimator.set().definitions[j].tolerance.mm();
        let v = estimator
            .compiled()
            .measure_one(j, &est.mesh.vertices)?
            .value;
        let e = shares.entry(r.name.clone()).or_default();
        e.1 += 1;
        if ((v - r.value.metres) * 1000.0).abs() <= tol {
            e.0 += 1;
        }
    }
    Ok(())
}

/// Prints one table; `first`: estimates whose step-2 first solver was
/// kept and fell back.
fn print_shares(
    title: &str,
    estimator: &Estimator,
    shares: &Shares,
    refused: &[String],
    first: [usize; 2],
) {
    println!("\n{title}\n");
    let [kept, fell_back] = first;
    if kept + fell_back > 0 {
        println!("step 2's first solver: kept in {kept}, fell back in {fell_back}\n");
    }
    println!("| measurement | ISO tolerance mm | passed | share |");
    println!("|---|---|---|---|");
    let (mut p, mut t) = (0, 0);
    for (name, (ok, n)) in shares {
        let j = estimator.set().index_of(name).expect("known");
        println!(
            "| {name} | {} | {ok}/{n} | {:.1} % |",
            estimator.set().definitions[j].tolerance.mm(),
            100.0 * *ok as f64 / *n as f64
        );
        p += ok;
        t += n;
    }
    println!(
        "| **all** | | {p}/{t} | {:.1} % |",
        100.0 * p as f64 / t.max(1) as f64
    );
    if !refused.is_empty() {
        println!(
            "\n{} predictions refused by the input checks (counted as failures), e.g.: {}",
            refused.len(),
            refused[0]
        );
    }
}

fn iso(args: &Iso) -> Result<(), Box<dyn std::error::Error>> {
    let estimator = match &args.model {
        Some(m) => Estimator::load(m)?,
        None => Estimator::new(
            Estimator::default_model()?.file().clone(),
            "embedded default model",
        )?,
    };
    let n = args.n;
    let n_ansur = args.ansur;
    let n_subsets = args.subsets;
    let settings = settings_from_args(&args.settings)?;
    println!(
        "settings: l = {}, lambda = {}, s = {}, step 1 {:?} weighted {:?}, step-2 weighting {:?}",
        settings.l,
        settings.step2.lambda,
        settings.s,
        settings.step1.solver,
        settings.step1.weighting,
        settings.step2.weighting
    );
    let settings = PredictOptions::custom(settings);
    let heldout = args
        .heldout
        .as_ref()
        .map(|h| Dataset::read(h))
        .transpose()?;
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(4);
    for set in ["quick", "ansur"] {
        let names = usable(&estimator, estimator.set_members(set)?);
        let idx: Vec<usize> = names
            .iter()
            .map(|n| estimator.set().index_of(n).expect("member"))
            .collect();
        if let Some(h) = &heldout {
            let (mut full, mut sub, mut rf, mut rs) =
                (Shares::new(), Shares::new(), vec![], vec![]);
            let (mut ff, mut fs) = ([0; 2], [0; 2]);
            for body in h.bodies.iter().take(n) {
                let truth: Vec<f64> = idx
                    .iter()
                    .map(|&j| estimator.compiled().measure_one(j, body).map(|m| m.value))
                    .collect::<Result<_, _>>()?;
                let mut inputs = Inputs::new();
                for (name, v) in names.iter().zip(&truth) {
                    inputs.insert_metres(name, *v)?;
                }
                tally(&estimator, &inputs, &settings, &mut full, &mut rf, &mut ff)?;
                if set == "quick" {
                    for _ in 0..n_subsets {
                        let mut order: Vec<usize> = (0..names.len()).collect();
                        // `seeded`: the same subsets as the figures of
                        // docs/results/predict-iso.md, whatever the rand release.
                        seeded::shuffle(&mut rng, &mut order);
                        let k = seeded::index_in(&mut rng, 3..names.len());
                        let mut inputs = Inputs::new();
                        for &a in &order[..k] {
                            inputs.insert_metres(&names[a], truth[a])?;
                        }
                        tally(&estimator, &inputs, &settings, &mut sub, &mut rs, &mut fs)?;
                    }
                }
            }
            print_shares(
                &format!(
                    "{set}: {} held-out generated bodies, all {} measurements",
                    n.min(h.len()),
                    names.len()
                ),
                &estimator,
                &full,
                &rf,
                ff,
            );
            if set == "quick" {
                print_shares(
                    &format!("quick: random subsets (3 to 8 measurements), {n_subsets} per body"),
                    &estimator,
                    &sub,
                    &rs,
                    fs,
                );
            }
        }
        if n_ansur > 0 {
            let ansur = Ansur::get()?;
            let (mut sh, mut rf, mut ff) = (Shares::new(), vec![], [0; 2]);
            let mut used = 0;
            for subject in ansur.subjects(None, Split::Test).take(n_ansur) {
                let mut inputs = Inputs::new();
                for name in &names {
                    let d = &estimator.set().definitions
                        [estimator.set().index_of(name).expect("member")];
                    if let Some(v) = d.ansur.as_deref().and_then(|c| subject.dim(c)) {
                        inputs.insert_metres(name, v)?;
                    }
                }
                used += 1;
                tally(&estimator, &inputs, &settings, &mut sh, &mut rf, &mut ff)?;
            }
            print_shares(&format!("{set}: {used} ANSUR II test-split subjects (ids divisible by 4), their real values as input (a fit check)"), &estimator, &sh, &rf, ff);
        }
    }
    Ok(())
}

/// Why does a measurement miss its ISO tolerance? For the first `--n`
/// held-out bodies, predicts from the full `--set` and, for every body with
/// a failing measurement, prints the report (target, start, step 1, step 2)
/// and what each L-BFGS run did (iterations, energy, why it stopped).
fn diag(args: &Diag) -> Result<(), Box<dyn std::error::Error>> {
    let estimator = match &args.model {
        Some(m) => Estimator::load(m)?,
        None => Estimator::new(
            Estimator::default_model()?.file().clone(),
            "embedded default model",
        )?,
    };
    let n = args.n;
    let set = &args.set;
    let settings = PredictOptions::custom(settings_from_args(&args.settings)?);
    let names = usable(&estimator, estimator.set_members(set)?);
    let idx: Vec<usize> = names
        .iter()
        .map(|n| estimator.set().index_of(n).expect("member"))
        .collect();
    let only: Option<&Vec<usize>> = args.bodies.as_ref();
    // Inputs: held-out bodies' values (--heldout FILE) or ANSUR II test-split
    // subjects' real values (--ansur-subjects).
    let cases: Vec<Vec<Option<f64>>> = if let Some(h) = &args.heldout {
        let heldout = Dataset::read(h)?;
        heldout
            .bodies
            .iter()
            .take(n)
            .map(|body| {
                idx.iter()
                    .map(|&j| {
                        estimator
                            .compiled()
                            .measure_one(j, body)
                            .map(|m| Some(m.value))
                    })
                    .collect::<Result<_, _>>()
            })
            .collect::<Result<_, _>>()?
    } else {
        let ansur = Ansur::get()?;
        ansur
            .subjects(None, Split::Test)
            .take(n)
            .map(|subject| {
                idx.iter()
                    .map(|&j| {
                        estimator.set().definitions[j]
                            .ansur
                            .as_deref()
                            .and_then(|c| subject.dim(c))
                    })
                    .collect()
            })
            .collect()
    };
    for (b, case) in cases.iter().enumerate() {
        if only.is_some_and(|o| !o.contains(&b)) {
            continue;
        }
        let mut inputs = Inputs::new();
        for (name, v) in names.iter().zip(case) {
            if let Some(v) = v {
                inputs.insert_metres(name, *v)?;
            }
        }
        let truth: Vec<f64> = case.iter().map(|v| v.unwrap_or(f64::NAN)).collect();
        let est = estimator.predict(&inputs, &settings)?;
        let mut failing = Vec::new();
        for (k, &j) in idx.iter().enumerate() {
            let tol = estimator.set().definitions[j].tolerance.mm();
            let v = estimator
                .compiled()
                .measure_one(j, &est.mesh.vertices)?
                .value;
            let e = (v - truth[k]) * 1000.0;
            if e.abs() > tol {
                failing.push(format!("{} {e:+.1} mm (tol {tol})", names[k]));
            }
        }
        let r = &est.report.prediction;
        println!(
            "body {b}: {} failing: {}",
            failing.len(),
            failing.join(", ")
        );
        if !failing.is_empty() || args.all.is_some() {
            for m in &r.measurements {
                if let (Some(t), Some(s0), Some(s1), Some(s2)) =
                    (m.target_mm, m.start_mm, m.step1_mm, m.step2_mm)
                {
                    println!(
                        "  {:<28} target {t:8.1}  start {:+7.2}  step1 {:+7.2}  step2 {:+7.2}",
                        m.name,
                        s0 - t,
                        s1 - t,
                        s2 - t
                    );
                }
            }
            println!(
                "  rounds: step 1 {:?}, step 2 {:?}",
                r.step1_rounds, r.step2_rounds
            );
            for (k, run) in r.step1_runs.iter().enumerate() {
                println!(
                    "  step1 run {k}: {} it, E {:.3e} -> {:.3e}, {}",
                    run.iterations, run.cost_start, run.cost_end, run.reason
                );
            }
            for (k, run) in r.step2_runs.iter().enumerate() {
                println!(
                    "  step2 run {k}: {} it, E {:.3e} -> {:.3e}, {}",
                    run.iterations, run.cost_start, run.cost_end, run.reason
                );
            }
            if let Some(f) = &r.step2_first {
                println!("  step2 first solver: kept {}, misses {}", f.kept, f.misses);
            }
            println!(
                "  time: step1 {:.0} ms, step2 {:.0} ms",
                r.timings.step1.as_secs_f64() * 1e3,
                r.timings.step2.as_secs_f64() * 1e3
            );
            for w in &r.warnings {
                println!("  warning: {w}");
            }
        }
    }
    Ok(())
}

/// Prediction settings from the flags (defaults: the station's), in the
/// order `Settings` lists them: `--paper` first, `--gn` before the other
/// step-1 flags (they apply to the solver it picks), `--w2-scale` with or
/// after `--w2`, `--cont` before `--cont-iters1` and `--budget`,
/// `--solver2` before `--iters2`. A flag that needs a setting the others
/// left out is an error.
fn settings_from_args(args: &Settings) -> Result<PredictSettings, Box<dyn std::error::Error>> {
    let mut s = if args.paper {
        PredictSettings::paper()
    } else {
        PredictSettings::default()
    };
    if let Some(v) = args.l {
        s.l = v;
    }
    if let Some(v) = args.lambda {
        s.step2.lambda = v;
    }
    if let Some(v) = args.s {
        s.s = v;
    }
    if let Some(v) = args.gn {
        // Keeps the reading noise / prior the current solver had.
        let tau = match s.step1.solver {
            Step1Solver::Lbfgs { prior_mm } => prior_mm,
            Step1Solver::GaussNewtonMap { tau_mm, .. } => tau_mm,
        };
        s.step1.solver = match v {
            OnOff::On => Step1Solver::GaussNewtonMap {
                tau_mm: tau,
                min_decrease_mm: tapeshape_model::predict::DEFAULT_STEP1_MIN_DECREASE_MM,
            },
            OnOff::Off => Step1Solver::Lbfgs { prior_mm: tau },
        };
    }
    if let Some(v) = args.prior {
        let tau = Some(v);
        s.step1.solver = match s.step1.solver {
            Step1Solver::Lbfgs { .. } => Step1Solver::Lbfgs { prior_mm: tau },
            Step1Solver::GaussNewtonMap {
                min_decrease_mm, ..
            } => Step1Solver::GaussNewtonMap {
                tau_mm: tau,
                min_decrease_mm,
            },
        };
    }
    if let Some(v) = args.gn_min_decrease {
        match &mut s.step1.solver {
            Step1Solver::GaussNewtonMap {
                min_decrease_mm, ..
            } => *min_decrease_mm = v,
            Step1Solver::Lbfgs { .. } => {
                return Err("--gn-min-decrease needs step 1's Gauss-Newton (--gn on)".into())
            }
        }
    }
    let weighting = |v: Weighting| match v {
        Weighting::Paper => EnergyWeighting::Paper,
        Weighting::PerMeasurement => EnergyWeighting::PerMeasurement,
    };
    if let Some(v) = args.w1 {
        s.step1.weighting = weighting(v);
    }
    let scale = args.w2_scale;
    let current_scale = match s.step2.weighting {
        Step2Weighting::PerMeasurement { reading_weight } => reading_weight,
        Step2Weighting::Paper => 1e4,
    };
    if let Some(v) = args.w2 {
        s.step2.weighting = match weighting(v) {
            EnergyWeighting::Paper => Step2Weighting::Paper,
            EnergyWeighting::PerMeasurement => Step2Weighting::PerMeasurement {
                reading_weight: scale.unwrap_or(current_scale),
            },
        };
    }
    if let Some(w) = scale {
        match &mut s.step2.weighting {
            Step2Weighting::PerMeasurement { reading_weight } => *reading_weight = w,
            Step2Weighting::Paper => {
                return Err(
                    "--w2-scale needs per-measurement step-2 weighting (--w2 per-measurement)"
                        .into(),
                )
            }
        }
    }
    if let Some(v) = args.k1 {
        s.step1.components = Some(v);
    }
    if let Some(v) = args.clamp {
        s.step1.clamp = match v {
            OnOff::On => Step1Clamp::InsideBox,
            OnOff::Off => Step1Clamp::AfterStep,
        };
    }
    if let Some(v) = args.cont {
        s.continuation = match v {
            Cont::Off => None,
            Cont::Rounds(n) => Some(Continuation {
                max_extra_rounds: n,
                ..Default::default()
            }),
        };
    }
    if let Some(v) = args.cont_iters1 {
        match &mut s.continuation {
            Some(c) => {
                c.step1_max_iters = match v {
                    ContIters1::Solver => None,
                    ContIters1::Iters(n) => Some(n),
                }
            }
            None => return Err("--cont-iters1 needs the continuation (not with --cont off)".into()),
        }
    }
    if let Some(v) = args.budget {
        match &mut s.continuation {
            Some(c) => c.max_evaluations = v,
            None => return Err("--budget needs the continuation (not with --cont off)".into()),
        }
    }
    if let Some(v) = args.iters1 {
        s.step1.stop.max_iters = v;
    }
    if let Some(v) = args.solver2 {
        s.step2.solver = v;
    }
    if let Some(v) = args.iters2 {
        *s.step2.solver.max_iters_mut() = v;
    }
    if let Some(v) = args.first {
        s.step2.first = match v {
            First::None => None,
            First::Smooth => Some(Step2Solver::smooth_basis()),
        };
    }
    Ok(s)
}
