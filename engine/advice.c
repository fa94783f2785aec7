/* Method advice: cost and error estimates from the fitted trade-off model, and the choice for "method": "auto". */
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "advice.h"
#include "mc/dsmc.h"
#include "md/md.h"
#include "engine/advice_model_json.h"   /* generated from data/advice-model.json: advice_model_text[] */

#define GRID_MAX 8
#define TAU_MAX 16
#define VARIANTS_MAX 8
/* Cost per operation is measured at one N; beyond this factor caches change it (docs/benchmarks.md). */
#define SIZE_FACTOR 10.0

typedef struct {
	char name[16];
	double bias[GRID_MAX][GRID_MAX][TAU_MAX];     /* [volume fraction][lambda][Haff time] */
	double spread[GRID_MAX][GRID_MAX][TAU_MAX];   /* relative SE of T x sqrt(N replicas) */
	double clustering;                   /* error measured past the last Haff time; NAN = not measured */
} variant_t;

typedef struct {
	double ed_a, ed_b;                   /* ed: s per collision = a + b / (nu chi) */
	double mc_move[2], mc_coll[2];       /* [0] dsmc, [1] hsmc */
	int has_md;                          /* cost.md.D given (optional: models before md lack it) */
	double md_step, md_step_nu;          /* md: s per particle-step = md_step + md_step_nu nu */
	int nnu, nlam, ntau;
	double nu[GRID_MAX], lam[GRID_MAX], tau[TAU_MAX];
	double xnu[GRID_MAX];                /* the density coordinate of each grid volume fraction */
	int nvar;
	variant_t var[VARIANTS_MAX];
} dimmodel_t;

struct advice_model {
	int version;
	char date[32];
	double particles;        /* N of the measured table */
	int contact_axis;        /* interpolate in chi(nu) - 1 (1) or in nu (0) */
	dimmodel_t d[2];         /* D = 2, 3 */
};

const char *advice_model_builtin(size_t *len)
{
	if (len)
		*len = sizeof(advice_model_text) - 1;
	return advice_model_text;
}

const char *advice_strerror(int code)
{
	switch (code) {
	case ADVICE_OK: return "success";
	case ADVICE_ENOMEM: return "out of memory";
	case ADVICE_EMODEL: return "invalid advice model";
	case ADVICE_ESCENE: return "scene cannot be estimated";
	default: return "unknown error";
	}
}

/* ---- model parsing ---------------------------------------------------------- */

typedef struct {
	char *err;
	size_t errlen;
} pctx_t;

static int bad(pctx_t *c, const char *path, const char *fmt, ...)
{
	if (c->err && c->errlen) {
		int n = snprintf(c->err, c->errlen, "%s: ", path);
		va_list ap;
		va_start(ap, fmt);
		if (n >= 0 && (size_t)n < c->errlen)
			vsnprintf(c->err + n, c->errlen - n, fmt, ap);
		va_end(ap);
	}
	return -1;
}

/* A finite number >= lo at obj.key. */
static int num_at(pctx_t *c, const json_t *obj, const char *path, const char *key, double lo, double *out)
{
	char p[160];
	snprintf(p, sizeof p, "%s%s%s", path, *path ? "." : "", key);
	json_t *v = json_object_get(obj, key);
	if (!v)
		return bad(c, p, "required key missing");
	if (!json_is_number(v) || !isfinite(json_number_value(v)) || json_number_value(v) < lo)
		return bad(c, p, "must be a finite number >= %g", lo);
	*out = json_number_value(v);
	return 0;
}

static json_t *obj_at(pctx_t *c, json_t *obj, const char *path, const char *key)
{
	char p[160];
	snprintf(p, sizeof p, "%s%s%s", path, *path ? "." : "", key);
	json_t *v = json_object_get(obj, key);
	if (!json_is_object(v)) {
		bad(c, p, v ? "must be an object" : "required key missing");
		return NULL;
	}
	return v;
}

/* A strictly increasing array of 1..max numbers > 0. */
static int axis(pctx_t *c, json_t *obj, const char *path, const char *key, int max, double *out, int *n)
{
	char p[160];
	snprintf(p, sizeof p, "%s.%s", path, key);
	json_t *a = json_object_get(obj, key), *v;
	size_t i;
	if (!json_is_array(a) || json_array_size(a) < 1 || json_array_size(a) > (size_t)max)
		return bad(c, p, "must be an array of 1 to %d numbers", max);
	json_array_foreach(a, i, v) {
		if (!json_is_number(v) || !(json_number_value(v) > 0) || (i > 0 && !(json_number_value(v) > out[i - 1])))
			return bad(c, p, "must hold increasing numbers > 0");
		out[i] = json_number_value(v);
	}
	*n = (int)json_array_size(a);
	return 0;
}

