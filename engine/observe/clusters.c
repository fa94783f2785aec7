/* Particle-cluster statistics: union-find over a periodic cell grid, O(N) per call. */
#include "clusters.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "observe/geom.h"

/*
 * Method
 * - Wrap every coordinate into [0, L), counting-sort the particles into a
 *   grid of cells whose edge is at least the cutoff 2*radius + delta, and
 *   keep the wrapped positions in cell order (neighbour scans then read
 *   memory sequentially).
 * - Test each pair in the same or in neighbouring cells once, joining the
 *   two in a union-find (path halving, union by size) over the sorted slots.
 * - Neighbour cells: per axis the distinct offsets among {-1, 0, +1} modulo
 *   the number of cells m ({0} for m = 1, {0, 1} for m = 2), so that tiny
 *   grids visit no cell pair twice; a pair of distinct cells is tested from
 *   its lower index only.
 * - The number of cells is capped at CELLS_PER_PARTICLE * N (+ a few): a
 *   huge dilute box gets larger cells instead of O(volume) memory.
 *
 * Cutoff above half a box edge: the grid then has one cell on that axis,
 * all pairs are tested, and the distance is that of the minimum image. A
 * particle within the cutoff of two images of another still makes one
 * bond, and a cluster joined to its own image is not told apart; such
 * boxes are too small for cluster statistics to mean much anyway.
 */

#define CELLS_PER_PARTICLE 3
#define CELLS_MIN 27
#define NO_LABEL UINT32_MAX

struct clusters {
	int dim;
	size_t n, cap;        /* rows of the next computes (clusters_set_count()); rows allocated */
	const double *radii;  /* clusters_radii(): each row's radius (not owned), or NULL: one radius */
	double rmax;          /* the largest of them */
	double *srad;         /* radii in slot order (with radii) */
	double delta;         /* the gap of the compute in progress */
	int walled[3];        /* clusters_walls(): no periodic image on these axes */
	int valid;            /* labels belong to a successful compute */
	double *spos;         /* n*dim wrapped positions in slot (cell) order */
	uint32_t *cell_of;    /* particle -> cell; later root slot -> label */
	uint32_t *slot_of;    /* particle -> slot */
	uint32_t *parent;     /* union-find over slots */
	uint32_t *size;       /* cluster size, valid at roots */
	uint32_t *label;      /* particle -> label */
	uint32_t *cell_start; /* cell_cap + 1 entries */
	size_t cell_cap;
	uint32_t *ns;         /* n + 1 entries: clusters of size s (after fill_stats) */
	double *sbin_edges;   /* CLUSTERS_SIZE_BINS + 1: size bins for the exponent fit */
	double *sbin_ns, *sbin_count;
	int sbins;
};

clusters_t *clusters_create(int dim, size_t n)
{
	if ((dim != 2 && dim != 3) || n >= NO_LABEL)
		return NULL;
	clusters_t *c = calloc(1, sizeof(*c));
	if (c == NULL)
		return NULL;
	c->dim = dim;
	c->n = c->cap = n;
	size_t m = n ? n : 1; /* malloc(0) may return NULL */
	c->spos = malloc(m * dim * sizeof(double));
	c->cell_of = malloc(m * sizeof(uint32_t));
	c->slot_of = malloc(m * sizeof(uint32_t));
	c->parent = malloc(m * sizeof(uint32_t));
	c->size = malloc(m * sizeof(uint32_t));
	c->label = malloc(m * sizeof(uint32_t));
	/* Dense packings need about one cell per particle; more is grown. */
	c->cell_cap = n + CELLS_MIN;
	c->cell_start = malloc((c->cell_cap + 1) * sizeof(uint32_t));
	c->ns = calloc(m + 1, sizeof(uint32_t));
	c->sbin_edges = malloc((CLUSTERS_SIZE_BINS + 1) * sizeof(double));
	c->sbin_ns = malloc(CLUSTERS_SIZE_BINS * sizeof(double));
	c->sbin_count = malloc(CLUSTERS_SIZE_BINS * sizeof(double));
	if (!c->spos || !c->cell_of || !c->slot_of || !c->parent || !c->size ||
	    !c->label || !c->cell_start || !c->ns || !c->sbin_edges || !c->sbin_ns || !c->sbin_count) {
		clusters_destroy(c);
		return NULL;
	}
	c->sbins = clusters_size_bins(n, c->sbin_edges, NULL);
	return c;
}

