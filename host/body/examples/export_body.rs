//! Generates one body and writes it as OBJ, PLY or GLB (by the extension),
//! so it can be opened in Blender or a browser glTF viewer.
//!
//! Usage: `cargo run -p tapeshape-body --release --example export_body -- OUT.glb [name=value ...]`
//! where name is a phenotype field (`gender`, `years` or `age`, `muscle`,
//! `weight`, `height`, `proportions`, `cupsize`, `firmness`, `african`,
//! `asian`, `caucasian`) or a local-change label; the rest stay at
//! `Phenotype::default()`. Example:
//! `... -- /tmp/woman.glb gender=1 years=40 height=0.35 measure-waist-circ-incr=0.3`

use std::path::PathBuf;

use clap::Parser;
use tapeshape_body::{age_from_years, BodyModel, LocalChanges, Phenotype};
use tapeshape_mesh::io;

/// Generates one body and writes it as OBJ, PLY or GLB (by the extension).
#[derive(Parser)]
struct Args {
    /// The file written: its extension, `.obj`, `.ply` or `.glb`, picks the
    /// format.
    #[arg(value_name = "OUT.{obj,ply,glb}")]
    out: PathBuf,
    /// A phenotype field (`gender`, `years` or `age`, `muscle`, `weight`,
    /// `height`, `proportions`, `cupsize`, `firmness`, `african`, `asian`,
    /// `caucasian`) or a local-change label, and its value; set in the order
    /// given, the rest stay at `Phenotype::default()`.
    #[arg(value_name = "name=value", value_parser = setting)]
    settings: Vec<(String, f64)>,
}

/// A `name=value` argument: the name and the number.
fn setting(arg: &str) -> Result<(String, f64), String> {
    let (name, value) = arg
        .split_once('=')
        .ok_or_else(|| format!("{arg:?}: expected name=value"))?;
    let v: f64 = value
        .parse()
        .map_err(|_| format!("{arg:?}: {value:?} is not a number"))?;
    Ok((name.to_string(), v))
}

fn main() {
    let args = tapeshape_common::cli::parse_or_exit::<Args>();
    if let Err(e) = run(args) {
        eprintln!("error: {e}");
        std::process::exit(1);
    }
}

fn run(args: Args) -> Result<(), Box<dyn std::error::Error>> {
    let Args { out, settings } = args;
    let mut ph = Phenotype::default();
    let mut lc = LocalChanges::new();
    for (name, v) in settings {
        match name.as_str() {
            "gender" => ph.gender = v,
            "age" => ph.age = v,
            "years" => ph.age = age_from_years(v)?,
            "muscle" => ph.muscle = v,
            "weight" => ph.weight = v,
            "height" => ph.height = v,
            "proportions" => ph.proportions = v,
            "cupsize" => ph.cupsize = v,
            "firmness" => ph.firmness = v,
            "african" => ph.african = v,
            "asian" => ph.asian = v,
            "caucasian" => ph.caucasian = v,
            label => {
                lc.set(label, v)?;
            }
        }
    }
    let body = BodyModel::load()?.generate(&ph, &lc)?;
    match out.extension().and_then(|e| e.to_str()) {
        Some("obj") => io::write_obj(&body, &out)?,
        Some("ply") => io::write_ply(&body, &out, io::PlyPrecision::F64)?,
        Some("glb") => io::write_glb(&body, &out)?,
        _ => return Err("the output must end in .obj, .ply or .glb".into()),
    }
    let bb = body.bounding_box().ok_or("empty body")?;
    println!(
        "wrote {} ({} vertices, {} triangles, stature {:.3} m)",
        out.display(),
        body.vertices.len(),
        body.faces().len(),
        bb.max[2] - bb.min[2]
    );
    Ok(())
}
