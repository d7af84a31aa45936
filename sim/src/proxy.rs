//! A fault-injecting proxy between the firmware's host port and the station.
//!
//! Why a proxy and not faults inside the firmware harness: the same proxy sits in front of the
//! firmware logic running on the host *and* in front of the real board firmware running under
//! QEMU, so both are tested against exactly the same line faults.
//!
//! ```text
//! firmware host UART (a tty path)  <-->  proxy  <-->  PlugPort (symlink -> pty slave)  <-->  station
//!                                         |  device->host bytes: FaultInjector (bit flips,
//!                                         |  drops, duplicates; Unplug and Silence events)
//! ```
//!
//! * Device -> host bytes go through a [`FaultInjector`]. A [`FaultEvent::Unplug`] unplugs the
//!   host side ([`PlugPort::unplug`]: the station reads end-of-file, the path disappears) and
//!   plugs a new pty in after the given time; bytes the device sends meanwhile are lost, as on
//!   a pulled cable. A [`FaultEvent::Silence`] stalls the line: the proxy stops reading from
//!   the device for that long (the device's bytes wait in its tty buffer).
//! * Bytes the device sends while no station has the port open (killed, reconnecting) are
//!   dropped and counted, as a USB serial adapter with no reader would lose them; they are not
//!   delivered late to the next process that opens the port.
//! * Host -> device bytes are copied unchanged, or through a second injector if configured.
//! * [`ProxyHandle::unplug_for`] unplugs on demand, for tests that time unplugs themselves.

use std::io;
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex};
use std::time::Duration;

use tokio::io::{AsyncRead, AsyncReadExt, AsyncWrite, AsyncWriteExt};
use tokio::sync::{mpsc, oneshot};
use tokio::task::JoinHandle;
use tokio::time::Instant;

use crate::faults::{FaultEvent, FaultInjector, FaultPlan, FaultPlanError, FaultStats, Segment};
use crate::pty::{is_peer_gone, PlugPort, TtyStream};

/// Configuration of a [`Proxy`].
#[derive(Debug, Clone)]
pub struct ProxyConfig {
    /// Faults on device -> host bytes (and the unplug/silence events, placed at device byte
    /// offsets).
    pub device_to_host: FaultPlan,
    /// Faults on host -> device bytes (`None`: copied unchanged).
    pub host_to_device: Option<FaultPlan>,
    /// File name of the host-side port symlink.
    pub port_name: String,
}

impl ProxyConfig {
    /// No faults at all.
    pub fn transparent() -> Self {
        Self {
            device_to_host: FaultPlan::clean(0),
            host_to_device: None,
            port_name: "tapeshape-station".into(),
        }
    }
}

/// What the proxy has done so far.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct ProxyStats {
    /// Faults applied to device -> host bytes.
    pub device_to_host: FaultStats,
    /// Faults applied to host -> device bytes.
    pub host_to_device: FaultStats,
    /// Device -> host bytes handed to the station's pty.
    pub delivered_to_host: u64,
    /// Device -> host bytes lost because the port was unplugged or nobody had it open.
    pub lost_host_absent: u64,
    /// Host -> device bytes copied.
    pub delivered_to_device: u64,
    /// Unplugs carried out (plan events and [`ProxyHandle::unplug_for`] alike).
    pub unplugs: u32,
    /// Replugs carried out.
    pub replugs: u32,
}

/// Errors of the proxy.
#[derive(Debug, thiserror::Error)]
pub enum ProxyError {
    /// The fault plan is invalid.
    #[error("invalid fault plan: {0}")]
    Plan(#[from] FaultPlanError),
    /// A pty or symlink operation failed.
    #[error("proxy I/O error while {what}: {source}")]
    Io {
        /// What the proxy was doing.
        what: &'static str,
        /// The error.
        source: io::Error,
    },
}

fn io_err(what: &'static str) -> impl FnOnce(io::Error) -> ProxyError {
    move |source| ProxyError::Io { what, source }
}

enum Command {
    Unplug(Duration),
}

/// A running proxy.
#[derive(Debug)]
pub struct ProxyHandle {
    path: PathBuf,
    stats: Arc<Mutex<ProxyStats>>,
    commands: mpsc::UnboundedSender<Command>,
    stop: Option<oneshot::Sender<()>>,
    task: Option<JoinHandle<Result<(), ProxyError>>>,
}

impl ProxyHandle {
    /// The path the station must open (a symlink that follows the replugs).
    pub fn host_port_path(&self) -> &Path {
        &self.path
    }

