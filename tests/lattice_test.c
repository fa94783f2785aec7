/* Lattice starts that N does not fill: the vacancy choice, and the density profile of every method's start. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "ed/ed.h"
#include "lattice.h"
#include "mc/dsmc.h"
#include "rng.h"
#include "scene.h"
#include "tap.h"

/* lattice_fill_t hands out n increasing sites of [0, m), leaves exactly one
 * vacancy in each stratum [floor(k m/v), floor((k+1) m/v)) and is a function
 * of the seed. */
static void test_fill(uint64_t m, uint64_t n)
{
	lattice_fill_t f;
	rng_t rng, rng2;
	uint64_t v = m - n, prev = 0, bad = 0, seen = 0, diff = 0;
	unsigned char *occ = calloc(m, 1);
	rng_init(&rng, 7, 0);
	rng_init(&rng2, 8, 0);
	lattice_fill_t f2;
	lattice_fill_init(&f, m, n, &rng);
	lattice_fill_init(&f2, m, n, &rng2);
	for (uint64_t i = 0; i < n; i++) {
		uint64_t j = lattice_fill_next(&f);
		if (j >= m || (i > 0 && j <= prev))
			bad++;
		else
			occ[j] = 1;
		prev = j;
		seen++;
		diff += lattice_fill_next(&f2) != j;
	}
	/* one vacancy per stratum (strata by exact 128-bit arithmetic) */
	uint64_t strata_bad = 0;
	for (uint64_t k = 0; k < v && !bad; k++) {
		uint64_t lo = (uint64_t)((unsigned __int128)k * m / v), hi = (uint64_t)((unsigned __int128)(k + 1) * m / v);
		uint64_t holes = 0;
		for (uint64_t j = lo; j < hi; j++)
			holes += !occ[j];
		strata_bad += holes != 1;
	}
	/* the same seed again gives the same sites */
	rng_init(&rng, 7, 0);
	lattice_fill_init(&f, m, n, &rng);
	uint64_t again = 0;
	for (uint64_t j = 0; j < m; j++)
		if (occ[j] && lattice_fill_next(&f) != j)
			again++;
	ok(!bad && seen == n && !strata_bad && !again && (v < 2 || v == m - 1 || diff > 0),
	   "fill %llu of %llu sites: increasing, in range, one vacancy per stratum (%llu bad strata), "
	   "same seed same sites, another seed other sites (%llu differ)",
	   (unsigned long long)n, (unsigned long long)m, (unsigned long long)strata_bad, (unsigned long long)diff);
	free(occ);
}

static int cmp(const void *p, const void *q)
{
	double a = *(const double *)p, b = *(const double *)q;
	return (a > b) - (a < b);
}

/*
 * Density profile of a start along axis a, from its positions alone. The
 * sites of these lattices (staggered rows, FCC, the simple grid of dsmc)
 * lie on P equally spaced planes normal to each axis, every plane holding
 * the same number of sites; P = L/s with s the smallest spacing of the
 * distinct coordinates (planes without any particle still count: an empty
 * slab is the bug). With the vacancies spread at random over the sites, the
 * count of a slab of p planes is hypergeometric with mean E = N p/P and a
 * variance below the binomial's, below E: it must lie within 4 sqrt(E) + 1
 * (a 4-sigma excursion has probability ~6e-5 per slab; stratified vacancies
 * vary far less). Checked for every single plane and for 10 slabs of whole
 * planes. Returns the largest |count - E| / (4 sqrt(E) + 1) (> 1: fails)
 * and the number of planes in *planes.
 */
