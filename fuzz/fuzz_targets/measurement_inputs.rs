//! The estimator's measurement input readers (`Inputs::from_file` for
//! `.toml`, `.json` and `.csv`, which `tapeshape predict --measurements FILE`
//! reads, and `Inputs::add_assignment` for `--measure name=value`): no panic,
//! only typed errors; accepted readings have unique names.
//!
//! The first byte picks the reader; the rest is the file's text (or the
//! assignment). `from_file` is called on a real file so that its extension
//! dispatch is what runs.
#![no_main]

use std::io::Write;
use std::sync::OnceLock;

use libfuzzer_sys::fuzz_target;
use tapeshape_estimator::Inputs;

/// A folder for the input file, in memory where the system has one (a file
/// per input on a disk would dominate the run).
fn dir() -> &'static tempfile::TempDir {
    static D: OnceLock<tempfile::TempDir> = OnceLock::new();
    D.get_or_init(|| {
        let shm = std::path::Path::new("/dev/shm");
        if shm.is_dir() {
            tempfile::tempdir_in(shm)
        } else {
            tempfile::tempdir()
        }
        .expect("a temporary folder")
    })
}

fn unique_names(inputs: &Inputs) {
    let mut names: Vec<&str> = inputs.readings.iter().map(|r| r.name.as_str()).collect();
    names.sort_unstable();
    names.dedup();
    assert_eq!(names.len(), inputs.readings.len());
}

fuzz_target!(|data: &[u8]| {
    let Some((&pick, rest)) = data.split_first() else {
        return;
    };
    let ext = match pick % 4 {
        0 => "toml",
        1 => "json",
        2 => "csv",
        _ => {
            let Ok(text) = std::str::from_utf8(rest) else {
                return;
            };
            let mut inputs = Inputs::new();
            for part in text.split('\n') {
                let _ = inputs.add_assignment(part);
                let _ = inputs.set_tolerance(part);
            }
            unique_names(&inputs);
            return;
        }
    };
    let path = dir().path().join(format!("m.{ext}"));
    std::fs::File::create(&path)
        .and_then(|mut f| f.write_all(rest))
        .expect("writing the input file");
    if let Ok(inputs) = Inputs::from_file(&path) {
        unique_names(&inputs);
    }
});
