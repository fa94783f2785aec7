/* The durable job queue: jobs, attempts and progress series in SQLite; pure logic, no sockets, no processes. */
#pragma once

#include <stddef.h>
#include <stdint.h>
#include <jansson.h>

/*
 * Contract
 * - The SQLite row is the only truth about a job. Every change is one
 *   BEGIN IMMEDIATE transaction; a call either happens completely or not at
 *   all (on error nothing changed).
 * - Thread-safe: one connection behind a mutex (the write rate is tiny; reads
 *   are index lookups).
 * - Calls that produce JSON return a new reference in *out (caller
 *   json_decref()s it); on error *out is NULL and err holds one line.
 * - Times are unix seconds (double) passed in by the caller, so tests
 *   control the clock.
 * - States: queued -> running -> {succeeded, failed, cancelled}; running ->
 *   queued when an attempt is interrupted by the daemon (restart, drain);
 *   queued -> cancelled.
 */

typedef struct jobq jobq_t;

enum {
	JOBQ_OK = 0,
	JOBQ_EINVAL = -1,    /* bad request body (err names the field) */
	JOBQ_ENOTFOUND = -2, /* no such job */
	JOBQ_ECONFLICT = -3, /* state does not allow it, or submission_id reused with another scene */
	JOBQ_ELIMIT = -4,    /* queue full (max_queued) */
	JOBQ_EDB = -5,       /* SQLite failed (disk full, I/O): the request did not happen */
	JOBQ_ENOMEM = -6,
	JOBQ_EEMPTY = -7,    /* jobq_claim: nothing can start now */
	JOBQ_EFULL = -8,     /* the disk holding the database is full */
};

typedef enum { JOB_QUEUED = 0, JOB_RUNNING, JOB_SUCCEEDED, JOB_FAILED, JOB_CANCELLED, JOB_NSTATES } job_state_t;

typedef struct {
	uint64_t max_particles;  /* per-job limit on particles.count */
	int max_ranks;           /* per-job limit on ranks */
	int max_queued;          /* jobs in state queued; more gives JOBQ_ELIMIT */
	int max_json_depth;      /* nesting limit of the request body */
	int max_progress;        /* stored progress records per job before downsampling */
	/* Admission (docs/daemon.md): 0 = no limit. */
	uint64_t memory_budget;  /* bytes the memory estimates of running jobs may add up to */
	uint64_t max_replicas;   /* per-job limit on run.replicas */
	uint64_t max_output;     /* bytes a job's directory may hold; a job may ask for less */
} jobq_limits_t;

/* Open the queue on a database file (":memory:" for tests). NULL on error (err). */
jobq_t *jobq_open(const char *path, const jobq_limits_t *lim, char *err, size_t errlen);
void jobq_close(jobq_t *q);

const char *jobq_strerror(int code);
const char *job_state_name(job_state_t s);
/* -1 when name is not a state. */
int job_state_parse(const char *name);

/* Submit: body is the scene JSON itself or {"scene": {...}, "priority": p,
 * "ranks": r, "submission_id": "...", "max_output_bytes": b, "slurm": {"nodes":
 * n <= r, "time_limit": seconds, "partition": name}} (the Slurm options are
 * stored and shown as "slurm"; only launcher = slurm uses them). The scene is
 * validated by the engine's own parser, which makes the engine's start
 * checks too (scene.h), and admitted by its budget (engine/budget.h) on the
 * job's ranks: JOBQ_EINVAL naming the key and the estimate when its memory
 * exceeds memory_budget (it could never start) or its output the job's
 * limit (max_output_bytes, at most the limits' max_output), or when
 * run.replicas exceeds max_replicas. A repeated submission_id with the same
 * scene returns the existing job with *created = 0; with another scene
 * JOBQ_ECONFLICT. The job keeps its estimates: "resources" {memory_bytes,
 * output_bytes, max_output_bytes}. */
int jobq_submit(jobq_t *q, const char *body, size_t len, double now, json_t **out, int *created, char *err,
                size_t errlen);

/* Submission of a "method": "auto" scene: the method is chosen with the
 * built-in advice model (advice.h) at submission; the job then holds the
 * concrete scene ("method" set, "accuracy" dropped), the chosen method, and
 * the decision in "advice" (null for other jobs). */

