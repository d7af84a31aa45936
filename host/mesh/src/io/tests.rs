//! Tests of `io`, in a file of their own so that the module stays short.

use super::*;

fn square_pyramid() -> Mesh {
    Mesh::from_faces(
        vec![
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [1.0, 1.0, 0.0],
            [0.0, 1.0, 0.0],
            [0.5, 0.5, 1.0],
        ],
        vec![
            [0, 2, 1],
            [0, 3, 2],
            [0, 1, 4],
            [1, 2, 4],
            [2, 3, 4],
            [3, 0, 4],
        ],
    )
    .unwrap()
}

#[test]
fn obj_forms_and_errors() {
    let text = "# c\nv 0 0 0\nv 1 0 0 0.5 0.5 0.5\nv 0 1 0\nv 0 0 1\nvt 0 0\nvn 0 0 1\ng x\nf 1/1/1 3/1/1 2/1/1\nf 1//1 2//1 4//1\nf -4 -1 -2\n";
    let m = parse_obj(text, "t.obj", ReadOptions::default()).unwrap();
    assert_eq!(m.vertices.len(), 4);
    assert_eq!(m.faces(), &[[0, 2, 1], [0, 1, 3], [0, 3, 2]]);
    let quad = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\n";
    let e = parse_obj(quad, "q.obj", ReadOptions::default()).unwrap_err();
    assert!(e.to_string().contains("q.obj, line 5"), "{e}");
    let m = parse_obj(
        quad,
        "q.obj",
        ReadOptions {
            triangulate_polygons: true,
        },
    )
    .unwrap();
    assert_eq!(m.faces(), &[[0, 1, 2], [0, 2, 3]]);
    for (bad, line) in [
        ("v 0 0\n", 1),
        ("v 0 0 x\n", 1),
        ("v 0 0 0\nf 1 2 3\n", 2),
        ("v 0 0 0\nv 0 0 0\nv 0 0 0\nf 0 1 2\n", 4),
        ("v 0 0 nan\n", 1),
    ] {
        match parse_obj(bad, "b.obj", ReadOptions::default()) {
            Err(MeshIoError::Syntax { line: l, .. }) => assert_eq!(l, line, "{bad:?}"),
            other => panic!("{bad:?}: {other:?}"),
        }
    }
    // A degenerate face is a mesh error naming the file.
    let e = parse_obj(
        "v 0 0 0\nv 1 0 0\nf 1 2 2\n",
        "d.obj",
        ReadOptions::default(),
    )
    .unwrap_err();
    assert!(matches!(e, MeshIoError::Mesh { .. }) && e.to_string().starts_with("d.obj"));
}

#[test]
fn obj_round_trip_is_exact() {
    let mut m = square_pyramid();
    m.vertices[4] = [0.1 + 0.2, -1e-17, 1.0 / 3.0];
    let back = parse_obj(&obj_string(&m), "rt", ReadOptions::default()).unwrap();
    assert_eq!(back.vertices, m.vertices);
    assert_eq!(back.faces(), m.faces());
    assert!(obj_string(&m).lines().next().unwrap().contains("metres"));
}

#[test]
fn ply_round_trips_and_ascii() {
    let mut m = square_pyramid();
    m.vertices[4] = [0.1 + 0.2, -1e-17, 1.0 / 3.0];
    let b = ply_bytes(&m, PlyPrecision::F64);
    let back = parse_ply(&b, "rt.ply", ReadOptions::default()).unwrap();
    assert_eq!(back.vertices, m.vertices);
    assert_eq!(back.faces(), m.faces());
    let back32 = parse_ply(
        &ply_bytes(&m, PlyPrecision::F32),
        "rt.ply",
        ReadOptions::default(),
    )
    .unwrap();
    for (a, b) in back32.vertices.iter().zip(&m.vertices) {
        for k in 0..3 {
            assert_eq!(a[k], b[k] as f32 as f64);
        }
    }
    let ascii = "ply\nformat ascii 1.0\ncomment x\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\nproperty uchar red\nelement face 2\nproperty list uchar int vertex_indices\nend_header\n0 0 0 255\n1 0 0 0\n1 1 0 0\n0 1 0 0\n3 0 1 2\n3 0 2 3\n";
    let a = parse_ply(ascii.as_bytes(), "a.ply", ReadOptions::default()).unwrap();
    assert_eq!(a.vertices[2], [1.0, 1.0, 0.0]);
    assert_eq!(a.faces(), &[[0, 1, 2], [0, 2, 3]]);
    let quad = ascii
        .replace("element face 2", "element face 1")
        .replace("3 0 1 2\n3 0 2 3\n", "4 0 1 2 3\n");
    let e = parse_ply(quad.as_bytes(), "q.ply", ReadOptions::default()).unwrap_err();
    assert!(e.to_string().contains("face 0"), "{e}");
    let t = parse_ply(
        quad.as_bytes(),
        "q.ply",
        ReadOptions {
            triangulate_polygons: true,
        },
    )
    .unwrap();
    assert_eq!(t.faces(), &[[0, 1, 2], [0, 2, 3]]);
    // Truncated binary: names the element.
    let e = parse_ply(&b[..b.len() - 5], "tr.ply", ReadOptions::default()).unwrap_err();
    assert!(
        matches!(&e, MeshIoError::Element { element, index: 5, .. } if element == "face"),
        "{e}"
    );
    let e = parse_ply(
        b"ply\nformat binary_big_endian 1.0\nend_header\n",
        "be.ply",
        ReadOptions::default(),
    )
    .unwrap_err();
    assert!(e.to_string().contains("binary_big_endian"), "{e}");
    assert!(parse_ply(b"not a ply", "x", ReadOptions::default()).is_err());
    // A face index past the vertices.
    let bad = ascii.replace("3 0 2 3\n", "3 0 2 9\n");
    assert!(matches!(
        parse_ply(bad.as_bytes(), "v.ply", ReadOptions::default()),
        Err(MeshIoError::Mesh { .. })
    ));
}

#[test]
fn gltf_frame_is_a_proper_rotation() {
    let ex = station_to_gltf([1.0, 0.0, 0.0]);
    let ey = station_to_gltf([0.0, 1.0, 0.0]);
    let ez = station_to_gltf([0.0, 0.0, 1.0]);
    assert_eq!(ez, [0.0, 1.0, 0.0]);
    assert_eq!(ey, [0.0, 0.0, 1.0]);
    // ex = ey x ez (right-handed, proper)
    assert_eq!(ex, crate::vec3::cross(ey, ez));
}

#[test]
fn atomic_write_replaces_and_leaves_no_temp() {
    let dir = std::env::temp_dir().join(format!("tapeshape-mesh-io-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let p = dir.join("a.obj");
    write_obj(&square_pyramid(), &p).unwrap();
    write_obj(&square_pyramid(), &p).unwrap();
    let names: Vec<_> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    assert_eq!(names, vec![std::ffi::OsString::from("a.obj")]);
    let back = read_obj(&p, ReadOptions::default()).unwrap();
    assert_eq!(back.vertices, square_pyramid().vertices);
    let e = read_obj(dir.join("missing.obj"), ReadOptions::default()).unwrap_err();
    assert!(e.to_string().contains("missing.obj"));
    std::fs::remove_dir_all(&dir).unwrap();
}
