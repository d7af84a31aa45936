//! `tapeshape demo`: the whole station on one machine, no hardware.
//!
//! Why: an engineer, a visitor or a CI job must be able to see the station
//! work without a tape or a board. The demo starts the firmware logic on the
//! host between two pseudo-terminals (`tapeshape_sim::harness`, the very
//! `run` function the boards run), plays a simulated tape into the
//! firmware's tape port (`tapeshape_sim::tape`: live lines while the tape is
//! pulled, a hold per measurement), and runs the station's own link and store
//! on the firmware's host port exactly as `tapeshape station` does.
//!
//! In a terminal it runs the kiosk interface ([`crate::tui`]) with a
//! simulated operator that measures, estimates and exports by itself; any
//! key takes over. With `--headless`, or when stdout is not a terminal (CI,
//! a pipe), it records the session in line mode, prints it, estimates the
//! body and prints the result's summary.
//!
//! The customer: an ANSUR II test-split subject (id divisible by 4, never
//! used to train or fit anything), chosen by `--seed`, whose real
//! measurements the tape reads for every entry of the set that maps to an
//! ANSUR column (all of `quick` and `ansur`). For a set without such a
//! mapping (e.g. `paper34`) the customer is a body generated from the
//! population with that seed, measured with the model's operators; only a
//! set file the model does not know falls back to synthetic lengths, and
//! says so.

use std::path::PathBuf;
use std::time::Duration;

use anyhow::{bail, Context as _};
use tapeshape_sim::harness::{FirmwareHarness, HarnessConfig};
use tapeshape_sim::pty::TtyStream;
use tapeshape_sim::tape::{play, Script, TapeTiming};

use crate::cli::station::{plan, record, RecordOptions};
use crate::cli::{mono_wanted, reading_tolerance, Global};
use crate::services::station::StationServices;
use crate::session::Sessions;
use crate::store::DATA_DIR_ENV;

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

    /// Give up if the session is not complete after this many seconds
    /// (headless mode).
    #[arg(long, default_value_t = 60)]
    pub timeout_s: u64,

    /// No interface: record, print the session and the estimate's summary
    /// (the default when stdout is not a terminal).
    #[arg(long)]
    pub headless: bool,

    /// Interface without colours (also when NO_COLOR is set).
    #[arg(long)]
    pub mono: bool,

    /// Folder for exported bodies and reports [default: DATA_DIR/exports;
    /// headless: no export unless given].
    #[arg(long, value_name = "DIR")]
    pub export_dir: Option<PathBuf>,

    /// The operator's reading uncertainty in millimetres (standard
    /// deviation; about 10 for a novice with a tape). Readings are checked
    /// and fitted with it instead of a skilled measurer's ISO 20685-1
    /// tolerances.
    #[arg(long, value_name = "MM")]
    pub reading_tolerance: Option<f64>,

    /// The store's size chart (TOML, docs/size-charts.md) for the result
    /// screen's sizes [default: DATA_DIR/size-chart.toml when it exists,
    /// else the example chart (examples/size-charts/) of the simulated
    /// customer's sex].
    #[arg(long, value_name = "FILE")]
    pub chart: Option<PathBuf>,

    /// Syncing the demo's sessions to a chain's hub (none by default).
    #[command(flatten)]
    pub hub: crate::cli::HubArgs,
}

/// The example charts (`examples/size-charts/`, made by
/// `host/sizes/examples/make_example_charts.rs` from ANSUR II percentiles;
/// no brand's chart), embedded so that the demo shows sizes with nothing
/// beside the program.
const EXAMPLE_CHARTS: [(&str, &str); 2] = [
    (
        "examples/size-charts/menswear.toml",
        include_str!("../../../../examples/size-charts/menswear.toml"),
    ),
    (
        "examples/size-charts/womenswear.toml",
        include_str!("../../../../examples/size-charts/womenswear.toml"),
    ),
];

