/* Tests of reservoir walls (open-stream inlet) in the event-driven engine against kinetic theory: entry flux, entry velocities, equilibrium with a reservoir, a steady stream, slots and ids, exact checkpoints. */
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
#include "preset_file.h"

#ifndef M_PI
#define M_PI 3.14159265358979323846
#endif

/* Moments of the flux-weighted normal velocity of a reservoir at mean
 * inward normal velocity a and thermal speed s = sqrt(T / m), by Simpson's
 * rule on [0, a + 12 s] (independent of the engine's closed forms):
 * mk[k] = int_0^inf w^k exp(-(w - a)^2 / (2 s^2)) dw, k = 0..3. */
static void moments(double a, double s, double mk[4])
{
	const int n = 200000;
	const double hi = fmax(a, 0.0) + 12.0 * s, h = hi / n;
	for (int k = 0; k < 4; k++)
		mk[k] = 0.0;
	for (int i = 0; i <= n; i++) {
		const double w = i * h, f = exp(-(w - a) * (w - a) / (2.0 * s * s));
		const double c = (i == 0 || i == n) ? 1.0 : (i & 1) ? 4.0 : 2.0;
		for (int k = 0; k < 4; k++)
			mk[k] += c * f * pow(w, k);
	}
	for (int k = 0; k < 4; k++)
		mk[k] *= h / 3.0;
}

/* One-sided flux F_+ (particles per unit time and area, or length in 2D)
 * into the box of a reservoir of number density n: n times the mean of the
 * positive part of a Maxwellian normal velocity about a (seed 001, 3.15). */
static double flux_plus(double n, double a, double s)
{
	double mk[4];
	moments(a, s, mk);
	return n * mk[1] / (s * sqrt(2.0 * M_PI));
}

/* Henderson's equation of state of hard disks, Z = (1 + eta^2/8)/(1 - eta)^2. */
static double z_henderson(double eta)
{
	return (1.0 + eta * eta / 8.0) / ((1.0 - eta) * (1.0 - eta));
}

/* Number density of a volume fraction in 2D, radius r. */
static double density_2d(double eta, double r) { return eta / (M_PI * r * r); }

/* Test 2, the flux identity: attempted entries (made + rejected) per unit
 * time at a reservoir whose flow is into the box (lower x wall, U_n =
 * +0.5) and out of it (upper x wall, U_n = -0.5) are Poisson counts of
 * mean F_+ x area x time; each must lie within 4 sqrt(expected). */
