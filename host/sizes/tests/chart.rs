//! The chart file: what a valid one becomes, and every error's message.

mod common;

use common::{hand_made, known, HAND_MADE};
use tapeshape_sizes::{Chart, ChartProblem, DimensionKind, Role, Units};

/// A one-garment chart around `garment` (a `[[garment]]` block, TOML).
fn chart(units: &str, garment: &str) -> String {
    format!("[chart]\nname = \"t\"\nunits = \"{units}\"\n\n{garment}")
}

fn error(text: &str) -> String {
    let e = Chart::from_toml_str(text, "store.toml", &known()).expect_err("the chart is invalid");
    let message = e.to_string();
    assert!(
        message.starts_with("size chart store.toml: "),
        "the message names the file: {message}"
    );
    message
}

fn problem(text: &str) -> ChartProblem {
    Chart::from_toml_str(text, "store.toml", &known())
        .expect_err("the chart is invalid")
        .problem
        .as_ref()
        .clone()
}

fn assert_contains(message: &str, parts: &[&str]) {
    for p in parts {
        assert!(message.contains(p), "`{p}` missing from: {message}");
    }
}

#[test]
fn a_valid_chart_is_read_in_millimetres_with_its_grid() {
    let chart = hand_made();
    assert_eq!(chart.name(), "hand-made test chart");
    assert_eq!(chart.units(), Units::Cm);
    assert_eq!(chart.description(), Some("Known answers for the tests."));
    let names: Vec<&str> = chart.garments().iter().map(|g| g.name()).collect();
    assert_eq!(names, ["shirt", "trousers", "dress"]);

    let shirt = chart.garment("shirt").unwrap();
    assert_eq!(shirt.primary().len(), 1);
    assert_eq!(shirt.primary()[0].name(), "chest");
    assert_eq!(shirt.primary()[0].kind(), DimensionKind::Girth);
    assert_eq!(shirt.secondary()[0].name(), "arm_length");
    assert_eq!(shirt.secondary()[0].role(), Role::Secondary);
    assert_eq!(shirt.secondary()[0].kind(), DimensionKind::Length);
    let m = &shirt.sizes()[1];
    assert_eq!(m.label(), "M");
    let chest = m.interval("chest").unwrap();
    assert_eq!((chest.lo_mm(), chest.hi_mm()), (960.0, 1040.0));
    assert_eq!(m.interval("arm_length").unwrap().hi_mm(), 640.0);
    // A secondary dimension a size leaves out.
    assert!(shirt.sizes()[3].interval("arm_length").is_none());

    // Inline-table sizes read the same as [[garment.size]] ones.
    let trousers = chart.garment("trousers").unwrap();
    assert_eq!(trousers.sizes().len(), 4);
    let cell = &trousers.sizes()[3];
    assert_eq!(cell.label(), "W88/L82");
    assert_eq!(cell.interval("waist").unwrap().lo_mm(), 840.0);
    assert_eq!(cell.interval("inside_leg").unwrap().hi_mm(), 840.0);
}

#[test]
fn millimetre_charts_are_taken_as_written() {
    let c = Chart::from_toml_str(
        &chart(
            "mm",
            "[[garment]]\nname = \"shirt\"\nprimary = [\"chest\"]\n[[garment.size]]\nlabel = \"M\"\nchest = [960.5, 1040]\n",
        ),
        "t",
        &known(),
    )
    .unwrap();
    let i = c.garments()[0].sizes()[0].interval("chest").unwrap();
    assert_eq!((i.lo_mm(), i.hi_mm()), (960.5, 1040.0));
}

#[test]
fn a_grid_may_miss_a_cell() {
    // No W88/L82: allowed, the customer there is between sizes.
    let text = chart(
        "cm",
        r#"[[garment]]
name = "trousers"
primary = ["waist", "inside_leg"]
size = [
    { label = "W80/L78", waist = [76, 84], inside_leg = [76, 80] },
    { label = "W80/L82", waist = [76, 84], inside_leg = [80, 84] },
    { label = "W88/L78", waist = [84, 92], inside_leg = [76, 80] },
]"#,
    );
    assert!(Chart::from_toml_str(&text, "t", &known()).is_ok());
}

