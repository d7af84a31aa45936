//! Builds the embedded blend pack from the MakeHuman pack folder.
//!
//! Usage (from the repository root):
//! `cargo run -p tapeshape-body --release --example pack_assets -- ../shared/assets/makehuman host/body/assets/makehuman/blend.pack.z`
//!
//! The output is written to a temporary file beside the destination and
//! renamed, so a failed run never leaves a half-written pack.

use std::path::PathBuf;

use clap::Parser;

/// Builds the embedded blend pack from the MakeHuman pack folder.
#[derive(Parser)]
struct Args {
    /// The MakeHuman pack folder (such as `../shared/assets/makehuman`).
    #[arg(value_name = "PACK_DIR")]
    src: PathBuf,
    /// The pack written (such as `host/body/assets/makehuman/blend.pack.z`).
    #[arg(value_name = "OUT.pack.z")]
    dst: PathBuf,
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args = tapeshape_common::cli::parse_or_exit::<Args>();
    let Args { src, dst } = args;
    let pack = tapeshape_body::pack::read_sources(&src)?;
    let blob = pack.encode();
    tapeshape_common::fs::write_atomic(&dst, &blob)?;
    let entries: usize = pack.targets.iter().map(|t| t.index.len()).sum();
    println!(
        "wrote {} ({} bytes): {} base vertices, {} targets, {} offsets",
        dst.display(),
        blob.len(),
        pack.base.len(),
        pack.targets.len(),
        entries
    );
    Ok(())
}
