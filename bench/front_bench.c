/* Seed 001 anchor 11: the dense front of an inelastic stream in front of an obstacle, measured from a scene (presets/dense-front-2d.json). */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "ed/ed.h"
#include "scene.h"

#ifndef M_PI
#define M_PI 3.14159265358979323846
#endif

/* usage: front_bench SCENE.json [FROM]
 * Runs the scene (method ed, 2D, a dispenser along x, obstacle 0 in the
 * stream) to its run.until time and samples every 5 time units from FROM
 * (default: half the run) to the end: the volume fraction (particle
 * centres counted, times the disk area, over the box's area) in a box of
 * 3 x 6 diameters touching the obstacle's upstream side on its axis
 * ("eta_contact": low by the layer next to the obstacle that no centre can
 * reach), in the next box upstream ("eta_front", 3 to 6 diameters from
 * the obstacle), and in the inflow region x in [10, 30) over the whole
 * width ("eta_inflow"); the temperature of the particles present (about
 * their mean velocity). Prints one JSON line. */
int main(int argc, char **argv)
{
	if (argc < 2) {
		fprintf(stderr, "usage: front_bench SCENE.json [FROM]\n");
		return 2;
	}
	static char buf[1 << 16];
	FILE *f = fopen(argv[1], "r");
	if (!f) {
		perror(argv[1]);
		return 2;
	}
	size_t len = fread(buf, 1, sizeof buf - 1, f);
	fclose(f);
	buf[len] = '\0';
	scene_t sc;
	char err[512];
	int rc;
	if (scene_parse(buf, len, &sc, err, sizeof err) != SCENE_OK || sc.dim != 2 || sc.n_obstacles < 1 ||
	    sc.until.kind != SCENE_CLOCK_TIME) {
		fprintf(stderr, "%s: %s\n", argv[1], err[0] ? err : "needs a 2D scene with an obstacle and run.until.time");
		return 2;
	}
	ed_t *ed = ed_create(&sc, &rc, err, sizeof err);
	if (!ed) {
		fprintf(stderr, "%s\n", err);
		return 1;
	}
	const double t_end = sc.until.value, from = argc > 2 ? atof(argv[2]) : 0.5 * t_end, d = 2.0 * sc.radius;
	const double cx = sc.obstacle[0].center[0], cy = sc.obstacle[0].center[1], R = sc.obstacle[0].radius;
	const double ap = M_PI * sc.radius * sc.radius;
	const size_t N = ed_slots(ed);
	double *pos = malloc(N * 2 * sizeof(double)), *vel = malloc(N * 2 * sizeof(double));
	double c1 = 0.0, c2 = 0.0, ci = 0.0, temp = 0.0;
	int samples = 0;
	ed_advance(ed, from, UINT64_MAX, UINT64_MAX);
	for (double t = from + 5.0; t <= t_end + 1e-9; t += 5.0) {
		if ((rc = ed_advance(ed, t, UINT64_MAX, UINT64_MAX)) != ED_OK) {
			fprintf(stderr, "ed_advance: %s at t = %g\n", ed_strerror(rc), t);
			break;
		}
		ed_state(ed, pos, vel);
		double n = 0.0, s[2] = {0.0, 0.0}, s2 = 0.0;
		for (size_t i = 0; i < N; i++) {
			const double x = pos[2 * i], y = pos[2 * i + 1];
			if (isnan(x))
				continue;
			n += 1.0;
			s[0] += vel[2 * i];
			s[1] += vel[2 * i + 1];
			s2 += vel[2 * i] * vel[2 * i] + vel[2 * i + 1] * vel[2 * i + 1];
			if (fabs(y - cy) < 3.0 * d) {
				if (x < cx - R && x >= cx - R - 3.0 * d)
					c1 += 1.0;
				else if (x < cx - R - 3.0 * d && x >= cx - R - 6.0 * d)
					c2 += 1.0;
			}
			if (x >= 10.0 && x < 30.0)
				ci += 1.0;
		}
		temp += 0.5 * (s2 / n - (s[0] * s[0] + s[1] * s[1]) / (n * n));
		samples++;
	}
	const double box = 3.0 * d * 6.0 * d;
	printf("{\"scene\":\"%s\",\"from\":%g,\"until\":%g,\"samples\":%d,\"eta_contact\":%.4f,\"eta_front\":%.4f,"
	       "\"eta_inflow\":%.4f,\"temperature\":%.5g,\"collisions\":%llu}\n",
	       argv[1], from, t_end, samples, c1 / samples * ap / box, c2 / samples * ap / box,
	       ci / samples * ap / (20.0 * sc.box[1]), temp / samples, (unsigned long long)ed_collisions(ed));
	free(pos);
	free(vel);
	ed_destroy(ed);
	return 0;
}
