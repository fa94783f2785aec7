/* Structure observables: workspaces and tables made from the scene once, filled by the family modules at each sample. */
#include "observe.h"

#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "observe/dspec.h"
#include "observe/fgrid.h"
#include "observe/fields.h"
#include "observe/surface.h"
#include "observe/gofr.h"
#include "observe/sofk.h"
#include "observe/tables.h"
#include "observe/vcorr.h"
#include "observe/vdist.h"

#define N_SCALARS 12  /* temperature, a2, a3, g_pairs, cluster_w, cluster_exponent, m2_reduced, mean_size,
                        * impact_a, impact_c, a2_spin, temperature_rot */
#define N_COUNTS 3    /* then packed: fields_samples, dspec_samples, dspec_alpha (ensembles) */

struct obs {
	scene_t s;
	unsigned bits;            /* curve families asked for */
	int layout_only;
	double sigma, volume;
	gofr_t *gofr;             /* pair_correlation, velocity_correlations */
	fgrid_t *grid;            /* structure_factor, velocity_correlations */
	fields_t *fields;         /* fields */
	dspec_t *dspec;           /* density_spectrum */
	double *mem;              /* one block: axes, values, standard errors, scratch */
	double *gcount, *gpar, *gperp;   /* pair sums over the g(r) bins */
	double *vhist;                   /* 4 * bins: the component histograms, axis-major, and the spins' |c| */
	double *vmix;                    /* mixtures: 4 * bins scratch for each species' histograms */
	double *mass_rows;               /* mixtures with fields: each row's mass (fields_masses()) */
	double *bcount;                  /* impact parameters counted by the engine since the last curves */
	double *gsp;                     /* mixtures with pair_correlation: pair counts per class and bin */
	obs_curves_t c;
	size_t packed;
};

static size_t n_vals(const obs_curves_t *c)
{
	size_t k = 0;
	for (int i = 0; i < c->ntables; i++)
		k += (size_t)c->t[i].nb * c->t[i].ncols;
	return k;
}

void obs_destroy(obs_t *o)
{
	if (!o)
		return;
	gofr_destroy(o->gofr);
	fgrid_destroy(o->grid);
	fields_destroy(o->fields);
	dspec_destroy(o->dspec);
	free(o->mass_rows);
	free(o->gsp);
	free(o->mem);
	free(o);
}

