/* Tests of dsmc with mixtures (species): equipartition, an inelastic mixture's cooling and temperature ratio against ed, per-pair restitution, exact restores, refusals; walls, gravity and obstacles (barometric profiles, energy, thermal walls, contact distances). */
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "ed/ed.h"
#include "mc/dsmc.h"
#include "scene.h"
#include "tap.h"
#include "mc_util.h"
#include "stats.h"


/* T_s = 2 E_s / (D N_s) of species s now. */

/* An elastic binary mixture (600 disks m = 1, r = 0.5; 200 disks m = 4,
 * r = 1; nu = 0.05) started with the large species 3 times hotter (its
 * velocities scaled by sqrt(3) through the checkpoint field "particles")
 * relaxes to equal temperatures (equipartition). Energy and momentum are
 * conserved by every collision (masses in the rule): 1e-10 relative over
 * the run is ~10^5 ulps. After 20 collisions per particle, 40 snapshots 1
 * collision per particle apart (T_s of 200 particles fluctuates by ~7%; a
 * snapshot a collision later is nearly independent of it): T_l / T_s = 1
 * within 5 SE of the mean over them; the start must be far from it. */
static void test_equipartition(void)
{
	const char *json = "{\"method\":\"dsmc\",\"dimensions\":2,\"particles\":{\"species\":[{\"name\":\"s\",\"count\":600,"
	                   "\"radius\":0.5,\"mass\":1},{\"name\":\"l\",\"count\":200,\"radius\":1,\"mass\":4}],"
	                   "\"volume_fraction\":0.05,\"initial\":{\"positions\":\"random\",\"temperature\":1}},"
	                   "\"run\":{\"seed\":3,\"until\":{\"time\":1000}}}";
	scene_t sc;
	dsmc_t *d = mc_make(json, &sc, 0);
	double ratio0 = NAN, ratio[40] = {0}, e0 = NAN, p0[3] = {0}, worst = 0, pworst = 0;
	if (d) {
		mc_scale_ids_2d(d, sc.count, 600, sqrt(3.0));
		dsmc_sample_t sm;
		dsmc_totals(d, &sm);
		ratio0 = tspec(&sm, 1, 2) / tspec(&sm, 0, 2);
		e0 = sm.kinetic_energy;
		memcpy(p0, sm.momentum, sizeof p0);
		for (int k = 0; k < 60; k++) {
			uint64_t c = dsmc_collisions(d) + sc.count / 2;   /* one collision per particle */
			dsmc_advance(d, INFINITY, c, UINT64_MAX);
			dsmc_totals(d, &sm);
			double rel = fabs(sm.kinetic_energy - e0) / e0, dp = hypot(sm.momentum[0] - p0[0], sm.momentum[1] - p0[1]);
			worst = rel > worst ? rel : worst;
			pworst = dp > pworst ? dp : pworst;
			if (k >= 20)
				ratio[k - 20] = tspec(&sm, 1, 2) / tspec(&sm, 0, 2);
		}
	}
	double m, se;
	mean_se(ratio, 40, &m, &se);
	/* momentum scale: sqrt(M E) ~ sqrt(1400 * 1600) = 1.5e3; 1e-10 of it */
	ok(d && worst < 1e-10 && pworst < 1.5e-7, "elastic mixture: energy conserved to %.2g (< 1e-10), momentum to %.2g "
	   "(< 1.5e-7)", worst, pworst);
	ok(d && ratio0 > 2.5 && fabs(m - 1) < 5 * se && se < 0.03,
	   "elastic mixture (m 1 : 4): T_l / T_s from %.3f to %.4f +- %.4f: 1 within 5 SE (equipartition)", ratio0, m, se);
	dsmc_destroy(d);
}

/* Temperatures of species 0 and 1 at the times tt[] over NR replicas of
 * the scene with method ed (m = 0) or dsmc (m = 1); T overall. */
enum { NR = 16, NT = 3 };
static int run_mixture(const char *scene_fmt, const char *method, const double *tt, double t[NT][NR], double t0[NT][NR],
                       double t1[NT][NR])
{
	int good = 1;
	for (int r = 0; r < NR; r++) {
		char json[2048], err[512] = "";
		snprintf(json, sizeof json, scene_fmt, method, 100 + r);
		scene_t sc;
		int rc;
		if (scene_parse(json, strlen(json), &sc, err, sizeof err) != SCENE_OK) {
			diag("%s", err);
			return 0;
		}
		if (!strcmp(method, "ed")) {
			ed_t *e = ed_create(&sc, &rc, err, sizeof err);
			for (int k = 0; e && k < NT; k++) {
				ed_sample_t sm;
				ed_advance(e, tt[k], UINT64_MAX, UINT64_MAX);
				ed_totals(e, &sm);
				t[k][r] = sm.kinetic_energy / sc.count;
				t0[k][r] = sm.species_kinetic_energy[0] / sm.species_count[0];
				t1[k][r] = sm.species_kinetic_energy[1] / sm.species_count[1];
			}
			good &= e != NULL;
			ed_destroy(e);
		} else {
			dsmc_t *d = dsmc_create(&sc, 0, &rc, err, sizeof err);
			for (int k = 0; d && k < NT; k++) {
				dsmc_sample_t sm;
				dsmc_advance(d, tt[k], UINT64_MAX, UINT64_MAX);
				dsmc_totals(d, &sm);
				t[k][r] = sm.kinetic_energy / sc.count;
				t0[k][r] = tspec(&sm, 0, 2);
				t1[k][r] = tspec(&sm, 1, 2);
			}
			good &= d != NULL;
			dsmc_destroy(d);
		}
		if (err[0])
			diag("%s", err);
	}
	return good;
}

