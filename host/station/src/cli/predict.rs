//! `tapeshape predict --measure stature=176.5cm --measure chest=98cm ... -o body.glb`:
//! estimates a customer's body from tape readings with the paper's method
//! and prints, per measurement, the target, the value after the start, after
//! step 1 and after step 2, and the error; then the plausibility and times.
//!
//! Why here and not in the estimator: parsing the command line, reading the
//! readings file and writing files; the checks and the method live in
//! `tapeshape_estimator`, shared with the TUI and the tests.
//!
//! Units: every value takes its unit (`176.5cm`, `1765mm`, `1.765m`,
//! `69.5in`); a bare number is read as centimetres (what a tape shows) and
//! the report says so. Output files (the report, the mesh, the customer's
//! card) go to a temporary name, then renamed.

use std::path::{Path, PathBuf};

use anyhow::{bail, Context as _};
use tapeshape_estimator::{EstimateReport, Estimator, Inputs, PredictOptions};

use super::Global;
use crate::estimate::MeshFormat;

/// Arguments of `tapeshape predict`.
#[derive(clap::Args, Debug)]
#[command(
    after_help = "Values take a unit: 176.5cm, 1765mm, 1.765m, 69.5in. A number without a unit is read as cm.\n\
Examples:\n  tapeshape predict --measure stature=176.5cm --measure chest=98cm --measure waist=84cm -o body.glb\n  \
tapeshape predict --measurements customer.toml --report report.json -o body.obj\n  \
tapeshape predict --measurements customer.toml --chart examples/size-charts/menswear.toml --card card.pdf\n  tapeshape predict --list"
)]
pub struct Args {
    /// Model file from `tapeshape train` [default: the embedded model, trained
    /// on 400 generated bodies with the paper34, ansur and quick sets].
    #[arg(long, value_name = "FILE")]
    pub model: Option<PathBuf>,

    /// A reading, NAME=VALUE with a unit (e.g. stature=176.5cm); repeat for each.
    #[arg(long = "measure", value_name = "NAME=VALUE")]
    pub measures: Vec<String>,

    /// Readings from a file: TOML or JSON (`name = "98cm"`, optional
    /// `unit = "cm"` for bare numbers, `name = { value = .., tolerance = .. }`)
    /// or a CSV with a header row and one value row (optional `unit` column).
    #[arg(long, value_name = "FILE")]
    pub measurements: Option<PathBuf>,

    /// Uncertainty of a reading, NAME=LENGTH (bare numbers are mm), e.g.
    /// chest=10mm for a novice's tape: that reading then counts for less.
    #[arg(long = "tolerance", value_name = "NAME=MM")]
    pub tolerances: Vec<String>,

    /// The customer's sex (female or male; f, m): what was not measured
    /// then follows real people of that sex. Without it both are pooled.
    #[arg(long, value_name = "SEX", value_parser = parse_sex)]
    pub sex: Option<tapeshape_population::ansur::Sex>,

    /// Keep a reading the checks would refuse (the operator re-measured
    /// and it is right): the body is estimated with it and a warning; only
    /// impossible values are refused then. Repeat for each.
    #[arg(long = "keep", value_name = "NAME")]
    pub keep: Vec<String>,

    /// The values were taken as the ANSUR II survey takes them (calipers
    /// that compress the tissue, flexed girths), as in ANSUR data: readings
    /// of the dimensions the standing body cannot take that way (chest and
    /// bicristal breadth, flexed biceps and forearm girths) are then
    /// recorded in the report, not fitted; so is the sleeve outseam (arm length)
    /// when the acromion-radiale and radiale-stylion lengths are given too
    /// (on the body it is their sum; ANSUR's is about 10 mm shorter).
    #[arg(long)]
    pub ansur_survey: bool,

    /// Estimate what was not measured from the model alone, without the
    /// soft targets from real people (ANSUR II statistics).
    #[arg(long)]
    pub no_real_people: bool,

    /// A store's size chart (TOML, docs/size-charts.md; examples in
    /// examples/size-charts/): print the size per garment and add it to
    /// the report as "sizes".
    #[arg(long, value_name = "FILE")]
    pub chart: Option<PathBuf>,

    /// Write the customer's card: a PDF with the body front and side, the
    /// readings, what was read off the body and the sizes (with --chart);
    /// "no session" (docs/card.md).
    #[arg(long, value_name = "FILE")]
    pub card: Option<PathBuf>,

    /// Write the body mesh (format by extension: .obj, .ply or .glb).
    #[arg(short, long, value_name = "FILE")]
    pub out: Option<PathBuf>,

    /// Write the full report as JSON.
    #[arg(long, value_name = "FILE")]
    pub report: Option<PathBuf>,

    /// Clamp of the normalised PCA weights, in SDs (paper: 3 synthetic, 10
    /// real) [default: 3].
    #[arg(long)]
    pub l: Option<f64>,

    /// Weight of the smoothness energy in step 2, in [0, 1] [default: 0.1, the paper's].
    #[arg(long)]
    pub lambda: Option<f64>,

