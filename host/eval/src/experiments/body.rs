//! `body-synthetic` and `body-real-table`: the paper's body experiments
//! (its Tables of average errors and of S_real per measurement) on
//! generated bodies with the `paper34` set.

use tapeshape_body::render::View;
use tapeshape_measure::MeasurementSet;

use super::common::{
    informative, mean, run_all, summarise, training_data, Case, Dimensions, MeasurementGaussian,
    Outcome as Res, Reference,
};
use super::{beats, population, recipe, train, EvalError, Options, Outcome, Params, Roster, Topo};
use crate::figures::{
    body_views, colour_bar, common_region, grid, save, signed_distance_mm, Paint,
};
use crate::report::{Cell, Report, Table};
use crate::Method;

/// The paper's Table of average body errors (mm): S_close, S_2, S_4, S_real.
pub const PAPER_BODY: [(&str, [f64; 4]); 3] = [
    ("feature analysis", [3.29, 14.26, 36.86, 3.09]),
    ("SGPLVM", [4.91, 12.19, 22.88, 4.55]),
    ("ours", [1.74, 6.39, 15.49, 1.10]),
];

/// The paper's S_real table for its method: (our dimension name, average
/// mm, maximum mm), in the paper's row order.
pub const PAPER_SREAL_OURS: [(&str, f64, f64); 22] = [
    ("foot_length_left", 2.38e-4, 2.02e-3),
    ("lower_leg_length_left", 4.93e-4, 1.82e-3),
    ("upper_leg_length_left", 7.79e-4, 3.48e-3),
    ("upper_leg_length_right", 9.56e-4, 3.62e-3),
    ("lower_leg_length_right", 5.57e-4, 2.49e-3),
    ("foot_length_right", 2.09e-4, 2.28e-3),
    ("upper_body_length", 2.99e-4, 9.91e-4),
    ("shoulder_neck_distance_right", 1.71e-3, 6.65e-3),
    ("upper_arm_length_right", 6.11e-4, 1.74e-3),
    ("lower_arm_length_right", 4.42e-4, 1.79e-3),
    ("shoulder_neck_distance_left", 2.12e-3, 8.50e-3),
    ("upper_arm_length_left", 7.16e-4, 2.2e-3),
    ("lower_arm_length_left", 4.79e-4, 2.21e-3),
    ("head_neck_distance", 1.14e-3, 5.38e-3),
    ("knee_circumference_right", 5.48, 15.36),
    ("knee_circumference_left", 6.02, 24.44),
    ("arm_circumference_right", 4.62, 11.17),
    ("arm_circumference_left", 5.07, 16.36),
    ("hip_circumference", 5.29, 40.01),
    ("waist_circumference", 1.24, 6.11),
    ("chest_circumference", 1.29, 4.08),
    ("head_circumference", 8.414, 26.76),
];

/// Sizes of a run.
struct Sizes {
    n_train: usize,
    n_held: usize,
    n_samples: usize,
}

fn sizes(quick: bool) -> Sizes {
    if quick {
        Sizes {
            n_train: 40,
            n_held: 4,
            n_samples: 6,
        }
    } else {
        Sizes {
            n_train: 360,
            n_held: 50,
            n_samples: 200,
        }
    }
}

/// Parameters of the synthetic body experiments (the paper's: l = 3,
/// lambda = 0.1, s = 3).
pub const BODY_PARAMS: Params = Params {
    l: 3.0,
    lambda: 0.1,
    s: 3,
};

/// Training data, held-out bodies and what is measured.
struct Setup {
    data: crate::TrainingData,
    held: Vec<Vec<tapeshape_mesh::Vec3>>,
    used: Vec<usize>,
    dims: Dimensions,
    set: MeasurementSet,
    reference: Reference,
    train_recipe: String,
    held_recipe: String,
}

