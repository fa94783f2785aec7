/* Tests for engine/observe/vdist.c: Sonine coefficients of known distributions, histograms of a Maxwellian, Galilean invariance. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "observe/vdist.h"
#include "obs_util.h"
#include "tap.h"

/*
 * A Maxwellian sample of N particles: a2 and a3 are zero in expectation.
 * Their standard errors are estimated from the sample itself, as the
 * standard deviation of the per-particle terms of the estimators divided
 * by sqrt(N) (delta method, normalisation by the sample temperature
 * ignored, which only makes the estimate larger). 5 standard errors:
 * a false failure has probability ~6e-7.
 */
static void test_maxwell(int dim, size_t n)
{
	uint64_t seed = 17 + dim;
	double *v = malloc(n * dim * sizeof(double));
	for (size_t i = 0; i < n * dim; i++)
		v[i] = 1.7 * gauss(&seed);
	vdist_moments_t m;
	vdist_moments(dim, n, 2.0, v, &m);
	double d = dim, vt2 = 2 * m.temperature / 2.0, s4 = 0, s4q = 0, s3 = 0, s3q = 0;
	for (size_t i = 0; i < n; i++) {
		double c2 = 0;
		for (int a = 0; a < dim; a++) {
			double w = v[i * dim + a] - m.mean[a];
			c2 += w * w / vt2;
		}
		double t4 = 4 * c2 * c2 / (d * (d + 2));
		double t3 = 3 * t4 - 8 * c2 * c2 * c2 / (d * (d + 2) * (d + 4));
		s4 += t4, s4q += t4 * t4, s3 += t3, s3q += t3 * t3;
	}
	double se2 = sqrt((s4q / n - (s4 / n) * (s4 / n)) / n), se3 = sqrt((s3q / n - (s3 / n) * (s3 / n)) / n);
	ok(fabs(m.temperature - 2.0 * 1.7 * 1.7) < 5 * 2.0 * 1.7 * 1.7 * sqrt(2.0 / (d * n)),
	   "%dD Maxwellian: T = %.5f (expected %.5f)", dim, m.temperature, 2.0 * 1.7 * 1.7);
	ok(fabs(m.a2) < 5 * se2, "%dD Maxwellian, N=%zu: a2 = %.2e (5 se = %.1e)", dim, n, m.a2, 5 * se2);
	ok(fabs(m.a3) < 5 * se3, "%dD Maxwellian, N=%zu: a3 = %.2e (5 se = %.1e)", dim, n, m.a3, 5 * se3);

	/* Histograms against the Maxwellian densities: expected count per bin
	 * n * integral of the density over the bin (midpoint rule with 64
	 * sub-steps); every bin within 5 Poisson standard deviations (+1). */
	enum { B = 40 };
	double range = 3.0, comp[3 * B], speed[B];
	vdist_histograms(dim, n, 2.0, v, &m, B, range, comp, speed);
	int bad = 0;
	for (int k = 0; k < B; k++) {
		double ec = 0, es = 0, cw = 2 * range / B, sw = range / B;
		for (int j = 0; j < 64; j++) {
			ec += vdist_maxwell_component(-range + (k + (j + 0.5) / 64) * cw) * cw / 64;
			es += vdist_maxwell_speed(dim, (k + (j + 0.5) / 64) * sw) * sw / 64;
		}
		for (int a = 0; a < dim; a++) {
			double got = comp[a * B + k] * n * cw, exp = ec * n;
			bad += fabs(got - exp) > 5 * sqrt(exp) + 1;
		}
		double got = speed[k] * n * sw, exp = es * n;
		bad += fabs(got - exp) > 5 * sqrt(exp) + 1;
	}
	ok(bad == 0, "%dD Maxwellian: every component and speed bin within 5 sigma of the Maxwellian (%d off)", dim, bad);

	/* Galilean invariance: a common velocity changes nothing. */
	for (size_t i = 0; i < n; i++)
		v[i * dim] += 3.25;
	vdist_moments_t m2;
	vdist_moments(dim, n, 2.0, v, &m2);
	ok(fabs(m2.a2 - m.a2) < 1e-9 && fabs(m2.a3 - m.a3) < 1e-9 && fabs(m2.temperature - m.temperature) < 1e-9,
	   "%dD: a2, a3, T unchanged by a uniform drift (%.1e, %.1e)", dim, m2.a2 - m.a2, m2.a3 - m.a3);
	free(v);
}

/* All speeds equal: <c^4> = <c^2>^2 = d^2/4, <c^6> = d^3/8, so
 * a2 = -2/(d+2) and a3 = 1 + 3 a2 - d^2/((d+2)(d+4)) exactly. */
static void test_shell(int dim)
{
	enum { N = 2000 };
	static double v[N * 3];
	uint64_t seed = 99;
	for (int i = 0; i < N; i += 2) {
		double u[3] = {0, 0, 0}, r = 0;
		for (int a = 0; a < dim; a++) {
			u[a] = gauss(&seed);
			r += u[a] * u[a];
		}
		r = sqrt(r);
		for (int a = 0; a < dim; a++) {
			v[i * dim + a] = 2.5 * u[a] / r;       /* +v and -v: the mean is exactly 0 */
			v[(i + 1) * dim + a] = -2.5 * u[a] / r;
		}
	}
	vdist_moments_t m;
	vdist_moments(dim, N, 1.0, v, &m);
	double d = dim, a2 = -2 / (d + 2), a3 = 1 + 3 * a2 - d * d / ((d + 2) * (d + 4));
	ok(fabs(m.a2 - a2) < 1e-12 && fabs(m.a3 - a3) < 1e-12, "%dD equal speeds: a2 = %.15f (%.15f), a3 = %.15f (%.15f)",
	   dim, m.a2, a2, m.a3, a3);
}

int main(void)
{
	plan(12);
	test_maxwell(2, 400000);
	test_maxwell(3, 400000);
	test_shell(2);
	test_shell(3);
	return done_testing();
}
