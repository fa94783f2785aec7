/* The durable job queue on SQLite: submission, listing, cancellation, claims, attempts, progress series. */
#include <errno.h>
#include <fcntl.h>
#include <inttypes.h>
#include <sys/stat.h>
#include <sys/statvfs.h>
#include <unistd.h>
#include <stdarg.h>
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "advice.h"
#include "budget.h"
#include "db.h"
#include "jobq.h"
#include "scene.h"

struct jobq {
	sqlite3 *db;
	pthread_mutex_t lock;
	jobq_limits_t lim;
	int64_t queued;     /* jobs in state queued: kept here so a submission need not count them */
	char *reserve;      /* ballast file, released when the disk fills */
	uint64_t reserve_bytes;
	int low_space;      /* ballast spent, or the disk ran full: no new jobs, no progress records */
	int have_reserve;   /* the ballast file is in place */
	pthread_mutex_t blk;    /* guards the submission batch below */
	pthread_cond_t bcond;
	struct sub *pending;    /* validated submissions waiting for the next transaction */
	int leader;             /* a thread is running batches */
	advice_model_t *model;  /* the built-in advice model: "method": "auto" and jobq_advice() */
};

static int space_short(jobq_t *q);
static int release_reserve(jobq_t *q);
static void backfill_estimates(jobq_t *q);

static const char *const state_names[JOB_NSTATES] = {
	[JOB_QUEUED] = "queued", [JOB_RUNNING] = "running", [JOB_SUCCEEDED] = "succeeded",
	[JOB_FAILED] = "failed", [JOB_CANCELLED] = "cancelled",
};

const char *job_state_name(job_state_t s) { return (unsigned)s < JOB_NSTATES ? state_names[s] : "?"; }

int job_state_parse(const char *name)
{
	for (int i = 0; i < JOB_NSTATES; i++)
		if (!strcmp(name, state_names[i]))
			return i;
	return -1;
}

const char *jobq_strerror(int code)
{
	switch (code) {
	case JOBQ_OK: return "ok";
	case JOBQ_EINVAL: return "invalid request";
	case JOBQ_ENOTFOUND: return "no such job";
	case JOBQ_ECONFLICT: return "conflict with the job's state";
	case JOBQ_ELIMIT: return "queue full";
	case JOBQ_EDB: return "database error";
	case JOBQ_ENOMEM: return "out of memory";
	case JOBQ_EEMPTY: return "nothing to start";
	case JOBQ_EFULL: return "disk full";
	default: return "unknown error";
	}
}

jobq_t *jobq_open(const char *path, const jobq_limits_t *lim, char *err, size_t errlen)
{
	jobq_t *q = calloc(1, sizeof(*q));
	if (!q) {
		snprintf(err, errlen, "out of memory");
		return NULL;
	}
	q->db = db_open(path, err, errlen);
	if (!q->db) {
		free(q);
		return NULL;
	}
	pthread_mutex_init(&q->lock, NULL);
	pthread_mutex_init(&q->blk, NULL);
	pthread_cond_init(&q->bcond, NULL);
	q->lim = *lim;
	{
		size_t n;
		const char *text = advice_model_builtin(&n);
		q->model = advice_model_create(text, n, err, errlen);
		if (!q->model) {
			jobq_close(q);
			return NULL;
		}
	}
	sqlite3_stmt *st = NULL;
	if (sqlite3_prepare_v2(q->db, "SELECT count(*) FROM jobs WHERE state='queued'", -1, &st, NULL) == SQLITE_OK &&
	    sqlite3_step(st) == SQLITE_ROW)
		q->queued = sqlite3_column_int64(st, 0);
	sqlite3_finalize(st);
	backfill_estimates(q);
	return q;
}

void jobq_close(jobq_t *q)
{
	if (!q)
		return;
	sqlite3_close_v2(q->db);
	pthread_mutex_destroy(&q->lock);
	pthread_mutex_destroy(&q->blk);
	pthread_cond_destroy(&q->bcond);
	advice_model_destroy(q->model);
	free(q->reserve);
	free(q);
}

/* ---- helpers --------------------------------------------------------------- */

#define DBERR(q, err, errlen) snprintf(err, errlen, "database: %s", sqlite3_errmsg((q)->db))

static int begin(jobq_t *q) { return sqlite3_exec(q->db, "BEGIN IMMEDIATE", NULL, NULL, NULL); }
static int commit(jobq_t *q) { return sqlite3_exec(q->db, "COMMIT", NULL, NULL, NULL); }
static void rollback(jobq_t *q) { sqlite3_exec(q->db, "ROLLBACK", NULL, NULL, NULL); }

/* A byte count for SQLite and JSON (signed 64 bits; saturated estimates stay saturated). */
static int64_t i64(uint64_t x) { return x > (uint64_t)INT64_MAX ? INT64_MAX : (int64_t)x; }

static uint64_t fnv1a(const char *s, size_t n)
{
	uint64_t h = 1469598103934665603ull;
	for (size_t i = 0; i < n; i++)
		h = (h ^ (unsigned char)s[i]) * 1099511628211ull;
	return h;
}

static int json_depth(const json_t *v)
{
	int d = 0;
	if (json_is_object(v)) {
		const char *k;
		json_t *c;
		json_object_foreach((json_t *)v, k, c) {
			int cd = json_depth(c);
			if (cd > d)
				d = cd;
		}
		return d + 1;
	}
	if (json_is_array(v)) {
		size_t i;
		json_t *c;
		json_array_foreach(v, i, c) {
			int cd = json_depth(c);
			if (cd > d)
				d = cd;
		}
		return d + 1;
	}
	return 0;
}

static json_t *col_json(sqlite3_stmt *st, int i)
{
	switch (sqlite3_column_type(st, i)) {
	case SQLITE_NULL: return json_null();
	case SQLITE_INTEGER: return json_integer(sqlite3_column_int64(st, i));
	case SQLITE_FLOAT: return json_real(sqlite3_column_double(st, i));
	default: return json_string((const char *)sqlite3_column_text(st, i));
	}
}

#define JOB_COLS "id, submission_id, state, priority, ranks, method, particles, reason, created_at, " \
	"updated_at, started_at, finished_at, progress, sim_time, events, collisions, cancel_requested, scene, advice, " \
	"progress_received, progress_stored, progress_thinned, progress_dropped, progress_stride, " \
	"memory_bytes, output_bytes, max_output, slurm"

/* Job object from a row selected with JOB_COLS. */
static json_t *job_from_row(sqlite3_stmt *st, int with_scene)
{
	static const char *const names[] = {"id", "submission_id", "state", "priority", "ranks", "method",
	                                    "particles", "reason", "created_at", "updated_at", "started_at",
	                                    "finished_at", "progress", "sim_time", "events", "collisions"};
	json_t *j = json_object();
	for (int i = 0; i < (int)(sizeof(names) / sizeof(names[0])); i++)
		json_object_set_new(j, names[i], col_json(st, i));
	json_object_set_new(j, "cancel_requested", json_boolean(sqlite3_column_int(st, 16)));
	/* "method": "auto" jobs: the decision (estimates, choice, reason); null otherwise. */
	json_t *adv = sqlite3_column_type(st, 18) == SQLITE_TEXT
	                      ? json_loads((const char *)sqlite3_column_text(st, 18), 0, NULL) : NULL;
	json_object_set_new(j, "advice", adv ? adv : json_null());
	/* Progress ingestion: what the engine sent and what became of it (docs/daemon.md, "Progress records"). */
	json_object_set_new(j, "progress_records",
	                    json_pack("{sI sI sI sI sI}", "received", (json_int_t)sqlite3_column_int64(st, 19),
	                              "stored", (json_int_t)sqlite3_column_int64(st, 20), "thinned",
	                              (json_int_t)sqlite3_column_int64(st, 21), "dropped",
	                              (json_int_t)sqlite3_column_int64(st, 22), "stride",
	                              (json_int_t)sqlite3_column_int64(st, 23)));
	/* Admission: the estimates made at submission and the output limit
	 * (null for jobs of older versions: the server's max_job_output). */
	json_object_set_new(j, "resources", json_pack("{s:o, s:o, s:o}", "memory_bytes", col_json(st, 24),
	                                              "output_bytes", col_json(st, 25), "max_output_bytes",
	                                              col_json(st, 26)));
	/* The submission's Slurm options (launcher = slurm), null when none. */
	json_t *so = sqlite3_column_type(st, 27) == SQLITE_TEXT
	                     ? json_loads((const char *)sqlite3_column_text(st, 27), 0, NULL) : NULL;
	json_object_set_new(j, "slurm", so ? so : json_null());
	if (with_scene) {
		json_t *sc = json_loads((const char *)sqlite3_column_text(st, 17), 0, NULL);
		json_object_set_new(j, "scene", sc ? sc : json_null());
	}
	return j;
}

static json_t *attempts_of(jobq_t *q, int64_t id)
{
	sqlite3_stmt *st = NULL;
	json_t *a = json_array();
	if (sqlite3_prepare_v2(q->db,
	                       "SELECT n, pid, started_at, ended_at, exit_status, signal, reason, checkpoint, "
	                       "stderr_tail, slurm_job, slurm_state FROM attempts WHERE job_id=? ORDER BY n", -1, &st,
	                       NULL) != SQLITE_OK)
		return a;
	sqlite3_bind_int64(st, 1, id);
	while (sqlite3_step(st) == SQLITE_ROW) {
		static const char *const names[] = {"n", "pid", "started_at", "ended_at", "exit_status", "signal",
		                                    "reason", "checkpoint", "stderr_tail", "slurm_job", "slurm_state"};
		json_t *o = json_object();
		for (int i = 0; i < 11; i++)
			json_object_set_new(o, names[i], col_json(st, i));
		json_array_append_new(a, o);
	}
	sqlite3_finalize(st);
	return a;
}

/* A split ed run's load (engine records with "ranks": one system over several MPI
 * ranks, docs/daemon.md): the fields of the job's newest stored record, with
 * its time; null when that record has none (not a split run, or no record
 * yet). One row read: the newest record of a split run always has them. */
