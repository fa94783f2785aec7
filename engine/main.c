/* granular-engine: command-line front end (MPI program; the serial method runs on rank 0). */
#include <errno.h>
#include <mpi.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>

#include "advice.h"
#include "io/checkpoint.h"
#include "config.h"
#include "par/dsmcrun.h"
#include "par/edrun.h"
#include "par/ensemble.h"
#include "io/frame.h"
#include "io/h5md.h"
#include "io/report.h"
#include "run.h"
#include "scene.h"

/* Exit codes (documented in docs/engine.md and docs/output.md). */
enum { EX_DONE = 0, EX_FAIL = 1, EX_INPUT = 2, EX_INTERRUPTED = 3, EX_CHECKPOINTED = 4 };

static volatile sig_atomic_t stop_requested;

/* Announcement mode of one ed system split over the ranks (engine/par/edrun.h; the others: announce()). */
enum { ED_SPLIT = 1 << 10 };

static void on_signal(int sig)
{
	(void)sig;
	stop_requested = 1;
}

typedef struct {
	FILE *progress;     /* progress stream (stdout or --progress-fd) */
	FILE *copy;         /* DIR/progress.jsonl with --out, or NULL */
	h5md_t *traj;       /* DIR/trajectory.h5 with --out, or NULL */
	FILE *curves;       /* DIR/observables.jsonl with --out and curve observables, or NULL */
	uint64_t curve_samples;   /* samples written to it (the next "sample" index) */
	char err[512];      /* why an output failed */
	const char *outdir, *text;   /* split runs' checkpoints (split_checkpoint()): --out DIR, the scene text */
	size_t len;
} sink_t;

/* One curve sample as JSON lines into DIR/observables.jsonl. */
static int emit_curves(sink_t *sk, const run_record_t *rec)
{
	if (!sk->curves)
		return 0;
	size_t cap = report_curves_max(rec->curves);
	char *buf = malloc(cap);
	int n = buf ? report_curves(rec, sk->curve_samples, buf, cap) : -1;
	int ret = -1;
	if (n < 0) {
		snprintf(sk->err, sizeof(sk->err), "observables.jsonl: cannot format a sample (out of memory)");
	} else if (fwrite(buf, 1, (size_t)n, sk->curves) != (size_t)n || fflush(sk->curves) != 0) {
		snprintf(sk->err, sizeof(sk->err), "observables.jsonl: %s", strerror(errno));
	} else {
		sk->curve_samples++;
		ret = 0;
	}
	free(buf);
	return ret;
}

static int emit(const run_record_t *rec, void *ctx)
{
	sink_t *sk = ctx;
	char line[REPORT_MAX];
	if (rec->kind == RUN_SNAPSHOT)
		return sk->traj ? h5md_snapshot(sk->traj, rec, sk->err, sizeof(sk->err)) : 0;
	if (rec->kind == RUN_CURVES)
		return (sk->traj && h5md_fields(sk->traj, rec, sk->err, sizeof(sk->err))) || emit_curves(sk, rec) ? -1 : 0;
	if (rec->kind == RUN_PROGRESS && sk->traj && h5md_observables(sk->traj, rec, sk->err, sizeof(sk->err)))
		return -1;
	if (rec->kind == RUN_SUMMARY && rec->status == RUN_COLLAPSED && sk->traj && rec->warning &&
	    h5md_collapse(sk->traj, rec->time, rec->warning, sk->err, sizeof(sk->err)))
		return -1;
	int n = report_format(rec, line, sizeof(line));
	if (n < 0)
		return -1;
	if (fwrite(line, 1, (size_t)n, sk->progress) != (size_t)n || fflush(sk->progress) != 0)
		return -1;
	if (sk->copy && (fwrite(line, 1, (size_t)n, sk->copy) != (size_t)n || fflush(sk->copy) != 0))
		return -1;
	return 0;
}

/* The time of the last progress record in f (progress.jsonl cut back to a checkpoint; f is left at its
 * end): an ensemble checkpoint is taken right after the record of its output time, whose time (the mean
 * over the replicas) is that of the curves taken then. 0 when there is none. */
static double last_progress_time(FILE *f)
{
	char line[REPORT_MAX + 2];
	double t = 0.0;
	if (fseek(f, 0, SEEK_SET) != 0)
		return 0.0;
	while (fgets(line, sizeof(line), f)) {
		const char *p = strstr(line, "\"time\":");
		if (!strncmp(line, "{\"type\":\"progress\",", 19) && p)
			t = strtod(p + 7, NULL);
	}
	fseek(f, 0, SEEK_END);
	return t;
}

/* DIR/observables.jsonl: new, or (resumed from a checkpoint at time t_ckpt) cut back to the samples taken
 * up to the checkpoint (lines are in time order; a sample at t_ckpt was written before the checkpoint and
 * is not taken again), counting the samples kept. A torn last line goes too. */
static int open_curves(const char *outdir, int resumed, double t_ckpt, sink_t *sk)
{
	char path[4096], line[160];
	snprintf(path, sizeof(path), "%s/observables.jsonl", outdir);
	sk->curves = fopen(path, resumed ? "r+" : "w");
	if (!sk->curves) {
		fprintf(stderr, "granular-engine: %s: %s\n", path, strerror(errno));
		return -1;
	}
	if (!resumed)
		return 0;
	long keep = 0;
	int at_start = 1;
	uint64_t last_sample = UINT64_MAX;
	while (fgets(line, sizeof(line), sk->curves)) {
		size_t l = strlen(line);
		if (at_start) {
			/* each line opens {"name":"...","sample":K,...,"time":T, within its first 160 bytes */
			const char *q = strstr(line, "\"sample\":"), *t = strstr(line, "\"time\":");
			if (!q || !t || strtod(t + 7, NULL) > t_ckpt)
				break;
			uint64_t k = strtoull(q + 9, NULL, 10);
			if (k != last_sample)
				sk->curve_samples++;
			last_sample = k;
		}
		at_start = l > 0 && line[l - 1] == '\n';
		if (at_start)
			keep = ftell(sk->curves);
	}
	if (keep < 0 || fflush(sk->curves) != 0 || ftruncate(fileno(sk->curves), (off_t)keep) != 0 ||
	    fseek(sk->curves, 0, SEEK_END) != 0) {
		fprintf(stderr, "granular-engine: %s: cannot cut back to the checkpoint: %s\n", path, strerror(errno));
		return -1;
	}
	return 0;
}

/* Make the outputs durable and note where they stand (for a checkpoint). */
static int flush_outputs(const char *outdir, sink_t *sk, ckpt_output_t *pos)
{
	long off;
	if (fflush(sk->copy) != 0 || fsync(fileno(sk->copy)) != 0 || (off = ftell(sk->copy)) < 0) {
		snprintf(sk->err, sizeof(sk->err), "%s/progress.jsonl: %s", outdir, strerror(errno));
		return -1;
	}
	pos->progress_bytes = (uint64_t)off;
	if (sk->curves && (fflush(sk->curves) != 0 || fsync(fileno(sk->curves)) != 0)) {
		snprintf(sk->err, sizeof(sk->err), "%s/observables.jsonl: %s", outdir, strerror(errno));
		return -1;
	}
	if (h5md_flush(sk->traj, sk->err, sizeof(sk->err)) != H5MD_OK)
		return -1;
	h5md_rows(sk->traj, &pos->obs_rows, &pos->snap_rows);
	return 0;
}

/* Make the outputs durable, note where they stand, and write the checkpoint. */
static int checkpoint(const char *outdir, run_t *run, sink_t *sk, const char *text, size_t len)
{
	ckpt_output_t pos = {0, 0, 0};
	if (flush_outputs(outdir, sk, &pos))
		return -1;
	return ckpt_write(outdir, run, text, len, &pos, sk->err, sizeof(sk->err)) == CKPT_OK ? 0 : -1;
}

/* A split ed run's checkpoint (engine/par/edrun.h): r holds the state in the serial layout. */
typedef struct {
	const char *outdir;
	sink_t *sink;
	const char *text;
	size_t len;
} ed_save_t;

static int ed_save(run_t *r, void *ctx)
{
	ed_save_t *c = ctx;
	return checkpoint(c->outdir, r, c->sink, c->text, c->len);
}

