//! `tapeshape customer ...`: a customer's rights at this station (export
//! everything held about them; erase them here and, through the hub, in
//! the whole chain) and the returning-customer lookup.
//!
//! For the whole chain at once the head office has `tapeshape hub
//! customer export|erase` (feature `hub`).

use std::io::Write as _;
use std::path::PathBuf;

use anyhow::{bail, Context as _};
use serde_json::json;

use crate::cli::{Global, HubArgs};
use crate::store::{ReadingSource, Store};
use crate::sync::{HubClient, LookupSource};
use crate::text::{format_tenth_mm, format_time_ms};

/// Arguments of `tapeshape customer`.
#[derive(clap::Args, Clone, Debug)]
pub struct Args {
    /// What to do.
    #[command(subcommand)]
    pub action: Action,
}

/// `tapeshape customer` actions.
#[derive(clap::Subcommand, Clone, Debug)]
pub enum Action {
    /// Write everything this station holds about a customer as JSON
    /// (sessions, readings with retakes and undos, marks, estimates).
    Export {
        /// The customer's id.
        id: String,
        /// File to write (owner-only) [default: DATA_DIR/exports/customer-HASH.json];
        /// `-` writes to stdout.
        #[arg(long, value_name = "FILE")]
        out: Option<PathBuf>,
    },
    /// Erase a customer at this station now (every session, reading,
    /// estimate) and, on the next sync, at the hub and every other store.
    Erase {
        /// The customer's id.
        id: String,
        /// Confirm the erasure.
        #[arg(long)]
        yes: bool,
    },
    /// A returning customer's earlier sessions at every store (from the
    /// hub), or at this station when there is no hub or it does not answer.
    Lookup {
        /// The customer's id.
        id: String,
        /// The hub to ask.
        #[command(flatten)]
        hub: HubArgs,
        /// Also write each session's readings into this folder as a
        /// measurements file (`STORE-sessionN.json`, owner-only), to
        /// re-estimate the body from: `tapeshape predict --measurements FILE`.
        #[arg(long, value_name = "DIR")]
        save: Option<PathBuf>,
    },
}

/// A looked-up session's readings as a measurements file for `tapeshape
/// predict --measurements` (bare numbers in mm).
pub fn measurements_json(readings: &[(String, u32)]) -> serde_json::Value {
    let mut m = serde_json::Map::new();
    m.insert("unit".into(), json!("mm"));
    for (name, tenth_mm) in readings {
        m.insert(name.clone(), json!(f64::from(*tenth_mm) / 10.0));
    }
    serde_json::Value::Object(m)
}

/// Everything `store` holds about `customer`, as the export writes it.
pub fn export_json(store: &Store, customer: &str) -> anyhow::Result<serde_json::Value> {
    let mut sessions = Vec::new();
    for s in store.customer_sessions(customer)? {
        let detail = store.open_session(s.id)?;
        let readings: Vec<serde_json::Value> = detail
            .readings
            .iter()
            .map(|r| {
                let source = match &r.source {
                    ReadingSource::Tape(t) => json!({"tape": {
                        "device_id": format!("{:016x}", t.device_id), "boot_id": t.boot_id,
                        "seq": t.seq, "device_time_ms": t.device_time_ms}}),
                    ReadingSource::Keyboard => json!("keyboard"),
                };
                json!({
                    "reading": r.id.0, "measurement": r.measurement,
                    "value_tenth_mm": r.value_tenth_mm, "source": source,
                    "received_at_ms": r.received_at_ms,
                    "superseded_by": r.superseded_by.map(|x| x.0),
                    "withdrawn_at_ms": r.withdrawn_at_ms,
                })
            })
            .collect();
        let marks: Vec<serde_json::Value> = store
            .marks(s.id)?
            .into_iter()
            .map(|(m, k)| json!({"measurement": m, "mark": k.as_str()}))
            .collect();
        let estimate = store.estimate(s.id)?.map(|e| {
            json!({
                "made_at_ms": e.made_at_ms, "seconds": e.seconds, "model": e.model_source,
                "readings": e.readings, "vertices": e.vertices.len(),
                "report": serde_json::from_str::<serde_json::Value>(&e.report_json)
                    .unwrap_or(serde_json::Value::Null),
            })
        });
        sessions.push(json!({
            "session": s.id.0, "created_at_ms": s.created_at_ms, "updated_at_ms": s.updated_at_ms,
            "status": s.status.as_str(), "set": s.measurement_set, "notes": s.notes,
            "consent": s.consent.map(|c| c.as_str()),
            "readings": readings, "marks": marks, "estimate": estimate,
        }));
    }
    Ok(json!({
        "format": "tapeshape customer export",
        "version": 1,
        "held_by": "station",
        "station": store.sync_state()?.station,
        "customer": customer,
        "exported_at_ms": crate::store::now_ms(),
        "units": "lengths in tenths of a millimetre (value_tenth_mm); times in ms since the Unix epoch (UTC); an estimate's body is counted (vertices), `tapeshape session export ID` writes it",
        "sessions": sessions,
    }))
}

