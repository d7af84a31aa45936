//! `tapeshape batch --measurements people.csv --out DIR [--shard K/N]
//! [--threads N]`: a body and a report for every person of a survey.
//!
//! Why: the paper's point is that "traditional anthropometric data can be
//! leveraged to create 3D datasets"; a survey of thousands of people is a
//! CSV of their tape readings, and this turns it into bodies on all cores.
//!
//! * **Input.** One row per person: a column per measurement (names as
//!   `tapeshape predict --list` shows them; values as `predict` takes them,
//!   `98cm`, `980mm`, a bare number in centimetres; an empty cell is "not
//!   measured"), and optionally `id` (default: the row number, `row-1`,
//!   ...), `sex` (`m`/`f`/`male`/`female`: what was not measured then
//!   follows real people of that sex, as `tapeshape predict --sex`) and
//!   `unit` (the unit of that row's bare numbers).
//! * **Output.** `DIR/<id>.<glb|obj|ply>` and `DIR/<id>.json` (the report
//!   without stage times, which differ from run to run), each written
//!   atomically, the report last: a person is done when both exist and the
//!   report records the same readings (their sha256). A second run skips
//!   what is done (resume after a crash, or after adding rows); a changed
//!   row is done again.
//! * **Deterministic.** A row gives the same bytes whatever the thread
//!   count or the order rows finish in: every prediction runs on one
//!   thread and its budgets count work, not time.
//! * **Shards.** `--shard K/N` (K from 1 to N) takes the rows whose id's
//!   stable hash (the first 8 bytes of its sha256, modulo N) is K - 1, so
//!   N machines given the same CSV split it between them under any job
//!   scheduler, with no overlap and nothing left out.
//! * **Refusals.** A row that cannot be read or that the estimator refuses
//!   (an impossible reading, a unit slip) is listed with its reason at the
//!   end and in `DIR/refused[-K-of-N].csv`; it never stops the others (a
//!   panic inside one prediction is caught and reported as that row's
//!   failure).

use std::collections::HashSet;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};

use anyhow::{bail, Context as _};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use sha2::{Digest, Sha256};
use tapeshape_estimator::{parse_length, Estimator, Input, Inputs, PredictOptions, Unit};

use super::Global;
use crate::estimate::MeshFormat;

/// Arguments of `tapeshape batch`.
#[derive(clap::Args, Debug)]
#[command(
    after_help = "Example:\n  tapeshape batch --measurements survey.csv --out bodies/ --shard 2/8 --threads 2\n\
The CSV: a header of measurement names (tapeshape predict --list), optional id, sex and unit columns, one row per person."
)]
pub struct Args {
    /// The survey: a CSV with a header row and one row per person.
    #[arg(long, value_name = "FILE")]
    pub measurements: PathBuf,

    /// Directory for the bodies and reports (created if missing).
    #[arg(long, value_name = "DIR")]
    pub out: PathBuf,

    /// Only this share of the rows: K/N, K from 1 to N (by a stable hash of each id).
    #[arg(long, value_name = "K/N")]
    pub shard: Option<String>,

    /// Worker threads [default: one per core].
    #[arg(long, value_name = "N")]
    pub threads: Option<usize>,

    /// Mesh format of the bodies: glb, obj or ply.
    #[arg(long, default_value = "glb", value_name = "EXT")]
    pub format: String,

    /// Model file from `tapeshape train` [default: the embedded model].
    #[arg(long, value_name = "FILE")]
    pub model: Option<PathBuf>,

    /// No progress bar.
    #[arg(long)]
    pub quiet: bool,

    /// The values were taken as the ANSUR II survey takes them (calipers
    /// that compress the tissue, flexed girths), as in ANSUR data: readings
    /// of the dimensions the standing body cannot take that way (chest and
    /// bicristal breadth, flexed biceps and forearm girths) are then
    /// recorded in each report, not fitted; so is the sleeve outseam (arm length)
    /// when the acromion-radiale and radiale-stylion lengths are given too
    /// (on the body it is their sum; ANSUR's is about 10 mm shorter).
    #[arg(long)]
    pub ansur_survey: bool,
}

