/* One ed system over all MPI ranks (the parallel core par/ped.h): set-up from rank 0's initial state, the output schedule, records reduced over the ranks, frames gathered to rank 0. */
#include <limits.h>
#include <math.h>
#include <mpi.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "edrun.h"
#include "mc/dsmc.h"
#include "par/ped.h"
#include "par/pedmpi.h"

/* What the records need of the core, reduced. */
typedef struct {
	uint64_t collisions, tc_elastic, events;
	double ekin, mom[3], virial, eint_part;   /* eint_part: sum (dekin (t - tref) - dekin_t) */
} sums_t;

/* The run's state besides the core. */
typedef struct {
	const scene_t *s;
	ped_t *pd;
	int rank, size;
	double t;                   /* time reached (every event before it done) */
	double t_mark, ekin_mark;   /* the last progress record's time and kinetic energy */
	uint64_t coll_mark;
	double t0;                  /* MPI_Wtime() at the start of the production run */
	run_record_t last;          /* the last progress record (the summary's base) */
} er_t;

int edrun_check(const scene_t *s, int resumed, int out, char *msg, size_t msglen)
{
	const char *key = NULL, *why = NULL;
	const unsigned ok_obs = SCENE_OBS_ENERGY | SCENE_OBS_PRESSURE | SCENE_OBS_COLLISION_RATE | SCENE_OBS_MOMENTUM;
	char grid[160];
	if (s->method != SCENE_METHOD_ED)
		key = "method", why = "a split ed run needs method ed";
	else if (scene_has_gravity(s))
		key = "gravity", why = "gravity over several ranks is not supported yet";
	else if (scene_has_walls(s))
		key = "boundaries", why = "walls over several ranks are not supported yet (periodic box only)";
	else if (s->n_obstacles > 0)
		key = "obstacles", why = "obstacles over several ranks are not supported yet";
	else if (scene_has_species(s))
		key = "particles.species", why = "mixtures over several ranks are not supported yet";
	else if (s->rough)
		key = "collisions.rough", why = "rough particles over several ranks are not supported yet";
	else if (s->drive != SCENE_DRIVE_NONE)
		key = "driving", why = "driven systems over several ranks are not supported yet";
	else if (s->restitution < 1.0 && !(s->tc > 0.0))
		key = "collisions.tc", why = "an inelastic run over several ranks needs the TC model (tc > 0): an inelastic "
		                             "collapse is not detected there yet";
	else if (s->until.kind != SCENE_CLOCK_TIME)
		key = "run.until", why = "over several ranks only a time (collision counts are not reached in order there)";
	else if (s->every.kind != SCENE_CLOCK_TIME)
		key = "output.every", why = "over several ranks only a time";
	else if (out && s->snapshots.kind != SCENE_CLOCK_NONE && s->snapshots.kind != SCENE_CLOCK_TIME)
		key = "output.snapshots", why = "over several ranks only a time";
	else if (s->observables & ~ok_obs)
		key = "output.observables", why = "over several ranks only kinetic_energy, temperature, pressure, "
		                                  "compressibility, collision_rate and momentum (sums over the particles)";
	else if (s->count > UINT32_MAX || (double)s->count * s->dim > (double)INT_MAX / 2)
		key = "particles.count", why = "at most 2^30 / dimensions particles over several ranks";
	else if (out && s->checkpoint.kind != SCENE_CLOCK_NONE)
		key = "output.checkpoint", why = "checkpoints of a split ed run are not supported yet (leave it out)";
	else if (resumed)
		key = "--resume", why = "checkpoints of a split ed run are not supported yet";
	if (!key) {
		ped_params_t p = {.dim = s->dim, .sigma = 2.0 * s->radius};
		for (int a = 0; a < 3; a++)
			p.L[a] = a < s->dim ? s->box[a] : 1.0;
		ped_grid(&p, s->count);
		for (int a = 0; a < s->dim; a++)
			if (p.nc[a] < 3) {
				snprintf(grid, sizeof grid, "the split run needs at least 3 cells of one diameter along each axis; "
				         "this box has %d along axis %d", p.nc[a], a);
				key = "particles.count", why = grid;
				break;
			}
	}
	if (!key)
		return 0;
	if (msg && msglen)
		snprintf(msg, msglen, "%s: %s", key, why);
	return -1;
}

