/* One dsmc system over all MPI ranks (dsmcp.h): the step's exchanges and sums over MPI, the output schedule and records. */
#pragma once

#include <signal.h>
#include <stddef.h>
#include <stdint.h>
#include "io/checkpoint.h"
#include "mc/dsmcp.h"
#include "run.h"
#include "scene.h"

/*
 * Contract (issue 15, first slice; docs/parallel.md "One dsmc system over many ranks")
 * - MPI: collective over MPI_COMM_WORLD; every rank calls with the same
 *   scene. Linked into granular-engine only (not libgranular.a).
 * - dsmcrun_step(): one step of dsmcp.h, the migrants moved with
 *   MPI_Alltoall (counts) + MPI_Alltoallv (records), the sums with
 *   MPI_Allreduce(MPI_SUM) on 64-bit integers (exact, so every rank and
 *   every rank count gets the same numbers).
 * - dsmcrun_run(): the scene's output schedule (output.every and
 *   run.until in time or collisions per particle, as run.c: a time lands a
 *   step exactly on it, a collision count ends with the step that reaches
 *   it), progress records with energy, temperature, pressure,
 *   compressibility, collision_rate and momentum reduced over the ranks,
 *   then a summary; rank 0 emits them (emit may be NULL elsewhere). The
 *   stop flag is read on rank 0 before each step and summed with the
 *   step's own reduction, so every rank stops after the same step. frames != 0 (--out): RUN_SNAPSHOT records of the whole state in
 *   the scene's particle order, gathered to rank 0 (MPI_Gatherv: rank 0
 *   holds all particles, 3 copies, while it writes), at the first state,
 *   at the end of the step that reaches each output.snapshots instant and
 *   at the last state.
 * - Checkpoints (o->checkpoints, with --out): at the end of the step that
 *   reaches each output.checkpoint time (steps are not cut for them, so
 *   they do not change the run), after the wall-clock interval (rank 0's
 *   clock, reduced with the stop flag), and on a stop request: every
 *   rank's part gathered to rank 0 in the 1-rank order (MPI_Gatherv:
 *   rank 0 holds the whole state once while o->checkpoint() writes it),
 *   after that step's record and frame. A stop writes one, emits the
 *   summary (status interrupted) and returns RUN_STOPPED.
 * - Resume (o->resumed on every rank; rank 0 holds o->resume): rank 0
 *   sends each rank the records and cells of its slab for this rank
 *   count (MPI_Scatterv), the schedule goes on where it stood; the run is
 *   bit for bit the uninterrupted one, whatever the rank counts before
 *   and after.
 * - particles.initial.from: rank 0's frame (s->init_pos, s->init_vel)
 *   is broadcast to every rank, which builds dsmc_create()'s state from it.
 * - Bit-identity: the state and the integer and energy columns are those of
 *   any other rank count; pressure and momentum are sums of doubles over
 *   ranks (MPI_SUM) and may differ in the last bits between rank counts.
 */

typedef struct {
	uint64_t steps;
	uint64_t migrants;      /* records sent to other ranks (this rank) */
	uint64_t bytes;         /* bytes of those records */
	uint64_t messages;      /* non-empty sends to another rank */
	double seconds;         /* wall time in dsmcrun_step() */
	double comm_seconds;    /* of which in MPI calls */
	double cpu_compute;     /* CPU seconds of this process outside MPI calls */
} dsmcrun_stats_t;

/* One step to at most t_stop on every rank. 0, DSMCP_QUIESCENT (T = 0,
 * t_stop infinite: nothing done), or a negative DSMCP_ code (same on all ranks). */
int dsmcrun_step(dsmcp_t *d, double t_stop, dsmcrun_stats_t *st);

/* Build the decomposed system of scene s (stream 0) on every rank. NULL
 * with msg on failure (the same outcome on every rank). */
dsmcp_t *dsmcrun_create(const scene_t *s, int rank, int size, char *msg, size_t msglen);

typedef struct {
	int frames;              /* every rank: frames (--out) */
	int checkpoints;         /* every rank: checkpoints (--out) */
	int resumed;             /* every rank: continue from a checkpoint (rank 0 holds it in resume) */
	const ckpt_split_t *resume;   /* rank 0, with resumed */
	/* rank 0, with checkpoints: make the outputs durable and write ck;
	 * 0, or -1 (the reason is the emit context's) */
	int (*checkpoint)(const ckpt_split_t *ck, void *ctx);
} dsmcrun_opts_t;

/* The whole run; RUN_OK, RUN_STOPPED (stopped with a checkpoint written),
 * RUN_EMIT (rank 0's emit or checkpoint failed: every rank stops),
 * RUN_ENOMEM or RUN_ESETUP with msg. */
int dsmcrun_run(const scene_t *s, int rank, int size, const dsmcrun_opts_t *o, run_emit_fn emit, void *ctx,
                const volatile sig_atomic_t *stop, char *msg, size_t msglen);
