/* Tests of dsmc with mixtures (species): equipartition, an inelastic mixture's cooling and temperature ratio against ed, per-pair restitution, exact restores, refusals. */
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
static double tspec(const dsmc_sample_t *sm, int s, int dim)
{
	return 2 * sm->species_kinetic_energy[s] / (dim * (double)sm->species_count[s]);
}

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
		size_t np = sc.count * 4;
		double *p = malloc(np * sizeof(double));
		uint32_t *id = malloc(sc.count * sizeof(uint32_t));
		dsmc_field_get(d, "particles", p);
		dsmc_field_get(d, "id", id);
		for (uint64_t k = 0; k < sc.count; k++)
			if (id[k] >= 600)
				for (int a = 0; a < 2; a++)
					p[k * 4 + 2 + a] *= sqrt(3.0);
		dsmc_field_set(d, "particles", ED_T_F64, np, p);
		free(p);
		free(id);
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
 * offsets use each pair's own diameter). */
static void test_restore(void)
{
	const char *json = "{\"method\":\"dsmc\",\"dimensions\":3,\"particles\":{\"species\":[{\"name\":\"p\",\"count\":800,"
	                   "\"radius_range\":[0.3,0.6],\"mass\":1},{\"name\":\"q\",\"count\":400,\"radius\":0.8,\"mass\":3}],"
	                   "\"volume_fraction\":0.1,\"initial\":{\"positions\":\"random\",\"temperature\":1}},"
	                   "\"collisions\":{\"restitution\":0.9},\"dsmc\":{\"correction\":\"cba\"},"
	                   "\"run\":{\"seed\":8,\"until\":{\"time\":100}}}";
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
		size_t bytes = sc.count * 3 * sizeof(double);
		double *pa = malloc(bytes), *pb = malloc(bytes);
		dsmc_state(a, pa, NULL);
		dsmc_state(b, pb, NULL);
		dsmc_sample(a, &x);
		same = !memcmp(pa, pb, bytes);
		free(pa), free(pb);
	}
	ok(same && same_samples && x.n_species == 2 && dsmc_collisions(a) > 1000,
	   "polydisperse mixture with CBA: 30 restores bit-identical (%llu collisions) %s",
	   a ? (unsigned long long)dsmc_collisions(a) : 0ULL, err);
	dsmc_destroy(a);
	dsmc_destroy(b);
}

/* What dsmc/hsmc cannot honour with species yet is refused, naming the key. */
static void test_refusals(void)
{
	static const char *const extra[] = {
		"\"boundaries\":{\"y\":{\"type\":\"walls\",\"lower\":{\"type\":\"specular\"},\"upper\":{\"type\":\"specular\"}}}",
		"\"gravity\":[0,-1],\"boundaries\":{\"y\":{\"type\":\"walls\",\"lower\":{\"type\":\"specular\"},"
		"\"upper\":{\"type\":\"specular\"}}}",
		"\"obstacles\":[{\"type\":\"slip\",\"center\":[20,20],\"radius\":3}]",
	};
	for (int m = 0; m < 2; m++)
		for (size_t k = 0; k < sizeof extra / sizeof extra[0]; k++) {
			char json[1024], err[512] = "";
			snprintf(json, sizeof json, "{\"method\":\"%s\",\"dimensions\":2,\"particles\":{\"species\":[{\"count\":50,\"mass\":1,"
			         "\"radius\":0.5},{\"count\":50,\"radius\":1,\"mass\":1}],\"box\":[40,40]},\"run\":{\"until\":{\"time\":1}},%s}",
			         m ? "hsmc" : "dsmc", extra[k]);
			scene_t sc;
			int rc = scene_parse(json, strlen(json), &sc, err, sizeof err);
			ok(rc == SCENE_EINVAL && !strncmp(err, "particles.species: ", 19), "refused: %s", err);
		}
}

int main(void)
{
	test_refusals();
	test_equipartition();
	test_restore();
	test_pair_restitution();
	test_cooling_vs_ed();
	plan(tap_n);
	return done_testing();
}