fn setup(s: &Sizes) -> Result<Setup, EvalError> {
    let train_set = population(s.n_train, 1, 0.5, "training bodies")?;
    let held = population(s.n_held, 2, 0.5, "held-out bodies")?;
    let set = MeasurementSet::load("paper34")?;
    let anatomy = tapeshape_body::anatomy::anatomy();
    let data = training_data(train_set.bodies, &train_set.topology, &set, &anatomy)?;
    let used = informative(&data.measurements);
    let dims = Dimensions::of(&set, &used);
    let reference = Reference::new(&data)?;
    Ok(Setup {
        data,
        held: held.bodies,
        used,
        dims,
        set,
        reference,
        train_recipe: recipe(s.n_train, 1, 0.5),
        held_recipe: recipe(s.n_held, 2, 0.5),
    })
}

/// S_real cases: every held-out body's `used` measurements as targets.
fn sreal_cases(su: &Setup, keep: usize) -> Vec<Case> {
    su.held
        .iter()
        .enumerate()
        .map(|(i, body)| {
            let all = super::common::measure_all(&su.data.compiled, body);
            let mut t = vec![None; all.len()];
            for &j in &su.used {
                t[j] = Some(all[j]);
            }
            Case {
                targets: t,
                truth: Some(body.clone()),
                keep: i < keep,
            }
        })
        .collect()
}

fn data_text(su: &Setup, s: &Sizes) -> String {
    let left_out: Vec<&str> = (0..su.set.definitions.len())
        .filter(|j| !su.used.contains(j))
        .map(|j| su.set.definitions[j].name.as_str())
        .collect();
    format!(
        "**Data.** The paper trained on 360 CAESAR scans; the project has no scans, so the bodies are generated: \
training = {} ({} bodies), held-out S_real bodies = {} ({} bodies; other random draws of people and local variation, \
never trained on). Measurement set `paper34` ({} of 34 measurements vary on the training set{}), reported as {} \
dimensions: 14 lengths, 4 planar circumferences and 4 knee/arm circumferences whose error is the **sum of the errors of their 4 geodesics** (as the paper's S_real table).",
        su.train_recipe,
        s.n_train,
        su.held_recipe,
        s.n_held,
        su.used.len(),
        if left_out.is_empty() {
            String::new()
        } else {
            format!("; constant and left out: {}", left_out.join(", "))
        },
        su.dims.len()
    )
}

const READING: &str = "**How the paper's definitions are read.** N(mu, Sigma) is fitted to the training bodies' measurements \
(the informative ones, metres). **S_close**: 200 draws of N(mu, Sigma). **S_k** (k = 2, 4): two readings of the paper's \
\"points on the ellipsoidal surface x^T Sigma^-1 x where x = mu + k Sigma_d\": S_2 and S_4 = 200 points at Mahalanobis distance \
exactly k (x = mu + k L u, L L^T = Sigma, u uniform on the unit sphere; the method notes' reading), and S_2' and S_4' = 200 points \
on the ellipsoid through mu + k sigma (the literal reading; see `body-synthetic`). **S_real**: the held-out bodies measured \
digitally. **Error** of one result in one dimension = |value measured on the result - input value| in mm (a knee or arm \
circumference: the sum over its 4 geodesics); a table cell averages over all dimensions and all samples. Every method gets all \
informative measurements. Feature analysis is the paper's (Allen et al.): w = B [P; 1], not clamped.";

const METRICS: &str = "**Beyond the paper.** *Implausible*: share of results whose normalised PCA weights (the result projected \
onto the PCA of the training bodies; the leading components that explain 99 % of the training variance) have a chi-square quantile >= 0.999 (Mahalanobis distance beyond what 99.9 % \
of training-like bodies reach). *Out of space*: RMS distance (mm) from the result to that projection (how far it left the learned \
space; step 2 of the method moves off it on purpose). *Folded*: results with more triangles facing the other way (relative to the \
training mean body) than any training body has. *Vertex distance*: average and maximum distance between corresponding vertices \
of the result and the true body (S_real).";

fn method_names(methods: &[Box<dyn Method>]) -> Vec<String> {
    methods.iter().map(|m| m.name().to_string()).collect()
}

