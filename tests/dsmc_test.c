/* Validation of the Monte Carlo methods (dsmc, hsmc) against kinetic theory: Haff's law, Enskog collision rate, equation of state, conservation. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "mc/dsmc.h"
#include "run.h"
#include "scene.h"
#include "tap.h"

#include "kinetic.h"

/* Collision frequency per particle at T = 1, radius 1/2, mass 1:
 * f = D 2^(D-1) / (sqrt(pi) a) nu chi (seed 003 eq. 4.56 with g -> chi). */
static double f_theory(int dim, double nu, double chi) { return dim * pow(2, dim - 1) / (sqrt(PI) * 0.5) * nu * chi; }

/*
 * Haff's law T/T0 = 1/(1 + tau)^2, tau = (1 - e^2) f t / (2 D), with the
 * collision frequency f of the gas the method simulates: chi = 1 for
 * correction "none" (Boltzmann gas), chi = g(sigma) for "enskog"/"cba" and
 * hsmc. Systems below the shear-instability threshold (see physics_test.c),
 * so the state stays homogeneous. R replicas (seeds) give mean and standard
 * error at each of K output times. Tolerance: 4 standard errors (a 4-sigma
 * excursion has probability ~6e-5 per point) plus 1.5% of the theory for
 * what Haff's law leaves out: the Sonine coefficient a2 of the cooling state
 * (cooling rate changed by < 0.5% for e >= 0.9) and the operator-splitting
 * error of the time step (0.2 mean free times by default: the cooling per
 * step is lambda/(2D) * 0.4 <= 1%, and Euler splitting errs by a fraction of
 * that, measured < 0.5% by halving the step).
 */
static void test_haff(const char *method, const char *corr, int dim, int n, double nu, double e)
{
	enum { R = 6, K = 8 };
	static series_t s;
	const double tau_end = 2;
	double chi = strcmp(corr, "none") ? g_contact(dim, nu) : 1.0;
	double lam = 1 - e * e, f = f_theory(dim, nu, chi);
	double t_end = tau_end * 2 * dim / (lam * f);
	double ratio[K][R];
	int okrun = 1;
	for (int r = 0; r < R && okrun; r++) {
		char json[1024];
		snprintf(json, sizeof(json),
		         "{\"method\":\"%s\",\"dimensions\":%d,\"particles\":{\"count\":%d,\"volume_fraction\":%g,"
		         "\"initial\":{\"positions\":\"random\"}},\"collisions\":{\"restitution\":%g},"
		         "\"run\":{\"seed\":%d,\"until\":{\"time\":%.17g}},"
		         "\"output\":{\"every\":{\"time\":%.17g},\"observables\":[\"temperature\"]},"
		         "\"%s\":{\"correction\":\"%s\"}}",
		         method, dim, n, nu, e, 300 + r, t_end, t_end / K, method, corr);
		okrun = run_json(json, &s) == 0 && s.n == K + 1;
		for (int k = 0; okrun && k < K; k++)
			ratio[k][r] = s.rec[k + 1].temperature / s.rec[0].temperature;
	}
	if (!okrun) {
		ok(0, "Haff %s/%s %dD ran", method, corr, dim);
		return;
	}
	double t[K];
	for (int k = 0; k < K; k++)
		t[k] = s.rec[k + 1].time;
	double worst = haff_worst(K, R, &ratio[0][0], t, lam * f / (2 * dim));
	ok(worst < 1, "Haff %s/%s %dD N=%d nu=%.2f e=%.2f to tau=%.0f: worst deviation %.2f of tolerance", method, corr,
	   dim, n, nu, e, tau_end, worst);
}

/*
 * contact_value "local": chi per cell from the M particles expected in the
 * ring of 3^D - 1 cells around it, with the second-order (delta-method)
 * convexity term removed in the engine. What remains is O(1/M^2): the third
 * central moment of a Poisson count (g''' nu^3 / (6 M^2)) and g'' taken at
 * the estimate rather than the mean (g''' nu^3 / (2 M^2)), relative to g:
 * residual = (2/3) |g'''| nu^3 / (g M^2). g''' by central differences.
 */
static double local_residual(const char *json, int dim, double nu)
{
	scene_t sc;
	dsmc_params_t p;
	if (scene_parse(json, strlen(json), &sc, NULL, 0) != SCENE_OK || dsmc_params(&sc, &p, NULL, 0) != DSMC_OK)
		return 0;
	double h = sc.box[0] / floor(sc.box[0] / p.cell_edge), ring = pow(3, dim) - 1;
	double M = nu * ring * pow(h, dim) / scene_particle_volume(&sc), e = 1e-3;
	double g3 = (g_contact(dim, nu + 2 * e) - 2 * g_contact(dim, nu + e) + 2 * g_contact(dim, nu - e) -
	             g_contact(dim, nu - 2 * e)) / (2 * e * e * e);
	return 2.0 / 3.0 * fabs(g3) * nu * nu * nu / (g_contact(dim, nu) * M * M);
}

