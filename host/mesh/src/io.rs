//! Reading and writing meshes: Wavefront OBJ, PLY, binary glTF (GLB).
//!
//! Rules kept by every function here:
//! * **Vertex order is never changed**: vertex i of the file is vertex i of
//!   the mesh and the other way round; triangles keep their order and winding.
//! * Units are **metres** and the frame is the station frame (Z up, +Y = the
//!   body's front, +X = the body's right, feet at z = 0). The OBJ and PLY
//!   writers say so in their header comments. glTF is defined as Y up with
//!   the front facing +Z, so the GLB writer converts with the proper rotation
//!   `(x, y, z)_station -> (-x, z, y)_glTF` (determinant +1, so winding and
//!   normals stay outward) and the body stands up, facing the viewer, in
//!   Blender or a browser viewer. The readers assume station-frame metres.
//! * Only triangles are accepted when reading. A polygon with more vertices is
//!   an error unless [`ReadOptions::triangulate_polygons`] asks for fan
//!   triangulation `(v0, v1, v2), (v0, v2, v3), ...` (vertices untouched).
//! * Every writer goes through `tapeshape_common::fs::write_atomic` (a
//!   temporary file in the destination's folder, fsynced, renamed over the
//!   destination, the folder fsynced), so a crash never leaves half a file.
//! * Errors name the file and the line (text) or element (binary).
//!
//! The OBJ and PLY parsers are hand-written because they are small, must keep
//! vertex order and report exact line/element positions, and the crates that
//! exist either re-index vertices per face corner (tobj) or carry far more
//! than needed; the GLB writer builds its JSON with serde_json.

use std::path::Path;

use crate::{Mesh, MeshError, Vec3};

/// The frame/units statement written into OBJ and PLY headers.
pub const FRAME_NOTE: &str =
    "units: metres; frame: Z up, +Y = body front, +X = body right, feet at z = 0";

/// Errors reading or writing mesh files.
#[derive(Debug, thiserror::Error)]
pub enum MeshIoError {
    /// The operating system refused a read or write.
    #[error("{path}: {source}")]
    Io {
        /// File.
        path: String,
        /// Underlying error.
        source: std::io::Error,
    },
    /// A text line could not be understood.
    #[error("{path}, line {line}: {what}")]
    Syntax {
        /// File.
        path: String,
        /// 1-based line number.
        line: usize,
        /// What was wrong.
        what: String,
    },
    /// A PLY element could not be read.
    #[error("{path}, {element} {index}: {what}")]
    Element {
        /// File.
        path: String,
        /// Element name (`vertex`, `face`, ...).
        element: String,
        /// 0-based element index.
        index: usize,
        /// What was wrong.
        what: String,
    },
    /// The file's structure (e.g. a PLY header) is not supported or invalid.
    #[error("{path}: {what}")]
    Format {
        /// File.
        path: String,
        /// What was wrong.
        what: String,
    },
    /// A face with more than three vertices, and triangulation was not asked for.
    #[error("{path}, {location}: a polygon with {n} vertices; only triangles are accepted (set ReadOptions::triangulate_polygons to fan-triangulate)")]
    Polygon {
        /// File.
        path: String,
        /// `line N` or `face N`.
        location: String,
        /// Number of vertices of the polygon.
        n: usize,
    },
    /// The faces read do not form a valid mesh.
    #[error("{path}: {source}")]
    Mesh {
        /// File.
        path: String,
        /// The mesh error.
        source: MeshError,
    },
}

/// Options for the readers.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct ReadOptions {
    /// Fan-triangulate polygons with more than 3 vertices instead of failing.
    pub triangulate_polygons: bool,
}

/// Scalar precision of PLY vertex coordinates.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub enum PlyPrecision {
    /// `double` (lossless; the default).
    #[default]
    F64,
    /// `float` (half the size; about 0.1 micrometre error on a body).
    F32,
}

/// Writes `bytes` to `path` with the one atomic, fsynced write
/// ([`tapeshape_common::fs::write_atomic`]): a reader never sees half a mesh.
fn write_file(path: &Path, bytes: &[u8]) -> Result<(), MeshIoError> {
    tapeshape_common::fs::write_atomic(path, bytes).map_err(|source| MeshIoError::Io {
        path: path.display().to_string(),
        source,
    })
}

