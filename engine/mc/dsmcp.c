/* DSMC of one system decomposed over ranks in slabs of cell planes: free flight, migrants packed, cell-keyed collisions, exact sums. */
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <stdio.h>

#include "dsmcp.h"
#include "rng.h"

#define PI 3.14159265358979323846
#define ALWAYS_INLINE inline __attribute__((always_inline))

struct dsmcp {
	int dim, rank, ranks;
	uint32_t n;                    /* particles in the whole system */
	double L[3], inv_h[3];
	int nc[3];
	size_t plane;                  /* cells per plane of the last axis */
	int p0, p1;                    /* own planes */
	size_t c0, c1;                 /* own cells [c0, c1) (global indices) */
	int *owner;                    /* owner rank of each plane of the last axis */
	double sigma, mass, e, chi, sigma_t, vcell, fcoef, cps, dt_fixed;
	int cba;
	uint64_t key;                  /* (seed, stream) mixed: base of the cell keys */
	double escale;                 /* fixed-point scale of the energy sums (a power of two) */

	/* own particles: AoS x[D] v[D], identities, cells (56 B a particle in 3D); the sort's ring and
	 * overflow list (sort_cells_d()) */
	size_t nl, cap;
	double *p;
	uint32_t *id;                  /* identities (N < 2^32, dsmcp_check()) */
	uint32_t *cell;                /* local cell (cell - c0) of each record, then its sort destination;
	                                * UINT32_MAX: a migrant (dsmcp_move()) */
	double *ringp, *overp;         /* ring: records waiting for their slot j at j % ring_n; overflow: far movers */
	uint32_t *ringid, *overid, *overdst;
	size_t ring_cap, over_cap;
	uint32_t *start;               /* own cells + 1: offsets of the sorted records (the sort's cursors while it runs) */
	float *rem;                    /* NTC remainder per own cell */
	/* migrants */
	double *out;
	size_t out_cap, *out_cnt, *out_pos;

	/* global, after dsmcp_finish() */
	double t, ekin;
	uint64_t steps, collisions, candidates, vmax_raised, migrated, moves;
	uint64_t step_migr;            /* this rank's migrants in the current step */
	size_t nown_nl, nlow;          /* records before the arrivals; arrivals from lower ranks (first) */
	/* hsmc (dsmcp_hs_*) */
	int hsmc;
	uint32_t nfull;
	double *gcm;                   /* every cell: count, mean velocity (start of the step) */
	uint32_t *gstamp;              /* every cell: step mark of its last cell collision */
	double *ev;                    /* the chain's events */
	size_t ev_cap;
	uint64_t step_cellc, step_rej; /* this rank's, this step */
	uint64_t cell_collisions, rejected;   /* global totals */
	/* interval accumulators (dsmcp_interval()) */
	double t_sample, ekin_int;     /* global: E_kin dt summed over the steps (the same on every rank) */
	double virial;                 /* this rank's collisions' (sigma n) . J */
};

/* ---- keyed random numbers --------------------------------------------------- */

static inline uint64_t mix64(uint64_t z)
{
	z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
	z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
	return z ^ (z >> 31);
}

/* A xoshiro256** state for (key, step, cell): two rounds of the splitmix
 * finaliser over the three words, then splitmix64 to fill the state (as
 * rng_init()); the all-zero state cannot occur. */
static inline void cell_rng(rng_t *r, uint64_t key, uint64_t step, uint64_t cell)
{
	uint64_t x = mix64(key ^ mix64(step * 0x9e3779b97f4a7c15ull + 0x632be59bd9b4e019ull));
	x = mix64(x ^ (cell * 0xd1b54a32d192ed03ull + 0x8cb92ba72f3d8dd7ull));
	for (int i = 0; i < 4; i++) {
		uint64_t z = (x += 0x9e3779b97f4a7c15ull);
		r->s[i] = mix64(z);
	}
}

static inline double wrap(double x, double L)
{
	if (x >= L || x < 0) {
		x -= L * floor(x / L);
		if (x >= L || x < 0)
			x = 0;
	}
	return x;
}

static inline size_t cell_at(const struct dsmcp *d, const double *x)
{
	size_t c = 0;
	for (int a = d->dim - 1; a >= 0; a--) {
		int ix = (int)(x[a] * d->inv_h[a]);
		if (ix >= d->nc[a])
			ix = d->nc[a] - 1;
		c = c * (size_t)d->nc[a] + (size_t)ix;
	}
	return c;
}

/* ---- set-up ------------------------------------------------------------------- */

int dsmcp_check(const scene_t *s, char *msg, size_t msglen)
{
	const char *key = NULL, *why = NULL;
	if (s->method != SCENE_METHOD_DSMC && s->method != SCENE_METHOD_HSMC)
		key = "method", why = "a decomposed run needs method dsmc or hsmc";
	else if (scene_has_walls(s))
		key = "boundaries", why = "walls over several ranks are not supported yet (periodic box only)";
	else if (scene_has_gravity(s))
		key = "gravity", why = "gravity over several ranks is not supported yet";
	else if (s->n_obstacles > 0)
		key = "obstacles", why = "obstacles over several ranks are not supported yet";
	else if (scene_has_species(s))
		key = "particles.species", why = "mixtures over several ranks are not supported yet";
	else if (s->mc_local_chi)
		key = "dsmc.contact_value", why = "\"local\" over several ranks is not supported yet (use \"global\")";
	else if (s->mc_impact_n > 0)
		key = "dsmc.impact_c", why = "impact_c over several ranks is not supported yet";
	else if (s->observables & ~(unsigned)(SCENE_OBS_ENERGY | SCENE_OBS_PRESSURE | SCENE_OBS_COLLISION_RATE |
	                                    SCENE_OBS_MOMENTUM))
		key = "output.observables", why = "over several ranks only energy, pressure, collision_rate and momentum";
	else if (s->count > UINT32_MAX)
		key = "particles.count", why = "at most 2^32 - 1 particles";
	if (!key)
		return DSMCP_OK;
	if (msg && msglen)
		snprintf(msg, msglen, "%s: %s", key, why);
	return DSMCP_EINVAL;
}

/* Records of cap rows: S doubles (position, velocity), an id and a cell or destination each. Each array
 * that grows is kept even when another fails (the old ones stay valid); -1 when any failed. */
static int grow_records(double **p, uint32_t **a, uint32_t **b, size_t cap, size_t S)
{
	double *np = realloc(*p, cap * S * sizeof(double));
	if (np)
		*p = np;
	uint32_t *na = realloc(*a, cap * sizeof(uint32_t));
	if (na)
		*a = na;
	uint32_t *nb = realloc(*b, cap * sizeof(uint32_t));
	if (nb)
		*b = nb;
	return np && na && nb ? 0 : -1;
}

/* Room for cap particles. */
static int reserve(struct dsmcp *d, size_t cap)
{
	if (cap <= d->cap)
		return DSMCP_OK;
	/* a margin of 1/16: the arrivals of a step are a small fraction (0.2 % of N per step in 3D at 2 ranks);
	 * pages never written are not resident */
	cap = cap + cap / 16 + 64;
	if (cap >= UINT32_MAX)   /* local indices and destinations below the migrant mark */
		return DSMCP_ENOMEM;
	if (grow_records(&d->p, &d->id, &d->cell, cap, 2 * (size_t)d->dim))
		return DSMCP_ENOMEM;
	d->cap = cap;
	return DSMCP_OK;
}

static double limbs_energy(const struct dsmcp *d, const uint64_t *limb)
{
	unsigned __int128 acc = 0;
	for (int i = 3; i >= 0; i--)
		acc = (acc << 32) + limb[i];   /* limbs may exceed 32 bits after summing: carries propagate */
	return (double)acc / d->escale;
}

