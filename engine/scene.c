/* Scene parser: validates a scene JSON text (version 1) into a defaulted scene_t, or names the one key at fault. */
#include <math.h>
#include <stdarg.h>
#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <jansson.h>

#include "scene.h"
#include "ed/ed.h"
#include "mc/dsmc.h"
#include "place.h"
#include "observe/fields.h"
#include "rng.h"

#define PI 3.14159265358979323846
#define PATHLEN 256
#define COUNT_MAX SCENE_COUNT_MAX        /* particle indices are 32-bit in the engines */
#define SEED_MAX 9007199254740992LL     /* 2^53: exact in every JSON client (doubles) */

typedef struct {
	scene_t *s;
	char *err;
	size_t errlen;
} ctx_t;

/* dst points at the destination inside the scene (object base + field offset). */
typedef int (*parse_fn)(ctx_t *c, const char *path, json_t *v, void *dst, const void *arg);

struct field {
	const char *name;
	parse_fn parse;
	size_t off;        /* destination, relative to the enclosing object's base */
	const void *arg;   /* struct range, struct irange or struct object */
	bool required;
};

struct object {
	const struct field *fields;   /* ends with a NULL name */
	/* Rules across keys; runs after all keys parsed. */
	int (*check)(ctx_t *c, const char *path, json_t *v, void *base);
};

struct range { double lo, hi; bool lo_open; };  /* hi inclusive, INFINITY = none */
struct irange { long long lo, hi; };

static const struct range R_POS = { 0, INFINITY, true };
static const struct range R_NONNEG = { 0, INFINITY, false };
static const struct range R_UNIT = { 0, 1, false };
static const struct range R_ANY = { -INFINITY, INFINITY, false };
static const struct range R_SIGNED_UNIT = { -1, 1, false };
static const struct irange R_COUNT = { 2, COUNT_MAX };
static const struct irange R_SEED = { 0, SEED_MAX };
static const struct irange R_REPLICAS = { 1, 1000000 };

static const char *const method_names[] = {
	[SCENE_METHOD_ED] = "ed", [SCENE_METHOD_DSMC] = "dsmc", [SCENE_METHOD_HSMC] = "hsmc",
	[SCENE_METHOD_AUTO] = "auto", [SCENE_METHOD_MD] = "md",
};
static const char *const md_law_names[] = { "linear", "hertz" };
static const char *const position_names[] = {
	[SCENE_POS_LATTICE] = "lattice", [SCENE_POS_RANDOM] = "random",
};
static const char *const correction_names[] = {
	[SCENE_MC_NONE - 1] = "none", [SCENE_MC_ENSKOG - 1] = "enskog", [SCENE_MC_CBA - 1] = "cba",
};
static const char *const contact_names[] = { "global", "local" };
static const char *const wall_names[] = {
	[SCENE_WALL_SPECULAR] = "specular", [SCENE_WALL_THERMAL] = "thermal", [SCENE_WALL_ROUGH] = "rough",
	[SCENE_WALL_MOVING] = "moving", [SCENE_WALL_VIBRATING] = "vibrating", [SCENE_WALL_OPEN] = "open",
	[SCENE_WALL_RESERVOIR] = "reservoir", [SCENE_WALL_DISPENSER] = "dispenser",
};
static const char *const obstacle_names[] = {
	[SCENE_OBST_SLIP] = "slip", [SCENE_OBST_NO_SLIP] = "no_slip", [SCENE_OBST_RANDOM_SIGN] = "random_sign",
};
static const char *const axis_kinds[] = { "periodic", "walls" };
static const char *const drive_names[] = {
	[SCENE_DRIVE_NONE] = "none", [SCENE_DRIVE_STOCHASTIC] = "stochastic", [SCENE_DRIVE_WHITE_NOISE] = "white_noise",
};
static const char *const axis_names[] = { "x", "y", "z" };
static const struct { const char *name; unsigned bit; } observables[] = {
	{ "kinetic_energy", SCENE_OBS_ENERGY },
	{ "temperature", SCENE_OBS_ENERGY },
	{ "pressure", SCENE_OBS_PRESSURE },
	{ "compressibility", SCENE_OBS_PRESSURE },
	{ "collision_rate", SCENE_OBS_COLLISION_RATE },
	{ "clusters", SCENE_OBS_CLUSTERS },
	{ "momentum", SCENE_OBS_MOMENTUM },
	{ "velocity_distribution", SCENE_OBS_VDIST },
	{ "pair_correlation", SCENE_OBS_GOFR },
	{ "structure_factor", SCENE_OBS_SOFK },
	{ "velocity_correlations", SCENE_OBS_VCORR },
	{ "wall_force", SCENE_OBS_WALL_FORCE },
	{ "center_of_mass_height", SCENE_OBS_COM_HEIGHT },
	{ "potential_energy", SCENE_OBS_POTENTIAL },
	{ "impact_parameter", SCENE_OBS_IMPACT },
	{ "mean_square_displacement", SCENE_OBS_MSD },
	{ "obstacle_force", SCENE_OBS_OBSTACLE_FORCE },
	{ "outflow", SCENE_OBS_OUTFLOW },
	{ "rotational_energy", SCENE_OBS_ROTATION },
	{ "rotational_temperature", SCENE_OBS_ROTATION },
	{ "fields", SCENE_OBS_FIELDS },
	{ "density_spectrum", SCENE_OBS_DSPEC },
	{ "flux", SCENE_OBS_FLUX },
	{ "surface_profile", SCENE_OBS_SURFACE },
};
#define N_OBSERVABLES (sizeof observables / sizeof observables[0])

static int fail(ctx_t *c, const char *path, const char *fmt, ...)
{
	if (c->err == NULL || c->errlen == 0)
		return SCENE_EINVAL;
	int n = snprintf(c->err, c->errlen, "%s: ", path);
	if (n >= 0 && (size_t)n < c->errlen) {
		va_list ap;
		va_start(ap, fmt);
		vsnprintf(c->err + n, c->errlen - n, fmt, ap);
		va_end(ap);
	}
	/* Keys and strings come from the user: keep the message on one line. */
	for (char *p = c->err; *p; p++)
		if ((unsigned char)*p < 0x20 || *p == 0x7f)
			*p = '?';
	return SCENE_EINVAL;
}

/* A value for a message, in a buffer that lives to the end of the full expression. */
typedef struct { char s[48]; } str_t;

/* Shortest of %.15g / %.17g that reads back exactly. */
static str_t num(double x)
{
	str_t r;
	snprintf(r.s, sizeof r.s, "%.15g", x);
	if (strtod(r.s, NULL) != x)
		snprintf(r.s, sizeof r.s, "%.17g", x);
	return r;
}

static const char *type_name(const json_t *v)
{
	static const char *const names[] = {
		[JSON_OBJECT] = "object", [JSON_ARRAY] = "array", [JSON_STRING] = "string",
		[JSON_INTEGER] = "number", [JSON_REAL] = "number", [JSON_TRUE] = "boolean",
		[JSON_FALSE] = "boolean", [JSON_NULL] = "null",
	};
	return names[json_typeof(v)];
}

/* The offending value: numbers as written (a real keeps a ".0" so that 2.0 is
 * visibly not an integer), strings quoted, anything else by type. */
static str_t describe(const json_t *v)
{
	str_t r;
	if (json_is_integer(v)) {
		snprintf(r.s, sizeof r.s, "%" JSON_INTEGER_FORMAT, json_integer_value(v));
	} else if (json_is_real(v)) {
		r = num(json_real_value(v));
		if (strpbrk(r.s, ".e") == NULL)
			strncat(r.s, ".0", sizeof r.s - strlen(r.s) - 1);
	} else if (json_is_string(v)) {
		snprintf(r.s, sizeof r.s, "\"%.40s\"", json_string_value(v));
	} else {
		snprintf(r.s, sizeof r.s, "%s", type_name(v));
	}
	return r;
}

static void join(char *dst, const char *path, const char *key)
{
	snprintf(dst, PATHLEN, "%s%s%s", path, *path ? "." : "", key);
}

/* ---- value parsers --------------------------------------------------- */

static int get_number(ctx_t *c, const char *path, const json_t *v, const struct range *r, double *out)
{
	if (!json_is_number(v))
		return fail(c, path, "must be a number, got %s", type_name(v));
	double x = json_number_value(v);
	bool low = r->lo_open ? !(x > r->lo) : !(x >= r->lo);
	if (low || x > r->hi) {
		if (isinf(r->hi))
			return fail(c, path, "must be a number %s %s, got %s",
				    r->lo_open ? ">" : ">=", num(r->lo).s, num(x).s);
		return fail(c, path, "must be between %s and %s, got %s",
			    num(r->lo).s, num(r->hi).s, num(x).s);
	}
	*out = x;
	return 0;
}

static int parse_number(ctx_t *c, const char *path, json_t *v, void *dst, const void *arg)
{
	return get_number(c, path, v, arg, dst);
}

/* JSON integers only: 1000.0 and 1e3 are reals and rejected, so that a count
 * or seed is never silently rounded. */
static int parse_integer(ctx_t *c, const char *path, json_t *v, void *dst, const void *arg)
{
	const struct irange *r = arg;
	if (json_is_real(v)) {
		double x = json_real_value(v);
		return fail(c, path, "must be an integer >= %lld, got %s%s", r->lo, describe(v).s,
			    x == floor(x) ? " (write integers without a decimal point or exponent)" : "");
	}
	if (!json_is_integer(v))
		return fail(c, path, "must be an integer, got %s", type_name(v));
	json_int_t i = json_integer_value(v);
	if (i < r->lo)
		return fail(c, path, "must be an integer >= %lld, got %s", r->lo, describe(v).s);
	if (i > r->hi)
		return fail(c, path, "must be an integer <= %lld, got %s", r->hi, describe(v).s);
	*(uint64_t *)dst = (uint64_t)i;
	return 0;
}

/* Index of string v in names[n]. */
static int match(ctx_t *c, const char *path, const json_t *v, const char *const *names, size_t n, int *idx)
{
	if (!json_is_string(v))
		return fail(c, path, "must be a string, got %s", type_name(v));
	char known[PATHLEN * 2] = "";
	for (size_t i = 0; i < n; i++) {
		if (strcmp(json_string_value(v), names[i]) == 0) {
			*idx = (int)i;
			return 0;
		}
		snprintf(known + strlen(known), sizeof known - strlen(known), "%s\"%s\"", i ? ", " : "", names[i]);
	}
	return fail(c, path, "must be one of %s, got %s", known, describe(v).s);
}

static int parse_method(ctx_t *c, const char *path, json_t *v, void *dst, const void *arg)
{
	int i, ret = match(c, path, v, method_names, 5, &i);
	if (ret == 0)
		*(scene_method_t *)dst = (scene_method_t)i;
	return ret;
}

static int parse_md_law(ctx_t *c, const char *path, json_t *v, void *dst, const void *arg)
{
	return match(c, path, v, md_law_names, 2, (int *)dst);
}

static int parse_positions(ctx_t *c, const char *path, json_t *v, void *dst, const void *arg)
{
	int i, ret = match(c, path, v, position_names, 2, &i);
	if (ret == 0)
		*(scene_positions_t *)dst = (scene_positions_t)i;
	return ret;
}

static int parse_correction(ctx_t *c, const char *path, json_t *v, void *dst, const void *arg)
{
	int i, ret = match(c, path, v, correction_names, 3, &i);
	if (ret == 0)
		*(scene_mc_correction_t *)dst = (scene_mc_correction_t)(i + 1);
	return ret;
}

/* A choice of two names (arg: the two, in index order), as an int 0 or 1: contact_value, hsmc.cell_partners,
 * hsmc.entry, hsmc.rejected_moves. */
static int parse_two(ctx_t *c, const char *path, json_t *v, void *dst, const void *arg)
{
	int i, ret = match(c, path, v, (const char *const *)arg, 2, &i);
	if (ret == 0)
		*(int *)dst = i;
	return ret;
}
static const char *const partner_names[] = { "full", "any" };
static const char *const entry_names[] = { "step", "linear" };
static const char *const rejected_names[] = { "keep", "collide" };

static int parse_version(ctx_t *c, const char *path, json_t *v, void *dst, const void *arg)
{
	if (!json_is_integer(v) || json_integer_value(v) != 1)
		return fail(c, path, "must be 1, got %s", describe(v).s);
	return 0;
}

static int parse_dimensions(ctx_t *c, const char *path, json_t *v, void *dst, const void *arg)
{
	json_int_t d = json_is_integer(v) ? json_integer_value(v) : 0;
	if (d != 2 && d != 3)
		return fail(c, path, "must be 2 or 3, got %s", describe(v).s);
	*(int *)dst = (int)d;
	return 0;
}

/* Needs the dimension: the root table parses "dimensions" before "particles". */
static int parse_box(ctx_t *c, const char *path, json_t *v, void *dst, const void *arg)
{
	double *box = dst;
	if (!json_is_array(v))
		return fail(c, path, "must be an array, got %s", type_name(v));
	if (json_array_size(v) != (size_t)c->s->dim)
		return fail(c, path, "must have %d edge lengths (one per dimension), got %zu",
			    c->s->dim, json_array_size(v));
	for (int i = 0; i < c->s->dim; i++) {
		char sub[PATHLEN];
		snprintf(sub, sizeof sub, "%s[%d]", path, i);
		int ret = get_number(c, sub, json_array_get(v, i), &R_POS, &box[i]);
		if (ret)
			return ret;
	}
	return 0;
}

/* A vector of D finite numbers (gravity, wall velocity); needs the dimension. */
static int parse_vector(ctx_t *c, const char *path, json_t *v, void *dst, const void *arg)
{
	double *x = dst;
	if (!json_is_array(v))
		return fail(c, path, "must be an array, got %s", type_name(v));
	if (json_array_size(v) != (size_t)c->s->dim)
		return fail(c, path, "must have %d components (one per dimension), got %zu", c->s->dim, json_array_size(v));
	for (int i = 0; i < c->s->dim; i++) {
		char sub[PATHLEN];
		snprintf(sub, sizeof sub, "%s[%d]", path, i);
		int ret = get_number(c, sub, json_array_get(v, i), &R_ANY, &x[i]);
		if (ret)
			return ret;
	}
	return 0;
}

static int parse_wall_type(ctx_t *c, const char *path, json_t *v, void *dst, const void *arg)
{
	int i, ret = match(c, path, v, wall_names, sizeof wall_names / sizeof wall_names[0], &i);
	if (ret == 0)
		*(scene_wall_type_t *)dst = (scene_wall_type_t)i;
	return ret;
}

/* A reservoir's gas: "ideal" (SCENE_GAS_IDEAL) or "hard_spheres". */
static int parse_gas(ctx_t *c, const char *path, json_t *v, void *dst, const void *arg)
{
	static const char *const names[] = { "ideal", "hard_spheres" };
	(void)arg;
	return match(c, path, v, names, 2, (int *)dst);
}

/* run.balance: "off" (0) or "events" (1). */
static int parse_balance(ctx_t *c, const char *path, json_t *v, void *dst, const void *arg)
{
	static const char *const names[] = { "off", "events" };
	(void)arg;
	return match(c, path, v, names, 2, (int *)dst);
}

static int parse_axis_kind(ctx_t *c, const char *path, json_t *v, void *dst, const void *arg)
{
	int i, ret = match(c, path, v, axis_kinds, 2, &i);
	if (ret == 0)
		*(int *)dst = i;
	return ret;
}

static int parse_observables(ctx_t *c, const char *path, json_t *v, void *dst, const void *arg)
{
	unsigned bits = 0, seen = 0;
	size_t i;
	json_t *o;
	if (!json_is_array(v))
		return fail(c, path, "must be an array, got %s", type_name(v));
	json_array_foreach(v, i, o) {
		char sub[PATHLEN];
		snprintf(sub, sizeof sub, "%s[%zu]", path, i);
		if (!json_is_string(o))
			return fail(c, sub, "must be a string, got %s", type_name(o));
		size_t k;
		for (k = 0; k < N_OBSERVABLES; k++)
			if (strcmp(json_string_value(o), observables[k].name) == 0)
				break;
		if (k == N_OBSERVABLES) {
			char known[PATHLEN * 2] = "";
			for (size_t j = 0; j < N_OBSERVABLES; j++)
				snprintf(known + strlen(known), sizeof known - strlen(known), "%s%s",
					 j ? ", " : "", observables[j].name);
			return fail(c, sub, "unknown observable %s (known: %s)", describe(o).s, known);
		}
		/* By name, not by bit: "temperature" after "kinetic_energy" is fine. */
		if (seen & (1u << k))
			return fail(c, sub, "duplicate observable %s", describe(o).s);
		seen |= 1u << k;
		bits |= observables[k].bit;
	}
	*(unsigned *)dst = bits;
	return 0;
}

/* 0 means automatic; any explicit edge must hold at least one particle. */
static int parse_cell_size(ctx_t *c, const char *path, json_t *v, void *dst, const void *arg)
{
	if (!json_is_number(v))
		return fail(c, path, "must be a number, got %s", type_name(v));
	double x = json_number_value(v);
	if (x != 0 && !(x >= 1))
		return fail(c, path, "must be 0 (automatic) or a number >= 1, got %s", num(x).s);
	*(double *)dst = x;
	return 0;
}

/* ---- objects --------------------------------------------------------- */

