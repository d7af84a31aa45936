//! Generates a small population and prints fit quality and timing (scratch check).
fn main() {
    let n: usize = std::env::args()
        .nth(1)
        .and_then(|a| a.parse().ok())
        .unwrap_or(4);
    let t = std::time::Instant::now();
    let s = tapeshape_engine::dataset::PopulationSettings {
        n,
        seed: 7,
        ..Default::default()
    };
    let d = tapeshape_engine::dataset::generate_population(&s, &|_, _| {}).unwrap();
    println!("{} bodies in {:?}", d.len(), t.elapsed());
    for r in &d.header.bodies {
        let f = r.fit.as_ref().unwrap();
        println!(
            "{} {:?} it={} max={:.2}mm",
            r.name, r.sex, f.iterations, f.max_error_mm
        );
        for (k, t) in &f.target_mm {
            println!("   {k:28} target {t:7.1} got {:7.1}", f.achieved_mm[k]);
        }
        println!(
            "   locals {:?}",
            r.local_changes
                .iter()
                .filter(|(k, _)| k.starts_with("measure"))
                .collect::<Vec<_>>()
        );
    }
}
