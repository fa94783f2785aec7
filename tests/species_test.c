/* Tests of particle species (mixtures) in the event-driven engine: the scene keys, placement of mixed sizes, conservation, equipartition, the homogeneous cooling state against theory, checkpoints. */
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <jansson.h>

#include "ed/ed.h"
#include "mc/dsmc.h"
#include "scene.h"
#include "preset_file.h"
#include "tap.h"
#include "ed_util.h"
#include "stats.h"

#ifndef M_PI
#define M_PI 3.14159265358979323846
#endif

/* ---- the scene keys --------------------------------------------------- */

static void test_parse(void)
{
	scene_t s;
	char err[512] = "";
	const char *j = "{\"method\":\"ed\",\"dimensions\":2,\"particles\":{\"species\":["
	                "{\"name\":\"small\",\"count\":30,\"radius\":0.5,\"mass\":1},"
	                "{\"count\":10,\"radius\":1.5,\"mass\":9}],\"volume_fraction\":0.2},"
	                "\"collisions\":{\"restitution\":0.9,\"restitution_pairs\":[{\"a\":\"small\",\"b\":1,"
	                "\"restitution\":0.7}]},\"run\":{\"until\":{\"time\":1}}}";
	int rc = scene_parse(j, strlen(j), &s, err, sizeof err);
	ok(rc == SCENE_OK, "two species parse (%s)", err);
	ok(s.n_species == 2 && s.count == 40 && s.radius == 1.5 && fabs(s.mass - 120.0 / 40.0) < 1e-15,
	   "count is the sum 40, radius the largest 1.5, mass the mean 3 (got %llu, %g, %g)",
	   (unsigned long long)s.count, s.radius, s.mass);
	ok(!strcmp(s.species[0].name, "small") && !strcmp(s.species[1].name, "1"),
	   "names as given, else the index (\"%s\", \"%s\")", s.species[0].name, s.species[1].name);
	ok(s.restitution_pair[0][1] == 0.7 && s.restitution_pair[1][0] == 0.7 && s.restitution_pair[0][0] == 0.9 &&
	   s.restitution_pair[1][1] == 0.9, "pair restitution symmetric, pairs not listed take collisions.restitution");
	/* the mean particle volume: (30 pi 0.25 + 10 pi 2.25) / 40 */
	double vp = (30 * M_PI * 0.25 + 10 * M_PI * 2.25) / 40.0;
	ok(fabs(scene_particle_volume(&s) - vp) < 1e-14 * vp &&
	   fabs(s.box[0] * s.box[1] * 0.2 - 40 * vp) < 1e-9 * 40 * vp,
	   "volume fraction from the species' volumes (box %g)", s.box[0]);
	ok(scene_has_species(&s), "scene_has_species()");
	/* hsmc builds a mixture (issue 13: tests/mc_species_test, tests/hsmc_species_test),
	 * also with the local contact value (each pair's chi_ij per cell) */
	scene_t m = s;
	m.method = SCENE_METHOD_HSMC;
	char why[256] = "";
	int dc;
	dsmc_t *d = dsmc_create(&m, 0, &dc, why, sizeof why);
	int built = d != NULL;
	dsmc_destroy(d);
	m.mc_local_chi = 1;
	d = dsmc_create(&m, 0, &dc, why, sizeof why);
	ok(built && d && dc == DSMC_OK, "dsmc_create() builds hsmc with two species, also with the local contact value%s%s",
	   why[0] ? ": " : "", why);
	dsmc_destroy(d);

	static const struct { const char *what, *json, *key; } bad[] = {
		{ "both count and species", "{\"method\":\"ed\",\"dimensions\":2,\"particles\":{\"count\":4,\"species\":"
		  "[{\"count\":2,\"radius\":0.5,\"mass\":1}],\"volume_fraction\":0.1},\"run\":{\"until\":{\"time\":1}}}",
		  "particles.count:" },
		{ "clusters of a dsmc mixture with an open wall", "{\"method\":\"dsmc\",\"dimensions\":2,\"particles\":"
		  "{\"species\":[{\"count\":200,\"radius\":0.5,\"mass\":1},{\"count\":200,\"radius\":0.5,\"mass\":2}],"
		  "\"volume_fraction\":0.1},\"boundaries\":{\"y\":{\"type\":\"walls\",\"lower\":{\"type\":\"specular\"},"
		  "\"upper\":{\"type\":\"open\"}}},\"run\":{\"until\":{\"time\":1}},\"output\":{\"observables\":"
		  "[\"clusters\"]}}", "output.observables:" },
		{ "pairs without species", "{\"method\":\"ed\",\"dimensions\":2,\"particles\":{\"count\":40,"
		  "\"volume_fraction\":0.1},\"collisions\":{\"restitution_pairs\":[]},\"run\":{\"until\":{\"time\":1}}}",
		  "collisions.restitution_pairs:" },
		{ "pair given twice", "{\"method\":\"ed\",\"dimensions\":2,\"particles\":{\"species\":"
		  "[{\"count\":20,\"radius\":0.5,\"mass\":1},{\"count\":20,\"radius\":0.5,\"mass\":2}],"
		  "\"volume_fraction\":0.1},\"collisions\":{\"restitution_pairs\":[{\"a\":0,\"b\":1,\"restitution\":0.5},"
		  "{\"a\":1,\"b\":0,\"restitution\":0.5}]},\"run\":{\"until\":{\"time\":1}}}",
		  "collisions.restitution_pairs[1]:" },
		{ "duplicate names", "{\"method\":\"ed\",\"dimensions\":2,\"particles\":{\"species\":"
		  "[{\"name\":\"a\",\"count\":20,\"radius\":0.5,\"mass\":1},{\"name\":\"a\",\"count\":20,\"radius\":0.5,"
		  "\"mass\":2}],\"volume_fraction\":0.1},\"run\":{\"until\":{\"time\":1}}}", "particles.species[1].name:" },
		{ "velocity distribution of a mixture with an open wall", "{\"method\":\"ed\",\"dimensions\":2,"
		  "\"particles\":{\"species\":[{\"count\":20,\"radius\":0.5,\"mass\":1},{\"count\":20,\"radius\":0.5,"
		  "\"mass\":2}],\"volume_fraction\":0.1},\"boundaries\":{\"x\":{\"type\":\"walls\",\"lower\":{\"type\":"
		  "\"specular\"},\"upper\":{\"type\":\"open\"}}},\"run\":{\"until\":{\"time\":1}},\"output\":"
		  "{\"observables\":[\"velocity_distribution\"]}}", "output.observables:" },
		{ "radius and radius_range", "{\"method\":\"ed\",\"dimensions\":2,\"particles\":{\"species\":"
		  "[{\"count\":20,\"radius\":0.5,\"radius_range\":[0.4,0.6],\"mass\":1}],\"volume_fraction\":0.1},"
		  "\"run\":{\"until\":{\"time\":1}}}", "particles.species[0].radius_range:" },
		{ "radius_range reversed", "{\"method\":\"ed\",\"dimensions\":2,\"particles\":{\"species\":"
		  "[{\"count\":20,\"radius_range\":[0.6,0.4],\"mass\":1}],\"volume_fraction\":0.1},"
		  "\"run\":{\"until\":{\"time\":1}}}", "particles.species[0].radius_range:" },
		{ "g(r) of a mixture between walls", "{\"method\":\"ed\",\"dimensions\":2,\"particles\":{\"species\":"
		  "[{\"count\":20,\"radius\":0.5,\"mass\":1},{\"count\":20,\"radius\":0.5,\"mass\":2}],"
		  "\"volume_fraction\":0.1},\"boundaries\":{\"x\":{\"type\":\"walls\",\"lower\":{\"type\":\"specular\"},\"upper\":{\"type\":\"specular\"}}},"
		  "\"run\":{\"until\":{\"time\":1}},\"output\":{\"observables\":"
		  "[\"pair_correlation\"]}}", "output.observables:" },
		{ "g(r) of polydisperse species", "{\"method\":\"ed\",\"dimensions\":2,\"particles\":{\"species\":"
		  "[{\"count\":20,\"radius\":0.5,\"mass\":1},{\"count\":20,\"radius_range\":[0.4,0.6],\"mass\":2}],"
		  "\"volume_fraction\":0.1},\"run\":{\"until\":{\"time\":1}},\"output\":{\"observables\":"
		  "[\"pair_correlation\"]}}", "output.observables:" },
		{ "g(r) of five species", "{\"method\":\"ed\",\"dimensions\":2,\"particles\":{\"species\":"
		  "[{\"count\":9,\"radius\":0.5,\"mass\":1},{\"count\":9,\"radius\":0.5,\"mass\":2},"
		  "{\"count\":9,\"radius\":0.5,\"mass\":3},{\"count\":9,\"radius\":0.5,\"mass\":4},"
		  "{\"count\":9,\"radius\":0.5,\"mass\":5}],"
		  "\"volume_fraction\":0.1},\"run\":{\"until\":{\"time\":1}},\"output\":{\"observables\":"
		  "[\"pair_correlation\"]}}", "output.observables:" },
	};
	for (size_t k = 0; k < sizeof bad / sizeof bad[0]; k++) {
		err[0] = '\0';
		rc = scene_parse(bad[k].json, strlen(bad[k].json), &s, err, sizeof err);
		ok(rc == SCENE_EINVAL && !strncmp(err, bad[k].key, strlen(bad[k].key)), "%s: refused naming %s (%s)",
		   bad[k].what, bad[k].key, err);
	}
}