static int walk(ctx_t *c, const char *path, json_t *v, void *base, const struct object *o)
{
	const char *key;
	json_t *val;
	char sub[PATHLEN];

	if (!json_is_object(v))
		return fail(c, path, "must be an object, got %s", type_name(v));
	/* Unknown keys first, in document order: a typo explains a missing key. */
	json_object_foreach(v, key, val) {
		const struct field *f;
		for (f = o->fields; f->name && strcmp(f->name, key) != 0; f++)
			;
		if (f->name)
			continue;
		char known[PATHLEN] = "";
		for (f = o->fields; f->name; f++)
			snprintf(known + strlen(known), sizeof known - strlen(known), "%s%s",
				 f == o->fields ? "" : ", ", f->name);
		join(sub, path, key);
		return fail(c, sub, "unknown key (known: %s)", known);
	}
	/* Then in table order, so that later keys may depend on earlier ones. */
	for (const struct field *f = o->fields; f->name; f++) {
		json_t *x = json_object_get(v, f->name);
		join(sub, path, f->name);
		if (x == NULL) {
			if (f->required)
				return fail(c, sub, "required key missing");
			continue;
		}
		int ret = f->parse(c, sub, x, (char *)base + f->off, f->arg);
		if (ret)
			return ret;
	}
	return o->check ? o->check(c, path, v, base) : 0;
}

static int parse_object(ctx_t *c, const char *path, json_t *v, void *dst, const void *arg)
{
	return walk(c, path, v, dst, arg);
}

static int check_when(ctx_t *c, const char *path, json_t *v, void *base)
{
	scene_when_t *w = base;
	bool time = json_object_get(v, "time") != NULL;
	bool cpp = json_object_get(v, "collisions_per_particle") != NULL;
	if (time == cpp)
		return fail(c, path, "must have exactly one of time or collisions_per_particle");
	w->kind = time ? SCENE_CLOCK_TIME : SCENE_CLOCK_CPP;
	return 0;
}

static int check_particles(ctx_t *c, const char *path, json_t *v, void *base)
{
	scene_t *s = base;
	char sub[PATHLEN];
	if ((json_object_get(v, "volume_fraction") == NULL) == (json_object_get(v, "box") == NULL))
		return fail(c, path, "exactly one of volume_fraction or box is required");
	if (!json_object_get(v, "species")) {
		if (!json_object_get(v, "count")) {
			join(sub, path, "count");
			return fail(c, sub, "required key missing");
		}
		return 0;
	}
	static const char *const single[] = { "count", "radius", "mass" };
	for (size_t k = 0; k < sizeof single / sizeof single[0]; k++)
		if (json_object_get(v, single[k])) {
			join(sub, path, single[k]);
			return fail(c, sub, "not with particles.species (each species gives its own count, radius and mass)");
		}
	/* what species-blind code sees: the total, the largest radius, the mean mass */
	uint64_t n = 0;
	double rmax = 0.0, msum = 0.0;
	for (int k = 0; k < s->n_species; k++) {
		const scene_species_t *q = &s->species[k];
		n += q->count;
		rmax = fmax(rmax, q->radius);
		msum += (double)q->count * q->mass;
	}
	join(sub, path, "species");
	if (n < 2 || n > (uint64_t)COUNT_MAX)
		return fail(c, sub, "the species' counts add up to %llu; the total must be 2 .. %lld",
			    (unsigned long long)n, COUNT_MAX);
	s->count = n;
	s->radius = rmax;
	s->mass = msum / (double)n;
	return 0;
}

/* particles.species[k].name: 1 .. SCENE_NAME_MAX - 1 printable bytes. */
static int parse_name(ctx_t *c, const char *path, json_t *v, void *dst, const void *arg)
{
	(void)arg;
	if (!json_is_string(v))
		return fail(c, path, "must be a string, got %s", type_name(v));
	const char *p = json_string_value(v);
	size_t n = json_string_length(v);
	if (n == 0 || n >= SCENE_NAME_MAX)
		return fail(c, path, "must be a name of 1 to %d bytes, got %zu", SCENE_NAME_MAX - 1, n);
	for (size_t i = 0; i < n; i++)
		if ((unsigned char)p[i] < 0x20 || p[i] == 0x7f)
			return fail(c, path, "must not contain control characters");
	memcpy(dst, p, n + 1);
	return 0;
}

static const struct irange R_SPECIES_COUNT = { 1, COUNT_MAX };

/* particles.species[k].radius_range: [lo, hi], 0 < lo < hi (into radius_lo, radius_hi). */
static int parse_radius_range(ctx_t *c, const char *path, json_t *v, void *dst, const void *arg)
{
	(void)arg;
	double *r = dst;
	char sub[PATHLEN];
	if (!json_is_array(v) || json_array_size(v) != 2)
		return fail(c, path, "must be an array [smallest, largest] of two radii");
	for (size_t k = 0; k < 2; k++) {
		snprintf(sub, sizeof sub, "%s[%zu]", path, k);
		int ret = get_number(c, sub, json_array_get(v, k), &R_POS, &r[k]);
		if (ret)
			return ret;
	}
	if (!(r[0] < r[1]))
		return fail(c, path, "the smallest radius %s must be less than the largest %s (a single radius: use radius)",
			    num(r[0]).s, num(r[1]).s);
	return 0;
}

/* A species has exactly one of radius and radius_range. */
static int check_species(ctx_t *c, const char *path, json_t *v, void *base)
{
	scene_species_t *q = base;
	bool one = json_object_get(v, "radius") != NULL, range = json_object_get(v, "radius_range") != NULL;
	char sub[PATHLEN];
	if (one && range) {
		join(sub, path, "radius_range");
		return fail(c, sub, "not with radius (a species has one radius or a range)");
	}
	if (!one && !range) {
		join(sub, path, "radius");
		return fail(c, sub, "required key missing (or radius_range)");
	}
	if (range)
		q->radius = q->radius_hi;
	return 0;
}

static const struct object species_obj = {
	.fields = (const struct field[]){
		{ "name", parse_name, offsetof(scene_species_t, name), NULL, false },
		{ "count", parse_integer, offsetof(scene_species_t, count), &R_SPECIES_COUNT, true },
		{ "radius", parse_number, offsetof(scene_species_t, radius), &R_POS, false },
		{ "radius_range", parse_radius_range, offsetof(scene_species_t, radius_lo), NULL, false },
		{ "mass", parse_number, offsetof(scene_species_t, mass), &R_POS, true },
		{ .name = NULL },
	},
	.check = check_species,
};

/* particles.species: an array of 1 .. SCENE_SPECIES_MAX species with distinct names. */
static int parse_species(ctx_t *c, const char *path, json_t *v, void *dst, const void *arg)
{
	(void)dst, (void)arg;
	scene_t *s = c->s;
	size_t i;
	json_t *o;
	if (!json_is_array(v))
		return fail(c, path, "must be an array of species objects, got %s", type_name(v));
	if (json_array_size(v) < 1 || json_array_size(v) > SCENE_SPECIES_MAX)
		return fail(c, path, "must have 1 to %d species, got %zu", SCENE_SPECIES_MAX, json_array_size(v));
	json_array_foreach(v, i, o) {
		char sub[PATHLEN / 2];
		snprintf(sub, sizeof sub, "%s[%zu]", path, i);
		scene_species_t *q = &s->species[i];
		*q = (scene_species_t){ .count = 0 };
		int ret = walk(c, sub, o, q, &species_obj);
		if (ret)
			return ret;
		if (!q->name[0])
			snprintf(q->name, sizeof q->name, "%zu", i);
		for (size_t k = 0; k < i; k++)
			if (strcmp(s->species[k].name, q->name) == 0) {
				char key[PATHLEN];
				snprintf(key, sizeof key, "%s.name", sub);
				return fail(c, key, "\"%s\" is the name of species %zu too (names must differ)", q->name, k);
			}
		s->n_species = (int)i + 1;
	}
	return 0;
}

/* A species named in collisions.restitution_pairs: its name or its index. */
static int species_ref(ctx_t *c, const char *path, const json_t *v, int *out)
{
	const scene_t *s = c->s;
	if (json_is_integer(v)) {
		json_int_t k = json_integer_value(v);
		if (k < 0 || k >= s->n_species)
			return fail(c, path, "species index %lld is not in 0 .. %d", (long long)k, s->n_species - 1);
		*out = (int)k;
		return 0;
	}
	if (!json_is_string(v))
		return fail(c, path, "must be a species name or index, got %s", type_name(v));
	for (int k = 0; k < s->n_species; k++)
		if (strcmp(s->species[k].name, json_string_value(v)) == 0) {
			*out = k;
			return 0;
		}
	return fail(c, path, "no species named %s in particles.species", describe(v).s);
}

/* collisions.restitution_pairs: [{"a": A, "b": B, "restitution": r}, ...],
 * A and B species names or indices; each unordered pair at most once. */
static int parse_pairs(ctx_t *c, const char *path, json_t *v, void *dst, const void *arg)
{
	(void)dst, (void)arg;
	scene_t *s = c->s;
	size_t i;
	json_t *o;
	if (s->n_species == 0)
		return fail(c, path, "needs particles.species (restitution per pair of species)");
	if (!json_is_array(v))
		return fail(c, path, "must be an array of {\"a\", \"b\", \"restitution\"} objects, got %s", type_name(v));
	json_array_foreach(v, i, o) {
		char sub[PATHLEN / 2], key[PATHLEN];
		snprintf(sub, sizeof sub, "%s[%zu]", path, i);
		if (!json_is_object(o))
			return fail(c, sub, "must be an object, got %s", type_name(o));
		const char *k;
		json_t *x;
		json_object_foreach(o, k, x)
			if (strcmp(k, "a") && strcmp(k, "b") && strcmp(k, "restitution")) {
				join(key, sub, k);
				return fail(c, key, "unknown key (known: a, b, restitution)");
			}
		static const char *const need[] = { "a", "b", "restitution" };
		for (int q = 0; q < 3; q++)
			if (!json_object_get(o, need[q])) {
				join(key, sub, need[q]);
				return fail(c, key, "required key missing");
			}
		int a, b, ret;
		double r;
		join(key, sub, "a");
		if ((ret = species_ref(c, key, json_object_get(o, "a"), &a)))
			return ret;
		join(key, sub, "b");
		if ((ret = species_ref(c, key, json_object_get(o, "b"), &b)))
			return ret;
		join(key, sub, "restitution");
		if ((ret = get_number(c, key, json_object_get(o, "restitution"), &R_UNIT, &r)))
			return ret;
		if (!isnan(s->restitution_pair[a][b]))
			return fail(c, sub, "the pair (%s, %s) is given twice", s->species[a].name, s->species[b].name);
		s->restitution_pair[a][b] = s->restitution_pair[b][a] = r;
	}
	return 0;
}

/* ---- method md (soft spheres, engine/md/md.h) ------------------------------ */

static const struct range R_MD_STEP = { 0, 0.5, true };
static const struct range R_MD_OVERLAP = { 0, 0.1, true };

static int check_md_obj(ctx_t *c, const char *path, json_t *v, void *base)
{
	scene_t *s = base;
	int n = (s->md_stiffness > 0) + (s->md_contact_time > 0);
	if (n > 1)
		return fail(c, path, "at most one of stiffness and contact_time");
	if (s->md_law == 1 && s->md_contact_time > 0)
		return fail(c, "md.contact_time", "only with force_law \"linear\" (a Hertz contact's duration depends on "
			    "the impact speed); give stiffness (the effective modulus E*) or max_overlap");
	if (n && json_object_get(v, "max_overlap"))
		return fail(c, "md.max_overlap", "sets the stiffness: not with stiffness or contact_time");
	if (s->md_rolling > 0 && !(s->md_friction > 0))
		return fail(c, "md.rolling_friction", "needs md.friction > 0 (a frictionless particle does not roll; the "
			    "rolling spring lives with the tangential one)");
	return 0;
}

static const struct object md_obj = {
	.fields = (const struct field[]){
		{ "force_law", parse_md_law, offsetof(scene_t, md_law), NULL, false },
		{ "stiffness", parse_number, offsetof(scene_t, md_stiffness), &R_POS, false },
		{ "contact_time", parse_number, offsetof(scene_t, md_contact_time), &R_POS, false },
		{ "max_overlap", parse_number, offsetof(scene_t, md_max_overlap), &R_MD_OVERLAP, false },
		{ "impact_speed", parse_number, offsetof(scene_t, md_impact_speed), &R_POS, false },
		{ "time_step", parse_number, offsetof(scene_t, md_time_step), &R_MD_STEP, false },
		{ "friction", parse_number, offsetof(scene_t, md_friction), &R_NONNEG, false },
		{ "tangential_stiffness", parse_number, offsetof(scene_t, md_tangential_ratio), &R_POS, false },
		{ "rolling_friction", parse_number, offsetof(scene_t, md_rolling), &R_NONNEG, false },
		{ .name = NULL },
	},
	.check = check_md_obj,
};

void scene_md_placement(const scene_t *s, scene_t *p)
{
	*p = *s;
	p->method = SCENE_METHOD_ED;   /* hard-particle placement: no two closer than a diameter */
	if (!p->has_region) {
		p->has_region = 1;
		for (int a = 0; a < 3; a++)
			p->region_lo[a] = 0.0, p->region_hi[a] = s->box[a];
	}
}

/* Method md: what this slice supports (species, a restitution per pair, specular, moving and vibrating walls,
 * gravity, friction, rolling resistance; time clocks; energy, momentum, centre-of-mass height and potential
 * energy); everything else refused by name. Resolves the md object's defaults. */
