//! Folds on step 2's body, and smoothing them out
//! ([`super::Step2Settings::fold_repair`]).
//!
//! A triangle is *folded* when its normal turned by more than 90 degrees
//! from the step-1 shape's (flipped) or its area fell below 1 % of it
//! (collapsed), as [`super::triangle_changes`] counts them. Step 2's
//! membrane term lets a reading pull a few vertices through their
//! neighbours where the template's surface cannot follow it (the crotch,
//! the navel, the armpits); the repair gives each free vertex of the folded
//! triangles' neighbourhood the mean displacement of its neighbours (a
//! Jacobi step of the displacement's Laplace equation, the region's border
//! and the pinned vertices held), a few rounds at a time, the region
//! growing by a ring when it does not settle. A triangle still folded after
//! that (mostly the template's slivers, a millimetre across, whose vertices
//! the smoothing moves by nearly but not exactly the same) is then moved as
//! one piece, with its held vertices where it has any. Written here because
//! it is a few dozen lines over the template's own edges; no mesh crate has
//! it.

use tapeshape_mesh::vec3::{add, cross, dot, norm, scale, sub, triangle_normal};
use tapeshape_mesh::{Topology, Vec3};

/// Rings of neighbours around the folded triangles smoothed from the start.
pub(crate) const REPAIR_RINGS: usize = 2;

/// Smoothing rounds at most.
pub(crate) const REPAIR_ROUNDS: usize = 60;

/// The region grows by a ring every this many rounds.
pub(crate) const REPAIR_GROW_EVERY: usize = 20;

/// Passes that move the triangles still folded after the smoothing as one
/// piece each ([`translate_folded`]), while the count falls.
pub(crate) const TRANSLATE_PASSES: usize = 5;

/// How a triangle of the template changed from `before` to `after`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Fold {
    /// Its normal turned by more than 90 degrees.
    Flipped,
    /// Its area fell below 1 % of what it was.
    Collapsed,
}

/// Whether face `f` (vertex indices) of `after` is folded against
/// `before` (both V vertices, the same unit), and how.
pub(crate) fn fold_of(before: &[Vec3], after: &[Vec3], f: &[u32; 3]) -> Option<Fold> {
    let normal = |p: &[Vec3]| triangle_normal(p[f[0] as usize], p[f[1] as usize], p[f[2] as usize]);
    let (n0, n1) = (normal(before), normal(after));
    if dot(n0, n1) < 0.0 {
        Some(Fold::Flipped)
    } else if norm(n1) < 0.01 * norm(n0) {
        Some(Fold::Collapsed)
    } else {
        None
    }
}

/// The faces (indices into `topology.faces()`) of `after` flipped or
/// collapsed against `before` (both V vertices, the same unit).
pub(crate) fn folded_faces(topology: &Topology, before: &[Vec3], after: &[Vec3]) -> Vec<usize> {
    topology
        .faces()
        .iter()
        .enumerate()
        .filter(|(_, f)| fold_of(before, after, f).is_some())
        .map(|(i, _)| i)
        .collect()
}

/// How far (degrees) the fold of an edge (the angle between its two
/// triangles' normals) may grow from the step-1 shape before the edge
/// counts as creased ([`creased_edges`]). Step 2's displacement is meant to
/// be smooth, and the step-1 shape, inside the learned space, already bends
/// where the training bodies bend; a fold grown by tens of degrees across
/// one edge of the template is a ridge or a crease.
pub(crate) const CREASE_DEG: f64 = 30.0;

/// How many creased edges ([`CREASE_DEG`]) a step-2 body may have before
/// step 2 counts it as folded (and tries a smaller soft pull,
/// `SOFT_PULL_SHARES` in `step2.rs`). Why 20: a few edges grow that much on
/// most bodies (the template's slivers, the armpits, the crotch) without
/// anything wrong; calibrated on 1,500 ANSUR II *train-split* people
/// (`quick`, with sex, the embedded default model, 2026-12-07): at most 15
/// such edges on any of them (median 2, 99th percentile 11). Test-split
/// subject 25296, whose body the surface check failed
/// (`docs/results/real-customers/surface-check.md`), had 52: ridges over
/// the head, torso and thighs where step 2 followed the soft targets.
pub(crate) const CREASES_ALLOWED: usize = 20;

