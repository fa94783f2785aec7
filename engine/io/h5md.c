/* H5MD 1.1 trajectory writer: snapshots, observables and parameters of a run in one HDF5 file, plus an XDMF sidecar. */
#include <errno.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "config.h"
#include "h5md.h"
#include "h5util.h"

/* Particles per chunk of a frame: ~1.5 MB chunks in 3D, larger than the
 * default chunk cache, so frames go straight to disk. */
#define FRAME_CHUNK 65536u
/* Rows per chunk of an observable time series. */
#define OBS_CHUNK 256u
#define MAX_OBS 48
/* fields: fields_samples, fields_count, fields_density, fields_velocity, fields_temperature, fields_spin */
#define FLD_MAX 6
static const char *const fld_names[FLD_MAX] = {"fields_samples", "fields_count", "fields_density", "fields_velocity",
                                               "fields_temperature", "fields_spin"};
/* density_spectrum: samples (int), power [rows][K], alpha, alpha_se; one row per spectrum (snapshot times) */
#define DSP_MAX 4
static const char *const dsp_names[DSP_MAX] = {"density_spectrum_samples", "density_spectrum_power",
                                               "density_spectrum_alpha", "density_spectrum_alpha_se"};

/* What a value column holds: cols 0 = scalar per row, -1 = D components,
 * -2 = D components per obstacle (obstacle k's at k D .. k D + D - 1),
 * -3 = one per species (mixtures). */
typedef struct {
	const char *path;       /* under /observables */
	uint64_t need;          /* SCENE_OBS_* bit (32 bits) and NEED_* flags (above them); 0 = always */
	int i64;                /* integer series */
	int cols;
	const char *unit;       /* NULL: dimensionless count, no unit attribute */
	void (*get)(const run_record_t *r, void *out);
} obs_def_t;

/* flags above the 32 bits of the SCENE_OBS_* values (scene_t.observables is an unsigned) */
#define NEED_TC (1ull << 32)     /* only with the TC model */
#define NEED_SE (1ull << 33)     /* flag: only in ensembles (standard error of the mean over the replicas) */
#define NEED_MIX (1ull << 34)    /* flag: only for mixtures (two or more particles.species) */
#define NEED_RES (1ull << 35)    /* flag: only with a reservoir wall */
#define NEED_WALLED (1ull << 36) /* flag: only single runs with a walled axis */
#define NEED_VARY (1ull << 37)   /* flag: only single runs with a varying particle set (scene_has_open_walls()) */
#define NEED_FLAGS (NEED_SE | NEED_MIX | NEED_RES | NEED_WALLED | NEED_VARY)

static void g_coll(const run_record_t *r, void *o) { *(int64_t *)o = (int64_t)r->collisions; }
static void g_ekin(const run_record_t *r, void *o) { *(double *)o = r->kinetic_energy / (double)r->n; }
static void g_temp(const run_record_t *r, void *o) { *(double *)o = r->temperature; }
static void g_temp_sp(const run_record_t *r, void *o) { memcpy(o, r->temperature_species, r->n_species * sizeof(double)); }
static void g_pres(const run_record_t *r, void *o) { *(double *)o = r->have_interval ? r->pressure : NAN; }
static void g_comp(const run_record_t *r, void *o) { *(double *)o = r->have_interval ? r->compressibility : NAN; }
static void g_rate(const run_record_t *r, void *o) { *(double *)o = r->have_interval ? r->collision_rate : NAN; }
static void g_mom(const run_record_t *r, void *o) { memcpy(o, r->momentum, r->dim * sizeof(double)); }
static void g_wcoll(const run_record_t *r, void *o) { *(int64_t *)o = (int64_t)r->wall_collisions; }
/* per wall w = 2 axis + end; NaN where the scene has no such wall */
static void g_wpres(const run_record_t *r, void *o)
{
	for (int w = 0; w < 6; w++)
		((double *)o)[w] = r->have_interval && (r->walls & (1u << w)) ? r->wall_pressure[w] : NAN;
}
static void g_present(const run_record_t *r, void *o) { *(int64_t *)o = (int64_t)r->particles; }
static void g_wout(const run_record_t *r, void *o)
{
	for (int w = 0; w < 6; w++)
		((int64_t *)o)[w] = (int64_t)r->wall_outflow[w];
}
static void g_win(const run_record_t *r, void *o)
{
	for (int w = 0; w < 6; w++)
		((int64_t *)o)[w] = (int64_t)r->wall_inflow[w];
}
static void g_wrej(const run_record_t *r, void *o)
{
	for (int w = 0; w < 6; w++)
		((int64_t *)o)[w] = (int64_t)r->wall_rejected[w];
}
static void g_ocoll(const run_record_t *r, void *o) { *(int64_t *)o = (int64_t)r->obstacle_collisions; }
static void g_oforce(const run_record_t *r, void *o)
{
	for (int k = 0; k < r->n_obstacles; k++)
		for (int a = 0; a < r->dim; a++)
			((double *)o)[k * r->dim + a] = r->have_interval ? r->obstacle_force[k][a] : NAN;
}
static void g_com(const run_record_t *r, void *o) { *(double *)o = r->com_height; }
static void g_epot(const run_record_t *r, void *o) { *(double *)o = r->potential_energy / (double)r->n; }
static void g_erot(const run_record_t *r, void *o) { *(double *)o = r->rotational_energy / (double)r->n; }
static void g_trot(const run_record_t *r, void *o) { *(double *)o = r->rotational_temperature; }
static void g_tc(const run_record_t *r, void *o) { *(int64_t *)o = (int64_t)r->elastic_by_tc; }
static void g_ccount(const run_record_t *r, void *o) { *(int64_t *)o = (int64_t)r->clusters.n_clusters; }
static void g_clargest(const run_record_t *r, void *o) { *(int64_t *)o = (int64_t)r->clusters.largest; }
static void g_cfrac(const run_record_t *r, void *o) { *(double *)o = r->clusters.largest_fraction; }
static void g_cmean(const run_record_t *r, void *o) { *(double *)o = r->clusters.mean_size; }
static void g_cm2(const run_record_t *r, void *o) { *(double *)o = r->clusters.m2; }
static void g_cm2r(const run_record_t *r, void *o) { *(double *)o = r->clusters.m2_reduced; }
/* Standard errors of ensemble means (NaN where the mean is). */
static void g_time_se(const run_record_t *r, void *o) { *(double *)o = r->se.time; }
static void g_ekin_se(const run_record_t *r, void *o) { *(double *)o = r->se.kinetic_energy / (double)r->n; }
static void g_temp_se(const run_record_t *r, void *o) { *(double *)o = r->se.temperature; }
static void g_temp_sp_se(const run_record_t *r, void *o)
{
	memcpy(o, r->se.temperature_species, r->n_species * sizeof(double));
}
static void g_pres_se(const run_record_t *r, void *o) { *(double *)o = r->have_interval ? r->se.pressure : NAN; }
static void g_comp_se(const run_record_t *r, void *o) { *(double *)o = r->have_interval ? r->se.compressibility : NAN; }
static void g_rate_se(const run_record_t *r, void *o) { *(double *)o = r->have_interval ? r->se.collision_rate : NAN; }
static void g_cfrac_se(const run_record_t *r, void *o) { *(double *)o = r->se.largest_fraction; }
static void g_cmean_se(const run_record_t *r, void *o) { *(double *)o = r->se.mean_size; }
/* structure observables (observe.h): NaN where undefined (no interval yet, no contact fit) */
static void g_a2(const run_record_t *r, void *o) { *(double *)o = r->obs.a2; }
static void g_a3(const run_record_t *r, void *o) { *(double *)o = r->obs.a3; }
static void g_gpairs(const run_record_t *r, void *o) { *(double *)o = r->obs.g_pairs; }
static void g_grate(const run_record_t *r, void *o) { *(double *)o = r->have_interval ? r->obs.g_rate : NAN; }
static void g_gpres(const run_record_t *r, void *o) { *(double *)o = r->have_interval ? r->obs.g_pressure : NAN; }
static void g_msd(const run_record_t *r, void *o) { *(double *)o = r->obs.msd; }
static void g_msd_walled(const run_record_t *r, void *o) { *(double *)o = r->obs.msd_walled; }
static void g_msd_count(const run_record_t *r, void *o) { *(double *)o = r->obs.msd_count; }
static void g_wpres_se(const run_record_t *r, void *o)
{
	for (int w = 0; w < 6; w++)
		((double *)o)[w] = r->have_interval && (r->walls & (1u << w)) ? r->se.wall_pressure[w] : NAN;
}
static void g_oforce_se(const run_record_t *r, void *o)
{
	for (int k = 0; k < r->n_obstacles; k++)
		for (int a = 0; a < r->dim; a++)
			((double *)o)[k * r->dim + a] = r->have_interval ? r->se.obstacle_force[k][a] : NAN;
}
static void g_com_se(const run_record_t *r, void *o) { *(double *)o = r->se.com_height; }
static void g_epot_se(const run_record_t *r, void *o) { *(double *)o = r->se.potential_energy / (double)r->n; }
static void g_erot_se(const run_record_t *r, void *o) { *(double *)o = r->se.rotational_energy / (double)r->n; }
static void g_trot_se(const run_record_t *r, void *o) { *(double *)o = r->se.rotational_temperature; }
static void g_flux(const run_record_t *r, void *o) { *(double *)o = r->obs.flux; }
static void g_flux_err(const run_record_t *r, void *o) { *(double *)o = r->obs.flux_se; }
static void g_diff(const run_record_t *r, void *o) { *(double *)o = r->obs.diffusion; }
static void g_msd_se(const run_record_t *r, void *o) { *(double *)o = r->se.msd; }
static void g_diff_se(const run_record_t *r, void *o) { *(double *)o = r->se.diffusion; }
static void g_a2_se(const run_record_t *r, void *o) { *(double *)o = r->se.a2; }
static void g_a3_se(const run_record_t *r, void *o) { *(double *)o = r->se.a3; }
static void g_gpairs_se(const run_record_t *r, void *o) { *(double *)o = r->se.g_pairs; }
static void g_grate_se(const run_record_t *r, void *o) { *(double *)o = r->have_interval ? r->se.g_rate : NAN; }
static void g_gpres_se(const run_record_t *r, void *o) { *(double *)o = r->have_interval ? r->se.g_pressure : NAN; }
static void g_chist(const run_record_t *r, void *o)
{
	int64_t *h = o;
	for (int k = 0; k < CLUSTERS_MAX_BINS; k++)
		h[k] = k < r->clusters.n_bins ? (int64_t)r->clusters.hist[k] : 0;
}