/* ---- helpers ---------------------------------------------------------- */

/* Smallest surface gap over all pairs (brute force, minimum image), and the
 * smallest centre distance among pairs of species 0: an independent check
 * of what the engine's cell scans and pair tables do. */
static double brute_gap(const scene_t *s, const double *pos, double *min_d00)
{
	const int D = s->dim;
	double best = INFINITY, d00 = INFINITY;
	uint32_t first1 = (uint32_t)s->species[0].count;
	for (uint32_t i = 0; i < s->count; i++)
		for (uint32_t j = i + 1; j < s->count; j++) {
			double r2 = 0.0;
			for (int a = 0; a < D; a++) {
				double x = pos[(size_t)i * D + a] - pos[(size_t)j * D + a];
				x -= s->box[a] * nearbyint(x / s->box[a]);
				r2 += x * x;
			}
			int si = i >= first1, sj = j >= first1;
			double g = sqrt(r2) - s->species[si].radius - s->species[sj].radius;
			if (g < best)
				best = g;
			if (!si && !sj && sqrt(r2) < d00)
				d00 = sqrt(r2);
		}
	if (min_d00)
		*min_d00 = d00;
	return best;
}

/* Temperatures of the two species now (ed_totals changes nothing). */
static void temps(ed_t *ed, const scene_t *s, double *t0, double *t1, double *t)
{
	ed_sample_t sm;
	ed_totals(ed, &sm);
	*t0 = 2.0 * sm.species_kinetic_energy[0] / (s->dim * (double)sm.species_count[0]);
	*t1 = 2.0 * sm.species_kinetic_energy[1] / (s->dim * (double)sm.species_count[1]);
	*t = 2.0 * sm.kinetic_energy / (s->dim * (double)s->count);
}