/*
 * Elastic equilibrium: collision frequency f/sqrt(T) against n sigma_T <g>
 * chi, and compressibility Z = 1 + 2^(D-1) nu chi from the collision virial
 * (the Enskog equation of state: Henderson in 2D, Carnahan-Starling in 3D,
 * whose chi the corrected methods use). Blocks of 2 mean free times are
 * nearly independent (velocities decorrelate within a collision time), so
 * the block standard error is the statistical error; tolerance 4 standard
 * errors plus `model` (relative): 0 for dsmc/enskog, where the sampled rate
 * is the formula, and for the CBA offset (cba, hsmc) the depletion of
 * same-cell pairs by the offset, which pushes partners one diameter apart:
 * a hole of ~(2 sigma)^D in a cell of L^D, a few percent at the default L.
 */
static void test_eos(const char *method, const char *corr, int dim, int n, double nu, double model, int local)
{
	static series_t s;
	double chi = strcmp(corr, "none") ? g_contact(dim, nu) : 1.0, f = f_theory(dim, nu, chi);
	char json[1024];
	const char *contact = local ? ",\"contact_value\":\"local\"" : "";
	snprintf(json, sizeof(json),
	         "{\"method\":\"%s\",\"dimensions\":%d,\"particles\":{\"count\":%d,\"volume_fraction\":%g,"
	         "\"initial\":{\"positions\":\"random\",\"relax\":{\"collisions_per_particle\":5}}},"
	         "\"run\":{\"seed\":11,\"until\":{\"time\":%.17g}},"
	         "\"output\":{\"every\":{\"time\":%.17g},\"observables\":[\"temperature\",\"compressibility\",\"collision_rate\"]},"
	         "\"%s\":{\"correction\":\"%s\"%s}}",
	         method, dim, n, nu, 60 / f, 2 / f, method, corr, contact);
	if (local)
		model += local_residual(json, dim, nu);
	if (run_json(json, &s) != 0 || s.n < 20) {
		ok(0, "EOS %s %dD ran", method, dim);
		return;
	}
	double z[1024], r[1024], zm, zse, rm, rse;
	int k = 0;
	for (int i = 1; i < s.n; i++, k++) {
		z[k] = s.rec[i].compressibility;
		r[k] = s.rec[i].collision_rate / sqrt(s.rec[i].temperature);
	}
	mean_se(z, k, &zm, &zse);
	mean_se(r, k, &rm, &rse);
	double zt = 1 + pow(2, dim - 1) * nu * chi;
	double tol = 4 * zse + model * zt;
	ok(fabs(zm - zt) < tol, "EOS %s/%s%s %dD nu=%.2f: Z = %.4f +- %.4f, Enskog %.4f (tolerance %.4f)", method, corr,
	   local ? "/local" : "", dim, nu, zm, zse, zt, tol);
	tol = 4 * rse + model * f;
	ok(fabs(rm - f) < tol, "rate %s/%s%s %dD nu=%.2f: f/sqrt(T) = %.4f +- %.4f, theory %.4f (tolerance %.4f)", method,
	   corr, local ? "/local" : "", dim, nu, rm, rse, f, tol);
}

/*
 * HSMC near its maximum density: many full cells, cell-cell collisions and
 * rejected moves. Elastic particles: particle collisions conserve momentum
 * and energy up to rounding, and cell collisions conserve both exactly by
 * construction (the macroscopic loss is returned as thermal motion), so
 * after ~10^5 collisions energy drifts by no more than rounding (~1e-16
 * per operation, random walk ~1e-13): 1e-10 flags any leak. Momentum stays
 * zero to rounding (relative to N m v_th).
 */