/* The first entry owns the shared step and time datasets. */
static const obs_def_t obs_defs[] = {
	{ "collision_count", 0, 1, 0, NULL, g_coll },
	{ "kinetic_energy", SCENE_OBS_ENERGY, 0, 0, "e0", g_ekin },
	{ "temperature", SCENE_OBS_ENERGY, 0, 0, "e0", g_temp },
	{ "temperature_species", SCENE_OBS_ENERGY | NEED_MIX, 0, -3, "e0", g_temp_sp },
	{ "pressure", SCENE_OBS_PRESSURE, 0, 0, "pressure", g_pres },
	{ "compressibility", SCENE_OBS_PRESSURE, 0, 0, "1", g_comp },
	{ "collision_rate", SCENE_OBS_COLLISION_RATE, 0, 0, "t0-1", g_rate },
	{ "momentum", SCENE_OBS_MOMENTUM, 0, -1, "m0 l0 t0-1", g_mom },
	{ "elastic_by_tc", NEED_TC, 1, 0, NULL, g_tc },
	{ "wall_collisions", SCENE_OBS_WALL_FORCE, 1, 0, NULL, g_wcoll },
	{ "wall_pressure", SCENE_OBS_WALL_FORCE, 0, 6, "pressure", g_wpres },
	{ "particles_present", SCENE_OBS_OUTFLOW, 1, 0, NULL, g_present },
	{ "wall_outflow", SCENE_OBS_OUTFLOW, 1, 6, NULL, g_wout },
	{ "wall_inflow", SCENE_OBS_OUTFLOW | NEED_RES, 1, 6, NULL, g_win },
	{ "wall_rejected", SCENE_OBS_OUTFLOW | NEED_RES, 1, 6, NULL, g_wrej },
	{ "obstacle_collisions", SCENE_OBS_OBSTACLE_FORCE, 1, 0, NULL, g_ocoll },
	{ "obstacle_force", SCENE_OBS_OBSTACLE_FORCE, 0, -2, "m0 l0 t0-2", g_oforce },
	{ "center_of_mass_height", SCENE_OBS_COM_HEIGHT, 0, 0, "l0", g_com },
	{ "potential_energy", SCENE_OBS_POTENTIAL, 0, 0, "e0", g_epot },
	{ "rotational_energy", SCENE_OBS_ROTATION, 0, 0, "e0", g_erot },
	{ "rotational_temperature", SCENE_OBS_ROTATION, 0, 0, "e0", g_trot },
	{ "clusters_count", SCENE_OBS_CLUSTERS, 1, 0, NULL, g_ccount },
	{ "clusters_largest", SCENE_OBS_CLUSTERS, 1, 0, NULL, g_clargest },
	{ "clusters_largest_fraction", SCENE_OBS_CLUSTERS, 0, 0, "1", g_cfrac },
	{ "clusters_mean_size", SCENE_OBS_CLUSTERS, 0, 0, "1", g_cmean },
	{ "clusters_m2", SCENE_OBS_CLUSTERS, 0, 0, "1", g_cm2 },
	{ "clusters_m2_reduced", SCENE_OBS_CLUSTERS, 0, 0, "1", g_cm2r },
	{ "clusters_histogram", SCENE_OBS_CLUSTERS, 1, CLUSTERS_MAX_BINS, NULL, g_chist },
	{ "sonine_a2", SCENE_OBS_VDIST, 0, 0, "1", g_a2 },
	{ "sonine_a3", SCENE_OBS_VDIST, 0, 0, "1", g_a3 },
	{ "g_contact_pairs", SCENE_OBS_GOFR, 0, 0, "1", g_gpairs },
	{ "g_contact_rate", SCENE_OBS_GOFR, 0, 0, "1", g_grate },
	{ "g_contact_pressure", SCENE_OBS_GOFR, 0, 0, "1", g_gpres },
	{ "mean_square_displacement", SCENE_OBS_MSD, 0, 0, "l0+2", g_msd },
	{ "diffusion_coefficient", SCENE_OBS_MSD, 0, 0, "l0+2 t0-1", g_diff },
	{ "mean_square_displacement_walled", NEED_WALLED | SCENE_OBS_MSD, 0, 0, "l0+2", g_msd_walled },
	{ "mean_square_displacement_count", NEED_VARY | SCENE_OBS_MSD, 0, 0, "1", g_msd_count },
	{ "flux", SCENE_OBS_FLUX, 0, 0, "flux", g_flux },
	{ "flux_error", SCENE_OBS_FLUX, 0, 0, "flux", g_flux_err },
	/* ensembles: NAME_se beside NAME, as KEY_se in the progress stream */
	{ "time_se", NEED_SE, 0, 0, "t0", g_time_se },
	{ "kinetic_energy_se", NEED_SE | SCENE_OBS_ENERGY, 0, 0, "e0", g_ekin_se },
	{ "temperature_se", NEED_SE | SCENE_OBS_ENERGY, 0, 0, "e0", g_temp_se },
	{ "temperature_species_se", NEED_SE | SCENE_OBS_ENERGY | NEED_MIX, 0, -3, "e0", g_temp_sp_se },
	{ "pressure_se", NEED_SE | SCENE_OBS_PRESSURE, 0, 0, "pressure", g_pres_se },
	{ "compressibility_se", NEED_SE | SCENE_OBS_PRESSURE, 0, 0, "1", g_comp_se },
	{ "collision_rate_se", NEED_SE | SCENE_OBS_COLLISION_RATE, 0, 0, "t0-1", g_rate_se },
	{ "clusters_largest_fraction_se", NEED_SE | SCENE_OBS_CLUSTERS, 0, 0, "1", g_cfrac_se },
	{ "clusters_mean_size_se", NEED_SE | SCENE_OBS_CLUSTERS, 0, 0, "1", g_cmean_se },
	{ "sonine_a2_se", NEED_SE | SCENE_OBS_VDIST, 0, 0, "1", g_a2_se },
	{ "sonine_a3_se", NEED_SE | SCENE_OBS_VDIST, 0, 0, "1", g_a3_se },
	{ "g_contact_pairs_se", NEED_SE | SCENE_OBS_GOFR, 0, 0, "1", g_gpairs_se },
	{ "g_contact_rate_se", NEED_SE | SCENE_OBS_GOFR, 0, 0, "1", g_grate_se },
	{ "wall_pressure_se", NEED_SE | SCENE_OBS_WALL_FORCE, 0, 6, "pressure", g_wpres_se },
	{ "obstacle_force_se", NEED_SE | SCENE_OBS_OBSTACLE_FORCE, 0, -2, "m0 l0 t0-2", g_oforce_se },
	{ "center_of_mass_height_se", NEED_SE | SCENE_OBS_COM_HEIGHT, 0, 0, "l0", g_com_se },
	{ "potential_energy_se", NEED_SE | SCENE_OBS_POTENTIAL, 0, 0, "e0", g_epot_se },
	{ "rotational_energy_se", NEED_SE | SCENE_OBS_ROTATION, 0, 0, "e0", g_erot_se },
	{ "rotational_temperature_se", NEED_SE | SCENE_OBS_ROTATION, 0, 0, "e0", g_trot_se },
	{ "g_contact_pressure_se", NEED_SE | SCENE_OBS_GOFR, 0, 0, "1", g_gpres_se },
	{ "mean_square_displacement_se", NEED_SE | SCENE_OBS_MSD, 0, 0, "l0+2", g_msd_se },
	{ "diffusion_coefficient_se", NEED_SE | SCENE_OBS_MSD, 0, 0, "l0+2 t0-1", g_diff_se },
};
#define N_OBS_DEFS (sizeof obs_defs / sizeof obs_defs[0])

/* One H5MD particles group: /particles/all (single runs) or
 * /particles/replica_K (ensembles with output.snapshots). */
typedef struct {
	hid_t pos_step, pos_time, pos_value, vel_value, box_value;
	hid_t spin_value;           /* rough particles (single runs): angular_velocity/value */
	hid_t id_value;             /* reservoir walls: id/value, each row's particle id (-1: empty slot) */
	uint64_t rows;
	double *frame_t;            /* times of the frames, for the XDMF */
	size_t frame_cap;
} pgroup_t;

struct h5md {
	hid_t file;
	char *path, *xdmf_path;
	const char *h5_name;        /* base name of path, as the XDMF refers to it */
	int dim, level;
	int spin_dim;               /* rough particles, single runs: 1 (2D) or 3 (3D); else 0 */
	int ids;                    /* reservoir walls: rows are slots, particles/all/id is written */
	uint64_t n;
	hid_t obs_step, obs_time;
	hid_t obs[MAX_OBS];
	int obs_def[MAX_OBS];
	int n_obs;
	double box[3];
	uint64_t obs_rows;
	int ensemble;               /* groups are replica_K, not all */
	int n_grp;
	pgroup_t *grp;
	int frames_pending;         /* frames appended since the last flush + XDMF */
	/* fields (output.fields): one row per sample of the fields (RUN_CURVES), own step and time */
	int n_fld;                  /* datasets in fld[] (0: no fields) */
	hid_t fld_step, fld_time, fld[FLD_MAX];
	uint64_t fld_rows, fld_cells;
	double *fld_buf;            /* fld_cells * 3 */
	/* density_spectrum: like the fields, one row per spectrum, own step and time */
	int dsp_on;
	hid_t dsp_step, dsp_time, dsp[DSP_MAX];
	uint64_t dsp_rows;
	int dsp_k;                  /* frequencies per row */
};

int h5md_groups(const scene_t *s)
{
	if (s->replicas <= 1)
		return 1;
	return s->snapshots.kind != SCENE_CLOCK_NONE ? (int)s->replicas : 0;
}

