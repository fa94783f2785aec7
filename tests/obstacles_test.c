/* Tests of fixed obstacles in the event-driven engine: exact contact times, energy conservation, drag against kinetic theory, thermal obstacles, checkpoints, scene errors. */
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "ed/ed.h"
#include "ed/obstacle.h"
#include "rng.h"
#include "scene.h"
#include "tap.h"
#include "stats.h"
#include "ed_util.h"

#ifndef M_PI
#define M_PI 3.14159265358979323846
#endif

/* ---- contact times (obstacle.h) ---------------------------------------- */

static double f_at(const double *x, const double *v, const double *g, int dim, double S, double t)
{
	double s = 0.0;
	for (int a = 0; a < dim; a++) {
		double d = x[a] + v[a] * t + 0.5 * g[a] * t * t;
		s += d * d;
	}
	return s - S * S;
}

static void test_times_analytic(void)
{
	/* free flight: impact parameter b, speed u, from distance 10 */
	const double S = 1.5, b = 0.7, u = 1.3;
	double x[3] = {-10.0, b, 0.0}, v[3] = {u, 0.0, 0.0};
	double t = obstacle_time_free(x, v, 2, S), want = (10.0 - sqrt(S * S - b * b)) / u;
	double t3 = obstacle_time_free(x, v, 3, S);
	double away = obstacle_time_free((double[]){-10.0, b, 0.0}, (double[]){-u, 0.0, 0.0}, 2, S);
	double miss = obstacle_time_free((double[]){-10.0, 1.6, 0.0}, v, 2, S);
	ok(fabs(t - want) < 1e-14 * want && fabs(t3 - want) < 1e-14 * want && away == INFINITY && miss == INFINITY,
	   "free flight: contact at %.17g, analytic %.17g (2D and 3D); moving away and missing: none", t, want);

	/* gravity: dropped from rest at height h above the contact point, off
	 * centre by c: contact when the centre is sqrt(S^2 - c^2) above */
	const double G = 0.8, c = 0.9, h = 2.0;
	const double y0 = sqrt(S * S - c * c) + h;
	double xg[3] = {c, y0, 0.0}, v0[3] = {0.0, 0.0, 0.0}, gg[3] = {0.0, -G, 0.0};
	t = obstacle_time_grav(xg, v0, gg, 2, S, 100.0);
	want = sqrt(2.0 * h / G);
	/* just reflected upwards at the top (rounding puts it a hair inside):
	 * the next contact is the return, 2 u / g later, not now */
	double xr[3] = {0.0, S * (1.0 - 1e-16), 0.0}, vr[3] = {0.0, 0.5, 0.0};
	double tr = obstacle_time_grav(xr, vr, gg, 2, S, 100.0), wr = 2.0 * 0.5 / G;
	/* inside by rounding and approaching: now */
	double xi[3] = {0.0, S * (1.0 - 1e-15), 0.0}, vi[3] = {0.0, -0.5, 0.0};
	double ti = obstacle_time_grav(xi, vi, gg, 2, S, 100.0);
	ok(fabs(t - want) < 1e-12 * want && fabs(tr - wr) < 1e-9 * wr && ti == 0.0,
	   "gravity: drop lands at %.15g (analytic %.15g); rebound returns at %.12g (analytic %.12g); inside and approaching: %g",
	   t, want, tr, wr, ti);
}

/* Random parabolas against a brute-force scan of f = |d|^2 - S^2 on a fine
 * grid (a sign change found there is refined by bisection): the engine's
 * time is never later than a contact the scan sees (no missed contact),
 * lies on the contact sphere while approaching, and no grid point before it
 * is inside (no early or phantom contact). Many are grazing by design. */
