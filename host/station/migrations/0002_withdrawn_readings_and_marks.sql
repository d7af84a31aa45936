-- 2: the operator's marks survive a restart: a reading withdrawn by undo
-- (kept in the history, no longer current) and per-measurement marks
-- (skipped, a flagged reading kept on purpose).
ALTER TABLE readings ADD COLUMN withdrawn_at_ms INTEGER;
CREATE TABLE marks (
    session_id  INTEGER NOT NULL REFERENCES sessions (id) ON DELETE CASCADE,
    measurement TEXT    NOT NULL,
    mark        TEXT    NOT NULL CHECK (mark IN ('skipped', 'kept-flagged')),
    at_ms       INTEGER NOT NULL,
    PRIMARY KEY (session_id, measurement)
);
