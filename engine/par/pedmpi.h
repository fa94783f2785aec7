/* The MPI driver of the parallel ED core (engine/par/ped): one ped_t per rank, rounds of message exchange and reductions over a communicator. */
#pragma once

#include <mpi.h>
#include <signal.h>

#include "par/ped.h"

/*
 * Contract: every rank of comm calls pedmpi_run() with its own ped_t (rank
 * and rank count of comm, loaded with ped_load()) and the same t_end and
 * sync_dt; it runs the rounds of ped.h's contract: in each round the changed
 * particles go point to point to the neighbour ranks (ped_neighbours(): one
 * message to each, empty ones included, MPI_Isend/MPI_Probe/MPI_Recv) and one
 * MPI_Allreduce of six doubles (error time, next event time, failure, sent,
 * progress, stop), exactly as ped_sim_run() does in one process, so the run
 * is the same bit for bit. window >= 0 sets the first optimistic window
 * (< 0: ped_sched_init()'s; 0: border events in global time order). Returns
 * PED_OK on every rank, or the same negative code on every rank. *st (may be
 * NULL) gets this rank's messages (non-empty ones) and bytes sent and the
 * common round, sync and rollback counts.
 */
int pedmpi_run(ped_t *pd, MPI_Comm comm, double t_end, double sync_dt, double window, ped_stats_t *st);

/* The same rounds from a sync at t0 (ped_load(), or an earlier call that
 * returned PED_OK at t0) to t_end with the schedule *s (ped_sched_init()
 * once for the run: its sync interval and statistics, messages and bytes of
 * this rank included, carry over from call to call), so that a run can stop
 * at output times without changing its collisions. stop (read on rank 0
 * only, NULL elsewhere allowed) is reduced with every round: once set, the
 * run ends at the next sync (t_end included) and returns PED_STOPPED on every
 * rank. PED_OK and PED_STOPPED leave the state saved at *t_reached (every
 * event before it done, none after; t_end on PED_OK); a negative code (the
 * same on every rank) leaves it unusable. With s->balance set, every sync
 * (t_end included, not a stop) also balances the load as ped.h's "Load
 * balancing at a global sync" says: MPI_Allgather of the window's events,
 * when due an MPI_Allreduce of the per-cell costs and an MPI_Alltoallv of
 * the moved particles; the neighbour exchange then follows the new bounds. */
int pedmpi_advance(ped_t *pd, MPI_Comm comm, ped_sched_t *s, double t0, double t_end,
                   const volatile sig_atomic_t *stop, double *t_reached);
