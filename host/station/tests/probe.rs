//! The port search (`tapeshape::link::probe`) over real pseudo-terminals:
//! simulated tapes (the firmware logic, `tapeshape_sim::harness`, on a
//! pty), silent ptys, a pty that talks garbage, a port another program
//! holds, and a path that does not exist, injected as the candidates. No
//! test touches the machine's real serial ports. And `tapeshape ports`
//! end to end on a simulated device.

mod common;

use std::path::{Path, PathBuf};
use std::time::Duration;

use tapeshape::link::probe::{self, Candidate, Decision, Outcome, ProbeConfig, ProbeError, Survey};
use tapeshape::link::{Link, LinkConfig, LinkEvent, Naming};
use tapeshape::session::Sessions;
use tapeshape_protocol::{ProtocolVersion, UnitShown, PROTOCOL_VERSION};
use tapeshape_sim::harness::{FirmwareHarness, HarnessConfig};
use tapeshape_sim::pty::TtyStream;
use tapeshape_sim::tape::TapeLine;
use tokio::io::AsyncWriteExt;
use tokio_serial::{SerialPort, SerialStream};

/// Short, as the brief asks: the simulated firmware answers in
/// milliseconds.
fn config() -> ProbeConfig {
    ProbeConfig {
        timeout: Duration::from_millis(300),
        ..ProbeConfig::default()
    }
}

/// A pty nobody answers on: the master is held (so the slave opens and
/// stays usable) and never written.
struct SilentPty {
    _master: SerialStream,
    _slave: SerialStream,
    path: PathBuf,
}

fn silent_pty() -> SilentPty {
    let (master, slave) = SerialStream::pair().unwrap();
    let path = PathBuf::from(slave.name().unwrap());
    SilentPty {
        _master: master,
        _slave: slave,
        path,
    }
}

/// A pty whose device talks, but not our protocol: AT-command answers and
/// text with zero bytes in it (so frames end and fail their check).
struct GarbagePty {
    task: tokio::task::JoinHandle<()>,
    _slave: SerialStream,
    path: PathBuf,
}

impl Drop for GarbagePty {
    fn drop(&mut self) {
        self.task.abort();
    }
}

fn garbage_pty() -> GarbagePty {
    let (mut master, slave) = SerialStream::pair().unwrap();
    let path = PathBuf::from(slave.name().unwrap());
    let task = tokio::spawn(async move {
        loop {
            let _ = master
                .write_all(b"\r\nOK\r\nAT+GMR\r\nv1.2 modem ready\0noise \x07\x01\x02\0")
                .await;
            tokio::time::sleep(Duration::from_millis(20)).await;
        }
    });
    GarbagePty {
        task,
        _slave: slave,
        path,
    }
}

/// A simulated tape: the firmware logic on a thread, its host port a pty.
fn sim_tape(device_id: u64) -> FirmwareHarness {
    FirmwareHarness::start(HarnessConfig::fast(device_id, 7)).expect("firmware harness")
}

/// A lister returning `paths` as named candidates.
fn named(paths: Vec<PathBuf>) -> impl Fn() -> Result<Vec<Candidate>, ProbeError> {
    move || Ok(paths.iter().map(Candidate::named).collect())
}

async fn survey_of(paths: Vec<PathBuf>) -> Survey {
    probe::survey(&named(paths), &config()).await.unwrap()
}

