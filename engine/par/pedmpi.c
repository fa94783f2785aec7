/* The MPI driver of the parallel ED core (engine/par/ped): one ped_t per rank, rounds of message exchange and reductions over a communicator. */
#include <math.h>
#include <signal.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "par/pedmpi.h"

/* One round sends at most two particles to a rank (a border event changes at
 * most two), so the exchange is one fixed-size MPI_Alltoall. */
enum { SLOTS = 2 };
typedef struct {
	int32_t n, pad;
	ped_msg_t m[SLOTS];
} slot_t;

int pedmpi_advance(ped_t *pd, MPI_Comm comm, ped_sched_t *sp, double t0, double t_end,
                   const volatile sig_atomic_t *stop, double *t_reached)
{
	int P, rank, rc = PED_OK, lrc = PED_OK;
	MPI_Comm_size(comm, &P);
	MPI_Comm_rank(comm, &rank);
	ped_sched_t s = *sp;
	ped_sched_next(&s, t0, t_end);
	slot_t *sbuf = calloc((size_t)P, sizeof *sbuf), *rbuf = calloc((size_t)P, sizeof *rbuf);
	double t_sync = t0;
	*t_reached = t0;
	int idle_rounds = 0, moved = 1, have_in = 0;
	uint64_t messages = 0, bytes = 0;
	if (!sbuf || !rbuf)
		lrc = PED_ENOMEM;   /* told to the others by the first reduction */
	for (;;) {
		if (have_in && !lrc)
			for (int d = 0; d < P && !lrc; d++)
				lrc = ped_inbox(pd, rbuf[d].m, (size_t)rbuf[d].n);
		have_in = 0;
		double tb = lrc ? -INFINITY : ped_interior(pd, s.barrier);
		/* min of: error time, next border time, -(failure), -(progress last round), -(stop asked on rank 0) */
		double v[5] = {ped_error(pd), tb, lrc ? -1.0 : 0.0, moved ? -1.0 : 0.0,
		               rank == 0 && stop && *stop ? -1.0 : 0.0};
		MPI_Allreduce(MPI_IN_PLACE, v, 5, MPI_DOUBLE, MPI_MIN, comm);
		if (v[2] < 0.0) {
			rc = lrc ? lrc : PED_ENOMEM;
			goto cleanup;
		}
		double E = v[0], T = v[1], bprev = s.barrier;
		idle_rounds = v[3] < 0.0 ? 0 : idle_rounds + 1;
		int act = ped_sched(&s, E, T);
		if (act == 1) {
			if (!(E > t_sync)) {
				rc = PED_ESTALL;
				goto cleanup;
			}
			ped_restore(pd);
			moved = 1;
			continue;
		}
		if (act >= 2) {
			t_sync = bprev;
			ped_save(pd);
			*t_reached = t_sync;
			if (v[4] < 0.0) {   /* also at t_end: a run from stop to stop may never sync between */
				rc = PED_STOPPED;
				goto cleanup;
			}
			if (act == 3)
				break;
			moved = 1;
			continue;
		}
		if (idle_rounds > 0) {   /* nothing moved anywhere: it never will */
			rc = PED_ESTALL;
			goto cleanup;
		}
		moved = ped_border(pd, T);
		int sent = 0;
		for (int d = 0; d < P; d++) {
			size_t n;
			const ped_msg_t *m = ped_outbox(pd, d, &n);
			if (n > SLOTS) {
				lrc = PED_EINVAL;   /* cannot happen (see SLOTS); reported at the next reduction */
				n = SLOTS;
			}
			if (n)
				memcpy(sbuf[d].m, m, n * sizeof *m);
			sbuf[d].n = (int32_t)n;
			sent |= n > 0;
			messages += n > 0;
			bytes += n * sizeof *m;
		}
		ped_outbox_clear(pd);
		MPI_Alltoall(sbuf, (int)sizeof *sbuf, MPI_BYTE, rbuf, (int)sizeof *rbuf, MPI_BYTE, comm);
		have_in = 1;
		for (int d = 0; d < P; d++)
			moved |= rbuf[d].n > 0;
		moved |= sent;
	}
cleanup:
	free(sbuf);
	free(rbuf);
	s.st.messages += messages;
	s.st.bytes += bytes;
	*sp = s;
	return rc;
}

int pedmpi_run(ped_t *pd, MPI_Comm comm, double t_end, double sync_dt, ped_stats_t *st)
{
	ped_sched_t s;
	double t;
	ped_sched_init(&s, t_end, sync_dt);
	int rc = pedmpi_advance(pd, comm, &s, 0.0, t_end, NULL, &t);
	if (st)
		*st = s.st;
	return rc;
}
