/* Initial placement in a region of the box (lattice or random sequential addition) and the checks of a given initial state. */
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "place.h"
#include "lattice.h"
#include "rng.h"

static const char *const axis_names[] = { "x", "y", "z" };

/* The centres' range along one axis: [lo, hi] (bounded), or [0, hi) with
 * wrap-around (periodic: the region spans a periodic axis whole). */
typedef struct {
	double lo, hi;
	int periodic;
} span_t;

static int fail(char *msg, size_t msglen, int code, const char *fmt, ...)
{
	if (msg && msglen) {
		va_list ap;
		va_start(ap, fmt);
		vsnprintf(msg, msglen, fmt, ap);
		va_end(ap);
	}
	return code;
}

/* Displacement of a wall along its inward normal at time 0 (vibrating walls). */
static double wall_offset(const scene_wall_t *w)
{
	return w->type == SCENE_WALL_VIBRATING ? w->amplitude * sin(w->phase) : 0.0;
}

static double wall_amplitude(const scene_wall_t *w)
{
	return w->type == SCENE_WALL_VIBRATING ? w->amplitude : 0.0;
}

/* Centre ranges of the region of s (the box without one), or PLACE_EINVAL naming the key. */
static int spans_r(const scene_t *s, double r, span_t sp[3], char *msg, size_t msglen)
{
	for (int a = 0; a < 3; a++)
		sp[a] = (span_t){ 0.0, 1.0, 1 };
	for (int a = 0; a < s->dim; a++) {
		const double L = s->box[a];
		const scene_boundary_t *b = &s->boundary[a];
		double lo = s->has_region ? s->region_lo[a] : 0.0, hi = s->has_region ? s->region_hi[a] : L;
		if (!(lo >= 0.0 && lo < L))
			return fail(msg, msglen, PLACE_EINVAL, "particles.initial.region.lower[%d]: %.15g is outside the box "
			            "[0, %.15g) along %s", a, lo, L, axis_names[a]);
		if (!(hi > lo && hi <= L))
			return fail(msg, msglen, PLACE_EINVAL, "particles.initial.region.upper[%d]: %.15g must be above "
			            "lower[%d] (%.15g) and at most the box edge %.15g along %s", a, hi, a, lo, L, axis_names[a]);
		if (!b->walled && lo == 0.0 && hi == L) {
			sp[a] = (span_t){ 0.0, L, 1 };
			continue;
		}
		sp[a] = (span_t){ lo + r, hi - r, 0 };
		if (b->walled) {
			/* out of the walls' reach, as the engines place */
			sp[a].lo = fmax(sp[a].lo, wall_amplitude(&b->wall[0]) + r);
			sp[a].hi = fmin(sp[a].hi, L - wall_amplitude(&b->wall[1]) - r);
		}
		if (sp[a].hi < sp[a].lo)
			return fail(msg, msglen, PLACE_EINVAL, "particles.initial.region: no room for a particle of diameter "
			            "%.6g along %s between %.15g and %.15g%s", 2 * r, axis_names[a], lo, hi,
			            b->walled ? " (out of the walls' reach)" : "");
	}
	return PLACE_OK;
}

/* The centre ranges for the scene's radius (mixtures: the largest, so
 * every particle fits). */
static int spans(const scene_t *s, span_t sp[3], char *msg, size_t msglen)
{
	return spans_r(s, s->radius, sp, msg, msglen);
}

/* A mixture's radii in scene order (scene_species_radii(): the engine's
 * own draws), or NULL with *err = 0 for one species (every radius
 * s->radius); NULL with *err = PLACE_ENOMEM when out of memory. */
static double *radii_of(const scene_t *s, int *err)
{
	*err = PLACE_OK;
	if (!scene_has_species(s))
		return NULL;
	double *r = malloc((size_t)s->count * sizeof(double));
	if (!r)
		*err = PLACE_ENOMEM;
	else
		scene_species_radii(s, r);
	return r;
}

/* Edge of the lattice's periodic cell along each axis: the box on periodic
 * spans; the centre range on bounded ones (the lattice fills it as if
 * periodic, as the ed engine does between walls: at most one layer lost). */
