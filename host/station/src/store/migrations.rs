//! Schema migrations: ordered SQL files in `host/station/migrations/`,
//! compiled into the program and tracked by `PRAGMA user_version`.
//!
//! Why files and not strings in the code: a migration is reviewed as SQL,
//! and `migrations/released.sha256` pins every released one by checksum, so
//! editing one after release fails a test (`released_migrations_never_change`)
//! instead of silently giving two stations two schemas under one version
//! number. To change the schema, add `NNNN_what.sql` (the next number), list
//! it in [`MIGRATIONS`], and add its line to `released.sha256`
//! (`sha256sum NNNN_what.sql >> released.sha256`).
//!
//! Migration `i` (1-based) takes a database from `user_version = i - 1` to
//! `i`, in one immediate transaction, so opening a store twice (or from two
//! processes at once) is harmless. Foreign keys are off while migrations run
//! (SQLite's documented way to rebuild a table, see 0003) and every
//! migration's transaction checks them (`PRAGMA foreign_key_check`) before
//! it commits.

use std::path::Path;

use rusqlite::{Connection, TransactionBehavior};

use super::StoreError;

/// One migration file.
#[derive(Clone, Copy, Debug)]
pub struct Migration {
    /// The file's name in `host/station/migrations/` (`0003_reading_source.sql`).
    pub file: &'static str,
    /// Its SQL.
    pub sql: &'static str,
}

macro_rules! migration {
    ($file:literal) => {
        Migration {
            file: $file,
            sql: include_str!(concat!("../../migrations/", $file)),
        }
    };
}

/// Every migration, in order: entry `i` takes the schema to version `i + 1`.
pub const MIGRATIONS: &[Migration] = &[
    migration!("0001_sessions_readings_link_state.sql"),
    migration!("0002_withdrawn_readings_and_marks.sql"),
    migration!("0003_reading_source.sql"),
    migration!("0004_estimates.sql"),
    migration!("0005_outbox_and_consent.sql"),
    migration!("0006_careful_mode.sql"),
];

/// The schema version this build writes (the number of migrations).
pub fn current_version() -> i64 {
    MIGRATIONS.len() as i64
}

/// Applies the migrations `conn` (the database at `path`) has not had yet.
pub(crate) fn migrate(conn: &mut Connection, path: &Path) -> Result<(), StoreError> {
    conn.pragma_update(None, "foreign_keys", false)?;
    let result = apply_pending(conn, path);
    // Back on whatever happened: the connection is used for everything else.
    conn.pragma_update(None, "foreign_keys", true)?;
    result
}

