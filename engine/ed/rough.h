/* The collision rule of rough disks and spheres (normal and tangential restitution, Walton's Coulomb rule): pure, inlined into the engine's rough kernels. */
#pragma once

#include <math.h>

/*
 * Contract
 * - Pure arithmetic on the caller's arrays; no state, no allocation.
 * - dim is 2 or 3 (a compile-time constant in the engine, so the branches
 *   on it vanish). Vectors have dim components; spins have 1 component in
 *   2D (about z) and 3 in 3D.
 * - Units: equal masses m, radius a (contact at distance 2a), moment of
 *   inertia I = q m a^2; n is the unit vector from particle 2 to particle 1.
 *
 * The rule (seed 001, Baryshev 2003, eqs. 3.56-3.69, after Walton 1993 and
 * Luding et al., PRE 58, 3416 (1998)), with M = m / 2:
 *   g   = v1 - v2 - a (w1 + w2) x n          slip velocity at the contact
 *   J_n = -(1 + e) M (g . n) n               so that g_n' = -e g_n
 *   J_t = -M q / (1 + q) (1 + beta) g_t      so that g_t' = -beta g_t (sticking)
 * Walton's rule (mu >= 0): where that tangential impulse exceeds mu |J_n|
 * the contact slides, J_t = -mu |J_n| g_t / |g_t|; i.e. the effective beta
 * is min(beta_0, -1 + mu (1 + e)(1 + 1/q) |g_n| / |g_t|). mu < 0: constant
 * beta. v1 += J / m, v2 -= J / m, and both spins change by -(a / I) n x J.
 * beta = -1 is smooth (J_t = 0); beta = +1 with e = 1 conserves the
 * translational plus rotational energy.
 */
typedef struct {
	double m, a, e, beta, mu, q;
} rough_rule_t;

/* Apply the collision to v1, v2 (dim each) and w1, w2 (1 or 3 each) for
 * approaching particles (gn = (v1 - v2) . n < 0). Returns the change of
 * the translational kinetic energy (J . (v1 - v2) + |J|^2 / m). */
static inline double rough_collide(int dim, const rough_rule_t *R, const double *n, double gn, double *v1, double *v2,
                                   double *w1, double *w2)
{
	const double m = R->m, M = 0.5 * m, a = R->a, q = R->q;
	double dv[3], gt[3], J[3], Jt[3], gt2 = 0.0, de = 0.0;
	for (int k = 0; k < dim; k++)
		dv[k] = v1[k] - v2[k];
	/* g_t = dv - g_n n - a W x n (W x n is tangential) */
	if (dim == 2) {
		const double W = w1[0] + w2[0];
		gt[0] = dv[0] - gn * n[0] + a * W * n[1];
		gt[1] = dv[1] - gn * n[1] - a * W * n[0];
	} else {
		const double W[3] = {w1[0] + w2[0], w1[1] + w2[1], w1[2] + w2[2]};
		gt[0] = dv[0] - gn * n[0] - a * (W[1] * n[2] - W[2] * n[1]);
		gt[1] = dv[1] - gn * n[1] - a * (W[2] * n[0] - W[0] * n[2]);
		gt[2] = dv[2] - gn * n[2] - a * (W[0] * n[1] - W[1] * n[0]);
	}
	for (int k = 0; k < dim; k++)
		gt2 += gt[k] * gt[k];
	const double jn = -(1.0 + R->e) * M * gn;           /* |J_n| */
	double ct = M * q / (1.0 + q) * (1.0 + R->beta);   /* J_t = -ct g_t (sticking) */
	if (R->mu >= 0.0 && ct * sqrt(gt2) > R->mu * jn)
		ct = R->mu * jn / sqrt(gt2);                    /* sliding: |J_t| = mu |J_n| */
	for (int k = 0; k < dim; k++) {
		Jt[k] = -ct * gt[k];
		J[k] = jn * n[k] + Jt[k];
		de += J[k] * dv[k] + J[k] * J[k] / m;
		v1[k] += J[k] / m;
		v2[k] -= J[k] / m;
	}
	/* spins: -(a / I) n x J = -(1 / (q m a)) n x J_t (from J_t alone, so
	 * that a smooth collision leaves them exactly as they were) */
	const double s = -1.0 / (q * m * a);
	if (dim == 2) {
		const double dw = s * (n[0] * Jt[1] - n[1] * Jt[0]);
		w1[0] += dw;
		w2[0] += dw;
	} else {
		const double dw[3] = {s * (n[1] * Jt[2] - n[2] * Jt[1]), s * (n[2] * Jt[0] - n[0] * Jt[2]),
		                      s * (n[0] * Jt[1] - n[1] * Jt[0])};
		for (int k = 0; k < 3; k++) {
			w1[k] += dw[k];
			w2[k] += dw[k];
		}
	}
	return de;
}

/*
 * Unequal particles (mixtures): masses m1, m2, radii a1, a2, moments of
 * inertia I_i = q m_i a_i^2 (one q for all). With the reduced mass
 * mu = m1 m2 / (m1 + m2) the rule above holds with M -> mu:
 *   g   = v1 - v2 - (a1 w1 + a2 w2) x n
 *   J_n = -(1 + e) mu (g . n) n,   J_t = -mu q / (1 + q) (1 + beta) g_t
 * (a tangential impulse J_t changes g_t by (1/m1 + 1/m2)(1 + 1/q) J_t),
 * Walton's cap |J_t| <= mu_c |J_n| as above; v1 += J / m1, v2 -= J / m2,
 * w_i += -(a_i / I_i) n x J_t = -(1 / (q m_i a_i)) n x J_t. Linear momentum
 * and the angular momentum about the contact point are conserved; with
 * e = 1 and beta = +-1 the energy (translational plus rotational) too.
 */
