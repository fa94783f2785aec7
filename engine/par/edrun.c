/* One ed system over all MPI ranks (the parallel core par/ped.h): set-up from rank 0's initial state, the output schedule, records reduced over the ranks, frames gathered to rank 0. */
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
	double ekin, mom[3];
	double virial, eint_part;   /* over [t_mark, t]: the collision virial and the integral of E_kin dt */
} sums_t;

/* What a rank's part of the image holds besides ped_image_write(): the
 * driver's interval bookkeeping and the schedule (the same on every rank). */
typedef struct {
	uint64_t coll_base, tc_base, ev_base, coll_mark;
	double t, t_mark, t_ref, e_ref, eint_base, vir_base;
	ped_sched_t sched;
} er_img_t;

/* The run's state besides the core. */
typedef struct {
	const scene_t *s;
	ped_t *pd;
	int rank, size;
	double t;                   /* time reached (every event before it done) */
	double t_mark;              /* the last progress record's time: the interval's start */
	double t_ref, e_ref;        /* ped_mark()'s time (or the load's) and the kinetic energy then */
	double eint_base, vir_base; /* energy integral and collision virial over [t_mark, t_ref] */
	uint64_t coll_mark;         /* collisions at t_mark */
	uint64_t coll_base, tc_base, ev_base;   /* totals before this process (a resumed run) */
	double t0, wall_before;     /* MPI_Wtime() at the start of this process's part; wall seconds before it */
	run_record_t last;          /* the last progress record (the summary's base) */
	const ped_sched_t *sched;   /* the core's schedule: rollbacks, syncs, sync interval, rebalances */
	int from_image;             /* resumed from the core's own state (same rank count): img_sched holds its schedule */
	ped_sched_t img_sched;
	er_img_t img;               /* rank's image header when from_image */
	uint64_t *rank_ev, *rank_n; /* every rank's events processed and particles owned (records, size > 1) */
} er_t;

/* A checkpoint's state (rank 0 reads or writes it; broadcast as plain data). */
typedef struct {
	double t, t_mark, eint, virial, wall_before;
	uint64_t collisions, tc_elastic, events, coll_mark;
	run_state_t st;
} ckst_t;

int edrun_check(const scene_t *s, int out, char *msg, size_t msglen)
{
	return ped_scene_check(s, out, msg, msglen);
}

/* The core's totals of every rank, summed in rank order (the same bits on every rank, for every run at one rank count). */
static int reduce(er_t *E, sums_t *out)
{
	ped_totals_t tt;
	ped_totals(E->pd, &tt);
	double w[12];
	uint64_t u[5] = {tt.collisions, tt.tc_elastic, tt.events, tt.events_done, tt.owned};
	w[0] = tt.ekin;
	for (int a = 0; a < 3; a++)
		w[1 + a] = tt.mom[a];
	w[4] = tt.virial;
	w[5] = tt.dekin * (E->t - E->t_ref) - tt.dekin_t;
	memcpy(&w[6], u, sizeof u);   /* 5 words of 8 bytes */
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
		const double *x = &all[(size_t)r * 12];
		out->ekin += x[0];
		for (int a = 0; a < 3; a++)
			out->mom[a] += x[1 + a];
		out->virial += x[4];
		out->eint_part += x[5];
		memcpy(u, &x[6], sizeof u);
		out->collisions += u[0];
		out->tc_elastic += u[1];
		out->events += u[2];
		if (E->rank_ev) {
			E->rank_ev[r] = u[3];
			E->rank_n[r] = u[4];
		}
	}
	free(all);
	out->collisions += E->coll_base;
	out->tc_elastic += E->tc_base;
	out->events += E->ev_base;
	/* over [t_mark, t]: the integral of E_kin dt and the virial */
	out->eint_part += E->eint_base + E->e_ref * (E->t - E->t_ref);
	out->virial += E->vir_base;
	return RUN_OK;
}

