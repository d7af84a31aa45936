//! The hub over TLS (`--tls-cert`, `--tls-key`): a station that trusts the
//! hub's CA (`--hub-ca`) syncs its sessions through HTTPS; one that does not
//! trust it refuses the hub (and sends nothing, its token included); a
//! plain-HTTP request to the TLS port gets no answer.
//!
//! The certificates are made for the test with the `openssl` command (a CA,
//! and the hub's certificate for 127.0.0.1 signed by it). Without PostgreSQL
//! or openssl: SKIPPED outside CI, a failure in CI (`.ci/run` installs both).

use std::path::Path;
use std::process::Command;
use std::time::Duration;

use tapeshape::session::Sessions;
use tapeshape::sync::{GlbSource, HubClient, SyncConfig};
use tapeshape_hub::pgtest::PgCluster;
use tapeshape_hub::{Db, DbTarget, ServeConfig};

fn openssl(dir: &Path, args: &[&str]) {
    let out = Command::new("openssl")
        .args(args)
        .current_dir(dir)
        .output()
        .expect("running openssl");
    assert!(
        out.status.success(),
        "openssl {args:?}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
}

/// A CA (`ca.pem`) and the hub's certificate for 127.0.0.1 signed by it
/// (`hub.pem`, `hub.key`).
fn certificates(dir: &Path) {
    let ec = [
        "-newkey",
        "ec",
        "-pkeyopt",
        "ec_paramgen_curve:prime256v1",
        "-nodes",
    ];
    let mut ca = vec!["req", "-x509"];
    ca.extend(ec);
    ca.extend([
        "-keyout",
        "ca.key",
        "-out",
        "ca.pem",
        "-days",
        "2",
        "-subj",
        "/CN=tapeshape test CA",
    ]);
    openssl(dir, &ca);
    let mut csr = vec!["req"];
    csr.extend(ec);
    csr.extend([
        "-keyout",
        "hub.key",
        "-out",
        "hub.csr",
        "-subj",
        "/CN=127.0.0.1",
    ]);
    openssl(dir, &csr);
    std::fs::write(
        dir.join("ext"),
        "subjectAltName=IP:127.0.0.1\nbasicConstraints=CA:FALSE\nextendedKeyUsage=serverAuth\n",
    )
    .unwrap();
    openssl(
        dir,
        &[
            "x509",
            "-req",
            "-in",
            "hub.csr",
            "-CA",
            "ca.pem",
            "-CAkey",
            "ca.key",
            "-CAcreateserial",
            "-out",
            "hub.pem",
            "-days",
            "2",
            "-extfile",
            "ext",
        ],
    );
}

fn openssl_or_skip(test: &str) -> bool {
    let found = Command::new("openssl")
        .arg("version")
        .output()
        .is_ok_and(|o| o.status.success());
    if found {
        return true;
    }
    assert!(
        std::env::var_os("CI").is_none(),
        "{test}: the openssl command is missing, and CI is set: CI must install it (apt-get install -y openssl)"
    );
    eprintln!(
        "\n*** SKIPPED {test}: the openssl command is missing (apt-get install -y openssl) ***\n"
    );
    false
}

#[test]
fn a_station_syncs_over_tls_only_to_a_hub_it_trusts() {
    let test = "a_station_syncs_over_tls_only_to_a_hub_it_trusts";
    if !tapeshape_hub::pgtest::available_or_skip(test) || !openssl_or_skip(test) {
        return;
    }
    let work = tempfile::tempdir().unwrap();
    certificates(work.path());
    let cluster = PgCluster::start().expect("starting a throwaway PostgreSQL");
    let rt = tokio::runtime::Builder::new_multi_thread()
        .worker_threads(2)
        .enable_all()
        .build()
        .unwrap();
    let db = Db::new(DbTarget::parse(&cluster.url()).unwrap(), 4).unwrap();
    rt.block_on(db.migrate()).unwrap();
    let token = rt.block_on(db.add_station("store-tls", false)).unwrap();
    let listener = std::net::TcpListener::bind("127.0.0.1:0").unwrap();
    let addr = listener.local_addr().unwrap();
    let config = ServeConfig {
        listen: addr,
        tls: Some((work.path().join("hub.pem"), work.path().join("hub.key"))),
        retain_days: None,
        purge_every: Duration::from_secs(3600),
    };
    let (stop_tx, stop_rx) = tokio::sync::oneshot::channel::<()>();
    let server_db = db.clone();
    rt.spawn(async move {
        let stop = async move {
            let _ = stop_rx.await;
        };
        if let Err(e) = tapeshape_hub::serve_listener(server_db, listener, config, stop).await {
            eprintln!("hub stopped: {e:#}");
        }
    });
    let url = format!("https://{addr}");
    let ca = std::fs::read(work.path().join("ca.pem")).unwrap();

    // Trusting the hub's CA: the token is good, through TLS.
    let mut trusting = SyncConfig::new(&url, token.clone()).unwrap();
    trusting.ca_pem = Some(ca);
    let mut who = Err(String::new());
    for _ in 0..100 {
        who = HubClient::new(&trusting)
            .unwrap()
            .whoami()
            .map_err(|e| e.to_string());
        if who.is_ok() {
            break;
        }
        std::thread::sleep(Duration::from_millis(50));
    }
    assert_eq!(who.as_deref(), Ok("store-tls"));

    // The public web's roots only: the hub's certificate is refused.
    let public = SyncConfig::new(&url, token.clone()).unwrap();
    let e = HubClient::new(&public).unwrap().whoami().unwrap_err();
    assert!(e.to_string().contains("certificate"), "{e}");

    // Plain HTTP to the TLS port: no HTTP answer.
    let plain = SyncConfig::new(&format!("http://{addr}"), token.clone()).unwrap();
    assert!(HubClient::new(&plain).unwrap().whoami().is_err());

    // A session synced through TLS.
    let station = Sessions::open(&work.path().join("station")).unwrap();
    let v = station.start("c-tls001", "quick", None).unwrap();
    for (k, name) in ["stature", "chest", "waist"].iter().enumerate() {
        station
            .capture_keyboard(v.id, name, 9_000 + k as u32)
            .unwrap();
    }
    let no_body: GlbSource = std::sync::Arc::new(|_| None);
    let sync = tapeshape::sync::spawn(station.clone(), trusting, no_body).unwrap();
    assert!(
        sync.wait_synced(Duration::from_secs(60)),
        "{:?}",
        sync.status()
    );
    sync.stop();
    let readings: i64 = rt.block_on(async {
        let c = db.client().await.unwrap();
        c.query_one(
            "SELECT COUNT(*) FROM readings WHERE station = 'store-tls'",
            &[],
        )
        .await
        .unwrap()
        .get(0)
    });
    assert_eq!(readings, 3);
    let _ = stop_tx.send(());
}