static int check_md(ctx_t *c, json_t *v, scene_t *s)
{
	if (s->method != SCENE_METHOD_MD)
		return 0;
	json_t *par = json_object_get(v, "particles"), *ini = json_object_get(par, "initial");
	json_t *col = json_object_get(v, "collisions"), *out = json_object_get(v, "output");
	static const struct { const char *obj, *key; } refused[] = {
		{ "particles", "capacity" }, { "initial", "velocity" },
		{ "initial", "rotational_temperature" }, { "initial", "relax" }, { "initial", "from" },
		{ "collisions", "tc" }, { "collisions", "rough" },
		{ "", "driving" }, { "", "ed" }, { "run", "max_events" },
	};
	for (size_t k = 0; k < sizeof refused / sizeof refused[0]; k++) {
		const char *o = refused[k].obj;
		json_t *in = !*o ? v : !strcmp(o, "particles") ? par : !strcmp(o, "initial") ? ini :
			     !strcmp(o, "collisions") ? col : !strcmp(o, "output") ? out : json_object_get(v, o);
		if (!json_object_get(in, refused[k].key))
			continue;
		char key[PATHLEN];
		snprintf(key, sizeof key, "%s%s%s", !*o ? "" : !strcmp(o, "initial") ? "particles.initial" : o, *o ? "." : "",
			 refused[k].key);
		return fail(c, key, "not supported with method \"md\" yet (docs/md.md)");
	}
	if (s->restitution <= 0)
		return fail(c, "collisions.restitution", "must be > 0 with method \"md\" (the damping of a contact is "
			    "derived from it)");
	for (int a = 0; a < s->n_species; a++)   /* given pairs (the others take restitution, > 0) */
		for (int b = a; b < s->n_species; b++)
			if (s->restitution_pair[a][b] == 0)
				return fail(c, "collisions.restitution_pairs", "0 for (%s, %s): must be > 0 with method \"md\" "
					    "(the damping of a contact is derived from it)", s->species[a].name, s->species[b].name);
	/* clocks: simulated time only (md has contacts, not countable collisions) */
	static const struct { const char *key; size_t off; } clocks[] = {
		{ "run.until", offsetof(scene_t, until) }, { "output.every", offsetof(scene_t, every) },
		{ "output.snapshots.every", offsetof(scene_t, snapshots) },
	};
	for (size_t k = 0; k < sizeof clocks / sizeof clocks[0]; k++) {
		const scene_when_t *w = (const scene_when_t *)((const char *)s + clocks[k].off);
		if (w->kind != SCENE_CLOCK_NONE && w->kind != SCENE_CLOCK_TIME)
			return fail(c, clocks[k].key, "method \"md\" takes \"time\" only (soft contacts have no collision "
				    "count to define collisions per particle)");
	}
	char path[PATHLEN];
	for (int a = 0; a < s->dim; a++)
		for (int k = 0; k < 2 && s->boundary[a].walled; k++) {
			const scene_wall_t *w = &s->boundary[a].wall[k];
			json_t *wj = json_object_get(json_object_get(json_object_get(v, "boundaries"), axis_names[a]),
						     k ? "upper" : "lower");
			snprintf(path, sizeof path, "boundaries.%s.%s.type", axis_names[a], k ? "upper" : "lower");
			if (w->type != SCENE_WALL_SPECULAR && w->type != SCENE_WALL_MOVING && w->type != SCENE_WALL_VIBRATING)
				return fail(c, path, "method \"md\" supports \"specular\", \"moving\" and \"vibrating\" "
					    "(flat) walls only yet");
			static const char *const wkeys[] = { "restitution", "coverage", "tangential_restitution" };
			for (size_t q = 0; q < sizeof wkeys / sizeof wkeys[0]; q++)
				if (json_object_get(wj, wkeys[q])) {
					snprintf(path, sizeof path, "boundaries.%s.%s.%s", axis_names[a], k ? "upper" : "lower",
						 wkeys[q]);
					return fail(c, path, "not with method \"md\": a wall is a contact partner with the "
						    "particles' force law and collisions.restitution");
				}
		}
	/* obstacles: fixed contact partners with the particles' law (md.h), so no rule of their own: type
	 * "slip" (the only one without keys of its own), without restitution */
	json_t *obj = json_object_get(v, "obstacles");
	for (size_t q = 0; q < json_array_size(obj); q++) {
		if (q < (size_t)s->n_obstacles && s->obstacle[q].type != SCENE_OBST_SLIP) {
			snprintf(path, sizeof path, "obstacles[%zu].type", q);
			return fail(c, path, "method \"md\" takes \"slip\" obstacles only: a fixed contact partner "
				    "with the particles' force law, collisions.restitution and md.friction");
		}
		static const char *const okeys[] = { "restitution", "temperature", "accommodation" };
		for (size_t k = 0; k < sizeof okeys / sizeof okeys[0]; k++)
			if (json_object_get(json_array_get(obj, q), okeys[k])) {
				snprintf(path, sizeof path, "obstacles[%zu].%s", q, okeys[k]);
				return fail(c, path, "not with method \"md\": an obstacle is a fixed contact partner with the "
					    "particles' force law, collisions.restitution and md.friction");
			}
	}
	const unsigned md_obs = SCENE_OBS_ENERGY | SCENE_OBS_MOMENTUM | SCENE_OBS_COM_HEIGHT | SCENE_OBS_POTENTIAL |
				SCENE_OBS_WALL_FORCE | SCENE_OBS_ROTATION | SCENE_OBS_PRESSURE | SCENE_OBS_OBSTACLE_FORCE | SCENE_OBS_SURFACE |
				SCENE_OBS_VDIST | SCENE_OBS_GOFR | SCENE_OBS_SOFK | SCENE_OBS_MSD;
	json_t *obs = json_object_get(out, "observables");
	if (!obs)
		s->observables = SCENE_OBS_ENERGY | (scene_has_gravity(s) ? SCENE_OBS_COM_HEIGHT | SCENE_OBS_POTENTIAL : 0);
	size_t i;
	json_t *o;
	json_array_foreach(obs, i, o)
		for (size_t k = 0; k < N_OBSERVABLES; k++)
			if (!strcmp(json_string_value(o), observables[k].name) && !(observables[k].bit & md_obs)) {
				snprintf(path, sizeof path, "output.observables[%zu]", i);
				return fail(c, path, "\"%s\" is not computed by method \"md\" yet (it has kinetic_energy, "
					    "temperature, momentum, center_of_mass_height, potential_energy, wall_force, "
					    "rotational_energy, rotational_temperature, pressure, compressibility, obstacle_force, "
					    "surface_profile, velocity_distribution, pair_correlation, structure_factor, "
					    "mean_square_displacement)",
					    observables[k].name);
			} else if (!strcmp(json_string_value(o), observables[k].name) &&
				 (observables[k].bit & SCENE_OBS_PRESSURE) && (scene_has_walls(s) || s->n_obstacles > 0)) {
				/* the pair virial gives the pressure of a periodic box; walls take part of the momentum
				 * flux (their forces are wall_force) */
				snprintf(path, sizeof path, "output.observables[%zu]", i);
				return fail(c, path, "\"%s\" with method \"md\" is the virial pressure of a periodic box "
					    "without obstacles; with walls use \"wall_force\" (the pressure on each wall)",
					    observables[k].name);
			}
	static const char *const outs[] = { "clusters", "impact_parameter", "fields", "density_spectrum" };
	for (size_t k = 0; k < sizeof outs / sizeof outs[0]; k++)
		if (json_object_get(out, outs[k])) {
			snprintf(path, sizeof path, "output.%s", outs[k]);
			return fail(c, path, "not computed by method \"md\" yet");
		}
	/* defaults: the reference impact speed from the thermal speed and the fall through the box */
	/* mixtures: the lightest particle is the fastest at a temperature, the heaviest and smallest overlaps the
	 * most at a speed (scene_t.mass is the mean, .radius the largest) */
	double m_lo = s->mass, m_hi = s->mass, r_lo = s->radius;
	for (int k = 0; k < s->n_species; k++) {
		m_lo = fmin(m_lo, s->species[k].mass);
		m_hi = fmax(m_hi, s->species[k].mass);
		r_lo = fmin(r_lo, s->species[k].radius_lo > 0 ? s->species[k].radius_lo : s->species[k].radius);
	}
	if (s->md_impact_speed == 0) {
		double fall = 0.0;
		for (int a = 0; a < s->dim; a++)
			fall += fabs(s->gravity[a]) * s->box[a];
		s->md_impact_speed = fmax(4.0 * sqrt(s->temperature / m_lo), sqrt(2.0 * fall));
		if (!(s->md_impact_speed > 0))
			return fail(c, "md.impact_speed", "required when the temperature is 0 and there is no gravity (it "
				    "sets the stiffness and the time step)");
	}
	if (s->md_max_overlap == 0)
		s->md_max_overlap = 0.01;
	if (s->md_time_step == 0)
		s->md_time_step = 1.0 / 50.0;
	if (s->md_tangential_ratio == 0)
		s->md_tangential_ratio = 2.0 / 7.0;
	if (s->md_stiffness == 0 && s->md_contact_time == 0) {
		/* the stiffness at which a head-on elastic impact on a wall at impact_speed overlaps max_overlap
		 * diameters: linear m v^2 = k delta^2; hertz m v^2 / 2 = 8/15 E* sqrt(R) delta^(5/2) */
		double v2 = s->md_impact_speed * s->md_impact_speed, d = s->md_max_overlap * 2.0 * r_lo;
		s->md_stiffness = s->md_law == 0 ? m_hi * v2 / (d * d)
						 : 15.0 * m_hi * v2 / (16.0 * sqrt(r_lo) * pow(d, 2.5));
	}
	return 0;
}

/* Observables and features a mixture does not have yet: refused by name. */
static int check_species_scene(ctx_t *c, json_t *v, scene_t *s)
{
	if (s->n_species == 0)
		return 0;
	for (int a = 0; a < s->n_species; a++)
		for (int b = 0; b < s->n_species; b++)
			if (isnan(s->restitution_pair[a][b]))
				s->restitution_pair[a][b] = s->restitution;
	if (s->n_species == 1)
		s->restitution = s->restitution_pair[0][0];   /* the one-species scene */
	if (!scene_has_species(s))
		return 0;
	const char *what = s->n_species > 1 ? "more than one particle species" : "polydisperse particles";
	/* dsmc, hsmc: periodic boxes, walls of every kind, gravity and obstacles (each particle's own radius and
	 * mass; each pair's contact value chi_ij); the local contact value is refused by dsmc_plan() */
	if (s->method != SCENE_METHOD_ED && s->method != SCENE_METHOD_DSMC && s->method != SCENE_METHOD_HSMC &&
	    s->method != SCENE_METHOD_MD)
		return fail(c, "particles.species", "method \"%s\" simulates one species of one radius only; use method "
			    "\"ed\", \"dsmc\", \"hsmc\" or \"md\" for %s", method_names[s->method], what);
	/* ed: particles.initial.region and .from (place.c, frame.c), run.replicas and collisions.rough work with
	 * mixtures; md places as ed (region) and runs replicas; dsmc mixtures not yet (untested there) */
	if (s->method != SCENE_METHOD_ED && s->method != SCENE_METHOD_MD) {
		json_t *col = json_object_get(v, "collisions");
		if (json_object_get(col, "rough"))
			return fail(c, "collisions.rough", "rough particles: not supported yet with %s (particles.species) "
				    "in method \"%s\"; use method \"ed\"", what, method_names[s->method]);
		json_t *ini = json_object_get(json_object_get(v, "particles"), "initial");
		static const char *const inits[] = { "from", "region" };
		for (size_t k = 0; k < sizeof inits / sizeof inits[0]; k++)
			if (json_object_get(ini, inits[k])) {
				char sub[PATHLEN];
				snprintf(sub, sizeof sub, "particles.initial.%s", inits[k]);
				return fail(c, sub, "not with %s (particles.species) in method \"%s\" yet; use method \"ed\"",
					    what, method_names[s->method]);
			}
		if (s->replicas > 1)
			return fail(c, "run.replicas", "ensembles with %s (particles.species) in method \"%s\" are not "
				    "supported yet; use method \"ed\"", what, method_names[s->method]);
	}
	/* clusters (each particle's own radius), velocity_distribution (each species scaled by its own
	 * temperature), fields (mass-weighted), mean_square_displacement (bounds from the lightest and heaviest)
	 * work with mixtures (observe.h); these are defined for one radius only */
	static const struct { unsigned bit; const char *name; } obs[] = {
		{ SCENE_OBS_VCORR, "velocity_correlations" }, { SCENE_OBS_IMPACT, "impact_parameter" },
	};
	/* pair_correlation: partial g_ab(r) of 2 ... SCENE_GOFR_SPECIES_MAX species of one radius each in a
	 * periodic box (the ideal pair counts of species that reach different regions are not there yet) */
	if (s->observables & SCENE_OBS_GOFR) {
		const char *why = NULL;
		for (int k = 0; k < s->n_species && !why; k++)
			if (s->species[k].radius_lo < s->species[k].radius_hi)
				why = "polydisperse species (radius_range)";
		if (!why && s->n_species < 2)
			why = "polydisperse particles";
		else if (!why && s->n_species > SCENE_GOFR_SPECIES_MAX)
			why = "more than 4 species";
		else if (!why && scene_has_walls(s))
			why = "walls (boundaries)";
		else if (!why && s->n_obstacles > 0)
			why = "obstacles";
		if (why)
			return fail(c, "output.observables", "\"pair_correlation\" of a mixture is available for 2 to %d "
				    "species of one radius each in a periodic box, not with %s", SCENE_GOFR_SPECIES_MAX, why);
	}
	for (size_t k = 0; k < sizeof obs / sizeof obs[0]; k++)
		if (s->observables & obs[k].bit)
			return fail(c, "output.observables", "\"%s\" is defined for one species of one radius only, not for "
				    "%s (particles.species)", obs[k].name, what);
	/* the species are blocks of rows; with an open wall the rows present are compacted (run.c) and the
	 * blocks lost */
	static const struct { unsigned bit; const char *name; } rows[] = {
		{ SCENE_OBS_CLUSTERS, "clusters" }, { SCENE_OBS_VDIST, "velocity_distribution" },
	};
	for (size_t k = 0; k < sizeof rows / sizeof rows[0]; k++)
		if ((s->observables & rows[k].bit) && scene_has_open_walls(s))
			return fail(c, "output.observables", "\"%s\" of %s (particles.species) is not available with an "
				    "\"open\" wall yet", rows[k].name, what);
	if (s->tc == 0)
		for (int a = 0; a < s->n_species; a++)
			for (int b = a; b < s->n_species; b++)
				if (s->restitution_pair[a][b] == 0)
					return fail(c, "collisions.restitution_pairs", "0 for (%s, %s) leads to inelastic collapse "
						    "unless collisions.tc > 0; set collisions.tc", s->species[a].name,
						    s->species[b].name);
	return 0;
}

/* Largest density grid per axis: 2^24 cells in all (128 MiB of doubles per field). */
#define GRID_MAX_2D 4096
#define GRID_MAX_3D 256

/* Settings of the structure observables (docs/scene.md, output.*): only with
 * an observable that uses them; g(r) within the minimum image; the density
 * grid within its memory bound; defaults that depend on the box. */
static int check_structure(ctx_t *c, json_t *v, scene_t *s)
{
	static const struct { const char *key; unsigned users; const char *names; } settings[] = {
		{ "velocity_distribution", SCENE_OBS_VDIST, "\"velocity_distribution\"" },
		{ "pair_correlation", SCENE_OBS_GOFR | SCENE_OBS_VCORR, "\"pair_correlation\" or \"velocity_correlations\"" },
		{ "structure_factor", SCENE_OBS_SOFK | SCENE_OBS_VCORR, "\"structure_factor\" or \"velocity_correlations\"" },
		{ "impact_parameter", SCENE_OBS_IMPACT, "\"impact_parameter\"" },
		{ "fields", SCENE_OBS_FIELDS, "\"fields\"" },
		{ "density_spectrum", SCENE_OBS_DSPEC, "\"density_spectrum\"" },
	};
	json_t *out = json_object_get(v, "output");
	char sub[PATHLEN];
	for (size_t i = 0; i < sizeof settings / sizeof settings[0]; i++)
		if (json_object_get(out, settings[i].key) && !(s->observables & settings[i].users)) {
			snprintf(sub, sizeof sub, "output.%s", settings[i].key);
			return fail(c, sub, "settings of an observable not asked for: add %s to output.observables",
				    settings[i].names);
		}
	double sigma = 2 * s->radius, half = s->box[0];
	for (int i = 1; i < s->dim; i++)
		half = fmin(half, s->box[i]);
	half /= 2 * sigma;   /* half the smallest edge, in diameters */
	if (s->gofr_range == 0)
		s->gofr_range = fmin(5.0, half);
	else if (s->gofr_range > half)
		return fail(c, "output.pair_correlation.range", "%s diameters is more than half the smallest box edge "
			    "(%.6g diameters): pairs beyond it have no unique minimum image", num(s->gofr_range).s, half);
	int gmax = s->dim == 2 ? GRID_MAX_2D : GRID_MAX_3D;
	if (s->sofk_grid[0] > gmax)
		return fail(c, "output.structure_factor.grid", "must be at most %d in %dD (memory), got %d", gmax,
			    s->dim, s->sofk_grid[0]);
	for (int i = 0; i < 3; i++) {
		if (i >= s->dim) {
			s->sofk_grid[i] = 1;
			continue;
		}
		if (s->sofk_grid[i] > 0)
			continue;
		/* Seed 000 sec. 3.2: the power of 2 whose cell is closest to one diameter. */
		double m = s->box[i] / sigma;
		int g = 4;
		while (g < gmax && fabs(log((double)g * 2 / m)) < fabs(log((double)g / m)))
			g *= 2;
		s->sofk_grid[i] = g;
	}
	return 0;
}

static int check_boundaries(ctx_t *c, json_t *v, scene_t *s);

/* Gravity's axis when gravity has exactly one non-zero component, else -1. */
static int gravity_axis(const scene_t *s)
{
	int g = -1, n = 0;
	for (int a = 0; a < s->dim; a++)
		if (s->gravity[a] != 0)
			g = a, n++;
	return n == 1 ? g : -1;
}

/* particles.source (docs/scene.md): dsmc/hsmc only, one species; gravity along one walled axis (the
 * particles are put above the top of the pile, on the floor gravity points to); the insertion column inside
 * the box. Resolves src_axis and src_position. */
static int check_source(ctx_t *c, scene_t *s)
{
	if (s->src_count == 0)
		return 0;
	if (s->method != SCENE_METHOD_DSMC && s->method != SCENE_METHOD_HSMC)
		return fail(c, "particles.source", "method \"%s\" does not support a source (only \"dsmc\" and \"hsmc\" do)",
		            method_names[s->method]);
	if (scene_has_species(s))
		return fail(c, "particles.source", "takes one species (particles.species is not supported with it yet)");
	if (scene_has_reservoir(s))
		return fail(c, "particles.source", "not with \"reservoir\" or \"dispenser\" walls");
	int g = gravity_axis(s);
	if (g < 0 || !s->boundary[g].walled)
		return fail(c, "particles.source", "needs gravity along exactly one axis, and walls on that axis (particles "
		            "are put above the top of the pile, which rests on the floor gravity points to)");
	if ((double)s->count + (double)s->src_count > (double)COUNT_MAX)
		return fail(c, "particles.source.count", "%llu plus particles.count %llu is more than %lld particles",
		            (unsigned long long)s->src_count, (unsigned long long)s->count, (long long)COUNT_MAX);
	s->src_axis = g;
	for (int a = 0, i = 0; a < 3; a++) {
		s->src_position[a] = 0.0;
		if (a >= s->dim || a == g)
			continue;
		double x = s->src_pos_raw[i], lo = 0.0, hi = s->box[a];
		if (s->boundary[a].walled)
			lo += s->radius, hi -= s->radius;   /* the contact planes */
		if (!(x - s->src_spread >= lo && x + s->src_spread <= hi)) {
			char sub[PATHLEN];
			snprintf(sub, sizeof sub, "particles.source.position[%d]", i);
			return fail(c, sub, "%s plus or minus spread %s leaves [%s, %s], the centres' range along %s", num(x).s,
			            num(s->src_spread).s, num(lo).s, num(hi).s, axis_names[a]);
		}
		s->src_position[a] = x;
		i++;
	}
	return 0;
}

/* output.surface_profile (engine/observe/surface.h): needs gravity along one walled axis (heights along
 * -gravity); bins along an axis across it (default: the first), default one bin per diameter. */
static int check_surface(ctx_t *c, json_t *v, scene_t *s)
{
	json_t *out = json_object_get(v, "output"), *d = json_object_get(out, "surface_profile");
	if (d && !(s->observables & SCENE_OBS_SURFACE))
		return fail(c, "output.surface_profile", "settings of an observable not asked for: add \"surface_profile\" "
		            "to output.observables");
	if (!(s->observables & SCENE_OBS_SURFACE))
		return 0;
	int g = gravity_axis(s);
	if (g < 0 || !s->boundary[g].walled)
		return fail(c, "output.observables", "\"surface_profile\" needs gravity along exactly one axis, and walls on "
		            "that axis (heights are measured from the floor along -gravity)");
	if (!json_object_get(d, "axis"))
		s->surf_axis = g == 0 ? 1 : 0;
	else if (s->surf_axis >= s->dim || s->surf_axis == g)
		return fail(c, "output.surface_profile.axis", "\"%s\" must be an axis across gravity within the %dD scene",
		            axis_names[s->surf_axis], s->dim);
	if (!json_object_get(d, "bins"))
		s->surf_bins = (int)fmax(2.0, fmin(100000.0, floor(s->box[s->surf_axis] / (2 * s->radius))));
	return 0;
}

