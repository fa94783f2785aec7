/* Decomposed DSMC (engine/mc/dsmcp.h) with P ranks simulated in one process: bit-identity over rank counts, migration, Haff's law, refusals. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "mc/dsmc.h"
#include "mc/dsmcp.h"
#include "kinetic.h"

#define PMAX 8

static void test_identity_m(const char *method, int dim, int n, double nu, const char *corr, double e, uint64_t steps);

typedef struct {
	int P;
	dsmcp_t *r[PMAX];
	uint64_t migr_max;   /* most migrants of one step */
} sim_t;

/* direct: the initial state generated slab by slab (dsmcp_direct_ok()), else from dsmc_create(). */
static int sim_create_how(sim_t *s, const scene_t *sc, uint64_t stream, int P, int direct)
{
	int err;
	char msg[256];
	memset(s, 0, sizeof *s);
	s->P = P;
	dsmc_t *init = direct ? NULL : dsmc_create(sc, stream, &err, msg, sizeof msg);
	if (!direct && !init) {
		diag("dsmc_create: %s", msg);
		return -1;
	}
	for (int k = 0; k < P; k++)
		if (!(s->r[k] = dsmcp_create(sc, init, stream, k, P, &err, msg, sizeof msg))) {
			diag("dsmcp_create: %s", msg);
			dsmc_destroy(init);
			return -1;
		}
	dsmc_destroy(init);
	dsmcp_sums_t sum, part;
	memset(&sum, 0, sizeof sum);
	for (int k = 0; k < P; k++) {
		dsmcp_initial_sums(s->r[k], &part);
		for (int i = 0; i < DSMCP_NSUM; i++)
			sum.w[i] += part.w[i];
	}
	for (int k = 0; k < P; k++)
		if (dsmcp_start(s->r[k], &sum) != DSMCP_OK)
			return -1;
	return 0;
}

static int sim_create(sim_t *s, const scene_t *sc, uint64_t stream, int P)
{
	return sim_create_how(s, sc, stream, P, 0);
}

static void sim_destroy(sim_t *s)
{
	for (int k = 0; k < s->P; k++)
		dsmcp_destroy(s->r[k]);
}

/* hsmc's cell collisions, as engine/par/dsmcrun.c does them with MPI: the grid gathered in rank order,
 * the chain of turns in rank order, the last list to every rank. */
static int sim_cells(sim_t *s)
{
	int p0, p1, nc[3];
	dsmcp_slab(s->r[0], &p0, &p1, nc);
	const int D = dsmcp_dim(s->r[0]), W = dsmcp_hs_width(s->r[0]);
	size_t ncells = 1, off = 0;
	for (int a = 0; a < D; a++)
		ncells *= (size_t)nc[a];
	double *all = malloc(ncells * W * sizeof(double));
	if (!all)
		return -1;
	for (int k = 0; k < s->P; k++)
		off += dsmcp_hs_cells(s->r[k], all + off * W);
	for (int k = 0; k < s->P; k++)
		dsmcp_hs_grid(s->r[k], all);
	free(all);
	if (off != ncells)
		return -1;
	const double *ev = NULL;
	size_t n = 0;
	for (int k = 0; k < s->P; k++)
		if (dsmcp_hs_turn(s->r[k], ev, n, &ev, &n) != DSMCP_OK)
			return -1;
	for (int k = 0; k < s->P; k++)
		dsmcp_hs_final(s->r[k], ev, n);
	return 0;
}

