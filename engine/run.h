/* Run driver: a scene from start to stop condition, sampling observables on the output schedule. */
#pragma once

#include <signal.h>
#include <stdint.h>
#include "observe/clusters.h"
#include "observe/observe.h"
#include "ed/ed.h"
#include "scene.h"

/*
 * Contract
 * - No I/O: records are handed to the caller's emit() callback, which
 *   serialises them (report.h) and writes them where it wants.
 * - Only the observables the scene asks for are computed; the flags in a
 *   record say which fields are valid.
 * - The dynamics do not depend on the output schedule (the engine never
 *   moves particles to sample them), so runs that differ only in
 *   output.every reach identical states at identical times.
 */

typedef enum { RUN_PROGRESS = 0, RUN_SUMMARY, RUN_SNAPSHOT, RUN_CURVES } run_kind_t;
typedef enum { RUN_COMPLETED = 0, RUN_QUIESCENT, RUN_INTERRUPTED, RUN_COLLAPSED, RUN_FULL } run_status_t;

enum {
	RUN_OK = 0,
	RUN_ESETUP = -1,     /* the engine could not build the initial state (msg says why) */
	RUN_EMIT = -2,       /* emit() returned non-zero (e.g. the output pipe broke) */
	RUN_ENOMEM = -3,
	RUN_EMETHOD = -4,    /* method not implemented yet */
	RUN_ERESTORE = -5,   /* a restored state is inconsistent (msg says why) */
	RUN_ECOLLAPSE = -6,  /* inelastic collapse (ed, ed_watch_collapse()): the last progress record
	                      * and the summary (status RUN_COLLAPSED) were emitted; msg says what
	                      * happened, starting "collisions.tc: " */
	/* run_go() results that ask the caller to act and call again: */
	RUN_CHECKPOINT = 1,  /* a checkpoint is due: save the state now */
	RUN_STOPPED = 2,     /* stop requested: save the state, then run_summary() */
};

