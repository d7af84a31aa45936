//! `tapeshape batch`: the same bytes whatever the thread count, resumable,
//! shards that partition the rows, a bad row that stops nothing.

use super::*;

const SURVEY: &str = "\
id,sex,stature,chest,waist,hip
a1,f,164cm,88cm,70cm,98cm
b2,m,178cm,101cm,88cm,101cm
c3,,1.71m,95cm,300cm,99cm
d4,x,170cm,90cm,80cm,95cm
e5,m,185,104,92,103
";

fn files(dir: &Path) -> Vec<(String, Vec<u8>)> {
    let mut out: Vec<(String, Vec<u8>)> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| {
            let e = e.unwrap();
            (
                e.file_name().to_string_lossy().into_owned(),
                std::fs::read(e.path()).unwrap(),
            )
        })
        .collect();
    out.sort();
    out
}

#[test]
fn rows_are_read_with_units_ids_and_reasons() {
    let rows = read_rows(SURVEY, "survey.csv").unwrap();
    assert_eq!(rows.len(), 5);
    assert_eq!(rows[0].id, "a1");
    assert_eq!(rows[0].sex.as_deref(), Some("f"));
    let a = rows[0].inputs.as_ref().unwrap();
    assert_eq!(a.readings.len(), 4);
    assert!((a.readings[0].value.metres - 1.64).abs() < 1e-12);
    // Bare numbers are centimetres, as `predict` reads them.
    let e = rows[4].inputs.as_ref().unwrap();
    assert!((e.readings[0].value.metres - 1.85).abs() < 1e-12);
    let bad = rows[3].inputs.as_ref().unwrap_err();
    assert!(bad.contains("sex 'x'"), "{bad}");
    // Without an id column, ids are the row numbers.
    let rows = read_rows("stature,chest\n170cm,90cm\n,\n", "x").unwrap();
    assert_eq!(rows[0].id, "row-1");
    assert!(rows[1]
        .inputs
        .as_ref()
        .unwrap_err()
        .contains("no measurement"));
    assert!(read_rows("stature,stature\n1,2\n", "x").is_err());
}

#[test]
fn shards_partition_the_rows() {
    let ids: Vec<String> = (0..500).map(|i| format!("person-{i}")).collect();
    for n in [1, 2, 3, 7] {
        let mut count = vec![0; ids.len()];
        for k in 1..=n {
            let shard = Shard::parse(&format!("{k}/{n}")).unwrap();
            for (i, id) in ids.iter().enumerate() {
                if shard.contains(id) {
                    count[i] += 1;
                }
            }
            // Every shard gets a fair share (a stable hash, not a bias).
            let mine = ids.iter().filter(|id| shard.contains(id)).count();
            assert!(mine * n as usize > 500 / 2, "{k}/{n}: {mine}");
        }
        assert!(count.iter().all(|&c| c == 1), "n = {n}");
    }
    // Stable: the same id lands in the same shard on every machine.
    assert!(
        Shard::parse("2/3").unwrap().contains("person-1") == {
            let h = Sha256::digest(b"person-1");
            u64::from_be_bytes(h[..8].try_into().unwrap()) % 3 == 1
        }
    );
    for bad in ["0/3", "4/3", "1/0", "x", "1/2/3"] {
        assert!(Shard::parse(bad).is_err(), "{bad}");
    }
}

/// One run on 1 thread, one on 2: the same files, byte for byte; the bad
/// rows are refused with their reasons and the others are done; a second
/// run skips everything; a changed row is done again.
#[test]
fn batch_is_deterministic_resumable_and_refuses_bad_rows_alone() {
    let estimator = Estimator::default_model().unwrap();
    let rows = read_rows(SURVEY, "survey.csv").unwrap();
    let (one, two) = (tempfile::tempdir().unwrap(), tempfile::tempdir().unwrap());
    let s1 = run_rows(
        estimator,
        &rows,
        one.path(),
        MeshFormat::Ply,
        Shard::ALL,
        1,
        &|| {},
    )
    .unwrap();
    let s2 = run_rows(
        estimator,
        &rows,
        two.path(),
        MeshFormat::Ply,
        Shard::ALL,
        2,
        &|| {},
    )
    .unwrap();
    assert_eq!((s1.done, s1.skipped, s1.refused.len()), (3, 0, 2), "{s1:?}");
    assert_eq!((s2.done, s2.skipped), (3, 0));
    let refused: Vec<&str> = s1.refused.iter().map(|r| r.1.as_str()).collect();
    assert_eq!(refused, ["c3", "d4"]);
    assert!(s1.refused[0].2.contains("waist"), "{:?}", s1.refused[0]);
    assert_eq!(files(one.path()), files(two.path()));
    assert_eq!(files(one.path()).len(), 6);
    let report: PersonReport =
        serde_json::from_slice(&std::fs::read(one.path().join("a1.json")).unwrap()).unwrap();
    assert_eq!(report.sex.as_deref(), Some("f"));
    assert!(report.estimate["prediction"].get("timings").is_none());

    let before = files(one.path());
    let again = run_rows(
        estimator,
        &rows,
        one.path(),
        MeshFormat::Ply,
        Shard::ALL,
        2,
        &|| {},
    )
    .unwrap();
    assert_eq!((again.done, again.skipped, again.refused.len()), (0, 3, 2));
    assert_eq!(files(one.path()), before);

    let changed = SURVEY.replace("a1,f,164cm", "a1,f,166cm");
    let rows = read_rows(&changed, "survey.csv").unwrap();
    let third = run_rows(
        estimator,
        &rows,
        one.path(),
        MeshFormat::Ply,
        Shard::ALL,
        2,
        &|| {},
    )
    .unwrap();
    assert_eq!((third.done, third.skipped), (1, 2));
    assert_ne!(
        std::fs::read(one.path().join("a1.ply")).unwrap(),
        before.iter().find(|f| f.0 == "a1.ply").unwrap().1
    );
}

#[test]
fn repeated_and_unsafe_ids_are_refused() {
    let estimator = Estimator::default_model().unwrap();
    let rows = read_rows("id,stature\n../x,170cm\nsame,170cm\nsame,171cm\n", "x").unwrap();
    let dir = tempfile::tempdir().unwrap();
    let s = run_rows(
        estimator,
        &rows,
        dir.path(),
        MeshFormat::Ply,
        Shard::ALL,
        1,
        &|| {},
    )
    .unwrap();
    assert_eq!(s.done, 1);
    let why: Vec<&str> = s.refused.iter().map(|r| r.2.as_str()).collect();
    assert!(why[0].contains("cannot name a file"), "{why:?}");
    assert!(why[1].contains("used by an earlier row"), "{why:?}");
}

#[test]
fn a_survey_row_has_its_own_digest_and_a_plain_row_keeps_the_old_one() {
    let rows = read_rows(SURVEY, "survey.csv").unwrap();
    let plain = rows[0].inputs.as_ref().unwrap().clone();
    let mut survey = plain.clone();
    survey.ansur_survey = true;
    let d = inputs_sha256(&plain, Some("m"));
    // A resumed run with --ansur-survey must not skip rows done without it,
    // nor the reverse.
    assert_ne!(d, inputs_sha256(&survey, Some("m")));
    // The plain digest is the one this row had before the flag existed
    // (inputs_sha256 of 59ec0cc): earlier runs still resume.
    assert_eq!(
        d,
        "0bb410b71969bc12ea02b57db02757a064df2526dd2d78f2ed980df556636de9"
    );
}
