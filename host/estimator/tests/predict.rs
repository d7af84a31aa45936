//! Prediction end to end on generated bodies: the reduced S_real check of
//! issue 4 (train on 60 generated bodies, predict 5 held-out ones from their
//! paper34 values), subsets, the embedded default model, and bad input.
//!
//! Why generated bodies: their true shape is known, so the vertex distance
//! and the measurement errors are checked against ground truth, and the
//! held-out bodies are certainly not in the training set (another seed).

use std::sync::OnceLock;

use tapeshape_estimator::{
    load_model_bytes, save_model, train, Estimator, Inputs, PredictError, PredictOptions,
    TrainSettings,
};
use tapeshape_mesh::Vec3;
use tapeshape_population::{generate_population, Dataset, PopulationSettings};

struct Fixture {
    heldout: Dataset,
    paper34: Estimator,
}

fn fixture() -> &'static Fixture {
    static F: OnceLock<Fixture> = OnceLock::new();
    F.get_or_init(|| {
        let gen = |n, seed| {
            generate_population(
                &PopulationSettings {
                    n,
                    seed,
                    ..PopulationSettings::default()
                },
                &|_, _| {},
            )
            .expect("generate")
        };
        let training = gen(60, 11);
        let heldout = gen(5, 12);
        let file = train(&training, &["paper34"], &TrainSettings::default()).expect("train");
        Fixture {
            heldout,
            paper34: Estimator::new(file, "test paper34 model").expect("estimator"),
        }
    })
}

fn measure(estimator: &Estimator, names: &[String], body: &[Vec3]) -> Vec<f64> {
    names
        .iter()
        .map(|n| {
            let j = estimator.set().index_of(n).unwrap();
            estimator.compiled().measure_one(j, body).unwrap().value
        })
        .collect()
}

/// Names of `set` whose training SD is not zero (a measurement constant on
/// the training set carries no information; see the report).
fn usable(estimator: &Estimator, set: &str) -> Vec<String> {
    let stats = estimator.file().model.measurement_stats();
    estimator
        .set_members(set)
        .unwrap()
        .into_iter()
        .filter(|n| stats[estimator.set().index_of(n).unwrap()].1 > 1e-9)
        .collect()
}

fn mean(v: &[f64]) -> f64 {
    v.iter().sum::<f64>() / v.len() as f64
}

fn vertex_distance(a: &[Vec3], b: &[Vec3]) -> f64 {
    mean(
        &a.iter()
            .zip(b)
            .map(|(p, q)| tapeshape_mesh::vec3::distance(*p, *q))
            .collect::<Vec<_>>(),
    )
}

/// Mean errors `[euclidean mm, circumference mm, vertex distance mm]` of
/// feature analysis alone (s = 0) and of the full method (s = 3) on the
/// held-out bodies, computed once.
fn sreal() -> &'static [[f64; 3]; 2] {
    static S: OnceLock<[[f64; 3]; 2]> = OnceLock::new();
    S.get_or_init(sreal_compute)
}

fn sreal_compute() -> [[f64; 3]; 2] {
    let f = fixture();
    let e = &f.paper34;
    let names = usable(e, "paper34");
    let is_circ = |n: &str| {
        let d = &e.set().definitions[e.set().index_of(n).unwrap()];
        d.group.is_some() || matches!(d.kind, tapeshape_measure::Kind::Circumference { .. })
    };
    let mut stats = [
        [Vec::new(), Vec::new(), Vec::new()],
        [Vec::new(), Vec::new(), Vec::new()],
    ];
    for body in &f.heldout.bodies {
        let truth = measure(e, &names, body);
        let mut inputs = Inputs::new();
        for (n, v) in names.iter().zip(&truth) {
            inputs.insert_metres(n, *v).unwrap();
        }
        for (m, s) in [0usize, 3].into_iter().enumerate() {
            let est = e
                .predict(
                    &inputs,
                    &PredictOptions {
                        s: Some(s),
                        ..PredictOptions::default()
                    },
                )
                .unwrap();
            let got = measure(e, &names, &est.mesh.vertices);
            for (k, n) in names.iter().enumerate() {
                let err = (got[k] - truth[k]).abs() * 1000.0;
                stats[m][usize::from(is_circ(n))].push(err);
            }
            stats[m][2].push(vertex_distance(&est.mesh.vertices, body) * 1000.0);
            if s > 0 {
                // Step 2 must not fold or collapse any triangle of the
                // step-1 shape (comparing with the true body is no criterion:
                // tiny triangles of fingers and toes face differently from
                // body to body, see docs/results/predict-sreal.md).
                let p = &est.report.prediction.plausibility;
                assert_eq!((p.flipped_triangles, p.degenerate_triangles), (0, 0));
            }
        }
    }
    let [fa, full] = stats.map(|s| s.map(|v| mean(&v)));
    eprintln!(
        "feature analysis: euclidean {:.4} mm, circumference {:.3} mm, vertex {:.2} mm",
        fa[0], fa[1], fa[2]
    );
    eprintln!(
        "full method:      euclidean {:.4} mm, circumference {:.3} mm, vertex {:.2} mm",
        full[0], full[1], full[2]
    );
    [fa, full]
}