obs_t *obs_create(const scene_t *s, int layout_only)
{
	obs_t *o = calloc(1, sizeof(*o));
	if (!o)
		return NULL;
	const int D = s->dim;
	o->s = *s;
	o->bits = obs_curve_bits(s);
	o->layout_only = layout_only;
	o->sigma = 2 * s->radius;
	o->volume = scene_box_volume(s);
	int J = 0, gnb = s->gofr_bins;
	double rmax = s->gofr_range * o->sigma;

	/* The grid first: its shell count sizes the k tables. */
	int walled[3];
	for (int a = 0; a < 3; a++)
		walled[a] = s->boundary[a].walled;
	if (o->bits & (SCENE_OBS_SOFK | SCENE_OBS_VCORR)) {
		/* with walls: wave vectors along the periodic axes only (fgrid.h) */
		o->grid = fgrid_create_walled(D, s->box, s->sofk_grid, layout_only ? 1 : (o->bits & SCENE_OBS_VCORR) ? D : 1,
		                              walled);
		if (!o->grid)
			goto fail;
		J = fgrid_bins(o->grid);
	}
	if (!layout_only && (s->observables & (SCENE_OBS_GOFR | SCENE_OBS_VCORR))) {
		o->gofr = gofr_create(D, scene_slots(s), s->box, fmax(rmax, o->sigma * (1 + GOFR_CONTACT_WIDTH)));
		if (!o->gofr)
			goto fail;
		if (scene_has_walls(s)) {
			if (gofr_walls(o->gofr, walled, s->radius) != 0)
				goto fail;
		}
		if (s->n_obstacles > 0) {
			/* the ideal-gas pairs in the region the centres reach (gofr.h) */
			double oc[SCENE_OBSTACLES_MAX * 3], os[SCENE_OBSTACLES_MAX];
			for (int k = 0; k < s->n_obstacles; k++) {
				for (int a = 0; a < D; a++)
					oc[k * D + a] = s->obstacle[k].center[a];
				os[k] = s->obstacle[k].radius + s->radius;
			}
			if (gofr_obstacles(o->gofr, s->n_obstacles, oc, os) != 0)
				goto fail;
		}
		if ((s->observables & SCENE_OBS_GOFR) && s->n_species > 1 && s->n_species <= OBS_GOFR_SPECIES_MAX) {
			/* the species are blocks of rows in scene order (scene.h) */
			uint8_t *spc = malloc(s->count);
			o->gsp = malloc((size_t)gofr_pair_classes(s->n_species) * gnb * sizeof(double));
			size_t off = 0;
			for (int k = 0; spc && k < s->n_species; k++)
				for (uint64_t j = 0; j < s->species[k].count && off < s->count; j++)
					spc[off++] = (uint8_t)k;
			int bad = !spc || !o->gsp || off != s->count || scene_slots(s) != s->count ||
			          gofr_species(o->gofr, s->n_species, spc) != 0;
			free(spc);
			if (bad)
				goto fail;
		}
	}

	const int spin_dim = s->rough ? (D == 2 ? 1 : 3) : 0;
	if (!layout_only && (o->bits & SCENE_OBS_FIELDS)) {
		int per[3];
		for (int a = 0; a < 3; a++)
			per[a] = !s->boundary[a].walled;
		o->fields = fields_create(D, s->box, s->fields_cells, per, spin_dim);
		if (!o->fields)
			goto fail;
		if (s->n_species > 1) {   /* mixtures: mass-weighted velocity and temperature (fields.h) */
			o->mass_rows = malloc(s->count * sizeof(double));
			if (!o->mass_rows)
				goto fail;
			size_t off = 0;
			for (int k = 0; k < s->n_species; k++)
				for (uint64_t j = 0; j < s->species[k].count && off < s->count; j++)
					o->mass_rows[off++] = s->species[k].mass;
			if (off != s->count || fields_masses(o->fields, s->count, o->mass_rows) != 0)
				goto fail;
		}
	}

	if (!layout_only && (o->bits & SCENE_OBS_DSPEC)) {
		o->dspec = dspec_create(D, s->dspec_axis, s->dspec_slices, s->box[s->dspec_axis], s->dspec_m,
		                        s->dspec_interval, s->dspec_fit[0], s->dspec_fit[1]);
		if (!o->dspec)
			goto fail;
	}

	/* Tables (values assigned below from one block). */
	tables_layout(&o->c, s, J);
	int vnb = s->vdist_bins, bnb = (o->bits & SCENE_OBS_IMPACT) ? s->impact_bins : 0;

	/* One block: per table edges (nb+1) and centres (nb); per column value
	 * and standard error (nb each); pair sums (3 gnb). */
	size_t need = 3 * (size_t)gnb + 8 * (size_t)vnb + (size_t)bnb;
	for (int i = 0; i < o->c.ntables; i++)
		need += 2 * (size_t)o->c.t[i].nb + 1 + 2 * (size_t)o->c.t[i].nb * o->c.t[i].ncols;
	o->mem = calloc(need ? need : 1, sizeof(double));
	if (!o->mem)
		goto fail;
	double *p = o->mem;
	o->gcount = p, p += gnb;
	o->gpar = p, p += gnb;
	o->gperp = p, p += gnb;
	o->vhist = p, p += 4 * (size_t)vnb;
	o->vmix = p, p += 4 * (size_t)vnb;
	o->bcount = p, p += bnb;
	for (int i = 0; i < o->c.ntables; i++) {
		obs_table_t *t = &o->c.t[i];
		double *edges = p, *centres = p + t->nb + 1;
		p += 2 * (size_t)t->nb + 1;
		for (int k = 0; k < t->ncols; k++) {
			t->val[k] = p, p += t->nb;
			t->se[k] = p, p += t->nb;
		}
		t->edges = edges;
		t->centres = centres;
		if (!strcmp(t->x, "c")) {
			int sp = !strcmp(t->table, "speed");
			double lo = sp ? 0 : -s->vdist_range, w = (sp ? s->vdist_range : 2 * s->vdist_range) / t->nb;
			for (int b = 0; b <= t->nb; b++)
				edges[b] = lo + b * w;
		} else if (!strcmp(t->x, "r")) {
			for (int b = 0; b <= t->nb; b++)
				edges[b] = rmax * b / t->nb;
		} else if (!strcmp(t->x, "b")) {
			for (int b = 0; b <= t->nb; b++)
				edges[b] = (double)b / t->nb;
		} else if (!strcmp(t->x, "cell") || !strcmp(t->x, "pair")) {
			/* the flat cell index c = i_x + n_x (i_y + n_y i_z), or the pair class, as centre, edges c -+ 1/2 */
			for (int b = 0; b <= t->nb; b++)
				edges[b] = b - 0.5;
			for (int b = 0; b < t->nb; b++)
				centres[b] = b;
			continue;
		} else if (!strcmp(t->x, "f")) {
			/* f_k = k / (m interval), k = 1 .. m/2 - 1 (observe/dspec.h) */
			double df = 1.0 / (s->dspec_m * s->dspec_interval);
			for (int b = 0; b <= t->nb; b++)
				edges[b] = (b + 0.5) * df;
			for (int b = 0; b < t->nb; b++)
				centres[b] = (b + 1) * df;
			continue;
		} else if (!strcmp(t->x, "x")) {
			/* surface_profile: equal bins of the box edge along its axis */
			for (int b = 0; b <= t->nb; b++)
				edges[b] = s->box[s->surf_axis] * b / t->nb;
		} else if (!strcmp(t->x, "k")) {
			fgrid_axis(o->grid, edges, centres, NULL);
			continue;
		} else {
			clusters_size_bins(scene_slots(s), edges, centres);
			continue;
		}
		for (int b = 0; b < t->nb; b++)
			centres[b] = 0.5 * (edges[b] + edges[b + 1]);
	}
	o->packed = n_vals(&o->c) + N_SCALARS + N_COUNTS;
	return o;
fail:
	obs_destroy(o);
	return NULL;
}

