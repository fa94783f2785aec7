/* Tests of state export and restore (ed fields, run schedule): a restored run continues bit for bit. */
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "mc/dsmc.h"
#include "ed/ed.h"
#include "io/report.h"
#include "par/ensemble.h"
#include "rng.h"
#include "run.h"
#include "scene.h"
#include "tap.h"

/* One field's saved copy. */
typedef struct {
	ed_field_t f;
	void *data;
} saved_t;

typedef struct {
	saved_t s[ED_MAX_FIELDS];
	int n;
} snapshot_t;

static void snap_free(snapshot_t *sn)
{
	for (int k = 0; k < sn->n; k++)
		free(sn->s[k].data);
	sn->n = 0;
}

static int snap_take(const ed_t *ed, snapshot_t *sn)
{
	ed_field_t f[ED_MAX_FIELDS];
	int n = ed_fields(ed, f, ED_MAX_FIELDS);
	if (n > ED_MAX_FIELDS)
		return -1;
	sn->n = 0;
	for (int k = 0; k < n; k++) {
		size_t bytes = f[k].count * ed_type_size(f[k].type);
		sn->s[k].f = f[k];
		sn->s[k].data = malloc(bytes ? bytes : 1);
		sn->n++;
		if (!sn->s[k].data || ed_field_get(ed, f[k].name, sn->s[k].data) != ED_OK)
			return -1;
	}
	return 0;
}

static int snap_equal(const snapshot_t *a, const snapshot_t *b, const char **which)
{
	if (a->n != b->n)
		return 0;
	for (int k = 0; k < a->n; k++) {
		*which = a->s[k].f.name;
		if (strcmp(a->s[k].f.name, b->s[k].f.name) || a->s[k].f.count != b->s[k].f.count ||
		    memcmp(a->s[k].data, b->s[k].data, a->s[k].f.count * ed_type_size(a->s[k].f.type)))
			return 0;
	}
	return 1;
}

/* Restore sn into a fresh engine for scene sc. */
static ed_t *restore(const scene_t *sc, const snapshot_t *sn, char *msg, size_t len)
{
	int err;
	ed_t *ed = ed_create_blank(sc, &err, msg, len);
	if (!ed)
		return NULL;
	for (int k = 0; k < sn->n; k++)
		if (ed_field_set(ed, sn->s[k].f.name, sn->s[k].f.type, sn->s[k].f.count, sn->s[k].data) != ED_OK) {
			snprintf(msg, len, "field %s refused", sn->s[k].f.name);
			ed_destroy(ed);
			return NULL;
		}
	if (ed_restore_finish(ed, msg, len) != ED_OK) {
		ed_destroy(ed);
		return NULL;
	}
	return ed;
}

static const struct {
	const char *name;
	const char *json;
} scenes[] = {
	{ "2D dilute elastic (cells)",
	  "{\"method\":\"ed\",\"dimensions\":2,\"particles\":{\"count\":800,\"volume_fraction\":0.05,"
	  "\"initial\":{\"positions\":\"random\"}},\"run\":{\"seed\":3,\"until\":{\"time\":100}}}" },
	{ "2D dense inelastic TC (neighbour lists)",
	  "{\"method\":\"ed\",\"dimensions\":2,\"particles\":{\"count\":900,\"volume_fraction\":0.7},"
	  "\"collisions\":{\"restitution\":0.8,\"tc\":0.0001},\"run\":{\"seed\":4,\"until\":{\"time\":100}}}" },
	{ "3D dilute inelastic TC (cells)",
	  "{\"method\":\"ed\",\"dimensions\":3,\"particles\":{\"count\":700,\"volume_fraction\":0.1,"
	  "\"initial\":{\"positions\":\"random\"}},\"collisions\":{\"restitution\":0.9,\"tc\":0.001},"
	  "\"run\":{\"seed\":5,\"until\":{\"time\":100}}}" },
	{ "3D dense elastic (neighbour lists)",
	  "{\"method\":\"ed\",\"dimensions\":3,\"particles\":{\"count\":864,\"volume_fraction\":0.45},"
	  "\"run\":{\"seed\":6,\"until\":{\"time\":100}}}" },
	{ "3D tiny box (small grid, minimum image)",
	  "{\"method\":\"ed\",\"dimensions\":3,\"particles\":{\"count\":6,\"box\":[2.5,2.5,2.5]},"
	  "\"run\":{\"seed\":7,\"until\":{\"time\":100}}}" },
};
#define N_SCENES (sizeof scenes / sizeof scenes[0])

