/* Tests of advice_: model parsing and its errors, the cost model's scaling, Haff's law, the choice for "auto", determinism. */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "advice.h"
#include "dsmc.h"
#include "scene.h"
#include "tap.h"

/* A synthetic model with round constants, so expectations follow from the
 * formulas in advice.h rather than from a bench run. 2D grid nu {0.05, 0.4},
 * lambda {0.19, 0.75}; 3D the same numbers. */
#define DIMMODEL(D) \
	"\"" #D "\": {\"volume_fraction\": [0.05, 0.4], \"lambda\": [0.19, 0.75], \"variants\": {" \
	"\"ed\": {\"bias\": [[0,0],[0,0]], \"spread\": [[1,1],[1,1]]}," \
	"\"dsmc/none\": {\"bias\": [[0.1,0.1],[0.1,0.1]], \"spread\": [[1,1],[1,1]]}," \
	"\"hsmc/cba\": {\"bias\": [[0.02,0.02],[0.02,0.02]], \"spread\": [[1,1],[1,1]]}}," \
	"\"clustering\": {\"dsmc/none\": 0.3, \"hsmc/cba\": 0.2}}"
#define COST(D) \
	"\"" #D "\": {\"per_move\": 1e-8, \"per_collision\": 1e-7}"
static const char *const MODEL =
	"{\"format\": \"granulard-advice-model\", \"version\": 1, \"generated\": {\"date\": \"test\"},"
	" \"particles_measured\": 10000, \"haff_time_max\": 2,"
	" \"cost\": {\"ed\": {\"2\": {\"per_collision\": 1e-6, \"per_collision_dilute\": 1e-7},"
	"                     \"3\": {\"per_collision\": 2e-6, \"per_collision_dilute\": 0}},"
	"          \"dsmc\": {" COST(2) ", " COST(3) "}, \"hsmc\": {" COST(2) ", " COST(3) "}},"
	" \"error\": {" DIMMODEL(2) ", " DIMMODEL(3) "}}";

static advice_model_t *model(void)
{
	char err[256];
	advice_model_t *m = advice_model_create(MODEL, strlen(MODEL), err, sizeof err);
	if (!m)
		diag("test model rejected: %s", err);
	return m;
}

/* A scene from a JSON text with {N}, {E}, ... filled in by the caller's printf. */
static int scene(scene_t *s, const char *fmt, ...)
{
	char buf[2048], err[256];
	va_list ap;
	va_start(ap, fmt);
	vsnprintf(buf, sizeof buf, fmt, ap);
	va_end(ap);
	if (scene_parse(buf, strlen(buf), s, err, sizeof err) != SCENE_OK) {
		diag("scene rejected: %s", err);
		return -1;
	}
	return 0;
}

#define COOL "{\"method\":\"%s\",%s\"dimensions\":%d,\"particles\":{\"count\":%d,\"volume_fraction\":%g," \
	"\"initial\":{\"relax\":{\"collisions_per_particle\":%g}}},\"collisions\":{\"restitution\":%g}," \
	"\"run\":{\"until\":{%s},\"replicas\":%d},\"output\":{\"every\":{%s}}}"

static int estimate(const advice_model_t *m, const scene_t *s, advice_t *a)
{
	char err[256];
	int r = advice_estimate(m, s, 1, a, err, sizeof err);
	if (r)
		diag("advice_estimate: %s", err);
	return r;
}

