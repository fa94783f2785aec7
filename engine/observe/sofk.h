/* Static structure factor S(k) from an FFT of the particle density on a grid, radially averaged over shells of |k| (seed 000 sec. 3.2). */
#pragma once

#include <stddef.h>
#include "observe/fgrid.h"

/*
 * S(k) = <|sum_j exp(-i k.r_j)|^2> / N over the wave vectors of each shell
 * (fgrid.h), from the cloud-in-cell density: (|F|^2/N - alias) / W(k)^2.
 * S -> 1 at large k for any fluid; S(k -> 0) = n T kappa_T for a fluid in
 * equilibrium. Uses field 0 of g. No allocation, no I/O.
 */

/* s[fgrid_bins(g)]: S(k) per shell (NaN for a shell without modes). */
void sofk_compute(fgrid_t *g, size_t n, const double *pos, double *s);