static void test_times_random(void)
{
	rng_t rng;
	rng_init(&rng, 7, 0);
	int bad = 0, hits = 0, grazing = 0;
	const int M = 20000;
	for (int k = 0; k < M && bad < 5; k++) {
		const int dim = 2 + (k & 1);
		const double S = 0.5 + rng_uniform(&rng) * 2.0, H = 5.0;
		double x[3] = {0, 0, 0}, v[3] = {0, 0, 0}, g[3] = {0, 0, 0};
		for (int a = 0; a < dim; a++) {
			x[a] = (rng_uniform(&rng) - 0.5) * 8.0;
			v[a] = rng_gauss(&rng);
			g[a] = rng_gauss(&rng) * 0.5;
		}
		if (k & 2) {
			/* grazing by construction: at time tau the particle passes a
			 * point P = S nrm of the sphere with velocity w, tangent but
			 * for a normal part -eps (eps from 1e-8 to 1e-2): x and v now
			 * follow by running the parabola back */
			double nrm[3] = {0, 0, 0}, w[3] = {0, 0, 0}, nn = 0.0, wn = 0.0;
			for (int a = 0; a < dim; a++) {
				nrm[a] = rng_gauss(&rng);
				nn += nrm[a] * nrm[a];
				w[a] = rng_gauss(&rng);
			}
			for (int a = 0; a < dim; a++) {
				nrm[a] /= sqrt(nn);
				wn += w[a] * nrm[a];
			}
			const double eps = pow(10.0, -8.0 + 6.0 * rng_uniform(&rng)), tau = 0.5 + 3.0 * rng_uniform(&rng);
			for (int a = 0; a < dim; a++) {
				w[a] -= (wn + eps) * nrm[a];
				x[a] = S * nrm[a] - w[a] * tau + 0.5 * g[a] * tau * tau;
				v[a] = w[a] - g[a] * tau;
			}
		}
		if (f_at(x, v, g, dim, S, 0.0) <= 0.0)
			continue;   /* starts inside: not a reachable state */
		double t = obstacle_time_grav(x, v, g, dim, S, H);
		/* brute force */
		const int NG = 20000;
		double tb = INFINITY, fprev = f_at(x, v, g, dim, S, 0.0), fmin = fprev;
		for (int i = 1; i <= NG; i++) {
			double ti = H * i / NG, fi = f_at(x, v, g, dim, S, ti);
			if (fi < fmin)
				fmin = fi;
			if (fi <= 0.0 && fprev > 0.0) {
				double lo = H * (i - 1) / NG, hi = ti;
				for (int it = 0; it < 100; it++) {
					double mid = 0.5 * (lo + hi);
					if (f_at(x, v, g, dim, S, mid) <= 0.0) hi = mid; else lo = mid;
				}
				tb = hi;
				break;
			}
			fprev = fi;
		}
		if (t < INFINITY) {
			hits++;
			double ft = f_at(x, v, g, dim, S, t), dft = 0.0;
			for (int a = 0; a < dim; a++)
				dft += (x[a] + v[a] * t + 0.5 * g[a] * t * t) * (v[a] + g[a] * t);
			int early = 0;
			for (int i = 1; i <= NG && H * i / NG < t * (1 - 1e-9); i++)
				early |= f_at(x, v, g, dim, S, H * i / NG) < -1e-9 * S * S;
			if (fabs(ft) > 1e-9 * S * S || dft > 1e-9 || early || t > tb + 1e-9) {
				diag("case %d: t %.17g brute %.17g f(t) %g f'(t) %g early %d", k, t, tb, ft, dft, early);
				bad++;
			}
			if (tb == INFINITY)
				grazing++;   /* between two grid points: the scan missed it */
		} else if (tb < INFINITY) {
			diag("case %d: missed a contact at %.17g", k, tb);
			bad++;
		}
	}
	ok(bad == 0 && grazing > 100, "gravity, %d random parabolas (half of them grazing, normal speed 1e-8 .. 1e-2): %d "
	   "contacts all exact and first (%d too grazing for a 2.5e-4 grid), none missed", M, hits, grazing);
}

/* ---- the engine -------------------------------------------------------- */

/* Two particles at rest (temperature 0) in a walled box under gravity; an
 * obstacle right below particle 0 (whose lattice place is found first
 * without it): its first hit is at sqrt(2 h / g), and elastic bounces on
 * the top of the obstacle repeat every 2 sqrt(2 h / g) with kinetic plus
 * potential energy conserved. Event by event: the clock at the hit is the
 * event time. */
