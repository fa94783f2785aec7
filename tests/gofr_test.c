/* Tests for engine/observe/gofr.c: pair counts and velocity sums against brute force, g(r) of an ideal gas, the contact fit, Enskog conversions. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "observe/gofr.h"
#include "obs_util.h"
#include "tap.h"

/* Brute force over all pairs with the same binning rule. */
static void brute(int dim, size_t n, const double *box, const double *pos, const double *vel, double r0, double r1,
                  int nb, double *count, double *par, double *perp)
{
	double mean[3] = {0, 0, 0};
	memset(count, 0, nb * sizeof(double));
	memset(par, 0, nb * sizeof(double));
	memset(perp, 0, nb * sizeof(double));
	for (size_t i = 0; i < n; i++)
		for (int a = 0; a < dim; a++)
			mean[a] += vel[i * dim + a] / n;
	for (size_t i = 0; i < n; i++)
		for (size_t j = i + 1; j < n; j++) {
			double d[3], r2 = 0;
			for (int a = 0; a < dim; a++) {
				d[a] = pos[i * dim + a] - pos[j * dim + a];
				d[a] -= box[a] * round(d[a] / box[a]);
				r2 += d[a] * d[a];
			}
			if (r2 >= r1 * r1 || r2 < r0 * r0)
				continue;
			double r = sqrt(r2);
			int k = (int)((r - r0) * (nb / (r1 - r0)));
			k = k >= nb ? nb - 1 : k;
			count[k]++;
			double pi = 0, pj = 0, dot = 0;
			for (int a = 0; a < dim; a++) {
				double wi = vel[i * dim + a] - mean[a], wj = vel[j * dim + a] - mean[a];
				pi += wi * d[a], pj += wj * d[a], dot += wi * wj;
			}
			par[k] += pi * pj / r2;
			perp[k] += dot - pi * pj / r2;
		}
}

/* Every count equal to brute force; velocity sums to 1e-9 of their scale. */
static void test_brute(int dim, size_t n, const double *box, double r1, const char *what)
{
	enum { NB = 37 };
	uint64_t seed = 5 + dim;
	double *pos = malloc(n * dim * sizeof(double)), *vel = malloc(n * dim * sizeof(double));
	random_positions(dim, n, box, &seed, pos);
	for (size_t i = 0; i < n * dim; i++)
		vel[i] = gauss(&seed) + 0.3;
	/* a few positions outside [0, L): the engine's positions are folded, but the API accepts any */
	pos[0] += box[0];
	pos[1] -= 3 * box[1];
	double c[NB], p[NB], q[NB], bc[NB], bp[NB], bq[NB];
	gofr_t *g = gofr_create(dim, n, box, r1);
	int rc = gofr_pairs(g, pos, vel, 0.25, r1, NB, c, p, q);
	brute(dim, n, box, pos, vel, 0.25, r1, NB, bc, bp, bq);
	int same = rc == 0, close = 1;
	double total = 0;
	for (int k = 0; k < NB; k++) {
		same &= c[k] == bc[k];
		close &= fabs(p[k] - bp[k]) <= 1e-9 * (1 + fabs(bp[k])) && fabs(q[k] - bq[k]) <= 1e-9 * (1 + fabs(bq[k]));
		total += c[k];
	}
	ok(same, "%s: pair counts equal brute force (%.0f pairs)", what, total);
	ok(close, "%s: velocity pair sums equal brute force", what);
	/* without velocities: the same counts */
	rc = gofr_pairs(g, pos, NULL, 0.25, r1, NB, c, NULL, NULL);
	same = rc == 0;
	for (int k = 0; k < NB; k++)
		same &= c[k] == bc[k];
	ok(same, "%s: counts without velocities the same", what);
	gofr_destroy(g);
	free(pos);
	free(vel);
}

/*
 * Ideal gas (uniform random points): g(r) = 1. Each bin's count is
 * binomial with mean = the ideal count, so |count - ideal| < 5 sqrt(ideal)
 * per bin (40 bins: a false failure has probability ~2e-5); the contact fit
 * on [1, 1.1) gives 1 within 5 of its standard errors.
 */
