/* Run driver: output schedule, stop conditions and observables around the event-driven core. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "ed.h"
#include "run.h"

/* Events processed between polls of the stop flag: ~0.1 s of work. */
#define RUN_CHUNK_EVENTS 200000u

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

struct run {
	const scene_t *s;        /* the caller's; must outlive the run */
	run_opts_t opts;
	ed_t *ed;
	clusters_t *cl;
	double *pos, *vel;       /* sampling buffers (clusters, snapshots) */
	double t0;               /* wall clock at the start of this process's part */
	double ckpt_wall;        /* wall clock of the last checkpoint request */
	run_state_t st;
	run_record_t rec;        /* the last progress record */
	run_status_t status;
};

static double wall_seconds(const run_t *r)
{
	return r->st.wall_before + (wall_now() - r->t0);
}

static int sample(run_t *rc, run_record_t *r, run_kind_t kind)
{
	const scene_t *s = rc->s;
	ed_sample_t sm;
	ed_sample(rc->ed, &sm);
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
	r->have = s->observables;
	r->kinetic_energy = sm.kinetic_energy;
	r->temperature = 2.0 * sm.kinetic_energy / (s->dim * (double)s->count);
	memcpy(r->momentum, sm.momentum, sizeof(r->momentum));
	if (sm.interval > 0.0) {
		/* Time-averaged temperature over the interval from the exact
		 * integral of E_kin dt (E_kin is piecewise constant). */
		double t_avg = 2.0 * sm.ekin_time_integral / (s->dim * (double)s->count * sm.interval);
		double vol = scene_box_volume(s);
		r->have_interval = 1;
		r->pressure = ((double)s->count * t_avg + sm.virial / (s->dim * sm.interval)) / vol;
		r->compressibility = t_avg > 0.0 ? r->pressure * vol / ((double)s->count * t_avg) : NAN;
		r->collision_rate = 2.0 * (double)sm.interval_collisions / ((double)s->count * sm.interval);
	}
	if ((s->observables & SCENE_OBS_CLUSTERS) && rc->cl) {
		ed_state(rc->ed, rc->pos, NULL);
		if (clusters_compute(rc->cl, rc->pos, s->box, s->radius, s->cluster_delta * 2.0 * s->radius,
		                     &r->clusters) != 0)
			return RUN_ENOMEM;
	}
	return RUN_OK;
}

static int emit_progress(run_t *r, run_emit_fn emit, void *ctx)
{
	int ret = sample(r, &r->rec, RUN_PROGRESS);
	if (ret == RUN_OK && emit(&r->rec, ctx))
		ret = RUN_EMIT;
	return ret;
}

/* A snapshot of the present state (the dynamics are not touched). */
static int emit_snapshot(run_t *r, run_emit_fn emit, void *ctx)
{
	ed_sample_t sm;
	run_record_t rec;
	ed_totals(r->ed, &sm);
	memset(&rec, 0, sizeof(rec));
	rec.kind = RUN_SNAPSHOT;
	rec.dim = r->s->dim;
	rec.n = r->s->count;
	rec.time = sm.time;
	rec.events = sm.events;
	rec.collisions = sm.collisions;
	rec.collisions_per_particle = 2.0 * (double)sm.collisions / (double)r->s->count;
	rec.wall_seconds = wall_seconds(r);
	rec.kinetic_energy = sm.kinetic_energy;
	ed_state(r->ed, r->pos, r->vel);
	rec.pos = r->pos;
	rec.vel = r->vel;
	r->st.snap_events = sm.events;
	return emit(&rec, ctx) ? RUN_EMIT : RUN_OK;
}

static run_t *create(const scene_t *s, const run_opts_t *opts, int blank, int *err, char *msg, size_t msglen)
{
	run_t *r = NULL;
	int e = 0;

	if (s->method != SCENE_METHOD_ED) {
		if (msg && msglen)
			snprintf(msg, msglen, "method: \"%s\" is not implemented yet (use \"ed\")",
			         scene_method_name(s->method));
		*err = RUN_EMETHOD;
		return NULL;
	}
	r = calloc(1, sizeof(*r));
	if (!r)
		goto nomem;
	r->s = s;
	if (opts)
		r->opts = *opts;
	r->st = (run_state_t){.k_out = 1, .k_snap = 1, .k_ckpt = 1, .snap_events = UINT64_MAX};
	r->ed = blank ? ed_create_blank(s, &e, msg, msglen) : ed_create(s, &e, msg, msglen);
	if (!r->ed) {
		*err = e == ED_ENOMEM ? RUN_ENOMEM : RUN_ESETUP;
		run_destroy(r);
		return NULL;
	}
	if ((s->observables & SCENE_OBS_CLUSTERS) || r->opts.snapshots) {
		r->pos = malloc(s->count * s->dim * sizeof(double));
		if (!r->pos)
			goto nomem;
	}
	if (s->observables & SCENE_OBS_CLUSTERS) {
		r->cl = clusters_create(s->dim, s->count);
		if (!r->cl)
			goto nomem;
	}
	if (r->opts.snapshots) {
		r->vel = malloc(s->count * s->dim * sizeof(double));
		if (!r->vel)
			goto nomem;
	}
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
	return create(s, opts, 0, err, msg, msglen);
}