#[test]
fn sreal_reduced_measurement_errors_beat_feature_analysis() {
    let [fa, full] = sreal();
    assert!(full[0] < 0.01, "euclidean error {} mm", full[0]);
    assert!(full[1] <= 1.0, "circumference error {} mm", full[1]);
    assert!(
        full[0] < fa[0] && full[1] < fa[1],
        "not better than feature analysis"
    );
}

/// The issue asks for a vertex distance below feature analysis alone. With
/// the Gauss-Newton MAP step 1 (the default; `tapeshape_model::map`) the
/// full method is closer here by 16 % (16.89 vs 20.08 mm on these 5 bodies;
/// at full scale 13.65 vs 13.86 mm, `docs/results/predict-sreal.md`): with
/// 60 training bodies feature analysis's least-squares map is noisy, and the
/// prior shrinks what the readings do not inform. The L-BFGS step 1 (the
/// paper's and the former default) tied feature analysis (19.99 vs 20.08 mm).
/// Asserted with a 5 % margin.
#[test]
fn sreal_reduced_vertex_distance_beats_feature_analysis() {
    let [fa, full] = sreal();
    assert!(
        full[2] < 0.95 * fa[2],
        "vertex distance {} not 5 % below feature analysis {}",
        full[2],
        fa[2]
    );
}

#[test]
fn a_subset_fits_and_reports_the_rest() {
    let f = fixture();
    let e = &f.paper34;
    let body = &f.heldout.bodies[0];
    let names: Vec<String> = ["stature", "chest_circumference", "hip_circumference"]
        .iter()
        .filter_map(|n| e.set().index_of(n).map(|_| n.to_string()))
        .collect();
    let names = if names.len() == 3 {
        names
    } else {
        // Fall back on the first three circumferences/heights of the set.
        usable(e, "paper34").into_iter().take(3).collect()
    };
    let truth = measure(e, &names, body);
    let mut inputs = Inputs::new();
    for (n, v) in names.iter().zip(&truth) {
        inputs.insert_metres(n, *v).unwrap();
    }
    let est = e.predict(&inputs, &PredictOptions::default()).unwrap();
    let got = measure(e, &names, &est.mesh.vertices);
    for (k, n) in names.iter().enumerate() {
        assert!(
            (got[k] - truth[k]).abs() < 0.002,
            "{n}: {} vs {}",
            got[k],
            truth[k]
        );
    }
    let r = &est.report.prediction;
    assert_eq!(
        r.start_method,
        tapeshape_model::predict::StartMethod::Conditional
    );
    // Every measurement is reported; only the given ones have a target,
    // besides the soft targets from real people (marked soft).
    assert_eq!(r.measurements.len(), e.set().len());
    assert_eq!(
        r.measurements
            .iter()
            .filter(|m| m.target_mm.is_some() && !m.soft)
            .count(),
        3
    );
    assert_eq!(
        r.measurements.iter().filter(|m| m.soft).count(),
        est.report.soft_targets.len()
    );
    assert!(r.measurements.iter().all(|m| m.step2_mm.is_some()));
}

