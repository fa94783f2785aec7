/* Soft-sphere MD (DEM): linear/Hertz contacts with restitution-derived damping, Cundall-Strack friction, velocity Verlet. */
#include "md/md.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#define MD_PI 3.14159265358979323846
#define MD_ETA_R 0.3   /* rolling dashpot's damping ratio (Ai et al. 2011) */

typedef struct {
	int i, j;
	double s[3];             /* periodic image shift added to x_j */
} md_pair_t;

typedef struct {
	int partner;             /* j >= 0, or -1 - (2 axis + side) for a wall */
	double xi[3];            /* tangential spring */
} md_slot_t;

struct md {
	int dim, n, law, friction, slots;
	int periodic[3];
	double L[3], g[3];
	double *x, *v, *w, *f, *t, *xref;
	double *r, *m, *im, *iI;
	double e, beta, kn, young, alpha, mu, ktr, sqrt_ktr;
	int pairwise, ns;        /* restitution per pair of species: species of each particle, damp[a * ns + b] the */
	int *sp;                 /* pair's beta (linear) or alpha (hertz) */
	double damp[MD_SPECIES_MAX * MD_SPECIES_MAX];
	int rolling;             /* mu_r > 0: rolling springs rold/rnew, 3 per slot, swapped with hold/hnew */
	double mu_r;
	double *rold, *rnew;
	double *iroll;           /* 1 / (I_i + m_i R_i^2): the rolling inertia about the contact point, inverse */
	double dt, tc, skin, rmax;
	md_pair_t *pairs;
	size_t np, capp;
	int nc[3];
	size_t ncell;
	int *head, *next;
	md_slot_t *hold, *hnew;
	int *nold, *nnew;
	size_t ncontacts;
	long steps, rebuilds;
	int walled;              /* some axis has walls: their forces are summed (wf, wimp) */
	double wf[6][3];         /* force on each wall w = 2 axis + side at the last force pass */
	double wimp[6][3];       /* momentum given to each wall since the last md_wall_reset() */
	long wsteps;             /* steps at the last md_wall_reset() */
	int wmoving;             /* some wall moves or vibrates (wv, wamp, womega, wphase) */
	double wv[6][3], wamp[6], womega[6], wphase[6];
	int nob;                 /* obstacles: centres, radii, forces at the last pass, impulses */
	double oc[MD_OBSTACLES_MAX][3], orad[MD_OBSTACLES_MAX], of[MD_OBSTACLES_MAX][3], oimp[MD_OBSTACLES_MAX][3];
	int track;               /* params.virial: vir, kin and their integrals */
	double vir, kin;         /* pair virial at the last force pass, sum m v^2 at the last full step */
	double virint, kinint;   /* their integrals since the last md_wall_reset() */
};

static inline double dot3(const double *a, const double *b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }

/* sum m v^2 now */
static double mv2(const md_t *md)
{
	double k = 0.0;
	for (int i = 0; i < md->n; i++)
		k += md->m[i] * dot3(md->v + 3 * i, md->v + 3 * i);
	return k;
}

static inline void cross3(const double *a, const double *b, double *c)
{
	c[0] = a[1] * b[2] - a[2] * b[1];
	c[1] = a[2] * b[0] - a[0] * b[2];
	c[2] = a[0] * b[1] - a[1] * b[0];
}

/* A spring held from the last pass rotated into the tangent plane of normal n, its length kept. */
static inline void tangent_keep(double *x, const double *n)
{
	double l2 = dot3(x, x);
	if (l2 > 0.0) {
		double xn = dot3(x, n);
		for (int a = 0; a < 3; a++)
			x[a] -= xn * n[a];
		double p2 = dot3(x, x);
		if (p2 > 0.0) {
			double sc = sqrt(l2 / p2);
			for (int a = 0; a < 3; a++)
				x[a] *= sc;
		}
	}
}

/*
 * Hertz with Tsuji damping in units of the impact: X'' = -X^(3/2) - alpha
 * X^(1/4) X', X(0) = 0, X'(0) = 1, RK4 with step h; returns e = -X' when X
 * comes back to 0 (linear interpolation in the last step), *tau the
 * dimensionless contact time. 0 when it never comes back (overdamped).
 */
static double hertz_restitution(double alpha, double *tau)
{
	const double h = 2e-4;
	double X = 0.0, V = 1.0, t = 0.0;
	for (long k = 0; k < 1000000; k++) {
		double k1x, k1v, k2x, k2v, k3x, k3v, k4x, k4v, y;
#define HACC(XX, VV) (y = fmax((XX), 0.0), -y * sqrt(y) - alpha * sqrt(sqrt(y)) * (VV))
		k1x = V;
		k1v = HACC(X, V);
		k2x = V + 0.5 * h * k1v;
		k2v = HACC(X + 0.5 * h * k1x, k2x);
		k3x = V + 0.5 * h * k2v;
		k3v = HACC(X + 0.5 * h * k2x, k3x);
		k4x = V + h * k3v;
		k4v = HACC(X + h * k3x, k4x);
#undef HACC
		double Xn = X + h / 6.0 * (k1x + 2 * k2x + 2 * k3x + k4x);
		double Vn = V + h / 6.0 * (k1v + 2 * k2v + 2 * k3v + k4v);
		if (Xn <= 0.0 && k > 0) {
			double fr = X / (X - Xn);
			*tau = t + fr * h;
			return -(V + fr * (Vn - V));
		}
		X = Xn;
		V = Vn;
		t += h;
	}
	*tau = INFINITY;
	return 0.0;
}

/* alpha(e) of the hertz law by bisection: e(alpha) decreases from 1 at alpha = 0. */
static double hertz_alpha(double e)
{
	double lo = 0.0, hi = 1.0, tau;
	if (!(e < 1.0))
		return 0.0;
	while (hertz_restitution(hi, &tau) > e && hi < 1e3)
		hi *= 2.0;
	for (int it = 0; it < 60 && hi - lo > 1e-12 * hi; it++) {
		double mid = 0.5 * (lo + hi);
		if (hertz_restitution(mid, &tau) > e)
			lo = mid;
		else
			hi = mid;
	}
	return 0.5 * (lo + hi);
}

static double restitution_beta(double e)
{
	double le = log(e);
	return -le / sqrt(MD_PI * MD_PI + le * le);
}

const char *md_strerror(int code)
{
	switch (code) {
	case MD_OK: return "ok";
	case MD_E_NOMEM: return "out of memory";
	case MD_E_PARAM: return "invalid md parameter";
	case MD_E_BOX: return "periodic box shorter than twice the neighbour cut-off (2 R_max + skin)";
	case MD_E_CONTACTS: return "a particle has more contacts than max_contacts";
	case MD_E_UNSTABLE: return "a position became non-finite (time step too large for the contact stiffness)";
	default: return "unknown md error";
	}
}

