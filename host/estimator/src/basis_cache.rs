//! The smooth basis of step 2's optional smooth-basis solver
//! (`tapeshape_model::Step2Solver::SmoothBasis`), kept in the cache
//! directory beside the decoded model, so that only the first process on a
//! machine pays its computation (about 1.3 s for 200 modes of the
//! template).
//!
//! The file (`<dir>/smooth-<key>-<k>.tsb`, `key` the topology's
//! fingerprint, `tapeshape_model::smooth_basis::edges_key`, in hex) holds
//!
//! ```text
//! magic "TSBASIS1" | format u32 | vertices u64 | modes u64 | key u64 | body crc32 u32 | body
//! body: values (modes f64) | rows (vertices x modes f64, row-major), little-endian
//! ```
//!
//! f64 and not f32: a basis read back must be the one computed, bit for
//! bit, or the first prediction of a machine would differ from the later
//! ones. A file with another magic, format, shape or key, or a body whose
//! checksum does not match, is ignored and rewritten (atomically); one that
//! cannot be written costs only time.

use std::path::{Path, PathBuf};

use tapeshape_model::smooth_basis::{edges_key, Preparing, SmoothBasis};

const MAGIC: [u8; 8] = *b"TSBASIS1";
const FORMAT: u32 = 1;
const HEADER: usize = 8 + 4 + 8 + 8 + 8 + 4;

/// The cache file of the basis with `k` modes of the topology `key`.
pub fn basis_path(dir: &Path, key: u64, k: usize) -> PathBuf {
    dir.join(format!("smooth-{key:016x}-{k}.tsb"))
}

/// The file's bytes for `basis`.
pub(crate) fn encode(basis: &SmoothBasis) -> Vec<u8> {
    let mut body = Vec::with_capacity(8 * (basis.values().len() + basis.rows().len()));
    for v in basis.values().iter().chain(basis.rows()) {
        body.extend_from_slice(&v.to_le_bytes());
    }
    let mut out = Vec::with_capacity(HEADER + body.len());
    out.extend_from_slice(&MAGIC);
    out.extend_from_slice(&FORMAT.to_le_bytes());
    out.extend_from_slice(&(basis.n_vertices() as u64).to_le_bytes());
    out.extend_from_slice(&(basis.k() as u64).to_le_bytes());
    out.extend_from_slice(&basis.key().to_le_bytes());
    out.extend_from_slice(&crc32fast::hash(&body).to_le_bytes());
    out.extend_from_slice(&body);
    out
}

/// The basis in `bytes` if it is a valid file for `n` vertices, `k` modes
/// and topology `key`.
pub(crate) fn decode(bytes: &[u8], n: usize, k: usize, key: u64) -> Option<SmoothBasis> {
    if bytes.len() < HEADER || bytes[..8] != MAGIC || bytes[8..12] != FORMAT.to_le_bytes() {
        return None;
    }
    let word = |at: usize| u64::from_le_bytes(bytes[at..at + 8].try_into().expect("8 bytes"));
    if word(12) != n as u64 || word(20) != k as u64 || word(28) != key {
        return None;
    }
    let crc = u32::from_le_bytes(bytes[36..40].try_into().expect("4 bytes"));
    let body = &bytes[HEADER..];
    if body.len() != 8 * (k + n * k) || crc32fast::hash(body) != crc {
        return None;
    }
    let mut all = body
        .chunks_exact(8)
        .map(|c| f64::from_le_bytes(c.try_into().expect("8 bytes")));
    let values: Vec<f64> = all.by_ref().take(k).collect();
    let rows: Vec<f64> = all.collect();
    SmoothBasis::from_parts(n, k, rows, values, key).ok()
}