/* An inelastic binary mixture in homogeneous cooling (600 disks m = 1,
 * r = 0.5; 200 disks m = 4, r = 1; e_ss = e_ll = 0.9, e_sl = 0.8; nu =
 * 0.01, dilute: ed's contact value ~1.01, matched by dsmc's Enskog
 * factor): temperature and temperature ratio T_l / T_s at t = 100, 200,
 * 400 (T falls to ~0.35) over 16 replicas of each method: equal within 5
 * combined standard errors, and the gas must have cooled by more than 10
 * of them. */
static void test_cooling_vs_ed(void)
{
	const char *fmt = "{\"method\":\"%s\",\"dimensions\":2,\"particles\":{\"species\":[{\"name\":\"s\",\"count\":600,"
	                  "\"radius\":0.5,\"mass\":1},{\"name\":\"l\",\"count\":200,\"radius\":1.0,\"mass\":4}],"
	                  "\"volume_fraction\":0.01,\"initial\":{\"positions\":\"random\",\"temperature\":1}},"
	                  "\"collisions\":{\"restitution\":0.9,\"restitution_pairs\":[{\"a\":\"s\",\"b\":\"l\","
	                  "\"restitution\":0.8}]},\"run\":{\"until\":{\"time\":400},\"seed\":%d}}";
	char dfmt[2048];
	/* dsmc: the Enskog factor at the total volume fraction */
	snprintf(dfmt, sizeof dfmt, "%.*s,\"dsmc\":{\"correction\":\"enskog\"}}", (int)strlen(fmt) - 1, fmt);
	static double te[NT][NR], te0[NT][NR], te1[NT][NR], tm[NT][NR], tm0[NT][NR], tm1[NT][NR];
	const double tt[NT] = {100, 200, 400};
	int good = run_mixture(fmt, "ed", tt, te, te0, te1) & run_mixture(dfmt, "dsmc", tt, tm, tm0, tm1);
	for (int k = 0; k < NT; k++) {
		double re[NR], rm[NR];
		for (int r = 0; r < NR; r++)
			re[r] = te1[k][r] / te0[k][r], rm[r] = tm1[k][r] / tm0[k][r];
		double me, se, mm, sm, mre, sre, mrm, srm;
		mean_se(te[k], NR, &me, &se);
		mean_se(tm[k], NR, &mm, &sm);
		mean_se(re, NR, &mre, &sre);
		mean_se(rm, NR, &mrm, &srm);
		double c = sqrt(se * se + sm * sm), cr = sqrt(sre * sre + srm * srm);
		ok(good && fabs(me - mm) < 5 * c && 1 - mm > 10 * c && fabs(mre - mrm) < 5 * cr,
		   "inelastic mixture, t = %g: T ed %.4f +- %.4f, dsmc %.4f +- %.4f; T_l/T_s ed %.4f +- %.4f, dsmc %.4f +- "
		   "%.4f: equal within 5 combined SE", tt[k], me, se, mm, sm, mre, sre, mrm, srm);
	}
}

/* Per-pair restitution: two species alike in mass and radius (500 disks
 * each, r = 0.5, m = 1, nu = 0.05), elastic among themselves, e = 0.5
 * between them. Half the collisions are between the species (2 x_a x_b),
 * so the gas cools as a one-species gas with 1 - e'^2 = (1 - 0.5^2) / 2,
 * e' = 0.790569, and both species keep one temperature. T at t = 20, 40,
 * 80 over 16 replicas of each: equal within 5 combined SE, the species
 * within 5 SE of each other. (A rule that took e_aa or e_bb for the pair
 * would not cool at all; one that took 0.5 for every pair would cool
 * twice as fast.) */
static void test_pair_restitution(void)
{
	const char *mix = "{\"method\":\"%s\",\"dimensions\":2,\"particles\":{\"species\":[{\"name\":\"a\",\"count\":500,"
	                  "\"radius\":0.5,\"mass\":1},{\"name\":\"b\",\"count\":500,\"radius\":0.5,\"mass\":1}],"
	                  "\"volume_fraction\":0.05,\"initial\":{\"positions\":\"random\",\"temperature\":1}},"
	                  "\"collisions\":{\"restitution\":1,\"restitution_pairs\":[{\"a\":\"a\",\"b\":\"b\","
	                  "\"restitution\":0.5}]},\"run\":{\"until\":{\"time\":100},\"seed\":%d}}";
	const char *one = "{\"method\":\"%s\",\"dimensions\":2,\"particles\":{\"count\":1000,\"radius\":0.5,\"mass\":1,"
	                  "\"volume_fraction\":0.05,\"initial\":{\"positions\":\"random\",\"temperature\":1}},"
	                  "\"collisions\":{\"restitution\":0.7905694150420949},\"run\":{\"until\":{\"time\":100},\"seed\":%d}}";
	static double tm[NT][NR], ta[NT][NR], tb[NT][NR], to[NT][NR];
	const double tt[NT] = {20, 40, 80};
	int good = run_mixture(mix, "dsmc", tt, tm, ta, tb);
	/* the one-species gas */
	for (int r = 0; r < NR && good; r++) {
		char json[1024];
		snprintf(json, sizeof json, one, "dsmc", 100 + r);
		scene_t sc;
		dsmc_t *d = mc_make(json, &sc, 0);
		for (int k = 0; d && k < NT; k++) {
			dsmc_sample_t sm;
			dsmc_advance(d, tt[k], UINT64_MAX, UINT64_MAX);
			dsmc_totals(d, &sm);
			to[k][r] = sm.kinetic_energy / sc.count;
		}
		good &= d != NULL;
		dsmc_destroy(d);
	}
	for (int k = 0; k < NT; k++) {
		double mm, sm, mo, so, d[NR], md, sd;
		mean_se(tm[k], NR, &mm, &sm);
		mean_se(to[k], NR, &mo, &so);
		for (int r = 0; r < NR; r++)
			d[r] = ta[k][r] - tb[k][r];
		mean_se(d, NR, &md, &sd);
		double c = sqrt(sm * sm + so * so);
		ok(good && fabs(mm - mo) < 5 * c && 1 - mm > 10 * c && fabs(md) < 5 * sd,
		   "only the pair (a, b) inelastic (e = 0.5), t = %g: T %.4f +- %.4f, one species with e' = 0.7906: %.4f +- "
		   "%.4f; T_a - T_b = %.4f +- %.4f", tt[k], mm, sm, mo, so, md, sd);
	}
}

