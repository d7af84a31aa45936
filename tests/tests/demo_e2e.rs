//! End to end, a fitting-room session with a customer whose true body is
//! known: a generated body (held out from the default model's training: its
//! population has seed 2, the model's seed 1) is measured with the `quick`
//! set on its true mesh; the values go through the simulated tape's serial
//! lines, the firmware logic between two pseudo-terminals
//! (`tapeshape_sim::harness`), the station's link and SQLite store (the
//! `record` loop `tapeshape station` and the headless demo run), then the
//! station's estimate job and export. Checked: every reading stored once
//! with the value sent, the files exported and parseable (OBJ, PLY, GLB
//! with the `gltf` crate as an oracle, the JSON report), and the estimated
//! body's mean vertex distance to the true body below a bound measured
//! beforehand (see `docs/results/demo-e2e.md` and [`BOUND_CLEAN_MM`]).
//! Then the same with novice-operator noise (1 cm SD per reading, seeded).
//! Three bodies, six sessions.
//!
//! `tapeshape demo` itself cannot take a known body (its customer is an
//! ANSUR II person, whose body is unknown), so the demo's path (harness +
//! tape + `record`) is reproduced here with generated bodies; a second test
//! runs the real `tapeshape demo --headless` binary and checks its stored
//! session against the simulated person's readings and its exported files.
//!
//! `cargo test -p tapeshape-tests --test demo_e2e -- --ignored --nocapture`
//! runs the measurement behind the bounds (20 held-out bodies, without the
//! serial path, whose values are identical to 0.1 mm).

use std::path::Path;
use std::sync::OnceLock;
use std::time::Duration;

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};
use tapeshape::cli::station::{plan, record, RecordOptions};
use tapeshape::estimate::{export, start_estimate, MeshFormat, Reading, SessionInfo};
use tapeshape::store::Store;
use tapeshape_engine::dataset::{generate_population, Dataset, PopulationSettings};
use tapeshape_engine::predict::{Engine, PredictOptions};
use tapeshape_mesh::Vec3;
use tapeshape_sim::harness::{FirmwareHarness, HarnessConfig};
use tapeshape_sim::pty::TtyStream;
use tapeshape_sim::tape::{play, Script, Step, TapeTiming};

/// Bodies of the held-out population that go through the whole path.
const E2E_BODIES: usize = 3;
/// Mean vertex distance (mm) each e2e body's estimate must stay under, clean
/// readings. Measured over the first 20 held-out bodies with the quick set
/// (docs/results/demo-e2e.md), with two versions of the model code of
/// 22 Nov 2026 (the method was being tuned): mean 16.1 / 16.5 mm, largest
/// 28.8 / 31.4 mm (body 0, one of the e2e bodies). The bound is the larger
/// maximum plus about 25 %, room for the tuning still under way; a unit,
/// frame or vertex-order mistake (tens to hundreds of mm) still fails.
const BOUND_CLEAN_MM: f64 = 40.0;
/// The same with 1 cm SD reading noise (measured: mean 17.2 / 17.8 mm,
/// largest 28.3 / 32.6 mm): the same bound, since nine noisy readings moved
/// the 20-body mean by little more than 1 mm.
const BOUND_NOISY_MM: f64 = 40.0;
/// Novice-operator noise per reading, metres (the paper's real-measurement
/// experiment: about 1 cm).
const NOVICE_SD_M: f64 = 0.01;

fn engine() -> &'static Engine {
    Engine::default_model().expect("embedded default model")
}

/// Held-out generated bodies (seed 2, as in docs/results/predict-sreal.md).
fn held_out(n: usize) -> &'static Dataset {
    static DATA: OnceLock<Dataset> = OnceLock::new();
    let d = DATA.get_or_init(|| {
        generate_population(
            &PopulationSettings {
                n: n.max(20),
                seed: 2,
                ..PopulationSettings::default()
            },
            &|_, _| {},
        )
        .expect("generating held-out bodies")
    });
    assert!(d.len() >= n);
    d
}

/// The `quick` set's values on `body` (name, metres), in set order.
fn quick_values(body: &[Vec3]) -> Vec<(String, f64)> {
    set_values(body, "quick")
}

