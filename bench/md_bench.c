/* Soft-sphere MD speed: a 3D bed of frictional spheres settling under gravity, particle-steps per second. */
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <time.h>

#include "md/md.h"

/*
 * usage: md_bench NX NY NZ STEPS [MU [LAW]]
 * NX x NZ x NY spheres (diameter 1, mass 1) on a cubic lattice of spacing
 * 1.05 (NY layers), random velocities (+-0.05), gravity 100 along -y,
 * periodic in x and z, floor and lid walls in y (box 2 NY high). Linear law,
 * k_n = 2e5 (overlap m g NY / k_n = 1.25% of d at the bottom of 25 layers),
 * e = 0.5, mu = 0.5 (default), k_t = 2/7 k_n, dt = t_c/50 = 1.0e-4. LAW 1:
 * Hertz with E* = 1e6, v_ref = 2. An untimed settle of STEPS (the column
 * falls 0.05 NY in sqrt(0.1 NY / 100) = 0.16 for NY = 25, 1600 steps), then
 * STEPS timed, while the bed compacts and its contacts carry the weight.
 */
static double now(clockid_t c)
{
	struct timespec ts;
	clock_gettime(c, &ts);
	return ts.tv_sec + 1e-9 * ts.tv_nsec;
}

int main(int argc, char **argv)
{
	if (argc < 5) {
		fprintf(stderr, "usage: md_bench NX NY NZ STEPS [MU [LAW]]\n");
		return 2;
	}
	int nx = atoi(argv[1]), ny = atoi(argv[2]), nz = atoi(argv[3]);
	long steps = atol(argv[4]);
	double mu = argc > 5 ? atof(argv[5]) : 0.5;
	int law = argc > 6 ? atoi(argv[6]) : 0;
	if (nx < 1 || ny < 1 || nz < 1 || steps < 1) {
		fprintf(stderr, "md_bench: NX NY NZ STEPS must be >= 1\n");
		return 2;
	}
	int n = nx * ny * nz;
	const double a = 1.05;
	double *x = malloc(3 * sizeof(double) * n), *v = malloc(3 * sizeof(double) * n);
	if (!x || !v)
		return 1;
	uint64_t s = 42;
	for (int i = 0; i < n; i++) {
		int c[3] = {i % nx, i / (nx * nz), (i / nx) % nz};
		for (int k = 0; k < 3; k++) {
			s = s * 6364136223846793005ull + 1442695040888963407ull;
			x[3 * i + k] = (c[k] + 0.5) * a;
			v[3 * i + k] = 0.1 * ((double)(s >> 11) * 0x1.0p-53 - 0.5);
		}
	}
	md_params_t p = {0};
	p.dim = 3;
	p.n = n;
	p.radius = 0.5;
	p.mass = 1.0;
	p.box[0] = nx * a;
	p.box[1] = 2.0 * ny * a;
	p.box[2] = nz * a;
	p.periodic[0] = p.periodic[2] = 1;
	p.gravity[1] = -100.0;
	p.law = law ? MD_LAW_HERTZ : MD_LAW_LINEAR;
	p.restitution = 0.5;
	p.kn = 2e5;
	p.young = 1e6;
	p.v_ref = 2.0;
	p.mu = mu;
	p.x = x;
	p.v = v;
	int err;
	md_t *md = md_create(&p, &err);
	if (!md) {
		fprintf(stderr, "md_bench: %s\n", md_strerror(err));
		return 1;
	}
	err = md_step(md, steps);
	long r0 = md_rebuilds(md);
	double t0 = now(CLOCK_MONOTONIC), c0 = now(CLOCK_PROCESS_CPUTIME_ID);
	if (!err)
		err = md_step(md, steps);
	double el = now(CLOCK_MONOTONIC) - t0, cpu = now(CLOCK_PROCESS_CPUTIME_ID) - c0;
	if (err) {
		fprintf(stderr, "md_bench: %s\n", md_strerror(err));
		return 1;
	}
	/* CPU time as well: on a shared machine the wall clock counts other jobs' time */
	printf("N %d steps %ld dt %.3g wall %.3g s cpu %.3g s particle-steps/s %.4g (wall) %.4g (cpu) contacts/particle %.2f rebuilds %ld\n",
		n, steps, md_dt(md), el, cpu, (double)n * steps / el, (double)n * steps / cpu, (double)md_contact_count(md) / n,
		md_rebuilds(md) - r0);
	md_destroy(md);
	free(x);
	free(v);
	return 0;
}
