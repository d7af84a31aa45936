//! Tests of `estimate`, in a file of their own so that the module stays short.

use super::*;
use tapeshape_mesh::io::ReadOptions;

fn estimator() -> &'static Estimator {
    Estimator::default_model().expect("embedded model")
}

const READINGS: [(&str, f64); 4] = [
    ("stature", 1.76),
    ("chest", 0.98),
    ("waist", 0.84),
    ("hip", 1.00),
];

fn readings() -> Inputs {
    let mut inputs = Inputs::new();
    for (name, m) in READINGS {
        inputs.push(tape_input(name, m, None)).unwrap();
    }
    inputs
}

#[test]
fn a_job_reports_monotone_progress_and_returns_the_engines_body() {
    let e = estimator();
    let settings = PredictOptions::default();
    let job = start_estimate(e, &readings(), &settings).unwrap();
    let mut seen = Vec::new();
    while !job.is_finished() {
        seen.extend(job.next_progress(Duration::from_millis(50)));
    }
    seen.extend(job.progress());
    let est = job.wait().unwrap();
    assert!(!seen.is_empty());
    for w in seen.windows(2) {
        assert!(w[1].fraction >= w[0].fraction, "{seen:?}");
    }
    assert_eq!(seen.last().unwrap().stage, PredictStage::Done);
    assert_eq!(seen.last().unwrap().fraction, 1.0);
    assert!(seen.iter().any(|p| p.stage == PredictStage::Step2));
    // The same body as a direct prediction (the job adds nothing).
    let direct = e.predict(&readings(), &settings).unwrap();
    assert_eq!(direct.mesh.vertices, est.mesh.vertices);
}

#[test]
fn cancelling_ends_the_job_with_cancelled() {
    let e = estimator();
    // Cancel before it starts: the estimator stops at its first report.
    let job = start_estimate(e, &readings(), &PredictOptions::default()).unwrap();
    job.cancel();
    assert!(matches!(job.wait(), Err(EstimateError::Cancelled(_))));
    // Cancel from another handle once step 2 is under way.
    let job = start_estimate(e, &readings(), &PredictOptions::default()).unwrap();
    let handle = job.cancel_handle();
    let mut cancelled_at = None;
    while let Some(p) = job.next_progress(Duration::from_secs(30)) {
        if p.stage == PredictStage::Step2 {
            handle.cancel();
            cancelled_at = Some(p);
            break;
        }
    }
    assert!(cancelled_at.is_some(), "never reached step 2");
    match job.wait() {
        Err(EstimateError::Cancelled(stage)) => assert!(stage.starts_with("step 2"), "{stage}"),
        other => panic!("expected Cancelled, got {other:?}"),
    }
}

#[test]
fn bad_readings_fail_before_or_inside_the_job_with_a_clear_error() {
    let e = estimator();
    let s = PredictOptions::default();
    let mut twice = readings();
    let err = twice.push(tape_input("chest", 0.99, None)).unwrap_err();
    assert!(err.to_string().contains("given twice"), "{err}");
    let mut neg = readings();
    neg.readings[1].value.metres = -0.98;
    assert!(matches!(
        start_estimate(e, &neg, &s),
        Err(EstimateError::Predict(PredictError::BadValue(_)))
    ));
    let mut tol = readings();
    tol.readings[1].tolerance = Some(f64::NAN);
    assert!(matches!(
        start_estimate(e, &tol, &s),
        Err(EstimateError::Predict(PredictError::BadValue(_)))
    ));
    let mut typo = readings();
    typo.readings[1].name = "chets".into();
    let err = start_estimate(e, &typo, &s).unwrap().wait().unwrap_err();
    assert!(err.to_string().contains("did you mean `chest`"), "{err}");
}

