/* Energy dissipated per collision in homogeneous cooling, ed vs dsmc/hsmc: kappa = loss / ((1 - e^2) T) per window, and its pair statistics. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "ed/ed.h"
#include "mc/dsmc.h"
#include "scene.h"

/*
 * usage: dissipation METHOD CORR DIM N PHI E SEED [CELL [CPS]]
 *   METHOD ed, dsmc or hsmc; CORR none/enskog/cba (ignored for ed); CELL the
 *   MC cell size in diameters (0: default), CPS collisions per step (0:
 *   default). Diameter 1, mass 1, T0 = 1.
 * Random start (3D: FCC lattice, filled exactly for N = 4 k^3), elastic
 * pre-run of 20 collisions per particle, then cooling with restitution E.
 * One JSON line per window between c = 2C/N in {0, 1, 2, 4, 7, 10, 15}:
 *   kappa:      -D N ln(E1/E0) / (2 (1 - e^2) dC), the energy lost per
 *               collision in units of (1 - e^2) T (the loss is
 *               (1 - e^2)/4 m (g.n)^2, and under molecular chaos with a
 *               Maxwellian <(g.n)^2>_coll = 4 T/m in 2D and 3D: kappa = 1),
 *   rate:       collisions per particle per unit time over Enskog's
 *               n sigma_T <|g|> g(sigma) at the current T (Henderson /
 *               Carnahan-Starling), exact if T follows Haff's law in the window;
 * and from the state at the window's start:
 *   pairs_glob: c_D <g^3>/<g> / (4 T/m) over random pairs (the chaos value for
 *               the current velocities; c_D = <cos^2> = 2/3 (2D), 1/2 (3D)),
 *   pairs_cell: the same over same-cell pairs (MC only; cells of the last
 *               step's positions, close to what the next step samples),
 *   contact:    ed only: <|g.r|^3>/<|g.r|> / (4 T/m) over approaching pairs
 *               within 2% of contact (the collision-weighted normal speed),
 *   cos2:       ed only: <|g.r|^3/|g|^2>/<|g.r|> / c_D (impact parameters).
 * -1 marks a value that does not apply.
 */

static const double edges[] = {0, 1, 2, 4, 7, 10, 15};
#define NW ((int)(sizeof edges / sizeof edges[0]) - 1)

typedef struct {
	int dim;
	long n;
	double L[3];
	const double *x, *v;
} snap_t;

/* c_D <g^3>/<g> / (4T/m) over random pairs (2e6 samples, m = 1). */
static double pairs_glob(const snap_t *s, double T, unsigned long long *rs)
{
	double s3 = 0, s1 = 0;
	for (int k = 0; k < 2000000; k++) {
		*rs = *rs * 6364136223846793005ULL + 1442695040888963407ULL;
		long i = (long)((*rs >> 11) % (unsigned long long)s->n);
		*rs = *rs * 6364136223846793005ULL + 1442695040888963407ULL;
		long j = (long)((*rs >> 11) % (unsigned long long)s->n);
		if (i == j)
			continue;
		double g2 = 0;
		for (int a = 0; a < s->dim; a++) {
			double g = s->v[i * s->dim + a] - s->v[j * s->dim + a];
			g2 += g * g;
		}
		double g = sqrt(g2);
		s3 += g2 * g;
		s1 += g;
	}
	double cd = s->dim == 2 ? 2.0 / 3.0 : 0.5;
	return cd * s3 / s1 / (4 * T);
}

/* Same over all pairs sharing a cell of the grid nc (cell index from the
 * positions, as the MC sort does). */
static double pairs_cell(const snap_t *s, const int nc[3], double T)
{
	size_t ncell = (size_t)nc[0] * nc[1] * (s->dim == 3 ? nc[2] : 1);
	long *head = malloc(ncell * sizeof(long)), *next = malloc(s->n * sizeof(long));
	for (size_t c = 0; c < ncell; c++)
		head[c] = -1;
	for (long i = 0; i < s->n; i++) {
		size_t c = 0, mul = 1;
		for (int a = 0; a < s->dim; a++) {
			long k = (long)(s->x[i * s->dim + a] / s->L[a] * nc[a]);
			k = k < 0 ? 0 : k >= nc[a] ? nc[a] - 1 : k;
			c += (size_t)k * mul;
			mul *= (size_t)nc[a];
		}
		next[i] = head[c];
		head[c] = i;
	}
	double s3 = 0, s1 = 0;
	for (size_t c = 0; c < ncell; c++)
		for (long i = head[c]; i >= 0; i = next[i])
			for (long j = next[i]; j >= 0; j = next[j]) {
				double g2 = 0;
				for (int a = 0; a < s->dim; a++) {
					double g = s->v[i * s->dim + a] - s->v[j * s->dim + a];
					g2 += g * g;
				}
				double g = sqrt(g2);
				s3 += g2 * g;
				s1 += g;
			}
	free(head);
	free(next);
	double cd = s->dim == 2 ? 2.0 / 3.0 : 0.5;
	return cd * s3 / s1 / (4 * T);
}