/* Model texts that must be refused, and the key the message must start with. */
static void model_errors(void)
{
	static const struct { const char *json, *path; } cases[] = {
		{"not json", "(root)"},
		{"[1]", "(root)"},
		{"{\"format\": \"other\", \"version\": 1}", "format"},
		{"{\"format\": \"granulard-advice-model\", \"version\": 2}", "version"},
		{"{\"format\": \"granulard-advice-model\", \"version\": 1}", "particles_measured"},
	};
	char err[256];
	for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
		advice_model_t *m = advice_model_create(cases[i].json, strlen(cases[i].json), err, sizeof err);
		ok(!m && !strncmp(err, cases[i].path, strlen(cases[i].path)) && err[strlen(cases[i].path)] == ':',
		   "model %s refused: %s", cases[i].path, err);
		advice_model_destroy(m);
	}
	/* Edits of the good model: each must name its key. */
	static const struct { const char *from, *to, *path; } edits[] = {
		{"\"per_collision\": 1e-6", "\"per_collision\": -1", "cost.ed.2.per_collision"},
		{"\"per_collision_dilute\": 0", "\"per_collision_dilute\": \"x\"", "cost.ed.3.per_collision_dilute"},
		{"\"lambda\": [0.19, 0.75]", "\"lambda\": [0.75, 0.19]", "error.2.lambda"},
		{"\"spread\": [[1,1],[1,1]]}}", "\"spread\": [[1,1]]}}", "error.2.variants.hsmc/cba.spread"},
	};
	for (size_t i = 0; i < sizeof edits / sizeof edits[0]; i++) {
		char buf[4096];
		const char *at = strstr(MODEL, edits[i].from);
		snprintf(buf, sizeof buf, "%.*s%s%s", (int)(at - MODEL), MODEL, edits[i].to, at + strlen(edits[i].from));
		advice_model_t *m = advice_model_create(buf, strlen(buf), err, sizeof err);
		ok(!m && !strncmp(err, edits[i].path, strlen(edits[i].path)), "model key %s checked: %s", edits[i].path, err);
		advice_model_destroy(m);
	}
	size_t len;
	const char *text = advice_model_builtin(&len);
	advice_model_t *b = advice_model_create(text, len, err, sizeof err);
	ok(b && advice_model_particles(b) >= 1000, "the built-in model parses (measured at N = %g)%s%s",
	   b ? advice_model_particles(b) : 0.0, b ? "" : ": ", b ? "" : err);
	advice_model_destroy(b);
}

/* Haff's law against a direct integration of dT/dt = -(lambda/D) f(T) T,
 * dcpp/dt = f(T), f = f0 sqrt(T/T0) (RK4, 20000 steps: error ~1e-12). */
static void haff(const advice_model_t *m)
{
	const int D = 2;
	const double nu = 0.2, e = 0.8, lam = 1 - e * e, t_end = 7.5;
	double f0 = dsmc_collision_frequency(D, nu, 0.5, 1, 1, dsmc_contact_value(D, nu));
	double T = 1, c = 0, h = t_end / 20000;
	for (int i = 0; i < 20000; i++) {
#define FT(T) (f0 * sqrt(T))
		double k1 = -lam / D * FT(T) * T, c1 = FT(T);
		double T2 = T + h / 2 * k1, k2 = -lam / D * FT(T2) * T2, c2 = FT(T2);
		double T3 = T + h / 2 * k2, k3 = -lam / D * FT(T3) * T3, c3 = FT(T3);
		double T4 = T + h * k3, k4 = -lam / D * FT(T4) * T4, c4 = FT(T4);
#undef FT
		T += h / 6 * (k1 + 2 * k2 + 2 * k3 + k4);
		c += h / 6 * (c1 + 2 * c2 + 2 * c3 + c4);
	}
	double cpp = advice_haff_cpp(D, f0, lam, t_end);
	ok(fabs(cpp / c - 1) < 1e-9, "Haff: collisions per particle %.10g = integral of f(T(t)) dt %.10g", cpp, c);
	ok(fabs(advice_haff_cpp(D, f0, 0, t_end) / (f0 * t_end) - 1) < 1e-12, "elastic limit: f0 t");

	scene_t s;
	advice_t a;
	if (scene(&s, COOL, "ed", "", D, 1000, nu, 0.0, e, "\"time\":7.5", 3, "\"time\":0.75") || estimate(m, &s, &a)) {
		ok(0, "estimate of a cooling scene");
		return;
	}
	ok(fabs(a.cpp / c - 1) < 1e-9 && fabs(a.est[0].collisions / (3 * 1000 / 2.0 * c) - 1) < 1e-9,
	   "ed estimate: %.6g collisions = replicas x N/2 x Haff's cpp", a.est[0].collisions);
	/* dsmc/none simulates chi = 1: fewer collisions in the same time. */
	double c1 = advice_haff_cpp(D, f0 / dsmc_contact_value(D, nu), lam, t_end);
	ok(fabs(a.est[1].collisions / (3 * 1000 / 2.0 * c1) - 1) < 1e-9, "dsmc/none: Haff with chi = 1 (%.6g collisions)",
	   a.est[1].collisions);
	ok(fabs(a.haff_time - lam * f0 * t_end / (2 * D)) < 1e-12, "Haff time reached: %.4g", a.haff_time);
}