static double cpp_coll(double cpp, uint64_t n) { return ceil(cpp * (double)n / 2.0); }

/* ---- placement -------------------------------------------------------- */

/* Lattice (spacing from the largest diameter, species shuffled over the
 * sites: so only at volume fractions that the largest diameter allows)
 * and random placement (pair contact distances) of disks and spheres of
 * radius ratio 3: no overlap, by brute force over all pairs, and the
 * engine's own smallest gap agrees. */
static void test_placement(void)
{
	static const struct { int dim; const char *pos; double phi; } c[] = {
		{ 2, "lattice", 0.15 }, { 2, "random", 0.25 }, { 3, "lattice", 0.08 }, { 3, "random", 0.15 },
	};
	for (size_t k = 0; k < sizeof c / sizeof c[0]; k++) {
		char j[1024];
		snprintf(j, sizeof j, "{\"method\":\"ed\",\"dimensions\":%d,\"particles\":{\"species\":["
		         "{\"count\":300,\"radius\":0.3,\"mass\":1},{\"count\":60,\"radius\":0.9,\"mass\":27}],"
		         "\"volume_fraction\":%g,\"initial\":{\"positions\":\"%s\"}},\"run\":{\"until\":{\"time\":1}}}",
		         c[k].dim, c[k].phi, c[k].pos);
		scene_t s;
		ed_t *ed = make(j, &s);
		if (!ed) {
			ok(0, "%dD %s: engine", c[k].dim, c[k].pos);
			continue;
		}
		double *pos = malloc(s.count * s.dim * sizeof(double)), d00;
		ed_state(ed, pos, NULL);
		double g = brute_gap(&s, pos, &d00);
		ok(g >= -1e-12 && fabs(ed_min_gap(ed) - g) < 1e-9,
		   "%dD %s, radii 0.3 and 0.9: no overlap (smallest gap %.3g, engine's %.3g)", c[k].dim, c[k].pos, g,
		   ed_min_gap(ed));
		free(pos);
		ed_destroy(ed);
	}
}

/* ---- elastic mixture: conservation and equipartition --------------------- */

#define EQ_RUNS 8
/* A binary elastic mixture (2D, 500 + 500 disks, radii 0.5 and 0.8, masses
 * 1 and 4, volume fraction 0.2) started far from equipartition (the heavy
 * species at 1/4 of the light one's temperature) relaxes to T_0 = T_1.
 * Exactly: at fixed energy E and zero momentum the kinetic energy of
 * species s is on average E f_s / f, f_s = D (N_s - M_s / M) its share of
 * the f = D (N - 1) degrees of freedom (the centre of mass takes D, shared
 * by mass), so (T_0 - T_1) / T = N / (N - 1) (M_1 / (M N_1) - M_0 / (M
 * N_0)) = 0.0012 here. Measured: the mean of (T_0 - T_1) / T over 100
 * samples (collisions per particle 20 .. 120) per run, over EQ_RUNS
 * independent runs; within 5 standard errors of the mean over the runs.
 * Each run also conserves energy to 1e-12 relative and momentum to 1e-12
 * of sqrt(2 M E), and keeps every pair apart by its own contact distance
 * (brute force at the end) while small pairs come closer than a large
 * diameter. */