/* Advice without submitting: body as for jobq_submit() (ranks count for the
 * wall time; priority and submission_id are ignored); *out = the estimates
 * (advice_json()). Same validation and limits as a submission. */
int jobq_advice(jobq_t *q, const char *body, size_t len, json_t **out, char *err, size_t errlen);

/* Validation without submitting: exactly the checks of jobq_submit() (the
 * method of an "auto" scene chosen as a submission would), nothing stored.
 * *out = {"valid": true, "method": m, "resources": {...}} with the budget
 * (docs/daemon.md); errors as jobq_submit(). */
int jobq_validate(jobq_t *q, const char *body, size_t len, json_t **out, char *err, size_t errlen);

/* One job (with its attempts; with the scene when with_scene). */
int jobq_get(jobq_t *q, int64_t id, int with_scene, json_t **out, char *err, size_t errlen);

typedef struct {
	unsigned states;   /* bit set of 1u << job_state_t; 0 = all */
	double since;      /* updated at or after (unix s); 0 = no filter */
	int limit;         /* 1..1000 */
	int64_t cursor;    /* return jobs with id < cursor; 0 = from the newest */
} jobq_filter_t;

/* {"jobs": [...], "next_cursor": id|null}: newest first. */
int jobq_list(jobq_t *q, const jobq_filter_t *f, json_t **out, char *err, size_t errlen);

/* Cancel: a queued job becomes cancelled at once (*signal = 0); a running
 * one gets cancel_requested and *signal = 1 (the supervisor stops it and
 * records the end). Cancelling a cancelled job is a no-op; a succeeded or
 * failed one is JOBQ_ECONFLICT. *out is the job after the change. */
int jobq_cancel(jobq_t *q, int64_t id, double now, int *signal, json_t **out, char *err, size_t errlen);

/* Delete a finished job and its rows (not its files: the caller removes them). */
int jobq_delete(jobq_t *q, int64_t id, char *err, size_t errlen);

/* The stored progress records (engine JSON lines, parsed) with seq > after,
 * at most limit: {"job": id, "stride": s, "records": [...]}. clusters_only
 * keeps the records that carry cluster statistics. */
int jobq_progress(jobq_t *q, int64_t id, int64_t after, int limit, int clusters_only, json_t **out, char *err,
                  size_t errlen);

/* Counts by state, jobs finished in the hour before now, running jobs with ranks. */
int jobq_stats(jobq_t *q, double now, json_t **out, char *err, size_t errlen);

/* ---- supervisor side ---------------------------------------------------- */

typedef struct {
	int64_t id;
	int attempt;        /* number of the attempt just created */
	int ranks;
	char *scene;        /* malloc'd scene JSON; caller frees */
	char *slurm;        /* malloc'd "slurm" options of the submission (JSON), NULL = none; caller frees */
	double until;       /* stop condition value, with until_cpp telling its kind */
	int until_cpp;      /* 1: collisions per particle, 0: simulated time */
	uint64_t particles;
} jobq_claim_t;

/* Claim the next queued job (priority, then submission order) if its ranks
 * fit in free_slots and its memory estimate beside those of the running jobs
 * in memory_budget: it becomes running with a new attempt row. Strict order
 * (a big job at the head waits for slots or memory instead of being
 * overtaken forever). A head job whose estimate alone exceeds memory_budget
 * (the budget shrank since it was submitted) can never start: it fails with
 * a reason saying so and the next one is considered. JOBQ_EEMPTY when
 * nothing can start. */
int jobq_claim(jobq_t *q, int free_slots, double now, jobq_claim_t *out, char *err, size_t errlen);

/* Record the launch (pid of the process-group leader and its start time) and
 * the checkpoint the attempt resumes from (NULL = fresh). */
int jobq_attempt_launched(jobq_t *q, int64_t id, int attempt, int pid, uint64_t pid_start, const char *checkpoint);
/* launcher = slurm: record the Slurm job id of the attempt (sbatch's answer;
 * its Slurm state becomes "pending") and the checkpoint it resumes from. */
