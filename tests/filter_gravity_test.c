/* Tests of seed 001's filter outlet under gravity in the event-driven engine (issue 12): frozen particles fly straight at U while the others fall, no contact is missed (no overlap), the running kinetic energy follows the frozen and the falling particles exactly, a stream across the field holds eta, T and U, checkpoints are exact. */
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "ed/ed.h"
#include "scene.h"
#include "tap.h"
#include "stats.h"
#include "ed_util.h"

#ifndef M_PI
#define M_PI 3.14159265358979323846
#endif

/* A 2D channel along x, box L x 20, disks of radius 0.5, initially a
 * relaxed lattice at eta moving at U = 0.1 with T = 0.02; at x = 0 a
 * dispenser at (eta, U, T); at x = L an open wall with a filter 4 from it
 * (velocity U, turn-back at T = 0.02). Gravity (gx, gy); with gy != 0 the
 * y axis has specular walls (a floor), else it is periodic. restitution <
 * 1: inelastic with the TC model (tc). */
static void channel(char *buf, size_t len, double L, double eta, double gx, double gy, double restitution, double tc,
                    uint64_t seed)
{
	const uint64_t count = (uint64_t)llround(eta * L * 20.0 / (M_PI * 0.25));
	char coll[128] = "", yax[160] = "";
	if (restitution < 1.0)
		snprintf(coll, sizeof coll, "\"collisions\":{\"restitution\":%.17g,\"tc\":%.17g},", restitution, tc);
	if (gy != 0.0)
		snprintf(yax, sizeof yax, ",\"y\":{\"type\":\"walls\",\"lower\":{\"type\":\"specular\"},"
		         "\"upper\":{\"type\":\"specular\"}}");
	snprintf(buf, len,
	         "{\"method\":\"ed\",\"dimensions\":2,\"particles\":{\"count\":%llu,\"radius\":0.5,\"box\":[%.17g,20],"
	         "\"initial\":{\"positions\":\"lattice\",\"temperature\":0.02,\"velocity\":[0.1,0],"
	         "\"relax\":{\"collisions_per_particle\":20}}},%s\"gravity\":[%.17g,%.17g],"
	         "\"boundaries\":{\"x\":{\"type\":\"walls\","
	         "\"lower\":{\"type\":\"dispenser\",\"volume_fraction\":%.17g,\"velocity\":[0.1,0],\"temperature\":0.02},"
	         "\"upper\":{\"type\":\"open\",\"filter\":{\"distance\":4,\"velocity\":[0.1,0],\"temperature\":0.02}}}%s},"
	         "\"run\":{\"seed\":%llu,\"until\":{\"time\":1}}}",
	         (unsigned long long)count, L, coll, gx, gy, eta, yax, (unsigned long long)seed);
}

/* Kinetic energy of the particles present (velocities from ed_state, NaN
 * for empty slots), in units of the mass. */
static double ekin_state(const double *vel, size_t N)
{
	double s = 0.0;
	for (size_t i = 0; i < N; i++)
		if (!isnan(vel[2 * i]))
			s += vel[2 * i] * vel[2 * i] + vel[2 * i + 1] * vel[2 * i + 1];
	return 0.5 * s;
}

/* Test 1: gravity along the stream and across it (g = (0.01, -0.004),
 * floor and ceiling specular), inelastic with TC, a channel 30 long at eta
 * 0.3. (a) Frozen particles (beyond the plane at x = 26) move at U exactly
 * and in a straight line: each one present at two frames 0.5 apart has
 * velocity (0.1, 0) bit for bit and moved by (0.05, 0) to rounding (1e-9),
 * where a fall would have moved it by g t^2 / 2 = (1.25e-3, -5e-4). (b)
 * No contact missed: the smallest gap over 400 frames (including frozen
 * -- regular pairs) is above -1e-9. (c) The engine's running kinetic
 * energy (its exact time integral over [t0, t0 + 2], ekin_time_integral)
 * agrees with the trapezoid rule over frames h = 0.002 apart of the
 * kinetic energy computed from the velocities: between events E(t) is a
 * parabola of curvature m N_regular g^2 (error <= K h^3 m N g^2 / 12) and
 * an event's jump costs at most h |jump| / 2 <= h |E_k+1 - E_k| / 2 in its
 * step (with one event a step; bound summed over the steps, plus 1e-9
 * relative rounding). Counting the frozen particles as falling would be
 * off by m g.U n_frozen t^2 / 2 over the interval (diag), far beyond the
 * bound. */
