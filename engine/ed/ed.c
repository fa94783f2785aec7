/* Event-driven hard-sphere dynamics: setup, event queue, clock and the dimension dispatch. */
#define _DEFAULT_SOURCE   /* madvise(MADV_HUGEPAGE) */
#include <math.h>
#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/mman.h>

#include "ed.h"
#include "rng.h"
#include "lattice.h"
#include "walltime.h"
#include "obstacle.h"
#include "rough.h"

/* Hot particle record: everything a neighbour scan touches, one cache line
 * in 3D. Position r is valid at the particle's own time t (lazy update).
 * next: cell-list link in cell mode (see link() in ed_impl.h). */
typedef struct { double r[2], v[2], t; int32_t next; uint32_t count; } p2_t;
typedef struct { double r[3], v[3], t; int32_t next; uint32_t count; } p3_t;

/* Cold per-particle event data: the next collision (partner and the
 * partner's collision counter at prediction time, for lazy invalidation)
 * and the next cell crossing; the particle's event is the earlier one. */
typedef struct {
	double t_coll, t_cross;
	int32_t partner;   /* -1: no collision predicted */
	uint32_t pcount;
	int32_t cross;     /* 2*axis + (direction > 0) */
	int32_t cc[3];     /* cell coordinates */
} ev_t;

typedef struct { double t; uint32_t i; } hent_t;

/* A particle's place in the event calendar, in one record: a calendar
 * operation touches one line of the particle (the queued time is here too,
 * so moving a bucket into the heap reads no event record). */
typedef struct {
	double t;          /* queued event time */
	int32_t slot;      /* -1: in the heap; 0..cal_m-1: ring bucket; cal_m: overflow */
	int32_t next, prev;   /* bucket list */
	uint32_t hpos;     /* heap slot while in the heap */
} cnode_t;

/* A wall (method ed, scenes with boundaries): its rule's parameters from
 * the scene, its place in internal coordinates and its phase (state). Wall
 * w = 2 axis + side (0: lower end, 1: upper end); its inward normal is +axis
 * (lower) or -axis (upper), and it is displaced along it by A sin(theta). */
typedef struct {
	int type;              /* SCENE_WALL_* */
	double r;              /* normal restitution */
	double sv;             /* thermal: sqrt(T_w / m) */
	double acc;            /* thermal: accommodation */
	double p;              /* rough: probability of reversing the tangential velocity */
	double u[3];           /* moving, thermal: velocity (in the wall's plane) */
	double beta;           /* moving: tangential restitution */
	double A, omega, phase0;   /* vibrating (A = 0: fixed) */
	double ph;             /* state: theta at local time 0 (rebased with the clock) */
	double rest;           /* internal coordinate of the wall plane at rest */
	double vmin;           /* minimum rebound (normal speed relative to the wall) with TC; 0 without */
	/* Dispenser (a piston; 0 for other walls): the plane is displaced along
	 * the inward normal by pu (t - pt0), t local; pu is 0 during the
	 * elastic pre-run (the piston stands at rest) and pspeed after. */
	double pu, pt0;        /* speed now; state: local time of the last recharge (the piston at rest) */
	double pspeed, lh;     /* the piston's speed (the velocity's inward normal component); layer thickness h */
} wall_t;

/* Event codes in ev_t.cross at and above this: a wall (ED_WALL0 + w);
 * at and above ED_OBST0: an obstacle (ED_OBST0 + k). */
enum { ED_WALL0 = 8, ED_OBST0 = 16 };
/* ... and at and above ED_FILT0: the filter plane of wall w (ED_FILT0 + w). */
enum { ED_FILT0 = ED_OBST0 + SCENE_OBSTACLES_MAX };

/* An obstacle (walls variants): a fixed disk/sphere, its rule from the
 * scene, its centre in internal coordinates. */
typedef struct {
	int type;              /* SCENE_OBST_* */
	double c[3];           /* centre (internal coordinates) */
	double S;              /* contact distance: obstacle radius + particle radius */
	double r;              /* normal restitution */
	double sv;             /* no_slip: sqrt(T_o / m) */
	double acc;            /* no_slip: accommodation */
	double vmin;           /* minimum rebound with TC (against gravity); 0 without */
} obst_t;

enum { NL_KMAX = 32 };   /* largest neighbour-list capacity (setup_mode) */
/* Cell scans consult the occupancy bitmap above this many cells (heads of
 * 512 KiB and more: out of a core's L2 cache). */
enum { OCC_MIN_CELLS = 1 << 17 };

struct ed_ops;

struct ed {
	int dim;
	uint32_t n;
	double L[3], halfL[3];    /* internal box (walled axes: + vibration amplitudes); halfL = INFINITY on walled axes */
	double sigma, sigma2, mass, e, tc;
	int32_t nc[3];
	double cw[3];
	int no[3], off[3][3];     /* neighbour-cell offsets per axis (deduplicated when nc < 3) */
	int minimg;               /* some axis has < 3 cells: neighbour images need minimum image */
	size_t ncells;
	int32_t *head;            /* first particle of each cell, -1 if empty */
	uint64_t *occ;            /* bit c set: cell c is not empty */
	int32_t *next;            /* neighbour-list mode: next particle in the same cell, -1 at the end */
	/* Neighbour-list mode (dense systems): each particle lists the particles
	 * whose build positions xn lie within nl_r of its own; a particle is
	 * rebuilt when it drifts nl_d from xn, so a pair not listed stays apart
	 * (nl_r - 2 nl_d >= sigma). Lists are symmetric. Cells then hold
	 * particles by build position and there are no crossing events; ev.t_cross
	 * is the rebuild time. */
	int nl, nl_over;          /* mode on; some list overflowed (leave the mode) */
	uint32_t nlk;             /* list capacity */
	double nl_r2, nl_d2;
	double *xn;               /* build positions, n*dim */
	int32_t *nb;              /* lists, n*nlk */
	uint8_t *nn;              /* list lengths */
	uint8_t *mark;            /* all 0 between events; scratch of a list rebuild */
	void *p;                  /* p2_t[n] or p3_t[n] */
	ev_t *ev;
	double *tlast;            /* last collision time per particle; only with the TC model */
	uint32_t *id;             /* scene index of each particle (storage is in cell order) */
	/* buffers for the periodic renumbering in cell order */
	uint32_t *scratch_idx, *scratch_cell;
	/* Event calendar: a ring of cal_m buckets of width cal_w (bucket number
	 * floor(t / cal_w)) holding unsorted lists, an overflow list for events
	 * beyond the ring, and a binary min-heap on (time, particle) for the
	 * current bucket cal_cur and earlier. Invariant: every event in the heap
	 * has bucket <= cal_cur, every other one > cal_cur, so the heap's top is
	 * the next event in (time, index) order. */
	hent_t *heap;
	uint32_t hn;              /* events in the heap */
	cnode_t *cn;              /* per particle */
	int32_t *cal_head;        /* first of each bucket list (cal_m + 1: the overflow list) */
	uint32_t cal_m, cal_ring; /* ring size (a power of two); events in ring lists */
	int64_t cal_cur;
	double cal_w, cal_iw;
	int32_t cal_pf;           /* cache hint only: next bucket's list, one particle per event */
	double t;                 /* clock since the last rebase */
	double epoch, epoch_c;    /* absolute time of the last rebase (compensated sum) */
	/* When ed_advance() stopped at t_stop, the absolute clock is exactly
	 * t_stop (epoch + (t_stop - epoch) need not round back to it, and a
	 * caller waiting for t >= t_stop would wait forever). Cleared by the
	 * next event. */
	double t_abs;
	int t_abs_valid;
	uint64_t events, collisions, tc_elastic, since_rebase, rebase_every;
	/* interval accumulators for ed_sample() */
	double ekin_cur, ekin_int, t_mark, t_int0, virial;
	uint64_t coll_int0;
	/* Inelastic-collapse watch (ed_watch_collapse()): not state, the run
	 * ends when it fires. */
	double collapse_rate;     /* limit at T = 1, events per particle per unit time; 0: off */
	ed_collapse_t collapse;   /* the window that fired */
	/* The kernels of this scene's variant (dimension, walls, gravity),
	 * chosen once; at the end, so that the hot fields above keep the
	 * periodic engine's layout. */
	const struct ed_ops *ops;
	int variant;              /* 0 periodic homogeneous, 1 walls, 2 gravity (and maybe walls) */
	int open;                 /* some wall is open (particles leave) */
	/* Walls and gravity (variants 1, 2; unused in 0). Internal coordinates
	 * on a walled axis are the scene's plus org (the lower wall's
	 * amplitude), so that a vibrating wall never leaves [0, L]. */
	int periodic[3];
	double org[3];
	double plo[3], phi[3];     /* where particle centres can be placed at the start */
	double radius;
	double g[3];
	wall_t wall[6];
	int32_t nzone[6];         /* cells from its end in which a particle can meet wall w */
	int relaxing;             /* the elastic pre-run: walls specular, elastic, fixed */
	double wimp[6][3];        /* momentum given to each wall over the output interval */
	double wimp_tot[6][3];    /* ... since the start of the production run */
	uint64_t whits[6], wall_collisions;
	rng_t wrng;               /* thermal and rough walls */
	double psum[3];           /* sum of the velocities at t_mark (gravity: energy bookkeeping) */
	double *bcount;           /* ed_count_impacts(): impact-parameter histogram, or NULL */
	int bnb;
	/* Obstacles (walls variants only; nobst = 0 and ocell NULL without):
	 * ocell[c] has bit k set when a particle centred in cell c can touch
	 * obstacle k (its contact sphere meets the cell). */
	int nobst;
	obst_t obst[SCENE_OBSTACLES_MAX];
	uint16_t *ocell;
	double oimp[SCENE_OBSTACLES_MAX][3];      /* momentum given to each obstacle over the output interval */
	double oimp_tot[SCENE_OBSTACLES_MAX][3];  /* ... since the start of the production run */
	uint64_t ohits[SCENE_OBSTACLES_MAX], obst_collisions;
	/* Open walls (walls variants only; gone NULL without): gone[i] = 1 once
	 * particle i has left (out of the cell lists, no events, velocity 0). */
	uint8_t *gone;
	uint64_t n_gone;
	uint64_t wout[6];         /* particles out through each wall (total) */
	/* Rough particles (ROUGH kernels; collisions.rough): spins, one per
	 * particle in 2D (about z), three in 3D, in storage order like the
	 * records; the tangential rule's constants. NULL / 0 for smooth scenes. */
	double *spin;
	int rough;
	double rbeta;             /* tangential restitution beta (Walton: beta_0), -1..1 */
	double rmu;               /* Coulomb friction mu of Walton's rule; < 0: constant beta */
	double rq;                /* moment of inertia factor q: I = q m (sigma/2)^2 */
	/* Driving (scene "driving"; drive_* below): kicks of random particles
	 * at Poisson times (rate N / interval), outside the event loop. */
	int drive;                /* 0 none, SCENE_DRIVE_* */
	double drv_interval, drv_temp, drv_xi2, drv_tavg;
	double drv_box[3];        /* the scene's box: positions of kick_get() lie in it */
	int drv_grid[3];
	size_t drv_bins;
	double *drv_mean;         /* state: per bin, the running mean velocity (dim each) */
	double *drv_sum;          /* scratch: per bin, velocity sums and count (dim + 1 each) */
	double *drv_pos, *drv_vel;   /* scratch (grids of more than one bin): positions, velocities */
	double drv_next[2];       /* state: absolute times of the next kick and of the next mean update */
	uint64_t drv_kicks[1];    /* state: kicks so far */
	rng_t drng;               /* state: the driving's random stream */
	/* Mixtures (SPEC kernels; scene_has_species(): two or more species or
	 * polydisperse radii; any variant, smooth or rough): spc[i] the species and
	 * prad[i] the radius of particle i in storage order (permuted with the
	 * records by reorder(), rebuilt from id on restore: not state fields of
	 * their own); species k holds the scene indices [first[k], first[k + 1]).
	 * mixture = 0, nsp = 1 and spc, prad, mix NULL for one species. */
	int nsp, mixture;
	uint8_t *spc;
	double *prad;
	struct ed_mix *mix;
	/* Reservoir walls (walls variants; scene_has_reservoir(); inlet = 0
	 * and the arrays NULL without): the n slots hold the particles present
	 * and the empty slots (gone), which form the stack freei (its n_gone
	 * entries, storage indices, remapped by reorder()); label[row] is the
	 * unique id of the particle in row (scene index) row, -1 when empty.
	 * Entries come at Poisson times per reservoir wall (inlet_* below). */
	int inlet;
	uint32_t n_init;          /* particles placed at the start (slots n_init.. start empty) */
	uint32_t *freei;          /* state: empty slots, a stack of n_gone storage indices */
	int64_t *label;           /* state: per row, the particle's id or -1 */
	double in_next[6];        /* state: absolute time of each wall's next entry (INFINITY: not a reservoir) */
	uint64_t in_count[13];    /* state: entered per wall [0..5], rejected per wall [6..11], next id [12] */
	rng_t irng;               /* state: the entries' random stream */
	double in_rate[6];        /* entries per unit time: F_+ times the face area */
	double in_a[6], in_s[6];  /* mean inward normal velocity U_n; thermal speed sqrt(T / m) */
	double in_u[6][3];        /* the reservoir's velocity */
	double in_cum[6][SCENE_SPECIES_MAX];   /* mixtures: species k's share of wall w's rate, cumulative */
	double in_sk[6][SCENE_SPECIES_MAX];    /* mixtures: species k's thermal speed sqrt(T / m_k) */
	/* Seed 001's open stream (walls variant; frozen NULL, nfilt 0 and no
	 * dispenser without). Filters: frozen[i] = 1 + w once particle i has
	 * crossed the filter plane of wall w (fplane, internal coordinate) going
	 * out: from then on it moves at fu[w] exactly, with infinite mass,
	 * until it leaves through the wall (0 for a regular particle or an
	 * empty slot). filt_on: filters act (not during the elastic pre-run).
	 * Dispensers (disp: bit w set for a dispenser at wall w; wall_t pu,
	 * pt0): each recharge of wall w places one of its ntpl template layers
	 * (tpl + tpl_off[w]: ntpl x tpl_n[w] positions of D coordinates in the
	 * layer's frame: normal coordinate in [r, h - r] from the piston,
	 * transverse in the box), built at load from the scene (not state). */
	uint8_t *frozen;
	int nfilt, filt_on, disp;
	double fplane[6];
	double fu[6][3];
	double fback[6], fsv[6];  /* turn-back probability F_- / F_+ at the plane (0: none), thermal speed sqrt(T / m) */
	int32_t fcell[6];         /* the cell of the plane (one more towards the inside) */
	uint64_t nfrozen[6];      /* state (in "frozen_counts"): particles frozen per filter wall */
	int ntpl;
	uint32_t tpl_n[6];        /* particles in a template layer of wall w: ceil(eta h W / v_p) */
	double tpl_frac[6];       /* a recharge places tpl_n, or tpl_n - 1 with probability 1 - tpl_frac (mean eta h W / v_p) */
	size_t tpl_off[6];        /* wall w's templates in tpl (doubles) */
	double *tpl;
	double disp_u[6][3], disp_s[6];   /* layer velocity U and thermal speed sqrt(T / m) per dispenser wall */
	/* mean_square_displacement with an energy feed (scene_msd_images()): the periodic images each particle
	 * crossed, img[id * dim + a] (scene order: renumbering leaves it alone), counted where a position is
	 * wrapped (do_cross, nl_rebuild, resync: a wrap, not every event, tests it); NULL otherwise */
	int img_on;
	int32_t *img;
	/* Filters under gravity (the FILTG kernels; derived, not state: frozen_tally() after a restore):
	 * frozen particles present per wall, in all, and the sum of their (constant) velocities. Last in
	 * the struct: the other kernels' field offsets stay as they were. */
	uint64_t nfzw[6], nfz;
	double fzv[3];
	/* mixtures (the FILTG species kernels): the frozen particles present per wall and species, and
	 * their mass over the mean mass (fzv then sums (m_k / m) U: psum's weighting) */
	uint64_t nfzk[6][SCENE_SPECIES_MAX];
	double nfzm;
	/* dispensers on several axes: per dispenser wall w the bit set of the other axes' dispenser walls
	 * (a layer particle behind one of their pistons is not placed: layer_behind()); 0 for all with
	 * dispensers on one axis only */
	int dclip[6];
	/* per dispenser wall w the bit set of the other axes' filter walls (a layer particle beyond one of
	 * their planes is placed frozen: layer_frozen()); 0 for all without such a pair */
	int fclip[6];
#ifdef ED_TRACE
	ed_trace_fn trace;        /* bench-only build (ed.h, "Event trace"): called before each event */
	void *trace_ctx;
#endif
};

/* Per ordered pair of species q = a * nsp + b: restitution, the share
 * m_b / (m_a + m_b) of the velocity change that falls on a, the reduced
 * mass; and every particle's radius in scene order (scene_species_radii()). */
struct ed_mix {
	uint32_t first[SCENE_SPECIES_MAX + 1];
	double m[SCENE_SPECIES_MAX];
	double e[SCENE_SPECIES_MAX * SCENE_SPECIES_MAX], w[SCENE_SPECIES_MAX * SCENE_SPECIES_MAX];
	double mu[SCENE_SPECIES_MAX * SCENE_SPECIES_MAX];
	double *rscene;
	/* the particles present per species and their mass (mix_present(): from the counts, so the same
	 * numbers however they were reached; rebuilt on restore) */
	uint64_t npres[SCENE_SPECIES_MAX];
	double mpres;
	/* Dispensers (scene_row_species()): rsp[row] the species of each row
	 * (slot) in scene order, fixed; rscene covers the slots too. The free
	 * slots form one stack per species: species k's fs_n[k] entries at
	 * freei + fs_off[k] (fs_off: the rows of species < k), fs_n rebuilt
	 * from gone on restore (not a field of its own). The templates' species
	 * (tsp, parallel to tpl: one per template particle) and per wall and
	 * species the most any template holds (tmax: a recharge needs that
	 * many free slots). Filters: the turn-back probability and thermal
	 * speed per wall and species (the species' mass). */
	uint8_t *rsp, *tsp;
	uint32_t fs_off[SCENE_SPECIES_MAX], fs_n[SCENE_SPECIES_MAX];
	uint32_t tmax[6][SCENE_SPECIES_MAX];
	double fback[6][SCENE_SPECIES_MAX], fsv[6][SCENE_SPECIES_MAX];
	double dsv[6][SCENE_SPECIES_MAX];   /* a dispenser's layer thermal speed sqrt(T / m_k) */
	unsigned poly;            /* bit k: species k is polydisperse (a layer particle takes a free slot at random) */
};

static inline bool hless(const hent_t *a, const hent_t *b)
{
	return a->t < b->t || (a->t == b->t && a->i < b->i);
}

static void heap_down(struct ed *ed, uint32_t k)
{
	hent_t *h = ed->heap, x = h[k];
	uint32_t n = ed->hn;
	for (;;) {
		uint32_t c = 2 * k + 1;
		if (c >= n)
			break;
		if (c + 1 < n && hless(&h[c + 1], &h[c]))
			c++;
		if (!hless(&h[c], &x))
			break;
		h[k] = h[c];
		ed->cn[h[k].i].hpos = k;
		k = c;
	}
	h[k] = x;
	ed->cn[x.i].hpos = k;
}

static void heap_up(struct ed *ed, uint32_t k)
{
	hent_t *h = ed->heap, x = h[k];
	while (k > 0) {
		uint32_t p = (k - 1) / 2;
		if (!hless(&x, &h[p]))
			break;
		h[k] = h[p];
		ed->cn[h[k].i].hpos = k;
		k = p;
	}
	h[k] = x;
	ed->cn[x.i].hpos = k;
}

static inline double ev_time(const struct ed *ed, uint32_t i)
{
	return ed->ev[i].t_coll <= ed->ev[i].t_cross ? ed->ev[i].t_coll : ed->ev[i].t_cross;
}

static void heap_push(struct ed *ed, uint32_t i, double t)
{
	uint32_t k = ed->hn++;
	ed->heap[k].t = t;
	ed->heap[k].i = i;
	ed->cn[i].slot = -1;
	ed->cn[i].t = t;
	heap_up(ed, k);
}

/* Bucket of time t if it is within the ring (bucket < cal_cur + cal_m),
 * else -1 (overflow; also INFINITY). */
static inline int64_t cal_bucket(const struct ed *ed, double t)
{
	double f = t * ed->cal_iw;
	return f < (double)(ed->cal_cur + ed->cal_m) ? (int64_t)f : -1;
}

static void cal_insert(struct ed *ed, uint32_t i, double t)
{
	int64_t b = cal_bucket(ed, t);
	if (b >= 0 && b <= ed->cal_cur) {
		heap_push(ed, i, t);
		return;
	}
	int32_t s = b < 0 ? (int32_t)ed->cal_m : (int32_t)(b & (ed->cal_m - 1)), h = ed->cal_head[s];
	cnode_t *c = &ed->cn[i];
	c->t = t;
	c->slot = s;
	c->prev = -1;
	c->next = h;
	if (h >= 0)
		ed->cn[h].prev = (int32_t)i;
	ed->cal_head[s] = (int32_t)i;
	ed->cal_ring += b >= 0;
}

static void cal_remove(struct ed *ed, uint32_t i)
{
	int32_t s = ed->cn[i].slot;
	if (s < 0) {
		uint32_t k = ed->cn[i].hpos;
		hent_t last = ed->heap[--ed->hn];
		if (k < ed->hn) {
			double old = ed->heap[k].t;
			ed->heap[k] = last;
			ed->cn[last.i].hpos = k;
			if (last.t < old || (last.t == old && last.i < i))
				heap_up(ed, k);
			else
				heap_down(ed, k);
		}
		return;
	}
	int32_t p = ed->cn[i].prev, n = ed->cn[i].next;
	if (p >= 0) ed->cn[p].next = n; else ed->cal_head[s] = n;
	if (n >= 0) ed->cn[n].prev = p;
	ed->cal_ring -= s < (int32_t)ed->cal_m;
}

/* New event time of particle i. */
static inline void cal_update(struct ed *ed, uint32_t i, double t)
{
	if (ed->cn[i].slot < 0) {
		int64_t b = cal_bucket(ed, t);
		if (b >= 0 && b <= ed->cal_cur) {
			uint32_t k = ed->cn[i].hpos;
			double old = ed->heap[k].t;
			ed->heap[k].t = t;
			ed->cn[i].t = t;
			if (t < old)
				heap_up(ed, k);
			else if (t > old)
				heap_down(ed, k);
			return;
		}
	}
	cal_remove(ed, i);
	cal_insert(ed, i, t);
}

/* Make the heap's top the next event: walk the ring to the next non-empty
 * bucket (pulling overflow events in at each lap); with nothing left in
 * the ring, jump to the earliest overflow event. Returns its time
 * (INFINITY: no event left). */
static double cal_next_time(struct ed *ed)
{
	while (ed->hn == 0) {
		if (ed->cal_ring == 0) {
			double tmin = INFINITY;
			for (int32_t j = ed->cal_head[ed->cal_m]; j >= 0; j = ed->cn[j].next) {
				double t = ed->cn[j].t;
				if (t < tmin) tmin = t;
			}
			if (tmin == INFINITY)
				return INFINITY;
			double f = tmin * ed->cal_iw;
			/* beyond any bucket number: everything goes through the heap */
			ed->cal_cur = f < 4e18 ? (int64_t)f : (int64_t)4e18;
		} else {
			ed->cal_cur++;
			int32_t s = (int32_t)(ed->cal_cur & (ed->cal_m - 1));
			int32_t j = ed->cal_head[s];
			ed->cal_head[s] = -1;
			while (j >= 0) {
				int32_t nx = ed->cn[j].next;
				ed->cal_ring--;
				heap_push(ed, (uint32_t)j, ed->cn[j].t);
				j = nx;
			}
			/* The next bucket's list is a chain of cache misses when it is
			 * pulled in: walk it ahead, one link per event (cal_prefetch). */
			ed->cal_pf = ed->cal_head[(s + 1) & (int32_t)(ed->cal_m - 1)];
			if (ed->cal_pf >= 0)
				__builtin_prefetch(&ed->cn[ed->cal_pf]);
			if (s != 0)
				continue;
		}
		/* a new lap (or a jump): overflow events now in reach move in */
		int32_t j = ed->cal_head[ed->cal_m];
		ed->cal_head[ed->cal_m] = -1;
		while (j >= 0) {
			int32_t nx = ed->cn[j].next;
			cal_insert(ed, (uint32_t)j, ed->cn[j].t);
			j = nx;
		}
	}
	return ed->heap[0].t;
}

/* One step of the walk ahead along the next bucket's list (the record
 * asked for one event ago has arrived by now). A hint only: the list may
 * have changed meanwhile; links are always valid indices or -1. */
static inline void cal_prefetch(struct ed *ed)
{
	if (ed->cal_pf >= 0) {
		ed->cal_pf = ed->cn[ed->cal_pf].next;
		if (ed->cal_pf >= 0)
			__builtin_prefetch(&ed->cn[ed->cal_pf]);
	}
}

/* Calendar from scratch at time 0 (after a rebase or a full prediction):
 * buckets a few events wide, the ring spanning a few mean event delays. */