/* Engine level: the reference advances in random chunks; the copy does the
 * same but is saved and restored into a fresh engine after every chunk
 * (so at arbitrary event boundaries, through rebases and list rebuilds),
 * and both sample at the same points. Final states must be identical. */
static void test_engine(size_t k)
{
	scene_t sc;
	char err[512];
	int e1, e2;
	snapshot_t sa = {.n = 0}, sb = {.n = 0};
	if (scene_parse(scenes[k].json, strlen(scenes[k].json), &sc, err, sizeof(err)) != SCENE_OK) {
		ok(0, "%s: scene: %s", scenes[k].name, err);
		return;
	}
	ed_t *a = ed_create(&sc, &e1, err, sizeof(err)), *b = ed_create(&sc, &e2, err, sizeof(err));
	rng_t rng;
	rng_init(&rng, 42 + k, 0);
	int restores = 0, same_samples = 1;
	const uint64_t total = 60000;
	while (a && b && ed_events(a) < total) {
		uint64_t chunk = 1 + (rng_u64(&rng) % 3000), before = ed_events(a);
		ed_advance(a, INFINITY, UINT64_MAX, chunk);
		if (ed_events(a) == before)
			break;   /* quiescent */
		ed_advance(b, INFINITY, UINT64_MAX, chunk);
		if (rng_u64(&rng) % 4 == 0) {
			ed_sample_t x, y;
			ed_sample(a, &x);
			ed_sample(b, &y);
			same_samples &= memcmp(&x, &y, sizeof x) == 0;
		}
		if (snap_take(b, &sb) != 0)
			break;
		ed_destroy(b);
		b = restore(&sc, &sb, err, sizeof(err));
		snap_free(&sb);
		restores++;
	}
	const char *which = "";
	int same = a && b && snap_take(a, &sa) == 0 && snap_take(b, &sb) == 0 && snap_equal(&sa, &sb, &which);
	ok(same && same_samples, "%s: %d restores at random event boundaries, %llu events: state %s, samples %s",
	   scenes[k].name, restores, a ? (unsigned long long)ed_events(a) : 0ull,
	   same ? "bit-identical" : which, same_samples ? "identical" : "differ");
	snap_free(&sa);
	snap_free(&sb);
	ed_destroy(a);
	ed_destroy(b);
}

/* dsmc/hsmc: the same at random step boundaries (random chunks of steps,
 * some cut short by a stop time, as output times do), through dsmc_fields(). */
static const struct {
	const char *name;
	const char *json;
} mc_scenes[] = {
	{ "dsmc 2D CBA", "{\"method\":\"dsmc\",\"dimensions\":2,\"particles\":{\"count\":900,\"volume_fraction\":0.2,"
	  "\"initial\":{\"positions\":\"random\"}},\"collisions\":{\"restitution\":0.9},\"run\":{\"seed\":8,"
	  "\"until\":{\"time\":100}},\"dsmc\":{\"correction\":\"cba\"}}" },
	{ "hsmc 3D dense", "{\"method\":\"hsmc\",\"dimensions\":3,\"particles\":{\"count\":1000,\"volume_fraction\":0.45},"
	  "\"collisions\":{\"restitution\":0.8},\"run\":{\"seed\":9,\"until\":{\"time\":100}},\"hsmc\":{\"cell_size\":2}}" },
};

