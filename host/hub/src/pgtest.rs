//! A throwaway PostgreSQL cluster: `initdb` and `pg_ctl` in a temporary
//! folder, on a free loopback port, stopped (and deleted) when dropped,
//! also when the test using it fails. For the hub's tests, the chain's
//! end-to-end test and the benchmark; no test touches a PostgreSQL it did
//! not start.
//!
//! Why not a system service: tests must not depend on (or change) a
//! database someone else runs, and each needs a fresh one. `initdb`
//! refuses to run as root, and CI runs as root: then the cluster runs as
//! the `postgres` user the Debian package creates (through `runuser`), in
//! a folder handed to that user. Debian puts the server's programs in
//! `/usr/lib/postgresql/<version>/bin`, outside `PATH`.
//!
//! Where PostgreSQL is not installed, [`available_or_skip`] says SKIPPED
//! outside CI and fails in CI (the `CI` variable), as the QEMU tests do.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::time::Duration;

/// Why a cluster could not be started or driven.
#[derive(Debug, thiserror::Error)]
pub enum PgError {
    /// No `initdb` was found.
    #[error(
        "PostgreSQL's server programs (initdb, pg_ctl) are not installed: \
         apt-get install -y postgresql"
    )]
    NotInstalled,
    /// A file or a command failed.
    #[error("{what}: {source}")]
    Io {
        /// What was done.
        what: String,
        /// Why it failed.
        #[source]
        source: std::io::Error,
    },
    /// A PostgreSQL program failed.
    #[error("{what} failed ({status}): {output}")]
    Command {
        /// The program and what it did.
        what: String,
        /// Its exit status.
        status: String,
        /// Its output (and the server log's end).
        output: String,
    },
}

/// The folder holding `initdb` and `pg_ctl`: the newest
/// `/usr/lib/postgresql/<version>/bin`, else the one `initdb` on `PATH`
/// is in.
pub fn server_bin_dir() -> Option<PathBuf> {
    let mut versions: Vec<(u32, PathBuf)> = std::fs::read_dir("/usr/lib/postgresql")
        .ok()?
        .filter_map(|e| e.ok())
        .filter_map(|e| {
            let v: u32 = e.file_name().to_string_lossy().parse().ok()?;
            let bin = e.path().join("bin");
            bin.join("initdb").is_file().then_some((v, bin))
        })
        .collect();
    versions.sort();
    if let Some((_, bin)) = versions.pop() {
        return Some(bin);
    }
    let path = std::env::var_os("PATH")?;
    std::env::split_paths(&path).find(|d| d.join("initdb").is_file() && d.join("pg_ctl").is_file())
}

/// Is PostgreSQL installed? If not: in CI (the `CI` variable set) this
/// panics, so that a CI machine without it fails; elsewhere it prints
/// SKIPPED for `test` and returns `false`.
pub fn available_or_skip(test: &str) -> bool {
    if server_bin_dir().is_some() {
        return true;
    }
    assert!(
        std::env::var_os("CI").is_none(),
        "{test}: PostgreSQL is not installed, and CI is set: CI must install it \
         (apt-get install -y postgresql)"
    );
    eprintln!(
        "\n*** SKIPPED {test}: PostgreSQL is not installed (apt-get install -y postgresql) ***\n"
    );
    false
}

/// A running throwaway cluster. Dropping it stops the server and deletes
/// its folder.
#[derive(Debug)]
pub struct PgCluster {
    dir: tempfile::TempDir,
    bin: PathBuf,
    port: u16,
    password: String,
    run_as: Option<String>,
    stopped: bool,
}

const USER: &str = "tapeshape";

fn io(what: impl Into<String>) -> impl FnOnce(std::io::Error) -> PgError {
    let what = what.into();
    move |source| PgError::Io { what, source }
}

/// A free TCP port on 127.0.0.1 (bound and released: another program could
/// take it in between, which on a test machine does not happen in practice).
pub fn free_port() -> Result<u16, PgError> {
    let l = std::net::TcpListener::bind("127.0.0.1:0").map_err(io("finding a free port"))?;
    Ok(l.local_addr().map_err(io("finding a free port"))?.port())
}

