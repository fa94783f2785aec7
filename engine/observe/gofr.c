/* Pair correlation: counting sort into cells, each pair of neighbouring cells visited once, minimum-image distances binned. */
#include "gofr.h"

#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "observe/geom.h"
#include "rng.h"

#define PI 3.14159265358979323846
/* Cells in all at most this many per particle (+ a few): a huge dilute box gets larger cells, not
 * O(volume) memory (as in clusters.c). */
#define CELLS_PER_PARTICLE 3
#define CELLS_MIN 27

/* The accessible-fraction table with obstacles: radii j * cutoff / FRAC_RADII, j = 0 .. FRAC_RADII, and
 * the Monte Carlo points that estimate it (gofr_obstacles()). */
#define FRAC_RADII 256
#define FRAC_POINTS (1u << 18)

struct gofr {
	int dim;
	size_t n, cap;            /* rows of the next calls (gofr_set_count()); rows allocated */
	double box[3], cutoff;
	double half[3];           /* minimum image threshold per axis: L/2 periodic, INFINITY walled (no image) */
	int walled[3];            /* gofr_walls(): 1 on walled axes */
	double inner[3];          /* edges of the region the centres fill: L, or L - 2 radius on walled axes */
	double lo[3];             /* its lower edge: 0, or radius on walled axes */
	double *frac;             /* obstacles: F(r) at FRAC_RADII + 1 radii (gofr_obstacles()); NULL without */
	double area;              /* obstacles: |A|, the volume the centres can reach */
	double *spos, *svel;      /* wrapped positions and peculiar velocities in cell order */
	uint32_t *cell_of;        /* particle -> cell */
	uint32_t *start;          /* cell_cap + 1 */
	size_t cell_cap;
	/* gofr_species(): K classes, each row's class, and the same in cell order (NULL without) */
	int nsp;
	uint8_t *sp, *ssp;
};

gofr_t *gofr_create(int dim, size_t n, const double *box, double cutoff)
{
	if ((dim != 2 && dim != 3) || n < 2 || n >= UINT32_MAX || !(cutoff > 0) || !isfinite(cutoff))
		return NULL;
	gofr_t *g = calloc(1, sizeof(*g));
	if (!g)
		return NULL;
	g->dim = dim;
	g->n = g->cap = n;
	g->cutoff = cutoff;
	g->box[0] = g->box[1] = g->box[2] = 1;
	for (int a = 0; a < dim; a++) {
		if (!(box[a] > 0) || !isfinite(box[a])) {
			free(g);
			return NULL;
		}
		g->box[a] = box[a];
	}
	for (int a = 0; a < 3; a++) {
		g->half[a] = 0.5 * g->box[a];
		g->inner[a] = g->box[a];
	}
	g->cell_cap = (size_t)CELLS_PER_PARTICLE * n + CELLS_MIN;
	g->spos = malloc(n * dim * sizeof(double));
	g->svel = malloc(n * dim * sizeof(double));
	g->cell_of = malloc(n * sizeof(uint32_t));
	g->start = malloc((g->cell_cap + 1) * sizeof(uint32_t));
	if (!g->spos || !g->svel || !g->cell_of || !g->start) {
		gofr_destroy(g);
		return NULL;
	}
	return g;
}

void gofr_destroy(gofr_t *g)
{
	if (!g)
		return;
	free(g->spos);
	free(g->svel);
	free(g->cell_of);
	free(g->start);
	free(g->frac);
	free(g->sp);
	free(g->ssp);
	free(g);
}

int gofr_species(gofr_t *g, int k, const uint8_t *species)
{
	if (!g || k < 0 || k > GOFR_SPECIES_MAX || (k > 0 && !species))
		return -1;
	if (k == 0) {
		free(g->sp);
		free(g->ssp);
		g->sp = g->ssp = NULL;
		g->nsp = 0;
		return 0;
	}
	for (size_t i = 0; i < g->cap; i++)
		if (species[i] >= k)
			return -1;
	if (!g->sp) {
		g->sp = malloc(g->cap);
		g->ssp = malloc(g->cap);
		if (!g->sp || !g->ssp) {
			free(g->sp);
			free(g->ssp);
			g->sp = g->ssp = NULL;
			g->nsp = 0;
			return -2;
		}
	}
	memcpy(g->sp, species, g->cap);
	g->nsp = k;
	return 0;
}

