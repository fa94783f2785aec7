/* Statistics shared by the physics tests: the mean of independent block means and its standard error. */
#pragma once

#include <math.h>

/* Mean and standard error of k >= 2 block means x[0..k-1]; the blocks must
 * be long against the correlation time so that they count as independent. */
static inline void mean_se(const double *x, int k, double *mean, double *se)
{
	double s = 0.0, s2 = 0.0;
	for (int i = 0; i < k; i++)
		s += x[i];
	*mean = s / k;
	for (int i = 0; i < k; i++)
		s2 += (x[i] - *mean) * (x[i] - *mean);
	*se = sqrt(s2 / (k - 1) / k);
}
