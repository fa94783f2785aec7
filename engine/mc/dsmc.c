/* DSMC and HSMC for granular gases: free flight, counting sort into cells, no-time-counter collisions, Enskog/CBA corrections, coarse excluded volume. */
#include <math.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "dsmc.h"
#include "rng.h"
#include "lattice.h"
#include "ed/walltime.h"
#include "ed/obstacle.h"

#define PI 3.14159265358979323846
#define ALWAYS_INLINE inline __attribute__((always_inline))
/* Wall hits in one step's flight beyond which a particle rests on the wall
 * for the rest of the step (an inelastic bounce series under gravity is
 * infinite in finite time; an elastic one with v_n ~ 0 is as long). */
#define MAX_WALL_HITS 64

/* A wall's rule for dsmc/hsmc (scene.h, scene_wall_t; the same rules as ed's). */
typedef struct {
	int type;                      /* scene_wall_type_t */
	double r, acc, p, beta;        /* restitution; thermal accommodation; rough probability; moving beta */
	double sv;                     /* thermal: sqrt(T_w / m) */
	double svs[SCENE_SPECIES_MAX]; /* thermal, mixtures: sqrt(T_w / m_s) of each species */
	double u[3];                   /* moving, thermal: wall velocity (tangential) */
	double A, omega, ph;           /* vibrating: displacement A sin(ph + omega t) along the inward normal (A = 0: fixed) */
} mcwall_t;

/* An obstacle for dsmc/hsmc (scene.h, scene_obstacle_t; the rule is ed's, obstacle_rule()). */
typedef struct {
	int type;                      /* SCENE_OBST_* */
	double c[3];                   /* centre (internal coordinates) */
	double S;                      /* contact distance: obstacle radius + particle radius (mixtures: the largest) */
	double r, acc, sv;             /* restitution; no_slip: accommodation, sqrt(T_o / m) */
	double svs[SCENE_SPECIES_MAX]; /* no_slip, mixtures: sqrt(T_o / m_s) of each species */
} mcobst_t;

struct dsmc {
	int dim, hsmc, cba;
	uint32_t n;
	double L[3];
	double sigma, mass, e, vp;     /* diameter, mass, restitution, particle volume */
	double chi, sigma_t;           /* rate factor, total cross-section */
	int local_chi;                 /* chi per cell from the local volume fraction (chic) */
	double nu_cap;                 /* local volume fraction is capped here (chi diverges at 1) */
	double fcoef;                  /* collision frequency = fcoef * sqrt(T) */
	double dt_grav;                /* adaptive step's bound under gravity (layout()) */
	double dt_fixed, cps;          /* one of them is > 0 */

	/* cells */
	int nc[3];
	size_t ncells;
	double h[3], inv_h[3], vcell;
	uint32_t nfull;                /* hsmc: a cell with >= nfull particles is full */
	int cell_any;                  /* hsmc.cell_partners "any": a full cell's partner may be any non-empty neighbour */
	/* hsmc in bounded scenes (move_bounded(); scene.h mc_entry, mc_reject; both 0 by default): xopt = either.
	 * entry_lin: a move into another cell is accepted with probability 1 - nu / nu_cap instead of the step at
	 * full; rej_coll: a refused move is a binary collision along the face normal with a random particle of the
	 * refusing cell, the flight going on along the other axes (without obstacles). */
	int xopt, entry_lin, rej_coll;

	/* particles: AoS, stride 2D doubles: x[D] then v[D], in cell order (sorted in place) */
	double *p;
	uint32_t *id;                  /* particle identity (creation index) of each record */
	int32_t *img;                  /* scene_msd_images(): periodic images each particle crossed, img[id * D + a]
	                                * (counted where a flight or a CBA offset wraps it), or NULL */
	uint32_t *cell;                /* new cell of each particle, then its sort destination (one step) */
	uint32_t *start, *cnt;         /* ncells + 1 each; start: sorted offsets of p; cnt: counts, cursors */
	/* sort scratch (see sort()): ring of ring_n records waiting for their slot
	 * (slot j at j % ring_n), list of over_n far movers and their destinations */
	uint32_t ring_n, over_n;
	double *ringp, *overp;
	uint32_t *ringid, *overid, *overdst;
	float *rem;                    /* NTC fractional candidate carried per cell */
	uint32_t *stamp;               /* hsmc: step at which a cell last took part in a cell collision */
	float *chic, *chit;            /* local_chi: chi per cell; scratch for the block average */
	double *chilay;                /* local_chi with walls or species: per axis, each layer's length and its block's */
	float *chm;                    /* local_chi with species: per cell c0, c1, c2 of chi_ij and 1 / chi_max */
	float *vring;                  /* local_chi with obstacles: each cell's ring volume outside them (fixed) */
	float *mixa;                   /* local_chi with species: per moment of the diameters, own sums and block sums */

	rng_t rng;
	double t;
	uint64_t steps, collisions, candidates, vmax_raised, cell_collisions, rejected;
	double ekin_est;               /* E_kin now, up to rounding (for the adaptive step) */
	double e_loss;                 /* energy dissipated in the current step's collisions */

	/* interval accumulators */
	double t_sample, ekin_int, virial;
	uint64_t coll_sample;

	double *bcount;                /* dsmc_count_impacts(): impact-parameter histogram, or NULL */
	int pb_n;                      /* impact_c points (scene.h), 0: molecular chaos */
	double pb_tau[SCENE_IMPACT_MAX], pb_c[SCENE_IMPACT_MAX];
	int bnb;
	/* Bounded scenes (walls, gravity; all zero in a periodic box without
	 * gravity, which runs the original step: see step_dim()'s B). */
	int bounded;                   /* any wall or gravity */
	int walled[3];                 /* axis with walls at both ends */
	int has_walls;                 /* any walled axis */
	double g[3], gnorm;            /* uniform acceleration, |g| */
	double lo[3], hi[3];           /* walled axes: the contact planes of the centres, one radius inside the walls */
	mcwall_t wall[6];              /* wall w = 2 axis + end (0 lower, 1 upper) */
	/* Vibrating walls (step variant B = 2 only): the internal box is the
	 * scene's widened by each vibrating wall's amplitude below its rest
	 * position, as ed does (internal = scene + org); cur_lo/cur_hi are the
	 * contact planes where the walls are at the end of the current step. */
	double org[3];
	double cur_lo[3], cur_hi[3];
	/* Open walls (step variant B = 2): a particle that touches one leaves;
	 * its record goes after the na records still present (sort() puts the
	 * records of the extra cell index ncells there), velocity 0, its last
	 * position kept. na = n without open walls. relaxing: open walls
	 * reflect during the elastic pre-run. */
	uint32_t na;
	int open, relaxing;
	uint64_t wout[6];              /* particles out through each wall, total */
	uint64_t wall_collisions, wall_hits[6], rested;
	double wall_impulse[6][3];     /* momentum given to each wall over the interval */
	/* Obstacles (step variant B = 1 only; nobst = 0 without): oreach bounds
	 * a flight segment's travel along a periodic axis so that the nearest
	 * image of each obstacle is the only one it can reach (flight()); vfac:
	 * per cell V_c / V_free (the volume open to centres), the collision-rate
	 * factor of cells that obstacles cut (1 elsewhere, 0 for a covered cell). */
	int nobst;
	mcobst_t obst[SCENE_OBSTACLES_MAX];
	double oreach;
	float *vfac;
	uint64_t obst_collisions;      /* total */
	double obst_impulse[SCENE_OBSTACLES_MAX][3];   /* momentum given to each obstacle over the interval */
	/* Mixtures (step variant M = 1, dsmc only; mix = 0 without): periodic
	 * (B = 0), with fixed walls, gravity and obstacles (B = 1: flight()) or
	 * vibrating and open walls (B = 2: flight_vib()), each particle with its
	 * own radius and mass. Species and radius of each particle identity (constant:
	 * from the scene), each species' mass, each pair's restitution. sigma
	 * is the largest diameter (the majorant's; placement and CBA offsets use
	 * its contact planes, conservative for the smaller ones); mass the mean
	 * mass. */
	int mix, nsp;
	uint8_t *spc;
	double *rad;
	/* Mixtures with correction enskog or cba: chi_ij = chc[0] + d (chc[1] +
	 * d chc[2]), d = sigma_i sigma_j / (sigma_i + sigma_j), from the moments of
	 * the radii present (dsmc_contact_coefs()); chimax = chi of two particles
	 * of the largest diameter, the majorant's factor, chinv = 1 / chimax. Without
	 * a correction chc = {1, 0, 0}, chimax = chinv = 1: chi_ij = 1 exactly. */
	int corr;
	double chc[3], chimax, chinv;
	/* hsmc mixtures: volume of the particles of each cell (ncells + 1;
	 * cell_volumes() after each sort and at each step's start: a function of
	 * the records, not state); a cell is full at >= vfull. */
	double *vocc, vfull;
	double *pcount;                /* dsmc_count_pairs(): collisions per pair of species, or NULL */
	double msp[SCENE_SPECIES_MAX];
	double pe[SCENE_SPECIES_MAX][SCENE_SPECIES_MAX];
	/* particles.source (scene.h; src = 0 without): n = n0 + src_total records, the ones not inserted yet
	 * wait after the na present ones (as the ones that left through an open wall), at rest, with their
	 * ids n0 + k. src_k: insertions due so far (made, or skipped because the particle would lie beyond
	 * the far wall: src_rej of them); the next is due at (src_k + 1) / src_rate. src_ax: gravity's axis,
	 * src_sg = +1 when gravity points to -src_ax (the floor is the lower wall), else -1. */
	int src, src_ax;
	double src_sg;
	uint32_t n0;
	uint64_t src_total, src_k, src_rej;
	double src_rate, src_h, src_spread, src_sv, src_x[3], src_v[3];
	void (*step)(struct dsmc *, double);   /* chosen at load: dimension and periodic or bounded */
};

/* ---- kinetic theory ------------------------------------------------------ */

double dsmc_contact_value(int dim, double nu)
{
	return dim == 2 ? (1 - 7 * nu / 16) / ((1 - nu) * (1 - nu)) : (1 - nu / 2) / pow(1 - nu, 3);
}

/* Mixtures. 3D: Boublik (J. Chem. Phys. 53, 471 (1970)) and Grundke-Henderson-
 * Lee-Levesque, the contact values that go with the Boublik-Mansoori-Carnahan-
 * Starling-Leland equation of state: with xi_k = (pi/6) sum_s n_s sigma_s^k,
 * chi_ij = 1/(1 - xi_3) + 3 xi_2 d_ij/(1 - xi_3)^2 + 2 xi_2^2 d_ij^2/(1 - xi_3)^3,
 * d_ij = sigma_i sigma_j / (sigma_i + sigma_j). One species (d = sigma/2,
 * xi_2 sigma = nu): 1/(1-nu) + 3 nu/(2 (1-nu)^2) + nu^2/(2 (1-nu)^3) =
 * (1 - nu/2)/(1 - nu)^3, Carnahan-Starling. 2D: Jenkins and Mancini (Phys.
 * Fluids 30, 3776 (1987)), the generalisation of Henderson's value (the same
 * as Santos, Yuste and Lopez de Haro's (Mol. Phys. 96, 1 (1999)) with
 * Henderson's one-species value): with M_k = sum_s n_s sigma_s^k and nu =
 * (pi/4) M_2, chi_ij = 1/(1 - nu) + (9/8) nu d_ij M_1 / ((1 - nu)^2 M_2);
 * one species: 1/(1-nu) + 9 nu/(16 (1-nu)^2) = (1 - 7 nu/16)/(1 - nu)^2. */
static void contact_coefs_moments(int dim, const double m[4], double c[3])
{
	if (dim == 2) {
		double nu = PI / 4 * m[2], u = 1 - nu;
		c[0] = 1 / u;
		c[1] = m[2] > 0 ? 9.0 / 8.0 * nu * m[1] / (u * u * m[2]) : 0;
		c[2] = 0;
	} else {
		double x2 = PI / 6 * m[2], x3 = PI / 6 * m[3], u = 1 - x3;
		c[0] = 1 / u;
		c[1] = 3 * x2 / (u * u);
		c[2] = 2 * x2 * x2 / (u * u * u);
	}
}

void dsmc_contact_coefs(int dim, int ns, const double *n, const double *sigma, double c[3])
{
	double m[4] = {0, 0, 0, 0};
	for (int s = 0; s < ns; s++) {
		double q = 1;
		for (int k = 0; k < 4; k++, q *= sigma[s])
			m[k] += n[s] * q;
	}
	contact_coefs_moments(dim, m, c);
}

double dsmc_contact_pair(const double c[3], double si, double sj)
{
	double dd = si * sj / (si + sj);
	return c[0] + dd * (c[1] + dd * c[2]);
}

double dsmc_mean_speed(int dim, double mass, double temp)
{
	return dim == 2 ? sqrt(PI * temp / (2 * mass)) : sqrt(8 * temp / (PI * mass));
}

/* f = n sigma_T <|g|> chi with <|g|> = sqrt(2) <|v|>. */
double dsmc_collision_frequency(int dim, double nu, double radius, double mass, double temp, double chi)
{
	double sigma = 2 * radius;
	double vp = dim == 2 ? PI * radius * radius : 4.0 / 3.0 * PI * radius * radius * radius;
	double n = nu / vp, st = dim == 2 ? 2 * sigma : PI * sigma * sigma;
	return n * st * sqrt(2.0) * dsmc_mean_speed(dim, mass, temp) * chi;
}

static double default_numax(int dim) { return dim == 2 ? 0.82 : 0.64; }   /* random close packing */

int dsmc_params(const scene_t *s, dsmc_params_t *p, char *warn, size_t warnlen)
{
	memset(p, 0, sizeof(*p));
	if (warn && warnlen)
		warn[0] = '\0';
	if (s->method != SCENE_METHOD_DSMC && s->method != SCENE_METHOD_HSMC)
		return DSMC_EINVAL;
	p->hsmc = s->method == SCENE_METHOD_HSMC;
	p->correction = s->mc_correction != SCENE_MC_DEFAULT ? (int)s->mc_correction
	                                                       : (p->hsmc ? SCENE_MC_CBA : SCENE_MC_NONE);
	p->chi = p->correction == SCENE_MC_NONE ? 1.0 : dsmc_contact_value(s->dim, s->volume_fraction);
	p->local_chi = p->correction != SCENE_MC_NONE && s->mc_local_chi;
	p->max_volume_fraction = s->mc_max_volume_fraction > 0 ? s->mc_max_volume_fraction : default_numax(s->dim);

	/* Validity scales of the gas as simulated (collision rate with chi). */
	double sigma = 2 * s->radius, T = s->temperature;
	double f = dsmc_collision_frequency(s->dim, s->volume_fraction, s->radius, s->mass, T, p->chi);
	p->mean_free_time = f > 0 ? 1 / f : INFINITY;
	p->mean_free_path = dsmc_mean_speed(s->dim, s->mass, 1.0) / dsmc_collision_frequency(s->dim,
	                    s->volume_fraction, s->radius, s->mass, 1.0, p->chi);   /* T-independent */
	/* Two conditions on the cell edge L. Resolution: L <= lambda. Molecular
	 * chaos: a pair that shares a cell must rarely meet twice there. During
	 * its stay (~L / v) a particle has ~L / lambda collisions, shared among
	 * its N_c - 1 = n L^D cell mates, so repeats ~ 1 / (n L^(D-1) lambda):
	 * L >= L_chaos = (2 / (n lambda))^(1/(D-1)) keeps them below 1/2. In a
	 * dilute gas L_chaos < lambda; in a dense one (lambda < sigma) no cell
	 * meets both, and chaos wins (repeated collisions of a cooling pair stop
	 * dissipating: measured in docs/tradeoff.md). hsmc cells must moreover
	 * hold particles to be full: L >= 2 sigma. */
	double n = s->volume_fraction / scene_particle_volume(s);
	p->chaos_edge = pow(2 / (n * p->mean_free_path), 1.0 / (s->dim - 1));
	double floor_edge = fmax(p->chaos_edge, p->hsmc ? 2 * sigma : 0);
	double auto_edge = fmax(p->mean_free_path, floor_edge);
	p->cell_edge = s->mc_cell_size > 0 ? s->mc_cell_size * sigma : auto_edge;
	if (s->mc_time_step > 0)
		p->time_step = s->mc_time_step;
	else
		p->collisions_per_step = s->mc_collisions_per_step > 0 ? s->mc_collisions_per_step : 0.2;

	/* The validity conditions (seed 000 sec. 2.4.1), as warnings. */
	char buf[512] = "";
	size_t k = 0;
#define WARN(...) do { if (k < sizeof buf) k += snprintf(buf + k, sizeof buf - k, "%s", k ? "; " : ""); \
	if (k < sizeof buf) k += snprintf(buf + k, sizeof buf - k, __VA_ARGS__); } while (0)
	if (p->cell_edge > auto_edge * (1 + 1e-9))
		WARN("cell size %.3g diameters exceeds the mean free path %.3g diameters", p->cell_edge / sigma,
		     p->mean_free_path / sigma);
	if (p->cell_edge < 0.5 * p->chaos_edge)
		WARN("cell size %.3g diameters holds too few particles for molecular chaos (repeated collisions of "
		     "the same pair); use >= %.3g", p->cell_edge / sigma, p->chaos_edge / sigma);
	if (p->time_step > p->mean_free_time)
		WARN("time step %.3g exceeds the mean free time %.3g at the initial temperature",
		     p->time_step, p->mean_free_time);
	if (p->collisions_per_step > 1)
		WARN("collisions_per_step %.3g > 1: the time step exceeds the mean free time", p->collisions_per_step);
	if (p->hsmc) {
		double vc = pow(p->cell_edge, s->dim);
		if (p->max_volume_fraction * vc / scene_particle_volume(s) < 2)
			WARN("a full cell holds fewer than 2 particles (cell size %.3g diameters, max_volume_fraction %.3g)",
			     p->cell_edge / sigma, p->max_volume_fraction);
		if (s->volume_fraction >= p->max_volume_fraction)
			WARN("volume fraction %.3g is at or above max_volume_fraction %.3g", s->volume_fraction,
			     p->max_volume_fraction);
	}
#undef WARN
	if (warn && warnlen)
		snprintf(warn, warnlen, "%s", buf);
	return DSMC_OK;
}

/* ---- helpers ------------------------------------------------------------- */

static ALWAYS_INLINE double wrap(double x, double L)
{
	if (x >= L || x < 0) {
		x -= L * floor(x / L);
		if (x >= L || x < 0)
			x = 0;
	}
	return x;
}

/* The cell of x from the grid's inverse edges and counts (locals in hot loops). */
static ALWAYS_INLINE uint32_t cell_at(const double *inv_h, const int *nc, const double *x, const int D)
{
	uint32_t c = 0;
	for (int a = D - 1; a >= 0; a--) {
		int ix = (int)(x[a] * inv_h[a]);
		if (ix >= nc[a])
			ix = nc[a] - 1;
		c = c * (uint32_t)nc[a] + (uint32_t)ix;
	}
	return c;
}

static ALWAYS_INLINE uint32_t cell_of(const struct dsmc *d, const double *x, const int D)
{
	return cell_at(d->inv_h, d->nc, x, D);
}

/* hsmc: whether cell c is full (one species: it holds nfull particles or
 * more; mixtures: the volume of its particles reaches max_volume_fraction
 * of the cell's). */
static ALWAYS_INLINE int cell_full(const struct dsmc *d, size_t c, const int M)
{
	return M ? d->vocc[c] >= d->vfull : d->start[c + 1] - d->start[c] >= d->nfull;
}