/* A mixture run restored from its checkpoint fields after every few steps
 * is bit-for-bit the uninterrupted one (species and radii come from the
 * scene: no new field). Polydisperse species with the CBA correction (its
 * offsets use each pair's own diameter); bounded: the same with walls of
 * the fixed kinds, gravity and obstacles (no new state either). */
static void test_restore(const char *json, const char *label)
{
	scene_t sc;
	char err[512] = "";
	dsmc_t *a = mc_make(json, &sc, 0), *b = mc_make(json, &sc, 0);
	int same_samples = 1;
	for (int it = 0; a && b && it < 30; it++) {
		dsmc_advance(a, INFINITY, UINT64_MAX, 1 + it % 4);
		dsmc_advance(b, INFINITY, UINT64_MAX, 1 + it % 4);
		dsmc_sample_t x, y;
		dsmc_sample(a, &x);
		dsmc_sample(b, &y);
		same_samples &= memcmp(&x, &y, sizeof x) == 0;
		b = mc_reload(b, &sc, err, sizeof err);
	}
	int same = 0;
	dsmc_sample_t x = {0};
	if (a && b) {
		size_t bytes = sc.count * (size_t)sc.dim * sizeof(double);
		double *pa = malloc(bytes), *pb = malloc(bytes);
		dsmc_state(a, pa, NULL);
		dsmc_state(b, pb, NULL);
		dsmc_sample(a, &x);
		same = !memcmp(pa, pb, bytes);
		free(pa), free(pb);
	}
	/* hsmc: the full-cell rules must have acted (moves rejected, cell collisions) */
	int hs = sc.method == SCENE_METHOD_HSMC;
	ok(same && same_samples && x.n_species == 2 && dsmc_collisions(a) > 1000 &&
	   (!hs || (x.rejected_moves > 0 && x.cell_collisions > 0)),
	   "%s: 30 restores bit-identical (%llu collisions, %llu wall hits, %llu obstacle hits, %llu left, %llu "
	   "rejected moves, %llu cell collisions) %s", label,
	   a ? (unsigned long long)dsmc_collisions(a) : 0ULL, (unsigned long long)x.wall_collisions,
	   (unsigned long long)x.obstacle_collisions, (unsigned long long)(sc.count - x.particles),
	   (unsigned long long)x.rejected_moves, (unsigned long long)x.cell_collisions, err);
	dsmc_destroy(a);
	dsmc_destroy(b);
}

/* dsmc and hsmc take mixtures with walls of every kind, gravity and
 * obstacles, and the local contact value (chi_ij per cell). */
static void test_refusals(void)
{
	static const char *const extra[] = {
		"\"boundaries\":{\"y\":{\"type\":\"walls\",\"lower\":{\"type\":\"specular\"},\"upper\":{\"type\":\"specular\"}}}",
		"\"gravity\":[0,-1],\"boundaries\":{\"y\":{\"type\":\"walls\",\"lower\":{\"type\":\"specular\"},"
		"\"upper\":{\"type\":\"specular\"}}}",
		"\"obstacles\":[{\"type\":\"slip\",\"center\":[20,20],\"radius\":3}]",
	};
	static const char *const walls[] = {
		"\"gravity\":[0,-1],\"boundaries\":{\"y\":{\"type\":\"walls\",\"lower\":{\"type\":\"vibrating\",\"amplitude\":1,"
		"\"frequency\":0.1},\"upper\":{\"type\":\"specular\"}}}",
		"\"boundaries\":{\"x\":{\"type\":\"walls\",\"lower\":{\"type\":\"specular\"},\"upper\":{\"type\":\"open\"}}}",
	};
	const char *fmt = "{\"method\":\"%s\",\"dimensions\":2,\"particles\":{\"species\":[{\"count\":50,\"mass\":1,"
	                  "\"radius\":0.5},{\"count\":50,\"radius\":1,\"mass\":1}],\"box\":[40,40]},\"run\":{\"until\":{\"time\":1}},%s}";
	for (size_t k = 0; k < sizeof extra / sizeof extra[0]; k++) {
		char json[1024], err[512] = "";
		snprintf(json, sizeof json, fmt, "hsmc", extra[k]);
		scene_t sc;
		int rc = scene_parse(json, strlen(json), &sc, err, sizeof err);
		ok(rc == SCENE_OK, "hsmc mixture accepted with %.30s...: %s", extra[k], rc == SCENE_OK ? "ok" : err);
		snprintf(json, sizeof json, fmt, "dsmc", extra[k]);
		rc = scene_parse(json, strlen(json), &sc, err, sizeof err);
		ok(rc == SCENE_OK, "dsmc mixture accepted with %.30s...: %s", extra[k], rc == SCENE_OK ? "ok" : err);
	}
	for (size_t k = 0; k < sizeof walls / sizeof walls[0]; k++) {
		char json[1024], err[512] = "";
		snprintf(json, sizeof json, fmt, "dsmc", walls[k]);
		scene_t sc;
		int rc = scene_parse(json, strlen(json), &sc, err, sizeof err);
		ok(rc == SCENE_OK, "dsmc mixture accepted with %.50s...: %s", walls[k], rc == SCENE_OK ? "ok" : err);
		snprintf(json, sizeof json, fmt, "hsmc", walls[k]);
		rc = scene_parse(json, strlen(json), &sc, err, sizeof err);
		ok(rc == SCENE_OK, "hsmc mixture accepted with %.50s...: %s", walls[k], rc == SCENE_OK ? "ok" : err);
	}
	/* the local contact value: each pair's chi_ij per cell (with walls,
	 * gravity and obstacles too) */
	static const char *const local[][2] = {
		{"dsmc", "\"dsmc\":{\"correction\":\"enskog\",\"contact_value\":\"local\"},\"gravity\":[0,-1],"
		         "\"boundaries\":{\"y\":{\"type\":\"walls\",\"lower\":{\"type\":\"specular\"},\"upper\":{\"type\":\"specular\"}}}"},
		{"hsmc", "\"hsmc\":{\"contact_value\":\"local\"}"},
		{"hsmc", "\"hsmc\":{\"contact_value\":\"local\"},\"obstacles\":[{\"type\":\"slip\",\"center\":[20,20],\"radius\":3}]"},
	};
	for (size_t k = 0; k < sizeof local / sizeof local[0]; k++) {
		char json[1024], err[512] = "";
		snprintf(json, sizeof json, fmt, local[k][0], local[k][1]);
		scene_t sc;
		int rc = scene_parse(json, strlen(json), &sc, err, sizeof err);
		ok(rc == SCENE_OK, "%s mixture with a local contact value accepted (%.40s...): %s", local[k][0],
		   local[k][1] + 8, rc == SCENE_OK ? "ok" : err);
	}
}