/* output.fields (engine/observe/fields.h): with the "fields" observable only (check_structure) and then
 * required; one cell count per axis, at most FIELDS_MAX_CELLS in all; an exposure looks back from each
 * snapshot time, so it needs snapshots on a time schedule no shorter than itself. */
static int check_fields(ctx_t *c, json_t *v, scene_t *s)
{
	json_t *out = json_object_get(v, "output"), *f = json_object_get(out, "fields");
	if (!(s->observables & SCENE_OBS_FIELDS))
		return 0;
	if (!f)
		return fail(c, "output.fields", "required with the \"fields\" observable (at least \"cells\")");
	json_t *cells = json_object_get(f, "cells");
	if (json_is_array(cells) && json_array_size(cells) != (size_t)s->dim)
		return fail(c, "output.fields.cells", "must have %d entries (one per axis of a %dD scene), got %zu", s->dim,
		            s->dim, json_array_size(cells));
	double total = 1.0;
	for (int a = 0; a < 3; a++) {
		if (a >= s->dim)
			s->fields_cells[a] = 1;
		total *= s->fields_cells[a];
	}
	if (total > FIELDS_MAX_CELLS)
		return fail(c, "output.fields.cells", "%.0f cells in all, more than %d (each sample is one line of "
		            "observables.jsonl, at most 16 MiB for the daemon)", total, FIELDS_MAX_CELLS);
	bool exposure = json_object_get(f, "exposure") != NULL;
	if (json_object_get(f, "samples") && !exposure)
		return fail(c, "output.fields.samples", "needs output.fields.exposure (without it the fields are the "
		            "snapshot instant alone)");
	if (!exposure) {
		s->fields_samples = 1;
		return 0;
	}
	if (s->fields_samples == 0)
		s->fields_samples = 10;
	if (s->snapshots.kind != SCENE_CLOCK_TIME)
		return fail(c, "output.fields.exposure", "needs output.snapshots.every.time (the exposure ends at each snapshot "
		            "time, known in advance only on a time schedule)");
	if (s->fields_exposure > s->snapshots.value)
		return fail(c, "output.fields.exposure", "%s is longer than the snapshot interval output.snapshots.every.time = %s",
		            num(s->fields_exposure).s, num(s->snapshots.value).s);
	return 0;
}

/* Largest ring of density_spectrum samples (slices * samples per snapshot interval) and samples per
 * spectrum (the DFT costs slices * samples^2 at each snapshot). */
#define DSPEC_MAX_VALUES (1 << 24)
#define DSPEC_MAX_SAMPLES 16384

/* density_spectrum (engine/observe/dspec.h, docs/scene.md): with open walls over the particles present at
 * each sample, in ensembles the mean over the replicas; the spectrum needs output.density_spectrum (interval) and snapshots on a time schedule that
 * is a whole number of intervals; slices >= 2; the axis within the dimension (default: gravity's axis, else
 * the last axis). */
static int check_pipe(ctx_t *c, json_t *v, scene_t *s)
{
	json_t *out = json_object_get(v, "output"), *d = json_object_get(out, "density_spectrum");
	if (!(s->observables & SCENE_OBS_DSPEC))
		return 0;
	if (!d)
		return fail(c, "output.density_spectrum", "required with the \"density_spectrum\" observable (at least "
		            "\"interval\")");
	int g = s->dim - 1;
	for (int a = 0; a < s->dim; a++)
		if (s->gravity[a] != 0) {
			g = a;
			break;
		}
	if (!json_object_get(d, "axis"))
		s->dspec_axis = g;
	else if (s->dspec_axis >= s->dim)
		return fail(c, "output.density_spectrum.axis", "\"%s\" is out of range in a %dD scene", axis_names[s->dspec_axis],
		            s->dim);
	double len = s->box[s->dspec_axis], sigma = 2 * s->radius;
	if (!json_object_get(d, "slices"))
		s->dspec_slices = (int)fmax(2.0, fmin(1000.0, floor(len / sigma)));   /* about one diameter high */
	else if (s->dspec_slices < 2)
		return fail(c, "output.density_spectrum.slices", "must be at least 2 (a spectrum of density differences "
		            "along the axis), got %d", s->dspec_slices);
	if (s->snapshots.kind != SCENE_CLOCK_TIME)
		return fail(c, "output.density_spectrum.interval", "needs output.snapshots.every.time (each spectrum is "
		            "made from the samples of one snapshot interval)");
	double m = s->snapshots.value / s->dspec_interval;
	if (fabs(m - round(m)) > 1e-9 * m || round(m) < 8 || round(m) > DSPEC_MAX_SAMPLES)
		return fail(c, "output.density_spectrum.interval", "the snapshot interval %s must be a whole number of "
		            "intervals between 8 and %d, got %.6g", num(s->snapshots.value).s, DSPEC_MAX_SAMPLES, m);
	s->dspec_m = (int)round(m);
	if ((double)s->dspec_m * s->dspec_slices > DSPEC_MAX_VALUES)
		return fail(c, "output.density_spectrum.slices", "%d slices times %d samples is more than %d values "
		            "(memory)", s->dspec_slices, s->dspec_m, DSPEC_MAX_VALUES);
	if (!json_object_get(d, "fit")) {
		s->dspec_fit[0] = 0;
		s->dspec_fit[1] = INFINITY;
	}
	return 0;
}

/* Rough particles across the scene: method ed only, the initial spins and
 * the rotational observables only with them (or with method md and friction). */
static int check_rough_scene(ctx_t *c, json_t *v, scene_t *s)
{
	json_t *init = json_object_get(json_object_get(v, "particles"), "initial");
	bool trot = json_object_get(init, "rotational_temperature") != NULL;
	if (s->rough && s->method != SCENE_METHOD_ED)
		return fail(c, "collisions.rough", "method \"%s\" does not support rough particles (only \"ed\" does)",
		            method_names[s->method]);
	if (trot && !s->rough)
		return fail(c, "particles.initial.rotational_temperature", "needs rough particles (collisions.rough)");
	if (s->rough && !trot)
		s->rot_temperature = s->temperature;
	json_t *obs = json_object_get(json_object_get(v, "output"), "observables");
	size_t i;
	json_t *o;
	json_array_foreach(obs, i, o) {
		const char *name = json_string_value(o);
		if (strcmp(name, "rotational_energy") && strcmp(name, "rotational_temperature"))
			continue;
		char path[PATHLEN];
		snprintf(path, sizeof path, "output.observables[%zu]", i);
		if (s->method == SCENE_METHOD_MD && !(s->md_friction > 0))
			return fail(c, path, "\"%s\" needs md.friction > 0 with method \"md\" (without friction the spins "
			            "stay 0)", name);
		if (!s->rough && s->method != SCENE_METHOD_MD)
			return fail(c, path, "\"%s\" needs rough particles (collisions.rough)", name);
	}
	return 0;
}

/* Rules that span objects, and the derived fields. */
static int check_scene(ctx_t *c, const char *path, json_t *v, void *base)
{
	scene_t *s = base;
	bool box_given = json_object_get(json_object_get(v, "particles"), "box") != NULL;
	double vp = scene_particle_volume(s);
	const char *shape = s->dim == 2 ? "2D disks" : "3D spheres";

	if (box_given) {
		s->volume_fraction = (double)s->count * vp / scene_box_volume(s);
	} else {
		double edge = pow((double)s->count * vp / s->volume_fraction, 1.0 / s->dim);
		for (int i = 0; i < s->dim; i++)
			s->box[i] = edge;
	}
	/* Absurd radii or edges overflow; say so rather than divide by inf. */
	if (!isfinite(vp) || !isfinite(s->volume_fraction) || !(s->volume_fraction > 0) ||
	    !isfinite(s->box[0]) || !(s->box[0] > 0))
		return fail(c, box_given ? "particles.box" : "particles.volume_fraction",
			    "box volume or particle volume out of range (radius %s)", num(s->radius).s);

	double cp = scene_close_packing(s->dim);
	if (s->volume_fraction >= cp) {
		const char *how = s->volume_fraction > cp ? "above" : "at";
		if (box_given)
			return fail(c, "particles.box", "gives volume fraction %.4g, %s the close-packing limit %.4f of %s",
				    s->volume_fraction, how, cp, shape);
		return fail(c, "particles.volume_fraction", "%s is %s the close-packing limit %.4f of %s",
			    num(s->volume_fraction).s, how, cp, shape);
	}

	/* Minimum image: each pair has a single nearest image only if every edge
	 * exceeds twice the interaction range (one diameter). */
	for (int i = 0; i < s->dim; i++) {
		if (s->box[i] > 4 * s->radius)
			continue;
		if (box_given) {
			char sub[PATHLEN];
			snprintf(sub, sizeof sub, "particles.box[%d]", i);
			return fail(c, sub, "edge %s must be greater than 2 diameters (%s) for the minimum image convention",
				    num(s->box[i]).s, num(4 * s->radius).s);
		}
		return fail(c, "particles.volume_fraction",
			    "gives box edge %.4g, which must be greater than 2 diameters (%s) for the minimum image convention; "
			    "use more particles or a lower volume_fraction", s->box[i], num(4 * s->radius).s);
	}

	int sret = check_md(c, v, s);
	if (sret)
		return sret;
	sret = check_species_scene(c, v, s);
	if (sret)
		return sret;
	/* Perfectly inelastic hard spheres collapse in finite time (infinitely many
	 * collisions); the TC model makes close repeat collisions elastic. */
	if (s->restitution == 0 && s->tc == 0)
		return fail(c, "collisions.restitution", "0 leads to inelastic collapse unless collisions.tc > 0; set collisions.tc");

	/* Method settings only with their method: a forgotten "method" is a mistake. */
	static const struct { const char *key; scene_method_t m; } tuning[] = {
		{ "dsmc", SCENE_METHOD_DSMC }, { "hsmc", SCENE_METHOD_HSMC }, { "md", SCENE_METHOD_MD },
	};
	for (size_t i = 0; i < sizeof tuning / sizeof tuning[0]; i++)
		if (json_object_get(v, tuning[i].key) && s->method != tuning[i].m)
			return fail(c, tuning[i].key, "settings of method \"%s\", but method is \"%s\"", tuning[i].key,
				    method_names[s->method]);
	/* An accuracy target is what "auto" chooses by; with a fixed method it would be ignored. */
	bool accuracy = json_object_get(v, "accuracy") != NULL;
	if (accuracy && s->method != SCENE_METHOD_AUTO)
		return fail(c, "accuracy", "only with \"method\": \"auto\", but method is \"%s\"", method_names[s->method]);
	if (!accuracy && s->method == SCENE_METHOD_AUTO)
		return fail(c, "accuracy", "required with \"method\": \"auto\" (e.g. {\"temperature\": 0.05})");
	/* A local contact value scales the Enskog rate: without one it would do nothing. */
	if (s->mc_local_chi && (s->mc_correction == SCENE_MC_NONE ||
	                        (s->mc_correction == SCENE_MC_DEFAULT && s->method == SCENE_METHOD_DSMC)))
		return fail(c, s->method == SCENE_METHOD_HSMC ? "hsmc.contact_value" : "dsmc.contact_value",
			    "\"local\" needs correction \"enskog\" or \"cba\" (the correction is \"none\")");
	if (s->mc_max_volume_fraction >= cp)
		return fail(c, "hsmc.max_volume_fraction", "%s is at or above the close-packing limit %.4f of %s",
			    num(s->mc_max_volume_fraction).s, cp, shape);

	/* region.upper defaults to the box, known only now */
	for (int a = 0; a < s->dim && s->has_region; a++)
		if (isnan(s->region_hi[a]))
			s->region_hi[a] = s->box[a];
	if (s->has_from && s->replicas > 1 && s->from_replica != SCENE_FROM_EACH)
		return fail(c, "particles.initial.from", "with run.replicas > 1 every replica would start from the same "
		            "frame; use \"replica\": \"each\" (replica r from replica r of an ensemble's trajectory)");
	if (s->balance && s->method != SCENE_METHOD_ED)
		return fail(c, "run.balance", "\"events\" balances one ed system split over MPI ranks; method \"%s\" has no "
		            "such run (use \"off\")", method_names[s->method]);
	if (s->balance && s->replicas > 1)
		return fail(c, "run.balance", "\"events\" needs run.replicas 1 (one system split over the ranks); an ensemble "
		            "runs each replica whole on one rank");
	if (s->has_from && s->replicas == 1 && s->from_replica == SCENE_FROM_EACH)
		return fail(c, "particles.initial.from.replica", "\"each\" needs run.replicas > 1 (replica r from replica "
		            "r); a single run names one replica by its index");

	int ret = check_structure(c, v, s);
	if (ret)
		return ret;

	ret = check_boundaries(c, v, s);
	if (ret)
		return ret;
	ret = check_source(c, s);
	if (ret)
		return ret;
	ret = check_surface(c, v, s);
	if (ret)
		return ret;
	ret = check_rough_scene(c, v, s);
	if (ret)
		return ret;
	ret = check_fields(c, v, s);
	if (ret)
		return ret;
	ret = check_pipe(c, v, s);
	if (ret)
		return ret;
	if (s->every.kind == SCENE_CLOCK_NONE)
		s->every = (scene_when_t){ s->until.kind, s->until.value / 100 };

	return scene_check_start(s, c->err, c->errlen);
}

/* The engines' own start checks (cell grid, initial placement), made by
 * the engines' plan functions that their constructors share: a scene that
 * parses is one the engine starts. */
int scene_check_start(const scene_t *s, char *err, size_t errlen)
{
	char why[PATHLEN + 256] = "";
	int bad = 0;
	if (s->method == SCENE_METHOD_ED)
		bad = ed_plan(s, NULL, why, sizeof why) != ED_OK;
	else if (s->method == SCENE_METHOD_DSMC || s->method == SCENE_METHOD_HSMC)
		bad = dsmc_plan(s, NULL, why, sizeof why) != DSMC_OK;
	if (!bad && s->method == SCENE_METHOD_MD) {
		scene_t p;   /* md places as ed does, in the whole box (scene_md_placement()) */
		scene_md_placement(s, &p);
		bad = place_check(&p, why, sizeof why) != PLACE_OK;
	} else if (!bad && s->method != SCENE_METHOD_AUTO)
		bad = place_check(s, why, sizeof why) != PLACE_OK;
	if (!bad)
		return SCENE_OK;
	/* why is "KEY: reason" */
	ctx_t c = { NULL, err, errlen };
	char key[PATHLEN];
	const char *sep = strstr(why, ": ");
	snprintf(key, sizeof key, "%.*s", sep ? (int)(sep - why) : 0, why);
	return fail(&c, sep ? key : "(root)", "%s", sep ? sep + 2 : why);
}


/* ---- boundaries ------------------------------------------------------ */

/* Keys a wall of each type takes besides "type" (and what it requires). */
static const struct {
	const char *key;
	unsigned types;      /* bit per scene_wall_type_t that accepts it */
	unsigned required;   /* bit per type that requires it */
} wall_keys[] = {
	{ "restitution", 0x1f | 1u << SCENE_WALL_DISPENSER, 0 },
	{ "temperature", 1u << SCENE_WALL_THERMAL | 1u << SCENE_WALL_RESERVOIR | 1u << SCENE_WALL_DISPENSER,
	  1u << SCENE_WALL_THERMAL | 1u << SCENE_WALL_RESERVOIR | 1u << SCENE_WALL_DISPENSER },
	{ "accommodation", 1u << SCENE_WALL_THERMAL, 0 },
	{ "probability", 1u << SCENE_WALL_ROUGH, 1u << SCENE_WALL_ROUGH },
	{ "velocity", 1u << SCENE_WALL_MOVING | 1u << SCENE_WALL_THERMAL | 1u << SCENE_WALL_RESERVOIR |
	  1u << SCENE_WALL_DISPENSER, 1u << SCENE_WALL_MOVING | 1u << SCENE_WALL_DISPENSER },
	{ "volume_fraction", 1u << SCENE_WALL_RESERVOIR | 1u << SCENE_WALL_DISPENSER,
	  1u << SCENE_WALL_RESERVOIR | 1u << SCENE_WALL_DISPENSER },
	{ "gas", 1u << SCENE_WALL_RESERVOIR, 0 },
	{ "thickness", 1u << SCENE_WALL_DISPENSER, 0 },
	{ "composition", 1u << SCENE_WALL_DISPENSER | 1u << SCENE_WALL_RESERVOIR, 0 },
	{ "filter", 1u << SCENE_WALL_OPEN, 0 },
	{ "tangential_restitution", 1u << SCENE_WALL_MOVING, 0 },
	{ "coverage", 1u << SCENE_WALL_MOVING, 0 },
	{ "amplitude", 1u << SCENE_WALL_VIBRATING, 1u << SCENE_WALL_VIBRATING },
	{ "frequency", 1u << SCENE_WALL_VIBRATING, 1u << SCENE_WALL_VIBRATING },
	{ "phase", 1u << SCENE_WALL_VIBRATING, 0 },
};

static int check_wall(ctx_t *c, const char *path, json_t *v, void *base)
{
	scene_wall_t *w = base;
	char sub[PATHLEN];
	for (size_t k = 0; k < sizeof wall_keys / sizeof wall_keys[0]; k++) {
		bool has = json_object_get(v, wall_keys[k].key) != NULL;
		join(sub, path, wall_keys[k].key);
		if (has && !(wall_keys[k].types & (1u << w->type)))
			return fail(c, sub, "not a key of a \"%s\" wall", wall_names[w->type]);
		if (!has && (wall_keys[k].required & (1u << w->type)))
			return fail(c, sub, "required for a \"%s\" wall", wall_names[w->type]);
	}
	if (json_object_get(v, "coverage") && json_object_get(v, "restitution"))
		return fail(c, path, "at most one of restitution or coverage (which sets the restitution)");
	return 0;
}

