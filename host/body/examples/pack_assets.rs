//! Builds the embedded blend pack from the MakeHuman pack folder.
//!
//! Usage (from the repository root):
//! `cargo run -p tapeshape-body --release --example pack_assets -- ../shared/assets/makehuman host/body/assets/makehuman/blend.pack.z`
//!
//! The output is written to a temporary file beside the destination and
//! renamed, so a failed run never leaves a half-written pack.

use std::path::PathBuf;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let [src, dst] = args.as_slice() else {
        return Err("usage: pack_assets <makehuman pack folder> <output .pack.z>".into());
    };
    let pack = tapeshape_body::pack::read_sources(&PathBuf::from(src))?;
    let blob = pack.encode();
    let dst = PathBuf::from(dst);
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
