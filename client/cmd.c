/* granularctl commands: a table of {name, options, handler}; each handler calls the API and prints a table or the raw JSON. */
#include <config.h>
#include <ctype.h>
#include <errno.h>
#include <getopt.h>
#include <math.h>
#include <stdarg.h>
#include <stdint.h>
#include <stdio.h>
#include <sys/stat.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>
#include "cmd.h"
#include "conn.h"
#include "fmt.h"
#include "jpath.h"
#include "settings.h"

/* Command-specific options; the global ones (--url --token --token-file --state-dir --json --help) go with every command. */
enum {
	O_STATE = 1u << 0, O_LIMIT = 1u << 1, O_ALL = 1u << 2, O_PRESET = 1u << 3, O_SET = 1u << 4,
	O_PRIORITY = 1u << 5, O_RANKS = 1u << 6, O_SUBID = 1u << 7, O_WAIT = 1u << 8, O_OUTPUT = 1u << 9,
	O_AFTER = 1u << 10, O_FORCE = 1u << 11, O_NODES = 1u << 12, O_TLIMIT = 1u << 13, O_PARTITION = 1u << 14,
	O_ACCOUNT = 1u << 15,
};

#define MAX_SETS 64

typedef struct {
	const char *url, *token, *token_file, *state_dir;
	int json, help;
	unsigned given;              /* O_* seen on the command line */
	const char *state, *preset, *subid, *output, *partition, *account;
	const char *sets[MAX_SETS];
	int nsets;
	long long limit, priority, ranks, after, nodes, time_limit;
	char **args;                 /* positional arguments after the command */
	int nargs;
	conn_t *conn;
	settings_t cfg;
	const struct cmd *cmd;
} ctx_t;

typedef int (*cmd_fn)(ctx_t *x);

typedef struct cmd {
	const char *name;
	const char *args;            /* synopsis after the name */
	const char *summary;
	const char *help;            /* option lines */
	cmd_fn fn;
	int min_args, max_args;
	unsigned opts;
} cmd_t;

/* ---- messages ----------------------------------------------------------------- */

static void errf(const char *fmt, ...)
{
	va_list ap;
	va_start(ap, fmt);
	fputs("granularctl: ", stderr);
	vfprintf(stderr, fmt, ap);
	fputc('\n', stderr);
	va_end(ap);
}

static int usage_error(const ctx_t *x, const char *fmt, ...)
{
	va_list ap;
	va_start(ap, fmt);
	fputs("granularctl: ", stderr);
	vfprintf(stderr, fmt, ap);
	fprintf(stderr, "\nTry 'granularctl %s%s--help'.\n", x->cmd ? x->cmd->name : "", x->cmd ? " " : "");
	va_end(ap);
	return CTL_EXIT_USAGE;
}

/* Report a failed API call; the exit status follows the HTTP status. */
static int api_failed(const ctx_t *x, int rc)
{
	long st = conn_status(x->conn);
	if (rc == CONN_EHTTP && st == 401)
		errf("%s (token from %s)", conn_error(x->conn), x->cfg.token_source);
	else
		errf("%s", conn_error(x->conn));
	if (rc == CONN_EHTTP && (st == 401 || st == 403 || st == 404 || st == 409))
		return CTL_EXIT_REFUSED;
	if (rc == CONN_EHTTP && (st == 400 || st == 413 || st == 415))
		return CTL_EXIT_USAGE;   /* the server says our input is wrong (a scene error, say) */
	return CTL_EXIT_SERVER;
}

static void print_json(const json_t *j)
{
	char *s = json_dumps(j, JSON_INDENT(2) | JSON_PRESERVE_ORDER);
	if (s)
		puts(s);
	free(s);
}

static double num(const json_t *o, const char *key)
{
	const json_t *v = json_object_get(o, key);
	return json_is_number(v) ? json_number_value(v) : NAN;
}

static const char *str(const json_t *o, const char *key, const char *dflt)
{
	const char *s = json_string_value(json_object_get(o, key));
	return s ? s : dflt;
}

/* A job id argument: a positive integer (anything else cannot be a job). */
static int job_arg(const ctx_t *x, const char *a, long long *id)
{
	char *end;
	errno = 0;
	*id = strtoll(a, &end, 10);
	if (!*a || *end || errno || *id <= 0)
		return usage_error(x, "ID '%s': not a job id (a positive integer)", a);
	return 0;
}

static int terminal(const char *state)
{
	return state && (!strcmp(state, "succeeded") || !strcmp(state, "failed") || !strcmp(state, "cancelled"));
}

/* GET/POST/DELETE path; on success print --json output when asked. *out is the caller's. */
/* Find the server lazily: usage errors are reported before any server is looked for. */
static int ensure_conn(ctx_t *x)
{
	char err[1024];
	if (x->conn)
		return CTL_EXIT_OK;
	int r = settings_init(&x->cfg, x->url, x->token, x->token_file, x->state_dir, err, sizeof(err));
	if (r != SETTINGS_OK) {
		errf("%s", err);
		return r == SETTINGS_ETOKEN ? CTL_EXIT_USAGE : CTL_EXIT_SERVER;
	}
	if (!(x->conn = conn_create(x->cfg.url, x->cfg.token))) {
		errf("out of memory");
		return CTL_EXIT_SERVER;
	}
	return CTL_EXIT_OK;
}

static int call(ctx_t *x, const char *method, const char *path, const char *body, json_t **out)
{
	int rc = ensure_conn(x);
	if (rc != CTL_EXIT_OK)
		return rc;
	rc = conn_request(x->conn, method, path, body, out);
	if (rc != CONN_OK)
		return api_failed(x, rc);
	return CTL_EXIT_OK;
}

/* ---- watch (also submit --wait) --------------------------------------------------- */

typedef struct {
	ctx_t *x;
	long long id;
	double until_time, until_cpp;   /* the job's stop condition, 0 when not of that kind */
	double last_wall, last_events, rate;
	int tty, drawn;
	int next_decile;                /* non-terminal output: next tenth of the run to print at */
	char state[16];
	char reason[512];
	int deleted;
} watch_t;

static void draw(watch_t *w, const json_t *r)
{
	char bar[64], eta[32], rate[32], line[256];
	double t = num(r, "time"), cpp = num(r, "collisions_per_particle"), temp = num(r, "temperature");
	double wall = num(r, "wall_seconds"), ev = num(r, "events"), f = NAN;
	int summary = !strcmp(str(r, "type", ""), "summary");
	if (summary && !strcmp(str(r, "status", ""), "completed"))
		f = 1;
	else if (w->until_time > 0 && isfinite(t))
		f = t / w->until_time;
	else if (w->until_cpp > 0 && isfinite(cpp))
		f = cpp / w->until_cpp;
	if (isfinite(f) && f > 1)
		f = 1;
	if (!summary && isfinite(wall) && isfinite(ev) && wall > w->last_wall && w->last_wall >= 0)
		w->rate = (ev - w->last_events) / (wall - w->last_wall);
	if (isfinite(wall) && isfinite(ev)) {
		w->last_wall = wall;
		w->last_events = ev;
	}
	double left = isfinite(f) && f > 0 && isfinite(wall) ? wall * (1 - f) / f : NAN;
	snprintf(line, sizeof(line), "%s %5.1f%%  ETA %s  %s ev/s  T=%s  t=%s", fmt_bar(f, 30, bar, sizeof(bar)),
	         isfinite(f) ? 100 * f : 0.0, fmt_duration(left, eta, sizeof(eta)), fmt_si(w->rate, rate, sizeof(rate)),
	         FMT_NUM(temp, "%.3g"), FMT_NUM(t, "%.4g"));
	if (w->tty) {
		fprintf(stderr, "\r\033[Kjob %lld %s", w->id, line);
		fflush(stderr);
		w->drawn = 1;
	} else if (!isfinite(f) || (int)(10 * f + 1e-9) >= w->next_decile) {
		/* Not a terminal: a line per tenth of the run, not per record. */
		printf("job %lld %s\n", w->id, line);
		fflush(stdout);
		if (isfinite(f))
			w->next_decile = (int)(10 * f + 1e-9) + 1;
	}
}

