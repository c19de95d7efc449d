-- palplab results store, schema version 4 (docs/FORMATS.md; version 1 lacked the study
-- structure tables study_groups, phases and thresholds; version 2 lacked the session columns
-- attempt, status, trainee, device, started_at and abort_reason of human sessions; version 3
-- lacked the transparency columns of phases and sessions).
-- One database holds one run of one study. Units: s, N, m. Times of day are UTC ISO 8601.
-- results/schema.cpp embeds this file verbatim (a test checks that they are identical).
PRAGMA user_version = 4;

CREATE TABLE meta (
  key   TEXT PRIMARY KEY,
  value TEXT NOT NULL
);

-- The study as run: its exact JSON text and SHA-256, the software and the seed.
CREATE TABLE study (
  id              INTEGER PRIMARY KEY CHECK (id = 1),
  study_id        TEXT NOT NULL,
  title           TEXT NOT NULL,
  json            TEXT NOT NULL,
  sha256          TEXT NOT NULL,
  palplab_version TEXT NOT NULL,
  git_commit      TEXT NOT NULL,
  seed            TEXT NOT NULL,          -- unsigned 64-bit, decimal
  started_at      TEXT NOT NULL,
  finished_at     TEXT                    -- NULL while the run is incomplete
);

-- Every prototype file a session used, as it was when the run started.
CREATE TABLE prototypes (
  prototype TEXT PRIMARY KEY,
  path      TEXT NOT NULL,
  sha256    TEXT NOT NULL,
  json      TEXT NOT NULL
);

-- The study's structure as run (from the validated study, so the report need not re-parse it):
-- groups and phases in declaration order, each phase's kind and cue switches as the study
-- declares them, and the force thresholds that applied in each phase.
CREATE TABLE study_groups (
  grp       TEXT PRIMARY KEY,
  position  INTEGER NOT NULL,             -- 0-based declaration order
  prototype TEXT NOT NULL                 -- default prototype id
);

CREATE TABLE phases (
  phase              TEXT PRIMARY KEY,
  position           INTEGER NOT NULL,    -- 0-based declaration order
  kind               TEXT NOT NULL,       -- pre_training | training | post_training | other
  sessions           INTEGER NOT NULL,
  session_duration   REAL NOT NULL,       -- s
  haptic             INTEGER,             -- cue switches: 1 on, 0 off, NULL as the prototype says
  visual_deformation INTEGER,
  audio              INTEGER,
  instructed         INTEGER NOT NULL,    -- 1 when an instructor guides the phase
  feature            TEXT NOT NULL,       -- region to find (task.feature)
  transparency       INTEGER              -- needle scenes' see-through soft tissue switch (v4)
);

-- Force thresholds (N) per phase and region; region '*' applies to every other region.
CREATE TABLE thresholds (
  phase  TEXT NOT NULL REFERENCES phases (phase),
  region TEXT NOT NULL,
  st     REAL NOT NULL,                   -- sound threshold
  mpf    REAL NOT NULL,                   -- maximum palpation force (the target)
  sft    REAL NOT NULL,                   -- stopping force threshold
  PRIMARY KEY (phase, region)
);

CREATE TABLE participants (
  participant TEXT PRIMARY KEY,
  grp         TEXT NOT NULL,              -- group id
  number      INTEGER NOT NULL,           -- 0-based position in the plan
  seed        TEXT NOT NULL               -- derived seed, unsigned 64-bit decimal
);

-- One row per session attempt. A virtual session is written in one transaction with its
-- measures, events and samples (status 'complete'). A human session (`run --human`) is written
-- as it goes: the row first (status 'running'), samples and events every second, then the
-- measures and status 'complete' -- or 'aborted' (window closed, Ctrl-C, device lost; a
-- 'running' row left by a killed process becomes 'aborted' at the next run). Aborted attempts
-- are kept with their data; the participant's next run repeats the session as attempt + 1.
-- Analyses read the 'complete' rows only.
CREATE TABLE sessions (
  session       INTEGER PRIMARY KEY,
  participant   TEXT NOT NULL REFERENCES participants (participant),
  ordinal       INTEGER NOT NULL,         -- 0-based position in the participant's timeline
  phase         TEXT NOT NULL,
  phase_index   INTEGER NOT NULL,         -- 0-based session number within the phase
  prototype     TEXT NOT NULL,
  instructor    TEXT,                     -- NULL when not instructed
  study_offset  REAL NOT NULL,            -- s from the participant's first session start
  day           INTEGER NOT NULL,         -- calendar day of the session (0 = first day)
  duration      REAL NOT NULL,            -- s of simulated time
  steps         INTEGER NOT NULL,         -- haptic steps simulated
  wall_duration REAL NOT NULL,            -- s of wall-clock time to simulate it
  loop_median   REAL NOT NULL,            -- s, median wall time of one haptic step
  loop_p99      REAL NOT NULL,            -- s, 99th percentile of the same
  seed          TEXT NOT NULL,            -- derived session seed, unsigned 64-bit decimal
  state_after   TEXT NOT NULL,            -- participant model state after the session (JSON)
  completed_at  TEXT NOT NULL,           -- '' while running or when aborted
  attempt       INTEGER NOT NULL DEFAULT 0,           -- 0-based try of this ordinal
  status        TEXT NOT NULL DEFAULT 'complete',     -- complete | running | aborted
  trainee       TEXT NOT NULL DEFAULT 'virtual',      -- virtual | human
  device        TEXT,                     -- human sessions: "udp:5005", "mouse", "trace:FILE"
  started_at    TEXT,                     -- human sessions: UTC wall-clock start
  abort_reason  TEXT,                     -- aborted sessions: why
  transparency  INTEGER,                  -- transparency cue as run: 1 on, 0 off, NULL before v4
  UNIQUE (participant, ordinal, attempt)
);

CREATE TABLE measures (
  session INTEGER NOT NULL REFERENCES sessions (session),
  name    TEXT NOT NULL,                  -- palpation_force | exploration_time | feature_identified | accuracy | ...
  value   REAL,                           -- NULL when undefined (e.g. force when nothing was identified)
  unit    TEXT NOT NULL,
  PRIMARY KEY (session, name)
);

CREATE TABLE events (
  session INTEGER NOT NULL REFERENCES sessions (session),
  t       REAL NOT NULL,                  -- s from the session start
  kind    TEXT NOT NULL,
  value   REAL NOT NULL,
  region  TEXT                            -- anatomical region, NULL when none
);
CREATE INDEX events_by_session ON events (session, t);

-- Device samples, one row per started second of a session. `data` holds `n` samples taken every
-- `dt` s from `t0`, encoded as described in docs/FORMATS.md (quantised, delta, zigzag
-- varints: x, y, z in um; Fx, Fy, Fz in 0.1 mN; contact node + 1).
CREATE TABLE samples (
  session  INTEGER NOT NULL REFERENCES sessions (session),
  second   INTEGER NOT NULL,
  t0       REAL NOT NULL,
  dt       REAL NOT NULL,
  n        INTEGER NOT NULL,
  encoding TEXT NOT NULL,                 -- 'qdv1'
  data     BLOB NOT NULL,
  PRIMARY KEY (session, second)
);
