//! The README's "A hub and two stations locally", command for command, with
//! the real `tapeshape` binary: a hub on a throwaway PostgreSQL (its own
//! port instead of 5433, a free port instead of 8750), two stores' tokens
//! and a head-office user; store A measures a customer, store B finds them
//! at the hub and re-estimates from those readings, measures them too; the
//! customer is erased at A and is then gone at A, at the hub and at B; the
//! pages need the user's password.

use std::io::{BufRead as _, BufReader};
use std::path::Path;
use std::process::{Child, Command, Output, Stdio};

use tapeshape_hub::pgtest::{free_port, PgCluster};

struct Killed(Child);

impl Drop for Killed {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

fn run(bin: &Path, dir: &Path, db: &str, args: &[&str]) -> String {
    let out: Output = Command::new(bin)
        .args(args)
        .current_dir(dir)
        .env("TAPESHAPE_HUB_DATABASE", db)
        .env_remove("TAPESHAPE_DATA_DIR")
        .env_remove("TAPESHAPE_LOG")
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout).into_owned();
    assert!(
        out.status.success(),
        "tapeshape {args:?} failed:\n{stdout}\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    stdout
}

fn get(url: &str, auth: Option<(&str, &str)>) -> (u16, usize) {
    let agent: ureq::Agent = ureq::Agent::config_builder()
        .http_status_as_error(false)
        .build()
        .into();
    let mut req = agent.get(url);
    if let Some((user, password)) = auth {
        use base64::Engine as _;
        let basic = base64::engine::general_purpose::STANDARD.encode(format!("{user}:{password}"));
        req = req.header("Authorization", &format!("Basic {basic}"));
    }
    let mut r = req.call().unwrap();
    let status = r.status().as_u16();
    let len = r.body_mut().read_to_vec().map(|b| b.len()).unwrap_or(0);
    (status, len)
}

#[test]
fn the_readmes_hub_and_two_stations() {
    if !tapeshape_hub::pgtest::available_or_skip("the_readmes_hub_and_two_stations") {
        return;
    }
    let bin = tapeshape_tests::tapeshape_binary();
    let cluster = PgCluster::start().expect("starting a throwaway PostgreSQL");
    let db = cluster.url();
    let work = tempfile::tempdir().unwrap();
    let dir = work.path();
    let t = |args: &[&str]| run(&bin, dir, &db, args);

    t(&["hub", "add-station", "store-a", "--token-file", "a.token"]);
    t(&["hub", "add-station", "store-b", "--token-file", "b.token"]);
    let password = t(&["hub", "add-user", "head-office"]).trim().to_string();
    assert!(password.len() >= 12, "{password:?}");
    let port = free_port().unwrap();
    let mut hub = Command::new(&bin)
        .args(["hub", "--listen", &format!("127.0.0.1:{port}")])
        .current_dir(dir)
        .env("TAPESHAPE_HUB_DATABASE", &db)
        .stdout(Stdio::piped())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let mut line = String::new();
    BufReader::new(hub.stdout.take().unwrap())
        .read_line(&mut line)
        .unwrap();
    let _hub = Killed(hub);
    let url = format!("http://127.0.0.1:{port}");
    assert_eq!(line.trim(), format!("hub listening on {url}"));

    t(&[
        "--data-dir",
        "store-a",
        "demo",
        "--headless",
        "--hub",
        &url,
        "--station-token",
        "a.token",
    ]);
    let found = t(&[
        "--data-dir",
        "store-b",
        "customer",
        "lookup",
        "demo-1",
        "--hub",
        &url,
        "--station-token",
        "b.token",
        "--save",
        "looked-up",
    ]);
    assert!(found.contains("from the chain's hub"), "{found}");
    assert!(found.contains("store store-a  session 1"), "{found}");
    assert!(found.contains("9 readings, estimated"), "{found}");
    let saved = dir.join("looked-up/store-a-session1.json");
    let readings: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&saved).unwrap()).unwrap();
    assert_eq!(readings["unit"], "mm");
    assert_eq!(readings.as_object().unwrap().len(), 10, "{readings}");
    t(&[
        "predict",
        "--measurements",
        "looked-up/store-a-session1.json",
        "-o",
        "body.glb",
    ]);
    assert!(std::fs::metadata(dir.join("body.glb")).unwrap().len() > 100_000);

    t(&[
        "--data-dir",
        "store-b",
        "demo",
        "--headless",
        "--hub",
        &url,
        "--station-token",
        "b.token",
    ]);
    let stations = t(&["hub", "stations"]);
    for s in ["store-a", "store-b"] {
        let row = stations.lines().find(|l| l.starts_with(s)).unwrap();
        let cols: Vec<&str> = row.split_whitespace().collect();
        assert_eq!(&cols[2..4], ["1", "9"], "{stations}");
    }
    // The pages: none without the password; the session's body with it.
    assert_eq!(get(&format!("{url}/"), None).0, 401);
    let (status, len) = get(
        &format!("{url}/stores/store-b/sessions/1/body.glb"),
        Some(("head-office", &password)),
    );
    assert_eq!(status, 200);
    assert!(len > 100_000, "{len}");

    for store in ["store-a", "store-b"] {
        let list = t(&["--data-dir", store, "sessions"]);
        assert!(list.contains("demo-1"), "{store}: {list}");
    }
    t(&[
        "--data-dir",
        "store-a",
        "customer",
        "erase",
        "demo-1",
        "--yes",
    ]);
    let a = t(&[
        "--data-dir",
        "store-a",
        "sync",
        "--hub",
        &url,
        "--station-token",
        "a.token",
    ]);
    assert!(a.contains("carried out here: 0"), "{a}");
    let b = t(&[
        "--data-dir",
        "store-b",
        "sync",
        "--hub",
        &url,
        "--station-token",
        "b.token",
    ]);
    assert!(b.contains("carried out here: 1"), "{b}");
    for store in ["store-a", "store-b"] {
        let list = t(&["--data-dir", store, "sessions"]);
        assert!(!list.contains("demo-1"), "{store}: {list}");
    }
    let export: serde_json::Value =
        serde_json::from_str(&t(&["hub", "customer", "export", "demo-1"])).unwrap();
    assert_eq!(export["sessions"].as_array().unwrap().len(), 0, "{export}");
    assert_eq!(
        export["earlier_erasures"][0]["origin"], "store-a",
        "{export}"
    );
    let stations = t(&["hub", "stations"]);
    assert!(
        stations
            .lines()
            .skip(1)
            .all(|l| l.split_whitespace().nth(2) == Some("0")),
        "{stations}"
    );
}
