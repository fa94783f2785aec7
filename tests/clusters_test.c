/* Tests for engine/clusters.c: hand-made cases, brute-force comparison, ideal-gas bond count, a 10^6 run. */
#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "observe/clusters.h"
#include "tap.h"

#define PI 3.14159265358979323846

/* Set CLUSTERS_TEST_QUICK (e.g. under valgrind) to skip the 10^6 run. */

static uint64_t splitmix64(uint64_t *s)
{
	uint64_t z = (*s += 0x9e3779b97f4a7c15ULL);
	z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
	z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
	return z ^ (z >> 31);
}

/* Uniform in [0, 1). */
static double uniform(uint64_t *s) { return (double)(splitmix64(s) >> 11) * 0x1.0p-53; }

static double now(void)
{
	struct timespec ts;
	clock_gettime(CLOCK_MONOTONIC, &ts);
	return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

/* ---- brute force: all pairs, minimum image on the raw coordinates ---- */

static uint32_t bf_find(uint32_t *p, uint32_t x)
{
	while (p[x] != x)
		x = p[x] = p[p[x]];
	return x;
}

/* Labels in order of first particle, as clusters_label() promises. */
static void brute_labels(int dim, size_t n, const double *pos, const double *box,
                         double cutoff, uint32_t *label)
{
	uint32_t *p = malloc((n ? n : 1) * sizeof(*p));
	uint32_t *lab = malloc((n ? n : 1) * sizeof(*lab));
	for (size_t i = 0; i < n; i++) {
		p[i] = (uint32_t)i;
		lab[i] = UINT32_MAX;
	}
	for (size_t i = 0; i < n; i++)
		for (size_t j = i + 1; j < n; j++) {
			double r2 = 0.0;
			for (int a = 0; a < dim; a++) {
				double d = pos[i * dim + a] - pos[j * dim + a];
				d -= box[a] * round(d / box[a]);
				r2 += d * d;
			}
			if (r2 < cutoff * cutoff)
				p[bf_find(p, (uint32_t)i)] = bf_find(p, (uint32_t)j);
		}
	uint32_t next = 0;
	for (size_t i = 0; i < n; i++) {
		uint32_t r = bf_find(p, (uint32_t)i);
		if (lab[r] == UINT32_MAX)
			lab[r] = next++;
		label[i] = lab[r];
	}
	free(p);
	free(lab);
}

/* Statistics from a labelling, computed independently of clusters.c. */
static void stats_from_labels(size_t n, const uint32_t *label, clusters_stats_t *st)
{
	memset(st, 0, sizeof(*st));
	st->n_particles = n;
	uint64_t *cnt = calloc(n ? n : 1, sizeof(*cnt));
	for (size_t i = 0; i < n; i++) {
		cnt[label[i]]++;
		if (label[i] + 1 > st->n_clusters)
			st->n_clusters = label[i] + 1;
	}
	uint64_t sum2 = 0;
	for (uint64_t k = 0; k < st->n_clusters; k++) {
		uint64_t s = cnt[k];
		sum2 += s * s;
		if (s > st->largest)
			st->largest = s;
		int b = (int)floor(log2((double)s));
		st->hist[b]++;
		if (b + 1 > st->n_bins)
			st->n_bins = b + 1;
	}
	if (st->n_clusters) {
		double nc = (double)st->n_clusters;
		st->largest_fraction = (double)st->largest / (double)n;
		st->mean_size = (double)n / nc;
		st->m2 = (double)sum2 / nc;
		st->m2_reduced = ((double)sum2 - (double)st->largest * (double)st->largest) / nc;
	}
	free(cnt);
}

static int close_to(double a, double b) { return fabs(a - b) <= 1e-12 * fmax(1.0, fabs(b)); }

/* Empty string when equal, else what differs first. */
static const char *stats_diff(const clusters_stats_t *a, const clusters_stats_t *b)
{
	if (a->n_particles != b->n_particles) return "n_particles";
	if (a->n_clusters != b->n_clusters) return "n_clusters";
	if (a->largest != b->largest) return "largest";
	if (a->n_bins != b->n_bins) return "n_bins";
	for (int k = 0; k < CLUSTERS_MAX_BINS; k++)
		if (a->hist[k] != b->hist[k]) return "hist";
	if (!close_to(a->largest_fraction, b->largest_fraction)) return "largest_fraction";
	if (!close_to(a->mean_size, b->mean_size)) return "mean_size";
	if (!close_to(a->m2, b->m2)) return "m2";
	if (!close_to(a->m2_reduced, b->m2_reduced)) return "m2_reduced";
	return "";
}

/* Compute with c (or a fresh workspace when c is NULL) and compare labels
 * and statistics with the brute force. */
static int check_against_brute(clusters_t *c, int dim, size_t n, const double *pos,
                               const double *box, double radius, double delta,
                               const char *what)
{
	clusters_t *own = NULL;
	if (c == NULL)
		c = own = clusters_create(dim, n);
	clusters_stats_t got, want;
	int rc = clusters_compute(c, pos, box, radius, delta, &got);
	uint32_t *lab = malloc((n ? n : 1) * sizeof(*lab));
	brute_labels(dim, n, pos, box, 2.0 * radius + delta, lab);
	stats_from_labels(n, lab, &want);
	size_t bad = n;
	for (size_t i = 0; rc == 0 && i < n; i++)
		if (clusters_label(c, i) != lab[i]) {
			bad = i;
			break;
		}
	const char *d = stats_diff(&got, &want);
	int good = ok(rc == 0 && bad == n && *d == '\0',
	              "%s: %dD N=%zu box %.3g: %llu clusters, largest %llu",
	              what, dim, n, box[0], (unsigned long long)got.n_clusters,
	              (unsigned long long)got.largest);
	if (!good)
		diag("rc %d, first label mismatch %zu, stats differ in '%s' (want %llu clusters)",
		     rc, bad, d, (unsigned long long)want.n_clusters);
	free(lab);
	clusters_destroy(own);
	return good;
}

/* ---- hand-made configurations ---- */

static void test_chain(int dim)
{
	/* Five spheres 2r + delta/2 apart (bonded), a sixth 2r + 1.5 delta
	 * after the last (not bonded). Repeated straddling the boundary. */
	const double r = 0.5, delta = 0.2, box[3] = { 20.0, 20.0, 20.0 };
	double x0[2] = { 1.0, 17.5 };
	for (int t = 0; t < 2; t++) {
		double pos[6 * 3];
		double x = x0[t];
		for (int i = 0; i < 6; i++) {
			pos[i * dim + 0] = x;
			pos[i * dim + 1] = 5.0;
			if (dim == 3)
				pos[i * dim + 2] = 7.0;
			x += 2 * r + (i < 4 ? 0.5 : 1.5) * delta;
		}
		clusters_t *c = clusters_create(dim, 6);
		clusters_stats_t st;
		int rc = clusters_compute(c, pos, box, r, delta, &st);
		int labels_ok = 1;
		for (int i = 0; i < 6; i++)
			labels_ok &= clusters_label(c, i) == (i < 5 ? 0u : 1u);
		ok(rc == 0 && st.n_clusters == 2 && st.largest == 5 && labels_ok &&
		   st.n_bins == 3 && st.hist[0] == 1 && st.hist[1] == 0 && st.hist[2] == 1 &&
		   close_to(st.mean_size, 3.0) && close_to(st.m2, 13.0) &&
		   close_to(st.m2_reduced, 0.5) && close_to(st.largest_fraction, 5.0 / 6.0),
		   "%dD chain of 5 + 1 %s", dim, t ? "across the boundary" : "inside the box");
		clusters_destroy(c);
	}
}

static void test_boundary_pair(int dim)
{
	const double r = 0.5, delta = 0.2, box[3] = { 10.0, 8.0, 6.0 };
	/* Raw coordinates outside [0, L) on purpose: x = -0.1 ~ 9.9 and
	 * 10.3 ~ 0.3 are 0.4 apart through the boundary; y and z several
	 * periods away. */
	double pos[2 * 3] = { 0 };
	pos[0] = -0.1; pos[1] = 3.0 + 3 * 8.0;
	pos[dim + 0] = 10.3; pos[dim + 1] = 3.2 - 2 * 8.0;
	if (dim == 3) {
		pos[2] = 5.9;
		pos[dim + 2] = 6.1;
	}
	clusters_t *c = clusters_create(dim, 2);
	clusters_stats_t st;
	int rc = clusters_compute(c, pos, box, r, delta, &st);
	ok(rc == 0 && st.n_clusters == 1 && st.largest == 2 && clusters_label(c, 1) == 0,
	   "%dD pair across the periodic boundary joins", dim);
	/* Same pair 1.3 apart along x (cutoff 1.2): apart. */
	pos[dim + 0] = 11.2;
	rc = clusters_compute(c, pos, box, r, delta, &st);
	ok(rc == 0 && st.n_clusters == 2 && st.largest == 1 && clusters_label(c, 1) == 1 &&
	   st.n_bins == 1 && st.hist[0] == 2 && close_to(st.m2_reduced, 0.5),
	   "%dD pair just beyond the cutoff across the boundary stays apart", dim);
	clusters_destroy(c);
}

static void test_small_n(int dim)
{
	const double box[3] = { 4.0, 4.0, 4.0 };
	double pos[2 * 3] = { 1.0, 1.0, 1.0, 1.0, 1.0, 1.0 };
	clusters_stats_t st;
	clusters_t *c = clusters_create(dim, 1);
	int rc = clusters_compute(c, pos, box, 0.5, 0.1, &st);
	ok(rc == 0 && st.n_particles == 1 && st.n_clusters == 1 && st.largest == 1 &&
	   st.n_bins == 1 && st.hist[0] == 1 && close_to(st.largest_fraction, 1.0) &&
	   close_to(st.mean_size, 1.0) && close_to(st.m2, 1.0) && close_to(st.m2_reduced, 0.0) &&
	   clusters_label(c, 0) == 0 && clusters_label(c, 1) == UINT32_MAX,
	   "%dD N=1", dim);
	clusters_destroy(c);

	c = clusters_create(dim, 2);
	pos[dim] = 2.0; /* distance 1.0 < cutoff 1.1 */
	rc = clusters_compute(c, pos, box, 0.5, 0.1, &st);
	ok(rc == 0 && st.n_clusters == 1 && st.largest == 2 && st.n_bins == 2 &&
	   st.hist[1] == 1 && close_to(st.m2, 4.0) && close_to(st.m2_reduced, 0.0),
	   "%dD N=2 bonded", dim);
	pos[dim] = 2.2; /* 1.2 > 1.1 */
	rc = clusters_compute(c, pos, box, 0.5, 0.1, &st);
	ok(rc == 0 && st.n_clusters == 2 && st.largest == 1 && clusters_label(c, 0) == 0 &&
	   clusters_label(c, 1) == 1, "%dD N=2 apart", dim);
	/* Coincident particles (ideal gas allows it). */
	pos[dim] = 1.0;
	rc = clusters_compute(c, pos, box, 0.5, 0.1, &st);
	ok(rc == 0 && st.n_clusters == 1, "%dD N=2 coincident", dim);
	clusters_destroy(c);

	c = clusters_create(dim, 0);
	rc = clusters_compute(c, pos, box, 0.5, 0.1, &st);
	ok(c != NULL && rc == 0 && st.n_particles == 0 && st.n_clusters == 0 && st.n_bins == 0,
	   "%dD N=0", dim);
	clusters_destroy(c);
}

static void test_bad_arguments(void)
{
	ok(clusters_create(1, 10) == NULL && clusters_create(4, 10) == NULL,
	   "create rejects dim other than 2 and 3");
	clusters_destroy(NULL);
	ok(1, "destroy(NULL) is a no-op");

	clusters_t *c = clusters_create(3, 2);
	double pos[6] = { 1, 1, 1, 2, 2, 2 }, box[3] = { 5, 5, 5 };
	clusters_stats_t st;
	int rc = clusters_compute(c, pos, box, 0.5, 0.1, &st);
	ok(rc == 0 && clusters_label(c, 0) == 0, "valid call");
	double badbox[3] = { 5, 0, 5 };
	ok(clusters_compute(c, pos, badbox, 0.5, 0.1, &st) == -1, "zero box edge: -1");
	ok(clusters_label(c, 0) == UINT32_MAX, "no labels after a failed call");
	badbox[1] = INFINITY;
	ok(clusters_compute(c, pos, badbox, 0.5, 0.1, &st) == -1, "infinite box edge: -1");
	ok(clusters_compute(c, pos, box, -0.5, 2.0, &st) == -1, "negative radius: -1");
	ok(clusters_compute(c, pos, box, 0.0, 0.0, &st) == -1, "zero cutoff: -1");
	ok(clusters_compute(c, pos, box, 0.5, -1.5, &st) == -1, "negative cutoff: -1");
	ok(clusters_compute(c, pos, box, 0.5, NAN, &st) == -1, "NaN delta: -1");
	pos[4] = NAN;
	ok(clusters_compute(c, pos, box, 0.5, 0.1, &st) == -1, "NaN position: -1");
	pos[4] = 2;
	ok(clusters_compute(NULL, pos, box, 0.5, 0.1, &st) == -1 &&
	   clusters_compute(c, NULL, box, 0.5, 0.1, &st) == -1 &&
	   clusters_compute(c, pos, NULL, 0.5, 0.1, &st) == -1 &&
	   clusters_compute(c, pos, box, 0.5, 0.1, NULL) == -1, "NULL arguments: -1");
	ok(clusters_label(NULL, 0) == UINT32_MAX, "label(NULL)");
	clusters_destroy(c);
}

/* ---- random configurations against the brute force ---- */

/* Uniform positions, a fifth of them shifted by whole periods or pushed
 * slightly outside the box, to exercise the wrapping. */
static void random_positions(uint64_t *rng, int dim, size_t n, const double *box, double *pos)
{
	for (size_t i = 0; i < n; i++)
		for (int a = 0; a < dim; a++) {
			double x = uniform(rng) * box[a];
			uint64_t u = splitmix64(rng) % 10;
			if (u == 0)
				x += box[a] * (double)((int)(splitmix64(rng) % 7) - 3);
			else if (u == 1)
				x += (uniform(rng) < 0.5 ? -1 : 1) * 1e-3 * box[a];
			pos[i * dim + a] = x;
		}
}

static double ball_volume(int dim, double R)
{
	return dim == 2 ? PI * R * R : 4.0 / 3.0 * PI * R * R * R;
}

static void test_random(void)
{
	const double radius = 0.45, delta = 0.1, cutoff = 2 * radius + delta;
	/* Box edges in cutoffs: below 1/2 (one cell, ambiguous minimum image),
	 * 2 and 3 cells per axis, and larger. Reduced densities eta = N v/V with
	 * v the ball of radius cutoff/2 straddle the continuum percolation
	 * thresholds (eta_c ~ 1.13 in 2D, 0.34 in 3D). */
	const double edges[] = { 0.45, 1.5, 2.5, 3.2, 5.0, 13.0 };
	const double etas[] = { 0.1, 0.3, 0.6, 1.2 };
	uint64_t rng = 12345;
	for (int dim = 2; dim <= 3; dim++)
		for (size_t e = 0; e < sizeof(edges) / sizeof(edges[0]); e++)
			for (size_t k = 0; k < sizeof(etas) / sizeof(etas[0]); k++) {
				double box[3], V = 1.0;
				for (int a = 0; a < dim; a++) {
					box[a] = edges[e] * cutoff;
					V *= box[a];
				}
				double nn = etas[k] * V / ball_volume(dim, cutoff / 2);
				size_t n = (size_t)fmax(2.0, fmin(2500.0, round(nn)));
				double *pos = malloc(n * dim * sizeof(double));
				random_positions(&rng, dim, n, box, pos);
				check_against_brute(NULL, dim, n, pos, box, radius, delta, "random");
				free(pos);
			}

	/* Tiny boxes (1 to 3 cells per axis) with few particles, so that the
	 * partition is neither all singles nor one cluster. */
	for (int t = 0; t < 24; t++) {
		int dim = 2 + t % 2;
		double box[3];
		for (int a = 0; a < dim; a++)
			box[a] = (1.0 + 3.0 * uniform(&rng)) * cutoff;
		size_t n = 2 + splitmix64(&rng) % (dim == 2 ? 6 : 10);
		double pos[12 * 3];
		random_positions(&rng, dim, n, box, pos);
		check_against_brute(NULL, dim, n, pos, box, radius, delta, "tiny box");
	}

	/* Anisotropic boxes mixing 1, 2, 3 and many cells per axis. */
	const double aniso[][3] = { { 0.4, 2.3, 9.0 }, { 2.2, 14.0, 3.1 }, { 25.0, 1.0, 2.6 },
	                            { 3.05, 2.05, 1.05 } };
	for (int dim = 2; dim <= 3; dim++)
		for (size_t t = 0; t < sizeof(aniso) / sizeof(aniso[0]); t++) {
			double box[3], V = 1.0;
			for (int a = 0; a < dim; a++) {
				box[a] = aniso[t][a] * cutoff;
				V *= box[a];
			}
			size_t n = (size_t)fmax(3.0, round(0.6 * V / ball_volume(dim, cutoff / 2)));
			double *pos = malloc(n * dim * sizeof(double));
			random_positions(&rng, dim, n, box, pos);
			check_against_brute(NULL, dim, n, pos, box, radius, delta, "anisotropic");
			free(pos);
		}

	/* Huge dilute boxes (the cell count is capped, cells are many cutoffs
	 * wide) with clumps so that there are clusters to find. */
	for (int dim = 2; dim <= 3; dim++)
		for (int t = 0; t < 3; t++) {
			const size_t n = 600;
			double box[3] = { 1e4, 3e3, 2e4 };
			double *pos = malloc(n * dim * sizeof(double));
			double centre[3] = { 0 };
			for (size_t i = 0; i < n; i++) {
				if (splitmix64(&rng) % 4 == 0)
					for (int a = 0; a < dim; a++)
						centre[a] = uniform(&rng) * box[a];
				for (int a = 0; a < dim; a++)
					pos[i * dim + a] = centre[a] + (uniform(&rng) - 0.5) * 1.6 * cutoff;
			}
			check_against_brute(NULL, dim, n, pos, box, radius, delta, "dilute clumps");
			free(pos);
		}

	/* One workspace reused across boxes that need more and fewer cells. */
	for (int dim = 2; dim <= 3; dim++) {
		const size_t n = 400;
		clusters_t *c = clusters_create(dim, n);
		double *pos = malloc(n * dim * sizeof(double));
		const double reuse[] = { 1.0, 40.0, 2.1, 200.0, 3.0 };
		int all = 1;
		for (size_t t = 0; t < sizeof(reuse) / sizeof(reuse[0]); t++) {
			double box[3] = { reuse[t] * cutoff, reuse[t] * cutoff, reuse[t] * cutoff };
			random_positions(&rng, dim, n, box, pos);
			all &= check_against_brute(c, dim, n, pos, box, radius, delta, "reused workspace");
		}
		free(pos);
		clusters_destroy(c);
		(void)all;
	}
}

/* ---- ideal gas: number of bonds ---- */

/*
 * N uniform independent points in a periodic box. A pair is bonded with
 * probability p = v_d / V (v_d: ball of radius d = cutoff, d < L/2). The bond
 * count B has mean E = N(N-1)/2 p and, because on a torus the events "i~j"
 * and "i~k" are independent (covariance zero), variance E(1-p): Poisson,
 * sigma = sqrt(E). Without cycles the bond graph is a forest and
 * N - n_clusters = B. The leading correction is one per triangle:
 * E[T] = C(N,3) p^2 q with q the probability that two uniform points in a
 * ball of radius d are within d of each other (15/32 in 3D,
 * 1 - 3 sqrt(3)/(4 pi) in 2D). At mean degree 0.05 this is under 1% of E,
 * and longer cycles are smaller still. We accept |N - n_clusters - (E - T)| <
 * 4 sigma, so each fixed seed would fail by chance with probability ~6e-5.
 */
static void test_ideal_gas(void)
{
	const size_t n = 20000;
	const double degree = 0.05;
	for (int dim = 2; dim <= 3; dim++) {
		clusters_t *c = clusters_create(dim, n);
		double *pos = malloc(n * dim * sizeof(double));
		double box[3] = { 1.0, 1.0, 1.0 };
		double d = dim == 2 ? sqrt(degree / (n * PI))
		                    : cbrt(degree / (n * 4.0 / 3.0 * PI));
		double p = ball_volume(dim, d);
		double q = dim == 2 ? 1.0 - 3.0 * sqrt(3.0) / (4.0 * PI) : 15.0 / 32.0;
		double E = 0.5 * n * (n - 1.0) * p;
		double T = n * (n - 1.0) * (n - 2.0) / 6.0 * p * p * q;
		for (uint64_t seed = 1; seed <= 4; seed++) {
			uint64_t rng = seed * 1000003;
			for (size_t k = 0; k < n * dim; k++)
				pos[k] = uniform(&rng);
			clusters_stats_t st;
			/* Radius d/4, delta d/2: points, cutoff d. */
			int rc = clusters_compute(c, pos, box, d / 4, d / 2, &st);
			double bonds = (double)n - (double)st.n_clusters;
			double z = (bonds - (E - T)) / sqrt(E);
			ok(rc == 0 && fabs(z) < 4.0,
			   "%dD ideal gas seed %llu: N - n_clusters = %.0f, expected %.1f - %.1f triangles, z = %+.2f",
			   dim, (unsigned long long)seed, bonds, E, T, z);
		}
		free(pos);
		clusters_destroy(c);
	}
}

/* ---- size distribution and its fits ---- */

/* Bins: sizes 1..16 one each, then growing, contiguous, ending at n + 1. */
static void test_size_bins(void)
{
	static const uint64_t ns[] = {1, 2, 16, 17, 100, 1000000, 2147483647ULL};
	int good = 1;
	for (size_t t = 0; t < sizeof ns / sizeof ns[0]; t++) {
		double e[CLUSTERS_SIZE_BINS + 1], c[CLUSTERS_SIZE_BINS];
		int nb = clusters_size_bins(ns[t], e, c);
		good &= nb >= 1 && nb <= CLUSTERS_SIZE_BINS && e[0] == 1 && e[nb] == (double)(ns[t] + 1);
		for (int k = 0; k < nb; k++) {
			good &= e[k + 1] > e[k] && c[k] >= e[k] && c[k] <= e[k + 1] - 1;
			if (k < 16 && e[k] <= (double)ns[t])
				good &= e[k] == k + 1;
		}
	}
	ok(good, "size bins: one per size to 16, then contiguous and growing, up to n + 1");
}

/*
 * Particles placed as isolated chains of s touching spheres (far apart), so
 * that n_s is exactly what we choose: n_s = round(A s^-theta e^-w s) for the
 * initial (percolation) form, and round(B s^-tau) for a power law. The fits
 * must return w and tau; the rounding of small counts is the only error
 * (a few per cent in the far tail, which the count weights suppress).
 */
static size_t place_chains(const uint64_t *count, int smax, double *pos, double *box)
{
	/* chains along x on a 3D grid of slots 24 diameters apart */
	size_t chains = 0, n = 0;
	for (int s = 1; s <= smax; s++)
		chains += count[s];
	int side = (int)ceil(cbrt((double)chains));
	double slot = smax + 4.0;
	box[0] = side * slot, box[1] = box[2] = side * 4.0;
	size_t k = 0;
	for (int s = 1; s <= smax; s++)
		for (uint64_t c = 0; c < count[s]; c++, k++) {
			int ix = (int)(k % side), iy = (int)(k / side % side), iz = (int)(k / side / side);
			for (int j = 0; j < s; j++, n++) {
				pos[3 * n] = ix * slot + j * 1.02;   /* gap 0.02 < delta 0.1: one cluster */
				pos[3 * n + 1] = iy * 4.0;
				pos[3 * n + 2] = iz * 4.0;
			}
		}
	return n;
}

static void test_fits(void)
{
	enum { SMAX = 60 };
	uint64_t cnt[SMAX + 1] = {0};
	size_t n = 0;
	/* initial form, 3D theta = 3/2, w = 0.35 */
	for (int s = 1; s <= SMAX; s++) {
		cnt[s] = (uint64_t)llround(20000 * pow(s, -1.5) * exp(-0.35 * s));
		n += cnt[s] * s;
	}
	cnt[SMAX] = 1;   /* a largest cluster (left out of the fit) */
	n += SMAX;
	double *pos = malloc(n * 3 * sizeof(double)), box[3];
	size_t placed = place_chains(cnt, SMAX, pos, box);
	clusters_t *c = clusters_create(3, placed);
	clusters_stats_t st;
	int rc = clusters_compute(c, pos, box, 0.5, 0.1, &st);
	ok(rc == 0 && st.largest == SMAX && fabs(st.w - 0.35) < 0.01,
	   "n_s = 20000 s^-3/2 e^-0.35 s (rounded): fitted w = %.4f, %llu clusters", st.w, (unsigned long long)st.n_clusters);
	double e[CLUSTERS_SIZE_BINS + 1], nsd[CLUSTERS_SIZE_BINS], ct[CLUSTERS_SIZE_BINS];
	int nb = clusters_size_bins(placed, e, NULL);
	clusters_size_distribution(c, nb, e, nsd, ct);
	int same = 1;
	for (int s = 1; s <= 16; s++)
		same &= nsd[s - 1] == (double)cnt[s] && ct[s - 1] == (double)cnt[s];
	ok(same, "n_s per bin equals the placed counts for s = 1..16");
	clusters_destroy(c);
	free(pos);

	/* power law tau = 2.2 (the 3D percolation exponent) */
	n = 0;
	for (int s = 1; s <= SMAX; s++) {
		cnt[s] = (uint64_t)llround(30000 * pow(s, -2.2));
		n += cnt[s] * s;
	}
	cnt[SMAX] += 1;
	n += SMAX;
	pos = malloc(n * 3 * sizeof(double));
	placed = place_chains(cnt, SMAX, pos, box);
	c = clusters_create(3, placed);
	rc = clusters_compute(c, pos, box, 0.5, 0.1, &st);
	ok(rc == 0 && fabs(st.exponent - 2.2) < 0.05, "n_s = 30000 s^-2.2 (rounded): fitted exponent %.3f", st.exponent);
	clusters_destroy(c);
	free(pos);

	/* nothing to fit: all single */
	double one[6] = {0, 0, 0, 5, 5, 5}, b1[3] = {10, 10, 10};
	c = clusters_create(3, 2);
	rc = clusters_compute(c, one, b1, 0.5, 0.1, &st);
	ok(rc == 0 && isnan(st.w) && isnan(st.exponent), "two free particles: no fit (NaN)");
	clusters_destroy(c);
}

/* ---- a large run: 10^6 spheres at volume fraction 0.3 ---- */

/* Labels consistent with the statistics, in O(N). */
static int labels_consistent(clusters_t *c, size_t n, const clusters_stats_t *st)
{
	uint32_t *cnt = calloc(n, sizeof(*cnt));
	uint64_t next = 0, largest = 0;
	int good = 1;
	for (size_t i = 0; i < n && good; i++) {
		uint32_t l = clusters_label(c, i);
		if (l > next) /* labels appear in order of first particle */
			good = 0;
		else {
			next += l == next;
			if (++cnt[l] > largest)
				largest = cnt[l];
		}
	}
	free(cnt);
	return good && next == st->n_clusters && largest == st->largest;
}

static void test_large(void)
{
	const size_t sizes[2] = { 100000, 1000000 };
	const double r = 0.5, delta = 0.1, phi = 0.3;
	for (int t = 0; t < 2; t++) {
		size_t n = sizes[t];
		double L = cbrt(n * ball_volume(3, r) / phi), box[3] = { L, L, L };
		double *pos = malloc(n * 3 * sizeof(double));
		uint64_t rng = 777;
		for (size_t k = 0; k < n * 3; k++)
			pos[k] = uniform(&rng) * L;
		clusters_t *c = clusters_create(3, n);
		clusters_stats_t st;
		double t0 = now();
		int rc = clusters_compute(c, pos, box, r, delta, &st);
		double t1 = now();
		rc |= clusters_compute(c, pos, box, r, delta, &st);
		double t2 = now();
		ok(rc == 0 && labels_consistent(c, n, &st),
		   "3D N=%zu phi=%.1f: %llu clusters, largest %llu, M'_2 %.2f", n, phi,
		   (unsigned long long)st.n_clusters, (unsigned long long)st.largest, st.m2_reduced);
		diag("N=%zu: first call %.3f s, second (reused workspace) %.3f s, %.0f ns/particle",
		     n, t1 - t0, t2 - t1, 1e9 * (t2 - t1) / (double)n);
		clusters_destroy(c);
		free(pos);
	}
}

/* Brute force: clusters over all pairs, minimum image on periodic axes only. */
static uint64_t brute_clusters(int dim, size_t n, const double *pos, const double *box, const int *walled, double cut)
{
	uint32_t *par = malloc(n * sizeof(uint32_t));
	for (size_t i = 0; i < n; i++)
		par[i] = (uint32_t)i;
	for (size_t i = 0; i < n; i++)
		for (size_t j = i + 1; j < n; j++) {
			double r2 = 0;
			for (int a = 0; a < dim; a++) {
				double d = pos[i * dim + a] - pos[j * dim + a];
				if (!walled[a])
					d -= box[a] * round(d / box[a]);
				r2 += d * d;
			}
			if (r2 >= cut * cut)
				continue;
			uint32_t x = (uint32_t)i, y = (uint32_t)j;
			while (par[x] != x)
				x = par[x];
			while (par[y] != y)
				y = par[y];
			par[x] = y;
		}
	uint64_t k = 0;
	for (size_t i = 0; i < n; i++)
		k += par[i] == i;
	free(par);
	return k;
}

/* Walled axes (clusters_walls): two chains, one on each wall of y (centres one radius from the wall,
 * one a little beyond it as below a vibrating wall), 1.0 apart through the periodic image: one cluster
 * when y is periodic, two when it is walled; and random configurations against brute force. */
static void test_walls(int dim)
{
	const double box[3] = { 12.0, 10.0, 9.0 }, r = 0.5, delta = 0.1;
	double pos[8 * 3] = { 0 };
	for (int k = 0; k < 4; k++) {
		pos[k * dim + 0] = pos[(4 + k) * dim + 0] = 6.0;
		pos[k * dim + 1] = 0.5 + 1.05 * k;
		pos[(4 + k) * dim + 1] = 9.5 - 1.05 * k;
		if (dim == 3)
			pos[k * dim + 2] = pos[(4 + k) * dim + 2] = 4.0;
	}
	pos[1] = 0.46;   /* a little beyond the wall's contact plane (below a vibrating wall's rest position) */
	clusters_t *c = clusters_create(dim, 8);
	clusters_stats_t st;
	int rc = clusters_compute(c, pos, box, r, delta, &st);
	ok(rc == 0 && st.n_clusters == 1 && st.largest == 8, "%dD chains on both ends of a periodic axis: one cluster "
	   "(%llu)", dim, (unsigned long long)st.n_clusters);
	int wy[3] = { 0, 1, 0 };
	rc = clusters_walls(c, wy) | clusters_compute(c, pos, box, r, delta, &st);
	ok(rc == 0 && st.n_clusters == 2 && st.largest == 4 && clusters_label(c, 3) == 0 && clusters_label(c, 4) == 1,
	   "%dD chains touching both walls of a walled axis: not joined across (%llu clusters)", dim,
	   (unsigned long long)st.n_clusters);
	clusters_destroy(c);

	/* random: 600 particles, a few beyond the walls; every subset of walled axes */
	enum { N = 600 };
	double *rp = malloc(N * 3 * sizeof(double));
	uint64_t seed = 4242 + (uint64_t)dim;
	int all = 1;
	for (int mask = 1; mask < (1 << dim); mask++) {
		int w[3] = { mask & 1, (mask >> 1) & 1, (mask >> 2) & 1 };
		for (size_t i = 0; i < N * (size_t)dim; i++) {
			int a = (int)(i % (size_t)dim);
			rp[i] = uniform(&seed) * box[a];
			if (w[a] && i % 97 == 0)
				rp[i] = (i % 2 ? -0.2 : box[a] + 0.2);
		}
		clusters_t *q = clusters_create(dim, N);
		rc = clusters_walls(q, w) | clusters_compute(q, rp, box, r, 0.6, &st);
		uint64_t want = brute_clusters(dim, N, rp, box, w, 2 * r + 0.6);
		all &= rc == 0 && st.n_clusters == want;
		clusters_destroy(q);
	}
	ok(all, "%dD random configurations, every subset of walled axes: cluster counts equal brute force", dim);
	free(rp);
}

int main(int argc, char **argv)
{
	int quick = getenv("CLUSTERS_TEST_QUICK") != NULL;
	test_bad_arguments();
	for (int dim = 2; dim <= 3; dim++) {
		test_chain(dim);
		test_boundary_pair(dim);
		test_walls(dim);
		test_small_n(dim);
	}
	test_random();
	test_ideal_gas();
	test_size_bins();
	test_fits();
	if (quick)
		skip("10^6 particle run (CLUSTERS_TEST_QUICK)");
	else
		test_large();
	plan(tap_n); /* trailing plan: the count depends on quick */
	return done_testing();
}