/* Cost: linear in N and replicas, linear in the run length when it is a number of collisions. */
static void scaling(const advice_model_t *m)
{
	scene_t s1, s2, s3;
	advice_t a1, a2, a3;
	if (scene(&s1, COOL, "ed", "", 3, 2000, 0.1, 5.0, 0.9, "\"collisions_per_particle\":20", 1,
	          "\"collisions_per_particle\":2") ||
	    scene(&s2, COOL, "ed", "", 3, 8000, 0.1, 5.0, 0.9, "\"collisions_per_particle\":20", 1,
	          "\"collisions_per_particle\":2") ||
	    scene(&s3, COOL, "ed", "", 3, 2000, 0.1, 10.0, 0.9, "\"collisions_per_particle\":40", 1,
	          "\"collisions_per_particle\":2") ||
	    estimate(m, &s1, &a1) || estimate(m, &s2, &a2) || estimate(m, &s3, &a3)) {
		ok(0, "scaling scenes");
		return;
	}
	for (int i = 0; i < 3; i++) {
		ok(fabs(a2.est[i].cpu_seconds / a1.est[i].cpu_seconds - 4) < 1e-9, "%s: 4x N -> 4x cost (%.4g -> %.4g s)",
		   a1.est[i].variant, a1.est[i].cpu_seconds, a2.est[i].cpu_seconds);
		ok(fabs(a3.est[i].cpu_seconds / a1.est[i].cpu_seconds - 2) < 1e-9,
		   "%s: 2x collisions per particle (run and relax) -> 2x cost", a1.est[i].variant);
		ok(fabs(a2.est[i].statistical / a1.est[i].statistical - 0.5) < 1e-9, "%s: 4x N -> half the statistical error",
		   a1.est[i].variant);
	}
	/* The ed cost formula itself: collisions x (a + b / (nu chi)) with a = 2e-6, b = 0 in 3D. */
	ok(fabs(a1.est[0].cpu_seconds - 2000 / 2.0 * 25 * 2e-6) < 1e-12, "ed cost = collisions x seconds per collision");
	/* MC: moves = N x (cpp / 0.2 + outputs) for the run + N x relax / 0.2; collisions N/2 x (cpp + relax). */
	double moves = 2000 * (20 / 0.2 + 10 + 5 / 0.2);
	ok(fabs(a1.est[1].moves / moves - 1) < 1e-12 && fabs(a1.est[1].cpu_seconds - (moves * 1e-8 + 2000 / 2.0 * 25 * 1e-7)) < 1e-12,
	   "dsmc cost = moves x s_move + collisions x s_coll (%.6g moves)", a1.est[1].moves);
	ok(a1.est[0].wall_seconds == a1.est[0].cpu_seconds, "one replica: wall time = CPU time");
}

