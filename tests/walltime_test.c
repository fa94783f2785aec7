/* Tests of the wall contact times: fixed planes under gravity (grazing, resting) and the vibrating wall against brute force. */
#include <math.h>
#include <stdio.h>

#include "ed/walltime.h"
#include "rng.h"
#include "tap.h"

#ifndef M_PI
#define M_PI 3.14159265358979323846
#endif

typedef struct {
	double d, u, gam, A, w, th;
} gap_t;

/* The gap and its rate, written out independently of walltime.c. */
static double h(const gap_t *g, double t)
{
	return g->d + g->u * t + 0.5 * g->gam * t * t - g->A * (sin(g->th + g->w * t) - sin(g->th));
}

static double dh(const gap_t *g, double t)
{
	return g->u + g->gam * t - g->A * g->w * cos(g->th + g->w * t);
}

static void test_plane(void)
{
	/* resting on the plane under gravity: contact now (the wall rule then
	 * lifts it off with the TC minimum rebound) */
	ok(walltime_plane(0.0, 0.0, -1.0) == 0.0, "plane: resting particle (d = 0, u = 0, pulled in): contact now");
	/* just reflected, a rounding error beyond the plane: the contact is the
	 * return from the apex, 2u/g, not now */
	double t = walltime_plane(-1e-17, 1e-3, -1.0);
	ok(fabs(t - 2e-3) < 1e-12, "plane: just reflected (d = -1e-17, u = 1e-3, g = 1): next contact %.17g = 2u/g", t);
	/* falling from rest: t = sqrt(2 d / g) */
	t = walltime_plane(1.0, 0.0, -2.0);
	ok(fabs(t - 1.0) < 1e-15, "plane: fall from rest d = 1, g = 2 takes %.17g = 1", t);
	/* a far, fast approach: no cancellation (2d/(s - u) form) */
	t = walltime_plane(1e-12, -1e3, -1.0);
	ok(fabs(t / 1e-15 - 1.0) < 1e-12, "plane: d = 1e-12 at u = -1e3: t = %.17g (1e-15 to 1e-12 relative)", t);
	/* pushed away (plane overhead, gravity pulls back): grazing misses */
	ok(walltime_plane(1.0, -1.0, 1.0) == INFINITY, "plane: pushed away, u^2 < 2 g d: never reaches it");
	t = walltime_plane(0.5, -1.0, 1.0);
	ok(fabs(t - 1.0) < 1e-15, "plane: pushed away, u^2 = 2 g d (grazing): touches at the apex t = %.17g", t);
	ok(walltime_plane(1.0, 1.0, 0.0) == INFINITY && walltime_plane(1.0, -0.5, 0.0) == 2.0,
	   "plane without gravity: receding never, approaching d/|u|");
	/* beyond the plane and approaching (a rounding error late): now */
	ok(walltime_plane(-1e-15, -1.0, -1.0) == 0.0, "plane: beyond and approaching: contact now, never missed");
}

/* Random vibrating-wall cases: the contact found is a contact (gap 0,
 * approaching), no earlier time on a fine grid has the particle beyond
 * the wall (none missed), and after an elastic reflection at that time the
 * next contact is later (no double collision). */
static void test_vibrating(void)
{
	rng_t r;
	rng_init(&r, 7, 0);
	int n = 0, bad_contact = 0, missed = 0, doubled = 0, found = 0;
	double worst_h = 0.0;
	enum { CASES = 3000, GRID = 20000 };
	for (int k = 0; k < CASES; k++) {
		gap_t g;
		g.A = 0.01 + rng_uniform(&r);
		g.w = 2.0 * M_PI * (0.1 + 10.0 * rng_uniform(&r));
		g.gam = -(k % 3 == 0 ? 0.0 : 20.0 * rng_uniform(&r));
		g.th = 2.0 * M_PI * rng_uniform(&r);
		g.d = (k % 5 == 0 ? 1e-9 : 3.0) * rng_uniform(&r);
		g.u = 4.0 * (rng_uniform(&r) - 0.5);
		if (k % 7 == 0)
			g.u = g.A * g.w * cos(g.th) + 1e-9;   /* moving with the wall: grazing */
		const double horizon = 3.0;
		double t = walltime_vibrating(g.d, g.u, g.gam, g.A, g.w, g.th, horizon);
		n++;
		double scale = 1e-9 * (1.0 + fabs(g.u) + g.A + fabs(g.gam));
		double end = t < INFINITY ? t : horizon;
		/* grid: the first instant beyond the wall must not come before t */
		for (int i = 0; i < GRID; i++) {
			double s = end * i / GRID;
			if (h(&g, s) < -scale) {
				missed++;
				diag("missed: d=%g u=%g gam=%g A=%g w=%g th=%g: h(%g) = %g, walltime %g", g.d, g.u, g.gam,
				     g.A, g.w, g.th, s, h(&g, s), t);
				break;
			}
		}
		if (t == INFINITY)
			continue;
		found++;
		double ht = h(&g, t), dht = dh(&g, t);
		if (fabs(ht) > fabs(worst_h))
			worst_h = ht;
		if (fabs(ht) > scale || dht > scale) {
			bad_contact++;
			diag("not a contact: h(%g) = %g, h' = %g", t, ht, dht);
			continue;
		}
		if (dht >= 0.0)
			continue;   /* touching tangentially: nothing to reflect */
		/* elastic reflection: the gap rate reverses */
		double th2 = g.th + g.w * t;
		double wv = g.A * g.w * cos(th2), v = g.u + g.gam * t;
		double v2 = 2.0 * wv - v;
		double t2 = walltime_vibrating(ht, v2, g.gam, g.A, g.w, th2, horizon);
		if (!(t2 > 0.0)) {
			doubled++;
			diag("double: after a contact at %g (h' %g) the next is at %g", t, dht, t2);
		}
	}
	ok(bad_contact == 0, "vibrating wall: %d cases, %d contacts found, each at gap 0 and approaching (largest |h| %.2g)",
	   n, found, worst_h);
	ok(missed == 0, "vibrating wall: no contact missed (fine grid of %d points before each)", GRID);
	ok(doubled == 0, "vibrating wall: after an elastic reflection the next contact is strictly later");
	/* A particle at rest on a wall that accelerates into it faster than
	 * gravity pulls (A w^2 > g): contact at once when the wall starts up. */
	double t = walltime_vibrating(0.0, 0.0, -1.0, 1.0, 2.0 * M_PI, 0.0, 1.0);
	ok(t == 0.0 || t < 1e-12, "vibrating wall: particle resting on a wall moving up: contact now (%g)", t);
}

int main(void)
{
	plan(12);
	test_plane();
	test_vibrating();
	return done_testing();
}