static int on_event(const char *event, const char *data, void *ud)
{
	watch_t *w = ud;
	if (w->x->json) {
		printf("{\"event\": \"%s\", \"data\": %s}\n", event, data);
		fflush(stdout);
	}
	if (!strcmp(event, "deleted")) {
		w->deleted = 1;
		return 1;
	}
	json_t *j = json_loads(data, 0, NULL);
	if (!j)
		return 0;
	if (!strcmp(event, "state")) {
		const char *st = str(j, "state", "");
		if (strcmp(st, w->state) && !w->x->json && !terminal(st)) {
			if (w->drawn)
				fputc('\n', stderr), w->drawn = 0;
			fprintf(w->tty ? stderr : stdout, "job %lld %s\n", w->id, st);
		}
		snprintf(w->state, sizeof(w->state), "%s", st);
		snprintf(w->reason, sizeof(w->reason), "%s", str(j, "reason", ""));
	} else if (!strcmp(event, "progress") && !w->x->json) {
		draw(w, j);
	}
	json_decref(j);
	return 0;
}

/* Follow job id to its end; the exit status reflects the result. */
static int follow(ctx_t *x, long long id)
{
	char path[128];
	json_t *job = NULL;
	watch_t w = {.x = x, .id = id, .last_wall = -1, .rate = NAN, .tty = isatty(STDERR_FILENO) && !x->json};
	int rc;

	snprintf(path, sizeof(path), "/api/v1/jobs/%lld", id);
	if ((rc = call(x, "GET", path, NULL, &job)))
		return rc;
	json_t *until = json_object_get(json_object_get(json_object_get(job, "scene"), "run"), "until");
	w.until_time = num(until, "time");
	w.until_cpp = num(until, "collisions_per_particle");
	json_decref(job);
	job = NULL;
	w.until_time = isfinite(w.until_time) ? w.until_time : 0;
	w.until_cpp = isfinite(w.until_cpp) ? w.until_cpp : 0;

	snprintf(path, sizeof(path), "/api/v1/jobs/%lld/events", id);
	int sr = conn_stream(x->conn, path, on_event, &w);
	if (w.drawn)
		fputc('\n', stderr);
	if (w.deleted) {
		errf("job %lld was deleted", id);
		return CTL_EXIT_REFUSED;
	}
	if (!terminal(w.state)) {
		/* The stream ended early (daemon stopped?): say so, with the reason curl gave. */
		if (sr != CONN_OK)
			return api_failed(x, sr);
		errf("the event stream of job %lld ended while it was %s (%s%s)", id, *w.state ? w.state : "unknown",
		     conn_url(x->conn), path);
		return CTL_EXIT_SERVER;
	}
	if (!x->json) {
		if (!strcmp(w.state, "succeeded"))
			printf("job %lld succeeded\n", id);
		else
			printf("job %lld %s%s%s\n", id, w.state, *w.reason ? ": " : "", w.reason);
	}
	return !strcmp(w.state, "succeeded") ? CTL_EXIT_OK : CTL_EXIT_JOB;
}

static int c_watch(ctx_t *x)
{
	long long id;
	int rc = job_arg(x, x->args[0], &id);
	return rc ? rc : follow(x, id);
}

/* ---- submit -------------------------------------------------------------------- */

/* Scene objects that hold exactly one clock ("time" or "collisions_per_particle"):
 * --set run.until.time=5 replaces the preset's run.until.collisions_per_particle. */
static const char *const one_clock[] = {"run.until.", "output.every."};

static void clear_clock(json_t *scene, const char *assignment)
{
	for (size_t i = 0; i < sizeof(one_clock) / sizeof(one_clock[0]); i++) {
		size_t n = strlen(one_clock[i]);
		const char *eq = strchr(assignment, '='), *dot = strchr(assignment + n, '.');
		if (strncmp(assignment, one_clock[i], n) || !eq || eq < assignment + n || (dot && dot < eq))
			continue;
		json_t *o = scene;
		char key[32];
		for (const char *p = one_clock[i], *d; o && (d = strchr(p, '.')); p = d + 1) {
			snprintf(key, sizeof(key), "%.*s", (int)(d - p), p);
			o = json_object_get(o, key);
		}
		if (json_is_object(o))
			json_object_clear(o);
	}
}

/* The request body {"scene": ...} from SCENE.json (a scene or a whole
 * submission) or --preset, with --set applied. *doc and *body are the caller's. */
static int scene_body(ctx_t *x, json_t **doc, json_t **body)
{
	int rc = CTL_EXIT_OK;
	json_t *scene;
	json_error_t je;
	char err[512], path[256];

	if (!!x->preset == (x->nargs == 1))
		return usage_error(x, "%s: give either SCENE.json or --preset NAME", x->cmd->name);
	if (x->preset) {
		for (const char *p = x->preset; *p; p++)
			if (!isalnum((unsigned char)*p) && !strchr("-_.", *p))
				return usage_error(x, "--preset '%s': not a preset name (see 'granularctl presets')", x->preset);
		snprintf(path, sizeof(path), "/api/v1/presets/%s", x->preset);
		if ((rc = call(x, "GET", path, NULL, doc)))
			return rc;
		*body = json_pack("{s:O}", "scene", json_object_get(*doc, "scene"));
	} else {
		const char *f = x->args[0];
		*doc = !strcmp(f, "-") ? json_loadf(stdin, 0, &je) : json_load_file(f, 0, &je);
		if (!*doc || !json_is_object(*doc)) {
			if (*doc)
				errf("%s: not a JSON object", f);
			else if (je.line > 0)
				errf("%s:%d:%d: %s", f, je.line, je.column, je.text);
			else
				errf("%s", je.text);
			return CTL_EXIT_USAGE;
		}
		/* A scene, or a whole submission {"scene": {...}, "priority": ...}. */
		*body = json_object_get(*doc, "scene") ? json_deep_copy(*doc) : json_pack("{s:O}", "scene", *doc);
	}
	if (!*body || !json_is_object(scene = json_object_get(*body, "scene"))) {
		errf("no scene in %s", x->preset ? x->preset : x->args[0]);
		return CTL_EXIT_USAGE;
	}
	for (int i = 0; i < x->nsets; i++) {
		clear_clock(scene, x->sets[i]);
		if (jpath_set(scene, x->sets[i], err, sizeof(err)) != JPATH_OK)
			return usage_error(x, "%s", err);
	}
	if (x->given & O_RANKS)
		json_object_set_new(*body, "ranks", json_integer(x->ranks));
	return rc;
}

