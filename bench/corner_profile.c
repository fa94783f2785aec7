/* The density and temperature of a diagonal stream fed by dispensers on two axes (2D), in squares along the diagonal from the inlets' corner and in the bulk (docs/engine.md, "Two-axis streams with filters"). */
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "ed/ed.h"
#include "scene.h"

#ifndef M_PI
#define M_PI 3.14159265358979323846
#endif

/* Squares [2q, 2q + 2)^2 for q < NQ - 1 and the bulk [8, 32)^2 (q = NQ - 1); NB blocks of one transit. */
enum { NQ = 9, NB = 10 };

static void mean_se(const double *x, int k, double *mean, double *se)
{
	double s = 0.0, s2 = 0.0;
	for (int i = 0; i < k; i++)
		s += x[i];
	*mean = s / k;
	for (int i = 0; i < k; i++)
		s2 += (x[i] - *mean) * (x[i] - *mean);
	*se = sqrt(s2 / (k - 1) / k);
}

/* usage: corner_profile ETA SEED. A 40 x 40 box of disks of radius 0.5, dispensers at x and y lower and
 * filters 4 from x and y upper, all at U = (0.1, 0.1), T = 0.02; 10 blocks of one transit (400) over t in
 * [800, 4800]. Prints per square eta and T (mean and SE over the blocks) and the least gap seen. */
int main(int argc, char **argv)
{
	if (argc != 3) {
		fprintf(stderr, "usage: %s ETA SEED\n", argv[0]);
		return 2;
	}
	const double L = 40.0, eta = atof(argv[1]);
	const int seed = atoi(argv[2]);
	const uint64_t count = (uint64_t)llround(eta * L * L / (M_PI * 0.25));
	char json[2048], err[512];
	snprintf(json, sizeof json,
	         "{\"method\":\"ed\",\"dimensions\":2,\"particles\":{\"count\":%llu,\"radius\":0.5,\"box\":[40,40],"
	         "\"capacity\":6000,\"initial\":{\"positions\":\"lattice\",\"temperature\":0.02,\"velocity\":[0.1,0.1],"
	         "\"relax\":{\"collisions_per_particle\":20}}},"
	         "\"boundaries\":{\"x\":{\"type\":\"walls\","
	         "\"lower\":{\"type\":\"dispenser\",\"volume_fraction\":%.17g,\"velocity\":[0.1,0.1],\"temperature\":0.02},"
	         "\"upper\":{\"type\":\"open\",\"filter\":{\"distance\":4,\"velocity\":[0.1,0.1],\"temperature\":0.02}}},"
	         "\"y\":{\"type\":\"walls\","
	         "\"lower\":{\"type\":\"dispenser\",\"volume_fraction\":%.17g,\"velocity\":[0.1,0.1],\"temperature\":0.02},"
	         "\"upper\":{\"type\":\"open\",\"filter\":{\"distance\":4,\"velocity\":[0.1,0.1],\"temperature\":0.02}}}},"
	         "\"run\":{\"seed\":%d,\"until\":{\"time\":1}}}",
	         (unsigned long long)count, eta, eta, seed);
	scene_t sc;
	int rc = 1;
	ed_t *ed = NULL;
	double *p = NULL, *v = NULL;
	if (scene_parse(json, strlen(json), &sc, err, sizeof err) != SCENE_OK) {
		fprintf(stderr, "scene: %s\n", err);
		goto done;
	}
	if (!(ed = ed_create(&sc, &rc, err, sizeof err))) {
		fprintf(stderr, "ed_create: %s\n", err);
		rc = 1;
		goto done;
	}
	rc = 1;
	const size_t N = ed_slots(ed);
	p = malloc(N * 2 * sizeof(double));
	v = malloc(N * 2 * sizeof(double));
	if (!p || !v)
		goto done;
	double eb[NQ][NB], Tb[NQ][NB], mg = INFINITY;
	const double t0 = 800.0, t1 = 4800.0, dt = 2.0;
	const int per = (int)((t1 - t0) / dt) / NB;
	for (int b = 0; b < NB; b++) {
		double c[NQ] = {0}, s1[NQ][2] = {{0}}, s2[NQ] = {0};
		for (int f = 0; f < per; f++) {
			if (ed_advance(ed, t0 + (b * per + f + 1) * dt, UINT64_MAX, UINT64_MAX) != ED_OK)
				goto done;
			ed_state(ed, p, v);
			const double g = ed_min_gap(ed);
			if (g < mg)
				mg = g;
			for (size_t i = 0; i < N; i++) {
				if (isnan(p[2 * i]))
					continue;
				const double x = p[2 * i], y = p[2 * i + 1];
				for (int q = 0; q < NQ; q++) {
					const double lo = q < NQ - 1 ? 2.0 * q : 8.0, hi = q < NQ - 1 ? lo + 2.0 : 32.0;
					if (x < lo || x >= hi || y < lo || y >= hi)
						continue;
					c[q] += 1.0;
					s1[q][0] += v[2 * i];
					s1[q][1] += v[2 * i + 1];
					s2[q] += v[2 * i] * v[2 * i] + v[2 * i + 1] * v[2 * i + 1];
				}
			}
		}
		for (int q = 0; q < NQ; q++) {
			const double area = q < NQ - 1 ? 4.0 : 576.0, ux = s1[q][0] / c[q], uy = s1[q][1] / c[q];
			eb[q][b] = c[q] / per * M_PI * 0.25 / area;
			Tb[q][b] = (s2[q] / c[q] - ux * ux - uy * uy) / 2.0;
		}
	}
	printf("# eta %g seed %d: least gap %.2g\n", eta, seed, mg);
	for (int q = 0; q < NQ; q++) {
		double me, se, mT, sT;
		mean_se(eb[q], NB, &me, &se);
		mean_se(Tb[q], NB, &mT, &sT);
		if (q < NQ - 1)
			printf("[%d, %d)^2  eta %.4f +- %.4f  T %.5f +- %.5f\n", 2 * q, 2 * q + 2, me, se, mT, sT);
		else
			printf("bulk [8, 32)^2  eta %.4f +- %.4f  T %.5f +- %.5f\n", me, se, mT, sT);
	}
	rc = 0;
done:
	free(p);
	free(v);
	ed_destroy(ed);
	return rc;
}
