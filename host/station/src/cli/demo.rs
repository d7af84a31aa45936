//! `tapeshape demo`: the whole data path on one machine, no hardware.
//!
//! Why: an engineer (or a CI job) must be able to see the station record a
//! session without a tape or a board. The demo starts the firmware logic on
//! the host between two pseudo-terminals (`tapeshape_sim::harness`, the very
//! `run` function the boards run), plays a simulated tape into the
//! firmware's tape port (`tapeshape_sim::tape`: live lines while the tape is
//! pulled, a hold per measurement), runs the station's own link and store on
//! the firmware's host port exactly as `tapeshape station` does, and prints
//! the stored session.
//!
//! The customer: an ANSUR II **test-split** subject (id divisible by 4, never
//! used to train or fit anything), chosen by `--seed`; the simulated operator
//! takes that person's real measurements for every entry of the set that maps
//! to an ANSUR column (all of `quick` and `ansur`). A set without such a
//! mapping (e.g. `paper34`) falls back to synthetic lengths, and says so.

use std::time::Duration;

use anyhow::{bail, Context as _};
use tapeshape_sim::harness::{FirmwareHarness, HarnessConfig};
use tapeshape_sim::pty::TtyStream;
use tapeshape_sim::tape::{play, Script, TapeTiming};

use crate::cli::station::{plan, record, RecordOptions};
use crate::cli::Global;
use crate::store::{Store, DATA_DIR_ENV};

/// Arguments of `tapeshape demo`.
#[derive(clap::Args, Clone, Debug)]
pub struct Args {
    /// Measurement set to walk through (built-in name or TOML file).
    #[arg(long = "set", value_name = "NAME", default_value = "quick")]
    pub measurement_set: String,

    /// Seed of the simulated readings.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,

    /// How much faster than real time the simulated operator works.
    #[arg(long, default_value_t = 10.0)]
    pub speedup: f64,

    /// Give up if the session is not complete after this many seconds.
    #[arg(long, default_value_t = 60)]
    pub timeout_s: u64,
}

/// Runs the demo. The session goes to the data directory if one is given
/// (`--data-dir` or `TAPESHAPE_DATA_DIR`), else to a temporary one removed
/// at the end.
pub fn run(args: Args, global: &Global) -> anyhow::Result<()> {
    if !(args.speedup.is_finite() && args.speedup > 0.0) {
        bail!("--speedup must be a positive number, got {}", args.speedup);
    }
    let set = tapeshape_measure::MeasurementSet::load(&args.measurement_set)?;
    let explicit = global.data_dir.is_some() || std::env::var_os(DATA_DIR_ENV).is_some();
    let (store, temp) = if explicit {
        (global.open_store()?, None)
    } else {
        let dir = tempfile::Builder::new()
            .prefix("tapeshape-demo-")
            .tempdir()
            .context("creating a temporary data directory for the demo")?;
        (Store::open(dir.path())?, Some(dir))
    };
    if temp.is_some() {
        println!(
            "demo store {} (temporary; pass --data-dir DIR to keep the session)",
            store.path().display()
        );
    }
    let (script, customer) = demo_script(&set, args.seed)?;
    println!("demo customer: {customer}");
    let session = store.create_session(&format!("demo-{}", args.seed), Some(&set.name))?;
    let plan = plan(&store, &session, &[])?;
    let n = set.definitions.len();

    let runtime = tokio::runtime::Builder::new_multi_thread()
        .worker_threads(2)
        .enable_all()
        .build()
        .context("starting the async runtime")?;
    runtime.block_on(async {
        // A boot id that differs per run, as a real board's does.
        let boot_id = std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .map(|d| d.subsec_nanos() ^ (d.as_secs() as u32))
            .unwrap_or(1);
        let harness = FirmwareHarness::start(HarnessConfig::fast(0x7a9e_da70_0000_0001, boot_id))
            .context("starting the simulated tape firmware")?;
        let timeline = script
            .timeline(TapeTiming::default())
            .context("building the simulated tape's script")?;
        let mut tape = TtyStream::open_path(harness.tape_path())
            .with_context(|| format!("opening {}", harness.tape_path().display()))?;
        let speedup = args.speedup;
        let player = tokio::spawn(async move {
            // Let the station connect first; the firmware queues readings
            // anyway, but live values are nicer to watch with a host there.
            tokio::time::sleep(Duration::from_millis(300)).await;
            play(&timeline, speedup, &mut tape, |_| {}).await
        });
        let options = RecordOptions {
            port: harness.host_path().to_path_buf(),
            baud: 115_200,
            live: false,
            exit_when_complete: true,
        };
        let outcome = tokio::time::timeout(
            Duration::from_secs(args.timeout_s),
            record(options, store.clone(), session.id, plan),
        )
        .await;
        player.abort();
        match outcome {
            Ok(r) => r,
            Err(_) => bail!(
                "the demo session was not complete after {} s ({} of {n} readings stored)",
                args.timeout_s,
                store.reading_count(session.id)?
            ),
        }
    })?;
    println!();
    print!(
        "{}",
        crate::cli::session::render(&store.open_session(session.id)?)
    );
    Ok(())
}

/// The simulated operator's tape script for `set` and a line describing the
/// customer. Every entry with an ANSUR column gets the real value of the
/// ANSUR II test-split subject number `seed` (modulo the split's size), pulled
/// out over 1.5 s (script time) and held; if any entry has no ANSUR column,
/// the whole script falls back to seeded synthetic lengths of 30-120 cm.
pub fn demo_script(
    set: &tapeshape_measure::MeasurementSet,
    seed: u64,
) -> anyhow::Result<(Script, String)> {
    use tapeshape_engine::ansur::{Ansur, Split};
    use tapeshape_sim::tape::Step;
    let pull = Duration::from_millis(1500);
    let ansur = Ansur::get()?;
    let test: Vec<_> = ansur.subjects(None, Split::Test).collect();
    let subject = test[(seed % test.len() as u64) as usize];
    let values: Option<Vec<u32>> = set
        .definitions
        .iter()
        .map(|d| {
            let metres = subject.dim(d.ansur.as_deref()?)?;
            Some((metres * 10_000.0).round() as u32)
        })
        .collect();
    let Some(values) = values else {
        let script = Script::session(set.definitions.len(), seed, 3000..12_000, pull);
        return Ok((
            script,
            format!(
                "synthetic lengths of 30 to 120 cm from seed {seed} (set {} has entries without an ANSUR II column)",
                set.name
            ),
        ));
    };
    let mut steps = Vec::with_capacity(2 * values.len());
    for v in values {
        steps.push(Step::Pull {
            to_tenth_mm: v,
            over: pull,
        });
        steps.push(Step::Hold);
    }
    let customer = format!(
        "ANSUR II test-split subject {} ({:?}, {} years): the tape reads this person's real {} measurements",
        subject.id, subject.sex, subject.age_years, set.name
    );
    Ok((Script { steps }, customer))
}