static void test_flux(void)
{
	const char *json = "{\"method\":\"ed\",\"dimensions\":2,\"particles\":{\"count\":10,\"box\":[40,100],"
	                   "\"initial\":{\"positions\":\"random\",\"temperature\":1}},"
	                   "\"boundaries\":{\"x\":{\"type\":\"walls\","
	                   "\"lower\":{\"type\":\"reservoir\",\"volume_fraction\":0.005,\"velocity\":[0.5,0],\"temperature\":1},"
	                   "\"upper\":{\"type\":\"reservoir\",\"volume_fraction\":0.005,\"velocity\":[0.5,0],\"temperature\":1}}},"
	                   "\"run\":{\"seed\":21,\"until\":{\"time\":1}}}";
	scene_t sc;
	ed_t *ed = make(json, &sc);
	if (!ed) {
		ok(0, "flux, U_n > 0: setup");
		ok(0, "flux, U_n < 0: setup");
		return;
	}
	const double t_end = 4000.0;
	int rc = ed_advance(ed, t_end, UINT64_MAX, UINT64_MAX);
	ed_sample_t sm;
	ed_sample(ed, &sm);
	const double n = density_2d(0.005, sc.radius);
	for (int k = 0; k < 2; k++) {
		const double a = k ? -0.5 : 0.5, expect = flux_plus(n, a, 1.0) * sc.box[1] * t_end;
		const double got = (double)(sm.wall_inflow[k] + sm.wall_rejected[k]), tol = 4.0 * sqrt(expect);
		ok(rc == ED_OK && fabs(got - expect) < tol,
		   "flux, U_n %s 0: %.0f entries tried (%llu made, %llu rejected) over t = %g, F_+ L t = %.1f, "
		   "tolerance 4 sqrt = %.1f", k ? "<" : ">", got, (unsigned long long)sm.wall_inflow[k],
		   (unsigned long long)sm.wall_rejected[k], t_end, expect, tol);
	}
	ed_destroy(ed);
	/* 3D, a reservoir on each end of z with a flow across it (U = (0.4, 0, 0.3)): F_+ times the face
	 * area 20 x 15 at U_n = +0.3 (lower) and -0.3 (upper), the tangential flow not counting */
	const char *json3 = "{\"method\":\"ed\",\"dimensions\":3,\"particles\":{\"count\":10,\"box\":[20,15,30],"
	                    "\"initial\":{\"positions\":\"random\",\"temperature\":1}},"
	                    "\"boundaries\":{\"z\":{\"type\":\"walls\","
	                    "\"lower\":{\"type\":\"reservoir\",\"volume_fraction\":0.002,\"velocity\":[0.4,0,0.3],\"temperature\":1},"
	                    "\"upper\":{\"type\":\"reservoir\",\"volume_fraction\":0.002,\"velocity\":[0.4,0,0.3],\"temperature\":1}}},"
	                    "\"run\":{\"seed\":28,\"until\":{\"time\":1}}}";
	ed = make(json3, &sc);
	rc = ed ? ed_advance(ed, 2000.0, UINT64_MAX, UINT64_MAX) : -99;
	if (ed)
		ed_sample(ed, &sm);
	const double n3 = 0.002 / (4.0 / 3.0 * M_PI * pow(sc.radius, 3));
	for (int k = 0; k < 2; k++) {
		const double a = k ? -0.3 : 0.3, expect = flux_plus(n3, a, 1.0) * sc.box[0] * sc.box[1] * 2000.0;
		const double got = ed ? (double)(sm.wall_inflow[4 + k] + sm.wall_rejected[4 + k]) : -1.0;
		const double tol = 4.0 * sqrt(expect);
		ok(rc == ED_OK && fabs(got - expect) < tol,
		   "flux 3D, U_n %s 0 (tangential flow 0.4): %.0f entries tried over t = 2000, F_+ A t = %.1f, tolerance %.1f",
		   k ? "<" : ">", got, expect, tol);
	}
	ed_destroy(ed);
}

/* Test 3, entry velocities: in a very dilute box (eta 5e-4: a particle
 * meets another once in ~2e3 time units) a particle's velocity right after
 * it entered is its entry velocity. New ids are picked up every 0.25 time
 * units (a particle crossing the 60-long box in less needs a speed of 240,
 * never seen at T = 1); the mean and mean square of the normal speed over M
 * entries must match the flux-weighted distribution (3.29) within 5
 * standard errors (sample variance / M), at U_n = +0.8 (lower) and -0.8
 * (upper), and the tangential velocity's mean and variance the Maxwellian
 * about the reservoir's (0.3). */