static int c_submit(ctx_t *x)
{
	json_t *doc = NULL, *body = NULL, *resp = NULL;
	char *txt = NULL;
	int rc = scene_body(x, &doc, &body);

	if (rc)
		goto cleanup;
	if (x->given & O_PRIORITY)
		json_object_set_new(body, "priority", json_integer(x->priority));
	if (x->subid)
		json_object_set_new(body, "submission_id", json_string(x->subid));
	if (x->given & (O_NODES | O_TLIMIT | O_PARTITION | O_ACCOUNT)) {
		/* The submission's "slurm" object (docs/daemon.md, "Running on a cluster"): the
		 * flags go over the keys of a whole submission given as SCENE.json. */
		json_t *so = json_object_get(body, "slurm");
		if (!json_is_object(so))
			json_object_set_new(body, "slurm", so = json_object());
		if (x->given & O_NODES)
			json_object_set_new(so, "nodes", json_integer(x->nodes));
		if (x->given & O_TLIMIT)
			json_object_set_new(so, "time_limit", json_integer(x->time_limit));
		if (x->partition)
			json_object_set_new(so, "partition", json_string(x->partition));
		if (x->account)
			json_object_set_new(so, "account", json_string(x->account));
	}
	if (!(txt = json_dumps(body, JSON_COMPACT))) {
		errf("out of memory");
		rc = CTL_EXIT_SERVER;
		goto cleanup;
	}
	if ((rc = call(x, "POST", "/api/v1/jobs", txt, &resp)))
		goto cleanup;
	long long id = json_integer_value(json_object_get(resp, "id"));
	if (x->json && !(x->given & O_WAIT))
		print_json(resp);
	else if (!x->json)
		printf("job %lld %s (%s)\n", id, conn_status(x->conn) == 201 ? "submitted" : "already submitted",
		       str(resp, "state", "?"));
	fflush(stdout);
	if (x->given & O_WAIT)
		rc = follow(x, id);
cleanup:
	free(txt);
	json_decref(doc);
	json_decref(body);
	json_decref(resp);
	return rc;
}

/* ---- advise ---------------------------------------------------------------------- */

static void settings_text(const json_t *e, char *buf, size_t n)
{
	const json_t *st = json_object_get(e, "settings");
	if (!strcmp(str(e, "method", ""), "md")) {   /* md scenes: the step of the run */
		snprintf(buf, n, "step %s", FMT_NUM(num(st, "time_step"), "%.3g"));
		return;
	}
	if (!strcmp(str(e, "method", ""), "ed")) {
		double c = num(st, "cell_size");
		if (isfinite(c))
			snprintf(buf, n, "cell %.3g diameters", c);
		else
			snprintf(buf, n, "cell automatic");
		return;
	}
	double cps = num(st, "collisions_per_step"), dt = num(st, "time_step");
	int k = snprintf(buf, n, "%s, cell %s, ", str(st, "correction", "?"), FMT_NUM(num(st, "cell_size"), "%.3g"));
	if (k > 0 && (size_t)k < n)
		snprintf(buf + k, n - k, isfinite(dt) ? "step %s" : "%s coll/step", FMT_NUM(isfinite(dt) ? dt : cps, "%.3g"));
}

/* POST the command's scene (file or preset, --set, --ranks) to path, without
 * submission_id (it makes no job), and priority where the endpoint takes
 * none (drop_priority); *resp is the answer, the caller's to free. */
static int post_scene(ctx_t *x, const char *path, int drop_priority, json_t **resp)
{
	json_t *doc = NULL, *body = NULL;
	char *txt = NULL;
	int rc = scene_body(x, &doc, &body);

	if (rc)
		goto cleanup;
	if (drop_priority)
		json_object_del(body, "priority");
	json_object_del(body, "submission_id");
	if (!(txt = json_dumps(body, JSON_COMPACT))) {
		errf("out of memory");
		rc = CTL_EXIT_SERVER;
		goto cleanup;
	}
	rc = call(x, "POST", path, txt, resp);
cleanup:
	free(txt);
	json_decref(doc);
	json_decref(body);
	return rc;
}

static int c_advise(ctx_t *x)
{
	json_t *resp = NULL, *e;
	size_t i;
	int rc = post_scene(x, "/api/v1/advice", 1, &resp);

	if (rc)
		goto cleanup;
	if (x->json) {
		print_json(resp);
		goto cleanup;
	}
	const json_t *sc = json_object_get(resp, "scene");
	double target = num(json_object_get(resp, "target"), "temperature");
	double reps = num(sc, "replicas"), ranks = num(sc, "ranks");
	printf("%s particles x %s replica%s, %s rank%s; Haff time %s, %s collisions per particle",
	       FMT_NUM(num(sc, "particles"), "%.0f"), FMT_NUM(reps, "%.0f"), reps == 1 ? "" : "s",
	       FMT_NUM(ranks, "%.0f"), ranks == 1 ? "" : "s", FMT_NUM(num(sc, "haff_time"), "%.3g"),
	       FMT_NUM(num(sc, "collisions_per_particle"), "%.3g"));
	if (isfinite(target))
		printf("; target: temperature error <= %.3g", target);
	printf("\n%-6s %-32s %10s %10s %9s %-7s %s\n", "METHOD", "SETTINGS", "CPU", "WALL", "ERROR", "MEETS",
	       "EXTRAPOLATED");
	json_array_foreach(json_object_get(resp, "estimates"), i, e) {
		char set[96];
		const json_t *m = json_object_get(e, "meets_target");
		settings_text(e, set, sizeof(set));
		printf("%-6s %-32s %10s %10s %9s %-7s %s\n", str(e, "method", "?"), set, FMT_NUM(num(e, "cpu_seconds"), "%.3gs"),
		       FMT_NUM(num(e, "wall_seconds"), "%.3gs"), FMT_NUM(num(json_object_get(e, "error"), "temperature"), "%.3g"),
		       json_is_true(json_object_get(e, "refused")) ? "refused"
		       : json_is_boolean(m) ? (json_is_true(m) ? "yes" : "no") : "-",
		       json_is_true(json_object_get(e, "extrapolated")) ? "yes" : "");
	}
	json_array_foreach(json_object_get(resp, "estimates"), i, e) {
		size_t k;
		json_t *nt;
		json_array_foreach(json_object_get(e, "notes"), k, nt)
			printf("  %s: %s\n", str(e, "method", "?"), json_string_value(nt));
	}
	if (json_is_string(json_object_get(resp, "choice")))
		printf("choice: %s (%s)\n", str(resp, "choice_variant", str(resp, "choice", "?")), str(resp, "reason", ""));
cleanup:
	json_decref(resp);
	return rc;
}

/* ---- validate ---------------------------------------------------------------------- */

/* The checks of a submission without submitting (POST /api/v1/scenes/validate):
 * the engine's start checks and admission. Exit 0 when the scene would be
 * accepted, the server's 400 (one line naming the key) otherwise. */