/* Steps to t_stop (or max_steps): the caller's side of the contract, as engine/main.c does it with MPI. */
static int sim_advance(sim_t *s, double t_stop, uint64_t max_steps)
{
	const int R = dsmcp_record_doubles(s->r[0]);
	for (uint64_t n = 0; n < max_steps; n++) {
		dsmcp_totals_t tot;
		dsmcp_totals(s->r[0], &tot);
		if (!(tot.time < t_stop))
			return 0;
		int last;
		double dt = dsmcp_next_dt(s->r[0], t_stop, &last);
		for (int k = 1; k < s->P; k++) {   /* every rank computes the same step */
			int l2;
			if (dsmcp_next_dt(s->r[k], t_stop, &l2) != dt || l2 != last)
				return -1;
		}
		if (dsmcp_hsmc(s->r[0]) && sim_cells(s) != 0)
			return -1;
		for (int k = 0; k < s->P; k++)
			if (dsmcp_move(s->r[k], dt) != DSMCP_OK)
				return -1;
		uint64_t migr = 0;
		for (int to = 0; to < s->P; to++) {
			/* as MPI_Alltoallv: the sources' records in source-rank order */
			size_t nin = 0, nlow = 0, cap = 0;
			for (int from = 0; from < s->P; from++) {
				const size_t *cnt;
				(void)dsmcp_outbox(s->r[from], &cnt);
				cap += cnt[to];
			}
			double *in = malloc((cap + 1) * R * sizeof(double));
			if (!in)
				return -1;
			for (int from = 0; from < s->P; from++) {
				const size_t *cnt;
				const double *box = dsmcp_outbox(s->r[from], &cnt);
				size_t off = 0;
				for (int q = 0; q < to; q++)
					off += cnt[q];
				if (cnt[to])
					memcpy(in + nin * R, box + off * R, cnt[to] * R * sizeof(double));
				nin += cnt[to];
				nlow += from < to ? cnt[to] : 0;
			}
			int rc = dsmcp_arrive(s->r[to], in, nin, nlow);
			free(in);
			if (rc != DSMCP_OK)
				return -1;
			migr += nin;
		}
		s->migr_max = migr > s->migr_max ? migr : s->migr_max;
		dsmcp_sums_t sum, part;
		memset(&sum, 0, sizeof sum);
		for (int k = 0; k < s->P; k++) {
			dsmcp_collide(s->r[k], dt, &part);
			for (int i = 0; i < DSMCP_NSUM; i++)
				sum.w[i] += part.w[i];
		}
		for (int k = 0; k < s->P; k++)
			dsmcp_finish(s->r[k], &sum, dt, last, t_stop);
	}
	return 0;
}

static void test_identity(int dim, int n, double nu, const char *corr, double e, uint64_t steps)
{
	test_identity_m("dsmc", dim, n, nu, corr, e, steps);
}

/* The whole state by identity; returns the particles found (each identity must appear once). */
static size_t sim_state(const sim_t *s, int D, size_t N, double *pos, double *vel, int *dup)
{
	size_t found = 0;
	char *seen = calloc(N, 1);
	*dup = 0;
	for (int k = 0; k < s->P; k++) {
		size_t nl = dsmcp_local(s->r[k], NULL, NULL, NULL);
		uint64_t *id = malloc((nl + 1) * sizeof *id);
		double *x = malloc((nl + 1) * D * sizeof *x), *v = malloc((nl + 1) * D * sizeof *v);
		dsmcp_local(s->r[k], id, x, v);
		for (size_t i = 0; i < nl; i++) {
			if (id[i] >= N || seen[id[i]]) {
				*dup = 1;
				continue;
			}
			seen[id[i]] = 1;
			found++;
			memcpy(&pos[id[i] * D], &x[i * D], D * sizeof(double));
			memcpy(&vel[id[i] * D], &v[i * D], D * sizeof(double));
		}
		free(id);
		free(x);
		free(v);
	}
	free(seen);
	return found;
}

static int parse(const char *json, scene_t *sc)
{
	char err[512];
	if (scene_parse(json, strlen(json), sc, err, sizeof err) != SCENE_OK) {
		diag("scene rejected: %s", err);
		return -1;
	}
	return 0;
}

/*
 * The guarantee: P = 2, 3, 4 (and 5 > planes / 2 in 2D) give the 1-rank
 * state bit for bit: positions, velocities, clock, counters. A gas with
 * many migrants (cells of a mean free path, dt of 0.2 mean free times).
 */
