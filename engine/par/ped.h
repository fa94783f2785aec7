/* Parallel event-driven hard disks/spheres: one rank's share of one periodic system (cells of a Morton range, ghosts, border updates, rollback); pure, no MPI. */
#pragma once

#include <stddef.h>
#include <stdint.h>

/*
 * Contract (issue 14, first slice; docs/parallel.md "The parallel ED engine")
 * - Scope: periodic box, one species, smooth particles, constant normal
 *   restitution e with the TC model (tc >= 0; 0 = off). Nothing else.
 * - Pure computation: no MPI, no I/O, no globals. Every rank holds one
 *   ped_t; a driver (ped_sim_run() below for P ranks in one process, or
 *   pedmpi.c over MPI) moves the messages and the two reductions per round.
 * - Decomposition: the cell grid numbered in Morton order (decomp.h), rank r
 *   owns a contiguous Z range and every particle whose cell it owns. It
 *   keeps bitwise copies (ghosts) of the particles in the other ranks' cells
 *   that neighbour its own; ghosts have no events.
 * - Events: an event is a border event if it touches a border cell (an
 *   own cell next to another rank's), a guard cell (an own cell next to a
 *   border cell) or a ghost: a collision with a particle there, a crossing
 *   from or into such a cell. All others are interior.
 * - Round (the driver): (1) apply the messages of the previous round,
 *   (2) process the own events in local time order (ped_run()): interior
 *   ones up to the barrier B, border ones up to the round's horizon H
 *   (optimistically: other ranks may not have reached H), stopping at the
 *   first border event beyond H or collision with a ghost of lower id (its
 *   owner processes it and sends the partner's new state), (3) send the
 *   changed particles to the neighbour ranks that see them (point to point),
 *   (4) global min of the error times E and of the next unprocessed event
 *   times T, and whether anything was sent. On an error all ranks restore
 *   the state saved at the last sync and run again with the barrier at the
 *   error time (window and sync interval halve); if T >= B and nothing was
 *   sent every event before B is done: sync (save; both grow by 1.1);
 *   otherwise the next horizon is H = T + W, W the optimistic window
 *   (ped_sched_t). W = 0 is the exact global time order of border events
 *   (one border event time per round).
 *   Causality errors: a border event meets a particle that already had a
 *   later event; a message changes a particle next to an own particle that
 *   already had an event after the message's time; a message's collision
 *   counter does not match the receiver's copy.
 * - Exactness: the committed collisions are those of the serial engine from
 *   the same initial state (times to rounding: pair times are computed from
 *   the pair's later reference time, the lower id first, and again from the
 *   two records when processed). For one rank count and one schedule (sync
 *   interval, window, stops) a run is bit for bit reproducible; the
 *   committed collisions do not depend on where syncs and rollbacks fall,
 *   their times may differ in the last bits (a rank that runs ahead may take
 *   a pair's time from a ghost whose cell crossing, the same course from a
 *   later reference point, has not arrived yet).
 *   More causality errors, once border events run ahead of global time order:
 *   a message changes an own particle (a collision another rank made) that
 *   still has a valid pending collision before the change, in its calendar
 *   entry or a neighbour's; an event processed out of time order changes a
 *   particle next to one whose course since then already had an event (own
 *   particles: their courses since the change are checked for contact; ghosts
 *   this rank moved or collided: any such event counts).
 * - Load balancing (off unless the driver's ped_sched_t.balance is set):
 *   at a global sync the bounds may change and the particles move to their
 *   new owners with their records unchanged (see "Load balancing at a
 *   global sync" below).
 * - Memory per rank: particles of its cells and ghosts (fixed capacity),
 *   one saved copy, and a per-cell role byte and head index over the whole
 *   grid (O(cells), not O(N/P): a known limitation of this slice).
 */

enum { PED_OK = 0, PED_ENOMEM = -1, PED_EINVAL = -2, PED_EFULL = -3, PED_ESTALL = -4, PED_STOPPED = 1 };

