/* The MPI driver of the parallel ED core (engine/par/ped): one ped_t per rank, rounds of neighbour exchange and one reduction over a communicator. */
#include <math.h>
#include <signal.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "par/pedmpi.h"

enum { TAG = 7141 };

typedef struct {
	ped_msg_t *m;
	size_t n, cap;
} rbuf_t;

/* Send this round's changed particles to every neighbour (an empty message
 * too: each neighbour receives exactly one per round, so rounds cannot mix;
 * MPI keeps the order of messages between two ranks) and receive theirs. */
static int exchange(ped_t *pd, MPI_Comm comm, const int *nb, int nn, rbuf_t *in, MPI_Request *req,
                    uint64_t *messages, uint64_t *bytes, int *sent)
{
	int rc = PED_OK;
	*sent = 0;
	for (int q = 0; q < nn; q++) {
		size_t n;
		const ped_msg_t *m = ped_outbox(pd, nb[q], &n);
		MPI_Isend(m, (int)(n * sizeof *m), MPI_BYTE, nb[q], TAG, comm, &req[q]);
		*sent |= n > 0;
		*messages += n > 0;
		*bytes += n * sizeof *m;
	}
	for (int q = 0; q < nn; q++) {
		MPI_Status st;
		int cnt = 0;
		MPI_Probe(nb[q], TAG, comm, &st);
		MPI_Get_count(&st, MPI_BYTE, &cnt);
		size_t n = (size_t)cnt / sizeof(ped_msg_t);
		if (n > in[q].cap) {
			ped_msg_t *x = realloc(in[q].m, n * sizeof *x);
			if (!x) {
				rc = PED_ENOMEM;   /* received into nothing below, reported at the reduction */
				MPI_Recv(NULL, 0, MPI_BYTE, nb[q], TAG, comm, MPI_STATUS_IGNORE);
				in[q].n = 0;
				continue;
			}
			in[q].m = x, in[q].cap = n;
		}
		MPI_Recv(in[q].m, cnt, MPI_BYTE, nb[q], TAG, comm, MPI_STATUS_IGNORE);
		in[q].n = n;
	}
	MPI_Waitall(nn, req, MPI_STATUSES_IGNORE);
	ped_outbox_clear(pd);
	return rc;
}

/* Load balancing at a sync (ped.h, "Load balancing at a global sync"):
 * collective; the same decision and bounds on every rank. */
