/* Pair correlation g(r) by a cell-list pair histogram in O(N), its contact value, and velocity pair correlations on the same pairs. */
#pragma once

#include <stddef.h>
#include <stdint.h>

/*
 * Contract
 * - Periodic box, minimum image, unless gofr_walls() names walled axes:
 *   there distances are plain differences (chosen once; the periodic path
 *   is unchanged). Particles are sorted into a grid of cells
 *   of edge >= the largest distance asked for, so one call costs O(N) at
 *   bounded density (N times the pairs within range). No I/O; all memory
 *   is allocated in gofr_create() (reused by every call).
 * - g(r) of a shell [a, b) = pairs counted / pairs an ideal gas of the same
 *   N and volume would have there, N (N-1)/2 * v_shell / V (gofr_ideal());
 *   with walls, the pairs of N uniform independent centres in the region
 *   they can reach (gofr_ideal_in(): the box shrunk by one radius at each
 *   wall, the shell's part inside counted exactly, gofr.c); with obstacles (gofr_obstacles()) the region
 *   also leaves out each obstacle's contact sphere, and its pair counts come from a table estimated once
 *   by Monte Carlo (relative error below 1e-3, gofr.c).
 * - Scenes whose particle count varies (open and reservoir walls) give the rows present at each call:
 *   gofr_set_count() (at most the n of gofr_create()); the ideal counts then use that count.
 * - Distances must not exceed half the smallest box edge (the caller's
 *   check; scene_parse() enforces it for the scene's range).
 */

typedef struct gofr gofr_t;

/* Workspace for n particles in dim (2, 3) dimensions in a box of edges box[dim];
 * cutoff: the largest distance a call will ask for. NULL on bad arguments or no memory. */
gofr_t *gofr_create(int dim, size_t n, const double *box, double cutoff);
void gofr_destroy(gofr_t *g);

/* Walls: walled[dim] (nonzero: walls at 0 and the box edge on that axis, no periodic image), radius: the
 * centres' distance of closest approach to a wall (the region they fill is L - 2 radius on a walled axis).
 * Call once after gofr_create(); positions on walled axes are then taken as they are (not folded).
 * 0, or -1 on bad arguments (no room between the walls). */
int gofr_walls(gofr_t *g, const int *walled, double radius);

/* Rows of the next calls: n <= the n given to gofr_create(). 0, or -1 when n is larger. */
int gofr_set_count(gofr_t *g, size_t n);

/* Obstacles: k spheres (disks) with centres centres[k * dim] in the positions' frame and contact distances
 * contact[k] (obstacle radius + particle radius: no centre comes closer). Call after gofr_walls() (if
 * any); the ideal pair counts then count only the region the centres can reach (gofr.c). k = 0 removes
 * them. 0, -1 on bad arguments (or no reachable room), -2 out of memory. Costs about 2^18 * 257 point
 * tests, once (~0.1 s). */
int gofr_obstacles(gofr_t *g, int k, const double *centres, const double *contact);

/* Pairs of an ideal gas (uniform independent centres) of g's n particles in g's geometry in the shell
 * [a, b): gofr_ideal() of the box volume without walls; exact for b below every walled region edge. */
double gofr_ideal_in(const gofr_t *g, double a, double b);

/* Pair counts in nb equal bins over [r0, r1) into count[nb]. With vel (n*dim doubles, may be NULL),
 * also per bin the sums over those pairs of (w_i . e)(w_j . e) into par[nb] and of
 * (w_i . w_j - (w_i . e)(w_j . e)) into perp[nb], where w are the peculiar velocities (v minus the mean
 * over the particles) and e the unit vector between the pair. Returns 0, or -1 on bad arguments
 * (r1 above the cutoff, nb < 1, par/perp missing with vel). */
int gofr_pairs(gofr_t *g, const double *pos, const double *vel, double r0, double r1, int nb, double *count,
               double *par, double *perp);

