/* Initial placement in a region and the checks of a given state (engine/place.h). */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "place.h"
#include "scene.h"
#include "tap.h"

static scene_t parse(const char *json)
{
	scene_t s;
	char err[512];
	memset(&s, 0, sizeof s);
	if (scene_parse(json, strlen(json), &s, err, sizeof err) != SCENE_OK) {
		diag("scene does not parse: %s", err);
		s.count = 0;
	}
	return s;
}

/* Smallest pair distance (minimum image on the periodic axes), brute force. */
static double min_pair(const scene_t *s, const double *p)
{
	double best = INFINITY;
	for (uint64_t i = 0; i < s->count; i++)
		for (uint64_t j = i + 1; j < s->count; j++) {
			double r2 = 0;
			for (int a = 0; a < s->dim; a++) {
				double d = p[i * s->dim + a] - p[j * s->dim + a];
				if (!s->boundary[a].walled)
					d -= s->box[a] * nearbyint(d / s->box[a]);
				r2 += d * d;
			}
			best = fmin(best, sqrt(r2));
		}
	return best;
}

/* Every centre in [lo, hi] along every axis. */
static int inside(const scene_t *s, const double *p, const double *lo, const double *hi)
{
	for (uint64_t i = 0; i < s->count; i++)
		for (int a = 0; a < s->dim; a++)
			if (!(p[i * s->dim + a] >= lo[a] && p[i * s->dim + a] <= hi[a]))
				return 0;
	return 1;
}

/* Placement of scene json: inside [lo, hi] (centres), no two closer than a
 * diameter (ed; mind = 0 for point particles), and a function of the seed. */
static void test_region(const char *what, const char *json, const double *lo, const double *hi, double mind)
{
	scene_t s = parse(json);
	if (!s.count) {
		ok(0, "%s: scene parses", what);
		return;
	}
	size_t n = s.count * s.dim;
	double *p = malloc(n * sizeof(double)), *q = malloc(n * sizeof(double));
	char err[512] = "";
	int rc = place_region(&s, 0, p, err, sizeof err), rc2 = place_region(&s, 0, q, err, sizeof err);
	ok(rc == PLACE_OK && rc2 == PLACE_OK, "%s: placed (%s)", what, err);
	ok(inside(&s, p, lo, hi), "%s: every centre inside the region's centre range", what);
	double d = min_pair(&s, p);
	ok(d >= mind * (1 - 1e-12), "%s: nearest pair %.6g >= %.6g", what, d, mind);
	ok(!memcmp(p, q, n * sizeof(double)), "%s: the same seed and stream give the same placement", what);
	if (s.positions == SCENE_POS_RANDOM) {
		rc = place_region(&s, 1, q, err, sizeof err);
		ok(rc == PLACE_OK && memcmp(p, q, n * sizeof(double)), "%s: another stream, another placement", what);
	}
	free(p);
	free(q);
}

/* place_check_state() on a two-particle state of scene json: want OK or
 * EINVAL with a message containing needle. */
static void test_state(const char *what, const char *json, double *pos, const double *vel, int want, const char *needle)
{
	scene_t s = parse(json);
	char err[512] = "";
	int rc = s.count ? place_check_state(&s, pos, vel, "particles.initial.from", err, sizeof err) : -99;
	ok(rc == want && (!needle || (strstr(err, needle) && !strncmp(err, "particles.initial.from: ", 24))),
	   "%s: %s (%s)", what, want == PLACE_OK ? "accepted" : "refused", err);
}

#define ED2 "{\"method\":\"ed\",\"dimensions\":2,\"particles\":{\"count\":2,\"box\":[10,10]},\"run\":{\"until\":{\"time\":1}}"
#define WALLS_Y ",\"boundaries\":{\"y\":{\"type\":\"walls\",\"lower\":{\"type\":\"specular\"},\"upper\":{\"type\":\"specular\"}}}"