/* Move every record k to dest[k] (a permutation) along its cycles, each record once: in place, but
 * cycles jump through the whole array (2.5x the step's CPU time as the sort of every step); used for
 * the set-up's sort (records in identity order), and when the overflow list cannot be had. */
static void permute_cycles(struct dsmcp *d, const int S)
{
	double *restrict p = d->p;
	uint32_t *restrict id = d->id, *restrict dest = d->cell;
	for (size_t i = 0; i < d->nl; i++) {
		uint32_t j = dest[i];
		if (j == i)
			continue;   /* in place, or placed by an earlier cycle */
		double carry[6], tmp[6];
		memcpy(carry, &p[i * S], S * sizeof(double));
		uint32_t cid = id[i];
		dest[i] = (uint32_t)i;
		while (j != i) {   /* carry to j, take what was there on to its destination */
			memcpy(tmp, &p[(size_t)j * S], S * sizeof(double));
			memcpy(&p[(size_t)j * S], carry, S * sizeof(double));
			memcpy(carry, tmp, S * sizeof(double));
			uint32_t t = id[j];
			id[j] = cid;
			cid = t;
			uint32_t jn = dest[j];
			dest[j] = j;
			j = jn;
		}
		memcpy(&p[i * S], carry, S * sizeof(double));
		id[i] = cid;
	}
}

/* The ring's length for nl records: 1.25 planes of records (a move along the last axis lands about one
 * plane ahead; the arrivals from the lower rank shift the own records by a few more) + 512, as dsmc.c's
 * ring_size(); at most nl. DSMCP_ENOMEM if the room cannot be had. */
static int ring_fit(struct dsmcp *d, const int S, size_t *W)
{
	const size_t nown = d->c1 - d->c0;
	double w = 1.25 * (double)d->nl * (double)d->plane / (double)(nown ? nown : 1) + 512;
	size_t want = w < (double)d->nl ? (size_t)w : d->nl;
	want = want ? want : 1;
	if (want > d->ring_cap) {
		size_t cap = want + want / 8;
		double *rp = realloc(d->ringp, cap * S * sizeof(double));
		if (rp)
			d->ringp = rp;
		uint32_t *ri = realloc(d->ringid, cap * sizeof(uint32_t));
		if (ri)
			d->ringid = ri;
		if (!rp || !ri)
			return DSMCP_ENOMEM;
		/* defined bytes: the pass copies ring slots whatever they hold (stale copies are overwritten) */
		memset(&d->ringp[d->ring_cap * S], 0, (cap - d->ring_cap) * S * sizeof(double));
		memset(&d->ringid[d->ring_cap], 0, (cap - d->ring_cap) * sizeof(uint32_t));
		d->ring_cap = cap;
	}
	*W = want;
	return DSMCP_OK;
}

/* Room for nf far movers in the overflow list. */
static int over_fit(struct dsmcp *d, const int S, size_t nf)
{
	if (nf <= d->over_cap)
		return DSMCP_OK;
	size_t cap = nf + nf / 4 + 128;
	if (grow_records(&d->overp, &d->overid, &d->overdst, cap, (size_t)S))
		return DSMCP_ENOMEM;
	d->over_cap = cap;
	return DSMCP_OK;
}

/* Stable counting sort of the own records into cells: the 1-rank order (see dsmcp.h, dsmcp_arrive()),
 * in place (dsmc.c's sort()). Each record's destination (its cell's next slot, the records taken in
 * the stable order over the three segments below) replaces its cell; the cell offsets go to start
 * (its entries serve as the cursors, then are shifted back by one cell). The permutation is then
 * applied reading the records once, in index order: slot r is written as soon as its own record has
 * been read; a record going back (destination <= r) is written at once, one going forward waits in a
 * ring of W slots indexed by destination (a move to the next cell plane lands about one plane of
 * records ahead), the few going W or more ahead (the periodic wrap across the last axis on one rank)
 * in an overflow list written at the end. The memory traffic of a copy, without a second copy of the
 * records: the resident memory is the records' and a ring of ~1.25 planes.
 * full (the set-up: records in identity order, every record far): permute_cycles(). */
static ALWAYS_INLINE void sort_cells_d(struct dsmcp *d, const int D, int full)
{
	const int S = 2 * D;
	const size_t nown = d->c1 - d->c0;
	uint32_t *restrict start = d->start, *restrict dest = d->cell;
	memset(start, 0, (nown + 1) * sizeof(uint32_t));
	for (size_t k = 0; k < d->nl; k++)
		start[dest[k]]++;
	uint32_t acc = 0;
	for (size_t c = 0; c < nown; c++) {
		uint32_t k = start[c];
		start[c] = acc;   /* cursor of cell c */
		acc += k;
	}
	size_t W = 0;
	const int ring = !full && ring_fit(d, S, &W) == DSMCP_OK;
	/* stable over the 1-rank order: arrivals from lower ranks (lower cells),
	 * the own survivors, arrivals from higher ranks (dsmcp_arrive()) */
	const size_t seg[3][2] = {{d->nown_nl, d->nown_nl + d->nlow}, {0, d->nown_nl}, {d->nown_nl + d->nlow, d->nl}};
	size_t nfar = 0;
	for (int g = 0; g < 3; g++)
		for (size_t k = seg[g][0]; k < seg[g][1]; k++) {
			uint32_t j = start[dest[k]]++;
			dest[k] = j;
			nfar += j > k && j - k >= W;
		}
	/* start[c] is now the end of cell c: the offsets one cell on */
	memmove(start + 1, start, nown * sizeof(uint32_t));
	start[0] = 0;
	const size_t nl = d->nl;
	d->nown_nl = nl;
	d->nlow = 0;
	if (!ring || over_fit(d, S, nfar) != DSMCP_OK) {
		permute_cycles(d, S);
		return;
	}
	double *restrict p = d->p, *restrict rp = d->ringp, *restrict op = d->overp;
	uint32_t *restrict id = d->id, *restrict rid = d->ringid, *restrict oid = d->overid, *restrict odst = d->overdst;
	size_t no = 0;
	/* No data-dependent branch but the rare far mover's: ring slot r % W is copied to slot r whatever it
	 * holds; when it is not slot r's record (stale), that record is written over it later in this pass
	 * (record r itself, just below; a record read later that goes back; or an overflow record, at the
	 * end). */
	for (size_t r = 0, w = 0; r < nl; r++, w = w + 1 == W ? 0 : w + 1) {   /* w = r % W */
		double rec[6];
		memcpy(rec, &p[r * S], S * sizeof(double));
		uint32_t rid0 = id[r];
		size_t j = dest[r];
		memcpy(&p[r * S], &rp[w * S], S * sizeof(double));
		id[r] = rid[w];
		if (j > r && j - r >= W) {   /* far forward: the overflow list */
			memcpy(&op[no * S], rec, S * sizeof(double));
			oid[no] = rid0;
			odst[no++] = (uint32_t)j;
			continue;
		}
		size_t wj = w + (j - r);   /* j % W when 0 < j - r < W (unused otherwise) */
		wj = wj >= W ? wj - W : wj;
		const int back = j <= r;
		double *to = back ? &p[j * S] : &rp[wj * S];
		uint32_t *ti = back ? &id[j] : &rid[wj];
		memcpy(to, rec, S * sizeof(double));
		*ti = rid0;
	}
	for (size_t o = 0; o < no; o++) {
		memcpy(&p[(size_t)odst[o] * S], &op[o * S], S * sizeof(double));
		id[odst[o]] = oid[o];
	}
}

