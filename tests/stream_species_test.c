/* Tests of seed 001's dense open stream with a mixture (issue 12): a dispenser delivers the scene's species in its number fractions at the inlet's eta, T (each species) and U, and a filter holds them; slots keep their species; checkpoints are exact. */
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

/* The two species of these tests: A (radius 0.5, mass 1) and B (radius
 * 0.35, mass 0.5); a 2D channel along x, box L x 20, y periodic,
 * initially a relaxed lattice of NA + NB disks at eta moving at U = 0.1
 * with T = 0.02; at x = 0 a dispenser at (eta, U, T), layers of the
 * default thickness (two of A's diameters); at x = L an open wall with a
 * filter 4 from it (turn-back at T = 0.02). coll: the "collisions" object
 * ("" for elastic). */
static const double RA = 0.5, RB = 0.35, MA = 1.0, MB = 0.5;

static void channel_c(char *buf, size_t len, double L, double eta, uint64_t na, uint64_t nb, const char *coll,
                      const char *comp, uint64_t seed)
{
	snprintf(buf, len,
	         "{\"method\":\"ed\",\"dimensions\":2,\"particles\":{\"species\":["
	         "{\"name\":\"A\",\"count\":%llu,\"radius\":%.17g,\"mass\":%.17g},"
	         "{\"name\":\"B\",\"count\":%llu,\"radius\":%.17g,\"mass\":%.17g}],\"box\":[%.17g,20],"
	         "\"initial\":{\"positions\":\"lattice\",\"temperature\":0.02,\"velocity\":[0.1,0],"
	         "\"relax\":{\"collisions_per_particle\":20}}},%s"
	         "\"boundaries\":{\"x\":{\"type\":\"walls\","
	         "\"lower\":{\"type\":\"dispenser\",\"volume_fraction\":%.17g,\"velocity\":[0.1,0],\"temperature\":0.02%s},"
	         "\"upper\":{\"type\":\"open\",\"filter\":{\"distance\":4,\"velocity\":[0.1,0],\"temperature\":0.02}}}},"
	         "\"run\":{\"seed\":%llu,\"until\":{\"time\":1}}}",
	         (unsigned long long)na, RA, MA, (unsigned long long)nb, RB, MB, L, coll, eta, comp, (unsigned long long)seed);
}

/* The same with the scene's composition (no "composition" key). */
static void channel(char *buf, size_t len, double L, double eta, uint64_t na, uint64_t nb, const char *coll,
                    uint64_t seed)
{
	channel_c(buf, len, L, eta, na, nb, coll, "", seed);
}

enum { NSL = 4, NB = 10 };

/* Per slice of [x0, x1) and per time block (frames every dt over [t0,
 * t1]): the volume fraction (the disks' areas per slice area), B's number
 * fraction, the flow velocity along x (number mean) and each species'
 * temperature m <|v - u_k|^2> / D (u_k its mean velocity in the slice over
 * the block), in D dimensions for a channel of cross-section A (the width
 * in 2D, the area in 3D). */
typedef struct {
	double eta[NSL][NB], xb[NSL][NB], u[NSL][NB], T[2][NSL][NB];
	double min_gap;
} profile_t;

static int measure_d(ed_t *ed, const uint8_t *sp, int D, double A, double t0, double t1, double dt, double x0,
                     double x1, profile_t *pr)
{
	const size_t N = ed_slots(ed);
	double *pos = malloc(N * D * sizeof(double)), *vel = malloc(N * D * sizeof(double));
	const double wsl = (x1 - x0) / NSL, area = wsl * A, mass[2] = {MA, MB};
	const double vp[2] = {D == 2 ? M_PI * RA * RA : 4.0 / 3.0 * M_PI * RA * RA * RA,
	                      D == 2 ? M_PI * RB * RB : 4.0 / 3.0 * M_PI * RB * RB * RB};
	const int frames = (int)llround((t1 - t0) / dt), per = frames / NB;
	int rc = 1;
	pr->min_gap = INFINITY;
	if (!pos || !vel || per < 1)
		goto done;
	for (int b = 0; b < NB; b++) {
		double c[2][NSL] = {{0}}, vol[NSL] = {0}, sv[2][NSL][3] = {{{0}}}, sv2[2][NSL] = {{0}};
		for (int f = 0; f < per; f++) {
			if (ed_advance(ed, t0 + (b * per + f + 1) * dt, UINT64_MAX, UINT64_MAX) != ED_OK)
				goto done;
			ed_state(ed, pos, vel);
			for (size_t i = 0; i < N; i++) {
				const double *r = pos + D * i, *v = vel + D * i;
				if (isnan(r[0]) || r[0] < x0 || r[0] >= x1)
					continue;
				int k = (int)((r[0] - x0) / wsl);
				if (k >= NSL)
					k = NSL - 1;
				const int s = sp[i];
				c[s][k] += 1.0;
				vol[k] += vp[s];
				for (int j = 0; j < D; j++) {
					sv[s][k][j] += v[j];
					sv2[s][k] += v[j] * v[j];
				}
			}
		}
		double g = ed_min_gap(ed);
		if (g < pr->min_gap)
			pr->min_gap = g;
		for (int k = 0; k < NSL; k++) {
			const double n = c[0][k] + c[1][k];
			pr->eta[k][b] = vol[k] / per / area;
			pr->xb[k][b] = c[1][k] / n;
			pr->u[k][b] = (sv[0][k][0] + sv[1][k][0]) / n;
			for (int s = 0; s < 2; s++) {
				double u2 = 0.0;
				for (int j = 0; j < D; j++)
					u2 += (sv[s][k][j] / c[s][k]) * (sv[s][k][j] / c[s][k]);
				pr->T[s][k][b] = mass[s] * (sv2[s][k] / c[s][k] - u2) / D;
			}
		}
	}
	rc = 0;
done:
	free(pos);
	free(vel);
	return rc;
}