static void test_mc(size_t k)
{
	scene_t sc;
	char err[512] = "";
	int e1, e2, restores = 0, same_samples = 1, same = 0;
	ed_field_t f[DSMC_MAX_FIELDS];
	void *data[DSMC_MAX_FIELDS] = {NULL};
	int nf = 0;
	scene_parse(mc_scenes[k].json, strlen(mc_scenes[k].json), &sc, err, sizeof(err));
	dsmc_t *a = dsmc_create(&sc, 0, &e1, err, sizeof(err)), *b = dsmc_create(&sc, 0, &e2, err, sizeof(err));
	rng_t rng;
	rng_init(&rng, 77 + k, 0);
	for (int it = 0; a && b && it < 60; it++) {
		uint64_t steps = 1 + rng_u64(&rng) % 8;
		double t_stop = rng_u64(&rng) % 3 == 0 ? dsmc_time(a) + 0.37 * rng_uniform(&rng) : INFINITY;
		dsmc_advance(a, t_stop, UINT64_MAX, steps);
		dsmc_advance(b, t_stop, UINT64_MAX, steps);
		if (rng_u64(&rng) % 4 == 0) {
			dsmc_sample_t x, y;
			dsmc_sample(a, &x);
			dsmc_sample(b, &y);
			same_samples &= memcmp(&x, &y, sizeof x) == 0;
		}
		nf = dsmc_fields(b, f, DSMC_MAX_FIELDS);
		for (int j = 0; j < nf; j++) {
			data[j] = malloc(f[j].count * ed_type_size(f[j].type) + 1);
			dsmc_field_get(b, f[j].name, data[j]);
		}
		dsmc_destroy(b);
		b = dsmc_create_blank(&sc, &e2, err, sizeof(err));
		for (int j = 0; b && j < nf; j++)
			if (dsmc_field_set(b, f[j].name, f[j].type, f[j].count, data[j]) != DSMC_OK)
				snprintf(err, sizeof err, "field %s refused", f[j].name);
		if (b && dsmc_restore_finish(b, err, sizeof(err)) != DSMC_OK) {
			dsmc_destroy(b);
			b = NULL;
		}
		for (int j = 0; j < nf; j++)
			free(data[j]);
		restores++;
	}
	if (a && b) {
		size_t bytes = sc.count * sc.dim * sizeof(double);
		double *pa = malloc(bytes), *pb = malloc(bytes), *va = malloc(bytes), *vb = malloc(bytes);
		dsmc_state(a, pa, va);
		dsmc_state(b, pb, vb);
		same = !memcmp(pa, pb, bytes) && !memcmp(va, vb, bytes) && dsmc_collisions(a) == dsmc_collisions(b) &&
		       dsmc_time(a) == dsmc_time(b) && dsmc_collisions(a) > 1000;
		free(pa), free(pb), free(va), free(vb);
	}
	ok(same && same_samples, "%s: %d restores at random step boundaries, %llu collisions: state %s, samples %s %s",
	   mc_scenes[k].name, restores, a ? (unsigned long long)dsmc_collisions(a) : 0ull,
	   same ? "bit-identical" : "differs", same_samples ? "identical" : "differ", err);
	dsmc_destroy(a);
	dsmc_destroy(b);
}

/* dsmc: damaged fields are refused. */
static void test_mc_refuse(void)
{
	scene_t sc;
	char err[512] = "";
	int e;
	scene_parse(mc_scenes[1].json, strlen(mc_scenes[1].json), &sc, err, sizeof(err));
	dsmc_t *a = dsmc_create(&sc, 0, &e, err, sizeof(err));
	static const char *const targets[] = {"id", "start", "particles"};
	for (size_t t = 0; a && t < sizeof targets / sizeof targets[0]; t++) {
		ed_field_t f[DSMC_MAX_FIELDS];
		int nf = dsmc_fields(a, f, DSMC_MAX_FIELDS);
		void *data[DSMC_MAX_FIELDS];
		dsmc_t *b = dsmc_create_blank(&sc, &e, err, sizeof(err));
		for (int j = 0; j < nf; j++) {
			data[j] = malloc(f[j].count * ed_type_size(f[j].type));
			dsmc_field_get(a, f[j].name, data[j]);
			if (!strcmp(f[j].name, targets[t])) {
				if (f[j].type == ED_T_U32)
					((uint32_t *)data[j])[f[j].count / 2] = (uint32_t)sc.count + 5;
				else
					((double *)data[j])[0] = -1.0;
			}
			dsmc_field_set(b, f[j].name, f[j].type, f[j].count, data[j]);
			free(data[j]);
		}
		int rc = dsmc_restore_finish(b, err, sizeof(err));
		ok(rc == DSMC_EINVAL, "dsmc field %s damaged: refused (%s)", targets[t], rc ? err : "accepted");
		dsmc_destroy(b);
	}
	dsmc_destroy(a);
}