static json_t *split_of(jobq_t *q, int64_t id)
{
	static const char *const keys[] = {"ranks", "rank_events", "rank_particles", "rollbacks", "syncs",
	                                   "sync_interval", "rebalances", "time"};
	sqlite3_stmt *st = NULL;
	json_t *out = NULL, *r = NULL;
	if (sqlite3_prepare_v2(q->db, "SELECT record FROM progress WHERE job_id=? ORDER BY seq DESC LIMIT 1", -1, &st,
	                       NULL) != SQLITE_OK)
		return json_null();
	sqlite3_bind_int64(st, 1, id);
	if (sqlite3_step(st) == SQLITE_ROW)
		r = json_loads((const char *)sqlite3_column_text(st, 0), 0, NULL);
	sqlite3_finalize(st);
	if (json_is_integer(json_object_get(r, "ranks"))) {
		out = json_object();
		for (size_t k = 0; k < sizeof keys / sizeof *keys; k++) {
			json_t *v = json_object_get(r, keys[k]);
			json_object_set(out, keys[k], v ? v : json_null());
		}
	}
	json_decref(r);
	return out ? out : json_null();
}

/* Job by id, locked by the caller. JOBQ_ENOTFOUND when absent. */
static int load_job(jobq_t *q, int64_t id, int with_scene, json_t **out)
{
	sqlite3_stmt *st = NULL;
	int ret = JOBQ_ENOTFOUND, rc;
	*out = NULL;
	if (sqlite3_prepare_v2(q->db, "SELECT " JOB_COLS " FROM jobs WHERE id=?", -1, &st, NULL) != SQLITE_OK)
		return JOBQ_EDB;
	sqlite3_bind_int64(st, 1, id);
	rc = sqlite3_step(st);
	if (rc == SQLITE_ROW) {
		*out = job_from_row(st, with_scene);
		json_object_set_new(*out, "attempts", attempts_of(q, id));
		json_object_set_new(*out, "split", split_of(q, id));
		ret = JOBQ_OK;
	} else if (rc != SQLITE_DONE) {
		ret = JOBQ_EDB;
	}
	sqlite3_finalize(st);
	return ret;
}

/* Jobs queued or running under a version without admission (schema 2) get
 * their memory estimate now, so the scheduler can count them. Best effort:
 * a scene that no longer parses keeps none (it fails at its start). */
static void backfill_estimates(jobq_t *q)
{
	sqlite3_stmt *st = NULL, *up = NULL;
	if (sqlite3_prepare_v2(q->db, "SELECT id, ranks, scene FROM jobs WHERE memory_bytes IS NULL AND "
	                       "state IN ('queued','running')", -1, &st, NULL) != SQLITE_OK ||
	    sqlite3_prepare_v2(q->db, "UPDATE jobs SET memory_bytes=?, output_bytes=? WHERE id=?", -1, &up, NULL) !=
	        SQLITE_OK || begin(q) != SQLITE_OK)
		goto out;
	while (sqlite3_step(st) == SQLITE_ROW) {
		const char *txt = (const char *)sqlite3_column_text(st, 2);
		scene_t sc;
		budget_t u;
		if (!txt || scene_parse(txt, strlen(txt), &sc, NULL, 0) != SCENE_OK ||
		    budget_estimate(&sc, sqlite3_column_int(st, 1), &u, NULL, 0) != BUDGET_OK)
			continue;
		sqlite3_bind_int64(up, 1, i64(u.memory));
		sqlite3_bind_int64(up, 2, i64(u.output));
		sqlite3_bind_int64(up, 3, sqlite3_column_int64(st, 0));
		sqlite3_step(up);
		sqlite3_reset(up);
	}
	if (commit(q) != SQLITE_OK)
		rollback(q);
out:
	sqlite3_finalize(st);
	sqlite3_finalize(up);
}

/* ---- submission ------------------------------------------------------------ */

