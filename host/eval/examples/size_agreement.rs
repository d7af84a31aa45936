//! Sizes from a few readings against sizes from all of them, on every ANSUR
//! II test-split person (issue 14's results page).
//!
//! For each person and each garment of the example chart of their sex
//! (`examples/size-charts/`): the size their nine real `quick` values give
//! (all measured: the reference), beside the size the station recommends
//! from only stature, chest, waist and hip (the other chart dimensions read
//! off the estimated body, with their spread), and the size least squares
//! with sex on the ANSUR II train split gives from the same four (its
//! residual SD as spread). Prints a Markdown page: the share of people
//! whose recommended size equals the reference, per garment.
//!
//! ```text
//! cargo run --release -p tapeshape-eval --example size_agreement -- [--per-sex N] [--out FILE]
//! ```
//!
//! Options: `--help` lists them (how many people, where the page goes).

use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::Path;

use clap::Parser;
use nalgebra::{DMatrix, DVector};
use tapeshape_estimator::{Estimator, PredictOptions};
use tapeshape_eval::customers::{features, ols, predict_row, run, test_people, CustomersOptions};
use tapeshape_measure::{Class, MeasurementSet};
use tapeshape_population::ansur::{Ansur, Sex, Split};
use tapeshape_sizes::{recommend, Chart, DimensionKind, KnownDimension, Readings};

/// The four readings of the short set (station names).
const FOUR: [&str; 4] = ["stature", "chest", "waist", "hip"];

fn known(set: &MeasurementSet) -> Vec<KnownDimension> {
    set.definitions
        .iter()
        .map(|d| {
            let kind = match d.class {
                Class::Girth => DimensionKind::Girth,
                Class::Length | Class::Height | Class::Arc => DimensionKind::Length,
                Class::Breadth | Class::Depth => DimensionKind::Breadth,
            };
            KnownDimension::new(d.name.clone(), kind)
        })
        .collect()
}

fn best(chart: &Chart, readings: &Readings) -> Vec<Option<String>> {
    recommend(chart, readings)
        .garments
        .iter()
        .map(|g| g.best.as_ref().map(|b| b.label.clone()))
        .collect()
}

