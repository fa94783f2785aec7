/* DSMC of one system decomposed over P ranks in slabs of cell planes: migration, cell-keyed random numbers, exact sums (no MPI). */
#pragma once

#include <stddef.h>
#include <stdint.h>
#include "dsmc.h"
#include "scene.h"

/*
 * Contract (issue 15, first slice; docs/parallel.md "One dsmc system over many ranks")
 * - Pure computation: no MPI, no I/O, no globals. One dsmcp_t per rank;
 *   the caller (engine/par/dsmcrun.c with MPI, or a test in one process) moves
 *   the migrants between ranks and sums the dsmcp_sums_t words.
 * - Decomposition: slabs of whole cell planes along the last axis (z in 3D,
 *   y in 2D): rank r of P owns planes [r nz / P, (r + 1) nz / P), a
 *   contiguous range of cell indices (x fastest). nz < P leaves ranks idle.
 * - Scope: methods dsmc and hsmc, periodic box, one species, correction
 *   none, enskog or cba with the global contact value, molecular-chaos impact
 *   parameters; observables energy, pressure, collision_rate, momentum.
 *   dsmcp_check() names the first scene key outside it.
 * - One step of length dt: [hsmc: cell-cell collisions, dsmcp_hs_*()];
 *   free flight (wrap; hsmc: moves into cells full at the start rejected),
 *   migrants packed for their owner rank (dsmcp_move), arrivals appended
 *   (dsmcp_arrive), counting sort into the own cells (stable over the
 *   concatenation: arrivals from lower ranks, own particles, arrivals from
 *   higher ranks, which is the order the 1-rank run has), Bird's
 *   no-time-counter collisions as in dsmc.c whose random numbers come from
 *   a generator keyed on (seed, stream, step, cell) only (dsmcp_collide),
 *   then the global sums installed (dsmcp_finish).
 * - Guarantee: given the same scene, stream and dsmcp_next_dt() stop times,
 *   the particles' positions, velocities, the clock and every counter after
 *   any number of steps are bit-identical for every rank count P >= 1: a
 *   rank's particles are always in the order of the 1-rank run restricted
 *   to them (by induction: slabs own increasing cell ranges, the sort is
 *   stable), so a cell's collisions depend only on its particles in that
 *   order, its carried remainder and its key; and the adaptive step
 *   uses the kinetic energy summed exactly (per-cell double sums in
 *   cell order rounded once to 128-bit fixed point; integer sums are
 *   associative). The sequence differs from dsmc.c's serial one (its single
 *   stream), which this module leaves untouched.
 * - The initial state is dsmc_create()'s (the same scene and stream), each
 *   rank keeping its own cells' particles (built by dsmc_create() on every
 *   rank, or generated directly when dsmcp_direct_ok(): the same numbers);
 *   the remainders restart uniform from the keyed generator; the first
 *   step's kinetic energy is the exact fixed-point sum (dsmcp_start()).
 */

typedef struct dsmcp dsmcp_t;

enum { DSMCP_OK = 0, DSMCP_ENOMEM = -1, DSMCP_EINVAL = -2, DSMCP_QUIESCENT = 1 };

/* Words summed over ranks after each step (dsmcp_collide() fills a rank's
 * part, the caller adds them element-wise, exactly, e.g. MPI_SUM on
 * MPI_UINT64_T): kinetic energy in four 32-bit limbs of a 128-bit fixed-point
 * number, then counters. */
enum {
	DSMCP_EK0 = 0, DSMCP_EK3 = 3,
	DSMCP_COLL = 4,        /* accepted collisions this step */
	DSMCP_CAND = 5,        /* candidate pairs this step */
	DSMCP_VMAX = 6,        /* v_max raises this step */
	DSMCP_COUNT = 7,       /* particles (after the step) */
	DSMCP_MIGR = 8,        /* particles that changed rank this step */
	DSMCP_CELLC = 9,       /* hsmc: cell-cell collisions this step */
	DSMCP_REJ = 10,        /* hsmc: moves into full cells rejected this step */
	DSMCP_NSUM = 11
};
typedef struct {
	uint64_t w[DSMCP_NSUM];
} dsmcp_sums_t;

/* Which key of scene s a decomposed run over ranks > 1 cannot honour:
 * DSMCP_OK, or DSMCP_EINVAL with "KEY: reason" in msg. */
int dsmcp_check(const scene_t *s, char *msg, size_t msglen);

/* Rank `rank` of `ranks` of the run of scene s from the built initial
 * state init (dsmc_create(s, stream, ...), identical on every rank; the
 * caller may destroy it afterwards), or with init NULL, for a scene where
 * dsmcp_direct_ok() holds, the same state generated directly: the scene's
 * random stream is run through twice on every rank, which keeps only its
 * slab (O(N) time, O(N / P) memory). NULL with *err and msg set. Then,
 * collectively: dsmcp_initial_sums() on every rank, the parts summed,
 * dsmcp_start() on every rank (the kinetic energy of the first step). */
