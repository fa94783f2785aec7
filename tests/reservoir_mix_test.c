/* Tests of a mixture's hard-sphere reservoir gas ("gas": "hard_spheres" with particles.species, 2D and 3D): the partial densities the box holds at rest against the requested ones, and the ideal gas's against its grand-canonical theory. */
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

/* A binary mixture at rest between two equal reservoir walls on x (the
 * other axes periodic), T = 1, masses proportional to the particle volume.
 * Reservoir: number fractions x_k (its composition), total volume fraction
 * eta, so partial number densities n_k = x_k eta / v, v = sum_k x_k v_k.
 * Statistics: K blocks of S snapshots, tb time units each, after t0; the
 * bulk is the centres of species k farther than margin from its accessible
 * ends [a_k, L_x - a_k]. A block spans several diffusion times of the
 * density across the bulk slab (L^2 / (pi^2 D) with D ~ 1 at these
 * densities: ~25 in 2D, ~7 in 3D, blocks of 100 and 50), so the block means
 * count as independent. */
typedef struct {
	const char *name;
	int dim;
	double eta, a[2], x[2];
	double box[3];
	double margin, t0, tb;
	int K, S;
	unsigned seed;
} mcase_t;

static double pvol(int dim, double a)
{
	return dim == 2 ? M_PI * a * a : 4.0 / 3.0 * M_PI * a * a * a;
}

/* The requested partial densities n_k = x_k eta / v. */
static void requested(const mcase_t *c, double *n)
{
	const double v = c->x[0] * pvol(c->dim, c->a[0]) + c->x[1] * pvol(c->dim, c->a[1]);
	for (int k = 0; k < 2; k++)
		n[k] = c->x[k] * c->eta / v;
}

/* The bulk partial densities with gas `gas` over K blocks: mean and standard
 * error of the block means per species. 0 on failure (a TAP diagnostic). */
static int bulk_partial(const mcase_t *c, const char *gas, int K, double *mean, double *se)
{
	char json[2048], wall[512], box[128], sp[2][160];
	double n[2], vol = 1.0;
	requested(c, n);
	for (int a = 0; a < c->dim; a++)
		vol *= c->box[a];
	for (int k = 0; k < 2; k++)   /* start near the requested densities */
		snprintf(sp[k], sizeof sp[k], "{\"name\":\"%c\",\"count\":%ld,\"radius\":%.17g,\"mass\":%.17g}", 'A' + k,
		         lround(n[k] * vol), c->a[k], pvol(c->dim, c->a[k]) / pvol(c->dim, c->a[0]));
	snprintf(wall, sizeof wall, "{\"type\":\"reservoir\",\"volume_fraction\":%.17g,\"temperature\":1,"
	         "\"composition\":[%.17g,%.17g],\"gas\":\"%s\"}", c->eta, c->x[0], c->x[1], gas);
	if (c->dim == 2)
		snprintf(box, sizeof box, "[%.17g,%.17g]", c->box[0], c->box[1]);
	else
		snprintf(box, sizeof box, "[%.17g,%.17g,%.17g]", c->box[0], c->box[1], c->box[2]);
	snprintf(json, sizeof json, "{\"method\":\"ed\",\"dimensions\":%d,\"particles\":{\"species\":[%s,%s],\"box\":%s,"
	         "\"initial\":{\"positions\":\"random\",\"temperature\":1}},"
	         "\"boundaries\":{\"x\":{\"type\":\"walls\",\"lower\":%s,\"upper\":%s}},"
	         "\"run\":{\"seed\":%u,\"until\":{\"time\":1}}}", c->dim, sp[0], sp[1], box, wall, wall, c->seed);
	scene_t sc;
	ed_t *ed = make(json, &sc);
	if (!ed)
		return 0;
	const uint32_t N = ed_slots(ed);
	const int D = c->dim;
	double *pos = malloc(sizeof(double) * D * N), *vel = malloc(sizeof(double) * D * N);
	double *nb = malloc(sizeof(double) * 2 * K);
	uint8_t *row = malloc(N);
	double bulk[2];
	for (int k = 0; k < 2; k++) {
		bulk[k] = c->box[0] - 2.0 * (c->a[k] + c->margin);
		for (int a = 1; a < D; a++)
			bulk[k] *= c->box[a];
	}
	int good = pos && vel && nb && row && ed_advance(ed, c->t0, UINT64_MAX, UINT64_MAX) == ED_OK;
	if (good)
		scene_row_species(&sc, row, NULL);
	for (int b = 0; b < K && good; b++) {
		double cnt[2] = { 0.0, 0.0 };
		for (int j = 1; j <= c->S && good; j++) {
			good = ed_advance(ed, c->t0 + b * c->tb + j * c->tb / c->S, UINT64_MAX, UINT64_MAX) == ED_OK;
			ed_state(ed, pos, vel);
			for (uint32_t i = 0; i < N; i++) {
				const double x = pos[(size_t)D * i], lo = c->a[row[i]] + c->margin;
				if (isnan(x) || x < lo || x > c->box[0] - lo)
					continue;   /* an empty slot, or outside the bulk */
				cnt[row[i]] += 1.0;
			}
		}
		for (int k = 0; k < 2; k++)
			nb[k * K + b] = cnt[k] / c->S / bulk[k];
	}
	if (good)
		for (int k = 0; k < 2; k++) {
			mean_se(nb + k * K, K, &mean[k], &se[k]);
			/* the blocks' independence: the standard error of the K / 2 means of pairs of blocks */
			double pm, ps;
			for (int b = 0; b + 1 < K; b += 2)
				nb[k * K + b / 2] = 0.5 * (nb[k * K + b] + nb[k * K + b + 1]);
			mean_se(nb + k * K, K / 2, &pm, &ps);
			diag("%s (%s), species %c: standard error %.5f over %d blocks, %.5f over %d pairs of blocks", c->name,
			     gas, 'A' + k, se[k], K, ps, K / 2);
		}
	else
		diag("%s (%s): the run failed", c->name, gas);
	free(pos);
	free(vel);
	free(nb);
	free(row);
	ed_destroy(ed);
	return good;
}

