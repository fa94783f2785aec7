/* Tests of the Morton-order domain decomposition (engine/par/decomp): ids, ownership, border and ghost cells against brute force, balancing. */
#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "tap.h"
#include "par/decomp.h"

/* Brute-force owner: linear scan of the bounds (independent of the
 * library's binary search). */
static int owner_linear(const decomp_t *d, uint64_t z)
{
	const uint64_t *b = decomp_bounds(d);
	for (int r = 0; r < decomp_ranks(d); r++)
		if (b[r] <= z && z < b[r + 1])
			return r;
	return -1;
}

/* Brute-force neighbour relation from coordinates: at most one cell apart
 * on every axis, by the minimum image on periodic axes; a cell is not its
 * own neighbour. Independent of decomp_neighbours(). */
static int adjacent(int dim, const int *nc, const int *per, const int32_t *p, const int32_t *q)
{
	int same = 1;
	for (int a = 0; a < dim; a++) {
		int dd = abs(p[a] - q[a]);
		if (per[a] && nc[a] - dd < dd)
			dd = nc[a] - dd;
		if (dd > 1)
			return 0;
		same &= p[a] == q[a];
	}
	return !same;
}

static int contains(const uint64_t *a, size_t n, uint64_t x)
{
	for (size_t k = 0; k < n; k++)
		if (a[k] == x)
			return 1;
	return 0;
}

static int sorted_unique(const uint64_t *a, size_t n)
{
	for (size_t k = 1; k < n; k++)
		if (a[k] <= a[k - 1])
			return 0;
	return 1;
}

/* Every check of one decomposition against brute force: ownership,
 * contiguity, border, ghosts and their owners, neighbour ranks. */
static void check_grid(int dim, const int *nc, const int *per, int P, const char *what, decomp_t *given)
{
	int err;
	decomp_t *d = given ? given : decomp_create(dim, nc, per, P, &err);
	if (!ok(d != NULL, "%s: created", what))
		return;
	const uint64_t zs = decomp_zsize(d), nreal = decomp_ncells(d);
	const uint64_t *b = decomp_bounds(d);
	/* all real cells: coordinates and Z ids */
	int32_t (*xy)[3] = malloc(nreal * sizeof *xy);
	uint64_t *zid = malloc(nreal * sizeof *zid);
	int *own = malloc(nreal * sizeof *own);
	uint64_t k = 0;
	int32_t c[3] = {0, 0, 0};
	for (c[2] = 0; c[2] < (dim == 3 ? nc[2] : 1); c[2]++)
		for (c[1] = 0; c[1] < nc[1]; c[1]++)
			for (c[0] = 0; c[0] < nc[0]; c[0]++, k++) {
				memcpy(xy[k], c, sizeof c);
				zid[k] = decomp_morton(d, c);
			}
	int bij = 1, owner_ok = 1;
	for (k = 0; k < nreal; k++) {
		int32_t back[3];
		bij &= zid[k] < zs && decomp_cell(d, zid[k], back) == 1 && !memcmp(back, xy[k], sizeof back);
		own[k] = owner_linear(d, zid[k]);
		owner_ok &= own[k] >= 0 && decomp_owner(d, xy[k]) == own[k] && decomp_owner_z(d, zid[k]) == own[k];
	}
	/* ids unique */
	uint64_t *zz = malloc(nreal * sizeof *zz);
	memcpy(zz, zid, nreal * sizeof *zz);
	for (uint64_t i = 1; i < nreal; i++)   /* insertion sort: small grids */
		for (uint64_t j = i; j > 0 && zz[j] < zz[j - 1]; j--) {
			uint64_t t = zz[j]; zz[j] = zz[j - 1]; zz[j - 1] = t;
		}
	ok(bij && sorted_unique(zz, nreal), "%s: Morton ids of the %llu real cells are distinct, < %llu, and decode back",
	   what, (unsigned long long)nreal, (unsigned long long)zs);
	int pad = 1;
	for (uint64_t z = 0; z < zs; z++) {
		int32_t q[3];
		if (!decomp_cell(d, z, q))
			pad &= !contains(zid, nreal, z);
		pad &= decomp_owner_z(d, z) == owner_linear(d, z);
	}
	ok(pad, "%s: padding ids are no cell's; owner lookup of every Z id equals the linear scan", what);
	ok(owner_ok, "%s: owner of every cell (by coordinates and by id) equals the linear scan", what);
	int mono = b[0] == 0 && b[P] == zs;
	for (int r = 0; r < P; r++)
		mono &= b[r] <= b[r + 1];
	ok(mono, "%s: bounds start at 0, end at zsize and are non-decreasing", what);
	/* rank views against brute force */
	uint64_t total = 0;
	int cells_ok = 1, border_ok = 1, ghost_ok = 1, neigh_ok = 1;
	for (int r = 0; r < P; r++) {
		decomp_rank_t v;
		if (decomp_rank_build(d, r, &v) != DECOMP_OK) {
			cells_ok = 0;
			continue;
		}
		total += v.ncells;
		cells_ok &= sorted_unique(v.cells, v.ncells) && sorted_unique(v.border, v.nborder) &&
		            sorted_unique(v.ghost, v.nghost);
		for (size_t i = 0; i < v.ncells; i++)
			cells_ok &= v.cells[i] >= b[r] && v.cells[i] < b[r + 1];   /* contiguous range */
		size_t nb = 0, ng = 0;
		int seen[64] = {0};
		for (k = 0; k < nreal; k++) {
			int is_border = 0, is_ghost = 0;
			for (uint64_t m = 0; m < nreal; m++) {
				if (!adjacent(dim, nc, per, xy[k], xy[m]))
					continue;
				if (own[k] == r && own[m] != r)
					is_border = 1;
				if (own[k] != r && own[m] == r)
					is_ghost = 1;
			}
			if (own[k] == r)
				cells_ok &= contains(v.cells, v.ncells, zid[k]);
			if (is_border) {
				nb++;
				border_ok &= contains(v.border, v.nborder, zid[k]);
			}
			if (is_ghost) {
				ng++;
				int found = 0;
				for (size_t i = 0; i < v.nghost; i++)
					if (v.ghost[i] == zid[k])
						found = 1, ghost_ok &= v.ghost_owner[i] == own[k];
				ghost_ok &= found;
				seen[own[k]] = 1;
			}
		}
		border_ok &= nb == v.nborder;
		ghost_ok &= ng == v.nghost;
		int nn = 0;
		for (int q = 0; q < P; q++)
			if (seen[q]) {
				neigh_ok &= nn < v.nneigh && v.neigh[nn] == q;
				nn++;
			}
		neigh_ok &= nn == v.nneigh;
		decomp_rank_free(&v);
	}
	ok(cells_ok && total == nreal, "%s: every cell owned exactly once, inside its rank's Z range", what);
	ok(border_ok, "%s: border zones equal the brute-force neighbour scan", what);
	ok(ghost_ok, "%s: ghost cells and their owners equal the brute-force scan", what);
	ok(neigh_ok, "%s: neighbour ranks equal the owners of the ghosts", what);
	free(zz);
	free(own);
	free(zid);
	free(xy);
	if (!given)
		decomp_destroy(d);
}

