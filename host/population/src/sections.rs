//! Shape changes that square the hip and waist sections (issue 12).
//!
//! At the same girth every body the MakeHuman generator makes is broader
//! and deeper than real people are: real people's buttock circumference is
//! 1.09 times the perimeter of the ellipse with their hip breadth and
//! buttock depth, the generator's bodies' 1.01-1.05 whatever its hip and
//! waist parameters (docs/population.md, "The hip and waist sections are
//! rounder than people's"). The two fields here push the torso's
//! horizontal sections out along their diagonals and leave their sides,
//! front and back where they are, so a body can have a real person's
//! girth, breadth and depth at once. Written here because no generator
//! asset has such a change; they are offsets over the template's vertices
//! like a MakeHuman target, added after the blend, so they are linear in
//! their coefficient and the fit's Jacobian column is the field itself.
//!
//! Each field is made once from the average adult (the default
//! [`Phenotype`]): a vertex of the torso (within 250 mm of the mid-plane,
//! so not the hands of the A-pose) at height `z` moves horizontally away
//! from the centre of its 10 mm slab of such vertices by
//! `UNIT_M * sin^2(2 theta) * w(z)`, `theta` the vertex's angle from the
//! side in the slab scaled to the slab's half-breadth and half-depth (0 at
//! the sides, front and back; largest on the diagonals). `w` is 1 over the
//! field's band and falls to 0 with a squared sine: the hip field's band
//! is from 20 mm below the buttock level to half-way up to the omphalion,
//! falling to the crotch (plus 10 mm) below and the omphalion above; the
//! waist field's from there to 20 mm above the omphalion, falling to the
//! buttock level below and 80 mm above the omphalion above. Between the
//! buttock level and the omphalion the two overlap (at the same
//! coefficient their sum peaks at twice a field's push half-way up), so a
//! body's fit can square its hips and its waist by different amounts.

use std::sync::OnceLock;

use tapeshape_body::{BodyModel, LocalChanges, Phenotype};
use tapeshape_mesh::Vec3;

use crate::DatasetError;

/// A field's largest push, metres per unit of its coefficient (10 mm).
pub const UNIT_M: f64 = 0.010;

/// Vertices further than this from the mid-plane (metres) are not moved:
/// the hands of the A-pose hang at the hips' height further out.
const TORSO_HALF_WIDTH_M: f64 = 0.25;

/// Height of a slab whose vertices give a section's centre and half-axes.
const SLAB_M: f64 = 0.010;

/// The two offset fields (one [`Vec3`] per template vertex, metres per
/// unit coefficient, station frame).
#[derive(Debug, Clone)]
pub struct SectionFields {
    /// Squares the hip (from the crotch to half-way up to the omphalion).
    pub hip: Vec<Vec3>,
    /// Squares the waist (around the omphalion).
    pub waist: Vec<Vec3>,
}

/// Perimeter of the ellipse with full axes `breadth` and `depth` (any unit,
/// the same one back), Ramanujan's second approximation (relative error
/// below 1e-4 for these aspect ratios).
pub fn ellipse_perimeter(breadth: f64, depth: f64) -> f64 {
    let (a, b) = (breadth / 2.0, depth / 2.0);
    let h = ((a - b) / (a + b)).powi(2);
    std::f64::consts::PI * (a + b) * (1.0 + 3.0 * h / (10.0 + (4.0 - 3.0 * h).sqrt()))
}

/// The fields of the shared body model, made on first use.
pub fn section_fields(body: &BodyModel) -> Result<&'static SectionFields, DatasetError> {
    static FIELDS: OnceLock<Result<SectionFields, String>> = OnceLock::new();
    FIELDS
        .get_or_init(|| make(body).map_err(|e| e.to_string()))
        .as_ref()
        .map_err(|e| DatasetError::Settings(format!("making the section fields: {e}")))
}