static void cal_build(struct ed *ed)
{
	double sum = 0.0;
	uint32_t fin = 0;
	for (uint32_t i = 0; i < ed->n; i++) {
		double t = ev_time(ed, i);
		if (t < INFINITY) {
			sum += t;
			fin++;
		}
	}
	double w = fin ? 4.0 * sum / fin / ed->n : 0.0;   /* ~4 events a bucket (2..8 measured alike) */
	if (!(w > 0.0) || !isfinite(1.0 / w))
		w = 1.0;
	ed->cal_w = w;
	ed->cal_iw = 1.0 / w;
	ed->cal_cur = 0;
	ed->cal_ring = 0;
	ed->cal_pf = -1;
	ed->hn = 0;
	for (uint32_t s = 0; s <= ed->cal_m; s++)
		ed->cal_head[s] = -1;
	for (uint32_t i = 0; i < ed->n; i++)
		cal_insert(ed, i, ev_time(ed, i));
}

static void nl_abandon(struct ed *ed);

/* All cells empty. */
static void cells_clear(struct ed *ed)
{
	for (size_t c = 0; c < ed->ncells; c++)
		ed->head[c] = -1;
	memset(ed->occ, 0, (ed->ncells + 63) / 64 * sizeof(uint64_t));
}

/* Move row i of n rows of size bytes to row newidx[i], in place by
 * following the permutation's cycles (the top bit of newidx marks rows done
 * and is cleared again). */
static void permute(void *base, size_t size, uint32_t *newidx, uint32_t n)
{
	const uint32_t done = 0x80000000u;
	_Alignas(64) unsigned char a[1024], b[1024];
	char *p = base;
	for (uint32_t s = 0; s < n; s++) {
		if (newidx[s] & done)
			continue;
		memcpy(a, p + s * size, size);
		uint32_t cur = s;
		do {
			uint32_t dst = newidx[cur];
			newidx[cur] |= done;
			memcpy(b, p + dst * size, size);
			memcpy(p + dst * size, a, size);
			memcpy(a, b, size);
			cur = dst;
		} while (cur != s);
	}
	for (uint32_t s = 0; s < n; s++)
		newidx[s] &= ~done;
}

static void epoch_add(struct ed *ed, double t)
{
	/* Kahan summation: the absolute clock keeps its digits over many rebases. */
	double y = t - ed->epoch_c, s = ed->epoch + y;
	ed->epoch_c = (s - ed->epoch) - y;
	ed->epoch = s;
}

double ed_time(const ed_t *ed) { return ed->t_abs_valid ? ed->t_abs : ed->epoch + ed->t; }

/* Called after each rebase with dt, the time the last rebase_every events
 * took: an event rate beyond collapse_rate sqrt(T) is an inelastic collapse
 * (ed.h, ed_watch_collapse()). Once per 8N events, O(1); in a collapse dt
 * may be exactly 0. */
static bool collapse_check(struct ed *ed, double dt)
{
	if (!(ed->collapse_rate > 0.0))
		return false;
	/* (with open walls N counts the particles that left too, which makes
	 * the limit higher by sqrt(N / present): a looser watch; kept so that
	 * the periodic event loop's code stays as it was) */
	double temp = fmax(2.0 * ed->ekin_cur / (ed->dim * (double)ed->n), 0.0);
	if (2.0 * (double)ed->rebase_every <= ed->collapse_rate * sqrt(temp) * (double)ed->n * dt)
		return false;
	ed->collapse = (ed_collapse_t){.time = ed_time(ed), .interval = dt, .events = ed->rebase_every,
	                               .temperature = temp};
	return true;
}

/* Velocity v (dim components) of a particle meeting wall w at local time t,
 * by the wall's rule; elastic: the TC model makes the normal restitution 1.
 * Normal components are relative to the wall's own velocity. A rebound
 * slower than the wall's vmin (TC scenes: a particle resting on a wall, or
 * carried by a vibrating one) is raised to vmin: then two hits of one
 * particle on one wall are at least tc apart and no bed collapses
 * (docs/engine.md, "Walls and gravity"). */
static void wall_rule(struct ed *ed, int w, double *v, double t, int elastic, double svs)
{
	const wall_t *W = &ed->wall[w];
	const int a = w >> 1, dim = ed->dim;
	const double s = (w & 1) ? -1.0 : 1.0;
	const double un = W->A != 0.0 ? W->A * W->omega * cos(W->ph + W->omega * t) : W->pu;   /* pu: a dispenser's piston */
	double vn = s * v[a] - un;   /* < 0: approaching */
	if (ed->relaxing) {
		if (vn < 0.0)
			vn = -vn;
		v[a] = s * (un + vn);
		return;
	}
	if (vn < 0.0) {
		const double r = elastic ? 1.0 : W->r;
		switch (W->type) {
		case SCENE_WALL_THERMAL:
			if (rng_uniform(&ed->wrng) < W->acc) {
				/* diffuse: the flux-weighted Maxwellian of the wall, moving
				 * with it (Rayleigh normal, Gaussian tangential about u) */
				const double sv = W->sv * svs;
				vn = sv * sqrt(-2.0 * log(1.0 - rng_uniform(&ed->wrng)));
				for (int k = 0; k < dim; k++)
					if (k != a)
						v[k] = W->u[k] + sv * rng_gauss(&ed->wrng);
			} else {
				vn = -r * vn;
			}
			break;
		case SCENE_WALL_ROUGH:
			vn = -r * vn;
			if (rng_uniform(&ed->wrng) < W->p)
				for (int k = 0; k < dim; k++)
					if (k != a)
						v[k] = -v[k];
			break;
		case SCENE_WALL_MOVING:
			vn = -r * vn;
			for (int k = 0; k < dim; k++)
				if (k != a)
					v[k] = W->u[k] - W->beta * (v[k] - W->u[k]);
			break;
		default:
			vn = -r * vn;
			break;
		}
	}
	if (vn < W->vmin && ed->tlast)
		vn = W->vmin;
	v[a] = s * (un + vn);
}

/* The clock moves its origin by t: wall phases follow (reduced mod 2 pi). */
static void walls_rebase(struct ed *ed, double t)
{
	for (int w = 0; w < 6; w++) {
		if (ed->wall[w].A != 0.0)
			ed->wall[w].ph = fmod(ed->wall[w].ph + ed->wall[w].omega * t, 6.28318530717958647692);
		if (ed->wall[w].type == SCENE_WALL_DISPENSER)   /* the piston's recharge time, local */
			ed->wall[w].pt0 -= t;
	}
}

/* Velocity v (dim components) of a particle meeting obstacle k with unit
 * normal nrm (from the obstacle's centre to the particle's) by the
 * obstacle's rule (scene.h); elastic: the TC model makes the restitution 1.
 * Like walls, a rebound slower than vmin (TC scenes with gravity: a
 * particle resting on an obstacle) is raised to it. */
static void obst_rule(struct ed *ed, int k, const double *nrm, double *v, int elastic, double svs)
{
	const obst_t *O = &ed->obst[k];
	obstacle_rule(O->type, elastic ? 1.0 : O->r, O->acc, O->sv * svs, ed->tlast ? O->vmin : -INFINITY, ed->relaxing, nrm, v,
	              ed->dim, &ed->wrng);
}

/* Whether a particle centred at r (internal coordinates) is clear of
 * every obstacle (at least the contact distance from each centre). */
static int obst_clear(const struct ed *ed, const double *r)
{
	for (int k = 0; k < ed->nobst; k++) {
		double r2 = 0.0;
		for (int a = 0; a < ed->dim; a++) {
			double x = r[a] - ed->obst[k].c[a];
			if (ed->periodic[a])
				x -= ed->L[a] * nearbyint(x / ed->L[a]);
			r2 += x * x;
		}
		if (r2 < ed->obst[k].S * ed->obst[k].S)
			return 0;
	}
	return 1;
}

static double inlet_normal(rng_t *g, double a, double s);

/* Filters: particle velocity v (dim components) crossing the filter plane
 * of wall w outwards. With a filter temperature T, seed 001's turn-back
 * first: with probability F_- / F_+ (eq. 3.15-3.18 at the filter's
 * outward speed U and T) the particle is sent back with the flux-weighted
 * velocity of a gas at (U, T) crossing the plane inwards (3.28: normal
 * speed from inlet_normal() at inward mean -U, tangential Maxwellian about
 * the filter velocity); returns 0. Otherwise it freezes: v = fu exactly;
 * returns 1. fback, sv: the wall's F_- / F_+ and sqrt(T / m) (mixtures: at
 * the particle's species' mass). */
static int filter_rule(struct ed *ed, int w, double *v, double fback, double sv)
{
	const int a = w >> 1;
	const double sg = (w & 1) ? -1.0 : 1.0;   /* inward */
	if (fback > 0.0 && rng_uniform(&ed->wrng) < fback) {
		for (int k = 0; k < ed->dim; k++)
			if (k != a)
				v[k] = ed->fu[w][k] + sv * rng_gauss(&ed->wrng);
		v[a] = sg * inlet_normal(&ed->wrng, sg * ed->fu[w][a], sv);
		return 0;
	}
	for (int k = 0; k < ed->dim; k++)
		v[k] = ed->fu[w][k];
	return 1;
}
/* Event trace hook (ed.h): code only in the bench-only -DED_TRACE build;
 * elsewhere ED_TRACE_EVENT expands to nothing, so the engine is unchanged. */
#ifdef ED_TRACE
static void trace_emit(struct ed *ed, int kind, uint32_t i, int32_t x, double t)
{
	ed_trace_t ev;
	ev.t = ed->epoch + t;
	ev.kind = kind;
	ev.i = ed->id[i];
	ev.j = kind == ED_TRACE_CROSS ? UINT32_MAX : ed->id[x];
	memcpy(ev.ci, ed->ev[i].cc, sizeof ev.ci);
	if (kind == ED_TRACE_CROSS) {
		/* x: the crossing code, 2 axis + (upper face) */
		int a = x >> 1;
		memcpy(ev.cj, ev.ci, sizeof ev.cj);
		ev.cj[a] += (x & 1) ? 1 : -1;
		if (ev.cj[a] >= ed->nc[a])
			ev.cj[a] = 0;
		else if (ev.cj[a] < 0)
			ev.cj[a] = ed->nc[a] - 1;
	} else {
		memcpy(ev.cj, ed->ev[x].cc, sizeof ev.cj);   /* x: the partner */
	}
	ed->trace(ed->trace_ctx, &ev);
}
#define ED_TRACE_EVENT(ed, kind, i, x, t) do { if ((ed)->trace) trace_emit(ed, kind, i, x, t); } while (0)
#else
#define ED_TRACE_EVENT(ed, kind, i, x, t) ((void)0)
#endif

/* Filters under gravity: particles frozen at wall w present changed by
 * dn; their count and velocity sum follow (the sum from the counts, so it
 * is the same numbers however it was reached: a restored run goes on bit
 * for bit). */
static void frozen_count(struct ed *ed, int w, int sp, int dn)
{
	ed->nfzw[w] += (uint64_t)(int64_t)dn;
	ed->nfz = 0;
	for (int a = 0; a < 3; a++)
		ed->fzv[a] = 0.0;
	if (ed->mixture) {   /* mixtures: each species' count weighted by m_k / m */
		ed->nfzk[w][sp] += (uint64_t)(int64_t)dn;
		ed->nfzm = 0.0;
		for (int k = 0; k < 6; k++)
			for (int q = 0; q < ed->nsp; q++) {
				const double mk = (double)ed->nfzk[k][q] * (ed->mix->m[q] / ed->mass);
				ed->nfz += ed->nfzk[k][q];
				ed->nfzm += mk;
				for (int a = 0; a < 3; a++)
					ed->fzv[a] += mk * ed->fu[k][a];
			}
		return;
	}
	for (int k = 0; k < 6; k++) {
		ed->nfz += ed->nfzw[k];
		for (int a = 0; a < 3; a++)
			ed->fzv[a] += (double)ed->nfzw[k] * ed->fu[k][a];
	}
}

/* The frozen particles present, counted afresh from frozen[] (start of the
 * production run, restore). */
static void frozen_tally(struct ed *ed)
{
	memset(ed->nfzw, 0, sizeof ed->nfzw);
	memset(ed->nfzk, 0, sizeof ed->nfzk);
	if (ed->frozen)
		for (uint32_t i = 0; i < ed->n; i++)
			if (ed->frozen[i] && !ed->gone[i]) {
				ed->nfzw[ed->frozen[i] - 1]++;
				if (ed->mixture)
					ed->nfzk[ed->frozen[i] - 1][ed->spc[i]]++;
			}
	frozen_count(ed, 0, 0, 0);
}

/* Mixtures: the particles of species sp present changed by dn (sp < 0:
 * none); the mass present follows from the counts. */
static void mix_present(struct ed *ed, int sp, int dn)
{
	struct ed_mix *x = ed->mix;
	if (sp >= 0)
		x->npres[sp] += (uint64_t)(int64_t)dn;
	x->mpres = 0.0;
	for (int k = 0; k < ed->nsp; k++)
		x->mpres += (double)x->npres[k] * x->m[k];
}

/* Loops over the D axes, unrolled (GCC does not at -O2 by itself; the
 * per-candidate arithmetic is the hot loop of the engine). */
#define FOR_AXES(a) _Pragma("GCC unroll 3") for (int a = 0; a < D; a++)

/* The kernels, once per dimension and variant: periodic homogeneous
 * (_2d, _3d: the original engine, untouched by the features below), walls
 * (_2w, _3w) and gravity with or without walls (_2g, _3g). */
#define SPEC 0
#define ROUGH 0
#define WALLS 0
#define GRAV 0
#define VARIANT d
#include "ed_inst.h"
#define WALLS 1
#define GRAV 0
#define VARIANT w
#include "ed_inst.h"
#define WALLS 1
#define GRAV 1
#define VARIANT g
#include "ed_inst.h"
#undef SPEC
#undef ROUGH

/* Filters under gravity (_2gf, _3gf; rough _2grf, _3grf below): the
 * gravity variant whose frozen particles fly straight (FILTG in
 * ed_impl.h), chosen at load only for a scene with both. Without heuristic
 * inlining, like the rough variants, so that the kernels above keep theirs. */
#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC push_options
#pragma GCC optimize ("no-inline-functions")
#endif
#define SPEC 0
#define ROUGH 0
#define WALLS 1
#define GRAV 1
#define FILTG 1
#define VARIANT gf
#include "ed_inst.h"
#undef SPEC
#undef ROUGH
#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC pop_options
#endif

/* Rough particles: the same three variants with the rough collision rule
 * (_2dr, _3dr periodic; _2wr, _3wr walls; _2gr, _3gr gravity). Compiled
 * without GCC's heuristic inlining of functions not declared inline: this
 * unit's inlining budget is shared, and six more variants inlined at will
 * took it from the smooth kernels (the periodic event loop lost inlined
 * calendar updates and ran up to 7% slower). */
#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC push_options
#pragma GCC optimize ("no-inline-functions")
#endif
#define SPEC 0
#define ROUGH 1
#define WALLS 0
#define GRAV 0
#define VARIANT dr
#include "ed_inst.h"
#define WALLS 1
#define GRAV 0
#define VARIANT wr
#include "ed_inst.h"
#define WALLS 1
#define GRAV 1
#define VARIANT gr
#include "ed_inst.h"
#define WALLS 1
#define GRAV 1
#define FILTG 1
#define VARIANT grf
#include "ed_inst.h"
#undef SPEC
#undef ROUGH
#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC pop_options
#endif

/* Species (mixtures): the periodic and walls variants with the particles'
 * own radii and the pair tables of restitution and masses (_2ds, _3ds
 * periodic; _2ws, _3ws walls and obstacles, no gravity). Chosen at load for
 * mixtures; one species keeps the kernels above.
 * Without heuristic inlining like the rough ones, for the same reason. */
#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC push_options
#pragma GCC optimize ("no-inline-functions")
#endif
#define SPEC 1
#define ROUGH 0
#define WALLS 0
#define GRAV 0
#define VARIANT ds
#include "ed_inst.h"
#define WALLS 1
#define GRAV 0
#define VARIANT ws
#include "ed_inst.h"
#define WALLS 1
#define GRAV 1
#define VARIANT gs
#include "ed_inst.h"
#define WALLS 1
#define GRAV 1
#define FILTG 1
#define VARIANT gsf
#include "ed_inst.h"
#undef ROUGH
/* Rough mixtures: the three variants (_2dsr, _3dsr periodic; _2wsr, _3wsr
 * walls and obstacles; _2gsr, _3gsr gravity) with the rough rule for
 * unequal particles (rough.h, rough_collide_pair()). */
#define ROUGH 1
#define WALLS 0
#define GRAV 0
#define VARIANT dsr
#include "ed_inst.h"
#define WALLS 1
#define GRAV 0
#define VARIANT wsr
#include "ed_inst.h"
#define WALLS 1
#define GRAV 1
#define VARIANT gsr
#include "ed_inst.h"
#define WALLS 1
#define GRAV 1
#define FILTG 1
#define VARIANT gsrf
#include "ed_inst.h"
#undef SPEC
#undef ROUGH
#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC pop_options
#endif

/* A variant's entry points, chosen once in ed_alloc(): nothing per event. */
typedef struct ed_ops {
	int (*run)(struct ed *, double, uint64_t, uint64_t);
	int (*place_random)(struct ed *, rng_t *);
	void (*place)(struct ed *, uint32_t);
	double (*ekin)(const struct ed *, double *);
	void (*state)(const struct ed *, double *, double *);
	double (*min_gap)(const struct ed *);
	int32_t (*cell_index)(const struct ed *, const int32_t *);
	void (*rebase)(struct ed *);
	void (*set_cross)(struct ed *, uint32_t);
	void (*scan_full)(struct ed *, uint32_t);
	/* periodic variant only (neighbour lists); NULL elsewhere */
	void (*nl_build_all)(struct ed *);
	void (*resync)(struct ed *);
	void (*set_nl)(struct ed *, uint32_t);
	void (*scan_nl)(struct ed *, uint32_t);
	/* walls and gravity variants only */
	void (*observe)(const struct ed *, double *, double *);
	void (*energy_to)(struct ed *, double);
	/* driving (thermostats) */
	void (*kick_get)(struct ed *, uint32_t, double *, double *);
	void (*kick_set)(struct ed *, uint32_t, const double *);
	/* reservoir walls (walls and gravity variants) */
	int (*enter)(struct ed *, uint32_t, const double *, const double *);
	/* dispensers (walls variant, one species) */
	int (*enter_layer)(struct ed *, uint32_t, const double *, const double *);
} ed_ops_t;

#define OPS_COMMON(x) \
	.run = run_##x, .place_random = place_random_##x, .place = place_##x, .ekin = ekin_##x, .state = state_##x, \
	.min_gap = min_gap_##x, .cell_index = cell_index_##x, .rebase = rebase_##x, .set_cross = set_cross_##x, \
	.scan_full = scan_full_##x, .kick_get = kick_get_##x, .kick_set = kick_set_##x
#define OPS_NL(x) .nl_build_all = nl_build_all_##x, .resync = resync_##x, .set_nl = set_nl_##x, .scan_nl = scan_nl_##x
static const ed_ops_t ed_ops[2][3] = {
	{ { OPS_COMMON(2d), OPS_NL(2d) }, { OPS_COMMON(2w), .observe = observe_2w, .enter = enter_2w, .enter_layer = enter_layer_2w },
	  { OPS_COMMON(2g), .observe = observe_2g, .energy_to = energy_to_2g, .enter = enter_2g, .enter_layer = enter_layer_2g } },
	{ { OPS_COMMON(3d), OPS_NL(3d) }, { OPS_COMMON(3w), .observe = observe_3w, .enter = enter_3w, .enter_layer = enter_layer_3w },
	  { OPS_COMMON(3g), .observe = observe_3g, .energy_to = energy_to_3g, .enter = enter_3g, .enter_layer = enter_layer_3g } },
};
static const ed_ops_t ed_ops_species[2][3] = {
	{ { OPS_COMMON(2ds), OPS_NL(2ds) }, { OPS_COMMON(2ws), .observe = observe_2ws, .enter = enter_2ws, .enter_layer = enter_layer_2ws },
	  { OPS_COMMON(2gs), .observe = observe_2gs, .energy_to = energy_to_2gs, .enter = enter_2gs, .enter_layer = enter_layer_2gs } },
	{ { OPS_COMMON(3ds), OPS_NL(3ds) }, { OPS_COMMON(3ws), .observe = observe_3ws, .enter = enter_3ws, .enter_layer = enter_layer_3ws },
	  { OPS_COMMON(3gs), .observe = observe_3gs, .energy_to = energy_to_3gs, .enter = enter_3gs, .enter_layer = enter_layer_3gs } },
};
static const ed_ops_t ed_ops_species_rough[2][3] = {
	{ { OPS_COMMON(2dsr), OPS_NL(2dsr) }, { OPS_COMMON(2wsr), .observe = observe_2wsr, .enter = enter_2wsr, .enter_layer = enter_layer_2wsr },
	  { OPS_COMMON(2gsr), .observe = observe_2gsr, .energy_to = energy_to_2gsr, .enter = enter_2gsr, .enter_layer = enter_layer_2gsr } },
	{ { OPS_COMMON(3dsr), OPS_NL(3dsr) }, { OPS_COMMON(3wsr), .observe = observe_3wsr, .enter = enter_3wsr, .enter_layer = enter_layer_3wsr },
	  { OPS_COMMON(3gsr), .observe = observe_3gsr, .energy_to = energy_to_3gsr, .enter = enter_3gsr, .enter_layer = enter_layer_3gsr } },
};
static const ed_ops_t ed_ops_rough[2][3] = {
	{ { OPS_COMMON(2dr), OPS_NL(2dr) }, { OPS_COMMON(2wr), .observe = observe_2wr, .enter = enter_2wr, .enter_layer = enter_layer_2wr },
	  { OPS_COMMON(2gr), .observe = observe_2gr, .energy_to = energy_to_2gr, .enter = enter_2gr, .enter_layer = enter_layer_2gr } },
	{ { OPS_COMMON(3dr), OPS_NL(3dr) }, { OPS_COMMON(3wr), .observe = observe_3wr, .enter = enter_3wr, .enter_layer = enter_layer_3wr },
	  { OPS_COMMON(3gr), .observe = observe_3gr, .energy_to = energy_to_3gr, .enter = enter_3gr, .enter_layer = enter_layer_3gr } },
};

/* Filters under gravity, smooth and rough (one species): in place of the gravity column above. */
#define OPS_FILTG(x) { OPS_COMMON(x), .observe = observe_##x, .energy_to = energy_to_##x, .enter = enter_##x, \
		.enter_layer = enter_layer_##x }
static const ed_ops_t ed_ops_filtg[2] = { OPS_FILTG(2gf), OPS_FILTG(3gf) };
static const ed_ops_t ed_ops_filtg_rough[2] = { OPS_FILTG(2grf), OPS_FILTG(3grf) };
/* ... and mixtures (each frozen/regular pair its own contact distance, masses and restitution) */
static const ed_ops_t ed_ops_filtg_species[2] = { OPS_FILTG(2gsf), OPS_FILTG(3gsf) };
static const ed_ops_t ed_ops_filtg_species_rough[2] = { OPS_FILTG(2gsrf), OPS_FILTG(3gsrf) };

#define DISPATCH(ed, fn, ...) ((ed)->ops->fn(__VA_ARGS__))

static void set_msg(char *msg, size_t len, const char *fmt, double a, double b)
{
	if (msg && len)
		snprintf(msg, len, fmt, a, b);
}

/* Cell grid: edges of at least max(sigma, requested) so the 3^D stencil
 * holds every possible partner. Dense systems want the smallest legal cells;
 * dilute ones want fewer cells than that (crossings get too frequent): at
 * most ~1.5 cells per particle in 2D and ~8 in 3D (seed 003, Fig. 2.3). */
static void setup_cells(struct ed *ed, double min_edge)
{
	double vol = 1.0;
	for (int a = 0; a < ed->dim; a++)
		vol *= ed->L[a];
	if (min_edge <= 0.0) {
		double per = ed->dim == 2 ? 1.5 : 8.0;
		double edge = pow(vol / (per * ed->n), 1.0 / ed->dim);
		min_edge = edge > ed->sigma ? edge : ed->sigma;
	}
	/* A hair above sigma so that rounding of positions at cell faces can
	 * never hide a partner two cells away. */
	min_edge *= 1.0 + 1e-9;
	ed->ncells = 1;
	for (int a = 0; a < 3; a++) {
		if (a >= ed->dim) {
			ed->nc[a] = 1;
			ed->cw[a] = 1.0;
		} else {
			double k = floor(ed->L[a] / min_edge);
			ed->nc[a] = k < 1.0 ? 1 : (k > 1e6 ? 1000000 : (int32_t)k);
			ed->cw[a] = ed->L[a] / ed->nc[a];
		}
		ed->ncells *= (size_t)ed->nc[a];
		if (a < ed->dim && ed->nc[a] < 3)
			ed->minimg = 1;
		if (ed->nc[a] >= 3) {
			ed->no[a] = 3;
			ed->off[a][0] = -1, ed->off[a][1] = 0, ed->off[a][2] = 1;
		} else {
			ed->no[a] = ed->nc[a];
			ed->off[a][0] = 0, ed->off[a][1] = 1, ed->off[a][2] = 0;
		}
	}
}

/* Neighbour-list shell (list radius (1 + shell) sigma) for a volume
 * fraction, or 0 for cell mode: lists pay where particles meet their
 * neighbours often before drifting far, i.e. in dense systems. */
static double nl_shell(int dim, double phi)
{
	/* crossovers and shells measured at N ~ 10^4 (N = 10^5 alike) */
	if (dim == 2)
		return phi >= 0.6 ? 0.7 : 0.0;
	return phi >= 0.33 ? 0.6 : 0.0;
}

/* Choose the mode and the cell grid. Lists need >= 3 cells of edge >= the
 * list radius on every axis (one image per neighbour cell). */