#[test]
fn model_files_round_trip_plain_and_compressed() {
    let f = fixture();
    let dir = std::env::temp_dir().join(format!("tapeshape-predict-test-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    for name in ["m.tsm", "m.tsm.gz"] {
        let p = dir.join(name);
        save_model(f.paper34.file(), &p).unwrap();
        let bytes = std::fs::read(&p).unwrap();
        assert_eq!(bytes.starts_with(&[0x1f, 0x8b]), name.ends_with(".gz"));
        let back = load_model_bytes(&bytes, name).unwrap();
        assert_eq!(back.model.pca.mean, f.paper34.file().model.pca.mean);
        assert_eq!(
            back.model.measurement_names,
            f.paper34.file().model.measurement_names
        );
        let mut cut = bytes.clone();
        cut.truncate(bytes.len() / 2);
        assert!(load_model_bytes(&cut, name).is_err());
    }
    std::fs::remove_dir_all(&dir).ok();
}

fn default_estimator() -> &'static Estimator {
    Estimator::default_model().expect("the embedded default model loads")
}

#[test]
fn the_embedded_default_model_predicts_from_the_quick_set() {
    let e = default_estimator();
    for set in ["paper34", "ansur", "quick"] {
        assert!(e.set_members(set).is_ok(), "default model lacks {set}");
    }
    let names = usable(e, "quick");
    assert_eq!(names.len(), 9);
    let body = &fixture().heldout.bodies[1];
    let truth = measure(e, &names, body);
    let mut inputs = Inputs::new();
    for (n, v) in names.iter().zip(&truth) {
        inputs.insert_metres(n, *v).unwrap();
    }
    let est = e.predict(&inputs, &PredictOptions::default()).unwrap();
    let got = measure(e, &names, &est.mesh.vertices);
    for (k, n) in names.iter().enumerate() {
        let tol = e.set().definitions[e.set().index_of(n).unwrap()]
            .tolerance
            .mm();
        let err = (got[k] - truth[k]).abs() * 1000.0;
        assert!(
            err <= tol,
            "{n}: error {err:.2} mm above the ISO tolerance {tol} mm"
        );
    }
    let json = serde_json::to_string(&est.report).unwrap();
    assert!(json.contains("\"step2_mm\""));
}

fn entered(pairs: &[&str]) -> Inputs {
    let mut i = Inputs::new();
    for p in pairs {
        i.add_assignment(p).unwrap();
    }
    i
}

fn refuse(pairs: &[&str]) -> PredictError {
    default_estimator()
        .predict(&entered(pairs), &PredictOptions::default())
        .expect_err("must be refused")
}

#[test]
fn bad_input_gets_a_clear_message() {
    let e = refuse(&["statur=176cm"]);
    assert!(matches!(e, PredictError::UnknownMeasurement { .. }), "{e}");
    assert!(e.to_string().contains("did you mean `stature`"), "{e}");

    for (v, word) in [("0cm", "positive"), ("-170cm", "positive")] {
        let e = refuse(&[&format!("stature={v}")]);
        assert!(
            matches!(e, PredictError::BadValue(_)) && e.to_string().contains(word),
            "{e}"
        );
    }
    let mut nan = Inputs::new();
    nan.insert_metres("stature", f64::NAN).unwrap();
    let e = default_estimator()
        .predict(&nan, &PredictOptions::default())
        .unwrap_err();
    assert!(matches!(e, PredictError::BadValue(_)), "{e}");

    let e = refuse(&["stature=1.76cm"]);
    assert!(e.to_string().contains("looks like metres"), "{e}");
    let e = refuse(&["chest=38cm"]);
    assert!(e.to_string().contains("looks like inches"), "{e}");
    let e = refuse(&["stature=1765"]);
    assert!(e.to_string().contains("looks like millimetres"), "{e}");
    assert!(
        e.to_string()
            .contains("without a unit is read as centimetres"),
        "{e}"
    );

    // A waist three times the hip: far outside the population.
    let e = refuse(&["waist=300cm", "hip=100cm"]);
    assert!(matches!(e, PredictError::OutOfPopulation { .. }), "{e}");
    // Each plausible alone, but not together.
    let e = refuse(&["waist=125cm", "hip=85cm"]);
    assert!(matches!(e, PredictError::Contradiction(_)), "{e}");
    assert!(e.to_string().contains("SD"), "{e}");

    assert!(default_estimator()
        .predict(&Inputs::new(), &PredictOptions::default())
        .is_err());
}

