/* Ensemble statistics over replica records: pack to vectors, mean and standard error in replica order. */
#include <math.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "ensemble.h"

enum {
	V_TIME, V_CPP, V_EVENTS, V_COLL, V_EKIN, V_TEMP, V_P, V_Z, V_RATE, V_MOM0, V_MOM1, V_MOM2,
	V_LFRAC, V_MSIZE, V_M2, V_M2R, V_NCL, V_LARGEST, V_NBINS, V_DONE, V_HAVEI, V_STATUS,
	V_VMAX, V_CELLC, V_REJ, V_TC, V_HIST,
	/* after the histogram: absent (zero) in records packed by older versions */
	V_A2 = V_HIST + CLUSTERS_MAX_BINS, V_A3, V_GPAIRS, V_GRATE, V_GPRES, V_CW, V_CEXP,
	V_MSD, V_DIFF,
	V_NSP, V_TSP,   /* mixtures: species, then SCENE_SPECIES_MAX temperatures (absent in older records: zero) */
	/* bounded scenes (absent in older records: zero) */
	V_COM = V_TSP + SCENE_SPECIES_MAX, V_POT, V_FLUX, V_EROT, V_TROT, V_PRESENT, V_WCOLL, V_OCOLL, V_WALLS,
	V_RESV, V_WPRES, V_WFORCE = V_WPRES + 6, V_OFORCE = V_WFORCE + 18, V_OUT = V_OFORCE + 3 * SCENE_OBSTACLES_MAX,
	V_IN = V_OUT + 6, V_WREJ = V_IN + 6, V_END = V_WREJ + 6,
};
_Static_assert(V_END == ENSEMBLE_NV, "ensemble record layout");
_Static_assert(V_COM == ENSEMBLE_NV_V4, "older records end where the bounded scenes' observables begin");

void ensemble_pack(const run_record_t *r, int done, double *v)
{
	memset(v, 0, ENSEMBLE_NV * sizeof(double));
	v[V_TIME] = r->time;
	v[V_CPP] = r->collisions_per_particle;
	v[V_EVENTS] = (double)r->events;
	v[V_COLL] = (double)r->collisions;
	v[V_EKIN] = r->kinetic_energy;
	v[V_TEMP] = r->temperature;
	v[V_P] = r->pressure;
	v[V_Z] = r->compressibility;
	v[V_RATE] = r->collision_rate;
	for (int a = 0; a < 3; a++)
		v[V_MOM0 + a] = r->momentum[a];
	v[V_LFRAC] = r->clusters.largest_fraction;
	v[V_MSIZE] = r->clusters.mean_size;
	v[V_M2] = r->clusters.m2;
	v[V_M2R] = r->clusters.m2_reduced;
	v[V_NCL] = (double)r->clusters.n_clusters;
	v[V_LARGEST] = (double)r->clusters.largest;
	v[V_NBINS] = r->clusters.n_bins;
	v[V_DONE] = done;
	v[V_HAVEI] = r->have_interval;
	v[V_STATUS] = r->status;
	v[V_VMAX] = (double)r->vmax_raised;
	v[V_CELLC] = (double)r->cell_collisions;
	v[V_REJ] = (double)r->rejected_moves;
	v[V_TC] = (double)r->elastic_by_tc;
	for (int k = 0; k < CLUSTERS_MAX_BINS; k++)
		v[V_HIST + k] = (double)r->clusters.hist[k];
	v[V_A2] = r->obs.a2;
	v[V_A3] = r->obs.a3;
	v[V_GPAIRS] = r->obs.g_pairs;
	v[V_GRATE] = r->obs.g_rate;
	v[V_GPRES] = r->obs.g_pressure;
	v[V_CW] = r->clusters.w;
	v[V_CEXP] = r->clusters.exponent;
	v[V_MSD] = r->obs.msd;
	v[V_DIFF] = r->obs.diffusion;
	v[V_NSP] = r->n_species;
	for (int k = 0; k < r->n_species && k < SCENE_SPECIES_MAX; k++)
		v[V_TSP + k] = r->temperature_species[k];
	v[V_COM] = r->com_height;
	v[V_POT] = r->potential_energy;
	v[V_FLUX] = r->obs.flux;
	v[V_EROT] = r->rotational_energy;
	v[V_TROT] = r->rotational_temperature;
	v[V_PRESENT] = (double)r->particles;
	v[V_WCOLL] = (double)r->wall_collisions;
	v[V_OCOLL] = (double)r->obstacle_collisions;
	v[V_WALLS] = r->walls;
	v[V_RESV] = r->reservoirs;
	for (int w = 0; w < 6; w++) {
		v[V_WPRES + w] = r->wall_pressure[w];
		for (int a = 0; a < 3; a++)
			v[V_WFORCE + 3 * w + a] = r->wall_force[w][a];
		v[V_OUT + w] = (double)r->wall_outflow[w];
		v[V_IN + w] = (double)r->wall_inflow[w];
		v[V_WREJ + w] = (double)r->wall_rejected[w];
	}
	for (int k = 0; k < SCENE_OBSTACLES_MAX; k++)
		for (int a = 0; a < 3; a++)
			v[V_OFORCE + 3 * k + a] = k < r->n_obstacles ? r->obstacle_force[k][a] : 0.0;
}