static void test_drop(void)
{
	const char *base = "{\"method\":\"ed\",\"dimensions\":2,\"particles\":{\"count\":2,\"box\":[20,40],"
	                   "\"initial\":{\"temperature\":0}},\"gravity\":[0,-0.5],"
	                   "\"boundaries\":{\"y\":{\"type\":\"walls\",\"lower\":{\"type\":\"specular\"},"
	                   "\"upper\":{\"type\":\"specular\"}}},%s\"run\":{\"seed\":3,\"until\":{\"time\":1}},"
	                   "\"output\":{\"observables\":[\"potential_energy\"%s]}}";
	char json[1024], obst[256];
	scene_t sc;
	snprintf(json, sizeof json, base, "", "");
	ed_t *ed = make(json, &sc);
	double pos[4];
	if (!ed) {
		ok(0, "drop: setup");
		return;
	}
	ed_state(ed, pos, NULL);
	ed_destroy(ed);
	const double R = 1.0, h = 3.0, G = 0.5, S = R + 0.5;
	const double cy = pos[1] - h - S;
	snprintf(obst, sizeof obst, "\"obstacles\":[{\"type\":\"slip\",\"center\":[%.17g,%.17g],\"radius\":%.17g}],",
	         pos[0], cy, R);
	snprintf(json, sizeof json, base, obst, ",\"obstacle_force\"");
	ed = make(json, &sc);
	if (!ed || cy - R < 0.0) {
		ok(0, "drop: setup with the obstacle (centre %g)", cy);
		ed_destroy(ed);
		return;
	}
	ed_sample_t s0, s1;
	ed_sample(ed, &s0);
	const double e0 = s0.kinetic_energy + s0.potential_energy, t1 = sqrt(2.0 * h / G);
	double worst = 0.0;
	int hits = 0;
	uint64_t prev = 0;
	for (int ev = 0; ev < 100000 && hits < 10; ev++) {
		ed_advance(ed, INFINITY, UINT64_MAX, 1);
		ed_totals(ed, &s1);
		if (s1.obstacle_collisions != prev) {
			prev = s1.obstacle_collisions;
			double want = t1 * (2 * hits + 1);
			worst = fmax(worst, fabs(ed_time(ed) - want) / want);
			hits++;
		}
	}
	ed_sample(ed, &s1);
	const double drift = fabs(s1.kinetic_energy + s1.potential_energy - e0) / fabs(e0);
	ok(hits == 10 && worst < 1e-12 && drift < 1e-12,
	   "drop onto an obstacle: %d hits at (2k+1) sqrt(2h/g) to %.2g relative; kinetic + potential energy conserved to %.2g",
	   hits, worst, drift);
	ed_destroy(ed);
}

/* Elastic particles and elastic obstacles (slip, random_sign: both keep
 * |v|) conserve kinetic energy exactly but for rounding; no particle ever
 * overlaps an obstacle or another particle. 2D periodic, and 3D between
 * walls under gravity (kinetic + potential). */
static void test_energy(void)
{
	const char *j2 = "{\"method\":\"ed\",\"dimensions\":2,\"particles\":{\"count\":1500,\"box\":[80,80],"
	                 "\"initial\":{\"positions\":\"random\",\"temperature\":1,\"velocity\":[0.5,0.2]}},"
	                 "\"obstacles\":[{\"type\":\"slip\",\"center\":[20,20],\"radius\":6},"
	                 "{\"type\":\"random_sign\",\"center\":[60,50],\"radius\":4},"
	                 "{\"type\":\"slip\",\"center\":[79,2],\"radius\":3}],"
	                 "\"run\":{\"seed\":5,\"until\":{\"time\":1}}}";
	const char *j3 = "{\"method\":\"ed\",\"dimensions\":3,\"particles\":{\"count\":800,\"box\":[14,14,20],"
	                 "\"initial\":{\"positions\":\"random\",\"temperature\":1}},\"gravity\":[0,0,-0.3],"
	                 "\"boundaries\":{\"z\":{\"type\":\"walls\",\"lower\":{\"type\":\"specular\"},"
	                 "\"upper\":{\"type\":\"specular\"}}},"
	                 "\"obstacles\":[{\"type\":\"slip\",\"center\":[7,7,5],\"radius\":2.5},"
	                 "{\"type\":\"random_sign\",\"center\":[1,13,12],\"radius\":2}],"
	                 "\"run\":{\"seed\":6,\"until\":{\"time\":1}},"
	                 "\"output\":{\"observables\":[\"potential_energy\",\"obstacle_force\"]}}";
	const char *js[2] = {j2, j3};
	for (int k = 0; k < 2; k++) {
		scene_t sc;
		ed_t *ed = make(js[k], &sc);
		if (!ed) {
			ok(0, "energy %d: setup", k);
			continue;
		}
		ed_sample_t s0, s1;
		ed_sample(ed, &s0);
		const double e0 = s0.kinetic_energy + (k ? s0.potential_energy : 0.0);
		double gap = INFINITY;
		for (int i = 1; i <= 20; i++) {
			ed_advance(ed, 10.0 * i, UINT64_MAX, UINT64_MAX);
			gap = fmin(gap, ed_min_gap(ed));
		}
		ed_sample(ed, &s1);
		const double e1 = s1.kinetic_energy + (k ? s1.potential_energy : 0.0), drift = fabs(e1 - e0) / e0;
		ok(drift < 1e-12 && gap > -1e-9 && s1.obstacle_collisions > 1000,
		   "%dD elastic obstacles%s: energy conserved to %.2g over %llu collisions and %llu obstacle hits; "
		   "smallest gap %.3g", sc.dim, k ? ", walls and gravity" : "", drift, (unsigned long long)s1.collisions,
		   (unsigned long long)s1.obstacle_collisions, gap);
		ed_destroy(ed);
	}
}

