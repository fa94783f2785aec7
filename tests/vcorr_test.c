/* Tests for engine/observe/vcorr.c: no correlation for independent velocities, a shear wave in the transverse structure factor and in G_par. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "observe/fgrid.h"
#include "observe/gofr.h"
#include "observe/vcorr.h"
#include "observe/vdist.h"
#include "obs_util.h"
#include "tap.h"

enum { NB = 20 };

/*
 * Velocities independent of each other and of the positions: S_par =
 * S_perp = 1 in every shell (standard error of a shell mean over M wave
 * vectors at most sqrt(2/M) for S_par, sqrt(2/((D-1) M)) for S_perp) and
 * G_par = G_perp = 0 (standard error about 1/sqrt(pairs in the bin) for a
 * product of independent unit normals). Each within 5 standard errors.
 */
static void test_uncorrelated(int dim, size_t n, int m)
{
	double box[3] = {40, 40, 40}, sp[1024], st[1024], modes[1024];
	int grid[3] = {m, m, m};
	uint64_t seed = 21 + dim;
	double *pos = malloc(n * dim * sizeof(double)), *vel = malloc(n * dim * sizeof(double));
	random_positions(dim, n, box, &seed, pos);
	for (size_t i = 0; i < n * dim; i++)
		vel[i] = 0.7 * gauss(&seed) + 1.0;
	vdist_moments_t vm;
	vdist_moments(dim, n, 1.0, vel, &vm);
	fgrid_t *g = fgrid_create(dim, box, grid, dim);
	vcorr_kspace(g, dim, n, pos, vel, vm.mean, vm.temperature, sp, st);
	fgrid_axis(g, NULL, NULL, modes);
	int J = fgrid_bins(g), bad = 0;
	double worst = 0;
	for (int b = 0; b < J; b++) {
		double z1 = fabs(sp[b] - 1) / sqrt(2 / modes[b]), z2 = fabs(st[b] - 1) / sqrt(2 / ((dim - 1) * modes[b]));
		bad += z1 > 5 || z2 > 5;
		worst = fmax(worst, fmax(z1, z2));
	}
	ok(bad == 0, "%dD independent velocities: S_par = S_perp = 1 in %d shells within 5 se (worst %.2f)", dim, J, worst);

	double c[NB], p[NB], q[NB], gp[NB], gq[NB];
	gofr_t *gr = gofr_create(dim, n, box, 5.0);
	gofr_pairs(gr, pos, vel, 0, 5.0, NB, c, p, q);
	vcorr_pairs(dim, NB, c, p, q, vm.temperature, gp, gq);
	bad = 0;
	worst = 0;
	for (int b = 2; b < NB; b++) {
		double z1 = fabs(gp[b]) * sqrt(c[b]), z2 = fabs(gq[b]) * sqrt(c[b] * (dim - 1));
		bad += z1 > 5 || z2 > 5;
		worst = fmax(worst, fmax(z1, z2));
	}
	ok(bad == 0, "%dD independent velocities: G_par = G_perp = 0 within 5 se (worst %.2f)", dim, worst);
	gofr_destroy(gr);
	fgrid_destroy(g);
	free(pos);
	free(vel);
}

/*
 * A transverse (shear) wave v_x = A sin(2 pi y / L) plus thermal noise, 2D:
 * the modes k = (0, +-2 pi/L) carry |j_x|^2 = (N A / 2)^2, all transverse,
 * so S_perp of the first shell (M = 8 wave vectors: (0, +-1), (+-1, 0),
 * (+-1, +-1) in units of 2 pi/L) is about (2 (N A/2)^2 / (N T/m) + M - 2) / M
 * and S_par stays near 1 (the wave has no longitudinal part). Neighbours
 * move together along x: G_par > 0 and G_perp > 0 at short distance.
 */
static void test_shear(void)
{
	enum { N = 20000, M = 64 };
	double box[3] = {50, 50, 1}, sp[64], st[64], A = 0.5;
	int grid[3] = {M, M, 1};
	uint64_t seed = 8;
	double *pos = malloc(N * 2 * sizeof(double)), *vel = malloc(N * 2 * sizeof(double));
	random_positions(2, N, box, &seed, pos);
	for (int i = 0; i < N; i++) {
		vel[2 * i] = 0.3 * gauss(&seed) + A * sin(2 * PI * pos[2 * i + 1] / box[1]);
		vel[2 * i + 1] = 0.3 * gauss(&seed);
	}
	vdist_moments_t vm;
	vdist_moments(2, N, 1.0, vel, &vm);
	fgrid_t *g = fgrid_create(2, box, grid, 2);
	vcorr_kspace(g, 2, N, pos, vel, vm.mean, vm.temperature, sp, st);
	double modes[64];
	fgrid_axis(g, NULL, NULL, modes);
	double expect = (2 * pow(N * A / 2, 2) / (N * vm.temperature) + modes[0] - 2) / modes[0];
	/* |j_x|^2 of the wave mode fluctuates by ~2/sqrt(N A^2) relative: 5% */
	ok(modes[0] == 8 && fabs(st[0] / expect - 1) < 0.05 && fabs(sp[0] - 1) < 5 * sqrt(2 / modes[0]),
	   "2D shear wave: S_perp(k1) = %.1f (expected %.1f), S_par(k1) = %.2f", st[0], expect, sp[0]);
	double c[NB], p[NB], q[NB], gp[NB], gq[NB];
	gofr_t *gr = gofr_create(2, N, box, 2.0);
	gofr_pairs(gr, pos, vel, 0, 2.0, NB, c, p, q);
	vcorr_pairs(2, NB, c, p, q, vm.temperature, gp, gq);
	/* <w_i w_j> over close pairs = A^2/2 of the x components; of T/m = (A^2/2 + 2 * 0.09)/2
	 * per component, the x-x part projects half on e, half across */
	double corr = A * A / 2 / 2 / vm.temperature;
	ok(fabs(gp[NB - 1] - corr) < 0.05 && fabs(gq[NB - 1] - corr) < 0.05, "2D shear wave: G_par = %.3f, G_perp = %.3f (expected %.3f)",
	   gp[NB - 1], gq[NB - 1], corr);
	gofr_destroy(gr);
	fgrid_destroy(g);
	free(pos);
	free(vel);
}

int main(void)
{
	plan(6);
	test_uncorrelated(2, 20000, 64);
	test_uncorrelated(3, 20000, 32);
	test_shear();
	return done_testing();
}