/// One person of the survey.
#[derive(Debug, Clone, PartialEq)]
pub struct Row {
    /// 1-based data row (the line after the header is row 1).
    pub line: usize,
    /// The person's id (the `id` column, else `row-<line>`).
    pub id: String,
    /// The readings, or why the row cannot be read.
    pub inputs: Result<Inputs, String>,
    /// `m` or `f` when given.
    pub sex: Option<String>,
}

/// A share of the rows: the `k`-th (0-based) of `n`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Shard {
    /// 0-based.
    pub k: u64,
    /// At least 1.
    pub n: u64,
}

impl Shard {
    /// All rows.
    pub const ALL: Shard = Shard { k: 0, n: 1 };

    /// Parses `K/N` (K from 1 to N).
    pub fn parse(text: &str) -> anyhow::Result<Shard> {
        let parsed = text.split_once('/').and_then(|(k, n)| {
            Some((k.trim().parse::<u64>().ok()?, n.trim().parse::<u64>().ok()?))
        });
        match parsed {
            Some((k, n)) if n >= 1 && (1..=n).contains(&k) => Ok(Shard { k: k - 1, n }),
            _ => bail!("--shard {text}: write K/N with 1 <= K <= N, e.g. --shard 2/8"),
        }
    }

    /// Whether the row with `id` is in this shard: the first 8 bytes of the
    /// sha256 of the id (UTF-8), big-endian, modulo `n` (stable across
    /// machines, versions and row orders).
    pub fn contains(self, id: &str) -> bool {
        let h = Sha256::digest(id.as_bytes());
        let v = u64::from_be_bytes(h[..8].try_into().expect("8 bytes"));
        v % self.n == self.k
    }

    fn suffix(self) -> String {
        if self.n == 1 {
            String::new()
        } else {
            format!("-{}-of-{}", self.k + 1, self.n)
        }
    }
}

/// Reads a survey CSV (see the module docs). Errors only if the file or
/// its header cannot be read, or a column is named twice; a bad row comes
/// back as a row whose `inputs` is the reason.
pub fn read_rows(text: &str, origin: &str) -> anyhow::Result<Vec<Row>> {
    let mut rdr = csv::ReaderBuilder::new()
        .trim(csv::Trim::All)
        .flexible(true)
        .from_reader(text.as_bytes());
    let header: Vec<String> = rdr
        .headers()
        .with_context(|| format!("{origin}: reading the header row"))?
        .iter()
        .map(str::to_string)
        .collect();
    let mut seen = HashSet::new();
    for h in &header {
        if !seen.insert(h.as_str()) {
            bail!("{origin}: the column '{h}' appears twice in the header");
        }
    }
    let col = |name: &str| header.iter().position(|h| h == name);
    let (id_col, sex_col, unit_col) = (col("id"), col("sex"), col("unit"));
    let mut rows = Vec::new();
    for (i, record) in rdr.records().enumerate() {
        let line = i + 1;
        let record = match record {
            Ok(r) => r,
            Err(e) => {
                rows.push(Row {
                    line,
                    id: format!("row-{line}"),
                    inputs: Err(format!("cannot read the row: {e}")),
                    sex: None,
                });
                continue;
            }
        };
        let cell = |c: Option<usize>| c.and_then(|c| record.get(c)).filter(|v| !v.is_empty());
        let id = cell(id_col).map_or_else(|| format!("row-{line}"), str::to_string);
        let (sex, sex_err) = match cell(sex_col).map(str::to_ascii_lowercase).as_deref() {
            None => (None, None),
            Some("m" | "male") => (Some("m".to_string()), None),
            Some("f" | "female") => (Some("f".to_string()), None),
            Some(other) => (
                None,
                Some(format!("sex '{other}' is not m, f, male or female")),
            ),
        };
        let inputs = (|| -> Result<Inputs, String> {
            if let Some(e) = sex_err {
                return Err(e);
            }
            if record.len() != header.len() {
                return Err(format!(
                    "{} cells for {} columns",
                    record.len(),
                    header.len()
                ));
            }
            let unit = match cell(unit_col) {
                Some(u) => Some(
                    Unit::parse(u)
                        .ok_or_else(|| format!("unit '{u}' is not one of mm, cm, m, in"))?,
                ),
                None => None,
            };
            let mut inputs = Inputs::new();
            for (c, (name, value)) in header.iter().zip(record.iter()).enumerate() {
                if Some(c) == id_col
                    || Some(c) == sex_col
                    || Some(c) == unit_col
                    || value.is_empty()
                {
                    continue;
                }
                let mut length =
                    parse_length(value, unit).map_err(|e| format!("measurement '{name}': {e}"))?;
                length.unit_typed |= unit.is_some();
                inputs
                    .push(Input {
                        name: name.clone(),
                        value: length,
                        tolerance: None,
                    })
                    .map_err(|e| e.to_string())?;
            }
            if inputs.readings.is_empty() {
                return Err("no measurement in this row".into());
            }
            inputs.sex = sex
                .as_deref()
                .and_then(tapeshape_population::ansur::Sex::parse);
            Ok(inputs)
        })();
        rows.push(Row {
            line,
            id,
            inputs,
            sex,
        });
    }
    Ok(rows)
}

