/* Tests for engine/observe/msd.c: ballistic particles followed across many periodic images, the update bound, the checkpoint state. */
#include <math.h>
#include <stdint.h>
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

/* Reflect x into [lo, hi] (specular walls): the position of a free flight x0 + v t bouncing between them. */
static double bounce(double x, double lo, double hi)
{
	double w = hi - lo, y = fmod(x - lo, 2 * w);
	y = y < 0 ? y + 2 * w : y;
	return lo + (y <= w ? y : 2 * w - y);
}

/*
 * Walls along y (msd_walls): x periodic and unwrapped, y absolute (a particle bouncing between the walls
 * moves far more than half the edge between two updates and still counts its true displacement, and one
 * a little beyond a wall counts as it is). Ballistic particles at constant |v_y| between specular walls
 * at contact planes 0.5 and 8.5: MSD along x = <v_x^2> t^2, along y the exact bounced displacement.
 * Without a periodic axis no update is ever due.
 */
static void test_walls(void)
{
	const size_t n = 40;
	const double box[2] = {7.0, 9.0}, mass = 1.5;
	double x0[80], v[80], pos[80], ekin = 0;
	for (size_t i = 0; i < n; i++) {
		x0[2 * i] = fold(0.41 * i, box[0]);
		x0[2 * i + 1] = 0.5 + fmod(0.77 * i, 8.0);
		v[2 * i] = 2.5 * sin(1.3 * i);
		v[2 * i + 1] = 9.0 * cos(0.9 * i);   /* fast along the walled axis */
		ekin += 0.5 * mass * (v[2 * i] * v[2 * i] + v[2 * i + 1] * v[2 * i + 1]);
	}
	msd_t *m = msd_create(2, n, box, mass, 0.45);
	int rc = msd_walls(m, (const int[]){0, 1}, (const double[]){0, 0}, 0.5);
	msd_origin(m, 0.0, x0, ekin);
	double t = 0, wx = 0, wy = 0;
	int steps = 0;
	while (t < 30.0) {
		t = msd_due(m);
		for (size_t i = 0; i < n; i++) {
			pos[2 * i] = fold(x0[2 * i] + v[2 * i] * t, box[0]);
			pos[2 * i + 1] = bounce(x0[2 * i + 1] + v[2 * i + 1] * t, 0.5, 8.5);
		}
		msd_update(m, t, pos, ekin);
		steps++;
	}
	for (size_t i = 0; i < n; i++) {
		wx += v[2 * i] * t * v[2 * i] * t / n;
		wy += (pos[2 * i + 1] - x0[2 * i + 1]) * (pos[2 * i + 1] - x0[2 * i + 1]) / n;
	}
	double px = msd_value_axes(m, 0), py = msd_value_axes(m, 1);
	ok(rc == 0 && fabs(px - wx) < 1e-9 * wx && fabs(py - wy) < 1e-12 * (1 + wy) &&
	   fabs(msd_value(m, NULL) - (wx + wy)) < 1e-9 * wx,
	   "walls along y, %d updates: MSD along x %.8g = <v_x^2> t^2 %.8g, along y %.8g = the bounced displacement "
	   "%.8g", steps, px, wx, py, wy);
	/* the bound uses the periodic edge only (7, not the walled 9) */
	ok(fabs(msd_due(m) - t - 0.45 * 7.0 / sqrt(2 * ekin / mass)) < 1e-12, "the update bound uses the periodic edge");
	msd_destroy(m);

	/* every axis walled: no update due; positions absolute */
	msd_t *b = msd_create(2, 1, box, 1.0, 0.45);
	double p0[2] = {1.0, 1.0}, p1[2] = {6.5, 8.2};
	rc = msd_walls(b, (const int[]){1, 1}, (const double[]){0, 0}, 0.5);
	msd_origin(b, 0.0, p0, 50.0);
	msd_update(b, 3.0, p1, 50.0);
	ok(rc == 0 && isinf(msd_due(b)) && fabs(msd_value(b, NULL) - (5.5 * 5.5 + 7.2 * 7.2)) < 1e-12 &&
	   isnan(msd_value_axes(b, 0)), "every axis walled: no update due, displacement as it is (%.6g)",
	   msd_value(b, NULL));
	msd_destroy(b);
}

/*
 * Gravity along the walled axis: the bound takes the potential energy above the floor. A particle at rest
 * at height 8.5 (contact plane 0.5, g = -2) reaches speed sqrt(2 g 8) = 5.66 on the floor: the next update
 * must come within 0.45 periodic edges at that speed, not never (E_kin = 0). Gravity along a periodic axis
 * is refused.
 */
