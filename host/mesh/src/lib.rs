//! Triangle meshes for tapeshape.
//!
//! Frame and units everywhere in tapeshape: **metres, f64, Z up, feet at
//! z = 0, +Y towards the body's front**, +X towards the body's right side (see
//! the MakeHuman pack's README, section 2.4). Vertex order is the template's
//! order and is never changed by any function in this crate.
//!
//! The [`Topology`] (edges, one-rings, face adjacency) depends only on the
//! faces, so it is computed once per template and shared (through an
//! [`std::sync::Arc`]) by every body with that topology.
//!
//! [`geometry`] holds normals, areas, volume, bounding box, connected
//! components and the triangle-quality check; [`io`] reads and writes OBJ and
//! PLY and writes binary glTF (converted to glTF's Y-up frame); [`vec3`] is
//! the one set of small vector operations on [`Vec3`] every crate uses.

use std::sync::Arc;

pub mod geometry;
pub mod io;
pub mod vec3;

pub use geometry::{Aabb, Components, TriangleQuality};
pub use io::MeshIoError;

/// A 3D point or vector in metres, station frame (Z up, +Y front).
pub type Vec3 = [f64; 3];

/// Errors from building or reading meshes.
#[derive(Debug, thiserror::Error)]
pub enum MeshError {
    /// A face refers to a vertex index that does not exist.
    #[error("face {face} uses vertex {vertex}, but the mesh has only {n_vertices} vertices")]
    VertexOutOfRange {
        /// Face index.
        face: usize,
        /// Offending vertex index.
        vertex: u32,
        /// Number of vertices.
        n_vertices: usize,
    },
    /// A face uses the same vertex twice.
    #[error("face {face} is degenerate: it uses vertex {vertex} more than once")]
    DegenerateFace {
        /// Face index.
        face: usize,
        /// Repeated vertex.
        vertex: u32,
    },
    /// Vertex count does not match the topology.
    #[error("{got} vertices given, but the topology has {expected}")]
    VertexCountMismatch {
        /// Vertices given.
        got: usize,
        /// Vertices the topology expects.
        expected: usize,
    },
    /// A face index that does not exist.
    #[error("face {face} does not exist: the mesh has {n_faces} faces")]
    FaceOutOfRange {
        /// Face index given.
        face: usize,
        /// Number of faces.
        n_faces: usize,
    },
    /// Two meshes compared face by face do not have the same faces.
    #[error(
        "the meshes have different faces ({got} vs {expected} triangles or a different order)"
    )]
    TopologyMismatch {
        /// Faces of the mesh checked.
        got: usize,
        /// Faces of the reference.
        expected: usize,
    },
}

/// Connectivity of a triangle mesh, independent of vertex positions.
///
/// All index lists are sorted so results are deterministic.
#[derive(Debug, Clone)]
pub struct Topology {
    n_vertices: usize,
    faces: Vec<[u32; 3]>,
    /// Unique undirected edges `[a, b]` with `a < b`, sorted.
    edges: Vec<[u32; 2]>,
    /// CSR offsets into `ring_vertices` (length `n_vertices + 1`).
    ring_offsets: Vec<u32>,
    /// One-ring neighbours of each vertex, sorted ascending.
    ring_vertices: Vec<u32>,
    /// For each edge: the (one or two) faces that use it; `u32::MAX` if none.
    edge_faces: Vec<[u32; 2]>,
    /// For each edge: how many faces use it (more than 2 = non-manifold).
    edge_face_counts: Vec<u32>,
}

