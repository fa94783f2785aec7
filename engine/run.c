/* Run driver: output, snapshot and checkpoint schedules, stop conditions and observables around the engines (ed, dsmc/hsmc). */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "mc/dsmc.h"
#include "md/md.h"
#include "rng.h"
#include "observe/dspec.h"
#include "observe/fields.h"
#include "observe/msd.h"
#include "ed/ed.h"
#include "run.h"
#include "place.h"

/* Work between polls of the stop flag: ~0.1 s (events for ed, particle moves for dsmc). */
#define RUN_CHUNK_EVENTS 200000u
#define RUN_CHUNK_MOVES 4000000u

/*
 * Inelastic collapse (ed; docs/engine.md, "Inelastic collapse"): the run
 * stops when a window of 8N events (ed_watch_collapse()) came more than
 * RUN_COLLAPSE_FACTOR times faster than the Enskog collision rate of the
 * scene's volume fraction at the present temperature, per particle. Events
 * outnumber collisions (crossings, list rebuilds: 1-10 per collision), and
 * dense clusters of a cooling gas collide faster than the mean density
 * says: measured windows of fluids, dense elastic systems, clustering
 * inelastic gases and TC runs stay below 10^3 times the rate. A collapse
 * processes events at one instant (the window's time tends to 0, often is
 * 0): measured 10^9 and more, or infinite. 10^6 leaves three decades on
 * either side.
 */
#define RUN_COLLAPSE_FACTOR 1e6

/* md: time steps above t_c / 20 get a warning on the first record: damped contacts' restitution errs to first
 * order in dt (linear, e = 0.7: 2.6e-3 low at t_c/50, measured in tests/md_test.c), 6.5e-3 at t_c/20. */
#define RUN_MD_STEP_WARN 0.05

static double wall_now(void)
{
	struct timespec ts;
	clock_gettime(CLOCK_MONOTONIC, &ts);
	return ts.tv_sec + 1e-9 * ts.tv_nsec;
}

/* Collision count at which a collisions-per-particle condition is met. */
static uint64_t cpp_to_collisions(double cpp, uint64_t n)
{
	double c = ceil(cpp * (double)n / 2.0 - 1e-9);
	return c < 1.0 ? 1 : (c >= 1.8e19 ? UINT64_MAX : (uint64_t)c);
}

/* One replica: the engine state (ed or dsmc/hsmc) and the schedules. */
struct run {
	scene_t s;               /* copy, with the replica's stream */
	unsigned char *extra;    /* run_extra_set(): opaque bytes a checkpoint carries (split ed runs), or NULL */
	size_t extra_len;
	run_opts_t opts;
	ed_t *ed;
	dsmc_t *mc;
	md_t *md;                /* method md (soft spheres), else NULL */
	double *md_radii, *md_masses; /* md mixtures: each particle's radius and mass (scene order), else NULL */
	uint64_t md_steps;       /* md: velocity-Verlet steps taken (the events of its records) */
	int md_err;              /* md: the core's error code when a step failed */
	uint64_t md_kend;        /* md: the steps to run.until.time (dt = until / md_kend, md_build()) */
	md_state_t md_in;        /* md, restoring: the state fields read so far (run_field_set()), for md_state_set() */
	unsigned md_got;         /* md, restoring: bit k set when field k of md_fields[] was read */
	uint64_t mc_chunk;       /* dsmc steps between polls of the stop flag */
	clusters_t *cl;
	int varying;             /* open or reservoir walls: particles come and go (NaN rows, eng_present()) */
	double *radii;           /* clusters of mixtures: each particle's radius (scene_species_radii()) */
	obs_t *obs;              /* structure observables (observe.h), NULL when none is asked for */
	msd_t *msd;              /* mean_square_displacement (observe/msd.h), or NULL */
	double msd_prev, msd_tprev; /* MSD and time of the previous progress record (the interval's D) */
	double *pos, *vel;       /* sampling buffers (clusters, snapshots, structure observables) */
	int64_t *ids;            /* reservoir scenes with snapshots: each row's particle id */
	double *placed;          /* positions placed in particles.initial.region (s.init_pos), or NULL */
	double *spin;            /* snapshots and fields of rough particles: angular velocities */
	/* fields (output.fields): the exposure before the next curves, at fld_end; its instants
	 * fld_end - exposure + k exposure / samples, k = fld_k .. samples (the next at fld_next, INFINITY when
	 * none is left); fld_last: the time of the last instant added (-INFINITY: none) */
	int fld;                 /* fields are sampled (asked for, and curves emitted) */
	double fld_k, fld_end, fld_next, fld_last;
	/* density_spectrum: slice counts sampled at dsp_k * interval (the next), k = 1, 2, ... */
	int dsp;
	double dsp_k;
	double t0;               /* wall clock at the start of this process's part */
	double ckpt_wall;        /* wall clock of the last checkpoint request */
	char warning[512];       /* dsmc/hsmc validity warning for the first record */
	char collapse[512];      /* status RUN_COLLAPSED: what happened and what to do (last records) */
	run_state_t st;
	run_record_t rec;        /* the last progress record */
	run_status_t status;
	int done;                /* run_next(): the last record has been returned */
};

static double wall_seconds(const run_t *r)
{
	return r->st.wall_before + (wall_now() - r->t0);
}

/* ---- the engines' common ground ---------------------------------------- */

typedef struct {
	double time, interval, kinetic_energy, momentum[3], ekin_time_integral, virial;
	uint64_t events, collisions, interval_collisions, elastic_by_tc;
	uint64_t vmax_raised, cell_collisions, rejected_moves;
	uint64_t wall_collisions;
	double wall_impulse[6][3], com_height, potential_energy;
	uint64_t obstacle_collisions;
	double obstacle_impulse[SCENE_OBSTACLES_MAX][3];
	uint64_t particles, wall_outflow[6];   /* present now (N without open walls); out per wall */
	uint64_t wall_inflow[6], wall_rejected[6];   /* reservoir walls: in per wall, rejected entries */
	uint64_t source_inserted, source_skipped;    /* particles.source: inserted, skipped (totals) */
	double rotational_energy;
	int n_species;                         /* ed mixtures: kinetic energy and count per species */
	double species_ekin[SCENE_SPECIES_MAX];
	uint64_t species_count[SCENE_SPECIES_MAX];
} smp_t;

static void eng_species(smp_t *o, const ed_sample_t *sm)
{
	o->n_species = sm->n_species;
	memcpy(o->species_ekin, sm->species_kinetic_energy, sizeof o->species_ekin);
	memcpy(o->species_count, sm->species_count, sizeof o->species_count);
}

static void mc_species(smp_t *o, const dsmc_sample_t *sm)
{
	o->n_species = sm->n_species;
	memcpy(o->species_ekin, sm->species_kinetic_energy, sizeof o->species_ekin);
	memcpy(o->species_count, sm->species_count, sizeof o->species_count);
}

/* md: totals now (time, steps, kinetic energy, momentum; with gravity the centre-of-mass height along -g
 * and the potential energy -m sum g.x, as ed defines them, plus the elastic energy of the contacts). Positions are unwrapped between Verlet-list
 * rebuilds: only a periodic axis can carry gravity's component, which parsing does not forbid, so the
 * height is taken from positions wrapped into the box. */
/* md: the clock, run.until.time exactly at its last step (dt = until / md_kend). */
static double md_clock(const run_t *rc)
{
	return rc->md_steps == rc->md_kend ? rc->s.until.value : md_time(rc->md);
}

static void md_totals(const run_t *rc, smp_t *o)
{
	const scene_t *s = &rc->s;
	const double *x = md_positions(rc->md), *v = md_velocities(rc->md);
	double g2 = 0.0, gr = 0.0;
	for (int a = 0; a < s->dim; a++)
		g2 += s->gravity[a] * s->gravity[a];
	o->time = md_clock(rc);
	o->events = rc->md_steps;
	o->particles = s->count;
	md_energy_t en;
	md_energy(rc->md, &en);
	o->rotational_energy = en.rotational;
	if (rc->md_masses) {   /* mixtures: each particle's mass; species in blocks of rows (scene order) */
		double mg = 0.0, mtot = 0.0, ek = 0.0;
		o->n_species = s->n_species;
		for (uint64_t i = 0, k = 0, end = s->species[0].count; i < s->count; i++) {
			while (i >= end)
				end += s->species[++k].count;
			const double m = rc->md_masses[i];
			double v2 = 0.0;
			for (int a = 0; a < s->dim; a++) {
				double xa = x[i * 3 + a];
				if (!s->boundary[a].walled)
					xa -= s->box[a] * floor(xa / s->box[a]);
				mg += m * s->gravity[a] * xa;
				o->momentum[a] += m * v[i * 3 + a];
				v2 += v[i * 3 + a] * v[i * 3 + a];
			}
			o->species_ekin[k] += 0.5 * m * v2;
			o->species_count[k]++;
			ek += 0.5 * m * v2;
			mtot += m;
		}
		o->kinetic_energy = ek;
		o->com_height = g2 > 0.0 ? -mg / (sqrt(g2) * mtot) : NAN;   /* mass-weighted, as ed's */
		o->potential_energy = -mg + en.elastic;
		return;
	}
	double sum[3] = {0, 0, 0}, v2 = 0.0;
	for (uint64_t i = 0; i < s->count; i++)
		for (int a = 0; a < s->dim; a++) {
			double xa = x[i * 3 + a];
			if (!s->boundary[a].walled)
				xa -= s->box[a] * floor(xa / s->box[a]);
			sum[a] += xa;
			o->momentum[a] += s->mass * v[i * 3 + a];
			v2 += v[i * 3 + a] * v[i * 3 + a];
		}
	for (int a = 0; a < s->dim; a++)
		gr += s->gravity[a] * sum[a];
	o->kinetic_energy = 0.5 * s->mass * v2;
	o->com_height = g2 > 0.0 ? -gr / (sqrt(g2) * (double)s->count) : NAN;
	o->potential_energy = -s->mass * gr + en.elastic;   /* gravity's and the contacts' springs' */
}

