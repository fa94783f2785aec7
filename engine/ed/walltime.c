/* Contact time of a particle with a vibrating wall: the time axis cut at the wall's inflection points, then bracketed monotone root searches. */
#include <float.h>
#include <math.h>

#include "roots.h"
#include "walltime.h"

#define TWO_PI 6.28318530717958647692

typedef struct {
	double d, u, gam, A, omega, th0, s0;
} gap_t;

/* h(t): sin(th0 + w t) - sin th0 = 2 cos(th0 + w t / 2) sin(w t / 2), so
 * that small t lose no digits against d. */
static double h(const void *ctx, double t)
{
	const gap_t *g = ctx;
	double half = 0.5 * g->omega * t;
	return g->d + t * (g->u + 0.5 * g->gam * t) - 2.0 * g->A * cos(g->th0 + half) * sin(half);
}

static double dh(const void *ctx, double t)
{
	const gap_t *g = ctx;
	return g->u + g->gam * t - g->A * g->omega * cos(g->th0 + g->omega * t);
}

static double d2h(const gap_t *g, double t)
{
	return g->gam + g->A * g->omega * g->omega * sin(g->th0 + g->omega * t);
}

double walltime_vibrating(double d, double u, double gam, double A, double omega, double theta0, double horizon)
{
	if (A == 0.0 || omega == 0.0) {
		double t = walltime_plane(d, u, gam);
		return t <= horizon ? t : INFINITY;
	}
	if (!(horizon >= 0.0))
		return INFINITY;
	const gap_t g = {d, u, gam, A, omega, theta0, 0.0};
	/* Inflection points of h: sin(theta) = q. */
	const double q = -gam / (A * omega * omega);
	double r[2] = {0.0, 0.0};
	int cuts = fabs(q) < 1.0;
	if (cuts) {
		double al = asin(q);
		r[0] = al < 0.0 ? al + TWO_PI : al;
		r[1] = 3.14159265358979323846 - al;
		if (r[1] < r[0]) {
			double x = r[0];
			r[0] = r[1], r[1] = x;
		}
	}
	double phi = fmod(theta0, TWO_PI);
	if (phi < 0.0)
		phi += TWO_PI;
	/* The next inflection after phi: index m of the sequence
	 * r[m & 1] + 2 pi (m >> 1). */
	long m = 0;
	if (cuts)
		while (r[m & 1] + TWO_PI * (double)(m >> 1) <= phi)
			m++;
	double a = 0.0;
	for (long k = 0; k < 4000000; k++) {
		double b = horizon;
		if (cuts) {
			double tb = (r[m & 1] + TWO_PI * (double)(m >> 1) - phi) / omega;
			m++;
			if (tb < b)
				b = tb;
		}
		if (b > a) {
			int concave = d2h(&g, 0.5 * (a + b)) <= 0.0;
			double t = roots_piece(h, dh, &g, a, b, concave);
			if (t < INFINITY)
				return t;
		} else if (a == 0.0 && b == 0.0) {
			/* a cut exactly now, or horizon 0: contact only if now */
			if (h(&g, 0.0) <= 0.0 && dh(&g, 0.0) < 0.0)
				return 0.0;
		}
		if (b >= horizon)
			break;
		a = b;
	}
	return INFINITY;
}
