//! The cache: what it gives back is what the embedded model decodes to,
//! and a damaged, stale or foreign file is never used.

use super::*;
use crate::file::{load_model_bytes, DEFAULT_MODEL};
use crate::Estimator;

fn decoded() -> (ModelFile, RealStats) {
    let file = load_model_bytes(DEFAULT_MODEL, "test").expect("embedded model");
    let estimator = Estimator::new(file.clone(), "test").expect("compiles");
    (file, RealStats::compute(&estimator.set, None))
}

fn same(a: &ModelFile, b: &ModelFile) {
    assert_eq!(a.to_bytes().unwrap(), b.to_bytes().unwrap());
}

#[test]
fn a_cache_round_trips_the_model_and_its_statistics_exactly() {
    let (file, real) = decoded();
    let bytes = encode(&file, &real, DEFAULT_MODEL_SHA256).unwrap();
    // The embedded basis is rounded to f32: stored at half the width.
    assert!(bytes.len() < file.to_bytes().unwrap().len() * 2 / 3);
    let (back, real_back) = decode(&bytes, DEFAULT_MODEL_SHA256).unwrap();
    same(&file, &back);
    assert_eq!(real_back.row_for_tests(), real.row_for_tests());
    assert_eq!(
        real_back.joint_for_tests().mean,
        real.joint_for_tests().mean
    );
    assert_eq!(real_back.joint_for_tests().cov, real.joint_for_tests().cov);
}

#[test]
fn damaged_stale_or_foreign_files_are_refused() {
    let (file, real) = decoded();
    let good = encode(&file, &real, DEFAULT_MODEL_SHA256).unwrap();
    // One flipped bit anywhere in the body.
    for at in [HEADER + 3, HEADER + 5000, good.len() / 2, good.len() - 1] {
        let mut bad = good.clone();
        bad[at] ^= 0x10;
        assert_eq!(
            decode(&bad, DEFAULT_MODEL_SHA256).unwrap_err(),
            Rejected::Damaged,
            "byte {at}"
        );
    }
    // Truncated.
    assert_eq!(
        decode(&good[..good.len() - 10], DEFAULT_MODEL_SHA256).unwrap_err(),
        Rejected::Damaged
    );
    assert_eq!(
        decode(&good[..20], DEFAULT_MODEL_SHA256).unwrap_err(),
        Rejected::NotACache
    );
    // Made for another model.
    let other = "00".repeat(32);
    assert_eq!(decode(&good, &other).unwrap_err(), Rejected::Stale);
    // Another format version.
    let mut old = good.clone();
    old[8] ^= 0xff;
    assert_eq!(
        decode(&old, DEFAULT_MODEL_SHA256).unwrap_err(),
        Rejected::NotACache
    );
    // A body whose checksum matches but whose content is wrong (written by
    // a broken build, say): the model's own validation refuses it.
    let mut broken = file.clone();
    broken.template.n_vertices += 1;
    let bytes = encode(&broken, &real, DEFAULT_MODEL_SHA256).unwrap();
    assert!(matches!(
        decode(&bytes, DEFAULT_MODEL_SHA256),
        Err(Rejected::Invalid(_))
    ));
}

/// Through the directory: a miss writes the cache, a hit reads it, a
/// damaged file is rebuilt, other models' caches are removed.
#[test]
fn the_default_model_rebuilds_a_damaged_cache() {
    let dir = tempfile::tempdir().unwrap();
    let foreign = dir.path().join(format!("default-{}.tsc", "11".repeat(32)));
    std::fs::write(&foreign, b"an older model's cache").unwrap();
    let path = cache_path(dir.path(), DEFAULT_MODEL_SHA256);

    let first = Estimator::default_cached(dir.path()).unwrap();
    let written = std::fs::read(&path).expect("a miss writes the cache");
    assert!(!foreign.exists(), "other models' caches are removed");
    assert!(first.real.get().is_some(), "a miss computes the statistics");

    let second = Estimator::default_cached(dir.path()).unwrap();
    same(&first.file, &second.file);
    assert!(second.real.get().is_some(), "a hit brings the statistics");
    assert_eq!(
        std::fs::read(&path).unwrap(),
        written,
        "a hit leaves the file"
    );

    let mut damaged = written.clone();
    let mid = damaged.len() / 2;
    damaged[mid] ^= 1;
    std::fs::write(&path, &damaged).unwrap();
    assert_eq!(
        read(dir.path(), DEFAULT_MODEL_SHA256).unwrap_err(),
        Rejected::Damaged
    );
    let third = Estimator::default_cached(dir.path()).unwrap();
    same(&first.file, &third.file);
    assert_eq!(
        std::fs::read(&path).unwrap(),
        written,
        "the damaged file is rewritten"
    );
}