/* A split run's checkpoint (dsmcrun.h, rank 0): the outputs made durable, then the gathered state. */
static int split_checkpoint(const ckpt_split_t *ck, void *ctx)
{
	sink_t *sk = ctx;
	ckpt_output_t pos = {0, 0, 0};
	if (flush_outputs(sk->outdir, sk, &pos))
		return -1;
	return ckpt_write_split(sk->outdir, ck, sk->text, sk->len, &pos, sk->err, sizeof(sk->err)) == CKPT_OK ? 0 : -1;
}

/* Ensemble state from a checkpoint (rank 0): replica state strings and the
 * ensemble's schedule; blobs and lens have run.replicas entries. */
typedef struct {
	unsigned char **blobs;
	size_t *lens;
	ckpt_ensemble_t es;
} ens_resume_t;

static int read_ckpt(const char *path, const scene_t *s, const char *text, size_t len, const run_opts_t *opts,
                     run_t **run, ens_resume_t *ens, ckpt_split_t *sck, ckpt_output_t *pos, char *msg, size_t msglen)
{
	if (sck)   /* a split run's */
		return ckpt_read_split(path, s, text, len, sck, pos, msg, msglen);
	if (s->replicas > 1)
		return ckpt_read_ensemble(path, s, text, len, ens->blobs, ens->lens, &ens->es, pos, msg, msglen);
	return ckpt_read(path, s, text, len, opts, run, pos, msg, msglen);
}

/* Load --resume PATH, falling back to checkpoint.prev.h5 beside it when PATH
 * is damaged (one line on stderr says so). Exit code on failure. */
static int resume(const char *path, const scene_t *s, const char *text, size_t len, const run_opts_t *opts,
                  run_t **run, ens_resume_t *ens, ckpt_split_t *sck, ckpt_output_t *pos)
{
	char msg[512], prev[4096];
	int rc = read_ckpt(path, s, text, len, opts, run, ens, sck, pos, msg, sizeof(msg));
	if (rc == CKPT_OK)
		return EX_DONE;
	if (rc == CKPT_ESCENE || rc == CKPT_ENOMEM || rc == CKPT_EIO) {
		fprintf(stderr, "granular-engine: --resume %s\n", msg);
		return rc == CKPT_ENOMEM ? EX_FAIL : EX_INPUT;
	}
	/* Any checkpoint that does not verify (unreadable, truncated, digest,
	 * a damaged stored scene: CKPT_ECORRUPT; missing) falls back. The line
	 * "...; using PREV" is printed only when PREV did load: the daemon reads
	 * it to record the checkpoint really used (scheduler.c). */
	const char *slash = strrchr(path, '/');
	char first[512];
	snprintf(first, sizeof(first), "%s", msg);
	snprintf(prev, sizeof(prev), "%.*s%s", slash ? (int)(slash - path + 1) : 0, path, CKPT_PREV);
	rc = read_ckpt(prev, s, text, len, opts, run, ens, sck, pos, msg, sizeof(msg));
	if (rc == CKPT_OK) {
		fprintf(stderr, "granular-engine: --resume %s; using %s\n", first, prev);
		return EX_DONE;
	}
	fprintf(stderr, "granular-engine: --resume %s; tried %s\n", first, prev);
	fprintf(stderr, "granular-engine: --resume %s\n", msg);
	return rc == CKPT_ENOMEM ? EX_FAIL : EX_INPUT;
}

/* Frames per particles group at the checkpoint (h5md_open_append()): a
 * single run's count, or each replica's "@frames", which must add up to the
 * checkpoint's total. *out is malloc'd (caller frees). 0, or -1. */
static int resume_frames(const scene_t *s, const ens_resume_t *ens, const ckpt_output_t *at, uint64_t **out)
{
	int ng = h5md_groups(s);
	uint64_t sum = 0, *f = calloc(ng > 0 ? (size_t)ng : 1, sizeof(uint64_t));
	*out = f;
	if (!f)
		return -1;
	if (s->replicas <= 1) {
		f[0] = at->snap_rows;
		return 0;
	}
	for (int r = 0; r < ng; r++) {
		if (ensemble_blob_u64(ens->blobs[r], ens->lens[r], "@frames", &f[r]) < 0)
			return -1;
		sum += f[r];
	}
	return sum == at->snap_rows ? 0 : -1;
}

static char *read_file(const char *path, size_t *len, char *err, size_t errlen)
{
	FILE *f = fopen(path, "rb");
	char *buf = NULL;
	size_t cap = 0, n = 0;
	if (!f) {
		snprintf(err, errlen, "%s: cannot open: %s", path, strerror(errno));
		return NULL;
	}
	for (;;) {
		if (n + 4096 > cap) {
			size_t ncap = cap ? 2 * cap : 8192;
			char *nb = ncap > (64u << 20) ? NULL : realloc(buf, ncap);
			if (!nb) {
				snprintf(err, errlen, "%s: too large or out of memory", path);
				free(buf);
				fclose(f);
				return NULL;
			}
			buf = nb, cap = ncap;
		}
		size_t k = fread(buf + n, 1, cap - n, f);
		n += k;
		if (k == 0)
			break;
	}
	if (ferror(f)) {
		snprintf(err, errlen, "%s: read error: %s", path, strerror(errno));
		free(buf);
		fclose(f);
		return NULL;
	}
	fclose(f);
	*len = n;
	return buf;
}

/* Method "auto": choose with the built-in model (deterministic, so every
 * rank of an ensemble agrees). line (may be NULL) receives the decision as
 * one malloc'd {"type":"advice",...} JSON line. Exit code. */
static int resolve_auto(scene_t *s, int ranks, char **line)
{
	char err[512];
	size_t len;
	advice_t adv;
	const char *text = advice_model_builtin(&len);
	advice_model_t *m = advice_model_create(text, len, err, sizeof(err));
	if (!m) {
		fprintf(stderr, "granular-engine: built-in advice model: %s\n", err);
		return EX_FAIL;
	}
	int rc = advice_estimate(m, s, ranks, &adv, err, sizeof(err));
	advice_model_destroy(m);
	if (rc != ADVICE_OK) {
		fprintf(stderr, "%s\n", err);
		return EX_INPUT;
	}
	advice_apply(&adv, s);
	if (line) {
		json_t *o = json_pack("{s:s}", "type", "advice"), *a = advice_json(&adv);
		char *t = o && a && !json_object_update(o, a) ? json_dumps(o, JSON_COMPACT | JSON_REAL_PRECISION(6)) : NULL;
		json_decref(o);
		json_decref(a);
		*line = t ? malloc(strlen(t) + 2) : NULL;
		if (*line)
			sprintf(*line, "%s\n", t);
		free(t);
		if (!*line) {
			fprintf(stderr, "granular-engine: out of memory\n");
			return EX_FAIL;
		}
	}
	return EX_DONE;
}

