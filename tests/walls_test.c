/* Tests of walls and gravity in the event-driven engine against theory: wall pressure, barometric height, thermal walls, vibrating walls, a settling bed, exact checkpoints. */
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <jansson.h>

#include "ed/ed.h"
#include "scene.h"
#include "preset_file.h"
#include "tap.h"
#include "stats.h"
#include "ed_util.h"
#include "place.h"

#ifndef M_PI
#define M_PI 3.14159265358979323846
#endif

/* Henderson's equation of state of hard disks, Z = (1 + eta^2/8)/(1 - eta)^2
 * (within 1e-4 of simulations at eta = 0.05). */
static double z_henderson(double eta)
{
	return (1.0 + eta * eta / 8.0) / ((1.0 - eta) * (1.0 - eta));
}

/* Elastic disks between two specular walls (y), periodic in x: energy
 * conserved, and the pressure on the walls (momentum per unit time and
 * length) is the bulk pressure n T Z(eta) with n = N / (L_x (L_y - sigma))
 * (the centres' accessible area). */
static void test_specular_pressure(void)
{
	const char *json = "{\"method\":\"ed\",\"dimensions\":2,\"particles\":{\"count\":1000,\"volume_fraction\":0.05,"
	                   "\"initial\":{\"positions\":\"random\",\"temperature\":1}},"
	                   "\"boundaries\":{\"y\":{\"type\":\"walls\",\"lower\":{\"type\":\"specular\"},"
	                   "\"upper\":{\"type\":\"specular\"}}},\"run\":{\"seed\":11,\"until\":{\"time\":1}}}";
	scene_t sc;
	ed_t *ed = make(json, &sc);
	if (!ed) {
		ok(0, "specular walls: setup");
		ok(0, "specular walls: pressure");
		return;
	}
	ed_sample_t sm;
	ed_sample(ed, &sm);
	const double e0 = sm.kinetic_energy;
	enum { K = 40 };
	const double tau = 60.0, t_eq = 100.0;
	double p[K];
	ed_advance(ed, t_eq, UINT64_MAX, UINT64_MAX);
	ed_sample(ed, &sm);
	for (int k = 0; k < K; k++) {
		ed_advance(ed, t_eq + (k + 1) * tau, UINT64_MAX, UINT64_MAX);
		ed_sample(ed, &sm);
		/* momentum into the lower wall is -y, into the upper +y */
		p[k] = (-sm.wall_impulse[2][1] + sm.wall_impulse[3][1]) / (2.0 * sm.interval * sc.box[0]);
	}
	const double drift = fabs(sm.kinetic_energy - e0) / e0;
	ok(drift < 1e-12 && ed_min_gap(ed) > -1e-9,
	   "specular walls, elastic: energy conserved to %.2g relative over %llu collisions and %llu wall hits, no overlap",
	   drift, (unsigned long long)sm.collisions, (unsigned long long)sm.wall_collisions);
	double mean, se;
	mean_se(p, K, &mean, &se);
	const double sigma = 2.0 * sc.radius, T = 2.0 * e0 / (2.0 * sc.count);
	const double n = sc.count / (sc.box[0] * (sc.box[1] - sigma));
	const double eta = n * M_PI * sigma * sigma / 4.0, theory = n * T * z_henderson(eta);
	/* 4 standard errors of the block means, plus 1e-3 relative for what the
	 * bulk formula neglects (the density excess at the walls, O(eta sigma /
	 * L_y) = 4e-4; the EOS, 1e-4). Z - 1 = 0.11 here, far outside it. */
	const double tol = 4.0 * se + 1e-3 * theory;
	ok(fabs(mean - theory) < tol,
	   "specular walls: wall pressure %.6g +- %.2g (%d blocks), theory n T Z = %.6g (Z = %.4f), tolerance %.2g",
	   mean, se, K, theory, z_henderson(eta), tol);
	ed_destroy(ed);
}

/* Second-virial local-density theory of a dilute hard-disk gas in gravity:
 * T (1 + 2 b n) dn/dy = -m g n with b = pi sigma^2 / 2, i.e.
 * ln n + 2 b n = c - y / lambda. Returns the mean height of the centres on
 * [y0, y1] for N particles over a width Lx. */
static double com_theory(double lambda, double b, double y0, double y1, double N, double Lx)
{
	enum { M = 4000 };
	double lo = -40.0, hi = 10.0, com = 0.0;
	for (int it = 0; it < 200; it++) {
		double c = 0.5 * (lo + hi), sn = 0.0, sy = 0.0, dy = (y1 - y0) / M;
		for (int i = 0; i < M; i++) {
			double y = y0 + (i + 0.5) * dy, rhs = c - y / lambda;
			double nn = exp(rhs);
			for (int k = 0; k < 50; k++) {   /* Newton on ln n + 2 b n = rhs */
				double f = log(nn) + 2.0 * b * nn - rhs;
				nn -= f / (1.0 / nn + 2.0 * b);
				if (nn <= 0.0)
					nn = 1e-300;
			}
			sn += nn * dy;
			sy += nn * y * dy;
		}
		com = sy / sn;
		if (sn * Lx > N)
			hi = c;
		else
			lo = c;
	}
	return com;
}

/* Elastic disks under gravity on a specular floor under a specular lid:
 * kinetic + potential energy conserved, and the time-averaged
 * centre-of-mass height is the barometric one at the measured temperature. */