fn ids_of(user: &str) -> Option<(u32, u32)> {
    let id = |flag: &str| -> Option<u32> {
        let out = Command::new("id").args([flag, user]).output().ok()?;
        String::from_utf8(out.stdout).ok()?.trim().parse().ok()
    };
    Some((id("-u")?, id("-g")?))
}

impl PgCluster {
    /// Creates and starts a cluster on a free port, with a superuser
    /// `tapeshape` whose password is random (password authentication over
    /// TCP, as a real hub would connect).
    pub fn start() -> Result<Self, PgError> {
        let bin = server_bin_dir().ok_or(PgError::NotInstalled)?;
        let dir = tempfile::Builder::new()
            .prefix("tapeshape-pg-")
            .tempdir()
            .map_err(io("creating the cluster's folder"))?;
        let root = rustix::process::geteuid().is_root();
        let run_as = root.then(|| "postgres".to_string());
        if let Some(user) = &run_as {
            let (uid, gid) = ids_of(user).ok_or_else(|| PgError::Command {
                what: format!("looking up the {user} user"),
                status: "no such user".into(),
                output: "running as root needs the postgres user the Debian package creates".into(),
            })?;
            rustix::fs::chown(
                dir.path(),
                Some(rustix::fs::Uid::from_raw(uid)),
                Some(rustix::fs::Gid::from_raw(gid)),
            )
            .map_err(|e| PgError::Io {
                what: "handing the cluster's folder to the postgres user".into(),
                source: e.into(),
            })?;
        }
        let mut pw = [0u8; 18];
        getrandom::fill(&mut pw).map_err(|e| PgError::Io {
            what: "making a password".into(),
            source: std::io::Error::other(e.to_string()),
        })?;
        let password: String = pw.iter().map(|b| format!("{b:02x}")).collect();
        let port = free_port()?;
        let mut cluster = Self {
            dir,
            bin,
            port,
            password,
            run_as,
            stopped: true,
        };
        let pwfile = cluster.dir.path().join("pw");
        std::fs::write(&pwfile, &cluster.password).map_err(io("writing the password file"))?;
        cluster.hand_over(&pwfile)?;
        let data = cluster.data_dir();
        cluster.run(
            "initdb",
            &[
                "-D",
                &data.to_string_lossy(),
                "-U",
                USER,
                &format!("--pwfile={}", pwfile.display()),
                "--auth-host=scram-sha-256",
                "--auth-local=trust",
                "-E",
                "UTF8",
                "--locale=C",
                "--no-sync",
            ],
        )?;
        let _ = std::fs::remove_file(&pwfile);
        let conf = format!(
            "listen_addresses = '127.0.0.1'\nport = {port}\nunix_socket_directories = '{}'\n\
             max_connections = 200\nlog_min_messages = warning\n",
            cluster.dir.path().display()
        );
        let conf_path = data.join("postgresql.auto.conf");
        std::fs::OpenOptions::new()
            .append(true)
            .open(&conf_path)
            .and_then(|mut f| std::io::Write::write_all(&mut f, conf.as_bytes()))
            .map_err(io("configuring the cluster"))?;
        cluster.pg_ctl(&["start", "-w", "-t", "60"])?;
        cluster.stopped = false;
        Ok(cluster)
    }

    fn data_dir(&self) -> PathBuf {
        self.dir.path().join("data")
    }

    fn log_path(&self) -> PathBuf {
        self.dir.path().join("server.log")
    }

    fn hand_over(&self, path: &Path) -> Result<(), PgError> {
        if let Some(user) = &self.run_as {
            if let Some((uid, gid)) = ids_of(user) {
                rustix::fs::chown(
                    path,
                    Some(rustix::fs::Uid::from_raw(uid)),
                    Some(rustix::fs::Gid::from_raw(gid)),
                )
                .map_err(|e| PgError::Io {
                    what: format!("handing {} to {user}", path.display()),
                    source: e.into(),
                })?;
            }
        }
        Ok(())
    }