/// The interior edges (two triangles) of `topology` whose fold grew by
/// more than [`CREASE_DEG`] from `before` to `after` (both V vertices, the
/// same unit). A flipped triangle's edges usually count too (not an
/// edge between two triangles flipped together). Written here for the
/// same reason as the repair: a few lines over the template's own edges.
pub(crate) fn creased_edges(topology: &Topology, before: &[Vec3], after: &[Vec3]) -> usize {
    let faces = topology.faces();
    let normals = |p: &[Vec3]| -> Vec<Vec3> {
        faces
            .iter()
            .map(|f| triangle_normal(p[f[0] as usize], p[f[1] as usize], p[f[2] as usize]))
            .collect()
    };
    let fold = |n: Vec3, m: Vec3| {
        if norm(n) == 0.0 || norm(m) == 0.0 {
            return std::f64::consts::PI;
        }
        norm(cross(n, m)).atan2(dot(n, m))
    };
    let limit = CREASE_DEG.to_radians();
    let cos_limit = limit.cos();
    let after_n = normals(after);
    // An edge whose fold on `after` is below the limit cannot have grown
    // by more than it: most edges are left at a dot product (squared, no
    // square root: the limit is below 90 degrees, so a negative dot product
    // is beyond it), and the angles (atan2, the cost) are taken for the
    // rest only.
    debug_assert!(cos_limit > 0.0);
    let candidates: Vec<(u32, u32)> = (0..topology.edges().len())
        .filter(|&e| topology.edge_face_count(e) == 2)
        .filter_map(|e| {
            let mut it = topology.edge_faces(e);
            let (f, g) = (it.next()?, it.next()?);
            let (n, m) = (after_n[f as usize], after_n[g as usize]);
            let (d, nn, mm) = (dot(n, m), dot(n, n), dot(m, m));
            // A degenerate triangle has no direction: it counts as folded
            // (`fold` gives it pi).
            (d < 0.0 || nn == 0.0 || mm == 0.0 || d * d < cos_limit * cos_limit * nn * mm)
                .then_some((f, g))
        })
        .collect();
    let normal = |p: &[Vec3], f: u32| {
        let [a, b, c] = faces[f as usize].map(|v| p[v as usize]);
        triangle_normal(a, b, c)
    };
    candidates
        .into_iter()
        .filter(|&(f, g)| {
            fold(after_n[f as usize], after_n[g as usize])
                - fold(normal(before, f), normal(before, g))
                > limit
        })
        .count()
}