static void test_barometric(void)
{
	const char *json = "{\"method\":\"ed\",\"dimensions\":2,\"particles\":{\"count\":300,\"box\":[600,120],"
	                   "\"initial\":{\"positions\":\"random\",\"temperature\":1}},"
	                   "\"boundaries\":{\"y\":{\"type\":\"walls\",\"lower\":{\"type\":\"specular\"},"
	                   "\"upper\":{\"type\":\"specular\"}}},\"gravity\":[0,-0.05],"
	                   "\"run\":{\"seed\":12,\"until\":{\"time\":1}}}";
	scene_t sc;
	ed_t *ed = make(json, &sc);
	if (!ed) {
		ok(0, "gravity: setup");
		ok(0, "gravity: barometric");
		return;
	}
	ed_sample_t sm;
	ed_sample(ed, &sm);
	const double e0 = sm.kinetic_energy + sm.potential_energy;
	double emax = 0.0;
	const double t_eq = 3000.0, dt = 5.0;
	enum { K = 40, PER = 100 };
	double com[K], temp[K];
	ed_advance(ed, t_eq, UINT64_MAX, UINT64_MAX);
	ed_sample(ed, &sm);
	double t = t_eq;
	for (int k = 0; k < K; k++) {
		double sc_sum = 0.0, ek_int = 0.0, span = 0.0;
		for (int i = 0; i < PER; i++) {
			t += dt;
			ed_advance(ed, t, UINT64_MAX, UINT64_MAX);
			ed_sample(ed, &sm);
			sc_sum += sm.com_height;
			ek_int += sm.ekin_time_integral;
			span += sm.interval;
			double e = fabs(sm.kinetic_energy + sm.potential_energy - e0) / e0;
			if (e > emax)
				emax = e;
		}
		com[k] = sc_sum / PER;
		temp[k] = 2.0 * ek_int / (2.0 * sc.count * span);
	}
	ok(emax < 1e-12 && ed_min_gap(ed) > -1e-9,
	   "gravity: kinetic + potential energy conserved to %.2g relative (largest over %d samples), no overlap",
	   emax, K * PER);
	double hm, hse, tm, tse;
	mean_se(com, K, &hm, &hse);
	mean_se(temp, K, &tm, &tse);
	const double sigma = 2.0 * sc.radius, g = 0.05;
	const double lambda = tm / (sc.mass * g), b = M_PI * sigma * sigma / 2.0;
	const double theory = com_theory(lambda, b, sc.radius, sc.box[1] - sc.radius, sc.count, sc.box[0]);
	const double ideal = com_theory(lambda, 0.0, sc.radius, sc.box[1] - sc.radius, sc.count, sc.box[0]);
	/* 4 standard errors of the height, plus the temperature's standard
	 * error propagated (dH/dT ~ H/T), plus 1e-3 relative for what the
	 * theory neglects: third virial (eta_floor^2 ~ 4e-4) and the
	 * microcanonical ensemble (O(1/N) = 3e-3 on the temperature, already in
	 * the measured T). */
	const double tol = 4.0 * sqrt(hse * hse + (theory * tse / tm) * (theory * tse / tm)) + 1e-3 * theory;
	ok(fabs(hm - theory) < tol,
	   "gravity: centre-of-mass height %.5g +- %.2g at T = %.5g +- %.2g, theory %.5g (ideal gas %.5g), tolerance %.2g",
	   hm, hse, tm, tse, theory, ideal, tol);
	ed_destroy(ed);
}

/* Henderson's pressure in units of 4 T / (pi sigma^2): P(eta) = eta Z(eta),
 * and dP/deta. */
static double p_henderson_deta(double eta)
{
	const double u = 1.0 - eta;
	return ((1.0 + 3.0 * eta * eta / 8.0) * u + 2.0 * eta * (1.0 + eta * eta / 8.0)) / (u * u * u);
}

/* Local-density (Enskog) hydrostatics of hard disks: dp/dy = -m g n with p
 * = n T Z(eta): d eta / dy = -(m g / T) eta / P'(eta), from the floor's
 * contact plane y = lo up to hi; the floor's eta shot (bisection) so that
 * the column holds N disks over the width W. Returns the mean height of
 * the centres. RK4 in steps of 1e-3 of the scale height. */
static double column_eta(double eta, double k) { return -k * eta / p_henderson_deta(eta); }

static double enskog_column_com(double T, double mg, double sigma, double lo, double hi, double N, double W)
{
	const double k = mg / T, dy = 1e-3 / k, area = M_PI * sigma * sigma / 4.0;
	double a = 0.0, b = 0.9, com = 0.0;
	for (int it = 0; it < 60; it++) {
		const double e0 = 0.5 * (a + b);
		double eta = e0, m = 0.0, my = 0.0;
		for (double y = lo; y < hi && eta > 1e-12; y += dy) {
			double h = fmin(dy, hi - y);
			double k1 = column_eta(eta, k), k2 = column_eta(eta + 0.5 * h * k1, k);
			double k3 = column_eta(eta + 0.5 * h * k2, k), k4 = column_eta(eta + h * k3, k);
			double e1 = eta + h / 6.0 * (k1 + 2 * k2 + 2 * k3 + k4);
			m += 0.5 * (eta + e1) * h;   /* trapezoid: the profile is smooth on this step */
			my += 0.5 * (eta * y + e1 * (y + h)) * h;
			eta = e1;
		}
		com = my / m;
		if (m / area * W < N)
			a = e0;
		else
			b = e0;
	}
	return com;
}

/* A dense elastic column: 600 disks under gravity in a 20-wide box whose
 * floor reaches volume fraction ~0.34, where the pressure is twice the
 * ideal gas's. The time-averaged centre-of-mass height against Enskog
 * hydrostatics with Henderson's equation of state at the measured T
 * (enskog_column_com(); the ideal gas would sit 20 diameters lower, the
 * second-virial estimate of test_barometric() several lower). Tolerance:
 * 4 standard errors of 40 block means (50 time units each, ~ a sound
 * crossing of the dense part) with the temperature's error propagated,
 * plus 0.5% of the height above the floor for the theory: Henderson's Z is
 * within ~0.5% of hard-disk simulations below eta = 0.4, and the local-
 * density approximation misses the layering at the floor and gradient
 * terms of order (sigma / scale height)^2 ~ 1e-3. */