/* Aligned power-of-two blocks (the buddy invariant). */
static int buddy_blocks(const decomp_t *d)
{
	const uint64_t *b = decomp_bounds(d);
	for (int r = 0; r < decomp_ranks(d); r++) {
		uint64_t s = b[r + 1] - b[r];
		if (!s || (s & (s - 1)) || b[r] % s)
			return 0;
	}
	return 1;
}

int main(void)
{
	int err;
	const int per[3] = {1, 1, 1}, open[3] = {0, 0, 0}, mixed[3] = {1, 0, 1};

	/* seed 003 section 3.1: (x, y) = (0, 6) -> 101000_2 = 40 */
	{
		const int nc[3] = {8, 8, 1};
		decomp_t *d = decomp_create(2, nc, per, 1, &err);
		const int32_t c[3] = {0, 6, 0}, e[3] = {6, 0, 0}, f[3] = {7, 7, 0};
		ok(d && decomp_morton(d, c) == 40, "2D Morton id of (0,6) is 40 (seed 003)");
		ok(d && decomp_morton(d, e) == 20 && decomp_morton(d, f) == 63, "(6,0) -> 010100_2 = 20, (7,7) -> 63");
		const int nc3[3] = {4, 4, 4};
		decomp_t *d3 = decomp_create(3, nc3, per, 1, &err);
		const int32_t g[3] = {1, 2, 3};   /* z1 y1 x1 z0 y0 x0 = 1 1 0 1 0 1 */
		ok(d3 && decomp_morton(d3, g) == 53, "3D Morton id of (1,2,3) is 110101_2 = 53");
		decomp_destroy(d3);
		/* 8 x 8 over 4 ranks: equal quarters are the four 4 x 4 quadrants */
		decomp_t *q = decomp_create(2, nc, per, 4, &err);
		const uint64_t *b = q ? decomp_bounds(q) : NULL;
		ok(b && b[1] == 16 && b[2] == 32 && b[3] == 48, "8x8 over 4 ranks: ranges of 16 ids");
		const int32_t c1[3] = {5, 2, 0};
		ok(q && decomp_owner(q, c1) == 1, "cell (5,2) is in the lower right quadrant: rank 1");
		/* periodic wrap: (0,0)'s neighbours include (7,7) only when periodic */
		int32_t nbs[26][3];
		const int32_t o[3] = {0, 0, 0};
		int n = decomp_neighbours(q, o, nbs), wrap = 0;
		for (int k = 0; k < n; k++)
			wrap |= nbs[k][0] == 7 && nbs[k][1] == 7;
		decomp_t *qo = decomp_create(2, nc, open, 4, &err);
		int no = decomp_neighbours(qo, o, nbs), wrap_o = 0;
		for (int k = 0; k < no; k++)
			wrap_o |= nbs[k][0] == 7 && nbs[k][1] == 7;
		ok(n == 8 && wrap && no == 3 && !wrap_o, "periodic: (0,0) has 8 neighbours incl. (7,7); open: 3, not (7,7)");
		decomp_rank_t v, vo;
		ok(decomp_rank_build(q, 0, &v) == DECOMP_OK && v.ncells == 16 && v.nborder == 12 && v.nneigh == 3,
		   "periodic 8x8 / 4: rank 0 (a 4x4 quadrant) has 12 border cells (all but the 2x2 interior) and 3 neighbours");
		ok(decomp_rank_build(qo, 0, &vo) == DECOMP_OK && vo.nborder == 7 && vo.nghost == 9 && vo.nneigh == 3,
		   "open 8x8 / 4: rank 0 has 7 border cells (x = 3 or y = 3), 9 ghosts, 3 neighbours");
		decomp_rank_free(&vo);
		decomp_rank_free(&v);
		decomp_destroy(qo);
		decomp_destroy(q);
		decomp_destroy(d);
	}

	/* bad input */
	{
		const int nc[3] = {4, 0, 4}, ok3[3] = {4, 4, 4};
		ok(!decomp_create(3, nc, per, 2, &err) && err == DECOMP_EINVAL, "a zero-cell axis is refused");
		ok(!decomp_create(4, ok3, per, 2, &err) && err == DECOMP_EINVAL, "dimension 4 is refused");
		ok(!decomp_create(3, ok3, per, 0, &err) && err == DECOMP_EINVAL, "0 ranks are refused");
		decomp_t *d = decomp_create(3, ok3, per, 3, &err);
		uint64_t bad[4] = {0, 30, 20, 64};
		ok(decomp_set_bounds(d, bad) == DECOMP_EINVAL, "decreasing bounds are refused");
		ok(decomp_buddy_init(d) == DECOMP_EINVAL, "buddy blocks need a power-of-two rank count");
		decomp_destroy(d);
	}

	/* brute force on small grids, odd sizes, 2D and 3D, periodic and not */
	{
		const int g1[3] = {5, 7, 1}, g2[3] = {3, 5, 6}, g3[3] = {2, 9, 1}, g4[3] = {1, 4, 3}, g5[3] = {7, 3, 5};
		check_grid(2, g1, per, 3, "2D 5x7 periodic, 3 ranks", NULL);
		check_grid(2, g1, open, 5, "2D 5x7 open, 5 ranks", NULL);
		check_grid(3, g2, per, 4, "3D 3x5x6 periodic, 4 ranks", NULL);
		check_grid(3, g2, mixed, 7, "3D 3x5x6 periodic x,z, open y, 7 ranks", NULL);
		check_grid(2, g3, per, 4, "2D 2x9 periodic (an axis of 2 cells), 4 ranks", NULL);
		check_grid(3, g4, per, 2, "3D 1x4x3 periodic (an axis of 1 cell), 2 ranks", NULL);
		check_grid(3, g5, per, 16, "3D 7x3x5 periodic, 16 ranks", NULL);
		check_grid(2, g1, per, 1, "2D 5x7 periodic, 1 rank", NULL);
	}

	/* equal split: cell counts within one of each other */
	{
		const int nc[3] = {13, 11, 7};
		decomp_t *d = decomp_create(3, nc, per, 6, &err);
		double loads[6];
		double imb = decomp_loads(d, NULL, loads), mn = loads[0], mx = loads[0];
		for (int r = 1; r < 6; r++) {
			if (loads[r] < mn) mn = loads[r];
			if (loads[r] > mx) mx = loads[r];
		}
		ok(mx - mn <= 1.0, "13x11x7 over 6 ranks: cell counts %g..%g differ by at most one (imbalance %.4f)", mn, mx, imb);
		decomp_destroy(d);
	}

	/* balancing on a skewed cost: a dense blob (cost 50) in one corner of a
	 * 3D 16^3 grid over 8 ranks (a clustering gas's collision frequency) */
	{
		const int nc[3] = {16, 16, 16}, P = 8;
		decomp_t *d = decomp_create(3, nc, per, P, &err);
		const uint64_t zs = decomp_zsize(d);
		double *cost = malloc(zs * sizeof(double)), loads[8], maxc = 0.0, W = 0.0;
		for (uint64_t z = 0; z < zs; z++) {
			int32_t c[3];
			decomp_cell(d, z, c);
			double dx = c[0] - 3.5, dy = c[1] - 4.5, dz = c[2] - 2.5;
			cost[z] = (dx * dx + dy * dy + dz * dz < 16.0) ? 50.0 : 1.0;
			W += cost[z];
			if (cost[z] > maxc)
				maxc = cost[z];
		}
		double imb0 = decomp_loads(d, cost, loads);
		ok(decomp_balance_prefix(d, cost) == DECOMP_OK, "prefix balancing runs");
		double imb1 = decomp_loads(d, cost, loads), lmax = 0.0, sum = 0.0;
		for (int r = 0; r < P; r++) {
			sum += loads[r];
			if (loads[r] > lmax)
				lmax = loads[r];
		}
		ok(imb1 < imb0 && lmax <= W / P + maxc, "prefix split: imbalance %.3f -> %.3f; max load %.0f <= W/P + max cell cost = %.0f",
		   imb0, imb1, lmax, W / P + maxc);
		ok(sum == W, "prefix split conserves the total cost");
		check_grid(3, nc, per, P, "16^3 after prefix balancing", d);
		ok(decomp_balance_buddy(d, cost, 8) == DECOMP_EINVAL, "buddy balancing refuses bounds that are not aligned blocks");
		ok(decomp_buddy_init(d) == DECOMP_OK && buddy_blocks(d), "buddy init: 8 aligned blocks");
		double imbb0 = decomp_loads(d, cost, loads);
		int moves = decomp_balance_buddy(d, cost, 64);
		double imbb1 = decomp_loads(d, cost, loads);
		ok(moves > 0 && imbb1 < imbb0 && buddy_blocks(d), "buddy (triple merge/split): %d moves, imbalance %.3f -> %.3f, blocks stay aligned",
		   moves, imbb0, imbb1);
		diag("skewed cost, 8 ranks: static %.3f, prefix %.3f, buddy %.3f", imb0, imb1, imbb1);
		check_grid(3, nc, per, P, "16^3 after buddy balancing", d);
		/* hysteresis: a split already at its targets stays; a huge tolerance
		 * keeps any bounds; otherwise each boundary is kept within tol
		 * deviations of its target or placed where the plain split puts it */
		{
			decomp_balance_prefix(d, cost);
			uint64_t b0[9], b1[9], bp[9];
			memcpy(b0, decomp_bounds(d), sizeof b0);
			ok(decomp_balance_prefix_keep(d, cost, 1.0) == DECOMP_OK && !memcmp(b0, decomp_bounds(d), sizeof b0),
			   "prefix with hysteresis (1 deviation): a split at its targets does not move");
			/* new cost: 100 more in the last cell (rank 7's); the targets
			 * k W / P move by 12.5 k against deviations of ~43 (W / P ~ 2100):
			 * the low boundaries should stay, the high ones move */
			double *c2 = malloc(zs * sizeof(double));
			memcpy(c2, cost, zs * sizeof(double));
			c2[zs - 1] += 100.0;
			decomp_balance_prefix_keep(d, c2, 1e9);
			ok(!memcmp(b0, decomp_bounds(d), sizeof b0), "a huge tolerance keeps every boundary on a new cost");
			decomp_balance_prefix(d, c2);
			memcpy(bp, decomp_bounds(d), sizeof bp);
			decomp_set_bounds(d, b0);
			decomp_balance_prefix_keep(d, c2, 1.0);
			memcpy(b1, decomp_bounds(d), sizeof b1);
			double *S = malloc((zs + 1) * sizeof(double));
			S[0] = 0.0;
			for (uint64_t z = 0; z < zs; z++)
				S[z + 1] = S[z] + c2[z];
			int each = 1, kept = 0, moved = 0;
			for (int k = 1; k < P; k++) {
				double T = S[zs] * k / P, sd = sqrt(T * (1.0 - (double)k / P));
				if (b1[k] == b0[k] && fabs(S[b0[k]] - T) <= sd)
					kept++;
				else if (b1[k] == bp[k])
					moved++;
				else
					each = 0;
			}
			ok(each && kept > 0 && moved > 0 && b1[0] == 0 && b1[P] == zs, "1 deviation on a new cost: %d boundaries kept within "
			   "tolerance, %d moved to the plain split's place", kept, moved);
			free(S);
			free(c2);
			ok(decomp_balance_prefix_keep(d, cost, -1.0) == DECOMP_EINVAL, "a negative tolerance is refused");
		}
		/* a zero cost falls back to equal cell counts */
		memset(cost, 0, zs * sizeof(double));
		ok(decomp_balance_prefix(d, cost) == DECOMP_OK && decomp_bounds(d)[1] == zs / P, "zero cost: equal split");
		free(cost);
		decomp_destroy(d);
	}

	/* balancing with padding (non-power-of-two grid) and empty ranks:
	 * everything concentrated in one cell leaves ranks with no cells */
	{
		const int nc[3] = {6, 5, 1}, P = 5;
		decomp_t *d = decomp_create(2, nc, per, P, &err);
		const uint64_t zs = decomp_zsize(d);
		double *cost = calloc(zs, sizeof(double));
		const int32_t hot[3] = {4, 3, 0};
		cost[decomp_morton(d, hot)] = 1.0;
		ok(decomp_balance_prefix(d, cost) == DECOMP_OK, "one hot cell: prefix balancing runs");
		check_grid(2, nc, per, P, "6x5 with a single hot cell (empty ranks)", d);
		free(cost);
		decomp_destroy(d);
	}

	/* transfers between two decompositions: random bounds (empty ranges
	 * included) against the owner of every id before and after */
	{
		const int nc[3] = {6, 5, 3}, P = 7;
		decomp_t *d = decomp_create(3, nc, per, P, &err);
		const uint64_t zs = decomp_zsize(d);
		uint64_t old_b[8], new_b[8], x = 12345;
		decomp_transfer_t tr[14];
		int all = 1, maximal = 1, rounds = 200, nonzero = 0;
		for (int round = 0; round < rounds; round++) {
			for (int side = 0; side < 2; side++) {
				uint64_t *b = side ? new_b : old_b;
				b[0] = 0;
				b[P] = zs;
				for (int r = 1; r < P; r++) {
					x = x * 6364136223846793005ull + 1442695040888963407ull;
					b[r] = (x >> 33) % (zs + 1);
				}
				for (int r = 1; r < P; r++)   /* sort */
					for (int q = r; q > 1 && b[q] < b[q - 1]; q--) {
						uint64_t t = b[q]; b[q] = b[q - 1]; b[q - 1] = t;
					}
			}
			int n = decomp_transfers(old_b, new_b, P, tr);
			nonzero += n > 0;
			all &= n >= 0 && n <= 2 * P;
			for (int k = 0; k < n; k++) {
				all &= tr[k].z0 < tr[k].z1 && (k == 0 || tr[k].z0 >= tr[k - 1].z1);
				if (k > 0 && tr[k].z0 == tr[k - 1].z1 && tr[k].from == tr[k - 1].from && tr[k].to == tr[k - 1].to)
					maximal = 0;
			}
			decomp_set_bounds(d, old_b);
			int *own_old = malloc(zs * sizeof(int));
			for (uint64_t z = 0; z < zs; z++)
				own_old[z] = owner_linear(d, z);
			decomp_set_bounds(d, new_b);
			for (uint64_t z = 0; z < zs; z++) {
				int on = owner_linear(d, z), in = -1;
				for (int k = 0; k < n; k++)
					if (z >= tr[k].z0 && z < tr[k].z1)
						in = k;
				if (own_old[z] == on)
					all &= in < 0;
				else
					all &= in >= 0 && tr[in].from == own_old[z] && tr[in].to == on;
			}
			free(own_old);
		}
		ok(all && nonzero > rounds / 2, "transfers: %d random pairs of bounds, each id changes hands iff it is in a "
		   "transfer range with its old and new owner; ranges sorted, disjoint, at most 2P", rounds);
		ok(maximal, "transfer ranges are maximal (no two adjacent with the same pair)");
		uint64_t same[8];
		memcpy(same, old_b, sizeof same);
		ok(decomp_transfers(old_b, same, P, tr) == 0, "identical bounds: no transfer");
		decomp_destroy(d);
	}

	plan(tap_n);
	return done_testing();
}