/* Free-molecular drag on a specular (elastic slip) disk of contact radius
 * S in a Maxwellian stream (density n, velocity U along x, temperature T):
 * every element of the contact circle takes the momentum flux
 * p(u_n) = 2 m n E[c_n^2; c_n < 0] of the particles arriving on it, with
 * c_n ~ N(u_n, T/m) and u_n = U.n, so F_x = -S int p(U cos th) cos th dth
 * (Simpson, 4096 intervals: exact to ~1e-12). */
static double drag_theory_2d(double n, double U, double T, double m, double S)
{
	const double sg = sqrt(T / m);
	const int M = 4096;
	double sum = 0.0;
	for (int i = 0; i <= M; i++) {
		double th = 2.0 * M_PI * i / M, un = U * cos(th), z = un / sg;
		double Phi = 0.5 * erfc(z / sqrt(2.0)), phi = exp(-0.5 * z * z) / sqrt(2.0 * M_PI);
		double p = 2.0 * m * n * ((un * un + sg * sg) * Phi - un * sg * phi);
		double w = (i == 0 || i == M) ? 1.0 : (i & 1) ? 4.0 : 2.0;
		sum += w * p * cos(th);
	}
	return -S * sum * (2.0 * M_PI / M) / 3.0;
}

/* A dilute elastic gas (eta = 0.003, mean free path ~ 90 diameters, 36
 * obstacle contact radii: nearly free-molecular) streams through a
 * periodic box past a slip obstacle; the stream decays by the drag itself
 * (and heats: energy is conserved), so each interval's drag is compared with
 * the theory at that interval's mean velocity U = P / (N m) and temperature
 * T = (2 E / N - m U^2) / D. Tolerance: 4 standard errors of the interval
 * ratios (intervals of ~100 hits, >> the collision time: independent) plus
 * 3% for what the free-molecular theory leaves out (contact density
 * n Z with Z - 1 = 0.6%; collisions within ~S of the obstacle, O(S / lambda)
 * = 3%, partly cancelling; the obstacle's recirculating wake). */
static void test_drag(void)
{
	const char *json = "{\"method\":\"ed\",\"dimensions\":2,\"particles\":{\"count\":3000,\"volume_fraction\":0.003,"
	                   "\"initial\":{\"positions\":\"random\",\"temperature\":1,\"velocity\":[2,0]}},"
	                   "\"obstacles\":[{\"type\":\"slip\",\"center\":[400,400],\"radius\":2}],"
	                   "\"ed\":{\"cell_size\":40},\"run\":{\"seed\":9,\"until\":{\"time\":1}},"
	                   "\"output\":{\"observables\":[\"obstacle_force\"]}}";
	scene_t sc;
	ed_t *ed = make(json, &sc);
	if (!ed) {
		ok(0, "drag: setup");
		return;
	}
	enum { K = 24 };
	const double tau = 1500.0, m = sc.mass, N = (double)sc.count, S = sc.obstacle[0].radius + sc.radius;
	const double area = sc.box[0] * sc.box[1] - M_PI * S * S, n = N / area;
	double ratio[K], ux[K];
	ed_sample_t a, b;
	ed_sample(ed, &a);
	for (int k = 0; k < K; k++) {
		ed_advance(ed, (k + 1) * tau, UINT64_MAX, UINT64_MAX);
		ed_sample(ed, &b);
		/* interval means of U and T from the ends (they drift slowly) */
		double U = 0.5 * (a.momentum[0] + b.momentum[0]) / (N * m), E = 0.5 * (a.kinetic_energy + b.kinetic_energy);
		double Uy = 0.5 * (a.momentum[1] + b.momentum[1]) / (N * m);
		double T = (2.0 * E / N - m * (U * U + Uy * Uy)) / 2.0;
		double eta = n * M_PI * 0.25 * 4.0 * sc.radius * sc.radius;
		double Z = (1.0 + eta * eta / 8.0) / ((1.0 - eta) * (1.0 - eta));
		ratio[k] = b.obstacle_impulse[0][0] / b.interval / (Z * drag_theory_2d(n, U, T, m, S));
		ux[k] = U;
		a = b;
	}
	double mean, se;
	mean_se(ratio, K, &mean, &se);
	const double tol = 4.0 * se + 0.03;
	ok(fabs(mean - 1.0) < tol,
	   "slip obstacle in a dilute stream (U %.3g -> %.3g, %llu hits): drag / kinetic theory = %.4f +- %.4f, tolerance %.3f",
	   ux[0], ux[K - 1], (unsigned long long)b.obstacle_collisions, mean, se, tol);
	ed_destroy(ed);
}

