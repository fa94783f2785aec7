/* Shared by the physics tests: run a scene into a series of records, and kinetic-theory formulas written independently of the engine. */
#pragma once

#include <math.h>
#include <string.h>
#include "run.h"
#include "scene.h"
#include "tap.h"

#define PI 3.14159265358979323846

/* Records of one run, collected through the same run_scene()/emit path the
 * engine program uses, so the tested numbers are the ones users see. */
typedef struct {
	int n;
	run_record_t rec[4096];
} series_t;

static int collect(const run_record_t *r, void *ctx)
{
	series_t *s = ctx;
	if (r->kind == RUN_PROGRESS && s->n < 4096)
		s->rec[s->n++] = *r;
	return 0;
}

static inline int run_json(const char *json, series_t *out)
{
	scene_t sc;
	char err[512];
	out->n = 0;
	if (scene_parse(json, strlen(json), &sc, err, sizeof(err)) != SCENE_OK) {
		diag("scene rejected: %s", err);
		return -1;
	}
	if (run_scene(&sc, collect, out, NULL, err, sizeof(err)) != RUN_OK) {
		diag("run failed: %s", err);
		return -1;
	}
	return 0;
}

/* Contact value of the pair correlation: Henderson (2D), Carnahan-Starling (3D). */
static inline double g_contact(int dim, double nu)
{
	return dim == 2 ? (1 - 7 * nu / 16) / ((1 - nu) * (1 - nu)) : (1 - nu / 2) / pow(1 - nu, 3);
}

/* Mean and standard error of n >= 2 samples. */
static inline void mean_se(const double *x, int n, double *mean, double *se)
{
	double s = 0, s2 = 0;
	for (int i = 0; i < n; i++)
		s += x[i];
	*mean = s / n;
	for (int i = 0; i < n; i++)
		s2 += (x[i] - *mean) * (x[i] - *mean);
	*se = sqrt(s2 / (n - 1) / n);
}

/* Haff's law T/T0 = 1/(1 + tau)^2, tau = rate t, against ratio[k * R + r]
 * (T/T0 of replica r at time t[k], K times): tolerance 4 standard errors of
 * the replica mean plus 1.5% of the theory (the callers' comments justify
 * both). Failing times go to diag(). Returns the worst deviation in units
 * of the tolerance: below 1 passes. */
static inline double haff_worst(int K, int R, const double *ratio, const double *t, double rate)
{
	double worst = 0;
	for (int k = 0; k < K; k++) {
		double m, se, tau = rate * t[k], th = 1 / ((1 + tau) * (1 + tau));
		mean_se(ratio + (size_t)k * R, R, &m, &se);
		double dev = fabs(m - th) / (4 * se + 0.015 * th);
		worst = dev > worst ? dev : worst;
		if (dev >= 1)
			diag("tau=%.3f: T/T0 = %.5f +- %.5f, Haff %.5f", tau, m, se, th);
	}
	return worst;
}
