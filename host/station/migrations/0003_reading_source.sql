-- 3: a reading says where it came from: the tape's queue ('tape', with
-- the device, boot and sequence number it was sent under) or the keyboard
-- ('keyboard': the operator pressed Enter to store the tape's live value,
-- which never went through the tape's numbered queue; no device fields).
--
-- Until now a keyboard reading was stored under a made-up device 0, boot 0
-- and a sequence of its own; those rows become 'keyboard' readings and the
-- made-up device's bookkeeping row goes. SQLite cannot relax NOT NULL in
-- place, so the table is rebuilt (the migration runner turns foreign keys
-- off around migrations and checks them before committing).
CREATE TABLE readings_v3 (
    id              INTEGER PRIMARY KEY,
    session_id      INTEGER NOT NULL REFERENCES sessions (id) ON DELETE CASCADE,
    measurement     TEXT    NOT NULL,
    value_tenth_mm  INTEGER NOT NULL,
    source          TEXT    NOT NULL CHECK (source IN ('tape', 'keyboard')),
    device_id       INTEGER,
    boot_id         INTEGER,
    seq             INTEGER,
    device_time_ms  INTEGER,
    received_at_ms  INTEGER NOT NULL,
    superseded_by   INTEGER REFERENCES readings (id) ON DELETE SET NULL,
    withdrawn_at_ms INTEGER,
    -- A tape reading has all four device fields, a keyboard reading none.
    CHECK (
        (source = 'tape' AND device_id IS NOT NULL AND boot_id IS NOT NULL
            AND seq IS NOT NULL AND device_time_ms IS NOT NULL)
        OR (source = 'keyboard' AND device_id IS NULL AND boot_id IS NULL
            AND seq IS NULL AND device_time_ms IS NULL)
    ),
    UNIQUE (device_id, boot_id, seq)
);

INSERT INTO readings_v3 (id, session_id, measurement, value_tenth_mm, source, device_id,
                         boot_id, seq, device_time_ms, received_at_ms, superseded_by,
                         withdrawn_at_ms)
SELECT id, session_id, measurement, value_tenth_mm,
       CASE WHEN device_id = 0 THEN 'keyboard' ELSE 'tape' END,
       CASE WHEN device_id = 0 THEN NULL ELSE device_id END,
       CASE WHEN device_id = 0 THEN NULL ELSE boot_id END,
       CASE WHEN device_id = 0 THEN NULL ELSE seq END,
       CASE WHEN device_id = 0 THEN NULL ELSE device_time_ms END,
       received_at_ms, superseded_by, withdrawn_at_ms
FROM readings;

DROP TABLE readings;
ALTER TABLE readings_v3 RENAME TO readings;
CREATE INDEX readings_session ON readings (session_id, measurement);

DELETE FROM link_state WHERE device_id = 0;
