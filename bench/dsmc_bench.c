/* Benchmark of the Monte Carlo core: particle moves and collisions per second, bytes per particle. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "mc/dsmc.h"
#include "scene.h"

static double now(void)
{
	struct timespec ts;
	clock_gettime(CLOCK_MONOTONIC, &ts);
	return ts.tv_sec + 1e-9 * ts.tv_nsec;
}

/* usage: dsmc_bench METHOD DIM N PHI RESTITUTION STEPS [CORRECTION]
 * METHOD dsmc or hsmc; default cell size and adaptive step (0.2 collisions
 * per particle per step). Random start, 2 untimed warm-up steps. One JSON line. */
int main(int argc, char **argv)
{
	if (argc < 7) {
		fprintf(stderr, "usage: dsmc_bench METHOD DIM N PHI RESTITUTION STEPS [CORRECTION]\n");
		return 2;
	}
	const char *method = argv[1], *corr = argc > 7 ? argv[7] : "none";
	int dim = atoi(argv[2]);
	long n = atol(argv[3]);
	double phi = atof(argv[4]), e = atof(argv[5]);
	long steps = atol(argv[6]);
	char json[512], err[512];
	snprintf(json, sizeof(json),
	         "{\"method\":\"%s\",\"dimensions\":%d,\"particles\":{\"count\":%ld,\"volume_fraction\":%g,"
	         "\"initial\":{\"positions\":\"random\"}},\"collisions\":{\"restitution\":%g},"
	         "\"run\":{\"until\":{\"time\":1}},\"%s\":{\"correction\":\"%s\"}}",
	         method, dim, n, phi, e, method, corr);
	scene_t sc;
	int rc;
	if (scene_parse(json, strlen(json), &sc, err, sizeof(err)) != SCENE_OK) {
		fprintf(stderr, "%s\n", err);
		return 2;
	}
	dsmc_t *d = dsmc_create(&sc, 0, &rc, err, sizeof(err));
	if (!d) {
		fprintf(stderr, "%s\n", err);
		return 1;
	}
	dsmc_advance(d, INFINITY, UINT64_MAX, 2);
	uint64_t m0 = dsmc_moves(d), c0 = dsmc_collisions(d);
	double t0 = now();
	clock_t c_0 = clock();
	dsmc_advance(d, INFINITY, UINT64_MAX, (uint64_t)steps);
	double w = now() - t0, cpu = (double)(clock() - c_0) / CLOCKS_PER_SEC;
	uint64_t moves = dsmc_moves(d) - m0, coll = dsmc_collisions(d) - c0;
	int cells[3];
	dsmc_cells(d, cells);
	printf("{\"method\":\"%s\",\"correction\":\"%s\",\"dim\":%d,\"n\":%ld,\"phi\":%g,\"restitution\":%g,"
	       "\"steps\":%ld,\"seconds\":%.3f,\"cpu_seconds\":%.6f,\"moves\":%llu,\"moves_per_second\":%.4g,\"collisions_per_second\":%.4g,"
	       "\"bytes_per_particle\":%.1f,\"cells\":[%d,%d,%d]}\n",
	       method, corr, dim, n, phi, e, steps, w, cpu, (unsigned long long)moves, moves / w, coll / w,
	       (double)dsmc_memory(d) / n, cells[0], cells[1], cells[2]);
	dsmc_destroy(d);
	return 0;
}