fn outcome_of<'a>(survey: &'a Survey, path: &Path) -> &'a Outcome {
    &survey
        .ports
        .iter()
        .find(|p| p.candidate.path == path)
        .unwrap_or_else(|| panic!("{} not in the survey: {survey:?}", path.display()))
        .outcome
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_simulated_tape_is_picked_over_a_silent_pty() {
    let tape = sim_tape(0x5157_0000_0000_0001);
    let silent = silent_pty();
    // The silent one first, so that order alone cannot pick the tape.
    let s = survey_of(vec![silent.path.clone(), tape.host_path().to_path_buf()]).await;
    assert_eq!(s.ports.len(), 2);
    match s.decision() {
        Decision::One(p) => {
            assert_eq!(p.candidate.path, tape.host_path());
            let hello = p.outcome.station().expect("a station's hello");
            assert_eq!(hello.device_id, 0x5157_0000_0000_0001);
            assert_eq!(hello.boot_id, 7);
            assert!(PROTOCOL_VERSION.is_compatible(&hello.protocol));
        }
        other => panic!("expected one station, got {other:?}"),
    }
    assert_eq!(
        outcome_of(&s, &silent.path),
        &Outcome::Silent {
            waited: Duration::from_millis(300)
        }
    );
    assert_eq!(s.ports[0].candidate.kind, probe::PortKind::Pty);
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn two_simulated_tapes_are_both_reported_for_the_operator_to_choose() {
    let a = sim_tape(0x5157_0000_0000_00a1);
    let b = sim_tape(0x5157_0000_0000_00b2);
    let s = survey_of(vec![a.host_path().into(), b.host_path().into()]).await;
    let Decision::Several(stations) = s.decision() else {
        panic!("expected two stations: {s:?}");
    };
    let mut ids: Vec<u64> = stations
        .iter()
        .map(|p| p.outcome.station().unwrap().device_id)
        .collect();
    ids.sort();
    assert_eq!(ids, [0x5157_0000_0000_00a1, 0x5157_0000_0000_00b2]);
    // `tapeshape ports` names the --port of each.
    let text = tapeshape::cli::ports::conclusion(&s);
    assert!(text.starts_with("2 tape stations answered"), "{text}");
    for path in [a.host_path(), b.host_path()] {
        assert!(
            text.contains(&format!("--port {}", path.display())),
            "{text}"
        );
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn one_device_through_two_paths_is_one_station() {
    let tape = sim_tape(0x5157_0000_0000_0003);
    let dir = tempfile::tempdir().unwrap();
    let link = dir
        .path()
        .join("usb-tapeshape_tapeshape_tape_station_5157-if00");
    std::os::unix::fs::symlink(tape.host_path(), &link).unwrap();
    let s = survey_of(vec![tape.host_path().into(), link.clone()]).await;
    // Probed once (a second open of the same device would be busy).
    assert_eq!(s.ports.len(), 1, "{s:?}");
    assert!(matches!(s.decision(), Decision::One(_)));
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn with_no_station_it_says_what_to_plug_in_and_lists_what_it_saw() {
    let silent = silent_pty();
    let garbage = garbage_pty();
    let missing = PathBuf::from("/nonexistent/ttyACM7");
    let s = survey_of(vec![
        silent.path.clone(),
        garbage.path.clone(),
        missing.clone(),
    ])
    .await;
    assert_eq!(s.decision(), Decision::None);
    let text = s.nothing_found();
    assert!(
        text.starts_with(
            "No tape station answered. Plug the tape station's USB cable into this computer"
        ),
        "{text}"
    );
    let line = |path: &Path| {
        text.lines()
            .find(|l| l.trim_start().starts_with(&path.display().to_string()))
            .unwrap_or_else(|| panic!("{} not listed:\n{text}", path.display()))
            .to_string()
    };
    assert!(
        line(&silent.path).contains("no answer within 300 ms"),
        "{text}"
    );
    assert!(
        line(&garbage.path).contains("not the tapeshape protocol"),
        "{text}"
    );
    assert!(line(&missing).contains("no such port"), "{text}");
    // And with nothing attached at all.
    let empty = probe::survey(&|| Ok(Vec::new()), &config()).await.unwrap();
    assert!(
        empty
            .nothing_found()
            .contains("No serial ports are attached"),
        "{}",
        empty.nothing_found()
    );
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_pty_speaking_garbage_is_not_taken_and_says_why() {
    let garbage = garbage_pty();
    let tape = sim_tape(0x5157_0000_0000_0004);
    let s = survey_of(vec![garbage.path.clone(), tape.host_path().into()]).await;
    match outcome_of(&s, &garbage.path) {
        Outcome::NotTheProtocol {
            bytes, bad_frames, ..
        } => {
            assert!(*bytes > 0);
            assert!(*bad_frames > 0, "its zero bytes end frames that fail");
        }
        other => panic!("garbage taken as {other:?}"),
    }
    let Decision::One(p) = s.decision() else {
        panic!("expected the tape: {s:?}");
    };
    assert_eq!(p.candidate.path, tape.host_path());
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_port_another_program_holds_is_busy_and_left_alone() {
    let tape = sim_tape(0x5157_0000_0000_0005);
    // Another station has the tape open (exclusively, as the link opens).
    let held = SerialStream::open(&tokio_serial::new(
        tape.host_path().to_string_lossy(),
        115_200,
    ))
    .unwrap();
    let s = survey_of(vec![tape.host_path().into()]).await;
    assert_eq!(outcome_of(&s, tape.host_path()), &Outcome::Busy);
    assert_eq!(s.decision(), Decision::None);
    drop(held);
    // Released: found on one of the next looks, as the kiosk looks again
    // every second (the kernel may take a moment to drop the exclusive
    // open; CI saw one look right after the drop still find it busy).
    let mut s = survey_of(vec![tape.host_path().into()]).await;
    for _ in 0..20 {
        if matches!(s.decision(), Decision::One(_)) {
            break;
        }
        tokio::time::sleep(Duration::from_millis(100)).await;
        s = survey_of(vec![tape.host_path().into()]).await;
    }
    assert!(matches!(s.decision(), Decision::One(_)), "{s:?}");
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_station_of_another_protocol_is_named_but_not_taken() {
    let dev = common::SimDevice::start(ProtocolVersion {
        major: PROTOCOL_VERSION.major + 1,
        minor: 0,
    });
    let s = survey_of(vec![dev.port.clone()]).await;
    let outcome = outcome_of(&s, &dev.port);
    assert!(
        matches!(outcome, Outcome::Incompatible { .. }),
        "{outcome:?}"
    );
    assert!(
        outcome.to_string().contains("update the older"),
        "{outcome}"
    );
    assert_eq!(s.decision(), Decision::None);
}

/// The hello acknowledges nothing: a reading the tape holds when it is
/// probed (twice) still reaches the store when the station connects.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn probing_a_tape_loses_no_reading() {
    let harness = sim_tape(0x5157_0000_0000_0006);
    let mut tape = TtyStream::open_path(harness.tape_path()).expect("tape pty");
    let line = TapeLine {
        value_tenth_mm: 8520,
        confirmed: true,
        unit: UnitShown::Metric,
    };
    tape.write_all(&line.to_bytes().unwrap()).await.unwrap();
    // Let the firmware read the line and queue the reading.
    tokio::time::sleep(Duration::from_millis(300)).await;
    for _ in 0..2 {
        let outcome = probe::probe_port(harness.host_path(), &config()).await;
        assert!(outcome.station().is_some(), "{outcome:?}");
    }
    let data = tempfile::tempdir().unwrap();
    let sessions = Sessions::open(data.path()).unwrap();
    let session = sessions.create("cust-probe", None, None).unwrap().id;
    let link_config = LinkConfig {
        reconnect_poll: Duration::from_millis(50),
        ..LinkConfig::default()
    };
    let (link, mut events, _task) = Link::spawn(harness.host_path(), link_config, sessions.clone());
    link.set_session(Some(session));
    link.set_naming(Naming::Numbered);
    let committed = tokio::time::timeout(Duration::from_secs(5), async {
        loop {
            match events.recv().await {
                Some(LinkEvent::ReadingCommitted { reading, .. }) => return reading,
                Some(_) => continue,
                None => panic!("link stopped"),
            }
        }
    })
    .await
    .expect("the held reading is committed after the probes");
    assert_eq!(committed.value_tenth_mm, 8520);
    assert_eq!(committed.tape().map(|t| t.seq), Some(0));
    link.shutdown();
}

/// `tapeshape ports` on a simulated device and a silent pty: one line each,
/// the device's hello and the silent one's reason, and the conclusion.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn tapeshape_ports_prints_what_answered_and_why_not() {
    let dev = common::SimDevice::start(common::compatible());
    let silent = silent_pty();
    let tmp = tempfile::tempdir().unwrap();
    let out = common::tapeshape(tmp.path(), &["ports", "--timeout-ms", "300", "--also"])
        .arg(&dev.port)
        .arg("--also")
        .arg(&silent.path)
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{stdout}\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let mut lines = stdout.lines();
    let header = lines.next().unwrap();
    for column in ["PATH", "KIND", "VID:PID", "SERIAL", "PRODUCT", "HELLO"] {
        assert!(header.contains(column), "{header}");
    }
    let row = |path: &Path| {
        stdout
            .lines()
            .find(|l| l.starts_with(&path.display().to_string()))
            .unwrap_or_else(|| panic!("{} not listed:\n{stdout}", path.display()))
    };
    // SimDevice: device id 77, boot 11, firmware 1.2.3.
    let tape = row(&dev.port);
    assert!(tape.contains(" pty "), "{tape}");
    assert!(
        tape.contains("answered: tape 000000000000004d, boot 11, firmware 1.2.3, protocol"),
        "{tape}"
    );
    assert!(
        row(&silent.path).contains("no: no answer within 300 ms"),
        "{stdout}"
    );
    assert!(
        stdout.contains(&format!(
            "One tape station answered: `tapeshape station` connects to {} by itself.",
            dev.port.display()
        )),
        "{stdout}"
    );
}

/// A port this user may not open: `tapeshape ports` says so and what to do
/// (join the port's group), and probes nothing else for it. As root (CI,
/// containers) the command runs as `nobody` through `setpriv`, since root
/// opens any mode; otherwise the pty is made unreadable to its owner.
#[test]
fn a_port_this_user_may_not_open_says_to_join_its_group() {
    use std::os::unix::fs::PermissionsExt as _;
    let rt = tokio::runtime::Runtime::new().unwrap();
    let silent = rt.block_on(async { silent_pty() });
    let root = rustix::process::geteuid().is_root();
    let tmp = tempfile::tempdir().unwrap();
    // The data directory must be usable by `nobody` too.
    std::fs::set_permissions(tmp.path(), std::fs::Permissions::from_mode(0o777)).unwrap();
    let mode = if root { 0o600 } else { 0o000 };
    std::fs::set_permissions(&silent.path, std::fs::Permissions::from_mode(mode)).unwrap();
    let mut cmd = if root {
        if std::process::Command::new("setpriv")
            .arg("--version")
            .output()
            .is_err()
        {
            if std::env::var_os("CI").is_some() {
                panic!("setpriv (util-linux) is missing: .ci/run installs it");
            }
            eprintln!("skipped: running as root without setpriv");
            return;
        }
        let mut c = std::process::Command::new("setpriv");
        c.args(["--reuid=65534", "--regid=65534", "--clear-groups"])
            .arg(env!("CARGO_BIN_EXE_tapeshape"));
        c
    } else {
        std::process::Command::new(env!("CARGO_BIN_EXE_tapeshape"))
    };
    let out = cmd
        .args(["ports", "--timeout-ms", "300", "--also"])
        .arg(&silent.path)
        .env("TAPESHAPE_DATA_DIR", tmp.path())
        .env("LC_ALL", "C")
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{stdout}\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let row = stdout
        .lines()
        .find(|l| l.starts_with(&silent.path.display().to_string()))
        .unwrap_or_else(|| panic!("{} not listed:\n{stdout}", silent.path.display()));
    assert!(
        row.contains("no: permission denied: add this user to the port's group")
            && row.contains("usermod -aG dialout"),
        "{row}"
    );
    assert!(stdout.contains("No tape station answered"), "{stdout}");
}
