/* Tests of a reservoir wall's gas ("gas": "hard_spheres" against the default "ideal"): the density the box holds at rest and in a stream, 2D and 3D, against the requested volume fraction. */
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "ed/ed.h"
#include "scene.h"
#include "tap.h"
#include "stats.h"
#include "ed_util.h"

#ifndef M_PI
#define M_PI 3.14159265358979323846
#endif

/* Blocks: K blocks of S snapshots each, tb time units long, after a
 * relaxation of t0. A block spans several diffusion times of the density
 * across the bulk slab (L^2 / D with D ~ mean free path x thermal speed),
 * so the K block means count as independent (the test of the ideal gas
 * against its theory below checks that the standard errors are sound). */
typedef struct {
	const char *name;
	int dim;
	double eta;            /* the reservoirs' volume fraction */
	double box[3];
	double u, kT;          /* the reservoirs' velocity along x, temperature */
	int stream;            /* 1: reservoirs at both ends of x; 0: a reservoir at the lower end, a specular wall at the upper */
	double margin;         /* the bulk: centres farther than this from the accessible ends [r, L_x - r] */
	double t0, tb;
	int K, S;
	unsigned seed;
} case_t;

/* The measured number density in the bulk: mean and standard error of K
 * block means. 0 on failure (a TAP diagnostic says why). */
static int bulk_density(const case_t *c, const char *gas, double *mean, double *se, double *ux)
{
	char json[2048], wall[512], box[128];
	const double r = 0.5, vp = c->dim == 2 ? M_PI * r * r : 4.0 / 3.0 * M_PI * r * r * r;
	double vol = 1.0;
	for (int a = 0; a < c->dim; a++)
		vol *= c->box[a];
	const long count = lround(c->eta * vol / vp);   /* start near the requested density */
	snprintf(wall, sizeof wall, "{\"type\":\"reservoir\",\"volume_fraction\":%.17g,\"velocity\":[%.17g,0%s],"
	         "\"temperature\":%.17g,\"gas\":\"%s\"}", c->eta, c->u, c->dim == 3 ? ",0" : "", c->kT, gas);
	if (c->dim == 2)
		snprintf(box, sizeof box, "[%.17g,%.17g]", c->box[0], c->box[1]);
	else
		snprintf(box, sizeof box, "[%.17g,%.17g,%.17g]", c->box[0], c->box[1], c->box[2]);
	snprintf(json, sizeof json, "{\"method\":\"ed\",\"dimensions\":%d,\"particles\":{\"count\":%ld,\"box\":%s,"
	         "\"initial\":{\"positions\":\"random\",\"temperature\":%.17g,\"velocity\":[%.17g,0%s]}},"
	         "\"boundaries\":{\"x\":{\"type\":\"walls\",\"lower\":%s,\"upper\":%s}},"
	         "\"run\":{\"seed\":%u,\"until\":{\"time\":1}}}",
	         c->dim, count, box, c->kT, c->u, c->dim == 3 ? ",0" : "", wall,
	         c->stream ? wall : "{\"type\":\"specular\"}", c->seed);
	scene_t sc;
	ed_t *ed = make(json, &sc);
	if (!ed)
		return 0;
	const uint32_t N = ed_slots(ed);
	const int D = c->dim;
	double *pos = malloc(sizeof(double) * D * N), *vel = malloc(sizeof(double) * D * N);
	double *nb = malloc(sizeof(double) * c->K), *ub = malloc(sizeof(double) * c->K);
	const double lo = r + c->margin, hi = c->box[0] - r - c->margin;
	double bulk = hi - lo;
	for (int a = 1; a < D; a++)
		bulk *= c->box[a];
	int good = pos && vel && nb && ub && ed_advance(ed, c->t0, UINT64_MAX, UINT64_MAX) == ED_OK;
	for (int k = 0; k < c->K && good; k++) {
		double cnt = 0.0, sx = 0.0, np = 0.0;
		for (int j = 1; j <= c->S && good; j++) {
			good = ed_advance(ed, c->t0 + k * c->tb + j * c->tb / c->S, UINT64_MAX, UINT64_MAX) == ED_OK;
			ed_state(ed, pos, vel);
			for (uint32_t i = 0; i < N; i++) {
				const double x = pos[(size_t)D * i];
				if (isnan(x) || x < lo || x > hi)
					continue;   /* an empty slot, or outside the bulk */
				cnt += 1.0;
				sx += vel[(size_t)D * i];
				np += 1.0;
			}
		}
		nb[k] = cnt / c->S / bulk;
		ub[k] = np > 0.0 ? sx / np : 0.0;
	}
	if (good) {
		double us;
		mean_se(nb, c->K, mean, se);
		mean_se(ub, c->K, ux, &us);
	} else {
		diag("%s (%s): the run failed", c->name, gas);
	}
	free(pos);
	free(vel);
	free(nb);
	free(ub);
	ed_destroy(ed);
	return good;
}