/* D a constant in each copy: the record copies inline. */
static void sort_cells(struct dsmcp *d, int full)
{
	if (d->dim == 3)
		sort_cells_d(d, 3, full);
	else
		sort_cells_d(d, 2, full);
}

int dsmcp_direct_ok(const scene_t *s)
{
	return s->positions == SCENE_POS_RANDOM && !s->init_pos && !s->init_vel && !(s->relax_cpp > 0) &&
	       !scene_has_species(s) && !scene_has_walls(s) && !scene_has_gravity(s) && s->n_obstacles == 0;
}

/* Own a particle of identity i at x, velocity v, if its cell is in the slab. */
static int take(struct dsmcp *d, uint32_t i, const double *x, const double *v, size_t xs, size_t vs)
{
	const int D = d->dim, S = 2 * D;
	size_t c = 0;
	for (int a = D - 1; a >= 0; a--) {
		int ix = (int)(x[a * xs] * d->inv_h[a]);
		if (ix >= d->nc[a])
			ix = d->nc[a] - 1;
		c = c * (size_t)d->nc[a] + (size_t)ix;
	}
	if (c < d->c0 || c >= d->c1)
		return DSMCP_OK;
	if (d->nl == d->cap && reserve(d, d->nl + 1) != DSMCP_OK)
		return DSMCP_ENOMEM;
	double *r = &d->p[d->nl * S];
	for (int a = 0; a < D; a++) {
		r[a] = x[a * xs];
		r[D + a] = v ? v[a * vs] : 0.0;
	}
	d->id[d->nl] = i;
	d->cell[d->nl++] = (uint32_t)(c - d->c0);
	return DSMCP_OK;
}

/* dsmc_create()'s initial state of a periodic one-species scene with random
 * positions and no pre-run, built without holding the whole system: the
 * scene's stream is run through twice (positions, then the Maxwellian: the
 * mean in the first pass, the variance after removing it in the second, in
 * dsmc_create()'s order, so every number is the same), each rank keeping
 * its slab. */
static int fill_direct(struct dsmcp *d, const scene_t *s, uint64_t stream)
{
	const int D = d->dim, S = 2 * D;
	const uint32_t n = d->n;
	rng_t rng;
	double mean[3] = {0, 0, 0}, s2 = 0;
	rng_init(&rng, s->seed, stream);
	for (uint32_t i = 0; i < n; i++) {
		double x[3];
		for (int a = 0; a < D; a++)
			x[a] = wrap(rng_uniform(&rng) * d->L[a], d->L[a]);
		if (take(d, i, x, NULL, 1, 1) != DSMCP_OK)
			return DSMCP_ENOMEM;
	}
	/* raw Gaussians: the own ones kept (in identity order, as the records) */
	size_t k = 0;
	for (uint32_t i = 0; i < n; i++)
		for (int a = 0; a < D; a++) {
			double v = rng_gauss(&rng);
			mean[a] += v;
			if (k < d->nl && d->id[k] == i)
				d->p[k * S + D + a] = v;
			if (a == D - 1 && k < d->nl && d->id[k] == i)
				k++;
		}
	/* the variance after the mean is removed, in dsmc_create()'s order */
	rng_init(&rng, s->seed, stream);
	for (uint64_t j = 0; j < (uint64_t)n * D; j++)
		(void)rng_uniform(&rng);
	for (uint32_t i = 0; i < n; i++)
		for (int a = 0; a < D; a++) {
			double v = rng_gauss(&rng);
			v -= mean[a] / n;
			s2 += v * v;
		}
	double scale = s2 > 0 ? sqrt(s->temperature * D * n / (d->mass * s2)) : 0;
	for (size_t q = 0; q < d->nl; q++)
		for (int a = 0; a < D; a++) {
			double *v = &d->p[q * S + D + a];
			*v -= mean[a] / n;
			*v *= scale;
		}
	return DSMCP_OK;
}

/* The grid, constants and per-cell memory of rank `rank` of `ranks` for
 * geometry g (no particles yet). NULL when out of memory. */
static struct dsmcp *make(const scene_t *s, const dsmc_geom_t *g, uint64_t stream, int rank, int ranks)
{
	size_t nown;
	struct dsmcp *d = calloc(1, sizeof *d);
	if (!d)
		return NULL;
	const int D = g->dim;
	d->dim = D;
	d->rank = rank;
	d->ranks = ranks;
	d->n = g->n;
	d->plane = 1;
	for (int a = 0; a < 3; a++) {
		d->L[a] = g->L[a];
		d->nc[a] = g->nc[a];
		d->inv_h[a] = g->nc[a] / g->L[a];
		if (a < D - 1)
			d->plane *= (size_t)g->nc[a];
	}
	const int nz = g->nc[D - 1];
	d->p0 = (int)((int64_t)rank * nz / ranks);
	d->p1 = (int)((int64_t)(rank + 1) * nz / ranks);
	d->c0 = (size_t)d->p0 * d->plane;
	d->c1 = (size_t)d->p1 * d->plane;
	d->owner = malloc((size_t)nz * sizeof(int));
	if (!d->owner)
		goto fail;
	for (int r = 0; r < ranks; r++)
		for (int z = (int)((int64_t)r * nz / ranks); z < (int)((int64_t)(r + 1) * nz / ranks); z++)
			d->owner[z] = r;
	d->sigma = g->sigma;
	d->mass = g->mass;
	d->e = g->e;
	d->chi = g->chi;
	d->sigma_t = g->sigma_t;
	d->vcell = g->vcell;
	d->fcoef = g->fcoef;
	d->cps = g->cps;
	d->dt_fixed = g->dt_fixed;
	d->cba = g->cba;
	d->hsmc = g->hsmc;
	d->nfull = g->nfull;
	d->key = mix64(s->seed ^ mix64(0xa0761d6478bd642full * (stream + 1)));

	nown = d->c1 - d->c0;
	d->start = calloc(nown + 1, sizeof(uint32_t));
	d->rem = malloc((nown ? nown : 1) * sizeof(float));
	d->out_cnt = calloc((size_t)ranks, sizeof(size_t));
	d->out_pos = calloc((size_t)ranks, sizeof(size_t));
	if (!d->start || !d->rem || !d->out_cnt || !d->out_pos)
		goto fail;
	if (d->hsmc) {
		const size_t ncells = d->plane * (size_t)nz;
		d->gcm = calloc(ncells * (size_t)(1 + D), sizeof(double));
		d->gstamp = calloc(ncells, sizeof(uint32_t));
		if (!d->gcm || !d->gstamp)
			goto fail;
	}
	return d;
fail:
	dsmcp_destroy(d);
	return NULL;
}

