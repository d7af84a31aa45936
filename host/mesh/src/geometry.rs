//! Geometric quantities of a [`Mesh`] and connectivity queries on a [`Topology`].
//!
//! All positions are metres in the station frame (Z up, +Y front); areas are
//! m^2, volumes m^3. Per-face results are indexed like [`Topology::faces`],
//! per-vertex results like [`Mesh::vertices`].

use crate::vec3::{cross, dot, norm, normalize, sub};
use crate::{Mesh, MeshError, Topology, Vec3};

/// Axis-aligned bounding box, metres.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Aabb {
    /// Smallest x, y, z.
    pub min: Vec3,
    /// Largest x, y, z.
    pub max: Vec3,
}

impl Aabb {
    /// `max - min` per axis (metres).
    pub fn extent(&self) -> Vec3 {
        sub(self.max, self.min)
    }
    /// Centre point (metres).
    pub fn centre(&self) -> Vec3 {
        [
            0.5 * (self.min[0] + self.max[0]),
            0.5 * (self.min[1] + self.max[1]),
            0.5 * (self.min[2] + self.max[2]),
        ]
    }
}

/// Result of [`Mesh::triangle_quality_vs`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct TriangleQuality {
    /// Triangles whose normal points against the reference triangle's normal
    /// (dot product < 0); degenerate triangles are not counted here.
    pub flipped: usize,
    /// Triangles with area below the tolerance.
    pub degenerate: usize,
    /// Triangles checked.
    pub total: usize,
}

/// Connected components: a label per element and the count.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Components {
    /// Component label of each element (face or vertex), `0..count`;
    /// components are numbered in order of their lowest element index.
    pub label: Vec<u32>,
    /// Number of components.
    pub count: usize,
}

impl Components {
    /// The element indices of component `c`, ascending.
    pub fn members(&self, c: u32) -> Vec<u32> {
        (0..self.label.len() as u32)
            .filter(|&i| self.label[i as usize] == c)
            .collect()
    }

    /// Number of elements in each component.
    pub fn sizes(&self) -> Vec<usize> {
        let mut s = vec![0; self.count];
        for &l in &self.label {
            s[l as usize] += 1;
        }
        s
    }
}

/// Union-find with path halving, used for component labelling.
struct Dsu(Vec<u32>);

impl Dsu {
    fn find(&mut self, mut x: u32) -> u32 {
        while self.0[x as usize] != x {
            let p = self.0[self.0[x as usize] as usize];
            self.0[x as usize] = p;
            x = p;
        }
        x
    }
    fn union(&mut self, a: u32, b: u32) {
        let (ra, rb) = (self.find(a), self.find(b));
        if ra != rb {
            // keep the smaller index as root so labels follow lowest index
            let (lo, hi) = (ra.min(rb), ra.max(rb));
            self.0[hi as usize] = lo;
        }
    }
    fn into_components(mut self) -> Components {
        let n = self.0.len();
        let mut map = vec![u32::MAX; n];
        let mut label = vec![0u32; n];
        let mut count = 0u32;
        for i in 0..n as u32 {
            let r = self.find(i);
            if map[r as usize] == u32::MAX {
                map[r as usize] = count;
                count += 1;
            }
            label[i as usize] = map[r as usize];
        }
        Components {
            label,
            count: count as usize,
        }
    }
}

impl Topology {
    /// Components of the faces, two faces being connected when they share an edge.
    pub fn face_components(&self) -> Components {
        let mut dsu = Dsu((0..self.faces().len() as u32).collect());
        for e in 0..self.edges().len() {
            let mut fs = self.edge_faces(e);
            if let (Some(a), Some(b)) = (fs.next(), fs.next()) {
                dsu.union(a, b);
            }
        }
        dsu.into_components()
    }

    /// Components of the vertices, two vertices being connected when they
    /// share an edge (an unused vertex is a component of its own).
    pub fn vertex_components(&self) -> Components {
        let mut dsu = Dsu((0..self.n_vertices() as u32).collect());
        for e in self.edges() {
            dsu.union(e[0], e[1]);
        }
        dsu.into_components()
    }

