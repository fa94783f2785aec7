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

/* One step; flags (may be NULL): rank 0's stop and wall-clock checkpoint flags in (0 elsewhere),
 * summed over the ranks in the step's own reduction out (so they cost no message of their own). */
static int step_x(dsmcp_t *d, double t_stop, dsmcrun_stats_t *st, xbuf_t *x, int P, int rank, uint64_t *flags)
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
	uint64_t in[DSMCP_NSUM + 2], out[DSMCP_NSUM + 2];
	memcpy(in, part.w, sizeof part.w);
	in[DSMCP_NSUM] = flags ? flags[0] : 0;
	in[DSMCP_NSUM + 1] = flags ? flags[1] : 0;
	MPI_Allreduce(in, out, DSMCP_NSUM + 2, MPI_UINT64_T, MPI_SUM, MPI_COMM_WORLD);
	memcpy(sum.w, out, sizeof sum.w);
	if (flags)
		flags[0] = out[DSMCP_NSUM], flags[1] = out[DSMCP_NSUM + 1];
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
	int rc = bad ? DSMCP_ENOMEM : step_x(d, t_stop, st, &x, P, rank, NULL);
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

/* MPI counts are ints: a part of more than INT32_MAX elements cannot go in one call. */
static int too_big(uint64_t n) { return n > INT32_MAX; }

/* The whole state gathered to rank 0 in the 1-rank order (collective):
 * on rank 0 ck->state is allocated and filled (the caller frees it; rank
 * 0's own part is copied in place, first: no second copy of it). 0 on
 * every rank, or -1 on every rank (out of memory, or a part too large for
 * one MPI call). */
static int gather_state(dsmcp_t *d, const scene_t *s, int rank, int size, ckpt_split_t *ck)
{
	const int D = s->dim;
	uint64_t c0, c1, ncells = 0;
	dsmcp_cells(d, &c0, &c1);
	size_t nl = dsmcp_local(d, NULL, NULL, NULL), nown = (size_t)(c1 - c0);
	const size_t bl = rank == 0 ? 0 : nl, bc = rank == 0 ? 0 : nown;   /* rank 0 writes into the state */
	double *x = malloc((bl + 1) * D * sizeof(double)), *v = malloc((bl + 1) * D * sizeof(double));
	double *rem = malloc((bc + 1) * sizeof(double));
	uint32_t *id = malloc((bl + 1) * sizeof(uint32_t)), *cnt = malloc((bc + 1) * sizeof(uint32_t));
	int *rc = NULL, *rd = NULL, *cc = NULL, *cd = NULL;
	int bad = !x || !v || !rem || !id || !cnt || too_big(nl * (uint64_t)D);
	if (rank == 0) {
		rc = calloc((size_t)size * 4, sizeof(int));
		bad = bad || !rc || too_big(s->count * (uint64_t)D) ||
		      dsmcp_cells_of(s, 0, size, &c0, &c1, &ncells, NULL, 0) != DSMCP_OK || too_big(ncells) ||
		      dsmcp_saved_alloc(&ck->state, D, s->count, ncells) != DSMCP_OK;
		if (rc)
			rd = rc + size, cc = rc + 2 * size, cd = rc + 3 * size;
		dsmcp_cells(d, &c0, &c1);
	}
	MPI_Allreduce(MPI_IN_PLACE, &bad, 1, MPI_INT, MPI_MAX, MPI_COMM_WORLD);
	if (bad)
		goto cleanup;
	dsmcp_saved_t *sv = &ck->state;
	if (rank == 0) {   /* the first part, in place */
		dsmcp_local(d, NULL, sv->pos, sv->vel);
		dsmcp_local_ids(d, sv->id);
		dsmcp_cell_state(d, sv->count, sv->rem);
	} else {
		dsmcp_local(d, NULL, x, v);
		dsmcp_local_ids(d, id);
		dsmcp_cell_state(d, cnt, rem);
	}
	int mine[2] = {(int)nl, (int)nown}, all[2 * 64], *both = NULL;
	both = size <= 64 ? all : malloc((size_t)size * 2 * sizeof(int));
	bad = both == NULL;
	MPI_Allreduce(MPI_IN_PLACE, &bad, 1, MPI_INT, MPI_MAX, MPI_COMM_WORLD);
	if (bad)
		goto cleanup;
	MPI_Gather(mine, 2, MPI_INT, both, 2, MPI_INT, 0, MPI_COMM_WORLD);
	if (rank == 0)
		for (int r = 0, ro = 0, co = 0; r < size; r++) {
			rc[r] = both[2 * r];
			rd[r] = ro;
			cc[r] = both[2 * r + 1];
			cd[r] = co;
			ro += rc[r];
			co += cc[r];
		}
	if (both != all)
		free(both);
	/* positions and velocities: D doubles a record; the root's part is in place (displacement 0) */
	const int root = rank == 0;
	MPI_Datatype rec;
	MPI_Type_contiguous(D, MPI_DOUBLE, &rec);
	MPI_Type_commit(&rec);
	MPI_Gatherv(root ? MPI_IN_PLACE : x, (int)nl, rec, root ? sv->pos : NULL, rc, rd, rec, 0, MPI_COMM_WORLD);
	MPI_Gatherv(root ? MPI_IN_PLACE : v, (int)nl, rec, root ? sv->vel : NULL, rc, rd, rec, 0, MPI_COMM_WORLD);
	MPI_Type_free(&rec);
	MPI_Gatherv(root ? MPI_IN_PLACE : id, (int)nl, MPI_UINT32_T, root ? sv->id : NULL, rc, rd, MPI_UINT32_T, 0,
	            MPI_COMM_WORLD);
	MPI_Gatherv(root ? MPI_IN_PLACE : cnt, (int)nown, MPI_UINT32_T, root ? sv->count : NULL, cc, cd, MPI_UINT32_T, 0,
	            MPI_COMM_WORLD);
	MPI_Gatherv(root ? MPI_IN_PLACE : rem, (int)nown, MPI_DOUBLE, root ? sv->rem : NULL, cc, cd, MPI_DOUBLE, 0,
	            MPI_COMM_WORLD);
	double vir = dsmcp_virial_part(d), vsum = 0;
	MPI_Reduce(&vir, &vsum, 1, MPI_DOUBLE, MPI_SUM, 0, MPI_COMM_WORLD);
	if (rank == 0) {
		dsmcp_clock(d, &sv->clock);
		sv->virial = vsum;
	}
cleanup:
	if (bad && rank == 0)
		dsmcp_saved_free(&ck->state);
	free(x);
	free(v);
	free(rem);
	free(id);
	free(cnt);
	free(rc);
	return bad ? -1 : 0;
}

