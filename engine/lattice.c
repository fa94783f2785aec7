/* Lattice starts that N does not fill: stratified choice of the vacant sites. */
#include "lattice.h"

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