static void choice(const advice_model_t *m)
{
	scene_t s;
	advice_t a;
	char err[256];
	/* Costs: ed ~1e-6 s/collision, MC ~1e-7 s/collision + moves: MC is cheaper here. */
	if (scene(&s, COOL, "auto", "\"accuracy\":{\"temperature\":0.05},", 2, 10000, 0.1, 0.0, 0.9, "\"time\":5", 4,
	          "\"time\":1") || estimate(m, &s, &a)) {
		ok(0, "auto scene");
		return;
	}
	/* Expected: ed statistical 1/sqrt(4e4) = 0.005; dsmc ~0.1; hsmc ~0.02. */
	ok(a.choice == 2 && a.est[0].meets == 1 && a.est[1].meets == 0 && a.est[2].meets == 1,
	   "target 0.05: hsmc chosen (meets, cheaper than ed; dsmc misses): %s", a.reason);
	ok(a.est[2].cpu_seconds < a.est[0].cpu_seconds, "hsmc (%.3g s) is cheaper than ed (%.3g s)", a.est[2].cpu_seconds,
	   a.est[0].cpu_seconds);
	scene_t r = s;
	advice_apply(&a, &r);
	ok(r.method == SCENE_METHOD_HSMC, "advice_apply: method hsmc");

	s.accuracy_temperature = 0.5;
	advice_estimate(m, &s, 1, &a, err, sizeof err);
	int cheapest = 0;
	for (int i = 1; i < a.n; i++)
		if (a.est[i].cpu_seconds < a.est[cheapest].cpu_seconds)
			cheapest = i;
	ok(a.choice == cheapest && cheapest == 1, "target 0.5: every method meets it, the cheapest (dsmc) chosen");

	s.accuracy_temperature = 0.001;
	advice_estimate(m, &s, 1, &a, err, sizeof err);
	ok(a.choice == 0 && strstr(a.reason, "no method is expected") && strstr(a.reason, "run.replicas >= 100"),
	   "target 0.001: none meets it; ed, with what would: %s", a.reason);

	/* Outside the measured densities an MC error is not trusted. */
	if (scene(&s, COOL, "auto", "\"accuracy\":{\"temperature\":0.5},", 2, 10000, 0.6, 0.0, 0.9, "\"time\":1", 4,
	          "\"time\":1") || estimate(m, &s, &a)) {
		ok(0, "dense auto scene");
		return;
	}
	ok((a.est[1].extrapolated & ADVICE_X_DENSITY) && a.est[1].meets == 0 && a.choice == 0,
	   "volume fraction 0.6: MC extrapolated (%s), ed chosen", a.est[1].notes);
	/* Beyond the measured Haff time: clustering, MC bias at least the clustering error. */
	if (scene(&s, COOL, "ed", "", 2, 10000, 0.1, 0.0, 0.9, "\"collisions_per_particle\":200", 4,
	          "\"collisions_per_particle\":20") || estimate(m, &s, &a)) {
		ok(0, "long cooling scene");
		return;
	}
	ok((a.est[2].extrapolated & ADVICE_X_CLUSTERING) && a.est[2].bias >= 0.2 && a.est[2].meets == -1,
	   "Haff time %.3g > 2: clustering flagged, hsmc bias %.3g >= the clustering error; no target for ed scenes",
	   a.haff_time, a.est[2].bias);
	/* The scene's own MC settings count, and flag the error as extrapolated. */
	if (scene(&s, "{\"method\":\"dsmc\",\"dimensions\":2,\"particles\":{\"count\":1000,\"volume_fraction\":0.1},"
	              "\"collisions\":{\"restitution\":0.9},\"run\":{\"until\":{\"time\":1}},"
	              "\"dsmc\":{\"correction\":\"enskog\",\"collisions_per_step\":0.1}}") || estimate(m, &s, &a)) {
		ok(0, "dsmc scene with settings");
		return;
	}
	ok(!strcmp(a.est[1].variant, "dsmc/enskog") && a.est[1].collisions_per_step == 0.1 &&
	   (a.est[1].extrapolated & ADVICE_X_VARIANT) && !strcmp(a.est[2].variant, "hsmc/cba") && !a.est[2].extrapolated,
	   "dsmc with correction enskog: its settings assumed (%s); hsmc at its defaults", a.est[1].notes);
}

static void determinism(const advice_model_t *m)
{
	scene_t s;
	advice_t a, b;
	if (scene(&s, COOL, "auto", "\"accuracy\":{\"temperature\":0.05},", 3, 5000, 0.2, 10.0, 0.7, "\"time\":3", 2,
	          "\"time\":0.3") || estimate(m, &s, &a) || estimate(m, &s, &b)) {
		ok(0, "determinism scene");
		return;
	}
	json_t *ja = advice_json(&a), *jb = advice_json(&b);
	char *ta = json_dumps(ja, JSON_COMPACT), *tb = json_dumps(jb, JSON_COMPACT);
	ok(ta && tb && !strcmp(ta, tb), "same scene, same advice (%zu bytes of JSON)", ta ? strlen(ta) : 0);
	ok(json_array_size(json_object_get(ja, "estimates")) == 3 && json_is_string(json_object_get(ja, "choice")) &&
	   json_is_object(json_object_get(json_array_get(json_object_get(ja, "estimates"), 1), "settings")),
	   "advice JSON: three estimates with settings, a choice");
	free(ta);
	free(tb);
	json_decref(ja);
	json_decref(jb);
}

int main(void)
{
	plan(38);
	advice_model_t *m = model();
	ok(m != NULL, "synthetic model parses");
	model_errors();
	if (m) {
		haff(m);
		scaling(m);
		choice(m);
		determinism(m);
	}
	advice_model_destroy(m);
	return done_testing();
}