static void lattice_edges(const scene_t *s, const span_t *sp, double *Lp)
{
	for (int a = 0; a < 3; a++)
		Lp[a] = a < s->dim ? sp[a].hi - sp[a].lo : 1.0;
}

static double particle_volume(const scene_t *s)
{
	return scene_particle_volume(s);
}

/* Random sequential addition jams at 0.547 (disks) and 0.384 (spheres)
 * (Torquato, Random Heterogeneous Materials, sec. 3.4; as engine/ed/ed.c). */
static double rsa_jamming(int dim) { return dim == 2 ? 0.547 : 0.384; }

/* The obstacle whose excluded zone (centre distance below its radius plus
 * the particle radius, less tol) holds centre x, or -1. Minimum image on
 * periodic axes. */
static int in_obstacle_r(const scene_t *s, const double *x, double r, double tol)
{
	for (int k = 0; k < s->n_obstacles; k++) {
		const scene_obstacle_t *o = &s->obstacle[k];
		double r2 = 0.0, reach = o->radius + r - tol;
		for (int a = 0; a < s->dim; a++) {
			double d = x[a] - o->center[a];
			if (!s->boundary[a].walled)
				d -= s->box[a] * nearbyint(d / s->box[a]);
			r2 += d * d;
		}
		if (r2 < reach * reach)
			return k;
	}
	return -1;
}

static int in_obstacle(const scene_t *s, const double *x, double tol)
{
	return in_obstacle_r(s, x, s->radius, tol);
}

/* A lattice of the region: its shape, and site j's centre. */
typedef struct {
	int dim;
	int64_t n[3];      /* 2D: columns, rows; 3D: FCC cells per axis */
	double a[3];       /* spacing */
	double lo[3];
	uint64_t sites;
	double nearest;    /* nearest-neighbour distance */
} lat_t;

static void lat_shape(lat_t *l, const scene_t *s, const span_t *sp, uint64_t want)
{
	double Lp[3];
	lattice_edges(s, sp, Lp);
	l->dim = s->dim;
	l->n[0] = l->n[1] = l->n[2] = 1;
	if (s->dim == 2) {
		l->nearest = lattice_shape_2d(Lp, want, &l->n[0], &l->n[1]);
		l->sites = (uint64_t)(l->n[0] * l->n[1]);
	} else {
		l->nearest = lattice_shape_3d(Lp, want, l->n);
		l->sites = (uint64_t)(4 * l->n[0] * l->n[1] * l->n[2]);
	}
	for (int a = 0; a < 3; a++) {
		l->a[a] = Lp[a] / l->n[a];
		l->lo[a] = sp[a].lo;
	}
}

static void lat_site(const lat_t *l, uint64_t j, double *x)
{
	if (l->dim == 2) {
		int64_t ix = (int64_t)j % l->n[0], iy = (int64_t)j / l->n[0];
		x[0] = l->lo[0] + (ix + 0.25 + 0.5 * (iy & 1)) * l->a[0];
		x[1] = l->lo[1] + (iy + 0.5) * l->a[1];
	} else {
		static const double site[4][3] = { { 0, 0, 0 }, { .5, .5, 0 }, { .5, 0, .5 }, { 0, .5, .5 } };
		int64_t c = (int64_t)j / 4, k = (int64_t)j % 4;
		int64_t ix = c % l->n[0], iy = (c / l->n[0]) % l->n[1], iz = c / (l->n[0] * l->n[1]);
		x[0] = l->lo[0] + (ix + site[k][0] + 0.25) * l->a[0];
		x[1] = l->lo[1] + (iy + site[k][1] + 0.25) * l->a[1];
		x[2] = l->lo[2] + (iz + site[k][2] + 0.25) * l->a[2];
	}
}

static uint64_t lat_free(const lat_t *l, const scene_t *s);

/* The lattice for N particles: N sites, or with obstacles the smallest
 * lattice (in steps of the sites they block) with N sites clear of them,
 * as long as its nearest distance stays at least a diameter. */