static void setup_mode(struct ed *ed, double min_edge)
{
	double vol = 1.0;
	for (int a = 0; a < ed->dim; a++)
		vol *= ed->L[a];
	const double pi = 3.14159265358979323846;
	double vp = ed->dim == 2 ? 0.25 * pi * ed->sigma2 : pi / 6.0 * ed->sigma2 * ed->sigma;
	double shell = nl_shell(ed->dim, ed->n * vp / vol);
	if (shell > 0.0) {
		double rl = (1.0 + shell) * ed->sigma;
		setup_cells(ed, rl > min_edge ? rl : min_edge);
		if (!ed->minimg) {
			ed->nl = 1;
			/* a hair wider than needed: rounding in the drift test cannot
			 * let an unlisted pair touch */
			ed->nl_r2 = rl * rl * (1.0 + 1e-9);
			ed->nl_d2 = 0.25 * shell * shell * ed->sigma2;
			/* dense random packing holds ~1.3x the mean count within rl;
			 * more than this capacity sends the run back to cell mode */
			ed->nlk = ed->dim == 2 ? 24 : 32;   /* <= NL_KMAX */
			return;
		}
		ed->minimg = 0;
	}
	setup_cells(ed, min_edge);
}

/* Lattice start: a rectangular (2D, staggered rows ~ hexagonal) or FCC (3D)
 * lattice chosen to maximise the nearest-neighbour distance for N sites in
 * the box; when N does not fill it, the vacancies are spread over the box
 * (lattice.h), not left as an empty slab at the top. The shapes come from
 * lattice_shape_2d/3d (engine/lattice.c), shared with region placement.
 *
 * Whether a lattice of nearest distance d is too tight for the diameter (msg says so). */
static int lattice_short(const struct ed *ed, double d, char *msg, size_t msglen)
{
	if (d >= ed->sigma * (1.0 + 1e-12))
		return 0;
	set_msg(msg, msglen, "particles.initial.positions: no lattice of this many particles fits the box "
	        "(nearest distance %.6g < diameter %.6g); use fewer particles or a lower volume fraction", d, ed->sigma);
	return 1;
}

/* The lattice for n sites in Lp (nearest distance returned; b: cells per
 * axis) and its site j (internal coordinates, offset plo). */
static double lattice_dims(const struct ed *ed, const double *Lp, uint64_t n, int64_t b[3], uint64_t *sites)
{
	double d;
	b[0] = b[1] = b[2] = 1;
	if (ed->dim == 2) {
		d = lattice_shape_2d(Lp, n, &b[0], &b[1]);
		*sites = (uint64_t)(b[0] * b[1]);
	} else {
		d = lattice_shape_3d(Lp, n, b);
		*sites = (uint64_t)(4 * b[0] * b[1] * b[2]);
	}
	return d;
}

static void lattice_site(const struct ed *ed, const double *Lp, const int64_t b[3], uint64_t j, double *r)
{
	static const double site[4][3] = {{0, 0, 0}, {.5, .5, 0}, {.5, 0, .5}, {0, .5, .5}};
	if (ed->dim == 2) {
		int64_t ix = (int64_t)j % b[0], iy = (int64_t)j / b[0];
		r[0] = (ix + 0.25 + 0.5 * (iy & 1)) * (Lp[0] / b[0]);
		r[1] = (iy + 0.5) * (Lp[1] / b[1]);
	} else {
		int64_t c = (int64_t)j / 4, s = (int64_t)j % 4;
		int64_t ix = c % b[0], iy = (c / b[0]) % b[1], iz = c / (b[0] * b[1]);
		r[0] = (ix + site[s][0] + 0.25) * (Lp[0] / b[0]);
		r[1] = (iy + site[s][1] + 0.25) * (Lp[1] / b[1]);
		r[2] = (iz + site[s][2] + 0.25) * (Lp[2] / b[2]);
	}
	if (ed->variant)
		for (int a = 0; a < ed->dim; a++)
			r[a] += ed->plo[a];
}

/* The region the lattice fills: [plo, phi) as if periodic (walled axes: out
 * of reach of the walls; the periodic spacing keeps the first and last
 * layers a diameter apart too, which costs at most one layer). */
static void lattice_region(const struct ed *ed, double Lp[3])
{
	for (int a = 0; a < 3; a++)
		Lp[a] = ed->variant && a < ed->dim ? ed->phi[a] - ed->plo[a] : ed->L[a];
}

/* With obstacles the lattice has more sites than particles: grown until
 * enough sites are clear of the obstacles (a site is at least the contact
 * distance from every obstacle centre). Returns the nearest distance; *free
 * the clear sites (all without obstacles). O(sites) per try, few tries. */
static double lattice_plan(const struct ed *ed, int64_t b[3], uint64_t *sites, uint64_t *nfree)
{
	double Lp[3], r[3] = {0, 0, 0};
	lattice_region(ed, Lp);
	uint64_t want = ed->n;
	double d = lattice_dims(ed, Lp, want, b, sites);
	*nfree = *sites;
	for (int tries = 0; ed->nobst && tries < 64; tries++) {
		*nfree = 0;
		for (uint64_t j = 0; j < *sites; j++) {
			lattice_site(ed, Lp, b, j, r);
			*nfree += obst_clear(ed, r);
		}
		if (*nfree >= ed->n)
			break;
		want += (ed->n - *nfree) + want / 32 + 1;
		d = lattice_dims(ed, Lp, want, b, sites);
	}
	return d;
}

/* "particles.initial.positions" when the obstacles leave too few lattice sites. */
static int lattice_blocked(const struct ed *ed, uint64_t nfree, char *msg, size_t msglen)
{
	if (nfree >= ed->n)
		return 0;
	set_msg(msg, msglen, "particles.initial.positions: the obstacles leave room for only %.0f of %.0f particles on a "
	        "lattice; use fewer particles, smaller obstacles or a larger box", (double)nfree, (double)ed->n);
	return 1;
}

static int place_lattice(struct ed *ed, rng_t *rng, char *msg, size_t msglen)
{
	size_t stride = ed->dim == 2 ? sizeof(p2_t) : sizeof(p3_t);
	lattice_fill_t fill;
	int64_t b[3];
	uint64_t sites, nfree, *clear = NULL;
	double Lp[3];
	lattice_region(ed, Lp);
	double d = lattice_plan(ed, b, &sites, &nfree);
	if (lattice_short(ed, d, msg, msglen) || lattice_blocked(ed, nfree, msg, msglen))
		return ED_EPLACE;
	if (ed->nobst) {
		/* the clear sites, in site order; the fill picks among them */
		if (!(clear = malloc(nfree * sizeof(uint64_t)))) {
			set_msg(msg, msglen, "out of memory for %.0f lattice sites%.0s", (double)nfree, 0);
			return ED_ENOMEM;
		}
		double r[3] = {0, 0, 0};
		uint64_t m = 0;
		for (uint64_t j = 0; j < sites; j++) {
			lattice_site(ed, Lp, b, j, r);
			if (obst_clear(ed, r))
				clear[m++] = j;
		}
	}
	lattice_fill_init(&fill, nfree, ed->n, rng);
	for (uint32_t i = 0; i < ed->n; i++) {
		uint64_t j = lattice_fill_next(&fill);
		lattice_site(ed, Lp, b, clear ? clear[j] : j, (double *)((char *)ed->p + i * stride));
	}
	free(clear);
	if (ed->mixture)   /* species are blocks of indices: sites shuffled among particles so they mix */
		for (uint32_t i = ed->n - 1; i > 0; i--) {
			uint32_t j = (uint32_t)(rng_uniform(rng) * (i + 1.0));
			if (j > i)
				j = i;
			double *ri = (double *)((char *)ed->p + i * stride), *rj = (double *)((char *)ed->p + j * stride);
			for (int a = 0; a < ed->dim; a++) {
				double x = ri[a];
				ri[a] = rj[a];
				rj[a] = x;
			}
		}
	for (uint32_t i = 0; i < ed->n; i++)
		DISPATCH(ed, place, ed, i);
	return ED_OK;
}

/* Random sequential addition (place_random()) cannot pass its jamming
 * coverage: 0.547 for disks, 0.384 for spheres (Torquato, Random
 * Heterogeneous Materials, sec. 3.4), so at or above it the placement
 * fails for certain, after ~2000 N tries. Refused before trying. */
static double rsa_jamming(int dim) { return dim == 2 ? 0.547 : 0.384; }

/* The placement checks ed_create() makes, without placing (ed_plan() and
 * ed_create() share them): a lattice whose nearest distance is below a
 * diameter, random placement at or above jamming. ED_OK or ED_EPLACE. */
static int placement_check(const struct ed *ed, const scene_t *s, char *msg, size_t msglen)
{
	/* Walled scenes place centres in [plo, phi) only (out of the walls'
	 * reach): the lattice spans that, and random placement sees the volume
	 * fraction of that region grown by one diameter (the particles' extent). */
	double Lp[3] = {ed->L[0], ed->L[1], ed->L[2]}, phi_eff = s->volume_fraction;
	if (ed->variant)
		for (int a = 0; a < ed->dim; a++) {
			Lp[a] = ed->phi[a] - ed->plo[a];
			if (!ed->periodic[a])
				phi_eff *= ed->L[a] / (Lp[a] + ed->sigma);
		}
	/* obstacles: their excluded volume (contact distance; within the box
	 * by the scene's checks) is not available either */
	if (ed->nobst) {
		double vol = 1.0, excl = 0.0;
		for (int a = 0; a < ed->dim; a++)
			vol *= ed->L[a];
		for (int k = 0; k < ed->nobst; k++) {
			const double S = ed->obst[k].S;
			excl += ed->dim == 2 ? 3.14159265358979323846 * S * S : 4.18879020478639098461 * S * S * S;
		}
		phi_eff = excl < vol ? phi_eff * vol / (vol - excl) : INFINITY;
	}
	(void)Lp;
	if (s->positions == SCENE_POS_RANDOM) {
		if (phi_eff < rsa_jamming(ed->dim))
			return ED_OK;
		set_msg(msg, msglen, "particles.initial.positions: \"random\" cannot place particles at volume fraction "
		        "%.4g (random sequential addition jams at %.3g); use \"lattice\"", phi_eff,
		        rsa_jamming(ed->dim));
		return ED_EPLACE;
	}
	int64_t b[3] = {1, 1, 1};
	uint64_t sites, nfree;
	double d = lattice_plan(ed, b, &sites, &nfree);
	return lattice_short(ed, d, msg, msglen) || lattice_blocked(ed, nfree, msg, msglen) ? ED_EPLACE : ED_OK;
}

/* A state from outside (scene_t.init_pos, init_vel: scene coordinates,
 * checked by the caller, place.h): into internal coordinates and cells. */
static void given_state(struct ed *ed, const double *pos, const double *vel)
{
	size_t stride = ed->dim == 2 ? sizeof(p2_t) : sizeof(p3_t);
	size_t voff = ed->dim == 2 ? offsetof(p2_t, v) : offsetof(p3_t, v);
	for (uint32_t i = 0; i < ed->n; i++) {
		double *r = (double *)((char *)ed->p + i * stride), *v = (double *)((char *)ed->p + i * stride + voff);
		for (int a = 0; a < ed->dim; a++) {
			r[a] = pos[(size_t)i * ed->dim + a] + (ed->variant ? ed->org[a] : 0.0);
			if (vel)
				v[a] = vel[(size_t)i * ed->dim + a];
		}
		DISPATCH(ed, place, ed, i);
	}
}

static void init_velocities(struct ed *ed, double temp, rng_t *rng)
{
	size_t stride = ed->dim == 2 ? sizeof(p2_t) : sizeof(p3_t);
	size_t voff = ed->dim == 2 ? offsetof(p2_t, v) : offsetof(p3_t, v);
	double mean[3] = {0, 0, 0}, s2 = 0.0;
	for (uint32_t i = 0; i < ed->n; i++) {
		double *v = (double *)((char *)ed->p + i * stride + voff);
		for (int a = 0; a < ed->dim; a++) {
			v[a] = rng_gauss(rng);
			mean[a] += v[a];
		}
	}
	for (int a = 0; a < ed->dim; a++)
		mean[a] /= ed->n;
	for (uint32_t i = 0; i < ed->n; i++) {
		double *v = (double *)((char *)ed->p + i * stride + voff);
		for (int a = 0; a < ed->dim; a++) {
			v[a] -= mean[a];
			s2 += v[a] * v[a];
		}
	}
	/* Scale to exactly the requested temperature T = m sum v^2 / (D N). */
	double scale = s2 > 0.0 ? sqrt(temp * ed->dim * ed->n / (ed->mass * s2)) : 0.0;
	for (uint32_t i = 0; i < ed->n; i++) {
		double *v = (double *)((char *)ed->p + i * stride + voff);
		for (int a = 0; a < ed->dim; a++)
			v[a] *= scale;
	}
}

/* Mixtures: Gaussian velocities of variance T / m_s per component for
 * species s, the centre-of-mass velocity removed (total momentum zero),
 * scaled to exactly T = sum m v^2 / (D N) over all particles (each
 * species' own temperature is T up to sampling noise). */
static void init_velocities_species(struct ed *ed, double temp, rng_t *rng)
{
	size_t stride = ed->dim == 2 ? sizeof(p2_t) : sizeof(p3_t);
	size_t voff = ed->dim == 2 ? offsetof(p2_t, v) : offsetof(p3_t, v);
	double mom[3] = {0, 0, 0}, mtot = 0.0, s2 = 0.0;
	for (uint32_t i = 0; i < ed->n; i++) {
		double *v = (double *)((char *)ed->p + i * stride + voff), m = ed->mix->m[ed->spc[i]], sd = 1.0 / sqrt(m);
		for (int a = 0; a < ed->dim; a++) {
			v[a] = sd * rng_gauss(rng);
			mom[a] += m * v[a];
		}
		mtot += m;
	}
	for (uint32_t i = 0; i < ed->n; i++) {
		double *v = (double *)((char *)ed->p + i * stride + voff), m = ed->mix->m[ed->spc[i]];
		for (int a = 0; a < ed->dim; a++) {
			v[a] -= mom[a] / mtot;
			s2 += m * v[a] * v[a];
		}
	}
	double scale = s2 > 0.0 ? sqrt(temp * ed->dim * ed->n / s2) : 0.0;
	for (uint32_t i = 0; i < ed->n; i++) {
		double *v = (double *)((char *)ed->p + i * stride + voff);
		for (int a = 0; a < ed->dim; a++)
			v[a] *= scale;
	}
}

/* Kinetic energy per species now (0 fields for one species). */
static void species_ekin(const struct ed *ed, ed_sample_t *out)
{
	out->n_species = ed->mixture && ed->nsp > 1 ? ed->nsp : 0;
	if (!out->n_species)
		return;
	size_t stride = ed->dim == 2 ? sizeof(p2_t) : sizeof(p3_t);
	size_t voff = ed->dim == 2 ? offsetof(p2_t, v) : offsetof(p3_t, v);
	double s2[SCENE_SPECIES_MAX] = {0};
	uint64_t cnt[SCENE_SPECIES_MAX] = {0};
	for (uint32_t i = 0; i < ed->n; i++) {
		if (ed->gone && ed->gone[i])   /* left through an open wall: not counted */
			continue;
		const double *v = (const double *)((const char *)ed->p + i * stride + voff);
		const double dt = ed->t - ((const double *)((const char *)ed->p + i * stride +
		                  (ed->dim == 2 ? offsetof(p2_t, t) : offsetof(p3_t, t))))[0];
		for (int a = 0; a < ed->dim; a++) {
			const double va = v[a] + ed->g[a] * dt;   /* with gravity: the velocity now (g = 0 otherwise) */
			s2[ed->spc[i]] += va * va;
		}
		cnt[ed->spc[i]]++;
	}
	for (int k = 0; k < ed->nsp; k++) {
		out->species_kinetic_energy[k] = 0.5 * ed->mix->m[k] * s2[k];
		out->species_count[k] = cnt[k];   /* present (open walls: fewer than the species' count) */
	}
}

/* The scene's initial mean flow (particles.initial.velocity) added to the
 * thermal velocities; nothing at all without one (the periodic start stays
 * bit for bit as before). */
static void add_flow(struct ed *ed, const scene_t *s)
{
	int any = 0;
	for (int a = 0; a < ed->dim; a++)
		any |= s->flow[a] != 0.0;
	if (!any)
		return;
	size_t stride = ed->dim == 2 ? sizeof(p2_t) : sizeof(p3_t);
	size_t voff = ed->dim == 2 ? offsetof(p2_t, v) : offsetof(p3_t, v);
	for (uint32_t i = 0; i < ed->n; i++) {
		double *v = (double *)((char *)ed->p + i * stride + voff);
		for (int a = 0; a < ed->dim; a++)
			v[a] += s->flow[a];
	}
}

/* Spins of rough particles: Gaussian, scaled to exactly the rotational
 * temperature T_rot = I sum w^2 / (D_r N) (D_r = 1 in 2D, 3 in 3D). The
 * random numbers come after the velocities': smooth scenes are unchanged. */
static void init_spins(struct ed *ed, double temp, rng_t *rng)
{
	const size_t k = (size_t)ed->n * (ed->dim == 2 ? 1 : 3);
	double s2 = 0.0;
	for (size_t i = 0; i < k; i++) {
		ed->spin[i] = rng_gauss(rng);
		s2 += ed->spin[i] * ed->spin[i];
	}
	if (ed->mixture) {
		/* mixtures: variance T / I_i per component, I_i = q m_i a_i^2, scaled to exactly T_rot */
		const size_t c = ed->dim == 2 ? 1 : 3;
		double e2 = 0.0;
		for (uint32_t i = 0; i < ed->n; i++) {
			const double I = ed->rq * ed->mix->m[ed->spc[i]] * ed->prad[i] * ed->prad[i];
			for (size_t a = 0; a < c; a++) {
				ed->spin[i * c + a] /= sqrt(I);
				e2 += I * ed->spin[i * c + a] * ed->spin[i * c + a];
			}
		}
		const double scale = e2 > 0.0 ? sqrt(temp * (double)k / e2) : 0.0;
		for (size_t i = 0; i < k; i++)
			ed->spin[i] *= scale;
		return;
	}
	const double inertia = ed->rq * ed->mass * 0.25 * ed->sigma2;
	const double scale = s2 > 0.0 ? sqrt(temp * (double)k / (inertia * s2)) : 0.0;
	for (size_t i = 0; i < k; i++)
		ed->spin[i] *= scale;
}

/* Rotational energy I/2 sum w^2 (0 for smooth particles). */
static double ed_erot(const struct ed *ed)
{
	if (!ed->rough)
		return 0.0;
	const size_t k = (size_t)ed->n * (ed->dim == 2 ? 1 : 3);
	double s2 = 0.0;
	if (ed->mixture) {   /* each particle's own I = q m_i a_i^2 */
		const size_t c = ed->dim == 2 ? 1 : 3;
		for (uint32_t i = 0; i < ed->n; i++) {
			double w2 = 0.0;
			for (size_t a = 0; a < c; a++)
				w2 += ed->spin[i * c + a] * ed->spin[i * c + a];
			s2 += ed->rq * ed->mix->m[ed->spc[i]] * ed->prad[i] * ed->prad[i] * w2;
		}
		return 0.5 * s2;
	}
	for (size_t i = 0; i < k; i++)
		s2 += ed->spin[i] * ed->spin[i];
	return 0.5 * ed->rq * ed->mass * 0.25 * ed->sigma2 * s2;
}

static void predict_all(struct ed *ed)
{
	for (uint32_t i = 0; i < ed->n; i++) {
		ed->ev[i].t_coll = INFINITY;
		ed->ev[i].partner = -1;
	}
	if (ed->nl)
		DISPATCH(ed, nl_build_all, ed);
	for (uint32_t i = 0; i < ed->n; i++) {
		if (ed->gone && ed->gone[i]) {   /* an empty slot: no events */
			ed->ev[i].t_cross = INFINITY;
			ed->ev[i].cross = -1;
			continue;
		}
		if (ed->nl) { DISPATCH(ed, set_nl, ed, i); DISPATCH(ed, scan_nl, ed, i); }
		else { DISPATCH(ed, set_cross, ed, i); DISPATCH(ed, scan_full, ed, i); }
	}
	cal_build(ed);
}

/* A neighbour list overflowed (denser locally than its capacity): go on in
 * cell mode on the same grid, everything predicted afresh from the present
 * state. Deterministic like any other event. */
__attribute__((noinline, cold)) static void nl_abandon(struct ed *ed)
{
	ed->nl = ed->nl_over = 0;
	DISPATCH(ed, resync, ed);
	predict_all(ed);
}

/* Start the production run here: clock to zero, counters and interval
 * statistics reset (used after the elastic pre-run). */
static void reset_clock(struct ed *ed)
{
	DISPATCH(ed, rebase, ed);
	ed->epoch = ed->epoch_c = 0.0;
	ed->t_abs_valid = 0;
	ed->events = ed->collisions = ed->tc_elastic = ed->since_rebase = 0;
	double mom[3];
	ed->ekin_cur = DISPATCH(ed, ekin, ed, mom);
	ed->ekin_int = ed->virial = 0.0;
	ed->t_mark = ed->t_int0 = 0.0;
	ed->coll_int0 = 0;
	if (ed->tlast)
		for (uint32_t i = 0; i < ed->n; i++)
			ed->tlast[i] = -INFINITY;
	/* walls: phases as the scene says at time 0, accumulators empty */
	for (int w = 0; w < 6; w++)
		ed->wall[w].ph = ed->wall[w].phase0;
	memset(ed->wimp, 0, sizeof ed->wimp);
	memset(ed->wimp_tot, 0, sizeof ed->wimp_tot);
	memset(ed->whits, 0, sizeof ed->whits);
	ed->wall_collisions = 0;
	memset(ed->oimp, 0, sizeof ed->oimp);
	memset(ed->oimp_tot, 0, sizeof ed->oimp_tot);
	memset(ed->ohits, 0, sizeof ed->ohits);
	ed->obst_collisions = 0;
	memset(ed->wout, 0, sizeof ed->wout);
	memset(ed->in_count, 0, 12 * sizeof ed->in_count[0]);   /* (the next id [12] stays) */
	for (int a = 0; a < 3; a++)
		ed->psum[a] = mom[a] / ed->mass;
}

/* Per-particle arrays are read at random (neighbours, calendar): with 4 KiB
 * pages a large system misses the TLB on most of those reads. Arrays of
 * 2 MiB and more are aligned to and advised for transparent huge pages (a
 * hint, ignored where unsupported). Cache-line aligned; freed with free(). */
static size_t big_size(size_t bytes)
{
	const size_t huge = (size_t)2 << 20;
	return bytes < huge ? (bytes ? (bytes + 63) / 64 * 64 : 64) : (bytes + huge - 1) / huge * huge;
}

static void *big_alloc(size_t bytes, int zero)
{
	const size_t huge = (size_t)2 << 20;
	void *p;
	bytes = big_size(bytes);
	if (bytes < huge) {
		p = aligned_alloc(64, bytes);
	} else {
		p = aligned_alloc(huge, bytes);
#ifdef MADV_HUGEPAGE
		if (p)
			madvise(p, bytes, MADV_HUGEPAGE);
#endif
	}
	if (p && zero)
		memset(p, 0, bytes);
	return p;
}

/* Walls and gravity from the scene: internal box, wall rules and places. */
static void setup_walls(struct ed *ed, const scene_t *s)
{
	const double two_pi = 6.28318530717958647692;
	ed->radius = s->radius;
	for (int a = 0; a < 3; a++) {
		ed->periodic[a] = 1;
		ed->g[a] = a < s->dim ? s->gravity[a] : 0.0;
		ed->plo[a] = 0.0;
		ed->phi[a] = ed->L[a];
	}
	for (int a = 0; a < s->dim; a++) {
		const scene_boundary_t *b = &s->boundary[a];
		if (!b->walled)
			continue;
		const double alo = b->wall[0].type == SCENE_WALL_VIBRATING ? b->wall[0].amplitude : 0.0;
		const double ahi = b->wall[1].type == SCENE_WALL_VIBRATING ? b->wall[1].amplitude : 0.0;
		ed->periodic[a] = 0;
		ed->org[a] = alo;
		ed->L[a] = s->box[a] + alo + ahi;
		ed->halfL[a] = INFINITY;   /* no minimum image along a walled axis */
		ed->plo[a] = 2.0 * alo + s->radius;
		ed->phi[a] = ed->L[a] - 2.0 * ahi - s->radius;
		for (int k = 0; k < 2; k++) {
			const scene_wall_t *sw = &b->wall[k];
			wall_t *W = &ed->wall[2 * a + k];
			const double sg = k ? -1.0 : 1.0;
			W->type = sw->type;
			W->r = sw->restitution;
			W->sv = sw->type == SCENE_WALL_THERMAL ? sqrt(sw->temperature / s->mass) : 0.0;
			W->acc = sw->accommodation;
			W->p = sw->probability;
			for (int j = 0; j < 3; j++)
				W->u[j] = sw->type == SCENE_WALL_MOVING || sw->type == SCENE_WALL_THERMAL ? sw->velocity[j] : 0.0;
			W->beta = sw->tangential_restitution;
			if (sw->type == SCENE_WALL_VIBRATING && sw->amplitude > 0.0) {
				W->A = sw->amplitude;
				W->omega = two_pi * sw->frequency;
				W->phase0 = W->ph = sw->phase;
			}
			W->rest = k ? ed->L[a] - ahi : alo;
			W->pu = W->pt0 = 0.0;
			if (sw->type == SCENE_WALL_DISPENSER) {
				W->pspeed = sg * sw->velocity[a];
				W->lh = sw->thickness > 0.0 ? sw->thickness : 4.0 * s->radius;
			}
			/* the rebound that keeps two hits tc apart against the wall's
			 * pull: gravity into it plus its largest acceleration */
			double pull = fmax(0.0, -sg * ed->g[a]) + W->A * W->omega * W->omega;
			W->vmin = 0.5 * s->tc * pull;
		}
	}
	rng_init(&ed->wrng, s->seed, s->stream | (1ull << 62));
}