typedef struct {
	run_kind_t kind;
	int dim;
	uint64_t n;
	double time;                 /* simulated time */
	uint64_t events, collisions;
	double collisions_per_particle;  /* 2C/N */
	double wall_seconds;         /* since the start of the production run */
	unsigned have;               /* SCENE_OBS_* bits valid in this record */
	int have_interval;           /* interval quantities (pressure, rate) valid */
	double kinetic_energy;       /* total */
	double temperature;          /* 2 E_kin / (D N) */
	double pressure;             /* collision virial over the interval */
	double compressibility;      /* P V / (N <T>) over the interval */
	double collision_rate;       /* 2 C / (N dt) over the interval */
	double momentum[3];
	clusters_stats_t clusters;
	obs_scalars_t obs;           /* velocity_distribution (a2, a3), pair_correlation (contact values) */
	uint64_t elastic_by_tc;      /* collisions made elastic by the TC model */
	/* Walls (SCENE_OBS_WALL_FORCE): bit w of walls set for each wall w =
	 * 2 axis + end (0 lower, 1 upper); over the interval (have_interval):
	 * the mean force on the wall (momentum given to it per unit time) and
	 * its pressure, the outward normal force per unit wall area (per unit
	 * length in 2D). Gravity (SCENE_OBS_COM_HEIGHT, SCENE_OBS_POTENTIAL):
	 * centre-of-mass height along -g above the lower walls, potential
	 * energy -m sum g.r, now. */
	unsigned walls;
	uint64_t wall_collisions;
	double wall_force[6][3], wall_pressure[6];
	double com_height, potential_energy;
	/* Obstacles (SCENE_OBS_OBSTACLE_FORCE): n_obstacles of them; hits in
	 * all (total) and each one's mean force over the interval (momentum
	 * given to it per unit time: the drag, and the lift across the flow). */
	int n_obstacles;
	uint64_t obstacle_collisions;
	double obstacle_force[SCENE_OBSTACLES_MAX][3];
	/* Open walls (SCENE_OBS_OUTFLOW): particles still in the system and
	 * those that left through each wall w (totals). */
	uint64_t particles, wall_outflow[6];
	/* Reservoir walls (with SCENE_OBS_OUTFLOW): particles that entered
	 * through each wall w and entries rejected there (totals). */
	uint64_t wall_inflow[6], wall_rejected[6];
	unsigned reservoirs;         /* bit w: wall w is a reservoir */
	/* particles.source (dsmc/hsmc, with SCENE_OBS_OUTFLOW; single runs): particles inserted so far and
	 * insertions skipped (beyond the far wall), totals; source = 0 without one. */
	int source;
	uint64_t source_inserted, source_skipped;
	/* Rough particles (SCENE_OBS_ROTATION): rotational energy I/2 sum w^2
	 * and rotational temperature 2 E_rot / (D_r N), D_r = 1 (2D) or 3
	 * (3D) rotational degrees of freedom, now. */
	double rotational_energy, rotational_temperature;
	/* Mixtures (particles.species, two or more; with SCENE_OBS_ENERGY):
	 * temperature of each species now, T_s = 2 E_s / (D N_s); n_species = 0
	 * for one species. */
	int n_species;
	double temperature_species[SCENE_SPECIES_MAX];
	const char *warning;         /* dsmc/hsmc validity warning (first record only), or NULL */
	/* One ed system split over ranks > 1 MPI ranks (engine/par/edrun.c; 0
	 * otherwise): each rank's events processed (rolled-back ones included:
	 * its work) and particles owned now, for ranks <= RUN_RANKS_MAX only
	 * (NULL above; owned by the run, valid during emit()); the rollbacks,
	 * syncs and load-balancing rebalances so far and the sync interval now. */
	int ranks;
	const uint64_t *rank_events, *rank_particles;
	uint64_t rollbacks, syncs, rebalances;
	double sync_interval;
	/* dsmc/hsmc diagnostics (totals; printed in the summary when non-zero) */
	uint64_t vmax_raised, cell_collisions, rejected_moves;
	/* Ensembles (run.replicas > 1): the observables above are means over the
	 * replicas and these their standard errors; replicas = 0 or 1 otherwise. */
	uint32_t replicas;
	struct {
		double time, collisions_per_particle, kinetic_energy, temperature, pressure,
		       compressibility, collision_rate, largest_fraction, mean_size;
		double a2, a3, g_pairs, g_rate, g_pressure, cluster_w, cluster_exponent;
		double msd, diffusion;
		double temperature_species[SCENE_SPECIES_MAX];
		double com_height, potential_energy, rotational_energy, rotational_temperature;
		double wall_pressure[6], wall_force[6][3];
		double obstacle_force[SCENE_OBSTACLES_MAX][3];
	} se;                        /* flux: obs.flux_se is the standard error over the replicas then */
	/* summary only */
	run_status_t status;
	double events_per_second, collisions_per_second;
	uint64_t memory_bytes;
	int cells[3];
	/* snapshot only: N*D positions (folded into the box) and velocities in
	 * scene particle order; owned by the run, valid during emit() */
	const double *pos, *vel;
	/* snapshot only, rough particles: N*spin_dim angular velocities
	 * (spin_dim 1 in 2D, 3 in 3D; 0 and NULL for smooth particles) */
	const double *spin;
	int spin_dim;
	/* snapshot only, scenes with a reservoir wall: n = scene_slots() rows
	 * (empty slots NaN) and each row's particle id (-1 when empty);
	 * NULL otherwise */
	const int64_t *ids;
	/* RUN_CURVES only: the structure curves of the present state (observe.h),
	 * taken with the snapshots; owned by the run, valid during emit() */
	const obs_curves_t *curves;
} run_record_t;

/* The most ranks whose per-rank loads a record carries (REPORT_MAX holds them). */
#define RUN_RANKS_MAX 128

/* Called for each record; a non-zero return stops the run (RUN_EMIT). */
typedef int (*run_emit_fn)(const run_record_t *rec, void *ctx);