/* Mean height of an ideal gas between h = 0 and H' in gravity with scale
 * height l: l - H' / (exp(H' / l) - 1). */
static double baro_mean(double l, double H)
{
	return l - H / expm1(H / l);
}

/* An elastic binary mixture (2000 disks m = 1, r = 0.5; 2000 disks m = 4,
 * r = 0.25) in gravity g = 0.01 between a specular floor and lid settles,
 * species by species, into the barometric profile n_s(h) ~ exp(-m_s g h / T)
 * (h the height of a centre above its own lowest plane, one own radius
 * above the floor, 0 <= h <= H'_s = H - 2 r_s): DSMC without correction is
 * an ideal gas of points, so each species' profile is exact, with its own
 * scale height l_s = T / (m_s g) (~200 and ~50: m g H' / T ~ 1 and ~4). T
 * is the common temperature (time average of 2 E_kin / (D N): the total
 * energy is conserved, T settles near 2, above the initial 1, as the gas
 * sinks).
 * Mean heights are averaged over 8 blocks of 25 samples in the second half
 * of the run (t = 3000..6000, ~10 sound crossings of the box and ~200 mean
 * free times per block); tolerance: 4 standard errors of the block means
 * plus the effect of T's block SE through d<h>/dT. Equipartition: T of the
 * two species agree within 4 combined SE. */
static void test_barometric(void)
{
	const char *json = "{\"method\":\"dsmc\",\"dimensions\":2,\"particles\":{\"species\":[{\"name\":\"a\",\"count\":2000,"
	                   "\"radius\":0.5,\"mass\":1},{\"name\":\"b\",\"count\":2000,\"radius\":0.25,\"mass\":4}],"
	                   "\"box\":[785.4,200],\"initial\":{\"positions\":\"random\",\"temperature\":1}},"
	                   "\"boundaries\":{\"y\":{\"type\":\"walls\",\"lower\":{\"type\":\"specular\"},"
	                   "\"upper\":{\"type\":\"specular\"}}},"
	                   "\"gravity\":[0,-0.01],\"run\":{\"seed\":11,\"until\":{\"time\":6000}}}";
	scene_t sc;
	dsmc_t *d = mc_make(json, &sc, 0);
	if (!d) {
		ok(0, "barometric mixture scene");
		return;
	}
	enum { N = 4000, NS = 2000, B = 8, PER = 25 };
	const double g = 0.01, m[2] = {1, 4}, r[2] = {0.5, 0.25}, Hb = 200;
	double hb[2][B] = {{0}}, tb[B] = {0}, ts[2][B] = {{0}};
	double *pos = malloc(N * 2 * sizeof(double));
	dsmc_advance(d, 3000, UINT64_MAX, UINT64_MAX);
	for (int b = 0; b < B; b++)
		for (int k = 0; k < PER; k++) {
			dsmc_advance(d, 3000 + (b * PER + k + 1) * 3000.0 / (B * PER), UINT64_MAX, UINT64_MAX);
			dsmc_state(d, pos, NULL);
			dsmc_sample_t sm;
			dsmc_totals(d, &sm);
			for (int i = 0; i < N; i++) {
				const int s = i >= NS;   /* species are blocks in scene order */
				hb[s][b] += (pos[2 * i + 1] - r[s]) / NS / PER;
			}
			tb[b] += 2 * sm.kinetic_energy / (2.0 * N) / PER;
			for (int s = 0; s < 2; s++)
				ts[s][b] += tspec(&sm, s, 2) / PER;
		}
	free(pos);
	double T, tse, ta, tase, tbb, tbse;
	mean_se(tb, B, &T, &tse);
	mean_se(ts[0], B, &ta, &tase);
	mean_se(ts[1], B, &tbb, &tbse);
	for (int s = 0; s < 2; s++) {
		double hm, hse;
		mean_se(hb[s], B, &hm, &hse);
		const double H = Hb - 2 * r[s], l = T / (m[s] * g), theory = baro_mean(l, H);
		const double dl = 1e-6 * l, dth = (baro_mean(l + dl, H) - theory) / dl;   /* d<h>/dl */
		const double tol = 4 * hse + fabs(dth) * tse / (m[s] * g);
		/* and the profile far from uniform: the uniform gas's mean H' / 2 is more than 5 tolerances off */
		ok(fabs(hm - theory) < tol && fabs(theory - 0.5 * H) > 5 * tol,
		   "barometric mixture, species %d (m = %g): mean height %.4g, theory %.4g at T = %.4g (m g H' / T = %.3g), "
		   "tolerance %.3g", s, m[s], hm, theory, T, H / l, tol);
	}
	ok(fabs(ta - tbb) < 4 * sqrt(tase * tase + tbse * tbse),
	   "barometric mixture: equipartition T_a %.4f, T_b %.4f (4 SE = %.3g)", ta, tbb,
	   4 * sqrt(tase * tase + tbse * tbse));
	dsmc_destroy(d);
}