const obs_curves_t *obs_layout(const obs_t *o) { return &o->c; }

double *obs_impact_counts(const obs_t *o, int *nb)
{
	int on = (o->bits & SCENE_OBS_IMPACT) && !o->layout_only;
	*nb = on ? o->s.impact_bins : 0;
	return on ? o->bcount : NULL;
}
size_t obs_packed_size(const obs_t *o) { return o->packed; }

size_t obs_memory(const obs_t *o)
{
	size_t b = sizeof(*o) + o->packed * 2 * sizeof(double);
	if (o->grid)
		b += fgrid_memory(o->grid);
	if (o->fields)
		b += fields_memory(o->fields);
	if (o->dspec)
		b += dspec_memory(o->dspec);
	if (o->gsp)   /* pair counts per class, and gofr's class of each row twice */
		b += (size_t)gofr_pair_classes(o->s.n_species) * o->s.gofr_bins * sizeof(double) + 2 * (size_t)o->s.count;
	if (o->gofr)
		b += (size_t)scene_slots(&o->s) * (2 * o->s.dim * sizeof(double) + sizeof(uint32_t)) +
		     (3 * (size_t)scene_slots(&o->s) + 28) * sizeof(uint32_t);
	return b;
}

size_t obs_present(size_t rows, int dim, double *pos, double *vel, double *spin, int spin_dim)
{
	size_t n = 0;
	for (size_t i = 0; i < rows; i++) {
		if (!isfinite(pos[i * dim]))
			continue;
		if (n != i) {
			memcpy(pos + n * dim, pos + i * dim, (size_t)dim * sizeof(double));
			if (vel)
				memcpy(vel + n * dim, vel + i * dim, (size_t)dim * sizeof(double));
			if (spin && spin_dim > 0)
				memcpy(spin + n * spin_dim, spin + i * spin_dim, (size_t)spin_dim * sizeof(double));
		}
		n++;
	}
	return n;
}