typedef struct {
	int dim;            /* 2 or 3 */
	double L[3];        /* box edges */
	double sigma;       /* diameter */
	double mass;
	double e;           /* normal restitution */
	double tc;          /* TC model time, 0 = off */
	int nc[3];          /* cells per axis, each >= 3, edge >= sigma */
	int ranks;
} ped_params_t;

/* A changed particle as sent to a rank that sees it. */
typedef struct {
	double r[3], v[3], t, tlast, tev, tu;  /* state (tev: its last event), time of the change */
	uint64_t count, pre_count;             /* collision counter after and before the change */
	uint32_t gid;                          /* particle id (scene order) */
	int32_t cc[3], oc[3];                  /* cell after and before */
	int32_t apply;                         /* 1: the receiver owns it (a collision made by another rank) */
} ped_msg_t;

typedef struct {
	double t;            /* collision time */
	uint32_t i, j;       /* ids, i < j */
} ped_coll_t;

typedef struct ped ped_t;

/* Cell grid as the serial engine would choose for N particles (edge >= sigma,
 * about 1.5 cells per particle in 2D, 8 in 3D). */
void ped_grid(ped_params_t *p, uint64_t n);

/* Rank `rank` of p->ranks: NULL with *err set on bad input or no memory.
 * capacity: most particles (own + ghosts) the rank may hold. */
ped_t *ped_create(const ped_params_t *p, int rank, size_t capacity, int *err);
void ped_destroy(ped_t *pd);

/* Take the particles of the own and ghost cells from the whole initial
 * state (n particles, positions in the box, velocities; n*dim doubles each,
 * time 0) and save it as the first sync. */
int ped_load(ped_t *pd, uint64_t n, const double *pos, const double *vel);
/* The same with every particle's state at time t0 (all events before it
 * done) and, when tlast is not NULL, its last collision time (TC model; n
 * doubles, -INFINITY: none): a resumed run. */
int ped_load_at(ped_t *pd, uint64_t n, const double *pos, const double *vel, const double *tlast, double t0);

/* The rank's whole core state at a sync (particle records and their slots,
 * cell lists, calendar entries, counters, bounds, the balance window), as
 * plain bytes for a checkpoint: ped_image_load() into a fresh ped_t of the
 * same scene, rank and rank count continues bit for bit as the saved one
 * would (instead of ped_load_at()). Native byte order. Returns the size;
 * load: PED_OK, PED_EINVAL (not this rank's image of this system),
 * PED_ENOMEM. */
size_t ped_image_size(const ped_t *pd);
size_t ped_image_write(const ped_t *pd, unsigned char *buf);
int ped_image_load(ped_t *pd, const unsigned char *buf, size_t len);

/* Round steps (see the contract). */
int ped_inbox(ped_t *pd, const ped_msg_t *m, size_t n);   /* PED_OK or PED_EFULL */
/* Process the own events before the barrier, border events only up to the
 * horizon (included); returns the time of the next unprocessed event before
 * the barrier (INFINITY: none) and in *done (may be NULL) how many it did. */
double ped_run(ped_t *pd, double horizon, double barrier, uint64_t *done);
double ped_error(const ped_t *pd);                        /* earliest causality error this section, INFINITY if none */
/* The ranks this rank may send to (owners of cells within two cells of its
 * own; ascending): the neighbour exchange. Returns how many. */
int ped_neighbours(const ped_t *pd, const int **ranks);
const ped_msg_t *ped_outbox(const ped_t *pd, int dest, size_t *n);
void ped_outbox_clear(ped_t *pd);
void ped_save(ped_t *pd);
void ped_restore(ped_t *pd);

/* Totals of this rank: committed collisions it logged (each collision is
 * logged by exactly one rank), TC-elastic ones among them, committed events
 * (collisions, crossings and cancelled predictions it processed; a
 * collision of two ranks' particles counts on the rank that made it), events
 * it processed including those later rolled back (work done), particles it
 * owns. */