static void stat(const double *vals, int R, int idx, double *mean, double *se)
{
	double s = 0, s2 = 0;
	for (int r = 0; r < R; r++)
		s += vals[(size_t)r * ENSEMBLE_NV + idx];
	*mean = s / R;
	for (int r = 0; r < R; r++) {
		double d = vals[(size_t)r * ENSEMBLE_NV + idx] - *mean;
		s2 += d * d;
	}
	*se = R > 1 ? sqrt(s2 / (R - 1) / R) : 0.0;
}

static double sum(const double *vals, int R, int idx)
{
	double s = 0;
	for (int r = 0; r < R; r++)
		s += vals[(size_t)r * ENSEMBLE_NV + idx];
	return s;
}

int ensemble_combine(const double *vals, int R, const run_record_t *proto, run_record_t *out)
{
	double dummy;
	memset(out, 0, sizeof(*out));
	out->kind = proto->kind;
	out->dim = proto->dim;
	out->n = proto->n;
	out->have = proto->have;
	out->replicas = (uint32_t)R;
	out->warning = proto->warning;
	memcpy(out->cells, proto->cells, sizeof(out->cells));
	out->memory_bytes = proto->memory_bytes;
	stat(vals, R, V_TIME, &out->time, &out->se.time);
	stat(vals, R, V_CPP, &out->collisions_per_particle, &out->se.collisions_per_particle);
	stat(vals, R, V_EKIN, &out->kinetic_energy, &out->se.kinetic_energy);
	stat(vals, R, V_TEMP, &out->temperature, &out->se.temperature);
	stat(vals, R, V_P, &out->pressure, &out->se.pressure);
	stat(vals, R, V_Z, &out->compressibility, &out->se.compressibility);
	stat(vals, R, V_RATE, &out->collision_rate, &out->se.collision_rate);
	for (int a = 0; a < 3; a++)
		stat(vals, R, V_MOM0 + a, &out->momentum[a], &dummy);
	stat(vals, R, V_LFRAC, &out->clusters.largest_fraction, &out->se.largest_fraction);
	stat(vals, R, V_MSIZE, &out->clusters.mean_size, &out->se.mean_size);
	stat(vals, R, V_M2, &out->clusters.m2, &dummy);
	stat(vals, R, V_M2R, &out->clusters.m2_reduced, &dummy);
	/* NaN in one replica (undefined there: no fit, no interval) makes the mean NaN: said, not hidden */
	stat(vals, R, V_A2, &out->obs.a2, &out->se.a2);
	stat(vals, R, V_A3, &out->obs.a3, &out->se.a3);
	stat(vals, R, V_GPAIRS, &out->obs.g_pairs, &out->se.g_pairs);
	stat(vals, R, V_GRATE, &out->obs.g_rate, &out->se.g_rate);
	stat(vals, R, V_GPRES, &out->obs.g_pressure, &out->se.g_pressure);
	stat(vals, R, V_CW, &out->clusters.w, &out->se.cluster_w);
	stat(vals, R, V_CEXP, &out->clusters.exponent, &out->se.cluster_exponent);
	stat(vals, R, V_MSD, &out->obs.msd, &out->se.msd);
	stat(vals, R, V_DIFF, &out->obs.diffusion, &out->se.diffusion);
	out->obs.msd_se = out->obs.msd_walled = NAN;
	out->obs.g_pairs_se = NAN;
	out->n_species = proto->n_species;
	for (int k = 0; k < out->n_species; k++)
		stat(vals, R, V_TSP + k, &out->temperature_species[k], &out->se.temperature_species[k]);
	/* bounded scenes: means with standard errors; counts are totals (as events and collisions) */
	out->walls = proto->walls;
	out->reservoirs = proto->reservoirs;
	out->n_obstacles = proto->n_obstacles;
	stat(vals, R, V_COM, &out->com_height, &out->se.com_height);
	stat(vals, R, V_POT, &out->potential_energy, &out->se.potential_energy);
	stat(vals, R, V_FLUX, &out->obs.flux, &out->obs.flux_se);
	stat(vals, R, V_EROT, &out->rotational_energy, &out->se.rotational_energy);
	stat(vals, R, V_TROT, &out->rotational_temperature, &out->se.rotational_temperature);
	for (int w = 0; w < 6; w++) {
		stat(vals, R, V_WPRES + w, &out->wall_pressure[w], &out->se.wall_pressure[w]);
		for (int a = 0; a < 3; a++)
			stat(vals, R, V_WFORCE + 3 * w + a, &out->wall_force[w][a], &out->se.wall_force[w][a]);
		out->wall_outflow[w] = (uint64_t)llround(sum(vals, R, V_OUT + w));
		out->wall_inflow[w] = (uint64_t)llround(sum(vals, R, V_IN + w));
		out->wall_rejected[w] = (uint64_t)llround(sum(vals, R, V_WREJ + w));
	}
	for (int k = 0; k < out->n_obstacles && k < SCENE_OBSTACLES_MAX; k++)
		for (int a = 0; a < 3; a++)
			stat(vals, R, V_OFORCE + 3 * k + a, &out->obstacle_force[k][a], &out->se.obstacle_force[k][a]);
	out->particles = (uint64_t)llround(sum(vals, R, V_PRESENT));
	out->wall_collisions = (uint64_t)llround(sum(vals, R, V_WCOLL));
	out->obstacle_collisions = (uint64_t)llround(sum(vals, R, V_OCOLL));
	out->clusters.n_particles = proto->n;
	out->clusters.n_clusters = (uint64_t)llround(sum(vals, R, V_NCL) / R);
	out->clusters.largest = (uint64_t)llround(sum(vals, R, V_LARGEST) / R);
	int nb = 0;
	for (int r = 0; r < R; r++) {
		int b = (int)vals[(size_t)r * ENSEMBLE_NV + V_NBINS];
		nb = b > nb ? b : nb;
	}
	out->clusters.n_bins = nb;
	for (int k = 0; k < CLUSTERS_MAX_BINS; k++)
		out->clusters.hist[k] = (uint64_t)llround(sum(vals, R, V_HIST + k));
	out->events = (uint64_t)llround(sum(vals, R, V_EVENTS));
	out->collisions = (uint64_t)llround(sum(vals, R, V_COLL));
	out->vmax_raised = (uint64_t)llround(sum(vals, R, V_VMAX));
	out->cell_collisions = (uint64_t)llround(sum(vals, R, V_CELLC));
	out->rejected_moves = (uint64_t)llround(sum(vals, R, V_REJ));
	out->elastic_by_tc = (uint64_t)llround(sum(vals, R, V_TC));
	/* Interval quantities only when every replica has them. */
	out->have_interval = sum(vals, R, V_HAVEI) == R;
	/* Status: the most severe (interrupted > quiescent > completed). */
	int st = 0;
	for (int r = 0; r < R; r++) {
		int s = (int)vals[(size_t)r * ENSEMBLE_NV + V_STATUS];
		st = s > st ? s : st;
	}
	out->status = (run_status_t)st;
	return (int)sum(vals, R, V_DONE);
}