/* A dispenser's composition: an array of 1 ... SCENE_SPECIES_MAX weights
 * >= 0, not all 0, normalised into number fractions (into n_composition,
 * composition); checked against particles.species by check_streams(). */
static int parse_composition(ctx_t *c, const char *path, json_t *v, void *dst, const void *arg)
{
	(void)arg;
	scene_wall_t *w = (scene_wall_t *)((char *)dst - offsetof(scene_wall_t, n_composition));
	char sub[PATHLEN];
	const size_t n = json_is_array(v) ? json_array_size(v) : 0;
	if (n < 1 || n > SCENE_SPECIES_MAX)
		return fail(c, path, "must be an array of 1 ... %d numbers (one weight per species, in the order of "
		            "particles.species)", SCENE_SPECIES_MAX);
	double sum = 0.0;
	for (size_t k = 0; k < n; k++) {
		snprintf(sub, sizeof sub, "%s[%zu]", path, k);
		int ret = get_number(c, sub, json_array_get(v, k), &R_NONNEG, &w->composition[k]);
		if (ret)
			return ret;
		sum += w->composition[k];
	}
	if (!(sum > 0.0) || !isfinite(sum))
		return fail(c, path, "the weights must not all be 0");
	for (size_t k = 0; k < n; k++)
		w->composition[k] /= sum;
	w->n_composition = (int)n;
	return 0;
}

static int check_filter(ctx_t *c, const char *path, json_t *v, void *base)
{
	scene_filter_t *f = base;
	(void)c, (void)path, (void)v;
	f->on = 1;
	return 0;
}

static const struct object filter_obj = {
	.fields = (const struct field[]){
		{ "distance", parse_number, offsetof(scene_filter_t, distance), &R_POS, true },
		{ "velocity", parse_vector, offsetof(scene_filter_t, velocity), NULL, true },
		{ "temperature", parse_number, offsetof(scene_filter_t, temperature), &R_POS, false },
		{ .name = NULL },
	},
	.check = check_filter,
};

static const struct object wall_obj = {
	.fields = (const struct field[]){
		{ "type", parse_wall_type, offsetof(scene_wall_t, type), NULL, true },
		{ "restitution", parse_number, offsetof(scene_wall_t, restitution), &R_UNIT, false },
		{ "temperature", parse_number, offsetof(scene_wall_t, temperature), &R_POS, false },
		{ "accommodation", parse_number, offsetof(scene_wall_t, accommodation), &R_UNIT, false },
		{ "probability", parse_number, offsetof(scene_wall_t, probability), &R_UNIT, false },
		{ "velocity", parse_vector, offsetof(scene_wall_t, velocity), NULL, false },
		{ "tangential_restitution", parse_number, offsetof(scene_wall_t, tangential_restitution), &R_SIGNED_UNIT, false },
		{ "coverage", parse_number, offsetof(scene_wall_t, coverage), &R_UNIT, false },
		{ "amplitude", parse_number, offsetof(scene_wall_t, amplitude), &R_NONNEG, false },
		{ "frequency", parse_number, offsetof(scene_wall_t, frequency), &R_POS, false },
		{ "phase", parse_number, offsetof(scene_wall_t, phase), &R_ANY, false },
		{ "volume_fraction", parse_number, offsetof(scene_wall_t, volume_fraction), &R_POS, false },
		{ "gas", parse_gas, offsetof(scene_wall_t, gas), NULL, false },
		{ "thickness", parse_number, offsetof(scene_wall_t, thickness), &R_POS, false },
		{ "composition", parse_composition, offsetof(scene_wall_t, n_composition), NULL, false },
		{ "filter", parse_object, offsetof(scene_wall_t, filter), &filter_obj, false },
		{ .name = NULL },
	},
	.check = check_wall,
};

static int check_axis(ctx_t *c, const char *path, json_t *v, void *base)
{
	scene_boundary_t *b = base;
	int axis = (int)(b - c->s->boundary);
	static const char *const ends[2] = { "lower", "upper" };
	char sub[PATHLEN];
	if (axis >= c->s->dim)
		return fail(c, path, "no such axis in %d dimensions", c->s->dim);
	for (int k = 0; k < 2; k++) {
		bool has = json_object_get(v, ends[k]) != NULL;
		join(sub, path, ends[k]);
		if (has && !b->walled)
			return fail(c, sub, "a wall on a periodic axis (%s.type is \"periodic\"; use \"walls\")", path);
		if (!has && b->walled)
			return fail(c, sub, "required with type \"walls\" (walls at both ends)");
		const scene_wall_t *w = &b->wall[k];
		if (has && (w->type == SCENE_WALL_MOVING || w->type == SCENE_WALL_THERMAL) && w->velocity[axis] != 0) {
			char vel[PATHLEN + 32];
			snprintf(vel, sizeof vel, "%s.velocity[%d]", sub, axis & 3);
			return fail(c, vel, "the wall moves in its own plane: the component along the axis must be 0, got %s "
			            "(a wall moving along its normal is \"vibrating\")", num(w->velocity[axis]).s);
		}
	}
	return 0;
}

static const struct object axis_obj = {
	.fields = (const struct field[]){
		{ "type", parse_axis_kind, offsetof(scene_boundary_t, walled), NULL, true },
		{ "lower", parse_object, offsetof(scene_boundary_t, wall[0]), &wall_obj, false },
		{ "upper", parse_object, offsetof(scene_boundary_t, wall[1]), &wall_obj, false },
		{ .name = NULL },
	},
	.check = check_axis,
};

static const struct object boundaries_obj = {
	.fields = (const struct field[]){
		{ "x", parse_object, offsetof(scene_t, boundary[0]), &axis_obj, false },
		{ "y", parse_object, offsetof(scene_t, boundary[1]), &axis_obj, false },
		{ "z", parse_object, offsetof(scene_t, boundary[2]), &axis_obj, false },
		{ .name = NULL },
	},
};

/* ---- obstacles ------------------------------------------------------- */

static int parse_obstacle_type(ctx_t *c, const char *path, json_t *v, void *dst, const void *arg)
{
	int i, ret = match(c, path, v, obstacle_names, sizeof obstacle_names / sizeof obstacle_names[0], &i);
	if (ret == 0)
		*(scene_obstacle_type_t *)dst = (scene_obstacle_type_t)i;
	return ret;
}

static int check_obstacle(ctx_t *c, const char *path, json_t *v, void *base)
{
	const scene_obstacle_t *o = base;
	char sub[PATHLEN];
	static const char *const thermal_keys[] = { "temperature", "accommodation" };
	for (size_t k = 0; k < 2; k++) {
		bool has = json_object_get(v, thermal_keys[k]) != NULL;
		join(sub, path, thermal_keys[k]);
		if (has && o->type != SCENE_OBST_NO_SLIP)
			return fail(c, sub, "not a key of a \"%s\" obstacle (only \"no_slip\")", obstacle_names[o->type]);
		if (!has && k == 0 && o->type == SCENE_OBST_NO_SLIP)
			return fail(c, sub, "required for a \"no_slip\" obstacle (the wall temperature it re-emits at)");
	}
	return 0;
}

static const struct object obstacle_obj = {
	.fields = (const struct field[]){
		{ "type", parse_obstacle_type, offsetof(scene_obstacle_t, type), NULL, true },
		{ "center", parse_vector, offsetof(scene_obstacle_t, center), NULL, true },
		{ "radius", parse_number, offsetof(scene_obstacle_t, radius), &R_POS, true },
		{ "restitution", parse_number, offsetof(scene_obstacle_t, restitution), &R_UNIT, false },
		{ "temperature", parse_number, offsetof(scene_obstacle_t, temperature), &R_POS, false },
		{ "accommodation", parse_number, offsetof(scene_obstacle_t, accommodation), &R_UNIT, false },
		{ .name = NULL },
	},
	.check = check_obstacle,
};

static int parse_obstacles(ctx_t *c, const char *path, json_t *v, void *dst, const void *arg)
{
	scene_t *s = c->s;
	size_t i;
	json_t *o;
	if (!json_is_array(v))
		return fail(c, path, "must be an array of obstacle objects, got %s", type_name(v));
	if (json_array_size(v) > SCENE_OBSTACLES_MAX)
		return fail(c, path, "at most %d obstacles, got %zu", SCENE_OBSTACLES_MAX, json_array_size(v));
	json_array_foreach(v, i, o) {
		char sub[PATHLEN / 2];   /* "obstacles[k]": short, so keys below it fit a path */
		snprintf(sub, sizeof sub, "%s[%zu]", path, i);
		s->obstacle[i] = (scene_obstacle_t){ .restitution = 1, .accommodation = 1 };
		int ret = walk(c, sub, o, &s->obstacle[i], &obstacle_obj);
		if (ret)
			return ret;
		s->n_obstacles = (int)i + 1;
	}
	return 0;
}

/* Obstacles inside the box, clear of the walls' reach and of each other;
 * on periodic axes one image of an obstacle at a time within a particle's
 * reach (2 (R + a) < L). */
static int check_obstacles(ctx_t *c, const scene_t *s)
{
	char path[PATHLEN];
	for (int k = 0; k < s->n_obstacles; k++) {
		const scene_obstacle_t *o = &s->obstacle[k];
		for (int a = 0; a < s->dim; a++) {
			const scene_boundary_t *b = &s->boundary[a];
			snprintf(path, sizeof path, "obstacles[%d].center[%d]", k, a);
			if (!(o->center[a] >= 0 && o->center[a] <= s->box[a]))
				return fail(c, path, "%s is outside the box [0, %s]", num(o->center[a]).s, num(s->box[a]).s);
			if (!b->walled) {
				if (!(2 * (o->radius + s->radius) < s->box[a])) {
					snprintf(path, sizeof path, "obstacles[%d].radius", k);
					return fail(c, path, "2 (radius + particle radius) = %s must be less than the periodic box edge "
					            "%s along %s (a particle would touch two images at once)",
					            num(2 * (o->radius + s->radius)).s, num(s->box[a]).s, axis_names[a]);
				}
				continue;
			}
			/* the walls' innermost positions (vibrating: amplitude) */
			double lo = b->wall[0].type == SCENE_WALL_VIBRATING ? b->wall[0].amplitude : 0;
			double hi = s->box[a] - (b->wall[1].type == SCENE_WALL_VIBRATING ? b->wall[1].amplitude : 0);
			if (o->center[a] - o->radius < lo || o->center[a] + o->radius > hi) {
				snprintf(path, sizeof path, "obstacles[%d]", k);
				return fail(c, path, "overlaps the wall boundaries.%s.%s: centre %s, radius %s, walls reach %s .. %s",
				            axis_names[a], o->center[a] - o->radius < lo ? "lower" : "upper", num(o->center[a]).s,
				            num(o->radius).s, num(lo).s, num(hi).s);
			}
		}
		for (int j = 0; j < k; j++) {
			const scene_obstacle_t *q = &s->obstacle[j];
			double r2 = 0;
			for (int a = 0; a < s->dim; a++) {
				double x = o->center[a] - q->center[a];
				if (!s->boundary[a].walled)
					x -= s->box[a] * nearbyint(x / s->box[a]);
				r2 += x * x;
			}
			if (sqrt(r2) < o->radius + q->radius) {
				snprintf(path, sizeof path, "obstacles[%d]", k);
				return fail(c, path, "overlaps obstacles[%d] (centre distance %s < sum of radii %s)", j,
				            num(sqrt(r2)).s, num(o->radius + q->radius).s);
			}
		}
	}
	return 0;
}

/* Reservoir walls (method ed): what the inlet supports, and the particle
 * slots (particles.capacity, docs/scene.md). Without a reservoir the
 * capacity is the count and the key is refused. */
/* A wall's optional composition (boundaries.AXIS.END.composition of reservoir and dispenser walls): one
 * weight per species of a mixture. 0 or SCENE_EINVAL naming the key. */
static int check_composition(ctx_t *c, const scene_t *s, const scene_wall_t *w, int a, const char *end)
{
	char path[PATHLEN];
	if (!w->n_composition)
		return 0;
	snprintf(path, sizeof path, "boundaries.%s.%s.composition", axis_names[a], end);
	if (s->n_species < 2)
		return fail(c, path, "needs particles.species with two or more species (the weights are per species)");
	if (w->n_composition != s->n_species)
		return fail(c, path, "has %d weights for %d species (one per species, in the order of "
		            "particles.species)", w->n_composition, s->n_species);
	return 0;
}

static int check_reservoirs(ctx_t *c, json_t *v, scene_t *s)
{
	char path[PATHLEN];
	bool given = json_object_get(json_object_get(v, "particles"), "capacity") != NULL;
	if (!scene_has_reservoir(s)) {
		if (given)
			return fail(c, "particles.capacity", "only with a \"reservoir\" or \"dispenser\" wall (particles enter)");
		s->capacity = s->count;
		return 0;
	}
	const double vp = scene_particle_volume(s), cp = scene_close_packing(s->dim);
	double nmax = 0.0;   /* the largest reservoir number density */
	for (int a = 0; a < s->dim; a++)
		for (int k = 0; k < 2; k++) {
			const scene_wall_t *w = &s->boundary[a].wall[k];
			if (!s->boundary[a].walled || (w->type != SCENE_WALL_RESERVOIR && w->type != SCENE_WALL_DISPENSER))
				continue;
			const char *wn = wall_names[w->type];
			snprintf(path, sizeof path, "boundaries.%s.%s", axis_names[a], k ? "upper" : "lower");
			if (s->method != SCENE_METHOD_ED)
				return fail(c, path, "method \"%s\" does not support \"%s\" walls (only \"ed\" does)",
				            method_names[s->method], wn);
			if (w->volume_fraction >= cp) {
				snprintf(path, sizeof path, "boundaries.%s.%s.volume_fraction", axis_names[a], k ? "upper" : "lower");
				return fail(c, path, "%s is at or above the close-packing limit %.4f", num(w->volume_fraction).s, cp);
			}
			/* a hard-sphere reservoir gas: its activity comes from the fluid's equation of state
			 * (Henderson, Carnahan-Starling), not valid beyond freezing (2D: the hexatic phase from
			 * about 0.70; 3D: 0.494) */
			const double freeze = s->dim == 2 ? 0.69 : 0.494;
			if (w->type == SCENE_WALL_RESERVOIR && w->gas == SCENE_GAS_HARD_SPHERES && w->volume_fraction > freeze) {
				snprintf(path, sizeof path, "boundaries.%s.%s.volume_fraction", axis_names[a], k ? "upper" : "lower");
				return fail(c, path, "%s is above %.3g, the fluid's limit in %dD: a reservoir with gas "
				            "\"hard_spheres\" is a fluid (its equation of state)", num(w->volume_fraction).s,
				            freeze, s->dim);
			}
			nmax = fmax(nmax, w->volume_fraction / (w->type == SCENE_WALL_DISPENSER && s->n_species > 0 ?
			                                        scene_dispenser_volume(s, w) : vp));
			int rc = w->type == SCENE_WALL_RESERVOIR ? check_composition(c, s, w, a, k ? "upper" : "lower") : 0;
			if (rc)
				return rc;
			for (int q = 0; q < s->n_species && w->type == SCENE_WALL_RESERVOIR; q++)
				if (s->species[q].radius_hi > 0) {
					snprintf(path, sizeof path, "particles.species[%d].radius_range", q);
					return fail(c, path, "a scene with a \"%s\" wall takes species of one radius each: an "
					            "entering particle takes a free slot of its species and a slot keeps its radius, "
					            "so the radii entering would not follow the reservoir's distribution%s; give "
					            "each species one radius (a \"dispenser\" wall takes polydisperse species)", wn,
					            w->gas == SCENE_GAS_HARD_SPHERES ? " (with gas \"hard_spheres\" weighted by "
					            "exp(beta mu_ex) of each radius)" : "");
				}
		}
	/* default: room for twice the larger of the initial count and what the
	 * box holds at the densest reservoir's density, plus 64 */
	double fill = nmax * scene_box_volume(s), def = 2.0 * fmax((double)s->count, fill) + 64.0;
	if (!given)
		s->capacity = def < (double)COUNT_MAX ? (uint64_t)ceil(def) : (uint64_t)COUNT_MAX;
	if (s->capacity < s->count)
		return fail(c, "particles.capacity", "%llu is below particles.count %llu (slots for the particles present)",
		            (unsigned long long)s->capacity, (unsigned long long)s->count);
	return 0;
}

/* Whether a dispenser's layers or a filter's frozen particles may move at v
 * along axis j (not their own): periodic, at rest along it, or a stream
 * along it that way (the wall they move away from a dispenser, the wall
 * they move towards open): they never run into a wall of j. */
static int stream_along(const scene_t *s, int j, double v)
{
	const scene_boundary_t *b = &s->boundary[j];
	if (!b->walled || v == 0)
		return 1;
	const int up = v > 0 ? 0 : 1;   /* the wall upstream */
	return b->wall[up].type == SCENE_WALL_DISPENSER && b->wall[1 - up].type == SCENE_WALL_OPEN;
}

/* Seed 001's open stream (method ed): dispenser walls (the piston and its
 * layers) and the filters of open walls: where they fit, what they move
 * with, what they are not combined with yet (docs/scene.md). */