/*
 * Mixtures (two or more particles.species, each a block of rows in scene order): every species' velocities
 * are scaled by its own thermal speed about its own mean, c = (v - <v>_s) / sqrt(2 T_s / m_s), and pooled:
 * the histograms are the species' weighted by their counts, a2 and a3 the count-weighted means of the
 * species' (the moments of the pooled c), the temperature the count-weighted mean of T_s. comp/speed may be
 * NULL (moments only); scratch: (dim + 1) * bins doubles.
 */
static void vdist_species(const scene_t *s, size_t n, const double *vel, vdist_moments_t *m, int bins, double range,
                          double *comp, double *speed, double *scratch)
{
	const int D = s->dim;
	size_t off = 0;
	double T = 0, a2 = 0, a3 = 0;
	memset(m, 0, sizeof(*m));
	if (comp)
		memset(comp, 0, (size_t)D * bins * sizeof(double));
	if (speed)
		memset(speed, 0, (size_t)bins * sizeof(double));
	for (int k = 0; k < s->n_species && off < n; k++) {
		size_t nk = s->species[k].count;
		if (nk > n - off)
			nk = n - off;
		vdist_moments_t mk;
		vdist_moments(D, nk, s->species[k].mass, vel + off * D, &mk);
		double w = (double)nk / (double)n;
		T += w * mk.temperature;
		a2 += w * mk.a2;
		a3 += w * mk.a3;
		for (int a = 0; a < D; a++)
			m->mean[a] += w * mk.mean[a];
		if (comp && speed) {
			vdist_histograms(D, nk, s->species[k].mass, vel + off * D, &mk, bins, range, scratch, scratch + D * bins);
			for (int b = 0; b < D * bins; b++)
				comp[b] += w * scratch[b];
			for (int b = 0; b < bins; b++)
				speed[b] += w * scratch[D * bins + b];
		}
		off += nk;
	}
	m->temperature = T;
	m->a2 = a2;
	m->a3 = a3;
}

int obs_scalars(obs_t *o, size_t n, const double *pos, const double *vel, obs_scalars_t *out)
{
	const scene_t *s = &o->s;
	out->a2 = out->a3 = out->g_pairs = out->g_pairs_se = NAN;
	if ((s->observables & SCENE_OBS_VDIST) && vel && n > 0) {
		vdist_moments_t m;
		if (s->n_species > 1)
			vdist_species(s, n, vel, &m, 0, 0, NULL, NULL, NULL);
		else
			vdist_moments(s->dim, n, s->mass, vel, &m);
		out->a2 = m.a2;
		out->a3 = m.a3;
	}
	if (s->observables & SCENE_OBS_GOFR) {
		if (!o->gofr || !pos || gofr_set_count(o->gofr, n) != 0)
			return -1;
		gofr_contact_t gc;
		if (n >= 2 && s->n_species <= 1) {   /* mixtures: per pair of species in the curves */
			gofr_contact(o->gofr, pos, o->sigma, &gc);
			out->g_pairs = gc.value;
			out->g_pairs_se = gc.se;
		}
	}
	return 0;
}

void obs_interval(const obs_t *o, double rate, double z, double t_avg, obs_scalars_t *out)
{
	const scene_t *s = &o->s;
	if (s->n_species > 1) {   /* one-radius formulas (gofr.h) */
		out->g_rate = out->g_pressure = NAN;
		return;
	}
	out->g_rate = gofr_contact_rate(s->dim, s->volume_fraction, s->radius, s->mass, t_avg, rate);
	out->g_pressure = gofr_contact_virial(s->dim, s->volume_fraction, s->restitution, z);
}