/* granular-engine advise SCENE.json [--ranks P] [--model MODEL.json]: the estimates as JSON on stdout. */
static int advise_main(int argc, char **argv)
{
	const char *scene_path = NULL, *model_path = NULL;
	char err[512], *text = NULL, *mtext = NULL, *out = NULL;
	size_t len = 0, mlen = 0;
	long ranks = 1;
	int ret = EX_INPUT;
	scene_t scene;
	advice_t adv;
	advice_model_t *m = NULL;
	json_t *j = NULL;

	for (int i = 2; i < argc; i++) {
		if (!strcmp(argv[i], "--ranks") && i + 1 < argc) {
			char *end;
			ranks = strtol(argv[++i], &end, 10);
			if (*end || ranks < 1 || ranks > 1 << 20) {
				fprintf(stderr, "granular-engine: --ranks: not a positive integer: %s\n", argv[i]);
				goto cleanup;
			}
		} else if (!strcmp(argv[i], "--model") && i + 1 < argc) {
			model_path = argv[++i];
		} else if (argv[i][0] == '-' || scene_path) {
			fprintf(stderr, "granular-engine: unexpected argument: %s (see --help)\n", argv[i]);
			goto cleanup;
		} else {
			scene_path = argv[i];
		}
	}
	if (!scene_path) {
		fprintf(stderr, "granular-engine: advise: missing SCENE.json (see --help)\n");
		goto cleanup;
	}
	if (!(text = read_file(scene_path, &len, err, sizeof(err))) ||
	    (model_path && !(mtext = read_file(model_path, &mlen, err, sizeof(err))))) {
		fprintf(stderr, "granular-engine: %s\n", err);
		goto cleanup;
	}
	if (scene_parse(text, len, &scene, err, sizeof(err)) != SCENE_OK) {
		fprintf(stderr, "%s\n", err);
		goto cleanup;
	}
	if (!mtext)
		mtext = (char *)advice_model_builtin(&mlen);
	m = advice_model_create(mtext, mlen, err, sizeof(err));
	if (!m) {
		fprintf(stderr, "granular-engine: %s: %s\n", model_path ? model_path : "built-in advice model", err);
		ret = model_path ? EX_INPUT : EX_FAIL;
		goto cleanup;
	}
	if (advice_estimate(m, &scene, (int)ranks, &adv, err, sizeof(err)) != ADVICE_OK) {
		fprintf(stderr, "%s\n", err);
		goto cleanup;
	}
	ret = EX_FAIL;
	if (!(j = advice_json(&adv)) || !(out = json_dumps(j, JSON_INDENT(2) | JSON_REAL_PRECISION(6))) || printf("%s\n", out) < 0 ||
	    fflush(stdout) != 0)
		goto cleanup;
	ret = EX_DONE;
cleanup:
	if (model_path)
		free(mtext);
	free(text);
	free(out);
	json_decref(j);
	advice_model_destroy(m);
	return ret;
}

static void usage(FILE *f)
{
	fprintf(f,
	        "usage: granular-engine run SCENE.json [--out DIR [--resume CHECKPOINT.h5]] [--progress-fd N]\n"
	        "                                      [--jobs-dir DIR] [--split]\n"
	        "       granular-engine validate SCENE.json [--jobs-dir DIR]\n"
	        "       granular-engine advise SCENE.json [--ranks P] [--model MODEL.json]\n"
	        "       granular-engine --version | --help\n"
	        "Runs a granular-gas scene (docs/scene.md) and writes one JSON progress\n"
	        "line per output time and a summary line (docs/engine.md). With --out DIR:\n"
	        "DIR/progress.jsonl, DIR/trajectory.h5 (H5MD), DIR/trajectory.xdmf and\n"
	        "checkpoints DIR/checkpoint.h5 (docs/output.md); --resume continues exactly.\n"
	        "Exit status: 0 done, 1 failure, 2 bad input or usage, 3 interrupted,\n"
	        "4 checkpointed and stopped (SIGTERM/SIGINT with --out).\n"
	        "advise prints the estimated cost and expected error of each method\n"
	        "(docs/engine.md); \"method\": \"auto\" scenes run the method it chooses.\n"
	        "--jobs-dir DIR: where particles.initial.from.job ID finds DIR/ID/trajectory.h5\n"
	        "(the daemon's job directories; docs/scene.md).\n"
	        "--split: an ed, dsmc or hsmc scene with run.replicas 1 runs as one system decomposed over\n"
	        "the ranks even on one rank (the default under mpirun -np P > 1; docs/parallel.md).\n");
}

/* Complete a non-blocking collective without spinning a core (a blocking
 * MPI call busy-polls in Open MPI). */
static void wait_idle(MPI_Request *req)
{
	int flag = 0;
	while (!flag) {
		MPI_Test(req, &flag, MPI_STATUS_IGNORE);
		if (!flag) {
			struct timespec ts = {0, 20 * 1000 * 1000};
			nanosleep(&ts, NULL);
		}
	}
}

/* Ranks other than 0 wait for rank 0 at the final barrier. */
static void idle_until_rank0(void)
{
	MPI_Request req;
	MPI_Ibarrier(MPI_COMM_WORLD, &req);
	wait_idle(&req);
}

/* Rank 0 tells the others, once, whether there is work: {mode, text length};
 * mode != 0 (ensemble: ENS_RUN | ENS_CKPT | ENS_RESUME | ENS_FRAMES) is
 * followed by the scene text, which every rank parses. */
enum { ENS_RUN = 1, ENS_CKPT = 2, ENS_RESUME = 4, ENS_FRAMES = 8, ENS_CURVES = 16, DSMC_SPLIT = 32 };
/* Bytes of packed curves of all replicas an ensemble may reduce (each rank holds them all). */
#define ENS_CURVES_MAX (1024.0 * 1024 * 1024)
typedef struct {
	int sent;
} announce_t;

static void announce(announce_t *an, long long mode, const char *text, size_t len)
{
	long long hdr[2] = {mode, (long long)len};
	MPI_Request req;
	an->sent = 1;
	MPI_Ibcast(hdr, 2, MPI_LONG_LONG, 0, MPI_COMM_WORLD, &req);
	wait_idle(&req);
	if (mode != 0)
		MPI_Bcast((void *)text, (int)len, MPI_CHAR, 0, MPI_COMM_WORLD);
}

/* particles.initial.from: the longest file name load_from() makes */
#define FROM_PATH_MAX (2 * SCENE_PATH_MAX + 64)

/* Ensemble checkpoints and resume (ENS_CKPT, ENS_RESUME). Rank 0 only:
 * outdir, text/len, ens (resume state); every rank: mode. */
typedef struct {
	int mode;
	const char *outdir;
	const char *text;
	size_t len;
	ens_resume_t *ens;
	const char *from_path;   /* from.replica "each": the trajectory (load_from()); rank 0 only */
} ens_opts_t;

/* Load the replicas of this rank from rank 0's resume state: rank 0 sends
 * replica r's state string to its owner r mod size, in replica order. */
static int ens_load(const scene_t *s, int rank, int size, ens_resume_t *ens, run_t **runs, char *err, size_t errlen)
{
	const int R = (int)s->replicas;
	int ret = RUN_OK;
	for (int r = 0; r < R; r++) {
		int owner = r % size;
		unsigned long long n = 0;
		unsigned char *buf = NULL;
		if (rank == 0 && owner != 0) {
			n = ens->lens[r];
			MPI_Send(&n, 1, MPI_UNSIGNED_LONG_LONG, owner, r, MPI_COMM_WORLD);
			MPI_Send(ens->blobs[r], (int)n, MPI_BYTE, owner, r, MPI_COMM_WORLD);
			continue;
		}
		if (rank != owner)
			continue;
		if (rank == 0) {
			buf = ens->blobs[r];
			n = ens->lens[r];
		} else {
			MPI_Recv(&n, 1, MPI_UNSIGNED_LONG_LONG, 0, r, MPI_COMM_WORLD, MPI_STATUS_IGNORE);
			buf = malloc(n ? n : 1);
			if (!buf) {
				ret = RUN_ENOMEM;
				MPI_Recv(NULL, 0, MPI_BYTE, 0, r, MPI_COMM_WORLD, MPI_STATUS_IGNORE);
				continue;
			}
			MPI_Recv(buf, (int)n, MPI_BYTE, 0, r, MPI_COMM_WORLD, MPI_STATUS_IGNORE);
		}
		int e = ensemble_load(s, (uint64_t)r, buf, (size_t)n, &runs[r / size], err, errlen);
		if (e != RUN_OK && ret == RUN_OK)
			ret = e;
		if (rank != 0)
			free(buf);
	}
	return ret;
}

/* Collective checkpoint: every rank serialises its replicas and sends them to
 * rank 0 (in replica order), which writes one file. Returns 0 on every rank
 * when the file was written. */