/// `body-synthetic`.
pub fn body_synthetic(opts: &Options, roster: &Roster) -> Result<Outcome, EvalError> {
    let t0 = std::time::Instant::now();
    let s = sizes(opts.quick);
    let su = setup(&s)?;
    let (methods, train_notes, train_secs) = train(roster, &su.data, &BODY_PARAMS);
    if methods.is_empty() {
        return Err(EvalError::Data(format!(
            "no method could be trained: {}",
            train_notes.join("; ")
        )));
    }
    let names = method_names(&methods);
    let m_total = su.data.compiled.len();
    let g = MeasurementGaussian::fit(&su.data.measurements, &su.used)?;
    let mut sets: Vec<(String, Vec<Case>)> = Vec::new();
    let mut redraws = Vec::new();
    let r2 = g.radius_through_sd(2.0);
    let r4 = g.radius_through_sd(4.0);
    for (label, k, seed) in [
        ("S_close", None, 11u64),
        ("S_2", Some(2.0), 12),
        ("S_4", Some(4.0), 13),
        ("S_2'", Some(r2), 14),
        ("S_4'", Some(r4), 15),
    ] {
        let (samples, redrawn) = g.sample(s.n_samples, k, m_total, seed);
        redraws.push(format!("{label}: {redrawn}"));
        let keep = if label == "S_close" { 4 } else { 1 };
        sets.push((
            label.to_string(),
            samples
                .into_iter()
                .enumerate()
                .map(|(i, t)| Case {
                    targets: t,
                    truth: None,
                    keep: i < keep,
                })
                .collect(),
        ));
    }
    sets.push(("S_real".to_string(), sreal_cases(&su, 3)));
    let results: Vec<Vec<Vec<Res>>> = sets
        .iter()
        .map(|(label, cases)| {
            run_all(
                &methods,
                cases,
                &su.data.compiled,
                &su.dims,
                &su.reference,
                label,
            )
        })
        .collect();

    // Average errors.
    let cols: Vec<&str> = sets.iter().map(|(l, _)| l.as_str()).collect();
    let mut header = vec!["method"];
    header.extend(cols.iter().copied());
    let mut errors = Table::new("errors", "Average error over all dimensions (mm)", &header);
    let mut col_errors: Vec<Vec<f64>> = vec![Vec::new(); sets.len()];
    for (mi, name) in names.iter().enumerate() {
        let mut row: Vec<Cell> = vec![name.as_str().into()];
        for (si, _) in sets.iter().enumerate() {
            let e = summarise(&results[si][mi], &su.reference).mean_error;
            col_errors[si].push(e);
            row.push(e.into());
        }
        errors.push(row);
    }
    errors.notes.push(format!(
        "{} samples per synthetic set, {} S_real bodies; {} training bodies; l = {}, lambda = {}, s = {}.",
        s.n_samples, s.n_held, s.n_train, BODY_PARAMS.l, BODY_PARAMS.lambda, BODY_PARAMS.s
    ));
    let mut paper = Table::new(
        "paper",
        "The paper's Table (CAESAR, 360 training scans), mm",
        &["method", "S_close", "S_2", "S_4", "S_real"],
    );
    for (n, v) in PAPER_BODY {
        let mut row: Vec<Cell> = vec![n.into()];
        row.extend(v.iter().map(|x| Cell::from(*x)));
        paper.push(row);
    }

    // Plausibility and time per set.
    let mut plaus = Table::new(
        "plausibility",
        "Plausibility, folds, failures and time per set",
        &[
            "set",
            "method",
            "implausible %",
            "out of space RMS mm",
            "folded",
            "failed",
            "s per prediction",
        ],
    );
    for (si, (label, _)) in sets.iter().enumerate() {
        for (mi, name) in names.iter().enumerate() {
            let sm = summarise(&results[si][mi], &su.reference);
            plaus.push(vec![
                label.as_str().into(),
                name.as_str().into(),
                (100.0 * sm.implausible).into(),
                sm.out_of_space.into(),
                sm.folded.into(),
                sm.failures.into(),
                sm.seconds.into(),
            ]);
        }
    }
    plaus.notes.push(format!(
        "Folded: more flipped triangles (vs the training mean) than the most any training body has ({}). Times are wall-clock per prediction with two predictions running at once on the 2 cores.",
        su.reference.train_flips_max
    ));
    let sreal_i = sets.len() - 1;
    let mut vd = Table::new(
        "sreal_vertices",
        "S_real: distance to the true body (mm)",
        &[
            "method",
            "average vertex distance",
            "maximum vertex distance",
        ],
    );
    for (mi, name) in names.iter().enumerate() {
        let sm = summarise(&results[sreal_i][mi], &su.reference);
        vd.push(vec![
            name.as_str().into(),
            sm.vertex_mean.into(),
            sm.vertex_max.into(),
        ]);
    }

    // Figures.
    let topo = su.data.topology.clone();
    let mut figs: Vec<(String, String)> = Vec::new();
    if let Some(o) = super::position(&methods, "ours") {
        let bodies: Vec<Vec<[f64; 3]>> = results[0][o]
            .iter()
            .filter_map(|r| r.vertices.clone())
            .collect();
        if !bodies.is_empty() {
            let refs: Vec<&[[f64; 3]]> = bodies.iter().map(|b| b.as_slice()).collect();
            let region = common_region(&refs);
            let panels = bodies
                .iter()
                .map(|b| {
                    body_views(
                        b,
                        &topo,
                        &Paint::Shaded,
                        &[View::Front, View::Right],
                        region,
                        400,
                        260,
                    )
                })
                .collect::<Result<Vec<_>, _>>()?;
            let cols: Vec<String> = (1..=panels.len()).map(|i| format!("sample {i}")).collect();
            save(
                &grid(&cols, vec![("ours".into(), panels)]),
                &opts.out.join("s_close_ours.png"),
            )?;
            figs.push((
                "s_close_ours.png".into(),
                "Four results of our method from random samples of S_close (front and side), as the paper's figure.".into(),
            ));
        }
    }
    figs.extend(method_row_figure(
        &opts.out,
        "s4_methods.png",
        &names,
        &results[2],
        &topo,
        "The first S_4 sample predicted by every method (front and side).",
    )?);
    figs.extend(signed_figure(
        &opts.out,
        "sreal_signed_distance.png",
        &names,
        &results[sreal_i],
        &sets[sreal_i].1,
        &topo,
    )?);

    let mut checks = Vec::new();
    if opts.quick {
        for (si, label) in cols.iter().enumerate() {
            beats(&names, &col_errors[si], label, &mut checks);
        }
    }
    let mut headline = vec![format!("average error (mm) by {}", cols.join(" / "))];
    for (mi, n) in names.iter().enumerate() {
        headline.push(format!(
            "  {n:>18}: {}",
            col_errors
                .iter()
                .map(|c| format!("{:8.3}", c[mi]))
                .collect::<Vec<_>>()
                .join(" ")
        ));
    }

    let mut r = Report::new(
        "body-synthetic: the paper's body experiments (average errors)",
        &opts.command,
    );
    r.text(data_text(&su, &s));
    r.text(READING);
    r.text(sk_text(g.typical_radius(), r2, r4, &redraws));
    r.table(errors);
    r.table(paper);
    r.text(METRICS);
    r.table(plaus);
    r.table(vd);
    for (f, c) in &figs {
        r.figure(f, c);
    }
    let run_time = format!(
        "**Run time**: {:.1} min in all on this machine (2-core x86_64 sandbox, shared with other engineers' builds, so timings are under load), of which training the methods {:.1} s; {}.",
        t0.elapsed().as_secs_f64() / 60.0,
        train_secs,
        if opts.quick { "quick mode" } else { "full sizes" }
    );
    super::finish(r, &train_notes, run_time, checks, headline, &opts.out)
}