dsmcp_t *dsmcp_create(const scene_t *s, const dsmc_t *init, uint64_t stream, int rank, int ranks, int *err,
                      char *msg, size_t msglen)
{
	struct dsmcp *d = NULL;
	double *pos = NULL, *vel = NULL;
	*err = DSMCP_EINVAL;
	if (msg && msglen)
		msg[0] = '\0';
	if (ranks < 1 || rank < 0 || rank >= ranks) {
		if (msg && msglen)
			snprintf(msg, msglen, "run: rank %d of %d", rank, ranks);
		goto fail;
	}
	if (dsmcp_check(s, msg, msglen) != DSMCP_OK)
		goto fail;
	dsmc_geom_t g;
	if (init) {
		dsmc_geometry(init, &g);
	} else if (!dsmcp_direct_ok(s) || dsmc_geometry_scene(s, &g, msg, msglen) != DSMC_OK) {
		if (msg && msglen && !msg[0])
			snprintf(msg, msglen, "run: the decomposed dsmc needs an initial state for this scene");
		goto fail;
	}
	if (g.mix || g.bounded || g.local_chi || g.impact) {
		if (msg && msglen)
			snprintf(msg, msglen, "method: the scene uses a feature the decomposed dsmc does not support");
		goto fail;
	}
	*err = DSMCP_ENOMEM;
	d = make(s, &g, stream, rank, ranks);
	if (!d)
		goto fail;
	const int D = g.dim;
	const size_t nown = d->c1 - d->c0;
	if (init) {
		pos = malloc((size_t)g.n * D * sizeof(double));
		vel = malloc((size_t)g.n * D * sizeof(double));
		if (!pos || !vel)
			goto fail;
		dsmc_state(init, pos, vel);
		size_t mine = 0;
		for (uint32_t i = 0; i < g.n; i++) {
			size_t c = cell_at(d, &pos[(size_t)i * D]);
			mine += c >= d->c0 && c < d->c1;
		}
		if (reserve(d, mine) != DSMCP_OK)
			goto fail;
		for (uint32_t i = 0; i < g.n; i++)
			if (take(d, i, &pos[(size_t)i * D], &vel[(size_t)i * D], 1, 1) != DSMCP_OK)
				goto fail;
	} else if (reserve(d, (size_t)g.n / (size_t)ranks + 64) != DSMCP_OK || fill_direct(d, s, stream) != DSMCP_OK) {
		goto fail;
	}
	d->nown_nl = d->nl;
	sort_cells(d, 1);
	/* remainders uniform on [0, 1) from the generator of (key, step 2^64 - 1, cell) */
	for (size_t c = 0; c < nown; c++) {
		rng_t r;
		cell_rng(&r, d->key, UINT64_MAX, d->c0 + c);
		d->rem[c] = (float)rng_uniform_fast(&r);
	}
	/* fixed point: the expected initial total D N T / 2 near 2^80, so 2^47
	 * times more fits in 128 bits (given velocities: their exact energy) */
	double eref = 0.5 * D * (double)g.n * s->temperature;
	if (init && s->init_vel) {
		dsmc_sample_t tot;
		dsmc_totals(init, &tot);
		eref = tot.kinetic_energy;
	}
	int ex = 0;
	(void)frexp(eref > 0 ? eref : 1.0, &ex);
	d->escale = ldexp(1.0, 80 - ex);
	d->ekin = NAN;   /* dsmcp_start() */
	*err = DSMCP_OK;
	free(pos);
	free(vel);
	return d;
fail:
	if (*err == DSMCP_ENOMEM && msg && msglen)
		snprintf(msg, msglen, "run: out of memory for the decomposed dsmc");
	free(pos);
	free(vel);
	dsmcp_destroy(d);
	return NULL;
}

void dsmcp_destroy(dsmcp_t *d)
{
	if (!d)
		return;
	free(d->owner);
	free(d->p);
	free(d->id);
	free(d->cell);
	free(d->ringp);
	free(d->ringid);
	free(d->overp);
	free(d->overid);
	free(d->overdst);
	free(d->start);
	free(d->rem);
	free(d->out);
	free(d->out_cnt);
	free(d->out_pos);
	free(d->gcm);
	free(d->gstamp);
	free(d->ev);
	free(d);
}

/* ---- one step ------------------------------------------------------------------- */

double dsmcp_next_dt(const dsmcp_t *d, double t_stop, int *last)
{
	double dt = d->dt_fixed;
	*last = 0;
	if (dt <= 0) {
		double T = 2 * d->ekin / (d->dim * (double)d->n);
		dt = T > 0 ? d->cps / (d->fcoef * sqrt(T)) : INFINITY;
	}
	if (!isfinite(dt) && !isfinite(t_stop))
		return INFINITY;
	if (!(d->t + dt < t_stop) || (t_stop - d->t - dt) < 1e-12 * dt) {
		dt = t_stop - d->t;
		*last = 1;
	}
	return dt;
}

int dsmcp_record_doubles(const dsmcp_t *d) { return 2 * d->dim + 1; }

static ALWAYS_INLINE int move_d(dsmcp_t *d, double dt, const int D)
{
	const int S = 2 * D, R = S + 1;
	size_t nout = 0;
	memset(d->out_cnt, 0, (size_t)d->ranks * sizeof(size_t));
	/* flight; cell of each record (global index for the migrants); the
	 * grid in locals (the stores to cell may alias the struct) */
	double L[3], ih[3];
	int ncl[3];
	for (int a = 0; a < D; a++) {
		L[a] = d->L[a];
		ih[a] = d->inv_h[a];
		ncl[a] = d->nc[a];
	}
	const size_t c0 = d->c0, c1 = d->c1, nl = d->nl;
	double *restrict p = d->p;
	uint32_t *restrict cell = d->cell;
	size_t cur = 0;   /* hsmc: the own cell of record k (records in cell order) */
	for (size_t k = 0; k < nl; k++) {
		double *x = &p[k * S], *v = x + D;
		size_t c = 0;   /* the new cell */
		if (d->hsmc) {
			/* a move into another cell full at the start of the step is rejected */
			double y[3];
			while (k >= d->start[cur + 1])
				cur++;
			for (int a = D - 1; a >= 0; a--) {
				y[a] = wrap(x[a] + v[a] * dt, L[a]);
				int ix = (int)(y[a] * ih[a]);
				ix = ix >= ncl[a] ? ncl[a] - 1 : ix;
				c = c * (size_t)ncl[a] + (size_t)ix;
			}
			if (c != c0 + cur && d->gcm[c * (size_t)(1 + D)] >= (double)d->nfull) {
				d->step_rej++;
				c = c0 + cur;
			} else {
				for (int a = 0; a < D; a++)
					x[a] = y[a];
			}
		} else {
			for (int a = D - 1; a >= 0; a--) {
				double y = wrap(x[a] + v[a] * dt, L[a]);
				x[a] = y;
				int ix = (int)(y * ih[a]);
				ix = ix >= ncl[a] ? ncl[a] - 1 : ix;
				c = c * (size_t)ncl[a] + (size_t)ix;
			}
		}
		if (c >= c0 && c < c1) {
			cell[k] = (uint32_t)(c - c0);
		} else {
			cell[k] = UINT32_MAX;
			d->out_cnt[d->owner[c / d->plane]]++;
			nout++;
		}
	}
	d->step_migr = nout;
	d->nown_nl = d->nl;
	if (!nout)
		return DSMCP_OK;
	if (nout > d->out_cap) {
		size_t cap = nout + nout / 2 + 64;
		double *o = realloc(d->out, cap * R * sizeof(double));
		if (!o)
			return DSMCP_ENOMEM;
		d->out = o;
		d->out_cap = cap;
	}
	size_t acc = 0;
	for (int r = 0; r < d->ranks; r++) {
		d->out_pos[r] = acc;
		acc += d->out_cnt[r];
	}
	size_t w = 0;
	for (size_t k = 0; k < d->nl; k++) {
		if (d->cell[k] == UINT32_MAX) {
			const double *x = &d->p[k * S];
			int r = d->owner[cell_at(d, x) / d->plane];
			double *o = &d->out[d->out_pos[r]++ * R];
			memcpy(o, x, S * sizeof(double));
			o[S] = (double)d->id[k];
			continue;
		}
		if (w != k) {
			memcpy(&d->p[w * S], &d->p[k * S], S * sizeof(double));
			d->id[w] = d->id[k];
			d->cell[w] = d->cell[k];
		}
		w++;
	}
	d->nl = d->nown_nl = w;
	return DSMCP_OK;
}

int dsmcp_move(dsmcp_t *d, double dt)
{
	return d->dim == 3 ? move_d(d, dt, 3) : move_d(d, dt, 2);
}

