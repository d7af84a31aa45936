//! Recommendations on the hand-made chart with known answers. Expected
//! probabilities were computed separately from the normal CDF (Python's
//! `math.erfc`), not by this crate.

mod common;

use common::hand_made;
use tapeshape_sizes::{
    recommend, BetweenReason, Edge, GarmentFit, Position, ReadingError, Readings, Role, Side,
    Source,
};

fn close(a: f64, b: f64, tol: f64) -> bool {
    (a - b).abs() <= tol
}

fn garment<'a>(r: &'a tapeshape_sizes::Recommendation, name: &str) -> &'a GarmentFit {
    r.garments.iter().find(|g| g.garment == name).unwrap()
}

fn shirt_for(chest_mm: f64, sd_mm: f64, estimated: bool) -> GarmentFit {
    let mut readings = Readings::new();
    if estimated {
        readings.insert_estimated("chest", chest_mm, sd_mm).unwrap();
    } else {
        readings.insert_measured("chest", chest_mm, sd_mm).unwrap();
    }
    readings.insert_measured("arm_length", 620.0, 5.0).unwrap();
    garment(&recommend(&hand_made(), &readings), "shirt").clone()
}

fn probability(fit: &GarmentFit, label: &str) -> f64 {
    fit.probabilities
        .iter()
        .find(|s| s.label == label)
        .unwrap()
        .probability
}

#[test]
fn exactly_on_an_edge_belongs_to_the_upper_size_lo_inclusive_hi_exclusive() {
    // Exact reading: M is [960, 1040), L is [1040, 1120).
    let fit = shirt_for(1040.0, 0.0, false);
    let best = fit.best.as_ref().unwrap();
    assert_eq!(best.label, "L");
    assert!(best.holds_readings);
    assert_eq!(best.probability, 1.0);
    assert_eq!(
        best.placements[0].position,
        Position::Inside {
            nearer: Edge::Lower,
            distance_mm: 0.0
        }
    );
    assert_eq!(probability(&fit, "M"), 0.0);
    assert!(fit.between.is_none(), "an exact reading has no doubt");
    // Just below the edge is M.
    let fit = shirt_for(1039.999, 0.0, false);
    assert_eq!(fit.best.as_ref().unwrap().label, "M");

    // With the tape's 9 mm: both sizes equally likely (0.5 each, to 1e-12),
    // the tie goes to the size that holds the reading, and M is named as
    // the other size, the reading 0 mm from its upper edge.
    let fit = shirt_for(1040.0, 9.0, false);
    let best = fit.best.as_ref().unwrap();
    assert_eq!(best.label, "L");
    assert!(close(probability(&fit, "M"), 0.5, 1e-12));
    assert!(close(probability(&fit, "L"), 0.5, 1e-12));
    let between = fit.between.as_ref().expect("between M and L");
    assert_eq!(between.other.label, "M");
    assert_eq!(
        between.other.placements[0].position,
        Position::Above { by_mm: 0.0 }
    );
    assert_eq!(between.other.placements[0].words, "tight at the chest");
    match &between.reason {
        BetweenReason::NearEdge {
            dimension,
            edge_mm,
            distance_mm,
            ..
        } => {
            assert_eq!(dimension, "chest");
            assert_eq!(*edge_mm, 1040.0);
            assert_eq!(*distance_mm, 0.0);
        }
        other => panic!("expected NearEdge, got {other:?}"),
    }
}

