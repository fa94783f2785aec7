/* Run driver: output schedule, stop conditions and observables around the engines (ed, dsmc/hsmc). */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "dsmc.h"
#include "ed.h"
#include "run.h"

/* Work between polls of the stop flag: ~0.1 s (events for ed, particle moves for dsmc). */
#define RUN_CHUNK_EVENTS 200000u
#define RUN_CHUNK_MOVES 4000000u

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

/* One replica: the engine state (ed or dsmc/hsmc) and the output schedule. */
struct run {
	scene_t s;                   /* copy, with the replica's stream */
	ed_t *ed;
	dsmc_t *mc;
	uint64_t mc_chunk;           /* dsmc steps between polls of the stop flag */
	clusters_t *cl;
	double *pos;
	double t0;
	char warning[512];
	int out_time, until_time;
	double t_until;
	uint64_t c_until, k_out;
	int started, done;
	run_status_t status;
	run_record_t last;
};

/* The engines' common ground: one sample. */
typedef struct {
	double time, interval, kinetic_energy, momentum[3], ekin_time_integral, virial;
	uint64_t events, collisions, interval_collisions, elastic_by_tc;
	uint64_t vmax_raised, cell_collisions, rejected_moves;
} smp_t;

static void eng_sample(run_t *rc, smp_t *o)
{
	memset(o, 0, sizeof(*o));
	if (rc->ed) {
		ed_sample_t sm;
		ed_sample(rc->ed, &sm);
		o->time = sm.time, o->interval = sm.interval, o->kinetic_energy = sm.kinetic_energy;
		memcpy(o->momentum, sm.momentum, sizeof(o->momentum));
		o->ekin_time_integral = sm.ekin_time_integral, o->virial = sm.virial;
		o->events = sm.events, o->collisions = sm.collisions;
		o->interval_collisions = sm.interval_collisions, o->elastic_by_tc = sm.elastic_by_tc;
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
	}
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
	r->wall_seconds = wall_now() - rc->t0;
	r->elastic_by_tc = sm.elastic_by_tc;
	r->vmax_raised = sm.vmax_raised;
	r->cell_collisions = sm.cell_collisions;
	r->rejected_moves = sm.rejected_moves;
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
		if (rc->ed)
			ed_state(rc->ed, rc->pos, NULL);
		else
			dsmc_state(rc->mc, rc->pos, NULL);
		if (clusters_compute(rc->cl, rc->pos, s->box, s->radius, s->cluster_delta * 2.0 * s->radius,
		                     &r->clusters) != 0)
			return RUN_ENOMEM;
	}
	return RUN_OK;
}

void run_close(run_t *rc)
{
	if (!rc)
		return;
	clusters_destroy(rc->cl);
	free(rc->pos);
	ed_destroy(rc->ed);
	dsmc_destroy(rc->mc);
	free(rc);
}

run_t *run_open(const scene_t *s, uint64_t stream, int *err, char *msg, size_t msglen)
{
	run_t *rc = calloc(1, sizeof(*rc));
	int e = 0;
	*err = RUN_ENOMEM;
	if (!rc)
		goto fail;
	rc->s = *s;
	rc->s.stream = stream;
	if (s->method == SCENE_METHOD_ED) {
		rc->ed = ed_create(&rc->s, &e, msg, msglen);
		if (!rc->ed) {
			*err = e == ED_ENOMEM ? RUN_ENOMEM : RUN_ESETUP;
			goto fail;
		}
	} else {
		dsmc_params_t pr;
		dsmc_params(&rc->s, &pr, rc->warning, sizeof(rc->warning));
		rc->mc = dsmc_create(&rc->s, stream, &e, msg, msglen);
		if (!rc->mc) {
			*err = e == DSMC_ENOMEM ? RUN_ENOMEM : RUN_ESETUP;
			goto fail;
		}
		rc->mc_chunk = RUN_CHUNK_MOVES / s->count + 1;
	}
	if (s->observables & SCENE_OBS_CLUSTERS) {
		rc->cl = clusters_create(s->dim, s->count);
		rc->pos = malloc(s->count * s->dim * sizeof(double));
		if (!rc->cl || !rc->pos)
			goto fail;
	}
	/* Output and stop schedules: each is a time or a collision count. */
	rc->out_time = s->every.kind == SCENE_CLOCK_TIME;
	rc->until_time = s->until.kind == SCENE_CLOCK_TIME;
	rc->t_until = rc->until_time ? s->until.value : INFINITY;
	rc->c_until = rc->until_time ? UINT64_MAX : cpp_to_collisions(s->until.value, s->count);
	rc->k_out = 1;
	rc->status = RUN_COMPLETED;
	rc->t0 = wall_now();
	*err = RUN_OK;
	return rc;
fail:
	if (*err == RUN_ENOMEM && msg && msglen)
		snprintf(msg, msglen, "out of memory");
	run_close(rc);
	return NULL;
}