static int c_validate(ctx_t *x)
{
	json_t *resp = NULL;
	int rc = post_scene(x, "/api/v1/scenes/validate", 0, &resp);

	if (rc)
		goto cleanup;
	if (x->json) {
		print_json(resp);
		goto cleanup;
	}
	const json_t *r = json_object_get(resp, "resources");
	printf("valid: method %s; memory %s (rank 0 %s, one engine %s); output up to %s of %s allowed; "
	       "%s frames, %s progress records (%s)\n",
	       str(resp, "method", "?"), FMT_NUM(num(r, "memory_bytes") / 1048576.0, "%.1f MiB"),
	       FMT_NUM(num(r, "memory_rank0_bytes") / 1048576.0, "%.1f MiB"),
	       FMT_NUM(num(r, "engine_bytes") / 1048576.0, "%.1f MiB"),
	       FMT_NUM(num(r, "output_bytes") / 1048576.0, "%.1f MiB"),
	       FMT_NUM(num(r, "max_output_bytes") / 1048576.0, "%.0f MiB"), FMT_NUM(num(r, "frames"), "%.0f"),
	       FMT_NUM(num(r, "records"), "%.0f"),
	       !strcmp(str(r, "output_estimate", ""), "haff") ? "estimated with Haff's law" : "from the schedules");
cleanup:
	json_decref(resp);
	return rc;
}

/* ---- list / show / cancel / delete ------------------------------------------------- */

static void job_row(const json_t *j, double now)
{
	char age[16], n[16], prog[16];
	double p = num(j, "progress");
	snprintf(prog, sizeof(prog), isfinite(p) ? "%.1f%%" : "-", 100 * p);
	printf("%-6lld %-10s %8s %-6s %8s %6s\n", (long long)json_integer_value(json_object_get(j, "id")),
	       str(j, "state", "?"), prog, str(j, "method", "-"), fmt_si(num(j, "particles"), n, sizeof(n)),
	       fmt_age(now - num(j, "created_at"), age, sizeof(age)));
}

static int c_list(ctx_t *x)
{
	int rc = CTL_EXIT_OK;
	json_t *all = json_array(), *page = NULL, *j;
	char path[512], cursor[32] = "";
	size_t i;
	long long limit = (x->given & O_LIMIT) ? x->limit : 100;
	if (x->state && strspn(x->state, "abcdefghijklmnopqrstuvwxyz,") != strlen(x->state)) {
		rc = usage_error(x, "--state '%s': expected states separated by commas", x->state);
		goto cleanup;
	}
	do {
		snprintf(path, sizeof(path), "/api/v1/jobs?limit=%lld%s%s%s%s", limit > 1000 ? 1000 : limit,
		         x->state ? "&state=" : "", x->state ? x->state : "", *cursor ? "&cursor=" : "", cursor);
		json_decref(page);
		if ((rc = call(x, "GET", path, NULL, &page)))
			goto cleanup;
		json_array_extend(all, json_object_get(page, "jobs"));
		json_t *next = json_object_get(page, "next_cursor");
		if (json_is_integer(next))
			snprintf(cursor, sizeof(cursor), "%lld", (long long)json_integer_value(next));
		else
			snprintf(cursor, sizeof(cursor), "%s", json_is_string(next) ? json_string_value(next) : "");
	} while ((x->given & O_ALL) && *cursor);
	if (x->json) {
		if (x->given & O_ALL)
			json_object_set_new(page, "next_cursor", json_null()), json_object_set(page, "jobs", all);
		print_json(page);
		goto cleanup;
	}
	double now = (double)time(NULL);
	printf("%-6s %-10s %8s %-6s %8s %6s\n", "ID", "STATE", "PROGRESS", "METHOD", "N", "AGE");
	json_array_foreach(all, i, j)
		job_row(j, now);
	if (*cursor)
		printf("(more: --all, or --limit)\n");
cleanup:
	json_decref(page);
	json_decref(all);
	return rc;
}

static void when(const char *label, double t, double now)
{
	char b[64], age[16];
	if (!isfinite(t))
		return;
	time_t tt = (time_t)t;
	struct tm tm;
	strftime(b, sizeof(b), "%Y-%m-%d %H:%M:%S", localtime_r(&tt, &tm));
	printf("  %-12s %s (%s ago)\n", label, b, fmt_age(now - t, age, sizeof(age)));
}

/* The job named by the first argument: METHOD /api/v1/jobs/ID<suffix> (a printf format for the rest). */
static int job_request(ctx_t *x, const char *method, long long *id, json_t **j, const char *suffix, ...)
	__attribute__((format(printf, 5, 6)));
static int job_request(ctx_t *x, const char *method, long long *id, json_t **j, const char *suffix, ...)
{
	char path[256], rest[160];
	va_list ap;
	int rc = job_arg(x, x->args[0], id);
	if (rc)
		return rc;
	va_start(ap, suffix);
	vsnprintf(rest, sizeof(rest), suffix, ap);
	va_end(ap);
	snprintf(path, sizeof(path), "/api/v1/jobs/%lld%s", *id, rest);
	return call(x, method, path, NULL, j);
}

static int c_show(ctx_t *x)
{
	long long id;
	json_t *j = NULL, *a;
	char ev[16];
	size_t i;
	int rc = job_request(x, "GET", &id, &j, "%s", "");
	if (rc)
		return rc;
	if (x->json) {
		print_json(j);
		goto cleanup;
	}
	double now = (double)time(NULL);
	const json_t *sc = json_object_get(j, "scene");
	printf("job %lld  %s\n", id, str(j, "state", "?"));
	printf("  %-12s %s\n", "submission", str(j, "submission_id", "-"));
	printf("  %-12s %s, %lldD, N=%lld, %lld rank%s, priority %lld\n", "scene", str(j, "method", "?"),
	       (long long)json_integer_value(json_object_get(sc, "dimensions")),
	       (long long)json_integer_value(json_object_get(j, "particles")),
	       (long long)json_integer_value(json_object_get(j, "ranks")),
	       json_integer_value(json_object_get(j, "ranks")) == 1 ? "" : "s",
	       (long long)json_integer_value(json_object_get(j, "priority")));
	printf("  %-12s %s  sim time %s  events %s\n", "progress", FMT_NUM(100 * num(j, "progress"), "%.1f%%"),
	       FMT_NUM(num(j, "sim_time"), "%.6g"), fmt_si(num(j, "events"), ev, sizeof(ev)));
	/* Cancelling a running job takes up to cancel_grace: say that one was asked for. */
	if (json_is_true(json_object_get(j, "cancel_requested")))
		printf("  %-12s requested%s\n", "cancel", !strcmp(str(j, "state", ""), "running") ? " (the job is stopping)" : "");
	when("created", num(j, "created_at"), now);
	when("started", num(j, "started_at"), now);
	when("finished", num(j, "finished_at"), now);
	if (json_string_value(json_object_get(j, "reason")))
		printf("  %-12s %s\n", "reason", str(j, "reason", ""));
	/* The submission's Slurm options (null when it gave none). */
	const json_t *so = json_object_get(j, "slurm");
	if (json_is_object(so) && json_object_size(so)) {
		printf("  %-12s", "slurm");
		if (json_is_integer(json_object_get(so, "nodes")))
			printf(" nodes %lld", (long long)json_integer_value(json_object_get(so, "nodes")));
		if (json_is_integer(json_object_get(so, "time_limit")))
			printf(" time limit %lld s", (long long)json_integer_value(json_object_get(so, "time_limit")));
		if (json_is_string(json_object_get(so, "partition")))
			printf(" partition %s", str(so, "partition", ""));
		if (json_is_string(json_object_get(so, "account")))
			printf(" account %s", str(so, "account", ""));
		putchar('\n');
	}
	json_array_foreach(json_object_get(j, "attempts"), i, a) {
		printf("  attempt %lld", (long long)json_integer_value(json_object_get(a, "n")));
		if (json_is_integer(json_object_get(a, "pid")))  /* none under Slurm: the job runs elsewhere */
			printf("  pid %lld", (long long)json_integer_value(json_object_get(a, "pid")));
		if (json_is_integer(json_object_get(a, "exit_status")))
			printf("  exit %lld", (long long)json_integer_value(json_object_get(a, "exit_status")));
		if (json_is_integer(json_object_get(a, "signal")))
			printf("  signal %lld", (long long)json_integer_value(json_object_get(a, "signal")));
		const json_t *sj = json_object_get(a, "slurm_job");
		if (json_is_integer(sj))
			printf("  slurm job %lld", (long long)json_integer_value(sj));
		else if (json_is_string(sj))
			printf("  slurm job %s", json_string_value(sj));
		if (json_is_string(json_object_get(a, "slurm_state")))
			printf(" %s", str(a, "slurm_state", ""));
		printf("%s%s\n", json_is_string(json_object_get(a, "reason")) ? "  " : "", str(a, "reason", ""));
	}
cleanup:
	json_decref(j);
	return rc;
}

