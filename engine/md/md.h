/* Soft-sphere molecular dynamics (DEM) of frictional disks/spheres: contact forces, velocity Verlet, cell/Verlet lists. */
#pragma once

#include <stddef.h>
#include <stdint.h>

/*
 * Contract
 * - Pure computation: no I/O, no globals. All memory is allocated in
 *   md_create(); md_step() allocates nothing except when a Verlet-list
 *   rebuild finds more pairs than ever before (the pair array then grows
 *   geometrically, so at most O(log N) times in a run).
 * - State arrays have stride 3 in 2D and 3D (x, y, z; z = 0 in 2D). Spins
 *   are angular velocities, stride 3 (2D: only the z component moves).
 * - Contact between i and j when |x_i - x_j| < R_i + R_j; overlap
 *   delta = R_i + R_j - |x_i - x_j|, unit normal n from i to j,
 *   m_eff = m_i m_j / (m_i + m_j), R_eff = R_i R_j / (R_i + R_j).
 *   A wall is a flat contact partner of infinite mass and radius
 *   (m_eff = m_i, R_eff = R_i, delta = R_i - distance to the wall), with the
 *   same law and the same parameters.
 * - Normal force (repulsive > 0), v_n = approach speed at the contact:
 *     linear:  f_n = k_n delta + eta_n v_n,  eta_n = 2 beta sqrt(k_n m_eff),
 *              beta = -ln e / sqrt(pi^2 + ln^2 e): exactly restitution e and
 *              contact time t_c = pi / sqrt(k_n/m_eff - (eta_n/m_eff)^2/4)
 *              for every pair and every impact speed.
 *     hertz:   f_n = k_h delta^(3/2) + alpha sqrt(m_eff k_h) delta^(1/4) v_n,
 *              k_h = 4/3 E* sqrt(R_eff) (Tsuji et al. 1992 damping). The
 *              dimensionless equation X'' = -X^(3/2) - alpha X^(1/4) X' has no
 *              velocity scale, so e is independent of the impact speed;
 *              alpha(e) is found in md_create() by bisection on that
 *              equation integrated with RK4 (the relation Antypov & Elliott
 *              2011 approximate in closed form). The contact time depends on
 *              the impact speed v: t_c = tau(alpha) (m_eff/k_h)^(2/5) v^(-1/5);
 *              elastic: tau = 3.2182, i.e. t_c = 2.8685 (m_eff^2/(R_eff E*^2 v))^(1/5).
 *   The dashpot may pull at the very end of a contact (no clamp), which is
 *   what keeps e exact; Coulomb's limit uses max(f_n, 0).
 * - Tangential (Cundall-Strack), when mu > 0: a spring xi per contact, kept
 *   in the tangent plane (rotated with the normal, length preserved),
 *   xi += v_t dt; F_t = -k_t xi - eta_t v_t; if |F_t| > mu max(f_n, 0) then
 *   F_t is scaled to that bound and xi = -(F_t + eta_t v_t) / k_t (slip).
 *   k_t = kt_ratio k_n (linear) or kt_ratio * 3/2 k_h sqrt(delta) (hertz, the
 *   tangent normal stiffness); eta_t = eta_n sqrt(kt_ratio). v_t is the
 *   sliding velocity at the contact point including the spins; the contact
 *   point is mid-overlap (lever arms R_i - delta/2, R_j - delta/2, which sum
 *   to the distance, so pair torques conserve angular momentum exactly;
 *   walls: R_i - delta, the wall plane). The history
 *   lives in max_contacts fixed slots per particle (pairs are owned by the
 *   lower index; walls by the particle); more contacts -> MD_E_CONTACTS.
 *   mu = 0: no tangential force and no spin change (the code path has no
 *   friction terms; chosen at create).
 * - Restitution per pair of species (params.restitution_pair): each pair's
 *   damping from its own e by the rules above (linear beta(e_ab), hertz
 *   alpha(e_ab) by the same bisection), with its own m_eff; walls and
 *   obstacles with params.restitution. The reference contact time (below)
 *   is then the shortest over the pairs' and the walls' restitutions. Chosen
 *   at create: without it the pair loop has no species look-up.
 * - Rolling resistance, when mu_r > 0 (the elastic-plastic spring-dashpot
 *   model, EPSD, "model type C" of Ai, Chen, Rotter & Ooi, Powder Technol.
 *   206 (2011) 269): a rolling spring M per contact (in the slot of the
 *   tangential spring, rotated into the tangent plane as xi), the relative
 *   rolling rotation w_r = (w_i - w_j) minus its normal component (wall,
 *   obstacle: w_j = 0); M -= k_r w_r dt, k_r = 2.25 k_N mu_r^2 R_eff^2
 *   (k_N = k_n, hertz 3/2 k_h sqrt(delta)); if |M| > mu_r R_eff max(f_n, 0)
 *   it is cut to that bound (full mobilisation, no damping), else a dashpot
 *   -C_r w_r is added, C_r = 2 eta_r sqrt(I_r k_r), eta_r = 0.3 (Ai et al.),
 *   I_r = 1 / (1/(I_i + m_i R_i^2) + 1/(I_j + m_j R_j^2)) (wall: I_i +
 *   m_i R_i^2). Torque +M on i, -M on j (angular momentum conserved). A
 *   disk/sphere rolling on a floor then decelerates at a = mu_r R f_n l /
 *   (I + m l^2) (l = R - delta the lever arm) and stops. mu_r = 0: no
 *   rolling code in the force loop (chosen at create).
 * - Moments of inertia: disk m R^2 / 2 (2D), sphere 2/5 m R^2 (3D).
 * - Time step: dt = params.dt if > 0, else t_c / dt_steps (default 50), t_c
 *   the contact time of the stiffest reference pair: the two lightest
 *   particles (linear), and for hertz at the impact speed v_ref (required
 *   then). Linear: k_n is given, or t_contact is given and
 *   k_n = m_ref (pi^2 + ln^2 e) / t_contact^2 with m_ref the m_eff of two
 *   lightest particles.
 * - Velocity Verlet: v += F/m dt/2, x += v dt, forces at the new positions
 *   with the half-step velocities (the dashpot and xi see v(t+dt/2)), then
 *   v += F/m dt/2; same for the spins with the torques.
 * - Neighbours: half Verlet list of pairs closer than 2 R_max + skin, built
 *   with cell lists; rebuilt when some particle moved more than skin/2 since
 *   the last build (default skin = 0.2 R_max). Positions are wrapped into
 *   the box at a rebuild only. A periodic axis must be at least
 *   2 (2 R_max + skin) long.
 * - Determinism: the same parameters give the same bits on the same build.
 * - Checkpoints (md_state_get/md_state_set): the dynamic state is the
 *   positions (unwrapped since the last Verlet-list build), velocities,
 *   spins, the forces and torques of the last force pass (the next step's
 *   first half-kick uses them), the Verlet list's reference positions (the
 *   positions of its last build, wrapped into the box), the tangential
 *   springs held (per particle: their number, then each one's partner and
 *   spring vector, in slot order; with mu_r > 0 each one's rolling
 *   spring), the step, build and contact counters and the walls' forces
 *   and impulses (md_walls()).
 *   The pair list is not state: md_state_set() builds it again from the
 *   reference positions, which is what the last build computed. A system
 *   given a state taken from another (same parameters) continues with the
 *   same bits as the original.
 */

