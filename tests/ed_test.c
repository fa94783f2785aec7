/* Tests of the event-driven core: determinism, extremes of density, restitution and run length. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "ed/ed.h"
#include "scene.h"
#include "tap.h"
#include "ed_util.h"

static double energy(ed_t *ed)
{
	ed_sample_t s;
	ed_sample(ed, &s);
	return s.kinetic_energy;
}

/* Same scene and seed: bitwise identical state; sampling in between (as
 * output does) and stopping at intermediate times must not change it. */
static void test_determinism(int dim)
{
	char json[512];
	scene_t sc;
	snprintf(json, sizeof(json),
	         "{\"method\":\"ed\",\"dimensions\":%d,\"particles\":{\"count\":500,\"volume_fraction\":0.3,"
	         "\"initial\":{\"positions\":\"random\"}},\"collisions\":{\"restitution\":0.8,\"tc\":0.001},"
	         "\"run\":{\"seed\":5,\"until\":{\"time\":1}}}", dim);
	ed_t *a = make(json, &sc), *b = make(json, &sc);
	if (!a || !b) {
		ok(0, "determinism %dD: setup", dim);
		ed_destroy(a);
		ed_destroy(b);
		return;
	}
	ed_advance(a, 3.0, UINT64_MAX, UINT64_MAX);
	for (int k = 1; k <= 300; k++) {
		ed_advance(b, 0.01 * k, UINT64_MAX, UINT64_MAX);
		double *tmp = malloc(sizeof(double) * sc.count * dim);
		ed_state(b, tmp, NULL);   /* sampling must not perturb */
		free(tmp);
		energy(b);
	}
	ed_advance(b, 3.0, UINT64_MAX, UINT64_MAX);
	size_t m = sc.count * dim;
	double *pa = malloc(sizeof(double) * m * 4), *va = pa + m, *pb = va + m, *vb = pb + m;
	ed_state(a, pa, va);
	ed_state(b, pb, vb);
	ok(ed_collisions(a) == ed_collisions(b) && ed_events(a) == ed_events(b) &&
	   !memcmp(pa, pb, m * sizeof(double)) && !memcmp(va, vb, m * sizeof(double)),
	   "determinism %dD: %llu collisions, identical state with and without 300 intermediate samples",
	   dim, (unsigned long long)ed_collisions(a));
	free(pa);
	ed_destroy(a);
	ed_destroy(b);
}

/* Run a scene to its collision target; energy (elastic) and overlaps checked. */
static void test_extreme(const char *name, const char *json, double cpp, int elastic)
{
	scene_t sc;
	ed_t *ed = make(json, &sc);
	if (!ed) {
		ok(0, "%s: setup", name);
		return;
	}
	double e0 = energy(ed);
	uint64_t target = (uint64_t)(cpp * sc.count / 2);
	int rc = ed_advance(ed, INFINITY, target, UINT64_MAX);
	double e1 = energy(ed), gap = ed_min_gap(ed);
	/* Rounding per collision is ~1e-16 relative; 1e-10 bounds any honest
	 * accumulation at these collision counts. */
	int energy_ok = elastic ? fabs(e1 / e0 - 1) < 1e-10 : e1 <= e0 * (1 + 1e-12);
	ok(rc == ED_OK && ed_collisions(ed) >= target && energy_ok && gap > -1e-10 * 2 * sc.radius,
	   "%s: %llu collisions at time %.4g, energy ratio %.12f, smallest gap %.2e", name,
	   (unsigned long long)ed_collisions(ed), ed_time(ed), e1 / e0, gap);
	ed_destroy(ed);
}