fn read_file(path: &Path) -> Result<Vec<u8>, MeshIoError> {
    std::fs::read(path).map_err(|source| MeshIoError::Io {
        path: path.display().to_string(),
        source,
    })
}

/// Splits a polygon into triangles (or errors), keeping vertex indices.
fn push_polygon(
    poly: &[u32],
    opts: ReadOptions,
    faces: &mut Vec<[u32; 3]>,
    path: &str,
    location: impl FnOnce() -> String,
) -> Result<(), MeshIoError> {
    if poly.len() != 3 && !(opts.triangulate_polygons && poly.len() > 3) {
        return Err(MeshIoError::Polygon {
            path: path.to_string(),
            location: location(),
            n: poly.len(),
        });
    }
    for k in 1..poly.len() - 1 {
        faces.push([poly[0], poly[k], poly[k + 1]]);
    }
    Ok(())
}

fn build(path: &str, vertices: Vec<Vec3>, faces: Vec<[u32; 3]>) -> Result<Mesh, MeshIoError> {
    Mesh::from_faces(vertices, faces).map_err(|source| MeshIoError::Mesh {
        path: path.to_string(),
        source,
    })
}

// ---------------------------------------------------------------- OBJ

/// Parses OBJ text: `v x y z [...]` lines (extra values such as colours are
/// ignored) and `f` lines whose corners are `i`, `i/t`, `i//n` or `i/t/n`
/// (1-based, or negative = relative to the last vertex). Other records
/// (`vt`, `vn`, `g`, `o`, `s`, `usemtl`, ...) are ignored. `path` names the
/// source in errors.
pub fn parse_obj(text: &str, path: &str, opts: ReadOptions) -> Result<Mesh, MeshIoError> {
    let mut vertices: Vec<Vec3> = Vec::new();
    let mut faces: Vec<[u32; 3]> = Vec::new();
    let mut poly: Vec<u32> = Vec::new();
    for (i, raw) in text.lines().enumerate() {
        let line_no = i + 1;
        let err = |what: String| MeshIoError::Syntax {
            path: path.to_string(),
            line: line_no,
            what,
        };
        let line = raw.split('#').next().unwrap_or("").trim();
        let mut tok = line.split_whitespace();
        match tok.next() {
            Some("v") => {
                let mut p = [0.0; 3];
                for (k, c) in p.iter_mut().enumerate() {
                    let s = tok
                        .next()
                        .ok_or_else(|| err(format!("vertex needs 3 coordinates, found {k}")))?;
                    *c = s
                        .parse::<f64>()
                        .ok()
                        .filter(|v| v.is_finite())
                        .ok_or_else(|| err(format!("bad coordinate {s:?}")))?;
                }
                vertices.push(p);
            }
            Some("f") => {
                poly.clear();
                for corner in tok {
                    let s = corner.split('/').next().unwrap_or("");
                    let idx: i64 = s
                        .parse()
                        .map_err(|_| err(format!("bad vertex reference {corner:?}")))?;
                    let n = vertices.len() as i64;
                    let zero_based = match idx {
                        0 => return Err(err("vertex index 0 (OBJ indices start at 1)".into())),
                        i if i > 0 => i - 1,
                        i => n + i,
                    };
                    if zero_based < 0 || zero_based >= n {
                        return Err(err(format!(
                            "vertex {idx} does not exist ({n} vertices so far)"
                        )));
                    }
                    poly.push(zero_based as u32);
                }
                push_polygon(&poly, opts, &mut faces, path, || format!("line {line_no}"))?;
            }
            _ => {}
        }
    }
    build(path, vertices, faces)
}

/// Reads an OBJ file (see [`parse_obj`]).
pub fn read_obj(path: impl AsRef<Path>, opts: ReadOptions) -> Result<Mesh, MeshIoError> {
    let path = path.as_ref();
    let shown = path.display().to_string();
    let bytes = read_file(path)?;
    let text = String::from_utf8(bytes).map_err(|e| MeshIoError::Format {
        path: shown.clone(),
        what: format!("not UTF-8 text (byte {})", e.utf8_error().valid_up_to()),
    })?;
    parse_obj(&text, &shown, opts)
}