static void test_dense_column(void)
{
	const char *json = "{\"method\":\"ed\",\"dimensions\":2,\"particles\":{\"count\":600,\"radius\":0.5,\"box\":[20,400],"
	                   "\"initial\":{\"positions\":\"random\",\"temperature\":1,\"region\":{\"upper\":[20,60]}}},"
	                   "\"boundaries\":{\"x\":{\"type\":\"walls\",\"lower\":{\"type\":\"specular\"},"
	                   "\"upper\":{\"type\":\"specular\"}},\"y\":{\"type\":\"walls\",\"lower\":{\"type\":\"specular\"},"
	                   "\"upper\":{\"type\":\"specular\"}}},\"gravity\":[0,-0.02],"
	                   "\"run\":{\"seed\":1,\"until\":{\"time\":1}}}";
	scene_t sc;
	char err[512] = "";
	double *placed = malloc(600 * 2 * sizeof(double));
	ed_t *ed = NULL;
	int rc;
	/* the engine program places particles.initial.region (run.c); here by hand */
	if (placed && scene_parse(json, strlen(json), &sc, err, sizeof err) == SCENE_OK &&
	    place_region(&sc, 0, placed, err, sizeof err) == PLACE_OK) {
		sc.init_pos = placed;
		ed = ed_create(&sc, &rc, err, sizeof err);
	}
	if (!ed) {
		free(placed);
		ok(0, "dense column: setup: %s", err);
		return;
	}
	enum { K = 40, PER = 10 };
	const double g = 0.02, t0 = 1000.0, dt = 5.0;
	double com[K], temp[K];
	ed_sample_t sm;
	ed_advance(ed, t0, UINT64_MAX, UINT64_MAX);
	ed_sample(ed, &sm);
	double t = t0;
	for (int k = 0; k < K; k++) {
		double h = 0.0, ek = 0.0, span = 0.0;
		for (int i = 0; i < PER; i++) {
			t += dt;
			ed_advance(ed, t, UINT64_MAX, UINT64_MAX);
			ed_sample(ed, &sm);
			h += sm.com_height;
			ek += sm.ekin_time_integral;
			span += sm.interval;
		}
		com[k] = h / PER;
		temp[k] = 2.0 * ek / (2.0 * sc.count * span);
	}
	double hm, hse, tm, tse;
	mean_se(com, K, &hm, &hse);
	mean_se(temp, K, &tm, &tse);
	const double sigma = 2.0 * sc.radius, lo = sc.radius, hi = sc.box[1] - sc.radius;
	const double theory = enskog_column_com(tm, sc.mass * g, sigma, lo, hi, sc.count, sc.box[0]);
	const double dth = enskog_column_com(tm + tse, sc.mass * g, sigma, lo, hi, sc.count, sc.box[0]) - theory;
	const double tol = 4.0 * sqrt(hse * hse + dth * dth) + 0.005 * (theory - lo);
	ok(fabs(hm - theory) < tol && ed_min_gap(ed) > -1e-9,
	   "dense column: centre-of-mass height %.4g +- %.2g at T = %.4g +- %.2g, Enskog-Henderson %.4g (ideal gas %.4g), "
	   "tolerance %.2g", hm, hse, tm, tse, theory, lo + tm / (sc.mass * g), tol);
	ed_destroy(ed);
	free(placed);
}

/* Elastic disks between two thermal walls at T_w = 2 (one fully, one half
 * accommodating), starting at T = 1: the gas relaxes to T_w, the
 * canonical equilibrium the walls impose (detailed balance). */
static void test_thermal(void)
{
	const char *json = "{\"method\":\"ed\",\"dimensions\":2,\"particles\":{\"count\":400,\"volume_fraction\":0.05,"
	                   "\"initial\":{\"positions\":\"random\",\"temperature\":1}},"
	                   "\"boundaries\":{\"y\":{\"type\":\"walls\",\"lower\":{\"type\":\"thermal\",\"temperature\":2},"
	                   "\"upper\":{\"type\":\"thermal\",\"temperature\":2,\"accommodation\":0.5}}},"
	                   "\"run\":{\"seed\":13,\"until\":{\"time\":1}}}";
	scene_t sc;
	ed_t *ed = make(json, &sc);
	if (!ed) {
		ok(0, "thermal walls: setup");
		return;
	}
	ed_sample_t sm;
	/* blocks much longer than the relaxation time of the temperature
	 * (each particle hits a wall about every 60 time units) */
	enum { K = 40 };
	const double t_eq = 1000.0, tau = 500.0;
	double temp[K];
	ed_advance(ed, t_eq, UINT64_MAX, UINT64_MAX);
	ed_sample(ed, &sm);
	for (int k = 0; k < K; k++) {
		ed_advance(ed, t_eq + (k + 1) * tau, UINT64_MAX, UINT64_MAX);
		ed_sample(ed, &sm);
		temp[k] = 2.0 * sm.ekin_time_integral / (2.0 * sc.count * sm.interval);
	}
	double m, se;
	mean_se(temp, K, &m, &se);
	/* 4 standard errors; the initial T = 1 is 1/2 of the target, so a gas
	 * that did not relax (or relaxed to the mean of T and T_w) fails */
	ok(fabs(m - 2.0) < 4.0 * se && se < 0.02,
	   "thermal walls T_w = 2: gas temperature %.5g +- %.2g (%d blocks of %g), %llu wall hits", m, se, K, tau,
	   (unsigned long long)sm.wall_collisions);
	ed_destroy(ed);
}

/* Thermal walls moving together at u = 0.5 along x (T_w = 1): the gas
 * relaxes to the walls' Maxwellian, drifting with them: mean velocity u,
 * and 2 E_kin / (D N) = T_w + m u^2 / D. */
