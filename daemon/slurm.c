/* Slurm backend: batch scripts, and the Slurm client commands run with a timeout and parsed. */
#define _GNU_SOURCE
#include <errno.h>
#include <fcntl.h>
#include <inttypes.h>
#include <poll.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>
#include "slurm.h"

/* A Slurm command that takes longer is killed: slurmctld answers in
 * milliseconds, and the scheduler thread waits for it. */
#define CMD_TIMEOUT 15.0
#define OUT_MAX (1 << 20)

static const char *const names[SLURM_NSTATES] = {
	[SLURM_PENDING] = "pending", [SLURM_RUNNING] = "running", [SLURM_SUSPENDED] = "suspended",
	[SLURM_COMPLETING] = "completing", [SLURM_COMPLETED] = "completed", [SLURM_FAILED] = "failed",
	[SLURM_TIMEOUT] = "timeout", [SLURM_NODE_FAIL] = "node_fail", [SLURM_PREEMPTED] = "preempted",
	[SLURM_CANCELLED] = "cancelled", [SLURM_GONE] = "gone",
};

const char *slurm_state_name(slurm_state_t s) { return (unsigned)s < SLURM_NSTATES ? names[s] : "?"; }

slurm_state_t slurm_state_parse(const char *word)
{
	static const struct {
		const char *w;
		slurm_state_t s;
	} map[] = {
		{"PENDING", SLURM_PENDING}, {"CONFIGURING", SLURM_PENDING}, {"REQUEUED", SLURM_PENDING},
		{"REQUEUE_HOLD", SLURM_PENDING}, {"REQUEUE_FED", SLURM_PENDING}, {"RESV_DEL_HOLD", SLURM_PENDING},
		{"RUNNING", SLURM_RUNNING}, {"RESIZING", SLURM_RUNNING}, {"SIGNALING", SLURM_RUNNING},
		{"STAGE_OUT", SLURM_RUNNING}, {"SUSPENDED", SLURM_SUSPENDED}, {"STOPPED", SLURM_SUSPENDED},
		{"COMPLETING", SLURM_COMPLETING}, {"COMPLETED", SLURM_COMPLETED}, {"FAILED", SLURM_FAILED},
		{"BOOT_FAIL", SLURM_FAILED}, {"OUT_OF_MEMORY", SLURM_FAILED}, {"DEADLINE", SLURM_FAILED},
		{"SPECIAL_EXIT", SLURM_FAILED}, {"TIMEOUT", SLURM_TIMEOUT}, {"NODE_FAIL", SLURM_NODE_FAIL},
		{"PREEMPTED", SLURM_PREEMPTED}, {"CANCELLED", SLURM_CANCELLED}, {"REVOKED", SLURM_CANCELLED},
	};
	size_t len = strcspn(word, " \t\n+");   /* "CANCELLED by 0", "COMPLETING+" */
	for (size_t i = 0; i < sizeof(map) / sizeof(map[0]); i++)
		if (strlen(map[i].w) == len && !strncmp(word, map[i].w, len))
			return map[i].s;
	return SLURM_FAILED;
}

int slurm_state_final(slurm_state_t s)
{
	return s == SLURM_COMPLETED || s == SLURM_FAILED || s == SLURM_TIMEOUT || s == SLURM_NODE_FAIL ||
	       s == SLURM_PREEMPTED || s == SLURM_CANCELLED || s == SLURM_GONE;
}

/* The value of " KEY=" in a one-line record, up to the next space; 0 when absent. */
static int field(const char *text, const char *key, char *out, size_t n)
{
	size_t kl = strlen(key);
	for (const char *p = text; (p = strstr(p, key)); p += kl) {
		if ((p != text && p[-1] != ' ' && p[-1] != '\n') || p[kl] != '=')
			continue;
		const char *v = p + kl + 1;
		size_t len = strcspn(v, " \n");
		snprintf(out, n, "%.*s", (int)len, v);
		return 1;
	}
	return 0;
}