static void test_identity_m(const char *method, int dim, int n, double nu, const char *corr, double e, uint64_t steps)
{
	char json[1024];
	snprintf(json, sizeof json,
	         "{\"method\":\"%s\",\"dimensions\":%d,\"particles\":{\"count\":%d,\"volume_fraction\":%g,"
	         "\"initial\":{\"positions\":\"random\"}},\"collisions\":{\"restitution\":%g},"
	         "\"run\":{\"seed\":7,\"until\":{\"time\":100}},\"%s\":{\"correction\":\"%s\"%s}}",
	         method, dim, n, nu, e, method, corr, strcmp(method, "hsmc") ? "" : ",\"cell_size\":2");
	scene_t sc;
	if (parse(json, &sc)) {
		ok(0, "identity %dD scene", dim);
		return;
	}
	const size_t N = (size_t)n, D = (size_t)dim;
	double *x1 = calloc(N * D, sizeof(double)), *v1 = calloc(N * D, sizeof(double));
	double *xp = calloc(N * D, sizeof(double)), *vp = calloc(N * D, sizeof(double));
	dsmcp_totals_t t1 = {0};
	for (int P = 1; P <= 5; P++) {
		sim_t s;
		int dup = 0;
		if (sim_create(&s, &sc, 3, P) || sim_advance(&s, INFINITY, steps)) {
			ok(0, "%dD %s P=%d ran", dim, corr, P);
			sim_destroy(&s);
			continue;
		}
		dsmcp_totals_t t;
		dsmcp_totals(s.r[0], &t);
		size_t found = sim_state(&s, dim, N, P == 1 ? x1 : xp, P == 1 ? v1 : vp, &dup);
		ok(found == N && !dup, "%dD %s P=%d: %zu of %zu particles, each once (migration conserves the count)", dim,
		   corr, P, found, N);
		if (P == 1) {
			t1 = t;
			ok(t.collisions > 0 && t.migrated == 0, "%dD %s P=1: %llu collisions, no migrants", dim, corr,
			   (unsigned long long)t.collisions);
		} else {
			ok(t.migrated > 0, "%dD %s P=%d: %llu migrants in %llu steps (most in one step %llu)", dim, corr, P,
			   (unsigned long long)t.migrated, (unsigned long long)t.steps, (unsigned long long)s.migr_max);
			ok(!memcmp(x1, xp, N * D * sizeof(double)) && !memcmp(v1, vp, N * D * sizeof(double)) &&
			   t.time == t1.time && t.collisions == t1.collisions && t.candidates == t1.candidates &&
			   t.vmax_raised == t1.vmax_raised && t.kinetic_energy == t1.kinetic_energy &&
			   t.cell_collisions == t1.cell_collisions && t.rejected == t1.rejected,
			   "%s %dD %s P=%d: state, clock and counters bit-identical to P=1 after %llu steps (%llu cell "
			   "collisions, %llu rejected moves)", method, dim, corr, P, (unsigned long long)steps,
			   (unsigned long long)t.cell_collisions, (unsigned long long)t.rejected);
		}
		sim_destroy(&s);
	}
	free(x1);
	free(v1);
	free(xp);
	free(vp);
}

/*
 * Momentum: each collision conserves it up to rounding (a few ulps of the
 * pair's velocities), migration moves records unchanged. Elastic gas, so the
 * energy is conserved too, up to the same rounding: bounds of 1e-9 relative
 * to the scale N sqrt(T) (momentum) and N T (energy), far above the ~1e-16
 * per collision times ~1e5 collisions and far below any real leak (one lost
 * particle changes the energy by ~1/N = 1e-3).
 */
static void test_conservation_json(const char *json, const char *what);
static void test_conservation(void)
{
	test_conservation_json("{\"method\":\"dsmc\",\"dimensions\":3,\"particles\":{\"count\":3000,\"volume_fraction\":0.05,"
	                       "\"initial\":{\"positions\":\"random\"}},\"collisions\":{\"restitution\":1},"
	                       "\"run\":{\"seed\":11,\"until\":{\"time\":100}}}", "dsmc");
	/* hsmc: cell-cell collisions conserve momentum and energy exactly too (dsmc.c, cell_collisions()) */
	test_conservation_json("{\"method\":\"hsmc\",\"dimensions\":2,\"particles\":{\"count\":3000,\"volume_fraction\":0.75,"
	                       "\"initial\":{\"positions\":\"random\"}},\"collisions\":{\"restitution\":1},"
	                       "\"run\":{\"seed\":11,\"until\":{\"time\":100}},\"hsmc\":{\"cell_size\":2}}", "hsmc");
}

