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
