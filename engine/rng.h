/* Deterministic pseudo-random numbers (xoshiro256**, seeded by splitmix64) with portable deviates. */
#pragma once

#include <stdint.h>

/* Caller-owned state; copyable (a checkpoint stores the four words). */
typedef struct {
	uint64_t s[4];
} rng_t;

/* Seed from a 64-bit seed and a stream number (independent replicas/ranks). */
void rng_init(rng_t *r, uint64_t seed, uint64_t stream);
uint64_t rng_u64(rng_t *r);
/* Uniform in [0, 1) with 53 random bits. */
double rng_uniform(rng_t *r);
/* Standard normal deviate (polar Box-Muller without caching, so the state
 * alone determines the sequence). */
double rng_gauss(rng_t *r);

/* Inline copies of rng_u64()/rng_uniform() for hot loops (same sequence). */
static inline uint64_t rng_u64_fast(rng_t *r)
{
	uint64_t *s = r->s;
	uint64_t x = s[1] * 5;
	uint64_t out = ((x << 7) | (x >> 57)) * 9;
	uint64_t t = s[1] << 17;
	s[2] ^= s[0];
	s[3] ^= s[1];
	s[1] ^= s[2];
	s[0] ^= s[3];
	s[2] ^= t;
	s[3] = (s[3] << 45) | (s[3] >> 19);
	return out;
}

static inline double rng_uniform_fast(rng_t *r)
{
	return (double)(rng_u64_fast(r) >> 11) * 0x1.0p-53;
}
