//! Real pseudo-terminals, so that the host opens a path and runs its real serial code.
//!
//! Why real ptys and not an in-memory pipe: the station's link opens a device path with
//! tokio-serial, sets termios, and must survive the port vanishing under it. Only a real
//! pseudo-terminal exercises that code; an in-memory stream would test a different program.
//!
//! Pieces:
//!
//! * [`TtyStream`]: a non-blocking tty file descriptor (a pty master, or a tty opened by path)
//!   registered with tokio, implementing [`tokio::io::AsyncRead`] / [`tokio::io::AsyncWrite`].
//! * [`PtyPair`]: a fresh pty with both ends in raw mode; the simulator keeps the master, the
//!   program under test opens the slave path.
//! * [`PlugPort`]: a stable path (a symlink in a directory we own) to the current pty slave,
//!   that can be *unplugged* (master closed, symlink removed) and *replugged* (a new pty, the
//!   symlink pointed at its slave), like a USB serial adapter pulled out and put back.
//!
//! Linux pty behaviour this module relies on (checked by the tests below):
//!
//! * closing the master makes the slave's reads return end-of-file (0 bytes) and its writes
//!   fail with `EIO`: that is what the host sees on an unplug;
//! * while no slave is open, reading the master fails with `EIO` ([`is_peer_gone`]): that is
//!   what the simulator sees while the host is away (unplugged, killed, reconnecting);
//! * termios settings made on the slave stay with the pty when the slave is closed, so raw mode
//!   set once at creation holds for whoever opens the slave later. Raw mode matters: the
//!   default line discipline echoes, turns `\r` into `\n` and eats control bytes, which would
//!   corrupt binary frames.

use std::ffi::OsStr;
use std::io;
use std::os::fd::{AsFd, OwnedFd};
use std::os::unix::ffi::OsStrExt;
use std::path::{Path, PathBuf};
use std::pin::Pin;
use std::task::{ready, Context, Poll};

use rustix::fs::{Mode, OFlags};
use rustix::pty::OpenptFlags;
use rustix::termios::{OptionalActions, Termios};
use tokio::io::unix::AsyncFd;
use tokio::io::{AsyncRead, AsyncWrite, ReadBuf};

/// Whether an I/O error means the other end of the tty has gone away (`EIO` on Linux: the
/// slave of a master we read is closed, or the master of a slave we write is closed).
pub fn is_peer_gone(err: &io::Error) -> bool {
    err.raw_os_error() == Some(rustix::io::Errno::IO.raw_os_error())
}

/// Puts a tty into raw mode: no echo, no line editing, no character translation, 8 data bits.
pub fn set_raw(fd: impl AsFd) -> io::Result<()> {
    let mut t: Termios = rustix::termios::tcgetattr(&fd)?;
    t.make_raw();
    rustix::termios::tcsetattr(&fd, OptionalActions::Now, &t)?;
    Ok(())
}

/// A non-blocking tty file descriptor driven by tokio's reactor.
///
/// Reads and writes return the raw OS errors; see [`is_peer_gone`] for the one that means the
/// other end has gone.
#[derive(Debug)]
pub struct TtyStream {
    // Always `Some` between calls; taken only while re-registering (see `reregister`).
    fd: Option<AsyncFd<OwnedFd>>,
}

impl TtyStream {
    /// Wraps an open tty descriptor: sets it non-blocking and registers it with the current
    /// tokio runtime (must be called inside one).
    pub fn from_fd(fd: OwnedFd) -> io::Result<Self> {
        let flags = rustix::fs::fcntl_getfl(&fd)?;
        rustix::fs::fcntl_setfl(&fd, flags | OFlags::NONBLOCK)?;
        // SAFETY: `fd` is an `OwnedFd` moved into the `AsyncFd`, which owns it from here on;
        // nothing else can close or replace the descriptor while it is registered.
        let fd = unsafe { AsyncFd::register(fd)? };
        Ok(Self { fd: Some(fd) })
    }

    fn afd(&self) -> &AsyncFd<OwnedFd> {
        self.fd
            .as_ref()
            .expect("TtyStream: descriptor always registered between calls")
    }

