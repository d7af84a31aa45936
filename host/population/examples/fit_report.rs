//! How well a generated population's bodies met their subjects, per fitted
//! dimension: mean absolute and mean signed error (achieved - target), the
//! share within 5 mm, and iterations.
//!
//! `cargo run --release -p tapeshape-population --example fit_report -- FILE.tsd`

use std::collections::BTreeMap;

use clap::Parser;

/// How well a generated population's bodies met their subjects, per fitted
/// dimension, and where the fit left its drivers.
#[derive(Parser)]
struct Args {
    /// A generated population's dataset file: the fit records of its
    /// bodies (bodies without one are skipped).
    #[arg(value_name = "FILE.tsd")]
    path: String,
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args = tapeshape_common::cli::parse_or_exit::<Args>();
    let path = args.path;
    let d = tapeshape_population::Dataset::read(std::path::Path::new(&path))?;
    let mut per: BTreeMap<String, (f64, f64, usize, usize)> = BTreeMap::new();
    let mut iters = Vec::new();
    for b in &d.header.bodies {
        let Some(f) = &b.fit else { continue };
        iters.push(f.iterations);
        for (k, t) in &f.target_mm {
            let Some(a) = f.achieved_mm.get(k) else {
                continue;
            };
            let e = per.entry(k.clone()).or_default();
            e.0 += (a - t).abs();
            e.1 += a - t;
            e.2 += usize::from((a - t).abs() <= 5.0);
            e.3 += 1;
        }
    }
    println!("| dimension | mean abs error mm | mean signed mm | within 5 mm |\n|---|---|---|---|");
    for (k, (abs, signed, ok, n)) in &per {
        let n = *n as f64;
        println!(
            "| {k} | {:.1} | {:+.1} | {:.0} % |",
            abs / n,
            signed / n,
            100.0 * *ok as f64 / n
        );
    }
    // The fitted drivers: where the fit left them, and how many bodies
    // have them at the end of their range (a driver at its bound cannot
    // move its dimension further).
    println!("\n| driver | mean | at -1 | at +1 |\n|---|---|---|---|");
    for (_, driver) in tapeshape_population::generate::FIT_TARGETS
        .iter()
        .chain(tapeshape_population::generate::EXTRA_FIT_TARGETS)
        .filter(|(_, d)| !d.starts_with('@'))
    {
        let v: Vec<f64> = d
            .header
            .bodies
            .iter()
            .filter_map(|b| b.local_changes.get(*driver).copied())
            .collect();
        if v.is_empty() {
            continue;
        }
        let n = v.len() as f64;
        println!(
            "| {driver} | {:+.2} | {:.0} % | {:.0} % |",
            v.iter().sum::<f64>() / n,
            100.0 * v.iter().filter(|x| **x <= -0.999).count() as f64 / n,
            100.0 * v.iter().filter(|x| **x >= 0.999).count() as f64 / n
        );
    }
    iters.sort_unstable();
    println!(
        "\n{} bodies; iterations median {}",
        iters.len(),
        iters.get(iters.len() / 2).copied().unwrap_or(0)
    );
    Ok(())
}
