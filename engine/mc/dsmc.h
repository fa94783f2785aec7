/* Direct simulation Monte Carlo of inelastic hard disks/spheres (Bird's scheme, Enskog/CBA corrections) and Mueller's hybrid HSMC. */
#pragma once

#include <stddef.h>
#include <stdint.h>
#include "ed/ed.h"      /* ed_type_t, ed_field_t: the state-field description shared by the engines */
#include "scene.h"

/*
 * Contract
 * - Pure computation: no I/O, no globals, no allocation after dsmc_create().
 * - Units are the scene's: diameter sigma = 2 * radius, mass m, k_B = 1,
 *   T = 2 E_kin / (D N). Periodic box, or walls on some axes and a uniform
 *   gravity (scene.h): then free flight is exact (parabolas, wall hits at
 *   the roots of a quadratic, the rest of the flight reflected by the
 *   wall's rule; a particle touches a wall when its centre is one radius
 *   from it, as in ed) and the cells tile the box; collisions stay cell-local.
 *   Walls: specular, thermal, rough, moving, vibrating (contact times by
 *   walltime_vibrating(), the rule applied relative to the wall's velocity;
 *   the wall's phase is a function of the clock, so checkpoints hold
 *   nothing more), open (a particle that reaches one leaves: its record
 *   goes after the particles present, dsmc_state() gives NaN for it,
 *   energies and heights are over the particles present; ed's semantics,
 *   docs/scene.md). A source (particles.source): n = count + source count
 *   records, those not inserted yet wait after the present ones (at rest,
 *   NaN in dsmc_state()); each insertion is due at k / rate, steps land on
 *   it, and it is made between steps (source_insert(): above the highest
 *   centre present, into its cell's records); ids count + k - 1 in order. Mixtures (particles.species, dsmc and hsmc): each
 *   particle's own radius for its wall and obstacle contacts, its own mass
 *   for impulses and a thermal wall's or no_slip obstacle's re-emission
 *   (sqrt(T / m_s)); walls of every kind; with correction enskog or cba each
 *   pair's contact value chi_ij (dsmc_contact_coefs()); hsmc: a cell is full
 *   when the volume of its particles reaches max_volume_fraction of it, and a
 *   cell collision has the cell's mass and centre-of-mass velocity. Obstacles (fixed-wall variant only; refused with
 *   vibrating or open walls): exact contact times with each obstacle's
 *   contact sphere within the flight (ed/obstacle.h), ed's rule
 *   (obstacle_rule()), walls and obstacles in one loop; no centre ends a
 *   step inside one; a cell an obstacle cuts collides at the rate of its
 *   free volume (docs/engine.md). A scene without walls, gravity and obstacles
 *   runs the periodic step, which has no wall code at all; one without a
 *   vibrating or open wall runs the fixed-wall step, which has no code for
 *   them (the variant is chosen at load). With a vibrating lower wall the
 *   engine's internal coordinates are the scene's shifted by its amplitude
 *   (as ed's); every output is in scene coordinates.
 * - One step of length dt (operator splitting, seed 000 eq. 2.19):
 *   [hsmc only: coarse-grain cells, cell-cell pseudo-collisions, return of
 *   their lost energy as thermal motion]; free flight (hsmc: moves into
 *   full cells rejected); counting sort into cells; in each cell
 *   chi * N_c (N_c - 1) sigma_T v_max dt / (2 V_c) candidate pairs (no-time-
 *   counter, the fractional remainder carried per cell), each accepted with
 *   probability |g| / v_max, impact parameter uniform (molecular chaos),
 *   normal restitution along the contact normal it defines.
 *   sigma_T = 2 sigma (2D), pi sigma^2 (3D).
 * - v_max per cell is the strict bound 2 max_i |v_i - u_c| (u_c the cell's
 *   mean velocity at the start of its collision step). A collision that
 *   raises max_i |v_i - u_c| raises v_max, and later candidates then cost
 *   less of the cell's budget (thinning of a Poisson process), so the
 *   collision rate stays exact (vmax_raised counts these raises).
 * - Determinism: for one scene (seed and stream included) and one sequence
 *   of dsmc_advance() stop times, every number is identical from run to run.
 *   Output times cut a step short (steps land exactly on t_stop), so the
 *   output schedule changes the random sequence, not the statistics.
 */