static void lat_init(lat_t *l, const scene_t *s, const span_t *sp)
{
	uint64_t want = s->count;
	for (int round = 0; round < 64; round++) {
		lat_shape(l, s, sp, want);
		if (!s->n_obstacles || l->nearest < 2.0 * s->radius * (1.0 - 1e-12))
			return;
		uint64_t nfree = lat_free(l, s);
		if (nfree >= s->count)
			return;
		want = (want > l->sites ? want : l->sites) + (s->count - nfree);
	}
}

/* Sites of the lattice clear of every obstacle. */
static uint64_t lat_free(const lat_t *l, const scene_t *s)
{
	if (!s->n_obstacles)
		return l->sites;
	uint64_t nfree = 0;
	double x[3];
	for (uint64_t j = 0; j < l->sites; j++) {
		lat_site(l, j, x);
		nfree += in_obstacle(s, x, 0.0) < 0;
	}
	return nfree;
}

int place_check(const scene_t *s, char *msg, size_t msglen)
{
	span_t sp[3];
	if (!s->has_region)
		return PLACE_OK;
	int rc = spans(s, sp, msg, msglen);
	if (rc)
		return rc;
	/* the volume the particles of the region occupy: centre range grown by a diameter */
	double vol = 1.0, sigma = 2.0 * s->radius;
	for (int a = 0; a < s->dim; a++)
		vol *= sp[a].periodic ? sp[a].hi : sp[a].hi - sp[a].lo + sigma;
	double phi = (double)s->count * particle_volume(s) / vol, cp = scene_close_packing(s->dim);
	if (phi >= cp)
		return fail(msg, msglen, PLACE_EINVAL, "particles.initial.region: %llu particles in the region are at "
		            "volume fraction %.4g, at or above close packing %.4f", (unsigned long long)s->count, phi, cp);
	if (s->method != SCENE_METHOD_ED)
		return PLACE_OK;
	if (s->positions == SCENE_POS_RANDOM) {
		if (phi < rsa_jamming(s->dim))
			return PLACE_OK;
		return fail(msg, msglen, PLACE_EINVAL, "particles.initial.region: \"random\" cannot place %llu particles "
		            "in the region: volume fraction %.4g there (random sequential addition jams at %.3g); use "
		            "\"lattice\" or a larger region", (unsigned long long)s->count, phi, rsa_jamming(s->dim));
	}
	lat_t l;
	lat_init(&l, s, sp);
	if (l.nearest < sigma * (1.0 - 1e-12))
		return fail(msg, msglen, PLACE_EINVAL, "particles.initial.region: no lattice of %llu particles fits the region%s "
		            "(nearest distance %.6g < diameter %.6g); use a larger region or fewer particles",
		            (unsigned long long)s->count, s->n_obstacles ? " clear of the obstacles" : "", l.nearest, sigma);
	uint64_t nfree = lat_free(&l, s);
	if (nfree < s->count)
		return fail(msg, msglen, PLACE_EINVAL, "particles.initial.region: the obstacles leave room for only %llu of "
		            "%llu particles on a lattice in the region; use a larger region or fewer particles",
		            (unsigned long long)nfree, (unsigned long long)s->count);
	return PLACE_OK;
}

/* N of the lattice's sites clear of the obstacles, the vacancies spread
 * over them (lattice.h); place_check() made sure there are enough. */
static void place_lattice(const scene_t *s, const span_t *sp, rng_t *rng, double *pos)
{
	const int D = s->dim;
	lat_t l;
	lattice_fill_t fill;
	double x[3];
	lat_init(&l, s, sp);
	lattice_fill_init(&fill, lat_free(&l, s), s->count, rng);
	uint64_t f = 0, want = lattice_fill_next(&fill);
	uint32_t i = 0;
	for (uint64_t j = 0; j < l.sites && i < s->count; j++) {
		lat_site(&l, j, x);
		if (s->n_obstacles && in_obstacle(s, x, 0.0) >= 0)
			continue;
		if (f++ != want)
			continue;
		memcpy(&pos[(size_t)i * D], x, (size_t)D * sizeof(double));
		if (++i < s->count)
			want = lattice_fill_next(&fill);
	}
}