/* The split run's load fields of a record (size > 1; reduce() just filled the per-rank arrays). */
static void split_fields(const er_t *E, run_record_t *r)
{
	if (E->size < 2)
		return;
	r->ranks = E->size;
	r->rank_events = E->rank_ev;
	r->rank_particles = E->rank_n;
	r->rollbacks = E->sched->st.rollbacks;
	r->syncs = E->sched->st.syncs;
	r->rebalances = E->sched->st.rebalances;
	r->sync_interval = E->sched->sync_dt;
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
	r->wall_seconds = E->wall_before + MPI_Wtime() - E->t0;
	r->elastic_by_tc = sm.tc_elastic;
	r->have = s->observables;
	r->kinetic_energy = sm.ekin;
	r->particles = s->count;
	r->temperature = 2.0 * sm.ekin / (s->dim * N);
	for (int a = 0; a < 3; a++)
		r->momentum[a] = a < s->dim ? sm.mom[a] : 0.0;
	if (interval > 0.0) {
		/* the exact integral of E_kin dt (piecewise constant between collisions) */
		double eint = sm.eint_part;
		double t_avg = 2.0 * eint / (s->dim * N * interval);
		double vol = scene_box_volume(s);
		r->have_interval = 1;
		r->pressure = (N * t_avg + sm.virial / (s->dim * interval)) / vol;
		r->compressibility = t_avg > 0.0 ? r->pressure * vol / (N * t_avg) : NAN;
		r->collision_rate = 2.0 * (double)(sm.collisions - E->coll_mark) / (N * interval);
	}
	r->com_height = r->potential_energy = NAN;   /* no gravity (as ed_sample()) */
	r->obs.a2 = r->obs.a3 = r->obs.g_pairs = r->obs.g_pairs_se = r->obs.g_rate = r->obs.g_pressure = NAN;
	r->obs.msd = r->obs.msd_se = r->obs.diffusion = r->obs.msd_walled = r->obs.msd_count = NAN;
	r->obs.flux = r->obs.flux_se = NAN;
	split_fields(E, r);
	ped_mark(E->pd, E->t);   /* right after a sync: pedmpi_advance() saved the state at E->t */
	E->t_mark = E->t_ref = E->t;
	E->e_ref = sm.ekin;
	E->eint_base = E->vir_base = 0.0;
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

/* Every rank's particles at E->t gathered to rank 0 (MPI_Gatherv) in
 * particle order: positions and velocities (N D doubles each) and, with
 * tlast != NULL, their last collision times (collective; rank 0 owns the
 * arrays, NULL elsewhere). RUN_OK or RUN_ENOMEM (every rank). */
static int gather(er_t *E, double **pos_out, double **vel_out, double **tlast_out)
{
	const scene_t *s = E->s;
	const int D = s->dim, W = 2 * D + 2;
	const size_t N = (size_t)s->count;
	ped_totals_t tt;
	ped_totals(E->pd, &tt);
	const size_t nl = (size_t)tt.owned;
	double *mine = malloc((nl + 1) * (size_t)W * sizeof(double));
	uint32_t *id = malloc((nl + 1) * sizeof(uint32_t));
	double *x = malloc((nl + 1) * (size_t)D * sizeof(double)), *v = malloc((nl + 1) * (size_t)D * sizeof(double));
	double *tl = malloc((nl + 1) * sizeof(double));
	double *all = NULL, *pos = NULL, *vel = NULL, *tla = NULL;
	int *cnt = NULL, *dis = NULL, ret = RUN_OK;
	int bad = !mine || !id || !x || !v || !tl;
	if (E->rank == 0) {
		all = malloc((N + 1) * (size_t)W * sizeof(double));
		pos = malloc(N * (size_t)D * sizeof(double));
		vel = malloc(N * (size_t)D * sizeof(double));
		tla = tlast_out ? malloc(N * sizeof(double)) : NULL;
		cnt = malloc((size_t)E->size * 2 * sizeof(int));
		bad = bad || !all || !pos || !vel || (tlast_out && !tla) || !cnt || N * (size_t)W > INT32_MAX;
		dis = cnt ? cnt + E->size : NULL;
	}
	MPI_Allreduce(MPI_IN_PLACE, &bad, 1, MPI_INT, MPI_MAX, MPI_COMM_WORLD);
	if (bad) {
		ret = RUN_ENOMEM;
		goto cleanup;
	}
	ped_owned(E->pd, E->t, id, x, v);
	ped_owned_tlast(E->pd, tl);
	for (size_t k = 0; k < nl; k++) {
		double *r = &mine[k * (size_t)W];
		memcpy(r, &x[k * (size_t)D], (size_t)D * sizeof(double));
		memcpy(r + D, &v[k * (size_t)D], (size_t)D * sizeof(double));
		r[2 * D] = (double)id[k];
		r[2 * D + 1] = tl[k];
	}
	int n = (int)(nl * (size_t)W);
	MPI_Gather(&n, 1, MPI_INT, cnt, 1, MPI_INT, 0, MPI_COMM_WORLD);
	if (E->rank == 0)
		for (int r = 0, off = 0; r < E->size; r++) {
			dis[r] = off;
			off += cnt[r];
		}
	MPI_Gatherv(mine, n, MPI_DOUBLE, all, cnt, dis, MPI_DOUBLE, 0, MPI_COMM_WORLD);
	if (E->rank == 0)
		for (size_t k = 0; k < N; k++) {
			const double *r = &all[k * (size_t)W];
			size_t i = (size_t)r[2 * D];
			memcpy(&pos[i * (size_t)D], r, (size_t)D * sizeof(double));
			memcpy(&vel[i * (size_t)D], r + D, (size_t)D * sizeof(double));
			if (tla)
				tla[i] = r[2 * D + 1];
		}
cleanup:
	free(mine);
	free(id);
	free(x);
	free(v);
	free(tl);
	free(all);
	free(cnt);
	if (ret != RUN_OK) {
		free(pos);
		free(vel);
		free(tla);
		pos = vel = tla = NULL;
	}
	*pos_out = pos;
	*vel_out = vel;
	if (tlast_out)
		*tlast_out = tla;
	return ret;
}

/* A frame at E->t, gathered to rank 0 and emitted there (collective); *events: the events total then. */
static int emit_frame(er_t *E, run_emit_fn emit, void *ctx, uint64_t *events)
{
	const scene_t *s = E->s;
	sums_t sm;
	double *pos = NULL, *vel = NULL;
	int ret = reduce(E, &sm);
	if (ret != RUN_OK || (ret = gather(E, &pos, &vel, NULL)) != RUN_OK)
		return ret;
	*events = sm.events;
	int failed = 0;
	if (E->rank == 0) {
		run_record_t rec;
		memset(&rec, 0, sizeof rec);
		rec.kind = RUN_SNAPSHOT;
		rec.dim = s->dim;
		rec.n = s->count;
		rec.time = E->t;
		rec.events = sm.events;
		rec.collisions = sm.collisions;
		rec.collisions_per_particle = 2.0 * (double)sm.collisions / (double)s->count;
		rec.wall_seconds = E->wall_before + MPI_Wtime() - E->t0;
		rec.kinetic_energy = sm.ekin;
		rec.pos = pos;
		rec.vel = vel;
		failed = emit && emit(&rec, ctx) != 0;
	}
	MPI_Bcast(&failed, 1, MPI_INT, 0, MPI_COMM_WORLD);
	free(pos);
	free(vel);
	return failed ? RUN_EMIT : RUN_OK;
}

/* ---- checkpoints in the serial run's layout ------------------------------ */

static int set_f64(run_t *r, const char *name, double x) { return run_field_set(r, name, ED_T_F64, 1, &x); }
static int set_u64(run_t *r, const char *name, uint64_t x) { return run_field_set(r, name, ED_T_U64, 1, &x); }

/* Rank 0: a serial run holding the state at time c->t (pos, vel, tlast
 * absolute), the counters and the interval accumulators of c, and the
 * schedule c->st: a fresh engine from the state (its own predictions) with
 * its clock's epoch at c->t. NULL with msg on failure. */
static run_t *as_serial(const scene_t *s, const double *pos, const double *vel, const double *tlast, const ckst_t *c,
                        char *msg, size_t msglen)
{
	scene_t s2 = *s;
	s2.init_pos = pos;
	s2.init_vel = vel;
	s2.relax_cpp = 0.0;
	s2.has_region = 0;
	run_opts_t opts = {0};
	int err = RUN_OK, bad = 0;
	run_t *r = run_create(&s2, &opts, &err, msg, msglen);
	if (!r)
		return NULL;
	/* the clock: relative 0 (the engine's), epoch c->t; exactly c->t until the next event */
	int32_t valid = 1;
	bad |= set_f64(r, "epoch", c->t) || set_f64(r, "epoch_c", 0.0) || set_f64(r, "t_abs", c->t) ||
	       run_field_set(r, "t_abs_valid", ED_T_I32, 1, &valid);
	bad |= set_u64(r, "events", c->events) || set_u64(r, "collisions", c->collisions) ||
	       set_u64(r, "tc_elastic", c->tc_elastic) || set_u64(r, "coll_int0", c->coll_mark);
	/* the interval since the last progress record: [t_mark, t], relative times */
	bad |= set_f64(r, "ekin_int", c->eint) || set_f64(r, "t_mark", 0.0) || set_f64(r, "t_int0", c->t_mark - c->t) ||
	       set_f64(r, "virial", c->virial);
	if (s->tc > 0.0 && tlast) {
		/* the engine stores its particles in cell order: slot k holds scene particle id[k] */
		double *rel = malloc((size_t)s->count * sizeof(double));
		uint32_t *id = malloc((size_t)s->count * sizeof(uint32_t));
		bad |= !rel || !id || run_field_get(r, "id", id) != RUN_OK;
		for (uint64_t k = 0; !bad && k < s->count; k++) {
			bad |= id[k] >= s->count;
			if (!bad)
				rel[k] = tlast[id[k]] - c->t;   /* -INFINITY stays */
		}
		bad |= !bad && run_field_set(r, "tlast", ED_T_F64, (size_t)s->count, rel) != RUN_OK;
		free(rel);
		free(id);
	}
	run_set_state(r, &c->st);
	if (bad) {
		if (msg && msglen)
			snprintf(msg, msglen, "run: the split run's state does not fit the serial engine's checkpoint fields");
		run_destroy(r);
		return NULL;
	}
	return r;
}

/* Rank 0: the state of a serial run restored from a checkpoint (as_serial()'s inverse). */
static int from_serial(run_t *r, const scene_t *s, double *pos, double *vel, double *tlast, ckst_t *c)
{
	ed_t *ed = run_ed(r);
	double clock, t_int0, t_mark, ekin_int, ekin_cur;
	ed_sample_t sm;
	if (!ed || run_field_get(r, "clock", &clock) || run_field_get(r, "t_int0", &t_int0) ||
	    run_field_get(r, "t_mark", &t_mark) || run_field_get(r, "ekin_int", &ekin_int) ||
	    run_field_get(r, "ekin_cur", &ekin_cur) || run_field_get(r, "virial", &c->virial) ||
	    run_field_get(r, "coll_int0", &c->coll_mark))
		return -1;
	ed_state(ed, pos, vel);
	ed_totals(ed, &sm);
	c->t = ed_time(ed);
	c->collisions = sm.collisions;
	c->tc_elastic = sm.elastic_by_tc;
	c->events = sm.events;
	c->t_mark = c->t - (clock - t_int0);
	c->eint = ekin_int + ekin_cur * (clock - t_mark);
	for (uint64_t i = 0; i < s->count; i++)
		tlast[i] = -INFINITY;
	if (s->tc > 0.0) {
		/* slot k of the engine holds scene particle id[k] */
		double *rel = malloc((size_t)s->count * sizeof(double));
		uint32_t *id = malloc((size_t)s->count * sizeof(uint32_t));
		int bad = !rel || !id || run_field_get(r, "tlast", rel) || run_field_get(r, "id", id);
		for (uint64_t k = 0; !bad && k < s->count; k++) {
			bad = id[k] >= s->count;
			if (!bad)
				tlast[id[k]] = c->t - (clock - rel[k]);
		}
		free(rel);
		free(id);
		if (bad)
			return -1;
	}
	run_get_state(r, &c->st);
	c->wall_before = c->st.wall_before;
	return 0;
}

/* ---- the core's own state beside the serial layout (same rank count) ----- */

#define IMG_MAGIC 0x31454d4944455000ULL   /* "\0PEDIME1" */


/* Every rank's core state gathered to rank 0 as one blob: magic, P, then per
 * rank its length and bytes (er_img_t, then ped_image_write()). Collective;
 * *out (rank 0, malloc'd) stays NULL on failure and when the image exceeds
 * MPI's int counts (then RUN_OK: no image). RUN_OK or RUN_ENOMEM (every rank). */
static int gather_image(er_t *E, unsigned char **out, size_t *outlen)
{
	const int P = E->size;
	er_img_t h;
	memset(&h, 0, sizeof h);
	h.coll_base = E->coll_base, h.tc_base = E->tc_base, h.ev_base = E->ev_base, h.coll_mark = E->coll_mark;
	h.t = E->t, h.t_mark = E->t_mark, h.t_ref = E->t_ref, h.e_ref = E->e_ref, h.eint_base = E->eint_base,
	h.vir_base = E->vir_base, h.sched = *E->sched;
	size_t il = ped_image_size(E->pd), len = sizeof h + il;
	unsigned char *mine = NULL, *all = NULL;
	int *cnt = NULL, *dis = NULL, ret = RUN_OK;
	/* a part beyond MPI's int counts (about 10^7 particles on one rank): no image, the serial layout only */
	int big = len > INT32_MAX;
	MPI_Allreduce(MPI_IN_PLACE, &big, 1, MPI_INT, MPI_MAX, MPI_COMM_WORLD);
	if (big)
		goto cleanup;
	mine = malloc(len);
	int bad = !mine;
	if (!bad) {
		memcpy(mine, &h, sizeof h);
		ped_image_write(E->pd, mine + sizeof h);
	}
	int n = bad ? 0 : (int)len;
	if (E->rank == 0) {
		cnt = malloc(2 * (size_t)P * sizeof *cnt);
		bad = bad || !cnt;
		dis = cnt ? cnt + P : NULL;
	}
	MPI_Allreduce(MPI_IN_PLACE, &bad, 1, MPI_INT, MPI_MAX, MPI_COMM_WORLD);
	if (bad) {
		ret = RUN_ENOMEM;
		goto cleanup;
	}
	MPI_Gather(&n, 1, MPI_INT, cnt, 1, MPI_INT, 0, MPI_COMM_WORLD);
	size_t head = 2 * sizeof(uint64_t) + (size_t)P * sizeof(uint64_t), tot = head;
	if (E->rank == 0) {
		for (int r = 0; r < P; r++)
			tot += (size_t)cnt[r];
		big = tot - head > INT32_MAX;
		all = big ? NULL : malloc(tot);
		bad = !big && !all;
		for (int r = 0, o = 0; !bad && r < P; o += cnt[r], r++)
			dis[r] = o;
	}
	int flags[2] = {bad, big};
	MPI_Bcast(flags, 2, MPI_INT, 0, MPI_COMM_WORLD);
	if (flags[0] || flags[1]) {
		ret = flags[0] ? RUN_ENOMEM : RUN_OK;
		goto cleanup;
	}
	MPI_Gatherv(mine, n, MPI_BYTE, all ? all + head : NULL, cnt, dis, MPI_BYTE, 0, MPI_COMM_WORLD);
	if (E->rank == 0) {
		uint64_t u[2] = {IMG_MAGIC, (uint64_t)P};
		memcpy(all, u, sizeof u);
		for (int r = 0; r < P; r++) {
			uint64_t l = (uint64_t)cnt[r];
			memcpy(all + sizeof u + (size_t)r * sizeof l, &l, sizeof l);
		}
		*out = all, *outlen = tot;
		all = NULL;
	}
cleanup:
	free(mine);
	free(all);
	free(cnt);
	return ret;
}

/* Rank 0: whether blob (len bytes) is an image of P ranks; rank r's part in
 * parts[r] (offset), lens[r]. */
static int image_parts(const unsigned char *blob, size_t len, int P, size_t *off, size_t *lens)
{
	uint64_t u[2];
	size_t head = 2 * sizeof(uint64_t) + (size_t)P * sizeof(uint64_t);
	if (!blob || len < sizeof u)
		return 0;
	memcpy(u, blob, sizeof u);
	if (u[0] != IMG_MAGIC || u[1] != (uint64_t)P || len < head)
		return 0;
	size_t o = head;
	for (int r = 0; r < P; r++) {
		uint64_t l;
		memcpy(&l, blob + sizeof u + (size_t)r * sizeof l, sizeof l);
		if (l < sizeof(er_img_t) || l > len - o || l > INT32_MAX)
			return 0;
		off[r] = o, lens[r] = (size_t)l;
		o += (size_t)l;
	}
	return o == len;
}

/* A checkpoint of the present state in the serial layout, written by rank 0
 * through o->save (collective). RUN_OK, RUN_ENOMEM, RUN_EMIT (save failed). */
static int write_ckpt(er_t *E, const edrun_opts_t *o, const run_state_t *st, char *msg, size_t msglen)
{
	sums_t sm;
	double *pos = NULL, *vel = NULL, *tlast = NULL;
	int ret = reduce(E, &sm);
	if (ret != RUN_OK || (ret = gather(E, &pos, &vel, &tlast)) != RUN_OK)
		return ret;
	/* over P > 1 ranks also the core's own state (/ped/image), which a run at
	 * the same rank count resumes bit for bit */
	unsigned char *img = NULL;
	size_t imglen = 0;
	if (E->size > 1 && (ret = gather_image(E, &img, &imglen)) != RUN_OK) {
		free(pos);
		free(vel);
		free(tlast);
		return ret;
	}
	int failed = 0;
	if (E->rank == 0) {
		ckst_t c = {.t = E->t, .t_mark = E->t_mark, .eint = sm.eint_part, .virial = sm.virial,
		            .collisions = sm.collisions, .tc_elastic = sm.tc_elastic, .events = sm.events,
		            .coll_mark = E->coll_mark, .st = *st};
		c.st.wall_before = E->wall_before + MPI_Wtime() - E->t0;
		run_t *r = as_serial(E->s, pos, vel, tlast, &c, msg, msglen);
		failed = !r || (img && run_extra_set(r, img, imglen) != RUN_OK) ? 1
		         : (o->save && o->save(r, o->save_ctx) != 0) ? 2 : 0;
		run_destroy(r);
	}
	MPI_Bcast(&failed, 1, MPI_INT, 0, MPI_COMM_WORLD);
	free(img);
	free(pos);
	free(vel);
	free(tlast);
	return failed == 1 ? RUN_ENOMEM : failed == 2 ? RUN_EMIT : RUN_OK;
}

/* Resume from the checkpoint's core image when it is one of this rank
 * count at time t0 (rank 0 decides and scatters the parts). Collective.
 * 1 loaded on every rank (E->from_image, E->img set), 0 no image (pd
 * untouched), -1 some rank failed (pd must be rebuilt). */
static int load_image(er_t *E, const edrun_opts_t *o, ped_t *pd, double t0)
{
	const int P = E->size;
	size_t *off = NULL, *lens = NULL, blen = 0;
	const unsigned char *blob = NULL;
	int *cnt = NULL, *dis = NULL, ok = 0, n = 0, ret = 0;
	unsigned char *mine = NULL;
	if (E->rank == 0) {
		off = malloc((size_t)P * sizeof *off);
		lens = malloc((size_t)P * sizeof *lens);
		cnt = malloc(2 * (size_t)P * sizeof *cnt);
		blob = o->resume ? run_extra(o->resume, &blen) : NULL;
		ok = off && lens && cnt && image_parts(blob, blen, P, off, lens);
		dis = cnt ? cnt + P : NULL;
		for (int r = 0; ok && r < P; r++)
			cnt[r] = (int)lens[r];
		for (int r = 0; ok && r < P; r++) {
			if (off[r] - off[0] > INT32_MAX)
				ok = 0;
			else
				dis[r] = (int)(off[r] - off[0]);
		}
	}
	MPI_Bcast(&ok, 1, MPI_INT, 0, MPI_COMM_WORLD);
	if (!ok)
		goto cleanup;
	MPI_Scatter(cnt, 1, MPI_INT, &n, 1, MPI_INT, 0, MPI_COMM_WORLD);
	mine = malloc(n > 0 ? (size_t)n : 1);
	int bad = !mine;
	MPI_Allreduce(MPI_IN_PLACE, &bad, 1, MPI_INT, MPI_MAX, MPI_COMM_WORLD);
	if (bad) {
		ret = -1;
		goto cleanup;
	}
	MPI_Scatterv(E->rank == 0 ? blob + off[0] : NULL, cnt, dis, MPI_BYTE, mine, n, MPI_BYTE, 0, MPI_COMM_WORLD);
	memcpy(&E->img, mine, sizeof E->img);
	bad = E->img.t != t0 || ped_image_load(pd, mine + sizeof E->img, (size_t)n - sizeof E->img) != PED_OK;
	MPI_Allreduce(MPI_IN_PLACE, &bad, 1, MPI_INT, MPI_MAX, MPI_COMM_WORLD);
	ret = bad ? -1 : 1;
	E->from_image = ret == 1;
cleanup:
	free(mine);
	free(off);
	free(lens);
	free(cnt);
	return ret;
}

/* Rank 0 builds the serial run's initial state (or takes a resumed run's)
 * and broadcasts it; every rank loads its share. NULL with msg and *err on
 * failure (every rank). */
static ped_t *setup(er_t *E, const edrun_opts_t *o, ckst_t *c, int *err, char *msg, size_t msglen)
{
	const scene_t *s = E->s;
	const int rank = E->rank;
	const size_t ND = (size_t)s->count * (size_t)s->dim;
	double *pos = malloc(ND * sizeof(double)), *vel = malloc(ND * sizeof(double));
	double *tlast = o->resumed ? malloc((size_t)s->count * sizeof(double)) : NULL;
	ped_t *pd = NULL;
	int st[2] = {pos && vel && (tlast || !o->resumed) ? RUN_OK : RUN_ENOMEM, 0};   /* outcome, rank 0's msg says it */
	memset(c, 0, sizeof *c);
	if (rank == 0 && st[0] == RUN_OK && o->resumed) {
		if (!o->resume || from_serial(o->resume, s, pos, vel, tlast, c) != 0) {
			st[0] = RUN_ESETUP, st[1] = 1;
			if (msg && msglen)
				snprintf(msg, msglen, "--resume: the checkpoint holds no ed state this run can continue");
		}
	} else if (rank == 0 && st[0] == RUN_OK) {
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
	MPI_Bcast(c, (int)sizeof *c, MPI_BYTE, 0, MPI_COMM_WORLD);
	MPI_Bcast(pos, (int)ND, MPI_DOUBLE, 0, MPI_COMM_WORLD);
	MPI_Bcast(vel, (int)ND, MPI_DOUBLE, 0, MPI_COMM_WORLD);
	if (tlast)
		MPI_Bcast(tlast, (int)s->count, MPI_DOUBLE, 0, MPI_COMM_WORLD);
	ped_params_t p = {.dim = s->dim, .sigma = 2.0 * s->radius, .mass = s->mass, .e = s->restitution, .tc = s->tc,
	                  .ranks = E->size};
	for (int a = 0; a < 3; a++)
		p.L[a] = a < s->dim ? s->box[a] : 1.0;
	ped_grid(&p, s->count);
	int perr = PED_OK;
	pd = ped_create(&p, rank, (size_t)s->count, &perr);
	/* a checkpoint of a split run at this rank count holds the core's own
	 * state: load it (bit for bit the uninterrupted run); otherwise, or if
	 * any rank cannot, the serial state at the checkpoint time */
	int use_img = 0;
	if (pd && o->resumed && E->size > 1)
		use_img = load_image(E, o, pd, c->t);
	if (use_img < 0) {   /* a rank's load failed half-way: start again from a fresh core */
		ped_destroy(pd);
		pd = ped_create(&p, rank, (size_t)s->count, &perr);
		use_img = 0;
	}
	if (pd && !use_img)
		perr = ped_load_at(pd, s->count, pos, vel, tlast, c->t);
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
	/* the interval so far (a resumed run) and the energy now, in particle order on every rank */
	double ek = 0.0;
	for (size_t k = 0; k < ND; k++)
		ek += 0.5 * s->mass * vel[k] * vel[k];
	E->t = E->t_mark = E->t_ref = c->t;
	E->e_ref = ek;
	if (o->resumed) {
		E->t_mark = c->t_mark;
		E->eint_base = c->eint;
		E->vir_base = c->virial;
		E->coll_mark = c->coll_mark;
		E->coll_base = c->collisions;
		E->tc_base = c->tc_elastic;
		E->ev_base = c->events;
		E->wall_before = c->wall_before;
	}
	if (E->from_image) {   /* the interval bookkeeping of the uninterrupted run */
		E->t_mark = E->img.t_mark, E->t_ref = E->img.t_ref, E->e_ref = E->img.e_ref;
		E->eint_base = E->img.eint_base, E->vir_base = E->img.vir_base, E->coll_mark = E->img.coll_mark;
		E->coll_base = E->img.coll_base, E->tc_base = E->img.tc_base, E->ev_base = E->img.ev_base;
		E->img_sched = E->img.sched;
	}
cleanup:
	free(pos);
	free(vel);
	free(tlast);
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

/* The summary: the last progress record with the run's totals (run.c's run_summary_record()); after a stop
 * for a checkpoint the totals now, without sampling. Collective. */
static int summary(er_t *E, run_status_t status, int now, run_emit_fn emit, void *ctx)
{
	const scene_t *s = E->s;
	run_record_t sum = E->last;
	if (now) {
		sums_t sm;
		int ret = reduce(E, &sm);
		if (ret != RUN_OK)
			return ret;
		sum.time = E->t;
		sum.events = sm.events;
		sum.collisions = sm.collisions;
		sum.collisions_per_particle = 2.0 * (double)sm.collisions / (double)s->count;
		sum.kinetic_energy = sm.ekin;
		sum.temperature = 2.0 * sm.ekin / (s->dim * (double)s->count);
		for (int a = 0; a < 3; a++)
			sum.momentum[a] = a < s->dim ? sm.mom[a] : 0.0;
		sum.elastic_by_tc = sm.tc_elastic;
		split_fields(E, &sum);
	}
	sum.kind = RUN_SUMMARY;
	sum.dim = s->dim;
	sum.n = s->count;
	sum.have = s->observables;
	sum.have_interval = 0;
	sum.status = status;
	sum.wall_seconds = E->wall_before + MPI_Wtime() - E->t0;
	sum.events_per_second = sum.wall_seconds > 0 ? sum.events / sum.wall_seconds : 0.0;
	sum.collisions_per_second = sum.wall_seconds > 0 ? sum.collisions / sum.wall_seconds : 0.0;
	uint64_t mem = ped_memory(E->pd);
	MPI_Allreduce(MPI_IN_PLACE, &mem, 1, MPI_UINT64_T, MPI_SUM, MPI_COMM_WORLD);
	sum.memory_bytes = mem;
	ped_params_t p = {.dim = s->dim, .sigma = 2.0 * s->radius};
	for (int a = 0; a < 3; a++)
		p.L[a] = a < s->dim ? s->box[a] : 1.0;
	ped_grid(&p, s->count);
	for (int a = 0; a < 3; a++)
		sum.cells[a] = a < s->dim ? p.nc[a] : 1;
	return emit_all(E->rank, emit, ctx, &sum) ? RUN_EMIT : RUN_OK;
}

int edrun_run(const scene_t *s, int rank, int size, const edrun_opts_t *o, run_emit_fn emit, void *ctx,
              const volatile sig_atomic_t *stop, char *msg, size_t msglen)
{
	er_t E = {.s = s, .rank = rank, .size = size};
	int ret = RUN_OK;
	ckst_t c;
	E.pd = setup(&E, o, &c, &ret, msg, msglen);
	if (!E.pd)
		return ret;
	E.t0 = MPI_Wtime();
	const double N = (double)s->count, t_until = s->until.value, every = s->every.value;
	const int frames = o->frames;
	const int snap_time = frames && s->snapshots.kind == SCENE_CLOCK_TIME && s->snapshots.value > 0;
	const int ck_time = o->checkpoints && s->checkpoint.kind == SCENE_CLOCK_TIME && s->checkpoint.value > 0;
	const int ck_wall = o->checkpoints && s->checkpoint.kind == SCENE_CLOCK_WALL;
	/* the first sync interval: one Enskog collision time at the temperature now (one collision per
	 * particle between syncs); the core adapts it (x1.1 per sync, x0.5 per rollback) */
	double T0 = 2.0 * E.e_ref / (s->dim * N);
	double f = dsmc_collision_frequency(s->dim, s->volume_fraction, s->radius, s->mass, T0,
	                                    dsmc_contact_value(s->dim, s->volume_fraction));
	double sync_dt = f > 0.0 && isfinite(1.0 / f) ? 1.0 / f : (every > 0.0 ? every : t_until);
	ped_sched_t sched;
	ped_sched_init(&sched, t_until, sync_dt);
	sched.balance = s->balance;   /* run.balance "events": load balancing at syncs */
	if (E.from_image) {           /* the uninterrupted run's schedule: interval, window, statistics */
		sched = E.img_sched;
		sched.balance = s->balance;
	}
	E.sched = &sched;
	if (size > 1 && size <= RUN_RANKS_MAX) {
		E.rank_ev = calloc((size_t)size, sizeof *E.rank_ev);
		E.rank_n = calloc((size_t)size, sizeof *E.rank_n);
		int bad = !E.rank_ev || !E.rank_n;
		MPI_Allreduce(MPI_IN_PLACE, &bad, 1, MPI_INT, MPI_MAX, MPI_COMM_WORLD);
		if (bad) {
			ret = RUN_ENOMEM;
			goto cleanup;
		}
	}
	/* the schedule (run.c's run_state_t: indices of the next output, snapshot and checkpoint) */
	run_state_t st = {.started = 1, .k_out = 1, .k_snap = 1, .k_ckpt = 1, .snap_events = UINT64_MAX};
	if (o->resumed)
		st = c.st;
	double t_frame = o->resumed && st.snap_events == c.events ? E.t : -INFINITY;   /* time of the last frame */
	double ckpt_wall = MPI_Wtime();
	/* wall-clock checkpoints: the run also stops every `chunk` of simulated time (rank 0 sizes it to about a
	 * second of wall time and broadcasts it with its decision); where it stops does not change the collisions */
	double chunk = 16.0 * sync_dt;
	run_status_t status = RUN_COMPLETED;
	if (!o->resumed) {
		if ((ret = emit_progress(&E, emit, ctx)) != RUN_OK)
			goto cleanup;
		if (frames) {
			if ((ret = emit_frame(&E, emit, ctx, &st.snap_events)) != RUN_OK)
				goto cleanup;
			t_frame = E.t;
		}
	}
	for (;;) {
		/* run.c's schedule: stop at the next output time, snapshot time, checkpoint time or the end */
		double t_out = every > 0.0 ? (double)st.k_out * every : INFINITY;
		double t_snap = snap_time ? (double)st.k_snap * s->snapshots.value : INFINITY;
		double t_ck = ck_time ? (double)st.k_ckpt * s->checkpoint.value : INFINITY;
		double target = fmin(fmin(fmin(t_out, t_until), t_snap), t_ck);
		if (ck_wall && E.t + chunk < target)
			target = E.t + chunk;
		double reached, w0 = MPI_Wtime();
		int rc = pedmpi_advance(E.pd, MPI_COMM_WORLD, &sched, E.t, target, stop, &reached);
		E.t = reached;
		if (rc == PED_STOPPED && !(E.t < t_until))
			rc = PED_OK;   /* the end reached: completed (run.c: a stop counts before the end only) */
		if (rc == PED_STOPPED && o->checkpoints) {
			/* as the serial run: nothing sampled, the checkpoint, the summary with the totals now */
			if ((ret = write_ckpt(&E, o, &st, msg, msglen)) != RUN_OK)
				goto cleanup;
			ret = summary(&E, RUN_INTERRUPTED, 1, emit, ctx);
			if (ret == RUN_OK)
				ret = RUN_STOPPED;
			goto cleanup;
		}
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
			while (every > 0.0 && (double)st.k_out * every <= E.t)   /* output times passed count once */
				st.k_out++;
		}
		if (frames && (due_snap || (done && t_frame != E.t))) {
			if ((ret = emit_frame(&E, emit, ctx, &st.snap_events)) != RUN_OK)
				goto cleanup;
			t_frame = E.t;
			while (snap_time && (double)st.k_snap * s->snapshots.value <= E.t)
				st.k_snap++;
		}
		if (done)
			break;
		int ck = ck_time && E.t >= t_ck;
		if (ck_wall) {   /* rank 0's clock decides, and sizes the next chunk */
			double d[2] = {MPI_Wtime() - ckpt_wall >= s->checkpoint.value, chunk};
			if (rank == 0) {
				double el = MPI_Wtime() - w0, g = el > 0.0 ? 1.0 / el : 2.0;
				d[1] = chunk * (g < 0.5 ? 0.5 : g > 2.0 ? 2.0 : g);
			}
			MPI_Bcast(d, 2, MPI_DOUBLE, 0, MPI_COMM_WORLD);
			ck = d[0] != 0.0;
			chunk = d[1];
		}
		if (ck) {
			while (ck_time && (double)st.k_ckpt * s->checkpoint.value <= E.t)
				st.k_ckpt++;
			if ((ret = write_ckpt(&E, o, &st, msg, msglen)) != RUN_OK)
				goto cleanup;
			ckpt_wall = MPI_Wtime();
		}
	}
	ret = summary(&E, status, 0, emit, ctx);
cleanup:
	if (ret == RUN_ENOMEM && msg && msglen && !msg[0])
		snprintf(msg, msglen, "run: out of memory");
	ped_destroy(E.pd);
	free(E.rank_ev);
	free(E.rank_n);
	return ret;
}