/* ED: approaching pairs with centre distance in [1, 1.02] diameters (diameter 1). */
static void contact(const snap_t *s, double T, double *kap, double *cos2)
{
	int nc[3] = {1, 1, 1};
	size_t ncell = 1;
	for (int a = 0; a < s->dim; a++) {
		nc[a] = (int)floor(s->L[a] / 1.02);
		ncell *= (size_t)nc[a];
	}
	long *head = malloc(ncell * sizeof(long)), *next = malloc(s->n * sizeof(long));
	int *ci = malloc(s->n * 3 * sizeof(int));
	for (size_t c = 0; c < ncell; c++)
		head[c] = -1;
	for (long i = 0; i < s->n; i++) {
		size_t c = 0, mul = 1;
		for (int a = 0; a < 3; a++) {
			int k = a < s->dim ? (int)(s->x[i * s->dim + a] / s->L[a] * nc[a]) : 0;
			k = k < 0 ? 0 : k >= nc[a] ? nc[a] - 1 : k;
			ci[i * 3 + a] = k;
			c += (size_t)k * mul;
			mul *= (size_t)nc[a];
		}
		next[i] = head[c];
		head[c] = i;
	}
	double s3 = 0, s1 = 0, sc = 0;
	for (long i = 0; i < s->n; i++) {
		int lo2 = s->dim == 3 ? -1 : 0, hi2 = s->dim == 3 ? 1 : 0;
		for (int d0 = -1; d0 <= 1; d0++)
			for (int d1 = -1; d1 <= 1; d1++)
				for (int d2 = lo2; d2 <= hi2; d2++) {
					int dd[3] = {d0, d1, d2};
					size_t c = 0, mul = 1;
					for (int a = 0; a < 3; a++) {
						int k = (ci[i * 3 + a] + dd[a] + nc[a]) % nc[a];
						c += (size_t)k * mul;
						mul *= (size_t)nc[a];
					}
					for (long j = head[c]; j >= 0; j = next[j]) {
						if (j <= i)
							continue;
						double r[3], r2 = 0, gr = 0, g2 = 0;
						for (int a = 0; a < s->dim; a++) {
							r[a] = s->x[i * s->dim + a] - s->x[j * s->dim + a];
							r[a] -= s->L[a] * nearbyint(r[a] / s->L[a]);
							r2 += r[a] * r[a];
						}
						if (r2 > 1.02 * 1.02)
							continue;
						double rm = sqrt(r2);
						for (int a = 0; a < s->dim; a++) {
							double g = s->v[i * s->dim + a] - s->v[j * s->dim + a];
							gr += g * r[a] / rm;
							g2 += g * g;
						}
						if (gr >= 0)
							continue;
						double w = -gr;
						s3 += w * w * w;
						s1 += w;
						sc += w * w * w / g2;
					}
				}
	}
	free(head);
	free(next);
	free(ci);
	double cd = s->dim == 2 ? 2.0 / 3.0 : 0.5;
	*kap = s1 > 0 ? s3 / s1 / (4 * T) : -1;
	*cos2 = s1 > 0 ? sc / s1 / cd : -1;
}

