//! Property tests: OBJ and PLY (f64) round trips keep every vertex bit for
//! bit and in order, and every face in order and winding.

use proptest::prelude::*;
use tapeshape_mesh::io::{obj_string, parse_obj, parse_ply, ply_bytes, PlyPrecision, ReadOptions};
use tapeshape_mesh::Mesh;

fn mesh_strategy() -> impl Strategy<Value = Mesh> {
    (3usize..40)
        .prop_flat_map(|n| {
            let coord = prop_oneof![
                -10.0f64..10.0,
                any::<f64>().prop_filter("finite", |x| x.is_finite()),
                Just(0.0),
                Just(-0.0),
                Just(f64::MIN_POSITIVE),
            ];
            let verts = proptest::collection::vec([coord.clone(), coord.clone(), coord], n);
            let face = (0..n as u32, 0..n as u32, 0..n as u32)
                .prop_filter("distinct corners", |(a, b, c)| a != b && b != c && a != c)
                .prop_map(|(a, b, c)| [a, b, c]);
            (verts, proptest::collection::vec(face, 1..60))
        })
        .prop_map(|(v, f)| Mesh::from_faces(v, f).unwrap())
}

fn bits(m: &Mesh) -> Vec<[u64; 3]> {
    m.vertices.iter().map(|v| v.map(f64::to_bits)).collect()
}

proptest! {
    #[test]
    fn obj_round_trip(m in mesh_strategy()) {
        let back = parse_obj(&obj_string(&m), "p.obj", ReadOptions::default()).unwrap();
        prop_assert_eq!(bits(&back), bits(&m));
        prop_assert_eq!(back.faces(), m.faces());
    }

    #[test]
    fn ply_round_trip(m in mesh_strategy()) {
        let bytes = ply_bytes(&m, PlyPrecision::F64);
        let back = parse_ply(&bytes, "p.ply", ReadOptions::default()).unwrap();
        prop_assert_eq!(bits(&back), bits(&m));
        prop_assert_eq!(back.faces(), m.faces());
    }
}

proptest! {
    // Bytes from outside never panic the readers: arbitrary input, and valid
    // files truncated or with one byte changed, give a value or an error.
    #[test]
    fn readers_never_panic_on_garbage(bytes in proptest::collection::vec(any::<u8>(), 0..400)) {
        let _ = parse_ply(&bytes, "g.ply", ReadOptions::default());
        let _ = parse_obj(&String::from_utf8_lossy(&bytes), "g.obj", ReadOptions::default());
    }

    #[test]
    fn readers_never_panic_on_damaged_files(
        m in mesh_strategy(),
        cut in any::<proptest::sample::Index>(),
        flip in any::<proptest::sample::Index>(),
        byte in any::<u8>(),
        ascii in any::<bool>(),
    ) {
        let mut ply = ply_bytes(&m, PlyPrecision::F32);
        let i = flip.index(ply.len());
        ply[i] = byte;
        let _ = parse_ply(&ply, "d.ply", ReadOptions { triangulate_polygons: ascii });
        let _ = parse_ply(&ply[..cut.index(ply.len())], "t.ply", ReadOptions::default());
        let obj = obj_string(&m);
        let mut obj = obj.into_bytes();
        let j = flip.index(obj.len());
        obj[j] = byte;
        let obj = String::from_utf8_lossy(&obj).into_owned();
        let _ = parse_obj(&obj, "d.obj", ReadOptions { triangulate_polygons: ascii });
    }
}

#[test]
fn headers_state_units_and_frame() {
    let m = Mesh::from_faces(
        vec![[0.0; 3], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]],
        vec![[0, 1, 2]],
    )
    .unwrap();
    let obj = obj_string(&m);
    let ply = String::from_utf8_lossy(&ply_bytes(&m, PlyPrecision::F32)).into_owned();
    for header in [obj.lines().next().unwrap(), ply.lines().nth(2).unwrap()] {
        assert!(
            header.contains("metres")
                && header.contains("Z up")
                && header.contains("+Y = body front"),
            "{header}"
        );
    }
    assert!(ply.contains("property float x"));
}
