/* Coarse-grained fields: per-cell sums of occupation, velocity, squared speed and spin over the instants of an exposure. */
#include "fields.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

struct fields {
	int dim, spin_dim, samples;
	int n[3], periodic[3];
	double box[3], h[3], cell_volume;
	size_t nc, stride;   /* cells; doubles per cell: visits, sum v (dim), sum |v|^2, sum w (spin_dim); with
	                      * fields_masses(): sum m v, sum m |v|^2, then sum m last */
	const double *mass;  /* fields_masses(): each row's mass (not owned), or NULL */
	size_t mrows;
	double *sum;         /* nc * stride */
};

fields_t *fields_create(int dim, const double *box, const int cells[3], const int periodic[3], int spin_dim)
{
	if ((dim != 2 && dim != 3) || (spin_dim != 0 && spin_dim != 1 && spin_dim != 3))
		return NULL;
	double nc = 1.0;
	for (int a = 0; a < dim; a++) {
		if (cells[a] < 1 || !(box[a] > 0) || !isfinite(box[a]))
			return NULL;
		nc *= cells[a];
	}
	if (nc > FIELDS_MAX_CELLS)
		return NULL;
	fields_t *f = calloc(1, sizeof(*f));
	if (!f)
		return NULL;
	f->dim = dim;
	f->spin_dim = spin_dim;
	f->nc = (size_t)nc;
	f->stride = 2 + (size_t)dim + (size_t)spin_dim;
	f->cell_volume = 1.0;
	for (int a = 0; a < 3; a++) {
		f->n[a] = a < dim ? cells[a] : 1;
		f->periodic[a] = a < dim ? periodic[a] != 0 : 0;
		f->box[a] = a < dim ? box[a] : 1.0;
		f->h[a] = f->box[a] / f->n[a];
		if (a < dim)
			f->cell_volume *= f->h[a];
	}
	f->sum = calloc(f->nc * f->stride, sizeof(double));
	if (!f->sum) {
		free(f);
		return NULL;
	}
	return f;
}

void fields_destroy(fields_t *f)
{
	if (!f)
		return;
	free(f->sum);
	free(f);
}

size_t fields_cells(const fields_t *f) { return f->nc; }
int fields_samples(const fields_t *f) { return f->samples; }

void fields_reset(fields_t *f)
{
	memset(f->sum, 0, f->nc * f->stride * sizeof(double));
	f->samples = 0;
}

size_t fields_cell_of(const fields_t *f, const double *x)
{
	size_t c = 0, m = 1;
	for (int a = 0; a < f->dim; a++) {
		double y = x[a];
		if (f->periodic[a])
			y -= f->box[a] * floor(y / f->box[a]);
		double q = floor(y / f->h[a]);
		int i = q < 0 ? 0 : q >= f->n[a] ? f->n[a] - 1 : (int)q;   /* also wrap rounding to L */
		c += (size_t)i * m;
		m *= (size_t)f->n[a];
	}
	return c;
}

int fields_masses(fields_t *f, size_t rows, const double *mass)
{
	if (!f || !mass || rows == 0 || f->samples > 0 || f->mass)
		return -1;
	for (size_t i = 0; i < rows; i++)
		if (!(mass[i] > 0) || !isfinite(mass[i]))
			return -1;
	double *sum = calloc(f->nc * (f->stride + 1), sizeof(double));
	if (!sum)
		return -2;
	free(f->sum);
	f->sum = sum;
	f->stride++;
	f->mass = mass;
	f->mrows = rows;
	return 0;
}

