//! Body-generator benchmark: load time, and the time to generate 1,000 bodies
//! with random adult phenotypes (target: at most 5 s), single-threaded.
//!
//! Run: `cargo bench -p tapeshape-body --bench generate`
//! (prints its figures; recorded in docs/results/body-bench.md).

use std::time::Instant;

use tapeshape_body::{age_from_years, BodyModel, LocalChanges, Param, Phenotype};

/// Small deterministic generator (SplitMix64) so every run blends the same bodies.
struct Rng(u64);

impl Rng {
    fn next_f64(&mut self) -> f64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^= z >> 31;
        (z >> 11) as f64 / (1u64 << 53) as f64
    }
}

fn random_body(rng: &mut Rng, n_local: usize) -> (Phenotype, LocalChanges) {
    let ph = Phenotype {
        gender: rng.next_f64(),
        age: age_from_years(18.0 + 72.0 * rng.next_f64()).unwrap(),
        muscle: rng.next_f64(),
        weight: rng.next_f64(),
        height: rng.next_f64(),
        proportions: rng.next_f64(),
        cupsize: rng.next_f64(),
        firmness: rng.next_f64(),
        african: rng.next_f64(),
        asian: rng.next_f64(),
        caucasian: rng.next_f64() + 0.01,
    };
    let labels = LocalChanges::labels();
    let mut lc = LocalChanges::new();
    for _ in 0..n_local {
        let i = (rng.next_f64() * labels.len() as f64) as usize % labels.len();
        lc.set(&labels[i], 2.0 * rng.next_f64() - 1.0).unwrap();
    }
    (ph, lc)
}

fn main() {
    let t = Instant::now();
    let model = BodyModel::load().expect("embedded model loads");
    println!("load: {:.3} s", t.elapsed().as_secs_f64());

    for n_local in [0, 20] {
        let mut rng = Rng(42);
        let bodies: Vec<_> = (0..1000).map(|_| random_body(&mut rng, n_local)).collect();
        let mut runs = Vec::new();
        let mut checksum = 0.0;
        for _ in 0..3 {
            let t = Instant::now();
            for (ph, lc) in &bodies {
                let m = model.generate(ph, lc).unwrap();
                checksum += m.vertices[0][2];
            }
            runs.push(t.elapsed().as_secs_f64());
        }
        runs.sort_by(f64::total_cmp);
        println!(
            "generate 1000 bodies ({n_local} local changes each): best {:.3} s, median {:.3} s ({:.2} ms/body) [checksum {checksum:.6}]",
            runs[0],
            runs[1],
            runs[1] * 1e3 / 1000.0
        );
    }

    let mut rng = Rng(7);
    let (ph, lc) = random_body(&mut rng, 0);
    let t = Instant::now();
    let n = 20;
    for _ in 0..n {
        let full = model.generate_full(&ph, &lc).unwrap();
        assert_eq!(full.len(), 19_158);
    }
    println!(
        "generate_full (19,158 vertices): {:.2} ms/body",
        t.elapsed().as_secs_f64() * 1e3 / n as f64
    );
    let n = 20;
    let t = Instant::now();
    for _ in 0..n {
        let j = model.jacobian(&ph, &lc, &Param::MACRO).unwrap();
        assert_eq!((j.len(), j[0].len()), (11, 13_718));
    }
    println!(
        "jacobian, 11 macro parameters: {:.2} ms per call",
        t.elapsed().as_secs_f64() * 1e3 / n as f64
    );
    // A fitting step as the population fitter does it: body + derivatives
    // by height, weight, muscle, proportions and 4 local changes.
    let mut params = vec![
        Param::Height,
        Param::Weight,
        Param::Muscle,
        Param::Proportions,
    ];
    for label in [
        "measure-waist-circ-incr",
        "measure-hips-circ-incr",
        "measure-bust-circ-incr",
        "measure-neck-circ-incr",
    ] {
        params.push(Param::local(label).unwrap());
    }
    let t = Instant::now();
    for _ in 0..n {
        let (body, j) = model.generate_with_jacobian(&ph, &lc, &params).unwrap();
        assert_eq!((body.vertices.len(), j.len()), (13_718, 8));
    }
    println!(
        "generate_with_jacobian, 4 macro + 4 local parameters: {:.2} ms per call",
        t.elapsed().as_secs_f64() * 1e3 / n as f64
    );
}
