//! The estimate is kept with its session: after a restart (the process
//! gone, the store opened again) the result is shown and exported again
//! without estimating again, and the export is the same body as before.

mod common;

use std::path::Path;

use tapeshape::cli::demo::demo_customer;
use tapeshape::estimate::MeshFormat;
use tapeshape::services::station::StationServices;
use tapeshape::services::{EstimateSummary, Services as _};
use tapeshape::session::{EstimateInfo, Sessions};
use tapeshape::store::SessionId;

/// Measures the demo's customer (an ANSUR II test-split subject) with the
/// keyboard and estimates; returns the session and the summary shown.
fn measured_and_estimated(sessions: &Sessions) -> (SessionId, EstimateSummary) {
    let set = tapeshape_measure::MeasurementSet::builtin("quick").unwrap();
    let customer = demo_customer(&set, 2).unwrap();
    let view = sessions.start("c-restart", "quick", None).unwrap();
    for (name, v) in &customer.values {
        sessions.capture_keyboard(view.id, name, *v).unwrap();
    }
    let readings: Vec<(String, u32)> = customer
        .values
        .iter()
        .map(|(n, v)| (n.clone(), *v))
        .collect();
    (
        view.id,
        common::estimate_and_wait(sessions, view.id, &readings),
    )
}

fn export_all(services: &StationServices, id: SessionId, dir: &Path) -> Vec<std::path::PathBuf> {
    let mut files = Vec::new();
    for f in MeshFormat::ALL {
        files.extend(services.export(id, f, dir).unwrap());
    }
    files.sort();
    files.dedup();
    files
}

#[test]
fn after_a_restart_the_stored_estimate_shows_and_exports_the_same_body() {
    let data = tempfile::tempdir().unwrap();
    let out = tempfile::tempdir().unwrap();
    let (before_dir, after_dir) = (out.path().join("before"), out.path().join("after"));
    let (id, shown) = {
        let sessions = Sessions::open(data.path()).unwrap();
        let (id, shown) = measured_and_estimated(&sessions);
        let services = StationServices::new(sessions.clone(), None);
        export_all(&services, id, &before_dir);
        (id, shown)
        // Every handle dropped here: the program is gone.
    };
    assert_eq!(shown.rows.len(), 9, "{shown:?}");

    let sessions = Sessions::open(data.path()).unwrap();
    let services = StationServices::new(sessions.clone(), None);
    // Shown as it was, without estimating again.
    let again = services
        .stored_result(id)
        .unwrap()
        .expect("a stored estimate");
    assert_eq!(again, shown);
    let opened = sessions.open_for_measuring(id).unwrap();
    assert!(matches!(
        opened.estimate,
        Some(EstimateInfo { current: true, .. })
    ));
    // Exported again: the same meshes byte for byte, the same report but
    // for the export's own fields.
    let files = export_all(&services, id, &after_dir);
    assert_eq!(files.len(), 4, "{files:?}");
    for f in &files {
        let name = f.file_name().unwrap();
        let before = std::fs::read(before_dir.join(name)).unwrap();
        let after = std::fs::read(f).unwrap();
        if name.to_string_lossy().ends_with("report.json") {
            let mut b: serde_json::Value = serde_json::from_slice(&before).unwrap();
            let mut a: serde_json::Value = serde_json::from_slice(&after).unwrap();
            for v in [&mut a, &mut b] {
                v["session"]["exported_at_ms"] = serde_json::Value::Null;
            }
            assert_eq!(a, b, "the report changed across the restart");
            assert!(a["measurements"].as_array().unwrap().len() == 9);
        } else {
            assert!(
                before == after,
                "{} differs across the restart",
                f.display()
            );
        }
    }
    // With the store's size chart, the stored result shows a size per
    // garment (from the estimator's report kept with the estimate).
    let chart_path =
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/size-charts/menswear.toml");
    let estimator = tapeshape_estimator::Estimator::default_model().unwrap();
    let chart = tapeshape::estimate::sizes::load_chart(&chart_path, estimator).unwrap();
    let with_sizes = StationServices::new(sessions.clone(), None).with_chart(chart);
    let sized = with_sizes.stored_result(id).unwrap().unwrap();
    assert_eq!(sized.rows, shown.rows);
    let garments: Vec<&str> = sized
        .sizes
        .iter()
        .map(|l| l.split(':').next().unwrap())
        .collect();
    assert_eq!(
        garments,
        ["shirt", "jacket", "trousers"],
        "{:?}",
        sized.sizes
    );
    assert!(
        sized.sizes.iter().all(|l| l.contains(" %")),
        "{:?}",
        sized.sizes
    );
    assert!(shown.sizes.is_empty());
    // The exported report carries them too.
    let sized_dir = out.path().join("sized");
    let files = with_sizes.export(id, MeshFormat::Glb, &sized_dir).unwrap();
    let report = files
        .iter()
        .find(|f| f.to_string_lossy().ends_with("report.json"))
        .unwrap();
    let json: serde_json::Value = serde_json::from_slice(&std::fs::read(report).unwrap()).unwrap();
    assert_eq!(json["sizes"]["garments"].as_array().unwrap().len(), 3);
    // A session without an estimate says so.
    let empty = sessions.start("c-none", "quick", None).unwrap();
    assert_eq!(services.stored_result(empty.id).unwrap(), None);
    let err = services
        .export(empty.id, MeshFormat::Glb, &after_dir)
        .unwrap_err();
    assert!(err.to_string().contains("estimate it first"), "{err}");
}

