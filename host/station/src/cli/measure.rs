//! `tapeshape measure MESH --set NAME|FILE`: take a measurement set on a body
//! mesh in the template topology and print a table (mm) or JSON.
//!
//! Why a subcommand: engineers check a predicted or exported body against the
//! tape, compare sets, and try a custom set file, without writing code. The
//! mesh must be in the template topology (13,718 vertices, the template's
//! triangles, template vertex order), because landmarks and body parts are
//! vertex and triangle indices of that topology.

use std::collections::BTreeSet;
use std::path::{Path, PathBuf};

use anyhow::{bail, Context as _};
use tapeshape_measure::{MeasureError, Measured, MeasurementSet, BUILTIN_SETS};
use tapeshape_mesh::io::ReadOptions;
use tapeshape_mesh::{Mesh, Topology, Vec3};

use crate::cli::Global;

/// The scale of a mesh file's coordinates (a file property, not a reading's
/// unit: MakeHuman writes decimetres).
#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum MeshUnit {
    /// Metres (tapeshape's own files).
    M,
    /// Decimetres (MakeHuman's files).
    Dm,
    /// Centimetres.
    Cm,
    /// Millimetres.
    Mm,
}

impl MeshUnit {
    fn to_metres(self) -> f64 {
        match self {
            MeshUnit::M => 1.0,
            MeshUnit::Dm => 0.1,
            MeshUnit::Cm => 0.01,
            MeshUnit::Mm => 0.001,
        }
    }
}

/// The `--help` text listing the built-in sets (read from the sets themselves).
fn sets_help() -> String {
    let mut s = String::from(
        "Measurement sets (--set NAME, or a path to your own TOML file in the same format):\n",
    );
    for (name, _) in BUILTIN_SETS {
        match MeasurementSet::builtin(name) {
            Ok(set) => s.push_str(&format!(
                "  {name:<8} {:>2} measurements. {}\n",
                set.len(),
                set.description
            )),
            Err(e) => s.push_str(&format!("  {name:<8} (broken: {e})\n")),
        }
    }
    s.push_str(
        "\nValues are millimetres. Group totals (the knee and arm loops of paper34) are \
         derived: the sum of their members, marked \"derived\" in --json; `tapeshape predict` \
         takes the members, not the total. The mesh must be a body in the template topology \
         (13,718 vertices, e.g. exported by tapeshape), station frame: Z up, +Y front, \
         +X the body's right. `--describe` prints each measurement's instruction.",
    );
    s
}

/// Arguments of `tapeshape measure`.
#[derive(clap::Args, Clone, Debug)]
#[command(after_long_help = sets_help(), after_help = "Run with --help to list the measurement sets.")]
pub struct Args {
    /// Body mesh (.obj or .ply) in the template topology.
    #[arg(value_name = "MESH", required_unless_present = "describe")]
    pub mesh: Option<PathBuf>,

    /// Measurement set: a built-in name (paper34, ansur, quick, face7) or a TOML file.
    #[arg(long, default_value = "paper34", value_name = "NAME|FILE")]
    pub set: String,

    /// Print a machine-readable JSON result instead of the table.
    #[arg(long)]
    pub json: bool,

    /// With --json: also print each measurement's support (points as vertex
    /// pairs and weights, segments), for checking or plotting.
    #[arg(long, requires = "json")]
    pub support: bool,

    /// Unit of the mesh file's coordinates (no guessing: a body of implausible
    /// size is an error that names the likely unit).
    #[arg(long, value_enum, default_value = "m")]
    pub unit: MeshUnit,

    /// Print the set's measurements and the operator's instruction for each, then exit.
    #[arg(long)]
    pub describe: bool,
}

/// Runs `tapeshape measure`.
pub fn run(args: Args, _global: &Global) -> anyhow::Result<()> {
    let set = MeasurementSet::load(&args.set).context("loading the measurement set")?;
    if args.describe {
        out!("{}", describe(&set))?;
        return Ok(());
    }
    let path = args.mesh.as_deref().context("no MESH given")?;
    let model = tapeshape_body::BodyModel::shared().context("loading the body template")?;
    let anatomy = tapeshape_body::anatomy::anatomy();
    let vertices = read_template_mesh(path, model.topology(), args.unit)?;
    let compiled = set
        .compile(model.topology(), &anatomy)
        .with_context(|| format!("compiling measurement set `{}`", set.name))?;
    let results = compiled.measure_each(&vertices)?;
    let failed = results.iter().filter(|r| r.is_err()).count();
    let text = if args.json {
        let doc = to_json(&set, path, &results, args.support);
        format!("{}\n", serde_json::to_string_pretty(&doc)?)
    } else {
        render_table(&set, &results)
    };
    out!("{text}")?;
    if failed > 0 {
        bail!(
            "{failed} of {} measurements failed (see above)",
            results.len()
        );
    }
    Ok(())
}

