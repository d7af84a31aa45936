//! The quick mode of `body-synthetic` with every method, as CI runs it
//! (`tapeshape-eval body-synthetic --out DIR --quick`): it must write its
//! tables and figures, and the paper's method must beat feature analysis
//! and SGPLVM in every column (the checks the CLI enforces).
//!
//! About a minute in the dev profile (the numeric crates are opt-level 3 there).

use tapeshape_eval::experiments::{all_methods, run, Experiment, Options};

#[test]
fn quick_body_synthetic_beats_feature_analysis_and_sgplvm() {
    let dir = std::env::temp_dir().join(format!("tapeshape-eval-quick-{}", std::process::id()));
    let opts = Options {
        out: dir.clone(),
        quick: true,
        command: "tapeshape-eval body-synthetic --quick (test)".into(),
    };
    let res = run(Experiment::BodySynthetic, &opts, &all_methods).expect("quick run");
    // Both rivals were trained and compared in all six columns.
    assert_eq!(res.checks.len(), 12, "{:#?}", res.checks);
    for c in &res.checks {
        assert!(c.passed, "{}", c.what);
    }
    for f in [
        "README.md",
        "errors.csv",
        "errors.json",
        "plausibility.csv",
        "sreal_vertices.json",
        "s_close_ours.png",
        "s4_methods.png",
        "sreal_signed_distance.png",
    ] {
        assert!(dir.join(f).is_file(), "{f} missing");
    }
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("errors.json")).unwrap()).unwrap();
    let rows = json["rows"].as_array().unwrap();
    let names: Vec<&str> = rows.iter().map(|r| r["method"].as_str().unwrap()).collect();
    for m in [
        "ours",
        "feature analysis",
        "SGPLVM",
        "step 1 only",
        "RBF",
        "generator fit",
    ] {
        assert!(names.contains(&m), "{m} missing from {names:?}");
    }
    let _ = std::fs::remove_dir_all(&dir);
}
