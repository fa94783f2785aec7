/* Tests of dsmc/hsmc with obstacles: exact invariants (energy, no centre inside an obstacle), equilibrium density and drag, a heating no_slip obstacle against ed, exact restores, refusals. */
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

#define PI 3.14159265358979323846


/* Kinetic plus potential energy now (potential 0 without gravity). */
static double energy(const dsmc_t *d)
{
	dsmc_sample_t sm;
	dsmc_totals(d, &sm);
	return sm.kinetic_energy + (isnan(sm.potential_energy) ? 0.0 : sm.potential_energy);
}

/* Smallest (|x - c| - S) / S over particles and obstacles (S = R + a;
 * nearest image on periodic axes), scene coordinates. */
static double min_gap(const dsmc_t *d, const scene_t *sc, double *pos)
{
	dsmc_state(d, pos, NULL);
	double worst = INFINITY;
	for (uint64_t i = 0; i < sc->count; i++)
		for (int k = 0; k < sc->n_obstacles; k++) {
			const scene_obstacle_t *o = &sc->obstacle[k];
			double r2 = 0, S = o->radius + sc->radius;
			for (int a = 0; a < sc->dim; a++) {
				double x = pos[i * sc->dim + a] - o->center[a];
				if (!sc->boundary[a].walled)
					x -= sc->box[a] * nearbyint(x / sc->box[a]);
				r2 += x * x;
			}
			double g = (sqrt(r2) - S) / S;
			worst = g < worst ? g : worst;
		}
	return worst;
}

/* Elastic particles, elastic obstacles (slip, random_sign: both keep |v|),
 * elastic walls and gravity along the walled axis: every part of a step conserves kinetic +
 * potential energy in exact arithmetic (exact parabolic flights between
 * wall and obstacle hits; hsmc as in mc_walls_test.c: a CBA offset into an
 * obstacle is not made). The drift allowed, 1e-10 relative, is ~10^5 ulps:
 * far above rounding, far below one mishandled hit (~1/N = 5e-4). No
 * centre may ever be inside an obstacle: checked after every step (every
 * frame a run could write) with 1e-12 relative rounding allowed (a centre
 * put back on the contact sphere, then moving away). Lattice (hsmc) and
 * random (dsmc) placement are checked the same way at t = 0. */
static void test_energy(const char *method, int dim)
{
	char json[2048];
	const char *obst = dim == 2
	    ? "[{\"type\":\"slip\",\"center\":[10,20],\"radius\":5},{\"type\":\"random_sign\",\"center\":[30,12],\"radius\":4},"
	      "{\"type\":\"slip\",\"center\":[30,31],\"radius\":3}]"
	    : "[{\"type\":\"slip\",\"center\":[5,10,7],\"radius\":3},{\"type\":\"random_sign\",\"center\":[14,6,12],\"radius\":2.5}]";
	snprintf(json, sizeof json,
	         "{\"method\":\"%s\",\"dimensions\":%d,\"particles\":{\"count\":%d,\"radius\":0.5,\"box\":%s,"
	         "\"initial\":{\"positions\":\"%s\",\"temperature\":1}},"
	         "\"boundaries\":{\"y\":{\"type\":\"walls\",\"lower\":{\"type\":\"specular\"},\"upper\":{\"type\":\"rough\","
	         "\"probability\":0.5}}},\"obstacles\":%s,"
	         "\"gravity\":%s,\"run\":{\"seed\":5,\"until\":{\"time\":100}},\"%s\":{\"cell_size\":2}}",
	         method, dim, dim == 2 ? 1000 : 2000, dim == 2 ? "[60,60]" : "[20,20,20]",
	         strcmp(method, "hsmc") ? "random" : "lattice", obst, dim == 2 ? "[0,-0.5]" : "[0,-0.5,0]", method);
	scene_t sc;
	dsmc_t *d = mc_make(json, &sc, 0);
	double *pos = malloc(sc.count * 3 * sizeof(double));
	double e0 = d ? energy(d) : NAN, worst = 0, gap = d ? min_gap(d, &sc, pos) : -1;
	for (int k = 0; d && k < 800; k++) {
		dsmc_advance(d, INFINITY, UINT64_MAX, 1);
		double rel = fabs(energy(d) - e0) / e0, g = min_gap(d, &sc, pos);
		worst = rel > worst ? rel : worst;
		gap = g < gap ? g : gap;
	}
	dsmc_sample_t sm = {0};
	if (d)
		dsmc_totals(d, &sm);
	ok(d && worst < 1e-10 && gap > -1e-12 && sm.obstacle_collisions > 1000 && sm.collisions > 10000,
	   "%s %dD, elastic obstacles, walls and gravity: E conserved to %.2g (< 1e-10), smallest gap to an obstacle "
	   "%.2g S (> -1e-12) over %llu steps, %llu obstacle hits, %llu collisions", method, dim, worst, gap,
	   (unsigned long long)sm.steps, (unsigned long long)sm.obstacle_collisions, (unsigned long long)sm.collisions);
	free(pos);
	dsmc_destroy(d);
}