const double *dsmcp_outbox(const dsmcp_t *d, const size_t **counts)
{
	*counts = d->out_cnt;
	return d->out;
}

int dsmcp_arrive(dsmcp_t *d, const double *rec, size_t n, size_t nlow)
{
	const int D = d->dim, S = 2 * D, R = S + 1;
	if (nlow > n || d->nl != d->nown_nl)
		return DSMCP_EINVAL;
	if (reserve(d, d->nl + n) != DSMCP_OK)
		return DSMCP_ENOMEM;
	d->nlow = nlow;
	for (size_t i = 0; i < n; i++) {
		const double *r = &rec[i * R];
		size_t c = cell_at(d, r);
		if (c < d->c0 || c >= d->c1 || !(r[S] >= 0) || r[S] >= (double)d->n)
			return DSMCP_EINVAL;
		memcpy(&d->p[d->nl * S], r, S * sizeof(double));
		d->id[d->nl] = (uint32_t)r[S];
		d->cell[d->nl++] = (uint32_t)(c - d->c0);
	}
	return DSMCP_OK;
}

/* Bird's no-time-counter collisions of the own cells, as dsmc.c's collide()
 * (periodic, one species, molecular chaos), each cell drawing from its own
 * keyed generator. */
static ALWAYS_INLINE void collide_d(dsmcp_t *d, double dt, dsmcp_sums_t *part, const int D)
{
	const int S = 2 * D;
	const double coef = d->chi * d->sigma_t * dt / (2 * d->vcell);
	const double ehalf = 0.5 * (1 + d->e);
	const double sigma = d->sigma;
	uint64_t ncoll = 0, ncand = 0, nraise = 0;
	double virial = 0;
	unsigned __int128 eacc = 0;
	sort_cells(d, 0);
	const size_t nown = d->c1 - d->c0;
	for (size_t c = 0; c < nown; c++) {
		uint32_t k0 = d->start[c], nc = d->start[c + 1] - k0;
		if (nc < 2)
			goto energy;
		double u[3] = {0, 0, 0}, s2 = 0;
		for (uint32_t k = k0; k < k0 + nc; k++)
			for (int a = 0; a < D; a++)
				u[a] += d->p[(size_t)k * S + D + a];
		for (int a = 0; a < D; a++)
			u[a] /= nc;
		for (uint32_t k = k0; k < k0 + nc; k++) {
			double w2 = 0;
			for (int a = 0; a < D; a++) {
				double w = d->p[(size_t)k * S + D + a] - u[a];
				w2 += w * w;
			}
			s2 = w2 > s2 ? w2 : s2;
		}
		if (s2 == 0)
			goto energy;
		double vmax = 2 * sqrt(s2), inv = 1 / vmax;
		double b = coef * (double)nc * (double)(nc - 1) + (double)d->rem[c] * inv;
		rng_t rng;
		int seeded = 0;
		while (b >= inv) {
			if (!seeded) {
				cell_rng(&rng, d->key, d->steps, d->c0 + c);
				seeded = 1;
			}
			b -= inv;
			ncand++;
			uint32_t i = k0 + (uint32_t)(rng_uniform_fast(&rng) * nc);
			uint32_t j = k0 + (uint32_t)(rng_uniform_fast(&rng) * (nc - 1));
			if (j >= i)
				j++;
			double *vi = &d->p[(size_t)i * S + D], *vj = &d->p[(size_t)j * S + D], g[3], g2 = 0;
			for (int a = 0; a < D; a++) {
				g[a] = vi[a] - vj[a];
				g2 += g[a] * g[a];
			}
			double r = rng_uniform_fast(&rng) * vmax;
			if (r * r >= g2)
				continue;
			double gm = sqrt(g2), gh[3], nrm[3], cth;
			for (int a = 0; a < D; a++)
				gh[a] = g[a] / gm;
			if (D == 2) {
				double bp = 2 * rng_uniform_fast(&rng) - 1;
				cth = sqrt(1 - bp * bp);
				nrm[0] = -bp * gh[1] - cth * gh[0];
				nrm[1] = bp * gh[0] - cth * gh[1];
			} else {
				double b1, b2, bb;
				do {
					b1 = 2 * rng_uniform_fast(&rng) - 1;
					b2 = 2 * rng_uniform_fast(&rng) - 1;
					bb = b1 * b1 + b2 * b2;
				} while (bb >= 1);
				cth = sqrt(1 - bb);
				double sg = gh[2] >= 0 ? 1.0 : -1.0, aa = -1 / (sg + gh[2]), bq = gh[0] * gh[1] * aa;
				double e1[3] = {1 + sg * gh[0] * gh[0] * aa, sg * bq, -sg * gh[0]};
				double e2[3] = {bq, sg + gh[1] * gh[1] * aa, -gh[1]};
				for (int a = 0; a < 3; a++)
					nrm[a] = b1 * e1[a] + b2 * e2[a] - cth * gh[a];
			}
			double dv = ehalf * gm * cth;
			for (int a = 0; a < D; a++) {
				vi[a] += dv * nrm[a];
				vj[a] -= dv * nrm[a];
			}
			ncoll++;
			virial += sigma * d->mass * dv;   /* (sigma n) . J, J = m dv n */
			double wi = 0, wj = 0;
			for (int a = 0; a < D; a++) {
				wi += (vi[a] - u[a]) * (vi[a] - u[a]);
				wj += (vj[a] - u[a]) * (vj[a] - u[a]);
			}
			if (wi > s2 || wj > s2) {
				s2 = wi > wj ? wi : wj;
				vmax = 2 * sqrt(s2);
				inv = 1 / vmax;
				nraise++;
			}
			if (d->cba && !(d->hsmc && nc >= d->nfull)) {   /* CBA: each partner one diameter along its momentum change (hsmc: not in a full cell) */
				double *xi = vi - D, *xj = vj - D;
				for (int a = 0; a < D; a++) {
					xi[a] = wrap(xi[a] + sigma * nrm[a], d->L[a]);
					xj[a] = wrap(xj[a] - sigma * nrm[a], d->L[a]);
				}
			}
		}
		d->rem[c] = (float)(b * vmax);
	energy:;
		/* the cell's kinetic energy after its collisions (still in cache): a
		 * double sum in the cell's order, rounded once to the fixed point */
		double e = 0;
		for (uint32_t k = k0; k < k0 + nc; k++)
			for (int a = 0; a < D; a++) {
				double v = d->p[(size_t)k * S + D + a];
				e += v * v;
			}
		if (e > 0)
			eacc += (unsigned __int128)(0.5 * d->mass * e * d->escale);
	}
	d->virial += virial;
	memset(part, 0, sizeof *part);
	for (int i = 0; i < 4; i++)
		part->w[DSMCP_EK0 + i] = (uint64_t)(eacc >> (32 * i)) & 0xffffffffu;
	part->w[DSMCP_COLL] = ncoll;
	part->w[DSMCP_CAND] = ncand;
	part->w[DSMCP_VMAX] = nraise;
	part->w[DSMCP_COUNT] = d->nl;
	part->w[DSMCP_MIGR] = d->step_migr;
	part->w[DSMCP_CELLC] = d->step_cellc;
	part->w[DSMCP_REJ] = d->step_rej;
	d->step_cellc = d->step_rej = 0;
}

void dsmcp_collide(dsmcp_t *d, double dt, dsmcp_sums_t *part)
{
	if (d->dim == 3)
		collide_d(d, dt, part, 3);
	else
		collide_d(d, dt, part, 2);
}

