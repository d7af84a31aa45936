//! The head office's pages in a real browser: headless Chromium (Debian's
//! `chromium`) loads a session's page from a hub on a throwaway PostgreSQL
//! with a user's password, and the screenshot shows the body drawn by the
//! vendored three.js viewer (its pixels counted); without the password no
//! page, body or script is served.
//!
//! Chromium missing: SKIPPED outside CI, a failure in CI (`.ci/run`
//! installs it), as for PostgreSQL.

mod common;

use std::path::Path;
use std::process::Command;

use common::{post, TestHub};
use tapeshape_hub_api::{encode_glb, Consent, Event, EventBody, Source, SyncRequest, SYNC_PATH};

const CHROMIUM: &str = "/usr/bin/chromium";
const USER: &str = "head-office";
const PASSWORD: &str = "correct horse battery staple";

fn chromium_or_skip(test: &str) -> bool {
    if Path::new(CHROMIUM).is_file() {
        return true;
    }
    assert!(
        std::env::var_os("CI").is_none(),
        "{test}: {CHROMIUM} is missing, and CI is set: CI must install it (apt-get install -y chromium)"
    );
    eprintln!("\n*** SKIPPED {test}: {CHROMIUM} is missing (apt-get install -y chromium) ***\n");
    false
}

/// Headless Chromium on `url`: a screenshot (`png`), or the page's DOM
/// after its scripts ran (`None`).
fn chromium(url: &str, png: Option<&Path>, profile: &Path) -> String {
    // Under coreutils' `timeout`: a browser that hangs fails the test
    // instead of holding CI (a run takes a few seconds).
    let mut cmd = Command::new("timeout");
    cmd.args(["--kill-after=10", "180", CHROMIUM]);
    cmd.args([
        "--headless",
        "--no-sandbox",
        "--disable-gpu",
        // WebGL on the CPU (SwiftShader), opted into for this page only.
        "--enable-unsafe-swiftshader",
        "--disable-background-networking",
        "--disable-component-update",
        "--disable-sync",
        "--no-first-run",
        "--hide-scrollbars",
        "--window-size=800,1400",
        // Time for the module scripts, the GLB and the first frame.
        "--virtual-time-budget=20000",
        "--enable-logging=stderr",
    ])
    .arg(format!("--user-data-dir={}", profile.display()));
    match png {
        Some(p) => cmd.arg(format!("--screenshot={}", p.display())),
        None => cmd.arg("--dump-dom"),
    };
    cmd.arg(url);
    let out = cmd.output().expect("running chromium");
    assert_ne!(
        out.status.code(),
        Some(124),
        "chromium ran for 3 minutes on {url} and was stopped"
    );
    if std::env::var_os("TAPESHAPE_CHROMIUM_LOG").is_some() {
        eprintln!("{}", String::from_utf8_lossy(&out.stderr));
    }
    String::from_utf8_lossy(&out.stdout).into_owned()
}

/// Pixels of the body's colour in a screenshot: the viewer's blue
/// (0x2f6fd0), lit and shaded, is far more blue than green and more green
/// than red; the page's blue links (and their anti-aliased edges) have as
/// much green as red, and the rest is grey or white.
fn body_pixels(png: &Path) -> usize {
    let img = image::open(png)
        .unwrap_or_else(|e| panic!("no screenshot {}: {e}", png.display()))
        .to_rgb8();
    img.pixels()
        .filter(|p| {
            let [r, g, b] = p.0;
            let (r, g, b) = (i32::from(r), i32::from(g), i32::from(b));
            b > 90 && b > g + 40 && g > r + 25
        })
        .count()
}

fn sync(hub: &TestHub, token: &str, events: Vec<Event>) {
    let body = serde_json::to_vec(&SyncRequest {
        station: "store-a".into(),
        events,
        erasures_done: vec![],
    })
    .unwrap();
    let (status, text) = post(&format!("{}{SYNC_PATH}", hub.base), Some(token), &body);
    assert_eq!(status, 200, "{text}");
}

