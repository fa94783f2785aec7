/* REST API handlers and route table: each handler parses its request, calls the job queue, serialises the answer. */
#include <config.h>
#include <errno.h>
#include <inttypes.h>
#include <math.h>
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>
#include "api.h"
#include "curves.h"
#include "dashboard.h"
#include "files.h"
#include "presets.h"
#include "slurm.h"
#include "daemon/openapi_yaml.h"   /* generated from schema/openapi.yaml: openapi_yaml[] */
#include "util.h"


static const struct { int status; const char *code; } error_codes[] = {
	{400, "bad_request"}, {401, "unauthorized"}, {403, "forbidden"}, {404, "not_found"},
	{405, "method_not_allowed"}, {408, "request_timeout"}, {409, "conflict"}, {413, "payload_too_large"},
	{414, "uri_too_long"}, {415, "unsupported_media_type"}, {416, "range_not_satisfiable"},
	{429, "too_many_requests"}, {431, "header_fields_too_large"}, {500, "internal"}, {503, "unavailable"},
};

void api_error(api_resp_t *rs, int status, const char *message)
{
	const char *code = "error";
	for (size_t i = 0; i < sizeof(error_codes) / sizeof(error_codes[0]); i++)
		if (error_codes[i].status == status)
			code = error_codes[i].code;
	json_decref(rs->json);
	rs->status = status;
	rs->json = json_pack("{s:{s:s, s:s}}", "error", "code", code, "message", message);
	if (!rs->json) {
		/* Messages quote request bytes (a path, a query value, cut at a byte
		 * count), which need not be UTF-8, and a JSON string must be: rather
		 * than an answer without a body, send the text with '?' for every
		 * non-ASCII byte. */
		char safe[1024];
		size_t n = 0;
		for (const unsigned char *p = (const unsigned char *)message; *p && n + 1 < sizeof(safe); p++)
			safe[n++] = *p < 0x80 ? (char)*p : '?';
		safe[n] = '\0';
		rs->json = json_pack("{s:{s:s, s:s}}", "error", "code", code, "message", safe);
	}
}

/* Map a queue error to an HTTP answer. */
static void queue_error(api_resp_t *rs, int code, const char *msg)
{
	static const struct { int code, status; } map[] = {
		{JOBQ_EINVAL, 400}, {JOBQ_ENOTFOUND, 404}, {JOBQ_ECONFLICT, 409},
		{JOBQ_ELIMIT, 429}, {JOBQ_EDB, 503}, {JOBQ_ENOMEM, 503}, {JOBQ_EFULL, 503},
	};
	int status = 500;
	for (size_t i = 0; i < sizeof(map) / sizeof(map[0]); i++)
		if (map[i].code == code)
			status = map[i].status;
	api_error(rs, status, msg);
	if (status == 429 || status == 503)
		rs->retry_after = 5;
}

/* An integer in one spelling only: an optional '-', then digits without a
 * leading zero ("0" itself is fine); no '+', no spaces, within long long. */
int api_parse_int(const char *s, long long *v)
{
	char *end;
	const char *d = s && *s == '-' ? s + 1 : s;
	if (!d || *d < '0' || *d > '9' || (d[0] == '0' && d[1]))
		return -1;
	errno = 0;
	long long x = strtoll(s, &end, 10);
	if (*end || errno)
		return -1;
	*v = x;
	return 0;
}

/* Path parameter as a job id; 0 (and a 404 answer) when it is not one. */
static int64_t job_id(const api_req_t *rq, api_resp_t *rs)
{
	long long v;
	if (api_parse_int(rq->params[0], &v) || v <= 0) {
		char m[200];
		snprintf(m, sizeof(m), "job %.100s not found (ids are positive integers, written without sign or leading zeros)",
		         rq->params[0]);
		api_error(rs, 404, m);
		return 0;
	}
	return v;
}

