/* State digests of a few dsmc/hsmc gases after some steps: checks that a speed change leaves trajectories bit-identical. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "mc/dsmc.h"
#include "scene.h"

static uint64_t fnv(uint64_t h, const void *p, size_t n)
{
	const unsigned char *c = p;
	for (size_t i = 0; i < n; i++) {
		h ^= c[i];
		h *= 1099511628211ULL;
	}
	return h;
}

/* usage: dsmc_digest [STEPS]  (default 60). One line per gas: method, dimension,
 * correction, FNV-1a of the positions and velocities in particle order,
 * collisions, candidates, time. Compare the output of two builds with diff. */
int main(int argc, char **argv)
{
	static const char *cases[][6] = {
		{"dsmc", "3", "20000", "0.05", "1", "none"}, {"dsmc", "3", "20000", "0.25", "0.9", "enskog"},
		{"dsmc", "2", "20000", "0.05", "0.9", "none"}, {"hsmc", "3", "20000", "0.25", "0.9", "cba"},
		{"hsmc", "2", "20000", "0.4", "0.9", "cba"}, {"dsmc", "3", "20000", "0.3", "0.8", "cba"},
	};
	long steps = argc > 1 ? atol(argv[1]) : 60;
	int ret = 0;
	for (size_t c = 0; c < sizeof cases / sizeof cases[0]; c++) {
		char json[512], err[512];
		int rc;
		scene_t sc;
		snprintf(json, sizeof json,
		         "{\"method\":\"%s\",\"dimensions\":%s,\"particles\":{\"count\":%s,\"volume_fraction\":%s,"
		         "\"initial\":{\"positions\":\"random\"}},\"collisions\":{\"restitution\":%s},"
		         "\"run\":{\"until\":{\"time\":1}},\"%s\":{\"correction\":\"%s\"}}",
		         cases[c][0], cases[c][1], cases[c][2], cases[c][3], cases[c][4], cases[c][0], cases[c][5]);
		if (scene_parse(json, strlen(json), &sc, err, sizeof err) != SCENE_OK) {
			fprintf(stderr, "%s\n", err);
			return 2;
		}
		dsmc_t *d = dsmc_create(&sc, 0, &rc, err, sizeof err);
		if (!d) {
			fprintf(stderr, "%s\n", err);
			return 1;
		}
		dsmc_advance(d, INFINITY, UINT64_MAX, (uint64_t)steps);
		size_t n = (size_t)atol(cases[c][2]) * (size_t)atoi(cases[c][1]);
		double *x = malloc(n * sizeof(double)), *v = malloc(n * sizeof(double));
		if (x && v) {
			dsmc_state(d, x, v);
			dsmc_sample_t s;
			dsmc_totals(d, &s);
			uint64_t h = fnv(fnv(1469598103934665603ULL, x, n * sizeof(double)), v, n * sizeof(double));
			printf("%s %sD %s: %016llx coll %llu cand %llu t %.17g\n", cases[c][0], cases[c][1], cases[c][5],
			       (unsigned long long)h, (unsigned long long)s.collisions, (unsigned long long)s.candidates, s.time);
		} else {
			ret = 1;
		}
		free(x);
		free(v);
		dsmc_destroy(d);
	}
	return ret;
}
