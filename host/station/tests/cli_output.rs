//! What the commands print, with the real binary: a closed pipe ends a
//! command quietly (`tapeshape predict --list | head`), a name one
//! command prints is one the other accepts (`measure --json` -> `predict`),
//! and `dataset stats --all` prints every dimension as Markdown or JSON.

mod common;

use std::path::Path;
use std::process::Stdio;

use tapeshape_estimator::priors::CANNOT_FOLLOW_ANSUR;

/// Runs `tapeshape args` with its stdout a pipe whose reading end is
/// already closed (what `| head` leaves once it has its lines): every write
/// fails with EPIPE.
fn with_stdout_closed(data: &Path, args: &[&str]) -> std::process::Output {
    let (reader, writer) = std::io::pipe().unwrap();
    drop(reader);
    common::tapeshape(data, args)
        .stdout(Stdio::from(writer))
        .output()
        .unwrap()
}

#[test]
fn a_closed_stdout_ends_a_command_quietly() {
    let tmp = tempfile::tempdir().unwrap();
    for args in [
        &["predict", "--list"][..],
        &["measure", "--describe", "--set", "paper34"][..],
        &["sessions"][..],
        &["--help"][..],
    ] {
        let out = with_stdout_closed(tmp.path(), args);
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(!stderr.contains("panicked"), "{args:?}: {stderr}");
        assert!(!stderr.contains("Broken pipe"), "{args:?}: {stderr}");
        assert!(out.status.success(), "{args:?}: {:?} {stderr}", out.status);
    }
    // The same command with a reader prints its list (so the check above
    // did exercise a write).
    let out = common::tapeshape(tmp.path(), &["predict", "--list"])
        .output()
        .unwrap();
    assert!(out.status.success());
    assert!(String::from_utf8_lossy(&out.stdout).contains("stature"));
}

/// The template body as an OBJ (metres, station frame).
fn template_obj(dir: &Path) -> std::path::PathBuf {
    let model = tapeshape_body::BodyModel::shared().unwrap();
    let path = dir.join("template.obj");
    tapeshape_mesh::io::write_obj(&model.template(), &path).unwrap();
    path
}

/// Every measurement `tapeshape measure --json` prints for a set the default
/// model carries is one `tapeshape predict` takes (the whole set predicts);
/// each group total is marked derived, and `predict` refuses it naming the
/// members to give instead.
#[test]
fn what_measure_prints_predict_takes_totals_included() {
    let tmp = tempfile::tempdir().unwrap();
    let mesh = template_obj(tmp.path());
    let mut groups_seen = 0;
    for set in ["quick", "ansur", "paper34"] {
        let out = common::tapeshape(tmp.path(), &["measure", "--set", set, "--json"])
            .arg(&mesh)
            .output()
            .unwrap();
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        let doc: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
        let mut readings = serde_json::Map::new();
        readings.insert("unit".into(), "mm".into());
        for m in doc["measurements"].as_array().unwrap() {
            let name = m["name"].as_str().unwrap();
            readings.insert(name.into(), m["value_mm"].clone());
        }
        let file = tmp.path().join(format!("{set}.json"));
        std::fs::write(&file, serde_json::to_vec(&readings).unwrap()).unwrap();
        let out = common::tapeshape(tmp.path(), &["predict", "--measurements"])
            .arg(&file)
            .output()
            .unwrap();
        assert!(
            out.status.success(),
            "{set}: predict refused what measure printed: {}",
            String::from_utf8_lossy(&out.stderr)
        );
        for g in doc["groups"].as_array().unwrap() {
            groups_seen += 1;
            let name = g["name"].as_str().unwrap();
            assert_eq!(g["derived"], "sum", "{g}");
            let members: Vec<&str> = g["sum_of"]
                .as_array()
                .unwrap()
                .iter()
                .map(|m| m.as_str().unwrap())
                .collect();
            assert!(members.len() >= 2, "{g}");
            // The total is the sum of its members as printed.
            let sum: f64 = members.iter().map(|m| readings[*m].as_f64().unwrap()).sum();
            assert!((g["value_mm"].as_f64().unwrap() - sum).abs() < 1e-6, "{g}");
            // A total is one tape reading: predict takes it and shares it
            // out over its pieces (issue 12, item 5).
            let out = common::tapeshape(tmp.path(), &["predict", "--measure"])
                .arg(format!("{name}={}mm", g["value_mm"].as_f64().unwrap()))
                .arg("--measure")
                .arg(format!(
                    "stature={}mm",
                    readings
                        .get("stature")
                        .and_then(serde_json::Value::as_f64)
                        .unwrap_or(1700.0)
                ))
                .output()
                .unwrap();
            let stdout = String::from_utf8_lossy(&out.stdout);
            assert!(
                out.status.success(),
                "{name} was refused: {}",
                String::from_utf8_lossy(&out.stderr)
            );
            assert!(stdout.contains("taken as one reading"), "{stdout}");
            for m in &members {
                assert!(stdout.contains(m), "{name}: {stdout}");
            }
            // With one of its own pieces it is a mistake, said plainly.
            let out = common::tapeshape(tmp.path(), &["predict", "--measure"])
                .arg(format!("{name}=380mm"))
                .arg("--measure")
                .arg(format!("{}=100mm", members[0]))
                .output()
                .unwrap();
            let err = String::from_utf8_lossy(&out.stderr);
            assert!(!out.status.success(), "{name} with its piece was accepted");
            assert!(err.contains("both as a total"), "{err}");
        }
    }
    assert_eq!(groups_seen, 4, "paper34's knee and arm loops, both sides");
}