static void test_thermal_moving(void)
{
	const char *json = "{\"method\":\"ed\",\"dimensions\":2,\"particles\":{\"count\":400,\"volume_fraction\":0.05,"
	                   "\"initial\":{\"positions\":\"random\",\"temperature\":1}},"
	                   "\"boundaries\":{\"y\":{\"type\":\"walls\",\"lower\":{\"type\":\"thermal\",\"temperature\":1,"
	                   "\"velocity\":[0.5,0]},\"upper\":{\"type\":\"thermal\",\"temperature\":1,\"velocity\":[0.5,0]}}},"
	                   "\"run\":{\"seed\":20,\"until\":{\"time\":1}}}";
	scene_t sc;
	ed_t *ed = make(json, &sc);
	if (!ed) {
		ok(0, "moving thermal walls: setup");
		return;
	}
	enum { K = 30 };
	const double t_eq = 1000.0, tau = 300.0;
	double ux[K], temp[K];
	ed_sample_t sm;
	ed_advance(ed, t_eq, UINT64_MAX, UINT64_MAX);
	ed_sample(ed, &sm);
	for (int k = 0; k < K; k++) {
		ed_advance(ed, t_eq + (k + 1) * tau, UINT64_MAX, UINT64_MAX);
		ed_sample(ed, &sm);
		ux[k] = sm.momentum[0] / (sc.mass * sc.count);   /* momentum is conserved between wall hits: a snapshot */
		temp[k] = 2.0 * sm.ekin_time_integral / (2.0 * sc.count * sm.interval);
	}
	double mu, seu, mt, set;
	mean_se(ux, K, &mu, &seu);
	mean_se(temp, K, &mt, &set);
	const double t_theory = 1.0 + sc.mass * 0.25 / 2.0;
	ok(fabs(mu - 0.5) < 4.0 * seu && fabs(mt - t_theory) < 4.0 * set,
	   "thermal walls moving at 0.5: gas drifts at %.4f +- %.2g, 2E/(DN) = %.4f +- %.2g (theory T_w + m u^2/D = %.4f)",
	   mu, seu, mt, set, t_theory);
	ed_destroy(ed);
}

/* Elastic disks under gravity on a floor vibrating as A sin(2 pi f t)
 * (and a lid vibrating too): no particle is ever beyond a wall, no pair
 * overlaps, and the walls inject energy. */
static void test_vibrating(void)
{
	const char *json = "{\"method\":\"ed\",\"dimensions\":2,\"particles\":{\"count\":100,\"box\":[20,60],"
	                   "\"initial\":{\"positions\":\"random\",\"temperature\":0.1}},"
	                   "\"boundaries\":{\"y\":{\"type\":\"walls\","
	                   "\"lower\":{\"type\":\"vibrating\",\"amplitude\":0.5,\"frequency\":0.5},"
	                   "\"upper\":{\"type\":\"vibrating\",\"amplitude\":0.2,\"frequency\":0.37,\"phase\":1}}},"
	                   "\"gravity\":[0,-1],\"run\":{\"seed\":14,\"until\":{\"time\":1}}}";
	scene_t sc;
	ed_t *ed = make(json, &sc);
	if (!ed) {
		ok(0, "vibrating walls: setup");
		ok(0, "vibrating walls: energy");
		return;
	}
	double *pos = malloc(sizeof(double) * 2 * sc.count);
	ed_sample_t sm;
	ed_sample(ed, &sm);
	const double e0 = sm.kinetic_energy + sm.potential_energy;
	double worst = INFINITY, gap = INFINITY;
	const double w = 2.0 * M_PI * 0.5, w2 = 2.0 * M_PI * 0.37;
	for (int k = 1; k <= 4000; k++) {
		double t = 0.1237 * k;
		ed_advance(ed, t, UINT64_MAX, UINT64_MAX);
		ed_state(ed, pos, NULL);
		double lo = 0.5 * sin(w * t), hi = sc.box[1] - 0.2 * sin(1.0 + w2 * t);
		for (uint64_t i = 0; i < sc.count; i++) {
			double y = pos[2 * i + 1];
			double g = fmin(y - sc.radius - lo, hi - sc.radius - y);
			if (g < worst)
				worst = g;
		}
		double mg = ed_min_gap(ed);
		if (mg < gap)
			gap = mg;
	}
	ed_sample(ed, &sm);
	const double e1 = sm.kinetic_energy + sm.potential_energy;
	ok(worst > -1e-9 && gap > -1e-9,
	   "vibrating walls: in 4000 samples no particle beyond a wall (smallest wall gap %.3g) or overlapping (%.3g); "
	   "%llu wall hits", worst, gap, (unsigned long long)sm.wall_collisions);
	/* the energy of elastic particles can only grow by the walls' work */
	ok(e1 > 3.0 * e0, "vibrating walls: energy injected, E(0) = %.4g -> E(495) = %.4g", e0, e1);
	free(pos);
	ed_destroy(ed);
}

/* Stochastic (Fermi-Ulam) heating: elastic disks hitting a wall that
 * vibrates with velocity u = A w cos(phase), at phases uniform in time (the
 * flight between hits, ~20, is long against the period 1). A hit at normal
 * speed |v| > |u| gives dE = 2 m (u^2 - u v); weighted by the hit rate
 * (u - v) and averaged over the phase, <dE> = 4 m <u^2> = 2 m (A w)^2 per
 * hit (|v| > A w for all but ~0.2% of the hits here). */
