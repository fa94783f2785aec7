/* Serial event statistics for one system over P ranks (issue 14): traces the serial ED engine and measures border events, events between them, load imbalance with and without balancing, and a speed-up model. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "ed/ed.h"
#include "par/decomp.h"
#include "scene.h"

/*
 * Not a parallel run: one serial run of the engine, linked with the
 * bench-only instrumented copy of ed.c (-DED_TRACE, ed.h "Event trace"),
 * records each event's kind and cells; the decompositions of
 * engine/par/decomp over P ranks are then applied to that one event stream.
 * See docs/parallel.md for the definitions and the model.
 *
 * usage: par_model DIM N PHI RESTITUTION TC WARMUP_CPP MEASURE_CPP [RANKS [WINDOWS [CELL_SIZE]]]
 *   a periodic box of N particles at volume fraction PHI (elastic pre-run
 *   of 2 collisions per particle from the lattice), then WARMUP_CPP
 *   collisions per particle of the scene's own dynamics untraced (timed:
 *   the serial CPU time per event t_e), then MEASURE_CPP traced. RANKS: a
 *   comma list (default 2,4,8,16,64,128), WINDOWS: the stream is cut into
 *   this many windows of equal event count (default 10; balancing uses the
 *   previous window's cost), CELL_SIZE: the scene's ed.cell_size (minimum
 *   cell edge in diameters; default 0, the engine's automatic grid). The
 *   model is given for a cost of one communication phase alpha = 0, 1 and
 *   5 microseconds; it charges one t_e per particle a rebalance moves.
 * Output: markdown tables on stdout.
 */

/* equal cells; prefix-sum split every window; the same only when the
 * imbalance on the last window's costs exceeds Poisson noise; the split
 * with hysteresis of one deviation; seed 003 buddy blocks */
enum { S_STATIC, S_PREFIX, S_NOISE, S_KEEP, S_BUDDY, S_COUNT };

typedef struct {
	int dim, nc[3];
	uint32_t ncell;
	uint64_t zsize;
	uint32_t *rm2z, *z2rm;      /* row-major cell index <-> Z id (UINT32_MAX: padding) */
	/* the trace */
	size_t n, cap;
	uint8_t *kind;
	uint32_t *ci, *cj;
	int full;
	/* scratch of one decomposition */
	uint16_t *own;              /* owner per row-major cell */
	uint32_t *stamp, gen;       /* memo of border flags: valid when stamp == gen */
	uint8_t *bflag;
	double *cost;               /* per Z id */
	double *loads;              /* per rank */
	decomp_transfer_t *transfers;   /* 2 per rank */
	uint64_t *old_b;            /* bounds before a rebalance */
	uint64_t *recv;             /* per rank: cells received in a rebalance */
} model_t;

static double cpu_now(void)
{
	struct timespec ts;
	clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
	return ts.tv_sec + 1e-9 * ts.tv_nsec;
}

static uint32_t rm_index(const model_t *m, const int32_t *c)
{
	return m->dim == 2 ? (uint32_t)(c[1] * m->nc[0] + c[0])
	                   : (uint32_t)((c[2] * m->nc[1] + c[1]) * m->nc[0] + c[0]);
}

#define TRACE_MAX ((size_t)40 * 1000 * 1000)

static void on_event(void *ctx, const ed_trace_t *ev)
{
	model_t *m = ctx;
	if (m->n == m->cap) {
		size_t c = m->cap ? 2 * m->cap : (size_t)1 << 20;
		if (c > TRACE_MAX)
			c = TRACE_MAX;
		uint8_t *k = c > m->cap ? realloc(m->kind, c) : NULL;
		if (k) m->kind = k;
		uint32_t *a = k ? realloc(m->ci, c * sizeof(uint32_t)) : NULL;
		if (a) m->ci = a;
		uint32_t *b = a ? realloc(m->cj, c * sizeof(uint32_t)) : NULL;
		if (b) m->cj = b;
		if (!b) {
			m->full = 1;
			return;
		}
		m->cap = c;
	}
	m->kind[m->n] = (uint8_t)ev->kind;
	m->ci[m->n] = rm_index(m, ev->ci);
	m->cj[m->n] = rm_index(m, ev->cj);
	m->n++;
}

/* Owners per cell from the decomposition's ranges; border memo reset. */
static void fill_owners(model_t *m, const decomp_t *d)
{
	const uint64_t *b = decomp_bounds(d);
	for (int r = 0; r < decomp_ranks(d); r++)
		for (uint64_t z = b[r]; z < b[r + 1]; z++)
			if (m->z2rm[z] != UINT32_MAX)
				m->own[m->z2rm[z]] = (uint16_t)r;
	m->gen++;
}