/* Every rank's part of rank 0's saved state (collective): the records and
 * cells of its slab for this rank count, the clock to all, rank 0 the
 * virial. NULL on every rank on failure, with msg. */
static dsmcp_t *scatter_state(const scene_t *s, int rank, int size, const ckpt_split_t *ck, char *msg, size_t msglen)
{
	const int D = s->dim;
	uint64_t c0 = 0, c1 = 0, ncells = 0, nl = 0;
	dsmcp_clock_t clk;
	double vir = 0;
	int *rc = NULL, *rd = NULL, *cc = NULL, *cd = NULL;
	double *x = NULL, *v = NULL, *rem = NULL;
	uint32_t *id = NULL, *cnt = NULL;
	uint64_t *nls = NULL;
	dsmcp_t *d = NULL;
	int bad = dsmcp_cells_of(s, rank, size, &c0, &c1, &ncells, msg, msglen) != DSMCP_OK || too_big(c1 - c0);
	if (rank == 0) {
		const dsmcp_saved_t *sv = &ck->state;
		clk = sv->clock;
		vir = sv->virial;
		rc = calloc((size_t)size * 4, sizeof(int));
		nls = calloc((size_t)size, sizeof(uint64_t));
		bad = bad || !rc || !nls || too_big(s->count * (uint64_t)D);
		if (rc)
			rd = rc + size, cc = rc + 2 * size, cd = rc + 3 * size;
		for (int r = 0, co = 0, ro = 0; !bad && r < size; r++) {
			uint64_t a, b, nc;
			if (dsmcp_cells_of(s, r, size, &a, &b, &nc, NULL, 0) != DSMCP_OK) {
				bad = 1;
				break;
			}
			for (uint64_t c = a; c < b; c++)
				nls[r] += sv->count[c];
			cc[r] = (int)(b - a);
			cd[r] = co;
			rc[r] = (int)nls[r];
			rd[r] = ro;
			co += cc[r];
			ro += rc[r];
		}
	}
	MPI_Allreduce(MPI_IN_PLACE, &bad, 1, MPI_INT, MPI_MAX, MPI_COMM_WORLD);
	if (bad)
		goto cleanup;
	MPI_Bcast(&clk, (int)sizeof clk, MPI_BYTE, 0, MPI_COMM_WORLD);
	MPI_Scatter(nls, 1, MPI_UINT64_T, &nl, 1, MPI_UINT64_T, 0, MPI_COMM_WORLD);
	const size_t nown = (size_t)(c1 - c0);
	x = malloc((nl + 1) * D * sizeof(double));
	v = malloc((nl + 1) * D * sizeof(double));
	id = malloc((nl + 1) * sizeof(uint32_t));
	cnt = malloc((nown + 1) * sizeof(uint32_t));
	rem = malloc((nown + 1) * sizeof(double));
	bad = !x || !v || !id || !cnt || !rem;
	MPI_Allreduce(MPI_IN_PLACE, &bad, 1, MPI_INT, MPI_MAX, MPI_COMM_WORLD);
	if (bad)
		goto cleanup;
	const dsmcp_saved_t *sv = rank == 0 ? &ck->state : NULL;
	MPI_Datatype rec;
	MPI_Type_contiguous(D, MPI_DOUBLE, &rec);
	MPI_Type_commit(&rec);
	MPI_Scatterv(sv ? sv->pos : NULL, rc, rd, rec, x, (int)nl, rec, 0, MPI_COMM_WORLD);
	MPI_Scatterv(sv ? sv->vel : NULL, rc, rd, rec, v, (int)nl, rec, 0, MPI_COMM_WORLD);
	MPI_Type_free(&rec);
	MPI_Scatterv(sv ? sv->id : NULL, rc, rd, MPI_UINT32_T, id, (int)nl, MPI_UINT32_T, 0, MPI_COMM_WORLD);
	MPI_Scatterv(sv ? sv->count : NULL, cc, cd, MPI_UINT32_T, cnt, (int)nown, MPI_UINT32_T, 0, MPI_COMM_WORLD);
	MPI_Scatterv(sv ? sv->rem : NULL, cc, cd, MPI_DOUBLE, rem, (int)nown, MPI_DOUBLE, 0, MPI_COMM_WORLD);
	int err;
	d = dsmcp_restore(s, 0, rank, size, &clk, rank == 0 ? vir : 0.0, (size_t)nl, x, v, id, cnt, rem, &err, msg,
	                  msglen);
	bad = d == NULL;
	MPI_Allreduce(MPI_IN_PLACE, &bad, 1, MPI_INT, MPI_MAX, MPI_COMM_WORLD);
cleanup:
	if (bad) {
		dsmcp_destroy(d);
		d = NULL;
		if (msg && msglen && !msg[0])
			snprintf(msg, msglen, "run: the checkpoint could not be distributed over %d ranks (out of memory)", size);
	}
	free(rc);
	free(nls);
	free(x);
	free(v);
	free(id);
	free(cnt);
	free(rem);
	return d;
}