static void test_fermi_heating(void)
{
	const char *json = "{\"method\":\"ed\",\"dimensions\":2,\"particles\":{\"count\":200,\"box\":[200,10],"
	                   "\"initial\":{\"positions\":\"random\",\"temperature\":1}},"
	                   "\"boundaries\":{\"y\":{\"type\":\"walls\","
	                   "\"lower\":{\"type\":\"vibrating\",\"amplitude\":0.01,\"frequency\":1},"
	                   "\"upper\":{\"type\":\"specular\"}}},\"run\":{\"seed\":19,\"until\":{\"time\":1}}}";
	scene_t sc;
	ed_t *ed = make(json, &sc);
	if (!ed) {
		ok(0, "fermi heating: setup");
		return;
	}
	enum { K = 40 };
	const double tau = 500.0;
	double gain[K];
	ed_sample_t sm;
	ed_sample(ed, &sm);
	double e = sm.kinetic_energy;
	uint64_t hits = sm.wall_hits[2];
	for (int k = 0; k < K; k++) {
		ed_advance(ed, (k + 1) * tau, UINT64_MAX, UINT64_MAX);
		ed_sample(ed, &sm);
		gain[k] = (sm.kinetic_energy - e) / (double)(sm.wall_hits[2] - hits);
		e = sm.kinetic_energy;
		hits = sm.wall_hits[2];
	}
	double m, se;
	mean_se(gain, K, &m, &se);
	const double aw = 0.01 * 2.0 * M_PI, theory = 2.0 * sc.mass * aw * aw;
	/* 4 standard errors of the block means (blocks of ~4000 hits) */
	ok(fabs(m - theory) < 4.0 * se && se < 0.1 * theory,
	   "vibrating wall: energy gain per hit %.5g +- %.2g over %llu hits, theory 2 m (A w)^2 = %.5g", m, se,
	   (unsigned long long)hits, theory);
	ed_destroy(ed);
}

/* A bed of inelastic disks (r = 0.5, walls too) dropped on a floor under
 * gravity with the TC model: it settles without a Zeno stall (the run
 * reaches its end with a bounded number of events), nothing falls through
 * the floor or overlaps, and the kinetic energy dies away. */
static void test_settling(void)
{
	const char *json = "{\"method\":\"ed\",\"dimensions\":2,\"particles\":{\"count\":100,\"box\":[20,40],"
	                   "\"initial\":{\"positions\":\"random\",\"temperature\":1}},"
	                   "\"collisions\":{\"restitution\":0.5,\"tc\":1e-2},"
	                   "\"boundaries\":{\"y\":{\"type\":\"walls\",\"lower\":{\"type\":\"specular\",\"restitution\":0.5},"
	                   "\"upper\":{\"type\":\"specular\",\"restitution\":0.5}},"
	                   "\"x\":{\"type\":\"walls\",\"lower\":{\"type\":\"specular\"},\"upper\":{\"type\":\"specular\"}}},"
	                   "\"gravity\":[0,-1],\"run\":{\"seed\":15,\"until\":{\"time\":1}}}";
	scene_t sc;
	ed_t *ed = make(json, &sc);
	if (!ed) {
		ok(0, "settling bed: setup");
		ok(0, "settling bed: at rest");
		return;
	}
	double *pos = malloc(sizeof(double) * 2 * sc.count);
	ed_sample_t sm;
	ed_sample(ed, &sm);
	const double k0 = sm.kinetic_energy;
	double worst = INFINITY;
	int stalled = 0;
	for (int k = 1; k <= 30; k++) {
		/* at most 3e6 events per unit time: a collapsing bed would need
		 * infinitely many. (With TC the rate stays finite but grows as the
		 * bed cools towards the TC floor: about 3e5 per unit time at t = 30
		 * here, 1e6 at t = 40; docs/engine.md, "Walls and gravity".) */
		ed_advance(ed, k, UINT64_MAX, 3000000);
		if (ed_time(ed) < k) {
			stalled = 1;
			break;
		}
		ed_state(ed, pos, NULL);
		for (uint64_t i = 0; i < sc.count; i++)
			if (pos[2 * i + 1] - sc.radius < worst)
				worst = pos[2 * i + 1] - sc.radius;
	}
	ed_sample(ed, &sm);
	ok(!stalled && worst > -1e-9 && ed_min_gap(ed) > -1e-9,
	   "settling bed, r = 0.5, TC: reached t = %g in %llu events (no stall), lowest gap to the floor %.3g, no overlap",
	   ed_time(ed), (unsigned long long)ed_events(ed), worst);
	/* at rest: the TC model keeps velocities of order g tc in the bed (a
	 * particle is lifted by minimum rebounds g tc / 2 only), so E_kin below
	 * N m (10 g tc)^2 / 2 = 0.5; centre of mass that of a bed of 5 layers
	 * (100 disks, 20 wide: about 2.6) */
	const double g = 1.0, tc = 1e-2;
	ok(sm.kinetic_energy < 0.5 * sc.count * sc.mass * (10 * g * tc) * (10 * g * tc) && sm.com_height < 3.5,
	   "settling bed: E_kin %.3g of its initial %.3g, centre of mass at height %.4g (5 layers: about 2.6)",
	   sm.kinetic_energy, k0, sm.com_height);
	free(pos);
	ed_destroy(ed);
}

/* Inelastic disks (r = 0.9) sheared between walls moving at -+0.5 along
 * x (Couette, beta = 1): in the steady state the gas's x momentum is
 * stationary, so the mean x forces on the two walls cancel, and the shear
 * stress they carry is clearly non-zero. Rough walls (elastic) reverse
 * tangential velocities only: energy is conserved. */