/* Mixtures: the same sums weighted by each particle's mass, and the mass. */
static void add_weighted(fields_t *f, size_t n, const double *pos, const double *vel, const double *spin)
{
	const int D = f->dim, sd = f->spin_dim;
	for (size_t i = 0; i < n && i < f->mrows; i++) {
		if (isnan(pos[i * D]))
			continue;
		double *s = f->sum + fields_cell_of(f, pos + i * D) * f->stride;
		const double *v = vel + i * D, m = f->mass[i];
		double v2 = 0;
		s[0] += 1.0;
		for (int a = 0; a < D; a++) {
			s[1 + a] += m * v[a];
			v2 += v[a] * v[a];
		}
		s[1 + D] += m * v2;
		for (int a = 0; a < sd; a++)
			s[2 + D + a] += spin[i * sd + a];
		s[f->stride - 1] += m;
	}
	f->samples++;
}

void fields_add(fields_t *f, size_t n, const double *pos, const double *vel, const double *spin)
{
	const int D = f->dim, sd = f->spin_dim;
	if (f->mass) {
		add_weighted(f, n, pos, vel, spin);
		return;
	}
	for (size_t i = 0; i < n; i++) {
		if (isnan(pos[i * D]))
			continue;   /* an empty slot (open and reservoir walls): no particle */
		double *s = f->sum + fields_cell_of(f, pos + i * D) * f->stride;
		const double *v = vel + i * D;
		double v2 = 0;
		s[0] += 1.0;
		for (int a = 0; a < D; a++) {
			s[1 + a] += v[a];
			v2 += v[a] * v[a];
		}
		s[1 + D] += v2;
		for (int a = 0; a < sd; a++)
			s[2 + D + a] += spin[i * sd + a];
	}
	f->samples++;
}

int fields_result(const fields_t *f, double mass, double *count, double *density, double *const *u, double *temp,
                  double *const *w)
{
	const int D = f->dim, sd = f->spin_dim, S = f->samples;
	for (size_t c = 0; c < f->nc; c++) {
		const double *s = f->sum + c * f->stride;
		double visits = s[0], occ = S > 0 ? visits / S : NAN;
		if (count)
			count[c] = occ;
		if (density)
			density[c] = occ / f->cell_volume;
		/* one mass: u = sum v / visits, T = m (sum v^2 / visits - u^2) / D; mixtures: the barycentric
		 * u = sum m v / sum m and T = (sum m v^2 - sum m u^2) / (D visits) */
		const double M = f->mass ? s[f->stride - 1] : visits;
		double u2 = 0;
		for (int a = 0; a < D; a++) {
			double ua = visits > 0 ? s[1 + a] / M : NAN;
			u2 += ua * ua;
			if (u)
				u[a][c] = ua;
		}
		if (temp) {
			double t = visits > 0 ? (f->mass ? (s[1 + D] - M * u2) / (D * visits) : mass * (s[1 + D] / visits - u2) / D)
			                      : NAN;
			temp[c] = t < 0 ? 0.0 : t;   /* rounding when all visits have one velocity */
		}
		for (int a = 0; w && a < sd; a++)
			w[a][c] = visits > 0 ? s[2 + D + a] / visits : NAN;
	}
	return S;
}

size_t fields_state_size(const fields_t *f) { return f->nc * f->stride + 1; }

void fields_state_get(const fields_t *f, double *v)
{
	memcpy(v, f->sum, f->nc * f->stride * sizeof(double));
	v[f->nc * f->stride] = f->samples;
}

int fields_state_set(fields_t *f, const double *v)
{
	double S = v[f->nc * f->stride];
	if (!(S >= 0) || S > 2147483647.0 || S != floor(S))
		return -1;
	for (size_t c = 0; c < f->nc; c++) {
		const double *s = v + c * f->stride;
		if (!(s[0] >= 0) || !isfinite(s[0]))
			return -1;
		for (size_t k = 1; k < f->stride; k++)
			if (!isfinite(s[k]))
				return -1;
	}
	memcpy(f->sum, v, f->nc * f->stride * sizeof(double));
	f->samples = (int)S;
	return 0;
}

size_t fields_memory(const fields_t *f) { return sizeof(*f) + f->nc * f->stride * sizeof(double); }