int slurm_parse_show_job(const char *text, slurm_job_t *out)
{
	char v[128];
	memset(out, 0, sizeof(*out));
	if (!field(text, "JobState", v, sizeof(v)))
		return SLURM_EFAIL;
	snprintf(out->word, sizeof(out->word), "%s", v);
	out->state = slurm_state_parse(v);
	if (field(text, "Reason", v, sizeof(v)) && strcmp(v, "None"))
		snprintf(out->reason, sizeof(out->reason), "%s", v);
	if (field(text, "ExitCode", v, sizeof(v)))
		sscanf(v, "%d:%d", &out->exit_code, &out->exit_signal);
	return SLURM_OK;
}

/* A word for a POSIX shell: single quotes, with ' written as '\''. */
static void quote(FILE *f, const char *s)
{
	fputc('\'', f);
	for (; *s; s++)
		if (*s == '\'')
			fputs("'\\''", f);
		else
			fputc(*s, f);
	fputc('\'', f);
}

char *slurm_script(const slurm_script_t *sc)
{
	char *buf = NULL;
	size_t len = 0;
	FILE *f = open_memstream(&buf, &len);
	if (!f)
		return NULL;
	fprintf(f, "#!/bin/sh\n# Written by granulard for one attempt of a job (docs/daemon.md, \"Running on a cluster\").\n");
	fprintf(f, "#SBATCH --job-name=%s\n#SBATCH --ntasks=%d\n", sc->name, sc->ranks);
	if (sc->nodes > 0)
		fprintf(f, "#SBATCH --nodes=%d\n", sc->nodes);
	if (sc->time_limit > 0)   /* minutes, rounded up: Slurm's granularity */
		fprintf(f, "#SBATCH --time=%ld\n", (sc->time_limit + 59) / 60);
	if (sc->partition && *sc->partition)
		fprintf(f, "#SBATCH --partition=%s\n", sc->partition);
	if (sc->account && *sc->account)
		fprintf(f, "#SBATCH --account=%s\n", sc->account);
	/* #SBATCH lines are not read by a shell: no quoting there, so a job
	 * directory with spaces is given on sbatch's command line instead
	 * (slurm_submit() runs in it: --chdir defaults to the submission's). */
	fprintf(f, "#SBATCH --output=%s\n#SBATCH --error=%s\n", sc->out, sc->err);
	/* Retries are granulard's: one Slurm job per attempt, never requeued by Slurm. */
	fprintf(f, "#SBATCH --no-requeue\n");
	fprintf(f, "exec ");
	quote(f, sc->srun);
	fprintf(f, " --mpi=%s --kill-on-bad-exit=1", sc->mpi);
	for (size_t i = 0; sc->argv[i]; i++) {
		fputc(' ', f);
		quote(f, sc->argv[i]);
	}
	fputc('\n', f);
	if (fclose(f)) {
		free(buf);
		return NULL;
	}
	return buf;
}

