-- 6: careful mode (ISO 20685-1): a session may take each measurement twice,
-- a third time when the two differ by more than the allowable error.
--
-- careful: 1 for a careful session, 0 for one reading per measurement
--   (every session from before). The readings themselves are ordinary
--   readings: each repeat supersedes the one before it, as a retake does,
--   and the rounds, the kept value (median) and the TEM are read off them
--   (host/station/src/session/careful.rs), never stored.
ALTER TABLE sessions ADD COLUMN careful INTEGER NOT NULL DEFAULT 0 CHECK (careful IN (0, 1));