#[test]
fn close_to_an_edge_is_between_two_sizes_with_the_reason() {
    // 1037 mm, 9 mm SD: M 0.63056, L 0.36944; L/M = 0.586 >= 0.5.
    let fit = shirt_for(1037.0, 9.0, false);
    let best = fit.best.as_ref().unwrap();
    assert_eq!(best.label, "M");
    assert!(close(best.probability, 0.630_558_659_818_236_3, 1e-12));
    assert_eq!(
        best.placements[0].position,
        Position::Inside {
            nearer: Edge::Upper,
            distance_mm: 3.0
        }
    );
    assert_eq!(
        best.placements[0].words,
        "fits at the chest, 3 mm from the upper edge"
    );
    let between = fit.between.as_ref().expect("between M and L");
    assert_eq!(between.other.label, "L");
    assert!(close(
        between.other.probability,
        0.369_441_340_181_763_67,
        1e-12
    ));
    assert_eq!(between.other.placements[0].words, "loose at the chest");
    assert!(matches!(
        between.reason,
        BetweenReason::NearEdge { ref dimension, value_mm, edge_mm, distance_mm, source: Source::Measured { sd_mm } }
            if dimension == "chest" && value_mm == 1037.0 && edge_mm == 1040.0 && distance_mm == 3.0 && sd_mm == 9.0
    ));
    let text = fit.to_string();
    assert!(
        text.contains("between M and L (37 %): chest 1037 mm (measured ±9 mm) is 3 mm below the edge of M at 1040 mm"),
        "{text}"
    );

    // 10 mm inside: L is only 0.15 of M: a plain fit.
    let fit = shirt_for(1030.0, 9.0, false);
    assert_eq!(fit.best.as_ref().unwrap().label, "M");
    assert!(fit.between.is_none());
}

#[test]
fn sizes_that_point_different_ways_are_between_with_both_misfits() {
    let chart = hand_made();
    // Chest in 38's [860, 900), hip in 40's [980, 1020): no size holds both.
    let mut readings = Readings::new();
    readings.insert_measured("chest", 880.0, 0.0).unwrap();
    readings.insert_measured("hip", 990.0, 0.0).unwrap();
    let r = recommend(&chart, &readings);
    let dress = garment(&r, "dress");
    let best = dress.best.as_ref().unwrap();
    // 38 misses by 10 mm (hip), 40 by 20 mm (chest).
    assert_eq!(best.label, "38");
    assert!(!best.holds_readings);
    assert!(dress.beyond.is_empty());
    let between = dress.between.as_ref().expect("between 38 and 40");
    assert_eq!(between.other.label, "40");
    assert_eq!(between.reason, BetweenReason::NoSizeHoldsAll);
    assert_eq!(best.placements[1].words, "tight at the hip");
    assert_eq!(best.placements[1].position, Position::Above { by_mm: 10.0 });
    assert_eq!(between.other.placements[0].words, "loose at the chest");
    let json = serde_json::to_value(dress).unwrap();
    assert_eq!(json["between"]["reason"], "no_size_holds_all");
    assert_eq!(json["between"]["other"]["label"], "40");
    let text = dress.to_string();
    assert!(
        text.contains("between 38 and 40 (0 %): no size holds every reading; 38 is tight at the hip, 40 is loose at the chest"),
        "{text}"
    );

    // Equal misses (5 mm each way): the looser size.
    let mut readings = Readings::new();
    readings.insert_measured("chest", 895.0, 0.0).unwrap();
    readings.insert_measured("hip", 985.0, 0.0).unwrap();
    let r = recommend(&chart, &readings);
    let dress = garment(&r, "dress");
    assert_eq!(dress.best.as_ref().unwrap().label, "40");
    assert_eq!(dress.between.as_ref().unwrap().other.label, "38");

    // A missing cell of a grid: waist W88 column, leg L82 row, and no
    // W88/L82 cell.
    let text = common::HAND_MADE.replace(
        "    { label = \"W88/L82\", waist = [84, 92], inside_leg = [80, 84] },\n",
        "",
    );
    let gappy = tapeshape_sizes::Chart::from_toml_str(&text, "t", &common::known()).unwrap();
    let mut readings = Readings::new();
    readings.insert_measured("waist", 860.0, 0.0).unwrap();
    readings.insert_measured("inside_leg", 810.0, 0.0).unwrap();
    let r = recommend(&gappy, &readings);
    let trousers = garment(&r, "trousers");
    assert!(trousers.beyond.is_empty());
    let between = trousers.between.as_ref().expect("between two cells");
    assert_eq!(between.reason, BetweenReason::NoSizeHoldsAll);
    let mut pair = [
        trousers.best.as_ref().unwrap().label.as_str(),
        between.other.label.as_str(),
    ];
    pair.sort();
    // W80/L82 misses by 20 mm (waist), W88/L78 by 10 mm (leg).
    assert_eq!(trousers.best.as_ref().unwrap().label, "W88/L78");
    assert_eq!(pair, ["W80/L82", "W88/L78"]);
    assert_eq!(
        trousers.best.as_ref().unwrap().placements[1].words,
        "too short for the inside leg"
    );
}