    /// Indices of edges used by exactly one face (the mesh boundary).
    pub fn boundary_edges(&self) -> Vec<usize> {
        (0..self.edges().len())
            .filter(|&e| self.edge_face_count(e) == 1)
            .collect()
    }

    /// True when every edge is used by exactly two faces (closed and
    /// edge-manifold, e.g. a watertight body).
    pub fn is_closed(&self) -> bool {
        (0..self.edges().len()).all(|e| self.edge_face_count(e) == 2)
    }
}

impl Mesh {
    /// Unnormalised face normal `(b - a) x (c - a)` of face `f`: its length is
    /// twice the area (m^2), direction outward for counter-clockwise faces.
    pub fn face_cross(&self, f: usize) -> Vec3 {
        let [a, b, c] = self.faces()[f].map(|i| self.vertices[i as usize]);
        cross(sub(b, a), sub(c, a))
    }

    /// Unit face normals, one per face (zero for a degenerate face).
    pub fn face_normals(&self) -> Vec<Vec3> {
        (0..self.faces().len())
            .map(|f| normalize(self.face_cross(f)))
            .collect()
    }

    /// Triangle areas in m^2, one per face.
    pub fn triangle_areas(&self) -> Vec<f64> {
        (0..self.faces().len())
            .map(|f| 0.5 * norm(self.face_cross(f)))
            .collect()
    }

    /// Total surface area, m^2.
    pub fn area(&self) -> f64 {
        self.triangle_areas().iter().sum()
    }

    /// Area-weighted unit vertex normals, one per vertex: the normalised sum
    /// of the unnormalised normals of the faces around the vertex (zero for
    /// an unused vertex).
    pub fn vertex_normals(&self) -> Vec<Vec3> {
        let mut n = vec![[0.0; 3]; self.vertices.len()];
        for (f, face) in self.faces().iter().enumerate() {
            let c = self.face_cross(f);
            for &v in face {
                let a = &mut n[v as usize];
                a[0] += c[0];
                a[1] += c[1];
                a[2] += c[2];
            }
        }
        n.into_iter().map(normalize).collect()
    }

    /// Signed volume in m^3 (divergence theorem). Positive for a closed mesh
    /// with outward (counter-clockwise) winding; meaningful only for closed meshes.
    pub fn signed_volume(&self) -> f64 {
        self.signed_volume_of(0..self.faces().len())
    }

    /// Signed volume (m^3) enclosed by the faces in `faces` (e.g. one closed component).
    pub fn signed_volume_of(&self, faces: impl IntoIterator<Item = usize>) -> f64 {
        faces
            .into_iter()
            .map(|f| {
                let [a, b, c] = self.faces()[f].map(|i| self.vertices[i as usize]);
                dot(a, cross(b, c))
            })
            .sum::<f64>()
            / 6.0
    }

    /// Axis-aligned bounding box of all vertices (metres), `None` for no vertices.
    pub fn bounding_box(&self) -> Option<Aabb> {
        bounding_box(&self.vertices)
    }

    /// Compares each triangle with the same triangle of `reference` (same
    /// topology, e.g. the template): counts triangles whose unit normal has a
    /// negative dot product with the reference's (flipped) and triangles with
    /// area below `min_area` m^2 (degenerate). Errors if the face counts differ.
    pub fn triangle_quality_vs(
        &self,
        reference: &Mesh,
        min_area: f64,
    ) -> Result<TriangleQuality, MeshError> {
        if reference.faces() != self.faces() {
            return Err(MeshError::TopologyMismatch {
                got: self.faces().len(),
                expected: reference.faces().len(),
            });
        }
        let mut q = TriangleQuality {
            total: self.faces().len(),
            ..Default::default()
        };
        for f in 0..self.faces().len() {
            let c = self.face_cross(f);
            if 0.5 * norm(c) < min_area {
                q.degenerate += 1;
            } else if dot(c, reference.face_cross(f)) < 0.0 {
                q.flipped += 1;
            }
        }
        Ok(q)
    }
}

