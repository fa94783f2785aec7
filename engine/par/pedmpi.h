/* The MPI driver of the parallel ED core (engine/par/ped): one ped_t per rank, rounds of message exchange and reductions over a communicator. */
#pragma once

#include <mpi.h>

#include "par/ped.h"

/*
 * Contract: every rank of comm calls pedmpi_run() with its own ped_t (rank
 * and rank count of comm, loaded with ped_load()) and the same t_end and
 * sync_dt; it runs the rounds of ped.h's contract with one MPI_Allreduce
 * (error time, next border time, progress) and one fixed-size MPI_Alltoall
 * (the changed particles: at most two per rank and round) per round, exactly as ped_sim_run()
 * does in one process, so the run is the same bit for bit. Returns PED_OK
 * on every rank, or the same negative code on every rank. *st (may be NULL)
 * gets this rank's messages and bytes sent and the common round, sync and
 * rollback counts.
 */
int pedmpi_run(ped_t *pd, MPI_Comm comm, double t_end, double sync_dt, ped_stats_t *st);
