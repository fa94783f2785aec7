/* Pair correlation: counting sort into cells, each pair of neighbouring cells visited once, minimum-image distances binned. */
#include "gofr.h"

#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#define PI 3.14159265358979323846
/* Cells in all at most this many per particle (+ a few): a huge dilute box gets larger cells, not
 * O(volume) memory (as in clusters.c). */
#define CELLS_PER_PARTICLE 3
#define CELLS_MIN 27

struct gofr {
	int dim;
	size_t n;
	double box[3], cutoff;
	double *spos, *svel;      /* wrapped positions and peculiar velocities in cell order */
	uint32_t *cell_of;        /* particle -> cell */
	uint32_t *start;          /* cell_cap + 1 */
	size_t cell_cap;
};

gofr_t *gofr_create(int dim, size_t n, const double *box, double cutoff)
{
	if ((dim != 2 && dim != 3) || n < 2 || n >= UINT32_MAX || !(cutoff > 0) || !isfinite(cutoff))
		return NULL;
	gofr_t *g = calloc(1, sizeof(*g));
	if (!g)
		return NULL;
	g->dim = dim;
	g->n = n;
	g->cutoff = cutoff;
	g->box[0] = g->box[1] = g->box[2] = 1;
	for (int a = 0; a < dim; a++) {
		if (!(box[a] > 0) || !isfinite(box[a])) {
			free(g);
			return NULL;
		}
		g->box[a] = box[a];
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
	free(g);
}

static inline double wrap(double x, double L)
{
	if (x >= 0.0 && x < L)
		return x;
	x -= L * floor(x / L);
	return (x >= 0.0 && x < L) ? x : 0.0;
}

static inline double min_image(double d, double L)
{
	if (d > 0.5 * L)
		return d - L;
	if (d < -0.5 * L)
		return d + L;
	return d;
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
				d[a] = min_image(pi[a] - pj[a], g->box[a]);
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

int gofr_pairs(gofr_t *g, const double *pos, const double *vel, double r0, double r1, int nb, double *count,
               double *par, double *perp)
{
	if (!g || !pos || !count || nb < 1 || !(r0 >= 0) || !(r1 > r0) || r1 > g->cutoff * (1 + 1e-12) ||
	    (vel && (!par || !perp)))
		return -1;
	const int D = g->dim;
	const size_t n = g->n;
	memset(count, 0, (size_t)nb * sizeof(double));
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
			size_t ci = (size_t)(wrap(pos[i * D + a], g->box[a]) * inv[a]);
			if (ci >= m[a])
				ci = m[a] - 1;
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
		for (int a = 0; a < D; a++) {
			g->spos[(size_t)s * D + a] = wrap(pos[i * D + a], g->box[a]);
			if (vel)
				g->svel[(size_t)s * D + a] = vel[i * D + a] - mean[a];
		}
	}
	memmove(start + 1, start, ncells * sizeof(uint32_t));
	start[0] = 0;

	bins_t b = {r0 * r0, r1 * r1, r0, nb / (r1 - r0), nb, count, par, perp};
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
			if (b0 != b1)
				scan(g, &b, vel != NULL, a0, a1, b0, b1);
		}
	}
	return 0;
}

double gofr_ideal(int dim, size_t n, double volume, double a, double b)
{
	double shell = dim == 2 ? PI * (b * b - a * a) : 4.0 / 3.0 * PI * (b * b * b - a * a * a);
	return 0.5 * (double)n * (double)(n - 1) * shell / volume;
}

int gofr_contact_fit(int dim, size_t n, double volume, double sigma, double width, int nb, const double *count,
                     gofr_contact_t *out)
{
	/* Weighted least squares of y = ln g on x = r - sigma (bin centres),
	 * weights = counts (var ln g = 1/count for Poisson counts). */
	double sw = 0, sx = 0, sy = 0, sxx = 0, sxy = 0, pairs = 0;
	int used = 0;
	for (int k = 0; k < nb; k++) {
		pairs += count[k];
		if (!(count[k] > 0))
			continue;
		double a = sigma + k * width, b = a + width;
		double g = count[k] / gofr_ideal(dim, n, volume, a, b), x = 0.5 * (a + b) - sigma, y = log(g), w = count[k];
		sw += w, sx += w * x, sy += w * y, sxx += w * x * x, sxy += w * x * y;
		used++;
	}
	out->pairs = pairs;
	double det = sw * sxx - sx * sx;
	if (used < 3 || !(det > 0)) {
		out->value = out->se = NAN;
		return -1;
	}
	double b0 = (sxx * sy - sx * sxy) / det;   /* intercept at x = 0 */
	out->value = exp(b0);
	out->se = out->value * sqrt(sxx / det);
	return 0;
}

int gofr_contact(gofr_t *g, const double *pos, double sigma, gofr_contact_t *out)
{
	double count[GOFR_CONTACT_BINS], vol = 1;
	double width = sigma * GOFR_CONTACT_WIDTH / GOFR_CONTACT_BINS;
	if (gofr_pairs(g, pos, NULL, sigma, sigma * (1 + GOFR_CONTACT_WIDTH), GOFR_CONTACT_BINS, count, NULL, NULL)) {
		out->value = out->se = out->pairs = NAN;
		return -1;
	}
	for (int a = 0; a < g->dim; a++)
		vol *= g->box[a];
	return gofr_contact_fit(g->dim, g->n, vol, sigma, width, GOFR_CONTACT_BINS, count, out);
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