/* Integer query parameter within [lo, hi]; returns 0 and answers 400 on error. */
static int query_int(const api_req_t *rq, api_resp_t *rs, const char *key, long long lo, long long hi,
                     long long *v)
{
	const char *s = rq->query(rq->conn, key);
	char m[200];
	long long x = 0;
	if (!s)
		return 1;
	if (api_parse_int(s, &x) || x < lo || x > hi) {
		snprintf(m, sizeof(m), "%s: must be an integer in %lld..%lld", key, lo, hi);
		api_error(rs, 400, m);
		return 0;
	}
	*v = x;
	return 1;
}

/* ---- jobs ------------------------------------------------------------------ */

static void h_submit(gd_t *gd, const api_req_t *rq, api_resp_t *rs)
{
	char err[1024];
	int created = 0;
	int r = jobq_submit(gd->q, rq->body, rq->body_len, util_now(), &rs->json, &created, err, sizeof(err));
	if (r) {
		queue_error(rs, r, err);
		return;
	}
	rs->status = created ? 201 : 200;
	if (created) {
		int64_t id = json_integer_value(json_object_get(rs->json, "id"));
		sched_publish_state(gd->q, gd->hub, id);
		sched_wake(gd->sched);
	}
}

/* Estimates only: nothing changes, so it is a read (auth as for GET), but it
 * takes a body with the same validation and limits as a submission. */
static void h_advice(gd_t *gd, const api_req_t *rq, api_resp_t *rs)
{
	char err[1024];
	int r = jobq_advice(gd->q, rq->body, rq->body_len, &rs->json, err, sizeof(err));
	if (r)
		queue_error(rs, r, err);
	else
		rs->status = 200;
}

/* The checks of a submission (the engine's own start checks and the
 * admission limits) without submitting; a read, like advice. */
static void h_validate(gd_t *gd, const api_req_t *rq, api_resp_t *rs)
{
	char err[1024];
	int r = jobq_validate(gd->q, rq->body, rq->body_len, &rs->json, err, sizeof(err));
	if (r)
		queue_error(rs, r, err);
	else
		rs->status = 200;
}

static void h_list(gd_t *gd, const api_req_t *rq, api_resp_t *rs)
{
	jobq_filter_t f = {.limit = 100};
	long long limit = 100, cursor = 0;
	char err[256];
	const char *st = rq->query(rq->conn, "state"), *since = rq->query(rq->conn, "since");
	if (!query_int(rq, rs, "limit", 1, 1000, &limit) || !query_int(rq, rs, "cursor", 1, INT64_MAX, &cursor))
		return;
	f.limit = (int)limit;
	f.cursor = cursor;
	if (st) {
		char buf[256];
		snprintf(buf, sizeof(buf), "%s", st);
		for (char *sp = NULL, *t = strtok_r(buf, ",", &sp); t; t = strtok_r(NULL, ",", &sp)) {
			int s = job_state_parse(t);
			if (s < 0) {
				snprintf(err, sizeof(err),
				         "state: '%.64s' is not one of queued, running, succeeded, failed, cancelled", t);
				api_error(rs, 400, err);
				return;
			}
			f.states |= 1u << s;
		}
	}
	if (since) {
		char *end;
		f.since = strtod(since, &end);
		if (!*since || *end || !isfinite(f.since) || f.since < 0) {
			api_error(rs, 400, "since: must be a unix time in seconds");
			return;
		}
	}
	int r = jobq_list(gd->q, &f, &rs->json, err, sizeof(err));
	if (r)
		queue_error(rs, r, err);
	else
		rs->status = 200;
}

static void h_get(gd_t *gd, const api_req_t *rq, api_resp_t *rs)
{
	char err[256];
	int64_t id = job_id(rq, rs);
	if (!id)
		return;
	const char *ws = rq->query(rq->conn, "scene");
	int r = jobq_get(gd->q, id, !ws || strcmp(ws, "0"), &rs->json, err, sizeof(err));
	if (r)
		queue_error(rs, r, err);
	else
		rs->status = 200;
}