impl Topology {
    /// Builds the topology of `n_vertices` vertices and triangles `faces`
    /// (counter-clockwise seen from outside).
    ///
    /// Errors if a face refers to a missing vertex or repeats a vertex.
    pub fn new(n_vertices: usize, faces: Vec<[u32; 3]>) -> Result<Self, MeshError> {
        for (fi, f) in faces.iter().enumerate() {
            for &v in f {
                if v as usize >= n_vertices {
                    return Err(MeshError::VertexOutOfRange {
                        face: fi,
                        vertex: v,
                        n_vertices,
                    });
                }
            }
            if f[0] == f[1] || f[0] == f[2] {
                return Err(MeshError::DegenerateFace {
                    face: fi,
                    vertex: f[0],
                });
            }
            if f[1] == f[2] {
                return Err(MeshError::DegenerateFace {
                    face: fi,
                    vertex: f[1],
                });
            }
        }
        let mut directed: Vec<(u32, u32, u32)> = Vec::with_capacity(faces.len() * 3);
        for (fi, f) in faces.iter().enumerate() {
            for k in 0..3 {
                let (a, b) = (f[k], f[(k + 1) % 3]);
                directed.push((a.min(b), a.max(b), fi as u32));
            }
        }
        directed.sort_unstable();
        let mut edges: Vec<[u32; 2]> = Vec::new();
        let mut edge_faces: Vec<[u32; 2]> = Vec::new();
        let mut edge_face_counts: Vec<u32> = Vec::new();
        for &(a, b, fi) in &directed {
            if edges.last() == Some(&[a, b]) {
                *edge_face_counts.last_mut().expect("parallels edges") += 1;
                let ef = edge_faces.last_mut().expect("edge_faces parallels edges");
                if ef[1] == u32::MAX {
                    ef[1] = fi;
                }
            } else {
                edges.push([a, b]);
                edge_faces.push([fi, u32::MAX]);
                edge_face_counts.push(1);
            }
        }
        let mut degree = vec![0u32; n_vertices];
        for e in &edges {
            degree[e[0] as usize] += 1;
            degree[e[1] as usize] += 1;
        }
        let mut ring_offsets = vec![0u32; n_vertices + 1];
        for v in 0..n_vertices {
            ring_offsets[v + 1] = ring_offsets[v] + degree[v];
        }
        let mut fill = ring_offsets.clone();
        let mut ring_vertices = vec![0u32; ring_offsets[n_vertices] as usize];
        for e in &edges {
            let (a, b) = (e[0] as usize, e[1] as usize);
            ring_vertices[fill[a] as usize] = e[1];
            fill[a] += 1;
            ring_vertices[fill[b] as usize] = e[0];
            fill[b] += 1;
        }
        for v in 0..n_vertices {
            ring_vertices[ring_offsets[v] as usize..ring_offsets[v + 1] as usize].sort_unstable();
        }
        Ok(Self {
            n_vertices,
            faces,
            edges,
            ring_offsets,
            ring_vertices,
            edge_faces,
            edge_face_counts,
        })
    }

    /// Number of vertices.
    pub fn n_vertices(&self) -> usize {
        self.n_vertices
    }

    /// Triangles, counter-clockwise seen from outside; indices into the vertices.
    pub fn faces(&self) -> &[[u32; 3]] {
        &self.faces
    }

    /// Unique undirected edges `[a, b]` with `a < b`, sorted.
    pub fn edges(&self) -> &[[u32; 2]] {
        &self.edges
    }

    /// Index of edge `{a, b}` in [`Topology::edges`], if the edge exists.
    pub fn edge_index(&self, a: u32, b: u32) -> Option<usize> {
        let key = [a.min(b), a.max(b)];
        self.edges.binary_search(&key).ok()
    }

    /// The faces using edge `e` (one for a boundary edge, two for an interior one).
    pub fn edge_faces(&self, e: usize) -> impl Iterator<Item = u32> + '_ {
        self.edge_faces[e].into_iter().filter(|&f| f != u32::MAX)
    }

    /// Number of faces using edge `e` (1 on a boundary, 2 inside a manifold
    /// surface, more on a non-manifold edge, of which [`Topology::edge_faces`]
    /// lists only the first two).
    pub fn edge_face_count(&self, e: usize) -> usize {
        self.edge_face_counts[e] as usize
    }

    /// One-ring neighbours of vertex `v`, sorted ascending.
    pub fn ring(&self, v: u32) -> &[u32] {
        let v = v as usize;
        &self.ring_vertices[self.ring_offsets[v] as usize..self.ring_offsets[v + 1] as usize]
    }

    /// Faces sharing an edge with face `f` (at most three).
    pub fn face_neighbours(&self, f: u32) -> impl Iterator<Item = u32> + '_ {
        let face = self.faces[f as usize];
        (0..3).filter_map(move |k| {
            let e = self.edge_index(face[k], face[(k + 1) % 3])?;
            self.edge_faces(e).find(|&g| g != f)
        })
    }
}

