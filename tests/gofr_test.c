/* Tests for engine/observe/gofr.c: pair counts and velocity sums against brute force, g(r) of an ideal gas, the contact fit, Enskog conversions. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "observe/gofr.h"
#include "obs_util.h"
#include "tap.h"

/* Brute force over all pairs with the same binning rule. */
static void brute(int dim, size_t n, const double *box, const int *walled, const double *pos, const double *vel,
                  double r0, double r1, int nb, double *count, double *par, double *perp)
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
				if (!walled[a])
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
	brute(dim, n, box, (const int[3]){0, 0, 0}, pos, vel, 0.25, r1, NB, bc, bp, bq);
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

/* Walled axes: plain differences (brute force with the same rule), positions not folded (a few beyond the
 * walls, as below a vibrating wall); a pair close only through the walled axis' image is not counted. */
static void test_brute_walled(int dim, size_t n, const double *box, const int *walled, double r1, const char *what)
{
	enum { NB = 29 };
	uint64_t seed = 15 + dim;
	double *pos = malloc(n * dim * sizeof(double)), *vel = malloc(n * dim * sizeof(double));
	random_positions(dim, n, box, &seed, pos);
	for (size_t i = 0; i < n * dim; i++)
		vel[i] = gauss(&seed);
	for (int a = 0; a < dim; a++)
		if (walled[a]) {
			pos[a] = -0.05 * box[a];
			pos[dim + a] = 1.05 * box[a];
		}
	double c[NB], p[NB], q[NB], bc[NB], bp[NB], bq[NB];
	gofr_t *g = gofr_create(dim, n, box, r1);
	int rc = gofr_walls(g, walled, 0.5) | gofr_pairs(g, pos, vel, 0.0, r1, NB, c, p, q);
	brute(dim, n, box, walled, pos, vel, 0.0, r1, NB, bc, bp, bq);
	int same = rc == 0, close = 1;
	double total = 0;
	for (int k = 0; k < NB; k++) {
		same &= c[k] == bc[k];
		close &= fabs(p[k] - bp[k]) <= 1e-9 * (1 + fabs(bp[k])) && fabs(q[k] - bq[k]) <= 1e-9 * (1 + fabs(bq[k]));
		total += c[k];
	}
	ok(same && close, "%s: pair counts and velocity sums equal brute force with plain differences (%.0f pairs)",
	   what, total);
	/* two particles 0.2 from opposite walls: 0.4 apart through the image, not counted */
	double two[6] = {0}, c2[NB];
	for (int a = 0; a < dim; a++)
		two[a] = two[dim + a] = 0.5 * box[a];
	for (int a = 0; a < dim; a++)
		if (walled[a]) {
			two[a] = 0.2;
			two[dim + a] = box[a] - 0.2;
			break;
		}
	gofr_t *g2 = gofr_create(dim, 2, box, r1);
	rc = gofr_walls(g2, walled, 0.0) | gofr_pairs(g2, two, NULL, 0.0, r1, NB, c2, NULL, NULL);
	total = 0;
	for (int k = 0; k < NB; k++)
		total += c2[k];
	ok(rc == 0 && total == 0, "%s: a pair across the walls (0.4 apart through the image) is not counted", what);
	gofr_destroy(g2);
	gofr_destroy(g);
	free(pos);
	free(vel);
}

/*
 * Ideal gas between walls: n uniform independent centres in the region they reach (radius 0.5 from each
 * wall), g(r) = 1 with the edge-corrected normalisation up to half the smallest edge, where the shell's
 * part inside the region is down to 1 - 2r/(pi L) = 0.67 (2D, one walled axis) or 1 - r/(2L) (3D): the
 * same 5 sigma per bin as test_ideal. The plain normalisation N(N-1)/2 v_shell/V(region) is also
 * counted against the same counts, to show that the test sees the edge (it must fail in most bins).
 */