/* A nnu x nlam x ntau array of numbers >= 0. */
static int cube(pctx_t *c, json_t *obj, const char *path, const char *key, int nnu, int nlam, int ntau,
                double m[GRID_MAX][GRID_MAX][TAU_MAX])
{
	char p[160];
	snprintf(p, sizeof p, "%s.%s", path, key);
	json_t *a = json_object_get(obj, key);
	if (!json_is_array(a) || json_array_size(a) != (size_t)nnu)
		return bad(c, p, "must be an array of %d rows (one per volume fraction)", nnu);
	for (int i = 0; i < nnu; i++) {
		json_t *row = json_array_get(a, i);
		if (!json_is_array(row) || json_array_size(row) != (size_t)nlam)
			return bad(c, p, "row %d must hold %d arrays (one per lambda)", i, nlam);
		for (int j = 0; j < nlam; j++) {
			json_t *cur = json_array_get(row, j);
			if (!json_is_array(cur) || json_array_size(cur) != (size_t)ntau)
				return bad(c, p, "[%d][%d] must hold %d numbers (one per Haff time)", i, j, ntau);
			for (int k = 0; k < ntau; k++) {
				json_t *v = json_array_get(cur, k);
				if (!json_is_number(v) || !(json_number_value(v) >= 0) || !isfinite(json_number_value(v)))
					return bad(c, p, "[%d][%d][%d] must be a finite number >= 0", i, j, k);
				m[i][j][k] = json_number_value(v);
			}
		}
	}
	return 0;
}

/* The coordinate in which the error is interpolated across densities:
 * chi(nu) - 1 follows the collision rate (and dsmc/none's bias, which is
 * the missing chi), so it is closer to linear than nu itself. */
static double density_coordinate(int dim, double nu, int contact_axis)
{
	return contact_axis ? dsmc_contact_value(dim, nu) - 1 : nu;
}

static int parse_dim(pctx_t *c, json_t *root, int dim, dimmodel_t *d, int contact_axis)
{
	char path[64], p2[96];
	json_t *cost = obj_at(c, root, "", "cost"), *err = cost ? obj_at(c, root, "", "error") : NULL, *o, *vars, *v;
	const char *key, *dk = dim == 2 ? "2" : "3";
	if (!cost || !err)
		return -1;
	json_t *ed = obj_at(c, cost, "cost", "ed");
	if (!ed || !(o = obj_at(c, ed, "cost.ed", dk)))
		return -1;
	snprintf(path, sizeof path, "cost.ed.%s", dk);
	if (num_at(c, o, path, "per_collision", 0, &d->ed_a) || num_at(c, o, path, "per_collision_dilute", 0, &d->ed_b))
		return -1;
	static const char *const mc[2] = {"dsmc", "hsmc"};
	for (int k = 0; k < 2; k++) {
		snprintf(path, sizeof path, "cost.%s", mc[k]);
		json_t *m = obj_at(c, cost, "cost", mc[k]);
		if (!m || !(o = obj_at(c, m, path, dk)))
			return -1;
		snprintf(path, sizeof path, "cost.%s.%s", mc[k], dk);
		if (num_at(c, o, path, "per_move", 0, &d->mc_move[k]) || num_at(c, o, path, "per_collision", 0, &d->mc_coll[k]))
			return -1;
	}
	json_t *md = json_object_get(cost, "md");
	if (md) {   /* optional (bench/tradeoff.py --md adds it) */
		if (!(o = obj_at(c, md, "cost.md", dk)))
			return -1;
		snprintf(path, sizeof path, "cost.md.%s", dk);
		if (num_at(c, o, path, "per_particle_step", 0, &d->md_step) ||
		    num_at(c, o, path, "per_particle_step_density", 0, &d->md_step_nu))
			return -1;
		d->has_md = 1;
	}
	snprintf(path, sizeof path, "error.%s", dk);
	if (!(o = obj_at(c, err, "error", dk)))
		return -1;
	if (axis(c, o, path, "volume_fraction", GRID_MAX, d->nu, &d->nnu) ||
	    axis(c, o, path, "lambda", GRID_MAX, d->lam, &d->nlam) || axis(c, o, path, "haff_time", TAU_MAX, d->tau, &d->ntau))
		return -1;
	for (int i = 0; i < d->nnu; i++)
		d->xnu[i] = density_coordinate(dim, d->nu[i], contact_axis);
	snprintf(p2, sizeof p2, "%s.variants", path);
	if (!(vars = obj_at(c, o, path, "variants")))
		return -1;
	json_t *clu = json_object_get(o, "clustering");
	json_object_foreach(vars, key, v) {
		char vp[160];
		if (d->nvar == VARIANTS_MAX)
			return bad(c, p2, "more than %d variants", VARIANTS_MAX);
		variant_t *x = &d->var[d->nvar++];
		snprintf(vp, sizeof vp, "%s.%s", p2, key);
		if (strlen(key) >= sizeof x->name)
			return bad(c, vp, "name too long");
		snprintf(x->name, sizeof x->name, "%s", key);
		if (!json_is_object(v))
			return bad(c, vp, "must be an object");
		if (cube(c, v, vp, "bias", d->nnu, d->nlam, d->ntau, x->bias) ||
		    cube(c, v, vp, "spread", d->nnu, d->nlam, d->ntau, x->spread))
			return -1;
		json_t *cv = json_object_get(clu, key);
		x->clustering = json_is_number(cv) && json_number_value(cv) >= 0 ? json_number_value(cv) : NAN;
	}
	return 0;
}

