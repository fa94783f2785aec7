/* Lattice starts that N does not fill: which N of the M sites are occupied, vacancies spread evenly. */
#pragma once

#include <stdint.h>
#include "rng.h"

/*
 * Contract
 * - A lattice start numbers its M sites in its own order (row by row,
 *   plane by plane). When N < M, taking the first N sites leaves every
 *   vacancy at the end, i.e. a slab of the box without particles (issue
 *   19.9). lattice_fill_t hands out the N occupied sites instead, in
 *   increasing order, with the V = M - N vacancies spread by stratified
 *   sampling: the site sequence is cut into V strata of floor or ceil of M/V
 *   consecutive sites (stratum k is [floor(k M/V), floor((k+1) M/V))) and
 *   one site of each, uniform within it, is left empty. So any run of
 *   consecutive sites holds its share of vacancies to within one (exact
 *   along the slowest axis), and within a row the vacancies fall at random
 *   (no columns of vacancies when M/V divides the row length).
 * - Deterministic: the V draws come from rng (one rng_u64() per vacancy,
 *   in order, none when N = M), so the same seed gives the same start.
 * - No allocation; O(1) memory and O(M) time for all the sites.
 */

typedef struct {
	uint64_t sites;      /* M */
	uint64_t vac;        /* V = M - N */
	uint64_t q, r;       /* M = q V + r: strata have q or q + 1 sites */
	uint64_t k;          /* strata done */
	uint64_t lo, acc;    /* start of stratum k; (k r) mod V */
	uint64_t hole;       /* the vacancy of stratum k - 1 not yet passed, or M */
	uint64_t j;          /* next site to hand out */
	rng_t *rng;
} lattice_fill_t;

/* Start handing out n of sites sites (1 <= n <= sites). rng is used by
 * lattice_fill_next() and must outlive f. */
void lattice_fill_init(lattice_fill_t *f, uint64_t sites, uint64_t n, rng_t *rng);
/* The next occupied site (increasing); call it exactly n times. */
uint64_t lattice_fill_next(lattice_fill_t *f);

/* Lattice shapes for N sites in a box of edges L (the ed engine's starts and
 * engine/place.c's region placement use the same ones). 2D: nx columns by ny
 * staggered rows (ny even when > 1, so rows stay periodic), a near-hexagonal
 * lattice; 3D: an FCC lattice of nx*ny*nz cubic cells of 4 sites. Each
 * returns the largest nearest-neighbour distance over the shapes with at
 * least n sites and stores that shape in bx/by or bn[3]. n >= 1, L > 0. */
double lattice_shape_2d(const double *L, uint64_t n, int64_t *bx, int64_t *by);
double lattice_shape_3d(const double *L, uint64_t n, int64_t *bn);