static void eng_sample(run_t *rc, smp_t *o)
{
	memset(o, 0, sizeof(*o));
	if (rc->md) {   /* the walls' impulses and the virial over the interval since the last sample */
		md_totals(rc, o);
		md_walls(rc->md, o->wall_impulse, &o->interval);
		double kin;
		md_virial(rc->md, &o->virial, &kin);
		md_obstacles(rc->md, o->obstacle_impulse);
		o->ekin_time_integral = 0.5 * kin;
		md_wall_reset(rc->md);
	} else if (rc->ed) {
		ed_sample_t sm;
		ed_sample(rc->ed, &sm);
		o->time = sm.time, o->interval = sm.interval, o->kinetic_energy = sm.kinetic_energy;
		memcpy(o->momentum, sm.momentum, sizeof(o->momentum));
		o->ekin_time_integral = sm.ekin_time_integral, o->virial = sm.virial;
		o->events = sm.events, o->collisions = sm.collisions;
		o->interval_collisions = sm.interval_collisions, o->elastic_by_tc = sm.elastic_by_tc;
		o->wall_collisions = sm.wall_collisions;
		memcpy(o->wall_impulse, sm.wall_impulse, sizeof(o->wall_impulse));
		o->com_height = sm.com_height, o->potential_energy = sm.potential_energy;
		o->obstacle_collisions = sm.obstacle_collisions;
		memcpy(o->obstacle_impulse, sm.obstacle_impulse, sizeof(o->obstacle_impulse));
		o->particles = sm.particles;
		memcpy(o->wall_outflow, sm.wall_outflow, sizeof(o->wall_outflow));
		memcpy(o->wall_inflow, sm.wall_inflow, sizeof(o->wall_inflow));
		memcpy(o->wall_rejected, sm.wall_rejected, sizeof(o->wall_rejected));
		o->rotational_energy = sm.rotational_energy;
		eng_species(o, &sm);
	} else {
		dsmc_sample_t sm;
		dsmc_sample(rc->mc, &sm);
		o->time = sm.time, o->interval = sm.interval, o->kinetic_energy = sm.kinetic_energy;
		memcpy(o->momentum, sm.momentum, sizeof(o->momentum));
		o->ekin_time_integral = sm.ekin_time_integral, o->virial = sm.virial;
		o->events = sm.moves, o->collisions = sm.collisions;
		o->interval_collisions = sm.interval_collisions;
		o->vmax_raised = sm.vmax_raised, o->cell_collisions = sm.cell_collisions;
		o->rejected_moves = sm.rejected_moves;
		o->wall_collisions = sm.wall_collisions;
		memcpy(o->wall_impulse, sm.wall_impulse, sizeof(o->wall_impulse));
		o->obstacle_collisions = sm.obstacle_collisions;
		memcpy(o->obstacle_impulse, sm.obstacle_impulse, sizeof(o->obstacle_impulse));
		o->com_height = sm.com_height, o->potential_energy = sm.potential_energy;
		o->particles = sm.particles;
		memcpy(o->wall_outflow, sm.wall_outflow, sizeof(o->wall_outflow));
		o->source_inserted = sm.source_inserted, o->source_skipped = sm.source_skipped;
		mc_species(o, &sm);
	}
}

/* Totals now without starting a new interval (changes nothing). */
static void eng_totals(const run_t *rc, smp_t *o)
{
	memset(o, 0, sizeof(*o));
	if (rc->md) {
		md_totals(rc, o);
	} else if (rc->ed) {
		ed_sample_t sm;
		ed_totals(rc->ed, &sm);
		o->time = sm.time, o->kinetic_energy = sm.kinetic_energy;
		memcpy(o->momentum, sm.momentum, sizeof(o->momentum));
		o->events = sm.events, o->collisions = sm.collisions, o->elastic_by_tc = sm.elastic_by_tc;
		o->wall_collisions = sm.wall_collisions;
		o->com_height = sm.com_height, o->potential_energy = sm.potential_energy;
		o->obstacle_collisions = sm.obstacle_collisions;
		o->particles = sm.particles;
		memcpy(o->wall_outflow, sm.wall_outflow, sizeof(o->wall_outflow));
		memcpy(o->wall_inflow, sm.wall_inflow, sizeof(o->wall_inflow));
		memcpy(o->wall_rejected, sm.wall_rejected, sizeof(o->wall_rejected));
		o->rotational_energy = sm.rotational_energy;
		eng_species(o, &sm);
	} else {
		dsmc_sample_t sm;
		dsmc_totals(rc->mc, &sm);
		o->time = sm.time, o->kinetic_energy = sm.kinetic_energy;
		memcpy(o->momentum, sm.momentum, sizeof(o->momentum));
		o->events = sm.moves, o->collisions = sm.collisions;
		o->vmax_raised = sm.vmax_raised, o->cell_collisions = sm.cell_collisions;
		o->rejected_moves = sm.rejected_moves;
		o->wall_collisions = sm.wall_collisions;
		o->obstacle_collisions = sm.obstacle_collisions;
		o->com_height = sm.com_height, o->potential_energy = sm.potential_energy;
		o->particles = sm.particles;
		memcpy(o->wall_outflow, sm.wall_outflow, sizeof(o->wall_outflow));
		mc_species(o, &sm);
	}
}

/* Advance to t_stop / c_stop or a chunk of work; returns 1 when the system
 * is quiescent (no further collisions will happen), 2 on an inelastic
 * collapse (ed_watch_collapse()), else 0. t_soft: a
 * schedule time that must not change the dynamics. ed stops exactly there
 * (its events do not depend on where it stops); dsmc/hsmc stop at the end
 * of the step that reaches it, since shortening a step would change the
 * random sequence (frames and checkpoints must not alter the run). */
static int eng_advance(run_t *rc, double t_stop, double t_soft, uint64_t c_stop)
{
	if (rc->md) {   /* md: whole steps up to the first that reaches the stop (as dsmc), a chunk at most */
		double dt = md_dt(rc->md), target = fmin(t_stop, t_soft), left = target - md_clock(rc);
		double steps = target >= rc->s.until.value ? (double)(rc->md_kend - rc->md_steps) : ceil(left / dt - 1e-9);
		/* the clock at the target already: a run stopped (SIGTERM) after the step that reached an output
		 * time and before its record, resumed from its checkpoint; the record comes without a step */
		if (md_clock(rc) >= target || rc->md_steps >= rc->md_kend)
			return 0;
		long k = (long)fmax(1.0, fmin(steps, (double)rc->mc_chunk));
		int e = md_step(rc->md, k);
		rc->md_steps += (uint64_t)k;
		rc->md_err = e;
		return e == MD_OK ? 0 : 4;
	}
	if (rc->ed) {
		int e = ed_advance(rc->ed, fmin(t_stop, t_soft), c_stop, RUN_CHUNK_EVENTS);
		return e == ED_QUIESCENT ? 1 : e == ED_COLLAPSE ? 2 : e == ED_FULL ? 3 : 0;
	}
	return dsmc_advance_soft(rc->mc, t_stop, t_soft, c_stop, rc->mc_chunk) == DSMC_QUIESCENT;
}

static uint64_t eng_events(const run_t *rc)
{
	return rc->md ? rc->md_steps : rc->ed ? ed_events(rc->ed) : dsmc_moves(rc->mc);
}

static void eng_state(const run_t *rc, double *pos, double *vel)
{
	if (rc->md) {   /* stride 3 to the scene's dim; periodic axes wrapped into [0, L) */
		const scene_t *s = &rc->s;
		const double *x = md_positions(rc->md), *v = md_velocities(rc->md);
		for (uint64_t i = 0; i < s->count; i++)
			for (int a = 0; a < s->dim; a++) {
				double xa = x[i * 3 + a];
				if (!s->boundary[a].walled)
					xa -= s->box[a] * floor(xa / s->box[a]);
				if (pos)
					pos[i * s->dim + a] = xa;
				if (vel)
					vel[i * s->dim + a] = v[i * 3 + a];
			}
	} else if (rc->ed)
		ed_state(rc->ed, pos, vel);
	else
		dsmc_state(rc->mc, pos, vel);
}

/* The state of the particles present, as eng_state(), in the first rows (obs_present()); their count.
 * A scene with a fixed particle set (r->varying 0: no open or reservoir wall) has them all, in order. */
static size_t eng_present(const run_t *rc, double *pos, double *vel, double *spin)
{
	eng_state(rc, pos, vel);
	if (!rc->varying)
		return rc->s.count;
	return obs_present(scene_slots(&rc->s), rc->s.dim, pos, vel, spin, spin ? ed_spin_dim(rc->ed) : 0);
}

static double eng_time(const run_t *rc)
{
	return rc->md ? md_clock(rc) : rc->ed ? ed_time(rc->ed) : dsmc_time(rc->mc);
}

static uint64_t eng_collisions(const run_t *rc)
{
	return rc->md ? 0 : rc->ed ? ed_collisions(rc->ed) : dsmc_collisions(rc->mc);
}

/* mean_square_displacement: unwrap the present positions (or take them as the origin). The speed bound's
 * energy (observe/msd.h): the kinetic energy, plus the rotational energy of rough particles (collisions
 * turn it into translation); with gravity the kinetic energy now, from the velocities (ed's totals hold
 * it at the last event), to which msd adds the potential energy above its least value. */
static void msd_follow(run_t *rc)
{
	const scene_t *s = &rc->s;
	smp_t sm;
	eng_totals(rc, &sm);
	double e = sm.kinetic_energy;
	if ((rc->ed || rc->mc) && scene_msd_images(s)) {   /* the engine counted the images: exact, no bound */
		if (rc->ed)
			ed_unwrapped(rc->ed, rc->pos);
		else
			dsmc_unwrapped(rc->mc, rc->pos);
		if (rc->st.started)
			msd_update(rc->msd, sm.time, rc->pos, 0.0);
		else
			msd_origin(rc->msd, sm.time, rc->pos, 0.0);
		if (rc->ids && ed_labels(rc->ed, rc->ids) == ED_OK)   /* reservoir slots: refilled ones drop out */
			msd_ids(rc->msd, rc->ids);
		return;
	}
	if (scene_has_gravity(s)) {
		eng_state(rc, rc->pos, rc->vel);
		if (s->n_species > 1) {   /* mixtures: each species' block of rows with its mass */
			size_t off = 0;
			e = 0.0;
			for (int k = 0; k < s->n_species; k++) {
				double v2 = 0.0;
				for (size_t j = off * s->dim; j < (off + s->species[k].count) * s->dim; j++)
					if (isfinite(rc->vel[j]))   /* (absent rows of a varying set: NaN) */
						v2 += rc->vel[j] * rc->vel[j];
				e += 0.5 * s->species[k].mass * v2;
				off += s->species[k].count;
			}
		} else {
			double v2 = 0.0;
			for (size_t k = 0; k < scene_slots(s) * (size_t)s->dim; k++)
				if (isfinite(rc->vel[k]))   /* (absent rows of a varying set: NaN) */
					v2 += rc->vel[k] * rc->vel[k];
			e = 0.5 * s->mass * v2;
		}
	} else {
		eng_state(rc, rc->pos, NULL);
	}
	if (s->rough && isfinite(sm.rotational_energy))
		e += sm.rotational_energy;
	if (rc->md) {   /* soft contacts store energy that they give back: the bound takes the conserved energy
			 * (kinetic + rotational, friction turns spin into translation, + the contacts' elastic) */
		md_energy_t en;
		md_energy(rc->md, &en);
		e += en.rotational + en.elastic;
	}
	if (rc->st.started)
		msd_update(rc->msd, sm.time, rc->pos, e);
	else
		msd_origin(rc->msd, sm.time, rc->pos, e);
}