typedef struct dsmc dsmc_t;

enum {
	DSMC_OK = 0,
	DSMC_ENOMEM = -1,
	DSMC_EINVAL = -2,    /* scene not usable (message says why) */
	DSMC_QUIESCENT = 1,  /* dsmc_advance: T = 0 and no finite stop time */
};

/* Parameters resolved from the scene: defaults from the validity conditions
 * (Bird; seed 000 sec. 2.4.1): cell edge = the mean free path lambda of the
 * simulated gas, but not below chaos_edge (enough cell mates that a pair
 * rarely collides twice: dense gases) nor, for hsmc, 2 sigma; adaptive time
 * step of 0.2 mean free times. Both lengths in the scene's units. */
typedef struct {
	int hsmc;                 /* 1 for the hybrid method */
	int correction;           /* SCENE_MC_NONE / _ENSKOG / _CBA */
	double chi;               /* collision-rate factor: g(sigma) at the mean volume fraction, or 1 */
	int local_chi;            /* 1: g(sigma) per cell at the local volume fraction (3^D cell block,
	                             capped at max_volume_fraction) instead of chi */
	double cell_edge;         /* requested minimum cell edge (length units) */
	double time_step;         /* fixed step, or 0 */
	double collisions_per_step; /* adaptive step dt = this / f_E(T), or 0 */
	double max_volume_fraction; /* hsmc: a cell at or above this is full */
	double mean_free_path;    /* lambda_E at the initial temperature */
	double mean_free_time;    /* tau_E = 1 / f_E at the initial temperature */
	double chaos_edge;        /* smallest cell edge that keeps repeated pair collisions rare */
} dsmc_params_t;

/* Resolve the parameters of s (method dsmc or hsmc). warn (may be NULL)
 * receives "" or one line listing the validity conditions the scene
 * breaks. Returns DSMC_OK or DSMC_EINVAL. */
int dsmc_params(const scene_t *s, dsmc_params_t *p, char *warn, size_t warnlen);

/* What dsmc_create() would build for scene s, without building it (pure,
 * no allocation): the checks it makes before allocating (the cell grid:
 * at most 64 cells per particle) and the sizes. Returns DSMC_OK, or
 * DSMC_EINVAL with "KEY: reason" in msg (the scene parser reports it; see
 * scene.h). out may be NULL (checks only). */
typedef struct {
	uint64_t memory;   /* bytes the engine allocates: dsmc_memory() of the built engine */
	uint64_t state;    /* bytes of its state fields (dsmc_fields()): a checkpoint's data */
	uint64_t largest;  /* bytes of the largest state field (checkpoints copy one field at a time) */
	uint64_t cells;
} dsmc_plan_t;
int dsmc_plan(const scene_t *s, dsmc_plan_t *out, char *msg, size_t msglen);

/* Build the initial state: positions (lattice: a simple grid; random:
 * uniform, no overlap check since the particles are points to DSMC),
 * Maxwellian velocities with zero total momentum scaled to exactly T,
 * optional elastic pre-run (initial.relax, not counted). Random stream:
 * rng_init(seed, stream). NULL on failure with *err and msg set. */
dsmc_t *dsmc_create(const scene_t *s, uint64_t stream, int *err, char *msg, size_t msglen);
void dsmc_destroy(dsmc_t *d);

/* Take steps until the clock reaches t_stop (the last step is shortened to
 * land on it), or the collision count reaches max_collisions (at the end of
 * the step that reaches it), or max_steps steps were taken. INFINITY /
 * UINT64_MAX mean no limit. Returns DSMC_OK, or DSMC_QUIESCENT when the
 * adaptive step is infinite (T = 0) and t_stop is infinite. */
int dsmc_advance(dsmc_t *d, double t_stop, uint64_t max_collisions, uint64_t max_steps);
/* The same, also stopping after the step that reaches or passes t_soft
 * (that step is not shortened): a schedule (frames, checkpoints) that must
 * not change the step sequence, unlike t_stop. */
int dsmc_advance_soft(dsmc_t *d, double t_stop, double t_soft, uint64_t max_collisions, uint64_t max_steps);