/* ---- a cell grid over the centre ranges, for overlap tests ---------------- */

typedef struct {
	int dim;
	span_t sp[3];
	int32_t nc[3];
	double cw[3];
	int32_t *head, *next;
	const double *pos;
	const double *rad;   /* mixtures: the radii (scene order; pairs touch at r_i + r_j); NULL: one radius */
} grid_t;

static int grid_init(grid_t *g, int dim, const span_t *sp, double sigma, uint32_t n, const double *pos)
{
	double len[3], vol = 1.0;
	g->dim = dim;
	g->pos = pos;
	g->rad = NULL;
	for (int a = 0; a < 3; a++) {
		g->sp[a] = sp[a];
		len[a] = a < dim ? sp[a].hi - sp[a].lo : 1.0;
		if (a < dim)
			vol *= fmax(len[a], sigma);
	}
	/* cells of at least a diameter, about one particle each at most */
	double edge = fmax(sigma, pow(vol / n, 1.0 / dim));
	size_t cells = 1;
	for (int a = 0; a < 3; a++) {
		double k = a < dim ? floor(len[a] / edge) : 1.0;
		g->nc[a] = k < 1.0 ? 1 : (int32_t)k;
		g->cw[a] = len[a] > 0.0 ? len[a] / g->nc[a] : 1.0;
		cells *= (size_t)g->nc[a];
	}
	g->head = malloc(cells * sizeof(int32_t));
	g->next = malloc((size_t)n * sizeof(int32_t));
	if (!g->head || !g->next) {
		free(g->head);
		free(g->next);
		return PLACE_ENOMEM;
	}
	for (size_t c = 0; c < cells; c++)
		g->head[c] = -1;
	return PLACE_OK;
}

static void grid_deinit(grid_t *g)
{
	free(g->head);
	free(g->next);
}

static int32_t cell_of(const grid_t *g, int a, double x)
{
	double u = floor((x - g->sp[a].lo) / g->cw[a]);
	return u < 0.0 ? 0 : u >= g->nc[a] ? g->nc[a] - 1 : (int32_t)u;
}

static size_t cell_index(const grid_t *g, const int32_t *c)
{
	return ((size_t)c[2] * g->nc[1] + c[1]) * g->nc[0] + c[0];
}

static void grid_insert(grid_t *g, uint32_t i)
{
	int32_t c[3] = { 0, 0, 0 };
	for (int a = 0; a < g->dim; a++)
		c[a] = cell_of(g, a, g->pos[i * g->dim + a]);
	size_t k = cell_index(g, c);
	g->next[i] = g->head[k];
	g->head[k] = (int32_t)i;
}

/* The first particle in the grid closer than sqrt(d2) to x (not skip), or
 * -1; with g->rad (mixtures) closer than rx + r_j - tol instead. */
static int32_t grid_clash_r(const grid_t *g, const double *x, double d2, double rx, double tol, int64_t skip,
                            double *r2_out)
{
	int32_t base[3] = { 0, 0, 0 }, lo[3], cnt[3];
	for (int a = 0; a < 3; a++) {
		if (a >= g->dim) {
			lo[a] = 0, cnt[a] = 1;
			continue;
		}
		base[a] = cell_of(g, a, x[a]);
		if (g->sp[a].periodic && g->nc[a] < 3) {
			lo[a] = 0, cnt[a] = g->nc[a];   /* every cell once */
		} else if (g->sp[a].periodic) {
			lo[a] = base[a] - 1, cnt[a] = 3;
		} else {
			lo[a] = base[a] > 0 ? base[a] - 1 : 0;
			cnt[a] = (base[a] + 1 < g->nc[a] ? base[a] + 1 : g->nc[a] - 1) - lo[a] + 1;
		}
	}
	int32_t c[3];
	for (int32_t kz = 0; kz < cnt[2]; kz++)
		for (int32_t ky = 0; ky < cnt[1]; ky++)
			for (int32_t kx = 0; kx < cnt[0]; kx++) {
				int32_t k[3] = { kx, ky, kz };
				for (int a = 0; a < 3; a++)
					c[a] = ((lo[a] + k[a]) % g->nc[a] + g->nc[a]) % g->nc[a];
				for (int32_t j = g->head[cell_index(g, c)]; j >= 0; j = g->next[j]) {
					if (j == skip)
						continue;
					double r2 = 0.0;
					for (int a = 0; a < g->dim; a++) {
						double dx = x[a] - g->pos[(size_t)j * g->dim + a];
						if (g->sp[a].periodic) {
							double L = g->sp[a].hi;
							dx -= L * nearbyint(dx / L);
						}
						r2 += dx * dx;
					}
					if (g->rad) {
						const double d = rx + g->rad[j] - tol;
						d2 = d * d;
					}
					if (r2 < d2) {
						*r2_out = r2;
						return j;
					}
				}
			}
	return -1;
}

