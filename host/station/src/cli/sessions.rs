//! `tapeshape sessions`: list the stored sessions with their reading counts.

use crate::cli::Global;
use crate::store::{SessionStatus, SessionSummary};
use crate::text::format_time_ms;

/// Arguments of `tapeshape sessions`.
#[derive(clap::Args, Clone, Debug)]
pub struct Args {
    /// Only sessions with this status (open, done, abandoned).
    #[arg(long)]
    pub status: Option<SessionStatus>,
}

/// Prints the session list, most recently updated first.
pub fn run(args: Args, global: &Global) -> anyhow::Result<()> {
    let store = global.open_store()?;
    let list: Vec<SessionSummary> = store
        .list_sessions()?
        .into_iter()
        .filter(|s| args.status.is_none_or(|st| s.session.status == st))
        .collect();
    out!("{}", render(&list))?;
    if list.is_empty() {
        eprintln!("no sessions in {}", store.path().display());
    }
    Ok(())
}

/// The listing as text: a header and one line per session.
pub fn render(list: &[SessionSummary]) -> String {
    let mut out = String::new();
    if list.is_empty() {
        return out;
    }
    out.push_str(&format!(
        "{:>5}  {:<9}  {:<20}  {:<12}  {:>8}  {:<20}\n",
        "ID", "STATUS", "CUSTOMER", "SET", "READINGS", "UPDATED (UTC)"
    ));
    for s in list {
        let readings = if s.total_readings == s.current_readings {
            s.current_readings.to_string()
        } else {
            format!(
                "{}+{}",
                s.current_readings,
                s.total_readings - s.current_readings
            )
        };
        out.push_str(&format!(
            "{:>5}  {:<9}  {:<20}  {:<12}  {:>8}  {:<20}\n",
            s.session.id,
            s.session.status,
            s.session.customer_id,
            s.session.measurement_set.as_deref().unwrap_or("-"),
            readings,
            format_time_ms(s.session.updated_at_ms)
        ));
    }
    out
}
