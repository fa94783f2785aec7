/* Mean-square displacement from unwrapped positions: the displacement of each particle since the run's start, followed across periodic images. */
#pragma once

#include <stddef.h>
#include <stdint.h>

/*
 * Contract
 * - The engines keep positions folded into the box. msd_t unwraps them: each
 *   update adds the minimum image of the change since the previous update
 *   to the particle's unwrapped position. That is exact when no particle
 *   moved half a box edge between two updates; msd_due() gives the latest
 *   time of the next update that guarantees `reach` edges (msd_create(),
 *   below 1/2): with the kinetic
 *   energy E non-increasing (no walls, no gravity: restitution <= 1 only
 *   loses energy), no particle is faster than sqrt(2 E / m) at any later
 *   time. (dsmc/hsmc with the CBA correction also move colliding partners
 *   by a diameter: not in the bound; docs/output.md.)
 * - Walls and gravity (msd_walls()): walled axes are not unwrapped (a wall
 *   has no image: the position is the displacement's own coordinate), and
 *   only the periodic edges enter the bound (none periodic: no update is
 *   ever due). Gravity along walled axes turns potential energy into
 *   kinetic energy: the bound then takes E = E_kin + sum_i m (u_i - u_min),
 *   u = -g . r and u_min its least value on the contact planes, which no
 *   particle can exceed while the mechanical energy does not grow (walls
 *   that do not feed energy: specular, rough; no driving; for rough
 *   particles ekin must include the rotational energy: the caller's to
 *   ensure).
 * - pos: N*D doubles in scene particle order, folded into [0, L). Times are
 *   the run's clock; units of the scene (diameter from the scene radius).
 * - Varying particle sets (msd_varying(): open, reservoir or dispenser
 *   walls, a source): rows of absent particles are NaN. The MSD at t is
 *   over the members: the particles present at the origin and at every
 *   update since (one that leaves is dropped for good; with labels, so is
 *   one whose row holds another particle's label, a slot refilled between
 *   updates). Particles that enter after the origin are never members. The
 *   speed bound covers the members when the energy of the particles present
 *   cannot grow (leaving only removes energy); entries feed energy: the
 *   caller then passes exact unwrapped positions (msd_exact()).
 * - No I/O, no globals; msd_create() allocates everything (2 N D doubles;
 *   msd_varying(): N more, 2 N with labels).
 */

typedef struct msd msd_t;

/* NULL when out of memory. box: D edge lengths; reach in (0, 1/2): the largest move between updates
 * msd_due() allows, in smallest box edges (less than 1/2 leaves room for an engine that stops after
 * the time asked for). */
msd_t *msd_create(int dim, size_t n, const double *box, double mass, double reach);
void msd_destroy(msd_t *m);

/* Mixtures (particles of several masses), once after msd_create(): no particle is faster than
 * sqrt(2 E / lightest), and the potential energy gravity can release is at most heaviest sum_i (u_i - u_min).
 * 0, or -1 on bad arguments (0 < lightest <= heaviest). */
int msd_masses(msd_t *m, double lightest, double heaviest);

/* Walls and gravity, once after msd_create(): walled[dim] (nonzero: walls, no unwrapping), gravity[dim]
 * (zero on periodic axes), radius (the contact planes, radius from each wall). 0, or -1 on bad arguments
 * (gravity along a periodic axis, no room between walls). */
int msd_walls(msd_t *m, const int *walled, const double *gravity, double radius);

/* Exact mode, once after msd_create() and before msd_walls(): the caller passes positions already unwrapped
 * (an engine that counts the periodic images crossed: ed_unwrapped()); no speed bound, msd_due() is
 * INFINITY, ekin is ignored, and gravity may point along a periodic axis. */
void msd_exact(msd_t *m);

/* Varying particle set, once after msd_create() (before msd_origin()): absent rows are NaN, and the mean
 * is over the members (the contract). labelled: the caller gives each row's particle label by msd_ids()
 * (slots reused by entering particles). 0, or -1 when out of memory or already set. */
int msd_varying(msd_t *m, int labelled);
/* Labelled varying sets: call right after each msd_origin() (records the members' labels; a row with a
 * negative label is no member) and msd_update() (drops the members whose label changed). ids: N labels. */
void msd_ids(msd_t *m, const int64_t *ids);

/* The origin: positions at time t, with total kinetic energy ekin (the speed bound). */
void msd_origin(msd_t *m, double t, const double *pos, double ekin);
/* Follow the particles to pos at time t (t >= the previous update's). */
void msd_update(msd_t *m, double t, const double *pos, double ekin);
/* Latest time of the next update (INFINITY when nothing moves). */
double msd_due(const msd_t *m);

/* Mean over particles (varying sets: the members) of |r(t) - r(0)|^2 (length^2) at the last update, and
 * its standard error (sample standard deviation / sqrt(N): particles taken
 * as independent) into *se (may be NULL). NaN without members. */
double msd_value(const msd_t *m, double *se);
/* Particles the mean is over: N, or the members of a varying set. */
size_t msd_count(const msd_t *m);
/* Varying sets: the mean over the members now of the growth of their squared displacement along the
 * periodic axes (every axis without walls) since the previous call (or the origin), the same particles at
 * both ends; stores the present values for the next call. NaN without members, without a periodic axis or
 * for a fixed set (there the difference of msd_value()s is the same). */
double msd_interval(msd_t *m);
/* Mean over particles of the squared displacement summed over the walled axes (walled != 0) or over the
 * periodic ones (walled == 0) at the last update; NaN when there is no such axis. */
double msd_value_axes(const msd_t *m, int walled);
/* Time of the origin and of the last update. */
double msd_time0(const msd_t *m);
double msd_time(const msd_t *m);

/* State for checkpoints: msd_state_size() doubles (origin, unwrapped positions, times, energy; varying
 * sets: each row's squared displacement at the last msd_interval() and, labelled, its origin label). */
size_t msd_state_size(const msd_t *m);
void msd_state_get(const msd_t *m, double *v);
/* 0, or -1 when a value is not finite (varying sets: NaN origin rows mark the particles not members). */
int msd_state_set(msd_t *m, const double *v);