/// Named places on a template topology: landmarks (vertex indices) and body
/// parts (sets of triangle indices). Names are snake_case with a `_left` /
/// `_right` suffix for the body's own left and right (in the station frame the
/// body's right side is +X).
#[derive(Debug, Clone, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Anatomy {
    /// Landmark name -> vertex index.
    pub landmarks: std::collections::BTreeMap<String, u32>,
    /// Body part name -> sorted triangle indices.
    pub parts: std::collections::BTreeMap<String, Vec<u32>>,
}

/// A triangle mesh: vertex positions (metres, station frame) over a shared [`Topology`].
#[derive(Debug, Clone)]
pub struct Mesh {
    /// Vertex positions, metres, station frame; length = `topology.n_vertices()`.
    pub vertices: Vec<Vec3>,
    /// Shared connectivity.
    pub topology: Arc<Topology>,
}

impl Mesh {
    /// A mesh from positions and a shared topology; errors if the counts differ.
    pub fn new(vertices: Vec<Vec3>, topology: Arc<Topology>) -> Result<Self, MeshError> {
        if vertices.len() != topology.n_vertices() {
            return Err(MeshError::VertexCountMismatch {
                got: vertices.len(),
                expected: topology.n_vertices(),
            });
        }
        Ok(Self { vertices, topology })
    }

    /// Builds the topology from `faces` and wraps it with `vertices`.
    pub fn from_faces(vertices: Vec<Vec3>, faces: Vec<[u32; 3]>) -> Result<Self, MeshError> {
        let topology = Arc::new(Topology::new(vertices.len(), faces)?);
        Self::new(vertices, topology)
    }

    /// Triangles of the mesh.
    pub fn faces(&self) -> &[[u32; 3]] {
        self.topology.faces()
    }

    /// Vertex positions as one flat slice `[x0, y0, z0, x1, ...]` of length 3V (metres).
    pub fn flat(&self) -> &[f64] {
        self.vertices.as_flattened()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tetra() -> Mesh {
        Mesh::from_faces(
            vec![
                [0.0, 0.0, 0.0],
                [1.0, 0.0, 0.0],
                [0.0, 1.0, 0.0],
                [0.0, 0.0, 1.0],
            ],
            vec![[0, 2, 1], [0, 1, 3], [1, 2, 3], [0, 3, 2]],
        )
        .unwrap()
    }

    #[test]
    fn tetrahedron_topology() {
        let m = tetra();
        let t = &m.topology;
        assert_eq!(t.edges().len(), 6);
        for v in 0..4 {
            assert_eq!(t.ring(v).len(), 3);
        }
        for e in 0..6 {
            assert_eq!(t.edge_faces(e).count(), 2);
        }
        for f in 0..4 {
            assert_eq!(t.face_neighbours(f).count(), 3);
        }
        assert_eq!(t.edge_index(3, 1), t.edge_index(1, 3));
        assert!(t.edge_index(1, 3).is_some());
        assert_eq!(m.flat().len(), 12);
    }

    #[test]
    fn non_manifold_edge_is_counted() {
        // Three triangles share edge {0, 1}.
        let v = vec![[0.0; 3]; 5];
        let m = Mesh::from_faces(v, vec![[0, 1, 2], [1, 0, 3], [0, 1, 4]]).unwrap();
        let e = m.topology.edge_index(0, 1).unwrap();
        assert_eq!(m.topology.edge_face_count(e), 3);
        assert_eq!(m.topology.edge_faces(e).count(), 2);
        assert!(!m.topology.is_closed());
    }

    #[test]
    fn bad_faces_are_errors() {
        let v = vec![[0.0; 3]; 3];
        assert!(matches!(
            Mesh::from_faces(v.clone(), vec![[0, 1, 5]]),
            Err(MeshError::VertexOutOfRange { vertex: 5, .. })
        ));
        assert!(matches!(
            Mesh::from_faces(v, vec![[0, 1, 1]]),
            Err(MeshError::DegenerateFace { .. })
        ));
    }
}
