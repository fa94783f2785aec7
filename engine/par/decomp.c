/* Domain decomposition of a cell grid over P ranks along the Morton (Z) curve: owners, border zones, ghost cells, load balancing (pure, no MPI). */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "decomp.h"

struct decomp {
	int dim, ranks;
	int nc[3], periodic[3], bits[3];
	int nbits;              /* sum of bits */
	uint64_t zsize, ncells;
	uint64_t *bounds;       /* ranks + 1 */
};

static int bits_for(int n)
{
	int b = 0;
	while (((int64_t)1 << b) < n)
		b++;
	return b;
}

decomp_t *decomp_create(int dim, const int nc[3], const int periodic[3], int ranks, int *err)
{
	decomp_t *d = NULL;
	int rc = DECOMP_EINVAL;
	if ((dim != 2 && dim != 3) || ranks < 1 || !nc || !periodic)
		goto cleanup;
	int nbits = 0;
	for (int a = 0; a < dim; a++) {
		if (nc[a] < 1)
			goto cleanup;
		nbits += bits_for(nc[a]);
	}
	if (nbits > 62)
		goto cleanup;
	rc = DECOMP_ENOMEM;
	if (!(d = calloc(1, sizeof *d)) || !(d->bounds = calloc((size_t)ranks + 1, sizeof(uint64_t))))
		goto cleanup;
	d->dim = dim;
	d->ranks = ranks;
	d->ncells = 1;
	for (int a = 0; a < 3; a++) {
		d->nc[a] = a < dim ? nc[a] : 1;
		d->periodic[a] = a < dim ? periodic[a] != 0 : 0;
		d->bits[a] = bits_for(d->nc[a]);
		d->ncells *= (uint64_t)d->nc[a];
	}
	d->nbits = nbits;
	d->zsize = (uint64_t)1 << nbits;
	rc = decomp_balance_prefix(d, NULL);
cleanup:
	if (rc != DECOMP_OK) {
		decomp_destroy(d);
		d = NULL;
	}
	if (err)
		*err = rc;
	return d;
}

void decomp_destroy(decomp_t *d)
{
	if (!d)
		return;
	free(d->bounds);
	free(d);
}

int decomp_dim(const decomp_t *d) { return d->dim; }
int decomp_ranks(const decomp_t *d) { return d->ranks; }
uint64_t decomp_zsize(const decomp_t *d) { return d->zsize; }
uint64_t decomp_ncells(const decomp_t *d) { return d->ncells; }
const uint64_t *decomp_bounds(const decomp_t *d) { return d->bounds; }

uint64_t decomp_morton(const decomp_t *d, const int32_t c[3])
{
	uint64_t z = 0;
	int pos = 0;
	for (int l = 0; pos < d->nbits; l++)
		for (int a = 0; a < d->dim; a++)
			if (l < d->bits[a])
				z |= (uint64_t)(((uint32_t)c[a] >> l) & 1u) << pos++;
	return z;
}

int decomp_cell(const decomp_t *d, uint64_t z, int32_t c[3])
{
	int pos = 0;
	c[0] = c[1] = c[2] = 0;
	for (int l = 0; pos < d->nbits; l++)
		for (int a = 0; a < d->dim; a++)
			if (l < d->bits[a])
				c[a] |= (int32_t)(((z >> pos++) & 1u) << l);
	for (int a = 0; a < d->dim; a++)
		if (c[a] >= d->nc[a])
			return 0;
	return 1;
}

int decomp_owner_z(const decomp_t *d, uint64_t z)
{
	/* the last r with bounds[r] <= z (empty ranges share a bound: the
	 * last of them is the one whose range holds z) */
	int lo = 0, hi = d->ranks - 1;
	while (lo < hi) {
		int mid = lo + (hi - lo + 1) / 2;
		if (d->bounds[mid] <= z)
			lo = mid;
		else
			hi = mid - 1;
	}
	return lo;
}