static void test_ideal_walled(int dim, size_t n, const double *box, const int *walled, const char *what)
{
	enum { NB = 40 };
	uint64_t seed = 91 + dim;
	const double radius = 0.5;
	double *pos = malloc(n * dim * sizeof(double)), c[NB], inner[3], vol = 1, rmax = 1e300;
	for (int a = 0; a < dim; a++) {
		inner[a] = walled[a] ? box[a] - 2 * radius : box[a];
		vol *= inner[a];
		rmax = fmin(rmax, 0.5 * box[a]);
	}
	random_positions(dim, n, inner, &seed, pos);
	for (size_t i = 0; i < n; i++)
		for (int a = 0; a < dim; a++)
			pos[i * dim + a] += walled[a] ? radius : 0;
	gofr_t *g = gofr_create(dim, n, box, rmax);
	int rc = gofr_walls(g, walled, radius) | gofr_pairs(g, pos, NULL, 0, rmax, NB, c, NULL, NULL);
	int bad = 0, plain_bad = 0;
	double worst = 0;
	for (int k = 0; k < NB; k++) {
		double a = rmax * k / NB, b = rmax * (k + 1) / NB, e = gofr_ideal_in(g, a, b), e0 = gofr_ideal(dim, n, vol, a, b);
		bad += fabs(c[k] - e) > 5 * sqrt(e);
		plain_bad += fabs(c[k] - e0) > 5 * sqrt(e0);
		worst = fmax(worst, fabs(c[k] / e - 1));
	}
	ok(rc == 0 && bad == 0 && plain_bad > NB / 2, "%s, N=%zu: edge-corrected g(r) = 1 in all %d bins up to r = %g "
	   "within 5 sigma (%d off, largest |g-1| %.4f); without the correction %d bins off", what, n, NB, rmax, bad,
	   worst, plain_bad);
	gofr_contact_t gc;
	rc = gofr_contact(g, pos, 1.0, &gc);
	ok(rc == 0 && fabs(gc.value - 1) < 5 * gc.se, "%s: contact fit g(1) = %.4f +- %.4f (%.0f pairs)", what,
	   gc.value, gc.se, gc.pairs);
	gofr_destroy(g);
	free(pos);
}

/*
 * Obstacles (gofr_obstacles()): n uniform independent centres in the region they reach (outside each
 * obstacle's contact circle/sphere, inside the walls' region), by rejection, K independent configurations.
 * The pair counts of one configuration are not Poisson (pairs share points, and where a point sits near an
 * obstacle all its shells lose alike), so each bin's standard error is the spread over the K
 * configurations; to it adds the table's own relative error (about 2e-3: sqrt(F (1 - F) / M) at each radius
 * and the same for |A|, M ~ 2^18 points). Per bin the pooled count within 5 of those combined standard
 * errors; the walls-only normalisation of the same n (no obstacle) must be off in most bins, which shows
 * that the test sees the obstacle. Then rows that left (gofr_set_count() with a subset): the same on the
 * first n/2 rows. And the table's volume: the smallest shell's ideal count gives |A| = n(n-1)/2 v/ideal,
 * against the exact box minus the obstacles, within 4 binomial standard errors of the estimate
 * (sqrt(p (1 - p) / M) / p relative, p = |A| / |R|, M = 2^18 points).
 */
static int outside(int dim, const double *x, const double *box, const int *walled, int k, const double *oc,
                   const double *os)
{
	for (int j = 0; j < k; j++) {
		double d2 = 0;
		for (int a = 0; a < dim; a++) {
			double d = x[a] - oc[j * dim + a];
			if (!walled[a])
				d -= box[a] * round(d / box[a]);
			d2 += d * d;
		}
		if (d2 < os[j] * os[j])
			return 0;
	}
	return 1;
}