static void test_velocities(void)
{
	const char *json = "{\"method\":\"ed\",\"dimensions\":2,\"particles\":{\"count\":2,\"box\":[60,4000],"
	                   "\"capacity\":1000,\"initial\":{\"positions\":\"random\",\"temperature\":1}},"
	                   "\"boundaries\":{\"x\":{\"type\":\"walls\","
	                   "\"lower\":{\"type\":\"reservoir\",\"volume_fraction\":5e-4,\"velocity\":[0.8,0.3],\"temperature\":1},"
	                   "\"upper\":{\"type\":\"reservoir\",\"volume_fraction\":5e-4,\"velocity\":[0.8,0.3],\"temperature\":1}}},"
	                   "\"run\":{\"seed\":22,\"until\":{\"time\":1}}}";
	scene_t sc;
	ed_t *ed = make(json, &sc);
	if (!ed) {
		for (int k = 0; k < 3; k++)
			ok(0, "entry velocities: setup");
		return;
	}
	const uint32_t N = ed_slots(ed);
	double *vel = malloc(sizeof(double) * 2 * N);
	int64_t *id = malloc(sizeof(int64_t) * N);
	double s1[2] = {0, 0}, s2[2] = {0, 0}, s3[2] = {0, 0}, s4[2] = {0, 0}, t1 = 0, t2 = 0;
	long m[2] = {0, 0};
	int64_t seen = 2;
	for (int step = 1; step <= 40000; step++) {
		ed_advance(ed, 0.25 * step, UINT64_MAX, UINT64_MAX);
		ed_state(ed, NULL, vel);
		ed_labels(ed, id);
		int64_t top = seen;
		for (uint32_t r = 0; r < N; r++) {
			if (id[r] < seen)
				continue;
			top = id[r] + 1 > top ? id[r] + 1 : top;
			const double vx = vel[2 * r], vy = vel[2 * r + 1];
			const int k = vx < 0.0;   /* from the upper wall: moving -x */
			const double w = fabs(vx);
			s1[k] += w, s2[k] += w * w, s3[k] += w * w * w, s4[k] += w * w * w * w;
			t1 += vy - 0.3, t2 += (vy - 0.3) * (vy - 0.3);
			m[k]++;
		}
		seen = top;
	}
	for (int k = 0; k < 2; k++) {
		double mk[4];
		const double a = k ? -0.8 : 0.8;
		moments(a, 1.0, mk);
		const double mean = mk[2] / mk[1], msq = mk[3] / mk[1];
		const double em = s1[k] / m[k], esq = s2[k] / m[k];
		const double se1 = sqrt((esq - em * em) / m[k]), se2 = sqrt((s4[k] / m[k] - esq * esq) / m[k]);
		(void)s3;
		ok(m[k] > 1000 && fabs(em - mean) < 5.0 * se1 && fabs(esq - msq) < 5.0 * se2,
		   "entry velocities, U_n = %+.1f: <w> = %.4f +- %.4f (theory %.4f), <w^2> = %.4f +- %.4f (theory %.4f) "
		   "over %ld entries", a, em, se1, mean, esq, se2, msq, m[k]);
	}
	const long mt = m[0] + m[1];
	const double tm = t1 / mt, tv = t2 / mt - tm * tm;
	/* the variance of a sample variance of a Gaussian is 2 s^4 / M */
	ok(mt > 2000 && fabs(tm) < 5.0 / sqrt(mt) && fabs(tv - 1.0) < 5.0 * sqrt(2.0 / mt),
	   "entry velocities, tangential: mean - U_t = %.4f, variance %.4f (theory 0, 1; 5 standard errors %.4f, %.4f)",
	   tm, tv, 5.0 / sqrt(mt), 5.0 * sqrt(2.0 / mt));
	free(vel);
	free(id);
	ed_destroy(ed);
}

/* Test 1, equilibrium with a reservoir: a box closed but for one reservoir
 * wall at rest (x lower; x upper specular, y periodic) at the reservoir's
 * density and temperature. Over K blocks, each ~8 exchange times N/(F_+ L)
 * long, the mean temperature must be T_res (5 standard errors of the block
 * means) and the mean number of centres in the accessible area A (x in
 * [r, L_x - r]) n_res (1 - f) A / Z (docs/engine.md, "Reservoir walls"):
 * f is the fraction of entries rejected (the flux in is that of an ideal
 * reservoir of density n_res (1 - f), which is the density of centres at
 * the face), and Z = P / (n T) of hard disks, since the normal pressure is
 * the same at the face (kinetic only: nothing beyond it) and in the bulk.
 * Tolerance: 5 standard errors plus the particles in the layers a diameter
 * thick at the face and at the far wall, where the density departs from the
 * bulk's by O(Z - 1): 2 (Z - 1) n sigma L_y. */