/* The theory, independent of the engine's closed forms: the mixture's
 * compressibility factor Z(eta) at fixed composition -- 3D BMCSL, Z =
 * 1/(1 - xi_3) + 3 xi_1 xi_2 / (xi_0 (1 - xi_3)^2) + (3 - xi_3) xi_2^3 /
 * (xi_0 (1 - xi_3)^3), xi_m = (pi/6) sum n_j s_j^m; 2D Santos-Yuste-Lopez
 * de Haro, Z = 1/(1 - eta) + (<s>^2/<s^2>) [Z_H - 1/(1 - eta)], Z_H
 * Henderson's -- integrated numerically over density (Simpson) to the
 * excess free energy per particle a = int_0^eta (Z - 1)/t dt, and beta
 * mu_ex,k = d(n a)/dn_k by central differences. */
static double mix_z(int dim, double t, double R1, double R2)
{
	const double q = 1.0 - t;
	if (dim == 2)   /* R1 = <s>^2 / <s^2> */
		return 1.0 / q + R1 * ((1.0 + t * t / 8.0) / (q * q) - 1.0 / q);
	/* R1 = xi_1 xi_2 / (xi_0 xi_3), R2 = xi_2^3 / (xi_0 xi_3^2): ratios fixed by the composition */
	return 1.0 / q + 3.0 * R1 * t / (q * q) + (3.0 - t) * R2 * t * t / (q * q * q);
}

static double mix_free(int dim, const double *n, const double *a)
{
	double m[4] = { 0.0, 0.0, 0.0, 0.0 };
	for (int k = 0; k < 2; k++)
		for (int p = 0; p < 4; p++)
			m[p] += n[k] * pow(2.0 * a[k], p);
	double eta, R1, R2 = 0.0;
	if (dim == 2) {
		eta = M_PI / 4.0 * m[2];
		R1 = m[1] * m[1] / (m[0] * m[2]);
	} else {
		eta = M_PI / 6.0 * m[3];
		R1 = m[1] * m[2] / (m[0] * m[3]);
		R2 = m[2] * m[2] * m[2] / (m[0] * m[3] * m[3]);
	}
	const int steps = 2000;
	const double h = eta / steps;
	double s = 0.0;
	for (int i = 0; i <= steps; i++) {
		const double t = i * h, w = (i == 0 || i == steps) ? 1.0 : (i & 1) ? 4.0 : 2.0;
		/* (Z - 1)/t at t = 0: its limit, B_2 n / eta */
		const double f = i == 0 ? (dim == 2 ? 1.0 + R1 : 1.0 + 3.0 * R1) : (mix_z(dim, t, R1, R2) - 1.0) / t;
		s += w * f;
	}
	return m[0] * s * h / 3.0;
}

