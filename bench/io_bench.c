/* Benchmark of the HDF5 output: checkpoint and snapshot write time and size, and the slowdown of a run with checkpoints. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>

#include "io/checkpoint.h"
#include "ed/ed.h"
#include "io/h5md.h"
#include "run.h"
#include "scene.h"

static double now(void)
{
	struct timespec ts;
	clock_gettime(CLOCK_MONOTONIC, &ts);
	return ts.tv_sec + 1e-9 * ts.tv_nsec;
}

static double fsize(const char *path)
{
	struct stat st;
	return stat(path, &st) == 0 ? (double)st.st_size : -1.0;
}

static int ignore(const run_record_t *r, void *ctx)
{
	(void)r;
	(void)ctx;
	return 0;
}

/* usage: io_bench DIR DIM N PHI MEASURE_CPP CKPT_WALL_SECONDS
 * Writes its files under DIR (removed afterwards) and prints one JSON line:
 * checkpoint write/read seconds and bytes, one frame's write seconds and
 * bytes at deflate 0 and 1, and a run of MEASURE_CPP collisions per particle
 * without and with a checkpoint every CKPT_WALL_SECONDS. */
int main(int argc, char **argv)
{
	if (argc < 7) {
		fprintf(stderr, "usage: io_bench DIR DIM N PHI MEASURE_CPP CKPT_WALL_SECONDS\n");
		return 2;
	}
	const char *dir = argv[1];
	int dim = atoi(argv[2]);
	long n = atol(argv[3]);
	double phi = atof(argv[4]), meas = atof(argv[5]), every = atof(argv[6]);
	char json[1024], err[512], path[4096];
	scene_t sc;
	int rc;

	snprintf(json, sizeof(json),
	         "{\"method\":\"ed\",\"dimensions\":%d,\"particles\":{\"count\":%ld,\"volume_fraction\":%g},"
	         "\"run\":{\"until\":{\"collisions_per_particle\":%g}},\"output\":{\"every\":{\"collisions_per_particle\":%g},"
	         "\"checkpoint\":{\"every\":{\"wall_seconds\":%g}}}}",
	         dim, n, phi, meas, meas, every);
	if (scene_parse(json, strlen(json), &sc, err, sizeof(err)) != SCENE_OK) {
		fprintf(stderr, "%s\n", err);
		return 2;
	}
	mkdir(dir, 0777);

	/* 1. Baseline: the run without checkpoints. */
	run_opts_t plain = {.snapshots = 0, .checkpoints = 0};
	run_t *r = run_create(&sc, &plain, &rc, err, sizeof(err));
	if (!r) {
		fprintf(stderr, "%s\n", err);
		return 1;
	}
	double t0 = now();
	rc = run_go(r, ignore, NULL, NULL, err, sizeof(err));
	double t_plain = now() - t0;
	uint64_t coll = ed_collisions(run_ed(r));

	/* 2. Checkpoint of the final state: write (best of 3), size, read. */
	ckpt_output_t at = {0, 0, 0};
	double t_write = INFINITY;
	for (int k = 0; k < 3; k++) {
		t0 = now();
		if (ckpt_write(dir, r, json, strlen(json), &at, err, sizeof(err)) != CKPT_OK) {
			fprintf(stderr, "%s\n", err);
			return 1;
		}
		double w = now() - t0;
		if (w < t_write)
			t_write = w;
	}
	snprintf(path, sizeof(path), "%s/%s", dir, CKPT_FILE);
	double ckpt_bytes = fsize(path);
	run_t *back = NULL;
	t0 = now();
	if (ckpt_read(path, &sc, json, strlen(json), &plain, &back, &at, err, sizeof(err)) != CKPT_OK) {
		fprintf(stderr, "%s\n", err);
		return 1;
	}
	double t_read = now() - t0;
	run_destroy(back);

	/* 3. One frame (positions + velocities) at deflate 0 and 1. */
	double t_frame[2] = {0, 0}, frame_bytes[2] = {0, 0};
	for (int level = 0; level < 2; level++) {
		sc.compression = level;
		snprintf(path, sizeof(path), "%s/traj%d.h5", dir, level);
		h5md_t *h = h5md_create(path, &sc, json, strlen(json), &rc, err, sizeof(err));
		if (!h) {
			fprintf(stderr, "%s\n", err);
			return 1;
		}
		double *pos = malloc(n * dim * sizeof(double)), *vel = malloc(n * dim * sizeof(double));
		ed_state(run_ed(r), pos, vel);
		run_record_t rec = {.kind = RUN_SNAPSHOT, .dim = dim, .n = (uint64_t)n, .pos = pos, .vel = vel};
		double before = fsize(path);
		t0 = now();
		rc = h5md_snapshot(h, &rec, err, sizeof(err)) || h5md_flush(h, err, sizeof(err));
		t_frame[level] = now() - t0;
		h5md_destroy(h);
		frame_bytes[level] = fsize(path) - before;
		free(pos);
		free(vel);
		unlink(path);
		snprintf(path, sizeof(path), "%s/traj%d.xdmf", dir, level);
		unlink(path);
		if (rc) {
			fprintf(stderr, "%s\n", err);
			return 1;
		}
	}
	run_destroy(r);

	/* 4. The same run with a checkpoint every `every` wall seconds. */
	run_opts_t ck = {.snapshots = 0, .checkpoints = 1};
	sc.compression = 1;
	r = run_create(&sc, &ck, &rc, err, sizeof(err));
	int nck = 0;
	double t_ck_sum = 0.0;
	t0 = now();
	while (r && (rc = run_go(r, ignore, NULL, NULL, err, sizeof(err))) == RUN_CHECKPOINT) {
		double c0 = now();
		if (ckpt_write(dir, r, json, strlen(json), &at, err, sizeof(err)) != CKPT_OK) {
			fprintf(stderr, "%s\n", err);
			return 1;
		}
		t_ck_sum += now() - c0;
		nck++;
	}
	double t_ck = now() - t0;
	run_destroy(r);
	const char *names[] = {CKPT_FILE, CKPT_PREV, CKPT_TMP};
	for (size_t k = 0; k < 3; k++) {
		snprintf(path, sizeof(path), "%s/%s", dir, names[k]);
		unlink(path);
	}
	rmdir(dir);

	printf("{\"dim\":%d,\"n\":%ld,\"phi\":%g,\"collisions\":%llu,\"ckpt_write_seconds\":%.3f,\"ckpt_read_seconds\":%.3f,"
	       "\"ckpt_bytes\":%.0f,\"frame_seconds\":[%.3f,%.3f],\"frame_bytes\":[%.0f,%.0f],"
	       "\"run_seconds\":%.3f,\"run_ckpt_seconds\":%.3f,\"checkpoints\":%d,\"ckpt_seconds_in_run\":%.3f,"
	       "\"every\":%g}\n",
	       dim, n, phi, (unsigned long long)coll, t_write, t_read, ckpt_bytes, t_frame[0], t_frame[1],
	       frame_bytes[0], frame_bytes[1], t_plain, t_ck, nck, t_ck_sum, every);
	return 0;
}
