//! The experiment pipeline with trivial methods whose answers are known:
//! a method that returns the true body must score zero error and zero
//! vertex distance; one that always returns the training mean body must
//! score exactly |measurement of the mean - target| per dimension.

use std::sync::Arc;

use tapeshape_eval::experiments::common::{
    informative, measure_all, run_all, training_data, Case, Dimensions, Reference,
};
use tapeshape_eval::{Method, MethodError, MethodOutput};
use tapeshape_measure::MeasurementSet;
use tapeshape_mesh::Vec3;
use tapeshape_population::{generate_population, PopulationSettings};

/// Returns the stored body whose measurements equal the targets.
struct Truth {
    targets: Vec<Vec<Option<f64>>>,
    bodies: Vec<Vec<Vec3>>,
}

impl Method for Truth {
    fn name(&self) -> &str {
        "truth"
    }
    fn predict(&self, t: &[Option<f64>]) -> Result<MethodOutput, MethodError> {
        let i = self
            .targets
            .iter()
            .position(|x| x.as_slice() == t)
            .ok_or_else(|| MethodError::Predict {
                method: "truth".into(),
                message: "unknown targets".into(),
            })?;
        Ok(MethodOutput {
            vertices: self.bodies[i].clone(),
            weights: None,
        })
    }
}

/// Always the training mean body.
struct MeanBody(Vec<Vec3>);

impl Method for MeanBody {
    fn name(&self) -> &str {
        "mean body"
    }
    fn predict(&self, _t: &[Option<f64>]) -> Result<MethodOutput, MethodError> {
        Ok(MethodOutput {
            vertices: self.0.clone(),
            weights: None,
        })
    }
}

#[test]
fn known_answers_give_known_errors() {
    let pop = generate_population(
        &PopulationSettings {
            n: 8,
            seed: 5,
            ..Default::default()
        },
        &|_, _| {},
    )
    .unwrap();
    let set = MeasurementSet::load("paper34").unwrap();
    let anatomy = tapeshape_body::anatomy::anatomy();
    let train: Vec<Vec<Vec3>> = pop.bodies[..6].to_vec();
    let held: Vec<Vec<Vec3>> = pop.bodies[6..].to_vec();
    let data = training_data(train, &pop.topology, &set, &anatomy).unwrap();
    let used = informative(&data.measurements);
    let dims = Dimensions::of(&set, &used);
    // 14 lengths + 4 circumferences + 4 loops of 4 geodesics.
    assert_eq!(dims.len(), 22);
    assert!(dims.members.iter().filter(|m| m.len() == 4).count() == 4);
    let reference = Reference::new(&data).unwrap();
    let cases: Vec<Case> = held
        .iter()
        .map(|b| {
            let all = measure_all(&data.compiled, b);
            let mut t = vec![None; all.len()];
            for &j in &used {
                t[j] = Some(all[j]);
            }
            Case {
                targets: t,
                truth: Some(b.clone()),
                keep: false,
            }
        })
        .collect();
    let methods: Vec<Box<dyn Method>> = vec![
        Box::new(Truth {
            targets: cases.iter().map(|c| c.targets.clone()).collect(),
            bodies: held.clone(),
        }),
        Box::new(MeanBody(reference.mean.clone())),
    ];
    let res = run_all(&methods, &cases, &data.compiled, &dims, &reference, "test");
    for o in &res[0] {
        assert!(o.failure.is_none());
        assert!(o.errors.iter().all(|e| *e == 0.0), "{:?}", o.errors);
        assert_eq!(o.vertex_distance, Some((0.0, 0.0)));
    }
    let mean_m = measure_all(&data.compiled, &reference.mean);
    for (c, o) in cases.iter().zip(&res[1]) {
        for (d, members) in dims.members.iter().enumerate() {
            let want: f64 = members
                .iter()
                .map(|&j| (mean_m[j] - c.targets[j].unwrap()).abs() * 1000.0)
                .sum();
            assert!(
                (o.errors[d] - want).abs() < 1e-9,
                "{} vs {want}",
                o.errors[d]
            );
        }
        // The mean body is the most plausible body there is.
        assert!(o.plausibility.0 < 1e-6, "{}", o.plausibility.0);
        assert!(o.vertex_distance.unwrap().0 > 1.0);
    }
    let _ = Arc::strong_count(&data.topology);
}