static void test_ideal_obstacles(int dim, size_t n, int K, const double *box, const int *walled, int k,
                                 const double *oc, const double *os, double exact_area, const char *what)
{
	enum { NB = 40 };
	uint64_t seed = 517 + dim + k;
	const double radius = 0.5;
	double rmax = 1e300, inner[3], *pos = malloc(n * dim * sizeof(double)), c[NB], tot[NB], tot2[NB], sq[NB],
	       sq2[NB];
	for (int a = 0; a < dim; a++) {
		inner[a] = walled[a] ? box[a] - 2 * radius : box[a];
		rmax = fmin(rmax, 0.5 * box[a]);
	}
	gofr_t *g = gofr_create(dim, n, box, rmax), *w = gofr_create(dim, n, box, rmax);
	int rc = gofr_walls(g, walled, radius) | gofr_walls(w, walled, radius) | gofr_obstacles(g, k, oc, os);
	memset(tot, 0, sizeof tot);
	memset(tot2, 0, sizeof tot2);
	memset(sq, 0, sizeof sq);
	memset(sq2, 0, sizeof sq2);
	for (int r = 0; r < K; r++) {
		for (size_t i = 0; i < n; i++) {
			double x[3];
			do {
				for (int a = 0; a < dim; a++)
					x[a] = uniform(&seed) * inner[a] + (walled[a] ? radius : 0);
			} while (!outside(dim, x, box, walled, k, oc, os));
			memcpy(pos + i * dim, x, dim * sizeof(double));
		}
		rc |= gofr_set_count(g, n) | gofr_pairs(g, pos, NULL, 0, rmax, NB, c, NULL, NULL);
		for (int b = 0; b < NB; b++)
			tot[b] += c[b], sq[b] += c[b] * c[b];
		/* the first half of the rows only (the rest left) */
		rc |= gofr_set_count(g, n / 2) | gofr_pairs(g, pos, NULL, 0, rmax, NB, c, NULL, NULL);
		for (int b = 0; b < NB; b++)
			tot2[b] += c[b], sq2[b] += c[b] * c[b];
	}
	int bad = 0, bad2 = 0, plain_bad = 0;
	double worst = 0;
	for (int b = 0; b < NB; b++) {
		double lo = rmax * b / NB, hi = rmax * (b + 1) / NB;
		rc |= gofr_set_count(g, n);
		double e = K * gofr_ideal_in(g, lo, hi), e0 = K * gofr_ideal_in(w, lo, hi);
		rc |= gofr_set_count(g, n / 2);
		double e2 = K * gofr_ideal_in(g, lo, hi);
		/* K times the variance of one configuration's count, plus the table's error */
		double v1 = K * (sq[b] - tot[b] * tot[b] / K) / (K - 1), v2 = K * (sq2[b] - tot2[b] * tot2[b] / K) / (K - 1);
		double s1 = sqrt(v1 + e * e * 4e-6), s2 = sqrt(v2 + e2 * e2 * 4e-6);
		bad += fabs(tot[b] - e) > 5 * s1;
		bad2 += fabs(tot2[b] - e2) > 5 * s2;
		plain_bad += fabs(tot[b] - e0) > 5 * s1;
		worst = fmax(worst, fabs(tot[b] / e - 1));
	}
	ok(rc == 0 && bad == 0 && bad2 == 0 && plain_bad > NB / 2,
	   "%s, N=%zu x %d: g(r) = 1 with the obstacles' normalisation in all %d bins up to r = %g within 5 se "
	   "(%d off; %d off with N/2 rows present; largest |g-1| %.4f); walls-only normalisation: %d bins off", what,
	   n, K, NB, rmax, bad, bad2, worst, plain_bad);
	if (exact_area > 0) {
		double rr = rmax / 1000, v = dim == 2 ? PI * rr * rr : 4.0 / 3.0 * PI * rr * rr * rr, R = 1;
		for (int a = 0; a < dim; a++)
			R *= inner[a];
		gofr_set_count(g, n);
		double area = 0.5 * (double)n * (double)(n - 1) * v / gofr_ideal_in(g, 0, rr), p = exact_area / R;
		double se = exact_area * sqrt(p * (1 - p) / (1 << 18)) / p;
		ok(fabs(area - exact_area) < 4 * se, "%s: reachable volume %.3f, exactly %.3f (se %.3f)", what, area,
		   exact_area, se);
	}
	gofr_destroy(g);
	gofr_destroy(w);
	free(pos);
}