/*
 * Mixtures: partial pair correlations g_ab(r) by species class.
 * - gofr_species(): K classes (1 ... GOFR_SPECIES_MAX; 0 removes them) and each row's class species[i] < K,
 *   for all rows of gofr_create() (the array is copied). 0, -1 on bad arguments, -2 out of memory.
 * - A pair of classes a <= b is pair class gofr_pair_class(K, a, b) = a K - a (a - 1)/2 + b - a in
 *   0 .. gofr_pair_classes(K) - 1 (00, 01, ..., 0K-1, 11, 12, ...).
 * - gofr_pairs_species(): pair counts of each pair class in nb equal bins over [r0, r1) into
 *   count[class * nb + bin] (gofr_pair_classes(K) * nb doubles). 0, or -1 on bad arguments (no classes).
 * - gofr_ideal_class(): the pairs of an ideal gas in the shell [a, b) for a class of `pairs` pairs
 *   (N_a (N_a - 1)/2 or N_a N_b): gofr_ideal_in() scaled by pairs / (N (N - 1)/2), exact when every row
 *   can reach the same region (a periodic box; the scene parser allows partial g(r) only there).
 * - gofr_contact_species(): the contact value g_ab(sigma) of pair class (a, b) at contact distance sigma,
 *   as gofr_contact() on that class's pairs. -1 (NaN) as there, or on bad arguments.
 * - gofr_species_count(): rows of each class among the n rows of the next call into count[K].
 */
#define GOFR_SPECIES_MAX 16
static inline int gofr_pair_class(int K, int a, int b)
{
	if (a > b) {
		int t = a;
		a = b;
		b = t;
	}
	return a * K - a * (a - 1) / 2 + b - a;
}
static inline int gofr_pair_classes(int K) { return K * (K + 1) / 2; }
int gofr_species(gofr_t *g, int k, const uint8_t *species);
int gofr_species_count(const gofr_t *g, size_t *count);
int gofr_pairs_species(gofr_t *g, const double *pos, double r0, double r1, int nb, double *count);
double gofr_ideal_class(const gofr_t *g, double pairs, double a, double b);

/* Pairs of an ideal gas of n particles in volume V in the shell [a, b). */
double gofr_ideal(int dim, size_t n, double volume, double a, double b);

/* Contact value g(sigma) from the pair histogram: GOFR_CONTACT_BINS bins of width sigma/100 over
 * [sigma, 1.1 sigma); g(r) = exp(a + b (r - sigma)) fitted to the counts by Poisson maximum likelihood
 * (unbiased to O(1 / the window's pairs); a least-squares fit of ln(count) weighted by the counts is biased
 * by +1/(2 count) per bin, gofr.c) and taken at r = sigma. se: the standard error of that value from the
 * Fisher information (Poisson counting only). NaN (and -1 returned) when fewer than 3 bins hold pairs. Hard spheres have no pair below sigma; point particles (dsmc/hsmc) do, and
 * are counted from sigma on as well. */
#define GOFR_CONTACT_BINS 10
#define GOFR_CONTACT_WIDTH 0.1
typedef struct {
	double value, se;
	double pairs;     /* pairs counted in [sigma, 1.1 sigma) */
} gofr_contact_t;
int gofr_contact(gofr_t *g, const double *pos, double sigma, gofr_contact_t *out);

int gofr_contact_species(gofr_t *g, const double *pos, int a, int b, double sigma, gofr_contact_t *out);

/* The same fit on counts already binned (count[nb] over [sigma, sigma + nb*width), nb <= GOFR_FIT_BINS_MAX),
 * for tests. */
#define GOFR_FIT_BINS_MAX 1024
int gofr_contact_fit(int dim, size_t n, double volume, double sigma, double width, int nb, const double *count,
                     gofr_contact_t *out);

/* The contact value that Enskog theory (molecular chaos, Maxwellian velocities) gives from other
 * observables; for elastic hard disks/spheres all three agree with the pair histogram:
 * - from the collision frequency per particle f = 2C/(N t) at temperature T:
 *     f = D 2^(D-1) nu g sqrt(T/m) / (sqrt(pi) a),  a the radius;
 * - from the compressibility factor Z = p V / (N T) of the collision virial:
 *     Z - 1 = (1 + e)/2 2^(D-1) nu g  (e the restitution; 2 nu g (2D), 4 nu g (3D) elastic).
 * NaN when the input is not finite or T, nu not positive. */
double gofr_contact_rate(int dim, double nu, double radius, double mass, double temp, double rate);
double gofr_contact_virial(int dim, double nu, double restitution, double z);