static double mono(void)
{
	struct timespec ts;
	clock_gettime(CLOCK_MONOTONIC, &ts);
	return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

extern char **environ;

/* Run argv in dir (NULL: here) with stdout and stderr captured together in
 * out (NUL-terminated, cut at n-1). Returns the exit status, or -1 (err). */
static int run(char *const argv[], const char *dir, char *out, size_t n, char *err, size_t errlen)
{
	int p[2];
	size_t got = 0;
	out[0] = '\0';
	if (pipe2(p, O_CLOEXEC)) {
		snprintf(err, errlen, "%s: pipe: %s", argv[0], strerror(errno));
		return -1;
	}
	pid_t pid = fork();
	if (pid < 0) {
		snprintf(err, errlen, "%s: fork: %s", argv[0], strerror(errno));
		close(p[0]);
		close(p[1]);
		return -1;
	}
	if (pid == 0) {
		/* Child of a multi-threaded process: async-signal-safe calls only. */
		sigset_t none;
		sigemptyset(&none);
		sigprocmask(SIG_SETMASK, &none, NULL);
		signal(SIGPIPE, SIG_DFL);
		int nul = open("/dev/null", O_RDONLY);
		if (nul >= 0)
			dup2(nul, 0);
		dup2(p[1], 1);
		dup2(p[1], 2);
		close_range(3, ~0U, 0);
		if (!dir || chdir(dir) == 0)
			execvpe(argv[0], argv, environ);
		_exit(127);
	}
	close(p[1]);
	double dl = mono() + CMD_TIMEOUT;
	int timed_out = 0;
	for (;;) {
		double left = dl - mono();
		if (left <= 0) {
			timed_out = 1;
			break;
		}
		struct pollfd pf = {.fd = p[0], .events = POLLIN};
		if (poll(&pf, 1, (int)(left * 1000) + 1) <= 0)
			continue;
		char tmp[4096];
		ssize_t r = read(p[0], tmp, sizeof(tmp));
		if (r < 0 && errno == EINTR)
			continue;
		if (r <= 0)
			break;
		size_t take = (size_t)r < n - 1 - got ? (size_t)r : n - 1 - got;
		memcpy(out + got, tmp, take);
		got += take;
		out[got] = '\0';
	}
	close(p[0]);
	if (timed_out)
		kill(pid, SIGKILL);
	int st = 0;
	while (waitpid(pid, &st, 0) < 0 && errno == EINTR)
		;
	if (timed_out) {
		snprintf(err, errlen, "%s: no answer in %.0f s", argv[0], CMD_TIMEOUT);
		return -1;
	}
	if (WIFEXITED(st) && WEXITSTATUS(st) == 127 && !got) {
		snprintf(err, errlen, "%s: cannot execute", argv[0]);
		return -1;
	}
	return WIFEXITED(st) ? WEXITSTATUS(st) : 128 + WTERMSIG(st);
}

/* err = "PROGRAM: its first line of output" */
static void said(char *err, size_t errlen, const char *prog, const char *out, int rc)
{
	size_t len = strcspn(out, "\n");
	snprintf(err, errlen, "%s exited with status %d%s%.*s", prog, rc, len ? ": " : "", (int)len, out);
}

/* run() for a command whose only answer is its exit status: SLURM_OK on 0, else SLURM_EFAIL with err set
 * (by run() when it could not run it, by said() when it failed). */
static int run_ok(char *const argv[], char *out, size_t n, char *err, size_t errlen)
{
	int rc = run(argv, NULL, out, n, err, errlen);
	if (rc < 0)
		return SLURM_EFAIL;
	if (rc != 0) {
		said(err, errlen, argv[0], out, rc);
		return SLURM_EFAIL;
	}
	return SLURM_OK;
}

int slurm_submit(const cfg_t *c, const char *script_path, int64_t *job, char *err, size_t errlen)
{
	char out[4096], dir[4096];
	snprintf(dir, sizeof(dir), "%s", script_path);
	char *slash = strrchr(dir, '/');
	if (slash)
		*slash = '\0';
	char *const argv[] = {c->sbatch, "--parsable", (char *)script_path, NULL};
	int rc = run(argv, slash ? dir : NULL, out, sizeof(out), err, errlen);
	if (rc < 0)
		return SLURM_EFAIL;
	char *end = NULL;
	long long id = strtoll(out, &end, 10);   /* "ID" or "ID;CLUSTER" */
	if (rc != 0 || id <= 0 || end == out || (*end && *end != ';' && *end != '\n')) {
		said(err, errlen, c->sbatch, out, rc);
		return SLURM_EFAIL;
	}
	*job = id;
	return SLURM_OK;
}

int slurm_query(const cfg_t *c, int64_t job, slurm_job_t *out, char *err, size_t errlen)
{
	char text[16384], id[32];
	snprintf(id, sizeof(id), "%" PRId64, job);
	char *const argv[] = {c->scontrol, "show", "job", "-o", id, NULL};
	int rc = run(argv, NULL, text, sizeof(text), err, errlen);
	if (rc < 0)
		return SLURM_EFAIL;
	if (rc != 0 && strstr(text, "Invalid job id")) {
		memset(out, 0, sizeof(*out));
		out->state = SLURM_GONE;
		return SLURM_EGONE;
	}
	if (rc != 0 || slurm_parse_show_job(text, out)) {
		said(err, errlen, c->scontrol, text, rc);
		return SLURM_EFAIL;
	}
	return SLURM_OK;
}

void slurm_parse_squeue(const char *text, const int64_t *ids, size_t n, slurm_job_t *out)
{
	for (size_t i = 0; i < n; i++) {
		memset(&out[i], 0, sizeof(out[i]));
		out[i].state = SLURM_GONE;
	}
	for (const char *p = text; *p;) {
		size_t len = strcspn(p, "\n");
		char line[256], word[32], reason[96] = "";
		long long id;
		snprintf(line, sizeof(line), "%.*s", (int)len, p);
		p += len + (p[len] == '\n');
		if (sscanf(line, "%lld|%31[^|]|%95[^\n]", &id, word, reason) < 2)
			continue;
		for (size_t i = 0; i < n; i++)
			if (ids[i] == id) {
				out[i].state = slurm_state_parse(word);
				snprintf(out[i].word, sizeof(out[i].word), "%s", word);
				if (strcmp(reason, "None"))
					snprintf(out[i].reason, sizeof(out[i].reason), "%s", reason);
			}
	}
}

int slurm_states(const cfg_t *c, const int64_t *ids, size_t n, slurm_job_t *out, char *err, size_t errlen)
{
	size_t cap = n * 24 + 1;
	char *list = malloc(cap), *text = malloc(OUT_MAX);
	int ret = SLURM_EFAIL;
	if (!list || !text) {
		snprintf(err, errlen, "out of memory");
		goto cleanup;
	}
	list[0] = '\0';
	for (size_t i = 0, o = 0; i < n; i++)
		o += (size_t)snprintf(list + o, cap - o, "%s%" PRId64, i ? "," : "", ids[i]);
	char *const argv[] = {c->squeue, "-h", "-t", "all", "-j", list, "-o", "%i|%T|%r", NULL};
	int rc = run(argv, NULL, text, OUT_MAX, err, errlen);
	if (rc < 0)
		goto cleanup;
	/* Every id unknown: squeue says so and fails; some unknown: they are left out. */
	if (rc != 0 && !strstr(text, "Invalid job id")) {
		said(err, errlen, c->squeue, text, rc);
		goto cleanup;
	}
	slurm_parse_squeue(rc ? "" : text, ids, n, out);
	ret = SLURM_OK;
cleanup:
	free(list);
	free(text);
	return ret;
}

int slurm_cancel(const cfg_t *c, int64_t job, const char *sig, char *err, size_t errlen)
{
	char out[4096], id[32], sigopt[48];
	snprintf(id, sizeof(id), "%" PRId64, job);
	snprintf(sigopt, sizeof(sigopt), "--signal=%s", sig ? sig : "");
	char *const with[] = {c->scancel, sigopt, id, NULL};
	char *const plain[] = {c->scancel, id, NULL};
	return run_ok(sig ? with : plain, out, sizeof(out), err, errlen);
}

int slurm_cancel_name(const cfg_t *c, const char *name, char *err, size_t errlen)
{
	char out[4096], opt[160];
	snprintf(opt, sizeof(opt), "--name=%s", name);
	char *const argv[] = {c->scancel, opt, NULL};
	return run_ok(argv, out, sizeof(out), err, errlen);
}

int slurm_find(const cfg_t *c, const char *name, int64_t *job, char *err, size_t errlen)
{
	char out[4096];
	char *const argv[] = {c->squeue, "-h", "-n", (char *)name, "-o", "%i", NULL};
	*job = 0;
	if (run_ok(argv, out, sizeof(out), err, errlen) != SLURM_OK)
		return SLURM_EFAIL;
	*job = strtoll(out, NULL, 10);
	return SLURM_OK;
}

json_t *slurm_parse_partition(const char *partition, const char *sinfo_out, const char *squeue_out)
{
	long total = 0, idle = 0, alloc = 0, mixed = 0, other = 0, ca = 0, ci = 0, co = 0, ct = 0, pending = 0;
	char name[128] = "";
	if (partition && *partition)
		snprintf(name, sizeof(name), "%s", partition);
	for (const char *p = sinfo_out; *p;) {
		size_t len = strcspn(p, "\n");
		char line[512], part[128], state[64];
		long nodes, a, i, o, t;
		snprintf(line, sizeof(line), "%.*s", (int)len, p);
		p += len + (p[len] == '\n');
		/* "%P|%D|%T|%C": partition (default marked with *), nodes, state, CPUs A/I/O/T */
		if (sscanf(line, "%127[^|]|%ld|%63[^|]|%ld/%ld/%ld/%ld", part, &nodes, state, &a, &i, &o, &t) != 7)
			continue;
		size_t pl = strlen(part);
		int dflt = pl && part[pl - 1] == '*';
		if (dflt)
			part[--pl] = '\0';
		if (*name ? strcmp(part, name) : !dflt)
			continue;
		snprintf(name, sizeof(name), "%s", part);
		total += nodes;
		size_t sl = strcspn(state, "*~#!%$@^-");   /* idle*, mixed~, ...: flags after the word */
		if (sl == 4 && !strncmp(state, "idle", 4))
			idle += nodes;
		else if ((sl == 9 && !strncmp(state, "allocated", 9)) || (sl == 5 && !strncmp(state, "alloc", 5)))
			alloc += nodes;
		else if ((sl == 5 && !strncmp(state, "mixed", 5)) || (sl == 3 && !strncmp(state, "mix", 3)))
			mixed += nodes;
		else
			other += nodes;
		ca += a;
		ci += i;
		co += o;
		ct += t;
	}
	for (const char *p = squeue_out; *p;) {
		size_t len = strcspn(p, "\n");
		if (len && strlen(name) == len && !strncmp(p, name, len))
			pending++;
		p += len + (p[len] == '\n');
	}
	return json_pack("{s:s, s:{s:i, s:i, s:i, s:i, s:i}, s:{s:i, s:i, s:i, s:i}, s:i}", "partition", name, "nodes",
	                 "total", (json_int_t)total, "idle", (json_int_t)idle, "allocated", (json_int_t)alloc, "mixed",
	                 (json_int_t)mixed, "other", (json_int_t)other, "cpus", "allocated", (json_int_t)ca, "idle",
	                 (json_int_t)ci, "other", (json_int_t)co, "total", (json_int_t)ct, "pending_jobs",
	                 (json_int_t)pending);
}

int slurm_partition(const cfg_t *c, json_t **out, char *err, size_t errlen)
{
	char *si = malloc(OUT_MAX), *sq = malloc(OUT_MAX);
	int ret = SLURM_EFAIL, rc;
	*out = NULL;
	if (!si || !sq) {
		snprintf(err, errlen, "out of memory");
		goto cleanup;
	}
	char *const a1[] = {c->sinfo, "-h", "-o", "%P|%D|%T|%C", NULL};
	if ((rc = run(a1, NULL, si, OUT_MAX, err, errlen)) != 0) {
		if (rc > 0)
			said(err, errlen, c->sinfo, si, rc);
		goto cleanup;
	}
	char *const a2[] = {c->squeue, "-h", "-t", "pending", "-o", "%P", NULL};
	if ((rc = run(a2, NULL, sq, OUT_MAX, err, errlen)) != 0) {
		if (rc > 0)
			said(err, errlen, c->squeue, sq, rc);
		goto cleanup;
	}
	*out = slurm_parse_partition(c->slurm_partition, si, sq);
	if (!*out) {
		snprintf(err, errlen, "out of memory");
		goto cleanup;
	}
	ret = SLURM_OK;
cleanup:
	free(si);
	free(sq);
	return ret;
}
