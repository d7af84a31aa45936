//! The measurement-set file loader (`MeasurementSet::from_toml_str`, what
//! `MeasurementSet::from_path` and `tapeshape measure --set FILE` read), then
//! compiling an accepted set against the real template's topology and anatomy,
//! as the station does before measuring: no panic, only typed errors; an
//! accepted set has at least one measurement, unique names, and its groups
//! index its own measurements.
#![no_main]

use std::sync::OnceLock;

use libfuzzer_sys::fuzz_target;
use tapeshape_body::BodyModel;
use tapeshape_measure::MeasurementSet;
use tapeshape_mesh::{Anatomy, Topology};

fn template() -> &'static (std::sync::Arc<Topology>, Anatomy) {
    static T: OnceLock<(std::sync::Arc<Topology>, Anatomy)> = OnceLock::new();
    T.get_or_init(|| {
        let model = BodyModel::shared().expect("the embedded body model loads");
        (model.topology().clone(), tapeshape_body::anatomy::anatomy())
    })
}

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    let Ok(set) = MeasurementSet::from_toml_str(text, "fuzz") else {
        return;
    };
    assert!(!set.is_empty());
    let mut names: Vec<&str> = set.definitions.iter().map(|d| d.name.as_str()).collect();
    names.sort_unstable();
    names.dedup();
    assert_eq!(names.len(), set.len());
    for (_, members) in set.groups() {
        assert!(members.iter().all(|&i| i < set.len()));
    }
    let (topology, anatomy) = template();
    let _ = set.compile(topology, anatomy);
});