static int check_streams(ctx_t *c, const scene_t *s)
{
	char path[PATHLEN];
	for (int a = 0; a < s->dim; a++) {
		const scene_boundary_t *b = &s->boundary[a];
		if (!b->walled)
			continue;
		for (int k = 0; k < 2; k++) {
			const scene_wall_t *w = &b->wall[k];
			const char *end = k ? "upper" : "lower";
			const double sg = k ? -1.0 : 1.0;   /* inward normal along the axis */
			if (w->type == SCENE_WALL_DISPENSER) {
				snprintf(path, sizeof path, "boundaries.%s.%s", axis_names[a], end);
				int rc = check_composition(c, s, w, a, end);
				if (rc)
					return rc;
				if (!(sg * w->velocity[a] >= 0)) {
					snprintf(path, sizeof path, "boundaries.%s.%s.velocity[%d]", axis_names[a], end, a);
					return fail(c, path, "the piston moves into the box: the component along the inward normal must be "
					            ">= 0, got %s", num(sg * w->velocity[a]).s);
				}
				for (int j = 0; j < s->dim; j++)
					if (j != a && !stream_along(s, j, w->velocity[j])) {
						snprintf(path, sizeof path, "boundaries.%s.%s.velocity[%d]", axis_names[a], end, j);
						return fail(c, path, "must be 0 along the walled axis %s (the layers would drift into its walls) "
						            "unless %s is a stream that way (a dispenser upstream, an open wall downstream)",
						            axis_names[j], axis_names[j]);
					}
				const double h = w->thickness > 0 ? w->thickness : 4 * s->radius;
				snprintf(path, sizeof path, "boundaries.%s.%s.thickness", axis_names[a], end);
				if (!(h > 2 * s->radius))
					return fail(c, path, "%s must exceed one particle diameter %s (the layer lies between the piston "
					            "and the particles ahead)", num(h).s, num(2 * s->radius).s);
				if (!(h <= 0.25 * s->box[a]))
					return fail(c, path, "%s must be at most a quarter of the box edge %s along %s", num(h).s,
					            num(s->box[a]).s, axis_names[a]);
			}
			if (w->type == SCENE_WALL_OPEN && w->filter.on) {
				const scene_filter_t *f = &w->filter;
				snprintf(path, sizeof path, "boundaries.%s.%s.filter", axis_names[a], end);
				if (s->method != SCENE_METHOD_ED)
					return fail(c, path, "method \"%s\" does not support filters (only \"ed\" does)",
					            method_names[s->method]);
				snprintf(path, sizeof path, "boundaries.%s.%s.filter.distance", axis_names[a], end);
				if (!(f->distance > s->radius))
					return fail(c, path, "%s must exceed the particle radius %s (seed 001: the plane lies more than a "
					            "radius inside the outlet)", num(f->distance).s, num(s->radius).s);
				if (!(f->distance <= 0.5 * s->box[a]))
					return fail(c, path, "%s must be at most half the box edge %s along %s", num(f->distance).s,
					            num(s->box[a]).s, axis_names[a]);
				if (!(-sg * f->velocity[a] >= 0)) {
					snprintf(path, sizeof path, "boundaries.%s.%s.filter.velocity[%d]", axis_names[a], end, a);
					return fail(c, path, "frozen particles move out: the component along the outward normal must be "
					            ">= 0, got %s", num(-sg * f->velocity[a]).s);
				}
				for (int j = 0; j < s->dim; j++)
					if (j != a && !stream_along(s, j, f->velocity[j])) {
						snprintf(path, sizeof path, "boundaries.%s.%s.filter.velocity[%d]", axis_names[a], end, j);
						return fail(c, path, "must be 0 along the walled axis %s (frozen particles would run into its "
						            "walls) unless %s is a stream that way (a dispenser upstream, an open wall "
						            "downstream)", axis_names[j], axis_names[j]);
					}
				/* frozen particles never meet one another: every filter on another axis moves its frozen
				 * particles at the same velocity (filters facing each other on one axis freeze on opposite
				 * sides of the box) */
				for (int b2 = 0; b2 < a; b2++)
					for (int k2 = 0; k2 < 2 && s->boundary[b2].walled; k2++) {
						const scene_wall_t *o = &s->boundary[b2].wall[k2];
						if (o->type != SCENE_WALL_OPEN || !o->filter.on)
							continue;
						for (int j = 0; j < s->dim; j++)
							if (o->filter.velocity[j] != f->velocity[j]) {
								snprintf(path, sizeof path, "boundaries.%s.%s.filter.velocity", axis_names[a], end);
								return fail(c, path, "differs from the filter of boundaries.%s.%s: filters on two axes "
								            "must freeze at one velocity (frozen particles never meet)",
								            axis_names[b2], k2 ? "upper" : "lower");
							}
					}
				/* the plane, and no obstacle beyond it (frozen particles do not meet obstacles) */
				const double plane = k ? s->box[a] - f->distance : f->distance;
				for (int o = 0; o < s->n_obstacles; o++) {
					const scene_obstacle_t *ob = &s->obstacle[o];
					if (sg * (ob->center[a] - plane) - ob->radius - 2 * s->radius < 0) {
						snprintf(path, sizeof path, "obstacles[%d]", o);
						return fail(c, path, "reaches beyond the filter plane of boundaries.%s.%s (obstacles must lie "
						            "upstream of it, one diameter clear)", axis_names[a], end);
					}
				}
			}
		}
	}
	return 0;
}

/* Rules of boundaries and gravity across the scene (after particles,
 * collisions and output are parsed). */
static int check_boundaries(ctx_t *c, json_t *v, scene_t *s)
{
	bool walls = scene_has_walls(s), grav = scene_has_gravity(s);
	char path[PATHLEN];

	bool obst = scene_has_obstacles(s);
	/* dsmc/hsmc: the combinations they cannot honour yet (vibrating or
	 * open walls, contact_value "local") are refused by dsmc_plan(). */
	if (obst && s->method == SCENE_METHOD_AUTO)
		return fail(c, "obstacles", "method \"auto\" does not support obstacles yet (choose \"ed\", \"dsmc\" or "
			    "\"hsmc\")");
	/* dsmc/hsmc: the wall kinds they cannot honour are refused by
	 * dsmc_plan() (scene_check_start()), naming the key. "auto" advises on
	 * bounded scenes too and takes ed there (advice.h: the MC error model
	 * is the periodic gas's), so ed's rules below apply to it as well. */
	bool inelastic = s->restitution < 1, vibrating = false;
	for (int k = 0; k < s->n_obstacles; k++)
		inelastic |= s->obstacle[k].restitution < 1;
	for (int a = 0; a < s->dim; a++) {
		scene_boundary_t *b = &s->boundary[a];
		if (!b->walled)
			continue;
		double room = s->box[a] - 2 * s->radius;
		for (int k = 0; k < 2; k++) {
			scene_wall_t *w = &b->wall[k];
			if (w->coverage >= 0)
				w->restitution = 1 - (1 - s->restitution) * w->coverage;
			inelastic |= w->restitution < 1;
			if (w->type == SCENE_WALL_VIBRATING) {
				vibrating |= w->amplitude > 0;
				room -= 2 * w->amplitude;
			}
		}
		/* the walls' innermost positions must leave room for a particle */
		if (!(room > 0)) {
			snprintf(path, sizeof path, "boundaries.%s", axis_names[a]);
			return fail(c, path, "the walls leave no room for a particle: box edge %s minus one diameter and twice "
			            "the vibration amplitudes is %s", num(s->box[a]).s, num(room).s);
		}
	}
	/* Gravity or a vibrating wall presses particles against a wall: with
	 * any dissipation a bed at rest there would collide infinitely often in
	 * finite time (inelastic collapse). The TC model with its minimum
	 * rebound (docs/engine.md, "Walls and gravity") prevents it. */
	int ret = check_obstacles(c, s);
	if (ret)
		return ret;
	if ((ret = check_reservoirs(c, v, s)))
		return ret;
	if ((ret = check_streams(c, s)))
		return ret;
	for (int a = 0; a < s->dim; a++)
		if (s->flow[a] != 0 && s->method != SCENE_METHOD_ED)
			return fail(c, "particles.initial.velocity", "method \"%s\" does not support a mean flow yet (only \"ed\" "
			            "does)", method_names[s->method]);
	/* (Time-stepped dsmc/hsmc have no collapse: a bounce series under
	 * gravity ends with the particle resting on the wall, dsmc.h.) */
	if ((s->method == SCENE_METHOD_ED || s->method == SCENE_METHOD_AUTO) && (walls || obst) && (grav || vibrating) &&
	    inelastic && s->tc == 0)
		return fail(c, "collisions.tc", "must be > 0 with %s, walls and restitution below 1 (a bed at rest on a wall "
		            "would collapse: infinitely many collisions in finite time%s); set collisions.tc, e.g. 1e-5 of "
		            "the time a particle takes to fall one diameter", grav ? "gravity" : "a vibrating wall",
		            s->method == SCENE_METHOD_AUTO ? "; method \"auto\" takes ed on such a scene" : "");
	/* Observables that need what the scene has. */
	json_t *obs = json_object_get(json_object_get(v, "output"), "observables");
	if (!obs && scene_has_open_walls(s))
		s->observables &= ~(unsigned)SCENE_OBS_PRESSURE;   /* default set: no pressure with outflow (asked for: over the particles present) */
	size_t i;
	json_t *o;
	json_array_foreach(obs, i, o) {
		const char *name = json_string_value(o);
		snprintf(path, sizeof path, "output.observables[%zu]", i);
		/* cluster search, g(r), S(k) and the velocity correlations: minimum image on periodic axes, plain
		 * differences on walled ones; open and reservoir walls: over the particles present at each sample
		 * (run.c, eng_present()); obstacles: g(r)'s ideal-gas pairs count only the region the centres reach
		 * (observe/gofr.h) */
		static const char *const periodic_only[] = { "structure_factor", "velocity_correlations" };
		int periodic_axes = 0;
		for (int a = 0; a < s->dim; a++)
			periodic_axes += !s->boundary[a].walled;
		for (size_t k = 0; k < sizeof periodic_only / sizeof periodic_only[0]; k++)
			if (!periodic_axes && !strcmp(name, periodic_only[k]))
				return fail(c, path, "\"%s\" needs a periodic axis (its wave vectors run along the periodic "
				            "axes only); every axis has walls", name);
		/* unwrapped displacements along periodic axes: a speed bound from the mechanical energy
		 * (engine/observe/msd.h), which must not grow; ed, dsmc and hsmc count the periodic images crossed
		 * instead when something feeds energy or particles enter (scene_msd_images()); walled axes need no
		 * unwrapping. Varying particle sets: over the particles present at the origin and since. */
		if (!strcmp(name, "mean_square_displacement")) {
			const char *feed = scene_energy_feed(s);
			if (feed && s->method != SCENE_METHOD_ED && s->method != SCENE_METHOD_DSMC &&
			    s->method != SCENE_METHOD_HSMC)
				return fail(c, path, "\"mean_square_displacement\" with a periodic axis and %s (it feeds energy: "
				            "no speed bound for following particles across periodic images) needs method "
				            "\"ed\", \"dsmc\" or \"hsmc\", which count the images crossed", feed);
		}
		if (!strcmp(name, "obstacle_force") && !obst)
			return fail(c, path, "\"obstacle_force\" needs obstacles");
		if (!strcmp(name, "outflow") && !scene_has_open_walls(s))
			return fail(c, path, "\"outflow\" needs an \"open\" wall");
		if (!strcmp(name, "wall_force") && !walls)
			return fail(c, path, "\"wall_force\" needs walls (boundaries)");
		if (!strcmp(name, "center_of_mass_height") || !strcmp(name, "potential_energy")) {
			/* md: potential_energy includes the contacts' elastic energy (defined without gravity too) */
			if (!grav && !(s->method == SCENE_METHOD_MD && !strcmp(name, "potential_energy")))
				return fail(c, path, "\"%s\" needs gravity", name);
			for (int a = 0; a < s->dim; a++)
				if (s->gravity[a] != 0 && !s->boundary[a].walled)
					return fail(c, path, "\"%s\" needs gravity along walled axes only: gravity[%d] is %s along "
					            "periodic axis %s, where heights wrap", name, a, num(s->gravity[a]).s,
					            axis_names[a]);
		}
	}
	return 0;
}

static const struct object when_obj = {
	.fields = (const struct field[]){
		{ "time", parse_number, offsetof(scene_when_t, value), &R_POS, false },
		{ "collisions_per_particle", parse_number, offsetof(scene_when_t, value), &R_POS, false },
		{ .name = NULL },
	},
	.check = check_when,
};

/* Checkpoint interval: simulated time or wall-clock seconds. */
static int check_ckpt_when(ctx_t *c, const char *path, json_t *v, void *base)
{
	scene_when_t *w = base;
	bool time = json_object_get(v, "time") != NULL;
	bool wall = json_object_get(v, "wall_seconds") != NULL;
	if (time == wall)
		return fail(c, path, "must have exactly one of time or wall_seconds");
	w->kind = time ? SCENE_CLOCK_TIME : SCENE_CLOCK_WALL;
	return 0;
}

static const struct object ckpt_when_obj = {
	.fields = (const struct field[]){
		{ "time", parse_number, offsetof(scene_when_t, value), &R_POS, false },
		{ "wall_seconds", parse_number, offsetof(scene_when_t, value), &R_POS, false },
		{ .name = NULL },
	},
	.check = check_ckpt_when,
};

static const struct irange R_LEVEL = { 0, 9 };

static int parse_level(ctx_t *c, const char *path, json_t *v, void *dst, const void *arg)
{
	uint64_t x = 0;   /* set when ret == 0; -O3 cannot see it */
	int ret = parse_integer(c, path, v, &x, arg);
	if (ret == 0)
		*(int *)dst = (int)x;
	return ret;
}

static const struct object snapshots_obj = {
	.fields = (const struct field[]){
		{ "every", parse_object, offsetof(scene_t, snapshots), &when_obj, false },
		{ "compression", parse_level, offsetof(scene_t, compression), &R_LEVEL, false },
		{ .name = NULL },
	},
};

static const struct object checkpoint_obj = {
	.fields = (const struct field[]){
		{ "every", parse_object, offsetof(scene_t, checkpoint), &ckpt_when_obj, true },
		{ .name = NULL },
	},
};

static const struct object relax_obj = {
	.fields = (const struct field[]){
		{ "collisions_per_particle", parse_number, offsetof(scene_t, relax_cpp), &R_NONNEG, true },
		{ .name = NULL },
	},
};

/* ---- particles.initial.region and .from (docs/scene.md, "Initial state") */

/* A file name: non-empty, shorter than SCENE_PATH_MAX, no control characters. */
static int parse_path(ctx_t *c, const char *path, json_t *v, void *dst, const void *arg)
{
	if (!json_is_string(v))
		return fail(c, path, "must be a string, got %s", type_name(v));
	const char *p = json_string_value(v);
	size_t n = json_string_length(v);
	if (n == 0 || n >= SCENE_PATH_MAX)
		return fail(c, path, "must be a file name of 1 to %d bytes, got %zu", SCENE_PATH_MAX - 1, n);
	for (size_t i = 0; i < n; i++)
		if ((unsigned char)p[i] < 0x20 || p[i] == 0x7f)
			return fail(c, path, "must not contain control characters");
	memcpy(dst, p, n + 1);
	return 0;
}

static int parse_i64(ctx_t *c, const char *path, json_t *v, void *dst, const void *arg)
{
	uint64_t x = 0;
	int ret = parse_integer(c, path, v, &x, arg);
	if (ret == 0)
		*(int64_t *)dst = (int64_t)x;
	return ret;
}

static const struct irange R_FRAME = { -SEED_MAX, SEED_MAX };
static const struct irange R_JOB = { 1, SEED_MAX };
static const struct irange R_REPLICA = { 0, 999999 };

/* from.replica: a replica index, or "each" (an ensemble continuing an ensemble, replica by replica) */
static int parse_from_replica(ctx_t *c, const char *path, json_t *v, void *dst, const void *arg)
{
	(void)arg;
	if (json_is_string(v)) {
		if (strcmp(json_string_value(v), "each"))
			return fail(c, path, "must be a replica index (0 ... 999999) or \"each\"");
		*(int64_t *)dst = SCENE_FROM_EACH;
		return 0;
	}
	return parse_i64(c, path, v, dst, &R_REPLICA);
}

static int check_from(ctx_t *c, const char *path, json_t *v, void *base)
{
	scene_t *s = base;
	if ((json_object_get(v, "file") != NULL) == (json_object_get(v, "job") != NULL))
		return fail(c, path, "must have exactly one of file (an earlier run's trajectory.h5) or job (a job's "
		            "trajectory, through the daemon)");
	s->has_from = 1;
	return 0;
}

static const struct object from_obj = {
	.fields = (const struct field[]){
		{ "file", parse_path, offsetof(scene_t, from_file), NULL, false },
		{ "job", parse_integer, offsetof(scene_t, from_job), &R_JOB, false },
		{ "frame", parse_i64, offsetof(scene_t, from_frame), &R_FRAME, false },
		{ "replica", parse_from_replica, offsetof(scene_t, from_replica), NULL, false },
		{ .name = NULL },
	},
	.check = check_from,
};

static int check_region(ctx_t *c, const char *path, json_t *v, void *base)
{
	c->s->has_region = 1;
	return 0;
}

static const struct object region_obj = {
	.fields = (const struct field[]){
		{ "lower", parse_vector, offsetof(scene_t, region_lo), NULL, false },
		{ "upper", parse_vector, offsetof(scene_t, region_hi), NULL, false },
		{ .name = NULL },
	},
	.check = check_region,
};

/* A frame brings positions and velocities: what would place or draw them
 * is an error beside it, not silently ignored. */