int main(void)
{
	/* a bed: 2D, walls along y, the bottom third; random sequential addition */
	test_region("ed 2D random bed",
	            "{\"method\":\"ed\",\"dimensions\":2,\"particles\":{\"count\":150,\"box\":[20,40],\"initial\":"
	            "{\"positions\":\"random\",\"region\":{\"upper\":[20,12]}}}" WALLS_Y ",\"run\":{\"until\":{\"time\":1}}}",
	            (double[]){0, 0.5}, (double[]){20, 11.5}, 1.0);
	/* the same bed on a lattice */
	test_region("ed 2D lattice bed",
	            "{\"method\":\"ed\",\"dimensions\":2,\"particles\":{\"count\":150,\"box\":[20,40],\"initial\":"
	            "{\"region\":{\"upper\":[20,12]}}}" WALLS_Y ",\"run\":{\"until\":{\"time\":1}}}",
	            (double[]){0, 0.5}, (double[]){20, 11.5}, 1.0);
	/* a periodic slab in 3D: x, y spanned whole (periodic, pairs across the edges count), z bounded */
	test_region("ed 3D random slab",
	            "{\"method\":\"ed\",\"dimensions\":3,\"particles\":{\"count\":300,\"box\":[8,8,30],\"initial\":"
	            "{\"positions\":\"random\",\"region\":{\"lower\":[0,0,10],\"upper\":[8,8,20]}}},"
	            "\"run\":{\"until\":{\"time\":1}}}",
	            (double[]){0, 0, 10.5}, (double[]){8, 8, 19.5}, 1.0);
	test_region("ed 3D lattice slab",
	            "{\"method\":\"ed\",\"dimensions\":3,\"particles\":{\"count\":300,\"box\":[8,8,30],\"initial\":"
	            "{\"region\":{\"lower\":[0,0,10],\"upper\":[8,8,20]}}},\"run\":{\"until\":{\"time\":1}}}",
	            (double[]){0, 0, 10.5}, (double[]){8, 8, 19.5}, 1.0);
	/* a dense periodic square region: lattice at volume fraction 0.7 of the region */
	test_region("ed 2D lattice, dense region",
	            "{\"method\":\"ed\",\"dimensions\":2,\"particles\":{\"count\":400,\"box\":[40,40],\"initial\":"
	            "{\"region\":{\"lower\":[5,5],\"upper\":[29,29]}}},\"run\":{\"until\":{\"time\":1}}}",
	            (double[]){5.5, 5.5}, (double[]){28.5, 28.5}, 1.0);
	/* a vibrating floor reaches 2 above its rest position: centres from 2 + radius */
	test_region("ed 2D bed over a vibrating floor",
	            "{\"method\":\"ed\",\"dimensions\":2,\"particles\":{\"count\":50,\"box\":[20,40],\"initial\":"
	            "{\"positions\":\"random\",\"region\":{\"upper\":[20,10]}}},\"collisions\":{\"tc\":1e-4},"
	            "\"boundaries\":{\"y\":{\"type\":\"walls\",\"lower\":{\"type\":\"vibrating\",\"amplitude\":2,"
	            "\"frequency\":1},\"upper\":{\"type\":\"specular\"}}},\"run\":{\"until\":{\"time\":1}}}",
	            (double[]){0, 2.5}, (double[]){20, 9.5}, 1.0);
	/* dsmc: point particles, uniform in the region, may overlap */
	test_region("dsmc 2D random region",
	            "{\"method\":\"dsmc\",\"dimensions\":2,\"particles\":{\"count\":200,\"box\":[40,40],\"initial\":"
	            "{\"positions\":\"random\",\"region\":{\"lower\":[0,10],\"upper\":[40,20]}}},\"run\":{\"until\":{\"time\":1}}}",
	            (double[]){0, 10.5}, (double[]){40, 19.5}, 0.0);

	/* a scene without a region has nothing to check */
	scene_t plain = parse(ED2 "}");
	ok(plain.count && place_check(&plain, NULL, 0) == PLACE_OK, "no region: place_check() accepts");

	/* given states */
	const double v0[4] = {1, 0, -1, 0};
	test_state("two disks apart", ED2 "}", (double[]){2, 2, 5, 5}, v0, PLACE_OK, NULL);
	test_state("NaN position", ED2 "}", (double[]){2, NAN, 5, 5}, v0, PLACE_EINVAL, "particle 0 has a non-finite position");
	test_state("infinite velocity", ED2 "}", (double[]){2, 2, 5, 5}, (double[]){1, 0, INFINITY, 0}, PLACE_EINVAL,
	           "particle 1 has a non-finite velocity");
	test_state("outside a periodic box", ED2 "}", (double[]){2, 2, 10.5, 5}, v0, PLACE_EINVAL, "particle 1 is outside the box along x");
	test_state("negative coordinate", ED2 "}", (double[]){2, -1e-9, 5, 5}, v0, PLACE_EINVAL, "outside the box along y");
	double edge[4] = {10, 2, 5, 5};
	test_state("a centre at the edge L of a periodic axis", ED2 "}", edge, v0, PLACE_OK, NULL);
	ok(edge[0] == 0.0, "... is folded to 0 (the same point)");
	test_state("overlap", ED2 "}", (double[]){2, 2, 2.5, 2.4}, v0, PLACE_EINVAL, "particles 0 and 1 overlap");
	test_state("overlap across the periodic edge", ED2 "}", (double[]){0.2, 5, 9.7, 5}, v0, PLACE_EINVAL,
	           "particles 0 and 1 overlap");
	test_state("contact up to the tolerance (1e-12 diameters)", ED2 "}", (double[]){2, 2, 3 - 1e-12, 2}, v0, PLACE_OK, NULL);
	test_state("overlap beyond the tolerance (1e-8 diameters)", ED2 "}", (double[]){2, 2, 3 - 1e-8, 2}, v0, PLACE_EINVAL,
	           "overlap");
	test_state("dsmc: point particles may overlap",
	           "{\"method\":\"dsmc\",\"dimensions\":2,\"particles\":{\"count\":2,\"box\":[10,10]},\"run\":{\"until\":{\"time\":1}}}",
	           (double[]){2, 2, 2, 2}, v0, PLACE_OK, NULL);
	test_state("a radius from a wall", ED2 WALLS_Y "}", (double[]){2, 0.5, 5, 9.5}, v0, PLACE_OK, NULL);
	test_state("closer than a radius to the floor", ED2 WALLS_Y "}", (double[]){2, 0.49, 5, 5}, v0, PLACE_EINVAL,
	           "particle 0 is closer than a radius to a wall along y");
	test_state("closer than a radius to the ceiling", ED2 WALLS_Y "}", (double[]){2, 2, 5, 9.6}, v0, PLACE_EINVAL,
	           "particle 1 is closer than a radius to a wall along y");
	/* a vibrating floor at phase pi/2 is displaced by its amplitude at time 0 */
	test_state("a vibrating floor where it is at time 0",
	           "{\"method\":\"ed\",\"dimensions\":2,\"particles\":{\"count\":2,\"box\":[10,10]},\"collisions\":{\"tc\":1e-4},"
	           "\"boundaries\":{\"y\":{\"type\":\"walls\",\"lower\":{\"type\":\"vibrating\",\"amplitude\":1,\"frequency\":1,"
	           "\"phase\":1.5707963267948966},\"upper\":{\"type\":\"specular\"}}},\"run\":{\"until\":{\"time\":1}}}",
	           (double[]){2, 1.2, 5, 5}, v0, PLACE_EINVAL, "closer than a radius to a wall along y");
	/* obstacles: region placement keeps out of them, a given state may not overlap them */
	static const char *const obst_scenes[] = {
		"{\"method\":\"ed\",\"dimensions\":2,\"particles\":{\"count\":150,\"box\":[30,30],\"initial\":"
		"{\"positions\":\"random\",\"region\":{\"upper\":[30,20]}}},\"obstacles\":[{\"type\":\"slip\","
		"\"center\":[15,10],\"radius\":5},{\"type\":\"slip\",\"center\":[1,1],\"radius\":2}],"
		"\"run\":{\"until\":{\"time\":1}}}",
		"{\"method\":\"ed\",\"dimensions\":2,\"particles\":{\"count\":150,\"box\":[30,30],\"initial\":"
		"{\"region\":{\"upper\":[30,20]}}},\"obstacles\":[{\"type\":\"slip\","
		"\"center\":[15,10],\"radius\":5},{\"type\":\"slip\",\"center\":[1,1],\"radius\":2}],"
		"\"run\":{\"until\":{\"time\":1}}}",
	};
	for (size_t c = 0; c < 2; c++) {
		scene_t s = parse(obst_scenes[c]);
		double *p = s.count ? malloc(s.count * 2 * sizeof(double)) : NULL;
		char err[512] = "";
		int rc = p ? place_region(&s, 0, p, err, sizeof err) : -99;
		/* closest approach of a centre to an obstacle's centre less (R + r), minimum image in x and y */
		double worst = INFINITY;
		for (uint64_t i = 0; rc == PLACE_OK && i < s.count; i++)
			for (int k = 0; k < s.n_obstacles; k++) {
				double dx = p[2 * i] - s.obstacle[k].center[0], dy = p[2 * i + 1] - s.obstacle[k].center[1];
				dx -= 30 * nearbyint(dx / 30);
				dy -= 30 * nearbyint(dy / 30);
				worst = fmin(worst, sqrt(dx * dx + dy * dy) - s.obstacle[k].radius - s.radius);
			}
		ok(rc == PLACE_OK && worst >= 0 && min_pair(&s, p) >= 1.0,
		   "%s in a region with two obstacles (one across the periodic corner): clear of them by %.4g (%s)",
		   c ? "lattice" : "random", worst, err);
		free(p);
	}
	scene_t crowded = parse("{\"method\":\"ed\",\"dimensions\":2,\"particles\":{\"count\":200,\"box\":[30,30]},"
	                        "\"obstacles\":[{\"type\":\"slip\",\"center\":[15,5],\"radius\":6}],"
	                        "\"run\":{\"until\":{\"time\":1}}}");
	if (crowded.count) {
		char err[512] = "";
		crowded.has_region = 1;
		crowded.region_hi[0] = 30;
		crowded.region_hi[1] = 8;
		int rc = place_check(&crowded, err, sizeof err);
		ok(rc == PLACE_EINVAL && !strncmp(err, "particles.initial.region: ", 26) && strstr(err, "obstacles"),
		   "a lattice region mostly covered by an obstacle: %s", err);
	} else {
		ok(0, "crowded scene parses");
	}
	test_state("a particle inside an obstacle",
	           "{\"method\":\"ed\",\"dimensions\":2,\"particles\":{\"count\":2,\"box\":[10,10]},"
	           "\"obstacles\":[{\"type\":\"slip\",\"center\":[9.5,5],\"radius\":1}],\"run\":{\"until\":{\"time\":1}}}",
	           (double[]){0.2, 5, 5, 5}, v0, PLACE_EINVAL, "particle 0 overlaps obstacles[0]");
	test_state("a particle touching an obstacle",
	           "{\"method\":\"ed\",\"dimensions\":2,\"particles\":{\"count\":2,\"box\":[10,10]},"
	           "\"obstacles\":[{\"type\":\"slip\",\"center\":[8,5],\"radius\":1}],\"run\":{\"until\":{\"time\":1}}}",
	           (double[]){6.5, 5, 2, 5}, v0, PLACE_OK, NULL);
	plan(tap_n);
	return done_testing();
}