/* flux: sum_i v_i . g_hat / volume and its standard error over particles (observe.h). */
static void flux_compute(const scene_t *s, uint64_t n, const double *vel, double *flux, double *se)
{
	const int D = s->dim;
	double g[3] = {0, 0, 0}, gn = 0.0;
	for (int a = 0; a < D; a++)
		gn += s->gravity[a] * s->gravity[a];
	gn = sqrt(gn);
	for (int a = 0; a < D; a++)
		g[a] = gn > 0.0 ? s->gravity[a] / gn : (a == D - 1);
	double sum = 0.0, sum2 = 0.0;
	for (uint64_t i = 0; i < n; i++) {
		double u = 0.0;
		for (int a = 0; a < D; a++)
			u += vel[i * D + a] * g[a];
		sum += u;
		sum2 += u * u;
	}
	double vol = scene_box_volume(s), mean = sum / (double)n;
	double var = n > 1 ? fmax(0.0, (sum2 - n * mean * mean) / (double)(n - 1)) : NAN;
	*flux = sum / vol;
	*se = sqrt((double)n * var) / vol;
}

static int sample(run_t *rc, run_record_t *r, run_kind_t kind)
{
	const scene_t *s = &rc->s;
	smp_t sm;
	eng_sample(rc, &sm);
	memset(r, 0, sizeof(*r));
	r->kind = kind;
	r->dim = s->dim;
	r->n = s->count;
	r->time = sm.time;
	r->events = sm.events;
	r->collisions = sm.collisions;
	r->collisions_per_particle = 2.0 * (double)sm.collisions / (double)s->count;
	r->wall_seconds = wall_seconds(rc);
	r->elastic_by_tc = sm.elastic_by_tc;
	r->vmax_raised = sm.vmax_raised;
	r->cell_collisions = sm.cell_collisions;
	r->rejected_moves = sm.rejected_moves;
	r->have = s->observables;
	r->kinetic_energy = sm.kinetic_energy;
	/* with open walls, over the particles still present (the interval
	 * mean divides by those present at its end) */
	const double np = sm.particles ? (double)sm.particles : (double)s->count;
	r->particles = sm.particles;
	memcpy(r->wall_outflow, sm.wall_outflow, sizeof(r->wall_outflow));
	memcpy(r->wall_inflow, sm.wall_inflow, sizeof(r->wall_inflow));
	memcpy(r->wall_rejected, sm.wall_rejected, sizeof(r->wall_rejected));
	r->source = s->src_count > 0;
	r->source_inserted = sm.source_inserted, r->source_skipped = sm.source_skipped;
	r->temperature = 2.0 * sm.kinetic_energy / (s->dim * np);
	r->n_species = sm.n_species;
	for (int k = 0; k < sm.n_species; k++)
		r->temperature_species[k] = 2.0 * sm.species_ekin[k] / (s->dim * (double)sm.species_count[k]);
	memcpy(r->momentum, sm.momentum, sizeof(r->momentum));
	if (sm.interval > 0.0) {
		/* Time-averaged temperature over the interval from the exact
		 * integral of E_kin dt (E_kin is piecewise constant). */
		double t_avg = 2.0 * sm.ekin_time_integral / (s->dim * np * sm.interval);
		double vol = scene_box_volume(s);
		r->have_interval = 1;
		if (rc->varying) {
			/* particles come and go: the kinetic part from the exact integral of E_kin over the particles
			 * present (no fixed N), Z = 1 + virial / (2 int E_kin dt): docs/output.md */
			r->pressure = (2.0 * sm.ekin_time_integral + sm.virial) / (s->dim * sm.interval * vol);
			r->compressibility = sm.ekin_time_integral > 0.0 ? 1.0 + sm.virial / (2.0 * sm.ekin_time_integral) : NAN;
		} else {
			r->pressure = ((double)s->count * t_avg + sm.virial / (s->dim * sm.interval)) / vol;
			r->compressibility = t_avg > 0.0 ? r->pressure * vol / ((double)s->count * t_avg) : NAN;
		}
		r->collision_rate = 2.0 * (double)sm.interval_collisions / ((double)s->count * sm.interval);
	}
	r->wall_collisions = sm.wall_collisions;
	r->com_height = sm.com_height, r->potential_energy = sm.potential_energy;
	r->n_obstacles = s->n_obstacles;
	r->obstacle_collisions = sm.obstacle_collisions;
	if (sm.interval > 0.0)
		for (int k = 0; k < s->n_obstacles; k++)
			for (int b = 0; b < 3; b++)
				r->obstacle_force[k][b] = sm.obstacle_impulse[k][b] / sm.interval;
	if (s->rough || rc->md) {   /* md: the spins friction gives */
		r->rotational_energy = sm.rotational_energy;
		r->rotational_temperature = 2.0 * sm.rotational_energy / ((s->dim == 2 ? 1.0 : 3.0) * np);
	}
	for (int a = 0; a < s->dim; a++) {
		if (!s->boundary[a].walled)
			continue;
		/* the wall's area: the box's other edges */
		double area = 1.0;
		for (int b = 0; b < s->dim; b++)
			if (b != a)
				area *= s->box[b];
		for (int k = 0; k < 2; k++) {
			int w = 2 * a + k;
			r->walls |= 1u << w;
			if (s->boundary[a].wall[k].type == SCENE_WALL_RESERVOIR ||
			    s->boundary[a].wall[k].type == SCENE_WALL_DISPENSER)   /* particles enter */
				r->reservoirs |= 1u << w;
			if (!(sm.interval > 0.0))
				continue;
			for (int b = 0; b < 3; b++)
				r->wall_force[w][b] = sm.wall_impulse[w][b] / sm.interval;
			/* outward: -axis at the lower wall, +axis at the upper */
			r->wall_pressure[w] = (k ? 1.0 : -1.0) * r->wall_force[w][a] / area;
		}
	}
	int want_vel = (s->observables & (SCENE_OBS_VDIST | SCENE_OBS_FLUX)) != 0;
	int want_pos = (s->observables & (SCENE_OBS_CLUSTERS | SCENE_OBS_GOFR)) != 0;
	size_t rows = s->count;
	if (want_pos || want_vel)
		rows = eng_present(rc, rc->pos, want_vel ? rc->vel : NULL, NULL);
	if ((s->observables & SCENE_OBS_CLUSTERS) && rc->cl) {
		if (clusters_set_count(rc->cl, rows) != 0 ||
		    clusters_compute(rc->cl, rc->pos, s->box, s->radius, s->cluster_delta * 2.0 * s->radius,
		                     &r->clusters) != 0)
			return RUN_ENOMEM;
	}
	r->obs.a2 = r->obs.a3 = r->obs.g_pairs = r->obs.g_pairs_se = r->obs.g_rate = r->obs.g_pressure = NAN;
	r->obs.msd = r->obs.msd_se = r->obs.diffusion = r->obs.msd_walled = r->obs.msd_count = NAN;
	r->obs.flux = r->obs.flux_se = NAN;
	if (s->observables & SCENE_OBS_FLUX)
		flux_compute(s, rows, rc->vel, &r->obs.flux, &r->obs.flux_se);
	if (rc->msd) {
		msd_follow(rc);
		r->obs.msd = msd_value(rc->msd, &r->obs.msd_se);
		double dt = sm.time - rc->msd_tprev;
		/* with walls: D along the periodic axes only (the walled part saturates); msd_prev is then
		 * the periodic part */
		int dp = 0;
		for (int a = 0; a < s->dim; a++)
			dp += !s->boundary[a].walled;
		double m = dp == s->dim ? r->obs.msd : msd_value_axes(rc->msd, 0);
		if (dp < s->dim)
			r->obs.msd_walled = msd_value_axes(rc->msd, 1);
		/* varying sets: the growth over the interval of the particles present at both ends */
		double dm = rc->varying ? msd_interval(rc->msd) : m - rc->msd_prev;
		r->obs.msd_count = rc->varying ? (double)msd_count(rc->msd) : NAN;
		if (rc->st.started && dt > 0.0 && dp > 0)
			r->obs.diffusion = dm / (2.0 * dp * dt);
		rc->msd_prev = m;
		rc->msd_tprev = sm.time;
	}
	if (rc->obs && (s->observables & (SCENE_OBS_VDIST | SCENE_OBS_GOFR))) {
		if (obs_scalars(rc->obs, rows, rc->pos, rc->vel, &r->obs) != 0)
			return RUN_ENOMEM;
		/* md: no collisions are counted and the contacts' virial is not a hard-sphere collision virial, so
		 * g_rate and g_pressure stay NaN (docs/md.md, "Structure observables") */
		if (r->have_interval && (s->observables & SCENE_OBS_GOFR) && !rc->md) {
			double t_avg = 2.0 * sm.ekin_time_integral / (s->dim * (double)s->count * sm.interval);
			obs_interval(rc->obs, r->collision_rate, r->compressibility, t_avg, &r->obs);
		}
	}
	return RUN_OK;
}

/* A record of kind with the run's totals now (clock, counters, energy). */
static void totals_record(run_t *r, run_record_t *rec, run_kind_t kind)
{
	smp_t sm;
	eng_totals(r, &sm);
	memset(rec, 0, sizeof(*rec));
	rec->kind = kind;
	rec->dim = r->s.dim;
	rec->n = r->s.count;
	rec->time = sm.time;
	rec->events = sm.events;
	rec->collisions = sm.collisions;
	rec->collisions_per_particle = 2.0 * (double)sm.collisions / (double)r->s.count;
	rec->kinetic_energy = sm.kinetic_energy;
}

/* ---- fields (output.fields) ----------------------------------------------- */

/* Add the state at time t (pos, vel: read now unless have_state) to the exposure. */
static void fields_sample(run_t *r, double t, int have_state)
{
	if (have_state == 0)
		eng_state(r, r->pos, r->vel);
	if (r->spin)
		ed_spins(r->ed, r->spin);
	obs_fields_add(r->obs, r->pos, r->vel, r->spin);
	r->fld_last = t;
}

/* The next instant of the exposure at or after index fld_k that lies after t (INFINITY: none left). */
static void fields_next(run_t *r, double t)
{
	const scene_t *s = &r->s;
	r->fld_next = INFINITY;
	if (s->fields_exposure <= 0.0)
		return;   /* the curves' instant alone */
	for (; r->fld_k <= s->fields_samples; r->fld_k++) {
		double ti = r->fld_end - s->fields_exposure + r->fld_k * s->fields_exposure / s->fields_samples;
		if (ti > t) {
			r->fld_next = ti;
			return;
		}
	}
}

/* A new exposure after curves at time t: it ends at the next snapshot time or the run's end time. */
static double sched_time(const scene_when_t *w, uint64_t k);
static void fields_plan(run_t *r, double t)
{
	const scene_t *s = &r->s;
	if (!r->fld)
		return;
	double end = sched_time(&s->snapshots, r->st.k_snap);
	if (s->until.kind == SCENE_CLOCK_TIME)
		end = fmin(end, s->until.value);
	r->fld_end = end;
	r->fld_k = 1;
	fields_next(r, t);
}

/* After the engine reached time t: add it when it is the exposure's next instant (ed stops there exactly;
 * dsmc/hsmc at the end of the step that reaches it: instants passed in one step count once). */
