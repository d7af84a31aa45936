//! How far the posterior waist landmark (`waist_back`, a fixed template
//! vertex) sits above or below the omphalion on each body of a dataset, per
//! sex. ANSUR II takes waist back length and the back half of crotch
//! length to "the level of omphalion on the back"; a landmark that moves
//! off that level with the body's shape changes both measurements, and by
//! sex when the offset differs by sex.
//!
//! `cargo run --release -p tapeshape-population --example landmark_levels -- FILE.tsd`

use clap::Parser;
use tapeshape_population::ansur::Sex;

/// How far the posterior waist landmark sits above or below the omphalion
/// on each body of a dataset, per sex.
#[derive(Parser)]
struct Args {
    /// A dataset file: the landmarks are read on its bodies' meshes.
    #[arg(value_name = "FILE.tsd")]
    path: String,
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args = tapeshape_common::cli::parse_or_exit::<Args>();
    let path = args.path;
    let d = tapeshape_population::Dataset::read(std::path::Path::new(&path))?;
    let records = tapeshape_body::anatomy::landmark_records()?;
    let landmark = |name: &str| -> Result<usize, String> {
        records
            .iter()
            .find(|r| r.name == name)
            .map(|r| r.vertex as usize)
            .ok_or_else(|| format!("no landmark {name}"))
    };
    let (om, wb) = (landmark("omphalion")?, landmark("waist_back")?);
    println!("| sex | bodies | mean mm | 5 % | median | 95 % |\n|---|---|---|---|---|---|");
    for sex in [Sex::Male, Sex::Female] {
        let mut v: Vec<f64> = d
            .bodies
            .iter()
            .zip(&d.header.bodies)
            .filter(|(_, r)| r.sex == Some(sex))
            .map(|(b, _)| (b[wb][2] - b[om][2]) * 1000.0)
            .collect();
        if v.is_empty() {
            continue;
        }
        v.sort_by(f64::total_cmp);
        let n = v.len();
        let mean = v.iter().sum::<f64>() / n as f64;
        println!(
            "| {} | {n} | {mean:+.1} | {:+.1} | {:+.1} | {:+.1} |",
            sex.word(),
            v[n / 20],
            v[n / 2],
            v[(n * 19 / 20).min(n - 1)]
        );
    }
    Ok(())
}