/* A dilute elastic gas at rest around a slip obstacle in a periodic box:
 * in equilibrium the density is uniform outside the obstacle (an ideal
 * gas; the slip rule keeps the equilibrium), and the mean force on the
 * obstacle is zero. N = 2000, box 200^2 (nu = 0.04), R = 10. Blocks of 10
 * snapshots 2 time units apart (a particle crosses ~3 diameters between
 * snapshots; the density in a shell relaxes in a crossing time of the shell,
 * ~ 2-5 units), 40 blocks after 100 units of equilibration: the block means
 * count as independent. The density in the shells S < r < S + 2 and S + 2 <
 * r < S + 6 relative to that beyond S + 20 must be 1 within 5 standard
 * errors of the mean over the blocks, each force component 0 within 5 SE.
 * The shells hold ~35 and ~80 particles a snapshot: SE ~ 3%, so a depletion
 * or pile-up of 15% at the obstacle fails. */
static void test_equilibrium(const char *method)
{
	char json[1024];
	snprintf(json, sizeof json,
	         "{\"method\":\"%s\",\"dimensions\":2,\"particles\":{\"count\":2000,\"radius\":0.5,\"box\":[200,200],"
	         "\"initial\":{\"positions\":\"random\",\"temperature\":1}},\"obstacles\":[{\"type\":\"slip\","
	         "\"center\":[80,120],\"radius\":10}],\"run\":{\"seed\":11,\"until\":{\"time\":1000}}}", method);
	scene_t sc;
	dsmc_t *d = mc_make(json, &sc, 0);
	enum { NB = 40, NS = 10 };
	double r1[NB] = {0}, r2[NB] = {0}, fx[NB] = {0}, fy[NB] = {0};
	double *pos = malloc(sc.count * 2 * sizeof(double));
	const double S = 10.5, L = 200, a1 = PI * ((S + 2) * (S + 2) - S * S), a2 = PI * ((S + 6) * (S + 6) - (S + 2) * (S + 2));
	const double afar = L * L - PI * (S + 20) * (S + 20);
	dsmc_sample_t sm;
	if (d) {
		dsmc_advance(d, 100, UINT64_MAX, UINT64_MAX);
		dsmc_sample(d, &sm);
	}
	for (int b = 0; d && b < NB; b++) {
		double c1 = 0, c2 = 0, cf = 0;
		for (int s = 0; s < NS; s++) {
			dsmc_advance(d, dsmc_time(d) + 2, UINT64_MAX, UINT64_MAX);
			dsmc_state(d, pos, NULL);
			for (uint64_t i = 0; i < sc.count; i++) {
				double x = pos[2 * i] - 80, y = pos[2 * i + 1] - 120;
				x -= L * nearbyint(x / L);
				y -= L * nearbyint(y / L);
				double r = sqrt(x * x + y * y);
				c1 += r < S + 2;
				c2 += r >= S + 2 && r < S + 6;
				cf += r >= S + 20;
			}
		}
		dsmc_sample(d, &sm);
		r1[b] = (c1 / a1) / (cf / afar);
		r2[b] = (c2 / a2) / (cf / afar);
		fx[b] = sm.obstacle_impulse[0][0] / sm.interval;
		fy[b] = sm.obstacle_impulse[0][1] / sm.interval;
	}
	double m1, s1, m2, s2, mx, sx, my, sy;
	mean_se(r1, NB, &m1, &s1);
	mean_se(r2, NB, &m2, &s2);
	mean_se(fx, NB, &mx, &sx);
	mean_se(fy, NB, &my, &sy);
	ok(d && fabs(m1 - 1) < 5 * s1 && fabs(m2 - 1) < 5 * s2 && s1 < 0.05,
	   "%s slip obstacle, gas at rest: density next to it / far = %.4f +- %.4f (shell S..S+2), %.4f +- %.4f "
	   "(S+2..S+6): 1 within 5 SE", method, m1, s1, m2, s2);
	/* the pressure on one side is n T (2 S) ~ 2.1: the SE must resolve a fraction of it */
	ok(d && fabs(mx) < 5 * sx && fabs(my) < 5 * sy && sx < 0.2 && sy < 0.2 && sm.obstacle_collisions > 1000,
	   "%s slip obstacle, gas at rest: drag (%.4f +- %.4f, %.4f +- %.4f): 0 within 5 SE (%llu hits)", method, mx, sx,
	   my, sy, (unsigned long long)sm.obstacle_collisions);
	free(pos);
	dsmc_destroy(d);
}

