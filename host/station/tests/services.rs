//! The station's services over the embedded model: an operator's stated
//! reading uncertainty reaches the reading check.

use tapeshape::services::station::{reading_tolerance_m, StationServices};
use tapeshape::services::{CheckRequest, Services as _};
use tapeshape::session::Sessions;
use tapeshape_estimator::Unit;

fn chest_after_stature(chest_mm: f64) -> CheckRequest {
    CheckRequest {
        set: "quick".into(),
        name: "chest".into(),
        value_mm: chest_mm,
        others: vec![("stature".into(), 1760.0)],
        tape_unit: Unit::Cm,
    }
}

#[test]
fn a_stated_uncertainty_widens_what_the_check_accepts() {
    // 58 cm of chest on a 176 cm person is many SDs off for a skilled
    // measurer's reading...
    let dir = tempfile::tempdir().unwrap();
    let sessions = Sessions::open(dir.path()).unwrap();
    let services = |tolerance| StationServices::new(sessions.clone(), tolerance);
    let skilled = services(None).check(&chest_after_stature(580.0));
    assert!(skilled.flag.is_some(), "{skilled:?}");
    // ...but with 10 cm of stated reading uncertainty (a wildly unsure
    // operator) it is no longer a "measure again".
    let unsure = services(Some(0.1)).check(&chest_after_stature(580.0));
    assert!(unsure.flag.is_none(), "{unsure:?}");
    // A typical chest passes either way.
    assert!(services(None)
        .check(&chest_after_stature(980.0))
        .flag
        .is_none());
}

#[test]
fn the_tolerance_option_is_millimetres_and_must_be_sensible() {
    assert_eq!(reading_tolerance_m(None).unwrap(), None);
    assert_eq!(reading_tolerance_m(Some(10.0)).unwrap(), Some(0.01));
    for bad in [0.0, -3.0, f64::NAN, f64::INFINITY, 1000.0] {
        let e = reading_tolerance_m(Some(bad)).unwrap_err().to_string();
        assert!(e.contains("millimetres"), "{e}");
    }
}