static void test_equipartition(void)
{
	double x[EQ_RUNS], start = 0.0, worst_e = 0.0, worst_p = 0.0, worst_gap = INFINITY, d00_max = 0.0;
	int made = 0;
	for (int run = 0; run < EQ_RUNS; run++) {
		char j[1024];
		snprintf(j, sizeof j, "{\"method\":\"ed\",\"dimensions\":2,\"particles\":{\"species\":["
		         "{\"name\":\"light\",\"count\":500,\"radius\":0.5,\"mass\":1},"
		         "{\"name\":\"heavy\",\"count\":500,\"radius\":0.8,\"mass\":4}],\"volume_fraction\":0.2,"
		         "\"initial\":{\"positions\":\"random\"}},\"run\":{\"until\":{\"time\":1},\"seed\":%d}}", 11 + run);
		scene_t s;
		ed_t *a = make(j, &s);
		if (!a)
			break;
		const size_t nd = s.count * s.dim;
		double *pos = malloc(nd * sizeof(double)), *vel = malloc(nd * sizeof(double));
		ed_state(a, pos, vel);
		ed_destroy(a);
		/* heavy species slowed by 2 (temperature / 4), then the centre-of-mass velocity removed */
		double P[2] = {0, 0}, M = 0.0;
		for (uint32_t i = 0; i < s.count; i++) {
			int sp = i >= 500;
			double m = s.species[sp].mass;
			for (int d = 0; d < 2; d++) {
				if (sp)
					vel[i * 2 + d] *= 0.5;
				P[d] += m * vel[i * 2 + d];
			}
			M += m;
		}
		for (uint32_t i = 0; i < s.count; i++)
			for (int d = 0; d < 2; d++)
				vel[i * 2 + d] -= P[d] / M;
		s.init_pos = pos;
		s.init_vel = vel;
		int rc;
		char msg[256];
		ed_t *ed = ed_create(&s, &rc, msg, sizeof msg);
		if (!ed) {
			diag("ed_create: %s", msg);
			free(pos), free(vel);
			break;
		}
		double t0, t1, t;
		temps(ed, &s, &t0, &t1, &t);
		start += (t0 - t1) / t / EQ_RUNS;
		ed_sample_t s0, s1;
		ed_totals(ed, &s0);
		ed_advance(ed, INFINITY, (uint64_t)cpp_coll(20, s.count), UINT64_MAX);
		double sum = 0.0;
		for (int k = 1; k <= 100; k++) {
			ed_advance(ed, INFINITY, (uint64_t)cpp_coll(20 + k, s.count), UINT64_MAX);
			temps(ed, &s, &t0, &t1, &t);
			sum += (t0 - t1) / t;
		}
		x[run] = sum / 100;
		ed_totals(ed, &s1);
		double de = fabs(s1.kinetic_energy - s0.kinetic_energy) / s0.kinetic_energy;
		double dp = hypot(s1.momentum[0] - s0.momentum[0], s1.momentum[1] - s0.momentum[1]) /
		            sqrt(2.0 * M * s0.kinetic_energy);
		worst_e = fmax(worst_e, de);
		worst_p = fmax(worst_p, dp);
		double d00;
		ed_state(ed, pos, NULL);
		worst_gap = fmin(worst_gap, brute_gap(&s, pos, &d00));
		d00_max = fmax(d00_max, d00);
		ed_destroy(ed);
		free(pos), free(vel);
		made++;
	}
	if (made < EQ_RUNS) {
		ok(0, "equipartition: %d of %d runs made", made, EQ_RUNS);
		return;
	}
	double mean, se;
	mean_se(x, EQ_RUNS, &mean, &se);
	const double expect = 1000.0 / 999.0 * (2000.0 / 2500.0 / 500.0 - 500.0 / 2500.0 / 500.0);
	ok(start > 1.0, "the runs start far from equipartition: (T_0 - T_1) / T = %.3f", start);
	ok(fabs(mean - expect) < 5.0 * se, "equipartition: (T_0 - T_1) / T = %.5f +- %.5f, exact %.5f (5 SE over %d runs)",
	   mean, se, expect, EQ_RUNS);
	ok(worst_e < 1e-12, "elastic mixture: energy conserved to %.2g relative (< 1e-12)", worst_e);
	ok(worst_p < 1e-12, "unequal masses: momentum conserved to %.2g of sqrt(2 M E) (< 1e-12)", worst_p);
	ok(worst_gap > -1e-9 && d00_max < 1.6,
	   "pair contact distances: smallest gap %.3g >= 0; light pairs at %.3f < a heavy diameter 1.6", worst_gap,
	   d00_max);
}

/* ---- inelastic mixture: homogeneous cooling ------------------------------ */

/* Cooling rate of species i (up to a factor common to all species) in a
 * dilute binary mixture of Maxwellians at temperatures T (Gaussian
 * approximation; derivation in docs/engine.md, "Species"):
 * zeta_i ~ (1/T_i) sum_j n_j sigma_ij^(D-1) s_ij^3 m_i (1 + e_ij) w_ij (lambda_ij - (1 + e_ij) w_ij / 2),
 * s_ij^2 = T_i/m_i + T_j/m_j, lambda_ij = (T_i/m_i) / s_ij^2, w_ij = m_j / (m_i + m_j). */
static double zeta(int i, const double *T, const double *m, const double *n, const double sig[2][2],
                   const double e[2][2], int D)
{
	double z = 0.0;
	for (int j = 0; j < 2; j++) {
		double s2 = T[i] / m[i] + T[j] / m[j], lam = T[i] / m[i] / s2, w = m[j] / (m[i] + m[j]);
		z += n[j] * pow(sig[i][j], D - 1) * pow(s2, 1.5) * m[i] * (1 + e[i][j]) * w * (lam - 0.5 * (1 + e[i][j]) * w);
	}
	return z / T[i];
}

/* T_0 / T_1 where both species cool at the same rate (bisection in log). */
static double hcs_ratio(const double *m, const double *n, const double sig[2][2], const double e[2][2], int D)
{
	double lo = 0.01, hi = 100.0;
	for (int k = 0; k < 200; k++) {
		double mid = sqrt(lo * hi), Tl[2] = {lo, 1.0}, Tm[2] = {mid, 1.0};
		double fl = zeta(0, Tl, m, n, sig, e, D) - zeta(1, Tl, m, n, sig, e, D);
		double fm = zeta(0, Tm, m, n, sig, e, D) - zeta(1, Tm, m, n, sig, e, D);
		if (fl * fm <= 0.0)
			hi = mid;
		else
			lo = mid;
	}
	return sqrt(lo * hi);
}

#define HCS_RUNS 12
/* Homogeneous cooling of a binary mixture (the preset binary-mixture-2d:
 * 2D, 1000 + 1000 disks of equal radius 0.5, masses 1 and 4, restitution
 * 0.9, volume fraction 0.02, random start): the
 * temperature ratio T_light / T_heavy settles to a constant below 1 (no
 * equipartition: the heavy species is hotter), the ratio at which both
 * species cool at the same rate (Garzo and Dufty's Maxwellian
 * approximation, derived in docs/engine.md; 0.8646 here). Equal radii: the
 * Enskog contact factors are the same for every pair and cancel, so the
 * density does not enter. Measured: the mean ratio over 50 samples
 * (collisions per particle 11 .. 60, the scaling state: the ratio's
 * transient from 1 decays within a few collisions) per run, over HCS_RUNS
 * independent runs; within 5 standard errors of the mean over the runs.
 * The approximation neglects the non-Gaussian parts of the distributions,
 * whose effect on the ratio is of the order of their fourth cumulant a2
 * (about 0.01 at e = 0.9), below the tolerance. */