/*
 * Seed 000 sec. 3.6: P(b) = a / (1 - c b^2) (b in diameters; 3D: relative to
 * molecular chaos 2b, so that chaos is a = 1, c = 0 in both dimensions).
 * Linear in b^2 for y = 1 / q, q = P / P_chaos: y = 1/a - (c/a) b^2, least
 * squares weighted by 1 / var(y) = n q^2 (Poisson counts n per bin). NaN
 * with fewer than 3 non-empty bins.
 */
static void impact_fit(int D, const obs_table_t *t, double *a, double *c)
{
	double s = 0, sx = 0, sy = 0, sxx = 0, sxy = 0;
	int used = 0;
	*a = *c = NAN;
	for (int b = 0; b < t->nb; b++) {
		double x = t->centres[b], n = t->val[1][b], q = t->val[0][b] / (D == 2 ? 1.0 : 2.0 * x);
		if (!(n > 0) || !(q > 0))
			continue;
		double y = 1.0 / q, wt = n * q * q, x2 = x * x;
		s += wt, sx += wt * x2, sy += wt * y, sxx += wt * x2 * x2, sxy += wt * x2 * y;
		used++;
	}
	double det = s * sxx - sx * sx;
	if (used < 3 || !(det > 0))
		return;
	double alpha = (sxx * sy - sx * sxy) / det, beta = (s * sxy - sx * sy) / det;
	if (alpha == 0)
		return;
	*a = 1.0 / alpha;
	*c = -beta / alpha;
}

static obs_table_t *find(obs_t *o, const char *family, const char *sub)
{
	for (int i = 0; i < o->c.ntables; i++)
		if (!strcmp(o->c.t[i].family, family) && !strcmp(o->c.t[i].table, sub))
			return &o->c.t[i];
	return NULL;
}

