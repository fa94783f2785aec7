/* Exact event-driven simulation of inelastic hard disks (2D) and spheres (3D) in a periodic box or between walls, optionally under gravity and around fixed obstacles. */
#pragma once

#include <stdint.h>
#include "scene.h"

/*
 * Contract
 * - Pure computation: no I/O, no globals, no allocation per event. All
 *   memory is allocated in ed_create() and freed in ed_destroy().
 * - Units are the scene's (lengths, masses, k_B = 1). Times are absolute
 *   simulated times since the start of the production run (after the
 *   optional elastic pre-run, which does not count).
 * - Determinism: for one scene (including its seed) the sequence of events
 *   and every number derived from it is identical from run to run and does
 *   not depend on how often the caller samples (sampling never moves
 *   particles; see docs/engine.md, "Precision").
 */

typedef struct ed ed_t;

enum {
	ED_OK = 0,
	ED_ENOMEM = -1,
	ED_EPLACE = -2,    /* initial positions could not be placed */
	ED_EINVAL = -3,    /* scene not usable by this method */
	ED_QUIESCENT = 1,  /* ed_advance: no further event can ever happen */
	ED_COLLAPSE = 2,   /* ed_advance: inelastic collapse (ed_watch_collapse()) */
	ED_FULL = 3,       /* ed_advance: a particle was due to enter through a reservoir wall and every
	                      slot is taken (particles.capacity); the state is intact, the entry not made */
};

/* Build the initial state (positions, Maxwellian velocities with zero total
 * momentum, optional elastic pre-run). Returns NULL on failure with *err set
 * and a one-line reason in msg (msglen bytes; msg may be NULL). */
ed_t *ed_create(const scene_t *s, int *err, char *msg, size_t msglen);
void ed_destroy(ed_t *ed);

/* What ed_create() would build for scene s, without building it (pure, no
 * allocation; the lattice search is O(N^(1/2)) in 2D, O(N^(2/3)) in 3D):
 * the checks it makes before running (cell grid of at most 64 cells per
 * particle beyond the first million; a lattice whose nearest distance is at least a diameter;
 * random placement below the jamming coverage of random sequential
 * addition, 0.547 in 2D and 0.384 in 3D) and the sizes. Returns ED_OK,
 * or ED_EINVAL / ED_EPLACE with "KEY: reason" in msg (the scene parser
 * reports it: scene.h). out may be NULL (checks only). Random placement
 * below jamming may still exhaust its tries at start (a property of the
 * random sequence; docs/scene.md). */
typedef struct {
	uint64_t memory;       /* bytes the engine allocates: ed_memory() of the built engine */
	uint64_t state;        /* bytes of its state fields (ed_fields()): a checkpoint's data; the
	                          neighbour lists at their mean length */
	uint64_t largest;      /* bytes of the largest state field (checkpoints copy one field at a time) */
	uint64_t cells;
	int neighbour_lists;   /* 1: neighbour-list mode (dense), 0: cell mode */
} ed_plan_t;
int ed_plan(const scene_t *s, ed_plan_t *out, char *msg, size_t msglen);

/* Process events in time order until the next event would lie beyond
 * t_stop, or the total collision count reaches max_collisions, or
 * max_events further events were processed, whichever comes first. Use
 * INFINITY / UINT64_MAX for "no limit". When stopped by t_stop the clock is
 * set to t_stop. Returns ED_OK, or ED_QUIESCENT when no event remains (the
 * clock is then set to t_stop if finite), or ED_COLLAPSE (below). */
int ed_advance(ed_t *ed, double t_stop, uint64_t max_collisions, uint64_t max_events);

/*
 * Inelastic collapse: without the TC model, strongly inelastic particles can
 * collide infinitely often in finite time; the engine then processes
 * collisions at (numerically) one instant and the clock stalls. With
 * ed_watch_collapse(ed, rate) (rate > 0; 0 turns it off, the default),
 * ed_advance() checks at each clock rebase (every 8N events, at least 4096:
 * part of the dynamics, so at the same events in every run and across a
 * restore) whether the events since the previous rebase came faster than
 * rate * sqrt(T) per particle per unit time (T = 2 E_kin / (D N) now), and
 * then returns ED_COLLAPSE at once, the state intact. ed_collapse() gives
 * the window that fired (NULL before). Costs O(1) per 8N events.
 */
typedef struct {
	double time;          /* absolute time of the rebase that fired */
	double interval;      /* time the window's events took (may be 0) */
	uint64_t events;      /* events in the window */
	double temperature;   /* T at the end of the window */
} ed_collapse_t;
void ed_watch_collapse(ed_t *ed, double rate);
const ed_collapse_t *ed_collapse(const ed_t *ed);