static void test_hcs(void)
{
	double x[HCS_RUNS], m[2] = {0, 0}, nf[2] = {0, 0}, sig[2][2] = {{0}}, e[2][2] = {{0}};
	int made = 0;
	char path[4096];
	preset_path("binary-mixture-2d.json", path, sizeof path);
	json_error_t jerr;
	json_t *preset = json_load_file(path, 0, &jerr);
	if (!preset) {
		ok(0, "preset %s: %s", path, jerr.text);
		return;
	}
	for (int run = 0; run < HCS_RUNS; run++) {
		/* the preset, with seed 101 + run */
		json_object_set_new(json_object_get(preset, "run"), "seed", json_integer(101 + run));
		char *j = json_dumps(preset, JSON_REAL_PRECISION(17));
		scene_t s;
		ed_t *ed = j ? make(j, &s) : NULL;
		free(j);
		if (!ed)
			break;
		/* the theory's parameters from the preset: masses, number fractions, contact distances, restitution */
		for (int a = 0; a < 2 && s.n_species == 2; a++) {
			m[a] = s.species[a].mass;
			nf[a] = (double)s.species[a].count / (double)s.count;
			for (int b = 0; b < 2; b++) {
				sig[a][b] = s.species[a].radius + s.species[b].radius;
				e[a][b] = s.restitution_pair[a][b];
			}
		}
		double sum = 0.0, t0, t1, t;
		ed_advance(ed, INFINITY, (uint64_t)cpp_coll(10, s.count), UINT64_MAX);
		for (int k = 1; k <= 50; k++) {
			ed_advance(ed, INFINITY, (uint64_t)cpp_coll(10 + k, s.count), UINT64_MAX);
			temps(ed, &s, &t0, &t1, &t);
			sum += t0 / t1;
		}
		x[run] = sum / 50;
		ed_destroy(ed);
		made++;
	}
	json_decref(preset);
	if (made < HCS_RUNS) {
		ok(0, "cooling mixture: %d of %d runs made", made, HCS_RUNS);
		return;
	}
	const double theory = hcs_ratio(m, nf, sig, e, 2);
	double mean, se;
	mean_se(x, HCS_RUNS, &mean, &se);
	ok(mean < 1.0 - 5.0 * se, "cooling mixture: the heavy species is hotter, T_light / T_heavy = %.4f +- %.4f < 1",
	   mean, se);
	ok(fabs(mean - theory) < 5.0 * se, "cooling mixture: T_light / T_heavy = %.4f +- %.4f, theory %.4f (5 SE over %d "
	   "runs)", mean, se, theory, HCS_RUNS);
	/* the elastic limit of the theory: equipartition */
	const double e1[2][2] = {{1, 1}, {1, 1}};
	ok(fabs(hcs_ratio(m, nf, sig, e1, 2) - 1.0) < 1e-9 && fabs(theory - 0.8646) < 1e-4,
	   "theory: ratio 1 at e = 1 (equipartition); %.4f for the preset (masses 1, 4, e = 0.9)", theory);
}

/* ---- polydisperse radii ------------------------------------------------ */

/* One polydisperse species (2D, 2000 disks, radii uniform in [0.3, 0.7],
 * volume fraction 0.3, random start), elastic: the radii lie in the range
 * with the mean of the uniform distribution, 0.5, within 5 standard errors
 * ((0.7 - 0.3) / sqrt(12 N)); the parser's box holds the expected volume
 * fraction (E[r^2] = (0.7^3 - 0.3^3) / (3 x 0.4)); no pair overlaps by more
 * than rounding (brute force with the drawn radii) at the start and after
 * 50 collisions per particle; energy conserved to 1e-12 relative. */
static void test_polydisperse(void)
{
	const char *j = "{\"method\":\"ed\",\"dimensions\":2,\"particles\":{\"species\":[{\"count\":2000,"
	                "\"radius_range\":[0.3,0.7],\"mass\":1}],\"volume_fraction\":0.3,\"initial\":{\"positions\":"
	                "\"random\"}},\"run\":{\"until\":{\"time\":1},\"seed\":5}}";
	scene_t s;
	ed_t *ed = make(j, &s);
	if (!ed) {
		ok(0, "polydisperse scene");
		return;
	}
	const uint64_t n = s.count;
	double *rad = malloc(n * sizeof(double)), *pos = malloc(n * 2 * sizeof(double)), sum = 0.0, lo = 1, hi = 0;
	scene_species_radii(&s, rad);
	for (uint64_t i = 0; i < n; i++) {
		sum += rad[i];
		lo = fmin(lo, rad[i]);
		hi = fmax(hi, rad[i]);
	}
	const double se = 0.4 / sqrt(12.0 * n), er2 = (0.343 - 0.027) / 1.2;
	ok(lo >= 0.3 && hi <= 0.7 && fabs(sum / n - 0.5) < 5 * se && s.radius == 0.7,
	   "radii in [%.4f, %.4f], mean %.4f (0.5 +- %.4f), largest radius 0.7 for the cells", lo, hi, sum / n, se);
	ok(fabs(s.box[0] * s.box[1] * 0.3 - n * M_PI * er2) < 1e-9 * n, "box from the expected particle area (edge %.4f)",
	   s.box[0]);
	/* brute force with the drawn radii */
	double g0 = INFINITY, g1 = INFINITY;
	for (int pass = 0; pass < 2; pass++) {
		if (pass)
			ed_advance(ed, INFINITY, (uint64_t)cpp_coll(50, n), UINT64_MAX);
		ed_state(ed, pos, NULL);
		double g = INFINITY;
		for (uint64_t a = 0; a < n; a++)
			for (uint64_t b = a + 1; b < n; b++) {
				double r2 = 0.0;
				for (int d = 0; d < 2; d++) {
					double x = pos[a * 2 + d] - pos[b * 2 + d];
					x -= s.box[d] * nearbyint(x / s.box[d]);
					r2 += x * x;
				}
				g = fmin(g, sqrt(r2) - rad[a] - rad[b]);
			}
		*(pass ? &g1 : &g0) = g;
	}
	ed_sample_t s1;
	ed_totals(ed, &s1);
	double de = fabs(s1.kinetic_energy - 0.5 * 2 * n * s.temperature) / (0.5 * 2 * n * s.temperature);
	ok(g0 >= -1e-12 && g1 > -1e-9 && fabs(ed_min_gap(ed) - g1) < 1e-9,
	   "no overlap with the drawn radii: smallest gap %.3g at the start, %.3g after 50 collisions per particle", g0, g1);
	ok(de < 1e-12, "polydisperse elastic gas: energy conserved to %.2g relative", de);
	free(rad);
	free(pos);
	ed_destroy(ed);
}

