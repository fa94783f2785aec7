/* Helpers shared by the Monte Carlo tests: an engine from a scene text, and a restore from the engine's own checkpoint fields. */
#pragma once

#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "ed/ed.h"   /* ED_T_F64: the field types */
#include "mc/dsmc.h"
#include "scene.h"
#include "tap.h"

/* Temperature of species s (k_B = 1) from a sample of a dim-dimensional mixture. */
static inline double tspec(const dsmc_sample_t *sm, int s, int dim)
{
	return 2 * sm->species_kinetic_energy[s] / (dim * (double)sm->species_count[s]);
}

/* 2D: the velocities of every particle whose id is first or above scaled by f, through the checkpoint fields
 * "particles" (x, y, v_x, v_y per record) and "id" (a hot species, the scene's last block of ids). */
static inline void mc_scale_ids_2d(dsmc_t *d, uint64_t n, uint32_t first, double f)
{
	size_t np = n * 4;
	double *p = malloc(np * sizeof(double));
	uint32_t *id = malloc(n * sizeof(uint32_t));
	if (p && id) {
		dsmc_field_get(d, "particles", p);
		dsmc_field_get(d, "id", id);
		for (uint64_t k = 0; k < n; k++)
			if (id[k] >= first)
				for (int a = 0; a < 2; a++)
					p[k * 4 + 2 + a] *= f;
		dsmc_field_set(d, "particles", ED_T_F64, np, p);
	}
	free(p);
	free(id);
}

/* The engine of scene json (parsed into *sc) on random stream stream; NULL (with a diagnostic) when the scene
 * or the engine refuses. */
static inline dsmc_t *mc_make(const char *json, scene_t *sc, uint64_t stream)
{
	char err[512];
	int rc;
	if (scene_parse(json, strlen(json), sc, err, sizeof(err)) != SCENE_OK) {
		diag("scene rejected: %s", err);
		return NULL;
	}
	dsmc_t *d = dsmc_create(sc, stream, &rc, err, sizeof(err));
	if (!d)
		diag("dsmc_create: %s", err);
	return d;
}

/* Kinetic plus potential energy now (no gravity: the kinetic energy alone). */
static inline double mc_energy(const dsmc_t *d)
{
	dsmc_sample_t sm;
	dsmc_totals(d, &sm);
	return sm.kinetic_energy + (isnan(sm.potential_energy) ? 0.0 : sm.potential_energy);
}

/* The largest relative change of mc_energy() from its start over rounds of `steps` steps each (NaN when d
 * is NULL); the totals after the last round into *sm. */
static inline double mc_energy_drift(dsmc_t *d, int rounds, uint64_t steps, dsmc_sample_t *sm)
{
	double e0 = d ? mc_energy(d) : NAN, worst = 0;
	for (int k = 0; d && k < rounds; k++) {
		dsmc_advance(d, INFINITY, UINT64_MAX, steps);
		double rel = fabs(mc_energy(d) - e0) / e0;
		worst = rel > worst ? rel : worst;
	}
	memset(sm, 0, sizeof(*sm));
	if (d)
		dsmc_totals(d, sm);
	return d ? worst : NAN;
}

/* What a resume does: b's checkpoint fields copied out, b destroyed, a blank engine of scene sc given the
 * fields and finished. The new engine, or NULL (err says why). */
static inline dsmc_t *mc_reload(dsmc_t *b, const scene_t *sc, char *err, size_t errlen)
{
	ed_field_t f[DSMC_MAX_FIELDS];
	void *data[DSMC_MAX_FIELDS];
	int e, nf = dsmc_fields(b, f, DSMC_MAX_FIELDS);
	for (int j = 0; j < nf; j++) {
		data[j] = malloc(f[j].count * ed_type_size(f[j].type) + 1);
		dsmc_field_get(b, f[j].name, data[j]);
	}
	dsmc_destroy(b);
	b = dsmc_create_blank(sc, &e, err, errlen);
	for (int j = 0; b && j < nf; j++)
		if (dsmc_field_set(b, f[j].name, f[j].type, f[j].count, data[j]) != DSMC_OK)
			snprintf(err, errlen, "field %s refused", f[j].name);
	if (b && dsmc_restore_finish(b, err, errlen) != DSMC_OK) {
		dsmc_destroy(b);
		b = NULL;
	}
	for (int j = 0; j < nf; j++)
		free(data[j]);
	return b;
}

/* Two engines of scene json (parsed into *sc) advanced alike for 40 rounds of 1..5 steps, the second reloaded
 * from its own checkpoint fields after every round (mc_reload()); *same_samples whether their samples agreed
 * at every third round, *restores how many reloads were made, *last the first engine's final sample. Returns
 * 1 when the final positions, velocities and samples are bit-identical, 0 otherwise (err says why when an
 * engine could not be made or reloaded). Both engines are destroyed. */
static inline int mc_restore_run(const char *json, scene_t *sc, int *same_samples, int *restores, dsmc_sample_t *last,
                                 char *err, size_t errlen)
{
	dsmc_t *a = mc_make(json, sc, 0), *b = mc_make(json, sc, 0);
	*same_samples = 1;
	*restores = 0;
	for (int it = 0; a && b && it < 40; it++) {
		dsmc_advance(a, INFINITY, UINT64_MAX, 1 + it % 5);
		dsmc_advance(b, INFINITY, UINT64_MAX, 1 + it % 5);
		if (it % 3 == 0) {
			dsmc_sample_t x, y;
			dsmc_sample(a, &x);
			dsmc_sample(b, &y);
			*same_samples &= memcmp(&x, &y, sizeof x) == 0;
		}
		b = mc_reload(b, sc, err, errlen);
		(*restores)++;
	}
	int same = 0;
	dsmc_sample_t y = {0};
	memset(last, 0, sizeof(*last));
	if (a && b) {
		size_t bytes = sc->count * (size_t)sc->dim * sizeof(double);
		double *pa = malloc(bytes), *pb = malloc(bytes), *va = malloc(bytes), *vb = malloc(bytes);
		dsmc_state(a, pa, va);
		dsmc_state(b, pb, vb);
		dsmc_sample(a, last);
		dsmc_sample(b, &y);
		same = pa && pb && va && vb && !memcmp(pa, pb, bytes) && !memcmp(va, vb, bytes) &&
		       !memcmp(last, &y, sizeof y);
		free(pa), free(pb), free(va), free(vb);
	}
	dsmc_destroy(a);
	dsmc_destroy(b);
	return same;
}