/// Reads an OBJ or PLY body, converts it to metres and checks that it is in
/// the template topology and of plausible size.
pub fn read_template_mesh(
    path: &Path,
    topology: &Topology,
    unit: MeshUnit,
) -> anyhow::Result<Vec<Vec3>> {
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase);
    let opts = ReadOptions::default();
    let mesh: Mesh = match ext.as_deref() {
        Some("obj") => tapeshape_mesh::io::read_obj(path, opts)?,
        Some("ply") => tapeshape_mesh::io::read_ply(path, opts)?,
        _ => bail!(
            "{}: unknown mesh format; give a .obj or .ply file",
            path.display()
        ),
    };
    if mesh.vertices.len() != topology.n_vertices() {
        bail!(
            "{}: the mesh has {} vertices, but the template topology has {}: the mesh is not in the template topology \
             (measure bodies generated, predicted or exported by tapeshape, not raw scans)",
            path.display(),
            mesh.vertices.len(),
            topology.n_vertices()
        );
    }
    let canon = |f: &[u32; 3]| {
        // Same triangle with any rotation of its corners.
        let k = (0..3).min_by_key(|&k| f[k]).unwrap_or(0);
        [f[k], f[(k + 1) % 3], f[(k + 2) % 3]]
    };
    let theirs: BTreeSet<[u32; 3]> = mesh.faces().iter().map(canon).collect();
    let ours: BTreeSet<[u32; 3]> = topology.faces().iter().map(canon).collect();
    if theirs != ours {
        bail!(
            "{}: the mesh has the template's vertex count but different triangles: it is not in the template topology \
             (was it re-triangulated or re-ordered by another program?)",
            path.display()
        );
    }
    let s = unit.to_metres();
    let vertices: Vec<Vec3> = mesh
        .vertices
        .iter()
        .map(|p| [p[0] * s, p[1] * s, p[2] * s])
        .collect();
    check_size(path, &vertices, unit)?;
    Ok(vertices)
}

fn unit_name(u: MeshUnit) -> &'static str {
    match u {
        MeshUnit::M => "metres",
        MeshUnit::Dm => "decimetres",
        MeshUnit::Cm => "centimetres",
        MeshUnit::Mm => "millimetres",
    }
}

fn unit_flag(u: MeshUnit) -> &'static str {
    match u {
        MeshUnit::M => "m",
        MeshUnit::Dm => "dm",
        MeshUnit::Cm => "cm",
        MeshUnit::Mm => "mm",
    }
}

fn check_size(path: &Path, v: &[Vec3], unit: MeshUnit) -> anyhow::Result<()> {
    let mut lo = [f64::INFINITY; 3];
    let mut hi = [f64::NEG_INFINITY; 3];
    for p in v {
        for k in 0..3 {
            if !p[k].is_finite() {
                bail!(
                    "{}: a vertex has a non-finite coordinate {p:?}",
                    path.display()
                );
            }
            lo[k] = lo[k].min(p[k]);
            hi[k] = hi[k].max(p[k]);
        }
    }
    let ext = [hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]];
    let h = ext[2];
    if ext[1] > h {
        bail!(
            "{}: the body is taller along Y ({:.3}) than along Z ({:.3}): it looks Y-up; tapeshape meshes are Z-up \
             (station frame: Z up, +Y front, +X the body's right)",
            path.display(),
            ext[1],
            h
        );
    }
    if !(0.5..=2.6).contains(&h) {
        // Which unit would make the file's numbers a plausible person?
        let raw = h / unit.to_metres();
        let hint = [MeshUnit::M, MeshUnit::Dm, MeshUnit::Cm, MeshUnit::Mm]
            .into_iter()
            .find(|u| (0.5..=2.6).contains(&(raw * u.to_metres())))
            .map_or(String::new(), |u| {
                format!(
                    " (the numbers look like {}: pass --unit {})",
                    unit_name(u),
                    unit_flag(u)
                )
            });
        bail!(
            "{}: the body is {h:.4} m tall when read as {}; a person is 0.5-2.6 m{hint}",
            path.display(),
            unit_name(unit)
        );
    }
    Ok(())
}