static void test_gravity(void)
{
	const double box[2] = {7.0, 9.0};
	double p[2] = {3.0, 8.5};
	msd_t *m = msd_create(2, 1, box, 1.0, 0.45);
	int rc = msd_walls(m, (const int[]){0, 1}, (const double[]){0, -2.0}, 0.5);
	msd_origin(m, 0.0, p, 0.0);
	double due = msd_due(m), vmax = sqrt(2 * 2.0 * 8.0);
	ok(rc == 0 && fabs(due - 0.45 * 7.0 / vmax) < 1e-12, "gravity: the update bound at sqrt(2 (E_kin + m g h)) = %.4f "
	   "(next update %.6g)", vmax, due);
	ok(msd_walls(m, (const int[]){0, 1}, (const double[]){1.0, -2.0}, 0.5) == -1,
	   "gravity along a periodic axis refused");
	/* upward gravity: the least potential is at the upper contact plane 8.5 */
	rc = msd_walls(m, (const int[]){0, 1}, (const double[]){0, 3.0}, 0.5);
	p[1] = 0.5;
	msd_origin(m, 0.0, p, 0.0);
	ok(rc == 0 && fabs(msd_due(m) - 0.45 * 7.0 / sqrt(2 * 3.0 * 8.0)) < 1e-12, "gravity along +y: measured from "
	   "the upper contact plane");
	msd_destroy(m);
}

/*
 * A varying particle set (msd_varying()): 4 labelled rows in 1D-like 2D motion, exact mode. Row 1 leaves
 * (NaN) at the first update, row 2's slot is refilled by another particle (new label) at the second, row 3
 * is empty at the origin and filled later: the members are row 0 throughout and row 2 until its refill. The mean, the count, the interval growth of the same members and the state round trip with NaN
 * origin rows are checked exactly.
 */
static void test_varying(void)
{
	const double box[2] = {10.0, 10.0};
	msd_t *m = msd_create(2, 4, box, 1.0, 0.45);
	msd_exact(m);
	int rc = msd_varying(m, 1);
	double p0[8] = {1, 1, 2, 2, 3, 3, NAN, NAN};
	int64_t id0[4] = {0, 1, 2, -1};
	msd_origin(m, 0.0, p0, 0.0);
	msd_ids(m, id0);
	ok(rc == 0 && msd_count(m) == 3 && msd_value(m, NULL) == 0.0, "varying set: 3 members at the origin (one row empty)");
	/* t = 1: row 0 moved by (3, 4), row 1 gone, row 2 moved by (1, 0), row 3 entered */
	double p1[8] = {4, 5, NAN, NAN, 4, 3, 7, 7};
	int64_t id1[4] = {0, -1, 2, 5};
	msd_update(m, 1.0, p1, 0.0);
	msd_ids(m, id1);
	double se, v1 = msd_value(m, &se), g1 = msd_interval(m);
	ok(msd_count(m) == 2 && v1 == 13.0 && g1 == 13.0, "t = 1: members 0 and 2, MSD (25 + 1) / 2 = %g, interval growth %g", v1, g1);
	/* t = 2: row 0 at (3, 5) from its origin (9 + 25 = 34), row 2 refilled by id 6 */
	double p2[8] = {4, 6, NAN, NAN, 0, 0, 8, 8};
	int64_t id2[4] = {0, -1, 6, 5};
	msd_update(m, 2.0, p2, 0.0);
	msd_ids(m, id2);
	size_t k = msd_state_size(m);
	double *st = malloc(k * sizeof(double));
	msd_state_get(m, st);
	double v2 = msd_value(m, NULL), g2 = msd_interval(m);
	ok(msd_count(m) == 1 && v2 == 34.0 && g2 == 9.0, "t = 2: the refilled slot dropped: MSD %g of row 0, growth of the same "
	   "particle %g (34 - 25)", v2, g2);
	msd_t *c = msd_create(2, 4, box, 1.0, 0.45);
	msd_exact(c);
	msd_varying(c, 1);
	ok(msd_state_set(c, st) == 0 && msd_count(c) == 1 && msd_value(c, NULL) == 34.0 && msd_interval(c) == 9.0,
	   "state of %zu doubles with NaN origin rows restores the members, labels and last squared displacements", k);
	/* a refilled slot after the restore is still told by its label */
	double p3[8] = {4, 6, NAN, NAN, 0, 0, 8, 8};
	int64_t id3[4] = {7, -1, 6, 5};
	msd_update(c, 3.0, p3, 0.0);
	msd_ids(c, id3);
	ok(msd_count(c) == 0 && isnan(msd_value(c, NULL)) && isnan(msd_interval(c)), "no member left: NaN");
	free(st);
	msd_destroy(m);
	msd_destroy(c);
}

int main(void)
{
	plan(20);
	test_ballistic(2);
	test_ballistic(3);
	test_too_rare();
	test_walls();
	test_gravity();
	test_varying();
	return done_testing();
}