static int32_t grid_clash(const grid_t *g, const double *x, double d2, int64_t skip, double *r2_out)
{
	return grid_clash_r(g, x, d2, 0.0, 0.0, skip, r2_out);
}

/* Mixtures: the lattice of the largest radius (place_lattice()), its sites
 * shuffled among the particles so that the species (blocks of scene
 * indices) mix. */
static void shuffle_sites(const scene_t *s, rng_t *rng, double *pos)
{
	const int D = s->dim;
	for (uint32_t i = (uint32_t)s->count - 1; i > 0; i--) {
		uint32_t j = (uint32_t)(rng_uniform(rng) * (i + 1.0));
		if (j > i)
			j = i;
		for (int a = 0; a < D; a++) {
			double x = pos[(size_t)i * D + a];
			pos[(size_t)i * D + a] = pos[(size_t)j * D + a];
			pos[(size_t)j * D + a] = x;
		}
	}
}

typedef struct {
	double r;
	uint32_t i;
} by_r_t;

static int by_radius_desc(const void *pa, const void *pb)
{
	const by_r_t *a = pa, *b = pb;
	return a->r > b->r ? -1 : a->r < b->r ? 1 : (a->i > b->i) - (a->i < b->i);
}

/* Mixtures: random sequential addition with every particle's own radius,
 * the largest first (the small ones fill the gaps), each centre uniform in
 * its own range (its radius from the region's faces and the walls), clear
 * of the obstacles by its radius and of the placed particles by r_i + r_j. */
static int place_random_mix(const scene_t *s, const span_t *sp, const double *rad, rng_t *rng, double *pos)
{
	const int D = s->dim;
	const uint32_t n = (uint32_t)s->count;
	grid_t g;
	by_r_t *order = malloc((size_t)n * sizeof(by_r_t));
	if (!order || grid_init(&g, D, sp, 2.0 * s->radius, n, pos) != PLACE_OK) {
		free(order);
		return PLACE_ENOMEM;
	}
	g.rad = rad;
	for (uint32_t i = 0; i < n; i++)
		order[i] = (by_r_t){ rad[i], i };
	qsort(order, n, sizeof *order, by_radius_desc);
	uint64_t tries = 0, max_tries = 1000 + 2000ull * n;
	int rc = PLACE_OK;
	for (uint32_t k = 0; k < n && rc == PLACE_OK; k++) {
		const uint32_t i = order[k].i;
		span_t own[3];
		if (spans_r(s, rad[i], own, NULL, 0) != PLACE_OK) {
			rc = PLACE_EPLACE;
			break;
		}
		for (;;) {
			if (++tries > max_tries) {
				rc = PLACE_EPLACE;
				break;
			}
			double *x = &pos[(size_t)i * D], r2;
			for (int a = 0; a < D; a++)
				x[a] = own[a].lo + rng_uniform(rng) * (own[a].hi - own[a].lo);
			if (s->n_obstacles && in_obstacle_r(s, x, rad[i], 0.0) >= 0)
				continue;
			if (grid_clash_r(&g, x, 0.0, rad[i], 0.0, -1, &r2) < 0)
				break;
		}
		if (rc == PLACE_OK)
			grid_insert(&g, i);
	}
	grid_deinit(&g);
	free(order);
	return rc;
}

