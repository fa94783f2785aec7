/* Shared by the physics tests: run a scene into a series of records, and kinetic-theory formulas written independently of the engine. */
#pragma once

#include <math.h>
#include <string.h>
#include "run.h"
#include "scene.h"
#include "tap.h"

#define PI 3.14159265358979323846

/* Records of one run, collected through the same run_scene()/emit path the
 * engine program uses, so the tested numbers are the ones users see. */
typedef struct {
	int n;
	run_record_t rec[4096];
} series_t;

static int collect(const run_record_t *r, void *ctx)
{
	series_t *s = ctx;
	if (r->kind == RUN_PROGRESS && s->n < 4096)
		s->rec[s->n++] = *r;
	return 0;
}

static inline int run_json(const char *json, series_t *out)
{
	scene_t sc;
	char err[512];
	out->n = 0;
	if (scene_parse(json, strlen(json), &sc, err, sizeof(err)) != SCENE_OK) {
		diag("scene rejected: %s", err);
		return -1;
	}
	if (run_scene(&sc, collect, out, NULL, err, sizeof(err)) != RUN_OK) {
		diag("run failed: %s", err);
		return -1;
	}
	return 0;
}

/* Contact value of the pair correlation: Henderson (2D), Carnahan-Starling (3D). */
static inline double g_contact(int dim, double nu)
{
	return dim == 2 ? (1 - 7 * nu / 16) / ((1 - nu) * (1 - nu)) : (1 - nu / 2) / pow(1 - nu, 3);
}
