/* The curve tables of a scene (names, bins, columns): one description for obs_create() and admission control. */
#pragma once

#include <stddef.h>

#include "observe/observe.h"
#include "scene.h"

/*
 * Contract
 * - Pure: no allocation, no I/O, no FFTW (the daemon links this without
 *   FFTW), thread-safe.
 * - The tables are what obs_create() lays out: family, table, x, x_unit, nb,
 *   ncols, col and (fields) shape; edges, centres, val and se stay NULL.
 */

/* Append the tables of scene s to c (c->ntables counts them), with J shells of k for the
 * structure_factor and velocity_correlations modes (fgrid_bins() of the scene's grid). */
void tables_layout(obs_curves_t *c, const scene_t *s, int J);

/* The shells of k that fgrid_create_walled() makes for a grid of m[a] points over box: dk = 2 pi / the
 * largest periodic edge, up to the smallest periodic Nyquist wave number, at least 1; 0 when
 * fgrid_create_walled() would refuse the arguments (dim 2 or 3, every periodic m >= 4, finite positive
 * edges, a periodic axis). walled[dim]: the axes with walls (NULL: none), which carry no wave vectors. */
int tables_k_shells(int dim, const double *box, const int m[3], const int *walled);

/* The whole description for scene s into *out (zeroed first). */
void tables_of(const scene_t *s, obs_curves_t *out);

/* Bytes that always suffice for one sample of c's curves as JSON lines (report_curves(), io/report.h):
 * every number at most 16 characters and a separator; per bin and column a value and, when ensemble is
 * set (run.replicas > 1), a standard error. */
size_t tables_json_max(const obs_curves_t *c, int ensemble);