/* hsmc mixtures: the volume of each cell's particles (vocc), from the records' cells (start). */
static void cell_volumes(struct dsmc *d)
{
	const double k = d->dim == 2 ? PI : 4.0 / 3.0 * PI;
	for (size_t c = 0; c < d->ncells; c++) {
		double v = 0;
		for (uint32_t q = d->start[c]; q < d->start[c + 1]; q++) {
			double r = d->rad[d->id[q]];
			v += d->dim == 2 ? r * r : r * r * r;
		}
		d->vocc[c] = k * v;
	}
	d->vocc[d->ncells] = 0;
}

static void set_msg(char *msg, size_t len, const char *fmt, double a)
{
	if (msg && len)
		snprintf(msg, len, fmt, a);
}

/* ---- one step -------------------------------------------------------------- */

/* Mean velocity of cell particles [k0, k0+n). */
static ALWAYS_INLINE void cell_mean(const struct dsmc *d, uint32_t k0, uint32_t n, double *u, const int D)
{
	const int S = 2 * D;
	for (int a = 0; a < D; a++)
		u[a] = 0;
	for (uint32_t k = k0; k < k0 + n; k++)
		for (int a = 0; a < D; a++)
			u[a] += d->p[k * S + D + a];
	for (int a = 0; a < D; a++)
		u[a] /= n;
}

/* Mass of particle record k (mixtures: its species'). */
static ALWAYS_INLINE double rec_mass(const struct dsmc *d, uint32_t k, const int M)
{
	return M ? d->msp[d->spc[d->id[k]]] : d->mass;
}

/* Cell particles [k0, k0+n): velocity u of their centre of mass; returns
 * their mass (M = 0: the plain mean, n m). */
static ALWAYS_INLINE double cell_momentum(const struct dsmc *d, uint32_t k0, uint32_t n, double *u, const int D,
                                          const int M)
{
	if (!M) {
		cell_mean(d, k0, n, u, D);
		return (double)n * d->mass;
	}
	const int S = 2 * D;
	double mt = 0;
	for (int a = 0; a < D; a++)
		u[a] = 0;
	for (uint32_t k = k0; k < k0 + n; k++) {
		double m = rec_mass(d, k, M);
		mt += m;
		for (int a = 0; a < D; a++)
			u[a] += m * d->p[k * S + D + a];
	}
	for (int a = 0; a < D; a++)
		u[a] /= mt;
	return mt;
}

/* Give cell particles the new mean velocity u1 (old u0, their centre of
 * mass's; total mass mt) and return gain (>= 0) to their thermal motion:
 * v' = u1 + k (v - u0), k^2 = (E + gain)/E (seed 000 eqs. 2.23-2.33). A
 * cell with no thermal energy (all particles at u0) cannot be rescaled;
 * there a zero-momentum kick along a random direction to its first two
 * particles carries the gain instead. M = 1: each particle's own mass. */
static ALWAYS_INLINE void cell_return(struct dsmc *d, uint32_t k0, uint32_t n, const double *u0, const double *u1,
                                      double gain, const int D, const int M, double mt)
{
	const int S = 2 * D;
	double eth = 0;
	for (uint32_t k = k0; k < k0 + n; k++) {
		double e = 0;
		for (int a = 0; a < D; a++) {
			double w = d->p[k * S + D + a] - u0[a];
			if (M)
				e += w * w;
			else
				eth += w * w;
		}
		if (M)
			eth += rec_mass(d, k, M) * e;
	}
	eth *= M ? 0.5 : 0.5 * d->mass;
	double ref = 0;
	for (int a = 0; a < D; a++)
		ref += u0[a] * u0[a] + u1[a] * u1[a];
	ref *= M ? 0.5 * mt : 0.5 * d->mass * n;
	if (eth > 1e-12 * ref && eth > 0) {
		double kf = sqrt((eth + gain) / eth);
		for (uint32_t k = k0; k < k0 + n; k++)
			for (int a = 0; a < D; a++) {
				double *v = &d->p[k * S + D + a];
				*v = u1[a] + kf * (*v - u0[a]);
			}
		return;
	}
	double w[3], s2 = 0;
	do {
		s2 = 0;
		for (int a = 0; a < D; a++) {
			w[a] = 2 * rng_uniform_fast(&d->rng) - 1;
			s2 += w[a] * w[a];
		}
	} while (s2 > 1 || s2 < 1e-6);
	if (M) {   /* momentum q w to the first, -q w to the second: q^2 s2 (1/m_0 + 1/m_1) / 2 = gain */
		double m0 = rec_mass(d, k0, M), m1 = rec_mass(d, k0 + 1, M);
		double q = sqrt(2 * gain / (s2 * (1 / m0 + 1 / m1)));
		for (uint32_t k = k0; k < k0 + n; k++)
			for (int a = 0; a < D; a++)
				d->p[k * S + D + a] = u1[a] + (k == k0 ? q / m0 * w[a] : k == k0 + 1 ? -q / m1 * w[a] : 0);
		return;
	}
	double delta = sqrt(gain / d->mass / s2);
	for (uint32_t k = k0; k < k0 + n; k++)
		for (int a = 0; a < D; a++)
			d->p[k * S + D + a] = u1[a] + (k == k0 ? delta * w[a] : k == k0 + 1 ? -delta * w[a] : 0);
}

/* HSMC: each full cell of this step's colour meets the full face neighbour
 * (not yet used this step) with the largest approaching normal velocity, as
 * a pseudo-particle of mass M_c and velocity u_c; normal restitution along
 * the face normal; the macroscopic energy lost goes back into the thermal
 * motion of the two cells in proportion to their masses, so a cell
 * collision conserves momentum and energy exactly. M = 1 (mixtures): a
 * cell is full by the volume of its particles, its mass and velocity are
 * its particles' total and centre of mass's. */
static ALWAYS_INLINE void cell_collisions(struct dsmc *d, const int D, const int B, const int M)
{
	uint32_t mark = (uint32_t)d->steps + 1;
	int colour = (int)(d->steps & 1);
	int ci[3] = {0, 0, 0};
	for (size_t c = 0; c < d->ncells; c++) {
		if (c > 0) {   /* advance the cell coordinates */
			for (int a = 0; a < D; a++) {
				if (++ci[a] < d->nc[a])
					break;
				ci[a] = 0;
			}
		}
		uint32_t na = d->start[c + 1] - d->start[c];
		if ((M ? na < 2 || !cell_full(d, c, M) : na < d->nfull) || ((ci[0] + ci[1] + ci[2] + colour) & 1) ||
		    d->stamp[c] == mark)
			continue;
		double ua[3], ub[3] = {0, 0, 0}, best_u[3] = {0, 0, 0}, best_w = 0;
		size_t best = c;
		int best_axis = 0, best_sign = 0;
		double ma = cell_momentum(d, d->start[c], na, ua, D, M), mb = 0;   /* M = 0: after the search, as before */
		for (int a = 0; a < D; a++) {
			size_t stride = 1;
			for (int b = 0; b < a; b++)
				stride *= (size_t)d->nc[b];
			for (int sgn = -1; sgn <= 1; sgn += 2) {
				int cj = ci[a] + sgn;
				if (B && d->walled[a] && (cj < 0 || cj >= d->nc[a]))
					continue;   /* a wall, not a neighbour */
				cj = cj < 0 ? d->nc[a] - 1 : cj >= d->nc[a] ? 0 : cj;
				size_t nb = c + ((size_t)cj - (size_t)ci[a]) * stride;
				if (nb == c)
					continue;
				uint32_t nn = d->start[nb + 1] - d->start[nb];
				if ((d->cell_any ? nn == 0 : M ? nn < 2 || !cell_full(d, nb, M) : nn < d->nfull) || d->stamp[nb] == mark)
					continue;
				double mn = cell_momentum(d, d->start[nb], nn, ub, D, M);
				double w = sgn * (ua[a] - ub[a]);   /* approach speed along the face normal a -> b */
				if (w > best_w) {
					best_w = w;
					best = nb;
					if (M)
						mb = mn;
					best_axis = a;
					best_sign = sgn;
					memcpy(best_u, ub, sizeof(best_u));
				}
			}
		}
		if (best == c)
			continue;
		uint32_t nb_n = d->start[best + 1] - d->start[best];
		if (!M)
			ma = (double)na * d->mass, mb = (double)nb_n * d->mass;
		double mu = ma * mb / (ma + mb);
		double J = (1 + d->e) * mu * best_w;
		double ua1[3], ub1[3];
		memcpy(ua1, ua, sizeof(ua1));
		memcpy(ub1, best_u, sizeof(ub1));
		ua1[best_axis] -= best_sign * J / ma;
		ub1[best_axis] += best_sign * J / mb;
		double lost = 0.5 * (1 - d->e * d->e) * mu * best_w * best_w;
		/* a lone particle has no thermal motion to take its share (cell_partners "any"): the full cell takes it all */
		const int lone = nb_n < 2;
		cell_return(d, d->start[c], na, ua, ua1, lone ? lost : lost * ma / (ma + mb), D, M, ma);
		cell_return(d, d->start[best], nb_n, best_u, ub1, lone ? 0.0 : lost * mb / (ma + mb), D, M, mb);
		d->stamp[c] = d->stamp[best] = mark;
		d->cell_collisions++;
	}
}

/* cell_collisions() of each variant as a function of its own (called once
 * per hsmc step): the step functions keep no trace of it, so that the
 * register allocation of dsmc's hot loops does not depend on it. */
#define CELL_COLL(D, B, M) \
	static __attribute__((noinline)) void cell_coll_##D##B##M(struct dsmc *d) { cell_collisions(d, D, B, M); }
CELL_COLL(2, 0, 0) CELL_COLL(2, 1, 0) CELL_COLL(2, 2, 0) CELL_COLL(2, 0, 1) CELL_COLL(2, 1, 1) CELL_COLL(2, 2, 1)
CELL_COLL(3, 0, 0) CELL_COLL(3, 1, 0) CELL_COLL(3, 2, 0) CELL_COLL(3, 0, 1) CELL_COLL(3, 1, 1) CELL_COLL(3, 2, 1)
#undef CELL_COLL
static ALWAYS_INLINE void cell_coll(struct dsmc *d, const int D, const int B, const int M)
{
	if (D == 2)
		(B == 0 ? (M ? cell_coll_201 : cell_coll_200) : B == 1 ? (M ? cell_coll_211 : cell_coll_210)
		        : (M ? cell_coll_221 : cell_coll_220))(d);
	else
		(B == 0 ? (M ? cell_coll_301 : cell_coll_300) : B == 1 ? (M ? cell_coll_311 : cell_coll_310)
		        : (M ? cell_coll_321 : cell_coll_320))(d);
}

/* Free flight, new cells counted; hsmc rejects moves into cells that were
 * full at the start of the step (free space not updated during the step:
 * order-independent, cells may overfill slightly). Returns E_kin. */
static ALWAYS_INLINE double move(struct dsmc *d, double dt, const int D, const int M)
{
	const int S = 2 * D;
	double ek = 0;
	memset(d->cnt, 0, (d->ncells + 1) * sizeof(uint32_t));
	if (!d->hsmc) {
		/* dsmc: one flat loop (a loop per cell would mispredict its exit at
		 * every cell, ~2.5 particles) */
		double *restrict p = d->p;
		uint32_t *restrict cell = d->cell, *restrict cnt = d->cnt;
		const uint32_t n = d->na;
		/* the grid in locals: the stores to cell and cnt (uint32_t) may
		 * alias d->nc (int), which the compiler would reload each time */
		double L[3], ih[3];
		int ncl[3];
		for (int a = 0; a < D; a++) {
			L[a] = d->L[a];
			ih[a] = d->inv_h[a];
			ncl[a] = d->nc[a];
		}
		for (uint32_t k = 0; k < n; k++) {
			double *x = &p[(size_t)k * S], *v = x + D;
			if (M) {
				double v2 = 0;
				for (int a = 0; a < D; a++) {
					v2 += v[a] * v[a];
					x[a] = wrap(x[a] + v[a] * dt, L[a]);
				}
				ek += d->msp[d->spc[d->id[k]]] * v2;
			} else {
				for (int a = 0; a < D; a++) {
					ek += v[a] * v[a];
					x[a] = wrap(x[a] + v[a] * dt, L[a]);
				}
			}
			uint32_t cn = cell_at(ih, ncl, x, D);
			cell[k] = cn;
			cnt[cn]++;
		}
		return M ? 0.5 * ek : 0.5 * d->mass * ek;
	}
	for (size_t c = 0; c < d->ncells; c++) {
		for (uint32_t k = d->start[c]; k < d->start[c + 1]; k++) {
			double *x = &d->p[(size_t)k * S], *v = x + D, xn[3];
			if (M) {   /* mixtures: each particle's own mass */
				double v2 = 0;
				for (int a = 0; a < D; a++) {
					v2 += v[a] * v[a];
					xn[a] = wrap(x[a] + v[a] * dt, d->L[a]);
				}
				ek += d->msp[d->spc[d->id[k]]] * v2;
			} else {
				for (int a = 0; a < D; a++) {
					ek += v[a] * v[a];
					xn[a] = wrap(x[a] + v[a] * dt, d->L[a]);
				}
			}
			uint32_t cn = cell_of(d, xn, D);
			if (d->hsmc && cn != c && cell_full(d, cn, M)) {
				d->rejected++;
				cn = (uint32_t)c;
			} else {
				for (int a = 0; a < D; a++)
					x[a] = xn[a];
			}
			d->cell[k] = cn;
			d->cnt[cn]++;
		}
	}
	return M ? 0.5 * ek : 0.5 * d->mass * ek;
}

/* ---- bounded scenes: walls and gravity ------------------------------------ */

/* Velocity v of a particle that meets wall w: the wall's rule (as ed's
 * wall_rule(): normal restitution r_w; thermal: with probability
 * accommodation re-emitted from the wall's flux-weighted Maxwellian, a
 * Rayleigh normal and Gaussian tangential speeds about the wall velocity;
 * rough: tangential velocity reversed with probability p; moving:
 * v_t' - u = -beta (v_t - u)). Random numbers from the engine's stream
 * (the flights run in a fixed order). M = 1 (mixtures): a thermal wall
 * re-emits with W->svs[sp], sqrt(T_w / m_sp) for the particle's species sp.
 * Returns the inward normal speed. */
static ALWAYS_INLINE double wall_rule(struct dsmc *d, int w, double *v, const int D, const int M, int sp)
{
	const mcwall_t *W = &d->wall[w];
	const int a = w >> 1;
	const double s = (w & 1) ? -1.0 : 1.0;
	double vn = s * v[a];   /* <= 0: approaching */
	switch (W->type) {
	case SCENE_WALL_THERMAL:
		if (rng_uniform(&d->rng) < W->acc) {
			const double sv = M ? W->svs[sp] : W->sv;
			vn = sv * sqrt(-2.0 * log(1.0 - rng_uniform(&d->rng)));
			for (int k = 0; k < D; k++)
				if (k != a)
					v[k] = W->u[k] + sv * rng_gauss(&d->rng);
		} else {
			vn = -W->r * vn;
		}
		break;
	case SCENE_WALL_ROUGH:
		vn = -W->r * vn;
		if (rng_uniform(&d->rng) < W->p)
			for (int k = 0; k < D; k++)
				if (k != a)
					v[k] = -v[k];
		break;
	case SCENE_WALL_MOVING:
		vn = -W->r * vn;
		for (int k = 0; k < D; k++)
			if (k != a)
				v[k] = W->u[k] - W->beta * (v[k] - W->u[k]);
		break;
	default:
		vn = -W->r * vn;
		break;
	}
	v[a] = s * vn;
	return vn;
}

/* Wall bookkeeping of one flight, committed only when the move is
 * accepted (hsmc rejects moves into full cells: then nothing happened). */
typedef struct {
	unsigned touched;              /* bit per wall */
	uint32_t hits[6];
	uint32_t rested;
	int out;                       /* flight_vib(): 1 + the open wall the particle left through, or 0 */
	double imp[6][3];
	/* obstacle k: bit 6 + k of touched */
	uint32_t ohits[SCENE_OBSTACLES_MAX];
	double oimp[SCENE_OBSTACLES_MAX][3];
} flight_log_t;

/* After a particle's rebound off fixed wall w (axis a): vn its normal speed
 * away from the wall (<= 0: it does not leave it), hits the hits before this
 * one, `left` the time of its flight to go. A particle that gravity presses onto the
 * wall, or that has hit MAX_WALL_HITS times, rests on it for the rest of the
 * flight (the wall takes its normal momentum and its weight; the axis is
 * pinned); one not pressed stays at the wall with no force on it. */
static ALWAYS_INLINE void rest_or_stop(double m, flight_log_t *lg, int w, int a, double vn, int hits,
                                       double left, double *v, double *ga, int *pinned)
{
	double press = (w & 1) ? ga[a] : -ga[a];   /* > 0: gravity pushes it onto this wall */
	if ((vn <= 0 && press > 0) || hits + 1 >= MAX_WALL_HITS) {
		lg->imp[w][a] += m * (v[a] + ga[a] * left);
		v[a] = 0;
		ga[a] = 0;
		*pinned |= 1 << a;
		lg->rested++;
	} else if (vn <= 0) {
		v[a] = 0;
	}
}

/* Particle centre x relative to obstacle k's centre: the nearest image on
 * periodic axes (x may have left [0, L) during a flight). */
static ALWAYS_INLINE void obst_rel(const struct dsmc *d, const double *x, int k, double *rel, const int D)
{
	for (int a = 0; a < D; a++) {
		rel[a] = x[a] - d->obst[k].c[a];
		if (!d->walled[a])
			rel[a] -= d->L[a] * nearbyint(rel[a] / d->L[a]);
	}
	for (int a = D; a < 3; a++)
		rel[a] = 0;
}

/* Exact flight of one particle over dt under constant acceleration g with
 * walls and obstacles: free parabolas between hits, each hit the earliest
 * contact of the centre with a contact plane (walltime_plane(): a quadratic
 * root, cancellation-free, never a missed or repeated contact for grazing
 * and resting particles) or with an obstacle's contact sphere
 * (obstacle_time_grav(), the same guarantees), the rest of the flight
 * continuing from there with the velocity the wall's or obstacle's rule
 * gives. A particle that a wall leaves with no inward speed while gravity
 * presses it there, or that hits walls MAX_WALL_HITS times in one flight,
 * rests on that wall for the rest of the flight (normal velocity and
 * acceleration 0: the wall carries it); an obstacle hit frees it again (the
 * rule may send it off the wall). After MAX_WALL_HITS hits an obstacle hit
 * ends the flight there (the particle waits on the contact sphere with its
 * new velocity). With obstacles a segment is at most oreach / (|v| + |g|
 * left) long (it travels less than oreach along any axis), so the nearest
 * image of each obstacle is the only one in reach. x, v are updated in place
 * (periodic axes left unfolded: move_bounded() folds them). Returns the integral of |v|^2 over the flight
 * (exact: |v + g t|^2 is a quadratic in t).
 * M = 1 (mixtures, chosen at load): the particle of species sp and radius
 * sigma/2 + dr (dr <= 0: sigma is the largest diameter) touches a wall when
 * its centre is its own radius from it (the contact planes moved out by
 * -dr) and an obstacle at obstacle radius + its own radius; impulses with
 * its own mass, thermal re-emission at sqrt(T / m_sp). */
