/* Scene description: the parsed, validated, defaulted form of a scene JSON (version 1). */
#pragma once

#include <stddef.h>
#include <stdint.h>

/*
 * Contract
 * - scene_parse() is the single authority on what a valid scene is: the
 *   engine and (later) the daemon both call it, so they cannot disagree.
 * - It performs no I/O. On error it returns a negative SCENE_E* code and
 *   writes one line "KEY.PATH: reason" (no newline) into err.
 * - Units: lengths in particle diameters only when the scene says so; all
 *   values are in the scene's own units (diameter = 2*radius, mass = mass),
 *   k_B = 1, temperature T = 2 E_kin / (D N).
 */

enum {
	SCENE_OK = 0,
	SCENE_EJSON = -1,    /* not JSON, or not an object at the top */
	SCENE_EINVAL = -2,   /* unknown key, wrong type, value out of range */
	SCENE_ENOMEM = -3,
};

/* SCENE_METHOD_AUTO: chosen by advice_ (advice.h) from accuracy_temperature
 * before the scene runs; the engines never see it. */
/* Largest particles.count scene_parse() accepts: particle indices are 32-bit in the engines. */
#define SCENE_COUNT_MAX 2147483647LL
/* Longest particles.initial.from.file, bytes including the NUL. */
#define SCENE_PATH_MAX 1024

/* SCENE_METHOD_MD: soft spheres (engine/md/md.h); never chosen by "auto". */
typedef enum { SCENE_METHOD_ED = 0, SCENE_METHOD_DSMC, SCENE_METHOD_HSMC, SCENE_METHOD_AUTO, SCENE_METHOD_MD } scene_method_t;
typedef enum { SCENE_POS_LATTICE = 0, SCENE_POS_RANDOM } scene_positions_t;
/* Dense-gas correction of the Monte Carlo methods (dsmc.h). */
#define SCENE_IMPACT_MAX 64   /* points of dsmc/hsmc impact_c */

typedef enum { SCENE_MC_DEFAULT = 0, SCENE_MC_NONE, SCENE_MC_ENSKOG, SCENE_MC_CBA } scene_mc_correction_t;
/* A stop or output condition: simulated time or collisions per particle. */
typedef enum { SCENE_CLOCK_NONE = 0, SCENE_CLOCK_TIME, SCENE_CLOCK_CPP, SCENE_CLOCK_WALL } scene_clock_t;

/* Observables a scene may ask for; only those asked for are computed. */
enum {
	SCENE_OBS_ENERGY = 1u << 0,         /* kinetic_energy, temperature */
	SCENE_OBS_PRESSURE = 1u << 1,       /* pressure, compressibility (collision virial) */
	SCENE_OBS_COLLISION_RATE = 1u << 2, /* collision_rate */
	SCENE_OBS_CLUSTERS = 1u << 3,       /* particle-cluster statistics */
	SCENE_OBS_MOMENTUM = 1u << 4,       /* total momentum vector */
	/* structure and statistics (engine/observe/observe.h; docs/scene.md) */
	SCENE_OBS_VDIST = 1u << 5,          /* velocity_distribution: a2, a3; histograms at snapshot times */
	SCENE_OBS_GOFR = 1u << 6,           /* pair_correlation: contact values; g(r) at snapshot times */
	SCENE_OBS_SOFK = 1u << 7,           /* structure_factor: S(k) at snapshot times */
	SCENE_OBS_VCORR = 1u << 8,          /* velocity_correlations: G_par(r), G_perp(r), S_par(k), S_perp(k) at snapshot times */
	/* scenes with walls and gravity (method ed; docs/scene.md) */
	SCENE_OBS_WALL_FORCE = 1u << 9,     /* force on each wall: pressure and shear stress (needs walls) */
	SCENE_OBS_COM_HEIGHT = 1u << 10,    /* centre-of-mass height along -gravity (needs gravity) */
	SCENE_OBS_POTENTIAL = 1u << 11,     /* potential energy in the gravity field (needs gravity) */
	SCENE_OBS_IMPACT = 1u << 12,        /* impact_parameter: P(b) of the collisions between snapshot times */
	SCENE_OBS_MSD = 1u << 13,           /* mean_square_displacement: MSD and D (periodic, no gravity) */
	SCENE_OBS_OBSTACLE_FORCE = 1u << 16, /* force on each obstacle: drag (needs obstacles) */
	SCENE_OBS_OUTFLOW = 1u << 17,       /* particles present and particles out per wall (needs an open wall) */
	SCENE_OBS_ROTATION = 1u << 14,      /* rotational_energy, rotational_temperature (needs collisions.rough) */
	SCENE_OBS_FIELDS = 1u << 15,        /* fields: density, velocity, temperature (spin) per grid cell at snapshot times */
	SCENE_OBS_DSPEC = 1u << 24,         /* density_spectrum: slice counts along an axis, P(f) and its slope at snapshot times */
	SCENE_OBS_FLUX = 1u << 25,          /* flux: sum of v along gravity / volume in the progress stream */
	SCENE_OBS_SURFACE = 1u << 26,       /* surface_profile: h(x), the highest centre per bin across gravity, at snapshot times */
};