static void test_couette_rough(void)
{
	const char *json = "{\"method\":\"ed\",\"dimensions\":2,\"particles\":{\"count\":400,\"volume_fraction\":0.05,"
	                   "\"initial\":{\"positions\":\"random\",\"temperature\":1}},"
	                   "\"collisions\":{\"restitution\":0.9,\"tc\":1e-4},"
	                   "\"boundaries\":{\"y\":{\"type\":\"walls\",\"lower\":{\"type\":\"moving\",\"velocity\":[-0.5,0]},"
	                   "\"upper\":{\"type\":\"moving\",\"velocity\":[0.5,0]}}},\"run\":{\"seed\":17,\"until\":{\"time\":1}}}";
	scene_t sc;
	ed_t *ed = make(json, &sc);
	if (!ed) {
		ok(0, "couette: setup");
	} else {
		enum { K = 40 };
		const double t_eq = 500.0, tau = 100.0;
		double sum[K], lo[K];
		ed_sample_t sm;
		ed_advance(ed, t_eq, UINT64_MAX, UINT64_MAX);
		ed_sample(ed, &sm);
		for (int k = 0; k < K; k++) {
			ed_advance(ed, t_eq + (k + 1) * tau, UINT64_MAX, UINT64_MAX);
			ed_sample(ed, &sm);
			sum[k] = (sm.wall_impulse[2][0] + sm.wall_impulse[3][0]) / sm.interval;
			lo[k] = sm.wall_impulse[2][0] / sm.interval;
		}
		double ms, ses, ml, sel;
		mean_se(sum, K, &ms, &ses);
		mean_se(lo, K, &ml, &sel);
		/* the sum within 4 standard errors of 0; the lower wall, dragged
		 * forward (+x) by the gas moving faster than it, at > 10 SE */
		ok(fabs(ms) < 4.0 * ses && ml > 10.0 * sel,
		   "couette walls -+0.5: x forces on the walls cancel (sum %.3g +- %.2g), shear force on the lower wall %.4g +- %.2g",
		   ms, ses, ml, sel);
		ed_destroy(ed);
	}
	json = "{\"method\":\"ed\",\"dimensions\":3,\"particles\":{\"count\":500,\"volume_fraction\":0.1,"
	       "\"initial\":{\"positions\":\"random\",\"temperature\":1}},"
	       "\"boundaries\":{\"x\":{\"type\":\"walls\",\"lower\":{\"type\":\"rough\",\"probability\":0.5},"
	       "\"upper\":{\"type\":\"rough\",\"probability\":1}},\"z\":{\"type\":\"walls\","
	       "\"lower\":{\"type\":\"specular\"},\"upper\":{\"type\":\"rough\",\"probability\":0.2}}},"
	       "\"run\":{\"seed\":18,\"until\":{\"time\":1}}}";
	ed = make(json, &sc);
	if (!ed) {
		ok(0, "rough walls: setup");
		return;
	}
	ed_sample_t s0, s1;
	ed_sample(ed, &s0);
	ed_advance(ed, 300.0, UINT64_MAX, UINT64_MAX);
	ed_sample(ed, &s1);
	double drift = fabs(s1.kinetic_energy - s0.kinetic_energy) / s0.kinetic_energy;
	ok(drift < 1e-12 && s1.wall_collisions > 10000 && ed_min_gap(ed) > -1e-9,
	   "rough walls (3D, p = 0.5, 1, 0.2), elastic: energy conserved to %.2g over %llu wall hits, no overlap", drift,
	   (unsigned long long)s1.wall_collisions);
	ed_destroy(ed);
}

/* Bagnold scaling (seed 000, A7; the preset bagnold-shear-2d): hard particles have no time scale of
 * their own, so a Couette flow driven by walls at -+v/2 (restitution 0.9,
 * no TC) has a steady state that is the v = 1 one run v times faster: the
 * shear force F is proportional to v^2. Measured at v = 0.2, 2 and 20 (two
 * decades), each for the same number of wall-speed time units. */
static void test_bagnold(void)
{
	const double v[3] = {0.2, 2.0, 20.0};
	double lf[3], sl[3];
	/* the preset presets/bagnold-shear-2d.json at three wall speeds */
	char path[4096];
	preset_path("bagnold-shear-2d.json", path, sizeof path);
	json_error_t jerr;
	json_t *preset = json_load_file(path, 0, &jerr);
	json_t *y = json_object_get(json_object_get(preset, "boundaries"), "y");
	json_t *vl = json_object_get(json_object_get(y, "lower"), "velocity");
	json_t *vu = json_object_get(json_object_get(y, "upper"), "velocity");
	if (!vl || !vu) {
		ok(0, "bagnold: preset %s with moving walls (%s)", path, jerr.text);
		json_decref(preset);
		return;
	}
	for (int k = 0; k < 3; k++) {
		json_array_set_new(vl, 0, json_real(-v[k] / 2));
		json_array_set_new(vu, 0, json_real(v[k] / 2));
		char *json = json_dumps(preset, JSON_REAL_PRECISION(17));
		scene_t sc;
		ed_t *ed = json ? make(json, &sc) : NULL;
		free(json);
		if (!ed) {
			json_decref(preset);
			ok(0, "bagnold: setup v = %g", v[k]);
			return;
		}
		enum { K = 30 };
		const double t_eq = 400.0 / v[k], tau = 100.0 / v[k];
		double f[K];
		ed_sample_t sm;
		ed_advance(ed, t_eq, UINT64_MAX, UINT64_MAX);
		ed_sample(ed, &sm);
		for (int b = 0; b < K; b++) {
			ed_advance(ed, t_eq + (b + 1) * tau, UINT64_MAX, UINT64_MAX);
			ed_sample(ed, &sm);
			/* shear force: mean of the two walls' x forces (opposite signs) */
			f[b] = 0.5 * (sm.wall_impulse[2][0] - sm.wall_impulse[3][0]) / sm.interval;
		}
		double m, se;
		mean_se(f, K, &m, &se);
		lf[k] = log(m);
		sl[k] = se / m;   /* standard error of log F */
		diag("bagnold v = %g: shear force %.6g +- %.2g", v[k], m, se);
		ed_destroy(ed);
	}
	json_decref(preset);
	double slope = (lf[2] - lf[0]) / log(v[2] / v[0]);
	double se = sqrt(sl[2] * sl[2] + sl[0] * sl[0]) / log(v[2] / v[0]);
	double mid = (lf[1] - lf[0]) / log(v[1] / v[0]);
	ok(fabs(slope - 2.0) < 4.0 * se && se < 0.025,
	   "bagnold: shear force ~ v^%.4f +- %.2g over v = 0.2 .. 20 (first decade %.4f; theory 2)", slope, se, mid);
}

/* Checkpoint with thermal and vibrating walls and gravity: every field out,
 * into a blank engine, and both continue bit for bit. */
