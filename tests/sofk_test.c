/* Tests for engine/observe/fgrid.c and sofk.c: shells, S(k) of uncorrelated points, of doublets, of a lattice, and against direct summation. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "observe/fgrid.h"
#include "observe/sofk.h"
#include "observe/tables.h"
#include "obs_util.h"
#include "tap.h"

/* Shell populations: in a cubic box the shells are integer |n| +- 1/2;
 * count the integer vectors by brute force. */
static void test_shells(int dim, int m)
{
	double box[3] = {10, 10, 10}, modes[2048], centres[2048], edges[2049];
	int grid[3] = {m, m, m};
	fgrid_t *g = fgrid_create(dim, box, grid, 1);
	int J = fgrid_bins(g), same = J == m / 2 - 1 || J == m / 2;
	fgrid_axis(g, edges, centres, modes);
	for (int b = 0; b < J && same; b++) {
		double cnt = 0;
		int h = m / 2;
		for (int x = -h; x <= h; x++)
			for (int y = -h; y <= h; y++)
				for (int z = (dim == 3 ? -h : 0); z <= (dim == 3 ? h : 0); z++) {
					double r = sqrt((double)x * x + (double)y * y + (double)z * z);
					if (r >= b + 0.5 && r < b + 1.5)
						cnt++;
				}
		same &= cnt == modes[b];
		same &= fabs(edges[b] - (b + 0.5) * 2 * PI / 10) < 1e-12 && centres[b] > edges[b] && centres[b] < edges[b + 1];
	}
	ok(g && same, "%dD grid %d: %d shells, wave vectors per shell as counted by brute force", dim, m, J);
	fgrid_destroy(g);
}

/*
 * Uncorrelated points: S(k) = 1 at every k (the alias correction is exact
 * for them). |F|^2 / N of one mode is exponentially distributed (standard
 * deviation 1), a mode and its mirror are the same number, so a shell's
 * mean over M wave vectors has standard error <= sqrt(2/M); averaged over
 * 8 configurations. Every shell within 5 standard errors.
 */
static void test_poisson(int dim, size_t n, int m, double factor, const char *what)
{
	enum { REP = 8 };
	double box[3] = {30, 30, 30}, s[2048], acc[2048] = {0}, modes[2048];
	int grid[3] = {m, m, m};
	uint64_t seed = 11 + dim;
	fgrid_t *g = fgrid_create(dim, box, grid, 1);
	int J = fgrid_bins(g);
	size_t np = factor > 1 ? n / 2 : n;
	double *pos = malloc(n * dim * sizeof(double));
	for (int r = 0; r < REP; r++) {
		random_positions(dim, np, box, &seed, pos);
		if (factor > 1)   /* doublets: each point twice, S = 2 */
			memcpy(pos + np * dim, pos, np * dim * sizeof(double));
		sofk_compute(g, n, pos, s);
		for (int b = 0; b < J; b++)
			acc[b] += s[b] / REP;
	}
	fgrid_axis(g, NULL, NULL, modes);
	int bad = 0, upto = factor > 1 ? J / 4 : J;   /* doublets: the aliases (S = 2 there too) are not corrected for */
	double worst = 0;
	for (int b = 0; b < upto; b++) {
		double se = factor * sqrt(2 / (modes[b] * REP)), z = fabs(acc[b] - factor) / se;
		bad += z > 5;
		worst = z > worst ? z : worst;
	}
	ok(bad == 0, "%s: S(k) = %g in %d shells within 5 se (worst %.2f se; S(k1) = %.3f)", what, factor, upto, worst,
	   acc[0]);
	free(pos);
	fgrid_destroy(g);
}

/* A square lattice on the grid points: S(k) = 0 below the reciprocal
 * lattice, up to the alias term at small k (order (k h)^4). */
static void test_lattice(void)
{
	enum { M = 32 };
	double box[3] = {32, 32, 1}, s[64], pos[M * M * 2];
	int grid[3] = {M, M, 1};
	for (int i = 0; i < M; i++)
		for (int j = 0; j < M; j++) {
			pos[(i * M + j) * 2] = i + 0.5;   /* between grid points: CIC spreads over 4 */
			pos[(i * M + j) * 2 + 1] = j + 0.5;
		}
	fgrid_t *g = fgrid_create(2, box, grid, 1);
	sofk_compute(g, M * M, pos, s);
	ok(fabs(s[0]) < 1e-3 && fabs(s[1]) < 1e-3 && fabs(s[3]) < 2e-2, "2D lattice: S(k1) = %.1e, S(k2) = %.1e, S(k4) = %.1e",
	   s[0], s[1], s[3]);
	fgrid_destroy(g);
}

