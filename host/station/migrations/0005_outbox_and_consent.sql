-- 5: a chain of stores (docs/hub.md). Every change to a session is also an
-- event in the outbox, written in the same transaction as the change, and
-- pushed to the head-office hub by the sync task when the station has one;
-- the customer's consent, asked on the new-customer screen; the station's
-- sync bookkeeping.
--
-- consent: 'keep' (keep my data) or 'visit' (this visit only); NULL: not
--   asked (sessions from before, or from the line-mode station).
ALTER TABLE sessions ADD COLUMN consent TEXT CHECK (consent IN ('keep', 'visit'));

-- seq: the station's event sequence, 1, 2, 3, ... without gaps
--   (AUTOINCREMENT: a number is never handed out twice; a rolled-back
--   change takes none).
-- session_id: the session the event concerns (NULL: a customer's
--   erasure), so that erasing a session redacts its earlier events.
-- kind, body: the event (tapeshape-hub-api's EventBody as JSON; kind is
--   its "kind"). A redacted event keeps its seq with kind 'redacted'.
-- committed_at_ms: when the hub answered that it had committed it.
CREATE TABLE outbox (
    seq             INTEGER PRIMARY KEY AUTOINCREMENT,
    session_id      INTEGER,
    at_ms           INTEGER NOT NULL,
    kind            TEXT    NOT NULL,
    body            TEXT    NOT NULL,
    committed_at_ms INTEGER
);
CREATE INDEX outbox_session ON outbox (session_id);

-- One row. station: the station's name at the hub, bound by the first
-- start with a token (a store belongs to one station); hub_committed_seq:
-- the hub holds events 1 ..= this.
CREATE TABLE sync_state (
    id                INTEGER PRIMARY KEY CHECK (id = 1),
    station           TEXT,
    hub_committed_seq INTEGER NOT NULL DEFAULT 0
);
INSERT INTO sync_state (id) VALUES (1);