/// The operator's view of a set: name, label and instruction for each measurement.
pub fn describe(set: &MeasurementSet) -> String {
    let mut out = format!(
        "{} ({} measurements): {}\n\n",
        set.name,
        set.len(),
        set.description
    );
    for d in &set.definitions {
        out.push_str(&format!("{} ({}, {})", d.name, d.label, d.kind.name()));
        if let Some(a) = &d.ansur {
            out.push_str(&format!(" [ANSUR {a}]"));
        }
        out.push_str(&format!("\n    {}\n", d.description));
        if let Some(n) = &d.note {
            out.push_str(&format!("    Note: {n}\n"));
        }
    }
    out
}

/// The result table: one row per measurement (mm), then the group sums.
pub fn render_table(set: &MeasurementSet, results: &[Result<Measured, MeasureError>]) -> String {
    let mut out = format!(
        "{:<34} {:>10}  {:<14} {:<8} {}\n",
        "MEASUREMENT", "VALUE (mm)", "KIND", "TOL (mm)", "ANSUR"
    );
    for (d, r) in set.definitions.iter().zip(results) {
        let value = match r {
            // `+ 0.0` turns an empty sum's -0.0 into 0.0 for display.
            Ok(m) => format!("{:.1}", m.value * 1000.0 + 0.0),
            Err(_) => "ERROR".to_string(),
        };
        out.push_str(&format!(
            "{:<34} {:>10}  {:<14} {:<8} {}\n",
            d.name,
            value,
            d.kind.name(),
            d.tolerance.mm(),
            d.ansur.as_deref().unwrap_or("-")
        ));
    }
    let groups = set.groups();
    if !groups.is_empty() {
        out.push_str("\nGROUP (sum of its members)\n");
        for (g, members) in groups {
            let sum: Option<f64> = members
                .iter()
                .map(|&i| results[i].as_ref().ok().map(|m| m.value))
                .sum();
            let value = sum.map_or("ERROR".to_string(), |s| format!("{:.1}", s * 1000.0));
            out.push_str(&format!("{g:<34} {value:>10}\n"));
        }
    }
    let errors: Vec<String> = results
        .iter()
        .filter_map(|r| r.as_ref().err().map(|e| format!("  {e}")))
        .collect();
    if !errors.is_empty() {
        out.push_str("\nERRORS\n");
        out.push_str(&errors.join("\n"));
        out.push('\n');
    }
    out
}