int gofr_species_count(const gofr_t *g, size_t *count)
{
	if (!g || !g->sp || !count)
		return -1;
	memset(count, 0, (size_t)g->nsp * sizeof(size_t));
	for (size_t i = 0; i < g->n; i++)
		count[g->sp[i]]++;
	return 0;
}

int gofr_set_count(gofr_t *g, size_t n)
{
	if (!g || n > g->cap)
		return -1;
	g->n = n;
	return 0;
}

int gofr_walls(gofr_t *g, const int *walled, double radius)
{
	if (!g || !walled || !(radius >= 0) || !isfinite(radius))
		return -1;
	for (int a = 0; a < g->dim; a++)
		if (walled[a] && !(g->box[a] - 2 * radius > 0))
			return -1;
	for (int a = 0; a < g->dim; a++) {
		g->walled[a] = walled[a] != 0;
		g->half[a] = g->walled[a] ? INFINITY : 0.5 * g->box[a];
		g->inner[a] = g->walled[a] ? g->box[a] - 2 * radius : g->box[a];
		g->lo[a] = g->walled[a] ? radius : 0.0;
	}
	return 0;
}

/* Whether a centre at x (dim coordinates, periodic axes wrapped into [0, L)) lies in the region the centres
 * can reach: inside the walls' region on walled axes, and no closer than the contact distance to any
 * obstacle centre (minimum image on periodic axes). */
static int reachable(const gofr_t *g, const double *x, int k, const double *oc, const double *os)
{
	const int D = g->dim;
	for (int a = 0; a < D; a++)
		if (g->walled[a] && !(x[a] >= g->lo[a] && x[a] <= g->lo[a] + g->inner[a]))
			return 0;
	for (int j = 0; j < k; j++) {
		double d2 = 0.0;
		for (int a = 0; a < D; a++) {
			double d = geom_min_image(x[a] - oc[j * D + a], g->box[a], g->half[a]);
			d2 += d * d;
		}
		if (d2 < os[j] * os[j])
			return 0;
	}
	return 1;
}

/*
 * Uniform independent centres in the reachable region A: the pairs expected in a shell [a, b) are
 * N(N-1)/2 / |A| int_a^b s_D r^(D-1) F(r) dr, with F(r) the probability that x + r u lies in A for x
 * uniform in A and u a uniform direction (|A n (A - d)| / |A| averaged over directions). Both |A| and
 * F are estimated here once, by FRAC_POINTS points uniform in the walls' region (those in A kept) and one
 * direction each, every radius on the same points (common random numbers: F is smooth in r). The
 * binomial error of F is sqrt(F (1 - F) / M) for M points kept: below 1e-3 for M >= 2.5e5 (docs/output.md).
 */
int gofr_obstacles(gofr_t *g, int k, const double *centres, const double *contact)
{
	if (!g || k < 0 || (k > 0 && (!centres || !contact)))
		return -1;
	for (int j = 0; j < k; j++)
		if (!(contact[j] > 0) || !isfinite(contact[j]))
			return -1;
	if (k == 0) {
		free(g->frac);
		g->frac = NULL;
		return 0;
	}
	const int D = g->dim;
	double *frac = calloc(FRAC_RADII + 1, sizeof(double));
	double *oc = malloc((size_t)k * D * sizeof(double));
	if (!frac || !oc) {
		free(frac);
		free(oc);
		return -2;
	}
	for (int j = 0; j < k; j++)
		for (int a = 0; a < D; a++)
			oc[j * D + a] = geom_fold(centres[j * D + a], g->box[a], g->walled[a]);
	rng_t r;
	rng_init(&r, 0x676f6672ULL, 0);   /* fixed: the table is a property of the geometry */
	uint64_t kept = 0;
	double vol = 1.0;
	for (int a = 0; a < D; a++)
		vol *= g->inner[a];
	for (uint32_t m = 0; m < FRAC_POINTS; m++) {
		double x[3], u[3], y[3];
		for (int a = 0; a < D; a++)
			x[a] = g->lo[a] + g->inner[a] * rng_uniform(&r);
		if (D == 2) {
			double th = 2.0 * PI * rng_uniform(&r);
			u[0] = cos(th), u[1] = sin(th);
		} else {
			double z = 2.0 * rng_uniform(&r) - 1.0, ph = 2.0 * PI * rng_uniform(&r), s = sqrt(fmax(0.0, 1 - z * z));
			u[0] = s * cos(ph), u[1] = s * sin(ph), u[2] = z;
		}
		if (!reachable(g, x, k, oc, contact))
			continue;
		kept++;
		for (int j = 0; j <= FRAC_RADII; j++) {
			double rr = g->cutoff * j / FRAC_RADII;
			for (int a = 0; a < D; a++)
				y[a] = geom_fold(x[a] + rr * u[a], g->box[a], g->walled[a]);
			frac[j] += reachable(g, y, k, oc, contact);
		}
	}
	free(oc);
	if (kept == 0) {
		free(frac);
		return -1;
	}
	for (int j = 0; j <= FRAC_RADII; j++)
		frac[j] /= (double)kept;
	free(g->frac);
	g->frac = frac;
	g->area = vol * (double)kept / FRAC_POINTS;
	return 0;
}

