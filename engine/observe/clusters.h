/* Particle-cluster statistics: connected components of particles closer than a gap, in linear time. */
#pragma once

#include <stddef.h>
#include <stdint.h>

/*
 * Two particles belong to the same cluster when their surface gap is below
 * delta, i.e. centre distance < 2*radius + delta (seed 003, ch. 5; delta is
 * given here in length units, the scene gives it in diameters). Periodic
 * box, minimum image; on axes named by clusters_walls() the plain
 * difference (a cluster touching both walls is not joined across them).
 * Union-find over a cell grid of edge >= 2*radius+delta: O(N) time for
 * bounded density. No I/O.
 */

#define CLUSTERS_MAX_BINS 40

typedef struct {
	uint64_t n_particles;
	uint64_t n_clusters;           /* including single particles */
	uint64_t largest;              /* size of the largest cluster */
	double largest_fraction;       /* largest / n_particles */
	/* Moments over the cluster-size distribution n_s (number of clusters
	 * of size s), n_tot = n_clusters: M_k = sum_s s^k n_s / n_tot. */
	double mean_size;              /* M_1 = N / n_clusters */
	double m2;                     /* M_2 */
	double m2_reduced;             /* M'_2 = M_2 - largest^2 / n_tot */
	int n_bins;                    /* logarithmic bins [2^k, 2^(k+1)) */
	uint64_t hist[CLUSTERS_MAX_BINS]; /* number of clusters per bin */
	/* Fits to n_s (seed 003 sec. 5.3.1), NaN when there is too little to fit:
	 * - w: the initial (percolation) form n_s ~ s^-theta exp(-w s) with the
	 *   universal theta = 1 (2D), 3/2 (3D) fixed, fitted to ln(n_s s^theta)
	 *   over the sizes 1 <= s < largest present (weights n_s);
	 * - exponent: the power law n_s ~ s^-exponent fitted to ln n_s (per unit
	 *   size, CLUSTERS_SIZE_BINS bins) against ln s over 2 <= s, the largest
	 *   cluster left out (weights: clusters per bin). At the peak of
	 *   m2_reduced it is the percolation exponent (2.2 in 3D), late in the
	 *   clustering regime about 3. */
	double w;
	double exponent;
} clusters_stats_t;

typedef struct clusters clusters_t;

/* Workspace for n particles in dim (2 or 3) dimensions; reusable across calls. */
clusters_t *clusters_create(int dim, size_t n);
void clusters_destroy(clusters_t *c);

/* Walled axes (walled[dim], nonzero: no periodic image; positions taken as they are, not folded), for
 * every later clusters_compute(). 0, or -1 on NULL arguments. */
int clusters_walls(clusters_t *c, const int *walled);

/* Rows of the next computes, for scenes whose particle count varies (open and reservoir walls): n <= the
 * n of clusters_create(). 0, or -1 when n is larger. */
int clusters_set_count(clusters_t *c, size_t n);

/* pos: n*dim coordinates (any values; wrapped internally into [0, box) on periodic axes).
 * box: dim edge lengths. Returns 0, or a negative code (-1 bad arguments,
 * -2 out of memory). */
int clusters_compute(clusters_t *c, const double *pos, const double *box,
                     double radius, double delta, clusters_stats_t *out);

/* Cluster label (0..n_clusters-1, in order of first particle) of particle i
 * after the last clusters_compute(). */
uint32_t clusters_label(const clusters_t *c, size_t i);

/* Bins of cluster size for n particles: each size 1..16, then edges growing by 2^(1/4) (at least 1)
 * up to n + 1. edges[nb + 1] (bin k: s in [edges[k], edges[k+1])) and centres[nb] (mean size in the
 * bin); returns nb (<= CLUSTERS_SIZE_BINS). Either array may be NULL. */
#define CLUSTERS_SIZE_BINS 128
int clusters_size_bins(uint64_t n, double *edges, double *centres);
/* n_s after the last clusters_compute(): clusters per bin divided by the number of sizes in the bin
 * (ns[nb], for edges of clusters_size_bins()), and the clusters per bin (count[nb], may be NULL). */
void clusters_size_distribution(const clusters_t *c, int nb, const double *edges, double *ns, double *count);
