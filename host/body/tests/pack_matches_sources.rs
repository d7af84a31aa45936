//! The MakeHuman data committed with this crate is what the MakeHuman pack
//! holds.
//!
//! Always (a plain clone of the repository): every committed copy
//! (`assets/makehuman/*`, `tests/data/reference/*`) has the SHA-256 that
//! `assets/makehuman/SHA256SUMS` records for the pack's own file, and the
//! embedded blend pack has the SHA-256 it had when it was last checked against
//! the sources ([`EMBEDDED_PACK_SHA256`]).
//!
//! Opt-in, for maintainers who hold the full pack (the project's `shared/`
//! folder): `TAPESHAPE_SHARED=/path/to/shared cargo test -p tapeshape-body
//! --test pack_matches_sources` re-reads `$TAPESHAPE_SHARED/assets/makehuman`
//! file by file: `SHA256SUMS` matches it, the embedded blend pack holds
//! exactly its base mesh and its 848 targets, and the anatomy derivation's
//! [`Pack`] read from it equals [`Pack::committed`] value for value. With the
//! variable set and the pack missing these tests fail; without it they say
//! SKIPPED.

use std::path::{Path, PathBuf};

use sha2::{Digest, Sha256};
use tapeshape_body::anatomy::pack::Pack;
use tapeshape_body::pack::{self, RawPack};

/// SHA-256 of `assets/makehuman/blend.pack.z` as built by the `pack_assets`
/// example from the pack and checked equal to it by
/// [`embedded_pack_equals_the_sources`] (2026-12-01). A rebuilt pack must pass
/// that check (run it with `TAPESHAPE_SHARED`) before this value is updated.
const EMBEDDED_PACK_SHA256: &str =
    "ff5e71f28428b7e1aeedbb7c63e8bd03ad78b0c9571c8f82c7d2da753e33a100";

fn crate_dir() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
}

fn sha256_hex(bytes: &[u8]) -> String {
    Sha256::digest(bytes)
        .iter()
        .map(|b| format!("{b:02x}"))
        .collect()
}

/// `(hash, path in the pack)` of every line of `SHA256SUMS`.
fn recorded_sums() -> Vec<(String, String)> {
    let path = crate_dir().join("assets/makehuman/SHA256SUMS");
    let text = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let sums: Vec<(String, String)> = text
        .lines()
        .filter(|l| !l.starts_with('#') && !l.trim().is_empty())
        .map(|l| {
            let (hash, name) = l
                .split_once("  ")
                .unwrap_or_else(|| panic!("SHA256SUMS line {l:?} is not `HASH  PATH`"));
            assert_eq!(hash.len(), 64, "{l:?}");
            (hash.to_string(), name.to_string())
        })
        .collect();
    assert!(sums.len() >= 28, "SHA256SUMS lists {} files", sums.len());
    sums
}

/// Where the repository keeps its copy of the pack file `name`.
fn committed_copy(name: &str) -> PathBuf {
    match name {
        "README.md" => crate_dir().join("assets/makehuman/pack-README.md"),
        _ => match name.strip_prefix("reference/") {
            Some(rest) => crate_dir().join("tests/data/reference").join(rest),
            None => crate_dir().join("assets/makehuman").join(name),
        },
    }
}