/// An id that can name a file: letters, digits, `.`, `_`, `-`, not
/// starting with `.`, at most 128 bytes.
fn file_safe(id: &str) -> bool {
    !id.is_empty()
        && id.len() <= 128
        && !id.starts_with('.')
        && id
            .bytes()
            .all(|b| b.is_ascii_alphanumeric() || matches!(b, b'.' | b'_' | b'-'))
}

/// The report of one person as `tapeshape batch` writes it.
#[derive(Debug, Serialize, Deserialize)]
pub struct PersonReport {
    /// The person's id.
    pub id: String,
    /// `m` or `f` when the survey gave it (the estimate then follows real
    /// people of that sex for what was not measured).
    pub sex: Option<String>,
    /// sha256 (hex) of the readings as parsed (names, metres, units): a
    /// rerun skips the person only if this matches.
    pub inputs_sha256: String,
    /// The estimator's report, without its stage times.
    pub estimate: serde_json::Value,
}

fn inputs_sha256(inputs: &Inputs, sex: Option<&str>) -> String {
    let mut h = Sha256::new();
    for r in &inputs.readings {
        h.update(r.name.as_bytes());
        h.update([0]);
        h.update(r.value.metres.to_le_bytes());
        h.update(r.value.unit.symbol().as_bytes());
        h.update([u8::from(r.value.unit_typed)]);
        h.update(r.tolerance.unwrap_or(-1.0).to_le_bytes());
    }
    h.update(sex.unwrap_or("-").as_bytes());
    // Only when set, so that the digests of earlier runs stay valid.
    if inputs.ansur_survey {
        h.update(b"\0ansur-survey");
    }
    h.finalize().iter().map(|b| format!("{b:02x}")).collect()
}

/// What happened to one row.
#[derive(Debug, Clone, PartialEq)]
pub enum Outcome {
    /// Body and report written.
    Done,
    /// Already done by an earlier run with the same readings.
    Skipped,
    /// Not done, with the reason.
    Refused(String),
}

/// What a batch did.
#[derive(Debug, Default)]
pub struct Summary {
    /// Rows in this shard.
    pub rows: usize,
    /// Bodies written now.
    pub done: usize,
    /// Rows already done.
    pub skipped: usize,
    /// (line, id, reason) of every refused row, in row order.
    pub refused: Vec<(usize, String, String)>,
}