    fn command(&self, program: &str) -> Command {
        let exe = self.bin.join(program);
        match &self.run_as {
            Some(user) => {
                let mut c = Command::new("runuser");
                c.args(["-u", user, "--"]).arg(exe);
                c
            }
            None => Command::new(exe),
        }
    }

    fn run(&self, program: &str, args: &[&str]) -> Result<Output, PgError> {
        let out = self
            .command(program)
            .args(args)
            .current_dir(self.dir.path())
            .env("LC_ALL", "C")
            .output()
            .map_err(io(format!("running {program}")))?;
        if !out.status.success() {
            let log = std::fs::read_to_string(self.log_path()).unwrap_or_default();
            let tail: String = log
                .lines()
                .rev()
                .take(30)
                .collect::<Vec<_>>()
                .into_iter()
                .rev()
                .collect::<Vec<_>>()
                .join("\n");
            return Err(PgError::Command {
                what: format!("{program} {}", args.first().unwrap_or(&"")),
                status: out.status.to_string(),
                output: format!(
                    "{}{}\nserver log:\n{tail}",
                    String::from_utf8_lossy(&out.stdout),
                    String::from_utf8_lossy(&out.stderr)
                ),
            });
        }
        Ok(out)
    }

    fn pg_ctl(&self, args: &[&str]) -> Result<(), PgError> {
        let data = self.data_dir().to_string_lossy().into_owned();
        let log = self.log_path().to_string_lossy().into_owned();
        let mut all = vec!["-D", &data, "-l", &log];
        all.extend_from_slice(args);
        self.run("pg_ctl", &all).map(|_| ())
    }

    /// The port it listens on (127.0.0.1).
    pub fn port(&self) -> u16 {
        self.port
    }

    /// The superuser's password (random; a secret the tests check never
    /// appears in logs).
    pub fn password(&self) -> &str {
        &self.password
    }

    /// A connection URL to database `postgres` as the superuser.
    pub fn url(&self) -> String {
        format!(
            "postgres://{USER}:{}@127.0.0.1:{}/postgres",
            self.password, self.port
        )
    }

    /// Creates database `name` (for a test that wants one of its own).
    pub fn create_database(&self, name: &str) -> Result<String, PgError> {
        let port = self.port.to_string();
        let sock = self.dir.path().to_string_lossy().into_owned();
        self.run("createdb", &["-h", &sock, "-p", &port, "-U", USER, name])?;
        Ok(format!(
            "postgres://{USER}:{}@127.0.0.1:{}/{name}",
            self.password, self.port
        ))
    }

    /// Restarts the server (fast shutdown: open connections are cut, as in
    /// a real restart), waiting until it accepts connections again.
    pub fn restart(&self) -> Result<(), PgError> {
        self.pg_ctl(&["restart", "-m", "fast", "-w", "-t", "60"])
    }

    /// Stops the server now (immediate: as if it crashed).
    pub fn stop(&mut self) -> Result<(), PgError> {
        if !self.stopped {
            self.stopped = true;
            self.pg_ctl(&["stop", "-m", "immediate", "-w", "-t", "30"])?;
        }
        Ok(())
    }

    /// Starts it again after [`PgCluster::stop`].
    pub fn start_again(&mut self) -> Result<(), PgError> {
        if self.stopped {
            self.pg_ctl(&["start", "-w", "-t", "60"])?;
            self.stopped = false;
        }
        Ok(())
    }

    /// Waits until `url` accepts a TCP connection (at most `timeout`).
    pub fn wait_ready(&self, timeout: Duration) -> bool {
        let until = std::time::Instant::now() + timeout;
        while std::time::Instant::now() < until {
            if std::net::TcpStream::connect(("127.0.0.1", self.port)).is_ok() {
                return true;
            }
            std::thread::sleep(Duration::from_millis(50));
        }
        false
    }
}

impl Drop for PgCluster {
    fn drop(&mut self) {
        if let Err(e) = self.stop() {
            eprintln!("stopping the throwaway PostgreSQL cluster: {e}");
        }
    }
}