/* A no_slip obstacle at T_o = 2 heats a dilute elastic gas at T = 1
 * (periodic box 60^2, N = 200, nu = 0.044, R = 8): the heating rate is the
 * flux onto the obstacle times the energy each re-emission brings, a
 * property of free flight and of the gas's velocity distribution next to
 * the obstacle, which DSMC must reproduce. Temperatures at t = 40 and 120
 * over 24 independent replicas (seeds) of each method: the means must agree
 * within 5 combined standard errors, and the gas must have heated by more
 * than 10 of them (the test can see heating). */
static void test_heating_vs_ed(void)
{
	enum { NR = 24, NT = 2 };
	const double tt[NT] = {40, 120};
	double te[NT][NR], tm[NT][NR];
	char json[1024];
	int okrun = 1;
	for (int r = 0; r < NR; r++)
		for (int m = 0; m < 2; m++) {
			snprintf(json, sizeof json,
			         "{\"method\":\"%s\",\"dimensions\":2,\"particles\":{\"count\":1000,\"radius\":0.1,\"box\":[60,60],"
			         "\"initial\":{\"positions\":\"random\",\"temperature\":1}},\"obstacles\":[{\"type\":\"no_slip\","
			         "\"center\":[30,30],\"radius\":8,\"temperature\":2}],\"run\":{\"seed\":%d,\"until\":{\"time\":200}}}",
			         m ? "dsmc" : "ed", 100 + r);
			scene_t sc;
			char err[512] = "";
			int rc;
			if (scene_parse(json, strlen(json), &sc, err, sizeof err) != SCENE_OK) {
				diag("%s", err);
				okrun = 0;
				continue;
			}
			if (m) {
				dsmc_t *d = dsmc_create(&sc, 0, &rc, err, sizeof err);
				for (int k = 0; d && k < NT; k++) {
					dsmc_sample_t sm;
					dsmc_advance(d, tt[k], UINT64_MAX, UINT64_MAX);
					dsmc_totals(d, &sm);
					tm[k][r] = sm.kinetic_energy / sc.count;   /* T = 2 E / (D N) = E / N in 2D */
				}
				okrun &= d != NULL;
				dsmc_destroy(d);
			} else {
				ed_t *e = ed_create(&sc, &rc, err, sizeof err);
				for (int k = 0; e && k < NT; k++) {
					ed_sample_t sm;
					ed_advance(e, tt[k], UINT64_MAX, UINT64_MAX);
					ed_totals(e, &sm);
					te[k][r] = sm.kinetic_energy / sc.count;
				}
				okrun &= e != NULL;
				ed_destroy(e);
			}
			if (err[0])
				diag("%s", err);
		}
	for (int k = 0; k < NT; k++) {
		double me, se, mm, sm;
		mean_se(te[k], NR, &me, &se);
		mean_se(tm[k], NR, &mm, &sm);
		double c = sqrt(se * se + sm * sm);
		ok(okrun && fabs(me - mm) < 5 * c && mm - 1 > 10 * c,
		   "no_slip obstacle at T_o = 2 heating a gas at T = 1, t = %g: T ed %.4f +- %.4f, dsmc %.4f +- %.4f: equal "
		   "within 5 combined SE, heated by > 10 SE", tt[k], me, se, mm, sm);
	}
}

