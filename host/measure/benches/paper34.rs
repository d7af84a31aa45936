//! Benchmark: all `paper34` measurements on one body (target: at most 20 ms
//! on one core), plus compiling the set and the other built-in sets.
//! Results and the command: docs/results/measure-bench.md.

use criterion::{criterion_main, Criterion};
use tapeshape_body::BodyModel;
use tapeshape_measure::MeasurementSet;

fn bench(c: &mut Criterion) {
    let model = BodyModel::shared().expect("body model");
    let anatomy = tapeshape_body::anatomy::anatomy();
    let template = model.template();
    let topo = model.topology();
    let paper34 = MeasurementSet::builtin("paper34").unwrap();
    c.bench_function("compile paper34 (per topology, once)", |b| {
        b.iter(|| paper34.compile(topo, &anatomy).unwrap())
    });
    for name in ["paper34", "ansur", "quick", "face7"] {
        let set = MeasurementSet::builtin(name).unwrap();
        let compiled = set.compile(topo, &anatomy).unwrap();
        c.bench_function(
            &format!("measure {name} ({} values) on one body", set.len()),
            |b| {
                b.iter(|| {
                    compiled
                        .measure(std::hint::black_box(&template.vertices))
                        .unwrap()
                })
            },
        );
    }
    let compiled = paper34.compile(topo, &anatomy).unwrap();
    for (i, d) in paper34.definitions.iter().enumerate() {
        if [
            "hip_circumference",
            "knee_left_front_lateral",
            "foot_length_left",
        ]
        .contains(&d.name.as_str())
        {
            c.bench_function(
                &format!("measure_one {} ({})", d.name, d.kind.name()),
                |b| {
                    b.iter(|| {
                        compiled
                            .measure_one(i, std::hint::black_box(&template.vertices))
                            .unwrap()
                    })
                },
            );
        }
    }
}

/// The benchmark group (written out instead of `criterion_group!`, whose
/// generated function has no docs and so fails the workspace's missing_docs lint).
fn benches() {
    let mut c = Criterion::default().configure_from_args();
    bench(&mut c);
}

criterion_main!(benches);
