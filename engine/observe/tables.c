/* The curve tables of a scene (names, bins, columns): one description for obs_create() and admission control. */
#include "observe/tables.h"

#include <math.h>
#include <string.h>

#include "observe/clusters.h"
#include "observe/dspec.h"

#define PI 3.14159265358979323846

/* observe.h: here, so that admission control need not link obs_create() and FFTW */
unsigned obs_curve_bits(const scene_t *s)
{
	return s->observables & OBS_CURVE_BITS;
}

/* Table i with nb bins and ncols columns named by cols (NULL-terminated). */
static obs_table_t *table(obs_curves_t *c, const char *family, const char *sub, const char *x, const char *x_unit,
                          int nb, const char *const *cols)
{
	obs_table_t *t = &c->t[c->ntables++];
	t->family = family;
	t->table = sub;
	t->x = x;
	t->x_unit = x_unit;
	t->nb = nb;
	t->ncols = 0;
	while (cols[t->ncols] && t->ncols < OBS_MAX_COLS) {
		t->col[t->ncols] = cols[t->ncols];
		t->ncols++;
	}
	return t;
}

void tables_layout(obs_curves_t *c, const scene_t *s, int J)
{
	static const char *const comp3[] = {"p_x", "p_y", "p_z", NULL}, *const comp2[] = {"p_x", "p_y", NULL};
	static const char *const speed[] = {"p", NULL}, *const gcols[] = {"g", NULL}, *const scol[] = {"s", NULL};
	static const char *const vpairs[] = {"g_par", "g_perp", "g_nn", NULL}, *const vmodes[] = {"s_par", "s_perp", NULL};
	static const char *const ncol[] = {"n_s", NULL}, *const bcols[] = {"p", "n", NULL};
	const int D = s->dim, spin_dim = s->rough ? (D == 2 ? 1 : 3) : 0;
	const unsigned bits = obs_curve_bits(s);
	int vnb = s->vdist_bins, gnb = s->gofr_bins, bnb = (bits & SCENE_OBS_IMPACT) ? s->impact_bins : 0;
	if (bits & SCENE_OBS_VDIST) {
		static const char *const wcomp3[] = {"p_x", "p_y", "p_z", NULL}, *const wcomp1[] = {"p", NULL};
		table(c, "velocity_distribution", "components", "c", "1", vnb, D == 3 ? comp3 : comp2);
		table(c, "velocity_distribution", "speed", "c", "1", vnb, speed);
		if (spin_dim)   /* rough particles: the angular velocities, scaled by their thermal value */
			table(c, "velocity_distribution", "spin", "c", "1", vnb, spin_dim == 3 ? wcomp3 : wcomp1);
	}
	if (bits & SCENE_OBS_GOFR) {
		table(c, "pair_correlation", "", "r", "l0", gnb, gcols);
		if (s->n_species > 1 && s->n_species <= OBS_GOFR_SPECIES_MAX) {
			/* mixtures: g_ab(r) of each pair of species a <= b (scene order), and their contact values */
			static const char *const names[OBS_GOFR_SPECIES_MAX][OBS_GOFR_SPECIES_MAX] = {
				{"g_00", "g_01", "g_02", "g_03"}, {NULL, "g_11", "g_12", "g_13"},
				{NULL, NULL, "g_22", "g_23"}, {NULL, NULL, NULL, "g_33"},
			};
			static const char *const ccols[] = {"g", "g_se", "sigma", NULL};
			const char *pcols[OBS_MAX_COLS + 1];
			int k = 0;
			for (int a = 0; a < s->n_species; a++)
				for (int b = a; b < s->n_species; b++)
					pcols[k++] = names[a][b];
			pcols[k] = NULL;
			table(c, "pair_correlation", "species", "r", "l0", gnb, pcols);
			table(c, "pair_correlation", "contact", "pair", "1", k, ccols);
		}
	}
	if (bits & SCENE_OBS_SOFK)
		table(c, "structure_factor", "", "k", "l0-1", J, scol);
	if (bits & SCENE_OBS_VCORR) {
		table(c, "velocity_correlations", "pairs", "r", "l0", gnb, vpairs);
		table(c, "velocity_correlations", "modes", "k", "l0-1", J, vmodes);
	}
	if (bits & SCENE_OBS_CLUSTERS)
		table(c, "clusters", "", "s", "1", clusters_size_bins(scene_slots(s), NULL, NULL), ncol);
	if (bits & SCENE_OBS_IMPACT)
		table(c, "impact_parameter", "", "b", "1", bnb, bcols);
	if (bits & SCENE_OBS_FIELDS) {
		static const char *const dcols[] = {"n", "count", NULL}, *const u3[] = {"u_x", "u_y", "u_z", NULL},
		                         *const u2[] = {"u_x", "u_y", NULL}, *const tcols[] = {"T", NULL},
		                         *const w3[] = {"w_x", "w_y", "w_z", NULL}, *const w1[] = {"w", NULL};
		int nc = s->fields_cells[0] * s->fields_cells[1] * s->fields_cells[2];
		obs_table_t *ft[4];
		int k = 0;
		ft[k++] = table(c, "fields", "density", "cell", "1", nc, dcols);
		ft[k++] = table(c, "fields", "velocity", "cell", "1", nc, D == 3 ? u3 : u2);
		ft[k++] = table(c, "fields", "temperature", "cell", "1", nc, tcols);
		if (spin_dim)
			ft[k++] = table(c, "fields", "spin", "cell", "1", nc, D == 3 ? w3 : w1);
		for (int i = 0; i < k; i++)
			for (int a = 0; a < 3; a++)
				ft[i]->shape[a] = a < D ? s->fields_cells[a] : 0;
	}

	if (bits & SCENE_OBS_DSPEC) {
		static const char *const pcols[] = {"P", NULL};
		table(c, "density_spectrum", "", "f", "t0-1", dspec_bins(s->dspec_m), pcols);
	}
	if (bits & SCENE_OBS_SURFACE) {
		static const char *const hcols[] = {"h", "n", NULL};
		table(c, "surface_profile", "", "x", "l0", s->surf_bins, hcols);
	}
}