int run_next(run_t *rc, const volatile sig_atomic_t *stop, run_record_t *rec, int *done_out)
{
	const scene_t *s = &rc->s;
	int ret;
	*done_out = rc->done;
	if (rc->done) {
		*rec = rc->last;
		return RUN_OK;
	}
	if (!rc->started) {
		rc->started = 1;
		if ((ret = sample(rc, rec, RUN_PROGRESS)) != RUN_OK)
			return ret;
		if (rc->warning[0])
			rec->warning = rc->warning;
		rc->last = *rec;
		rc->last.warning = NULL;
		return RUN_OK;
	}
	for (;;) {
		double t_out = rc->out_time ? (double)rc->k_out * s->every.value : INFINITY;
		uint64_t c_out = rc->out_time ? UINT64_MAX : cpp_to_collisions((double)rc->k_out * s->every.value, s->count);
		double t_stop = t_out < rc->t_until ? t_out : rc->t_until;
		uint64_t c_stop = c_out < rc->c_until ? c_out : rc->c_until;
		int quiescent;
		double t;
		uint64_t c;
		if (rc->ed) {
			quiescent = ed_advance(rc->ed, t_stop, c_stop, RUN_CHUNK_EVENTS) == ED_QUIESCENT;
			t = ed_time(rc->ed);
			c = ed_collisions(rc->ed);
		} else {
			quiescent = dsmc_advance(rc->mc, t_stop, c_stop, rc->mc_chunk) == DSMC_QUIESCENT;
			t = dsmc_time(rc->mc);
			c = dsmc_collisions(rc->mc);
		}
		int done = (rc->until_time && t >= rc->t_until) || (!rc->until_time && c >= rc->c_until);
		if (quiescent && !done && !rc->until_time) {
			rc->status = RUN_QUIESCENT;   /* the collision target can never be reached */
			done = 1;
		}
		int due = rc->out_time ? t >= t_out : c >= c_out;
		if (stop && *stop && !done) {
			rc->status = RUN_INTERRUPTED;
			done = 1;
		}
		if (due || done) {
			if ((ret = sample(rc, rec, RUN_PROGRESS)) != RUN_OK)
				return ret;
			/* Skip output times already passed (a long jump in a quiescent
			 * or very dilute system emits one record, not thousands). */
			while (rc->out_time ? (double)rc->k_out * s->every.value <= t
			                    : cpp_to_collisions((double)rc->k_out * s->every.value, s->count) <= c)
				rc->k_out++;
			rc->done = done;
			*done_out = done;
			rc->last = *rec;
			return RUN_OK;
		}
	}
}

void run_summary(run_t *rc, run_record_t *sum)
{
	*sum = rc->last;
	sum->kind = RUN_SUMMARY;
	sum->have_interval = 0;
	sum->warning = NULL;
	sum->status = rc->status;
	sum->wall_seconds = wall_now() - rc->t0;
	sum->events_per_second = sum->wall_seconds > 0 ? sum->events / sum->wall_seconds : 0.0;
	sum->collisions_per_second = sum->wall_seconds > 0 ? sum->collisions / sum->wall_seconds : 0.0;
	if (rc->ed) {
		sum->memory_bytes = ed_memory(rc->ed);
		ed_cells(rc->ed, sum->cells);
	} else {
		sum->memory_bytes = dsmc_memory(rc->mc);
		dsmc_cells(rc->mc, sum->cells);
	}
}

int run_scene(const scene_t *s, run_emit_fn emit, void *ctx,
              const volatile sig_atomic_t *stop, char *msg, size_t msglen)
{
	run_record_t rec;
	int ret = RUN_OK, done = 0;
	run_t *rc = run_open(s, s->stream, &ret, msg, msglen);
	if (!rc)
		return ret;
	while (!done) {
		if ((ret = run_next(rc, stop, &rec, &done)) != RUN_OK)
			goto cleanup;
		if (emit(&rec, ctx)) {
			ret = RUN_EMIT;
			goto cleanup;
		}
	}
	/* Summary: totals over the production run. */
	run_summary(rc, &rec);
	if (emit(&rec, ctx))
		ret = RUN_EMIT;
cleanup:
	if (ret == RUN_ENOMEM && msg && msglen)
		snprintf(msg, msglen, "out of memory");
	run_close(rc);
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
