//! Tests of the template anatomy data (landmarks and body parts).
//!
//! They re-derive the data from the MakeHuman pack as committed with this
//! crate ([`Pack::committed`]: `assets/makehuman/` and the embedded blend pack,
//! which `tests/pack_matches_sources.rs` ties to the full pack) and check the
//! committed files against it, then check the landmarks' meaning on the pack's
//! 8 reference bodies (made by anny itself, independent of this crate;
//! committed in `tests/data/reference/`): heights as fractions of stature
//! against ANSUR II means, breadths and lengths against ANSUR II ranges,
//! symmetry, and side.

use std::collections::BTreeSet;
use std::sync::OnceLock;

use tapeshape_body::anatomy::{
    self, derive, pack::Pack, BILATERAL_LANDMARKS, MIDLINE_LANDMARKS, N_TRIANGLES, N_VERTICES,
    PART_NAMES,
};

fn pack() -> &'static Pack {
    static P: OnceLock<Pack> = OnceLock::new();
    P.get_or_init(|| {
        Pack::committed().unwrap_or_else(|e| panic!("the committed MakeHuman pack: {e}"))
    })
}

fn derived() -> &'static derive::Derived {
    static D: OnceLock<derive::Derived> = OnceLock::new();
    D.get_or_init(|| derive::derive(pack()).expect("derivation succeeds"))
}

#[test]
fn committed_files_equal_the_derivation() {
    let d = derived();
    assert!(
        anatomy::landmarks_toml(d) == anatomy::LANDMARKS_TOML,
        "data/landmarks.toml differs from the derivation: run `cargo run -p tapeshape-body --example derive_anatomy`"
    );
    assert!(
        anatomy::parts_toml(d) == anatomy::PARTS_TOML,
        "data/parts.toml differs from the derivation: run `cargo run -p tapeshape-body --example derive_anatomy`"
    );
}

#[test]
fn every_required_landmark_exists_on_the_body_component() {
    let a = anatomy::anatomy();
    let mut want: BTreeSet<String> = MIDLINE_LANDMARKS.iter().map(|s| s.to_string()).collect();
    for s in BILATERAL_LANDMARKS {
        want.insert(format!("{s}_left"));
        want.insert(format!("{s}_right"));
    }
    let have: BTreeSet<String> = a.landmarks.keys().cloned().collect();
    assert_eq!(want, have);
    let records = anatomy::parse_landmarks(anatomy::LANDMARKS_TOML).unwrap();
    for r in &records {
        assert!((r.vertex as usize) < N_VERTICES);
        assert_eq!(pack().keep[r.vertex as usize], r.base_vertex, "{}", r.name);
        assert!(
            r.base_vertex < 13_380,
            "{} is not on the body component",
            r.name
        );
        assert!(!r.rule.is_empty());
    }
}

#[test]
fn pairs_are_mirror_partners_and_midline_is_on_the_mid_plane() {
    use anatomy::pack::Side;
    let p = pack();
    let records = anatomy::parse_landmarks(anatomy::LANDMARKS_TOML).unwrap();
    let base = |n: &str| records.iter().find(|r| r.name == n).unwrap().base_vertex as usize;
    for s in BILATERAL_LANDMARKS {
        let (r, l) = (base(&format!("{s}_right")), base(&format!("{s}_left")));
        assert_eq!(p.mirror[r].0 as usize, l, "{s}");
        assert_eq!(
            p.mirror[r].1,
            Side::Right,
            "{s}_right is not on the body's right"
        );
        assert_eq!(
            p.mirror[l].1,
            Side::Left,
            "{s}_left is not on the body's left"
        );
        // Base mesh: exact mirror images (MakeHuman +x is the body's left).
        let (pr, pl) = (p.base[r], p.base[l]);
        assert!(pr[0] < 0.0 && (pr[0] + pl[0]).abs() < 1e-9 && pr[1] == pl[1] && pr[2] == pl[2]);
    }
    for s in MIDLINE_LANDMARKS {
        let b = base(s);
        assert_eq!(p.mirror[b].1, Side::Mid, "{s}");
        assert_eq!(p.base[b][0], 0.0, "{s} is off the mid-plane");
    }
}

