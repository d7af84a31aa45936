//! `tapeshape sync`: one exchange with the chain's hub for a station whose
//! kiosk is not running: push what the outbox holds that the hub has not
//! committed (e.g. an erasure made with `tapeshape customer erase`), and
//! carry out the erasures the hub sends for customers this station holds.
//!
//! A running kiosk (`station`/`demo` with `--hub`) does this by itself all
//! the time; this is the same sync task, run until it has caught up.

use std::time::{Duration, Instant};

use anyhow::bail;

use crate::cli::{Global, HubArgs};

/// Arguments of `tapeshape sync`.
#[derive(clap::Args, Clone, Debug)]
pub struct Args {
    /// The hub.
    #[command(flatten)]
    pub hub: HubArgs,

    /// Give up after this many seconds (what is not sent goes next time).
    #[arg(long, value_name = "S", default_value_t = 60)]
    pub timeout_s: u64,
}

/// Runs the exchange.
pub fn run(args: Args, global: &Global) -> anyhow::Result<()> {
    if args.hub.hub.is_none() {
        bail!("give the hub: tapeshape sync --hub URL --station-token FILE");
    }
    let sessions = global.open_sessions()?;
    let Some(sync) = args.hub.start(&sessions)? else {
        bail!("give the hub: tapeshape sync --hub URL --station-token FILE");
    };
    let until = Instant::now() + Duration::from_secs(args.timeout_s);
    let left = || until.saturating_duration_since(Instant::now());
    // Caught up, and at least one answer from the hub (which carries the
    // erasures it has for this station).
    let mut synced = sync.wait_synced(left());
    while synced && sync.status().batches == 0 && !left().is_zero() {
        std::thread::sleep(Duration::from_millis(20));
    }
    // Erasures carried out are acknowledged with the next request, sent at
    // once; if it is lost the hub asks again next time (erasing again
    // finds nothing), so this waits for it only briefly.
    let st = sync.status();
    if st.erasures_applied > 0 {
        let ack_by = Instant::now() + Duration::from_secs(2).min(left());
        while sync.status().batches == st.batches && Instant::now() < ack_by {
            std::thread::sleep(Duration::from_millis(20));
        }
    }
    synced &= sync.status().batches > 0;
    let st = sync.status();
    sync.stop();
    if !synced {
        bail!(
            "the hub holds this station's events up to {} of {} after {} s{}; run again \
             (or start the kiosk with --hub) to send the rest",
            st.committed_through,
            st.last_seq,
            args.timeout_s,
            st.last_error
                .map(|e| format!(" (last error: {e})"))
                .unwrap_or_default()
        );
    }
    outln!(
        "the hub holds every event of this station (1 to {}); erasures from the hub \
         carried out here: {}",
        st.committed_through,
        st.erasures_applied
    )?;
    Ok(())
}