const obs_curves_t *obs_curves(obs_t *o, clusters_t *cl, size_t n, const double *pos, const double *vel,
                               const double *spin)
{
	const scene_t *s = &o->s;
	const int D = s->dim;
	obs_curves_t *c = &o->c;
	obs_table_t *t;
	vdist_moments_t m;
	if (s->n_species > 1)
		vdist_species(s, n, vel, &m, 0, 0, NULL, NULL, NULL);
	else
		vdist_moments(D, n, s->mass, vel, &m);
	double tm = m.temperature / s->mass;
	c->temperature = m.temperature;
	c->a2 = c->a3 = c->g_pairs = c->cluster_w = c->cluster_exponent = c->m2_reduced = c->mean_size = NAN;
	c->impact_a = c->impact_c = NAN;
	c->dspec_alpha = c->dspec_alpha_se = NAN;
	c->dspec_samples = 0;
	if ((t = find(o, "velocity_distribution", "components"))) {
		obs_table_t *sp = find(o, "velocity_distribution", "speed");
		if (s->n_species > 1)
			vdist_species(s, n, vel, &m, t->nb, s->vdist_range, o->vhist, sp->val[0], o->vmix);
		else
			vdist_histograms(D, n, s->mass, vel, &m, t->nb, s->vdist_range, o->vhist, sp->val[0]);
		for (int a = 0; a < D; a++)
			memcpy(t->val[a], o->vhist + (size_t)a * t->nb, (size_t)t->nb * sizeof(double));
		c->a2 = m.a2;
		c->a3 = m.a3;
	}
	c->a2_spin = c->temperature_rot = NAN;
	if ((t = find(o, "velocity_distribution", "spin"))) {
		/* c_w = (w - <w>) / sqrt(2 T_rot / I), T_rot = I <(w - <w>)^2> / spin_dim: the same scaling and
		 * moments as the velocities, with I = q m a^2 for the mass (vdist.h works in any dimension) */
		const int sd = t->ncols;
		const double inertia = s->rough_q * s->mass * s->radius * s->radius;
		for (int a = 0; a < sd; a++)
			for (int b = 0; b < t->nb; b++)
				t->val[a][b] = NAN;
		if (spin) {
			vdist_moments_t mw;
			vdist_moments(sd, n, inertia, spin, &mw);
			vdist_histograms(sd, n, inertia, spin, &mw, t->nb, s->vdist_range, o->vhist, o->vhist + 3 * t->nb);
			for (int a = 0; a < sd; a++)
				memcpy(t->val[a], o->vhist + (size_t)a * t->nb, (size_t)t->nb * sizeof(double));
			c->a2_spin = mw.a2;
			c->temperature_rot = mw.temperature;
		}
	}
	obs_table_t *tg = find(o, "pair_correlation", ""), *tv = find(o, "velocity_correlations", "pairs");
	if (o->gofr && (tg || tv) && gofr_set_count(o->gofr, n) == 0 && n >= 2) {
		int nb = s->gofr_bins;
		double rmax = s->gofr_range * o->sigma;
		gofr_pairs(o->gofr, pos, tv ? vel : NULL, 0, rmax, nb, o->gcount, o->gpar, o->gperp);
		for (int b = 0; b < nb; b++) {
			double ideal = gofr_ideal_in(o->gofr, rmax * b / nb, rmax * (b + 1) / nb);
			double g = o->gcount[b] / ideal;
			if (tg)
				tg->val[0][b] = g;
			if (tv)
				tv->val[2][b] = g - 1;
		}
		if (tv)
			vcorr_pairs(D, nb, o->gcount, o->gpar, o->gperp, tm, tv->val[0], tv->val[1]);
		if ((s->observables & SCENE_OBS_GOFR) && s->n_species <= 1) {
			gofr_contact_t gc;
			gofr_contact(o->gofr, pos, o->sigma, &gc);
			c->g_pairs = gc.value;
		}
		obs_table_t *ts = find(o, "pair_correlation", "species"), *tc = find(o, "pair_correlation", "contact");
		if (ts && tc && o->gsp) {
			const int K = s->n_species;
			size_t nk[GOFR_SPECIES_MAX];
			gofr_species_count(o->gofr, nk);
			gofr_pairs_species(o->gofr, pos, 0, rmax, nb, o->gsp);
			for (int a = 0; a < K; a++)
				for (int b2 = a; b2 < K; b2++) {
					int p = gofr_pair_class(K, a, b2);
					double pairs = a == b2 ? 0.5 * (double)nk[a] * ((double)nk[a] - 1) :
					                         (double)nk[a] * (double)nk[b2];
					for (int b = 0; b < nb; b++)
						ts->val[p][b] = pairs > 0 ? o->gsp[(size_t)p * nb + b] /
						                gofr_ideal_class(o->gofr, pairs, rmax * b / nb, rmax * (b + 1) / nb) : NAN;
					double sig = s->species[a].radius + s->species[b2].radius;
					gofr_contact_t gc;
					gofr_contact_species(o->gofr, pos, a, b2, sig, &gc);
					tc->val[0][p] = gc.value;
					tc->val[1][p] = gc.se;
					tc->val[2][p] = sig;
				}
		}
	} else {
		/* fewer than two particles present: no pairs (NaN rows) */
		for (int b = 0; b < s->gofr_bins; b++) {
			for (int k = 0; tg && k < tg->ncols; k++)
				tg->val[k][b] = NAN;
			for (int k = 0; tv && k < tv->ncols; k++)
				tv->val[k][b] = NAN;
		}
	}
	if ((t = find(o, "structure_factor", "")))
		sofk_compute(o->grid, n, pos, t->val[0]);
	if ((t = find(o, "velocity_correlations", "modes")))
		vcorr_kspace(o->grid, D, n, pos, vel, m.mean, tm, t->val[0], t->val[1]);
	if ((t = find(o, "impact_parameter", ""))) {
		/* the collisions since the previous curves: counts, and the density in b / sigma */
		double tot = 0.0, w = 1.0 / t->nb;
		for (int b = 0; b < t->nb; b++)
			tot += o->bcount[b];
		for (int b = 0; b < t->nb; b++) {
			t->val[1][b] = o->bcount[b];
			t->val[0][b] = tot > 0.0 ? o->bcount[b] / (tot * w) : NAN;
			o->bcount[b] = 0.0;
		}
		impact_fit(D, t, &c->impact_a, &c->impact_c);
	}
	if ((t = find(o, "fields", "density")) && o->fields) {
		obs_table_t *tu = find(o, "fields", "velocity"), *tt = find(o, "fields", "temperature");
		obs_table_t *tw = find(o, "fields", "spin");
		c->fields_samples = fields_result(o->fields, s->mass, t->val[1], t->val[0], tu->val, tt->val[0],
		                                  tw ? tw->val : NULL);
		fields_reset(o->fields);
	}
	if ((t = find(o, "surface_profile", ""))) {
		/* heights from the floor gravity points to (the parser's rule: gravity along one walled axis) */
		int g = 0;
		for (int a = 0; a < D; a++)
			if (s->gravity[a] != 0)
				g = a;
		surface_profile(D, n, pos, s->surf_axis, s->box[s->surf_axis], t->nb, g, s->gravity[g] < 0 ? 1 : -1,
		                s->box[g], t->val[0], t->val[1]);
	}
	if ((t = find(o, "density_spectrum", "")) && o->dspec)
		c->dspec_samples = dspec_result(o->dspec, t->val[0], &c->dspec_alpha, &c->dspec_alpha_se);
	if ((t = find(o, "clusters", ""))) {
		clusters_stats_t st;
		if (!cl || clusters_set_count(cl, n) != 0 || clusters_compute(cl, pos, s->box, s->radius, s->cluster_delta * o->sigma, &st) != 0)
			return NULL;
		clusters_size_distribution(cl, t->nb, t->edges, t->val[0], NULL);
		c->cluster_w = st.w;
		c->cluster_exponent = st.exponent;
		c->m2_reduced = st.m2_reduced;
		c->mean_size = st.mean_size;
	}
	return c;
}