int decomp_owner(const decomp_t *d, const int32_t c[3])
{
	return decomp_owner_z(d, decomp_morton(d, c));
}

int decomp_set_bounds(decomp_t *d, const uint64_t *b)
{
	if (b[0] != 0 || b[d->ranks] != d->zsize)
		return DECOMP_EINVAL;
	for (int r = 0; r < d->ranks; r++)
		if (b[r + 1] < b[r])
			return DECOMP_EINVAL;
	memcpy(d->bounds, b, ((size_t)d->ranks + 1) * sizeof(uint64_t));
	return DECOMP_OK;
}

int decomp_neighbours(const decomp_t *d, const int32_t c[3], int32_t out[26][3])
{
	int n = 0;
	const int span[3] = {1, 1, d->dim == 3 ? 1 : 0};
	for (int dz = -span[2]; dz <= span[2]; dz++)
		for (int dy = -1; dy <= 1; dy++)
			for (int dx = -1; dx <= 1; dx++) {
				const int off[3] = {dx, dy, dz};
				int32_t q[3] = {0, 0, 0};
				int valid = 1, same = 1;
				for (int a = 0; a < d->dim && valid; a++) {
					int32_t x = c[a] + off[a];
					if (x < 0 || x >= d->nc[a]) {
						if (!d->periodic[a])
							valid = 0;
						x = (x + d->nc[a]) % d->nc[a];
					}
					q[a] = x;
					same &= x == c[a];
				}
				if (!valid || same)
					continue;
				int dup = 0;
				for (int k = 0; k < n && !dup; k++)
					dup = out[k][0] == q[0] && out[k][1] == q[1] && out[k][2] == q[2];
				if (dup)
					continue;
				memcpy(out[n++], q, sizeof q);
			}
	return n;
}

static int cmp_u64(const void *a, const void *b)
{
	uint64_t x = *(const uint64_t *)a, y = *(const uint64_t *)b;
	return (x > y) - (x < y);
}

void decomp_rank_free(decomp_rank_t *v)
{
	if (!v)
		return;
	free(v->cells);
	free(v->border);
	free(v->ghost);
	free(v->ghost_owner);
	free(v->neigh);
	memset(v, 0, sizeof *v);
}

/* Append x to a growing array. */
static int push(uint64_t **a, size_t *n, size_t *cap, uint64_t x)
{
	if (*n == *cap) {
		size_t c = *cap ? 2 * *cap : 64;
		uint64_t *p = realloc(*a, c * sizeof(uint64_t));
		if (!p)
			return DECOMP_ENOMEM;
		*a = p;
		*cap = c;
	}
	(*a)[(*n)++] = x;
	return DECOMP_OK;
}