    /// What the proxy has done so far.
    pub fn stats(&self) -> ProxyStats {
        *self.stats.lock().unwrap_or_else(|p| p.into_inner())
    }

    /// Unplugs the host side now and plugs it in again after `down`.
    pub fn unplug_for(&self, down: Duration) {
        let _ = self.commands.send(Command::Unplug(down));
    }

    /// Stops the proxy (the host side is unplugged) and returns its final statistics, or the
    /// error that stopped it earlier.
    pub async fn stop(mut self) -> Result<ProxyStats, ProxyError> {
        if let Some(s) = self.stop.take() {
            let _ = s.send(());
        }
        if let Some(t) = self.task.take() {
            match t.await {
                Ok(r) => r?,
                Err(e) => {
                    return Err(ProxyError::Io {
                        what: "joining the proxy task",
                        source: io::Error::other(e),
                    })
                }
            }
        }
        Ok(self.stats())
    }
}

impl Drop for ProxyHandle {
    fn drop(&mut self) {
        if let Some(t) = self.task.take() {
            t.abort();
        }
    }
}

/// The fault-injecting proxy.
pub struct Proxy;

impl Proxy {
    /// Starts a proxy between `device` (the firmware's host port) and a new host-side
    /// [`PlugPort`], plugged in at once. Must be called inside a tokio runtime.
    pub fn spawn<D>(device: D, config: ProxyConfig) -> Result<ProxyHandle, ProxyError>
    where
        D: AsyncRead + AsyncWrite + Send + Unpin + 'static,
    {
        let d2h = FaultInjector::new(config.device_to_host)?;
        let h2d = config.host_to_device.map(FaultInjector::new).transpose()?;
        let port =
            PlugPort::new_plugged(&config.port_name).map_err(io_err("creating the host port"))?;
        let path = port.path().to_path_buf();
        let stats = Arc::new(Mutex::new(ProxyStats::default()));
        let (tx, rx) = mpsc::unbounded_channel();
        let (stop_tx, stop_rx) = oneshot::channel();
        let task = tokio::spawn(run(device, port, d2h, h2d, stats.clone(), rx, stop_rx));
        Ok(ProxyHandle {
            path,
            stats,
            commands: tx,
            stop: Some(stop_tx),
            task: Some(task),
        })
    }

    /// Opens the device's tty by path (a pty slave made by the firmware harness or by QEMU)
    /// and starts a proxy in front of it.
    pub fn spawn_on_path(
        device_path: &Path,
        config: ProxyConfig,
    ) -> Result<ProxyHandle, ProxyError> {
        let dev = TtyStream::open_path(device_path).map_err(io_err("opening the device port"))?;
        Self::spawn(dev, config)
    }
}

struct State {
    port: PlugPort,
    replug_at: Option<Instant>,
    stats: Arc<Mutex<ProxyStats>>,
}

impl State {
    fn update(&self, f: impl FnOnce(&mut ProxyStats)) {
        f(&mut self.stats.lock().unwrap_or_else(|p| p.into_inner()));
    }

    fn unplug(&mut self, down: Duration) -> Result<(), ProxyError> {
        if self.port.is_plugged() {
            self.port
                .unplug()
                .map_err(io_err("unplugging the host port"))?;
            self.update(|s| s.unplugs += 1);
        }
        let at = Instant::now() + down;
        self.replug_at = Some(self.replug_at.map_or(at, |r| r.max(at)));
        Ok(())
    }