/// The JSON document: set, mesh, unit, one object per measurement (mm),
/// group sums. Every name under `measurements` is a measurement
/// `tapeshape predict` takes (for a set its model carries); a group is
/// marked `"derived": "sum"` with the members it sums (`sum_of`), and
/// `predict` takes those members, not the total.
pub fn to_json(
    set: &MeasurementSet,
    mesh: &Path,
    results: &[Result<Measured, MeasureError>],
    with_support: bool,
) -> serde_json::Value {
    let measurements: Vec<serde_json::Value> = set
        .definitions
        .iter()
        .zip(results)
        .map(|(d, r)| {
            let mut o = serde_json::json!({
                "name": d.name,
                "label": d.label,
                "kind": d.kind.name(),
                "class": d.class,
                "tolerance_mm": d.tolerance.mm(),
                "ansur": d.ansur,
                "group": d.group,
            });
            match r {
                Ok(m) => {
                    o["value_mm"] = serde_json::json!(m.value * 1000.0);
                    if with_support {
                        o["support_m"] = serde_json::to_value(&m.support).unwrap_or_default();
                    }
                }
                Err(e) => o["error"] = serde_json::json!(e.to_string()),
            }
            o
        })
        .collect();
    let groups: Vec<serde_json::Value> = set
        .groups()
        .into_iter()
        .map(|(g, members)| {
            let sum: Option<f64> = members
                .iter()
                .map(|&i| results[i].as_ref().ok().map(|m| m.value))
                .sum();
            let sum_of: Vec<&str> = members
                .iter()
                .map(|&i| set.definitions[i].name.as_str())
                .collect();
            serde_json::json!({
                "name": g,
                "derived": "sum",
                "sum_of": sum_of,
                "value_mm": sum.map(|s| s * 1000.0),
            })
        })
        .collect();
    serde_json::json!({
        "set": set.name,
        "mesh": mesh.display().to_string(),
        "unit": "mm",
        "frame": "station: metres internally, Z up, +Y front, +X the body's right",
        "measurements": measurements,
        "groups": groups,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::Parser;

    #[derive(Parser, Debug)]
    struct Cli {
        #[command(flatten)]
        args: Args,
    }

    fn write_template_obj(dir: &Path, scale: f64) -> PathBuf {
        let model = tapeshape_body::BodyModel::shared().unwrap();
        let t = model.template();
        let scaled: Vec<Vec3> = t
            .vertices
            .iter()
            .map(|p| [p[0] * scale, p[1] * scale, p[2] * scale])
            .collect();
        let m = Mesh::new(scaled, t.topology.clone()).unwrap();
        let path = dir.join("body.obj");
        tapeshape_mesh::io::write_obj(&m, &path).unwrap();
        path
    }

    #[test]
    fn measures_the_template_from_an_obj_file() {
        let dir = tempfile::tempdir().unwrap();
        let path = write_template_obj(dir.path(), 1.0);
        let model = tapeshape_body::BodyModel::shared().unwrap();
        let v = read_template_mesh(&path, model.topology(), MeshUnit::M).unwrap();
        // Metres read as millimetres: an error that names the right unit.
        let e = read_template_mesh(&path, model.topology(), MeshUnit::Mm)
            .unwrap_err()
            .to_string();
        assert!(e.contains("--unit m)"), "{e}");
        let set = MeasurementSet::builtin("quick").unwrap();
        let c = set
            .compile(model.topology(), &tapeshape_body::anatomy::anatomy())
            .unwrap();
        let res = c.measure_each(&v).unwrap();
        let table = render_table(&set, &res);
        assert!(
            table.contains("stature") && table.contains("crotchheight"),
            "{table}"
        );
        let json = to_json(&set, &path, &res, false);
        let stature = json["measurements"][0]["value_mm"].as_f64().unwrap();
        let direct = c.measure_one(0, &model.template().vertices).unwrap().value * 1000.0;
        assert!((stature - direct).abs() < 1e-3, "{stature} vs {direct}");
        // The same body written in millimetres: an error naming the unit, then right with --unit mm.
        let path_mm = write_template_obj(dir.path(), 1000.0);
        let e = read_template_mesh(&path_mm, model.topology(), MeshUnit::M)
            .unwrap_err()
            .to_string();
        assert!(e.contains("--unit mm"), "{e}");
        let v_mm = read_template_mesh(&path_mm, model.topology(), MeshUnit::Mm).unwrap();
        let s_mm = c.measure_one(0, &v_mm).unwrap().value * 1000.0;
        assert!((s_mm - direct).abs() < 1e-6);
    }

    #[test]
    fn rejects_a_mesh_outside_the_template_topology() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("tet.obj");
        std::fs::write(
            &path,
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 3 2\nf 1 2 4\nf 2 3 4\nf 1 4 3\n",
        )
        .unwrap();
        let model = tapeshape_body::BodyModel::shared().unwrap();
        let e = read_template_mesh(&path, model.topology(), MeshUnit::M)
            .unwrap_err()
            .to_string();
        assert!(e.contains("not in the template topology"), "{e}");
    }

    #[test]
    fn parses_arguments_and_describes_sets() {
        let cli = Cli::try_parse_from(["x", "body.obj", "--set", "quick", "--json"]).unwrap();
        assert_eq!(cli.args.set, "quick");
        assert!(cli.args.json && !cli.args.support);
        assert!(Cli::try_parse_from(["x"]).is_err(), "MESH is required");
        assert!(Cli::try_parse_from(["x", "--describe"]).is_ok());
        let help = sets_help();
        for (name, _) in BUILTIN_SETS {
            assert!(help.contains(name), "{help}");
        }
        let d = describe(&MeasurementSet::builtin("quick").unwrap());
        assert!(d.contains("navel"), "{d}");
    }
}