/// Claims the preparation of the basis of `k` modes of the mesh (`n`
/// vertices, `edges`): [`PendingBasis::finish`] makes it available to this
/// process's predictions, read from `dir`, or computed and written there (a
/// failure to compute is left to the prediction, which reports it; a cache
/// that cannot be read or written only costs time). The claim means a
/// prediction's step 2 waits for it rather than computing it; `None` if the
/// process has it already or another thread is preparing it. The claim is
/// made here, on the calling thread; [`PendingBasis::finish`] can then run
/// on another.
pub(crate) fn begin<'a>(
    dir: Option<&'a Path>,
    n: usize,
    edges: &'a [[u32; 2]],
    k: usize,
) -> Option<PendingBasis<'a>> {
    let key = edges_key(n, edges);
    let claim = SmoothBasis::preparing(n, key, k)?;
    Some(PendingBasis {
        dir,
        n,
        edges,
        k,
        key,
        _claim: claim,
    })
}

/// A basis this thread has claimed to prepare ([`begin`]).
pub(crate) struct PendingBasis<'a> {
    dir: Option<&'a Path>,
    n: usize,
    edges: &'a [[u32; 2]],
    k: usize,
    key: u64,
    /// Released when this is finished or dropped.
    _claim: Preparing,
}

impl PendingBasis<'_> {
    /// Reads the basis from the cache folder, or computes it (and writes
    /// it there), and shares it with the process.
    pub(crate) fn finish(self) {
        let (n, k, key) = (self.n, self.k, self.key);
        let Some(dir) = self.dir else {
            if let Ok(basis) = SmoothBasis::compute(n, self.edges, k) {
                SmoothBasis::share(basis);
            }
            return;
        };
        let path = basis_path(dir, key, k);
        if let Some(basis) = crate::cache::map_file(&path)
            .ok()
            .and_then(|b| decode(&b, n, k, key))
        {
            SmoothBasis::share(basis);
            return;
        }
        // Not `SmoothBasis::shared`: it would wait for this very claim.
        let Ok(basis) = SmoothBasis::compute(n, self.edges, k) else {
            return;
        };
        let basis = SmoothBasis::share(basis);
        let written = std::fs::create_dir_all(dir)
            .and_then(|()| tapeshape_common::fs::write_atomic(&path, &encode(&basis)));
        if let Err(e) = written {
            tracing::warn!(path = %path.display(), error = %e, "could not write the smooth-basis cache (each process computes it again)");
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn grid_edges(w: u32) -> Vec<[u32; 2]> {
        let id = |i: u32, j: u32| i * w + j;
        let mut edges = Vec::new();
        for i in 0..w {
            for j in 0..w {
                if i + 1 < w {
                    edges.push([id(i, j), id(i + 1, j)]);
                }
                if j + 1 < w {
                    edges.push([id(i, j), id(i, j + 1)]);
                }
            }
        }
        edges
    }

    #[test]
    fn a_basis_round_trips_bit_for_bit_and_a_damaged_or_foreign_file_is_refused() {
        let edges = grid_edges(9);
        let b = SmoothBasis::compute(81, &edges, 12).unwrap();
        let bytes = encode(&b);
        assert_eq!(decode(&bytes, 81, 12, b.key()).as_ref(), Some(&b));
        assert!(decode(&bytes, 81, 11, b.key()).is_none());
        assert!(decode(&bytes, 81, 12, b.key() ^ 1).is_none());
        let mut bad = bytes.clone();
        let last = bad.len() - 1;
        bad[last] ^= 1;
        assert!(decode(&bad, 81, 12, b.key()).is_none());
        assert!(decode(&bytes[..bytes.len() - 8], 81, 12, b.key()).is_none());
    }

    #[test]
    fn prepare_writes_the_file_and_a_later_process_can_read_it() {
        let dir = std::env::temp_dir().join(format!("tapeshape-basis-{}", std::process::id()));
        let edges = grid_edges(7);
        begin(Some(&dir), 49, &edges, 9).unwrap().finish();
        let key = edges_key(49, &edges);
        let bytes = std::fs::read(basis_path(&dir, key, 9)).unwrap();
        let read = decode(&bytes, 49, 9, key).unwrap();
        assert_eq!(read, *SmoothBasis::find_shared(49, key, 9).unwrap());
        std::fs::remove_dir_all(&dir).ok();
    }
}