/// OBJ text of a mesh: a header comment (units, frame, counts), `v` lines
/// with each coordinate in Rust's shortest round-trip form (reading gives back
/// the same f64), then 1-based `f` lines.
pub fn obj_string(mesh: &Mesh) -> String {
    use std::fmt::Write as _;
    let mut s = String::with_capacity(mesh.vertices.len() * 60 + mesh.faces().len() * 24);
    let _ = writeln!(s, "# tapeshape mesh ({FRAME_NOTE})");
    let _ = writeln!(
        s,
        "# {} vertices, {} triangles (counter-clockwise seen from outside)",
        mesh.vertices.len(),
        mesh.faces().len()
    );
    for v in &mesh.vertices {
        let _ = writeln!(s, "v {} {} {}", v[0], v[1], v[2]);
    }
    for f in mesh.faces() {
        let _ = writeln!(s, "f {} {} {}", f[0] + 1, f[1] + 1, f[2] + 1);
    }
    s
}

/// Writes an OBJ file (see [`obj_string`]) atomically.
pub fn write_obj(mesh: &Mesh, path: impl AsRef<Path>) -> Result<(), MeshIoError> {
    write_file(path.as_ref(), obj_string(mesh).as_bytes())
}

// ---------------------------------------------------------------- PLY

#[derive(Debug, Clone, Copy, PartialEq)]
enum Scalar {
    I8,
    U8,
    I16,
    U16,
    I32,
    U32,
    F32,
    F64,
}

impl Scalar {
    fn parse(s: &str) -> Option<Self> {
        Some(match s {
            "char" | "int8" => Self::I8,
            "uchar" | "uint8" => Self::U8,
            "short" | "int16" => Self::I16,
            "ushort" | "uint16" => Self::U16,
            "int" | "int32" => Self::I32,
            "uint" | "uint32" => Self::U32,
            "float" | "float32" => Self::F32,
            "double" | "float64" => Self::F64,
            _ => return None,
        })
    }
    fn size(self) -> usize {
        match self {
            Self::I8 | Self::U8 => 1,
            Self::I16 | Self::U16 => 2,
            Self::I32 | Self::U32 | Self::F32 => 4,
            Self::F64 => 8,
        }
    }
    fn is_integer(self) -> bool {
        !matches!(self, Self::F32 | Self::F64)
    }
    fn read_le(self, b: &[u8]) -> f64 {
        match self {
            Self::I8 => b[0] as i8 as f64,
            Self::U8 => b[0] as f64,
            Self::I16 => i16::from_le_bytes([b[0], b[1]]) as f64,
            Self::U16 => u16::from_le_bytes([b[0], b[1]]) as f64,
            Self::I32 => i32::from_le_bytes([b[0], b[1], b[2], b[3]]) as f64,
            Self::U32 => u32::from_le_bytes([b[0], b[1], b[2], b[3]]) as f64,
            Self::F32 => f32::from_le_bytes([b[0], b[1], b[2], b[3]]) as f64,
            Self::F64 => f64::from_le_bytes(b[..8].try_into().expect("8 bytes")),
        }
    }
}

#[derive(Debug, Clone)]
enum Property {
    Scalar(String, Scalar),
    List(String, Scalar, Scalar),
}

#[derive(Debug, Clone)]
struct ElementDef {
    name: String,
    count: usize,
    props: Vec<Property>,
}

/// Source of property values: ASCII tokens of one line or little-endian bytes.
trait PlySource {
    fn scalar(&mut self, t: Scalar) -> Result<f64, String>;
}

struct AsciiLine<'a>(std::str::SplitWhitespace<'a>);

impl PlySource for AsciiLine<'_> {
    fn scalar(&mut self, t: Scalar) -> Result<f64, String> {
        let s = self.0.next().ok_or("too few values")?;
        let v: f64 = s.parse().map_err(|_| format!("bad value {s:?}"))?;
        if t.is_integer() && v.fract() != 0.0 {
            return Err(format!("{s:?} is not an integer"));
        }
        Ok(v)
    }
}