/// The two readings of S_k and their Mahalanobis radii.
pub(crate) fn sk_text(typical: f64, r2: f64, r4: f64, redraws: &[String]) -> String {
    format!(
        "**Two readings of S_k.** Read as Mahalanobis distance k (the method notes' reading, columns S_2 and S_4), S_k lies *closer* to the mean than most of S_close: a draw of N(mu, Sigma) in d dimensions lies at Mahalanobis distance about sqrt(d) = {typical:.2}, so S_2 and S_4 are not \"farther from the training set\" than S_close, against the paper's intent and its error ordering (S_close < S_2 < S_4). The literal reading of the paper's formula, the ellipsoid x^T Sigma^-1 x = const through the point mu + k sigma (sigma = per-measurement SDs; the paper's \"diagonal elements\", square-rooted so that the units agree), gives Mahalanobis radii {r2:.2} (k = 2) and {r4:.2} (k = 4): columns **S_2'** and **S_4'** (200 points each, uniform directions). Samples with a non-positive length were drawn again (redrawn: {}).",
        redraws.join(", ")
    )
}

/// Markdown list of checks.
pub(crate) fn checks_text(checks: &[super::Check]) -> String {
    let mut s = String::from("**Checks (quick mode)**:\n\n");
    for c in checks {
        s.push_str(&format!(
            "- {} — {}\n",
            c.what,
            if c.passed { "holds" } else { "DOES NOT HOLD" }
        ));
    }
    s
}