int decomp_rank_build(const decomp_t *d, int rank, decomp_rank_t *out)
{
	int rc = DECOMP_EINVAL;
	size_t ccap = 0, bcap = 0, gcap = 0;
	memset(out, 0, sizeof *out);
	out->rank = rank;
	if (rank < 0 || rank >= d->ranks)
		goto cleanup;
	rc = DECOMP_OK;
	for (uint64_t z = d->bounds[rank]; z < d->bounds[rank + 1] && rc == DECOMP_OK; z++) {
		int32_t c[3], nb[26][3];
		if (!decomp_cell(d, z, c))
			continue;
		rc = push(&out->cells, &out->ncells, &ccap, z);
		int n = decomp_neighbours(d, c, nb), foreign = 0;
		for (int k = 0; k < n && rc == DECOMP_OK; k++) {
			uint64_t q = decomp_morton(d, nb[k]);
			if (q >= d->bounds[rank] && q < d->bounds[rank + 1])
				continue;
			foreign = 1;
			rc = push(&out->ghost, &out->nghost, &gcap, q);
		}
		if (foreign && rc == DECOMP_OK)
			rc = push(&out->border, &out->nborder, &bcap, z);
	}
	if (rc != DECOMP_OK)
		goto cleanup;
	/* ghosts: sorted, each once, with their owners */
	if (out->nghost) {
		qsort(out->ghost, out->nghost, sizeof(uint64_t), cmp_u64);
		size_t m = 1;
		for (size_t k = 1; k < out->nghost; k++)
			if (out->ghost[k] != out->ghost[m - 1])
				out->ghost[m++] = out->ghost[k];
		out->nghost = m;
	}
	rc = DECOMP_ENOMEM;
	if (!(out->ghost_owner = malloc((out->nghost + 1) * sizeof(int))) ||
	    !(out->neigh = malloc(((size_t)d->ranks + 1) * sizeof(int))))
		goto cleanup;
	for (size_t k = 0; k < out->nghost; k++)
		out->ghost_owner[k] = decomp_owner_z(d, out->ghost[k]);
	/* neighbour ranks: the ghosts' owners, each once, ascending (ghosts are
	 * in Z order and ranges are sorted, so owners are non-decreasing) */
	out->nneigh = 0;
	for (size_t k = 0; k < out->nghost; k++)
		if (out->nneigh == 0 || out->neigh[out->nneigh - 1] != out->ghost_owner[k])
			out->neigh[out->nneigh++] = out->ghost_owner[k];
	rc = DECOMP_OK;
cleanup:
	if (rc != DECOMP_OK)
		decomp_rank_free(out);
	return rc;
}

/* Prefix sums S[z] = cost of ids < z over the whole Z space (padding ids
 * hold 0: the caller's contract); cost NULL: 1 per real cell. */
static double *prefix_sums(const decomp_t *d, const double *cost)
{
	double *S = malloc((d->zsize + 1) * sizeof(double));
	if (!S)
		return NULL;
	S[0] = 0.0;
	for (uint64_t z = 0; z < d->zsize; z++) {
		int32_t c[3];
		double w = cost ? cost[z] : decomp_cell(d, z, c);
		S[z + 1] = S[z] + w;
	}
	return S;
}

double decomp_loads(const decomp_t *d, const double *cost, double *loads)
{
	double *S = prefix_sums(d, cost), max = 0.0;
	if (!S)
		return -1.0;
	for (int r = 0; r < d->ranks; r++) {
		loads[r] = S[d->bounds[r + 1]] - S[d->bounds[r]];
		if (loads[r] > max)
			max = loads[r];
	}
	double mean = S[d->zsize] / d->ranks;
	free(S);
	return mean > 0.0 ? max / mean : 0.0;
}

int decomp_balance_prefix_keep(decomp_t *d, const double *cost, double tol)
{
	if (!(tol >= 0.0))
		return DECOMP_EINVAL;
	double *S = prefix_sums(d, cost);
	if (!S)
		return DECOMP_ENOMEM;
	if (cost && !(S[d->zsize] > 0.0)) {
		free(S);
		return decomp_balance_prefix_keep(d, NULL, 0.0);
	}
	const double W = S[d->zsize];
	const int P = d->ranks;
	uint64_t z = 0;
	for (int k = 1; k < P; k++) {
		const double T = W * k / P;
		const uint64_t old = d->bounds[k];
		uint64_t b;
		if (tol > 0.0 && old >= d->bounds[k - 1] && fabs(S[old] - T) <= tol * sqrt(T * (1.0 - (double)k / P))) {
			b = old;   /* within the noise of its target: stays */
		} else {
			/* first z with S[z + 1] > T: the target lies in [S[z], S[z + 1]) */
			while (z < d->zsize && S[z + 1] <= T)
				z++;
			b = z;
			if (z < d->zsize && S[z + 1] - T < T - S[z])
				b = z + 1;
		}
		if (b < d->bounds[k - 1])
			b = d->bounds[k - 1];
		d->bounds[k] = b;
	}
	d->bounds[0] = 0;
	d->bounds[P] = d->zsize;
	free(S);
	return DECOMP_OK;
}