/* A no_slip (thermal) obstacle is the gas's only heat bath: elastic
 * particles started at T = 0.3 relax to the obstacle's temperature 1.5.
 * Block means of T over the second half; tolerance 4 standard errors plus
 * 1% (the finite relaxation left at the start of the averaging, e^-6). */
static void test_thermal(void)
{
	const char *json = "{\"method\":\"ed\",\"dimensions\":2,\"particles\":{\"count\":400,\"box\":[50,50],"
	                   "\"initial\":{\"positions\":\"random\",\"temperature\":0.3}},"
	                   "\"obstacles\":[{\"type\":\"no_slip\",\"center\":[25,25],\"radius\":5,\"temperature\":1.5}],"
	                   "\"run\":{\"seed\":12,\"until\":{\"time\":1}}}";
	scene_t sc;
	ed_t *ed = make(json, &sc);
	if (!ed) {
		ok(0, "thermal obstacle: setup");
		return;
	}
	/* relaxation: each particle meets the obstacle about every
	 * A / (2 S v) ~ 1250 / (11 * 1) ~ 110 time units */
	ed_advance(ed, 4000.0, UINT64_MAX, UINT64_MAX);
	enum { K = 30 };
	double T[K];
	ed_sample_t sm;
	ed_sample(ed, &sm);
	for (int k = 0; k < K; k++) {
		ed_advance(ed, 4000.0 + (k + 1) * 150.0, UINT64_MAX, UINT64_MAX);
		ed_sample(ed, &sm);
		T[k] = sm.ekin_time_integral / sm.interval / sc.count;   /* 2 E / (D N) with D = 2 */
	}
	double mean, se;
	mean_se(T, K, &mean, &se);
	const double tol = 4.0 * se + 0.015;
	ok(fabs(mean - 1.5) < tol, "no_slip obstacle at T = 1.5 thermalises the gas: T = %.4f +- %.4f, tolerance %.3f",
	   mean, se, tol);
	ed_destroy(ed);
}

/* Restored from its fields mid-run, a scene with obstacles of every kind
 * (walls, gravity, TC, the thermal obstacle's random draws) runs on bit for
 * bit as the original. */
