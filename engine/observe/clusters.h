/* Particle-cluster statistics: connected components of particles closer than a gap, in linear time. */
#pragma once

#include <stddef.h>
#include <stdint.h>

/*
 * Two particles belong to the same cluster when their surface gap is below
 * delta, i.e. centre distance < 2*radius + delta (seed 003, ch. 5; delta is
 * given here in length units, the scene gives it in diameters). Periodic
 * box, minimum image. Union-find over a cell grid of edge >= 2*radius+delta:
 * O(N) time for bounded density. No I/O.
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
} clusters_stats_t;

typedef struct clusters clusters_t;

/* Workspace for n particles in dim (2 or 3) dimensions; reusable across calls. */
clusters_t *clusters_create(int dim, size_t n);
void clusters_destroy(clusters_t *c);

/* pos: n*dim coordinates (any values; wrapped internally into [0, box)).
 * box: dim edge lengths. Returns 0, or a negative code (-1 bad arguments,
 * -2 out of memory). */
int clusters_compute(clusters_t *c, const double *pos, const double *box,
                     double radius, double delta, clusters_stats_t *out);

/* Cluster label (0..n_clusters-1, in order of first particle) of particle i
 * after the last clusters_compute(). */
uint32_t clusters_label(const clusters_t *c, size_t i);