/// Smooths the displacement `x - reference` around the folded triangles
/// of `x` (both V vertices, the same unit; `x` is changed in place), the
/// vertices with `pinned[v]` held. Returns how many triangles were folded
/// before and after.
pub(crate) fn smooth_folds(
    topology: &Topology,
    reference: &[Vec3],
    x: &mut [Vec3],
    pinned: &[bool],
) -> (usize, usize) {
    let n = topology.n_vertices();
    let mut folded = folded_faces(topology, reference, x);
    let before = folded.len();
    if before == 0 {
        return (0, 0);
    }
    // Only the region's vertices move in a round, and the region holds
    // every folded triangle's vertices, so the triangles folded after a
    // round are among those touching the region: the rings are grown and
    // the folds looked for there, not over the whole mesh (the same
    // result as scanning all vertices and faces, 31 -> a few ms for a
    // body with two folded triangles).
    let mut face_offsets = vec![0u32; n + 1];
    for f in topology.faces() {
        for &v in f {
            face_offsets[v as usize + 1] += 1;
        }
    }
    for v in 0..n {
        face_offsets[v + 1] += face_offsets[v];
    }
    let mut face_of = vec![0u32; face_offsets[n] as usize];
    let mut fill = face_offsets.clone();
    for (i, f) in topology.faces().iter().enumerate() {
        for &v in f {
            face_of[fill[v as usize] as usize] = i as u32;
            fill[v as usize] += 1;
        }
    }
    let mut free = vec![false; n];
    for round in 0..REPAIR_ROUNDS {
        if folded.is_empty() {
            break;
        }
        let mut region: Vec<usize> = Vec::new();
        for &f in &folded {
            for v in topology.faces()[f] {
                if !free[v as usize] {
                    free[v as usize] = true;
                    region.push(v as usize);
                }
            }
        }
        let mut frontier = region.clone();
        for _ in 0..REPAIR_RINGS + round / REPAIR_GROW_EVERY {
            let mut ring = Vec::new();
            for &v in &frontier {
                for &w in topology.ring(v as u32) {
                    if !free[w as usize] {
                        free[w as usize] = true;
                        ring.push(w as usize);
                    }
                }
            }
            region.extend_from_slice(&ring);
            frontier = ring;
        }
        // In place, in vertex order (Gauss-Seidel): each vertex sees the
        // neighbours already moved this round.
        region.sort_unstable();
        for &v in region.iter().filter(|&&v| !pinned[v]) {
            let ring = topology.ring(v as u32);
            if ring.is_empty() {
                continue;
            }
            let k = ring.len() as f64;
            let mut d = [0.0; 3];
            for &w in ring {
                for c in 0..3 {
                    d[c] += (x[w as usize][c] - reference[w as usize][c]) / k;
                }
            }
            for c in 0..3 {
                x[v][c] = reference[v][c] + d[c];
            }
        }
        let mut touched: Vec<usize> = region
            .iter()
            .flat_map(|&v| &face_of[face_offsets[v] as usize..face_offsets[v + 1] as usize])
            .map(|&f| f as usize)
            .collect();
        touched.sort_unstable();
        touched.dedup();
        folded = touched
            .into_iter()
            .filter(|&f| fold_of(reference, x, &topology.faces()[f]).is_some())
            .collect();
        region.iter().for_each(|&v| free[v] = false);
    }
    for _ in 0..TRANSLATE_PASSES {
        if folded.is_empty() {
            break;
        }
        let saved = x.to_vec();
        translate_folded(topology, reference, x, pinned, &folded);
        let now = folded_faces(topology, reference, x);
        if now.len() >= folded.len() {
            x.copy_from_slice(&saved);
            break;
        }
        folded = now;
    }
    (before, folded.len())
}

/// Moves each of the `folded` faces of `x` as one piece (`reference`,
/// `x`: V vertices, the same unit; `x` changed in place): its free vertices
/// take the mean displacement from `reference` of its held vertices, or of
/// all three where none is held. A translated triangle has the reference's
/// normal and area, so it is no longer folded; where the smoothing leaves a
/// sliver of the template (edges of a millimetre, whose vertices move by
/// nearly but not exactly the same) folded, this unfolds it at the cost of
/// a fraction of a millimetre. A face whose three vertices are held is left.
fn translate_folded(
    topology: &Topology,
    reference: &[Vec3],
    x: &mut [Vec3],
    pinned: &[bool],
    folded: &[usize],
) {
    for &f in folded {
        let face = topology.faces()[f].map(|v| v as usize);
        let held: Vec<usize> = face.iter().copied().filter(|&v| pinned[v]).collect();
        if held.len() == face.len() {
            continue;
        }
        let from: &[usize] = if held.is_empty() { &face } else { &held };
        let n = from.len() as f64;
        let d = from.iter().fold([0.0; 3], |d, &v| {
            add(d, sub(x[v], reference[v]).map(|e| e / n))
        });
        for v in face.into_iter().filter(|&v| !pinned[v]) {
            x[v] = add(reference[v], d);
        }
    }
}

