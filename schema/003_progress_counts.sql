-- granulard job store, version 3: what became of each job's progress records (docs/daemon.md, "Progress records").
-- Applied by daemon/db.c to a version-2 database in place (one transaction with PRAGMA user_version=3).
ALTER TABLE jobs ADD COLUMN progress_received INTEGER NOT NULL DEFAULT 0; -- JSON records the engine sent, all attempts
ALTER TABLE jobs ADD COLUMN progress_stored INTEGER NOT NULL DEFAULT 0;   -- records in the progress table now
ALTER TABLE jobs ADD COLUMN progress_thinned INTEGER NOT NULL DEFAULT 0;  -- never stored: beyond progress_rate
ALTER TABLE jobs ADD COLUMN progress_dropped INTEGER NOT NULL DEFAULT 0;  -- never stored: the disk was full
-- Jobs from before: every record received was offered (no thinning), progress_seq counted them.
UPDATE jobs SET progress_received = progress_seq,
                progress_stored = (SELECT count(*) FROM progress WHERE progress.job_id = jobs.id);