/* The core's totals of every rank, summed in rank order (the same bits on every rank, for every run at one rank count). */
static int reduce(er_t *E, sums_t *out)
{
	ped_totals_t tt;
	ped_totals(E->pd, &tt);
	double w[10];
	uint64_t u[3] = {tt.collisions, tt.tc_elastic, tt.events};
	w[0] = tt.ekin;
	for (int a = 0; a < 3; a++)
		w[1 + a] = tt.mom[a];
	w[4] = tt.virial;
	w[5] = tt.dekin * (E->t - E->t_mark) - tt.dekin_t;
	memcpy(&w[6], u, sizeof u);   /* 3 words of 8 bytes */
	double *all = malloc((size_t)E->size * sizeof w);
	int bad = all == NULL;
	MPI_Allreduce(MPI_IN_PLACE, &bad, 1, MPI_INT, MPI_MAX, MPI_COMM_WORLD);
	if (bad) {
		free(all);
		return RUN_ENOMEM;
	}
	MPI_Allgather(w, (int)sizeof w, MPI_BYTE, all, (int)sizeof w, MPI_BYTE, MPI_COMM_WORLD);
	memset(out, 0, sizeof *out);
	for (int r = 0; r < E->size; r++) {
		const double *x = &all[(size_t)r * 10];
		out->ekin += x[0];
		for (int a = 0; a < 3; a++)
			out->mom[a] += x[1 + a];
		out->virial += x[4];
		out->eint_part += x[5];
		memcpy(u, &x[6], sizeof u);
		out->collisions += u[0];
		out->tc_elastic += u[1];
		out->events += u[2];
	}
	free(all);
	return RUN_OK;
}

/* A progress record of the present state (collective), as run.c's sample()
 * for a periodic one-species ed scene; starts a new interval. */
static int progress(er_t *E, run_record_t *r)
{
	const scene_t *s = E->s;
	sums_t sm;
	int ret = reduce(E, &sm);
	if (ret != RUN_OK)
		return ret;
	const double N = (double)s->count, interval = E->t - E->t_mark;
	memset(r, 0, sizeof *r);
	r->kind = RUN_PROGRESS;
	r->dim = s->dim;
	r->n = s->count;
	r->time = E->t;
	r->events = sm.events;
	r->collisions = sm.collisions;
	r->collisions_per_particle = 2.0 * (double)sm.collisions / N;
	r->wall_seconds = MPI_Wtime() - E->t0;
	r->elastic_by_tc = sm.tc_elastic;
	r->have = s->observables;
	r->kinetic_energy = sm.ekin;
	r->particles = s->count;
	r->temperature = 2.0 * sm.ekin / (s->dim * N);
	for (int a = 0; a < 3; a++)
		r->momentum[a] = a < s->dim ? sm.mom[a] : 0.0;
	if (interval > 0.0) {
		/* the exact integral of E_kin dt (piecewise constant between collisions) */
		double eint = E->ekin_mark * interval + sm.eint_part;
		double t_avg = 2.0 * eint / (s->dim * N * interval);
		double vol = scene_box_volume(s);
		r->have_interval = 1;
		r->pressure = (N * t_avg + sm.virial / (s->dim * interval)) / vol;
		r->compressibility = t_avg > 0.0 ? r->pressure * vol / (N * t_avg) : NAN;
		r->collision_rate = 2.0 * (double)(sm.collisions - E->coll_mark) / (N * interval);
	}
	r->com_height = r->potential_energy = NAN;   /* no gravity (as ed_sample()) */
	r->obs.a2 = r->obs.a3 = r->obs.g_pairs = r->obs.g_pairs_se = r->obs.g_rate = r->obs.g_pressure = NAN;
	r->obs.msd = r->obs.msd_se = r->obs.diffusion = r->obs.msd_walled = NAN;
	r->obs.flux = r->obs.flux_se = NAN;
	ped_mark(E->pd, E->t);   /* right after a sync: pedmpi_advance() saved the state at E->t */
	E->t_mark = E->t;
	E->ekin_mark = sm.ekin;
	E->coll_mark = sm.collisions;
	E->last = *r;
	return RUN_OK;
}

