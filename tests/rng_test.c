/* Tests of the random number generator: determinism, streams, and moments of the deviates. */
#include <math.h>
#include "rng.h"
#include "tap.h"

int main(void)
{
	rng_t a, b, c;
	rng_init(&a, 42, 0);
	rng_init(&b, 42, 0);
	rng_init(&c, 42, 1);
	int same = 1, differ = 0;
	for (int i = 0; i < 1000; i++) {
		uint64_t x = rng_u64(&a), y = rng_u64(&b), z = rng_u64(&c);
		same &= x == y;
		differ += x != z;
	}
	ok(same, "same seed and stream give the same sequence");
	ok(differ == 1000, "another stream gives a different sequence");

	/* Moments of 10^6 deviates: the standard error of a mean of n draws of
	 * variance v is sqrt(v/n); we allow 5 standard errors. */
	const int n = 1000000;
	double su = 0, su2 = 0, sg = 0, sg2 = 0, sg4 = 0;
	int in_range = 1;
	for (int i = 0; i < n; i++) {
		double u = rng_uniform(&a), g = rng_gauss(&a);
		in_range &= u >= 0.0 && u < 1.0;
		su += u, su2 += u * u;
		sg += g, sg2 += g * g, sg4 += g * g * g * g;
	}
	ok(in_range, "uniform deviates lie in [0, 1)");
	ok(fabs(su / n - 0.5) < 5 * sqrt(1.0 / 12 / n), "uniform mean %.5f", su / n);
	ok(fabs(su2 / n - 1.0 / 3) < 5 * sqrt(4.0 / 45 / n), "uniform second moment %.5f", su2 / n);
	ok(fabs(sg / n) < 5 * sqrt(1.0 / n), "gaussian mean %.5f", sg / n);
	ok(fabs(sg2 / n - 1) < 5 * sqrt(2.0 / n), "gaussian variance %.5f", sg2 / n);
	ok(fabs(sg4 / n - 3) < 5 * sqrt(96.0 / n), "gaussian fourth moment %.4f (3 expected)", sg4 / n);
	plan(tap_n);
	return done_testing();
}