/* The half Verlet list of the reference positions xref (cell lists); a function of xref alone, so a
 * restored state gets the list its last build made. */
static int build_pairs(md_t *md)
{
	const int n = md->n;
	double rc = 2.0 * md->rmax + md->skin;
	double cs[3];
	for (int a = 0; a < 3; a++) {
		int nc = a < md->dim ? (int)floor(md->L[a] / rc) : 1;
		if (nc < 1)
			nc = 1;
		if (md->periodic[a] && nc < 3)
			nc = 1;
		if (nc > 1024)
			nc = 1024;
		md->nc[a] = nc;
		cs[a] = a < md->dim ? md->L[a] / nc : 1.0;
	}
	size_t ncell = (size_t)md->nc[0] * md->nc[1] * md->nc[2];
	if (ncell > md->ncell) {
		int *h = realloc(md->head, ncell * sizeof(int));
		if (!h)
			return MD_E_NOMEM;
		md->head = h;
		md->ncell = ncell;
	}
	for (size_t c = 0; c < ncell; c++)
		md->head[c] = -1;
	for (int i = n - 1; i >= 0; i--) {
		int ci[3];
		for (int a = 0; a < 3; a++) {
			int c = a < md->dim ? (int)floor(md->xref[3 * i + a] / cs[a]) : 0;
			ci[a] = c < 0 ? 0 : c >= md->nc[a] ? md->nc[a] - 1 : c;
		}
		size_t c = ((size_t)ci[2] * md->nc[1] + ci[1]) * md->nc[0] + ci[0];
		md->next[i] = md->head[c];
		md->head[c] = i;
	}
	md->np = 0;
	for (int i = 0; i < n; i++) {
		const double *xi = md->xref + 3 * i;
		int ci[3], lo[3], hi[3];
		for (int a = 0; a < 3; a++) {
			int c = a < md->dim ? (int)floor(xi[a] / cs[a]) : 0;
			ci[a] = c < 0 ? 0 : c >= md->nc[a] ? md->nc[a] - 1 : c;
			lo[a] = md->nc[a] >= 3 || (!md->periodic[a] && md->nc[a] > 1) ? -1 : 0;
			hi[a] = -lo[a];
		}
		for (int oz = lo[2]; oz <= hi[2]; oz++)
			for (int oy = lo[1]; oy <= hi[1]; oy++)
				for (int ox = lo[0]; ox <= hi[0]; ox++) {
					int o[3] = {ox, oy, oz}, cc[3];
					int skip = 0;
					for (int a = 0; a < 3; a++) {
						cc[a] = ci[a] + o[a];
						if (cc[a] < 0 || cc[a] >= md->nc[a]) {
							if (!md->periodic[a])
								skip = 1;
							cc[a] = (cc[a] + md->nc[a]) % md->nc[a];
						}
					}
					if (skip)
						continue;
					size_t c = ((size_t)cc[2] * md->nc[1] + cc[1]) * md->nc[0] + cc[0];
					for (int j = md->head[c]; j >= 0; j = md->next[j]) {
						if (j <= i)
							continue;
						const double *xj = md->xref + 3 * j;
						double d[3], s[3] = {0.0, 0.0, 0.0};
						for (int a = 0; a < 3; a++) {
							d[a] = xj[a] - xi[a];
							if (a < md->dim && md->periodic[a]) {
								s[a] = -md->L[a] * nearbyint(d[a] / md->L[a]);
								d[a] += s[a];
							}
						}
						double cut = md->r[i] + md->r[j] + md->skin;
						if (dot3(d, d) >= cut * cut)
							continue;
						if (md->np == md->capp) {
							size_t cap = md->capp ? 2 * md->capp : 1024;
							md_pair_t *p = realloc(md->pairs, cap * sizeof(*p));
							if (!p)
								return MD_E_NOMEM;
							md->pairs = p;
							md->capp = cap;
						}
						md_pair_t *p = md->pairs + md->np++;
						p->i = i;
						p->j = j;
						memcpy(p->s, s, sizeof(s));
					}
				}
	}
	return MD_OK;
}

/* Verlet-list build: positions wrapped into the box on periodic axes, taken as the reference, pairs. */
static int rebuild(md_t *md)
{
	const int n = md->n;
	for (int i = 0; i < n; i++) {
		double *xi = md->x + 3 * i;
		for (int a = 0; a < 3; a++) {
			if (!isfinite(xi[a]))
				return MD_E_UNSTABLE;
			if (a < md->dim && md->periodic[a])
				xi[a] -= md->L[a] * floor(xi[a] / md->L[a]);
		}
	}
	memcpy(md->xref, md->x, (size_t)n * 3 * sizeof(double));
	int rc = build_pairs(md);
	if (rc)
		return rc;
	md->rebuilds++;
	return MD_OK;
}

/*
 * One contact: i against partner (j >= 0 or a wall code), normal n from i to
 * the partner, overlap delta, damping coefficient damp (beta for the linear
 * law, alpha for hertz), relative contact velocity vrel (of i's surface
 * relative to the partner's), lever arms li, lj from the centres to the
 * contact point; rolling: the relative spin wr (w_i - w_j) and the pair's
 * rolling inertia ir. Returns the force on i in fc (on j: -fc) and adds the
 * torques about each centre to ti and tj (tj NULL for a wall).
 */
