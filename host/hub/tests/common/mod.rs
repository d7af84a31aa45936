//! A hub served in-process on a throwaway PostgreSQL cluster, and a small
//! blocking HTTP client for the tests.

#![allow(dead_code)]

use std::time::Duration;

use tapeshape_hub::pgtest::PgCluster;
use tapeshape_hub::{Db, DbTarget, ServeConfig};

/// A running hub: its cluster, its runtime, its address.
pub struct TestHub {
    pub cluster: PgCluster,
    pub rt: tokio::runtime::Runtime,
    pub db: Db,
    pub base: String,
    stop: Option<tokio::sync::oneshot::Sender<()>>,
}

impl TestHub {
    /// Starts a cluster and a hub on a free port (`None`: PostgreSQL is
    /// missing and this is not CI: the test is skipped).
    pub fn start(test: &str) -> Option<Self> {
        if !tapeshape_hub::pgtest::available_or_skip(test) {
            return None;
        }
        let cluster = PgCluster::start().expect("starting a throwaway PostgreSQL");
        let rt = tokio::runtime::Builder::new_multi_thread()
            .worker_threads(2)
            .enable_all()
            .build()
            .unwrap();
        let db = Db::new(DbTarget::parse(&cluster.url()).unwrap(), 8).unwrap();
        rt.block_on(db.migrate()).expect("migrating");
        let listener = std::net::TcpListener::bind("127.0.0.1:0").unwrap();
        let base = format!("http://{}", listener.local_addr().unwrap());
        let (tx, rx) = tokio::sync::oneshot::channel::<()>();
        let config = ServeConfig {
            listen: listener.local_addr().unwrap(),
            tls: None,
            retain_days: None,
            purge_every: Duration::from_secs(3600),
        };
        let server_db = db.clone();
        rt.spawn(async move {
            let stop = async move {
                let _ = rx.await;
            };
            if let Err(e) = tapeshape_hub::serve_listener(server_db, listener, config, stop).await {
                eprintln!("hub stopped: {e:#}");
            }
        });
        let hub = Self {
            cluster,
            rt,
            db,
            base,
            stop: Some(tx),
        };
        let agent = agent();
        for _ in 0..100 {
            if let Ok(r) = agent.get(format!("{}/healthz", hub.base)).call() {
                if r.status() == 200 {
                    return Some(hub);
                }
            }
            std::thread::sleep(Duration::from_millis(50));
        }
        panic!("the hub did not come up");
    }

    /// A station's token (registered now).
    pub fn station(&self, name: &str) -> String {
        self.rt
            .block_on(self.db.add_station(name, false))
            .unwrap()
            .expose()
    }

    /// One SQL count.
    pub fn count(&self, sql: &str) -> i64 {
        self.rt.block_on(async {
            let c = self.db.client().await.unwrap();
            c.query_one(sql, &[]).await.unwrap().get::<_, i64>(0)
        })
    }
}

impl Drop for TestHub {
    fn drop(&mut self) {
        if let Some(tx) = self.stop.take() {
            let _ = tx.send(());
        }
    }
}

/// A client that returns 4xx/5xx answers instead of erring on them.
pub fn agent() -> ureq::Agent {
    ureq::Agent::config_builder()
        .http_status_as_error(false)
        .timeout_global(Some(Duration::from_secs(30)))
        .build()
        .into()
}

/// POSTs `body` with `token` (if any): (status, body text).
pub fn post(url: &str, token: Option<&str>, body: &[u8]) -> (u16, String) {
    let mut req = agent().post(url).header("Content-Type", "application/json");
    if let Some(t) = token {
        req = req.header("Authorization", &format!("Bearer {t}"));
    }
    let mut r = req.send(body).expect("the hub answers");
    let status = r.status().as_u16();
    (status, r.body_mut().read_to_string().unwrap_or_default())
}