#[test]
fn parts_cover_the_body_component_exactly_once() {
    let a = anatomy::anatomy();
    let names: BTreeSet<&str> = a.parts.keys().map(String::as_str).collect();
    assert_eq!(names, PART_NAMES.iter().copied().collect());
    let p = pack();
    let mut owner = vec![None; N_TRIANGLES];
    for (name, tris) in &a.parts {
        assert!(tris.windows(2).all(|w| w[0] < w[1]), "{name} not sorted");
        assert!(tris.len() > 100, "{name} has only {} triangles", tris.len());
        for &t in tris {
            assert!(owner[t as usize].is_none(), "triangle {t} in two parts");
            owner[t as usize] = Some(name.as_str());
        }
    }
    for (t, tri) in p.triangles.iter().enumerate() {
        let body = tri.iter().all(|&v| p.keep[v as usize] < 13_380);
        assert_eq!(
            owner[t].is_some(),
            body,
            "triangle {t}: body {body}, part {:?}",
            owner[t]
        );
    }
}

/// Vertices of a part's triangles.
fn part_vertices(part: &str) -> BTreeSet<u32> {
    let a = anatomy::anatomy();
    let p = pack();
    a.parts[part]
        .iter()
        .flat_map(|&t| p.triangles[t as usize])
        .collect()
}

#[test]
fn parts_lie_where_their_joints_say() {
    let d = derived();
    let a = anatomy::anatomy();
    let pos = |k: u32| d.body[k as usize];
    let joint = |b: &str, tail: bool| {
        let j = d.joints[b];
        if tail {
            j.1
        } else {
            j.0
        }
    };
    use tapeshape_mesh::vec3::{dot, sub};
    // The head part holds the vertex landmark, the feet the heel points.
    assert!(part_vertices("head").contains(&a.landmarks["vertex"]));
    assert!(part_vertices("foot_right").contains(&a.landmarks["heel_bottom_right"]));
    assert!(part_vertices("hand_left").contains(&a.landmarks["dactylion_left"]));
    for (side, s) in [("right", "R"), ("left", "L")] {
        // Hands lie beyond the wrist (1 cm slack for the skin around the joint).
        let (elbow, wrist) = (
            joint(&format!("lowerarm01.{s}"), false),
            joint(&format!("lowerarm02.{s}"), true),
        );
        let axis = sub(wrist, elbow);
        let len = dot(axis, axis).sqrt();
        let axis = axis.map(|c| c / len);
        for v in part_vertices(&format!("hand_{side}")) {
            assert!(
                dot(sub(pos(v), wrist), axis) > -0.02,
                "hand_{side} vertex {v} above the wrist"
            );
        }
        // Feet lie below the knee, thighs above the knee's lower leg.
        let knee = joint(&format!("lowerleg01.{s}"), false);
        for v in part_vertices(&format!("foot_{side}")) {
            assert!(pos(v)[2] < knee[2] - 0.2, "foot_{side} vertex {v} too high");
        }
        let ankle = joint(&format!("foot.{s}"), false);
        for v in part_vertices(&format!("lower_leg_{side}")) {
            assert!(pos(v)[2] > ankle[2] - 0.05 && pos(v)[2] < knee[2] + 0.05);
        }
        // Sides: right parts at x > 0.
        let sign = if side == "right" { 1.0 } else { -1.0 };
        for part in ["upper_arm", "forearm", "hand", "thigh", "lower_leg", "foot"] {
            for v in part_vertices(&format!("{part}_{side}")) {
                assert!(
                    sign * pos(v)[0] > 0.0,
                    "{part}_{side} vertex {v} on the wrong side"
                );
            }
        }
    }
    // The neck lies between the shoulders' and the chin's heights.
    let z_neck: Vec<f64> = part_vertices("neck").iter().map(|&v| pos(v)[2]).collect();
    let z_head = pos(a.landmarks["vertex"])[2];
    assert!(z_neck
        .iter()
        .all(|&z| z > 0.78 * z_head && z < 0.94 * z_head));
}