static void h_cancel(gd_t *gd, const api_req_t *rq, api_resp_t *rs)
{
	char err[256];
	int sig = 0;
	int64_t id = job_id(rq, rs);
	if (!id)
		return;
	int r = jobq_cancel(gd->q, id, util_now(), &sig, &rs->json, err, sizeof(err));
	if (r) {
		queue_error(rs, r, err);
		return;
	}
	rs->status = 200;
	if (sig)
		sched_cancel(gd->sched, id);
	sched_publish_state(gd->q, gd->hub, id);
}

static void h_delete(gd_t *gd, const api_req_t *rq, api_resp_t *rs)
{
	char err[256], dir[4200];
	int64_t id = job_id(rq, rs);
	if (!id)
		return;
	int r = jobq_delete(gd->q, id, err, sizeof(err));
	snprintf(dir, sizeof(dir), "%s/%" PRId64, gd->jobs_dir, id);
	if (r == JOBQ_EDB || r == JOBQ_EFULL) {
		/* On a full disk the row's deletion itself needs room in the journal:
		 * free the job's files first (they are what fills disks), then retry. */
		json_t *j = NULL;
		char e2[256];
		if (jobq_get(gd->q, id, 0, &j, e2, sizeof(e2)) == JOBQ_OK) {
			const char *st = json_string_value(json_object_get(j, "state"));
			if (st && strcmp(st, "queued") && strcmp(st, "running")) {
				util_rmtree(dir);
				r = jobq_delete(gd->q, id, err, sizeof(err));
			}
		}
		json_decref(j);
	}
	if (r) {
		queue_error(rs, r, err);
		return;
	}
	/* Normally the row goes first: a crash here leaves an orphan directory, never a job without files. */
	util_rmtree(dir);
	rs->status = 200;
	rs->json = json_pack("{s:I, s:b}", "id", (json_int_t)id, "deleted", 1);
	hub_publish(gd->hub, id, "deleted", "{}");
}

static void series(gd_t *gd, const api_req_t *rq, api_resp_t *rs, int clusters)
{
	char err[256];
	long long after = -1, limit = 100000;
	int64_t id = job_id(rq, rs);
	if (!id || !query_int(rq, rs, "after", -1, INT64_MAX, &after) ||
	    !query_int(rq, rs, "limit", 1, 100000, &limit))
		return;
	int r = jobq_progress(gd->q, id, after, (int)limit, clusters, &rs->json, err, sizeof(err));
	if (r)
		queue_error(rs, r, err);
	else
		rs->status = 200;
}

static void h_progress(gd_t *gd, const api_req_t *rq, api_resp_t *rs) { series(gd, rq, rs, 0); }

static void h_clusters(gd_t *gd, const api_req_t *rq, api_resp_t *rs)
{
	series(gd, rq, rs, 1);
	if (rs->status != 200)
		return;
	/* Only the cluster statistics and the clock of each record. */
	json_t *recs = json_object_get(rs->json, "records"), *out = json_array(), *r;
	size_t i;
	json_array_foreach(recs, i, r) {
		json_t *o = json_object();
		static const char *const keep[] = {"seq", "time", "collisions_per_particle", "clusters"};
		for (size_t k = 0; k < 4; k++) {
			json_t *v = json_object_get(r, keep[k]);
			if (v)
				json_object_set(o, keep[k], v);
		}
		json_array_append_new(out, o);
	}
	json_object_del(rs->json, "records");
	json_object_set_new(rs->json, "series", out);
}

static void h_events_job(gd_t *gd, const api_req_t *rq, api_resp_t *rs)
{
	char err[256];
	json_t *j = NULL;
	int64_t id = job_id(rq, rs);
	if (!id)
		return;
	int r = jobq_get(gd->q, id, 0, &j, err, sizeof(err));
	json_decref(j);
	if (r) {
		queue_error(rs, r, err);
		return;
	}
	rs->status = 200;
	rs->sse = 1;
	rs->sse_job = id;
}

static void h_events_all(gd_t *gd, const api_req_t *rq, api_resp_t *rs)
{
	rs->status = 200;
	rs->sse = 1;
	rs->sse_job = 0;
}

/* ---- files ----------------------------------------------------------------- */