static int measure(ed_t *ed, const uint8_t *sp, double t0, double t1, double dt, double x0, double x1, profile_t *pr)
{
	return measure_d(ed, sp, 2, 20.0, t0, t1, dt, x0, x1, pr);
}

/* Test 1: a channel 40 long, A:B = 505:217 (B's number fraction 0.3006)
 * at eta = 0.6, T = 0.02, U = 0.1 with dispenser and filter, run for 11
 * transits (L / U = 400). From t = 400 to 4400, in four slices between
 * the piston's reach and the filter region (x in [6, 32)), the volume
 * fraction, B's number fraction, each species' temperature and the flow
 * velocity hold what the dispenser delivers. Tolerance: each slice's mean
 * over 10 blocks of one transit each (what a slice holds is renewed by the
 * flow once per block, long against the sound crossing 20 / 1.4 and the
 * mean free time: the blocks are taken as independent, as in
 * stream_test's one-species channel) within 5 standard errors of those
 * blocks. Targets: eta (the dispenser's mean layer volume, eta h W, exact
 * on average), the scene's fraction 217 / 722 (the templates' mean
 * composition is n x_B to within 1 / 32 of a particle), T = 0.02 for each
 * species (the layers draw each species' velocities at its own mass) and
 * U. Then: frozen particles move at U exactly, ids are unique, every
 * present particle's species is its row's (ed_sample's per-species counts
 * against scene_row_species()), nothing rejected, no overlap. */