/* exp(beta mu_ex) of the hard-disk (dim 2) or hard-sphere (dim 3) fluid at
 * volume fraction eta: the ratio of activity to number density, the inverse
 * of Widom's insertion probability. From the equation of state by
 * beta mu_ex = int_0^eta (Z - 1) / x dx + Z - 1: Henderson in 2D, Z = (1 +
 * eta^2/8) / (1 - eta)^2, gives (9/8) eta / (1 - eta) - (7/8) ln(1 - eta) +
 * Z - 1; Carnahan-Starling in 3D gives (8 eta - 9 eta^2 + 3 eta^3) / (1 -
 * eta)^3. Both 4 eta (2D), 8 eta (3D) at low density (2 B_2 n). */
static double hs_activity(int dim, double eta)
{
	const double q = 1.0 - eta;
	if (dim == 2) {
		const double z = (1.0 + eta * eta / 8.0) / (q * q);
		return exp(1.125 * eta / q - 0.875 * log(q) + z - 1.0);
	}
	return exp((8.0 * eta - 9.0 * eta * eta + 3.0 * eta * eta * eta) / (q * q * q));
}

/* exp(beta mu_ex,k) of each species k of an additive hard-disk (dim 2) or
 * hard-sphere (dim 3) mixture of nq species, number densities n[k], radii
 * a[k] (diameters s_k = 2 a_k): the activities of a mixture, into act[nq].
 * Each is the derivative d(beta f_ex)/dn_k of an excess free energy density
 * f_ex(n_1 .. n_nq), so the set is thermodynamically consistent.
 * 3D: Boublik-Mansoori-Carnahan-Starling-Leland, with xi_m = (pi/6) sum_j
 * n_j s_j^m, L = ln(1 - xi_3), q = 1 - xi_3:
 *     (pi/6) beta f_ex = (xi_2^3 / xi_3^2 - xi_0) L + 3 xi_1 xi_2 / q + xi_2^3 / (xi_3 q^2),
 *     beta mu_ex,k = sum_m s_k^m d[(pi/6) beta f_ex] / d xi_m.
 * 2D: Santos, Yuste and Lopez de Haro's mapping onto the one-component
 * Henderson fluid (Mol. Phys. 96, 1 (1999)), Z = 1/(1 - eta) + (<s>^2 /
 * <s^2>) [Z_H(eta) - 1/(1 - eta)] at fixed composition, integrated over
 * density: with t_m = sum_j n_j s_j^m, eta = (pi/4) t_2,
 *     beta f_ex = -t_0 ln(1 - eta) + (t_1^2 / t_2) G(eta),
 *     G = A_H + ln(1 - eta) = (9/8) eta / (1 - eta) + (1/8) ln(1 - eta),
 * A_H the Henderson fluid's beta f_ex per particle. For one species both
 * reduce to hs_activity()'s Carnahan-Starling and Henderson (the one-species
 * path keeps hs_activity()). */
static void hs_mix_activity(int dim, int nq, const double *n, const double *a, double *act)
{
	if (dim == 2) {
		const double pi = 3.14159265358979323846;
		double t0 = 0.0, t1 = 0.0, t2 = 0.0;
		for (int k = 0; k < nq; k++) {
			const double s = 2.0 * a[k];
			t0 += n[k], t1 += n[k] * s, t2 += n[k] * s * s;
		}
		const double eta = 0.25 * pi * t2, q = 1.0 - eta, L = log1p(-eta);
		const double g = 1.125 * eta / q + 0.125 * L, dg = (1.0 + eta / 8.0) / (q * q);
		for (int k = 0; k < nq; k++) {
			const double s = 2.0 * a[k], u = t1 * s / t2;
			act[k] = exp(-L + t0 / q * 0.25 * pi * s * s + (2.0 * u - u * u) * g + t1 * t1 / t2 * dg * 0.25 * pi * s * s);
		}
		return;
	}
	const double c = 3.14159265358979323846 / 6.0;
	double x0 = 0.0, x1 = 0.0, x2 = 0.0, x3 = 0.0;
	for (int k = 0; k < nq; k++) {
		const double s = 2.0 * a[k];
		x0 += c * n[k], x1 += c * n[k] * s, x2 += c * n[k] * s * s, x3 += c * n[k] * s * s * s;
	}
	const double q = 1.0 - x3, L = log1p(-x3), r = x2 / x3;
	const double d0 = -L, d1 = 3.0 * x2 / q;
	const double d2 = 3.0 * r * r * L + 3.0 * x1 / q + 3.0 * x2 * r / (q * q);
	const double d3 = -2.0 * r * r * r * L - (x2 * r * r - x0) / q + 3.0 * x1 * x2 / (q * q)
	                  - x2 * r * r / (q * q) + 2.0 * x2 * x2 * r / (q * q * q);
	for (int k = 0; k < nq; k++) {
		const double s = 2.0 * a[k];
		act[k] = exp(d0 + s * (d1 + s * (d2 + s * d3)));
	}
}

/* Reservoir walls from the scene (after setup_walls()): each one's entry
 * rate and velocity parameters. The reservoir is an ideal gas of number
 * density n = eta / v_p (v_p the particle volume) moving with velocity U
 * at temperature T; with c = m / (2 T) and a = U_n the component of U
 * along the wall's inward normal, the one-sided flux into the box is
 * (seed 001, eq. 3.15)
 *     F_+ = n / (2 sqrt(pi c)) f(sqrt(c) a),  f(t) = exp(-t^2) + sqrt(pi) t erfc(-t),
 * which is n sqrt(T / (2 pi m)) at a = 0; entries per unit time are F_+
 * times the face area (the box's cross-section). Other walls: rate 0. A
 * reservoir of gas "hard_spheres" enters at n exp(beta mu_ex(eta)) instead
 * of n: the activity of the hard-sphere gas at eta; a mixture's species k
 * at n_k exp(beta mu_ex,k) (hs_mix_activity()). */
static void setup_inlet(struct ed *ed, const scene_t *s)
{
	const double pi = 3.14159265358979323846;
	ed->inlet = scene_has_reservoir(s);
	for (int w = 0; w < 6; w++)
		ed->in_rate[w] = 0.0;
	if (!ed->inlet)
		return;
	const double vp = s->dim == 2 ? pi * s->radius * s->radius : 4.0 / 3.0 * pi * s->radius * s->radius * s->radius;
	for (int a = 0; a < s->dim; a++)
		for (int k = 0; k < 2; k++) {
			const scene_wall_t *sw = &s->boundary[a].wall[k];
			const int w = 2 * a + k;
			if (!s->boundary[a].walled || sw->type != SCENE_WALL_RESERVOIR)
				continue;
			/* gas "hard_spheres": the reservoir is a hard-sphere gas at volume_fraction, whose
			 * activity exp(beta mu_ex) n enters as an ideal gas's density (docs/engine.md) */
			const double act = sw->gas == SCENE_GAS_HARD_SPHERES ? hs_activity(s->dim, sw->volume_fraction) : 1.0;
			const double n = act * sw->volume_fraction / vp, c = s->mass / (2.0 * sw->temperature);
			const double ua = (k ? -1.0 : 1.0) * sw->velocity[a], t = sqrt(c) * ua;
			const double f = exp(-t * t) + sqrt(pi) * t * erfc(-t);
			double area = 1.0;
			for (int j = 0; j < s->dim; j++)
				if (j != a)
					area *= s->box[j];
			ed->in_rate[w] = n / (2.0 * sqrt(pi * c)) * f * area;
			if (scene_has_species(s)) {
				/* a mixture (ideal: actq is 1): species k at density x_k eta / v (v the mean
				 * particle volume at the fractions x), F_+ at its mass; independent Poisson
				 * streams, superposed: one of rate sum_k F_k, species k with probability F_k / sum */
				double x[SCENE_SPECIES_MAX], rk[SCENE_SPECIES_MAX], tot = 0.0;
				double nq[SCENE_SPECIES_MAX], aq[SCENE_SPECIES_MAX], actq[SCENE_SPECIES_MAX];
				scene_dispenser_fractions(s, sw, x);
				const double nt = sw->volume_fraction / scene_dispenser_volume(s, sw);
				for (int q = 0; q < s->n_species; q++) {
					nq[q] = nt * x[q];
					aq[q] = s->species[q].radius;
					actq[q] = 1.0;
				}
				/* gas "hard_spheres": species k enters at its activity n_k exp(beta mu_ex,k) of the
				 * mixture at the densities n_k (hs_mix_activity(): BMCSL in 3D, SYH-Henderson in 2D) */
				if (sw->gas == SCENE_GAS_HARD_SPHERES)
					hs_mix_activity(s->dim, s->n_species, nq, aq, actq);
				for (int q = 0; q < s->n_species; q++) {
					const double cq = s->species[q].mass / (2.0 * sw->temperature), tq = sqrt(cq) * ua;
					const double fq = exp(-tq * tq) + sqrt(pi) * tq * erfc(-tq);
					rk[q] = actq[q] * nt * x[q] / (2.0 * sqrt(pi * cq)) * fq * area;
					tot += rk[q];
					ed->in_sk[w][q] = sqrt(sw->temperature / s->species[q].mass);
				}
				double cum = 0.0;
				for (int q = 0; q < s->n_species; q++)
					ed->in_cum[w][q] = (cum += rk[q]) / tot;
				ed->in_cum[w][s->n_species - 1] = 1.0;
				ed->in_rate[w] = tot;
			}
			ed->in_a[w] = ua;
			ed->in_s[w] = sqrt(sw->temperature / s->mass);
			for (int j = 0; j < 3; j++)
				ed->in_u[w][j] = j < s->dim ? sw->velocity[j] : 0.0;
		}
}

/* Obstacles from the scene: internal centres, rules, minimum rebound. */
static void setup_obstacles(struct ed *ed, const scene_t *s)
{
	double g2 = 0.0;
	for (int a = 0; a < s->dim; a++)
		g2 += ed->g[a] * ed->g[a];
	ed->nobst = s->n_obstacles;
	for (int k = 0; k < s->n_obstacles; k++) {
		const scene_obstacle_t *so = &s->obstacle[k];
		obst_t *O = &ed->obst[k];
		O->type = so->type;
		for (int a = 0; a < 3; a++)
			O->c[a] = a < s->dim ? so->center[a] + (ed->periodic[a] ? 0.0 : ed->org[a]) : 0.0;
		O->S = so->radius + s->radius;
		O->r = so->restitution;
		O->sv = so->type == SCENE_OBST_NO_SLIP ? sqrt(so->temperature / s->mass) : 0.0;
		O->acc = so->accommodation;
		/* two hits tc apart against gravity's pull into the obstacle */
		O->vmin = 0.5 * s->tc * sqrt(g2);
	}
}

/* Cells from which a particle can touch each obstacle: the cell box (a
 * hair larger, against rounding at faces) within the contact distance of
 * the centre, images on periodic axes. Only the obstacle's bounding box of
 * cells is visited. */
static void build_ocell(struct ed *ed)
{
	memset(ed->ocell, 0, ed->ncells * sizeof(uint16_t));
	for (int k = 0; k < ed->nobst; k++) {
		const obst_t *O = &ed->obst[k];
		int32_t lo[3] = {0, 0, 0}, hi[3] = {0, 0, 0};
		for (int a = 0; a < ed->dim; a++) {
			lo[a] = (int32_t)floor((O->c[a] - O->S) / ed->cw[a]) - 1;
			hi[a] = (int32_t)floor((O->c[a] + O->S) / ed->cw[a]) + 1;
			if (ed->periodic[a]) {
				if (hi[a] - lo[a] + 1 >= ed->nc[a])
					lo[a] = 0, hi[a] = ed->nc[a] - 1;   /* all of the axis: every cell once */
			} else {
				if (lo[a] < 0) lo[a] = 0;
				if (hi[a] > ed->nc[a] - 1) hi[a] = ed->nc[a] - 1;
			}
		}
		int32_t q[3];
		for (q[2] = lo[2]; q[2] <= hi[2]; q[2]++)
			for (q[1] = lo[1]; q[1] <= hi[1]; q[1]++)
				for (q[0] = lo[0]; q[0] <= hi[0]; q[0]++) {
					int32_t cc[3] = {0, 0, 0};
					double d2 = 0.0;
					for (int a = 0; a < ed->dim; a++) {
						int32_t c = q[a];
						if (c < 0) c += ed->nc[a];
						else if (c >= ed->nc[a]) c -= ed->nc[a];
						cc[a] = c;
						const double eps = 1e-9 * ed->cw[a];
						double best = INFINITY;
						for (int sh = -1; sh <= 1; sh++) {   /* images: periodic axes only */
							if (sh && !ed->periodic[a])
								continue;
							double f0 = c * ed->cw[a] + sh * ed->L[a] - eps, f1 = (c + 1) * ed->cw[a] + sh * ed->L[a] + eps;
							double x = O->c[a] < f0 ? f0 - O->c[a] : O->c[a] > f1 ? O->c[a] - f1 : 0.0;
							if (x < best)
								best = x;
						}
						d2 += best * best;
					}
					if (d2 <= O->S * O->S * (1.0 + 1e-9))
						ed->ocell[DISPATCH(ed, cell_index, ed, cc)] |= (uint16_t)(1u << k);
				}
	}
}

/* Walled axes: neighbour cells -1, 0, +1 clipped at the ends (no images);
 * only small periodic axes need the minimum image; the cells each wall can
 * reach. */
static void setup_wall_cells(struct ed *ed)
{
	ed->minimg = 0;
	for (int a = 0; a < ed->dim; a++) {
		if (ed->periodic[a]) {
			if (ed->nc[a] < 3)
				ed->minimg = 1;
			continue;
		}
		ed->no[a] = 3;
		ed->off[a][0] = -1, ed->off[a][1] = 0, ed->off[a][2] = 1;
		for (int k = 0; k < 2; k++) {
			double reach = 2.0 * ed->wall[2 * a + k].A + ed->radius;
			if (ed->wall[2 * a + k].type == SCENE_WALL_DISPENSER)   /* the piston's whole travel */
				reach += ed->wall[2 * a + k].lh * (1.0 + 1e-9);
			double z = floor(reach / ed->cw[a]) + 1.0;
			ed->nzone[2 * a + k] = z < ed->nc[a] ? (int32_t)z : ed->nc[a];
		}
	}
}

/* The engine's arrays in bytes (ed_alloc() allocates exactly these, with
 * big_alloc() but for the scratch arrays; ed_plan() adds them up), for an
 * engine of ed's geometry with neighbour lists (nl) and TC times (tc);
 * absent arrays are 0. */
enum { A_P, A_EV, A_HEAP, A_CN, A_CALHEAD, A_HEAD, A_OCC, A_NEXT, A_ID, A_SCRATCH_IDX, A_SCRATCH_CELL,
       A_XN, A_NB, A_NN, A_MARK, A_TLAST, A_OCELL, A_GONE, A_SPIN, A_DMEAN, A_DSUM, A_DPOS, A_DVEL, A_SPC, A_MIX, A_PRAD, A_RSCENE, A_FREE, A_LABEL, A_FROZEN, A_TPL, A_IMG, A_COUNT };
static void array_bytes(const struct ed *ed, int nl, int tc, size_t b[A_COUNT])
{
	const size_t n = ed->n;
	b[A_P] = n * (ed->dim == 2 ? sizeof(p2_t) : sizeof(p3_t));
	b[A_EV] = n * sizeof(ev_t);
	b[A_HEAP] = n * sizeof(hent_t);
	b[A_CN] = n * sizeof(cnode_t);
	b[A_CALHEAD] = (ed->cal_m + 1) * sizeof(int32_t);
	b[A_HEAD] = ed->ncells * sizeof(int32_t);
	b[A_OCC] = (ed->ncells + 63) / 64 * sizeof(uint64_t);
	b[A_NEXT] = n * sizeof(int32_t);
	b[A_ID] = n * sizeof(uint32_t);
	b[A_SCRATCH_IDX] = n * sizeof(uint32_t);
	b[A_SCRATCH_CELL] = (ed->ncells + 1) * sizeof(uint32_t);
	b[A_XN] = nl ? n * ed->dim * sizeof(double) : 0;
	b[A_NB] = nl ? n * ed->nlk * sizeof(int32_t) : 0;
	b[A_NN] = b[A_MARK] = nl ? n : 0;
	b[A_TLAST] = tc ? n * sizeof(double) : 0;
	b[A_OCELL] = ed->nobst ? ed->ncells * sizeof(uint16_t) : 0;
	b[A_GONE] = ed->open ? n : 0;
	b[A_SPIN] = ed->rough ? n * (ed->dim == 2 ? 1 : 3) * sizeof(double) : 0;
	b[A_DMEAN] = ed->drive ? ed->drv_bins * ed->dim * sizeof(double) : 0;
	b[A_DSUM] = ed->drive ? ed->drv_bins * (ed->dim + 1) * sizeof(double) : 0;
	b[A_DPOS] = b[A_DVEL] = ed->drive && ed->drv_bins > 1 ? n * ed->dim * sizeof(double) : 0;
	b[A_SPC] = ed->mixture ? n : 0;
	b[A_MIX] = ed->mixture ? sizeof(struct ed_mix) : 0;
	b[A_PRAD] = b[A_RSCENE] = ed->mixture ? n * sizeof(double) : 0;
	b[A_FREE] = ed->inlet ? n * sizeof(uint32_t) : 0;
	b[A_LABEL] = ed->inlet ? n * sizeof(int64_t) : 0;
	b[A_FROZEN] = ed->nfilt ? n : 0;
	size_t ntd = 0;
	for (int w = 0; w < 6; w++)
		if (ed->disp >> w & 1)
			ntd += (size_t)ed->ntpl * ed->tpl_n[w] * ed->dim;
	b[A_TPL] = ntd * sizeof(double);
	b[A_IMG] = ed->img_on ? n * ed->dim * sizeof(int32_t) : 0;
}

/* Cells cost memory even when empty (~9 bytes each): a grid finer than this
 * (an explicit ed.cell_size in a dilute box; the automatic grid has at
 * most 8 per particle) is a scene error, not an out-of-memory failure at
 * start. A million cells (9 MB) are always allowed. */
#define ED_CELLS_FREE 1048576.0
static int too_many_cells(size_t ncells, uint32_t n) { return (double)ncells > 64.0 * n + ED_CELLS_FREE; }

/* Pair tables of a mixture (struct ed, "Species"). ed->sigma is the
 * largest diameter: cells, neighbour-list radii and lattice spacing are set
 * by it, so every pair's contact lies within one cell layer. */
static void setup_species(struct ed *ed, const scene_t *s)
{
	const int ns = s->n_species;
	ed->mix->first[0] = 0;
	for (int a = 0; a < ns; a++) {
		ed->mix->m[a] = s->species[a].mass;
		ed->mix->npres[a] = s->species[a].count;
		ed->mix->first[a + 1] = ed->mix->first[a] + (uint32_t)s->species[a].count;
	}
	mix_present(ed, -1, 0);
	for (int a = 0; a < ns; a++)
		for (int b = 0; b < ns; b++) {
			const int q = a * ns + b;
			const double ma = s->species[a].mass, mb = s->species[b].mass;
			struct ed_mix *x = ed->mix;
			x->e[q] = s->restitution_pair[a][b];
			x->w[q] = mb / (ma + mb);
			x->mu[q] = ma * mb / (ma + mb);
		}
}

/* A mixture's open stream (after setup_stream() and setup_species(), rsp
 * filled): the free stacks' offsets (the rows of each species), and per
 * species the dispensers' thermal speeds and the filters' turn-back
 * probability and thermal speed (as setup_stream() for one species, at
 * the species' mass). */
static void setup_stream_species(struct ed *ed, const scene_t *s)
{
	struct ed_mix *x = ed->mix;
	uint32_t rows[SCENE_SPECIES_MAX] = {0};
	for (uint32_t r = 0; r < ed->n; r++)
		rows[x->rsp[r]]++;
	for (int k = 0, o = 0; k < ed->nsp; o += (int)rows[k], k++)
		x->fs_off[k] = (uint32_t)o;
	x->poly = 0;
	for (int k = 0; k < ed->nsp; k++)
		x->poly |= (unsigned)(s->species[k].radius_hi > 0) << k;
	for (int a = 0; a < s->dim; a++) {
		if (!s->boundary[a].walled)
			continue;
		for (int e = 0; e < 2; e++) {
			const scene_wall_t *sw = &s->boundary[a].wall[e];
			const int w = 2 * a + e;
			const double sg = e ? -1.0 : 1.0;
			for (int k = 0; k < ed->nsp; k++) {
				const double m = x->m[k];
				if (sw->type == SCENE_WALL_DISPENSER)
					x->dsv[w][k] = sqrt(sw->temperature / m);
				if (sw->type == SCENE_WALL_OPEN && sw->filter.on && sw->filter.temperature > 0.0) {
					const double t = sqrt(m / (2.0 * sw->filter.temperature)) * -sg * sw->filter.velocity[a];
					const double sp = 1.77245385090551602730;
					x->fback[w][k] = (exp(-t * t) - sp * t * erfc(t)) / (exp(-t * t) + sp * t * erfc(-t));
					x->fsv[w][k] = sqrt(sw->filter.temperature / m);
				}
			}
		}
	}
}

/* spc and prad from the scene indices (id): species are blocks of scene
 * indices (rsp, scene_row_species()), radii drawn in scene order. */
static void species_from_id(struct ed *ed)
{
	for (uint32_t i = 0; i < ed->n; i++) {
		ed->spc[i] = ed->mix->rsp[ed->id[i]];
		ed->prad[i] = ed->mix->rscene[ed->id[i]];
	}
}


/* ---- seed 001's open stream: dispenser layout and filters (setup) ------ */

/* Template layers: this many equilibrated snapshots per dispenser. */
enum { TPL_LAYERS = 16 };

/* The starting layout of dispenser wall w's layer (2D): n = ceil(eta h W /
 * v_p) particles in R rows across the layer, centres at normal
 * coordinates r ... h - r from the piston (R = 1: h / 2), each row evenly
 * spaced along the transverse axis (periodic: the whole edge; walled: a
 * radius clear of its walls), odd rows shifted by half a spacing; R is
 * the fewest rows with every pair at least a diameter apart. Writes the
 * positions (n x 2: normal, transverse) when pos is not NULL. ED_OK, or
 * ED_EINVAL with "KEY: reason" in msg. Pure; O(n^2 / R) for the check. */
static int layer_layout(const struct ed *ed, const scene_t *s, int w, double *pos, uint32_t *nout, char *msg,
                        size_t msglen)
{
	const double pi = 3.14159265358979323846, r = s->radius, sig = 2.0 * r;
	const int a = w >> 1, b = 1 - a;
	const scene_wall_t *sw = &s->boundary[a].wall[w & 1];
	const double h = ed->wall[w].lh, W = s->box[b];
	const int per = !s->boundary[b].walled;
	const double vp = ed->mixture ? scene_dispenser_volume(s, sw) : pi * r * r;   /* mixtures: the mean at its fractions */
	const double n_d = sw->volume_fraction * h * W / vp;
	static const char *const an[] = { "x", "y" };
	const char *end = (w & 1) ? "upper" : "lower";
	if (!(n_d >= 1.5) || n_d > INT32_MAX) {
		if (msg && msglen)
			snprintf(msg, msglen, "boundaries.%s.%s.thickness: the layer holds %.3g particles (volume_fraction x "
			         "thickness x width / particle area); it must hold at least two", an[a], end, n_d);
		return ED_EINVAL;
	}
	const uint32_t n = (uint32_t)ceil(n_d);
	for (uint32_t R = 1; R <= 64 && R <= n; R++) {
		const double dx = R > 1 ? (h - 2.0 * r) / (R - 1) : 0.0;
		const double span = per ? W : W - 2.0 * r;   /* transverse room for the centres */
		int ok = 1;
		/* row k holds n / R particles, the first n % R rows one more */
		for (uint32_t k1 = 0; k1 < R && ok; k1++) {
			const uint32_t m1 = n / R + (k1 < n % R);
			if (m1 == 0)
				continue;
			for (uint32_t k2 = k1; k2 < R && ok; k2++) {
				const double ddx = (double)(k2 - k1) * dx;
				if (ddx >= sig)
					break;
				const uint32_t m2 = n / R + (k2 < n % R);
				for (uint32_t i = 0; i < m1 && ok; i++) {
					const double y1 = (i + 0.25 + 0.5 * (k1 & 1)) * span / m1;
					for (uint32_t j = (k1 == k2 ? i + 1 : 0); j < m2; j++) {
						double dy = fabs(y1 - (j + 0.25 + 0.5 * (k2 & 1)) * span / m2);
						if (per && dy > 0.5 * W)
							dy = W - dy;
						if (ddx * ddx + dy * dy < sig * sig * (1.0 + 1e-12)) {
							ok = 0;
							break;
						}
					}
				}
				if (per && k1 == k2 && m1 == 1 && W < sig * (1.0 + 1e-12))
					ok = 0;
			}
		}
		if (!ok)
			continue;
		if (pos) {
			uint32_t q = 0;
			for (uint32_t k = 0; k < R; k++) {
				const uint32_t m = n / R + (k < n % R);
				for (uint32_t i = 0; i < m; i++, q++) {
					pos[2 * q + a] = R > 1 ? r + k * dx : 0.5 * h;
					pos[2 * q + b] = (per ? 0.0 : r) + (i + 0.25 + 0.5 * (k & 1)) * span / m;
				}
			}
		}
		*nout = n;
		return ED_OK;
	}
	if (msg && msglen)
		snprintf(msg, msglen, "boundaries.%s.%s.volume_fraction: a layer of %u particles (volume_fraction x thickness "
		         "x width / particle area) does not fit into rows a diameter apart across the thickness %.6g; lower "
		         "the volume fraction or change the thickness", an[a], end, n, h);
	return ED_EINVAL;
}