static inline __attribute__((always_inline)) int contact(md_t *md, const int law, const int friction,
	const int rolling, int i, int partner, const double *n, double delta, double meff, double reff, double damp,
	const double *vrel, const double *wr, double ir, double li, double lj, double dth, double *fc, double *ti,
	double *tj)
{
	double vn = dot3(vrel, n);
	double fn, eta, kt = 0.0, kN = 0.0;
	if (law == MD_LAW_LINEAR) {
		eta = 2.0 * damp * sqrt(md->kn * meff);
		fn = md->kn * delta + eta * vn;
		if (friction)
			kt = md->ktr * md->kn;
		if (rolling)
			kN = md->kn;
	} else {
		double sd = sqrt(delta);
		double kh = 4.0 / 3.0 * md->young * sqrt(reff);
		eta = damp * sqrt(meff * kh) * sqrt(sd);
		fn = kh * delta * sd + eta * vn;
		if (friction)
			kt = md->ktr * 1.5 * kh * sd;
		if (rolling)
			kN = 1.5 * kh * sd;
	}
	for (int a = 0; a < 3; a++)
		fc[a] = -fn * n[a];
	md->ncontacts++;
	if (!friction)
		return MD_OK;
	double xi[3] = {0.0, 0.0, 0.0};
	const md_slot_t *old = md->hold + (size_t)i * md->slots;
	int ko = -1;
	for (int k = 0; k < md->nold[i]; k++)
		if (old[k].partner == partner) {
			ko = k;
			memcpy(xi, old[k].xi, sizeof(xi));
			double l2 = dot3(xi, xi);
			if (l2 > 0.0) {
				double xn = dot3(xi, n);
				for (int a = 0; a < 3; a++)
					xi[a] -= xn * n[a];
				double p2 = dot3(xi, xi);
				if (p2 > 0.0) {
					double sc = sqrt(l2 / p2);
					for (int a = 0; a < 3; a++)
						xi[a] *= sc;
				}
			}
			break;
		}
	double vt[3], ft[3];
	double etat = eta * md->sqrt_ktr;
	for (int a = 0; a < 3; a++) {
		vt[a] = vrel[a] - vn * n[a];
		xi[a] += vt[a] * dth;
		ft[a] = -kt * xi[a] - etat * vt[a];
	}
	double lim = md->mu * (fn > 0.0 ? fn : 0.0);
	double f2 = dot3(ft, ft);
	if (f2 > lim * lim) {
		double sc = lim / sqrt(f2);
		for (int a = 0; a < 3; a++) {
			ft[a] *= sc;
			xi[a] = kt > 0.0 ? -(ft[a] + etat * vt[a]) / kt : 0.0;
		}
	}
	for (int a = 0; a < 3; a++)
		fc[a] += ft[a];
	double tq[3];
	cross3(n, ft, tq);
	for (int a = 0; a < 3; a++) {
		ti[a] += li * tq[a];
		if (tj)
			tj[a] += lj * tq[a];
	}
	double mr[3] = {0.0, 0.0, 0.0};
	if (rolling) {   /* EPSD (md.h): spring cut at mu_r R_eff f_n, dashpot below the cut */
		if (ko >= 0) {
			memcpy(mr, md->rold + 3 * ((size_t)i * md->slots + ko), sizeof(mr));
			tangent_keep(mr, n);
		}
		double kr = 2.25 * kN * md->mu_r * md->mu_r * reff * reff, wrn = dot3(wr, n), wt[3], tr[3];
		for (int a = 0; a < 3; a++) {
			wt[a] = wr[a] - wrn * n[a];
			mr[a] -= kr * wt[a] * dth;
		}
		double mlim = md->mu_r * reff * (fn > 0.0 ? fn : 0.0), m2 = dot3(mr, mr);
		if (m2 > mlim * mlim) {
			double sc = mlim / sqrt(m2);
			for (int a = 0; a < 3; a++)
				tr[a] = mr[a] *= sc;
		} else {
			double cr = 2.0 * MD_ETA_R * sqrt(ir * kr);
			for (int a = 0; a < 3; a++)
				tr[a] = mr[a] - cr * wt[a];
		}
		for (int a = 0; a < 3; a++) {
			ti[a] += tr[a];
			if (tj)
				tj[a] -= tr[a];
		}
	}
	if (md->nnew[i] >= md->slots)
		return MD_E_CONTACTS;
	if (rolling)
		memcpy(md->rnew + 3 * ((size_t)i * md->slots + md->nnew[i]), mr, sizeof(mr));
	md_slot_t *s = md->hnew + (size_t)i * md->slots + md->nnew[i]++;
	s->partner = partner;
	memcpy(s->xi, xi, sizeof(xi));
	return MD_OK;
}

/* Forces and torques at the current positions (time t); dth is the time since the last pass (spring
 * increments), tv the time of the velocities (t - dt/2 in a step: the walls' velocities are taken then). */