#[test]
fn unknown_dimension_names_the_garment_the_size_and_the_closest_name() {
    let in_size = HAND_MADE.replacen("arm_length = [58, 62]", "chets = [1, 2]", 1);
    let m = error(&in_size);
    assert_contains(
        &m,
        &[
            "garment `shirt`",
            "size `S`",
            "unknown dimension `chets`",
            "did you mean `chest`?",
            "station's measurement names",
        ],
    );
    let in_list = HAND_MADE.replacen(
        "secondary = [\"arm_length\"]",
        "secondary = [\"arm_lenght\"]",
        1,
    );
    let m = error(&in_list);
    assert_contains(
        &m,
        &[
            "garment `shirt`: unknown dimension `arm_lenght`",
            "did you mean `arm_length`?",
        ],
    );
    assert!(!m.contains("size `"), "no size in a list error: {m}");
    assert!(matches!(
        problem(&in_list),
        ChartProblem::UnknownDimension { size: None, .. }
    ));
}

#[test]
fn a_known_dimension_the_garment_does_not_declare_is_refused() {
    let text = HAND_MADE.replacen("arm_length = [58, 62]", "hip = [90, 100]", 1);
    assert_contains(
        &error(&text),
        &[
            "garment `shirt`, size `S`",
            "`hip` is neither a primary nor a secondary dimension of `shirt`",
            "add it to `secondary`",
        ],
    );
}

#[test]
fn an_empty_or_non_finite_interval_is_refused() {
    let backwards = HAND_MADE.replacen("chest = [96, 104]", "chest = [104, 96]", 1);
    let m = error(&backwards);
    assert_contains(
        &m,
        &[
            "garment `shirt`, size `M`, dimension `chest`",
            "[104, 96]",
            "is empty",
            "smaller bound first",
        ],
    );
    let equal = HAND_MADE.replacen("chest = [96, 104]", "chest = [96, 96]", 1);
    assert!(
        matches!(problem(&equal), ChartProblem::EmptyInterval { lo, hi, .. } if lo == 96.0 && hi == 96.0)
    );
    for bad in ["[nan, 104]", "[96, inf]", "[-inf, 104]"] {
        let text = HAND_MADE.replacen("chest = [96, 104]", &format!("chest = {bad}"), 1);
        let m = error(&text);
        assert_contains(
            &m,
            &[
                "garment `shirt`, size `M`, dimension `chest`",
                "not a finite number",
            ],
        );
    }
    let one = HAND_MADE.replacen("chest = [96, 104]", "chest = [96]", 1);
    assert_contains(
        &error(&one),
        &[
            "size `M`, dimension `chest`",
            "not a pair of numbers",
            "`chest = [lo, hi]`",
        ],
    );
    let text = HAND_MADE.replacen("chest = [96, 104]", "chest = [\"96\", 104]", 1);
    assert_contains(
        &error(&text),
        &["size `M`, dimension `chest`", "not a number"],
    );
}

#[test]
fn overlapping_sizes_are_refused_naming_both_and_the_dimension() {
    let text = HAND_MADE.replacen("chest = [104, 112]", "chest = [100, 112]", 1);
    let m = error(&text);
    assert_contains(
        &m,
        &[
            "garment `shirt`",
            "sizes `M` [96, 104) cm and `L` [100, 112) cm overlap along `chest`",
            "end where the other's begins",
        ],
    );
    // Two sizes on one cell of a one-dimensional chart.
    let same = HAND_MADE.replacen("chest = [104, 112]", "chest = [96, 104]", 1);
    let m = error(&same);
    assert_contains(
        &m,
        &["sizes `M` and `L` have the same intervals", "(chest)"],
    );
    // Two cells of a grid that share only part of a column overlap too
    // (the sizes must sit on one grid); the same column is fine.
    let off_grid = HAND_MADE.replacen(
        "{ label = \"W88/L82\", waist = [84, 92]",
        "{ label = \"W88/L82\", waist = [86, 92]",
        1,
    );
    assert_contains(
        &error(&off_grid),
        &["garment `trousers`", "overlap along `waist`"],
    );
    let same_cell = HAND_MADE.replacen(
        "{ label = \"W88/L82\", waist = [84, 92], inside_leg = [80, 84] }",
        "{ label = \"W88/L82\", waist = [84, 92], inside_leg = [76, 80] }",
        1,
    );
    assert_contains(
        &error(&same_cell),
        &["sizes `W88/L78` and `W88/L82` have the same intervals along every primary dimension (waist, inside_leg)"],
    );
}