/* Rank 0 emits; the outcome is shared (collective). */
static int emit_all(int rank, run_emit_fn emit, void *ctx, const run_record_t *r)
{
	int bad = rank == 0 && emit && emit(r, ctx) != 0;
	MPI_Bcast(&bad, 1, MPI_INT, 0, MPI_COMM_WORLD);
	return bad;
}

static int emit_progress(er_t *E, run_emit_fn emit, void *ctx)
{
	run_record_t r;
	int ret = progress(E, &r);
	if (ret == RUN_OK && emit_all(E->rank, emit, ctx, &r))
		ret = RUN_EMIT;
	return ret;
}

/* A frame: every rank's particles at E->t gathered to rank 0 (MPI_Gatherv),
 * put in particle order and emitted there (collective). */
static int emit_frame(er_t *E, run_emit_fn emit, void *ctx)
{
	const scene_t *s = E->s;
	const int D = s->dim, W = 2 * D + 1;
	const size_t N = (size_t)s->count;
	sums_t sm;
	int ret = reduce(E, &sm);
	if (ret != RUN_OK)
		return ret;
	ped_totals_t tt;
	ped_totals(E->pd, &tt);
	const size_t nl = (size_t)tt.owned;
	double *mine = malloc((nl + 1) * (size_t)W * sizeof(double));
	uint32_t *id = malloc((nl + 1) * sizeof(uint32_t));
	double *x = malloc((nl + 1) * (size_t)D * sizeof(double)), *v = malloc((nl + 1) * (size_t)D * sizeof(double));
	double *all = NULL, *pos = NULL, *vel = NULL;
	int *cnt = NULL, *dis = NULL;
	int bad = !mine || !id || !x || !v;
	if (E->rank == 0) {
		all = malloc((N + 1) * (size_t)W * sizeof(double));
		pos = malloc(N * (size_t)D * sizeof(double));
		vel = malloc(N * (size_t)D * sizeof(double));
		cnt = malloc((size_t)E->size * 2 * sizeof(int));
		bad = bad || !all || !pos || !vel || !cnt || N * (size_t)W > INT32_MAX;
		dis = cnt ? cnt + E->size : NULL;
	}
	MPI_Allreduce(MPI_IN_PLACE, &bad, 1, MPI_INT, MPI_MAX, MPI_COMM_WORLD);
	if (bad) {
		ret = RUN_ENOMEM;
		goto cleanup;
	}
	ped_owned(E->pd, E->t, id, x, v);
	for (size_t k = 0; k < nl; k++) {
		double *r = &mine[k * (size_t)W];
		memcpy(r, &x[k * (size_t)D], (size_t)D * sizeof(double));
		memcpy(r + D, &v[k * (size_t)D], (size_t)D * sizeof(double));
		r[2 * D] = (double)id[k];
	}
	int n = (int)(nl * (size_t)W);
	MPI_Gather(&n, 1, MPI_INT, cnt, 1, MPI_INT, 0, MPI_COMM_WORLD);
	if (E->rank == 0)
		for (int r = 0, off = 0; r < E->size; r++) {
			dis[r] = off;
			off += cnt[r];
		}
	MPI_Gatherv(mine, n, MPI_DOUBLE, all, cnt, dis, MPI_DOUBLE, 0, MPI_COMM_WORLD);
	int failed = 0;
	if (E->rank == 0) {
		for (size_t k = 0; k < N; k++) {
			const double *r = &all[k * (size_t)W];
			size_t i = (size_t)r[2 * D];
			memcpy(&pos[i * (size_t)D], r, (size_t)D * sizeof(double));
			memcpy(&vel[i * (size_t)D], r + D, (size_t)D * sizeof(double));
		}
		run_record_t rec;
		memset(&rec, 0, sizeof rec);
		rec.kind = RUN_SNAPSHOT;
		rec.dim = D;
		rec.n = N;
		rec.time = E->t;
		rec.events = sm.events;
		rec.collisions = sm.collisions;
		rec.collisions_per_particle = 2.0 * (double)sm.collisions / (double)N;
		rec.wall_seconds = MPI_Wtime() - E->t0;
		rec.kinetic_energy = sm.ekin;
		rec.pos = pos;
		rec.vel = vel;
		failed = emit && emit(&rec, ctx) != 0;
	}
	MPI_Bcast(&failed, 1, MPI_INT, 0, MPI_COMM_WORLD);
	if (failed)
		ret = RUN_EMIT;
cleanup:
	free(mine);
	free(id);
	free(x);
	free(v);
	free(all);
	free(pos);
	free(vel);
	free(cnt);
	return ret;
}

