//! `tapeshape session ...`: show one session's readings, close or delete it.

use anyhow::bail;

use crate::cli::{format_tenth_mm, format_time_ms, Global};
use crate::store::{SessionDetail, SessionId, SessionStatus};

/// Arguments of `tapeshape session`.
#[derive(clap::Args, Clone, Debug)]
pub struct Args {
    /// What to do.
    #[command(subcommand)]
    pub action: Action,
}

/// `tapeshape session` actions.
#[derive(clap::Subcommand, Clone, Debug)]
pub enum Action {
    /// Print a session and every reading (retakes included).
    Show {
        /// Session id (see `tapeshape sessions`).
        id: i64,
    },
    /// Set a session's status (open, done, abandoned).
    SetStatus {
        /// Session id.
        id: i64,
        /// New status.
        status: SessionStatus,
    },
    /// Delete a session and its readings for good.
    Delete {
        /// Session id.
        id: i64,
        /// Confirm the deletion.
        #[arg(long)]
        yes: bool,
    },
}

/// Runs the action.
pub fn run(args: Args, global: &Global) -> anyhow::Result<()> {
    let store = global.open_store()?;
    match args.action {
        Action::Show { id } => {
            print!("{}", render(&store.open_session(SessionId(id))?));
        }
        Action::SetStatus { id, status } => {
            store.set_status(SessionId(id), status)?;
            println!("session {id} is now {status}");
        }
        Action::Delete { id, yes } => {
            let s = store.session(SessionId(id))?;
            if !yes {
                bail!(
                    "this would delete session {id} (customer {}) and all its readings; \
                     run again with --yes to confirm",
                    s.customer_id
                );
            }
            store.delete_session(SessionId(id))?;
            println!("session {id} deleted");
        }
    }
    Ok(())
}

/// A session as text: header lines, then one line per reading in commit
/// order; superseded readings (retaken later) are marked.
pub fn render(d: &SessionDetail) -> String {
    let s = &d.session;
    let mut out = format!(
        "session {}  customer {}  status {}  set {}\ncreated {}  updated {}\n",
        s.id,
        s.customer_id,
        s.status,
        s.measurement_set.as_deref().unwrap_or("-"),
        format_time_ms(s.created_at_ms),
        format_time_ms(s.updated_at_ms)
    );
    if let Some(n) = &s.notes {
        out.push_str(&format!("notes: {n}\n"));
    }
    if d.readings.is_empty() {
        out.push_str("no readings\n");
        return out;
    }
    out.push_str(&format!(
        "{:<28}  {:>12}  {:>16}  {:>10}  {:>6}  {:<20}  {}\n",
        "MEASUREMENT", "VALUE", "DEVICE", "BOOT", "SEQ", "RECEIVED (UTC)", "NOTE"
    ));
    for r in &d.readings {
        let note = match r.superseded_by {
            Some(by) => format!("retaken (reading {by})"),
            None => String::new(),
        };
        out.push_str(&format!(
            "{:<28}  {:>12}  {:>16x}  {:>10}  {:>6}  {:<20}  {}\n",
            r.measurement,
            format_tenth_mm(r.device.value_tenth_mm),
            r.device.device_id,
            r.device.boot_id,
            r.device.seq,
            format_time_ms(r.received_at_ms),
            note
        ));
    }
    out
}