dsmcp_t *dsmcp_create(const scene_t *s, const dsmc_t *init, uint64_t stream, int rank, int ranks, int *err,
                      char *msg, size_t msglen);
/* Random positions, no given positions or velocities, no pre-run, one
 * species, periodic: dsmcp_create() can build the state without init. */
int dsmcp_direct_ok(const scene_t *s);
void dsmcp_initial_sums(const dsmcp_t *d, dsmcp_sums_t *part);
/* DSMCP_EINVAL if the summed count is not the system's N. */
int dsmcp_start(dsmcp_t *d, const dsmcp_sums_t *sum);
void dsmcp_destroy(dsmcp_t *d);

/* The next step's length for a run to t_stop (shortened to land on it:
 * *last = 1) from the global kinetic energy; INFINITY when T = 0 with
 * t_stop infinite (quiescent). The same number on every rank. */
double dsmcp_next_dt(const dsmcp_t *d, double t_stop, int *last);

/*
 * HSMC (method hsmc; before dsmcp_move() in each step): Mueller's cell-cell
 * collisions as in dsmc.c, in the 1-rank order of the cells, which makes
 * them a chain over the ranks in rank order:
 * 1. dsmcp_hs_cells(): this rank's cells' counts and mean velocities into
 *    buf (dsmcp_hs_width() doubles per own cell); the caller gathers every
 *    rank's, in rank order (the whole grid), into dsmcp_hs_grid();
 * 2. rank 0 first, then each rank with the events of the ranks before it:
 *    dsmcp_hs_turn() marks the cells they used, applies their claims on
 *    this rank's cells, runs this rank's cells and appends its own events
 *    (records of DSMCP_HS_EVENT doubles); the last rank's list goes to all;
 * 3. dsmcp_hs_final() with the whole list: the claims on this rank's cells
 *    made by ranks after it.
 * dsmcp_move() then rejects moves into cells full at the start of the step
 * (from the grid of step 1).
 */
#define DSMCP_HS_EVENT 10
int dsmcp_hs_width(const dsmcp_t *d);
size_t dsmcp_hs_cells(const dsmcp_t *d, double *buf);
void dsmcp_hs_grid(dsmcp_t *d, const double *all);
/* in: nin events; out: a buffer (owned by d, valid until the next call)
 * holding in's events followed by this rank's, *nout in all. DSMCP_OK or
 * DSMCP_ENOMEM. */
int dsmcp_hs_turn(dsmcp_t *d, const double *in, size_t nin, const double **out, size_t *nout);
void dsmcp_hs_final(dsmcp_t *d, const double *all, size_t n);
int dsmcp_hsmc(const dsmcp_t *d);

/* Free flight of the own particles over dt; those that left the slab are
 * removed and packed for their owners. DSMCP_OK or DSMCP_ENOMEM. */
int dsmcp_move(dsmcp_t *d, double dt);
/* The packed migrants: records of dsmcp_record_doubles() doubles, grouped
 * by destination rank in rank order, counts[r] records for rank r. Valid
 * until the next dsmcp_move(). */
int dsmcp_record_doubles(const dsmcp_t *d);
const double *dsmcp_outbox(const dsmcp_t *d, const size_t **counts);
/* After dsmcp_move(), once: the n records arriving from the other ranks,
 * in source-rank order, each source's records in its outbox order; the
 * first nlow come from lower ranks. DSMCP_OK, DSMCP_ENOMEM, or
 * DSMCP_EINVAL for a record outside this rank's slab. */
int dsmcp_arrive(dsmcp_t *d, const double *rec, size_t n, size_t nlow);
/* Sort and collide the own cells; this rank's part of the sums into *part. */
void dsmcp_collide(dsmcp_t *d, double dt, dsmcp_sums_t *part);
/* Install the summed words of all ranks and advance the clock
 * (to t_stop when last). */
void dsmcp_finish(dsmcp_t *d, const dsmcp_sums_t *sum, double dt, int last, double t_stop);

/* Totals after the last dsmcp_finish() (the same on every rank). */
typedef struct {
	double time, kinetic_energy;   /* kinetic energy from the exact fixed-point sum */
	uint64_t steps, collisions, candidates, vmax_raised, migrated, moves;
	uint64_t cell_collisions, rejected;   /* hsmc */
} dsmcp_totals_t;
void dsmcp_totals(const dsmcp_t *d, dsmcp_totals_t *out);

/* Start a new sampling interval, returning the one that ends: its length,
 * the integral of the kinetic energy over it (global: the same on every
 * rank) and this rank's collision virial sum of (sigma n) . J (to be summed
 * over ranks). */
