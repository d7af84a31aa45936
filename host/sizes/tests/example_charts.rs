//! The shipped example charts (`examples/size-charts/`): they parse and
//! validate against the station's measurement names, and they are what
//! `make_example_charts` writes today (so the committed files and the
//! documented rule cannot drift apart).

#[path = "../examples/make_example_charts.rs"]
#[allow(dead_code)]
mod make_example_charts;

use tapeshape_measure::{Class, MeasurementSet};
use tapeshape_population::ansur::Sex;
use tapeshape_sizes::{recommend, Chart, DimensionKind, KnownDimension, Readings};

/// The station's names: the quick and ansur sets, kinds from their classes
/// (the mapping `DimensionKind` documents).
fn station_names() -> Vec<KnownDimension> {
    let mut known: Vec<KnownDimension> = Vec::new();
    for set in ["quick", "ansur"] {
        for d in MeasurementSet::builtin(set).unwrap().definitions {
            let kind = match d.class {
                Class::Girth => DimensionKind::Girth,
                Class::Length | Class::Height | Class::Arc => DimensionKind::Length,
                Class::Breadth | Class::Depth => DimensionKind::Breadth,
            };
            if !known.iter().any(|k| k.name == d.name) {
                known.push(KnownDimension::new(d.name, kind));
            }
        }
    }
    known
}

fn shipped(sex: Sex) -> (String, Chart) {
    let path = make_example_charts::chart_path(sex);
    let text = std::fs::read_to_string(&path).unwrap();
    let chart = Chart::from_path(&path, &station_names())
        .unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    (text, chart)
}

#[test]
fn the_shipped_charts_validate_against_the_station_names() {
    let (text, men) = shipped(Sex::Male);
    assert!(text.starts_with("# EXAMPLE size chart (menswear), NOT any brand's"));
    let garments: Vec<&str> = men.garments().iter().map(|g| g.name()).collect();
    assert_eq!(garments, ["shirt", "jacket", "trousers"]);
    let (text, women) = shipped(Sex::Female);
    assert!(text.starts_with("# EXAMPLE size chart (womenswear), NOT any brand's"));
    let garments: Vec<&str> = women.garments().iter().map(|g| g.name()).collect();
    assert_eq!(garments, ["shirt", "jacket", "dress", "trousers"]);
    for chart in [&men, &women] {
        assert!(chart.name().contains("not a brand's chart"));
        for g in chart.garments() {
            assert!(g.sizes().len() >= 5, "{}: {}", chart.name(), g.name());
        }
    }
}

#[test]
fn the_shipped_charts_are_what_the_program_writes() {
    for sex in [Sex::Male, Sex::Female] {
        let written = make_example_charts::chart_text(sex).unwrap();
        let (committed, _) = shipped(sex);
        assert!(
            written == committed,
            "{} is out of date: run `cargo run -p tapeshape-sizes --example make_example_charts`",
            make_example_charts::chart_path(sex).display()
        );
    }
}

#[test]
fn readings_at_the_centre_of_a_size_get_that_size() {
    // Chest 104 cm: the centre of shirt M [100, 108) and jacket 52
    // [102, 106); waist 96 and inside leg 84 cm: the centre of W96/L84.
    let (_, men) = shipped(Sex::Male);
    let mut readings = Readings::new();
    readings.insert_measured("chest", 1040.0, 9.0).unwrap();
    readings.insert_measured("waist", 960.0, 9.0).unwrap();
    readings.insert_measured("inside_leg", 840.0, 4.0).unwrap();
    let r = recommend(&men, &readings);
    let best: Vec<&str> = r
        .garments
        .iter()
        .map(|g| g.best.as_ref().unwrap().label.as_str())
        .collect();
    assert_eq!(best, ["M", "52", "W96/L84"]);
    // The secondary dimensions were not given: reported, not skipped.
    let shirt = &r.garments[0];
    let missing: Vec<&str> = shirt.missing.iter().map(|m| m.dimension.as_str()).collect();
    assert_eq!(missing, ["neck", "arm_length"]);
}