/* particles.initial.from: rank 0's frame to every rank (collective). The
 * scene copy *t then points at the arrays in *buf (the caller frees them).
 * 0, or -1 on every rank. */
static int share_from(const scene_t *s, scene_t *t, int rank, double **buf)
{
	const size_t nd = (size_t)s->count * (size_t)s->dim;
	int have[2] = {rank == 0 && s->init_pos, rank == 0 && s->init_vel};
	*t = *s;
	*buf = NULL;
	MPI_Bcast(have, 2, MPI_INT, 0, MPI_COMM_WORLD);
	int bad = too_big(nd);
	if (rank != 0 && !bad && (have[0] || have[1]))
		bad = !(*buf = malloc(2 * nd * sizeof(double)));
	MPI_Allreduce(MPI_IN_PLACE, &bad, 1, MPI_INT, MPI_MAX, MPI_COMM_WORLD);
	if (bad)
		return -1;
	/* the root's buffers are only read (MPI_Bcast takes them as void *) */
	double *pos = rank == 0 ? (double *)s->init_pos : *buf, *vel = rank == 0 ? (double *)s->init_vel : *buf + nd;
	if (have[0])
		MPI_Bcast(pos, (int)nd, MPI_DOUBLE, 0, MPI_COMM_WORLD);
	if (have[1])
		MPI_Bcast(vel, (int)nd, MPI_DOUBLE, 0, MPI_COMM_WORLD);
	t->init_pos = have[0] ? pos : NULL;
	t->init_vel = have[1] ? vel : NULL;
	return 0;
}