static int ens_checkpoint(const scene_t *s, int rank, int size, run_t **runs, const ens_opts_t *eo, sink_t *sink,
                          const ckpt_ensemble_t *es, int out_failed)
{
	const int R = (int)s->replicas;
	unsigned char **blobs = rank == 0 ? calloc(R, sizeof(*blobs)) : NULL;
	size_t *lens = rank == 0 ? calloc(R, sizeof(*lens)) : NULL;
	/* out_failed (rank 0: a record or frame was not written): no checkpoint
	 * of outputs that are not there */
	int bad = rank == 0 && (!blobs || !lens || out_failed);
	for (int r = 0; r < R; r++) {
		int owner = r % size;
		unsigned char *buf = NULL;
		size_t n = 0;
		unsigned long long nn;
		if (rank == owner) {
			if (ensemble_save(runs[r / size], &buf, &n))
				bad = 1, n = 0;
			nn = n;
			if (rank == 0) {
				if (blobs) blobs[r] = buf, lens[r] = n;
				else free(buf);
			} else {
				MPI_Send(&nn, 1, MPI_UNSIGNED_LONG_LONG, 0, r, MPI_COMM_WORLD);
				MPI_Send(buf, (int)nn, MPI_BYTE, 0, r, MPI_COMM_WORLD);
				free(buf);
			}
		} else if (rank == 0) {
			MPI_Recv(&nn, 1, MPI_UNSIGNED_LONG_LONG, owner, r, MPI_COMM_WORLD, MPI_STATUS_IGNORE);
			buf = malloc(nn ? nn : 1);
			if (!buf)
				bad = 1;
			MPI_Recv(buf, buf ? (int)nn : 0, MPI_BYTE, owner, r, MPI_COMM_WORLD, MPI_STATUS_IGNORE);
			if (blobs) blobs[r] = buf, lens[r] = nn;
			else free(buf);
		}
	}
	int failed = bad;
	MPI_Allreduce(MPI_IN_PLACE, &failed, 1, MPI_INT, MPI_MAX, MPI_COMM_WORLD);
	if (rank == 0 && !failed) {
		ckpt_output_t pos = {0, 0, 0};
		if (flush_outputs(eo->outdir, sink, &pos) ||
		    ckpt_write_ensemble(eo->outdir, R, blobs, lens, es, eo->text, eo->len, &pos, sink->err,
		                        sizeof(sink->err)) != CKPT_OK)
			failed = 1;
	} else if (rank == 0 && !out_failed) {
		snprintf(sink->err, sizeof(sink->err), "checkpoint: out of memory for the replica states");
	}
	MPI_Bcast(&failed, 1, MPI_INT, 0, MPI_COMM_WORLD);
	for (int r = 0; blobs && r < R; r++)
		free(blobs[r]);
	free(blobs);
	free(lens);
	return failed ? -1 : 0;
}

/* Collective frames of one output time (ENS_FRAMES): want[r] != 0 for the
 * replicas whose schedule asks for one (run_frame_due(), reduced). In
 * replica order, the owner copies the replica's state into its buffers and,
 * unless it is rank 0, sends them to rank 0, which appends the frame to
 * particles/replica_r: rank 0 holds one frame at a time, whatever R. A
 * write failure on rank 0 sets *failed there (the next reduction stops the
 * run); the exchange is completed regardless, so no rank is left waiting. */
static void ens_frames(const scene_t *s, int rank, int size, run_t **runs, const double *want, sink_t *sink,
                       double *pos, double *vel, int64_t *ids, int *failed)
{
	const int R = (int)s->replicas;
	/* rows: the particles, or the slots with a reservoir wall (ids: each row's particle id, -1 empty) */
	const uint64_t rows = scene_slots(s);
	const int cnt = (int)(rows * (uint64_t)s->dim);
	struct { double time; uint64_t events, collisions; } hdr;
	for (int r = 0; r < R; r++) {
		int owner = r % size;
		run_record_t rec;
		if (want[r] == 0 || (rank != owner && rank != 0))
			continue;
		if (rank == owner) {
			run_frame(runs[r / size], &rec, pos, vel, ids);
			if (rank != 0) {
				hdr.time = rec.time, hdr.events = rec.events, hdr.collisions = rec.collisions;
				MPI_Send(&hdr, (int)sizeof hdr, MPI_BYTE, 0, r, MPI_COMM_WORLD);
				MPI_Send(pos, cnt, MPI_DOUBLE, 0, r, MPI_COMM_WORLD);
				MPI_Send(vel, cnt, MPI_DOUBLE, 0, r, MPI_COMM_WORLD);
				if (ids)
					MPI_Send(ids, (int)rows, MPI_INT64_T, 0, r, MPI_COMM_WORLD);
				continue;
			}
		} else {
			MPI_Recv(&hdr, (int)sizeof hdr, MPI_BYTE, owner, r, MPI_COMM_WORLD, MPI_STATUS_IGNORE);
			MPI_Recv(pos, cnt, MPI_DOUBLE, owner, r, MPI_COMM_WORLD, MPI_STATUS_IGNORE);
			MPI_Recv(vel, cnt, MPI_DOUBLE, owner, r, MPI_COMM_WORLD, MPI_STATUS_IGNORE);
			if (ids)
				MPI_Recv(ids, (int)rows, MPI_INT64_T, owner, r, MPI_COMM_WORLD, MPI_STATUS_IGNORE);
			memset(&rec, 0, sizeof rec);
			rec.kind = RUN_SNAPSHOT;
			rec.dim = s->dim;
			rec.n = rows;
			rec.time = hdr.time, rec.events = hdr.events, rec.collisions = hdr.collisions;
			rec.pos = pos, rec.vel = vel, rec.ids = ids;
		}
		if (!*failed && h5md_frame(sink->traj, r, &rec, sink->err, sizeof(sink->err)) != H5MD_OK)
			*failed = 1;
	}
	if (rank == 0 && !*failed && h5md_frames_done(sink->traj, sink->err, sizeof(sink->err)) != H5MD_OK)
		*failed = 1;
}

/*
 * Ensemble run (run.replicas > 1) on every rank: replica r runs on rank
 * r mod size with random stream r. After each output time all ranks sum
 * their packed records into one vector (each replica's slot is non-zero on
 * exactly one rank, so the sum is exact), and rank 0 emits the mean and
 * standard error over the replicas in replica order: the output does not
 * depend on the number of ranks. Three extra slots carry rank 0's stop flag
 * (SIGTERM/SIGINT), an error count and rank 0's wall-clock checkpoint flag.
 * With ENS_CKPT, checkpoints are taken at output times (where the replicas
 * are in step): when the mean time passes the next output.checkpoint time,
 * when the wall-clock interval has passed on rank 0, or on a stop request
 * (then the summary says interrupted and RUN_STOPPED is returned). With
 * ENS_FRAMES, R more slots carry each replica's frame request; the frames
 * are written after the record and before a checkpoint (ens_frames()), so
 * a checkpoint's replica states count exactly the frames in the file.
 * Returns a RUN_* code.
 */