    /// Registers the descriptor with tokio afresh.
    ///
    /// Why: tokio keeps the "read closed" / "write closed" readiness that a hang-up (`POLLHUP`)
    /// sets for the rest of a registration's life, on purpose (sockets do not reopen). A pty
    /// master does: when a process opens the slave again, the master is usable again, but its
    /// old registration would keep reporting "ready" and a read would return `EAGAIN` forever,
    /// a busy loop. A fresh registration starts from the descriptor's real state.
    fn reregister(&mut self) -> io::Result<()> {
        if let Some(afd) = self.fd.take() {
            let fd = afd.into_inner();
            // SAFETY: as in `from_fd`: the descriptor is owned and moved in.
            self.fd = Some(unsafe { AsyncFd::register(fd)? });
        }
        Ok(())
    }

    /// Another stream on a duplicate of the same descriptor (its own registration), so a
    /// reader and a writer can own one each.
    pub fn try_clone(&self) -> io::Result<Self> {
        let fd = rustix::io::fcntl_dupfd_cloexec(self.afd().get_ref(), 0)?;
        Self::from_fd(fd)
    }

    /// Opens a tty by path (for example a pty slave that QEMU created), puts it in raw mode
    /// and wraps it. Must be called inside a tokio runtime.
    pub fn open_path(path: &Path) -> io::Result<Self> {
        let fd = rustix::fs::open(
            path,
            OFlags::RDWR | OFlags::NOCTTY | OFlags::NONBLOCK | OFlags::CLOEXEC,
            Mode::empty(),
        )?;
        set_raw(&fd)?;
        Self::from_fd(fd)
    }

    /// Whether the other end is there: for a pty master, whether some process has the slave
    /// open (Linux reports `POLLHUP` on the master while none has).
    pub fn peer_present(&self) -> io::Result<bool> {
        use rustix::event::{PollFd, PollFlags, Timespec};
        let mut fds = [PollFd::new(self.afd().get_ref(), PollFlags::IN)];
        let zero = Timespec {
            tv_sec: 0,
            tv_nsec: 0,
        };
        rustix::event::poll(&mut fds, Some(&zero))?;
        Ok(!fds[0].revents().contains(PollFlags::HUP))
    }

    /// Discards bytes received but not yet read, and bytes written but not yet transmitted.
    pub fn flush_queues(&self) -> io::Result<()> {
        rustix::termios::tcflush(
            self.afd().get_ref(),
            rustix::termios::QueueSelector::IOFlush,
        )?;
        Ok(())
    }
}

impl AsyncRead for TtyStream {
    fn poll_read(
        self: Pin<&mut Self>,
        cx: &mut Context<'_>,
        buf: &mut ReadBuf<'_>,
    ) -> Poll<io::Result<()>> {
        let this = self.get_mut();
        loop {
            let mut guard = ready!(this.afd().poll_read_ready(cx))?;
            let stale_hangup = guard.ready().is_read_closed();
            let unfilled = buf.initialize_unfilled();
            match guard.try_io(|inner| {
                rustix::io::read(inner.get_ref(), &mut *unfilled).map_err(io::Error::from)
            }) {
                Ok(Ok(n)) => {
                    buf.advance(n);
                    return Poll::Ready(Ok(()));
                }
                Ok(Err(e)) => return Poll::Ready(Err(e)),
                Err(_would_block) if stale_hangup => this.reregister()?,
                Err(_would_block) => {}
            }
        }
    }
}

impl AsyncWrite for TtyStream {
    fn poll_write(
        self: Pin<&mut Self>,
        cx: &mut Context<'_>,
        buf: &[u8],
    ) -> Poll<io::Result<usize>> {
        let this = self.get_mut();
        loop {
            let mut guard = ready!(this.afd().poll_write_ready(cx))?;
            let stale_hangup = guard.ready().is_write_closed();
            match guard
                .try_io(|inner| rustix::io::write(inner.get_ref(), buf).map_err(io::Error::from))
            {
                Ok(result) => return Poll::Ready(result),
                Err(_would_block) if stale_hangup => this.reregister()?,
                Err(_would_block) => {}
            }
        }
    }

    fn poll_flush(self: Pin<&mut Self>, _cx: &mut Context<'_>) -> Poll<io::Result<()>> {
        // A tty write hands the bytes to the kernel; there is no user-space buffer to flush.
        Poll::Ready(Ok(()))
    }

