/* Fourier grids: in-place FFTW r2c transforms of cloud-in-cell densities, shells and windows from per-axis tables. */
#include "fgrid.h"

#include <fftw3.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "observe/tables.h"

#define PI 3.14159265358979323846

struct fgrid {
	int dim, fields, J;
	size_t m[3];          /* points per axis (1 beyond dim) */
	size_t pad;           /* padded length of the last axis: 2 (m_last / 2 + 1) doubles */
	size_t nreal;         /* doubles per field: m0 (* m1) * pad */
	size_t nmodes;        /* complex modes per field */
	double L[3], h[3], dk, lo2, hi2;
	double **data;        /* fields, fftw_malloc'd (aligned) */
	fftw_plan *plan;
	double *sinc2[3];     /* per axis, per index: sinc^2(k_a h_a / 2)^2 = window factor squared */
	double *cic[3];       /* per axis, per index: 1 - (2/3) sin^2(k_a h_a / 2) = sum over aliases of W^2 */
	double *kax[3];       /* per axis, per index: signed k_a */
	double *shell_w;      /* per shell: number of wave vectors (mode weights summed) */
	double *shell_k;      /* per shell: mean |k| */
};

static size_t last_axis(const fgrid_t *g) { return (size_t)g->dim - 1; }

void fgrid_destroy(fgrid_t *g)
{
	if (!g)
		return;
	for (int f = 0; f < g->fields; f++) {
		if (g->plan && g->plan[f])
			fftw_destroy_plan(g->plan[f]);
		if (g->data && g->data[f])
			fftw_free(g->data[f]);
	}
	free(g->plan);
	free(g->data);
	free(g->shell_w);
	free(g->shell_k);
	for (int a = 0; a < 3; a++) {
		free(g->sinc2[a]);
		free(g->cic[a]);
		free(g->kax[a]);
	}
	free(g);
}

fgrid_t *fgrid_create(int dim, const double *box, const int m[3], int fields)
{
	return fgrid_create_walled(dim, box, m, fields, NULL);
}

fgrid_t *fgrid_create_walled(int dim, const double *box, const int m[3], int fields, const int *walled)
{
	if ((dim != 2 && dim != 3) || fields < 1)
		return NULL;
	int periodic = 0;
	for (int a = 0; a < dim; a++) {
		int w = walled && walled[a];
		if ((!w && m[a] < 4) || !(box[a] > 0) || !isfinite(box[a]))
			return NULL;
		periodic += !w;
	}
	if (!periodic)
		return NULL;
	fgrid_t *g = calloc(1, sizeof(*g));
	if (!g)
		return NULL;
	g->dim = dim;
	g->fields = fields;
	double lmax = 0;
	for (int a = 0; a < 3; a++) {
		int w = a < dim && walled && walled[a];
		/* a walled axis has one grid point: the deposit sums over it, so only k_a = 0 is transformed */
		g->m[a] = a < dim && !w ? (size_t)m[a] : 1;
		g->L[a] = a < dim ? box[a] : 1;
		g->h[a] = g->L[a] / (double)g->m[a];
		if (a < dim && !w)
			lmax = fmax(lmax, g->L[a]);
	}
	g->dk = 2 * PI / lmax;
	g->J = tables_k_shells(dim, box, m, walled);   /* the one formula, shared with admission control */
	g->lo2 = 0.25 * g->dk * g->dk;
	g->hi2 = (g->J + 0.5) * (g->J + 0.5) * g->dk * g->dk;
	size_t ml = g->m[last_axis(g)];
	g->pad = 2 * (ml / 2 + 1);
	g->nreal = (dim == 3 ? g->m[0] * g->m[1] : g->m[0]) * g->pad;
	g->nmodes = g->nreal / 2;
	g->data = calloc((size_t)fields, sizeof(double *));
	g->plan = calloc((size_t)fields, sizeof(fftw_plan));
	if (!g->data || !g->plan)
		goto fail;
	int n[3] = {(int)g->m[0], (int)g->m[1], (int)g->m[2]};
	for (int f = 0; f < fields; f++) {
		g->data[f] = fftw_malloc(g->nreal * sizeof(double));
		if (!g->data[f])
			goto fail;
		/* FFTW_ESTIMATE leaves the array alone and picks the plan without
		 * timing runs, so the same grid always gets the same plan. */
		g->plan[f] = fftw_plan_dft_r2c(dim, n, g->data[f], (fftw_complex *)g->data[f], FFTW_ESTIMATE);
		if (!g->plan[f])
			goto fail;
		memset(g->data[f], 0, g->nreal * sizeof(double));
	}
	for (int a = 0; a < dim; a++) {
		size_t ma = g->m[a];
		g->sinc2[a] = malloc(ma * sizeof(double));
		g->cic[a] = malloc(ma * sizeof(double));
		g->kax[a] = malloc(ma * sizeof(double));
		if (!g->sinc2[a] || !g->cic[a] || !g->kax[a])
			goto fail;
		for (size_t j = 0; j < ma; j++) {
			long q = (long)j <= (long)ma / 2 ? (long)j : (long)j - (long)ma;
			double k = 2 * PI * (double)q / g->L[a], x = 0.5 * k * g->h[a];
			double s = x == 0 ? 1.0 : sin(x) / x;
			g->kax[a][j] = k;
			g->sinc2[a][j] = s * s * s * s;   /* (sinc^2)^2: the CIC window, squared */
			g->cic[a][j] = 1 - 2.0 / 3.0 * sin(x) * sin(x);
		}
	}
	/* Shell populations and mean |k|: geometry only, counted once here. */
	g->shell_w = calloc((size_t)g->J, sizeof(double));
	g->shell_k = calloc((size_t)g->J, sizeof(double));
	if (!g->shell_w || !g->shell_k)
		goto fail;
	fgrid_mode_t md;
	for (size_t i = 0; i < g->nmodes; i++)
		if (fgrid_mode(g, i, &md)) {
			g->shell_k[md.bin] += md.weight * md.kmag;
			g->shell_w[md.bin] += md.weight;
		}
	for (int b = 0; b < g->J; b++)
		g->shell_k[b] = g->shell_w[b] > 0 ? g->shell_k[b] / g->shell_w[b] : (b + 1) * g->dk;
	return g;
fail:
	fgrid_destroy(g);
	return NULL;
}