static ALWAYS_INLINE double flight(struct dsmc *d, double *x, double *v, double dt, flight_log_t *lg, const int D,
                                   const int M, int sp, double dr)
{
	double left = dt, integ = 0, ga[3] = {0, 0, 0};
	int pinned = 0;
	/* the one-species expressions exactly when M = 0 (the same code as before) */
#define LO(a) (M ? d->lo[a] + dr : d->lo[a])
#define HI(a) (M ? d->hi[a] - dr : d->hi[a])
#define MASS (M ? d->msp[sp] : d->mass)
	(void)sp, (void)dr;
	for (int a = 0; a < D; a++)
		ga[a] = d->g[a];
	for (int hits = 0;;) {
		double th = left;
		int w = -1, ko = -1;
		if (d->nobst) {
			double v2 = 0, g2 = 0;
			for (int a = 0; a < D; a++)
				v2 += v[a] * v[a], g2 += ga[a] * ga[a];
			const double hmax = d->oreach / (sqrt(v2) + sqrt(g2) * left);
			if (hmax < th)
				th = hmax;
		}
		for (int a = 0; a < D; a++) {
			if (!d->walled[a] || (pinned >> a & 1))
				continue;
			double t0 = walltime_plane(x[a] - LO(a), v[a], ga[a]);
			if (t0 < th)
				th = t0, w = 2 * a;
			double t1 = walltime_plane(HI(a) - x[a], -v[a], -ga[a]);
			if (t1 < th)
				th = t1, w = 2 * a + 1;
		}
		for (int k = 0; k < d->nobst; k++) {
			double rel[3];
			obst_rel(d, x, k, rel, D);
			double t = obstacle_time_grav(rel, v, ga, D, M ? d->obst[k].S + dr : d->obst[k].S, th);
			if (t < th)
				th = t, w = -1, ko = k;
		}
		for (int a = 0; a < D; a++) {
			integ += th * (v[a] * v[a] + th * (v[a] * ga[a] + th * ga[a] * ga[a] / 3));
			x[a] += th * (v[a] + 0.5 * ga[a] * th);
			v[a] += ga[a] * th;
		}
		left -= th;
		if (ko >= 0) {
			const mcobst_t *O = &d->obst[ko];
			const double OS = M ? O->S + dr : O->S;
			double rel[3], nrm[3] = {0, 0, 0}, r2 = 0, before[3];
			obst_rel(d, x, ko, rel, D);
			for (int a = 0; a < D; a++)
				r2 += rel[a] * rel[a];
			const double r = sqrt(r2);
			for (int a = 0; a < D; a++) {
				nrm[a] = rel[a] / r;
				before[a] = v[a];
			}
			obstacle_rule(O->type, O->r, O->acc, M ? O->svs[sp] : O->sv, -INFINITY, d->relaxing, nrm, v, D, &d->rng);
			for (int a = 0; a < D; a++)
				lg->oimp[ko][a] += MASS * (before[a] - v[a]);
			lg->ohits[ko]++;
			lg->touched |= 1u << (6 + ko);
			/* back on the contact sphere: rounding may leave the centre a hair inside */
			if (r < OS)
				for (int a = 0; a < D; a++)
					x[a] += (OS - r) * nrm[a];
			pinned = 0;
			for (int a = 0; a < D; a++)
				ga[a] = d->g[a];
			if (++hits >= MAX_WALL_HITS) {
				double v2 = 0;
				for (int a = 0; a < D; a++)
					v2 += v[a] * v[a];
				integ += left * v2;
				lg->rested++;
				break;
			}
			if (!(left > 0))
				break;
			continue;
		}
		if (w < 0) {
			if (left > 0 && d->nobst)
				continue;   /* a segment cut at oreach: fly on */
			break;
		}
		const int a = w >> 1;
		x[a] = (w & 1) ? HI(a) : LO(a);
		double before[3];
		for (int k = 0; k < D; k++)
			before[k] = v[k];
		double vn = wall_rule(d, w, v, D, M, sp);
		for (int k = 0; k < D; k++)
			lg->imp[w][k] += MASS * (before[k] - v[k]);
		lg->hits[w]++;
		lg->touched |= 1u << w;
		rest_or_stop(MASS, lg, w, a, vn, hits, left, v, ga, &pinned);
		hits++;
		if (!(left > 0))
			break;
	}
	/* (periodic axes: the caller folds x, move_bounded()) */
	return integ;
#undef LO
#undef HI
#undef MASS
}

/* ---- vibrating walls (step variant B = 2, chosen at load) ---------------- */

/* Contact plane of the centres on wall w's side when the wall's phase is th
 * (fixed walls: lo/hi). */
static ALWAYS_INLINE double vib_plane(const struct dsmc *d, int w, double th)
{
	const mcwall_t *W = &d->wall[w];
	const int a = w >> 1;
	const double disp = W->A != 0.0 ? W->A * sin(th) : 0.0;
	return (w & 1) ? d->hi[a] - disp : d->lo[a] + disp;
}

/* Time from phase th until a particle carried by vibrating wall w (pressed
 * on it: the wall accelerates inward faster than gravity, h'' = gam + A
 * omega^2 sin th < 0 with gam gravity along the inward normal) leaves it:
 * the next phase where sin rises through q = -gam / (A omega^2). INFINITY
 * when q >= 1 (the wall never decelerates faster than gravity: A omega^2 <= g). */
static double vib_detach(const mcwall_t *W, double gam, double th)
{
	const double two_pi = 6.28318530717958647692;
	const double q = -gam / (W->A * W->omega * W->omega);
	if (q >= 1.0)
		return INFINITY;
	double delta = asin(q > -1.0 ? q : -1.0) - th;
	delta -= two_pi * floor(delta / two_pi);
	return delta / W->omega;
}

/* flight() with vibrating walls: the same exact parabolas, a vibrating
 * wall's contact found by walltime_vibrating() (the time axis cut at the
 * gap's inflection points, then bracketed monotone root searches: the
 * first contact within the flight, never a missed or a repeated one), the
 * wall's rule applied to the velocity relative to the wall,
 *     v_n' = -r_w (v_n - w) + w,   w = A omega cos(theta) at contact,
 * the centre put on the contact plane. t0 is the time at the start of the
 * flight (the wall phases are ph + omega t: a function of the clock, so a
 * checkpoint needs nothing more). A particle that the rule leaves with no
 * speed away from the wall while the wall presses it (h'' < 0) rides the
 * wall (position and velocity the wall's) until the wall's deceleration
 * exceeds gravity's (vib_detach(): the completely inelastic bouncing ball,
 * exact), then flies off from the wall with the wall's velocity. A flight
 * with MAX_WALL_HITS hits rides its wall (vibrating) or rests on it (fixed)
 * for the rest of the flight. Fixed walls as in flight(). Returns the
 * integral of |v|^2 over the flight (exact, riding included). */
static ALWAYS_INLINE double flight_vib(struct dsmc *d, double *x, double *v, double dt, double t0, flight_log_t *lg,
                                       const int D, const int M, int sp, double dr)
{
	/* M: the particle's own contact planes (flight()), mass and thermal speed */
#define MASS (M ? d->msp[sp] : d->mass)
#define VPLANE(w, th) (M ? vib_plane(d, (w), (th)) + (((w) & 1) ? -dr : dr) : vib_plane(d, (w), (th)))
	(void)sp, (void)dr;
	double left = dt, integ = 0, ga[3];
	int pinned = 0, ride = -1;     /* ride: the vibrating wall carrying the particle, or -1 */
	double tdet = INFINITY;        /* riding: time left until it leaves the wall */
	for (int a = 0; a < D; a++)
		ga[a] = d->g[a];
	for (int hits = 0;; hits++) {
		const double tnow = t0 + (dt - left);
		double th = left;
		int w = -1, detach = 0;
		for (int a = 0; a < D; a++) {
			if (!d->walled[a] || (pinned >> a & 1) || (ride >= 0 && ride >> 1 == a))
				continue;
			for (int k = 0; k < 2; k++) {
				const mcwall_t *W = &d->wall[2 * a + k];
				const double gap = M ? (k ? d->hi[a] - dr - x[a] : x[a] - (d->lo[a] + dr))
				                     : (k ? d->hi[a] - x[a] : x[a] - d->lo[a]);
				const double u = k ? -v[a] : v[a], gam = k ? -ga[a] : ga[a];
				double t;
				if (W->A != 0.0) {
					const double th0 = W->ph + W->omega * tnow;
					t = walltime_vibrating(gap - W->A * sin(th0), u, gam, W->A, W->omega, th0, th);
				} else {
					t = walltime_plane(gap, u, gam);
				}
				if (t < th)
					th = t, w = 2 * a + k;
			}
		}
		if (ride >= 0 && tdet <= th)
			th = tdet, w = -1, detach = 1;
		for (int a = 0; a < D; a++) {
			if (ride >= 0 && ride >> 1 == a) {
				/* riding: the wall's motion; |v_a|^2 = (A omega cos)^2 integrated exactly */
				const mcwall_t *W = &d->wall[ride];
				const double s = (ride & 1) ? -1.0 : 1.0, th0 = W->ph + W->omega * tnow;
				const double th1 = th0 + W->omega * th, aw = W->A * W->omega;
				integ += aw * aw * (0.5 * th + 0.5 * cos(th0 + th1) * sin(W->omega * th) / W->omega);
				const double vb = v[a];
				x[a] = VPLANE(ride, th1);
				v[a] = s * aw * cos(th1);
				/* the wall's push: the momentum change less gravity's share */
				lg->imp[ride][a] += MASS * (ga[a] * th - (v[a] - vb));
				tdet -= th;
				continue;
			}
			integ += th * (v[a] * v[a] + th * (v[a] * ga[a] + th * ga[a] * ga[a] / 3));
			x[a] += th * (v[a] + 0.5 * ga[a] * th);
			v[a] += ga[a] * th;
		}
		left -= th;
		if (detach) {
			ride = -1, tdet = INFINITY;   /* leaves with the wall's velocity; the gap now opens */
		} else if (w >= 0) {
			const int a = w >> 1;
			const mcwall_t *W = &d->wall[w];
			const double s = (w & 1) ? -1.0 : 1.0, thc = W->ph + W->omega * (t0 + (dt - left));
			const double un = W->A != 0.0 ? W->A * W->omega * cos(thc) : 0.0;
			x[a] = VPLANE(w, thc);
			if (W->type == SCENE_WALL_OPEN && !d->relaxing) {
				lg->out = 1 + w;   /* leaves: the flight ends here */
				for (int k = 0; k < D; k++)
					v[k] = 0;
				return integ;
			}
			double before[3];
			for (int k = 0; k < D; k++)
				before[k] = v[k];
			v[a] -= s * un;   /* the rule acts on the velocity relative to the wall */
			double vn = wall_rule(d, w, v, D, M, sp);
			v[a] += s * un;
			for (int k = 0; k < D; k++)
				lg->imp[w][k] += MASS * (before[k] - v[k]);
			lg->hits[w]++;
			lg->touched |= 1u << w;
			if (W->A != 0.0) {
				const double gam = s * ga[a];
				const int pressed = gam + W->A * W->omega * W->omega * sin(thc) < 0.0;
				if ((vn <= 0 && pressed) || hits + 1 >= MAX_WALL_HITS) {
					ride = w;
					tdet = hits + 1 >= MAX_WALL_HITS ? INFINITY : vib_detach(W, gam, thc);
					v[a] = s * un;
					lg->rested++;
				} else if (vn <= 0) {
					v[a] = s * un;   /* leaves with the wall: the gap opens */
				}
			} else {
				rest_or_stop(MASS, lg, w, a, vn, hits, left, v, ga, &pinned);
			}
		} else {
			break;
		}
		if (!(left > 0))
			break;
	}
	for (int a = 0; a < D; a++) {
		if (!d->walled[a])   /* the caller folds it (move_bounded()) */
			continue;
		/* inside the walls where they are now (rounding of the roots) */
		const double clo = M ? d->cur_lo[a] + dr : d->cur_lo[a], chi = M ? d->cur_hi[a] - dr : d->cur_hi[a];
		if (x[a] < clo)
			x[a] = clo;
		if (x[a] > chi)
			x[a] = chi;
	}
	return integ;
#undef VPLANE
#undef MASS
}

/* ---- hsmc's excluded-volume options (bounded scenes, move_bounded()) ------------ */

/* hsmc with an excluded-volume option (xopt): whether the move of record k from cell c of the sort to xn
 * (cell cn) is refused; *tc: the refusing cell. The rule:
 * the target cell (another cell than the start's) holds the volume occ of its capacity cap (nu_cap times its
 * volume); "step": refused at occ >= cap; "linear": accepted with probability 1 - occ / cap (seed 000's p(nu),
 * 1 in an empty cell, 0 at nu_cap). Random numbers from the engine's stream (the moves run in a fixed order). */
static ALWAYS_INLINE int refused(struct dsmc *d, uint32_t k, size_t c, size_t cn, const double *xn, size_t *tc,
                                 const int D, const int M)
{
	double occ, cap;
	if (cn == c)
		return 0;
	*tc = cn;
	if (!d->entry_lin)
		return cell_full(d, cn, M);
	occ = M ? d->vocc[cn] : (double)(d->start[cn + 1] - d->start[cn]) * d->vp;
	cap = d->vfull;
	if (occ <= 0)
		return 0;
	double pin = cap > 0 ? 1 - occ / cap : 0;
	return pin <= 0 || rng_uniform(&d->rng) >= pin;
}

/* hsmc.rejected_moves "collide": record k (velocity v, at x, refused by cell tc on its way to xn) is stopped
 * across the faces it would cross (the axes whose cell coordinate changes) and collides with a random particle
 * j of the refusing cell along their normal (the sum of those axes' unit vectors, normalised): when they
 * approach, J = (1 + e) mu w along it, w the normal relative velocity, mu the pair's reduced mass (the
 * particles' own masses, not the cell's); the pair's momentum is conserved and (1 - e^2) mu w^2 / 2 dissipated.
 * When j has flown already this step (j < k), its kinetic energy change goes to *ekfix (in move_bounded()'s
 * units of ek). Returns the mask of the stopped axes (move_bounded() keeps the flight along the others). */
static ALWAYS_INLINE unsigned refused_collide(struct dsmc *d, uint32_t k, double *v, const double *x,
                                              const double *xn, size_t tc, double *ekfix, const int D, const int M)
{
	const int S = 2 * D;
	double nrm[3] = {0, 0, 0}, n2 = 0;
	unsigned stop = 0;
	for (int a = 0; a < D; a++) {
		int i0 = (int)(x[a] * d->inv_h[a]), i1 = (int)(xn[a] * d->inv_h[a]);
		i0 = i0 >= d->nc[a] ? d->nc[a] - 1 : i0;
		i1 = i1 >= d->nc[a] ? d->nc[a] - 1 : i1;
		int di = i1 - i0;
		if (!d->walled[a] && (di > 1 || di < -1))   /* across the periodic seam */
			di = di > 0 ? -1 : 1;
		if (di)
			stop |= 1u << a;
		nrm[a] = di;
		n2 += (double)di * di;
	}
	const uint32_t b = d->start[tc], nb = d->start[tc + 1] - b;
	if (nb == 0 || n2 == 0)
		return stop ? stop : (1u << D) - 1;
	uint32_t q = nb > 1 ? (uint32_t)(rng_uniform(&d->rng) * nb) : 0;
	if (q >= nb)
		q = nb - 1;
	const uint32_t j = b + q;
	double *vj = &d->p[(size_t)j * S + D], w = 0, inv = 1 / sqrt(n2);
	for (int a = 0; a < D; a++) {
		nrm[a] *= inv;
		w += (v[a] - vj[a]) * nrm[a];
	}
	if (w <= 0)
		return stop;
	const double mi = rec_mass(d, k, M), mj = rec_mass(d, j, M);
	const double e = d->relaxing ? 1.0 : M ? d->pe[d->spc[d->id[k]]][d->spc[d->id[j]]] : d->e;
	const double J = (1 + e) * mi * mj / (mi + mj) * w;
	double before = 0, after = 0;
	for (int a = 0; a < D; a++) {
		before += vj[a] * vj[a];
		vj[a] += J / mj * nrm[a];
		after += vj[a] * vj[a];
		v[a] -= J / mi * nrm[a];
	}
	if (j < k)
		*ekfix += M ? mj * (after - before) : after - before;
	return stop;
}

/* move() for bounded scenes: the exact flight() of each particle; hsmc
 * rejects moves into full cells as move() does (the particle keeps its
 * position and velocity: no acceleration that step, seed 000 sec. 2.3.2).
 * V = 1 (vibrating walls): flight_vib(), and a move is not rejected when
 * the kept position would be beyond a wall where it is at the end of the
 * step (the wall carries the particle). M = 1 (mixtures): each particle's
 * own radius and mass (flight(), flight_vib()). Adds the integral
 * of E_kin dt over the step to *ekint; returns E_kin at the end of the
 * flights. */