    /// Rounds of support recomputation per step (0 = the start only) [default: 3, the paper's].
    #[arg(long)]
    pub s: Option<usize>,

    /// Weight of step 2's bending term, which keeps a body entered with many
    /// readings from creasing at the cost of meeting fewer of them (with
    /// `--l 1`: docs/results/real-customers/surface-check.md) [default: 0, the paper's].
    #[arg(long, value_name = "MU")]
    pub bending: Option<f64>,

    /// How step 2 solves: `smooth-first` tries the template's 200 smoothest
    /// modes first and keeps that body where it meets every reading, else
    /// runs L-BFGS (fast; docs/prediction.md); `lbfgs` is the paper's L-BFGS
    /// alone (slower, the reference) [default: smooth-first; lbfgs with --bending].
    #[arg(long, value_name = "SOLVER", value_enum)]
    pub step2: Option<Step2Choice>,

    /// Leave the triangles step 2 folded as they are. By default a body
    /// whose surface step 2 turned over in places (a crotch or navel pulled
    /// through its neighbours by many readings) is smoothed there, kept only
    /// where no reading within its ISO 20685-1 allowable error falls out,
    /// and the report says so (`folds-smoothed`; docs/prediction.md).
    #[arg(long)]
    pub no_fold_repair: bool,

    /// List the model's measurements (name, sets, label) and exit.
    #[arg(long)]
    pub list: bool,
}

/// `--step2`: how step 2 solves.
#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum Step2Choice {
    /// The smooth basis first, L-BFGS where it misses a reading.
    SmoothFirst,
    /// The paper's L-BFGS alone.
    Lbfgs,
}

fn parse_sex(text: &str) -> Result<tapeshape_population::ansur::Sex, String> {
    tapeshape_population::ansur::Sex::parse(text)
        .ok_or_else(|| format!("'{text}' is not a sex: write female or male (f, m)"))
}

fn load_engine(model: Option<&Path>) -> anyhow::Result<EngineRef> {
    Ok(match model {
        Some(p) => EngineRef::Owned(Box::new(
            Estimator::load(p).with_context(|| format!("loading the model {}", p.display()))?,
        )),
        None => EngineRef::Default(Estimator::default_model()?),
    })
}