static void test_checkpoint(void)
{
	const char *json = "{\"method\":\"ed\",\"dimensions\":3,\"particles\":{\"count\":300,\"volume_fraction\":0.1,"
	                   "\"initial\":{\"positions\":\"random\",\"temperature\":1}},"
	                   "\"collisions\":{\"restitution\":0.9,\"tc\":1e-4},"
	                   "\"boundaries\":{\"z\":{\"type\":\"walls\",\"lower\":{\"type\":\"vibrating\",\"amplitude\":0.3,"
	                   "\"frequency\":2},\"upper\":{\"type\":\"thermal\",\"temperature\":1}},"
	                   "\"x\":{\"type\":\"walls\",\"lower\":{\"type\":\"rough\",\"probability\":0.3},"
	                   "\"upper\":{\"type\":\"moving\",\"velocity\":[0,0.5,0]}}},"
	                   "\"gravity\":[0,0,-0.3],\"run\":{\"seed\":16,\"until\":{\"time\":1}}}";
	scene_t sc;
	ed_t *a, *b;
	if (!checkpoint_pair(json, &sc, 7.5, 10.0, &a, &b)) {
		ok(0, "checkpoint with walls and gravity: restore");
		return;
	}
	ed_advance(a, 40.0, UINT64_MAX, UINT64_MAX);
	ed_advance(b, 40.0, UINT64_MAX, UINT64_MAX);
	ed_sample_t sa, sb;
	ed_sample(a, &sa);
	ed_sample(b, &sb);
	size_t m = sc.count * 3;
	double *p = malloc(sizeof(double) * m * 4);
	ed_state(a, p, p + m);
	ed_state(b, p + 2 * m, p + 3 * m);
	ok(sa.events == sb.events && sa.wall_collisions == sb.wall_collisions && sa.wall_collisions > 0 &&
	   !memcmp(p, p + 2 * m, 2 * m * sizeof(double)) &&
	   !memcmp(sa.wall_impulse, sb.wall_impulse, sizeof sa.wall_impulse) &&
	   sa.ekin_time_integral == sb.ekin_time_integral,
	   "checkpoint (rough, moving, thermal, vibrating walls, gravity, TC): restored run identical bit for bit "
	   "after %llu more events (%llu wall hits)", (unsigned long long)sa.events, (unsigned long long)sa.wall_collisions);
	free(p);
	ed_destroy(a);
	ed_destroy(b);
}

/* FNV-1a over bytes: a bit-exact fingerprint of a state. */
static uint64_t fnv(const void *p, size_t n, uint64_t h)
{
	const unsigned char *c = p;
	for (size_t i = 0; i < n; i++) {
		h ^= c[i];
		h *= 1099511628211ull;
	}
	return h;
}

/* Periodic scenes run the engine as it was before walls and gravity
 * existed: the fingerprints of positions and velocities after 5 time units
 * are those of main just before walls were merged (the lattice start of
 * issue 19.9 included; computed with its libgranular.a by the same code). Cell mode with TC in 2D and
 * neighbour lists with an elastic pre-run in 3D. (Depends on libm's log
 * and sqrt in the Maxwellian start: glibc on x86-64, as CI.) */
static void test_periodic_unchanged(void)
{
	static const struct {
		const char *json;
		uint64_t fp, coll;
	} c[2] = {
		{ "{\"method\":\"ed\",\"dimensions\":2,\"particles\":{\"count\":2000,\"volume_fraction\":0.3,"
		  "\"initial\":{\"positions\":\"random\"}},\"collisions\":{\"restitution\":0.8,\"tc\":0.001},"
		  "\"run\":{\"seed\":21,\"until\":{\"time\":1}}}", 0xbf4f411eb6587067ull, 7985 },
		{ "{\"method\":\"ed\",\"dimensions\":3,\"particles\":{\"count\":2000,\"volume_fraction\":0.45,"
		  "\"initial\":{\"relax\":{\"collisions_per_particle\":5}}},\"collisions\":{\"restitution\":0.9,\"tc\":0.0001},"
		  "\"run\":{\"seed\":22,\"until\":{\"time\":1}}}", 0x8861fde651e50654ull, 54561 },
	};
	for (int k = 0; k < 2; k++) {
		scene_t sc;
		ed_t *ed = make(c[k].json, &sc);
		if (!ed) {
			ok(0, "periodic scene %d: setup", k);
			continue;
		}
		ed_advance(ed, 5.0, UINT64_MAX, UINT64_MAX);
		size_t m = sc.count * sc.dim;
		double *p = malloc(2 * m * sizeof(double));
		ed_state(ed, p, p + m);
		uint64_t fp = fnv(p, 2 * m * sizeof(double), 14695981039346656037ull);
		ok(fp == c[k].fp && ed_collisions(ed) == c[k].coll,
		   "periodic %dD scene: state fingerprint %016llx after %llu collisions, as before walls existed (%016llx, %llu)",
		   sc.dim, (unsigned long long)fp, (unsigned long long)ed_collisions(ed), (unsigned long long)c[k].fp,
		   (unsigned long long)c[k].coll);
		free(p);
		ed_destroy(ed);
	}
}

/*
 * Periodic images (scene_msd_images(): mean_square_displacement with an energy feed): ed_unwrapped() against
 * positions unwrapped by hand from samples taken so often that no particle can move half an edge between
 * two (a step of `step` time units: the fastest particle seen stays far below half an edge per step, checked);
 * the two must agree to rounding after many box crossings. Then a checkpoint copy (the "images" field) gives
 * the same unwrapped positions bit for bit after more events. A scene without the feed has no images.
 */