struct BinCursor<'a> {
    buf: &'a [u8],
    pos: usize,
}

impl PlySource for BinCursor<'_> {
    fn scalar(&mut self, t: Scalar) -> Result<f64, String> {
        let n = t.size();
        let b = self
            .buf
            .get(self.pos..self.pos + n)
            .ok_or("file ends inside this element")?;
        self.pos += n;
        Ok(t.read_le(b))
    }
}

/// Reads one element instance: `xyz` gets the x/y/z scalars of a vertex,
/// `list` the face index list; everything else is skipped.
fn read_instance(
    src: &mut dyn PlySource,
    def: &ElementDef,
    xyz: &mut Vec3,
    list: &mut Vec<u32>,
) -> Result<(), String> {
    for p in &def.props {
        match p {
            Property::Scalar(name, t) => {
                let v = src.scalar(*t)?;
                match name.as_str() {
                    "x" => xyz[0] = v,
                    "y" => xyz[1] = v,
                    "z" => xyz[2] = v,
                    _ => {}
                }
            }
            Property::List(name, ct, it) => {
                let n = src.scalar(*ct)?;
                if !(0.0..=1e6).contains(&n) {
                    return Err(format!("list length {n} is not plausible"));
                }
                let wanted = name == "vertex_indices" || name == "vertex_index";
                if wanted {
                    list.clear();
                }
                for _ in 0..n as usize {
                    let v = src.scalar(*it)?;
                    if wanted {
                        if !(0.0..=u32::MAX as f64).contains(&v) {
                            return Err(format!("vertex index {v} is negative or too large"));
                        }
                        list.push(v as u32);
                    }
                }
            }
        }
    }
    Ok(())
}

