/* Benchmark of the event-driven core: collisions per second and bytes per particle for one system. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "ed/ed.h"
#include "scene.h"

static double now(void)
{
	struct timespec ts;
	clock_gettime(CLOCK_MONOTONIC, &ts);
	return ts.tv_sec + 1e-9 * ts.tv_nsec;
}

/* CPU time of this process: on a shared machine less disturbed by other
 * work than the wall clock (time waiting for the CPU does not count). */
static double cpu_now(void)
{
	struct timespec ts;
	clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
	return ts.tv_sec + 1e-9 * ts.tv_nsec;
}

/* usage: ed_bench DIM N VOLUME_FRACTION RESTITUTION WARMUP_CPP MEASURE_CPP [TC [CELL_SIZE [FEATURE]]]
 * Prints one JSON line. The warm-up (elastic relaxation from the lattice
 * for restitution 1) is not timed. FEATURE (scene features, issue 12):
 * periodic (default), walls (specular walls on every axis), thermal
 * (thermal walls at T = 1 on the last axis), gravity (specular walls on the
 * last axis, gravity along it with scale height T/(m g) = half the box),
 * obstacle (periodic box, one slip obstacle of radius L/10 at the centre),
 * walls-obstacle (walls on every axis and that obstacle),
 * rough (periodic, perfectly rough particles: tangential restitution 1, so
 * with restitution 1 the gas stays elastic and only the rule's cost
 * differs), walton (periodic, Walton's rule: beta_0 0.5, mu 0.1; this one
 * dissipates, so its dynamics differ too), mixture (periodic, two species
 * of N/2 particles, radius 0.5, masses 1 and 2: the species kernels at the
 * same packing). */