static void test_along_across(void)
{
	const double gx = 0.01, gy = -0.004, L = 30.0, plane = L - 4.0;
	char json[2048];
	scene_t sc;
	channel(json, sizeof json, L, 0.3, gx, gy, 0.9, 0.05, 7);
	ed_t *ed = make(json, &sc);
	if (!ed) {
		ok(0, "filter in a field: setup");
		ok(0, "filter in a field: no overlap");
		ok(0, "filter in a field: running energy");
		return;
	}
	const size_t N = ed_slots(ed);
	double *p1 = malloc(N * 2 * sizeof(double)), *v1 = malloc(N * 2 * sizeof(double));
	double *p2 = malloc(N * 2 * sizeof(double)), *v2 = malloc(N * 2 * sizeof(double));
	int64_t *l1 = malloc(N * sizeof(int64_t)), *l2 = malloc(N * sizeof(int64_t));
	int rc = ed_advance(ed, 200.0, UINT64_MAX, UINT64_MAX);
	/* (a) and (b) */
	size_t frozen = 0, bad = 0;
	double gap = INFINITY, fall = 0.0;
	for (int f = 0; f < 400 && rc == ED_OK; f++) {
		const double t1 = 200.0 + f;
		rc |= ed_advance(ed, t1, UINT64_MAX, UINT64_MAX);
		ed_state(ed, p1, v1);
		ed_labels(ed, l1);
		double g = ed_min_gap(ed);
		if (g < gap)
			gap = g;
		rc |= ed_advance(ed, t1 + 0.5, UINT64_MAX, UINT64_MAX);
		ed_state(ed, p2, v2);
		ed_labels(ed, l2);
		for (size_t i = 0; i < N; i++) {
			if (isnan(p1[2 * i]) || isnan(p2[2 * i]) || l1[i] != l2[i] || !(p1[2 * i] > plane + 1e-9))
				continue;
			frozen++;
			const double dx = p2[2 * i] - p1[2 * i] - 0.05, dy = p2[2 * i + 1] - p1[2 * i + 1];
			if (fabs(dx) > fall) fall = fabs(dx);
			if (fabs(dy) > fall) fall = fabs(dy);
			bad += v1[2 * i] != 0.1 || v1[2 * i + 1] != 0.0 || v2[2 * i] != 0.1 || v2[2 * i + 1] != 0.0 ||
			       fabs(dx) > 1e-9 || fabs(dy) > 1e-9;
		}
	}
	ed_sample_t s0, s1;
	ed_sample(ed, &s0);
	ok(rc == ED_OK && frozen > 1000 && bad == 0 && s0.wall_outflow[1] > 500,
	   "filter in a field g = (%g, %g): %zu frozen particle frames move at U in a straight line (%zu do not; "
	   "largest deviation %.2g); %llu out", gx, gy, frozen, bad, fall, (unsigned long long)s0.wall_outflow[1]);
	ok(rc == ED_OK && gap > -1e-9, "filter in a field: no overlap over 400 frames (min gap %.3g)", gap);
	/* (c) */
	const double t0 = ed_time(ed), h = 0.002;
	enum { K = 1000 };
	ed_state(ed, NULL, v1);
	double m = s0.kinetic_energy / ekin_state(v1, N);   /* the mass */
	double Ek = s0.kinetic_energy, trap = 0.0, bound = 0.0;
	size_t nmax = 0, nfz = 0;
	for (int k = 1; k <= K && rc == ED_OK; k++) {
		rc |= ed_advance(ed, t0 + k * h, UINT64_MAX, UINT64_MAX);
		ed_state(ed, p1, v1);
		const double E = m * ekin_state(v1, N);
		size_t n = 0;
		for (size_t i = 0; i < N; i++) {
			n += !isnan(p1[2 * i]);
			nfz += !isnan(p1[2 * i]) && p1[2 * i] > plane + 1e-9;
		}
		if (n > nmax)
			nmax = n;
		trap += 0.5 * h * (Ek + E);
		bound += 0.5 * h * fabs(E - Ek);
		Ek = E;
	}
	ed_sample(ed, &s1);
	bound += K * h * h * h * m * (double)nmax * (gx * gx + gy * gy) / 12.0 + 1e-9 * fabs(trap);
	const double T = K * h, wrong = 0.5 * m * gx * 0.1 * ((double)nfz / K) * T * T;
	ok(rc == ED_OK && fabs(s1.ekin_time_integral - trap) <= bound && fabs(s1.interval - T) < 1e-9,
	   "filter in a field: running kinetic energy exact (integral %.12g, trapezoid of the velocities %.12g, "
	   "difference %.3g <= bound %.3g; frozen counted as falling would be off by ~%.3g)",
	   s1.ekin_time_integral, trap, fabs(s1.ekin_time_integral - trap), bound, wrong);
	free(p1);
	free(v1);
	free(p2);
	free(v2);
	free(l1);
	free(l2);
	ed_destroy(ed);
}

enum { NSL = 4, NB = 10 };

/* Test 2, the stream across a field: g = (0, -0.002) (m g H / T = 2 over
 * the 20 wide channel: clearly stratified), floor and ceiling specular,
 * elastic, eta = 0.3, a channel 30 long. From t = 300 to 3300, in four
 * slices of x in [6, 22) (between the piston's reach and the filter
 * region), the volume fraction (averaged across), the temperature and the
 * flow velocity hold their inlet values: a field across the stream does no
 * work on average (elastic, specular walls), so the barometric gas keeps T
 * = 0.02. Tolerance: each slice's mean over 10 blocks of one transit each
 * (300: what a slice holds is renewed once per block, so the blocks are
 * taken as independent, as in stream_test) within 5 standard errors of
 * those blocks. No overlap. */