static inline __attribute__((always_inline)) int forces_impl(md_t *md, double dth, double t, double tv,
	const int law, const int friction, const int pairwise, const int rolling)
{
	const int n = md->n;
	int rc = MD_OK;
	const double damp0 = law == MD_LAW_LINEAR ? md->beta : md->alpha;   /* walls, obstacles, one restitution */
	md_slot_t *hs = md->hold;
	md->hold = md->hnew;
	md->hnew = hs;
	if (rolling) {
		double *rs = md->rold;
		md->rold = md->rnew;
		md->rnew = rs;
	}
	int *ns = md->nold;
	md->nold = md->nnew;
	md->nnew = ns;
	memset(md->nnew, 0, (size_t)n * sizeof(int));
	for (int i = 0; i < n; i++)
		for (int a = 0; a < 3; a++) {
			md->f[3 * i + a] = md->m[i] * md->g[a];
			md->t[3 * i + a] = 0.0;
		}
	md->ncontacts = 0;
	double vir = 0.0;
	if (md->walled)
		memset(md->wf, 0, sizeof md->wf);
	for (size_t p = 0; p < md->np; p++) {
		const md_pair_t *pp = md->pairs + p;
		const int i = pp->i, j = pp->j;
		const double *xi = md->x + 3 * i, *xj = md->x + 3 * j;
		double d[3] = {xj[0] - xi[0] + pp->s[0], xj[1] - xi[1] + pp->s[1], xj[2] - xi[2] + pp->s[2]};
		double r2 = dot3(d, d), sr = md->r[i] + md->r[j];
		if (r2 >= sr * sr)
			continue;
		double dist = sqrt(r2);
		double nv[3] = {d[0] / dist, d[1] / dist, d[2] / dist};
		/* lever arms to the contact point (mid-overlap): li + lj = dist, so torques conserve angular momentum */
		double ri = md->r[i], rj = md->r[j], li = ri - 0.5 * (sr - dist), lj = rj - 0.5 * (sr - dist);
		double wsum[3], wxn[3], vrel[3], fc[3];
		for (int a = 0; a < 3; a++)
			wsum[a] = li * md->w[3 * i + a] + lj * md->w[3 * j + a];
		cross3(wsum, nv, wxn);
		for (int a = 0; a < 3; a++)
			vrel[a] = md->v[3 * i + a] - md->v[3 * j + a] + (friction ? wxn[a] : 0.0);
		double meff = md->m[i] * md->m[j] / (md->m[i] + md->m[j]);
		double reff = ri * rj / sr;
		double dmp = pairwise ? md->damp[md->sp[i] * md->ns + md->sp[j]] : damp0;
		double wr[3] = {0.0, 0.0, 0.0}, ir = 0.0;
		if (rolling) {
			for (int a = 0; a < 3; a++)
				wr[a] = md->w[3 * i + a] - md->w[3 * j + a];
			ir = 1.0 / (md->iroll[i] + md->iroll[j]);
		}
		int e = contact(md, law, friction, rolling, i, j, nv, sr - dist, meff, reff, dmp, vrel, wr, ir, li, lj, dth,
			fc, md->t + 3 * i, md->t + 3 * j);
		if (e)
			rc = e;
		for (int a = 0; a < 3; a++) {
			md->f[3 * i + a] += fc[a];
			md->f[3 * j + a] -= fc[a];
		}
		vir -= dot3(d, fc);   /* r_ij . f_ij with r_ij = -d: the friction force is normal to d */
	}
	md->vir = vir;
	/* the walls' displacements along their inward normals and velocities (0 for fixed walls: then the
	 * same bits as without the terms) */
	double off[6] = {0.0, 0.0, 0.0, 0.0, 0.0, 0.0}, wvel[6][3] = {{0.0}};
	if (md->wmoving)
		for (int w = 0; w < 6; w++) {
			memcpy(wvel[w], md->wv[w], sizeof wvel[w]);
			if (md->wamp[w] > 0.0) {
				off[w] = md->wamp[w] * sin(md->womega[w] * t + md->wphase[w]);
				wvel[w][w / 2] += (w % 2 ? -1.0 : 1.0) * md->wamp[w] * md->womega[w] *
						  cos(md->womega[w] * tv + md->wphase[w]);
			}
		}
	for (int i = 0; i < n; i++)
		for (int a = 0; a < md->dim; a++) {
			if (md->periodic[a])
				continue;
			double ri = md->r[i], xa = md->x[3 * i + a];
			for (int side = 0; side < 2; side++) {
				const int wl = 2 * a + side;
				double delta = side ? ri - ((md->L[a] - off[wl]) - xa) : ri - (xa - off[wl]);
				if (delta <= 0.0)
					continue;
				double nv[3] = {0.0, 0.0, 0.0}, wxn[3], vrel[3], fc[3];
				nv[a] = side ? 1.0 : -1.0;
				double li = ri - delta; /* centre to the contact point on the wall plane */
				cross3(md->w + 3 * i, nv, wxn);
				for (int b = 0; b < 3; b++)
					vrel[b] = (md->v[3 * i + b] + (friction ? li * wxn[b] : 0.0)) - wvel[wl][b];
				double ir = rolling ? 1.0 / md->iroll[i] : 0.0;
				int e = contact(md, law, friction, rolling, i, -1 - (2 * a + side), nv, delta, md->m[i], ri, damp0,
					vrel, md->w + 3 * i, ir, li, 0.0, dth, fc, md->t + 3 * i, NULL);
				if (e)
					rc = e;
				for (int b = 0; b < 3; b++)
					md->f[3 * i + b] += fc[b];
				for (int b = 0; b < 3; b++)
					md->wf[2 * a + side][b] -= fc[b];
			}
		}
	if (md->nob) {
		memset(md->of, 0, sizeof md->of);
		for (int i = 0; i < n; i++)
			for (int k = 0; k < md->nob; k++) {
				double d[3], r2 = 0.0, ri = md->r[i], sr = ri + md->orad[k];
				for (int a = 0; a < 3; a++) {   /* from i to the obstacle, minimum image on periodic axes */
					d[a] = md->oc[k][a] - md->x[3 * i + a];
					if (md->periodic[a])
						d[a] -= md->L[a] * floor(d[a] / md->L[a] + 0.5);
					r2 += d[a] * d[a];
				}
				if (r2 >= sr * sr)
					continue;
				double dist = sqrt(r2), delta = sr - dist;
				double nv[3] = {d[0] / dist, d[1] / dist, d[2] / dist}, wxn[3], vrel[3], fc[3];
				double li = ri - 0.5 * delta;   /* mid-overlap, as pairs */
				cross3(md->w + 3 * i, nv, wxn);
				for (int b = 0; b < 3; b++)
					vrel[b] = md->v[3 * i + b] + (friction ? li * wxn[b] : 0.0);
				double ir = rolling ? 1.0 / md->iroll[i] : 0.0;
				int e = contact(md, law, friction, rolling, i, -7 - k, nv, delta, md->m[i], ri * md->orad[k] / sr,
					damp0, vrel, md->w + 3 * i, ir, li, 0.0, dth, fc, md->t + 3 * i, NULL);
				if (e)
					rc = e;
				for (int b = 0; b < 3; b++) {
					md->f[3 * i + b] += fc[b];
					md->of[k][b] -= fc[b];
				}
			}
	}
	return rc;
}

/* The force pass specialised at create (law, friction, restitution per pair, rolling): no test of them per
 * contact. */
static inline __attribute__((always_inline)) int forces_law(md_t *md, double dth, double t, double tv, const int law)
{
	if (!md->friction)
		return md->pairwise ? forces_impl(md, dth, t, tv, law, 0, 1, 0) : forces_impl(md, dth, t, tv, law, 0, 0, 0);
	if (!md->rolling)
		return md->pairwise ? forces_impl(md, dth, t, tv, law, 1, 1, 0) : forces_impl(md, dth, t, tv, law, 1, 0, 0);
	return md->pairwise ? forces_impl(md, dth, t, tv, law, 1, 1, 1) : forces_impl(md, dth, t, tv, law, 1, 0, 1);
}

static int forces(md_t *md, double dth, double t, double tv)
{
	return md->law == MD_LAW_LINEAR ? forces_law(md, dth, t, tv, MD_LAW_LINEAR) :
					  forces_law(md, dth, t, tv, MD_LAW_HERTZ);
}

void md_destroy(md_t *md)
{
	if (!md)
		return;
	free(md->x);
	free(md->pairs);
	free(md->head);
	free(md->next);
	free(md->hold);
	free(md->hnew);
	free(md->nold);
	free(md->nnew);
	free(md->sp);
	free(md->rold);
	free(md->rnew);
	free(md->iroll);
	free(md);
}