static void test_conservation_json(const char *json, const char *what)
{
	scene_t sc;
	sim_t s;
	if (parse(json, &sc) || sim_create(&s, &sc, 0, 4)) {
		ok(0, "%s conservation scene", what);
		return;
	}
	double m0[3] = {0, 0, 0}, m1[3] = {0, 0, 0}, mk[3];
	for (int k = 0; k < 4; k++) {
		mk[0] = mk[1] = mk[2] = 0;   /* 2D fills two */
		dsmcp_momentum(s.r[k], mk);
		for (int a = 0; a < 3; a++)
			m0[a] += mk[a];
	}
	dsmcp_totals_t t0, t1;
	dsmcp_totals(s.r[0], &t0);
	int ran = sim_advance(&s, INFINITY, 200) == 0;
	dsmcp_totals(s.r[0], &t1);
	for (int k = 0; k < 4; k++) {
		mk[0] = mk[1] = mk[2] = 0;   /* 2D fills two */
		dsmcp_momentum(s.r[k], mk);
		for (int a = 0; a < 3; a++)
			m1[a] += mk[a];
	}
	double dp = 0;
	for (int a = 0; a < 3; a++)
		dp = fmax(dp, fabs(m1[a] - m0[a]));
	double scale = 3000 * sqrt(2 * t0.kinetic_energy / (3 * 3000.0));
	ok(ran && dp < 1e-9 * scale, "%s P=4 elastic, 200 steps, %llu collisions, %llu cell collisions, %llu migrants: "
	   "momentum change %.3g (scale %.3g)", what, (unsigned long long)t1.collisions,
	   (unsigned long long)t1.cell_collisions, (unsigned long long)t1.migrated, dp, scale);
	ok(ran && fabs(t1.kinetic_energy - t0.kinetic_energy) < 1e-9 * t0.kinetic_energy,
	   "%s P=4 elastic: energy %.15g -> %.15g", what, t0.kinetic_energy, t1.kinetic_energy);
	sim_destroy(&s);
}

/*
 * Haff's law over 3 ranks, as dsmc_test's test_haff_to(): R = 6 streams,
 * K = 8 output times, tolerance 4 standard errors of the mean over the 6
 * runs plus 1.5% of the theory (Sonine a2 and splitting error; see
 * tests/dsmc_test.c and tests/kinetic.h haff_worst()).
 */
static void test_haff_m(const char *method, int dim, int n, double nu, double e, int P)
{
	enum { R = 6, K = 8 };
	/* chi = 1 for dsmc's default correction "none", g(sigma) for hsmc's "cba" (tests/dsmc_test.c) */
	const double chi = strcmp(method, "hsmc") ? 1.0 : g_contact(dim, nu);
	const double lam = 1 - e * e, f = dim * pow(2, dim - 1) / (sqrt(PI) * 0.5) * nu * chi;
	const double t_end = 2 * 2 * dim / (lam * f);                                      /* tau = 2 */
	double ratio[K][R], t[K];
	int okrun = 1;
	for (int r = 0; r < R && okrun; r++) {
		char json[1024];
		snprintf(json, sizeof json,
		         "{\"method\":\"%s\",\"dimensions\":%d,\"particles\":{\"count\":%d,\"volume_fraction\":%g,"
		         "\"initial\":{\"positions\":\"random\"}},\"collisions\":{\"restitution\":%g},"
		         "\"run\":{\"seed\":%d,\"until\":{\"time\":%.17g}}}",
		         method, dim, n, nu, e, 300 + r, t_end);
		scene_t sc;
		sim_t s;
		if (parse(json, &sc) || sim_create(&s, &sc, 0, P)) {
			okrun = 0;
			break;
		}
		dsmcp_totals_t tt;
		dsmcp_totals(s.r[0], &tt);
		double T0 = 2 * tt.kinetic_energy / (dim * (double)n);
		for (int k = 0; k < K && okrun; k++) {
			okrun = sim_advance(&s, t_end * (k + 1) / K, UINT64_MAX) == 0;
			dsmcp_totals(s.r[0], &tt);
			t[k] = tt.time;
			ratio[k][r] = 2 * tt.kinetic_energy / (dim * (double)n) / T0;
		}
		sim_destroy(&s);
	}
	if (!okrun) {
		ok(0, "Haff decomposed %s %dD ran", method, dim);
		return;
	}
	double worst = haff_worst(K, R, &ratio[0][0], t, lam * f / (2 * dim));
	ok(worst < 1, "Haff decomposed %s %dD N=%d nu=%.2f e=%.3g over P=%d: worst deviation %.2f of tolerance", method, dim,
	   n, nu, e, P, worst);
}

