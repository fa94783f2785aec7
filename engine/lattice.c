/* Lattice starts that N does not fill: stratified choice of the vacant sites. */
#include "lattice.h"
#include <math.h>

/* Draw the vacancy of the next stratum (or none when all are drawn). */
static void next_hole(lattice_fill_t *f)
{
	if (f->k >= f->vac) {
		f->hole = f->sites;
		return;
	}
	/* Stratum k is [lo, lo + len) with lo = floor(k M/V) kept exactly by
	 * integer steps (k M overflows 64 bits for the largest lattices). */
	uint64_t len = f->q;
	f->acc += f->r;
	if (f->acc >= f->vac) {
		f->acc -= f->vac;
		len++;
	}
	/* len <= M < 2^36: the modulo bias is below 2^-28 */
	f->hole = f->lo + rng_u64(f->rng) % len;
	f->lo += len;
	f->k++;
}

void lattice_fill_init(lattice_fill_t *f, uint64_t sites, uint64_t n, rng_t *rng)
{
	f->sites = sites;
	f->vac = n < sites ? sites - n : 0;
	f->q = f->vac ? sites / f->vac : 0;
	f->r = f->vac ? sites % f->vac : 0;
	f->k = f->lo = f->acc = f->j = 0;
	f->rng = rng;
	next_hole(f);
}

uint64_t lattice_fill_next(lattice_fill_t *f)
{
	/* Strata have >= 1 site each, so holes come in increasing order and at
	 * most one lies at any site. */
	while (f->j == f->hole) {
		f->j++;
		next_hole(f);
	}
	return f->j++;
}

double lattice_shape_2d(const double *L, uint64_t n, int64_t *bx, int64_t *by)
{
	double best = -1.0;
	for (int64_t nx = 1; nx <= (int64_t)n; nx++) {
		int64_t ny = ((int64_t)n + nx - 1) / nx;
		if (ny > 1 && (ny & 1))
			ny++;          /* staggered rows need an even count to be periodic */
		double ax = L[0] / nx, ay = L[1] / ny;
		double d = ax;
		if (ny > 1) {
			double diag = sqrt(0.25 * ax * ax + ay * ay);
			if (diag < d) d = diag;
			if (2 * ay < d) d = 2 * ay;
		}
		if (d > best) {
			best = d;
			*bx = nx, *by = ny;
		}
		if (nx > 1 && ax < 0.25 * best)
			break;
	}
	return best;
}

double lattice_shape_3d(const double *L, uint64_t n, int64_t *bn)
{
	double best = -1.0;
	uint64_t cells = (n + 3) / 4;
	for (int64_t nx = 1; nx <= (int64_t)cells; nx++) {
		if (L[0] / nx < 0.25 * best)
			break;
		for (int64_t ny = 1; (uint64_t)(nx * ny) <= cells; ny++) {
			if (L[1] / ny < 0.25 * best)
				break;
			int64_t nz = (int64_t)((cells + nx * ny - 1) / (nx * ny));
			double ax = L[0] / nx, ay = L[1] / ny, az = L[2] / nz;
			double d = fmin(fmin(ax, ay), az);
			d = fmin(d, 0.5 * sqrt(ax * ax + ay * ay));
			d = fmin(d, 0.5 * sqrt(ay * ay + az * az));
			d = fmin(d, 0.5 * sqrt(ax * ax + az * az));
			if (d > best) {
				best = d;
				bn[0] = nx, bn[1] = ny, bn[2] = nz;
			}
		}
	}
	return best;
}
