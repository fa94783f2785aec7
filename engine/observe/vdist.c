/* Velocity distribution: two passes over the velocities (mean, then moments of c^2), histograms in a third. */
#include "vdist.h"

#include <math.h>
#include <string.h>

#define PI 3.14159265358979323846

void vdist_moments(int dim, size_t n, double mass, const double *vel, vdist_moments_t *out)
{
	memset(out, 0, sizeof(*out));
	/* Mean first: the moments are those of the peculiar velocities, which
	 * differ from v only when the total momentum is not zero. */
	for (size_t i = 0; i < n; i++)
		for (int a = 0; a < dim; a++)
			out->mean[a] += vel[i * dim + a];
	for (int a = 0; a < dim; a++)
		out->mean[a] /= (double)n;
	double s2 = 0, s4 = 0, s6 = 0;
	for (size_t i = 0; i < n; i++) {
		double w2 = 0;
		for (int a = 0; a < dim; a++) {
			double w = vel[i * dim + a] - out->mean[a];
			w2 += w * w;
		}
		s2 += w2;
		s4 += w2 * w2;
		s6 += w2 * w2 * w2;
	}
	double d = dim, w2m = s2 / (double)n;
	out->temperature = mass * w2m / d;
	if (!(w2m > 0)) {
		out->a2 = out->a3 = NAN;
		return;
	}
	/* c^2 = w^2 / v_T^2 with v_T^2 = 2 T / m = 2 <w^2> / d. */
	double vt2 = 2 * w2m / d;
	double c4 = s4 / (double)n / (vt2 * vt2), c6 = s6 / (double)n / (vt2 * vt2 * vt2);
	out->a2 = 4 * c4 / (d * (d + 2)) - 1;
	out->a3 = 1 + 3 * out->a2 - 8 * c6 / (d * (d + 2) * (d + 4));
}

void vdist_histograms(int dim, size_t n, double mass, const double *vel, const vdist_moments_t *m, int bins,
                      double range, double *comp, double *speed)
{
	memset(comp, 0, (size_t)dim * bins * sizeof(double));
	memset(speed, 0, (size_t)bins * sizeof(double));
	double vt = sqrt(2 * m->temperature / mass);
	if (!(vt > 0) || !(range > 0) || bins < 1)
		return;
	double inv = 1 / vt, cw = 2 * range / bins, sw = range / bins;
	for (size_t i = 0; i < n; i++) {
		double c2 = 0;
		for (int a = 0; a < dim; a++) {
			double c = (vel[i * dim + a] - m->mean[a]) * inv;
			c2 += c * c;
			double u = (c + range) / cw;
			if (u >= 0 && u < bins)
				comp[a * bins + (int)u] += 1;
		}
		double u = sqrt(c2) / sw;
		if (u < bins)
			speed[(int)u] += 1;
	}
	for (int k = 0; k < dim * bins; k++)
		comp[k] /= (double)n * cw;
	for (int k = 0; k < bins; k++)
		speed[k] /= (double)n * sw;
}

double vdist_maxwell_component(double c)
{
	return exp(-c * c) / sqrt(PI);
}

double vdist_maxwell_speed(int dim, double c)
{
	/* 2 c^(d-1) e^(-c^2) / Gamma(d/2): Gamma(1) = 1, Gamma(3/2) = sqrt(pi)/2 */
	double g = dim == 2 ? 1.0 : sqrt(PI) / 2;
	return 2 * pow(c, dim - 1) * exp(-c * c) / g;
}