impl Mesh {
    /// The mesh made of the faces `faces` (indices into [`Mesh::faces`], in
    /// the order given) and only the vertices they use, **kept in their
    /// original relative order**. Returns the new mesh and, for each of its
    /// vertices, the index of that vertex in `self`. E.g. the skin of a
    /// generated body without eyes and tongue. Errors if a face index is out of range.
    pub fn submesh(&self, faces: &[u32]) -> Result<(Mesh, Vec<u32>), MeshError> {
        let all = self.faces();
        let mut used = vec![false; self.vertices.len()];
        for &f in faces {
            let face = all.get(f as usize).ok_or(MeshError::FaceOutOfRange {
                face: f as usize,
                n_faces: all.len(),
            })?;
            for &v in face {
                used[v as usize] = true;
            }
        }
        let mut new_index = vec![u32::MAX; self.vertices.len()];
        let mut old_index = Vec::new();
        for (v, _) in used.iter().enumerate().filter(|(_, &u)| u) {
            new_index[v] = old_index.len() as u32;
            old_index.push(v as u32);
        }
        let vertices = old_index
            .iter()
            .map(|&v| self.vertices[v as usize])
            .collect();
        let new_faces = faces
            .iter()
            .map(|&f| all[f as usize].map(|v| new_index[v as usize]))
            .collect();
        Ok((Mesh::from_faces(vertices, new_faces)?, old_index))
    }
}

