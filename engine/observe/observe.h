/* Structure observables of a run: the scalars sampled with each progress record and the curves (histograms, g(r), S(k), n_s, correlations) sampled at snapshot times. */
#pragma once

#include <stddef.h>
#include <stdint.h>
#include "observe/clusters.h"
#include "scene.h"

/*
 * Contract
 * - obs_create() allocates everything for the scene's observables
 *   (velocity_distribution, pair_correlation, structure_factor,
 *   velocity_correlations, the cluster-size distribution of clusters and
 *   impact_parameter);
 *   sampling allocates nothing. No I/O, no globals (FFTW keeps its own
 *   planner state; plans are made once, FFTW_ESTIMATE, deterministic).
 * - The curves are described by a fixed list of tables (obs_curves_t): one
 *   x axis (bin edges and centres, fixed by the scene) and one to
 *   OBS_MAX_COLS value columns each. Writers (H5MD, JSON lines) and ensembles use the
 *   description and need no knowledge of the families.
 *   fields are a grid of cells (obs_table_t.shape), one table per quantity.
 * - Every method (ed, dsmc, hsmc): the input is the particle state only.
 *   For dsmc/hsmc, whose particles are points, g(r) has no excluded volume
 *   (see docs/output.md for what each contact value means there).
 */

/* Scalars of a progress record (NaN where not asked for or undefined). */
typedef struct {
	double a2, a3;            /* velocity_distribution: Sonine coefficients */
	double g_pairs, g_pairs_se; /* pair_correlation: contact value from the pair histogram, its fit error */
	double g_rate;            /* ... from the collision rate over the interval (Enskog) */
	double g_pressure;        /* ... from the pressure (collision virial) over the interval */
	double msd, msd_se;       /* mean_square_displacement: since the run's start (length^2), its se over particles */
	double diffusion;         /* ... (MSD(t) - MSD(t_prev)) / (2 D (t - t_prev)) over the output interval; with
	                           * walls over the periodic axes only (their MSD, D their number) */
	double msd_walled;        /* ... with walls: the part of msd along the walled axes (NaN without walls) */
	double msd_count;         /* ... varying particle sets (open, reservoir, dispenser walls, a source): the
	                           * particles msd is over, those present at the origin and since (NaN otherwise) */
	double flux, flux_se;     /* flux: sum_i v_i . g_hat / volume now (g_hat: gravity's direction, else the last
	                           * axis), its standard error sqrt(N var(v . g_hat)) / volume over particles */
} obs_scalars_t;

#define OBS_MAX_COLS 10
/* Mixtures of 2 ... OBS_GOFR_SPECIES_MAX species (one radius each, periodic box: the scene parser's rule)
 * with pair_correlation get two more tables: "pair_correlation"/"species", g_ab(r) over the same r bins as
 * g(r) in columns "g_ab" (a <= b species indices in scene order: g_00, g_01, g_11, ...), and
 * "pair_correlation"/"contact", x = "pair" (the pair class index, gofr.h), columns "g" (g_ab at contact
 * sigma_ab = R_a + R_b from the pair histogram, gofr_contact_species()), "g_se" (its fit error) and
 * "sigma" (sigma_ab). The one-radius scalars g_contact_* are NaN for mixtures. */
#define OBS_GOFR_SPECIES_MAX SCENE_GOFR_SPECIES_MAX
#define OBS_MAX_TABLES 16

typedef struct {
	const char *family;       /* observable name (output.observables; "clusters" for n_s) */
	const char *table;        /* "" or the sub-table name ("components", "speed", "pairs", "modes") */
	const char *x;            /* name of the x quantity: "c", "r", "k", "s" */
	const char *x_unit;       /* H5MD-style unit string of x ("1", "l0", "l0-1") */
	int nb;                   /* bins */
	const double *edges;      /* nb + 1 */
	const double *centres;    /* nb */
	int ncols;
	const char *col[OBS_MAX_COLS];   /* column names, e.g. "g", "p_x" */
	double *val[OBS_MAX_COLS];       /* nb each: the sample (ensembles: the mean) */
	double *se[OBS_MAX_COLS];        /* nb each: ensembles only (standard error), else unused */
	int shape[3];             /* fields: cells per axis (x is the flat cell index, x fastest); else 0 */
} obs_table_t;

typedef struct {
	int ntables;
	obs_table_t t[OBS_MAX_TABLES];
	/* scalars of the sample */
	double temperature;       /* of the peculiar velocities */
	double a2, a3;            /* when velocity_distribution is asked */
	double a2_spin;           /* ... for rough particles: a2 of the angular velocities (NaN otherwise) */
	double temperature_rot;   /* ... for rough particles: I <(w - <w>)^2> / spin_dim (NaN otherwise) */
	double g_pairs;           /* when pair_correlation is asked */
	double cluster_w, cluster_exponent, m2_reduced, mean_size;   /* when clusters is asked */
	int fields_samples;       /* fields: instants averaged (observe/fields.h) */
	double impact_a, impact_c;  /* impact_parameter: P(b) / P_chaos(b) = a / (1 - c (b/sigma)^2), weighted fit */
	double dspec_alpha, dspec_alpha_se; /* density_spectrum: slope of log P(f) over the fit range, its se */
	int dspec_samples;        /* density_spectrum: samples behind the spectrum (NaN values below m) */
	/* ensembles: standard errors of the same scalars */
	double se_temperature, se_a2, se_a3, se_g_pairs, se_cluster_w, se_cluster_exponent, se_m2_reduced,
	       se_mean_size, se_impact_a, se_impact_c, se_a2_spin, se_temperature_rot;
} obs_curves_t;