/// Parses a PLY file's bytes: `ascii` or `binary_little_endian` format 1.0,
/// element `vertex` with scalar properties `x y z` (any numeric type; other
/// properties are skipped), element `face` with a list property
/// `vertex_indices` (or `vertex_index`) of any integer types. Other elements
/// are skipped. `path` names the source in errors.
pub fn parse_ply(bytes: &[u8], path: &str, opts: ReadOptions) -> Result<Mesh, MeshIoError> {
    let fmt = |what: String| MeshIoError::Format {
        path: path.to_string(),
        what,
    };
    // Header: ASCII lines up to "end_header".
    let mut pos = 0;
    let mut header_lines = Vec::new();
    loop {
        let end = bytes[pos..]
            .iter()
            .position(|&b| b == b'\n')
            .ok_or_else(|| fmt("no `end_header` line: not a PLY file or truncated".into()))?;
        let line = std::str::from_utf8(&bytes[pos..pos + end])
            .map_err(|_| fmt("header is not ASCII".into()))?
            .trim_end_matches('\r')
            .to_string();
        pos += end + 1;
        if line == "end_header" {
            break;
        }
        header_lines.push(line);
    }
    if header_lines.first().map(String::as_str) != Some("ply") {
        return Err(fmt("does not start with `ply`".into()));
    }
    let mut ascii = None;
    let mut elements: Vec<ElementDef> = Vec::new();
    for (i, line) in header_lines.iter().enumerate().skip(1) {
        let herr = |what: String| MeshIoError::Syntax {
            path: path.to_string(),
            line: i + 1,
            what,
        };
        let t: Vec<&str> = line.split_whitespace().collect();
        match t.as_slice() {
            ["format", f, "1.0"] => {
                ascii = Some(match *f {
                    "ascii" => true,
                    "binary_little_endian" => false,
                    other => {
                        return Err(herr(format!(
                            "format {other} is not supported (ascii or binary_little_endian)"
                        )))
                    }
                })
            }
            ["comment", ..] | ["obj_info", ..] | [] => {}
            ["element", name, count] => elements.push(ElementDef {
                name: name.to_string(),
                count: count
                    .parse()
                    .map_err(|_| herr(format!("bad element count {count:?}")))?,
                props: Vec::new(),
            }),
            ["property", "list", ct, it, name] => {
                let e = elements
                    .last_mut()
                    .ok_or_else(|| herr("property before any element".into()))?;
                let (Some(ct), Some(it)) = (Scalar::parse(ct), Scalar::parse(it)) else {
                    return Err(herr(format!("unknown list types {ct} {it}")));
                };
                if !ct.is_integer() || !it.is_integer() {
                    return Err(herr("list count and index types must be integers".into()));
                }
                e.props.push(Property::List(name.to_string(), ct, it));
            }
            ["property", ty, name] => {
                let e = elements
                    .last_mut()
                    .ok_or_else(|| herr("property before any element".into()))?;
                let ty = Scalar::parse(ty).ok_or_else(|| herr(format!("unknown type {ty}")))?;
                e.props.push(Property::Scalar(name.to_string(), ty));
            }
            _ => return Err(herr(format!("unrecognised header line {line:?}"))),
        }
    }
    let ascii = ascii.ok_or_else(|| fmt("no `format` line".into()))?;
    let vdef = elements
        .iter()
        .find(|e| e.name == "vertex")
        .ok_or_else(|| fmt("no `vertex` element".into()))?;
    for axis in ["x", "y", "z"] {
        if !vdef
            .props
            .iter()
            .any(|p| matches!(p, Property::Scalar(n, _) if n == axis))
        {
            return Err(fmt(format!(
                "the vertex element has no scalar property {axis}"
            )));
        }
    }
    if let Some(fdef) = elements.iter().find(|e| e.name == "face") {
        if !fdef.props.iter().any(
            |p| matches!(p, Property::List(n, _, _) if n == "vertex_indices" || n == "vertex_index"),
        ) {
            return Err(fmt("the face element has no vertex_indices list".into()));
        }
    }

    let mut vertices = Vec::new();
    let mut faces = Vec::new();
    let mut list = Vec::new();
    let text_lines = if ascii {
        Some(
            std::str::from_utf8(&bytes[pos..])
                .map_err(|_| fmt("ASCII body is not text".into()))?
                .lines()
                .enumerate()
                .filter(|(_, l)| !l.trim().is_empty()),
        )
    } else {
        None
    };
    let header_len = header_lines.len() + 1;
    let mut text_lines = text_lines;
    let mut cursor = BinCursor { buf: bytes, pos };
    for def in &elements {
        for index in 0..def.count {
            let eerr = |what: String| MeshIoError::Element {
                path: path.to_string(),
                element: def.name.clone(),
                index,
                what,
            };
            let mut xyz = [0.0; 3];
            if let Some(lines) = text_lines.as_mut() {
                let (ln, line) = lines
                    .next()
                    .ok_or_else(|| eerr("file ends before this element".into()))?;
                let mut src = AsciiLine(line.split_whitespace());
                read_instance(&mut src, def, &mut xyz, &mut list)
                    .map_err(|w| eerr(format!("line {}: {w}", ln + header_len + 1)))?;
                if src.0.next().is_some() {
                    return Err(eerr(format!(
                        "line {}: more values than the header declares",
                        ln + header_len + 1
                    )));
                }
            } else {
                read_instance(&mut cursor, def, &mut xyz, &mut list).map_err(eerr)?;
            }
            match def.name.as_str() {
                "vertex" => {
                    if xyz.iter().any(|c| !c.is_finite()) {
                        return Err(eerr("coordinate is not finite".into()));
                    }
                    vertices.push(xyz);
                }
                "face" => push_polygon(&list, opts, &mut faces, path, || format!("face {index}"))?,
                _ => {}
            }
        }
    }
    if !ascii && cursor.pos != bytes.len() {
        return Err(fmt(format!(
            "{} bytes after the last element",
            bytes.len() - cursor.pos
        )));
    }
    build(path, vertices, faces)
}

/// Reads a PLY file (see [`parse_ply`]).
pub fn read_ply(path: impl AsRef<Path>, opts: ReadOptions) -> Result<Mesh, MeshIoError> {
    let path = path.as_ref();
    parse_ply(&read_file(path)?, &path.display().to_string(), opts)
}

