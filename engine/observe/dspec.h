/* density_spectrum: particle counts in slices along one axis sampled at fixed intervals, and the power spectrum in frequency of each slice's time series (seed 000 eq. 3.11). */
#pragma once

#include <stddef.h>
#include <stdint.h>

/*
 * Contract
 * - dspec_create(dim, axis, slices, length, m, interval, f_lo, f_hi): S = slices equal slices of the box
 *   edge `length` along `axis`; a ring of the last m samples (m >= 4) of the S counts, taken every
 *   `interval`. Allocates everything; sampling and results allocate nothing. No I/O, no globals.
 * - dspec_add(): one sample (pos: n * dim, scene order) into the ring, replacing the oldest.
 * - dspec_result(): when the ring holds m samples, for k = 1 .. m/2 - 1 (dspec_bins()),
 *   P(f_k) = (|C_k|^2 + |C_{m-k}|^2) / m^2, C_k = sum_j c_j exp(2 pi i j k / m), c_j the count of a slice at
 *   sample j (oldest first), f_k = k / (m interval), averaged over the S slices; and the least-squares slope
 *   alpha of log P against log f over the f_k in [f_lo, f_hi] with its standard error from the residuals
 *   (NaN with fewer than 3 frequencies). Fewer than m samples: P, alpha and se are NaN.
 *   Returns the samples in the ring (at most m).
 *   White noise (uncorrelated counts of variance var): E P(f_k) = 2 var / m at every k, slope 0.
 * - State (checkpoints): dspec_state_size() doubles, get/set bit-exact; set returns -1 on bad state.
 */

typedef struct dspec dspec_t;

dspec_t *dspec_create(int dim, int axis, int slices, double length, int m, double interval, double f_lo,
                      double f_hi);
void dspec_destroy(dspec_t *d);
int dspec_bins(int m);
void dspec_axis(const dspec_t *d, double *edges, double *centres);
void dspec_add(dspec_t *d, uint64_t n, const double *pos);
int dspec_result(dspec_t *d, double *P, double *alpha, double *alpha_se);
size_t dspec_state_size(const dspec_t *d);
void dspec_state_get(const dspec_t *d, double *v);
int dspec_state_set(dspec_t *d, const double *v);
size_t dspec_memory(const dspec_t *d);
