//! `small-train`: the paper's experiment with a small training set: train on
//! 35 typical men, predict 5 men whose shape the training set does not
//! cover (l = 3, s = 10).
//!
//! Rules (documented on the results page): from a pool of generated men
//! (bodies fitted to ANSUR II train-split men), *typical* = stature, body
//! mass index and waist-to-hip ratio each within one standard deviation of
//! the pool's mean (the first 35 such men in pool order); *atypical* = the
//! tallest, the shortest, the heaviest (BMI), the lightest (BMI) and the one
//! with the largest waist-to-hip ratio among the others.

use tapeshape_body::render::View;
use tapeshape_measure::MeasurementSet;
use tapeshape_population::ansur::Ansur;

use super::body::signed_figure;
use super::common::{informative, run_all, summarise, training_data, Case, Dimensions, Reference};
use super::{beats, population, recipe, train, EvalError, Options, Outcome, Params, Roster};
use crate::figures::{body_views, common_region, expand, grid, label, save, Paint};
use crate::report::{Cell, Report, Table};

/// Parameters: l = 3 (the shapes are not represented by the training
/// data), lambda = 0.1, s = 10 (the paper's).
pub const SMALL_PARAMS: Params = Params {
    l: 3.0,
    lambda: 0.1,
    s: 10,
};

