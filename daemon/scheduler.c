/* Job supervisor thread: launch, follow, stop and reap engine runs; record every outcome in the job queue. */
#define _GNU_SOURCE
#include <errno.h>
#include <fcntl.h>
#include <inttypes.h>
#include <limits.h>
#include <poll.h>
#include <pthread.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>
#include "ingest.h"
#include "log.h"
#include "quota.h"
#include "scene.h"
#include "scheduler.h"
#include "slurm.h"
#include "util.h"

#define MAX_CHILDREN 4096
#define LINE_MAX_BYTES (1 << 16)
#define TAIL_BYTES 2048
/* Bounded work per wake-up: one read of at most this many bytes per pipe per
 * loop turn, so that requests, deadlines and reaping never wait behind an
 * engine that writes without pause. */
#define READ_BYTES (1 << 16)
/* At the end of a run, what is left in its pipes is read up to this much;
 * beyond (ranks that would not die), the rest is abandoned. */
#define FINAL_READ_BYTES (16 << 20)
/* Queued jobs are looked at when woken (submission, cancel), after a job
 * ends, and at least this often (seconds). */
#define CLAIM_PERIOD 1.0

typedef struct {
	int64_t id;
	int attempt, ranks;
	pid_t pid;
	int out, err;                /* pipe read ends, -1 at EOF */
	int reaped, status;
	ingest_t *ing;               /* stdout: progress records, thinned and batched */
	char tail[TAIL_BYTES];       /* last stderr bytes (ring) */
	size_t ntail;
	double started, term_at, kill_at;   /* monotonic seconds; 0 = not scheduled */
	int cancel, walllimit, failed_start;
	double last_wall, rate;      /* events/s from successive records */
	int64_t last_events;
	int summary_seen;
	double until;                /* the stop condition: time, or collisions per particle when until_cpp */
	int until_cpp;
	pid_t desc[16];              /* mpirun's ranks (own process groups): signalled one by one */
	uint64_t desc_start[16];
	int ndesc;
	double desc_at;              /* when desc was refreshed */
	char status_word[32];        /* summary status: completed, quiescent, interrupted */
	int resumed, ckpt_noted;     /* launched with --resume; fallback seen (note_fallback()) */
	char head[1024];             /* first stderr bytes: the engine's resume line comes first */
	size_t nhead;
	int over_output;             /* stopped for its output limit (quota.h): over_msg says why */
	char over_msg[320];
	/* launcher = slurm (pid stays 0): the attempt is Slurm job sjob; out and
	 * err are its output files in the job directory, tailed, not pipes. */
	int64_t sjob;
	char sstate_text[160];       /* as stored: "pending (Resources)" */
	double spoll_at;             /* next look at its Slurm state */
	int wall_own;                /* its Slurm time limit is max_wall_seconds: a timeout fails the job */
	int sretry;                  /* ended by Slurm, not by the engine (timeout, node failure, ...): retry */
	char swhy[200];              /* what Slurm said, for the reason */
	char *skip;                  /* adopted after a restart: the last stored record; output up to it was read */
	char swarned[200];           /* the last query error logged (logged once) */
} child_t;

/* A slot in use: a local launch (pid) or a Slurm job (sjob). */
static int busy(const child_t *k) { return k->pid || k->sjob; }

struct sched {
	sched_conf_t c;
	pthread_t thread;
	int started;
	int wake[2];
	pthread_mutex_t lock;        /* guards requests and stats below */
	int64_t *cancels;
	size_t ncancels, capcancels;
	int stopping;
	double stop_deadline;
	sched_stats_t stats;
	child_t *kids;
	size_t nkids;
	double reserve_at;           /* last ballast check (monotonic s) */
	int warned_full;
	quota_t *quota;              /* output limits of running jobs */
	double claim_at;             /* last look at the queue (monotonic s) */
	int slurm;                   /* launcher = slurm */
	char tag[32];                /* "granulard-XXXXXXXX": Slurm job names of this state dir */
	char swarned[512];           /* the last squeue failure logged (logged once) */
	char rbuf[READ_BYTES];
};

