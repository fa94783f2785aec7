/* One ed system over all MPI ranks (the parallel core par/ped.h): set-up from rank 0's initial state, the output schedule, records reduced over the ranks, frames gathered to rank 0. */
#pragma once

#include <signal.h>
#include <stddef.h>
#include "run.h"
#include "scene.h"

/*
 * Contract (issue 14; docs/parallel.md "One ed system over many ranks")
 * - edrun_check(): pure. What the split ed run cannot do for scene s (with
 *   resumed: --resume given; out: --out given): 0, or -1 with "KEY: reason"
 *   in msg (a program option starts with "--"). The core's scope (ped.h):
 *   periodic box, one species, smooth particles, constant restitution
 *   with the TC model; inelastic runs need collisions.tc > 0 (an inelastic
 *   collapse is not detected over ranks); time schedules only (run.until,
 *   output.every, output.snapshots); observables that are sums over the
 *   particles (energy, temperature, pressure, compressibility,
 *   collision_rate, momentum); no checkpoints and no --resume.
 * - edrun_run(): collective over MPI_COMM_WORLD, every rank with the same
 *   scene (rank 0's carries particles.initial.from's state, if any). Rank 0
 *   builds the serial run's initial state (run_create(): placement, region,
 *   pre-run, from) and broadcasts it; each rank loads its share into the
 *   core (capacity N: every rank holds room for all particles, O(N) memory
 *   per rank in this slice). The run advances with pedmpi_advance() from
 *   output time to output time (and to each snapshot time), which leaves
 *   the collisions unchanged (ped.h: independent of where syncs fall).
 *   Records as the serial ed run's (run.c): a progress record at time 0,
 *   at every output time and at the end; kinetic energy, momentum, the
 *   interval's collision virial and energy integral, collisions and
 *   TC-elastic collisions summed over the ranks in rank order (MPI_Allgather,
 *   so every rank count is bit-reproducible); events are the core's
 *   committed events (collisions, cell crossings, cancelled predictions:
 *   not the serial engine's count). frames != 0 (--out): RUN_SNAPSHOT
 *   records of the whole state in particle order, gathered to rank 0
 *   (MPI_Gatherv), at time 0, at each output.snapshots time and at the end
 *   (when not already taken there). rank 0 emits (emit may be NULL
 *   elsewhere); *stop (rank 0's) is reduced with every round of the core:
 *   the run then ends at the core's next sync with a last progress record
 *   (and frame) and a summary of status interrupted.
 * - Returns RUN_OK, RUN_EMIT (rank 0's emit failed: every rank stops),
 *   RUN_ESETUP (the initial state could not be built: msg says why), or
 *   RUN_ENOMEM (out of memory, or the core failed: msg says which); the
 *   same on every rank.
 */

int edrun_check(const scene_t *s, int resumed, int out, char *msg, size_t msglen);

int edrun_run(const scene_t *s, int rank, int size, int frames, run_emit_fn emit, void *ctx,
              const volatile sig_atomic_t *stop, char *msg, size_t msglen);
