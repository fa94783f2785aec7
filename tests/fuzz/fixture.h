/* Shared by the API and HTTP harnesses: a job queue fixture in memory, a scheduler that never starts, checks on answers. */
#pragma once

#include <fcntl.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "api.h"
#include "util.h"

/*
 * The queue is a ":memory:" database holding a fixture: job 1 finished with
 * progress and files, job 2 running, job 3 queued. Opening a queue takes
 * 10-70 ms under ASan (the schema, the advice model) and a scheduler ~10 ms
 * (its child table, 6 MB zeroed), so both are kept across inputs and rebuilt
 * only after a request changed a fixture job (cancel, delete) or after a few
 * accepted submissions (fx_after()). Rebuilding them for every input held the
 * API harness at ~60 exec/s; kept, it runs at ~3,000. Every input meets the
 * fixture plus at most MAX_EXTRA jobs, and a crash found in a run reproduces
 * from its input alone in practice (a fresh process starts from the fixture).
 */

#define MAX_EXTRA 4

static cfg_t cfg;
static int extra = MAX_EXTRA + 1;   /* > MAX_EXTRA: build before the first input */
static gd_t gd;
static char jobs[256];
static const char *SCENE =
	"{\"method\":\"ed\",\"dimensions\":2,\"particles\":{\"count\":100,\"volume_fraction\":0.2},"
	"\"run\":{\"until\":{\"time\":1}},\"output\":{\"observables\":[\"kinetic_energy\",\"clusters\"]}}";

static void put(const char *dir, const char *name, const char *text)
{
	char p[512];
	snprintf(p, sizeof p, "%s/%s", dir, name);
	int fd = open(p, O_WRONLY | O_CREAT | O_TRUNC, 0644);
	if (fd >= 0) {
		ssize_t w = write(fd, text, strlen(text));
		(void)w;
		close(fd);
	}
}

/* Job 1's directory (a DELETE removes it; the next input gets it back). */
static void job_files(void)
{
	char d[300];
	struct stat st;
	snprintf(d, sizeof d, "%s/1", jobs);
	if (stat(d, &st) == 0)
		return;
	mkdir(d, 0755);
	put(d, "scene.json", SCENE);
	put(d, "progress.jsonl", "{\"type\":\"progress\",\"time\":0.5}\n");
	put(d, "trajectory.h5", "\x89HDF\r\n\x1a\n0123456789abcdef");
	put(d, "stderr.log", "");
}

static void fx_die(const char *what, const char *err)
{
	fprintf(stderr, "fixture: %s: %s\n", what, err);
	abort();
}

static void record(jobq_t *q, int64_t id, const char *line, double frac, double now)
{
	json_t *r = json_loads(line, 0, NULL);
	if (jobq_attempt_progress(q, id, 1, line, r, frac, now) != JOBQ_OK)
		fx_die("progress", line);
	json_decref(r);
}

static jobq_t *fixture(void)
{
	jobq_limits_t lim = {.max_particles = 100000, .max_ranks = 4, .max_queued = 8, .max_json_depth = 32,
	                     .max_progress = 64};
	char err[512];
	jobq_claim_t cl;
	json_t *j = NULL;
	int created;
	jobq_t *q = jobq_open(":memory:", &lim, err, sizeof err);
	if (!q)
		return NULL;
	/* A fixture that did not build would leave the harness fuzzing an empty queue: stop, saying why. */
	for (int i = 0; i < 3; i++) {
		if (jobq_submit(q, SCENE, strlen(SCENE), 100.0 + i, &j, &created, err, sizeof err) != JOBQ_OK)
			fx_die("submit", err);
		json_decref(j);
		j = NULL;
	}
	for (int i = 0; i < 2; i++) {
		if (jobq_claim(q, 4, 200.0 + i, &cl, err, sizeof err) != JOBQ_OK)
			fx_die("claim", err);
		jobq_attempt_launched(q, cl.id, 1, 1000 + i, 1, NULL);
		free(cl.scene);
	}
	record(q, 1, "{\"type\":\"progress\",\"time\":0.5,\"events\":10,\"collisions\":5,"
	             "\"clusters\":{\"count\":3,\"largest\":7}}", 0.5, 300.0);
	record(q, 1, "{\"type\":\"summary\",\"status\":\"completed\",\"time\":1}", 1.0, 301.0);
	record(q, 2, "{\"type\":\"progress\",\"time\":0.1,\"events\":1,\"collisions\":1}", 0.1, 302.0);
	if (jobq_attempt_finished(q, 1, 1, 310.0, 0, 0, NULL, "", JOB_SUCCEEDED) != JOBQ_OK)
		fx_die("finish", "job 1");
	return q;
}