void ensemble_unpack(const double *v, const scene_t *s, run_record_t *r)
{
	memset(r, 0, sizeof(*r));
	r->kind = RUN_PROGRESS;
	r->dim = s->dim;
	r->n = s->count;
	r->have = s->observables;
	r->time = v[V_TIME];
	r->collisions_per_particle = v[V_CPP];
	r->events = (uint64_t)v[V_EVENTS];
	r->collisions = (uint64_t)v[V_COLL];
	r->kinetic_energy = v[V_EKIN];
	r->temperature = v[V_TEMP];
	r->pressure = v[V_P];
	r->compressibility = v[V_Z];
	r->collision_rate = v[V_RATE];
	for (int a = 0; a < 3; a++)
		r->momentum[a] = v[V_MOM0 + a];
	r->clusters.n_particles = s->count;
	r->clusters.largest_fraction = v[V_LFRAC];
	r->clusters.mean_size = v[V_MSIZE];
	r->clusters.m2 = v[V_M2];
	r->clusters.m2_reduced = v[V_M2R];
	r->clusters.n_clusters = (uint64_t)v[V_NCL];
	r->clusters.largest = (uint64_t)v[V_LARGEST];
	r->clusters.n_bins = (int)v[V_NBINS];
	r->have_interval = (int)v[V_HAVEI];
	r->status = (run_status_t)(int)v[V_STATUS];
	r->vmax_raised = (uint64_t)v[V_VMAX];
	r->cell_collisions = (uint64_t)v[V_CELLC];
	r->rejected_moves = (uint64_t)v[V_REJ];
	r->elastic_by_tc = (uint64_t)v[V_TC];
	for (int k = 0; k < CLUSTERS_MAX_BINS; k++)
		r->clusters.hist[k] = (uint64_t)v[V_HIST + k];
	r->obs.a2 = v[V_A2];
	r->obs.a3 = v[V_A3];
	r->obs.g_pairs = v[V_GPAIRS];
	r->obs.g_rate = v[V_GRATE];
	r->obs.g_pressure = v[V_GPRES];
	r->obs.g_pairs_se = NAN;
	r->clusters.w = v[V_CW];
	r->clusters.exponent = v[V_CEXP];
	r->obs.msd = v[V_MSD];
	r->obs.diffusion = v[V_DIFF];
	r->obs.msd_se = r->obs.msd_walled = NAN;
	r->n_species = (int)v[V_NSP];
	if (r->n_species < 0 || r->n_species > SCENE_SPECIES_MAX)
		r->n_species = 0;
	for (int k = 0; k < r->n_species; k++)
		r->temperature_species[k] = v[V_TSP + k];
	r->com_height = v[V_COM];
	r->potential_energy = v[V_POT];
	r->obs.flux = v[V_FLUX];
	r->obs.flux_se = NAN;
	r->rotational_energy = v[V_EROT];
	r->rotational_temperature = v[V_TROT];
	r->particles = (uint64_t)v[V_PRESENT];
	r->wall_collisions = (uint64_t)v[V_WCOLL];
	r->obstacle_collisions = (uint64_t)v[V_OCOLL];
	r->walls = (unsigned)v[V_WALLS];
	r->reservoirs = (unsigned)v[V_RESV];
	r->n_obstacles = s->n_obstacles;
	for (int w = 0; w < 6; w++) {
		r->wall_pressure[w] = v[V_WPRES + w];
		for (int a = 0; a < 3; a++)
			r->wall_force[w][a] = v[V_WFORCE + 3 * w + a];
		r->wall_outflow[w] = (uint64_t)v[V_OUT + w];
		r->wall_inflow[w] = (uint64_t)v[V_IN + w];
		r->wall_rejected[w] = (uint64_t)v[V_WREJ + w];
	}
	for (int k = 0; k < s->n_obstacles && k < SCENE_OBSTACLES_MAX; k++)
		for (int a = 0; a < 3; a++)
			r->obstacle_force[k][a] = v[V_OFORCE + 3 * k + a];
}