static int balance(ped_t *pd, MPI_Comm comm, int P, ped_stats_t *st)
{
	ped_totals_t tt;
	ped_totals(pd, &tt);
	uint64_t mine[2] = {ped_window_events(pd), tt.owned}, n = 0, *all = malloc(2 * (size_t)P * sizeof *all),
	         *ev = malloc((size_t)P * sizeof *ev), *newb = malloc(((size_t)P + 1) * sizeof *newb);
	double *cost = NULL, imb;
	int *cnt = malloc(4 * (size_t)P * sizeof *cnt), rc = PED_OK, bad;
	ped_msg_t *in = NULL;
	MPI_Datatype mt = MPI_DATATYPE_NULL;
	bad = !all || !ev || !newb || !cnt;
	MPI_Allreduce(MPI_IN_PLACE, &bad, 1, MPI_INT, MPI_MAX, comm);
	if (bad) {
		rc = PED_ENOMEM;
		goto cleanup;
	}
	MPI_Allgather(mine, 2, MPI_UINT64_T, all, 2, MPI_UINT64_T, comm);
	for (int r = 0; r < P; r++) {
		ev[r] = all[2 * r];
		n += all[2 * r + 1];
	}
	uint64_t zs = ped_zsize(pd);
	if (!ped_balance_due(ev, P, n, &imb) || zs > (uint64_t)INT32_MAX)
		goto cleanup;
	cost = calloc(zs, sizeof *cost);
	bad = !cost;
	MPI_Allreduce(MPI_IN_PLACE, &bad, 1, MPI_INT, MPI_MAX, comm);
	if (bad) {
		rc = PED_ENOMEM;
		goto cleanup;
	}
	/* one rank holds each cell's count: the sum is exact */
	ped_window_cost(pd, cost);
	MPI_Allreduce(MPI_IN_PLACE, cost, (int)zs, MPI_DOUBLE, MPI_SUM, comm);
	int changed = ped_balance_bounds(pd, cost, newb);
	bad = changed < 0;
	MPI_Allreduce(MPI_IN_PLACE, &bad, 1, MPI_INT, MPI_MAX, comm);
	if (bad) {
		rc = PED_ENOMEM;
		goto cleanup;
	}
	if (!changed) {
		ped_window_reset(pd);   /* judged: within the hysteresis */
		goto cleanup;
	}
	bad = ped_migrate_out(pd, newb) != PED_OK;
	MPI_Allreduce(MPI_IN_PLACE, &bad, 1, MPI_INT, MPI_MAX, comm);
	if (bad) {
		rc = PED_ENOMEM;
		goto cleanup;
	}
	/* all to all: counts, then the particles (one MPI type per particle record) */
	int *scnt = cnt, *sdis = cnt + P, *rcnt = cnt + 2 * P, *rdis = cnt + 3 * P;
	const ped_msg_t *sbase = NULL;
	size_t stot = 0;
	ped_msg_t *sendbuf = NULL;
	for (int d = 0; d < P; d++) {
		size_t k;
		ped_outbox(pd, d, &k);
		scnt[d] = (int)k;
		sdis[d] = (int)stot;
		stot += k;
	}
	sendbuf = malloc((stot ? stot : 1) * sizeof *sendbuf);
	if (sendbuf)
		for (int d = 0; d < P; d++) {
			size_t k;
			sbase = ped_outbox(pd, d, &k);
			if (k)
				memcpy(sendbuf + sdis[d], sbase, k * sizeof *sendbuf);
		}
	MPI_Alltoall(scnt, 1, MPI_INT, rcnt, 1, MPI_INT, comm);
	size_t rtot = 0;
	for (int r = 0; r < P; r++) {
		rdis[r] = (int)rtot;
		rtot += (size_t)rcnt[r];
	}
	in = malloc((rtot ? rtot : 1) * sizeof *in);
	bad = !in || !sendbuf || stot > (size_t)INT32_MAX || rtot > (size_t)INT32_MAX;
	MPI_Allreduce(MPI_IN_PLACE, &bad, 1, MPI_INT, MPI_MAX, comm);
	if (bad) {
		free(sendbuf);
		rc = PED_ENOMEM;
		goto cleanup;
	}
	MPI_Type_contiguous((int)sizeof(ped_msg_t), MPI_BYTE, &mt);
	MPI_Type_commit(&mt);
	MPI_Alltoallv(sendbuf, scnt, sdis, mt, in, rcnt, rdis, mt, comm);
	free(sendbuf);
	st->bytes += stot * sizeof(ped_msg_t);
	uint64_t moved = 0;
	bad = ped_migrate_in(pd, in, rtot, &moved) != PED_OK;
	MPI_Allreduce(MPI_IN_PLACE, &bad, 1, MPI_INT, MPI_MAX, comm);
	if (bad) {
		rc = PED_ENOMEM;
		goto cleanup;
	}
	ped_window_reset(pd);
	st->rebalances++;
	st->migrated += moved;
cleanup:
	if (mt != MPI_DATATYPE_NULL)
		MPI_Type_free(&mt);
	free(in);
	free(cost);
	free(cnt);
	free(newb);
	free(ev);
	free(all);
	return rc;
}

