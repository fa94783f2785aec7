/* Tests of the bench-only event trace of the ed engine (-DED_TRACE build, ed.h "Event trace"): complete, ordered, geometrically consistent. */
#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "tap.h"
#include "ed/ed.h"
#include "scene.h"

typedef struct {
	int dim, nc[3];
	uint64_t n, coll, cross, cancelled;
	double last_t;
	int ordered, cross_adjacent, partner_near, in_grid;
} check_t;

/* At most one cell apart on every axis, periodic minimum image. */
static int near(const check_t *c, const int32_t *a, const int32_t *b)
{
	for (int k = 0; k < c->dim; k++) {
		int d = abs(a[k] - b[k]);
		if (c->nc[k] - d < d)
			d = c->nc[k] - d;
		if (d > 1)
			return 0;
	}
	return 1;
}

static void on_event(void *ctx, const ed_trace_t *ev)
{
	check_t *c = ctx;
	c->n++;
	c->ordered &= ev->t >= c->last_t;
	c->last_t = ev->t;
	for (int k = 0; k < c->dim; k++)
		c->in_grid &= ev->ci[k] >= 0 && ev->ci[k] < c->nc[k] && ev->cj[k] >= 0 && ev->cj[k] < c->nc[k];
	if (ev->kind == ED_TRACE_CROSS) {
		/* the cell entered differs from the cell left on exactly one axis, by one (wrapped) */
		int axes = 0;
		for (int k = 0; k < c->dim; k++)
			axes += ev->ci[k] != ev->cj[k];
		c->cross_adjacent &= axes == 1 && near(c, ev->ci, ev->cj);
		c->cross++;
	} else {
		/* a collision partner is in contact: within the 3^D stencil of cells
		 * (a cancelled prediction's partner has moved on: anywhere) */
		if (ev->kind == ED_TRACE_COLLISION) {
			c->partner_near &= near(c, ev->ci, ev->cj);
			c->coll++;
		} else {
			c->cancelled++;
		}
	}
}

static void run(int dim, long n, double phi, double e, double tc)
{
	char json[512], err[256];
	snprintf(json, sizeof json,
	         "{\"method\":\"ed\",\"dimensions\":%d,\"particles\":{\"count\":%ld,\"volume_fraction\":%g,"
	         "\"initial\":{\"relax\":{\"collisions_per_particle\":2}}},"
	         "\"collisions\":{\"restitution\":%g,\"tc\":%g},\"run\":{\"until\":{\"time\":1}}}",
	         dim, n, phi, e, tc);
	scene_t sc;
	int rc;
	if (!ok(scene_parse(json, strlen(json), &sc, err, sizeof err) == SCENE_OK, "%dD scene parses", dim))
		return;
	ed_t *ed = ed_create(&sc, &rc, err, sizeof err);
	if (!ok(ed != NULL, "%dD N=%ld phi=%g e=%g: engine created", dim, n, phi, e))
		return;
	check_t c = {.dim = dim, .ordered = 1, .cross_adjacent = 1, .partner_near = 1, .in_grid = 1, .last_t = -INFINITY};
	int cells[3];
	ed_cells(ed, cells);
	for (int k = 0; k < 3; k++)
		c.nc[k] = cells[k];
	ok(ed_trace(ed, on_event, &c) == ED_OK, "ed_trace accepts a periodic cell-mode scene");
	const uint64_t e0 = ed_events(ed), c0 = ed_collisions(ed);
	ed_advance(ed, INFINITY, c0 + 20 * (uint64_t)n, UINT64_MAX);   /* 40 collisions per particle (ed_bench's count) */
	const uint64_t ne = ed_events(ed) - e0, nc = ed_collisions(ed) - c0;
	ok(c.n == ne && c.coll == nc, "one record per event (%llu of %llu) and per collision (%llu of %llu)",
	   (unsigned long long)c.n, (unsigned long long)ne, (unsigned long long)c.coll, (unsigned long long)nc);
	ok(c.cross > 0 && c.coll > 0, "crossings (%llu), collisions, cancelled predictions (%llu) all seen",
	   (unsigned long long)c.cross, (unsigned long long)c.cancelled);
	ok(c.ordered, "event times never decrease (absolute times across clock rebases)");
	ok(c.in_grid, "every cell lies in the %dx%dx%d grid", c.nc[0], c.nc[1], c.nc[2]);
	ok(c.cross_adjacent, "each crossing enters a face neighbour of the cell it leaves (wrap included)");
	ok(c.partner_near, "each collision partner lies in a neighbouring cell");
	ok(fabs(c.last_t - ed_time(ed)) <= 1e-9 * (1.0 + ed_time(ed)), "last event time %.12g = the engine clock %.12g",
	   c.last_t, ed_time(ed));
	/* the trace off again: no more calls */
	ed_trace(ed, NULL, NULL);
	uint64_t before = c.n;
	ed_advance(ed, INFINITY, ed_collisions(ed) + 100, UINT64_MAX);
	ok(c.n == before, "ed_trace(NULL) stops the calls");
	ed_destroy(ed);
}

int main(void)
{
	run(2, 3000, 0.3, 1.0, 0.0);
	run(3, 4000, 0.25, 0.8, 1e-4);
	/* a dense 2D gas runs with neighbour lists: no crossing events, refused */
	{
		const char *json = "{\"method\":\"ed\",\"dimensions\":2,\"particles\":{\"count\":2000,\"volume_fraction\":0.7},"
		                   "\"run\":{\"until\":{\"time\":1}}}";
		char err[256];
		scene_t sc;
		int rc;
		ed_t *ed = scene_parse(json, strlen(json), &sc, err, sizeof err) == SCENE_OK ? ed_create(&sc, &rc, err, sizeof err) : NULL;
		ok(ed && ed_trace(ed, on_event, NULL) == ED_EINVAL, "neighbour-list mode (2D, 0.7) is refused");
		ed_destroy(ed);
	}
	plan(tap_n);
	return done_testing();
}
