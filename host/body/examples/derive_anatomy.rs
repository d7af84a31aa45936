//! Derives the template's landmarks and body parts from the MakeHuman pack and
//! writes `host/body/data/landmarks.toml`, `host/body/data/parts.toml`,
//! `docs/anatomy.md` and `docs/anatomy.png`.
//!
//! Run from anywhere: `cargo run -p tapeshape-body --example derive_anatomy`
//! (optionally `-- PACK_DIR`; default `../shared/assets/makehuman` beside the
//! repository). The test `tests/anatomy_data.rs` checks that the committed data
//! files equal what this derivation produces.

use std::path::{Path, PathBuf};

use anyhow::Context;
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
    let tmp = path.with_extension("tmp");
    std::fs::write(&tmp, text).with_context(|| format!("writing {}", tmp.display()))?;
    std::fs::rename(&tmp, path).with_context(|| format!("renaming to {}", path.display()))
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

fn main() -> anyhow::Result<()> {
    let crate_dir = PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    let pack_dir = std::env::args()
        .nth(1)
        .map(PathBuf::from)
        .unwrap_or_else(Pack::default_dir);
    let pack = Pack::load(&pack_dir).context("loading the MakeHuman pack")?;
    let d = derive::derive(&pack).context("deriving the anatomy")?;

    write_atomic(
        &crate_dir.join("data/landmarks.toml"),
        &anatomy::landmarks_toml(&d),
    )?;
    write_atomic(&crate_dir.join("data/parts.toml"), &anatomy::parts_toml(&d))?;

    // Picture.
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
            label: Some(
                l.name
                    .trim_end_matches("_right")
                    .trim_end_matches("_left")
                    .to_string(),
            ),
        })
        .collect();
    let body_panel = |view| Panel {
        view,
        region: None,
        width: 560,
        height: 1100,
        marker_radius: 3,
        labels: true,
    };
    let head = d
        .landmarks
        .iter()
        .find(|l| l.name == "vertex")
        .map(|l| l.position);
    let top = head.map_or(1.7, |p| p[2]);
    let face_region = ([-0.11, -0.13, top - 0.27], [0.11, 0.13, top + 0.01]);
    let face_panel = |view| Panel {
        view,
        region: Some(face_region),
        width: 520,
        height: 550,
        marker_radius: 4,
        labels: true,
    };
    let colouring = Colouring::PerFace(&colours);
    let row1 = render::render_panels(
        &mesh,
        &colouring,
        &markers,
        &[
            body_panel(View::Front),
            body_panel(View::Right),
            body_panel(View::Back),
        ],
    )?;
    let faces = render::render_panels(
        &mesh,
        &colouring,
        &markers,
        &[face_panel(View::Front), face_panel(View::Right)],
    )?;
    let img = render::hstack(&[row1, faces]);
    render::save_png(&img, &crate_dir.join("../../docs/anatomy.png"))?;
    if let Some(dir) = std::env::args().nth(2).map(PathBuf::from) {
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
            let panels: Vec<Panel> = [View::Front, View::Right, View::Back]
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
        "wrote {} landmarks, {} parts, docs/anatomy.png",
        d.landmarks.len(),
        derive::PART_NAMES.len()
    );
    Ok(())
}
