/* Exact event-driven simulation of inelastic hard disks (2D) and spheres (3D) in a periodic box. */
#pragma once

#include <stdint.h>
#include "scene.h"

/*
 * Contract
 * - Pure computation: no I/O, no globals, no allocation per event. All
 *   memory is allocated in ed_create() and freed in ed_destroy().
 * - Units are the scene's (lengths, masses, k_B = 1). Times are absolute
 *   simulated times since the start of the production run (after the
 *   optional elastic pre-run, which does not count).
 * - Determinism: for one scene (including its seed) the sequence of events
 *   and every number derived from it is identical from run to run and does
 *   not depend on how often the caller samples (sampling never moves
 *   particles; see docs/engine.md, "Precision").
 */

typedef struct ed ed_t;

enum {
	ED_OK = 0,
	ED_ENOMEM = -1,
	ED_EPLACE = -2,    /* initial positions could not be placed */
	ED_EINVAL = -3,    /* scene not usable by this method */
	ED_QUIESCENT = 1,  /* ed_advance: no further event can ever happen */
};

/* Build the initial state (positions, Maxwellian velocities with zero total
 * momentum, optional elastic pre-run). Returns NULL on failure with *err set
 * and a one-line reason in msg (msglen bytes; msg may be NULL). */
ed_t *ed_create(const scene_t *s, int *err, char *msg, size_t msglen);
void ed_destroy(ed_t *ed);

/* Process events in time order until the next event would lie beyond
 * t_stop, or the total collision count reaches max_collisions, or
 * max_events further events were processed, whichever comes first. Use
 * INFINITY / UINT64_MAX for "no limit". When stopped by t_stop the clock is
 * set to t_stop. Returns ED_OK, or ED_QUIESCENT when no event remains (the
 * clock is then set to t_stop if finite). */
int ed_advance(ed_t *ed, double t_stop, uint64_t max_collisions, uint64_t max_events);

/* Interval statistics since the previous ed_sample() (or the start). */
typedef struct {
	double time;             /* current simulated time */
	double interval;         /* length of the interval */
	uint64_t events;         /* totals since the start */
	uint64_t collisions;
	uint64_t interval_collisions;
	uint64_t elastic_by_tc;  /* collisions made elastic by the TC model (total) */
	double kinetic_energy;   /* total, exact from velocities, now */
	double momentum[3];      /* total, now */
	double ekin_time_integral;  /* integral of E_kin dt over the interval */
	double virial;           /* sum over collisions in the interval of r_ij . J_ij */
} ed_sample_t;

/* Fill *out and start a new interval. Does not change the dynamics. */
void ed_sample(ed_t *ed, ed_sample_t *out);

/* Positions (wrapped into the box) and velocities at the current time, as
 * N*D doubles in particle order. Either pointer may be NULL. */
void ed_state(const ed_t *ed, double *pos, double *vel);

double ed_time(const ed_t *ed);
uint64_t ed_collisions(const ed_t *ed);
uint64_t ed_events(const ed_t *ed);
/* Smallest pair distance minus the contact distance (negative = overlap);
 * O(N) via the cell list. For tests and diagnostics. */
double ed_min_gap(const ed_t *ed);
/* Cell grid in use (cells per axis) and memory held, for benchmarks. */
void ed_cells(const ed_t *ed, int cells[3]);
size_t ed_memory(const ed_t *ed);

const char *ed_strerror(int code);