/* The job must exist (a deleted job's leftovers are not served). */
static int job_dir(gd_t *gd, const api_req_t *rq, api_resp_t *rs, char *dir, size_t n)
{
	char err[256];
	json_t *j = NULL;
	int64_t id = job_id(rq, rs);
	if (!id)
		return 0;
	int r = jobq_get(gd->q, id, 0, &j, err, sizeof(err));
	json_decref(j);
	if (r) {
		queue_error(rs, r, err);
		return 0;
	}
	snprintf(dir, n, "%s/%" PRId64, gd->jobs_dir, id);
	return 1;
}

static void h_files(gd_t *gd, const api_req_t *rq, api_resp_t *rs)
{
	char dir[4200], err[512];
	if (!job_dir(gd, rq, rs, dir, sizeof(dir)))
		return;
	if (files_list(dir, &rs->json, err, sizeof(err))) {
		api_error(rs, 500, err);
		return;
	}
	rs->status = 200;
}

static void h_file(gd_t *gd, const api_req_t *rq, api_resp_t *rs)
{
	char dir[4200], err[512];
	uint64_t size = 0, off = 0, len = 0;
	int fd = -1;
	if (!job_dir(gd, rq, rs, dir, sizeof(dir)))
		return;
	int r = files_open(dir, rq->params[1], &fd, &size, err, sizeof(err));
	if (r) {
		api_error(rs, r == FILES_ENAME ? 400 : 404, err);
		return;
	}
	int part = files_range(rq->header(rq->conn, "Range"), size, &off, &len);
	if (part < 0) {
		close(fd);
		snprintf(err, sizeof(err), "Range: not satisfiable for a file of %" PRIu64 " bytes", size);
		api_error(rs, 416, err);
		rs->file_size = size;
		return;
	}
	rs->status = part ? 206 : 200;
	rs->has_file = 1;
	rs->fd = fd;
	rs->file_off = part ? off : 0;
	rs->file_len = part ? len : size;
	rs->file_size = size;
	rs->ctype = files_content_type(rq->params[1]);
	snprintf(rs->disposition, sizeof(rs->disposition), "attachment; filename=\"%s\"", rq->params[1]);
}

/* The curves of one observable family (DIR/observables.jsonl): ?name= (required), after= (sample index),
 * limit= (the first N after it) or last= (the last N). */
static void h_observables(gd_t *gd, const api_req_t *rq, api_resp_t *rs)
{
	char dir[4200], err[600];
	long long after = -1, limit = 0, last = 0;
	if (!job_dir(gd, rq, rs, dir, sizeof(dir)))
		return;
	const char *name = rq->query(rq->conn, "name");
	if (!name) {
		char known[400] = "";
		for (int i = 0; curves_families[i]; i++)
			snprintf(known + strlen(known), sizeof(known) - strlen(known), "%s%s", i ? ", " : "", curves_families[i]);
		snprintf(err, sizeof(err), "name: required, one of %s", known);
		api_error(rs, 400, err);
		return;
	}
	if (!query_int(rq, rs, "after", -1, INT64_MAX, &after) || !query_int(rq, rs, "limit", 1, 1000, &limit) ||
	    !query_int(rq, rs, "last", 1, 1000, &last))
		return;
	if (limit && last) {
		api_error(rs, 400, "last: not with limit (the first N samples or the last N, not both)");
		return;
	}
	int r = curves_read(dir, name, after, last ? (int)last : limit ? (int)limit : 100, last != 0, &rs->json, err,
	                    sizeof(err));
	if (r) {
		api_error(rs, r == CURVES_ENAME ? 400 : r == CURVES_ENOMEM ? 503 : 500, err);
		return;
	}
	rs->status = 200;
}

/* ---- service --------------------------------------------------------------- */

/* The Slurm partition (slurm.h), asked for at most once a second whatever
 * the number of clients (each answer runs sinfo and squeue); a failure is
 * shown as {"error": "..."}. A new reference. */