/// Moves the neighbourhood of each group of folded faces of `x` as one
/// piece (`reference`, `x`: V vertices, the same unit; `x` changed in
/// place): the folded faces' vertices and one ring of neighbours around
/// them, each connected group taking the mean displacement from
/// `reference` of its `held` vertices where it has any (a landmark stays
/// where it was), else of all its vertices, blended into the displacement around it over `band` more
/// rings (linearly with the ring's distance). Inside a group every
/// triangle then has the reference's normal and area; the band spreads
/// the change over a few rings so that its small triangles do not fold
/// in turn. Nothing is held: this is the last resort of the fold repair,
/// for the folds that smoothing left (a template sliver whose neighbours
/// [`smooth_folds`] moves apart again). Returns how many faces are folded
/// after.
pub(crate) fn translate_regions(
    topology: &Topology,
    reference: &[Vec3],
    x: &mut [Vec3],
    held: &[bool],
    band: usize,
) -> usize {
    let n = topology.n_vertices();
    let folded = folded_faces(topology, reference, x);
    if folded.is_empty() {
        return 0;
    }
    // The core: the folded faces' vertices and one ring.
    let mut core = vec![false; n];
    let mut seeds: Vec<usize> = Vec::new();
    for &f in &folded {
        for v in topology.faces()[f] {
            if !core[v as usize] {
                core[v as usize] = true;
                seeds.push(v as usize);
            }
        }
    }
    for v in seeds {
        for &w in topology.ring(v as u32) {
            core[w as usize] = true;
        }
    }
    // Connected groups of the core and their mean displacements.
    const NONE: usize = usize::MAX;
    let mut group_of = vec![NONE; n];
    let mut means: Vec<Vec3> = Vec::new();
    for start in 0..n {
        if !core[start] || group_of[start] != NONE {
            continue;
        }
        let g = means.len();
        group_of[start] = g;
        let mut group = vec![start];
        let mut k = 0;
        while k < group.len() {
            for &w in topology.ring(group[k] as u32) {
                let w = w as usize;
                if core[w] && group_of[w] == NONE {
                    group_of[w] = g;
                    group.push(w);
                }
            }
            k += 1;
        }
        let pinned: Vec<usize> = group.iter().copied().filter(|&v| held[v]).collect();
        let from: &[usize] = if pinned.is_empty() { &group } else { &pinned };
        let m = from.len() as f64;
        means.push(from.iter().fold([0.0; 3], |d, &v| {
            add(d, sub(x[v], reference[v]).map(|e| e / m))
        }));
    }
    // The band: rings around the core by breadth-first distance, each
    // vertex blended towards the group that reached it first.
    let mut dist = vec![NONE; n];
    let mut frontier: Vec<usize> = (0..n).filter(|&v| core[v]).collect();
    frontier.iter().for_each(|&v| dist[v] = 0);
    for k in 1..=band {
        let mut ring = Vec::new();
        for &v in &frontier {
            for &w in topology.ring(v as u32) {
                let w = w as usize;
                if dist[w] == NONE {
                    dist[w] = k;
                    group_of[w] = group_of[v];
                    ring.push(w);
                }
            }
        }
        frontier = ring;
    }
    for v in 0..n {
        if dist[v] == NONE {
            continue;
        }
        let t = dist[v] as f64 / (band + 1) as f64;
        let own = sub(x[v], reference[v]);
        let d = add(scale(means[group_of[v]], 1.0 - t), scale(own, t));
        x[v] = add(reference[v], d);
    }
    folded_faces(topology, reference, x).len()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A flat n x n grid in the z = 0 plane, spacing 1, two triangles per
    /// cell (counter-clockwise seen from +z).
    fn grid(n: usize) -> (Topology, Vec<Vec3>) {
        let id = |i: usize, j: usize| (i * n + j) as u32;
        let mut faces = Vec::new();
        for i in 0..n - 1 {
            for j in 0..n - 1 {
                faces.push([id(i, j), id(i, j + 1), id(i + 1, j + 1)]);
                faces.push([id(i, j), id(i + 1, j + 1), id(i + 1, j)]);
            }
        }
        let points = (0..n * n)
            .map(|k| [(k % n) as f64, (k / n) as f64, 0.0])
            .collect();
        (Topology::new(n * n, faces).unwrap(), points)
    }

    /// The 9 x 9 grid folded along the line x = 4 by `deg` degrees: the
    /// part with x > 4 turned about that line (the y axis through x = 4).
    fn folded_grid(deg: f64) -> Vec<Vec3> {
        let (_, flat) = grid(9);
        let (s, c) = deg.to_radians().sin_cos();
        flat.iter()
            .map(|p| {
                if p[0] > 4.0 {
                    let d = p[0] - 4.0;
                    [4.0 + d * c, p[1], d * s]
                } else {
                    *p
                }
            })
            .collect()
    }

    #[test]
    fn a_grid_folded_along_a_line_creases_exactly_that_line() {
        let (topo, flat) = grid(9);
        // The line x = 4 has 8 edges, each between a triangle of the cell
        // to its left and one of the cell to its right; every other edge
        // stays between two coplanar triangles.
        assert_eq!(creased_edges(&topo, &flat, &folded_grid(45.0)), 8);
        assert_eq!(
            creased_edges(&topo, &flat, &folded_grid(CREASE_DEG + 1.0)),
            8
        );
        assert_eq!(
            creased_edges(&topo, &flat, &folded_grid(CREASE_DEG - 1.0)),
            0
        );
        // Growth, not the fold itself: from the 20-degree fold to the
        // 45-degree one the line grows by 25 degrees only.
        assert_eq!(
            creased_edges(&topo, &folded_grid(20.0), &folded_grid(45.0)),
            0
        );
        // Past 90 degrees (a negative dot product) and all the way over.
        assert_eq!(creased_edges(&topo, &flat, &folded_grid(150.0)), 8);
        // Vertex (4, 4) moved onto the segment (5, 4)-(5, 5): their
        // triangle collapses to a line and has no direction (fold pi), so
        // its edges count (its neighbours across (4, 4)'s ring may flip and
        // count as well).
        let mut collapsed = flat.clone();
        collapsed[4 * 9 + 4] = [5.0, 4.5, 0.0];
        assert!(creased_edges(&topo, &flat, &collapsed) >= 2);
        // Unfolding is no crease, and a rigid motion changes no fold.
        assert_eq!(creased_edges(&topo, &folded_grid(60.0), &flat), 0);
        let moved: Vec<Vec3> = folded_grid(60.0)
            .iter()
            .map(|p| [p[1] + 3.0, -p[0], p[2] - 1.0])
            .collect();
        assert_eq!(creased_edges(&topo, &folded_grid(60.0), &moved), 0);
    }

    #[test]
    fn a_vertex_pushed_through_its_neighbours_is_smoothed_back() {
        let (topo, reference) = grid(9);
        let mut x = reference.clone();
        // A smooth bump everywhere, then one vertex pulled 1.6 spacings
        // sideways, past its neighbours: its ring folds.
        for p in x.iter_mut() {
            p[2] = 0.1 * (p[0] * 0.3).sin();
        }
        let centre = 4 * 9 + 4;
        x[centre][0] += 1.6;
        let folded = folded_faces(&topo, &reference, &x).len();
        assert!(folded > 0);
        let bump: Vec<Vec3> = x.clone();
        let (before, after) = smooth_folds(&topo, &reference, &mut x, &[false; 81]);
        assert_eq!((before, after), (folded, 0));
        // Only the neighbourhood moved: the grid's border is untouched.
        for v in [0, 8, 72, 80, 40 - 4] {
            assert_eq!(x[v], bump[v], "vertex {v}");
        }
    }

    #[test]
    fn pinned_vertices_stay_and_a_body_without_folds_is_unchanged() {
        let (topo, reference) = grid(9);
        let mut x = reference.clone();
        let centre = 4 * 9 + 4;
        x[centre][0] += 1.6;
        let mut pinned = vec![false; 81];
        pinned[centre] = true;
        let moved = x[centre];
        let (before, after) = smooth_folds(&topo, &reference, &mut x, &pinned);
        assert!(before > 0);
        assert_eq!(x[centre], moved);
        // The neighbours follow the pinned vertex far enough to unfold.
        assert_eq!(after, 0);

        let mut flat = reference.clone();
        flat.iter_mut().for_each(|p| p[2] += 0.5);
        let copy = flat.clone();
        assert_eq!(smooth_folds(&topo, &reference, &mut flat, &pinned), (0, 0));
        assert_eq!(flat, copy);
    }

    #[test]
    fn a_folded_neighbourhood_moved_as_one_piece_unfolds_and_the_rest_stays() {
        let (topo, reference) = grid(9);
        // A smooth displacement everywhere, then the centre vertex pushed
        // through its neighbours.
        let mut x: Vec<Vec3> = reference
            .iter()
            .map(|p| [p[0] + 0.2, p[1] - 0.1, 0.05 * p[0]])
            .collect();
        let centre = 4 * 9 + 4;
        x[centre][0] += 1.6;
        assert!(!folded_faces(&topo, &reference, &x).is_empty());
        let before = x.clone();
        assert_eq!(
            translate_regions(&topo, &reference, &mut x, &[false; 81], 0),
            0
        );
        // The centre and its ring took one displacement; beyond two rings
        // nothing moved.
        let d = |v: usize| sub(x[v], reference[v]);
        for &w in topo.ring(centre as u32) {
            assert!(norm(sub(d(w as usize), d(centre))) < 1e-12);
        }
        for v in [0, 8, 72, 80, 4, 36, 44, 76] {
            assert_eq!(x[v], before[v], "vertex {v}");
        }
        // A body without folds is left as it is.
        let mut clean: Vec<Vec3> = reference.iter().map(|p| [p[0] + 0.2, p[1], 0.0]).collect();
        let same = clean.clone();
        assert_eq!(
            translate_regions(&topo, &reference, &mut clean, &[false; 81], 3),
            0
        );
        assert_eq!(clean, same);
    }

    #[test]
    fn a_folded_face_is_translated_by_its_held_vertices_or_its_mean() {
        let (topo, reference) = grid(5);
        let f = 10;
        let face = topo.faces()[f].map(|v| v as usize);
        let displacement = [[0.3, -0.2, 0.1], [-1.5, 0.4, 0.0], [0.6, 2.0, -0.3]];
        let mut x = reference.clone();
        for (v, d) in face.iter().zip(displacement) {
            for c in 0..3 {
                x[*v][c] += d[c];
            }
        }
        assert_eq!(
            fold_of(&reference, &x, &topo.faces()[f]),
            Some(Fold::Flipped)
        );

        // Nothing held: the three take their mean displacement, the face
        // is the reference's moved, no other vertex changes.
        let mut free = x.clone();
        translate_folded(&topo, &reference, &mut free, &[false; 25], &[f]);
        let mean = [-0.2, 2.2 / 3.0, -0.2 / 3.0];
        for v in 0..25 {
            for c in 0..3 {
                let want = if face.contains(&v) {
                    reference[v][c] + mean[c]
                } else {
                    x[v][c]
                };
                assert!((free[v][c] - want).abs() < 1e-12, "vertex {v}");
            }
        }
        assert_eq!(fold_of(&reference, &free, &topo.faces()[f]), None);

        // One held: it stays, the others take its displacement.
        let mut pinned = [false; 25];
        pinned[face[1]] = true;
        let mut held = x.clone();
        translate_folded(&topo, &reference, &mut held, &pinned, &[f]);
        assert_eq!(held[face[1]], x[face[1]]);
        for v in [face[0], face[2]] {
            for c in 0..3 {
                assert!((held[v][c] - reference[v][c] - displacement[1][c]).abs() < 1e-12);
            }
        }
        assert_eq!(fold_of(&reference, &held, &topo.faces()[f]), None);

        // All three held: left as it is.
        face.iter().for_each(|&v| pinned[v] = true);
        let mut all = x.clone();
        translate_folded(&topo, &reference, &mut all, &pinned, &[f]);
        assert_eq!(all, x);
    }

    #[test]
    fn folds_counts_flipped_and_collapsed_triangles_like_the_report() {
        let (topo, reference) = grid(5);
        let mut x = reference.clone();
        x[12][0] += 1.6;
        let (flipped, collapsed) = super::super::triangle_changes(&topo, &reference, &x);
        assert_eq!(
            folded_faces(&topo, &reference, &x).len(),
            flipped + collapsed
        );
        assert!(flipped > 0);
    }
}
