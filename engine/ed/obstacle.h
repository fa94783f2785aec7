/* Contact times of a particle with a fixed disk/sphere (an obstacle), in free flight or under uniform gravity, and the obstacle's collision rule (shared by ed and dsmc/hsmc). */
#pragma once

#include "rng.h"

/*
 * Contract
 * - Pure functions of their arguments: no state, no I/O, no allocation.
 * - The particle's centre relative to the obstacle's is d(t) = x + v t +
 *   g t^2 / 2 (dim components, t from now); contact at |d| = S (obstacle
 *   radius plus particle radius). With f(t) = |d|^2 - S^2, a contact is the
 *   first t >= 0 with f <= 0 and f' < 0 (touching or inside, approaching),
 *   or, for a particle at or inside the contact distance and moving away,
 *   the moment it would turn back (f' = 0 with f <= 0). Times are >= 0;
 *   INFINITY means none (within the horizon, with gravity).
 * - Never a missed contact: a particle inside by rounding and approaching
 *   gets 0 (contact now); one just reflected (f ~ 0, f' > 0) is not given
 *   the same contact again.
 */

/* Free flight (g = 0): the quadratic in closed form, without cancellation
 * (like a pair prediction with a partner at rest). */
double obstacle_time_free(const double *x, const double *v, int dim, double S);

/* Uniform gravity g: f is a quartic. The time axis [0, horizon] (horizon
 * finite) is cut at the roots of f'' (a quadratic, closed form); on each
 * piece f is convex or concave, so its first contact is decided by the
 * ends and at most two bracketed monotone root searches (regula falsi
 * alternating with bisection, to adjacent doubles). The first contact in
 * [0, horizon], else INFINITY. */
double obstacle_time_grav(const double *x, const double *v, const double *g, int dim, double S, double horizon);

/* Velocity v (dim components) of a particle meeting an obstacle of type
 * SCENE_OBST_* with unit normal nrm (from the obstacle's centre to the
 * particle's): normal restitution r (slip: v_n' = -r v_n; random_sign: also
 * the tangential velocity reversed with probability 1/2; no_slip: with
 * probability acc re-emitted from the flux-weighted Maxwellian of speed
 * scale sv = sqrt(T_o / m), a Rayleigh normal and a Gaussian tangential
 * velocity, else as slip). Only an approaching particle (v_n < 0) is
 * changed; relaxing: v_n' = |v_n| (an elastic pre-run: no random numbers).
 * A rebound slower than vmin is raised to it (not when relaxing; -INFINITY:
 * never). Random numbers from rng, in a fixed order. */
void obstacle_rule(int type, double r, double acc, double sv, double vmin, int relaxing, const double *nrm, double *v,
                   int dim, rng_t *rng);