/* Wall kinds (boundaries.AXIS.lower/upper.type; method ed only). Every wall
 * has a normal restitution r_w: the normal velocity relative to the wall
 * becomes -r_w times itself. */
typedef enum {
	SCENE_WALL_SPECULAR = 0,   /* v_n' = -r_w v_n, tangential unchanged */
	SCENE_WALL_THERMAL,        /* with probability accommodation: re-emitted from a Maxwellian at temperature */
	SCENE_WALL_ROUGH,          /* tangential velocity reversed with probability (seed 000 pipe) */
	SCENE_WALL_MOVING,         /* tangential velocity u: v_t' - u = -beta (v_t - u) (seed 000 3.7-3.8 at beta = 1) */
	SCENE_WALL_VIBRATING,      /* displaced along its inward normal by A sin(2 pi f t + phase) */
	SCENE_WALL_OPEN,           /* outflow: a particle touching it leaves the system (counted); no restitution */
	SCENE_WALL_RESERVOIR,      /* open wall backed by an ideal-gas reservoir (volume_fraction, velocity,
	                            * temperature): leaves like "open", and particles enter at the one-sided flux */
	SCENE_WALL_DISPENSER,      /* seed 001 inlet: a hard piston moving along the inward normal at the normal
	                            * component of velocity; each time it has cleared thickness, a layer at
	                            * volume_fraction and temperature is placed behind it and it jumps back */
} scene_wall_type_t;

/* Particle species: at most this many (particles.species; scene_species_t below). */
#define SCENE_SPECIES_MAX 16

/* The filter of an "open" wall (seed 001 outlet): a plane distance inside
 * the wall; a particle crossing it outwards is frozen (infinite mass,
 * velocity exactly velocity) until it leaves through the wall. */
typedef struct {
	int on;                    /* 0: no filter */
	double distance;           /* > particle radius, from the wall's plane (length) */
	double velocity[3];        /* the frozen particles' velocity; outward normal component >= 0 */
	double temperature;        /* > 0: seed 001's turn-back at the plane at this temperature; 0: none */
} scene_filter_t;

/* The gas of a reservoir wall (key "gas"). */
enum { SCENE_GAS_IDEAL = 0, SCENE_GAS_HARD_SPHERES = 1 };

