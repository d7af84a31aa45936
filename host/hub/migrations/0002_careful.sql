-- Careful mode (station migration 0006): the session took each measurement
-- twice (a third time when the two differed by more than its allowable
-- error) and kept the median, so its superseded readings are repeats, not
-- retakes. Sessions from before it, and from stations that do not send it,
-- are taken once.
ALTER TABLE sessions ADD COLUMN careful BOOLEAN NOT NULL DEFAULT false;