    fn poll_shutdown(self: Pin<&mut Self>, _cx: &mut Context<'_>) -> Poll<io::Result<()>> {
        Poll::Ready(Ok(()))
    }
}

/// A fresh pseudo-terminal: the master as a [`TtyStream`] and the path of its slave.
///
/// Both ends are in raw mode. Nobody holds the slave open: the program under test opens
/// [`PtyPair::slave_path`]. Dropping the pair (the master) unplugs the slave.
#[derive(Debug)]
pub struct PtyPair {
    /// The master end, kept by the simulator.
    pub master: TtyStream,
    /// Path of the slave end (`/dev/pts/N`).
    pub slave_path: PathBuf,
}

impl PtyPair {
    /// Opens a new pty with both ends in raw mode. Must be called inside a tokio runtime.
    pub fn open() -> io::Result<Self> {
        let master = rustix::pty::openpt(OpenptFlags::RDWR | OpenptFlags::NOCTTY)?;
        rustix::pty::grantpt(&master)?;
        rustix::pty::unlockpt(&master)?;
        let name = rustix::pty::ptsname(&master, Vec::new())?;
        let slave_path = PathBuf::from(OsStr::from_bytes(name.as_bytes()));
        // Raw mode lives in the slave's termios, which survives this close.
        let slave = rustix::fs::open(
            &slave_path,
            OFlags::RDWR | OFlags::NOCTTY | OFlags::CLOEXEC,
            Mode::empty(),
        )?;
        set_raw(&slave)?;
        set_raw(&master)?;
        // Closing it leaves the master in the "nobody has the slave open" state (reads fail
        // with EIO, poll reports POLLHUP), which is what the simulator wants to see.
        drop(slave);
        Ok(Self {
            master: TtyStream::from_fd(master)?,
            slave_path,
        })
    }
}

/// A port path that can be unplugged and plugged in again.
///
/// The path is a symlink inside a directory this value owns; it points at the slave of the
/// current pty. [`PlugPort::unplug`] closes the master (the program holding the slave then
/// reads end-of-file and gets `EIO` on writes) and removes the symlink (so reopening the path
/// fails with "not found" until the replug). [`PlugPort::plug`] opens a new pty and points
/// the symlink at its slave, atomically (symlink under a temporary name, then rename).
#[derive(Debug)]
pub struct PlugPort {
    dir: tempfile::TempDir,
    link: PathBuf,
    current: Option<PtyPair>,
    plugs: u32,
}

impl PlugPort {
    /// Creates the port directory with the port unplugged. `name` is the symlink's file name
    /// (for example `"tape-station"`).
    pub fn new(name: &str) -> io::Result<Self> {
        let dir = tempfile::Builder::new()
            .prefix("tapeshape-port-")
            .tempdir()?;
        let link = dir.path().join(name);
        Ok(Self {
            dir,
            link,
            current: None,
            plugs: 0,
        })
    }

    /// Creates the port directory and plugs the port in.
    pub fn new_plugged(name: &str) -> io::Result<Self> {
        let mut p = Self::new(name)?;
        p.plug()?;
        Ok(p)
    }

    /// The stable path the program under test opens.
    pub fn path(&self) -> &Path {
        &self.link
    }

    /// Whether the port is plugged in now.
    pub fn is_plugged(&self) -> bool {
        self.current.is_some()
    }

    /// How many times the port has been plugged in (the first plug included).
    pub fn plug_count(&self) -> u32 {
        self.plugs
    }

    /// The master end of the current pty, if plugged in.
    pub fn master(&mut self) -> Option<&mut TtyStream> {
        self.current.as_mut().map(|p| &mut p.master)
    }

    /// The slave path the symlink points at now, if plugged in.
    pub fn slave_path(&self) -> Option<&Path> {
        self.current.as_ref().map(|p| p.slave_path.as_path())
    }

    /// Plugs the port in: a new pty, the symlink pointed at its slave. Unplugs first if
    /// plugged.
    pub fn plug(&mut self) -> io::Result<()> {
        self.unplug()?;
        let pair = PtyPair::open()?;
        let tmp = self.dir.path().join(format!(".plug-{}", self.plugs));
        let _ = std::fs::remove_file(&tmp);
        std::os::unix::fs::symlink(&pair.slave_path, &tmp)?;
        std::fs::rename(&tmp, &self.link)?;
        self.current = Some(pair);
        self.plugs += 1;
        Ok(())
    }