/* Impact parameters (issue 17, engine/observe): with counts != NULL each
 * particle collision (an approaching pair) adds 1 to counts[k], k the bin of
 * b / |r_ij| in [0, 1] over nb equal bins, b = |r_ij x g| / |g| the distance
 * of the pre-collision relative trajectory from the centre (|r_ij| = sigma
 * at contact). The caller owns counts (nb doubles) and resets it; NULL stops
 * counting. Not state: changes nothing in the dynamics, not checkpointed. */
void ed_count_impacts(ed_t *ed, double *counts, int nb);

/* Interval statistics since the previous ed_sample() (or the start). */
typedef struct {
	double time;             /* current simulated time */
	double interval;         /* length of the interval */
	uint64_t events;         /* totals since the start */
	uint64_t collisions;
	uint64_t interval_collisions;
	uint64_t elastic_by_tc;  /* collisions made elastic by the TC model (total) */
	double kinetic_energy;   /* total, exact from velocities, now */
	double momentum[3];      /* total, now */
	double ekin_time_integral;  /* integral of E_kin dt over the interval */
	double virial;           /* sum over collisions in the interval of r_ij . J_ij */
	/* Scenes with walls (boundaries): wall w = 2 axis + end (0 lower, 1
	 * upper). wall_impulse[w]: momentum given to wall w over the interval
	 * (its time average force is wall_impulse / interval; the normal
	 * component along the axis is positive for a push outwards at the
	 * lower wall, negative at the upper). Zero without walls. */
	uint64_t wall_collisions;       /* particle-wall collisions (total) */
	uint64_t wall_hits[6];          /* ... per wall (total) */
	double wall_impulse[6][3];
	/* Scenes with gravity g: centre-of-mass height along -g (from the
	 * lower walls' rest positions; scene coordinates) and potential energy
	 * -m sum g.r, now. NAN without gravity. */
	double com_height, potential_energy;
	/* Scenes with obstacles (scene.h): obstacle k's hits (total) and the
	 * momentum given to it over the interval (its mean force, the drag, is
	 * obstacle_impulse / interval). Zero without obstacles. */
	/* Scenes with open walls: particles still in the system, and those
	 * that left through each wall (total). particles = N otherwise. */
	uint64_t particles;
	uint64_t wall_outflow[6];
	/* Reservoir walls: particles that entered through each wall, and
	 * entries rejected because they would have overlapped a particle, an
	 * obstacle or a side wall (totals). Zero without. */
	uint64_t wall_inflow[6], wall_rejected[6];
	int n_obstacles;
	uint64_t obstacle_collisions;   /* particle-obstacle collisions (total) */
	uint64_t obstacle_hits[SCENE_OBSTACLES_MAX];
	double obstacle_impulse[SCENE_OBSTACLES_MAX][3];
	/* Rough particles (collisions.rough): rotational energy I/2 sum w^2,
	 * I = q m (sigma/2)^2, now; NAN for smooth particles. kinetic_energy
	 * is the translational part. */
	double rotational_energy;
	/* Mixtures (particles.species, two or more): kinetic energy of each
	 * species now (T_s = 2 E_s / (D N_s)) and its particle count;
	 * n_species = 0 for one species. */
	int n_species;
	double species_kinetic_energy[SCENE_SPECIES_MAX];
	uint64_t species_count[SCENE_SPECIES_MAX];
} ed_sample_t;

/* Fill *out and start a new interval. Does not change the dynamics. */
void ed_sample(ed_t *ed, ed_sample_t *out);

/* Positions (wrapped into the box) and velocities at the current time, as
 * N*D doubles in particle order. Either pointer may be NULL. */
void ed_state(const ed_t *ed, double *pos, double *vel);

/* Scenes where the engine follows periodic images (scene_msd_images(): mean_square_displacement with
 * something that feeds energy): positions at the current time as N*D doubles in particle order, NOT folded:
 * on periodic axes the engine's position plus the box edges it was wrapped by (exact: counted at each
 * wrap), on walled axes as ed_state(). NaN rows for particles gone (open walls) and empty slots.
 * ED_EINVAL (nothing written) in other scenes. O(N). */
int ed_unwrapped(const ed_t *ed, double *pos);
/* Rough particles: spin components per particle (1 in 2D: about z; 3 in
 * 3D), 0 for smooth ones; ed_spins() writes N * ed_spin_dim() angular
 * velocities (radians per unit time) in particle order. */
int ed_spin_dim(const ed_t *ed);
void ed_spins(const ed_t *ed, double *w);