/* ---- walls and obstacles ---------------------------------------------- */

/* A mixture (2D, 400 + 400 disks of radii 0.4 and 0.8, masses 1 and 5, box
 * 60 x 40) between specular walls on y around a slip obstacle of radius 5
 * at the centre, elastic: energy conserved to 1e-12 relative, and every
 * particle keeps its own radius from the walls and its own contact
 * distance (5 + radius) from the obstacle (sampled every collision per
 * particle for 100), while light disks come closer to a wall and to the
 * obstacle than a heavy radius would allow: each particle's own radius is
 * used, not the largest. */
static void test_walls(void)
{
	const char *j = "{\"method\":\"ed\",\"dimensions\":2,\"particles\":{\"species\":["
	                "{\"count\":400,\"radius\":0.4,\"mass\":1},{\"count\":400,\"radius\":0.8,\"mass\":5}],"
	                "\"box\":[60,40],\"initial\":{\"positions\":\"random\"}},\"boundaries\":{\"y\":{\"type\":"
	                "\"walls\",\"lower\":{\"type\":\"specular\"},\"upper\":{\"type\":\"specular\"}}},"
	                "\"obstacles\":[{\"type\":\"slip\",\"center\":[30,20],\"radius\":5}],"
	                "\"run\":{\"until\":{\"time\":1},\"seed\":9}}";
	scene_t s;
	ed_t *ed = make(j, &s);
	if (!ed) {
		ok(0, "mixture with walls and an obstacle");
		return;
	}
	double *pos = malloc(s.count * 2 * sizeof(double));
	double gap = INFINITY, wall_light = INFINITY, obst_light = INFINITY;
	ed_sample_t s0, s1;
	ed_totals(ed, &s0);
	for (int k = 1; k <= 100; k++) {
		ed_advance(ed, INFINITY, (uint64_t)cpp_coll(k, s.count), UINT64_MAX);
		ed_state(ed, pos, NULL);
		for (uint32_t i = 0; i < s.count; i++) {
			const double a = i < 400 ? 0.4 : 0.8, y = pos[i * 2 + 1];
			const double dw = fmin(y, 40.0 - y), dx = pos[i * 2] - 30.0, dy = y - 20.0;
			const double dob = sqrt(dx * dx + dy * dy);
			gap = fmin(gap, fmin(dw - a, dob - 5.0 - a));
			if (i < 400) {
				wall_light = fmin(wall_light, dw);
				obst_light = fmin(obst_light, dob - 5.0);
			}
		}
	}
	ed_totals(ed, &s1);
	double de = fabs(s1.kinetic_energy - s0.kinetic_energy) / s0.kinetic_energy;
	ok(de < 1e-12, "mixture between walls, around an obstacle: energy conserved to %.2g relative", de);
	ok(gap > -1e-9 && ed_min_gap(ed) > -1e-9 && ed_min_gap(ed) <= gap + 1e-9 && wall_light < 0.8 && obst_light < 0.8,
	   "walls and obstacle at each particle's own radius: smallest gap %.3g; light disks reach %.3f from a wall, "
	   "%.3f from the obstacle (< 0.8)", gap, wall_light, obst_light);
	free(pos);
	ed_destroy(ed);
}

/* Gravity (2D mixture of radii 0.4 and 0.8, masses 1 and 5, specular floor
 * and lid, g = 0.05 down, elastic): kinetic plus potential energy conserved
 * to 1e-12 relative; the centre-of-mass height is the mass-weighted mean
 * height (brute force from the positions); and the engine's running E_kin
 * integral over an interval (exact for piecewise free flight under
 * gravity, with the momentum weighted by mass) equals the trapezoid rule
 * over 2000 exact samples of E_kin within 1e-6 relative (E_kin is smooth in
 * an elastic gas under gravity; the rule's error is far below that). */
