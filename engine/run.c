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

typedef struct {
	const scene_t *s;
	ed_t *ed;
	clusters_t *cl;
	double *pos;
	double t0;
} run_ctx_t;

static int sample(run_ctx_t *rc, run_record_t *r, run_kind_t kind)
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
	r->wall_seconds = wall_now() - rc->t0;
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

int run_scene(const scene_t *s, run_emit_fn emit, void *ctx,
              const volatile sig_atomic_t *stop, char *msg, size_t msglen)
{
	run_ctx_t rc = {.s = s};
	run_record_t rec;
	int ret = RUN_OK, err = 0;

	if (s->method != SCENE_METHOD_ED) {
		if (msg && msglen)
			snprintf(msg, msglen, "method: \"%s\" is not implemented yet (use \"ed\")",
			         scene_method_name(s->method));
		return RUN_EMETHOD;
	}
	rc.ed = ed_create(s, &err, msg, msglen);
	if (!rc.ed) {
		ret = err == ED_ENOMEM ? RUN_ENOMEM : RUN_ESETUP;
		goto cleanup;
	}
	if (s->observables & SCENE_OBS_CLUSTERS) {
		rc.cl = clusters_create(s->dim, s->count);
		rc.pos = malloc(s->count * s->dim * sizeof(double));
		if (!rc.cl || !rc.pos) {
			ret = RUN_ENOMEM;
			goto cleanup;
		}
	}
	rc.t0 = wall_now();

	/* Output and stop schedules: each is a time or a collision count. */
	const int out_time = s->every.kind == SCENE_CLOCK_TIME;
	const int until_time = s->until.kind == SCENE_CLOCK_TIME;
	const double t_until = until_time ? s->until.value : INFINITY;
	const uint64_t c_until = until_time ? UINT64_MAX : cpp_to_collisions(s->until.value, s->count);
	uint64_t k_out = 1;
	run_status_t status = RUN_COMPLETED;

	if ((ret = sample(&rc, &rec, RUN_PROGRESS)) != RUN_OK)
		goto cleanup;
	if (emit(&rec, ctx)) {
		ret = RUN_EMIT;
		goto cleanup;
	}
	for (;;) {
		double t_out = out_time ? (double)k_out * s->every.value : INFINITY;
		uint64_t c_out = out_time ? UINT64_MAX : cpp_to_collisions((double)k_out * s->every.value, s->count);
		double t_stop = t_out < t_until ? t_out : t_until;
		uint64_t c_stop = c_out < c_until ? c_out : c_until;

		int r = ed_advance(rc.ed, t_stop, c_stop, RUN_CHUNK_EVENTS);
		double t = ed_time(rc.ed);
		uint64_t c = ed_collisions(rc.ed);
		int done = (until_time && t >= t_until) || (!until_time && c >= c_until);
		if (r == ED_QUIESCENT && !done && !until_time) {
			status = RUN_QUIESCENT;   /* the collision target can never be reached */
			done = 1;
		}
		int due = out_time ? t >= t_out : c >= c_out;
		if (stop && *stop && !done) {
			status = RUN_INTERRUPTED;
			done = 1;
		}
		if (due || done) {
			if ((ret = sample(&rc, &rec, RUN_PROGRESS)) != RUN_OK)
				goto cleanup;
			if (emit(&rec, ctx)) {
				ret = RUN_EMIT;
				goto cleanup;
			}
			/* Skip output times already passed (a long jump in a quiescent
			 * or very dilute system emits one record, not thousands). */
			while (out_time ? (double)k_out * s->every.value <= t
			                : cpp_to_collisions((double)k_out * s->every.value, s->count) <= c)
				k_out++;
		}
		if (done)
			break;
	}

	/* Summary: totals over the production run. */
	run_record_t sum = rec;
	sum.kind = RUN_SUMMARY;
	sum.have_interval = 0;
	sum.status = status;
	sum.wall_seconds = wall_now() - rc.t0;
	sum.events_per_second = sum.wall_seconds > 0 ? sum.events / sum.wall_seconds : 0.0;
	sum.collisions_per_second = sum.wall_seconds > 0 ? sum.collisions / sum.wall_seconds : 0.0;
	sum.memory_bytes = ed_memory(rc.ed);
	ed_cells(rc.ed, sum.cells);
	if (emit(&sum, ctx))
		ret = RUN_EMIT;

cleanup:
	if (ret == RUN_ENOMEM && msg && msglen)
		snprintf(msg, msglen, "out of memory");
	clusters_destroy(rc.cl);
	free(rc.pos);
	ed_destroy(rc.ed);
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