/// The demo's size chart: `--chart FILE` or `DATA_DIR/size-chart.toml` as
/// the station takes it, else the embedded example chart for `sex`
/// (menswear without one).
fn demo_chart(
    chart: Option<&std::path::Path>,
    data_dir: &std::path::Path,
    sex: Option<tapeshape_population::ansur::Sex>,
) -> anyhow::Result<tapeshape_sizes::Chart> {
    if let Some(c) = crate::cli::station::station_chart(chart, data_dir)? {
        return Ok(c);
    }
    let (origin, text) = match sex {
        Some(tapeshape_population::ansur::Sex::Female) => EXAMPLE_CHARTS[1],
        _ => EXAMPLE_CHARTS[0],
    };
    let estimator = tapeshape_estimator::Estimator::default_model()?;
    Ok(tapeshape_sizes::Chart::from_toml_str(
        text,
        origin,
        &crate::estimate::sizes::known_dimensions(estimator),
    )?)
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
    let (sessions, temp) = if explicit {
        (global.open_sessions()?, None)
    } else {
        let dir = tempfile::Builder::new()
            .prefix("tapeshape-demo-")
            .tempdir()
            .context("creating a temporary data directory for the demo")?;
        (Sessions::open(dir.path())?, Some(dir))
    };
    if temp.is_some() {
        outln!(
            "demo store {} (temporary; pass --data-dir DIR to keep the session)",
            sessions.store().path().display()
        )?;
    }
    use std::io::IsTerminal as _;
    let interactive =
        !args.headless && std::io::stdout().is_terminal() && std::io::stdin().is_terminal();
    let sync = args.hub.start(&sessions)?;
    let result = if interactive {
        run_interactive(&args, global, sessions, temp.as_ref().map(|t| t.path()))
    } else {
        run_headless(&args, &set, sessions)
    };
    crate::cli::finish_sync(sync, Duration::from_secs(10));
    result
}

/// The demo without an interface: records one session from the simulated
/// tape, prints it and estimates it.
fn run_headless(
    args: &Args,
    set: &tapeshape_measure::MeasurementSet,
    sessions: Sessions,
) -> anyhow::Result<()> {
    let (script, customer) = demo_script(set, args.seed)?;
    // Synthetic lengths (a set without ANSUR columns) are not a body: the
    // estimate may refuse them, which is then reported, not an error.
    let real_customer = demo_customer(set, args.seed)?.sex.is_some();
    outln!("demo customer: {customer}")?;
    let session = sessions.create(&format!("demo-{}", args.seed), Some(&set.name), None)?;
    let plan = plan(&sessions, &session, &[])?;
    let n = set.definitions.len();

    let runtime = tokio::runtime::Builder::new_multi_thread()
        .worker_threads(2)
        .enable_all()
        .build()
        .context("starting the async runtime")?;
    runtime.block_on(async {
        let harness = FirmwareHarness::start(HarnessConfig::fast(0x7a9e_da70_0000_0001, boot_id()))
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
            record(options, sessions.clone(), session.id, plan),
        )
        .await;
        player.abort();
        match outcome {
            Ok(r) => r,
            Err(_) => bail!(
                "the demo session was not complete after {} s ({} of {n} readings stored)",
                args.timeout_s,
                sessions.store().reading_count(session.id)?
            ),
        }
    })?;
    outln!()?;
    let detail = sessions.store().open_session(session.id)?;
    let careful = sessions.careful_reading_notes(&detail)?;
    out!("{}", crate::cli::session::render(&detail, &careful))?;
    outln!()?;
    let services = StationServices::new(sessions, reading_tolerance(args.reading_tolerance)?);
    headless_estimate(
        &services,
        &detail,
        args.export_dir.as_deref(),
        real_customer,
    )
}

/// Estimates the body from a recorded session with the station's services
/// (which store it with the session) and prints the interface's result
/// table; exports into `export` if given.
fn headless_estimate(
    services: &StationServices,
    detail: &crate::store::SessionDetail,
    export: Option<&std::path::Path>,
    must_succeed: bool,
) -> anyhow::Result<()> {
    use crate::services::{EstimateEvent, EstimateRequest, Services as _};
    let request = EstimateRequest {
        session: detail.session.id,
        readings: detail
            .current_readings()
            .map(|r| (r.measurement.clone(), r.value_mm()))
            .collect(),
        sex: crate::tui::screens::new_customer::sex_of_notes(detail.session.notes.as_deref()),
        // The headless demo keeps nothing: a refused set fails it.
        kept: Vec::new(),
    };
    let (tx, rx) = std::sync::mpsc::channel();
    let _cancel = services.start_estimate(
        request,
        Box::new(move |ev| {
            let _ = tx.send(ev);
        }),
    );
    let summary = loop {
        match rx.recv_timeout(Duration::from_secs(120)) {
            Ok(EstimateEvent::Stage { .. }) => {}
            Ok(EstimateEvent::Done(s)) => break s,
            Ok(EstimateEvent::Failed(e)) if must_succeed => {
                bail!("the estimate was refused: {e}")
            }
            Ok(EstimateEvent::Failed(e)) => {
                outln!("estimate refused (synthetic lengths are not a body): {e}")?;
                return Ok(());
            }
            Ok(EstimateEvent::Cancelled) => bail!("the estimate was cancelled"),
            Err(_) => bail!("the estimate did not finish within 120 s"),
        }
    };
    outln!(
        "estimate: {} readings in {:.2} s; plausibility: {}",
        summary.rows.len(),
        summary.seconds,
        summary.plausibility
    )?;
    outln!(
        "{:<34} {:>9} {:>9} {:>7}",
        "measurement (cm)",
        "target",
        "body",
        "error"
    )?;
    for r in &summary.rows {
        outln!(
            "{:<34} {:>9.1} {:>9.1} {:>+7.2}",
            r.name,
            r.target_mm / 10.0,
            r.achieved_mm / 10.0,
            (r.achieved_mm - r.target_mm) / 10.0
        )?;
    }
    for w in &summary.warnings {
        outln!("warning: {w}")?;
    }
    if let Some(dir) = export {
        use crate::estimate::MeshFormat;
        let mut files = Vec::new();
        for f in [MeshFormat::Glb, MeshFormat::Obj, MeshFormat::Ply] {
            files.extend(services.export(detail.session.id, f, dir)?);
        }
        files.sort();
        files.dedup();
        for f in files {
            outln!("exported {}", f.display())?;
        }
    }
    Ok(())
}

