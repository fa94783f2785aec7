/* Monotone root searches shared by the contact times of moving walls and of obstacles under gravity (header only: inlined into each). */
#ifndef GRANULAR_ED_ROOTS_H
#define GRANULAR_ED_ROOTS_H

#include <math.h>

/* A function of time on caller data: a gap h(t) (contact where h <= 0) or
 * its derivative. */
typedef double (*root_fn)(const void *ctx, double t);

/* The ends of [lo, hi] bracket the first point where f is "reached":
 * f <= 0 (dir 1: the gap), f < 0 (dir 2: h' falling through 0), f >= 0
 * (dir 3: h' rising through 0); lo is not reached, hi is. Narrow it to
 * adjacent doubles (or 200 steps) and return hi, the first time known to be
 * reached. Regula falsi
 * (Illinois) alternating with bisection: fast on these smooth monotone
 * pieces, and never slower than halving every second step. */
static inline double roots_bracket(root_fn f, const void *g, double lo, double hi, int dir)
{
	double flo = f(g, lo), fhi = f(g, hi);
	int side = 0;
	for (int k = 0; k < 200; k++) {
		double mid = 0.5 * (lo + hi);
		if (!(mid > lo && mid < hi))
			break;   /* adjacent doubles */
		double x = mid;
		if ((k & 1) == 0 && flo != fhi) {
			x = lo + (hi - lo) * (flo / (flo - fhi));
			if (!(x > lo && x < hi))
				x = mid;
		}
		double fx = f(g, x);
		int below = dir == 1 ? fx <= 0.0 : dir == 2 ? fx < 0.0 : fx >= 0.0;
		if (below) {
			hi = x, fhi = fx;
			if (side == -1) flo *= 0.5;   /* Illinois: the stale end loses weight */
			side = -1;
		} else {
			lo = x, flo = fx;
			if (side == 1) fhi *= 0.5;
			side = 1;
		}
	}
	return hi;
}

/* First contact (h <= 0) in [a, b], on which h is concave (concave = 1: h' does not
 * increase) or convex; INFINITY if none. */
static inline double roots_piece(root_fn h, root_fn dh, const void *g, double a, double b, int concave)
{
	double ha = h(g, a), dha = dh(g, a);
	if (concave) {
		if (dha >= 0.0) {
			/* rising at a; h' only falls: find where it turns */
			if (dh(g, b) >= 0.0)
				return INFINITY;
			a = roots_bracket(dh, g, a, b, 2);
			ha = h(g, a);
		}
		/* h' < 0 from a on: h falls */
		if (ha <= 0.0)
			return a;
		if (h(g, b) > 0.0)
			return INFINITY;
		return roots_bracket(h, g, a, b, 1);
	}
	/* convex: h' only rises; an approach can only be at the start */
	if (dha >= 0.0)
		return INFINITY;
	if (ha <= 0.0)
		return a;
	double m = b;
	if (dh(g, b) >= 0.0)
		m = roots_bracket(dh, g, a, b, 3);   /* h' turns at m: the lowest point */
	if (h(g, m) > 0.0)
		return INFINITY;
	return roots_bracket(h, g, a, m, 1);
}

#endif
