//! Figures of the experiments, drawn with the body crate's software
//! rasteriser (`tapeshape_body::render`): shaded front and side views of
//! bodies, bodies coloured by their signed distance to the true body
//! (diverging colour map, as in the paper's figures), and labelled grids of
//! such panels.
//!
//! Every panel of one figure frames the same box (the union of the meshes'
//! bounding boxes), so bodies keep their true relative sizes side by side.
//!
//! Units and frame: metres, station frame (Z up, +Y front, +X the body's
//! right); signed distances in millimetres.

use std::path::Path;
use std::sync::Arc;

use image::RgbImage;
use tapeshape_body::render::{
    diverging_colour, draw_text, fill_rect, hstack, render_panel, save_png, vertex_normals, vstack,
    Colouring, Panel, RenderError, View,
};
use tapeshape_mesh::{Mesh, Topology, Vec3};

/// Skin-like grey-beige for shaded bodies.
pub const SKIN: [u8; 3] = [222, 196, 170];

/// A box (min, max corners, metres) holding every vertex of `meshes`.
pub fn common_region(meshes: &[&[Vec3]]) -> (Vec3, Vec3) {
    let mut lo = [f64::INFINITY; 3];
    let mut hi = [f64::NEG_INFINITY; 3];
    for m in meshes {
        for p in m.iter() {
            for k in 0..3 {
                if p[k].is_finite() {
                    lo[k] = lo[k].min(p[k]);
                    hi[k] = hi[k].max(p[k]);
                }
            }
        }
    }
    if !lo[0].is_finite() {
        return ([0.0; 3], [1.0; 3]);
    }
    (lo, hi)
}

/// `region` grown by `fraction` of its size on every side (so that a
/// figure framed on the true bodies leaves room for near misses, while a
/// wildly wrong result is cut at the panel's edge instead of shrinking
/// every body to a dot).
pub fn expand(region: (Vec3, Vec3), fraction: f64) -> (Vec3, Vec3) {
    let (lo, hi) = region;
    let d = [0, 1, 2].map(|k| (hi[k] - lo[k]) * fraction);
    (
        [0, 1, 2].map(|k| lo[k] - d[k]),
        [0, 1, 2].map(|k| hi[k] + d[k]),
    )
}

/// Per-vertex signed distance (mm) of `pred` from `truth` (both `V`
/// vertices, metres, same topology): the displacement of each vertex from
/// its counterpart projected on the true body's outward vertex normal, so
/// positive = the prediction lies outside the true body. The meshes are in
/// correspondence (one template), so this is the paper's "signed distance
/// from the parameterized body scan" at the matching point.
pub fn signed_distance_mm(pred: &[Vec3], truth: &[Vec3], topology: &Arc<Topology>) -> Vec<f64> {
    let mesh = Mesh {
        vertices: truth.to_vec(),
        topology: topology.clone(),
    };
    let n = vertex_normals(&mesh);
    pred.iter()
        .zip(truth)
        .zip(&n)
        .map(|((p, t), n)| {
            ((p[0] - t[0]) * n[0] + (p[1] - t[1]) * n[1] + (p[2] - t[2]) * n[2]) * 1000.0
        })
        .collect()
}

/// How a body panel is coloured.
pub enum Paint<'a> {
    /// Shaded in [`SKIN`].
    Shaded,
    /// Coloured by a per-vertex value (mm) with the diverging map, ±limit mm.
    Signed(&'a [f64], f64),
}

