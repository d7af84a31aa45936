-- 1: the chain's stations, their sessions (readings, marks, estimates),
-- erasures and head-office users. docs/hub.md describes every table.
--
-- Keys: a session is (station, session), a reading (station, reading), with
-- the station's own row ids: the hub never renumbers, so an event applied
-- twice finds its row and changes nothing.

CREATE TABLE stations (
    name          TEXT PRIMARY KEY,
    -- SHA-256 (hex) of the station's token (256 random bits): the token
    -- itself is shown once, by `tapeshape hub add-station`.
    token_sha256  TEXT NOT NULL UNIQUE,
    created_at    TIMESTAMPTZ NOT NULL DEFAULT now(),
    revoked_at    TIMESTAMPTZ,
    -- The station's events 1 ..= last_seq are applied.
    last_seq      BIGINT NOT NULL DEFAULT 0 CHECK (last_seq >= 0),
    last_sync_at  TIMESTAMPTZ
);

CREATE TABLE sessions (
    station        TEXT   NOT NULL REFERENCES stations (name),
    session        BIGINT NOT NULL,
    customer       TEXT   NOT NULL,
    customer_hash  TEXT   NOT NULL,
    set_name       TEXT,
    notes          TEXT,
    consent        TEXT CHECK (consent IN ('keep', 'visit')),
    status         TEXT   NOT NULL CHECK (status IN ('open', 'done', 'abandoned')),
    created_at_ms  BIGINT NOT NULL,
    updated_at_ms  BIGINT NOT NULL,
    hub_received_at TIMESTAMPTZ NOT NULL DEFAULT now(),
    PRIMARY KEY (station, session)
);
CREATE INDEX sessions_customer ON sessions (customer_hash);
CREATE INDEX sessions_created ON sessions (created_at_ms);

CREATE TABLE readings (
    station         TEXT   NOT NULL,
    reading         BIGINT NOT NULL,
    session         BIGINT NOT NULL,
    measurement     TEXT   NOT NULL,
    value_tenth_mm  BIGINT NOT NULL CHECK (value_tenth_mm >= 0),
    source          TEXT   NOT NULL CHECK (source IN ('tape', 'keyboard')),
    -- The tape's 64-bit id as the same 64 bits in a signed BIGINT.
    device_id       BIGINT,
    boot_id         BIGINT,
    device_seq      BIGINT,
    device_time_ms  BIGINT,
    received_at_ms  BIGINT NOT NULL,
    superseded_by   BIGINT,
    withdrawn       BOOLEAN NOT NULL DEFAULT false,
    committed_at    TIMESTAMPTZ NOT NULL DEFAULT now(),
    PRIMARY KEY (station, reading),
    FOREIGN KEY (station, session) REFERENCES sessions (station, session) ON DELETE CASCADE
);
CREATE INDEX readings_session ON readings (station, session);

CREATE TABLE marks (
    station      TEXT   NOT NULL,
    session      BIGINT NOT NULL,
    measurement  TEXT   NOT NULL,
    mark         TEXT   NOT NULL CHECK (mark IN ('skipped', 'kept_flagged')),
    PRIMARY KEY (station, session, measurement),
    FOREIGN KEY (station, session) REFERENCES sessions (station, session) ON DELETE CASCADE
);

CREATE TABLE estimates (
    station        TEXT   NOT NULL,
    session        BIGINT NOT NULL,
    made_at_ms     BIGINT NOT NULL,
    model_source   TEXT   NOT NULL,
    readings_json  TEXT   NOT NULL,
    report_json    TEXT   NOT NULL,
    -- The body, binary glTF (Y up, metres); NULL when the station sent none.
    glb            BYTEA,
    PRIMARY KEY (station, session),
    FOREIGN KEY (station, session) REFERENCES sessions (station, session) ON DELETE CASCADE
);

-- What the hub keeps of an erased customer: the hash of their id and when.
CREATE TABLE erasures (
    id             BIGSERIAL PRIMARY KEY,
    customer_hash  TEXT   NOT NULL,
    erased_at_ms   BIGINT NOT NULL,
    -- Who asked: a station's name, or 'hub' (`tapeshape hub customer erase`).
    origin         TEXT   NOT NULL
);
CREATE INDEX erasures_customer ON erasures (customer_hash);

-- An erasure a station still has to carry out (done_at NULL) or has.
CREATE TABLE erasure_notices (
    erasure  BIGINT NOT NULL REFERENCES erasures (id),
    station  TEXT   NOT NULL REFERENCES stations (name),
    done_at  TIMESTAMPTZ,
    PRIMARY KEY (erasure, station)
);
CREATE INDEX erasure_notices_pending ON erasure_notices (station) WHERE done_at IS NULL;

-- Head-office users of the pages (HTTP basic authentication).
CREATE TABLE users (
    name             TEXT PRIMARY KEY,
    -- argon2id PHC string (salted, slow: a person chose or keeps the password).
    password_argon2  TEXT NOT NULL,
    created_at       TIMESTAMPTZ NOT NULL DEFAULT now()
);
