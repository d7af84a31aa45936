//! A small headless software renderer: triangle meshes to RGB images (PNG).
//!
//! Why hand-written: the docs need pictures of the template's parts and
//! landmarks, and later of predicted bodies coloured by error, rendered in CI
//! without a GPU or a window. No well-kept pure-Rust crate rasterises meshes
//! into an image buffer headlessly (the 3D crates need a GPU surface), while an
//! orthographic z-buffered triangle rasteriser with Gouraud-interpolated
//! Lambert shading is about a hundred lines. PNG encoding uses the `image`
//! crate and label glyphs come from `font8x8` (public-domain 8x8 bitmap font).
//!
//! Frame: meshes are in the station frame (metres, Z up, +Y the body's
//! front, +X the body's right side). Views are orthographic; image rows run
//! top to bottom.

use std::path::Path;

use image::{Rgb, RgbImage};
use tapeshape_mesh::vec3::{cross, dot, norm, triangle_normal};
use tapeshape_mesh::{Mesh, Vec3};

/// Errors from saving pictures.
#[derive(Debug, thiserror::Error)]
pub enum RenderError {
    /// Encoding or writing the file failed.
    #[error("cannot write picture {path}: {detail}")]
    Write {
        /// Target path.
        path: std::path::PathBuf,
        /// What failed.
        detail: String,
    },
    /// A colour list does not match the mesh.
    #[error("{what}: {got} colours given for {expected} items")]
    ColourCount {
        /// Per-face or per-vertex.
        what: &'static str,
        /// Colours given.
        got: usize,
        /// Faces or vertices in the mesh.
        expected: usize,
    },
}

/// An orthographic viewing direction.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum View {
    /// Camera in front of the body (+Y), looking at it; the body's right is on the image's left.
    Front,
    /// Camera behind the body (-Y).
    Back,
    /// Camera on the body's right side (+X); the body's front is on the image's right.
    Right,
    /// Camera on the body's left side (-X); the body's front is on the image's left.
    Left,
    /// Any camera: `toward_camera` (unit, from the body to the camera) and `up`
    /// (unit, perpendicular to it).
    Custom {
        /// Direction from the scene to the camera.
        toward_camera: Vec3,
        /// Image up direction.
        up: Vec3,
    },
}

impl View {
    /// (screen right, screen up, toward camera) unit vectors in the station frame.
    pub fn axes(self) -> (Vec3, Vec3, Vec3) {
        let (c, u) = match self {
            View::Front => ([0.0, 1.0, 0.0], [0.0, 0.0, 1.0]),
            View::Back => ([0.0, -1.0, 0.0], [0.0, 0.0, 1.0]),
            View::Right => ([1.0, 0.0, 0.0], [0.0, 0.0, 1.0]),
            View::Left => ([-1.0, 0.0, 0.0], [0.0, 0.0, 1.0]),
            View::Custom { toward_camera, up } => (toward_camera, up),
        };
        // right = up x toward_camera (right-handed screen: right, up, out).
        let r = cross(u, c);
        (r, u, c)
    }
}