/* ---- replica state as a byte string ----------------------------------------
 * Per field: name length with its NUL (u32), name, type (u32), count (u64), data. */

int ensemble_put_field(unsigned char **buf, size_t *len, size_t *cap, const char *name, ed_type_t type,
                       size_t count, const void *data)
{
	uint32_t nl = (uint32_t)strlen(name) + 1, t = (uint32_t)type;
	uint64_t c = count;
	size_t bytes = count * ed_type_size(type), need = *len + 4 + nl + 4 + 8 + bytes;
	if (need > *cap) {
		size_t nc = *cap ? *cap : 4096;
		while (nc < need)
			nc *= 2;
		unsigned char *nb = realloc(*buf, nc);
		if (!nb)
			return -1;
		*buf = nb;
		*cap = nc;
	}
	unsigned char *p = *buf + *len;
	memcpy(p, &nl, 4), p += 4;
	memcpy(p, name, nl), p += nl;
	memcpy(p, &t, 4), p += 4;
	memcpy(p, &c, 8), p += 8;
	if (bytes)
		memcpy(p, data, bytes);
	*len = need;
	return 0;
}

int ensemble_next_field(const unsigned char *buf, size_t len, size_t *pos, ed_field_t *f, const void **data)
{
	uint32_t nl, t;
	uint64_t c;
	size_t p = *pos;
	if (p == len)
		return 0;
	if (p > len || len - p < 4)
		return -1;
	memcpy(&nl, buf + p, 4);
	p += 4;
	if (nl < 2 || nl > 64 || len - p < (size_t)nl + 12 || buf[p + nl - 1] != '\0')
		return -1;
	f->name = (const char *)buf + p;
	p += nl;
	memcpy(&t, buf + p, 4);
	memcpy(&c, buf + p + 4, 8);
	p += 12;
	if (t > ED_T_U8 || c > len)
		return -1;
	size_t bytes = (size_t)c * ed_type_size((ed_type_t)t);
	if (len - p < bytes)
		return -1;
	f->type = (ed_type_t)t;
	f->count = (size_t)c;
	*data = buf + p;
	*pos = p + bytes;
	return 1;
}