/*
 * One disk of contact radius S in a periodic square of edge L (no wrap onto itself: r + 2S < L): the set of
 * centres A misses the disk O, and |A n (A - d)| = L^2 - |O u (O - d)| = L^2 - 2 pi S^2 + lens(|d|), with
 * lens(r) = 2 S^2 acos(r / 2S) - (r/2) sqrt(4 S^2 - r^2) the overlap of two disks (0 beyond 2S). The ideal
 * pairs in [a, b) are n(n-1)/2 int_a^b 2 pi r |A n (A - r)| dr / |A|^2 exactly; the table must agree within
 * its Monte Carlo error (about 2e-3 relative: the binomial error of F and of |A| for 2^18 points, 4 se).
 */
static double lens(double r, double S)
{
	return r < 2 * S ? 2 * S * S * acos(r / (2 * S)) - 0.5 * r * sqrt(4 * S * S - r * r) : 0.0;
}

static void test_obstacle_formula(void)
{
	const double L = 40, S = 6, box[3] = {L, L, 1}, oc[2] = {3, 20}, os[1] = {S};
	const size_t n = 1000;
	const int per[3] = {0, 0, 0};
	gofr_t *g = gofr_create(2, n, box, 19);
	int rc = gofr_walls(g, per, 0.5) | gofr_obstacles(g, 1, oc, os);
	double A = L * L - PI * S * S, worst = 0;
	int bad = 0;
	for (int k = 0; k < 19; k++) {
		double a = k, b = k + 1, sum = 0;
		int M = 2000;
		for (int i = 0; i < M; i++) {
			double r = a + (b - a) * (i + 0.5) / M;
			sum += 2 * PI * r * (L * L - 2 * PI * S * S + lens(r, S));
		}
		double exact = 0.5 * n * (n - 1.0) * sum * (b - a) / M / (A * A), got = gofr_ideal_in(g, a, b);
		worst = fmax(worst, fabs(got / exact - 1));
		bad += fabs(got / exact - 1) > 4 * 2e-3;
	}
	ok(rc == 0 && bad == 0, "one obstacle in a periodic box: the table's ideal pairs against the exact lens "
	   "formula in 19 shells, largest relative difference %.5f (< 8e-3)", worst);
	gofr_destroy(g);
}

/* The edge-corrected ideal counts against a direct numerical integration of the triangular difference
 * densities over the shell (midpoint rule in angle, 2D), and the periodic limit. */