/// The demo in the kiosk interface, driven by the simulated operator until a
/// key is pressed.
fn run_interactive(
    args: &Args,
    global: &Global,
    sessions: Sessions,
    temp: Option<&std::path::Path>,
) -> anyhow::Result<()> {
    use crate::tui::operator::{Autopilot, SimDemo, SimOperator, SimTape};
    let set = tapeshape_measure::MeasurementSet::load(&args.measurement_set)?;
    let customer = demo_customer(&set, args.seed)?;
    let runtime = tokio::runtime::Builder::new_multi_thread()
        .worker_threads(2)
        .enable_all()
        .build()
        .context("starting the async runtime")?;
    let _enter = runtime.enter();
    let harness = FirmwareHarness::start(HarnessConfig::fast(0x7a9e_da70_0000_0001, boot_id()))
        .context("starting the simulated tape firmware")?;
    let tape_port = TtyStream::open_path(harness.tape_path())
        .with_context(|| format!("opening {}", harness.tape_path().display()))?;
    let tape = SimTape::start(
        tape_port,
        customer.values.into_iter().collect(),
        args.speedup,
    );
    let pace = Duration::from_secs_f64((4.0 / args.speedup).clamp(0.15, 2.0));
    let operator = SimOperator::new(customer.sex, pace);
    let data_dir = match temp {
        Some(t) => t.to_path_buf(),
        None => global.data_dir()?,
    };
    let export_dir = match &args.export_dir {
        Some(d) => d.clone(),
        None => data_dir.join("exports"),
    };
    let chart = demo_chart(args.chart.as_deref(), &data_dir, customer.sex)?;
    let services = std::sync::Arc::new(
        StationServices::new(sessions.clone(), reading_tolerance(args.reading_tolerance)?)
            .with_chart(chart),
    );
    let options = crate::tui::runner::RunOptions {
        sessions: sessions.clone(),
        port: harness.host_path().to_path_buf(),
        port_label: format!("simulated tape ({})", harness.host_path().display()),
        baud: 115_200,
        mono: mono_wanted(args.mono),
        export_dir: export_dir.clone(),
        log_dir: data_dir,
        default_set: set.name.clone(),
        careful: false,
        demo: Some(Box::new(SimDemo {
            tape,
            pilot: Autopilot::new(operator),
        })),
    };
    let result = crate::tui::runner::run_with_log(options, services, &runtime);
    drop(harness);
    outln!("demo customer: {}", customer.description)?;
    for s in sessions.store().list_sessions()?.iter().take(3) {
        outln!(
            "session {} customer {} {} ({} readings)",
            s.session.id,
            s.session.customer_id,
            s.session.status,
            s.current_readings
        )?;
    }
    if temp.is_some() {
        outln!(
            "the demo's store and exports were temporary ({}); pass --data-dir DIR to keep them",
            sessions.store().path().display()
        )?;
    } else {
        outln!("exports: {}", export_dir.display())?;
    }
    result
}

/// A boot id that differs per run, as a real board's does.
fn boot_id() -> u32 {
    std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map(|d| d.subsec_nanos() ^ (d.as_secs() as u32))
        .unwrap_or(1)
}

/// The demo's simulated customer for a set.
pub struct DemoCustomer {
    /// The customer's true value of each measurement of the set (name,
    /// tenths of a mm), in set order.
    pub values: Vec<(String, u32)>,
    /// Who it is, for the operator.
    pub description: String,
    /// Sex, when the customer is a real person (`None`: synthetic lengths).
    pub sex: Option<tapeshape_population::ansur::Sex>,
}