static ALWAYS_INLINE double move_bounded(struct dsmc *d, double dt, double *ekint, const int D, const int V,
                                         const int M)
{
	const int S = 2 * D;
	double ek = 0, integ = 0, ekfix = 0;
	flight_log_t lg;
	memset(&lg, 0, sizeof lg);
	memset(d->cnt, 0, (d->ncells + 1) * sizeof(uint32_t));
	if (V)
		for (int a = 0; a < D; a++)
			if (d->walled[a]) {
				d->cur_lo[a] = vib_plane(d, 2 * a, d->wall[2 * a].ph + d->wall[2 * a].omega * (d->t + dt));
				d->cur_hi[a] = vib_plane(d, 2 * a + 1, d->wall[2 * a + 1].ph + d->wall[2 * a + 1].omega * (d->t + dt));
			}
	for (size_t c = 0; c < d->ncells; c++) {
		for (uint32_t k = d->start[c]; k < d->start[c + 1]; k++) {
			double *x = &d->p[(size_t)k * S], *v = x + D, xn[3], vn[3];
			for (int a = 0; a < D; a++)
				xn[a] = x[a], vn[a] = v[a];
			int sp = 0;
			double dr = 0, m = 1;
			if (M) {
				const uint32_t idk = d->id[k];
				sp = d->spc[idk];
				dr = d->rad[idk] - 0.5 * d->sigma;
				m = d->msp[sp];
			}
			double in = V ? flight_vib(d, xn, vn, dt, d->t, &lg, D, M, sp, dr) : flight(d, xn, vn, dt, &lg, D, M, sp, dr);
			/* periodic axes folded into the box; a fold (not every move) is logged for the image counts
			 * (d->img), added when the move is committed */
			int folded = 0;
			int32_t fold[3] = {0, 0, 0};
			for (int a = 0; a < D; a++)
				if (!d->walled[a] && (xn[a] >= d->L[a] || xn[a] < 0)) {
					double y = wrap(xn[a], d->L[a]);
					fold[a] = (int32_t)nearbyint((xn[a] - y) / d->L[a]);
					folded = 1;
					xn[a] = y;
				}
			uint32_t cn = cell_of(d, xn, D);
			int stays = 1;
			if (V) {
				for (int a = 0; a < D; a++)
					if (d->walled[a] && (x[a] < (M ? d->cur_lo[a] + dr : d->cur_lo[a]) ||
					                     x[a] > (M ? d->cur_hi[a] - dr : d->cur_hi[a])))
						stays = 0;
				if (lg.out) {
					/* it left through an open wall: to the extra cell ncells, after the present ones */
					d->wout[lg.out - 1]++;
					lg.out = 0;
					cn = (uint32_t)d->ncells;
					stays = 0;
				}
			}
			/* stays first: a particle that left has cn = ncells, whose start[cn + 1] does not exist */
			size_t tc = 0;
			if (d->hsmc && stays && (d->xopt ? refused(d, k, c, cn, xn, &tc, D, M) : cn != c && cell_full(d, cn, M))) {
				d->rejected++;
				cn = (uint32_t)c;
				unsigned stop = (1u << D) - 1;
				if (d->rej_coll)
					stop = refused_collide(d, k, v, x, xn, tc, &ekfix, D, M);
				if (stop != (1u << D) - 1 && !d->nobst) {
					/* "collide": the flight goes on along the axes not stopped (its walls and gravity; the
					 * axes of a flight without obstacles are independent; with obstacles the whole move
					 * stops, as a part of it could end inside one) */
					for (int a = 0; a < D; a++)
						if (!(stop >> a & 1))
							x[a] = xn[a], v[a] = vn[a];
					cn = cell_of(d, x, D);
					for (int w = 0; w < 2 * D; w++)
						if ((lg.touched >> w & 1) && !(stop >> (w >> 1) & 1)) {
							d->wall_hits[w] += lg.hits[w];
							d->wall_collisions += lg.hits[w];
							for (int b = 0; b < D; b++)
								d->wall_impulse[w][b] += lg.imp[w][b];
						}
				}
				double v2 = 0;   /* unchanged velocity over the step (but for "collide") */
				for (int a = 0; a < D; a++)
					v2 += v[a] * v[a];
				in = v2 * dt;
				ek += M ? m * v2 : v2;
				if (lg.touched)
					memset(&lg, 0, sizeof lg);
			} else {
				if (folded && d->img)
					for (int a = 0; a < D; a++)
						d->img[(size_t)d->id[k] * D + a] += fold[a];
				if (M) {
					double v2 = 0;
					for (int a = 0; a < D; a++) {
						x[a] = xn[a], v[a] = vn[a];
						v2 += vn[a] * vn[a];
					}
					ek += m * v2;
				} else {
					for (int a = 0; a < D; a++) {
						x[a] = xn[a], v[a] = vn[a];
						ek += vn[a] * vn[a];
					}
				}
				if (lg.touched) {
					for (int w = 0; w < 6; w++) {
						if (!(lg.touched >> w & 1))
							continue;
						d->wall_hits[w] += lg.hits[w];
						d->wall_collisions += lg.hits[w];
						for (int b = 0; b < D; b++)
							d->wall_impulse[w][b] += lg.imp[w][b];
					}
					for (int o = 0; o < d->nobst; o++) {
						if (!(lg.touched >> (6 + o) & 1))
							continue;
						d->obst_collisions += lg.ohits[o];
						for (int b = 0; b < D; b++)
							d->obst_impulse[o][b] += lg.oimp[o][b];
					}
					d->rested += lg.rested;
					memset(&lg, 0, sizeof lg);
				}
			}
			integ += M ? m * in : in;
			d->cell[k] = cn;
			d->cnt[cn]++;
		}
	}
	ek += ekfix;
	if (M) {
		*ekint += 0.5 * integ;
		return 0.5 * ek;
	}
	*ekint += 0.5 * d->mass * integ;
	return 0.5 * d->mass * ek;
}

/* Stable counting sort of the records by d->cell, in place: the new
 * offsets go to start and each record's destination (its rank among the
 * records of its new cell, in the old order) replaces its cell number. The
 * order is that of the out-of-place stable sort it replaced (bit-identical
 * trajectories) without a second copy of the records.
 * The records are read once, in order; slot r is written as soon as its
 * own record has been read. A record going back (dst <= r) is written at
 * once; one going forward waits in a ring indexed by destination (window
 * W records: a move to the next cell plane lands about one plane of
 * records ahead); the few going further (periodic wrap across the last
 * axis) wait in an overflow list until the end. Memory traffic is that of
 * a copy, in cache-friendly order. When a step has more far movers than
 * the list holds (a strongly clustered gas), the permutation is applied by
 * following its cycles instead: the same result, with random access. */
static ALWAYS_INLINE void sort(struct dsmc *d, const int D)
{
	const int S = 2 * D;
	const uint32_t n = d->na, W = d->ring_n;
	uint32_t acc = 0;
	for (size_t c = 0; c < d->ncells; c++) {
		uint32_t k = d->cnt[c];
		d->start[c] = d->cnt[c] = acc;   /* cnt: running cursor of cell c */
		acc += k;
	}
	d->start[d->ncells] = acc;
	/* records that left through an open wall (extra cell ncells; none without
	 * open walls) go after the present ones */
	d->cnt[d->ncells] = acc;
	d->na = acc;
	uint32_t *dst = d->cell, far = 0;
	for (uint32_t k = 0; k < n; k++) {
		uint32_t j = d->cnt[dst[k]]++;
		dst[k] = j;
		far += j >= k + W;
	}
	double *p = d->p;
	uint32_t *id = d->id;
	if (far <= d->over_n) {
		double *rp = d->ringp, *op = d->overp;
		uint32_t *rid = d->ringid, *oid = d->overid, *odst = d->overdst, no = 0;
		/* No data-dependent branch but the rare far mover's: whether slot r's
		 * record waits in the ring and whether record r goes back or forward
		 * are coin flips, mispredicted at half the records. Ring slot r % W is
		 * copied to slot r whatever it holds: when it is not slot r's record
		 * (stale), that record is written over it later in this pass (it is
		 * record r itself, just below; a record read later that goes back; or
		 * an overflow record, at the end). */
		for (uint32_t r = 0, w = 0; r < n; r++, w = w + 1 == W ? 0 : w + 1) {   /* w = r % W */
			double rec[6];
			memcpy(rec, &p[(size_t)r * S], S * sizeof(double));
			uint32_t rid0 = id[r], j = dst[r];
			memcpy(&p[(size_t)r * S], &rp[(size_t)w * S], S * sizeof(double));
			id[r] = rid[w];
			if (j > r && j - r >= W) {   /* far forward: the overflow list */
				memcpy(&op[(size_t)no * S], rec, S * sizeof(double));
				oid[no] = rid0;
				odst[no++] = j;
				continue;
			}
			uint32_t wj = w + (j - r);   /* j % W when 0 < j - r < W (unused otherwise) */
			wj = wj >= W ? wj - W : wj;
			const int back = j <= r;
			double *to = back ? &p[(size_t)j * S] : &rp[(size_t)wj * S];
			uint32_t *ti = back ? &id[j] : &rid[wj];
			memcpy(to, rec, S * sizeof(double));
			*ti = rid0;
		}
		for (uint32_t o = 0; o < no; o++) {
			memcpy(&p[(size_t)odst[o] * S], &op[(size_t)o * S], S * sizeof(double));
			id[odst[o]] = oid[o];
		}
		return;
	}
	for (uint32_t k = 0; k < n; k++) {
		uint32_t j = dst[k];
		if (j == k)
			continue;
		/* carry record k along its cycle until the slot k is reached again */
		double rec[6];
		memcpy(rec, &p[(size_t)k * S], S * sizeof(double));
		uint32_t rid = id[k];
		do {
			double tmp[6];
			memcpy(tmp, &p[(size_t)j * S], S * sizeof(double));
			memcpy(&p[(size_t)j * S], rec, S * sizeof(double));
			memcpy(rec, tmp, S * sizeof(double));
			uint32_t ti = id[j];
			id[j] = rid;
			rid = ti;
			uint32_t jn = dst[j];
			dst[j] = j;
			j = jn;
		} while (j != k);
		memcpy(&p[(size_t)k * S], rec, S * sizeof(double));
		id[k] = rid;
		dst[k] = k;
	}
}

/* d^2 g / d nu^2 of dsmc_contact_value(). */
static double contact_value_dd(int dim, double nu)
{
	double w = 1 / (1 - nu);
	return dim == 2 ? -4 * (7.0 / 16) * w * w * w + 6 * (1 - 7 * nu / 16) * w * w * w * w
	                : -3 * w * w * w * w + 12 * (1 - nu / 2) * w * w * w * w * w;
}

/* Layer lengths for the ring volumes: per axis, len[i] of layer i between
 * the walls (h on periodic axes; see local_chi_walled()) and sum[i] of the
 * layers of its block. Uses chilay. */
static void ring_layers(struct dsmc *d, const int D, double *len[3], double *sum[3])
{
	double *w = d->chilay;
	const double R = 0.5 * d->sigma;
	for (int ax = 0; ax < D; ax++) {
		const int n = d->nc[ax];
		const double h = d->h[ax];
		const double wlo = d->cur_lo[ax] - R, whi = d->cur_hi[ax] + R;
		len[ax] = w;
		sum[ax] = w + n;
		w += 2 * (size_t)n;
		for (int i = 0; i < n; i++)
			len[ax][i] = d->walled[ax] ? fmax(0.0, fmin((i + 1) * h, whi) - fmax(i * h, wlo)) : h;
		for (int i = 0; i < n; i++) {
			double t = len[ax][i];
			if (d->walled[ax]) {
				t += i + 1 < n ? len[ax][i + 1] : 0.0;
				t += i > 0 ? len[ax][i - 1] : 0.0;
			} else {
				t += n >= 2 ? len[ax][(i + 1) % n] : 0.0;
				t += n >= 3 ? len[ax][(i + n - 1) % n] : 0.0;
			}
			sum[ax][i] = t;
		}
	}
}

/* local_chi() with walls: the block sums a[] were cut at the walls; the
 * ring's volume is what lies between the walls, per cell. Along a walled
 * axis layer i of the grid holds len[i] of the space between the walls
 * (the contact planes plus one radius: a vibrating wall where it is at the
 * end of this step, B = 2; the layers below it hold none), len = h along
 * periodic axes; the block's volume is the product over axes of the
 * summed lengths of its layers, the ring's that less the cell's own. The
 * same bias correction with each cell's own unit vp / V_ring. A cell
 * whose ring holds no space (a vibrating wall more than a layer into the
 * grid) holds no particles either: chi of the empty gas, 1. */
static void local_chi_walled(struct dsmc *d, const int D, const float *a)
{
	double *len[3], *sum[3];
	ring_layers(d, D, len, sum);
	int idx[3] = {0, 0, 0};
	for (size_t c = 0; c < d->ncells; c++) {
		double vblock = 1, vown = 1;
		for (int ax = 0; ax < D; ax++) {
			vblock *= sum[ax][idx[ax]];
			vown *= len[ax][idx[ax]];
		}
		const double own = (double)(d->start[c + 1] - d->start[c]);
		const double vring = d->vring ? (double)d->vring[c] : vblock - vown;
		double chi = 1.0;
		if (vring > 1e-12 * d->vcell) {
			const double unit = d->vp / vring, nu = (a[c] - own) * unit;
			chi = nu >= d->nu_cap ? dsmc_contact_value(D, d->nu_cap)
			                      : dsmc_contact_value(D, nu) - 0.5 * contact_value_dd(D, nu) * nu * unit;
		}
		d->chic[c] = (float)(chi > 0 ? chi : 0);
		for (int ax = 0; ax < D && ++idx[ax] == d->nc[ax]; ax++)
			idx[ax] = 0;
	}
}

/* The 3^D block sums of a per-cell array a (b: scratch of the same size):
 * one pass of 3-point sums per axis, periodic axes wrapped, walled ones cut.
 * Returns the array holding the sums (a or b, by D's parity); *block: the
 * cells in a periodic block. */
static float *block_sums(const struct dsmc *d, const int D, float *a, float *b, double *block_out)
{
	size_t stride = 1;
	double block = 1;
	for (int ax = 0; ax < D; ax++) {
		size_t n = (size_t)d->nc[ax];
		if (d->walled[ax]) {   /* a wall has no cells beyond it: the end layers' blocks are cut */
			for (size_t c = 0; c < d->ncells; c++) {
				size_t i = (c / stride) % n;
				float sum = a[c];
				if (i + 1 < n)
					sum += a[c + stride];
				if (i > 0)
					sum += a[c - stride];
				b[c] = sum;
			}
		} else {
			for (size_t c = 0; c < d->ncells; c++) {
				size_t i = (c / stride) % n, base = c - i * stride;
				float sum = a[c];
				if (n >= 2)
					sum += a[base + ((i + 1) % n) * stride];
				if (n >= 3)
					sum += a[base + ((i + n - 1) % n) * stride];
				b[c] = sum;
			}
		}
		block *= n >= 3 ? 3 : (double)n;
		float *t = a;
		a = b;
		b = t;
		stride *= n;
	}
	*block_out = block;
	return a;
}

/* Local contact values of a mixture: each pair's chi_ij per cell from the
 * moments m_k = sum sigma^k / V of the diameters in the ring of cells around
 * it (the cell itself left out, as for one species), through the same
 * formulas as the global value (contact_coefs_moments()). chi_ij = c0 + dd
 * (c1 + dd c2) is linear in the coefficients, so the convexity bias is taken
 * off each coefficient: 1/2 sum_jk d2c/dm_j dm_k Cov(m_j, m_k), with Poisson
 * counts Cov(m_j, m_k) = m_(j+k) / V_ring (2D: c depends on m1, m2; 3D: on
 * m2, m3; derivatives worked out by hand, checked against finite
 * differences). Past nu_cap the moments are scaled down to it (the
 * composition kept) and no bias is taken off. Writes chm (c0, c1, c2,
 * chi_max per cell: the majorant's value, two particles of the largest
 * diameter) and chic (= chi_max, the cell's budget factor). */
static void local_chi_mix(struct dsmc *d, const int D)
{
	const size_t nc = d->ncells;
	/* the moments the formulas and their bias need: m1..m4 (2D), m2..m6 (3D),
	 * summed per cell over its particles' own diameters (polydisperse too) */
	const int k0 = D == 2 ? 1 : 2, nk = D == 2 ? 4 : 5;
	float *own = d->mixa, *scr = d->mixa + (size_t)nk * nc;
	float *sums[5];
	memset(own, 0, (size_t)nk * nc * sizeof(float));
	for (size_t c = 0; c < nc; c++)
		for (uint32_t k = d->start[c]; k < d->start[c + 1]; k++) {
			const double sg = 2 * d->rad[d->id[k]];
			double p = D == 2 ? sg : sg * sg;
			for (int q = 0; q < nk; q++, p *= sg)
				own[(size_t)q * nc + c] += (float)p;
		}
	/* each moment's block sums formed in its half of the scratch, with chit
	 * as the second buffer (odd D ends there: copied back) */
	for (int q = 0; q < nk; q++) {
		double block;
		float *tmp = scr + (size_t)q * nc, *other = d->chit;
		memcpy(tmp, own + (size_t)q * nc, nc * sizeof(float));
		sums[q] = block_sums(d, D, tmp, other, &block);
		if (sums[q] == other) {
			memcpy(tmp, other, nc * sizeof(float));
			sums[q] = tmp;
		}
	}
	double *len[3], *sum[3];
	ring_layers(d, D, len, sum);
	const double a = D == 2 ? PI / 4 : PI / 6, dmax = 0.5 * d->sigma;
	int idx[3] = {0, 0, 0};
	for (size_t c = 0; c < nc; c++) {
		double vblock = 1, vown = 1;
		for (int ax = 0; ax < D; ax++) {
			vblock *= sum[ax][idx[ax]];
			vown *= len[ax][idx[ax]];
		}
		const double vring = d->vring ? (double)d->vring[c] : vblock - vown;
		double m[7] = {0, 0, 0, 0, 0, 0, 0}, c3[3] = {1, 0, 0};
		if (vring > 1e-12 * d->vcell) {
			for (int q = 0; q < nk; q++)
				m[k0 + q] = ((double)sums[q][c] - (double)own[(size_t)q * nc + c]) / vring;
			const double nu = a * (D == 2 ? m[2] : m[3]), iv = 1 / vring;
			if (nu >= d->nu_cap) {
				const double f = d->nu_cap / nu;
				for (int k = 0; k < 7; k++)
					m[k] *= f;
				contact_coefs_moments(D, m, c3);
			} else if (nu > 0) {
				contact_coefs_moments(D, m, c3);
				const double u = 1 - nu;
				if (D == 2) {
					const double b = 9 * PI / 32;
					c3[0] -= a * a * m[4] * iv / (u * u * u);
					c3[1] -= 2 * a * b * m[3] * iv / (u * u * u) + 3 * a * a * b * m[1] * m[4] * iv / (u * u * u * u);
				} else {
					const double u3 = u * u * u, u4 = u3 * u, u5 = u4 * u;
					c3[0] -= a * a * m[6] * iv / u3;
					c3[1] -= 6 * a * a * m[5] * iv / u3 + 9 * a * a * a * m[2] * m[6] * iv / u4;
					c3[2] -= 2 * a * a * m[4] * iv / u3 + 12 * a * a * a * m[2] * m[5] * iv / u4 +
					         12 * a * a * a * a * m[2] * m[2] * m[6] * iv / u5;
				}
				/* a handful of particles in the ring can push a corrected
				 * coefficient below its empty-gas value: keep chi_ij a
				 * non-decreasing function of dd, bounded by chi_max */
				c3[0] = fmax(c3[0], 0.0);
				c3[1] = fmax(c3[1], 0.0);
				c3[2] = fmax(c3[2], 0.0);
			}
		}
		const double cmax = c3[0] + dmax * (c3[1] + dmax * c3[2]);
		float *o = d->chm + 4 * c;
		o[0] = (float)c3[0];
		o[1] = (float)c3[1];
		o[2] = (float)c3[2];
		o[3] = (float)(cmax > 0 ? 1 / cmax : 0);
		d->chic[c] = (float)cmax;
		for (int ax = 0; ax < D && ++idx[ax] == d->nc[ax]; ax++)
			idx[ax] = 0;
	}
}

/* Local contact value: chi per cell from the volume fraction of the cells
 * around it (the 3^D block less the cell itself). Two biases are avoided:
 * counting the cell's own particles would correlate chi with its pair
 * count N(N-1) (rate too high by ~2 chi' nu / (3^D chi m) for m particles
 * per cell), and chi is convex, so E g(nu^) > g(nu): the second-order
 * (delta-method) term 1/2 g'' Var(nu^) is taken off, Var from Poisson
 * counts, leaving O(1/M^2) for M particles in the ring. nu is capped at
 * nu_cap, where chi diverges no more. The block sum is separable: one pass
 * of 3-point periodic sums per axis (an axis of 1 or 2 cells sums its
 * distinct cells only). Writes chic. */
static void local_chi(struct dsmc *d, const int D)
{
	if (d->mix) {
		local_chi_mix(d, D);
		return;
	}
	float *a = d->chic;
	for (size_t c = 0; c < d->ncells; c++)
		a[c] = (float)(d->start[c + 1] - d->start[c]);
	double block;
	a = block_sums(d, D, a, d->chit, &block);
	/* a: block sums (chic or chit, depending on D's parity). */
	if (d->has_walls || d->vring) {
		local_chi_walled(d, D, a);
		return;
	}
	const int ring = block > 1;
	const double vring = (ring ? block - 1 : 1) * d->vcell, unit = d->vp / vring;
	for (size_t c = 0; c < d->ncells; c++) {
		double m = a[c] - (ring ? (double)(d->start[c + 1] - d->start[c]) : 0);
		double nu = m * unit, chi;
		if (nu >= d->nu_cap)
			chi = dsmc_contact_value(D, d->nu_cap);
		else
			chi = dsmc_contact_value(D, nu) - 0.5 * contact_value_dd(D, nu) * nu * unit;
		d->chic[c] = (float)(chi > 0 ? chi : 0);   /* unbiased: no clamp at 1 */
	}
}