static void test_ideal_formula(void)
{
	const double box[3] = {12, 7, 1};
	const int walled[3] = {1, 1, 0};
	gofr_t *g = gofr_create(2, 10, box, 3.4);
	gofr_walls(g, walled, 0.5);
	double Lx = 11, Ly = 6, a = 2.1, b = 3.4, sum = 0;
	int M = 4000, K = 400;
	for (int i = 0; i < K; i++) {
		double r = a + (b - a) * (i + 0.5) / K;
		for (int j = 0; j < M; j++) {
			double t = 2 * PI * (j + 0.5) / M;
			sum += r * (1 - r * fabs(cos(t)) / Lx) * (1 - r * fabs(sin(t)) / Ly);
		}
	}
	double num = 45.0 * sum * (b - a) / K * (2 * PI / M) / (Lx * Ly), got = gofr_ideal_in(g, a, b);
	ok(fabs(got / num - 1) < 1e-5, "2D, both axes walled: ideal pairs in [2.1, 3.4) %.8f, numerically %.8f", got, num);
	gofr_t *p = gofr_create(3, 10, (const double[]){5, 6, 7}, 2);
	ok(gofr_ideal_in(p, 1, 2) == gofr_ideal(3, 10, 5 * 6 * 7, 1, 2), "no walls: the periodic ideal count");
	ok(gofr_walls(p, (const int[]){0, 1, 0}, 3.0) == -1, "walls with no room between them: -1");
	gofr_destroy(p);
	gofr_destroy(g);
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

/*
 * Species classes: gofr_pairs_species() against brute force per class (every count equal); the classes
 * add up to gofr_pairs(); for an ideal gas of three species each class's g in the contact window of
 * gofr_contact_species() is 1 within 5 of its fit standard errors; bad arguments are refused.
 */
static void test_species(int dim, size_t n, const double *box)
{
	enum { NB = 23, K = 3 };
	const int P = gofr_pair_classes(K);
	uint64_t seed = 77 + dim;
	double *pos = malloc(n * dim * sizeof(double)), *vel = calloc(n * dim, sizeof(double));
	uint8_t *sp = malloc(n);
	random_positions(dim, n, box, &seed, pos);
	for (size_t i = 0; i < n; i++)
		sp[i] = (uint8_t)(i < n / 2 ? 0 : i < 3 * n / 4 ? 1 : 2);   /* blocks, as the engine's rows */
	const double r1 = 2.5;
	gofr_t *g = gofr_create(dim, n, box, r1);
	double *cnt = calloc((size_t)P * NB, sizeof(double)), *bc = calloc((size_t)P * NB, sizeof(double));
	double tot[NB], bt[NB], bp[NB], bq[NB];
	int rc = gofr_species(g, K, sp);
	rc |= gofr_pairs_species(g, pos, 0.1, r1, NB, cnt);
	rc |= gofr_pairs(g, pos, NULL, 0.1, r1, NB, tot, NULL, NULL);
	/* brute force per class: the pairs of rows restricted to the class, binned as brute() does */
	for (size_t i = 0; i < n; i++)
		for (size_t j = i + 1; j < n; j++) {
			double r2 = 0;
			for (int a = 0; a < dim; a++) {
				double d = pos[i * dim + a] - pos[j * dim + a];
				d -= box[a] * round(d / box[a]);
				r2 += d * d;
			}
			if (r2 >= r1 * r1 || r2 < 0.01)
				continue;
			int k = (int)((sqrt(r2) - 0.1) * (NB / (r1 - 0.1)));
			k = k >= NB ? NB - 1 : k;
			bc[(size_t)gofr_pair_class(K, sp[i], sp[j]) * NB + k]++;
		}
	brute(dim, n, box, (const int[3]){0, 0, 0}, pos, vel, 0.1, r1, NB, bt, bp, bq);
	int same = rc == 0, sum = 1;
	for (int b = 0; b < NB; b++) {
		double s = 0;
		for (int p = 0; p < P; p++) {
			same &= cnt[(size_t)p * NB + b] == bc[(size_t)p * NB + b];
			s += cnt[(size_t)p * NB + b];
		}
		sum &= s == tot[b] && tot[b] == bt[b];
	}
	ok(same, "%dD, 3 species: pair counts of each of the %d classes equal brute force", dim, P);
	ok(sum, "%dD, 3 species: the classes add up to the pair counts of gofr_pairs()", dim);
	size_t nk[K];
	int fine = gofr_species_count(g, nk) == 0 && nk[0] == n / 2 && nk[1] == n / 4 && nk[2] == n - 3 * (n / 4);
	double worst = 0;
	for (int a = 0; a < K; a++)
		for (int b = a; b < K; b++) {
			gofr_contact_t gc;
			double sig = 0.6 + 0.2 * (a + b);
			fine &= gofr_contact_species(g, pos, a, b, sig, &gc) == 0 && fabs(gc.value - 1) < 5 * gc.se;
			worst = fmax(worst, fabs(gc.value - 1) / gc.se);
		}
	ok(fine, "%dD ideal gas, 3 species: every class's contact value is 1 (largest deviation %.2f se)", dim, worst);
	gofr_contact_t gc;
	ok(gofr_contact_species(g, pos, 0, K, 1.0, &gc) == -1 && gofr_species(g, 2, sp) == -1 &&
	   gofr_species(g, GOFR_SPECIES_MAX + 1, sp) == -1 && gofr_species(g, 0, NULL) == 0 &&
	   gofr_pairs_species(g, pos, 0.1, r1, NB, cnt) == -1,
	   "%dD: a species beyond K, a row's class >= K, K too large: -1; K = 0 removes the classes", dim);
	gofr_destroy(g);
	free(cnt);
	free(bc);
	free(sp);
	free(pos);
	free(vel);
}

int main(void)
{
	plan(49);
	test_species(2, 6000, (const double[3]){40, 40, 1});
	test_species(3, 6000, (const double[3]){14, 14, 14});
	double b2[3] = {20, 17, 1}, b3[3] = {9, 11, 10}, tiny[3] = {5, 6, 5.5};
	test_brute(2, 1500, b2, 3.0, "2D, 6x5 cells");
	test_brute(3, 1500, b3, 3.0, "3D, 3x3x3 cells");
	test_brute(3, 300, tiny, 2.7, "3D, 2x2x2 cells (cutoff near half the box)");
	double i2[3] = {60, 60, 1}, i3[3] = {25, 25, 25};
	test_ideal(2, 20000, i2);
	test_ideal(3, 20000, i3);
	int wy[3] = {0, 1, 0}, wxy[3] = {1, 1, 0}, wz[3] = {0, 0, 1}, wxyz[3] = {1, 1, 1};
	test_brute_walled(2, 1500, b2, wy, 3.0, "2D, y walled");
	test_brute_walled(3, 1500, b3, wxyz, 3.0, "3D, all walled");
	test_brute_walled(3, 300, tiny, wz, 2.7, "3D, z walled, 2x2x2 cells");
	double w2[3] = {60, 30, 1}, w3[3] = {25, 25, 16};
	test_ideal_walled(2, 20000, w2, wy, "2D, walls along y");
	test_ideal_walled(2, 20000, w2, wxy, "2D, walls along x and y");
	test_ideal_walled(3, 20000, w3, wz, "3D, walls along z");
	test_ideal_walled(3, 20000, w3, wxyz, "3D, walls on every axis");
	{
		/* 2D periodic 60 x 60 with one disk of contact radius 15 (20% of the box), near the edge so that
		 * it wraps; 3D with a wall along z and two spheres */
		double b2o[3] = {60, 60, 1}, c2[2] = {50, 12}, s2[1] = {15};
		int per[3] = {0, 0, 0};
		test_ideal_obstacles(2, 2000, 16, b2o, per, 1, c2, s2, 3600 - PI * 225, "2D periodic, one obstacle");
		double b3o[3] = {24, 24, 20}, c3[6] = {6, 6, 10, 18, 15, 9}, s3[2] = {5, 4};
		test_ideal_obstacles(3, 2000, 16, b3o, wz, 2, c3, s3,
		                     24 * 24 * 19 - 4.0 / 3.0 * PI * (125 + 64), "3D, walls along z, two obstacles");
	}
	{
		gofr_t *t = gofr_create(2, 10, (const double[]){10, 10, 1}, 4);
		ok(gofr_obstacles(t, 1, (const double[]){5, 5}, (const double[]){100}) == -1 && gofr_set_count(t, 11) == -1,
		   "an obstacle that leaves no room: -1; more rows than allocated: -1");
		gofr_destroy(t);
	}
	test_obstacle_formula();
	test_ideal_formula();
	test_fit();
	test_enskog();
	return done_testing();
}