/* The same in 3D: n = ceil(eta h W1 W2 / v_p) particles in R rows across
 * the layer (centres at r ... h - r from the piston, R = 1: h / 2), each
 * row a grid of nx x ny >= m sites over the transverse plane (the grid
 * whose smaller spacing is the largest), evenly spaced as in 2D (periodic
 * axes: the whole edge; walled ones: a radius clear of their walls; odd
 * rows shifted by half a spacing along both), R the fewest rows with every
 * pair at least a diameter apart (checked pair by pair, minimum image
 * along periodic axes; pairs in rows a diameter apart or more are apart).
 * Writes the positions (n x 3, scene axes) when pos is not NULL. ED_OK or
 * ED_EINVAL with "KEY: reason" in msg. Pure; O(n^2) per tried R. */
static int layer_layout3(const struct ed *ed, const scene_t *s, int w, double *pos, uint32_t *nout, char *msg,
                         size_t msglen)
{
	const double pi = 3.14159265358979323846, r = s->radius, sig = 2.0 * r;
	const int a = w >> 1, b1 = a == 0 ? 1 : 0, b2 = a == 2 ? 1 : 2;
	const scene_wall_t *sw = &s->boundary[a].wall[w & 1];
	const double h = ed->wall[w].lh, W1 = s->box[b1], W2 = s->box[b2];
	const int per1 = !s->boundary[b1].walled, per2 = !s->boundary[b2].walled;
	const double vp = ed->mixture ? scene_dispenser_volume(s, sw) : 4.0 / 3.0 * pi * r * r * r;
	const double n_d = sw->volume_fraction * h * W1 * W2 / vp;
	static const char *const an[] = { "x", "y", "z" };
	const char *end = (w & 1) ? "upper" : "lower";
	double *q = NULL;
	int rc = ED_EINVAL;
	if (!(n_d >= 1.5) || n_d > 1e6) {
		if (msg && msglen)
			snprintf(msg, msglen, "boundaries.%s.%s.thickness: the layer holds %.3g particles (volume_fraction x "
			         "thickness x cross-section / particle volume); it must hold 2 ... 10^6", an[a], end, n_d);
		return ED_EINVAL;
	}
	const uint32_t n = (uint32_t)ceil(n_d);
	const double span1 = per1 ? W1 : W1 - 2.0 * r, span2 = per2 ? W2 : W2 - 2.0 * r;
	if (!(q = malloc((size_t)n * 3 * sizeof(double)))) {
		if (msg && msglen)
			snprintf(msg, msglen, "boundaries.%s.%s: out of memory for the layer's layout", an[a], end);
		return ED_ENOMEM;
	}
	for (uint32_t R = 1; R <= 64 && R <= n; R++) {
		const double dx = R > 1 ? (h - 2.0 * r) / (R - 1) : 0.0;
		uint32_t k0 = 0;
		for (uint32_t k = 0; k < R; k++) {
			const uint32_t m = n / R + (k < n % R);
			uint32_t nx = 1;   /* the grid whose smaller spacing is the largest */
			double best = -1.0;
			for (uint32_t cx = 1; cx <= m; cx++) {
				const uint32_t cy = (m + cx - 1) / cx;
				const double sp = fmin(span1 / cx, span2 / cy);
				if (sp > best) {
					best = sp;
					nx = cx;
				}
			}
			const uint32_t ny = (m + nx - 1) / nx;
			const double o = 0.25 + 0.5 * (k & 1);
			for (uint32_t i = 0; i < m; i++, k0++) {
				q[3 * k0 + a] = R > 1 ? r + k * dx : 0.5 * h;
				q[3 * k0 + b1] = (per1 ? 0.0 : r) + ((i % nx) + o) * span1 / nx;
				q[3 * k0 + b2] = (per2 ? 0.0 : r) + ((i / nx) + o) * span2 / ny;
			}
		}
		int ok = 1;
		for (uint32_t i = 0; i < n && ok; i++)
			for (uint32_t j = i + 1; j < n; j++) {
				double d2 = 0.0;
				if (fabs(q[3 * i + a] - q[3 * j + a]) >= sig)   /* rows a diameter apart or more (as in 2D) */
					continue;
				for (int c = 0; c < 3; c++) {
					double d = fabs(q[3 * i + c] - q[3 * j + c]);
					if ((c == b1 && per1) || (c == b2 && per2)) {
						const double L = c == b1 ? W1 : W2;
						if (d > 0.5 * L)
							d = L - d;
					}
					d2 += d * d;
				}
				if (d2 < sig * sig * (1.0 + 1e-12)) {
					ok = 0;
					break;
				}
			}
		if (!ok)
			continue;
		if (pos)
			memcpy(pos, q, (size_t)n * 3 * sizeof(double));
		*nout = n;
		rc = ED_OK;
		goto done;
	}
	if (msg && msglen)
		snprintf(msg, msglen, "boundaries.%s.%s.volume_fraction: a layer of %u particles (volume_fraction x thickness "
		         "x cross-section / particle volume) does not fit into rows a diameter apart across the thickness "
		         "%.6g; lower the volume fraction or change the thickness", an[a], end, n, h);
done:
	free(q);
	return rc;
}

/* Filters and the dispenser from the scene (walls variant, after the
 * cells): each filter's plane (internal coordinate), frozen velocity and
 * the cells from which a particle can cross it; the dispenser's wall and
 * its layer's velocity; the layer's size (layer_layout). */
static int setup_stream(struct ed *ed, const scene_t *s, char *msg, size_t msglen)
{
	ed->nfilt = 0;
	ed->disp = 0;
	for (int a = 0; a < s->dim; a++) {
		if (!s->boundary[a].walled)
			continue;
		for (int k = 0; k < 2; k++) {
			const scene_wall_t *sw = &s->boundary[a].wall[k];
			const int w = 2 * a + k;
			const double sg = k ? -1.0 : 1.0;
			if (sw->type == SCENE_WALL_OPEN && sw->filter.on) {
				ed->nfilt++;
				ed->fplane[w] = ed->wall[w].rest + sg * sw->filter.distance;
				for (int j = 0; j < 3; j++)
					ed->fu[w][j] = j < s->dim ? sw->filter.velocity[j] : 0.0;
				ed->fback[w] = 0.0;
				if (sw->filter.temperature > 0.0) {
					/* F_- / F_+ = f(-t) / f(t), t = sqrt(m / 2T) U (outward), f(t) = exp(-t^2) + sqrt(pi) t erfc(-t) */
					const double t = sqrt(s->mass / (2.0 * sw->filter.temperature)) * -sg * sw->filter.velocity[a];
					const double sp = 1.77245385090551602730;
					ed->fback[w] = (exp(-t * t) - sp * t * erfc(t)) / (exp(-t * t) + sp * t * erfc(-t));
					ed->fsv[w] = sqrt(sw->filter.temperature / s->mass);
				}
				/* the plane's cell, and one more inwards against rounding at a face */
				int32_t c = (int32_t)floor(ed->fplane[w] / ed->cw[a]) + (int32_t)sg;
				if (c < 0) c = 0;
				if (c >= ed->nc[a]) c = ed->nc[a] - 1;
				ed->fcell[w] = c + 1;
			}
			if (sw->type == SCENE_WALL_DISPENSER) {
				ed->disp |= 1 << w;
				for (int j = 0; j < 3; j++)
					ed->disp_u[w][j] = j < s->dim ? sw->velocity[j] : 0.0;
				ed->disp_s[w] = sqrt(sw->temperature / s->mass);
				int rc = s->dim == 2 ? layer_layout(ed, s, w, NULL, &ed->tpl_n[w], msg, msglen)
				                     : layer_layout3(ed, s, w, NULL, &ed->tpl_n[w], msg, msglen);
				if (rc != ED_OK)
					return rc;
				const double pi = 3.14159265358979323846, rr = s->radius;
				const double vp = ed->mixture ? scene_dispenser_volume(s, sw) : s->dim == 2 ? pi * rr * rr
				                                                                      : 4.0 / 3.0 * pi * rr * rr * rr;
				const double n_d = s->dim == 2 ? sw->volume_fraction * ed->wall[w].lh * s->box[1 - a] / vp
				                               : sw->volume_fraction * ed->wall[w].lh * s->box[a == 0 ? 1 : 0] *
				                                 s->box[a == 2 ? 1 : 2] / vp;
				ed->tpl_frac[w] = n_d - floor(n_d);
				if (ed->tpl_frac[w] == 0.0)
					ed->tpl_frac[w] = 1.0;   /* a whole number: every recharge places them all */
				ed->ntpl = TPL_LAYERS;
			}
		}
	}
	int filt = 0;
	for (int w = 0; w < 6; w++)
		filt |= (ed->fcell[w] != 0) << w;
	for (int w = 0; w < 6; w++) {
		ed->dclip[w] = (ed->disp >> w & 1) ? ed->disp & ~(3 << (w & ~1)) : 0;
		ed->fclip[w] = (ed->disp >> w & 1) ? filt & ~(3 << (w & ~1)) : 0;
	}
	size_t off = 0;
	for (int w = 0; w < 6; w++) {
		ed->tpl_off[w] = off;
		if (ed->disp >> w & 1)
			off += (size_t)ed->ntpl * ed->tpl_n[w] * s->dim;
	}
	return ED_OK;
}

/* The lowest wall with a dispenser (its templates keep the seed stream
 * they had when a scene could have one dispenser only). */
static int ed_first_disp(const struct ed *ed)
{
	int w = 0;
	while (w < 5 && !(ed->disp >> w & 1))
		w++;
	return w;
}

/* The template scene of dispenser wall w's layers, common to one species and mixtures: the scene s as a
 * strip h thick along the wall's axis holding n particles, elastic and specular all round, without
 * obstacles, driving, TC or spins (positions only: the layers' spins are drawn at each recharge), at the
 * dispenser's volume fraction and temperature, at rest; gravity: the strip in the same field, the
 * template's normal coordinate counted from the piston (an upper wall's layer is flipped along the axis
 * when placed: the field along it is flipped here). */
static void layer_strip(const scene_t *s, scene_t *t, int w, uint32_t n, double h)
{
	const int a = w >> 1, D = s->dim;
	memcpy(t, s, sizeof *t);
	t->count = t->capacity = n;
	t->box[a] = h;
	t->volume_fraction = s->boundary[a].wall[w & 1].volume_fraction;
	for (int k = 0; k < 2; k++) {
		t->boundary[a].wall[k] = (scene_wall_t){ .type = SCENE_WALL_SPECULAR, .restitution = 1.0, .coverage = -1.0 };
		for (int b = 0; b < D; b++)
			if (b != a && t->boundary[b].walled)
				t->boundary[b].wall[k] = (scene_wall_t){ .type = SCENE_WALL_SPECULAR, .restitution = 1.0,
				                                         .coverage = -1.0 };
	}
	t->boundary[a].walled = 1;
	t->n_obstacles = 0;
	t->drive = SCENE_DRIVE_NONE;
	t->tc = 0.0;
	t->restitution = 1.0;
	t->rough = 0;
	t->init_spin = NULL;
	t->temperature = s->boundary[a].wall[w & 1].temperature;
	for (int k = 0; k < 3; k++) {
		t->flow[k] = 0.0;
		t->gravity[k] = k == a && (w & 1) ? -s->gravity[k] : s->gravity[k];
	}
}

/* The dispenser's template layers: its starting layout (layer_layout)
 * equilibrated by an elastic run of its own, a strip of the layer's
 * thickness between two specular walls across the transverse axis of the
 * scene (periodic, or specular walls where the scene has walls), 50
 * collisions per particle, then TPL_LAYERS snapshots 20 collisions per
 * particle apart. Positions are clamped into [r, h - r] against rounding
 * at the strip's walls. Deterministic (the scene's seed, a stream of its
 * own). */
static int build_templates(struct ed *ed, const scene_t *s, int w, char *msg, size_t msglen)
{
	const int a = w >> 1, D = s->dim;
	const uint32_t n = ed->tpl_n[w];
	const double r = s->radius, h = ed->wall[w].lh;
	int rc = ED_ENOMEM;
	double *pos = malloc((size_t)n * D * sizeof(double));
	scene_t *t = malloc(sizeof *t);
	ed_t *sub = NULL;
	if (!pos || !t)
		goto done;
	if (D == 2)
		layer_layout(ed, s, w, pos, &ed->tpl_n[w], NULL, 0);
	else if ((rc = layer_layout3(ed, s, w, pos, &ed->tpl_n[w], msg, msglen)) != ED_OK)
		goto done;
	layer_strip(s, t, w, n, h);
	t->init_pos = pos;
	t->init_vel = NULL;
	t->has_region = t->has_from = 0;
	t->relax_cpp = 50.0;
	t->ed_cell_size = 0.0;
	t->stream = s->stream | (1ull << 59) | (uint64_t)(w != ed_first_disp(ed)) * ((uint64_t)w << 52);
	int err = ED_OK;
	sub = ed_create(t, &err, msg, msglen);
	if (!sub) {
		rc = err;
		goto done;
	}
	for (int q = 0; q < ed->ntpl; q++) {
		if (q > 0)
			ed_advance(sub, INFINITY, ed_collisions(sub) + 10ull * n, UINT64_MAX);
		double *out = ed->tpl + ed->tpl_off[w] + (size_t)q * n * D;
		ed_state(sub, out, NULL);
		for (uint32_t i = 0; i < n; i++)
			out[(size_t)D * i + a] = fmin(fmax(out[(size_t)D * i + a], r), h - r);
	}
	rc = ED_OK;
done:
	ed_destroy(sub);
	free(pos);
	free(t);
	return rc;
}

/* Constants, mode and grid of scene s in ed (no arrays): the checks a
 * scene must pass before allocating, shared by ed_alloc() and ed_plan().
 * ED_OK or ED_EINVAL with "KEY: reason" in msg. */
static int geometry(struct ed *ed, const scene_t *s, char *msg, size_t msglen)
{
	if (s->dim != 2 && s->dim != 3) {
		set_msg(msg, msglen, "dimensions: must be 2 or 3%.0s%.0s", 0, 0);
		return ED_EINVAL;
	}
	if (s->count < 2 || s->count > INT32_MAX) {
		set_msg(msg, msglen, "particles.count: %.0f is outside 2..2^31-1%.0s", (double)s->count, 0);
		return ED_EINVAL;
	}
	ed->dim = s->dim;
	ed->n = (uint32_t)s->count;
	ed->n_init = ed->n;
	ed->img_on = scene_msd_images(s);
	ed->inlet = scene_has_reservoir(s);
	if (ed->inlet) {
		if (s->capacity < s->count || s->capacity > INT32_MAX) {
			set_msg(msg, msglen, "particles.capacity: %.0f is outside particles.count .. 2^31-1%.0s",
			        (double)s->capacity, 0);
			return ED_EINVAL;
		}
		int res = 0;   /* a "reservoir" wall (dispensers take polydisperse species: dispense_mix()) */
		for (int a = 0; a < s->dim; a++)
			for (int k = 0; k < 2; k++)
				res |= s->boundary[a].walled && s->boundary[a].wall[k].type == SCENE_WALL_RESERVOIR;
		/* mixtures: each slot has its species (dispense_mix(), inlet_enter_mix()); a reservoir's entering
		 * particle takes a slot of its species' one radius */
		for (int k = 0; k < s->n_species && scene_has_species(s) && res; k++)
			if (s->species[k].radius_hi > 0) {
				set_msg(msg, msglen, "particles.species[%.0f].radius_range: not with a \"reservoir\" wall%.0s",
				        (double)k, 0);
				return ED_EINVAL;
			}
		ed->n = (uint32_t)s->capacity;   /* slots; n_init of them filled at the start */
	}
	ed->sigma = 2.0 * s->radius;
	ed->sigma2 = ed->sigma * ed->sigma;
	ed->mass = s->mass;
	ed->e = s->restitution;
	ed->tc = s->tc;
	for (int a = 0; a < 3; a++) {
		ed->L[a] = a < s->dim ? s->box[a] : 1.0;
		ed->halfL[a] = 0.5 * ed->L[a];
	}
	/* obstacles live in the walls variants (all axes may be periodic there) */
	ed->variant = scene_has_gravity(s) ? 2 : scene_has_walls(s) || scene_has_obstacles(s) ? 1 : 0;
	ed->open = scene_has_open_walls(s) || scene_has_reservoir(s);   /* (dispensers: empty slots) */
	ed->rough = s->rough;
	ed->drive = s->drive;
	if (ed->drive) {
		ed->drv_interval = s->drive_interval;
		ed->drv_temp = s->drive_temperature;
		ed->drv_xi2 = s->drive_strength;
		ed->drv_tavg = s->drive_average_time;
		ed->drv_bins = 1;
		for (int a = 0; a < 3; a++) {
			ed->drv_box[a] = a < s->dim ? s->box[a] : 1.0;
			ed->drv_grid[a] = a < s->dim ? s->drive_grid[a] : 1;
			ed->drv_bins *= (size_t)ed->drv_grid[a];
		}
	}
	ed->ops = ed->rough ? &ed_ops_rough[ed->dim - 2][ed->variant] : &ed_ops[ed->dim - 2][ed->variant];
	ed->nsp = 1;
	if (scene_has_species(s)) {
		ed->nsp = s->n_species;   /* tables: setup_species() in ed_alloc() */
		ed->mixture = 1;
		ed->ops = ed->rough ? &ed_ops_species_rough[ed->dim - 2][ed->variant] : &ed_ops_species[ed->dim - 2][ed->variant];
		if (ed->variant == 2 && scene_has_filter(s))   /* filters under gravity with species */
			ed->ops = ed->rough ? &ed_ops_filtg_species_rough[ed->dim - 2] : &ed_ops_filtg_species[ed->dim - 2];
	} else if (ed->variant == 2 && scene_has_filter(s)) {   /* filters under gravity (one species) */
		ed->ops = ed->rough ? &ed_ops_filtg_rough[ed->dim - 2] : &ed_ops_filtg[ed->dim - 2];
	}
	if (ed->rough) {
		ed->rbeta = s->rough_beta;
		ed->rmu = s->rough_mu;
		ed->rq = s->rough_q;
	}
	if (ed->variant) {
		setup_walls(ed, s);
		setup_inlet(ed, s);
		setup_obstacles(ed, s);
		setup_cells(ed, s->ed_cell_size * ed->sigma);   /* cell mode only */
		setup_wall_cells(ed);
		int rc = setup_stream(ed, s, msg, msglen);
		if (rc != ED_OK)
			return rc;
	} else {
		setup_mode(ed, s->ed_cell_size * ed->sigma);
	}
	if (too_many_cells(ed->ncells, ed->n)) {
		set_msg(msg, msglen, "ed.cell_size: gives %.3g cells, more than 64 per particle (beyond the first %.0f); "
		        "use a larger cell_size or 0 (automatic)", (double)ed->ncells, ED_CELLS_FREE);
		return ED_EINVAL;
	}
	/* a power of two >= N: bucket numbers wrap with a mask, not a division */
	ed->cal_m = 64;
	while (ed->cal_m < ed->n)
		ed->cal_m *= 2;
	return ED_OK;
}

/* A mixture's template layers (build_templates() for one species): the
 * same starting layout (sites a largest diameter apart), template q
 * holding n_k(q) = floor(n X_k + (q + 1/2) / ntpl) - (the same for k - 1)
 * particles of species k (X_k the dispenser's fractions of species 0 .. k
 * summed, scene_dispenser_fractions(): over the ntpl templates the mean of
 * n_k is n x_k to within 1 / (2 ntpl)), the sites
 * shuffled among the species (so that they mix across the layer), each
 * template relaxed by an elastic run of its own (the mixture between
 * specular walls, 50 collisions per particle; seed stream as
 * build_templates()' plus (q + 1) << 40). Positions clamped into [r_k, h -
 * r_k] (r_k the particle's radius); species in tsp. */
static int build_templates_mix(struct ed *ed, const scene_t *s, int w, char *msg, size_t msglen)
{
	const int a = w >> 1, D = s->dim, ns = s->n_species;
	const uint32_t n = ed->tpl_n[w];
	const double h = ed->wall[w].lh;
	struct ed_mix *x = ed->mix;
	int rc = ED_ENOMEM;
	double *pos = malloc((size_t)n * D * sizeof(double)), *sh = malloc((size_t)n * D * sizeof(double));
	scene_t *t = malloc(sizeof *t);
	ed_t *sub = NULL;
	if (!pos || !sh || !t)
		goto done;
	if (D == 2)
		layer_layout(ed, s, w, pos, &ed->tpl_n[w], NULL, 0);
	else if ((rc = layer_layout3(ed, s, w, pos, &ed->tpl_n[w], msg, msglen)) != ED_OK)
		goto done;
	memset(x->tmax[w], 0, sizeof x->tmax[w]);
	const uint64_t stream = s->stream | (1ull << 59) | (uint64_t)(w != ed_first_disp(ed)) * ((uint64_t)w << 52);
	double frac[SCENE_SPECIES_MAX];
	scene_dispenser_fractions(s, &s->boundary[a].wall[w & 1], frac);
	for (int q = 0; q < ed->ntpl; q++) {
		uint32_t cnt[SCENE_SPECIES_MAX], prev = 0;
		double X = 0.0;
		for (int k = 0; k < ns; k++) {
			X += frac[k];
			double bd = floor((double)n * X + (q + 0.5) / ed->ntpl);
			uint32_t bk = k == ns - 1 || bd >= (double)n ? n : (uint32_t)bd;
			if (bk < prev)
				bk = prev;
			cnt[k] = bk - prev;
			prev = bk;
			if (cnt[k] > x->tmax[w][k])
				x->tmax[w][k] = cnt[k];
		}
		layer_strip(s, t, w, n, h);
		/* the species present in this template, in index order */
		uint8_t map[SCENE_SPECIES_MAX];
		int m = 0;
		double rmax = 0.0, msum = 0.0;
		for (int k = 0; k < ns; k++)
			if (cnt[k]) {
				t->species[m] = s->species[k];
				t->species[m].count = cnt[k];
				/* a polydisperse species: sites of its largest radius (any slot of it fits one) */
				t->species[m].radius_lo = t->species[m].radius_hi = 0.0;
				map[m++] = (uint8_t)k;
				rmax = fmax(rmax, s->species[k].radius);
				msum += (double)cnt[k] * s->species[k].mass;
			}
		t->n_species = m;
		t->radius = rmax;
		t->mass = msum / (double)n;
		for (int i = 0; i < SCENE_SPECIES_MAX; i++)
			for (int j = 0; j < SCENE_SPECIES_MAX; j++)
				t->restitution_pair[i][j] = 1.0;
		/* the sites shuffled among the particles (Fisher-Yates) */
		rng_t g;
		rng_init(&g, s->seed, stream | ((uint64_t)(q + 1) << 40) | (1ull << 39));
		memcpy(sh, pos, (size_t)n * D * sizeof(double));
		for (uint32_t i = n; i-- > 1;) {
			uint32_t j = (uint32_t)(rng_uniform(&g) * (i + 1));
			if (j > i)
				j = i;
			for (int c = 0; c < D; c++) {
				const double y = sh[(size_t)D * i + c];
				sh[(size_t)D * i + c] = sh[(size_t)D * j + c];
				sh[(size_t)D * j + c] = y;
			}
		}
		t->init_pos = sh;
		t->init_vel = NULL;
		t->has_region = t->has_from = 0;
		t->relax_cpp = 50.0;
		t->ed_cell_size = 0.0;
		t->stream = stream | ((uint64_t)(q + 1) << 40);
		int err = ED_OK;
		if (!(sub = ed_create(t, &err, msg, msglen))) {
			rc = err;
			goto done;
		}
		double *out = ed->tpl + ed->tpl_off[w] + (size_t)q * n * D;
		uint8_t *ts = x->tsp + ed->tpl_off[w] / (size_t)D + (size_t)q * n;
		ed_state(sub, out, NULL);
		uint32_t i = 0;
		for (int k = 0; k < m; k++)
			for (uint32_t j = 0; j < t->species[k].count; j++, i++) {
				const double rk = s->species[map[k]].radius;
				ts[i] = map[k];
				out[(size_t)D * i + a] = fmin(fmax(out[(size_t)D * i + a], rk), h - rk);
			}
		ed_destroy(sub);
		sub = NULL;
	}
	rc = ED_OK;
done:
	ed_destroy(sub);
	free(pos);
	free(sh);
	free(t);
	return rc;
}

/* Allocate the engine for a scene and choose its mode and grid; no state
 * yet (particles zeroed, cells empty). */
static struct ed *ed_alloc(const scene_t *s, int *err, char *msg, size_t msglen)
{
	struct ed *ed = NULL;
	int rc = ED_ENOMEM;

	if (msg && msglen)
		msg[0] = '\0';
	ed = calloc(1, sizeof(*ed));
	if (!ed)
		goto fail;
	if (geometry(ed, s, msg, msglen) != ED_OK) {
		rc = ED_EINVAL;
		goto fail;
	}