/* Collisions in every cell (seed 000 eqs. 2.34-2.38, acceptance corrected). */
/* CBA offset in a bounded scene: 0 when a partner would leave the contact
 * planes of a walled axis or enter an obstacle's contact sphere, and the
 * pair then keeps its places. Reflecting
 * or clamping it instead would raise the pair's centre of mass off a floor
 * (an energy source under gravity: the offsets keep the pair's centre of
 * mass, hence its potential energy, only when both move). */
static ALWAYS_INLINE int offset_fits(const struct dsmc *d, const double *xi, const double *xj, const double *sn,
                                     const int D, uint32_t c, const int B, const int M)
{
	double yi[3], yj[3];
	for (int a = 0; a < D; a++) {
		/* B = 2: the planes where the (vibrating) walls are after this step's flights */
		const double lo = B == 2 ? d->cur_lo[a] : d->lo[a], hi = B == 2 ? d->cur_hi[a] : d->hi[a];
		if (d->walled[a] && (xi[a] + sn[a] < lo || xi[a] + sn[a] > hi || xj[a] - sn[a] < lo || xj[a] - sn[a] > hi))
			return 0;
		yi[a] = wrap(xi[a] + sn[a], d->L[a]);
		yj[a] = wrap(xj[a] - sn[a], d->L[a]);
	}
	/* nor into an obstacle */
	for (int k = 0; k < d->nobst; k++) {
		double ri[3], rj[3], si = 0, sj = 0;
		obst_rel(d, yi, k, ri, D);
		obst_rel(d, yj, k, rj, D);
		for (int a = 0; a < D; a++)
			si += ri[a] * ri[a], sj += rj[a] * rj[a];
		if (si < d->obst[k].S * d->obst[k].S || sj < d->obst[k].S * d->obst[k].S)
			return 0;
	}
	if (!d->hsmc)
		return 1;
	/* hsmc: nor may it carry a partner into another cell that is full */
	uint32_t ci = cell_of(d, yi, D), cj = cell_of(d, yj, D);
	return !((ci != c && cell_full(d, ci, M)) || (cj != c && cell_full(d, cj, M)));
}

/* c of P(b)/P_chaos = a / (1 - c b^2) at tau collisions per particle (impact_c: linear between points). */
static double impact_c_at(const struct dsmc *d, double tau)
{
	int k = 0;
	if (tau <= d->pb_tau[0])
		return d->pb_c[0];
	while (k + 1 < d->pb_n && d->pb_tau[k + 1] < tau)
		k++;
	if (k + 1 >= d->pb_n)
		return d->pb_c[d->pb_n - 1];
	double w = (tau - d->pb_tau[k]) / (d->pb_tau[k + 1] - d->pb_tau[k]);
	return d->pb_c[k] + w * (d->pb_c[k + 1] - d->pb_c[k]);
}

/* |b| (in diameters) from P(b)/P_chaos = a / (1 - c b^2) by its inverse CDF at u in [0, 1): in 2D (P_chaos = 1)
 * F(b) = atanh(sqrt(c) b) / atanh(sqrt(c)) (c > 0), atan(sqrt(-c) b) / atan(sqrt(-c)) (c < 0), b (c = 0); in 3D
 * (P_chaos = 2b) b^2 = (1 - (1 - c)^u) / c, b^2 = u at c = 0. k: atanh(sqrt c) or atan(sqrt(-c)) (2D), ln(1 - c)
 * (3D), precomputed per step. */
static ALWAYS_INLINE double impact_b(double c, double k, double u, const int D)
{
	if (D == 2) {
		if (c > 1e-12)
			return tanh(u * k) / sqrt(c);
		if (c < -1e-12)
			return tan(u * k) / sqrt(-c);
		return u;
	}
	return sqrt(fabs(c) > 1e-12 ? -expm1(u * k) / c : u);
}

/* Collision bound of cell c: mean velocity u, s2 = max_i |v_i - u|^2,
 * v_max = 2 sqrt(s2) and 1 / v_max (s2 = 0 for a cell of fewer than two). */
static ALWAYS_INLINE void cell_bound(const struct dsmc *d, size_t c, double *u, double *s2, double *vmax, double *inv,
                                     const int D)
{
	const int S = 2 * D;
	uint32_t k0 = d->start[c], nc = d->start[c + 1] - k0;
	double m = 0;
	if (nc >= 2) {
		cell_mean(d, k0, nc, u, D);
		for (uint32_t k = k0; k < k0 + nc; k++) {
			double w2 = 0;
			for (int a = 0; a < D; a++) {
				double w = d->p[(size_t)k * S + D + a] - u[a];
				w2 += w * w;
			}
			m = w2 > m ? w2 : m;
		}
	}
	*s2 = m;
	*vmax = 2 * sqrt(m);
	*inv = 1 / *vmax;
}

static ALWAYS_INLINE void collide(struct dsmc *d, double dt, const int D, const int B, const int M, const int P)
{
	const int S = 2 * D;
	/* mixtures: the majorant's factor, chi of the largest pair (1 without a correction) */
	const double coef = (d->local_chi ? 1.0 : M ? d->chimax : d->chi) * d->sigma_t * dt / (2 * d->vcell);
	const double ehalf = 0.5 * (1 + d->e), eloss = 0.25 * (1 - d->e * d->e) * d->mass;
	const double sigma = d->sigma;
	double virial = 0, loss = 0, pc = 0, pk = 0;
	uint64_t ncoll = 0, ncand = 0;
	if (P) {   /* impact_c: c at the collisions per particle the run has reached, held for the step */
		pc = impact_c_at(d, 2.0 * (double)d->collisions / (double)d->n);
		pk = D == 3 ? log1p(-pc) : pc > 1e-12 ? atanh(sqrt(pc)) : pc < -1e-12 ? atan(sqrt(-pc)) : 1;
	}
	if (d->local_chi)
		local_chi(d, D);
	/* The cells of two particles or more, listed first without a branch (a
	 * test per cell would be mispredicted at a quarter of the cells, ~2.5
	 * particles each), in cnt: free until the next step's count. The bound
	 * of the next listed cell (mean, maximum, square root, division) is
	 * worked out before this cell's candidates: the collisions of a cell
	 * change only its own particles, so the numbers are the same, and their
	 * latency overlaps this cell's work instead of stalling each cell's start. */
	uint32_t *act = d->cnt, nact = 0;
	for (size_t c = 0; c < d->ncells; c++) {
		act[nact] = (uint32_t)c;
		nact += d->start[c + 1] - d->start[c] >= 2;
	}
	double un[3] = {0, 0, 0}, s2n = 0, vmaxn = 0, invn = 0;
	if (nact)
		cell_bound(d, act[0], un, &s2n, &vmaxn, &invn, D);
	for (uint32_t q = 0; q < nact; q++) {
		const size_t c = act[q];
		uint32_t k0 = d->start[c], nc = d->start[c + 1] - k0;
		double u[3], s2 = s2n, vmax = vmaxn, inv = invn;
		for (int a = 0; a < D; a++)
			u[a] = un[a];
		if (q + 1 < nact)
			cell_bound(d, act[q + 1], un, &s2n, &vmaxn, &invn, D);
		if (s2 == 0)
			continue;
		/* No-time-counter as a thinned Poisson process: the cell has a budget
		 * b = chi N (N-1) sigma_T dt / (2 V_c) (plus the carried remainder)
		 * and each candidate costs 1/v_max. When a collision raises the
		 * bound, later candidates cost less: the thinning stays exact. */
		/* obstacles (B only): n = N_c / V_free in a cell they cut */
		const double vf = B && d->vfac ? (double)d->vfac[c] : 1.0;
		double b = (d->local_chi ? coef * d->chic[c] : coef) * vf * (double)nc * (double)(nc - 1) +
		           (double)d->rem[c] * inv;
		int offset = d->cba && !(d->hsmc && (M ? cell_full(d, c, M) : nc >= d->nfull));
		/* mixtures: chi_ij's coefficients, the box's or (local_chi) the cell's */
		double cc0 = 1, cc1 = 0, cc2 = 0, cinv = 1;
		if (M) {
			const float *o = d->local_chi ? d->chm + 4 * c : NULL;
			cc0 = o ? o[0] : d->chc[0];
			cc1 = o ? o[1] : d->chc[1];
			cc2 = o ? o[2] : d->chc[2];
			cinv = o ? o[3] : d->chinv;
		}
		while (b >= inv) {
			b -= inv;
			ncand++;
			uint32_t i = k0 + (uint32_t)(rng_uniform_fast(&d->rng) * nc);
			uint32_t j = k0 + (uint32_t)(rng_uniform_fast(&d->rng) * (nc - 1));
			if (j >= i)
				j++;
			double *vi = &d->p[(size_t)i * S + D], *vj = &d->p[(size_t)j * S + D], g[3], g2 = 0;
			for (int a = 0; a < D; a++) {
				g[a] = vi[a] - vj[a];
				g2 += g[a] * g[a];
			}
			double r = rng_uniform_fast(&d->rng) * vmax;
			/* mixtures: the majorant has the largest cross-section sigma^(D-1)
			 * and contact value chimax; a pair is accepted with its own,
			 * (sigma_ij / sigma)^(D-1) chi_ij / chimax of it (<= 1: chi_ij grows
			 * with each diameter). chi_ij = 1 exactly without a correction. */
			double sij = sigma, w2 = 1;
			uint32_t si = 0, sj = 0;
			if (M) {
				const uint32_t ii = d->id[i], jj = d->id[j];
				si = d->spc[ii], sj = d->spc[jj];
				const double ri = d->rad[ii], rj = d->rad[jj];
				sij = ri + rj;
				const double dd = 2 * ri * rj / sij, chi = cc0 + dd * (cc1 + dd * cc2);
				const double w = (D == 2 ? sij / sigma : (sij / sigma) * (sij / sigma)) * (chi * cinv);
				w2 = w * w;
			}
			if (M ? r * r >= g2 * w2 : r * r >= g2)
				continue;
			/* Accepted: contact normal n (from j to i) from an impact
			 * parameter uniform on [-sigma, sigma] (2D) or the disk of
			 * radius sigma (3D) perpendicular to g. */
			double gm = sqrt(g2), gh[3], nrm[3], cth, bimp;
			for (int a = 0; a < D; a++)
				gh[a] = g[a] / gm;
			if (D == 2) {
				double bp;
				if (P) {   /* |b| from the table's P(b), the sign uniform */
					bp = impact_b(pc, pk, rng_uniform_fast(&d->rng), 2);
					bp = rng_uniform_fast(&d->rng) < 0.5 ? -bp : bp;
				} else {
					bp = 2 * rng_uniform_fast(&d->rng) - 1;
				}
				cth = sqrt(1 - bp * bp);
				bimp = fabs(bp);
				nrm[0] = -bp * gh[1] - cth * gh[0];
				nrm[1] = bp * gh[0] - cth * gh[1];
			} else {
				double b1, b2, bb;
				if (P) {   /* |b| from the table's P(b), the direction uniform */
					double bm = impact_b(pc, pk, rng_uniform_fast(&d->rng), 3), ph = 2 * PI * rng_uniform_fast(&d->rng);
					bm = bm < 1 ? bm : 1;
					b1 = bm * cos(ph), b2 = bm * sin(ph), bb = bm * bm;
				} else {
					do {
						b1 = 2 * rng_uniform_fast(&d->rng) - 1;
						b2 = 2 * rng_uniform_fast(&d->rng) - 1;
						bb = b1 * b1 + b2 * b2;
					} while (bb >= 1);
				}
				cth = sqrt(1 - bb);
				bimp = sqrt(bb);
				/* orthonormal basis e1, e2 perpendicular to gh (Duff et al. 2017) */
				double sg = gh[2] >= 0 ? 1.0 : -1.0, aa = -1 / (sg + gh[2]), bq = gh[0] * gh[1] * aa;
				double e1[3] = {1 + sg * gh[0] * gh[0] * aa, sg * bq, -sg * gh[0]};
				double e2[3] = {bq, sg + gh[1] * gh[1] * aa, -gh[1]};
				for (int a = 0; a < 3; a++)
					nrm[a] = b1 * e1[a] + b2 * e2[a] - cth * gh[a];
			}
			if (d->bcount) {
				int kb = (int)(bimp * d->bnb);
				d->bcount[kb < d->bnb ? kb : d->bnb - 1] += 1.0;
			}
			double gn = gm * cth;            /* -g.n > 0 */
			if (M && d->pcount)
				d->pcount[si <= sj ? si * (uint32_t)d->nsp + sj : sj * (uint32_t)d->nsp + si] += 1.0;
			if (M) {
				/* J = (1 + e_ij) mu_ij g_n along n, mu_ij = m_i m_j / (m_i + m_j) */
				const double e = d->relaxing ? 1.0 : d->pe[si][sj], mi = d->msp[si], mj = d->msp[sj];
				const double mu = mi * mj / (mi + mj), J = (1 + e) * mu * gn;
				for (int a = 0; a < D; a++) {
					vi[a] += J / mi * nrm[a];
					vj[a] -= J / mj * nrm[a];
				}
				virial += sij * J;
				loss += 0.5 * (1 - e * e) * mu * gn * gn;
			} else {
				double dv = ehalf * gn;
				for (int a = 0; a < D; a++) {
					vi[a] += dv * nrm[a];
					vj[a] -= dv * nrm[a];
				}
				virial += sigma * d->mass * dv;  /* (sigma n) . J, J = m dv n */
				loss += eloss * gn * gn;
			}
			ncoll++;
			/* Keep v_max a strict bound: |g| <= |v_i - u| + |v_j - u|. */
			double wi = 0, wj = 0;
			for (int a = 0; a < D; a++) {
				wi += (vi[a] - u[a]) * (vi[a] - u[a]);
				wj += (vj[a] - u[a]) * (vj[a] - u[a]);
			}
			if (wi > s2 || wj > s2) {
				s2 = wi > wj ? wi : wj;
				vmax = 2 * sqrt(s2);
				inv = 1 / vmax;
				d->vmax_raised++;
			}
			if (offset) {
				/* CBA: each partner moves one diameter along its own
				 * momentum change (seed 000 sec. 2.4.2). */
				double *xi = vi - D, *xj = vj - D, sn[3];
				for (int a = 0; a < D; a++)
					sn[a] = sij * nrm[a];
				if (!B || offset_fits(d, xi, xj, sn, D, (uint32_t)c, B, M))
					for (int a = 0; a < D; a++) {
						double yi = wrap(xi[a] + sn[a], d->L[a]);   /* walled axes: inside, wrap is the identity */
						double yj = wrap(xj[a] - sn[a], d->L[a]);
						if (B && d->img) {   /* bounded scenes only (B = 0: no trace); at a wrap only */
							if (yi != xi[a] + sn[a])
								d->img[(size_t)d->id[(size_t)(xi - d->p) / (2 * D)] * D + a] +=
									(int32_t)nearbyint((xi[a] + sn[a] - yi) / d->L[a]);
							if (yj != xj[a] - sn[a])
								d->img[(size_t)d->id[(size_t)(xj - d->p) / (2 * D)] * D + a] +=
									(int32_t)nearbyint((xj[a] - sn[a] - yj) / d->L[a]);
						}
						xi[a] = yi;
						xj[a] = yj;
					}
			}
		}
		d->rem[c] = (float)(b * vmax);
	}
	d->virial += virial;
	d->e_loss += loss;
	d->collisions += ncoll;
	d->candidates += ncand;
}

/* One step; B = 1 for bounded scenes (walls, gravity): exact flights and
 * wall-aware neighbours and offsets; B = 2 for bounded scenes with a
 * vibrating wall (flight_vib()). B = 0 compiles to the periodic step
 * with no trace of walls (the variant is chosen once, at load). */
static ALWAYS_INLINE void step_dim(struct dsmc *d, double dt, const int D, const int B, const int M, const int P)
{
	if (M && d->hsmc)
		cell_volumes(d);   /* full cells at the step's start */
	if (d->hsmc)
		cell_coll(d, D, B, M);
	double ek;
	if (B) {
		ek = move_bounded(d, dt, &d->ekin_int, D, B == 2, M);
	} else {
		ek = move(d, dt, D, M);
		d->ekin_int += ek * dt;
	}
	sort(d, D);
	if (M && d->hsmc)
		cell_volumes(d);   /* full cells after the flights: for collide() */
	d->e_loss = 0;
	collide(d, dt, D, B, M, P);
	d->ekin_est = ek - d->e_loss;
	d->steps++;
}

static void step2(struct dsmc *d, double dt) { step_dim(d, dt, 2, 0, 0, 0); }
static void step3(struct dsmc *d, double dt) { step_dim(d, dt, 3, 0, 0, 0); }
static void step2b(struct dsmc *d, double dt) { step_dim(d, dt, 2, 1, 0, 0); }
static void step3b(struct dsmc *d, double dt) { step_dim(d, dt, 3, 1, 0, 0); }
static void step2v(struct dsmc *d, double dt) { step_dim(d, dt, 2, 2, 0, 0); }
static void step3v(struct dsmc *d, double dt) { step_dim(d, dt, 3, 2, 0, 0); }
static void step2s(struct dsmc *d, double dt) { step_dim(d, dt, 2, 0, 1, 0); }
static void step3s(struct dsmc *d, double dt) { step_dim(d, dt, 3, 0, 1, 0); }
static void step2bs(struct dsmc *d, double dt) { step_dim(d, dt, 2, 1, 1, 0); }   /* mixtures, fixed walls */
static void step3bs(struct dsmc *d, double dt) { step_dim(d, dt, 3, 1, 1, 0); }
static void step2vs(struct dsmc *d, double dt) { step_dim(d, dt, 2, 2, 1, 0); }   /* mixtures, vibrating or open walls */
static void step3vs(struct dsmc *d, double dt) { step_dim(d, dt, 3, 2, 1, 0); }
static void step2p(struct dsmc *d, double dt) { step_dim(d, dt, 2, 0, 0, 1); }   /* impact_c */
static void step3p(struct dsmc *d, double dt) { step_dim(d, dt, 3, 0, 0, 1); }

/* Initial sort (positions only). */
static void initial_sort(struct dsmc *d)
{
	const int D = d->dim, S = 2 * D;
	memset(d->cnt, 0, (d->ncells + 1) * sizeof(uint32_t));
	for (uint32_t k = 0; k < d->na; k++) {   /* a source's records wait after the na present ones */
		uint32_t c = cell_of(d, &d->p[(size_t)k * S], D);
		d->cell[k] = c;
		d->cnt[c]++;
	}
	if (D == 2)
		sort(d, 2);
	else
		sort(d, 3);
}

static double ekin_exact(const struct dsmc *d, double *mom)
{
	const int D = d->dim, S = 2 * D;
	double ek = 0, pm[3] = {0, 0, 0};
	if (d->mix) {   /* each particle's own mass */
		for (uint32_t k = 0; k < d->n; k++) {
			const double m = d->msp[d->spc[d->id[k]]];
			for (int a = 0; a < D; a++) {
				double v = d->p[(size_t)k * S + D + a];
				ek += m * v * v;
				pm[a] += m * v;
			}
		}
		if (mom)
			for (int a = 0; a < 3; a++)
				mom[a] = pm[a];
		return 0.5 * ek;
	}
	for (uint32_t k = 0; k < d->n; k++)
		for (int a = 0; a < D; a++) {
			double v = d->p[(size_t)k * S + D + a];
			ek += v * v;
			pm[a] += v;
		}
	if (mom)
		for (int a = 0; a < 3; a++)
			mom[a] = d->mass * pm[a];
	return 0.5 * d->mass * ek;
}

int dsmc_advance(dsmc_t *d, double t_stop, uint64_t max_collisions, uint64_t max_steps)
{
	return dsmc_advance_soft(d, t_stop, INFINITY, max_collisions, max_steps);
}