    async fn send_to_host(&mut self, bytes: &[u8]) -> Result<(), ProxyError> {
        let Some(master) = self.port.master() else {
            self.update(|s| s.lost_host_absent += bytes.len() as u64);
            return Ok(());
        };
        if !master.peer_present().unwrap_or(false) {
            self.update(|s| s.lost_host_absent += bytes.len() as u64);
            return Ok(());
        }
        // A station that stops reading must not stall the device side forever: give up on a
        // chunk after a second, as a UART with a full receiver would lose it.
        match tokio::time::timeout(Duration::from_secs(1), master.write_all(bytes)).await {
            Ok(Ok(())) => self.update(|s| s.delivered_to_host += bytes.len() as u64),
            Ok(Err(e)) if is_peer_gone(&e) || e.kind() == io::ErrorKind::WouldBlock => {
                self.update(|s| s.lost_host_absent += bytes.len() as u64)
            }
            Ok(Err(e)) => return Err(io_err("writing to the host port")(e)),
            Err(_) => self.update(|s| s.lost_host_absent += bytes.len() as u64),
        }
        Ok(())
    }
}

async fn run<D>(
    device: D,
    port: PlugPort,
    mut d2h: FaultInjector,
    mut h2d: Option<FaultInjector>,
    stats: Arc<Mutex<ProxyStats>>,
    mut commands: mpsc::UnboundedReceiver<Command>,
    mut stop: oneshot::Receiver<()>,
) -> Result<(), ProxyError>
where
    D: AsyncRead + AsyncWrite + Send + Unpin + 'static,
{
    let (mut dev_rx, mut dev_tx) = tokio::io::split(device);
    let mut st = State {
        port,
        replug_at: None,
        stats,
    };
    let mut dbuf = vec![0u8; 4096];
    let mut hbuf = vec![0u8; 4096];
    // After the station side reports "nobody there", poll it again only after a short pause
    // (its reads fail at once while nobody has it open).
    let mut host_backoff: Option<Instant> = None;
    let mut device_open = true;
    loop {
        let replug_at = st.replug_at;
        let backoff = host_backoff;
        let plugged = st.port.is_plugged();
        tokio::select! {
            biased;
            _ = &mut stop => break,
            Some(cmd) = commands.recv() => match cmd {
                Command::Unplug(down) => st.unplug(down)?,
            },
            _ = async { tokio::time::sleep_until(replug_at.unwrap_or_else(Instant::now)).await },
                if replug_at.is_some() => {
                st.replug_at = None;
                st.port.plug().map_err(io_err("replugging the host port"))?;
                st.update(|s| s.replugs += 1);
                host_backoff = None;
            }
            r = dev_rx.read(&mut dbuf), if device_open => {
                let n = match r {
                    Ok(0) => { device_open = false; continue; }
                    Ok(n) => n,
                    // The device tty has no writer right now (QEMU not started, harness
                    // between boots): nothing arrives; look again shortly.
                    Err(e) if is_peer_gone(&e) => {
                        tokio::time::sleep(Duration::from_millis(10)).await;
                        continue;
                    }
                    Err(e) => return Err(io_err("reading the device port")(e)),
                };
                for seg in d2h.process(&dbuf[..n]) {
                    match seg {
                        Segment::Bytes(b) => st.send_to_host(&b).await?,
                        Segment::Event(FaultEvent::Unplug { down }) => st.unplug(down)?,
                        Segment::Event(FaultEvent::Silence(d)) => tokio::time::sleep(d).await,
                    }
                }
                let s = d2h.stats();
                st.update(|x| x.device_to_host = s);
            }
            r = async {
                if let Some(t) = backoff { tokio::time::sleep_until(t).await; }
                match st.port.master() {
                    Some(m) => m.read(&mut hbuf).await,
                    None => std::future::pending().await,
                }
            }, if plugged => {
                match r {
                    Ok(0) => host_backoff = Some(Instant::now() + Duration::from_millis(10)),
                    Ok(n) => {
                        host_backoff = None;
                        let out = match h2d.as_mut() {
                            None => vec![Segment::Bytes(hbuf[..n].to_vec())],
                            Some(inj) => inj.process(&hbuf[..n]),
                        };
                        for seg in out {
                            if let Segment::Bytes(b) = seg {
                                dev_tx.write_all(&b).await
                                    .map_err(io_err("writing to the device port"))?;
                                st.update(|s| s.delivered_to_device += b.len() as u64);
                            }
                        }
                        if let Some(inj) = h2d.as_ref() {
                            let s = inj.stats();
                            st.update(|x| x.host_to_device = s);
                        }
                    }
                    Err(e) if is_peer_gone(&e) => {
                        host_backoff = Some(Instant::now() + Duration::from_millis(10));
                    }
                    Err(e) => return Err(io_err("reading the host port")(e)),
                }
            }
        }
    }
    st.port.unplug().map_err(io_err("unplugging at stop"))?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::faults::ScheduledEvent;
    use crate::pty::PtyPair;

    /// Bytes flow both ways unchanged through a transparent proxy, over real ptys.
    #[tokio::test]
    async fn transparent_both_ways() {
        let mut dev = PtyPair::open().unwrap();
        let proxy = Proxy::spawn_on_path(&dev.slave_path, ProxyConfig::transparent()).unwrap();
        let mut host = TtyStream::open_path(proxy.host_port_path()).unwrap();
        let data: Vec<u8> = (0..2000u32).map(|i| (i % 256) as u8).collect();
        dev.master.write_all(&data).await.unwrap();
        let mut got = vec![0u8; data.len()];
        tokio::time::timeout(Duration::from_secs(5), host.read_exact(&mut got))
            .await
            .unwrap()
            .unwrap();
        assert_eq!(got, data);
        host.write_all(b"ack!").await.unwrap();
        let mut b = [0u8; 4];
        tokio::time::timeout(Duration::from_secs(5), dev.master.read_exact(&mut b))
            .await
            .unwrap()
            .unwrap();
        assert_eq!(&b, b"ack!");
        let s = proxy.stop().await.unwrap();
        assert_eq!(s.delivered_to_host, 2000);
        assert_eq!(s.delivered_to_device, 4);
    }

    /// A planned unplug: the station reads end-of-file, the path vanishes, then comes back
    /// pointing at a new pty through which bytes flow again.
    #[tokio::test]
    async fn planned_unplug_and_replug() {
        let mut dev = PtyPair::open().unwrap();
        let mut cfg = ProxyConfig::transparent();
        cfg.device_to_host.events = vec![ScheduledEvent {
            at_byte: 100,
            event: FaultEvent::Unplug {
                down: Duration::from_millis(200),
            },
        }];
        let proxy = Proxy::spawn_on_path(&dev.slave_path, cfg).unwrap();
        let mut host = TtyStream::open_path(proxy.host_port_path()).unwrap();
        dev.master.write_all(&[7u8; 100]).await.unwrap();
        let mut got = vec![0u8; 100];
        host.read_exact(&mut got).await.unwrap();
        dev.master.write_all(&[8u8; 10]).await.unwrap();
        let mut b = [0u8; 16];
        let n = tokio::time::timeout(Duration::from_secs(5), host.read(&mut b))
            .await
            .unwrap()
            .unwrap();
        assert_eq!(n, 0, "unplugged: end-of-file");
        assert!(TtyStream::open_path(proxy.host_port_path()).is_err());
        tokio::time::sleep(Duration::from_millis(400)).await;
        let mut host = TtyStream::open_path(proxy.host_port_path()).unwrap();
        dev.master.write_all(&[9u8; 5]).await.unwrap();
        let mut b = [0u8; 5];
        tokio::time::timeout(Duration::from_secs(5), host.read_exact(&mut b))
            .await
            .unwrap()
            .unwrap();
        assert_eq!(b, [9u8; 5]);
        let s = proxy.stop().await.unwrap();
        assert_eq!((s.unplugs, s.replugs), (1, 1));
        assert_eq!(s.lost_host_absent, 10);
    }

    /// Bytes sent while nobody has the station port open are dropped, not delivered late.
    #[tokio::test]
    async fn bytes_without_a_reader_are_lost_not_delayed() {
        let mut dev = PtyPair::open().unwrap();
        let proxy = Proxy::spawn_on_path(&dev.slave_path, ProxyConfig::transparent()).unwrap();
        dev.master.write_all(b"stale").await.unwrap();
        tokio::time::sleep(Duration::from_millis(100)).await;
        let mut host = TtyStream::open_path(proxy.host_port_path()).unwrap();
        dev.master.write_all(b"fresh").await.unwrap();
        let mut b = [0u8; 5];
        tokio::time::timeout(Duration::from_secs(5), host.read_exact(&mut b))
            .await
            .unwrap()
            .unwrap();
        assert_eq!(&b, b"fresh");
        assert_eq!(proxy.stats().lost_host_absent, 5);
    }
}