/*
 * One configuration of a dense random packing-like set (random points with
 * a minimum distance by rejection) against direct summation over the
 * particles: (1/N) |sum_j exp(-i k.r_j)|^2 averaged over the same wave
 * vectors. In one configuration the aliases do not average out, so the
 * grid estimate differs by about W(k + 2 pi/h) ~ (k h / 2 pi)^2 relative:
 * 2% at a quarter of the Nyquist wavenumber. Tolerance 3% + 0.02 absolute.
 */
static void test_direct(void)
{
	enum { N = 400, M = 32 };
	double box[3] = {12, 12, 12}, pos[N * 3], s[64], direct[64] = {0}, wsum[64] = {0};
	int grid[3] = {M, M, M};
	uint64_t seed = 3;
	int n = 0;
	while (n < N) {
		double p[3] = {uniform(&seed) * 12, uniform(&seed) * 12, uniform(&seed) * 12};
		int okp = 1;
		for (int j = 0; j < n && okp; j++) {
			double r2 = 0;
			for (int a = 0; a < 3; a++) {
				double d = p[a] - pos[j * 3 + a];
				d -= 12 * round(d / 12);
				r2 += d * d;
			}
			okp = r2 >= 1.0;
		}
		if (okp)
			memcpy(pos + 3 * n++, p, sizeof p);
	}
	fgrid_t *g = fgrid_create(3, box, grid, 1);
	sofk_compute(g, N, pos, s);
	int J = fgrid_bins(g);
	fgrid_mode_t md;
	for (size_t i = 0; i < fgrid_modes(g); i++) {
		if (!fgrid_mode(g, i, &md) || md.bin >= J / 4)
			continue;
		double re = 0, im = 0;
		for (int j = 0; j < N; j++) {
			double ph = md.k[0] * pos[3 * j] + md.k[1] * pos[3 * j + 1] + md.k[2] * pos[3 * j + 2];
			re += cos(ph), im -= sin(ph);
		}
		direct[md.bin] += md.weight * (re * re + im * im) / N;
		wsum[md.bin] += md.weight;
	}
	int bad = 0;
	for (int b = 0; b < J / 4; b++) {
		double d = direct[b] / wsum[b];
		bad += fabs(s[b] - d) > 0.03 * d + 0.02;
		if (fabs(s[b] - d) > 0.03 * d + 0.02)
			diag("shell %d: grid %.4f direct %.4f", b + 1, s[b], d);
	}
	ok(bad == 0, "3D N=%d: S(k) from the grid = direct summation in the %d lowest shells (S(k1) = %.4f / %.4f)", N, J / 4,
	   s[0], direct[0] / wsum[0]);
	fgrid_destroy(g);
}

/*
 * Walls (fgrid_create_walled): wave vectors only along the periodic axes; every shell holds the +-k pairs
 * of a periodic axis (2D with y walled: 2 per shell); uncorrelated points in the box (a few beyond the
 * walls, as below a vibrating wall) give S = 1 in every shell within 5 standard errors of the mean over
 * 64 configurations (the sample standard deviation over them: a shell may hold only the two wave vectors
 * +-k, which are the same number, and the window correction raises the scatter near Nyquist); one
 * configuration equals direct summation over the same wave vectors (aliases along the periodic axes
 * only); every axis walled is refused.
 */