static void test_gravity(void)
{
	const char *j = "{\"method\":\"ed\",\"dimensions\":2,\"particles\":{\"species\":["
	                "{\"count\":300,\"radius\":0.4,\"mass\":1},{\"count\":300,\"radius\":0.8,\"mass\":5}],"
	                "\"box\":[40,60],\"initial\":{\"positions\":\"random\"}},\"boundaries\":{\"y\":{\"type\":"
	                "\"walls\",\"lower\":{\"type\":\"specular\"},\"upper\":{\"type\":\"specular\"}}},"
	                "\"gravity\":[0,-0.05],\"run\":{\"until\":{\"time\":1},\"seed\":4}}";
	scene_t s;
	ed_t *ed = make(j, &s);
	if (!ed) {
		ok(0, "mixture under gravity");
		return;
	}
	ed_sample_t a, b;
	ed_sample(ed, &a);
	const double e0 = a.kinetic_energy + a.potential_energy;
	ed_advance(ed, 20.0, UINT64_MAX, UINT64_MAX);
	ed_sample(ed, &b);   /* starts the interval [20, 30] */
	double trap = 0.0, prev = b.kinetic_energy;
	for (int k = 1; k <= 2000; k++) {
		ed_sample_t c;
		ed_advance(ed, 20.0 + 10.0 * k / 2000, UINT64_MAX, UINT64_MAX);
		ed_totals(ed, &c);
		trap += 0.5 * (prev + c.kinetic_energy) * (10.0 / 2000);
		prev = c.kinetic_energy;
	}
	ed_sample(ed, &b);
	double de = fabs(b.kinetic_energy + b.potential_energy - e0) / fabs(e0);
	double di = fabs(b.ekin_time_integral - trap) / trap;
	double *pos = malloc(s.count * 2 * sizeof(double)), hm = 0.0, mt = 0.0;
	ed_state(ed, pos, NULL);
	for (uint32_t i = 0; i < s.count; i++) {
		double m = i < 300 ? 1.0 : 5.0;
		hm += m * pos[i * 2 + 1];
		mt += m;
	}
	const double esp = b.species_kinetic_energy[0] + b.species_kinetic_energy[1];
	ok(de < 1e-12 && fabs(esp - b.kinetic_energy) < 1e-12 * b.kinetic_energy,
	   "mixture under gravity: kinetic + potential energy conserved to %.2g relative (%llu collisions); the "
	   "species' kinetic energies add up to the total", de, (unsigned long long)b.collisions);
	ok(fabs(b.com_height - hm / mt) < 1e-9 * hm / mt && fabs(b.potential_energy - 0.05 * hm) < 1e-9 * 0.05 * hm,
	   "mass-weighted centre-of-mass height %.6f (positions: %.6f) and potential energy", b.com_height, hm / mt);
	ok(di < 1e-6, "running E_kin integral %.10g against the trapezoid rule %.10g: %.2g relative", b.ekin_time_integral,
	   trap, di);
	free(pos);
	ed_destroy(ed);
}

#define HOLD_RUNS 6
/* An elastic mixture held at temperature 2 by its boundaries or its driving:
 * the scene SCENE_FMT (a %d for the seed, seed0 + run) run HOLD_RUNS times;
 * per run the mean of each species' temperature over `samples` samples, the
 * k-th (k = 1 .. samples) taken at first + k step collisions per particle
 * (by_cpp) or at time first + k step; passes when both species' means over
 * the runs are 2 within 5 standard errors of the mean over the runs. */
static void equilibrium_at_2(const char *what, const char *scene_fmt, int seed0, int by_cpp, double first, double step,
                             int samples)
{
	double tl[HOLD_RUNS], th[HOLD_RUNS];
	int made = 0;
	for (int run = 0; run < HOLD_RUNS; run++) {
		char j[1024];
		snprintf(j, sizeof j, scene_fmt, seed0 + run);
		scene_t s;
		ed_t *ed = make(j, &s);
		if (!ed)
			break;
		double sl = 0.0, sh = 0.0, t0, t1, t;
		for (int k = 1; k <= samples; k++) {
			if (by_cpp)
				ed_advance(ed, INFINITY, (uint64_t)cpp_coll(first + step * k, s.count), UINT64_MAX);
			else
				ed_advance(ed, first + step * k, UINT64_MAX, UINT64_MAX);
			temps(ed, &s, &t0, &t1, &t);
			sl += t0;
			sh += t1;
		}
		tl[run] = sl / samples;
		th[run] = sh / samples;
		ed_destroy(ed);
		made++;
	}
	if (made < HOLD_RUNS) {
		ok(0, "%s: %d of %d runs made", what, made, HOLD_RUNS);
		return;
	}
	double ml, sel, mh, seh;
	mean_se(tl, HOLD_RUNS, &ml, &sel);
	mean_se(th, HOLD_RUNS, &mh, &seh);
	ok(fabs(ml - 2.0) < 5 * sel && fabs(mh - 2.0) < 5 * seh,
	   "%s: T_light = %.4f +- %.4f, T_heavy = %.4f +- %.4f (5 SE over %d runs)", what, ml, sel, mh, seh, HOLD_RUNS);
}

/* Thermal walls (both ends of y, T_w = 2, full accommodation) hold an
 * elastic mixture (400 + 400 disks, masses 1 and 5) in equilibrium at the
 * walls' temperature: each species' temperature is T_w on average (a diffuse
 * wall re-emits a particle of mass m from the Maxwellian of temperature T_w,
 * sqrt(T_w / m) per component: the engine scales the wall's speed by the
 * particle's mass). 60 samples at collisions per particle 45 .. 340, every
 * 5 (started at T = 2). */
static void test_thermal_walls(void)
{
	equilibrium_at_2("thermal walls at T_w = 2",
	                 "{\"method\":\"ed\",\"dimensions\":2,\"particles\":{\"species\":["
	                 "{\"count\":400,\"radius\":0.5,\"mass\":1},{\"count\":400,\"radius\":0.5,\"mass\":5}],"
	                 "\"box\":[40,40],\"initial\":{\"positions\":\"random\",\"temperature\":2}},"
	                 "\"boundaries\":{\"y\":{\"type\":\"walls\",\"lower\":{\"type\":\"thermal\",\"temperature\":2},"
	                 "\"upper\":{\"type\":\"thermal\",\"temperature\":2}}},\"run\":{\"until\":{\"time\":1},"
	                 "\"seed\":%d}}",
	                 201, 1, 40, 5, 60);
}