/// Runs the rows of `shard` into `out` with `threads` workers (see the
/// module docs); `progress` is told of every finished row.
pub fn run_rows(
    estimator: &Estimator,
    rows: &[Row],
    out: &Path,
    format: MeshFormat,
    shard: Shard,
    threads: usize,
    progress: &(dyn Fn() + Sync),
) -> anyhow::Result<Summary> {
    std::fs::create_dir_all(out).with_context(|| format!("creating {}", out.display()))?;
    let mine: Vec<&Row> = rows.iter().filter(|r| shard.contains(&r.id)).collect();
    // Ids name files: a repeated id would overwrite another person.
    let mut first = HashSet::new();
    let repeated: HashSet<usize> = mine
        .iter()
        .filter(|r| !first.insert(r.id.as_str()))
        .map(|r| r.line)
        .collect();
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads.max(1))
        .build()
        .context("starting the worker threads")?;
    let outcomes: Vec<Outcome> = pool.install(|| {
        mine.par_iter()
            .map(|row| {
                let outcome = if repeated.contains(&row.line) {
                    Outcome::Refused(format!("the id '{}' is used by an earlier row", row.id))
                } else {
                    std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
                        one_row(estimator, row, out, format)
                    }))
                    .unwrap_or_else(|p| {
                        let what = p
                            .downcast_ref::<&str>()
                            .map(|s| s.to_string())
                            .or_else(|| p.downcast_ref::<String>().cloned())
                            .unwrap_or_default();
                        Outcome::Refused(format!("internal error (please report it): {what}"))
                    })
                };
                progress();
                outcome
            })
            .collect()
    });
    let mut summary = Summary {
        rows: mine.len(),
        ..Summary::default()
    };
    for (row, outcome) in mine.iter().zip(outcomes) {
        match outcome {
            Outcome::Done => summary.done += 1,
            Outcome::Skipped => summary.skipped += 1,
            Outcome::Refused(why) => summary.refused.push((row.line, row.id.clone(), why)),
        }
    }
    Ok(summary)
}

fn one_row(estimator: &Estimator, row: &Row, out: &Path, format: MeshFormat) -> Outcome {
    let inputs = match &row.inputs {
        Ok(i) => i,
        Err(e) => return Outcome::Refused(e.clone()),
    };
    if !file_safe(&row.id) {
        return Outcome::Refused(format!(
            "the id '{}' cannot name a file: use letters, digits, '.', '_' and '-'",
            row.id
        ));
    }
    let mesh_path = out.join(format!("{}.{}", row.id, format.ext()));
    let report_path = out.join(format!("{}.json", row.id));
    let digest = inputs_sha256(inputs, row.sex.as_deref());
    if mesh_path.exists() && already_done(&report_path, &digest) {
        return Outcome::Skipped;
    }
    let estimate = match estimator.predict(inputs, &PredictOptions::default()) {
        Ok(e) => e,
        Err(e) => return Outcome::Refused(e.to_string()),
    };
    let mut value = match estimate.report.to_json() {
        Ok(v) => v,
        Err(e) => return Outcome::Refused(format!("encoding the report: {e}")),
    };
    // Stage times differ from run to run; the batch's files must not.
    if let Some(o) = value.as_object_mut() {
        o.remove("check_time");
        if let Some(p) = o.get_mut("prediction").and_then(|p| p.as_object_mut()) {
            p.remove("timings");
        }
    }
    let report = PersonReport {
        id: row.id.clone(),
        sex: row.sex.clone(),
        inputs_sha256: digest,
        estimate: value,
    };
    if let Err(e) = format.write(&estimate.mesh, &mesh_path) {
        return Outcome::Refused(format!("writing {}: {e}", mesh_path.display()));
    }
    let json = match serde_json::to_vec_pretty(&report) {
        Ok(j) => j,
        Err(e) => return Outcome::Refused(format!("encoding the report: {e}")),
    };
    match tapeshape_common::fs::write_atomic(&report_path, &json) {
        Ok(()) => Outcome::Done,
        Err(e) => Outcome::Refused(format!("writing {}: {e}", report_path.display())),
    }
}