static void fields_follow(run_t *r, double t)
{
	if (!r->fld || t < r->fld_next)
		return;
	fields_sample(r, t, 0);
	fields_next(r, t);
}

/* ---- density_spectrum (output.density_spectrum) ---------------------------- */

/* After the engine reached time t: one sample of the slice counts when the next sampling time has come
 * (ed stops there exactly; dsmc/hsmc at the end of the step that reaches it: instants passed in one step
 * count once). */
static void dspec_follow(run_t *r, double t)
{
	const double dt = r->s.dspec_interval;
	if (!r->dsp || t < r->dsp_k * dt)
		return;
	obs_dspec_add(r->obs, eng_present(r, r->pos, NULL, NULL), r->pos);
	while (r->dsp_k * dt <= t)
		r->dsp_k += 1.0;
}

/* Curves of the present state as a RUN_CURVES record (the dynamics are not touched). */
int run_curves(run_t *r, run_record_t *rec)
{
	if (!r->obs || !obs_curve_bits(&r->s))
		return RUN_EMETHOD;
	totals_record(r, rec, RUN_CURVES);
	rec->wall_seconds = wall_seconds(r);
	rec->have = r->s.observables;
	eng_state(r, r->pos, r->vel);
	if (r->fld && r->fld_last != rec->time)
		fields_sample(r, rec->time, 1);   /* the curves' instant itself (the last of its exposure) */
	const int spins = r->spin && (r->s.observables & SCENE_OBS_VDIST);   /* only velocity_distribution uses them */
	if (spins)
		ed_spins(r->ed, r->spin);
	/* the rows present (fields_sample() above took the slot rows as they are) */
	size_t np = r->varying ? obs_present(scene_slots(&r->s), r->s.dim, r->pos, r->vel, spins ? r->spin : NULL,
	                                     spins ? ed_spin_dim(r->ed) : 0) : r->s.count;
	rec->curves = obs_curves(r->obs, r->cl, np, r->pos, r->vel, spins ? r->spin : NULL);
	if (!rec->curves)
		return RUN_ENOMEM;
	rec->temperature = rec->curves->temperature;
	return RUN_OK;
}

static void sched_skip(const scene_when_t *w, uint64_t *k, double t, uint64_t c, uint64_t n);

size_t run_curves_packed_size(const run_t *r)
{
	return r->obs && obs_curve_bits(&r->s) ? obs_packed_size(r->obs) : 0;
}

int run_curves_pack(run_t *r, double *v)
{
	run_record_t rec;
	int ret = run_curves(r, &rec);
	if (ret == RUN_OK)
		obs_pack(r->obs, rec.curves, v);
	return ret;
}

void run_snap_taken(run_t *r)
{
	smp_t sm;
	eng_totals(r, &sm);
	r->st.snap_events = sm.events;
	sched_skip(&r->s.snapshots, &r->st.k_snap, sm.time, sm.collisions, r->s.count);
	fields_plan(r, sm.time);   /* the next exposure ends at the next snapshot time */
}

static int curves_on(const run_t *r)
{
	return r->opts.curves && r->obs && obs_curve_bits(&r->s);
}

/* Sample into r->rec; the first record carries the dsmc/hsmc warning. */
static int sample_progress(run_t *r)
{
	int first = !r->st.started;
	int ret = sample(r, &r->rec, RUN_PROGRESS);
	if (ret == RUN_OK && first && r->warning[0])
		r->rec.warning = r->warning;
	if (ret == RUN_OK && (r->status == RUN_COLLAPSED || r->status == RUN_FULL))
		r->rec.warning = r->collapse;
	return ret;
}

static int emit_progress(run_t *r, run_emit_fn emit, void *ctx)
{
	int ret = sample_progress(r);
	if (ret == RUN_OK && emit(&r->rec, ctx))
		ret = RUN_EMIT;
	r->rec.warning = NULL;
	return ret;
}

/* A snapshot of the present state (the dynamics are not touched). */
static int emit_snapshot(run_t *r, run_emit_fn emit, void *ctx)
{
	smp_t sm;
	run_record_t rec;
	eng_totals(r, &sm);
	memset(&rec, 0, sizeof(rec));
	rec.kind = RUN_SNAPSHOT;
	rec.dim = r->s.dim;
	rec.n = scene_slots(&r->s);
	rec.time = sm.time;
	rec.events = sm.events;
	rec.collisions = sm.collisions;
	rec.collisions_per_particle = 2.0 * (double)sm.collisions / (double)r->s.count;
	rec.wall_seconds = wall_seconds(r);
	rec.kinetic_energy = sm.kinetic_energy;
	eng_state(r, r->pos, r->vel);
	rec.pos = r->pos;
	rec.vel = r->vel;
	if (r->ids && ed_labels(r->ed, r->ids) == ED_OK)
		rec.ids = r->ids;
	if (r->spin) {
		ed_spins(r->ed, r->spin);
		rec.spin = r->spin;
		rec.spin_dim = ed_spin_dim(r->ed);
	}
	r->st.snap_events = sm.events;
	return emit(&rec, ctx) ? RUN_EMIT : RUN_OK;
}

/* The snapshot schedule's records: the frame (opts.snapshots), then the curves (opts.curves). */
static int emit_structure(run_t *r, run_emit_fn emit, void *ctx)
{
	int ret = RUN_OK;
	if (r->opts.snapshots && (ret = emit_snapshot(r, emit, ctx)) != RUN_OK)
		return ret;
	if (curves_on(r)) {
		run_record_t rec;
		if ((ret = run_curves(r, &rec)) != RUN_OK)
			return ret;
		r->st.snap_events = rec.events;
		if (emit(&rec, ctx))
			return RUN_EMIT;
	}
	return RUN_OK;
}

/* ---- life cycle ------------------------------------------------------------ */

/* md: the particles placed as ed places them (scene_md_placement(): no overlap, off the walls), velocities
 * Maxwellian at particles.initial.temperature from the seed and the replica's stream (the total momentum
 * removed when no wall or gravity takes it up), spins 0, and the core with the scene's md settings. */
static int md_build(run_t *r, uint64_t stream, int blank, char *msg, size_t msglen)
{
	const scene_t *s = &r->s;
	const size_t n = s->count;
	int ret = -1, e = 0;
	double *pos = malloc(n * s->dim * sizeof(double)), *x = calloc(n * 3, sizeof(double));
	double *v = calloc(n * 3, sizeof(double));
	int *sp = NULL;
	double epair[SCENE_SPECIES_MAX * SCENE_SPECIES_MAX];
	int pairwise = 0;   /* collisions.restitution_pairs with a pair other than collisions.restitution */
	for (int a = 0; a < s->n_species; a++)
		for (int b = 0; b < s->n_species; b++) {
			epair[a * s->n_species + b] = s->restitution_pair[a][b];
			pairwise |= s->n_species > 1 && s->restitution_pair[a][b] != s->restitution;
		}
	if (pairwise && !(sp = malloc(n * sizeof(int)))) {
		if (msg && msglen)
			snprintf(msg, msglen, "out of memory");
		goto cleanup;
	}
	if (scene_has_species(s)) {
		r->md_radii = malloc(n * sizeof(double));
		r->md_masses = malloc(n * sizeof(double));
	}
	if (!pos || !x || !v || (scene_has_species(s) && (!r->md_radii || !r->md_masses))) {
		if (msg && msglen)
			snprintf(msg, msglen, "out of memory");
		goto cleanup;
	}
	if (blank) {   /* restoring: the state comes from the checkpoint (run_field_set(), run_restore_finish()) */
	} else if (s->init_pos) {
		memcpy(pos, s->init_pos, n * s->dim * sizeof(double));
	} else {
		scene_t p;
		scene_md_placement(s, &p);
		if (place_region(&p, stream, pos, msg, msglen) != PLACE_OK)
			goto cleanup;
	}
	rng_t rng;
	rng_init(&rng, s->seed, stream);
	if (r->md_radii) {   /* mixtures: each row's radius (scene_species_radii()) and its species' mass */
		scene_species_radii(s, r->md_radii);
		for (size_t i = 0, k = 0, end = s->species[0].count; i < n; i++) {
			while (i >= end)
				end += s->species[++k].count;
			r->md_masses[i] = s->species[k].mass;
			if (sp)
				sp[i] = (int)k;
		}
	}
	double mean[3] = {0, 0, 0}, msum = 0.0;
	for (size_t i = 0; i < n && !blank; i++) {
		const double m = r->md_masses ? r->md_masses[i] : s->mass, sd = sqrt(s->temperature / m);
		for (int a = 0; a < s->dim; a++) {
			x[i * 3 + a] = pos[i * s->dim + a];
			v[i * 3 + a] = sd * rng_gauss(&rng);
			/* one species: the mean velocity; mixtures: the centre of mass's (mass-weighted) */
			mean[a] += r->md_masses ? m * v[i * 3 + a] : v[i * 3 + a] / (double)n;
		}
		msum += m;
	}
	if (r->md_masses)
		for (int a = 0; a < s->dim; a++)
			mean[a] /= msum;
	if (!scene_has_walls(s))
		for (size_t i = 0; i < n; i++)
			for (int a = 0; a < s->dim; a++)
				v[i * 3 + a] -= mean[a];
	md_params_t pr = {
		.dim = s->dim, .n = (int)n, .radius = s->radius, .mass = s->mass, .radii = r->md_radii,
		.masses = r->md_masses,
		.law = s->md_law ? MD_LAW_HERTZ : MD_LAW_LINEAR, .restitution = s->restitution,
		.v_ref = s->md_impact_speed, .mu = s->md_friction, .kt_ratio = s->md_tangential_ratio,
		.mu_r = s->md_rolling, .n_species = pairwise ? s->n_species : 0, .species = sp, .restitution_pair = pairwise ? epair : NULL,
		.dt_steps = 1.0 / s->md_time_step, .x = NULL, .v = v, .virial = (s->observables & SCENE_OBS_PRESSURE) != 0,
	};
	for (int a = 0; a < 3; a++) {
		pr.box[a] = a < s->dim ? s->box[a] : 1.0;
		pr.periodic[a] = a < s->dim ? !s->boundary[a].walled : 1;
		pr.gravity[a] = a < s->dim ? s->gravity[a] : 0.0;
	}
	pr.n_obstacles = s->n_obstacles;   /* contact partners (check_md(): no type-specific keys) */
	for (int k = 0; k < s->n_obstacles; k++) {
		pr.obstacle_radius[k] = s->obstacle[k].radius;
		for (int a = 0; a < s->dim; a++)
			pr.obstacle_center[k][a] = s->obstacle[k].center[a];
	}
	for (int a = 0; a < s->dim; a++)   /* moving and vibrating walls (check_md() allows no other kind) */
		for (int k = 0; k < 2 && s->boundary[a].walled; k++) {
			const scene_wall_t *w = &s->boundary[a].wall[k];
			if (w->type == SCENE_WALL_MOVING)
				for (int b = 0; b < s->dim; b++)
					pr.wall_velocity[2 * a + k][b] = w->velocity[b];
			if (w->type == SCENE_WALL_VIBRATING) {
				pr.wall_amplitude[2 * a + k] = w->amplitude;
				pr.wall_frequency[2 * a + k] = w->frequency;
				pr.wall_phase[2 * a + k] = w->phase;
			}
		}
	if (s->md_law)
		pr.young = s->md_stiffness;
	else if (s->md_contact_time > 0)
		pr.t_contact = s->md_contact_time;
	else
		pr.kn = s->md_stiffness;
	/* dt: the contact time's fraction md_time_step, shortened so that run.until.time is a whole number of
	 * steps (progress records and frames come at the end of the step that reaches their time, as dsmc's) */
	md_t *probe = md_create(&pr, &e);   /* without positions: dt only */
	if (probe) {
		double k = ceil(s->until.value / md_dt(probe));
		md_destroy(probe);
		if (!(k < 9e15)) {
			if (msg && msglen)
				snprintf(msg, msglen, "run.until.time: %.3g steps of the md time step: too many", k);
			goto cleanup;
		}
		r->md_kend = (uint64_t)k;
		pr.dt = s->until.value / k;
		pr.x = blank ? NULL : x;
		r->md = md_create(&pr, &e);
	}
	if (!r->md) {
		if (msg && msglen)
			snprintf(msg, msglen, "md: %s", md_strerror(e));
		goto cleanup;
	}
	if (blank) {   /* the restore's buffers: the six 3N arrays and the springs held per particle */
		md_state_t *in = &r->md_in;
		in->x = malloc(18 * n * sizeof(double));
		in->held = malloc(n * sizeof(int32_t));
		if (!in->x || !in->held) {
			if (msg && msglen)
				snprintf(msg, msglen, "out of memory");
			goto cleanup;
		}
		in->v = in->x + 3 * n, in->w = in->v + 3 * n, in->f = in->w + 3 * n, in->t = in->f + 3 * n;
		in->xref = in->t + 3 * n;
	}
	ret = 0;
cleanup:
	free(pos);
	free(x);
	free(v);
	free(sp);
	return ret;
}