static void test_across(void)
{
	char json[2048];
	scene_t sc;
	channel(json, sizeof json, 30.0, 0.3, 0.0, -0.002, 1.0, 0.0, 17);
	ed_t *ed = make(json, &sc);
	if (!ed) {
		ok(0, "stream across a field: setup");
		ok(0, "stream across a field: temperature");
		ok(0, "stream across a field: velocity");
		return;
	}
	const size_t N = ed_slots(ed);
	double *pos = malloc(N * 2 * sizeof(double)), *vel = malloc(N * 2 * sizeof(double));
	double eta[NSL][NB], T[NSL][NB], u[NSL][NB], gap = INFINITY;
	const double x0 = 6.0, x1 = 22.0, wsl = (x1 - x0) / NSL, dt = 2.0;
	const int per = 150;   /* frames per block of 300 */
	int rc = ed_advance(ed, 300.0, UINT64_MAX, UINT64_MAX);
	for (int b = 0; b < NB && rc == ED_OK; b++) {
		double c[NSL] = {0}, sv[NSL][2] = {{0}}, sv2[NSL] = {0};
		for (int f = 0; f < per && rc == ED_OK; f++) {
			rc |= ed_advance(ed, 300.0 + (b * per + f + 1) * dt, UINT64_MAX, UINT64_MAX);
			ed_state(ed, pos, vel);
			for (size_t i = 0; i < N; i++) {
				const double *r = pos + 2 * i, *v = vel + 2 * i;
				if (isnan(r[0]) || r[0] < x0 || r[0] >= x1)
					continue;
				int k = (int)((r[0] - x0) / wsl);
				if (k >= NSL)
					k = NSL - 1;
				c[k] += 1.0;
				sv[k][0] += v[0];
				sv[k][1] += v[1];
				sv2[k] += v[0] * v[0] + v[1] * v[1];
			}
		}
		double g = ed_min_gap(ed);
		if (g < gap)
			gap = g;
		for (int k = 0; k < NSL; k++) {
			const double ux = sv[k][0] / c[k], uy = sv[k][1] / c[k];
			eta[k][b] = c[k] / per * (M_PI * 0.25) / (wsl * 20.0);
			u[k][b] = ux;
			T[k][b] = (sv2[k] / c[k] - ux * ux - uy * uy) / 2.0;
		}
	}
	int good_eta = rc == ED_OK, good_T = rc == ED_OK, good_u = rc == ED_OK;
	for (int k = 0; k < NSL && rc == ED_OK; k++) {
		double me, se, mT, sT, mu, su;
		mean_se(eta[k], NB, &me, &se);
		mean_se(T[k], NB, &mT, &sT);
		mean_se(u[k], NB, &mu, &su);
		diag("slice %d: eta %.4f +- %.4f, T %.5f +- %.5f, u %.4f +- %.4f", k, me, se, mT, sT, mu, su);
		good_eta &= fabs(me - 0.3) < 5.0 * se;
		good_T &= fabs(mT - 0.02) < 5.0 * sT;
		good_u &= fabs(mu - 0.1) < 5.0 * su;
	}
	ok(good_eta && gap > -1e-9, "stream across a field (g = -0.002): volume fraction holds along the channel (each "
	   "of 4 slices within 5 SE of 0.3), no overlap (min gap %.3g)", gap);
	ok(good_T, "stream across a field: temperature holds along the channel (within 5 SE of 0.02)");
	ok(good_u, "stream across a field: the stream flows at U = 0.1 (within 5 SE)");
	free(pos);
	free(vel);
	ed_destroy(ed);
}

/* Test 3, checkpoints: a filter in a field (along and across, inelastic,
 * TC) copied through its state fields goes on bit for bit: positions,
 * velocities, ids, counters, impulses, the running energy's integral. */
static void test_checkpoint(void)
{
	char json[2048];
	scene_t sc;
	channel(json, sizeof json, 30.0, 0.3, 0.01, -0.004, 0.9, 0.05, 11);
	ed_t *a, *b;
	if (!checkpoint_pair(json, &sc, 113.0, 155.0, &a, &b)) {
		ok(0, "checkpoint with a filter in a field: restore");
		return;
	}
	ed_advance(a, 400.0, UINT64_MAX, UINT64_MAX);
	ed_advance(b, 400.0, UINT64_MAX, UINT64_MAX);
	ed_sample_t sa, sb;
	ed_sample(a, &sa);
	ed_sample(b, &sb);
	ok(sa.events == sb.events && sa.wall_outflow[1] == sb.wall_outflow[1] && sa.wall_outflow[1] > 0 &&
	   !memcmp(sa.wall_impulse, sb.wall_impulse, sizeof sa.wall_impulse) && same_slots(a, b) &&
	   sa.ekin_time_integral == sb.ekin_time_integral,
	   "checkpoint (filter in a field, TC): restored run identical bit for bit after %llu events (%llu in, %llu "
	   "out)", (unsigned long long)sa.events, (unsigned long long)sa.wall_inflow[0],
	   (unsigned long long)sa.wall_outflow[1]);
	ed_destroy(a);
	ed_destroy(b);
}