md_t *md_create(const md_params_t *p, int *err)
{
	int rc = MD_E_PARAM;
	md_t *md = NULL;
	if (!p || (p->dim != 2 && p->dim != 3) || p->n < 1)
		goto cleanup;
	if (!(p->restitution > 0.0 && p->restitution <= 1.0) || !(p->mu >= 0.0) || !(p->kt_ratio >= 0.0) ||
		!(p->dt >= 0.0) || !(p->dt_steps >= 0.0) || !(p->skin >= 0.0) || p->max_contacts < 0)
		goto cleanup;
	/* rolling resistance acts in the tangential springs' slots: with friction only */
	if (!(p->mu_r >= 0.0) || !isfinite(p->mu_r) || (p->mu_r > 0.0 && !(p->mu > 0.0)))
		goto cleanup;
	if (p->restitution_pair) {
		const int ns = p->n_species;
		if (ns < 1 || ns > MD_SPECIES_MAX || !p->species)
			goto cleanup;
		for (int a = 0; a < ns; a++)
			for (int b = 0; b < ns; b++) {
				double e = p->restitution_pair[a * ns + b];
				if (!(e > 0.0 && e <= 1.0) || e != p->restitution_pair[b * ns + a])
					goto cleanup;
			}
		for (int i = 0; i < p->n; i++)
			if (p->species[i] < 0 || p->species[i] >= ns)
				goto cleanup;
	}
	if (p->law != MD_LAW_LINEAR && p->law != MD_LAW_HERTZ)
		goto cleanup;
	for (int a = 0; a < p->dim; a++)
		if (!(p->box[a] > 0.0) || !isfinite(p->box[a]) || !isfinite(p->gravity[a]))
			goto cleanup;
	if (p->dim == 2 && p->gravity[2] != 0.0)
		goto cleanup;
	rc = MD_E_NOMEM;
	md = calloc(1, sizeof(*md));
	if (!md)
		goto cleanup;
	const int n = p->n;
	md->dim = p->dim;
	md->n = n;
	md->law = p->law;
	md->mu = p->mu;
	md->friction = p->mu > 0.0;
	md->rolling = p->mu_r > 0.0;
	md->mu_r = p->mu_r;
	md->pairwise = p->restitution_pair != NULL;
	md->ns = md->pairwise ? p->n_species : 0;
	md->ktr = p->kt_ratio > 0.0 ? p->kt_ratio : 2.0 / 7.0;
	md->sqrt_ktr = sqrt(md->ktr);
	md->slots = p->max_contacts > 0 ? p->max_contacts : (p->dim == 2 ? 8 : 12);
	for (int a = 0; a < 3; a++) {
		md->periodic[a] = a < p->dim ? (p->periodic[a] != 0) : 0;
		md->walled |= a < p->dim && !md->periodic[a];
		md->L[a] = a < p->dim ? p->box[a] : 1.0;
		md->g[a] = a < p->dim ? p->gravity[a] : 0.0;
	}
	/* moving and vibrating walls: only on walled axes, tangential velocities, finite vibrations */
	rc = MD_E_PARAM;
	for (int w = 0; w < 6; w++) {
		const int a = w / 2, walls = a < p->dim && !md->periodic[a];
		double A = p->wall_amplitude[w], f = p->wall_frequency[w], ph = p->wall_phase[w];
		if (!(A >= 0.0) || !isfinite(A) || !isfinite(f) || !isfinite(ph) || (A > 0.0 && !(f > 0.0)))
			goto cleanup;
		if (!walls && (A > 0.0 || f != 0.0 || ph != 0.0))
			goto cleanup;
		for (int b = 0; b < 3; b++) {
			double u = p->wall_velocity[w][b];
			if (!isfinite(u) || (u != 0.0 && (!walls || b == a || b >= p->dim)))
				goto cleanup;
			md->wv[w][b] = u;
			md->wmoving |= u != 0.0;
		}
		if (A > 0.0) {
			md->wamp[w] = A;
			md->womega[w] = 2.0 * MD_PI * f;
			md->wphase[w] = ph;
			md->wmoving = 1;
		}
	}
	md->track = p->virial != 0;
	/* obstacles: inside the box on walled axes, finite */
	if (p->n_obstacles < 0 || p->n_obstacles > MD_OBSTACLES_MAX)
		goto cleanup;
	md->nob = p->n_obstacles;
	for (int k = 0; k < md->nob; k++) {
		if (!(p->obstacle_radius[k] > 0.0) || !isfinite(p->obstacle_radius[k]))
			goto cleanup;
		md->orad[k] = p->obstacle_radius[k];
		for (int a = 0; a < 3; a++) {
			double c = a < p->dim ? p->obstacle_center[k][a] : 0.0;
			if (!isfinite(c) || (a < p->dim && !(c >= 0.0 && c <= md->L[a])))
				goto cleanup;
			md->oc[k][a] = c;
		}
	}
	rc = MD_E_NOMEM;
	/* one block for the double arrays: x v w f t xref (3n each), r m im iI (n each) */
	md->x = calloc((size_t)n * 22, sizeof(double));
	md->next = calloc((size_t)n, sizeof(int));
	md->hold = calloc((size_t)n * md->slots, sizeof(md_slot_t));
	md->hnew = calloc((size_t)n * md->slots, sizeof(md_slot_t));
	md->nold = calloc((size_t)n, sizeof(int));
	md->nnew = calloc((size_t)n, sizeof(int));
	if (!md->x || !md->next || !md->hold || !md->hnew || !md->nold || !md->nnew)
		goto cleanup;
	if (md->pairwise && !(md->sp = malloc((size_t)n * sizeof(int))))
		goto cleanup;
	if (md->rolling && (!(md->rold = calloc((size_t)n * md->slots * 3, sizeof(double))) ||
			    !(md->rnew = calloc((size_t)n * md->slots * 3, sizeof(double))) ||
			    !(md->iroll = calloc((size_t)n, sizeof(double)))))
		goto cleanup;
	if (md->pairwise)
		memcpy(md->sp, p->species, (size_t)n * sizeof(int));
	md->v = md->x + 3 * (size_t)n;
	md->w = md->v + 3 * (size_t)n;
	md->f = md->w + 3 * (size_t)n;
	md->t = md->f + 3 * (size_t)n;
	md->xref = md->t + 3 * (size_t)n;
	md->r = md->xref + 3 * (size_t)n;
	md->m = md->r + n;
	md->im = md->m + n;
	md->iI = md->im + n;
	rc = MD_E_PARAM;
	double mmin = INFINITY;
	md->rmax = 0.0;
	for (int i = 0; i < n; i++) {
		double r = p->radii ? p->radii[i] : p->radius;
		double m = p->masses ? p->masses[i] : p->mass;
		if (!(r > 0.0) || !(m > 0.0) || !isfinite(r) || !isfinite(m))
			goto cleanup;
		md->r[i] = r;
		md->m[i] = m;
		md->im[i] = 1.0 / m;
		md->iI[i] = 1.0 / ((p->dim == 2 ? 0.5 : 0.4) * m * r * r);
		if (md->rolling)
			md->iroll[i] = 1.0 / ((p->dim == 2 ? 0.5 : 0.4) * m * r * r + m * r * r);
		if (r > md->rmax)
			md->rmax = r;
		if (m < mmin)
			mmin = m;
		for (int a = 0; a < 3 && p->x; a++) {
			double xa = a < p->dim ? p->x[3 * i + a] : 0.0;
			double va = p->v && a < p->dim ? p->v[3 * i + a] : 0.0;
			double wa = p->w && (p->dim == 3 || a == 2) ? p->w[3 * i + a] : 0.0;
			if (!isfinite(xa) || !isfinite(va) || !isfinite(wa))
				goto cleanup;
			md->x[3 * i + a] = xa;
			md->v[3 * i + a] = va;
			md->w[3 * i + a] = wa;
		}
	}
	double e = p->restitution, le = log(e);
	md->e = e;
	md->beta = -le / sqrt(MD_PI * MD_PI + le * le);
	double mref = 0.5 * mmin;
	/* restitution per pair: each pair's damping; the shortest contact time (the largest e) sets dt */
	double emax = e;
	for (int a = 0; a < md->ns; a++)
		for (int b = 0; b < md->ns; b++) {
			double eab = p->restitution_pair[a * md->ns + b];
			md->damp[a * md->ns + b] = p->law == MD_LAW_LINEAR ? restitution_beta(eab) : hertz_alpha(eab);
			emax = fmax(emax, eab);
		}
	if (p->law == MD_LAW_LINEAR) {
		if (p->kn > 0.0)
			md->kn = p->kn;
		else if (p->t_contact > 0.0)
			md->kn = mref * (MD_PI * MD_PI + le * le) / (p->t_contact * p->t_contact);
		else
			goto cleanup;
		if (!isfinite(md->kn))
			goto cleanup;
		double bref = emax > e ? restitution_beta(emax) : md->beta;
		md->tc = MD_PI / sqrt(md->kn / mref * (1.0 - bref * bref));
	} else {
		if (!(p->young > 0.0) || !isfinite(p->young))
			goto cleanup;
		md->young = p->young;
		double tau;
		md->alpha = hertz_alpha(e);
		hertz_restitution(emax > e ? hertz_alpha(emax) : md->alpha, &tau);
		if (p->dt <= 0.0 && (!(p->v_ref > 0.0) || !isfinite(p->v_ref)))
			goto cleanup;
		if (p->v_ref > 0.0 && isfinite(p->v_ref)) {
			double kh = 4.0 / 3.0 * md->young * sqrt(0.5 * md->rmax);
			md->tc = tau * pow(mref / kh, 0.4) * pow(p->v_ref, -0.2);
		}
	}
	md->dt = p->dt > 0.0 ? p->dt : md->tc / (p->dt_steps > 0.0 ? p->dt_steps : 50.0);
	if (!(md->dt > 0.0) || !isfinite(md->dt))
		goto cleanup;
	md->skin = p->skin > 0.0 ? p->skin : 0.2 * md->rmax;
	rc = MD_E_BOX;
	for (int a = 0; a < p->dim; a++)
		if (md->periodic[a] && md->L[a] < 2.0 * (2.0 * md->rmax + md->skin))
			goto cleanup;
	rc = MD_OK;
	if (!p->x)
		goto cleanup;   /* memory only: md_state_set() gives the state */
	rc = rebuild(md);
	if (rc)
		goto cleanup;
	rc = forces(md, 0.0, 0.0, 0.0);
	md->kin = md->track ? mv2(md) : 0.0;
cleanup:
	if (err)
		*err = rc;
	if (rc) {
		md_destroy(md);
		md = NULL;
	}
	return md;
}

