/* Surface profile h(x) of a pile: the highest particle centre in each bin across gravity (seed 000 sec. 3.5). */
#pragma once

#include <stddef.h>

/*
 * Contract
 * - Pure computation: no allocation, no I/O, no globals.
 * - pos: n rows of dim doubles (scene coordinates, the particles present).
 *   The bins cut [0, len) along axis `axis` into `bins` equal bins (a centre
 *   outside it counts in the first or last bin); the height of a centre is
 *   its coordinate along gaxis measured from the floor gravity points to:
 *   pos[gaxis] when gravity points to -gaxis (up = +1), glen - pos[gaxis]
 *   when it points to +gaxis (up = -1; glen the box edge along gaxis).
 * - h[b]: the largest height in bin b (seed 000: "the maximum y coordinate
 *   of all particles between x0 - dx/2 and x0 + dx/2"), NaN for an empty
 *   bin; count[b]: the particles in bin b (any height).
 */
void surface_profile(int dim, size_t n, const double *pos, int axis, double len, int bins, int gaxis, int up,
                     double glen, double *h, double *count);