/// The ANSUR II test-split subject number `seed` (modulo the split's size)
/// with their real values of every entry of `set` that has an ANSUR column;
/// if any entry has none, seeded synthetic lengths of 30-120 cm.
pub fn demo_customer(
    set: &tapeshape_measure::MeasurementSet,
    seed: u64,
) -> anyhow::Result<DemoCustomer> {
    use tapeshape_population::ansur::{Ansur, Split};
    let ansur = Ansur::get()?;
    let test: Vec<_> = ansur.subjects(None, Split::Test).collect();
    let subject = test[(seed % test.len() as u64) as usize];
    let values: Option<Vec<(String, u32)>> = set
        .definitions
        .iter()
        .map(|d| {
            let metres = subject.dim(d.ansur.as_deref()?)?;
            Some((d.name.clone(), (metres * 10_000.0).round() as u32))
        })
        .collect();
    Ok(match values {
        Some(values) => DemoCustomer {
            values,
            description: format!(
                "ANSUR II test-split subject {} ({:?}, {} years): the tape reads this person's real {} measurements",
                subject.id, subject.sex, subject.age_years, set.name
            ),
            sex: Some(subject.sex),
        },
        None => match population_customer(set, seed)? {
            Some(c) => c,
            None => {
            let script = Script::session(
                set.definitions.len(),
                seed,
                3000..12_000,
                Duration::from_millis(1500),
            );
            DemoCustomer {
                values: set
                    .definitions
                    .iter()
                    .map(|d| d.name.clone())
                    .zip(script.confirmed_values())
                    .collect(),
                description: format!(
                    "synthetic lengths of 30 to 120 cm from seed {seed} (set {} has entries the model does not know)",
                    set.name
                ),
                sex: None,
            }
            }
        },
    })
}

/// A body from the generated population (seed `seed`, one body) measured
/// with the default model's operators: the customer for a set whose
/// entries have no ANSUR II column (e.g. paper34). `None` if the set names
/// a measurement the model does not know (a custom file).
fn population_customer(
    set: &tapeshape_measure::MeasurementSet,
    seed: u64,
) -> anyhow::Result<Option<DemoCustomer>> {
    use tapeshape_estimator::Estimator;
    use tapeshape_population::{generate_population, PopulationSettings};
    let estimator = Estimator::default_model()?;
    let Some(index): Option<Vec<usize>> = set
        .definitions
        .iter()
        .map(|d| estimator.set().index_of(&d.name))
        .collect()
    else {
        return Ok(None);
    };
    // Never the population the default model was trained on (seed 1): the
    // demo's customer must be someone the model has not seen.
    let population_seed = seed.wrapping_add(1_000_000);
    let settings = PopulationSettings {
        n: 1,
        seed: population_seed,
        ..PopulationSettings::default()
    };
    let population = generate_population(&settings, &|_, _| {})
        .context("generating the demo's simulated customer")?;
    let body = &population.bodies[0];
    if body.len() != estimator.topology().n_vertices() {
        return Ok(None);
    }
    let measured = estimator
        .compiled()
        .measure(body)
        .context("measuring the demo's simulated customer")?;
    let values = set
        .definitions
        .iter()
        .zip(index)
        .map(|(d, j)| {
            (
                d.name.clone(),
                (measured[j].value * 10_000.0).round() as u32,
            )
        })
        .collect();
    let record = population.header.bodies.first();
    let sex = record
        .and_then(|r| r.sex)
        .unwrap_or(tapeshape_population::ansur::Sex::Female);
    Ok(Some(DemoCustomer {
        values,
        description: format!(
            "a generated body held out from the model's training (population seed {population_seed}, {sex:?}) measured with the {} set",
            set.name
        ),
        sex: Some(sex),
    }))
}

/// The simulated operator's tape script for `set` and a line describing the
/// customer ([`demo_customer`]): each value pulled out over 1.5 s (script
/// time) and held.
pub fn demo_script(
    set: &tapeshape_measure::MeasurementSet,
    seed: u64,
) -> anyhow::Result<(Script, String)> {
    use tapeshape_sim::tape::Step;
    let customer = demo_customer(set, seed)?;
    let mut steps = Vec::with_capacity(2 * customer.values.len());
    for (_, v) in customer.values {
        steps.push(Step::Pull {
            to_tenth_mm: v,
            over: Duration::from_millis(1500),
        });
        steps.push(Step::Hold);
    }
    Ok((Script { steps }, customer.description))
}