/* Kinetic plus potential energy now. */
/* An elastic polydisperse mixture (masses 1 and 4, radii 0.5 and
 * 0.3..0.8) with elastic walls (specular, rough, moving with beta = 1 and
 * u = 0, thermal with accommodation 0), an elastic slip obstacle and
 * gravity: every part of a step conserves kinetic + potential energy (each
 * particle's own mass in E_kin and E_pot) exactly in exact arithmetic, so
 * the drift is rounding: 1e-10 relative is ~10^5 ulps, far below one
 * mishandled hit (~1/N = 5e-4 relative), as in tests/mc_walls_test.c. */
static void test_energy(int dim)
{
	char json[2048];
	const char *grav = dim == 2 ? "[0.3, -1]" : "[0.2, -1, 0.4]";
	const char *z = dim == 2 ? "" : ",\"z\":{\"type\":\"walls\",\"lower\":{\"type\":\"moving\",\"velocity\":[0,0,0]},"
	                               "\"upper\":{\"type\":\"thermal\",\"temperature\":3,\"accommodation\":0}}";
	snprintf(json, sizeof json,
	         "{\"method\":\"dsmc\",\"dimensions\":%d,\"particles\":{\"species\":[{\"count\":1000,\"radius\":0.5,\"mass\":1},"
	         "{\"count\":1000,\"radius_range\":[0.3,0.8],\"mass\":4}],\"box\":%s,"
	         "\"initial\":{\"positions\":\"random\",\"temperature\":1}},"
	         "\"boundaries\":{\"x\":{\"type\":\"walls\",\"lower\":{\"type\":\"rough\",\"probability\":0.5},"
	         "\"upper\":{\"type\":\"specular\"}},\"y\":{\"type\":\"walls\",\"lower\":{\"type\":\"specular\"},"
	         "\"upper\":{\"type\":\"rough\",\"probability\":1}}%s},\"obstacles\":[{\"type\":\"slip\",\"center\":%s,"
	         "\"radius\":%s}],\"gravity\":%s,\"run\":{\"seed\":3,\"until\":{\"time\":100}}}",
	         dim, dim == 2 ? "[150,150]" : "[40,40,40]", z, dim == 2 ? "[75,75]" : "[20,20,20]", dim == 2 ? "10" : "6",
	         grav);
	scene_t sc;
	dsmc_t *d = mc_make(json, &sc, 0);
	dsmc_sample_t sm;
	double worst = mc_energy_drift(d, 100, 5, &sm);
	ok(d && worst < 1e-10 && sm.wall_collisions > 1000 && sm.collisions > 10000 && sm.obstacle_collisions > 50 &&
	   sm.rested == 0,
	   "mixture %dD, elastic walls, obstacle and gravity: E_kin + E_pot conserved to %.2g (< 1e-10) over %llu steps, "
	   "%llu wall hits, %llu obstacle hits, %llu collisions", dim, worst, (unsigned long long)sm.steps,
	   (unsigned long long)sm.wall_collisions, (unsigned long long)sm.obstacle_collisions,
	   (unsigned long long)sm.collisions);
	dsmc_destroy(d);
}

/* Thermal walls (T_w = 2, full accommodation) at both ends of y hold an
 * elastic mixture (300 disks m = 1, 300 disks m = 4) started at T = 0.5:
 * the Maxwellian at T_w is the stationary state, so each species must end
 * at T_w (a wall that re-emitted with another mass than the particle's own,
 * e.g. the mean mass 2.5, would put the light species at 2.5 T_w / 1 ... far
 * off). Both species relax within t ~ 250 (block means of a long run);
 * after t = 500, 16 blocks of 25 snapshots 10 time units apart (blocks of
 * 250 time units, several relaxation times: nearly independent block
 * means); tolerance 4 SE of the block means. */
static void test_thermal(void)
{
	const char *json = "{\"method\":\"dsmc\",\"dimensions\":2,\"particles\":{\"species\":[{\"count\":300,\"radius\":0.5,"
	                   "\"mass\":1},{\"count\":300,\"radius\":1,\"mass\":4}],\"box\":[60,60],"
	                   "\"initial\":{\"positions\":\"random\",\"temperature\":0.5}},"
	                   "\"boundaries\":{\"y\":{\"type\":\"walls\",\"lower\":{\"type\":\"thermal\",\"temperature\":2},"
	                   "\"upper\":{\"type\":\"thermal\",\"temperature\":2}}},\"run\":{\"seed\":21,\"until\":{\"time\":4500}}}";
	scene_t sc;
	dsmc_t *d = mc_make(json, &sc, 0);
	enum { B = 16, PER = 25 };
	double tb[2][B] = {{0}}, t0[2] = {NAN, NAN};
	dsmc_sample_t sm = {0};
	if (d) {
		dsmc_totals(d, &sm);
		t0[0] = tspec(&sm, 0, 2), t0[1] = tspec(&sm, 1, 2);
		dsmc_advance(d, 500, UINT64_MAX, UINT64_MAX);
		for (int b = 0; b < B; b++)
			for (int k = 0; k < PER; k++) {
				dsmc_advance(d, 500 + (b * PER + k + 1) * 10.0, UINT64_MAX, UINT64_MAX);
				dsmc_totals(d, &sm);
				for (int s = 0; s < 2; s++)
					tb[s][b] += tspec(&sm, s, 2) / PER;
			}
	}
	for (int s = 0; s < 2; s++) {
		double m, se;
		mean_se(tb[s], B, &m, &se);
		ok(d && fabs(m - 2) < 4 * se && se < 0.05 && fabs(t0[s] - 2) > 1,
		   "thermal walls T_w = 2, species %d (m = %d): T from %.3f to %.4f +- %.4f (T_w within 4 SE; %llu wall hits)", s,
		   s ? 4 : 1, t0[s], m, se, (unsigned long long)sm.wall_collisions);
	}
	dsmc_destroy(d);
}

