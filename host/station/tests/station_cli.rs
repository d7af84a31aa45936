//! The `tapeshape` binary end to end against a simulated device: a session
//! following a measurement set, the listing and show commands, and the
//! version-mismatch error.

mod common;

use std::time::Duration;

use common::{tapeshape, SimDevice};
use tapeshape::store::{SessionStatus, Store};
use tapeshape_protocol::{ProtocolVersion, PROTOCOL_VERSION};

/// Waits for `child` to exit, at most `secs`; kills it and fails otherwise.
async fn wait_exit(child: &mut std::process::Child, secs: u64) -> std::process::ExitStatus {
    let deadline = tokio::time::Instant::now() + Duration::from_secs(secs);
    loop {
        if let Some(status) = child.try_wait().unwrap() {
            return status;
        }
        if tokio::time::Instant::now() > deadline {
            child.kill().unwrap();
            panic!("station did not exit within {secs} s");
        }
        tokio::time::sleep(Duration::from_millis(20)).await;
    }
}

fn output_of(child: std::process::Child) -> (String, String) {
    let out = child.wait_with_output().unwrap();
    (
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_session_follows_its_set_and_completes() {
    let tmp = tempfile::tempdir().unwrap();
    let data = tmp.path().join("data");
    let dev = SimDevice::start(common::compatible());
    let set = tapeshape_measure::MeasurementSet::builtin("quick").unwrap();
    let names: Vec<String> = set.definitions.iter().map(|d| d.name.clone()).collect();
    assert!(names.len() >= 3);
    let mut child = tapeshape(&data, &["station", "--customer", "anna", "--set", "quick"])
        .arg("--port")
        .arg(&dev.port)
        .arg("--exit-when-complete")
        .spawn()
        .unwrap();
    // The operator measures: one value per measurement of the set.
    for i in 0..names.len() {
        dev.state
            .lock()
            .unwrap()
            .take(1000 + 10 * u32::try_from(i).unwrap());
    }
    let status = wait_exit(&mut child, 20).await;
    let (stdout, stderr) = output_of(child);
    assert!(status.success(), "stdout:\n{stdout}\nstderr:\n{stderr}");
    assert!(stdout.contains("complete"), "{stdout}");
    assert!(stdout.contains(&format!("next {}", names[0])), "{stdout}");

    let store = Store::open(&data).unwrap();
    let list = store.list_sessions().unwrap();
    assert_eq!(list.len(), 1);
    let s = &list[0].session;
    assert_eq!(s.status, SessionStatus::Done);
    assert_eq!(s.measurement_set.as_deref(), Some("quick"));
    let got: Vec<(String, u32)> = store
        .open_session(s.id)
        .unwrap()
        .readings
        .into_iter()
        .map(|r| (r.measurement, r.value_tenth_mm))
        .collect();
    let want: Vec<(String, u32)> = names
        .iter()
        .enumerate()
        .map(|(i, n)| (n.clone(), 1000 + 10 * u32::try_from(i).unwrap()))
        .collect();
    assert_eq!(got, want);

    let out = tapeshape(&data, &["sessions"]).output().unwrap();
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success());
    assert!(
        text.contains("anna") && text.contains("done") && text.contains("quick"),
        "{text}"
    );
    let id = s.id.to_string();
    let out = tapeshape(&data, &["session", "show", &id])
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success());
    assert!(
        text.contains(&names[1]) && text.contains("101.0 mm"),
        "{text}"
    );
    // A second run cannot resume a finished session.
    let out = tapeshape(&data, &["station", "--resume", "--port", "/nonexistent"])
        .output()
        .unwrap();
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("no open session"));
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn version_mismatch_exits_naming_both_versions() {
    let tmp = tempfile::tempdir().unwrap();
    let data = tmp.path().join("data");
    let theirs = ProtocolVersion {
        major: PROTOCOL_VERSION.major + 1,
        minor: 3,
    };
    let dev = SimDevice::start(theirs);
    dev.state.lock().unwrap().take(4242);
    let mut child = tapeshape(&data, &["station", "--customer", "bob", "--port"])
        .arg(&dev.port)
        .spawn()
        .unwrap();
    let status = wait_exit(&mut child, 20).await;
    let (stdout, stderr) = output_of(child);
    assert!(!status.success(), "{stdout}");
    let ours = format!(
        "protocol {}.{}",
        PROTOCOL_VERSION.major, PROTOCOL_VERSION.minor
    );
    let device = format!("protocol {}.{}", theirs.major, theirs.minor);
    assert!(
        stderr.contains(&ours) && stderr.contains(&device),
        "{stderr}"
    );
    // Nothing was stored or acknowledged.
    assert_eq!(dev.state.lock().unwrap().acked, None);
    let store = Store::open(&data).unwrap();
    let id = store.list_sessions().unwrap()[0].session.id;
    assert_eq!(store.reading_count(id).unwrap(), 0);
}