fn already_done(report: &Path, digest: &str) -> bool {
    #[derive(Deserialize)]
    struct Head {
        inputs_sha256: String,
    }
    std::fs::read(report)
        .ok()
        .and_then(|b| serde_json::from_slice::<Head>(&b).ok())
        .is_some_and(|h| h.inputs_sha256 == digest)
}

/// Runs `tapeshape batch`.
pub fn run(args: Args, _global: &Global) -> anyhow::Result<()> {
    let format = MeshFormat::from_path(Path::new(&format!("x.{}", args.format)))?;
    let shard = match &args.shard {
        Some(s) => Shard::parse(s)?,
        None => Shard::ALL,
    };
    let threads = match args.threads {
        Some(0) => bail!("--threads 0: give at least 1"),
        Some(n) => n,
        None => std::thread::available_parallelism().map_or(1, |n| n.get()),
    };
    let text = std::fs::read_to_string(&args.measurements)
        .with_context(|| format!("reading {}", args.measurements.display()))?;
    let mut rows = read_rows(&text, &args.measurements.display().to_string())?;
    if args.ansur_survey {
        for inputs in rows.iter_mut().filter_map(|r| r.inputs.as_mut().ok()) {
            inputs.ansur_survey = true;
        }
    }
    let owned;
    let estimator: &Estimator = match &args.model {
        Some(p) => {
            owned =
                Estimator::load(p).with_context(|| format!("loading the model {}", p.display()))?;
            &owned
        }
        None => Estimator::default_model()?,
    };
    let in_shard = rows.iter().filter(|r| shard.contains(&r.id)).count();
    let bar = if args.quiet {
        indicatif::ProgressBar::hidden()
    } else {
        indicatif::ProgressBar::new(in_shard as u64)
    };
    bar.set_style(
        indicatif::ProgressStyle::with_template(
            "{bar:40} {pos}/{len} bodies, {per_sec}, {eta} left",
        )
        .expect("a valid template"),
    );
    let t = std::time::Instant::now();
    let finished = AtomicUsize::new(0);
    let summary = run_rows(estimator, &rows, &args.out, format, shard, threads, &|| {
        finished.fetch_add(1, Ordering::Relaxed);
        bar.inc(1);
    })?;
    bar.finish_and_clear();
    let secs = t.elapsed().as_secs_f64();
    outln!(
        "{} rows{}: {} bodies written, {} already done, {} refused, in {:.1} s ({:.1} bodies/s, {} threads)",
        summary.rows,
        if shard.n > 1 {
            format!(" in shard {}/{} (of {})", shard.k + 1, shard.n, rows.len())
        } else {
            String::new()
        },
        summary.done,
        summary.skipped,
        summary.refused.len(),
        secs,
        summary.done as f64 / secs.max(1e-9),
        threads
    )?;
    let refused_path = args.out.join(format!("refused{}.csv", shard.suffix()));
    if summary.refused.is_empty() {
        let _ = std::fs::remove_file(&refused_path);
    } else {
        let mut w = csv::Writer::from_writer(Vec::new());
        w.write_record(["line", "id", "reason"])?;
        for (line, id, why) in &summary.refused {
            outln!("refused: row {line} ({id}): {why}")?;
            w.write_record([line.to_string().as_str(), id, why])?;
        }
        let bytes = w.into_inner().context("writing the refusals")?;
        tapeshape_common::fs::write_atomic(&refused_path, &bytes)
            .with_context(|| format!("writing {}", refused_path.display()))?;
        outln!("refusals: {}", refused_path.display())?;
    }
    Ok(())
}

#[cfg(test)]
mod tests;
