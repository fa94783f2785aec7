/* Unit tests of the job queue logic (daemon/jobq.c) against an in-memory and a temporary SQLite database. */
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>
#include "db.h"
#include "jobq.h"
#include "tap.h"

static const char *SCENE =
	"{\"method\":\"ed\",\"dimensions\":2,\"particles\":{\"count\":100,\"volume_fraction\":0.2},"
	"\"run\":{\"until\":{\"time\":1}}}";
static const char *SCENE2 =
	"{\"method\":\"ed\",\"dimensions\":3,\"particles\":{\"count\":108,\"volume_fraction\":0.2},"
	"\"run\":{\"until\":{\"collisions_per_particle\":10}}}";

static jobq_limits_t lim = {.max_particles = 1000000, .max_ranks = 4, .max_queued = 1000, .max_json_depth = 8,
                            .max_progress = 16};

static int64_t submit(jobq_t *q, const char *body, int *rc, int *created, char *err)
{
	json_t *j = NULL;
	int c = 0;
	*rc = jobq_submit(q, body, strlen(body), 100.0, &j, &c, err, 512);
	if (created)
		*created = c;
	int64_t id = j ? json_integer_value(json_object_get(j, "id")) : 0;
	json_decref(j);
	return id;
}

static const char *state_of(jobq_t *q, int64_t id, char *buf)
{
	json_t *j = NULL;
	char err[256];
	if (jobq_get(q, id, 0, &j, err, sizeof(err)))
		return "none";
	snprintf(buf, 32, "%s", json_string_value(json_object_get(j, "state")));
	json_decref(j);
	return buf;
}

/* Concurrent submitters share transactions (group commit): every submission
 * must get exactly one job, and repeated submission_ids the same job. */
typedef struct {
	jobq_t *q;
	int t;
	int64_t ids[40];
} worker_t;

static void *submitter(void *arg)
{
	worker_t *w = arg;
	char body[512], err[512];
	for (int i = 0; i < 40; i++) {
		json_t *j = NULL;
		int created = 0;
		/* even i: a key shared by all threads (i/2); odd i: a key of this thread */
		snprintf(body, sizeof(body), "{\"scene\":%s,\"submission_id\":\"k-%d-%d\"}", SCENE,
		         i % 2 ? w->t : -1, i / 2);
		int rc = jobq_submit(w->q, body, strlen(body), 1.0, &j, &created, err, sizeof(err));
		w->ids[i] = rc == 0 ? json_integer_value(json_object_get(j, "id")) : -1;
		json_decref(j);
	}
	return NULL;
}

static int cmp64(const void *a, const void *b)
{
	int64_t x = *(const int64_t *)a, y = *(const int64_t *)b;
	return (x > y) - (x < y);
}

/* A job's stored series as "p0 p1 s4.5 ...": type initial and time of each record. */
static void series_of(jobq_t *q, int64_t id, char *got, size_t len)
{
	char err[256];
	json_t *p = NULL;
	got[0] = '\0';
	if (jobq_progress(q, id, -1, 1000, 0, &p, err, sizeof(err)) != 0)
		return;
	json_t *rr = json_object_get(p, "records");
	for (size_t i = 0; i < json_array_size(rr); i++) {
		json_t *o = json_array_get(rr, i);
		const char *ty = json_string_value(json_object_get(o, "type"));
		size_t l = strlen(got);
		snprintf(got + l, len - l, "%s%c%g", i ? " " : "", ty ? ty[0] : '?', json_number_value(json_object_get(o, "time")));
	}
	json_decref(p);
}

/* jobq_validate(): 0 and the resources, or the error. */
static int validate(jobq_t *q, const char *body, json_t **res, char *err)
{
	json_t *j = NULL;
	int rc = jobq_validate(q, body, strlen(body), &j, err, 512);
	if (res)
		*res = rc == 0 ? json_incref(json_object_get(j, "resources")) : NULL;
	json_decref(j);
	return rc;
}

static long long res_int(const json_t *res, const char *key) { return json_integer_value(json_object_get(res, key)); }

/* A 2D dsmc scene of n particles and r replicas (~100 bytes per particle per replica). */
static void mc_scene(char *buf, size_t len, long n, long r, const char *extra)
{
	snprintf(buf, len, "{\"method\":\"dsmc\",\"dimensions\":2,\"particles\":{\"count\":%ld,\"volume_fraction\":0.1},"
	         "\"run\":{\"until\":{\"time\":1},\"replicas\":%ld}%s}", n, r, extra);
}

/*
 * Admission (issue 19, items 3 and 7): a job is estimated before it is
 * queued (engine/budget.h). What can never fit the machine's memory budget
 * is refused naming the key and the estimate; what fits alone but not
 * beside the running jobs waits in the queue; replicas are capped; the
 * output limit is per job (max_output_bytes) under the server's; and the
 * engine's own start checks run at validation, advice and submission.
 * On main every one of these scenes was accepted.
 */