/* Cells per axis: edge >= cutoff, at most cap cells in all (shrinking every axis alike). */
static void grid_shape(int dim, const double *box, double cutoff, double cap, size_t m[3])
{
	double md[3] = {1, 1, 1};
	for (int a = 0; a < dim; a++) {
		double q = floor(box[a] / cutoff * (1.0 - 1e-9));
		md[a] = q < 1 ? 1 : q;
	}
	while (md[0] * md[1] * md[2] > cap) {
		for (int a = 0; a < dim; a++)
			md[a] = md[a] > 1 ? floor(md[a] / 2) : 1;
	}
	for (int a = 0; a < 3; a++)
		m[a] = (size_t)md[a];
}

/* Distinct neighbour offsets of an axis with m cells ({0}, {0, 1} or {0, 1, -1}). */
static int axis_offsets(size_t m, int off[3])
{
	off[0] = 0;
	if (m == 1)
		return 1;
	off[1] = 1;
	if (m == 2)
		return 2;
	off[2] = -1;
	return 3;
}

typedef struct {
	double r0sq, r1sq, r0, inv_dr;
	int nb;
	double *count, *par, *perp;
	/* by species class (scan_species()): K classes; only >= 0 counts that pair class alone into count[nb],
	 * else class p into count[p nb .. p nb + nb) */
	int K, only;
} bins_t;

static void scan(const gofr_t *g, const bins_t *b, int with_vel, uint32_t a0, uint32_t a1, uint32_t b0, uint32_t b1)
{
	const int D = g->dim;
	const double *p = g->spos, *w = g->svel;
	for (uint32_t i = a0; i < a1; i++) {
		const double *pi = p + (size_t)i * D;
		for (uint32_t j = (a0 == b0 ? i + 1 : b0); j < b1; j++) {
			const double *pj = p + (size_t)j * D;
			double d[3] = {0, 0, 0}, r2 = 0;
			for (int a = 0; a < D; a++) {
				d[a] = geom_min_image(pi[a] - pj[a], g->box[a], g->half[a]);
				r2 += d[a] * d[a];
			}
			if (r2 >= b->r1sq || r2 < b->r0sq)
				continue;
			double r = sqrt(r2);
			int k = (int)((r - b->r0) * b->inv_dr);
			if (k >= b->nb)
				k = b->nb - 1;   /* rounding at the upper edge */
			if (k < 0)
				k = 0;
			b->count[k] += 1;
			if (with_vel && r > 0) {
				const double *wi = w + (size_t)i * D, *wj = w + (size_t)j * D;
				double pi_e = 0, pj_e = 0, dot = 0;
				for (int a = 0; a < D; a++) {
					pi_e += wi[a] * d[a];
					pj_e += wj[a] * d[a];
					dot += wi[a] * wj[a];
				}
				double pp = pi_e * pj_e / r2;
				b->par[k] += pp;
				b->perp[k] += dot - pp;
			}
		}
	}
}

/* The same for species classes (gofr_pairs_species()): a loop of its own, so that the one-species scan
 * tests nothing more per pair. */