static void group_name(const h5md_t *h, int k, char *buf, size_t len)
{
	if (h->ensemble)
		snprintf(buf, len, "particles/replica_%d", k);
	else
		snprintf(buf, len, "particles/all");
}


static int def_wanted(const obs_def_t *d, const scene_t *s)
{
	uint64_t need = d->need & ~NEED_FLAGS;
	int walled = 0;
	for (int a = 0; a < s->dim; a++)
		walled |= s->boundary[a].walled;
	if ((d->need & NEED_WALLED) && (!walled || s->replicas > 1))
		return 0;
	if ((d->need & NEED_VARY) && (!scene_has_open_walls(s) || s->replicas > 1))
		return 0;
	if ((d->need & NEED_RES) && !scene_has_reservoir(s))
		return 0;
	if ((d->need & NEED_SE) && s->replicas <= 1)
		return 0;
	if ((d->need & NEED_MIX) && s->n_species < 2)
		return 0;
	if (need == 0)
		return 1;
	if (need == NEED_TC)
		return s->tc > 0.0;
	return (s->observables & need) != 0;
}

/* Chunked dataset with an unlimited first dimension: rank 1 + extra dims. */
static hid_t create_series(hid_t loc, const char *name, hid_t ftype, int rank, const hsize_t *inner,
                           const hsize_t *chunk, int level)
{
	hsize_t dims[3] = {0, 0, 0}, maxd[3] = {H5S_UNLIMITED, 0, 0};
	for (int k = 1; k < rank; k++)
		dims[k] = maxd[k] = inner[k - 1];
	hid_t d = H5I_INVALID_HID, sp = H5Screate_simple(rank, dims, maxd), dcpl = H5Pcreate(H5P_DATASET_CREATE);
	if (sp < 0 || dcpl < 0 || H5Pset_chunk(dcpl, rank, chunk) < 0)
		goto out;
	if (level > 0 && (H5Pset_shuffle(dcpl) < 0 || H5Pset_deflate(dcpl, (unsigned)level) < 0))
		goto out;
	if (H5Pset_fletcher32(dcpl) < 0)   /* last: it checksums the stored (compressed) chunk; see h5md_create() */
		goto out;
	d = H5Dcreate2(loc, name, ftype, sp, H5P_DEFAULT, dcpl, H5P_DEFAULT);
out:
	if (sp >= 0) H5Sclose(sp);
	if (dcpl >= 0) H5Pclose(dcpl);
	return d;
}

/* Write one row (row index `row`, inner elements as in the dataset) and
 * grow the dataset to row + 1 rows. */
static int append_row(hid_t d, hid_t mtype, uint64_t row, const void *buf)
{
	int ret = -1;
	hsize_t dims[3], start[3] = {row, 0, 0}, count[3];
	hid_t fs = H5Dget_space(d), ms = H5I_INVALID_HID;
	int rank = fs >= 0 ? H5Sget_simple_extent_ndims(fs) : -1;
	if (rank < 1 || rank > 3 || H5Sget_simple_extent_dims(fs, dims, NULL) < 0)
		goto out;
	H5Sclose(fs);
	fs = H5I_INVALID_HID;
	dims[0] = row + 1;
	if (H5Dset_extent(d, dims) < 0 || (fs = H5Dget_space(d)) < 0)
		goto out;
	count[0] = 1;
	for (int k = 1; k < rank; k++)
		count[k] = dims[k];
	if (H5Sselect_hyperslab(fs, H5S_SELECT_SET, start, NULL, count, NULL) < 0)
		goto out;
	ms = H5Screate_simple(rank, count, NULL);
	if (ms >= 0 && H5Dwrite(d, mtype, ms, fs, H5P_DEFAULT, buf) >= 0)
		ret = 0;
out:
	if (fs >= 0) H5Sclose(fs);
	if (ms >= 0) H5Sclose(ms);
	return ret;
}

static int64_t rows_of(hid_t d)
{
	hsize_t dims[3];
	hid_t fs = H5Dget_space(d);
	int rank = fs >= 0 ? H5Sget_simple_extent_ndims(fs) : -1;
	int64_t n = -1;
	if (rank >= 1 && rank <= 3 && H5Sget_simple_extent_dims(fs, dims, NULL) >= 0)
		n = (int64_t)dims[0];
	if (fs >= 0)
		H5Sclose(fs);
	return n;
}

static int truncate_rows(hid_t d, uint64_t rows)
{
	hsize_t dims[3];
	hid_t fs = H5Dget_space(d);
	int rank = fs >= 0 ? H5Sget_simple_extent_ndims(fs) : -1;
	int ret = -1;
	if (rank >= 1 && rank <= 3 && H5Sget_simple_extent_dims(fs, dims, NULL) >= 0) {
		dims[0] = rows;
		ret = H5Dset_extent(d, dims) < 0 ? -1 : 0;
	}
	if (fs >= 0)
		H5Sclose(fs);
	return ret;
}

static h5md_t *alloc_writer(const char *path, const scene_t *s)
{
	h5md_t *h = calloc(1, sizeof(*h));
	if (!h)
		return NULL;
	h->file = h->obs_step = h->obs_time = h->fld_step = h->fld_time = H5I_INVALID_HID;
	for (int k = 0; k < FLD_MAX; k++)
		h->fld[k] = H5I_INVALID_HID;
	h->dsp_step = h->dsp_time = H5I_INVALID_HID;
	for (int k = 0; k < DSP_MAX; k++)
		h->dsp[k] = H5I_INVALID_HID;
	if (s->observables & SCENE_OBS_DSPEC) {   /* ensembles: the mean over the replicas */
		h->dsp_on = 1;
		h->dsp_k = s->dspec_m / 2 - 1;
	}
	if (s->observables & SCENE_OBS_FIELDS) {   /* ensembles: the replicas combined (observe.h) */
		h->fld_cells = (uint64_t)s->fields_cells[0] * (uint64_t)s->fields_cells[1] * (uint64_t)s->fields_cells[2];
		h->n_fld = s->rough ? FLD_MAX : FLD_MAX - 1;
		h->fld_buf = malloc(h->fld_cells * 3 * sizeof(double));
		if (!h->fld_buf) {
			free(h);
			return NULL;
		}
	}
	h->ensemble = s->replicas > 1;
	h->n_grp = h5md_groups(s);
	h->grp = calloc(h->n_grp > 0 ? (size_t)h->n_grp : 1, sizeof(*h->grp));
	if (!h->grp) {
		free(h->fld_buf);
		free(h);
		return NULL;
	}
	for (int k = 0; k < h->n_grp; k++) {
		pgroup_t *g = &h->grp[k];
		g->pos_step = g->pos_time = g->pos_value = g->vel_value = g->box_value = H5I_INVALID_HID;
		g->spin_value = g->id_value = H5I_INVALID_HID;
	}
	memcpy(h->box, s->box, sizeof(h->box));
	for (int k = 0; k < MAX_OBS; k++)
		h->obs[k] = H5I_INVALID_HID;
	h->dim = s->dim;
	h->n = scene_slots(s);
	h->ids = scene_has_reservoir(s);
	h->level = s->compression;
	h->spin_dim = s->rough && s->replicas <= 1 ? (s->dim == 2 ? 1 : 3) : 0;
	size_t len = strlen(path);
	h->path = strdup(path);
	h->xdmf_path = malloc(len + 8);
	if (!h->path || !h->xdmf_path) {
		h5md_destroy(h);
		return NULL;
	}
	const char *slash = strrchr(h->path, '/');
	h->h5_name = slash ? slash + 1 : h->path;
	if (len > 3 && !strcmp(path + len - 3, ".h5"))
		snprintf(h->xdmf_path, len + 8, "%.*s.xdmf", (int)(len - 3), path);
	else
		snprintf(h->xdmf_path, len + 8, "%s.xdmf", path);
	return h;
}

/* Unit strings of the reduced system (docs/output.md): l0, m0, e0, t0. */
static const char *unit_of(const obs_def_t *d, int dim)
{
	if (d->unit && !strcmp(d->unit, "pressure"))
		return dim == 2 ? "e0 l0-2" : "e0 l0-3";
	if (d->unit && !strcmp(d->unit, "flux"))
		return dim == 2 ? "l0-1 t0-1" : "l0-2 t0-1";
	return d->unit;
}

static int write_parameters(hid_t f, const scene_t *s, const char *text, size_t len)
{
	int ret = -1;
	hid_t g = h5u_group(f, "parameters");
	if (g < 0 || h5u_write_string(g, "scene", text, len))
		goto out;
	int64_t dim = s->dim, count = (int64_t)s->count;
	double diam = 2.0 * s->radius;
	if (h5u_attr_i64(g, "dimensions", &dim, 1) || h5u_attr_u64(g, "particles", (uint64_t)count) ||
	    h5u_attr_f64(g, "diameter", &diam, 1) || h5u_attr_f64(g, "mass", &s->mass, 1) ||
	    h5u_attr_f64(g, "restitution", &s->restitution, 1) || h5u_attr_f64(g, "tc", &s->tc, 1) ||
	    h5u_attr_u64(g, "seed", s->seed) || h5u_attr_f64(g, "volume_fraction", &s->volume_fraction, 1) ||
	    h5u_attr_f64(g, "box", s->box, (size_t)s->dim) || h5u_attr_str(g, "method", scene_method_name(s->method)))
		goto out;
	if (scene_has_species(s)) {
		/* mixtures: the species' names, in index order (diameter: the largest, mass: the mean) */
		const char *names[SCENE_SPECIES_MAX];
		for (int k = 0; k < s->n_species; k++)
			names[k] = s->species[k].name;
		if (h5u_attr_strs(g, "species", names, (size_t)s->n_species))
			goto out;
	}
	ret = 0;
out:
	if (g >= 0) H5Gclose(g);
	return ret;
}