static int c_cancel(ctx_t *x)
{
	long long id;
	json_t *j = NULL;
	int rc = job_request(x, "POST", &id, &j, "/cancel");
	if (rc)
		return rc;
	if (x->json)
		print_json(j);
	else if (!strcmp(str(j, "state", ""), "cancelled"))
		printf("job %lld cancelled\n", id);
	else
		printf("job %lld: cancel requested (%s)\n", id, str(j, "state", "?"));
	json_decref(j);
	return rc;
}

static int c_delete(ctx_t *x)
{
	long long id;
	json_t *j = NULL;
	int rc = job_request(x, "DELETE", &id, &j, "%s", "");
	if (rc)
		return rc;
	if (x->json)
		print_json(j);
	else
		printf("job %lld deleted\n", id);
	json_decref(j);
	return rc;
}

/* ---- series ------------------------------------------------------------------------ */

static int c_progress(ctx_t *x)
{
	long long id;
	json_t *j = NULL, *r;
	char ev[16];
	size_t i;
	int rc = job_request(x, "GET", &id, &j, "/progress?after=%lld", (x->given & O_AFTER) ? x->after : -1);
	if (rc)
		return rc;
	if (x->json) {
		print_json(j);
		goto cleanup;
	}
	printf("%-5s %-8s %12s %9s %8s %12s %12s %10s\n", "SEQ", "TYPE", "TIME", "COLL/N", "EVENTS", "E_KIN",
	       "TEMPERATURE", "COLL_RATE");
	json_array_foreach(json_object_get(j, "records"), i, r)
		printf("%-5lld %-8s %12s %9s %8s %12s %12s %10s\n",
		       (long long)json_integer_value(json_object_get(r, "seq")), str(r, "type", "?"), FMT_NUM(num(r, "time"), "%.6g"),
		       FMT_NUM(num(r, "collisions_per_particle"), "%.4g"), fmt_si(num(r, "events"), ev, sizeof(ev)),
		       FMT_NUM(num(r, "kinetic_energy"), "%.6g"), FMT_NUM(num(r, "temperature"), "%.6g"),
		       FMT_NUM(num(r, "collision_rate"), "%.4g"));
cleanup:
	json_decref(j);
	return rc;
}

static int c_clusters(ctx_t *x)
{
	long long id;
	json_t *j = NULL, *r;
	size_t i;
	int rc = job_request(x, "GET", &id, &j, "/clusters");
	if (rc)
		return rc;
	if (x->json) {
		print_json(j);
		goto cleanup;
	}
	printf("%-5s %12s %9s %8s %8s %9s %9s\n", "SEQ", "TIME", "COLL/N", "CLUSTERS", "LARGEST", "FRACTION",
	       "MEAN_SIZE");
	json_array_foreach(json_object_get(j, "series"), i, r) {
		const json_t *c = json_object_get(r, "clusters");
		printf("%-5lld %12s %9s %8s %8s %9s %9s\n", (long long)json_integer_value(json_object_get(r, "seq")),
		       FMT_NUM(num(r, "time"), "%.6g"), FMT_NUM(num(r, "collisions_per_particle"), "%.4g"),
		       FMT_NUM(num(c, "count"), "%.0f"), FMT_NUM(num(c, "largest"), "%.0f"),
		       FMT_NUM(num(c, "largest_fraction"), "%.4f"), FMT_NUM(num(c, "mean_size"), "%.3f"));
	}
cleanup:
	json_decref(j);
	return rc;
}

/* Curves of one observable family as CSV: one row per bin of each table of each sample,
 * sample,time,table,x,<columns>[,<column>_se...] (ensembles add the standard errors). */
static int c_observables(ctx_t *x)
{
	long long id;
	json_t *j = NULL, *smp;
	size_t i;
	const char *name = x->args[1];
	for (const char *p = name; *p; p++)
		if (!((*p >= 'a' && *p <= 'z') || (*p >= '0' && *p <= '9') || *p == '_')) {
			fprintf(stderr, "granularctl: observables: NAME '%s' is not an observable family name "
			        "(velocity_distribution, pair_correlation, ...)\n", name);
			return 2;
		}
	int rc = (x->given & O_AFTER) ? job_request(x, "GET", &id, &j, "/observables?name=%s&after=%lld", name, x->after)
	                              : job_request(x, "GET", &id, &j, "/observables?name=%s&last=1", name);
	if (rc)
		return rc;
	if (x->json) {
		print_json(j);
		goto cleanup;
	}
	json_array_foreach(json_object_get(j, "samples"), i, smp) {
		size_t k;
		json_t *t;
		json_array_foreach(json_object_get(smp, "tables"), k, t) {
			json_t *cols = json_object_get(t, "columns"), *se = json_object_get(t, "se"), *v;
			const json_t *centres = json_object_get(t, "centres");
			const char *key;
			printf("# %s sample %lld, time %.9g, table \"%s\"\nsample,time,table,%s", name,
			       (long long)json_integer_value(json_object_get(smp, "sample")), num(smp, "time"), str(t, "table", ""),
			       str(t, "x", "x"));
			json_object_foreach(cols, key, v)
				printf(",%s", key);
			json_object_foreach(se, key, v)
				printf(",%s_se", key);
			printf("\n");
			for (size_t b = 0; b < json_array_size(centres); b++) {
				printf("%lld,%.9g,%s,%.9g", (long long)json_integer_value(json_object_get(smp, "sample")),
				       num(smp, "time"), str(t, "table", ""), json_number_value(json_array_get(centres, b)));
				json_object_foreach(cols, key, v) {
					json_t *e = json_array_get(v, b);
					json_is_number(e) ? printf(",%.9g", json_number_value(e)) : printf(",");
				}
				json_object_foreach(se, key, v) {
					json_t *e = json_array_get(v, b);
					json_is_number(e) ? printf(",%.9g", json_number_value(e)) : printf(",");
				}
				printf("\n");
			}
		}
	}
	if (json_is_true(json_object_get(j, "truncated")))
		fprintf(stderr, "granularctl: more samples follow: --after %lld\n",
		        (long long)json_integer_value(json_object_get(j, "next")));
cleanup:
	json_decref(j);
	return rc;
}

/* ---- files ------------------------------------------------------------------------- */