int main(int argc, char **argv)
{
	if (argc < 7) {
		fprintf(stderr, "usage: ed_bench DIM N PHI RESTITUTION WARMUP_CPP MEASURE_CPP [TC [CELL_SIZE]]\n");
		return 2;
	}
	int dim = atoi(argv[1]);
	long n = atol(argv[2]);
	double phi = atof(argv[3]), e = atof(argv[4]), warm = atof(argv[5]), meas = atof(argv[6]);
	double tc = argc > 7 ? atof(argv[7]) : 0.0, cell = argc > 8 ? atof(argv[8]) : 0.0;
	const char *feature = argc > 9 ? argv[9] : "periodic";
	char json[1024], err[512], extra[512] = "";
	const char *rough = "";
	const char *ax = dim == 2 ? "y" : "z";
	const char *spec = "{\"type\":\"walls\",\"lower\":{\"type\":\"specular\"},\"upper\":{\"type\":\"specular\"}}";
	if (!strcmp(feature, "walls")) {
		snprintf(extra, sizeof extra, ",\"boundaries\":{\"x\":%s,\"y\":%s%s%s}", spec, spec,
		         dim == 3 ? ",\"z\":" : "", dim == 3 ? spec : "");
	} else if (!strcmp(feature, "thermal")) {
		snprintf(extra, sizeof extra, ",\"boundaries\":{\"%s\":{\"type\":\"walls\",\"lower\":{\"type\":\"thermal\","
		         "\"temperature\":1},\"upper\":{\"type\":\"thermal\",\"temperature\":1}}}", ax);
	} else if (!strcmp(feature, "gravity")) {
		/* box edge of the square/cubic box; g = 2 T / (m L) */
		double vp = dim == 2 ? 3.14159265358979 / 4 : 3.14159265358979 / 6;
		double L = pow(n * vp / phi, 1.0 / dim), g = 2.0 / L;
		snprintf(extra, sizeof extra, ",\"boundaries\":{\"%s\":%s},\"gravity\":[0,%s%.17g]", ax, spec,
		         dim == 3 ? "0,-" : "-", g);
	} else if (!strcmp(feature, "obstacle") || !strcmp(feature, "walls-obstacle")) {
		double vp = dim == 2 ? 3.14159265358979 / 4 : 3.14159265358979 / 6;
		double L = pow(n * vp / phi, 1.0 / dim);
		char walls[256] = "", center[128];
		if (feature[0] == 'w')
			snprintf(walls, sizeof walls, ",\"boundaries\":{\"x\":%s,\"y\":%s%s%s}", spec, spec,
			         dim == 3 ? ",\"z\":" : "", dim == 3 ? spec : "");
		if (dim == 2)
			snprintf(center, sizeof center, "%.17g,%.17g", 0.5 * L, 0.5 * L);
		else
			snprintf(center, sizeof center, "%.17g,%.17g,%.17g", 0.5 * L, 0.5 * L, 0.5 * L);
		snprintf(extra, sizeof extra, "%s,\"obstacles\":[{\"type\":\"slip\",\"center\":[%s],\"radius\":%.17g}]",
		         walls, center, 0.1 * L);
	} else if (!strcmp(feature, "rough")) {
		rough = ",\"rough\":{\"tangential_restitution\":1}";
	} else if (!strcmp(feature, "walton")) {
		rough = ",\"rough\":{\"tangential_restitution\":0.5,\"friction\":0.1}";
	} else if (strcmp(feature, "periodic") && strcmp(feature, "mixture")) {
		fprintf(stderr, "ed_bench: unknown feature %s (periodic, walls, thermal, gravity, obstacle, walls-obstacle, "
		        "rough, walton, mixture)\n", feature);
		return 2;
	}
	char count[256];
	if (!strcmp(feature, "mixture"))
		snprintf(count, sizeof count, "\"species\":[{\"count\":%ld,\"radius\":0.5,\"mass\":1},"
		         "{\"count\":%ld,\"radius\":0.5,\"mass\":2}]", n / 2, n - n / 2);
	else
		snprintf(count, sizeof count, "\"count\":%ld", n);
	snprintf(json, sizeof(json),
	         "{\"method\":\"ed\",\"dimensions\":%d,\"particles\":{%s,\"volume_fraction\":%g,"
	         "\"initial\":{\"relax\":{\"collisions_per_particle\":%g}}},"
	         "\"collisions\":{\"restitution\":%g,\"tc\":%g%s},\"run\":{\"until\":{\"time\":1}},"
	         "\"ed\":{\"cell_size\":%g}%s}",
	         dim, count, phi, warm, e, tc, rough, cell, extra);
	scene_t sc;
	int rc;
	if (scene_parse(json, strlen(json), &sc, err, sizeof(err)) != SCENE_OK) {
		fprintf(stderr, "%s\n", err);
		return 2;
	}
	double t0 = now();
	ed_t *ed = ed_create(&sc, &rc, err, sizeof(err));
	if (!ed) {
		fprintf(stderr, "%s\n", err);
		return 1;
	}
	double t_setup = now() - t0;
	uint64_t target = (uint64_t)(meas * n / 2);
	t0 = now();
	double c0 = cpu_now();
	ed_advance(ed, INFINITY, target, UINT64_MAX);
	double w = now() - t0, cpu = cpu_now() - c0;
	int cells[3];
	ed_cells(ed, cells);
	printf("{\"dim\":%d,\"n\":%ld,\"phi\":%g,\"restitution\":%g,\"collisions\":%llu,\"events\":%llu,"
	       "\"seconds\":%.3f,\"cpu_seconds\":%.3f,\"collisions_per_second\":%.4g,\"events_per_second\":%.4g,"
	       "\"bytes_per_particle\":%.1f,\"cells\":[%d,%d,%d],\"setup_seconds\":%.2f}\n",
	       dim, n, phi, e, (unsigned long long)ed_collisions(ed), (unsigned long long)ed_events(ed), w, cpu,
	       ed_collisions(ed) / w, ed_events(ed) / w, (double)ed_memory(ed) / n, cells[0], cells[1],
	       dim == 3 ? cells[2] : 1, t_setup);
	ed_destroy(ed);
	return 0;
}