static void test_walls(int dim, const int *walled, const char *what)
{
	enum { REP = 64, N = 20000 };
	double box[3] = {30, 40, 24}, s[2048], acc[2048] = {0}, acc2[2048] = {0}, modes[2048];
	int grid[3] = {32, 32, 32};
	uint64_t seed = 31 + dim + 2 * walled[0];
	fgrid_t *g = fgrid_create_walled(dim, box, grid, 1, walled);
	int J = g ? fgrid_bins(g) : 0, kzero = g != NULL;
	double *pos = malloc(N * dim * sizeof(double));
	fgrid_mode_t md;
	for (size_t i = 0; g && i < fgrid_modes(g); i++)
		if (fgrid_mode(g, i, &md))
			for (int a = 0; a < dim; a++)
				kzero &= !walled[a] || md.k[a] == 0;
	for (int r = 0; g && r < REP; r++) {
		random_positions(dim, N, box, &seed, pos);
		for (int a = 0; a < dim; a++)
			if (walled[a])
				pos[(size_t)r * dim + a] = r % 2 ? -0.3 : box[a] + 0.3;
		sofk_compute(g, N, pos, s);
		for (int b = 0; b < J; b++) {
			acc[b] += s[b] / REP;
			acc2[b] += s[b] * s[b] / REP;
		}
	}
	int bad = 0;
	double worst = 0;
	if (g)
		fgrid_axis(g, NULL, NULL, modes);
	for (int b = 0; b < J; b++) {
		double se = sqrt((acc2[b] - acc[b] * acc[b]) / (REP - 1)), z = fabs(acc[b] - 1) / se;
		bad += z > 5;
		worst = z > worst ? z : worst;
	}
	ok(g && J > 2 && kzero && bad == 0, "%s: k along the periodic axes only; uncorrelated points S(k) = 1 in %d shells "
	   "within 5 se (worst %.2f se; S(k1) = %.3f over %.0f wave vectors)", what, J, worst, acc[0], J ? modes[0] : 0);
	ok(tables_k_shells(dim, box, grid, walled) == J, "%s: the layout's shell count (tables_k_shells) is the grid's, %d",
	   what, J);
	/* direct summation, one configuration of 300 points, lowest quarter of the shells */
	double direct[2048] = {0}, wsum[2048] = {0};
	random_positions(dim, 300, box, &seed, pos);
	sofk_compute(g, 300, pos, s);
	for (size_t i = 0; g && i < fgrid_modes(g); i++) {
		if (!fgrid_mode(g, i, &md) || md.bin >= J / 4)
			continue;
		double re = 0, im = 0;
		for (int j = 0; j < 300; j++) {
			double ph = 0;
			for (int a = 0; a < dim; a++)
				ph += md.k[a] * pos[j * dim + a];
			re += cos(ph), im -= sin(ph);
		}
		direct[md.bin] += md.weight * (re * re + im * im) / 300;
		wsum[md.bin] += md.weight;
	}
	bad = 0;
	for (int b = 0; b < J / 4; b++)
		bad += fabs(s[b] - direct[b] / wsum[b]) > 0.03 * direct[b] / wsum[b] + 0.02;
	ok(g && bad == 0, "%s: S(k) from the grid = direct summation in the %d lowest shells", what, J / 4);
	free(pos);
	fgrid_destroy(g);
}

int main(void)
{
	plan(23);
	test_shells(2, 16);
	test_shells(3, 16);
	test_shells(2, 32);
	test_poisson(2, 20000, 64, 1, "2D uncorrelated, N=20000");
	test_poisson(3, 20000, 32, 1, "3D uncorrelated, N=20000");
	test_poisson(3, 20000, 32, 2, "3D doublets, N=20000");
	test_lattice();
	test_direct();
	ok(fgrid_create(3, (double[]){1, 1, 1}, (int[]){2, 4, 4}, 1) == NULL, "grid below 4 points refused");
	test_walls(2, (const int[]){0, 1, 0}, "2D, y walled");
	test_walls(2, (const int[]){1, 0, 0}, "2D, x walled");
	test_walls(3, (const int[]){0, 0, 1}, "3D, z walled");
	test_walls(3, (const int[]){1, 1, 0}, "3D, x and y walled");
	/* a long walled axis: shells 2 pi / 20 wide up to x's Nyquist pi 16 / 20, not 2 pi / 100 (31 shells) */
	fgrid_t *lw = fgrid_create_walled(2, (double[]){20, 100, 1}, (int[]){16, 64, 1}, 1, (const int[]){0, 1, 0});
	const double lbox[3] = {20, 100, 1};
	const int lgrid[3] = {16, 64, 1}, wy[3] = {0, 1, 0};
	ok(lw && fgrid_bins(lw) == 7 && tables_k_shells(2, lbox, lgrid, wy) == 7 &&
	   tables_k_shells(2, lbox, lgrid, NULL) == 31,
	   "a long walled axis: 7 shells along the periodic one in the grid and the layout (31 without walls)");
	fgrid_destroy(lw);
	ok(fgrid_create_walled(2, (double[]){8, 8, 1}, (int[]){8, 8, 1}, 1, (const int[]){1, 1, 0}) == NULL &&
	   fgrid_create_walled(2, (double[]){8, 8, 1}, (int[]){8, 2, 1}, 1, (const int[]){0, 1, 0}) != NULL,
	   "every axis walled refused; a walled axis ignores its grid size");
	return done_testing();
}