int fgrid_bins(const fgrid_t *g) { return g->J; }
size_t fgrid_modes(const fgrid_t *g) { return g->nmodes; }

size_t fgrid_memory(const fgrid_t *g)
{
	size_t b = sizeof(*g) + (size_t)g->fields * g->nreal * sizeof(double) + 2 * (size_t)g->J * sizeof(double);
	for (int a = 0; a < g->dim; a++)
		b += 3 * g->m[a] * sizeof(double);
	return b;
}

int fgrid_mode(const fgrid_t *g, size_t i, fgrid_mode_t *md)
{
	const size_t half = g->pad / 2, la = last_axis(g);
	size_t j[3] = {0, 0, 0};
	j[la] = i % half;
	size_t rest = i / half;
	if (g->dim == 3) {
		j[1] = rest % g->m[1];
		j[0] = rest / g->m[1];
	} else {
		j[0] = rest;
	}
	double k2 = 0, w2 = 1, c2 = 1;
	for (int a = 0; a < g->dim; a++) {
		md->k[a] = g->kax[a][j[a]];
		k2 += md->k[a] * md->k[a];
		w2 *= g->sinc2[a][j[a]];
		c2 *= g->cic[a][j[a]];
	}
	if (k2 < g->lo2 || k2 >= g->hi2)
		return 0;
	md->k[2] = g->dim == 3 ? md->k[2] : 0;
	md->kmag = sqrt(k2);
	md->bin = (int)floor(md->kmag / g->dk + 0.5) - 1;
	if (md->bin < 0)
		md->bin = 0;
	if (md->bin >= g->J)
		md->bin = g->J - 1;
	/* The mirror image -k is in the half spectrum only for j_last = 0 and,
	 * for even m, j_last = m/2; every other mode stands for two. */
	size_t ml = g->m[la];
	md->weight = (j[la] == 0 || (ml % 2 == 0 && j[la] == ml / 2)) ? 1.0 : 2.0;
	md->w2 = w2;
	md->alias = c2 - w2;
	return 1;
}

const double *fgrid_coef(const fgrid_t *g, int f, size_t i)
{
	return g->data[f] + 2 * i;
}

void fgrid_axis(const fgrid_t *g, double *edges, double *centres, double *modes)
{
	for (int b = 0; b <= g->J; b++) {
		if (edges)
			edges[b] = (b + 0.5) * g->dk;
		if (b == g->J)
			break;
		if (centres)
			centres[b] = g->shell_k[b];
		if (modes)
			modes[b] = g->shell_w[b];
	}
}

double fgrid_shell_modes(const fgrid_t *g, int b)
{
	return g->shell_w[b];
}

static inline double wrap(double x, double L)
{
	if (x >= 0.0 && x < L)
		return x;
	x -= L * floor(x / L);
	return (x >= 0.0 && x < L) ? x : 0.0;
}

void fgrid_deposit(fgrid_t *g, int f, size_t n, const double *pos, const double *w, int wstride, double shift)
{
	double *d = g->data[f];
	const int D = g->dim;
	memset(d, 0, g->nreal * sizeof(double));
	for (size_t p = 0; p < n; p++) {
		double q = w ? w[p * (size_t)wstride] - shift : 1.0;
		size_t i0[3] = {0, 0, 0}, i1[3] = {0, 0, 0};
		double f1[3] = {0, 0, 0};
		for (int a = 0; a < D; a++) {
			double u = wrap(pos[p * D + a], g->L[a]) / g->h[a];
			size_t i = (size_t)u;
			if (i >= g->m[a])
				i = g->m[a] - 1;
			f1[a] = u - (double)i;
			i0[a] = i;
			i1[a] = i + 1 == g->m[a] ? 0 : i + 1;
		}
		if (D == 2) {
			double *r0 = d + i0[0] * g->pad, *r1 = d + i1[0] * g->pad;
			double wx1 = f1[0], wx0 = 1 - wx1, wy1 = f1[1], wy0 = 1 - wy1;
			r0[i0[1]] += q * wx0 * wy0;
			r0[i1[1]] += q * wx0 * wy1;
			r1[i0[1]] += q * wx1 * wy0;
			r1[i1[1]] += q * wx1 * wy1;
		} else {
			for (int cx = 0; cx < 2; cx++) {
				double wx = cx ? f1[0] : 1 - f1[0];
				size_t ix = cx ? i1[0] : i0[0];
				for (int cy = 0; cy < 2; cy++) {
					double wy = wx * (cy ? f1[1] : 1 - f1[1]);
					double *row = d + (ix * g->m[1] + (cy ? i1[1] : i0[1])) * g->pad;
					row[i0[2]] += q * wy * (1 - f1[2]);
					row[i1[2]] += q * wy * f1[2];
				}
			}
		}
	}
}

void fgrid_forward(fgrid_t *g, int f)
{
	fftw_execute(g->plan[f]);
}