/// One row of every method's first kept result, front and side, shaded.
pub(crate) fn method_row_figure(
    out: &std::path::Path,
    file: &str,
    names: &[String],
    results: &[Vec<Res>],
    topo: &Topo,
    caption: &str,
) -> Result<Vec<(String, String)>, EvalError> {
    let bodies: Vec<(String, Vec<[f64; 3]>)> = names
        .iter()
        .zip(results)
        .filter_map(|(n, r)| {
            r.first()
                .and_then(|o| o.vertices.clone())
                .map(|v| (n.clone(), v))
        })
        .collect();
    if bodies.is_empty() {
        return Ok(vec![]);
    }
    let refs: Vec<&[[f64; 3]]> = bodies.iter().map(|b| b.1.as_slice()).collect();
    let region = common_region(&refs);
    let panels = bodies
        .iter()
        .map(|(_, b)| {
            body_views(
                b,
                topo,
                &Paint::Shaded,
                &[View::Front, View::Right],
                region,
                400,
                260,
            )
        })
        .collect::<Result<Vec<_>, _>>()?;
    let cols: Vec<String> = bodies.iter().map(|b| b.0.clone()).collect();
    save(&grid(&cols, vec![(String::new(), panels)]), &out.join(file))?;
    Ok(vec![(file.into(), caption.into())])
}

/// Rows = kept cases with a truth; columns = methods (coloured by signed
/// distance to the truth, front and side) and the true body (shaded).
pub(crate) fn signed_figure(
    out: &std::path::Path,
    file: &str,
    names: &[String],
    results: &[Vec<Res>],
    cases: &[Case],
    topo: &Topo,
) -> Result<Vec<(String, String)>, EvalError> {
    let limit = 30.0;
    let mut rows = Vec::new();
    for (ci, case) in cases.iter().enumerate() {
        let Some(truth) = case.truth.as_ref().filter(|_| case.keep) else {
            continue;
        };
        let region = crate::figures::expand(common_region(&[truth.as_slice()]), 0.12);
        let mut panels = Vec::new();
        for r in results {
            match &r[ci].vertices {
                Some(v) => {
                    let d = signed_distance_mm(v, truth, topo);
                    panels.push(body_views(
                        v,
                        topo,
                        &Paint::Signed(&d, limit),
                        &[View::Front, View::Right],
                        region,
                        400,
                        240,
                    )?);
                }
                None => panels.push(crate::figures::label("failed", 150, 240, 1)),
            }
        }
        panels.push(body_views(
            truth,
            topo,
            &Paint::Shaded,
            &[View::Front, View::Right],
            region,
            400,
            240,
        )?);
        rows.push((format!("body {}", ci + 1), panels));
    }
    if rows.is_empty() {
        return Ok(vec![]);
    }
    let mut cols: Vec<String> = names.to_vec();
    cols.push("true body".into());
    let g = grid(&cols, rows);
    let bar = colour_bar(limit, 300);
    save(&tapeshape_body::render::vstack(&[g, bar]), &out.join(file))?;
    Ok(vec![(
        file.into(),
        format!("Held-out bodies predicted by every method, coloured by the signed distance to the true body (red: outside, blue: inside, ±{limit:.0} mm), front and side; last column the true body. As the paper's S_real figure."),
    )])
}

