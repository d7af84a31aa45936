//! Properties over random valid charts (one-dimensional rows and
//! two-dimensional grids with missing cells) and random readings: a
//! garment's probabilities sum to at most 1, the best size has the highest
//! probability (within the documented tie), and exact readings give a
//! certain answer.

mod common;

use proptest::prelude::*;
use tapeshape_sizes::{recommend, Chart, Readings, PROBABILITY_TIE};

/// Consecutive edges in mm from a start and widths.
fn edges(start: u32, widths: &[u32]) -> Vec<u32> {
    let mut e = vec![start];
    for w in widths {
        e.push(e.last().unwrap() + w);
    }
    e
}

/// A trousers-like grid (waist columns by inside-leg rows) in mm, with the
/// cells `present[i][j]` says (every row and column keeps one).
fn grid_chart(waist: &[u32], leg: &[u32], present: &[Vec<bool>]) -> String {
    let mut text = String::from(
        "[chart]\nname = \"random\"\nunits = \"mm\"\n\n[[garment]]\nname = \"trousers\"\nprimary = [\"waist\", \"inside_leg\"]\nsize = [\n",
    );
    for i in 0..waist.len() - 1 {
        for j in 0..leg.len() - 1 {
            if present[i][j] {
                text += &format!(
                    "  {{ label = \"{i}/{j}\", waist = [{}, {}], inside_leg = [{}, {}] }},\n",
                    waist[i],
                    waist[i + 1],
                    leg[j],
                    leg[j + 1]
                );
            }
        }
    }
    text + "]\n"
}

fn grid() -> impl Strategy<Value = String> {
    (
        500u32..1200,
        prop::collection::vec(5u32..120, 1..6),
        600u32..900,
        prop::collection::vec(5u32..60, 1..5),
        prop::collection::vec(any::<bool>(), 30),
    )
        .prop_map(|(w0, ww, l0, lw, mask)| {
            let (c, r) = (ww.len(), lw.len());
            let mut present = vec![vec![false; r]; c];
            for i in 0..c {
                for j in 0..r {
                    present[i][j] = mask[(i * r + j) % mask.len()];
                }
            }
            // Keep every column and every row.
            for i in 0..c.max(r) {
                present[i % c][i % r] = true;
            }
            grid_chart(&edges(w0, &ww), &edges(l0, &lw), &present)
        })
}

fn sd() -> impl Strategy<Value = f64> {
    prop_oneof![Just(0.0), 0.5f64..150.0]
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(300))]

    #[test]
    fn probabilities_sum_to_at_most_one_and_the_best_is_the_most_likely(
        text in grid(),
        waist in 300.0f64..2000.0,
        waist_sd in sd(),
        leg in 400.0f64..1100.0,
        leg_sd in sd(),
        estimated in any::<bool>(),
    ) {
        let chart = Chart::from_toml_str(&text, "random", &common::known());
        prop_assert!(chart.is_ok(), "{:?}\n{text}", chart.err());
        let chart = chart.unwrap();
        let mut readings = Readings::new();
        if estimated {
            readings.insert_estimated("waist", waist, waist_sd).unwrap();
        } else {
            readings.insert_measured("waist", waist, waist_sd).unwrap();
        }
        readings.insert_measured("inside_leg", leg, leg_sd).unwrap();
        let r = recommend(&chart, &readings);
        let fit = &r.garments[0];
        let best = fit.best.as_ref().unwrap();
        let sum: f64 = fit.probabilities.iter().map(|s| s.probability).sum();
        prop_assert!(sum <= 1.0 + 1e-12, "sum {sum}");
        let max = fit.probabilities.iter().map(|s| s.probability).fold(0.0, f64::max);
        prop_assert!(best.probability >= max - PROBABILITY_TIE, "best {} max {max}", best.probability);
        for s in &fit.probabilities {
            prop_assert!((0.0..=1.0).contains(&s.probability));
        }
        if let Some(between) = &fit.between {
            prop_assert_ne!(&between.other.label, &best.label);
            prop_assert!(between.other.probability <= best.probability + PROBABILITY_TIE);
        }
        let holder = chart.garments()[0].sizes().iter().find(|s| {
            s.interval("waist").unwrap().contains(waist) && s.interval("inside_leg").unwrap().contains(leg)
        });
        if waist_sd == 0.0 && leg_sd == 0.0 {
            // Exact readings: certainty, in the size that holds them if any.
            match holder {
                Some(size) => {
                    prop_assert_eq!(&best.label, size.label());
                    prop_assert_eq!(best.probability, 1.0);
                    prop_assert_eq!(sum, 1.0);
                    prop_assert!(fit.between.is_none());
                }
                None => prop_assert_eq!(sum, 0.0),
            }
        }
        // A holder never loses to a size that misses, unless less likely.
        if let Some(size) = holder {
            if !best.holds_readings {
                let p = fit.probabilities.iter().find(|s| s.label == size.label()).unwrap().probability;
                prop_assert!(best.probability > p + PROBABILITY_TIE);
            }
        }
    }
}