static void test_haff(int dim, int n, double nu, double e, int P)
{
	test_haff_m("dsmc", dim, n, nu, e, P);
}

/*
 * The direct set-up (no rank holds the whole system) builds dsmc_create()'s
 * state: the same particles, positions and velocities bit for bit, so the
 * runs are identical too: P = 3 direct against P = 3 from dsmc_create(),
 * after 40 steps.
 */
static void test_direct(void)
{
	const char *json = "{\"method\":\"dsmc\",\"dimensions\":3,\"particles\":{\"count\":3000,\"volume_fraction\":0.05,"
	                   "\"initial\":{\"positions\":\"random\"}},\"collisions\":{\"restitution\":0.9},"
	                   "\"run\":{\"seed\":21,\"until\":{\"time\":100}}}";
	scene_t sc;
	sim_t a, b;
	if (parse(json, &sc) || !dsmcp_direct_ok(&sc) || sim_create_how(&a, &sc, 2, 3, 0) ||
	    sim_create_how(&b, &sc, 2, 3, 1)) {
		ok(0, "direct set-up scene");
		return;
	}
	const size_t N = 3000, D = 3;
	double *xa = calloc(N * D, sizeof(double)), *va = calloc(N * D, sizeof(double));
	double *xb = calloc(N * D, sizeof(double)), *vb = calloc(N * D, sizeof(double));
	int da, db;
	size_t fa = sim_state(&a, 3, N, xa, va, &da), fb = sim_state(&b, 3, N, xb, vb, &db);
	ok(fa == N && fb == N && !da && !db && !memcmp(xa, xb, N * D * sizeof(double)) &&
	   !memcmp(va, vb, N * D * sizeof(double)), "direct set-up over 3 ranks: dsmc_create()'s initial state bit for bit");
	int ran = sim_advance(&a, INFINITY, 40) == 0 && sim_advance(&b, INFINITY, 40) == 0;
	sim_state(&a, 3, N, xa, va, &da);
	sim_state(&b, 3, N, xb, vb, &db);
	dsmcp_totals_t ta, tb;
	dsmcp_totals(a.r[0], &ta);
	dsmcp_totals(b.r[0], &tb);
	ok(ran && !memcmp(xa, xb, N * D * sizeof(double)) && !memcmp(va, vb, N * D * sizeof(double)) &&
	   ta.collisions == tb.collisions && ta.time == tb.time,
	   "direct set-up: the same run after 40 steps (%llu collisions)", (unsigned long long)ta.collisions);
	free(xa);
	free(va);
	free(xb);
	free(vb);
	sim_destroy(&a);
	sim_destroy(&b);
}

static void test_refusals(void)
{
	static const struct {
		const char *extra, *key;
	} cases[] = {
		{ "\"method\":\"dsmc\",\"gravity\":[0,0,-1]", "gravity" },
		{ "\"method\":\"dsmc\",\"boundaries\":{\"z\":{\"type\":\"walls\",\"lower\":{\"type\":\"specular\"},\"upper\":{\"type\":\"specular\"}}}", "boundaries" },
		{ "\"method\":\"dsmc\",\"dsmc\":{\"contact_value\":\"local\",\"correction\":\"enskog\"}", "dsmc.contact_value" },
	};
	for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
		char json[1024], msg[256] = "";
		snprintf(json, sizeof json,
		         "{%s,\"dimensions\":3,\"particles\":{\"count\":500,\"volume_fraction\":0.05},"
		         "\"run\":{\"until\":{\"time\":1}}}", cases[i].extra);
		scene_t sc;
		if (parse(json, &sc)) {
			ok(0, "refusal %s: scene", cases[i].key);
			continue;
		}
		int rc = dsmcp_check(&sc, msg, sizeof msg);
		size_t kl = strlen(cases[i].key);
		ok(rc == DSMCP_EINVAL && !strncmp(msg, cases[i].key, kl) && msg[kl] == ':', "refused, naming %s: %s",
		   cases[i].key, msg);
	}
}

