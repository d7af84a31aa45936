//! Tests of `set`, in a file of their own so that the module stays short.

use super::*;

const HEADER: &str = "[set]\nname = \"t\"\ndescription = \"test\"\n";

fn parse(body: &str) -> Result<MeasurementSet, MeasureError> {
    MeasurementSet::from_toml_str(&format!("{HEADER}{body}"), "t")
}

const GOOD: &str = r#"
[[measurement]]
name = "a"
label = "A"
description = "d"
kind = "euclidean"
from = "x"
to = "y"
tolerance = "segment_length"
"#;

#[test]
fn builtin_sets_parse_with_expected_counts() {
    let counts = [("paper34", 34), ("quick", 9), ("face7", 7)];
    for (name, n) in counts {
        let s = MeasurementSet::builtin(name).unwrap();
        assert_eq!(s.len(), n, "{name}");
        assert_eq!(s.name, name);
    }
    let ansur = MeasurementSet::builtin("ansur").unwrap();
    assert!(ansur.len() >= 25, "ansur has {}", ansur.len());
    assert!(ansur.definitions.iter().all(|d| d.ansur.is_some()));
}

#[test]
fn paper34_has_the_papers_composition() {
    let s = MeasurementSet::builtin("paper34").unwrap();
    let count = |k: &str| s.definitions.iter().filter(|d| d.kind.name() == k).count();
    assert_eq!(count("euclidean"), 14);
    assert_eq!(count("circumference"), 4);
    assert_eq!(count("geodesic"), 16);
    let groups = s.groups();
    assert_eq!(groups.len(), 4);
    assert!(groups.iter().all(|(_, m)| m.len() == 4));
}

#[test]
fn good_entry_parses_and_infers_class() {
    let s = parse(GOOD).unwrap();
    assert_eq!(s.definitions[0].class, Class::Length);
    assert_eq!(s.definitions[0].tolerance.mm(), 5.0);
}

#[test]
fn unknown_kind_names_entry_and_suggests() {
    let e = parse(&GOOD.replace("\"euclidean\"", "\"euclidian\""))
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("`a`") && e.contains("did you mean `euclidean`"),
        "{e}"
    );
}

#[test]
fn missing_field_duplicate_and_unknown_field_are_errors() {
    let e = parse(&GOOD.replace("to = \"y\"\n", ""))
        .unwrap_err()
        .to_string();
    assert!(e.contains("missing field `to`"), "{e}");
    let e = parse(&format!("{GOOD}{GOOD}")).unwrap_err().to_string();
    assert!(e.contains("duplicate name") && e.contains("#2"), "{e}");
    let e = parse(&GOOD.replace("to = ", "too = "))
        .unwrap_err()
        .to_string();
    assert!(e.contains("missing field `to`"), "{e}");
    let e = parse(&format!("{GOOD}grup = \"g\"\n"))
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("unknown field `grup`") && e.contains("`group`"),
        "{e}"
    );
    let e = parse(&format!("{GOOD}ansur = \"statur\"\n"))
        .unwrap_err()
        .to_string();
    assert!(e.contains("did you mean `stature`"), "{e}");
}

#[test]
fn bad_vectors_are_errors() {
    let circ = r#"
[[measurement]]
name = "c"
label = "C"
description = "d"
kind = "breadth"
anchor = "x"
normal = [0, 0, 1]
axis = [0, 0.5, 1]
parts = ["torso"]
tolerance = "breadth"
"#;
    let e = parse(circ).unwrap_err().to_string();
    assert!(e.contains("must lie in the plane"), "{e}");
    let e = parse(&circ.replace("[0, 0, 1]", "[0, 0, 0]"))
        .unwrap_err()
        .to_string();
    assert!(e.contains("non-zero"), "{e}");
    let ok = parse(&circ.replace("[0, 0.5, 1]", "[2, 0, 0]")).unwrap();
    match &ok.definitions[0].kind {
        Kind::Breadth { axis, .. } => assert_eq!(*axis, [1.0, 0.0, 0.0]),
        k => panic!("{k:?}"),
    }
}

#[test]
fn unknown_set_suggests() {
    let e = MeasurementSet::load("paper43").unwrap_err().to_string();
    assert!(e.contains("did you mean `paper34`"), "{e}");
}