static int write_header(hid_t f)
{
	int ret = -1;
	int64_t ver[2] = {1, 1}, mver[2] = {1, 0};
	hid_t h = h5u_group(f, "h5md"), a = h5u_group(f, "h5md/author"), c = h5u_group(f, "h5md/creator");
	hid_t u = h5u_group(f, "h5md/modules/units"), th = h5u_group(f, "h5md/modules/thermodynamics");
	if (h >= 0 && a >= 0 && c >= 0 && u >= 0 && th >= 0 && !h5u_attr_i64(h, "version", ver, 2) &&
	    !h5u_attr_str(a, "name", "granulard") && !h5u_attr_str(c, "name", "granular-engine") &&
	    !h5u_attr_str(c, "version", PACKAGE_VERSION) && !h5u_attr_i64(u, "version", mver, 2) &&
	    !h5u_attr_str(u, "system", "granulard-reduced") && !h5u_attr_i64(th, "version", mver, 2))
		ret = 0;
	if (h >= 0) H5Gclose(h);
	if (a >= 0) H5Gclose(a);
	if (c >= 0) H5Gclose(c);
	if (u >= 0) H5Gclose(u);
	if (th >= 0) H5Gclose(th);
	return ret;
}

/* Time-independent per-particle constant (diameter, mass): [N], compressed. */
static int write_constant(hid_t g, const char *name, double v, uint64_t n)
{
	int ret = -1;
	hsize_t dims[1] = {n}, chunk[1] = {n < FRAME_CHUNK ? n : FRAME_CHUNK};
	double *buf = malloc(chunk[0] * sizeof(double));
	hid_t sp = H5Screate_simple(1, dims, NULL), dcpl = H5Pcreate(H5P_DATASET_CREATE), d = H5I_INVALID_HID;
	hid_t fs = H5I_INVALID_HID, ms = H5I_INVALID_HID;
	if (!buf || sp < 0 || dcpl < 0 || H5Pset_chunk(dcpl, 1, chunk) < 0 || H5Pset_deflate(dcpl, 1) < 0 ||
	    H5Pset_fletcher32(dcpl) < 0)
		goto out;
	d = H5Dcreate2(g, name, H5T_IEEE_F64LE, sp, H5P_DEFAULT, dcpl, H5P_DEFAULT);
	if (d < 0)
		goto out;
	for (size_t i = 0; i < chunk[0]; i++)
		buf[i] = v;
	for (hsize_t k = 0; k < n; k += chunk[0]) {
		hsize_t start[1] = {k}, cnt[1] = {n - k < chunk[0] ? n - k : chunk[0]};
		if ((fs = H5Dget_space(d)) < 0 || H5Sselect_hyperslab(fs, H5S_SELECT_SET, start, NULL, cnt, NULL) < 0 ||
		    (ms = H5Screate_simple(1, cnt, NULL)) < 0 || H5Dwrite(d, H5T_NATIVE_DOUBLE, ms, fs, H5P_DEFAULT, buf) < 0)
			goto out;
		H5Sclose(fs);
		H5Sclose(ms);
		fs = ms = H5I_INVALID_HID;
	}
	ret = 0;
out:
	free(buf);
	if (fs >= 0) H5Sclose(fs);
	if (ms >= 0) H5Sclose(ms);
	if (d >= 0) H5Dclose(d);
	if (sp >= 0) H5Sclose(sp);
	if (dcpl >= 0) H5Pclose(dcpl);
	return ret;
}

/* A per-particle array [N] of mixtures (species index, diameter, mass), compressed. */
static int write_array(hid_t g, const char *name, hid_t ftype, hid_t mtype, const void *buf, uint64_t n)
{
	int ret = -1;
	hsize_t dims[1] = {n}, chunk[1] = {n < FRAME_CHUNK ? n : FRAME_CHUNK};
	hid_t sp = H5Screate_simple(1, dims, NULL), dcpl = H5Pcreate(H5P_DATASET_CREATE), d = H5I_INVALID_HID;
	if (sp < 0 || dcpl < 0 || H5Pset_chunk(dcpl, 1, chunk) < 0 || H5Pset_deflate(dcpl, 1) < 0 ||
	    H5Pset_fletcher32(dcpl) < 0)
		goto out;
	d = H5Dcreate2(g, name, ftype, sp, H5P_DEFAULT, dcpl, H5P_DEFAULT);
	if (d < 0 || H5Dwrite(d, mtype, H5S_ALL, H5S_ALL, H5P_DEFAULT, buf) < 0)
		goto out;
	ret = 0;
out:
	if (d >= 0) H5Dclose(d);
	if (sp >= 0) H5Sclose(sp);
	if (dcpl >= 0) H5Pclose(dcpl);
	return ret;
}

/* Mixtures: species (H5MD's per-particle integer), diameter and mass of
 * each particle, time-independent (species are blocks of indices; radii
 * of polydisperse species drawn as the engine draws them; a dispenser's
 * empty slots: scene_row_species(), a slot keeps its species). */
static int write_species(hid_t all, const scene_t *s, uint64_t n)
{
	int ret = -1;
	int32_t *sp = malloc(n * sizeof(int32_t));
	double *diam = malloc(n * sizeof(double)), *mass = malloc(n * sizeof(double));
	uint8_t *row = malloc(n);
	if (!sp || !diam || !mass || !row || n != scene_slots(s))
		goto out;
	scene_row_species(s, row, diam);   /* the engine's radii: the same draws; dispensers: the empty slots' too */
	uint64_t i = 0;
	for (; i < n; i++) {
		sp[i] = row[i];
		diam[i] *= 2.0;
		mass[i] = s->species[row[i]].mass;
	}
	if (!write_array(all, "species", H5T_STD_I32LE, H5T_NATIVE_INT32, sp, n) &&
	    !write_array(all, "diameter", H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, diam, n) &&
	    !write_array(all, "mass", H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, mass, n))
		ret = 0;
out:
	free(row);
	free(sp);
	free(diam);
	free(mass);
	return ret;
}

static int write_group(h5md_t *h, int k, const scene_t *s)
{
	int ret = -1;
	const hsize_t chunk_t[1] = {OBS_CHUNK};
	hsize_t inner[2] = {h->n, (hsize_t)h->dim}, chunk[3] = {1, h->n < FRAME_CHUNK ? h->n : FRAME_CHUNK, (hsize_t)h->dim};
	const char *bnd[3] = {"periodic", "periodic", "periodic"};
	for (int a = 0; a < 3; a++)
		if (s->boundary[a].walled)
			bnd[a] = "none";   /* H5MD: a non-periodic axis */
	int64_t dim = h->dim;
	pgroup_t *pg = &h->grp[k];
	char name[64];
	group_name(h, k, name, sizeof name);
	hid_t all = h5u_group(h->file, name), box = all >= 0 ? h5u_group(all, "box") : H5I_INVALID_HID;
	hid_t pos = all >= 0 ? h5u_group(all, "position") : H5I_INVALID_HID;
	hid_t vel = all >= 0 ? h5u_group(all, "velocity") : H5I_INVALID_HID;
	hid_t edges = H5I_INVALID_HID;
	hsize_t binner[2] = {(hsize_t)h->dim, (hsize_t)h->dim}, bchunk[3] = {OBS_CHUNK, (hsize_t)h->dim, (hsize_t)h->dim};
	if (all < 0 || box < 0 || pos < 0 || vel < 0)
		goto out;
	if (h5u_attr_i64(box, "dimension", &dim, 1) || h5u_attr_strs(box, "boundary", bnd, (size_t)h->dim))
		goto out;
	pg->pos_step = create_series(pos, "step", H5T_STD_I64LE, 1, NULL, chunk_t, 0);
	pg->pos_time = create_series(pos, "time", H5T_IEEE_F64LE, 1, NULL, chunk_t, 0);
	pg->pos_value = create_series(pos, "value", H5T_IEEE_F64LE, 3, inner, chunk, h->level);
	pg->vel_value = create_series(vel, "value", H5T_IEEE_F64LE, 3, inner, chunk, h->level);
	/* The box as a time-dependent element of D x D box vectors sampled with
	 * the frames (H5MD 1.1 allows a fixed [D]; MDAnalysis reads only this). */
	edges = h5u_group(box, "edges");
	pg->box_value = edges >= 0 ? create_series(edges, "value", H5T_IEEE_F64LE, 3, binner, bchunk, 0) : H5I_INVALID_HID;
	if (pg->box_value < 0 || H5Lcreate_hard(pos, "step", edges, "step", H5P_DEFAULT, H5P_DEFAULT) < 0 ||
	    H5Lcreate_hard(pos, "time", edges, "time", H5P_DEFAULT, H5P_DEFAULT) < 0)
		goto out;
	/* No unit attributes under /particles: the reduced system (l0, t0) is not
	 * in the tables of H5MD readers such as MDAnalysis, which refuse unknown
	 * unit strings even with convert_units=False (docs/output.md). */
	if (pg->pos_step < 0 || pg->pos_time < 0 || pg->pos_value < 0 || pg->vel_value < 0 ||
	    H5Lcreate_hard(pos, "step", vel, "step", H5P_DEFAULT, H5P_DEFAULT) < 0 ||
	    H5Lcreate_hard(pos, "time", vel, "time", H5P_DEFAULT, H5P_DEFAULT) < 0)
		goto out;
	if (scene_has_species(s)) {
		/* ensembles: replica k runs on random stream k (engine/main.c), which draws its polydisperse radii */
		scene_t sk = *s;
		if (h->ensemble)
			sk.stream = (uint64_t)k;
		if (write_species(all, &sk, h->n))
			goto out;
	} else if (write_constant(all, "diameter", 2.0 * s->radius, h->n) || write_constant(all, "mass", s->mass, h->n)) {
		goto out;
	}
	if (h->ids) {
		/* reservoir walls: H5MD's time-dependent id, [frames][slots], the
		 * frames' step and time; -1 marks an empty slot (its position NaN) */
		hsize_t iinner[1] = {h->n}, ichunk[2] = {1, chunk[1]};
		hid_t ig = h5u_group(all, "id");
		if (ig >= 0)
			pg->id_value = create_series(ig, "value", H5T_STD_I64LE, 2, iinner, ichunk, h->level);
		int bad = ig < 0 || pg->id_value < 0 ||
		          H5Lcreate_hard(pos, "step", ig, "step", H5P_DEFAULT, H5P_DEFAULT) < 0 ||
		          H5Lcreate_hard(pos, "time", ig, "time", H5P_DEFAULT, H5P_DEFAULT) < 0;
		if (ig >= 0)
			H5Gclose(ig);
		if (bad)
			goto out;
	}
	if (h->spin_dim) {
		/* rough particles: angular velocities, [frames][N][1 or 3], with the
		 * frames' step and time */
		hsize_t sinner[2] = {h->n, (hsize_t)h->spin_dim};
		hsize_t schunk[3] = {1, chunk[1], (hsize_t)h->spin_dim};
		hid_t sp = h5u_group(all, "angular_velocity");
		if (sp >= 0)
			pg->spin_value = create_series(sp, "value", H5T_IEEE_F64LE, 3, sinner, schunk, h->level);
		int bad = sp < 0 || pg->spin_value < 0 ||
		          H5Lcreate_hard(pos, "step", sp, "step", H5P_DEFAULT, H5P_DEFAULT) < 0 ||
		          H5Lcreate_hard(pos, "time", sp, "time", H5P_DEFAULT, H5P_DEFAULT) < 0;
		if (sp >= 0)
			H5Gclose(sp);
		if (bad)
			goto out;
	}
	ret = 0;
out:
	if (edges >= 0) H5Gclose(edges);
	if (all >= 0) H5Gclose(all);
	if (box >= 0) H5Gclose(box);
	if (pos >= 0) H5Gclose(pos);
	if (vel >= 0) H5Gclose(vel);
	return ret;
}