static void test_checkpoint(void)
{
	const char *json = "{\"method\":\"ed\",\"dimensions\":2,\"particles\":{\"count\":600,\"box\":[40,60],"
	                   "\"initial\":{\"positions\":\"random\",\"temperature\":1,\"velocity\":[0.3,0]}},"
	                   "\"collisions\":{\"restitution\":0.9,\"tc\":1e-4},\"gravity\":[0,-0.2],"
	                   "\"boundaries\":{\"y\":{\"type\":\"walls\",\"lower\":{\"type\":\"thermal\",\"temperature\":1},"
	                   "\"upper\":{\"type\":\"specular\"}},\"x\":{\"type\":\"walls\",\"lower\":{\"type\":\"specular\"},"
	                   "\"upper\":{\"type\":\"open\"}}},"
	                   "\"obstacles\":[{\"type\":\"slip\",\"center\":[10,20],\"radius\":3,\"restitution\":0.8},"
	                   "{\"type\":\"no_slip\",\"center\":[30,20],\"radius\":3,\"temperature\":1},"
	                   "{\"type\":\"random_sign\",\"center\":[20,40],\"radius\":4,\"restitution\":0.9}],"
	                   "\"run\":{\"seed\":16,\"until\":{\"time\":1}}}";
	scene_t sc;
	ed_t *a, *b;
	if (!checkpoint_pair(json, &sc, 7.5, 10.0, &a, &b)) {
		ok(0, "checkpoint with obstacles: restore");
		return;
	}
	ed_advance(a, 60.0, UINT64_MAX, UINT64_MAX);
	ed_advance(b, 60.0, UINT64_MAX, UINT64_MAX);
	ed_sample_t sa, sb;
	ed_sample(a, &sa);
	ed_sample(b, &sb);
	size_t m = sc.count * 2;
	double *p = malloc(sizeof(double) * m * 4);
	ed_state(a, p, p + m);
	ed_state(b, p + 2 * m, p + 3 * m);
	ok(sa.events == sb.events && sa.obstacle_collisions == sb.obstacle_collisions && sa.obstacle_collisions > 0 &&
	   !memcmp(p, p + 2 * m, 2 * m * sizeof(double)) &&
	   !memcmp(sa.obstacle_impulse, sb.obstacle_impulse, sizeof sa.obstacle_impulse) &&
	   !memcmp(sa.obstacle_hits, sb.obstacle_hits, sizeof sa.obstacle_hits) &&
	   sa.particles == sb.particles && sa.particles < sc.count &&
	   !memcmp(sa.wall_outflow, sb.wall_outflow, sizeof sa.wall_outflow),
	   "checkpoint (slip, no_slip, random_sign obstacles, walls, an open wall, gravity, TC): restored run identical "
	   "bit for bit after %llu events (%llu obstacle hits, %llu particles left)", (unsigned long long)sa.events,
	   (unsigned long long)sa.obstacle_collisions, (unsigned long long)(sc.count - sa.particles));
	free(p);
	ed_destroy(a);
	ed_destroy(b);
}

/* TC at obstacles: inelastic disks (r = 0.5, obstacle r_o = 0.5) rain onto
 * a slip obstacle under gravity and settle on it and on the floor. Without
 * the TC rule at obstacle contacts a disk resting on the obstacle would
 * collide infinitely often in finite time; with it (elastic within tc,
 * minimum rebound tc g / 2) the run reaches its end with no overlap, and
 * the disks have come to rest: E_kin below 2% of the initial kinetic
 * energy (the TC floor keeps velocities of order 10 g tc = 0.1 in the
 * wedges between obstacle, floor and neighbours: measured E_kin 0.13 to 0.6
 * from t = 40 to 200, i.e. below 1% of the initial 60). */
static void test_tc_rest(void)
{
	const char *json = "{\"method\":\"ed\",\"dimensions\":2,\"particles\":{\"count\":60,\"box\":[20,40],"
	                   "\"initial\":{\"positions\":\"random\",\"temperature\":1}},"
	                   "\"collisions\":{\"restitution\":0.5,\"tc\":1e-2},"
	                   "\"boundaries\":{\"y\":{\"type\":\"walls\",\"lower\":{\"type\":\"specular\",\"restitution\":0.5},"
	                   "\"upper\":{\"type\":\"specular\",\"restitution\":0.5}}},"
	                   "\"obstacles\":[{\"type\":\"slip\",\"center\":[10,10],\"radius\":6,\"restitution\":0.5},"
	                   "{\"type\":\"random_sign\",\"center\":[1,4],\"radius\":2,\"restitution\":0.5}],"
	                   "\"gravity\":[0,-1],\"run\":{\"seed\":15,\"until\":{\"time\":1}}}";
	scene_t sc;
	ed_t *ed = make(json, &sc);
	if (!ed) {
		ok(0, "TC at obstacles: setup");
		return;
	}
	int stalled = 0;
	double gap = INFINITY;
	ed_sample_t s0;
	ed_sample(ed, &s0);
	const double e0 = s0.kinetic_energy;
	for (int k = 1; k <= 40 && !stalled; k++) {
		ed_advance(ed, k, UINT64_MAX, 3000000);   /* a collapse would need infinitely many */
		stalled = ed_time(ed) < k;
		gap = fmin(gap, ed_min_gap(ed));
	}
	ed_sample_t sm;
	ed_sample(ed, &sm);
	ok(!stalled && gap > -1e-9 && sm.obstacle_collisions > 0 && sm.kinetic_energy < 0.02 * e0,
	   "TC at obstacles: inelastic disks settle on obstacles and floor, t = %g reached in %llu events (%llu obstacle "
	   "hits), smallest gap %.3g, E_kin %.3g", ed_time(ed), (unsigned long long)sm.events,
	   (unsigned long long)sm.obstacle_collisions, gap, sm.kinetic_energy);
	ed_destroy(ed);
}