static void test_holds(void)
{
	char json[4096];
	scene_t sc;
	const uint64_t na = 505, nb = 217;
	const double eta = 0.6, xb = (double)nb / (double)(na + nb);
	channel(json, sizeof json, 40.0, eta, na, nb, "", 3);
	ed_t *ed = make(json, &sc);
	profile_t pr;
	uint8_t *sp = ed ? malloc(ed_slots(ed)) : NULL;
	if (sp)
		scene_row_species(&sc, sp, NULL);
	if (!ed || !sp || measure(ed, sp, 400.0, 4400.0, 2.0, 6.0, 32.0, &pr)) {
		for (int k = 0; k < 5; k++)
			ok(0, "mixture dispenser + filter: run");
		ed_destroy(ed);
		free(sp);
		return;
	}
	int good_eta = 1, good_x = 1, good_T = 1, good_u = 1;
	for (int k = 0; k < NSL; k++) {
		double me, se, mx, sx, mu, su, mT[2], sT[2];
		mean_se(pr.eta[k], NB, &me, &se);
		mean_se(pr.xb[k], NB, &mx, &sx);
		mean_se(pr.u[k], NB, &mu, &su);
		for (int s = 0; s < 2; s++)
			mean_se(pr.T[s][k], NB, &mT[s], &sT[s]);
		diag("slice %d: eta %.4f +- %.4f, x_B %.4f +- %.4f, T_A %.5f +- %.5f, T_B %.5f +- %.5f, u %.4f +- %.4f", k,
		     me, se, mx, sx, mT[0], sT[0], mT[1], sT[1], mu, su);
		good_eta &= fabs(me - eta) < 5.0 * se;
		good_x &= fabs(mx - xb) < 5.0 * sx;
		good_T &= fabs(mT[0] - 0.02) < 5.0 * sT[0] && fabs(mT[1] - 0.02) < 5.0 * sT[1];
		good_u &= fabs(mu - 0.1) < 5.0 * su;
	}
	ok(good_eta && pr.min_gap > -1e-9, "mixture dispenser + filter at eta 0.6: volume fraction holds along the "
	   "channel (each of 4 slices within 5 SE of 0.6), no overlap (min gap %.2g)", pr.min_gap);
	ok(good_x, "mixture: B's number fraction holds along the channel (within 5 SE of %.4f)", xb);
	ok(good_T, "mixture: each species' temperature holds along the channel (within 5 SE of 0.02)");
	ok(good_u, "mixture: the stream flows at U = 0.1 (within 5 SE)");
	const size_t N = ed_slots(ed);
	double *pos = malloc(N * 2 * sizeof(double)), *vel = malloc(N * 2 * sizeof(double));
	int64_t *ids = malloc(N * sizeof(int64_t));
	uint8_t *seen = NULL;
	size_t frozen = 0, bad = 0, dup = 0;
	uint64_t cnt[2] = {0, 0};
	ed_state(ed, pos, vel);
	ed_labels(ed, ids);
	int64_t maxid = 0;
	for (size_t i = 0; i < N; i++)
		if (ids[i] > maxid)
			maxid = ids[i];
	seen = calloc((size_t)maxid + 1, 1);
	for (size_t i = 0; i < N; i++) {
		if (isnan(pos[2 * i]))
			continue;
		cnt[sp[i]]++;
		if (ids[i] < 0 || seen[ids[i]]++)
			dup++;
		if (pos[2 * i] > 36.0) {
			frozen++;
			bad += vel[2 * i] != 0.1 || vel[2 * i + 1] != 0.0;
		}
	}
	ed_sample_t sm;
	ed_sample(ed, &sm);
	ok(frozen > 50 && bad == 0 && dup == 0 && sm.n_species == 2 && sm.species_count[0] == cnt[0] &&
	   sm.species_count[1] == cnt[1] && sm.wall_inflow[0] > 6000 && sm.wall_outflow[1] > 6000 &&
	   sm.wall_rejected[0] == 0,
	   "mixture filter: the %zu particles beyond the plane move at U exactly (%zu do not); ids unique (%zu "
	   "repeated); species by row %llu + %llu as the engine counts them (%llu + %llu); %llu in (%llu rejected), "
	   "%llu out", frozen, bad, dup, (unsigned long long)cnt[0], (unsigned long long)cnt[1],
	   (unsigned long long)sm.species_count[0], (unsigned long long)sm.species_count[1],
	   (unsigned long long)sm.wall_inflow[0], (unsigned long long)sm.wall_rejected[0],
	   (unsigned long long)sm.wall_outflow[1]);
	free(pos);
	free(vel);
	free(ids);
	free(seen);
	free(sp);
	ed_destroy(ed);
}

/* Test 2: an inelastic mixture stream (restitution 0.97, A-B pairs 0.9,
 * TC) with dispenser and filter, copied through its state fields between
 * recharges (the free stacks per species are rebuilt from the presence
 * flags), goes on bit for bit: events, inflow, outflow, wall impulses,
 * every slot's position, velocity and id, the per-species counts. */
static void test_checkpoint(void)
{
	char json[4096];
	scene_t sc;
	channel(json, sizeof json, 30.0, 0.6, 379, 162,
	        "\"collisions\":{\"restitution\":0.97,\"tc\":0.05,"
	        "\"restitution_pairs\":[{\"a\":\"A\",\"b\":\"B\",\"restitution\":0.9}]},",
	        11);
	ed_t *a, *b;
	if (!checkpoint_pair(json, &sc, 13.0, 55.0, &a, &b)) {
		ok(0, "mixture checkpoint with dispenser and filter: restore");
		return;
	}
	ed_advance(a, 250.0, UINT64_MAX, UINT64_MAX);
	ed_advance(b, 250.0, UINT64_MAX, UINT64_MAX);
	ed_sample_t sa, sb;
	ed_sample(a, &sa);
	ed_sample(b, &sb);
	ok(sa.events == sb.events && sa.wall_inflow[0] == sb.wall_inflow[0] && sa.wall_inflow[0] > 0 &&
	   sa.wall_outflow[1] == sb.wall_outflow[1] && sa.wall_outflow[1] > 0 &&
	   !memcmp(sa.wall_impulse, sb.wall_impulse, sizeof sa.wall_impulse) && same_slots(a, b) &&
	   !memcmp(sa.species_count, sb.species_count, sizeof sa.species_count) &&
	   sa.ekin_time_integral == sb.ekin_time_integral,
	   "mixture checkpoint (dispenser, filter, TC, pair restitution): restored run identical bit for bit after "
	   "%llu events (%llu in, %llu out)", (unsigned long long)sa.events, (unsigned long long)sa.wall_inflow[0],
	   (unsigned long long)sa.wall_outflow[1]);
	ed_destroy(a);
	ed_destroy(b);
}