/* Test 4, rough spheres in 3D (the rough FILTG kernels): a channel 16 x 6
 * x 6 at eta 0.3, U = 0.1, walls across y, g = (0.005, -0.004, 0.002),
 * Walton's rule with TC: over 100 frame pairs 0.5 apart the frozen
 * particles (beyond the plane at x = 13) move at U bit for bit and by U t
 * to 1e-9, none spinning; no overlap (min gap >= -1e-9); a copy through
 * the state fields goes on bit for bit, spins included. */
static void test_rough_3d(void)
{
	const double plane = 13.0;
	char json[2048];
	snprintf(json, sizeof json,
	         "{\"method\":\"ed\",\"dimensions\":3,\"particles\":{\"count\":160,\"radius\":0.5,\"box\":[16,6,6],"
	         "\"initial\":{\"positions\":\"lattice\",\"temperature\":0.02,\"velocity\":[0.1,0,0]}},"
	         "\"collisions\":{\"restitution\":0.95,\"tc\":0.05,\"rough\":{\"tangential_restitution\":0.5,"
	         "\"friction\":0.3}},\"gravity\":[0.005,-0.004,0.002],"
	         "\"boundaries\":{\"x\":{\"type\":\"walls\",\"lower\":{\"type\":\"dispenser\",\"volume_fraction\":0.3,"
	         "\"velocity\":[0.1,0,0],\"temperature\":0.02},\"upper\":{\"type\":\"open\",\"filter\":{\"distance\":3,"
	         "\"velocity\":[0.1,0,0],\"temperature\":0.02}}},"
	         "\"y\":{\"type\":\"walls\",\"lower\":{\"type\":\"specular\"},\"upper\":{\"type\":\"specular\"}}},"
	         "\"run\":{\"seed\":19,\"until\":{\"time\":1}}}");
	scene_t sc;
	ed_t *a, *b;
	if (!checkpoint_pair(json, &sc, 40.0, 90.0, &a, &b)) {
		ok(0, "rough 3D filter in a field: frozen particles");
		ok(0, "rough 3D filter in a field: checkpoint");
		return;
	}
	const size_t N = ed_slots(a);
	double *p1 = malloc(N * 3 * sizeof(double)), *v1 = malloc(N * 3 * sizeof(double));
	double *p2 = malloc(N * 3 * sizeof(double)), *v2 = malloc(N * 3 * sizeof(double));
	double *w = malloc(N * 3 * sizeof(double));
	int64_t *l1 = malloc(N * sizeof(int64_t)), *l2 = malloc(N * sizeof(int64_t));
	size_t frozen = 0, bad = 0;
	double gap = INFINITY;
	int rc = ED_OK;
	for (int f = 0; f < 100 && rc == ED_OK; f++) {
		const double t1 = 100.0 + f;
		rc |= ed_advance(a, t1, UINT64_MAX, UINT64_MAX);
		ed_state(a, p1, v1);
		ed_labels(a, l1);
		ed_spins(a, w);
		const double g = ed_min_gap(a);
		if (g < gap)
			gap = g;
		rc |= ed_advance(a, t1 + 0.5, UINT64_MAX, UINT64_MAX);
		ed_state(a, p2, v2);
		ed_labels(a, l2);
		for (size_t i = 0; i < N; i++) {
			if (isnan(p1[3 * i]) || isnan(p2[3 * i]) || l1[i] != l2[i] || !(p1[3 * i] > plane + 1e-9))
				continue;
			frozen++;
			bad += v1[3 * i] != 0.1 || v1[3 * i + 1] != 0.0 || v1[3 * i + 2] != 0.0 || v2[3 * i] != 0.1 ||
			       fabs(p2[3 * i] - p1[3 * i] - 0.05) > 1e-9 || fabs(p2[3 * i + 1] - p1[3 * i + 1]) > 1e-9 ||
			       fabs(p2[3 * i + 2] - p1[3 * i + 2]) > 1e-9 || w[3 * i] != 0.0 || w[3 * i + 1] != 0.0 ||
			       w[3 * i + 2] != 0.0;
		}
	}
	ok(rc == ED_OK && frozen > 300 && bad == 0 && gap > -1e-9,
	   "rough 3D filter in a field: %zu frozen particle frames move at U in a straight line without spin (%zu do "
	   "not); min gap %.3g", frozen, bad, gap);
	ed_advance(b, 199.5, UINT64_MAX, UINT64_MAX);   /* where a stands */
	ed_sample_t sa, sb;
	ed_sample(a, &sa);
	ed_sample(b, &sb);
	double *wb = malloc(N * 3 * sizeof(double));
	ed_spins(a, w);
	ed_spins(b, wb);
	ok(sa.events == sb.events && sa.wall_outflow[1] == sb.wall_outflow[1] && sa.wall_outflow[1] > 0 &&
	   !memcmp(sa.wall_impulse, sb.wall_impulse, sizeof sa.wall_impulse) && same_slots_d(a, b, 3) &&
	   !memcmp(w, wb, N * 3 * sizeof(double)) && sa.ekin_time_integral == sb.ekin_time_integral,
	   "rough 3D filter in a field: restored run identical bit for bit, spins included (%llu events, %llu out)",
	   (unsigned long long)sa.events, (unsigned long long)sa.wall_outflow[1]);
	free(p1);
	free(v1);
	free(p2);
	free(v2);
	free(w);
	free(wb);
	free(l1);
	free(l2);
	ed_destroy(a);
	ed_destroy(b);
}