static double profile(const double *x, uint64_t n, int dim, int a, double L, int *planes)
{
	double *c = malloc(n * sizeof(double));
	for (uint64_t i = 0; i < n; i++)
		c[i] = x[i * dim + a];
	qsort(c, n, sizeof(double), cmp);
	double tol = 1e-9 * L, s = L;
	for (uint64_t i = 1; i < n; i++)
		if (c[i] - c[i - 1] > tol && c[i] - c[i - 1] < s)
			s = c[i] - c[i - 1];
	int P = (int)lround(L / s);
	uint64_t *cnt = calloc((size_t)P, sizeof(uint64_t));
	double off = c[0] - s * floor(c[0] / s + 1e-9), worst = 0.0;
	int misplaced = 0;
	for (uint64_t i = 0; i < n; i++) {
		double q = (c[i] - off) / s;
		long k = lround(q);
		if (fabs(q - (double)k) > 1e-6 || k < 0 || k >= P)
			misplaced++;
		else
			cnt[k]++;
	}
	for (int k = 0; k < P; k++) {
		double e = (double)n / P, d = fabs((double)cnt[k] - e) / (4 * sqrt(e) + 1);
		if (d > worst) worst = d;
	}
	for (int b = 0; b < 10 && P >= 10; b++) {
		int k0 = P * b / 10, k1 = P * (b + 1) / 10;
		uint64_t sum = 0;
		for (int k = k0; k < k1; k++)
			sum += cnt[k];
		double e = (double)n * (k1 - k0) / P, d = fabs((double)sum - e) / (4 * sqrt(e) + 1);
		if (d > worst) worst = d;
	}
	*planes = P;
	free(cnt);
	free(c);
	return misplaced ? INFINITY : worst;
}

/* Start method/dim with n particles at volume fraction nu (lattice
 * positions, seed seed) and check its profile along every axis; also that
 * the start is the same for the same seed. */
static void test_start(const char *method, int dim, uint64_t n, double nu, int seed)
{
	char json[512], err[256] = "";
	scene_t sc;
	int rc;
	snprintf(json, sizeof json,
	         "{\"method\":\"%s\",\"dimensions\":%d,\"particles\":{\"count\":%llu,\"volume_fraction\":%g},"
	         "\"run\":{\"seed\":%d,\"until\":{\"time\":1}}}",
	         method, dim, (unsigned long long)n, nu, seed);
	if (scene_parse(json, strlen(json), &sc, err, sizeof err) != SCENE_OK) {
		ok(0, "%s", err);
		return;
	}
	double *x[2] = {malloc(n * dim * sizeof(double)), malloc(n * dim * sizeof(double))};
	for (int t = 0; t < 2; t++) {
		if (!strcmp(method, "ed")) {
			ed_t *ed = ed_create(&sc, &rc, err, sizeof err);
			if (ed) ed_state(ed, x[t], NULL);
			else memset(x[t], 0, n * dim * sizeof(double));
			ed_destroy(ed);
		} else {
			dsmc_t *d = dsmc_create(&sc, 0, &rc, err, sizeof err);
			if (d) dsmc_state(d, x[t], NULL);
			else memset(x[t], 0, n * dim * sizeof(double));
			dsmc_destroy(d);
		}
	}
	if (err[0]) {
		ok(0, "%s %dD N=%llu: %s", method, dim, (unsigned long long)n, err);
	} else {
		for (int a = 0; a < dim; a++) {
			int planes = 0;
			double w = profile(x[0], n, dim, a, sc.box[a], &planes);
			ok(w <= 1.0, "%s %dD N=%llu nu=%g: axis %d, %d lattice planes: every plane and 10 slabs hold N/P per plane "
			   "within 4 sqrt(E)+1 (worst at %.2f of the tolerance)", method, dim, (unsigned long long)n, nu, a, planes, w);
		}
		ok(!memcmp(x[0], x[1], n * dim * sizeof(double)), "%s %dD N=%llu: same seed, same start", method, dim,
		   (unsigned long long)n);
	}
	free(x[0]);
	free(x[1]);
}

int main(void)
{
	test_fill(10, 10);
	test_fill(10, 1);
	test_fill(10, 9);
	test_fill(1000, 500);       /* M/V = 2: strata are pairs */
	test_fill(21952, 20000);    /* dsmc 3D grid of the issue */
	test_fill(4096, 4001);
	test_fill(100003, 99991);

	/* The case of issue 19.9 (N = 20000, nu = 0.2) for every method and
	 * dimension, and smaller fills; hsmc starts as dsmc does. */
	test_start("ed", 2, 20000, 0.2, 1);
	test_start("ed", 3, 20000, 0.2, 1);
	test_start("dsmc", 2, 20000, 0.2, 1);
	test_start("dsmc", 3, 20000, 0.2, 1);
	test_start("hsmc", 3, 20000, 0.2, 2);
	test_start("ed", 3, 1000, 0.3, 3);
	test_start("ed", 2, 1500, 0.5, 4);
	test_start("dsmc", 3, 3000, 0.1, 5);
	plan(tap_n);
	return done_testing();
}