int main(void)
{
	test_determinism(2);
	test_determinism(3);

	test_extreme("N=2 2D", "{\"method\":\"ed\",\"dimensions\":2,\"particles\":{\"count\":2,"
	             "\"volume_fraction\":0.1},\"run\":{\"until\":{\"time\":1}}}", 1e4, 1);
	test_extreme("N=2 3D", "{\"method\":\"ed\",\"dimensions\":3,\"particles\":{\"count\":2,"
	             "\"volume_fraction\":0.05},\"run\":{\"until\":{\"time\":1}}}", 1e4, 1);
	test_extreme("very dilute 2D (1e-4)", "{\"method\":\"ed\",\"dimensions\":2,\"particles\":{\"count\":2000,"
	             "\"volume_fraction\":1e-4,\"initial\":{\"positions\":\"random\"}},\"run\":{\"until\":{\"time\":1}}}",
	             5, 1);
	test_extreme("very dilute 3D (1e-4)", "{\"method\":\"ed\",\"dimensions\":3,\"particles\":{\"count\":2000,"
	             "\"volume_fraction\":1e-4,\"initial\":{\"positions\":\"random\"}},\"run\":{\"until\":{\"time\":1}}}",
	             5, 1);
	test_extreme("dense 2D (0.8)", "{\"method\":\"ed\",\"dimensions\":2,\"particles\":{\"count\":2000,"
	             "\"volume_fraction\":0.8},\"run\":{\"until\":{\"time\":1}}}", 100, 1);
	test_extreme("dense 3D (0.5)", "{\"method\":\"ed\",\"dimensions\":3,\"particles\":{\"count\":2048,"
	             "\"volume_fraction\":0.5},\"run\":{\"until\":{\"time\":1}}}", 100, 1);
	/* Restitution 0 with the TC model: the clock must advance (no loop of
	 * zero-time collisions between pairs left touching) and no overlap. */
	for (int dim = 2; dim <= 3; dim++) {
		char json[512];
		scene_t sc;
		snprintf(json, sizeof(json), "{\"method\":\"ed\",\"dimensions\":%d,\"particles\":{\"count\":2000,"
		         "\"volume_fraction\":0.3},\"collisions\":{\"restitution\":0,\"tc\":1e-3},"
		         "\"run\":{\"until\":{\"time\":1}}}", dim);
		ed_t *ed = make(json, &sc);
		double e0 = ed ? energy(ed) : 0;
		int rc = ed ? ed_advance(ed, 50.0, 20000000, UINT64_MAX) : -99;
		double e1 = ed ? energy(ed) : 0, gap = ed ? ed_min_gap(ed) : -1;
		ok(rc == ED_OK && ed_time(ed) == 50.0 && e1 < 0.1 * e0 && gap > -1e-10,
		   "restitution 0 with TC %dD: clock reaches 50 after %llu collisions, T/T0 = %.3g, smallest gap %.2e",
		   dim, ed ? (unsigned long long)ed_collisions(ed) : 0ull, e1 / e0, gap);
		ed_destroy(ed);
	}
	test_extreme("strong dissipation e=0.3 with TC 2D", "{\"method\":\"ed\",\"dimensions\":2,\"particles\":{\"count\":2000,"
	             "\"volume_fraction\":0.4},\"collisions\":{\"restitution\":0.3,\"tc\":1e-4},"
	             "\"run\":{\"until\":{\"time\":1}}}", 300, 0);

	/* A long run: N=2 disks, 10^7 collisions per particle, i.e. the clock
	 * reaches 10^7 mean free times. Rebasing keeps times small; without
	 * it t - t_j would lose ~7 digits and energy and contact distances
	 * would drift. */
	{
		scene_t sc;
		ed_t *ed = make("{\"method\":\"ed\",\"dimensions\":2,\"particles\":{\"count\":2,\"volume_fraction\":0.2},"
		                "\"run\":{\"until\":{\"time\":1}}}", &sc);
		if (ed) {
			double e0 = energy(ed);
			ed_advance(ed, INFINITY, 10000000, UINT64_MAX);
			double e1 = energy(ed), gap = ed_min_gap(ed);
			ok(ed_collisions(ed) == 10000000 && fabs(e1 / e0 - 1) < 1e-10 && gap > -1e-10,
			   "long run: 1e7 collisions per particle, clock %.4g, energy ratio - 1 = %.2e, smallest gap %.2e",
			   ed_time(ed), e1 / e0 - 1, gap);
			ed_destroy(ed);
		} else {
			ok(0, "long run: setup");
		}
	}

	/* Zero temperature: nothing ever happens; the engine must say so. */
	{
		scene_t sc;
		ed_t *ed = make("{\"method\":\"ed\",\"dimensions\":3,\"particles\":{\"count\":100,\"volume_fraction\":0.2,"
		                "\"initial\":{\"temperature\":0}},\"run\":{\"until\":{\"time\":1}}}", &sc);
		int rc = ed ? ed_advance(ed, 5.0, UINT64_MAX, UINT64_MAX) : -99;
		ok(rc == ED_QUIESCENT && ed_time(ed) == 5.0 && ed_events(ed) == 0,
		   "temperature 0: quiescent, clock jumps to the stop time");
		ed_destroy(ed);
	}
	ed_destroy(NULL);
	ok(1, "ed_destroy(NULL) is a no-op");
	plan(tap_n);
	return done_testing();
}