typedef struct obs obs_t;

/* The observables of scene s that make curves (what obs_create() lays out). */
#define OBS_CURVE_BITS (SCENE_OBS_VDIST | SCENE_OBS_GOFR | SCENE_OBS_SOFK | SCENE_OBS_VCORR | SCENE_OBS_CLUSTERS | \
                        SCENE_OBS_IMPACT | SCENE_OBS_FIELDS | SCENE_OBS_DSPEC | SCENE_OBS_SURFACE)
unsigned obs_curve_bits(const scene_t *s);

/* Workspaces for scene s. layout_only: only the curve description (axes, zeroed values), no
 * sampling workspace (for writers that need the table list). NULL when out of memory. */
obs_t *obs_create(const scene_t *s, int layout_only);
void obs_destroy(obs_t *o);

/* Scalars of the present state (pos, vel: n*D, the n particles present, n <= scene_slots(); particles
 * that left through open walls or empty reservoir slots are not among the rows: obs_present()) into *out:
 * a2, a3, g_pairs. g_rate and g_pressure come from obs_interval(). 0, or -1 (a workspace missing). */
int obs_scalars(obs_t *o, size_t n, const double *pos, const double *vel, obs_scalars_t *out);
/* Contact values from interval quantities (collision rate 2C/(N dt), compressibility Z, time-averaged
 * temperature t_avg) into out->g_rate and out->g_pressure. */
void obs_interval(const obs_t *o, double rate, double z, double t_avg, obs_scalars_t *out);

/* Curves of the present state (n rows, as obs_scalars()); cl (may be NULL unless clusters are asked for) is the run's cluster
 * workspace, recomputed here; spin (rough particles: N * spin_dim angular velocities, else NULL) gives
 * velocity_distribution's table "spin" (c = (w - <w>) / sqrt(2 T_rot / I), I = q m a^2: columns p (2D) or
 * p_x, p_y, p_z (3D), NaN without spin) with a2_spin and temperature_rot. Returns the tables (owned by o, valid until the next call), or NULL
 * when out of memory in the cluster code. */
const obs_curves_t *obs_curves(obs_t *o, clusters_t *cl, size_t n, const double *pos, const double *vel,
                               const double *spin);

/* Rows present: moves the rows whose position is finite (pos, and vel and spin where not NULL, with dim
 * and spin_dim doubles per row) to the front, in order, and returns their count. Engines write NaN rows
 * for particles that left through an open wall and for empty reservoir slots. */
size_t obs_present(size_t rows, int dim, double *pos, double *vel, double *spin, int spin_dim);

/* impact_parameter: the histogram (nb doubles, owned by o) that the engine fills
 * (ed_count_impacts(), dsmc_count_impacts()); obs_curves() turns it into the
 * table "impact_parameter" (columns p: density in b / sigma, n: counts) and
 * zeroes it. NULL and *nb = 0 when not asked for or layout_only. */
double *obs_impact_counts(const obs_t *o, int *nb);

/* fields (output.fields): the accumulator (observe/fields.h; NULL when not asked for or layout_only).
 * obs_fields_add() adds one instant (spin: N * spin_dim angular velocities, or NULL for smooth
 * particles); obs_curves() turns the instants added since the previous curves into the tables "fields"
 * "density" (n: particles per unit area/volume, count: mean occupation), "velocity" (u_x, u_y(, u_z)),
 * "temperature" (T) and, for rough particles, "spin" (w in 2D; w_x, w_y, w_z in 3D), over x = "cell", and
 * starts a new exposure. */
struct fields;
struct fields *obs_fields(const obs_t *o);
void obs_fields_add(obs_t *o, const double *pos, const double *vel, const double *spin);

/* density_spectrum (output.density_spectrum): the sampler (observe/dspec.h; NULL when not asked for or
 * layout_only). obs_dspec_add() adds one sample of the slice counts (pos: n*D, the rows present); obs_curves()
 * turns the last m samples into the table "density_spectrum" (x = "f", column P) with dspec_alpha,
 * dspec_alpha_se and dspec_samples. */
struct dspec;
struct dspec *obs_dspec(const obs_t *o);
void obs_dspec_add(obs_t *o, size_t n, const double *pos);

/* The table description without sampling (layout_only objects too). */
const obs_curves_t *obs_layout(const obs_t *o);
/* Doubles in one packed sample (obs_pack): every column of every table plus the scalars. */
size_t obs_packed_size(const obs_t *o);
/* Pack c into v[obs_packed_size()]; obs_combine() turns R packed samples (replica-major) into means
 * and standard errors (sample standard deviation / sqrt(R)) in o's tables, in replica order. */
void obs_pack(const obs_t *o, const obs_curves_t *c, double *v);
const obs_curves_t *obs_combine(obs_t *o, const double *v, int R);

/* Bytes of the workspaces. */
size_t obs_memory(const obs_t *o);