static int ensemble_run(const scene_t *s, int rank, int size, sink_t *sink, const ens_opts_t *eo, char *err,
                        size_t errlen)
{
	const int R = (int)s->replicas, NL = R / size + (rank < R % size);
	const size_t NV = (size_t)R * ENSEMBLE_NV;
	const int frames = (eo->mode & ENS_FRAMES) != 0, curves = (eo->mode & ENS_CURVES) != 0;
	const size_t NX = NV + 3 + (frames || curves ? (size_t)R : 0);   /* reduced each output time */
	/* curves: every replica's packed sample, reduced to rank 0 at the output times where a replica's
	 * snapshot schedule asks for one; rank 0 combines them on a layout-only obs (mean, se per bin) */
	obs_t *lay = curves && rank == 0 ? obs_create(s, 1) : NULL;
	size_t CP = 0;
	double *cvals = NULL;
	const size_t fsz = frames ? scene_slots(s) * (size_t)s->dim : 0;
	double *fpos = frames ? malloc(fsz * sizeof(double)) : NULL, *fvel = frames ? malloc(fsz * sizeof(double)) : NULL;
	const int with_ids = frames && scene_has_reservoir(s);
	int64_t *fids = with_ids ? malloc(scene_slots(s) * sizeof(int64_t)) : NULL;
	run_t **runs = calloc(NL > 0 ? NL : 1, sizeof(run_t *));
	double **from_state = NULL;   /* from.replica "each": each local replica's positions, velocities, spins */
	run_record_t *last = calloc(NL > 0 ? NL : 1, sizeof(run_record_t));
	int *done = calloc(NL > 0 ? NL : 1, sizeof(int));
	double *vals = malloc(NX * sizeof(double));
	volatile sig_atomic_t stop_all = 0;
	int ret = RUN_OK, failed = 0, emit_failed = 0, stopping = 0;
	run_record_t rec, out, proto;
	double t0, ckpt_wall;
	ckpt_ensemble_t es = {1, 0.0};
	const int ckpt = (eo->mode & ENS_CKPT) != 0;

	if (!runs || !last || !done || !vals || (frames && (!fpos || !fvel)) || (with_ids && !fids) || (curves && rank == 0 && !lay))
		failed = 1;
	if (eo->mode & ENS_RESUME) {
		if (rank == 0)
			es = eo->ens->es;
		MPI_Bcast(&es.k_ckpt, 1, MPI_UINT64_T, 0, MPI_COMM_WORLD);
		MPI_Bcast(&es.wall_before, 1, MPI_DOUBLE, 0, MPI_COMM_WORLD);
		if (!failed && (ret = ens_load(s, rank, size, eo->ens, runs, err, errlen)) != RUN_OK)
			failed = 1;
	}
	/* from.replica "each" (not on resume: the checkpoint has the states): replica r starts from replica r
	 * of the trajectory rank 0 checked (load_from()); the frames live as long as the runs, as a single
	 * run's do (the engines copy them at creation; the run's scene keeps the pointers) */
	const int from_each = s->has_from && s->from_replica == SCENE_FROM_EACH && !(eo->mode & ENS_RESUME);
	char from_path[FROM_PATH_MAX] = "";
	if (from_each) {
		if (rank == 0)
			snprintf(from_path, sizeof from_path, "%s", eo->from_path ? eo->from_path : "");
		MPI_Bcast(from_path, FROM_PATH_MAX, MPI_CHAR, 0, MPI_COMM_WORLD);
		if (!(from_state = calloc(3 * (size_t)(NL > 0 ? NL : 1), sizeof(double *))))
			failed = 1;
	}
	for (int i = 0; i < NL && !failed && !(eo->mode & ENS_RESUME); i++) {
		int e, r = rank + i * size;
		scene_t sr = *s;
		if (from_each) {
			sr.from_replica = r;
			double **st = from_state + 3 * (size_t)i;
			if (frame_load(&sr, from_path, &st[0], &st[1], &st[2], err, errlen) != FRAME_OK) {
				failed = 1;
				ret = RUN_ESETUP;
				break;
			}
			sr.init_pos = st[0], sr.init_vel = st[1], sr.init_spin = st[2];
		}
		runs[i] = run_open(&sr, (uint64_t)r, &e, err, errlen);
		if (!runs[i]) {
			failed = 1;
			ret = e;
		}
	}
	if (curves && !failed && NL > 0) {
		CP = run_curves_packed_size(runs[0]);
		if (!(cvals = malloc((size_t)R * CP * sizeof(double))))
			failed = 1;
	} else if (curves && !failed) {
		/* a rank without replicas (size > R) still takes part in the reduction */
		obs_t *o = obs_create(s, 1);
		CP = o ? obs_packed_size(o) : 0;
		obs_destroy(o);
		if (!o || !(cvals = malloc((size_t)R * CP * sizeof(double))))
			failed = 1;
	}
	t0 = ckpt_wall = MPI_Wtime();   /* wall_seconds: the production run, as for one replica (set-up and relax excluded) */
	for (;;) {
		memset(vals, 0, NX * sizeof(double));
		for (int i = 0; i < NL && !failed; i++) {
			int r = rank + i * size, e = RUN_OK;
			if (!done[i]) {
				if ((e = run_next(runs[i], &stop_all, &last[i], &done[i])) != RUN_OK) {
					failed = 1;
					ret = e;
					if (e == RUN_ECOLLAPSE)
						snprintf(err, errlen, "replica %d: %s", r, last[i].warning ? last[i].warning : "");
					break;
				}
				if (frames || curves)
					vals[NV + 3 + r] = run_frame_due(runs[i]);
			}
			ensemble_pack(&last[i], done[i], vals + (size_t)r * ENSEMBLE_NV);
			if (r == 0)
				proto = last[i];
		}
		vals[NV] = rank == 0 ? stop_requested : 0;
		vals[NV + 1] = failed + emit_failed;
		vals[NV + 2] = rank == 0 && ckpt && s->checkpoint.kind == SCENE_CLOCK_WALL &&
		               MPI_Wtime() - ckpt_wall >= s->checkpoint.value;
		MPI_Allreduce(MPI_IN_PLACE, vals, (int)NX, MPI_DOUBLE, MPI_SUM, MPI_COMM_WORLD);
		if (vals[NV + 1] > 0) {
			if (ret == RUN_OK)
				ret = emit_failed ? RUN_EMIT : RUN_ESETUP;
			if (ret == RUN_ESETUP && !failed)
				snprintf(err, errlen, "granular-engine: a replica failed on another rank");
			goto cleanup;
		}
		if (vals[NV] > 0) {
			if (ckpt)
				stopping = 1;   /* checkpoint below, after this output time's record */
			else
				stop_all = 1;
		}
		int ndone = ensemble_combine(vals, R, rank == 0 ? &proto : &last[0], &out);
		if (rank == 0) {
			out.wall_seconds = es.wall_before + MPI_Wtime() - t0;
			if (emit(&out, sink))
				emit_failed = 1;
		}
		if (curves) {
			int due = 0;
			for (int r = 0; r < R; r++)
				due |= vals[NV + 3 + r] != 0;
			if (due) {
				memset(cvals, 0, (size_t)R * CP * sizeof(double));
				for (int i = 0; i < NL; i++)
					if (run_curves_pack(runs[i], cvals + (size_t)(rank + i * size) * CP) != RUN_OK)
						emit_failed = 1;   /* out of memory: the next reduction stops the run */
				MPI_Reduce(rank == 0 ? MPI_IN_PLACE : cvals, cvals, (int)((size_t)R * CP), MPI_DOUBLE, MPI_SUM, 0,
				           MPI_COMM_WORLD);
				if (rank == 0 && !emit_failed) {
					run_record_t crec = out;
					crec.kind = RUN_CURVES;
					crec.curves = obs_combine(lay, cvals, R);
					crec.replicas = (uint32_t)R;
					if (emit(&crec, sink))
						emit_failed = 1;
				}
				if (!frames)
					for (int i = 0; i < NL; i++)
						if (vals[NV + 3 + rank + i * size] != 0)
							run_snap_taken(runs[i]);
			}
		}
		if (frames)
			ens_frames(s, rank, size, runs, vals + NV + 3, sink, fpos, fvel, fids, &emit_failed);
		if (ndone == R && !emit_failed)
			break;
		/* Checkpoint decisions from data every rank has: the mean time, the
		 * reduced flags. */
		int due = stopping || vals[NV + 2] > 0;
		if (ckpt && s->checkpoint.kind == SCENE_CLOCK_TIME && out.time >= (double)es.k_ckpt * s->checkpoint.value) {
			due = 1;
			while ((double)es.k_ckpt * s->checkpoint.value <= out.time)
				es.k_ckpt++;
		}
		if (ckpt && due) {
			ckpt_ensemble_t now = es;
			now.wall_before = es.wall_before + MPI_Wtime() - t0;
			if (ens_checkpoint(s, rank, size, runs, eo, sink, &now, emit_failed)) {
				ret = RUN_EMIT;
				goto cleanup;
			}
			ckpt_wall = MPI_Wtime();
			if (stopping)
				break;
		}
	}
	/* Summary: totals and final means over the replicas. */
	memset(vals, 0, NX * sizeof(double));
	for (int i = 0; i < NL; i++) {
		run_summary_record(runs[i], &rec);
		ensemble_pack(&rec, 1, vals + (size_t)(rank + i * size) * ENSEMBLE_NV);
		if (rank + i * size == 0)
			proto = rec;
	}
	MPI_Allreduce(MPI_IN_PLACE, vals, (int)(NV + 3), MPI_DOUBLE, MPI_SUM, MPI_COMM_WORLD);
	if (rank == 0) {
		ensemble_combine(vals, R, &proto, &out);
		if (stopping)
			out.status = RUN_INTERRUPTED;
		out.wall_seconds = es.wall_before + MPI_Wtime() - t0;
		out.events_per_second = out.wall_seconds > 0 ? out.events / out.wall_seconds : 0;
		out.collisions_per_second = out.wall_seconds > 0 ? out.collisions / out.wall_seconds : 0;
		if (emit(&out, sink))
			ret = RUN_EMIT;
	}
	if (stopping && ret == RUN_OK)
		ret = RUN_STOPPED;
cleanup:
	for (int i = 0; runs && i < NL; i++)
		run_destroy(runs[i]);
	for (size_t k = 0; from_state && k < 3 * (size_t)NL; k++)
		free(from_state[k]);
	free(from_state);
	free(runs);
	free(last);
	free(done);
	free(vals);
	free(fpos);
	free(fvel);
	free(fids);
	free(cvals);
	obs_destroy(lay);
	return ret;
}