void clusters_destroy(clusters_t *c)
{
	if (c == NULL)
		return;
	free(c->spos);
	free(c->cell_of);
	free(c->slot_of);
	free(c->parent);
	free(c->size);
	free(c->label);
	free(c->cell_start);
	free(c->ns);
	free(c->sbin_edges);
	free(c->sbin_ns);
	free(c->sbin_count);
	free(c->srad);
	free(c);
}

int clusters_walls(clusters_t *c, const int *walled)
{
	if (c == NULL || walled == NULL)
		return -1;
	for (int a = 0; a < c->dim; a++)
		c->walled[a] = walled[a] != 0;
	return 0;
}

int clusters_radii(clusters_t *c, const double *radii)
{
	if (c == NULL || radii == NULL)
		return -1;
	double rmax = 0.0;
	for (size_t i = 0; i < c->cap; i++) {
		if (!(radii[i] >= 0.0) || !isfinite(radii[i]))
			return -1;
		rmax = fmax(rmax, radii[i]);
	}
	if (!c->srad && !(c->srad = malloc((c->cap ? c->cap : 1) * sizeof(double))))
		return -2;
	c->radii = radii;
	c->rmax = rmax;
	return 0;
}

int clusters_set_count(clusters_t *c, size_t n)
{
	if (c == NULL || n > c->cap)
		return -1;
	c->n = n;
	c->valid = 0;
	return 0;
}

static inline uint32_t find(uint32_t *parent, uint32_t x)
{
	while (parent[x] != x) {
		parent[x] = parent[parent[x]];
		x = parent[x];
	}
	return x;
}

static inline void unite(clusters_t *c, uint32_t a, uint32_t b)
{
	a = find(c->parent, a);
	b = find(c->parent, b);
	if (a == b)
		return;
	if (c->size[a] < c->size[b]) {
		uint32_t t = a;
		a = b;
		b = t;
	}
	c->parent[b] = a;
	c->size[a] += c->size[b];
}

/* Cells per axis: edge >= cutoff, at most cap cells in all. */
static void grid_shape(int dim, const double *box, double cutoff, double cap,
                       size_t m[3])
{
	double md[3] = { 1.0, 1.0, 1.0 };
	for (int a = 0; a < dim; a++) {
		/* The margin keeps the edge strictly above the cutoff, so that a
		 * rounded cell index never puts a bonded pair two cells apart. */
		double q = floor(box[a] / cutoff * (1.0 - 1e-9));
		md[a] = q < 1.0 ? 1.0 : (q > cap ? cap : q);
	}
	/* Too many cells: shrink the axes that still have more than one cell
	 * by a common factor; an axis pinned at 1 drops out, so at most dim
	 * rounds are needed. */
	for (int round = 0; round < dim; round++) {
		double prod = md[0] * md[1] * md[2];
		if (prod <= cap)
			break;
		int k = 0;
		for (int a = 0; a < dim; a++)
			k += md[a] > 1.0;
		double f = pow(prod / cap, 1.0 / k) * (1.0 + 1e-12);
		for (int a = 0; a < dim; a++)
			if (md[a] > 1.0)
				md[a] = fmax(1.0, floor(md[a] / f));
	}
	if (md[0] * md[1] * md[2] > cap)
		md[0] = md[1] = md[2] = 1.0;
	for (int a = 0; a < 3; a++)
		m[a] = (size_t)md[a];
}

/* Distinct neighbour offsets of one axis with m cells; returns their count. */
static int axis_offsets(size_t m, int off[3])
{
	off[0] = 0;
	if (m == 1)
		return 1;
	off[1] = 1;
	if (m == 2)
		return 2; /* -1 and +1 are the same cell */
	off[2] = -1;
	return 3;
}