static double mono(void)
{
	struct timespec ts;
	clock_gettime(CLOCK_MONOTONIC, &ts);
	return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

void sched_publish_state(jobq_t *q, hub_t *hub, int64_t id)
{
	json_t *j = NULL;
	char err[256];
	if (jobq_get(q, id, 0, &j, err, sizeof(err)) == JOBQ_OK) {
		char *s = json_dumps(j, JSON_COMPACT);
		if (s)
			hub_publish(hub, id, "state", s);
		free(s);
		json_decref(j);
	}
}

sched_t *sched_create(const sched_conf_t *conf)
{
	sched_t *s = calloc(1, sizeof(*s));
	if (!s)
		return NULL;
	s->c = *conf;
	s->kids = calloc(MAX_CHILDREN, sizeof(child_t));
	s->quota = quota_create(conf->q, conf->jobs_dir, 1.0);
	if (!s->kids || !s->quota || pipe2(s->wake, O_CLOEXEC | O_NONBLOCK)) {
		quota_destroy(s->quota);
		free(s->kids);
		free(s);
		return NULL;
	}
	pthread_mutex_init(&s->lock, NULL);
	s->stats.slots = (int)conf->cfg->slots;
	s->slurm = conf->cfg->launcher && !strcmp(conf->cfg->launcher, "slurm");
	/* Job names tell this daemon's jobs from others' on the same cluster:
	 * FNV-1a of the jobs directory's absolute path. */
	char abs[PATH_MAX];
	const char *d = realpath(conf->jobs_dir, abs) ? abs : conf->jobs_dir;
	uint32_t h = 2166136261u;
	for (const char *p = d; *p; p++)
		h = (h ^ (unsigned char)*p) * 16777619u;
	snprintf(s->tag, sizeof(s->tag), "granulard-%08x", h);
	return s;
}

void sched_destroy(sched_t *s)
{
	if (!s)
		return;
	close(s->wake[0]);
	close(s->wake[1]);
	pthread_mutex_destroy(&s->lock);
	free(s->cancels);
	for (size_t i = 0; s->kids && i < s->nkids; i++)
		free(s->kids[i].skip);
	free(s->kids);
	quota_destroy(s->quota);
	free(s);
}

void sched_wake(sched_t *s)
{
	ssize_t r = write(s->wake[1], "w", 1);
	(void)r;   /* a full pipe already means "wake up" */
}

void sched_cancel(sched_t *s, int64_t id)
{
	pthread_mutex_lock(&s->lock);
	if (s->ncancels == s->capcancels) {
		size_t cap = s->capcancels ? 2 * s->capcancels : 16;
		int64_t *p = realloc(s->cancels, cap * sizeof(*p));
		if (p) {
			s->cancels = p;
			s->capcancels = cap;
		}
	}
	if (s->ncancels < s->capcancels)
		s->cancels[s->ncancels++] = id;
	pthread_mutex_unlock(&s->lock);
	sched_wake(s);
}

void sched_stats(sched_t *s, sched_stats_t *out)
{
	pthread_mutex_lock(&s->lock);
	*out = s->stats;
	pthread_mutex_unlock(&s->lock);
}

/* ---- launching ------------------------------------------------------------- */

/* Expand the launch template into argv (malloc'd strings, NULL-terminated). */
static char **build_argv(const sched_t *s, const child_t *k, const char *scene, const char *dir, const char *resume,
                         const char *jobs_dir)
{
	const char *tpl = s->c.cfg->launch;
	size_t cap = 8, n = 0;
	char **av = calloc(cap, sizeof(char *)), ranks[16];
	snprintf(ranks, sizeof(ranks), "%d", k->ranks);
	const char *ph[][2] = {{"{mpirun}", s->c.cfg->mpirun}, {"{ranks}", ranks}, {"{engine}", s->c.engine},
	                       {"{scene}", scene}, {"{dir}", dir}};
	const char *p = tpl;
	while (av && *p) {
		while (*p == ' ')
			p++;
		if (!*p)
			break;
		size_t len = strcspn(p, " ");
		char tok[1024];
		snprintf(tok, sizeof(tok), "%.*s", (int)len, p);
		p += len;
		char *val = NULL;
		for (size_t i = 0; i < sizeof(ph) / sizeof(ph[0]) && !val; i++)
			if (!strcmp(tok, ph[i][0]))
				val = strdup(ph[i][1]);
		if (!val)
			val = strdup(tok);
		if (n + 4 >= cap) {
			cap *= 2;
			char **q = realloc(av, cap * sizeof(char *));
			if (!q)
				break;
			av = q;
		}
		av[n++] = val;
	}
	if (av && resume) {
		av[n++] = strdup("--resume");
		av[n++] = strdup(resume);
	}
	if (av && jobs_dir) {
		av[n++] = strdup("--jobs-dir");
		av[n++] = strdup(jobs_dir);
	}
	if (av)
		av[n] = NULL;
	return av;
}

static void free_argv(char **av)
{
	for (size_t i = 0; av && av[i]; i++)
		free(av[i]);
	free(av);
}

static void tail_add(child_t *k, const char *b, size_t n)
{
	for (size_t i = 0; i < n; i++) {
		k->tail[k->ntail % TAIL_BYTES] = b[i];
		k->ntail++;
	}
}

/* The stderr tail as a string (last TAIL_BYTES, starting at a line break when possible). */
static char *tail_str(const child_t *k)
{
	size_t n = k->ntail < TAIL_BYTES ? k->ntail : TAIL_BYTES, start = k->ntail - n;
	char *s = malloc(n + 1);
	if (!s)
		return NULL;
	for (size_t i = 0; i < n; i++)
		s[i] = k->tail[(start + i) % TAIL_BYTES];
	s[n] = '\0';
	char *p = s;
	if (k->ntail > TAIL_BYTES && (p = strchr(s, '\n')))
		memmove(s, p + 1, strlen(p + 1) + 1);
	return s;
}

/* The line of the stderr tail that says what went wrong: the engine writes
 * its one-line error before mpirun adds its banners (blocks framed by rules
 * of dashes), so take the last line before the first rule; without rules, the
 * last line. */
static void last_line(const char *tail, char *out, size_t n)
{
	const char *best = NULL, *after = NULL;
	size_t best_len = 0, after_len = 0;
	int ruled = 0;
	for (const char *p = tail; *p;) {
		size_t len = strcspn(p, "\n");
		int rule = len >= 10 && strspn(p, "-") == len;
		if (rule)
			ruled = 1;
		else if (len && !ruled) {
			best = p;
			best_len = len;
		} else if (len && strspn(p, " ") < len) {
			after = p;
			after_len = len;
		}
		p += len + (p[len] == '\n');
	}
	if (!best) {
		best = after;
		best_len = after_len;
	}
	snprintf(out, n, "%.*s", best ? (int)best_len : 0, best ? best : "");
}

/* Launcher chatter on stdout (not a record): keep it with stderr for diagnosis. */
static void chatter(void *ctx, const char *line, size_t len)
{
	child_t *k = ctx;
	tail_add(k, line, len);
	tail_add(k, "\n", 1);
}

/* The launched command's environment: the daemon's, plus
 * OMPI_MCA_odls_base_sigkill_timeout=0 unless set: Open MPI's mpirun
 * otherwise waits 1 s twice before it exits after a rank's non-zero exit
 * (exit 4 after a checkpoint), which would hold a cancel for 2 s. Harmless
 * for other launchers. malloc'd array (entries borrowed), NULL on ENOMEM. */
extern char **environ;
static char **child_env(void)
{
	static char kill_timeout[] = "OMPI_MCA_odls_base_sigkill_timeout=0";
	size_t n = 0;
	int have = 0;
	for (; environ[n]; n++)
		have |= !strncmp(environ[n], kill_timeout, strlen("OMPI_MCA_odls_base_sigkill_timeout="));
	char **env = calloc(n + 2, sizeof(char *));
	if (!env)
		return NULL;
	memcpy(env, environ, n * sizeof(char *));
	if (!have)
		env[n] = kill_timeout;
	return env;
}

/* Progress ingestion of a launched attempt (its ingest; the rate clock). */
static void follow(sched_t *s, child_t *k, double now)
{
	const ingest_conf_t ic = {.rate = s->c.cfg->progress_rate, .burst = (double)s->c.cfg->progress_burst,
	                          .flush = s->c.cfg->progress_flush, .max_batch = 4096,
	                          .max_line = LINE_MAX_BYTES, .chatter = chatter, .ctx = k};
	k->ing = ingest_create(&ic, now);
	if (!k->ing)
		log_warning("job %" PRId64 ": no memory to follow its progress", k->id);
	k->last_wall = now;
}

/* launcher = slurm: the attempt becomes a Slurm job. The batch script
 * (DIR/attempt-N.sbatch) runs the engine under srun; its stdout and stderr
 * go to DIR/attempt-N.out and .err, which the daemon tails (docs/daemon.md,
 * "Running on a cluster"). 0, or -1 with err (nothing submitted). */
static int launch_slurm(sched_t *s, child_t *k, const jobq_claim_t *cl, const char *dir, const char *scene,
                        const char *resume, const char *jobs, char *err, size_t errlen)
{
	char name[96], out[64], errf[64], path[4200];
	const cfg_t *c = s->c.cfg;
	char *argv[12];
	int n = 0;
	argv[n++] = (char *)s->c.engine;
	argv[n++] = "run";
	argv[n++] = (char *)scene;
	argv[n++] = "--out";
	argv[n++] = (char *)dir;
	if (resume) {
		argv[n++] = "--resume";
		argv[n++] = (char *)resume;
	}
	if (jobs) {
		argv[n++] = "--jobs-dir";
		argv[n++] = (char *)jobs;
	}
	argv[n] = NULL;
	snprintf(name, sizeof(name), "%s-%" PRId64 "-%d", s->tag, cl->id, cl->attempt);
	snprintf(out, sizeof(out), "attempt-%d.out", cl->attempt);
	snprintf(errf, sizeof(errf), "attempt-%d.err", cl->attempt);
	/* The job's own options (validated at submission) within the config's:
	 * a job may ask for less time than slurm_time_limit, not more; and
	 * max_wall_seconds bounds an attempt whatever the launcher. */
	json_t *opt = cl->slurm ? json_loads(cl->slurm, 0, NULL) : NULL;
	long limit = c->slurm_time_limit, want = (long)json_integer_value(json_object_get(opt, "time_limit"));
	if (want > 0 && (limit == 0 || want < limit))
		limit = want;
	if (c->max_wall_seconds > 0 && (limit == 0 || c->max_wall_seconds < limit))
		limit = c->max_wall_seconds;
	const char *part = json_string_value(json_object_get(opt, "partition"));
	const char *acct = json_string_value(json_object_get(opt, "account"));
	const slurm_script_t sc = {.name = name, .ranks = cl->ranks, .time_limit = limit,
	                           .nodes = (int)json_integer_value(json_object_get(opt, "nodes")),
	                           .partition = part ? part : c->slurm_partition, .account = acct ? acct : c->slurm_account, .dir = dir,
	                           .out = out, .err = errf, .srun = c->srun, .mpi = c->slurm_mpi, .argv = argv};
	char *text = slurm_script(&sc);
	json_decref(opt);
	snprintf(path, sizeof(path), "%s/attempt-%d.sbatch", dir, cl->attempt);
	if (!text) {
		snprintf(err, errlen, "out of memory");
		return -1;
	}
	int r = util_write_atomic(path, text, strlen(text), err, errlen);
	free(text);
	if (r)
		return -1;
	int64_t job = 0;
	if (slurm_submit(c, path, &job, err, errlen)) {
		/* sbatch may have submitted before its answer was lost (timeout):
		 * a job of this attempt's name must not run behind a failed job. */
		char e2[256];
		if (slurm_cancel_name(c, name, e2, sizeof(e2)))
			log_warning("job %" PRId64 ": %s", cl->id, e2);
		return -1;
	}
	k->sjob = job;
	k->out = k->err = -1;
	k->started = mono();
	k->spoll_at = k->started + c->slurm_poll;
	k->wall_own = c->max_wall_seconds > 0 && limit == c->max_wall_seconds;
	if (jobq_attempt_slurm(s->c.q, cl->id, cl->attempt, job, resume ? "checkpoint.h5" : NULL) != JOBQ_OK)
		log_error("job %" PRId64 " attempt %d: could not record Slurm job %" PRId64
		          " (a restarted daemon finds it by its name %s)", cl->id, cl->attempt, job, name);
	log_info("job %" PRId64 " attempt %d: submitted as Slurm job %" PRId64 " (%s) with %d rank(s)%s", cl->id,
	         cl->attempt, job, name, cl->ranks, resume ? ", resuming from checkpoint.h5" : "");
	return 0;
}

static int launch(sched_t *s, const jobq_claim_t *cl)
{
	char dir[4096], scene[4200], ckpt[4200], err[512];
	child_t *k = NULL;
	char **av = NULL, **env = NULL;
	int po[2] = {-1, -1}, pe[2] = {-1, -1};
	const char *resume = NULL;
	pid_t pid;

	for (size_t i = 0; i < MAX_CHILDREN && !k; i++)
		if (!s->kids[i].pid && !s->kids[i].id)
			k = &s->kids[i];
	snprintf(dir, sizeof(dir), "%s/%" PRId64, s->c.jobs_dir, cl->id);
	snprintf(scene, sizeof(scene), "%s/scene.json", dir);
	snprintf(ckpt, sizeof(ckpt), "%s/checkpoint.h5", dir);
	if (!k) {
		snprintf(err, sizeof(err), "too many running jobs in this daemon");
		goto fail;
	}
	if (util_mkdirs(dir, 0750) || util_write_atomic(scene, cl->scene, strlen(cl->scene), err, sizeof(err))) {
		if (!*err || util_mkdirs(dir, 0750))
			snprintf(err, sizeof(err), "cannot create job directory %s: %s", dir, strerror(errno));
		goto fail;
	}
	if (access(ckpt, R_OK) == 0)
		resume = ckpt;   /* a previous attempt left a checkpoint: continue from it */
	memset(k, 0, sizeof(*k));
	k->id = cl->id;
	k->attempt = cl->attempt;
	k->resumed = resume != NULL;
	k->ranks = cl->ranks;
	k->until = cl->until;
	k->until_cpp = cl->until_cpp;
	/* particles.initial.from.job: the engine finds JOBS/ID/trajectory.h5
	 * (docs/scene.md); absolute, since the engine runs in the job's directory */
	scene_t sc;
	char jobs_abs[PATH_MAX];
	const char *jobs = NULL;
	if (strstr(cl->scene, "\"from\"") && scene_parse(cl->scene, strlen(cl->scene), &sc, NULL, 0) == SCENE_OK &&
	    sc.from_job)
		jobs = realpath(s->c.jobs_dir, jobs_abs) ? jobs_abs : s->c.jobs_dir;
	if (s->slurm) {
		if (launch_slurm(s, k, cl, dir, scene, resume, jobs, err, sizeof(err)))
			goto fail;
		follow(s, k, k->started);
		if (s->nkids < (size_t)(k - s->kids) + 1)
			s->nkids = (size_t)(k - s->kids) + 1;
		return 0;
	}
	av = build_argv(s, k, scene, dir, resume, jobs);
	env = child_env();
	if (!av || !env || pipe2(po, O_CLOEXEC) || pipe2(pe, O_CLOEXEC)) {
		snprintf(err, sizeof(err), "cannot launch: %s", strerror(errno ? errno : ENOMEM));
		goto fail;
	}
	pid = fork();
	if (pid < 0) {
		snprintf(err, sizeof(err), "fork: %s", strerror(errno));
		goto fail;
	}
	if (pid == 0) {
		/* Child of a multi-threaded process: async-signal-safe calls only. */
		int nul = open("/dev/null", O_RDONLY);
		sigset_t none;
		sigemptyset(&none);
		/* The daemon blocks SIGTERM for sigwait() and ignores SIGPIPE; both
		 * would be inherited across exec and make the job unstoppable. */
		sigprocmask(SIG_SETMASK, &none, NULL);
		signal(SIGPIPE, SIG_DFL);
		setsid();
		if (nul >= 0)
			dup2(nul, 0);
		dup2(po[1], 1);
		dup2(pe[1], 2);
		close_range(3, ~0U, 0);
		if (chdir(dir) == 0)
			execvpe(av[0], av, env);
		const char *m = "granulard: cannot execute the launcher: ";
		ssize_t w = write(2, m, strlen(m));
		w = write(2, av[0], strlen(av[0]));
		w = write(2, "\n", 1);
		(void)w;
		_exit(127);
	}
	close(po[1]);
	close(pe[1]);
	fcntl(po[0], F_SETFL, O_NONBLOCK);
	fcntl(pe[0], F_SETFL, O_NONBLOCK);
	k->pid = pid;
	k->out = po[0];
	k->err = pe[0];
	k->started = mono();
	follow(s, k, k->started);
	if (s->c.cfg->max_wall_seconds > 0)
		k->term_at = k->started + (double)s->c.cfg->max_wall_seconds;
	if (s->nkids < (size_t)(k - s->kids) + 1)
		s->nkids = (size_t)(k - s->kids) + 1;
	jobq_attempt_launched(s->c.q, cl->id, cl->attempt, pid, util_pid_start(pid), resume ? "checkpoint.h5" : NULL);
	log_info("job %" PRId64 " attempt %d: launched pid %d with %d rank(s)%s", cl->id, cl->attempt, (int)pid,
	         cl->ranks, resume ? ", resuming from checkpoint.h5" : "");
	free_argv(av);
	free(env);
	return 0;
fail:
	if (po[0] >= 0) {
		close(po[0]);
		close(po[1]);
	}
	if (pe[0] >= 0) {
		close(pe[0]);
		close(pe[1]);
	}
	free_argv(av);
	free(env);
	if (k)
		memset(k, 0, sizeof(*k));
	log_error("job %" PRId64 ": %s", cl->id, err);
	jobq_attempt_finished(s->c.q, cl->id, cl->attempt, util_now(), -1, 0, err, NULL, JOB_FAILED);
	sched_publish_state(s->c.q, s->c.hub, cl->id);
	return -1;
}

/* ---- following ------------------------------------------------------------- */

/* What the supervisor itself learns from an accepted record: the summary's
 * status, the event rate, the fraction of the stop condition. */
static double note_record(child_t *k, const json_t *r)
{
	const char *kind = json_string_value(json_object_get(r, "type"));
	json_t *ev = json_object_get(r, "events"), *wall = json_object_get(r, "wall_seconds");
	if (kind && !strcmp(kind, "summary")) {
		k->summary_seen = 1;
		const char *st = json_string_value(json_object_get(r, "status"));
		snprintf(k->status_word, sizeof(k->status_word), "%s", st ? st : "");
	}
	if (json_is_integer(ev) && json_is_number(wall)) {
		double w = json_number_value(wall);
		int64_t e = (int64_t)json_integer_value(ev);
		if (w > k->last_wall - k->started + 1e-3 && k->last_events >= 0) {
			double dw = w - (k->last_wall - k->started);
			k->rate = (double)(e - k->last_events) / dw;
		}
		k->last_wall = k->started + w;
		k->last_events = e;
	}
	/* Progress is the fraction of the stop condition reached. */
	json_t *x = json_object_get(r, k->until_cpp ? "collisions_per_particle" : "time");
	return json_is_number(x) && k->until > 0 ? json_number_value(x) / k->until : -1.0;
}

/* Store the pending batch of accepted records in one transaction, then
 * publish them to live subscribers (stored first, as for state changes). */
static void flush_progress(sched_t *s, child_t *k, double now)
{
	const ingest_record_t *recs;
	ingest_counts_t d;
	if (!k->ing)
		return;
	size_t n = ingest_batch(k->ing, &recs, &d);
	if (!n && !d.received)
		return;
	jobq_record_t *jr = n ? malloc(n * sizeof(*jr)) : NULL;
	if (n && !jr) {
		log_warning("job %" PRId64 ": no memory to store %zu progress records", k->id, n);
		ingest_taken(k->ing, now);
		return;
	}
	for (size_t i = 0; i < n; i++)
		jr[i] = (jobq_record_t){.line = recs[i].line, .r = recs[i].r, .frac = note_record(k, recs[i].r)};
	int rc = jobq_attempt_progress_batch(s->c.q, k->id, k->attempt, jr, n, (int64_t)d.received,
	                                     (int64_t)d.thinned, util_now());
	free(jr);
	if (rc != JOBQ_OK && rc != JOBQ_EFULL)   /* on a full disk records are dropped on purpose (and counted) */
		log_warning("job %" PRId64 ": could not store %zu progress records", k->id, n);
	/* Live subscribers of the multiplexed stream need to know whose record it is. */
	for (size_t i = 0; i < n; i++) {
		const char *line = recs[i].line;
		size_t ll = strlen(line);
		char *tagged = malloc(ll + 32);
		if (tagged) {
			snprintf(tagged, ll + 32, "{\"job\":%" PRId64 ",%s", k->id, line + 1);
			hub_publish(s->c.hub, k->id, "progress", tagged);
		}
		free(tagged);
	}
	ingest_taken(k->ing, now);
}

/* The engine could not verify checkpoint.h5 and resumed from the previous
 * one: its first stderr line is "granular-engine: --resume ...; using
 * DIR/checkpoint.prev.h5" (engine/main.c, printed only when that file
 * loaded). Record the file really used on the attempt, once. */
static void note_fallback(sched_t *s, child_t *k, const char *b, size_t n)
{
	static const char want[] = "; using ";
	static const char prev[] = "/checkpoint.prev.h5\n";
	if (!k->resumed || k->ckpt_noted || k->nhead >= sizeof(k->head) - 1)
		return;
	size_t take = n < sizeof(k->head) - 1 - k->nhead ? n : sizeof(k->head) - 1 - k->nhead;
	memcpy(k->head + k->nhead, b, take);
	k->nhead += take;
	k->head[k->nhead] = '\0';
	const char *line = strstr(k->head, "granular-engine: --resume ");
	const char *eol = line ? strchr(line, '\n') : NULL;
	if (!eol)
		return;   /* not (yet) a whole line */
	k->ckpt_noted = 1;
	const char *u = strstr(line, want);
	if (!u || u > eol || (size_t)(eol + 1 - line) < sizeof(prev) - 1 ||
	    memcmp(eol + 1 - (sizeof(prev) - 1), prev, sizeof(prev) - 1))
		return;
	if (jobq_attempt_checkpoint(s->c.q, k->id, k->attempt, "checkpoint.prev.h5") != JOBQ_OK)
		log_warning("job %" PRId64 " attempt %d: could not record the checkpoint used", k->id, k->attempt);
	else
		log_info("job %" PRId64 " attempt %d: checkpoint.h5 did not verify, resumed from checkpoint.prev.h5",
		         k->id, k->attempt);
}

/* Read what one pipe holds, at most `budget` bytes (one read when budget is
 * READ_BYTES). Closes the fd at EOF. */
static void read_fd(sched_t *s, child_t *k, int *fd, int is_out, size_t budget, double now)
{
	while (budget) {
		ssize_t n = read(*fd, s->rbuf, budget < READ_BYTES ? budget : READ_BYTES);
		if (n > 0) {
			if (!is_out) {
				tail_add(k, s->rbuf, (size_t)n);
				note_fallback(s, k, s->rbuf, (size_t)n);
			}
			else if (k->ing)
				ingest_feed(k->ing, s->rbuf, (size_t)n, now);
			budget -= (size_t)n < budget ? (size_t)n : budget;
			continue;
		}
		/* A Slurm attempt's output file: its end is only "nothing yet". */
		if (k->sjob && n == 0)
			return;
		if (n == 0 || (errno != EAGAIN && errno != EINTR)) {
			close(*fd);
			*fd = -1;
		}
		return;
	}
}

/* Releases what a child slot holds (its ingestion; a Slurm attempt's output files) and empties the slot. */
static void kid_clear(child_t *k)
{
	ingest_destroy(k->ing);
	if (k->sjob) {
		if (k->out >= 0)
			close(k->out);
		if (k->err >= 0)
			close(k->err);
	}
	free(k->skip);
	memset(k, 0, sizeof(*k));
}

/* Decide the outcome of an ended attempt and record it. */
static void finish(sched_t *s, child_t *k)
{
	char reason[1024], ll[512];
	char *tail = tail_str(k);
	int code = -1, sig = 0, stopping;
	job_state_t next;
	pthread_mutex_lock(&s->lock);
	stopping = s->stopping;
	pthread_mutex_unlock(&s->lock);
	if (WIFEXITED(k->status))
		code = WEXITSTATUS(k->status);
	else if (WIFSIGNALED(k->status))
		sig = WTERMSIG(k->status);
	last_line(tail ? tail : "", ll, sizeof(ll));
	int cancel = k->cancel || jobq_cancel_requested(s->c.q, k->id) == 1;
	if (cancel) {
		next = JOB_CANCELLED;
		snprintf(reason, sizeof(reason), "cancelled by request");
	} else if (stopping) {
		next = JOB_QUEUED;
		snprintf(reason, sizeof(reason), "interrupted by daemon shutdown; requeued");
	} else if (k->over_output) {
		next = JOB_FAILED;
		snprintf(reason, sizeof(reason), "%s", k->over_msg);
	} else if (k->walllimit) {
		next = JOB_FAILED;
		snprintf(reason, sizeof(reason), "wall-time limit of %ld s exceeded", s->c.cfg->max_wall_seconds);
	} else if (k->sretry) {
		/* Slurm ended the attempt (time limit, node failure, preemption, a
		 * cancel from outside granulard): like a local crash, the job goes
		 * on from its checkpoint, within max_attempts. */
		char ckpt[4200];
		snprintf(ckpt, sizeof(ckpt), "%s/%" PRId64 "/checkpoint.h5", s->c.jobs_dir, k->id);
		int have = access(ckpt, R_OK) == 0;
		if (k->attempt < s->c.cfg->max_attempts) {
			next = JOB_QUEUED;
			snprintf(reason, sizeof(reason), "%s; %s (attempt %d of %ld)", k->swhy,
			         have ? "retrying from checkpoint" : "restarting (no checkpoint yet)", k->attempt + 1,
			         s->c.cfg->max_attempts);
		} else {
			next = JOB_FAILED;
			snprintf(reason, sizeof(reason), "%s; no attempts left (max_attempts %ld)", k->swhy,
			         s->c.cfg->max_attempts);
		}
	} else if (code == 4 && k->attempt < s->c.cfg->max_attempts) {
		/* Exit 4: the engine was told to stop (SIGTERM from outside the
		 * daemon), wrote a checkpoint and stopped: continue from it. */
		next = JOB_QUEUED;
		snprintf(reason, sizeof(reason), "engine stopped by SIGTERM from outside granulard after a checkpoint; "
		         "requeued (attempt %d of %ld)", k->attempt + 1, s->c.cfg->max_attempts);
	} else if (code == 0) {
		next = JOB_SUCCEEDED;
		if (!strcmp(k->status_word, "quiescent"))
			snprintf(reason, sizeof(reason), "quiescent: every particle at rest before the stop condition");
		else
			reason[0] = '\0';
	} else {
		next = JOB_FAILED;
		if (sig)
			snprintf(reason, sizeof(reason), "engine killed by signal %d (%s)%s%s", sig, strsignal(sig),
			         *ll ? ": " : "", ll);
		else if (code == 127)
			snprintf(reason, sizeof(reason), "%s", *ll ? ll : "could not execute the launcher");
		else
			snprintf(reason, sizeof(reason), "engine exited with status %d%s%s", code, *ll ? ": " : "", ll);
		/* A failed attempt that left a checkpoint is retried from it, but
		 * not exit 2: a bad scene or an inelastic collapse (docs/engine.md)
		 * is deterministic and would only recur. */
		char ckpt[4200];
		snprintf(ckpt, sizeof(ckpt), "%s/%" PRId64 "/checkpoint.h5", s->c.jobs_dir, k->id);
		if (code != 2 && access(ckpt, R_OK) == 0 && k->attempt < s->c.cfg->max_attempts) {
			next = JOB_QUEUED;
			size_t l = strlen(reason);
			snprintf(reason + l, sizeof(reason) - l, "; retrying from checkpoint (attempt %d of %ld)",
			         k->attempt + 1, s->c.cfg->max_attempts);
		}
	}
	if (jobq_attempt_finished(s->c.q, k->id, k->attempt, util_now(), sig ? -1 : code, sig, *reason ? reason : NULL,
	                          tail, next) != JOBQ_OK)
		log_error("job %" PRId64 ": could not record the end of attempt %d", k->id, k->attempt);
	log_info("job %" PRId64 " attempt %d: %s%s%s", k->id, k->attempt, job_state_name(next), *reason ? ": " : "",
	         reason);
	sched_publish_state(s->c.q, s->c.hub, k->id);
	free(tail);
	kid_clear(k);
}

static void refresh_desc(child_t *k, double now, int force)
{
	if (k->reaped || (!force && now - k->desc_at < 1.0))
		return;
	k->desc_at = now;
	k->ndesc = util_descendants(k->pid, k->desc, k->desc_start, 16);
}

/* SIGKILL: mpirun's process group and every rank we have seen (they sit in
 * groups of their own and would outlive a killed mpirun).
 * SIGTERM: the ranks only, when they are known. Open MPI's mpirun answers a
 * SIGTERM of its own by killing its ranks (SIGTERM, then SIGKILL after
 * odls_base_sigkill_timeout), which would cut their checkpoint short; the
 * ranks checkpoint, exit 4, and mpirun follows (launch() sets that timeout
 * to 0 so that mpirun does not linger after a rank's non-zero exit). Before
 * the ranks exist (a launch under way) there is nothing to checkpoint: the
 * process group gets it. */
static void signal_child(child_t *k, int sig, double now)
{
	int ranks = 0;
	if (sig == SIGTERM)
		refresh_desc(k, now, 1);
	for (int i = 0; i < k->ndesc; i++)
		if (util_pid_alive(k->desc[i], k->desc_start[i])) {
			kill(k->desc[i], sig);
			ranks++;
		}
	if (k->pid > 0 && !k->reaped && (sig != SIGTERM || !ranks))
		kill(-k->pid, sig);
}

/* A Slurm attempt's output file, once it exists (-1 before). An adopted
 * attempt's stdout (skip: the last record stored) is read from just after
 * that record: what came before is stored already, what came after is not. */
static int open_output(const char *dir, const char *name, const char *skip)
{
	char path[4200];
	snprintf(path, sizeof(path), "%s/%s", dir, name);
	int fd = open(path, O_RDONLY | O_CLOEXEC | O_NONBLOCK);
	struct stat st;
	if (fd < 0 || !skip || fstat(fd, &st) || st.st_size <= 0)
		return fd;
	size_t size = (size_t)st.st_size, sl = strlen(skip);
	char *m = mmap(NULL, size, PROT_READ, MAP_PRIVATE, fd, 0);
	if (m == MAP_FAILED)
		return fd;
	off_t at = 0;
	for (const char *p = m; (p = memmem(p, size - (size_t)(p - m), skip, sl)); p++)
		if ((p == m || p[-1] == '\n') && (size_t)(p - m) + sl < size && p[sl] == '\n')
			at = (off_t)(p - m) + (off_t)sl + 1;
	munmap(m, size);
	lseek(fd, at, SEEK_SET);
	return fd;
}

static void open_outputs(sched_t *s, child_t *k)
{
	char dir[4096], name[64];
	snprintf(dir, sizeof(dir), "%s/%" PRId64, s->c.jobs_dir, k->id);
	if (k->out < 0) {
		snprintf(name, sizeof(name), "attempt-%d.out", k->attempt);
		k->out = open_output(dir, name, k->skip);
	}
	if (k->err < 0) {
		snprintf(name, sizeof(name), "attempt-%d.err", k->attempt);
		k->err = open_output(dir, name, NULL);
	}
}

/* One turn for a Slurm attempt: tail its files, act on a cancel, and when
 * polled (its state from this turn's squeue, slurm_poll_all()) follow its
 * state; at a final state (exit code from scontrol), decide the outcome
 * (finish()). Returns 1 when the attempt ended. */
static int slurm_turn(sched_t *s, child_t *k, double now, const slurm_job_t *polled)
{
	const cfg_t *c = s->c.cfg;
	char err[512];
	open_outputs(s, k);
	if (k->out >= 0)
		read_fd(s, k, &k->out, 1, READ_BYTES, now);
	if (k->err >= 0)
		read_fd(s, k, &k->err, 0, READ_BYTES, now);
	/* Cancel, output limit: scancel (Slurm sends SIGTERM, the engine
	 * checkpoints; SIGKILL after the cluster's KillWait). */
	if (k->term_at > 0 && now >= k->term_at) {
		k->term_at = 0;
		if (slurm_cancel(c, k->sjob, NULL, err, sizeof(err))) {
			log_error("job %" PRId64 ": %s", k->id, err);
			k->term_at = now + 5.0;   /* try again */
		}
		k->spoll_at = now + 0.2;
	}
	if (!polled)
		return 0;
	slurm_job_t sj = *polled;
	/* An end: its exit code (and a job squeue no longer lists) from scontrol. */
	if (slurm_state_final(sj.state)) {
		int r = slurm_query(c, k->sjob, &sj, err, sizeof(err));
		if (r == SLURM_EFAIL) {
			if (strcmp(err, k->swarned)) {
				log_warning("job %" PRId64 ": Slurm job %" PRId64 ": %s", k->id, k->sjob, err);
				snprintf(k->swarned, sizeof(k->swarned), "%s", err);
			}
			return 0;
		}
	}
	char text[160];
	snprintf(text, sizeof(text), "%s%s%s%s", slurm_state_name(sj.state), *sj.reason ? " (" : "", sj.reason,
	         *sj.reason ? ")" : "");
	if (strcmp(text, k->sstate_text)) {
		snprintf(k->sstate_text, sizeof(k->sstate_text), "%s", text);
		if (jobq_attempt_slurm_state(s->c.q, k->id, k->attempt, text, util_now()) != JOBQ_OK)
			log_warning("job %" PRId64 ": could not record its Slurm state", k->id);
		log_info("job %" PRId64 " attempt %d: Slurm job %" PRId64 " %s", k->id, k->attempt, k->sjob, text);
		sched_publish_state(s->c.q, s->c.hub, k->id);
	}
	if (!slurm_state_final(sj.state))
		return 0;
	/* The end: what is left in the files (written before Slurm saw the end), then the outcome. */
	open_outputs(s, k);
	if (k->out >= 0)
		read_fd(s, k, &k->out, 1, FINAL_READ_BYTES, now);
	if (k->err >= 0)
		read_fd(s, k, &k->err, 0, FINAL_READ_BYTES, now);
	if (k->ing)
		ingest_finish(k->ing, now);
	flush_progress(s, k, now);
	/* The batch script exec's srun: its ExitCode is srun's, i.e. the ranks'. */
	k->status = sj.exit_signal ? (sj.exit_signal & 0x7f) : ((sj.exit_code & 0xff) << 8);
	switch (sj.state) {
	case SLURM_CANCELLED:
		if (!k->cancel && !k->over_output) {
			k->sretry = 1;
			snprintf(k->swhy, sizeof(k->swhy), "Slurm job %" PRId64 " cancelled outside granulard", k->sjob);
		}
		break;
	case SLURM_TIMEOUT:
		if (k->wall_own)   /* the limit was granulard's own max_wall_seconds: fails as with mpirun */
			k->walllimit = 1;
		else {
			k->sretry = 1;
			snprintf(k->swhy, sizeof(k->swhy), "Slurm job %" PRId64 " reached its time limit", k->sjob);
		}
		break;
	case SLURM_NODE_FAIL:
		k->sretry = 1;
		snprintf(k->swhy, sizeof(k->swhy), "Slurm job %" PRId64 " ended by a node failure", k->sjob);
		break;
	case SLURM_PREEMPTED:
		k->sretry = 1;
		snprintf(k->swhy, sizeof(k->swhy), "Slurm job %" PRId64 " preempted", k->sjob);
		break;
	case SLURM_GONE:
		/* Slurm forgot the job (it ended longer than MinJobAge ago, while
		 * granulard was down): its output says how the engine ended. */
		if (k->summary_seen && strcmp(k->status_word, "interrupted"))
			k->status = 0;
		else {
			k->sretry = 1;
			snprintf(k->swhy, sizeof(k->swhy),
			         "Slurm job %" PRId64 " is unknown to Slurm and its output has no summary", k->sjob);
		}
		break;
	default:
		break;
	}
	finish(s, k);
	return 1;
}

/* A turn for every Slurm attempt; those due a look (slurm_poll) get their
 * state from one squeue for all of them. 1 when one ended. */
static int slurm_poll_all(sched_t *s, double now)
{
	const cfg_t *c = s->c.cfg;
	size_t n = 0, j = 0;
	int ended = 0, polled = 0;
	char err[512];
	for (size_t i = 0; i < s->nkids; i++)
		if (s->kids[i].sjob && now >= s->kids[i].spoll_at)
			n++;
	int64_t *ids = n ? malloc(n * sizeof(*ids)) : NULL;
	slurm_job_t *res = n ? malloc(n * sizeof(*res)) : NULL;
	if (n && ids && res) {
		for (size_t i = 0; i < s->nkids; i++)
			if (s->kids[i].sjob && now >= s->kids[i].spoll_at)
				ids[j++] = s->kids[i].sjob;
		if (slurm_states(c, ids, n, res, err, sizeof(err)) == SLURM_OK) {
			polled = 1;
			s->swarned[0] = '\0';
		} else if (strcmp(err, s->swarned)) {
			log_warning("following Slurm jobs: %s", err);
			snprintf(s->swarned, sizeof(s->swarned), "%s", err);
		}
	}
	j = 0;
	for (size_t i = 0; i < s->nkids; i++) {
		child_t *k = &s->kids[i];
		if (!k->sjob)
			continue;
		const slurm_job_t *p = NULL;
		if (n && ids && res && now >= k->spoll_at) {
			p = polled ? &res[j] : NULL;
			j++;
			k->spoll_at = now + c->slurm_poll;
		}
		ended |= slurm_turn(s, k, now, p);
	}
	free(ids);
	free(res);
	return ended;
}

/* sched_recover(): follow a Slurm job of the previous daemon again. */
static int adopt(sched_t *s, const jobq_running_t *r, int64_t job)
{
	const cfg_t *c = s->c.cfg;
	child_t *k = NULL;
	for (size_t i = 0; i < MAX_CHILDREN && !k; i++)
		if (!busy(&s->kids[i]) && !s->kids[i].id)
			k = &s->kids[i];
	if (!k)
		return -1;
	memset(k, 0, sizeof(*k));
	k->id = r->id;
	k->attempt = r->attempt;
	k->ranks = r->ranks;
	k->until = r->until;
	k->until_cpp = r->until_cpp;
	k->resumed = r->resumed;
	k->ckpt_noted = 1;   /* its first stderr lines were read by the previous daemon */
	k->sjob = job;
	k->out = k->err = -1;
	k->started = mono();
	/* Whether a job option made the limit shorter is not known here: judged by the config. */
	k->wall_own = c->max_wall_seconds > 0 && (c->slurm_time_limit == 0 || c->max_wall_seconds <= c->slurm_time_limit);
	if (jobq_last_record(s->c.q, r->id, r->attempt, &k->skip) != JOBQ_OK)
		k->skip = NULL;
	if (jobq_cancel_requested(s->c.q, r->id) == 1) {
		k->cancel = 1;
		k->term_at = k->started;
	}
	follow(s, k, k->started);
	if (s->nkids < (size_t)(k - s->kids) + 1)
		s->nkids = (size_t)(k - s->kids) + 1;
	return 0;
}

static void *loop(void *arg)
{
	sched_t *s = arg;
	struct pollfd *pf = calloc(2 * MAX_CHILDREN + 1, sizeof(*pf));
	size_t *who = calloc(2 * MAX_CHILDREN + 1, sizeof(*who));   /* pf[i] is kid who[i] */
	int claim = 1;   /* look at the queue this turn */
	if (!pf || !who) {
		free(pf);
		free(who);
		return NULL;
	}
	for (;;) {
		double now = mono();
		int stopping;
		pthread_mutex_lock(&s->lock);
		stopping = s->stopping;
		int64_t *cancels = s->cancels;
		size_t nc = s->ncancels;
		s->cancels = NULL;
		s->ncancels = s->capcancels = 0;
		pthread_mutex_unlock(&s->lock);

		/* Requests: cancellations, stop. */
		for (size_t c = 0; c < nc; c++)
			for (size_t i = 0; i < s->nkids; i++)
				if (s->kids[i].id == cancels[c] && busy(&s->kids[i]) && !s->kids[i].cancel) {
					s->kids[i].cancel = 1;
					s->kids[i].term_at = now;
				}
		free(cancels);
		if (stopping == 1) {
			for (size_t i = 0; i < s->nkids; i++)
				if (s->kids[i].pid)
					s->kids[i].term_at = now;
			pthread_mutex_lock(&s->lock);
			s->stopping = 2;
			pthread_mutex_unlock(&s->lock);
		}
		/* Output limits (quota.h): a job whose directory outgrew its limit is stopped and fails. */
		for (size_t i = 0; i < s->nkids; i++)
			if (busy(&s->kids[i]) && !s->kids[i].over_output && !s->kids[i].cancel &&
			    quota_exceeded(s->quota, s->kids[i].id, now, s->kids[i].over_msg, sizeof(s->kids[i].over_msg)))
				s->kids[i].over_output = 1, s->kids[i].term_at = now;
		/* Deadlines: SIGTERM (the engine checkpoints), then SIGKILL. */
		for (size_t i = 0; i < s->nkids; i++) {
			child_t *k = &s->kids[i];
			if (!k->pid)
				continue;
			refresh_desc(k, now, 0);
			if (k->term_at > 0 && now >= k->term_at) {
				if (!k->cancel && !k->over_output && stopping == 0)
					k->walllimit = 1;
				signal_child(k, SIGTERM, now);
				k->term_at = 0;
				k->kill_at = now + (stopping ? s->stop_deadline - now : s->c.cfg->cancel_grace);
			}
			if (k->kill_at > 0 && now >= k->kill_at) {
				signal_child(k, SIGKILL, now);
				k->kill_at = 0;
			}
		}
		/* Reap and finish. */
		for (size_t i = 0; i < s->nkids; i++) {
			child_t *k = &s->kids[i];
			if (!k->pid)
				continue;
			if (!k->reaped && waitpid(k->pid, &k->status, WNOHANG) == k->pid)
				k->reaped = 1;
			if (k->reaped) {
				/* Ranks that outlive mpirun would hold the pipes open: take what is there and stop. */
				signal_child(k, SIGKILL, now);
				if (k->out >= 0)
					read_fd(s, k, &k->out, 1, FINAL_READ_BYTES, now);
				if (k->err >= 0)
					read_fd(s, k, &k->err, 0, FINAL_READ_BYTES, now);
				if (k->out >= 0)
					close(k->out);
				if (k->err >= 0)
					close(k->err);
				/* The run's last records (its held progress record, the summary) are stored before its end. */
				if (k->ing)
					ingest_finish(k->ing, now);
				flush_progress(s, k, now);
				finish(s, k);
				claim = 1;   /* slots were freed */
			}
		}
		/* Slurm jobs: tail their files, follow their state, cancel. Not
		 * while stopping: an end seen then is the next daemon's to record. */
		if (s->slurm && !stopping && slurm_poll_all(s, now))
			claim = 1;
		/* Launch what fits. */
		int used = 0, running = 0, local = 0;
		double rate = 0;
		for (size_t i = 0; i < s->nkids; i++)
			if (busy(&s->kids[i])) {
				used += s->kids[i].ranks;
				running++;
				local += s->kids[i].pid != 0;
				rate += s->kids[i].rate;
			}
		/* Disk-full protection: restore the ballast when there is room again;
		 * start nothing while it is spent (a new job could not even write). */
		static const double reserve_period = 5.0;
		if (now - s->reserve_at > reserve_period) {
			s->reserve_at = now;
			char rp[4200];
			snprintf(rp, sizeof(rp), "%s/../reserve", s->c.jobs_dir);
			if (s->c.cfg->disk_reserve > 0 && jobq_reserve(s->c.q, rp, (uint64_t)s->c.cfg->disk_reserve) != 0 &&
			    !s->warned_full) {
				log_error("disk full: %s has less than %ld bytes free; new jobs wait", s->c.jobs_dir,
				          2 * s->c.cfg->disk_reserve);
				s->warned_full = 1;
			} else if (!jobq_low_space(s->c.q)) {
				s->warned_full = 0;
			}
		}
		if (now - s->claim_at >= CLAIM_PERIOD)
			claim = 1;
		if (claim && !stopping && !jobq_low_space(s->c.q)) {
			claim = 0;
			s->claim_at = now;
			for (;;) {
				jobq_claim_t cl;
				char err[256];
				int r = jobq_claim(s->c.q, (int)s->c.cfg->slots - used, util_now(), &cl, err, sizeof(err));
				if (r != JOBQ_OK) {
					if (r != JOBQ_EEMPTY)
						log_error("claiming a job: %s", err);
					break;
				}
				sched_publish_state(s->c.q, s->c.hub, cl.id);
				if (launch(s, &cl) == 0) {
					used += cl.ranks;
					running++;
					local += !s->slurm;
				}
				free(cl.scene);
				free(cl.slurm);
			}
		}
		pthread_mutex_lock(&s->lock);
		s->stats.used = used;
		s->stats.running = running;
		s->stats.events_per_second = rate;
		pthread_mutex_unlock(&s->lock);
		/* Slurm jobs run on without the daemon: the next one adopts them (sched_recover()). */
		if (stopping && local == 0)
			break;

		/* Progress: held records whose token came, batches whose interval is up. */
		double wait = 0.2;
		for (size_t i = 0; i < s->nkids; i++) {
			child_t *k = &s->kids[i];
			if (!busy(k) || !k->ing)
				continue;
			ingest_tick(k->ing, now);
			if (ingest_due(k->ing, now))
				flush_progress(s, k, now);
			double w = ingest_wait(k->ing, now);
			if (w < wait)
				wait = w;
		}

		/* Wait for output, a wake-up, the next batch or the next tick. */
		size_t np = 0;
		pf[np++] = (struct pollfd){.fd = s->wake[0], .events = POLLIN};
		for (size_t i = 0; i < s->nkids; i++) {
			child_t *k = &s->kids[i];
			if (!k->pid)
				continue;
			if (k->out >= 0) {
				who[np] = i;
				pf[np++] = (struct pollfd){.fd = k->out, .events = POLLIN};
			}
			if (k->err >= 0) {
				who[np] = i;
				pf[np++] = (struct pollfd){.fd = k->err, .events = POLLIN};
			}
		}
		poll(pf, np, (int)(wait * 1000.0) + 1);
		char buf[256];
		while (read(s->wake[0], buf, sizeof(buf)) > 0)
			claim = 1;
		/* One read per readable pipe: bounded work before the next turn. */
		now = mono();
		for (size_t i = 1; i < np; i++) {
			if (!(pf[i].revents & (POLLIN | POLLHUP | POLLERR)))
				continue;
			child_t *k = &s->kids[who[i]];
			if (k->out == pf[i].fd)
				read_fd(s, k, &k->out, 1, READ_BYTES, now);
			else if (k->err == pf[i].fd)
				read_fd(s, k, &k->err, 0, READ_BYTES, now);
		}
	}
	/* Slurm jobs left running: store what was read, let go of the files. */
	for (size_t i = 0; i < s->nkids; i++) {
		child_t *k = &s->kids[i];
		if (!k->sjob)
			continue;
		flush_progress(s, k, mono());
		kid_clear(k);
	}
	free(pf);
	free(who);
	return NULL;
}

int sched_start(sched_t *s)
{
	if (pthread_create(&s->thread, NULL, loop, s))
		return -1;
	s->started = 1;
	return 0;
}

void sched_stop(sched_t *s, double grace)
{
	if (!s || !s->started)
		return;
	pthread_mutex_lock(&s->lock);
	s->stopping = 1;
	s->stop_deadline = mono() + grace;
	pthread_mutex_unlock(&s->lock);
	sched_wake(s);
	pthread_join(s->thread, NULL);
	s->started = 0;
}

/* ---- start-up reconciliation --------------------------------------------- */

int sched_recover(sched_t *s, char *log, size_t loglen)
{
	jobq_running_t *r = NULL;
	size_t n = 0, o = 0;
	jobq_list_running(s->c.q, &r, &n);
	log[0] = '\0';
	for (size_t i = 0; i < n; i++) {
		const char *what = "its process was gone";
		char err[512];
		if (s->slurm && r[i].pid == 0) {
			/* A Slurm attempt: follow it again. One whose id was not recorded
			 * (the daemon died right after sbatch) is found by its name. */
			int64_t job = r[i].slurm_job;
			if (!job) {
				char name[96];
				snprintf(name, sizeof(name), "%s-%" PRId64 "-%d", s->tag, r[i].id, r[i].attempt);
				if (slurm_find(s->c.cfg, name, &job, err, sizeof(err))) {
					/* Cannot tell whether it runs: leave it as running rather than risk two copies. */
					o += (size_t)snprintf(log + o, o < loglen ? loglen - o : 0,
					                      "job %" PRId64 ": %s; left as running. ", r[i].id, err);
					continue;
				}
				if (job)
					jobq_attempt_slurm(s->c.q, r[i].id, r[i].attempt, job, NULL);
			}
			if (job && adopt(s, &r[i], job) == 0) {
				o += (size_t)snprintf(log + o, o < loglen ? loglen - o : 0,
				                      "job %" PRId64 ": following Slurm job %" PRId64 " again. ", r[i].id, job);
				continue;
			}
			what = "it was never submitted to Slurm";
		} else if (r[i].slurm_job > 0) {
			/* Submitted by a daemon with launcher = slurm, and this one runs
			 * jobs with mpirun: cancel the Slurm job before the job runs here. */
			what = "its Slurm job was cancelled: launcher is now mpirun";
			if (slurm_cancel(s->c.cfg, r[i].slurm_job, NULL, err, sizeof(err)))
				log_warning("job %" PRId64 ": %s", r[i].id, err);
		}
		if (r[i].pid > 0 && util_pid_alive(r[i].pid, r[i].pid_start)) {
			/* Still running from the previous daemon, but nobody reads its
			 * output any more: stop it (it checkpoints on SIGTERM) before the
			 * job may run again. */
			what = "its process was stopped";
			pid_t dp[16];
			uint64_t ds[16];
			int nd = util_descendants(r[i].pid, dp, ds, 16);
			for (int round = 0; round < 2; round++) {
				/* SIGTERM first (the engine checkpoints), SIGKILL after the grace. */
				int sig = round ? SIGKILL : SIGTERM;
				kill(-r[i].pid, sig);
				for (int d = 0; d < nd; d++)
					if (util_pid_alive(dp[d], ds[d]))
						kill(dp[d], sig);
				double dl = mono() + (round ? 10.0 : s->c.cfg->cancel_grace);
				int any = 1;
				while (any && mono() < dl) {
					any = util_pid_alive(r[i].pid, r[i].pid_start);
					for (int d = 0; d < nd; d++)
						any |= util_pid_alive(dp[d], ds[d]);
					if (any)
						usleep(20000);
				}
				if (!any)
					break;
			}
			int left = util_pid_alive(r[i].pid, r[i].pid_start);
			for (int d = 0; d < nd; d++)
				left |= util_pid_alive(dp[d], ds[d]);
			if (left) {
				/* Cannot prove it is gone: leave the job running in the
				 * database rather than risk two copies. */
				o += (size_t)snprintf(log + o, o < loglen ? loglen - o : 0,
				                      "job %" PRId64 ": process %d survives SIGKILL; left as running. ", r[i].id,
				                      r[i].pid);
				continue;
			}
		}
		char reason[256];
		snprintf(reason, sizeof(reason), "daemon restarted while the job ran (%s); requeued", what);
		job_state_t next = jobq_cancel_requested(s->c.q, r[i].id) == 1 ? JOB_CANCELLED : JOB_QUEUED;
		jobq_attempt_finished(s->c.q, r[i].id, r[i].attempt, util_now(), -1, 0, reason, NULL, next);
		o += (size_t)snprintf(log + o, o < loglen ? loglen - o : 0, "job %" PRId64 ": %s. ", r[i].id,
		                      next == JOB_QUEUED ? reason : "cancelled while the daemon was down");
	}
	free(r);
	return (int)n;
}