static void images_case(const char *what, const char *json, double step, double t_end)
{
	scene_t sc;
	ed_t *ed = make(json, &sc);
	if (!ed) {
		ok(0, "%s: setup", what);
		ok(0, "%s: checkpoint", what);
		return;
	}
	const int D = sc.dim;
	const size_t m = sc.count * (size_t)D;
	double *u = malloc(m * sizeof(double)), *f = malloc(m * sizeof(double)), *v = malloc(m * sizeof(double)),
	       *e = malloc(m * sizeof(double));
	double half = INFINITY, vmax = 0.0, far = 0.0, worst = 0.0;
	int walled[3] = {0, 0, 0};
	for (int a = 0; a < D; a++) {
		walled[a] = sc.boundary[a].walled;
		if (!walled[a])
			half = fmin(half, 0.5 * sc.box[a]);
	}
	ed_state(ed, f, NULL);
	int good = u && f && v && e && ed_unwrapped(ed, u) == ED_OK;
	for (double t = step; good && t <= t_end + 1e-9; t += step) {
		ed_advance(ed, t, UINT64_MAX, UINT64_MAX);
		ed_state(ed, e, v);
		for (size_t k = 0; k < m; k++) {
			vmax = fmax(vmax, fabs(v[k]));
			double d = e[k] - f[k];
			if (!walled[k % D])
				d -= sc.box[k % D] * nearbyint(d / sc.box[k % D]);
			u[k] += d;   /* u: the hand-unwrapped positions (starting from the engine's at t = 0) */
			f[k] = e[k];
		}
	}
	if (good && ed_unwrapped(ed, e) == ED_OK) {
		for (size_t k = 0; k < m; k++) {
			worst = fmax(worst, fabs(e[k] - u[k]));
			if (!walled[k % D])
				far = fmax(far, fabs(e[k] - f[k]));   /* how far from its folded position: edges crossed */
		}
	} else {
		good = 0;
	}
	ok(good && worst < 1e-9 * t_end && vmax * step < 0.5 * half && far > 2 * half,
	   "%s: ed_unwrapped() equals positions unwrapped by hand (largest difference %.2g; up to %.1f edges "
	   "crossed; fastest %.3g x step %.3g < half an edge %.3g)", what, worst, far / (2 * half), vmax, step, half);
	/* checkpoint copy: the images travel with the state */
	char msg[256] = "";
	ed_t *b = good ? clone_fields(ed, &sc, NULL, 0, NULL, msg, sizeof msg) : NULL;
	int same = 0;
	if (b) {
		ed_advance(ed, 2 * t_end, UINT64_MAX, UINT64_MAX);
		ed_advance(b, 2 * t_end, UINT64_MAX, UINT64_MAX);
		same = ed_unwrapped(ed, e) == ED_OK && ed_unwrapped(b, u) == ED_OK && !memcmp(e, u, m * sizeof(double));
	} else {
		diag("restore: %s", msg);
	}
	ok(same, "%s: a checkpoint copy gives the same unwrapped positions bit for bit later on", what);
	ed_destroy(b);
	ed_destroy(ed);
	free(u);
	free(f);
	free(v);
	free(e);
}

static void test_images(void)
{
	/* thermal walls along y at T_w = 2, periodic x: particles drift along x through many images */
	images_case("thermal walls, periodic x",
	            "{\"method\":\"ed\",\"dimensions\":2,\"particles\":{\"count\":200,\"box\":[20,40],"
	            "\"initial\":{\"positions\":\"random\",\"temperature\":1}},"
	            "\"boundaries\":{\"y\":{\"type\":\"walls\",\"lower\":{\"type\":\"thermal\",\"temperature\":2},"
	            "\"upper\":{\"type\":\"thermal\",\"temperature\":2}}},"
	            "\"run\":{\"seed\":21,\"until\":{\"time\":1}},"
	            "\"output\":{\"observables\":[\"mean_square_displacement\"]}}", 0.25, 150.0);
	/* white-noise driving in a periodic 3D box (the periodic variant, neighbour lists at this density) */
	images_case("driven periodic 3D box",
	            "{\"method\":\"ed\",\"dimensions\":3,\"particles\":{\"count\":400,\"volume_fraction\":0.3,"
	            "\"initial\":{\"positions\":\"random\",\"temperature\":1}},\"collisions\":{\"restitution\":0.8},"
	            "\"driving\":{\"type\":\"white_noise\",\"strength\":1,\"interval\":0.2},"
	            "\"run\":{\"seed\":22,\"until\":{\"time\":1}},"
	            "\"output\":{\"observables\":[\"mean_square_displacement\"]}}", 0.05, 60.0);
	/* gravity along the periodic axis between rough walls (seed 000's pipe): particles fall through images */
	images_case("gravity along a periodic axis (pipe)",
	            "{\"method\":\"ed\",\"dimensions\":2,\"particles\":{\"count\":150,\"box\":[12,30],"
	            "\"initial\":{\"positions\":\"random\",\"temperature\":1}},\"collisions\":{\"restitution\":0.9,\"tc\":1e-4},"
	            "\"boundaries\":{\"x\":{\"type\":\"walls\",\"lower\":{\"type\":\"rough\",\"probability\":0.5},"
	            "\"upper\":{\"type\":\"rough\",\"probability\":0.5}}},\"gravity\":[0,-0.05],"
	            "\"run\":{\"seed\":23,\"until\":{\"time\":1}},"
	            "\"output\":{\"observables\":[\"mean_square_displacement\"]}}", 0.1, 120.0);
	scene_t sc;
	ed_t *ed = make("{\"method\":\"ed\",\"dimensions\":2,\"particles\":{\"count\":100,\"volume_fraction\":0.1},"
	                "\"run\":{\"until\":{\"time\":1}},\"output\":{\"observables\":[\"mean_square_displacement\"]}}", &sc);
	double x[200];
	ok(ed && ed_unwrapped(ed, x) == ED_EINVAL, "a scene the speed bound covers (periodic, elastic) keeps no images");
	ed_destroy(ed);
}

int main(void)
{
	plan(25);
	test_images();
	test_periodic_unchanged();
	test_specular_pressure();
	test_couette_rough();
	test_bagnold();
	test_barometric();
	test_dense_column();
	test_thermal();
	test_thermal_moving();
	test_vibrating();
	test_fermi_heating();
	test_settling();
	test_checkpoint();
	return done_testing();
}