static void scan_species(const gofr_t *g, const bins_t *b, uint32_t a0, uint32_t a1, uint32_t b0, uint32_t b1)
{
	const int D = g->dim, K = b->K;
	const double *p = g->spos;
	for (uint32_t i = a0; i < a1; i++) {
		const double *pi = p + (size_t)i * D;
		for (uint32_t j = (a0 == b0 ? i + 1 : b0); j < b1; j++) {
			const double *pj = p + (size_t)j * D;
			double r2 = 0;
			for (int a = 0; a < D; a++) {
				double d = geom_min_image(pi[a] - pj[a], g->box[a], g->half[a]);
				r2 += d * d;
			}
			if (r2 >= b->r1sq || r2 < b->r0sq)
				continue;
			int c = gofr_pair_class(K, g->ssp[i], g->ssp[j]);
			if (b->only >= 0 && c != b->only)
				continue;
			int k = (int)((sqrt(r2) - b->r0) * b->inv_dr);
			if (k >= b->nb)
				k = b->nb - 1;   /* rounding at the upper edge */
			if (k < 0)
				k = 0;
			b->count[(b->only >= 0 ? 0 : (size_t)c * b->nb) + k] += 1;
		}
	}
}

static int pairs_impl(gofr_t *g, const double *pos, const double *vel, double r0, double r1, int nb, double *count,
                      double *par, double *perp, int K, int only)
{
	if (!g || !pos || !count || nb < 1 || !(r0 >= 0) || !(r1 > r0) || r1 > g->cutoff * (1 + 1e-12) ||
	    (vel && (!par || !perp)) || (K > 0 && (K != g->nsp || vel)))
		return -1;
	const int D = g->dim;
	const size_t n = g->n;
	memset(count, 0, (size_t)nb * (K > 0 && only < 0 ? (size_t)gofr_pair_classes(K) : 1) * sizeof(double));
	if (vel) {
		memset(par, 0, (size_t)nb * sizeof(double));
		memset(perp, 0, (size_t)nb * sizeof(double));
	}
	size_t m[3];
	grid_shape(D, g->box, r1, (double)g->cell_cap, m);
	size_t ncells = m[0] * m[1] * m[2];
	uint32_t *start = g->start;
	double inv[3];
	for (int a = 0; a < 3; a++)
		inv[a] = (double)m[a] / g->box[a];

	/* Counting sort by cell (as in clusters.c). */
	memset(start, 0, (ncells + 1) * sizeof(uint32_t));
	for (size_t i = 0; i < n; i++) {
		size_t idx = 0;
		for (int a = D - 1; a >= 0; a--) {
			size_t ci = geom_cell(geom_fold(pos[i * D + a], g->box[a], g->walled[a]), inv[a], m[a]);
			idx = idx * m[a] + ci;
		}
		g->cell_of[i] = (uint32_t)idx;
		start[idx]++;
	}
	uint32_t acc = 0;
	for (size_t k = 0; k < ncells; k++) {
		uint32_t c = start[k];
		start[k] = acc;
		acc += c;
	}
	double mean[3] = {0, 0, 0};
	if (vel) {
		for (size_t i = 0; i < n; i++)
			for (int a = 0; a < D; a++)
				mean[a] += vel[i * D + a];
		for (int a = 0; a < D; a++)
			mean[a] /= (double)n;
	}
	for (size_t i = 0; i < n; i++) {
		uint32_t s = start[g->cell_of[i]]++;
		if (K > 0)
			g->ssp[s] = g->sp[i];
		for (int a = 0; a < D; a++) {
			g->spos[(size_t)s * D + a] = geom_fold(pos[i * D + a], g->box[a], g->walled[a]);
			if (vel)
				g->svel[(size_t)s * D + a] = vel[i * D + a] - mean[a];
		}
	}
	memmove(start + 1, start, ncells * sizeof(uint32_t));
	start[0] = 0;

	bins_t b = {r0 * r0, r1 * r1, r0, nb / (r1 - r0), nb, count, par, perp, K, only};
	int off[3][3], noff[3];
	for (int a = 0; a < 3; a++)
		noff[a] = axis_offsets(m[a], off[a]);
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
			size_t nx = (x + m[0] + off[0][ox]) % m[0];
			size_t ny = (y + m[1] + off[1][oy]) % m[1];
			size_t nz = (z + m[2] + off[2][oz]) % m[2];
			size_t nbr = (nz * m[1] + ny) * m[0] + nx;
			if (nbr < idx)
				continue;   /* visited from the other cell */
			uint32_t b0 = start[nbr], b1 = start[nbr + 1];
			if (b0 == b1)
				continue;
			if (K > 0)
				scan_species(g, &b, a0, a1, b0, b1);
			else
				scan(g, &b, vel != NULL, a0, a1, b0, b1);
		}
	}
	return 0;
}

