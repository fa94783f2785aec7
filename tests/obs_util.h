/* Shared by the observable unit tests: a seeded generator, uniform and Gaussian numbers, brute-force pair loops. */
#pragma once

#include <math.h>
#include <stdint.h>
#include <stdlib.h>

#define PI 3.14159265358979323846

static inline uint64_t splitmix64(uint64_t *s)
{
	uint64_t z = (*s += 0x9e3779b97f4a7c15ULL);
	z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
	z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
	return z ^ (z >> 31);
}

/* Uniform in [0, 1). */
static inline double uniform(uint64_t *s) { return (double)(splitmix64(s) >> 11) * 0x1.0p-53; }

/* Standard normal (Box-Muller). */
static inline double gauss(uint64_t *s)
{
	double u = uniform(s), v = uniform(s);
	return sqrt(-2 * log(1 - u)) * cos(2 * PI * v);
}

/* Uniform random positions in the box (n*dim). */
static inline void random_positions(int dim, size_t n, const double *box, uint64_t *seed, double *pos)
{
	for (size_t i = 0; i < n; i++)
		for (int a = 0; a < dim; a++)
			pos[i * dim + a] = uniform(seed) * box[a];
}
