/* Mean-square displacement: unwrapped positions updated often enough that the minimum image of each step is the step. */
#include "observe/msd.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

struct msd {
	int dim;
	size_t n;
	double L[3], iL[3], mass, lmin, reach;
	double *r0;       /* N*D: positions at the origin */
	double *u;        /* N*D: unwrapped positions at the last update */
	double t0, t, ekin;
};

msd_t *msd_create(int dim, size_t n, const double *box, double mass, double reach)
{
	msd_t *m = calloc(1, sizeof(*m));
	if (!m)
		return NULL;
	m->dim = dim;
	m->n = n;
	m->mass = mass;
	m->reach = reach;
	m->lmin = INFINITY;
	for (int a = 0; a < dim; a++) {
		m->L[a] = box[a];
		m->iL[a] = 1.0 / box[a];
		m->lmin = fmin(m->lmin, box[a]);
	}
	m->r0 = malloc(2 * n * (size_t)dim * sizeof(double));
	if (!m->r0) {
		free(m);
		return NULL;
	}
	m->u = m->r0 + n * (size_t)dim;
	return m;
}

void msd_destroy(msd_t *m)
{
	if (!m)
		return;
	free(m->r0);
	free(m);
}

void msd_origin(msd_t *m, double t, const double *pos, double ekin)
{
	size_t k = m->n * (size_t)m->dim;
	memcpy(m->r0, pos, k * sizeof(double));
	memcpy(m->u, pos, k * sizeof(double));
	m->t0 = m->t = t;
	m->ekin = ekin;
}

void msd_update(msd_t *m, double t, const double *pos, double ekin)
{
	const int D = m->dim;
	for (size_t i = 0; i < m->n; i++)
		for (int a = 0; a < D; a++) {
			/* u and the folded position differ by whole edges (up to rounding) */
			double *u = &m->u[i * D + a], x = pos[i * D + a] - *u;
			*u += x - m->L[a] * nearbyint(x * m->iL[a]);
		}
	m->t = t;
	m->ekin = ekin;
}

double msd_due(const msd_t *m)
{
	double vmax = sqrt(2.0 * m->ekin / m->mass);
	return vmax > 0.0 ? m->t + m->reach * m->lmin / vmax : INFINITY;
}

double msd_value(const msd_t *m, double *se)
{
	const int D = m->dim;
	double s = 0.0, s2 = 0.0;
	for (size_t i = 0; i < m->n; i++) {
		double d2 = 0.0;
		for (int a = 0; a < D; a++) {
			double x = m->u[i * D + a] - m->r0[i * D + a];
			d2 += x * x;
		}
		s += d2;
		s2 += d2 * d2;
	}
	double n = (double)m->n, mean = s / n;
	if (se)
		*se = m->n > 1 ? sqrt(fmax(s2 / n - mean * mean, 0.0) / (n - 1)) : NAN;
	return mean;
}

double msd_time0(const msd_t *m) { return m->t0; }
double msd_time(const msd_t *m) { return m->t; }

size_t msd_state_size(const msd_t *m)
{
	return 2 * m->n * (size_t)m->dim + 3;
}

void msd_state_get(const msd_t *m, double *v)
{
	size_t k = 2 * m->n * (size_t)m->dim;
	memcpy(v, m->r0, k * sizeof(double));
	v[k] = m->t0;
	v[k + 1] = m->t;
	v[k + 2] = m->ekin;
}

int msd_state_set(msd_t *m, const double *v)
{
	size_t k = 2 * m->n * (size_t)m->dim;
	for (size_t i = 0; i < k + 3; i++)
		if (!isfinite(v[i]))
			return -1;
	memcpy(m->r0, v, k * sizeof(double));
	m->t0 = v[k];
	m->t = v[k + 1];
	m->ekin = v[k + 2];
	return 0;
}