/// Binary little-endian PLY bytes of a mesh: vertex `x y z` as `double`
/// (or `float` with [`PlyPrecision::F32`]), faces as `list uchar uint
/// vertex_indices`; header comments state units and frame.
pub fn ply_bytes(mesh: &Mesh, precision: PlyPrecision) -> Vec<u8> {
    let ty = match precision {
        PlyPrecision::F64 => "double",
        PlyPrecision::F32 => "float",
    };
    let header = format!(
        "ply\nformat binary_little_endian 1.0\ncomment tapeshape mesh ({FRAME_NOTE})\n\
         comment triangles counter-clockwise seen from outside\n\
         element vertex {}\nproperty {ty} x\nproperty {ty} y\nproperty {ty} z\n\
         element face {}\nproperty list uchar uint vertex_indices\nend_header\n",
        mesh.vertices.len(),
        mesh.faces().len()
    );
    let mut out = header.into_bytes();
    for v in &mesh.vertices {
        for c in v {
            match precision {
                PlyPrecision::F64 => out.extend_from_slice(&c.to_le_bytes()),
                PlyPrecision::F32 => out.extend_from_slice(&(*c as f32).to_le_bytes()),
            }
        }
    }
    for f in mesh.faces() {
        out.push(3);
        for i in f {
            out.extend_from_slice(&i.to_le_bytes());
        }
    }
    out
}

/// Writes a binary PLY file (see [`ply_bytes`]) atomically.
pub fn write_ply(
    mesh: &Mesh,
    path: impl AsRef<Path>,
    precision: PlyPrecision,
) -> Result<(), MeshIoError> {
    write_file(path.as_ref(), &ply_bytes(mesh, precision))
}

// ---------------------------------------------------------------- GLB

/// Station frame (Z up, +Y front) to glTF (Y up, +Z front): `(-x, z, y)`, a proper rotation.
pub fn station_to_gltf(p: Vec3) -> Vec3 {
    [-p[0], p[2], p[1]]
}

/// Binary glTF 2.0 (GLB) bytes of a mesh: one scene, one node, one mesh with
/// one triangle primitive; `POSITION` (f32, with min/max) and `NORMAL`
/// (area-weighted vertex normals, f32), `indices` u32. Positions are
/// converted with [`station_to_gltf`] (metres, as glTF requires). Errors for
/// a mesh without vertices or faces (glTF accessors cannot be empty).
pub fn glb_bytes(mesh: &Mesh, name: &str) -> Result<Vec<u8>, MeshIoError> {
    glb_bytes_with_colors(mesh, name, None)
}

