/* Coarse-grained fields on a grid of cells: number density, mean velocity, temperature and spin per cell, accumulated over the instants of an exposure. */
#pragma once

#include <stddef.h>

/*
 * Contract
 * - A grid of cells[0] x cells[1] (x cells[2]) equal cells over the box
 *   (cell edge h_a = box_a / cells_a); flat index c = i_x + n_x (i_y + n_y i_z)
 *   (x fastest). All memory is made in fields_create(); no I/O, no globals.
 * - fields_add() adds one instant: each particle's centre is put in its
 *   cell (periodic axes: wrapped into [0, L); walled axes: clamped into the
 *   first or last cell, for a centre on or beyond a wall, e.g. a vibrating
 *   wall below its rest position). The sums per cell are plain doubles in a
 *   fixed order: deterministic, and the state a checkpoint stores.
 * - fields_result() turns the sums over the S instants added since the last
 *   fields_reset() into, per cell c:
 *     count_c   = (number of particle visits) / S, the mean occupation
 *                 (sums over the cells to the mean number of particles present);
 *     density_c = count_c / (cell volume), particles per unit area (2D) or
 *                 volume (3D);
 *     u_c       = sum v / visits, the mean velocity;
 *     T_c       = m (sum |v|^2 / visits - |u_c|^2) / D, the temperature of
 *                 the velocity fluctuations about the cell mean (k_B = 1);
 *                 from the pooled visits of all instants, so its bias is
 *                 -m var(u_c) / D (order T / visits for independent visits);
 *     w_c       = sum omega / visits, the mean angular velocity (spin_dim 1
 *                 in 2D, 3 in 3D; rough particles only).
 *   A cell without visits has count 0 and u, T, w NaN; a cell with one
 *   visit has T 0.
 */

/* Cells in all: 2^15, so that one sample (observables.jsonl: about 17 numbers per cell in 3D with spins,
 * at most 17 characters each) stays within the 16 MiB line the daemon serves (daemon/curves.h). */
#define FIELDS_MAX_CELLS (1 << 15)

typedef struct fields fields_t;

/* NULL on bad arguments (dim 2 or 3, every cells[a] >= 1 for a < dim, at most FIELDS_MAX_CELLS in all,
 * box edges > 0, spin_dim 0, 1 or 3) or no memory. periodic[a]: wrap axis a, else clamp. */
fields_t *fields_create(int dim, const double *box, const int cells[3], const int periodic[3], int spin_dim);
void fields_destroy(fields_t *f);

size_t fields_cells(const fields_t *f);
/* Instants added since the last reset. */
int fields_samples(const fields_t *f);
void fields_reset(fields_t *f);
/* One instant: n particles, pos and vel n*dim, spin n*spin_dim (NULL when spin_dim is 0). A row whose
 * first position component is NaN is an empty slot (a particle that left through an open or reservoir
 * wall) and counts nowhere. */
void fields_add(fields_t *f, size_t n, const double *pos, const double *vel, const double *spin);
/* Mixtures (particles of several masses): rows masses (not copied: valid while f is used), one per row
 * that fields_add() will see. Then u_c is the barycentric (mass-weighted) velocity sum m v / sum m and
 * T_c = (sum m |v|^2 - (sum m) |u_c|^2) / (D visits), the mean over visits of m |v - u_c|^2 / D (the
 * temperature of the fluctuations about u_c); fields_result()'s mass is then unused. Call before the
 * first fields_add(). 0, -1 on bad arguments, -2 out of memory. */
int fields_masses(fields_t *f, size_t rows, const double *mass);
/* Cell index of the point x (dim coordinates), as fields_add() bins it. */
size_t fields_cell_of(const fields_t *f, const double *x);
/* The fields of the instants added (see the contract); any output may be NULL. u[a] and w[a] are arrays of
 * fields_cells() doubles for a < dim (u) and a < spin_dim (w). Returns the samples S; with S = 0 every output
 * is NaN. */
int fields_result(const fields_t *f, double mass, double *count, double *density, double *const *u, double *temp,
                  double *const *w);

/* Checkpoint state: the sums and the sample count, fields_state_size() doubles. set returns 0, or -1 when a
 * value is not a valid sum (negative or non-finite visits, non-integral sample count). */
size_t fields_state_size(const fields_t *f);
void fields_state_get(const fields_t *f, double *v);
int fields_state_set(fields_t *f, const double *v);

size_t fields_memory(const fields_t *f);
