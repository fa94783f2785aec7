/* Particle-obstacle contact times: closed form in free flight, bracketed roots of a piecewise convex/concave quartic under gravity; the obstacles' collision rules. */
#include <math.h>

#include "obstacle.h"
#include "roots.h"
#include "scene.h"

double obstacle_time_free(const double *x, const double *v, int dim, double S)
{
	double b = 0.0, r2 = 0.0, v2 = 0.0;
	for (int a = 0; a < dim; a++) {
		b += x[a] * v[a];
		r2 += x[a] * x[a];
		v2 += v[a] * v[a];
	}
	if (b >= 0.0)
		return INFINITY;   /* moving away (or at rest): never */
	const double c = r2 - S * S;
	if (c <= 0.0)
		return 0.0;        /* inside by rounding and approaching: now */
	const double disc = b * b - v2 * c;
	if (disc <= 0.0)
		return INFINITY;   /* misses */
	return c / (-b + sqrt(disc));
}

/* f(t) = |d(t)|^2 - S^2 and its derivatives, d = x + v t + g t^2 / 2. */
typedef struct {
	double x[3], v[3], g[3], S2;
	int dim;
} orbit_t;

static double of(const void *ctx, double t)
{
	const orbit_t *o = ctx;
	double s = 0.0;
	for (int a = 0; a < o->dim; a++) {
		double d = o->x[a] + t * (o->v[a] + 0.5 * o->g[a] * t);
		s += d * d;
	}
	return s - o->S2;
}

static double odf(const void *ctx, double t)
{
	const orbit_t *o = ctx;
	double s = 0.0;
	for (int a = 0; a < o->dim; a++) {
		double d = o->x[a] + t * (o->v[a] + 0.5 * o->g[a] * t);
		s += d * (o->v[a] + o->g[a] * t);
	}
	return 2.0 * s;
}

double obstacle_time_grav(const double *x, const double *v, const double *g, int dim, double S, double horizon)
{
	orbit_t o = { .S2 = S * S, .dim = dim };
	double g2 = 0.0, vg = 0.0, v2 = 0.0, xg = 0.0;
	for (int a = 0; a < dim; a++) {
		o.x[a] = x[a], o.v[a] = v[a], o.g[a] = g[a];
		g2 += g[a] * g[a];
		vg += v[a] * g[a];
		v2 += v[a] * v[a];
		xg += x[a] * g[a];
	}
	if (g2 == 0.0)
		return obstacle_time_free(x, v, dim, S);
	if (!(horizon >= 0.0))
		return INFINITY;
	{
		/* beyond T, |d| >= |g| t^2 / 2 - |v| t - |x| > S: no contact later */
		const double G = sqrt(g2), V = sqrt(v2), X = sqrt(x[0] * x[0] + x[1] * x[1] + (dim == 3 ? x[2] * x[2] : 0.0));
		const double T = (V + sqrt(V * V + 2.0 * G * (X + S))) / G * (1.0 + 1e-9) + 1e-300;
		if (!(horizon < T))
			horizon = T;
	}
	/* f''/2 = |v + g t|^2 + d.g = (3/2) g^2 t^2 + 3 (v.g) t + v^2 + x.g:
	 * its roots cut the axis into convex and concave pieces. */
	double cut[3];
	int nc = 0;
	{
		const double A = 1.5 * g2, B = 3.0 * vg, C = v2 + xg, disc = B * B - 4.0 * A * C;
		if (disc > 0.0) {
			const double q = -0.5 * (B + copysign(sqrt(disc), B));
			double r1 = q / A, r2 = q != 0.0 ? C / q : r1;
			if (r1 > r2) {
				double t = r1;
				r1 = r2, r2 = t;
			}
			if (r1 > 0.0 && r1 < horizon) cut[nc++] = r1;
			if (r2 > 0.0 && r2 < horizon && r2 > r1) cut[nc++] = r2;
		}
	}
	cut[nc++] = horizon;
	double a = 0.0;
	for (int k = 0; k < nc; k++) {
		const double b = cut[k];
		if (b > a) {
			const double m = 0.5 * (a + b);
			double f2 = v2 + xg + m * (3.0 * vg + 1.5 * g2 * m);
			double t = roots_piece(of, odf, &o, a, b, f2 <= 0.0);
			if (t < INFINITY)
				return t;
		} else if (a == 0.0 && b == 0.0) {
			if (of(&o, 0.0) <= 0.0 && odf(&o, 0.0) < 0.0)
				return 0.0;
		}
		a = b;
	}
	return INFINITY;
}

void obstacle_rule(int type, double r, double acc, double sv, double vmin, int relaxing, const double *nrm, double *v,
                   int dim, rng_t *rng)
{
	double vn = 0.0, vt[3] = {0.0, 0.0, 0.0};
	for (int a = 0; a < dim; a++)
		vn += v[a] * nrm[a];
	for (int a = 0; a < dim; a++)
		vt[a] = v[a] - vn * nrm[a];
	if (relaxing) {
		vn = fabs(vn);
	} else if (vn < 0.0) {
		switch (type) {
		case SCENE_OBST_NO_SLIP:
			if (rng_uniform(rng) < acc) {
				/* diffuse: flux-weighted Maxwellian of the obstacle at rest
				 * (Rayleigh normal; an isotropic Gaussian projected on the
				 * tangent plane is the tangential Gaussian) */
				vn = sv * sqrt(-2.0 * log(1.0 - rng_uniform(rng)));
				double gn = 0.0, gs[3] = {0.0, 0.0, 0.0};
				for (int a = 0; a < dim; a++) {
					gs[a] = sv * rng_gauss(rng);
					gn += gs[a] * nrm[a];
				}
				for (int a = 0; a < dim; a++)
					vt[a] = gs[a] - gn * nrm[a];
			} else {
				vn = -r * vn;
			}
			break;
		case SCENE_OBST_RANDOM_SIGN:
			vn = -r * vn;
			if (rng_uniform(rng) < 0.5)
				for (int a = 0; a < dim; a++)
					vt[a] = -vt[a];
			break;
		default:
			vn = -r * vn;
			break;
		}
	}
	if (!relaxing && vn < vmin)
		vn = vmin;
	for (int a = 0; a < dim; a++)
		v[a] = vt[a] + vn * nrm[a];
}