static int write_particles(h5md_t *h, const scene_t *s)
{
	hid_t p = h5u_group(h->file, "particles");
	if (p < 0)
		return -1;
	H5Gclose(p);
	for (int k = 0; k < h->n_grp; k++)
		if (write_group(h, k, s))
			return -1;
	return 0;
}

static int write_observables(h5md_t *h, const scene_t *s)
{
	int ret = -1;
	const hsize_t chunk1[1] = {OBS_CHUNK};
	hid_t root = h5u_group(h->file, "observables"), first = H5I_INVALID_HID;
	if (root < 0)
		return -1;
	for (size_t k = 0; k < N_OBS_DEFS; k++) {
		const obs_def_t *d = &obs_defs[k];
		if (!def_wanted(d, s))
			continue;
		hid_t g = h5u_group(root, d->path);
		if (g < 0)
			goto out;
		int cols = d->cols == -1 ? h->dim : d->cols == -2 ? h->dim * s->n_obstacles : d->cols == -3 ? s->n_species
		         : d->cols;
		hsize_t inner[1] = {(hsize_t)cols}, chunk[2] = {OBS_CHUNK, (hsize_t)cols};
		hid_t v = cols ? create_series(g, "value", d->i64 ? H5T_STD_I64LE : H5T_IEEE_F64LE, 2, inner, chunk, h->level)
		               : create_series(g, "value", d->i64 ? H5T_STD_I64LE : H5T_IEEE_F64LE, 1, NULL, chunk1, h->level);
		const char *unit = unit_of(d, h->dim);
		int bad = v < 0 || (unit && h5u_attr_str(v, "unit", unit));
		if (!bad && first < 0) {
			first = g;
			h->obs_step = create_series(g, "step", H5T_STD_I64LE, 1, NULL, chunk1, 0);
			h->obs_time = create_series(g, "time", H5T_IEEE_F64LE, 1, NULL, chunk1, 0);
			bad = h->obs_step < 0 || h->obs_time < 0 || h5u_attr_str(h->obs_time, "unit", "t0");
		} else if (!bad) {
			/* same sampling: step and time hard-linked (H5MD 1.1) */
			bad = H5Lcreate_hard(first, "step", g, "step", H5P_DEFAULT, H5P_DEFAULT) < 0 ||
			      H5Lcreate_hard(first, "time", g, "time", H5P_DEFAULT, H5P_DEFAULT) < 0;
		}
		if (g != first)
			H5Gclose(g);
		if (bad || h->n_obs >= MAX_OBS) {
			if (v >= 0) H5Dclose(v);
			goto out;
		}
		h->obs[h->n_obs] = v;
		h->obs_def[h->n_obs++] = (int)k;
	}
	ret = 0;
out:
	if (first >= 0) H5Gclose(first);
	H5Gclose(root);
	return ret;
}

/* Columns per cell of fields dataset k (0: a scalar per row, fields_samples). */
static int fld_cols(const h5md_t *h, int k)
{
	return k == 0 ? 0 : k == 3 ? h->dim : k == 5 ? (h->dim == 2 ? 1 : 3) : 1;
}

/* The fields' series under /observables (docs/output.md): value [rows][cells] or [rows][cells][K], the
 * cell index c = i_x + n_x (i_y + n_y i_z); step and time of their own, hard-linked among them. */
static int write_fields(h5md_t *h, const scene_t *s)
{
	static const char *const units[FLD_MAX] = {NULL, NULL, NULL, "l0 t0-1", "e0", "t0-1"};
	const hsize_t chunk1[1] = {OBS_CHUNK};
	int ret = -1;
	hid_t root = H5Gopen2(h->file, "observables", H5P_DEFAULT), first = H5I_INVALID_HID;
	if (root < 0)
		return -1;
	int64_t cells[3] = {s->fields_cells[0], s->fields_cells[1], s->fields_cells[2]};
	double edges[3];
	for (int a = 0; a < 3; a++)
		edges[a] = a < s->dim ? s->box[a] / s->fields_cells[a] : 0.0;
	for (int k = 0; k < h->n_fld; k++) {
		hid_t g = h5u_group(root, fld_names[k]);
		if (g < 0)
			goto out;
		int K = fld_cols(h, k);
		hsize_t inner[2] = {(hsize_t)h->fld_cells, (hsize_t)K};
		hsize_t chunk[3] = {1, (hsize_t)(h->fld_cells < 65536 ? h->fld_cells : 65536), (hsize_t)K};
		hid_t v = k == 0 ? create_series(g, "value", H5T_STD_I64LE, 1, NULL, chunk1, 0)
		        : create_series(g, "value", H5T_IEEE_F64LE, K > 1 || k == 5 ? 3 : 2, inner, chunk, h->level);
		const char *unit = k == 2 ? (h->dim == 2 ? "l0-2" : "l0-3") : units[k];
		int bad = v < 0 || (unit && h5u_attr_str(v, "unit", unit)) ||
		          (k > 0 && (h5u_attr_i64(v, "cells", cells, (size_t)s->dim) ||
		                     h5u_attr_f64(v, "cell_edges", edges, (size_t)s->dim)));
		if (!bad && first < 0) {
			first = g;
			h->fld_step = create_series(g, "step", H5T_STD_I64LE, 1, NULL, chunk1, 0);
			h->fld_time = create_series(g, "time", H5T_IEEE_F64LE, 1, NULL, chunk1, 0);
			bad = h->fld_step < 0 || h->fld_time < 0 || h5u_attr_str(h->fld_time, "unit", "t0");
		} else if (!bad) {
			bad = H5Lcreate_hard(first, "step", g, "step", H5P_DEFAULT, H5P_DEFAULT) < 0 ||
			      H5Lcreate_hard(first, "time", g, "time", H5P_DEFAULT, H5P_DEFAULT) < 0;
		}
		if (g != first)
			H5Gclose(g);
		h->fld[k] = v;
		if (bad)
			goto out;
	}
	ret = 0;
out:
	if (first >= 0) H5Gclose(first);
	H5Gclose(root);
	return ret;
}

/* The density spectrum's series under /observables (docs/output.md): samples, power [rows][K] (attribute
 * frequencies: f_k, k = 1 .. K), alpha and alpha_se; step and time of their own, hard-linked among them. */
static int write_dspec(h5md_t *h, const scene_t *s)
{
	const hsize_t chunk1[1] = {OBS_CHUNK};
	int ret = -1;
	hid_t root = H5Gopen2(h->file, "observables", H5P_DEFAULT), first = H5I_INVALID_HID;
	if (root < 0)
		return -1;
	double *f = malloc((size_t)(h->dsp_k > 0 ? h->dsp_k : 1) * sizeof(double));
	if (!f)
		goto out;
	for (int k = 0; k < h->dsp_k; k++)
		f[k] = (k + 1) / (s->dspec_m * s->dspec_interval);
	for (int k = 0; k < DSP_MAX; k++) {
		hid_t g = h5u_group(root, dsp_names[k]);
		if (g < 0)
			goto out;
		hsize_t inner[1] = {(hsize_t)h->dsp_k}, chunk[2] = {1, (hsize_t)h->dsp_k};
		hid_t v = k == 0 ? create_series(g, "value", H5T_STD_I64LE, 1, NULL, chunk1, 0)
		        : k == 1 ? create_series(g, "value", H5T_IEEE_F64LE, 2, inner, chunk, h->level)
		                 : create_series(g, "value", H5T_IEEE_F64LE, 1, NULL, chunk1, 0);
		int bad = v < 0 || (k == 1 && (h5u_attr_f64(v, "frequencies", f, (size_t)h->dsp_k) ||
		                               h5u_attr_str(v, "unit", "1"))) ||
		          (k >= 2 && h5u_attr_str(v, "unit", "1"));
		if (!bad && first < 0) {
			first = g;
			h->dsp_step = create_series(g, "step", H5T_STD_I64LE, 1, NULL, chunk1, 0);
			h->dsp_time = create_series(g, "time", H5T_IEEE_F64LE, 1, NULL, chunk1, 0);
			bad = h->dsp_step < 0 || h->dsp_time < 0 || h5u_attr_str(h->dsp_time, "unit", "t0");
		} else if (!bad) {
			bad = H5Lcreate_hard(first, "step", g, "step", H5P_DEFAULT, H5P_DEFAULT) < 0 ||
			      H5Lcreate_hard(first, "time", g, "time", H5P_DEFAULT, H5P_DEFAULT) < 0;
		}
		if (g != first)
			H5Gclose(g);
		h->dsp[k] = v;
		if (bad)
			goto out;
	}
	ret = 0;
out:
	free(f);
	if (first >= 0) H5Gclose(first);
	H5Gclose(root);
	return ret;
}