/* Time of the next insertion of the source (INFINITY: none left, or none during the elastic pre-run). */
static double source_next(const struct dsmc *d)
{
	return d->src && !d->relaxing && d->src_k < d->src_total ? (double)(d->src_k + 1) / d->src_rate : INFINITY;
}

/* The source's insertion due now (scene.h, particles.source): its centre src_h above the highest centre
 * present along -g (the floor's contact plane when none is), across gravity at src_x plus uniform noise
 * in [-spread, spread] (periodic axes wrapped), velocity src_v plus a Maxwellian of variance T / m per
 * component. Its record (id n0 + src_k, waiting after the present ones) goes to the end of its cell's
 * records, the records after it one place on: the cell offsets stay those of a sorted state. A particle
 * that would lie beyond the far wall's contact plane is not inserted (src_rej). Random numbers from the
 * engine's stream, at a fixed point of the step sequence (between steps). */
static void source_insert(struct dsmc *d)
{
	const int D = d->dim, S = 2 * D, g = d->src_ax;
	const uint32_t want = d->n0 + (uint32_t)d->src_k;
	d->src_k++;
	double x[3], v[3], top = -INFINITY, sg = d->src_sg;
	for (uint32_t k = 0; k < d->na; k++)
		top = fmax(top, sg * d->p[(size_t)k * S + g]);
	if (!(top > -INFINITY))
		top = sg > 0 ? d->lo[g] : -d->hi[g];   /* the floor's contact plane */
	for (int a = 0; a < D; a++) {
		if (a == g) {
			x[a] = sg * (top + d->src_h);
			continue;
		}
		double u = d->src_spread > 0 ? (2 * rng_uniform(&d->rng) - 1) * d->src_spread : 0.0;
		x[a] = d->src_x[a] + d->org[a] + u;
		if (!d->walled[a])
			x[a] = wrap(x[a], d->L[a]);
	}
	for (int a = 0; a < D; a++)
		v[a] = d->src_v[a] + (d->src_sv > 0 ? d->src_sv * rng_gauss(&d->rng) : 0.0);
	if (!(x[g] >= d->lo[g] && x[g] <= d->hi[g])) {
		d->src_rej++;
		return;
	}
	/* its record: to index na (absent records are interchangeable), then into its cell */
	uint32_t k = d->na;
	while (k < d->n && d->id[k] != want)
		k++;
	if (k >= d->n)
		return;   /* cannot happen: the ids n0 + j, j >= src_k, wait there */
	double rec[6];
	memcpy(rec, &d->p[(size_t)k * S], S * sizeof(double));
	memcpy(&d->p[(size_t)k * S], &d->p[(size_t)d->na * S], S * sizeof(double));
	d->id[k] = d->id[d->na];
	const size_t c = cell_of(d, x, D);
	const uint32_t pos = d->start[c + 1], j = d->na;
	memmove(&d->p[(size_t)(pos + 1) * S], &d->p[(size_t)pos * S], (size_t)(j - pos) * S * sizeof(double));
	memmove(&d->id[pos + 1], &d->id[pos], (size_t)(j - pos) * sizeof(uint32_t));
	for (int a = 0; a < D; a++)
		rec[a] = x[a], rec[D + a] = v[a];
	memcpy(&d->p[(size_t)pos * S], rec, S * sizeof(double));
	d->id[pos] = want;
	for (size_t q = c + 1; q <= d->ncells; q++)
		d->start[q]++;
	d->na++;
	double v2 = 0;
	for (int a = 0; a < D; a++)
		v2 += v[a] * v[a];
	d->ekin_est += 0.5 * d->mass * v2;
}

int dsmc_advance_soft(dsmc_t *d, double t_stop, double t_soft, uint64_t max_collisions, uint64_t max_steps)
{
	for (uint64_t k = 0; k < max_steps && d->t < t_stop && d->t < t_soft && d->collisions < max_collisions; k++) {
		/* the source: insertions due now; steps land on the next one (as on t_stop) */
		double t_land = t_stop;
		if (d->src) {
			while (source_next(d) <= d->t)
				source_insert(d);
			t_land = fmin(t_stop, source_next(d));
		}
		double dt = d->dt_fixed;
		if (dt <= 0) {
			double T = 2 * d->ekin_est / (d->dim * (double)(d->na ? d->na : 1));   /* present particles */
			dt = T > 0 ? d->cps / (d->fcoef * sqrt(T)) : INFINITY;
			if (d->gnorm > 0 && !(dt <= d->dt_grav))
				dt = d->dt_grav;
		}
		if (!isfinite(dt) && !isfinite(t_land))
			return DSMC_QUIESCENT;
		int last = 0;
		if (!(d->t + dt < t_land) || (t_land - d->t - dt) < 1e-12 * dt) {
			dt = t_land - d->t;
			last = 1;
		}
		d->step(d, dt);
		d->t = last ? t_land : d->t + dt;
	}
	return DSMC_OK;
}

/* ---- setup ------------------------------------------------------------------- */

/* Walls and gravity of scene s in d (after the cell grid), and the step
 * variant: the periodic one unless the scene has walls or gravity, the
 * vibrating-wall one (B = 2) only when a wall vibrates (amplitude > 0).
 * The scene's wall kinds dsmc/hsmc cannot honour are refused here (naming
 * the key), so that scene_parse() refuses them too. */
static int layout_bounded(struct dsmc *d, const scene_t *s, char *msg, size_t msglen)
{
	static const char *const axis[3] = { "x", "y", "z" }, *const end[2] = { "lower", "upper" };
	const char *method = d->hsmc ? "hsmc" : "dsmc";
	d->has_walls = scene_has_walls(s);
	d->bounded = d->has_walls || scene_has_gravity(s);
	double g2 = 0, hmin = INFINITY;
	int vib = 0;
	d->open = 0;
	for (int a = 0; a < d->dim; a++) {
		d->g[a] = s->gravity[a];
		g2 += d->g[a] * d->g[a];
		hmin = fmin(hmin, d->h[a]);
		d->walled[a] = s->boundary[a].walled;
		if (!d->walled[a])
			continue;
		/* a particle touches a wall when its centre is one radius from it */
		/* at rest (internal coordinates: org below the scene's 0) */
		d->lo[a] = d->org[a] + 0.5 * d->sigma;
		d->hi[a] = d->org[a] + s->box[a] - 0.5 * d->sigma;
		d->cur_lo[a] = d->lo[a];
		d->cur_hi[a] = d->hi[a];
		for (int k = 0; k < 2; k++) {
			const scene_wall_t *sw = &s->boundary[a].wall[k];
			if (sw->type != SCENE_WALL_SPECULAR && sw->type != SCENE_WALL_THERMAL && sw->type != SCENE_WALL_ROUGH &&
			    sw->type != SCENE_WALL_MOVING && sw->type != SCENE_WALL_VIBRATING && sw->type != SCENE_WALL_OPEN) {
				if (msg && msglen)
					snprintf(msg, msglen, "boundaries.%s.%s.type: these walls are not supported by method \"%s\"",
					         axis[a], end[k], method);
				return DSMC_EINVAL;
			}
			mcwall_t *W = &d->wall[2 * a + k];
			W->type = (int)sw->type;
			W->r = sw->restitution;
			W->acc = sw->accommodation;
			W->p = sw->probability;
			W->beta = sw->tangential_restitution;
			W->sv = sw->type == SCENE_WALL_THERMAL ? sqrt(sw->temperature / s->mass) : 0.0;
			for (int q = 0; q < SCENE_SPECIES_MAX; q++)   /* mixtures: each species' own mass */
				W->svs[q] = sw->type == SCENE_WALL_THERMAL && q < d->nsp && d->mix ? sqrt(sw->temperature / d->msp[q]) : 0.0;
			for (int b = 0; b < 3; b++)
				W->u[b] = b < d->dim && b != a ? sw->velocity[b] : 0.0;
			W->A = W->omega = W->ph = 0.0;
			if (sw->type == SCENE_WALL_OPEN) {
				W->r = 1.0;   /* reflects (specular) during relax only */
				d->open = 1;
			}
			if (sw->type == SCENE_WALL_VIBRATING && sw->amplitude > 0.0) {
				/* its rule is specular with r_w, relative to the wall (flight_vib()) */
				W->A = sw->amplitude;
				W->omega = 2 * PI * sw->frequency;
				W->ph = sw->phase;
				vib = 1;
			}
		}
	}
	/* obstacles: internal coordinates, contact distance, rule */
	d->nobst = s->n_obstacles;
	d->oreach = INFINITY;
	for (int k = 0; k < d->nobst; k++) {
		const scene_obstacle_t *so = &s->obstacle[k];
		mcobst_t *O = &d->obst[k];
		O->type = (int)so->type;
		for (int a = 0; a < 3; a++)
			O->c[a] = a < d->dim ? so->center[a] + d->org[a] : 0.0;
		O->S = so->radius + 0.5 * d->sigma;
		O->r = so->restitution;
		O->acc = so->accommodation;
		O->sv = so->type == SCENE_OBST_NO_SLIP ? sqrt(so->temperature / s->mass) : 0.0;
		for (int q = 0; q < SCENE_SPECIES_MAX; q++)
			O->svs[q] = so->type == SCENE_OBST_NO_SLIP && q < d->nsp && d->mix ? sqrt(so->temperature / d->msp[q]) : 0.0;
		/* a segment travels less than L/2 - S along a periodic axis: the
		 * nearest image is then the only one within reach (2 S < L, scene.c) */
		for (int a = 0; a < d->dim; a++)
			if (!d->walled[a])
				d->oreach = fmin(d->oreach, (0.5 * d->L[a] - O->S) * (1 - 1e-9));
	}
	if (d->nobst) {
		d->bounded = 1;
		if (vib || d->open) {
			if (msg && msglen)
				snprintf(msg, msglen, "obstacles: method \"%s\" does not support obstacles with a vibrating or "
				         "open wall yet; use method \"ed\"", method);
			return DSMC_EINVAL;
		}
	}
	d->gnorm = sqrt(g2);
	/* Adaptive step under gravity: at most the time to fall collisions_per_step
	 * of a cell from rest (a gas at T = 0 still falls, and a step should not
	 * carry particles across many cells between collision steps). */
	d->dt_grav = d->gnorm > 0 ? sqrt(2 * (d->cps > 0 ? d->cps : 0.2) * hmin / d->gnorm) : INFINITY;
	vib |= d->open;   /* open walls take the vibrating-wall step too (flight_vib()) */
	d->step = d->dim == 2 ? (vib ? step2v : d->bounded ? step2b : step2) : (vib ? step3v : d->bounded ? step3b : step3);
	if (d->mix) {
		/* dsmc and hsmc mixtures: periodic (step2s), fixed walls, gravity and
		 * obstacles (step2bs: each particle's own radius and mass in flight()),
		 * vibrating or open walls (step2vs: the same in flight_vib()) */
		d->step = vib ? (d->dim == 2 ? step2vs : step3vs)
		      : d->bounded ? (d->dim == 2 ? step2bs : step3bs) : (d->dim == 2 ? step2s : step3s);
	}
	d->pb_n = s->mc_impact_n;
	memcpy(d->pb_tau, s->mc_impact_tau, sizeof d->pb_tau);
	memcpy(d->pb_c, s->mc_impact_c, sizeof d->pb_c);
	if (d->pb_n > 0) {   /* the parser allows it only in a periodic box of one species */
		if (d->bounded || d->mix) {
			if (msg && msglen)
				snprintf(msg, msglen, "%s.impact_c: only in a periodic box of one species", method);
			return DSMC_EINVAL;
		}
		d->step = d->dim == 2 ? step2p : step3p;
	}
	return DSMC_OK;
}

/* Constants and the cell grid of scene s in d (no arrays): the checks a
 * scene must pass to start, shared by alloc() and dsmc_plan() so that a
 * scene the plan accepts is one the engine builds. DSMC_OK or DSMC_EINVAL
 * with "KEY: reason" in msg. */
static int layout(struct dsmc *d, const scene_t *s, char *msg, size_t msglen)
{
	dsmc_params_t pr;
	d->mix = scene_has_species(s);
	d->nsp = d->mix ? s->n_species : 1;
	for (int a = 0; d->mix && a < s->n_species; a++) {
		d->msp[a] = s->species[a].mass;
		for (int b = 0; b < s->n_species; b++)
			d->pe[a][b] = s->restitution_pair[a][b];
	}
	if ((s->dim != 2 && s->dim != 3) || s->count < 2 || s->count > INT32_MAX ||
	    dsmc_params(s, &pr, NULL, 0) != DSMC_OK) {
		set_msg(msg, msglen, "method: scene not usable by dsmc/hsmc (count %.0f)", (double)s->count);
		return DSMC_EINVAL;
	}
	d->dim = s->dim;
	d->n = d->na = d->n0 = (uint32_t)s->count;
	if (s->src_count > 0) {   /* records for the source's particles, waiting after the present ones */
		if (s->count + s->src_count > INT32_MAX) {
			set_msg(msg, msglen, "particles.source.count: %.0f particles in all are too many", (double)(s->count + s->src_count));
			return DSMC_EINVAL;
		}
		d->n = (uint32_t)(s->count + s->src_count);
		d->src = 1;
		d->src_total = s->src_count;
		d->src_rate = s->src_rate;
		d->src_h = s->src_height;
		d->src_spread = s->src_spread;
		d->src_sv = sqrt(s->src_temperature / s->mass);
		d->src_ax = s->src_axis;
		d->src_sg = s->gravity[s->src_axis] < 0 ? 1.0 : -1.0;
		for (int a = 0; a < 3; a++)
			d->src_x[a] = s->src_position[a], d->src_v[a] = a < s->dim ? s->src_velocity[a] : 0.0;
	}
	d->hsmc = pr.hsmc;
	d->cba = pr.correction == SCENE_MC_CBA;
	d->corr = pr.correction != SCENE_MC_NONE;
	d->sigma = 2 * s->radius;
	d->mass = s->mass;
	d->e = s->restitution;
	d->vp = scene_particle_volume(s);
	d->chi = pr.chi;
	d->local_chi = pr.local_chi;
	d->nu_cap = pr.max_volume_fraction;
	d->sigma_t = d->dim == 2 ? 2 * d->sigma : PI * d->sigma * d->sigma;
	d->fcoef = dsmc_collision_frequency(d->dim, s->volume_fraction, s->radius, s->mass, 1.0, d->chi);
	d->dt_fixed = pr.time_step;
	d->cps = pr.collisions_per_step;

	double ncell = 1;
	d->vcell = 1;
	for (int a = 0; a < 3; a++) {
		d->L[a] = a < d->dim ? s->box[a] : 1.0;
		/* vibrating walls: the internal box reaches each wall's lowest position */
		d->org[a] = 0.0;
		if (a < d->dim && s->boundary[a].walled) {
			const scene_wall_t *w = s->boundary[a].wall;
			d->org[a] = w[0].type == SCENE_WALL_VIBRATING ? w[0].amplitude : 0.0;
			d->L[a] += d->org[a] + (w[1].type == SCENE_WALL_VIBRATING ? w[1].amplitude : 0.0);
		}
		double k = a < d->dim ? floor(d->L[a] / pr.cell_edge) : 1;
		k = k < 1 ? 1 : k;
		ncell *= k;
		d->nc[a] = k > 1e9 ? 1 : (int)k;
		d->h[a] = d->L[a] / k;
		d->inv_h[a] = k / d->L[a];
		if (a < d->dim)
			d->vcell *= d->h[a];
	}
	/* Cells cost memory and time even when empty; an absurdly fine grid is
	 * a scene error, not an out-of-memory crash. */
	if (ncell > 64.0 * d->n + 4096 || ncell > 2e9) {
		if (msg && msglen)
			snprintf(msg, msglen, "%s.cell_size: gives %.3g cells, more than 64 per particle; "
			         "use a larger cell_size or leave it out (automatic)", d->hsmc ? "hsmc" : "dsmc", ncell);
		return DSMC_EINVAL;
	}
	d->ncells = (size_t)ncell;
	d->nfull = (uint32_t)ceil(pr.max_volume_fraction * d->vcell / d->vp - 1e-9);
	d->cell_any = d->hsmc && s->mc_cell_any;
	d->vfull = pr.max_volume_fraction * d->vcell;   /* mixtures */
	if (d->nfull < 2)
		d->nfull = 2;
	return layout_bounded(d, s, msg, msglen);
}

/* Memory and constants for scene s, no state (positions, velocities, RNG). */
/* Sizes of the sort's ring and overflow list (alloc() and dsmc_plan()):
 * ring 1.25 planes of cells (a move along the last axis) + 512 records;
 * overflow list 1/8 of that + 128. */
static void ring_size(struct dsmc *d)
{
	size_t plane = d->dim == 3 ? (size_t)d->nc[0] * (size_t)d->nc[1] : (size_t)d->nc[0];
	double ring = 1.25 * (double)d->n * (double)plane / (double)d->ncells + 512;
	d->ring_n = ring < d->n ? (uint32_t)ring : d->n;
	d->over_n = d->ring_n / 8 + 128 < d->n ? d->ring_n / 8 + 128 : d->n;
}

/* Whether a centre at x (internal coordinates) is inside some obstacle's
 * contact sphere. */
static int in_obstacle(const struct dsmc *d, const double *x)
{
	for (int k = 0; k < d->nobst; k++) {
		double rel[3], r2 = 0;
		obst_rel(d, x, k, rel, d->dim);
		for (int a = 0; a < d->dim; a++)
			r2 += rel[a] * rel[a];
		if (r2 < d->obst[k].S * d->obst[k].S)
			return 1;
	}
	return 0;
}

/* Points per axis of the free-volume quadrature in a cell an obstacle cuts. */
#define VFREE_M2 64
#define VFREE_M3 16

/* vfac[c] = V_c / V_free of every cell (obstacles only): V_free the part
 * of the cell open to centres (outside every contact sphere), by the
 * midpoint rule on an m^D grid in the cells whose box some contact sphere
 * reaches (m = 64 in 2D, 16 in 3D; the others are free: 1); 0 for a cell
 * the obstacles cover. */
static void free_volume(struct dsmc *d)
{
	const int D = d->dim, m = D == 2 ? VFREE_M2 : VFREE_M3;
	int ci[3] = {0, 0, 0};
	for (size_t c = 0; c < d->ncells; c++) {
		if (c > 0)
			for (int a = 0; a < D; a++) {
				if (++ci[a] < d->nc[a])
					break;
				ci[a] = 0;
			}
		/* does some contact sphere reach the cell's box? (distance from its centre to the box) */
		int cut = 0;
		for (int k = 0; k < d->nobst && !cut; k++) {
			double mid[3], rel[3], r2 = 0;
			for (int a = 0; a < D; a++)
				mid[a] = (ci[a] + 0.5) * d->h[a];
			obst_rel(d, mid, k, rel, D);
			for (int a = 0; a < D; a++) {
				double e = fabs(rel[a]) - 0.5 * d->h[a];
				r2 += e > 0 ? e * e : 0;
			}
			cut = r2 < d->obst[k].S * d->obst[k].S;
		}
		if (!cut) {
			d->vfac[c] = 1.0f;
			continue;
		}
		uint64_t total = D == 2 ? (uint64_t)m * m : (uint64_t)m * m * m, open = 0;
		for (uint64_t q = 0; q < total; q++) {
			double x[3];
			uint64_t r = q;
			for (int a = 0; a < D; a++) {
				x[a] = (ci[a] + ((double)(r % (uint64_t)m) + 0.5) / m) * d->h[a];
				r /= (uint64_t)m;
			}
			open += !in_obstacle(d, x);
		}
		d->vfac[c] = open ? (float)((double)total / (double)open) : 0.0f;
	}
}