/* A corrupted field must be refused, never crash the engine. */
static void test_refuse(void)
{
	scene_t sc;
	char err[512] = "";
	int e;
	const char *json = scenes[1].json;
	scene_parse(json, strlen(json), &sc, err, sizeof(err));
	ed_t *a = ed_create(&sc, &e, err, sizeof(err));
	snapshot_t sn = {.n = 0};
	if (!a || snap_take(a, &sn) != 0) {
		ok(0, "refuse: setup");
		ed_destroy(a);
		return;
	}
	static const char *const targets[] = {"partner", "next", "head", "id", "cell", "nb"};
	for (size_t t = 0; t < sizeof targets / sizeof targets[0]; t++) {
		for (int k = 0; k < sn.n; k++) {
			if (strcmp(sn.s[k].f.name, targets[t]))
				continue;
			int32_t *p = sn.s[k].data, old = p[3];
			p[3] = (int32_t)sc.count + 7;
			ed_t *b = restore(&sc, &sn, err, sizeof(err));
			ok(b == NULL, "field %s out of range refused: %s", targets[t], b ? "accepted" : err);
			ed_destroy(b);
			p[3] = old;
		}
	}
	/* a duplicated particle in the cell lists (a cycle) */
	for (int k = 0; k < sn.n; k++)
		if (!strcmp(sn.s[k].f.name, "next")) {
			int32_t *p = sn.s[k].data, old = p[10];
			p[10] = 10;
			ed_t *b = restore(&sc, &sn, err, sizeof(err));
			ok(b == NULL, "cell-list cycle refused: %s", b ? "accepted" : err);
			ed_destroy(b);
			p[10] = old;
		}
	int err2;
	ed_t *b = ed_create_blank(&sc, &err2, err, sizeof(err));
	double x = 1.0;
	ok(b && ed_field_set(b, "r", ED_T_F64, 3, &x) == ED_EINVAL && ed_field_set(b, "bogus", ED_T_F64, 1, &x) == ED_EINVAL &&
	   ed_field_set(b, "clock", ED_T_U64, 1, &x) == ED_EINVAL,
	   "wrong length, unknown name and wrong type refused");
	ed_destroy(b);
	b = restore(&sc, &sn, err, sizeof(err));
	ok(b != NULL, "the unaltered state is accepted%s%s", b ? "" : ": ", b ? "" : err);
	ed_destroy(b);
	snap_free(&sn);
	ed_destroy(a);
}

/* Run level: records of a run that is saved and restored at every
 * checkpoint equal those of run_scene() (wall clock aside). */
typedef struct {
	run_record_t r[512];
	int n;
} recs_t;

static int collect(const run_record_t *r, void *ctx)
{
	recs_t *c = ctx;
	if (r->kind == RUN_SNAPSHOT)
		return 0;
	if (c->n < 512) {
		c->r[c->n] = *r;
		c->r[c->n].wall_seconds = 0;
		c->r[c->n].events_per_second = c->r[c->n].collisions_per_second = 0;
		c->n++;
	}
	return 0;
}