/// A set's values on `body` (name, metres), in set order.
fn set_values(body: &[Vec3], set: &str) -> Vec<(String, f64)> {
    let e = engine();
    e.set_members(set)
        .expect("the default model carries the set")
        .into_iter()
        .map(|name| {
            let j = e.set().index_of(&name).expect("member");
            let v = e.compiled().measure_one(j, body).expect("measures").value;
            (name, v)
        })
        .collect()
}

/// Tape values in tenths of a millimetre, with optional Gaussian noise.
fn tape_values(values: &[(String, f64)], noise: Option<(f64, u64)>) -> Vec<(String, u32)> {
    let mut rng = noise.map(|(_, seed)| ChaCha8Rng::seed_from_u64(seed));
    let normal = noise.map(|(sd, _)| Normal::new(0.0, sd).expect("positive SD"));
    values
        .iter()
        .map(|(n, v)| {
            let e = match (&mut rng, &normal) {
                (Some(r), Some(d)) => d.sample(r),
                _ => 0.0,
            };
            (n.clone(), ((v + e) * 10_000.0).round() as u32)
        })
        .collect()
}

/// Mean distance (mm) between corresponding vertices.
fn mean_distance_mm(a: &[Vec3], b: &[Vec3]) -> f64 {
    assert_eq!(a.len(), b.len());
    let sum: f64 = a
        .iter()
        .zip(b)
        .map(|(p, q)| {
            ((p[0] - q[0]).powi(2) + (p[1] - q[1]).powi(2) + (p[2] - q[2]).powi(2)).sqrt()
        })
        .sum();
    1000.0 * sum / a.len() as f64
}

fn mean_shape() -> Vec<Vec3> {
    engine()
        .file()
        .model
        .pca
        .mean
        .chunks_exact(3)
        .map(|c| [c[0], c[1], c[2]])
        .collect()
}

/// Runs one session through tape -> firmware -> link -> store; returns the
/// store's current readings (name, tenths of a mm) and the session's id.
/// `boot_id` must differ per session: the store refuses a (device, boot,
/// seq) it has seen, as it must for a tape that did not reboot.
fn session_through_the_station(
    store: &Store,
    boot_id: u32,
    customer: &str,
    values: &[(String, u32)],
) -> (tapeshape::store::SessionId, Vec<(String, u32)>) {
    let session = store.create_session(customer, Some("quick")).unwrap();
    let planned = plan(store, &session, &[]).unwrap();
    assert_eq!(
        planned
            .as_ref()
            .map(|p| p.iter().map(|p| p.name.clone()).collect::<Vec<_>>()),
        Some(values.iter().map(|v| v.0.clone()).collect()),
        "the station's plan follows the set's order"
    );
    let mut steps = Vec::new();
    for (_, v) in values {
        steps.push(Step::Pull {
            to_tenth_mm: *v,
            over: Duration::from_millis(1500),
        });
        steps.push(Step::Hold);
    }
    let timeline = Script { steps }
        .timeline(TapeTiming::default())
        .expect("tape script");
    let runtime = tokio::runtime::Builder::new_multi_thread()
        .worker_threads(2)
        .enable_all()
        .build()
        .unwrap();
    runtime.block_on(async {
        let harness = FirmwareHarness::start(HarnessConfig::fast(0x7a9e_e2e0_0000_0001, boot_id))
            .expect("firmware harness");
        let mut tape = TtyStream::open_path(harness.tape_path()).expect("tape pty");
        let player = tokio::spawn(async move {
            tokio::time::sleep(Duration::from_millis(200)).await;
            play(&timeline, 20.0, &mut tape, |_| {}).await
        });
        let options = RecordOptions {
            port: harness.host_path().to_path_buf(),
            baud: 115_200,
            live: false,
            exit_when_complete: true,
        };
        tokio::time::timeout(
            Duration::from_secs(40),
            record(options, store.clone(), session.id, planned),
        )
        .await
        .expect("the session completes within 40 s")
        .expect("record ends cleanly");
        player.abort();
        drop(harness);
    });
    let detail = store.open_session(session.id).unwrap();
    // Every reading exactly once: no retakes, none superseded, none doubled.
    assert_eq!(detail.readings.len(), values.len(), "{:?}", detail.readings);
    let stored: Vec<(String, u32)> = detail
        .current_readings()
        .map(|r| (r.measurement.clone(), r.device.value_tenth_mm))
        .collect();
    (session.id, stored)
}