int gofr_pairs(gofr_t *g, const double *pos, const double *vel, double r0, double r1, int nb, double *count,
               double *par, double *perp)
{
	return pairs_impl(g, pos, vel, r0, r1, nb, count, par, perp, 0, -1);
}

int gofr_pairs_species(gofr_t *g, const double *pos, double r0, double r1, int nb, double *count)
{
	if (!g || g->nsp < 1)
		return -1;
	return pairs_impl(g, pos, NULL, r0, r1, nb, count, NULL, NULL, g->nsp, -1);
}

double gofr_ideal(int dim, size_t n, double volume, double a, double b)
{
	double shell = dim == 2 ? PI * (b * b - a * a) : 4.0 / 3.0 * PI * (b * b * b - a * a * a);
	return 0.5 * (double)n * (double)(n - 1) * shell / volume;
}

/*
 * Uniform independent centres in the region of edges inner[a]: the difference along a periodic axis is
 * uniform (density 1/L), along a walled one triangular, (1 - |x|/L)/L for |x| < L. The pairs expected in
 * the shell [a, b) are N(N-1)/2 / V int_a^b r^(D-1) W(r) dr with W(r) the integral over directions n of
 * prod_walled (1 - r |n_a| / L_a) (exact for r below every walled L_a). With c_a = 1/L_a on walled axes,
 * 0 on periodic ones, S1 = sum c_a, S2 = sum_{a<b} c_a c_b, S3 = c_x c_y c_z:
 *   2D: W = 2 pi - 4 S1 r + 2 S2 r^2   (int |cos| = 4, int |cos sin| = 2 over the circle);
 *   3D: W = 4 pi - 2 pi S1 r + 8/3 S2 r^2 - S3 r^3   (int |n_x| = 2 pi, int |n_x n_y| = 8/3,
 *       int |n_x n_y n_z| = 1 over the sphere).
 * One walled axis: the fraction of the shell inside is 1 - 2r/(pi L) (2D), 1 - r/(2L) (3D).
 */
static double ideal_box(int dim, size_t n, const double *box, const int *walled, const double *inner, double a,
                        double b)
{
	double c[3] = {0, 0, 0}, vol = 1;
	int any = 0;
	for (int k = 0; k < dim; k++) {
		if (walled[k]) {
			c[k] = 1.0 / inner[k];
			any = 1;
		}
	}
	if (!any)
		return gofr_ideal(dim, n, box[0] * box[1] * (dim == 3 ? box[2] : 1), a, b);
	for (int k = 0; k < dim; k++)
		vol *= inner[k];
	double s1 = c[0] + c[1] + c[2], s2 = c[0] * c[1] + c[0] * c[2] + c[1] * c[2], s3 = c[0] * c[1] * c[2];
	double a2 = a * a, b2 = b * b, a3 = a2 * a, b3 = b2 * b, a4 = a2 * a2, b4 = b2 * b2;
	double shell;
	if (dim == 2)
		shell = PI * (b2 - a2) - 4.0 / 3.0 * s1 * (b3 - a3) + 0.5 * s2 * (b4 - a4);
	else
		shell = 4.0 / 3.0 * PI * (b3 - a3) - 0.5 * PI * s1 * (b4 - a4) + 8.0 / 15.0 * s2 * (b4 * b - a4 * a) -
		        s3 / 6.0 * (b3 * b3 - a3 * a3);
	return 0.5 * (double)n * (double)(n - 1) * shell / vol;
}

/* With obstacles: N(N-1)/2 / |A| int_a^b s_D r^(D-1) F(r) dr, F linear between the table's radii; each
 * piece integrated by Simpson's rule, exact for r^(D-1) times a linear function (degree <= 3). */