/// `body-real-table`: S_real per measurement, average and maximum error.
pub fn body_real_table(opts: &Options, roster: &Roster) -> Result<Outcome, EvalError> {
    let t0 = std::time::Instant::now();
    let s = sizes(opts.quick);
    let su = setup(&s)?;
    let (methods, train_notes, _) = train(roster, &su.data, &BODY_PARAMS);
    let names = method_names(&methods);
    let cases = sreal_cases(&su, 3);
    let res = run_all(
        &methods,
        &cases,
        &su.data.compiled,
        &su.dims,
        &su.reference,
        "S_real",
    );
    let mut header: Vec<String> = vec!["dimension".into()];
    for n in &names {
        header.push(format!("{n} avg"));
        header.push(format!("{n} max"));
    }
    header.push("paper ours avg".into());
    header.push("paper ours max".into());
    let hdr: Vec<&str> = header.iter().map(String::as_str).collect();
    let mut t = Table::new(
        "sreal_per_measurement",
        &format!(
            "S_real: average and maximum error per dimension over {} held-out bodies (mm)",
            cases.len()
        ),
        &hdr,
    );
    let mut avg_of: Vec<Vec<f64>> = vec![Vec::new(); names.len()];
    for (di, dname) in su.dims.names.iter().enumerate() {
        let mut row: Vec<Cell> = vec![dname.as_str().into()];
        for (mi, r) in res.iter().enumerate() {
            let vals: Vec<f64> = r.iter().map(|o| o.errors[di]).collect();
            let a = mean(vals.iter().copied());
            avg_of[mi].push(a);
            row.push(a.into());
            row.push(super::common::max(vals).into());
        }
        let p = PAPER_SREAL_OURS.iter().find(|p| p.0 == dname);
        row.push(p.map_or(Cell::Missing, |p| p.1.into()));
        row.push(p.map_or(Cell::Missing, |p| p.2.into()));
        t.push(row);
    }
    let mut all_row: Vec<Cell> = vec!["**all dimensions**".into()];
    let mut all_avg = Vec::new();
    for (mi, r) in res.iter().enumerate() {
        let a = mean(avg_of[mi].iter().copied());
        all_avg.push(a);
        all_row.push(a.into());
        all_row.push(super::common::max(r.iter().flat_map(|o| o.errors.clone())).into());
    }
    all_row.push(Cell::Num(1.10));
    t.push(all_row);
    let mut extra = Table::new(
        "sreal_extra",
        "S_real beyond the paper: distance to the true body, plausibility",
        &[
            "method",
            "average vertex distance mm",
            "maximum vertex distance mm",
            "implausible %",
            "out of space RMS mm",
            "folded",
            "failed",
        ],
    );
    for (mi, n) in names.iter().enumerate() {
        let sm = summarise(&res[mi], &su.reference);
        extra.push(vec![
            n.as_str().into(),
            sm.vertex_mean.into(),
            sm.vertex_max.into(),
            (100.0 * sm.implausible).into(),
            sm.out_of_space.into(),
            sm.folded.into(),
            sm.failures.into(),
        ]);
    }
    let figs = signed_figure(
        &opts.out,
        "sreal_signed_distance.png",
        &names,
        &res,
        &cases,
        &su.data.topology,
    )?;
    let mut checks = Vec::new();
    if opts.quick {
        beats(&names, &all_avg, "S_real", &mut checks);
    }
    let mut r = Report::new("body-real-table: S_real per measurement", &opts.command);
    r.text(data_text(&su, &s));
    r.text(READING);
    r.table(t);
    r.text(METRICS);
    r.table(extra);
    for (f, c) in &figs {
        r.figure(f, c);
    }
    let headline = names
        .iter()
        .zip(&all_avg)
        .map(|(n, a)| format!("S_real {n}: {a:.3} mm"))
        .collect();
    let run_time = format!(
        "**Run time**: {:.1} min (2-core sandbox shared with other builds).",
        t0.elapsed().as_secs_f64() / 60.0
    );
    super::finish(r, &train_notes, run_time, checks, headline, &opts.out)
}