#[test]
fn predict_with_a_size_chart_prints_and_reports_the_sizes() {
    let tmp = tempfile::tempdir().unwrap();
    let chart =
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/size-charts/menswear.toml");
    let report = tmp.path().join("report.json");
    let out = common::tapeshape(
        tmp.path(),
        &[
            "predict",
            "--measure",
            "stature=176cm",
            "--measure",
            "chest=104cm",
            "--measure",
            "waist=88cm",
            "--measure",
            "inside_leg=83cm",
            "--sex",
            "male",
            "--chart",
        ],
    )
    .arg(&chart)
    .arg("--report")
    .arg(&report)
    .output()
    .unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    // Chest 104 cm sits inside the example chart's shirt M [100, 108).
    assert!(stdout.contains("shirt: M"), "{stdout}");
    // Hip was not measured: the trousers' hip is read off the body.
    assert!(stdout.contains("estimated"), "{stdout}");
    let json: serde_json::Value = serde_json::from_slice(&std::fs::read(&report).unwrap()).unwrap();
    let garments = json["sizes"]["garments"].as_array().unwrap();
    assert_eq!(garments.len(), 3);
    assert_eq!(json["sex"], "Male");
    // A chart naming a measurement the station does not know: a clear
    // error before any estimate.
    let bad = tmp.path().join("bad.toml");
    std::fs::write(
        &bad,
        "[chart]\nname = \"x\"\nunits = \"cm\"\n[[garment]]\nname = \"shirt\"\nprimary = [\"chst\"]\nsize = [{ label = \"M\", chst = [100, 108] }]\n",
    )
    .unwrap();
    let out = common::tapeshape(
        tmp.path(),
        &["predict", "--measure", "stature=176cm", "--chart"],
    )
    .arg(&bad)
    .output()
    .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success());
    assert!(err.contains("chst") && err.contains("chest"), "{err}");
}

/// `dataset stats --all` on a small population: Markdown with issue 3's
/// block then every `ansur` dimension (the unfollowable ones marked), JSON
/// with both parts; on a dataset that is not a population it refuses and
/// says what to give instead.
#[test]
fn dataset_stats_all_prints_every_dimension() {
    let tmp = tempfile::tempdir().unwrap();
    let settings = tapeshape_population::PopulationSettings {
        n: 8,
        seed: 11,
        ..Default::default()
    };
    let mut d = tapeshape_population::generate_population(&settings, &|_, _| {}).unwrap();
    let file = tmp.path().join("pop.tsd");
    d.write(&file).unwrap();
    let file_arg = file.to_str().unwrap();

    let out = common::tapeshape(tmp.path(), &["dataset", "stats", file_arg, "--all"])
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let issue3 = stdout.find("Worst: mean").expect("issue 3's block");
    let every = stdout.find("### Every `ansur` dimension").expect(&stdout);
    assert!(issue3 < every, "{stdout}");
    for marked in CANNOT_FOLLOW_ANSUR {
        assert!(
            stdout.contains(&format!("| {marked} * |")),
            "{marked}: {stdout}"
        );
    }
    assert!(stdout.contains("Within ISO 20685-1 of their own subject"));

    let out = common::tapeshape(
        tmp.path(),
        &["dataset", "stats", file_arg, "--all", "--json"],
    )
    .output()
    .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(v["checked"].as_array().unwrap().len(), 2);
    let all = &v["all_dimensions"];
    let k = all["dimensions"].as_array().unwrap().len();
    assert!(k >= 40, "{k} dimensions");
    for st in all["sexes"].as_array().unwrap() {
        assert_eq!(st["mean_mm"].as_array().unwrap().len(), k);
        assert_eq!(st["correlation"]["n_pairs"], k * (k - 1) / 2);
        assert_eq!(st["iso"]["n_judged"], st["n_bodies"]);
    }

    // Not a population: a clear refusal, not a panic or silence.
    d.header.kind = tapeshape_population::DatasetKind::Imported;
    d.write(&file).unwrap();
    let out = common::tapeshape(tmp.path(), &["dataset", "stats", file_arg, "--all"])
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success());
    assert!(stderr.contains("drop --all"), "{stderr}");
    assert!(!stderr.contains("panicked"), "{stderr}");
}