static int c_files(ctx_t *x)
{
	long long id;
	json_t *j = NULL, *f;
	char size[16], age[16];
	size_t i;
	int rc = job_request(x, "GET", &id, &j, "/files");
	if (rc)
		return rc;
	if (x->json) {
		print_json(j);
		goto cleanup;
	}
	double now = (double)time(NULL);
	printf("%-24s %8s %6s  %s\n", "NAME", "SIZE", "AGE", "SHA256");
	json_array_foreach(json_object_get(j, "files"), i, f)
		printf("%-24s %8s %6s  %s\n", str(f, "name", "?"), fmt_si(num(f, "size"), size, sizeof(size)),
		       fmt_age(now - num(f, "modified"), age, sizeof(age)), str(f, "sha256", "-"));
cleanup:
	json_decref(j);
	return rc;
}

/* Names the daemon serves: letters, digits, . _ - and no leading dot (also keeps -o's default safe). */
static int file_name_ok(const char *s)
{
	if (!*s || *s == '.')
		return 0;
	for (; *s; s++)
		if (!isalnum((unsigned char)*s) && !strchr("._-", *s))
			return 0;
	return 1;
}

static int c_download(ctx_t *x)
{
	long long id;
	char path[512];
	const char *name = x->args[1], *dest = x->output ? x->output : name;
	FILE *out = NULL;
	int rc = job_arg(x, x->args[0], &id);
	if (rc)
		return rc;
	if (!file_name_ok(name))
		return usage_error(x, "NAME '%s': not a job file name (letters, digits, . _ -; no leading dot)", name);
	int to_stdout = !strcmp(dest, "-"), force = !!(x->given & O_FORCE);
	/* A regular file is written as DEST.part and moved into place when
	 * complete, so a failure never leaves half a file nor destroys an existing
	 * one; anything else (/dev/null, a pipe) is written directly. An existing
	 * file is replaced only with --force: asked before any transfer, and again
	 * when moving into place (link() fails on a file that appeared meanwhile). */
	struct stat st;
	int exists = !to_stdout && stat(dest, &st) == 0;
	int direct = to_stdout || (exists && !S_ISREG(st.st_mode));
	if (exists && !direct && !force) {
		errf("%s exists: not overwritten (--force replaces it)", dest);
		return CTL_EXIT_USAGE;
	}
	char part[4200];
	snprintf(part, sizeof(part), "%s.part", dest);
	if (!to_stdout && !(out = fopen(direct ? dest : part, "wb"))) {
		errf("-o %s: %s", direct ? dest : part, strerror(errno));
		return CTL_EXIT_USAGE;
	}
	snprintf(path, sizeof(path), "/api/v1/jobs/%lld/files/%s", id, name);
	if ((rc = ensure_conn(x)) != CTL_EXIT_OK)
		goto cleanup;
	int r = conn_download(x->conn, path, to_stdout ? stdout : out);
	if (r != CONN_OK)
		rc = api_failed(x, r);
	else if (!to_stdout && fflush(out)) {
		errf("-o %s: %s", dest, strerror(errno));
		rc = CTL_EXIT_SERVER;
	}
cleanup:
	if (out && fclose(out) && rc == CTL_EXIT_OK) {
		errf("-o %s: %s", dest, strerror(errno));
		rc = CTL_EXIT_SERVER;
	}
	if (!direct && rc != CTL_EXIT_OK) {
		remove(part);   /* no half-written file left behind */
	} else if (!direct && !force && link(part, dest) == 0) {
		remove(part);
	} else if (!direct && !force && errno == EEXIST) {
		errf("%s exists: not overwritten (--force replaces it)", dest);
		remove(part);
		rc = CTL_EXIT_USAGE;
	} else if (!direct && rename(part, dest)) {   /* --force, or a file system without hard links */
		errf("-o %s: %s", dest, strerror(errno));
		remove(part);
		rc = CTL_EXIT_SERVER;
	}
	if (rc == CTL_EXIT_OK && !to_stdout && !x->json)
		fprintf(stderr, "granularctl: job %lld: %s -> %s\n", id, name, dest);
	return rc;
}

/* ---- service ----------------------------------------------------------------------- */

static int c_cluster(ctx_t *x)
{
	json_t *j = NULL, *v, *r;
	const char *k;
	char up[32], eps[16];
	size_t i;
	int rc = call(x, "GET", "/api/v1/cluster", NULL, &j);
	if (rc)
		return rc;
	if (x->json) {
		print_json(j);
		goto cleanup;
	}
	const json_t *s = json_object_get(j, "slots");
	printf("granulard %s at %s, up %s\n", str(j, "version", "?"), conn_url(x->conn),
	       fmt_duration(num(j, "uptime_seconds"), up, sizeof(up)));
	printf("  slots      %s used of %s (%s free)\n", FMT_NUM(num(s, "used"), "%.0f"), FMT_NUM(num(s, "total"), "%.0f"),
	       FMT_NUM(num(s, "free"), "%.0f"));
	printf("  jobs      ");
	json_object_foreach(json_object_get(j, "jobs"), k, v)
		printf(" %s %lld", k, (long long)json_integer_value(v));
	printf("\n  finished   %lld in the last hour\n", (long long)json_integer_value(json_object_get(j, "finished_last_hour")));
	printf("  events/s   %s\n", fmt_si(num(j, "events_per_second"), eps, sizeof(eps)));
	json_array_foreach(json_object_get(j, "running"), i, r)
		printf("  running    job %lld, %s, %lld rank%s\n", (long long)json_integer_value(json_object_get(r, "id")),
		       FMT_NUM(100 * num(r, "progress"), "%.1f%%"), (long long)json_integer_value(json_object_get(r, "ranks")),
		       json_integer_value(json_object_get(r, "ranks")) == 1 ? "" : "s");
	/* launcher = slurm: the partition the jobs go to (docs/daemon.md, "Running on a cluster"). */
	const json_t *sl = json_object_get(j, "slurm"), *sn = json_object_get(sl, "nodes"), *sc = json_object_get(sl, "cpus");
	if (json_is_string(json_object_get(sl, "error")))
		printf("  slurm      %s\n", str(sl, "error", "?"));
	else if (sl)
		printf("  slurm      partition %s: %s nodes (%s idle), CPUs %s allocated of %s (%s idle), %s pending jobs\n",
		       str(sl, "partition", "?"), FMT_NUM(num(sn, "total"), "%.0f"), FMT_NUM(num(sn, "idle"), "%.0f"),
		       FMT_NUM(num(sc, "allocated"), "%.0f"), FMT_NUM(num(sc, "total"), "%.0f"), FMT_NUM(num(sc, "idle"), "%.0f"),
		       FMT_NUM(num(sl, "pending_jobs"), "%.0f"));
cleanup:
	json_decref(j);
	return rc;
}

static int c_presets(ctx_t *x)
{
	json_t *j = NULL, *p;
	char n[16];
	size_t i;
	int rc = call(x, "GET", "/api/v1/presets", NULL, &j);
	if (rc)
		return rc;
	if (x->json) {
		print_json(j);
		goto cleanup;
	}
	printf("%-16s %-3s %-6s %7s  %s\n", "NAME", "DIM", "METHOD", "N", "DESCRIPTION");
	json_array_foreach(json_object_get(j, "presets"), i, p)
		printf("%-16s %-3lld %-6s %7s  %s\n", str(p, "name", "?"),
		       (long long)json_integer_value(json_object_get(p, "dimensions")), str(p, "method", "?"),
		       fmt_si(num(p, "particles"), n, sizeof(n)), str(p, "description", ""));
cleanup:
	json_decref(j);
	return rc;
}