struct fields *obs_fields(const obs_t *o) { return o->fields; }

void obs_fields_add(obs_t *o, const double *pos, const double *vel, const double *spin)
{
	if (o->fields)
		fields_add(o->fields, scene_slots(&o->s), pos, vel, spin);   /* rows: slots (reservoir walls) */
}

struct dspec *obs_dspec(const obs_t *o) { return o->dspec; }

void obs_dspec_add(obs_t *o, size_t n, const double *pos)
{
	if (o->dspec)
		dspec_add(o->dspec, n, pos);
}

/* ---- ensembles ------------------------------------------------------------- */

static double *scalar_slot(obs_curves_t *c, int k, int se)
{
	double *v[N_SCALARS] = {&c->temperature, &c->a2, &c->a3, &c->g_pairs, &c->cluster_w, &c->cluster_exponent,
	                        &c->m2_reduced, &c->mean_size, &c->impact_a, &c->impact_c, &c->a2_spin,
	                        &c->temperature_rot};
	double *e[N_SCALARS] = {&c->se_temperature, &c->se_a2, &c->se_a3, &c->se_g_pairs, &c->se_cluster_w,
	                        &c->se_cluster_exponent, &c->se_m2_reduced, &c->se_mean_size, &c->se_impact_a,
	                        &c->se_impact_c, &c->se_a2_spin, &c->se_temperature_rot};
	return se ? e[k] : v[k];
}

void obs_pack(const obs_t *o, const obs_curves_t *c, double *v)
{
	size_t p = 0;
	for (int i = 0; i < c->ntables; i++)
		for (int k = 0; k < c->t[i].ncols; k++) {
			memcpy(v + p, c->t[i].val[k], (size_t)c->t[i].nb * sizeof(double));
			p += (size_t)c->t[i].nb;
		}
	for (int k = 0; k < N_SCALARS; k++)
		v[p++] = *scalar_slot((obs_curves_t *)c, k, 0);
	v[p++] = c->fields_samples;
	v[p++] = c->dspec_samples;
	v[p++] = c->dspec_alpha;
	(void)o;
}