/* Checkpoint fields with obstacles: a run restored from its fields after
 * every few steps is bit-for-bit the uninterrupted one (state, samples,
 * obstacle impulses and hits included). Inelastic gas, gravity, a thermal
 * no_slip, a random_sign and a slip obstacle (their random numbers too). */
static void test_restore(const char *method)
{
	char json[1536];
	snprintf(json, sizeof json,
	         "{\"method\":\"%s\",\"dimensions\":2,\"particles\":{\"count\":1500,\"radius\":0.5,\"box\":[50,60],"
	         "\"initial\":{\"positions\":\"random\",\"temperature\":1}},\"collisions\":{\"restitution\":0.8},"
	         "\"boundaries\":{\"y\":{\"type\":\"walls\",\"lower\":{\"type\":\"specular\",\"restitution\":0.8},"
	         "\"upper\":{\"type\":\"thermal\",\"temperature\":1}}},\"obstacles\":[{\"type\":\"no_slip\",\"center\":[10,20],"
	         "\"radius\":4,\"temperature\":1.5,\"accommodation\":0.7},{\"type\":\"random_sign\",\"center\":[35,15],"
	         "\"radius\":5,\"restitution\":0.9},{\"type\":\"slip\",\"center\":[25,45],\"radius\":6}],"
	         "\"gravity\":[0,-0.05],\"run\":{\"seed\":17,\"until\":{\"time\":100}},\"%s\":{\"cell_size\":2}}",
	         method, method);
	scene_t sc;
	char err[512] = "";
	int same_samples, restores;
	dsmc_sample_t x;
	int same = mc_restore_run(json, &sc, &same_samples, &restores, &x, err, sizeof err);
	ok(same && same_samples && x.obstacle_collisions > 100,
	   "%s obstacles, walls, gravity: %d restores: state %s, samples %s (%llu obstacle hits) %s", method, restores,
	   same ? "bit-identical" : "differ", same_samples ? "identical" : "differ",
	   (unsigned long long)x.obstacle_collisions, err);
}

/* What dsmc/hsmc cannot honour with obstacles yet is refused, naming the key. */
/* contact_value "local" with an obstacle (ring_volumes_obst() in dsmc.c):
 * the ring's volume is what lies outside the obstacle's body. An elastic
 * gas at volume fraction 0.3 of the free area around a disk of radius 15
 * in a 60 x 60 box (the body takes 20% of the box): the collision rate with
 * the Enskog rate over that with correction "none" (same scene and seed:
 * the same uniform ideal-gas profile; cells of 2 diameters) is chi(0.3) =
 * 1.773 (Henderson),
 * where the box's mean volume fraction (0.24, what "global" uses) gives
 * 1.57. Tolerance: 4 standard errors of the ratio (51 samples one time
 * unit apart, ~2 collisions per particle between them) plus a bound for
 * the cells the contact circle cuts, whose rings hold the shell the
 * centres cannot reach (up to half the ring in the worst cell): the share
 * of the free area within a cell diagonal of the circle times 1 -
 * chi(0.15)/chi(0.3). */