/* Shells of width dk from dk/2 up to the smallest axis's Nyquist wave number kny (at least one). */
static int shells(double kny, double dk)
{
	int J = (int)floor(kny / dk - 0.5);
	return J < 1 ? 1 : J;
}

int tables_k_shells(int dim, const double *box, const int m[3], const int *walled)
{
	if (dim != 2 && dim != 3)
		return 0;
	double lmax = 0, kny = INFINITY;
	for (int a = 0; a < dim; a++) {
		int w = walled && walled[a];
		if ((!w && m[a] < 4) || !(box[a] > 0) || !isfinite(box[a]))
			return 0;
		if (w)
			continue;
		lmax = fmax(lmax, box[a]);
		kny = fmin(kny, PI * (double)m[a] / box[a]);
	}
	return lmax > 0 ? shells(kny, 2 * PI / lmax) : 0;
}

void tables_of(const scene_t *s, obs_curves_t *out)
{
	memset(out, 0, sizeof(*out));
	int walled[3];
	for (int a = 0; a < 3; a++)
		walled[a] = s->boundary[a].walled;
	int J = obs_curve_bits(s) & (SCENE_OBS_SOFK | SCENE_OBS_VCORR) ? tables_k_shells(s->dim, s->box, s->sofk_grid, walled)
	                                                                : 0;
	tables_layout(out, s, J);
}

size_t tables_json_max(const obs_curves_t *c, int ensemble)
{
	/* each number at most 16 characters (-1.23456789e-123) plus a comma;
	 * per table: edges, centres, a value per column and (ensembles) a
	 * standard error per column */
	const size_t per_col = ensemble ? 2 : 1;
	size_t n = 1024;
	for (int i = 0; i < c->ntables; i++)
		n += 256 + 17 * (size_t)(2 * c->t[i].nb + 1 + per_col * (size_t)c->t[i].nb * c->t[i].ncols);
	return n;
}