advice_model_t *advice_model_create(const char *json, size_t len, char *err, size_t errlen)
{
	pctx_t c = {err, errlen};
	json_error_t je;
	advice_model_t *m = NULL;
	json_t *root = json_loadb(json ? json : "", json ? len : 0, JSON_REJECT_DUPLICATES, &je), *v;
	if (err && errlen)
		err[0] = '\0';
	if (!root) {
		bad(&c, "(root)", "not valid JSON at line %d column %d: %s", je.line, je.column, je.text);
		goto cleanup;
	}
	if (!json_is_object(root)) {
		bad(&c, "(root)", "must be a JSON object");
		goto cleanup;
	}
	v = json_object_get(root, "format");
	if (!json_is_string(v) || strcmp(json_string_value(v), "granulard-advice-model")) {
		bad(&c, "format", "must be \"granulard-advice-model\"");
		goto cleanup;
	}
	v = json_object_get(root, "version");
	if (!json_is_integer(v) || json_integer_value(v) != 2) {
		bad(&c, "version", "must be 2 (this build reads model version 2)");
		goto cleanup;
	}
	m = calloc(1, sizeof(*m));
	if (!m) {
		bad(&c, "(root)", "out of memory");
		goto cleanup;
	}
	m->version = 2;
	v = json_object_get(root, "density_axis");
	if (v && (!json_is_string(v) || (strcmp(json_string_value(v), "contact_value") &&
	                                  strcmp(json_string_value(v), "volume_fraction")))) {
		bad(&c, "density_axis", "must be \"contact_value\" or \"volume_fraction\"");
		free(m);
		m = NULL;
		goto cleanup;
	}
	m->contact_axis = !v || !strcmp(json_string_value(v), "contact_value");
	json_t *gen = json_object_get(root, "generated");
	snprintf(m->date, sizeof m->date, "%s", json_is_string(json_object_get(gen, "date"))
	                                        ? json_string_value(json_object_get(gen, "date")) : "");
	if (num_at(&c, root, "", "particles_measured", 2, &m->particles) ||
	    parse_dim(&c, root, 2, &m->d[0], m->contact_axis) ||
	    parse_dim(&c, root, 3, &m->d[1], m->contact_axis)) {
		free(m);
		m = NULL;
	}
cleanup:
	json_decref(root);
	return m;
}

void advice_model_destroy(advice_model_t *m)
{
	free(m);
}

double advice_model_particles(const advice_model_t *m)
{
	return m->particles;
}

/* ---- physics ------------------------------------------------------------------ */

double advice_haff_cpp(int dim, double f0, double lambda, double t)
{
	/* dT/dt = -(lambda / D) f(T) T with f ~ sqrt(T): T = T0 / (1 + a t)^2,
	 * a = lambda f0 / (2D); collisions per particle = int f dt. */
	if (!(f0 > 0) || !(t > 0))
		return 0;
	double a = lambda * f0 / (2.0 * dim);
	return a * t < 1e-8 ? f0 * t : f0 / a * log1p(a * t);
}

/* Time at which a gas reaches cpp collisions per particle (inverse of the above). */
static double haff_time_of_cpp(int dim, double f0, double lambda, double cpp)
{
	if (!(f0 > 0))
		return INFINITY;
	double a = lambda * f0 / (2.0 * dim);
	return a * cpp / f0 < 1e-8 ? cpp / f0 : expm1(a * cpp / f0) / a;
}

/* Piecewise-linear interpolation on an axis; *out_of_range when x lies outside
 * [ax[0], ax[n-1]] (the value is then clamped). Returns the cell and weight. */
static void locate(const double *ax, int n, double x, int *i, double *w, int *out_of_range)
{
	*out_of_range = x < ax[0] * (1 - 1e-9) || x > ax[n - 1] * (1 + 1e-9);
	if (n == 1 || x <= ax[0]) {
		*i = 0, *w = 0;
		return;
	}
	if (x >= ax[n - 1]) {
		*i = n - 2, *w = 1;
		return;
	}
	int k = 0;
	while (k < n - 2 && x > ax[k + 1])
		k++;
	*i = k, *w = (x - ax[k]) / (ax[k + 1] - ax[k]);
}

/* One grid point's curve at Haff time tau: linear between the measured
 * times; below the first, the bias linear towards 0 at tau = 0 (both runs
 * start from the same state) and the spread constant; beyond the last,
 * clamped (the caller flags it). */
static double along_tau(const dimmodel_t *d, const double *curve, double tau, int is_bias)
{
	if (tau <= d->tau[0])
		return is_bias ? curve[0] * (tau > 0 ? tau / d->tau[0] : 0) : curve[0];
	int k, o;
	double w;
	locate(d->tau, d->ntau, tau, &k, &w, &o);
	return d->ntau > 1 ? (1 - w) * curve[k] + w * curve[k + 1] : curve[0];
}

/* Bilinear in (density coordinate, lambda) of the grid points' values at
 * tau; below the first lambda, linear towards 0 at lambda = 0. */
static double interp(const advice_model_t *m, const dimmodel_t *d, const double c[GRID_MAX][GRID_MAX][TAU_MAX],
                     int dim, double nu, double lam, double tau, int is_bias, unsigned *x)
{
	int i, j, o1, o2;
	double wi, wj;
	locate(d->nu, d->nnu, nu, &i, &wi, &o1);   /* for the range check */
	if (o1)
		*x |= ADVICE_X_DENSITY;
	locate(d->xnu, d->nnu, density_coordinate(dim, nu, m->contact_axis), &i, &wi, &o1);
	double lc = lam < d->lam[0] ? d->lam[0] : lam;
	locate(d->lam, d->nlam, lc, &j, &wj, &o2);
	if (lam > d->lam[d->nlam - 1] * (1 + 1e-9))
		*x |= ADVICE_X_DISSIPATION;
	int i1 = d->nnu > 1 ? i + 1 : i, j1 = d->nlam > 1 ? j + 1 : j;
#define AT(a, b) along_tau(d, c[a][b], tau, is_bias)
	double v = (1 - wi) * ((1 - wj) * AT(i, j) + wj * AT(i, j1)) + wi * ((1 - wj) * AT(i1, j) + wj * AT(i1, j1));
#undef AT
	return lam < d->lam[0] ? v * lam / d->lam[0] : v;
}