#[test]
fn a_gap_between_consecutive_sizes_is_refused_with_its_range() {
    let text = HAND_MADE.replacen("chest = [104, 112]", "chest = [105, 112]", 1);
    let m = error(&text);
    assert_contains(
        &m,
        &[
            "garment `shirt`: a gap along `chest` between size `M` [96, 104) cm and size `L` [105, 112) cm",
            "from 104 to 105 cm would fit no size",
            "Make `M` end where `L` begins",
        ],
    );
    // Along the second dimension of a grid.
    let leg = HAND_MADE.replace("inside_leg = [80, 84]", "inside_leg = [81, 84]");
    assert_contains(
        &error(&leg),
        &["a gap along `inside_leg`", "from 80 to 81 cm"],
    );
    // Along a diagonal, each dimension on its own.
    let dress = HAND_MADE.replacen("hip = [102, 106]", "hip = [103, 106]", 1);
    assert!(matches!(
        problem(&dress),
        ChartProblem::Gap { ref garment, ref dimension, ref below, ref above, .. }
            if garment == "dress" && dimension == "hip" && below == "40" && above == "42"
    ));
}

#[test]
fn a_size_missing_a_primary_dimension_is_refused() {
    let text = HAND_MADE.replacen(
        "{ label = \"W80/L82\", waist = [76, 84], inside_leg = [80, 84] }",
        "{ label = \"W80/L82\", waist = [76, 84] }",
        1,
    );
    assert_contains(
        &error(&text),
        &[
            "garment `trousers`, size `W80/L82`",
            "no interval for the primary dimension `inside_leg`",
            "every size needs one",
        ],
    );
}

#[test]
fn duplicate_labels_and_garments_are_refused() {
    let text = HAND_MADE.replacen("label = \"L\"", "label = \"M\"", 1);
    assert_contains(
        &error(&text),
        &[
            "garment `shirt` has two sizes labelled `M`",
            "its own label",
        ],
    );
    let text = HAND_MADE.replacen("name = \"dress\"", "name = \"shirt\"", 1);
    assert_contains(&error(&text), &["garment `shirt` appears twice"]);
}

#[test]
fn an_empty_garment_or_chart_is_refused() {
    let text = chart(
        "cm",
        "[[garment]]\nname = \"jacket\"\nprimary = [\"chest\"]\n",
    );
    assert_contains(
        &error(&text),
        &["garment `jacket` has no sizes", "add `[[garment.size]]`"],
    );
    let text = chart(
        "cm",
        "[[garment]]\nname = \"jacket\"\nprimary = []\n[[garment.size]]\nlabel = \"M\"\n",
    );
    assert_contains(
        &error(&text),
        &["garment `jacket` has no primary dimension"],
    );
    assert_contains(&error(&chart("cm", "")), &["the chart has no garments"]);
    let text = chart("cm", "[[garment]]\nname = \"jacket\"\nprimary = [\"chest\"]\n[[garment.size]]\nchest = [96, 104]\n");
    assert_contains(
        &error(&text),
        &["garment `jacket`, size number 1: no `label`"],
    );
}

#[test]
fn units_must_be_mm_or_cm() {
    let text = HAND_MADE.replacen("units = \"cm\"", "units = \"in\"", 1);
    assert_contains(
        &error(&text),
        &[
            "units `in` are not known",
            "`units = \"mm\"` or `units = \"cm\"`",
        ],
    );
    let text = HAND_MADE.replacen("units = \"cm\"\n", "", 1);
    assert_contains(&error(&text), &["missing field `units`"]);
}

#[test]
fn toml_errors_and_misspelt_fields_say_where() {
    let m = error("[chart\nname = 1");
    assert!(m.contains("line 1"), "{m}");
    let text = HAND_MADE.replacen(
        "secondary = [\"arm_length\"]",
        "secondry = [\"arm_length\"]",
        1,
    );
    assert_contains(&error(&text), &["unknown field `secondry`"]);
}

#[test]
fn a_dimension_named_twice_is_refused() {
    let text = HAND_MADE.replacen("secondary = [\"arm_length\"]", "secondary = [\"chest\"]", 1);
    assert_contains(
        &error(&text),
        &[
            "garment `shirt` lists dimension `chest` twice",
            "in `primary` or in `secondary`",
        ],
    );
}

#[test]
fn from_path_names_the_file_it_cannot_read() {
    let e =
        Chart::from_path(std::path::Path::new("/nonexistent/chart.toml"), &known()).unwrap_err();
    assert_eq!(e.origin, "/nonexistent/chart.toml");
    assert!(e.to_string().contains("cannot read it"), "{e}");
}