enum EngineRef {
    Owned(Box<Estimator>),
    Default(&'static Estimator),
}

impl std::ops::Deref for EngineRef {
    type Target = Estimator;
    fn deref(&self) -> &Estimator {
        match self {
            EngineRef::Owned(e) => e,
            EngineRef::Default(e) => e,
        }
    }
}

/// Runs `tapeshape predict`.
pub fn run(args: Args, _global: &Global) -> anyhow::Result<()> {
    let estimator = load_engine(args.model.as_deref())?;
    if args.list {
        print_list(&estimator)?;
        return Ok(());
    }
    if let Some(out) = &args.out {
        MeshFormat::from_path(out)?;
    }
    let mut inputs = match &args.measurements {
        Some(p) => Inputs::from_file(p)?,
        None => Inputs::new(),
    };
    for m in &args.measures {
        inputs.add_assignment(m)?;
    }
    for t in &args.tolerances {
        inputs.set_tolerance(t)?;
    }
    if args.sex.is_some() {
        inputs.sex = args.sex;
    }
    inputs.kept.extend(args.keep.iter().cloned());
    inputs.ansur_survey |= args.ansur_survey;
    if inputs.readings.is_empty() {
        bail!("no measurements given: use --measure NAME=VALUE (e.g. stature=176.5cm) or --measurements FILE; `tapeshape predict --list` shows the names");
    }
    let options = PredictOptions {
        l: args.l,
        lambda: args.lambda,
        s: args.s,
        bending: args.bending,
        smooth_first: args.step2.map(|c| c == Step2Choice::SmoothFirst),
        real_people: args.no_real_people.then_some(None),
        fold_repair: args.no_fold_repair.then_some(false),
        ..PredictOptions::default()
    };
    // The chart is checked before the estimate: a wrong chart costs nothing.
    let chart = match &args.chart {
        Some(p) => Some(crate::estimate::sizes::load_chart(p, &estimator)?),
        None => None,
    };
    let estimate = estimator.predict(&inputs, &options)?;
    print_report(&estimate.report)?;
    let sizes = chart
        .as_ref()
        .map(|c| crate::estimate::sizes::sizes(&estimator, &estimate.report, c));
    if let Some(s) = &sizes {
        outln!("{s}")?;
    }
    if let Some(path) = &args.report {
        let mut value = estimate.report.to_json().context("encoding the report")?;
        if let (Some(s), Some(obj)) = (&sizes, value.as_object_mut()) {
            obj.insert(
                "sizes".into(),
                serde_json::to_value(s).context("encoding the sizes")?,
            );
        }
        let json = serde_json::to_vec_pretty(&value).context("encoding the report")?;
        tapeshape_common::fs::write_atomic(path, &json)
            .with_context(|| format!("writing the report {}", path.display()))?;
        outln!("report: {}", path.display())?;
    }
    if let Some(path) = &args.out {
        write_mesh(&estimate.mesh, path)?;
        outln!("body: {}", path.display())?;
    }
    if let Some(path) = &args.card {
        let card = crate::estimate::card::Card::new(
            &estimator,
            &estimate.report,
            estimate.mesh.clone(),
            None,
            sizes,
        );
        let pdf = crate::estimate::card::card_pdf(&card)?;
        crate::estimate::card::write_card(path, &pdf)?;
        outln!("card: {}", path.display())?;
    }
    Ok(())
}

fn write_mesh(mesh: &tapeshape_mesh::Mesh, path: &Path) -> anyhow::Result<()> {
    MeshFormat::from_path(path)?
        .write(mesh, path)
        .with_context(|| format!("writing the body {}", path.display()))
}

fn print_list(estimator: &Estimator) -> std::io::Result<()> {
    let sets: Vec<(&str, Vec<String>)> = ["quick", "ansur", "paper34"]
        .iter()
        .filter_map(|s| estimator.set_members(s).ok().map(|m| (*s, m)))
        .collect();
    outln!(
        "{} measurements ({}); sets: {}",
        estimator.set().len(),
        estimator.file().measurement_set.name,
        sets.iter().map(|s| s.0).collect::<Vec<_>>().join(", ")
    )?;
    for d in &estimator.set().definitions {
        let member: Vec<&str> = sets
            .iter()
            .filter(|s| s.1.contains(&d.name))
            .map(|s| s.0)
            .collect();
        outln!("  {:<32} {:<18} {}", d.name, member.join(","), d.label)?;
    }
    Ok(())
}

fn fmt_mm(x: Option<f64>) -> String {
    x.map_or_else(|| "-".into(), |v| format!("{:.1}", v))
}

fn print_report(r: &EstimateReport) -> std::io::Result<()> {
    let p = &r.prediction;
    outln!(
        "{:<28} {:>9} {:>9} {:>9} {:>9} {:>8}",
        "measurement (mm)",
        "target",
        "start",
        "step 1",
        "step 2",
        "error"
    )?;
    let entered = |name: &str| r.inputs.iter().any(|c| c.name == name);
    for m in p
        .measurements
        .iter()
        .filter(|m| m.target_mm.is_some() && entered(&m.name))
    {
        let name = if m.recorded_only {
            format!("{} (recorded)", m.name)
        } else {
            m.name.clone()
        };
        outln!(
            "{:<28} {:>9} {:>9} {:>9} {:>9} {:>8}",
            name,
            fmt_mm(m.target_mm),
            fmt_mm(m.start_mm),
            fmt_mm(m.step1_mm),
            fmt_mm(m.step2_mm),
            m.error_mm.map_or("-".into(), |e| format!("{e:.2}"))
        )?;
    }
    for t in &r.totals {
        outln!(
            "{} {:.1} mm taken as one reading: shared out over {}",
            t.total,
            t.value_mm,
            t.pieces
                .iter()
                .map(|(n, v)| format!("{n} {v:.1}"))
                .collect::<Vec<_>>()
                .join(", ")
        )?;
    }
    if !r.soft_targets.is_empty() {
        outln!(
            "not measured: {} dimensions guided by real people{} (ANSUR II statistics given these readings; the report lists them)",
            r.soft_targets.len(),
            match r.sex {
                Some(s) => format!(" ({})", s.word()),
                None => " (both sexes)".into(),
            }
        )?;
    }
    let pl = &p.plausibility;
    outln!(
        "plausibility: result {:?} (Mahalanobis {:.2} over {} components), readings {:?} (Mahalanobis {:.2}); step 2 left the PCA space by {:.2} mm RMS ({:.2} max); flipped triangles {}, degenerate {}",
        pl.label,
        pl.mahalanobis,
        p.weights_step1.len(),
        pl.measurements_label,
        pl.measurements_mahalanobis,
        pl.out_of_space_rms_mm,
        pl.out_of_space_max_mm,
        pl.flipped_triangles,
        pl.degenerate_triangles
    )?;
    let t = &p.timings;
    outln!(
        "time: checks {:.1} ms, start {:.1} ms, step 1 {:.1} ms, step 2 {:.1} ms, total {:.1} ms",
        r.check_time.as_secs_f64() * 1e3,
        t.start.as_secs_f64() * 1e3,
        t.step1.as_secs_f64() * 1e3,
        t.step2.as_secs_f64() * 1e3,
        t.total.as_secs_f64() * 1e3
    )?;
    if let Some(f) = &p.step2_first {
        match (&f.error, f.kept) {
            (_, true) => outln!("step 2: in the smooth basis (it met every reading)")?,
            (Some(e), _) => outln!("step 2: L-BFGS (the smooth basis could not run: {e})")?,
            (None, false) => outln!(
                "step 2: L-BFGS (the smooth basis left {} reading(s) beyond the fit it aims for, by default half the ISO 20685-1 allowable error)",
                f.misses
            )?,
        }
    } else {
        outln!("step 2: L-BFGS alone (--step2 lbfgs, --bending, or the paper's pipeline)")?;
    }
    for w in &r.warnings {
        outln!("warning: {w}")?;
    }
    Ok(())
}