typedef struct md md_t;

#define MD_OBSTACLES_MAX 16
#define MD_SPECIES_MAX 16

enum {
	MD_OK = 0,
	MD_E_NOMEM = -1,
	MD_E_PARAM = -2,     /* invalid parameter (md_create) */
	MD_E_BOX = -3,       /* periodic box too small for the cut-off */
	MD_E_CONTACTS = -4,  /* a particle has more contacts than max_contacts */
	MD_E_UNSTABLE = -5,  /* a position became non-finite (time step too large) */
};

typedef enum { MD_LAW_LINEAR = 0, MD_LAW_HERTZ = 1 } md_law_t;

typedef struct {
	int dim;                 /* 2 or 3 */
	int n;                   /* particles, >= 1 */
	double radius;           /* used when radii == NULL */
	const double *radii;     /* optional, n values */
	double mass;             /* used when masses == NULL */
	const double *masses;    /* optional, n values */
	double box[3];           /* edges; box[2] ignored in 2D */
	int periodic[3];         /* 1 periodic, 0 flat walls at 0 and box[a] */
	double gravity[3];       /* acceleration; gravity[2] must be 0 in 2D */
	/* Walls w = 2 axis + side (side 0 at 0, 1 at box[axis]); all zero on periodic axes. A wall is a contact
	 * partner moving with velocity wall_velocity[w] (tangential: its component along the axis must be 0;
	 * a moving wall drags the particles through the dashpot and friction) plus, when wall_amplitude[w] > 0,
	 * a vibration: the plane is displaced along its inward normal by A sin(2 pi f t + phase) (A =
	 * wall_amplitude, f = wall_frequency > 0, phase = wall_phase), and its normal velocity is the
	 * derivative. The overlap uses the plane at the positions' time, the dashpot and the tangential
	 * spring the wall's velocity at the half-step velocities' time (velocity Verlet). */
	double wall_velocity[6][3];
	double wall_amplitude[6];
	double wall_frequency[6];
	double wall_phase[6];
	int virial;              /* nonzero: integrate the pair virial and sum m v^2 over time (md_virial()) */
	/* Fixed obstacles: disks (2D) / spheres (3D) of infinite mass, contact partners with the same law
	 * (m_eff = m_i, R_eff = R_i R_o / (R_i + R_o), contact point mid-overlap, minimum image on periodic
	 * axes; their springs have partner -1 - (6 + k)); their forces are summed (md_obstacles()). */
	int n_obstacles;         /* 0 ... MD_OBSTACLES_MAX */
	double obstacle_center[16][3];
	double obstacle_radius[16];
	md_law_t law;
	double restitution;      /* e in (0, 1]: the walls' and obstacles', and every pair's without restitution_pair */
	/* Restitution per pair of species (optional): species[i] in [0, n_species) for each particle and
	 * restitution_pair[a * n_species + b] (symmetric, each in (0, 1]) the e of the pairs (a, b), from which
	 * their damping is derived as from restitution (contract); walls and obstacles keep restitution.
	 * restitution_pair NULL: restitution for every pair (species then unused). */
	int n_species;           /* 1 ... MD_SPECIES_MAX when restitution_pair is given */
	const int *species;
	const double *restitution_pair;
	double kn;               /* linear: normal stiffness (force/length), or 0 ... */
	double t_contact;        /* ... linear: contact time of the reference pair instead */
	double young;            /* hertz: E*, f = 4/3 E* sqrt(R_eff) delta^(3/2) */
	double v_ref;            /* hertz: impact speed that sets t_c (for dt) */
	double mu;               /* Coulomb friction coefficient, >= 0 */
	double kt_ratio;         /* k_t / k_n; 0 -> 2/7 */
	double mu_r;             /* rolling resistance coefficient (EPSD, contract), >= 0; > 0 needs mu > 0 */
	double dt;               /* > 0: fixed step; 0 -> t_c / dt_steps */
	double dt_steps;         /* 0 -> 50 */
	double skin;             /* Verlet skin; 0 -> 0.2 R_max */
	int max_contacts;        /* history slots per particle; 0 -> 12 (2D: 8) */
	const double *x;         /* n*3 initial positions; NULL: memory only, whose state
	                          * md_state_set() must set before any other call */
	const double *v;         /* n*3 initial velocities, or NULL (rest) */
	const double *w;         /* n*3 initial spins, or NULL */
} md_params_t;

