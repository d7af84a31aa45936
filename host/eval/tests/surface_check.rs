//! The surface check (issue 12, "Show") as CI can afford it: a small
//! generated population is the envelope (24 bodies, the default model's
//! generator settings, seed 1), the rule is calibrated on 8 generated
//! held-out bodies (seed 2), never on people; then
//!
//! * the first 4 ANSUR II test-split men and 4 women, entered with their
//!   `quick` readings and sex into the embedded default model, all pass;
//! * a held-out body with a deliberate crease (a band of the chest pushed
//!   in and out by 6 mm, vertex by vertex) fails, and the same body without
//!   it passes;
//! * the body issue 12 reports creased (subject 10032 with all 44 `ansur`
//!   readings) fails (a check of the rule, not its calibration).
//!
//! With so small an envelope the calibration gives a wide margin (20
//! degrees) and the test-split people pass with little headroom (the
//! largest, 10080, 0.088 % against 0.10 %); deterministic (seeded), so a
//! change that tips it is a change in the bodies worth looking at.
//!
//! The full measurement (the 400-body envelope, all 1,505 test-split
//! people, the `ansur` set) is in docs/results/real-customers/surface-check.md.

use tapeshape_estimator::{Estimator, PredictOptions};
use tapeshape_eval::customers::{entered_readings, inputs_of, test_people, CustomersOptions};
use tapeshape_eval::surface::SurfaceCheck;
use tapeshape_mesh::{Mesh, Vec3};
use tapeshape_population::ansur::Ansur;
use tapeshape_population::{generate_population, PopulationSettings};

fn population(n: usize, seed: u64) -> tapeshape_population::Dataset {
    let settings = PopulationSettings {
        n,
        seed,
        ..PopulationSettings::default()
    };
    generate_population(&settings, &|_, _| {}).expect("a generated population")
}

/// `v` with the front of the chest (z 1.15..1.40 m on a body of stature
/// about 1.7 m, y in front of the body's middle) pushed along the vertex
/// normals by +-`depth` m, alternating with the vertex index: a field of
/// small creases.
fn creased(v: &[Vec3], mesh_of: impl Fn(Vec<Vec3>) -> Mesh, depth: f64) -> (Vec<Vec3>, usize) {
    let top = v.iter().map(|p| p[2]).fold(f64::MIN, f64::max);
    let normals = mesh_of(v.to_vec()).vertex_normals();
    let mut out = v.to_vec();
    let mut moved = 0;
    for (i, (p, n)) in out.iter_mut().zip(&normals).enumerate() {
        let z = p[2] / top;
        if (0.68..0.82).contains(&z) && p[1] > 0.05 && p[0].abs() < 0.15 {
            let s = if i % 2 == 0 { depth } else { -depth };
            for k in 0..3 {
                p[k] += s * n[k];
            }
            moved += 1;
        }
    }
    (out, moved)
}

#[test]
fn quick_bodies_pass_and_a_creased_body_fails() {
    let train = population(24, 1);
    let held = population(8, 2);
    let check = SurfaceCheck::from_datasets(&train, Some(&held)).expect("envelope and rule");
    let deg = 180.0 / std::f64::consts::PI;
    eprintln!(
        "rule from {} training bodies: margin {:.1} deg, at most {:.3} % of {} edges",
        check.envelope.bodies(),
        check.rule.delta * deg,
        100.0 * check.rule.max_share,
        check.envelope.edges().len()
    );
    assert!(check.rule.max_share < 0.01, "{:?}", check.rule);
    // A training body sits inside its own envelope exactly.
    let own = check.envelope.excess(&train.bodies[3], 0.0).unwrap();
    assert_eq!(own.count, 0);
    assert!(own.worst <= 0.0);
    // Every held-out body passes the rule calibrated on them.
    for b in &held.bodies {
        assert!(check.judge(b).unwrap().pass);
    }

    // Test-split people with their quick readings.
    let estimator = Estimator::default_model().expect("embedded model");
    check
        .envelope
        .check_topology(estimator.topology())
        .expect("the model's template is the generator's");
    let opts = CustomersOptions {
        input_set: "quick".into(),
        with_sex: true,
        per_sex: Some(4),
        leave_out: Vec::new(),
        ansur_survey: false,
        options: PredictOptions::default(),
    };
    let entered = entered_readings(estimator, &opts).unwrap();
    assert_eq!(entered.len(), 9);
    let ansur = Ansur::get().unwrap();
    for s in test_people(ansur, opts.per_sex) {
        let est = estimator
            .predict(&inputs_of(s, &entered, true), &opts.options)
            .unwrap_or_else(|e| panic!("{}: {e}", s.id));
        let v = check.judge(&est.mesh.vertices).unwrap();
        eprintln!(
            "{} {:?}: {} edges beyond ({:.3} %), worst {:.1} deg",
            s.id,
            s.sex,
            v.excess.count,
            100.0 * v.excess.share(),
            v.excess.worst * deg
        );
        assert!(v.pass, "test-split person {} fails: {:?}", s.id, v.excess);
    }

    // A deliberately creased body fails; the same body unchanged passes.
    let body = &held.bodies[0];
    let topology = held.topology.clone();
    let (bad, moved) = creased(
        body,
        |v| Mesh {
            vertices: v,
            topology: topology.clone(),
        },
        0.006,
    );
    assert!(moved > 100, "the crease band holds {moved} vertices");
    let v = check.judge(&bad).unwrap();
    eprintln!(
        "creased: {moved} vertices moved, {} edges beyond ({:.3} %)",
        v.excess.count,
        100.0 * v.excess.share()
    );
    assert!(!v.pass, "{:?}", v.excess);
    assert!(v.excess.share() > 2.0 * check.rule.max_share);
    assert!(check.judge(body).unwrap().pass);

    // The body issue 12 reports creased (subject 10032, all 44 `ansur`
    // readings) fails too: a check of the rule, not its calibration.
    let opts = CustomersOptions {
        input_set: "ansur".into(),
        ..opts
    };
    let entered = entered_readings(estimator, &opts).unwrap();
    assert_eq!(entered.len(), 44);
    let s = ansur.subject(10032).expect("subject 10032");
    let est = estimator
        .predict(&inputs_of(s, &entered, true), &opts.options)
        .expect("10032 with the ansur set");
    let v = check.judge(&est.mesh.vertices).unwrap();
    eprintln!(
        "10032 ansur: {} edges beyond ({:.3} %)",
        v.excess.count,
        100.0 * v.excess.share()
    );
    assert!(!v.pass, "{:?}", v.excess);
}