    /// Unplugs the port: closes the master and removes the symlink. Harmless when unplugged.
    pub fn unplug(&mut self) -> io::Result<()> {
        if self.current.take().is_some() {
            match std::fs::remove_file(&self.link) {
                Ok(()) => {}
                Err(e) if e.kind() == io::ErrorKind::NotFound => {}
                Err(e) => return Err(e),
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::time::Duration;
    use tokio::io::{AsyncReadExt, AsyncWriteExt};

    /// Every byte value crosses the pty unchanged in both directions (raw mode: no echo, no
    /// CR/LF translation, no control characters eaten).
    #[tokio::test]
    async fn raw_mode_passes_every_byte_both_ways() {
        let mut pair = PtyPair::open().unwrap();
        let mut slave = TtyStream::open_path(&pair.slave_path).unwrap();
        let all: Vec<u8> = (0..=255u8).collect();
        pair.master.write_all(&all).await.unwrap();
        let mut got = vec![0u8; 256];
        tokio::time::timeout(Duration::from_secs(5), slave.read_exact(&mut got))
            .await
            .unwrap()
            .unwrap();
        assert_eq!(got, all);
        slave.write_all(&all).await.unwrap();
        tokio::time::timeout(Duration::from_secs(5), pair.master.read_exact(&mut got))
            .await
            .unwrap()
            .unwrap();
        assert_eq!(got, all, "no echo of the first batch, no translation");
    }

    /// Unplug: the slave reads end-of-file and the path disappears; replug: the same path
    /// reaches a new pty.
    #[tokio::test]
    async fn unplug_and_replug_through_the_symlink() {
        let mut port = PlugPort::new_plugged("station").unwrap();
        let mut host = TtyStream::open_path(port.path()).unwrap();
        port.master().unwrap().write_all(b"abc").await.unwrap();
        let mut b = [0u8; 3];
        host.read_exact(&mut b).await.unwrap();
        assert_eq!(&b, b"abc");

        port.unplug().unwrap();
        let mut buf = [0u8; 8];
        let n = tokio::time::timeout(Duration::from_secs(5), host.read(&mut buf))
            .await
            .unwrap()
            .unwrap();
        assert_eq!(n, 0, "slave reads end-of-file after the master closed");
        let err = host.write_all(b"x").await.unwrap_err();
        assert!(is_peer_gone(&err), "{err}");
        assert!(TtyStream::open_path(port.path()).is_err());

        port.plug().unwrap();
        assert_eq!(port.plug_count(), 2);
        let mut host2 = TtyStream::open_path(port.path()).unwrap();
        assert_eq!(
            std::fs::canonicalize(port.path()).unwrap(),
            port.slave_path().unwrap()
        );
        host2.write_all(b"hi").await.unwrap();
        port.master()
            .unwrap()
            .read_exact(&mut b[..2])
            .await
            .unwrap();
        assert_eq!(&b[..2], b"hi");
    }

    /// While no slave is open, the master's reads fail with EIO.
    #[tokio::test]
    async fn master_sees_eio_without_a_slave() {
        let mut pair = PtyPair::open().unwrap();
        let mut buf = [0u8; 4];
        let err = tokio::time::timeout(Duration::from_secs(5), pair.master.read(&mut buf))
            .await
            .unwrap()
            .unwrap_err();
        assert!(is_peer_gone(&err), "{err}");
        assert!(!pair.master.peer_present().unwrap());
        let slave = TtyStream::open_path(&pair.slave_path).unwrap();
        assert!(pair.master.peer_present().unwrap());
        drop(slave);
        assert!(!pair.master.peer_present().unwrap());
        // After a hang-up the master works again for the next process (no stale readiness:
        // a read waits instead of spinning, and data flows).
        let mut slave = TtyStream::open_path(&pair.slave_path).unwrap();
        let pending =
            tokio::time::timeout(Duration::from_millis(100), pair.master.read(&mut buf)).await;
        assert!(pending.is_err(), "read must wait for data: {pending:?}");
        slave.write_all(b"ok").await.unwrap();
        tokio::time::timeout(
            Duration::from_secs(5),
            pair.master.read_exact(&mut buf[..2]),
        )
        .await
        .unwrap()
        .unwrap();
        assert_eq!(&buf[..2], b"ok");
    }
}