/* The replica's schedule and finish state beside its engine fields. */
static const struct {
	const char *name;
	size_t off;
	int is_double;
	int optional;   /* absent in older checkpoints: 0 */
} sched[] = {
	{ "@started", offsetof(run_state_t, started), 0, 0 },
	{ "@k_out", offsetof(run_state_t, k_out), 0, 0 },
	{ "@k_snap", offsetof(run_state_t, k_snap), 0, 0 },
	{ "@k_ckpt", offsetof(run_state_t, k_ckpt), 0, 0 },
	{ "@snap_events", offsetof(run_state_t, snap_events), 0, 0 },
	{ "@wall_before", offsetof(run_state_t, wall_before), 1, 0 },
	/* frames written for this replica (trajectory.h5 particles/replica_K);
	 * absent from checkpoints of versions without ensemble frames, which
	 * wrote none */
	{ "@frames", offsetof(run_state_t, frames), 0, 1 },
};
#define N_SCHED (sizeof sched / sizeof sched[0])
#define MAX_FIELDS 128   /* engine fields (ED_MAX_FIELDS) and the run's own */

int ensemble_save(const run_t *r, unsigned char **buf, size_t *len)
{
	ed_field_t f[MAX_FIELDS];
	size_t cap = 0;
	int nf = run_fields(r, f, MAX_FIELDS), done;
	run_status_t status;
	run_state_t st;
	double last[ENSEMBLE_NV];
	void *data = NULL;
	*buf = NULL;
	*len = 0;
	if (nf > MAX_FIELDS)
		goto fail;
	for (int k = 0; k < nf; k++) {
		data = malloc(f[k].count * ed_type_size(f[k].type) + 1);
		if (!data || run_field_get(r, f[k].name, data) != RUN_OK ||
		    ensemble_put_field(buf, len, &cap, f[k].name, f[k].type, f[k].count, data))
			goto fail;
		free(data);
		data = NULL;
	}
	run_get_state(r, &st);
	for (size_t k = 0; k < N_SCHED; k++)
		if (ensemble_put_field(buf, len, &cap, sched[k].name, sched[k].is_double ? ED_T_F64 : ED_T_U64, 1,
		                       (const char *)&st + sched[k].off))
			goto fail;
	run_get_finish(r, &done, &status);
	uint64_t d = (uint64_t)done, s = (uint64_t)status;
	ensemble_pack(run_last(r), done, last);
	if (ensemble_put_field(buf, len, &cap, "@done", ED_T_U64, 1, &d) ||
	    ensemble_put_field(buf, len, &cap, "@status", ED_T_U64, 1, &s) ||
	    ensemble_put_field(buf, len, &cap, "@last", ED_T_F64, ENSEMBLE_NV, last))
		goto fail;
	return 0;
fail:
	free(data);
	free(*buf);
	*buf = NULL;
	return -1;
}