/* Ranks other than 0: wait for rank 0's announcement, then take part in an
 * ensemble or just wait for the end. */
static int run_other(int rank, int size)
{
	long long hdr[2];
	MPI_Request req;
	char err[512] = "";
	int ret = EX_DONE;
	MPI_Ibcast(hdr, 2, MPI_LONG_LONG, 0, MPI_COMM_WORLD, &req);
	wait_idle(&req);
	if (hdr[0] != 0) {
		char *text = malloc((size_t)hdr[1] + 1);
		scene_t scene;
		ens_opts_t eo = {(int)hdr[0], NULL, NULL, 0, NULL, NULL};
		MPI_Bcast(text, (int)hdr[1], MPI_CHAR, 0, MPI_COMM_WORLD);
		/* Rank 0 accepted this text, so the parse cannot fail here. */
		if ((hdr[0] & ED_SPLIT) && scene_parse(text, (size_t)hdr[1], &scene, err, sizeof(err)) == SCENE_OK &&
		    (scene.method != SCENE_METHOD_AUTO || resolve_auto(&scene, size, NULL) == EX_DONE)) {
			/* one ed system over all ranks: rank 0 reports failures */
			edrun_opts_t edo = {.frames = (hdr[0] & ENS_FRAMES) != 0, .checkpoints = (hdr[0] & ENS_CKPT) != 0,
			                    .resumed = (hdr[0] & ENS_RESUME) != 0};
			int rc = edrun_run(&scene, rank, size, &edo, NULL, NULL, NULL, err, sizeof(err));
			if (rc != RUN_OK && rc != RUN_STOPPED)
				ret = EX_FAIL;
		} else if (scene_parse(text, (size_t)hdr[1], &scene, err, sizeof(err)) == SCENE_OK &&
		    (scene.method != SCENE_METHOD_AUTO || resolve_auto(&scene, size, NULL) == EX_DONE) &&
		    (hdr[0] & DSMC_SPLIT)) {
			/* one dsmc system over all ranks: rank 0 reports failures */
			dsmcrun_opts_t o = {.frames = (hdr[0] & ENS_FRAMES) != 0, .checkpoints = (hdr[0] & ENS_CKPT) != 0,
			                    .resumed = (hdr[0] & ENS_RESUME) != 0};
			int rc = dsmcrun_run(&scene, rank, size, &o, NULL, NULL, NULL, err, sizeof(err));
			if (rc != RUN_OK && rc != RUN_STOPPED)
				ret = EX_FAIL;
		} else if (scene_parse(text, (size_t)hdr[1], &scene, err, sizeof(err)) == SCENE_OK &&
		    (scene.method != SCENE_METHOD_AUTO || resolve_auto(&scene, size, NULL) == EX_DONE)) {
			int rc = ensemble_run(&scene, rank, size, NULL, &eo, err, sizeof(err));
			if (rc == RUN_ECOLLAPSE)
				fprintf(stderr, "%s\n", err);   /* rank 0 knows only that a replica failed here */
			if (rc != RUN_OK && rc != RUN_STOPPED)
				ret = EX_FAIL;
		}
		free(text);
	}
	idle_until_rank0();
	return ret;
}

/* particles.initial.from: the file it names (a relative file name is taken
 * from the scene file's directory; a job from --jobs-dir) loaded into
 * *pos, *vel and given to the engines through the scene. With
 * from.replica "each" (ensembles) every replica's frame is read here to
 * check it, and path (FROM_PATH_MAX bytes) keeps the file's name: each
 * replica loads its own when it starts (ensemble_run()). EX_DONE, or
 * EX_INPUT/EX_FAIL with the one line printed. */
static int load_from(scene_t *s, const char *scene_path, const char *jobs_dir, double **pos, double **vel,
                     double **spin, char *path)
{
	char err[2 * SCENE_PATH_MAX + 512];
	const size_t plen = FROM_PATH_MAX;
	if (s->from_job) {
		if (!jobs_dir) {
			fprintf(stderr, "particles.initial.from.job: a job reference is resolved by the daemon "
			        "(granular-engine --jobs-dir DIR); use from.file outside it\n");
			return EX_INPUT;
		}
		snprintf(path, plen, "%s/%llu/trajectory.h5", jobs_dir, (unsigned long long)s->from_job);
	} else if (s->from_file[0] == '/') {
		snprintf(path, plen, "%s", s->from_file);
	} else {
		const char *slash = strrchr(scene_path, '/');
		int dirlen = slash ? (int)(slash - scene_path) : 1;
		snprintf(path, plen, "%.*s/%s", dirlen, slash ? scene_path : ".", s->from_file);
	}
	if (s->from_replica == SCENE_FROM_EACH) {
		/* every replica's frame now, so that a missing one is the scene's error before anything runs */
		for (uint64_t r = 0; r < s->replicas; r++) {
			scene_t sr = *s;
			sr.from_replica = (int64_t)r;
			int rc = frame_load(&sr, path, pos, vel, spin, err, sizeof err);
			free(*pos);
			free(*vel);
			free(*spin);
			*pos = *vel = *spin = NULL;
			if (rc != FRAME_OK) {
				fprintf(stderr, "%s\n", err);
				return rc == FRAME_ENOMEM ? EX_FAIL : EX_INPUT;
			}
		}
		return EX_DONE;
	}
	int rc = frame_load(s, path, pos, vel, spin, err, sizeof err);
	if (rc != FRAME_OK) {
		fprintf(stderr, "%s\n", err);
		return rc == FRAME_ENOMEM ? EX_FAIL : EX_INPUT;
	}
	s->init_pos = *pos;
	s->init_vel = *vel;
	s->init_spin = *spin;
	return EX_DONE;
}