static char base[128];

static void fx_cleanup(void)
{
	util_rmtree(base);
}

/* Once per process: the job directory (tmpfs when there is one, removed at exit), the configuration, the hub. */
static void fx_init(const char *name)
{
	snprintf(base, sizeof base, "%s/%s.%ld", access("/dev/shm", W_OK) ? "/tmp" : "/dev/shm", name, (long)getpid());
	snprintf(jobs, sizeof jobs, "%s/jobs", base);
	if (util_mkdirs(jobs, 0755) || cfg_init(&cfg))
		abort();
	atexit(fx_cleanup);
	gd.cfg = &cfg;
	gd.hub = hub_create(64);
	gd.token = "fuzz";
	gd.jobs_dir = jobs;
	if (!gd.hub)
		abort();
}

/* Before each input: job 1's files, and the queue and scheduler when due. */
static void fx_before(void)
{
	job_files();
	if (extra > MAX_EXTRA) {
		/* The scheduler too: a cancel leaves its id in the scheduler's list. */
		sched_destroy(gd.sched);
		jobq_close(gd.q);
		if (!(gd.q = fixture()))
			abort();
		sched_conf_t sc = {.q = gd.q, .hub = gd.hub, .cfg = &cfg, .engine = "/nonexistent", .jobs_dir = jobs};
		if (!(gd.sched = sched_create(&sc)))   /* never started: no job is launched */
			abort();
		extra = 0;
	}
}

static void check_error_body(const api_resp_t *rs)
{
	json_t *e = json_object_get(rs->json, "error");
	if (!json_is_string(json_object_get(e, "code")) || !json_is_string(json_object_get(e, "message")))
		__builtin_trap();
}

/* A handler's answer: 2xx-4xx (nothing in a request may be an internal
 * error), errors carry {"error": {"code", "message"}}, the body serialises,
 * a file range stays inside the file. Then count what changed the queue. */
static void fx_after(const api_route_t *rt, const api_req_t *ar, const api_resp_t *rs)
{
	if (rs->status < 200 || rs->status > 599 || rs->status == 500)
		__builtin_trap();
	if (rs->status >= 400)
		check_error_body(rs);
	if (rs->json) {
		char *txt = json_dumps(rs->json, JSON_COMPACT);
		if (!txt)
			__builtin_trap();   /* e.g. a NaN, which JSON cannot carry */
		free(txt);
	}
	if (rs->has_file && (rs->fd < 0 || rs->file_off > rs->file_size || rs->file_len > rs->file_size - rs->file_off))
		__builtin_trap();
	if (rs->status < 300 && (rt->flags & API_MUTATES)) {
		/* A fixture job changed (ids 1..3): rebuild; a new job: count it. */
		long long id = ar->nparams ? atoll(ar->params[0]) : 0;
		extra += id >= 1 && id <= 3 ? MAX_EXTRA + 1 : 1;
	}
}

static void fx_release(api_resp_t *rs)
{
	if (rs->has_file && rs->fd >= 0)
		close(rs->fd);
	json_decref(rs->json);
	free(rs->owned);
}