/// Estimates and exports; returns the mean vertex distance to `truth` (mm).
fn estimate_export_and_compare(
    stored: &[(String, u32)],
    session: (i64, &str),
    folder: &Path,
    truth: &[Vec3],
) -> f64 {
    let readings: Vec<Reading> = stored
        .iter()
        .map(|(n, v)| Reading::new(n.clone(), *v as f64 / 10_000.0))
        .collect();
    let job = start_estimate(engine(), &readings, &PredictOptions::default()).unwrap();
    let mut last = 0.0;
    while !job.is_finished() {
        if let Some(p) = job.next_progress(Duration::from_millis(50)) {
            assert!(p.fraction >= last);
            last = p.fraction;
        }
    }
    for p in job.progress() {
        assert!(p.fraction >= last);
        last = p.fraction;
    }
    assert_eq!(last, 1.0, "progress reaches the end");
    let estimate = job.wait().expect("the estimate succeeds");
    let info = SessionInfo {
        customer_id: session.1.into(),
        session_id: session.0,
        set: "quick".into(),
        exported_at_ms: 0,
    };
    let files = export(&estimate, &info, folder, &MeshFormat::ALL).expect("export");
    assert_eq!(files.len(), 4);
    check_files(&files, &estimate.mesh.vertices, stored);
    mean_distance_mm(&estimate.mesh.vertices, truth)
}

/// The exported files parse back to the estimated body.
fn check_files(files: &[std::path::PathBuf], vertices: &[Vec3], stored: &[(String, u32)]) {
    use tapeshape_mesh::io::{read_obj, read_ply, ReadOptions};
    let obj = read_obj(&files[0], ReadOptions::default()).expect("OBJ parses");
    assert!(mean_distance_mm(&obj.vertices, vertices) < 1e-3);
    let ply = read_ply(&files[1], ReadOptions::default()).expect("PLY parses");
    assert_eq!(ply.vertices, vertices);
    // GLB container: magic, version 2, total length, 4-byte aligned chunks.
    let glb = std::fs::read(&files[2]).unwrap();
    let word = |at: usize| u32::from_le_bytes(glb[at..at + 4].try_into().unwrap()) as usize;
    assert_eq!(&glb[..4], b"glTF");
    assert_eq!(word(4), 2);
    assert_eq!(word(8), glb.len());
    let json_len = word(12);
    assert_eq!(&glb[16..20], b"JSON");
    assert_eq!(json_len % 4, 0);
    assert_eq!(&glb[24 + json_len..28 + json_len], b"BIN\0");
    assert_eq!(word(20 + json_len) % 4, 0);
    assert_eq!(28 + json_len + word(20 + json_len), glb.len());
    let (doc, buffers, _) = gltf::import(&files[2]).expect("GLB parses (gltf crate)");
    let prim = doc.meshes().next().unwrap().primitives().next().unwrap();
    let reader = prim.reader(|b| Some(&buffers[b.index()]));
    let pos: Vec<[f32; 3]> = reader.read_positions().unwrap().collect();
    assert_eq!(pos.len(), vertices.len());
    assert_eq!(reader.read_normals().unwrap().count(), vertices.len());
    // The POSITION accessor's min/max are those of the positions.
    let bb = prim.bounding_box();
    for k in 0..3 {
        let lo = pos.iter().map(|p| p[k]).fold(f32::INFINITY, f32::min);
        let hi = pos.iter().map(|p| p[k]).fold(f32::NEG_INFINITY, f32::max);
        assert_eq!((bb.min[k], bb.max[k]), (lo, hi), "axis {k}");
    }
    // glTF frame: (x, y, z)_station -> (-x, z, y); the body stands on y = 0.
    for (p, v) in pos.iter().zip(vertices).step_by(97) {
        assert!((p[0] as f64 + v[0]).abs() < 1e-5 && (p[1] as f64 - v[2]).abs() < 1e-5);
    }
    let json: serde_json::Value =
        serde_json::from_slice(&std::fs::read(&files[3]).unwrap()).expect("report parses");
    let ms = json["measurements"].as_array().unwrap();
    assert_eq!(ms.len(), stored.len());
    for (name, v) in stored {
        let m = ms.iter().find(|m| m["name"] == name.as_str()).unwrap();
        assert!((m["target_mm"].as_f64().unwrap() - *v as f64 / 10.0).abs() < 1e-9);
    }
}

