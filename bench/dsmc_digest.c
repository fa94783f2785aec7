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
	/* the last column: more scene keys (bounded scenes: walls of the fixed kinds, gravity, obstacles) */
	static const char *const walls2 =
		",\"boundaries\":{\"x\":{\"type\":\"walls\",\"lower\":{\"type\":\"rough\",\"probability\":0.5},"
		"\"upper\":{\"type\":\"moving\",\"velocity\":[0,0.5]}},\"y\":{\"type\":\"walls\",\"lower\":{\"type\":"
		"\"thermal\",\"temperature\":2},\"upper\":{\"type\":\"specular\",\"restitution\":0.9}}},\"gravity\":[0.1,-1]";
	static const char *const walls3 =
		",\"boundaries\":{\"z\":{\"type\":\"walls\",\"lower\":{\"type\":\"thermal\",\"temperature\":2},"
		"\"upper\":{\"type\":\"specular\"}}},\"gravity\":[0,0,-1],"
		"\"obstacles\":[{\"type\":\"no_slip\",\"center\":[5,5,5],\"radius\":2,\"temperature\":0.5}]";
	static const char *const vib2 =
		",\"boundaries\":{\"y\":{\"type\":\"walls\",\"lower\":{\"type\":\"vibrating\",\"amplitude\":1,"
		"\"frequency\":0.2,\"restitution\":0.8},\"upper\":{\"type\":\"open\"}},\"x\":{\"type\":\"walls\","
		"\"lower\":{\"type\":\"thermal\",\"temperature\":1},\"upper\":{\"type\":\"specular\"}}},\"gravity\":[0,-0.5]";
	static const char *cases[][6] = {
		{"dsmc", "3", "20000", "0.05", "1", "none"}, {"dsmc", "3", "20000", "0.25", "0.9", "enskog"},
		{"dsmc", "2", "20000", "0.05", "0.9", "none"}, {"hsmc", "3", "20000", "0.25", "0.9", "cba"},
		{"hsmc", "2", "20000", "0.4", "0.9", "cba"}, {"dsmc", "3", "20000", "0.3", "0.8", "cba"},
		{"dsmc", "2", "20000", "0.05", "0.9", "none"}, {"dsmc", "2", "20000", "0.1", "0.9", "cba"},
		{"dsmc", "3", "20000", "0.05", "0.9", "none"}, {"dsmc", "2", "20000", "0.05", "0.9", "none"},
	};
	const char *extra[sizeof cases / sizeof cases[0]] = { [6] = walls2, [7] = walls2, [8] = walls3, [9] = vib2 };
	long steps = argc > 1 ? atol(argv[1]) : 60;
	int ret = 0;
	for (size_t c = 0; c < sizeof cases / sizeof cases[0]; c++) {
		char json[1536], err[512];
		int rc;
		scene_t sc;
		snprintf(json, sizeof json,
		         "{\"method\":\"%s\",\"dimensions\":%s,\"particles\":{\"count\":%s,\"volume_fraction\":%s,"
		         "\"initial\":{\"positions\":\"random\"}},\"collisions\":{\"restitution\":%s},"
		         "\"run\":{\"until\":{\"time\":1}},\"%s\":{\"correction\":\"%s\"}%s}",
		         cases[c][0], cases[c][1], cases[c][2], cases[c][3], cases[c][4], cases[c][0], cases[c][5],
		         extra[c] ? extra[c] : "");
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
			printf("%s %sD %s%s: %016llx coll %llu cand %llu t %.17g\n", cases[c][0], cases[c][1], cases[c][5],
			       extra[c] ? " bounded" : "", (unsigned long long)h, (unsigned long long)s.collisions, (unsigned long long)s.candidates, s.time);
		} else {
			ret = 1;
		}
		free(x);
		free(v);
		dsmc_destroy(d);
	}
	return ret;
}
