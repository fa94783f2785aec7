/* Contact times of a particle with a plane under constant acceleration (cell faces, fixed walls) and with a sinusoidally vibrating wall. */
#pragma once

#include <math.h>

/*
 * Contract
 * - Pure functions of their arguments: no state, no I/O, no allocation.
 * - One coordinate along the plane's normal, pointing away from the plane
 *   into the particle's side ("inward"): the particle's gap to the plane
 *   (for a wall: centre distance minus radius) is
 *       h(t) = d + u t + gam t^2 / 2              (walltime_plane)
 *       h(t) = d + u t + gam t^2 / 2 - A (sin(theta0 + omega t) - sin theta0)
 *                                                  (walltime_vibrating)
 *   with t measured from now. A contact is the first t >= 0 at which the
 *   particle is at or beyond the plane (h <= 0) and approaching it
 *   (h' < 0), or, when it starts at or beyond the plane and moving away,
 *   the moment it would turn back (h' = 0 with h <= 0). Times are >= 0;
 *   INFINITY means no contact (within the horizon, for the vibrating wall).
 * - Never a missed contact: a particle that is beyond the plane and
 *   approaching gets 0 (contact now); one that has just been reflected
 *   (h ~ 0 by rounding, h' > 0) is not given the same contact again.
 */

/* Plane at rest, constant acceleration gam along the inward normal
 * (gravity towards the plane: gam < 0). Cancellation-free roots: for
 * gam < 0 the later root (u + s)/G is computed as 2d/(s - u) when u < 0,
 * for gam > 0 the earlier root as 2d/(s - u). */
static inline double walltime_plane(double d, double u, double gam)
{
	if (gam == 0.0)
		return u < 0.0 ? (d > 0.0 ? d / -u : 0.0) : INFINITY;
	if (gam < 0.0) {
		/* pulled towards the plane: it always gets there */
		const double G = -gam, disc = u * u + 2.0 * G * d;
		const double s = disc > 0.0 ? sqrt(disc) : 0.0;   /* < 0: beyond the plane at the apex: turns there */
		const double t = u >= 0.0 ? (u + s) / G : 2.0 * d / (s - u);
		return t > 0.0 ? t : 0.0;
	}
	/* pushed away: only a particle approaching fast enough gets there */
	if (u >= 0.0)
		return INFINITY;
	const double disc = u * u - 2.0 * gam * d;
	if (disc < 0.0)
		return INFINITY;
	const double t = 2.0 * d / (sqrt(disc) - u);
	return t > 0.0 ? t : 0.0;
}

/* The wall is displaced along the inward normal by A sin(theta0 + omega t)
 * (A >= 0, omega > 0); d is the gap now (wall displacement included). The
 * first contact in [0, horizon] (horizon finite), else INFINITY. The time
 * axis is cut where h'' = gam + A omega^2 sin(theta) changes sign (closed
 * form); on each piece h is convex or concave, so the first contact there is
 * decided by the ends and at most one monotone root search (bracketed:
 * regula falsi alternating with bisection, to the last bit). Cost: a few
 * sine evaluations per half period of the wall plus ~2x60 for a contact. */
double walltime_vibrating(double d, double u, double gam, double A, double omega, double theta0, double horizon);