static int place_random(const scene_t *s, const span_t *sp, rng_t *rng, double *pos)
{
	const int D = s->dim;
	const uint32_t n = (uint32_t)s->count;
	if (s->method != SCENE_METHOD_ED) {
		/* point particles: uniform, as dsmc/hsmc place in the whole box */
		for (uint32_t i = 0; i < n; i++)
			for (int a = 0; a < D; a++)
				pos[(size_t)i * D + a] = sp[a].lo + rng_uniform(rng) * (sp[a].hi - sp[a].lo);
		return PLACE_OK;
	}
	grid_t g;
	const double sigma = 2.0 * s->radius;
	if (grid_init(&g, D, sp, sigma, n, pos) != PLACE_OK)
		return PLACE_ENOMEM;
	uint64_t tries = 0, max_tries = 1000 + 2000ull * n;
	int rc = PLACE_OK;
	for (uint32_t i = 0; i < n && rc == PLACE_OK; i++) {
		for (;;) {
			if (++tries > max_tries) {
				rc = PLACE_EPLACE;
				break;
			}
			double *x = &pos[(size_t)i * D], r2;
			for (int a = 0; a < D; a++)
				x[a] = sp[a].lo + rng_uniform(rng) * (sp[a].hi - sp[a].lo);
			if (s->n_obstacles && in_obstacle(s, x, 0.0) >= 0)
				continue;
			if (grid_clash(&g, x, sigma * sigma, -1, &r2) < 0)
				break;
		}
		if (rc == PLACE_OK)
			grid_insert(&g, i);
	}
	grid_deinit(&g);
	return rc;
}

int place_region(const scene_t *s, uint64_t stream, double *pos, char *msg, size_t msglen)
{
	span_t sp[3];
	int rc = place_check(s, msg, msglen);
	if (rc)
		return rc;
	if ((rc = spans(s, sp, msg, msglen)))
		return rc;
	rng_t rng;
	rng_init(&rng, s->seed, stream | (1ull << 61));
	if (s->positions == SCENE_POS_LATTICE) {
		place_lattice(s, sp, &rng, pos);
		if (scene_has_species(s))
			shuffle_sites(s, &rng, pos);
		return PLACE_OK;
	}
	double *rad = radii_of(s, &rc);
	if (rc == PLACE_OK)
		rc = rad ? place_random_mix(s, sp, rad, &rng, pos) : place_random(s, sp, &rng, pos);
	free(rad);
	if (rc == PLACE_EPLACE)
		fail(msg, msglen, rc, "particles.initial.region: random placement of %llu particles in the region ran out "
		     "of tries (close to jamming); use \"lattice\" or a larger region", (unsigned long long)s->count);
	else if (rc == PLACE_ENOMEM)
		fail(msg, msglen, rc, "out of memory placing %llu particles", (unsigned long long)s->count);
	return rc;
}

