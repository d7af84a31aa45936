//! GLB output read back with the `gltf` crate: counts, bounds, indices,
//! normals and the station -> glTF frame conversion.

use tapeshape_mesh::io::{glb_bytes, glb_bytes_with_colors, station_to_gltf, write_glb};
use tapeshape_mesh::Mesh;

/// A tall box standing on the floor (station frame), 0.4 m wide (x), 0.2 m deep (y), 1.8 m tall (z).
fn standing_box() -> Mesh {
    let (a, b, c) = (0.4, 0.2, 1.8);
    let v = (0..8)
        .map(|i| {
            [
                if i & 1 != 0 { a / 2.0 } else { -a / 2.0 },
                if i & 2 != 0 { b / 2.0 } else { -b / 2.0 },
                if i & 4 != 0 { c } else { 0.0 },
            ]
        })
        .collect();
    let quads = [
        [0, 2, 3, 1],
        [4, 5, 7, 6],
        [0, 1, 5, 4],
        [2, 6, 7, 3],
        [0, 4, 6, 2],
        [1, 3, 7, 5],
    ];
    let faces = quads
        .iter()
        .flat_map(|q| [[q[0], q[1], q[2]], [q[0], q[2], q[3]]])
        .collect();
    Mesh::from_faces(v, faces).unwrap()
}

#[test]
fn glb_reads_back_with_the_gltf_crate() {
    let m = standing_box();
    let bytes = glb_bytes(&m, "box").unwrap();
    assert_eq!(bytes.len() & 3, 0, "GLB length is a multiple of 4");
    let (doc, buffers, _) = gltf::import_slice(&bytes).unwrap();
    assert!(doc
        .as_json()
        .asset
        .generator
        .as_deref()
        .unwrap()
        .starts_with("tapeshape-mesh"));
    assert_eq!(doc.meshes().count(), 1);
    assert_eq!(doc.nodes().count(), 1);
    let prim = doc.meshes().next().unwrap().primitives().next().unwrap();
    assert_eq!(prim.mode(), gltf::mesh::Mode::Triangles);
    let r = prim.reader(|b| Some(&buffers[b.index()]));
    let pos: Vec<[f32; 3]> = r.read_positions().unwrap().collect();
    let nrm: Vec<[f32; 3]> = r.read_normals().unwrap().collect();
    let idx: Vec<u32> = r.read_indices().unwrap().into_u32().collect();
    assert_eq!(pos.len(), 8);
    assert_eq!(nrm.len(), 8);
    assert_eq!(idx, m.faces().iter().flatten().copied().collect::<Vec<_>>());
    for (p, v) in pos.iter().zip(&m.vertices) {
        let g = station_to_gltf(*v);
        for k in 0..3 {
            assert_eq!(p[k], g[k] as f32);
        }
    }
    for n in &nrm {
        let len = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
        assert!((len - 1.0).abs() < 1e-6);
    }
    // Y up in glTF: the box stands on y = 0 and is 1.8 m tall; its front (+Y
    // in the station) faces glTF +Z; depth stays 0.2 m along z.
    let bb = prim.bounding_box();
    assert_eq!(bb.min, [-0.2, 0.0, -0.1]);
    assert_eq!(bb.max, [0.2, 1.8, 0.1]);
    // Winding stays outward after conversion: the signed volume of the
    // converted positions is positive.
    let mut vol = 0.0f64;
    for t in idx.chunks_exact(3) {
        let [a, b, c] = [0, 1, 2].map(|k| pos[t[k] as usize].map(f64::from));
        vol += a[0] * (b[1] * c[2] - b[2] * c[1]) - a[1] * (b[0] * c[2] - b[2] * c[0])
            + a[2] * (b[0] * c[1] - b[1] * c[0]);
    }
    assert!((vol / 6.0 - 0.4 * 0.2 * 1.8).abs() < 1e-6, "{}", vol / 6.0);
}

#[test]
fn glb_vertex_colours() {
    let m = standing_box();
    let colors: Vec<[f32; 3]> = (0..8)
        .map(|i| [i as f32 / 7.0, 0.5, 1.0 - i as f32 / 7.0])
        .collect();
    let bytes = glb_bytes_with_colors(&m, "heat", Some(&colors)).unwrap();
    let (doc, buffers, _) = gltf::import_slice(&bytes).unwrap();
    let prim = doc.meshes().next().unwrap().primitives().next().unwrap();
    let r = prim.reader(|b| Some(&buffers[b.index()]));
    let back: Vec<[f32; 3]> = r.read_colors(0).unwrap().into_rgb_f32().collect();
    assert_eq!(back, colors);
    let idx: Vec<u32> = r.read_indices().unwrap().into_u32().collect();
    assert_eq!(idx, m.faces().iter().flatten().copied().collect::<Vec<_>>());
    assert_eq!(r.read_positions().unwrap().count(), 8);
    assert!(glb_bytes_with_colors(&m, "x", Some(&colors[..7])).is_err());
    let mut hot = colors.clone();
    hot[3][0] = 1.5;
    assert!(glb_bytes_with_colors(&m, "x", Some(&hot)).is_err());
}

#[test]
fn glb_file_is_written_atomically_and_empty_meshes_are_refused() {
    let dir = std::env::temp_dir().join(format!("tapeshape-glb-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("box.glb");
    write_glb(&standing_box(), &path).unwrap();
    let (doc, _, _) = gltf::import(&path).unwrap();
    assert_eq!(doc.meshes().next().unwrap().name(), Some("box"));
    assert_eq!(std::fs::read_dir(&dir).unwrap().count(), 1);
    std::fs::remove_dir_all(&dir).unwrap();
    let empty = Mesh::from_faces(vec![], vec![]).unwrap();
    assert!(glb_bytes(&empty, "e").is_err());
}