static void test_admission(void)
{
	char err[512], body[1024], sb[32];
	json_t *res = NULL;
	int rc, created;
	jobq_limits_t al = lim;
	al.max_particles = 1000000000;
	al.max_replicas = 100;
	al.max_output = 200u << 20;
	al.memory_budget = 1000000000;   /* 1 GB */
	jobq_t *q = jobq_open(":memory:", &al, err, sizeof(err));
	if (!ok(q != NULL, "admission queue opened (%s)", q ? "ok" : err))
		return;

	/* The examples. */
	const char *BIG = "{\"method\":\"ed\",\"dimensions\":3,\"particles\":{\"count\":100000000,\"volume_fraction\":0.3},"
	                  "\"run\":{\"until\":{\"time\":1}}}";
	submit(q, BIG, &rc, NULL, err);
	ok(rc == JOBQ_EINVAL && !strncmp(err, "particles.count: the job needs an estimated ", 44) && strstr(err, " GB (") &&
	   strstr(err, "memory_budget"), "1e8 particles refused by memory, naming the key and the estimate: %s", err);
	mc_scene(body, sizeof body, 100, 1000000, "");
	submit(q, body, &rc, NULL, err);
	ok(rc == JOBQ_EINVAL && !strncmp(err, "run.replicas: 1000000 exceeds", 29) && strstr(err, "max_replicas"),
	   "1e6 replicas refused by max_replicas: %s", err);
	mc_scene(body, sizeof body, 300000, 100, "");   /* ~46 B per particle (dsmc 2D): 1.4 GB in all */
	submit(q, body, &rc, NULL, err);
	ok(rc == JOBQ_EINVAL && !strncmp(err, "run.replicas: the job needs", 27),
	   "100 replicas of 3e5 particles: the replicas named (one would fit): %s", err);
	snprintf(body, sizeof body, "{\"scene\":%s,\"ranks\":2}", BIG);
	ok(validate(q, body, NULL, err) == JOBQ_EINVAL && !strncmp(err, "scene.particles.count", 21),
	   "validation refuses it alike: %s", err);
	json_t *adv = NULL;
	ok(jobq_advice(q, BIG, strlen(BIG), &adv, err, sizeof(err)) == JOBQ_EINVAL && !strncmp(err, "particles.count", 15),
	   "advice refuses it alike: %s", err);
	json_decref(adv);

	/* Fits alone, not beside another: the second waits for the first. */
	mc_scene(body, sizeof body, 1000000, 1, "");
	rc = validate(q, body, &res, err);
	long long need = res_int(res, "memory_bytes");
	ok(rc == 0 && need > 100000000 && need < 500000000, "validate: a 1e6-particle job needs %.0f MB", need / 1e6);
	json_decref(res);
	jobq_close(q);
	al.memory_budget = (uint64_t)(1.5 * (double)need);
	q = jobq_open(":memory:", &al, err, sizeof(err));
	int64_t j1 = submit(q, body, &rc, NULL, err), j2 = submit(q, body, &rc, NULL, err);
	mc_scene(body, sizeof body, 1000, 1, "");
	int64_t j3 = submit(q, body, &rc, NULL, err);
	jobq_claim_t cl;
	rc = jobq_claim(q, 4, 200.0, &cl, err, sizeof(err));
	ok(rc == 0 && cl.id == j1, "budget 1.5 x one job: the first claimed");
	free(cl.scene);
	rc = jobq_claim(q, 4, 201.0, &cl, err, sizeof(err));
	ok(rc == JOBQ_EEMPTY && !strcmp(state_of(q, j2, sb), "queued") && !strcmp(state_of(q, j3, sb), "queued"),
	   "the second waits with 3 slots free (memory), and the small third does not overtake it");
	jobq_attempt_finished(q, j1, 1, 300.0, 0, 0, NULL, "", JOB_SUCCEEDED);
	rc = jobq_claim(q, 4, 301.0, &cl, err, sizeof(err));
	ok(rc == 0 && cl.id == j2, "when the first ends, the second starts");
	free(cl.scene);
	rc = jobq_claim(q, 4, 302.0, &cl, err, sizeof(err));
	ok(rc == 0 && cl.id == j3, "and the small one fits beside it");
	free(cl.scene);
	json_t *job = NULL;
	jobq_get(q, j2, 0, &job, err, sizeof(err));
	ok(json_integer_value(json_object_get(json_object_get(job, "resources"), "memory_bytes")) == need,
	   "the job keeps its estimate in resources.memory_bytes");
	json_decref(job);
	jobq_close(q);

	/* Output: the server's limit, a job's own smaller one, and its bounds. */
	al.memory_budget = 0;
	q = jobq_open(":memory:", &al, err, sizeof(err));
	mc_scene(body, sizeof body, 100000, 1, ",\"output\":{\"snapshots\":{\"every\":{\"time\":0.001}}}");
	submit(q, body, &rc, NULL, err);
	ok(rc == JOBQ_EINVAL && !strncmp(err, "output.snapshots.every: the job would write an estimated ", 57) &&
	   strstr(err, "max_job_output"), "1001 frames of 1e5 particles exceed the server's 200 MiB: %s", err);
	/* curves count too: 1001 samples of fields on 181 x 181 cells (5 values per cell: about 4 GB of
	 * observables.jsonl and trajectory.h5 rows) while the 1001 frames of 1000 particles are 32 MB */
	mc_scene(body, sizeof body, 1000, 1, ",\"output\":{\"observables\":[\"temperature\",\"fields\"],"
	         "\"fields\":{\"cells\":[181,181]},\"snapshots\":{\"every\":{\"time\":0.001}}}");
	submit(q, body, &rc, NULL, err);
	ok(rc == JOBQ_EINVAL && !strncmp(err, "output.snapshots.every: the job would write an estimated ", 57) &&
	   strstr(err, "1001 curve samples: "), "1001 samples of fields on 32761 cells exceed 200 MiB: %s", err);
	mc_scene(body, sizeof body, 1000, 1, ",\"output\":{\"observables\":[\"temperature\",\"fields\"],"
	         "\"fields\":{\"cells\":[181,181]},\"snapshots\":{\"every\":{\"time\":0.1}}}");
	rc = validate(q, body, &res, err);
	ok(rc == 0 && res_int(res, "curve_samples") == 11 && res_int(res, "curves_bytes") > 11 * 32761LL * 5 * 8 &&
	   res_int(res, "output_bytes") > res_int(res, "curves_bytes"),
	   "11 samples fit: curves %.1f MB of %.1f MB estimated", res_int(res, "curves_bytes") / 1e6,
	   res_int(res, "output_bytes") / 1e6);
	json_decref(res);
	mc_scene(body, sizeof body, 100000, 1, ",\"output\":{\"snapshots\":{\"every\":{\"time\":0.1}}}");
	rc = validate(q, body, &res, err);
	long long out = res_int(res, "output_bytes");
	ok(rc == 0 && res_int(res, "frames") == 11 && out > 11 * 3200000LL && res_int(res, "max_output_bytes") == 200 << 20,
	   "11 frames fit: output %.1f MB estimated", out / 1e6);
	json_decref(res);
	char wrap[1200];
	snprintf(wrap, sizeof wrap, "{\"scene\":%s,\"max_output_bytes\":%lld}", body, out / 2);
	submit(q, wrap, &rc, NULL, err);
	ok(rc == JOBQ_EINVAL && !strncmp(err, "scene.output.snapshots.every", 28) && strstr(err, "(max_output_bytes)"),
	   "the same job with max_output_bytes of half its estimate: %s", err);
	snprintf(wrap, sizeof wrap, "{\"scene\":%s,\"max_output_bytes\":%lld}", body, 2 * out);
	int64_t lim_job = submit(q, wrap, &rc, &created, err);
	uint64_t got = 0;
	int lr = jobq_output_limit(q, lim_job, &got);
	ok(rc == 0 && created && lr == 0 && got == (uint64_t)(2 * out),
	   "with twice its estimate it is queued, and its limit is kept (%llu)", (unsigned long long)got);
	int64_t plain = submit(q, body, &rc, NULL, err);
	lr = jobq_output_limit(q, plain, &got);
	ok(rc == 0 && lr == 0 && got == 200u << 20, "a job without max_output_bytes has the server's limit (%llu)",
	   (unsigned long long)got);
	snprintf(wrap, sizeof wrap, "{\"scene\":%s,\"max_output_bytes\":%llu}", body, (1ull << 40));
	submit(q, wrap, &rc, NULL, err);
	ok(rc == JOBQ_EINVAL && !strncmp(err, "max_output_bytes: 1099511627776 exceeds", 39),
	   "max_output_bytes above the server's refused: %s", err);
	snprintf(wrap, sizeof wrap, "{\"scene\":%s,\"max_output_bytes\":1000}", body);
	submit(q, wrap, &rc, NULL, err);
	ok(rc == JOBQ_EINVAL && !strncmp(err, "max_output_bytes: must be", 25), "max_output_bytes below 1 MiB refused");

	/* Validate = submit = start: the engine's start checks at every door. */
	static const struct { const char *scene, *key; } starts[] = {
		{"{\"method\":\"dsmc\",\"dimensions\":2,\"particles\":{\"count\":1000,\"volume_fraction\":0.1},"
		 "\"run\":{\"until\":{\"time\":1}},\"dsmc\":{\"cell_size\":1e-9}}", "dsmc.cell_size"},
		{"{\"method\":\"ed\",\"dimensions\":2,\"particles\":{\"count\":1000,\"volume_fraction\":0.6,"
		 "\"initial\":{\"positions\":\"random\"}},\"run\":{\"until\":{\"time\":1}}}", "particles.initial.positions"},
	};
	for (size_t i = 0; i < sizeof starts / sizeof starts[0]; i++) {
		char e1[512] = "", e2[512] = "", e3[512] = "";
		submit(q, starts[i].scene, &rc, NULL, e1);
		int r2 = validate(q, starts[i].scene, NULL, e2);
		int r3 = jobq_advice(q, starts[i].scene, strlen(starts[i].scene), &adv, e3, sizeof(e3));
		json_decref(adv);
		size_t kl = strlen(starts[i].key);
		ok(rc == JOBQ_EINVAL && r2 == JOBQ_EINVAL && r3 == JOBQ_EINVAL && !strncmp(e1, starts[i].key, kl) &&
		   !strcmp(e1, e2) && !strcmp(e1, e3), "submission, validation and advice refuse alike: %s", e1);
	}
	const char *AUTO = "{\"method\":\"auto\",\"accuracy\":{\"temperature\":0.9},\"dimensions\":2,"
	                   "\"particles\":{\"count\":1000,\"volume_fraction\":0.05},\"collisions\":{\"restitution\":0.99},"
	                   "\"run\":{\"until\":{\"time\":500},\"replicas\":2},\"output\":{\"every\":{\"time\":100}}}";
	json_t *v = NULL;
	rc = jobq_validate(q, AUTO, strlen(AUTO), &v, err, sizeof(err));
	const char *vm = json_string_value(json_object_get(v, "method"));
	int64_t aid = submit(q, AUTO, &rc, NULL, err);
	jobq_get(q, aid, 0, &job, err, sizeof(err));
	ok(vm && json_is_true(json_object_get(v, "valid")) && aid > 0 &&
	   !strcmp(vm, json_string_value(json_object_get(job, "method"))),
	   "validating an auto scene names the method its submission chooses (%s)", vm ? vm : "-");
	json_decref(v);
	json_decref(job);
	jobq_close(q);

	/* A budget lowered below a queued job's estimate: the job can never start; it fails, the next runs. */
	char path[] = "/tmp/jobq_adm.XXXXXX";
	int fd = mkstemp(path);
	close(fd);
	unlink(path);
	al.memory_budget = 1000000000;
	q = jobq_open(path, &al, err, sizeof(err));
	mc_scene(body, sizeof body, 1000000, 1, "");
	int64_t big = submit(q, body, &rc, NULL, err);
	mc_scene(body, sizeof body, 1000, 1, "");
	int64_t small = submit(q, body, &rc, NULL, err);
	jobq_close(q);
	al.memory_budget = (uint64_t)need / 2;
	q = jobq_open(path, &al, err, sizeof(err));
	rc = q ? jobq_claim(q, 4, 400.0, &cl, err, sizeof(err)) : -1;
	jobq_get(q, big, 0, &job, err, sizeof(err));
	const char *why = json_string_value(json_object_get(job, "reason"));
	ok(rc == 0 && cl.id == small && !strcmp(state_of(q, big, sb), "failed") && why && strstr(why, "never start"),
	   "after the budget shrank: the big head job failed (%s), the small one claimed", why ? why : "-");
	if (rc == 0)
		free(cl.scene);
	json_decref(job);
	jobq_close(q);
	char side[64];
	unlink(path);
	snprintf(side, sizeof(side), "%s-wal", path);
	unlink(side);
	snprintf(side, sizeof(side), "%s-shm", path);
	unlink(side);
}

