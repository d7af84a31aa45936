//! The embedded blend pack holds exactly the MakeHuman sources it was built
//! from (`../shared/assets/makehuman`, beside the repository as in CI).

use std::path::PathBuf;

use tapeshape_body::pack::{self, RawPack};

#[test]
fn embedded_pack_equals_the_sources() {
    // shared/ beside the repository root (CI), or inside it.
    let dir = env!("CARGO_MANIFEST_DIR");
    let candidates = [
        PathBuf::from(format!("{dir}/../../../shared/assets/makehuman")),
        PathBuf::from(format!("{dir}/../../shared/assets/makehuman")),
    ];
    let root = candidates
        .iter()
        .find(|p| p.join("README.md").exists())
        .unwrap_or_else(|| {
            panic!("the MakeHuman pack is expected at {candidates:?} (check out shared/ beside the repository)")
        });
    let sources = pack::read_sources(root).expect("sources parse");
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