/// `small-train`.
pub fn run(opts: &Options, roster: &Roster) -> Result<Outcome, EvalError> {
    let t0 = std::time::Instant::now();
    let (n_pool, n_typical) = if opts.quick { (60, 15) } else { (400, 35) };
    let pool = population(n_pool, 3, 1.0, "pool of men")?;
    let ansur = Ansur::get()?;
    // stature (m), BMI, waist/hip per body.
    let feats: Vec<[f64; 3]> = pool
        .header
        .bodies
        .iter()
        .map(|r| {
            let fit = r.fit.as_ref();
            let get = |c: &str| {
                fit.and_then(|f| f.achieved_mm.get(c))
                    .copied()
                    .unwrap_or(f64::NAN)
            };
            let subject = r.ansur_subject.and_then(|id| ansur.subject(id));
            let bmi = subject.map_or(f64::NAN, |s| {
                let h = s.dim("stature").unwrap_or(f64::NAN);
                s.mass_kg / (h * h)
            });
            [
                get("stature") / 1000.0,
                bmi,
                get("waistcircumference") / get("buttockcircumference"),
            ]
        })
        .collect();
    let stats: Vec<(f64, f64)> = (0..3)
        .map(|k| {
            let v: Vec<f64> = feats
                .iter()
                .map(|f| f[k])
                .filter(|x| x.is_finite())
                .collect();
            let m = v.iter().sum::<f64>() / v.len() as f64;
            let sd =
                (v.iter().map(|x| (x - m).powi(2)).sum::<f64>() / (v.len() as f64 - 1.0)).sqrt();
            (m, sd)
        })
        .collect();
    let z = |i: usize, k: usize| (feats[i][k] - stats[k].0) / stats[k].1;
    let typical: Vec<usize> = (0..n_pool)
        .filter(|&i| (0..3).all(|k| z(i, k).abs() <= 1.0))
        .take(n_typical)
        .collect();
    if typical.len() < n_typical {
        return Err(EvalError::Data(format!(
            "only {} typical men in a pool of {n_pool}; need {n_typical}",
            typical.len()
        )));
    }
    let others: Vec<usize> = (0..n_pool).filter(|i| !typical.contains(i)).collect();
    let mut atypical: Vec<(usize, &str)> = Vec::new();
    let rules: [(&str, usize, f64); 5] = [
        ("tallest", 0, 1.0),
        ("shortest", 0, -1.0),
        ("highest BMI", 1, 1.0),
        ("lowest BMI", 1, -1.0),
        ("largest waist/hip", 2, 1.0),
    ];
    for (name, k, sign) in rules {
        let best = others
            .iter()
            .copied()
            .filter(|i| !atypical.iter().any(|a| a.0 == *i) && feats[*i][k].is_finite())
            .max_by(|&a, &b| (sign * feats[a][k]).total_cmp(&(sign * feats[b][k])));
        if let Some(b) = best {
            atypical.push((b, name));
        }
    }
    let set = MeasurementSet::load("paper34")?;
    let anatomy = tapeshape_body::anatomy::anatomy();
    let train_meshes: Vec<_> = typical.iter().map(|&i| pool.bodies[i].clone()).collect();
    let data = training_data(train_meshes, &pool.topology, &set, &anatomy)?;
    let used = informative(&data.measurements);
    let dims = Dimensions::of(&set, &used);
    let reference = Reference::new(&data)?;
    let (methods, notes, _) = train(roster, &data, &SMALL_PARAMS);
    let names: Vec<String> = methods.iter().map(|m| m.name().to_string()).collect();
    let cases: Vec<Case> = atypical
        .iter()
        .map(|&(i, _)| {
            let all = super::common::measure_all(&data.compiled, &pool.bodies[i]);
            let mut t = vec![None; all.len()];
            for &j in &used {
                t[j] = Some(all[j]);
            }
            Case {
                targets: t,
                truth: Some(pool.bodies[i].clone()),
                keep: true,
            }
        })
        .collect();
    let res = run_all(
        &methods,
        &cases,
        &data.compiled,
        &dims,
        &reference,
        "small-train",
    );

    let mut bodies = Table::new(
        "bodies",
        "The atypical men (z = standard scores in the pool)",
        &[
            "body",
            "rule",
            "stature m",
            "BMI",
            "waist/hip",
            "z stature",
            "z BMI",
            "z waist/hip",
        ],
    );
    for (n, &(i, rule)) in atypical.iter().enumerate() {
        bodies.push(vec![
            format!("body {}", n + 1).into(),
            rule.into(),
            feats[i][0].into(),
            feats[i][1].into(),
            feats[i][2].into(),
            z(i, 0).into(),
            z(i, 1).into(),
            z(i, 2).into(),
        ]);
    }
    let mut per = Table::new(
        "results",
        "Per body and method",
        &[
            "body",
            "method",
            "average error mm",
            "average vertex distance mm",
            "maximum vertex distance mm",
            "plausibility",
            "out of space RMS mm",
            "flipped triangles",
        ],
    );
    for (ci, _) in cases.iter().enumerate() {
        for (mi, n) in names.iter().enumerate() {
            let o = &res[mi][ci];
            let vd = o.vertex_distance.unwrap_or((f64::NAN, f64::NAN));
            per.push(vec![
                format!("body {}", ci + 1).into(),
                n.as_str().into(),
                super::common::mean(o.errors.iter().copied()).into(),
                vd.0.into(),
                vd.1.into(),
                match &o.failure {
                    Some(f) => Cell::Text(format!("failed: {f}")),
                    None => Cell::Text(format!(
                        "{:?} (q {:.3})",
                        o.plausibility.2, o.plausibility.1
                    )),
                },
                o.plausibility.3.into(),
                o.flips.into(),
            ]);
        }
    }
    per.notes.push(format!(
        "Flipped triangles are counted against the training mean body; the training bodies themselves flip at most {}.",
        reference.train_flips_max
    ));
    let mut summary = Table::new(
        "summary",
        "Summary over the atypical bodies",
        &[
            "method",
            "average error mm",
            "average vertex distance mm",
            "maximum vertex distance mm",
            "implausible %",
            "folded",
        ],
    );
    let mut errs = Vec::new();
    let mut vdist = Vec::new();
    for (mi, n) in names.iter().enumerate() {
        let sm = summarise(&res[mi], &reference);
        errs.push(sm.mean_error);
        vdist.push(sm.vertex_mean);
        summary.push(vec![
            n.as_str().into(),
            sm.mean_error.into(),
            sm.vertex_mean.into(),
            sm.vertex_max.into(),
            (100.0 * sm.implausible).into(),
            sm.folded.into(),
        ]);
    }

    // The paper's figure: rows true / ours / SGPLVM / feature analysis.
    let topo = data.topology.clone();
    // Framed on the true bodies: a result far outside the shape space (as
    // feature analysis gives here) is cut at the panel edge.
    let truths: Vec<&[[f64; 3]]> = cases.iter().filter_map(|c| c.truth.as_deref()).collect();
    let region = expand(common_region(&truths), 0.12);
    let mut rows = Vec::new();
    let truth_panels = cases
        .iter()
        .map(|c| {
            body_views(
                c.truth.as_ref().expect("set"),
                &topo,
                &Paint::Shaded,
                &[View::Front, View::Right],
                region,
                400,
                240,
            )
        })
        .collect::<Result<Vec<_>, _>>()?;
    rows.push(("true".to_string(), truth_panels));
    for want in ["ours", "SGPLVM", "feature analysis"] {
        let Some(mi) = names.iter().position(|n| n == want) else {
            continue;
        };
        let panels = res[mi]
            .iter()
            .map(|o| match &o.vertices {
                Some(v) => body_views(
                    v,
                    &topo,
                    &Paint::Shaded,
                    &[View::Front, View::Right],
                    region,
                    400,
                    240,
                ),
                None => Ok(label("failed", 150, 240, 1)),
            })
            .collect::<Result<Vec<_>, _>>()?;
        rows.push((want.to_string(), panels));
    }
    let cols: Vec<String> = atypical.iter().map(|a| a.1.to_string()).collect();
    save(&grid(&cols, rows), &opts.out.join("small_train.png"))?;
    let sig = signed_figure(
        &opts.out,
        "small_train_signed_distance.png",
        &names,
        &res,
        &cases,
        &topo,
    )?;

    let mut checks = Vec::new();
    if opts.quick {
        beats(&names, &errs, "small-train error", &mut checks);
    }
    let mut r = Report::new(
        "small-train: a small typical training set, atypical bodies",
        &opts.command,
    );
    r.text(format!(
        "**Data.** Pool: {} ({n_pool} men). *Typical*: stature, BMI (the ANSUR subject's mass / stature^2) and waist-to-hip ratio \
(waist / buttock circumference on the body) each within one SD of the pool mean; the first {n_typical} such men train every \
method. *Atypical*: among the other men, the tallest, the shortest, the highest BMI, the lowest BMI and the largest waist-to-hip \
ratio. Each atypical body is measured with `paper34` ({} informative measurements) and predicted from those values. Settings as \
the paper: l = {}, lambda = {}, s = {}.",
        recipe(n_pool, 3, 1.0),
        used.len(),
        SMALL_PARAMS.l,
        SMALL_PARAMS.lambda,
        SMALL_PARAMS.s
    ));
    r.table(bodies);
    r.table(summary);
    r.table(per);
    r.figure(
        "small_train.png",
        "Rows: the true body, our method, SGPLVM, feature analysis (front and side), as the paper's figure; columns: the atypical bodies.",
    );
    for (f, c) in &sig {
        r.figure(f, c);
    }
    let run_time = format!(
        "**Run time**: {:.1} min (2-core sandbox shared with other builds).",
        t0.elapsed().as_secs_f64() / 60.0
    );
    super::finish(
        r,
        &notes,
        run_time,
        checks,
        names
            .iter()
            .zip(errs.iter().zip(&vdist))
            .map(|(n, (e, v))| {
                format!("small-train {n}: error {e:.3} mm, vertex distance {v:.2} mm")
            })
            .collect(),
        &opts.out,
    )
}