/* Test 3, 3D: a channel 16 x 6.5 x 6.5 (specular walls across y, z
 * periodic) of the two species (A:B = 315:136) at eta = 0.28 (the
 * layer's starting rows are a largest diameter apart: two rows of 5 x 6
 * sites hold it), inelastic
 * with pair restitution and TC, dispenser and filter; copied through its
 * state fields at t = 55, both go on to t = 125 (six recharges, at t = 20,
 * 40, ..., 120; no layer particle reaches the filter plane at x = 13 by
 * then, so every particle placed is still present). The copy is identical
 * bit for bit; nothing rejected, no overlap; the placed particles' species
 * (their rows') add up to the six layers' composition: B's count within 5
 * sqrt(L) of L nbar x_B (L = 6 layers, nbar = eta h W1 W2 / v_p the mean
 * layer count: each layer's B count differs from its mean n x_B by less
 * than 1 + 1 / 32 (its template's floor or ceiling, the particle left
 * out), so the sum over L layers has a standard deviation below sqrt(L))
 * and A's likewise. */
static void test_3d(void)
{
	const uint64_t na = 315, nb = 136;
	char json[4096];
	snprintf(json, sizeof json,
	         "{\"method\":\"ed\",\"dimensions\":3,\"particles\":{\"species\":["
	         "{\"name\":\"A\",\"count\":%llu,\"radius\":%.17g,\"mass\":%.17g},"
	         "{\"name\":\"B\",\"count\":%llu,\"radius\":%.17g,\"mass\":%.17g}],\"box\":[16,6.5,6.5],"
	         "\"initial\":{\"positions\":\"lattice\",\"temperature\":0.02,\"velocity\":[0.1,0,0]}},"
	         "\"collisions\":{\"restitution\":0.97,\"tc\":0.05,"
	         "\"restitution_pairs\":[{\"a\":\"A\",\"b\":\"B\",\"restitution\":0.9}]},"
	         "\"boundaries\":{\"x\":{\"type\":\"walls\","
	         "\"lower\":{\"type\":\"dispenser\",\"volume_fraction\":0.28,\"velocity\":[0.1,0,0],\"temperature\":0.02},"
	         "\"upper\":{\"type\":\"open\",\"filter\":{\"distance\":3,\"velocity\":[0.1,0,0],\"temperature\":0.02}}},"
	         "\"y\":{\"type\":\"walls\",\"lower\":{\"type\":\"specular\"},\"upper\":{\"type\":\"specular\"}}},"
	         "\"run\":{\"seed\":23,\"until\":{\"time\":1}}}",
	         (unsigned long long)na, RA, MA, (unsigned long long)nb, RB, MB);
	scene_t sc;
	ed_t *a, *b;
	if (!checkpoint_pair(json, &sc, 13.0, 55.0, &a, &b)) {
		ok(0, "3D mixture checkpoint: restore");
		ok(0, "3D mixture: layers' composition");
		return;
	}
	ed_advance(a, 125.0, UINT64_MAX, UINT64_MAX);
	ed_advance(b, 125.0, UINT64_MAX, UINT64_MAX);
	ed_sample_t sa, sb;
	ed_sample(a, &sa);
	ed_sample(b, &sb);
	const double gap = ed_min_gap(a);
	ok(sa.events == sb.events && sa.wall_inflow[0] == sb.wall_inflow[0] && same_slots_d(a, b, 3) &&
	   !memcmp(sa.species_count, sb.species_count, sizeof sa.species_count) && sa.wall_rejected[0] == 0 && gap > -1e-9,
	   "3D mixture checkpoint (dispenser, filter, TC, pair restitution, walls across y): restored run identical bit "
	   "for bit after %llu events (%llu in, %llu rejected, min gap %.2g)", (unsigned long long)sa.events,
	   (unsigned long long)sa.wall_inflow[0], (unsigned long long)sa.wall_rejected[0], gap);
	const size_t N = ed_slots(a);
	uint8_t *sp = malloc(N);
	int64_t *ids = malloc(N * sizeof(int64_t));
	uint64_t placed[2] = {0, 0};
	if (sp && ids) {
		scene_row_species(&sc, sp, NULL);
		ed_labels(a, ids);
		for (size_t i = 0; i < N; i++)
			if (ids[i] >= (int64_t)(na + nb))
				placed[sp[i]]++;
	}
	const double L = 6.0, xb = (double)nb / (double)(na + nb);
	const double vp = (1.0 - xb) * 4.0 / 3.0 * M_PI * RA * RA * RA + xb * 4.0 / 3.0 * M_PI * RB * RB * RB;
	const double nbar = 0.28 * 2.0 * 6.5 * 6.5 / vp, tol = 5.0 * sqrt(L);
	ok(placed[0] + placed[1] == sa.wall_inflow[0] && fabs((double)placed[1] - L * nbar * xb) < tol &&
	   fabs((double)placed[0] - L * nbar * (1.0 - xb)) < tol,
	   "3D mixture: the six layers placed %llu A + %llu B (all present), expected %.1f + %.1f (within %.1f)",
	   (unsigned long long)placed[0], (unsigned long long)placed[1], L * nbar * (1.0 - xb), L * nbar * xb, tol);
	free(sp);
	free(ids);
	ed_destroy(a);
	ed_destroy(b);
}


