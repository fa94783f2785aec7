/* Job budget: the memory a scene's run needs and the output it writes, estimated before it runs (admission control). */
#pragma once

#include <stddef.h>
#include <stdint.h>
#include "scene.h"

/*
 * Contract
 * - Pure: no I/O, no allocation, no globals; deterministic.
 * - For a parsed scene with a concrete method (not "auto": choose it first,
 *   advice.h) run as the daemon runs it: `granular-engine run --out DIR`
 *   under mpirun with `ranks` ranks (so single runs keep snapshot buffers
 *   and write checkpoints).
 * - Memory (bytes, peak resident set summed over the launcher and every
 *   rank) = BUDGET_LAUNCHER_BYTES + ranks x BUDGET_RANK_BYTES (measured:
 *   libraries, MPI, HDF5) + per replica the engine's own allocation
 *   (ed_plan() / dsmc_plan(): per particle and per cell, exact) and the run's
 *   buffers (sampling copies of positions and velocities, cluster analysis)
 *   + the transient copies of a checkpoint (the largest state field; for
 *   ensembles every replica's state gathered on rank 0) + ensemble
 *   reduction vectors and frame buffers; an ed single run that runs split
 *   over its ranks (engine/par/edrun.h) adds the parallel core on every rank
 *   (room for all N particles: ped_scene_bytes()) and the gathers on rank 0. docs/daemon.md ("Admission")
 *   gives the bytes per particle this comes to, with the measurements that
 *   test it (tests/budget_test.c).
 * - Output (bytes written into the run's directory, at its largest):
 *   trajectory.h5 (frames x groups x (2 N D + D^2 + 2) doubles, written
 *   uncompressed: compression only lowers it; observables rows; fixed
 *   layout) + trajectory.xdmf + progress.jsonl (records x measured line
 *   length) + curves (observables.jsonl: per sample the bound
 *   tables_json_max(), 17 characters per number, on the tables of
 *   tables_of(), observe/tables.h; the fields and density_spectrum rows of
 *   trajectory.h5) + checkpoints (the state fields and the scene; up to three
 *   files exist while one is written: checkpoint.tmp.h5, checkpoint.h5,
 *   checkpoint.prev.h5).
 * - Counts follow the schedules: records = 2 + until / output.every (the
 *   first, one per output time, the last) + the summary; frames = 2 +
 *   until / snapshots.every (first and last only without snapshots); curve
 *   samples = the frames of one group (curves are taken at snapshot times,
 *   with or without frames). When a
 *   schedule's clock differs from the stop condition's (time against
 *   collisions per particle), it is converted with Haff's law from the
 *   initial collision rate (advice_haff_cpp()): exact for homogeneous
 *   cooling, an estimate otherwise (clustering gases collide less): `bound`
 *   says so, and the daemon measures the real output while the job runs.
 */

/* Fixed bytes per process, measured on Debian 12 / Open MPI 4.1.4 / HDF5
 * 1.10.8 (peak RSS of `mpirun -np P granular-engine run` on a 100-particle
 * scene; docs/daemon.md): the launcher, and each rank. */
#define BUDGET_LAUNCHER_BYTES (16ull << 20)
#define BUDGET_RANK_BYTES (26ull << 20)

typedef enum {
	BUDGET_EXACT = 0,     /* counts follow from the schedules alone */
	BUDGET_ESTIMATE,      /* a clock was converted with Haff's law (homogeneous cooling) */
} budget_bound_t;

typedef struct {
	/* memory */
	uint64_t memory;          /* bytes, the whole job: launcher and all ranks */
	uint64_t memory_rank0;    /* bytes of rank 0 (the largest) */
	uint64_t replica;         /* bytes of one replica on its rank: its engine and the run's buffers */
	uint64_t engine;          /* bytes of one replica's engine (ed_plan()/dsmc_plan() memory) */
	uint64_t state;           /* bytes of one replica's state fields (checkpoint data) */
	uint64_t cells;           /* cells of one replica's engine grid */
	/* output */
	uint64_t records;         /* progress records (lines of progress.jsonl with the summary) */
	uint64_t frames;          /* trajectory frames, summed over the particle groups */
	uint64_t trajectory;      /* bytes of trajectory.h5 and trajectory.xdmf */
	uint64_t checkpoint;      /* bytes of one checkpoint file */
	uint64_t progress;        /* bytes of progress.jsonl */
	uint64_t curve_samples;   /* samples of the curve observables (0 when the scene asks for none) */
	uint64_t curves;          /* bytes of observables.jsonl (at most) and of the curve rows in trajectory.h5 */
	uint64_t output;          /* trajectory + progress + curves + 3 x checkpoint: the directory at its largest */
	budget_bound_t bound;
} budget_t;

enum {
	BUDGET_OK = 0,
	BUDGET_EINVAL = -1,   /* method "auto", ranks < 1, or the engine's plan refuses the scene (err says why) */
};

/* Estimate the budget of scene s run on `ranks` MPI ranks. err (may be NULL)
 * receives "KEY: reason" on failure. */
int budget_estimate(const scene_t *s, int ranks, budget_t *out, char *err, size_t errlen);

const char *budget_strerror(int code);