void dsmcp_initial_sums(const dsmcp_t *d, dsmcp_sums_t *part)
{
	const int D = d->dim, S = 2 * D;
	unsigned __int128 eacc = 0;
	memset(part, 0, sizeof *part);
	for (size_t c = 0; c < d->c1 - d->c0; c++) {
		double e = 0;
		for (uint32_t k = d->start[c]; k < d->start[c + 1]; k++)
			for (int a = 0; a < D; a++) {
				double v = d->p[(size_t)k * S + D + a];
				e += v * v;
			}
		if (e > 0)
			eacc += (unsigned __int128)(0.5 * d->mass * e * d->escale);
	}
	for (int i = 0; i < 4; i++)
		part->w[DSMCP_EK0 + i] = (uint64_t)(eacc >> (32 * i)) & 0xffffffffu;
	part->w[DSMCP_COUNT] = d->nl;
}

int dsmcp_start(dsmcp_t *d, const dsmcp_sums_t *sum)
{
	if (sum->w[DSMCP_COUNT] != d->n)
		return DSMCP_EINVAL;
	d->ekin = limbs_energy(d, &sum->w[DSMCP_EK0]);
	return DSMCP_OK;
}

void dsmcp_finish(dsmcp_t *d, const dsmcp_sums_t *sum, double dt, int last, double t_stop)
{
	d->ekin_int += d->ekin * dt;   /* the energy of this step's flight: the previous step's end */
	d->ekin = limbs_energy(d, &sum->w[DSMCP_EK0]);
	d->collisions += sum->w[DSMCP_COLL];
	d->candidates += sum->w[DSMCP_CAND];
	d->vmax_raised += sum->w[DSMCP_VMAX];
	d->migrated += sum->w[DSMCP_MIGR];
	d->cell_collisions += sum->w[DSMCP_CELLC];
	d->rejected += sum->w[DSMCP_REJ];
	d->moves += d->n;
	d->steps++;
	d->t = last ? t_stop : d->t + dt;
}

void dsmcp_interval(dsmcp_t *d, double *interval, double *ekin_int, double *virial)
{
	*interval = d->t - d->t_sample;
	*ekin_int = d->ekin_int;
	*virial = d->virial;
	d->t_sample = d->t;
	d->ekin_int = d->virial = 0;
}

/* ---- hsmc: cell-cell collisions ---------------------------------------------- */

int dsmcp_hsmc(const dsmcp_t *d) { return d->hsmc; }
int dsmcp_hs_width(const dsmcp_t *d) { return 1 + d->dim; }

size_t dsmcp_hs_cells(const dsmcp_t *d, double *buf)
{
	const int D = d->dim, S = 2 * D, W = 1 + D;
	const size_t nown = d->c1 - d->c0;
	for (size_t c = 0; c < nown; c++) {
		uint32_t k0 = d->start[c], n = d->start[c + 1] - k0;
		double *o = &buf[c * W], u[3] = {0, 0, 0};
		/* dsmc.c's cell_mean(): the same sums in the same order */
		for (uint32_t k = k0; k < k0 + n; k++)
			for (int a = 0; a < D; a++)
				u[a] += d->p[(size_t)k * S + D + a];
		for (int a = 0; a < D; a++)
			o[1 + a] = n ? u[a] / n : 0.0;
		o[0] = n;
	}
	return nown;
}

void dsmcp_hs_grid(dsmcp_t *d, const double *all)
{
	memcpy(d->gcm, all, d->plane * (size_t)d->nc[d->dim - 1] * (size_t)(1 + d->dim) * sizeof(double));
}

/* dsmc.c's cell_return() on own cell c (global): v' = u1 + k (v - u0), the
 * zero-momentum kick of a cell without thermal energy drawn from the
 * generator of (key, step, cell) of its own domain. */
static void cell_return(struct dsmcp *d, size_t c, const double *u0, const double *u1, double gain)
{
	const int D = d->dim, S = 2 * D;
	const uint32_t k0 = d->start[c - d->c0], n = d->start[c - d->c0 + 1] - k0;
	double eth = 0;
	for (uint32_t k = k0; k < k0 + n; k++)
		for (int a = 0; a < D; a++) {
			double w = d->p[(size_t)k * S + D + a] - u0[a];
			eth += w * w;
		}
	eth *= 0.5 * d->mass;
	double ref = 0;
	for (int a = 0; a < D; a++)
		ref += u0[a] * u0[a] + u1[a] * u1[a];
	ref *= 0.5 * d->mass * n;
	if (eth > 1e-12 * ref && eth > 0) {
		double kf = sqrt((eth + gain) / eth);
		for (uint32_t k = k0; k < k0 + n; k++)
			for (int a = 0; a < D; a++) {
				double *v = &d->p[(size_t)k * S + D + a];
				*v = u1[a] + kf * (*v - u0[a]);
			}
		return;
	}
	rng_t rng;
	cell_rng(&rng, d->key ^ 0x5851f42d4c957f2dull, d->steps, c);
	double w[3], s2 = 0;
	do {
		s2 = 0;
		for (int a = 0; a < D; a++) {
			w[a] = 2 * rng_uniform_fast(&rng) - 1;
			s2 += w[a] * w[a];
		}
	} while (s2 > 1 || s2 < 1e-6);
	double delta = sqrt(gain / d->mass / s2);
	for (uint32_t k = k0; k < k0 + n; k++)
		for (int a = 0; a < D; a++)
			d->p[(size_t)k * S + D + a] = u1[a] + (k == k0 ? delta * w[a] : k == k0 + 1 ? -delta * w[a] : 0);
}

static int own(const struct dsmcp *d, size_t c) { return c >= d->c0 && c < d->c1; }

/* An event: [cell, maker rank, kind (0 used, 1 claimed: u0, u1, gain follow), u0[3], u1[3], gain]. */
static void event(double *e, size_t c, int maker, int kind, const double *u0, const double *u1, double gain)
{
	memset(e, 0, DSMCP_HS_EVENT * sizeof(double));
	e[0] = (double)c;
	e[1] = maker;
	e[2] = kind;
	for (int a = 0; a < 3 && kind; a++) {
		e[3 + a] = u0[a];
		e[6 + a] = u1[a];
	}
	e[9] = gain;
}