/// [`glb_bytes`] with optional per-vertex colours (`COLOR_0`, linear RGB in
/// [0, 1], one per vertex), e.g. a heat map of per-vertex error. Errors if
/// the colour count differs from the vertex count or a value is outside [0, 1].
pub fn glb_bytes_with_colors(
    mesh: &Mesh,
    name: &str,
    colors: Option<&[[f32; 3]]>,
) -> Result<Vec<u8>, MeshIoError> {
    let n = mesh.vertices.len();
    let m = mesh.faces().len();
    let bad = |what: String| MeshIoError::Format {
        path: name.to_string(),
        what,
    };
    if n == 0 || m == 0 {
        return Err(bad(
            "cannot write a mesh without vertices or triangles as glTF".into(),
        ));
    }
    if let Some(c) = colors {
        if c.len() != n {
            return Err(bad(format!("{} colours for {n} vertices", c.len())));
        }
        if let Some(i) = c
            .iter()
            .position(|rgb| rgb.iter().any(|v| !(0.0..=1.0).contains(v)))
        {
            return Err(bad(format!(
                "colour of vertex {i} is outside [0, 1]: {:?}",
                c[i]
            )));
        }
    }
    let mut bin = Vec::with_capacity(36 * n + 12 * m);
    let mut min = [f32::INFINITY; 3];
    let mut max = [f32::NEG_INFINITY; 3];
    for v in &mesh.vertices {
        let g = station_to_gltf(*v);
        for k in 0..3 {
            let c = g[k] as f32;
            min[k] = min[k].min(c);
            max[k] = max[k].max(c);
            bin.extend_from_slice(&c.to_le_bytes());
        }
    }
    for nrm in mesh.vertex_normals() {
        // An unused vertex has no normal; glTF wants unit normals.
        let g = if nrm == [0.0; 3] {
            [0.0, 1.0, 0.0]
        } else {
            station_to_gltf(nrm)
        };
        for c in g {
            bin.extend_from_slice(&(c as f32).to_le_bytes());
        }
    }
    for rgb in colors.unwrap_or(&[]) {
        for c in rgb {
            bin.extend_from_slice(&c.to_le_bytes());
        }
    }
    for f in mesh.faces() {
        for i in f {
            bin.extend_from_slice(&i.to_le_bytes());
        }
    }
    let (vec_len, idx_len) = (12 * n, 12 * m);
    let mut attributes = serde_json::json!({ "POSITION": 0, "NORMAL": 1 });
    let mut accessors = vec![
        serde_json::json!({ "bufferView": 0, "componentType": 5126, "count": n, "type": "VEC3", "min": min, "max": max }),
        serde_json::json!({ "bufferView": 1, "componentType": 5126, "count": n, "type": "VEC3" }),
    ];
    let mut views = vec![
        serde_json::json!({ "buffer": 0, "byteOffset": 0, "byteLength": vec_len, "target": 34962 }),
        serde_json::json!({ "buffer": 0, "byteOffset": vec_len, "byteLength": vec_len, "target": 34962 }),
    ];
    if colors.is_some() {
        attributes["COLOR_0"] = serde_json::json!(2);
        accessors.push(serde_json::json!({ "bufferView": 2, "componentType": 5126, "count": n, "type": "VEC3" }));
        views.push(serde_json::json!({ "buffer": 0, "byteOffset": 2 * vec_len, "byteLength": vec_len, "target": 34962 }));
    }
    let idx_view = views.len();
    views.push(serde_json::json!({ "buffer": 0, "byteOffset": idx_view * vec_len, "byteLength": idx_len, "target": 34963 }));
    accessors.push(serde_json::json!({ "bufferView": idx_view, "componentType": 5125, "count": 3 * m, "type": "SCALAR" }));
    let json = serde_json::json!({
        "asset": {
            "version": "2.0",
            "generator": concat!("tapeshape-mesh ", env!("CARGO_PKG_VERSION")),
            "extras": {
                "units": "metres",
                "frame": "glTF: +Y up, +Z = body front; converted from the station frame (Z up, +Y front, +X body right) by (x, y, z) -> (-x, z, y)"
            }
        },
        "scene": 0,
        "scenes": [{ "nodes": [0] }],
        "nodes": [{ "mesh": 0, "name": name }],
        "meshes": [{
            "name": name,
            "primitives": [{ "attributes": attributes, "indices": accessors.len() - 1, "mode": 4 }]
        }],
        "accessors": accessors,
        "bufferViews": views,
        "buffers": [{ "byteLength": bin.len() }]
    });
    let mut json = serde_json::to_vec(&json).expect("a JSON value always serialises");
    while json.len() & 3 != 0 {
        json.push(b' ');
    }
    while bin.len() & 3 != 0 {
        bin.push(0);
    }
    let total = 12 + 8 + json.len() + 8 + bin.len();
    let total = u32::try_from(total).map_err(|_| MeshIoError::Format {
        path: name.to_string(),
        what: "mesh too large for a GLB file (4 GiB)".into(),
    })?;
    let mut out = Vec::with_capacity(total as usize);
    out.extend_from_slice(b"glTF");
    out.extend_from_slice(&2u32.to_le_bytes());
    out.extend_from_slice(&total.to_le_bytes());
    out.extend_from_slice(&(json.len() as u32).to_le_bytes());
    out.extend_from_slice(b"JSON");
    out.extend_from_slice(&json);
    out.extend_from_slice(&(bin.len() as u32).to_le_bytes());
    out.extend_from_slice(b"BIN\0");
    out.extend_from_slice(&bin);
    Ok(out)
}

/// Writes a GLB file (see [`glb_bytes`]) atomically; the node and mesh are
/// named after the file stem.
pub fn write_glb(mesh: &Mesh, path: impl AsRef<Path>) -> Result<(), MeshIoError> {
    let path = path.as_ref();
    let name = path
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| "mesh".into());
    write_file(path, &glb_bytes(mesh, &name)?)
}

#[cfg(test)]
mod tests;
