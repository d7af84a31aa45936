//! A small synthetic body family for end-to-end tests: open tubes with a
//! varying radius profile, height and ellipticity, and a measurer with the
//! paper's measurement kinds (projected height, ring girths, an interpolated
//! plane girth, a vertex path, a Euclidean distance).

#![allow(dead_code)]

use std::f64::consts::PI;

use tapeshape_measure::{Measured, Support, SupportPoint};
use tapeshape_mesh::{Topology, Vec3};
use tapeshape_model::predict::MeasureError;
use tapeshape_model::Measurer;

pub const NZ: usize = 12;
pub const NT: usize = 16;

/// Shape parameters of one tube.
#[derive(Debug, Clone, Copy)]
pub struct Params {
    pub h: f64,
    pub a: f64,
    pub b: f64,
    pub c: f64,
    pub e: f64,
    /// Per-ring radius variation (local shape variation the PCA can learn).
    pub ring: [f64; NZ],
    /// A one-sided bulge of ring 5 towards +Y (not in the training family).
    pub bump: f64,
}

pub fn lcg(seed: &mut u64) -> f64 {
    *seed = seed
        .wrapping_mul(6364136223846793005)
        .wrapping_add(1442695040888963407);
    ((*seed >> 11) as f64) / ((1u64 << 53) as f64)
}

pub fn random_params(seed: &mut u64) -> Params {
    Params {
        h: 1.5 + 0.4 * lcg(seed),
        a: 0.12 + 0.04 * lcg(seed),
        b: 0.02 + 0.04 * lcg(seed),
        c: -0.03 + 0.06 * lcg(seed),
        e: 0.2 * lcg(seed),
        ring: std::array::from_fn(|_| 0.006 * (lcg(seed) - 0.5)),
        bump: 0.0,
    }
}

pub fn vid(k: usize, i: usize) -> u32 {
    (k * NT + i % NT) as u32
}

pub fn tube(p: &Params) -> Vec<Vec3> {
    let mut v = Vec::with_capacity(NZ * NT);
    for k in 0..NZ {
        let f = k as f64 / (NZ - 1) as f64;
        let r0 = p.a + p.b * (PI * f).sin() + p.c * f + p.ring[k];
        for i in 0..NT {
            let th = 2.0 * PI * i as f64 / NT as f64;
            let r = r0
                + if k == 5 {
                    p.bump * th.sin().max(0.0)
                } else {
                    0.0
                };
            v.push([(1.0 + p.e) * r * th.cos(), r * th.sin(), p.h * f]);
        }
    }
    v
}

pub fn topology() -> Topology {
    let mut faces = Vec::new();
    for k in 0..NZ - 1 {
        for i in 0..NT {
            let (a, b, c, d) = (vid(k, i), vid(k, i + 1), vid(k + 1, i + 1), vid(k + 1, i));
            faces.push([a, b, c]);
            faces.push([a, c, d]);
        }
    }
    Topology::new(NZ * NT, faces).unwrap()
}

pub fn names() -> Vec<String> {
    [
        "height",
        "girth_2",
        "girth_5",
        "girth_9",
        "girth_between_6_7",
        "side_path",
        "width_5",
    ]
    .iter()
    .map(|s| s.to_string())
    .collect()
}

pub struct TubeMeasurer;

fn ring(points: Vec<SupportPoint>) -> Support {
    let n = points.len() as u32;
    Support {
        points,
        segments: (0..n).map(|i| [i, (i + 1) % n]).collect(),
        axis: None,
    }
}

impl TubeMeasurer {
    fn support(&self, x: &[Vec3], j: usize) -> Result<Support, MeasureError> {
        Ok(match j {
            0 => Support {
                points: vec![
                    SupportPoint::vertex(vid(0, 0)),
                    SupportPoint::vertex(vid(NZ - 1, 0)),
                ],
                segments: vec![[0, 1]],
                axis: Some([0.0, 0.0, 1.0]),
            },
            1..=3 => {
                let k = [2, 5, 9][j - 1];
                ring((0..NT).map(|i| SupportPoint::vertex(vid(k, i))).collect())
            }
            4 => {
                // Plane z = mid-height of vertices (6, 0) and (7, 0), cut with
                // the vertical edges between rings 6 and 7.
                let zc = 0.5 * (x[vid(6, 0) as usize][2] + x[vid(7, 0) as usize][2]);
                let mut pts = Vec::new();
                for i in 0..NT {
                    let (a, b) = (vid(6, i), vid(7, i));
                    let (za, zb) = (x[a as usize][2], x[b as usize][2]);
                    if (zb - za).abs() < 1e-12 {
                        return Err("degenerate edge in the cut".into());
                    }
                    let t = ((zc - za) / (zb - za)).clamp(0.0, 1.0);
                    pts.push(SupportPoint { a, b, t });
                }
                ring(pts)
            }
            5 => Support {
                points: (0..NZ).map(|k| SupportPoint::vertex(vid(k, 4))).collect(),
                segments: (0..NZ as u32 - 1).map(|k| [k, k + 1]).collect(),
                axis: None,
            },
            6 => Support {
                points: vec![
                    SupportPoint::vertex(vid(5, 0)),
                    SupportPoint::vertex(vid(5, NT / 2)),
                ],
                segments: vec![[0, 1]],
                axis: None,
            },
            _ => return Err(format!("no measurement {j}").into()),
        })
    }
}

impl Measurer for TubeMeasurer {
    fn n_measurements(&self) -> usize {
        7
    }
    fn measure(&self, x: &[Vec3], which: &[usize]) -> Result<Vec<Measured>, MeasureError> {
        which
            .iter()
            .map(|&j| {
                let support = self.support(x, j)?;
                Ok(Measured {
                    value: support.length(x),
                    support,
                })
            })
            .collect()
    }
}

pub fn measure_all(x: &[Vec3]) -> Vec<f64> {
    TubeMeasurer
        .measure(x, &(0..7).collect::<Vec<_>>())
        .unwrap()
        .iter()
        .map(|m| m.value)
        .collect()
}

/// Trains on `n` random tubes.
pub fn train(n: usize, seed: u64) -> tapeshape_model::ShapeModel {
    let mut s = seed;
    let bodies: Vec<Vec<Vec3>> = (0..n).map(|_| tube(&random_params(&mut s))).collect();
    let meas: Vec<Vec<f64>> = bodies.iter().map(|b| measure_all(b)).collect();
    let refs: Vec<&[Vec3]> = bodies.iter().map(|b| b.as_slice()).collect();
    tapeshape_model::ShapeModel::fit(&refs, &meas, &names(), &Default::default()).unwrap()
}

pub fn v2v_mm(a: &[Vec3], b: &[Vec3]) -> f64 {
    a.iter()
        .zip(b)
        .map(|(p, q)| tapeshape_mesh::vec3::distance(*p, *q))
        .sum::<f64>()
        / a.len() as f64
        * 1000.0
}