#[test]
fn the_session_page_draws_the_body_and_needs_the_password() {
    let test = "the_session_page_draws_the_body_and_needs_the_password";
    if !chromium_or_skip(test) {
        return;
    }
    let Some(hub) = TestHub::start(test) else {
        return;
    };
    hub.rt.block_on(hub.db.add_user(USER, PASSWORD)).unwrap();
    let token = hub.station("store-a");
    let body = tapeshape_body::BodyModel::shared().unwrap().template();
    let glb = tapeshape_mesh::io::glb_bytes(&body, "body").unwrap();
    let created = |seq, session| Event {
        seq,
        at_ms: 1_700_000_000_000,
        body: EventBody::Created {
            session,
            customer: "c-page01".into(),
            set: Some("quick".into()),
            notes: Some("sex: female".into()),
            consent: Some(Consent::Keep),
            careful: false,
            created_at_ms: 1_700_000_000_000,
        },
    };
    let report = serde_json::json!({
        "measurements": [{"name": "chest", "target_mm": 982.0, "achieved_mm": 981.4}],
        "measured_not_given": [["waist", 801.2]],
    });
    sync(
        &hub,
        &token,
        vec![
            created(1, 1),
            Event {
                seq: 2,
                at_ms: 1_700_000_001_000,
                body: EventBody::ReadingStored {
                    session: 1,
                    reading: 1,
                    measurement: "chest".into(),
                    value_tenth_mm: 9_820,
                    source: Source::Keyboard,
                    received_at_ms: 1_700_000_001_000,
                    supersedes: None,
                },
            },
            Event {
                seq: 3,
                at_ms: 1_700_000_002_000,
                body: EventBody::EstimateStored {
                    session: 1,
                    made_at_ms: 1_700_000_002_000,
                    model_source: "test model".into(),
                    readings: vec![("chest".into(), 9_820)],
                    report_json: report.to_string(),
                    glb_base64: Some(encode_glb(&glb)),
                },
            },
            // A session without an estimate: no body on its page.
            created(4, 2),
        ],
    );
    let base = hub.base.clone();
    let page = format!("{base}/stores/store-a/sessions/1");
    let with_password = page.replacen(
        "http://",
        &format!("http://{USER}:{}@", PASSWORD.replace(' ', "%20")),
        1,
    );

    // Without the password (or with a wrong one) nothing is served.
    let agent = common::agent();
    for path in [
        "/",
        "/stores/store-a",
        "/stores/store-a/sessions/1",
        "/stores/store-a/sessions/1/body.glb",
        "/static/three/three.module.js",
    ] {
        let r = agent.get(format!("{base}{path}")).call().unwrap();
        assert_eq!(r.status(), 401, "{path}");
        assert!(r.headers().get("www-authenticate").is_some(), "{path}");
        let wrong = agent
            .get(format!("{base}{path}"))
            .header("Authorization", "Basic aGVhZC1vZmZpY2U6d3Jvbmc=")
            .call()
            .unwrap();
        assert_eq!(wrong.status(), 401, "{path} with a wrong password");
    }

    let dir = tempfile::tempdir().unwrap();
    // With the password: the page, its readings and sizes, the body drawn.
    let dom = chromium(&with_password, None, &dir.path().join("p1"));
    assert!(dom.contains("c-page01") && dom.contains("98.2 cm"), "{dom}");
    assert!(
        dom.contains("id=\"sizes\"") && dom.contains("waist"),
        "{dom}"
    );
    assert!(
        dom.contains("data-body=\"drawn\""),
        "the viewer did not draw: {dom}"
    );
    let shot = dir.path().join("body.png");
    chromium(&with_password, Some(&shot), &dir.path().join("p2"));
    let drawn = body_pixels(&shot);
    // The canvas is 480 x 640; a standing body fills a good part of it.
    assert!(
        drawn > 15_000,
        "only {drawn} body-coloured pixels in the screenshot {}",
        shot.display()
    );

    // Controls: the session without an estimate, and the page without the
    // password, have no body pixels.
    let no_body = dir.path().join("no-body.png");
    chromium(
        &with_password.replace("/sessions/1", "/sessions/2"),
        Some(&no_body),
        &dir.path().join("p3"),
    );
    // Without the password Chromium gets the 401 (it would ask for the
    // password; headless, it draws no page and takes no screenshot).
    let refused = dir.path().join("refused.png");
    chromium(&page, Some(&refused), &dir.path().join("p4"));
    let dom = chromium(&page, None, &dir.path().join("p5"));
    assert!(
        !dom.contains("c-page01") && !dom.contains("viewer"),
        "{dom}"
    );
    // TAPESHAPE_SHOTS_DIR=DIR keeps the screenshots (to look at them).
    if let Some(keep) = std::env::var_os("TAPESHAPE_SHOTS_DIR") {
        for p in [&shot, &no_body, &refused] {
            let _ = std::fs::copy(p, Path::new(&keep).join(p.file_name().unwrap()));
        }
    }
    let without_estimate = body_pixels(&no_body);
    assert!(
        without_estimate < 100,
        "no estimate: {without_estimate} body-coloured pixels"
    );
    let without_password = if refused.exists() {
        body_pixels(&refused)
    } else {
        0
    };
    assert!(
        without_password < 100,
        "no password: {without_password} body-coloured pixels"
    );
    eprintln!(
        "body pixels: {drawn} with the password; {without_estimate} on a session without \
         an estimate; {without_password} without the password (screenshot taken: {})",
        refused.exists()
    );
}
