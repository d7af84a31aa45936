//! What the `tapeshape` program writes that holds a customer's data (the
//! store, the exports of a body, a customer's export) is readable by its
//! owner only, whatever the caller's umask; and the station's token and the
//! hub's database password never appear in what the program prints, even
//! at the most verbose log level, while the token does reach the hub.
//!
//! The kiosk interface's log file (`DATA_DIR/tapeshape.log`, written only
//! while the interface runs in a terminal) is checked in the real terminal
//! walk-through, `scripts/tmux-demo.sh` (step 15).

mod common;

use std::io::{Read as _, Write as _};
use std::net::TcpListener;
use std::os::unix::fs::PermissionsExt as _;
use std::path::{Path, PathBuf};
use std::process::Output;
use std::sync::{Arc, Mutex};

use common::tapeshape;

fn run(data: &Path, args: &[&str]) -> Output {
    let out = tapeshape(data, args).output().unwrap();
    assert!(
        out.status.success(),
        "tapeshape {args:?} failed:\n{}\n{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    out
}

/// Every file and folder below `root`, with its permission bits.
fn modes(root: &Path) -> Vec<(PathBuf, bool, u32)> {
    let mut out = Vec::new();
    let mut todo = vec![root.to_path_buf()];
    while let Some(dir) = todo.pop() {
        for e in std::fs::read_dir(&dir).unwrap() {
            let e = e.unwrap();
            let m = std::fs::symlink_metadata(e.path()).unwrap();
            if m.is_dir() {
                todo.push(e.path());
            }
            out.push((e.path(), m.is_dir(), m.permissions().mode() & 0o777));
        }
    }
    out
}

#[test]
fn what_holds_customer_data_is_owner_only() {
    let tmp = tempfile::tempdir().unwrap();
    // The test's own folder is world-readable: only the program's modes
    // can make what it writes owner-only.
    std::fs::set_permissions(tmp.path(), std::fs::Permissions::from_mode(0o755)).unwrap();
    let root = tmp.path().join("written");
    std::fs::create_dir(&root).unwrap();
    std::fs::set_permissions(&root, std::fs::Permissions::from_mode(0o755)).unwrap();
    let data = root.join("data");
    let p = |name: &str| root.join(name).to_str().unwrap().to_string();
    run(
        &data,
        &[
            "demo",
            "--seed",
            "3",
            "--speedup",
            "20",
            "--headless",
            "--export-dir",
            &p("exports"),
        ],
    );
    run(
        &data,
        &[
            "session",
            "export",
            "1",
            "--dir",
            &p("again/bodies"),
            "--format",
            "glb,obj,ply",
        ],
    );
    // The customer id from the listing (the demo names its customer).
    let list = String::from_utf8(run(&data, &["sessions"]).stdout).unwrap();
    let customer = list
        .lines()
        .nth(1)
        .and_then(|l| l.split_whitespace().nth(2))
        .unwrap_or_else(|| panic!("no session in the listing:\n{list}"))
        .to_string();
    run(&data, &["customer", "export", &customer]);
    run(
        &data,
        &[
            "customer",
            "export",
            &customer,
            "--out",
            &p("rights/c.json"),
        ],
    );
    let all = modes(&root);
    let files: Vec<_> = all.iter().filter(|(_, dir, _)| !dir).collect();
    // The store, four files of the demo's export, three of the session's,
    // two customer exports.
    assert!(files.len() >= 10, "{all:?}");
    for want in [
        data.join("tapeshape.sqlite3"),
        root.join("rights/c.json"),
        root.join("again/bodies"),
    ] {
        assert!(
            all.iter().any(|(p, _, _)| *p == want),
            "{} was not written: {all:?}",
            want.display()
        );
    }
    assert!(
        files
            .iter()
            .any(|(p, _, _)| p.starts_with(data.join("exports"))
                && p.extension().is_some_and(|e| e == "json")),
        "no customer export under DATA_DIR/exports: {all:?}"
    );
    for (path, dir, mode) in &all {
        let want = if *dir { 0o700 } else { 0o600 };
        assert_eq!(*mode, want, "{} is {mode:o}, not {want:o}", path.display());
    }
}

/// A hub that refuses every request with 401, keeping what it was sent.
fn refusing_hub() -> (String, Arc<Mutex<Vec<u8>>>) {
    let listener = TcpListener::bind("127.0.0.1:0").unwrap();
    let url = format!("http://{}", listener.local_addr().unwrap());
    let seen = Arc::new(Mutex::new(Vec::new()));
    let keep = seen.clone();
    std::thread::spawn(move || {
        for conn in listener.incoming() {
            let Ok(mut conn) = conn else { continue };
            let mut request = Vec::new();
            let mut buf = [0u8; 4096];
            // The head, then the body its Content-Length announces.
            let body_len = loop {
                let Ok(n) = conn.read(&mut buf) else {
                    break None;
                };
                if n == 0 {
                    break None;
                }
                request.extend_from_slice(&buf[..n]);
                let text = String::from_utf8_lossy(&request).to_string();
                if let Some(end) = text.find("\r\n\r\n") {
                    let len = text[..end]
                        .lines()
                        .find_map(|l| {
                            let (k, v) = l.split_once(':')?;
                            k.eq_ignore_ascii_case("content-length")
                                .then(|| v.trim().parse::<usize>().ok())?
                        })
                        .unwrap_or(0);
                    break Some(end + 4 + len);
                }
            };
            while body_len.is_some_and(|l| request.len() < l) {
                match conn.read(&mut buf) {
                    Ok(0) | Err(_) => break,
                    Ok(n) => request.extend_from_slice(&buf[..n]),
                }
            }
            keep.lock().unwrap().extend_from_slice(&request);
            let body = br#"{"error":"no valid station token"}"#;
            let _ = write!(
                conn,
                "HTTP/1.1 401 Unauthorized\r\nContent-Type: application/json\r\n\
                 Content-Length: {}\r\nConnection: close\r\n\r\n",
                body.len()
            );
            let _ = conn.write_all(body);
        }
    });
    (url, seen)
}

#[test]
fn the_token_and_the_database_password_stay_out_of_output_and_logs() {
    let tmp = tempfile::tempdir().unwrap();
    let data = tmp.path().join("data");
    let secret = "5e".repeat(32);
    let token = format!("store-a.{secret}");
    let token_file = tmp.path().join("station.token");
    std::fs::write(&token_file, format!("{token}\n")).unwrap();
    let token_file = token_file.to_str().unwrap().to_string();
    let (hub, seen) = refusing_hub();
    let mut printed = String::new();
    let mut keep = |out: &Output| {
        printed.push_str(&String::from_utf8_lossy(&out.stdout));
        printed.push_str(&String::from_utf8_lossy(&out.stderr));
    };
    // A session synced to a hub that refuses the token, logging everything.
    let out = tapeshape(
        &data,
        &[
            "-vvv",
            "demo",
            "--headless",
            "--speedup",
            "20",
            "--hub",
            &hub,
            "--station-token",
            &token_file,
        ],
    )
    .output()
    .unwrap();
    keep(&out);
    assert!(out.status.success(), "{printed}");
    // The lookup at that hub: refused, so this station's own history, saying why.
    let out = tapeshape(
        &data,
        &[
            "-vvv",
            "customer",
            "lookup",
            "demo-1",
            "--hub",
            &hub,
            "--station-token",
            &token_file,
        ],
    )
    .output()
    .unwrap();
    keep(&out);
    let said = String::from_utf8_lossy(&out.stdout);
    assert!(
        said.contains("this station's own history only") && said.contains("401"),
        "{said}"
    );
    // A token file that holds something else is refused without showing it.
    let bad = tmp.path().join("bad.token");
    std::fs::write(&bad, format!("store-a.{}", &secret[..40])).unwrap();
    let out = tapeshape(
        &data,
        &[
            "customer",
            "lookup",
            "demo-1",
            "--hub",
            &hub,
            "--station-token",
            bad.to_str().unwrap(),
        ],
    )
    .output()
    .unwrap();
    keep(&out);
    assert!(!out.status.success());
    assert!(
        String::from_utf8_lossy(&out.stderr).contains("holds no station token"),
        "{printed}"
    );
    // The hub's database password, in a URL the hub cannot connect to, and
    // in one it cannot parse (the hub's commands: feature `hub`).
    let password = "pg-Pa55word-never-shown";
    let urls = if cfg!(feature = "hub") {
        vec![
            (
                "unreachable",
                format!("postgres://hub:{password}@127.0.0.1:1/chain"),
            ),
            ("malformed", format!("postgres://hub:{password}@[::1/chain")),
        ]
    } else {
        Vec::new()
    };
    for (what, url) in urls {
        for args in [
            vec!["-vvv", "hub", "--listen", "127.0.0.1:0"],
            vec!["-vvv", "hub", "add-station", "store-b"],
        ] {
            let out = tapeshape(&data, &args)
                .env("TAPESHAPE_HUB_DATABASE", &url)
                .output()
                .unwrap();
            assert!(!out.status.success(), "{what} {args:?}");
            keep(&out);
            let err = String::from_utf8_lossy(&out.stderr);
            assert!(err.contains("database"), "{what} {args:?}: {err}");
        }
        let out = tapeshape(&data, &["hub", "--database", &url, "stations"])
            .output()
            .unwrap();
        assert!(!out.status.success());
        keep(&out);
    }
    // The token did reach the hub (so it was there to leak)...
    let sent = String::from_utf8_lossy(&seen.lock().unwrap()).to_string();
    assert!(
        sent.contains(&format!("Bearer {token}")),
        "the station never sent its token"
    );
    // ...and nothing the program printed holds it, its secret half, or the
    // password.
    for s in [token.as_str(), secret.as_str(), &secret[..16], password] {
        assert!(!printed.contains(s), "{s:?} was printed:\n{printed}");
    }
}