int pedmpi_advance(ped_t *pd, MPI_Comm comm, ped_sched_t *sp, double t0, double t_end,
                   const volatile sig_atomic_t *stop, double *t_reached)
{
	int P, rank, rc = PED_OK, lrc = PED_OK;
	MPI_Comm_size(comm, &P);
	MPI_Comm_rank(comm, &rank);
	ped_sched_t s = *sp;
	ped_sched_next(&s, t0, t_end);
	const int *nb;
	int nn = ped_neighbours(pd, &nb);
	rbuf_t *in = calloc((size_t)nn + 1, sizeof *in);
	MPI_Request *req = calloc((size_t)nn + 1, sizeof *req);
	*t_reached = t0;
	int have_in = 0;
	uint64_t messages = 0, bytes = 0;
	int bad = !in || !req;
	MPI_Allreduce(MPI_IN_PLACE, &bad, 1, MPI_INT, MPI_MAX, comm);
	if (bad) {
		rc = PED_ENOMEM;
		goto cleanup;
	}
	for (;;) {
		if (have_in && !lrc)
			for (int q = 0; q < nn && !lrc; q++)
				lrc = ped_inbox(pd, in[q].m, in[q].n);
		have_in = 0;
		uint64_t done = 0;
		double tb = lrc ? -INFINITY : ped_run(pd, s.horizon, s.barrier, &done);
		int sent = 0;
		if (!lrc) {
			/* send() addresses neighbours only: anything else is a bug, reported as a failure */
			for (int d = 0; d < P; d++) {
				size_t n;
				ped_outbox(pd, d, &n);
				int isnb = 0;
				for (int q = 0; q < nn; q++)
					isnb |= nb[q] == d;
				if (n && !isnb)
					lrc = PED_EINVAL;
			}
		}
		/* every rank takes part, also after a failure (the others wait for it) */
		int x = exchange(pd, comm, nb, nn, in, req, &messages, &bytes, &sent);
		lrc = lrc ? lrc : x;
		have_in = 1;
		/* min of: error time, next event time, -(failure), -(sent), -(progress), -(stop asked on rank 0) */
		double v[6] = {ped_error(pd), tb, lrc ? -1.0 : 0.0, sent ? -1.0 : 0.0, done || sent ? -1.0 : 0.0,
		               rank == 0 && stop && *stop ? -1.0 : 0.0};
		MPI_Allreduce(MPI_IN_PLACE, v, 6, MPI_DOUBLE, MPI_MIN, comm);
		if (v[2] < 0.0) {
			rc = lrc ? lrc : PED_ENOMEM;
			goto cleanup;
		}
		double E = v[0], T = v[1];
		int quiet = !(v[3] < 0.0), moved = v[4] < 0.0;
		double hprev = s.horizon;
		int act = ped_sched(&s, E, T, quiet);
		if (act < 0) {
			rc = PED_ESTALL;
			goto cleanup;
		}
		if (act == 1) {
			ped_restore(pd);
			have_in = 0;   /* the messages of the rolled-back round are dropped */
			continue;
		}
		if (act >= 2) {
			ped_save(pd);
			*t_reached = s.t_sync;
			if (v[5] < 0.0) {   /* also at t_end: a run from stop to stop may never sync between */
				rc = PED_STOPPED;
				goto cleanup;
			}
			if (s.balance && P > 1) {   /* also at t_end: a run from stop to stop may never sync between */
				if ((rc = balance(pd, comm, P, &s.st)) != PED_OK)
					goto cleanup;
				if (act == 3)
					break;
				/* new neighbours: new receive buffers (empty at a sync) */
				for (int q = 0; q < nn; q++)
					free(in[q].m);
				free(in);
				free(req);
				nn = ped_neighbours(pd, &nb);
				in = calloc((size_t)nn + 1, sizeof *in);
				req = calloc((size_t)nn + 1, sizeof *req);
				bad = !in || !req;
				MPI_Allreduce(MPI_IN_PLACE, &bad, 1, MPI_INT, MPI_MAX, comm);
				if (bad) {
					rc = PED_ENOMEM;
					goto cleanup;
				}
			}
			if (act == 3)
				break;
			continue;
		}
		if (!moved && T <= hprev) {   /* nothing moved anywhere though the next event was within reach: it never will */
			rc = PED_ESTALL;
			goto cleanup;
		}
	}
cleanup:
	if (in)
		for (int q = 0; q < nn; q++)
			free(in[q].m);
	free(in);
	free(req);
	s.st.messages += messages;
	s.st.bytes += bytes;
	*sp = s;
	return rc;
}

int pedmpi_run(ped_t *pd, MPI_Comm comm, double t_end, double sync_dt, double window, ped_stats_t *st)
{
	ped_sched_t s;
	double t;
	ped_sched_init(&s, t_end, sync_dt);
	if (window >= 0.0) {
		s.window = s.st.window = window;
		s.horizon = window;
	}
	int rc = pedmpi_advance(pd, comm, &s, 0.0, t_end, NULL, &t);
	if (st)
		*st = s.st;
	return rc;
}