static void test_equilibrium(void)
{
	const char *json = "{\"method\":\"ed\",\"dimensions\":2,\"particles\":{\"count\":2420,\"box\":[20,10000],"
	                   "\"initial\":{\"positions\":\"random\",\"temperature\":1}},"
	                   "\"boundaries\":{\"x\":{\"type\":\"walls\","
	                   "\"lower\":{\"type\":\"reservoir\",\"volume_fraction\":0.01,\"velocity\":[0,0],\"temperature\":1},"
	                   "\"upper\":{\"type\":\"specular\"}}},"
	                   "\"run\":{\"seed\":23,\"until\":{\"time\":1}}}";
	scene_t sc;
	ed_t *ed = make(json, &sc);
	if (!ed) {
		ok(0, "equilibrium: setup");
		ok(0, "equilibrium: temperature");
		return;
	}
	enum { K = 40, S = 50 };
	const double tb = 400.0, t0 = 400.0;
	double nb[K], tbk[K];
	ed_sample_t sm;
	ed_advance(ed, t0, UINT64_MAX, UINT64_MAX);
	ed_sample(ed, &sm);
	const uint64_t in0 = sm.wall_inflow[0], rej0 = sm.wall_rejected[0];
	for (int k = 0; k < K; k++) {
		double sn = 0.0, st = 0.0;
		for (int j = 1; j <= S; j++) {
			ed_advance(ed, t0 + k * tb + j * tb / S, UINT64_MAX, UINT64_MAX);
			ed_totals(ed, &sm);
			sn += (double)sm.particles;
			st += sm.kinetic_energy / (double)sm.particles;   /* T = 2 E / (D N) = E / N in 2D */
		}
		nb[k] = sn / S;
		tbk[k] = st / S;
	}
	ed_sample(ed, &sm);
	const double f = (double)(sm.wall_rejected[0] - rej0) /
	                 (double)(sm.wall_inflow[0] - in0 + sm.wall_rejected[0] - rej0);
	const double area = (sc.box[0] - 2.0 * sc.radius) * sc.box[1], n_res = density_2d(0.01, sc.radius);
	double mn, sen, mt, set;
	mean_se(nb, K, &mn, &sen);
	mean_se(tbk, K, &mt, &set);
	const double z = z_henderson(n_res * (1.0 - f) * M_PI * sc.radius * sc.radius);
	const double want = n_res * (1.0 - f) * area / z;
	const double tol = 5.0 * sen + 2.0 * (z - 1.0) * n_res * 2.0 * sc.radius * sc.box[1];
	ok(fabs(mn - want) < tol,
	   "equilibrium with a reservoir: <N> = %.2f +- %.2f (%d blocks), n_res (1 - f) A / Z = %.2f (f = %.4f rejected, "
	   "Z = %.4f; n_res A = %.2f), tolerance %.2f", mn, sen, K, want, f, z, n_res * area, tol);
	ok(fabs(mt - 1.0) < 5.0 * set, "equilibrium with a reservoir: <T> = %.5f +- %.5f, T_res = 1", mt, set);
	ed_destroy(ed);
}

/* Test 4, a stream (seed 001's low-density outlet with turn-back, in its
 * reservoir form): reservoirs at both ends of x with the same gas (eta
 * 0.04, kT 0.02, U = 0.05 along x), y periodic, 2D. After two crossing
 * times L/U, over K blocks of snapshots: the counts in B bins along the
 * accessible length hold the channel's mean, each within 5 standard errors
 * of its block mean plus (Z - 1) of the mean, and the mean velocity is 0
 * across (5 standard errors) and U along x within 5 standard errors plus
 * (Z - 1) U. The allowance: the reservoir is an ideal gas, the box's a
 * hard-disk gas (Z = P / (n T) = 1.07 here), and density and velocity in
 * the box depart from the reservoir's by O(Z - 1) (docs/engine.md,
 * "Reservoir walls": the bulk density is ~n_res (1 - f) / Z, the flow up to
 * Z U). Measured over 4 runs of 1e5 time units: u / U = 1.04 +- 0.01,
 * n / n_res = 0.873, and the density falls by 3-4% from the inlet's end
 * of the channel to the outlet's, which the statistics resolve (chi-square
 * of the bins against their mean 10 to 37 for 9 degrees of freedom): the
 * chi-square is reported, not tested. */