h5md_t *h5md_create(const char *path, const scene_t *s, const char *scene_text, size_t len,
                    int *err, char *msg, size_t msglen)
{
	h5u_quiet();
	h5md_t *h = alloc_writer(path, s);
	if (!h) {
		*err = h5u_fail(msg, msglen, H5MD_ENOMEM, "%s: out of memory", path);
		return NULL;
	}
	/* Checksums on what a resume trusts before it appends: the file format
	 * of HDF5 1.8 (superblock 2, object headers 2, new-style groups)
	 * checksums the metadata, and Fletcher-32 each stored chunk. Without them
	 * a damaged file sent HDF5 1.10 itself out of bounds when a resume cut the
	 * series back (ckpt_fuzz: a chunk size changed in an object header,
	 * heap overflow in H5Dset_extent); h5md_open_append() refuses such files.
	 * Not the 1.10 format: its superblock 3 marks the file open for writing,
	 * so a trajectory whose engine was killed could not be opened again
	 * (by the resume, h5py or ParaView) without h5clear. */
	hid_t fapl = H5Pcreate(H5P_FILE_ACCESS);
	if (fapl >= 0 && H5Pset_libver_bounds(fapl, H5F_LIBVER_V18, H5F_LIBVER_LATEST) >= 0)
		h->file = H5Fcreate(path, H5F_ACC_TRUNC, H5P_DEFAULT, fapl);
	if (fapl >= 0)
		H5Pclose(fapl);
	if (h->file < 0) {
		*err = h5u_fail(msg, msglen, H5MD_EIO, "%s: cannot create HDF5 file", path);
		goto fail;
	}
	if (write_header(h->file) || write_parameters(h->file, s, scene_text, len) || write_particles(h, s) ||
	    write_observables(h, s) || (h->n_fld && write_fields(h, s)) || (h->dsp_on && write_dspec(h, s)) || H5Fflush(h->file, H5F_SCOPE_GLOBAL) < 0) {
		*err = h5u_fail(msg, msglen, H5MD_EIO, "%s: cannot write the H5MD layout", path);
		goto fail;
	}
	*err = H5MD_OK;
	return h;
fail:
	h5md_destroy(h);
	return NULL;
}

static int frame_times_reserve(pgroup_t *g, size_t n)
{
	if (n <= g->frame_cap)
		return 0;
	size_t cap = g->frame_cap ? 2 * g->frame_cap : 64;
	while (cap < n)
		cap *= 2;
	double *t = realloc(g->frame_t, cap * sizeof(double));
	if (!t)
		return -1;
	g->frame_t = t;
	g->frame_cap = cap;
	return 0;
}

static int write_xdmf(h5md_t *h);

/* Every dataset attach() opened passes h5u_chunks_sane() (h5util.h: why). */
static int indexes_sane(const h5md_t *h, const char *path, char *msg, size_t msglen)
{
	hsize_t eof = 0;
	if (H5Fget_filesize(h->file, &eof) < 0)
		return h5u_fail(msg, msglen, H5MD_EIO, "%s: cannot read its size", path);
	hid_t ds[4 + MAX_OBS + FLD_MAX + DSP_MAX + 6];
	int n = 0;
	ds[n++] = h->obs_step, ds[n++] = h->obs_time;
	for (int k = 0; k < h->n_obs; k++)
		ds[n++] = h->obs[k];
	for (int k = 0; k < h->n_fld; k++)
		ds[n++] = h->fld[k];
	for (int k = 0; k < DSP_MAX && h->dsp_on; k++)
		ds[n++] = h->dsp[k];
	ds[n++] = h->fld_step, ds[n++] = h->fld_time, ds[n++] = h->dsp_step, ds[n++] = h->dsp_time;
	for (int k = 0; k < n; k++)
		if (ds[k] >= 0 && h5u_chunks_sane(ds[k], eof, 0, H5U_ALL_ROWS))
			return h5u_fail(msg, msglen, H5MD_EFORMAT, "%s: damaged chunk index of an observable series", path);
	for (int k = 0; k < h->n_grp; k++) {
		const pgroup_t *g = &h->grp[k];
		hid_t gs[] = {g->pos_step, g->pos_time, g->pos_value, g->vel_value, g->box_value, g->spin_value};
		for (size_t j = 0; j < sizeof gs / sizeof gs[0]; j++)
			if (gs[j] >= 0 && h5u_chunks_sane(gs[j], eof, 0, H5U_ALL_ROWS))
				return h5u_fail(msg, msglen, H5MD_EFORMAT, "%s: damaged chunk index of the frames", path);
	}
	return H5MD_OK;
}

/* Opens every dataset an append needs on h->file (the frames' groups, the
 * observables the scene asks for); on failure the message names what is
 * missing and the caller destroys h (which closes what was opened). */
static int attach(h5md_t *h, const scene_t *s, const char *path, char *msg, size_t msglen)
{
	static const char *const sub[] = {"position/step", "position/time", "position/value", "velocity/value",
	                                  "box/edges/value"};
	char name[64], p[160];
	for (int k = 0; k < h->n_grp; k++) {
		pgroup_t *g = &h->grp[k];
		hid_t *dst[] = {&g->pos_step, &g->pos_time, &g->pos_value, &g->vel_value, &g->box_value};
		group_name(h, k, name, sizeof name);
		if (h->ids) {
			snprintf(p, sizeof p, "%s/id/value", name);
			g->id_value = H5Dopen2(h->file, p, H5P_DEFAULT);
			if (g->id_value < 0)
				return h5u_fail(msg, msglen, H5MD_EFORMAT, "%s: not a trajectory of this scene (missing /%s)", path, p);
		}
		if (h->spin_dim) {
			snprintf(p, sizeof p, "%s/angular_velocity/value", name);
			g->spin_value = H5Dopen2(h->file, p, H5P_DEFAULT);
			if (g->spin_value < 0)
				return h5u_fail(msg, msglen, H5MD_EFORMAT, "%s: not a trajectory of this scene (missing /%s)", path, p);
		}
		for (size_t j = 0; j < sizeof sub / sizeof sub[0]; j++) {
			snprintf(p, sizeof p, "%s/%s", name, sub[j]);
			*dst[j] = H5Dopen2(h->file, p, H5P_DEFAULT);
			if (*dst[j] < 0)
				return h5u_fail(msg, msglen, H5MD_EFORMAT, "%s: not a trajectory of this scene (missing /%s)", path, p);
		}
	}
	int64_t first = -1;
	for (size_t k = 0; k < N_OBS_DEFS && h->n_obs < MAX_OBS; k++) {
		if (!def_wanted(&obs_defs[k], s))
			continue;
		snprintf(p, sizeof p, "observables/%s/value", obs_defs[k].path);
		h->obs[h->n_obs] = H5Dopen2(h->file, p, H5P_DEFAULT);
		if (h->obs[h->n_obs] < 0)
			return h5u_fail(msg, msglen, H5MD_EFORMAT, "%s: missing dataset /%s", path, p);
		h->obs_def[h->n_obs++] = (int)k;
		if (first < 0) {
			first = (int64_t)k;
			snprintf(p, sizeof p, "observables/%s/step", obs_defs[k].path);
			h->obs_step = H5Dopen2(h->file, p, H5P_DEFAULT);
			snprintf(p, sizeof p, "observables/%s/time", obs_defs[k].path);
			h->obs_time = H5Dopen2(h->file, p, H5P_DEFAULT);
		}
	}
	if (h->obs_step < 0 || h->obs_time < 0)
		return h5u_fail(msg, msglen, H5MD_EFORMAT, "%s: not a trajectory of this scene (datasets missing)", path);
	for (int k = 0; k < h->n_fld; k++) {
		snprintf(p, sizeof p, "observables/%s/value", fld_names[k]);
		if ((h->fld[k] = H5Dopen2(h->file, p, H5P_DEFAULT)) < 0)
			return h5u_fail(msg, msglen, H5MD_EFORMAT, "%s: missing dataset /%s", path, p);
	}
	if (h->n_fld) {
		h->fld_step = H5Dopen2(h->file, "observables/fields_samples/step", H5P_DEFAULT);
		h->fld_time = H5Dopen2(h->file, "observables/fields_samples/time", H5P_DEFAULT);
		if (h->fld_step < 0 || h->fld_time < 0)
			return h5u_fail(msg, msglen, H5MD_EFORMAT, "%s: missing /observables/fields_samples/step or time", path);
		int64_t r = rows_of(h->fld_time);
		h->fld_rows = r > 0 ? (uint64_t)r : 0;
	}
	for (int k = 0; k < DSP_MAX && h->dsp_on; k++) {
		snprintf(p, sizeof p, "observables/%s/value", dsp_names[k]);
		if ((h->dsp[k] = H5Dopen2(h->file, p, H5P_DEFAULT)) < 0)
			return h5u_fail(msg, msglen, H5MD_EFORMAT, "%s: missing dataset /%s", path, p);
	}
	if (h->dsp_on) {
		h->dsp_step = H5Dopen2(h->file, "observables/density_spectrum_samples/step", H5P_DEFAULT);
		h->dsp_time = H5Dopen2(h->file, "observables/density_spectrum_samples/time", H5P_DEFAULT);
		if (h->dsp_step < 0 || h->dsp_time < 0)
			return h5u_fail(msg, msglen, H5MD_EFORMAT, "%s: missing /observables/density_spectrum_samples/step or time",
			                path);
		int64_t r = rows_of(h->dsp_time);
		h->dsp_rows = r > 0 ? (uint64_t)r : 0;
	}
	return H5MD_OK;
}