typedef struct {
	double kinetic;          /* sum 1/2 m v^2 */
	double rotational;       /* sum 1/2 I w^2 */
	double elastic;          /* normal (and tangential spring) energy of the contacts */
	double gravitational;    /* -sum m g.x (x unwrapped since the last rebuild) */
} md_energy_t;

/* Creates the system and computes the initial forces. *err gets the code (may be NULL). */
md_t *md_create(const md_params_t *p, int *err);
void md_destroy(md_t *md);

/* Advances nsteps velocity-Verlet steps; 0 or a negative code (the state is then that of the failing step). */
int md_step(md_t *md, long nsteps);

const double *md_positions(const md_t *md);
const double *md_velocities(const md_t *md);
const double *md_spins(const md_t *md);
double md_time(const md_t *md);
double md_dt(const md_t *md);
/* The reference contact time that sets the default dt (see the contract); hertz without v_ref: 0. */
double md_contact_time(const md_t *md);
/* Linear: k_n; hertz: alpha, the dimensionless damping. */
double md_stiffness(const md_t *md);
double md_hertz_alpha(const md_t *md);
/* Contacts (pairs and walls) found at the last force computation. */
size_t md_contact_count(const md_t *md);
/* Verlet-list builds so far (1 after create). */
long md_rebuilds(const md_t *md);
void md_energy(const md_t *md, md_energy_t *out);

