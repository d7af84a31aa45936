-- 4: the estimate of a session, kept so that after a restart the result
-- can be shown and exported again without estimating again. One row per
-- session: the latest estimate (a new one replaces it).
--
-- vertices: the body's vertices in the template's vertex order, each as
--   three little-endian IEEE 754 binary64 numbers x, y, z (24 bytes a
--   vertex), metres, station frame (Z up, +Y the body's front, +X the
--   body's right, feet at z = 0). Exact: an export after a restart writes
--   the same mesh as one before it.
-- template_sha256: SHA-256 (hex) of the template topology the vertices
--   belong to (its triangles); an export rebuilds the mesh only on the
--   same template.
-- model_source: the model that made it (as its report names it).
-- readings_json: the readings it was made from, [[name, tenths of a mm], ...],
--   to tell whether the session's readings changed since.
-- report_json: the station's estimate report without its per-export
--   fields (the export writes it with the session, the time and the files).
CREATE TABLE estimates (
    session_id      INTEGER PRIMARY KEY REFERENCES sessions (id) ON DELETE CASCADE,
    made_at_ms      INTEGER NOT NULL,
    seconds         REAL    NOT NULL,
    model_source    TEXT    NOT NULL,
    template_sha256 TEXT    NOT NULL,
    n_vertices      INTEGER NOT NULL CHECK (n_vertices > 0),
    vertices        BLOB    NOT NULL CHECK (length(vertices) = 24 * n_vertices),
    readings_json   TEXT    NOT NULL,
    report_json     TEXT    NOT NULL
);