h5md_t *h5md_open_append(const char *path, const scene_t *s, uint64_t obs_rows, const uint64_t *frames,
                         int *err, char *msg, size_t msglen)
{
	char name[64];
	h5md_t *h = NULL;
	h5u_quiet();
	/* First read-only: a file that is not this scene's trajectory is refused
	 * without ever being opened for writing (HDF5 cannot close a damaged file
	 * it opened read-write: the handle would stay open for the process). */
	/* The format first, from the file's bytes: a damaged file of the old,
	 * unchecksummed format can make HDF5 allocate what a damaged length says
	 * (160 GB seen, ckpt_fuzz) in H5Fopen itself, before its superblock
	 * version can be asked. */
	int sbv = h5u_superblock_version(path);
	if (sbv < 0) {
		*err = h5u_fail(msg, msglen, H5MD_EIO, "%s: cannot open for appending (missing or damaged)", path);
		return NULL;
	}
	if (sbv < 2) {
		*err = h5u_fail(msg, msglen, H5MD_EFORMAT,
		                "%s: written without HDF5's metadata checksums (superblock version %d, a granulard "
		                "before 2026-11-27): it cannot be appended to safely; resume into a new --out", path, sbv);
		return NULL;
	}
	for (int pass = 0; pass < 2; pass++) {
		h5md_destroy(h);
		h = alloc_writer(path, s);
		if (!h) {
			*err = h5u_fail(msg, msglen, H5MD_ENOMEM, "%s: out of memory", path);
			return NULL;
		}
		h->file = H5Fopen(path, pass ? H5F_ACC_RDWR : H5F_ACC_RDONLY, H5P_DEFAULT);
		if (h->file < 0) {
			*err = h5u_fail(msg, msglen, H5MD_EIO, "%s: cannot open for appending (missing or damaged)", path);
			goto fail;
		}
		if ((*err = attach(h, s, path, msg, msglen)) != H5MD_OK)
			goto fail;
		if (!pass && (*err = indexes_sane(h, path, msg, msglen)) != H5MD_OK)
			goto fail;
	}
	int64_t have_obs = rows_of(h->obs_time);
	if (have_obs < (int64_t)obs_rows) {
		*err = h5u_fail(msg, msglen, H5MD_EFORMAT, "%s: has %lld observable rows, the checkpoint needs %llu",
		                path, (long long)have_obs, (unsigned long long)obs_rows);
		goto fail;
	}
	/* Drop what was written after the checkpoint. */
	int bad = truncate_rows(h->obs_step, obs_rows) || truncate_rows(h->obs_time, obs_rows);
	for (int k = 0; k < h->n_obs && !bad; k++)
		bad = truncate_rows(h->obs[k], obs_rows);
	for (int k = 0; k < h->n_grp && !bad; k++) {
		pgroup_t *g = &h->grp[k];
		int64_t have = rows_of(g->pos_time);
		if (have < (int64_t)frames[k]) {
			group_name(h, k, name, sizeof name);
			*err = h5u_fail(msg, msglen, H5MD_EFORMAT, "%s: /%s has %lld frames, the checkpoint needs %llu", path,
			                name, (long long)have, (unsigned long long)frames[k]);
			goto fail;
		}
		bad = truncate_rows(g->pos_step, frames[k]) || truncate_rows(g->pos_time, frames[k]) ||
		      truncate_rows(g->pos_value, frames[k]) || truncate_rows(g->vel_value, frames[k]) ||
		      truncate_rows(g->box_value, frames[k]) || frame_times_reserve(g, frames[k] + 1) ||
		      (g->spin_value >= 0 && truncate_rows(g->spin_value, frames[k])) ||
		      (g->id_value >= 0 && truncate_rows(g->id_value, frames[k]));
		if (!bad && frames[k] > 0 &&
		    H5Dread(g->pos_time, H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, g->frame_t) < 0) {
			*err = h5u_fail(msg, msglen, H5MD_EIO, "%s: cannot read frame times", path);
			goto fail;
		}
		g->rows = frames[k];
	}
	if (bad) {
		*err = h5u_fail(msg, msglen, H5MD_EIO, "%s: cannot truncate to the checkpoint", path);
		goto fail;
	}
	h->obs_rows = obs_rows;
	/* The sidecar may list frames written after the checkpoint. */
	if (h->n_grp > 0 && write_xdmf(h)) {
		*err = h5u_fail(msg, msglen, H5MD_EIO, "%s: cannot write: %s", h->xdmf_path, strerror(errno));
		goto fail;
	}
	*err = H5MD_OK;
	return h;
fail:
	h5md_destroy(h);
	return NULL;
}

int h5md_destroy(h5md_t *h)
{
	int ret = H5MD_OK;
	if (!h)
		return H5MD_OK;
	if (h->obs_step >= 0) H5Dclose(h->obs_step);
	if (h->obs_time >= 0) H5Dclose(h->obs_time);
	for (int k = 0; k < h->n_grp; k++) {
		pgroup_t *g = &h->grp[k];
		hid_t ds[] = {g->pos_step, g->pos_time, g->pos_value, g->vel_value, g->box_value, g->spin_value,
		              g->id_value};
		for (size_t j = 0; j < sizeof ds / sizeof ds[0]; j++)
			if (ds[j] >= 0)
				H5Dclose(ds[j]);
		free(g->frame_t);
	}
	for (int k = 0; k < MAX_OBS; k++)
		if (h->obs[k] >= 0)
			H5Dclose(h->obs[k]);
	for (int k = 0; k < FLD_MAX; k++)
		if (h->fld[k] >= 0)
			H5Dclose(h->fld[k]);
	if (h->fld_step >= 0) H5Dclose(h->fld_step);
	if (h->fld_time >= 0) H5Dclose(h->fld_time);
	for (int k = 0; k < DSP_MAX; k++)
		if (h->dsp[k] >= 0)
			H5Dclose(h->dsp[k]);
	if (h->dsp_step >= 0) H5Dclose(h->dsp_step);
	if (h->dsp_time >= 0) H5Dclose(h->dsp_time);
	free(h->fld_buf);
	if (h->file >= 0 && H5Fclose(h->file) < 0)
		ret = H5MD_EIO;
	free(h->grp);
	free(h->path);
	free(h->xdmf_path);
	free(h);
	return ret;
}

int h5md_observables(h5md_t *h, const run_record_t *rec, char *msg, size_t msglen)
{
	int64_t step = (int64_t)rec->events;
	/* the widest row: the cluster histogram or the obstacles' forces */
	double vbuf[CLUSTERS_MAX_BINS > 3 * SCENE_OBSTACLES_MAX ? CLUSTERS_MAX_BINS : 3 * SCENE_OBSTACLES_MAX];
	int64_t ibuf[CLUSTERS_MAX_BINS];
	if (append_row(h->obs_step, H5T_NATIVE_INT64, h->obs_rows, &step) ||
	    append_row(h->obs_time, H5T_NATIVE_DOUBLE, h->obs_rows, &rec->time))
		goto fail;
	for (int k = 0; k < h->n_obs; k++) {
		const obs_def_t *d = &obs_defs[h->obs_def[k]];
		void *buf = d->i64 ? (void *)ibuf : (void *)vbuf;
		d->get(rec, buf);
		if (append_row(h->obs[k], d->i64 ? H5T_NATIVE_INT64 : H5T_NATIVE_DOUBLE, h->obs_rows, buf))
			goto fail;
	}
	h->obs_rows++;
	return H5MD_OK;
fail:
	return h5u_fail(msg, msglen, H5MD_EIO, "%s: cannot append observables", h->path);
}

static const obs_table_t *fld_table(const obs_curves_t *c, const char *sub)
{
	for (int i = 0; c && i < c->ntables; i++)
		if (!strcmp(c->t[i].family, "fields") && !strcmp(c->t[i].table, sub))
			return &c->t[i];
	return NULL;
}

/* One row of the density spectrum (a no-op without it). */
static int dspec_row(h5md_t *h, const run_record_t *rec, char *msg, size_t msglen)
{
	const obs_curves_t *c = rec->curves;
	const obs_table_t *t = NULL;
	for (int i = 0; c && i < c->ntables; i++)
		if (!strcmp(c->t[i].family, "density_spectrum"))
			t = &c->t[i];
	if (!h->dsp_on || !t)
		return H5MD_OK;
	int64_t step = (int64_t)rec->events, samples = c->dspec_samples;
	if (t->nb != h->dsp_k || append_row(h->dsp_step, H5T_NATIVE_INT64, h->dsp_rows, &step) ||
	    append_row(h->dsp_time, H5T_NATIVE_DOUBLE, h->dsp_rows, &rec->time) ||
	    append_row(h->dsp[0], H5T_NATIVE_INT64, h->dsp_rows, &samples) ||
	    append_row(h->dsp[1], H5T_NATIVE_DOUBLE, h->dsp_rows, t->val[0]) ||
	    append_row(h->dsp[2], H5T_NATIVE_DOUBLE, h->dsp_rows, &c->dspec_alpha) ||
	    append_row(h->dsp[3], H5T_NATIVE_DOUBLE, h->dsp_rows, &c->dspec_alpha_se))
		return h5u_fail(msg, msglen, H5MD_EIO, "%s: cannot append the density spectrum", h->path);
	h->dsp_rows++;
	return H5MD_OK;
}

int h5md_fields(h5md_t *h, const run_record_t *rec, char *msg, size_t msglen)
{
	static const char *const sub[FLD_MAX] = {"", "density", "density", "velocity", "temperature", "spin"};
	if (dspec_row(h, rec, msg, msglen) != H5MD_OK)
		return H5MD_EIO;
	if (!h->n_fld || !fld_table(rec->curves, "density"))
		return H5MD_OK;
	int64_t step = (int64_t)rec->events, samples = rec->curves->fields_samples;
	if (append_row(h->fld_step, H5T_NATIVE_INT64, h->fld_rows, &step) ||
	    append_row(h->fld_time, H5T_NATIVE_DOUBLE, h->fld_rows, &rec->time) ||
	    append_row(h->fld[0], H5T_NATIVE_INT64, h->fld_rows, &samples))
		goto fail;
	for (int k = 1; k < h->n_fld; k++) {
		const obs_table_t *t = fld_table(rec->curves, sub[k]);
		int K = fld_cols(h, k), col = k == 1 ? 1 : 0;   /* density table: n (density), count */
		if (!t || (uint64_t)t->nb != h->fld_cells)
			goto fail;
		for (uint64_t c = 0; c < h->fld_cells; c++)
			for (int a = 0; a < K; a++)
				h->fld_buf[c * K + a] = t->val[k == 3 || k == 5 ? a : col][c];
		if (append_row(h->fld[k], H5T_NATIVE_DOUBLE, h->fld_rows, h->fld_buf))
			goto fail;
	}
	h->fld_rows++;
	return H5MD_OK;
fail:
	return h5u_fail(msg, msglen, H5MD_EIO, "%s: cannot append the fields", h->path);
}

