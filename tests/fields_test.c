/* Tests for engine/observe/fields.c: cell assignment (wrap, clamp), an ideal gas's cell counts (chi-square), Maxwellian cell temperatures and velocities, spins, exposure averages, the checkpoint state. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "observe/fields.h"
#include "obs_util.h"
#include "tap.h"

/* Upper quantile of chi-square with k degrees of freedom at the standard normal quantile z (Wilson-Hilferty:
 * good to about 1% of the quantile for k >= 10). */
static double chi2_quantile(double k, double z)
{
	double a = 2.0 / (9.0 * k);
	return k * pow(1.0 - a + z * sqrt(a), 3);
}

/* Hand-placed particles: cells of points inside, on the edges, outside a periodic box and beyond walls. */
static void test_cells(void)
{
	const double box[3] = {4.0, 2.0, 1.0};
	const int cells[3] = {4, 2, 1}, per[3] = {1, 0, 0};
	fields_t *f = fields_create(2, box, cells, per, 0);
	ok(f != NULL && fields_cells(f) == 8, "2D grid 4 x 2: 8 cells");
	double x[][2] = {{0.5, 0.5}, {3.5, 1.5}, {-0.25, 0.5}, {4.0, 0.5}, {1.0, -0.3}, {1.0, 2.0}, {9.5, 1.2}};
	size_t want[] = {0, 7, 3, 0, 1, 5, 5};
	int good = 1;
	for (size_t i = 0; i < sizeof want / sizeof want[0]; i++)
		if (fields_cell_of(f, x[i]) != want[i]) {
			diag("point (%g, %g): cell %zu, want %zu", x[i][0], x[i][1], fields_cell_of(f, x[i]), want[i]);
			good = 0;
		}
	ok(good, "x fastest; periodic x wraps (-0.25 -> last cell, L -> first); walled y clamps (below 0, at L)");
	fields_destroy(f);
	int bad[3] = {0, 2, 2}, big[3] = {128, 257, 1};
	ok(!fields_create(2, box, bad, per, 0) && !fields_create(2, box, big, per, 0) && !fields_create(4, box, cells, per, 0) &&
	   !fields_create(2, box, cells, per, 2), "refused: a zero cell count, more than 2^15 cells, dim 4, spin_dim 2");
}

/*
 * An ideal gas: N independent uniform positions, K equal cells. The counts
 * are multinomial(N, 1/K): X^2 = sum (n_c - N/K)^2 / (N/K) follows chi-square
 * with K - 1 degrees of freedom (N/K >= 50 here, so the approximation is
 * good). Two-sided test at significance 0.002 (0.001 each tail): a wrong
 * cell volume or a cell never filled makes X^2 huge, positions binned by
 * index rather than coordinate make it tiny. The counts sum to N exactly.
 */
static void test_uniform(int dim)
{
	const size_t n = 20000;
	const double box[3] = {7.0, 5.0, 3.0};
	const int cells[3] = {dim == 2 ? 10 : 6, dim == 2 ? 8 : 5, 4}, per[3] = {1, 1, 1};
	uint64_t seed = 17 + dim;
	double *pos = malloc(n * dim * sizeof(double)), *vel = calloc(n * dim, sizeof(double));
	random_positions(dim, n, box, &seed, pos);
	fields_t *f = fields_create(dim, box, cells, per, 0);
	size_t K = fields_cells(f);
	double *count = malloc(K * sizeof(double)), *dens = malloc(K * sizeof(double));
	fields_add(f, n, pos, vel, NULL);
	fields_result(f, 1.0, count, dens, NULL, NULL, NULL);
	double e = (double)n / K, x2 = 0, tot = 0, vc = 1.0, derr = 0;
	for (int a = 0; a < dim; a++)
		vc *= box[a] / cells[a];
	for (size_t c = 0; c < K; c++) {
		x2 += (count[c] - e) * (count[c] - e) / e;
		tot += count[c];
		derr = fmax(derr, fabs(dens[c] - count[c] / vc));
	}
	double lo = chi2_quantile(K - 1, -3.090), hi = chi2_quantile(K - 1, 3.090);
	ok(x2 > lo && x2 < hi, "%dD ideal gas, %zu cells of %.0f expected: X^2 = %.1f within the 0.1%% tails [%.1f, %.1f] of "
	   "chi-square(%zu)", dim, K, e, x2, lo, hi, K - 1);
	ok(tot == (double)n, "%dD counts sum to N = %zu", dim, n);
	ok(derr < 1e-12 * e / vc, "%dD density = count / cell volume %.4g", dim, vc);
	fields_destroy(f);
	free(pos);
	free(vel);
	free(count);
	free(dens);
}

/*
 * Maxwellian velocities at temperature T0 with a flow u0, mass m, S instants
 * of independent draws: in a cell of n visits, u_c has standard deviation
 * sqrt(T0 / (m n)) per component, and D n T_c / T0 is chi-square with
 * D (n - 1) degrees of freedom, so T_c has mean T0 (n - 1) / n and standard
 * deviation T0 sqrt(2 D (n - 1)) / (D n). Every cell within 5 of its
 * standard deviations (K cells: a false alarm has probability < K * 6e-7),
 * and the pooled chi-square of the temperatures within its 0.1% tails.
 * Spins: mean w0 per cell within 5 sqrt(var / n).
 */