static json_t *slurm_summary(const cfg_t *cfg, double now)
{
	static pthread_mutex_t lock = PTHREAD_MUTEX_INITIALIZER;
	static json_t *cached;
	static double at;
	json_t *j = NULL;
	pthread_mutex_lock(&lock);
	if (!cached || now - at >= 1.0 || now < at) {
		char err[512];
		json_decref(cached);
		if (slurm_partition(cfg, &cached, err, sizeof(err)))
			cached = json_pack("{s:s}", "error", err);
		at = now;
	}
	j = json_incref(cached);
	pthread_mutex_unlock(&lock);
	return j;
}

static void h_cluster(gd_t *gd, const api_req_t *rq, api_resp_t *rs)
{
	char err[256];
	sched_stats_t st;
	double now = util_now();
	int r = jobq_stats(gd->q, now, &rs->json, err, sizeof(err));
	if (r) {
		queue_error(rs, r, err);
		return;
	}
	sched_stats(gd->sched, &st);
	json_object_set_new(rs->json, "slots", json_pack("{s:i, s:i, s:i}", "total", st.slots, "used", st.used, "free",
	                                                 st.slots - st.used));
	json_object_set_new(rs->json, "events_per_second", json_real(st.events_per_second));
	json_object_set_new(rs->json, "uptime_seconds", json_real(now - gd->started));
	json_object_set_new(rs->json, "version", json_string(PACKAGE_VERSION));
	json_object_set_new(rs->json, "launcher", json_string(gd->cfg->launcher));
	if (!strcmp(gd->cfg->launcher, "slurm"))
		json_object_set_new(rs->json, "slurm", slurm_summary(gd->cfg, now));
	rs->status = 200;
}

static void h_healthz(gd_t *gd, const api_req_t *rq, api_resp_t *rs)
{
	json_t *j = NULL;
	char err[256];
	/* Healthy = the database answers. */
	int r = jobq_stats(gd->q, util_now(), &j, err, sizeof(err));
	json_decref(j);
	if (r) {
		api_error(rs, 503, err);
		return;
	}
	rs->status = 200;
	/* Still 200 on a full disk (the service answers and can end jobs), but say so. */
	rs->json = json_pack("{s:s, s:s}", "status",
	                     atomic_load(&gd->stopping) ? "stopping" : jobq_low_space(gd->q) ? "disk_full" : "ok",
	                     "version", PACKAGE_VERSION);
}

static void h_metrics(gd_t *gd, const api_req_t *rq, api_resp_t *rs)
{
	json_t *j = NULL, *v;
	char err[256];
	const char *k;
	sched_stats_t st;
	size_t cap = 8192, o = 0;
	char *b = malloc(cap);
	if (!b || jobq_stats(gd->q, util_now(), &j, err, sizeof(err))) {
		free(b);
		api_error(rs, 503, "statistics unavailable");
		return;
	}
	sched_stats(gd->sched, &st);
#define P(...) o += (size_t)snprintf(b + o, o < cap ? cap - o : 0, __VA_ARGS__)
	P("# HELP granulard_jobs Jobs by state.\n# TYPE granulard_jobs gauge\n");
	json_object_foreach(json_object_get(j, "jobs"), k, v)
		P("granulard_jobs{state=\"%s\"} %" JSON_INTEGER_FORMAT "\n", k, json_integer_value(v));
	P("# HELP granulard_slots MPI ranks the daemon may run at once.\n# TYPE granulard_slots gauge\n"
	  "granulard_slots %d\n", st.slots);
	P("# HELP granulard_slots_used MPI ranks running.\n# TYPE granulard_slots_used gauge\n"
	  "granulard_slots_used %d\n", st.used);
	P("# HELP granulard_events_per_second Engine events per second, summed over running jobs.\n"
	  "# TYPE granulard_events_per_second gauge\ngranulard_events_per_second %.6g\n", st.events_per_second);
	P("# HELP granulard_jobs_finished_last_hour Jobs that ended in the last hour.\n"
	  "# TYPE granulard_jobs_finished_last_hour gauge\ngranulard_jobs_finished_last_hour %" JSON_INTEGER_FORMAT "\n",
	  json_integer_value(json_object_get(j, "finished_last_hour")));
	P("# HELP granulard_http_requests_total HTTP requests answered, by status class.\n"
	  "# TYPE granulard_http_requests_total counter\n");
	for (int c = 1; c <= 5; c++)
		P("granulard_http_requests_total{class=\"%dxx\"} %ld\n", c, atomic_load(&gd->responses_by_class[c]));
	P("# HELP granulard_http_connections Client connections held open.\n# TYPE granulard_http_connections gauge\n"
	  "granulard_http_connections %d\n", atomic_load(&gd->open_connections));
	P("# HELP granulard_http_streams Event streams open.\n# TYPE granulard_http_streams gauge\n"
	  "granulard_http_streams %d\n", atomic_load(&gd->open_streams));
	P("# HELP granulard_http_connections_refused_total Connections refused: table full of busy ones.\n"
	  "# TYPE granulard_http_connections_refused_total counter\ngranulard_http_connections_refused_total %ld\n",
	  atomic_load(&gd->refused_connections));
	P("# HELP granulard_http_connections_evicted_total Idle or slow connections closed for a new one or on timeout.\n"
	  "# TYPE granulard_http_connections_evicted_total counter\ngranulard_http_connections_evicted_total %ld\n",
	  atomic_load(&gd->evicted_connections));
	P("# HELP granulard_uptime_seconds Seconds since the daemon started.\n# TYPE granulard_uptime_seconds gauge\n"
	  "granulard_uptime_seconds %.3f\n", util_now() - gd->started);
#undef P
	json_decref(j);
	if (o >= cap) {
		free(b);
		api_error(rs, 500, "metrics too large");
		return;
	}
	rs->status = 200;
	rs->owned = b;
	rs->raw_len = o;
	rs->ctype = "text/plain; version=0.0.4; charset=utf-8";
}