#[test]
fn smaller_than_the_smallest_and_larger_than_the_largest() {
    // S is [880, 960): 860 is 20 mm below.
    for sd in [0.0, 9.0] {
        let fit = shirt_for(860.0, sd, false);
        let best = fit.best.as_ref().unwrap();
        assert_eq!(best.label, "S", "sd {sd}");
        assert_eq!(best.placements[0].position, Position::Below { by_mm: 20.0 });
        assert_eq!(best.placements[0].words, "loose at the chest");
        assert_eq!(fit.beyond.len(), 1);
        assert_eq!(fit.beyond[0].side, Side::Below);
        assert_eq!(fit.beyond[0].by_mm, 20.0);
        assert!(fit.between.is_none(), "sd {sd}: {:?}", fit.between);
    }
    // XL is [1120, 1200): 1250 is 50 mm above; with 9 mm SD, P(XL) = 1.38e-8.
    for sd in [0.0, 9.0] {
        let fit = shirt_for(1250.0, sd, false);
        let best = fit.best.as_ref().unwrap();
        assert_eq!(best.label, "XL", "sd {sd}");
        assert_eq!(best.placements[0].words, "tight at the chest");
        assert_eq!(fit.beyond[0].side, Side::Above);
        assert_eq!(fit.beyond[0].by_mm, 50.0);
        assert!(fit.between.is_none());
        let expected = if sd == 0.0 {
            0.0
        } else {
            1.383_650_895_776_884_2e-8
        };
        assert!(
            close(best.probability, expected, 1e-20),
            "{}",
            best.probability
        );
        assert!(fit
            .to_string()
            .contains("beyond the chart: chest 50 mm above every size"));
    }
}

#[test]
fn an_estimated_dimension_with_a_wide_spread_spreads_the_probabilities() {
    // Chest not measured, estimated 1000 mm with SD 50 mm.
    let fit = shirt_for(1000.0, 50.0, true);
    let expected = [
        ("S", 0.203_657_862_658_800_56),
        ("M", 0.576_289_202_833_206_7),
        ("L", 0.203_657_862_658_800_56),
        ("XL", 0.008_165_864_682_763_018),
    ];
    for (label, p) in expected {
        assert!(close(probability(&fit, label), p, 1e-12), "{label}");
    }
    let sum: f64 = fit.probabilities.iter().map(|s| s.probability).sum();
    assert!(sum <= 1.0 && sum > 0.99, "{sum}");
    assert_eq!(fit.best.as_ref().unwrap().label, "M");
    assert!(fit.between.is_none(), "L/M = 0.35 < 0.5");
    // Which reading is which.
    let chest = fit
        .readings
        .iter()
        .find(|r| r.dimension == "chest")
        .unwrap();
    assert_eq!(chest.source, Source::Estimated { sd_mm: 50.0 });
    assert_eq!(chest.role, Role::Primary);
    let arm = fit
        .readings
        .iter()
        .find(|r| r.dimension == "arm_length")
        .unwrap();
    assert_eq!(arm.source, Source::Measured { sd_mm: 5.0 });
    assert_eq!(arm.role, Role::Secondary);
    assert!(fit.to_string().contains("estimated ±50 mm"));

    // SD 80 mm: M 0.383, L = S 0.242 (0.63 of M): between M and L (the
    // tie with S goes to the looser size), 40 mm from M's upper edge.
    let fit = shirt_for(1000.0, 80.0, true);
    assert!(close(
        probability(&fit, "M"),
        0.382_924_922_548_026_24,
        1e-12
    ));
    let between = fit.between.as_ref().expect("between");
    assert_eq!(between.other.label, "L");
    assert!(matches!(
        between.reason,
        BetweenReason::NearEdge { distance_mm, edge_mm, source: Source::Estimated { .. }, .. }
            if distance_mm == 40.0 && edge_mm == 1040.0
    ));
}