static void test_maxwell(int dim)
{
	const size_t n = 8000;
	const int S = 3, sd = dim == 2 ? 1 : 3;
	const double box[3] = {4.0, 4.0, 4.0}, m = 2.5, T0 = 0.7, u0[3] = {0.3, -1.1, 0.5}, w0[3] = {2.0, -0.5, 0.25};
	const int cells[3] = {4, 4, dim == 2 ? 1 : 2}, per[3] = {0, 1, 1};
	uint64_t seed = 99 + dim;
	double *pos = malloc(n * dim * sizeof(double)), *vel = malloc(n * dim * sizeof(double));
	double *spin = malloc(n * sd * sizeof(double));
	fields_t *f = fields_create(dim, box, cells, per, sd);
	size_t K = fields_cells(f);
	double *count = malloc(K * sizeof(double)), *temp = malloc(K * sizeof(double)), *u[3], *w[3];
	for (int a = 0; a < 3; a++) {
		u[a] = malloc(K * sizeof(double));
		w[a] = malloc(K * sizeof(double));
	}
	for (int k = 0; k < S; k++) {
		random_positions(dim, n, box, &seed, pos);
		for (size_t i = 0; i < n * dim; i++)
			vel[i] = u0[i % dim] + sqrt(T0 / m) * gauss(&seed);
		for (size_t i = 0; i < n * sd; i++)
			spin[i] = w0[i % sd] + 0.8 * gauss(&seed);
		fields_add(f, n, pos, vel, spin);
	}
	ok(fields_result(f, m, count, NULL, u, temp, w) == S, "%dD %d instants added", dim, S);
	double worst_t = 0, worst_u = 0, worst_w = 0, x2 = 0;
	for (size_t c = 0; c < K; c++) {
		double nv = count[c] * S;
		double sdt = T0 * sqrt(2.0 * dim * (nv - 1)) / (dim * nv), z = (temp[c] - T0 * (nv - 1) / nv) / sdt;
		worst_t = fmax(worst_t, fabs(z));
		x2 += z * z;
		for (int a = 0; a < dim; a++)
			worst_u = fmax(worst_u, fabs(u[a][c] - u0[a]) / sqrt(T0 / (m * nv)));
		for (int a = 0; a < sd; a++)
			worst_w = fmax(worst_w, fabs(w[a][c] - w0[a]) / (0.8 / sqrt(nv)));
	}
	ok(worst_t < 5, "%dD cell temperatures: largest deviation %.2f standard deviations (< 5)", dim, worst_t);
	ok(x2 > chi2_quantile(K, -3.090) && x2 < chi2_quantile(K, 3.090),
	   "%dD temperatures: sum of squared z %.1f within the 0.1%% tails of chi-square(%zu)", dim, x2, K);
	ok(worst_u < 5, "%dD cell velocities: largest deviation %.2f standard deviations (< 5)", dim, worst_u);
	ok(worst_w < 5, "%dD cell spins: largest deviation %.2f standard deviations (< 5)", dim, worst_w);

	/* state round trip: a copy gives the same fields; the same instant added twice keeps the counts */
	size_t k = fields_state_size(f);
	double *st = malloc(k * sizeof(double)), *c2 = malloc(K * sizeof(double)), *t2 = malloc(K * sizeof(double));
	fields_state_get(f, st);
	fields_t *g = fields_create(dim, box, cells, per, sd);
	ok(fields_state_set(g, st) == 0 && fields_result(g, m, c2, NULL, NULL, t2, NULL) == S &&
	   !memcmp(c2, count, K * sizeof(double)) && !memcmp(t2, temp, K * sizeof(double)),
	   "%dD state of %zu doubles restores the sums bit for bit", dim, k);
	st[0] = -1;
	ok(fields_state_set(g, st) < 0, "%dD a negative visit count is refused", dim);
	fields_reset(g);
	fields_add(g, n, pos, vel, spin);
	fields_add(g, n, pos, vel, spin);
	fields_result(g, m, c2, NULL, NULL, NULL, NULL);
	fields_reset(f);
	fields_add(f, n, pos, vel, spin);
	fields_result(f, m, count, NULL, NULL, NULL, NULL);
	ok(!memcmp(c2, count, K * sizeof(double)), "%dD one configuration twice: the same mean occupation", dim);
	fields_reset(f);
	fields_result(f, m, count, NULL, NULL, NULL, NULL);
	ok(isnan(count[0]) && fields_samples(f) == 0, "%dD no instants: NaN", dim);
	fields_destroy(g);
	fields_destroy(f);
	free(st);
	free(c2);
	free(t2);
	free(pos);
	free(vel);
	free(spin);
	free(count);
	free(temp);
	for (int a = 0; a < 3; a++) {
		free(u[a]);
		free(w[a]);
	}
}

int main(void)
{
	plan(27);
	test_cells();
	test_uniform(2);
	test_uniform(3);
	test_maxwell(2);
	test_maxwell(3);
	return done_testing();
}