typedef struct {
	uint64_t collisions, tc_elastic, events, events_done, owned;
	double ekin, mom[3];
	/* since ped_mark() (the start otherwise), of the collisions this rank
	 * made: the collision virial (sum of r_ij . J_ij, as the serial
	 * engine's), the sum of the kinetic energy changes dE and of dE (t_c -
	 * tref), tref the mark's time: the integral of the total E_kin over
	 * [tref, t] is E_kin(tref) (t - tref) + sum_ranks (dekin (t - tref) - dekin_t) */
	double virial, dekin, dekin_t;
} ped_totals_t;
void ped_totals(const ped_t *pd, ped_totals_t *out);
/* Start a new interval at time t: the interval sums of ped_totals() to 0.
 * Only right after a sync (ped_save(), or pedmpi_advance() returned), so that
 * a rollback cannot bring back collisions from before the mark. */
void ped_mark(ped_t *pd, double t);
/* Bytes held by this rank's ped_t. */
size_t ped_memory(const ped_t *pd);
/* Collision log (committed and since-last-sync ones, in processing order),
 * on only with ped_log_on(). */
void ped_log_on(ped_t *pd);
const ped_coll_t *ped_log(const ped_t *pd, size_t *n);
/* Owned particles: ids and positions/velocities (at their own times moved to
 * time t) into caller arrays of ped_totals().owned entries. */
void ped_owned(const ped_t *pd, double t, uint32_t *gid, double *pos, double *vel);
/* Their last collision times (TC model; -INFINITY: none), in ped_owned()'s order. */
void ped_owned_tlast(const ped_t *pd, double *tlast);

/* A scene on the core (scene.h's scene_t; the engine program's split run,
 * engine/par/edrun.h, and the daemon's budget, engine/budget.c):
 * ped_scene_check() is 0 when the split run can run scene s (out: with
 * --out), else -1 with "KEY: reason" in msg (msg may be NULL): the core's
 * scope (periodic box, one species, smooth particles, constant restitution,
 * inelastic with the TC model), time schedules, observables that are sums
 * over the particles, at least 3 cells per axis. ped_scene_bytes(): bytes
 * one rank's ped_t allocates for s over P ranks (capacity N: room for every
 * particle on every rank). */
struct scene;
int ped_scene_check(const struct scene *s, int out, char *msg, size_t msglen);
uint64_t ped_scene_bytes(const struct scene *s, int P);

/* Driver statistics. */
typedef struct {
	uint64_t rounds, syncs, rollbacks, messages, bytes;
	double sync_dt;        /* current sync interval */
	double window;         /* current optimistic window */
	uint64_t rebalances;   /* load balancing (ped_sched_t.balance): rebalances made */
	uint64_t migrated;     /* particles that changed owner in them (this rank's arrivals; summed by ped_sim_run()) */
} ped_stats_t;

/* Load balancing at a global sync (docs/parallel.md "Load balancing at run
 * time"). The core counts the events it processes (rolled-back ones
 * included: the work done) per cell since the window's start
 * (ped_window_reset(): at the load and after each rebalance). At a sync the
 * driver gathers every rank's ped_window_events(); when ped_balance_due()
 * says so, it sums every rank's ped_window_cost() over the Z space
 * (ped_zsize() entries, zeroed by the caller), computes new bounds with
 * ped_balance_bounds() (decomp_balance_prefix_keep() with tolerance
 * PED_BALANCE_TOL, the same on every rank) and, when they changed, moves the
 * particles: ped_migrate_out() on every rank (installs the new bounds and
 * fills the outboxes with each own particle for every rank that owns or sees
 * its cell under them, itself included; the rank's state is unusable until
 * ped_migrate_in()), the outboxes exchanged (all to all), ped_migrate_in()
 * on every rank with everything it received: the rank's particles rebuilt
 * with their records unchanged (position, velocity, own time, TC time,
 * collision counter), predicted afresh, the state saved as the sync.
 * Everything is a function of the state at the sync and of the event counts,
 * so a run at one rank count stays reproducible bit for bit; the committed
 * collisions are the serial engine's as with any decomposition (times to
 * rounding). */