static void test_stream(void)
{
	const char *json = "{\"method\":\"ed\",\"dimensions\":2,\"particles\":{\"count\":255,\"box\":[100,50],"
	                   "\"initial\":{\"positions\":\"random\",\"temperature\":0.02,\"velocity\":[0.05,0]}},"
	                   "\"boundaries\":{\"x\":{\"type\":\"walls\","
	                   "\"lower\":{\"type\":\"reservoir\",\"volume_fraction\":0.04,\"velocity\":[0.05,0],\"temperature\":0.02},"
	                   "\"upper\":{\"type\":\"reservoir\",\"volume_fraction\":0.04,\"velocity\":[0.05,0],\"temperature\":0.02}}},"
	                   "\"run\":{\"seed\":24,\"until\":{\"time\":1}}}";
	scene_t sc;
	ed_t *ed = make(json, &sc);
	if (!ed) {
		ok(0, "stream: setup");
		ok(0, "stream: velocity");
		return;
	}
	enum { K = 40, S = 40, B = 10 };
	const double t0 = 4000.0, tb = 2000.0;
	const uint32_t N = ed_slots(ed);
	double *pos = malloc(sizeof(double) * 2 * N), *vel = malloc(sizeof(double) * 2 * N);
	static double cnt[B][K];
	double ux[K], uy[K];
	ed_advance(ed, t0, UINT64_MAX, UINT64_MAX);
	for (int k = 0; k < K; k++) {
		double sx = 0.0, sy = 0.0, np = 0.0;
		for (int b = 0; b < B; b++)
			cnt[b][k] = 0.0;
		for (int j = 1; j <= S; j++) {
			ed_advance(ed, t0 + k * tb + j * tb / S, UINT64_MAX, UINT64_MAX);
			ed_state(ed, pos, vel);
			for (uint32_t r = 0; r < N; r++) {
				if (isnan(pos[2 * r]))
					continue;   /* an empty slot */
				/* bins over the centres' accessible length [r, L_x - r] */
				int b = (int)((pos[2 * r] - sc.radius) / (sc.box[0] - 2.0 * sc.radius) * B);
				cnt[b < 0 ? 0 : b >= B ? B - 1 : b][k] += 1.0 / S;
				sx += vel[2 * r], sy += vel[2 * r + 1], np += 1.0;
			}
		}
		ux[k] = sx / np, uy[k] = sy / np;
	}
	double m[B], se[B], all = 0.0, chi2 = 0.0;
	for (int b = 0; b < B; b++) {
		mean_se(cnt[b], K, &m[b], &se[b]);
		all += m[b] / B;
	}
	for (int b = 0; b < B; b++)
		chi2 += (m[b] - all) * (m[b] - all) / (se[b] * se[b]);
	const double zb = z_henderson(all * B / ((sc.box[0] - 2.0 * sc.radius) * sc.box[1]) * M_PI * sc.radius * sc.radius);
	int held = 1;
	for (int b = 0; b < B; b++)
		held &= fabs(m[b] - all) < 5.0 * se[b] + (zb - 1.0) * all;
	ok(held, "stream: density held along the channel: bin counts %.2f (inlet end) .. %.2f (outlet end), mean %.2f, "
	   "within 5 standard errors + (Z - 1) = %.3f of the mean (chi^2 against the mean %.1f over %d bins); "
	   "n_res A / B = %.2f", m[0], m[B - 1], all, zb - 1.0, chi2, B,
	   density_2d(0.04, sc.radius) * (sc.box[0] - 2.0 * sc.radius) * sc.box[1] / B);
	double mx, sx, my, sy;
	mean_se(ux, K, &mx, &sx);
	mean_se(uy, K, &my, &sy);
	const double z = z_henderson(all * B / ((sc.box[0] - 2.0 * sc.radius) * sc.box[1]) * M_PI * sc.radius * sc.radius);
	const double tol = 5.0 * sx + (z - 1.0) * 0.05;
	ok(fabs(mx - 0.05) < tol && fabs(my) < 5.0 * sy,
	   "stream: mean velocity (%.5f +- %.5f, %.5f +- %.5f), U = (0.05, 0), tolerance along x %.5f (Z = %.4f)",
	   mx, sx, my, sy, tol, z);
	free(pos);
	free(vel);
	ed_destroy(ed);
}

