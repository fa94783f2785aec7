-- granulard job store, version 2: the method decision of "method": "auto" jobs.
-- Applied by daemon/db.c to a version-1 database in place (one transaction with PRAGMA user_version=2).
-- advice: the advice JSON (estimates per method, choice and reason; docs/daemon.md) for jobs submitted with
-- "method": "auto", NULL otherwise. The job's scene and method are then the chosen, concrete ones.
ALTER TABLE jobs ADD COLUMN advice TEXT;