/* Border flag of cell c (some neighbour, periodic wrap, has another owner). */
static int border(model_t *m, uint32_t c)
{
	if (m->stamp[c] == m->gen)
		return m->bflag[c];
	int32_t x[3] = {(int32_t)(c % (uint32_t)m->nc[0]), (int32_t)(c / (uint32_t)m->nc[0] % (uint32_t)m->nc[1]),
	                m->dim == 3 ? (int32_t)(c / ((uint32_t)m->nc[0] * (uint32_t)m->nc[1])) : 0};
	const uint16_t r = m->own[c];
	int f = 0, sz = m->dim == 3 ? 1 : 0;
	for (int dz = -sz; dz <= sz && !f; dz++)
		for (int dy = -1; dy <= 1 && !f; dy++)
			for (int dx = -1; dx <= 1 && !f; dx++) {
				int32_t q[3] = {x[0] + dx, x[1] + dy, x[2] + dz};
				for (int a = 0; a < m->dim; a++)
					q[a] = (q[a] + m->nc[a]) % m->nc[a];
				f = m->own[rm_index(m, q)] != r;
			}
	m->stamp[c] = m->gen;
	m->bflag[c] = (uint8_t)f;
	return f;
}

typedef struct {
	double sum_max_e, sum_max_eb, sum_max_b, sum_mean;   /* over windows 1.. */
	uint64_t events, border_ev, remote_coll, migrations, collisions;
	double gap_per_rank;   /* mean over ranks of events / border events */
	uint64_t rebalances;   /* windows whose bounds were recomputed */
	uint64_t cells_moved;  /* real cells that changed owner, over all rebalances */
	double sum_max_recv;   /* over windows: the most cells one rank received */
} result_t;

static int analyse(model_t *m, int P, int scheme, int K, result_t *res)
{
	int err, rc = -1;
	const int per[3] = {1, 1, 1};
	decomp_t *d = decomp_create(m->dim, m->nc, per, P, &err);
	uint64_t *er = calloc((size_t)P, sizeof(uint64_t)), *br = calloc((size_t)P, sizeof(uint64_t));
	uint64_t *etot = calloc((size_t)P, sizeof(uint64_t)), *btot = calloc((size_t)P, sizeof(uint64_t));
	memset(res, 0, sizeof *res);
	if (!d || !er || !br || !etot || !btot)
		goto cleanup;
	if (scheme == S_BUDDY && decomp_buddy_init(d) != DECOMP_OK)
		goto cleanup;
	fill_owners(m, d);
	for (int w = 0; w < K; w++) {
		const size_t e0 = m->n * (size_t)w / (size_t)K, e1 = m->n * (size_t)(w + 1) / (size_t)K;
		if (w > 0 && scheme != S_STATIC) {
			/* cost per cell: the previous window's events there */
			const size_t p0 = m->n * (size_t)(w - 1) / (size_t)K;
			memset(m->cost, 0, m->zsize * sizeof(double));
			for (size_t k = p0; k < e0; k++)
				m->cost[m->rm2z[m->ci[k]]] += 1.0;
			int brc = 0, moved = 1;
			memcpy(m->old_b, decomp_bounds(d), ((size_t)P + 1) * sizeof(uint64_t));
			if (scheme == S_NOISE) {
				/* noise level: the expected max / mean of P Poisson counts of
				 * mean mu (a Gaussian's expected maximum, sigma sqrt(2 ln P)) */
				const double mu = (double)(e0 - p0) / P;
				double imb = decomp_loads(d, m->cost, m->loads);
				moved = imb > 1.0 + sqrt(2.0 * log((double)P) / mu);
				if (moved)
					brc = decomp_balance_prefix(d, m->cost);
			} else if (scheme == S_KEEP) {
				brc = decomp_balance_prefix_keep(d, m->cost, 1.0);
			} else {
				brc = scheme == S_PREFIX ? decomp_balance_prefix(d, m->cost) : decomp_balance_buddy(d, m->cost, 4 * P);
			}
			if (brc < 0)
				goto cleanup;
			if (moved) {
				fill_owners(m, d);
				/* what the rebalance moves: real cells changing owner */
				int nt = decomp_transfers(m->old_b, decomp_bounds(d), P, m->transfers);
				uint64_t mr = 0;
				memset(m->recv, 0, (size_t)P * sizeof(uint64_t));
				for (int k = 0; k < nt; k++)
					for (uint64_t z = m->transfers[k].z0; z < m->transfers[k].z1; z++)
						m->recv[m->transfers[k].to] += m->z2rm[z] != UINT32_MAX;
				for (int r = 0; r < P; r++) {
					res->cells_moved += m->recv[r];
					if (m->recv[r] > mr)
						mr = m->recv[r];
				}
				res->sum_max_recv += (double)mr;
			}
			res->rebalances += (uint64_t)moved;
		}
		memset(er, 0, (size_t)P * sizeof(uint64_t));
		memset(br, 0, (size_t)P * sizeof(uint64_t));
		for (size_t k = e0; k < e1; k++) {
			const uint32_t a = m->ci[k], b = m->cj[k];
			const uint16_t r = m->own[a];
			er[r]++;
			int bd = border(m, a) || (m->kind[k] != ED_TRACE_CANCELLED && border(m, b));
			br[r] += (uint64_t)bd;
			if (w == 0)
				continue;
			res->events++;
			res->border_ev += (uint64_t)bd;
			if (m->kind[k] == ED_TRACE_COLLISION) {
				res->collisions++;
				res->remote_coll += m->own[b] != r;
			} else if (m->kind[k] == ED_TRACE_CROSS) {
				res->migrations += m->own[b] != r;
			}
		}
		if (w == 0)
			continue;
		uint64_t me = 0, meb = 0, mb = 0;
		for (int r = 0; r < P; r++) {
			if (er[r] > me) me = er[r];
			if (er[r] + br[r] > meb) meb = er[r] + br[r];
			if (br[r] > mb) mb = br[r];
			etot[r] += er[r];
			btot[r] += br[r];
		}
		res->sum_max_e += (double)me;
		res->sum_max_eb += (double)meb;
		res->sum_max_b += (double)mb;
		res->sum_mean += (double)(e1 - e0) / P;
	}
	double g = 0.0;
	int nr = 0;
	for (int r = 0; r < P; r++)
		if (btot[r]) {
			g += (double)etot[r] / (double)btot[r];
			nr++;
		}
	res->gap_per_rank = nr ? g / nr : INFINITY;
	rc = 0;
cleanup:
	free(er);
	free(br);
	free(etot);
	free(btot);
	decomp_destroy(d);
	return rc;
}

