/* Helpers shared by the event-driven engine's unit tests: a scene made into an engine, and an engine copied through its state fields as a checkpoint copies it. */
#ifndef GRANULAR_TESTS_ED_UTIL_H
#define GRANULAR_TESTS_ED_UTIL_H

#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "ed/ed.h"
#include "scene.h"
#include "tap.h"

/* The engine of the scene given as JSON, parsed into *sc; NULL (with a TAP
 * diagnostic naming the reason) when the parser or the engine refuses it.
 * The caller destroys the engine. */
static inline ed_t *make(const char *json, scene_t *sc)
{
	char err[512];
	int rc;
	if (scene_parse(json, strlen(json), sc, err, sizeof(err)) != SCENE_OK) {
		diag("scene rejected: %s", err);
		return NULL;
	}
	ed_t *ed = ed_create(sc, &rc, err, sizeof(err));
	if (!ed)
		diag("ed_create: %s", err);
	return ed;
}

/* A blank engine of scene sc given every state field of a (ed_fields,
 * ed_field_get, ed_field_set) and finished as a restore finishes: what a
 * checkpoint and its reader do, without the file. With want, *has is set to
 * whether a has a field of that name (and, with count > 0, that many
 * elements). NULL with the reason in msg on failure; the caller destroys. */
static inline ed_t *clone_fields(const ed_t *a, const scene_t *sc, const char *want, size_t count, int *has,
                                 char *msg, size_t msglen)
{
	int rc, good;
	ed_field_t f[ED_MAX_FIELDS];
	ed_t *b = ed_create_blank(sc, &rc, msg, msglen);
	int nf = ed_fields(a, f, ED_MAX_FIELDS);
	if (has)
		*has = 0;
	good = b && nf <= ED_MAX_FIELDS;
	for (int k = 0; k < nf && good; k++) {
		void *buf = malloc(f[k].count * ed_type_size(f[k].type) + 1);
		if (want && has && !strcmp(f[k].name, want) && (count == 0 || f[k].count == count))
			*has = 1;
		good = buf && ed_field_get(a, f[k].name, buf) == ED_OK &&
		       ed_field_set(b, f[k].name, f[k].type, f[k].count, buf) == ED_OK;
		free(buf);
	}
	if (good && ed_restore_finish(b, msg, msglen) == ED_OK)
		return b;
	ed_destroy(b);
	return NULL;
}

/* The scene's engine a run to t_ckpt (sampled once at t_sample < t_ckpt, so
 * the sampling state is in the copy too) and b its copy through the state
 * fields (clone_fields). 1 with both set; 0 with both NULL and a TAP
 * diagnostic when the scene, the engine or the copy fails. The caller
 * destroys both. */
static inline int checkpoint_pair(const char *json, scene_t *sc, double t_sample, double t_ckpt, ed_t **pa,
                                  ed_t **pb)
{
	char msg[256] = "";
	ed_t *a = make(json, sc), *b = NULL;
	if (a) {
		ed_sample_t s0;
		ed_advance(a, t_sample, UINT64_MAX, UINT64_MAX);
		ed_sample(a, &s0);
		ed_advance(a, t_ckpt, UINT64_MAX, UINT64_MAX);
		b = clone_fields(a, sc, NULL, 0, NULL, msg, sizeof msg);
		if (!b)
			diag("restore: %s", msg);
	}
	if (!b) {
		ed_destroy(a);
		a = NULL;
	}
	*pa = a, *pb = b;
	return b != NULL;
}

/* Scenes with slots (reservoir and dispenser walls), D dimensions: whether a and b hold the same state of every
 * slot, positions, velocities and particle ids, bit for bit. 0 also when out of memory. */
static inline int same_slots_d(const ed_t *a, const ed_t *b, int D)
{
	const size_t N = ed_slots(a), m = N * (size_t)D;
	double *p = malloc(sizeof(double) * m * 4);
	int64_t *ia = malloc(sizeof(int64_t) * N * 2);
	int same = 0;
	if (p && ia && ed_slots(b) == N) {
		ed_state(a, p, p + m);
		ed_state(b, p + 2 * m, p + 3 * m);
		ed_labels(a, ia);
		ed_labels(b, ia + N);
		same = !memcmp(p, p + 2 * m, 2 * m * sizeof(double)) && !memcmp(ia, ia + N, N * sizeof(int64_t));
	}
	free(p);
	free(ia);
	return same;
}

/* The same in 2D. */
static inline int same_slots(const ed_t *a, const ed_t *b)
{
	return same_slots_d(a, b, 2);
}

#endif
