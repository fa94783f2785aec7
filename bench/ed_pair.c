/* Old against new event-driven engine in one process: alternating segments, CPU time per collision, median ratio. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "ed/ed.h"
#include "scene.h"

/* The old engine: the same API with every ed_ symbol renamed old_ed_
 * (bench/ed_pair.sh builds it from another source tree). */
ed_t *old_ed_create(const scene_t *s, int *err, char *msg, size_t msglen);
void old_ed_destroy(ed_t *ed);
int old_ed_advance(ed_t *ed, double t_stop, uint64_t max_collisions, uint64_t max_events);
uint64_t old_ed_collisions(const ed_t *ed);
uint64_t old_ed_events(const ed_t *ed);

typedef struct {
	ed_t *(*create)(const scene_t *, int *, char *, size_t);
	void (*destroy)(ed_t *);
	int (*advance)(ed_t *, double, uint64_t, uint64_t);
	uint64_t (*collisions)(const ed_t *);
	uint64_t (*events)(const ed_t *);
} api_t;

static const api_t apis[2] = {
	{ old_ed_create, old_ed_destroy, old_ed_advance, old_ed_collisions, old_ed_events },
	{ ed_create, ed_destroy, ed_advance, ed_collisions, ed_events },
};

static double cpu_now(void)
{
	struct timespec ts;
	clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
	return ts.tv_sec + 1e-9 * ts.tv_nsec;
}

static int cmp(const void *a, const void *b)
{
	double x = *(const double *)a, y = *(const double *)b;
	return (x > y) - (x < y);
}

/* usage: ed_pair DIM N PHI RESTITUTION WARMUP_CPP SEGMENT_CPP PAIRS [new-first]
 * Both engines start from the same scene (seed included) and the same
 * untimed warm-up; then segments of SEGMENT_CPP collisions per particle
 * alternate (old, new, new, old, ...: the order within a pair alternates
 * too), each timed in CPU time of this thread. Prints one line: the median
 * over pairs of (old time / new time) per collision (> 1: the new engine is
 * faster), its min-max, and events per collision of both. */
int main(int argc, char **argv)
{
	if (argc < 8) {
		fprintf(stderr, "usage: ed_pair DIM N PHI RESTITUTION WARMUP_CPP SEGMENT_CPP PAIRS [new-first]\n");
		return 2;
	}
	int dim = atoi(argv[1]), pairs = atoi(argv[7]);
	long n = atol(argv[2]);
	double phi = atof(argv[3]), e = atof(argv[4]), warm = atof(argv[5]), seg = atof(argv[6]);
	char json[1024], err[512];
	snprintf(json, sizeof(json),
	         "{\"method\":\"ed\",\"dimensions\":%d,\"particles\":{\"count\":%ld,\"volume_fraction\":%g,"
	         "\"initial\":{\"relax\":{\"collisions_per_particle\":%g}}},"
	         "\"collisions\":{\"restitution\":%g},\"run\":{\"until\":{\"time\":1}}}",
	         dim, n, phi, warm, e);
	scene_t sc;
	int rc;
	if (scene_parse(json, strlen(json), &sc, err, sizeof(err)) != SCENE_OK || pairs < 1 || pairs > 1000) {
		fprintf(stderr, "ed_pair: %s\n", pairs < 1 || pairs > 1000 ? "PAIRS: 1 to 1000" : err);
		return 2;
	}
	/* optional 8th argument "new-first": the new engine is created (and
	 * its memory allocated) first; at N = 10^7 the engine created second
	 * ran up to 1.23x faster in an A/A control, so compare both orders */
	const int first = argc > 8 && !strcmp(argv[8], "new-first");
	ed_t *ed[2];
	for (int q = 0; q < 2; q++) {
		int k = first ? 1 - q : q;
		if (!(ed[k] = apis[k].create(&sc, &rc, err, sizeof(err)))) {
			fprintf(stderr, "ed_pair: %s\n", err);
			return 1;
		}
	}
	/* one untimed segment each: the timed ones start from a run state */
	for (int k = 0; k < 2; k++)
		apis[k].advance(ed[k], INFINITY, apis[k].collisions(ed[k]) + (uint64_t)(seg * n / 2), UINT64_MAX);
	double ratio[1000], tot[2] = {0, 0};
	uint64_t c0[2], e0[2];
	for (int k = 0; k < 2; k++)
		c0[k] = apis[k].collisions(ed[k]), e0[k] = apis[k].events(ed[k]);
	for (int p = 0; p < pairs; p++) {
		double per[2];
		for (int q = 0; q < 2; q++) {
			int k = (p & 1) ? 1 - q : q;
			uint64_t c = apis[k].collisions(ed[k]);
			double t0 = cpu_now();
			apis[k].advance(ed[k], INFINITY, c + (uint64_t)(seg * n / 2), UINT64_MAX);
			double dt = cpu_now() - t0;
			per[k] = dt / (double)(apis[k].collisions(ed[k]) - c);
			tot[k] += dt;
		}
		ratio[p] = per[0] / per[1];
	}
	double sorted[1000];
	memcpy(sorted, ratio, pairs * sizeof(double));
	qsort(sorted, pairs, sizeof(double), cmp);
	double med = pairs & 1 ? sorted[pairs / 2] : 0.5 * (sorted[pairs / 2 - 1] + sorted[pairs / 2]);
	double ev[2];
	for (int k = 0; k < 2; k++)
		ev[k] = (double)(apis[k].events(ed[k]) - e0[k]) / (double)(apis[k].collisions(ed[k]) - c0[k]);
	printf("ed_pair %d %ld %g %g %g %g %d: speed new/old median %.3f (min %.3f max %.3f) over %d pairs; "
	       "old %.3g new %.3g coll/s (cpu, totals); events/coll old %.3f new %.3f\n",
	       dim, n, phi, e, warm, seg, pairs, med, sorted[0], sorted[pairs - 1], pairs,
	       (apis[0].collisions(ed[0]) - c0[0]) / tot[0], (apis[1].collisions(ed[1]) - c0[1]) / tot[1], ev[0], ev[1]);
	for (int k = 0; k < 2; k++)
		apis[k].destroy(ed[k]);
	return 0;
}