/* Rank 0's checkpoint of the present state (collective): RUN_OK, or RUN_EMIT on every rank. */
static int take_checkpoint(dsmcp_t *d, const scene_t *s, int rank, int size, const dsmcrun_opts_t *o,
                           const run_state_t *sched, uint64_t coll_sample, void *ctx, char *msg, size_t msglen)
{
	ckpt_split_t ck;
	memset(&ck, 0, sizeof ck);
	if (gather_state(d, s, rank, size, &ck) != 0) {
		if (msg && msglen)
			snprintf(msg, msglen, "run: out of memory gathering the checkpoint on rank 0");
		return RUN_ENOMEM;
	}
	int bad = 0;
	if (rank == 0) {
		ck.sched = *sched;
		ck.coll_sample = coll_sample;
		bad = !o->checkpoint || o->checkpoint(&ck, ctx) != 0;
		dsmcp_saved_free(&ck.state);
	}
	MPI_Bcast(&bad, 1, MPI_INT, 0, MPI_COMM_WORLD);
	return bad ? RUN_EMIT : RUN_OK;
}

int dsmcrun_run(const scene_t *s, int rank, int size, const dsmcrun_opts_t *o, run_emit_fn emit, void *ctx,
                const volatile sig_atomic_t *stop, char *msg, size_t msglen)
{
	int fbad = 0;
	const int frames = o->frames;
	uint64_t k_snap = 1, snap_events = UINT64_MAX;
	int ret = RUN_OK;
	xbuf_t x;
	run_record_t rec;
	uint64_t coll_sample = 0;
	double wall_before = 0;
	/* the set-up: from the checkpoint, or the scene (with rank 0's frame of particles.initial.from) */
	run_state_t sched = {.started = 0, .k_out = 1, .k_snap = 1, .k_ckpt = 1, .snap_events = UINT64_MAX};
	dsmcp_t *d = NULL;
	if (o->resumed) {
		if (rank == 0) {
			sched = o->resume->sched;
			coll_sample = o->resume->coll_sample;
		}
		MPI_Bcast(&sched, (int)sizeof sched, MPI_BYTE, 0, MPI_COMM_WORLD);
		MPI_Bcast(&coll_sample, 1, MPI_UINT64_T, 0, MPI_COMM_WORLD);
		d = scatter_state(s, rank, size, o->resume, msg, msglen);
	} else if (s->has_from) {
		scene_t t;
		double *buf = NULL;
		if (share_from(s, &t, rank, &buf) == 0)
			d = dsmcrun_create(&t, rank, size, msg, msglen);
		else if (msg && msglen)
			snprintf(msg, msglen, "run: out of memory sharing particles.initial.from with every rank");
		free(buf);
	} else {
		d = dsmcrun_create(s, rank, size, msg, msglen);
	}
	if (!d)
		return RUN_ESETUP;
	k_snap = sched.k_snap;
	snap_events = sched.snap_events;
	wall_before = sched.wall_before;
	int bad = xbuf_init(&x, size) != 0;
	MPI_Allreduce(MPI_IN_PLACE, &bad, 1, MPI_INT, MPI_MAX, MPI_COMM_WORLD);
	if (bad) {
		if (msg && msglen)
			snprintf(msg, msglen, "run: out of memory");
		ret = RUN_ENOMEM;
		goto cleanup;
	}
	const double N = (double)s->count, t0 = MPI_Wtime() - wall_before;
	double ckpt_wall = MPI_Wtime();
	/* targets: times (the step lands on them) or collision counts (the step that reaches one) */
	const int end_time = s->until.kind == SCENE_CLOCK_TIME;
	const double t_end = end_time ? s->until.value : INFINITY;
	const double c_end = end_time ? INFINITY : s->until.value * N / 2;
	const int out_time = s->every.kind == SCENE_CLOCK_TIME, out_cpp = s->every.kind == SCENE_CLOCK_CPP;
	const double every = s->every.value;
	const int ckpt_time = o->checkpoints && s->checkpoint.kind == SCENE_CLOCK_TIME && s->checkpoint.value > 0;
	const int ckpt_wall_on = o->checkpoints && s->checkpoint.kind == SCENE_CLOCK_WALL && s->checkpoint.value > 0;
	uint64_t k_out = sched.k_out;
	run_status_t status = RUN_COMPLETED;
	/* frames (output.snapshots): the first state, at the end of the step that
	 * reaches each snapshot time or collision count (steps are not cut for
	 * them, as run.c), and the last state */
	const int snap_time = s->snapshots.kind == SCENE_CLOCK_TIME, snap_cpp = s->snapshots.kind == SCENE_CLOCK_CPP;
	if (!sched.started) {
		record(d, s, RUN_PROGRESS, 0.0, &coll_sample, &rec);
		if (emit_all(rank, emit, ctx, &rec)) {
			ret = RUN_EMIT;
			goto cleanup;
		}
		if (frames) {
			if ((ret = emit_frame(d, s, rank, size, 0.0, emit, ctx, &fbad)) != RUN_OK)
				goto frame_failed;
			snap_events = 0;
		}
		sched.started = 1;
	}
	for (;;) {
		dsmcp_totals_t t;
		dsmcp_totals(d, &t);
		const double C = (double)t.collisions;
		if (!(t.time < t_end) || C >= c_end)
			break;
		double t_stop = t_end;
		if (out_time && every > 0 && k_out * every < t_stop)
			t_stop = (double)k_out * every;
		/* rank 0's stop flag and wall-clock checkpoint, reduced with the step's sums (every step) */
		uint64_t flags[2] = {rank == 0 && stop && *stop,
		                     rank == 0 && ckpt_wall_on && MPI_Wtime() - ckpt_wall >= s->checkpoint.value};
		int rc = step_x(d, t_stop, NULL, &x, size, rank, flags);
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
			snap_events = t.moves;
		}
		/* output.checkpoint in time: after the step that reaches it, its record and frame (not at the end:
		 * the run is complete) */
		int taken = 0;
		if (ckpt_time && !done && (double)sched.k_ckpt * s->checkpoint.value <= t.time) {
			while ((double)sched.k_ckpt * s->checkpoint.value <= t.time)
				sched.k_ckpt++;
			sched.k_out = k_out, sched.k_snap = k_snap, sched.snap_events = snap_events;
			sched.wall_before = MPI_Wtime() - t0;
			if ((ret = take_checkpoint(d, s, rank, size, o, &sched, coll_sample, ctx, msg, msglen)) != RUN_OK)
				goto cleanup;
			ckpt_wall = MPI_Wtime();
			taken = 1;
		}
		if (done || !(flags[0] || flags[1]))
			continue;
		if (o->checkpoints && !taken) {
			/* the state between two steps, nothing sampled: the resumed run continues exactly */
			sched.k_out = k_out, sched.k_snap = k_snap, sched.snap_events = snap_events;
			sched.wall_before = MPI_Wtime() - t0;
			if ((ret = take_checkpoint(d, s, rank, size, o, &sched, coll_sample, ctx, msg, msglen)) != RUN_OK)
				goto cleanup;
			ckpt_wall = MPI_Wtime();
		}
		if (flags[0]) {
			status = RUN_INTERRUPTED;
			if (o->checkpoints) {
				record(d, s, RUN_SUMMARY, MPI_Wtime() - t0, &coll_sample, &rec);
				rec.status = status;
				(void)emit_all(rank, emit, ctx, &rec);   /* best effort: the checkpoint is what counts */
				ret = RUN_STOPPED;
				goto cleanup;
			}
			break;
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
		if (t.moves != snap_events && (ret = emit_frame(d, s, rank, size, MPI_Wtime() - t0, emit, ctx, &fbad)) != RUN_OK)
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
