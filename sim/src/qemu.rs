//! The real `mps2-an386` board firmware, running under QEMU, as a simulated station's device.
//!
//! Why: the firmware logic is tested on the host through [`crate::harness`], but only the real
//! board binary shows that the UART drivers, the time driver and the executor carry that logic
//! correctly. QEMU's `mps2-an386` machine runs the very ELF that CI builds, with its two UARTs
//! on pseudo-terminals.
//!
//! Launching follows the board crate's contract, `firmware/boards/run-qemu.sh` (see its
//! header and `firmware/boards/README.md`): QEMU starts *paused* (`-S`), reports its two ptys
//! and a monitor socket in a state file; the caller opens both ports and only then sends
//! `cont`, because QEMU drops what the guest sends to a pty nobody has open. [`QemuBoard`]
//! runs that script (so the command line lives in one place), keeps QEMU's pid and kills QEMU
//! when dropped, so a failing test leaves no emulator behind.

use std::io::{self, Read, Write};
use std::os::unix::net::UnixStream;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

/// Errors starting or driving QEMU.
#[derive(Debug, thiserror::Error)]
pub enum QemuError {
    /// `qemu-system-arm` is not on the PATH.
    #[error(
        "qemu-system-arm not found on PATH; install it (Debian/Ubuntu: \
         apt-get install -y qemu-system-arm)"
    )]
    NotInstalled,
    /// Building the board firmware failed.
    #[error(
        "building the mps2-an386 firmware failed (cd firmware/boards && cargo build --release \
         -p tapeshape-board-mps2-an386; needs `rustup target add thumbv7em-none-eabihf`):\n{0}"
    )]
    Build(String),
    /// The launch script failed.
    #[error("run-qemu.sh failed: {0}")]
    Launch(String),
    /// The state file lacked a key.
    #[error("run-qemu.sh state file {file} has no {key}=...; the script and this crate disagree")]
    StateKey {
        /// The state file.
        file: PathBuf,
        /// The missing key.
        key: &'static str,
    },
    /// I/O error.
    #[error("QEMU I/O error while {what}: {source}")]
    Io {
        /// What was going on.
        what: &'static str,
        /// The error.
        source: io::Error,
    },
}

/// The board workspace folder (`firmware/boards`) of this repository.
pub fn boards_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../firmware/boards")
}

/// Path of the release ELF of the mps2-an386 firmware.
pub fn firmware_elf() -> PathBuf {
    boards_dir().join("target/thumbv7em-none-eabihf/release/tapeshape-mps2-an386")
}

/// Whether `qemu-system-arm` can be run.
pub fn qemu_installed() -> bool {
    Command::new("qemu-system-arm")
        .arg("--version")
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .status()
        .map(|s| s.success())
        .unwrap_or(false)
}

/// Whether a test that needs QEMU can run here, and what to say when it
/// cannot. With `qemu-system-arm` installed: `true`. Without it: a failure
/// (panic) when the `CI` environment variable is set, because CI must install
/// it (`.ci/run` does); otherwise a loud `SKIPPED` line on stderr and `false`,
/// so that a developer without QEMU can still run the rest of the tests.
pub fn available_or_skip(test: &str) -> bool {
    if qemu_installed() {
        return true;
    }
    assert!(
        std::env::var_os("CI").is_none(),
        "{test}: qemu-system-arm is not installed, and CI is set: CI must install it \
         (apt-get install -y qemu-system-arm)"
    );
    eprintln!(
        "\n*** SKIPPED {test}: qemu-system-arm is not installed \
         (apt-get install -y qemu-system-arm) ***\n"
    );
    false
}

/// Builds the release firmware (incremental: quick when nothing changed).
pub fn build_firmware() -> Result<PathBuf, QemuError> {
    let out = Command::new(std::env::var("CARGO").unwrap_or_else(|_| "cargo".into()))
        .args(["build", "--release", "-p", "tapeshape-board-mps2-an386"])
        .current_dir(boards_dir())
        // The host test's cargo settings must not leak into the cross build.
        .env_remove("CARGO_TARGET_DIR")
        .env_remove("CARGO_BUILD_TARGET")
        .env_remove("RUSTFLAGS")
        .env_remove("CARGO_ENCODED_RUSTFLAGS")
        .output()
        .map_err(|source| QemuError::Io {
            what: "running cargo build for the board",
            source,
        })?;
    if !out.status.success() {
        return Err(QemuError::Build(
            String::from_utf8_lossy(&out.stderr).into_owned(),
        ));
    }
    let elf = firmware_elf();
    if !elf.is_file() {
        return Err(QemuError::Build(format!(
            "cargo succeeded but {} is missing",
            elf.display()
        )));
    }
    Ok(elf)
}

/// A paused or running QEMU with the mps2-an386 firmware. Killed on drop.
#[derive(Debug)]
pub struct QemuBoard {
    /// UART0: write tape lines here.
    pub tape_pty: PathBuf,
    /// UART1: the firmware's host link.
    pub host_pty: PathBuf,
    /// QEMU's human monitor socket.
    pub monitor: PathBuf,
    /// QEMU's stderr log.
    pub log: PathBuf,
    /// The boot seed given to the board (its boot id derives from it).
    pub boot_seed: u32,
    pid: i32,
    _state_dir: tempfile::TempDir,
}