int dsmcp_hs_turn(dsmcp_t *d, const double *in, size_t nin, const double **out, size_t *nout)
{
	const int D = d->dim, W = 1 + D;
	const uint32_t mark = (uint32_t)d->steps + 1;
	const int colour = (int)(d->steps & 1);
	const size_t nown = d->c1 - d->c0;
	size_t need = nin + 2 * nown + 1;
	if (need > d->ev_cap) {
		double *e = realloc(d->ev, need * DSMCP_HS_EVENT * sizeof(double));
		if (!e)
			return DSMCP_ENOMEM;
		d->ev = e;
		d->ev_cap = need;
	}
	if (nin)
		memmove(d->ev, in, nin * DSMCP_HS_EVENT * sizeof(double));
	size_t ne = nin;
	for (size_t i = 0; i < nin; i++) {   /* the ranks before: cells used, claims on ours */
		const double *e = &d->ev[i * DSMCP_HS_EVENT];
		size_t c = (size_t)e[0];
		d->gstamp[c] = mark;
		if (e[2] == 1 && own(d, c))
			cell_return(d, c, e + 3, e + 6, e[9]);
	}
	size_t stride[3] = {1, 1, 1};
	for (int a = 1; a < D; a++)
		stride[a] = stride[a - 1] * (size_t)d->nc[a - 1];
	for (size_t c = d->c0; c < d->c1; c++) {
		int ci[3] = {0, 0, 0};
		for (int a = 0; a < D; a++)
			ci[a] = (int)((c / stride[a]) % (size_t)d->nc[a]);
		const double *ga = &d->gcm[c * W];
		if (ga[0] < d->nfull || ((ci[0] + ci[1] + ci[2] + colour) & 1) || d->gstamp[c] == mark)
			continue;
		double ua[3] = {0, 0, 0}, best_u[3] = {0, 0, 0}, best_w = 0;
		for (int a = 0; a < D; a++)
			ua[a] = ga[1 + a];
		size_t best = c;
		int best_axis = 0, best_sign = 0;
		for (int a = 0; a < D; a++)
			for (int sgn = -1; sgn <= 1; sgn += 2) {
				int cj = ci[a] + sgn;
				cj = cj < 0 ? d->nc[a] - 1 : cj >= d->nc[a] ? 0 : cj;
				size_t nb = c + ((size_t)cj - (size_t)ci[a]) * stride[a];
				if (nb == c)
					continue;
				const double *gb = &d->gcm[nb * W];
				if (gb[0] < d->nfull || d->gstamp[nb] == mark)
					continue;
				double w = sgn * (ua[a] - gb[1 + a]);
				if (w > best_w) {
					best_w = w;
					best = nb;
					best_axis = a;
					best_sign = sgn;
					for (int b = 0; b < D; b++)
						best_u[b] = gb[1 + b];
				}
			}
		if (best == c)
			continue;
		const double na = ga[0], nb_n = d->gcm[best * W];
		double ma = na * d->mass, mb = nb_n * d->mass, mu = ma * mb / (ma + mb);
		double J = (1 + d->e) * mu * best_w;
		double ua1[3], ub1[3];
		memcpy(ua1, ua, sizeof ua1);
		memcpy(ub1, best_u, sizeof ub1);
		ua1[best_axis] -= best_sign * J / ma;
		ub1[best_axis] += best_sign * J / mb;
		double lost = 0.5 * (1 - d->e * d->e) * mu * best_w * best_w;
		cell_return(d, c, ua, ua1, lost * ma / (ma + mb));
		d->gstamp[c] = d->gstamp[best] = mark;
		event(&d->ev[ne++ * DSMCP_HS_EVENT], c, d->rank, 0, NULL, NULL, 0);
		if (own(d, best)) {
			cell_return(d, best, best_u, ub1, lost * mb / (ma + mb));
			event(&d->ev[ne++ * DSMCP_HS_EVENT], best, d->rank, 0, NULL, NULL, 0);
		} else {
			event(&d->ev[ne++ * DSMCP_HS_EVENT], best, d->rank, 1, best_u, ub1, lost * mb / (ma + mb));
		}
		d->step_cellc++;
	}
	*out = d->ev;
	*nout = ne;
	return DSMCP_OK;
}

void dsmcp_hs_final(dsmcp_t *d, const double *all, size_t n)
{
	for (size_t i = 0; i < n; i++) {   /* claims on our cells by the ranks after us */
		const double *e = &all[i * DSMCP_HS_EVENT];
		size_t c = (size_t)e[0];
		if (e[2] == 1 && e[1] > d->rank && own(d, c))
			cell_return(d, c, e + 3, e + 6, e[9]);
	}
}

/* ---- queries ---------------------------------------------------------------------- */

void dsmcp_totals(const dsmcp_t *d, dsmcp_totals_t *out)
{
	out->time = d->t;
	out->kinetic_energy = d->ekin;
	out->steps = d->steps;
	out->collisions = d->collisions;
	out->candidates = d->candidates;
	out->vmax_raised = d->vmax_raised;
	out->migrated = d->migrated;
	out->moves = d->moves;
	out->cell_collisions = d->cell_collisions;
	out->rejected = d->rejected;
}

size_t dsmcp_local(const dsmcp_t *d, uint64_t *ids, double *pos, double *vel)
{
	const int D = d->dim, S = 2 * D;
	for (size_t k = 0; k < d->nl; k++) {
		if (ids)
			ids[k] = d->id[k];
		for (int a = 0; a < D; a++) {
			if (pos)
				pos[k * D + a] = d->p[k * S + a];
			if (vel)
				vel[k * D + a] = d->p[k * S + D + a];
		}
	}
	return d->nl;
}

void dsmcp_momentum(const dsmcp_t *d, double *mom)
{
	const int D = d->dim, S = 2 * D;
	for (int a = 0; a < D; a++)
		mom[a] = 0;
	for (size_t k = 0; k < d->nl; k++)
		for (int a = 0; a < D; a++)
			mom[a] += d->mass * d->p[k * S + D + a];
}

void dsmcp_slab(const dsmcp_t *d, int *p0, int *p1, int nc[3])
{
	*p0 = d->p0;
	*p1 = d->p1;
	for (int a = 0; a < 3; a++)
		nc[a] = d->nc[a];
}

int dsmcp_dim(const dsmcp_t *d) { return d->dim; }

size_t dsmcp_memory(const dsmcp_t *d)
{
	const size_t S = 2 * (size_t)d->dim, nown = d->c1 - d->c0;
	const size_t ncells = d->plane * (size_t)d->nc[d->dim - 1];
	return sizeof *d + d->cap * (S * sizeof(double) + 2 * sizeof(uint32_t)) +
	       d->ring_cap * (S * sizeof(double) + sizeof(uint32_t)) + d->over_cap * (S * sizeof(double) + 2 * sizeof(uint32_t)) +
	       (nown + 1) * sizeof(uint32_t) + nown * sizeof(float) + d->out_cap * (S + 1) * sizeof(double) +
	       (size_t)d->nc[d->dim - 1] * sizeof(int) +
	       (d->hsmc ? ncells * ((1 + (size_t)d->dim) * sizeof(double) + sizeof(uint32_t)) : 0) + d->ev_cap * DSMCP_HS_EVENT * sizeof(double);
}

/* ---- checkpoints ------------------------------------------------------------------ */

void dsmcp_clock(const dsmcp_t *d, dsmcp_clock_t *c)
{
	c->time = d->t;
	c->kinetic_energy = d->ekin;
	c->energy_scale = d->escale;
	c->t_sample = d->t_sample;
	c->ekin_int = d->ekin_int;
	c->steps = d->steps;
	c->collisions = d->collisions;
	c->candidates = d->candidates;
	c->vmax_raised = d->vmax_raised;
	c->migrated = d->migrated;
	c->moves = d->moves;
	c->cell_collisions = d->cell_collisions;
	c->rejected = d->rejected;
}

void dsmcp_cells(const dsmcp_t *d, uint64_t *c0, uint64_t *c1)
{
	*c0 = d->c0;
	*c1 = d->c1;
}

void dsmcp_cell_state(const dsmcp_t *d, uint32_t *count, double *rem)
{
	for (size_t c = 0; c < d->c1 - d->c0; c++) {
		count[c] = d->start[c + 1] - d->start[c];
		rem[c] = d->rem[c];
	}
}

size_t dsmcp_local_ids(const dsmcp_t *d, uint32_t *ids)
{
	memcpy(ids, d->id, d->nl * sizeof(uint32_t));
	return d->nl;
}

double dsmcp_virial_part(const dsmcp_t *d) { return d->virial; }

/* The geometry a restored state is built on: the scene's (as the direct set-up). */
static int geometry(const scene_t *s, dsmc_geom_t *g, char *msg, size_t msglen)
{
	if (dsmcp_check(s, msg, msglen) != DSMCP_OK || dsmc_geometry_scene(s, g, msg, msglen) != DSMC_OK)
		return DSMCP_EINVAL;
	if (g->mix || g->bounded || g->local_chi || g->impact) {
		if (msg && msglen)
			snprintf(msg, msglen, "method: the scene uses a feature the decomposed dsmc does not support");
		return DSMCP_EINVAL;
	}
	return DSMCP_OK;
}