/* Mixtures (the FILTG species kernels): A (radius 0.5, mass 1) and B
 * (radius 0.35, mass 0.5), A:B = na:nb, in the channel above (box L x 20,
 * dispenser and filter at (U, T) = (0.1, 0.02), the same keys); coll: the
 * "collisions" object ("" for elastic). */
static const double RA = 0.5, RB = 0.35, MA = 1.0, MB = 0.5;

static void channel_mix(char *buf, size_t len, double L, double eta, uint64_t na, uint64_t nb, double gx, double gy,
                        const char *coll, uint64_t seed)
{
	char yax[160] = "";
	if (gy != 0.0)
		snprintf(yax, sizeof yax, ",\"y\":{\"type\":\"walls\",\"lower\":{\"type\":\"specular\"},"
		         "\"upper\":{\"type\":\"specular\"}}");
	snprintf(buf, len,
	         "{\"method\":\"ed\",\"dimensions\":2,\"particles\":{\"species\":["
	         "{\"name\":\"A\",\"count\":%llu,\"radius\":%.17g,\"mass\":%.17g},"
	         "{\"name\":\"B\",\"count\":%llu,\"radius\":%.17g,\"mass\":%.17g}],\"box\":[%.17g,20],"
	         "\"initial\":{\"positions\":\"lattice\",\"temperature\":0.02,\"velocity\":[0.1,0],"
	         "\"relax\":{\"collisions_per_particle\":20}}},%s\"gravity\":[%.17g,%.17g],"
	         "\"boundaries\":{\"x\":{\"type\":\"walls\","
	         "\"lower\":{\"type\":\"dispenser\",\"volume_fraction\":%.17g,\"velocity\":[0.1,0],\"temperature\":0.02},"
	         "\"upper\":{\"type\":\"open\",\"filter\":{\"distance\":4,\"velocity\":[0.1,0],\"temperature\":0.02}}}%s},"
	         "\"run\":{\"seed\":%llu,\"until\":{\"time\":1}}}",
	         (unsigned long long)na, RA, MA, (unsigned long long)nb, RB, MB, L, coll, gx, gy, eta, yax,
	         (unsigned long long)seed);
}

static const char MIX_TC[] = "\"collisions\":{\"restitution\":0.9,\"tc\":0.05,"
                             "\"restitution_pairs\":[{\"a\":\"A\",\"b\":\"B\",\"restitution\":0.8}]},";

/* Test 5, test 1 for a mixture: g = (0.01, -0.004), floor and ceiling,
 * restitution 0.9 (A-B pairs 0.8) with TC, channel 30 long at eta 0.3, A:B
 * = 150:60. (a) Frozen particles of both species move at U in a straight
 * line (bit for bit in velocity, 1e-9 in displacement, against a fall of
 * 1.25e-3); (b) the smallest gap (each pair's own contact distance, frozen
 * -- regular pairs included) over 400 frames is above -1e-9; (c) the
 * running kinetic energy's exact integral against the trapezoid of sum
 * m_i v_i^2 / 2 (each row's species' mass) at steps h = 0.002 within the
 * bound of test 1 (curvature sum m_i g^2 over the particles present). */