/* The whole state in the 1-rank order, as engine/par/dsmcrun.c gathers it for a checkpoint: each rank's
 * records and cells concatenated in rank order. */
static int sim_save(const sim_t *s, const scene_t *sc, dsmcp_saved_t *sv)
{
	uint64_t c0, c1, ncells, n = 0, cells = 0;
	if (dsmcp_cells_of(sc, 0, s->P, &c0, &c1, &ncells, NULL, 0) != DSMCP_OK ||
	    dsmcp_saved_alloc(sv, (int)sc->dim, sc->count, ncells) != DSMCP_OK)
		return -1;
	const int D = (int)sc->dim;
	dsmcp_clock(s->r[0], &sv->clock);
	sv->virial = 0;
	for (int k = 0; k < s->P; k++) {
		size_t nl = dsmcp_local(s->r[k], NULL, sv->pos + n * D, sv->vel + n * D);
		dsmcp_local_ids(s->r[k], sv->id + n);
		dsmcp_cells(s->r[k], &c0, &c1);
		if (c0 != cells)
			return -1;
		dsmcp_cell_state(s->r[k], sv->count + c0, sv->rem + c0);
		sv->virial += dsmcp_virial_part(s->r[k]);
		n += nl;
		cells = c1;
	}
	return n == sc->count && cells == ncells ? 0 : -1;
}

/* P ranks from a saved state: rank k takes the records of its cells (dsmcp_cells_of()), as dsmcrun.c scatters them. */
static int sim_restore(sim_t *s, const scene_t *sc, uint64_t stream, int P, const dsmcp_saved_t *sv)
{
	const int D = sv->dim;
	uint64_t first = 0;
	memset(s, 0, sizeof *s);
	s->P = P;
	for (int k = 0; k < P; k++) {
		uint64_t c0, c1, ncells, nl = 0;
		int err;
		char msg[256];
		if (dsmcp_cells_of(sc, k, P, &c0, &c1, &ncells, msg, sizeof msg) != DSMCP_OK)
			return -1;
		for (uint64_t c = c0; c < c1; c++)
			nl += sv->count[c];
		s->r[k] = dsmcp_restore(sc, stream, k, P, &sv->clock, k == 0 ? sv->virial : 0.0, nl, sv->pos + first * D,
		                        sv->vel + first * D, sv->id + first, sv->count + c0, sv->rem + c0, &err, msg,
		                        sizeof msg);
		if (!s->r[k]) {
			diag("dsmcp_restore: %s", msg);
			return -1;
		}
		first += nl;
	}
	return 0;
}

/*
 * Checkpoints: a state saved after some steps at P = 2 and restored at P' = 1, 2, 3 continues exactly as
 * the uninterrupted run (positions, velocities, clock, counters, the interval's energy integral), and a
 * damaged saved state is refused (dsmcp_saved_check()).
 */
