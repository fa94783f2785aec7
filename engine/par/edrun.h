/* One ed system over all MPI ranks (the parallel core par/ped.h): set-up from rank 0's initial state, the output schedule, records reduced over the ranks, frames gathered to rank 0. */
#pragma once

#include <signal.h>
#include <stddef.h>
#include "run.h"
#include "scene.h"

/*
 * Contract (issue 14; docs/parallel.md "One ed system over many ranks")
 * - edrun_check(): pure. What the split ed run cannot do for scene s (out:
 *   --out given): 0, or -1 with "KEY: reason" in msg. The core's scope
 *   (ped.h): periodic box, one species, smooth particles, constant
 *   restitution with the TC model; inelastic runs need collisions.tc > 0
 *   (an inelastic collapse is not detected over ranks); time schedules only
 *   (run.until, output.every, output.snapshots); observables that are sums
 *   over the particles (energy, temperature, pressure, compressibility,
 *   collision_rate, momentum).
 * - edrun_run(): collective over MPI_COMM_WORLD, every rank with the same
 *   scene (rank 0's carries particles.initial.from's state, if any) and the
 *   same o->frames, o->checkpoints, o->resumed. Rank 0 builds the serial
 *   run's initial state (run_create(): placement, region, pre-run, from), or
 *   takes the state of o->resume (a serial run restored from a checkpoint),
 *   and broadcasts it; each rank loads its share into the core (capacity N:
 *   every rank holds room for all particles, O(N) memory per rank in this
 *   slice). The run advances with pedmpi_advance() from stop to stop (output,
 *   snapshot and checkpoint times, the end), which leaves the collisions
 *   unchanged (ped.h: independent of where syncs fall).
 *   Records as the serial ed run's (run.c): a progress record at time 0
 *   (not when resumed), at every output time and at the end; kinetic
 *   energy, momentum, the interval's collision virial and energy integral,
 *   collisions and TC-elastic collisions summed over the ranks in rank order
 *   (MPI_Allgather, so every rank count is bit-reproducible); events are the
 *   core's committed events (collisions, cell crossings, cancelled
 *   predictions: not the serial engine's count). o->frames (--out):
 *   RUN_SNAPSHOT records of the whole state in particle order, gathered to
 *   rank 0 (MPI_Gatherv), at time 0, at each output.snapshots time and at
 *   the end (when not already taken there).
 *   o->checkpoints (--out): at output.checkpoint times (simulated time: the
 *   run stops there; wall clock: checked by rank 0 at the schedule's stops
 *   and every chunk of about a second of wall time) and on a stop request,
 *   rank 0 writes a checkpoint in the serial run's
 *   layout through o->save: a serial run built from the gathered state (its
 *   engine fresh from positions and velocities with its clock's epoch at the
 *   checkpoint time; counters, TC times, the interval accumulators and the
 *   schedule set as fields), so that a serial run or a split run at any rank
 *   count resumes it; over P > 1 ranks the run also carries (run_extra_set())
 *   every rank's core state (ped_image_write()) and the driver's interval
 *   bookkeeping and schedule, from which o->resumed at the same rank count
 *   continues bit for bit (other rank counts: the serial state);
 *   after a stop the summary has the totals now
 *   (status interrupted) and RUN_STOPPED is returned, as run_go().
 *   Without o->checkpoints, *stop (rank 0's, reduced with every round of the
 *   core) ends the run at the core's next sync with a last progress record
 *   (and frame) and a summary of status interrupted.
 * - Returns RUN_OK, RUN_STOPPED (checkpointed and stopped), RUN_EMIT (rank
 *   0's emit or save failed: every rank stops), RUN_ESETUP (the initial
 *   state could not be built or resumed: msg says why), or RUN_ENOMEM (out
 *   of memory, or the core failed: msg says which); the same on every rank.
 */

typedef struct {
	int frames;                        /* every rank: frames (--out) */
	int checkpoints;                   /* every rank: checkpoints and stop -> checkpoint (--out) */
	int resumed;                       /* every rank: the state comes from rank 0's o->resume */
	run_t *resume;                     /* rank 0: the serial run restored from --resume */
	int (*save)(run_t *r, void *ctx);  /* rank 0: write r's checkpoint (0 = done) */
	void *save_ctx;
} edrun_opts_t;

int edrun_check(const scene_t *s, int out, char *msg, size_t msglen);

int edrun_run(const scene_t *s, int rank, int size, const edrun_opts_t *o, run_emit_fn emit, void *ctx,
              const volatile sig_atomic_t *stop, char *msg, size_t msglen);