static void note(advice_estimate_t *e, const char *fmt, ...)
{
	size_t k = strlen(e->notes);
	if (k + 3 >= sizeof e->notes)
		return;
	if (k)
		k += (size_t)snprintf(e->notes + k, sizeof e->notes - k, "; ");
	va_list ap;
	va_start(ap, fmt);
	vsnprintf(e->notes + k, sizeof e->notes - k, fmt, ap);
	va_end(ap);
}

static const variant_t *find_variant(const dimmodel_t *d, const char *name)
{
	for (int i = 0; i < d->nvar; i++)
		if (!strcmp(d->var[i].name, name))
			return &d->var[i];
	return NULL;
}

static const char *const corr_names[] = {"default", "none", "enskog", "cba"};

/* Output records cut MC steps short: one extra step each. */
static double outputs(const scene_t *s, double t_end, double cpp)
{
	double n = 0;
	if (s->every.kind == SCENE_CLOCK_TIME && s->every.value > 0)
		n = t_end / s->every.value;
	else if (s->every.kind == SCENE_CLOCK_CPP && s->every.value > 0)
		n = cpp / s->every.value;
	return isfinite(n) ? ceil(n) : 0;
}

/* The correction a scene's MC method resolves to (dsmc_params()'s default). */
static int resolved_correction(scene_method_t method, int corr)
{
	return corr != SCENE_MC_DEFAULT ? corr : method == SCENE_METHOD_HSMC ? SCENE_MC_CBA : SCENE_MC_NONE;
}

/* Gravity pulls the particles onto a wall: along some walled axis gravity
 * has a component (the wall it points to then carries a bed). */
static int bed_forms(const scene_t *s)
{
	for (int a = 0; a < s->dim; a++)
		if (s->boundary[a].walled && s->gravity[a] != 0)
			return 1;
	return 0;
}

/* md's step for scene s as the run computes it (run.c: the core's reference contact time, from the lightest
 * mass, the largest radius and the largest restitution of the pairs, over md.time_step): a core of one
 * particle per species without positions (memory only). 0, or -1 when the core refuses the settings. */
static int md_step_of(const scene_t *s, double *dt)
{
	double radii[SCENE_SPECIES_MAX], masses[SCENE_SPECIES_MAX], epair[SCENE_SPECIES_MAX * SCENE_SPECIES_MAX];
	int sp[SCENE_SPECIES_MAX], pairwise = 0;
	const int ns = s->n_species > 0 ? s->n_species : 1;
	for (int k = 0; k < ns; k++) {
		radii[k] = s->n_species > 0 ? s->species[k].radius : s->radius;
		masses[k] = s->n_species > 0 ? s->species[k].mass : s->mass;
		sp[k] = k;
		for (int b = 0; b < s->n_species; b++) {   /* run.c's rule: pairs only when one differs */
			epair[k * s->n_species + b] = s->restitution_pair[k][b];
			pairwise |= s->n_species > 1 && s->restitution_pair[k][b] != s->restitution;
		}
	}
	md_params_t p = {
		.dim = s->dim, .n = ns, .radius = s->radius, .mass = s->mass, .radii = radii, .masses = masses,
		.law = s->md_law ? MD_LAW_HERTZ : MD_LAW_LINEAR, .restitution = s->restitution,
		.v_ref = s->md_impact_speed, .dt_steps = s->md_time_step > 0 ? 1.0 / s->md_time_step : 0,
		.n_species = pairwise ? s->n_species : 0, .species = pairwise ? sp : NULL,
		.restitution_pair = pairwise ? epair : NULL,
	};
	for (int a = 0; a < 3; a++) {
		p.box[a] = a < s->dim ? s->box[a] : 1.0;
		p.periodic[a] = a < s->dim ? !s->boundary[a].walled : 1;
	}
	if (s->md_law)
		p.young = s->md_stiffness;
	else if (s->md_contact_time > 0)
		p.t_contact = s->md_contact_time;
	else
		p.kn = s->md_stiffness;
	md_t *md = md_create(&p, NULL);
	if (!md)
		return -1;
	*dt = md_dt(md);
	md_destroy(md);
	return 0;
}

/* The md settings the model's md error was measured with (bench/tradeoff.py --md): one species, the linear
 * law at the default stiffness (max_overlap 0.01 at the default impact speed, scene.c), the step t_c / 50,
 * no friction. */
static int md_default_settings(const scene_t *s)
{
	double fall = 0.0;
	for (int a = 0; a < s->dim; a++)
		fall += fabs(s->gravity[a]) * s->box[a];
	const double v = fmax(4.0 * sqrt(s->temperature / s->mass), sqrt(2.0 * fall)), d = 0.02 * s->radius;
	const double k = s->mass * v * v / (d * d);
	return s->n_species == 0 && s->md_law == 0 && s->md_contact_time == 0 && fabs(s->md_stiffness - k) <= 1e-9 * k &&
	       fabs(s->md_time_step - 1.0 / 50.0) <= 1e-12 && s->md_friction == 0 && s->md_rolling == 0;
}