typedef struct {
	scene_wall_type_t type;
	double restitution;        /* r_w in [0, 1], default 1 (moving: or from coverage, seed 000 3.9) */
	double temperature;        /* thermal: T_w > 0 */
	double accommodation;      /* thermal: fraction of diffuse re-emissions, [0, 1], default 1 */
	double probability;        /* rough: probability of reversing the tangential velocity, [0, 1] */
	double velocity[3];        /* moving, thermal: wall velocity, normal component 0 (thermal: default 0) */
	double tangential_restitution; /* moving: beta in [-1, 1], default 1 */
	double amplitude;          /* vibrating: A >= 0 (length) */
	double frequency;          /* vibrating: f > 0 (1/time) */
	double phase;              /* vibrating: radians, default 0 */
	double volume_fraction;    /* reservoir: eta of the reservoir gas in (0, close packing); number density
	                            * eta / (particle volume) */
	int gas;                   /* reservoir: SCENE_GAS_IDEAL (default: entries at the ideal-gas flux of
	                            * volume_fraction) or SCENE_GAS_HARD_SPHERES (a gas of the box's particles
	                            * at volume_fraction: entries at its activity, so the box holds it) */
	double coverage;           /* moving, instead of restitution: r_w = 1 - (1 - restitution) coverage (seed 000
	                            * 3.9, line coverage rho_l); -1 when not given */
	double thickness;          /* dispenser: layer thickness (length), > one diameter; 0: default 2 diameters */
	scene_filter_t filter;     /* open: the filter plane (filter.on = 0 without) */
	/* dispenser with particles.species: the number fractions of its layers' species (composition, given
	 * as weights >= 0 in species order, normalised to sum 1); n_composition 0: the scene's fractions */
	int n_composition;
	double composition[SCENE_SPECIES_MAX];
} scene_wall_t;

/* One axis of the box: periodic, or walls at both ends (wall[0] at
 * coordinate 0, wall[1] at the box edge; both at rest there on average). */
typedef struct {
	int walled;
	scene_wall_t wall[2];
} scene_boundary_t;

/* Obstacles (method ed only): fixed disks (2D) / spheres (3D). A particle
 * touches obstacle k when its centre is radius + particle radius from the
 * obstacle's centre. Normal restitution r_o as for walls. */
#define SCENE_OBSTACLES_MAX 16
typedef enum {
	SCENE_OBST_SLIP = 0,       /* specular: v_n' = -r_o v_n, tangential unchanged */
	SCENE_OBST_NO_SLIP,        /* thermal: with probability accommodation re-emitted from the flux-weighted
	                            * Maxwellian at temperature (diffuse), else as slip */
	SCENE_OBST_RANDOM_SIGN,    /* v_n' = -r_o v_n, tangential velocity reversed with probability 1/2 (seed 001:
	                            * no-slip without heating) */
} scene_obstacle_type_t;

typedef struct {
	scene_obstacle_type_t type;
	double center[3];          /* scene coordinates (walled axes: from the lower wall's rest position) */
	double radius;             /* R > 0 */
	double restitution;        /* r_o in [0, 1], default 1 */
	double temperature;        /* no_slip: T_o > 0 */
	double accommodation;      /* no_slip: fraction of diffuse re-emissions, [0, 1], default 1 */
} scene_obstacle_t;

/* Driving (method ed only; "driving"): kicks of random particles at Poisson
 * times, each particle on average once per interval. */
typedef enum {
	SCENE_DRIVE_NONE = 0,
	SCENE_DRIVE_STOCHASTIC,    /* seed 001: v' = local mean velocity + Maxwellian at temperature */
	SCENE_DRIVE_WHITE_NOISE,   /* v' = v + sqrt(strength interval) (Gaussian per component) */
} scene_drive_t;

typedef struct {
	scene_clock_t kind;
	double value;        /* time, collisions per particle (2C/N), or wall-clock seconds */
} scene_when_t;

/* Particle species (particles.species; methods ed, dsmc, hsmc and md beyond one): a scene
 * without the key has one species from particles.count/radius/mass. */
#define SCENE_NAME_MAX 32
#define SCENE_FROM_EACH (-2)
/* pair_correlation of mixtures: partial g_ab(r) of at most this many species (observe.h) */
#define SCENE_GOFR_SPECIES_MAX 4
typedef struct {
	uint64_t count;                /* >= 1 */
	double radius, mass;           /* > 0; radius: the largest (radius_hi) when polydisperse */
	/* polydisperse (radius_range): radii uniform in [radius_lo, radius_hi],
	 * drawn per particle from the seed (scene_species_radii()); 0, 0 when
	 * all particles of the species have radius */
	double radius_lo, radius_hi;
	char name[SCENE_NAME_MAX];     /* as given, or its index ("0", "1", ...) */
} scene_species_t;

