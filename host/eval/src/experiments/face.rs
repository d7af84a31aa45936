//! `face`: the paper's face experiment: 50 training faces, the seven facial
//! surface distances of `face7`, S_close, S_2 and S_4.

use tapeshape_body::render::View;
use tapeshape_body::BodyModel;
use tapeshape_measure::MeasurementSet;
use tapeshape_population::{generate_faces, remap_anatomy, PopulationSettings};

use super::body::method_row_figure;
use super::common::{
    informative, progress_bar, run_all, summarise, training_data, Case, Dimensions,
    MeasurementGaussian, Reference,
};
use super::{beats, train, EvalError, Options, Outcome, Params, Roster};
use crate::report::{Cell, Report, Table};

/// The paper's face Table (mm): S_close, S_2, S_4.
pub const PAPER_FACE: [(&str, [f64; 3]); 3] = [
    ("feature analysis", [0.67, 1.63, 6.76]),
    ("SGPLVM", [5.35, 5.28, 10.88]),
    ("ours", [0.68, 2.00, 7.27]),
];

/// The paper's synthetic parameters.
pub const FACE_PARAMS: Params = Params {
    l: 3.0,
    lambda: 0.1,
    s: 3,
};

/// `face`.
pub fn run(opts: &Options, roster: &Roster) -> Result<Outcome, EvalError> {
    let t0 = std::time::Instant::now();
    let (n_train, n_samples) = if opts.quick { (20, 6) } else { (50, 200) };
    let settings = PopulationSettings {
        n: n_train,
        seed: 1,
        ..PopulationSettings::default()
    };
    let pb = progress_bar(n_train as u64, "training faces");
    let faces = generate_faces(&settings, &|d, _| pb.set_position(d as u64))?;
    pb.finish_and_clear();
    let body = BodyModel::shared()
        .map_err(|e| EvalError::Data(format!("loading the body template: {e}")))?;
    let map = faces
        .header
        .vertex_map
        .clone()
        .ok_or_else(|| EvalError::Data("the faces dataset has no vertex map".into()))?;
    let anatomy = remap_anatomy(
        &tapeshape_body::anatomy::anatomy(),
        body.topology(),
        &map,
        faces.topology.faces(),
    );
    let set = MeasurementSet::load("face7")?;
    let data = training_data(faces.bodies.clone(), &faces.topology, &set, &anatomy)?;
    let used = informative(&data.measurements);
    let dims = Dimensions::of(&set, &used);
    let reference = Reference::new(&data)?;
    let (methods, notes, train_secs) = train(roster, &data, &FACE_PARAMS);
    let names: Vec<String> = methods.iter().map(|m| m.name().to_string()).collect();
    let g = MeasurementGaussian::fit(&data.measurements, &used)?;
    let m_total = data.compiled.len();
    let labels = ["S_close", "S_2", "S_4", "S_2'", "S_4'"];
    let r2 = g.radius_through_sd(2.0);
    let r4 = g.radius_through_sd(4.0);
    let mut results = Vec::new();
    let mut redraws = Vec::new();
    for (label, k, seed) in [
        ("S_close", None, 21u64),
        ("S_2", Some(2.0), 22),
        ("S_4", Some(4.0), 23),
        ("S_2'", Some(r2), 24),
        ("S_4'", Some(r4), 25),
    ] {
        let (samples, redrawn) = g.sample(n_samples, k, m_total, seed);
        redraws.push(format!("{label}: {redrawn}"));
        let cases: Vec<Case> = samples
            .into_iter()
            .enumerate()
            .map(|(i, t)| Case {
                targets: t,
                truth: None,
                keep: i == 0,
            })
            .collect();
        results.push(run_all(
            &methods,
            &cases,
            &data.compiled,
            &dims,
            &reference,
            label,
        ));
    }
    let mut header = vec!["method"];
    header.extend(labels);
    let mut t = Table::new(
        "errors",
        "Average error over the face7 dimensions (mm)",
        &header,
    );
    let mut cols: Vec<Vec<f64>> = vec![Vec::new(); labels.len()];
    for (mi, n) in names.iter().enumerate() {
        let mut row: Vec<Cell> = vec![n.as_str().into()];
        for si in 0..labels.len() {
            let e = summarise(&results[si][mi], &reference).mean_error;
            cols[si].push(e);
            row.push(e.into());
        }
        t.push(row);
    }
    let mut paper = Table::new(
        "paper",
        "The paper's face Table (50 CAESAR faces), mm",
        &["method", "S_close", "S_2", "S_4"],
    );
    for (n, v) in PAPER_FACE {
        let mut row: Vec<Cell> = vec![n.into()];
        row.extend(v.iter().map(|x| Cell::from(*x)));
        paper.push(row);
    }
    let mut plaus = Table::new(
        "plausibility",
        "Plausibility and time per set",
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
    for (si, label) in labels.iter().enumerate() {
        for (mi, n) in names.iter().enumerate() {
            let sm = summarise(&results[si][mi], &reference);
            plaus.push(vec![
                (*label).into(),
                n.as_str().into(),
                (100.0 * sm.implausible).into(),
                sm.out_of_space.into(),
                sm.folded.into(),
                sm.failures.into(),
                sm.seconds.into(),
            ]);
        }
    }
    let topo = data.topology.clone();
    let _ = View::Front;
    let figs = method_row_figure(
        &opts.out,
        "s4_faces.png",
        &names,
        &results[2],
        &topo,
        "The first S_4 sample predicted by every method (front and side of the head), as the paper's face figure.",
    )?;
    let mut checks = Vec::new();
    if opts.quick {
        for (si, l) in labels.iter().enumerate() {
            beats(&names, &cols[si], &format!("face {l}"), &mut checks);
        }
    }
    let mut r = Report::new("face: the paper's face experiment", &opts.command);
    r.text(format!(
        "**Data.** {n_train} generated faces (`generate_faces`, seed 1: random adults whose face local changes are drawn uniformly \
from [-0.8, 0.8], cropped to the template's head region, {} vertices), measured with `face7` (7 facial surface distances, {} informative). \
The sets are read as in `body-synthetic`: S_close = {n_samples} draws of N(mu, Sigma) of the training measurements, S_k = {n_samples} \
points at Mahalanobis distance k (mu + k L u, u uniform on the sphere). Error = |measured on the result - input| averaged over the \
7 dimensions and the samples. l = {}, lambda = {}, s = {}.",
        topo.n_vertices(),
        used.len(),
        FACE_PARAMS.l,
        FACE_PARAMS.lambda,
        FACE_PARAMS.s
    ));
    r.text(super::body::sk_text(g.typical_radius(), r2, r4, &redraws));
    r.table(t);
    r.table(paper);
    r.table(plaus);
    for (f, c) in &figs {
        r.figure(f, c);
    }
    let run_time = format!(
        "**Run time**: {:.1} min (training {train_secs:.1} s; 2-core sandbox shared with other builds).",
        t0.elapsed().as_secs_f64() / 60.0
    );
    super::finish(
        r,
        &notes,
        run_time,
        checks,
        names
            .iter()
            .enumerate()
            .map(|(mi, n)| {
                format!(
                    "face {n} ({}): {} mm",
                    labels.join(" / "),
                    cols.iter()
                        .map(|c| format!("{:.3}", c[mi]))
                        .collect::<Vec<_>>()
                        .join(" / ")
                )
            })
            .collect(),
        &opts.out,
    )
}