/* One candidate's estimate (correction: resolved, 0 for ed). The scene's own
 * method and correction is estimated with its settings, the others at the
 * defaults with that correction. */
static int estimate_one(const advice_model_t *m, const scene_t *s, scene_method_t method, int correction, int ranks,
                        double tau, advice_estimate_t *e, char *err, size_t errlen)
{
	const dimmodel_t *d = &m->d[s->dim == 3];
	const int D = s->dim;
	const int own = s->method == method &&
	                (method == SCENE_METHOD_ED || resolved_correction(method, s->mc_correction) == correction);
	const double N = (double)s->count, R = (double)s->replicas, nu = s->volume_fraction;
	const double lam = 1 - s->restitution * s->restitution;
	const double chi_hs = dsmc_contact_value(D, nu);
	const double f_hs = dsmc_collision_frequency(D, nu, s->radius, s->mass, s->temperature, chi_hs);
	double chi = chi_hs, cpp, relax_steps = 0, steps = 0, t_end;
	char warn[512] = "";

	memset(e, 0, sizeof(*e));
	e->method = method;
	e->meets = -1;
	if (method == SCENE_METHOD_ED) {
		snprintf(e->variant, sizeof e->variant, "ed");
		e->cell_size = s->ed_cell_size;
	} else if (method == SCENE_METHOD_MD) {   /* only the scene's own method (candidates()) */
		snprintf(e->variant, sizeof e->variant, "md");
		if (md_step_of(s, &e->time_step) != 0) {
			snprintf(err, errlen, "md: the time step cannot be computed for this scene");
			return ADVICE_ESCENE;
		}
		if (!md_default_settings(s)) {
			e->extrapolated |= ADVICE_X_SETTINGS;
			note(e, "md error measured for one species at the default stiffness and step (linear law, max_overlap "
			     "0.01, time_step 1/50, no friction or rolling resistance)");
		}
	} else {
		scene_t c = *s;
		dsmc_params_t p;
		c.method = method;
		if (!own) {   /* the defaults: what the engine picks for a dsmc/hsmc object with only a correction */
			c.mc_cell_size = c.mc_time_step = c.mc_collisions_per_step = c.mc_max_volume_fraction = 0;
			c.mc_correction = (scene_mc_correction_t)correction;
		}
		if (dsmc_params(&c, &p, warn, sizeof warn) != DSMC_OK) {
			snprintf(err, errlen, "method: %s cannot be estimated for this scene", scene_method_name(method));
			return ADVICE_ESCENE;
		}
		e->correction = p.correction;
		snprintf(e->variant, sizeof e->variant, "%s/%s", scene_method_name(method), corr_names[p.correction]);
		e->cell_size = p.cell_edge / (2 * s->radius);
		e->collisions_per_step = p.collisions_per_step;
		e->time_step = p.time_step;
		e->max_volume_fraction = method == SCENE_METHOD_HSMC ? p.max_volume_fraction : 0;
		chi = p.chi;
		if (own && (c.mc_cell_size > 0 || c.mc_time_step > 0 ||
		            (c.mc_collisions_per_step > 0 && c.mc_collisions_per_step != 0.2) ||
		            (c.mc_max_volume_fraction > 0 && method == SCENE_METHOD_HSMC))) {
			e->extrapolated |= ADVICE_X_SETTINGS;
			note(e, "error measured at default settings only (automatic cell, 0.2 collisions per step)");
		}
		if (warn[0]) {
			e->extrapolated |= ADVICE_X_VALIDITY;
			note(e, "validity warning: %s", warn);
		}
	}

	/* Work: the production run of the gas this method simulates, plus the relax. */
	const double f0 = chi_hs > 0 ? f_hs * chi / chi_hs : 0;
	if (s->until.kind == SCENE_CLOCK_TIME) {
		t_end = s->until.value;
		cpp = advice_haff_cpp(D, f0, lam, t_end);
	} else {
		cpp = s->until.value;
		t_end = haff_time_of_cpp(D, f0, lam, cpp);
	}
	e->collisions = R * N / 2 * (cpp + s->relax_cpp);
	if (method == SCENE_METHOD_ED) {
		double per = d->ed_a + d->ed_b / (nu * chi_hs);
		e->cpu_seconds = e->collisions * per;
		e->setup_cpu_seconds = R * N / 2 * s->relax_cpp * per;
	} else if (method == SCENE_METHOD_MD) {
		/* the run's steps: run.until.time over dt, rounded up (run.c); moves = particle-steps */
		steps = isfinite(t_end) ? ceil(t_end / e->time_step) : INFINITY;
		e->moves = R * N * steps;
		e->cpu_seconds = d->has_md ? e->moves * (d->md_step + d->md_step_nu * nu) : NAN;
		if (!d->has_md)
			note(e, "the model has no md cost (bench/tradeoff.py --md adds it)");
	} else {
		const int k = method == SCENE_METHOD_HSMC;
		double out = outputs(s, t_end, cpp);
		if (e->collisions_per_step > 0) {
			steps = cpp / e->collisions_per_step + out;
			relax_steps = s->relax_cpp / e->collisions_per_step;
		} else {
			steps = (isfinite(t_end) ? t_end / e->time_step : 0) + out;
			relax_steps = f0 > 0 ? s->relax_cpp / f0 / e->time_step : 0;
		}
		e->moves = R * N * (steps + relax_steps);
		e->cpu_seconds = e->moves * d->mc_move[k] + e->collisions * d->mc_coll[k];
		e->setup_cpu_seconds = R * N * (relax_steps * d->mc_move[k] + s->relax_cpp / 2 * d->mc_coll[k]);
	}
	/* Replicas are spread over the ranks; one replica runs on one rank. */
	double per_rank = ceil(R / (ranks < 1 ? 1 : ranks));
	e->wall_seconds = e->cpu_seconds / R * per_rank;
	if (N > SIZE_FACTOR * m->particles) {
		e->extrapolated |= ADVICE_X_SIZE;
		note(e, "cost per operation measured at N = %.0f; much larger systems run slower per operation "
		     "(caches; docs/benchmarks.md)", m->particles);
	}

	/* Bounded scenes: what the periodic gas's model cannot say (advice.h). */
	if (method != SCENE_METHOD_ED && bed_forms(s)) {
		e->refused = method == SCENE_METHOD_DSMC;
		if (e->refused)
			note(e, "refused: gravity pulls the particles onto a wall, and dsmc's point particles have no excluded "
			     "volume: the bed collapses onto the floor (seed 000 A12, the gravity box: docs/tradeoff.md, "
			     "\"Bounded scenes\")");
	}
	if (method != SCENE_METHOD_ED && (scene_has_walls(s) || scene_has_gravity(s))) {
		e->extrapolated |= ADVICE_X_BOUNDED;
		note(e, "walls or gravity: the error model is the periodic gas's, and the trade on bounded scenes is measured "
		     "in docs/tradeoff.md (\"Bounded scenes\"), not modelled");
	}

	/* Expected error. */
	unsigned x = 0;
	const variant_t *v = find_variant(d, e->variant);
	if (!v) {
		e->extrapolated |= ADVICE_X_VARIANT;
		e->bias = e->statistical = e->error = NAN;
		note(e, "no measured error for %s", e->variant);
		return ADVICE_OK;
	}
	e->bias = method == SCENE_METHOD_ED ? 0 : interp(m, d, v->bias, D, nu, lam, tau, 1, &x);   /* md: soft contacts */
	double spread = interp(m, d, v->spread, D, nu, lam, tau, 0, &x);
	e->statistical = spread / sqrt(N * R);
	const double tau_max = d->tau[d->ntau - 1];
	if (lam > 0 && tau > tau_max * (1 + 1e-9)) {
		x |= ADVICE_X_CLUSTERING;
		if (method != SCENE_METHOD_ED && isfinite(v->clustering) && v->clustering > e->bias)
			e->bias = v->clustering;
	}
	e->error = hypot(e->bias, e->statistical);
	if (x & ADVICE_X_DENSITY)
		note(e, "volume fraction %.3g outside the measured %.3g..%.3g", nu, d->nu[0], d->nu[d->nnu - 1]);
	if (x & ADVICE_X_DISSIPATION)
		note(e, "1 - e^2 = %.3g above the measured %.3g", lam, d->lam[d->nlam - 1]);
	if (x & ADVICE_X_CLUSTERING)
		note(e, "runs to Haff time %.3g, beyond the measured homogeneous cooling (%.3g): clustering regime%s", tau,
		     tau_max, method != SCENE_METHOD_ED && isfinite(v->clustering) ? ", bias at least the measured clustering error" : "");
	e->extrapolated |= x;
	return ADVICE_OK;
}