typedef struct scene {
	scene_method_t method;
	int dim;                       /* 2 or 3 */

	/* particles */
	uint64_t count;                /* N >= 2 */
	uint64_t capacity;             /* particle slots (particles.capacity): >= count with a reservoir wall
	                                * (default from the reservoirs, docs/scene.md), = count otherwise */
	double radius;                 /* > 0, default 0.5 */
	double mass;                   /* > 0, default 1 */
	/* particles.species: n_species = 0 without the key (one species:
	 * count, radius, mass above). With it, count is the sum of the species'
	 * counts, radius the largest radius and mass the mean mass (what
	 * species-blind code sees); particles 0 .. count_0 - 1 are species 0,
	 * the next count_1 species 1, and so on (scene order). */
	int n_species;
	scene_species_t species[SCENE_SPECIES_MAX];
	double box[3];                 /* edge lengths; derived from volume_fraction if not given */
	double volume_fraction;        /* always filled (derived from box if box given) */
	scene_positions_t positions;   /* default lattice */
	double temperature;            /* initial T >= 0, default 1 (of the velocities about the mean flow) */
	double flow[3];                /* initial mean velocity (a stream; method ed), default 0 */
	double relax_cpp;              /* elastic pre-run, collisions per particle (default 0) */
	/* particles.source (dsmc/hsmc; docs/scene.md): src_count particles inserted one at a time, the k-th
	 * (k = 1 .. src_count) at time k / src_rate, its centre src_height above the highest centre present
	 * along -gravity (the floor's contact plane when none is), across gravity at src_position (the
	 * gravity axis's entry 0) plus uniform noise in [-src_spread, src_spread] per axis, velocity
	 * src_velocity + a Maxwellian at src_temperature. src_axis: gravity's axis (resolved by the parser).
	 * The particles get the ids count .. count + src_count - 1 in insertion order (rows of the frames:
	 * scene_slots()); one that would lie beyond the upper contact plane is not inserted (counted). */
	uint64_t src_count;            /* 0: no source */
	double src_rate, src_height, src_spread, src_temperature;
	double src_position[3], src_velocity[3];
	double src_pos_raw[2];         /* parsed: the D - 1 coordinates across gravity, in axis order */
	int src_axis;
	/* particles.initial.region: centres placed so that every particle lies
	 * in [region_lo, region_hi] (scene coordinates, per axis; default the
	 * box); checked and placed by engine/place.h */
	int has_region;
	double region_lo[3], region_hi[3];
	/* particles.initial.from: an earlier run's frame (engine/io/frame.h
	 * loads it; the parser does no I/O). Exactly one of from_file ("" =
	 * none) and from_job (0 = none) when has_from. */
	int has_from;
	char from_file[SCENE_PATH_MAX];  /* as written: relative to the scene file's directory */
	uint64_t from_job;             /* a daemon job's trajectory.h5 (granular-engine --jobs-dir) */
	int64_t from_frame;            /* frame index, negative from the end; default -1 (the last) */
	int64_t from_replica;          /* -1: /particles/all; K: /particles/replica_K of an ensemble;
	                                * SCENE_FROM_EACH ("each", run.replicas > 1): replica r of this run
	                                * from /particles/replica_r */
	/* Not from JSON: a state given to the engines instead of placing and
	 * drawing (N * dim doubles each, scene coordinates, particle i at
	 * [i * dim]; not owned, must outlive the engine; NULL: as the scene
	 * says). Set by the run driver (region) or the program (from). */
	const double *init_pos, *init_vel;
	const double *init_spin;       /* rough particles: N * (1 in 2D, 3 in 3D) angular velocities, or NULL */

	/* collisions */
	double restitution;            /* 0..1, default 1 */
	double tc;                     /* TC-model time >= 0, default 0 = off */
	/* collisions.restitution_pairs: normal restitution of each pair of
	 * species (symmetric; pairs not listed: restitution). Filled for
	 * n_species > 0 only. */
	double restitution_pair[SCENE_SPECIES_MAX][SCENE_SPECIES_MAX];
	/* rough particles (collisions.rough; method ed only): spins, moment of
	 * inertia I = rough_q m radius^2, tangential restitution beta (g_t' =
	 * -beta g_t) or Walton's rule (rough_mu >= 0: Coulomb sliding with
	 * friction mu where it gives less tangential impulse than beta_0) */
	int rough;                     /* 0: smooth (default) */
	double rough_beta;             /* beta or beta_0 in [-1, 1] (-1 smooth, +1 perfectly rough) */
	double rough_mu;               /* Coulomb friction >= 0; -1: constant beta (not given) */
	double rough_q;                /* (0, 1]; default 2/5 (3D spheres), 1/2 (2D disks) */
	double rot_temperature;        /* initial rotational temperature >= 0, default = temperature */

	/* driving (method ed only) */
	scene_drive_t drive;           /* default none */
	double drive_interval;         /* mean time between two kicks of one particle, > 0 */
	double drive_temperature;      /* stochastic: T_th > 0 */
	double drive_strength;         /* white_noise: xi^2 > 0, velocity variance per component per unit time */
	double drive_average_time;     /* stochastic: time constant of the local mean velocity, default 10 interval */
	int drive_grid[3];             /* stochastic: bins per axis of the local mean, default 1 (global) */

	/* boundaries and fields (method ed only) */
	scene_boundary_t boundary[3];  /* per axis; default periodic */
	double gravity[3];             /* uniform acceleration, default 0 */
	int n_obstacles;               /* 0..SCENE_OBSTACLES_MAX */
	scene_obstacle_t obstacle[SCENE_OBSTACLES_MAX];

	/* run */
	uint64_t seed;                 /* default 1 */
	scene_when_t until;            /* required */
	double max_events;             /* safety bound on events, 0 = none */

	/* output */
	scene_when_t every;            /* default: until / 100 of the same kind */
	unsigned observables;          /* SCENE_OBS_* bit set; default energy|pressure|collision_rate */
	double cluster_delta;          /* gap in diameters, default 0.1 */
	int vdist_bins;                /* velocity histograms: bins (default 80) */
	double vdist_range;            /* ... over |c| < range, c = v / sqrt(2 T / m) (default 5) */
	int gofr_bins;                 /* pair correlation: bins over [0, range) (default 250) */
	double gofr_range;             /* ... range in diameters (default min(5, half the smallest box edge)) */
	int sofk_grid[3];              /* density grid per axis for S(k) and the velocity structure factors */
	int impact_bins;               /* impact parameters: bins over b / sigma in [0, 1] (default 20) */
	/* coarse-grained fields (output.fields, engine/observe/fields.h): cells per axis (1 beyond dim); the
	 * exposure: the fields at a snapshot time t average the instants t - exposure + k exposure / samples,
	 * k = 1 .. samples (0: the snapshot instant alone, samples 1) */
	int fields_cells[3];
	double fields_exposure;
	int fields_samples;
	/* density_spectrum (output.density_spectrum, engine/observe/dspec.h): slices along axis dspec_axis
	 * (default: the gravity axis, else the last), counted every dspec_interval; the spectrum at each
	 * snapshot from the dspec_m = snapshot interval / dspec_interval samples before it; the slope fitted
	 * over frequencies in [dspec_fit[0], dspec_fit[1]] (default: all) */
	int dspec_slices, dspec_axis, dspec_m;
	double dspec_interval, dspec_fit[2];
	/* surface_profile (output.surface_profile, engine/observe/surface.h): surf_bins bins along surf_axis
	 * (default: the first axis across gravity), height along -gravity */
	int surf_bins, surf_axis;
	scene_when_t snapshots;        /* trajectory frames (time or cpp); NONE = first and last only */
	int compression;               /* deflate level 0..9 of the HDF5 output, default 0 */
	scene_when_t checkpoint;       /* checkpoint interval (simulated time or wall seconds); NONE = none */

	/* ed method tuning */
	double ed_cell_size;           /* minimum cell edge in diameters, 0 = automatic */

	/* ensembles */
	uint64_t replicas;             /* independent runs (seed streams 0..replicas-1), default 1 */
	uint64_t stream;               /* not from JSON: the replica's random stream, set by the run driver */
	int balance;                   /* run.balance: 0 "off" (default), 1 "events": a split ed run moves cells
	                                * between ranks at syncs (engine/par/ped.h, docs/parallel.md) */

	/* dsmc / hsmc method tuning ("dsmc" or "hsmc" object; 0 = default) */
	double mc_cell_size;           /* minimum cell edge in diameters, 0 = from the mean free path */
	double mc_time_step;           /* fixed time step, 0 = not given */
	double mc_collisions_per_step; /* adaptive step: expected collisions per particle per step, 0 = not given */
	scene_mc_correction_t mc_correction; /* default: none (dsmc), cba (hsmc) */
	double mc_max_volume_fraction; /* hsmc: cells at or above are full; 0 = default */
	int mc_local_chi;              /* contact_value: 0 = "global" (mean volume fraction), 1 = "local" (per cell) */
	int mc_cell_any;               /* hsmc.cell_partners: 0 = "full" (a full cell collides with full neighbours only),
	                                * 1 = "any" (with any neighbour holding particles) */
	/* hsmc, walls or gravity only (move_bounded()): the excluded-volume rule of a move into another cell */
	int mc_entry;                  /* hsmc.entry: 0 = "step" (refused into a full cell), 1 = "linear" (accepted with
	                                * probability 1 - nu / max_volume_fraction, nu the target cell's volume fraction) */
	int mc_reject;                 /* hsmc.rejected_moves: 0 = "keep" (velocity kept), 1 = "collide" (a binary
	                                * collision along the face normal with a random particle of the refusing cell) */
	/* impact_c: the impact parameter drawn from P(b)/P_chaos = a / (1 - c b^2) (b in diameters; P_chaos = 1 in
	 * 2D, 2b in 3D) with c(tau) linear in the collisions per particle tau between the points (tau_k, c_k),
	 * constant beyond them: seed 000's "HSMC corrected" (sec. 3.6, c taken from an ed run). 0 points: molecular
	 * chaos (uniform b). Periodic, one species only. */
	int mc_impact_n;
	double mc_impact_tau[SCENE_IMPACT_MAX], mc_impact_c[SCENE_IMPACT_MAX];

	/* method md ("md" object, engine/md/md.h; docs/scene.md), resolved by scene_parse(): md_law 0 linear,
	 * 1 hertz; exactly one of md_stiffness (linear k_n, force/length; hertz E*, force/length^2) and
	 * md_contact_time (linear only) is > 0; md_impact_speed > 0 (the reference impact speed: default
	 * stiffness and the hertz contact time); md_time_step: dt as a fraction of the contact time */
	int md_law;
	double md_stiffness, md_contact_time, md_impact_speed, md_max_overlap, md_time_step;
	double md_friction, md_tangential_ratio;
	double md_rolling;             /* md.rolling_friction: mu_r of the EPSD rolling resistance (md.h), 0 none */

	/* method "auto" only (required there): target for the expected relative
	 * RMS error of T(t) against exact hard-sphere dynamics, in (0, 1] */
	double accuracy_temperature;
} scene_t;