static run_t *create(const scene_t *s, uint64_t stream, const run_opts_t *opts, int blank,
                     int *err, char *msg, size_t msglen)
{
	run_t *r = NULL;
	int e = 0;

	r = calloc(1, sizeof(*r));
	if (!r)
		goto nomem;
	r->s = *s;
	r->varying = scene_has_open_walls(s);
	r->s.stream = stream;
	if (opts)
		r->opts = *opts;
	r->st = (run_state_t){.k_out = 1, .k_snap = 1, .k_ckpt = 1, .snap_events = UINT64_MAX};
	if (!blank && s->has_region && !s->init_pos && s->method != SCENE_METHOD_MD) {   /* md: md_build() places */
		/* placed here, per replica stream; the engines take the positions */
		r->placed = malloc(s->count * s->dim * sizeof(double));
		if (!r->placed)
			goto nomem;
		e = place_region(&r->s, stream, r->placed, msg, msglen);
		if (e != PLACE_OK) {
			*err = e == PLACE_ENOMEM ? RUN_ENOMEM : RUN_ESETUP;
			run_destroy(r);
			return NULL;
		}
		r->s.init_pos = r->placed;
	}
	if (s->method == SCENE_METHOD_MD) {
		if (md_build(r, stream, blank, msg, msglen) != 0) {
			*err = RUN_ESETUP;
			run_destroy(r);
			return NULL;
		}
		r->mc_chunk = RUN_CHUNK_MOVES / s->count + 1;
		if (s->md_time_step > RUN_MD_STEP_WARN)   /* the first record says so (docs/md.md, "The time step") */
			snprintf(r->warning, sizeof(r->warning), "md.time_step %.3g: dt = t_c/%.3g, fewer than %.0f steps per "
			         "contact (restitution and contact time err to first order in dt)", s->md_time_step,
			         1.0 / s->md_time_step, 1.0 / RUN_MD_STEP_WARN);
	} else if (s->method == SCENE_METHOD_ED) {
		r->ed = blank ? ed_create_blank(&r->s, &e, msg, msglen) : ed_create(&r->s, &e, msg, msglen);
		if (!r->ed) {
			*err = e == ED_ENOMEM ? RUN_ENOMEM : RUN_ESETUP;
			run_destroy(r);
			return NULL;
		}
		/* Enskog collision rate per particle at T = 1 (dsmc.h: kinetic theory) */
		double f1 = dsmc_collision_frequency(s->dim, s->volume_fraction, s->radius, s->mass, 1.0,
		                                     dsmc_contact_value(s->dim, s->volume_fraction));
		ed_watch_collapse(r->ed, RUN_COLLAPSE_FACTOR * f1);
	} else {
		dsmc_params_t pr;
		dsmc_params(&r->s, &pr, r->warning, sizeof(r->warning));
		r->mc = blank ? dsmc_create_blank(&r->s, &e, msg, msglen) : dsmc_create(&r->s, stream, &e, msg, msglen);
		if (!r->mc) {
			*err = e == DSMC_ENOMEM ? RUN_ENOMEM : RUN_ESETUP;
			run_destroy(r);
			return NULL;
		}
		r->mc_chunk = RUN_CHUNK_MOVES / s->count + 1;
	}
	if (obs_curve_bits(s)) {
		r->obs = obs_create(s, 0);
		if (!r->obs)
			goto nomem;
	}
	if (s->observables & SCENE_OBS_MSD) {
		/* ed stops exactly at the time asked for: 0.45 edges is strict; dsmc/hsmc stop at the end of the
		 * step that reaches it: a quarter edge leaves room for that step */
		r->msd = msd_create(s->dim, scene_slots(s), s->box, s->mass, r->ed ? 0.45 : 0.25);
		if (!r->msd)
			goto nomem;
		if (scene_msd_images(s))
			msd_exact(r->msd);
		/* open, reservoir or dispenser walls, a source: over the particles present at the origin and still
		 * there (observe/msd.h); ed's reservoir and dispenser slots take new particles: their labels */
		if (scene_has_open_walls(s) && msd_varying(r->msd, r->ed && scene_has_reservoir(s)) != 0)
			goto nomem;
		/* mixtures: the lightest particle bounds the speed, the heaviest the potential energy, the smallest
		 * the lowest contact plane */
		double rmin = s->radius;
		if (scene_has_species(s)) {
			double lo = INFINITY, hi = 0.0;
			rmin = INFINITY;
			for (int k = 0; k < s->n_species; k++) {
				lo = fmin(lo, s->species[k].mass);
				hi = fmax(hi, s->species[k].mass);
				rmin = fmin(rmin, s->species[k].radius_lo > 0 ? s->species[k].radius_lo : s->species[k].radius);
			}
			msd_masses(r->msd, lo, hi);
		}
		if (scene_has_walls(s) || scene_has_gravity(s)) {
			int walled[3];
			for (int a = 0; a < 3; a++)
				walled[a] = s->boundary[a].walled;
			if (msd_walls(r->msd, walled, s->gravity, rmin) != 0) {   /* scene_parse() refuses these */
				*err = RUN_ESETUP;
				if (msg && msglen)
					snprintf(msg, msglen, "mean_square_displacement: gravity along a periodic axis");
				run_destroy(r);
				return NULL;
			}
		}
	}
	if (r->obs) {
		/* impact parameters: the engine counts into the observables' histogram */
		int nb;
		double *bc = obs_impact_counts(r->obs, &nb);
		if (bc && r->ed)
			ed_count_impacts(r->ed, bc, nb);
		else if (bc)
			dsmc_count_impacts(r->mc, bc, nb);
	}
	if ((s->observables & (SCENE_OBS_CLUSTERS | SCENE_OBS_MSD | SCENE_OBS_FLUX)) || r->opts.snapshots || r->obs) {
		r->pos = malloc(scene_slots(s) * s->dim * sizeof(double));
		if (!r->pos)
			goto nomem;
	}
	if (s->observables & SCENE_OBS_CLUSTERS) {
		r->cl = clusters_create(s->dim, scene_slots(s));
		if (!r->cl)
			goto nomem;
		if (scene_has_species(s)) {   /* mixtures, polydisperse: each particle's own radius (the engine's draws) */
			r->radii = malloc(scene_slots(s) * sizeof(double));
			if (!r->radii)
				goto nomem;
			scene_row_species(&r->s, NULL, r->radii);   /* dispensers: the slots' radii too */
			if (clusters_radii(r->cl, r->radii) != 0)
				goto nomem;
		}
		int walled[3];
		for (int a = 0; a < 3; a++)
			walled[a] = s->boundary[a].walled;
		clusters_walls(r->cl, walled);
	}
	if (r->opts.snapshots || r->obs || (s->observables & SCENE_OBS_FLUX) ||
	    ((s->observables & SCENE_OBS_MSD) && scene_has_gravity(s))) {
		r->vel = malloc(scene_slots(s) * s->dim * sizeof(double));
		if (!r->vel)
			goto nomem;
	}
	if ((r->opts.snapshots || (s->observables & SCENE_OBS_MSD)) && r->ed && scene_has_reservoir(s)) {
		r->ids = malloc(scene_slots(s) * sizeof(int64_t));
		if (!r->ids)
			goto nomem;
	}
	r->fld = curves_on(r) && obs_fields(r->obs) != NULL;
	r->dsp = curves_on(r) && obs_dspec(r->obs) != NULL;
	r->dsp_k = 1.0;
	r->fld_next = INFINITY;
	r->fld_last = -INFINITY;
	if ((r->opts.snapshots || r->fld || (curves_on(r) && (s->observables & SCENE_OBS_VDIST))) && r->ed &&
	    ed_spin_dim(r->ed)) {
		r->spin = malloc(scene_slots(s) * ed_spin_dim(r->ed) * sizeof(double));   /* rows: slots */
		if (!r->spin)
			goto nomem;
	}
	r->status = RUN_COMPLETED;
	r->t0 = r->ckpt_wall = wall_now();
	*err = RUN_OK;
	return r;
nomem:
	run_destroy(r);
	if (msg && msglen)
		snprintf(msg, msglen, "out of memory");
	*err = RUN_ENOMEM;
	return NULL;
}

run_t *run_create(const scene_t *s, const run_opts_t *opts, int *err, char *msg, size_t msglen)
{
	return create(s, s->stream, opts, 0, err, msg, msglen);
}

run_t *run_create_blank(const scene_t *s, const run_opts_t *opts, int *err, char *msg, size_t msglen)
{
	return create(s, s->stream, opts, 1, err, msg, msglen);
}

run_t *run_open(const scene_t *s, uint64_t stream, int *err, char *msg, size_t msglen)
{
	/* curves: each replica samples the fields' exposures and the density spectrum itself (run_next());
	 * the ensemble takes and combines the curves at its output times (run_curves()) */
	const run_opts_t opts = {.curves = 1};
	return create(s, stream, &opts, 0, err, msg, msglen);
}

