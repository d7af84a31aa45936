//! The smooth basis against a dense eigen-decomposition of the Laplacian.

use super::*;

/// A `w x w` grid's edges (rows, columns, one diagonal per cell).
pub(crate) fn grid_edges(w: u32) -> Vec<[u32; 2]> {
    let id = |i: u32, j: u32| i * w + j;
    let mut edges = Vec::new();
    for i in 0..w {
        for j in 0..w {
            if i + 1 < w {
                edges.push([id(i, j), id(i + 1, j)]);
            }
            if j + 1 < w {
                edges.push([id(i, j), id(i, j + 1)]);
            }
            if i + 1 < w && j + 1 < w {
                edges.push([id(i, j), id(i + 1, j + 1)]);
            }
        }
    }
    edges
}

#[test]
fn basis_is_orthonormal_diagonalises_the_laplacian_and_finds_the_smallest_modes() {
    let w = 20;
    let n = (w * w) as usize;
    let edges = grid_edges(w);
    let k = 12;
    let basis = SmoothBasis::compute(n, &edges, k).unwrap();
    assert_eq!((basis.n_vertices(), basis.k()), (n, k));
    let lap = Laplacian::new(n, &edges);
    // Columns of B and L B.
    let col = |j: usize| -> Vec<f64> { (0..n).map(|v| basis.row(v)[j]).collect() };
    let cols: Vec<Vec<f64>> = (0..k).map(col).collect();
    for i in 0..k {
        let mut li = vec![0.0; n];
        lap.times(&cols[i], &mut li);
        for j in 0..k {
            let g = dot(&cols[i], &cols[j]);
            let want = if i == j { 1.0 } else { 0.0 };
            assert!((g - want).abs() < 1e-10, "B^T B [{i},{j}] = {g}");
            let h = dot(&li, &cols[j]);
            let want = if i == j { basis.values()[i] } else { 0.0 };
            assert!((h - want).abs() < 1e-10, "B^T L B [{i},{j}] = {h}");
        }
    }
    // The dense Laplacian's k smallest eigenvalues.
    let mut dense = Mat::<f64>::zeros(n, n);
    for &[a, b] in &edges {
        let (a, b) = (a as usize, b as usize);
        dense[(a, a)] += 1.0;
        dense[(b, b)] += 1.0;
        dense[(a, b)] -= 1.0;
        dense[(b, a)] -= 1.0;
    }
    let exact = dense.self_adjoint_eigenvalues(Side::Lower).unwrap();
    // The Ritz values of a 2k-dimensional Krylov space: within 1e-5 of the
    // largest (about 2e-7 measured; a basis of the wrong modes is off by
    // the gaps between eigenvalues, 1e-2 here).
    for i in 0..k {
        let got = basis.values()[i];
        assert!(
            (got - exact[i]).abs() < 1e-5 * exact[k - 1],
            "mode {i}: {got} vs {}",
            exact[i]
        );
    }
    // Ascending, the first one the constants.
    assert!(basis.values().windows(2).all(|p| p[0] <= p[1]));
    assert!(basis.values()[0] < 1e-10);
}

#[test]
fn the_same_mesh_gives_the_same_basis_bit_for_bit_and_is_shared() {
    let edges = grid_edges(12);
    let a = SmoothBasis::compute(144, &edges, 10).unwrap();
    let b = SmoothBasis::compute(144, &edges, 10).unwrap();
    assert_eq!(a, b);
    let s1 = SmoothBasis::shared(144, &edges, 10).unwrap();
    let s2 = SmoothBasis::shared(144, &edges, 10).unwrap();
    assert!(Arc::ptr_eq(&s1, &s2));
    assert_eq!(*s1, a);
    let other = SmoothBasis::shared(144, &edges[1..], 10).unwrap();
    assert_ne!(other.key(), s1.key());
}

#[test]
fn bad_inputs_are_errors() {
    let edges = grid_edges(4);
    assert!(matches!(
        SmoothBasis::compute(16, &edges, 0),
        Err(BasisError::Modes { .. })
    ));
    assert!(matches!(
        SmoothBasis::compute(16, &edges, 17),
        Err(BasisError::Modes { .. })
    ));
    assert!(matches!(
        SmoothBasis::compute(8, &edges, 2),
        Err(BasisError::InvalidMesh(_))
    ));
    assert!(matches!(
        SmoothBasis::compute(0, &[], 1),
        Err(BasisError::InvalidMesh(_))
    ));
}

/// While a thread has claimed a basis, `shared` waits for it (rather than
/// computing the same numbers again) and returns the one shared.
#[test]
fn shared_waits_for_a_claimed_basis_and_a_dropped_claim_releases_it() {
    let edges = grid_edges(11);
    let (n, k) = (121, 6);
    let key = edges_key(n, &edges);
    let claim = SmoothBasis::preparing(n, key, k).expect("nobody has it yet");
    assert!(
        SmoothBasis::preparing(n, key, k).is_none(),
        "one claim at a time"
    );
    let waiter = {
        let edges = edges.clone();
        std::thread::spawn(move || SmoothBasis::shared(n, &edges, k).unwrap())
    };
    // Computing this basis takes well under a millisecond: still running
    // after 200 ms means waiting.
    std::thread::sleep(std::time::Duration::from_millis(200));
    assert!(
        !waiter.is_finished(),
        "shared() computed instead of waiting"
    );
    let mine = SmoothBasis::share(SmoothBasis::compute(n, &edges, k).unwrap());
    drop(claim);
    assert!(Arc::ptr_eq(&waiter.join().unwrap(), &mine));

    // A claim given up without a basis: the waiter computes it.
    let edges = grid_edges(10);
    let (n, k) = (100, 4);
    let claim = SmoothBasis::preparing(n, edges_key(n, &edges), k).unwrap();
    let waiter = {
        let edges = edges.clone();
        std::thread::spawn(move || SmoothBasis::shared(n, &edges, k).unwrap())
    };
    std::thread::sleep(std::time::Duration::from_millis(50));
    drop(claim);
    let got = waiter.join().unwrap();
    assert_eq!(*got, SmoothBasis::compute(n, &edges, k).unwrap());
}

#[test]
fn edges_key_remembers_meshes_by_their_edges_not_their_address() {
    // Six meshes (more than are remembered), asked for twice each, in
    // place: the same buffer holds different edges each time.
    let mut edges: Vec<[u32; 2]> = (0..500).map(|i| [i, i + 1]).collect();
    let mut keys = Vec::new();
    for round in 0..2 {
        for m in 0..6u32 {
            edges[7] = [7, 100 + m];
            let key = edges_key(501, &edges);
            assert_eq!(
                key,
                super::fnv_edges(501, &edges),
                "mesh {m}, round {round}"
            );
            if round == 0 {
                keys.push(key);
            } else {
                assert_eq!(key, keys[m as usize]);
            }
        }
    }
    keys.sort_unstable();
    keys.dedup();
    assert_eq!(keys.len(), 6, "different edges, different keys");
    // The vertex count is part of the key.
    assert_ne!(edges_key(501, &edges), edges_key(502, &edges));
}