/* seed 001's stochastic thermostat (T_th = 2, each particle kicked once per
 * unit time on average, one global mean velocity) drives an elastic mixture
 * (2D, 400 + 400 disks, masses 1 and 5, volume fraction 0.1, periodic) to
 * equilibrium at T_th for each species: a kick draws the velocity about the
 * mean from the Maxwellian of T_th for the particle's own mass. 50 samples
 * at times 11 .. 60 (started at T = 1). */
static void test_driving(void)
{
	equilibrium_at_2("stochastic thermostat at T_th = 2",
	                 "{\"method\":\"ed\",\"dimensions\":2,\"particles\":{\"species\":["
	                 "{\"count\":400,\"radius\":0.5,\"mass\":1},{\"count\":400,\"radius\":0.5,\"mass\":5}],"
	                 "\"volume_fraction\":0.1,\"initial\":{\"positions\":\"random\"}},"
	                 "\"driving\":{\"type\":\"stochastic\",\"temperature\":2,\"interval\":1},"
	                 "\"run\":{\"until\":{\"time\":1},\"seed\":%d}}",
	                 301, 0, 10, 1, 50);
}

/* ---- one species, checkpoints ------------------------------------------ */

/* particles.species with one entry is the one-species scene: the same
 * kernels, the same trajectory bit for bit as count/radius/mass. */
static void test_one_species(void)
{
	const char *ja = "{\"method\":\"ed\",\"dimensions\":3,\"particles\":{\"count\":500,\"radius\":0.5,\"mass\":2,"
	                 "\"volume_fraction\":0.3},\"collisions\":{\"restitution\":0.8},\"run\":{\"until\":{\"time\":1}}}";
	const char *jb = "{\"method\":\"ed\",\"dimensions\":3,\"particles\":{\"species\":[{\"count\":500,\"radius\":0.5,"
	                 "\"mass\":2}],\"volume_fraction\":0.3},\"collisions\":{\"restitution_pairs\":[{\"a\":0,\"b\":0,"
	                 "\"restitution\":0.8}]},\"run\":{\"until\":{\"time\":1}}}";
	scene_t sa, sb;
	ed_t *a = make(ja, &sa), *b = make(jb, &sb);
	int same = a && b;
	if (same) {
		ed_advance(a, INFINITY, 20000, UINT64_MAX);
		ed_advance(b, INFINITY, 20000, UINT64_MAX);
		size_t nd = 500 * 3;
		double *p = malloc(4 * nd * sizeof(double));
		ed_state(a, p, p + nd);
		ed_state(b, p + 2 * nd, p + 3 * nd);
		same = !memcmp(p, p + 2 * nd, 2 * nd * sizeof(double)) && ed_time(a) == ed_time(b);
		free(p);
	}
	ok(same, "one species via particles.species = count/radius/mass: bit-identical after 20000 collisions");
	ed_destroy(a);
	ed_destroy(b);
}

/* A mixture (one species polydisperse) copied through its state fields
 * (what a checkpoint holds) continues bit for bit: positions, velocities,
 * species temperatures. */
static void test_checkpoint(void)
{
	const char *j = "{\"method\":\"ed\",\"dimensions\":3,\"particles\":{\"species\":["
	                "{\"count\":300,\"radius\":0.5,\"mass\":1},{\"count\":100,\"radius\":0.75,\"mass\":3},"
	                "{\"count\":50,\"radius_range\":[0.2,0.4],\"mass\":0.2}],\"volume_fraction\":0.25,"
	                "\"initial\":{\"positions\":\"random\"}},"
	                "\"collisions\":{\"restitution\":0.95,\"restitution_pairs\":[{\"a\":0,\"b\":2,\"restitution\":0.7}]},"
	                "\"run\":{\"until\":{\"time\":1}}}";
	scene_t s;
	ed_t *a, *b;
	if (!checkpoint_pair(j, &s, 0.3, 0.7, &a, &b)) {
		ok(0, "mixture checkpoint copy");
		return;
	}
	ed_advance(a, 6.0, UINT64_MAX, UINT64_MAX);
	ed_advance(b, 6.0, UINT64_MAX, UINT64_MAX);
	ed_sample_t sa, sb;
	ed_sample(a, &sa);
	ed_sample(b, &sb);
	size_t nd = s.count * 3;
	double *p = malloc(4 * nd * sizeof(double));
	ed_state(a, p, p + nd);
	ed_state(b, p + 2 * nd, p + 3 * nd);
	ok(!memcmp(p, p + 2 * nd, 2 * nd * sizeof(double)) && sa.collisions == sb.collisions && sa.n_species == 3 &&
	   !memcmp(sa.species_kinetic_energy, sb.species_kinetic_energy, sizeof sa.species_kinetic_energy) &&
	   sa.virial == sb.virial,
	   "three species: the copy continues bit for bit (%llu collisions)", (unsigned long long)sa.collisions);
	free(p);
	ed_destroy(a);
	ed_destroy(b);
}

int main(void)
{
	plan(43);
	test_parse();
	test_placement();
	test_polydisperse();
	test_walls();
	test_thermal_walls();
	test_gravity();
	test_driving();
	test_one_species();
	test_checkpoint();
	test_equipartition();
	test_hcs();
	return done_testing();
}