static int check_initial(ctx_t *c, const char *path, json_t *v, void *base)
{
	static const char *const placing[] = { "positions", "temperature", "velocity", "rotational_temperature",
	                                       "region" };
	char sub[PATHLEN];
	if (!json_object_get(v, "from"))
		return 0;
	for (size_t k = 0; k < sizeof placing / sizeof placing[0]; k++)
		if (json_object_get(v, placing[k])) {
			join(sub, path, placing[k]);
			return fail(c, sub, "not with from (positions, velocities and spins come from the frame)");
		}
	return 0;
}

static const struct object initial_obj = {
	.fields = (const struct field[]){
		{ "positions", parse_positions, offsetof(scene_t, positions), NULL, false },
		{ "temperature", parse_number, offsetof(scene_t, temperature), &R_NONNEG, false },
		{ "velocity", parse_vector, offsetof(scene_t, flow), NULL, false },
		{ "rotational_temperature", parse_number, offsetof(scene_t, rot_temperature), &R_NONNEG, false },
		{ "relax", parse_object, 0, &relax_obj, false },
		{ "region", parse_object, 0, &region_obj, false },
		{ "from", parse_object, 0, &from_obj, false },
		{ .name = NULL },
	},
	.check = check_initial,
};

/* particles.source.position: the D - 1 coordinates across gravity (axis order, gravity's axis left out;
 * which axis that is is known only after gravity: check_source()). */
static int parse_src_position(ctx_t *c, const char *path, json_t *v, void *dst, const void *arg)
{
	double *x = dst;
	const int n = c->s->dim - 1;
	if (!json_is_array(v))
		return fail(c, path, "must be an array, got %s", type_name(v));
	if (json_array_size(v) != (size_t)n)
		return fail(c, path, "must have %d component%s (the coordinates across gravity), got %zu", n, n > 1 ? "s" : "",
		            json_array_size(v));
	for (int i = 0; i < n; i++) {
		char sub[PATHLEN];
		snprintf(sub, sizeof sub, "%s[%d]", path, i);
		int ret = get_number(c, sub, json_array_get(v, i), &R_ANY, &x[i]);
		if (ret)
			return ret;
	}
	return 0;
}

static const struct irange R_SRC_COUNT = { 1, COUNT_MAX };

static const struct object source_obj = {
	.fields = (const struct field[]){
		{ "count", parse_integer, offsetof(scene_t, src_count), &R_SRC_COUNT, true },
		{ "rate", parse_number, offsetof(scene_t, src_rate), &R_POS, true },
		{ "position", parse_src_position, offsetof(scene_t, src_pos_raw), NULL, true },
		{ "spread", parse_number, offsetof(scene_t, src_spread), &R_NONNEG, false },
		{ "height", parse_number, offsetof(scene_t, src_height), &R_POS, true },
		{ "velocity", parse_vector, offsetof(scene_t, src_velocity), NULL, false },
		{ "temperature", parse_number, offsetof(scene_t, src_temperature), &R_NONNEG, false },
		{ .name = NULL },
	},
};

static const struct object particles_obj = {
	.fields = (const struct field[]){
		{ "count", parse_integer, offsetof(scene_t, count), &R_COUNT, false },
		{ "capacity", parse_integer, offsetof(scene_t, capacity), &R_COUNT, false },
		{ "radius", parse_number, offsetof(scene_t, radius), &R_POS, false },
		{ "mass", parse_number, offsetof(scene_t, mass), &R_POS, false },
		{ "species", parse_species, 0, NULL, false },
		{ "volume_fraction", parse_number, offsetof(scene_t, volume_fraction), &R_POS, false },
		{ "box", parse_box, offsetof(scene_t, box), NULL, false },
		{ "initial", parse_object, 0, &initial_obj, false },
		{ "source", parse_object, 0, &source_obj, false },
		{ .name = NULL },
	},
	.check = check_particles,
};

/* collisions.rough: present means rough particles (scene_t.rough). */
static int check_rough(ctx_t *c, const char *path, json_t *v, void *base)
{
	scene_t *s = base;
	s->rough = 1;
	if (json_object_get(v, "friction") == NULL)
		s->rough_mu = -1;
	if (json_object_get(v, "inertia_factor") == NULL)
		s->rough_q = s->dim == 2 ? 0.5 : 0.4;
	return 0;
}

static const struct range R_INERTIA = { 0, 1, true };

static const struct object rough_obj = {
	.fields = (const struct field[]){
		{ "tangential_restitution", parse_number, offsetof(scene_t, rough_beta), &R_SIGNED_UNIT, true },
		{ "friction", parse_number, offsetof(scene_t, rough_mu), &R_NONNEG, false },
		{ "inertia_factor", parse_number, offsetof(scene_t, rough_q), &R_INERTIA, false },
		{ .name = NULL },
	},
	.check = check_rough,
};

static const struct object collisions_obj = {
	.fields = (const struct field[]){
		{ "restitution", parse_number, offsetof(scene_t, restitution), &R_UNIT, false },
		{ "tc", parse_number, offsetof(scene_t, tc), &R_NONNEG, false },
		{ "rough", parse_object, 0, &rough_obj, false },
		{ "restitution_pairs", parse_pairs, 0, NULL, false },
		{ .name = NULL },
	},
};

static const struct object run_obj = {
	.fields = (const struct field[]){
		{ "seed", parse_integer, offsetof(scene_t, seed), &R_SEED, false },
		{ "until", parse_object, offsetof(scene_t, until), &when_obj, true },
		{ "replicas", parse_integer, offsetof(scene_t, replicas), &R_REPLICAS, false },
		{ "balance", parse_balance, offsetof(scene_t, balance), NULL, false },
		{ .name = NULL },
	},
};

static const struct object clusters_obj = {
	.fields = (const struct field[]){
		{ "delta", parse_number, offsetof(scene_t, cluster_delta), &R_POS, false },
		{ .name = NULL },
	},
};

static const struct irange R_BINS = { 2, 100000 };
static const struct range R_VRANGE = { 0, 100, true };

static int parse_bins(ctx_t *c, const char *path, json_t *v, void *dst, const void *arg)
{
	uint64_t x = 0;   /* set when ret == 0 */
	int ret = parse_integer(c, path, v, &x, arg);
	if (ret == 0)
		*(int *)dst = (int)x;
	return ret;
}

/* One edge count for every axis; the range depends on the dimension (check_scene). */
static int parse_grid(ctx_t *c, const char *path, json_t *v, void *dst, const void *arg)
{
	static const struct irange r = { 4, 4096 };
	uint64_t x = 0;
	int ret = parse_integer(c, path, v, &x, &r);
	if (ret == 0) {
		int *g = dst;
		g[0] = g[1] = g[2] = (int)x;
	}
	return ret;
}

static const struct object vdist_obj = {
	.fields = (const struct field[]){
		{ "bins", parse_bins, offsetof(scene_t, vdist_bins), &R_BINS, false },
		{ "range", parse_number, offsetof(scene_t, vdist_range), &R_VRANGE, false },
		{ .name = NULL },
	},
};

static const struct object gofr_obj = {
	.fields = (const struct field[]){
		{ "bins", parse_bins, offsetof(scene_t, gofr_bins), &R_BINS, false },
		{ "range", parse_number, offsetof(scene_t, gofr_range), &R_POS, false },
		{ .name = NULL },
	},
};

static const struct object sofk_obj = {
	.fields = (const struct field[]){
		{ "grid", parse_grid, offsetof(scene_t, sofk_grid), NULL, false },
		{ .name = NULL },
	},
};

static const struct object impact_obj = {
	.fields = (const struct field[]){
		{ "bins", parse_bins, offsetof(scene_t, impact_bins), &R_BINS, false },
		{ .name = NULL },
	},
};

/* output.fields.cells: one count for every axis, or an array of one per axis (checked against the dimension
 * and the total in check_fields). */
static int parse_field_cells(ctx_t *c, const char *path, json_t *v, void *dst, const void *arg)
{
	static const struct irange r = { 1, FIELDS_MAX_CELLS };
	int *g = dst;
	uint64_t x = 0;
	if (!json_is_array(v)) {
		if (!json_is_number(v))
			return fail(c, path, "must be a positive integer or an array of one per axis, got %s", type_name(v));
		int ret = parse_integer(c, path, v, &x, &r);
		if (ret == 0)
			g[0] = g[1] = g[2] = (int)x;
		return ret;
	}
	size_t n = json_array_size(v), i;
	json_t *o;
	if (n < 2 || n > 3)
		return fail(c, path, "must have one positive integer per axis (2 or 3), got %zu", n);
	json_array_foreach(v, i, o) {
		char sub[PATHLEN];
		snprintf(sub, sizeof sub, "%s[%zu]", path, i);
		int ret = parse_integer(c, sub, o, &x, &r);
		if (ret)
			return ret;
		g[i] = (int)x;
	}
	g[2] = n == 3 ? g[2] : -1;   /* -1: not given (a 2D scene needs 2) */
	return 0;
}

static const struct range R_FIELD_EXPOSURE = { 0, INFINITY, true };
static const struct irange R_FIELD_SAMPLES = { 1, 10000 };

static const struct object fields_obj = {
	.fields = (const struct field[]){
		{ "cells", parse_field_cells, offsetof(scene_t, fields_cells), NULL, true },
		{ "exposure", parse_number, offsetof(scene_t, fields_exposure), &R_FIELD_EXPOSURE, false },
		{ "samples", parse_bins, offsetof(scene_t, fields_samples), &R_FIELD_SAMPLES, false },
		{ .name = NULL },
	},
};

/* output.density_spectrum.axis: "x", "y" or "z" (within the dimension: check_pipe). */
static int parse_dspec_axis(ctx_t *c, const char *path, json_t *v, void *dst, const void *arg)
{
	int i, ret = match(c, path, v, axis_names, 3, &i);
	if (ret == 0)
		*(int *)dst = i;
	return ret;
}

/* output.density_spectrum.fit: [f_min, f_max], 0 <= f_min < f_max. */
static int parse_dspec_fit(ctx_t *c, const char *path, json_t *v, void *dst, const void *arg)
{
	static const struct range r = { 0, INFINITY, false };
	double *f = dst;
	if (!json_is_array(v) || json_array_size(v) != 2)
		return fail(c, path, "must be an array [f_min, f_max] of two frequencies, got %s", describe(v).s);
	for (size_t i = 0; i < 2; i++) {
		char sub[PATHLEN];
		snprintf(sub, sizeof sub, "%s[%zu]", path, i);
		int ret = get_number(c, sub, json_array_get(v, i), &r, &f[i]);
		if (ret)
			return ret;
	}
	if (!(f[0] < f[1]))
		return fail(c, path, "f_min must be below f_max, got [%s, %s]", num(f[0]).s, num(f[1]).s);
	return 0;
}

static const struct irange R_DSPEC_SLICES = { 2, 100000 };
static const struct range R_DSPEC_INTERVAL = { 0, INFINITY, true };

static const struct object dspec_obj = {
	.fields = (const struct field[]){
		{ "slices", parse_bins, offsetof(scene_t, dspec_slices), &R_DSPEC_SLICES, false },
		{ "axis", parse_dspec_axis, offsetof(scene_t, dspec_axis), NULL, false },
		{ "interval", parse_number, offsetof(scene_t, dspec_interval), &R_DSPEC_INTERVAL, true },
		{ "fit", parse_dspec_fit, offsetof(scene_t, dspec_fit), NULL, false },
		{ .name = NULL },
	},
};

static const struct object surface_obj = {
	.fields = (const struct field[]){
		{ "bins", parse_bins, offsetof(scene_t, surf_bins), &R_BINS, false },
		{ "axis", parse_dspec_axis, offsetof(scene_t, surf_axis), NULL, false },
		{ .name = NULL },
	},
};

static const struct object output_obj = {
	.fields = (const struct field[]){
		{ "every", parse_object, offsetof(scene_t, every), &when_obj, false },
		{ "observables", parse_observables, offsetof(scene_t, observables), NULL, false },
		{ "clusters", parse_object, 0, &clusters_obj, false },
		{ "velocity_distribution", parse_object, 0, &vdist_obj, false },
		{ "pair_correlation", parse_object, 0, &gofr_obj, false },
		{ "structure_factor", parse_object, 0, &sofk_obj, false },
		{ "impact_parameter", parse_object, 0, &impact_obj, false },
		{ "fields", parse_object, 0, &fields_obj, false },
		{ "density_spectrum", parse_object, 0, &dspec_obj, false },
		{ "surface_profile", parse_object, 0, &surface_obj, false },
		{ "snapshots", parse_object, 0, &snapshots_obj, false },
		{ "checkpoint", parse_object, 0, &checkpoint_obj, false },
		{ .name = NULL },
	},
};

static const struct range R_ACCURACY = { 0, 1, true };

static const struct object accuracy_obj = {
	.fields = (const struct field[]){
		{ "temperature", parse_number, offsetof(scene_t, accuracy_temperature), &R_ACCURACY, true },
		{ .name = NULL },
	},
};

static int parse_drive_type(ctx_t *c, const char *path, json_t *v, void *dst, const void *arg)
{
	int i, ret = match(c, path, v, drive_names + 1, 2, &i);
	if (ret == 0)
		*(scene_drive_t *)dst = (scene_drive_t)(i + 1);
	return ret;
}

/* One bin count for every axis of the local mean. */
static int parse_drive_grid(ctx_t *c, const char *path, json_t *v, void *dst, const void *arg)
{
	static const struct irange r = { 1, 4096 };
	uint64_t x = 0;
	int ret = parse_integer(c, path, v, &x, &r);
	if (ret == 0) {
		int *g = dst;
		g[0] = g[1] = g[2] = (int)x;
	}
	return ret;
}

/* Keys of each driving type: the others are mistakes. */
static int check_driving(ctx_t *c, const char *path, json_t *v, void *base)
{
	scene_t *s = base;
	static const struct { const char *key; scene_drive_t type; bool required; } keys[] = {
		{ "temperature", SCENE_DRIVE_STOCHASTIC, true }, { "grid", SCENE_DRIVE_STOCHASTIC, false },
		{ "average_time", SCENE_DRIVE_STOCHASTIC, false }, { "strength", SCENE_DRIVE_WHITE_NOISE, true },
	};
	char sub[PATHLEN];
	for (size_t k = 0; k < sizeof keys / sizeof keys[0]; k++) {
		bool has = json_object_get(v, keys[k].key) != NULL;
		join(sub, path, keys[k].key);
		if (has && keys[k].type != s->drive)
			return fail(c, sub, "not a key of a \"%s\" thermostat", drive_names[s->drive]);
		if (!has && keys[k].required && keys[k].type == s->drive)
			return fail(c, sub, "required for a \"%s\" thermostat", drive_names[s->drive]);
	}
	if (s->drive_average_time == 0)
		s->drive_average_time = 10 * s->drive_interval;
	if (s->drive_grid[0] == 0)
		s->drive_grid[0] = s->drive_grid[1] = s->drive_grid[2] = 1;
	for (int a = s->dim; a < 3; a++)
		s->drive_grid[a] = 1;
	if ((double)s->drive_grid[0] * s->drive_grid[1] * s->drive_grid[2] > 1e6)
		return fail(c, "driving.grid", "%d bins per axis make more than 10^6 bins in %dD", s->drive_grid[0], s->dim);
	if (s->method != SCENE_METHOD_ED)
		return fail(c, path, "method \"%s\" does not support driving (only \"ed\" does)", method_names[s->method]);
	/* kicks go to particles drawn from all N: one that left cannot be kicked back in */
	if (scene_has_open_walls(s))
		return fail(c, path, "not available with an \"open\" wall (particles leave the system)");
	return 0;
}

static const struct object driving_obj = {
	.fields = (const struct field[]){
		{ "type", parse_drive_type, offsetof(scene_t, drive), NULL, true },
		{ "interval", parse_number, offsetof(scene_t, drive_interval), &R_POS, true },
		{ "temperature", parse_number, offsetof(scene_t, drive_temperature), &R_POS, false },
		{ "strength", parse_number, offsetof(scene_t, drive_strength), &R_POS, false },
		{ "grid", parse_drive_grid, offsetof(scene_t, drive_grid), NULL, false },
		{ "average_time", parse_number, offsetof(scene_t, drive_average_time), &R_POS, false },
		{ .name = NULL },
	},
	.check = check_driving,
};

static const struct object ed_obj = {
	.fields = (const struct field[]){
		{ "cell_size", parse_cell_size, offsetof(scene_t, ed_cell_size), NULL, false },
		{ .name = NULL },
	},
};

/* impact_c: [[tau, c], ...], tau >= 0 increasing, c in [-100, 0.99] (c < 1 keeps P(b) finite at b = 1). */
static int parse_impact(ctx_t *c, const char *path, json_t *v, void *dst, const void *arg)
{
	scene_t *s = c->s;
	size_t n = json_is_array(v) ? json_array_size(v) : 0;
	static const struct range R_C = { -100, 0.99, false };
	if (!json_is_array(v) || n < 1 || n > SCENE_IMPACT_MAX)
		return fail(c, path, "must be an array of 1 to %d [collisions_per_particle, c] pairs, got %s", SCENE_IMPACT_MAX,
			    json_is_array(v) ? "an empty array or too many" : type_name(v));
	for (size_t k = 0; k < n; k++) {
		char sub[PATHLEN];
		json_t *p = json_array_get(v, k);
		snprintf(sub, sizeof sub, "%s[%zu]", path, k);
		if (!json_is_array(p) || json_array_size(p) != 2)
			return fail(c, sub, "must be a pair [collisions_per_particle, c], got %s", type_name(p));
		snprintf(sub, sizeof sub, "%s[%zu][0]", path, k);
		int ret = get_number(c, sub, json_array_get(p, 0), &R_NONNEG, &s->mc_impact_tau[k]);
		if (ret)
			return ret;
		if (k > 0 && !(s->mc_impact_tau[k] > s->mc_impact_tau[k - 1]))
			return fail(c, sub, "the collisions per particle must increase (%s after %s)", num(s->mc_impact_tau[k]).s,
				    num(s->mc_impact_tau[k - 1]).s);
		snprintf(sub, sizeof sub, "%s[%zu][1]", path, k);
		if ((ret = get_number(c, sub, json_array_get(p, 1), &R_C, &s->mc_impact_c[k])) != 0)
			return ret;
	}
	s->mc_impact_n = (int)n;
	(void)dst, (void)arg;
	return 0;
}