typedef struct {
	double time;               /* current simulated time */
	double interval;           /* since the previous dsmc_sample() */
	uint64_t steps, moves;     /* totals: steps, particle moves (N per step) */
	uint64_t collisions;       /* accepted binary collisions, total */
	uint64_t interval_collisions;
	uint64_t candidates;       /* candidate pairs tested, total */
	uint64_t vmax_raised;      /* candidates that exceeded the cell's v_max bound */
	uint64_t cell_collisions;  /* hsmc: cell-cell pseudo-collisions, total */
	uint64_t rejected_moves;   /* hsmc: moves into full cells rejected, total */
	double kinetic_energy;     /* total, now (exact pass over the particles) */
	double momentum[3];        /* total, now */
	double ekin_time_integral; /* integral of E_kin dt over the interval */
	double virial;             /* sum over collisions in the interval of (sigma n) . J */
	/* Scenes with walls, as ed_sample_t: wall w = 2 axis + end (0 lower,
	 * 1 upper); wall_impulse[w]: momentum given to wall w over the interval
	 * (zero without walls). rested: flights that ended resting on a wall
	 * or rode a vibrating one (dsmc.c, flight(), flight_vib()), total. */
	uint64_t wall_collisions, wall_hits[6], rested;
	double wall_impulse[6][3];
	/* Open walls: particles present now (N without open walls) and the
	 * number that left through each wall, totals (as ed_sample_t). */
	uint64_t particles, wall_outflow[6];
	/* particles.source: particles inserted so far, and insertions skipped (the particle would
	 * have been beyond the far wall), totals; 0 without a source. */
	uint64_t source_inserted, source_skipped;
	/* Scenes with gravity g: centre-of-mass height along -g (scene
	 * coordinates) and potential energy -m sum g.r, now. NAN without gravity. */
	double com_height, potential_energy;
	/* Scenes with obstacles (as ed_sample_t): hits, total; momentum given
	 * to each obstacle over the interval (its force times the interval). */
	uint64_t obstacle_collisions;
	double obstacle_impulse[SCENE_OBSTACLES_MAX][3];
	/* Mixtures (as ed_sample_t): kinetic energy of each species now
	 * (T_s = 2 E_s / (D N_s)) and its count; n_species = 0 for one species. */
	int n_species;
	double species_kinetic_energy[SCENE_SPECIES_MAX];
	uint64_t species_count[SCENE_SPECIES_MAX];
} dsmc_sample_t;

/* Fill *out and start a new interval. Does not change the dynamics. */
void dsmc_sample(dsmc_t *d, dsmc_sample_t *out);

/* Totals now (time, counters, kinetic energy, momentum) without starting a
 * new interval: changes nothing. Interval fields 0. */
void dsmc_totals(const dsmc_t *d, dsmc_sample_t *out);

/* Positions in [0, L) (scene coordinates: near a vibrating wall they may
 * be slightly outside) and velocities as N*D doubles in particle order:
 * index i is the i-th particle created, in every call (the engine keeps
 * each record's identity through its cell sorts); NaN for a particle that
 * left through an open wall. Either pointer may be NULL. */
void dsmc_state(const dsmc_t *d, double *pos, double *vel);

/* Scenes where the engine follows periodic images (scene_msd_images(): mean_square_displacement with
 * something that feeds energy, or a source): positions as dsmc_state() plus, on periodic axes, the box
 * edges each particle was wrapped by (exact: counted at each wrap of a flight or a CBA offset, by particle
 * id; NaN rows stay NaN). DSMC_EINVAL (nothing written) in other scenes. O(N). */
int dsmc_unwrapped(const dsmc_t *d, double *pos);

double dsmc_time(const dsmc_t *d);
uint64_t dsmc_collisions(const dsmc_t *d);
uint64_t dsmc_moves(const dsmc_t *d);
void dsmc_cells(const dsmc_t *d, int cells[3]);
size_t dsmc_memory(const dsmc_t *d);

/* Impact parameters (issue 17, engine/observe): with counts != NULL each
 * accepted binary collision adds 1 to counts[k], k the bin of b / sigma in
 * [0, 1] over nb equal bins (the impact parameter the collision drew; full-cell
 * collisions of hsmc have none and are not counted). The caller owns counts
 * (nb doubles) and resets it; NULL stops counting. Not state: draws no
 * random numbers, not checkpointed. */
