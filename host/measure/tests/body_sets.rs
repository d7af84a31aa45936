//! Every built-in set compiles against the real template anatomy
//! (tapeshape-body) and measures plausible values on the template and on
//! generated bodies: each ANSUR-mapped value must lie within ANSUR II's
//! observed range (men and women together, from the survey's table of
//! dimensions committed as `host/population/data/ansur2/definitions.csv`),
//! widened by 15% for the mismatches the sets document (relaxed vs flexed arms,
//! skin vs bone, synthetic bodies at the edges of the population).
//! No measurement is skipped: a measurement whose two landmarks are the same
//! vertex (which measures nothing) fails.

use std::collections::BTreeMap;

use tapeshape_body::{BodyModel, LocalChanges, Phenotype};
use tapeshape_measure::MeasurementSet;
use tapeshape_mesh::Vec3;

/// ANSUR column -> (min, max) over men and women, millimetres.
fn ansur_ranges() -> BTreeMap<String, (f64, f64)> {
    // The survey's table as committed in the repository (tapeshape-population
    // embeds the same folder; origin and licence in its README.md).
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../population/data/ansur2/definitions.csv"
    );
    let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{path}: {e}"));
    let mut out = BTreeMap::new();
    for line in text.lines().skip(1) {
        // Quoted fields hold commas: take the column name (field 2) and the
        // last eight numeric fields (male mean, sd, min, max, female ...).
        let fields: Vec<&str> = line.split(',').collect();
        let n = fields.len();
        let num = |i: usize| fields[n - 8 + i].trim().parse::<f64>().unwrap();
        out.insert(
            fields[1].to_string(),
            (num(2).min(num(6)), num(3).max(num(7))),
        );
    }
    out
}

/// Every two-landmark measurement (but `height`, whose second landmark is
/// the floor it stands on) joins two different vertices of the anatomy; the
/// same vertex twice would measure nothing (an anatomy defect, not an
/// operator's: `biceps_front_*` and `biceps_medial_*` were one vertex until
/// commit 4e24c13 fixed the arm section the rule cuts).
fn assert_landmarks_distinct(set: &MeasurementSet, anatomy: &tapeshape_mesh::Anatomy) {
    for d in &set.definitions {
        if let [a, b] = d.kind.landmarks().as_slice() {
            if d.kind.name() != "height" {
                assert_ne!(
                    anatomy.landmarks.get(*a),
                    anatomy.landmarks.get(*b),
                    "{}/{}: landmarks `{a}` and `{b}` are the same vertex",
                    set.name,
                    d.name
                );
            }
        }
    }
}

fn bodies() -> Vec<(String, Vec<Vec3>)> {
    let model = BodyModel::shared().unwrap();
    let mut out = vec![("template".to_string(), model.template().vertices)];
    let cases = [
        (
            "male",
            Phenotype {
                gender: 0.0,
                height: 0.39,
                ..Phenotype::default()
            },
        ),
        (
            "female",
            Phenotype {
                gender: 1.0,
                height: 0.35,
                ..Phenotype::default()
            },
        ),
        (
            "heavy_male",
            Phenotype {
                gender: 0.0,
                weight: 0.9,
                muscle: 0.4,
                ..Phenotype::default()
            },
        ),
        (
            "thin_tall_female",
            Phenotype {
                gender: 1.0,
                weight: 0.1,
                height: 0.55,
                ..Phenotype::default()
            },
        ),
    ];
    for (name, ph) in cases {
        let m = model.generate(&ph, &LocalChanges::new()).unwrap();
        out.push((name.to_string(), m.vertices));
    }
    out
}

#[test]
fn every_set_measures_plausible_values_on_real_bodies() {
    let model = BodyModel::shared().unwrap();
    let anatomy = tapeshape_body::anatomy::anatomy();
    let ranges = ansur_ranges();
    let bodies = bodies();
    let mut failures = Vec::new();
    for set in MeasurementSet::builtins().unwrap() {
        let c = set.compile(model.topology(), &anatomy).unwrap();
        assert_landmarks_distinct(&set, &anatomy);
        for (body, p) in &bodies {
            let results = c
                .measure(p)
                .unwrap_or_else(|e| panic!("{} on {body}: {e}", set.name));
            for (d, m) in set.definitions.iter().zip(&results) {
                assert_eq!(m.support.length(p), m.value);
                let mm = m.value * 1000.0;
                println!("{:8} {:16} {:36} {:8.1} mm", set.name, body, d.name, mm);
                if let Some(col) = &d.ansur {
                    let (lo, hi) = ranges[col];
                    if !(mm >= 0.85 * lo && mm <= 1.15 * hi) {
                        failures.push(format!(
                            "{}/{} on {body}: {mm:.1} mm outside ANSUR {col} [{lo}, {hi}]",
                            set.name, d.name
                        ));
                    }
                }
                if !(mm > 10.0 && mm < 2300.0) {
                    failures.push(format!("{}/{} on {body}: {mm:.1} mm", set.name, d.name));
                }
            }
        }
    }
    assert!(
        failures.is_empty(),
        "{} implausible values:\n{}",
        failures.len(),
        failures.join("\n")
    );
}

#[test]
fn group_sums_and_batches_on_real_bodies() {
    let model = BodyModel::shared().unwrap();
    let anatomy = tapeshape_body::anatomy::anatomy();
    let set = MeasurementSet::builtin("paper34").unwrap();
    let c = set.compile(model.topology(), &anatomy).unwrap();
    assert_landmarks_distinct(&set, &anatomy);
    let bodies = bodies();
    let refs: Vec<&[Vec3]> = bodies.iter().map(|(_, p)| p.as_slice()).collect();
    let batch = c.measure_batch(&refs);
    for ((name, p), res) in bodies.iter().zip(batch) {
        let res = res.unwrap();
        assert_eq!(res, c.measure(p).unwrap());
        for (group, members) in set.groups() {
            let sum: f64 = members.iter().map(|&i| res[i].value).sum::<f64>() * 1000.0;
            // A knee or upper-arm loop of four geodesics: 200-600 mm on adults.
            assert!(
                (200.0..600.0).contains(&sum),
                "{group} on {name}: {sum:.1} mm"
            );
        }
    }
}