#[tokio::test]
async fn unknown_set_is_refused_before_a_session_is_created() {
    let tmp = tempfile::tempdir().unwrap();
    let data = tmp.path().join("data");
    let out = tapeshape(
        &data,
        &[
            "station",
            "--customer",
            "c",
            "--set",
            "quik",
            "--port",
            "/nonexistent",
        ],
    )
    .output()
    .unwrap();
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("quick"), "{err}");
    let store = Store::open(&data).unwrap();
    assert!(store.list_sessions().unwrap().is_empty());
}

#[cfg(feature = "demo")]
#[tokio::test]
async fn demo_stores_exactly_what_the_simulated_tape_confirmed() {
    let tmp = tempfile::tempdir().unwrap();
    let data = tmp.path().join("data");
    let out = tapeshape(&data, &["demo", "--seed", "3", "--speedup", "20"])
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{stdout}\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let set = tapeshape_measure::MeasurementSet::builtin("quick").unwrap();
    // The oracle: the printed ANSUR II subject's own record. Every stored
    // value must be that person's real measurement (tenths of a mm).
    let id: u32 = stdout
        .split("test-split subject ")
        .nth(1)
        .and_then(|rest| rest.split_whitespace().next())
        .and_then(|w| w.parse().ok())
        .unwrap_or_else(|| panic!("no subject id in the demo's output:\n{stdout}"));
    assert_eq!(id % 4, 0, "the demo customer must come from the test split");
    let subject = tapeshape_population::ansur::Ansur::get()
        .unwrap()
        .subject(id)
        .unwrap();
    let want: Vec<(String, u32)> = set
        .definitions
        .iter()
        .map(|d| {
            let mm = subject.dim(d.ansur.as_deref().unwrap()).unwrap() * 1000.0;
            (d.name.clone(), (mm * 10.0).round() as u32)
        })
        .collect();
    let store = Store::open(&data).unwrap();
    let list = store.list_sessions().unwrap();
    assert_eq!(list.len(), 1);
    assert_eq!(list[0].session.status, SessionStatus::Done);
    let got: Vec<(String, u32)> = store
        .open_session(list[0].session.id)
        .unwrap()
        .readings
        .into_iter()
        .map(|r| (r.measurement, r.value_tenth_mm))
        .collect();
    assert_eq!(got, want);
    // The printed session lists every measurement.
    for (name, _) in &want {
        assert!(stdout.contains(name.as_str()), "{stdout}");
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn ctrl_c_stops_cleanly_and_resume_continues_the_set() {
    let tmp = tempfile::tempdir().unwrap();
    let data = tmp.path().join("data");
    let dev = SimDevice::start(common::compatible());
    let set = tapeshape_measure::MeasurementSet::builtin("quick").unwrap();
    let names: Vec<String> = set.definitions.iter().map(|d| d.name.clone()).collect();
    let value = |i: usize| 2000 + 10 * u32::try_from(i).unwrap();
    let mut child = tapeshape(&data, &["station", "--customer", "cleo", "--set", "quick"])
        .arg("--port")
        .arg(&dev.port)
        .spawn()
        .unwrap();
    for i in 0..3 {
        dev.state.lock().unwrap().take(value(i));
    }
    let deadline = tokio::time::Instant::now() + Duration::from_secs(20);
    while dev.state.lock().unwrap().acked != Some(2) {
        assert!(tokio::time::Instant::now() < deadline, "first 3 not acked");
        tokio::time::sleep(Duration::from_millis(20)).await;
    }
    let kill = std::process::Command::new("kill")
        .args(["-INT", &child.id().to_string()])
        .status()
        .unwrap();
    assert!(kill.success());
    let status = wait_exit(&mut child, 10).await;
    let (stdout, _) = output_of(child);
    assert!(status.success(), "{stdout}");
    assert!(stdout.contains("stopped"), "{stdout}");

    // The rest of the set, in a second run that resumes the session.
    for i in 3..names.len() {
        dev.state.lock().unwrap().take(value(i));
    }
    let mut child = tapeshape(&data, &["station", "--resume", "--exit-when-complete"])
        .arg("--port")
        .arg(&dev.port)
        .spawn()
        .unwrap();
    let status = wait_exit(&mut child, 20).await;
    let (stdout, stderr) = output_of(child);
    assert!(status.success(), "{stdout}\n{stderr}");
    assert!(stdout.contains(&format!("next {}", names[3])), "{stdout}");

    let store = Store::open(&data).unwrap();
    let list = store.list_sessions().unwrap();
    assert_eq!(list.len(), 1);
    assert_eq!(list[0].session.status, SessionStatus::Done);
    let got: Vec<(String, u32)> = store
        .open_session(list[0].session.id)
        .unwrap()
        .readings
        .into_iter()
        .map(|r| (r.measurement, r.value_tenth_mm))
        .collect();
    let want: Vec<(String, u32)> = names
        .iter()
        .enumerate()
        .map(|(i, n)| (n.clone(), value(i)))
        .collect();
    assert_eq!(got, want);
}

#[test]
fn a_regular_file_is_not_taken_for_a_port() {
    let tmp = tempfile::tempdir().unwrap();
    let data = tmp.path().join("data");
    let file = tmp.path().join("notes.txt");
    std::fs::write(&file, b"x").unwrap();
    let out = tapeshape(&data, &["station", "--customer", "c", "--port"])
        .arg(&file)
        .output()
        .unwrap();
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("not a serial port") && err.contains("notes.txt"),
        "{err}"
    );
}

/// Line mode in careful mode: each measurement is asked for twice, a third
/// time when the two differ by more than its allowable error; the median is
/// kept and stored readings are named after the measurement the operator is
/// on. Each value is confirmed only after the line asking for it, as an
/// operator would.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn careful_line_mode_asks_again_and_keeps_the_median() {
    use std::io::BufRead as _;
    let tmp = tempfile::tempdir().unwrap();
    let data = tmp.path().join("data");
    let dev = SimDevice::start(common::compatible());
    let set = tapeshape_measure::MeasurementSet::builtin("quick").unwrap();
    let names: Vec<String> = set.definitions.iter().map(|d| d.name.clone()).collect();
    assert_eq!(names[0], "stature");
    assert_eq!(names[1], "chest");
    let mut child = tapeshape(
        &data,
        &[
            "station",
            "--customer",
            "dora",
            "--set",
            "quick",
            "--careful",
        ],
    )
    .arg("--port")
    .arg(&dev.port)
    .arg("--exit-when-complete")
    .spawn()
    .unwrap();
    let (tx, rx) = std::sync::mpsc::channel::<String>();
    let stdout = child.stdout.take().unwrap();
    std::thread::spawn(move || {
        for line in std::io::BufReader::new(stdout).lines() {
            let Ok(line) = line else { break };
            if tx.send(line).is_err() {
                break;
            }
        }
    });
    let mut seen: Vec<String> = Vec::new();
    // Waits for a line starting with `prefix` (after those seen so far).
    let mut expect = |prefix: &str| -> String {
        let deadline = std::time::Instant::now() + Duration::from_secs(20);
        loop {
            let left = deadline.saturating_duration_since(std::time::Instant::now());
            match rx.recv_timeout(left) {
                Ok(line) => {
                    seen.push(line.clone());
                    if line.starts_with(prefix) {
                        return line;
                    }
                }
                Err(_) => panic!("no line `{prefix}...`; saw:\n{}", seen.join("\n")),
            }
        }
    };
    let take = |v: u32| dev.state.lock().unwrap().take(v);

    // Stature: 3 mm apart, 4 mm allowed: two readings, their mean kept.
    expect("next stature (");
    take(17_650);
    assert_eq!(
        expect("next "),
        format!("next stature ({}) reading 2 of 2", set.definitions[0].label),
        "the second reading of the same measurement"
    );
    take(17_680);
    assert_eq!(
        expect("kept "),
        "kept stature = 1766.5 mm (the median of its last round)"
    );
    // Chest: 11 mm apart, 9 mm allowed: a third, the median kept.
    let next = expect("next ");
    assert!(next.starts_with("next chest ("), "{next}");
    take(9_820);
    assert!(expect("next ").ends_with("reading 2 of 2"));
    take(9_930);
    let third = expect("next ");
    assert!(
        third.starts_with("next chest (")
            && third.ends_with("reading 3 of 3: the two differ by 11.0 mm (allowed 9.0 mm)"),
        "{third}"
    );
    take(9_850);
    assert_eq!(
        expect("kept "),
        "kept chest = 985.0 mm (the median of its last round)"
    );
    // The rest: two equal readings each.
    for (i, name) in names.iter().enumerate().skip(2) {
        let next = expect("next ");
        assert!(next.starts_with(&format!("next {name} (")), "{next}");
        let v = 3_000 + 100 * u32::try_from(i).unwrap();
        take(v);
        expect("next ");
        take(v);
        expect(&format!("kept {name} = "));
    }
    expect("complete");
    let status = wait_exit(&mut child, 20).await;
    assert!(status.success(), "{}", seen.join("\n"));

    // Every reading is stored under its measurement, nothing lost: 2 + 3 +
    // 2 for each of the other seven.
    let store = Store::open(&data).unwrap();
    let list = store.list_sessions().unwrap();
    assert_eq!(list.len(), 1);
    let id = list[0].session.id;
    assert!(store.is_careful(id).unwrap());
    let detail = store.open_session(id).unwrap();
    let per_name = |n: &str| {
        detail
            .readings
            .iter()
            .filter(|r| r.measurement == n)
            .map(|r| r.value_tenth_mm)
            .collect::<Vec<_>>()
    };
    assert_eq!(detail.readings.len(), 2 + 3 + 2 * (names.len() - 2));
    assert_eq!(per_name("stature"), vec![17_650, 17_680]);
    assert_eq!(per_name("chest"), vec![9_820, 9_930, 9_850]);
    // `session show` names the repeats and states the TEM.
    let out = tapeshape(&data, &["session", "show", &id.to_string()])
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "{text}");
    assert!(
        text.contains("careful round 1, reading 3 of 3, kept 985.0 mm"),
        "{text}"
    );
    assert!(!text.contains("retaken"), "{text}");
    assert!(text.contains("careful mode: session TEM"), "{text}");
}
