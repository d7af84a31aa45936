//! The measurement behind `docs/results/demo-e2e.md`: held-out bodies whose
//! true mesh is known (the first 20 of `tests/tests/known_bodies`), the
//! `quick` and `ansur` sets, readings exact, with a novice's 1 cm noise, and
//! with that noise stated as the readings' tolerance; the estimator's estimate
//! directly (the serial path of the e2e test delivers the same 0.1 mm values,
//! as that test asserts).
//!
//! For each estimate it prints the mean vertex distance to the true body and
//! to the model's mean shape, and how well the estimate's own measurements
//! match: against the readings given (largest error in mm and in units of
//! the ISO 20685-1 allowable error) and against the true body's values.
//!
//! ```text
//! cargo run -p tapeshape-tests --example demo_measure [-- N]
//! ```
//! (N bodies, default 20; about a minute on two cores.)

#[path = "../tests/known_bodies/mod.rs"]
mod known_bodies;

use known_bodies::*;
use tapeshape::estimate::{start_estimate, tape_input};
use tapeshape_estimator::{Inputs, PredictOptions};

fn main() {
    let n: usize = match std::env::args().nth(1) {
        Some(a) => a.parse().expect("N: a number of bodies"),
        None => 20,
    };
    let data = held_out(n);
    let mean = mean_shape();
    let means: Vec<f64> = data
        .bodies
        .iter()
        .take(n)
        .map(|b| mean_distance_mm(&mean, b))
        .collect();
    let summary = |v: &[f64]| {
        let ok: Vec<f64> = v.iter().copied().filter(|x| x.is_finite()).collect();
        format!(
            "mean {:.2} max {:.2} (n = {}, refused {})",
            ok.iter().sum::<f64>() / ok.len() as f64,
            ok.iter().copied().fold(f64::MIN, f64::max),
            ok.len(),
            v.len() - ok.len()
        )
    };
    println!("mean shape: {}", summary(&means));
    let conditions = ["exact", "1 cm noise", "1 cm noise, 1 cm tolerance stated"];
    for set in ["quick", "ansur"] {
        let mut dist: [Vec<f64>; 3] = [Vec::new(), Vec::new(), Vec::new()];
        for (i, truth) in data.bodies.iter().take(n).enumerate() {
            let vals = set_values(truth, set);
            let seeded = Some((NOVICE_SD_M, NOISE_SEED + i as u64));
            for (k, (noise, tolerance)) in
                [(None, None), (seeded, None), (seeded, Some(NOVICE_SD_M))]
                    .into_iter()
                    .enumerate()
            {
                let given: Vec<(String, f64)> = tape_values(&vals, noise)
                    .iter()
                    .map(|(n, v)| (n.clone(), *v as f64 / 10_000.0))
                    .collect();
                let mut readings = Inputs::new();
                for (n, m) in &given {
                    readings
                        .push(tape_input(n.clone(), *m, tolerance))
                        .expect("distinct measurement names");
                }
                let est = start_estimate(estimator(), &readings, &PredictOptions::default())
                    .expect("the estimate starts")
                    .wait();
                let d = match est {
                    Ok(e) => {
                        let (vs_given_mm, vs_given_iso) =
                            worst_misfit(&e.mesh.vertices, &given, set);
                        let (vs_truth_mm, _) = worst_misfit(&e.mesh.vertices, &vals, set);
                        let d = mean_distance_mm(&e.mesh.vertices, truth);
                        println!(
                            "{set} body {i:2} {:34} vertex distance {d:6.2} mm (mean shape {:6.2}); \
                             worst measurement vs readings {vs_given_mm:5.1} mm = {vs_given_iso:4.2} x ISO, \
                             vs true body {vs_truth_mm:5.1} mm",
                            conditions[k], means[i]
                        );
                        d
                    }
                    Err(e) => {
                        println!("{set} body {i:2} {:34} refused: {e}", conditions[k]);
                        f64::NAN
                    }
                };
                dist[k].push(d);
            }
        }
        for (k, c) in conditions.iter().enumerate() {
            println!("{set} {c}: {}", summary(&dist[k]));
        }
    }
}