/* local_chi with obstacles: each cell's ring volume (its 3^D block less
 * itself) outside the obstacles' bodies and between the walls, once (the
 * walls are fixed with obstacles: vibrating and open walls are refused).
 * A cell's volume: the product of its layers' lengths between the walls
 * (ring_layers()) times the fraction of it outside every body (radius S
 * less the largest particle radius), by the midpoint rule of free_volume().
 * The ring volume is then the block sum (block_sums(), in double through
 * float: 1e-7 relative) less the cell's own. Uses chic and chit as scratch
 * (they are rewritten at each step). */
static void ring_volumes_obst(struct dsmc *d)
{
	const int D = d->dim, m = D == 2 ? VFREE_M2 : VFREE_M3;
	double *len[3], *sum[3], block;
	ring_layers(d, D, len, sum);
	float *own = d->vring, *a = d->chic;
	int ci[3] = {0, 0, 0};
	for (size_t c = 0; c < d->ncells; c++) {
		double v = 1;
		for (int ax = 0; ax < D; ax++)
			v *= len[ax][ci[ax]];
		if (d->vfac[c] != 1.0f) {   /* some contact sphere reaches the cell: sample the bodies */
			uint64_t total = D == 2 ? (uint64_t)m * m : (uint64_t)m * m * m, open = 0;
			for (uint64_t q = 0; q < total; q++) {
				double x[3];
				uint64_t r = q;
				for (int ax = 0; ax < D; ax++) {
					x[ax] = (ci[ax] + ((double)(r % (uint64_t)m) + 0.5) / m) * d->h[ax];
					r /= (uint64_t)m;
				}
				int in = 0;
				for (int k = 0; k < d->nobst && !in; k++) {
					double rel[3], r2 = 0, body = d->obst[k].S - 0.5 * d->sigma;
					obst_rel(d, x, k, rel, D);
					for (int ax = 0; ax < D; ax++)
						r2 += rel[ax] * rel[ax];
					in = r2 < body * body;
				}
				open += !in;
			}
			v *= (double)open / (double)total;
		}
		own[c] = (float)v;
		a[c] = (float)v;
		for (int ax = 0; ax < D && ++ci[ax] == d->nc[ax]; ax++)
			ci[ax] = 0;
	}
	float *bs = block_sums(d, D, a, d->chit, &block);
	for (size_t c = 0; c < d->ncells; c++)
		own[c] = fmaxf(bs[c] - own[c], 0.0f);
}

/* Mixtures: chi_ij from the moments of the radii present over the box's
 * volume (with a correction; 1 without), and its value for the largest pair. */
static void mix_contact(struct dsmc *d, const scene_t *s)
{
	d->chc[0] = 1;
	d->chc[1] = d->chc[2] = 0;
	d->chimax = d->chinv = 1;
	if (!d->corr)
		return;
	double vol = 1, m[4] = {0, 0, 0, 0};
	for (int a = 0; a < d->dim; a++)
		vol *= s->box[a];
	for (uint32_t i = 0; i < d->n; i++) {
		double q = 1, sg = 2 * d->rad[i];
		for (int k = 0; k < 4; k++, q *= sg)
			m[k] += q;
	}
	for (int k = 0; k < 4; k++)
		m[k] /= vol;
	contact_coefs_moments(d->dim, m, d->chc);
	d->chimax = dsmc_contact_pair(d->chc, d->sigma, d->sigma);
	d->chinv = 1 / d->chimax;
}

static dsmc_t *alloc(const scene_t *s, int *err, char *msg, size_t msglen)
{
	struct dsmc *d = NULL;
	int rc = DSMC_ENOMEM;

	if (msg && msglen)
		msg[0] = '\0';
	d = calloc(1, sizeof(*d));
	if (!d)
		goto fail;
	if (layout(d, s, msg, msglen) != DSMC_OK) {
		rc = DSMC_EINVAL;
		goto fail;
	}
	size_t S = 2 * (size_t)d->dim;
	if (d->hsmc && d->bounded) {
		d->entry_lin = s->mc_entry;
		d->rej_coll = s->mc_reject;
		d->xopt = d->entry_lin || d->rej_coll;
	}
	d->p = malloc(d->n * S * sizeof(double));
	d->cell = malloc(d->n * sizeof(uint32_t));
	d->start = calloc(d->ncells + 1, sizeof(uint32_t));
	d->cnt = calloc(d->ncells + 1, sizeof(uint32_t));
	d->rem = calloc(d->ncells, sizeof(float));
	if (d->hsmc)
		d->stamp = calloc(d->ncells, sizeof(uint32_t));
	if (d->local_chi) {
		d->chic = malloc(d->ncells * sizeof(float));
		d->chit = malloc(d->ncells * sizeof(float));
		if (d->has_walls || d->mix || d->nobst)
			d->chilay = malloc(2 * ((size_t)d->nc[0] + d->nc[1] + d->nc[2]) * sizeof(double));
		if (d->nobst)
			d->vring = malloc(d->ncells * sizeof(float));
		if (d->mix) {
			d->chm = malloc(4 * d->ncells * sizeof(float));
			d->mixa = malloc(2 * 5 * d->ncells * sizeof(float));
		}
	}
	if (d->nobst) {
		d->vfac = malloc(d->ncells * sizeof(float));
		if (!d->vfac)
			goto fail;
		free_volume(d);
		if (d->local_chi && d->vring && d->chic && d->chit && d->chilay)
			ring_volumes_obst(d);
	}
	if (d->mix) {
		d->spc = malloc(d->n);
		d->rad = malloc(d->n * sizeof(double));
		if (!d->spc || !d->rad)
			goto fail;
		scene_species_radii(s, d->rad);
		uint32_t i = 0;
		for (int a = 0; a < s->n_species; a++)
			for (uint64_t k = 0; k < s->species[a].count && i < d->n; k++)
				d->spc[i++] = (uint8_t)a;
		mix_contact(d, s);
		if (d->hsmc && !(d->vocc = calloc(d->ncells + 1, sizeof(double))))
			goto fail;
	}
	d->id = malloc(d->n * sizeof(uint32_t));
	if (scene_msd_images(s) && !(d->img = calloc((size_t)d->n * (size_t)d->dim, sizeof(int32_t))))
		goto fail;
	ring_size(d);
	/* zeroed: sort() copies ring slots whatever they hold (defined bytes) */
	d->ringp = calloc((size_t)d->ring_n * S, sizeof(double));
	d->ringid = calloc((size_t)d->ring_n, sizeof(uint32_t));
	d->overp = malloc((size_t)d->over_n * S * sizeof(double));
	d->overid = malloc((size_t)d->over_n * sizeof(uint32_t));
	d->overdst = malloc((size_t)d->over_n * sizeof(uint32_t));
	if (!d->ringp || !d->ringid || !d->overp || !d->overid || !d->overdst)
		goto fail;
	if (!d->p || !d->id || !d->cell || !d->start || !d->cnt || !d->rem ||
	    (d->hsmc && !d->stamp) || (d->local_chi && (!d->chic || !d->chit || ((d->has_walls || d->mix || d->nobst) && !d->chilay) ||
	                      (d->nobst && !d->vring) ||
	                      (d->mix && (!d->chm || !d->mixa)))))
		goto fail;
	*err = DSMC_OK;
	return d;
fail:
	dsmc_destroy(d);
	*err = rc;
	if (rc == DSMC_ENOMEM)
		set_msg(msg, msglen, "out of memory for %.0f particles", (double)s->count);
	return NULL;
}

dsmc_t *dsmc_create_blank(const scene_t *s, int *err, char *msg, size_t msglen)
{
	return alloc(s, err, msg, msglen);
}

/* Walled axis a: the range of centres no wall can reach (the contact
 * planes at rest, moved in by the vibrating walls' amplitudes), where
 * particles are placed. */
static double reach_lo(const struct dsmc *d, int a) { return d->lo[a] + d->wall[2 * a].A; }
static double reach_hi(const struct dsmc *d, int a) { return d->hi[a] - d->wall[2 * a + 1].A; }

/* Centre x of site q of the k^D grid over the reachable region (cell-centred). */
static void site_pos(const struct dsmc *d, uint64_t q, uint64_t k, double *x)
{
	for (int a = 0; a < d->dim; a++, q /= k) {
		double f = ((double)(q % k) + 0.5) / (double)k;
		x[a] = d->walled[a] ? reach_lo(d, a) + f * (reach_hi(d, a) - reach_lo(d, a)) : f * d->L[a];
	}
}

/* Lattice placement with obstacles: the smallest k^D grid (as without
 * them) with N sites clear of the obstacles, N of those taken with the
 * vacancies spread (lattice.h). */
static int lattice_clear(struct dsmc *d, char *msg, size_t msglen)
{
	const int D = d->dim;
	const size_t S = 2 * (size_t)D;
	uint64_t k = (uint64_t)ceil(pow((double)d->n, 1.0 / D) - 1e-9), nsite = 0, nfree = 0;
	uint64_t *site = NULL;
	double x[3];
	for (;; k++) {
		nsite = D == 2 ? k * k : k * k * k;
		if (nsite < d->n)
			continue;
		nfree = 0;
		for (uint64_t q = 0; q < nsite; q++) {
			site_pos(d, q, k, x);
			nfree += !in_obstacle(d, x);
		}
		if (nfree >= d->n)
			break;
	}
	site = malloc(nfree * sizeof *site);
	if (!site) {
		set_msg(msg, msglen, "out of memory for %.0f lattice sites", (double)nfree);
		return DSMC_ENOMEM;
	}
	nfree = 0;
	for (uint64_t q = 0; q < nsite; q++) {
		site_pos(d, q, k, x);
		if (!in_obstacle(d, x))
			site[nfree++] = q;
	}
	lattice_fill_t fill;
	lattice_fill_init(&fill, nfree, d->n, &d->rng);
	for (uint32_t i = 0; i < d->n; i++)
		site_pos(d, site[lattice_fill_next(&fill)], k, &d->p[i * S]);
	free(site);
	return DSMC_OK;
}

dsmc_t *dsmc_create(const scene_t *s, uint64_t stream, int *err, char *msg, size_t msglen)
{
	struct dsmc *d = alloc(s, err, msg, msglen);
	if (!d)
		return NULL;
	const size_t S = 2 * (size_t)d->dim;

	rng_init(&d->rng, s->seed, stream);
	/* a source's records wait after the initial particles: placement and velocities see those only */
	const uint32_t nslots = d->n;
	d->n = d->n0;
	/* positions: given (a region, place.h, or an earlier run's frame), or placed */
	if (s->init_pos) {
		for (uint32_t i = 0; i < d->n; i++)
			for (int a = 0; a < d->dim; a++)
				d->p[i * S + a] = wrap(s->init_pos[(size_t)i * d->dim + a] + d->org[a], d->L[a]);
	} else if (s->positions == SCENE_POS_RANDOM) {
		/* uniform in the volume open to centres: with obstacles, drawn again until clear of them */
		for (uint32_t i = 0; i < d->n; i++)
			do {
				for (int a = 0; a < d->dim; a++)
					d->p[i * S + a] = d->walled[a] ? reach_lo(d, a) + rng_uniform(&d->rng) * (reach_hi(d, a) - reach_lo(d, a))
					                               : wrap(rng_uniform(&d->rng) * d->L[a], d->L[a]);
			} while (d->nobst && in_obstacle(d, &d->p[i * S]));
	} else if (d->nobst) {
		if (lattice_clear(d, msg, msglen) != DSMC_OK) {
			*err = DSMC_ENOMEM;
			dsmc_destroy(d);
			return NULL;
		}
	} else {
		/* A k^D grid; when N does not fill it the vacancies are spread over
		 * the box (lattice.h), not left as an empty slab at the top. */
		uint64_t k = (uint64_t)ceil(pow((double)d->n, 1.0 / d->dim) - 1e-9);
		while (pow((double)k, d->dim) < d->n)
			k++;
		lattice_fill_t fill;
		lattice_fill_init(&fill, d->dim == 2 ? k * k : k * k * k, d->n, &d->rng);
		for (uint32_t i = 0; i < d->n; i++) {
			uint64_t r = lattice_fill_next(&fill);
			for (int a = 0; a < d->dim; a++) {
				double f = ((double)(r % k) + 0.5) / (double)k;
				/* walled axes: the grid spans the contact planes */
				d->p[i * S + a] = d->walled[a] ? reach_lo(d, a) + f * (reach_hi(d, a) - reach_lo(d, a)) : f * d->L[a];
				r /= k;
			}
		}
	}
	for (uint32_t i = 0; i < d->n; i++)
		d->id[i] = i;
	/* Maxwellian velocities, zero momentum, exactly T (or given). */
	double mean[3] = {0, 0, 0}, s2 = 0;
	for (uint32_t i = 0; i < d->n && s->init_vel; i++)
		for (int a = 0; a < d->dim; a++)
			d->p[i * S + d->dim + a] = s->init_vel[(size_t)i * d->dim + a];
	if (d->mix && !s->init_vel) {
		/* as ed: Gaussian of variance T / m_s for species s, the centre-of-mass
		 * velocity removed, scaled to exactly T = sum m v^2 / (D N) */
		double mtot = 0, s2m = 0;
		for (uint32_t i = 0; i < d->n; i++) {
			const double m = d->msp[d->spc[i]], sd = 1 / sqrt(m);
			for (int a = 0; a < d->dim; a++) {
				double v = sd * rng_gauss(&d->rng);
				d->p[i * S + d->dim + a] = v;
				mean[a] += m * v;
			}
			mtot += m;
		}
		for (uint32_t i = 0; i < d->n; i++)
			for (int a = 0; a < d->dim; a++) {
				double *v = &d->p[i * S + d->dim + a];
				*v -= mean[a] / mtot;
				s2m += d->msp[d->spc[i]] * *v * *v;
			}
		double sc = s2m > 0 ? sqrt(s->temperature * d->dim * d->n / s2m) : 0;
		for (uint32_t i = 0; i < d->n; i++)
			for (int a = 0; a < d->dim; a++)
				d->p[i * S + d->dim + a] *= sc;
	}
	for (uint32_t i = 0; i < d->n && !s->init_vel && !d->mix; i++)
		for (int a = 0; a < d->dim; a++) {
			double v = rng_gauss(&d->rng);
			d->p[i * S + d->dim + a] = v;
			mean[a] += v;
		}
	for (uint32_t i = 0; i < d->n && !s->init_vel && !d->mix; i++)
		for (int a = 0; a < d->dim; a++) {
			double *v = &d->p[i * S + d->dim + a];
			*v -= mean[a] / d->n;
			s2 += *v * *v;
		}
	double scale = s2 > 0 ? sqrt(s->temperature * d->dim * d->n / (d->mass * s2)) : 0;
	for (uint32_t i = 0; i < d->n && !s->init_vel && !d->mix; i++)
		for (int a = 0; a < d->dim; a++)
			d->p[i * S + d->dim + a] *= scale;
	d->n = nslots;
	for (uint32_t i = d->n0; i < d->n; i++) {   /* the source's, not inserted yet: at rest, inside the box */
		d->id[i] = i;
		for (int a = 0; a < d->dim; a++) {
			d->p[i * S + a] = d->walled[a] ? d->lo[a] : 0.0;
			d->p[i * S + d->dim + a] = 0.0;
		}
	}
	initial_sort(d);
	d->ekin_est = ekin_exact(d, NULL);
	/* The carried remainders start from their stationary distribution,
	 * uniform on [0, 1): starting at 0 would lose half a candidate per
	 * active cell until every cell has been active once (hundreds of steps
	 * when cells are sparsely occupied). */
	for (size_t c = 0; c < d->ncells; c++)
		d->rem[c] = (float)rng_uniform(&d->rng);

	if (s->relax_cpp > 0) {
		double e = d->e;
		d->e = 1;
		d->relaxing = 1;   /* open walls reflect */
		uint64_t target = (uint64_t)ceil(s->relax_cpp * d->na / 2.0);
		(void)dsmc_advance(d, INFINITY, target, UINT64_MAX);   /* QUIESCENT at T = 0: nothing to relax */
		d->e = e;
		d->relaxing = 0;
		d->t = 0;
		d->steps = d->collisions = d->candidates = d->vmax_raised = 0;
		d->cell_collisions = d->rejected = 0;
		d->virial = d->ekin_int = 0;
		d->wall_collisions = d->rested = d->obst_collisions = 0;
		memset(d->obst_impulse, 0, sizeof d->obst_impulse);
		memset(d->wall_hits, 0, sizeof d->wall_hits);
		memset(d->wall_impulse, 0, sizeof d->wall_impulse);
		/* the clock restarts at 0, and with it the vibrating walls' phases:
		 * keep the centres inside the walls where they are at time 0 */
		for (int a = 0; a < d->dim; a++) {
			if (!d->walled[a] || (d->wall[2 * a].A == 0.0 && d->wall[2 * a + 1].A == 0.0))
				continue;
			const double lo = vib_plane(d, 2 * a, d->wall[2 * a].ph), hi = vib_plane(d, 2 * a + 1, d->wall[2 * a + 1].ph);
			for (uint32_t k = 0; k < d->n; k++) {
				double *x = &d->p[k * S + a];
				*x = *x < lo ? lo : *x > hi ? hi : *x;
			}
		}
		d->ekin_est = ekin_exact(d, NULL);
	}
	return d;
}

void dsmc_destroy(dsmc_t *d)
{
	if (!d)
		return;
	free(d->p);
	free(d->id);
	free(d->img);
	free(d->ringp);
	free(d->ringid);
	free(d->overp);
	free(d->overid);
	free(d->overdst);
	free(d->cell);
	free(d->start);
	free(d->cnt);
	free(d->rem);
	free(d->stamp);
	free(d->chic);
	free(d->chit);
	free(d->chilay);
	free(d->chm);
	free(d->vring);
	free(d->mixa);
	free(d->vocc);
	free(d->vfac);
	free(d->spc);
	free(d->rad);
	free(d);
}

/* Wall counters and, with gravity, the centre-of-mass height along -g and
 * the potential energy -m sum g.r (scene coordinates, as ed reports them). */
static void walls_out(const struct dsmc *d, dsmc_sample_t *out)
{
	const int D = d->dim, S = 2 * D;
	out->wall_collisions = d->wall_collisions;
	out->obstacle_collisions = d->obst_collisions;
	out->rested = d->rested;
	out->particles = d->na;
	out->source_inserted = d->src_k - d->src_rej;
	out->source_skipped = d->src_rej;
	memcpy(out->wall_outflow, d->wout, sizeof out->wall_outflow);
	memcpy(out->wall_hits, d->wall_hits, sizeof out->wall_hits);
	out->com_height = out->potential_energy = NAN;
	if (!(d->gnorm > 0))
		return;
	double sum[3] = {0, 0, 0}, gr = 0;
	if (d->mix) {   /* as ed: sums weighted by each particle's mass */
		double mp = 0;
		for (uint32_t k = 0; k < d->na; k++) {
			const double m = d->msp[d->spc[d->id[k]]];
			mp += m;
			for (int a = 0; a < D; a++)
				sum[a] += m * (d->p[(size_t)k * S + a] - d->org[a]);
		}
		for (int a = 0; a < D; a++)
			gr += d->g[a] * sum[a];
		out->potential_energy = -gr;
		out->com_height = mp > 0 ? -gr / (d->gnorm * mp) : NAN;
		return;
	}
	for (uint32_t k = 0; k < d->na; k++)   /* the particles present */
		for (int a = 0; a < D; a++)
			sum[a] += d->p[(size_t)k * S + a];
	for (int a = 0; a < D; a++)
		gr += d->g[a] * (sum[a] - d->na * d->org[a]);   /* scene coordinates */
	out->potential_energy = -d->mass * gr;
	out->com_height = d->na ? -gr / (d->gnorm * d->na) : NAN;
}