int main(int argc, char **argv)
{
	if (argc < 8) {
		fprintf(stderr, "usage: par_model DIM N PHI RESTITUTION TC WARMUP_CPP MEASURE_CPP [RANKS [WINDOWS [CELL_SIZE]]]\n");
		return 2;
	}
	int dim = atoi(argv[1]);
	long n = atol(argv[2]);
	double phi = atof(argv[3]), e = atof(argv[4]), tc = atof(argv[5]), warm = atof(argv[6]), meas = atof(argv[7]);
	const char *ranks = argc > 8 ? argv[8] : "2,4,8,16,64,128";
	int K = argc > 9 ? atoi(argv[9]) : 10;
	double cell = argc > 10 ? atof(argv[10]) : 0.0;
	int P_list[32], nP = 0;
	for (const char *s = ranks; *s && nP < 32;) {
		P_list[nP] = atoi(s);
		if (P_list[nP] < 1 || P_list[nP] > 65535) {
			fprintf(stderr, "par_model: RANKS: each rank count must be 1..65535\n");
			return 2;
		}
		nP++;
		s = strchr(s, ',');
		if (!s)
			break;
		s++;
	}
	if ((dim != 2 && dim != 3) || n < 2 || K < 2 || !(meas > 0.0) || !(warm > 0.0)) {
		fprintf(stderr, "par_model: DIM 2 or 3, N >= 2, WARMUP_CPP and MEASURE_CPP > 0, WINDOWS >= 2\n");
		return 2;
	}
	char json[1024], err[512];
	snprintf(json, sizeof json,
	         "{\"method\":\"ed\",\"dimensions\":%d,\"particles\":{\"count\":%ld,\"volume_fraction\":%g,"
	         "\"initial\":{\"relax\":{\"collisions_per_particle\":2}}},"
	         "\"collisions\":{\"restitution\":%g,\"tc\":%g},\"run\":{\"until\":{\"time\":1}},"
	         "\"ed\":{\"cell_size\":%.17g}}",
	         dim, n, phi, e, tc, cell);
	scene_t sc;
	int rc = 1;
	model_t m = {0};
	decomp_t *d = NULL;
	ed_t *ed = NULL;
	if (scene_parse(json, strlen(json), &sc, err, sizeof err) != SCENE_OK) {
		fprintf(stderr, "par_model: %s\n", err);
		return 2;
	}
	if (!(ed = ed_create(&sc, &rc, err, sizeof err))) {
		fprintf(stderr, "par_model: %s\n", err);
		return 1;
	}
	rc = 1;
	int cells[3];
	ed_cells(ed, cells);
	m.dim = dim;
	m.ncell = 1;
	for (int a = 0; a < 3; a++) {
		m.nc[a] = a < dim ? cells[a] : 1;
		m.ncell *= (uint32_t)m.nc[a];
	}
	const int per[3] = {1, 1, 1};
	int derr;
	if (!(d = decomp_create(dim, m.nc, per, 1, &derr))) {
		fprintf(stderr, "par_model: cell grid not decomposable\n");
		goto cleanup;
	}
	m.zsize = decomp_zsize(d);
	if (m.zsize >= UINT32_MAX) {
		fprintf(stderr, "par_model: too many cells\n");
		goto cleanup;
	}
	m.rm2z = malloc(m.ncell * sizeof(uint32_t));
	m.z2rm = malloc(m.zsize * sizeof(uint32_t));
	m.own = malloc(m.ncell * sizeof(uint16_t));
	m.stamp = calloc(m.ncell, sizeof(uint32_t));
	m.bflag = malloc(m.ncell);
	m.cost = malloc(m.zsize * sizeof(double));
	m.loads = malloc(65536 * sizeof(double));
	m.transfers = malloc(2 * 65536 * sizeof(decomp_transfer_t));
	m.old_b = malloc(65537 * sizeof(uint64_t));
	m.recv = malloc(65536 * sizeof(uint64_t));
	if (!m.rm2z || !m.z2rm || !m.own || !m.stamp || !m.bflag || !m.cost || !m.loads || !m.transfers || !m.old_b || !m.recv) {
		fprintf(stderr, "par_model: out of memory\n");
		goto cleanup;
	}
	memset(m.z2rm, 0xff, m.zsize * sizeof(uint32_t));
	{
		int32_t c[3] = {0, 0, 0};
		for (c[2] = 0; c[2] < m.nc[2]; c[2]++)
			for (c[1] = 0; c[1] < m.nc[1]; c[1]++)
				for (c[0] = 0; c[0] < m.nc[0]; c[0]++) {
					uint32_t i = rm_index(&m, c), z = (uint32_t)decomp_morton(d, c);
					m.rm2z[i] = z;
					m.z2rm[z] = i;
				}
	}
	/* the untraced warm-up gives the serial cost per event */
	uint64_t ev0 = ed_events(ed);
	double c0 = cpu_now();
	ed_advance(ed, INFINITY, ed_collisions(ed) + (uint64_t)(warm * n / 2), UINT64_MAX);
	double t_e = (cpu_now() - c0) / (double)(ed_events(ed) - ev0);
	if (ed_trace(ed, on_event, &m) != ED_OK) {
		fprintf(stderr, "par_model: the trace needs cell mode (volume fraction below the neighbour-list threshold)\n");
		goto cleanup;
	}
	const uint64_t tr_ev0 = ed_events(ed), tr_coll0 = ed_collisions(ed);
	ed_advance(ed, INFINITY, ed_collisions(ed) + (uint64_t)(meas * n / 2), UINT64_MAX);
	if (m.full)
		fprintf(stderr, "par_model: trace truncated at %zu events\n", m.n);
	/* the trace is complete: one record per event, one collision record per collision */
	uint64_t ncoll = 0;
	for (size_t k = 0; k < m.n; k++)
		ncoll += m.kind[k] == ED_TRACE_COLLISION;
	if (!m.full && (m.n != ed_events(ed) - tr_ev0 || ncoll != ed_collisions(ed) - tr_coll0)) {
		fprintf(stderr, "par_model: trace incomplete: %zu records for %llu events, %llu collision records for %llu\n", m.n,
		        (unsigned long long)(ed_events(ed) - tr_ev0), (unsigned long long)ncoll,
		        (unsigned long long)(ed_collisions(ed) - tr_coll0));
		goto cleanup;
	}
	const double C = (double)m.ncell;
	printf("System: %dD, N = %ld, volume fraction %g, restitution %g, tc %g; cells %dx%dx%d (C = %.0f, Z space %llu); "
	       "%zu events traced (%.2f per particle); serial t_e = %.3g us per event (CPU, untraced warm-up of %g "
	       "collisions per particle); %d windows of %zu events (window 0 only seeds the balancing).\n\n",
	       dim, n, phi, e, tc, m.nc[0], m.nc[1], m.nc[2], C, (unsigned long long)m.zsize, m.n, (double)m.n / n,
	       t_e * 1e6, warm, K, m.n / (size_t)K);
	printf("| P | cells/rank | rank 0: border, ghosts, neighbours | border events | seed 2D(P/C)^(1/D) | "
	       "events per border event, per rank | events per phase, system | seed C^(1/D) P^(1-1/D) | "
	       "remote collisions | migrations per event |\n|---|---|---|---|---|---|---|---|---|---|\n");
	result_t res[32][S_COUNT];
	for (int ip = 0; ip < nP; ip++) {
		const int P = P_list[ip];
		for (int s = 0; s < S_COUNT; s++) {
			if (s == S_BUDDY && (P & (P - 1))) {
				memset(&res[ip][s], 0, sizeof res[ip][s]);
				continue;
			}
			if (analyse(&m, P, s, K, &res[ip][s])) {
				fprintf(stderr, "par_model: out of memory\n");
				goto cleanup;
			}
		}
		decomp_t *dp = decomp_create(dim, m.nc, per, P, &derr);
		decomp_rank_t v;
		if (!dp || decomp_rank_build(dp, 0, &v) != DECOMP_OK) {
			decomp_destroy(dp);
			goto cleanup;
		}
		const result_t *r = &res[ip][S_STATIC];
		printf("| %d | %.0f | %zu, %zu, %d | %.4f | %.4f | %.1f | %.0f | %.0f | %.4f | %.4f |\n", P, C / P, v.nborder,
		       v.nghost, v.nneigh, (double)r->border_ev / r->events, 2.0 * dim * pow(P / C, 1.0 / dim), r->gap_per_rank,
		       r->events / r->sum_max_b, pow(C, 1.0 / dim) * pow(P, 1.0 - 1.0 / dim),
		       (double)r->remote_coll / (r->collisions ? r->collisions : 1), (double)r->migrations / r->events);
		decomp_rank_free(&v);
		decomp_destroy(dp);
	}
	static const double alpha[3] = {0.0, 1e-6, 5e-6};
	const double rho = (double)n / C;   /* particles per cell */
	printf("\n| P | imbalance static | prefix (cells moved per window) | prefix above noise (rebalances; cells moved) | "
	       "prefix with hysteresis (cells moved) | buddy (cells moved) | model static, alpha 0 | 1 us | 5 us | "
	       "model prefix above noise, alpha 0 | 1 us | 5 us |\n|---|---|---|---|---|---|---|---|---|---|---|---|\n");
	for (int ip = 0; ip < nP; ip++) {
		const result_t *r = res[ip];
		double sp[2][3];
		for (int s = 0; s < 2; s++) {
			const result_t *q = &r[s == 0 ? S_STATIC : S_NOISE];
			for (int a = 0; a < 3; a++)
				/* T_1 = E t_e; T_P = t_e sum_w max_r (E_rw + B_rw + rho R_rw) + alpha sum_w max_r B_rw,
				 * R_rw the cells rank r receives in window w's rebalance */
				sp[s][a] = q->events * t_e /
				           (t_e * (q->sum_max_eb + rho * q->sum_max_recv) + alpha[a] * q->sum_max_b);
		}
		char buddy[64] = "-";
		const double W = (double)(K - 1) * C / 100.0;   /* cells moved per window, percent */
		if (r[S_BUDDY].events)
			snprintf(buddy, sizeof buddy, "%.3f (%.2g%%)", r[S_BUDDY].sum_max_e / r[S_BUDDY].sum_mean,
			         r[S_BUDDY].cells_moved / W);
		const result_t *g = &r[S_NOISE], *h = &r[S_KEEP];
		printf("| %d | %.3f | %.3f (%.2g%%) | %.3f (%llu of %d; %.2g%%) | %.3f (%.2g%%) | %s | %.1f | %.1f | %.1f | %.1f | %.1f | %.1f |\n",
		       P_list[ip], r[S_STATIC].sum_max_e / r[S_STATIC].sum_mean, r[S_PREFIX].sum_max_e / r[S_PREFIX].sum_mean,
		       r[S_PREFIX].cells_moved / W, g->sum_max_e / g->sum_mean, (unsigned long long)g->rebalances, K - 1,
		       g->cells_moved / W, h->sum_max_e / h->sum_mean, h->cells_moved / W, buddy,
		       sp[0][0], sp[0][1], sp[0][2], sp[1][0], sp[1][1], sp[1][2]);
	}
	rc = 0;
cleanup:
	ed_destroy(ed);
	decomp_destroy(d);
	free(m.kind);
	free(m.ci);
	free(m.cj);
	free(m.rm2z);
	free(m.z2rm);
	free(m.own);
	free(m.stamp);
	free(m.bflag);
	free(m.cost);
	free(m.loads);
	free(m.transfers);
	free(m.old_b);
	free(m.recv);
	return rc;
}