/* Test 4, a dispenser composition of its own ("composition": [2, 3], B's
 * fraction 0.6) at eta = 0.5 in the channel of test 1 filled at the start
 * with A:B = 421:180 (fraction 0.2995; at 0.6 the layer of 45 would not
 * fit two rows of largest-diameter sites): after two transits (the
 * initial particles flushed out at U), over t in [800, 4800] in 10 blocks
 * of one transit, each of the four slices holds B's fraction 0.6, eta 0.5
 * and T 0.02 for each species
 * within 5 standard errors of the blocks (as test 1). The spare slots are
 * split in the dispenser's fractions, so B's rows do not run out. */
static void test_composition(void)
{
	char json[4096];
	scene_t sc;
	channel_c(json, sizeof json, 40.0, 0.5, 421, 180, "", ",\"composition\":[2,3]", 5);
	ed_t *ed = make(json, &sc);
	profile_t pr;
	uint8_t *sp = ed ? malloc(ed_slots(ed)) : NULL;
	if (sp)
		scene_row_species(&sc, sp, NULL);
	if (!ed || !sp || measure(ed, sp, 800.0, 4800.0, 2.0, 6.0, 32.0, &pr)) {
		ok(0, "dispenser composition: run");
		ok(0, "dispenser composition: eta and temperatures");
		ed_destroy(ed);
		free(sp);
		return;
	}
	int good_x = 1, good_eta = 1, good_T = 1;
	for (int k = 0; k < NSL; k++) {
		double me, se, mx, sx, mT[2], sT[2];
		mean_se(pr.eta[k], NB, &me, &se);
		mean_se(pr.xb[k], NB, &mx, &sx);
		for (int s = 0; s < 2; s++)
			mean_se(pr.T[s][k], NB, &mT[s], &sT[s]);
		diag("composition slice %d: eta %.4f +- %.4f, x_B %.4f +- %.4f, T_A %.5f +- %.5f, T_B %.5f +- %.5f", k, me, se,
		     mx, sx, mT[0], sT[0], mT[1], sT[1]);
		good_x &= fabs(mx - 0.6) < 5.0 * sx;
		good_eta &= fabs(me - 0.5) < 5.0 * se;
		good_T &= fabs(mT[0] - 0.02) < 5.0 * sT[0] && fabs(mT[1] - 0.02) < 5.0 * sT[1];
	}
	ed_sample_t sm;
	ed_sample(ed, &sm);
	ok(good_x, "dispenser composition [2, 3]: B's number fraction 0.6 along the channel (within 5 SE; the box "
	   "started at 0.2995)");
	ok(good_eta && good_T && pr.min_gap > -1e-9 && sm.wall_rejected[0] == 0,
	   "dispenser composition: eta 0.5 and each species' T 0.02 hold (within 5 SE), no overlap, none rejected");
	free(sp);
	ed_destroy(ed);
}

/* Test 5, the 3D stream: a channel 24 x 6.5 x 6.5 (y and z periodic) of
 * A:B = 472:205 (B's fraction 0.3028) at eta = 0.28, T = 0.02, U = 0.1,
 * dispenser and filter (4 from the outlet), 11 transits: over t in [240,
 * 2640] in 10 blocks of one transit, four slices of x in [4, 18) hold B's
 * fraction and each species' T within 5 standard errors of the blocks (as
 * test 1) of 205 / 677 and 0.02, and the volume flux eta u (block by block)
 * within 5 of its standard errors of what the piston delivers, eta U =
 * 0.028; none rejected, no overlap. eta and u alone are not asserted at 5
 * block SE in 3D: the whole channel's density and speed drift together
 * over several transits (seeds 29-32: slice means eta = 0.2775-0.2828, u =
 * 0.0989-0.1009, each run's slices offset together, as the one-species 3D
 * channel's seed scatter of twice the blocks' SE), while their product
 * holds; a wrong layer count or composition would move the flux or x_B. */