/* Scenes with a reservoir wall: ed_state() and ed_labels() have one row
 * per slot (scene_slots()); ed_labels() writes each row's particle id
 * (unique over the run, never reused) or -1 for an empty slot and returns
 * ED_OK; ED_EINVAL without a reservoir (rows are the particles then). */
uint32_t ed_slots(const ed_t *ed);
int ed_labels(const ed_t *ed, int64_t *ids);

double ed_time(const ed_t *ed);
uint64_t ed_collisions(const ed_t *ed);
uint64_t ed_events(const ed_t *ed);
/* Smallest pair distance minus the contact distance (negative = overlap);
 * O(N) via the cell list. For tests and diagnostics. */
double ed_min_gap(const ed_t *ed);
/* Cell grid in use (cells per axis) and memory held, for benchmarks. */
void ed_cells(const ed_t *ed, int cells[3]);
size_t ed_memory(const ed_t *ed);

/* Totals now (time, counters, kinetic energy, momentum) without starting a
 * new interval: unlike ed_sample() it changes nothing. Interval fields 0. */
void ed_totals(const ed_t *ed, ed_sample_t *out);

/*
 * Checkpoints (no I/O here: the caller stores the fields where it wants).
 * The state is a list of named fields, each an array of count elements of one
 * type; ed_fields() lists them in an order that ed_field_set() accepts
 * (a field's count may depend on earlier fields: "nb" has sum("nn")
 * entries). Saving every field at any moment between ed_advance() calls and
 * restoring them into ed_create_blank() + ed_field_set() ... +
 * ed_restore_finish() gives an engine whose further events, states and
 * samples are bit-for-bit those of the original (the event calendar is
 * rebuilt: its pop order depends only on event times and particle indices).
 * Field data are native-endian.
 */
typedef enum { ED_T_F64 = 0, ED_T_U64, ED_T_I64, ED_T_I32, ED_T_U32, ED_T_U8 } ed_type_t;
typedef struct {
	const char *name;    /* static string */
	ed_type_t type;
	size_t count;        /* elements */
} ed_field_t;
#define ED_MAX_FIELDS 64

size_t ed_type_size(ed_type_t t);
/* Describe the fields of the current state into out[max]; returns how many
 * there are (may exceed max: then only max were written). */
int ed_fields(const ed_t *ed, ed_field_t *out, int max);
/* Copy field name into buf (count * ed_type_size(type) bytes, as listed by
 * ed_fields() now). ED_EINVAL for an unknown name. */
int ed_field_get(const ed_t *ed, const char *name, void *buf);
/* An engine for scene s with memory but no state: only for restoring. */
ed_t *ed_create_blank(const scene_t *s, int *err, char *msg, size_t msglen);
/* Set one field; ED_EINVAL if name, type or count does not fit this scene. */
int ed_field_set(ed_t *ed, const char *name, ed_type_t type, size_t count, const void *buf);
/* After all fields are set: check the state's consistency (indices in range,
 * cell lists) and rebuild the calendar. ED_EINVAL with a reason in msg. */
int ed_restore_finish(ed_t *ed, char *msg, size_t msglen);

const char *ed_strerror(int code);

/*
 * Event trace (issue 14: serial event statistics for the parallel model,
 * bench/par_model). Exists only in a build compiled with -DED_TRACE (the
 * bench-only instrumented copy of ed.c that bench/par_model links); the
 * engine, the daemon and the tests are built without it and contain no
 * trace code at all (the hook's three call sites in ed_impl.h expand to
 * nothing). Periodic scenes in cell mode only (the kernels without walls,
 * gravity, species or roughness); ed_trace() returns ED_EINVAL otherwise.
 * fn is called before each event is carried out, with the cells (engine
 * cell coordinates, ed_cells() per axis) of the particles involved.
 */
#ifdef ED_TRACE
enum { ED_TRACE_COLLISION = 0, ED_TRACE_CANCELLED = 1, ED_TRACE_CROSS = 2 };
typedef struct {
	double t;          /* absolute time of the event */
	int kind;          /* ED_TRACE_* */
	int32_t ci[3];     /* cell of the event's particle (before a crossing) */
	int32_t cj[3];     /* collision / cancelled: the partner's cell; crossing: the cell entered (wrapped) */
	uint32_t i, j;     /* scene index of the particle and of the partner (UINT32_MAX for a crossing) */
} ed_trace_t;
typedef void (*ed_trace_fn)(void *ctx, const ed_trace_t *ev);
int ed_trace(ed_t *ed, ed_trace_fn fn, void *ctx);
#endif