void dsmc_count_impacts(dsmc_t *d, double *counts, int nb);
/* Mixtures: with counts != NULL each accepted binary collision of species
 * a and b adds 1 to counts[min(a,b) * n_species + max(a,b)] (n_species^2
 * doubles, the caller's). Not state, as dsmc_count_impacts(). Ignored
 * for one species. */
void dsmc_count_pairs(dsmc_t *d, double *counts);

/* Kinetic theory used for the defaults and the corrections (also handy for
 * tests): contact value of the pair correlation, Henderson (2D) or
 * Carnahan-Starling (3D); Enskog collision frequency per particle
 * f_E = n sigma_T <|g|> chi; mean speed. */
double dsmc_contact_value(int dim, double nu);
/* Mixtures: contact value chi_ij of the pair correlation of species i and
 * j (diameters s_i, s_j) in a mixture of ns species of number densities
 * n[] and diameters sigma[]: chi_ij = c[0] + c[1] d + c[2] d^2, d = s_i
 * s_j / (s_i + s_j), with c from dsmc_contact_coefs() (3D: Boublik /
 * BMCSL; 2D: Jenkins-Mancini; see dsmc.c) and chi_ij from
 * dsmc_contact_pair(). Equal species give dsmc_contact_value() up to
 * rounding. */
void dsmc_contact_coefs(int dim, int ns, const double *n, const double *sigma, double c[3]);
double dsmc_contact_pair(const double c[3], double si, double sj);
double dsmc_collision_frequency(int dim, double nu, double radius, double mass, double temp, double chi);
double dsmc_mean_speed(int dim, double mass, double temp);

/*
 * Checkpoints (no I/O here), as for ed (ed.h): the state is a list of named
 * fields (ed_field_t); saving every field between dsmc_advance() calls and
 * restoring them into dsmc_create_blank() + dsmc_field_set() ... +
 * dsmc_restore_finish() gives an engine whose further steps, random numbers,
 * states and samples are bit-for-bit those of the original. Field counts
 * depend only on the scene. Native-endian data.
 */
#define DSMC_MAX_FIELDS 32
/* Describe the fields into out[max]; returns how many there are. */
int dsmc_fields(const dsmc_t *d, ed_field_t *out, int max);
/* Copy field name into buf (count * ed_type_size(type) bytes). DSMC_EINVAL if unknown. */
int dsmc_field_get(const dsmc_t *d, const char *name, void *buf);
/* An engine for scene s with memory but no state: only for restoring. */
dsmc_t *dsmc_create_blank(const scene_t *s, int *err, char *msg, size_t msglen);
/* Set one field; DSMC_EINVAL if name, type, count or values do not fit. */
int dsmc_field_set(dsmc_t *d, const char *name, ed_type_t type, size_t count, const void *buf);
/* After all fields are set: check consistency (cell offsets, identities a
 * permutation, positions in the box, RNG state). DSMC_EINVAL with msg. */
int dsmc_restore_finish(dsmc_t *d, char *msg, size_t msglen);

/* Constants of a built engine that a decomposed run (dsmcp.h) needs to
 * reproduce its grid and collision rule; pure, changes nothing. Flags say
 * which features the scene uses (the decomposed path refuses those it does
 * not support). */
typedef struct {
	int dim, hsmc, cba, local_chi, mix, bounded, impact;   /* impact: impact_c points */
	uint32_t n, nfull;                                     /* nfull: hsmc's full cell */
	double L[3];
	int nc[3];
	double sigma, mass, e, chi, sigma_t, vcell, fcoef, cps, dt_fixed;
} dsmc_geom_t;
void dsmc_geometry(const dsmc_t *d, dsmc_geom_t *out);
/* The same for scene s without building the engine (pure, no allocation):
 * DSMC_OK, or DSMC_EINVAL with "KEY: reason" in msg as dsmc_plan(). */
int dsmc_geometry_scene(const scene_t *s, dsmc_geom_t *out, char *msg, size_t msglen);

const char *dsmc_strerror(int code);