/// Sizes from a few readings against sizes from all of them, on every
/// ANSUR II test-split person: prints (or writes) a Markdown page.
#[derive(Parser)]
// A flag given twice takes its last value, as the hand-written loop did.
#[command(args_override_self = true)]
struct Args {
    /// The first N of each sex by id (default: all).
    #[arg(long, value_name = "N")]
    per_sex: Option<usize>,
    /// The Markdown page (default: print it).
    #[arg(long, value_name = "FILE")]
    out: Option<String>,
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    // The command as given, for the page.
    let given: Vec<String> = std::env::args().skip(1).collect();
    let Args { per_sex, out } = tapeshape_common::cli::parse_or_exit::<Args>();
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let quick = MeasurementSet::builtin("quick")?;
    let estimator = Estimator::default_model()?;
    let names = known(estimator.set());
    let charts = [
        (
            Sex::Male,
            Chart::from_path(&root.join("examples/size-charts/menswear.toml"), &names)?,
        ),
        (
            Sex::Female,
            Chart::from_path(&root.join("examples/size-charts/womenswear.toml"), &names)?,
        ),
    ];
    let chart_of = |sex: Sex| &charts.iter().find(|(s, _)| *s == sex).expect("both").1;
    // The station's estimate from the four: the quick set with the other
    // five columns left out.
    let column = |name: &str| {
        quick
            .definitions
            .iter()
            .find(|d| d.name == name)
            .and_then(|d| d.ansur.clone())
    };
    let leave_out: Vec<String> = quick
        .definitions
        .iter()
        .filter(|d| !FOUR.contains(&d.name.as_str()))
        .filter_map(|d| d.ansur.clone())
        .collect();
    let opts = CustomersOptions {
        input_set: "quick".into(),
        with_sex: true,
        per_sex,
        leave_out,
        ansur_survey: false,
        options: PredictOptions::default(),
    };
    let t0 = std::time::Instant::now();
    let result = run(estimator, &opts)?;
    let ansur = Ansur::get()?;
    let people = test_people(ansur, per_sex);
    // Least squares with sex from the four columns to every other quick
    // column, on the train split, with its residual SD.
    let four_cols: Vec<String> = FOUR.iter().filter_map(|n| column(n)).collect();
    let train: Vec<_> = ansur
        .subjects(None, Split::Train)
        .filter(|s| features(s, &four_cols, true).is_some())
        .collect();
    let mut ls: BTreeMap<String, (DVector<f64>, f64)> = BTreeMap::new();
    for d in &quick.definitions {
        let Some(col) = &d.ansur else { continue };
        if FOUR.contains(&d.name.as_str()) {
            continue;
        }
        let rows: Vec<_> = train.iter().filter(|s| s.dim(col).is_some()).collect();
        let x = DMatrix::from_row_iterator(
            rows.len(),
            four_cols.len() + 1,
            rows.iter()
                .flat_map(|s| features(s, &four_cols, true).unwrap_or_default()),
        );
        let y = DVector::from_iterator(rows.len(), rows.iter().filter_map(|s| s.dim(col)));
        let Some(b) = ols(&x, &y) else { continue };
        let rss: f64 = rows
            .iter()
            .map(|s| {
                let f = features(s, &four_cols, true).unwrap_or_default();
                (predict_row(&b, &f) - s.dim(col).unwrap_or(f64::NAN)).powi(2)
            })
            .sum();
        let sd = (rss / (rows.len() as f64 - four_cols.len() as f64 - 2.0)).sqrt();
        ls.insert(d.name.clone(), (b, sd));
    }
    let tol = |name: &str| {
        quick
            .definitions
            .iter()
            .find(|d| d.name == name)
            .map_or(0.0, |d| d.tolerance.mm())
    };
    let union_index = |name: &str| result.names.iter().position(|n| n == name);
    // garment -> (people, station agrees, regression agrees)
    let mut tally: BTreeMap<(Sex, String), (usize, usize, usize)> = BTreeMap::new();
    let mut skipped: Vec<String> = Vec::new();
    for (p, s) in result.people.iter().zip(&people) {
        if p.refused.is_some() {
            skipped.push(format!("{}: refused", s.id));
            continue;
        }
        let chart = chart_of(s.sex);
        let mut truth = Readings::new();
        let mut station = Readings::new();
        let mut regression = Readings::new();
        let four: Vec<f64> = four_cols.iter().filter_map(|c| s.dim(c)).collect();
        if four.len() != 4 {
            continue;
        }
        let mut f = four.clone();
        f.push(if s.sex == Sex::Male { 1.0 } else { 0.0 });
        let mut bad: Option<String> = None;
        for d in &quick.definitions {
            let Some(v) = d.ansur.as_deref().and_then(|c| s.dim(c)) else {
                continue;
            };
            let name = d.name.as_str();
            let mut ok = truth.insert_measured(name, v * 1000.0, tol(name)).is_ok();
            if FOUR.contains(&name) {
                ok &= station.insert_measured(name, v * 1000.0, tol(name)).is_ok();
                ok &= regression
                    .insert_measured(name, v * 1000.0, tol(name))
                    .is_ok();
                if !ok {
                    bad = Some(format!("{}: {name} {v} m not usable", s.id));
                }
                continue;
            }
            if !ok {
                bad = Some(format!("{}: {name} {v} m not usable", s.id));
            }
            if let Some(j) = union_index(name) {
                let sd = p
                    .soft_sd_mm
                    .iter()
                    .find(|(n, _)| n == name)
                    .map(|(_, sd)| *sd)
                    .or_else(|| {
                        let others: Vec<(&str, f64)> =
                            FOUR.iter().copied().zip(four.iter().copied()).collect();
                        estimator
                            .predict_reading(name, &others)
                            .ok()
                            .map(|r| r.sd * 1000.0)
                    })
                    .unwrap_or(tol(name));
                if let Err(e) = station.insert_estimated(name, p.body[j] * 1000.0, sd) {
                    bad = Some(format!("{}: station's {name}: {e}", s.id));
                }
            }
            if let Some((b, sd)) = ls.get(name) {
                if let Err(e) =
                    regression.insert_estimated(name, predict_row(b, &f) * 1000.0, sd * 1000.0)
                {
                    bad = Some(format!("{}: regression's {name}: {e}", s.id));
                }
            }
        }
        if let Some(b) = bad {
            skipped.push(b);
            continue;
        }
        let (t, st, rg) = (
            best(chart, &truth),
            best(chart, &station),
            best(chart, &regression),
        );
        for (k, g) in chart.garments().iter().enumerate() {
            let e = tally.entry((s.sex, g.name().to_string())).or_default();
            e.0 += 1;
            e.1 += usize::from(t[k].is_some() && t[k] == st[k]);
            e.2 += usize::from(t[k].is_some() && t[k] == rg[k]);
        }
    }
    let mut page = String::new();
    let _ = writeln!(
        page,
        "# Sizes from four readings against sizes from nine: ANSUR II test split\n\n\
Command: `cargo run --release -p tapeshape-eval --example size_agreement -- {}`\n\n\
{} test-split people ({:.0} s). Reference: the size each person's nine real `quick` values give on the example chart \
of their sex (all measured). Station: only stature, chest, waist and hip measured, the chart's other dimensions read off \
the estimated body (embedded model, default settings, sex given) with their spread. Regression: least squares with sex \
on the ANSUR II train split from the same four, its residual SD as spread. The example charts are built from ANSUR II \
train-split percentiles (docs/size-charts.md), not any brand's.\n",
        given.join(" "),
        result.people.len(),
        t0.elapsed().as_secs_f64()
    );
    let _ = writeln!(
        page,
        "| sex | garment | people | station (4 readings) = reference | regression (4) = reference |\n|---|---|---|---|---|"
    );
    for ((sex, g), (n, st, rg)) in &tally {
        let _ = writeln!(
            page,
            "| {} | {g} | {n} | {:.1} % | {:.1} % |",
            sex.word(),
            100.0 * *st as f64 / (*n).max(1) as f64,
            100.0 * *rg as f64 / (*n).max(1) as f64
        );
    }
    if !skipped.is_empty() {
        let _ = writeln!(page, "\nLeft out ({}):\n", skipped.len());
        for k in &skipped {
            let _ = writeln!(page, "- {k}");
        }
    }
    match out {
        Some(f) => tapeshape_common::fs::write_atomic(Path::new(&f), page.as_bytes())?,
        None => print!("{page}"),
    }
    eprint!("{page}");
    Ok(())
}