typedef struct run run_t;

/* Run the scene (any method, one replica with the scene's stream). stop (may
 * be NULL) is polled between chunks of work; when it becomes non-zero the run
 * ends with a summary of status RUN_INTERRUPTED. msg receives a one-line
 * reason on failure. */
int run_scene(const scene_t *s, run_emit_fn emit, void *ctx,
              const volatile sig_atomic_t *stop, char *msg, size_t msglen);

/*
 * Stepped runs with checkpoints. run_create() builds the initial state;
 * run_go() advances until the run ends (RUN_OK, summary emitted), a
 * checkpoint is due (RUN_CHECKPOINT) or a stop was requested (RUN_STOPPED),
 * or fails (< 0). After RUN_CHECKPOINT the caller saves the state
 * (run_fields() + run_get_state()) and calls run_go() again; after
 * RUN_STOPPED it saves the state and calls run_summary(). Nothing is sampled
 * for a checkpoint or a stop, so a run restored from a checkpoint
 * (run_create_blank, run_field_set, run_set_state, run_restore_finish)
 * continues with exactly the records and states of the uninterrupted run
 * (wall_seconds aside). Any method: for dsmc/hsmc, frame and checkpoint
 * times do not shorten a time step (they are taken at the end of the step
 * that reaches them), so they never change the run; only output times do.
 */
typedef struct {
	int snapshots;     /* emit RUN_SNAPSHOT records (output.snapshots; first and last state at least) */
	int checkpoints;   /* return RUN_CHECKPOINT on output.checkpoint and RUN_STOPPED on a stop request;
	                    * without it a stop ends the run with a last sample (status interrupted) */
	int curves;        /* emit RUN_CURVES records (after the RUN_SNAPSHOT of the same state, if any) on the
	                    * snapshot schedule, for the curve observables the scene asks for (obs_curve_bits()) */
} run_opts_t;

/* The schedule position: everything besides the engine state that a resumed
 * run needs. Plain data, stored in checkpoints. */
typedef struct {
	uint64_t started;         /* the initial records have been emitted */
	uint64_t k_out;           /* index of the next output time / collision target */
	uint64_t k_snap;          /* same for snapshots */
	uint64_t k_ckpt;          /* same for simulated-time checkpoints */
	uint64_t snap_events;     /* events at the last snapshot (UINT64_MAX: none yet) */
	double wall_before;       /* wall seconds spent before this process (resumed runs) */
	uint64_t frames;          /* ensemble replicas: frames taken by run_frame() (single runs: 0;
	                           * their checkpoints count frames in the output position) */
} run_state_t;

run_t *run_create(const scene_t *s, const run_opts_t *opts, int *err, char *msg, size_t msglen);
/* For restoring: engine memory without a state (ed_create_blank(), dsmc_create_blank()). */
run_t *run_create_blank(const scene_t *s, const run_opts_t *opts, int *err, char *msg, size_t msglen);
int run_restore_finish(run_t *r, char *msg, size_t msglen);
void run_destroy(run_t *r);

/* The event-driven engine (ed.h); owned by the run; NULL for dsmc/hsmc runs. */
struct ed *run_ed(run_t *r);
/* The engine's state fields, whatever the method (ed_fields() or
 * dsmc_fields() semantics); run_engine_name() names the set ("ed" or
 * "dsmc", also for hsmc): a checkpoint stores the fields under that name.
 * run_field_get/set return RUN_OK or RUN_ERESTORE (unknown name, wrong
 * type or count). */
const char *run_engine_name(const run_t *r);
int run_fields(const run_t *r, ed_field_t *out, int max);
int run_field_get(const run_t *r, const char *name, void *buf);
int run_field_set(run_t *r, const char *name, ed_type_t type, size_t count, const void *buf);
/* Opaque bytes a checkpoint stores beside the fields (/ped/image) and a
 * restored run gives back: a split ed run's per-rank core state (edrun.c).
 * The engines never read them. set: RUN_OK or RUN_ENOMEM (copied); get: NULL
 * when none. */
