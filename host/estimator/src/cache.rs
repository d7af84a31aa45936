//! The embedded default model, decoded once and kept in the data directory,
//! so that a process is ready in milliseconds instead of decompressing
//! 18 MB and recomputing the ANSUR II statistics on every start.
//!
//! Why a cache file and not a different embedded layout: the program keeps
//! one compressed model inside (18 MB instead of 34 MB in every binary);
//! the first process on a machine pays the decoding once (about 0.25 s of
//! CPU) and writes what it decoded, later ones read it back.
//!
//! The file (`<dir>/default-<sha256>.tsc`, the sha256 of the embedded
//! model computed at build time by `build.rs`) holds:
//!
//! ```text
//! magic "TSMCACHE" | format u32 | model sha256 [32] | body length u64 | body crc32 u32 | body
//! body: head length u64 | head (postcard: the model file without its PCA
//!       basis and mean, the ANSUR II statistics, the basis's width) |
//!       basis (f32 or f64, little-endian) | mean (f64, little-endian)
//! ```
//!
//! The basis and mean are raw so that reading them is a copy, not a
//! decode; the basis is stored as f32 when every value is exactly an f32
//! (the embedded model's basis is rounded to f32), which halves the file
//! and loses nothing. Never trusted blindly: a file with another magic,
//! format, model hash or length, a body whose crc32 does not match, or
//! whose head does not decode or does not validate, is ignored and
//! rewritten (atomically, [`tapeshape_common::fs::write_atomic`]). A cache
//! that cannot be written (read-only data directory) costs only speed.

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};
use tapeshape_model::ModelFile;

use crate::checks::RealStats;

const MAGIC: [u8; 8] = *b"TSMCACHE";
/// Bump when the layout or anything cached (the statistics' definition)
/// changes: older files are then rebuilt.
const FORMAT: u32 = 1;
const HEADER: usize = 8 + 4 + 32 + 8 + 4;

/// The sha256 (hex) of the embedded default model (`build.rs`).
pub const DEFAULT_MODEL_SHA256: &str = env!("TAPESHAPE_DEFAULT_MODEL_SHA256");

#[derive(Serialize, Deserialize)]
struct Head {
    file: ModelFile,
    real: RealStats,
    basis_f32: bool,
    basis_len: u64,
    mean_len: u64,
}

/// The cache file for the model with sha256 `sha_hex` in `dir`.
pub fn cache_path(dir: &Path, sha_hex: &str) -> PathBuf {
    dir.join(format!("default-{sha_hex}.tsc"))
}

fn sha_bytes(sha_hex: &str) -> Option<[u8; 32]> {
    let mut out = [0u8; 32];
    if sha_hex.len() != 64 {
        return None;
    }
    for (i, o) in out.iter_mut().enumerate() {
        *o = u8::from_str_radix(sha_hex.get(2 * i..2 * i + 2)?, 16).ok()?;
    }
    Some(out)
}

/// Encodes a decoded model and its statistics as a cache file for the
/// model with sha256 `sha_hex`.
pub(crate) fn encode(file: &ModelFile, real: &RealStats, sha_hex: &str) -> Option<Vec<u8>> {
    let sha = sha_bytes(sha_hex)?;
    let pca = &file.model.pca;
    let narrow = pca.basis_f32();
    let basis_len = pca.basis_len();
    let mut light = file.clone();
    light.model.pca.set_basis(Vec::new());
    let mean = std::mem::take(&mut light.model.pca.mean);
    let head = postcard::to_stdvec(&Head {
        file: light,
        real: real.clone(),
        basis_f32: narrow.is_some(),
        basis_len: basis_len as u64,
        mean_len: mean.len() as u64,
    })
    .ok()?;
    let width = if narrow.is_some() { 4 } else { 8 };
    let mut body = Vec::with_capacity(8 + head.len() + width * basis_len + 8 * mean.len());
    body.extend_from_slice(&(head.len() as u64).to_le_bytes());
    body.extend_from_slice(&head);
    match narrow {
        Some(n) => n
            .iter()
            .for_each(|v| body.extend_from_slice(&v.to_le_bytes())),
        None => pca
            .basis()
            .iter()
            .for_each(|v| body.extend_from_slice(&v.to_le_bytes())),
    }
    mean.iter()
        .for_each(|v| body.extend_from_slice(&v.to_le_bytes()));
    let mut out = Vec::with_capacity(HEADER + body.len());
    out.extend_from_slice(&MAGIC);
    out.extend_from_slice(&FORMAT.to_le_bytes());
    out.extend_from_slice(&sha);
    out.extend_from_slice(&(body.len() as u64).to_le_bytes());
    out.extend_from_slice(&crc32fast::hash(&body).to_le_bytes());
    out.extend_from_slice(&body);
    Some(out)
}

/// Why a cache file was not used.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Rejected {
    /// Too short, another magic or another format version.
    NotACache,
    /// Made for another model (another sha256).
    Stale,
    /// The body's length or checksum does not match (damaged).
    Damaged,
    /// The checksum matched but the content does not decode or validate.
    Invalid(String),
}