int place_check_state(const scene_t *s, double *pos, const double *vel, const char *key, char *msg, size_t msglen)
{
	const int D = s->dim;
	const uint32_t n = (uint32_t)s->count;
	const double sigma = 2.0 * s->radius, tol = PLACE_OVERLAP_TOL * sigma;
	span_t sp[3];
	for (uint32_t i = 0; i < n; i++)
		for (int a = 0; a < D; a++) {
			if (!isfinite(pos[(size_t)i * D + a]))
				return fail(msg, msglen, PLACE_EINVAL, "%s: particle %u has a non-finite position (%g along %s)",
				            key, i, pos[(size_t)i * D + a], axis_names[a]);
			if (!isfinite(vel[(size_t)i * D + a]))
				return fail(msg, msglen, PLACE_EINVAL, "%s: particle %u has a non-finite velocity (%g along %s)",
				            key, i, vel[(size_t)i * D + a], axis_names[a]);
		}
	/* mixtures: every particle's own radius (tol stays that of the largest diameter) */
	int rc;
	double *rad = radii_of(s, &rc);
	if (rc != PLACE_OK)
		return fail(msg, msglen, PLACE_ENOMEM, "out of memory checking %u particles", n);
	for (int a = 0; a < 3; a++)
		sp[a] = (span_t){ 0.0, a < D ? s->box[a] : 1.0, 1 };
	for (int a = 0; a < D && rc == PLACE_OK; a++) {
		const scene_boundary_t *b = &s->boundary[a];
		const double L = s->box[a];
		double lo = 0.0, hi = L;
		if (b->walled) {
			/* a radius from each wall where it is at time 0 (the grid's range: the smallest radius's) */
			lo = wall_offset(&b->wall[0]) - tol;
			hi = L - wall_offset(&b->wall[1]) + tol;
			sp[a] = (span_t){ lo + s->radius, hi - s->radius, 0 };
		}
		for (uint32_t i = 0; i < n; i++) {
			double *x = &pos[(size_t)i * D + a];
			const double r = rad ? rad[i] : s->radius, ilo = b->walled ? lo + r : lo, ihi = b->walled ? hi - r : hi;
			if (*x >= ilo && *x <= ihi) {
				if (!b->walled && *x == L)
					*x = 0.0;   /* the same point of the periodic axis */
				continue;
			}
			if (b->walled)
				rc = fail(msg, msglen, PLACE_EINVAL, "%s: particle %u is closer than a radius to a wall along %s "
				          "(centre %.15g, its room %.15g to %.15g at time 0)", key, i, axis_names[a], *x,
				          ilo + tol, ihi - tol);
			else
				rc = fail(msg, msglen, PLACE_EINVAL, "%s: particle %u is outside the box along %s (%.15g not in "
				          "[0, %.15g])", key, i, axis_names[a], *x, L);
			break;
		}
	}
	for (uint32_t i = 0; i < n && s->n_obstacles && rc == PLACE_OK; i++) {
		int k = in_obstacle_r(s, &pos[(size_t)i * D], rad ? rad[i] : s->radius, tol);
		if (k >= 0)
			rc = fail(msg, msglen, PLACE_EINVAL, "%s: particle %u overlaps obstacles[%d] (closer than its radius "
			          "plus the particle radius to its centre by more than %g diameters)", key, i, k,
			          PLACE_OVERLAP_TOL);
	}
	if (rc != PLACE_OK || s->method != SCENE_METHOD_ED) {
		free(rad);
		return rc;   /* point particles may overlap */
	}
	grid_t g;
	if (grid_init(&g, D, sp, sigma, n, pos) != PLACE_OK) {
		free(rad);
		return fail(msg, msglen, PLACE_ENOMEM, "out of memory checking %u particles", n);
	}
	g.rad = rad;
	for (uint32_t i = 0; i < n; i++)
		grid_insert(&g, i);
	const double d = sigma - tol;
	for (uint32_t i = 0; i < n && rc == PLACE_OK; i++) {
		double r2;
		const double ri = rad ? rad[i] : s->radius;
		int32_t j = grid_clash_r(&g, &pos[(size_t)i * D], d * d, ri, tol, i, &r2);
		if (j >= 0)
			rc = fail(msg, msglen, PLACE_EINVAL, "%s: particles %d and %u overlap (centre distance %.15g < %s "
			          "%.15g by more than %g diameters)", key, j < (int32_t)i ? j : (int32_t)i,
			          j < (int32_t)i ? i : (uint32_t)j, sqrt(r2), rad ? "the sum of their radii" : "diameter",
			          rad ? ri + rad[j] : sigma, PLACE_OVERLAP_TOL);
	}
	grid_deinit(&g);
	free(rad);
	return rc;
}

const char *place_strerror(int code)
{
	switch (code) {
	case PLACE_OK: return "success";
	case PLACE_EINVAL: return "initial state not usable";
	case PLACE_ENOMEM: return "out of memory";
	case PLACE_EPLACE: return "random placement ran out of tries";
	default: return "unknown error";
	}
}