void dsmcp_interval(dsmcp_t *d, double *interval, double *ekin_int, double *virial);

/* This rank's particles: count, and (each may be NULL) identities,
 * positions and velocities (dim doubles each) in the local order. */
size_t dsmcp_local(const dsmcp_t *d, uint64_t *ids, double *pos, double *vel);
/* This rank's share of the momentum (dim doubles, in local order: for
 * tests and reductions, not exact across ranks). */
void dsmcp_momentum(const dsmcp_t *d, double *mom);
/* Own planes [*p0, *p1) along the last axis, and the grid. */
void dsmcp_slab(const dsmcp_t *d, int *p0, int *p1, int nc[3]);
int dsmcp_dim(const dsmcp_t *d);
size_t dsmcp_memory(const dsmcp_t *d);

/*
 * Checkpoints (docs/output.md "Split runs"). Between steps (after
 * dsmcp_finish() or dsmcp_start()) the whole state is: every rank's records
 * in its local order, which concatenated in rank order is the 1-rank order;
 * the records per cell of the last sort (with CBA a record may have left
 * its cell since: its cell is where it was sorted, which the next hsmc
 * step needs); the per-cell remainders; the clock and counters; the
 * interval accumulators. None of it depends on P (but the statistic
 * `migrated`, which counts the migrants of the rank counts that ran), so a
 * state saved at P ranks restores at any P' (dsmcp_restore()): given the same stop times,
 * the restored run is bit for bit the uninterrupted one (the hsmc stamps
 * restart at 0, which no step's mark equals before step 2^32 - 1).
 */
typedef struct {
	double time, kinetic_energy, energy_scale, t_sample, ekin_int;
	uint64_t steps, collisions, candidates, vmax_raised, migrated, moves, cell_collisions, rejected;
} dsmcp_clock_t;
void dsmcp_clock(const dsmcp_t *d, dsmcp_clock_t *c);
/* This rank's own cells [*c0, *c1) (global indices). */
void dsmcp_cells(const dsmcp_t *d, uint64_t *c0, uint64_t *c1);
/* Records per own cell and the remainders (c1 - c0 each). */
void dsmcp_cell_state(const dsmcp_t *d, uint32_t *count, double *rem);
/* This rank's identities (uint32) in local order; the count. */
size_t dsmcp_local_ids(const dsmcp_t *d, uint32_t *ids);
/* This rank's part of the collision virial of the open interval. */
double dsmcp_virial_part(const dsmcp_t *d);
/* The cells rank `rank` of `ranks` owns for scene s and the grid's total:
 * DSMCP_OK, or DSMCP_EINVAL with msg. */
int dsmcp_cells_of(const scene_t *s, int rank, int ranks, uint64_t *c0, uint64_t *c1, uint64_t *ncells, char *msg,
                   size_t msglen);

/* A whole saved state in the 1-rank order (rank 0 of a checkpoint). */
typedef struct {
	dsmcp_clock_t clock;
	double virial;              /* summed over the ranks */
	int dim;
	uint64_t n, ncells;
	double *pos, *vel;          /* n * dim */
	uint32_t *id;               /* n */
	uint32_t *count;            /* ncells: records per cell at the last sort */
	double *rem;                /* ncells: no-time-counter remainders (floats, exact in doubles) */
} dsmcp_saved_t;
/* Arrays for n particles and ncells cells (zeroed struct otherwise):
 * DSMCP_OK or DSMCP_ENOMEM (then nothing is held). */
int dsmcp_saved_alloc(dsmcp_saved_t *sv, int dim, uint64_t n, uint64_t ncells);
void dsmcp_saved_free(dsmcp_saved_t *sv);
/* A loaded state fits scene s and is consistent (counts add up to N, the
 * identities a permutation, positions in the box, finite numbers):
 * DSMCP_OK, or DSMCP_EINVAL with the first reason in msg. */
int dsmcp_saved_check(const dsmcp_saved_t *sv, const scene_t *s, char *msg, size_t msglen);

/* Rank `rank` of `ranks` from a saved state: its own cells' part (the
 * records of cells [c0, c1) of dsmcp_cells_of(), nl of them, in the saved
 * order; count and rem of those cells), the global clock, and the virial
 * this rank carries (rank 0: the saved sum; others 0). No dsmcp_start()
 * follows. NULL with *err and msg. */
dsmcp_t *dsmcp_restore(const scene_t *s, uint64_t stream, int rank, int ranks, const dsmcp_clock_t *c, double virial,
                       size_t nl, const double *pos, const double *vel, const uint32_t *id, const uint32_t *count,
                       const double *rem, int *err, char *msg, size_t msglen);