static void md_in_free(run_t *r)
{
	free(r->md_in.x);
	free(r->md_in.held);
	free(r->md_in.partner);
	free(r->md_in.xi);
	free(r->md_in.mr);
	memset(&r->md_in, 0, sizeof r->md_in);
}

/* md: the core's state from the fields read (md_state_set() checks it), the run's step count from it. */
static int md_restore(run_t *r, char *msg, size_t msglen);

int run_restore_finish(run_t *r, char *msg, size_t msglen)
{
	if (r->md) {
		if (md_restore(r, msg, msglen) != RUN_OK)
			return RUN_ERESTORE;
	} else if (r->ed ? ed_restore_finish(r->ed, msg, msglen) != ED_OK : dsmc_restore_finish(r->mc, msg, msglen) != DSMC_OK)
		return RUN_ERESTORE;
	r->t0 = r->ckpt_wall = wall_now();
	return RUN_OK;
}

void run_destroy(run_t *r)
{
	if (!r)
		return;
	free(r->extra);
	free(r->placed);
	clusters_destroy(r->cl);
	free(r->radii);
	obs_destroy(r->obs);
	msd_destroy(r->msd);
	free(r->pos);
	free(r->vel);
	free(r->ids);
	free(r->spin);
	ed_destroy(r->ed);
	dsmc_destroy(r->mc);
	md_destroy(r->md);
	free(r->md_radii);
	free(r->md_masses);
	md_in_free(r);
	free(r);
}

struct ed *run_ed(run_t *r) { return r->ed; }

const char *run_engine_name(const run_t *r) { return r->md ? "md" : r->ed ? "ed" : "dsmc"; }

/* Run-level state besides the engine's (checkpoints): the observables that
 * accumulate between samples. */
#define F_MSD "obs_msd"          /* msd state, then the previous record's MSD and time */
#define F_IMPACT "obs_impact"    /* impact-parameter counts since the last curves */
#define F_FIELDS "obs_fields"    /* fields: the exposure's sums (fields.h), then fld_k, fld_end, fld_next, fld_last */
#define FLD_EXTRA 4
#define F_DSPEC "obs_density_spectrum" /* density_spectrum: the ring (dspec.h), then dsp_k */

static size_t impact_count(const run_t *r)
{
	int nb = 0;
	if (r->obs)
		obs_impact_counts(r->obs, &nb);
	return (size_t)nb;
}

/* md's state fields (md.h, md_state_t), in the order a restore reads them: "springs_held" before the
 * springs, whose count is its sum. */
enum { MDF_X, MDF_V, MDF_W, MDF_F, MDF_T, MDF_XREF, MDF_HELD, MDF_PARTNER, MDF_XI, MDF_WALLS, MDF_COUNTERS, MDF_VIRIAL,
       MDF_OBST, MDF_ROLL, MDF_N };
static const struct {
	const char *name;
	ed_type_t type;
} md_fields[MDF_N] = {
	[MDF_X] = {"positions", ED_T_F64}, [MDF_V] = {"velocities", ED_T_F64}, [MDF_W] = {"spins", ED_T_F64},
	[MDF_F] = {"forces", ED_T_F64}, [MDF_T] = {"torques", ED_T_F64}, [MDF_XREF] = {"verlet_reference", ED_T_F64},
	[MDF_HELD] = {"springs_held", ED_T_I32}, [MDF_PARTNER] = {"spring_partner", ED_T_I32},
	[MDF_XI] = {"spring", ED_T_F64}, [MDF_WALLS] = {"walls", ED_T_F64},   /* wall_force, then wall_impulse */
	[MDF_COUNTERS] = {"counters", ED_T_U64},   /* steps, rebuilds, contacts, wall_steps */
	[MDF_VIRIAL] = {"virial", ED_T_F64},       /* md_state_t.virial: only with pressure or compressibility */
	[MDF_OBST] = {"obstacles", ED_T_F64},      /* obstacle_force, then obstacle_impulse (n rows each): only with
	                                            * obstacles */
	[MDF_ROLL] = {"rolling_spring", ED_T_F64}, /* md_state_t.mr, one per spring: only with md.rolling_friction */
};

/* The md fields a run has: "virial" only when it integrates the pressure (the layout of other scenes as
 * before). */
static int md_has_field(const run_t *r, int k)
{
	return k == MDF_VIRIAL ? (r->s.observables & SCENE_OBS_PRESSURE) != 0 : k == MDF_OBST ? r->s.n_obstacles > 0 :
	       k == MDF_ROLL ? r->s.md_rolling > 0 : 1;
}

static size_t md_field_count(const run_t *r, int k, size_t springs)
{
	size_t n = r->s.count;
	return k <= MDF_XREF ? 3 * n : k == MDF_HELD ? n : k == MDF_PARTNER ? springs :
	       k == MDF_XI || k == MDF_ROLL ? 3 * springs :
	       k == MDF_WALLS ? 36 : k == MDF_OBST ? 6 * (size_t)r->s.n_obstacles : 4;   /* counters, virial */
}

static int md_field_find(const char *name)
{
	for (int k = 0; k < MDF_N; k++)
		if (!strcmp(name, md_fields[k].name))
			return k;   /* a field the run does not have: md_field_set() refuses it */
	return -1;
}

static int md_field_get(const run_t *r, const char *name, void *buf)
{
	int k = md_field_find(name);
	md_state_t st = {0};
	switch (k) {
	case MDF_X: st.x = buf; break;
	case MDF_V: st.v = buf; break;
	case MDF_W: st.w = buf; break;
	case MDF_F: st.f = buf; break;
	case MDF_T: st.t = buf; break;
	case MDF_XREF: st.xref = buf; break;
	case MDF_HELD: st.held = buf; break;
	case MDF_PARTNER: st.partner = buf; break;
	case MDF_XI: st.xi = buf; break;
	case MDF_ROLL: st.mr = buf; break;
	case MDF_WALLS: case MDF_COUNTERS: case MDF_VIRIAL: case MDF_OBST: break;
	default: return RUN_ERESTORE;
	}
	if (!md_has_field(r, k))
		return RUN_ERESTORE;
	md_state_get(r->md, &st);
	if (k == MDF_VIRIAL)
		memcpy(buf, st.virial, sizeof st.virial);
	if (k == MDF_OBST) {
		const size_t nb = 3 * (size_t)r->s.n_obstacles * sizeof(double);
		memcpy(buf, st.obstacle_force, nb);
		memcpy((char *)buf + nb, st.obstacle_impulse, nb);
	}
	if (k == MDF_COUNTERS)
		memcpy(buf, (uint64_t[4]){st.steps, st.rebuilds, st.contacts, st.wall_steps}, 4 * sizeof(uint64_t));
	if (k == MDF_WALLS) {
		memcpy(buf, st.wall_force, sizeof st.wall_force);
		memcpy((double *)buf + 18, st.wall_impulse, sizeof st.wall_impulse);
	}
	return RUN_OK;
}

static int md_field_set(run_t *r, const char *name, ed_type_t type, size_t count, const void *buf)
{
	int k = md_field_find(name);
	md_state_t *in = &r->md_in;
	if (k < 0 || !md_has_field(r, k) || !in->held || type != md_fields[k].type || (r->md_got >> k & 1u))
		return RUN_ERESTORE;
	if (k == MDF_PARTNER || k == MDF_XI || k == MDF_ROLL) {   /* after springs_held, whose sum they must match */
		if (!(r->md_got >> MDF_HELD & 1u) || count != md_field_count(r, k, in->springs))
			return RUN_ERESTORE;
		void *p = malloc(count ? count * ed_type_size(type) : 1);
		if (!p)
			return RUN_ERESTORE;
		memcpy(p, buf, count * ed_type_size(type));
		if (k == MDF_PARTNER)
			in->partner = p;
		else if (k == MDF_XI)
			in->xi = p;
		else
			in->mr = p;
	} else {
		if (count != md_field_count(r, k, 0))
			return RUN_ERESTORE;
		double *dst[MDF_XREF + 1] = {in->x, in->v, in->w, in->f, in->t, in->xref};
		if (k <= MDF_XREF)
			memcpy(dst[k], buf, count * sizeof(double));
		else if (k == MDF_HELD) {
			memcpy(in->held, buf, count * sizeof(int32_t));
			in->springs = 0;
			for (size_t i = 0; i < count; i++) {
				if (in->held[i] < 0)
					return RUN_ERESTORE;
				in->springs += (size_t)in->held[i];
			}
		} else if (k == MDF_WALLS) {
			memcpy(in->wall_force, buf, sizeof in->wall_force);
			memcpy(in->wall_impulse, (const double *)buf + 18, sizeof in->wall_impulse);
		} else if (k == MDF_VIRIAL) {
			memcpy(in->virial, buf, sizeof in->virial);
		} else if (k == MDF_OBST) {
			const size_t nb = 3 * (size_t)r->s.n_obstacles * sizeof(double);
			memcpy(in->obstacle_force, buf, nb);
			memcpy(in->obstacle_impulse, (const char *)buf + nb, nb);
		} else {
			const uint64_t *c = buf;
			in->steps = c[0], in->rebuilds = c[1], in->contacts = c[2], in->wall_steps = c[3];
		}
	}
	r->md_got |= 1u << k;
	return RUN_OK;
}

static int md_restore(run_t *r, char *msg, size_t msglen)
{
	int ret = RUN_ERESTORE;
	unsigned want = 0;
	for (int k = 0; k < MDF_N; k++)
		want |= md_has_field(r, k) ? 1u << k : 0u;
	if (r->md_got != want) {
		snprintf(msg, msglen, "md state fields missing");
		goto cleanup;
	}
	if (r->md_in.steps > r->md_kend) {
		snprintf(msg, msglen, "md step count beyond run.until");
		goto cleanup;
	}
	int e = md_state_set(r->md, &r->md_in);
	if (e != MD_OK) {
		snprintf(msg, msglen, "md state: %s", e == MD_E_NOMEM ? md_strerror(e) : "inconsistent (md_state_set())");
		goto cleanup;
	}
	r->md_steps = r->md_in.steps;
	ret = RUN_OK;
cleanup:
	md_in_free(r);
	return ret;
}

int run_fields(const run_t *r, ed_field_t *out, int max)
{
	int n = 0;
	if (r->md) {
		size_t springs = md_springs(r->md);
		for (int k = 0; k < MDF_N; k++)
			if (md_has_field(r, k) && n++ < max)
				out[n - 1] = (ed_field_t){md_fields[k].name, md_fields[k].type, md_field_count(r, k, springs)};
	} else
		n = r->ed ? ed_fields(r->ed, out, max) : dsmc_fields(r->mc, out, max);
	if (r->msd && n++ < max)
		out[n - 1] = (ed_field_t){F_MSD, ED_T_F64, msd_state_size(r->msd) + 2};
	if (impact_count(r) && n++ < max)
		out[n - 1] = (ed_field_t){F_IMPACT, ED_T_F64, impact_count(r)};
	if (r->fld && n++ < max)
		out[n - 1] = (ed_field_t){F_FIELDS, ED_T_F64, fields_state_size(obs_fields(r->obs)) + FLD_EXTRA};
	if (r->dsp && n++ < max)
		out[n - 1] = (ed_field_t){F_DSPEC, ED_T_F64, dspec_state_size(obs_dspec(r->obs)) + 1};
	return n;
}

