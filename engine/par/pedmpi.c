/* The MPI driver of the parallel ED core (engine/par/ped): one ped_t per rank, rounds of message exchange and reductions over a communicator. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "par/pedmpi.h"

int pedmpi_run(ped_t *pd, MPI_Comm comm, double t_end, double sync_dt, ped_stats_t *st)
{
	int P, rank, rc = PED_OK;
	MPI_Comm_size(comm, &P);
	MPI_Comm_rank(comm, &rank);
	ped_sched_t s;
	ped_sched_init(&s, t_end, sync_dt);
	int *scount = calloc((size_t)P, sizeof(int)), *rcount = calloc((size_t)P, sizeof(int));
	int *sdisp = calloc((size_t)P, sizeof(int)), *rdisp = calloc((size_t)P, sizeof(int));
	char *sbuf = NULL, *rbuf = NULL;
	size_t scap = 0, rcap = 0, nin = 0;
	double t_sync = 0.0;
	int idle_rounds = 0, moved = 1;
	uint64_t messages = 0, bytes = 0;
	if (!scount || !rcount || !sdisp || !rdisp) {
		rc = PED_ENOMEM;
		goto cleanup;
	}
	for (;;) {
		int lrc = ped_inbox(pd, (const ped_msg_t *)rbuf, nin);
		nin = 0;
		double tb = lrc ? -INFINITY : ped_interior(pd, s.barrier);
		/* min of: error time, next border time, -(local failure), -(progress last round) */
		double v[4] = {ped_error(pd), tb, lrc ? 1.0 : 0.0, moved ? -1.0 : 0.0};
		v[2] = -v[2];
		MPI_Allreduce(MPI_IN_PLACE, v, 4, MPI_DOUBLE, MPI_MIN, comm);
		if (v[2] < 0.0) {
			rc = lrc ? lrc : PED_EFULL;
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
			if (act == 3)
				break;
			ped_save(pd);
			moved = 1;
			continue;
		}
		if (idle_rounds > 0) {   /* nothing moved anywhere: it never will */
			rc = PED_ESTALL;
			goto cleanup;
		}
		moved = ped_border(pd, T);
		/* exchange the changed particles */
		size_t total = 0;
		for (int d = 0; d < P; d++) {
			size_t n;
			ped_outbox(pd, d, &n);
			total += n;
		}
		if (total * sizeof(ped_msg_t) > scap) {
			size_t nc = total * sizeof(ped_msg_t) * 2;
			char *x = realloc(sbuf, nc);
			if (!x)
				MPI_Abort(comm, 1);   /* out of memory mid-exchange: the collective cannot be left alone */
			sbuf = x, scap = nc;
		}
		size_t off = 0;
		for (int d = 0; d < P; d++) {
			size_t n;
			const ped_msg_t *m = ped_outbox(pd, d, &n);
			if (n)
				memcpy(sbuf + off, m, n * sizeof *m);
			scount[d] = (int)(n * sizeof *m);
			sdisp[d] = (int)off;
			off += n * sizeof *m;
			messages += n > 0;
			bytes += n * sizeof *m;
		}
		ped_outbox_clear(pd);
		MPI_Alltoall(scount, 1, MPI_INT, rcount, 1, MPI_INT, comm);
		size_t rtot = 0;
		for (int d = 0; d < P; d++) {
			rdisp[d] = (int)rtot;
			rtot += (size_t)rcount[d];
		}
		if (rtot > rcap) {
			char *x = realloc(rbuf, rtot * 2);
			if (!x)
				MPI_Abort(comm, 1);   /* as above */
			rbuf = x, rcap = rtot * 2;
		}
		MPI_Alltoallv(sbuf, scount, sdisp, MPI_BYTE, rbuf, rcount, rdisp, MPI_BYTE, comm);
		nin = rtot / sizeof(ped_msg_t);
		moved |= nin > 0 || total > 0;
	}
cleanup:
	free(scount);
	free(rcount);
	free(sdisp);
	free(rdisp);
	free(sbuf);
	free(rbuf);
	s.st.messages = messages;
	s.st.bytes = bytes;
	if (st)
		*st = s.st;
	return rc;
}