/* exp(beta mu_ex) of the hard-disk / hard-sphere fluid at eta, by
 * numerical integration of beta mu_ex = int_0^eta (Z - 1) / x dx + Z - 1
 * (Simpson, independent of the engine's closed form), Z from Henderson
 * (2D) or Carnahan-Starling (3D). */
static double zeta(int dim, double x)
{
	const double q = 1.0 - x;
	return dim == 2 ? (1.0 + x * x / 8.0) / (q * q) : (1.0 + x + x * x - x * x * x) / (q * q * q);
}

static double activity(int dim, double eta)
{
	const int n = 2000;
	const double h = eta / n;
	double s = 0.0;
	for (int i = 0; i <= n; i++) {
		const double x = i * h, w = (i == 0 || i == n) ? 1.0 : (i & 1) ? 4.0 : 2.0;
		/* (Z - 1) / x at x = 0: its limit, B_2 n / eta = 2 (2D), 4 (3D) */
		const double f = i == 0 ? (dim == 2 ? 2.0 : 4.0) : (zeta(dim, x) - 1.0) / x;
		s += w * f;
	}
	return exp(s * h / 3.0 + zeta(dim, eta) - 1.0);
}

/* The ideal-gas reservoir's box density: the n solving n = n_res / activity(n) (the grand-canonical
 * density at the reservoir's activity n_res), by fixed-point iteration. */
static double ideal_box_density(int dim, double eta)
{
	double e = eta;
	for (int k = 0; k < 200; k++)
		e = eta / activity(dim, e);
	return e;
}

/* One case: with gas "hard_spheres" the bulk density is the requested n =
 * eta / v_p within 5 standard errors of the block means; with the default
 * ideal gas it is measurably off (more than 5 standard errors below n) and,
 * at rest, the grand-canonical density of the activity n_res within 5
 * standard errors. In a stream the rest's theory is not exact (the density
 * runs 1-2% above it with either gas, docs/engine.md): the stream's ideal
 * case is only checked to be off. */
static void run_case(const case_t *c)
{
	const double r = 0.5, vp = c->dim == 2 ? M_PI * r * r : 4.0 / 3.0 * M_PI * r * r * r, n = c->eta / vp;
	double mh, sh, uh, mi, si, ui;
	if (!bulk_density(c, "hard_spheres", &mh, &sh, &uh) || !bulk_density(c, "ideal", &mi, &si, &ui)) {
		ok(0, "%s: gas hard_spheres holds the requested density", c->name);
		ok(0, "%s: gas ideal is off", c->name);
		return;
	}
	ok(fabs(mh - n) < 5.0 * sh, "%s: gas hard_spheres: bulk n = %.5f +- %.5f (%d blocks of %g), requested %.5f "
	   "(ratio %.4f), u_x = %.5f", c->name, mh, sh, c->K, c->tb, n, mh / n, uh);
	const double want = ideal_box_density(c->dim, c->eta) / vp;
	ok(n - mi > 5.0 * si && (c->stream || fabs(mi - want) < 5.0 * si),
	   "%s: gas ideal: bulk n = %.5f +- %.5f (ratio %.4f to the requested), grand-canonical theory %.5f%s, u_x = %.5f",
	   c->name, mi, si, mi / n, want, c->stream ? " (not tested in a stream)" : "", ui);
}

int main(void)
{
	/* blocks: at rest 2D eta 0.04, the slab 22 wide, D ~ 4: L^2 / D ~ 120 < tb = 200; eta 0.15, slab 16 wide, D ~
	 * 0.6: ~430 < 500; 3D eta 0.1, slab 8, D ~ 0.5: ~130 < 200; the stream, T = 0.02, 100 long: a block of
	 * 2000 is one channel transit (L / U) */
	static const case_t cases[] = {
		{ "rest, 2D, eta 0.04", 2, 0.04, { 30, 200, 0 }, 0.0, 1.0, 0, 4.0, 400.0, 200.0, 40, 20, 31 },
		{ "rest, 2D, eta 0.15", 2, 0.15, { 24, 100, 0 }, 0.0, 1.0, 0, 4.0, 1000.0, 500.0, 40, 25, 32 },
		{ "rest, 3D, eta 0.1", 3, 0.10, { 16, 10, 10 }, 0.0, 1.0, 0, 4.0, 400.0, 200.0, 40, 20, 33 },
		{ "stream, 2D, eta 0.04, U 0.05, kT 0.02", 2, 0.04, { 100, 50, 0 }, 0.05, 0.02, 1, 20.0, 4000.0, 2000.0, 40, 40, 34 },
	};
	const int nc = (int)(sizeof cases / sizeof cases[0]);
	plan(2 * nc);
	for (int k = 0; k < nc; k++)
		run_case(&cases[k]);
	return tap_failed ? 1 : 0;
}