static void test_run(void)
{
	const char *json =
	    "{\"method\":\"ed\",\"dimensions\":3,\"particles\":{\"count\":400,\"volume_fraction\":0.35},"
	    "\"collisions\":{\"restitution\":0.9,\"tc\":0.001},\"run\":{\"seed\":9,\"until\":{\"collisions_per_particle\":40}},"
	    "\"output\":{\"every\":{\"collisions_per_particle\":1.5},\"observables\":[\"kinetic_energy\",\"pressure\","
	    "\"collision_rate\",\"clusters\",\"momentum\"],\"checkpoint\":{\"every\":{\"time\":0.37}}}}";
	scene_t sc;
	char err[512];
	int e;
	static recs_t ref, got;
	ref.n = got.n = 0;
	scene_parse(json, strlen(json), &sc, err, sizeof(err));
	int rc = run_scene(&sc, collect, &ref, NULL, err, sizeof(err));
	run_opts_t opts = {.snapshots = 0, .checkpoints = 1};
	run_t *r = run_create(&sc, &opts, &e, err, sizeof(err));
	int restores = 0;
	while (r) {
		rc = run_go(r, collect, &got, NULL, err, sizeof(err));
		if (rc != RUN_CHECKPOINT)
			break;
		snapshot_t sn = {.n = 0};
		run_state_t st;
		run_get_state(r, &st);
		snap_take(run_ed(r), &sn);
		run_destroy(r);
		r = run_create_blank(&sc, &opts, &e, err, sizeof(err));
		for (int k = 0; r && k < sn.n; k++)
			ed_field_set(run_ed(r), sn.s[k].f.name, sn.s[k].f.type, sn.s[k].f.count, sn.s[k].data);
		snap_free(&sn);
		if (r) {
			run_set_state(r, &st);
			if (run_restore_finish(r, err, sizeof(err)) != RUN_OK)
				break;
		}
		restores++;
	}
	run_destroy(r);
	int same = rc == RUN_OK && ref.n == got.n && ref.n > 10;
	for (int k = 0; same && k < ref.n; k++) {
		char la[REPORT_MAX], lb[REPORT_MAX];
		same = report_format(&ref.r[k], la, sizeof la) > 0 && report_format(&got.r[k], lb, sizeof lb) > 0 &&
		       strcmp(la, lb) == 0;
	}
	ok(same && restores >= 3, "run restored at %d checkpoints: %d records identical to the uninterrupted run (%d)",
	   restores, got.n, ref.n);
}

/* A replica's state string as it lies in a checkpoint: at any offset (fields
 * follow names of any length). Loading must not read its arrays in place
 * (an int32_t or double at an odd address is undefined behaviour: the suite
 * under UBSan, make check-asan, failed here; found by tests/fuzz/ckpt_fuzz). */
static void test_ensemble_unaligned(void)
{
	const char *json =
	    "{\"method\":\"ed\",\"dimensions\":2,\"particles\":{\"count\":9,\"volume_fraction\":0.1,"
	    "\"initial\":{\"positions\":\"random\"}},\"run\":{\"seed\":5,\"until\":{\"time\":3},\"replicas\":2}}";
	scene_t sc;
	char err[512];
	int e, rc = -1;
	unsigned char *blob = NULL, *odd = NULL;
	size_t len = 0;
	run_opts_t opts = {.snapshots = 0, .checkpoints = 1};
	run_t *r = NULL, *back = NULL;
	if (scene_parse(json, strlen(json), &sc, err, sizeof(err)) == SCENE_OK && (r = run_create(&sc, &opts, &e, err, sizeof(err))) &&
	    ensemble_save(r, &blob, &len) == 0 && (odd = malloc(len + 1))) {
		memcpy(odd + 1, blob, len);
		rc = ensemble_load(&sc, 0, odd + 1, len, &back, err, sizeof(err));
	}
	ok(rc == RUN_OK && back, "a replica state string at an odd address loads (%s)", rc == RUN_OK ? "ok" : err);
	run_destroy(back);
	run_destroy(r);
	free(blob);
	free(odd);
}

int main(void)
{
	plan((int)N_SCENES + 10 + 2 + 3 + 1);
	for (size_t k = 0; k < N_SCENES; k++)
		test_engine(k);
	for (size_t k = 0; k < 2; k++)
		test_mc(k);
	test_mc_refuse();
	test_refuse();
	test_run();
	test_ensemble_unaligned();
	return done_testing();
}
