/* One dsmc system over all MPI ranks: migrant exchange and exact sums per step (MPI), the output schedule, reduced records. */
#include <math.h>
#include <mpi.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "dsmcrun.h"
#include "mc/dsmc.h"

/* Room for the arriving records, kept between steps. */
typedef struct {
	double *buf;
	size_t cap;
	int *scnt, *sdis, *rcnt, *rdis;
	uint64_t *c64;
	/* hsmc: the grid's counts and means, the chain's events */
	double *grid, *mine, *ev;
	size_t ev_cap;
	int *gcnt, *gdis;
} xbuf_t;

/* hsmc's cell-cell collisions over the ranks (dsmcp.h: grid, chain in rank
 * order, the last rank's list to all). 0 or DSMCP_ENOMEM (on every rank). */
static int cell_chain(dsmcp_t *d, xbuf_t *x, int P, int rank)
{
	const int W = dsmcp_hs_width(d), E = DSMCP_HS_EVENT;
	int p0, p1, nc[3], bad = 0;
	dsmcp_slab(d, &p0, &p1, nc);
	const int D = dsmcp_dim(d);
	size_t ncells = 1;
	for (int a = 0; a < D; a++)
		ncells *= (size_t)nc[a];
	if (!x->grid) {
		x->grid = malloc(ncells * (size_t)W * sizeof(double));
		x->mine = malloc((ncells / (size_t)P + (size_t)nc[0] * (D == 3 ? (size_t)nc[1] : 1) + 1) * (size_t)W *
		                 sizeof(double) * 2);
		x->gcnt = malloc((size_t)P * 2 * sizeof(int));
		bad = !x->grid || !x->mine || !x->gcnt || ncells * (size_t)W > INT32_MAX;
	}
	MPI_Allreduce(MPI_IN_PLACE, &bad, 1, MPI_INT, MPI_MAX, MPI_COMM_WORLD);
	if (bad)
		return DSMCP_ENOMEM;
	x->gdis = x->gcnt + P;
	int n = (int)(dsmcp_hs_cells(d, x->mine) * (size_t)W);
	MPI_Allgather(&n, 1, MPI_INT, x->gcnt, 1, MPI_INT, MPI_COMM_WORLD);
	for (int r = 0, off = 0; r < P; r++) {
		x->gdis[r] = off;
		off += x->gcnt[r];
	}
	MPI_Allgatherv(x->mine, n, MPI_DOUBLE, x->grid, x->gcnt, x->gdis, MPI_DOUBLE, MPI_COMM_WORLD);
	dsmcp_hs_grid(d, x->grid);
	/* the chain: rank r after rank r - 1 */
	uint64_t nin = 0, nout = 0;
	const double *out = NULL;
	if (rank > 0) {
		MPI_Recv(&nin, 1, MPI_UINT64_T, rank - 1, 15, MPI_COMM_WORLD, MPI_STATUS_IGNORE);
		if (nin > x->ev_cap) {
			double *e = realloc(x->ev, nin * E * sizeof(double));
			if (e) {
				x->ev = e;
				x->ev_cap = nin;
			}
		}
		bad = nin > x->ev_cap;   /* then the data is dropped below and every rank fails */
		MPI_Recv(bad ? NULL : x->ev, bad ? 0 : (int)(nin * E), MPI_DOUBLE, rank - 1, 16, MPI_COMM_WORLD,
		         MPI_STATUS_IGNORE);
	}
	size_t no = 0;
	if (!bad && dsmcp_hs_turn(d, x->ev, (size_t)nin, &out, &no) != DSMCP_OK)
		bad = 1;
	nout = bad ? 0 : no;
	if (rank + 1 < P) {
		MPI_Send(&nout, 1, MPI_UINT64_T, rank + 1, 15, MPI_COMM_WORLD);
		MPI_Send(out, (int)(nout * E), MPI_DOUBLE, rank + 1, 16, MPI_COMM_WORLD);
	}
	MPI_Allreduce(MPI_IN_PLACE, &bad, 1, MPI_INT, MPI_MAX, MPI_COMM_WORLD);
	if (bad)
		return DSMCP_ENOMEM;
	/* the last rank's list to every rank */
	MPI_Bcast(&nout, 1, MPI_UINT64_T, P - 1, MPI_COMM_WORLD);
	if (rank != P - 1 && nout > x->ev_cap) {
		double *e = realloc(x->ev, nout * E * sizeof(double));
		if (e) {
			x->ev = e;
			x->ev_cap = nout;
		}
	}
	bad = rank != P - 1 && nout > x->ev_cap;
	MPI_Allreduce(MPI_IN_PLACE, &bad, 1, MPI_INT, MPI_MAX, MPI_COMM_WORLD);
	if (bad)
		return DSMCP_ENOMEM;
	double *list = rank == P - 1 ? (double *)out : x->ev;
	MPI_Bcast(list, (int)(nout * E), MPI_DOUBLE, P - 1, MPI_COMM_WORLD);
	dsmcp_hs_final(d, list, (size_t)nout);
	return DSMCP_OK;
}

