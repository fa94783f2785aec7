-- granulard job store, version 1: jobs, their launch attempts, progress series and the event log.
-- Applied by daemon/db.c inside one BEGIN IMMEDIATE transaction together with PRAGMA user_version=1.
-- Times are unix seconds (REAL, UTC). The jobs row is the only truth about a job.

CREATE TABLE jobs (
  id            INTEGER PRIMARY KEY AUTOINCREMENT, -- monotonic, never reused (even after DELETE)
  submission_id TEXT UNIQUE,                    -- client-chosen idempotency key (NULL = none)
  scene         TEXT NOT NULL,                  -- the scene JSON as submitted (validated)
  scene_hash    TEXT NOT NULL,                  -- FNV-1a 64 of scene, to tell retries from clashes
  method        TEXT NOT NULL,
  particles     INTEGER NOT NULL,
  priority      INTEGER NOT NULL DEFAULT 0,     -- higher runs first
  ranks         INTEGER NOT NULL DEFAULT 1 CHECK (ranks >= 1),
  state         TEXT NOT NULL DEFAULT 'queued'
                CHECK (state IN ('queued','running','succeeded','failed','cancelled')),
  cancel_requested INTEGER NOT NULL DEFAULT 0,
  reason        TEXT,                           -- why the job is in its state (failed, cancelled, requeued)
  created_at    REAL NOT NULL,
  updated_at    REAL NOT NULL,
  started_at    REAL,                           -- first launch
  finished_at   REAL,
  progress      REAL NOT NULL DEFAULT 0,        -- fraction of the stop condition reached, 0..1
  sim_time      REAL,                           -- latest simulated time reported
  events        INTEGER,                        -- latest event count reported
  collisions    INTEGER,
  progress_seq  INTEGER NOT NULL DEFAULT 0,     -- records received over all attempts
  progress_stride INTEGER NOT NULL DEFAULT 1    -- downsampling stride of the stored series
) STRICT;
CREATE INDEX jobs_queue ON jobs(state, priority DESC, id);
CREATE INDEX jobs_finished ON jobs(finished_at) WHERE finished_at IS NOT NULL;

CREATE TABLE attempts (
  job_id      INTEGER NOT NULL REFERENCES jobs(id) ON DELETE CASCADE,
  n           INTEGER NOT NULL,                 -- 1, 2, ... per job
  pid         INTEGER,                          -- launcher (mpirun) pid, leader of its process group
  pid_start   INTEGER,                          -- /proc/PID/stat starttime: defeats pid reuse
  started_at  REAL NOT NULL,
  ended_at    REAL,
  exit_status INTEGER,                          -- exit code, or NULL when killed by a signal
  signal      INTEGER,
  reason      TEXT,
  stderr_tail TEXT,
  checkpoint  TEXT,                             -- checkpoint the attempt resumed from (NULL = fresh start)
  PRIMARY KEY (job_id, n)
) STRICT;

CREATE TABLE progress (
  job_id  INTEGER NOT NULL REFERENCES jobs(id) ON DELETE CASCADE,
  seq     INTEGER NOT NULL,                     -- record number within the job (all attempts)
  attempt INTEGER NOT NULL,
  time    REAL,                                 -- simulated time of the record
  record  TEXT NOT NULL,                        -- the engine's JSON line, verbatim
  PRIMARY KEY (job_id, seq)
) STRICT, WITHOUT ROWID;
