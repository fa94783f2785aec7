/* Velocity correlations (seed 000 sec. 3.6): G_nn, G_par, G_perp in real space and the longitudinal and transverse velocity structure factors in k. */
#pragma once

#include <stddef.h>
#include "observe/fgrid.h"

/*
 * Definitions (w = peculiar velocity, T = m <w^2> / D, k_B = 1):
 * - Real space, over the pairs at distance r (pair sums from gofr_pairs()):
 *     G_par(r)  = < (w_i . e)(w_j . e) > / (T/m),
 *     G_perp(r) = < w_i . w_j - (w_i . e)(w_j . e) > / ((D-1) T/m),
 *   e the unit vector between the pair: correlation coefficients, 0 for
 *   uncorrelated velocities; G_par > 0 when neighbours move together along
 *   their separation, G_perp > 0 for common motion across it (shear,
 *   vortices). The seed's G_par = e_a e_b G_ab with
 *   G_ab(r) = (1/V) int <u_a(r + r') u_b(r')> equals n^2 g(r) (T/m) G_par(r)
 *   here (u = sum_j w_j delta(r - r_j)); G_nn = n^2 (g(r) - 1) plus the
 *   self term.
 * - k space, with j(k) = sum_j w_j exp(-i k.r_j) and khat = k/|k|:
 *     S_par(k)  = < |khat . j(k)|^2 > / (N T/m),
 *     S_perp(k) = < |j(k) - khat (khat . j(k))|^2 > / ((D-1) N T/m),
 *   both 1 for velocities uncorrelated with each other and with the
 *   positions (an elastic gas in equilibrium); in a cooling granular gas
 *   S_perp grows at small k when the shear mode goes unstable, before
 *   clusters form (van Noije et al., PRL 79, 411 (1997)).
 */

/* Normalise pair sums (count, par, perp per bin from gofr_pairs()) to G_par, G_perp (NaN where a bin
 * holds no pair). t_over_m = T/m > 0. */
void vcorr_pairs(int dim, int nb, const double *count, const double *par, const double *perp, double t_over_m,
                 double *g_par, double *g_perp);

/* S_par, S_perp per shell (fgrid.h) from velocities vel (n*dim) at positions pos; mean: the mean
 * velocity (subtracted); t_over_m = T/m. Uses fields 0 .. dim-1 of g (created with >= dim fields). */
void vcorr_kspace(fgrid_t *g, int dim, size_t n, const double *pos, const double *vel, const double *mean,
                  double t_over_m, double *s_par, double *s_perp);