	size_t psz = ed->dim == 2 ? sizeof(p2_t) : sizeof(p3_t), b[A_COUNT];
	array_bytes(ed, ed->nl, s->tc > 0.0, b);
	ed->p = big_alloc(b[A_P], 0);
	ed->ev = big_alloc(b[A_EV], 1);
	ed->heap = big_alloc(b[A_HEAP], 1);
	ed->cn = big_alloc(b[A_CN], 1);
	ed->cal_head = big_alloc(b[A_CALHEAD], 0);
	ed->head = big_alloc(b[A_HEAD], 0);
	ed->occ = big_alloc(b[A_OCC], 0);
	ed->next = big_alloc(b[A_NEXT], 0);
	ed->id = big_alloc(b[A_ID], 0);
	ed->scratch_idx = malloc(b[A_SCRATCH_IDX]);
	ed->scratch_cell = malloc(b[A_SCRATCH_CELL]);
	if (ed->nl) {
		ed->xn = big_alloc(b[A_XN], 0);
		ed->nb = big_alloc(b[A_NB], 0);
		ed->nn = big_alloc(b[A_NN], 1);
		ed->mark = big_alloc(b[A_MARK], 1);
		if (!ed->xn || !ed->nb || !ed->nn || !ed->mark)
			goto fail;
	}
	if (s->tc > 0.0) {
		ed->tlast = big_alloc(b[A_TLAST], 0);
	}
	if (ed->nobst) {
		if (!(ed->ocell = big_alloc(b[A_OCELL], 0)))
			goto fail;
		build_ocell(ed);
	}
	if (ed->open && !(ed->gone = big_alloc(b[A_GONE], 1)))
		goto fail;
	if (ed->inlet && (!(ed->freei = big_alloc(b[A_FREE], 0)) || !(ed->label = big_alloc(b[A_LABEL], 0))))
		goto fail;
	if (ed->inlet)
		rng_init(&ed->irng, s->seed, s->stream | (1ull << 60));
	if (ed->nfilt && !(ed->frozen = big_alloc(b[A_FROZEN], 1)))
		goto fail;
	if (ed->mixture) {
		if (!(ed->spc = big_alloc(b[A_SPC], 0)) || !(ed->prad = big_alloc(b[A_PRAD], 0)) ||
		    !(ed->mix = big_alloc(b[A_MIX], 1)) || !(ed->mix->rscene = big_alloc(b[A_RSCENE], 0)) ||
		    !(ed->mix->rsp = big_alloc(b[A_SPC], 0)))
			goto fail;
		setup_species(ed, s);
		scene_row_species(s, ed->mix->rsp, ed->mix->rscene);   /* the slots' too (dispensers) */
		setup_stream_species(ed, s);
	}
	if (ed->disp) {
		if (!(ed->tpl = big_alloc(b[A_TPL], 0)) || (ed->mixture && !(ed->mix->tsp = big_alloc(b[A_TPL] / (sizeof(double) * (size_t)ed->dim), 0))))
			goto fail;
		for (int w = 0; w < 6; w++)
			if ((ed->disp >> w & 1) &&
			    (rc = ed->mixture ? build_templates_mix(ed, s, w, msg, msglen) : build_templates(ed, s, w, msg, msglen)) != ED_OK)
				goto fail;
		rc = ED_ENOMEM;
	}
	if (ed->rough && !(ed->spin = big_alloc(b[A_SPIN], 1)))
		goto fail;
	if (ed->img_on && !(ed->img = big_alloc(b[A_IMG], 1)))
		goto fail;
	if (ed->drive && (!(ed->drv_mean = big_alloc(b[A_DMEAN], 1)) || !(ed->drv_sum = big_alloc(b[A_DSUM], 1))))
		goto fail;
	if (b[A_DPOS] && (!(ed->drv_pos = big_alloc(b[A_DPOS], 0)) || !(ed->drv_vel = big_alloc(b[A_DVEL], 0))))
		goto fail;
	if (ed->drive)
		rng_init(&ed->drng, s->seed, s->stream | (1ull << 61));
	if (!ed->p || !ed->ev || !ed->heap || !ed->cn || !ed->cal_head || !ed->head || !ed->occ || !ed->next || !ed->id || !ed->scratch_idx || !ed->scratch_cell ||
	    (s->tc > 0.0 && !ed->tlast))
		goto fail;
	for (uint32_t i = 0; i < ed->n; i++)
		ed->id[i] = i;
	if (ed->spc)
		species_from_id(ed);
	memset(ed->p, 0, ed->n * psz);
	cells_clear(ed);
	/* Rebase often enough to keep times small, rarely enough to cost nothing. */
	ed->rebase_every = 8ull * ed->n < 4096 ? 4096 : 8ull * ed->n;
	*err = ED_OK;
	return ed;
fail:
	ed_destroy(ed);
	*err = rc;
	if (rc == ED_ENOMEM)
		set_msg(msg, msglen, "out of memory for %.0f particles%.0s", (double)s->count, 0);
	return NULL;
}

static void drive_start(struct ed *ed);
static void inlet_slots(struct ed *ed);
static void inlet_start(struct ed *ed);
static void stream_start(struct ed *ed);

ed_t *ed_create(const scene_t *s, int *err, char *msg, size_t msglen)
{
	int rc;
	rng_t rng;
	struct ed *ed = ed_alloc(s, err, msg, msglen);
	if (!ed)
		return NULL;

	rng_init(&rng, s->seed, s->stream);
	const uint32_t slots = ed->n;
	ed->n = ed->n_init;   /* reservoir scenes: place and draw the initial particles only */
	if (s->init_pos) {
		given_state(ed, s->init_pos, s->init_vel);   /* a region (place.h) or an earlier run's frame */
	} else if ((rc = placement_check(ed, s, msg, msglen)) != ED_OK) {
		goto fail;
	} else if (s->positions == SCENE_POS_RANDOM) {
		rc = DISPATCH(ed, place_random, ed, &rng);
		if (rc != ED_OK) {
			set_msg(msg, msglen, "particles.initial.positions: random placement failed at volume fraction %.4g "
			        "(random sequential addition jams near %.3g); use \"lattice\"",
			        s->volume_fraction, ed->dim == 2 ? 0.547 : 0.38);
			goto fail;
		}
	} else {
		rc = place_lattice(ed, &rng, msg, msglen);
		if (rc != ED_OK)
			goto fail;
	}
	if (!s->init_vel && ed->mixture) {
		init_velocities_species(ed, s->temperature, &rng);
		add_flow(ed, s);
	} else if (!s->init_vel) {
		init_velocities(ed, s->temperature, &rng);
		add_flow(ed, s);
	}
	if (ed->rough && s->init_spin)
		memcpy(ed->spin, s->init_spin, (size_t)ed->n * (ed->dim == 2 ? 1 : 3) * sizeof(double));
	else if (ed->rough)
		init_spins(ed, s->rot_temperature, &rng);
	ed->n = slots;
	if (ed->inlet)
		inlet_slots(ed);
	predict_all(ed);
	reset_clock(ed);

	if (s->relax_cpp > 0.0) {
		/* Elastic pre-run to an equilibrium fluid structure (seed 003, ch. 4);
		 * elastic, so the temperature is unchanged. */
		double e = ed->e, omega[6];
		double *tl = ed->tlast;
		ed->e = 1.0;
		ed->tlast = NULL;
		/* walls: specular, elastic and standing still where they are at time 0 */
		ed->relaxing = 1;
		for (int w = 0; w < 6; w++) {
			omega[w] = ed->wall[w].omega;
			ed->wall[w].omega = 0.0;
		}
		uint64_t target = (uint64_t)ceil(s->relax_cpp * (double)(ed->n - ed->n_gone) / 2.0);   /* particles present (reservoir scenes: not the empty slots) */
		DISPATCH(ed, run, ed, INFINITY, target, UINT64_MAX);
		ed->e = e;
		ed->tlast = tl;
		ed->relaxing = 0;
		for (int w = 0; w < 6; w++)
			ed->wall[w].omega = omega[w];
		reset_clock(ed);
	}
	if (ed->drive)
		drive_start(ed);
	if (ed->inlet)
		inlet_start(ed);
	if (ed->nfilt || ed->disp)
		stream_start(ed);
	*err = ED_OK;
	return ed;
fail:
	ed_destroy(ed);
	*err = rc;
	return NULL;
}

void ed_destroy(ed_t *ed)
{
	if (!ed)
		return;
	free(ed->p);
	free(ed->ev);
	free(ed->heap);
	free(ed->cn);
	free(ed->cal_head);
	free(ed->head);
	free(ed->occ);
	free(ed->next);
	free(ed->tlast);
	free(ed->spin);
	free(ed->spc);
	free(ed->prad);
	if (ed->mix) {
		free(ed->mix->rsp);
		free(ed->mix->tsp);
	}
	if (ed->mix)
		free(ed->mix->rscene);
	free(ed->mix);
	free(ed->drv_mean);
	free(ed->drv_sum);
	free(ed->drv_pos);
	free(ed->drv_vel);
	free(ed->id);
	free(ed->scratch_idx);
	free(ed->scratch_cell);
	free(ed->xn);
	free(ed->nb);
	free(ed->nn);
	free(ed->mark);
	free(ed->ocell);
	free(ed->gone);
	free(ed->freei);
	free(ed->label);
	free(ed->frozen);
	free(ed->tpl);
	free(ed->img);
	free(ed);
}

/* ---- driving (thermostats) ----------------------------------------------
 *
 * Kicks are not events of the calendar: the event loop (run) stops at the
 * time of the next kick like at any t_stop (which changes nothing), the
 * kick is applied, and the loop goes on. Kicks come at Poisson times of
 * rate N / interval to particles drawn uniformly, from a random stream of
 * their own; the times are absolute and part of the state, so where a
 * caller stops changes nothing. Cost: O(1) per kick plus one prediction;
 * the stochastic thermostat's local mean velocity is an exponential moving
 * average over average_time of the bins' mean velocities, refreshed every
 * average_time / 8 (O(N) each). */

/* Bin of a position (scene coordinates) in the driving grid. */
static size_t drive_bin(const struct ed *ed, const double *r)
{
	size_t b = 0;
	for (int a = ed->dim - 1; a >= 0; a--) {
		long k = (long)floor(r[a] / ed->drv_box[a] * ed->drv_grid[a]);
		if (k < 0) k = 0;
		if (k >= ed->drv_grid[a]) k = ed->drv_grid[a] - 1;
		b = b * (size_t)ed->drv_grid[a] + (size_t)k;
	}
	return b;
}

/* Bins' mean velocities now into the running means: weight w of the new
 * sample (1: replace). Empty bins keep their mean. */
static void drive_average(struct ed *ed, double w)
{
	const int D = ed->dim;
	memset(ed->drv_sum, 0, ed->drv_bins * (D + 1) * sizeof(double));
	if (ed->drv_bins == 1) {
		double mom[3];
		DISPATCH(ed, ekin, ed, mom);
		for (int a = 0; a < D; a++)
			ed->drv_sum[a] = mom[a] / ed->mass;
		ed->drv_sum[D] = ed->n;
	} else {
		DISPATCH(ed, state, ed, ed->drv_pos, ed->drv_vel);
		for (uint32_t i = 0; i < ed->n; i++) {
			double *sum = ed->drv_sum + drive_bin(ed, ed->drv_pos + (size_t)i * D) * (D + 1);
			for (int a = 0; a < D; a++)
				sum[a] += ed->drv_vel[(size_t)i * D + a];
			sum[D] += 1.0;
		}
	}
	for (size_t b = 0; b < ed->drv_bins; b++) {
		const double *sum = ed->drv_sum + b * (D + 1);
		if (sum[D] > 0.0)
			for (int a = 0; a < D; a++)
				ed->drv_mean[b * D + a] += w * (sum[a] / sum[D] - ed->drv_mean[b * D + a]);
	}
}

/* The kick due now: a random particle's velocity replaced (stochastic) or
 * changed by a Gaussian step (white noise); the next kick time drawn. */
static void drive_kick(struct ed *ed)
{
	const int D = ed->dim;
	uint32_t i = (uint32_t)(rng_uniform(&ed->drng) * ed->n);
	if (i >= ed->n)
		i = ed->n - 1;
	double r[3], v[3];
	DISPATCH(ed, kick_get, ed, i, r, v);
	if (ed->drive == SCENE_DRIVE_STOCHASTIC) {
		/* the particle's own mass (mixtures: its species'), so every species is driven towards T_th */
		const double m = ed->mixture ? ed->mix->m[ed->spc[i]] : ed->mass;
		const double *u = ed->drv_mean + drive_bin(ed, r) * D, s = sqrt(ed->drv_temp / m);
		for (int a = 0; a < D; a++)
			v[a] = u[a] + s * rng_gauss(&ed->drng);
	} else {
		const double s = sqrt(ed->drv_xi2 * ed->drv_interval);
		for (int a = 0; a < D; a++)
			v[a] += s * rng_gauss(&ed->drng);
	}
	DISPATCH(ed, kick_set, ed, i, v);
	/* its events afresh, as after a collision */
	if (ed->nl) {
		DISPATCH(ed, set_nl, ed, i);
		DISPATCH(ed, scan_nl, ed, i);
	} else {
		DISPATCH(ed, set_cross, ed, i);
		DISPATCH(ed, scan_full, ed, i);
	}
	cal_update(ed, i, ev_time(ed, i));
	ed->drv_kicks[0]++;
	ed->drv_next[0] -= ed->drv_interval / ed->n * log(1.0 - rng_uniform(&ed->drng));
}

/* At the start of the production run: the first kick time, the means. */
static void drive_start(struct ed *ed)
{
	ed->drv_kicks[0] = 0;
	ed->drv_next[0] = -ed->drv_interval / ed->n * log(1.0 - rng_uniform(&ed->drng));
	ed->drv_next[1] = ed->drive == SCENE_DRIVE_STOCHASTIC ? 0.125 * ed->drv_tavg : INFINITY;
	if (ed->drive == SCENE_DRIVE_STOCHASTIC)
		drive_average(ed, 1.0);
}

static int drive_advance(struct ed *ed, double t_stop, uint64_t max_coll, uint64_t max_events)
{
	const uint64_t ev_end = ed->events + max_events < ed->events ? UINT64_MAX : ed->events + max_events;
	for (;;) {
		const int mean_next = ed->drv_next[1] < ed->drv_next[0];
		const double tk = mean_next ? ed->drv_next[1] : ed->drv_next[0];
		const double stop = tk < t_stop ? tk : t_stop;
		int rc = DISPATCH(ed, run, ed, stop, max_coll, ev_end - ed->events);
		if (rc == ED_COLLAPSE || ed->collisions >= max_coll || ed->events >= ev_end)
			return rc == ED_QUIESCENT ? ED_OK : rc;
		if (!(tk < t_stop))
			return rc;
		/* the clock stands at tk */
		if (mean_next) {
			drive_average(ed, 0.125);
			ed->drv_next[1] += 0.125 * ed->drv_tavg;
		} else {
			drive_kick(ed);
		}
	}
}

/* ---- reservoir walls (inlet) -------------------------------------------
 *
 * Like the driving's kicks, entries are not events of the calendar: the
 * event loop (run) stops at the time of the next entry (which changes
 * nothing), the entry is made, and the loop goes on. Each reservoir wall
 * has its own timer (absolute times of a Poisson process of rate
 * in_rate[w], drawn from the scene's seed on a stream of its own, as are
 * the entries' positions and velocities); the timers are state. An entry
 * takes the top of the free-slot stack; one that would overlap a particle,
 * an obstacle or a side wall is rejected and counted (docs/engine.md,
 * "Reservoir walls"). Cost: O(1) per entry plus one prediction. */

/* Slots beyond the initial particles: empty, on the free stack (slot
 * n_init on top), their rows unlabelled; rows of the initial particles
 * get ids 0 .. n_init - 1. At creation, before the first prediction. */
static void inlet_slots(struct ed *ed)
{
	const size_t psz = ed->dim == 2 ? sizeof(p2_t) : sizeof(p3_t);
	ed->n_gone = 0;
	if (ed->mix)
		memset(ed->mix->fs_n, 0, sizeof ed->mix->fs_n);
	for (uint32_t i = ed->n; i-- > ed->n_init;) {
		memset((char *)ed->p + i * psz, 0, psz);
		ed->gone[i] = 1;
		if (ed->mix) {   /* mixtures (dispensers): the stack of the row's species */
			const int k = ed->mix->rsp[i];
			ed->freei[ed->mix->fs_off[k] + ed->mix->fs_n[k]++] = i;
			ed->n_gone++;
		} else {
			ed->freei[ed->n_gone++] = i;
		}
		ed->ev[i].t_coll = ed->ev[i].t_cross = INFINITY;
		ed->ev[i].partner = -1;
		ed->ev[i].cross = -1;
	}
	for (uint32_t r = 0; r < ed->n; r++)
		ed->label[r] = r < ed->n_init ? (int64_t)r : -1;
	ed->in_count[12] = ed->n_init;
}

/* Waiting time of wall w's next entry. */
static double inlet_wait(struct ed *ed, int w)
{
	return -log(1.0 - rng_uniform(&ed->irng)) / ed->in_rate[w];
}

/* At the start of the production run: the first entry times. */
static void inlet_start(struct ed *ed)
{
	for (int w = 0; w < 6; w++)
		ed->in_next[w] = ed->in_rate[w] > 0.0 ? inlet_wait(ed, w) : INFINITY;
	for (int w = 0; w < 6; w++)   /* the first recharge: when the piston has cleared one layer (never at speed 0) */
		if (ed->disp >> w & 1) {
			const wall_t *W = &ed->wall[w];
			ed->in_next[w] = W->pspeed > 0.0 ? W->lh / W->pspeed : INFINITY;
		}
}

/* Normal speed w >= 0 of an entering particle: density proportional to
 * w exp(-(w - a)^2 / (2 s^2)) (seed 001, eq. 3.29), exact rejection
 * sampling. a <= 0: Rayleigh proposal w exp(-w^2 / 2 s^2), accepted with
 * exp(a w / s^2) <= 1. a > 0: proposal ((w - a)_+ + a) exp(-(w - a)^2 /
 * 2 s^2), a mixture of a normal about a cut at 0 (weight a s sqrt(2 pi)
 * Phi(a / s)) and a Rayleigh above a (weight s^2), accepted with
 * w / ((w - a)_+ + a) <= 1. */
static double inlet_normal(rng_t *g, double a, double s)
{
	if (a <= 0.0) {
		for (;;) {
			const double w = s * sqrt(-2.0 * log(1.0 - rng_uniform(g)));
			if (rng_uniform(g) < exp(a * w / (s * s)))
				return w;
		}
	}
	const double w1 = a * s * 2.50662827463100050242 * 0.5 * erfc(-a / (s * 1.41421356237309504880)), w2 = s * s;
	for (;;) {
		double w;
		if (rng_uniform(g) * (w1 + w2) < w1) {
			do
				w = a + s * rng_gauss(g);
			while (w < 0.0);
		} else {
			w = a + s * sqrt(-2.0 * log(1.0 - rng_uniform(g)));
		}
		if (w >= a || rng_uniform(g) * a < w)
			return w;
	}
}

/* The entry due now at wall w: a position uniform on the face, one radius
 * inside the wall, the flux-weighted normal velocity and Maxwellian
 * tangential ones about the reservoir's; made or rejected; the next entry
 * time drawn. ED_FULL (nothing changed) when no slot is free. */
static int inlet_enter_mix(struct ed *ed, int w);

/* An entry through reservoir wall w made (particle i placed, clear of the others): its label and counts;
 * rough particles: the reservoir gas's spins, Maxwellian at its temperature T = m s^2, variance T / I per
 * component (I = q m a^2, a the particle's radius: sw = s / sqrt(q a^2) the spins' spread, each caller's
 * own arithmetic as before), drawn after the entry (times do not depend on spins: the predictions stay
 * valid); then its events. */
static void inlet_admit(struct ed *ed, uint32_t i, int w, double sw)
{
	ed->label[ed->id[i]] = (int64_t)ed->in_count[12]++;
	ed->in_count[w]++;
	if (ed->rough) {
		const int k = ed->dim == 2 ? 1 : 3;
		for (int c = 0; c < k; c++)
			ed->spin[(size_t)i * k + c] = sw * rng_gauss(&ed->irng);
	}
	DISPATCH(ed, set_cross, ed, i);
	DISPATCH(ed, scan_full, ed, i);
	cal_update(ed, i, ev_time(ed, i));
}

/* An entering particle's centre r and velocity v at wall w (thermal speed s, radius rad): uniform over the
 * wall's face along the side axes (the scene's box there, internal: + org), a radius inside the wall along
 * its axis, Maxwellian along the face about the stream velocity and flux-weighted along the normal. A walled
 * side axis takes only centres a radius clear of its walls (plo/phi, the one-species radius; a mixture's
 * particle, mixed, its own radius rad): 1 (a clash) for one that is not, else 0. */
static int inlet_draw(struct ed *ed, int w, double s, double rad, int mixed, double r[3], double v[3])
{
	const int a = w >> 1, D = ed->dim;
	const double sg = (w & 1) ? -1.0 : 1.0;
	int clash = 0;
	for (int k = 0; k < D; k++) {
		if (k == a)
			continue;
		const double lo = ed->periodic[k] ? 0.0 : ed->wall[2 * k].rest;
		const double hi = ed->periodic[k] ? ed->L[k] : ed->wall[2 * k + 1].rest;
		r[k] = lo + rng_uniform(&ed->irng) * (hi - lo);
		const double plo = mixed ? ed->plo[k] - ed->radius + rad : ed->plo[k];
		const double phi = mixed ? ed->phi[k] + ed->radius - rad : ed->phi[k];
		if (!ed->periodic[k] && (r[k] < plo || r[k] > phi))
			clash = 1;
		v[k] = ed->in_u[w][k] + s * rng_gauss(&ed->irng);
	}
	r[a] = ed->wall[w].rest + sg * rad;
	v[a] = sg * inlet_normal(&ed->irng, ed->in_a[w], s);
	return clash;
}

static int inlet_enter(struct ed *ed, int w)
{
	if (ed->mix)
		return inlet_enter_mix(ed, w);
	if (ed->n_gone == 0)
		return ED_FULL;
	const double s = ed->in_s[w];
	double r[3] = {0.0, 0.0, 0.0}, v[3] = {0.0, 0.0, 0.0};
	int clash = inlet_draw(ed, w, s, ed->radius, 0, r, v);
	const uint32_t i = ed->freei[ed->n_gone - 1];
	if (!clash)
		clash = ed->ops->enter(ed, i, r, v);
	if (clash) {
		ed->in_count[6 + w]++;
	} else {
		inlet_admit(ed, i, w, s / sqrt(ed->rq * 0.25 * ed->sigma2));
	}
	ed->in_next[w] += inlet_wait(ed, w);
	return ED_OK;
}

/* inlet_enter() for a mixture: first the species (one uniform: species k
 * with probability F_k / sum F, in_cum), then as inlet_enter() at its
 * thermal speed sqrt(T / m_k) and radius a_k (centre a_k inside the wall; a
 * walled side axis: a_k clear of its walls); the particle takes a free slot
 * of its species (its stack). ED_FULL (nothing changed: the stream put
 * back) when that species has no free slot. */
static int inlet_enter_mix(struct ed *ed, int w)
{
	struct ed_mix *x = ed->mix;
	const rng_t g0 = ed->irng;
	const double u = rng_uniform(&ed->irng);
	int sp = 0;
	while (sp < ed->nsp - 1 && !(u < ed->in_cum[w][sp]))
		sp++;
	if (x->fs_n[sp] == 0) {
		ed->irng = g0;
		return ED_FULL;
	}
	const uint32_t i = ed->freei[x->fs_off[sp] + x->fs_n[sp] - 1];
	const double s = ed->in_sk[w][sp], rad = ed->prad[i];
	double r[3] = {0.0, 0.0, 0.0}, v[3] = {0.0, 0.0, 0.0};
	int clash = inlet_draw(ed, w, s, rad, 1, r, v);
	if (!clash)
		clash = ed->ops->enter(ed, i, r, v);
	if (clash) {
		ed->in_count[6 + w]++;
	} else {
		x->fs_n[sp]--;
		inlet_admit(ed, i, w, s / sqrt(ed->rq * rad * rad));
	}
	ed->in_next[w] += inlet_wait(ed, w);
	return ED_OK;
}

/* ---- dispenser (seed 001 inlet) ---------------------------------------
 *
 * The piston (wall_t pu, pt0) moves along the inward normal at the
 * layer's normal speed U; its contacts are wall events with the plane at
 * rest + s U (t - pt0), exact like a fixed wall's (walltime_plane of the
 * relative motion). Its recharge is a timer like a reservoir's entries
 * (in_next[w], every h / U): the piston jumps back to the wall's rest
 * position, one template layer is placed in the room it cleared (centres
 * r ... h - r from the piston: the particles ahead are at least r beyond
 * the piston's plane, h from the rest position, so no pair overlaps), with
 * velocities U + sqrt(T / m) N(0, 1) per component, and every particle
 * within the piston's reach gets its boundary events predicted afresh
 * (the plane moved). A layer particle that would still overlap something
 * (an obstacle reaching into the layer, or a pair closer than (1 - 1e-9)
 * sigma) is not placed and counted as rejected. */

/* The start of a recharge at dispenser wall w (dispense() and
 * dispense_mix(): the same draws in the same order): the piston jumps back
 * and every particle in its reach (the wall's zone) gets its events anew;
 * then which template (returned), shifted along each periodic transverse
 * axis and mirrored or not along each (not across a field), and the one of
 * its n particles left out (*skip, UINT32_MAX for none) so that the
 * layer's mean count is eta h W / v_p. */