static void test_hsmc_conservation(int dim, double nu, double numax, double e)
{
	char json[1024], err[256];
	scene_t sc;
	int rc;
	snprintf(json, sizeof(json),
	         "{\"method\":\"hsmc\",\"dimensions\":%d,\"particles\":{\"count\":3000,\"volume_fraction\":%g,"
	         "\"initial\":{\"positions\":\"random\"}},\"collisions\":{\"restitution\":%g},"
	         "\"run\":{\"until\":{\"time\":1}},\"hsmc\":{\"cell_size\":2,\"max_volume_fraction\":%g}}",
	         dim, nu, e, numax);
	if (scene_parse(json, strlen(json), &sc, err, sizeof(err)) != SCENE_OK) {
		ok(0, "hsmc scene: %s", err);
		return;
	}
	dsmc_t *d = dsmc_create(&sc, 0, &rc, err, sizeof(err));
	if (!d) {
		ok(0, "hsmc create: %s", err);
		return;
	}
	dsmc_sample_t a, b;
	dsmc_sample(d, &a);
	dsmc_advance(d, INFINITY, 100000, UINT64_MAX);
	dsmc_sample(d, &b);
	double pm = 0;
	for (int k = 0; k < dim; k++)
		pm = fmax(pm, fabs(b.momentum[k]));
	double pscale = sc.count * sqrt(sc.temperature);
	ok(b.cell_collisions > 100 && b.rejected_moves > 100, "hsmc %dD nu=%.2f: %llu cell collisions, %llu rejected moves",
	   dim, nu, (unsigned long long)b.cell_collisions, (unsigned long long)b.rejected_moves);
	ok(pm / pscale < 1e-12, "hsmc %dD e=%g: total momentum %.2e of N m v_th", dim, e, pm / pscale);
	if (e == 1)
		ok(fabs(b.kinetic_energy / a.kinetic_energy - 1) < 1e-10, "hsmc %dD elastic: relative energy change %.2e",
		   dim, b.kinetic_energy / a.kinetic_energy - 1);
	dsmc_destroy(d);
}

/* Same seed and stream: bit-identical; another stream: different. */
static void test_determinism(void)
{
	static series_t a, b;
	const char *fmt = "{\"method\":\"hsmc\",\"dimensions\":2,\"particles\":{\"count\":1000,\"volume_fraction\":0.6},"
	                  "\"collisions\":{\"restitution\":0.8},\"run\":{\"seed\":%d,\"until\":{\"time\":2}},"
	                  "\"hsmc\":{\"cell_size\":2}}";
	char j1[512], j2[512];
	snprintf(j1, sizeof j1, fmt, 5);
	snprintf(j2, sizeof j2, fmt, 6);
	int same = run_json(j1, &a) == 0 && run_json(j1, &b) == 0 && a.n == b.n;
	for (int i = 0; same && i < a.n; i++)
		same = a.rec[i].kinetic_energy == b.rec[i].kinetic_energy && a.rec[i].collisions == b.rec[i].collisions;
	ok(same, "hsmc: same scene twice gives identical records");
	int differ = run_json(j2, &b) == 0 && b.rec[b.n - 1].kinetic_energy != a.rec[a.n - 1].kinetic_energy;
	ok(differ, "hsmc: another seed gives another run");
}

int main(void)
{
	/* Dilute/Boltzmann: DSMC without correction against chi = 1. */
	test_haff("dsmc", "none", 2, 500, 0.1, 0.95);
	test_haff("dsmc", "none", 3, 2000, 0.1, 0.9);
	/* Moderately dense, Enskog rate (3D N=2000 nu=0.25: optical depth
	 * l = (N nu^2 pi/6)^(1/3) = 4.0, shear threshold 5 pi^3/(144 l^2) =
	 * 0.066 > lambda = 0.0396 at e = 0.98). */
	test_haff("dsmc", "enskog", 3, 2000, 0.25, 0.98);
	/* 2D N=500 nu=0.4: l = sqrt(N nu pi/4) = 12.5, threshold 0.049 > 0.0396. */
	test_haff("hsmc", "cba", 2, 500, 0.4, 0.98);

	test_eos("dsmc", "none", 2, 2000, 0.05, 0, 0);
	test_eos("dsmc", "enskog", 2, 2000, 0.4, 0, 0);
	test_eos("dsmc", "enskog", 3, 2000, 0.25, 0, 0);
	test_eos("hsmc", "cba", 2, 2000, 0.4, 0.03, 0);
	test_eos("hsmc", "cba", 3, 2000, 0.25, 0.03, 0);
	/* Local contact value: in a homogeneous gas the same Enskog rate and EOS. */
	test_eos("dsmc", "enskog", 2, 2000, 0.4, 0, 1);
	test_eos("dsmc", "enskog", 3, 2000, 0.25, 0, 1);
	test_eos("hsmc", "cba", 2, 2000, 0.4, 0.03, 1);

	test_hsmc_conservation(2, 0.75, 0.82, 1);
	test_hsmc_conservation(3, 0.55, 0.6, 1);
	test_hsmc_conservation(2, 0.75, 0.82, 0.7);
	test_determinism();
	plan(tap_n);
	return done_testing();
}
