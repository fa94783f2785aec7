/* Domain decomposition of a cell grid over P ranks along the Morton (Z) curve: owners, border zones, ghost cells, load balancing (pure, no MPI). */
#pragma once

#include <stddef.h>
#include <stdint.h>

/*
 * Contract (issue 14, seed 003 section 3.1-3.2; docs/parallel.md)
 * - Pure computation: no MPI, no I/O, no globals. The parallel engine (a
 *   later slice) calls the same functions on every rank with the same
 *   inputs and so gets the same decomposition everywhere.
 * - Cells: a grid of nc[a] cells per axis (D = 2 or 3), each axis periodic
 *   or not. A cell's Z id interleaves the bits of its coordinates, x the
 *   lowest: level l contributes bit l of x, then of y, then of z, for the
 *   axes that have a bit l (an axis of nc cells has ceil(log2 nc) bits).
 *   For a cubic 2^k grid this is seed 003's z[k]y[k]x[k]...z[1]y[1]x[1];
 *   (x, y) = (0, 6) in an 8 x 8 grid is 40. Sides that are not powers of two
 *   are numbered in the next power of two per axis; the ids of the padding
 *   cells (a coordinate >= nc) belong to no cell and are skipped. The Z
 *   space has zsize = 2^(sum of the bits) ids, at most 2^D times the cells.
 * - Ownership: rank r owns the contiguous Z range [bounds[r], bounds[r+1]),
 *   bounds[0] = 0, bounds[P] = zsize, non-decreasing (a rank may own no real
 *   cell: it is then idle). Owner lookup is a binary search of the P + 1
 *   bounds: O(log P) time and O(P) memory per rank, no per-cell or
 *   per-particle global table.
 * - Neighbours of a cell: the 3^D - 1 cells that differ by at most one in
 *   each coordinate, wrapped on periodic axes, clipped on the others; the
 *   cell itself (axes of 1 or 2 cells) and repeats are dropped.
 * - A rank's view (decomp_rank_build) costs O(range + border * 3^D) time
 *   and O(cells/P + ghosts) memory: its cells, its border zone (own cells
 *   with a neighbour owned by another rank), its ghost ("virtual") cells
 *   (cells of other ranks neighbouring an own cell) with their owners, and
 *   its neighbour ranks.
 * - Balancing takes a cost per Z id (padding ids must hold 0) over the whole
 *   Z space: this is the reference computation; the parallel engine gets
 *   the same prefix sums from each rank's own range and an exclusive scan of
 *   the rank totals.
 */

enum { DECOMP_OK = 0, DECOMP_ENOMEM = -1, DECOMP_EINVAL = -2 };

typedef struct decomp decomp_t;

/* Grid of nc[0..dim-1] cells (each >= 1, at most 2^62 ids in all),
 * periodic[a] != 0 for periodic axes, over ranks >= 1 ranks, split into
 * contiguous Z ranges of equal numbers of real cells (within one cell).
 * NULL with *err set on bad input or no memory. */
decomp_t *decomp_create(int dim, const int nc[3], const int periodic[3], int ranks, int *err);
void decomp_destroy(decomp_t *d);

int decomp_dim(const decomp_t *d);
int decomp_ranks(const decomp_t *d);
uint64_t decomp_zsize(const decomp_t *d);
uint64_t decomp_ncells(const decomp_t *d);   /* real cells: product of nc */

/* Z id of cell c (coordinates in range). */
uint64_t decomp_morton(const decomp_t *d, const int32_t c[3]);
/* Coordinates of Z id z into c; returns 1 for a real cell, 0 for padding. */
int decomp_cell(const decomp_t *d, uint64_t z, int32_t c[3]);

/* Owner rank of Z id z (< zsize) or of cell c. */
int decomp_owner_z(const decomp_t *d, uint64_t z);
int decomp_owner(const decomp_t *d, const int32_t c[3]);

/* The P + 1 range bounds; decomp_set_bounds() checks and installs new ones
 * (DECOMP_EINVAL unless b[0] = 0, b[P] = zsize and non-decreasing). */
const uint64_t *decomp_bounds(const decomp_t *d);
int decomp_set_bounds(decomp_t *d, const uint64_t *b);

/* Neighbour cells of c (see the contract) into out[26]; returns how many. */
int decomp_neighbours(const decomp_t *d, const int32_t c[3], int32_t out[26][3]);

/* One rank's view. Arrays are Z ids in ascending order. */
typedef struct {
	int rank;
	size_t ncells, nborder, nghost;
	uint64_t *cells;      /* own real cells */
	uint64_t *border;     /* own cells with a neighbour of another rank */
	uint64_t *ghost;      /* other ranks' cells neighbouring an own cell */
	int *ghost_owner;     /* owner of each ghost cell */
	int nneigh;
	int *neigh;           /* ranks owning a ghost cell, ascending */
} decomp_rank_t;
int decomp_rank_build(const decomp_t *d, int rank, decomp_rank_t *out);
void decomp_rank_free(decomp_rank_t *v);

/* Cost of each rank under the current bounds into loads[P]; cost has zsize
 * entries, 0 at padding ids (NULL: 1 per real cell). Returns max / mean
 * (1 = perfect; 0 if the total is 0; -1 without memory). */
double decomp_loads(const decomp_t *d, const double *cost, double *loads);

/* Contiguous Z-range split by prefix sums of cost (NULL: 1 per real cell):
 * boundary k at the Z id whose prefix sum is nearest k W / P (W the total),
 * so every rank's load is within one cell's cost of W / P. A zero total
 * falls back to equal cell counts. */
int decomp_balance_prefix(decomp_t *d, const double *cost);

/* What changes hands when bounds old_b become new_b (both P + 1 bounds
 * of the same Z space): the Z ranges [z0, z1) whose owner changes, with
 * old and new owner, in Z order, maximal (adjacent ranges with the same
 * pair merged). At most 2 P ranges; out must hold 2 P. Returns how many.
 * Every rank computes the same list: the particles of a range move from
 * `from` to `to` when a rebalance installs new_b. */
typedef struct {
	uint64_t z0, z1;
	int from, to;
} decomp_transfer_t;
int decomp_transfers(const uint64_t *old_b, const uint64_t *new_b, int P, decomp_transfer_t *out);

/* The prefix split with hysteresis, for costs that are counts (events
 * per cell in a window): boundary k stays where it is while the cost below
 * it is within tol standard deviations of its target k W / P, the
 * deviation of a count being sqrt(T (1 - k / P)) for target T (binomial);
 * otherwise it moves as in decomp_balance_prefix(). tol = 0 is
 * decomp_balance_prefix(). Fewer cells change owner on noisy costs, at the
 * price of loads within about tol deviations of the mean. */
int decomp_balance_prefix_keep(decomp_t *d, const double *cost, double tol);

/* Seed 003's buddy scheme. decomp_buddy_init(): P (a power of two, at most
 * zsize) aligned blocks of zsize / P ids (DECOMP_EINVAL otherwise).
 * decomp_balance_buddy(): the triple merge/split of seed 003 section 3.2,
 * repeated: the heaviest rank whose block has >= 2 ids gives its upper half
 * to a rank freed by merging the lightest pair of buddy blocks (two ranks
 * owning the halves of one aligned block), while that lowers the heaviest
 * rank's load; at most max_moves times. Ranks are renumbered in Z order
 * (bounds stay sorted). Returns the moves made, or DECOMP_EINVAL if the
 * bounds are not aligned power-of-two blocks, DECOMP_ENOMEM. */
int decomp_buddy_init(decomp_t *d);
int decomp_balance_buddy(decomp_t *d, const double *cost, int max_moves);