int dsmcp_cells_of(const scene_t *s, int rank, int ranks, uint64_t *c0, uint64_t *c1, uint64_t *ncells, char *msg,
                   size_t msglen)
{
	dsmc_geom_t g;
	if (ranks < 1 || rank < 0 || rank >= ranks || geometry(s, &g, msg, msglen) != DSMCP_OK)
		return DSMCP_EINVAL;
	const int D = g.dim, nz = g.nc[D - 1];
	uint64_t plane = 1;
	for (int a = 0; a < D - 1; a++)
		plane *= (uint64_t)g.nc[a];
	*c0 = (uint64_t)((int64_t)rank * nz / ranks) * plane;
	*c1 = (uint64_t)((int64_t)(rank + 1) * nz / ranks) * plane;
	*ncells = plane * (uint64_t)nz;
	return DSMCP_OK;
}

int dsmcp_saved_alloc(dsmcp_saved_t *sv, int dim, uint64_t n, uint64_t ncells)
{
	memset(sv, 0, sizeof *sv);
	sv->dim = dim;
	sv->n = n;
	sv->ncells = ncells;
	sv->pos = malloc((n ? n : 1) * (size_t)dim * sizeof(double));
	sv->vel = malloc((n ? n : 1) * (size_t)dim * sizeof(double));
	sv->id = malloc((n ? n : 1) * sizeof(uint32_t));
	sv->count = malloc((ncells ? ncells : 1) * sizeof(uint32_t));
	sv->rem = malloc((ncells ? ncells : 1) * sizeof(double));
	if (sv->pos && sv->vel && sv->id && sv->count && sv->rem)
		return DSMCP_OK;
	dsmcp_saved_free(sv);
	return DSMCP_ENOMEM;
}

void dsmcp_saved_free(dsmcp_saved_t *sv)
{
	free(sv->pos);
	free(sv->vel);
	free(sv->id);
	free(sv->count);
	free(sv->rem);
	sv->pos = sv->vel = sv->rem = NULL;
	sv->id = sv->count = NULL;
}

/* A remainder as the engine keeps it: a float, finite, not negative. */
static int rem_ok(double r) { return r >= 0 && isfinite(r) && (double)(float)r == r; }

int dsmcp_saved_check(const dsmcp_saved_t *sv, const scene_t *s, char *msg, size_t msglen)
{
	dsmc_geom_t g;
	const char *why = NULL;
	uint8_t *seen = NULL;
	if (geometry(s, &g, msg, msglen) != DSMCP_OK)
		return DSMCP_EINVAL;
	uint64_t ncells = 1, sum = 0;
	for (int a = 0; a < g.dim; a++)
		ncells *= (uint64_t)g.nc[a];
	const dsmcp_clock_t *c = &sv->clock;
	int ex = 0;
	if (sv->dim != g.dim || sv->n != g.n || sv->ncells != ncells)
		why = "the state's size does not fit the scene";
	else if (!(c->time >= 0) || !isfinite(c->time) || !(c->kinetic_energy >= 0) || !isfinite(c->kinetic_energy) ||
	         !(c->t_sample >= 0) || !(c->t_sample <= c->time) || !isfinite(c->ekin_int) || !isfinite(sv->virial) ||
	         !(c->energy_scale > 0) || !isfinite(c->energy_scale) || frexp(c->energy_scale, &ex) != 0.5 ||
	         c->moves != c->steps * sv->n)
		why = "the clock or the counters are inconsistent";
	for (uint64_t k = 0; !why && k < ncells; k++) {
		sum += sv->count[k];
		if (!rem_ok(sv->rem[k]))
			why = "a cell remainder is not a non-negative float";
	}
	if (!why && sum != sv->n)
		why = "the cell counts do not add up to the particles";
	if (!why && !(seen = calloc(sv->n ? sv->n : 1, 1))) {
		if (msg && msglen)
			snprintf(msg, msglen, "out of memory");
		return DSMCP_ENOMEM;
	}
	const int D = sv->dim;
	for (uint64_t i = 0; !why && i < sv->n; i++) {
		uint32_t id = sv->id[i];
		if (id >= sv->n || seen[id]++)
			why = "the identities are not a permutation";
		for (int a = 0; !why && a < D; a++) {
			double x = sv->pos[i * D + a], v = sv->vel[i * D + a];
			if (!(x >= 0 && x < g.L[a]) || !isfinite(v))
				why = "a particle is outside the box or has a non-finite velocity";
		}
	}
	free(seen);
	if (!why)
		return DSMCP_OK;
	if (msg && msglen)
		snprintf(msg, msglen, "%s", why);
	return DSMCP_EINVAL;
}

dsmcp_t *dsmcp_restore(const scene_t *s, uint64_t stream, int rank, int ranks, const dsmcp_clock_t *c, double virial,
                       size_t nl, const double *pos, const double *vel, const uint32_t *id, const uint32_t *count,
                       const double *rem, int *err, char *msg, size_t msglen)
{
	struct dsmcp *d = NULL;
	dsmc_geom_t g;
	*err = DSMCP_EINVAL;
	if (msg && msglen)
		msg[0] = '\0';
	if (ranks < 1 || rank < 0 || rank >= ranks) {
		if (msg && msglen)
			snprintf(msg, msglen, "run: rank %d of %d", rank, ranks);
		goto fail;
	}
	if (geometry(s, &g, msg, msglen) != DSMCP_OK)
		goto fail;
	*err = DSMCP_ENOMEM;
	if (!(d = make(s, &g, stream, rank, ranks)) || reserve(d, nl + 1) != DSMCP_OK)
		goto fail;
	*err = DSMCP_EINVAL;
	const int D = d->dim, S = 2 * D;
	const size_t nown = d->c1 - d->c0;
	uint64_t acc = 0;
	for (size_t q = 0; q < nown; q++) {
		d->start[q] = (uint32_t)acc;
		acc += count[q];
		if (acc > UINT32_MAX || !rem_ok(rem[q]))
			goto bad;
		d->rem[q] = (float)rem[q];
		for (uint64_t k = d->start[q]; k < acc && k < nl; k++)
			d->cell[k] = (uint32_t)q;
	}
	d->start[nown] = (uint32_t)acc;
	if (acc != nl)
		goto bad;
	for (size_t k = 0; k < nl; k++) {
		if (id[k] >= d->n)
			goto bad;
		for (int a = 0; a < D; a++) {
			double x = pos[k * D + a], v = vel[k * D + a];
			if (!(x >= 0 && x < d->L[a]) || !isfinite(v))
				goto bad;
			d->p[k * S + a] = x;
			d->p[k * S + D + a] = v;
		}
		d->id[k] = id[k];
	}
	d->nl = d->nown_nl = nl;
	d->nlow = 0;
	d->t = c->time;
	d->ekin = c->kinetic_energy;
	d->escale = c->energy_scale;
	d->t_sample = c->t_sample;
	d->ekin_int = c->ekin_int;
	d->steps = c->steps;
	d->collisions = c->collisions;
	d->candidates = c->candidates;
	d->vmax_raised = c->vmax_raised;
	d->migrated = c->migrated;
	d->moves = c->moves;
	d->cell_collisions = c->cell_collisions;
	d->rejected = c->rejected;
	d->virial = virial;
	*err = DSMCP_OK;
	return d;
bad:
	if (msg && msglen)
		snprintf(msg, msglen, "run: the saved state of rank %d's cells is inconsistent", rank);
fail:
	if (*err == DSMCP_ENOMEM && msg && msglen)
		snprintf(msg, msglen, "run: out of memory for the decomposed dsmc");
	dsmcp_destroy(d);
	return NULL;
}
