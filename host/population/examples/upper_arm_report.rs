//! The upper arm of a generated population beside ANSUR II, per sex: the
//! relaxed mid-upper-arm girth (the `quick` set's `upper_arm`, a plane cut
//! of the right arm) and the paper34 right arm loop (the sum of its four
//! geodesics), with the bodies whose fit drove muscle and weight to their
//! upper limit. ANSUR II has only the flexed biceps girth
//! (`bicepscircumferenceflexed`, train split), shown for scale: a relaxed
//! girth runs a few centimetres under it.
//!
//! `cargo run --release -p tapeshape-population --example upper_arm_report -- FILE.tsd`

use clap::Parser;
use tapeshape_measure::MeasurementSet;
use tapeshape_population::ansur::{Ansur, Sex, Split};
use tapeshape_population::statistics::mean_sd_corr;

/// Arm loop members of the right arm in paper34 (their sum is the loop).
const RIGHT_LOOP: [&str; 4] = [
    "arm_right_front_lateral",
    "arm_right_lateral_back",
    "arm_right_back_medial",
    "arm_right_medial_front",
];

/// A body counts as "at the limit" when both muscle and weight are at least this.
const AT_LIMIT: f64 = 0.95;

/// Mean +- SD (the population statistics' own [`mean_sd_corr`]), the 5 % and
/// 95 % points and the largest value, cm.
fn summary(v: &mut [f64]) -> String {
    if v.is_empty() {
        return "none".into();
    }
    v.sort_by(f64::total_cmp);
    let rows: Vec<Vec<f64>> = v.iter().map(|&x| vec![x]).collect();
    let (mean, sd, _) = mean_sd_corr(&rows);
    let q = |p: f64| v[((p * (v.len() - 1) as f64).round() as usize).min(v.len() - 1)];
    format!(
        "{:.1} +- {:.1} cm (5 % {:.1}, 95 % {:.1}, max {:.1})",
        mean[0],
        sd[0],
        q(0.05),
        q(0.95),
        v[v.len() - 1]
    )
}

/// The upper arm of a generated population beside ANSUR II, per sex.
#[derive(Parser)]
struct Args {
    /// A generated population's dataset file: its bodies are measured.
    #[arg(value_name = "FILE.tsd")]
    path: String,
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args = tapeshape_common::cli::parse_or_exit::<Args>();
    let path = args.path;
    let d = tapeshape_population::Dataset::read(std::path::Path::new(&path))?;
    let anatomy = tapeshape_body::anatomy::anatomy();
    let quick = MeasurementSet::builtin("quick")?.compile(&d.topology, &anatomy)?;
    let paper = MeasurementSet::builtin("paper34")?.compile(&d.topology, &anatomy)?;
    let upper = quick
        .set()
        .index_of("upper_arm")
        .ok_or("quick has no upper_arm")?;
    let members: Vec<usize> = RIGHT_LOOP
        .iter()
        .map(|m| paper.set().index_of(m).ok_or(format!("paper34 has no {m}")))
        .collect::<Result<_, _>>()?;
    let ansur = Ansur::get()?;
    for sex in [Sex::Male, Sex::Female] {
        let (mut girth, mut looped, mut limit) = (Vec::new(), Vec::new(), Vec::new());
        for (record, verts) in d.header.bodies.iter().zip(&d.bodies) {
            if record.sex != Some(sex) {
                continue;
            }
            let g = 100.0 * quick.measure_one(upper, verts)?.value;
            let mut l = 0.0;
            for &m in &members {
                l += 100.0 * paper.measure_one(m, verts)?.value;
            }
            girth.push(g);
            looped.push(l);
            if record
                .phenotype
                .as_ref()
                .is_some_and(|p| p.muscle >= AT_LIMIT && p.weight >= AT_LIMIT)
            {
                limit.push(g);
            }
        }
        let mut flexed: Vec<f64> = ansur
            .subjects(Some(sex), Split::Train)
            .filter_map(|s| s.dim("bicepscircumferenceflexed"))
            .map(|m| 100.0 * m)
            .collect();
        let n = girth.len();
        println!("{} ({n} bodies)", sex.word());
        println!(
            "  upper_arm (relaxed, plane cut):   {}",
            summary(&mut girth)
        );
        println!(
            "  paper34 right arm loop (sum of 4): {}",
            summary(&mut looped)
        );
        println!(
            "  muscle and weight >= {AT_LIMIT}: {} bodies, upper_arm {}",
            limit.len(),
            summary(&mut limit)
        );
        println!(
            "  ANSUR II train split, biceps flexed ({} subjects): {}",
            flexed.len(),
            summary(&mut flexed)
        );
    }
    Ok(())
}