/// Decodes a cache file made for the model with sha256 `sha_hex`.
pub(crate) fn decode(bytes: &[u8], sha_hex: &str) -> Result<(ModelFile, RealStats), Rejected> {
    let sha = sha_bytes(sha_hex).ok_or(Rejected::Stale)?;
    if bytes.len() < HEADER || bytes[..8] != MAGIC || bytes[8..12] != FORMAT.to_le_bytes() {
        return Err(Rejected::NotACache);
    }
    if bytes[12..44] != sha {
        return Err(Rejected::Stale);
    }
    let len = u64::from_le_bytes(bytes[44..52].try_into().expect("8 bytes"));
    let crc = u32::from_le_bytes(bytes[52..56].try_into().expect("4 bytes"));
    let body = &bytes[HEADER..];
    if body.len() as u64 != len || crc32fast::hash(body) != crc {
        return Err(Rejected::Damaged);
    }
    let invalid = |m: &str| Rejected::Invalid(m.to_string());
    let head_len = body
        .get(..8)
        .map(|b| u64::from_le_bytes(b.try_into().expect("8 bytes")))
        .ok_or_else(|| invalid("no head length"))?;
    let head_end = usize::try_from(head_len)
        .ok()
        .and_then(|h| h.checked_add(8))
        .filter(|&e| e <= body.len())
        .ok_or_else(|| invalid("head longer than the body"))?;
    let head: Head =
        postcard::from_bytes(&body[8..head_end]).map_err(|e| Rejected::Invalid(e.to_string()))?;
    let width = if head.basis_f32 { 4 } else { 8 };
    let (nb, nm) = (head.basis_len as usize, head.mean_len as usize);
    let raw = &body[head_end..];
    if raw.len() != width * nb + 8 * nm {
        return Err(invalid("array lengths do not match the body"));
    }
    let (rb, rm) = raw.split_at(width * nb);
    let basis_f64: Option<Vec<f64>> = (!head.basis_f32).then(|| {
        rb.chunks_exact(8)
            .map(|c| f64::from_le_bytes(c.try_into().expect("8 bytes")))
            .collect()
    });
    let mean: Vec<f64> = rm
        .chunks_exact(8)
        .map(|c| f64::from_le_bytes(c.try_into().expect("8 bytes")))
        .collect();
    let mut file = head.file;
    file.model.pca.mean = mean;
    match basis_f64 {
        Some(basis) => file.model.pca.set_basis(basis),
        // f32 values: kept as they are for the PCA's f32 copy too.
        None => file
            .model
            .pca
            .set_basis_f32(
                rb.chunks_exact(4)
                    .map(|c| f32::from_le_bytes(c.try_into().expect("4 bytes")))
                    .collect(),
            )
            .map_err(|e| Rejected::Invalid(e.to_string()))?,
    }
    file.validate()
        .map_err(|e| Rejected::Invalid(e.to_string()))?;
    Ok((file, head.real))
}

/// Reads the cache for `sha_hex` in `dir`: the decoded model and its
/// statistics, or why there is none to use.
pub(crate) fn read(dir: &Path, sha_hex: &str) -> Result<(ModelFile, RealStats), Rejected> {
    let bytes = map_file(&cache_path(dir, sha_hex)).map_err(|_| Rejected::NotACache)?;
    decode(&bytes, sha_hex)
}

/// A cache file's bytes, mapped, or read where mapping fails.
pub(crate) enum FileBytes {
    /// Mapped read-only.
    Mapped(memmap2::Mmap),
    /// Read into memory.
    Read(Vec<u8>),
}

impl std::ops::Deref for FileBytes {
    type Target = [u8];
    fn deref(&self) -> &[u8] {
        match self {
            FileBytes::Mapped(m) => m,
            FileBytes::Read(v) => v,
        }
    }
}

/// The bytes of the cache file at `path`, mapped rather than read. Why:
/// the caches are tens of MB that each start decodes once; a read copies
/// them into fresh pages the kernel must first clear (the page faults and
/// copy were a tenth of a whole `tapeshape predict`), where a mapping
/// shares the page cache's.
pub(crate) fn map_file(path: &Path) -> std::io::Result<FileBytes> {
    let file = std::fs::File::open(path)?;
    // SAFETY: the mapping is read-only, lives only while this process
    // decodes the file into its own arrays, and this program never changes
    // a cache file in place: each is written whole to a temporary file and
    // renamed over the old (`write_atomic`), so the mapped inode keeps its
    // bytes. (Only another program truncating the file in that moment could
    // fault the read, as it could fault any mapped file.)
    match unsafe { memmap2::Mmap::map(&file) } {
        Ok(m) => Ok(FileBytes::Mapped(m)),
        Err(_) => std::fs::read(path).map(FileBytes::Read),
    }
}

/// Writes the cache for `sha_hex` in `dir` (creating `dir`), atomically,
/// and removes the caches of other models there. Errors are returned for
/// the caller to log; the cache is only an optimisation.
pub(crate) fn write(
    dir: &Path,
    sha_hex: &str,
    file: &ModelFile,
    real: &RealStats,
) -> std::io::Result<()> {
    let bytes = encode(file, real, sha_hex)
        .ok_or_else(|| std::io::Error::other("the model could not be encoded for the cache"))?;
    std::fs::create_dir_all(dir)?;
    tapeshape_common::fs::write_atomic(&cache_path(dir, sha_hex), &bytes)?;
    let keep = cache_path(dir, sha_hex);
    for entry in std::fs::read_dir(dir)?.flatten() {
        let p = entry.path();
        let name = entry.file_name();
        let name = name.to_string_lossy();
        if p != keep && name.starts_with("default-") && name.ends_with(".tsc") {
            let _ = std::fs::remove_file(p);
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests;