/// Renders `vertices` (metres) in `views`, each `h` pixels high and as wide
/// as the region's extent across the view needs at the same scale (at most
/// `w`), framing `region`, side by side.
pub fn body_views(
    vertices: &[Vec3],
    topology: &Arc<Topology>,
    paint: &Paint,
    views: &[View],
    region: (Vec3, Vec3),
    w: u32,
    h: u32,
) -> Result<RgbImage, RenderError> {
    let mesh = Mesh {
        vertices: vertices.to_vec(),
        topology: topology.clone(),
    };
    let colours: Vec<[u8; 3]>;
    let colouring = match paint {
        Paint::Shaded => Colouring::Uniform(SKIN),
        Paint::Signed(values, limit) => {
            colours = values
                .iter()
                .map(|v| diverging_colour(*v, *limit))
                .collect();
            Colouring::PerVertex(&colours)
        }
    };
    let imgs = views
        .iter()
        .map(|&view| {
            // Width from the region's extent across the view, so that every
            // view of a figure has the same scale (pixels per metre).
            let (r, u, _) = view.axes();
            let extent = |a: Vec3| {
                (0..8)
                    .map(|i| {
                        let p = [
                            if i & 1 == 0 { region.0[0] } else { region.1[0] },
                            if i & 2 == 0 { region.0[1] } else { region.1[1] },
                            if i & 4 == 0 { region.0[2] } else { region.1[2] },
                        ];
                        p[0] * a[0] + p[1] * a[1] + p[2] * a[2]
                    })
                    .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), x| {
                        (lo.min(x), hi.max(x))
                    })
            };
            let (rl, rh) = extent(r);
            let (ul, uh) = extent(u);
            let w = ((h as f64 * (rh - rl) / (uh - ul).max(1e-9)).ceil() as u32).clamp(8, w.max(8));
            render_panel(
                &mesh,
                &colouring,
                &[],
                &Panel {
                    view,
                    region: Some(region),
                    width: w,
                    height: h,
                    marker_radius: 0,
                    labels: false,
                },
            )
        })
        .collect::<Result<Vec<_>, _>>()?;
    Ok(hstack(&imgs))
}

/// A white strip `w x h` with `text` (8x8 font, scale 1 or 2).
pub fn label(text: &str, w: u32, h: u32, scale: i64) -> RgbImage {
    let mut img = RgbImage::from_pixel(w.max(1), h.max(1), image::Rgb([255, 255, 255]));
    draw_text(
        &mut img,
        4,
        (h as i64 - 8 * scale) / 2,
        text,
        [0, 0, 0],
        scale,
    );
    img
}

/// A grid: column titles on top, then one row per `(row title, panels)`;
/// the row title sits in a left margin. Panels in a column should share a
/// width.
pub fn grid(columns: &[String], rows: Vec<(String, Vec<RgbImage>)>) -> RgbImage {
    let margin = rows
        .iter()
        .map(|(t, _)| t.len() as u32 * 8 + 10)
        .max()
        .unwrap_or(0)
        .max(10);
    let widths: Vec<u32> = (0..columns.len())
        .map(|c| {
            rows.iter()
                .filter_map(|(_, p)| p.get(c).map(|i| i.width()))
                .max()
                .unwrap_or(100)
        })
        .collect();
    let mut out = Vec::new();
    let mut head = vec![label("", margin, 20, 1)];
    for (c, t) in columns.iter().enumerate() {
        head.push(label(t, widths[c], 20, 1));
    }
    out.push(hstack(&head));
    for (title, panels) in rows {
        let h = panels.iter().map(|p| p.height()).max().unwrap_or(20);
        let mut line = vec![label(&title, margin, h, 1)];
        line.extend(panels);
        out.push(hstack(&line));
    }
    vstack(&out)
}

/// A horizontal colour bar for the diverging map from `-limit` to `+limit`
/// mm, with its end and middle values written under it.
pub fn colour_bar(limit: f64, w: u32) -> RgbImage {
    let h = 34;
    let mut img = RgbImage::from_pixel(w.max(60), h, image::Rgb([255, 255, 255]));
    let bw = img.width() as i64 - 20;
    for x in 0..bw {
        let v = (x as f64 / (bw - 1).max(1) as f64 * 2.0 - 1.0) * limit;
        fill_rect(&mut img, 10 + x, 2, 1, 14, diverging_colour(v, limit));
    }
    draw_text(&mut img, 2, 20, &format!("-{limit:.0} mm"), [0, 0, 0], 1);
    let mid = img.width() as i64 / 2 - 4;
    draw_text(&mut img, mid, 20, "0", [0, 0, 0], 1);
    let t = format!("+{limit:.0} mm");
    let right = img.width() as i64 - 2 - 8 * t.len() as i64;
    draw_text(&mut img, right, 20, &t, [0, 0, 0], 1);
    img
}