#[test]
fn an_implausible_but_possible_set_gives_a_result_with_a_warning() {
    let e = default_estimator();
    let j = e.set().index_of("stature").unwrap();
    let (mean, sd) = e.file().model.measurement_stats()[j];
    let mut inputs = Inputs::new();
    inputs.insert_metres("stature", mean + 4.5 * sd).unwrap();
    let est = e.predict(&inputs, &PredictOptions::default()).unwrap();
    assert!(est.mesh.vertices.iter().flatten().all(|c| c.is_finite()));
    let p = &est.report.prediction.plausibility;
    assert!(
        p.measurements_mahalanobis > 4.0,
        "{}",
        p.measurements_mahalanobis
    );
    assert!(
        est.report.warnings.iter().any(|w| matches!(
            w,
            tapeshape_estimator::Warning::UnusualSet { .. }
        ) || matches!(
            w,
            tapeshape_estimator::Warning::Model(tapeshape_model::Warning::FarFromPopulation { .. })
        )),
        "{:?}",
        est.report.warnings
    );
    // The user's JSON: the English text under "warnings" (as before the
    // codes), the codes beside it, and it reads back.
    let json = est.report.to_json().unwrap();
    let text: Vec<String> = est.report.warnings.iter().map(|w| w.to_string()).collect();
    assert_eq!(json["warnings"], serde_json::json!(text));
    assert_eq!(
        json["warning_codes"].as_array().map(Vec::len),
        Some(est.report.warnings.len())
    );
    assert!(json["warning_codes"][0]["code"].is_string(), "{json}");
    let back: tapeshape_estimator::EstimateReport = serde_json::from_value(json).unwrap();
    let back_text: Vec<String> = back.warnings.iter().map(|w| w.to_string()).collect();
    assert_eq!(back_text, text);
}

/// Step 2 in the smooth basis (issue 13, `Step2Solver::SmoothBasis`) on the
/// embedded default model and a held-out body's quick and paper34 values:
/// every reading within its ISO 20685-1 tolerance, as with L-BFGS alone;
/// the readings' summed squared error (what the step-2 energy measures,
/// mm^2) at most that of L-BFGS alone plus 0.01 mm^2; the shape no
/// farther from the true body than the default's plus 0.05 mm (mean vertex
/// distance); and a second run the same bit for bit.
#[test]
fn the_smooth_basis_step_2_meets_the_readings_as_the_default_does() {
    use tapeshape_model::{PredictSettings, Step2Solver};
    let e = default_estimator();
    let mut settings = PredictSettings::default();
    settings.step2.solver = Step2Solver::smooth_basis();
    settings.step2.first = None;
    let smooth = PredictOptions::custom(settings);
    let mut lbfgs_settings = PredictSettings::default();
    lbfgs_settings.step2.first = None;
    let lbfgs_only = PredictOptions::custom(lbfgs_settings);
    let body = &fixture().heldout.bodies[1];
    for set in ["quick", "paper34"] {
        let names = usable(e, set);
        let truth = measure(e, &names, body);
        let mut inputs = Inputs::new();
        for (n, v) in names.iter().zip(&truth) {
            inputs.insert_metres(n, *v).unwrap();
        }
        let a = e.predict(&inputs, &smooth).unwrap();
        let b = e.predict(&inputs, &smooth).unwrap();
        assert_eq!(a.mesh.vertices, b.mesh.vertices, "{set}: not deterministic");
        let lbfgs = e.predict(&inputs, &lbfgs_only).unwrap();
        let squared = |vertices: &[Vec3]| -> f64 {
            let got = measure(e, &names, vertices);
            let mut sum = 0.0;
            for (k, n) in names.iter().enumerate() {
                let tol = e.set().definitions[e.set().index_of(n).unwrap()]
                    .tolerance
                    .mm();
                let err = (got[k] - truth[k]).abs() * 1000.0;
                assert!(
                    err <= tol,
                    "{set}, {n}: error {err:.2} mm above the ISO tolerance {tol} mm"
                );
                sum += err * err;
            }
            sum
        };
        let (ss, sl) = (squared(&a.mesh.vertices), squared(&lbfgs.mesh.vertices));
        assert!(
            ss <= sl + 0.01,
            "{set}: squared reading error {ss:.4} mm^2, L-BFGS {sl:.4}"
        );
        let (ds, dl) = (
            1000.0 * vertex_distance(&a.mesh.vertices, body),
            1000.0 * vertex_distance(&lbfgs.mesh.vertices, body),
        );
        assert!(
            ds <= dl + 0.05,
            "{set}: vertex distance {ds:.3} mm, L-BFGS {dl:.3}"
        );
    }
}

