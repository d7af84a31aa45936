//! Derives the template's landmarks and body parts from the MakeHuman pack and
//! writes `host/body/data/landmarks.toml`, `host/body/data/parts.toml`,
//! `docs/anatomy.md` and `docs/anatomy.png`.
//!
//! Run from anywhere: `cargo run -p tapeshape-body --example derive_anatomy`
//! (optionally `-- PACK_DIR`, a full MakeHuman pack folder such as
//! `../shared/assets/makehuman`; default: the pack as committed with the crate,
//! `Pack::committed`, which equals it value for value; after it, a folder for
//! close-up pictures of the landmarks, for checking the rules by eye). The test
//! `tests/anatomy_data.rs` checks that the committed data files equal what this
//! derivation produces.

use std::path::{Path, PathBuf};

use anyhow::Context;
use clap::Parser;
use tapeshape_body::anatomy::{self, derive, pack::Pack};
use tapeshape_body::render::{self, Colouring, Marker, Panel, View};
use tapeshape_mesh::Mesh;

/// Distinct colours for the 15 parts, in `PART_NAMES` order.
const PART_COLOURS: [[u8; 3]; 15] = [
    [200, 200, 200], // torso
    [240, 200, 120], // neck
    [250, 235, 200], // head
    [120, 170, 230], // upper_arm_right
    [90, 130, 200],  // upper_arm_left
    [130, 210, 160], // forearm_right
    [90, 170, 120],  // forearm_left
    [240, 160, 160], // hand_right
    [210, 120, 120], // hand_left
    [190, 160, 230], // thigh_right
    [150, 120, 200], // thigh_left
    [240, 200, 90],  // lower_leg_right
    [210, 170, 60],  // lower_leg_left
    [160, 220, 230], // foot_right
    [110, 180, 200], // foot_left
];

fn write_atomic(path: &Path, text: &str) -> anyhow::Result<()> {
    tapeshape_common::fs::write_atomic(path, text.as_bytes())
        .with_context(|| format!("writing {}", path.display()))
}

fn landmark_colour(name: &str) -> [u8; 3] {
    if name.ends_with("_left") {
        [30, 90, 255]
    } else if name.ends_with("_right") {
        [230, 30, 30]
    } else {
        [20, 170, 40]
    }
}

/// Derives the template's landmarks and body parts from the MakeHuman pack and
/// writes `host/body/data/landmarks.toml`, `host/body/data/parts.toml`,
/// `docs/anatomy.md` and `docs/anatomy.png`.
#[derive(Parser)]
struct Args {
    /// A full MakeHuman pack folder, such as `../shared/assets/makehuman`
    /// (default: the pack as committed with the crate, which equals it value
    /// for value).
    pack_dir: Option<PathBuf>,
    /// Also write close-ups of the landmarks (face, neck, torso, ...) there,
    /// one PNG each, for checking the rules by eye.
    closeups_dir: Option<PathBuf>,
}