static double ideal_table(const gofr_t *g, size_t n, double a, double b)
{
	const double h = g->cutoff / FRAC_RADII, sD = g->dim == 2 ? 2.0 * PI : 4.0 * PI;
	double sum = 0.0;
	a = fmax(a, 0.0);
	b = fmin(b, g->cutoff);
	while (a < b) {
		int j = (int)fmin(floor(a / h), FRAC_RADII - 1);
		double e = fmin(b, (j + 1) * h);
		if (!(e > a))
			e = b;   /* rounding at a node */
		double fa, fm, fe, m = 0.5 * (a + e);
#define F(x) (g->frac[j] + (g->frac[j + 1] - g->frac[j]) * ((x) / h - j))
		fa = F(a), fm = F(m), fe = F(e);
#undef F
		double pa = g->dim == 2 ? a : a * a, pm = g->dim == 2 ? m : m * m, pe = g->dim == 2 ? e : e * e;
		sum += (e - a) / 6.0 * (pa * fa + 4.0 * pm * fm + pe * fe);
		a = e;
	}
	return 0.5 * (double)n * (double)(n - 1) * sD * sum / g->area;
}

static double ideal_of(const gofr_t *g, size_t n, double a, double b)
{
	return g->frac ? ideal_table(g, n, a, b) : ideal_box(g->dim, n, g->box, g->walled, g->inner, a, b);
}

double gofr_ideal_in(const gofr_t *g, double a, double b)
{
	return ideal_of(g, g->n, a, b);
}

double gofr_ideal_class(const gofr_t *g, double pairs, double a, double b)
{
	if (g->n < 2)
		return NAN;
	/* the ideal count is proportional to the number of pairs when every row fills the same region */
	return ideal_of(g, g->n, a, b) * pairs / (0.5 * (double)g->n * (double)(g->n - 1));
}

/* The contact fit with the ideal pair counts of a geometry (g, or a periodic box of edges box when g is NULL). */
static int contact_fit(const gofr_t *g, int dim, size_t n, const double *box, const int *walled, const double *inner,
                       double sigma, double width, int nb, const double *count, double scale, gofr_contact_t *out)
{
	/*
	 * Poisson maximum likelihood of g(r) = exp(a + b x), x = r - sigma at the bin centres: count k has mean
	 * mu_k = I_k exp(a + b x_k), I_k the ideal-gas pairs of bin k. A least-squares fit of ln(count) weighted
	 * by the counts themselves (what this was before) is biased by about +1/(2 mu) per bin: E[c ln c] / E[c]
	 * = ln mu + 1/(2 mu) for Poisson c; with a few tens of pairs per bin and snapshot that was +1-2% on
	 * g(sigma), in every snapshot alike, so averaging did not remove it (measured against the virial g(sigma),
	 * tests/partial_gofr_test.sh). The likelihood's bias is O(1 / all pairs of the window). Newton's method
	 * on the concave log-likelihood from the least-squares start, step halved while the likelihood falls.
	 */
	double I[GOFR_FIT_BINS_MAX], x[GOFR_FIT_BINS_MAX];
	double sw = 0, sx = 0, sy = 0, sxx = 0, sxy = 0, pairs = 0;
	int used = 0;
	out->value = out->se = NAN;
	out->pairs = NAN;
	if (nb < 1 || nb > GOFR_FIT_BINS_MAX)
		return -1;
	for (int k = 0; k < nb; k++) {
		double a = sigma + k * width, b = a + width;
		I[k] = scale * (g ? ideal_of(g, n, a, b) : ideal_box(dim, n, box, walled, inner, a, b));
		x[k] = 0.5 * (a + b) - sigma;
		pairs += count[k];
		if (!(count[k] > 0) || !(I[k] > 0))
			continue;
		double y = log(count[k] / I[k]), w = count[k];
		sw += w, sx += w * x[k], sy += w * y, sxx += w * x[k] * x[k], sxy += w * x[k] * y;
		used++;
	}
	out->pairs = pairs;
	double det = sw * sxx - sx * sx;
	if (used < 3 || !(det > 0))
		return -1;
	double a0 = (sxx * sy - sx * sxy) / det, b0 = (sw * sxy - sx * sy) / det;
#define LOGLIK(A, B, L) do { L = 0; for (int k = 0; k < nb; k++) \
		L += count[k] * ((A) + (B) * x[k]) - I[k] * exp((A) + (B) * x[k]); } while (0)
	double ll, f00 = 0, f01 = 0, f11 = 0;
	LOGLIK(a0, b0, ll);
	for (int it = 0; it < 100; it++) {
		double g0 = 0, g1 = 0;
		f00 = f01 = f11 = 0;
		for (int k = 0; k < nb; k++) {
			double mu = I[k] * exp(a0 + b0 * x[k]);
			g0 += count[k] - mu, g1 += x[k] * (count[k] - mu);
			f00 += mu, f01 += mu * x[k], f11 += mu * x[k] * x[k];
		}
		double fd = f00 * f11 - f01 * f01;
		if (!(fd > 0))
			return -1;
		double da = (f11 * g0 - f01 * g1) / fd, db = (f00 * g1 - f01 * g0) / fd, step = 1, l2 = ll;
		for (int h = 0; h < 40; h++, step *= 0.5) {
			LOGLIK(a0 + step * da, b0 + step * db, l2);
			if (l2 >= ll)
				break;
		}
		if (!(l2 >= ll))
			break;   /* no ascent left: at the maximum to rounding */
		a0 += step * da, b0 += step * db, ll = l2;
		if (fabs(step * da) < 1e-13 && fabs(step * db) * width * nb < 1e-13)
			break;
	}
