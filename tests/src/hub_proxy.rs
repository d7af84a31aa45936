//! A fault-injecting HTTP proxy between stations and the hub, on loopback.
//!
//! Why at the HTTP level rather than bytes: the faults that matter for the
//! sync are per request: a connection reset before the hub sees the
//! request, the hub's answer lost after it committed (the station must send
//! again and the hub must change nothing), a request arriving twice (the
//! copy later, after newer ones), a slow hop, an answer cut in the middle.
//! The proxy reads each request whole (headers and `Content-Length` body),
//! decides its fate from a seeded generator, and forwards it on a fresh
//! upstream connection with `Connection: close`, so the answer ends at the
//! upstream's end of stream.

use std::net::SocketAddr;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::time::Duration;

use tokio::io::{AsyncReadExt, AsyncWriteExt};
use tokio::net::{TcpListener, TcpStream};

/// What the proxy did, per kind of fault.
#[derive(Debug, Default)]
pub struct HubProxyStats {
    /// Requests read from stations.
    pub requests: AtomicU64,
    /// Forwarded untouched.
    pub passed: AtomicU64,
    /// Connection reset before forwarding.
    pub reset_before: AtomicU64,
    /// Forwarded, the answer dropped (the hub committed, the station never hears).
    pub answer_lost: AtomicU64,
    /// Forwarded twice (the copy delayed).
    pub duplicated: AtomicU64,
    /// Delayed before forwarding.
    pub delayed: AtomicU64,
    /// The answer cut in the middle.
    pub answer_cut: AtomicU64,
    /// Refused while offline or while the hub was down.
    pub refused: AtomicU64,
}

impl HubProxyStats {
    /// One line for messages.
    pub fn summary(&self) -> String {
        let g = |a: &AtomicU64| a.load(Ordering::Relaxed);
        format!(
            "{} requests: {} passed, {} reset, {} answers lost, {} duplicated, {} delayed, \
             {} answers cut, {} refused (offline or hub down)",
            g(&self.requests),
            g(&self.passed),
            g(&self.reset_before),
            g(&self.answer_lost),
            g(&self.duplicated),
            g(&self.delayed),
            g(&self.answer_cut),
            g(&self.refused)
        )
    }
}

/// A running proxy.
#[derive(Debug, Clone)]
pub struct HubProxy {
    /// Where stations connect.
    pub addr: SocketAddr,
    /// While set, every connection is closed at once (the station is offline).
    pub offline: Arc<AtomicBool>,
    /// What happened.
    pub stats: Arc<HubProxyStats>,
}

/// Share of requests (per mille) given each fault; the rest pass.
#[derive(Clone, Copy, Debug)]
pub struct FaultRates {
    /// Reset before forwarding.
    pub reset: u32,
    /// Answer lost after the hub committed.
    pub lose_answer: u32,
    /// Request duplicated.
    pub duplicate: u32,
    /// Request delayed (up to 400 ms).
    pub delay: u32,
    /// Answer cut.
    pub cut: u32,
}

impl Default for FaultRates {
    /// About 40 % of requests get a fault.
    fn default() -> Self {
        Self {
            reset: 80,
            lose_answer: 80,
            duplicate: 80,
            delay: 80,
            cut: 80,
        }
    }
}

struct Rng(Mutex<u64>);

impl Rng {
    /// splitmix64 (a few lines; the faults need no statistical quality).
    fn next(&self) -> u64 {
        let mut s = self.0.lock().unwrap_or_else(|e| e.into_inner());
        *s = s.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = *s;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    }
}

/// Reads one HTTP request (headers and a `Content-Length` body) from
/// `conn`; `None` at the end of the stream.
async fn read_request(conn: &mut TcpStream) -> std::io::Result<Option<Vec<u8>>> {
    let mut buf = Vec::new();
    let mut chunk = [0u8; 16 * 1024];
    let header_end = loop {
        if let Some(i) = buf.windows(4).position(|w| w == b"\r\n\r\n") {
            break i + 4;
        }
        let n = conn.read(&mut chunk).await?;
        if n == 0 {
            return Ok(None);
        }
        buf.extend_from_slice(&chunk[..n]);
        if buf.len() > 64 * 1024 && !buf.windows(4).any(|w| w == b"\r\n\r\n") {
            return Err(std::io::Error::other("headers too long"));
        }
    };
    let head = String::from_utf8_lossy(&buf[..header_end]).to_ascii_lowercase();
    let len: usize = head
        .lines()
        .find_map(|l| l.strip_prefix("content-length:"))
        .and_then(|v| v.trim().parse().ok())
        .unwrap_or(0);
    while buf.len() < header_end + len {
        let n = conn.read(&mut chunk).await?;
        if n == 0 {
            return Err(std::io::Error::other("request cut"));
        }
        buf.extend_from_slice(&chunk[..n]);
    }
    buf.truncate(header_end + len);
    // Ask the hub to close after its answer: the answer then ends at EOF.
    let text = String::from_utf8_lossy(&buf[..header_end]).into_owned();
    let mut out: Vec<u8> = text
        .split("\r\n")
        .filter(|l| !l.to_ascii_lowercase().starts_with("connection:"))
        .take_while(|l| !l.is_empty())
        .collect::<Vec<_>>()
        .join("\r\n")
        .into_bytes();
    out.extend_from_slice(b"\r\nConnection: close\r\n\r\n");
    out.extend_from_slice(&buf[header_end..]);
    Ok(Some(out))
}