static void test_local_chi(void)
{
	static const char *const corr[2] = { "\"correction\":\"none\"", "\"correction\":\"enskog\",\"contact_value\":\"local\"" };
	const double W = 60, Ro = 15, nu = 0.3, a = 0.5;
	const int N = (int)(nu * (W * W - PI * Ro * Ro) / (PI * a * a));
	enum { B = 50 };
	double r[2][B], rm[2], rse[2];
	dsmc_params_t pr;
	for (int k = 0; k < 2; k++) {
		char json[1024];
		snprintf(json, sizeof json,
		         "{\"method\":\"dsmc\",\"dimensions\":2,\"particles\":{\"count\":%d,\"radius\":0.5,\"box\":[60,60],"
		         "\"initial\":{\"positions\":\"random\",\"temperature\":1}},\"run\":{\"seed\":3,\"until\":{\"time\":60}},"
		         "\"obstacles\":[{\"type\":\"slip\",\"center\":[30,30],\"radius\":15}],\"dsmc\":{%s,\"cell_size\":2}}", N,
		         corr[k]);
		scene_t sc;
		dsmc_t *d = mc_make(json, &sc, 0);
		if (!d || dsmc_params(&sc, &pr, NULL, 0) != DSMC_OK) {
			dsmc_destroy(d);
			ok(0, "local chi with an obstacle: setup");
			return;
		}
		dsmc_sample_t sm;
		dsmc_advance(d, 10, UINT64_MAX, UINT64_MAX);
		dsmc_sample(d, &sm);
		for (int b = 0; b < B; b++) {
			dsmc_advance(d, 11.0 + b, UINT64_MAX, UINT64_MAX);
			dsmc_sample(d, &sm);
			double T = sm.ekin_time_integral / sm.interval / N;
			r[k][b] = (double)sm.interval_collisions * 2.0 / N / sm.interval / sqrt(T);
		}
		dsmc_destroy(d);
		mean_se(r[k], B, &rm[k], &rse[k]);
	}
	const double chi = dsmc_contact_value(2, nu), chib = dsmc_contact_value(2, N * PI * a * a / (W * W));
	const double h = W / floor(W / pr.cell_edge), S = Ro + a, reach = S + sqrt(2.0) * h;
	const double share = PI * (reach * reach - S * S) / (W * W - PI * Ro * Ro);
	const double model = share * (1 - dsmc_contact_value(2, nu / 2) / chi) * chi;
	const double ratio = rm[1] / rm[0], se = ratio * sqrt(pow(rse[0] / rm[0], 2) + pow(rse[1] / rm[1], 2));
	const double tol = 4 * se + model;
	ok(fabs(ratio - chi) < tol && fabs(chib - chi) > tol,
	   "local chi around an obstacle: rate ratio enskog/local : none = %.4f +- %.4f, chi(0.3) %.4f (tolerance %.4f; "
	   "chi at the box's mean %.4f)", ratio, se, chi, tol, chib);
}

static void test_refusals(void)
{
	static const struct {
		const char *json, *key;
	} bad[] = {
		{ "{\"method\":\"hsmc\",\"dimensions\":2,\"particles\":{\"count\":100,\"box\":[40,40]},"
		  "\"run\":{\"until\":{\"time\":5}},\"obstacles\":[{\"type\":\"slip\",\"center\":[20,20],\"radius\":3}],"
		  "\"boundaries\":{\"y\":{\"type\":\"walls\",\"lower\":{\"type\":\"vibrating\",\"amplitude\":0.5,\"frequency\":1},"
		  "\"upper\":{\"type\":\"specular\"}}}}", "obstacles: " },
		{ "{\"method\":\"auto\",\"dimensions\":2,\"particles\":{\"count\":100,\"box\":[40,40]},"
		  "\"accuracy\":{\"temperature\":0.05},\"run\":{\"until\":{\"time\":5}},\"obstacles\":[{\"type\":\"slip\",\"center\":[20,20],\"radius\":3}]}",
		  "obstacles: " },
	};
	for (size_t k = 0; k < sizeof bad / sizeof bad[0]; k++) {
		scene_t sc;
		char err[512] = "";
		int rc = scene_parse(bad[k].json, strlen(bad[k].json), &sc, err, sizeof err);
		ok(rc == SCENE_EINVAL && !strncmp(err, bad[k].key, strlen(bad[k].key)), "refused: %s", err);
	}
}

int main(void)
{
	test_refusals();
	test_energy("dsmc", 2);
	test_energy("dsmc", 3);
	test_energy("hsmc", 2);
	test_energy("hsmc", 3);
	test_restore("dsmc");
	test_restore("hsmc");
	test_equilibrium("dsmc");
	test_equilibrium("hsmc");
	test_heating_vs_ed();
	test_local_chi();
	plan(tap_n);
	return done_testing();
}
