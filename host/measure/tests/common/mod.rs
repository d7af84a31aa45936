//! Test meshes with known answers: capped cylinders, star prisms (concave
//! cross-sections), icospheres and a lumpy asymmetric blob, plus helpers to
//! build anatomies and sets for them.
#![allow(dead_code)]

use std::collections::{BTreeMap, HashMap};

use tapeshape_mesh::{Anatomy, Mesh, Vec3};

/// A closed, capped prism whose cross-section is the polygon `outline`
/// (counter-clockwise seen from +Z, star-shaped about the origin), with
/// `rings + 1` rings from z = 0 to z = `height`. Vertex `k * n + i` is
/// outline point `i` on ring `k`; the last two vertices are the cap centres.
pub fn prism(outline: &[[f64; 2]], height: f64, rings: usize) -> Mesh {
    let n = outline.len();
    let mut v: Vec<Vec3> = Vec::new();
    for k in 0..=rings {
        let z = height * k as f64 / rings as f64;
        for p in outline {
            v.push([p[0], p[1], z]);
        }
    }
    let bottom = v.len() as u32;
    v.push([0.0, 0.0, 0.0]);
    let top = v.len() as u32;
    v.push([0.0, 0.0, height]);
    let id = |k: usize, i: usize| (k * n + i % n) as u32;
    let mut f = Vec::new();
    for k in 0..rings {
        for i in 0..n {
            let (a, b, c, d) = (id(k, i), id(k, i + 1), id(k + 1, i + 1), id(k + 1, i));
            f.push([a, b, c]);
            f.push([a, c, d]);
        }
    }
    for i in 0..n {
        f.push([bottom, id(0, i + 1), id(0, i)]);
        f.push([top, id(rings, i), id(rings, i + 1)]);
    }
    Mesh::from_faces(v, f).unwrap()
}

/// Regular `n`-gon of radius `r`.
pub fn circle(r: f64, n: usize) -> Vec<[f64; 2]> {
    (0..n)
        .map(|i| {
            let a = std::f64::consts::TAU * i as f64 / n as f64;
            [r * a.cos(), r * a.sin()]
        })
        .collect()
}

/// Star with `k` tips at radius `outer` and `k` notches at radius `inner`.
pub fn star(k: usize, outer: f64, inner: f64) -> Vec<[f64; 2]> {
    (0..2 * k)
        .map(|i| {
            let a = std::f64::consts::PI * i as f64 / k as f64;
            let r = if i % 2 == 0 { outer } else { inner };
            [r * a.cos(), r * a.sin()]
        })
        .collect()
}

/// Icosphere of radius `r` after `subdivisions` midpoint subdivisions.
/// Vertices 0..12 are the icosahedron's; vertex `2 * j` and `2 * j + 1` are
/// antipodal for j < 6.
pub fn icosphere(r: f64, subdivisions: usize) -> Mesh {
    let phi = (1.0 + 5f64.sqrt()) / 2.0;
    let base: Vec<Vec3> = vec![
        [-1.0, phi, 0.0],
        [1.0, -phi, 0.0],
        [1.0, phi, 0.0],
        [-1.0, -phi, 0.0],
        [0.0, -1.0, phi],
        [0.0, 1.0, -phi],
        [0.0, 1.0, phi],
        [0.0, -1.0, -phi],
        [phi, 0.0, -1.0],
        [-phi, 0.0, 1.0],
        [phi, 0.0, 1.0],
        [-phi, 0.0, -1.0],
    ];
    let norm = |p: Vec3| {
        let l = (p[0] * p[0] + p[1] * p[1] + p[2] * p[2]).sqrt();
        [p[0] / l, p[1] / l, p[2] / l]
    };
    let mut v: Vec<Vec3> = base.into_iter().map(norm).collect();
    // Faces found as the 20 triples of mutually adjacent vertices (edge length 2 before scaling).
    let mut faces: Vec<[u32; 3]> = Vec::new();
    let d2 = |a: Vec3, b: Vec3| (0..3).map(|k| (a[k] - b[k]).powi(2)).sum::<f64>();
    let e2 = d2(v[0], v[2]); // an icosahedron edge (vertices 0 and 2 are neighbours)
    let adj = |a: usize, b: usize| (d2(v[a], v[b]) - e2).abs() < 1e-9;
    for a in 0..12 {
        for b in a + 1..12 {
            for c in b + 1..12 {
                if adj(a, b) && adj(b, c) && adj(a, c) {
                    // Orient outward.
                    let (pa, pb, pc) = (v[a], v[b], v[c]);
                    let u = [pb[0] - pa[0], pb[1] - pa[1], pb[2] - pa[2]];
                    let w = [pc[0] - pa[0], pc[1] - pa[1], pc[2] - pa[2]];
                    let nrm = [
                        u[1] * w[2] - u[2] * w[1],
                        u[2] * w[0] - u[0] * w[2],
                        u[0] * w[1] - u[1] * w[0],
                    ];
                    if nrm[0] * pa[0] + nrm[1] * pa[1] + nrm[2] * pa[2] > 0.0 {
                        faces.push([a as u32, b as u32, c as u32]);
                    } else {
                        faces.push([a as u32, c as u32, b as u32]);
                    }
                }
            }
        }
    }
    assert_eq!(faces.len(), 20);
    for _ in 0..subdivisions {
        let mut mid: HashMap<(u32, u32), u32> = HashMap::new();
        let mut next = Vec::with_capacity(faces.len() * 4);
        let mut m = |a: u32, b: u32, v: &mut Vec<Vec3>| -> u32 {
            *mid.entry((a.min(b), a.max(b))).or_insert_with(|| {
                let (pa, pb) = (v[a as usize], v[b as usize]);
                v.push(norm([pa[0] + pb[0], pa[1] + pb[1], pa[2] + pb[2]]));
                (v.len() - 1) as u32
            })
        };
        for f in &faces {
            let ab = m(f[0], f[1], &mut v);
            let bc = m(f[1], f[2], &mut v);
            let ca = m(f[2], f[0], &mut v);
            next.push([f[0], ab, ca]);
            next.push([f[1], bc, ab]);
            next.push([f[2], ca, bc]);
            next.push([ab, bc, ca]);
        }
        faces = next;
    }
    let v = v
        .into_iter()
        .map(|p| [r * p[0], r * p[1], r * p[2]])
        .collect();
    Mesh::from_faces(v, faces).unwrap()
}