static void mix_mu(int dim, const double *n, const double *a, double *mu)
{
	for (int k = 0; k < 2; k++) {
		double p[2] = { n[0], n[1] }, m[2] = { n[0], n[1] };
		const double h = 1e-4 * n[k];
		p[k] += h;
		m[k] -= h;
		mu[k] = (mix_free(dim, p, a) - mix_free(dim, m, a)) / (2.0 * h);
	}
}

/* The box's partial densities in grand-canonical equilibrium with
 * activities z_k: n_k exp(beta mu_ex,k(n)) = z_k, by damped fixed-point
 * iteration. */
static void box_densities(int dim, const double *z, const double *a, double *n)
{
	n[0] = z[0], n[1] = z[1];
	for (int it = 0; it < 400; it++) {
		double mu[2];
		mix_mu(dim, n, a, mu);
		for (int k = 0; k < 2; k++)
			n[k] = 0.5 * n[k] + 0.5 * z[k] * exp(-mu[k]);
	}
}

/* One case: with gas "hard_spheres" each species' bulk density is the
 * requested n_k within 5 standard errors of the block means; with the ideal
 * gas (K / 4 blocks) each is more than 5 standard errors below n_k, and
 * within 5 of the grand-canonical density at activities z_k = n_k (what an
 * ideal-gas reservoir inserts at). */
static void run_case(const mcase_t *c)
{
	double n[2], mh[2], sh[2], mi[2], si[2], want[2];
	requested(c, n);
	box_densities(c->dim, n, c->a, want);
	if (!bulk_partial(c, "hard_spheres", c->K, mh, sh) || !bulk_partial(c, "ideal", c->K / 4, mi, si)) {
		for (int k = 0; k < 2; k++) {
			ok(0, "%s: gas hard_spheres holds species %c's density", c->name, 'A' + k);
			ok(0, "%s: gas ideal misses species %c's density", c->name, 'A' + k);
		}
		return;
	}
	for (int k = 0; k < 2; k++) {
		ok(fabs(mh[k] - n[k]) < 5.0 * sh[k], "%s: gas hard_spheres: species %c (radius %g): bulk n = %.5f +- %.5f "
		   "(%d blocks of %g), requested %.5f (ratio %.4f +- %.4f)", c->name, 'A' + k, c->a[k], mh[k], sh[k], c->K,
		   c->tb, n[k], mh[k] / n[k], sh[k] / n[k]);
		ok(n[k] - mi[k] > 5.0 * si[k] && fabs(mi[k] - want[k]) < 5.0 * si[k],
		   "%s: gas ideal: species %c: bulk n = %.5f +- %.5f (ratio %.4f +- %.4f to the requested), "
		   "grand-canonical theory %.5f (ratio %.4f)", c->name, 'A' + k, mi[k], si[k], mi[k] / n[k], si[k] / n[k],
		   want[k], want[k] / n[k]);
	}
}

int main(void)
{
	static const mcase_t cases[] = {
		{ "rest, 2D, eta 0.12, radii 0.5 and 0.25, x_B 0.5", 2, 0.12, { 0.5, 0.25 }, { 0.5, 0.5 }, { 24, 60, 0 },
		  4.0, 100.0, 100.0, 400, 20, 41 },
		{ "rest, 3D, eta 0.1, radii 0.5 and 0.3, x_B 0.4", 3, 0.10, { 0.5, 0.3 }, { 0.6, 0.4 }, { 16, 8, 8 },
		  4.0, 50.0, 50.0, 400, 10, 42 },
	};
	const int nc = (int)(sizeof cases / sizeof cases[0]);
	plan(4 * nc);
	for (int k = 0; k < nc; k++)
		run_case(&cases[k]);
	return tap_failed ? 1 : 0;
}