#[test]
fn a_two_dimensional_size_multiplies_its_dimensions() {
    // Waist at the centre of W80's [760, 840) with SD 40 (k = 1), leg at the
    // centre of L78's [760, 800) with SD 10 (k = 2): erf(1/√2)·erf(2/√2).
    let mut readings = Readings::new();
    readings.insert_estimated("waist", 800.0, 40.0).unwrap();
    readings.insert_measured("inside_leg", 780.0, 10.0).unwrap();
    let r = recommend(&hand_made(), &readings);
    let trousers = garment(&r, "trousers");
    let best = trousers.best.as_ref().unwrap();
    assert_eq!(best.label, "W80/L78");
    let expected = 0.682_689_492_137_085_9 * 0.954_499_736_103_641_6;
    assert!(
        close(best.probability, expected, 1e-12),
        "{}",
        best.probability
    );
    // The secondary hip was not given: reported missing, not skipped.
    assert_eq!(trousers.missing.len(), 1);
    assert_eq!(trousers.missing[0].dimension, "hip");
    assert_eq!(trousers.missing[0].role, Role::Secondary);
}

#[test]
fn a_primary_dimension_without_a_reading_leaves_the_garment_without_a_size() {
    let mut readings = Readings::new();
    readings.insert_measured("waist", 800.0, 9.0).unwrap();
    let r = recommend(&hand_made(), &readings);
    let trousers = garment(&r, "trousers");
    assert!(trousers.best.is_none());
    assert!(trousers.probabilities.is_empty());
    let missing: Vec<(&str, Role)> = trousers
        .missing
        .iter()
        .map(|m| (m.dimension.as_str(), m.role))
        .collect();
    assert_eq!(
        missing,
        [("inside_leg", Role::Primary), ("hip", Role::Secondary)]
    );
    assert_eq!(
        trousers.to_string(),
        "trousers: no size: inside_leg neither measured nor estimated\n"
    );
    // Every garment is reported, none skipped.
    assert_eq!(r.garments.len(), 3);
    assert!(r.garments.iter().all(|g| g.best.is_none()));
}

#[test]
fn measured_readings_win_over_estimated_and_bad_readings_are_refused() {
    let mut readings = Readings::new();
    readings.insert_estimated("chest", 1100.0, 30.0).unwrap();
    readings.insert_measured("chest", 1000.0, 9.0).unwrap();
    readings.insert_estimated("chest", 900.0, 30.0).unwrap();
    assert_eq!(readings.get("chest").unwrap().value_mm(), 1000.0);
    assert_eq!(
        readings.get("chest").unwrap().source(),
        Source::Measured { sd_mm: 9.0 }
    );
    let twice = readings.insert_measured("chest", 1001.0, 9.0).unwrap_err();
    assert!(matches!(twice, ReadingError::Twice { .. }));
    assert!(twice.to_string().contains("chest: given twice as measured"));
    for bad in [f64::NAN, 0.0, -5.0, f64::INFINITY] {
        let e = Readings::new()
            .insert_measured("waist", bad, 9.0)
            .unwrap_err();
        assert!(e.to_string().starts_with("waist: "), "{e}");
        assert!(e.to_string().contains("not a body length"), "{e}");
    }
    for bad in [f64::NAN, -1.0, f64::INFINITY] {
        let e = Readings::new()
            .insert_estimated("waist", 800.0, bad)
            .unwrap_err();
        assert!(e.to_string().contains("cannot be used"), "{e}");
    }
}