int ensemble_load(const scene_t *s, uint64_t stream, const unsigned char *buf, size_t len, run_t **out,
                  char *msg, size_t msglen)
{
	scene_t sc = *s;
	int err = 0, rc, got = 0, have_last = 0, need = 2;
	uint64_t done = 0, status = 0;
	size_t pos = 0;
	ed_field_t f;
	const void *data;
	run_state_t st;
	run_record_t last;
	run_t *r;

	sc.stream = stream;
	*out = NULL;
	const run_opts_t opts = {.curves = 1};   /* as run_open(): fields and spectrum sampled per replica */
	r = run_create_blank(&sc, &opts, &err, msg, msglen);
	if (!r)
		return err == RUN_ENOMEM ? RUN_ENOMEM : RUN_ERESTORE;
	memset(&st, 0, sizeof st);
	memset(&last, 0, sizeof last);
	while ((rc = ensemble_next_field(buf, len, &pos, &f, &data)) == 1) {
		size_t k;
		if (f.name[0] != '@') {
			/* data lies in the blob at any offset; the engines read it as typed
			 * arrays (int32_t, double), which need their alignment (UBSan). */
			size_t bytes = f.count * ed_type_size(f.type);
			void *al = malloc(bytes ? bytes : 1);
			if (!al) {
				run_destroy(r);
				return RUN_ENOMEM;
			}
			memcpy(al, data, bytes);
			rc = run_field_set(r, f.name, f.type, f.count, al);
			free(al);
			if (rc != RUN_OK) {
				snprintf(msg, msglen, "state field %s does not fit the scene", f.name);
				goto bad;
			}
			continue;
		}
		for (k = 0; k < N_SCHED && strcmp(sched[k].name, f.name); k++)
			;
		if (k < N_SCHED && f.count == 1 && f.type == (sched[k].is_double ? ED_T_F64 : ED_T_U64)) {
			memcpy((char *)&st + sched[k].off, data, 8);
			got += !sched[k].optional;
		} else if (!strcmp(f.name, "@done") && f.type == ED_T_U64 && f.count == 1) {
			memcpy(&done, data, 8);
			got++;
		} else if (!strcmp(f.name, "@status") && f.type == ED_T_U64 && f.count == 1) {
			memcpy(&status, data, 8);
			got++;
		} else if (!strcmp(f.name, "@last") && f.type == ED_T_F64 &&
		           (f.count == ENSEMBLE_NV || f.count == ENSEMBLE_NV_V4 || f.count == ENSEMBLE_NV_V3 ||
		            f.count == ENSEMBLE_NV_V2 || f.count == ENSEMBLE_NV_V1)) {
			/* an older version's record has no structure observables: zeros */
			double v[ENSEMBLE_NV] = {0};
			memcpy(v, data, f.count * sizeof(double));
			ensemble_unpack(v, s, &last);
			have_last = 1;
		} else {
			snprintf(msg, msglen, "unknown replica field %s", f.name);
			goto bad;
		}
	}
	for (size_t k = 0; k < N_SCHED; k++)
		need += !sched[k].optional;
	if (rc < 0 || got != need || !have_last || done > 1 || status > RUN_INTERRUPTED) {
		snprintf(msg, msglen, "replica state malformed or incomplete");
		goto bad;
	}
	run_set_state(r, &st);
	if (run_restore_finish(r, msg, msglen) != RUN_OK)
		goto bad;
	run_set_finish(r, &last, (int)done, (run_status_t)status);
	*out = r;
	return RUN_OK;
bad:
	run_destroy(r);
	return RUN_ERESTORE;
}

int ensemble_blob_u64(const unsigned char *buf, size_t len, const char *name, uint64_t *v)
{
	size_t pos = 0;
	ed_field_t f;
	const void *data;
	int rc;
	while ((rc = ensemble_next_field(buf, len, &pos, &f, &data)) == 1)
		if (!strcmp(f.name, name)) {
			if (f.type != ED_T_U64 || f.count != 1)
				return -1;
			memcpy(v, data, 8);
			return 0;
		}
	return rc < 0 ? -1 : 1;
}