int jobq_attempt_slurm(jobq_t *q, int64_t id, int attempt, int64_t slurm_job, const char *checkpoint);
/* The attempt's Slurm state as granulard names it (docs/daemon.md, "Running on a cluster"). */
int jobq_attempt_slurm_state(jobq_t *q, int64_t id, int attempt, const char *state, double now);
/* The last stored progress record of an attempt (malloc'd line in *line):
 * where a restarted daemon resumes reading the attempt's output file.
 * JOBQ_ENOTFOUND when the attempt stored none. */
int jobq_last_record(jobq_t *q, int64_t id, int attempt, char **line);
/* The engine fell back to another checkpoint than the one it was launched
 * with (its stderr says so): record that file name (relative to the job
 * directory) as the attempt's checkpoint. */
int jobq_attempt_checkpoint(jobq_t *q, int64_t id, int attempt, const char *checkpoint);

/* Store one progress record: line is the engine's JSON line as received, r
 * the same record parsed (the caller has it already), frac the fraction of
 * the stop condition it reports (< 0: unknown). Downsampling: when a job
 * holds more than max_progress records, every other one is dropped and the
 * stride doubles; summary records are always kept. A retry's first progress
 * record (attempt > 1) drops the earlier attempts' progress records at or
 * after its time: the part the retry repeats from its checkpoint (or from
 * the start), so the stored series reads as one run. */
int jobq_attempt_progress(jobq_t *q, int64_t id, int attempt, const char *line, const json_t *r, double frac,
                          double now);

/* One record for jobq_attempt_progress_batch(). */
typedef struct {
	const char *line;   /* the engine's JSON line as received */
	const json_t *r;    /* the same record, parsed (an object) */
	double frac;        /* fraction of the stop condition it reports, < 0: unknown */
} jobq_record_t;

/* Store n records of one attempt in one transaction (one commit), in order,
 * as jobq_attempt_progress() stores one, and add the ingestion counters the
 * job shows in "progress_records": received (records the engine sent since
 * the previous batch, n of them offered here) and thinned (not offered: the
 * daemon held them back beyond its rate, docs/daemon.md). On a full disk
 * nothing is stored, the n records count as dropped and JOBQ_EFULL is
 * returned. n may be 0 (only the counters change). */
int jobq_attempt_progress_batch(jobq_t *q, int64_t id, int attempt, const jobq_record_t *recs, size_t n,
                                int64_t received, int64_t thinned, double now);

/* End an attempt. next is the job's new state: JOB_QUEUED requeues it (the
 * attempt was interrupted), others are final. exit_status < 0 = none. */
int jobq_attempt_finished(jobq_t *q, int64_t id, int attempt, double now, int exit_status, int signal,
                          const char *reason, const char *stderr_tail, job_state_t next);

/* Jobs the database says are running, for reconciliation at start-up. */
typedef struct {
	int64_t id;
	int attempt;
	int pid;
	uint64_t pid_start;
	int64_t slurm_job;  /* 0: not submitted to Slurm */
	int ranks;
	int resumed;        /* the attempt resumes from a checkpoint */
	double until;       /* as in jobq_claim_t */
	int until_cpp;
} jobq_running_t;
/* *out malloc'd (caller frees), *n entries. */
int jobq_list_running(jobq_t *q, jobq_running_t **out, size_t *n);

/* Disk-full protection. jobq_reserve() creates PATH holding `bytes` of
 * ballast. When a write fails because the disk is full, the queue deletes the
 * ballast and retries once, so ending attempts, cancelling and deleting jobs
 * still work; until jobq_reserve() succeeds again, new submissions get
 * JOBQ_EFULL and progress records are not stored. Call jobq_reserve()
 * periodically: it restores the ballast when the disk has room again.
 * Returns 0 when the ballast is in place. */
int jobq_reserve(jobq_t *q, const char *path, uint64_t bytes);
/* 1 while the ballast is spent (disk full), else 0. */
int jobq_low_space(jobq_t *q);

/* Bytes job id's directory may hold (its max_output_bytes, or the limits'
 * max_output; 0 = no limit) into *bytes. JOBQ_OK or JOBQ_ENOTFOUND/EDB. */
int jobq_output_limit(jobq_t *q, int64_t id, uint64_t *bytes);

/* Whether cancel was requested for a job (0/1), negative on error. */
int jobq_cancel_requested(jobq_t *q, int64_t id);

/* Attempts made so far (for retry limits); negative on error. */
int jobq_attempts(jobq_t *q, int64_t id);