/* Slots and ids: ids are unique over the run and never reused, rows of
 * empty slots are NaN with id -1, and a full box stops the run with
 * ED_FULL, the state intact. */
static void test_slots(void)
{
	const char *json = "{\"method\":\"ed\",\"dimensions\":2,\"particles\":{\"count\":20,\"capacity\":60,\"box\":[30,30],"
	                   "\"initial\":{\"positions\":\"random\",\"temperature\":1}},"
	                   "\"boundaries\":{\"x\":{\"type\":\"walls\","
	                   "\"lower\":{\"type\":\"reservoir\",\"volume_fraction\":0.02,\"temperature\":1},"
	                   "\"upper\":{\"type\":\"open\"}}},"
	                   "\"run\":{\"seed\":25,\"until\":{\"time\":1}}}";
	scene_t sc;
	ed_t *ed = make(json, &sc);
	if (!ed) {
		ok(0, "slots: setup");
		ok(0, "slots: full");
		return;
	}
	const uint32_t N = ed_slots(ed);
	double *pos = malloc(sizeof(double) * 2 * N);
	int64_t *id = malloc(sizeof(int64_t) * N), *prev = malloc(sizeof(int64_t) * N);
	ed_labels(ed, prev);
	int good = N == 60, changes = 0, dup = 0;
	int64_t top = 20;
	for (int step = 1; step <= 200 && good; step++) {
		ed_advance(ed, 1.0 * step, UINT64_MAX, UINT64_MAX);
		ed_state(ed, pos, NULL);
		ed_labels(ed, id);
		const int64_t top0 = top;
		for (uint32_t r = 0; r < N; r++) {
			good &= (id[r] < 0) == (isnan(pos[2 * r]) != 0);
			if (id[r] != prev[r] && id[r] >= 0) {
				good &= id[r] >= top0;   /* a new particle gets a new id, above all earlier ones */
				top = id[r] + 1 > top ? id[r] + 1 : top;
				changes++;
			}
			for (uint32_t q = 0; q < r; q++)
				dup += id[r] >= 0 && id[q] == id[r];
		}
		memcpy(prev, id, sizeof(int64_t) * N);
	}
	ok(good && !dup && changes > 20, "slots: %d entries got new ids in order, no id twice, empty rows NaN with id -1",
	   changes);
	ed_destroy(ed);
	/* a reservoir much denser than the slots allow: fills up */
	const char *full = "{\"method\":\"ed\",\"dimensions\":2,\"particles\":{\"count\":10,\"capacity\":12,\"box\":[30,30],"
	                   "\"initial\":{\"positions\":\"random\",\"temperature\":1}},"
	                   "\"boundaries\":{\"x\":{\"type\":\"walls\","
	                   "\"lower\":{\"type\":\"reservoir\",\"volume_fraction\":0.2,\"temperature\":1},"
	                   "\"upper\":{\"type\":\"specular\"}}},"
	                   "\"run\":{\"seed\":26,\"until\":{\"time\":1}}}";
	ed = make(full, &sc);
	int rc = ed ? ed_advance(ed, 100.0, UINT64_MAX, UINT64_MAX) : -99;
	ed_sample_t sm;
	if (ed)
		ed_totals(ed, &sm);
	ok(rc == ED_FULL && sm.particles == 12 && ed_time(ed) < 100.0 && ed_min_gap(ed) > -1e-9,
	   "slots: a full box stops with ED_FULL (rc %d, %llu present at t = %g), no overlap", rc,
	   ed ? (unsigned long long)sm.particles : 0ull, ed ? ed_time(ed) : 0.0);
	ed_destroy(ed);
	free(pos);
	free(id);
	free(prev);
}

/* Checkpoints: a run copied through its state fields (slots, ids, timers,
 * the entries' random stream) goes on bit for bit like the original. */