/* Walls and obstacles with a mixture (radii 0.3 and 1.2): a centre never
 * ends a step closer to a wall or an obstacle than its own contact distance
 * (own radius; obstacle radius + own radius; 1e-9 for rounding), and the
 * small particles do come closer than the large radius would allow (the
 * contact is at each particle's own radius, not the largest). Gravity, a
 * thermal lid, slip and no_slip obstacles, CBA offsets; 300 snapshots. */
static void test_contact(void)
{
	const char *json = "{\"method\":\"dsmc\",\"dimensions\":2,\"particles\":{\"species\":[{\"count\":400,\"radius\":0.3,"
	                   "\"mass\":1},{\"count\":200,\"radius\":1.2,\"mass\":2}],\"box\":[60,40],"
	                   "\"initial\":{\"positions\":\"random\",\"temperature\":1}},"
	                   "\"boundaries\":{\"y\":{\"type\":\"walls\",\"lower\":{\"type\":\"specular\"},"
	                   "\"upper\":{\"type\":\"thermal\",\"temperature\":1}}},\"gravity\":[0,-0.05],"
	                   "\"obstacles\":[{\"type\":\"slip\",\"center\":[20,20],\"radius\":5},{\"type\":\"no_slip\","
	                   "\"center\":[45,20],\"radius\":3,\"temperature\":1}],\"dsmc\":{\"correction\":\"cba\"},"
	                   "\"run\":{\"seed\":4,\"until\":{\"time\":600}}}";
	scene_t sc;
	dsmc_t *d = mc_make(json, &sc, 0);
	enum { N = 600, NS = 400 };
	const double r[2] = {0.3, 1.2}, oc[2][2] = {{20, 20}, {45, 20}}, orad[2] = {5, 3};
	double worst = INFINITY, small_obst = INFINITY, small_wall = INFINITY;
	double *pos = malloc(N * 2 * sizeof(double));
	for (int k = 0; d && k < 300; k++) {
		dsmc_advance(d, 2.0 * (k + 1), UINT64_MAX, UINT64_MAX);
		dsmc_state(d, pos, NULL);
		for (int i = 0; i < N; i++) {
			const int s = i >= NS;
			const double x = pos[2 * i], y = pos[2 * i + 1];
			double gap = fmin(y - r[s], 40 - r[s] - y);
			if (!s)
				small_wall = fmin(small_wall, y);
			for (int o = 0; o < 2; o++) {
				double dx = x - oc[o][0], dy = y - oc[o][1];
				dx -= 60 * nearbyint(dx / 60);
				const double og = hypot(dx, dy) - (orad[o] + r[s]);
				gap = fmin(gap, og);
				if (!s)
					small_obst = fmin(small_obst, hypot(dx, dy) - orad[o]);
			}
			worst = fmin(worst, gap);
		}
	}
	free(pos);
	dsmc_sample_t sm = {0};
	if (d)
		dsmc_totals(d, &sm);
	ok(d && worst > -1e-9 && small_obst < 1.2 && small_wall < 1.2 && sm.obstacle_collisions > 1000,
	   "mixture with walls and obstacles: smallest gap to a contact %.3g (> -1e-9); the small species' centres come "
	   "to %.3g of an obstacle and %.3g of the floor (< the large radius 1.2); %llu obstacle hits", worst, small_obst,
	   small_wall, (unsigned long long)sm.obstacle_collisions);
	dsmc_destroy(d);
}

/* Effusion of a mixture through an open lid (as tests/mc_walls_test.c for
 * one species): a dilute elastic gas of two species (25000 disks m = 1,
 * r = 0.01; 25000 disks m = 4, r = 0.02), uniform, Maxwellian at T = 1, box
 * 400 x 200, no gravity. In tau = 2 (short against the crossing time) the
 * number of species s that leave is N_s tau sqrt(T / (2 pi m_s)) /
 * (L_y - 2 r_s) (the Maxwellian flux through its own contact plane; mean
 * free path ~700 >> v tau). Counts over 10 seeds (~1000 and ~500
 * expected) are Poisson: within 4 sqrt(expected) each. Consistency: the
 * rows that left are NaN, and the species counts of the particles present
 * plus those rows make N_s. */