fn make(body: &BodyModel) -> Result<SectionFields, Box<dyn std::error::Error>> {
    let x = body
        .generate(&Phenotype::default(), &LocalChanges::new())?
        .vertices;
    let anatomy = tapeshape_body::anatomy::try_anatomy()?;
    let at = |name: &str| -> Result<Vec3, String> {
        anatomy
            .landmarks
            .get(name)
            .map(|&v| x[v as usize])
            .ok_or_else(|| format!("the template has no landmark {name:?}"))
    };
    let (crotch, buttock, omphalion) = (
        at("crotch")?[2],
        at("buttock_back")?[2],
        at("omphalion")?[2],
    );
    let middle = 0.5 * (buttock + omphalion);
    // Each slab's (min y, max y, max |x|) over the torso's vertices.
    let slab = |z: f64| (z / SLAB_M).floor() as i64;
    let mut slabs: std::collections::BTreeMap<i64, (f64, f64, f64)> = Default::default();
    for p in &x {
        if p[0].abs() > TORSO_HALF_WIDTH_M {
            continue;
        }
        let e = slabs
            .entry(slab(p[2]))
            .or_insert((f64::INFINITY, f64::NEG_INFINITY, 0.0));
        e.0 = e.0.min(p[1]);
        e.1 = e.1.max(p[1]);
        e.2 = e.2.max(p[0].abs());
    }
    let ramp = |t: f64| {
        (std::f64::consts::FRAC_PI_2 * t.clamp(0.0, 1.0))
            .sin()
            .powi(2)
    };
    // Weight of a band with its full part [b, c] and ramps from a and to d.
    let band = |z: f64, a: f64, b: f64, c: f64, d: f64| {
        if z <= a || z >= d {
            0.0
        } else if z < b {
            ramp((z - a) / (b - a))
        } else if z > c {
            ramp((d - z) / (d - c))
        } else {
            1.0
        }
    };
    let field = |weight: &dyn Fn(f64) -> f64| -> Vec<Vec3> {
        x.iter()
            .map(|p| {
                let w = weight(p[2]);
                if w == 0.0 || p[0].abs() > TORSO_HALF_WIDTH_M {
                    return [0.0; 3];
                }
                let Some(&(lo, hi, half_breadth)) = slabs.get(&slab(p[2])) else {
                    return [0.0; 3];
                };
                let (dx, dy) = (p[0], p[1] - 0.5 * (lo + hi));
                let r = dx.hypot(dy);
                let half_depth = 0.5 * (hi - lo);
                if r < 1e-6 || half_breadth <= 0.0 || half_depth <= 0.0 {
                    return [0.0; 3];
                }
                let theta = (dy / half_depth).atan2(dx / half_breadth);
                let push = UNIT_M * (2.0 * theta).sin().powi(2) * w;
                [push * dx / r, push * dy / r, 0.0]
            })
            .collect()
    };
    let hip = field(&|z| band(z, crotch + 0.010, buttock - 0.020, middle, omphalion));
    let waist = field(&|z| band(z, buttock, middle, omphalion + 0.020, omphalion + 0.080));
    Ok(SectionFields { hip, waist })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// What the fields are for: with them the hip and waist girths grow
    /// against the ellipse of their breadth and depth, which move by less
    /// than the push (the sections' extreme points are near, not at, the
    /// sides, front and back: 8 mm at most for a 15 mm push).
    #[test]
    fn the_fields_square_the_sections() {
        use tapeshape_measure::MeasurementSet;
        let body = BodyModel::shared().unwrap();
        let f = section_fields(body).unwrap();
        let set = MeasurementSet::builtin("ansur")
            .unwrap()
            .compile(body.topology(), &tapeshape_body::anatomy::anatomy())
            .unwrap();
        let m = |x: &[Vec3], n: &str| {
            set.measure_one(set.set().index_of(n).unwrap(), x)
                .unwrap()
                .value
        };
        let ratio =
            |x: &[Vec3], g: &str, b: &str, d: &str| m(x, g) / ellipse_perimeter(m(x, b), m(x, d));
        let x0 = body
            .generate(&Phenotype::default(), &LocalChanges::new())
            .unwrap()
            .vertices;
        let mut x = x0.clone();
        for (p, (h, w)) in x.iter_mut().zip(f.hip.iter().zip(&f.waist)) {
            for a in 0..3 {
                p[a] += 1.5 * (h[a] + w[a]);
            }
        }
        let hip = ["buttockcircumference", "hipbreadth", "buttockdepth"];
        let waist = ["waistcircumference", "waistbreadth", "waistdepth"];
        for [g, b, d] in [hip, waist] {
            let (r0, r1) = (ratio(&x0, g, b, d), ratio(&x, g, b, d));
            assert!(r1 > r0 + 0.02, "{g}: {r0} -> {r1}");
            for c in [b, d] {
                let moved = (m(&x, c) - m(&x0, c)).abs();
                assert!(moved < 0.6 * 0.015, "{c} moved {moved} m");
            }
        }
    }

    #[test]
    fn a_circle_and_a_flat_ellipse() {
        // A circle of diameter 2: 2 pi.
        assert!((ellipse_perimeter(2.0, 2.0) - 2.0 * std::f64::consts::PI).abs() < 1e-12);
        // Full axes 2 and 0: the segment walked there and back, 4.
        assert!((ellipse_perimeter(2.0, 0.0) - 4.0).abs() < 2e-3);
        // Semi-axes 2 and 1: 9.688448 (the complete elliptic integral).
        assert!((ellipse_perimeter(4.0, 2.0) - 9.688_448_2).abs() < 1e-5);
    }

    #[test]
    fn the_fields_are_symmetric_horizontal_and_bounded() {
        let body = BodyModel::shared().unwrap();
        let f = section_fields(body).unwrap();
        let x = body
            .generate(&Phenotype::default(), &LocalChanges::new())
            .unwrap()
            .vertices;
        // The template is symmetric about x = 0: each vertex's mirror image
        // is a vertex (to round-off).
        let key = |p: Vec3| [p[0], p[1], p[2]].map(|c| (c * 1e5).round() as i64);
        let by_position: std::collections::HashMap<[i64; 3], usize> =
            x.iter().enumerate().map(|(v, p)| (key(*p), v)).collect();
        let mirror = |v: usize| by_position.get(&key([-x[v][0], x[v][1], x[v][2]])).copied();
        for field in [&f.hip, &f.waist] {
            let moved: Vec<usize> = (0..field.len())
                .filter(|&v| field[v][0] != 0.0 || field[v][1] != 0.0)
                .collect();
            assert!(moved.len() > 200, "{} vertices moved", moved.len());
            let mirrored = moved.iter().filter(|&&v| mirror(v).is_some()).count();
            assert!(
                10 * mirrored >= 9 * moved.len(),
                "{mirrored} of {} mirrored",
                moved.len()
            );
            for (v, d) in field.iter().enumerate() {
                assert_eq!(d[2], 0.0);
                assert!(d[0].hypot(d[1]) <= UNIT_M + 1e-12);
                // The field is symmetric too.
                if let Some(w) = mirror(v) {
                    let m = field[w];
                    assert!(
                        (d[0] + m[0]).abs() < 1e-9 && (d[1] - m[1]).abs() < 1e-9,
                        "vertex {v} {d:?} against its mirror {w} {m:?}"
                    );
                }
                // Away from the mid-plane (the hands) nothing moves.
                if x[v][0].abs() > TORSO_HALF_WIDTH_M {
                    assert_eq!(*d, [0.0; 3]);
                }
            }
        }
    }
}
