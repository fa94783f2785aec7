/* granulard: the simulation job daemon (configuration, start-up, signals); the work lives in the daemon library. */
#define _GNU_SOURCE
#include <errno.h>
#include <fcntl.h>
#include <inttypes.h>
#include <libgen.h>
#include <limits.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>
#include "api.h"
#include "cfg.h"
#include "http.h"
#include "log.h"
#include "notify.h"
#include "util.h"

#ifndef GRANULARD_BINDIR
#define GRANULARD_BINDIR "/usr/local/bin"
#endif

static void usage(FILE *f)
{
	fprintf(f, "usage: granulard [--listen HOST:PORT] [--state-dir DIR] [--slots N] [--config FILE] [--KEY VALUE]...\n"
	           "Serves the granulard REST API (man granulard, docs/daemon.md). Every flag --some-key is also a\n"
	           "config-file line `some_key = value`; flags override the file:\n");
	cfg_print_keys(f, CFG_FMT_TEXT);
}

static int executable(const char *p) { return access(p, X_OK) == 0; }

/* granular-engine: configured, next to us (installed or in the build tree), the install dir, PATH. */
static int find_engine(const cfg_t *c, char *out, size_t n)
{
	char self[PATH_MAX], dir[PATH_MAX];
	if (*c->engine) {
		snprintf(out, n, "%s", c->engine);
		return executable(out) ? 0 : -1;
	}
	ssize_t l = readlink("/proc/self/exe", self, sizeof(self) - 1);
	if (l > 0) {
		self[l] = '\0';
		snprintf(dir, sizeof(dir), "%s", dirname(self));
		snprintf(out, n, "%s/granular-engine", dir);
		if (executable(out))
			return 0;
		snprintf(out, n, "%s/../engine/granular-engine", dir);
		if (executable(out))
			return 0;
	}
	snprintf(out, n, "%s/granular-engine", GRANULARD_BINDIR);
	if (executable(out))
		return 0;
	const char *path = getenv("PATH");
	char buf[8192];
	snprintf(buf, sizeof(buf), "%s", path ? path : "/usr/bin:/bin");
	for (char *sp = NULL, *d = strtok_r(buf, ":", &sp); d; d = strtok_r(NULL, ":", &sp)) {
		snprintf(out, n, "%s/granular-engine", d);
		if (executable(out))
			return 0;
	}
	snprintf(out, n, "granular-engine");
	return -1;
}

/* The configured token, else STATE/token, created (0600) on first start. */
static int load_token(const cfg_t *c, char *tok, size_t n, char *err, size_t errlen)
{
	char path[PATH_MAX];
	if (*c->token) {
		snprintf(tok, n, "%s", c->token);
		return 0;
	}
	snprintf(path, sizeof(path), "%s/token", c->state_dir);
	FILE *f = fopen(path, "re");
	if (f) {
		if (!fgets(tok, (int)n, f))
			tok[0] = '\0';
		fclose(f);
		tok[strcspn(tok, "\r\n")] = '\0';
		if (strlen(tok) < 16) {
			snprintf(err, errlen, "%s: token shorter than 16 characters", path);
			return -1;
		}
		return 0;
	}
	if (util_random_hex(tok, 24)) {
		snprintf(err, errlen, "cannot generate a token: %s", strerror(errno));
		return -1;
	}
	int fd = open(path, O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0600);
	if (fd < 0 || write(fd, tok, strlen(tok)) < 0 || write(fd, "\n", 1) < 0 || fsync(fd) || close(fd)) {
		snprintf(err, errlen, "%s: %s", path, strerror(errno));
		return -1;
	}
	log_info("generated the API token in %s", path);
	return 0;
}

