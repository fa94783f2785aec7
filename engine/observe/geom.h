/* Box geometry shared by the pair observables (clusters, g(r)): wrapping, the minimum image and cell indices on periodic or walled axes. */
#pragma once

#include <math.h>
#include <stddef.h>

/* Into [0, L). x - L*floor(x/L) can round up to L itself: that is 0. */
static inline double geom_wrap(double x, double L)
{
	if (x >= 0.0 && x < L)
		return x;
	x -= L * floor(x / L);
	return (x >= 0.0 && x < L) ? x : 0.0;
}

/* Minimum-image component of a difference of two wrapped coordinates; half = L/2 on periodic axes,
 * INFINITY on walled ones (the plain difference, chosen once per call, no test per pair). */
static inline double geom_min_image(double d, double L, double half)
{
	if (d > half)
		return d - L;
	if (d < -half)
		return d + L;
	return d;
}

/* Periodic axes: folded into [0, L); walled axes: as they are (a centre may sit a little beyond a
 * wall's rest position, below a vibrating wall). */
static inline double geom_fold(double x, double L, int walled)
{
	return walled ? x : geom_wrap(x, L);
}

/* Cell of a coordinate on an axis of m cells (clamped: walled coordinates may lie outside [0, L)). */
static inline size_t geom_cell(double x, double inv, size_t m)
{
	double q = x * inv;
	if (!(q >= 0.0))
		return 0;
	size_t ci = (size_t)q;
	return ci >= m ? m - 1 : ci;
}
