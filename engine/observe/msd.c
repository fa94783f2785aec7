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
	int varying;      /* msd_varying(): rows may be absent (NaN); a member's row of r0 is finite */
	int ids_pending;  /* msd_origin() with labels: the next msd_ids() gives the origin's labels */
	double *r0;       /* N*D: positions at the origin (varying: NaN rows for the particles not members) */
	double *u;        /* N*D: unwrapped positions at the last update */
	double *id0;      /* msd_varying() with labels: N, each row's particle id at the origin (-1: none) */
	double *dprev;    /* msd_varying(): N, each member's squared displacement at the last msd_interval() */
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
		if (isfinite(ui))   /* (absent rows of a varying set: NaN) */
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
	free(m->id0);
	free(m->dprev);
	free(m);
}

int msd_varying(msd_t *m, int labelled)
{
	if (!m || m->varying)
		return -1;
	if (!(m->dprev = calloc(m->n ? m->n : 1, sizeof(double))))
		return -1;
	if (labelled && !(m->id0 = malloc((m->n ? m->n : 1) * sizeof(double)))) {
		free(m->dprev);
		m->dprev = NULL;
		return -1;
	}
	for (size_t i = 0; labelled && i < m->n; i++)
		m->id0[i] = -1.0;
	m->varying = 1;
	return 0;
}

/* Varying sets: a row is a member while its r0 row is finite. */
static int member(const msd_t *m, size_t i)
{
	return isfinite(m->r0[i * m->dim]);
}

static void drop(msd_t *m, size_t i)
{
	for (int a = 0; a < m->dim; a++)
		m->r0[i * m->dim + a] = NAN;
}

/* Varying sets: drop the members whose row is absent now (a non-finite coordinate). */
static void drop_absent(msd_t *m, const double *pos)
{
	const int D = m->dim;
	for (size_t i = 0; i < m->n; i++) {
		if (!member(m, i))
			continue;
		for (int a = 0; a < D; a++)
			if (!isfinite(pos[i * D + a])) {
				drop(m, i);
				break;
			}
	}
}

void msd_ids(msd_t *m, const int64_t *ids)
{
	if (!m->varying || !m->id0 || !ids)
		return;
	if (m->ids_pending) {   /* just after msd_origin(): the members' labels */
		for (size_t i = 0; i < m->n; i++) {
			m->id0[i] = (double)ids[i];
			if (ids[i] < 0)
				drop(m, i);
		}
		m->ids_pending = 0;
		return;
	}
	for (size_t i = 0; i < m->n; i++)
		if (member(m, i) && (double)ids[i] != m->id0[i])
			drop(m, i);   /* its slot holds another particle now: the member left */
}

void msd_origin(msd_t *m, double t, const double *pos, double ekin)
{
	size_t k = m->n * (size_t)m->dim;
	memcpy(m->r0, pos, k * sizeof(double));
	memcpy(m->u, pos, k * sizeof(double));
	m->t0 = m->t = t;
	m->ekin = bound_energy(m, pos, ekin);
	if (m->varying) {   /* members: the particles present now */
		for (size_t i = 0; i < m->n; i++) {
			m->dprev[i] = 0.0;
			for (int a = 0; a < m->dim; a++)
				if (!isfinite(pos[i * m->dim + a])) {
					drop(m, i);
					break;
				}
		}
		m->ids_pending = m->id0 != NULL;
	}
}

void msd_exact(msd_t *m)
{
	m->exact = 1;
}

void msd_update(msd_t *m, double t, const double *pos, double ekin)
{
	const int D = m->dim;
	if (m->varying)
		drop_absent(m, pos);
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
	size_t n = 0;
	for (size_t i = 0; i < m->n; i++) {
		if (m->varying && !member(m, i))
			continue;
		n++;
		for (int a = 0; a < D; a++)
			if (m->walled[a] == (walled != 0)) {
				double x = m->u[i * D + a] - m->r0[i * D + a];
				s += x * x;
			}
	}
	return n ? s / (double)n : NAN;
}