/* CPU seconds of this process (bench figures independent of the sharing of cores). */
static double cpu_now(void)
{
	struct timespec ts;
	clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
	return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

static int step_x(dsmcp_t *d, double t_stop, dsmcrun_stats_t *st, xbuf_t *x, int P, int rank)
{
	int last;
	double w0 = MPI_Wtime(), wc = 0, u0 = cpu_now(), uc = 0, cu0 = 0;
	double dt = dsmcp_next_dt(d, t_stop, &last);
	if (!isfinite(dt))
		return DSMCP_QUIESCENT;
	if (dsmcp_hsmc(d)) {
		double c0 = MPI_Wtime(), cu = cpu_now();
		int hr = cell_chain(d, x, P, rank);
		wc += MPI_Wtime() - c0, uc += cpu_now() - cu;   /* the chain is serial: counted as waiting */
		if (hr != DSMCP_OK)
			return hr;
	}
	int rc = dsmcp_move(d, dt), bad = rc != DSMCP_OK;
	const int R = dsmcp_record_doubles(d);
	const size_t *cnt;
	const double *box = dsmcp_outbox(d, &cnt);
	uint64_t total_in = 0, sent = 0, msgs = 0;
	for (int r = 0; r < P; r++) {
		x->c64[r] = bad ? 0 : cnt[r];
		if (r != rank && x->c64[r]) {
			sent += x->c64[r];
			msgs++;
		}
	}
	double c0 = MPI_Wtime();
	cu0 = cpu_now();
	uint64_t *rc64 = x->c64 + P;
	MPI_Alltoall(x->c64, 1, MPI_UINT64_T, rc64, 1, MPI_UINT64_T, MPI_COMM_WORLD);
	wc += MPI_Wtime() - c0, uc += cpu_now() - cu0;
	size_t off = 0;
	for (int r = 0; r < P; r++) {
		total_in += rc64[r];
		/* Alltoallv counts are ints: a step's migrants must stay below 2^31 / R doubles per pair */
		if (x->c64[r] * (uint64_t)R > INT32_MAX || rc64[r] * (uint64_t)R > INT32_MAX)
			bad = 1;
		x->scnt[r] = (int)(x->c64[r] * (uint64_t)R);
		x->sdis[r] = (int)(off * (size_t)R);
		off += x->c64[r];
	}
	if (off * (size_t)R > INT32_MAX || total_in * (uint64_t)R > INT32_MAX)
		bad = 1;
	if (!bad && total_in > x->cap) {
		size_t cap = total_in + total_in / 2 + 64;
		double *b = realloc(x->buf, cap * (size_t)R * sizeof(double));
		if (b) {
			x->buf = b;
			x->cap = cap;
		} else {
			bad = 1;
		}
	}
	c0 = MPI_Wtime();
	cu0 = cpu_now();
	MPI_Allreduce(MPI_IN_PLACE, &bad, 1, MPI_INT, MPI_MAX, MPI_COMM_WORLD);
	if (bad) {
		wc += MPI_Wtime() - c0, uc += cpu_now() - cu0;
		return DSMCP_ENOMEM;
	}
	size_t roff = 0;
	for (int r = 0; r < P; r++) {
		x->rcnt[r] = (int)(rc64[r] * (uint64_t)R);
		x->rdis[r] = (int)(roff * (size_t)R);
		roff += rc64[r];
	}
	static const double none = 0;
	MPI_Alltoallv(box ? box : &none, x->scnt, x->sdis, MPI_DOUBLE, x->buf ? x->buf : (double *)&none, x->rcnt, x->rdis,
	              MPI_DOUBLE, MPI_COMM_WORLD);
	wc += MPI_Wtime() - c0, uc += cpu_now() - cu0;
	size_t nlow = 0;
	for (int r = 0; r < rank; r++)
		nlow += rc64[r];
	rc = dsmcp_arrive(d, x->buf, (size_t)total_in, nlow);
	dsmcp_sums_t part, sum;
	if (rc == DSMCP_OK) {
		dsmcp_collide(d, dt, &part);
	} else {
		memset(&part, 0, sizeof part);
	}
	int failed = rc != DSMCP_OK;
	c0 = MPI_Wtime();
	cu0 = cpu_now();
	MPI_Allreduce(MPI_IN_PLACE, &failed, 1, MPI_INT, MPI_MAX, MPI_COMM_WORLD);
	if (failed) {
		wc += MPI_Wtime() - c0, uc += cpu_now() - cu0;
		return rc != DSMCP_OK ? rc : DSMCP_EINVAL;
	}
	MPI_Allreduce(part.w, sum.w, DSMCP_NSUM, MPI_UINT64_T, MPI_SUM, MPI_COMM_WORLD);
	wc += MPI_Wtime() - c0, uc += cpu_now() - cu0;
	dsmcp_finish(d, &sum, dt, last, t_stop);
	if (st) {
		st->steps++;
		st->migrants += sent;
		st->bytes += sent * (uint64_t)R * sizeof(double);
		st->messages += msgs;
		st->seconds += MPI_Wtime() - w0;
		st->comm_seconds += wc;
		st->cpu_compute += cpu_now() - u0 - uc;
	}
	return DSMCP_OK;
}

static int xbuf_init(xbuf_t *x, int P)
{
	memset(x, 0, sizeof *x);
	x->scnt = calloc((size_t)P * 4, sizeof(int));
	x->c64 = calloc((size_t)P * 2, sizeof(uint64_t));
	if (!x->scnt || !x->c64)
		return -1;
	x->sdis = x->scnt + P;
	x->rcnt = x->scnt + 2 * P;
	x->rdis = x->scnt + 3 * P;
	return 0;
}

static void xbuf_free(xbuf_t *x)
{
	free(x->grid);
	free(x->mine);
	free(x->ev);
	free(x->gcnt);
	free(x->buf);
	free(x->scnt);
	free(x->c64);
}

int dsmcrun_step(dsmcp_t *d, double t_stop, dsmcrun_stats_t *st)
{
	int P, rank;
	xbuf_t x;
	MPI_Comm_size(MPI_COMM_WORLD, &P);
	MPI_Comm_rank(MPI_COMM_WORLD, &rank);
	int bad = xbuf_init(&x, P) != 0;
	MPI_Allreduce(MPI_IN_PLACE, &bad, 1, MPI_INT, MPI_MAX, MPI_COMM_WORLD);
	int rc = bad ? DSMCP_ENOMEM : step_x(d, t_stop, st, &x, P, rank);
	xbuf_free(&x);
	return rc;
}

dsmcp_t *dsmcrun_create(const scene_t *s, int rank, int size, char *msg, size_t msglen)
{
	int err = 0;
	dsmcp_t *d = NULL;
	/* The initial state of dsmc_create() (stream 0: the serial run's): for
	 * random positions generated directly, each rank keeping its slab;
	 * otherwise built whole on every rank (the set-up then holds the whole
	 * system once per rank). */
	if (dsmcp_direct_ok(s)) {
		d = dsmcp_create(s, NULL, 0, rank, size, &err, msg, msglen);
	} else {
		dsmc_t *init = dsmc_create(s, 0, &err, msg, msglen);
		if (init)
			d = dsmcp_create(s, init, 0, rank, size, &err, msg, msglen);
		dsmc_destroy(init);
	}
	int bad = d == NULL, any = 0;
	MPI_Allreduce(&bad, &any, 1, MPI_INT, MPI_MAX, MPI_COMM_WORLD);
	if (!any) {
		dsmcp_sums_t part, sum;
		dsmcp_initial_sums(d, &part);
		MPI_Allreduce(part.w, sum.w, DSMCP_NSUM, MPI_UINT64_T, MPI_SUM, MPI_COMM_WORLD);
		any = dsmcp_start(d, &sum) != DSMCP_OK;   /* the same outcome on every rank */
	}
	if (any && d) {
		dsmcp_destroy(d);
		d = NULL;
		if (msg && msglen)
			snprintf(msg, msglen, "run: the decomposed dsmc could not be built on every rank");
	}
	return d;
}

/* The record of the present state and the interval since the last one (collective). */
static void record(dsmcp_t *d, const scene_t *s, run_kind_t kind, double wall, uint64_t *coll_sample, run_record_t *r)
{
	dsmcp_totals_t t;
	double interval, eint, vir, red[4], mom[3] = {0, 0, 0};
	dsmcp_totals(d, &t);
	dsmcp_interval(d, &interval, &eint, &vir);
	dsmcp_momentum(d, mom);
	red[0] = vir;
	for (int a = 0; a < 3; a++)
		red[1 + a] = mom[a];
	MPI_Allreduce(MPI_IN_PLACE, red, 4, MPI_DOUBLE, MPI_SUM, MPI_COMM_WORLD);
	memset(r, 0, sizeof *r);
	r->kind = kind;
	r->dim = s->dim;
	r->n = s->count;
	r->time = t.time;
	r->events = t.moves;
	r->collisions = t.collisions;
	r->collisions_per_particle = 2.0 * (double)t.collisions / (double)s->count;
	r->wall_seconds = wall;
	r->vmax_raised = t.vmax_raised;
	r->cell_collisions = t.cell_collisions;
	r->rejected_moves = t.rejected;
	r->have = s->observables;
	r->kinetic_energy = t.kinetic_energy;
	r->particles = s->count;
	r->temperature = 2.0 * t.kinetic_energy / (s->dim * (double)s->count);
	for (int a = 0; a < 3; a++)
		r->momentum[a] = a < s->dim ? red[1 + a] : 0.0;
	if (kind == RUN_PROGRESS && interval > 0.0) {
		double t_avg = 2.0 * eint / (s->dim * (double)s->count * interval);
		double vol = scene_box_volume(s);
		r->have_interval = 1;
		r->pressure = ((double)s->count * t_avg + red[0] / (s->dim * interval)) / vol;
		r->compressibility = t_avg > 0.0 ? r->pressure * vol / ((double)s->count * t_avg) : NAN;
		r->collision_rate = 2.0 * (double)(t.collisions - *coll_sample) / ((double)s->count * interval);
	}
	if (kind == RUN_PROGRESS)
		*coll_sample = t.collisions;
}

/* A frame: every rank's particles gathered to rank 0 (MPI_Gatherv), put in
 * identity order (the scene's particle order) and emitted there. */
static int emit_frame(dsmcp_t *d, const scene_t *s, int rank, int size, double wall, run_emit_fn emit, void *ctx,
                      int *bad_out)
{
	const int D = s->dim, W = 2 * D + 1;
	const size_t N = (size_t)s->count;
	size_t nl = dsmcp_local(d, NULL, NULL, NULL);
	double *mine = malloc((nl + 1) * (size_t)W * sizeof(double));
	uint64_t *id = malloc((nl + 1) * sizeof(uint64_t));
	double *x = malloc((nl + 1) * (size_t)D * sizeof(double)), *v = malloc((nl + 1) * (size_t)D * sizeof(double));
	double *all = NULL, *pos = NULL, *vel = NULL;
	int *cnt = NULL, *dis = NULL;
	int bad = !mine || !id || !x || !v || nl * (size_t)W > INT32_MAX;
	if (rank == 0) {
		all = malloc((N + 1) * (size_t)W * sizeof(double));
		pos = malloc(N * (size_t)D * sizeof(double));
		vel = malloc(N * (size_t)D * sizeof(double));
		cnt = malloc((size_t)size * 2 * sizeof(int));
		bad = bad || !all || !pos || !vel || !cnt || N * (size_t)W > INT32_MAX;
		dis = cnt ? cnt + size : NULL;
	}
	MPI_Allreduce(MPI_IN_PLACE, &bad, 1, MPI_INT, MPI_MAX, MPI_COMM_WORLD);
	int ret = RUN_OK;
	if (bad) {
		ret = RUN_ENOMEM;
		goto cleanup;
	}
	dsmcp_local(d, id, x, v);
	for (size_t k = 0; k < nl; k++) {
		double *r = &mine[k * W];
		memcpy(r, &x[k * D], D * sizeof(double));
		memcpy(r + D, &v[k * D], D * sizeof(double));
		r[2 * D] = (double)id[k];
	}
	int n = (int)(nl * (size_t)W);
	MPI_Gather(&n, 1, MPI_INT, cnt, 1, MPI_INT, 0, MPI_COMM_WORLD);
	if (rank == 0)
		for (int r = 0, off = 0; r < size; r++) {
			dis[r] = off;
			off += cnt[r];
		}
	MPI_Gatherv(mine, n, MPI_DOUBLE, all, cnt, dis, MPI_DOUBLE, 0, MPI_COMM_WORLD);
	int failed = 0;
	if (rank == 0) {
		for (size_t k = 0; k < N; k++) {
			const double *r = &all[k * W];
			size_t i = (size_t)r[2 * D];
			memcpy(&pos[i * D], r, D * sizeof(double));
			memcpy(&vel[i * D], r + D, D * sizeof(double));
		}
		dsmcp_totals_t t;
		dsmcp_totals(d, &t);
		run_record_t rec;
		memset(&rec, 0, sizeof rec);
		rec.kind = RUN_SNAPSHOT;
		rec.dim = D;
		rec.n = N;
		rec.time = t.time;
		rec.events = t.moves;
		rec.collisions = t.collisions;
		rec.collisions_per_particle = 2.0 * (double)t.collisions / (double)N;
		rec.wall_seconds = wall;
		rec.kinetic_energy = t.kinetic_energy;
		rec.pos = pos;
		rec.vel = vel;
		failed = emit && emit(&rec, ctx) != 0;
	}
	MPI_Bcast(&failed, 1, MPI_INT, 0, MPI_COMM_WORLD);
	if (failed)
		ret = RUN_EMIT;
cleanup:
	*bad_out = ret != RUN_OK;
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

/* Rank 0 emits; the outcome is shared (collective). */
static int emit_all(int rank, run_emit_fn emit, void *ctx, const run_record_t *r)
{
	int bad = rank == 0 && emit && emit(r, ctx) != 0;
	MPI_Bcast(&bad, 1, MPI_INT, 0, MPI_COMM_WORLD);
	return bad;
}

int dsmcrun_run(const scene_t *s, int rank, int size, int frames, run_emit_fn emit, void *ctx,
                const volatile sig_atomic_t *stop, char *msg, size_t msglen)
{
	int fbad = 0;
	uint64_t k_snap = 1, snap_steps = UINT64_MAX;
	int ret = RUN_OK;
	xbuf_t x;
	run_record_t rec;
	uint64_t coll_sample = 0;
	dsmcp_t *d = dsmcrun_create(s, rank, size, msg, msglen);
	if (!d)
		return RUN_ESETUP;
	int bad = xbuf_init(&x, size) != 0;
	MPI_Allreduce(MPI_IN_PLACE, &bad, 1, MPI_INT, MPI_MAX, MPI_COMM_WORLD);
	if (bad) {
		if (msg && msglen)
			snprintf(msg, msglen, "run: out of memory");
		ret = RUN_ENOMEM;
		goto cleanup;
	}
	const double N = (double)s->count, t0 = MPI_Wtime();
	/* targets: times (the step lands on them) or collision counts (the step that reaches one) */
	const int end_time = s->until.kind == SCENE_CLOCK_TIME;
	const double t_end = end_time ? s->until.value : INFINITY;
	const double c_end = end_time ? INFINITY : s->until.value * N / 2;
	const int out_time = s->every.kind == SCENE_CLOCK_TIME, out_cpp = s->every.kind == SCENE_CLOCK_CPP;
	const double every = s->every.value;
	uint64_t k_out = 1;
	run_status_t status = RUN_COMPLETED;
	record(d, s, RUN_PROGRESS, 0.0, &coll_sample, &rec);
	if (emit_all(rank, emit, ctx, &rec)) {
		ret = RUN_EMIT;
		goto cleanup;
	}
	/* frames (output.snapshots): the first state, at the end of the step that
	 * reaches each snapshot time or collision count (steps are not cut for
	 * them, as run.c), and the last state */
	const int snap_time = s->snapshots.kind == SCENE_CLOCK_TIME, snap_cpp = s->snapshots.kind == SCENE_CLOCK_CPP;
	if (frames) {
		if ((ret = emit_frame(d, s, rank, size, 0.0, emit, ctx, &fbad)) != RUN_OK)
			goto frame_failed;
		snap_steps = 0;
	}
	for (uint64_t n = 0;; n++) {
		dsmcp_totals_t t;
		dsmcp_totals(d, &t);
		const double C = (double)t.collisions;
		if (!(t.time < t_end) || C >= c_end)
			break;
		if (n % 64 == 0) {
			int halt = rank == 0 && stop && *stop;
			MPI_Bcast(&halt, 1, MPI_INT, 0, MPI_COMM_WORLD);
			if (halt) {
				status = RUN_INTERRUPTED;
				break;
			}
		}
		double t_stop = t_end;
		if (out_time && every > 0 && k_out * every < t_stop)
			t_stop = (double)k_out * every;
		int rc = step_x(d, t_stop, NULL, &x, size, rank);
		if (rc == DSMCP_QUIESCENT) {
			status = RUN_QUIESCENT;
			break;
		}
		if (rc != DSMCP_OK) {
			if (msg && msglen)
				snprintf(msg, msglen, "run: %s in the decomposed dsmc step",
				         rc == DSMCP_ENOMEM ? "out of memory" : "a migrant outside its slab");
			ret = rc == DSMCP_ENOMEM ? RUN_ENOMEM : RUN_ESETUP;
			goto cleanup;
		}
		dsmcp_totals(d, &t);
		int due = 0;
		if (every > 0 && (out_time || out_cpp)) {
			const double now = out_time ? t.time : 2.0 * (double)t.collisions / N;
			while ((double)k_out * every <= now) {   /* instants passed in one step count once */
				due = 1;
				k_out++;
			}
		}
		const int done = !(t.time < t_end) || (double)t.collisions >= c_end;
		if (due && !done) {
			record(d, s, RUN_PROGRESS, MPI_Wtime() - t0, &coll_sample, &rec);
			if (emit_all(rank, emit, ctx, &rec)) {
				ret = RUN_EMIT;
				goto cleanup;
			}
		}
		int due_snap = 0;
		if (frames && (snap_time || snap_cpp) && s->snapshots.value > 0) {
			const double now = snap_time ? t.time : 2.0 * (double)t.collisions / N;
			while ((double)k_snap * s->snapshots.value <= now) {
				due_snap = 1;
				k_snap++;
			}
		}
		if (due_snap && !done) {
			if ((ret = emit_frame(d, s, rank, size, MPI_Wtime() - t0, emit, ctx, &fbad)) != RUN_OK)
				goto frame_failed;
			snap_steps = t.steps;
		}
	}
	record(d, s, RUN_PROGRESS, MPI_Wtime() - t0, &coll_sample, &rec);
	if (emit_all(rank, emit, ctx, &rec)) {
		ret = RUN_EMIT;
		goto cleanup;
	}
	if (frames) {
		dsmcp_totals_t t;
		dsmcp_totals(d, &t);
		if (t.steps != snap_steps && (ret = emit_frame(d, s, rank, size, MPI_Wtime() - t0, emit, ctx, &fbad)) != RUN_OK)
			goto frame_failed;
	}
	record(d, s, RUN_SUMMARY, MPI_Wtime() - t0, &coll_sample, &rec);
	rec.status = status;
	rec.events_per_second = rec.wall_seconds > 0 ? rec.events / rec.wall_seconds : 0.0;
	rec.collisions_per_second = rec.wall_seconds > 0 ? rec.collisions / rec.wall_seconds : 0.0;
	uint64_t mem = dsmcp_memory(d);
	MPI_Allreduce(MPI_IN_PLACE, &mem, 1, MPI_UINT64_T, MPI_SUM, MPI_COMM_WORLD);
	rec.memory_bytes = mem;
	int p0, p1;
	dsmcp_slab(d, &p0, &p1, rec.cells);
	if (emit_all(rank, emit, ctx, &rec))
		ret = RUN_EMIT;
frame_failed:
	if (ret == RUN_ENOMEM && msg && msglen)
		snprintf(msg, msglen, "run: out of memory gathering a frame on rank 0");
cleanup:
	xbuf_free(&x);
	dsmcp_destroy(d);
	return ret;
}