static void test_holds_3d(void)
{
	const uint64_t na = 472, nb = 205;
	const double eta = 0.28, xb = (double)nb / (double)(na + nb);
	char json[4096];
	snprintf(json, sizeof json,
	         "{\"method\":\"ed\",\"dimensions\":3,\"particles\":{\"species\":["
	         "{\"name\":\"A\",\"count\":%llu,\"radius\":%.17g,\"mass\":%.17g},"
	         "{\"name\":\"B\",\"count\":%llu,\"radius\":%.17g,\"mass\":%.17g}],\"box\":[24,6.5,6.5],"
	         "\"initial\":{\"positions\":\"lattice\",\"temperature\":0.02,\"velocity\":[0.1,0,0],"
	         "\"relax\":{\"collisions_per_particle\":20}}},"
	         "\"boundaries\":{\"x\":{\"type\":\"walls\","
	         "\"lower\":{\"type\":\"dispenser\",\"volume_fraction\":%.17g,\"velocity\":[0.1,0,0],\"temperature\":0.02},"
	         "\"upper\":{\"type\":\"open\",\"filter\":{\"distance\":4,\"velocity\":[0.1,0,0],\"temperature\":0.02}}}},"
	         "\"run\":{\"seed\":29,\"until\":{\"time\":1}}}",
	         (unsigned long long)na, RA, MA, (unsigned long long)nb, RB, MB, eta);
	scene_t sc;
	ed_t *ed = make(json, &sc);
	profile_t pr;
	uint8_t *sp = ed ? malloc(ed_slots(ed)) : NULL;
	if (sp)
		scene_row_species(&sc, sp, NULL);
	if (!ed || !sp || measure_d(ed, sp, 3, 6.5 * 6.5, 240.0, 2640.0, 2.0, 4.0, 18.0, &pr)) {
		ok(0, "3D mixture stream: run");
		ok(0, "3D mixture stream: temperatures and flow");
		ed_destroy(ed);
		free(sp);
		return;
	}
	int good_flux = 1, good_x = 1, good_T = 1;
	for (int k = 0; k < NSL; k++) {
		double me, se, mx, sx, mu, su, mT[2], sT[2], fl[NB], mf, sf;
		for (int b = 0; b < NB; b++)
			fl[b] = pr.eta[k][b] * pr.u[k][b];
		mean_se(fl, NB, &mf, &sf);
		mean_se(pr.eta[k], NB, &me, &se);
		mean_se(pr.xb[k], NB, &mx, &sx);
		mean_se(pr.u[k], NB, &mu, &su);
		for (int s = 0; s < 2; s++)
			mean_se(pr.T[s][k], NB, &mT[s], &sT[s]);
		diag("3D slice %d: eta %.4f +- %.4f, u %.4f +- %.4f, eta u %.5f +- %.5f, x_B %.4f +- %.4f, T_A %.5f +- %.5f, "
		     "T_B %.5f +- %.5f", k, me, se, mu, su, mf, sf, mx, sx, mT[0], sT[0], mT[1], sT[1]);
		good_flux &= fabs(mf - eta * 0.1) < 5.0 * sf;
		good_x &= fabs(mx - xb) < 5.0 * sx;
		good_T &= fabs(mT[0] - 0.02) < 5.0 * sT[0] && fabs(mT[1] - 0.02) < 5.0 * sT[1];
	}
	ed_sample_t sm;
	ed_sample(ed, &sm);
	ok(good_flux && good_x && pr.min_gap > -1e-9 && sm.wall_rejected[0] == 0,
	   "3D mixture stream at eta 0.28: volume flux eta u = 0.028 and B's fraction %.4f hold in each of 4 slices "
	   "(within 5 SE), no overlap (min gap %.2g), %llu in, none rejected", xb, pr.min_gap,
	   (unsigned long long)sm.wall_inflow[0]);
	ok(good_T, "3D mixture stream: each species' T 0.02 holds (within 5 SE)");
	free(sp);
	ed_destroy(ed);
}