/* Cut the density spectrum's rows after t_ckpt. */
static int dspec_cut(h5md_t *h, double t_ckpt, char *msg, size_t msglen)
{
	if (!h->dsp_on || h->dsp_rows == 0)
		return H5MD_OK;
	double *t = malloc(h->dsp_rows * sizeof(double));
	uint64_t keep = 0;
	if (!t || H5Dread(h->dsp_time, H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, t) < 0) {
		free(t);
		return h5u_fail(msg, msglen, H5MD_EIO, "%s: cannot read the density spectrum's times", h->path);
	}
	while (keep < h->dsp_rows && t[keep] <= t_ckpt)
		keep++;
	free(t);
	int bad = truncate_rows(h->dsp_step, keep) || truncate_rows(h->dsp_time, keep);
	for (int k = 0; k < DSP_MAX && !bad; k++)
		bad = truncate_rows(h->dsp[k], keep);
	if (bad)
		return h5u_fail(msg, msglen, H5MD_EIO, "%s: cannot truncate the density spectrum to the checkpoint", h->path);
	h->dsp_rows = keep;
	return H5MD_OK;
}

int h5md_fields_cut(h5md_t *h, double t_ckpt, char *msg, size_t msglen)
{
	if (dspec_cut(h, t_ckpt, msg, msglen) != H5MD_OK)
		return H5MD_EIO;
	if (!h->n_fld || h->fld_rows == 0)
		return H5MD_OK;
	double *t = malloc(h->fld_rows * sizeof(double));
	uint64_t keep = 0;
	if (!t || H5Dread(h->fld_time, H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, t) < 0) {
		free(t);
		return h5u_fail(msg, msglen, H5MD_EIO, "%s: cannot read the fields' times", h->path);
	}
	while (keep < h->fld_rows && t[keep] <= t_ckpt)
		keep++;
	free(t);
	int bad = truncate_rows(h->fld_step, keep) || truncate_rows(h->fld_time, keep);
	for (int k = 0; k < h->n_fld && !bad; k++)
		bad = truncate_rows(h->fld[k], keep);
	if (bad)
		return h5u_fail(msg, msglen, H5MD_EIO, "%s: cannot truncate the fields to the checkpoint", h->path);
	h->fld_rows = keep;
	return H5MD_OK;
}

/* The XDMF sidecar: per particles group a temporal collection (named after
 * the group: "particles" for /particles/all, "replica_K" for ensembles) of
 * one uniform grid per frame, each a HyperSlab of frame k of
 * position/value (and velocity/value). Ensemble replicas may have different
 * frame times (collision-count schedules), hence a collection each. */
static int write_xdmf(h5md_t *h)
{
	char tmp[4200], name[64];
	snprintf(tmp, sizeof tmp, "%s.tmp", h->xdmf_path);
	FILE *f = fopen(tmp, "w");
	if (!f)
		return -1;
	const unsigned long long n = h->n;
	const int D = h->dim;
	fprintf(f, "<?xml version=\"1.0\" ?>\n<!DOCTYPE Xdmf SYSTEM \"Xdmf.dtd\" []>\n"
	           "<Xdmf Version=\"3.0\" xmlns:xi=\"http://www.w3.org/2001/XInclude\">\n <Domain>\n");
	for (int gi = 0; gi < h->n_grp; gi++) {
		const pgroup_t *g = &h->grp[gi];
		const unsigned long long nf = g->rows;
		group_name(h, gi, name, sizeof name);
		fprintf(f, "  <Grid Name=\"%s\" GridType=\"Collection\" CollectionType=\"Temporal\">\n",
		        h->ensemble ? name + strlen("particles/") : "particles");
		for (unsigned long long k = 0; k < nf; k++) {
			fprintf(f, "   <Grid Name=\"frame%llu\" GridType=\"Uniform\">\n"
			           "    <Time Value=\"%.17g\"/>\n"
			           "    <Topology TopologyType=\"Polyvertex\" NumberOfElements=\"%llu\" NodesPerElement=\"1\"/>\n"
			           "    <Geometry GeometryType=\"%s\">\n", k, g->frame_t[k], n, D == 2 ? "XY" : "XYZ");
			const char *what[2] = {"position", "velocity"};
			for (int w = 0; w < 2; w++) {
				if (w == 1)
					fprintf(f, "    <Attribute Name=\"velocity\" AttributeType=\"Vector\" Center=\"Node\">\n");
				fprintf(f, "     <DataItem ItemType=\"HyperSlab\" Dimensions=\"%llu %d\" Type=\"HyperSlab\">\n"
				           "      <DataItem Dimensions=\"3 3\" Format=\"XML\">%llu 0 0 1 1 1 1 %llu %d</DataItem>\n"
				           "      <DataItem Dimensions=\"%llu %llu %d\" NumberType=\"Float\" Precision=\"8\" Format=\"HDF\">%s:/%s/%s/value</DataItem>\n"
				           "     </DataItem>\n",
				        n, D, k, n, D, nf, n, D, h->h5_name, name, what[w]);
				fprintf(f, w == 0 ? "    </Geometry>\n" : "    </Attribute>\n");
			}
			fprintf(f, "   </Grid>\n");
		}
		fprintf(f, "  </Grid>\n");
	}
	fprintf(f, " </Domain>\n</Xdmf>\n");
	int bad = ferror(f);
	if (fclose(f) != 0 || bad || rename(tmp, h->xdmf_path) != 0) {
		remove(tmp);
		return -1;
	}
	return 0;
}

int h5md_frame(h5md_t *h, int group, const run_record_t *rec, char *msg, size_t msglen)
{
	int64_t step = (int64_t)rec->events;
	double edges[9] = {0};
	if (group < 0 || group >= h->n_grp)
		return h5u_fail(msg, msglen, H5MD_EFORMAT, "%s: no particles group %d", h->path, group);
	pgroup_t *g = &h->grp[group];
	for (int a = 0; a < h->dim; a++)
		edges[a * h->dim + a] = h->box[a];
	if (frame_times_reserve(g, g->rows + 1))
		return h5u_fail(msg, msglen, H5MD_ENOMEM, "%s: out of memory", h->path);
	if (append_row(g->pos_step, H5T_NATIVE_INT64, g->rows, &step) ||
	    append_row(g->pos_time, H5T_NATIVE_DOUBLE, g->rows, &rec->time) ||
	    append_row(g->pos_value, H5T_NATIVE_DOUBLE, g->rows, rec->pos) ||
	    append_row(g->vel_value, H5T_NATIVE_DOUBLE, g->rows, rec->vel) ||
	    append_row(g->box_value, H5T_NATIVE_DOUBLE, g->rows, edges) ||
	    (g->spin_value >= 0 && rec->spin && append_row(g->spin_value, H5T_NATIVE_DOUBLE, g->rows, rec->spin)) ||
	    (g->id_value >= 0 && (!rec->ids || append_row(g->id_value, H5T_NATIVE_INT64, g->rows, rec->ids))))
		return h5u_fail(msg, msglen, H5MD_EIO, "%s: cannot append a frame", h->path);
	g->frame_t[g->rows++] = rec->time;
	h->frames_pending = 1;
	return H5MD_OK;
}

int h5md_frames_done(h5md_t *h, char *msg, size_t msglen)
{
	if (!h->frames_pending)
		return H5MD_OK;
	if (H5Fflush(h->file, H5F_SCOPE_GLOBAL) < 0)
		return h5u_fail(msg, msglen, H5MD_EIO, "%s: cannot flush", h->path);
	if (write_xdmf(h))
		return h5u_fail(msg, msglen, H5MD_EIO, "%s: cannot write: %s", h->xdmf_path, strerror(errno));
	h->frames_pending = 0;
	return H5MD_OK;
}

int h5md_snapshot(h5md_t *h, const run_record_t *rec, char *msg, size_t msglen)
{
	int rc = h5md_frame(h, 0, rec, msg, msglen);
	return rc == H5MD_OK ? h5md_frames_done(h, msg, msglen) : rc;
}

int h5md_flush(h5md_t *h, char *msg, size_t msglen)
{
	if (H5Fflush(h->file, H5F_SCOPE_GLOBAL) < 0 || h5u_fsync_path(h->path))
		return h5u_fail(msg, msglen, H5MD_EIO, "%s: cannot flush", h->path);
	return H5MD_OK;
}

int h5md_collapse(h5md_t *h, double time, const char *message, char *msg, size_t msglen)
{
	static const char *const names[] = {"inelastic_collapse", "inelastic_collapse_time"};
	hid_t g = H5Gopen2(h->file, "observables", H5P_DEFAULT);
	int bad = g < 0;
	/* a resumed run that collapses again replaces what its first try wrote */
	for (size_t k = 0; !bad && k < 2; k++)
		if (H5Aexists(g, names[k]) > 0 && H5Adelete(g, names[k]) < 0)
			bad = 1;
	bad = bad || h5u_attr_str(g, names[0], message) || h5u_attr_f64(g, names[1], &time, 1);
	if (g >= 0)
		H5Gclose(g);
	if (bad || H5Fflush(h->file, H5F_SCOPE_GLOBAL) < 0)
		return h5u_fail(msg, msglen, H5MD_EIO, "%s: cannot record the inelastic collapse", h->path);
	return H5MD_OK;
}

void h5md_rows(const h5md_t *h, uint64_t *obs_rows, uint64_t *snap_rows)
{
	*obs_rows = h->obs_rows;
	*snap_rows = 0;
	for (int k = 0; k < h->n_grp; k++)
		*snap_rows += h->grp[k].rows;
}

const char *h5md_strerror(int code)
{
	switch (code) {
	case H5MD_OK: return "ok";
	case H5MD_EIO: return "HDF5 or file-system error";
	case H5MD_ENOMEM: return "out of memory";
	case H5MD_EFORMAT: return "file does not have the expected layout";
	default: return "unknown error";
	}
}