/* Rank 0 builds the serial run's initial state and broadcasts it; every
 * rank loads its share. NULL with msg and *err on failure (every rank). */
static ped_t *setup(const scene_t *s, int rank, int size, double *ekin0, int *err, char *msg, size_t msglen)
{
	const size_t ND = (size_t)s->count * (size_t)s->dim;
	double *pos = malloc(ND * sizeof(double)), *vel = malloc(ND * sizeof(double));
	ped_t *pd = NULL;
	int st[2] = {pos && vel ? RUN_OK : RUN_ENOMEM, 0};   /* outcome, and whether rank 0's message says it */
	if (rank == 0 && st[0] == RUN_OK) {
		run_opts_t opts = {0};
		int e = RUN_OK;
		run_t *r = run_create(s, &opts, &e, msg, msglen);
		if (r) {
			ed_state(run_ed(r), pos, vel);
			run_destroy(r);
		} else {
			st[0] = e, st[1] = 1;
		}
	}
	MPI_Bcast(st, 2, MPI_INT, 0, MPI_COMM_WORLD);
	int bad = st[0] != RUN_OK;
	MPI_Allreduce(MPI_IN_PLACE, &bad, 1, MPI_INT, MPI_MAX, MPI_COMM_WORLD);
	if (bad) {
		*err = st[0] != RUN_OK ? st[0] : RUN_ENOMEM;
		if (!(rank == 0 && st[1]) && msg && msglen)
			snprintf(msg, msglen, "run: out of memory for the initial state");
		goto cleanup;
	}
	MPI_Bcast(pos, (int)ND, MPI_DOUBLE, 0, MPI_COMM_WORLD);
	MPI_Bcast(vel, (int)ND, MPI_DOUBLE, 0, MPI_COMM_WORLD);
	ped_params_t p = {.dim = s->dim, .sigma = 2.0 * s->radius, .mass = s->mass, .e = s->restitution, .tc = s->tc,
	                  .ranks = size};
	for (int a = 0; a < 3; a++)
		p.L[a] = a < s->dim ? s->box[a] : 1.0;
	ped_grid(&p, s->count);
	int perr = PED_OK;
	pd = ped_create(&p, rank, (size_t)s->count, &perr);
	if (pd)
		perr = ped_load(pd, s->count, pos, vel);
	bad = perr != PED_OK;
	MPI_Allreduce(MPI_IN_PLACE, &bad, 1, MPI_INT, MPI_MAX, MPI_COMM_WORLD);
	if (bad) {
		ped_destroy(pd);
		pd = NULL;
		*err = RUN_ENOMEM;
		if (msg && msglen)
			snprintf(msg, msglen, "run: the split ed system could not be built on every rank (out of memory)");
		goto cleanup;
	}
	*ekin0 = 0.0;
	for (size_t k = 0; k < ND; k++)
		*ekin0 += 0.5 * s->mass * vel[k] * vel[k];
cleanup:
	free(pos);
	free(vel);
	return pd;
}

static const char *ped_why(int rc)
{
	switch (rc) {
	case PED_ENOMEM: return "out of memory in the parallel ed core";
	case PED_EFULL: return "a rank's particle room is full";
	case PED_ESTALL: return "the parallel ed core stalled (a causality error at a sync)";
	default: return "the parallel ed core failed";
	}
}