typedef struct {
	double m1, m2, a1, a2, e, beta, mu, q;
} rough_pair_t;

/* As rough_collide() for unequal particles; returns the change of the
 * translational kinetic energy (J . (v1 - v2) + |J|^2 / (2 mu)). */
static inline double rough_collide_pair(int dim, const rough_pair_t *R, const double *n, double gn, double *v1,
                                        double *v2, double *w1, double *w2)
{
	const double m1 = R->m1, m2 = R->m2, mu = m1 * m2 / (m1 + m2), q = R->q;
	double dv[3], gt[3], J[3], Jt[3], gt2 = 0.0, de = 0.0, jj = 0.0;
	for (int k = 0; k < dim; k++)
		dv[k] = v1[k] - v2[k];
	if (dim == 2) {
		const double W = R->a1 * w1[0] + R->a2 * w2[0];   /* (a1 w1 + a2 w2) about z */
		gt[0] = dv[0] - gn * n[0] + W * n[1];
		gt[1] = dv[1] - gn * n[1] - W * n[0];
	} else {
		double W[3];
		for (int k = 0; k < 3; k++)
			W[k] = R->a1 * w1[k] + R->a2 * w2[k];
		gt[0] = dv[0] - gn * n[0] - (W[1] * n[2] - W[2] * n[1]);
		gt[1] = dv[1] - gn * n[1] - (W[2] * n[0] - W[0] * n[2]);
		gt[2] = dv[2] - gn * n[2] - (W[0] * n[1] - W[1] * n[0]);
	}
	for (int k = 0; k < dim; k++)
		gt2 += gt[k] * gt[k];
	const double jn = -(1.0 + R->e) * mu * gn;
	double ct = mu * q / (1.0 + q) * (1.0 + R->beta);
	if (R->mu >= 0.0 && ct * sqrt(gt2) > R->mu * jn)
		ct = R->mu * jn / sqrt(gt2);
	for (int k = 0; k < dim; k++) {
		Jt[k] = -ct * gt[k];
		J[k] = jn * n[k] + Jt[k];
		de += J[k] * dv[k];
		jj += J[k] * J[k];
		v1[k] += J[k] / m1;
		v2[k] -= J[k] / m2;
	}
	de += 0.5 * jj / mu;
	const double s1 = -1.0 / (q * m1 * R->a1), s2 = -1.0 / (q * m2 * R->a2);
	if (dim == 2) {
		const double c = n[0] * Jt[1] - n[1] * Jt[0];
		w1[0] += s1 * c;
		w2[0] += s2 * c;
	} else {
		const double c[3] = {n[1] * Jt[2] - n[2] * Jt[1], n[2] * Jt[0] - n[0] * Jt[2], n[0] * Jt[1] - n[1] * Jt[0]};
		for (int k = 0; k < 3; k++) {
			w1[k] += s1 * c[k];
			w2[k] += s2 * c[k];
		}
	}
	return de;
}

/*
 * A particle (mass m1, radius a1, I_1 = q m1 a1^2) against a sphere of
 * infinite mass and moment of inertia without spin moving at u (seed 001's
 * frozen particles of a filter): the rule above with mu -> m1 (1/m2 and
 * a2^2/I_2 vanish):
 *   g   = v1 - u - a1 w1 x n
 *   J_n = -(1 + e) m1 (g . n) n,   J_t = -m1 q / (1 + q) (1 + beta) g_t
 * with Walton's cap; v1 += J / m1, w1 += -(1 / (q m1 a1)) n x J_t. The
 * particle's energy in the sphere's frame (translational plus rotational)
 * is conserved for e = 1 and beta = +-1. J (dim components, the impulse on
 * the particle) is returned in Jout.
 */
static inline void rough_collide_fixed(int dim, const rough_pair_t *R, const double *n, double gn, double *v1,
                                       const double *u, double *w1, double *Jout)
{
	const double m1 = R->m1, q = R->q;
	double gt[3], Jt[3], gt2 = 0.0;
	if (dim == 2) {
		const double W = R->a1 * w1[0];
		gt[0] = v1[0] - u[0] - gn * n[0] + W * n[1];
		gt[1] = v1[1] - u[1] - gn * n[1] - W * n[0];
	} else {
		double W[3];
		for (int k = 0; k < 3; k++)
			W[k] = R->a1 * w1[k];
		gt[0] = v1[0] - u[0] - gn * n[0] - (W[1] * n[2] - W[2] * n[1]);
		gt[1] = v1[1] - u[1] - gn * n[1] - (W[2] * n[0] - W[0] * n[2]);
		gt[2] = v1[2] - u[2] - gn * n[2] - (W[0] * n[1] - W[1] * n[0]);
	}
	for (int k = 0; k < dim; k++)
		gt2 += gt[k] * gt[k];
	const double jn = -(1.0 + R->e) * m1 * gn;
	double ct = m1 * q / (1.0 + q) * (1.0 + R->beta);
	if (R->mu >= 0.0 && ct * sqrt(gt2) > R->mu * jn)
		ct = R->mu * jn / sqrt(gt2);
	for (int k = 0; k < dim; k++) {
		Jt[k] = -ct * gt[k];
		Jout[k] = jn * n[k] + Jt[k];
		v1[k] += Jout[k] / m1;
	}
	const double s1 = -1.0 / (q * m1 * R->a1);
	if (dim == 2) {
		w1[0] += s1 * (n[0] * Jt[1] - n[1] * Jt[0]);
	} else {
		const double c[3] = {n[1] * Jt[2] - n[2] * Jt[1], n[2] * Jt[0] - n[0] * Jt[2], n[0] * Jt[1] - n[1] * Jt[0]};
		for (int k = 0; k < 3; k++)
			w1[k] += s1 * c[k];
	}
}
