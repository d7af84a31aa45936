//! Computes the sha256 of the embedded default model at build time
//! (`TAPESHAPE_DEFAULT_MODEL_SHA256`), the key of its decoded cache
//! (`src/cache.rs`): hashing 18 MB at every start would cost more than the
//! cache saves.

use sha2::{Digest, Sha256};

fn main() {
    let path = "models/default.tsm.gz";
    println!("cargo:rerun-if-changed={path}");
    let bytes = std::fs::read(path).expect("the embedded default model is part of the crate");
    let hex: String = Sha256::digest(&bytes)
        .iter()
        .map(|b| format!("{b:02x}"))
        .collect();
    println!("cargo:rustc-env=TAPESHAPE_DEFAULT_MODEL_SHA256={hex}");
}