static void test_restore(const char *method, int dim, int n, double nu, const char *corr, uint64_t before,
                         uint64_t after)
{
	char json[1024];
	snprintf(json, sizeof json,
	         "{\"method\":\"%s\",\"dimensions\":%d,\"particles\":{\"count\":%d,\"volume_fraction\":%g,"
	         "\"initial\":{\"positions\":\"random\"}},\"collisions\":{\"restitution\":0.9},"
	         "\"run\":{\"seed\":11,\"until\":{\"time\":100}},\"%s\":{\"correction\":\"%s\"%s}}",
	         method, dim, n, nu, method, corr, strcmp(method, "hsmc") ? "" : ",\"cell_size\":2");
	scene_t sc;
	sim_t a;
	dsmcp_saved_t sv;
	char msg[256] = "";
	memset(&sv, 0, sizeof sv);
	if (parse(json, &sc) || sim_create(&a, &sc, 0, 2) || sim_advance(&a, INFINITY, before) ||
	    sim_save(&a, &sc, &sv)) {
		ok(0, "restore %s %dD: set-up", method, dim);
		return;
	}
	int rc = dsmcp_saved_check(&sv, &sc, msg, sizeof msg);
	ok(rc == DSMCP_OK, "%s %dD %s: the state saved at P=2 after %llu steps is consistent %s", method, dim, corr,
	   (unsigned long long)before, msg);
	const size_t N = (size_t)n, D = (size_t)dim;
	double *x1 = calloc(N * D, sizeof(double)), *v1 = calloc(N * D, sizeof(double));
	double *xp = calloc(N * D, sizeof(double)), *vp = calloc(N * D, sizeof(double));
	int dup = 0;
	sim_advance(&a, INFINITY, after);
	sim_state(&a, dim, N, x1, v1, &dup);
	dsmcp_totals_t t1, t;
	dsmcp_clock_t k1, k;
	dsmcp_totals(a.r[0], &t1);
	dsmcp_clock(a.r[0], &k1);
	for (int P = 1; P <= 3; P++) {
		sim_t b;
		if (sim_restore(&b, &sc, 0, P, &sv) || sim_advance(&b, INFINITY, after)) {
			ok(0, "%s %dD restored at P=%d ran", method, dim, P);
			sim_destroy(&b);
			continue;
		}
		size_t found = sim_state(&b, dim, N, xp, vp, &dup);
		dsmcp_totals(b.r[0], &t);
		dsmcp_clock(b.r[0], &k);
		ok(found == N && !dup && !memcmp(x1, xp, N * D * sizeof(double)) && !memcmp(v1, vp, N * D * sizeof(double)) &&
		   t.time == t1.time && t.steps == t1.steps && t.collisions == t1.collisions &&
		   t.candidates == t1.candidates && t.vmax_raised == t1.vmax_raised &&
		   t.kinetic_energy == t1.kinetic_energy && t.cell_collisions == t1.cell_collisions &&
		   t.rejected == t1.rejected && k.ekin_int == k1.ekin_int && k.t_sample == k1.t_sample,
		   "%s %dD %s: saved at P=2, restored at P=%d, %llu more steps: state, clock and counters bit-identical to "
		   "the uninterrupted run (%llu collisions, %llu cell collisions)", method, dim, corr, P,
		   (unsigned long long)after, (unsigned long long)t.collisions, (unsigned long long)t.cell_collisions);
		sim_destroy(&b);
	}
	/* damage: a duplicated identity, a count moved between cells so they no longer add up, a negative remainder */
	uint32_t id0 = sv.id[0];
	sv.id[0] = sv.id[1];
	ok(dsmcp_saved_check(&sv, &sc, msg, sizeof msg) == DSMCP_EINVAL, "a duplicated identity is refused: %s", msg);
	sv.id[0] = id0;
	sv.count[0]++;
	ok(dsmcp_saved_check(&sv, &sc, msg, sizeof msg) == DSMCP_EINVAL, "cell counts off by one are refused: %s", msg);
	sv.count[0]--;
	sv.rem[0] = -1;
	ok(dsmcp_saved_check(&sv, &sc, msg, sizeof msg) == DSMCP_EINVAL, "a negative remainder is refused: %s", msg);
	sim_destroy(&a);
	dsmcp_saved_free(&sv);
	free(x1);
	free(v1);
	free(xp);
	free(vp);
}

int main(void)
{
	test_refusals();
	test_identity(3, 4000, 0.05, "none", 0.9, 60);
	test_identity(2, 1500, 0.1, "cba", 0.8, 60);
	/* 2 x 2 x 2 cells: at P = 3..5 some ranks own no plane (idle, and still correct) */
	test_identity(3, 40, 0.05, "none", 0.9, 40);
	/* hsmc, dense: full cells, cell-cell collisions and rejected moves across the slab borders */
	test_identity_m("hsmc", 2, 3000, 0.75, "cba", 0.9, 60);
	test_identity_m("hsmc", 3, 4000, 0.55, "cba", 0.9, 40);
	test_conservation();
	test_direct();
	test_restore("dsmc", 3, 4000, 0.05, "none", 30, 30);
	test_restore("dsmc", 2, 1500, 0.1, "cba", 30, 30);
	/* dense hsmc with CBA: records displaced out of their sort cells, which the next step's cell pass uses */
	test_restore("hsmc", 2, 3000, 0.75, "cba", 30, 30);
	test_haff(3, 2000, 0.1, 0.9, 3);
	test_haff(2, 500, 0.1, 0.95, 2);
	test_haff_m("hsmc", 2, 500, 0.4, 0.98, 3);   /* as tests/dsmc_test's hsmc/cba row */
	plan(tap_n);
	return done_testing();
}