static void test_mixture(void)
{
	const double gx = 0.01, gy = -0.004, L = 30.0, plane = L - 4.0;
	char json[4096];
	scene_t sc;
	channel_mix(json, sizeof json, L, 0.3, 150, 60, gx, gy, MIX_TC, 7);
	ed_t *ed = make(json, &sc);
	const size_t N = ed ? ed_slots(ed) : 0;
	uint8_t *sp = N ? malloc(N) : NULL;
	double *p1 = N ? malloc(N * 2 * sizeof(double)) : NULL, *v1 = N ? malloc(N * 2 * sizeof(double)) : NULL;
	double *p2 = N ? malloc(N * 2 * sizeof(double)) : NULL, *v2 = N ? malloc(N * 2 * sizeof(double)) : NULL;
	int64_t *l1 = N ? malloc(N * sizeof(int64_t)) : NULL, *l2 = N ? malloc(N * sizeof(int64_t)) : NULL;
	if (!ed || !sp || !p1 || !v1 || !p2 || !v2 || !l1 || !l2) {
		ok(0, "mixture filter in a field: setup");
		ok(0, "mixture filter in a field: no overlap");
		ok(0, "mixture filter in a field: running energy");
		goto done;
	}
	scene_row_species(&sc, sp, NULL);
	int rc = ed_advance(ed, 200.0, UINT64_MAX, UINT64_MAX);
	size_t frozen[2] = {0, 0}, bad = 0;
	double gap = INFINITY, fall = 0.0;
	for (int f = 0; f < 400 && rc == ED_OK; f++) {
		const double t1 = 200.0 + f;
		rc |= ed_advance(ed, t1, UINT64_MAX, UINT64_MAX);
		ed_state(ed, p1, v1);
		ed_labels(ed, l1);
		double g = ed_min_gap(ed);
		if (g < gap)
			gap = g;
		rc |= ed_advance(ed, t1 + 0.5, UINT64_MAX, UINT64_MAX);
		ed_state(ed, p2, v2);
		ed_labels(ed, l2);
		for (size_t i = 0; i < N; i++) {
			if (isnan(p1[2 * i]) || isnan(p2[2 * i]) || l1[i] != l2[i] || !(p1[2 * i] > plane + 1e-9))
				continue;
			frozen[sp[i]]++;
			const double dx = p2[2 * i] - p1[2 * i] - 0.05, dy = p2[2 * i + 1] - p1[2 * i + 1];
			if (fabs(dx) > fall) fall = fabs(dx);
			if (fabs(dy) > fall) fall = fabs(dy);
			bad += v1[2 * i] != 0.1 || v1[2 * i + 1] != 0.0 || v2[2 * i] != 0.1 || v2[2 * i + 1] != 0.0 ||
			       fabs(dx) > 1e-9 || fabs(dy) > 1e-9;
		}
	}
	ed_sample_t s0, s1;
	ed_sample(ed, &s0);
	ok(rc == ED_OK && frozen[0] > 500 && frozen[1] > 200 && bad == 0 && s0.wall_outflow[1] > 300,
	   "mixture filter in a field g = (%g, %g): %zu A and %zu B frozen particle frames move at U in a straight "
	   "line (%zu do not; largest deviation %.2g); %llu out", gx, gy, frozen[0], frozen[1], bad, fall,
	   (unsigned long long)s0.wall_outflow[1]);
	ok(rc == ED_OK && gap > -1e-9, "mixture filter in a field: no overlap over 400 frames (min gap %.3g)", gap);
	const double t0 = ed_time(ed), h = 0.002, mass[2] = {MA, MB};
	enum { K = 1000 };
	double Ek = s0.kinetic_energy, trap = 0.0, bound = 0.0, mmax = 0.0, mfz = 0.0;
	for (int k = 1; k <= K && rc == ED_OK; k++) {
		rc |= ed_advance(ed, t0 + k * h, UINT64_MAX, UINT64_MAX);
		ed_state(ed, p1, v1);
		double E = 0.0, mp = 0.0;
		for (size_t i = 0; i < N; i++) {
			if (isnan(p1[2 * i]))
				continue;
			E += 0.5 * mass[sp[i]] * (v1[2 * i] * v1[2 * i] + v1[2 * i + 1] * v1[2 * i + 1]);
			mp += mass[sp[i]];
			if (p1[2 * i] > plane + 1e-9)
				mfz += mass[sp[i]];
		}
		if (mp > mmax)
			mmax = mp;
		trap += 0.5 * h * (Ek + E);
		bound += 0.5 * h * fabs(E - Ek);
		Ek = E;
	}
	ed_sample(ed, &s1);
	bound += K * h * h * h * mmax * (gx * gx + gy * gy) / 12.0 + 1e-9 * fabs(trap);
	const double T = K * h, wrong = 0.5 * gx * 0.1 * (mfz / K) * T * T;
	ok(rc == ED_OK && fabs(s1.ekin_time_integral - trap) <= bound && fabs(s1.interval - T) < 1e-9,
	   "mixture filter in a field: running kinetic energy exact (integral %.12g, trapezoid %.12g, difference %.3g "
	   "<= bound %.3g; frozen counted as falling would be off by ~%.3g)", s1.ekin_time_integral, trap,
	   fabs(s1.ekin_time_integral - trap), bound, wrong);
done:
	free(sp);
	free(p1);
	free(v1);
	free(p2);
	free(v2);
	free(l1);
	free(l2);
	ed_destroy(ed);
}