/// The default tries the smooth basis first (issue 13,
/// `Step2Settings::first`): where it meets every reading (a held-out
/// body's quick values) the body is the smooth-basis body bit for bit and
/// the report says it was kept; where it does not (an ANSUR II test-split
/// person's real values of the whole `ansur` set, which the smooth basis
/// misses) L-BFGS runs on from the smooth body: the report says how many
/// readings the first result missed, the body is not the one L-BFGS gives
/// from the step-1 shape, it misses fewer readings (beyond ISO 20685-1)
/// than the smooth result it started from, and the progress reported never
/// goes back.
#[test]
fn step_2_keeps_the_smooth_basis_only_where_it_meets_every_reading() {
    use tapeshape_model::{PredictSettings, Step2Solver};
    use tapeshape_population::ansur::{Ansur, Split};
    let e = default_estimator();
    let first = PredictOptions::custom(PredictSettings::default());
    assert!(matches!(
        PredictSettings::default().step2.first,
        Some(Step2Solver::SmoothBasis { .. })
    ));
    let mut s = PredictSettings::default();
    s.step2.first = None;
    let lbfgs_only = PredictOptions::custom(s.clone());
    s.step2.solver = Step2Solver::smooth_basis();
    let smooth_only = PredictOptions::custom(s);

    let body = &fixture().heldout.bodies[1];
    let names = usable(e, "quick");
    let mut inputs = Inputs::new();
    for (n, v) in names.iter().zip(measure(e, &names, body)) {
        inputs.insert_metres(n, v).unwrap();
    }
    let outcome = |est: &tapeshape_estimator::Estimate| {
        est.report
            .prediction
            .step2_first
            .clone()
            .expect("tried first")
    };
    let got = e.predict(&inputs, &first).unwrap();
    let f = outcome(&got);
    assert!(f.kept && f.misses == 0, "{f:?}");
    let smooth = e.predict(&inputs, &smooth_only).unwrap();
    assert_eq!(got.mesh.vertices, smooth.mesh.vertices);

    let ansur = Ansur::get().unwrap();
    let person = ansur.subjects(None, Split::Test).next().unwrap();
    let mut inputs = Inputs::new();
    for name in usable(e, "ansur") {
        let d = &e.set().definitions[e.set().index_of(&name).unwrap()];
        if let Some(v) = d.ansur.as_deref().and_then(|c| person.dim(c)) {
            inputs.insert_metres(&name, v).unwrap();
        }
    }
    // The progress an observer sees never goes back, though step 2 runs
    // twice.
    let seen = std::sync::Mutex::new(Vec::new());
    let got = e
        .predict_observed(&inputs, &first, &|p: &tapeshape_model::PredictProgress| {
            seen.lock().unwrap().push(p.fraction());
            tapeshape_model::Control::Continue
        })
        .unwrap();
    let seen = seen.into_inner().unwrap();
    assert!(
        seen.len() > 10 && seen.windows(2).all(|w| w[0] <= w[1]),
        "{seen:?}"
    );
    let f = outcome(&got);
    assert!(!f.kept && f.misses > 0, "{f:?}");
    let lbfgs = e.predict(&inputs, &lbfgs_only).unwrap();
    assert_ne!(got.mesh.vertices, lbfgs.mesh.vertices);
    assert!(lbfgs.report.prediction.step2_first.is_none());
    let smooth = e.predict(&inputs, &smooth_only).unwrap();
    let beyond_iso = |est: &tapeshape_estimator::Estimate| {
        est.report
            .prediction
            .measurements
            .iter()
            .filter(|m| m.target_mm.is_some() && !m.soft && !m.recorded_only)
            .filter(|m| {
                let j = e.set().index_of(&m.name).unwrap();
                let iso = e.set().definitions[j].tolerance.mm();
                m.error_mm.is_some_and(|x| x.abs() > iso)
            })
            .count()
    };
    let (g, sm) = (beyond_iso(&got), beyond_iso(&smooth));
    assert!(g < sm, "beyond ISO: {g} readings, the smooth result {sm}");
}