int main(void)
{
	char err[512], sb[32], body[1024];
	int rc, created;
	jobq_t *q = jobq_open(":memory:", &lim, err, sizeof(err));
	if (!ok(q != NULL, "open an in-memory queue (%s)", q ? "ok" : err))
		return 1;

	/* Submission and validation by the engine's scene parser. */
	int64_t a = submit(q, SCENE, &rc, &created, err);
	ok(rc == 0 && a == 1 && created, "a bare scene is accepted as job 1");
	ok(!strcmp(state_of(q, a, sb), "queued"), "a new job is queued");
	submit(q, "{\"method\":\"ed\",\"dimensions\":4,\"particles\":{\"count\":10},\"run\":{\"until\":{\"time\":1}}}", &rc, NULL, err);
	ok(rc == JOBQ_EINVAL && !strncmp(err, "dimensions", 10), "a bad scene is refused with its key path: %s", err);
	submit(q, "{\"scene\":{\"method\":\"ed\",\"dimensions\":2,\"particles\":{\"count\":0},\"run\":{\"until\":{\"time\":1}}}}", &rc, NULL, err);
	ok(rc == JOBQ_EINVAL && !strncmp(err, "scene.particles.count", 21), "in the wrapper the path starts at scene.: %s", err);
	submit(q, "{\"scene\":{}, \"colour\": 1}", &rc, NULL, err);
	ok(rc == JOBQ_EINVAL && strstr(err, "colour"), "unknown wrapper key named: %s", err);
	submit(q, "[1,2]", &rc, NULL, err);
	ok(rc == JOBQ_EINVAL && !strncmp(err, "body", 4), "a non-object body is refused: %s", err);
	submit(q, "{\"a\":", &rc, NULL, err);
	ok(rc == JOBQ_EINVAL && strstr(err, "not valid JSON"), "broken JSON is refused: %s", err);
	submit(q, "{\"a\":[[[[[[[[[[1]]]]]]]]]]}", &rc, NULL, err);
	ok(rc == JOBQ_EINVAL && strstr(err, "nested"), "nesting beyond the limit is refused: %s", err);
	snprintf(body, sizeof(body), "{\"scene\":%s,\"ranks\":5}", SCENE);
	submit(q, body, &rc, NULL, err);
	ok(rc == JOBQ_EINVAL && !strncmp(err, "ranks", 5), "ranks above max_ranks refused: %s", err);
	submit(q, "{\"method\":\"ed\",\"dimensions\":2,\"particles\":{\"count\":2000000,\"volume_fraction\":0.1},\"run\":{\"until\":{\"time\":1}}}",
	       &rc, NULL, err);
	ok(rc == JOBQ_EINVAL && strstr(err, "particles.count"), "particles above max_particles refused: %s", err);
	snprintf(body, sizeof(body), "{\"scene\":%s,\"priority\":5000}", SCENE);
	submit(q, body, &rc, NULL, err);
	ok(rc == JOBQ_EINVAL && !strncmp(err, "priority", 8), "priority out of range refused: %s", err);

	/* Idempotent submission. */
	snprintf(body, sizeof(body), "{\"scene\":%s,\"submission_id\":\"run-42\",\"priority\":3,\"ranks\":2}", SCENE2);
	int64_t b = submit(q, body, &rc, &created, err);
	ok(rc == 0 && b == 2 && created, "wrapper with submission_id creates job 2");
	int64_t b2 = submit(q, body, &rc, &created, err);
	ok(rc == 0 && b2 == b && !created, "the same submission_id and scene return job 2 again, not created");
	snprintf(body, sizeof(body), "{\"scene\":%s,\"submission_id\":\"run-42\"}", SCENE);
	submit(q, body, &rc, NULL, err);
	ok(rc == JOBQ_ECONFLICT, "the same submission_id with another scene conflicts: %s", err);
	snprintf(body, sizeof(body), "{\"scene\":%s,\"submission_id\":\"bad id!\"}", SCENE);
	submit(q, body, &rc, NULL, err);
	ok(rc == JOBQ_EINVAL && !strncmp(err, "submission_id", 13), "submission_id charset checked");

	/* Claims: priority first, then submission order, strictly within slots. */
	int64_t c = submit(q, SCENE, &rc, NULL, err);   /* job 3, priority 0 */
	jobq_claim_t cl;
	rc = jobq_claim(q, 1, 200.0, &cl, err, sizeof(err));
	ok(rc == JOBQ_EEMPTY, "the head job (priority 3, 2 ranks) does not fit 1 slot and is not overtaken");
	rc = jobq_claim(q, 2, 200.0, &cl, err, sizeof(err));
	ok(rc == 0 && cl.id == b && cl.attempt == 1 && cl.ranks == 2 && cl.until_cpp && cl.until == 10,
	   "priority 3 job claimed first with its stop condition");
	free(cl.scene);
	ok(!strcmp(state_of(q, b, sb), "running"), "claimed job is running");
	rc = jobq_claim(q, 1, 201.0, &cl, err, sizeof(err));
	ok(rc == 0 && cl.id == a, "then the oldest priority-0 job (1)");
	free(cl.scene);
	ok(jobq_attempt_launched(q, a, 1, 4242, 777, NULL) == 0, "launch recorded");

	/* Progress storage with downsampling. */
	for (int i = 0; i < 100; i++) {
		char line[256];
		snprintf(line, sizeof(line), "{\"type\":\"progress\",\"time\":%g,\"events\":%d,\"collisions\":%d}", 0.01 * i,
		         10 * i, 5 * i);
		json_t *rj = json_loads(line, 0, NULL);
		jobq_attempt_progress(q, a, 1, line, rj, 0.01 * i, 300.0 + i);   /* until time 1 */
		json_decref(rj);
	}
	{
		const char *sum = "{\"type\":\"summary\",\"status\":\"completed\",\"time\":1}";
		json_t *rj = json_loads(sum, 0, NULL);
		jobq_attempt_progress(q, a, 1, sum, rj, 1.0, 400.0);
		json_decref(rj);
	}
	json_t *pr = NULL;
	rc = jobq_progress(q, a, -1, 100000, 0, &pr, err, sizeof(err));
	json_t *recs = json_object_get(pr, "records");
	size_t nrec = json_array_size(recs);
	int monotone = 1;
	for (size_t i = 1; i < nrec; i++)
		monotone &= json_integer_value(json_object_get(json_array_get(recs, i), "seq")) >
		            json_integer_value(json_object_get(json_array_get(recs, i - 1), "seq"));
	ok(rc == 0 && nrec <= 17 && nrec >= 8 && monotone, "101 records downsampled to %zu (limit 16), in order", nrec);
	ok(json_integer_value(json_object_get(pr, "stride")) >= 8, "stride doubled to %lld",
	   (long long)json_integer_value(json_object_get(pr, "stride")));
	ok(!strcmp(json_string_value(json_object_get(json_array_get(recs, nrec - 1), "type")), "summary"),
	   "the summary record is kept");
	ok(json_integer_value(json_object_get(json_array_get(recs, 0), "seq")) == 0, "the first record is kept");
	json_decref(pr);
	json_t *jj = NULL;
	jobq_get(q, a, 0, &jj, err, sizeof(err));
	ok(json_real_value(json_object_get(jj, "progress")) == 1.0 && json_integer_value(json_object_get(jj, "events")) == 990,
	   "job row carries progress fraction 1 and the latest event count");
	json_decref(jj);

	/* A retry's series: attempt 1 ran to time 5 (interrupted summary at 5);
	 * attempt 2 resumed from a checkpoint at 2.5 and re-emits 3, 4, ...;
	 * attempt 3 starts afresh at 0. Each retry's first progress record
	 * drops the earlier attempts' progress at or after its time. */
	{
		static const struct { int attempt; const char *line; } rs[] = {
			{1, "{\"type\":\"progress\",\"time\":0}"}, {1, "{\"type\":\"progress\",\"time\":1}"},
			{1, "{\"type\":\"progress\",\"time\":2}"}, {1, "{\"type\":\"progress\",\"time\":3}"},
			{1, "{\"type\":\"progress\",\"time\":4}"}, {1, "{\"type\":\"summary\",\"status\":\"interrupted\",\"time\":4.5}"},
			{2, "{\"type\":\"warning\",\"message\":\"x\"}"},
			{2, "{\"type\":\"progress\",\"time\":3}"}, {2, "{\"type\":\"progress\",\"time\":4}"},
		};
		for (size_t i = 0; i < sizeof rs / sizeof rs[0]; i++) {
			json_t *rj = json_loads(rs[i].line, 0, NULL);
			jobq_attempt_progress(q, b, rs[i].attempt, rs[i].line, rj, -1, 500.0 + (double)i);
			json_decref(rj);
		}
		char got[256];
		series_of(q, b, got, sizeof got);
		ok(!strcmp(got, "p0 p1 p2 s4.5 w0 p3 p4"), "resumed retry: repeated records dropped, summary kept: %s", got);
		const char *fresh = "{\"type\":\"progress\",\"time\":0}";
		json_t *rj = json_loads(fresh, 0, NULL);
		jobq_attempt_progress(q, b, 3, fresh, rj, -1, 600.0);
		json_decref(rj);
		series_of(q, b, got, sizeof got);
		ok(!strcmp(got, "s4.5 w0 p0"), "fresh retry: all earlier progress dropped: %s", got);
	}

	/* Cancel and delete rules. */
	int sig = -1;
	json_t *out = NULL;
	rc = jobq_cancel(q, c, 500.0, &sig, &out, err, sizeof(err));
	ok(rc == 0 && sig == 0 && !strcmp(json_string_value(json_object_get(out, "state")), "cancelled"),
	   "cancelling a queued job ends it at once");
	json_decref(out);
	rc = jobq_cancel(q, c, 501.0, &sig, &out, err, sizeof(err));
	ok(rc == 0, "cancelling it again is a no-op");
	json_decref(out);
	rc = jobq_cancel(q, b, 502.0, &sig, &out, err, sizeof(err));
	ok(rc == 0 && sig == 1 && !strcmp(json_string_value(json_object_get(out, "state")), "running") &&
	       jobq_cancel_requested(q, b) == 1, "cancelling a running job asks the supervisor to stop it");
	json_decref(out);
	ok(jobq_delete(q, b, err, sizeof(err)) == JOBQ_ECONFLICT, "a running job cannot be deleted: %s", err);
	ok(jobq_attempt_finished(q, b, 1, 600.0, -1, 15, "cancelled by request", "tail", JOB_CANCELLED) == 0 &&
	       !strcmp(state_of(q, b, sb), "cancelled"), "the supervisor records the cancellation");
	ok(jobq_attempt_finished(q, a, 1, 610.0, 0, 0, NULL, "", JOB_SUCCEEDED) == 0 && !strcmp(state_of(q, a, sb), "succeeded"),
	   "job 1 succeeds");
	rc = jobq_cancel(q, a, 620.0, &sig, &out, err, sizeof(err));
	ok(rc == JOBQ_ECONFLICT, "a succeeded job cannot be cancelled: %s", err);
	ok(jobq_get(q, a, 0, &out, err, sizeof(err)) == 0 &&
	       json_integer_value(json_object_get(json_array_get(json_object_get(out, "attempts"), 0), "pid")) == 4242 &&
	       json_is_null(json_object_get(json_array_get(json_object_get(out, "attempts"), 0), "signal")),
	   "attempt row holds pid, exit status and NULL signal");
	json_decref(out);
	ok(jobq_delete(q, a, err, sizeof(err)) == 0 && jobq_get(q, a, 0, &out, err, sizeof(err)) == JOBQ_ENOTFOUND,
	   "a finished job can be deleted, and is gone");
	ok(jobq_delete(q, 999, err, sizeof(err)) == JOBQ_ENOTFOUND, "deleting an unknown job: not found");
	int64_t e = submit(q, SCENE, &rc, NULL, err);
	ok(e == 4, "ids are never reused: the next job after deleting job 1 is 4 (got %lld)", (long long)e);
	jobq_cancel(q, e, 630.0, &sig, &out, err, sizeof(err));
	json_decref(out);

	/* Requeue (interrupted attempt) keeps the attempt history. */
	int64_t d = submit(q, SCENE, &rc, NULL, err);
	jobq_claim(q, 4, 700.0, &cl, err, sizeof(err));
	free(cl.scene);
	jobq_running_t *run = NULL;
	size_t nrun = 0;
	jobq_list_running(q, &run, &nrun);
	ok(nrun == 1 && run[0].id == d && run[0].attempt == 1, "the running job is listed for reconciliation");
	free(run);
	jobq_attempt_finished(q, d, 1, 710.0, -1, 0, "daemon restarted", NULL, JOB_QUEUED);
	rc = jobq_claim(q, 4, 720.0, &cl, err, sizeof(err));
	ok(rc == 0 && cl.id == d && cl.attempt == 2 && jobq_attempts(q, d) == 2, "a requeued job runs again as attempt 2");
	free(cl.scene);

	/* Listing: filters and cursor pagination (newest first). */
	for (int i = 0; i < 5; i++)
		submit(q, SCENE, &rc, NULL, err);
	jobq_filter_t f = {.limit = 3};
	json_t *l1 = NULL, *l2 = NULL, *l3 = NULL;
	jobq_list(q, &f, &l1, err, sizeof(err));
	const char *cur = json_string_value(json_object_get(l1, "next_cursor"));
	ok(json_array_size(json_object_get(l1, "jobs")) == 3 && cur, "first page of 3 with a cursor");
	f.cursor = cur ? atoll(cur) : 0;
	jobq_list(q, &f, &l2, err, sizeof(err));
	int64_t last1 = json_integer_value(json_object_get(json_array_get(json_object_get(l1, "jobs"), 2), "id"));
	int64_t first2 = json_integer_value(json_object_get(json_array_get(json_object_get(l2, "jobs"), 0), "id"));
	ok(first2 < last1, "second page continues below the first (%lld < %lld)", (long long)first2, (long long)last1);
	f = (jobq_filter_t){.limit = 100, .states = 1u << JOB_CANCELLED};
	jobq_list(q, &f, &l3, err, sizeof(err));
	ok(json_array_size(json_object_get(l3, "jobs")) == 3 && json_is_null(json_object_get(l3, "next_cursor")),
	   "state filter: the 3 cancelled jobs, no next page");
	json_decref(l1);
	json_decref(l2);
	json_decref(l3);
	json_t *st = NULL;
	jobq_stats(q, 650.0, &st, err, sizeof(err));
	ok(json_integer_value(json_object_get(json_object_get(st, "jobs"), "queued")) == 5 &&
	       json_integer_value(json_object_get(st, "ranks_running")) == 1, "stats: 5 queued, 1 rank running");
	json_decref(st);
	jobq_close(q);

	/* Queue limit. */
	jobq_limits_t small = lim;
	small.max_queued = 2;
	q = jobq_open(":memory:", &small, err, sizeof(err));
	submit(q, SCENE, &rc, NULL, err);
	submit(q, SCENE, &rc, NULL, err);
	submit(q, SCENE, &rc, NULL, err);
	ok(rc == JOBQ_ELIMIT, "a third job beyond max_queued=2 is refused: %s", err);
	jobq_close(q);

	/* Group commit under contention: 8 threads x 40 submissions; 20 keys shared
	 * by all threads and 20 per thread give 20 + 8*20 = 180 distinct jobs. */
	{
		jobq_limits_t big = lim;
		big.max_queued = 100000;
		jobq_t *cq = jobq_open(":memory:", &big, err, sizeof(err));
		worker_t w[8];
		pthread_t th[8];
		for (int t = 0; t < 8; t++) {
			w[t] = (worker_t){.q = cq, .t = t};
			pthread_create(&th[t], NULL, submitter, &w[t]);
		}
		for (int t = 0; t < 8; t++)
			pthread_join(th[t], NULL);
		int64_t all[320];
		int bad = 0, shared_ok = 1;
		for (int t = 0; t < 8; t++)
			for (int i = 0; i < 40; i++) {
				all[t * 40 + i] = w[t].ids[i];
				bad += w[t].ids[i] <= 0;
				if (i % 2 == 0)
					shared_ok &= w[t].ids[i] == w[0].ids[i];
			}
		qsort(all, 320, sizeof(all[0]), cmp64);
		int distinct = 0;
		for (int i = 0; i < 320; i++)
			distinct += i == 0 || all[i] != all[i - 1];
		ok(bad == 0 && distinct == 180 && shared_ok,
		   "8 concurrent submitters: 320 submissions, %d distinct jobs (180 expected), shared keys agree, %d failures",
		   distinct, bad);
		jobq_close(cq);
	}

	/* "method": "auto": the stored scene is the concrete one the advice estimated: the chosen method and, for
	 * dsmc/hsmc, the chosen correction (whatever the model chooses; the target is loose so that every candidate
	 * meets it and the cheapest is taken). The run is long (~150 collisions per particle, weakly dissipative:
	 * Haff time 0.75, inside the measured range) with few outputs, so the MC variants' cost, about 10 moves
	 * per collision, is well below ed's per collision: an MC variant wins by a wide margin whatever the
	 * refitted constants (a short run with many output times would make ed cheaper: every output is a step). */
	{
		static const char *AUTO =
			"{\"method\":\"auto\",\"accuracy\":{\"temperature\":0.9},\"dimensions\":2,"
			"\"particles\":{\"count\":1000,\"volume_fraction\":0.05},\"collisions\":{\"restitution\":0.99},"
			"\"run\":{\"until\":{\"time\":500},\"replicas\":2},\"output\":{\"every\":{\"time\":100}}}";
		json_t *j = NULL;
		q = jobq_open(":memory:", &lim, err, sizeof(err));
		int64_t id = q ? submit(q, AUTO, &rc, NULL, err) : 0;
		if (ok(id > 0 && jobq_get(q, id, 1, &j, err, sizeof(err)) == 0, "auto job submitted (%s)", id > 0 ? "ok" : err)) {
			json_t *sc = json_object_get(j, "scene"), *adv = json_object_get(j, "advice");
			const char *m = json_string_value(json_object_get(sc, "method"));
			const char *v = json_string_value(json_object_get(adv, "choice_variant"));
			const char *corr = json_string_value(json_object_get(json_object_get(sc, m ? m : ""), "correction"));
			const char *rm = json_string_value(json_object_get(json_object_get(adv, "resolved"), "method"));
			ok(m && v && rm && !strcmp(rm, m) && strcmp(m, "ed") && !strncmp(v, m, strlen(m)) && v[strlen(m)] == '/' &&
			   corr && !strcmp(v + strlen(m) + 1, corr) && !json_object_get(sc, "accuracy"),
			   "the stored scene runs the chosen variant %s: method %s, correction %s", v ? v : "-", m ? m : "-",
			   corr ? corr : "-");
		}
		json_decref(j);
		jobq_close(q);
	}

	/* Batches (the supervisor stores a job's records once per interval): the same stored series as one call
	 * per record, the counters on the job, and a record that is not an object refused without a change. */
	{
		jobq_t *q1 = jobq_open(":memory:", &lim, err, sizeof(err)), *q2 = jobq_open(":memory:", &lim, err, sizeof(err));
		int64_t id1 = submit(q1, SCENE, &rc, NULL, err), id2 = submit(q2, SCENE, &rc, NULL, err);
		jobq_claim_t c1, c2;
		jobq_claim(q1, 1, 100.0, &c1, err, sizeof(err));
		jobq_claim(q2, 1, 100.0, &c2, err, sizeof(err));
		free(c1.scene);
		free(c2.scene);
		char lines[101][128];
		json_t *rj[101];
		jobq_record_t batch[101];
		for (int i = 0; i < 101; i++) {
			if (i < 100)
				snprintf(lines[i], sizeof lines[i], "{\"type\":\"progress\",\"time\":%d,\"events\":%d}", i, 3 * i);
			else
				snprintf(lines[i], sizeof lines[i], "{\"type\":\"summary\",\"time\":99}");
			rj[i] = json_loads(lines[i], 0, NULL);
			batch[i] = (jobq_record_t){.line = lines[i], .r = rj[i], .frac = i / 99.0};
			jobq_attempt_progress(q1, id1, 1, lines[i], rj[i], i / 99.0, 200.0);
		}
		/* Batches of 7 (the last one shorter); say 3 records were thinned before each batch. */
		int bad = 0;
		for (int i = 0; i < 101; i += 7)
			bad |= jobq_attempt_progress_batch(q2, id2, 1, batch + i, i + 7 <= 101 ? 7 : (size_t)(101 - i),
			                                   (i + 7 <= 101 ? 7 : 101 - i) + 3, 3, 200.0);
		json_t *p1 = NULL, *p2 = NULL, *j2 = NULL;
		jobq_progress(q1, id1, -1, 1000, 0, &p1, err, sizeof(err));
		jobq_progress(q2, id2, -1, 1000, 0, &p2, err, sizeof(err));
		ok(!bad && p1 && p2 && json_equal(json_object_get(p1, "records"), json_object_get(p2, "records")) &&
		   json_equal(json_object_get(p1, "stride"), json_object_get(p2, "stride")),
		   "101 records in batches of 7 give the series of 101 single stores (%zu records, stride %lld)",
		   json_array_size(json_object_get(p2, "records")), (long long)json_integer_value(json_object_get(p2, "stride")));
		jobq_get(q2, id2, 0, &j2, err, sizeof(err));
		json_t *pc = json_object_get(j2, "progress_records");
		ok(json_integer_value(json_object_get(pc, "received")) == 101 + 3 * 15 &&
		   json_integer_value(json_object_get(pc, "thinned")) == 3 * 15 &&
		   json_integer_value(json_object_get(pc, "stored")) == (json_int_t)json_array_size(json_object_get(p2, "records")) &&
		   json_integer_value(json_object_get(j2, "events")) == 297 && json_real_value(json_object_get(j2, "progress")) == 1.0,
		   "the job counts received, thinned and stored records and carries the latest values");
		json_t *notobj = json_integer(5);
		jobq_record_t badrec = {.line = "5", .r = notobj, .frac = -1};
		json_t *j3 = NULL;
		ok(jobq_attempt_progress_batch(q2, id2, 1, &badrec, 1, 1, 0, 201.0) == JOBQ_EINVAL &&
		   jobq_get(q2, id2, 0, &j3, err, sizeof(err)) == 0 &&
		   json_equal(json_object_get(j3, "progress_records"), pc),
		   "a batch with a record that is not an object is refused and changes nothing");
		json_decref(notobj);
		json_decref(j3);
		json_decref(j2);
		json_decref(p1);
		json_decref(p2);
		for (int i = 0; i < 101; i++)
			json_decref(rj[i]);
		jobq_close(q1);
		jobq_close(q2);
	}

	/* A file database keeps its jobs and schema version across opens; a newer schema is refused. */
	char path[] = "/tmp/jobq_test.XXXXXX";
	int fd = mkstemp(path);
	close(fd);
	unlink(path);
	q = jobq_open(path, &lim, err, sizeof(err));
	submit(q, SCENE, &rc, NULL, err);
	jobq_close(q);
	q = jobq_open(path, &lim, err, sizeof(err));
	ok(q && !strcmp(state_of(q, 1, sb), "queued"), "jobs survive closing and reopening the file");
	jobq_close(q);
	sqlite3 *db = NULL;
	sqlite3_open(path, &db);
	sqlite3_exec(db, "PRAGMA user_version=99", NULL, NULL, NULL);
	sqlite3_close(db);
	q = jobq_open(path, &lim, err, sizeof(err));
	ok(q == NULL && strstr(err, "newer"), "a database from a newer granulard is refused: %s", err);
	jobq_close(q);
	char side[64];
	unlink(path);
	snprintf(side, sizeof(side), "%s-wal", path);
	unlink(side);
	snprintf(side, sizeof(side), "%s-shm", path);
	unlink(side);

	test_admission();
	plan(tap_n);
	return tap_failed != 0;
}