/* Mean and standard error of element idx over R packed samples of size P, in replica order. A NaN in
 * any replica (an empty bin) makes both NaN. */
static void stat(const double *v, int R, size_t P, size_t idx, double *mean, double *se)
{
	double s = 0, s2 = 0;
	for (int r = 0; r < R; r++)
		s += v[(size_t)r * P + idx];
	*mean = s / R;
	for (int r = 0; r < R; r++) {
		double d = v[(size_t)r * P + idx] - *mean;
		s2 += d * d;
	}
	*se = R > 1 ? sqrt(s2 / (R - 1) / R) : 0.0;
}

/*
 * A cell's velocity, temperature or spin over the replicas: the occupation-weighted mean
 * u = sum_r c_r u_r / sum_r c_r (c_r the replica's mean occupation of the cell, element cidx; replicas
 * that never saw the cell weigh 0), and the ratio estimator's standard error
 * sqrt(R / (R - 1) sum_r c_r^2 (u_r - u)^2) / sum_r c_r. NaN when no replica saw the cell.
 */
static void wstat(const double *v, int R, size_t P, size_t idx, size_t cidx, double *mean, double *se)
{
	double sc = 0, su = 0, s2 = 0;
	for (int r = 0; r < R; r++) {
		double c = v[(size_t)r * P + cidx], u = v[(size_t)r * P + idx];
		if (c > 0 && isfinite(u))
			sc += c, su += c * u;
	}
	if (!(sc > 0)) {
		*mean = *se = NAN;
		return;
	}
	*mean = su / sc;
	for (int r = 0; r < R; r++) {
		double c = v[(size_t)r * P + cidx], u = v[(size_t)r * P + idx];
		if (c > 0 && isfinite(u))
			s2 += c * c * (u - *mean) * (u - *mean);
	}
	*se = R > 1 ? sqrt(R / (R - 1.0) * s2) / sc : 0.0;
}

const obs_curves_t *obs_combine(obs_t *o, const double *v, int R)
{
	obs_curves_t *c = &o->c;
	size_t p = 0, P = o->packed, count = SIZE_MAX;
	/* fields: the occupation column (table "density", column "count") weighs the per-cell means */
	for (int i = 0; i < c->ntables; i++) {
		if (!strcmp(c->t[i].family, "fields") && !strcmp(c->t[i].table, "density"))
			count = p + (size_t)c->t[i].nb;   /* column 1 */
		p += (size_t)c->t[i].nb * c->t[i].ncols;
	}
	p = 0;
	for (int i = 0; i < c->ntables; i++) {
		int weighted = count != SIZE_MAX && !strcmp(c->t[i].family, "fields") && strcmp(c->t[i].table, "density");
		for (int k = 0; k < c->t[i].ncols; k++)
			for (int b = 0; b < c->t[i].nb; b++, p++) {
				if (weighted)
					wstat(v, R, P, p, count + (size_t)b, &c->t[i].val[k][b], &c->t[i].se[k][b]);
				else
					stat(v, R, P, p, &c->t[i].val[k][b], &c->t[i].se[k][b]);
			}
	}
	for (int k = 0; k < N_SCALARS; k++, p++)
		stat(v, R, P, p, scalar_slot(c, k, 0), scalar_slot(c, k, 1));
	/* samples behind the fields and the spectrum: the fewest of any replica; the spectrum's slope: the
	 * mean over the replicas, dspec_alpha_se its standard error over them */
	double fs = INFINITY, ds = INFINITY;
	for (int r = 0; r < R; r++) {
		fs = fmin(fs, v[(size_t)r * P + p]);
		ds = fmin(ds, v[(size_t)r * P + p + 1]);
	}
	c->fields_samples = R > 0 ? (int)fs : 0;
	c->dspec_samples = R > 0 ? (int)ds : 0;
	stat(v, R, P, p + 2, &c->dspec_alpha, &c->dspec_alpha_se);
	return c;
}