static void h_openapi(gd_t *gd, const api_req_t *rq, api_resp_t *rs)
{
	rs->status = 200;
	rs->raw = openapi_yaml;
	rs->raw_len = sizeof(openapi_yaml) - 1;
	rs->ctype = "application/yaml";
}

/* ---- presets (built-in scenes) --------------------------------------------- */

static void h_presets(gd_t *gd, const api_req_t *rq, api_resp_t *rs)
{
	char err[256];
	if (presets_list(&rs->json, err, sizeof(err)) != PRESETS_OK)
		api_error(rs, 500, err);
	else
		rs->status = 200;
}

static void h_preset(gd_t *gd, const api_req_t *rq, api_resp_t *rs)
{
	char err[256];
	int r = presets_get(rq->params[0], &rs->json, err, sizeof(err));
	if (r != PRESETS_OK)
		api_error(rs, r == PRESETS_ENOTFOUND ? 404 : 500, err);
	else
		rs->status = 200;
}

/* ---- dashboard (embedded dashboard/ files) ----------------------------------- */

static void serve_file(api_resp_t *rs, const char *name)
{
	dashboard_file_t f;
	char m[200];
	if (dashboard_find(name, &f)) {
		snprintf(m, sizeof(m), "no such file: %.100s", name);
		api_error(rs, 404, m);
		return;
	}
	rs->status = 200;
	rs->raw = f.data;
	rs->raw_len = f.len;
	rs->ctype = f.ctype;
}

/* Browsers ask for it on every page; an empty answer keeps their consoles clean. */
static void h_favicon(gd_t *gd, const api_req_t *rq, api_resp_t *rs)
{
	rs->status = 204;
	rs->raw = "";
	rs->raw_len = 0;
	rs->ctype = "image/x-icon";
}

static void h_index(gd_t *gd, const api_req_t *rq, api_resp_t *rs) { serve_file(rs, "index.html"); }

static void h_static(gd_t *gd, const api_req_t *rq, api_resp_t *rs) { serve_file(rs, rq->params[0]); }

/* ---- routes ---------------------------------------------------------------- */