/// Sends `request` to `upstream` and reads the whole answer.
async fn forward(upstream: SocketAddr, request: &[u8]) -> std::io::Result<Vec<u8>> {
    let mut up = tokio::time::timeout(Duration::from_secs(5), TcpStream::connect(upstream))
        .await
        .map_err(|_| std::io::Error::other("connect timed out"))??;
    up.write_all(request).await?;
    let mut answer = Vec::new();
    tokio::time::timeout(Duration::from_secs(30), up.read_to_end(&mut answer))
        .await
        .map_err(|_| std::io::Error::other("answer timed out"))??;
    Ok(answer)
}

impl HubProxy {
    /// Starts a proxy on a free loopback port in front of `upstream`, with
    /// faults drawn from `seed` at `rates`. Runs on the current tokio runtime.
    pub async fn start(
        upstream: SocketAddr,
        seed: u64,
        rates: FaultRates,
    ) -> std::io::Result<HubProxy> {
        let listener = TcpListener::bind("127.0.0.1:0").await?;
        let proxy = HubProxy {
            addr: listener.local_addr()?,
            offline: Arc::new(AtomicBool::new(false)),
            stats: Arc::new(HubProxyStats::default()),
        };
        let rng = Arc::new(Rng(Mutex::new(seed)));
        let p = proxy.clone();
        tokio::spawn(async move {
            loop {
                let Ok((conn, _)) = listener.accept().await else {
                    continue;
                };
                let p = p.clone();
                let rng = rng.clone();
                tokio::spawn(async move {
                    let _ = p.serve(conn, upstream, &rng, rates).await;
                });
            }
        });
        Ok(proxy)
    }

    async fn serve(
        &self,
        mut conn: TcpStream,
        upstream: SocketAddr,
        rng: &Rng,
        rates: FaultRates,
    ) -> std::io::Result<()> {
        let st = &self.stats;
        if self.offline.load(Ordering::SeqCst) {
            st.refused.fetch_add(1, Ordering::Relaxed);
            return Ok(()); // closed at once
        }
        let Some(request) = read_request(&mut conn).await? else {
            return Ok(());
        };
        st.requests.fetch_add(1, Ordering::Relaxed);
        let roll = (rng.next() % 1000) as u32;
        let mut edge = 0;
        let mut hit = |rate: u32| {
            let lo = edge;
            edge += rate;
            (lo..edge).contains(&roll)
        };
        if hit(rates.reset) {
            st.reset_before.fetch_add(1, Ordering::Relaxed);
            // Linger 0: closing sends a TCP reset, not an orderly end.
            let _ = rustix::net::sockopt::set_socket_linger(&conn, Some(Duration::ZERO));
            return Ok(()); // dropped: a reset
        }
        let lose = hit(rates.lose_answer);
        let duplicate = hit(rates.duplicate);
        let delay = hit(rates.delay);
        let cut = hit(rates.cut);
        if delay {
            st.delayed.fetch_add(1, Ordering::Relaxed);
            tokio::time::sleep(Duration::from_millis(50 + rng.next() % 350)).await;
        }
        if duplicate {
            st.duplicated.fetch_add(1, Ordering::Relaxed);
            let copy = request.clone();
            let wait = Duration::from_millis(rng.next() % 800);
            tokio::spawn(async move {
                tokio::time::sleep(wait).await;
                let _ = forward(upstream, &copy).await;
            });
        }
        let answer = match forward(upstream, &request).await {
            Ok(a) if !a.is_empty() => a,
            _ => {
                st.refused.fetch_add(1, Ordering::Relaxed);
                return Ok(()); // the hub is down: the station sees a closed connection
            }
        };
        if lose {
            st.answer_lost.fetch_add(1, Ordering::Relaxed);
            return Ok(());
        }
        if cut {
            st.answer_cut.fetch_add(1, Ordering::Relaxed);
            let half = answer.len() / 2;
            conn.write_all(&answer[..half]).await?;
            return Ok(());
        }
        if !(delay || duplicate) {
            st.passed.fetch_add(1, Ordering::Relaxed);
        }
        conn.write_all(&answer).await?;
        // The hub's answer says `connection: close`: so do we.
        Ok(())
    }
}