static int valid_submission_id(const char *s)
{
	size_t n = strlen(s);
	if (n < 1 || n > 128)
		return 0;
	for (size_t i = 0; i < n; i++) {
		char c = s[i];
		if (!((c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '-' ||
		      c == '_' || c == '.' || c == ':'))
			return 0;
	}
	return 1;
}

/* ---- submission batches ------------------------------------------------------ */

/* One validated submission waiting for its transaction. */
typedef struct sub {
	const char *sub_id, *scene, *hash, *method, *advice, *slurm;
	uint64_t count, memory, output, max_output;   /* max_output 0: NULL (the server's limit) */
	json_int_t priority, ranks;
	double now;
	int64_t id;
	int ret, created, done;
	json_t *out;
	char err[256];
	struct sub *next;
} sub_t;

/* Run a batch of submissions in ONE transaction, so concurrent clients share
 * one fsync instead of queueing for one each (group commit). Called by the
 * batch leader with no lock held. On any database error nothing of the batch
 * happened and every member gets JOBQ_EDB. */
static void run_batch(jobq_t *q, sub_t *batch)
{
	sqlite3_stmt *st = NULL;
	int64_t inserted = 0;
	int fail = 0;
	pthread_mutex_lock(&q->lock);
	if (q->low_space) {
		for (sub_t *it = batch; it; it = it->next) {
			it->ret = JOBQ_EFULL;
			snprintf(it->err, sizeof(it->err), "disk full: the state directory has no room for new jobs; delete finished jobs");
		}
		goto out;
	}
	if (begin(q) != SQLITE_OK) {
		fail = 1;
		goto done;
	}
	for (sub_t *it = batch; it && !fail; it = it->next) {
		it->ret = JOBQ_OK;
		if (it->sub_id) {
			/* Idempotent retry: the same key and scene give the same job (also within this batch). */
			sqlite3_prepare_v2(q->db, "SELECT id, scene_hash FROM jobs WHERE submission_id=?", -1, &st, NULL);
			sqlite3_bind_text(st, 1, it->sub_id, -1, SQLITE_STATIC);
			if (sqlite3_step(st) == SQLITE_ROW) {
				it->id = sqlite3_column_int64(st, 0);
				if (strcmp((const char *)sqlite3_column_text(st, 1), it->hash)) {
					it->ret = JOBQ_ECONFLICT;
					snprintf(it->err, sizeof(it->err),
					         "submission_id: already used by job %" PRId64 " with a different scene", it->id);
				}
				sqlite3_finalize(st);
				st = NULL;
				continue;
			}
			sqlite3_finalize(st);
			st = NULL;
		}
		if (q->queued + inserted >= q->lim.max_queued) {
			it->ret = JOBQ_ELIMIT;
			snprintf(it->err, sizeof(it->err), "queue full: %" PRId64 " jobs are waiting (limit %d); retry later",
			         q->queued + inserted, q->lim.max_queued);
			continue;
		}
		int rc = sqlite3_prepare_v2(q->db,
		                            "INSERT INTO jobs(submission_id, scene, scene_hash, method, particles, priority, "
		                            "ranks, created_at, updated_at, advice, memory_bytes, output_bytes, max_output, "
		                            "slurm) VALUES (?,?,?,?,?,?,?,?,?,?,?,?,?,?)", -1, &st, NULL);
		if (rc == SQLITE_OK) {
			if (it->sub_id)
				sqlite3_bind_text(st, 1, it->sub_id, -1, SQLITE_STATIC);
			sqlite3_bind_text(st, 2, it->scene, -1, SQLITE_STATIC);
			sqlite3_bind_text(st, 3, it->hash, -1, SQLITE_STATIC);
			sqlite3_bind_text(st, 4, it->method, -1, SQLITE_STATIC);
			sqlite3_bind_int64(st, 5, (sqlite3_int64)it->count);
			sqlite3_bind_int64(st, 6, it->priority);
			sqlite3_bind_int64(st, 7, it->ranks);
			sqlite3_bind_double(st, 8, it->now);
			sqlite3_bind_double(st, 9, it->now);
			if (it->advice)
				sqlite3_bind_text(st, 10, it->advice, -1, SQLITE_STATIC);
			sqlite3_bind_int64(st, 11, i64(it->memory));
			sqlite3_bind_int64(st, 12, i64(it->output));
			if (it->max_output)
				sqlite3_bind_int64(st, 13, i64(it->max_output));
			if (it->slurm)
				sqlite3_bind_text(st, 14, it->slurm, -1, SQLITE_STATIC);
			rc = sqlite3_step(st);
		}
		sqlite3_finalize(st);
		st = NULL;
		if (rc != SQLITE_DONE) {
			fail = 1;
			break;
		}
		it->id = sqlite3_last_insert_rowid(q->db);
		it->created = 1;
		inserted++;
	}
	if (!fail && commit(q) != SQLITE_OK)
		fail = 1;
done:
	if (fail) {
		char e[200];
		snprintf(e, sizeof(e), "database: %s", sqlite3_errmsg(q->db));
		rollback(q);
		for (sub_t *it = batch; it; it = it->next) {
			it->ret = JOBQ_EDB;
			it->created = 0;
			snprintf(it->err, sizeof(it->err), "%s", e);
		}
		goto out;
	}
	q->queued += inserted;
	for (sub_t *it = batch; it; it = it->next)
		if (it->ret == JOBQ_OK)
			it->ret = load_job(q, it->id, 0, &it->out);
out:
	pthread_mutex_unlock(&q->lock);
}

/* Queue the submission; the first waiter becomes the leader and runs batches
 * until none is left, the others sleep until theirs is done. */
static void submit_batched(jobq_t *q, sub_t *it)
{
	pthread_mutex_lock(&q->blk);
	sub_t **tail = &q->pending;
	while (*tail)
		tail = &(*tail)->next;
	*tail = it;
	while (!it->done) {
		if (q->leader) {
			pthread_cond_wait(&q->bcond, &q->blk);
			continue;
		}
		q->leader = 1;
		while (q->pending) {
			sub_t *batch = q->pending;
			q->pending = NULL;
			pthread_mutex_unlock(&q->blk);
			run_batch(q, batch);
			pthread_mutex_lock(&q->blk);
			for (sub_t *b = batch, *nx; b; b = nx) {
				nx = b->next;
				b->next = NULL;
				b->done = 1;
			}
			pthread_cond_broadcast(&q->bcond);
		}
		q->leader = 0;
	}
	pthread_mutex_unlock(&q->blk);
}

/* A request body: the scene itself or {"scene": ..., "priority", "ranks",
 * "submission_id", "max_output_bytes"}, validated by the engine's parser and
 * the limits. */
typedef struct {
	json_t *doc, *scene_obj;     /* doc owns scene_obj */
	const char *prefix;          /* "scene." in the wrapper form, for error paths */
	const char *sub_id;
	json_int_t priority, ranks;
	uint64_t max_output;         /* asked for by the submission; 0 = the server's limit */
	json_t *slurm;               /* the "slurm" options (borrowed from doc), NULL = none */
	scene_t sc;
	budget_t bud;                /* set by admit() */
} body_t;

#define MIN_OUTPUT_LIMIT (1u << 20)   /* smaller cannot hold a run's first files */

/* A submission's "slurm" options (docs/daemon.md, "Running on a cluster"):
 * {"nodes": 1..4096, "time_limit": seconds 1..100000000, "partition": name,
 * "account": name}, each optional; used by launcher = slurm only. */
static int slurm_options(const json_t *v, char *err, size_t errlen)
{
	const char *k;
	json_t *x;
	if (!json_is_object(v)) {
		snprintf(err, errlen, "slurm: must be an object (nodes, time_limit, partition, account)");
		return JOBQ_EINVAL;
	}
	json_object_foreach((json_t *)v, k, x) {
		if (!strcmp(k, "nodes")) {
			if (!json_is_integer(x) || json_integer_value(x) < 1 || json_integer_value(x) > 4096) {
				snprintf(err, errlen, "slurm.nodes: must be an integer in 1..4096");
				return JOBQ_EINVAL;
			}
		} else if (!strcmp(k, "time_limit")) {
			if (!json_is_integer(x) || json_integer_value(x) < 1 || json_integer_value(x) > 100000000) {
				snprintf(err, errlen, "slurm.time_limit: must be an integer number of seconds in 1..100000000");
				return JOBQ_EINVAL;
			}
		} else if (!strcmp(k, "partition") || !strcmp(k, "account")) {
			/* written into the batch script: a name, nothing a shell or sbatch would read otherwise */
			const char *p = json_string_value(x);
			if (!p || !*p || strlen(p) > 64 ||
			    strspn(p, "abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ0123456789_.-") != strlen(p)) {
				snprintf(err, errlen, "slurm.%s: must be a string of 1..64 characters from A-Z a-z 0-9 _ . -", k);
				return JOBQ_EINVAL;
			}
		} else {
			snprintf(err, errlen, "slurm.%s: unknown key (expected nodes, time_limit, partition, account)", k);
			return JOBQ_EINVAL;
		}
	}
	return JOBQ_OK;
}

/* Whether a relative file name, taken from a job's directory (JOBS/ID),
 * leaves the jobs directory JOBS: by being absolute or by more ".." than
 * it went down. Lexical: the job directories hold only what the engine
 * wrote (no links a user could plant). */
static int path_escapes(const char *p)
{
	int depth = 1;   /* JOBS/ID */
	if (*p == '/')
		return 1;
	while (*p) {
		size_t n = strcspn(p, "/");
		if (n == 2 && p[0] == '.' && p[1] == '.') {
			if (--depth < 0)
				return 1;
		} else if (n && !(n == 1 && p[0] == '.')) {
			depth++;
		}
		p += n;
		while (*p == '/')
			p++;
	}
	return 0;
}

/* particles.initial.from over HTTP (docs/scene.md, "Initial state"): a file
 * stays inside the daemon's job directories; a job exists and has ended,
 * so that its trajectory is complete. The engine checks the frame itself. */
static int check_from(jobq_t *q, const body_t *b, char *err, size_t errlen)
{
	const scene_t *s = &b->sc;
	if (!s->has_from)
		return JOBQ_OK;
	if (s->from_file[0]) {
		if (!path_escapes(s->from_file))
			return JOBQ_OK;
		snprintf(err, errlen, "%sparticles.initial.from.file: \"%.200s\" leaves the daemon's job directories: a "
		         "file is taken from the job's own directory and may only name another job's (e.g. "
		         "\"../17/trajectory.h5\"); use \"job\": 17", b->prefix, s->from_file);
		return JOBQ_EINVAL;
	}
	sqlite3_stmt *st = NULL;
	int ret = JOBQ_EDB, rc;
	pthread_mutex_lock(&q->lock);
	if (sqlite3_prepare_v2(q->db, "SELECT state FROM jobs WHERE id=?", -1, &st, NULL) == SQLITE_OK) {
		sqlite3_bind_int64(st, 1, (sqlite3_int64)s->from_job);
		rc = sqlite3_step(st);
		const char *state = rc == SQLITE_ROW ? (const char *)sqlite3_column_text(st, 0) : NULL;
		if (rc == SQLITE_DONE) {
			ret = JOBQ_EINVAL;
			snprintf(err, errlen, "%sparticles.initial.from.job: no job %" PRIu64, b->prefix, s->from_job);
		} else if (state && (!strcmp(state, "queued") || !strcmp(state, "running"))) {
			ret = JOBQ_EINVAL;
			snprintf(err, errlen, "%sparticles.initial.from.job: job %" PRIu64 " is %s; its trajectory is complete "
			         "only when it has ended", b->prefix, s->from_job, state);
		} else if (state) {
			ret = JOBQ_OK;
		}
	}
	if (ret == JOBQ_EDB)
		DBERR(q, err, errlen);
	sqlite3_finalize(st);
	pthread_mutex_unlock(&q->lock);
	return ret;
}

static int parse_body(jobq_t *q, const char *body, size_t len, body_t *b, char *err, size_t errlen)
{
	json_error_t jerr;
	char *txt = NULL;
	int ret = JOBQ_EINVAL;

	memset(b, 0, sizeof(*b));
	b->ranks = 1;
	b->prefix = "";
	b->doc = json_loadb(body, len, JSON_REJECT_DUPLICATES, &jerr);
	if (!b->doc) {
		snprintf(err, errlen, "body: not valid JSON at line %d column %d: %s", jerr.line, jerr.column, jerr.text);
		goto cleanup;
	}
	if (!json_is_object(b->doc)) {
		snprintf(err, errlen, "body: must be a JSON object (a scene, or {\"scene\": ...})");
		goto cleanup;
	}
	if (json_depth(b->doc) > q->lim.max_json_depth) {
		snprintf(err, errlen, "body: JSON nested deeper than %d levels", q->lim.max_json_depth);
		goto cleanup;
	}
	b->scene_obj = json_object_get(b->doc, "scene");
	if (b->scene_obj) {
		/* The wrapper form: only these keys, each checked. */
		const char *k;
		json_t *v;
		b->prefix = "scene.";
		json_object_foreach(b->doc, k, v) {
			if (!strcmp(k, "scene")) {
				if (!json_is_object(v)) {
					snprintf(err, errlen, "scene: must be an object");
					goto cleanup;
				}
			} else if (!strcmp(k, "priority")) {
				if (!json_is_integer(v) || json_integer_value(v) < -1000 || json_integer_value(v) > 1000) {
					snprintf(err, errlen, "priority: must be an integer in -1000..1000");
					goto cleanup;
				}
				b->priority = json_integer_value(v);
			} else if (!strcmp(k, "ranks")) {
				if (!json_is_integer(v) || json_integer_value(v) < 1) {
					snprintf(err, errlen, "ranks: must be an integer >= 1");
					goto cleanup;
				}
				b->ranks = json_integer_value(v);
				if (b->ranks > q->lim.max_ranks) {
					snprintf(err, errlen, "ranks: %" JSON_INTEGER_FORMAT " exceeds the limit of %d", b->ranks,
					         q->lim.max_ranks);
					goto cleanup;
				}
			} else if (!strcmp(k, "submission_id")) {
				if (!json_is_string(v) || !valid_submission_id(json_string_value(v))) {
					snprintf(err, errlen,
					         "submission_id: must be a string of 1..128 characters from A-Z a-z 0-9 . _ - :");
					goto cleanup;
				}
				b->sub_id = json_string_value(v);
			} else if (!strcmp(k, "max_output_bytes")) {
				json_int_t m = json_is_integer(v) ? json_integer_value(v) : -1;
				if (m < MIN_OUTPUT_LIMIT) {
					snprintf(err, errlen, "max_output_bytes: must be an integer >= %u", MIN_OUTPUT_LIMIT);
					goto cleanup;
				}
				if (q->lim.max_output && (uint64_t)m > q->lim.max_output) {
					snprintf(err, errlen, "max_output_bytes: %" JSON_INTEGER_FORMAT " exceeds this server's limit of "
					         "%" PRIu64 " (max_job_output)", m, q->lim.max_output);
					goto cleanup;
				}
				b->max_output = (uint64_t)m;
			} else if (!strcmp(k, "slurm")) {
				if (slurm_options(v, err, errlen))
					goto cleanup;
				b->slurm = v;
			} else {
				snprintf(err, errlen, "%s: unknown key (expected scene, priority, ranks, submission_id, "
				         "max_output_bytes, slurm)", k);
				goto cleanup;
			}
		}
		json_t *nodes = b->slurm ? json_object_get(b->slurm, "nodes") : NULL;
		if (nodes && json_integer_value(nodes) > b->ranks) {
			snprintf(err, errlen, "slurm.nodes: %" JSON_INTEGER_FORMAT " exceeds the job's ranks (%" JSON_INTEGER_FORMAT
			         "): each node runs at least one rank", json_integer_value(nodes), b->ranks);
			goto cleanup;
		}
	} else {
		b->scene_obj = b->doc;
	}
	txt = json_dumps(b->scene_obj, JSON_COMPACT | JSON_PRESERVE_ORDER);
	if (!txt) {
		ret = JOBQ_ENOMEM;
		snprintf(err, errlen, "out of memory");
		goto cleanup;
	}
	{
		char msg[512];
		if (scene_parse(txt, strlen(txt), &b->sc, msg, sizeof(msg)) != SCENE_OK) {
			snprintf(err, errlen, "%s%s", b->prefix, msg);
			goto cleanup;
		}
	}
	if ((ret = check_from(q, b, err, errlen)))
		goto cleanup;
	ret = JOBQ_EINVAL;
	if (b->sc.count > q->lim.max_particles) {
		snprintf(err, errlen, "%sparticles.count: %" PRIu64 " exceeds this server's limit of %" PRIu64, b->prefix,
		         b->sc.count, q->lim.max_particles);
		goto cleanup;
	}
	if (q->lim.max_replicas && b->sc.replicas > q->lim.max_replicas) {
		snprintf(err, errlen, "%srun.replicas: %" PRIu64 " exceeds this server's limit of %" PRIu64 " (max_replicas)",
		         b->prefix, b->sc.replicas, q->lim.max_replicas);
		goto cleanup;
	}
	ret = JOBQ_OK;
cleanup:
	free(txt);
	if (ret) {
		json_decref(b->doc);
		b->doc = b->scene_obj = NULL;
	}
	return ret;
}

/* Estimates for the body's scene with the body's ranks. */
static int estimate(jobq_t *q, const body_t *b, advice_t *adv, char *err, size_t errlen)
{
	char msg[512];
	if (advice_estimate(q->model, &b->sc, (int)b->ranks, adv, msg, sizeof(msg)) != ADVICE_OK) {
		snprintf(err, errlen, "%s%s", b->prefix, msg);
		return JOBQ_EINVAL;
	}
	return JOBQ_OK;
}

/* Bytes for a message: "17.2 GB", or with exact "17.2 GB (17234567890 bytes)". */
typedef struct { char s[64]; } bytes_t;
static bytes_t fmt_bytes_x(uint64_t x, int exact)
{
	bytes_t r;
	if (x == UINT64_MAX) {
		snprintf(r.s, sizeof(r.s), "more than 18 EB (unbounded)");
		return r;
	}
	static const char *const unit[] = {"B", "kB", "MB", "GB", "TB", "PB", "EB"};
	double v = (double)x;
	int u = 0;
	while (v >= 1000 && u < 6)
		v /= 1000, u++;
	if (u && exact)
		snprintf(r.s, sizeof(r.s), "%.3g %s (%" PRIu64 " bytes)", v, unit[u], x);
	else
		snprintf(r.s, sizeof(r.s), u ? "%.3g %s" : "%.0f %s", v, unit[u]);
	return r;
}
static bytes_t fmt_bytes(uint64_t x) { return fmt_bytes_x(x, 1); }
static bytes_t fmt_short(uint64_t x) { return fmt_bytes_x(x, 0); }

/* Admission of a body whose scene has a concrete method (b->sc; an "auto"
 * scene is resolved by the caller): the budget on the body's ranks against
 * the memory budget and the job's output limit. Sets b->bud. */
static int admit(jobq_t *q, body_t *b, char *err, size_t errlen)
{
	char msg[512];
	if (budget_estimate(&b->sc, (int)b->ranks, &b->bud, msg, sizeof(msg)) != BUDGET_OK) {
		snprintf(err, errlen, "%s%s", b->prefix, msg);
		return JOBQ_EINVAL;
	}
	const budget_t *u = &b->bud;
	if (q->lim.memory_budget && u->memory > q->lim.memory_budget) {
		/* The key to change: the replicas when one replica would fit. */
		scene_t one = b->sc;
		budget_t ub;
		one.replicas = 1;
		const char *key = b->sc.replicas > 1 && budget_estimate(&one, (int)b->ranks, &ub, NULL, 0) == BUDGET_OK &&
		                  ub.memory <= q->lim.memory_budget ? "run.replicas" : "particles.count";
		snprintf(err, errlen, "%s%s: the job needs an estimated %s of memory (one replica's engine %s, %" PRIu64
		         " replica(s) on %" JSON_INTEGER_FORMAT " rank(s)), more than this server's memory_budget of %s: "
		         "it could never start", b->prefix, key, fmt_bytes(u->memory).s, fmt_short(u->engine).s,
		         b->sc.replicas, b->ranks, fmt_bytes(q->lim.memory_budget).s);
		return JOBQ_EINVAL;
	}
	uint64_t limit = b->max_output ? b->max_output : q->lim.max_output;
	if (limit && u->output > limit) {
		/* The key behind the largest part. */
		uint64_t ck = 3 * (u->checkpoint < UINT64_MAX / 3 ? u->checkpoint : UINT64_MAX / 3);
		const int snaps = b->sc.snapshots.kind != SCENE_CLOCK_NONE;
		const char *key = u->curves > u->trajectory && u->curves >= u->progress && u->curves >= ck
		                          ? (snaps ? "output.snapshots.every" : "output.observables")
		                  : u->trajectory >= u->progress && u->trajectory >= ck
		                          ? (snaps ? "output.snapshots.every" : "particles.count")
		                  : u->progress >= ck ? "output.every"
		                  : b->sc.replicas > 1 ? "run.replicas" : "particles.count";
		snprintf(err, errlen, "%s%s: the job would write an estimated %s (%" PRIu64 " frames: trajectory %s; "
		         "%" PRIu64 " curve samples: %s; checkpoints %s; %" PRIu64 " progress lines: %s), more than its "
		         "output limit of %s (%s)", b->prefix, key, fmt_bytes(u->output).s, u->frames,
		         fmt_short(u->trajectory).s, u->curve_samples, fmt_short(u->curves).s, fmt_short(ck).s, u->records,
		         fmt_short(u->progress).s, fmt_bytes(limit).s,
		         b->max_output ? "max_output_bytes" : "the server's max_job_output");
		return JOBQ_EINVAL;
	}
	return JOBQ_OK;
}

/* The budget as JSON (the "resources" of a validation). */
static json_t *budget_json(const budget_t *u, uint64_t max_output)
{
	return json_pack("{s:I, s:I, s:I, s:I, s:I, s:I, s:I, s:I, s:I, s:I, s:I, s:I, s:s, s:I}",
	                 "memory_bytes", i64(u->memory), "memory_rank0_bytes", i64(u->memory_rank0),
	                 "engine_bytes", i64(u->engine), "output_bytes", i64(u->output),
	                 "trajectory_bytes", i64(u->trajectory), "checkpoint_bytes", i64(u->checkpoint),
	                 "progress_bytes", i64(u->progress), "curves_bytes", i64(u->curves),
	                 "curve_samples", i64(u->curve_samples), "frames", i64(u->frames),
	                 "records", i64(u->records), "cells", i64(u->cells), "output_estimate",
	                 u->bound == BUDGET_EXACT ? "schedule" : "haff", "max_output_bytes", i64(max_output));
}

/* Body parsed and admitted, "auto" resolved on a copy of the scene (b->sc
 * becomes the chosen scene; *adv the decision when adv is not NULL). The
 * checks of a submission, for advice and validation. */
static int check_body(jobq_t *q, const char *body, size_t len, body_t *b, advice_t *adv, char *err, size_t errlen)
{
	advice_t a;
	char msg[512];
	int ret = parse_body(q, body, len, b, err, errlen);
	if (ret)
		return ret;
	if (b->sc.method == SCENE_METHOD_AUTO || adv) {
		if ((ret = estimate(q, b, &a, err, errlen)))
			return ret;
		if (adv)
			*adv = a;
	}
	if (b->sc.method == SCENE_METHOD_AUTO) {
		advice_apply(&a, &b->sc);
		if (scene_check_start(&b->sc, msg, sizeof(msg)) != SCENE_OK) {
			snprintf(err, errlen, "%sthe scene with the chosen method is not valid: %s", b->prefix, msg);
			return JOBQ_EINVAL;
		}
	}
	return admit(q, b, err, errlen);
}

int jobq_advice(jobq_t *q, const char *body, size_t len, json_t **out, char *err, size_t errlen)
{
	body_t b;
	advice_t adv;
	*out = NULL;
	int ret = check_body(q, body, len, &b, &adv, err, errlen);
	if (!ret && !(*out = advice_json(&adv))) {
		ret = JOBQ_ENOMEM;
		snprintf(err, errlen, "out of memory");
	}
	json_decref(b.doc);
	return ret;
}

int jobq_validate(jobq_t *q, const char *body, size_t len, json_t **out, char *err, size_t errlen)
{
	body_t b;
	*out = NULL;
	int ret = check_body(q, body, len, &b, NULL, err, errlen);
	if (!ret) {
		json_t *r = budget_json(&b.bud, b.max_output ? b.max_output : q->lim.max_output);
		*out = r ? json_pack("{s:b, s:s, s:o}", "valid", 1, "method", scene_method_name(b.sc.method), "resources", r)
		         : NULL;
		if (!*out) {
			ret = JOBQ_ENOMEM;
			snprintf(err, errlen, "out of memory");
		}
	}
	json_decref(b.doc);
	return ret;
}

int jobq_submit(jobq_t *q, const char *body, size_t len, double now, json_t **out, int *created, char *err,
                size_t errlen)
{
	char *scene_txt = NULL, *advice_txt = NULL, *slurm_txt = NULL, hash[17];
	body_t b;
	int ret;

	*out = NULL;
	*created = 0;
	if ((ret = parse_body(q, body, len, &b, err, errlen)))
		return ret;
	ret = JOBQ_ENOMEM;
	scene_txt = json_dumps(b.scene_obj, JSON_COMPACT | JSON_PRESERVE_ORDER);
	if (!scene_txt)
		goto nomem;
	/* Retries are recognised by the scene as submitted. */
	snprintf(hash, sizeof(hash), "%016" PRIx64, fnv1a(scene_txt, strlen(scene_txt)));
	if (b.sc.method == SCENE_METHOD_AUTO) {
		/* Decide now and keep the decision: the job stores and runs the
		 * concrete scene (method and correction chosen, accuracy dropped:
		 * exactly what was estimated), so the engine,
		 * its checkpoints and a later daemon with another model agree. */
		advice_t adv;
		json_t *aj;
		char msg[512];
		if ((ret = estimate(q, &b, &adv, err, errlen)))
			goto cleanup;
		if (!(aj = advice_json(&adv)))
			goto nomem;
		advice_txt = json_dumps(aj, JSON_COMPACT);
		json_decref(aj);
		free(scene_txt);
		scene_txt = NULL;
		if (!advice_txt || advice_apply_json(&adv, b.scene_obj) != ADVICE_OK ||
		    !(scene_txt = json_dumps(b.scene_obj, JSON_COMPACT | JSON_PRESERVE_ORDER)))
			goto nomem;
		if (scene_parse(scene_txt, strlen(scene_txt), &b.sc, msg, sizeof(msg)) != SCENE_OK) {
			ret = JOBQ_EINVAL;
			snprintf(err, errlen, "%sthe scene with the chosen method is not valid: %s", b.prefix, msg);
			goto cleanup;
		}
	}
	if ((ret = admit(q, &b, err, errlen)))
		goto cleanup;
	{
		if (b.slurm && !(slurm_txt = json_dumps(b.slurm, JSON_COMPACT | JSON_SORT_KEYS)))
			goto nomem;
		sub_t it = {.sub_id = b.sub_id, .scene = scene_txt, .hash = hash, .method = scene_method_name(b.sc.method),
		            .advice = advice_txt, .count = b.sc.count, .priority = b.priority, .ranks = b.ranks, .now = now,
		            .memory = b.bud.memory, .output = b.bud.output, .max_output = b.max_output,
		            .slurm = slurm_txt};
		submit_batched(q, &it);
		ret = it.ret;
		*out = it.out;
		*created = it.created;
		if (ret)
			snprintf(err, errlen, "%s", it.err);
	}
	goto cleanup;
nomem:
	ret = JOBQ_ENOMEM;
	snprintf(err, errlen, "out of memory");
cleanup:
	free(scene_txt);
	free(advice_txt);
	free(slurm_txt);
	json_decref(b.doc);
	return ret;
}

/* ---- reads ----------------------------------------------------------------- */

int jobq_get(jobq_t *q, int64_t id, int with_scene, json_t **out, char *err, size_t errlen)
{
	pthread_mutex_lock(&q->lock);
	int ret = load_job(q, id, with_scene, out);
	pthread_mutex_unlock(&q->lock);
	if (ret == JOBQ_ENOTFOUND)
		snprintf(err, errlen, "job %" PRId64 " not found", id);
	else if (ret)
		DBERR(q, err, errlen);
	return ret;
}

int jobq_list(jobq_t *q, const jobq_filter_t *f, json_t **out, char *err, size_t errlen)
{
	char sql[512];
	size_t o = 0;
	sqlite3_stmt *st = NULL;
	int rc, n = 0, ret = JOBQ_OK, bi = 1;
	int64_t last = 0;
	json_t *jobs = json_array();

	o += (size_t)snprintf(sql + o, sizeof(sql) - o, "SELECT " JOB_COLS " FROM jobs WHERE 1");
	if (f->states) {
		o += (size_t)snprintf(sql + o, sizeof(sql) - o, " AND state IN (");
		for (int s = 0, first = 1; s < JOB_NSTATES; s++)
			if (f->states & (1u << s)) {
				o += (size_t)snprintf(sql + o, sizeof(sql) - o, "%s'%s'", first ? "" : ",", state_names[s]);
				first = 0;
			}
		o += (size_t)snprintf(sql + o, sizeof(sql) - o, ")");
	}
	if (f->since > 0)
		o += (size_t)snprintf(sql + o, sizeof(sql) - o, " AND updated_at >= ?");
	if (f->cursor > 0)
		o += (size_t)snprintf(sql + o, sizeof(sql) - o, " AND id < ?");
	snprintf(sql + o, sizeof(sql) - o, " ORDER BY id DESC LIMIT ?");

	pthread_mutex_lock(&q->lock);
	rc = sqlite3_prepare_v2(q->db, sql, -1, &st, NULL);
	if (rc == SQLITE_OK) {
		if (f->since > 0)
			sqlite3_bind_double(st, bi++, f->since);
		if (f->cursor > 0)
			sqlite3_bind_int64(st, bi++, f->cursor);
		sqlite3_bind_int(st, bi++, f->limit + 1);  /* one more tells whether a next page exists */
		while ((rc = sqlite3_step(st)) == SQLITE_ROW) {
			if (n == f->limit)
				break;
			json_t *j = job_from_row(st, 0);
			last = sqlite3_column_int64(st, 0);
			json_array_append_new(jobs, j);
			n++;
		}
	}
	if (rc != SQLITE_ROW && rc != SQLITE_DONE) {
		ret = JOBQ_EDB;
		DBERR(q, err, errlen);
	}
	sqlite3_finalize(st);
	pthread_mutex_unlock(&q->lock);
	if (ret) {
		json_decref(jobs);
		*out = NULL;
		return ret;
	}
	*out = json_pack("{s:o, s:n}", "jobs", jobs, "next_cursor");
	if (rc == SQLITE_ROW) {
		char c[32];
		snprintf(c, sizeof(c), "%" PRId64, last);
		json_object_set_new(*out, "next_cursor", json_string(c));
	}
	return JOBQ_OK;
}

/* ---- state changes --------------------------------------------------------- */

static int job_state(jobq_t *q, int64_t id, job_state_t *s)
{
	sqlite3_stmt *st = NULL;
	int ret = JOBQ_ENOTFOUND, rc;
	sqlite3_prepare_v2(q->db, "SELECT state FROM jobs WHERE id=?", -1, &st, NULL);
	sqlite3_bind_int64(st, 1, id);
	rc = sqlite3_step(st);
	if (rc == SQLITE_ROW) {
		*s = (job_state_t)job_state_parse((const char *)sqlite3_column_text(st, 0));
		ret = JOBQ_OK;
	} else if (rc != SQLITE_DONE) {
		ret = JOBQ_EDB;
	}
	sqlite3_finalize(st);
	return ret;
}

/* Run one statement with bound values: fmt chars i (int64), d (double), s (text or NULL),
 * n (const int64_t *, NULL pointer binds NULL), D (const double *, likewise). */
static int exec_bind(jobq_t *q, const char *sql, const char *fmt, ...)
{
	sqlite3_stmt *st = NULL;
	va_list ap;
	int rc = sqlite3_prepare_v2(q->db, sql, -1, &st, NULL);
	if (rc != SQLITE_OK)
		return rc;
	va_start(ap, fmt);
	for (int i = 0; fmt[i]; i++) {
		switch (fmt[i]) {
		case 'i': sqlite3_bind_int64(st, i + 1, va_arg(ap, int64_t)); break;
		case 'd': sqlite3_bind_double(st, i + 1, va_arg(ap, double)); break;
		case 'n': {
			const int64_t *v = va_arg(ap, const int64_t *);
			if (v)
				sqlite3_bind_int64(st, i + 1, *v);
			break;
		}
		case 'D': {
			const double *v = va_arg(ap, const double *);
			if (v)
				sqlite3_bind_double(st, i + 1, *v);
			break;
		}
		case 's': {
			const char *s = va_arg(ap, const char *);
			if (s)
				sqlite3_bind_text(st, i + 1, s, -1, SQLITE_TRANSIENT);
			break;
		}
		}
	}
	va_end(ap);
	rc = sqlite3_step(st);
	sqlite3_finalize(st);
	return rc == SQLITE_DONE || rc == SQLITE_ROW ? SQLITE_OK : rc;
}

static int jobq_cancel_once(jobq_t *q, int64_t id, double now, int *signal, json_t **out, char *err, size_t errlen)
{
	job_state_t s;
	int ret, rc = SQLITE_OK;
	*signal = 0;
	*out = NULL;
	pthread_mutex_lock(&q->lock);
	if (begin(q) != SQLITE_OK) {
		ret = JOBQ_EDB;
		DBERR(q, err, errlen);
		goto out;
	}
	ret = job_state(q, id, &s);
	if (ret == JOBQ_OK) {
		if (s == JOB_QUEUED) {
			rc = exec_bind(q, "UPDATE jobs SET state='cancelled', reason='cancelled by request', finished_at=?, "
			                  "updated_at=? WHERE id=?", "ddi", now, now, id);
			if (rc == SQLITE_OK)
				q->queued--;   /* undone below if the commit fails */
		} else if (s == JOB_RUNNING) {
			rc = exec_bind(q, "UPDATE jobs SET cancel_requested=1, updated_at=? WHERE id=?", "di", now, id);
			*signal = 1;
		} else if (s != JOB_CANCELLED) {
			ret = JOBQ_ECONFLICT;
			snprintf(err, errlen, "job %" PRId64 " already %s", id, state_names[s]);
		}
	} else if (ret == JOBQ_ENOTFOUND) {
		snprintf(err, errlen, "job %" PRId64 " not found", id);
	}
	if (ret == JOBQ_OK && (rc != SQLITE_OK || commit(q) != SQLITE_OK)) {
		ret = JOBQ_EDB;
		DBERR(q, err, errlen);
		if (rc == SQLITE_OK && s == JOB_QUEUED)
			q->queued++;
	}
	if (ret != JOBQ_OK)
		rollback(q);
	else
		ret = load_job(q, id, 0, out);
out:
	pthread_mutex_unlock(&q->lock);
	return ret;
}

static int jobq_delete_once(jobq_t *q, int64_t id, char *err, size_t errlen)
{
	job_state_t s;
	int ret;
	pthread_mutex_lock(&q->lock);
	if (begin(q) != SQLITE_OK) {
		ret = JOBQ_EDB;
		DBERR(q, err, errlen);
		goto out;
	}
	ret = job_state(q, id, &s);
	if (ret == JOBQ_ENOTFOUND)
		snprintf(err, errlen, "job %" PRId64 " not found", id);
	else if (ret == JOBQ_OK && (s == JOB_QUEUED || s == JOB_RUNNING)) {
		ret = JOBQ_ECONFLICT;
		snprintf(err, errlen, "job %" PRId64 " is %s; cancel it first", id, state_names[s]);
	} else if (ret == JOBQ_OK &&
	           (exec_bind(q, "DELETE FROM jobs WHERE id=?", "i", id) != SQLITE_OK || commit(q) != SQLITE_OK)) {
		ret = JOBQ_EDB;
		DBERR(q, err, errlen);
	}
	if (ret != JOBQ_OK)
		rollback(q);
out:
	pthread_mutex_unlock(&q->lock);
	return ret;
}

int jobq_progress(jobq_t *q, int64_t id, int64_t after, int limit, int clusters_only, json_t **out, char *err,
                  size_t errlen)
{
	sqlite3_stmt *st = NULL;
	json_t *recs = json_array();
	int ret = JOBQ_OK, rc, n = 0;
	int64_t stride = 1;
	*out = NULL;
	pthread_mutex_lock(&q->lock);
	sqlite3_prepare_v2(q->db, "SELECT progress_stride FROM jobs WHERE id=?", -1, &st, NULL);
	sqlite3_bind_int64(st, 1, id);
	rc = sqlite3_step(st);
	if (rc == SQLITE_ROW)
		stride = sqlite3_column_int64(st, 0);
	else
		ret = rc == SQLITE_DONE ? JOBQ_ENOTFOUND : JOBQ_EDB;
	sqlite3_finalize(st);
	st = NULL;
	if (ret == JOBQ_OK) {
		sqlite3_prepare_v2(q->db, "SELECT seq, record FROM progress WHERE job_id=? AND seq>? ORDER BY seq", -1, &st,
		                   NULL);
		sqlite3_bind_int64(st, 1, id);
		sqlite3_bind_int64(st, 2, after);
		while (n < limit && (rc = sqlite3_step(st)) == SQLITE_ROW) {
			json_t *r = json_loads((const char *)sqlite3_column_text(st, 1), 0, NULL);
			if (!r)
				continue;
			if (clusters_only && !json_object_get(r, "clusters")) {
				json_decref(r);
				continue;
			}
			json_object_set_new(r, "seq", json_integer(sqlite3_column_int64(st, 0)));
			json_array_append_new(recs, r);
			n++;
		}
		sqlite3_finalize(st);
	}
	pthread_mutex_unlock(&q->lock);
	if (ret) {
		json_decref(recs);
		if (ret == JOBQ_ENOTFOUND)
			snprintf(err, errlen, "job %" PRId64 " not found", id);
		else
			DBERR(q, err, errlen);
		return ret;
	}
	*out = json_pack("{s:I, s:I, s:o}", "job", (json_int_t)id, "stride", (json_int_t)stride, "records", recs);
	return JOBQ_OK;
}

int jobq_stats(jobq_t *q, double now, json_t **out, char *err, size_t errlen)
{
	sqlite3_stmt *st = NULL;
	json_t *by = json_object(), *running = json_array();
	int64_t finished_hour = 0, ranks_used = 0;
	for (int s = 0; s < JOB_NSTATES; s++)
		json_object_set_new(by, state_names[s], json_integer(0));
	pthread_mutex_lock(&q->lock);
	sqlite3_prepare_v2(q->db, "SELECT state, count(*) FROM jobs GROUP BY state", -1, &st, NULL);
	while (sqlite3_step(st) == SQLITE_ROW)
		json_object_set_new(by, (const char *)sqlite3_column_text(st, 0), json_integer(sqlite3_column_int64(st, 1)));
	sqlite3_finalize(st);
	sqlite3_prepare_v2(q->db, "SELECT count(*) FROM jobs WHERE finished_at >= ?", -1, &st, NULL);
	sqlite3_bind_double(st, 1, now - 3600.0);
	if (sqlite3_step(st) == SQLITE_ROW)
		finished_hour = sqlite3_column_int64(st, 0);
	sqlite3_finalize(st);
	sqlite3_prepare_v2(q->db, "SELECT id, ranks, progress, started_at FROM jobs WHERE state='running' ORDER BY id",
	                   -1, &st, NULL);
	while (sqlite3_step(st) == SQLITE_ROW) {
		ranks_used += sqlite3_column_int64(st, 1);
		json_array_append_new(running, json_pack("{s:I, s:I, s:f, s:o}", "id",
		                                         (json_int_t)sqlite3_column_int64(st, 0), "ranks",
		                                         (json_int_t)sqlite3_column_int64(st, 1), "progress",
		                                         sqlite3_column_double(st, 2), "started_at", col_json(st, 3)));
	}
	sqlite3_finalize(st);
	pthread_mutex_unlock(&q->lock);
	(void)err;
	(void)errlen;
	*out = json_pack("{s:o, s:o, s:I, s:I}", "jobs", by, "running", running, "finished_last_hour",
	                 (json_int_t)finished_hour, "ranks_running", (json_int_t)ranks_used);
	return JOBQ_OK;
}

/* ---- supervisor side ------------------------------------------------------- */

/* Whether a job needing `need` bytes fits beside the running jobs in the
 * memory budget (*never: not even alone). Locked, in the caller's
 * transaction. Running jobs of older versions without an estimate count 0. */
static int memory_fits(jobq_t *q, uint64_t need, int *never)
{
	*never = 0;
	if (!q->lim.memory_budget)
		return 1;
	if (need > q->lim.memory_budget) {
		*never = 1;
		return 0;
	}
	sqlite3_stmt *st = NULL;
	uint64_t used = 0;
	if (sqlite3_prepare_v2(q->db, "SELECT coalesce(sum(memory_bytes), 0) FROM jobs WHERE state='running'", -1, &st,
	                       NULL) == SQLITE_OK && sqlite3_step(st) == SQLITE_ROW)
		used = (uint64_t)sqlite3_column_int64(st, 0);
	sqlite3_finalize(st);
	return used <= q->lim.memory_budget && need <= q->lim.memory_budget - used;
}

int jobq_claim(jobq_t *q, int free_slots, double now, jobq_claim_t *out, char *err, size_t errlen)
{
	sqlite3_stmt *st = NULL;
	int ret = JOBQ_EEMPTY, rc;
	memset(out, 0, sizeof(*out));
	pthread_mutex_lock(&q->lock);
	if (begin(q) != SQLITE_OK) {
		ret = JOBQ_EDB;
		DBERR(q, err, errlen);
		goto out;
	}
	for (;;) {
		sqlite3_prepare_v2(q->db, "SELECT id, ranks, scene, coalesce(memory_bytes, 0), slurm FROM jobs "
		                   "WHERE state='queued' ORDER BY priority DESC, id LIMIT 1", -1, &st, NULL);
		rc = sqlite3_step(st);
		int never = 0;
		if (rc == SQLITE_ROW && sqlite3_column_int(st, 1) <= free_slots &&
		    memory_fits(q, (uint64_t)sqlite3_column_int64(st, 3), &never)) {
			out->id = sqlite3_column_int64(st, 0);
			out->ranks = sqlite3_column_int(st, 1);
			out->scene = strdup((const char *)sqlite3_column_text(st, 2));
			if (sqlite3_column_type(st, 4) == SQLITE_TEXT)
				out->slurm = strdup((const char *)sqlite3_column_text(st, 4));
			ret = JOBQ_OK;
		} else if (rc != SQLITE_ROW && rc != SQLITE_DONE) {
			ret = JOBQ_EDB;
			DBERR(q, err, errlen);
		}
		int64_t head = rc == SQLITE_ROW ? sqlite3_column_int64(st, 0) : 0;
		uint64_t need = rc == SQLITE_ROW ? (uint64_t)sqlite3_column_int64(st, 3) : 0;
		sqlite3_finalize(st);
		st = NULL;
		if (!never)
			break;
		/* The head can never start here: fail it, look at the next. */
		char why[256];
		snprintf(why, sizeof(why), "needs an estimated %s of memory, more than this server's memory_budget of %s "
		         "(lowered since the job was submitted): it can never start", fmt_short(need).s,
		         fmt_short(q->lim.memory_budget).s);
		if (exec_bind(q, "UPDATE jobs SET state='failed', reason=?, updated_at=?, finished_at=? WHERE id=?", "sddi",
		              why, now, now, head) != SQLITE_OK) {
			ret = JOBQ_EDB;
			DBERR(q, err, errlen);
			break;
		}
		q->queued--;
	}
	if (ret == JOBQ_OK) {
		int64_t n = 1;
		sqlite3_prepare_v2(q->db, "SELECT coalesce(max(n),0)+1 FROM attempts WHERE job_id=?", -1, &st, NULL);
		sqlite3_bind_int64(st, 1, out->id);
		if (sqlite3_step(st) == SQLITE_ROW)
			n = sqlite3_column_int64(st, 0);
		sqlite3_finalize(st);
		out->attempt = (int)n;
		if (exec_bind(q, "UPDATE jobs SET state='running', reason=NULL, updated_at=?, "
		                 "started_at=coalesce(started_at, ?) WHERE id=?", "ddi", now, now, out->id) != SQLITE_OK ||
		    exec_bind(q, "INSERT INTO attempts(job_id, n, started_at) VALUES (?,?,?)", "iid", out->id, n, now) !=
		        SQLITE_OK ||
		    commit(q) != SQLITE_OK) {
			ret = JOBQ_EDB;
			DBERR(q, err, errlen);
		} else {
			q->queued--;
		}
	}
	if (ret != JOBQ_OK) {
		rollback(q);
		free(out->scene);
		free(out->slurm);
		out->scene = out->slurm = NULL;
	} else {
		scene_t sc;
		if (scene_parse(out->scene, strlen(out->scene), &sc, NULL, 0) == SCENE_OK) {
			out->until = sc.until.value;
			out->until_cpp = sc.until.kind == SCENE_CLOCK_CPP;
			out->particles = sc.count;
		}
	}
out:
	pthread_mutex_unlock(&q->lock);
	return ret;
}

int jobq_output_limit(jobq_t *q, int64_t id, uint64_t *bytes)
{
	sqlite3_stmt *st = NULL;
	int ret = JOBQ_EDB, rc;
	*bytes = 0;
	pthread_mutex_lock(&q->lock);
	if (sqlite3_prepare_v2(q->db, "SELECT max_output FROM jobs WHERE id=?", -1, &st, NULL) == SQLITE_OK) {
		sqlite3_bind_int64(st, 1, id);
		rc = sqlite3_step(st);
		if (rc == SQLITE_ROW) {
			*bytes = sqlite3_column_type(st, 0) == SQLITE_NULL ? q->lim.max_output
			                                                   : (uint64_t)sqlite3_column_int64(st, 0);
			ret = JOBQ_OK;
		} else if (rc == SQLITE_DONE) {
			ret = JOBQ_ENOTFOUND;
		}
	}
	sqlite3_finalize(st);
	pthread_mutex_unlock(&q->lock);
	return ret;
}

int jobq_attempt_launched(jobq_t *q, int64_t id, int attempt, int pid, uint64_t pid_start, const char *checkpoint)
{
	pthread_mutex_lock(&q->lock);
	int rc = exec_bind(q, "UPDATE attempts SET pid=?, pid_start=?, checkpoint=? WHERE job_id=? AND n=?", "iisii",
	                   (int64_t)pid, (int64_t)pid_start, checkpoint, id, (int64_t)attempt);
	pthread_mutex_unlock(&q->lock);
	return rc == SQLITE_OK ? JOBQ_OK : JOBQ_EDB;
}

int jobq_attempt_slurm(jobq_t *q, int64_t id, int attempt, int64_t slurm_job, const char *checkpoint)
{
	pthread_mutex_lock(&q->lock);
	int rc = exec_bind(q, "UPDATE attempts SET slurm_job=?, slurm_state='pending', checkpoint=? WHERE job_id=? AND n=?",
	                   "isii", slurm_job, checkpoint, id, (int64_t)attempt);
	pthread_mutex_unlock(&q->lock);
	return rc == SQLITE_OK ? JOBQ_OK : JOBQ_EDB;
}

int jobq_attempt_slurm_state(jobq_t *q, int64_t id, int attempt, const char *state, double now)
{
	pthread_mutex_lock(&q->lock);
	int rc = exec_bind(q, "UPDATE attempts SET slurm_state=? WHERE job_id=? AND n=?", "sii", state, id,
	                   (int64_t)attempt);
	if (rc == SQLITE_OK)
		rc = exec_bind(q, "UPDATE jobs SET updated_at=? WHERE id=?", "di", now, id);
	pthread_mutex_unlock(&q->lock);
	return rc == SQLITE_OK ? JOBQ_OK : JOBQ_EDB;
}

int jobq_last_record(jobq_t *q, int64_t id, int attempt, char **line)
{
	sqlite3_stmt *st = NULL;
	int ret = JOBQ_EDB, rc;
	*line = NULL;
	pthread_mutex_lock(&q->lock);
	if (sqlite3_prepare_v2(q->db, "SELECT record FROM progress WHERE job_id=? AND attempt=? ORDER BY seq DESC LIMIT 1",
	                       -1, &st, NULL) == SQLITE_OK) {
		sqlite3_bind_int64(st, 1, id);
		sqlite3_bind_int64(st, 2, attempt);
		rc = sqlite3_step(st);
		if (rc == SQLITE_ROW) {
			*line = strdup((const char *)sqlite3_column_text(st, 0));
			ret = *line ? JOBQ_OK : JOBQ_ENOMEM;
		} else if (rc == SQLITE_DONE) {
			ret = JOBQ_ENOTFOUND;
		}
	}
	sqlite3_finalize(st);
	pthread_mutex_unlock(&q->lock);
	return ret;
}

int jobq_attempt_checkpoint(jobq_t *q, int64_t id, int attempt, const char *checkpoint)
{
	pthread_mutex_lock(&q->lock);
	int rc = exec_bind(q, "UPDATE attempts SET checkpoint=? WHERE job_id=? AND n=?", "sii", checkpoint, id,
	                   (int64_t)attempt);
	pthread_mutex_unlock(&q->lock);
	return rc == SQLITE_OK ? JOBQ_OK : JOBQ_EDB;
}

/*
 * A retry re-emits what the earlier attempt emitted after the point it
 * restarts from (its checkpoint, or time 0): at the first progress record
 * of attempt n > 1, drop the earlier attempts' progress records at or after
 * its time, so that the series reads as one run. Times increase strictly
 * within a run, so "at or after" is exactly the repeated part. Summaries
 * (an interrupted attempt's) and other record types stay. In the caller's
 * transaction.
 */
static int rewind_series(jobq_t *q, int64_t id, int attempt, const json_t *r)
{
	sqlite3_stmt *st = NULL;
	json_t *t = json_object_get(r, "time");
	const char *type = json_string_value(json_object_get(r, "type"));
	if (!json_is_number(t) || !type || strcmp(type, "progress"))
		return JOBQ_OK;
	int64_t last = -1;
	sqlite3_prepare_v2(q->db, "SELECT attempt FROM progress WHERE job_id=? AND "
	                          "json_extract(record, '$.type') = 'progress' ORDER BY seq DESC LIMIT 1", -1, &st, NULL);
	sqlite3_bind_int64(st, 1, id);
	int rc = sqlite3_step(st);
	if (rc == SQLITE_ROW)
		last = sqlite3_column_int64(st, 0);
	sqlite3_finalize(st);
	if (rc != SQLITE_ROW && rc != SQLITE_DONE)
		return JOBQ_EDB;
	if (last < 0 || last >= attempt)
		return JOBQ_OK;   /* nothing earlier, or not this attempt's first record */
	return exec_bind(q, "DELETE FROM progress WHERE job_id=? AND attempt<? AND time>=? AND "
	                    "json_extract(record, '$.type') = 'progress'", "iid", id, (int64_t)attempt,
	                 json_number_value(t)) == SQLITE_OK ? JOBQ_OK : JOBQ_EDB;
}

/* Count a batch's records that were not stored (disk full) on the job row, when the disk allows it. */
static void count_dropped(jobq_t *q, int64_t id, int64_t received, int64_t thinned, int64_t dropped, double now)
{
	if (begin(q) != SQLITE_OK)
		return;
	if (exec_bind(q, "UPDATE jobs SET progress_received=progress_received+?, progress_thinned=progress_thinned+?, "
	                 "progress_dropped=progress_dropped+?, updated_at=? WHERE id=?", "iiidi", received, thinned,
	              dropped, now, id) != SQLITE_OK || commit(q) != SQLITE_OK)
		rollback(q);
}

int jobq_attempt_progress_batch(jobq_t *q, int64_t id, int attempt, const jobq_record_t *recs, size_t n,
                                int64_t received, int64_t thinned, double now)
{
	sqlite3_stmt *st = NULL, *ins = NULL;
	int ret = JOBQ_OK;
	int64_t seq = 0, stride = 1, stored = 0;
	double frac_max = 0.0, tv = 0.0;
	int64_t evv = 0, cov = 0;
	int has_t = 0, has_ev = 0, has_co = 0;
	for (size_t i = 0; i < n; i++)
		if (!json_is_object(recs[i].r))
			return JOBQ_EINVAL;
	pthread_mutex_lock(&q->lock);
	if (q->low_space) {
		/* The ballast is for ending jobs, not for more records: counted as dropped. */
		count_dropped(q, id, received, thinned, (int64_t)n, now);
		ret = JOBQ_EFULL;
		goto out;
	}
	if (begin(q) != SQLITE_OK) {
		ret = JOBQ_EDB;
		goto out;
	}
	sqlite3_prepare_v2(q->db, "SELECT progress_seq, progress_stride FROM jobs WHERE id=?", -1, &st, NULL);
	sqlite3_bind_int64(st, 1, id);
	if (sqlite3_step(st) == SQLITE_ROW) {
		seq = sqlite3_column_int64(st, 0);
		stride = sqlite3_column_int64(st, 1);
	} else {
		ret = JOBQ_ENOTFOUND;
	}
	sqlite3_finalize(st);
	st = NULL;
	if (ret)
		goto fail;
	/* A retry's first progress record rewinds the series (it is the batch's
	 * first progress record or a later batch's, where rewinding is a no-op). */
	for (size_t i = 0; i < n && attempt > 1; i++) {
		const char *type = json_string_value(json_object_get(recs[i].r, "type"));
		if (type && !strcmp(type, "progress")) {
			if ((ret = rewind_series(q, id, attempt, recs[i].r)) != JOBQ_OK)
				goto fail;
			break;
		}
	}
	sqlite3_prepare_v2(q->db, "SELECT count(*) FROM progress WHERE job_id=?", -1, &st, NULL);
	sqlite3_bind_int64(st, 1, id);
	if (sqlite3_step(st) == SQLITE_ROW)
		stored = sqlite3_column_int64(st, 0);
	sqlite3_finalize(st);
	st = NULL;
	if (sqlite3_prepare_v2(q->db, "INSERT OR REPLACE INTO progress(job_id, seq, attempt, time, record) "
	                              "VALUES (?,?,?,?,?)", -1, &ins, NULL) != SQLITE_OK) {
		ret = JOBQ_EDB;
		goto fail;
	}
	for (size_t i = 0; i < n; i++, seq++) {
		const json_t *r = recs[i].r;
		const char *type = json_string_value(json_object_get(r, "type"));
		json_t *t = json_object_get(r, "time"), *ev = json_object_get(r, "events"),
		       *co = json_object_get(r, "collisions");
		double frac = recs[i].frac > 1.0 ? 1.0 : recs[i].frac;
		if (frac > frac_max)
			frac_max = frac;
		/* Absent fields keep the previous values (a summary may omit some). */
		if (json_is_number(t)) {
			tv = json_number_value(t);
			has_t = 1;
		}
		if (json_is_integer(ev)) {
			evv = (int64_t)json_integer_value(ev);
			has_ev = 1;
		}
		if (json_is_integer(co)) {
			cov = (int64_t)json_integer_value(co);
			has_co = 1;
		}
		if (!(type && !strcmp(type, "summary")) && seq % stride != 0)
			continue;
		sqlite3_reset(ins);
		sqlite3_bind_int64(ins, 1, id);
		sqlite3_bind_int64(ins, 2, seq);
		sqlite3_bind_int64(ins, 3, attempt);
		sqlite3_bind_double(ins, 4, json_is_number(t) ? json_number_value(t) : 0.0);
		sqlite3_bind_text(ins, 5, recs[i].line, -1, SQLITE_STATIC);
		if (sqlite3_step(ins) != SQLITE_DONE) {
			ret = JOBQ_EDB;
			goto fail;
		}
		if (++stored > q->lim.max_progress) {
			/* Halve the series: keep multiples of the doubled stride, the
			 * newest record and every summary. */
			stride *= 2;
			if (exec_bind(q, "DELETE FROM progress WHERE job_id=? AND seq % ? != 0 AND seq != ? AND "
			                 "json_extract(record, '$.type') IS NOT 'summary'", "iii", id, stride, seq) != SQLITE_OK) {
				ret = JOBQ_EDB;
				goto fail;
			}
			stored -= sqlite3_changes(q->db);
		}
	}
	if (exec_bind(q, "UPDATE jobs SET progress_seq=?, progress_stride=?, progress=max(progress, ?), "
	                 "sim_time=coalesce(?, sim_time), events=coalesce(?, events), "
	                 "collisions=coalesce(?, collisions), progress_received=progress_received+?, "
	                 "progress_thinned=progress_thinned+?, progress_stored=?, updated_at=? WHERE id=?",
	              "iidDnniiidi", seq, stride, frac_max, has_t ? &tv : NULL, has_ev ? &evv : NULL,
	              has_co ? &cov : NULL, received, thinned, stored, now, id) != SQLITE_OK ||
	    commit(q) != SQLITE_OK) {
		ret = JOBQ_EDB;
		goto fail;
	}
	goto out;
fail:
	rollback(q);
	if (space_short(q)) {
		q->low_space = 1;   /* stop storing records; the ballast stays for ending the job */
		count_dropped(q, id, received, thinned, (int64_t)n, now);
	}
out:
	sqlite3_finalize(ins);
	pthread_mutex_unlock(&q->lock);
	return ret;
}

int jobq_attempt_progress(jobq_t *q, int64_t id, int attempt, const char *line, const json_t *r, double frac,
                          double now)
{
	const jobq_record_t rec = {.line = line, .r = r, .frac = frac};
	return jobq_attempt_progress_batch(q, id, attempt, &rec, 1, 1, 0, now);
}

static int jobq_attempt_finished_once(jobq_t *q, int64_t id, int attempt, double now, int exit_status, int signal,
                          const char *reason, const char *stderr_tail, job_state_t next)
{
	int ret = JOBQ_OK;
	pthread_mutex_lock(&q->lock);
	if (begin(q) != SQLITE_OK) {
		ret = JOBQ_EDB;
		goto out;
	}
	if (exec_bind(q, "UPDATE attempts SET ended_at=?, exit_status=?, signal=?, reason=?, stderr_tail=? "
	                 "WHERE job_id=? AND n=?", "diissii", now, (int64_t)exit_status, (int64_t)signal, reason,
	              stderr_tail, id, (int64_t)attempt) != SQLITE_OK ||
	    /* NULL for "none" keeps the columns honest. */
	    exec_bind(q, "UPDATE attempts SET exit_status=CASE WHEN exit_status<0 THEN NULL ELSE exit_status END, "
	                 "signal=CASE WHEN signal<=0 THEN NULL ELSE signal END WHERE job_id=? AND n=?", "ii", id,
	              (int64_t)attempt) != SQLITE_OK ||
	    (next == JOB_QUEUED
	         ? exec_bind(q, "UPDATE jobs SET state='queued', reason=?, updated_at=? WHERE id=?", "sdi", reason, now, id)
	         : exec_bind(q, "UPDATE jobs SET state=?, reason=?, updated_at=?, finished_at=? WHERE id=?", "ssddi",
	                     state_names[next], reason, now, now, id)) != SQLITE_OK ||
	    commit(q) != SQLITE_OK) {
		ret = JOBQ_EDB;
		rollback(q);
	} else if (next == JOB_QUEUED) {
		q->queued++;
	}
out:
	pthread_mutex_unlock(&q->lock);
	return ret;
}

int jobq_list_running(jobq_t *q, jobq_running_t **out, size_t *n)
{
	sqlite3_stmt *st = NULL;
	size_t cap = 0;
	*out = NULL;
	*n = 0;
	pthread_mutex_lock(&q->lock);
	sqlite3_prepare_v2(q->db,
	                   "SELECT j.id, a.n, coalesce(a.pid,0), coalesce(a.pid_start,0), coalesce(a.slurm_job,0), "
	                   "j.ranks, a.checkpoint IS NOT NULL, j.scene FROM jobs j "
	                   "LEFT JOIN attempts a ON a.job_id=j.id AND a.n=(SELECT max(n) FROM attempts WHERE job_id=j.id) "
	                   "WHERE j.state='running' ORDER BY j.id", -1, &st, NULL);
	while (sqlite3_step(st) == SQLITE_ROW) {
		if (*n == cap) {
			cap = cap ? 2 * cap : 8;
			jobq_running_t *p = realloc(*out, cap * sizeof(**out));
			if (!p)
				break;
			*out = p;
		}
		(*out)[*n].id = sqlite3_column_int64(st, 0);
		(*out)[*n].attempt = sqlite3_column_int(st, 1);
		(*out)[*n].pid = sqlite3_column_int(st, 2);
		(*out)[*n].pid_start = (uint64_t)sqlite3_column_int64(st, 3);
		(*out)[*n].slurm_job = sqlite3_column_int64(st, 4);
		(*out)[*n].ranks = sqlite3_column_int(st, 5);
		(*out)[*n].resumed = sqlite3_column_int(st, 6);
		(*out)[*n].until = 0;
		(*out)[*n].until_cpp = 0;
		scene_t sc;
		const char *txt = (const char *)sqlite3_column_text(st, 7);
		if (txt && scene_parse(txt, strlen(txt), &sc, NULL, 0) == SCENE_OK) {
			(*out)[*n].until = sc.until.value;
			(*out)[*n].until_cpp = sc.until.kind == SCENE_CLOCK_CPP;
		}
		(*n)++;
	}
	sqlite3_finalize(st);
	pthread_mutex_unlock(&q->lock);
	return JOBQ_OK;
}

/* One integer from a query bound to a job id; fallback when there is no row. */
static int int_of_job(jobq_t *q, const char *sql, int64_t id, int fallback)
{
	sqlite3_stmt *st = NULL;
	int ret = fallback;
	pthread_mutex_lock(&q->lock);
	sqlite3_prepare_v2(q->db, sql, -1, &st, NULL);
	sqlite3_bind_int64(st, 1, id);
	if (sqlite3_step(st) == SQLITE_ROW)
		ret = sqlite3_column_int(st, 0);
	sqlite3_finalize(st);
	pthread_mutex_unlock(&q->lock);
	return ret;
}

int jobq_cancel_requested(jobq_t *q, int64_t id)
{
	return int_of_job(q, "SELECT cancel_requested FROM jobs WHERE id=?", id, JOBQ_ENOTFOUND);
}

int jobq_attempts(jobq_t *q, int64_t id)
{
	return int_of_job(q, "SELECT count(*) FROM attempts WHERE job_id=?", id, JOBQ_EDB);
}

/* ---- disk-full protection ------------------------------------------------- */

/* The disk holding the ballast (the state directory) has less free space
 * than half the ballast: a failed write there is most likely ENOSPC. */
/* Free bytes on the file system holding path's directory (UINT64_MAX if unknown). */
static uint64_t free_bytes(const char *path)
{
	struct statvfs vf;
	char dir[4096];
	snprintf(dir, sizeof(dir), "%s", path);
	char *sl = strrchr(dir, '/');
	if (sl)
		*sl = '\0';
	if (statvfs(sl ? dir : ".", &vf))
		return UINT64_MAX;
	return (uint64_t)vf.f_bavail * vf.f_frsize;
}

static int space_short(jobq_t *q)
{
	return q->reserve && free_bytes(q->reserve) < q->reserve_bytes / 2 + 65536;
}

/* Free the ballast (locked by the caller); 1 if space was freed. */
static int release_reserve(jobq_t *q)
{
	q->low_space = 1;
	if (!q->reserve || !q->have_reserve)
		return 0;
	q->have_reserve = 0;
	return unlink(q->reserve) == 0;
}

int jobq_reserve(jobq_t *q, const char *path, uint64_t bytes)
{
	int ret = 0;
	struct stat st;
	pthread_mutex_lock(&q->lock);
	if (!q->reserve || strcmp(q->reserve, path)) {
		free(q->reserve);
		q->reserve = strdup(path);
	}
	q->reserve_bytes = bytes;
	if (stat(path, &st) == 0 && (uint64_t)st.st_size >= bytes) {
		q->have_reserve = 1;
		/* In place, but the disk may still be full: look before lifting the stop. */
		if (q->low_space && free_bytes(path) < bytes) {
			ret = -1;
			goto out;
		}
		q->low_space = 0;
		goto out;
	}
	/* Only take the ballast back when it leaves as much again free; first give
	 * the journal's unused space back to the disk. */
	if (free_bytes(path) < 2 * bytes)
		sqlite3_exec(q->db, "PRAGMA wal_checkpoint(TRUNCATE)", NULL, NULL, NULL);
	if (free_bytes(path) < 2 * bytes) {
		q->low_space = 1;
		ret = -1;
		goto out;
	}
	int fd = open(path, O_WRONLY | O_CREAT | O_CLOEXEC, 0600);
	if (fd < 0 || posix_fallocate(fd, 0, (off_t)bytes) || fsync(fd)) {
		if (fd >= 0)
			close(fd);
		unlink(path);
		q->low_space = 1;
		ret = -1;
		goto out;
	}
	close(fd);
	q->have_reserve = 1;
	q->low_space = 0;
out:
	pthread_mutex_unlock(&q->lock);
	return ret;
}

int jobq_low_space(jobq_t *q)
{
	pthread_mutex_lock(&q->lock);
	int r = q->low_space;
	pthread_mutex_unlock(&q->lock);
	return r;
}

/* A write that failed on a full disk is retried once after freeing the ballast. */
int jobq_attempt_finished(jobq_t *q, int64_t id, int attempt, double now, int exit_status, int signal,
                          const char *reason, const char *stderr_tail, job_state_t next)
{
	int r = jobq_attempt_finished_once(q, id, attempt, now, exit_status, signal, reason, stderr_tail, next);
	if (r == JOBQ_EDB && space_short(q)) {
		pthread_mutex_lock(&q->lock);
		int freed = release_reserve(q);
		pthread_mutex_unlock(&q->lock);
		if (freed)
			r = jobq_attempt_finished_once(q, id, attempt, now, exit_status, signal, reason, stderr_tail, next);
	}
	return r;
}

/* A write that failed on a full disk is retried once after freeing the ballast. */
int jobq_cancel(jobq_t *q, int64_t id, double now, int *signal, json_t **out, char *err, size_t errlen)
{
	int r = jobq_cancel_once(q, id, now, signal, out, err, errlen);
	if (r == JOBQ_EDB && space_short(q)) {
		pthread_mutex_lock(&q->lock);
		int freed = release_reserve(q);
		pthread_mutex_unlock(&q->lock);
		if (freed)
			r = jobq_cancel_once(q, id, now, signal, out, err, errlen);
	}
	return r;
}

/* A write that failed on a full disk is retried once after freeing the ballast. */
int jobq_delete(jobq_t *q, int64_t id, char *err, size_t errlen)
{
	int r = jobq_delete_once(q, id, err, errlen);
	if (r == JOBQ_EDB && space_short(q)) {
		pthread_mutex_lock(&q->lock);
		int freed = release_reserve(q);
		pthread_mutex_unlock(&q->lock);
		if (freed)
			r = jobq_delete_once(q, id, err, errlen);
	}
	return r;
}
