/* Ensemble statistics over replica records: pack to vectors, mean and standard error in replica order. */
#include <math.h>
#include <string.h>

#include "ensemble.h"

enum {
	V_TIME, V_CPP, V_EVENTS, V_COLL, V_EKIN, V_TEMP, V_P, V_Z, V_RATE, V_MOM0, V_MOM1, V_MOM2,
	V_LFRAC, V_MSIZE, V_M2, V_M2R, V_NCL, V_LARGEST, V_NBINS, V_DONE, V_HAVEI, V_STATUS,
	V_VMAX, V_CELLC, V_REJ, V_TC, V_HIST
};

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