/// `--step2 lbfgs` runs the paper's L-BFGS alone and says so (in the
/// printout and the report's settings); the default tries the smooth basis
/// first and reports what became of it; `--no-fold-repair` turns the fold
/// repair off.
#[test]
fn predict_step2_chooses_the_solver_and_reports_it() {
    let tmp = tempfile::tempdir().unwrap();
    let run = |extra: &[&str], report: &str| {
        let path = tmp.path().join(report);
        let out = common::tapeshape(
            tmp.path(),
            &[
                "predict",
                "--measure",
                "stature=176.5cm",
                "--measure",
                "chest=98cm",
                "--measure",
                "waist=84cm",
                "--measure",
                "hip=100cm",
            ],
        )
        .args(extra)
        .arg("--report")
        .arg(&path)
        .output()
        .unwrap();
        let stdout = String::from_utf8_lossy(&out.stdout).into_owned();
        assert!(
            out.status.success(),
            "{extra:?}: {stdout} {}",
            String::from_utf8_lossy(&out.stderr)
        );
        let doc: serde_json::Value =
            serde_json::from_slice(&std::fs::read(&path).unwrap()).unwrap();
        (stdout, doc)
    };
    let (stdout, doc) = run(&["--step2", "lbfgs"], "lbfgs.json");
    assert!(stdout.contains("step 2: L-BFGS alone"), "{stdout}");
    assert!(
        doc["prediction"]["step2_first"].is_null(),
        "{}",
        doc["prediction"]
    );
    assert!(doc["prediction"]["settings"]["step2"]["first"].is_null());
    let (stdout, doc) = run(&[], "default.json");
    assert!(!stdout.contains("L-BFGS alone"), "{stdout}");
    assert!(stdout.contains("step 2: "), "{stdout}");
    let first = &doc["prediction"]["step2_first"];
    assert!(first["kept"].is_boolean(), "{first}");
    assert!(!doc["prediction"]["settings"]["step2"]["first"].is_null());
    // The fold repair is on unless `--no-fold-repair` says otherwise, and
    // the report records which.
    assert_eq!(doc["prediction"]["settings"]["step2"]["fold_repair"], true);
    let (_, doc) = run(&["--no-fold-repair"], "no-repair.json");
    assert_eq!(doc["prediction"]["settings"]["step2"]["fold_repair"], false);
    assert!(!doc["prediction"]["settings"]["step2"]["first"].is_null());
    // A solver that is not one is refused with the choices.
    let out = common::tapeshape(tmp.path(), &["predict", "--measure", "stature=176cm"])
        .args(["--step2", "newton"])
        .output()
        .unwrap();
    assert!(!out.status.success());
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        stderr.contains("smooth-first") && stderr.contains("lbfgs"),
        "{stderr}"
    );
}

/// `--ansur-survey`: a caliper chest breadth from ANSUR data is kept in the
/// report and on the screen beside the body's value, not fitted; without
/// the flag (a station's reading, skin to skin) it is fitted.
#[test]
fn predict_records_a_survey_chest_breadth_without_fitting_it() {
    let tmp = tempfile::tempdir().unwrap();
    let report = tmp.path().join("report.json");
    let args = [
        "predict",
        "--measure",
        "stature=176cm",
        "--measure",
        "chest=100cm",
        "--measure",
        "waist=88cm",
        "--measure",
        "chestbreadth=33cm",
        "--sex",
        "male",
    ];
    let chest_breadth = |survey: bool| {
        let mut cmd = common::tapeshape(tmp.path(), &args);
        if survey {
            cmd.arg("--ansur-survey");
        }
        let out = cmd.arg("--report").arg(&report).output().unwrap();
        let stdout = String::from_utf8_lossy(&out.stdout).to_string();
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        let json: serde_json::Value =
            serde_json::from_slice(&std::fs::read(&report).unwrap()).unwrap();
        let m = json["prediction"]["measurements"]
            .as_array()
            .unwrap()
            .iter()
            .find(|m| m["name"] == "chestbreadth")
            .unwrap()
            .clone();
        (stdout, json, m)
    };
    let (stdout, json, m) = chest_breadth(true);
    assert!(stdout.contains("chestbreadth (recorded)"), "{stdout}");
    assert!(
        stdout.contains("1 reading recorded, not fitted: chestbreadth"),
        "{stdout}"
    );
    assert_eq!(m["recorded_only"], true, "{m}");
    assert_eq!(m["target_mm"], 330.0, "{m}");
    assert!(json["warning_codes"]
        .as_array()
        .unwrap()
        .iter()
        .any(|w| w["code"] == "recorded-not-fitted"));
    let (stdout, _, m) = chest_breadth(false);
    assert!(!stdout.contains("recorded"), "{stdout}");
    assert!(m.get("recorded_only").is_none(), "{m}");
    assert!(m["error_mm"].as_f64().unwrap() < 2.0, "{m}");
}