int main(int argc, char **argv)
{
	if (argc < 8) {
		fprintf(stderr, "usage: dissipation METHOD CORR DIM N PHI E SEED [CELL [CPS]]\n");
		return 2;
	}
	const char *method = argv[1], *corr = argv[2];
	int dim = atoi(argv[3]);
	long n = atol(argv[4]);
	double phi = atof(argv[5]), e = atof(argv[6]);
	int seed = atoi(argv[7]);
	double cell = argc > 8 ? atof(argv[8]) : 0, cps = argc > 9 ? atof(argv[9]) : 0;
	int ed = !strcmp(method, "ed");
	char json[1024], extra[256] = "", err[512];
	if (!ed) {
		int k = snprintf(extra, sizeof extra, ",\"%s\":{\"correction\":\"%s\"", method, corr);
		if (cell > 0)
			k += snprintf(extra + k, sizeof extra - k, ",\"cell_size\":%g", cell);
		if (cps > 0)
			k += snprintf(extra + k, sizeof extra - k, ",\"collisions_per_step\":%g", cps);
		snprintf(extra + k, sizeof extra - k, "}");
	}
	snprintf(json, sizeof(json),
	         "{\"method\":\"%s\",\"dimensions\":%d,\"particles\":{\"count\":%ld,\"volume_fraction\":%g,"
	         "\"initial\":{\"positions\":\"%s\",\"relax\":{\"collisions_per_particle\":20}}},"
	         "\"collisions\":{\"restitution\":%g},\"run\":{\"seed\":%d,\"until\":{\"time\":1}}%s}",
	         method, dim, n, phi, dim == 3 ? "lattice" : "random", e, seed, extra);
	scene_t sc;
	int rc;
	if (scene_parse(json, strlen(json), &sc, err, sizeof(err)) != SCENE_OK) {
		fprintf(stderr, "%s\n", err);
		return 2;
	}
	ed_t *E = NULL;
	dsmc_t *M = NULL;
	int nc[3] = {1, 1, 1};
	if (ed)
		E = ed_create(&sc, &rc, err, sizeof err);
	else
		M = dsmc_create(&sc, 0, &rc, err, sizeof err);
	if (!E && !M) {
		fprintf(stderr, "%s\n", err);
		return 1;
	}
	if (M)
		dsmc_cells(M, nc);
	double *x = malloc(n * dim * sizeof(double)), *v = malloc(n * dim * sizeof(double));
	snap_t s = {dim, n, {sc.box[0], sc.box[1], sc.box[2]}, x, v};
	unsigned long long rs = 0x9e3779b97f4a7c15ULL * (unsigned long long)(seed + 1);
	for (int w = 0; w < NW; w++) {
		double e0, e1, t0, t1;
		uint64_t c0, c1, target = (uint64_t)ceil(edges[w + 1] * n / 2.0);
		if (E) {
			ed_sample_t t;
			ed_totals(E, &t);
			e0 = t.kinetic_energy;
			c0 = t.collisions;
			t0 = t.time;
			ed_state(E, x, v);
		} else {
			dsmc_sample_t t;
			dsmc_totals(M, &t);
			e0 = t.kinetic_energy;
			c0 = t.collisions;
			t0 = t.time;
			dsmc_state(M, x, v);
		}
		double T = 2 * e0 / (dim * (double)n);
		double pg = pairs_glob(&s, T, &rs), pc = ed ? -1 : pairs_cell(&s, nc, T), ck = -1, cc = -1;
		if (ed)
			contact(&s, T, &ck, &cc);
		if (E) {
			ed_advance(E, INFINITY, target, UINT64_MAX);
			ed_sample_t t;
			ed_totals(E, &t);
			e1 = t.kinetic_energy;
			c1 = t.collisions;
			t1 = t.time;
		} else {
			dsmc_advance(M, INFINITY, target, UINT64_MAX);
			dsmc_sample_t t;
			dsmc_totals(M, &t);
			e1 = t.kinetic_energy;
			c1 = t.collisions;
			t1 = t.time;
		}
		/* Collision rate against Enskog's f = f1 sqrt(T): the integral of
		 * sqrt(T) dt over the window, exact if T follows Haff's law in it. */
		double q = sqrt(e0 / e1), isq = (t1 - t0) * sqrt(T) * (q > 1 + 1e-12 ? log(q) / (q - 1) : 1);
		double f1 = dsmc_collision_frequency(dim, phi, 0.5, 1, 1, dsmc_contact_value(dim, phi));
		double rate = 2.0 * (double)(c1 - c0) / (double)n / isq / f1;
		double kappa = -dim * (double)n * log(e1 / e0) / (2 * (1 - e * e) * (double)(c1 - c0));
		printf("{\"method\":\"%s\",\"corr\":\"%s\",\"dim\":%d,\"n\":%ld,\"phi\":%g,\"e\":%g,\"seed\":%d,"
		       "\"cell\":%g,\"cells\":[%d,%d,%d],\"c0\":%g,\"c1\":%g,\"kappa\":%.6f,\"pairs_glob\":%.6f,"
		       "\"pairs_cell\":%.6f,\"contact\":%.6f,\"cos2\":%.6f,\"rate\":%.6f}\n",
		       method, ed ? "-" : corr, dim, n, phi, e, seed, cell, nc[0], nc[1], nc[2], 2.0 * c0 / n,
		       2.0 * c1 / n, kappa, pg, pc, ck, cc, rate);
		fflush(stdout);
	}
	free(x);
	free(v);
	ed_destroy(E);
	dsmc_destroy(M);
	return 0;
}