static void choose(advice_t *a)
{
	int best = -1;
	for (int i = 0; i < a->n; i++) {
		advice_estimate_t *e = &a->est[i];
		e->meets = isfinite(e->error) && e->error <= a->target && !e->refused &&
		           (e->method == SCENE_METHOD_ED || !(e->extrapolated & ADVICE_X_ERROR));
		if (e->meets && (best < 0 || e->cpu_seconds < a->est[best].cpu_seconds))
			best = i;
	}
	size_t k = 0;
	char *r = a->reason;
	const size_t n = sizeof a->reason;
#define ADD(...) do { if (k < n) k += (size_t)snprintf(r + k, n - k, __VA_ARGS__); } while (0)
	if (best >= 0) {
		const advice_estimate_t *b = &a->est[best];
		a->choice = best;
		ADD("%s: the cheapest method expected to meet the temperature error target %.3g (expected %.3g, %.3g CPU s)",
		    b->variant, a->target, b->error, b->cpu_seconds);
		for (int i = 0; i < a->n; i++) {
			const advice_estimate_t *e = &a->est[i];
			if (i == best)
				continue;
			if (e->meets)
				ADD("; %s also meets it but costs %.3g CPU s", e->variant, e->cpu_seconds);
			else if (e->refused)
				ADD("; %s: %.*s", e->variant, (int)strcspn(e->notes, ";"), e->notes);
			else if (e->method != SCENE_METHOD_ED && (e->extrapolated & ADVICE_X_BOUNDED))
				ADD("; %s: error not trusted on a bounded scene (docs/tradeoff.md)", e->variant);
			else if (e->method != SCENE_METHOD_ED && (e->extrapolated & ADVICE_X_ERROR))
				ADD("; %s: error not trusted here (extrapolated)", e->variant);
			else
				ADD("; %s is expected at %.3g", e->variant, e->error);
		}
	} else {
		const advice_estimate_t *ed = &a->est[0];
		a->choice = 0;
		double spread = ed->statistical * sqrt((double)a->particles * (double)a->replicas);
		double need = spread > 0 ? ceil((spread / a->target) * (spread / a->target)) : 0;
		ADD("no method is expected to meet the temperature error target %.3g; ed is exact, with only the statistical "
		    "error %.3g of %llu particles x %llu replicas", a->target, ed->error, (unsigned long long)a->particles,
		    (unsigned long long)a->replicas);
		if (need > 0)
			ADD("; N x replicas >= %.3g would meet it (e.g. run.replicas >= %.0f)", need,
			    ceil(need / (double)a->particles));
		for (int i = 1; i < a->n; i++) {
			const advice_estimate_t *e = &a->est[i];
			if (e->refused)
				ADD("; %s: %.*s", e->variant, (int)strcspn(e->notes, ";"), e->notes);
			else
				ADD("; %s is expected at %.3g%s", e->variant, e->error,
				    e->extrapolated & ADVICE_X_ERROR ? " (extrapolated)" : "");
		}
	}
#undef ADD
}

