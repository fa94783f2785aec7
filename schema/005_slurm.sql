-- granulard job store, version 5: the Slurm backend (docs/daemon.md, "Running on a cluster").
-- Applied by daemon/db.c to a version-4 database in place (one transaction with PRAGMA user_version=5).
-- slurm_job: the Slurm job id of an attempt submitted with sbatch (launcher = slurm); NULL for mpirun launches.
-- The id is written before granulard follows the job, so a restarted daemon finds the job again (none lost,
-- none run twice). slurm_state: the attempt's last Slurm state as granulard maps it (pending, running,
-- completing, completed, failed, timeout, node_fail, preempted, cancelled, ...), with Slurm's reason.
ALTER TABLE attempts ADD COLUMN slurm_job INTEGER;
ALTER TABLE attempts ADD COLUMN slurm_state TEXT;
-- jobs.slurm: the submission's "slurm" options as JSON ({"nodes", "time_limit", "partition"}, validated); NULL: none.
ALTER TABLE jobs ADD COLUMN slurm TEXT;