int decomp_balance_prefix(decomp_t *d, const double *cost)
{
	return decomp_balance_prefix_keep(d, cost, 0.0);
}

static int is_pow2(uint64_t x) { return x && !(x & (x - 1)); }

int decomp_buddy_init(decomp_t *d)
{
	const uint64_t P = (uint64_t)d->ranks;
	if (!is_pow2(P) || P > d->zsize)
		return DECOMP_EINVAL;
	const uint64_t s = d->zsize / P;
	for (uint64_t r = 0; r <= P; r++)
		d->bounds[r] = r * s;
	return DECOMP_OK;
}

int decomp_balance_buddy(decomp_t *d, const double *cost, int max_moves)
{
	const int P = d->ranks;
	uint64_t *b = d->bounds;
	for (int r = 0; r < P; r++) {
		uint64_t s = b[r + 1] - b[r];
		if (!is_pow2(s) || b[r] % s)
			return DECOMP_EINVAL;
	}
	double *S = prefix_sums(d, cost);
	if (!S)
		return DECOMP_ENOMEM;
#define LOAD(r) (S[b[(r) + 1]] - S[b[(r)]])
	int moves = 0;
	while (moves < max_moves && P >= 3) {
		/* heaviest rank (lowest index on ties) */
		int h = 0;
		for (int r = 1; r < P; r++)
			if (LOAD(r) > LOAD(h))
				h = r;
		const uint64_t sh = b[h + 1] - b[h];
		if (sh < 2)
			break;
		/* lightest pair of buddies not involving h */
		int m = -1;
		double best = 0.0;
		for (int r = 0; r + 1 < P; r++) {
			uint64_t s = b[r + 1] - b[r];
			if (r == h || r + 1 == h || b[r + 2] - b[r + 1] != s || b[r] % (2 * s))
				continue;
			double w = LOAD(r) + LOAD(r + 1);
			if (m < 0 || w < best)
				m = r, best = w;
		}
		if (m < 0)
			break;
		const uint64_t mid = b[h] + sh / 2;
		const double lh = LOAD(h), lo = S[mid] - S[b[h]], hi = S[b[h + 1]] - S[mid];
		double after = best;
		if (lo > after) after = lo;
		if (hi > after) after = hi;
		if (!(after < lh))
			break;
		/* merge m and m + 1 (drop bound m + 1), split h at mid (insert it) */
		int k = m + 1;
		memmove(&b[k], &b[k + 1], (size_t)(P - k) * sizeof(uint64_t));
		/* now P bounds b[0..P-1]; insert mid in order */
		int q = P - 1;
		while (q > 0 && b[q] > mid) {
			b[q + 1] = b[q];
			q--;
		}
		b[q + 1] = mid;
		moves++;
	}
#undef LOAD
	free(S);
	return moves;
}

int decomp_transfers(const uint64_t *old_b, const uint64_t *new_b, int P, decomp_transfer_t *out)
{
	/* merge the two sorted bound lists: between consecutive bounds of
	 * either list both owners are constant */
	int n = 0, i = 0, j = 0;
	uint64_t z = 0;
	const uint64_t end = old_b[P];
	while (z < end) {
		while (i < P - 1 && old_b[i + 1] <= z)
			i++;
		while (j < P - 1 && new_b[j + 1] <= z)
			j++;
		uint64_t z1 = old_b[i + 1] < new_b[j + 1] ? old_b[i + 1] : new_b[j + 1];
		if (i != j) {
			if (n > 0 && out[n - 1].z1 == z && out[n - 1].from == i && out[n - 1].to == j)
				out[n - 1].z1 = z1;
			else
				out[n++] = (decomp_transfer_t){z, z1, i, j};
		}
		z = z1;
	}
	return n;
}