/// How the surface is coloured.
#[derive(Debug, Clone, Copy)]
pub enum Colouring<'a> {
    /// One colour everywhere.
    Uniform([u8; 3]),
    /// One colour per face (length = number of faces).
    PerFace(&'a [[u8; 3]]),
    /// One colour per vertex, interpolated across faces (length = number of vertices).
    PerVertex(&'a [[u8; 3]]),
}

/// A dot drawn on top of the surface where it is visible.
#[derive(Debug, Clone)]
pub struct Marker {
    /// Position, metres, station frame.
    pub position: Vec3,
    /// Fill colour.
    pub colour: [u8; 3],
    /// Optional text drawn beside the dot.
    pub label: Option<String>,
}

/// One panel of a picture: a view of a region of space.
#[derive(Debug, Clone, Copy)]
pub struct Panel {
    /// Viewing direction.
    pub view: View,
    /// Axis-aligned box (min, max corners, metres) to frame; `None` frames the whole mesh.
    pub region: Option<(Vec3, Vec3)>,
    /// Panel size in pixels.
    pub width: u32,
    /// Panel height in pixels.
    pub height: u32,
    /// Marker dot radius in pixels.
    pub marker_radius: i32,
    /// Whether marker labels are drawn.
    pub labels: bool,
}

/// Area-weighted vertex normals (unit; zero for unused vertices).
pub fn vertex_normals(mesh: &Mesh) -> Vec<Vec3> {
    let mut n = vec![[0.0; 3]; mesh.vertices.len()];
    for f in mesh.faces() {
        let [a, b, c] = f.map(|i| mesh.vertices[i as usize]);
        let fnrm = triangle_normal(a, b, c);
        for &i in f {
            for k in 0..3 {
                n[i as usize][k] += fnrm[k];
            }
        }
    }
    for v in &mut n {
        let l = norm(*v);
        if l > 0.0 {
            *v = v.map(|c| c / l);
        }
    }
    n
}

fn check_colours(mesh: &Mesh, colouring: &Colouring) -> Result<(), RenderError> {
    match colouring {
        Colouring::PerFace(c) if c.len() != mesh.faces().len() => Err(RenderError::ColourCount {
            what: "per-face colouring",
            got: c.len(),
            expected: mesh.faces().len(),
        }),
        Colouring::PerVertex(c) if c.len() != mesh.vertices.len() => {
            Err(RenderError::ColourCount {
                what: "per-vertex colouring",
                got: c.len(),
                expected: mesh.vertices.len(),
            })
        }
        _ => Ok(()),
    }
}

/// Renders one panel: orthographic view, z-buffer, Lambert shading (light from
/// the camera, raised and to the left, plus 30% ambient), back faces culled
/// (meshes are closed and outward-wound), white background, then markers.
///
/// `mesh` is in metres, station frame. The region is scaled uniformly to fit
/// the panel with a 4% margin.
pub fn render_panel(
    mesh: &Mesh,
    colouring: &Colouring,
    markers: &[Marker],
    panel: &Panel,
) -> Result<RgbImage, RenderError> {
    check_colours(mesh, colouring)?;
    let (w, h) = (panel.width.max(1), panel.height.max(1));
    let (r, u, c) = panel.view.axes();
    let (lo, hi) = panel.region.unwrap_or_else(|| {
        let mut lo = [f64::INFINITY; 3];
        let mut hi = [f64::NEG_INFINITY; 3];
        for p in &mesh.vertices {
            for k in 0..3 {
                lo[k] = lo[k].min(p[k]);
                hi[k] = hi[k].max(p[k]);
            }
        }
        (lo, hi)
    });
    // Screen extent of the region box (its 8 corners).
    let (mut smin, mut smax) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
    for i in 0..8 {
        let p = [
            if i & 1 == 0 { lo[0] } else { hi[0] },
            if i & 2 == 0 { lo[1] } else { hi[1] },
            if i & 4 == 0 { lo[2] } else { hi[2] },
        ];
        let s = [dot(p, r), dot(p, u)];
        for k in 0..2 {
            smin[k] = smin[k].min(s[k]);
            smax[k] = smax[k].max(s[k]);
        }
    }
    let span = [(smax[0] - smin[0]).max(1e-9), (smax[1] - smin[1]).max(1e-9)];
    let px = (w as f64 / span[0]).min(h as f64 / span[1]) * 0.92;
    let centre = [(smin[0] + smax[0]) / 2.0, (smin[1] + smax[1]) / 2.0];
    let project = |p: Vec3| -> [f64; 3] {
        [
            w as f64 / 2.0 + (dot(p, r) - centre[0]) * px,
            h as f64 / 2.0 - (dot(p, u) - centre[1]) * px,
            dot(p, c),
        ]
    };
    let light = {
        let l = [
            c[0] + 0.5 * u[0] - 0.4 * r[0],
            c[1] + 0.5 * u[1] - 0.4 * r[1],
            c[2] + 0.5 * u[2] - 0.4 * r[2],
        ];
        let n = norm(l);
        l.map(|x| x / n)
    };
    let normals = vertex_normals(mesh);
    let shade: Vec<f64> = normals
        .iter()
        .map(|n| 0.3 + 0.7 * dot(*n, light).max(0.0))
        .collect();
    let screen: Vec<[f64; 3]> = mesh.vertices.iter().map(|&p| project(p)).collect();

    let mut img = RgbImage::from_pixel(w, h, Rgb([255, 255, 255]));
    let mut zbuf = vec![f64::NEG_INFINITY; (w * h) as usize];
    for (fi, f) in mesh.faces().iter().enumerate() {
        let [a, b, cc] = f.map(|i| screen[i as usize]);
        // Signed doubled area in screen space (y down): > 0 means facing the camera.
        let area = (b[0] - a[0]) * (cc[1] - a[1]) - (b[1] - a[1]) * (cc[0] - a[0]);
        if area >= 0.0 {
            continue;
        }
        let x0 = a[0].min(b[0]).min(cc[0]).floor().max(0.0) as i64;
        let x1 = a[0].max(b[0]).max(cc[0]).ceil().min(w as f64 - 1.0) as i64;
        let y0 = a[1].min(b[1]).min(cc[1]).floor().max(0.0) as i64;
        let y1 = a[1].max(b[1]).max(cc[1]).ceil().min(h as f64 - 1.0) as i64;
        let ids = f.map(|i| i as usize);
        let cols: [[f64; 3]; 3] = match colouring {
            Colouring::Uniform(k) => [k.map(f64::from); 3],
            Colouring::PerFace(k) => [k[fi].map(f64::from); 3],
            Colouring::PerVertex(k) => ids.map(|i| k[i].map(f64::from)),
        };
        for py in y0..=y1 {
            for pxl in x0..=x1 {
                let (sx, sy) = (pxl as f64 + 0.5, py as f64 + 0.5);
                // Barycentric weights from edge functions.
                let w0 = ((b[0] - sx) * (cc[1] - sy) - (b[1] - sy) * (cc[0] - sx)) / area;
                let w1 = ((cc[0] - sx) * (a[1] - sy) - (cc[1] - sy) * (a[0] - sx)) / area;
                let w2 = 1.0 - w0 - w1;
                if w0 < 0.0 || w1 < 0.0 || w2 < 0.0 {
                    continue;
                }
                let depth = w0 * a[2] + w1 * b[2] + w2 * cc[2];
                let zi = (py as u32 * w + pxl as u32) as usize;
                if depth <= zbuf[zi] {
                    continue;
                }
                zbuf[zi] = depth;
                let s = w0 * shade[ids[0]] + w1 * shade[ids[1]] + w2 * shade[ids[2]];
                let mut rgb = [0u8; 3];
                for k in 0..3 {
                    let v = (w0 * cols[0][k] + w1 * cols[1][k] + w2 * cols[2][k]) * s;
                    rgb[k] = v.round().clamp(0.0, 255.0) as u8;
                }
                img.put_pixel(pxl as u32, py as u32, Rgb(rgb));
            }
        }
    }
    // Markers: drawn where not hidden (within 4 mm of the visible surface).
    let tol = 0.004;
    for m in markers {
        let s = project(m.position);
        let (ix, iy) = (s[0].floor() as i64, s[1].floor() as i64);
        if ix < 0 || iy < 0 || ix >= w as i64 || iy >= h as i64 {
            continue;
        }
        // Visible if any pixel of its 3x3 neighbourhood is not in front of it
        // by more than `tol` (markers on silhouettes stay visible).
        let visible = (-1..=1).any(|dy: i64| {
            (-1..=1).any(|dx: i64| {
                let (qx, qy) = (ix + dx, iy + dy);
                qx >= 0
                    && qy >= 0
                    && qx < w as i64
                    && qy < h as i64
                    && s[2] + tol >= zbuf[(qy as u32 * w + qx as u32) as usize]
            })
        });
        if !visible {
            continue;
        }
        let rad = panel.marker_radius.max(1);
        for dy in -rad - 1..=rad + 1 {
            for dx in -rad - 1..=rad + 1 {
                let d2 = dx * dx + dy * dy;
                let col = if d2 <= rad * rad {
                    m.colour
                } else if d2 <= (rad + 1) * (rad + 1) {
                    [0, 0, 0]
                } else {
                    continue;
                };
                put(&mut img, ix + dx as i64, iy + dy as i64, col);
            }
        }
        if panel.labels {
            if let Some(text) = &m.label {
                draw_text(&mut img, ix + rad as i64 + 3, iy - 4, text, [0, 0, 0], 1);
            }
        }
    }
    Ok(img)
}

fn put(img: &mut RgbImage, x: i64, y: i64, col: [u8; 3]) {
    if x >= 0 && y >= 0 && (x as u32) < img.width() && (y as u32) < img.height() {
        img.put_pixel(x as u32, y as u32, Rgb(col));
    }
}

/// Draws ASCII `text` with the 8x8 bitmap font, top-left corner at (x, y),
/// each font pixel `scale` x `scale` image pixels. Non-ASCII characters are
/// drawn as `?`; pixels outside the image are clipped.
pub fn draw_text(img: &mut RgbImage, x: i64, y: i64, text: &str, colour: [u8; 3], scale: i64) {
    use font8x8::UnicodeFonts;
    let s = scale.max(1);
    for (i, ch) in text.chars().enumerate() {
        let glyph = font8x8::BASIC_FONTS
            .get(ch)
            .or_else(|| font8x8::BASIC_FONTS.get('?'))
            .unwrap_or([0; 8]);
        for (row, bits) in glyph.iter().enumerate() {
            for col in 0..8 {
                if bits & (1 << col) != 0 {
                    for sy in 0..s {
                        for sx in 0..s {
                            put(
                                img,
                                x + (i as i64 * 8 + col) * s + sx,
                                y + row as i64 * s + sy,
                                colour,
                            );
                        }
                    }
                }
            }
        }
    }
}

/// Renders several panels of the same mesh side by side (left to right, tops
/// aligned) into one image.
pub fn render_panels(
    mesh: &Mesh,
    colouring: &Colouring,
    markers: &[Marker],
    panels: &[Panel],
) -> Result<RgbImage, RenderError> {
    let imgs = panels
        .iter()
        .map(|p| render_panel(mesh, colouring, markers, p))
        .collect::<Result<Vec<_>, _>>()?;
    Ok(hstack(&imgs))
}

/// Places images side by side (tops aligned, white fill).
pub fn hstack(imgs: &[RgbImage]) -> RgbImage {
    let w: u32 = imgs.iter().map(|i| i.width()).sum();
    let h = imgs.iter().map(|i| i.height()).max().unwrap_or(1);
    let mut out = RgbImage::from_pixel(w.max(1), h, Rgb([255, 255, 255]));
    let mut x0 = 0;
    for i in imgs {
        for (x, y, p) in i.enumerate_pixels() {
            out.put_pixel(x0 + x, y, *p);
        }
        x0 += i.width();
    }
    out
}

/// A diverging colour map for signed values such as signed distances:
/// `-limit` -> blue, 0 -> light grey, `+limit` -> red, linear in between and
/// clamped beyond; NaN maps to black so that bad values stand out.
pub fn diverging_colour(value: f64, limit: f64) -> [u8; 3] {
    if value.is_nan() {
        return [0, 0, 0];
    }
    let t = if limit > 0.0 {
        (value / limit).clamp(-1.0, 1.0)
    } else {
        value.signum()
    };
    let mid = [225.0, 225.0, 225.0];
    let end = if t >= 0.0 {
        [200.0, 30.0, 30.0]
    } else {
        [30.0, 70.0, 200.0]
    };
    let a = t.abs();
    [0, 1, 2].map(|k| (mid[k] + (end[k] - mid[k]) * a).round() as u8)
}

/// Places images one above the other (left aligned, white fill).
pub fn vstack(imgs: &[RgbImage]) -> RgbImage {
    let w = imgs.iter().map(|i| i.width()).max().unwrap_or(1);
    let h: u32 = imgs.iter().map(|i| i.height()).sum();
    let mut out = RgbImage::from_pixel(w, h.max(1), Rgb([255, 255, 255]));
    let mut y0 = 0;
    for i in imgs {
        for (x, y, p) in i.enumerate_pixels() {
            out.put_pixel(x, y0 + y, *p);
        }
        y0 += i.height();
    }
    out
}

/// Fills the rectangle `[x, x + w) x [y, y + h)` (clipped to the image).
pub fn fill_rect(img: &mut RgbImage, x: i64, y: i64, w: i64, h: i64, colour: [u8; 3]) {
    for yy in y..y + h {
        for xx in x..x + w {
            put(img, xx, yy, colour);
        }
    }
}

/// Saves `img` as PNG at `path` with the one atomic, fsynced write
/// ([`tapeshape_common::fs::write_atomic`]), so a reader never sees a
/// half-written picture.
pub fn save_png(img: &RgbImage, path: &Path) -> Result<(), RenderError> {
    let err = |e: &dyn std::fmt::Display| RenderError::Write {
        path: path.to_path_buf(),
        detail: e.to_string(),
    };
    let mut png = std::io::Cursor::new(Vec::new());
    img.write_to(&mut png, image::ImageFormat::Png)
        .map_err(|e| err(&e))?;
    tapeshape_common::fs::write_atomic(path, png.get_ref()).map_err(|e| err(&e))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Axis-aligned box [lo, hi]^3 as 12 outward-wound triangles.
    fn cube(lo: f64, hi: f64) -> Mesh {
        let v: Vec<Vec3> = (0..8)
            .map(|i| {
                [
                    if i & 1 == 0 { lo } else { hi },
                    if i & 2 == 0 { lo } else { hi },
                    if i & 4 == 0 { lo } else { hi },
                ]
            })
            .collect();
        let quads = [
            [0, 2, 3, 1], // z = lo (normal -z)
            [4, 5, 7, 6], // z = hi
            [0, 1, 5, 4], // y = lo
            [2, 6, 7, 3], // y = hi
            [0, 4, 6, 2], // x = lo
            [1, 3, 7, 5], // x = hi
        ];
        let f = quads
            .iter()
            .flat_map(|q| [[q[0], q[1], q[2]], [q[0], q[2], q[3]]])
            .collect();
        Mesh::from_faces(v, f).unwrap()
    }

    fn panel(view: View) -> Panel {
        Panel {
            view,
            region: Some(([-1.0; 3], [1.0; 3])),
            width: 100,
            height: 100,
            marker_radius: 2,
            labels: false,
        }
    }

    #[test]
    fn cube_covers_its_projection_and_nothing_else() {
        let m = cube(-0.5, 0.5);
        let img = render_panel(
            &m,
            &Colouring::Uniform([255, 0, 0]),
            &[],
            &panel(View::Front),
        )
        .unwrap();
        // Region [-1, 1] fills 92% of 100 px: the cube spans 46 px around the centre.
        let px = |x: u32, y: u32| img.get_pixel(x, y).0;
        assert_eq!(px(2, 2), [255, 255, 255]);
        assert_eq!(px(50, 10), [255, 255, 255]);
        let c = px(50, 50);
        assert!(c[0] > 60 && c[1] == 0 && c[2] == 0, "{c:?}");
        let covered = img.pixels().filter(|p| p.0 != [255, 255, 255]).count();
        assert!((covered as i64 - 46 * 46).abs() < 2 * 46 + 10, "{covered}");
    }

    #[test]
    fn nearer_surface_wins_and_views_look_from_the_right_side() {
        // Two cubes: a red one in front (+y), a blue one behind (-y), overlapping in x/z.
        let front = cube(-0.3, 0.3);
        let mut v = front.vertices.clone();
        let mut f: Vec<[u32; 3]> = front.faces().to_vec();
        let back = cube(-0.5, 0.5);
        for p in &back.vertices {
            v.push([p[0], p[1] - 1.2, p[2]]);
        }
        for t in back.faces() {
            f.push(t.map(|i| i + 8));
        }
        let v: Vec<Vec3> = v.iter().map(|p| [p[0], p[1] + 0.4, p[2]]).collect();
        let m = Mesh::from_faces(v, f).unwrap();
        let cols: Vec<[u8; 3]> = (0..24)
            .map(|i| if i < 12 { [255, 0, 0] } else { [0, 0, 255] })
            .collect();
        let region = Some(([-1.5; 3], [1.5; 3]));
        let p = |view| Panel {
            region,
            ..panel(view)
        };
        let front_img = render_panel(&m, &Colouring::PerFace(&cols), &[], &p(View::Front)).unwrap();
        let c = front_img.get_pixel(50, 50).0;
        assert!(c[0] > 0 && c[2] == 0, "front view sees the red cube: {c:?}");
        let back_img = render_panel(&m, &Colouring::PerFace(&cols), &[], &p(View::Back)).unwrap();
        let c = back_img.get_pixel(50, 50).0;
        assert!(c[2] > 0 && c[0] == 0, "back view sees the blue cube: {c:?}");
        // Side view from the right (+x): front (+y) is on the image's right.
        let side = render_panel(&m, &Colouring::PerFace(&cols), &[], &p(View::Right)).unwrap();
        let (right_half, left_half) = (side.get_pixel(62, 50).0, side.get_pixel(30, 50).0);
        assert!(right_half[0] > 0 && right_half[2] == 0, "{right_half:?}");
        assert!(left_half[2] > 0 && left_half[0] == 0, "{left_half:?}");
    }

    #[test]
    fn markers_show_only_when_visible_and_colours_must_match() {
        let m = cube(-0.5, 0.5);
        let marker = |y: f64| Marker {
            position: [0.0, y, 0.0],
            colour: [0, 255, 0],
            label: None,
        };
        let on_front = render_panel(
            &m,
            &Colouring::Uniform([200; 3]),
            &[marker(0.5)],
            &panel(View::Front),
        )
        .unwrap();
        assert_eq!(on_front.get_pixel(50, 50).0, [0, 255, 0]);
        let hidden = render_panel(
            &m,
            &Colouring::Uniform([200; 3]),
            &[marker(-0.5)],
            &panel(View::Front),
        )
        .unwrap();
        assert_ne!(hidden.get_pixel(50, 50).0, [0, 255, 0]);
        let bad = render_panel(
            &m,
            &Colouring::PerFace(&[[0; 3]; 3]),
            &[],
            &panel(View::Front),
        );
        assert!(matches!(
            bad,
            Err(RenderError::ColourCount {
                got: 3,
                expected: 12,
                ..
            })
        ));
    }

    #[test]
    fn per_vertex_colours_interpolate_and_png_round_trips() {
        let m = cube(-0.5, 0.5);
        let cols: Vec<[u8; 3]> = m
            .vertices
            .iter()
            .map(|p| if p[0] < 0.0 { [255, 0, 0] } else { [0, 0, 255] })
            .collect();
        let img = render_panel(&m, &Colouring::PerVertex(&cols), &[], &panel(View::Front)).unwrap();
        // Front view: the body's right (+x) is on the image's left, so blue there.
        let (l, r, mid) = (
            img.get_pixel(30, 50).0,
            img.get_pixel(70, 50).0,
            img.get_pixel(50, 50).0,
        );
        assert!(
            l[2] > l[0] && r[0] > r[2] && mid[0] > 0 && mid[2] > 0,
            "{l:?} {r:?} {mid:?}"
        );
        let dir = std::env::temp_dir().join(format!("tapeshape-render-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("cube.png");
        save_png(&img, &path).unwrap();
        let back = image::open(&path).unwrap().to_rgb8();
        assert_eq!(back, img);
        assert!(!path.with_extension("png.tmp").exists());
        std::fs::remove_dir_all(&dir).unwrap();
        let err = save_png(&img, &dir.join("missing/sub/x.png"));
        assert!(matches!(err, Err(RenderError::Write { .. })));
    }

    #[test]
    fn diverging_colours_run_blue_grey_red() {
        assert_eq!(diverging_colour(0.0, 0.01), [225, 225, 225]);
        assert_eq!(diverging_colour(0.01, 0.01), [200, 30, 30]);
        assert_eq!(diverging_colour(5.0, 0.01), [200, 30, 30]);
        assert_eq!(diverging_colour(-0.01, 0.01), [30, 70, 200]);
        assert_eq!(diverging_colour(f64::NAN, 0.01), [0, 0, 0]);
        let half = diverging_colour(0.005, 0.01);
        assert!(half[0] > 200 && half[1] > 100 && half[1] < 150, "{half:?}");
    }

    #[test]
    fn text_is_drawn_inside_the_image_only() {
        let mut img = RgbImage::from_pixel(20, 10, Rgb([255, 255, 255]));
        draw_text(&mut img, 1, 1, "A", [0, 0, 0], 1);
        assert!(img.pixels().any(|p| p.0 == [0, 0, 0]));
        draw_text(&mut img, 15, 5, "WWWW\u{e9}", [0, 0, 0], 2); // clipped, no panic
        draw_text(&mut img, -100, -100, "x", [0, 0, 0], 1);
    }
}