/* Test 6, test 2 for a mixture: the stream across g = (0, -0.002), floor
 * and ceiling, elastic, eta 0.3, A:B = 150:60 (B's number fraction 2/7),
 * channel 30 long. From t = 300 to 3300 in four slices of x in [6, 22):
 * the volume fraction (each disk's own area), each species' temperature
 * m_k <|v - u_k|^2> / 2 and the flow velocity hold the inlet's 0.3, 0.02
 * and 0.1 (elastic with specular walls: the field across does no work on
 * average, the barometric mixture keeps T for both species), each within 5
 * standard errors of 10 blocks of one transit (as test 2). No overlap. */
static void test_mixture_across(void)
{
	char json[4096];
	scene_t sc;
	channel_mix(json, sizeof json, 30.0, 0.3, 150, 60, 0.0, -0.002, "", 17);
	ed_t *ed = make(json, &sc);
	const size_t N = ed ? ed_slots(ed) : 0;
	uint8_t *sp = N ? malloc(N) : NULL;
	double *pos = N ? malloc(N * 2 * sizeof(double)) : NULL, *vel = N ? malloc(N * 2 * sizeof(double)) : NULL;
	if (!ed || !sp || !pos || !vel) {
		ok(0, "mixture stream across a field: setup");
		ok(0, "mixture stream across a field: temperatures and velocity");
		goto done;
	}
	scene_row_species(&sc, sp, NULL);
	double eta[NSL][NB], T[2][NSL][NB], u[NSL][NB], gap = INFINITY;
	const double x0 = 6.0, x1 = 22.0, wsl = (x1 - x0) / NSL, dt = 2.0, mass[2] = {MA, MB};
	const double area[2] = {M_PI * RA * RA, M_PI * RB * RB};
	const int per = 150;
	int rc = ed_advance(ed, 300.0, UINT64_MAX, UINT64_MAX);
	for (int b = 0; b < NB && rc == ED_OK; b++) {
		double c[2][NSL] = {{0}}, vol[NSL] = {0}, sv[2][NSL][2] = {{{0}}}, sv2[2][NSL] = {{0}};
		for (int f = 0; f < per && rc == ED_OK; f++) {
			rc |= ed_advance(ed, 300.0 + (b * per + f + 1) * dt, UINT64_MAX, UINT64_MAX);
			ed_state(ed, pos, vel);
			for (size_t i = 0; i < N; i++) {
				const double *r = pos + 2 * i, *v = vel + 2 * i;
				if (isnan(r[0]) || r[0] < x0 || r[0] >= x1)
					continue;
				int k = (int)((r[0] - x0) / wsl);
				if (k >= NSL)
					k = NSL - 1;
				const int q = sp[i];
				c[q][k] += 1.0;
				vol[k] += area[q];
				sv[q][k][0] += v[0];
				sv[q][k][1] += v[1];
				sv2[q][k] += v[0] * v[0] + v[1] * v[1];
			}
		}
		double g = ed_min_gap(ed);
		if (g < gap)
			gap = g;
		for (int k = 0; k < NSL; k++) {
			eta[k][b] = vol[k] / per / (wsl * 20.0);
			u[k][b] = (sv[0][k][0] + sv[1][k][0]) / (c[0][k] + c[1][k]);
			for (int q = 0; q < 2; q++) {
				const double ux = sv[q][k][0] / c[q][k], uy = sv[q][k][1] / c[q][k];
				T[q][k][b] = mass[q] * (sv2[q][k] / c[q][k] - ux * ux - uy * uy) / 2.0;
			}
		}
	}
	int good_eta = rc == ED_OK, good_T = rc == ED_OK, good_u = rc == ED_OK;
	for (int k = 0; k < NSL && rc == ED_OK; k++) {
		double me, se, mT[2], sT[2], mu, su;
		mean_se(eta[k], NB, &me, &se);
		mean_se(u[k], NB, &mu, &su);
		for (int q = 0; q < 2; q++)
			mean_se(T[q][k], NB, &mT[q], &sT[q]);
		diag("mixture slice %d: eta %.4f +- %.4f, T_A %.5f +- %.5f, T_B %.5f +- %.5f, u %.4f +- %.4f", k, me, se,
		     mT[0], sT[0], mT[1], sT[1], mu, su);
		good_eta &= fabs(me - 0.3) < 5.0 * se;
		good_T &= fabs(mT[0] - 0.02) < 5.0 * sT[0] && fabs(mT[1] - 0.02) < 5.0 * sT[1];
		good_u &= fabs(mu - 0.1) < 5.0 * su;
	}
	ok(good_eta && gap > -1e-9, "mixture stream across a field (g = -0.002): volume fraction holds along the "
	   "channel (each of 4 slices within 5 SE of 0.3), no overlap (min gap %.3g)", gap);
	ok(good_T && good_u, "mixture stream across a field: each species' T 0.02 and the flow U = 0.1 hold (within 5 SE)");
done:
	free(sp);
	free(pos);
	free(vel);
	ed_destroy(ed);
}