int edrun_run(const scene_t *s, int rank, int size, int frames, run_emit_fn emit, void *ctx,
              const volatile sig_atomic_t *stop, char *msg, size_t msglen)
{
	er_t E = {.s = s, .rank = rank, .size = size};
	int ret = RUN_OK;
	double ekin0 = 0.0;
	E.pd = setup(s, rank, size, &ekin0, &ret, msg, msglen);
	if (!E.pd)
		return ret;
	E.t0 = MPI_Wtime();
	const double N = (double)s->count, t_until = s->until.value, every = s->every.value;
	const int snap_time = frames && s->snapshots.kind == SCENE_CLOCK_TIME && s->snapshots.value > 0;
	/* the first sync interval: one Enskog collision time at the initial temperature (one collision per
	 * particle between syncs); the core adapts it (x1.1 per sync, x0.5 per rollback) */
	double T0 = 2.0 * ekin0 / (s->dim * N);
	double f = dsmc_collision_frequency(s->dim, s->volume_fraction, s->radius, s->mass, T0,
	                                    dsmc_contact_value(s->dim, s->volume_fraction));
	double sync_dt = f > 0.0 && isfinite(1.0 / f) ? 1.0 / f : (every > 0.0 ? every : t_until);
	ped_sched_t sched;
	ped_sched_init(&sched, t_until, sync_dt);
	uint64_t k_out = 1, k_snap = 1;
	double t_frame = -INFINITY;   /* time of the last frame */
	run_status_t status = RUN_COMPLETED;
	if ((ret = emit_progress(&E, emit, ctx)) != RUN_OK)
		goto cleanup;
	if (frames) {
		if ((ret = emit_frame(&E, emit, ctx)) != RUN_OK)
			goto cleanup;
		t_frame = E.t;
	}
	for (;;) {
		/* run.c's schedule: stop at the next output time, snapshot time or the end */
		double t_out = every > 0.0 ? (double)k_out * every : INFINITY;
		double t_snap = snap_time ? (double)k_snap * s->snapshots.value : INFINITY;
		double target = fmin(fmin(t_out, t_until), t_snap);
		double reached;
		int rc = pedmpi_advance(E.pd, MPI_COMM_WORLD, &sched, E.t, target, stop, &reached);
		E.t = reached;
		if (rc == PED_STOPPED) {
			status = RUN_INTERRUPTED;
		} else if (rc != PED_OK) {
			if (msg && msglen)
				snprintf(msg, msglen, "run: %s at time %.9g", ped_why(rc), E.t);
			ret = RUN_ENOMEM;
			goto cleanup;
		}
		const int done = status == RUN_INTERRUPTED || !(E.t < t_until);
		const int due = E.t >= t_out, due_snap = E.t >= t_snap;
		if (due || done) {
			if ((ret = emit_progress(&E, emit, ctx)) != RUN_OK)
				goto cleanup;
			while (every > 0.0 && (double)k_out * every <= E.t)   /* output times passed count once */
				k_out++;
		}
		if (frames && (due_snap || (done && t_frame != E.t))) {
			if ((ret = emit_frame(&E, emit, ctx)) != RUN_OK)
				goto cleanup;
			t_frame = E.t;
			while (snap_time && (double)k_snap * s->snapshots.value <= E.t)
				k_snap++;
		}
		if (done)
			break;
	}
	/* the summary: the last progress record with the run's totals (run.c's run_summary_record()) */
	run_record_t sum = E.last;
	sum.kind = RUN_SUMMARY;
	sum.have_interval = 0;
	sum.status = status;
	sum.wall_seconds = MPI_Wtime() - E.t0;
	sum.events_per_second = sum.wall_seconds > 0 ? sum.events / sum.wall_seconds : 0.0;
	sum.collisions_per_second = sum.wall_seconds > 0 ? sum.collisions / sum.wall_seconds : 0.0;
	uint64_t mem = ped_memory(E.pd);
	MPI_Allreduce(MPI_IN_PLACE, &mem, 1, MPI_UINT64_T, MPI_SUM, MPI_COMM_WORLD);
	sum.memory_bytes = mem;
	ped_params_t p = {.dim = s->dim, .sigma = 2.0 * s->radius};
	for (int a = 0; a < 3; a++)
		p.L[a] = a < s->dim ? s->box[a] : 1.0;
	ped_grid(&p, s->count);
	for (int a = 0; a < 3; a++)
		sum.cells[a] = a < s->dim ? p.nc[a] : 1;
	if (emit_all(rank, emit, ctx, &sum))
		ret = RUN_EMIT;
cleanup:
	if (ret == RUN_ENOMEM && msg && msglen && !msg[0])
		snprintf(msg, msglen, "run: out of memory");
	ped_destroy(E.pd);
	return ret;
}