/// Writes `bytes` to `path` owner-only (0600), through a temporary name.
pub fn write_private(path: &std::path::Path, bytes: &[u8]) -> anyhow::Result<()> {
    use std::os::unix::fs::OpenOptionsExt as _;
    let dir = path.parent().filter(|p| !p.as_os_str().is_empty());
    if let Some(d) = dir {
        use std::os::unix::fs::DirBuilderExt as _;
        std::fs::DirBuilder::new()
            .recursive(true)
            .mode(0o700)
            .create(d)
            .with_context(|| format!("creating {}", d.display()))?;
    }
    let tmp = path.with_extension(format!("tmp-{}", std::process::id()));
    let result = (|| -> std::io::Result<()> {
        let mut f = std::fs::OpenOptions::new()
            .write(true)
            .create_new(true)
            .mode(0o600)
            .open(&tmp)?;
        f.write_all(bytes)?;
        f.sync_all()?;
        std::fs::rename(&tmp, path)
    })();
    if result.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    result.with_context(|| format!("writing {}", path.display()))
}

/// Runs the action.
pub fn run(args: Args, global: &Global) -> anyhow::Result<()> {
    let sessions = global.open_sessions()?;
    match args.action {
        Action::Export { id, out } => {
            let value = export_json(sessions.store(), &id)?;
            let n = value["sessions"].as_array().map_or(0, |a| a.len());
            let text = serde_json::to_string_pretty(&value)?;
            match out.as_deref() {
                Some(p) if p == std::path::Path::new("-") => outln!("{text}")?,
                _ => {
                    let path = match out {
                        Some(p) => p,
                        None => global.data_dir()?.join("exports").join(format!(
                            "customer-{}.json",
                            &tapeshape_hub_api::customer_hash(&id)[..12]
                        )),
                    };
                    write_private(&path, text.as_bytes())?;
                    outln!(
                        "exported {n} sessions of the customer to {}",
                        path.display()
                    )?;
                }
            }
        }
        Action::Erase { id, yes } => {
            let held = sessions.store().customer_sessions(&id)?.len();
            if !yes {
                bail!(
                    "this would erase the customer's {held} sessions at this station, and at the \
                     hub and every other store on the next sync; run again with --yes to confirm"
                );
            }
            let erased = sessions.erase_customer(&id)?;
            outln!(
                "erased {} sessions here; the erasure goes to the hub (and from there to every \
                 store that holds the customer) on the next sync",
                erased.len()
            )?;
        }
        Action::Lookup { id, hub, save } => {
            let config = hub.config()?;
            let client = config.as_ref().map(HubClient::new).transpose()?;
            let station = config.as_ref().map(|c| c.token.station().to_string());
            let found = crate::sync::lookup(&sessions, client.as_ref(), station.as_deref(), &id)?;
            match &found.source {
                LookupSource::Hub => outln!("from the chain's hub (every store):")?,
                LookupSource::Local { why } => {
                    outln!("from this station's own history only: {why}")?
                }
            }
            if found.sessions.is_empty() {
                outln!("no earlier sessions of this customer")?;
            }
            for s in &found.sessions {
                outln!(
                    "store {}  session {}  {}  set {}  {} readings{}",
                    s.station,
                    s.session,
                    format_time_ms(s.created_at_ms),
                    s.set.as_deref().unwrap_or("-"),
                    s.readings.len(),
                    if s.estimate_made_at_ms.is_some() {
                        ", estimated"
                    } else {
                        ""
                    }
                )?;
                for (name, v) in &s.readings {
                    outln!("    {name:<28} {}", format_tenth_mm(*v))?;
                }
                if let (Some(dir), false) = (&save, s.readings.is_empty()) {
                    // Only [A-Za-z0-9_-] of the name the hub sent goes
                    // into the file name: no path of the hub's choosing.
                    let store: String = s
                        .station
                        .chars()
                        .map(|c| {
                            if c.is_ascii_alphanumeric() || c == '-' || c == '_' {
                                c
                            } else {
                                '-'
                            }
                        })
                        .collect();
                    let file = dir.join(format!("{store}-session{}.json", s.session));
                    let text = serde_json::to_string_pretty(&measurements_json(&s.readings))?;
                    write_private(&file, text.as_bytes())?;
                    outln!(
                        "    re-estimate: tapeshape predict --measurements {} -o body.glb",
                        file.display()
                    )?;
                }
            }
        }
    }
    Ok(())
}
