/* Velocity distribution: Sonine coefficients a2, a3 and histograms of the velocity components and the speed in units of the thermal speed. */
#pragma once

#include <stddef.h>

/*
 * Contract
 * - Pure functions over a velocity array (n*dim doubles, particle-major);
 *   no allocation, no I/O. dim is 2 or 3, n >= 1.
 * - Peculiar velocities w = v - <v> (the mean over the particles), the
 *   temperature T = m <w^2> / dim (k_B = 1) and the scaled velocity
 *   c = w / v_T with the thermal speed v_T = sqrt(2 T / m), as in the
 *   kinetic theory of the homogeneous cooling state (van Noije & Ernst,
 *   Granular Matter 1, 57 (1998); Brilliantov & Poeschel, ch. 7).
 * - Sonine coefficients from the moments of c^2:
 *     <c^4> = d(d+2)/4 (1 + a2),  <c^6> = d(d+2)(d+4)/8 (1 + 3 a2 - a3),
 *   so a2 = a3 = 0 for a Maxwellian.
 */

typedef struct {
	double temperature;   /* T = m <w^2> / dim of the peculiar velocities */
	double mean[3];       /* <v> per axis */
	double a2, a3;        /* NaN when T = 0 */
} vdist_moments_t;

void vdist_moments(int dim, size_t n, double mass, const double *vel, vdist_moments_t *out);

/* Histograms with `bins` bins of the components c_a in [-range, range) (comp: dim*bins doubles, axis-major)
 * and of the speed |c| in [0, range) (speed: bins doubles), as probability densities: count / (n * width),
 * so a Maxwellian gives pi^(-1/2) exp(-c_a^2) and 2 |c|^(d-1) exp(-c^2) / Gamma(d/2). Values outside the
 * range are not counted (the densities then integrate to slightly less than 1). m from vdist_moments(). */
void vdist_histograms(int dim, size_t n, double mass, const double *vel, const vdist_moments_t *m, int bins,
                      double range, double *comp, double *speed);

/* The Maxwellian densities of the same quantities at c (for tests and clients). */
double vdist_maxwell_component(double c);
double vdist_maxwell_speed(int dim, double c);