/* Open walls: a nearly collisionless gas (eta = 1e-6: mean free path
 * 2.8e5 diameters, box 4e4: one particle in seven collides on its way out,
 * which in equilibrium hardly changes the outflow)
 * between two open walls drains ballistically. Centres start uniform in
 * [a, L - a] (width l) and leave on touching a wall, so a particle with
 * speed |v_x| is still in at time t with probability (1 - |v_x| t / l)+,
 * averaged over the Maxwellian (quadrature). The count present is binomial
 * about N f: tolerance 4 standard deviations; the few collisions change
 * it by far less. Kinetic energy of those present = the running sum. */
static double remain_theory(double t, double l, double T, double m)
{
	const double sg = sqrt(T / m);
	const int M = 20000;
	double sum = 0.0, vmax = 12.0 * sg, dv = vmax / M;
	for (int i = 0; i < M; i++) {
		double v = (i + 0.5) * dv, w = 2.0 * exp(-0.5 * v * v / (sg * sg)) / (sqrt(2.0 * M_PI) * sg);
		sum += w * fmax(0.0, 1.0 - v * t / l) * dv;
	}
	return sum;
}

static void test_open(void)
{
	const char *json = "{\"method\":\"ed\",\"dimensions\":2,\"particles\":{\"count\":2000,\"volume_fraction\":1e-6,"
	                   "\"initial\":{\"positions\":\"random\",\"temperature\":1}},"
	                   "\"boundaries\":{\"x\":{\"type\":\"walls\",\"lower\":{\"type\":\"open\"},"
	                   "\"upper\":{\"type\":\"open\"}}},\"ed\":{\"cell_size\":2000},"
	                   "\"run\":{\"seed\":17,\"until\":{\"time\":1}},\"output\":{\"observables\":[\"outflow\"]}}";
	scene_t sc;
	ed_t *ed = make(json, &sc);
	if (!ed) {
		ok(0, "open walls: setup");
		return;
	}
	const double l = sc.box[0] - 2.0 * sc.radius, N = (double)sc.count;
	double worst = 0.0, ekin_err = 0.0;
	int nan_ok = 1;
	ed_sample_t sm;
	double *v = malloc(sizeof(double) * 2 * sc.count);
	for (int k = 1; k <= 6; k++) {
		const double t = l * 0.25 * k;   /* up to 1.5 l: most have left */
		ed_advance(ed, t, UINT64_MAX, UINT64_MAX);
		ed_sample(ed, &sm);
		double f = remain_theory(t, l, 1.0, sc.mass), sd = sqrt(N * f * (1.0 - f));
		double z = fabs((double)sm.particles - N * f) / fmax(sd, 1.0);
		worst = fmax(worst, z);
		/* kinetic energy from the velocities of those present; NaN for the others */
		ed_state(ed, NULL, v);
		double e = 0.0;
		uint64_t nan = 0;
		for (uint64_t i = 0; i < sc.count; i++) {
			if (isnan(v[2 * i])) {
				nan++;
				continue;
			}
			e += 0.5 * sc.mass * (v[2 * i] * v[2 * i] + v[2 * i + 1] * v[2 * i + 1]);
		}
		nan_ok &= nan == sc.count - sm.particles && nan == sm.wall_outflow[0] + sm.wall_outflow[1];
		ekin_err = fmax(ekin_err, fabs(e - sm.kinetic_energy) / fmax(e, 1e-300));
		if (k == 6)
			diag("t = %.0f: %llu present, theory %.1f +- %.1f; out %llu / %llu", t,
			     (unsigned long long)sm.particles, N * f, sd, (unsigned long long)sm.wall_outflow[0],
			     (unsigned long long)sm.wall_outflow[1]);
	}
	free(v);
	ok(worst < 4.0 && nan_ok && ekin_err < 1e-12,
	   "open walls: ballistic drain follows E[(1 - |v_x| t / l)+] (worst %.2f standard deviations over 6 times); "
	   "particles out = NaN rows = N - present; kinetic energy of those present exact", worst);
	ed_destroy(ed);
}