int md_step(md_t *md, long nsteps)
{
	const int n = md->n;
	const double dt = md->dt, h = 0.5 * dt;
	const double lim = 0.25 * md->skin * md->skin;
	for (long s = 0; s < nsteps; s++) {
		int need = 0;
		for (int i = 0; i < n; i++) {
			double *x = md->x + 3 * i, *v = md->v + 3 * i, *w = md->w + 3 * i;
			const double *f = md->f + 3 * i, *t = md->t + 3 * i, *x0 = md->xref + 3 * i;
			double hm = h * md->im[i], hI = h * md->iI[i];
			for (int a = 0; a < 3; a++) {
				v[a] += hm * f[a];
				w[a] += hI * t[a];
				x[a] += dt * v[a];
			}
			double d0 = x[0] - x0[0], d1 = x[1] - x0[1], d2 = x[2] - x0[2];
			if (!(d0 * d0 + d1 * d1 + d2 * d2 <= lim))
				need = 1;
		}
		if (need) {
			int rc = rebuild(md);
			if (rc)
				return rc;
		}
		if (md->walled)   /* velocity Verlet's impulses: h F(t) now, h F(t + dt) after the force pass */
			for (int w = 0; w < 6; w++)
				for (int a = 0; a < 3; a++)
					md->wimp[w][a] += h * md->wf[w][a];
		for (int k = 0; k < md->nob; k++)
			for (int a = 0; a < 3; a++)
				md->oimp[k][a] += h * md->of[k][a];
		if (md->track) {   /* the trapezoid over the step, as the impulses */
			md->virint += h * md->vir;
			md->kinint += h * md->kin;
		}
		/* positions at the end of the step, velocities half a step before */
		int rc = forces(md, dt, (double)(md->steps + 1) * dt, ((double)md->steps + 0.5) * dt);
		if (md->walled)
			for (int w = 0; w < 6; w++)
				for (int a = 0; a < 3; a++)
					md->wimp[w][a] += h * md->wf[w][a];
		for (int k = 0; k < md->nob; k++)
			for (int a = 0; a < 3; a++)
				md->oimp[k][a] += h * md->of[k][a];
		for (int i = 0; i < n; i++) {
			double *v = md->v + 3 * i, *w = md->w + 3 * i;
			const double *f = md->f + 3 * i, *t = md->t + 3 * i;
			double hm = h * md->im[i], hI = h * md->iI[i];
			for (int a = 0; a < 3; a++) {
				v[a] += hm * f[a];
				w[a] += hI * t[a];
			}
		}
		if (md->track) {
			md->kin = mv2(md);
			md->virint += h * md->vir;
			md->kinint += h * md->kin;
		}
		md->steps++;
		if (rc)
			return rc;
	}
	return MD_OK;
}

const double *md_positions(const md_t *md) { return md->x; }
const double *md_velocities(const md_t *md) { return md->v; }
const double *md_spins(const md_t *md) { return md->w; }
double md_time(const md_t *md) { return (double)md->steps * md->dt; }
double md_dt(const md_t *md) { return md->dt; }
double md_contact_time(const md_t *md) { return md->tc; }
double md_stiffness(const md_t *md) { return md->kn; }
double md_hertz_alpha(const md_t *md) { return md->alpha; }
size_t md_contact_count(const md_t *md) { return md->ncontacts; }
long md_rebuilds(const md_t *md) { return md->rebuilds; }

void md_walls(const md_t *md, double impulse[6][3], double *interval)
{
	memcpy(impulse, md->wimp, sizeof md->wimp);
	*interval = (double)(md->steps - md->wsteps) * md->dt;
}