fn apply_pending(conn: &mut Connection, path: &Path) -> Result<(), StoreError> {
    let supported = current_version();
    loop {
        let tx = conn.transaction_with_behavior(TransactionBehavior::Immediate)?;
        // Read inside the write lock: another process may have migrated
        // between our checks.
        let version: i64 = tx.pragma_query_value(None, "user_version", |r| r.get(0))?;
        if version < 0 {
            return Err(StoreError::Corrupt(format!(
                "{} has negative schema version {version}",
                path.display()
            )));
        }
        if version > supported {
            return Err(StoreError::SchemaTooNew {
                path: path.to_path_buf(),
                found: version,
                supported,
            });
        }
        if version == supported {
            return Ok(());
        }
        let m = MIGRATIONS[usize::try_from(version).unwrap_or(0)];
        tx.execute_batch(m.sql)
            .map_err(|error| StoreError::Migration {
                path: path.to_path_buf(),
                file: m.file,
                error,
            })?;
        let broken: Option<String> = {
            let mut stmt = tx.prepare("PRAGMA foreign_key_check")?;
            let mut rows = stmt.query([])?;
            match rows.next()? {
                Some(r) => Some(format!(
                    "table {} row {} refers to a missing row of {}",
                    r.get::<_, String>(0)?,
                    r.get::<_, Option<i64>>(1)?.unwrap_or(-1),
                    r.get::<_, String>(2)?
                )),
                None => None,
            }
        };
        if let Some(broken) = broken {
            return Err(StoreError::Corrupt(format!(
                "{} after migration {}: {broken}",
                path.display(),
                m.file
            )));
        }
        tx.pragma_update(None, "user_version", version + 1)?;
        tx.commit()?;
        tracing::info!(path = %path.display(), version = version + 1, file = m.file, "session database migrated");
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use sha2::Digest as _;

    fn dir() -> std::path::PathBuf {
        Path::new(env!("CARGO_MANIFEST_DIR")).join("migrations")
    }

    /// Every migration applies, in order, to an empty in-memory database,
    /// and the result has the tables the store reads.
    #[test]
    fn every_migration_applies_to_an_empty_database() {
        let mut conn = Connection::open_in_memory().unwrap();
        migrate(&mut conn, Path::new(":memory:")).unwrap();
        let v: i64 = conn
            .pragma_query_value(None, "user_version", |r| r.get(0))
            .unwrap();
        assert_eq!(v, current_version());
        for table in [
            "sessions",
            "readings",
            "link_state",
            "marks",
            "estimates",
            "outbox",
            "sync_state",
        ] {
            let n: i64 = conn
                .query_row(
                    "SELECT COUNT(*) FROM sqlite_schema WHERE type = 'table' AND name = ?1",
                    [table],
                    |r| r.get(0),
                )
                .unwrap();
            assert_eq!(n, 1, "no table {table}");
        }
        let fk: bool = conn
            .pragma_query_value(None, "foreign_keys", |r| r.get(0))
            .unwrap();
        assert!(fk, "foreign keys are back on after migrating");
        // Migrating again does nothing.
        migrate(&mut conn, Path::new(":memory:")).unwrap();
    }

    /// The list in the code is exactly the files in the folder, in order,
    /// numbered 1, 2, 3, ... without gaps.
    #[test]
    fn the_list_matches_the_migrations_folder() {
        let mut files: Vec<String> = std::fs::read_dir(dir())
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .filter(|n| n.ends_with(".sql"))
            .collect();
        files.sort();
        let listed: Vec<&str> = MIGRATIONS.iter().map(|m| m.file).collect();
        assert_eq!(
            files, listed,
            "every migrations/*.sql must be listed in MIGRATIONS, in order"
        );
        for (i, f) in listed.iter().enumerate() {
            let n: usize = f[..4].parse().unwrap();
            assert_eq!(n, i + 1, "{f}: migrations are numbered 0001, 0002, ...");
            assert_eq!(&f[4..5], "_", "{f}: name them NNNN_what.sql");
        }
    }

    /// A released migration never changes: each file's SHA-256 must match
    /// its line in `migrations/released.sha256` (sha256sum's format).
    #[test]
    fn released_migrations_never_change() {
        let list = std::fs::read_to_string(dir().join("released.sha256")).unwrap();
        let released: Vec<(&str, &str)> = list
            .lines()
            .filter(|l| !l.trim().is_empty() && !l.starts_with('#'))
            .map(|l| {
                let (sum, file) = l.split_once("  ").expect("`<sha256>  <file>` lines");
                (file.trim(), sum.trim())
            })
            .collect();
        for m in MIGRATIONS {
            let got = hex(&sha2::Sha256::digest(m.sql.as_bytes()));
            match released.iter().find(|(f, _)| *f == m.file) {
                Some((_, want)) => assert_eq!(
                    &got, want,
                    "migration {} was edited after its release (SHA-256 now {got}, released {want}): \
                     a released migration must never change, or stores migrated by the released \
                     program and by this one differ under one version number. Revert the edit and \
                     add a new migration NNNN_what.sql instead.",
                    m.file
                ),
                None => panic!(
                    "migration {} has no checksum in migrations/released.sha256: add its line \
                     (`sha256sum {} >> released.sha256` in host/station/migrations)",
                    m.file, m.file
                ),
            }
        }
        assert_eq!(
            released.len(),
            MIGRATIONS.len(),
            "released.sha256 lists a migration that is gone: a released migration is never removed"
        );
    }

    fn hex(bytes: &[u8]) -> String {
        bytes.iter().map(|b| format!("{b:02x}")).collect()
    }
}