/* ---- the table --------------------------------------------------------------------- */

static int c_help(ctx_t *x);

static const cmd_t commands[] = {
	{.name = "submit", .args = "SCENE.json | --preset NAME", .summary = "submit a job (SCENE.json may be - for stdin)",
	 .help = "  --preset NAME         a built-in scene (see 'granularctl presets')\n"
	         "  --set KEY.PATH=VALUE  override a scene key (VALUE as JSON: 0.5, true, \"ed\"; else a string); repeatable;\n"
	         "                        run.until.X and output.every.X replace the clock there (time or collisions_per_particle)\n"
	         "  --priority P          -1000..1000, higher runs first (default 0)\n"
	         "  --ranks R             MPI ranks (default 1)\n"
	         "  --submission-id ID    idempotency key: resubmitting returns the same job\n"
	         "  --wait                follow the job to its end; exit status 0 succeeded, 1 failed/cancelled\n"
	         "  With launcher = slurm (the daemon's; ignored by mpirun):\n"
	         "  --nodes N             1..4096 and at most the ranks (sbatch --nodes; default: Slurm places the ranks)\n"
	         "  --time-limit SECONDS  1..100000000 per attempt, when shorter than the daemon's slurm_time_limit\n"
	         "  --partition NAME      1..64 of A-Z a-z 0-9 _ . - (default: the daemon's slurm_partition)\n"
	         "  --account NAME        1..64 of A-Z a-z 0-9 _ . - (default: the daemon's slurm_account)\n",
	 .fn = c_submit, .min_args = 0, .max_args = 1,
	 .opts = O_PRESET | O_SET | O_PRIORITY | O_RANKS | O_SUBID | O_WAIT | O_NODES | O_TLIMIT | O_PARTITION | O_ACCOUNT},
	{.name = "advise", .args = "SCENE.json | --preset NAME",
	 .summary = "estimated cost and expected error of each method for a scene (no job is made)",
	 .help = "  --preset NAME         a built-in scene\n"
	         "  --set KEY.PATH=VALUE  override a scene key, as for submit; repeatable\n"
	         "  --ranks R             MPI ranks the wall time assumes (default 1)\n",
	 .fn = c_advise, .min_args = 0, .max_args = 1, .opts = O_PRESET | O_SET | O_RANKS},
	{.name = "validate", .args = "SCENE.json | --preset NAME",
	 .summary = "check a scene as a submission would (engine start checks, admission); no job is made",
	 .help = "  --preset NAME         a built-in scene\n"
	         "  --set KEY.PATH=VALUE  override a scene key, as for submit; repeatable\n"
	         "  --ranks R             MPI ranks the estimate assumes (default 1)\n"
	         "  exit status 0: the scene would be accepted; otherwise one line naming the key and why\n",
	 .fn = c_validate, .min_args = 0, .max_args = 1, .opts = O_PRESET | O_SET | O_RANKS},
	{.name = "list", .args = "", .summary = "list jobs, newest first",
	 .help = "  --state S[,S...]      only these states (queued, running, succeeded, failed, cancelled)\n"
	         "  --limit N             at most N jobs per page (default 100)\n"
	         "  --all                 follow the cursor through every page\n",
	 .fn = c_list, .opts = O_STATE | O_LIMIT | O_ALL},
	{.name = "show", .args = "ID", .summary = "a job's record and attempts", .fn = c_show, .min_args = 1, .max_args = 1},
	{.name = "watch", .args = "ID", .summary = "follow a job live until it ends (exit 0 succeeded, 1 failed/cancelled)",
	 .fn = c_watch, .min_args = 1, .max_args = 1},
	{.name = "cancel", .args = "ID", .summary = "cancel a queued or running job", .fn = c_cancel, .min_args = 1,
	 .max_args = 1},
	{.name = "delete", .args = "ID", .summary = "delete a finished job and its files", .fn = c_delete, .min_args = 1,
	 .max_args = 1},
	{.name = "progress", .args = "ID", .summary = "the job's progress records (energy, temperature, rates)",
	 .help = "  --after SEQ           only records after sequence number SEQ\n",
	 .fn = c_progress, .min_args = 1, .max_args = 1, .opts = O_AFTER},
	{.name = "clusters", .args = "ID", .summary = "the job's particle-cluster statistics over time", .fn = c_clusters,
	 .min_args = 1, .max_args = 1},
	{.name = "observables", .args = "ID NAME",
	 .summary = "curves of an observable family (e.g. pair_correlation, impact_parameter) as CSV: the last sample",
	 .help = "  --after K             every sample after sample index K instead (up to 100 per call)\n",
	 .fn = c_observables, .min_args = 2, .max_args = 2, .opts = O_AFTER},
	{.name = "files", .args = "ID", .summary = "the job's output files with sizes and SHA-256", .fn = c_files,
	 .min_args = 1, .max_args = 1},
	{.name = "download", .args = "ID NAME", .summary = "download a job file (to NAME, or -o FILE; -o - for stdout)",
	 .help = "  -o, --output FILE     where to write (default: NAME in the current directory; - = stdout)\n"
	         "  -f, --force           replace an existing file (without it an existing file is left alone)\n",
	 .fn = c_download, .min_args = 2, .max_args = 2, .opts = O_OUTPUT | O_FORCE},
	{.name = "cluster", .args = "", .summary = "compute-cluster status: slots, queue, throughput", .fn = c_cluster},
	{.name = "presets", .args = "", .summary = "the built-in scenes", .fn = c_presets},
	{.name = "help", .args = "[COMMAND]", .summary = "this help, or a command's", .fn = c_help, .max_args = 1},
};
static const size_t ncommands = sizeof(commands) / sizeof(commands[0]);

static const char global_help[] =
	"Global options:\n"
	"  --url URL             granulard's address (else $GRANULAR_URL, else STATE_DIR/granulard.addr)\n"
	"  --token-file FILE     read the bearer token for changes from FILE (else $GRANULAR_TOKEN,\n"
	"                        else STATE_DIR/token; --token TOKEN also works but shows in ps)\n"
	"  --state-dir DIR       granulard's state directory (else $GRANULAR_STATE_DIR, else ./var)\n"
	"  --json                print the server's JSON instead of a table\n"
	"  -h, --help            help\n"
	"Exit status: 0 ok, 1 job failed or cancelled, 2 usage or invalid input (also HTTP 400),\n"
	"3 server or network error, 4 refused or not found (401, 403, 404, 409).\n";

static const cmd_t *find_cmd(const char *name)
{
	for (size_t i = 0; name && i < ncommands; i++)
		if (!strcmp(commands[i].name, name))
			return &commands[i];
	return NULL;
}

static void cmd_help(FILE *f, const cmd_t *c)
{
	fprintf(f, "usage: granularctl %s%s%s [options]\n%s.\n", c->name, *c->args ? " " : "", c->args, c->summary);
	if (c->help)
		fprintf(f, "Options:\n%s", c->help);
	fputs(global_help, f);
}

static void main_help(FILE *f)
{
	fprintf(f, "usage: granularctl COMMAND [ARGS] [options]\nClient of granulard, the granular-gas simulation service.\n"
	           "Commands:\n");
	for (size_t i = 0; i < ncommands; i++)
		fprintf(f, "  %-9s %-28s %s\n", commands[i].name, commands[i].args, commands[i].summary);
	fputs(global_help, f);
	fputs("'granularctl COMMAND --help' describes a command; 'man granularctl' is the manual.\n", f);
}