/* The candidates (see advice.h): ed; per MC method its default correction,
 * the other measured ones, and the scene's own if still missing. */
static int candidates(const dimmodel_t *d, const scene_t *s, scene_method_t meth[], int corr[])
{
	static const scene_method_t mc[2] = {SCENE_METHOD_DSMC, SCENE_METHOD_HSMC};
	int n = 0;
	meth[n] = SCENE_METHOD_ED, corr[n++] = 0;
	for (int k = 0; k < 2; k++) {
		const int def = resolved_correction(mc[k], SCENE_MC_DEFAULT);
		const int mine = s->method == mc[k] ? resolved_correction(mc[k], s->mc_correction) : -1;
		meth[n] = mc[k], corr[n++] = def;
		for (int c = SCENE_MC_NONE; c <= SCENE_MC_CBA; c++) {
			char name[16];
			snprintf(name, sizeof name, "%s/%s", scene_method_name(mc[k]), corr_names[c]);
			if (c != def && (c == mine || find_variant(d, name)) && n < ADVICE_MAX_ESTIMATES)
				meth[n] = mc[k], corr[n++] = c;
		}
	}
	/* md: for md scenes only (its stiffness and step are resolved by the scene parser for them; "auto"
	 * chooses among the hard-sphere methods) */
	if (s->method == SCENE_METHOD_MD && n < ADVICE_MAX_ESTIMATES)
		meth[n] = SCENE_METHOD_MD, corr[n++] = 0;
	return n;
}

int advice_estimate(const advice_model_t *m, const scene_t *s, int ranks, advice_t *out, char *err, size_t errlen)
{
	scene_method_t meth[ADVICE_MAX_ESTIMATES];
	int corr[ADVICE_MAX_ESTIMATES];
	memset(out, 0, sizeof(*out));
	if (err && errlen)
		err[0] = '\0';
	if (s->dim != 2 && s->dim != 3) {
		snprintf(err, errlen, "dimensions: must be 2 or 3");
		return ADVICE_ESCENE;
	}
	out->requested = s->method;
	out->dim = s->dim;
	out->particles = s->count;
	out->replicas = s->replicas;
	out->ranks = ranks < 1 ? 1 : ranks;
	out->volume_fraction = s->volume_fraction;
	out->restitution = s->restitution;
	out->target = s->method == SCENE_METHOD_AUTO ? s->accuracy_temperature : 0;
	out->choice = -1;
	out->model_version = m->version;
	snprintf(out->model_date, sizeof out->model_date, "%s", m->date);
	const double lam = 1 - s->restitution * s->restitution;
	const double f_hs = dsmc_collision_frequency(s->dim, s->volume_fraction, s->radius, s->mass, s->temperature,
	                                             dsmc_contact_value(s->dim, s->volume_fraction));
	double t_end = s->until.kind == SCENE_CLOCK_TIME ? s->until.value
	                                                 : haff_time_of_cpp(s->dim, f_hs, lam, s->until.value);
	out->cpp = s->until.kind == SCENE_CLOCK_TIME ? advice_haff_cpp(s->dim, f_hs, lam, t_end) : s->until.value;
	out->haff_time = isfinite(t_end) ? lam * f_hs * t_end / (2.0 * s->dim) : INFINITY;
	const int nc = candidates(&m->d[s->dim == 3], s, meth, corr);
	for (int i = 0; i < nc; i++) {
		int r = estimate_one(m, s, meth[i], corr[i], out->ranks, out->haff_time, &out->est[out->n], err, errlen);
		if (r)
			return r;
		out->n++;
	}
	if (s->method == SCENE_METHOD_AUTO) {
		if (!(out->target > 0)) {
			snprintf(err, errlen, "accuracy.temperature: required with \"method\": \"auto\"");
			return ADVICE_ESCENE;
		}
		choose(out);
	} else {
		for (int i = 0; i < out->n; i++)
			out->est[i].meets = -1;
	}
	return ADVICE_OK;
}

static const advice_estimate_t *chosen(const advice_t *a)
{
	return a->requested == SCENE_METHOD_AUTO && a->choice >= 0 && a->choice < a->n ? &a->est[a->choice] : NULL;
}