static int run_rank0(int argc, char **argv, announce_t *an, int size)
{
	const char *cmd = argv[1], *scene_path = NULL, *outdir = NULL, *resume_path = NULL, *jobs_dir = NULL;
	double *from_pos = NULL, *from_vel = NULL, *from_spin = NULL;
	char from_path[FROM_PATH_MAX] = "";
	int progress_fd = 1, ret = EX_FAIL, force_split = 0;
	char err[512] = "", *text = NULL, *advice_line = NULL;
	size_t len = 0;
	scene_t scene;
	sink_t sink = {.progress = NULL};
	ens_resume_t ens = {NULL, NULL, {1, 0.0}};
	ckpt_split_t sck;   /* a split run's checkpoint (--resume) */
	uint64_t *frames = NULL;

	memset(&sck, 0, sizeof sck);

	for (int i = 2; i < argc; i++) {
		if (!strcmp(argv[i], "--out") && i + 1 < argc) {
			outdir = argv[++i];
		} else if (!strcmp(argv[i], "--resume") && i + 1 < argc) {
			resume_path = argv[++i];
		} else if (!strcmp(argv[i], "--split")) {
			force_split = 1;
		} else if (!strcmp(argv[i], "--jobs-dir") && i + 1 < argc) {
			jobs_dir = argv[++i];
		} else if (!strcmp(argv[i], "--progress-fd") && i + 1 < argc) {
			char *end;
			long v = strtol(argv[++i], &end, 10);
			if (*end || v < 1 || v > 1 << 20) {
				fprintf(stderr, "granular-engine: --progress-fd: not a file descriptor number: %s\n", argv[i]);
				return EX_INPUT;
			}
			progress_fd = (int)v;
		} else if (argv[i][0] == '-' || scene_path) {
			fprintf(stderr, "granular-engine: unexpected argument: %s (see --help)\n", argv[i]);
			return EX_INPUT;
		} else {
			scene_path = argv[i];
		}
	}
	if (!scene_path) {
		fprintf(stderr, "granular-engine: %s: missing SCENE.json (see --help)\n", cmd);
		return EX_INPUT;
	}
	text = read_file(scene_path, &len, err, sizeof(err));
	if (!text) {
		fprintf(stderr, "granular-engine: %s\n", err);
		return EX_INPUT;
	}
	run_t *run = NULL;
	int rc = scene_parse(text, len, &scene, err, sizeof(err));
	if (rc != SCENE_OK) {
		/* One line, starting with the key path. */
		fprintf(stderr, "%s\n", err);
		ret = EX_INPUT;
		goto cleanup;
	}
	/* "auto": the method is chosen now, and the chosen scene must pass the
	 * start checks the parser makes for a fixed method (validate alike). */
	if (scene.method == SCENE_METHOD_AUTO) {
		if ((ret = resolve_auto(&scene, size, strcmp(cmd, "validate") ? &advice_line : NULL)) != EX_DONE)
			goto cleanup;
		if (scene_check_start(&scene, err, sizeof(err)) != SCENE_OK) {
			fprintf(stderr, "%s\n", err);
			ret = EX_INPUT;
			goto cleanup;
		}
	}
	/* An earlier run's frame (not when resuming: the checkpoint has the state). */
	if (scene.has_from && !resume_path &&
	    (ret = load_from(&scene, scene_path, jobs_dir, &from_pos, &from_vel, &from_spin, from_path)) != EX_DONE)
		goto cleanup;
	/* One dsmc system over several ranks (run.replicas 1 under mpirun -np
	 * P > 1; docs/parallel.md). What the decomposed run cannot do yet: with
	 * --split an error naming the key; under mpirun alone the run goes on as
	 * before this path existed (rank 0 runs it, the others wait) with a
	 * one-line notice, so that jobs that worked keep working. */
	/* A split run's checkpoint resumes split, at any rank count (one included, without --split); one that
	 * does not verify is left to the resume to report. */
	const int ckind = resume_path ? ckpt_is_split(resume_path) : -1, split_ckpt = ckind == 1;
	int split = (size > 1 || force_split || split_ckpt) && scene.replicas <= 1 &&
	            (scene.method == SCENE_METHOD_DSMC || scene.method == SCENE_METHOD_HSMC);
	if (split) {
		char why[512] = "";
		if (dsmcp_check(&scene, err, sizeof(err)) != DSMCP_OK)
			snprintf(why, sizeof why, "%s", err);
		else if (ckind == 0)
			snprintf(why, sizeof why, "--resume: the checkpoint is of a run on one rank, not split (resume it "
			         "without --split)");
		if (why[0] && (force_split || split_ckpt)) {
			/* a key names itself; an option is the program's */
			fprintf(stderr, "%s%s (one dsmc/hsmc system over %d ranks)\n", why[0] == '-' ? "granular-engine: " : "",
			        why, size);
			ret = EX_INPUT;
			goto cleanup;
		}
		if (why[0]) {
			fprintf(stderr, "granular-engine: running on rank 0 alone, not split over %d ranks: %s\n", size, why);
			split = 0;
		}
	}
	/* One ed system over several ranks (engine/par/edrun.h), refused and noticed as the dsmc split above. */
	int ed_split = (size > 1 || force_split) && scene.replicas <= 1 && scene.method == SCENE_METHOD_ED;
	if (ed_split && edrun_check(&scene, outdir != NULL, err, sizeof(err)) != 0) {
		if (force_split) {
			fprintf(stderr, "%s%s (one ed system over %d ranks)\n", err[0] == '-' ? "granular-engine: " : "", err, size);
			ret = EX_INPUT;
			goto cleanup;
		}
		fprintf(stderr, "granular-engine: running on rank 0 alone, not split over %d ranks: %s\n", size, err);
		ed_split = 0;
	}
	if (!strcmp(cmd, "validate")) {
		ret = EX_DONE;
		goto cleanup;
	}
	/* Single runs: run_go() with frames and checkpoints; ensembles take both
	 * at output times (ensemble_run()). */
	const int stepped = scene.replicas <= 1;
	if (resume_path && !outdir) {
		fprintf(stderr, "granular-engine: --resume needs --out DIR (the run's output directory)\n");
		ret = EX_INPUT;
		goto cleanup;
	}
	/* Curves (observables.jsonl) come with --out (ensembles: means and standard errors, ensemble_run()). */
	const int want_curves = outdir != NULL && obs_curve_bits(&scene) != 0;
	run_opts_t opts = {.snapshots = outdir != NULL && stepped, .checkpoints = outdir != NULL && stepped,
	                   .curves = want_curves && stepped};
	if (want_curves && !stepped) {
		/* every rank holds all replicas' packed curves for their reduction (ensemble_run()) */
		obs_t *lay = obs_create(&scene, 1);
		double need = lay ? (double)scene.replicas * (double)obs_packed_size(lay) * sizeof(double) : 0.0;
		obs_destroy(lay);
		if (need > ENS_CURVES_MAX) {
			fprintf(stderr, "granular-engine: output.observables: the curves of %llu replicas need %.3g GiB on every "
			        "rank to be combined (at most %.3g GiB): fewer replicas or fewer bins\n",
			        (unsigned long long)scene.replicas, need / (1u << 30), ENS_CURVES_MAX / (1u << 30));
			ret = EX_INPUT;
			goto cleanup;
		}
	}
	ckpt_output_t at = {0, 0, 0};
	if (!stepped) {
		ens.blobs = calloc(scene.replicas, sizeof(*ens.blobs));
		ens.lens = calloc(scene.replicas, sizeof(*ens.lens));
		if (!ens.blobs || !ens.lens) {
			fprintf(stderr, "granular-engine: out of memory\n");
			goto cleanup;
		}
	}
	if (resume_path &&
	    (ret = resume(resume_path, &scene, text, len, &opts, &run, &ens, split ? &sck : NULL, &at)) != EX_DONE)
		goto cleanup;
	ret = EX_FAIL;

	sink.progress = progress_fd == 1 ? stdout : fdopen(progress_fd, "w");
	if (!sink.progress) {
		fprintf(stderr, "granular-engine: --progress-fd %d: %s\n", progress_fd, strerror(errno));
		ret = EX_INPUT;
		goto cleanup;
	}
	if (outdir) {
		char path[4096];
		if (mkdir(outdir, 0777) != 0 && errno != EEXIST) {
			fprintf(stderr, "granular-engine: --out %s: %s\n", outdir, strerror(errno));
			ret = EX_INPUT;
			goto cleanup;
		}
		snprintf(path, sizeof(path), "%s/progress.jsonl", outdir);
		/* Resumed: drop the lines written after the checkpoint, append. */
		sink.copy = fopen(path, resume_path ? "r+" : "w");
		if (sink.copy && resume_path) {
			struct stat st;
			if (fstat(fileno(sink.copy), &st) != 0 || (uint64_t)st.st_size < at.progress_bytes ||
			    ftruncate(fileno(sink.copy), (off_t)at.progress_bytes) != 0 || fseek(sink.copy, 0, SEEK_END) != 0) {
				fprintf(stderr, "granular-engine: %s: shorter than at the checkpoint or not writable\n", path);
				goto cleanup;
			}
		}
		if (!sink.copy) {
			fprintf(stderr, "granular-engine: %s: %s\n", path, strerror(errno));
			ret = resume_path ? EX_FAIL : EX_INPUT;
			goto cleanup;
		}
		double t_ckpt = 0.0;
		uint64_t ev, co;
		if (run)
			run_totals(run, &t_ckpt, &ev, &co);
		else if (resume_path && split)
			t_ckpt = sck.state.clock.time;
		else if (resume_path)
			t_ckpt = last_progress_time(sink.copy);   /* ensembles: the mean time of the checkpoint's record */
		if (want_curves && open_curves(outdir, resume_path != NULL, t_ckpt, &sink) != 0)
			goto cleanup;
		snprintf(path, sizeof(path), "%s/trajectory.h5", outdir);
		if (resume_path && resume_frames(&scene, &ens, &at, &frames) != 0) {
			fprintf(stderr, "granular-engine: --resume %s: frame counts of the replicas do not add up to the "
			        "checkpoint's (damaged)\n", resume_path);
			ret = EX_INPUT;
			goto cleanup;
		}
		sink.traj = resume_path ? h5md_open_append(path, &scene, at.obs_rows, frames, &rc, err, sizeof(err))
		                        : h5md_create(path, &scene, text, len, &rc, err, sizeof(err));
		if (!sink.traj || (resume_path && h5md_fields_cut(sink.traj, t_ckpt, err, sizeof(err)) != H5MD_OK)) {
			fprintf(stderr, "granular-engine: %s\n", err);
			goto cleanup;
		}
	}
	if (!run && scene.replicas <= 1 && !split && !ed_split) {
		run = run_create(&scene, &opts, &rc, err, sizeof(err));
		if (!run) {
			fprintf(stderr, "%s\n", err);
			ret = rc == RUN_ENOMEM ? EX_FAIL : EX_INPUT;
			goto cleanup;
		}
	}

	/* The method choice goes first (not after a resume: it is already there). */
	if (advice_line && !resume_path) {
		size_t n = strlen(advice_line);
		if (fwrite(advice_line, 1, n, sink.progress) != n || fflush(sink.progress) != 0 ||
		    (sink.copy && (fwrite(advice_line, 1, n, sink.copy) != n || fflush(sink.copy) != 0))) {
			fprintf(stderr, "granular-engine: cannot write progress: %s\n", strerror(errno));
			goto cleanup;
		}
	}

	signal(SIGPIPE, SIG_IGN);   /* a closed progress pipe is an error return, not death */

	if (scene.replicas > 1) {
		ens_opts_t eo = {ENS_RUN | (outdir ? ENS_CKPT : 0) | (resume_path ? ENS_RESUME : 0) |
		                 (outdir && h5md_groups(&scene) > 0 ? ENS_FRAMES : 0) | (want_curves ? ENS_CURVES : 0), outdir,
		                 text, len, &ens, from_path};
		announce(an, eo.mode, text, len);
		rc = ensemble_run(&scene, 0, size, &sink, &eo, err, sizeof(err));
		if (rc == RUN_STOPPED) {
			ret = EX_CHECKPOINTED;
			goto cleanup;
		}
	} else if (ed_split) {
		ed_save_t es = {outdir, &sink, text, len};
		edrun_opts_t eo = {.frames = outdir != NULL, .checkpoints = outdir != NULL, .resumed = resume_path != NULL,
		                   .resume = run, .save = ed_save, .save_ctx = &es};
		announce(an, ED_SPLIT | (outdir ? ENS_FRAMES | ENS_CKPT : 0) | (resume_path ? ENS_RESUME : 0), text, len);
		rc = edrun_run(&scene, 0, size, &eo, emit, &sink, &stop_requested, err, sizeof(err));
		if (rc == RUN_STOPPED) {
			ret = EX_CHECKPOINTED;
			goto cleanup;
		}
	} else if (split) {
		dsmcrun_opts_t dop = {.frames = outdir != NULL, .checkpoints = outdir != NULL, .resumed = resume_path != NULL,
		                      .resume = &sck, .checkpoint = split_checkpoint};
		sink.outdir = outdir, sink.text = text, sink.len = len;
		announce(an, DSMC_SPLIT | (outdir ? ENS_FRAMES | ENS_CKPT : 0) | (resume_path ? ENS_RESUME : 0), text, len);
		rc = dsmcrun_run(&scene, 0, size, &dop, emit, &sink, &stop_requested, err, sizeof(err));
		if (rc == RUN_STOPPED) {
			ret = EX_CHECKPOINTED;
			goto cleanup;
		}
		if (rc == RUN_ENOMEM) {
			fprintf(stderr, "granular-engine: %s\n", err);
			ret = EX_FAIL;
			goto cleanup;
		}
	} else {
		announce(an, 0, NULL, 0);
		for (;;) {
			rc = run_go(run, emit, &sink, &stop_requested, err, sizeof(err));
			if (rc != RUN_CHECKPOINT && rc != RUN_STOPPED)
				break;
			if (checkpoint(outdir, run, &sink, text, len) != 0) {
				fprintf(stderr, "granular-engine: %s\n", sink.err);
				ret = EX_FAIL;
				goto cleanup;
			}
			if (rc == RUN_STOPPED) {
				run_summary(run, emit, &sink);   /* best effort: the checkpoint is what counts */
				ret = EX_CHECKPOINTED;
				goto cleanup;
			}
		}
	}
	if (rc == RUN_OK) {
		ret = stop_requested ? EX_INTERRUPTED : EX_DONE;
	} else if (rc == RUN_ESETUP || rc == RUN_EMETHOD || rc == RUN_ECOLLAPSE) {
		/* a collapse: the scene needs collisions.tc (the line starts with it) */
		fprintf(stderr, "%s\n", err);
		ret = EX_INPUT;
	} else if (rc == RUN_EMIT) {
		if (sink.err[0])
			fprintf(stderr, "granular-engine: %s\n", sink.err);
		else
			fprintf(stderr, "granular-engine: cannot write progress: %s\n", strerror(errno));
		ret = stop_requested ? EX_INTERRUPTED : EX_FAIL;
	} else {
		fprintf(stderr, "granular-engine: %s\n", err[0] ? err : "run failed");
		ret = EX_FAIL;
	}
cleanup:
	run_destroy(run);
	dsmcp_saved_free(&sck.state);
	free(from_pos);
	free(from_vel);
	free(from_spin);
	free(frames);
	for (uint64_t r = 0; ens.blobs && r < scene.replicas; r++)
		free(ens.blobs[r]);
	free(ens.blobs);
	free(ens.lens);
	free(text);
	free(advice_line);
	if (sink.traj && h5md_destroy(sink.traj) != H5MD_OK && ret == EX_DONE) {
		fprintf(stderr, "granular-engine: %s/trajectory.h5: cannot close\n", outdir);
		ret = EX_FAIL;
	}
	if (sink.copy)
		fclose(sink.copy);
	if (sink.curves)
		fclose(sink.curves);
	if (sink.progress && sink.progress != stdout)
		fclose(sink.progress);
	return ret;
}