/* Parse and validate a scene from a JSON text of len bytes. Fills *out with
 * defaults applied. err (errlen bytes, may be NULL) receives the message. */
int scene_parse(const char *json, size_t len, scene_t *out, char *err, size_t errlen);

/* The engines' start checks for a parsed scene of a concrete method: what
 * granular-engine refuses after parsing, before running (ed: a cell grid of
 * at most 64 cells per particle, initial placement; dsmc/hsmc: the cell
 * grid; ed_plan(), dsmc_plan()). scene_parse() makes them for ed, dsmc and
 * hsmc scenes; for "auto" call this once advice_apply() has chosen the
 * method. SCENE_OK, or SCENE_EINVAL with "KEY.PATH: reason" in err. */
int scene_check_start(const scene_t *s, char *err, size_t errlen);

/* Method md: the scene that places its particles (s with method ed and, without particles.initial.region,
 * the whole box as the region): place_check()/place_region() of p put no two particles closer than a
 * diameter and keep them off the walls, so soft contacts start without overlap. */
void scene_md_placement(const scene_t *s, scene_t *p);

/* Close-packing volume fraction of disks (dim 2) or spheres (dim 3). */
double scene_close_packing(int dim);

/* Any walled axis; any non-zero gravity component; any obstacle. */
int scene_has_walls(const scene_t *s);
int scene_has_obstacles(const scene_t *s);
/* Any wall of type "open" or "reservoir" (particles leave through it), or
 * "dispenser" (particles enter through it), or a particles.source (dsmc/hsmc):
 * the particle set is not fixed. */