/// An asymmetric lumpy blob (a deformed icosphere) standing on z = 0,
/// about 1 m tall: no symmetry can hide a wrong answer.
pub fn blob() -> Mesh {
    let s = icosphere(1.0, 3);
    let v = s
        .vertices
        .iter()
        .map(|p| {
            let bump = 1.0
                + 0.12 * (3.0 * p[0] + 1.0).sin() * (2.0 * p[1]).cos()
                + 0.08 * (4.0 * p[2]).sin();
            [
                0.22 * bump * p[0] + 0.03,
                0.15 * bump * p[1] - 0.02,
                0.5 * bump * p[2] + 0.5,
            ]
        })
        .collect();
    Mesh::new(v, s.topology.clone()).unwrap()
}

/// Index of the vertex maximising `f`.
pub fn argmax(m: &Mesh, f: impl Fn(Vec3) -> f64) -> u32 {
    (0..m.vertices.len())
        .max_by(|&a, &b| f(m.vertices[a]).total_cmp(&f(m.vertices[b])))
        .unwrap() as u32
}

/// Anatomy with the given landmarks and parts.
pub fn anatomy(landmarks: &[(&str, u32)], parts: &[(&str, Vec<u32>)]) -> Anatomy {
    Anatomy {
        landmarks: landmarks
            .iter()
            .map(|(n, v)| (n.to_string(), *v))
            .collect::<BTreeMap<_, _>>(),
        parts: parts
            .iter()
            .map(|(n, t)| (n.to_string(), t.clone()))
            .collect(),
    }
}

/// The blob's anatomy: six extreme points, a floor pair, an equator point,
/// the whole surface as part `body` and the faces above z = 0.35 as `upper`.
pub fn blob_anatomy(m: &Mesh) -> Anatomy {
    let all: Vec<u32> = (0..m.faces().len() as u32).collect();
    let upper: Vec<u32> = m
        .faces()
        .iter()
        .enumerate()
        .filter(|(_, f)| f.iter().all(|&v| m.vertices[v as usize][2] > 0.35))
        .map(|(i, _)| i as u32)
        .collect();
    let eq = argmax(m, |p| p[1] - 10.0 * (p[2] - 0.55).abs());
    anatomy(
        &[
            ("top", argmax(m, |p| p[2])),
            ("bottom", argmax(m, |p| -p[2])),
            ("front", argmax(m, |p| p[1])),
            ("back", argmax(m, |p| -p[1])),
            ("right", argmax(m, |p| p[0])),
            ("left", argmax(m, |p| -p[0])),
            ("equator_front", eq),
            ("heel_bottom_left", argmax(m, |p| -p[2] - p[0])),
            ("heel_bottom_right", argmax(m, |p| -p[2] + p[0])),
        ],
        &[("body", all), ("upper", upper)],
    )
}

/// A set file with one `[set]` header and the given entries (TOML text).
pub fn set_toml(entries: &str) -> String {
    format!("[set]\nname = \"test\"\ndescription = \"test set\"\n{entries}")
}

/// One entry's TOML: `name`, `kind` and extra `key = value` lines.
pub fn entry(name: &str, kind: &str, fields: &str) -> String {
    format!(
        "\n[[measurement]]\nname = \"{name}\"\nlabel = \"{name}\"\ndescription = \"test\"\nkind = \"{kind}\"\ntolerance = \"segment_length\"\n{fields}\n"
    )
}