#undef LOGLIK
	/* standard error of a from the Fisher information at the maximum: var(a) = F11 / det F */
	double fd = f00 * f11 - f01 * f01;
	if (!(fd > 0) || !isfinite(a0))
		return -1;
	out->value = exp(a0);
	out->se = out->value * sqrt(f11 / fd);
	return 0;
}

int gofr_contact_fit(int dim, size_t n, double volume, double sigma, double width, int nb, const double *count,
                     gofr_contact_t *out)
{
	/* a periodic box of that volume: only the product of the edges enters */
	const double box[3] = {volume, 1, 1};
	const int walled[3] = {0, 0, 0};
	return contact_fit(NULL, dim, n, box, walled, box, sigma, width, nb, count, 1.0, out);
}

int gofr_contact(gofr_t *g, const double *pos, double sigma, gofr_contact_t *out)
{
	double count[GOFR_CONTACT_BINS];
	double width = sigma * GOFR_CONTACT_WIDTH / GOFR_CONTACT_BINS;
	if (gofr_pairs(g, pos, NULL, sigma, sigma * (1 + GOFR_CONTACT_WIDTH), GOFR_CONTACT_BINS, count, NULL, NULL)) {
		out->value = out->se = out->pairs = NAN;
		return -1;
	}
	return contact_fit(g, g->dim, g->n, g->box, g->walled, g->inner, sigma, width, GOFR_CONTACT_BINS, count, 1.0, out);
}

int gofr_contact_species(gofr_t *g, const double *pos, int a, int b, double sigma, gofr_contact_t *out)
{
	double count[GOFR_CONTACT_BINS];
	double width = sigma * GOFR_CONTACT_WIDTH / GOFR_CONTACT_BINS;
	size_t nk[GOFR_SPECIES_MAX];
	out->value = out->se = out->pairs = NAN;
	if (!g || g->nsp < 1 || a < 0 || b < 0 || a >= g->nsp || b >= g->nsp || g->n < 2 ||
	    gofr_species_count(g, nk) != 0 ||
	    pairs_impl(g, pos, NULL, sigma, sigma * (1 + GOFR_CONTACT_WIDTH), GOFR_CONTACT_BINS, count, NULL, NULL,
	               g->nsp, gofr_pair_class(g->nsp, a, b)))
		return -1;
	double pairs = a == b ? 0.5 * (double)nk[a] * ((double)nk[a] - 1) : (double)nk[a] * (double)nk[b];
	if (!(pairs > 0))
		return -1;
	double scale = pairs / (0.5 * (double)g->n * (double)(g->n - 1));
	return contact_fit(g, g->dim, g->n, g->box, g->walled, g->inner, sigma, width, GOFR_CONTACT_BINS, count, scale,
	                   out);
}

double gofr_contact_rate(int dim, double nu, double radius, double mass, double temp, double rate)
{
	if (!(nu > 0) || !(temp > 0) || !isfinite(rate))
		return NAN;
	return rate * sqrt(PI) * radius / (dim * pow(2, dim - 1) * nu * sqrt(temp / mass));
}

double gofr_contact_virial(int dim, double nu, double restitution, double z)
{
	if (!(nu > 0) || !isfinite(z))
		return NAN;
	return (z - 1) / (0.5 * (1 + restitution) * pow(2, dim - 1) * nu);
}