/// Axis-aligned bounding box of points (metres), `None` for an empty slice.
pub fn bounding_box(points: &[Vec3]) -> Option<Aabb> {
    let first = *points.first()?;
    let mut b = Aabb {
        min: first,
        max: first,
    };
    for p in points {
        for (k, &c) in p.iter().enumerate() {
            b.min[k] = b.min[k].min(c);
            b.max[k] = b.max[k].max(c);
        }
    }
    Some(b)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Axis-aligned box [0,a]x[0,b]x[0,c] with outward triangles.
    pub(crate) fn cuboid(a: f64, b: f64, c: f64) -> Mesh {
        let v = (0..8)
            .map(|i| {
                [
                    if i & 1 != 0 { a } else { 0.0 },
                    if i & 2 != 0 { b } else { 0.0 },
                    if i & 4 != 0 { c } else { 0.0 },
                ]
            })
            .collect();
        let quads = [
            [0, 2, 3, 1], // z = 0, normal -z
            [4, 5, 7, 6], // z = c
            [0, 1, 5, 4], // y = 0
            [2, 6, 7, 3], // y = b
            [0, 4, 6, 2], // x = 0
            [1, 3, 7, 5], // x = a
        ];
        let faces = quads
            .iter()
            .flat_map(|q| [[q[0], q[1], q[2]], [q[0], q[2], q[3]]])
            .collect();
        Mesh::from_faces(v, faces).unwrap()
    }

    #[test]
    fn cuboid_measures_are_analytic() {
        let m = cuboid(2.0, 3.0, 0.5);
        assert!((m.signed_volume() - 3.0).abs() < 1e-12);
        assert!((m.area() - 2.0 * (6.0 + 1.0 + 1.5)).abs() < 1e-12);
        let bb = m.bounding_box().unwrap();
        assert_eq!(bb.min, [0.0; 3]);
        assert_eq!(bb.max, [2.0, 3.0, 0.5]);
        assert_eq!(bb.centre(), [1.0, 1.5, 0.25]);
        assert!(m.topology.is_closed());
        assert!(m.topology.boundary_edges().is_empty());
        // Every face normal points away from the centre.
        for (f, n) in m.face_normals().iter().enumerate() {
            let [a, _, _] = m.faces()[f].map(|i| m.vertices[i as usize]);
            assert!(dot(*n, sub(a, bb.centre())) > 0.0);
        }
        // Corner vertex normals point diagonally outward.
        let n0 = m.vertex_normals()[0];
        assert!(n0.iter().all(|&c| c < 0.0), "{n0:?}");
        assert!((norm(n0) - 1.0).abs() < 1e-12);
    }

    #[test]
    fn reversed_winding_flips_volume_and_quality() {
        let m = cuboid(1.0, 1.0, 1.0);
        let rev: Vec<[u32; 3]> = m.faces().iter().map(|f| [f[0], f[2], f[1]]).collect();
        let r = Mesh::from_faces(m.vertices.clone(), rev).unwrap();
        assert!((r.signed_volume() + 1.0).abs() < 1e-12);
        // Different faces: a topology mismatch.
        assert!(r.triangle_quality_vs(&m, 1e-12).is_err());
        // Same topology, mirrored geometry through the plane z = 0.5 flips every triangle.
        let mut mirrored = m.clone();
        mirrored.vertices.iter_mut().for_each(|v| v[2] = 1.0 - v[2]);
        let q = mirrored.triangle_quality_vs(&m, 1e-12).unwrap();
        assert_eq!(q.total, 12);
        // A reflection maps n to -R(n): the z walls keep their normal, the x and y walls flip.
        assert_eq!(q.flipped, 8);
        // Collapse to a plane: the walls become degenerate.
        let mut flat = m.clone();
        flat.vertices.iter_mut().for_each(|v| v[2] = 0.0);
        let q = flat.triangle_quality_vs(&m, 1e-9).unwrap();
        assert_eq!(q.degenerate, 8);
        assert_eq!(m.triangle_quality_vs(&m, 1e-9).unwrap().flipped, 0);
    }

    #[test]
    fn submesh_keeps_vertex_order() {
        let a = cuboid(1.0, 1.0, 1.0);
        let mut v = a.vertices.clone();
        v.extend(a.vertices.iter().map(|p| [p[0] + 5.0, p[1], p[2]]));
        let mut faces = a.faces().to_vec();
        faces.extend(a.faces().iter().map(|f| f.map(|i| i + 8)));
        let two = Mesh::from_faces(v, faces).unwrap();
        let second: Vec<u32> = (12..24).collect();
        let (sub, old) = two.submesh(&second).unwrap();
        assert_eq!(old, (8..16).collect::<Vec<u32>>());
        assert_eq!(sub.faces(), a.faces());
        assert!((sub.signed_volume() - 1.0).abs() < 1e-12);
        for (k, &o) in old.iter().enumerate() {
            assert_eq!(sub.vertices[k], two.vertices[o as usize]);
        }
        assert!(matches!(
            two.submesh(&[24]),
            Err(MeshError::FaceOutOfRange {
                face: 24,
                n_faces: 24
            })
        ));
    }

    #[test]
    fn components_of_two_boxes_and_a_loose_vertex() {
        let a = cuboid(1.0, 1.0, 1.0);
        let mut v = a.vertices.clone();
        v.extend(a.vertices.iter().map(|p| [p[0] + 5.0, p[1], p[2]]));
        v.push([9.0, 9.0, 9.0]);
        let mut faces = a.faces().to_vec();
        faces.extend(a.faces().iter().map(|f| f.map(|i| i + 8)));
        let m = Mesh::from_faces(v, faces).unwrap();
        let fc = m.topology.face_components();
        assert_eq!(fc.count, 2);
        assert_eq!(fc.sizes(), vec![12, 12]);
        assert_eq!(fc.members(1), (12..24).collect::<Vec<u32>>());
        let vc = m.topology.vertex_components();
        assert_eq!(vc.count, 3);
        assert_eq!(vc.label[16], 2);
        // An open mesh: drop one triangle.
        let open = Mesh::from_faces(a.vertices.clone(), a.faces()[1..].to_vec()).unwrap();
        assert!(!open.topology.is_closed());
        assert_eq!(open.topology.boundary_edges().len(), 3);
    }
}