fn read(path: &Path) -> Vec<u8> {
    std::fs::read(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

/// The full pack named by `TAPESHAPE_SHARED`, or `None` (SKIPPED) when the
/// variable is not set. Set but without a pack: a failure, not a skip.
fn shared_pack(test: &str) -> Option<PathBuf> {
    let Some(shared) = std::env::var_os("TAPESHAPE_SHARED") else {
        eprintln!(
            "SKIPPED {test}: set TAPESHAPE_SHARED=/path/to/shared (the folder holding \
             assets/makehuman) to check the committed data against the full MakeHuman pack"
        );
        return None;
    };
    let root = PathBuf::from(&shared).join("assets/makehuman");
    assert!(
        root.join("3dobjs/base.obj").is_file() && root.join("targets").is_dir(),
        "TAPESHAPE_SHARED={} is set, but {} holds no MakeHuman pack (3dobjs/base.obj, targets/)",
        shared.to_string_lossy(),
        root.display()
    );
    Some(root)
}

#[test]
fn committed_copies_have_the_recorded_checksums() {
    for (hash, name) in recorded_sums() {
        let path = committed_copy(&name);
        assert_eq!(
            sha256_hex(&read(&path)),
            hash,
            "{} is not the pack's {name} recorded in SHA256SUMS",
            path.display()
        );
    }
}

#[test]
fn embedded_pack_is_the_one_checked_against_the_sources() {
    assert_eq!(
        sha256_hex(pack::EMBEDDED),
        EMBEDDED_PACK_SHA256,
        "assets/makehuman/blend.pack.z changed: check it against the sources \
         (TAPESHAPE_SHARED=... cargo test -p tapeshape-body --test pack_matches_sources) \
         and then update EMBEDDED_PACK_SHA256"
    );
    let embedded = RawPack::decode(pack::EMBEDDED).expect("embedded pack decodes");
    let tsv = std::fs::read_to_string(crate_dir().join("assets/makehuman/local_changes.tsv"))
        .expect("local_changes.tsv");
    let rows = pack::parse_local_changes(&tsv, "local_changes.tsv").expect("parses");
    let names: Vec<&str> = embedded.targets.iter().map(|t| t.name.as_str()).collect();
    assert_eq!(names, pack::required_targets(&rows));
    assert_eq!(embedded.base.len(), pack::N_BASE);
}

#[test]
fn recorded_checksums_are_those_of_the_shared_pack() {
    let Some(root) = shared_pack("recorded_checksums_are_those_of_the_shared_pack") else {
        return;
    };
    for (hash, name) in recorded_sums() {
        assert_eq!(
            sha256_hex(&read(&root.join(&name))),
            hash,
            "SHA256SUMS differs from the pack's {name}: copy the file again and update SHA256SUMS"
        );
    }
}

#[test]
fn embedded_pack_equals_the_sources() {
    let Some(root) = shared_pack("embedded_pack_equals_the_sources") else {
        return;
    };
    let sources = pack::read_sources(&root).expect("sources parse");
    let embedded = RawPack::decode(pack::EMBEDDED).expect("embedded pack decodes");
    assert!(embedded.base == sources.base, "base mesh differs");
    assert_eq!(embedded.targets.len(), sources.targets.len());
    for (e, s) in embedded.targets.iter().zip(&sources.targets) {
        assert_eq!(e.name, s.name);
        assert!(
            e.index == s.index && e.delta == s.delta,
            "target {} differs",
            s.name
        );
    }
    // 848 = 36 universal + 12 race + 72 height + 72 proportions + 144 breast + 512 local.
    assert_eq!(sources.targets.len(), 848);
}

#[test]
fn committed_anatomy_pack_equals_the_full_pack() {
    let Some(root) = shared_pack("committed_anatomy_pack_equals_the_full_pack") else {
        return;
    };
    let full = Pack::load(&root).expect("the full pack loads");
    let committed = Pack::committed().expect("the committed pack loads");
    assert!(full.base == committed.base, "base mesh differs");
    assert_eq!(full.keep, committed.keep);
    assert_eq!(full.triangles, committed.triangles);
    assert_eq!(full.mirror, committed.mirror);
    assert_eq!(full.groups, committed.groups);
    assert_eq!(
        format!("{:?}", full.bones),
        format!("{:?}", committed.bones)
    );
    assert!(full.weights == committed.weights, "weights differ");
    // Every target, as the derivation reads it: the same f64 offsets.
    let embedded = RawPack::decode(pack::EMBEDDED).expect("embedded pack decodes");
    for t in &embedded.targets {
        let a = full.read_target(&t.name).expect("full pack target");
        let b = committed.read_target(&t.name).expect("committed target");
        assert!(a == b, "target {} differs", t.name);
    }
}
