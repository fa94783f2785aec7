/* Mean-square displacement: unwrapped positions updated often enough that the minimum image of each step is the step. */
#include "observe/msd.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

struct msd {
	int dim;
	size_t n;
	double L[3], iL[3], mass, mass_pot, lmin, reach;   /* mass: the lightest (speed bound); mass_pot: the
	                                                  * heaviest (potential energy bound) */
	int walled[3], any_walled; /* msd_walls(): walled axes are not unwrapped */
	double g[3], umin;          /* msd_walls(): gravity (walled axes only) and the least potential energy per
	                             * unit mass, -sum_a g_a x*_a, x*_a the contact plane gravity points to */
	int grav;
	int exact;        /* msd_exact(): positions come unwrapped, no bound */
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
	m->mass = m->mass_pot = mass;
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

int msd_walls(msd_t *m, const int *walled, const double *gravity, double radius)
{
	if (!m || !walled || !gravity || !(radius >= 0))
		return -1;
	for (int a = 0; a < m->dim; a++) {
		if (gravity[a] != 0 && !walled[a] && !m->exact)
			return -1;   /* falls forever along a periodic axis: no speed bound */
		if (walled[a] && !(m->L[a] > 2 * radius))
			return -1;
	}
	m->lmin = INFINITY;
	m->umin = 0.0;
	m->any_walled = m->grav = 0;
	for (int a = 0; a < m->dim; a++) {
		m->walled[a] = walled[a] != 0;
		m->any_walled |= m->walled[a];
		m->g[a] = gravity[a];
		m->grav |= gravity[a] != 0;
		if (!m->walled[a])
			m->lmin = fmin(m->lmin, m->L[a]);
		else if (gravity[a] != 0)
			m->umin -= gravity[a] * (gravity[a] < 0 ? radius : m->L[a] - radius);
	}
	return 0;
}

/* The energy that bounds every particle's speed: ekin plus, with gravity, the potential energy above its
 * least value, sum_i m (u_i - umin) >= 0 (u_i = -g . r_i), which gravity can turn into kinetic energy. */
static double bound_energy(const msd_t *m, const double *pos, double ekin)
{
	if (!m->grav)
		return ekin;
	double u = 0.0;
	for (size_t i = 0; i < m->n; i++) {
		double ui = 0.0;
		for (int a = 0; a < m->dim; a++)
			ui -= m->g[a] * pos[i * m->dim + a];
		u += fmax(ui - m->umin, 0.0);
	}
	return ekin + m->mass_pot * u;
}

int msd_masses(msd_t *m, double lightest, double heaviest)
{
	if (!m || !(lightest > 0) || !(heaviest >= lightest) || !isfinite(heaviest))
		return -1;
	m->mass = lightest;
	m->mass_pot = heaviest;
	return 0;
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
	m->ekin = bound_energy(m, pos, ekin);
}

void msd_exact(msd_t *m)
{
	m->exact = 1;
}

void msd_update(msd_t *m, double t, const double *pos, double ekin)
{
	const int D = m->dim;
	if (m->exact) {
		memcpy(m->u, pos, m->n * (size_t)D * sizeof(double));
	} else if (!m->any_walled) {
		for (size_t i = 0; i < m->n; i++)
			for (int a = 0; a < D; a++) {
				/* u and the folded position differ by whole edges (up to rounding) */
				double *u = &m->u[i * D + a], x = pos[i * D + a] - *u;
				*u += x - m->L[a] * nearbyint(x * m->iL[a]);
			}
	} else {
		/* walled axes: positions are absolute (a wall has no image), taken as they are */
		double per[3];
		for (int a = 0; a < D; a++)
			per[a] = m->walled[a] ? 0.0 : 1.0;
		for (size_t i = 0; i < m->n; i++)
			for (int a = 0; a < D; a++) {
				double *u = &m->u[i * D + a], x = pos[i * D + a] - *u;
				*u += x - per[a] * m->L[a] * nearbyint(x * m->iL[a]);
			}
	}
	m->t = t;
	m->ekin = bound_energy(m, pos, ekin);
}

double msd_due(const msd_t *m)
{
	if (m->exact)
		return INFINITY;
	double vmax = sqrt(2.0 * m->ekin / m->mass);
	return vmax > 0.0 && isfinite(m->lmin) ? m->t + m->reach * m->lmin / vmax : INFINITY;
}

double msd_value_axes(const msd_t *m, int walled)
{
	const int D = m->dim;
	double s = 0.0;
	int any = 0;
	for (int a = 0; a < D; a++)
		any |= m->walled[a] == (walled != 0);
	if (!any)
		return NAN;
	for (size_t i = 0; i < m->n; i++)
		for (int a = 0; a < D; a++)
			if (m->walled[a] == (walled != 0)) {
				double x = m->u[i * D + a] - m->r0[i * D + a];
				s += x * x;
			}
	return s / (double)m->n;
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