int run_extra_set(run_t *r, const void *buf, size_t len);
const void *run_extra(const run_t *r, size_t *len);
/* Simulated time, events (ed) or particle moves (dsmc) and collisions now; changes nothing. */
void run_totals(const run_t *r, double *time, uint64_t *events, uint64_t *collisions);
void run_get_state(const run_t *r, run_state_t *st);
void run_set_state(run_t *r, const run_state_t *st);

int run_go(run_t *r, run_emit_fn emit, void *ctx, const volatile sig_atomic_t *stop,
           char *msg, size_t msglen);
/* Summary of a stopped run (status interrupted), without sampling. */
int run_summary(run_t *r, run_emit_fn emit, void *ctx);

/* Step-wise form without emit(), used for ensembles: run_open() builds the
 * state of one replica (the scene with random stream `stream`, no snapshots
 * or checkpoints); each run_next() returns the next progress record (the
 * first at time 0) and sets *done on the last; run_summary_record() fills
 * the summary record. stop (may be NULL) is polled between chunks of work;
 * when set the current record is the last one and the status becomes
 * RUN_INTERRUPTED. An inelastic collapse ends the replica: its last record
 * (warning: the message) comes with RUN_ECOLLAPSE. Free with run_destroy(). Do not mix with run_go() on one
 * run. */
run_t *run_open(const scene_t *s, uint64_t stream, int *err, char *msg, size_t msglen);
/* For ensemble checkpoints (ensemble_save/ensemble_load): the replica's last
 * record, whether run_next() has returned its last record, and its status;
 * run_set_finish() restores them into a restored run. */
const run_record_t *run_last(const run_t *r);
void run_get_finish(const run_t *r, int *done, run_status_t *status);
void run_set_finish(run_t *r, const run_record_t *last, int done, run_status_t status);
int run_next(run_t *r, const volatile sig_atomic_t *stop, run_record_t *rec, int *done);
void run_summary_record(run_t *r, run_record_t *sum);
/* Ensemble frames (output.snapshots with run.replicas > 1), asked after each
 * run_next(): run_frame_due() says whether the replica wants a frame of its
 * present state: the first record, the first record at or after each
 * snapshot time or collision target of the replica's own clock, and the
 * last record when the state changed since the last frame (as for single
 * runs, whose frames are equal when snapshot times are output times).
 * run_frame() fills rec (RUN_SNAPSHOT: time, events, collisions, kinetic
 * energy) with the state copied into the caller's pos and vel (N*D doubles
 * each, scene particle order, positions folded; with a reservoir wall
 * scene_slots() rows, and each row's particle id into ids when not NULL) and advances the schedule
 * (run_state_t k_snap, snap_events, frames). Neither moves a particle. */
int run_frame_due(const run_t *r);
void run_frame(run_t *r, run_record_t *rec, double *pos, double *vel, int64_t *ids);
/* The structure curves of the present state (ensembles: each replica at the ensemble's curve times):
 * fills rec (RUN_CURVES: time, events, collisions, temperature, curves owned by r). Moves no
 * particle, changes no schedule. RUN_OK, or RUN_ENOMEM (cluster workspace), RUN_EMETHOD when the
 * scene asks for no curve observable. */
int run_curves(run_t *r, run_record_t *rec);
/* Ensembles: run_curves() packed (obs_pack()) into v[run_curves_packed_size()] for the reduction over
 * replicas (obs_combine() on a layout_only obs_create() of the scene); size 0 and RUN_EMETHOD without
 * curve observables. */
size_t run_curves_packed_size(const run_t *r);
int run_curves_pack(run_t *r, double *v);
/* Ensembles without frames: the snapshot schedule moves on as run_frame() would move it (curves taken
 * at this output time), without copying the state. */
void run_snap_taken(run_t *r);

const char *run_status_name(run_status_t st);