void md_virial(const md_t *md, double *vir, double *kin)
{
	*vir = md->virint;
	*kin = md->kinint;
}

void md_obstacles(const md_t *md, double impulse[][3])
{
	memcpy(impulse, md->oimp, (size_t)md->nob * sizeof md->oimp[0]);
}

void md_wall_reset(md_t *md)
{
	memset(md->wimp, 0, sizeof md->wimp);
	md->wsteps = md->steps;
	md->virint = md->kinint = 0.0;
	memset(md->oimp, 0, sizeof md->oimp);
}

/* The per-particle arrays md_create() allocates (md_memory(), md_plan()). */
static size_t arrays_bytes(size_t n, size_t slots, int pairwise, int rolling)
{
	return n * (22 * sizeof(double) + 3 * sizeof(int)) + 2 * n * slots * sizeof(md_slot_t) +
	       (pairwise ? n * sizeof(int) : 0) + (rolling ? (6 * n * slots + n) * sizeof(double) : 0);
}

size_t md_memory(const md_t *md)
{
	return sizeof(*md) + arrays_bytes((size_t)md->n, (size_t)md->slots, md->pairwise, md->rolling) +
	       md->capp * sizeof(md_pair_t) + md->ncell * sizeof(int);
}

int md_plan(const md_params_t *p, double volume_fraction, md_plan_t *out)
{
	memset(out, 0, sizeof(*out));
	if (p->n < 1 || (p->dim != 2 && p->dim != 3))
		return MD_E_PARAM;
	double rmax = p->radius;
	for (int i = 0; p->radii && i < p->n; i++)
		rmax = fmax(rmax, p->radii[i]);
	if (!(rmax > 0.0))
		return MD_E_PARAM;
	const size_t n = (size_t)p->n, slots = (size_t)(p->max_contacts > 0 ? p->max_contacts : (p->dim == 2 ? 8 : 12));
	const double rc = 2.0 * rmax + (p->skin > 0.0 ? p->skin : 0.2 * rmax);
	size_t ncell = 1;
	for (int a = 0; a < p->dim; a++) {   /* as the cell pass of the list build */
		if (!(p->box[a] > 0.0))
			return MD_E_PARAM;
		double nc = floor(p->box[a] / rc);
		nc = nc < 1 ? 1 : (p->periodic[a] && nc < 3) ? 1 : nc > 1024 ? 1024 : nc;
		ncell *= (size_t)nc;
	}
	/* pairs within rc of a particle: the volume fraction times (rc / R)^D, halved (each pair once), twice
	 * that for g(r)'s contact peak */
	const double pairs = (double)n * fmax(volume_fraction, 0.0) * pow(rc / rmax, p->dim);
	size_t cap = 1024;
	while ((double)cap < pairs)
		cap *= 2;
	const int rolling = p->mu_r > 0.0, pairwise = p->restitution_pair != NULL;
	out->cells = ncell;
	out->memory = sizeof(md_t) + arrays_bytes(n, slots, pairwise, rolling) + cap * sizeof(md_pair_t) +
	              ncell * sizeof(int);
	/* md_state_t: x, v, w, f, t, xref (3 n each), held (n), partner, xi (3), mr (3, rolling) per spring */
	const size_t springs = n * slots;
	out->state = 18 * n * sizeof(double) + n * sizeof(int) + springs * (sizeof(int) + 3 * sizeof(double)) +
	             (rolling ? 3 * springs * sizeof(double) : 0);
	out->largest = 3 * (springs > n ? springs : n) * sizeof(double);
	return MD_OK;
}

size_t md_springs(const md_t *md)
{
	size_t k = 0;
	for (int i = 0; i < md->n; i++)
		k += (size_t)md->nnew[i];
	return k;
}

void md_state_get(const md_t *md, md_state_t *st)
{
	const size_t n3 = (size_t)md->n * 3 * sizeof(double);
	double *const dst[6] = {st->x, st->v, st->w, st->f, st->t, st->xref};
	const double *const src[6] = {md->x, md->v, md->w, md->f, md->t, md->xref};
	for (int k = 0; k < 6; k++)
		if (dst[k])
			memcpy(dst[k], src[k], n3);
	size_t q = 0;
	for (int i = 0; i < md->n; i++) {
		if (st->held)
			st->held[i] = md->nnew[i];
		const md_slot_t *sl = md->hnew + (size_t)i * md->slots;
		for (int k = 0; k < md->nnew[i]; k++, q++) {
			if (st->partner)
				st->partner[q] = sl[k].partner;
			if (st->xi)
				memcpy(st->xi + 3 * q, sl[k].xi, sizeof(sl[k].xi));
			if (st->mr && md->rolling)
				memcpy(st->mr + 3 * q, md->rnew + 3 * ((size_t)i * md->slots + k), 3 * sizeof(double));
		}
	}
	st->springs = q;
	memcpy(st->wall_force, md->wf, sizeof md->wf);
	memcpy(st->wall_impulse, md->wimp, sizeof md->wimp);
	st->wall_steps = (uint64_t)md->wsteps;
	memcpy(st->obstacle_force, md->of, sizeof md->of);
	memcpy(st->obstacle_impulse, md->oimp, sizeof md->oimp);
	if (md->track)
		st->virial[0] = md->vir, st->virial[1] = md->kin, st->virial[2] = md->virint, st->virial[3] = md->kinint;
	else
		memset(st->virial, 0, sizeof st->virial);
	st->steps = (uint64_t)md->steps;
	st->rebuilds = (uint64_t)md->rebuilds;
	st->contacts = md->ncontacts;
}