/* Test all pairs between slots [a0, a1) and [b0, b1) (same cell: a0 == b0). */
/* The pairs of slots [a0, a1) x [b0, b1) (one cell with itself when a0 == b0) closer than the cutoff:
 * cut2 for every pair, or with radii (mixtures) the pair's own r_i + r_j + delta. Inlined into its two
 * callers, so the one-radius scan has no per-pair test of the mode. */
static inline __attribute__((always_inline)) void scan_cells(clusters_t *c, const double *box, const double *half,
                                                             double cut2, int radii, uint32_t a0, uint32_t a1,
                                                             uint32_t b0, uint32_t b1)
{
	const int dim = c->dim;
	const double *p = c->spos, *rad = c->srad, delta = c->delta;
	for (uint32_t i = a0; i < a1; i++) {
		const double *pi = p + (size_t)i * dim;
		for (uint32_t j = (a0 == b0 ? i + 1 : b0); j < b1; j++) {
			const double *pj = p + (size_t)j * dim;
			double dx = geom_min_image(pi[0] - pj[0], box[0], half[0]);
			double dy = geom_min_image(pi[1] - pj[1], box[1], half[1]);
			double r2 = dx * dx + dy * dy;
			if (dim == 3) {
				double dz = geom_min_image(pi[2] - pj[2], box[2], half[2]);
				r2 += dz * dz;
			}
			if (radii) {
				double cut = rad[i] + rad[j] + delta;
				cut2 = cut * cut;
			}
			if (r2 < cut2)
				unite(c, i, j);
		}
	}
}

static void scan_pair(clusters_t *c, const double *box, const double *half, double cut2,
                      uint32_t a0, uint32_t a1, uint32_t b0, uint32_t b1)
{
	scan_cells(c, box, half, cut2, 0, a0, a1, b0, b1);
}

static void scan_pair_radii(clusters_t *c, const double *box, const double *half, uint32_t a0, uint32_t a1,
                            uint32_t b0, uint32_t b1)
{
	scan_cells(c, box, half, 0.0, 1, a0, a1, b0, b1);
}

/* Weighted least squares slope and intercept of y on x; 0, or -1 when degenerate. */
static int wls(double sw, double sx, double sy, double sxx, double sxy, double *slope, double *icpt)
{
	double det = sw * sxx - sx * sx;
	if (!(det > 0) || !(sw > 0))
		return -1;
	*slope = (sw * sxy - sx * sy) / det;
	*icpt = (sxx * sy - sx * sxy) / det;
	return 0;
}

/* The two fits of clusters.h over c->ns (sizes 1 .. largest). */
static void fit_sizes(clusters_t *c, int dim, clusters_stats_t *out)
{
	double theta = dim == 2 ? 1.0 : 1.5, slope, icpt;
	double sw = 0, sx = 0, sy = 0, sxx = 0, sxy = 0;
	int used = 0;
	out->w = out->exponent = NAN;
	/* Initial form: ln(n_s s^theta) = A - w s, sizes below the largest. */
	for (uint64_t s = 1; s < out->largest; s++) {
		double ns = c->ns[s];
		if (ns <= 0)
			continue;
		double x = (double)s, y = log(ns) + theta * log(x);
		sw += ns, sx += ns * x, sy += ns * y, sxx += ns * x * x, sxy += ns * x * y;
		used++;
	}
	if (used >= 2 && wls(sw, sx, sy, sxx, sxy, &slope, &icpt) == 0)
		out->w = -slope;
	/* Power law over size bins from s = 2, the largest cluster left out. */
	c->ns[out->largest]--;
	clusters_size_distribution(c, c->sbins, c->sbin_edges, c->sbin_ns, c->sbin_count);
	c->ns[out->largest]++;
	sw = sx = sy = sxx = sxy = 0;
	used = 0;
	for (int k = 1; k < c->sbins; k++) {
		double cnt = c->sbin_count[k];
		if (cnt <= 0)
			continue;
		double lo = c->sbin_edges[k], hi = c->sbin_edges[k + 1] - 1;
		double x = log(0.5 * (lo + hi)), y = log(c->sbin_ns[k]);
		sw += cnt, sx += cnt * x, sy += cnt * y, sxx += cnt * x * x, sxy += cnt * x * y;
		used++;
	}
	if (used >= 3 && wls(sw, sx, sy, sxx, sxy, &slope, &icpt) == 0)
		out->exponent = -slope;
}