static void test_effusion(void)
{
	enum { R = 10, NS = 25000 };
	const double m[2] = {1, 4}, r[2] = {0.01, 0.02};
	double out[2] = {0, 0}, expect[2] = {0, 0};
	uint64_t bad = 0;
	double *pos = malloc(2 * NS * 2 * sizeof(double));
	for (int q = 0; q < R; q++) {
		char json[1024];
		snprintf(json, sizeof json,
		         "{\"method\":\"dsmc\",\"dimensions\":2,\"particles\":{\"species\":[{\"count\":%d,\"radius\":0.01,"
		         "\"mass\":1},{\"count\":%d,\"radius\":0.02,\"mass\":4}],\"box\":[400,200],"
		         "\"initial\":{\"positions\":\"random\",\"temperature\":1}},\"boundaries\":{\"y\":{\"type\":\"walls\","
		         "\"lower\":{\"type\":\"specular\"},\"upper\":{\"type\":\"open\"}}},\"run\":{\"seed\":%d,"
		         "\"until\":{\"time\":2}}}", NS, NS, 70 + q);
		scene_t sc;
		dsmc_t *d = mc_make(json, &sc, 0);
		if (!d) {
			bad++;
			continue;
		}
		dsmc_advance(d, 2.0, UINT64_MAX, UINT64_MAX);
		dsmc_sample_t sm;
		dsmc_totals(d, &sm);
		dsmc_state(d, pos, NULL);
		uint64_t gone[2] = {0, 0};
		for (int i = 0; i < 2 * NS; i++) {
			const int s = i >= NS;
			if (isnan(pos[2 * i + 1]))
				gone[s]++;
			else if (!(pos[2 * i + 1] >= r[s] && pos[2 * i + 1] <= 200 - r[s]))
				bad++;
		}
		for (int s = 0; s < 2; s++) {
			out[s] += (double)gone[s];
			expect[s] += NS * 2.0 * sqrt(1.0 / (2 * 3.14159265358979323846 * m[s])) / (200 - 2 * r[s]);
			bad += sm.species_count[s] + gone[s] != NS;
		}
		bad += gone[0] + gone[1] != sm.wall_outflow[3];
		dsmc_destroy(d);
	}
	free(pos);
	for (int s = 0; s < 2; s++)
		ok(fabs(out[s] - expect[s]) < 4 * sqrt(expect[s]) && bad == 0,
		   "mixture effusion through an open lid, species %d (m = %g): %.0f left in tau = 2 over %d runs, theory "
		   "N_s tau sqrt(T/2 pi m_s)/(L - 2r_s) = %.1f (4 sqrt = %.1f); %llu inconsistencies", s, m[s], out[s], R,
		   expect[s], 4 * sqrt(expect[s]), (unsigned long long)bad);
}

/* A vibrating floor (A = 1, f = 0.2, r_w = 0.9) under gravity with a
 * mixture (radii 0.3 and 1.2): at every snapshot (steps land on it) each
 * centre is at least its own radius above the floor where the floor is then
 * (scene coordinates: A sin(2 pi f t); 1e-9 for rounding), the small
 * species gets closer than the large radius (its own contact), and the bed
 * is driven (energy far above the T = 0.1 start). */
static void test_vibrating(void)
{
	const char *json = "{\"method\":\"dsmc\",\"dimensions\":2,\"particles\":{\"species\":[{\"count\":400,\"radius\":0.3,"
	                   "\"mass\":1},{\"count\":200,\"radius\":1.2,\"mass\":2}],\"box\":[60,60],"
	                   "\"initial\":{\"positions\":\"random\",\"temperature\":0.1}},"
	                   "\"collisions\":{\"restitution\":0.95},"
	                   "\"boundaries\":{\"y\":{\"type\":\"walls\",\"lower\":{\"type\":\"vibrating\",\"amplitude\":1,"
	                   "\"frequency\":0.2,\"restitution\":0.9},\"upper\":{\"type\":\"specular\"}}},\"gravity\":[0,-0.2],"
	                   "\"run\":{\"seed\":5,\"until\":{\"time\":300}}}";
	scene_t sc;
	dsmc_t *d = mc_make(json, &sc, 0);
	enum { N = 600, NS = 400 };
	const double r[2] = {0.3, 1.2}, A = 1, om = 2 * 3.14159265358979323846 * 0.2;
	double worst = INFINITY, small = INFINITY, e0 = NAN;
	double *pos = malloc(N * 2 * sizeof(double));
	dsmc_sample_t sm = {0};
	if (d) {
		dsmc_totals(d, &sm);
		e0 = sm.kinetic_energy;
	}
	for (int k = 0; d && k < 600; k++) {
		const double t = 0.5 * (k + 1), floor = A * sin(om * t);
		dsmc_advance(d, t, UINT64_MAX, UINT64_MAX);
		dsmc_state(d, pos, NULL);
		for (int i = 0; i < N; i++) {
			const int s = i >= NS;
			const double h = pos[2 * i + 1] - floor;
			worst = fmin(worst, fmin(h - r[s], 60 - r[s] - pos[2 * i + 1]));
			if (!s)
				small = fmin(small, h);
		}
	}
	free(pos);
	if (d)
		dsmc_totals(d, &sm);
	ok(d && worst > -1e-9 && small < 1.2 && sm.kinetic_energy > 10 * e0 && sm.wall_collisions > 1000,
	   "mixture on a vibrating floor: smallest gap to its own contact plane %.3g (> -1e-9); the small species "
	   "reaches %.3g of the floor (< 1.2); E_kin %.4g from %.4g; %llu wall hits", worst, small, sm.kinetic_energy, e0,
	   (unsigned long long)sm.wall_collisions);
	dsmc_destroy(d);
}