fn main() -> anyhow::Result<()> {
    let Args {
        pack_dir,
        closeups_dir,
    } = tapeshape_common::cli::parse_or_exit::<Args>();
    let crate_dir = PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    let pack = match pack_dir {
        Some(dir) => Pack::load(&dir),
        None => Pack::committed(),
    }
    .context("loading the MakeHuman pack")?;
    let d = derive::derive(&pack).context("deriving the anatomy")?;

    write_atomic(
        &crate_dir.join("data/landmarks.toml"),
        &anatomy::landmarks_toml(&d),
    )?;
    write_atomic(&crate_dir.join("data/parts.toml"), &anatomy::parts_toml(&d))?;

    // Picture: front, right and back views of the derivation body with parts
    // coloured and landmarks as dots (green mid-line, red right, blue left;
    // labels on mid-line and right-side landmarks only, to keep it readable),
    // face close-ups beside them and a colour legend below.
    let mesh = Mesh::from_faces(d.body.clone(), d.triangles.clone())?;
    let colours: Vec<[u8; 3]> = d
        .triangle_part
        .iter()
        .map(|p| p.map_or([90, 90, 90], |i| PART_COLOURS[i as usize]))
        .collect();
    let markers: Vec<Marker> = d
        .landmarks
        .iter()
        .map(|l| Marker {
            position: l.position,
            colour: landmark_colour(&l.name),
            label: (!l.name.ends_with("_left"))
                .then(|| l.name.trim_end_matches("_right").to_string()),
        })
        .collect();
    let body_panel = |view, width| Panel {
        view,
        region: None,
        width,
        height: 960,
        marker_radius: 3,
        labels: true,
    };
    let head = d
        .landmarks
        .iter()
        .find(|l| l.name == "vertex")
        .map(|l| l.position);
    let top = head.map_or(1.7, |p| p[2]);
    let face_region = ([-0.12, -0.1, top - 0.26], [0.12, 0.2, top + 0.01]);
    let face_panel = |view| Panel {
        view,
        region: Some(face_region),
        width: 480,
        height: 480,
        marker_radius: 4,
        labels: true,
    };
    let colouring = Colouring::PerFace(&colours);
    let bodies = render::render_panels(
        &mesh,
        &colouring,
        &markers,
        &[
            body_panel(View::Front, 600),
            body_panel(View::Right, 420),
            body_panel(View::Back, 600),
        ],
    )?;
    let faces = render::vstack(&[
        render::render_panel(&mesh, &colouring, &markers, &face_panel(View::Front))?,
        render::render_panel(&mesh, &colouring, &markers, &face_panel(View::Right))?,
    ]);
    let top_row = render::hstack(&[bodies, faces]);
    let mut legend = image::RgbImage::from_pixel(top_row.width(), 70, image::Rgb([255, 255, 255]));
    for (i, name) in derive::PART_NAMES.iter().enumerate() {
        let (x, y) = (10 + (i % 8) as i64 * 230, 8 + (i / 8) as i64 * 22);
        render::fill_rect(&mut legend, x, y, 16, 16, PART_COLOURS[i]);
        render::draw_text(&mut legend, x + 22, y + 4, name, [0, 0, 0], 1);
    }
    for (i, (what, c)) in [
        ("mid-line landmark", [20, 170, 40]),
        ("right-side landmark (labelled)", [230, 30, 30]),
        ("left-side landmark (mirror)", [30, 90, 255]),
    ]
    .into_iter()
    .enumerate()
    {
        let (x, y) = (10 + i as i64 * 420, 54);
        render::fill_rect(&mut legend, x, y, 10, 10, c);
        render::draw_text(&mut legend, x + 16, y + 1, what, [0, 0, 0], 1);
    }
    let img = render::vstack(&[top_row, legend]);
    render::save_png(&img, &crate_dir.join("../../docs/anatomy.png"))?;
    write_atomic(&crate_dir.join("../../docs/anatomy.md"), &docs(&d))?;

    if let Some(dir) = closeups_dir {
        // Close-ups for checking the rules by eye: region centre, half size, views.
        let lm = |n: &str| {
            d.landmarks
                .iter()
                .find(|l| l.name == n)
                .map(|l| l.position)
                .unwrap_or([0.0; 3])
        };
        let crops = [
            ("face", lm("pronasale"), 0.12),
            ("neck", lm("suprasternale"), 0.15),
            ("torso", lm("omphalion"), 0.35),
            ("navel", lm("omphalion"), 0.06),
            ("shoulder", lm("acromion_right"), 0.12),
            ("hand", lm("stylion_right"), 0.12),
            ("elbow", lm("radiale_right"), 0.12),
            ("knee", lm("patella_right"), 0.12),
            ("foot", lm("lateral_malleolus_right"), 0.15),
        ];
        for (name, c, r) in crops {
            let region = Some((
                [c[0] - r, c[1] - r, c[2] - r],
                [c[0] + r, c[1] + r, c[2] + r],
            ));
            let medial_front = View::Custom {
                toward_camera: [-0.5, 0.866, 0.0],
                up: [0.0, 0.0, 1.0],
            };
            let panels: Vec<Panel> = [View::Front, View::Right, View::Back, medial_front]
                .into_iter()
                .map(|view| Panel {
                    view,
                    region,
                    width: 700,
                    height: 700,
                    marker_radius: 4,
                    labels: true,
                })
                .collect();
            let img = render::render_panels(&mesh, &colouring, &markers, &panels)?;
            render::save_png(&img, &dir.join(format!("{name}.png")))?;
        }
    }
    println!(
        "wrote {} landmarks, {} parts, docs/anatomy.md, docs/anatomy.png",
        d.landmarks.len(),
        derive::PART_NAMES.len()
    );
    Ok(())
}

/// `docs/anatomy.md`, generated so that it always matches the data files.
fn docs(d: &derive::Derived) -> String {
    let mut s = String::from(DOC_HEAD);
    s.push_str("\n## Landmarks\n\n");
    s.push_str(
        "Heights are on the derivation body (stature 1,694 mm), millimetres above the floor. \
         `_left` landmarks are the exact mirror partners of the `_right` ones and are not listed.\n\n",
    );
    s.push_str("| name | vertex | base vertex | height mm | rule |\n|---|---|---|---|---|\n");
    for l in d.landmarks.iter().filter(|l| !l.name.ends_with("_left")) {
        s.push_str(&format!(
            "| `{}` | {} | {} | {:.0} | {} |\n",
            l.name,
            l.vertex,
            l.base_vertex,
            l.position[2] * 1e3,
            l.rule.replace('|', "/")
        ));
    }
    s.push_str(
        "\n## Parts\n\n| part | triangles | bones (largest summed weight) |\n|---|---|---|\n",
    );
    for (i, name) in derive::PART_NAMES.iter().enumerate() {
        let n = d
            .triangle_part
            .iter()
            .filter(|p| **p == Some(i as u8))
            .count();
        let stem = name.trim_end_matches("_left").trim_end_matches("_right");
        let bones = derive::BONE_RULES
            .iter()
            .find(|(b, _)| *b == stem)
            .map_or("", |(_, b)| *b);
        s.push_str(&format!("| `{name}` | {n} | {bones} |\n"));
    }
    s
}

const DOC_HEAD: &str = include_str!("anatomy_doc_head.md");
