//! The one way a file the user keeps is written: [`write_atomic`].
//!
//! Why: an export, a model, a dataset, a figure or a report must never be
//! found half written, whether the program is killed, the disk fills or the
//! power goes. So the bytes go to a temporary file in the same folder (a
//! rename is atomic only within one file system), the file is flushed to
//! disk (`fsync`), renamed over the target, and the folder is flushed too so
//! the rename itself survives a power cut. A reader sees the old file or the
//! whole new one, never a mixture; on any error the temporary file is
//! removed and the old file is left as it was.
//!
//! Built on `tempfile` (a unique name created exclusively, removed when
//! dropped, renamed by `persist`). The new file gets the permissions an
//! ordinary `File::create` would give (0666 less the umask), not
//! `tempfile`'s private 0600: an exported body is the user's file to share.

use std::io::{self, BufWriter, Write};
use std::path::Path;

/// Writes `bytes` to `path` atomically and durably (see the module docs).
///
/// Errors: any I/O error of creating, writing, flushing or renaming (the
/// caller adds the path to its message); `path` naming no file (`/`, `..`)
/// is [`io::ErrorKind::InvalidInput`].
pub fn write_atomic(path: &Path, bytes: &[u8]) -> io::Result<()> {
    write_atomic_with(path, |w| w.write_all(bytes))
}

/// [`write_atomic`] for a file written piece by piece: `write` gets a
/// buffered writer on the temporary file (for files too large to hold twice
/// in memory, such as a 66 MB dataset). If `write` fails, nothing is
/// renamed and its error is returned.
pub fn write_atomic_with(
    path: &Path,
    write: impl FnOnce(&mut dyn Write) -> io::Result<()>,
) -> io::Result<()> {
    let name = path.file_name().ok_or_else(|| {
        io::Error::new(
            io::ErrorKind::InvalidInput,
            format!("{} names no file", path.display()),
        )
    })?;
    let dir = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };
    let mut builder = tempfile::Builder::new();
    let prefix = format!(".{}.", name.to_string_lossy());
    builder.prefix(&prefix).suffix(".tmp");
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        builder.permissions(std::fs::Permissions::from_mode(0o666));
    }
    let mut tmp = builder.tempfile_in(dir)?;
    {
        let mut w = BufWriter::new(tmp.as_file_mut());
        write(&mut w)?;
        w.flush()?;
    }
    tmp.as_file().sync_all()?;
    tmp.persist(path).map_err(|e| e.error)?;
    sync_dir(dir)
}

/// Flushes a folder's entries (the rename) to disk. Only Unix can open a
/// folder to fsync it; elsewhere the rename is left to the file system.
fn sync_dir(dir: &Path) -> io::Result<()> {
    #[cfg(unix)]
    {
        std::fs::File::open(dir)?.sync_all()?;
    }
    #[cfg(not(unix))]
    let _ = dir;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn leftovers(dir: &Path) -> Vec<String> {
        std::fs::read_dir(dir)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .filter(|n| n.ends_with(".tmp"))
            .collect()
    }

    #[test]
    fn writes_replaces_and_leaves_no_temporary_file() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("body.obj");
        write_atomic(&path, b"first").unwrap();
        assert_eq!(std::fs::read(&path).unwrap(), b"first");
        write_atomic(&path, b"second, longer").unwrap();
        assert_eq!(std::fs::read(&path).unwrap(), b"second, longer");
        assert!(leftovers(dir.path()).is_empty());
        #[cfg(unix)]
        {
            use std::os::unix::fs::PermissionsExt;
            // Readable by others unless the umask says otherwise (not
            // tempfile's private 0600).
            let mode = std::fs::metadata(&path).unwrap().permissions().mode();
            let umask = umask_of_plain_create(dir.path());
            assert_eq!(mode & 0o777, 0o666 & !umask, "mode {mode:o}");
        }
    }

    /// The umask as `File::create` applies it (read from a file made the
    /// ordinary way, so the test needs no `unsafe` call to `umask`).
    #[cfg(unix)]
    fn umask_of_plain_create(dir: &Path) -> u32 {
        use std::os::unix::fs::PermissionsExt;
        let p = dir.join("plain");
        std::fs::File::create(&p).unwrap();
        let mode = std::fs::metadata(&p).unwrap().permissions().mode() & 0o777;
        std::fs::remove_file(&p).unwrap();
        0o666 & !mode
    }

    #[test]
    fn a_failed_write_keeps_the_old_file_and_cleans_up() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("model.tsm");
        write_atomic(&path, b"old").unwrap();
        let err = write_atomic_with(&path, |w| {
            w.write_all(b"half of the new")?;
            Err(io::Error::other("disk full"))
        })
        .unwrap_err();
        assert_eq!(err.to_string(), "disk full");
        assert_eq!(std::fs::read(&path).unwrap(), b"old");
        assert!(leftovers(dir.path()).is_empty());
    }

    #[test]
    fn bad_targets_are_errors_not_panics() {
        let dir = tempfile::tempdir().unwrap();
        // A folder that does not exist.
        assert!(write_atomic(&dir.path().join("no/such/dir/x"), b"x").is_err());
        // A path that names no file.
        let e = write_atomic(Path::new("/"), b"x").unwrap_err();
        assert_eq!(e.kind(), io::ErrorKind::InvalidInput);
    }
}