static void fill_stats(clusters_t *c, clusters_stats_t *out)
{
	memset(out, 0, sizeof(*out));
	out->n_particles = c->n;
	out->w = out->exponent = NAN;
	uint64_t sum2 = 0; /* exact: sum s^2 <= N^2 < 2^64 */
	memset(c->ns, 0, (c->n + 1) * sizeof(uint32_t));
	for (size_t s = 0; s < c->n; s++) {
		if (c->parent[s] != s)
			continue;
		uint64_t sz = c->size[s];
		c->ns[sz]++;
		out->n_clusters++;
		if (sz > out->largest)
			out->largest = sz;
		sum2 += sz * sz;
		int k = 0;
		while ((sz >> (k + 1)) != 0)
			k++;
		out->hist[k]++;
		if (k + 1 > out->n_bins)
			out->n_bins = k + 1;
	}
	if (out->n_clusters == 0)
		return;
	double nc = (double)out->n_clusters;
	out->largest_fraction = (double)out->largest / (double)c->n;
	out->mean_size = (double)c->n / nc;
	out->m2 = (double)sum2 / nc;
	out->m2_reduced = (double)(sum2 - out->largest * out->largest) / nc;
	fit_sizes(c, c->dim, out);
}

int clusters_compute(clusters_t *c, const double *pos, const double *box,
                     double radius, double delta, clusters_stats_t *out)
{
	if (c == NULL || pos == NULL || box == NULL || out == NULL)
		return -1;
	c->valid = 0;
	const int dim = c->dim;
	const size_t n = c->n;
	/* mixtures: cells of edge >= the largest pair cutoff, 2 r_max + delta */
	double cutoff = 2.0 * (c->radii ? c->rmax : radius) + delta;
	if (!(radius >= 0.0) || !isfinite(cutoff) || !(cutoff > 0.0))
		return -1;
	c->delta = delta;
	double L[3] = { 1.0, 1.0, 1.0 };
	for (int a = 0; a < dim; a++) {
		if (!isfinite(box[a]) || !(box[a] > 0.0))
			return -1;
		L[a] = box[a];
	}
	for (size_t k = 0; k < n * dim; k++)
		if (!isfinite(pos[k]))
			return -1;

	/* Cell ids are uint32_t. */
	double cap = fmin((double)CELLS_PER_PARTICLE * n + CELLS_MIN, (double)NO_LABEL - 1);
	size_t m[3];
	grid_shape(dim, L, cutoff, cap, m);
	size_t ncells = m[0] * m[1] * m[2];
	if (ncells > c->cell_cap) {
		uint32_t *cs = realloc(c->cell_start, (ncells + 1) * sizeof(uint32_t));
		if (cs == NULL)
			return -2;
		c->cell_start = cs;
		c->cell_cap = ncells;
	}
	uint32_t *start = c->cell_start;
	double inv[3];
	for (int a = 0; a < 3; a++)
		inv[a] = (double)m[a] / L[a];

	/* Counting sort by cell: count, exclusive prefix sum, place (which
	 * advances start[] to each cell's end), shift back. */
	memset(start, 0, (ncells + 1) * sizeof(uint32_t));
	for (size_t i = 0; i < n; i++) {
		size_t idx = 0;
		for (int a = dim - 1; a >= 0; a--) {
			size_t ci = geom_cell(geom_fold(pos[i * dim + a], L[a], c->walled[a]), inv[a], m[a]);
			idx = idx * m[a] + ci;
		}
		c->cell_of[i] = (uint32_t)idx;
		start[idx]++;
	}
	uint32_t acc = 0;
	for (size_t k = 0; k < ncells; k++) {
		uint32_t cnt = start[k];
		start[k] = acc;
		acc += cnt;
	}
	for (size_t i = 0; i < n; i++) {
		uint32_t s = start[c->cell_of[i]]++;
		c->slot_of[i] = s;
		for (int a = 0; a < dim; a++)
			c->spos[(size_t)s * dim + a] = geom_fold(pos[i * dim + a], L[a], c->walled[a]);
		if (c->radii)
			c->srad[s] = c->radii[i];
	}
	memmove(start + 1, start, ncells * sizeof(uint32_t));
	start[0] = 0;

	for (size_t s = 0; s < n; s++) {
		c->parent[s] = (uint32_t)s;
		c->size[s] = 1;
	}

	int off[3][3], noff[3];
	for (int a = 0; a < 3; a++)
		noff[a] = axis_offsets(m[a], off[a]);
	const double cut2 = cutoff * cutoff;
	double half[3];
	for (int a = 0; a < 3; a++)
		half[a] = c->walled[a] ? INFINITY : 0.5 * L[a];
	size_t idx = 0;
	for (size_t z = 0; z < m[2]; z++)
	for (size_t y = 0; y < m[1]; y++)
	for (size_t x = 0; x < m[0]; x++, idx++) {
		uint32_t a0 = start[idx], a1 = start[idx + 1];
		if (a0 == a1)
			continue;
		for (int oz = 0; oz < noff[2]; oz++)
		for (int oy = 0; oy < noff[1]; oy++)
		for (int ox = 0; ox < noff[0]; ox++) {
			/* (x + m + o) % m: o in {-1, 0, 1}. */
			size_t nx = (x + m[0] + off[0][ox]) % m[0];
			size_t ny = (y + m[1] + off[1][oy]) % m[1];
			size_t nz = (z + m[2] + off[2][oz]) % m[2];
			size_t nb = (nz * m[1] + ny) * m[0] + nx;
			if (nb < idx)
				continue; /* visited from the other cell */
			uint32_t b0 = start[nb], b1 = start[nb + 1];
			if (b0 != b1 && c->radii)
				scan_pair_radii(c, L, half, a0, a1, b0, b1);
			else if (b0 != b1)
				scan_pair(c, L, half, cut2, a0, a1, b0, b1);
		}
	}

	/* Labels in order of first particle; cell_of is free now and maps
	 * a root slot to its label. */
	uint32_t *root_label = c->cell_of;
	for (size_t s = 0; s < n; s++)
		root_label[s] = NO_LABEL;
	uint32_t next = 0;
	for (size_t i = 0; i < n; i++) {
		uint32_t r = find(c->parent, c->slot_of[i]);
		if (root_label[r] == NO_LABEL)
			root_label[r] = next++;
		c->label[i] = root_label[r];
	}
	fill_stats(c, out);
	c->valid = 1;
	return 0;
}

