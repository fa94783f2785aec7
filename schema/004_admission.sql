-- granulard job store, version 4: admission control (docs/daemon.md, "Admission").
-- Applied by daemon/db.c to a version-3 database in place (one transaction with PRAGMA user_version=4).
-- memory_bytes, output_bytes: the estimates made at submission (engine/budget.h) for the job's scene and ranks;
-- a job starts only while its memory estimate and those of the running jobs fit the server's memory_budget.
-- Jobs of older versions get memory_bytes when the daemon opens the database (queued and running jobs).
-- max_output: bytes the job's directory may hold (the submission's max_output_bytes); NULL: the server's
-- max_job_output.
ALTER TABLE jobs ADD COLUMN memory_bytes INTEGER;
ALTER TABLE jobs ADD COLUMN output_bytes INTEGER;
ALTER TABLE jobs ADD COLUMN max_output INTEGER;