void advice_apply(const advice_t *a, scene_t *s)
{
	const advice_estimate_t *e = chosen(a);
	if (s->method != SCENE_METHOD_AUTO || !e)
		return;
	s->method = e->method;
	if (e->method != SCENE_METHOD_ED)
		s->mc_correction = (scene_mc_correction_t)e->correction;
}

/* What the choice changes in the scene: {"method": M[, M: {"correction": C}]}. */
static json_t *resolved_json(const advice_estimate_t *e)
{
	const char *name = scene_method_name(e->method);
	if (e->method == SCENE_METHOD_ED)
		return json_pack("{s:s}", "method", name);
	return json_pack("{s:s, s:{s:s}}", "method", name, name, "correction", corr_names[e->correction]);
}

int advice_apply_json(const advice_t *a, json_t *scene)
{
	const advice_estimate_t *e = chosen(a);
	if (!e)
		return ADVICE_ESCENE;
	json_t *patch = resolved_json(e);
	int bad = !patch || json_object_update(scene, patch);
	json_decref(patch);
	if (!bad && json_object_get(scene, "accuracy"))
		bad = json_object_del(scene, "accuracy");
	return bad ? ADVICE_ENOMEM : ADVICE_OK;
}

/* ---- JSON ------------------------------------------------------------------------ */

static json_t *jnum(double v)
{
	return isfinite(v) ? json_real(v) : json_null();
}

static json_t *notes_array(const char *notes)
{
	json_t *a = json_array();
	const char *p = notes;
	while (a && *p) {
		const char *q = strstr(p, "; ");
		size_t n = q ? (size_t)(q - p) : strlen(p);
		json_array_append_new(a, json_stringn(p, n));
		p += n + (q ? 2 : 0);
	}
	return a;
}

static json_t *settings_json(const advice_estimate_t *e)
{
	if (e->method == SCENE_METHOD_MD)
		return json_pack("{s:o}", "time_step", jnum(e->time_step));
	if (e->method == SCENE_METHOD_ED)
		return json_pack("{s:o}", "cell_size", e->cell_size > 0 ? json_real(e->cell_size) : json_string("automatic"));
	json_t *o = json_pack("{s:s, s:o}", "correction", corr_names[e->correction], "cell_size", jnum(e->cell_size));
	if (!o)
		return NULL;
	if (e->time_step > 0)
		json_object_set_new(o, "time_step", json_real(e->time_step));
	else
		json_object_set_new(o, "collisions_per_step", json_real(e->collisions_per_step));
	if (e->method == SCENE_METHOD_HSMC)
		json_object_set_new(o, "max_volume_fraction", json_real(e->max_volume_fraction));
	return o;
}

json_t *advice_json(const advice_t *a)
{
	json_t *ests = json_array(), *root = NULL;
	if (!ests)
		return NULL;
	for (int i = 0; i < a->n; i++) {
		const advice_estimate_t *e = &a->est[i];
		json_t *o = json_pack("{s:s, s:s, s:o, s:o, s:o, s:o, s:o, s:o, s:{s:o, s:o, s:o}, s:o, s:b, s:o}",
		                      "method", scene_method_name(e->method), "variant", e->variant,
		                      "settings", settings_json(e), "cpu_seconds", jnum(e->cpu_seconds),
		                      "setup_cpu_seconds", jnum(e->setup_cpu_seconds), "wall_seconds", jnum(e->wall_seconds),
		                      "collisions", jnum(e->collisions), "moves", jnum(e->moves),
		                      "error", "temperature", jnum(e->error), "bias", jnum(e->bias), "statistical",
		                      jnum(e->statistical), "meets_target", e->meets < 0 ? json_null() : json_boolean(e->meets),
		                      "extrapolated", e->extrapolated != 0, "notes", notes_array(e->notes));
		if (o && json_object_set_new(o, "refused", json_boolean(e->refused))) {
			json_decref(o);
			o = NULL;
		}
		if (!o || json_array_append_new(ests, o)) {
			json_decref(ests);
			return NULL;
		}
	}
	root = json_pack("{s:{s:i, s:s}, s:{s:s, s:i, s:I, s:I, s:i, s:o, s:o, s:o, s:o}, s:o, s:o, s:o, s:o}",
	                 "model", "version", a->model_version, "date", a->model_date,
	                 "scene", "method", scene_method_name(a->requested), "dimensions", a->dim,
	                 "particles", (json_int_t)a->particles, "replicas", (json_int_t)a->replicas, "ranks", a->ranks,
	                 "volume_fraction", jnum(a->volume_fraction), "restitution", jnum(a->restitution),
	                 "haff_time", jnum(a->haff_time), "collisions_per_particle", jnum(a->cpp),
	                 "target", a->target > 0 ? json_pack("{s:f}", "temperature", a->target) : json_null(),
	                 "estimates", ests,
	                 "choice", a->choice >= 0 ? json_string(scene_method_name(a->est[a->choice].method)) : json_null(),
	                 "reason", a->choice >= 0 ? json_string(a->reason) : json_null());
	const advice_estimate_t *c = chosen(a);
	if (root && json_object_set_new(root, "choice_variant", c ? json_string(c->variant) : json_null())) {
		json_decref(root);
		return NULL;
	}
	if (root && json_object_set_new(root, "resolved", c ? resolved_json(c) : json_null())) {
		json_decref(root);
		return NULL;
	}
	return root;
}