impl QemuBoard {
    /// Builds the firmware if needed and starts QEMU paused. Open [`QemuBoard::tape_pty`] and
    /// [`QemuBoard::host_pty`], then call [`QemuBoard::resume`].
    pub fn launch(boot_seed: u32) -> Result<Self, QemuError> {
        if !qemu_installed() {
            return Err(QemuError::NotInstalled);
        }
        let elf = build_firmware()?;
        let state_dir = tempfile::tempdir().map_err(|source| QemuError::Io {
            what: "creating a state folder",
            source,
        })?;
        let state = state_dir.path().join("qemu.env");
        let out = Command::new("bash")
            .arg(boards_dir().join("run-qemu.sh"))
            .arg("--no-build")
            .arg("--elf")
            .arg(&elf)
            .arg("--seed")
            .arg(format!("{boot_seed:#010x}"))
            .arg(&state)
            .env("TMPDIR", state_dir.path())
            .stdin(Stdio::null())
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .output()
            .map_err(|source| QemuError::Io {
                what: "running run-qemu.sh",
                source,
            })?;
        if !out.status.success() {
            return Err(QemuError::Launch(
                String::from_utf8_lossy(&out.stderr).into_owned(),
            ));
        }
        let text = std::fs::read_to_string(&state).map_err(|source| QemuError::Io {
            what: "reading the state file",
            source,
        })?;
        let get = |key: &'static str| -> Result<String, QemuError> {
            text.lines()
                .find_map(|l| l.strip_prefix(key)?.strip_prefix('=').map(str::to_owned))
                .ok_or(QemuError::StateKey {
                    file: state.clone(),
                    key,
                })
        };
        let pid: i32 = get("QEMU_PID")?
            .parse()
            .map_err(|_| QemuError::Launch("QEMU_PID is not a number".into()))?;
        Ok(Self {
            tape_pty: get("TAPE_PTY")?.into(),
            host_pty: get("HOST_PTY")?.into(),
            monitor: get("MONITOR")?.into(),
            log: get("LOG")?.into(),
            boot_seed,
            pid,
            _state_dir: state_dir,
        })
    }

    /// Sends a command to QEMU's monitor and returns what it printed within a short while.
    pub fn monitor_command(&self, cmd: &str) -> Result<String, QemuError> {
        let io = |what| move |source| QemuError::Io { what, source };
        let mut s = UnixStream::connect(&self.monitor).map_err(io("connecting to the monitor"))?;
        s.set_read_timeout(Some(Duration::from_millis(200)))
            .map_err(io("configuring the monitor socket"))?;
        s.write_all(format!("{cmd}\n").as_bytes())
            .map_err(io("writing to the monitor"))?;
        let mut out = Vec::new();
        let deadline = Instant::now() + Duration::from_secs(2);
        let mut buf = [0u8; 1024];
        while Instant::now() < deadline {
            match s.read(&mut buf) {
                Ok(0) => break,
                Ok(n) => out.extend_from_slice(&buf[..n]),
                Err(e)
                    if e.kind() == io::ErrorKind::WouldBlock
                        || e.kind() == io::ErrorKind::TimedOut =>
                {
                    break
                }
                Err(e) => return Err(io("reading the monitor")(e)),
            }
        }
        Ok(String::from_utf8_lossy(&out).into_owned())
    }

    /// Lets the guest run (`cont`).
    pub fn resume(&self) -> Result<(), QemuError> {
        self.monitor_command("cont").map(|_| ())
    }

    /// Resets the board (`system_reset`): the firmware reboots with a new boot id.
    pub fn reset(&self) -> Result<(), QemuError> {
        self.monitor_command("system_reset").map(|_| ())
    }

    /// QEMU's log so far (for failure messages).
    pub fn log_text(&self) -> String {
        std::fs::read_to_string(&self.log).unwrap_or_default()
    }
}

impl Drop for QemuBoard {
    fn drop(&mut self) {
        let _ = self.monitor_command("quit");
        if let Some(pid) = rustix::process::Pid::from_raw(self.pid) {
            // QEMU is not our child (the script started it), so it cannot be waited for;
            // make sure it is gone.
            let deadline = Instant::now() + Duration::from_secs(2);
            while Instant::now() < deadline && rustix::process::test_kill_process(pid).is_ok() {
                std::thread::sleep(Duration::from_millis(20));
            }
            if rustix::process::test_kill_process(pid).is_ok() {
                let _ = rustix::process::kill_process(pid, rustix::process::Signal::KILL);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::pty::TtyStream;
    use tokio::io::{AsyncReadExt, AsyncWriteExt};

    /// The board boots under QEMU and speaks on its host UART once the ports are open and the
    /// guest resumed (the firmware sends its hello at boot; a tape line gives it more to say).
    #[tokio::test(flavor = "multi_thread", worker_threads = 2)]
    async fn board_boots_and_talks_on_the_host_uart() {
        if !available_or_skip("board_boots_and_talks_on_the_host_uart") {
            return;
        }
        let board = QemuBoard::launch(0x1234_5678).unwrap();
        let mut tape = TtyStream::open_path(&board.tape_pty).unwrap();
        let mut host = TtyStream::open_path(&board.host_pty).unwrap();
        board.resume().unwrap();
        tape.write_all(b"*01234;00000;0000PM\n").await.unwrap();
        let mut buf = [0u8; 64];
        let n = tokio::time::timeout(Duration::from_secs(10), host.read(&mut buf))
            .await
            .unwrap_or_else(|_| {
                panic!(
                    "no byte from the board in 10 s; QEMU log:\n{}",
                    board.log_text()
                )
            })
            .unwrap();
        assert!(n > 0);
    }
}