int run_field_get(const run_t *r, const char *name, void *buf)
{
	if (r->msd && !strcmp(name, F_MSD)) {
		double *v = buf;
		size_t k = msd_state_size(r->msd);
		msd_state_get(r->msd, v);
		v[k] = r->msd_prev;
		v[k + 1] = r->msd_tprev;
		return RUN_OK;
	}
	if (impact_count(r) && !strcmp(name, F_IMPACT)) {
		int nb;
		memcpy(buf, obs_impact_counts(r->obs, &nb), impact_count(r) * sizeof(double));
		return RUN_OK;
	}
	if (r->fld && !strcmp(name, F_FIELDS)) {
		double *v = buf;
		size_t k = fields_state_size(obs_fields(r->obs));
		fields_state_get(obs_fields(r->obs), v);
		v[k] = r->fld_k, v[k + 1] = r->fld_end, v[k + 2] = r->fld_next, v[k + 3] = r->fld_last;
		return RUN_OK;
	}
	if (r->dsp && !strcmp(name, F_DSPEC)) {
		double *v = buf;
		size_t k = dspec_state_size(obs_dspec(r->obs));
		dspec_state_get(obs_dspec(r->obs), v);
		v[k] = r->dsp_k;
		return RUN_OK;
	}
	if (r->md)
		return md_field_get(r, name, buf);
	int rc = r->ed ? ed_field_get(r->ed, name, buf) : dsmc_field_get(r->mc, name, buf);
	return rc == 0 ? RUN_OK : RUN_ERESTORE;
}

int run_field_set(run_t *r, const char *name, ed_type_t type, size_t count, const void *buf)
{
	if (r->msd && !strcmp(name, F_MSD)) {
		const double *v = buf;
		size_t k = msd_state_size(r->msd);
		if (type != ED_T_F64 || count != k + 2 || msd_state_set(r->msd, v) != 0)
			return RUN_ERESTORE;
		r->msd_prev = v[k];
		r->msd_tprev = v[k + 1];
		return RUN_OK;
	}
	if (impact_count(r) && !strcmp(name, F_IMPACT)) {
		int nb;
		const double *v = buf;
		if (type != ED_T_F64 || count != impact_count(r))
			return RUN_ERESTORE;
		double *bc = obs_impact_counts(r->obs, &nb);
		for (int k = 0; k < nb; k++) {
			if (!(v[k] >= 0.0))
				return RUN_ERESTORE;
			bc[k] = v[k];
		}
		return RUN_OK;
	}
	if (r->fld && !strcmp(name, F_FIELDS)) {
		const double *v = buf;
		size_t k = fields_state_size(obs_fields(r->obs));
		if (type != ED_T_F64 || count != k + FLD_EXTRA || fields_state_set(obs_fields(r->obs), v) != 0 ||
		    !(v[k] >= 1) || v[k] != floor(v[k]) || isnan(v[k + 1]) || isnan(v[k + 2]) || isnan(v[k + 3]))
			return RUN_ERESTORE;
		r->fld_k = v[k], r->fld_end = v[k + 1], r->fld_next = v[k + 2], r->fld_last = v[k + 3];
		return RUN_OK;
	}
	if (r->dsp && !strcmp(name, F_DSPEC)) {
		const double *v = buf;
		size_t k = dspec_state_size(obs_dspec(r->obs));
		if (type != ED_T_F64 || count != k + 1 || dspec_state_set(obs_dspec(r->obs), v) != 0 || !(v[k] >= 1) ||
		    v[k] != floor(v[k]))
			return RUN_ERESTORE;
		r->dsp_k = v[k];
		return RUN_OK;
	}
	if (r->md)
		return md_field_set(r, name, type, count, buf);
	int rc = r->ed ? ed_field_set(r->ed, name, type, count, buf) : dsmc_field_set(r->mc, name, type, count, buf);
	return rc == 0 ? RUN_OK : RUN_ERESTORE;
}

void run_totals(const run_t *r, double *time, uint64_t *events, uint64_t *collisions)
{
	smp_t sm;
	eng_totals(r, &sm);
	*time = sm.time;
	*events = sm.events;
	*collisions = sm.collisions;
}
void run_get_state(const run_t *r, run_state_t *st)
{
	*st = r->st;
	st->wall_before = wall_seconds(r);
}
void run_set_state(run_t *r, const run_state_t *st) { r->st = *st; }
const run_record_t *run_last(const run_t *r) { return &r->rec; }
void run_get_finish(const run_t *r, int *done, run_status_t *status)
{
	*done = r->done;
	*status = r->status;
}
void run_set_finish(run_t *r, const run_record_t *last, int done, run_status_t status)
{
	r->rec = *last;
	r->rec.warning = NULL;
	r->done = done;
	r->status = status;
}

/* ---- schedules ------------------------------------------------------------- */

/* Index k of a schedule of kind/value: its time, or its collision target. */
static double sched_time(const scene_when_t *w, uint64_t k)
{
	return w->kind == SCENE_CLOCK_TIME ? (double)k * w->value : INFINITY;
}

static uint64_t sched_coll(const scene_when_t *w, uint64_t k, uint64_t n)
{
	return w->kind == SCENE_CLOCK_CPP ? cpp_to_collisions((double)k * w->value, n) : UINT64_MAX;
}

/* First index whose time / target lies beyond the present. */
static void sched_skip(const scene_when_t *w, uint64_t *k, double t, uint64_t c, uint64_t n)
{
	if (w->kind == SCENE_CLOCK_TIME)
		while ((double)*k * w->value <= t)
			(*k)++;
	else if (w->kind == SCENE_CLOCK_CPP)
		while (cpp_to_collisions((double)*k * w->value, n) <= c)
			(*k)++;
}

/* ---- summaries ------------------------------------------------------------- */

void run_summary_record(run_t *r, run_record_t *sum)
{
	*sum = r->rec;
	if (r->status == RUN_INTERRUPTED && r->opts.checkpoints) {
		/* stopped for a checkpoint: totals now, without sampling */
		smp_t sm;
		eng_totals(r, &sm);
		sum->time = sm.time;
		sum->events = sm.events;
		sum->collisions = sm.collisions;
		sum->collisions_per_particle = 2.0 * (double)sm.collisions / (double)r->s.count;
		sum->kinetic_energy = sm.kinetic_energy;
		sum->temperature = 2.0 * sm.kinetic_energy / (r->s.dim * (double)r->s.count);
		memcpy(sum->momentum, sm.momentum, sizeof(sum->momentum));
		sum->elastic_by_tc = sm.elastic_by_tc;
		sum->vmax_raised = sm.vmax_raised;
		sum->cell_collisions = sm.cell_collisions;
		sum->rejected_moves = sm.rejected_moves;
	}
	sum->kind = RUN_SUMMARY;
	sum->dim = r->s.dim;
	sum->n = r->s.count;
	sum->have = r->s.observables;
	sum->have_interval = 0;
	sum->warning = r->status == RUN_COLLAPSED || r->status == RUN_FULL ? r->collapse : NULL;
	sum->status = r->status;
	sum->wall_seconds = wall_seconds(r);
	sum->events_per_second = sum->wall_seconds > 0 ? sum->events / sum->wall_seconds : 0.0;
	sum->collisions_per_second = sum->wall_seconds > 0 ? sum->collisions / sum->wall_seconds : 0.0;
	if (r->md) {
		sum->memory_bytes = md_memory(r->md);
	} else if (r->ed) {
		sum->memory_bytes = ed_memory(r->ed);
		ed_cells(r->ed, sum->cells);
	} else {
		sum->memory_bytes = dsmc_memory(r->mc);
		dsmc_cells(r->mc, sum->cells);
	}
	if (r->obs)
		sum->memory_bytes += obs_memory(r->obs);
}

int run_summary(run_t *r, run_emit_fn emit, void *ctx)
{
	run_record_t sum;
	run_summary_record(r, &sum);
	return emit(&sum, ctx) ? RUN_EMIT : RUN_OK;
}

/* ---- driving ------------------------------------------------------------- */

/* The run ends in an inelastic collapse: status and the message of its last
 * records, stderr and the job (it names collisions.tc, the remedy). */
static void note_collapse(run_t *r)
{
	const ed_collapse_t *c = ed_collapse(r->ed);
	const scene_t *s = &r->s;
	double f = dsmc_collision_frequency(s->dim, s->volume_fraction, s->radius, s->mass, c->temperature,
	                                    dsmc_contact_value(s->dim, s->volume_fraction));
	double rate = c->interval > 0.0 ? 2.0 * (double)c->events / ((double)s->count * c->interval) : INFINITY;
	int len = snprintf(r->collapse, sizeof(r->collapse),
	                   "collisions.tc: inelastic collapse at time %.9g: %llu events in %.3g time units, "
	                   "%.3g per particle per unit time, %.3g times the Enskog collision rate at T = %.3g; ",
	                   c->time, (unsigned long long)c->events, c->interval, rate, f > 0.0 ? rate / f : INFINITY,
	                   c->temperature);
	if (len > 0 && (size_t)len < sizeof(r->collapse) && s->tc > 0.0)
		snprintf(r->collapse + len, sizeof(r->collapse) - (size_t)len,
		         "tc = %.3g is too short to prevent it: make it longer (docs/engine.md)", s->tc);
	else if (len > 0 && (size_t)len < sizeof(r->collapse))
		snprintf(r->collapse + len, sizeof(r->collapse) - (size_t)len,
		         "set collisions.tc > 0 (the TC model, docs/engine.md)");
	r->status = RUN_COLLAPSED;
}

/* Advance the engine towards (t_stop, c_stop); *t and *c get the clock
 * reached. Returns 1 when the run's stop condition is met, or can never be
 * (a quiescent system short of a collision target: status set to quiescent). */