size_t msd_count(const msd_t *m)
{
	if (!m->varying)
		return m->n;
	size_t n = 0;
	for (size_t i = 0; i < m->n; i++)
		n += member(m, i);
	return n;
}

double msd_interval(msd_t *m)
{
	const int D = m->dim;
	int any = 0;
	for (int a = 0; a < D; a++)
		any |= !m->walled[a];
	if (!m->varying || !any)
		return NAN;
	double s = 0.0;
	size_t n = 0;
	for (size_t i = 0; i < m->n; i++) {
		if (!member(m, i))
			continue;
		double d2 = 0.0;
		for (int a = 0; a < D; a++)
			if (!m->walled[a]) {
				double x = m->u[i * D + a] - m->r0[i * D + a];
				d2 += x * x;
			}
		s += d2 - m->dprev[i];
		m->dprev[i] = d2;
		n++;
	}
	return n ? s / (double)n : NAN;
}

double msd_value(const msd_t *m, double *se)
{
	const int D = m->dim;
	double s = 0.0, s2 = 0.0;
	size_t cnt = 0;
	for (size_t i = 0; i < m->n; i++) {
		if (m->varying && !member(m, i))
			continue;
		cnt++;
		double d2 = 0.0;
		for (int a = 0; a < D; a++) {
			double x = m->u[i * D + a] - m->r0[i * D + a];
			d2 += x * x;
		}
		s += d2;
		s2 += d2 * d2;
	}
	double n = (double)cnt, mean = cnt ? s / n : NAN;
	if (se)
		*se = cnt > 1 ? sqrt(fmax(s2 / n - mean * mean, 0.0) / (n - 1)) : NAN;
	return mean;
}

double msd_time0(const msd_t *m) { return m->t0; }
double msd_time(const msd_t *m) { return m->t; }

size_t msd_state_size(const msd_t *m)
{
	size_t k = 2 * m->n * (size_t)m->dim + 3;
	if (m->varying)
		k += m->n * (m->id0 ? 2 : 1);
	return k;
}

void msd_state_get(const msd_t *m, double *v)
{
	size_t k = 2 * m->n * (size_t)m->dim;
	memcpy(v, m->r0, k * sizeof(double));
	v[k] = m->t0;
	v[k + 1] = m->t;
	v[k + 2] = m->ekin;
	if (m->varying) {
		memcpy(v + k + 3, m->dprev, m->n * sizeof(double));
		if (m->id0)
			memcpy(v + k + 3 + m->n, m->id0, m->n * sizeof(double));
	}
}

int msd_state_set(msd_t *m, const double *v)
{
	const int D = m->dim;
	size_t k = 2 * m->n * (size_t)D;
	if (!isfinite(v[k]) || !isfinite(v[k + 1]) || !isfinite(v[k + 2]))
		return -1;
	for (size_t i = 0; i < m->n; i++)
		for (int a = 0; a < D; a++) {
			/* varying sets: a row not a member has NaN origin (its unwrapped position is anything) */
			int mem = !m->varying || isfinite(v[i * D]);
			if (mem && (!isfinite(v[i * D + a]) || !isfinite(v[(m->n + i) * D + a])))
				return -1;
			if (!mem && !isnan(v[i * D + a]))
				return -1;
		}
	if (m->varying) {
		for (size_t i = 0; i < m->n; i++)
			if (!isfinite(v[k + 3 + i]) || (m->id0 && !(v[k + 3 + m->n + i] >= -1.0)))
				return -1;
		memcpy(m->dprev, v + k + 3, m->n * sizeof(double));
		if (m->id0)
			memcpy(m->id0, v + k + 3 + m->n, m->n * sizeof(double));
		m->ids_pending = 0;
	}
	memcpy(m->r0, v, k * sizeof(double));
	m->t0 = v[k];
	m->t = v[k + 1];
	m->ekin = v[k + 2];
	return 0;
}