/// The real program: the headless demo estimates and exports (one process),
/// then `tapeshape session export` (another process, nothing estimated)
/// writes the same body again and `session show` reports the estimate.
#[test]
fn the_command_line_exports_a_stored_estimate_again() {
    let tmp = tempfile::tempdir().unwrap();
    let data = tmp.path().join("data");
    let (first, second) = (tmp.path().join("first"), tmp.path().join("second"));
    let out = common::tapeshape(
        &data,
        &["demo", "--headless", "--seed", "5", "--speedup", "20"],
    )
    .arg("--export-dir")
    .arg(&first)
    .output()
    .unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{stdout}\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let show = common::tapeshape(&data, &["session", "show", "1"])
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&show.stdout);
    assert!(show.status.success(), "{text}");
    assert!(
        text.contains("estimate stored") && text.contains("from 9 readings"),
        "{text}"
    );
    assert!(!text.contains("the readings changed since"), "{text}");
    // And its sizes from a chart, from the stored estimate alone.
    let chart =
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/size-charts/womenswear.toml");
    let sized = common::tapeshape(&data, &["session", "show", "1", "--chart"])
        .arg(&chart)
        .output()
        .unwrap();
    let sized_text = String::from_utf8_lossy(&sized.stdout);
    assert!(
        sized.status.success(),
        "{sized_text}
{}",
        String::from_utf8_lossy(&sized.stderr)
    );
    assert!(
        sized_text.contains("Sizes on \"Example womenswear"),
        "{sized_text}"
    );
    let again = common::tapeshape(
        &data,
        &["session", "export", "1", "--format", "glb,obj,ply"],
    )
    .arg("--dir")
    .arg(&second)
    .output()
    .unwrap();
    let text = String::from_utf8_lossy(&again.stdout);
    assert!(
        again.status.success(),
        "{text}\n{}",
        String::from_utf8_lossy(&again.stderr)
    );
    let mut meshes = 0;
    for entry in std::fs::read_dir(&first).unwrap() {
        let name = entry.unwrap().file_name();
        if name.to_string_lossy().ends_with("report.json") {
            continue;
        }
        let a = std::fs::read(first.join(&name)).unwrap();
        let b = std::fs::read(second.join(&name)).unwrap();
        assert!(
            a == b,
            "{name:?} differs between the demo and `session export`"
        );
        meshes += 1;
    }
    assert_eq!(meshes, 3);
}

/// The real program SIGKILLed the moment it has shown an estimate: the
/// estimate was stored before it was shown, so the next program finds it.
#[test]
fn an_estimate_shown_before_a_sigkill_is_in_the_store() {
    use std::io::BufRead as _;
    let tmp = tempfile::tempdir().unwrap();
    let data = tmp.path().join("data");
    let mut child = common::tapeshape(
        &data,
        &["demo", "--headless", "--seed", "7", "--speedup", "20"],
    )
    .spawn()
    .unwrap();
    let stdout = child.stdout.take().unwrap();
    let mut shown = None;
    for line in std::io::BufReader::new(stdout).lines() {
        let line = line.unwrap();
        if line.starts_with("estimate:") {
            shown = Some(line);
            break;
        }
    }
    child.kill().unwrap(); // SIGKILL
    child.wait().unwrap();
    let shown = shown.expect("the demo showed no estimate");
    let show = common::tapeshape(&data, &["session", "show", "1"])
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&show.stdout);
    assert!(text.contains("estimate stored"), "{shown}\n{text}");
    let dir = tmp.path().join("out");
    let out = common::tapeshape(&data, &["session", "export", "1"])
        .arg("--dir")
        .arg(&dir)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let glb = std::fs::read_dir(&dir)
        .unwrap()
        .filter_map(|e| e.ok())
        .find(|e| e.file_name().to_string_lossy().ends_with(".glb"))
        .expect("a GLB");
    assert_eq!(&std::fs::read(glb.path()).unwrap()[..4], b"glTF");
}