static int check_mc(ctx_t *c, const char *path, json_t *v, void *base)
{
	scene_t *s = base;
	if (json_object_get(v, "time_step") && json_object_get(v, "collisions_per_step"))
		return fail(c, path, "at most one of time_step or collisions_per_step");
	if (s->mc_impact_n > 0 && (scene_has_walls(s) || scene_has_gravity(s) || scene_has_obstacles(s) ||
	                           scene_has_species(s))) {
		char sub[PATHLEN];
		snprintf(sub, sizeof sub, "%s.impact_c", path);
		return fail(c, sub, "only in a periodic box of one species without gravity or obstacles (not yet with %s)",
			    scene_has_species(s) ? "particles.species" : scene_has_obstacles(s) ? "obstacles" :
			    scene_has_gravity(s) ? "gravity" : "walls");
	}
	/* the excluded-volume options live in the bounded step (move_bounded()) */
	if (!scene_has_walls(s) && !scene_has_gravity(s)) {
		static const char *const key[] = { "entry", "rejected_moves" };
		const int set[] = { s->mc_entry, s->mc_reject };
		for (int k = 0; k < 2; k++)
			if (set[k] && json_object_get(v, key[k])) {
				char sub[PATHLEN];
				snprintf(sub, sizeof sub, "%s.%s", path, key[k]);
				return fail(c, sub, "only with walls or gravity (the periodic box's step has the default rule)");
			}
	}
	return 0;
}

#define MC_FIELDS \
	{ "cell_size", parse_number, offsetof(scene_t, mc_cell_size), &R_POS, false }, \
	{ "time_step", parse_number, offsetof(scene_t, mc_time_step), &R_POS, false }, \
	{ "collisions_per_step", parse_number, offsetof(scene_t, mc_collisions_per_step), &R_POS, false }, \
	{ "correction", parse_correction, offsetof(scene_t, mc_correction), NULL, false }, \
	{ "contact_value", parse_two, offsetof(scene_t, mc_local_chi), contact_names, false }, \
	{ "impact_c", parse_impact, 0, NULL, false }

static const struct object dsmc_obj = {
	.fields = (const struct field[]){
		MC_FIELDS,
		{ .name = NULL },
	},
	.check = check_mc,
};

static const struct object hsmc_obj = {
	.fields = (const struct field[]){
		MC_FIELDS,
		{ "max_volume_fraction", parse_number, offsetof(scene_t, mc_max_volume_fraction), &R_POS, false },
		{ "cell_partners", parse_two, offsetof(scene_t, mc_cell_any), partner_names, false },
		{ "entry", parse_two, offsetof(scene_t, mc_entry), entry_names, false },
		{ "rejected_moves", parse_two, offsetof(scene_t, mc_reject), rejected_names, false },
		{ .name = NULL },
	},
	.check = check_mc,
};

/* Table order is parse order: dimensions before particles (box length). */
static const struct object scene_obj = {
	.fields = (const struct field[]){
		{ "version", parse_version, 0, NULL, false },
		{ "method", parse_method, offsetof(scene_t, method), NULL, true },
		{ "dimensions", parse_dimensions, offsetof(scene_t, dim), NULL, true },
		{ "particles", parse_object, 0, &particles_obj, true },
		{ "collisions", parse_object, 0, &collisions_obj, false },
		{ "boundaries", parse_object, 0, &boundaries_obj, false },
		{ "gravity", parse_vector, offsetof(scene_t, gravity), NULL, false },
		{ "obstacles", parse_obstacles, 0, NULL, false },
		{ "driving", parse_object, 0, &driving_obj, false },
		{ "run", parse_object, 0, &run_obj, true },
		{ "output", parse_object, 0, &output_obj, false },
		{ "ed", parse_object, 0, &ed_obj, false },
		{ "dsmc", parse_object, 0, &dsmc_obj, false },
		{ "hsmc", parse_object, 0, &hsmc_obj, false },
		{ "md", parse_object, 0, &md_obj, false },
		{ "accuracy", parse_object, 0, &accuracy_obj, false },
		{ .name = NULL },
	},
	.check = check_scene,
};

int scene_parse(const char *json, size_t len, scene_t *out, char *err, size_t errlen)
{
	scene_t s = {
		.radius = 0.5,
		.mass = 1,
		.temperature = 1,
		.restitution = 1,
		.seed = 1,
		.observables = SCENE_OBS_ENERGY | SCENE_OBS_PRESSURE | SCENE_OBS_COLLISION_RATE,
		.cluster_delta = 0.1,
		.vdist_bins = 80,
		.vdist_range = 5,
		.gofr_bins = 250,
		.impact_bins = 20,
		.replicas = 1,
		.compression = 0,
		.region_hi = { NAN, NAN, NAN },
		.from_frame = -1,
		.from_replica = -1,
	};
	for (int a = 0; a < 3; a++)
		for (int k = 0; k < 2; k++)
			s.boundary[a].wall[k] = (scene_wall_t){ .restitution = 1, .accommodation = 1,
			                                        .tangential_restitution = 1, .coverage = -1 };
	for (int a = 0; a < SCENE_SPECIES_MAX; a++)
		for (int b = 0; b < SCENE_SPECIES_MAX; b++)
			s.restitution_pair[a][b] = NAN;
	ctx_t c = { &s, err, errlen };
	json_error_t jerr;

	if (err && errlen)
		err[0] = '\0';
	json_t *root = json_loadb(json ? json : "", json ? len : 0, JSON_REJECT_DUPLICATES, &jerr);
	if (root == NULL) {
		if (json_error_code(&jerr) == json_error_out_of_memory) {
			fail(&c, "(root)", "out of memory");
			return SCENE_ENOMEM;
		}
		fail(&c, "(root)", "not valid JSON at line %d column %d: %s", jerr.line, jerr.column, jerr.text);
		return SCENE_EJSON;
	}
	int ret;
	if (!json_is_object(root)) {
		fail(&c, "(root)", "must be a JSON object, got %s", type_name(root));
		ret = SCENE_EJSON;
	} else {
		ret = walk(&c, "", root, &s, &scene_obj);
	}
	json_decref(root);
	/* *out is left alone on error so that a caller's old scene survives. */
	if (ret == 0 && out)
		*out = s;
	return ret;
}

double scene_close_packing(int dim)
{
	return dim == 2 ? PI / (2 * sqrt(3.0)) : dim == 3 ? PI / (3 * sqrt(2.0)) : 0;
}

int scene_has_walls(const scene_t *s)
{
	for (int a = 0; a < s->dim && a < 3; a++)
		if (s->boundary[a].walled)
			return 1;
	return 0;
}

int scene_has_obstacles(const scene_t *s)
{
	return s->n_obstacles > 0;
}

const char *scene_energy_feed(const scene_t *s)
{
	static const char *const feeds[] = { [SCENE_WALL_THERMAL] = "a thermal wall", [SCENE_WALL_MOVING] = "a moving wall",
	                                     [SCENE_WALL_VIBRATING] = "a vibrating wall" };
	int per = 0;
	for (int a = 0; a < s->dim; a++)
		per += !s->boundary[a].walled;
	if (!per)
		return NULL;
	for (int a = 0; a < s->dim; a++) {
		if (s->gravity[a] != 0 && !s->boundary[a].walled)
			return "gravity along a periodic axis";
		for (int k = 0; k < 2 && s->boundary[a].walled; k++) {
			scene_wall_type_t t = s->boundary[a].wall[k].type;
			if ((size_t)t < sizeof feeds / sizeof feeds[0] && feeds[t])
				return feeds[t];
		}
	}
	for (int k = 0; k < s->n_obstacles; k++)
		if (s->obstacle[k].type == SCENE_OBST_NO_SLIP)
			return "a no_slip obstacle";
	if (s->drive != SCENE_DRIVE_NONE)
		return "driving";
	return NULL;
}

int scene_msd_images(const scene_t *s)
{
	if (!(s->observables & SCENE_OBS_MSD))
		return 0;
	if (s->method == SCENE_METHOD_ED)
		return scene_energy_feed(s) != NULL || scene_has_open_walls(s);
	if (s->method == SCENE_METHOD_DSMC || s->method == SCENE_METHOD_HSMC)   /* open walls alone: the bound */
		return scene_energy_feed(s) != NULL || s->src_count > 0;
	return 0;
}

int scene_has_open_walls(const scene_t *s)
{
	for (int a = 0; a < s->dim && a < 3; a++)
		for (int k = 0; k < 2; k++)
			if (s->boundary[a].walled && (s->boundary[a].wall[k].type == SCENE_WALL_OPEN ||
			                              s->boundary[a].wall[k].type == SCENE_WALL_RESERVOIR ||
			                              s->boundary[a].wall[k].type == SCENE_WALL_DISPENSER))
				return 1;
	return s->src_count > 0;   /* a source: particles enter */
}

int scene_has_reservoir(const scene_t *s)
{
	for (int a = 0; a < s->dim && a < 3; a++)
		for (int k = 0; k < 2; k++)
			if (s->boundary[a].walled && (s->boundary[a].wall[k].type == SCENE_WALL_RESERVOIR ||
			                              s->boundary[a].wall[k].type == SCENE_WALL_DISPENSER))
				return 1;
	return 0;
}

int scene_has_dispenser(const scene_t *s)
{
	for (int a = 0; a < s->dim && a < 3; a++)
		for (int k = 0; k < 2; k++)
			if (s->boundary[a].walled && s->boundary[a].wall[k].type == SCENE_WALL_DISPENSER)
				return 1;
	return 0;
}

int scene_has_filter(const scene_t *s)
{
	for (int a = 0; a < s->dim && a < 3; a++)
		for (int k = 0; k < 2; k++)
			if (s->boundary[a].walled && s->boundary[a].wall[k].type == SCENE_WALL_OPEN &&
			    s->boundary[a].wall[k].filter.on)
				return 1;
	return 0;
}

uint64_t scene_slots(const scene_t *s)
{
	if (s->src_count > 0)
		return s->count + s->src_count;   /* row = id: the initial particles, then the source's in order */
	return scene_has_reservoir(s) && s->capacity > s->count ? s->capacity : s->count;
}

int scene_has_gravity(const scene_t *s)
{
	for (int a = 0; a < s->dim && a < 3; a++)
		if (s->gravity[a] != 0)
			return 1;
	return 0;
}

double scene_box_volume(const scene_t *s)
{
	return s->box[0] * s->box[1] * (s->dim == 3 ? s->box[2] : 1);
}

int scene_has_species(const scene_t *s)
{
	for (int k = 0; k < s->n_species; k++)
		if (s->species[k].radius_hi > 0)
			return 1;
	return s->n_species > 1;
}

void scene_species_radii(const scene_t *s, double *r)
{
	rng_t rng;
	rng_init(&rng, s->seed, s->stream | (1ull << 60));
	uint64_t i = 0;
	for (int k = 0; k < s->n_species; k++) {
		const scene_species_t *q = &s->species[k];
		for (uint64_t j = 0; j < q->count; j++, i++)
			r[i] = q->radius_hi > 0 ? q->radius_lo + (q->radius_hi - q->radius_lo) * rng_uniform(&rng) : q->radius;
	}
}

static double species_volume(int dim, const scene_species_t *q);

void scene_dispenser_fractions(const scene_t *s, const scene_wall_t *w, double *x)
{
	for (int k = 0; k < s->n_species; k++)
		x[k] = w->n_composition ? w->composition[k] : (double)s->species[k].count / (double)s->count;
}

double scene_dispenser_volume(const scene_t *s, const scene_wall_t *w)
{
	if (!w->n_composition)
		return scene_particle_volume(s);
	double v = 0.0;
	for (int k = 0; k < s->n_species; k++)
		v += w->composition[k] * species_volume(s->dim, &s->species[k]);
	return v;
}

/* The fractions in which the empty slots are split among the species: the
 * scene's (NULL: exact integer split) unless a dispenser or a reservoir has
 * a composition. Dispensers only: the dispensers' mean weighted by their
 * particle rates (eta U_n A / v_p: what enters per unit time). With a
 * reservoir's composition: the mean over the dispensers and reservoirs
 * weighted by their number densities eta / v_p (what the box holds of each
 * species when it is filled from that wall). */
static int spare_fractions(const scene_t *s, double *y)
{
	int any = 0, res = 0;
	for (int a = 0; a < s->dim; a++)
		for (int e = 0; e < 2; e++) {
			const scene_wall_t *w = &s->boundary[a].wall[e];
			const int in = s->boundary[a].walled && w->n_composition > 0;
			any |= in && (w->type == SCENE_WALL_DISPENSER || w->type == SCENE_WALL_RESERVOIR);
			res |= in && w->type == SCENE_WALL_RESERVOIR;
		}
	if (!any)
		return 0;
	double tot = 0.0, x[SCENE_SPECIES_MAX];
	for (int k = 0; k < s->n_species; k++)
		y[k] = 0.0;
	for (int a = 0; a < s->dim; a++)
		for (int e = 0; e < 2; e++) {
			const scene_wall_t *w = &s->boundary[a].wall[e];
			if (!s->boundary[a].walled || (w->type != SCENE_WALL_DISPENSER && (!res || w->type != SCENE_WALL_RESERVOIR)))
				continue;
			double area = 1.0;
			for (int b = 0; b < s->dim; b++)
				if (b != a)
					area *= s->box[b];
			const double rate = res ? w->volume_fraction / scene_dispenser_volume(s, w)
			                        : w->volume_fraction * fabs(w->velocity[a]) * area / scene_dispenser_volume(s, w);
			scene_dispenser_fractions(s, w, x);
			for (int k = 0; k < s->n_species; k++) {
				y[k] += rate * x[k];
				tot += rate * x[k];
			}
		}
	if (!(tot > 0.0))
		return 0;   /* no piston moves: the scene's fractions */
	for (int k = 0; k < s->n_species; k++)
		y[k] /= tot;
	return 1;
}

void scene_row_species(const scene_t *s, uint8_t *sp, double *r)
{
	const uint64_t n = s->count, slots = scene_slots(s), spare = slots - n;
	if (r)
		scene_species_radii(s, r);
	uint64_t i = 0, c = 0;
	for (int k = 0; k < s->n_species; k++)
		for (uint64_t j = 0; j < s->species[k].count; j++, i++)
			if (sp)
				sp[i] = (uint8_t)k;
	double y[SCENE_SPECIES_MAX], Y = 0.0;
	const int comp = s->n_species > 0 && spare_fractions(s, y);
	uint64_t prev = 0;
	rng_t rng;   /* the empty rows of a polydisperse species: radii of a stream of their own */
	rng_init(&rng, s->seed, s->stream | (1ull << 60) | (1ull << 57));
	for (int k = 0; k < s->n_species; k++) {
		uint64_t lo = spare * c / n;
		c += s->species[k].count;
		uint64_t hi = spare * c / n;
		if (comp) {   /* the dispensers' composition: block k ends at floor(spare Y_k) */
			Y += y[k];
			const double e = floor((double)spare * Y);
			lo = prev;
			hi = k == s->n_species - 1 || e >= (double)spare ? spare : (uint64_t)e;
			if (hi < lo)
				hi = lo;
			prev = hi;
		}
		for (uint64_t j = lo; j < hi; j++, i++) {
			if (sp)
				sp[i] = (uint8_t)k;
			if (r)
				r[i] = s->species[k].radius_hi > 0 ? s->species[k].radius_lo + (s->species[k].radius_hi -
				       s->species[k].radius_lo) * rng_uniform(&rng) : s->species[k].radius;
		}
	}
}

static double ball_volume(int dim, double r)
{
	return dim == 3 ? 4.0 / 3.0 * PI * r * r * r : PI * r * r;
}

/* Mean particle volume of a species: of its radius, or the expectation over
 * radii uniform in [lo, hi]: E[r^D] = (hi^(D+1) - lo^(D+1)) / ((D+1)(hi - lo)). */
static double species_volume(int dim, const scene_species_t *q)
{
	if (!(q->radius_hi > 0))
		return ball_volume(dim, q->radius);
	const double lo = q->radius_lo, hi = q->radius_hi;
	const double erd = (pow(hi, dim + 1) - pow(lo, dim + 1)) / ((dim + 1) * (hi - lo));
	return ball_volume(dim, 1.0) * erd;
}

double scene_particle_volume(const scene_t *s)
{
	if (s->n_species == 0)
		return ball_volume(s->dim, s->radius);
	double v = 0.0;
	for (int k = 0; k < s->n_species; k++)
		v += (double)s->species[k].count * species_volume(s->dim, &s->species[k]);
	return v / (double)s->count;
}

const char *scene_strerror(int code)
{
	switch (code) {
	case SCENE_OK: return "success";
	case SCENE_EJSON: return "not a JSON object";
	case SCENE_EINVAL: return "invalid scene";
	case SCENE_ENOMEM: return "out of memory";
	default: return "unknown error";
	}
}

const char *scene_method_name(scene_method_t m)
{
	return (unsigned)m < sizeof method_names / sizeof method_names[0] ? method_names[m] : "unknown";
}