static void test_checkpoint(void)
{
	const char *json = "{\"method\":\"ed\",\"dimensions\":2,\"particles\":{\"count\":100,\"box\":[40,30],"
	                   "\"initial\":{\"positions\":\"random\",\"temperature\":1,\"velocity\":[0.5,0]}},"
	                   "\"collisions\":{\"restitution\":0.95,\"tc\":1e-4},"
	                   "\"boundaries\":{\"x\":{\"type\":\"walls\","
	                   "\"lower\":{\"type\":\"reservoir\",\"volume_fraction\":0.05,\"velocity\":[0.5,0],\"temperature\":1},"
	                   "\"upper\":{\"type\":\"reservoir\",\"volume_fraction\":0.05,\"velocity\":[0.5,0],\"temperature\":1}}},"
	                   "\"obstacles\":[{\"type\":\"slip\",\"center\":[20,15],\"radius\":3}],"
	                   "\"run\":{\"seed\":27,\"until\":{\"time\":1}}}";
	scene_t sc;
	ed_t *a, *b;
	if (!checkpoint_pair(json, &sc, 7.5, 20.0, &a, &b)) {
		ok(0, "checkpoint with reservoir walls: restore");
		return;
	}
	ed_advance(a, 200.0, UINT64_MAX, UINT64_MAX);
	ed_advance(b, 200.0, UINT64_MAX, UINT64_MAX);
	ed_sample_t sa, sb;
	ed_sample(a, &sa);
	ed_sample(b, &sb);
	ok(sa.events == sb.events && sa.wall_inflow[0] == sb.wall_inflow[0] && sa.wall_inflow[0] > 0 &&
	   !memcmp(sa.wall_rejected, sb.wall_rejected, sizeof sa.wall_rejected) &&
	   same_slots(a, b) &&
	   sa.ekin_time_integral == sb.ekin_time_integral,
	   "checkpoint (reservoir walls, obstacle, TC): restored run identical bit for bit after %llu events "
	   "(%llu + %llu entries, %llu present)", (unsigned long long)sa.events, (unsigned long long)sa.wall_inflow[0],
	   (unsigned long long)sa.wall_inflow[1], (unsigned long long)sa.particles);
	ed_destroy(a);
	ed_destroy(b);
}

/* Gravity (the gravity kernels' entry path): reservoirs at the x ends of a
 * box with a floor and a lid (y walls, g along -y), elastic. No overlap at
 * the end, the particle balance holds, and a copy through the state fields
 * goes on bit for bit. */
static void test_gravity(void)
{
	const char *json = "{\"method\":\"ed\",\"dimensions\":2,\"particles\":{\"count\":150,\"box\":[40,30],"
	                   "\"initial\":{\"positions\":\"random\",\"temperature\":1}},"
	                   "\"boundaries\":{\"x\":{\"type\":\"walls\","
	                   "\"lower\":{\"type\":\"reservoir\",\"volume_fraction\":0.05,\"velocity\":[0.5,0],\"temperature\":1},"
	                   "\"upper\":{\"type\":\"reservoir\",\"volume_fraction\":0.05,\"velocity\":[0.5,0],\"temperature\":1}},"
	                   "\"y\":{\"type\":\"walls\",\"lower\":{\"type\":\"specular\"},\"upper\":{\"type\":\"specular\"}}},"
	                   "\"gravity\":[0,-0.05],\"run\":{\"seed\":29,\"until\":{\"time\":1}}}";
	scene_t sc;
	ed_t *a, *b;
	if (!checkpoint_pair(json, &sc, 5.0, 60.0, &a, &b)) {
		ok(0, "gravity with reservoir walls: restore");
		return;
	}
	int ra = ed_advance(a, 400.0, UINT64_MAX, UINT64_MAX), rb = ed_advance(b, 400.0, UINT64_MAX, UINT64_MAX);
	ed_sample_t sa, sb;
	ed_sample(a, &sa);
	ed_sample(b, &sb);
	uint64_t in = 0, out = 0;
	for (int w = 0; w < 6; w++)
		in += sa.wall_inflow[w], out += sa.wall_outflow[w];
	ok(ra == ED_OK && rb == ED_OK && ed_min_gap(a) > -1e-9 && sa.particles == 150 + in - out && in > 100 &&
	   sa.events == sb.events && same_slots(a, b) &&
	   sa.ekin_time_integral == sb.ekin_time_integral && sa.potential_energy == sb.potential_energy,
	   "gravity with reservoir walls: no overlap (gap %.2g), %llu present = 150 + %llu in - %llu out, restored run "
	   "identical bit for bit after %llu events", ed_min_gap(a), (unsigned long long)sa.particles,
	   (unsigned long long)in, (unsigned long long)out, (unsigned long long)sa.events);
	ed_destroy(a);
	ed_destroy(b);
}