run_t *run_create_blank(const scene_t *s, const run_opts_t *opts, int *err, char *msg, size_t msglen)
{
	return create(s, opts, 1, err, msg, msglen);
}

int run_restore_finish(run_t *r, char *msg, size_t msglen)
{
	if (ed_restore_finish(r->ed, msg, msglen) != ED_OK)
		return RUN_ERESTORE;
	r->t0 = r->ckpt_wall = wall_now();
	return RUN_OK;
}

void run_destroy(run_t *r)
{
	if (!r)
		return;
	clusters_destroy(r->cl);
	free(r->pos);
	free(r->vel);
	ed_destroy(r->ed);
	free(r);
}

struct ed *run_ed(run_t *r) { return r->ed; }
void run_get_state(const run_t *r, run_state_t *st)
{
	*st = r->st;
	st->wall_before = wall_seconds(r);
}
void run_set_state(run_t *r, const run_state_t *st) { r->st = *st; }

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

int run_summary(run_t *r, run_emit_fn emit, void *ctx)
{
	run_record_t sum = r->rec;
	if (r->status == RUN_INTERRUPTED && r->opts.checkpoints) {
		/* stopped for a checkpoint: totals now, without sampling */
		ed_sample_t sm;
		ed_totals(r->ed, &sm);
		sum.time = sm.time;
		sum.events = sm.events;
		sum.collisions = sm.collisions;
		sum.collisions_per_particle = 2.0 * (double)sm.collisions / (double)r->s->count;
		sum.kinetic_energy = sm.kinetic_energy;
		sum.temperature = 2.0 * sm.kinetic_energy / (r->s->dim * (double)r->s->count);
		memcpy(sum.momentum, sm.momentum, sizeof(sum.momentum));
		sum.elastic_by_tc = sm.elastic_by_tc;
	}
	sum.kind = RUN_SUMMARY;
	sum.dim = r->s->dim;
	sum.n = r->s->count;
	sum.have = r->s->observables;
	sum.have_interval = 0;
	sum.status = r->status;
	sum.wall_seconds = wall_seconds(r);
	sum.events_per_second = sum.wall_seconds > 0 ? sum.events / sum.wall_seconds : 0.0;
	sum.collisions_per_second = sum.wall_seconds > 0 ? sum.collisions / sum.wall_seconds : 0.0;
	sum.memory_bytes = ed_memory(r->ed);
	ed_cells(r->ed, sum.cells);
	return emit(&sum, ctx) ? RUN_EMIT : RUN_OK;
}

int run_go(run_t *r, run_emit_fn emit, void *ctx, const volatile sig_atomic_t *stop,
           char *msg, size_t msglen)
{
	const scene_t *s = r->s;
	const uint64_t n = s->count;
	int ret = RUN_OK;

	/* Stop and checkpoint schedules: each is a time or a collision count. */
	const int until_time = s->until.kind == SCENE_CLOCK_TIME;
	const double t_until = until_time ? s->until.value : INFINITY;
	const uint64_t c_until = until_time ? UINT64_MAX : cpp_to_collisions(s->until.value, n);
	const scene_when_t none = {SCENE_CLOCK_NONE, 0.0};
	const scene_when_t *snaps = r->opts.snapshots ? &s->snapshots : &none;
	const int ckpt_time = r->opts.checkpoints && s->checkpoint.kind == SCENE_CLOCK_TIME;
	const int ckpt_wall = r->opts.checkpoints && s->checkpoint.kind == SCENE_CLOCK_WALL;

	r->status = RUN_COMPLETED;
	if (!r->st.started) {
		if ((ret = emit_progress(r, emit, ctx)) != RUN_OK)
			goto cleanup;
		if (r->opts.snapshots && (ret = emit_snapshot(r, emit, ctx)) != RUN_OK)
			goto cleanup;
		r->st.started = 1;
	}
	for (;;) {
		double t_stop = fmin(fmin(sched_time(&s->every, r->st.k_out), t_until),
		                     sched_time(snaps, r->st.k_snap));
		uint64_t c_stop = sched_coll(&s->every, r->st.k_out, n);
		if (c_until < c_stop) c_stop = c_until;
		if (sched_coll(snaps, r->st.k_snap, n) < c_stop) c_stop = sched_coll(snaps, r->st.k_snap, n);
		if (ckpt_time)
			t_stop = fmin(t_stop, sched_time(&s->checkpoint, r->st.k_ckpt));

		int e = ed_advance(r->ed, t_stop, c_stop, RUN_CHUNK_EVENTS);
		double t = ed_time(r->ed);
		uint64_t c = ed_collisions(r->ed);
		int done = (until_time && t >= t_until) || (!until_time && c >= c_until);
		if (e == ED_QUIESCENT && !done && !until_time) {
			r->status = RUN_QUIESCENT;   /* the collision target can never be reached */
			done = 1;
		}
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
		if (due_snap || (done && r->opts.snapshots && r->st.snap_events != ed_events(r->ed))) {
			if ((ret = emit_snapshot(r, emit, ctx)) != RUN_OK)
				goto cleanup;
			sched_skip(snaps, &r->st.k_snap, t, c, n);
		}
		if (done)
			return run_summary(r, emit, ctx);
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
	};
	return (unsigned)st < sizeof(names) / sizeof(names[0]) ? names[st] : "unknown";
}