/* Mixtures: kinetic energy and count of each species (n_species 0 for one). */
static void species_out(const struct dsmc *d, dsmc_sample_t *out)
{
	out->n_species = d->mix && d->nsp > 1 ? d->nsp : 0;
	if (!out->n_species)
		return;
	const int D = d->dim, S = 2 * D;
	for (uint32_t k = 0; k < d->na; k++) {   /* the particles present (open walls) */
		const int a = d->spc[d->id[k]];
		double v2 = 0;
		for (int b = 0; b < D; b++)
			v2 += d->p[(size_t)k * S + D + b] * d->p[(size_t)k * S + D + b];
		out->species_kinetic_energy[a] += 0.5 * d->msp[a] * v2;
		out->species_count[a]++;
	}
}

void dsmc_sample(dsmc_t *d, dsmc_sample_t *out)
{
	memset(out, 0, sizeof(*out));
	out->time = d->t;
	out->interval = d->t - d->t_sample;
	out->steps = d->steps;
	out->moves = d->steps * d->n;
	out->collisions = d->collisions;
	out->interval_collisions = d->collisions - d->coll_sample;
	out->candidates = d->candidates;
	out->vmax_raised = d->vmax_raised;
	out->cell_collisions = d->cell_collisions;
	out->rejected_moves = d->rejected;
	out->kinetic_energy = ekin_exact(d, out->momentum);
	out->ekin_time_integral = d->ekin_int;
	out->virial = d->virial;
	walls_out(d, out);
	species_out(d, out);
	memcpy(out->wall_impulse, d->wall_impulse, sizeof out->wall_impulse);
	memset(d->wall_impulse, 0, sizeof d->wall_impulse);
	memcpy(out->obstacle_impulse, d->obst_impulse, sizeof out->obstacle_impulse);
	memset(d->obst_impulse, 0, sizeof d->obst_impulse);
	d->t_sample = d->t;
	d->coll_sample = d->collisions;
	d->ekin_int = 0;
	d->virial = 0;
}

void dsmc_state(const dsmc_t *d, double *pos, double *vel)
{
	const int D = d->dim, S = 2 * D;
	for (uint32_t k = 0; k < d->n; k++) {
		size_t i = d->id[k];
		for (int a = 0; a < D; a++) {
			/* scene coordinates; NaN for a particle that left through an open wall */
			if (pos)
				pos[i * D + a] = k < d->na ? d->p[(size_t)k * S + a] - d->org[a] : NAN;
			if (vel)
				vel[i * D + a] = k < d->na ? d->p[(size_t)k * S + D + a] : NAN;
		}
	}
}

int dsmc_unwrapped(const dsmc_t *d, double *pos)
{
	if (!d->img || !pos)
		return DSMC_EINVAL;
	const int D = d->dim;
	dsmc_state(d, pos, NULL);
	for (uint32_t i = 0; i < d->n; i++)
		for (int a = 0; a < D; a++)
			if (!d->walled[a])   /* NaN rows (particles gone or not inserted yet) stay NaN */
				pos[(size_t)i * D + a] += d->L[a] * (double)d->img[(size_t)i * D + a];
	return DSMC_OK;
}

void dsmc_totals(const dsmc_t *d, dsmc_sample_t *out)
{
	memset(out, 0, sizeof(*out));
	out->time = d->t;
	out->steps = d->steps;
	out->moves = d->steps * d->n;
	out->collisions = d->collisions;
	out->candidates = d->candidates;
	out->vmax_raised = d->vmax_raised;
	out->cell_collisions = d->cell_collisions;
	out->rejected_moves = d->rejected;
	out->kinetic_energy = ekin_exact(d, out->momentum);
	walls_out(d, out);
	species_out(d, out);
}

/* ---- state fields (checkpoints) ------------------------------------------
 * Everything a step reads that is not rebuilt from the scene: the particle
 * records in their cell order with their identities and the cell offsets
 * (CBA offsets move particles after the sort, so the offsets are not a
 * function of the positions), the carried NTC remainders, the hsmc cell
 * stamps, the RNG, the clock and counters, the adaptive step's energy
 * estimate and the interval accumulators. Not stored: the sort scratch
 * cell, cnt (rewritten before they are read in every step) and v_max
 * (recomputed per cell and step from the velocities). */
enum { F_SCALAR, F_PART, F_ID, F_START, F_REM, F_STAMP, F_RNG, F_WALL, F_WHITS, F_WIMP, F_PRESENT, F_WOUT, F_OBST, F_OIMP,
       F_SRC, F_IMG };
typedef struct {
	const char *name;
	ed_type_t type;
	int kind;
	size_t off;   /* F_SCALAR: offset in struct dsmc */
} dfield_t;

static const dfield_t dfields[] = {
	{ "particles", ED_T_F64, F_PART, 0 },
	{ "id", ED_T_U32, F_ID, 0 },
	{ "start", ED_T_U32, F_START, 0 },
	{ "rem", ED_T_F64, F_REM, 0 },
	{ "stamp", ED_T_U32, F_STAMP, 0 },
	{ "rng", ED_T_U64, F_RNG, 0 },
	{ "t", ED_T_F64, F_SCALAR, offsetof(struct dsmc, t) },
	{ "steps", ED_T_U64, F_SCALAR, offsetof(struct dsmc, steps) },
	{ "collisions", ED_T_U64, F_SCALAR, offsetof(struct dsmc, collisions) },
	{ "candidates", ED_T_U64, F_SCALAR, offsetof(struct dsmc, candidates) },
	{ "vmax_raised", ED_T_U64, F_SCALAR, offsetof(struct dsmc, vmax_raised) },
	{ "cell_collisions", ED_T_U64, F_SCALAR, offsetof(struct dsmc, cell_collisions) },
	{ "rejected", ED_T_U64, F_SCALAR, offsetof(struct dsmc, rejected) },
	{ "ekin_est", ED_T_F64, F_SCALAR, offsetof(struct dsmc, ekin_est) },
	{ "e_loss", ED_T_F64, F_SCALAR, offsetof(struct dsmc, e_loss) },
	{ "t_sample", ED_T_F64, F_SCALAR, offsetof(struct dsmc, t_sample) },
	{ "ekin_int", ED_T_F64, F_SCALAR, offsetof(struct dsmc, ekin_int) },
	{ "virial", ED_T_F64, F_SCALAR, offsetof(struct dsmc, virial) },
	{ "coll_sample", ED_T_U64, F_SCALAR, offsetof(struct dsmc, coll_sample) },
	/* scenes with walls only (as stamp for hsmc: field counts depend on the scene) */
	{ "wall_collisions", ED_T_U64, F_WALL, offsetof(struct dsmc, wall_collisions) },
	{ "wall_rested", ED_T_U64, F_WALL, offsetof(struct dsmc, rested) },
	{ "wall_hits", ED_T_U64, F_WHITS, 0 },
	{ "wall_impulse", ED_T_F64, F_WIMP, 0 },
	/* scenes with open walls only */
	{ "present", ED_T_U64, F_PRESENT, 0 },
	{ "wall_outflow", ED_T_U64, F_WOUT, 0 },
	/* scenes with obstacles only */
	{ "obstacle_collisions", ED_T_U64, F_OBST, offsetof(struct dsmc, obst_collisions) },
	{ "obstacle_impulse", ED_T_F64, F_OIMP, 0 },
	/* scenes with a source only: insertions due so far, skipped ones (present: above) */
	{ "source", ED_T_U64, F_SRC, 0 },
	/* scene_msd_images() only: periodic image counts, by particle id */
	{ "images", ED_T_I32, F_IMG, 0 },
};
#define N_DFIELDS (sizeof dfields / sizeof dfields[0])

static size_t dfield_count(const struct dsmc *d, const dfield_t *f)
{
	switch (f->kind) {
	case F_PART: return (size_t)d->n * 2 * (size_t)d->dim;
	case F_ID: return d->n;
	case F_START: return d->ncells + 1;
	case F_REM: return d->ncells;
	case F_STAMP: return d->hsmc ? d->ncells : 0;
	case F_RNG: return 4;
	case F_WALL: return d->has_walls ? 1 : 0;
	case F_WHITS: return d->has_walls ? 6 : 0;
	case F_WIMP: return d->has_walls ? 18 : 0;
	case F_PRESENT: return d->open || d->src ? 1 : 0;
	case F_SRC: return d->src ? 2 : 0;
	case F_WOUT: return d->open ? 6 : 0;
	case F_OBST: return d->nobst ? 1 : 0;
	case F_OIMP: return 3 * (size_t)d->nobst;
	case F_IMG: return d->img ? (size_t)d->n * (size_t)d->dim : 0;
	default: return 1;
	}
}

/* Fields a scene's engine has (stamp: hsmc; wall state: scenes with walls). */
static int dfield_present(const struct dsmc *d, const dfield_t *f)
{
	return f->kind == F_IMG ? d->img != NULL : f->kind == F_STAMP ? d->hsmc : f->kind == F_SRC ? d->src
	       : f->kind >= F_OBST ? d->nobst > 0
	       : f->kind == F_PRESENT ? d->open || d->src : f->kind >= F_PRESENT ? d->open : f->kind >= F_WALL ? d->has_walls : 1;
}

static const dfield_t *dfield_find(const char *name)
{
	for (size_t k = 0; k < N_DFIELDS; k++)
		if (!strcmp(dfields[k].name, name))
			return &dfields[k];
	return NULL;
}

int dsmc_fields(const dsmc_t *d, ed_field_t *out, int max)
{
	int n = 0;
	for (size_t k = 0; k < N_DFIELDS; k++) {
		size_t count = dfield_count(d, &dfields[k]);
		if (!dfield_present(d, &dfields[k]))
			continue;
		if (n < max)
			out[n] = (ed_field_t){dfields[k].name, dfields[k].type, count};
		n++;
	}
	return n;
}

int dsmc_field_get(const dsmc_t *d, const char *name, void *buf)
{
	const dfield_t *f = dfield_find(name);
	if (!f || !dfield_present(d, f))
		return DSMC_EINVAL;
	size_t count = dfield_count(d, f);
	switch (f->kind) {
	case F_PART: memcpy(buf, d->p, count * sizeof(double)); break;
	case F_ID: memcpy(buf, d->id, count * sizeof(uint32_t)); break;
	case F_START: memcpy(buf, d->start, count * sizeof(uint32_t)); break;
	case F_STAMP: memcpy(buf, d->stamp, count * sizeof(uint32_t)); break;
	case F_RNG: memcpy(buf, d->rng.s, sizeof(d->rng.s)); break;
	case F_WHITS: memcpy(buf, d->wall_hits, sizeof d->wall_hits); break;
	case F_WIMP: memcpy(buf, d->wall_impulse, sizeof d->wall_impulse); break;
	case F_PRESENT: *(uint64_t *)buf = d->na; break;
	case F_WOUT: memcpy(buf, d->wout, sizeof d->wout); break;
	case F_OIMP: memcpy(buf, d->obst_impulse, count * sizeof(double)); break;
	case F_SRC: ((uint64_t *)buf)[0] = d->src_k, ((uint64_t *)buf)[1] = d->src_rej; break;
	case F_IMG: memcpy(buf, d->img, count * sizeof(int32_t)); break;
	case F_REM:
		for (size_t c = 0; c < count; c++)
			((double *)buf)[c] = d->rem[c];   /* float -> double -> float is exact */
		break;
	default: memcpy(buf, (const char *)d + f->off, 8); break;
	}
	return DSMC_OK;
}

int dsmc_field_set(dsmc_t *d, const char *name, ed_type_t type, size_t count, const void *buf)
{
	const dfield_t *f = dfield_find(name);
	if (!f || !dfield_present(d, f) || type != f->type || count != dfield_count(d, f))
		return DSMC_EINVAL;
	switch (f->kind) {
	case F_PART: memcpy(d->p, buf, count * sizeof(double)); break;
	case F_ID: memcpy(d->id, buf, count * sizeof(uint32_t)); break;
	case F_START: memcpy(d->start, buf, count * sizeof(uint32_t)); break;
	case F_STAMP: memcpy(d->stamp, buf, count * sizeof(uint32_t)); break;
	case F_RNG: memcpy(d->rng.s, buf, sizeof(d->rng.s)); break;
	case F_WHITS: memcpy(d->wall_hits, buf, sizeof d->wall_hits); break;
	case F_WIMP: memcpy(d->wall_impulse, buf, sizeof d->wall_impulse); break;
	case F_PRESENT:
		if (*(const uint64_t *)buf > d->n)
			return DSMC_EINVAL;
		d->na = (uint32_t)*(const uint64_t *)buf;
		break;
	case F_WOUT: memcpy(d->wout, buf, sizeof d->wout); break;
	case F_OIMP: memcpy(d->obst_impulse, buf, count * sizeof(double)); break;
	case F_SRC: d->src_k = ((const uint64_t *)buf)[0], d->src_rej = ((const uint64_t *)buf)[1]; break;
	case F_IMG: memcpy(d->img, buf, count * sizeof(int32_t)); break;
	case F_REM:
		for (size_t c = 0; c < count; c++) {
			double r = ((const double *)buf)[c];
			if (!(r >= 0 && r < 1e30) || (double)(float)r != r)
				return DSMC_EINVAL;
			d->rem[c] = (float)r;
		}
		break;
	default: memcpy((char *)d + f->off, buf, 8); break;
	}
	return DSMC_OK;
}

int dsmc_restore_finish(dsmc_t *d, char *msg, size_t msglen)
{
	const int D = d->dim, S = 2 * D;
	const char *why = NULL;
	if (d->start[0] != 0 || d->start[d->ncells] != d->na || d->na > d->n || (!d->open && !d->src && d->na != d->n) ||
	    (d->src && (d->src_k > d->src_total || d->src_rej > d->src_k || d->na > d->n0 + d->src_k - d->src_rej)))
		why = "cell offsets do not cover the particles present";
	for (size_t c = 0; !why && c < d->ncells; c++)
		if (d->start[c + 1] < d->start[c])
			why = "cell offsets decrease";
	/* identities: a permutation (cell as scratch marks) */
	memset(d->cell, 0, d->n * sizeof(uint32_t));
	for (uint32_t k = 0; !why && k < d->n; k++) {
		if (d->id[k] >= d->n || d->cell[d->id[k]])
			why = "particle identities are not a permutation";
		else
			d->cell[d->id[k]] = 1;
	}
	for (uint32_t k = 0; !why && k < d->n; k++)
		for (int a = 0; a < D; a++) {
			double x = d->p[(size_t)k * S + a], v = d->p[(size_t)k * S + D + a];
			if (!(x >= 0 && x < d->L[a]) || !isfinite(v)) {
				why = "a position outside the box or a non-finite velocity";
				break;
			}
		}
	if (!why && !(d->rng.s[0] | d->rng.s[1] | d->rng.s[2] | d->rng.s[3]))
		why = "random-number state is zero";
	if (!why && (!isfinite(d->t) || !isfinite(d->ekin_est) || !isfinite(d->t_sample) || !isfinite(d->ekin_int) ||
	             !isfinite(d->virial) || d->t_sample > d->t || d->coll_sample > d->collisions))
		why = "clock or accumulators out of range";
	if (why) {
		if (msg && msglen)
			snprintf(msg, msglen, "%s", why);
		return DSMC_EINVAL;
	}
	return DSMC_OK;
}

double dsmc_time(const dsmc_t *d) { return d->t; }
uint64_t dsmc_collisions(const dsmc_t *d) { return d->collisions; }
uint64_t dsmc_moves(const dsmc_t *d) { return d->steps * d->n; }

void dsmc_cells(const dsmc_t *d, int cells[3])
{
	for (int a = 0; a < 3; a++)
		cells[a] = a < d->dim ? d->nc[a] : 1;
}

void dsmc_count_impacts(dsmc_t *d, double *counts, int nb)
{
	d->bcount = nb > 0 ? counts : NULL;
	d->bnb = nb;
}

void dsmc_geometry(const dsmc_t *d, dsmc_geom_t *out)
{
	memset(out, 0, sizeof *out);
	out->dim = d->dim;
	out->hsmc = d->hsmc;
	out->cba = d->cba;
	out->local_chi = d->local_chi;
	out->mix = d->mix;
	out->bounded = d->bounded || d->has_walls || d->nobst > 0 || d->open;
	out->impact = d->pb_n;
	out->n = d->n;
	out->nfull = d->nfull;
	for (int a = 0; a < 3; a++) {
		out->L[a] = d->L[a];
		out->nc[a] = d->nc[a];
	}
	out->sigma = d->sigma;
	out->mass = d->mass;
	out->e = d->e;
	out->chi = d->chi;
	out->sigma_t = d->sigma_t;
	out->vcell = d->vcell;
	out->fcoef = d->fcoef;
	out->cps = d->cps;
	out->dt_fixed = d->dt_fixed;
}

int dsmc_geometry_scene(const scene_t *s, dsmc_geom_t *out, char *msg, size_t msglen)
{
	struct dsmc d;
	memset(&d, 0, sizeof(d));
	if (msg && msglen)
		msg[0] = '\0';
	int rc = layout(&d, s, msg, msglen);
	if (rc == DSMC_OK)
		dsmc_geometry(&d, out);
	return rc;
}

void dsmc_count_pairs(dsmc_t *d, double *counts)
{
	d->pcount = d->mix ? counts : NULL;
}

size_t dsmc_memory(const dsmc_t *d)
{
	size_t S = 2 * (size_t)d->dim;
	return sizeof(*d) + d->n * S * sizeof(double) + 2 * d->n * sizeof(uint32_t) +
	       (size_t)d->ring_n * (S * sizeof(double) + sizeof(uint32_t)) +
	       (size_t)d->over_n * (S * sizeof(double) + 2 * sizeof(uint32_t)) +
	       d->ncells * (2 * sizeof(uint32_t) + sizeof(float) + (d->hsmc ? sizeof(uint32_t) : 0) +
	                    (d->local_chi ? 2 * sizeof(float) : 0) + (d->nobst ? sizeof(float) : 0)) +
	       (d->mix ? d->n * (1 + sizeof(double)) + (d->hsmc ? (d->ncells + 1) * sizeof(double) : 0) : 0);
}

int dsmc_plan(const scene_t *s, dsmc_plan_t *out, char *msg, size_t msglen)
{
	struct dsmc d;
	memset(&d, 0, sizeof(d));
	if (msg && msglen)
		msg[0] = '\0';
	int rc = layout(&d, s, msg, msglen);
	if (rc != DSMC_OK || !out)
		return rc;
	ring_size(&d);
	out->memory = dsmc_memory(&d);
	out->state = out->largest = 0;
	for (size_t k = 0; k < N_DFIELDS; k++) {
		uint64_t bytes = dfield_count(&d, &dfields[k]) * ed_type_size(dfields[k].type);
		out->state += bytes;
		if (bytes > out->largest)
			out->largest = bytes;
	}
	out->cells = d.ncells;
	return DSMC_OK;
}

const char *dsmc_strerror(int code)
{
	switch (code) {
	case DSMC_OK: return "success";
	case DSMC_ENOMEM: return "out of memory";
	case DSMC_EINVAL: return "scene not usable by dsmc/hsmc";
	default: return "unknown error";
	}
}