int md_state_set(md_t *md, const md_state_t *st)
{
	const int n = md->n, D = md->dim;
	const double *const src[6] = {st->x, st->v, st->w, st->f, st->t, st->xref};
	double *const dst[6] = {md->x, md->v, md->w, md->f, md->t, md->xref};
	for (int k = 0; k < 6; k++)
		if (!src[k])
			return MD_E_PARAM;
	if (!st->held || (st->springs && (!st->partner || !st->xi || (md->rolling && !st->mr))) ||
	    st->steps > (uint64_t)1 << 62 ||
	    st->rebuilds < 1 || st->rebuilds > st->steps + 1)
		return MD_E_PARAM;
	for (size_t q = 0; q < (size_t)n * 3; q++) {
		int a = (int)(q % 3);
		for (int k = 0; k < 6; k++) {
			double y = src[k][q];
			/* 2D: positions, velocities and forces in the plane, spins and torques about z */
			int planar = k == 2 || k == 4 ? a < 2 : a == 2;
			if (!isfinite(y) || (D == 2 && planar && y != 0.0))
				return MD_E_PARAM;
		}
		if (a < D && md->periodic[a] && !(src[5][q] >= 0.0 && src[5][q] < md->L[a]))
			return MD_E_PARAM;
	}
	size_t q = 0;
	for (int i = 0; i < n; i++) {
		int h = st->held[i];
		if (h < 0 || h > md->slots || (size_t)h > st->springs - q)
			return MD_E_PARAM;
		for (int k = 0; k < h; k++) {
			int32_t p = st->partner[q + k];
			int wall = -1 - p, a = wall / 2;
			if (p >= 0 ? p <= i || p >= n : wall >= 6 ? wall - 6 >= md->nob : wall >= 2 * D || md->periodic[a])
				return MD_E_PARAM;
			for (int l = 0; l < k; l++)
				if (st->partner[q + l] == p)
					return MD_E_PARAM;
			for (int b = 0; b < 3; b++)
				if (!isfinite(st->xi[3 * (q + k) + b]) || (D == 2 && b == 2 && st->xi[3 * (q + k) + b] != 0.0))
					return MD_E_PARAM;
			/* rolling springs: torques, about z in 2D */
			for (int b = 0; b < 3 && md->rolling; b++)
				if (!isfinite(st->mr[3 * (q + k) + b]) || (D == 2 && b < 2 && st->mr[3 * (q + k) + b] != 0.0))
					return MD_E_PARAM;
		}
		q += (size_t)h;
	}
	if (q != st->springs || st->wall_steps > st->steps)
		return MD_E_PARAM;
	for (int w = 0; w < 6; w++)
		for (int a = 0; a < 3; a++) {
			double f = st->wall_force[w][a], m = st->wall_impulse[w][a];
			/* only walls of the box carry force */
			if (!isfinite(f) || !isfinite(m) || ((w / 2 >= D || md->periodic[w / 2]) && (f != 0.0 || m != 0.0)))
				return MD_E_PARAM;
		}
	for (int k = 0; k < 4; k++)
		if (!isfinite(st->virial[k]) || (!md->track && st->virial[k] != 0.0))
			return MD_E_PARAM;
	for (int k = 0; k < MD_OBSTACLES_MAX; k++)
		for (int a = 0; a < 3; a++)
			if (!isfinite(st->obstacle_force[k][a]) || !isfinite(st->obstacle_impulse[k][a]) ||
			    (k >= md->nob && (st->obstacle_force[k][a] != 0.0 || st->obstacle_impulse[k][a] != 0.0)))
				return MD_E_PARAM;
	memcpy(md->of, st->obstacle_force, sizeof md->of);
	memcpy(md->oimp, st->obstacle_impulse, sizeof md->oimp);
	memcpy(md->wf, st->wall_force, sizeof md->wf);
	memcpy(md->wimp, st->wall_impulse, sizeof md->wimp);
	md->wsteps = (long)st->wall_steps;
	if (md->track)
		md->vir = st->virial[0], md->kin = st->virial[1], md->virint = st->virial[2], md->kinint = st->virial[3];
	for (int k = 0; k < 6; k++)
		memcpy(dst[k], src[k], (size_t)n * 3 * sizeof(double));
	q = 0;
	for (int i = 0; i < n; i++) {
		md->nnew[i] = st->held[i];
		md->nold[i] = 0;
		md_slot_t *sl = md->hnew + (size_t)i * md->slots;
		for (int k = 0; k < md->nnew[i]; k++, q++) {
			sl[k].partner = st->partner[q];
			memcpy(sl[k].xi, st->xi + 3 * q, sizeof(sl[k].xi));
			if (md->rolling)
				memcpy(md->rnew + 3 * ((size_t)i * md->slots + k), st->mr + 3 * q, 3 * sizeof(double));
		}
	}
	md->steps = (long)st->steps;
	md->rebuilds = (long)st->rebuilds;
	md->ncontacts = (size_t)st->contacts;
	return build_pairs(md);
}

/* Elastic energy of one contact: normal potential and the tangential (and rolling) spring of its slot (if
 * any). */
static double contact_energy(const md_t *md, int i, int partner, double delta, double reff)
{
	double en, kt, kN;
	if (md->law == MD_LAW_LINEAR) {
		en = 0.5 * md->kn * delta * delta;
		kt = md->ktr * md->kn;
		kN = md->kn;
	} else {
		double kh = 4.0 / 3.0 * md->young * sqrt(reff), sd = sqrt(delta);
		en = 0.4 * kh * delta * delta * sd;
		kt = md->ktr * 1.5 * kh * sd;
		kN = 1.5 * kh * sd;
	}
	if (md->friction) {
		const md_slot_t *s = md->hnew + (size_t)i * md->slots;
		for (int k = 0; k < md->nnew[i]; k++)
			if (s[k].partner == partner) {
				en += 0.5 * kt * dot3(s[k].xi, s[k].xi);
				if (md->rolling) {
					const double *mr = md->rnew + 3 * ((size_t)i * md->slots + k);
					en += 0.5 * dot3(mr, mr) / (2.25 * kN * md->mu_r * md->mu_r * reff * reff);
				}
				break;
			}
	}
	return en;
}

void md_energy(const md_t *md, md_energy_t *out)
{
	md_energy_t e = {0.0, 0.0, 0.0, 0.0};
	for (int i = 0; i < md->n; i++) {
		const double *v = md->v + 3 * i, *w = md->w + 3 * i, *x = md->x + 3 * i;
		e.kinetic += 0.5 * md->m[i] * dot3(v, v);
		e.rotational += 0.5 / md->iI[i] * dot3(w, w);
		e.gravitational -= md->m[i] * dot3(md->g, x);
		for (int a = 0; a < md->dim; a++) {
			if (md->periodic[a])
				continue;
			for (int side = 0; side < 2; side++) {
				double delta = side ? md->r[i] - (md->L[a] - x[a]) : md->r[i] - x[a];
				if (delta > 0.0)
					e.elastic += contact_energy(md, i, -1 - (2 * a + side), delta, md->r[i]);
			}
		}
	}
	for (size_t p = 0; p < md->np; p++) {
		const md_pair_t *pp = md->pairs + p;
		const double *xi = md->x + 3 * pp->i, *xj = md->x + 3 * pp->j;
		double d[3] = {xj[0] - xi[0] + pp->s[0], xj[1] - xi[1] + pp->s[1], xj[2] - xi[2] + pp->s[2]};
		double sr = md->r[pp->i] + md->r[pp->j], r2 = dot3(d, d);
		if (r2 < sr * sr)
			e.elastic += contact_energy(md, pp->i, pp->j, sr - sqrt(r2), md->r[pp->i] * md->r[pp->j] / sr);
	}
	*out = e;
}