#[test]
fn the_result_serialises_for_the_report() {
    let fit = shirt_for(1037.0, 9.0, false);
    let mut readings = Readings::new();
    readings.insert_measured("chest", 1037.0, 9.0).unwrap();
    let r = recommend(&hand_made(), &readings);
    let json = serde_json::to_value(&r).unwrap();
    assert_eq!(json["chart"], "hand-made test chart");
    assert_eq!(
        serde_json::to_value(&readings).unwrap()["chest"],
        serde_json::json!({ "value_mm": 1037.0, "source": "measured", "sd_mm": 9.0 })
    );
    let shirt = &json["garments"][0];
    assert_eq!(shirt["garment"], "shirt");
    assert_eq!(shirt["best"]["label"], "M");
    assert_eq!(shirt["best"]["placements"][0]["source"], "measured");
    assert_eq!(shirt["best"]["placements"][0]["sd_mm"], 9.0);
    assert_eq!(
        shirt["best"]["placements"][0]["position"]["where"],
        "inside"
    );
    assert_eq!(
        shirt["best"]["placements"][0]["position"]["nearer"],
        "upper"
    );
    assert_eq!(shirt["best"]["placements"][0]["interval"]["lo_mm"], 960.0);
    assert_eq!(shirt["between"]["reason"], "near_edge");
    assert_eq!(shirt["between"]["other"]["label"], "L");
    assert_eq!(shirt["missing"][0]["dimension"], "arm_length");
    assert_eq!(shirt["missing"][0]["role"], "secondary");
    assert_eq!(shirt["readings"][0]["source"], "measured");
    // The same garment fit as through shirt_for, less its arm reading.
    assert_eq!(
        fit.best.as_ref().unwrap().probability,
        shirt["best"]["probability"].as_f64().unwrap()
    );
}

#[test]
fn the_text_names_sizes_sources_and_misfits() {
    let mut readings = Readings::new();
    readings.insert_measured("chest", 1037.0, 9.0).unwrap();
    readings
        .insert_estimated("arm_length", 655.0, 21.0)
        .unwrap();
    let r = recommend(&hand_made(), &readings);
    let expected = "\
Sizes on \"hand-made test chart\" (mm; probabilities take the dimensions as independent normals)
shirt: M (63 %)
  between M and L (37 %): chest 1037 mm (measured ±9 mm) is 3 mm below the edge of M at 1040 mm
  chest            1037 mm  measured ±9 mm     M [960, 1040) mm           fits at the chest, 3 mm from the upper edge
  arm_length        655 mm  estimated ±21 mm   M [600, 640) mm            too short for the arm length (15 mm above)
  chest            1037 mm  measured ±9 mm     L [1040, 1120) mm          loose at the chest (3 mm below)
  sizes: M 63 %, L 37 %
trousers: no size: waist, inside_leg neither measured nor estimated
dress: no size: hip neither measured nor estimated
";
    assert_eq!(r.to_string(), expected);
}

/// Probabilities a hair apart (within the tie tolerance of their
/// neighbours but not of each other) once made the sort of sizes panic
/// ("comparison does not implement a total order") on the ANSUR II test
/// split (`size_agreement`); the sizes are now ranked by a scan. Forty 1 cm
/// sizes and a reading far below them with a wide spread give such a chain
/// of near-ties (the standard sort's check is heuristic, so this does not
/// always reproduce the old panic); the smallest size must win.
#[test]
fn near_tied_probabilities_never_panic_and_the_nearest_size_wins() {
    let mut text = String::from(
        "[chart]\nname = \"ties\"\nunits = \"cm\"\n[[garment]]\nname = \"shirt\"\nprimary = [\"chest\"]\nsize = [\n",
    );
    for k in 0..40 {
        text.push_str(&format!(
            "  {{ label = \"S{k}\", chest = [{}, {}] }},\n",
            100 + k,
            101 + k
        ));
    }
    text.push_str("]\n");
    let chart = tapeshape_sizes::Chart::from_toml_str(&text, "ties", &common::known()).unwrap();
    for sd in [5.0, 20.0, 60.0, 150.0] {
        let mut r = Readings::new();
        r.insert_estimated("chest", 700.0, sd).unwrap();
        let rec = recommend(&chart, &r);
        let best = rec.garments[0].best.as_ref().unwrap();
        assert_eq!(best.label, "S0", "sd {sd}: {best:?}");
    }
}