/* Bad scenes name the key at fault. */
static void test_scene_errors(void)
{
	static const struct {
		const char *obst;   /* the obstacles (and anything else) spliced in */
		const char *key;    /* expected start of the message */
		const char *particles;   /* NULL: 300 in a 40 x 40 box */
	} c[] = {
		{ "\"obstacles\":[{\"type\":\"slip\",\"center\":[10,10],\"radius\":3},"
		  "{\"type\":\"slip\",\"center\":[14,10],\"radius\":2}]", "obstacles[1]: overlaps obstacles[0]", NULL },
		{ "\"obstacles\":[{\"type\":\"slip\",\"center\":[10,41],\"radius\":3}]", "obstacles[0].center[1]:", NULL },
		{ "\"obstacles\":[{\"type\":\"slip\",\"center\":[10,39],\"radius\":3}],"
		  "\"boundaries\":{\"y\":{\"type\":\"walls\",\"lower\":{\"type\":\"specular\"},\"upper\":{\"type\":\"specular\"}}}",
		  "obstacles[0]: overlaps the wall boundaries.y.upper", NULL },
		{ "\"obstacles\":[{\"type\":\"slip\",\"center\":[10,10],\"radius\":20}]", "obstacles[0].radius:", NULL },
		{ "\"obstacles\":[{\"type\":\"no_slip\",\"center\":[10,10],\"radius\":2}]", "obstacles[0].temperature:", NULL },
		{ "\"obstacles\":[{\"type\":\"slip\",\"center\":[10,10],\"radius\":2,\"temperature\":1}]",
		  "obstacles[0].temperature:", NULL },
		{ "\"obstacles\":[{\"type\":\"sticky\",\"center\":[10,10],\"radius\":2}]", "obstacles[0].type:", NULL },
		{ "\"obstacles\":[{\"type\":\"slip\",\"center\":[10],\"radius\":2}]", "obstacles[0].center:", NULL },
		{ "\"obstacles\":[{\"type\":\"slip\",\"center\":[20,20],\"radius\":19.2}]", "particles.initial.positions:",
		  "{\"count\":300,\"box\":[40,40],\"initial\":{\"positions\":\"random\"}}" },
		{ "\"obstacles\":[{\"type\":\"slip\",\"center\":[20,20],\"radius\":10}]", "particles.initial.positions:",
		  "{\"count\":1450,\"box\":[40,40]}" },
		{ "\"output\":{\"observables\":[\"obstacle_force\"]}", "output.observables[0]:", NULL },
	};
	char json[1024], err[512];
	int bad = 0;
	for (size_t k = 0; k < sizeof c / sizeof c[0]; k++) {
		scene_t sc;
		snprintf(json, sizeof json, "{\"method\":\"ed\",\"dimensions\":2,\"particles\":%s,"
		         "%s,\"run\":{\"until\":{\"time\":1}}}",
		         c[k].particles ? c[k].particles : "{\"count\":300,\"box\":[40,40]}", c[k].obst);
		int rc = scene_parse(json, strlen(json), &sc, err, sizeof err);
		if (rc != SCENE_EINVAL || strncmp(err, c[k].key, strlen(c[k].key))) {
			diag("case %zu: rc %d, message \"%s\", expected \"%s...\"", k, rc, err, c[k].key);
			bad++;
		}
	}
	/* the same obstacle is fine for method ed (and dsmc, hsmc: tests/mc_obstacles_test), refused for auto */
	snprintf(json, sizeof json, "{\"method\":\"auto\",\"dimensions\":2,\"particles\":{\"count\":300,\"box\":[40,40]},"
	         "\"accuracy\":{\"temperature\":0.05},\"obstacles\":[{\"type\":\"slip\",\"center\":[10,10],\"radius\":2}],"
	         "\"run\":{\"until\":{\"time\":1}}}");
	scene_t sc;
	int rc = scene_parse(json, strlen(json), &sc, err, sizeof err);
	if (rc != SCENE_EINVAL || strncmp(err, "obstacles:", 10)) {
		diag("auto: rc %d, message \"%s\"", rc, err);
		bad++;
	}
	ok(bad == 0, "bad obstacle scenes: %zu rejected, each naming its key", sizeof c / sizeof c[0] + 1);
}

int main(void)
{
	plan(12);
	test_times_analytic();
	test_times_random();
	test_drop();
	test_energy();
	test_drag();
	test_thermal();
	test_tc_rest();
	test_open();
	test_checkpoint();
	test_scene_errors();
	return done_testing();
}