static void test_ideal(int dim, size_t n, const double *box)
{
	enum { NB = 40 };
	uint64_t seed = 77 + dim;
	double *pos = malloc(n * dim * sizeof(double)), c[NB], vol = box[0] * box[1] * (dim == 3 ? box[2] : 1);
	random_positions(dim, n, box, &seed, pos);
	gofr_t *g = gofr_create(dim, n, box, 4.0);
	gofr_pairs(g, pos, NULL, 0, 4.0, NB, c, NULL, NULL);
	int bad = 0;
	for (int k = 0; k < NB; k++) {
		double e = gofr_ideal(dim, n, vol, 0.1 * k, 0.1 * (k + 1));
		bad += fabs(c[k] - e) > 5 * sqrt(e);
	}
	ok(bad == 0, "%dD ideal gas, N=%zu: g(r) = 1 in all %d bins within 5 sigma (%d off)", dim, n, NB, bad);
	gofr_contact_t gc;
	int rc = gofr_contact(g, pos, 1.0, &gc);
	ok(rc == 0 && fabs(gc.value - 1) < 5 * gc.se, "%dD ideal gas: contact fit g(1) = %.4f +- %.4f (%.0f pairs)", dim,
	   gc.value, gc.se, gc.pairs);
	gofr_destroy(g);
	free(pos);
}

/* The fit recovers an exactly exponential g(r) near contact. */
static void test_fit(void)
{
	double count[GOFR_CONTACT_BINS], sigma = 2.0, width = sigma * GOFR_CONTACT_WIDTH / GOFR_CONTACT_BINS, vol = 1e6;
	for (int k = 0; k < GOFR_CONTACT_BINS; k++) {
		double a = sigma + k * width, b = a + width, x = 0.5 * (a + b) - sigma;
		count[k] = gofr_ideal(3, 100000, vol, a, b) * 2.3 * exp(-1.7 * x);
	}
	gofr_contact_t gc;
	int rc = gofr_contact_fit(3, 100000, vol, sigma, width, GOFR_CONTACT_BINS, count, &gc);
	ok(rc == 0 && fabs(gc.value - 2.3) < 1e-12, "contact fit of g = 2.3 exp(-1.7 (r - sigma)): %.15f", gc.value);
	double few[GOFR_CONTACT_BINS] = {3, 0, 0, 0, 0, 0, 0, 0, 0, 2};
	rc = gofr_contact_fit(3, 100000, vol, sigma, width, GOFR_CONTACT_BINS, few, &gc);
	ok(rc == -1 && isnan(gc.value), "contact fit with pairs in only 2 bins: NaN");
}

/* Enskog conversions against the seed 003 anchors (a = m = T = 1): f_E =
 * 3.51 (3D) and 0.893 (2D) at nu = 0.25, Z = 3.074 (3D), 1.792 (2D): the
 * contact values must be Carnahan-Starling's 2.0741 and Henderson's 1.5833
 * to the digits given. */
static void test_enskog(void)
{
	double g3 = (1 - 0.125) / pow(0.75, 3), g2 = (1 - 7 * 0.25 / 16) / (0.75 * 0.75);
	ok(fabs(gofr_contact_rate(3, 0.25, 1, 1, 1, 3.51) / g3 - 1) < 2e-3 &&
	   fabs(gofr_contact_rate(2, 0.25, 1, 1, 1, 0.893) / g2 - 1) < 2e-3,
	   "rate -> g: %.4f (CS %.4f), %.4f (Henderson %.4f)", gofr_contact_rate(3, 0.25, 1, 1, 1, 3.51), g3,
	   gofr_contact_rate(2, 0.25, 1, 1, 1, 0.893), g2);
	ok(fabs(gofr_contact_virial(3, 0.25, 1, 3.074) / g3 - 1) < 2e-3 &&
	   fabs(gofr_contact_virial(2, 0.25, 1, 1.792) / g2 - 1) < 2e-3,
	   "virial -> g: %.4f, %.4f", gofr_contact_virial(3, 0.25, 1, 3.074), gofr_contact_virial(2, 0.25, 1, 1.792));
	/* rate scales as sqrt(T/m), the virial term as (1+e)/2 */
	ok(fabs(gofr_contact_rate(3, 0.25, 1, 4, 9, 3.51 * 1.5) / g3 - 1) < 2e-3 &&
	   fabs(gofr_contact_virial(3, 0.25, 0.5, 1 + 0.75 * 2.074) - 2.074) < 1e-12, "T/m and restitution scaling");
}

int main(void)
{
	plan(18);
	double b2[3] = {20, 17, 1}, b3[3] = {9, 11, 10}, tiny[3] = {5, 6, 5.5};
	test_brute(2, 1500, b2, 3.0, "2D, 6x5 cells");
	test_brute(3, 1500, b3, 3.0, "3D, 3x3x3 cells");
	test_brute(3, 300, tiny, 2.7, "3D, 2x2x2 cells (cutoff near half the box)");
	double i2[3] = {60, 60, 1}, i3[3] = {25, 25, 25};
	test_ideal(2, 20000, i2);
	test_ideal(3, 20000, i3);
	test_fit();
	test_enskog();
	return done_testing();
}