int scene_has_open_walls(const scene_t *s);
/* Any wall of type "reservoir" or "dispenser" (particles enter; ed only). Such
 * scenes have capacity particle slots, count of them filled at the start:
 * per-particle arrays of the run and its output have scene_slots() rows. */
int scene_has_reservoir(const scene_t *s);
/* Any wall of type "dispenser"; any "open" wall with a filter. */
int scene_has_dispenser(const scene_t *s);
int scene_has_filter(const scene_t *s);
/* Rows of the per-particle arrays of the run and its output: particles.capacity with a reservoir or
 * dispenser, particles.count + particles.source.count with a source (row = particle id), else count. */
uint64_t scene_slots(const scene_t *s);
int scene_has_gravity(const scene_t *s);
/* What feeds the mechanical energy of a scene with a periodic axis (thermal, moving or vibrating walls,
 * driving, no_slip obstacles, gravity along a periodic axis) as a short name for messages, or NULL: the
 * speed bound by which mean_square_displacement follows particles across periodic images (observe/msd.h)
 * holds only without it. The engines then count the images crossed instead (scene_msd_images()). */
const char *scene_energy_feed(const scene_t *s);
/* mean_square_displacement with a periodic axis and an energy feed (methods ed, dsmc, hsmc), in ed with a
 * varying particle set (scene_has_open_walls(): entries feed energy), in dsmc/hsmc with a particles.source:
 * the engine counts each particle's periodic images (ed_unwrapped(), dsmc_unwrapped()), exactly, with no
 * speed bound. */