/* Test 6, a polydisperse species in the stream: A (radius 0.5, mass 1)
 * and B with radii uniform in [0.3, 0.4] (mass 0.5), A:B = 315:135, in a
 * 2D channel 30 x 20 at eta = 0.5, T = 0.02, U = 0.1 with dispenser and
 * filter (the scene of test 1 otherwise). Every slot keeps the radius
 * scene_row_species() gives it (the initial rows' draws, the empty rows'
 * draws of their own); a layer's B particle takes a free B slot at
 * random. After one transit (L / U = 300), over t in [300, 3300] in 10
 * blocks of one transit, in four slices of x in [6, 22): the volume
 * fraction (each disk's own area) and B's mean radius and radius variance
 * (over the B disks present in the slice through the block). Tolerances,
 * 5 standard errors: for eta those of the blocks (taken as independent as
 * in test 1) and, in quadrature, the scatter of the target itself (the
 * layers' B disks are drawn from the M_B slots of B, whose radii are M_B
 * independent draws: their mean area differs from E[pi r^2] by sd(pi r^2)
 * / sqrt(M_B), which moves eta by x_B eta sd / (sqrt(M_B) v_p)); for B's
 * mean radius mu = 0.35 and variance w^2 / 12 (w = 0.1) likewise the
 * blocks' SE and the slots' sampling error, sigma / sqrt(M_B) for the
 * mean and w^2 / sqrt(180 M_B) for the variance (var of a sample variance:
 * (mu_4 - sigma^4) / M, mu_4 = w^4 / 80 for a uniform law). Then the same
 * scene copied through its state fields goes on bit for bit (the random
 * slot choice draws from the checkpointed stream and free stacks). */
