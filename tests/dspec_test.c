/* Tests for engine/observe/dspec.c: the normalisation of seed 000 eq. 3.11 on a pure tone, the white spectrum of uncorrelated positions, the slope fit, state round trip and bad settings. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "observe/dspec.h"
#include "obs_util.h"
#include "tap.h"

/* Place c[s] particles in slice s (2D, slices along y of a box of height L). */
static size_t place(const int *c, int S, double L, double *pos)
{
	size_t n = 0;
	for (int s = 0; s < S; s++)
		for (int i = 0; i < c[s]; i++, n++) {
			pos[2 * n] = 0.5;
			pos[2 * n + 1] = (s + 0.5) * L / S;
		}
	return n;
}

/*
 * A pure tone: slice 0 holds 10 + 5 cos(2 pi j k0 / m) particles at sample j (k0 = m/4: the cosine is
 * 1, 0, -1, 0), slice 1 the rest of 30. Then C_k = 5 m / 2 at k = k0 and m - k0, 0 elsewhere, so
 * P(f_k0) = 2 (5 m / 2)^2 / m^2 = 12.5 for slice 0 and the same for slice 1 (its counts are the mirror),
 * 0 at every other k: exact up to rounding.
 */
static void test_tone(void)
{
	const int m = 64, S = 2, k0 = m / 4;
	const double L = 10, dt = 0.5;
	dspec_t *d = dspec_create(2, 1, S, L, m, dt, 0, INFINITY);
	double pos[2 * 40], P[64], alpha, se, e[64], c[64];
	static const int cosv[4] = {1, 0, -1, 0};
	for (int j = 0; j < m; j++) {
		int cnt[2] = {10 + 5 * cosv[j % 4], 0};
		cnt[1] = 30 - cnt[0];
		size_t n = place(cnt, S, L, pos);
		if (j == 3)
			ok(dspec_result(d, P, &alpha, &se) == 3 && isnan(P[0]) && isnan(alpha), "fewer than m samples: NaN");
		dspec_add(d, n, pos);
	}
	int K = dspec_bins(m), n = dspec_result(d, P, &alpha, &se), good = n == m && K == m / 2 - 1;
	for (int k = 1; k <= K; k++)
		good &= fabs(P[k - 1] - (k == k0 ? 12.5 : 0.0)) < 1e-9;
	dspec_axis(d, e, c);
	good &= fabs(c[k0 - 1] - k0 / (m * dt)) < 1e-12 && fabs(e[0] - 0.5 / (m * dt)) < 1e-12;
	ok(good, "pure tone: P(f_k0) = 12.5 (eq. 3.11), 0 elsewhere, f_k = k / (m dt); P[k0]=%g", P[k0 - 1]);
	dspec_destroy(d);
}

/*
 * Uncorrelated positions: N particles uniform in the box at every sample. Each slice count is binomial,
 * var = N (1/S)(1 - 1/S), independent from sample to sample, so E P(f_k) = 2 var / m at every k (white)
 * and the slope of log P against log f is 0. The mean over the K frequencies is compared within 5
 * standard errors of the mean over the K values (their own scatter: values at different k are
 * independent); the slope within 5 of its standard errors from the fit residuals.
 */
static void test_white(int N, int S, int m, uint64_t seed)
{
	const double box[2] = {3, 50};
	dspec_t *d = dspec_create(2, 1, S, box[1], m, 1.0, 0, INFINITY);
	double *pos = malloc(2 * (size_t)N * sizeof(double)), *P = malloc((size_t)m * sizeof(double)), alpha, se;
	for (int j = 0; j < m; j++) {
		random_positions(2, (size_t)N, box, &seed, pos);
		dspec_add(d, (uint64_t)N, pos);
	}
	dspec_result(d, P, &alpha, &se);
	int K = dspec_bins(m);
	double s = 0, s2 = 0;
	for (int k = 0; k < K; k++)
		s += P[k];
	double mean = s / K;
	for (int k = 0; k < K; k++)
		s2 += (P[k] - mean) * (P[k] - mean);
	double sem = sqrt(s2 / (K - 1) / K), level = 2.0 * N * (1.0 / S) * (1.0 - 1.0 / S) / m;
	ok(fabs(mean - level) < 5 * sem, "white: mean P %.6g vs 2 var / m = %.6g (5 se = %.3g), N=%d S=%d m=%d", mean,
	   level, 5 * sem, N, S, m);
	ok(isfinite(se) && se > 0 && fabs(alpha) < 5 * se, "white: slope %.4f +- %.4f consistent with 0", alpha, se);
	free(pos);
	free(P);
	dspec_destroy(d);
}

/* The fit alone: counts whose spectrum is a known power law would need a generator; instead a red
 * signal, a random walk of the count in slice 0 (P ~ f^-2 at f << 1 / dt), must give a slope near -2:
 * between -2.5 and -1.5 over the lowest tenth of the frequencies. */
static void test_red(void)
{
	const int m = 2048, S = 2;
	const double L = 10;
	dspec_t *d = dspec_create(2, 1, S, L, m, 1.0, 0, 0.05);
	uint64_t seed = 7;
	double *pos = malloc(2 * 2000 * sizeof(double)), *P = malloc(m * sizeof(double)), alpha, se;
	int c = 1000;
	for (int j = 0; j < m; j++) {
		c += uniform(&seed) < 0.5 ? -5 : 5;
		c = c < 0 ? 0 : c > 2000 ? 2000 : c;
		int cnt[2] = {c, 2000 - c};
		size_t n = place(cnt, S, L, pos);
		dspec_add(d, n, pos);
	}
	dspec_result(d, P, &alpha, &se);
	ok(alpha > -2.5 && alpha < -1.5, "random walk: slope %.3f +- %.3f near -2 at low f", alpha, se);
	free(pos);
	free(P);
	dspec_destroy(d);
}

static void test_state(void)
{
	dspec_t *a = dspec_create(2, 0, 4, 2.0, 8, 1.0, 0, INFINITY), *b = dspec_create(2, 0, 4, 2.0, 8, 1.0, 0, INFINITY);
	uint64_t seed = 3;
	double box[2] = {2, 2}, pos[2 * 50], v[64], Pa[8], Pb[8], aa, ab, sa, sb;
	for (int j = 0; j < 11; j++) {
		random_positions(2, 50, box, &seed, pos);
		dspec_add(a, 50, pos);
	}
	dspec_state_get(a, v);
	int set = dspec_state_set(b, v) == 0;
	dspec_result(a, Pa, &aa, &sa);
	dspec_result(b, Pb, &ab, &sb);
	ok(set && !memcmp(Pa, Pb, sizeof(double) * dspec_bins(8)), "state round trip: the same spectrum bit for bit");
	v[dspec_state_size(a) - 1] = 9;   /* filled > m */
	ok(dspec_state_set(b, v) == -1, "bad state refused");
	dspec_destroy(a);
	dspec_destroy(b);
}

int main(void)
{
	plan(10);
	test_tone();
	test_white(2000, 20, 512, 11);
	test_white(300, 4, 1024, 12);
	test_red();
	test_state();
	ok(!dspec_create(2, 1, 1, 1.0, 64, 1.0, 0, 1) && !dspec_create(2, 2, 4, 1.0, 64, 1.0, 0, 1) &&
	   !dspec_create(2, 1, 4, 1.0, 2, 1.0, 0, 1), "slices < 2, axis out of range, m < 4 refused");
	return done_testing();
}