static int advance(run_t *r, double t_stop, double t_soft, uint64_t c_stop, int until_time, double t_until,
                   uint64_t c_until, double *t, uint64_t *c)
{
	/* mean_square_displacement: the engine stops for an unwrapping update by msd_due() (a soft stop:
	 * the dynamics do not change) */
	double t_msd = r->msd ? msd_due(r->msd) : INFINITY;
	int adv = eng_advance(r, t_stop, fmin(t_soft, t_msd), c_stop);
	*t = eng_time(r);
	if (r->msd && *t >= t_msd)
		msd_follow(r);
	*c = eng_collisions(r);
	int done = (until_time && *t >= t_until) || (!until_time && *c >= c_until);
	if (adv == 1 && !done && !until_time) {
		r->status = RUN_QUIESCENT;   /* the collision target can never be reached */
		done = 1;
	}
	if (adv == 2) {
		note_collapse(r);
		done = 1;
	}
	if (adv == 4) {   /* md: the core stopped (md_strerror()) */
		snprintf(r->collapse, sizeof(r->collapse), "md: the run stopped at time %.9g: %s", *t,
		         md_strerror(r->md_err));
		r->status = RUN_COLLAPSED;
		done = 1;
	}
	if (adv == 3 && scene_has_species(&r->s)) {   /* a mixture's dispenser or reservoir: one species' rows are taken */
		snprintf(r->collapse, sizeof(r->collapse), "particles.capacity: the %llu particle slots cannot take a "
		         "dispenser's layer or a reservoir's entry at time %.9g (the free rows of some species, which keep "
		         "their species, are fewer than a layer may hold of it, or none is left for the entering particle's "
		         "species); raise particles.capacity", (unsigned long long)scene_slots(&r->s),
		         *t);
		r->status = RUN_FULL;
		done = 1;
	} else if (adv == 3) {   /* reservoir walls: no free slot for an entry */
		snprintf(r->collapse, sizeof(r->collapse), "particles.capacity: all %llu particle slots are taken at time "
		         "%.9g when a particle was due to enter through a reservoir wall; raise particles.capacity",
		         (unsigned long long)scene_slots(&r->s), *t);
		r->status = RUN_FULL;
		done = 1;
	}
	return done;
}

int run_go(run_t *r, run_emit_fn emit, void *ctx, const volatile sig_atomic_t *stop,
           char *msg, size_t msglen)
{
	const scene_t *s = &r->s;
	const uint64_t n = s->count;
	int ret = RUN_OK;

	/* Stop and checkpoint schedules: each is a time or a collision count. */
	const int until_time = s->until.kind == SCENE_CLOCK_TIME;
	const double t_until = until_time ? s->until.value : INFINITY;
	const uint64_t c_until = until_time ? UINT64_MAX : cpp_to_collisions(s->until.value, n);
	const scene_when_t none = {SCENE_CLOCK_NONE, 0.0};
	const int structure = r->opts.snapshots || curves_on(r);   /* frames or curves on the snapshot schedule */
	const scene_when_t *snaps = structure ? &s->snapshots : &none;
	const int ckpt_time = r->opts.checkpoints && s->checkpoint.kind == SCENE_CLOCK_TIME;
	const int ckpt_wall = r->opts.checkpoints && s->checkpoint.kind == SCENE_CLOCK_WALL;

	r->status = RUN_COMPLETED;
	if (!r->st.started) {
		if ((ret = emit_progress(r, emit, ctx)) != RUN_OK)
			goto cleanup;
		if (structure && (ret = emit_structure(r, emit, ctx)) != RUN_OK)
			goto cleanup;
		fields_plan(r, eng_time(r));
		r->st.started = 1;
	}
	for (;;) {
		double t_stop = fmin(sched_time(&s->every, r->st.k_out), t_until);
		double t_soft = sched_time(snaps, r->st.k_snap);
		uint64_t c_stop = sched_coll(&s->every, r->st.k_out, n);
		if (c_until < c_stop) c_stop = c_until;
		if (sched_coll(snaps, r->st.k_snap, n) < c_stop) c_stop = sched_coll(snaps, r->st.k_snap, n);
		if (ckpt_time)
			t_soft = fmin(t_soft, sched_time(&s->checkpoint, r->st.k_ckpt));
		if (r->fld)
			t_soft = fmin(t_soft, r->fld_next);
		if (r->dsp)
			t_soft = fmin(t_soft, r->dsp_k * s->dspec_interval);

		double t;
		uint64_t c;
		int done = advance(r, t_stop, t_soft, c_stop, until_time, t_until, c_until, &t, &c);
		fields_follow(r, t);
		dspec_follow(r, t);
		int due = s->every.kind == SCENE_CLOCK_TIME ? t >= sched_time(&s->every, r->st.k_out)
		                                            : c >= sched_coll(&s->every, r->st.k_out, n);
		int due_snap = snaps->kind == SCENE_CLOCK_TIME ? t >= sched_time(snaps, r->st.k_snap)
		             : snaps->kind == SCENE_CLOCK_CPP ? c >= sched_coll(snaps, r->st.k_snap, n) : 0;
		if (stop && *stop && !done) {
			r->status = RUN_INTERRUPTED;
			if (r->opts.checkpoints)
				return RUN_STOPPED;   /* nothing sampled: the checkpoint continues exactly */
			done = 1;
		}
		if (due || done) {
			if ((ret = emit_progress(r, emit, ctx)) != RUN_OK)
				goto cleanup;
			/* Skip output times already passed (a long jump in a quiescent
			 * or very dilute system emits one record, not thousands). */
			sched_skip(&s->every, &r->st.k_out, t, c, n);
		}
		if (due_snap || (done && structure && r->st.snap_events != eng_events(r))) {
			if ((ret = emit_structure(r, emit, ctx)) != RUN_OK)
				goto cleanup;
			sched_skip(snaps, &r->st.k_snap, t, c, n);
			fields_plan(r, t);
		}
		if (done) {
			ret = run_summary(r, emit, ctx);
			if (ret == RUN_OK && (r->status == RUN_COLLAPSED || r->status == RUN_FULL)) {
				ret = RUN_ECOLLAPSE;
				if (msg && msglen)
					snprintf(msg, msglen, "%s", r->collapse);
			}
			return ret;
		}
		if (ckpt_time && t >= sched_time(&s->checkpoint, r->st.k_ckpt)) {
			sched_skip(&s->checkpoint, &r->st.k_ckpt, t, c, n);
			r->ckpt_wall = wall_now();
			return RUN_CHECKPOINT;
		}
		if (ckpt_wall && wall_now() - r->ckpt_wall >= s->checkpoint.value) {
			r->ckpt_wall = wall_now();
			return RUN_CHECKPOINT;
		}
	}
cleanup:
	if (ret == RUN_ENOMEM && msg && msglen)
		snprintf(msg, msglen, "out of memory");
	return ret;
}

int run_next(run_t *r, const volatile sig_atomic_t *stop, run_record_t *rec, int *done_out)
{
	const scene_t *s = &r->s;
	const uint64_t n = s->count;
	const int until_time = s->until.kind == SCENE_CLOCK_TIME;
	const double t_until = until_time ? s->until.value : INFINITY;
	const uint64_t c_until = until_time ? UINT64_MAX : cpp_to_collisions(s->until.value, n);
	int ret;

	*done_out = r->done;
	if (r->done) {
		*rec = r->rec;
		return RUN_OK;
	}
	if (!r->st.started) {
		r->status = RUN_COMPLETED;
		if ((ret = sample_progress(r)) != RUN_OK)
			return ret;
		fields_plan(r, eng_time(r));
		r->st.started = 1;
		*rec = r->rec;
		r->rec.warning = NULL;
		return RUN_OK;
	}
	for (;;) {
		double t_stop = fmin(sched_time(&s->every, r->st.k_out), t_until);
		uint64_t c_stop = sched_coll(&s->every, r->st.k_out, n);
		if (c_until < c_stop) c_stop = c_until;
		/* the fields' exposure instants and the density spectrum's samples, as in run_go() */
		double t_soft = INFINITY;
		if (r->fld)
			t_soft = fmin(t_soft, r->fld_next);
		if (r->dsp)
			t_soft = fmin(t_soft, r->dsp_k * s->dspec_interval);
		double t;
		uint64_t c;
		int done = advance(r, t_stop, t_soft, c_stop, until_time, t_until, c_until, &t, &c);
		fields_follow(r, t);
		dspec_follow(r, t);
		int due = s->every.kind == SCENE_CLOCK_TIME ? t >= sched_time(&s->every, r->st.k_out)
		                                            : c >= sched_coll(&s->every, r->st.k_out, n);
		if (stop && *stop && !done) {
			r->status = RUN_INTERRUPTED;
			done = 1;
		}
		if (due || done) {
			if ((ret = sample_progress(r)) != RUN_OK)
				return ret;
			sched_skip(&s->every, &r->st.k_out, t, c, n);
			r->done = done;
			*done_out = done;
			*rec = r->rec;
			return r->status == RUN_COLLAPSED || r->status == RUN_FULL ? RUN_ECOLLAPSE : RUN_OK;
		}
	}
}

/* Ensemble frames: the replica's own snapshot schedule judged at its output
 * records (run_next()), so a frame lands on the first output time at or
 * after each snapshot time or collision target. */
int run_frame_due(const run_t *r)
{
	const scene_t *s = &r->s;
	double t = eng_time(r);
	uint64_t c = eng_collisions(r), ev = eng_events(r);
	if (r->st.snap_events == UINT64_MAX)
		return 1;                      /* the initial state */
	if (r->done && r->st.snap_events != ev)
		return 1;                      /* the last state */
	if (s->snapshots.kind == SCENE_CLOCK_TIME)
		return t >= sched_time(&s->snapshots, r->st.k_snap);
	if (s->snapshots.kind == SCENE_CLOCK_CPP)
		return c >= sched_coll(&s->snapshots, r->st.k_snap, s->count);
	return 0;
}

void run_frame(run_t *r, run_record_t *rec, double *pos, double *vel, int64_t *ids)
{
	totals_record(r, rec, RUN_SNAPSHOT);
	rec->n = scene_slots(&r->s);
	eng_state(r, pos, vel);
	rec->pos = pos;
	rec->vel = vel;
	if (ids && r->ed && ed_labels(r->ed, ids) == ED_OK)
		rec->ids = ids;
	r->st.snap_events = rec->events;
	r->st.frames++;
	sched_skip(&r->s.snapshots, &r->st.k_snap, rec->time, rec->collisions, r->s.count);
	fields_plan(r, rec->time);   /* the next exposure ends at the next snapshot time */
}

int run_scene(const scene_t *s, run_emit_fn emit, void *ctx,
              const volatile sig_atomic_t *stop, char *msg, size_t msglen)
{
	int err = 0;
	run_t *r = run_create(s, NULL, &err, msg, msglen);
	if (!r)
		return err;
	int ret = run_go(r, emit, ctx, stop, msg, msglen);
	run_destroy(r);
	return ret;
}

const char *run_status_name(run_status_t st)
{
	static const char *const names[] = {
		[RUN_COMPLETED] = "completed",
		[RUN_QUIESCENT] = "quiescent",
		[RUN_INTERRUPTED] = "interrupted",
		[RUN_COLLAPSED] = "collapsed",
		[RUN_FULL] = "full",
	};
	return (unsigned)st < sizeof(names) / sizeof(names[0]) ? names[st] : "unknown";
}

int run_extra_set(run_t *r, const void *buf, size_t len)
{
	unsigned char *x = malloc(len ? len : 1);
	if (!x)
		return RUN_ENOMEM;
	if (len)
		memcpy(x, buf, len);
	free(r->extra);
	r->extra = x;
	r->extra_len = len;
	return RUN_OK;
}

const void *run_extra(const run_t *r, size_t *len)
{
	*len = r->extra ? r->extra_len : 0;
	return r->extra;
}