static int layer_begin(struct ed *ed, int w, uint32_t n, double shift[3], double lo[3], double wid[3], int mirror[3],
                       uint32_t *skip)
{
	const int a = w >> 1, D = ed->dim;
	ed->wall[w].pt0 = ed->t;
	for (uint32_t i = 0; i < ed->n; i++) {
		if (ed->gone[i])
			continue;
		const int32_t c = ed->ev[i].cc[a];
		if ((w & 1) ? c >= ed->nc[a] - ed->nzone[w] : c < ed->nzone[w]) {
			DISPATCH(ed, set_cross, ed, i);
			cal_update(ed, i, ev_time(ed, i));
		}
	}
	int q = (int)(rng_uniform(&ed->irng) * ed->ntpl);
	if (q >= ed->ntpl)
		q = ed->ntpl - 1;
	for (int b = 0; b < 3; b++) {
		shift[b] = lo[b] = wid[b] = 0.0;
		mirror[b] = 0;
	}
	for (int b = 0; b < D; b++) {
		if (b == a)
			continue;
		shift[b] = ed->periodic[b] ? rng_uniform(&ed->irng) * ed->L[b] : 0.0;
		mirror[b] = rng_uniform(&ed->irng) < 0.5 && ed->g[b] == 0.0;
		lo[b] = ed->periodic[b] ? 0.0 : ed->wall[2 * b].rest;
		wid[b] = ed->periodic[b] ? ed->L[b] : ed->wall[2 * b + 1].rest - lo[b];
	}
	*skip = UINT32_MAX;
	if (rng_uniform(&ed->irng) >= ed->tpl_frac[w]) {
		*skip = (uint32_t)(rng_uniform(&ed->irng) * n);
		if (*skip >= n)
			*skip = n - 1;
	}
	return q;
}

/* Dispensers on several axes: whether a layer particle of wall w at r
 * (internal coordinates) would lie less than the largest radius ahead of
 * the piston of another axis' dispenser (behind it, or touching it): it
 * is then not placed (the corner the other piston has swept is that
 * dispenser's to fill). 0 at once without (dclip[w] = 0). */
static int layer_behind(const struct ed *ed, int w, const double *r)
{
	for (int v = 0; ed->dclip[w] >> v; v++) {
		if (!(ed->dclip[w] >> v & 1))
			continue;
		const wall_t *P = &ed->wall[v];
		const double sg = (v & 1) ? -1.0 : 1.0;
		if (sg * (r[v >> 1] - P->rest) - P->pu * (ed->t - P->pt0) < 0.5 * ed->sigma * (1.0 - 1e-9))
			return 1;
	}
	return 0;
}

/* Dispensers with a filter on another axis: the filter wall (1 + its index) beyond whose plane a layer
 * particle of wall w at r lies, else 0. It is placed frozen there (at the filter's velocity, as the
 * particles beyond a plane at the start of the production run): a regular particle beyond the plane would
 * meet the plane at once from the wrong side. */
static int layer_frozen(const struct ed *ed, int w, const double *r)
{
	for (int v = 0; ed->fclip[w] >> v; v++) {
		if (!(ed->fclip[w] >> v & 1))
			continue;
		const double sg = (v & 1) ? -1.0 : 1.0;
		if (sg * (r[v >> 1] - ed->fplane[v]) <= 0.0)
			return 1 + v;
	}
	return 0;
}

/* A layer particle i just placed beyond the plane of filter wall fz - 1 (layer_frozen()): frozen, its
 * velocity v the filter's (set by the caller before the placement), no spin. */
static void layer_freeze(struct ed *ed, uint32_t i, int fz)
{
	const int D = ed->dim;
	ed->frozen[i] = (uint8_t)fz;
	ed->nfrozen[fz - 1]++;
	frozen_count(ed, fz - 1, ed->mixture ? ed->spc[i] : 0, 1);
	if (ed->spin)
		memset(ed->spin + (size_t)i * (D == 2 ? 1 : 3), 0, (D == 2 ? 1 : 3) * sizeof(double));
}

/* Template particle k of a recharge's layer at dispenser wall w (tp: the template layer_begin() chose, with
 * its shift, lo, wid, mirror and the particle it leaves out, skip): its position r (zero beyond D); 1 when
 * it is not placed (skip, or behind another axis' piston: layer_behind()), else 0. */
static int layer_site(const struct ed *ed, int w, const double *tp, uint32_t k, uint32_t skip, const double *shift,
                      const double *lo, const double *wid, const int *mirror, double r[3])
{
	if (k == skip)
		return 1;
	const int a = w >> 1, D = ed->dim;
	const double sg = (w & 1) ? -1.0 : 1.0;
	r[0] = r[1] = r[2] = 0.0;
	r[a] = ed->wall[w].rest + sg * tp[(size_t)D * k + a];
	for (int b = 0; b < D; b++) {
		if (b == a)
			continue;
		double y = tp[(size_t)D * k + b];
		if (mirror[b])
			y = wid[b] - y;
		y += shift[b];
		if (y >= wid[b])
			y -= wid[b];
		r[b] = lo[b] + y;
	}
	return ed->dclip[w] && layer_behind(ed, w, r);
}

/* The recharge due now at dispenser wall w. ED_FULL (nothing changed)
 * when the free slots cannot take a whole layer. */
static int dispense_mix(struct ed *ed, int w);

static int dispense(struct ed *ed, int w)
{
	if (ed->mixture)
		return dispense_mix(ed, w);
	const uint32_t n = ed->tpl_n[w];
	if (ed->n_gone < n)
		return ED_FULL;
	wall_t *W = &ed->wall[w];
	const int D = ed->dim;
	const double sv = ed->disp_s[w];
	double shift[3], lo[3], wid[3];
	int mirror[3];
	uint32_t skip;
	const int q = layer_begin(ed, w, n, shift, lo, wid, mirror, &skip);
	const double *tp = ed->tpl + ed->tpl_off[w] + (size_t)q * n * D;
	for (uint32_t k = 0; k < n; k++) {
		double r[3], v[3] = {0.0, 0.0, 0.0};
		if (layer_site(ed, w, tp, k, skip, shift, lo, wid, mirror, r))
			continue;
		for (int j = 0; j < D; j++)
			v[j] = ed->disp_u[w][j] + sv * rng_gauss(&ed->irng);
		const int fz = ed->fclip[w] ? layer_frozen(ed, w, r) : 0;
		for (int j = 0; fz && j < D; j++)
			v[j] = ed->fu[fz - 1][j];
		const uint32_t i = ed->freei[ed->n_gone - 1];
		if (ed->ops->enter_layer(ed, i, r, v)) {
			ed->in_count[6 + w]++;
			continue;
		}
		ed->label[ed->id[i]] = (int64_t)ed->in_count[12]++;
		ed->in_count[w]++;
		if (ed->rough) {
			/* rough particles: spins Maxwellian at the layers' temperature T = m sv^2, variance
			 * T / I per component (I = q m a^2), as a reservoir's entries (times do not depend
			 * on spins); drawn after the placement, so smooth scenes draw what they drew before */
			const int nk = D == 2 ? 1 : 3;
			const double swv = sv / sqrt(ed->rq * 0.25 * ed->sigma2);
			for (int c = 0; c < nk; c++)
				ed->spin[(size_t)i * nk + c] = swv * rng_gauss(&ed->irng);
		}
		if (fz)
			layer_freeze(ed, i, fz);
		DISPATCH(ed, set_cross, ed, i);
		DISPATCH(ed, scan_full, ed, i);
		cal_update(ed, i, ev_time(ed, i));
	}
	ed->in_next[w] += W->lh / W->pspeed;
	return ED_OK;
}

/* dispense() for a mixture: each template particle takes a free slot of
 * its species (that species' stack); ED_FULL (nothing changed) when some
 * species has fewer free slots than a template may hold of it. Velocities
 * U + sqrt(T / m_k) N(0, 1), spins (rough) variance T / I_k, in the order
 * dispense() draws them. */
static int dispense_mix(struct ed *ed, int w)
{
	const uint32_t n = ed->tpl_n[w];
	struct ed_mix *x = ed->mix;
	for (int k = 0; k < ed->nsp; k++)
		if (x->fs_n[k] < x->tmax[w][k])
			return ED_FULL;
	wall_t *W = &ed->wall[w];
	const int D = ed->dim;
	double shift[3], lo[3], wid[3];
	int mirror[3];
	uint32_t skip;
	const int q = layer_begin(ed, w, n, shift, lo, wid, mirror, &skip);
	const double *tp = ed->tpl + ed->tpl_off[w] + (size_t)q * n * D;
	const uint8_t *ts = x->tsp + ed->tpl_off[w] / (size_t)D + (size_t)q * n;
	for (uint32_t k = 0; k < n; k++) {
		const int sp = ts[k];
		const double sv = x->dsv[w][sp];
		double r[3], v[3] = {0.0, 0.0, 0.0};
		if (layer_site(ed, w, tp, k, skip, shift, lo, wid, mirror, r))
			continue;
		for (int j = 0; j < D; j++)
			v[j] = ed->disp_u[w][j] + sv * rng_gauss(&ed->irng);
		const int fz = ed->fclip[w] ? layer_frozen(ed, w, r) : 0;
		for (int j = 0; fz && j < D; j++)
			v[j] = ed->fu[fz - 1][j];
		uint32_t *top = ed->freei + x->fs_off[sp] + x->fs_n[sp] - 1;
		if (x->poly >> sp & 1) {   /* polydisperse: a free slot of the species at random (its radius) */
			uint32_t j = (uint32_t)(rng_uniform(&ed->irng) * x->fs_n[sp]);
			if (j >= x->fs_n[sp])
				j = x->fs_n[sp] - 1;
			uint32_t *o = ed->freei + x->fs_off[sp] + j, y = *o;
			*o = *top;
			*top = y;
		}
		const uint32_t i = *top;
		if (ed->ops->enter_layer(ed, i, r, v)) {
			ed->in_count[6 + w]++;
			continue;
		}
		x->fs_n[sp]--;
		ed->label[ed->id[i]] = (int64_t)ed->in_count[12]++;
		ed->in_count[w]++;
		if (ed->rough) {   /* T / I_k = sv^2 / (q a_k^2) */
			const int nk = D == 2 ? 1 : 3;
			const double swv = sv / sqrt(ed->rq * ed->prad[i] * ed->prad[i]);
			for (int c = 0; c < nk; c++)
				ed->spin[(size_t)i * nk + c] = swv * rng_gauss(&ed->irng);
		}
		if (fz)
			layer_freeze(ed, i, fz);
		DISPATCH(ed, set_cross, ed, i);
		DISPATCH(ed, scan_full, ed, i);
		cal_update(ed, i, ev_time(ed, i));
	}
	ed->in_next[w] += W->lh / W->pspeed;
	return ED_OK;
}

/* At the start of the production run (after the pre-run, which runs with
 * the piston at rest and no filter): the piston starts moving, filters
 * act; particles already beyond a filter plane are frozen; every event
 * predicted afresh. */
static void stream_start(struct ed *ed)
{
	for (int w = 0; w < 6; w++)   /* at rest at the start (the clock is 0; a pre-run's rebases moved pt0) */
		if (ed->disp >> w & 1) {
			ed->wall[w].pu = ed->wall[w].pspeed;
			ed->wall[w].pt0 = ed->t;
		}
	if (ed->nfilt) {
		ed->filt_on = 1;
		memset(ed->nfrozen, 0, sizeof ed->nfrozen);
		double *pos = NULL;
		const int D = ed->dim;
		const size_t psz = D == 2 ? sizeof(p2_t) : sizeof(p3_t);
		for (uint32_t i = 0; i < ed->n; i++) {
			if (ed->gone[i])
				continue;
			double *r = (double *)((char *)ed->p + i * psz), *v = r + D;   /* r[D], v[D] lead the record */
			for (int w = 0; w < 6; w++) {
				if (!ed->fcell[w])
					continue;
				const int a = w >> 1;
				const double sg = (w & 1) ? -1.0 : 1.0;
				if (sg * (r[a] - ed->fplane[w]) <= 0.0 && !ed->frozen[i]) {
					double de = 0.0;
					for (int j = 0; j < D; j++) {
						de += ed->fu[w][j] * ed->fu[w][j] - v[j] * v[j];
						v[j] = ed->fu[w][j];
					}
					ed->ekin_cur += 0.5 * ed->mass * de;
					ed->frozen[i] = (uint8_t)(1 + w);
					ed->nfrozen[w]++;
					if (ed->spin)   /* rough particles: frozen ones do not spin */
						memset(ed->spin + (size_t)i * (D == 2 ? 1 : 3), 0, (D == 2 ? 1 : 3) * sizeof(double));
				}
			}
		}
		(void)pos;
		frozen_tally(ed);
		double mom[3];
		ed->ekin_cur = DISPATCH(ed, ekin, ed, mom);
		for (int j = 0; j < 3; j++)
			ed->psum[j] = mom[j] / ed->mass;
	}
	predict_all(ed);
}

static int inlet_advance(struct ed *ed, double t_stop, uint64_t max_coll, uint64_t max_events)
{
	const uint64_t ev_end = ed->events + max_events < ed->events ? UINT64_MAX : ed->events + max_events;
	for (;;) {
		int w = 0;
		for (int k = 1; k < 6; k++)
			if (ed->in_next[k] < ed->in_next[w])
				w = k;
		const double tk = ed->in_next[w];
		const double stop = tk < t_stop ? tk : t_stop;
		int rc = DISPATCH(ed, run, ed, stop, max_coll, ev_end - ed->events);
		if (rc == ED_COLLAPSE || ed->collisions >= max_coll || ed->events >= ev_end)
			return rc == ED_QUIESCENT ? ED_OK : rc;
		if (!(tk < t_stop))
			return rc;
		/* the clock stands at tk */
		if ((ed->wall[w].type == SCENE_WALL_DISPENSER ? dispense(ed, w) : inlet_enter(ed, w)) == ED_FULL)
			return ED_FULL;
	}
}

uint32_t ed_slots(const ed_t *ed) { return ed->n; }

int ed_labels(const ed_t *ed, int64_t *ids)
{
	if (!ed->inlet)
		return ED_EINVAL;
	memcpy(ids, ed->label, (size_t)ed->n * sizeof(int64_t));
	return ED_OK;
}

int ed_advance(ed_t *ed, double t_stop, uint64_t max_collisions, uint64_t max_events)
{
	if (ed->drive)
		return drive_advance(ed, t_stop, max_collisions, max_events);
	if (ed->inlet)
		return inlet_advance(ed, t_stop, max_collisions, max_events);
	return DISPATCH(ed, run, ed, t_stop, max_collisions, max_events);
}

/* The wall and gravity fields of a sample (totals and the interval's
 * impulses so far). */
static void sample_walls(const struct ed *ed, ed_sample_t *out)
{
	out->wall_collisions = ed->wall_collisions;
	memcpy(out->wall_hits, ed->whits, sizeof out->wall_hits);
	memcpy(out->wall_impulse, ed->wimp, sizeof out->wall_impulse);
	out->particles = ed->n - ed->n_gone;
	memcpy(out->wall_outflow, ed->wout, sizeof out->wall_outflow);
	memcpy(out->wall_inflow, ed->in_count, sizeof out->wall_inflow);
	memcpy(out->wall_rejected, ed->in_count + 6, sizeof out->wall_rejected);
	out->n_obstacles = ed->nobst;
	out->obstacle_collisions = ed->obst_collisions;
	memcpy(out->obstacle_hits, ed->ohits, sizeof out->obstacle_hits);
	memcpy(out->obstacle_impulse, ed->oimp, sizeof out->obstacle_impulse);
	out->com_height = out->potential_energy = NAN;
	if (ed->variant == 2)
		ed->ops->observe(ed, &out->com_height, &out->potential_energy);
}

void ed_sample(ed_t *ed, ed_sample_t *out)
{
	memset(out, 0, sizeof(*out));
	out->time = ed_time(ed);
	out->interval = ed->t - ed->t_int0;
	out->events = ed->events;
	out->collisions = ed->collisions;
	out->interval_collisions = ed->collisions - ed->coll_int0;
	out->elastic_by_tc = ed->tc_elastic;
	if (ed->ops->energy_to)   /* gravity: E_kin changes between events */
		ed->ops->energy_to(ed, ed->t);
	out->kinetic_energy = DISPATCH(ed, ekin, ed, out->momentum);
	out->rotational_energy = ed->rough ? ed_erot(ed) : NAN;
	species_ekin(ed, out);
	out->ekin_time_integral = ed->ekin_int + ed->ekin_cur * (ed->t - ed->t_mark);
	out->virial = ed->virial;
	sample_walls(ed, out);
	memset(ed->wimp, 0, sizeof ed->wimp);
	memset(ed->oimp, 0, sizeof ed->oimp);
	for (int a = 0; a < 3; a++)
		ed->psum[a] = out->momentum[a] / ed->mass;
	/* New interval; the running energy is refreshed from the velocities so
	 * that rounding in the incremental bookkeeping cannot accumulate. */
	ed->ekin_cur = out->kinetic_energy;
	ed->ekin_int = 0.0;
	ed->virial = 0.0;
	ed->t_mark = ed->t_int0 = ed->t;
	ed->coll_int0 = ed->collisions;
}

void ed_state(const ed_t *ed, double *pos, double *vel)
{
	DISPATCH(ed, state, ed, pos, vel);
}

int ed_unwrapped(const ed_t *ed, double *pos)
{
	if (!ed->img || !pos)
		return ED_EINVAL;
	const int D = ed->dim, walls = ed->variant != 0, grav = ed->variant == 2;
	for (uint32_t i = 0; i < ed->n; i++) {
		const double *r, *v;
		double t;
		if (D == 2) {
			const p2_t *p = &((const p2_t *)ed->p)[i];
			r = p->r, v = p->v, t = p->t;
		} else {
			const p3_t *p = &((const p3_t *)ed->p)[i];
			r = p->r, v = p->v, t = p->t;
		}
		const double dt = ed->t - t;
		double *out = pos + (size_t)ed->id[i] * D;
		if (ed->gone && ed->gone[i]) {   /* left through an open wall, or an empty slot: NaN (as ed_state()) */
			for (int a = 0; a < D; a++)
				out[a] = NAN;
			continue;
		}
		for (int a = 0; a < D; a++) {
			/* the engine's position (never folded between wraps) plus the edges it was wrapped by */
			const int fall = grav && !(ed->frozen && ed->frozen[i]);   /* frozen by a filter: straight */
			double x = r[a] + v[a] * dt + (fall ? 0.5 * ed->g[a] * dt * dt : 0.0);
			if (!walls || ed->periodic[a])
				x += ed->L[a] * (double)ed->img[(size_t)ed->id[i] * D + a];
			else
				x -= ed->org[a];
			out[a] = x;
		}
	}
	return ED_OK;
}

int ed_spin_dim(const ed_t *ed)
{
	return ed->rough ? (ed->dim == 2 ? 1 : 3) : 0;
}

void ed_spins(const ed_t *ed, double *w)
{
	const int k = ed_spin_dim(ed);
	for (uint32_t i = 0; i < ed->n; i++)
		for (int c = 0; c < k; c++)
			w[(size_t)ed->id[i] * k + c] = ed->spin[(size_t)i * k + c];
}

uint64_t ed_collisions(const ed_t *ed) { return ed->collisions; }
uint64_t ed_events(const ed_t *ed) { return ed->events; }
double ed_min_gap(const ed_t *ed) { return DISPATCH(ed, min_gap, ed); }

void ed_cells(const ed_t *ed, int cells[3])
{
	for (int a = 0; a < 3; a++)
		cells[a] = ed->nc[a];
}

/* Bytes of an engine of this geometry (nl: neighbour lists; tc: TC times). */
static size_t held(const struct ed *ed, int nl, int tc)
{
	size_t psz = ed->dim == 2 ? sizeof(p2_t) : sizeof(p3_t);
	/* per particle: record, event, heap entry, calendar record, cell link,
	 * scene index, renumbering scratch; lists and marks; TC times */
	size_t per_nl = nl ? ed->dim * sizeof(double) + ed->nlk * sizeof(int32_t) + 2 : 0;
	return sizeof(*ed) + (ed->cal_m + 1) * sizeof(int32_t) + (2 * ed->ncells + 1) * sizeof(int32_t) +
	       (ed->ncells + 63) / 64 * sizeof(uint64_t) +
	       ed->n * (psz + sizeof(ev_t) + sizeof(hent_t) + sizeof(cnode_t) + 3 * sizeof(uint32_t) + per_nl +
	                (tc ? sizeof(double) : 0) + (ed->open ? 1 : 0) + (ed->rough ? (ed->dim == 2 ? 1 : 3) * sizeof(double) : 0) +
	                (ed->drive && ed->drv_bins > 1 ? 2 * ed->dim * sizeof(double) : 0)) +
	       (ed->nobst ? ed->ncells * sizeof(uint16_t) : 0) + (ed->drive ? ed->drv_bins * (2 * ed->dim + 1) * sizeof(double) : 0) +
	       (ed->mixture ? ed->n * (2 + 2 * sizeof(double)) + sizeof(struct ed_mix) : 0);
}

size_t ed_memory(const ed_t *ed) { return held(ed, ed->xn != NULL, ed->tlast != NULL); }

const char *ed_strerror(int code)
{
	switch (code) {
	case ED_OK: return "ok";
	case ED_ENOMEM: return "out of memory";
	case ED_EPLACE: return "initial positions could not be placed";
	case ED_EINVAL: return "scene not usable by the event-driven method";
	case ED_QUIESCENT: return "no further events";
	case ED_COLLAPSE: return "inelastic collapse";
	default: return "unknown error";
	}
}

/* ---- state export and import (checkpoints) ------------------------------
 *
 * The exported state is everything the dynamics read: particle records
 * (position at the particle's own time, velocity, local time, cell-list link,
 * collision counter), predicted events, cell heads, scene indices, TC times,
 * neighbour lists, clocks, counters and interval accumulators. The event
 * calendar is not exported: its pop order is the (time, particle index)
 * order of the per-particle event times (see the invariant at struct ed), so
 * re-inserting every particle's event into a calendar of the same bucket
 * width and current bucket gives the same sequence of events. */

typedef enum {
	F_R, F_V, F_TLOC, F_NEXT, F_COUNT, F_TCOLL, F_TCROSS, F_PARTNER, F_PCOUNT, F_CROSS, F_CELL,
	F_ID, F_HEAD, F_TLAST, F_XN, F_NN, F_NB,
	F_WPH, F_WIMP, F_WIMPTOT, F_WHITS, F_WCOLL, F_WRNG, F_PSUM,   /* walls and gravity variants only */
	F_OIMP, F_OIMPTOT, F_OHITS, F_OCOLL,                         /* with obstacles only */
	F_GONE, F_WOUT,                                              /* with open walls only */
	F_SPIN,   /* rough particles only */
	F_DMEAN, F_DNEXT, F_DKICKS, F_DRNG,   /* driving only */
	F_FREE, F_LABEL, F_INEXT, F_ICOUNT, F_IRNG,   /* reservoir walls only */
	F_FROZEN, F_NFROZEN,   /* filters only */
	F_PISTON,              /* dispensers only */
	F_IMG,                 /* periodic image counts (scene_msd_images()) only */
	F_SCALAR
} fid_t;

static const struct {
	const char *name;
	ed_type_t type;
	size_t off;
} scalars[] = {
	{ "clock", ED_T_F64, offsetof(struct ed, t) },
	{ "epoch", ED_T_F64, offsetof(struct ed, epoch) },
	{ "epoch_c", ED_T_F64, offsetof(struct ed, epoch_c) },
	{ "ekin_cur", ED_T_F64, offsetof(struct ed, ekin_cur) },
	{ "ekin_int", ED_T_F64, offsetof(struct ed, ekin_int) },
	{ "t_mark", ED_T_F64, offsetof(struct ed, t_mark) },
	{ "t_int0", ED_T_F64, offsetof(struct ed, t_int0) },
	{ "virial", ED_T_F64, offsetof(struct ed, virial) },
	{ "cal_w", ED_T_F64, offsetof(struct ed, cal_w) },
	{ "events", ED_T_U64, offsetof(struct ed, events) },
	{ "collisions", ED_T_U64, offsetof(struct ed, collisions) },
	{ "tc_elastic", ED_T_U64, offsetof(struct ed, tc_elastic) },
	{ "since_rebase", ED_T_U64, offsetof(struct ed, since_rebase) },
	{ "coll_int0", ED_T_U64, offsetof(struct ed, coll_int0) },
	{ "cal_cur", ED_T_I64, offsetof(struct ed, cal_cur) },
	{ "nl", ED_T_I32, offsetof(struct ed, nl) },
	{ "t_abs", ED_T_F64, offsetof(struct ed, t_abs) },
	{ "t_abs_valid", ED_T_I32, offsetof(struct ed, t_abs_valid) },
};
#define N_SCALARS (sizeof scalars / sizeof scalars[0])