#[test]
fn known_bodies_through_tape_firmware_link_store_estimate_and_export() {
    let data = held_out(E2E_BODIES);
    let dir = tempfile::tempdir().unwrap();
    let store = Store::open(&dir.path().join("store")).unwrap();
    let mean = mean_shape();
    let (mut clean_sum, mut noisy_sum, mut mean_sum) = (0.0, 0.0, 0.0);
    for (i, truth) in data.bodies.iter().take(E2E_BODIES).enumerate() {
        let true_values = quick_values(truth);
        let mean_dist = mean_distance_mm(&mean, truth);

        // A careful operator: the tape reads the true values.
        let sent = tape_values(&true_values, None);
        let customer = format!("e2e-{i}-clean");
        let boot = 100 + 2 * i as u32;
        let (id, stored) = session_through_the_station(&store, boot, &customer, &sent);
        assert_eq!(stored, sent, "every reading stored once, in order, as sent");
        let folder = dir.path().join(&customer);
        let clean = estimate_export_and_compare(&stored, (id.0, &customer), &folder, truth);

        // A novice: 1 cm SD per reading (seeded as in the measurement).
        let sent = tape_values(&true_values, Some((NOVICE_SD_M, 5 + i as u64)));
        assert_ne!(sent, tape_values(&true_values, None));
        let customer = format!("e2e-{i}-novice");
        let boot = boot + 1;
        let (id, stored) = session_through_the_station(&store, boot, &customer, &sent);
        assert_eq!(stored, sent, "every noisy reading stored once, as sent");
        let folder = dir.path().join(&customer);
        let noisy = estimate_export_and_compare(&stored, (id.0, &customer), &folder, truth);

        println!(
            "body {i}: mean vertex distance clean {clean:.2} mm, novice {noisy:.2} mm, mean shape {mean_dist:.2} mm"
        );
        assert!(clean < BOUND_CLEAN_MM, "body {i} clean: {clean:.2} mm");
        assert!(noisy < BOUND_NOISY_MM, "body {i} novice: {noisy:.2} mm");
        clean_sum += clean;
        noisy_sum += noisy;
        mean_sum += mean_dist;
    }
    // The readings carry information: on average the estimates are far
    // closer to the true bodies than the population's mean shape (not per
    // body: 9 readings can miss a body the mean shape happens to resemble).
    assert!(clean_sum < 0.75 * mean_sum, "{clean_sum} vs {mean_sum}");
    assert!(noisy_sum < 0.75 * mean_sum, "{noisy_sum} vs {mean_sum}");
    // Every session is in the store, complete.
    let sessions = store.list_sessions().unwrap();
    assert_eq!(sessions.len(), 2 * E2E_BODIES);
    for s in sessions {
        assert_eq!(s.current_readings as usize, 9, "{}", s.session.customer_id);
    }
}

/// The real `tapeshape demo --headless` (its customer is an ANSUR II
/// test-split person, whose body is unknown, so no vertex distance here):
/// the session it stores holds exactly the person's readings, and the body
/// it exports parses and fits them.
#[test]
fn the_headless_demo_binary_stores_every_reading_and_exports_a_body_that_fits_them() {
    let bin = tapeshape_tests::tapeshape_binary();
    let dir = tempfile::tempdir().unwrap();
    let (data, exports) = (dir.path().join("data"), dir.path().join("exports"));
    let seed = 3;
    let out = std::process::Command::new(&bin)
        .args(["demo", "--headless", "--set", "quick", "--speedup", "20"])
        .args(["--seed", &seed.to_string()])
        .arg("--data-dir")
        .arg(&data)
        .arg("--export-dir")
        .arg(&exports)
        .env_remove("TAPESHAPE_DATA_DIR")
        .output()
        .expect("running tapeshape demo");
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "demo failed: {}\n{stdout}\n{}",
        out.status,
        String::from_utf8_lossy(&out.stderr)
    );
    // The store holds exactly the simulated person's readings, once each.
    let set = tapeshape_engine::measure::MeasurementSet::load("quick").unwrap();
    let customer = tapeshape::cli::demo::demo_customer(&set, seed).unwrap();
    let store = Store::open(&data).unwrap();
    let sessions = store.list_sessions().unwrap();
    assert_eq!(sessions.len(), 1);
    let detail = store.open_session(sessions[0].session.id).unwrap();
    let stored: Vec<(String, u32)> = detail
        .readings
        .iter()
        .map(|r| (r.measurement.clone(), r.device.value_tenth_mm))
        .collect();
    assert_eq!(
        stored, customer.values,
        "every reading stored once, in order"
    );
    // The export: the three meshes and the report, in the export folder or
    // a folder of its own beneath it.
    fn walk(dir: &Path, out: &mut Vec<std::path::PathBuf>) {
        for e in std::fs::read_dir(dir).unwrap_or_else(|e| panic!("{}: {e}", dir.display())) {
            let p = e.unwrap().path();
            if p.is_dir() {
                walk(&p, out);
            } else {
                out.push(p);
            }
        }
    }
    let mut files = Vec::new();
    walk(&exports, &mut files);
    files.sort();
    let ext = |p: &std::path::PathBuf| p.extension().unwrap().to_string_lossy().into_owned();
    let by_ext = |e: &str| files.iter().find(|p| ext(p) == e).cloned().unwrap();
    assert_eq!(files.len(), 4, "{files:?}");
    let ordered = [by_ext("obj"), by_ext("ply"), by_ext("glb"), by_ext("json")];
    let ply = tapeshape_mesh::io::read_ply(&ordered[1], Default::default()).unwrap();
    check_files(&ordered, &ply.vertices, &stored);
    // The body fits the person's readings (the method fits what is given to
    // well under the model's 5 mm warning level).
    let report: serde_json::Value =
        serde_json::from_slice(&std::fs::read(&ordered[3]).unwrap()).unwrap();
    for m in report["measurements"].as_array().unwrap() {
        let err = m["error_mm"].as_f64().unwrap();
        assert!(err.abs() < 5.0, "{}: error {err} mm", m["name"]);
    }
}