#define PED_BALANCE_TOL 1.0
uint64_t ped_window_events(const ped_t *pd);
void ped_window_cost(const ped_t *pd, double *cost);   /* adds this rank's cells' counts at their Z ids */
void ped_window_reset(ped_t *pd);
uint64_t ped_zsize(const ped_t *pd);
const uint64_t *ped_bounds(const ped_t *pd);           /* the P + 1 bounds in use */
/* 1 when the busiest rank's window events exceed the mean by more than the
 * Poisson noise of the busiest of P counts (max / mean > 1 + sqrt(2 ln P /
 * mean)) and by at least n / P events (n particles: the rebuild costs about
 * one prediction per own particle); *imbalance = max / mean (1 when idle). */
int ped_balance_due(const uint64_t *events, int P, uint64_t n, double *imbalance);
/* New bounds into newb[P + 1]: 1 if they differ from the present ones, 0 if
 * not, a negative PED_ code on failure. */
int ped_balance_bounds(const ped_t *pd, const double *cost, uint64_t *newb);
int ped_migrate_out(ped_t *pd, const uint64_t *newb);
/* *moved_in: the particles that came to own here from another rank. */
int ped_migrate_in(ped_t *pd, const ped_msg_t *m, size_t n, uint64_t *moved_in);

/* The optimistic window at the start, as a fraction of the first sync
 * interval (ped_sched_init()). */
#define PED_WINDOW (1.0 / 32.0)
/* Relative slack of the horizon beyond T + window: two ranks' times for one
 * pair of particles may differ by rounding, and the rank waiting for the
 * other reports its own (ped_run()). */
#define PED_SLACK 1e-12

/* Driver decision shared by the in-process and MPI drivers: after the
 * reduction of a round (E = min error time, T = min next event time, quiet =
 * no rank sent anything this round), returns 0: next round with border
 * events up to horizon; 1: rollback (restore; barrier set to E); 2: sync
 * reached (save; barrier advanced); 3: done (t_end reached); -1: no progress
 * possible (an error at the sync itself in a section already run in global
 * time order). window: border events are processed up to T + window (0: in
 * global time order); it and sync_dt halve at a rollback and grow by 1.1 at
 * a sync. An error at the last sync itself runs the section again with
 * window 0 (cons). */
typedef struct {
	double barrier, t_end, sync_dt;
	double window, horizon, t_sync;
	int cons;
	int balance;         /* 1: load balancing at syncs (set after ped_sched_init(); off by default) */
	ped_stats_t st;
} ped_sched_t;
void ped_sched_init(ped_sched_t *s, double t_end, double sync_dt);
/* Continue a schedule from a sync at t0 (every event before t0 done) to a
 * new t_end; the sync interval, window and statistics carry over. */
void ped_sched_next(ped_sched_t *s, double t0, double t_end);
int ped_sched(ped_sched_t *s, double E, double T, int quiet);

/* P ranks in one process (tests): runs pd[0..P-1] to t_end. window >= 0
 * sets the first optimistic window (< 0: ped_sched_init()'s). force_every > 0
 * injects a rollback every force_every rounds (barrier halfway to T). */
int ped_sim_run(ped_t **pd, int P, double t_end, double sync_dt, double window, int force_every, ped_stats_t *st);
/* The same with load balancing at the syncs when balance != 0, as the MPI
 * driver does it (ped_sim_run() is this with balance 0). n: the particles. */
int ped_sim_run_bal(ped_t **pd, int P, uint64_t n, double t_end, double sync_dt, double window, int force_every,
                    int balance, ped_stats_t *st);