int main(void)
{
	test_refusals();
	test_equipartition();
	test_restore("{\"method\":\"dsmc\",\"dimensions\":3,\"particles\":{\"species\":[{\"name\":\"p\",\"count\":800,"
	             "\"radius_range\":[0.3,0.6],\"mass\":1},{\"name\":\"q\",\"count\":400,\"radius\":0.8,\"mass\":3}],"
	             "\"volume_fraction\":0.1,\"initial\":{\"positions\":\"random\",\"temperature\":1}},"
	             "\"collisions\":{\"restitution\":0.9},\"dsmc\":{\"correction\":\"cba\"},"
	             "\"run\":{\"seed\":8,\"until\":{\"time\":100}}}", "polydisperse mixture with CBA");
	test_restore("{\"method\":\"dsmc\",\"dimensions\":3,\"particles\":{\"species\":[{\"name\":\"p\",\"count\":800,"
	             "\"radius_range\":[0.3,0.6],\"mass\":1},{\"name\":\"q\",\"count\":400,\"radius\":0.8,\"mass\":3}],"
	             "\"box\":[20,20,20],\"initial\":{\"positions\":\"random\",\"temperature\":1}},"
	             "\"collisions\":{\"restitution\":0.9},\"dsmc\":{\"correction\":\"cba\"},"
	             "\"boundaries\":{\"z\":{\"type\":\"walls\",\"lower\":{\"type\":\"thermal\",\"temperature\":1},"
	             "\"upper\":{\"type\":\"rough\",\"probability\":0.5}},\"x\":{\"type\":\"walls\",\"lower\":{\"type\":"
	             "\"moving\",\"velocity\":[0,0.5,0]},\"upper\":{\"type\":\"specular\"}}},\"gravity\":[0,0,-0.5],"
	             "\"obstacles\":[{\"type\":\"no_slip\",\"center\":[10,10,8],\"radius\":3,\"temperature\":1}],"
	             "\"run\":{\"seed\":9,\"until\":{\"time\":100}}}", "bounded polydisperse mixture with CBA");
	test_pair_restitution();
	test_cooling_vs_ed();
	test_energy(2);
	test_energy(3);
	test_thermal();
	test_contact();
	test_effusion();
	test_vibrating();
	test_restore("{\"method\":\"dsmc\",\"dimensions\":2,\"particles\":{\"species\":[{\"count\":600,\"radius\":0.4,"
	             "\"mass\":1},{\"count\":300,\"radius_range\":[0.6,1],\"mass\":4}],\"box\":[40,50],"
	             "\"initial\":{\"positions\":\"random\",\"temperature\":1}},\"collisions\":{\"restitution\":0.9},"
	             "\"boundaries\":{\"y\":{\"type\":\"walls\",\"lower\":{\"type\":\"vibrating\",\"amplitude\":0.5,"
	             "\"frequency\":0.3,\"restitution\":0.8},\"upper\":{\"type\":\"open\"}},\"x\":{\"type\":\"walls\","
	             "\"lower\":{\"type\":\"thermal\",\"temperature\":1},\"upper\":{\"type\":\"specular\"}}},"
	             "\"gravity\":[0,-0.05],\"dsmc\":{\"correction\":\"cba\"},\"run\":{\"seed\":10,\"until\":{\"time\":100}}}",
	             "mixture with a vibrating floor and an open lid");
	test_barometric();
	/* hsmc mixtures: no new state either (the cells' particle volumes are a function of the records) */
	test_restore("{\"method\":\"hsmc\",\"dimensions\":2,\"particles\":{\"species\":[{\"name\":\"s\",\"count\":1500,"
	             "\"radius\":0.5,\"mass\":1},{\"name\":\"l\",\"count\":300,\"radius_range\":[0.8,1.2],\"mass\":4}],"
	             "\"volume_fraction\":0.5,\"initial\":{\"positions\":\"random\",\"temperature\":1}},"
	             "\"collisions\":{\"restitution\":0.9},\"hsmc\":{\"cell_size\":2},"
	             "\"run\":{\"seed\":11,\"until\":{\"time\":100}}}", "hsmc: dense polydisperse mixture, full cells");
	test_restore("{\"method\":\"hsmc\",\"dimensions\":3,\"particles\":{\"species\":[{\"name\":\"p\",\"count\":800,"
	             "\"radius_range\":[0.3,0.6],\"mass\":1},{\"name\":\"q\",\"count\":400,\"radius\":0.8,\"mass\":3}],"
	             "\"box\":[20,20,20],\"initial\":{\"positions\":\"random\",\"temperature\":1}},"
	             "\"collisions\":{\"restitution\":0.9},\"hsmc\":{\"cell_size\":1.5},"
	             "\"boundaries\":{\"z\":{\"type\":\"walls\",\"lower\":{\"type\":\"thermal\",\"temperature\":1},"
	             "\"upper\":{\"type\":\"rough\",\"probability\":0.5}},\"x\":{\"type\":\"walls\",\"lower\":{\"type\":"
	             "\"moving\",\"velocity\":[0,0.5,0]},\"upper\":{\"type\":\"specular\"}}},\"gravity\":[0,0,-0.5],"
	             "\"obstacles\":[{\"type\":\"no_slip\",\"center\":[10,10,8],\"radius\":3,\"temperature\":1}],"
	             "\"run\":{\"seed\":12,\"until\":{\"time\":100}}}", "hsmc: bounded polydisperse mixture");
	test_restore("{\"method\":\"hsmc\",\"dimensions\":2,\"particles\":{\"species\":[{\"count\":600,\"radius\":0.4,"
	             "\"mass\":1},{\"count\":300,\"radius_range\":[0.6,1],\"mass\":4}],\"box\":[40,50],"
	             "\"initial\":{\"positions\":\"random\",\"temperature\":1}},\"collisions\":{\"restitution\":0.9},"
	             "\"boundaries\":{\"y\":{\"type\":\"walls\",\"lower\":{\"type\":\"vibrating\",\"amplitude\":0.5,"
	             "\"frequency\":0.3,\"restitution\":0.8},\"upper\":{\"type\":\"open\"}},\"x\":{\"type\":\"walls\","
	             "\"lower\":{\"type\":\"thermal\",\"temperature\":1},\"upper\":{\"type\":\"specular\"}}},"
	             "\"gravity\":[0,-0.2],\"hsmc\":{\"cell_size\":2},\"run\":{\"seed\":13,\"until\":{\"time\":100}}}",
	             "hsmc: mixture with a vibrating floor and an open lid");
	plan(tap_n);
	return done_testing();
}