static int c_help(ctx_t *x)
{
	const cmd_t *c = x->nargs ? find_cmd(x->args[0]) : NULL;
	if (x->nargs && !c)
		return usage_error(x, "help: unknown command '%s'", x->args[0]);
	if (c)
		cmd_help(stdout, c);
	else
		main_help(stdout);
	return CTL_EXIT_OK;
}

/* ---- options ----------------------------------------------------------------------- */

static const struct option long_opts[] = {
	{"url", required_argument, NULL, 'U'},       {"token", required_argument, NULL, 'T'},
	{"state-dir", required_argument, NULL, 'D'}, {"json", no_argument, NULL, 'j'},
	{"help", no_argument, NULL, 'h'},            {"version", no_argument, NULL, 'V'},
	{"state", required_argument, NULL, 's'},     {"limit", required_argument, NULL, 'n'},
	{"all", no_argument, NULL, 'a'},             {"preset", required_argument, NULL, 'p'},
	{"set", required_argument, NULL, 'S'},       {"priority", required_argument, NULL, 'P'},
	{"ranks", required_argument, NULL, 'r'},     {"submission-id", required_argument, NULL, 'i'},
	{"wait", no_argument, NULL, 'w'},            {"output", required_argument, NULL, 'o'},
	{"after", required_argument, NULL, 'A'},     {"token-file", required_argument, NULL, 'F'},
	{"force", no_argument, NULL, 'f'},           {"nodes", required_argument, NULL, 'N'},
	{"time-limit", required_argument, NULL, 'L'}, {"partition", required_argument, NULL, 'Q'},
	{"account", required_argument, NULL, 'C'},
	{NULL, 0, NULL, 0},
};

/* Which bit each command-specific option sets, for the per-command check. */
static const struct { int ch; unsigned bit; const char *name; } opt_bits[] = {
	{'s', O_STATE, "--state"},   {'n', O_LIMIT, "--limit"},       {'a', O_ALL, "--all"},
	{'p', O_PRESET, "--preset"}, {'S', O_SET, "--set"},           {'P', O_PRIORITY, "--priority"},
	{'r', O_RANKS, "--ranks"},   {'i', O_SUBID, "--submission-id"}, {'w', O_WAIT, "--wait"},
	{'o', O_OUTPUT, "--output"}, {'A', O_AFTER, "--after"},         {'f', O_FORCE, "--force"},
	{'N', O_NODES, "--nodes"},   {'L', O_TLIMIT, "--time-limit"},   {'Q', O_PARTITION, "--partition"},
	{'C', O_ACCOUNT, "--account"},
};

static int int_opt(const ctx_t *x, const char *name, const char *s, long long lo, long long hi, long long *v)
{
	char *end;
	errno = 0;
	*v = strtoll(s, &end, 10);
	if (!*s || *end || errno || *v < lo || *v > hi)
		return usage_error(x, "%s '%s': expected an integer in %lld..%lld", name, s, lo, hi);
	return 0;
}

static int parse(ctx_t *x, int argc, char **argv)
{
	int ch, rc;
	opterr = 0;
	while ((ch = getopt_long(argc, argv, ":ho:f", long_opts, NULL)) != -1) {
		for (size_t i = 0; i < sizeof(opt_bits) / sizeof(opt_bits[0]); i++)
			if (opt_bits[i].ch == ch)
				x->given |= opt_bits[i].bit;
		switch (ch) {
		case 'U': x->url = optarg; break;
		case 'T': x->token = optarg; break;
		case 'F': x->token_file = optarg; break;
		case 'D': x->state_dir = optarg; break;
		case 'j': x->json = 1; break;
		case 'h': x->help = 1; break;
		case 'V': printf("granularctl %s\n", PACKAGE_VERSION); return -1;
		case 's': x->state = optarg; break;
		case 'n': if ((rc = int_opt(x, "--limit", optarg, 1, 1000000, &x->limit))) return rc; break;
		case 'a': break;
		case 'p': x->preset = optarg; break;
		case 'S':
			if (x->nsets == MAX_SETS)
				return usage_error(x, "--set: at most %d overrides", MAX_SETS);
			x->sets[x->nsets++] = optarg;
			break;
		case 'P': if ((rc = int_opt(x, "--priority", optarg, -1000, 1000, &x->priority))) return rc; break;
		case 'r': if ((rc = int_opt(x, "--ranks", optarg, 1, 4096, &x->ranks))) return rc; break;
		case 'i': x->subid = optarg; break;
		case 'w': break;
		case 'o': x->output = optarg; break;
		case 'f': break;
		case 'N': if ((rc = int_opt(x, "--nodes", optarg, 1, 4096, &x->nodes))) return rc; break;
		case 'L': if ((rc = int_opt(x, "--time-limit", optarg, 1, 100000000, &x->time_limit))) return rc; break;
		case 'Q':
		case 'C':
			/* The daemon's check (slurm.partition, slurm.account), so that a typo fails before any server is
			 * looked for. */
			*(ch == 'Q' ? &x->partition : &x->account) = optarg;
			if (!*optarg || strlen(optarg) > 64 || strspn(optarg, "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz"
			                                                     "0123456789_.-") != strlen(optarg))
				return usage_error(x, "%s '%s': expected 1..64 characters from A-Z a-z 0-9 _ . -",
				                   ch == 'Q' ? "--partition" : "--account", optarg);
			break;
		case 'A': if ((rc = int_opt(x, "--after", optarg, -1, INT64_MAX, &x->after))) return rc; break;
		case ':': return usage_error(x, "%s: needs an argument", argv[optind - 1]);
		default: return usage_error(x, "%s: unknown option", argv[optind - 1]);
		}
	}
	x->args = argv + optind;
	x->nargs = argc - optind;
	return 0;
}

int cmd_main(int argc, char **argv)
{
	ctx_t x = {0};
	int rc = parse(&x, argc, argv);
	if (rc)
		return rc < 0 ? CTL_EXIT_OK : rc;
	if (x.nargs == 0) {
		if (x.help) {
			main_help(stdout);
			return CTL_EXIT_OK;
		}
		main_help(stderr);
		return CTL_EXIT_USAGE;
	}
	if (!(x.cmd = find_cmd(x.args[0]))) {
		return usage_error(&x, "unknown command '%s'", x.args[0]);
	}
	x.args++;
	x.nargs--;
	if (x.help) {
		cmd_help(stdout, x.cmd);
		return CTL_EXIT_OK;
	}
	for (size_t i = 0; i < sizeof(opt_bits) / sizeof(opt_bits[0]); i++)
		if ((x.given & opt_bits[i].bit) && !(x.cmd->opts & opt_bits[i].bit))
			return usage_error(&x, "%s: not an option of '%s'", opt_bits[i].name, x.cmd->name);
	if (x.nargs < x.cmd->min_args || x.nargs > x.cmd->max_args)
		return usage_error(&x, "%s: expected %s%s", x.cmd->name, *x.cmd->args ? x.cmd->args : "no arguments",
		                   x.nargs > x.cmd->max_args ? ", got more" : "");
	rc = x.cmd->fn(&x);
	conn_destroy(x.conn);
	settings_deinit(&x.cfg);
	return rc;
}