int main(int argc, char **argv)
{
	cfg_t cfg;
	gd_t gd = {0};
	http_t *http = NULL;
	char err[1024], path[PATH_MAX], jobs[PATH_MAX], engine[PATH_MAX], token[256], addr[320];
	int port = 0, ret = 1, lockfd = -1, locked = 0, lvl;
	sigset_t sigs;

	if (cfg_init(&cfg)) {
		fprintf(stderr, "granulard: cannot initialise configuration\n");
		return 1;
	}
	if (argc == 2 && !strcmp(argv[1], "--list-routes")) {
		/* The route table, for the test that keeps schema/openapi.yaml complete. */
		for (size_t i = 0; i < api_nroutes; i++)
			printf("%s %s\n", api_routes[i].method, api_routes[i].pattern);
		cfg_deinit(&cfg);
		return 0;
	}
	if (argc == 3 && !strcmp(argv[1], "--list-keys")) {
		/* The key table as text, man or markdown: the man page is generated from it, docs/daemon.md checked. */
		int fmt = cfg_format_parse(argv[2]);
		cfg_deinit(&cfg);
		if (fmt < 0) {
			fprintf(stderr, "granulard: --list-keys %s: expected text, man or markdown\n", argv[2]);
			return 2;
		}
		return cfg_print_keys(stdout, (cfg_format_t)fmt) || fflush(stdout) ? 1 : 0;
	}
	int r = cfg_from_args(&cfg, argc, argv, err, sizeof(err));
	if (r == CFG_EHELP) {
		usage(stdout);
		cfg_deinit(&cfg);
		return 0;
	}
	if (r) {
		fprintf(stderr, "granulard: %s\n", err);
		cfg_deinit(&cfg);
		return 2;
	}
	lvl = log_parse_level(cfg.log_level);
	log_set_level(lvl < 0 ? LOG_INFO : (log_level_t)lvl);
	if (cfg.max_ranks == 0 || cfg.max_ranks > cfg.slots)
		cfg.max_ranks = cfg.slots;   /* a job larger than the slots could never start */

	/* Signals are taken by sigwait() below: block them before any thread exists. */
	sigemptyset(&sigs);
	sigaddset(&sigs, SIGTERM);
	sigaddset(&sigs, SIGINT);
	sigaddset(&sigs, SIGHUP);
	pthread_sigmask(SIG_BLOCK, &sigs, NULL);
	signal(SIGPIPE, SIG_IGN);
	if (geteuid() == 0) {
		/* Open MPI refuses root unless told; under systemd we run as a dynamic user instead. */
		setenv("OMPI_ALLOW_RUN_AS_ROOT", "1", 0);
		setenv("OMPI_ALLOW_RUN_AS_ROOT_CONFIRM", "1", 0);
	}

	snprintf(jobs, sizeof(jobs), "%s/jobs", cfg.state_dir);
	if (util_mkdirs(jobs, 0750)) {
		fprintf(stderr, "granulard: state_dir %s: %s\n", cfg.state_dir, strerror(errno));
		goto cleanup;
	}
	/* Jobs run in their own directories: every path handed to them must be absolute. */
	char *abs = realpath(cfg.state_dir, NULL);
	if (!abs) {
		fprintf(stderr, "granulard: state_dir %s: %s\n", cfg.state_dir, strerror(errno));
		goto cleanup;
	}
	free(cfg.state_dir);
	cfg.state_dir = abs;
	snprintf(jobs, sizeof(jobs), "%s/jobs", cfg.state_dir);
	/* One daemon per state directory: two would both claim the same jobs. */
	snprintf(path, sizeof(path), "%s/granulard.lock", cfg.state_dir);
	lockfd = open(path, O_RDWR | O_CREAT | O_CLOEXEC, 0600);
	if (lockfd < 0 || flock(lockfd, LOCK_EX | LOCK_NB)) {
		fprintf(stderr, "granulard: state_dir %s: %s\n", cfg.state_dir,
		        errno == EWOULDBLOCK ? "another granulard is using it" : strerror(errno));
		goto cleanup;
	}
	/* The lock file names its holder, so `./quickstart stop` signals exactly this daemon (after checking
	 * that the file is still locked and that the pid is a granulard that has it open). */
	locked = 1;
	if (ftruncate(lockfd, 0) || dprintf(lockfd, "%ld\n", (long)getpid()) < 0)
		log_warning("%s: cannot write our pid: %s", path, strerror(errno));
	if (load_token(&cfg, token, sizeof(token), err, sizeof(err))) {
		fprintf(stderr, "granulard: %s\n", err);
		goto cleanup;
	}
	if (find_engine(&cfg, engine, sizeof(engine)))
		log_warning("granular-engine not found (tried the engine key, next to granulard, %s, PATH); "
		            "jobs will fail until it is installed", GRANULARD_BINDIR);

	jobq_limits_t lim = {.max_particles = (uint64_t)cfg.max_particles, .max_ranks = (int)cfg.max_ranks,
	                     .max_queued = (int)cfg.max_queued, .max_json_depth = (int)cfg.max_json_depth,
	                     .max_progress = (int)cfg.max_progress_records};
	snprintf(path, sizeof(path), "%s/granulard.db", cfg.state_dir);
	gd.cfg = &cfg;
	gd.q = jobq_open(path, &lim, err, sizeof(err));
	if (!gd.q) {
		fprintf(stderr, "granulard: %s\n", err);
		goto cleanup;
	}
	gd.hub = hub_create(8192);
	gd.token = token;
	gd.jobs_dir = jobs;
	gd.started = util_now();
	sched_conf_t sc = {.q = gd.q, .hub = gd.hub, .cfg = &cfg, .engine = engine, .jobs_dir = jobs};
	gd.sched = sched_create(&sc);
	if (!gd.hub || !gd.sched) {
		fprintf(stderr, "granulard: out of memory\n");
		goto cleanup;
	}
	char rec[4096];
	if (sched_recover(gd.sched, rec, sizeof(rec)) > 0)
		log_warning("recovered jobs of the previous run: %s", rec);
	http = http_start(&gd, &port, err, sizeof(err));
	if (!http) {
		fprintf(stderr, "granulard: %s\n", err);
		goto cleanup;
	}
	/* Where we listen, for clients and tests that asked for port 0. */
	char host[256];
	snprintf(host, sizeof(host), "%s", cfg.listen);
	*strrchr(host, ':') = '\0';
	snprintf(addr, sizeof(addr), "%s:%d\n", host, port);
	snprintf(path, sizeof(path), "%s/granulard.addr", cfg.state_dir);
	if (util_write_atomic(path, addr, strlen(addr), err, sizeof(err)))
		log_warning("%s", err);
	if (sched_start(gd.sched)) {
		fprintf(stderr, "granulard: cannot start the supervisor thread\n");
		goto cleanup;
	}
	addr[strcspn(addr, "\n")] = '\0';
	log_info("serving http://%s/ (state %s, %ld slots, engine %s)", addr, cfg.state_dir, cfg.slots, engine);
	char st[512];
	snprintf(st, sizeof(st), "READY=1\nSTATUS=serving http://%s/ with %ld slots", addr, cfg.slots);
	notify_send(st);

	for (;;) {
		int sig = 0;
		if (sigwait(&sigs, &sig) == 0 && sig != SIGHUP)
			break;
	}
	log_info("stopping: running jobs get %.0f s to checkpoint", cfg.shutdown_grace);
	notify_send("STOPPING=1");
	atomic_store(&gd.stopping, 1);
	ret = 0;
cleanup:
	/* Jobs first (they checkpoint and are requeued) while the API still
	 * answers reads and refuses changes with 503; then the streams, then HTTP. */
	sched_stop(gd.sched, cfg.shutdown_grace);
	if (gd.hub)
		hub_close(gd.hub);
	http_stop(http);
	sched_destroy(gd.sched);
	hub_destroy(gd.hub);
	jobq_close(gd.q);
	if (locked && ftruncate(lockfd, 0))   /* no pid left for a stopped daemon */
		log_warning("granulard.lock: %s", strerror(errno));
	if (lockfd >= 0)
		close(lockfd);
	cfg_deinit(&cfg);
	return ret;
}