/* Test 7, checkpoints of the mixture kernels: test 5's scene (seed 11) and
 * a rough 3D mixture (test 4's channel with A:B = 110:50, Walton's rule,
 * the rough FILTG species kernels) copied through their state fields go on
 * bit for bit (the frozen counts per species rebuilt from the flags). */
static void test_mixture_checkpoint(void)
{
	char json[4096];
	scene_t sc;
	channel_mix(json, sizeof json, 30.0, 0.3, 150, 60, 0.01, -0.004, MIX_TC, 11);
	ed_t *a, *b;
	if (!checkpoint_pair(json, &sc, 113.0, 155.0, &a, &b)) {
		ok(0, "mixture checkpoint with a filter in a field: restore");
	} else {
		ed_advance(a, 400.0, UINT64_MAX, UINT64_MAX);
		ed_advance(b, 400.0, UINT64_MAX, UINT64_MAX);
		ed_sample_t sa, sb;
		ed_sample(a, &sa);
		ed_sample(b, &sb);
		ok(sa.events == sb.events && sa.wall_outflow[1] == sb.wall_outflow[1] && sa.wall_outflow[1] > 0 &&
		   !memcmp(sa.wall_impulse, sb.wall_impulse, sizeof sa.wall_impulse) && same_slots(a, b) &&
		   !memcmp(sa.species_count, sb.species_count, sizeof sa.species_count) &&
		   sa.ekin_time_integral == sb.ekin_time_integral,
		   "mixture checkpoint (filter in a field, TC, pair restitution): restored run identical bit for bit after "
		   "%llu events (%llu in, %llu out)", (unsigned long long)sa.events, (unsigned long long)sa.wall_inflow[0],
		   (unsigned long long)sa.wall_outflow[1]);
		ed_destroy(a);
		ed_destroy(b);
	}
	snprintf(json, sizeof json,
	         "{\"method\":\"ed\",\"dimensions\":3,\"particles\":{\"species\":["
	         "{\"name\":\"A\",\"count\":110,\"radius\":0.5,\"mass\":1},{\"name\":\"B\",\"count\":50,\"radius\":0.35,"
	         "\"mass\":0.5}],\"box\":[16,6,6],"
	         "\"initial\":{\"positions\":\"lattice\",\"temperature\":0.02,\"velocity\":[0.1,0,0]}},"
	         "\"collisions\":{\"restitution\":0.95,\"tc\":0.05,\"rough\":{\"tangential_restitution\":0.5,"
	         "\"friction\":0.3}},\"gravity\":[0.005,-0.004,0.002],"
	         "\"boundaries\":{\"x\":{\"type\":\"walls\",\"lower\":{\"type\":\"dispenser\",\"volume_fraction\":0.25,"
	         "\"velocity\":[0.1,0,0],\"temperature\":0.02},\"upper\":{\"type\":\"open\",\"filter\":{\"distance\":3,"
	         "\"velocity\":[0.1,0,0],\"temperature\":0.02}}},"
	         "\"y\":{\"type\":\"walls\",\"lower\":{\"type\":\"specular\"},\"upper\":{\"type\":\"specular\"}}},"
	         "\"run\":{\"seed\":19,\"until\":{\"time\":1}}}");
	if (!checkpoint_pair(json, &sc, 40.0, 90.0, &a, &b)) {
		ok(0, "rough 3D mixture filter in a field: restore");
		return;
	}
	ed_advance(a, 250.0, UINT64_MAX, UINT64_MAX);
	ed_advance(b, 250.0, UINT64_MAX, UINT64_MAX);
	ed_sample_t sa, sb;
	ed_sample(a, &sa);
	ed_sample(b, &sb);
	const size_t N = ed_slots(a);
	double *w = malloc(N * 6 * sizeof(double));
	int same_w = 0;
	if (w) {
		ed_spins(a, w);
		ed_spins(b, w + 3 * N);
		same_w = !memcmp(w, w + 3 * N, N * 3 * sizeof(double));
	}
	const double gap = ed_min_gap(a);
	ok(sa.events == sb.events && sa.wall_outflow[1] == sb.wall_outflow[1] && sa.wall_outflow[1] > 0 &&
	   !memcmp(sa.wall_impulse, sb.wall_impulse, sizeof sa.wall_impulse) && same_slots_d(a, b, 3) && same_w &&
	   sa.ekin_time_integral == sb.ekin_time_integral && gap > -1e-9,
	   "rough 3D mixture filter in a field: restored run identical bit for bit, spins included (%llu events, %llu "
	   "out, min gap %.2g)", (unsigned long long)sa.events, (unsigned long long)sa.wall_outflow[1], gap);
	free(w);
	ed_destroy(a);
	ed_destroy(b);
}

int main(void)
{
	plan(16);
	test_along_across();
	test_across();
	test_checkpoint();
	test_rough_3d();
	test_mixture();
	test_mixture_across();
	test_mixture_checkpoint();
	return done_testing();
}