static void test_polydisperse(void)
{
	const uint64_t na = 315, nb = 135;
	const double eta = 0.5, lo = 0.3, hi = 0.4, w = hi - lo, L = 30.0;
	char json[4096];
	snprintf(json, sizeof json,
	         "{\"method\":\"ed\",\"dimensions\":2,\"particles\":{\"species\":["
	         "{\"name\":\"A\",\"count\":%llu,\"radius\":%.17g,\"mass\":%.17g},"
	         "{\"name\":\"B\",\"count\":%llu,\"radius_range\":[%.17g,%.17g],\"mass\":%.17g}],\"box\":[%.17g,20],"
	         "\"initial\":{\"positions\":\"lattice\",\"temperature\":0.02,\"velocity\":[0.1,0],"
	         "\"relax\":{\"collisions_per_particle\":20}}},"
	         "\"boundaries\":{\"x\":{\"type\":\"walls\","
	         "\"lower\":{\"type\":\"dispenser\",\"volume_fraction\":%.17g,\"velocity\":[0.1,0],\"temperature\":0.02},"
	         "\"upper\":{\"type\":\"open\",\"filter\":{\"distance\":4,\"velocity\":[0.1,0],\"temperature\":0.02}}}},"
	         "\"run\":{\"seed\":7,\"until\":{\"time\":1}}}",
	         (unsigned long long)na, RA, MA, (unsigned long long)nb, lo, hi, MB, L, eta);
	scene_t sc;
	ed_t *ed = make(json, &sc);
	const size_t N = ed ? ed_slots(ed) : 0;
	uint8_t *sp = N ? malloc(N) : NULL;
	double *rad = N ? malloc(N * sizeof(double)) : NULL, *pos = N ? malloc(N * 2 * sizeof(double)) : NULL;
	double *vel = N ? malloc(N * 2 * sizeof(double)) : NULL;
	enum { NS = 4, NBK = 10 };
	const double x0 = 6.0, x1 = 22.0, wsl = (x1 - x0) / NS, dt = 2.0, t0 = 300.0, tb = 300.0;
	double e[NS][NBK], mr[NS][NBK], vr[NS][NBK], gap = INFINITY;
	int run_ok = ed && sp && rad && pos && vel;
	if (run_ok)
		scene_row_species(&sc, sp, rad);
	/* the slots: B's rows, their radii in [lo, hi] */
	size_t mb = 0, out_of_range = 0;
	for (size_t i = 0; run_ok && i < N; i++)
		if (sp[i] == 1) {
			mb++;
			out_of_range += !(rad[i] >= lo && rad[i] <= hi);
		} else {
			out_of_range += rad[i] != RA;
		}
	const int per = (int)llround(tb / dt);
	for (int b = 0; run_ok && b < NBK; b++) {
		double vol[NS] = {0}, c[NS] = {0}, s1[NS] = {0}, s2[NS] = {0};
		for (int f = 0; f < per && run_ok; f++) {
			if (ed_advance(ed, t0 + b * tb + (f + 1) * dt, UINT64_MAX, UINT64_MAX) != ED_OK) {
				run_ok = 0;
				break;
			}
			ed_state(ed, pos, vel);
			for (size_t i = 0; i < N; i++) {
				const double x = pos[2 * i];
				if (isnan(x) || x < x0 || x >= x1)
					continue;
				int k = (int)((x - x0) / wsl);
				if (k >= NS)
					k = NS - 1;
				vol[k] += M_PI * rad[i] * rad[i];
				if (sp[i] == 1) {
					c[k] += 1.0;
					s1[k] += rad[i];
					s2[k] += rad[i] * rad[i];
				}
			}
		}
		const double g = run_ok ? ed_min_gap(ed) : 0.0;
		if (g < gap)
			gap = g;
		for (int k = 0; k < NS; k++) {
			e[k][b] = vol[k] / per / (wsl * 20.0);
			mr[k][b] = s1[k] / c[k];
			vr[k][b] = s2[k] / c[k] - mr[k][b] * mr[k][b];
		}
	}
	if (!run_ok) {
		ok(0, "polydisperse dispenser: run");
		ok(0, "polydisperse dispenser: radius distribution");
		ok(0, "polydisperse dispenser: checkpoint");
		goto done;
	}
	const double xb = (double)nb / (double)(na + nb), er2 = (hi * hi * hi - lo * lo * lo) / (3.0 * w);
	const double er4 = (pow(hi, 5) - pow(lo, 5)) / (5.0 * w), sd_a = M_PI * sqrt(er4 - er2 * er2);
	const double vp = (1.0 - xb) * M_PI * RA * RA + xb * M_PI * er2, mu = 0.5 * (lo + hi), var = w * w / 12.0;
	const double pe = xb * eta * sd_a / (sqrt((double)mb) * vp);   /* the slots' sampling error of eta */
	const double pm = sqrt(var / (double)mb), pv = w * w / sqrt(180.0 * (double)mb);
	int good_eta = 1, good_m = 1, good_v = 1;
	for (int k = 0; k < NS; k++) {
		double me, se, mm, sm, mv, sv;
		mean_se(e[k], NBK, &me, &se);
		mean_se(mr[k], NBK, &mm, &sm);
		mean_se(vr[k], NBK, &mv, &sv);
		diag("polydisperse slice %d: eta %.4f +- %.4f (+- %.4f slots), B radius mean %.5f +- %.5f (+- %.5f), "
		     "variance %.3g +- %.2g (+- %.2g)", k, me, se, pe, mm, sm, pm, mv, sv, pv);
		good_eta &= fabs(me - eta) < 5.0 * hypot(se, pe);
		good_m &= fabs(mm - mu) < 5.0 * hypot(sm, pm);
		good_v &= fabs(mv - var) < 5.0 * hypot(sv, pv);
	}
	ed_sample_t sm;
	ed_sample(ed, &sm);
	ok(good_eta && gap > -1e-9 && sm.wall_rejected[0] == 0 && sm.wall_inflow[0] > 3000 && out_of_range == 0,
	   "polydisperse dispenser at eta 0.5: volume fraction holds in each of 4 slices (within 5 SE), no overlap "
	   "(min gap %.2g), %llu in, none rejected (%llu), slot radii in their ranges (%zu not; %zu B slots)", gap,
	   (unsigned long long)sm.wall_inflow[0], (unsigned long long)sm.wall_rejected[0], out_of_range, mb);
	ok(good_m && good_v, "polydisperse dispenser: B's radii keep their law along the channel (mean %.3f, variance "
	   "%.3g within 5 SE in each slice)", mu, var);
	{
		ed_t *a, *b;
		if (!checkpoint_pair(json, &sc, 13.0, 55.0, &a, &b)) {
			ok(0, "polydisperse dispenser checkpoint: restore");
			goto done;
		}
		ed_advance(a, 200.0, UINT64_MAX, UINT64_MAX);
		ed_advance(b, 200.0, UINT64_MAX, UINT64_MAX);
		ed_sample_t sa, sb;
		ed_sample(a, &sa);
		ed_sample(b, &sb);
		ok(sa.events == sb.events && sa.wall_inflow[0] == sb.wall_inflow[0] && sa.wall_inflow[0] > 0 &&
		   same_slots(a, b) && sa.ekin_time_integral == sb.ekin_time_integral,
		   "polydisperse dispenser checkpoint: restored run identical bit for bit after %llu events (%llu in)",
		   (unsigned long long)sa.events, (unsigned long long)sa.wall_inflow[0]);
		ed_destroy(a);
		ed_destroy(b);
	}
done:
	free(sp);
	free(rad);
	free(pos);
	free(vel);
	ed_destroy(ed);
}

int main(void)
{
	plan(15);
	test_holds();
	test_checkpoint();
	test_3d();
	test_composition();
	test_holds_3d();
	test_polydisperse();
	return done_testing();
}