#[test]
fn export_writes_every_format_and_a_report_that_reads_back() {
    let e = estimator();
    let est = e.predict(&readings(), &PredictOptions::default()).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let folder = dir.path().join("out/nested");
    let session = SessionInfo {
        customer_id: "C-42/../x y".into(),
        session_id: 7,
        set: "quick".into(),
        exported_at_ms: 1_700_000_000_000,
    };
    let files = export(&est, &session, &folder, &MeshFormat::ALL).unwrap();
    let names: Vec<String> = files
        .iter()
        .map(|p| p.file_name().unwrap().to_string_lossy().into_owned())
        .collect();
    assert_eq!(
        names,
        [
            "C-42____x_y-session7.obj",
            "C-42____x_y-session7.ply",
            "C-42____x_y-session7.glb",
            "C-42____x_y-session7-report.json"
        ]
    );
    // Nothing else (no temporary files) is left in the folder.
    assert_eq!(std::fs::read_dir(&folder).unwrap().count(), 4);
    let obj = tapeshape_mesh::io::read_obj(&files[0], ReadOptions::default()).unwrap();
    let ply = tapeshape_mesh::io::read_ply(&files[1], ReadOptions::default()).unwrap();
    assert_eq!(ply.vertices, est.mesh.vertices, "PLY f64 is exact");
    assert_eq!(obj.faces(), est.mesh.faces());
    for (a, b) in obj.vertices.iter().zip(&est.mesh.vertices) {
        for k in 0..3 {
            assert!((a[k] - b[k]).abs() < 1e-6);
        }
    }
    let glb = std::fs::read(&files[2]).unwrap();
    assert_eq!(&glb[..4], b"glTF");
    assert_eq!(
        u32::from_le_bytes(glb[8..12].try_into().unwrap()) as usize,
        glb.len()
    );
    let json: serde_json::Value =
        serde_json::from_slice(&std::fs::read(&files[3]).unwrap()).unwrap();
    assert_eq!(json["session"]["customer_id"], "C-42/../x y");
    assert_eq!(json["session"]["session_id"], 7);
    assert_eq!(json["session"]["set"], "quick");
    let ms = json["measurements"].as_array().unwrap();
    assert_eq!(ms.len(), 4);
    for m in ms {
        let name = m["name"].as_str().unwrap();
        let given = READINGS.iter().find(|r| r.0 == name).unwrap();
        let target = m["target_mm"].as_f64().unwrap();
        assert!((target - given.1 * 1000.0).abs() < 1e-9);
        let achieved = m["achieved_mm"].as_f64().unwrap();
        let err = m["error_mm"].as_f64().unwrap();
        assert!((achieved - target - err).abs() < 1e-9);
        // The paper's method fits what was given to well under a millimetre.
        assert!(err.abs() < 1.0, "{name}: error {err} mm");
    }
    assert!(json["units"].as_str().unwrap().contains("millimetres"));
    assert!(json["frames"].as_str().unwrap().contains("Z up"));
    assert!(json["plausibility"]["readings"].is_string());
    assert!(json["timings"]["total_ms"].as_f64().unwrap() > 0.0);
    assert_eq!(json["files"].as_array().unwrap().len(), 3);
    // Exporting again replaces the files (same names, still 4); a format
    // asked twice is written once.
    let again = export(
        &est,
        &session,
        &folder,
        &[MeshFormat::Glb, MeshFormat::Obj, MeshFormat::Glb],
    )
    .unwrap();
    assert_eq!(again.len(), 3);
    assert_eq!(std::fs::read_dir(&folder).unwrap().count(), 4);
}

#[test]
fn an_unwritable_folder_is_a_clear_error() {
    let e = estimator();
    let est = e.predict(&readings(), &PredictOptions::default()).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("a-file");
    std::fs::write(&file, b"x").unwrap();
    let session = SessionInfo {
        customer_id: String::new(),
        session_id: 1,
        set: "quick".into(),
        exported_at_ms: 0,
    };
    let err = export(&est, &session, &file.join("sub"), &[MeshFormat::Obj]).unwrap_err();
    assert!(matches!(err, ExportError::Folder { .. }), "{err}");
    assert!(err.to_string().contains("choose another folder"));
}