#if defined(__SANITIZE_ADDRESS__)
/* Under AddressSanitizer (./configure --enable-sanitizers): Open MPI's and
 * PMIx's components keep allocations until exit and are dlclose'd by then,
 * and they have no frame pointers, so the fast unwinder's two-frame stacks
 * name an "<unknown module>" that no suppression in tests/lsan.supp can
 * match and every run ended in a leak report (exit 1). The slow unwinder
 * reaches libmpi & co. Allocation is rare in the engine after its start. */
const char *__asan_default_options(void);
const char *__asan_default_options(void) { return "fast_unwind_on_malloc=0"; }
#endif

int main(int argc, char **argv)
{
	int rank = 0, size = 1, ret;

	if (argc >= 2 && (!strcmp(argv[1], "--help") || !strcmp(argv[1], "-h"))) {
		usage(stdout);
		return EX_DONE;
	}
	if (argc >= 2 && !strcmp(argv[1], "--version")) {
		printf("granular-engine %s\n", PACKAGE_VERSION);
		return EX_DONE;
	}
	if (argc >= 2 && !strcmp(argv[1], "advise"))
		return advise_main(argc, argv);   /* no MPI: a pure estimate */
	if (argc < 2 || (strcmp(argv[1], "run") && strcmp(argv[1], "validate"))) {
		usage(stderr);
		return EX_INPUT;
	}
	MPI_Init(&argc, &argv);
	/* Every rank notes SIGTERM/SIGINT (mpirun forwards them to all ranks):
	 * only rank 0's flag stops a run, at a point all ranks agree on, so the
	 * others must survive the signal to take part in the last checkpoint. */
	struct sigaction sa;
	memset(&sa, 0, sizeof(sa));
	sa.sa_handler = on_signal;
	sigaction(SIGTERM, &sa, NULL);
	sigaction(SIGINT, &sa, NULL);
	MPI_Comm_rank(MPI_COMM_WORLD, &rank);
	MPI_Comm_size(MPI_COMM_WORLD, &size);
	if (rank == 0) {
		announce_t an = {0};
		ret = run_rank0(argc, argv, &an, size);
		if (!an.sent)
			announce(&an, 0, NULL, 0);
		MPI_Request req;
		MPI_Ibarrier(MPI_COMM_WORLD, &req);
		MPI_Wait(&req, MPI_STATUS_IGNORE);
	} else {
		ret = run_other(rank, size);
	}
	MPI_Finalize();
	return ret;
}