/* The preset presets/obstacle-stream-2d.json (seed 001's obstacle in a
 * stream, anchors 4 and 10, at the seed's D = 74, U = 0.05, kT = 0.02, but
 * eta = 0.04: the low-density boundary). The seed gives no drag numbers
 * (Fig. 4.19 only); what is checked: after one flow-through time the
 * particle count is steady (the means of the third and fourth quarters of
 * the run agree within 5 standard errors of their block means), the drag
 * (the obstacle's mean force along the flow, momentum per unit time) is
 * positive by more than 5 standard errors, and the lift (across the flow;
 * the obstacle is on the channel's axis, y periodic) is 0 within 5
 * standard errors. Blocks of 1100 time units, 0.75 of the obstacle's
 * passage time D / U. */
static void test_preset(void)
{
	static char text[8192];
	scene_t sc;
	char err[512];
	int rc;
	if (!preset_text("obstacle-stream-2d.json", text, sizeof text) ||
	    scene_parse(text, strlen(text), &sc, err, sizeof err) != SCENE_OK) {
		ok(0, "preset obstacle-stream-2d: read and parsed (%s)", err);
		ok(0, "preset obstacle-stream-2d: drag");
		return;
	}
	ed_t *ed = ed_create(&sc, &rc, err, sizeof err);
	if (!ed) {
		ok(0, "preset obstacle-stream-2d: engine (%s)", err);
		ok(0, "preset obstacle-stream-2d: drag");
		return;
	}
	enum { K = 8 };
	const double t1 = sc.until.value / 2.0, tb = (sc.until.value - t1) / K;
	double np[K], fx[K], fy[K];
	ed_sample_t sm;
	ed_advance(ed, t1, UINT64_MAX, UINT64_MAX);
	ed_sample(ed, &sm);
	for (int k = 0; k < K; k++) {
		double sn = 0.0;
		for (int j = 1; j <= 20; j++) {
			ed_advance(ed, t1 + k * tb + j * tb / 20, UINT64_MAX, UINT64_MAX);
			ed_totals(ed, &sm);
			sn += (double)sm.particles / 20;
		}
		ed_sample(ed, &sm);
		np[k] = sn;
		fx[k] = sm.obstacle_impulse[0][0] / sm.interval;
		fy[k] = sm.obstacle_impulse[0][1] / sm.interval;
	}
	double m3, s3, m4, s4, mx, sx, my, sy;
	mean_se(np, K / 2, &m3, &s3);
	mean_se(np + K / 2, K / 2, &m4, &s4);
	mean_se(fx, K, &mx, &sx);
	mean_se(fy, K, &my, &sy);
	ok(fabs(m3 - m4) < 5.0 * sqrt(s3 * s3 + s4 * s4),
	   "preset obstacle-stream-2d: steady, %.1f +- %.1f then %.1f +- %.1f particles (n_res A = %.0f)", m3, s3, m4, s4,
	   density_2d(0.04, sc.radius) * sc.box[0] * sc.box[1]);
	ok(mx > 5.0 * sx && fabs(my) < 5.0 * sy,
	   "preset obstacle-stream-2d: drag %.4f +- %.4f (along the flow), lift %.4f +- %.4f, over %d blocks of %g",
	   mx, sx, my, sy, K, tb);
	ed_destroy(ed);
}

int main(void)
{
	plan(17);
	test_flux();
	test_velocities();
	test_equilibrium();
	test_stream();
	test_slots();
	test_checkpoint();
	test_gravity();
	test_preset();
	return tap_failed ? 1 : 0;
}