/// The measurement behind the bounds: 20 held-out bodies, quick and ansur
/// sets, clean and with 1 cm noise (seed 5 + body index), the engine's
/// estimate directly (the serial path delivers the same 0.1 mm values, as
/// the e2e test asserts).
#[test]
#[ignore = "measurement for docs/results/demo-e2e.md (about 30 s)"]
fn measure_vertex_distances_on_held_out_bodies() {
    let n = 20;
    let data = held_out(n);
    let mean = mean_shape();
    let means: Vec<f64> = data
        .bodies
        .iter()
        .take(n)
        .map(|b| mean_distance_mm(&mean, b))
        .collect();
    let summary = |v: &[f64]| {
        let ok: Vec<f64> = v.iter().copied().filter(|x| x.is_finite()).collect();
        format!(
            "mean {:.2} max {:.2} (n = {}, refused {})",
            ok.iter().sum::<f64>() / ok.len() as f64,
            ok.iter().copied().fold(f64::MIN, f64::max),
            ok.len(),
            v.len() - ok.len()
        )
    };
    println!("mean shape: {}", summary(&means));
    for set in ["quick", "ansur"] {
        // clean; novice; novice with its 1 cm stated as the readings' tolerance.
        let mut dist: [Vec<f64>; 3] = [Vec::new(), Vec::new(), Vec::new()];
        for (i, truth) in data.bodies.iter().take(n).enumerate() {
            let vals = set_values(truth, set);
            let seeded = Some((NOVICE_SD_M, 5 + i as u64));
            for (k, (noise, tolerance)) in
                [(None, None), (seeded, None), (seeded, Some(NOVICE_SD_M))]
                    .into_iter()
                    .enumerate()
            {
                let readings: Vec<Reading> = tape_values(&vals, noise)
                    .iter()
                    .map(|(n, v)| Reading {
                        name: n.clone(),
                        metres: *v as f64 / 10_000.0,
                        tolerance,
                    })
                    .collect();
                let est = start_estimate(engine(), &readings, &PredictOptions::default())
                    .unwrap()
                    .wait();
                dist[k].push(match est {
                    Ok(e) => mean_distance_mm(&e.mesh.vertices, truth),
                    Err(e) => {
                        println!("{set} body {i} condition {k}: refused: {e}");
                        f64::NAN
                    }
                });
            }
            println!(
                "{set} body {i:2}: clean {:6.2} mm, novice {:6.2} mm, novice with 1 cm tolerance {:6.2} mm, mean shape {:6.2} mm",
                dist[0][i], dist[1][i], dist[2][i], means[i]
            );
        }
        println!("{set} clean: {}", summary(&dist[0]));
        println!("{set} novice: {}", summary(&dist[1]));
        println!("{set} novice, 1 cm tolerance stated: {}", summary(&dist[2]));
    }
}