/* The dynamic state (see the contract). Arrays have 3n doubles (x ... xref), n (held), springs (partner)
 * and 3 springs (xi, and mr with mu_r > 0) entries; springs = sum of held. Partner: j > i for a pair (the
 * lower index holds it), -1 - (2 axis + side) for a wall (side 0 lower, 1 upper), -1 - (6 + k) for obstacle
 * k. */
typedef struct {
	double *x, *v, *w, *f, *t, *xref;
	int32_t *held;
	size_t springs;
	int32_t *partner;
	double *xi;
	double *mr;              /* 3 springs: the rolling springs (params.mu_r > 0; else unused, may be NULL) */
	uint64_t steps, rebuilds, contacts;
	double wall_force[6][3];     /* md_walls(): the walls' forces at the last force pass, */
	double wall_impulse[6][3];   /* their impulses since the last md_wall_reset() */
	uint64_t wall_steps;         /* and the step count then */
	double obstacle_force[16][3];   /* md_obstacles(): their forces at the last force pass, */
	double obstacle_impulse[16][3]; /* their impulses since the last md_wall_reset() (0 beyond n_obstacles) */
	double virial[4];            /* md_virial() (params.virial; else 0): W and sum m v^2 at the last pass and
	                              * step, and their integrals since the last md_wall_reset() */
} md_state_t;

/* Walls: the momentum the particles gave to each wall w = 2 axis + side (side 0 at 0, 1 at box[axis])
 * since the last md_wall_reset() (or md_create()), as velocity Verlet applies the contact forces: each
 * step gives dt/2 (F(t) + F(t + dt)), so the impulses and gravity's account exactly for the particles'
 * change of momentum; *interval is the time since then (steps times dt). Zero for periodic axes. */
void md_walls(const md_t *md, double impulse[6][3], double *interval);
/* With params.virial: the time integrals, since the last md_wall_reset() (or md_create()), of the pair virial
 * W = sum over contacts of r_ij . f_ij (r_ij from j to i, f_ij the force on i: > 0 for repulsion) and of
 * sum m v^2, by the trapezoid of velocity Verlet's steps (W at each force pass, v at each full step), so the
 * mean pressure over the interval of md_walls() is (kin + vir) / (D V interval) in a periodic box. Else 0. */
void md_virial(const md_t *md, double *vir, double *kin);
/* The momentum the particles gave to each obstacle since the last md_wall_reset(), as md_walls() (the
 * interval is md_walls()'s); n_obstacles rows. */
void md_obstacles(const md_t *md, double impulse[][3]);
/* Starts a new interval of md_walls(), md_obstacles() and md_virial(). */
void md_wall_reset(md_t *md);

/* Bytes the system holds now (its arrays, the pair list's capacity, the cell heads). */
size_t md_memory(const md_t *md);

/* What a system of params p would hold, without creating it (admission budgets; pure, no allocation):
 * memory = md_memory()'s arrays and cell heads for p, and a pair list of the pairs expected within the
 * list's cut-off 2 R_max + skin at volume_fraction (twice the ideal gas's count, for the contact peak of
 * g(r)), rounded up to the list's doubling; state = the bytes of md_state_t with every contact slot held
 * (an upper bound of a checkpoint's state fields); largest = its largest field. MD_OK or MD_E_PARAM (p->n
 * < 1, dim not 2 or 3, a radius or an edge not positive). */
typedef struct {
	size_t memory, state, largest, cells;
} md_plan_t;
int md_plan(const md_params_t *p, double volume_fraction, md_plan_t *out);

/* Springs held now (the partner and xi counts of md_state_get()). */
size_t md_springs(const md_t *md);
/* Copies the state into the non-NULL arrays of st and sets its springs and counters. */
void md_state_get(const md_t *md, md_state_t *st);
/* Sets the whole state (every array required; mr with mu_r > 0) and rebuilds the pair list from xref.
 * MD_OK; MD_E_PARAM when it cannot be a state of this system (non-finite values, a reference position
 * outside the box on a periodic axis, held out of [0, max_contacts], a partner out of range, twice in one
 * particle's slots, or a wall on a periodic axis, springs not the sum of held, in 2D a rolling spring off
 * the z axis); MD_E_NOMEM. The state is unusable after an error. */
int md_state_set(md_t *md, const md_state_t *st);

const char *md_strerror(int code);