/* UINT32_MAX when i is out of range or the last compute failed. */
uint32_t clusters_label(const clusters_t *c, size_t i)
{
	if (c == NULL || !c->valid || i >= c->n)
		return NO_LABEL;
	return c->label[i];
}

int clusters_size_bins(uint64_t n, double *edges, double *centres)
{
	uint64_t e = 1, next;
	int nb = 0;
	while (e <= n && nb < CLUSTERS_SIZE_BINS) {
		next = e < 17 ? e + 1 : (uint64_t)llround((double)e * 1.189207115002721);   /* 2^(1/4) */
		if (next <= e)
			next = e + 1;
		if (next > n + 1 || nb == CLUSTERS_SIZE_BINS - 1)
			next = n + 1;
		if (edges)
			edges[nb] = (double)e;
		if (centres)
			centres[nb] = 0.5 * (double)(e + next - 1);
		nb++;
		e = next;
	}
	if (edges)
		edges[nb] = (double)e;
	return nb;
}

void clusters_size_distribution(const clusters_t *c, int nb, const double *edges, double *ns, double *count)
{
	for (int k = 0; k < nb; k++) {
		uint64_t lo = (uint64_t)edges[k], hi = (uint64_t)edges[k + 1];
		double cnt = 0;
		for (uint64_t s = lo; s < hi && s <= c->n; s++)
			cnt += c->ns[s];
		ns[k] = cnt / (double)(hi - lo);
		if (count)
			count[k] = cnt;
	}
}
