/* Benchmark of the structure observables: wall time per sample of each curve family, and its memory, on an ed gas. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "ed/ed.h"
#include "observe/clusters.h"
#include "observe/observe.h"
#include "scene.h"

static double now(void)
{
	struct timespec ts;
	clock_gettime(CLOCK_MONOTONIC, &ts);
	return ts.tv_sec + 1e-9 * ts.tv_nsec;
}

static int cmp(const void *a, const void *b)
{
	double x = *(const double *)a, y = *(const double *)b;
	return (x > y) - (x < y);
}

#define REPS_MAX 15

/* The families timed: one scene each, asking for that family alone. "scalars" is obs_scalars() (a2,
 * a3, g_pairs: what each progress record costs with velocity_distribution and pair_correlation). */
static const char *const families[] = {"scalars", "velocity_distribution", "pair_correlation", "structure_factor",
                                       "velocity_correlations", "clusters", "fields"};
#define NF (sizeof families / sizeof families[0])

/* usage: obs_bench DIM N PHI REPS
 * An elastic ed gas from the lattice, advanced 1 collision per particle (untimed). Then REPS rounds; in
 * each, every family's sample is timed once, families interleaved (a shared machine drifts). One JSON
 * line per family: median seconds per sample, ns per particle, workspace bytes per particle. */
int main(int argc, char **argv)
{
	if (argc < 5) {
		fprintf(stderr, "usage: obs_bench DIM N PHI REPS\n");
		return 2;
	}
	int dim = atoi(argv[1]), reps = atoi(argv[4]);
	long n = atol(argv[2]);
	double phi = atof(argv[3]);
	if ((dim != 2 && dim != 3) || n < 2 || reps < 1 || reps > REPS_MAX) {
		fprintf(stderr, "obs_bench: DIM 2 or 3, N >= 2, 1 <= REPS <= %d\n", REPS_MAX);
		return 2;
	}
	char json[1024], err[512];
	scene_t sc[NF];
	obs_t *o[NF] = {0};
	clusters_t *cl = NULL;
	double *pos = NULL, *vel = NULL, t[NF][REPS_MAX];
	ed_t *ed = NULL;
	int rc, ret = 1;
	for (size_t f = 0; f < NF; f++) {
		const char *obs = f == 0 ? "\"velocity_distribution\",\"pair_correlation\"" : NULL;
		char one[64];
		if (!obs) {
			snprintf(one, sizeof one, "\"%s\"", families[f]);
			obs = one;
		}
		snprintf(json, sizeof(json),
		         "{\"method\":\"ed\",\"dimensions\":%d,\"particles\":{\"count\":%ld,\"volume_fraction\":%g},"
		         "\"run\":{\"until\":{\"collisions_per_particle\":1}},"
		         "\"output\":{\"observables\":[\"temperature\",%s]%s}}", dim, n, phi, obs,
		         !strcmp(families[f], "fields") ? (dim == 3 ? ",\"fields\":{\"cells\":32}" : ",\"fields\":{\"cells\":128}") : "");
		if (scene_parse(json, strlen(json), &sc[f], err, sizeof(err)) != SCENE_OK) {
			fprintf(stderr, "obs_bench: %s\n", err);
			goto out;
		}
		if (!(o[f] = obs_create(&sc[f], 0))) {
			fprintf(stderr, "obs_bench: %s: out of memory\n", families[f]);
			goto out;
		}
	}
	ed = ed_create(&sc[0], &rc, err, sizeof(err));
	pos = malloc((size_t)n * dim * sizeof(double));
	vel = malloc((size_t)n * dim * sizeof(double));
	cl = clusters_create(dim, (size_t)n);
	if (!ed || !pos || !vel || !cl) {
		fprintf(stderr, "obs_bench: %s\n", ed ? "out of memory" : err);
		goto out;
	}
	ed_advance(ed, INFINITY, (uint64_t)n, UINT64_MAX);
	ed_state(ed, pos, vel);
	for (int r = 0; r < reps; r++)
		for (size_t f = 0; f < NF; f++) {
			double t0 = now();
			if (f == 0) {
				obs_scalars_t sv;
				obs_scalars(o[f], (size_t)n, pos, vel, &sv);
			} else {
				if (!strcmp(families[f], "fields"))
					obs_fields_add(o[f], pos, vel, NULL);
				if (!obs_curves(o[f], cl, (size_t)n, pos, vel, NULL)) {
					fprintf(stderr, "obs_bench: %s: out of memory\n", families[f]);
					goto out;
				}
			}
			t[f][r] = now() - t0;
		}
	for (size_t f = 0; f < NF; f++) {
		qsort(t[f], (size_t)reps, sizeof(double), cmp);
		double med = t[f][reps / 2];
		size_t mem = obs_memory(o[f]);   /* clusters: plus the run's cluster workspace (docs/daemon.md) */
		printf("{\"family\":\"%s\",\"dim\":%d,\"n\":%ld,\"phi\":%g,\"reps\":%d,\"seconds\":%.4g,"
		       "\"min_seconds\":%.4g,\"ns_per_particle\":%.4g,\"bytes_per_particle\":%.1f}\n",
		       families[f], dim, n, phi, reps, med, t[f][0], 1e9 * med / n, (double)mem / n);
	}
	ret = 0;
out:
	for (size_t f = 0; f < NF; f++)
		obs_destroy(o[f]);
	clusters_destroy(cl);
	ed_destroy(ed);
	free(pos);
	free(vel);
	return ret;
}