int scene_msd_images(const scene_t *s);

/* A mixture: more than one particle species, or polydisperse radii
 * (particles.species[k].radius_range): the engine's species path. */
int scene_has_species(const scene_t *s);
/* The radius of every particle, in scene order (count doubles): each
 * species' radius, or for a polydisperse species uniform draws in its
 * radius_range from the scene's seed and stream (a stream of their own:
 * the same radii for every reader of the scene). Pure. */
void scene_species_radii(const scene_t *s, double *r);
/* Species and radius of every row (particle slot) of a mixture, in scene
 * order (scene_slots() entries each; either pointer may be NULL): rows
 * 0 .. count - 1 as scene_species_radii() (species in blocks), then the
 * empty slots of a dispenser or reservoir scene (capacity > count) in one block per
 * species, block k holding floor(spare C_k / count) - floor(spare C_(k-1) /
 * count) rows (spare = capacity - count, C_k the counts of species 0 .. k
 * summed: the scene's number fractions), each of its species' radius (a
 * polydisperse species: uniform draws in its radius_range from the seed,
 * a stream of their own; a slot's species and radius never change: frames
 * keep time-independent species and diameters).
 * Pure. */
void scene_row_species(const scene_t *s, uint8_t *sp, double *r);
/* A dispenser's or reservoir's species fractions (n_species entries: its
 * composition, or the scene's count_k / count) and the mean particle
 * volume at them (scene_particle_volume() without a composition). */
void scene_dispenser_fractions(const scene_t *s, const scene_wall_t *w, double *x);
double scene_dispenser_volume(const scene_t *s, const scene_wall_t *w);

/* Volume of the box and of one particle (disk area in 2D; with species the
 * mean over the particles). */
double scene_box_volume(const scene_t *s);
double scene_particle_volume(const scene_t *s);

const char *scene_strerror(int code);
const char *scene_method_name(scene_method_t m);