/// A reference body (anny frame, kept order) converted to the station frame.
fn reference(n: usize) -> Vec<[f64; 3]> {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join(format!("tests/data/reference/body{n}.f32"));
    let bytes = std::fs::read(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    assert_eq!(bytes.len(), N_VERTICES * 12);
    let mut v: Vec<[f64; 3]> = bytes
        .chunks_exact(12)
        .map(|c| {
            let f = |i: usize| f32::from_le_bytes([c[i], c[i + 1], c[i + 2], c[i + 3]]) as f64;
            [-f(0), -f(4), f(8)]
        })
        .collect();
    let z0 = v.iter().map(|p| p[2]).fold(f64::INFINITY, f64::min);
    for p in &mut v {
        p[2] -= z0;
    }
    v
}

#[test]
fn landmarks_are_plausible_on_every_reference_body() {
    let a = anatomy::anatomy();
    let lm = |n: &str| a.landmarks[n] as usize;
    let mut failures = Vec::new();
    for body in 1..=8 {
        let v = reference(body);
        let p = |n: &str| v[lm(n)];
        let stature = v.iter().map(|p| p[2]).fold(0.0, f64::max);
        let h = |n: &str| p(n)[2] / stature;
        let dist = |a: &str, b: &str| {
            let (pa, pb) = (p(a), p(b));
            ((pa[0] - pb[0]).powi(2) + (pa[1] - pb[1]).powi(2) + (pa[2] - pb[2]).powi(2)).sqrt()
        };
        let msg = |what: &str, val: f64| format!("body{body}: {what} = {val:.4}");
        // The top of the head is the highest point, the heels touch the floor.
        assert!(
            stature - p("vertex")[2] < 0.002,
            "{}",
            msg("vertex below top", stature - p("vertex")[2])
        );
        for s in ["right", "left"] {
            assert!(
                p(&format!("heel_bottom_{s}"))[2] < 0.01,
                "{}",
                msg("heel", p(&format!("heel_bottom_{s}"))[2])
            );
        }
        // Heights as a fraction of stature: ANSUR II male/female means are
        // given in comments; the ranges allow for the model's proportions.
        // (No arm heights: the template stands in an A-pose, ANSUR arms hang.)
        let ranges: [(&str, f64, f64); 15] = [
            ("acromion_right", 0.78, 0.86),          // 0.820 / 0.820
            ("cervicale", 0.83, 0.90),               // 0.864 / 0.857
            ("suprasternale", 0.78, 0.85),           // 0.819 / 0.817
            ("axilla_front_right", 0.71, 0.80),      // 0.757 / 0.761
            ("thelion_right", 0.68, 0.77),           // chest height 0.735 / 0.719
            ("omphalion", 0.56, 0.64),               // 0.602 / 0.602
            ("iliocristale_right", 0.56, 0.64),      // 0.605 / 0.611
            ("trochanterion_right", 0.47, 0.56),     // 0.513 / 0.519
            ("crotch", 0.44, 0.51),                  // 0.482 / 0.480
            ("patella_right", 0.25, 0.32),           // mid-patella 0.278 / 0.276
            ("tibiale_right", 0.24, 0.31),           // 0.267 / 0.269
            ("lateral_malleolus_right", 0.02, 0.06), // 0.042 / 0.039
            ("tragion_right", 0.89, 0.94),           // tragion height 0.925 / 0.922
            ("menton", 0.84, 0.89),                  // about sellion - 0.07
            ("exocanthion_right", 0.91, 0.95),       // eye height 0.934 / 0.934
        ];
        for (n, lo, hi) in ranges {
            if !(h(n) > lo && h(n) < hi) {
                failures.push(msg(&format!("{n} height / stature"), h(n)));
            }
        }
        // Lengths and breadths as a fraction of stature, against the ANSUR II
        // mean ratio (male and female means agree within a few percent):
        // within a factor 1 +- tol of it.
        let lengths: [(&str, &str, f64, f64); 15] = [
            ("glabella", "opisthocranion", 0.115, 0.3),  // head length
            ("sellion", "menton", 0.070, 0.3),           // menton-sellion length
            ("zygion_right", "zygion_left", 0.081, 0.3), // bizygomatic breadth
            ("acromion_right", "acromion_left", 0.230, 0.3), // biacromial breadth
            ("acromion_right", "radiale_right", 0.191, 0.3), // acromion-radiale length
            ("radiale_right", "stylion_right", 0.150, 0.3), // radiale-stylion length
            ("acromion_right", "stylion_right", 0.336, 0.3), // sleeve outseam (tape, so longer)
            ("stylion_right", "dactylion_right", 0.110, 0.3), // hand length
            ("pternion_right", "acropodion_right", 0.152, 0.3), // foot length
            ("iliocristale_right", "iliocristale_left", 0.185, 0.45), // waist breadth
            ("lateral_malleolus_right", "sphyrion_right", 0.042, 0.4), // bimalleolar breadth
            ("stylion_right", "ulnar_styloid_right", 0.032, 0.4), // wrist breadth (no ANSUR item; ~55 mm)
            ("exocanthion_right", "exocanthion_left", 0.055, 0.3), // biocular breadth (no ANSUR item; ~95 mm)
            ("endocanthion_right", "endocanthion_left", 0.019, 0.35), // intercanthal breadth (no ANSUR item; ~32 mm)
            ("cheilion_right", "cheilion_left", 0.029, 0.35), // mouth breadth (no ANSUR item; ~50 mm)
        ];
        for (a1, a2, ratio, tol) in lengths {
            let r = dist(a1, a2) / stature;
            if (r / ratio - 1.0).abs() > tol {
                failures.push(msg(&format!("|{a1} - {a2}| / stature (ANSUR {ratio})"), r));
            }
        }
        // Orientation: front points in front of back points, lateral outside medial.
        let pairs: [(&str, &str, usize); 9] = [
            ("patella_right", "knee_back_right", 1),
            ("biceps_front_right", "biceps_back_right", 1),
            ("axilla_front_right", "axilla_back_right", 1),
            ("omphalion", "waist_back", 1),
            ("acropodion_right", "pternion_right", 1),
            ("pronasale", "opisthocranion", 1),
            ("knee_lateral_right", "knee_medial_right", 0),
            ("exocanthion_right", "endocanthion_right", 0),
            ("lateral_malleolus_right", "sphyrion_right", 0),
        ];
        // Face order from top to bottom.
        let down = [
            "vertex",
            "glabella",
            "sellion",
            "pronasale",
            "subnasale",
            "cheilion_right",
            "menton",
            "suprasternale",
        ];
        for w in down.windows(2) {
            if p(w[0])[2] <= p(w[1])[2] {
                failures.push(format!("body{body}: {} not above {}", w[0], w[1]));
            }
        }
        for (front, back, axis) in pairs {
            assert!(
                p(front)[axis] > p(back)[axis],
                "body{body}: {front} not beyond {back} on axis {axis}"
            );
        }
        // Mid-line landmarks on the mid-plane for the symmetric bodies (body 8 has
        // asymmetric local changes).
        if body != 8 {
            for n in MIDLINE_LANDMARKS {
                assert!(p(n)[0].abs() < 1e-5, "{}", msg(&format!("{n} x"), p(n)[0]));
            }
            for s in BILATERAL_LANDMARKS {
                let (r, l) = (p(&format!("{s}_right")), p(&format!("{s}_left")));
                assert!(r[0] > 0.0, "body{body}: {s}_right not at +x");
                assert!(
                    (r[0] + l[0]).abs() < 1e-5
                        && (r[1] - l[1]).abs() < 1e-5
                        && (r[2] - l[2]).abs() < 1e-5
                );
            }
        }
    }
    assert!(
        failures.is_empty(),
        "implausible landmarks:\n{}",
        failures.join("\n")
    );
}

#[test]
fn bad_data_is_an_error() {
    assert!(
        anatomy::parse_parts("[[part]]\nname = \"x\"\ncount = 3\nranges = [[5, 6]]\n").is_err()
    );
    assert!(
        anatomy::parse_parts("[[part]]\nname = \"x\"\ncount = 2\nranges = [[5, 6], [6, 7]]\n")
            .is_err()
    );
    assert!(
        anatomy::parse_parts("[[part]]\nname = \"x\"\ncount = 1\nranges = [[27420, 27420]]\n")
            .is_err()
    );
    assert!(anatomy::parse_landmarks(
        "[[landmark]]\nname = \"a\"\nvertex = 13718\nbase_vertex = 0\nrule = \"r\"\nposition_mm = [0.0, 0.0, 0.0]\n"
    )
    .is_err());
    assert!(anatomy::parse_landmarks("not toml [").is_err());
    let ok = anatomy::parse_parts("[[part]]\nname = \"x\"\ncount = 3\nranges = [[1, 2], [7, 7]]\n")
        .unwrap();
    assert_eq!(anatomy::expand_ranges(&ok[0].ranges), vec![1, 2, 7]);
    assert_eq!(anatomy::compress_ranges(&[1, 2, 7]), ok[0].ranges);
}

#[test]
fn derivation_body_equals_the_generator_output() {
    // The derivation blends the pack files itself; the generator reads its own
    // embedded pack. Both must give the same body for the documented phenotype.
    let ph = tapeshape_body::Phenotype {
        gender: 0.5,
        age: 0.78,
        muscle: 0.5,
        weight: 0.5,
        height: 0.375,
        proportions: 0.5,
        cupsize: 0.5,
        firmness: 0.5,
        african: 1.0,
        asian: 1.0,
        caucasian: 1.0,
    };
    let model = tapeshape_body::BodyModel::shared().expect("generator loads");
    let mesh = model
        .generate(&ph, &tapeshape_body::LocalChanges::new())
        .expect("generates");
    let d = derived();
    assert_eq!(mesh.vertices.len(), d.body.len());
    let worst = mesh
        .vertices
        .iter()
        .zip(&d.body)
        .map(|(a, b)| (0..3).map(|k| (a[k] - b[k]).abs()).fold(0.0, f64::max))
        .fold(0.0, f64::max);
    assert!(
        worst < 1e-6,
        "derivation body differs from the generator by {worst} m"
    );
}

#[test]
fn sided_parts_are_mirror_images() {
    // Mirror every triangle of a right part through hm08.mirror; the result
    // must be a triangle (as a vertex set) of the matching left part.
    let a = anatomy::anatomy();
    let p = pack();
    let mut kept_of = vec![u32::MAX; p.base.len()];
    for (k, &b) in p.keep.iter().enumerate() {
        kept_of[b as usize] = k as u32;
    }
    let key = |t: [u32; 3]| {
        let mut t = t;
        t.sort_unstable();
        t
    };
    for stem in ["upper_arm", "forearm", "hand", "thigh", "lower_leg", "foot"] {
        let left: BTreeSet<[u32; 3]> = a.parts[&format!("{stem}_left")]
            .iter()
            .map(|&t| key(p.triangles[t as usize]))
            .collect();
        let right = &a.parts[&format!("{stem}_right")];
        assert_eq!(left.len(), right.len(), "{stem}");
        for &t in right {
            let m = p.triangles[t as usize]
                .map(|k| kept_of[p.mirror[p.keep[k as usize] as usize].0 as usize]);
            assert!(
                left.contains(&key(m)),
                "{stem}: mirror of triangle {t} not in the left part"
            );
        }
    }
}