/// Saves a figure as PNG (temporary file, then rename).
pub fn save(img: &RgbImage, path: &Path) -> Result<(), RenderError> {
    if let Some(d) = path.parent() {
        let _ = std::fs::create_dir_all(d);
    }
    save_png(img, path)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A unit cube's 12 outward triangles.
    fn cube(scale: f64) -> (Vec<Vec3>, Arc<Topology>) {
        let v: Vec<Vec3> = (0..8)
            .map(|i| {
                [
                    (i & 1) as f64 * scale,
                    ((i >> 1) & 1) as f64 * scale,
                    ((i >> 2) & 1) as f64 * scale,
                ]
            })
            .collect();
        let f = vec![
            [0, 2, 1],
            [1, 2, 3],
            [4, 5, 6],
            [5, 7, 6],
            [0, 1, 4],
            [1, 5, 4],
            [2, 6, 3],
            [3, 6, 7],
            [0, 4, 2],
            [2, 4, 6],
            [1, 3, 5],
            [3, 7, 5],
        ];
        (v, Arc::new(Topology::new(8, f).unwrap()))
    }

    #[test]
    fn signed_distance_is_positive_outside_and_negative_inside() {
        let (t, topo) = cube(1.0);
        // Scale about the centre: every vertex moves outward.
        let grow: Vec<Vec3> = t
            .iter()
            .map(|p| p.map(|x| 0.5 + (x - 0.5) * 1.01))
            .collect();
        let shrink: Vec<Vec3> = t
            .iter()
            .map(|p| p.map(|x| 0.5 + (x - 0.5) * 0.99))
            .collect();
        let d_out = signed_distance_mm(&grow, &t, &topo);
        let d_in = signed_distance_mm(&shrink, &t, &topo);
        // Each corner moved by 0.005 m along each axis (8.66 mm along the
        // diagonal); the triangulated cube's area-weighted corner normal
        // points outward, close to the diagonal, so the distance lies just
        // below 8.66 mm, and shrinking gives exactly the opposite.
        for (a, b) in d_out.iter().zip(&d_in) {
            assert!(*a > 7.5 && *a <= 8.661, "{a}");
            assert!((a + b).abs() < 1e-9, "{a} {b}");
        }
        assert!(signed_distance_mm(&t, &t, &topo).iter().all(|d| *d == 0.0));
    }

    #[test]
    fn grid_places_panels_and_keeps_sizes() {
        let (v, topo) = cube(1.0);
        let small: Vec<Vec3> = v.iter().map(|p| p.map(|x| x * 0.5)).collect();
        let region = common_region(&[&v, &small]);
        let a = body_views(&v, &topo, &Paint::Shaded, &[View::Front], region, 50, 60).unwrap();
        let b = body_views(
            &small,
            &topo,
            &Paint::Shaded,
            &[View::Front],
            region,
            50,
            60,
        )
        .unwrap();
        let ink = |i: &RgbImage| i.pixels().filter(|p| p.0 != [255, 255, 255]).count();
        // Same framing: the half-size cube covers about a quarter of the pixels.
        let ratio = ink(&b) as f64 / ink(&a) as f64;
        assert!((ratio - 0.25).abs() < 0.06, "{ratio}");
        let g = grid(
            &["x".into(), "y".into()],
            vec![("row".into(), vec![a.clone(), b])],
        );
        assert_eq!(g.height(), 20 + 60);
        assert!(g.width() >= 100);
        let bar = colour_bar(30.0, 200);
        assert_eq!(bar.width(), 200);
    }
}