static const struct {
	const char *name;
	fid_t id;
	ed_type_t type;
} arrays[] = {
	{ "r", F_R, ED_T_F64 }, { "v", F_V, ED_T_F64 }, { "t_local", F_TLOC, ED_T_F64 },
	{ "next", F_NEXT, ED_T_I32 }, { "count", F_COUNT, ED_T_U32 },
	{ "t_coll", F_TCOLL, ED_T_F64 }, { "t_cross", F_TCROSS, ED_T_F64 },
	{ "partner", F_PARTNER, ED_T_I32 }, { "pcount", F_PCOUNT, ED_T_U32 },
	{ "cross", F_CROSS, ED_T_I32 }, { "cell", F_CELL, ED_T_I32 },
	{ "id", F_ID, ED_T_U32 }, { "head", F_HEAD, ED_T_I32 }, { "tlast", F_TLAST, ED_T_F64 },
	{ "xn", F_XN, ED_T_F64 }, { "nn", F_NN, ED_T_U8 }, { "nb", F_NB, ED_T_I32 },
	{ "wall_phase", F_WPH, ED_T_F64 }, { "wall_impulse", F_WIMP, ED_T_F64 },
	{ "wall_impulse_total", F_WIMPTOT, ED_T_F64 }, { "wall_hits", F_WHITS, ED_T_U64 },
	{ "wall_collisions", F_WCOLL, ED_T_U64 }, { "wall_rng", F_WRNG, ED_T_U64 },
	{ "velocity_sum", F_PSUM, ED_T_F64 },
	{ "obstacle_impulse", F_OIMP, ED_T_F64 }, { "obstacle_impulse_total", F_OIMPTOT, ED_T_F64 },
	{ "obstacle_hits", F_OHITS, ED_T_U64 }, { "obstacle_collisions", F_OCOLL, ED_T_U64 },
	{ "gone", F_GONE, ED_T_U8 }, { "wall_outflow", F_WOUT, ED_T_U64 },
	{ "spin", F_SPIN, ED_T_F64 },
	{ "drive_mean", F_DMEAN, ED_T_F64 }, { "drive_next", F_DNEXT, ED_T_F64 }, { "drive_kicks", F_DKICKS, ED_T_U64 },
	{ "drive_rng", F_DRNG, ED_T_U64 },
	{ "free_slots", F_FREE, ED_T_U32 }, { "label", F_LABEL, ED_T_I64 }, { "inlet_next", F_INEXT, ED_T_F64 },
	{ "inlet_counts", F_ICOUNT, ED_T_U64 }, { "inlet_rng", F_IRNG, ED_T_U64 },
	{ "frozen", F_FROZEN, ED_T_U8 }, { "frozen_counts", F_NFROZEN, ED_T_U64 }, { "piston_t0", F_PISTON, ED_T_F64 },
	{ "images", F_IMG, ED_T_I32 },
};
#define N_ARRAYS (sizeof arrays / sizeof arrays[0])

size_t ed_type_size(ed_type_t t)
{
	switch (t) {
	case ED_T_F64: case ED_T_U64: case ED_T_I64: return 8;
	case ED_T_I32: case ED_T_U32: return 4;
	case ED_T_U8: return 1;
	}
	return 0;
}

/* Whether a field exists, for an engine with neighbour lists (nl) and TC times (tc); stream: 1 filters,
 * 2 dispensers, 4 periodic image counts. */
static int field_exists(fid_t id, int nl, int tc, int variant, int nobst, int open, int rough, int drive, int inlet,
                        int stream)
{
	if (id == F_FROZEN || id == F_NFROZEN)   /* scenes without filters or dispensers keep their layout */
		return stream & 1;
	if (id == F_PISTON)
		return (stream & 2) != 0;
	if (id == F_IMG)   /* scenes without image counts keep their checkpoint layout */
		return (stream & 4) != 0;
	if (id >= F_FREE && id <= F_IRNG)   /* scenes without reservoir walls keep their checkpoint layout */
		return inlet;
	if (id == F_GONE || id == F_WOUT)   /* scenes without open walls keep their checkpoint layout */
		return open;
	if (id >= F_OIMP && id <= F_OCOLL)   /* scenes without obstacles keep their checkpoint layout */
		return nobst > 0;
	if (id == F_SPIN)
		return rough;
	if (id >= F_DMEAN && id <= F_DRNG)
		return drive;
	if (id == F_TLAST)
		return tc;
	if (id == F_XN || id == F_NN || id == F_NB)
		return nl;
	if (id >= F_WPH && id <= F_PSUM)   /* periodic scenes keep their checkpoint layout */
		return variant != 0;
	return 1;
}

static int array_present(const struct ed *ed, fid_t id)
{
	return field_exists(id, ed->xn != NULL, ed->tlast != NULL, ed->variant, ed->nobst, ed->open, ed->rough, ed->drive, ed->inlet,
	                    (ed->nfilt ? 1 : 0) | (ed->disp ? 2 : 0) | (ed->img_on ? 4 : 0));
}

static size_t array_count(const struct ed *ed, fid_t id)
{
	switch (id) {
	case F_R: case F_V: case F_XN: case F_IMG: return (size_t)ed->n * ed->dim;
	case F_CELL: return (size_t)ed->n * 3;
	case F_HEAD: return ed->ncells;
	case F_WPH: case F_WHITS: return 6;
	case F_WIMP: case F_WIMPTOT: return 18;
	case F_WCOLL: return 1;
	case F_WRNG: return 4;
	case F_PSUM: return 3;
	case F_OIMP: case F_OIMPTOT: return (size_t)ed->nobst * 3;
	case F_OHITS: return (size_t)ed->nobst;
	case F_OCOLL: return 1;
	case F_WOUT: return 6;
	case F_SPIN: return (size_t)ed->n * (ed->dim == 2 ? 1 : 3);
	case F_DMEAN: return ed->drv_bins * ed->dim;
	case F_DNEXT: return 2;
	case F_DKICKS: return 1;
	case F_DRNG: return 4;
	case F_INEXT: return 6;
	case F_ICOUNT: return 13;
	case F_IRNG: return 4;
	case F_NFROZEN: case F_PISTON: return 6;
	case F_NB: {
		size_t k = 0;
		for (uint32_t i = 0; i < ed->n; i++)
			k += ed->nn[i];
		return k;
	}
	default: return ed->n;
	}
}

int ed_plan(const scene_t *s, ed_plan_t *out, char *msg, size_t msglen)
{
	struct ed ed;
	memset(&ed, 0, sizeof(ed));
	if (msg && msglen)
		msg[0] = '\0';
	int rc = geometry(&ed, s, msg, msglen);
	const uint32_t slots = ed.n;
	ed.n = ed.n_init;   /* reservoir scenes: the initial particles are placed */
	if (rc == ED_OK && !s->has_region && !s->has_from)   /* those: place_check(), frame checks */
		rc = placement_check(&ed, s, msg, msglen);
	ed.n = slots;
	if (rc != ED_OK || !out)
		return rc;
	/* What ed_alloc() takes: its arrays with big_alloc()'s rounding (of
	 * the zeroed arrays every page is touched; rounding is counted for all,
	 * an upper bound of at most 2 MiB per array) and the engine struct. */
	size_t b[A_COUNT];
	array_bytes(&ed, ed.nl, s->tc > 0.0, b);
	out->memory = sizeof(struct ed);
	for (int a = 0; a < A_COUNT; a++)
		out->memory += a == A_SCRATCH_IDX || a == A_SCRATCH_CELL ? b[a] : b[a] ? big_size(b[a]) : 0;
	out->cells = ed.ncells;
	out->neighbour_lists = ed.nl;
	/* State fields as ed_fields() lists them. The neighbour lists ("nb")
	 * hold each particle's neighbours within the list radius: their mean
	 * count is the number density times that ball's volume. */
	double vol = ed.L[0] * ed.L[1] * (ed.dim == 3 ? ed.L[2] : 1.0), rl = sqrt(ed.nl_r2);
	double ball = ed.dim == 2 ? 3.14159265358979323846 * rl * rl : 4.0 / 3.0 * 3.14159265358979323846 * rl * rl * rl;
	double per = fmin((double)ed.n / vol * ball, (double)ed.nlk);
	out->state = 0;
	for (size_t a = 0; a < N_SCALARS; a++)
		out->state += ed_type_size(scalars[a].type);
	out->largest = 0;
	for (size_t a = 0; a < N_ARRAYS; a++) {
		if (!field_exists(arrays[a].id, ed.nl, s->tc > 0.0, ed.variant, ed.nobst, ed.open, ed.rough, ed.drive, ed.inlet,
		                  (ed.nfilt ? 1 : 0) | (ed.disp ? 2 : 0) | (ed.img_on ? 4 : 0)))
			continue;
		double count = arrays[a].id == F_NB ? per * ed.n : (double)array_count(&ed, arrays[a].id);
		uint64_t bytes = (uint64_t)(count * (double)ed_type_size(arrays[a].type));
		out->state += bytes;
		if (bytes > out->largest)
			out->largest = bytes;
	}
	return ED_OK;
}

int ed_fields(const ed_t *ed, ed_field_t *out, int max)
{
	int k = 0;
	for (size_t a = 0; a < N_ARRAYS; a++) {
		if (!array_present(ed, arrays[a].id))
			continue;
		if (k < max)
			out[k] = (ed_field_t){ arrays[a].name, arrays[a].type, array_count(ed, arrays[a].id) };
		k++;
	}
	for (size_t a = 0; a < N_SCALARS; a++) {
		if (k < max)
			out[k] = (ed_field_t){ scalars[a].name, scalars[a].type, 1 };
		k++;
	}
	return k;
}

/* Copy one field between the engine and buf; to_buf selects the direction. */
static void field_copy(struct ed *ed, fid_t id, void *buf, int to_buf)
{
	const size_t stride = ed->dim == 2 ? sizeof(p2_t) : sizeof(p3_t);
	const int D = ed->dim;
	char *P = ed->p, *b = buf;
	size_t off = 0, width = 0;

	switch (id) {
	case F_R: off = D == 2 ? offsetof(p2_t, r) : offsetof(p3_t, r); width = D * sizeof(double); break;
	case F_V: off = D == 2 ? offsetof(p2_t, v) : offsetof(p3_t, v); width = D * sizeof(double); break;
	case F_TLOC: off = D == 2 ? offsetof(p2_t, t) : offsetof(p3_t, t); width = sizeof(double); break;
	case F_COUNT: off = D == 2 ? offsetof(p2_t, count) : offsetof(p3_t, count); width = 4; break;
	default: break;
	}
	if (width) {   /* a member of the particle records */
		for (uint32_t i = 0; i < ed->n; i++) {
			if (to_buf) memcpy(b + i * width, P + i * stride + off, width);
			else memcpy(P + i * stride + off, b + i * width, width);
		}
		return;
	}
	switch (id) {
	case F_TCOLL: off = offsetof(ev_t, t_coll); width = 8; break;
	case F_TCROSS: off = offsetof(ev_t, t_cross); width = 8; break;
	case F_PARTNER: off = offsetof(ev_t, partner); width = 4; break;
	case F_PCOUNT: off = offsetof(ev_t, pcount); width = 4; break;
	case F_CROSS: off = offsetof(ev_t, cross); width = 4; break;
	case F_CELL: off = offsetof(ev_t, cc); width = 12; break;
	default: break;
	}
	if (width) {   /* a member of the event records */
		char *E = (char *)ed->ev;
		for (uint32_t i = 0; i < ed->n; i++) {
			if (to_buf) memcpy(b + i * width, E + i * sizeof(ev_t) + off, width);
			else memcpy(E + i * sizeof(ev_t) + off, b + i * width, width);
		}
		return;
	}
	void *src = NULL;
	size_t bytes = 0;
	switch (id) {
	case F_ID: src = ed->id; bytes = ed->n * sizeof(uint32_t); break;
	case F_NEXT: {
		/* from the links in use; restored into both places, since the
		 * mode ("nl") is set after the arrays */
		int32_t *nx = (int32_t *)b;
		for (uint32_t i = 0; i < ed->n; i++) {
			int32_t *pl = (int32_t *)(P + i * stride + (D == 2 ? offsetof(p2_t, next) : offsetof(p3_t, next)));
			if (to_buf)
				nx[i] = ed->nl ? ed->next[i] : *pl;
			else
				ed->next[i] = *pl = nx[i];
		}
		return;
	}
	case F_HEAD: src = ed->head; bytes = ed->ncells * sizeof(int32_t); break;
	case F_TLAST: src = ed->tlast; bytes = ed->n * sizeof(double); break;
	case F_XN: src = ed->xn; bytes = (size_t)ed->n * D * sizeof(double); break;
	case F_NN: src = ed->nn; bytes = ed->n; break;
	case F_WPH: {
		double *ph = (double *)b;
		for (int w = 0; w < 6; w++) {
			if (to_buf) ph[w] = ed->wall[w].ph;
			else ed->wall[w].ph = ph[w];
		}
		return;
	}
	case F_WIMP: src = ed->wimp; bytes = sizeof ed->wimp; break;
	case F_WIMPTOT: src = ed->wimp_tot; bytes = sizeof ed->wimp_tot; break;
	case F_WHITS: src = ed->whits; bytes = sizeof ed->whits; break;
	case F_WCOLL: src = &ed->wall_collisions; bytes = sizeof ed->wall_collisions; break;
	case F_WRNG: src = ed->wrng.s; bytes = sizeof ed->wrng.s; break;
	case F_PSUM: src = ed->psum; bytes = sizeof ed->psum; break;
	case F_OIMP: src = ed->oimp; bytes = (size_t)ed->nobst * sizeof ed->oimp[0]; break;
	case F_OIMPTOT: src = ed->oimp_tot; bytes = (size_t)ed->nobst * sizeof ed->oimp_tot[0]; break;
	case F_OHITS: src = ed->ohits; bytes = (size_t)ed->nobst * sizeof ed->ohits[0]; break;
	case F_OCOLL: src = &ed->obst_collisions; bytes = sizeof ed->obst_collisions; break;
	case F_GONE: src = ed->gone; bytes = ed->n; break;
	case F_WOUT: src = ed->wout; bytes = sizeof ed->wout; break;
	case F_SPIN: src = ed->spin; bytes = (size_t)ed->n * (D == 2 ? 1 : 3) * sizeof(double); break;
	case F_DMEAN: src = ed->drv_mean; bytes = ed->drv_bins * D * sizeof(double); break;
	case F_DNEXT: src = ed->drv_next; bytes = sizeof ed->drv_next; break;
	case F_DKICKS: src = ed->drv_kicks; bytes = sizeof ed->drv_kicks; break;
	case F_DRNG: src = ed->drng.s; bytes = sizeof ed->drng.s; break;
	case F_FREE: src = ed->freei; bytes = ed->n * sizeof(uint32_t); break;
	case F_LABEL: src = ed->label; bytes = ed->n * sizeof(int64_t); break;
	case F_INEXT: src = ed->in_next; bytes = sizeof ed->in_next; break;
	case F_ICOUNT: src = ed->in_count; bytes = sizeof ed->in_count; break;
	case F_IRNG: src = ed->irng.s; bytes = sizeof ed->irng.s; break;
	case F_FROZEN: src = ed->frozen; bytes = ed->n; break;
	case F_IMG: src = ed->img; bytes = (size_t)ed->n * D * sizeof(int32_t); break;
	case F_NFROZEN: src = ed->nfrozen; bytes = sizeof ed->nfrozen; break;
	case F_PISTON: {
		double *pt = (double *)b;
		for (int w = 0; w < 6; w++) {
			if (to_buf) pt[w] = ed->wall[w].pt0;
			else ed->wall[w].pt0 = pt[w];
		}
		return;
	}
	case F_NB: {
		/* lists packed: the first nn[i] entries of each row */
		size_t k = 0;
		for (uint32_t i = 0; i < ed->n; i++) {
			int32_t *row = ed->nb + (size_t)i * ed->nlk;
			if (to_buf) memcpy(b + k * 4, row, ed->nn[i] * 4u);
			else memcpy(row, b + k * 4, ed->nn[i] * 4u);
			k += ed->nn[i];
		}
		return;
	}
	default: return;
	}
	if (to_buf) memcpy(buf, src, bytes);
	else memcpy(src, buf, bytes);
}

int ed_field_get(const ed_t *ed, const char *name, void *buf)
{
	for (size_t a = 0; a < N_ARRAYS; a++)
		if (!strcmp(arrays[a].name, name)) {
			if (!array_present(ed, arrays[a].id))
				return ED_EINVAL;
			field_copy((struct ed *)ed, arrays[a].id, buf, 1);
			return ED_OK;
		}
	for (size_t a = 0; a < N_SCALARS; a++)
		if (!strcmp(scalars[a].name, name)) {
			memcpy(buf, (const char *)ed + scalars[a].off, scalars[a].type == ED_T_I32 ? 4 : 8);
			return ED_OK;
		}
	return ED_EINVAL;
}

int ed_field_set(ed_t *ed, const char *name, ed_type_t type, size_t count, const void *buf)
{
	for (size_t a = 0; a < N_ARRAYS; a++)
		if (!strcmp(arrays[a].name, name)) {
			/* nb's length is the sum of nn: nn must come first (ed_fields order) */
			if (!array_present(ed, arrays[a].id) || type != arrays[a].type ||
			    count != array_count(ed, arrays[a].id))
				return ED_EINVAL;
			if (arrays[a].id == F_NN)
				for (size_t i = 0; i < count; i++)
					if (((const uint8_t *)buf)[i] > ed->nlk)
						return ED_EINVAL;
			field_copy(ed, arrays[a].id, (void *)buf, 0);
			return ED_OK;
		}
	for (size_t a = 0; a < N_SCALARS; a++)
		if (!strcmp(scalars[a].name, name)) {
			if (type != scalars[a].type || count != 1)
				return ED_EINVAL;
			memcpy((char *)ed + scalars[a].off, buf, type == ED_T_I32 ? 4 : 8);
			return ED_OK;
		}
	return ED_EINVAL;
}

ed_t *ed_create_blank(const scene_t *s, int *err, char *msg, size_t msglen)
{
	return ed_alloc(s, err, msg, msglen);
}

static int in_range(int32_t x, uint32_t n) { return x >= -1 && x < (int32_t)n; }

/* A boundary event code: none, a cell face, or (walls) a wall of a walled axis. */
static int cross_valid(const struct ed *ed, int32_t c)
{
	if (c >= -1 && c < 2 * ed->dim)
		return 1;
	if (ed->variant && c >= ED_FILT0)   /* a filter plane */
		return c < ED_FILT0 + 6 && ed->fcell[c - ED_FILT0] != 0;
	if (ed->variant && c >= ED_OBST0)
		return c < ED_OBST0 + ed->nobst;
	return ed->variant && c >= ED_WALL0 && c < ED_WALL0 + 2 * ed->dim && !ed->periodic[(c - ED_WALL0) >> 1];
}

int ed_restore_finish(ed_t *ed, char *msg, size_t msglen)
{
	const uint32_t n = ed->n;
	uint32_t *seen = ed->scratch_idx;
	const char *why = NULL;
#define NEXT(i) (ed->next[i])

	/* Indices must stay in range (a corrupted file must not crash us), the
	 * scene indices must be a permutation, and the cell lists must hold each
	 * particle once, in its own cell. */
	memset(seen, 0, n * sizeof(uint32_t));
	for (uint32_t i = 0; i < n && !why; i++) {
		const ev_t *e = &ed->ev[i];
		if (ed->id[i] >= n || seen[ed->id[i]]++)
			why = "scene indices are not a permutation";
		else if (!in_range(e->partner, n) || !in_range(NEXT(i), n))
			why = "particle index out of range";
		else if (!cross_valid(ed, e->cross) || isnan(e->t_coll) || isnan(e->t_cross))
			why = "bad event record";
		for (int a = 0; a < 3 && !why; a++)
			if (e->cc[a] < 0 || e->cc[a] >= ed->nc[a])
				why = "cell out of range";
		if (!why && ed->xn)
			for (int k = 0; k < ed->nn[i]; k++)
				if (ed->nb[(size_t)i * ed->nlk + k] < 0 || ed->nb[(size_t)i * ed->nlk + k] >= (int32_t)n)
					why = "neighbour index out of range";
	}
	memset(seen, 0, n * sizeof(uint32_t));
	for (size_t c = 0; c < ed->ncells && !why; c++) {
		if (!in_range(ed->head[c], n)) {
			why = "cell head out of range";
			break;
		}
		for (int32_t j = ed->head[c]; j >= 0 && !why; j = NEXT(j)) {
			if (seen[j]++)
				why = "cell lists are not disjoint";
			else if ((size_t)DISPATCH(ed, cell_index, ed, ed->ev[j].cc) != c)
				why = "particle filed in the wrong cell";
		}
	}
	for (uint32_t i = 0; i < n && !why; i++) {
		int out = ed->gone && ed->gone[i];
		if (ed->gone && ed->gone[i] > 1)
			why = "bad presence flag";
		else if (!seen[i] && !out)
			why = "particle missing from the cell lists";
		else if (seen[i] && out)
			why = "a particle that left is in the cell lists";
	}
	if (!why && ed->gone) {
		ed->n_gone = 0;
		for (uint32_t i = 0; i < n; i++)
			ed->n_gone += ed->gone[i];
	}
	if (!why && ed->freei && ed->mix) {   /* mixtures: one stack per species, its slots' count from gone */
		memset(ed->mix->fs_n, 0, sizeof ed->mix->fs_n);
		for (uint32_t i = 0; i < n; i++)
			if (ed->gone[i])
				ed->mix->fs_n[ed->mix->rsp[ed->id[i]]]++;
		for (int sp = 0; sp < ed->nsp && !why; sp++)
			for (uint32_t k = 0; k < ed->mix->fs_n[sp] && !why; k++) {
				const uint64_t at = (uint64_t)ed->mix->fs_off[sp] + k;
				const uint32_t i = at < n ? ed->freei[at] : UINT32_MAX;
				if (i >= n || !ed->gone[i] || seen[i] == 2 || ed->mix->rsp[ed->id[i]] != sp)
					why = "bad free-slot stack";
				else
					seen[i] = 2;
			}
	} else if (!why && ed->freei) {   /* the free stack: the empty slots, each once; labels of rows present */
		for (uint64_t k = 0; k < ed->n_gone && !why; k++) {
			const uint32_t i = ed->freei[k];
			if (i >= n || !ed->gone[i] || seen[i] == 2)
				why = "bad free-slot stack";
			else
				seen[i] = 2;
		}
	}
	if (!why && ed->freei) {
		for (uint32_t i = 0; i < n && !why; i++)
			if ((ed->label[ed->id[i]] < 0) != (ed->gone[i] != 0) || ed->label[ed->id[i]] >= (int64_t)ed->in_count[12])
				why = "bad particle ids";
	}
	if (!why && ed->gone && ed->mix) {   /* the mass that left (species from the scene indices) */
		memset(ed->mix->npres, 0, sizeof ed->mix->npres);
		for (uint32_t i = 0; i < n; i++)
			if (!ed->gone[i])
				ed->mix->npres[ed->mix->rsp[ed->id[i]]]++;
		mix_present(ed, -1, 0);
	}
	if (!why && (!(ed->cal_w > 0.0) || !isfinite(ed->cal_iw = 1.0 / ed->cal_w)))
		why = "bad calendar width";
	if (!why && (ed->nl != 0 && !(ed->nl == 1 && ed->xn)))
		why = "bad mode";
	if (!why && ed->t_abs_valid != 0 && ed->t_abs_valid != 1)
		why = "bad clock flag";
	for (int w = 0; w < 6 && !why; w++)
		if ((ed->disp >> w & 1) && !isfinite(ed->wall[w].pt0))
			why = "bad piston time";
	for (uint32_t i = 0; i < n && !why && ed->frozen; i++)
		if (ed->frozen[i] > 6 || (ed->frozen[i] && (!ed->fcell[ed->frozen[i] - 1] || ed->gone[i])))
			why = "bad frozen flag";
	memset(seen, 0, n * sizeof(uint32_t));
#undef NEXT
	if (why) {
		if (msg && msglen)
			snprintf(msg, msglen, "inconsistent engine state: %s", why);
		return ED_EINVAL;
	}
	/* Species of each stored particle from its scene index (now a valid permutation). */
	if (ed->spc)
		species_from_id(ed);
	/* Checkpoints are of the production run: the piston moves, filters act. */
	for (int w = 0; w < 6; w++)
		if (ed->disp >> w & 1)
			ed->wall[w].pu = ed->wall[w].pspeed;
	ed->filt_on = ed->nfilt > 0;
	frozen_tally(ed);   /* filters under gravity: the frozen particles present and their velocity sum */
	/* The occupancy bitmap from the cell heads. */
	memset(ed->occ, 0, (ed->ncells + 63) / 64 * sizeof(uint64_t));
	for (size_t c = 0; c < ed->ncells; c++)
		if (ed->head[c] >= 0)
			ed->occ[c >> 6] |= (uint64_t)1 << (c & 63);
	/* The calendar: same width and current bucket, every event re-inserted. */
	ed->nl_over = 0;
	ed->cal_ring = 0;
	ed->cal_pf = -1;
	ed->hn = 0;
	for (uint32_t c = 0; c <= ed->cal_m; c++)
		ed->cal_head[c] = -1;
	for (uint32_t i = 0; i < n; i++)
		cal_insert(ed, i, ev_time(ed, i));
	return ED_OK;
}

void ed_totals(const ed_t *ed, ed_sample_t *out)
{
	memset(out, 0, sizeof(*out));
	out->time = ed_time(ed);
	out->events = ed->events;
	out->collisions = ed->collisions;
	out->elastic_by_tc = ed->tc_elastic;
	out->kinetic_energy = DISPATCH(ed, ekin, ed, out->momentum);
	out->rotational_energy = ed->rough ? ed_erot(ed) : NAN;
	species_ekin(ed, out);
	sample_walls(ed, out);
}

void ed_watch_collapse(ed_t *ed, double rate)
{
	ed->collapse_rate = rate > 0.0 ? rate : 0.0;
}

#ifdef ED_TRACE
int ed_trace(ed_t *ed, ed_trace_fn fn, void *ctx)
{
	if (ed->nl || ed->variant || ed->rough || ed->mixture)
		return ED_EINVAL;
	ed->trace = fn;
	ed->trace_ctx = ctx;
	return ED_OK;
}
#endif

void ed_count_impacts(ed_t *ed, double *counts, int nb)
{
	ed->bcount = nb > 0 ? counts : NULL;
	ed->bnb = nb;
}

const ed_collapse_t *ed_collapse(const ed_t *ed)
{
	return ed->collapse.events ? &ed->collapse : NULL;
}
