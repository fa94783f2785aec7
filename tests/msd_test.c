/* Tests for engine/observe/msd.c: ballistic particles followed across many periodic images, the update bound, the checkpoint state. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "observe/msd.h"
#include "tap.h"

/* Fold x into [0, L). */
static double fold(double x, double L)
{
	x = fmod(x, L);
	return x < 0 ? x + L : x;
}

/*
 * N particles at constant velocities (one per particle, up to the bound's
 * speed) move through a box of edges L for many box lengths: updated at
 * msd_due() each time, the unwrapped displacement is exactly v t, so
 * MSD(t) = <|v|^2> t^2 (up to rounding). Folded positions only are given.
 */
static void test_ballistic(int dim)
{
	const size_t n = 50;
	const double box[3] = {7.0, 9.0, 11.0}, mass = 2.0;
	double x0[150], v[150], pos[150], ekin = 0, v2 = 0;
	for (size_t i = 0; i < n; i++)
		for (int a = 0; a < dim; a++) {
			x0[i * dim + a] = fold(0.37 * i + 1.3 * a, box[a]);
			v[i * dim + a] = sin(1.7 * i + a) * 3.0;   /* signs and sizes vary */
			ekin += 0.5 * mass * v[i * dim + a] * v[i * dim + a];
			v2 += v[i * dim + a] * v[i * dim + a] / n;
		}
	msd_t *m = msd_create(dim, n, box, mass, 0.45);
	msd_origin(m, 0.0, x0, ekin);
	double t = 0;
	int steps = 0;
	while (t < 40.0) {
		t = msd_due(m);
		for (size_t i = 0; i < n * dim; i++)
			pos[i] = fold(x0[i] + v[i] * t, box[i % dim]);
		msd_update(m, t, pos, ekin);
		steps++;
	}
	double se, val = msd_value(m, &se), want = v2 * t * t;
	ok(fabs(val - want) < 1e-9 * want, "%dD ballistic through ~%.0f box lengths in %d updates: MSD %.10g = <v^2> t^2 %.10g",
	   dim, sqrt(v2) * t / box[0], steps, val, want);
	/* the bound: 0.45 of the smallest edge at the largest speed the energy allows */
	double due = msd_due(m) - t;
	ok(fabs(due - 0.45 * 7.0 / sqrt(2 * ekin / mass)) < 1e-12, "%dD next update within 0.45 edges at sqrt(2E/m): %.6g",
	   dim, due);

	/* state round trip: a copy continues identically */
	size_t k = msd_state_size(m);
	double *st = malloc(k * sizeof(double));
	msd_state_get(m, st);
	msd_t *c = msd_create(dim, n, box, mass, 0.45);
	ok(msd_state_set(c, st) == 0 && msd_value(c, NULL) == val && msd_due(c) == msd_due(m),
	   "%dD state of %zu doubles restores MSD and the next update time", dim, k);
	st[0] = NAN;
	ok(msd_state_set(c, st) == -1, "%dD state with a NaN refused", dim);
	free(st);
	msd_destroy(c);
	msd_destroy(m);
}

/*
 * Updates too rare for the bound lose images: with steps of more than half
 * an edge the minimum image is the wrong image (the check that the cadence
 * matters, i.e. that the test above would notice a wrong unwrapping).
 */
static void test_too_rare(void)
{
	const double box[2] = {10.0, 10.0};
	double x0[2] = {1.0, 1.0}, pos[2];
	msd_t *m = msd_create(2, 1, box, 1.0, 0.45);
	msd_origin(m, 0.0, x0, 0.5 * 36.0);   /* speed 6 along x */
	for (int s = 1; s <= 10; s++) {
		pos[0] = fold(1.0 + 6.0 * s, 10.0);  /* 6 per update: more than half an edge */
		pos[1] = 1.0;
		msd_update(m, s, pos, 18.0);
	}
	double val = msd_value(m, NULL);
	ok(fabs(val - 3600.0) > 1.0, "updates 0.6 edges apart lose images: MSD %.6g, not 3600", val);
	msd_destroy(m);
	msd_destroy(NULL);
}

int main(void)
{
	plan(9);
	test_ballistic(2);
	test_ballistic(3);
	test_too_rare();
	return done_testing();
}
