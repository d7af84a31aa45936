-- 1: sessions, readings, per-device sequence bookkeeping.
CREATE TABLE sessions (
    id              INTEGER PRIMARY KEY,
    customer_id     TEXT    NOT NULL,
    created_at_ms   INTEGER NOT NULL,
    updated_at_ms   INTEGER NOT NULL,
    status          TEXT    NOT NULL CHECK (status IN ('open', 'done', 'abandoned')),
    measurement_set TEXT,
    notes           TEXT
);
CREATE INDEX sessions_status_updated ON sessions (status, updated_at_ms);

CREATE TABLE readings (
    id              INTEGER PRIMARY KEY,
    session_id      INTEGER NOT NULL REFERENCES sessions (id) ON DELETE CASCADE,
    measurement     TEXT    NOT NULL,
    value_tenth_mm  INTEGER NOT NULL,
    device_id       INTEGER NOT NULL,
    boot_id         INTEGER NOT NULL,
    seq             INTEGER NOT NULL,
    device_time_ms  INTEGER NOT NULL,
    received_at_ms  INTEGER NOT NULL,
    superseded_by   INTEGER REFERENCES readings (id) ON DELETE SET NULL,
    UNIQUE (device_id, boot_id, seq)
);
CREATE INDEX readings_session ON readings (session_id, measurement);

CREATE TABLE link_state (
    device_id          INTEGER NOT NULL,
    boot_id            INTEGER NOT NULL,
    last_committed_seq INTEGER NOT NULL,
    updated_at_ms      INTEGER NOT NULL,
    PRIMARY KEY (device_id, boot_id)
);