const api_route_t api_routes[] = {
	{.method = "GET", .pattern = "/", .fn = h_index, .flags = API_OPEN | API_INLINE},
	{.method = "GET", .pattern = "/healthz", .fn = h_healthz, .flags = API_OPEN},
	{.method = "GET", .pattern = "/favicon.ico", .fn = h_favicon, .flags = API_OPEN | API_INLINE},
	{.method = "GET", .pattern = "/metrics", .fn = h_metrics},
	{.method = "GET", .pattern = "/api/v1/openapi.yaml", .fn = h_openapi, .flags = API_OPEN | API_INLINE},
	{.method = "POST", .pattern = "/api/v1/jobs", .fn = h_submit, .flags = API_MUTATES},
	{.method = "GET", .pattern = "/api/v1/jobs", .fn = h_list},
	{.method = "GET", .pattern = "/api/v1/jobs/{id}", .fn = h_get},
	{.method = "DELETE", .pattern = "/api/v1/jobs/{id}", .fn = h_delete, .flags = API_MUTATES},
	{.method = "POST", .pattern = "/api/v1/jobs/{id}/cancel", .fn = h_cancel, .flags = API_MUTATES},
	{.method = "GET", .pattern = "/api/v1/jobs/{id}/progress", .fn = h_progress},
	{.method = "GET", .pattern = "/api/v1/jobs/{id}/clusters", .fn = h_clusters},
	{.method = "GET", .pattern = "/api/v1/jobs/{id}/events", .fn = h_events_job},
	{.method = "GET", .pattern = "/api/v1/jobs/{id}/observables", .fn = h_observables},
	{.method = "GET", .pattern = "/api/v1/jobs/{id}/files", .fn = h_files},
	{.method = "GET", .pattern = "/api/v1/jobs/{id}/files/{name}", .fn = h_file},
	{.method = "GET", .pattern = "/api/v1/events", .fn = h_events_all},
	{.method = "POST", .pattern = "/api/v1/advice", .fn = h_advice},
	{.method = "POST", .pattern = "/api/v1/scenes/validate", .fn = h_validate},
	{.method = "GET", .pattern = "/api/v1/cluster", .fn = h_cluster},
	{.method = "GET", .pattern = "/api/v1/presets", .fn = h_presets},
	{.method = "GET", .pattern = "/api/v1/presets/{name}", .fn = h_preset},
	{.method = "GET", .pattern = "/static/{name}", .fn = h_static, .flags = API_OPEN | API_INLINE},
};
const size_t api_nroutes = sizeof(api_routes) / sizeof(api_routes[0]);

/* Match one pattern; segments in {} take any non-empty segment. */
static int match(const char *pat, const char *path, api_req_t *rq, char store[][128])
{
	int np = 0;
	while (*pat && *path) {
		if (*pat == '{') {
			const char *pe = strchr(pat, '}');
			size_t n = strcspn(path, "/");
			if (!pe || n == 0 || n >= 128 || np >= 4)
				return 0;
			memcpy(store[np], path, n);
			store[np][n] = '\0';
			np++;
			pat = pe + 1;
			path += n;
		} else if (*pat++ != *path++) {
			return 0;
		}
	}
	if (*pat || *path)
		return 0;
	for (int i = 0; i < np; i++)
		rq->params[i] = store[i];
	rq->nparams = np;
	return 1;
}

const api_route_t *api_match(const char *method, const char *path, api_req_t *rq, char store[][128],
                             int *path_known, char *allow, size_t allowlen)
{
	const api_route_t *hit = NULL;
	size_t o = 0;
	*path_known = 0;
	allow[0] = '\0';
	for (size_t i = 0; i < api_nroutes; i++) {
		if (!match(api_routes[i].pattern, path, rq, store))
			continue;
		*path_known = 1;
		o += (size_t)snprintf(allow + o, o < allowlen ? allowlen - o : 0, "%s%s", o ? ", " : "",
		                      api_routes[i].method);
		if (!strcmp(api_routes[i].method, method) || (!strcmp(method, "HEAD") && !strcmp(api_routes[i].method, "GET")))
			hit = &api_routes[i];
	}
	if (hit)
		match(hit->pattern, path, rq, store);
	return hit;
}
