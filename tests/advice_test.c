/* Tests of advice_: model parsing and its errors, the cost model's scaling, Haff's law, the choice for "auto", determinism. */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "advice.h"
#include "mc/dsmc.h"
#include "scene.h"
#include "tap.h"

/* A synthetic model with round constants, so expectations follow from the
 * formulas in advice.h rather than from a bench run. 2D grid nu {0.05, 0.4},
 * lambda {0.19, 0.75}, Haff time {0.1, 2}; 3D the same numbers. Curves
 * [tau 0.1, tau 2]: dsmc/none's bias grows with density only (0.1 -> 0.3),
 * hsmc/cba's with the Haff time only (0.02 -> 0.04), the rest are flat (md's bias 0.005). */
#define FLAT(v) "[[[" v "," v "],[" v "," v "]],[[" v "," v "],[" v "," v "]]]"
#define DIMMODEL(D) \
	"\"" #D "\": {\"volume_fraction\": [0.05, 0.4], \"lambda\": [0.19, 0.75], \"haff_time\": [0.1, 2], \"variants\": {" \
	"\"ed\": {\"bias\": " FLAT("0") ", \"spread\": " FLAT("1") "}," \
	"\"dsmc/none\": {\"bias\": [[[0.1,0.1],[0.1,0.1]],[[0.3,0.3],[0.3,0.3]]], \"spread\": " FLAT("1") "}," \
	"\"dsmc/enskog\": {\"bias\": " FLAT("0.01") ", \"spread\": " FLAT("1") "}," \
	"\"hsmc/cba\": {\"bias\": [[[0.02,0.04],[0.02,0.04]],[[0.02,0.04],[0.02,0.04]]], \"spread\": " FLAT("1") "}," \
	"\"md\": {\"bias\": " FLAT("0.005") ", \"spread\": " FLAT("1") "}}," \
	"\"clustering\": {\"dsmc/none\": 0.3, \"hsmc/cba\": 0.2}}"
#define COST(D) \
	"\"" #D "\": {\"per_move\": 1e-8, \"per_collision\": 1e-7}"
#define HCOST(D) \
	"\"" #D "\": {\"per_move\": 1.5e-8, \"per_collision\": 1e-7}"
static const char *const MODEL =
	"{\"format\": \"granulard-advice-model\", \"version\": 2, \"generated\": {\"date\": \"test\"},"
	" \"particles_measured\": 10000,"
	" \"cost\": {\"ed\": {\"2\": {\"per_collision\": 1e-6, \"per_collision_dilute\": 1e-7},"
	"                     \"3\": {\"per_collision\": 2e-6, \"per_collision_dilute\": 0}},"
	"          \"dsmc\": {" COST(2) ", " COST(3) "}, \"hsmc\": {" HCOST(2) ", " HCOST(3) "},"
	"          \"md\": {\"2\": {\"per_particle_step\": 3e-8, \"per_particle_step_density\": 1e-8},"
	"                  \"3\": {\"per_particle_step\": 4e-8, \"per_particle_step_density\": 2e-8}}},"
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

/* The estimate of a variant ("dsmc/enskog"), NULL when not a candidate. */
static const advice_estimate_t *est(const advice_t *a, const char *variant)
{
	for (int i = 0; i < a->n; i++)
		if (!strcmp(a->est[i].variant, variant))
			return &a->est[i];
	return NULL;
}

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
		{"{\"format\": \"granulard-advice-model\", \"version\": 1}", "version"},
		{"{\"format\": \"granulard-advice-model\", \"version\": 2}", "particles_measured"},
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
		{"\"haff_time\": [0.1, 2]", "\"haff_time\": []", "error.2.haff_time"},
		{"[[[0.02,0.04],[0.02,0.04]],[[0.02,0.04],[0.02,0.04]]]", "[[[0.02,0.04],[0.02,0.04]],[[0.02,0.04],[0.02]]]",
		 "error.2.variants.hsmc/cba.bias"},
		{"\"particles_measured\": 10000,", "\"particles_measured\": 10000, \"density_axis\": \"nu\",", "density_axis"},
		{"\"per_particle_step\": 3e-8", "\"per_particle_stp\": 3e-8", "cost.md.2.per_particle_step"},
		{"\"per_particle_step_density\": 2e-8", "\"per_particle_step_density\": -2e-8", "cost.md.3.per_particle_step_density"},
	};
	for (size_t i = 0; i < sizeof edits / sizeof edits[0]; i++) {
		char buf[8192];
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
	const advice_estimate_t *dn = est(&a, "dsmc/none"), *de = est(&a, "dsmc/enskog");
	ok(dn && fabs(dn->collisions / (3 * 1000 / 2.0 * c1) - 1) < 1e-9, "dsmc/none: Haff with chi = 1 (%.6g collisions)",
	   dn ? dn->collisions : 0);
	ok(de && fabs(de->collisions / a.est[0].collisions - 1) < 1e-9, "dsmc/enskog: Haff with chi = g(sigma), as ed");
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
	for (int i = 0; i < a1.n; i++) {
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

/* The expected error's form: growth with the Haff time the run reaches,
 * interpolation in the density coordinate chi(nu) - 1, lambda below the grid. */
static void growth(const advice_model_t *m)
{
	scene_t s;
	advice_t a[3];
	const double times[3] = {1, 2, 40};
	for (int i = 0; i < 3; i++) {
		char until[32];
		snprintf(until, sizeof until, "\"time\":%g", times[i]);
		if (scene(&s, COOL, "ed", "", 2, 10000, 0.1, 0.0, 0.9, until, 4, "\"time\":0.5") || estimate(m, &s, &a[i])) {
			ok(0, "growth scenes");
			return;
		}
	}
	const advice_estimate_t *h0 = est(&a[0], "hsmc/cba"), *h1 = est(&a[1], "hsmc/cba"), *h2 = est(&a[2], "hsmc/cba");
	/* Haff time is proportional to t: 1 and 2 lie below the first measured 0.1, 40 between 0.1 and 2. */
	if (!ok(a[1].haff_time < 0.1 && a[2].haff_time > 0.1 && a[2].haff_time < 2 &&
	        fabs(a[1].haff_time / a[0].haff_time - 2) < 1e-12, "Haff times %.3g, %.3g, %.3g", a[0].haff_time,
	        a[1].haff_time, a[2].haff_time))
		return;
	ok(fabs(h0->bias - 0.02 * a[0].haff_time / 0.1) < 1e-12 && fabs(h1->bias / h0->bias - 2) < 1e-9,
	   "below the first Haff time the bias grows linearly from 0 (%.4g, %.4g)", h0->bias, h1->bias);
	ok(h0->statistical == h1->statistical && fabs(h0->statistical - 1 / sqrt(4e4)) < 1e-12,
	   "... and the spread is the first measured one");
	ok(fabs(h2->bias - (0.02 + 0.02 * (a[2].haff_time - 0.1) / 1.9)) < 1e-12 && !(h2->extrapolated & ADVICE_X_CLUSTERING),
	   "between measured Haff times: linear (bias %.5g at tau %.3g), not extrapolated", h2->bias, a[2].haff_time);
	const advice_estimate_t *e2 = est(&a[2], "dsmc/enskog");
	ok(fabs(e2->bias - 0.01) < 1e-12, "a flat curve stays flat (dsmc/enskog %.4g)", e2->bias);

	/* Density: bilinear in chi(nu) - 1 (dsmc/none: 0.1 at nu = 0.05 to 0.3 at 0.4, flat otherwise). */
	const double c05 = dsmc_contact_value(2, 0.05), c2 = dsmc_contact_value(2, 0.2), c4 = dsmc_contact_value(2, 0.4);
	if (scene(&s, COOL, "ed", "", 2, 10000, 0.2, 0.0, 0.9, "\"time\":10", 4, "\"time\":1") || estimate(m, &s, &a[0])) {
		ok(0, "density scene");
		return;
	}
	double want = 0.1 + 0.2 * (c2 - c05) / (c4 - c05);
	ok(fabs(est(&a[0], "dsmc/none")->bias - want) < 1e-12, "nu = 0.2: dsmc/none bias %.5g = linear in chi - 1 (%.5g)",
	   est(&a[0], "dsmc/none")->bias, want);
	char buf[8192], err[256];
	const char *at = strstr(MODEL, "\"particles_measured\"");
	snprintf(buf, sizeof buf, "%.*s\"density_axis\": \"volume_fraction\", %s", (int)(at - MODEL), MODEL, at);
	advice_model_t *mv = advice_model_create(buf, strlen(buf), err, sizeof err);
	advice_t b;
	if (ok(mv && !estimate(mv, &s, &b), "density_axis volume_fraction accepted%s%s", mv ? "" : ": ", mv ? "" : err))
		ok(fabs(est(&b, "dsmc/none")->bias - (0.1 + 0.2 * 0.15 / 0.35)) < 1e-12,
		   "density_axis volume_fraction: bilinear in nu (%.5g)", est(&b, "dsmc/none")->bias);
	advice_model_destroy(mv);

	/* lambda below the grid: towards 0 at lambda = 0 (e = 0.95: lambda 0.0975 < 0.19). */
	if (scene(&s, COOL, "ed", "", 2, 10000, 0.1, 0.0, 0.95, "\"time\":40", 4, "\"time\":1") || estimate(m, &s, &a[0])) {
		ok(0, "weak dissipation scene");
		return;
	}
	const double lam = 1 - 0.95 * 0.95;
	e2 = est(&a[0], "dsmc/enskog");
	ok(a[0].haff_time > 0.1 && fabs(e2->bias - 0.01 * lam / 0.19) < 1e-12 && fabs(e2->statistical - lam / 0.19 / 200) < 1e-12,
	   "lambda %.4g below the grid: bias and spread scaled by lambda / 0.19", lam);
}

/* The built-in model: a longer run never has a smaller bias (the fit makes the curves non-decreasing). */
static void builtin_growth(void)
{
	size_t len;
	char err[256];
	const char *text = advice_model_builtin(&len);
	advice_model_t *b = advice_model_create(text, len, err, sizeof err);
	int mono = b != NULL, n = 0;
	for (int dim = 2; b && dim <= 3; dim++)
		for (double nu = 0.05; nu < 0.41; nu += 0.07)
			for (double e = 0.5; e < 0.95; e += 0.2) {
				advice_t prev, cur;
				for (int k = 0; k < 12; k++) {
					scene_t s;
					char until[48];
					snprintf(until, sizeof until, "\"collisions_per_particle\":%g", 0.5 + 3.0 * k);
					if (scene(&s, COOL, "ed", "", dim, 2000, nu, 0.0, e, until, 1, "\"time\":1") || estimate(b, &s, &cur)) {
						mono = 0;
						break;
					}
					for (int i = 1; k > 0 && i < cur.n; i++)
						if (cur.est[i].bias < prev.est[i].bias * (1 - 1e-12)) {
							mono = 0;
							diag("D=%d nu=%g e=%g %s: bias %g at tau %g < %g at tau %g", dim, nu, e, cur.est[i].variant,
							     cur.est[i].bias, cur.haff_time, prev.est[i].bias, prev.haff_time);
						}
					prev = cur;
					n++;
				}
			}
	ok(mono, "built-in model: every MC bias is non-decreasing in the run length (%d scenes)", n);
	advice_model_destroy(b);
}

/* auto picks the cheapest candidate that meets the target by the model's own measure. */
static void check_choice(const advice_t *a, const char *what)
{
	int best = -1, flags = 1;
	for (int i = 0; i < a->n; i++) {
		const advice_estimate_t *e = &a->est[i];
		int meets = e->error <= a->target && (e->method == SCENE_METHOD_ED || !(e->extrapolated & ADVICE_X_ERROR));
		flags &= e->meets == meets;
		if (meets && (best < 0 || e->cpu_seconds < a->est[best].cpu_seconds))
			best = i;
	}
	ok(flags && a->choice == (best < 0 ? 0 : best), "%s: target %g, choice %s = the cheapest that meets it: %s", what,
	   a->target, a->choice >= 0 ? a->est[a->choice].variant : "-", a->reason);
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
	/* Candidates: ed, the default dsmc/none and hsmc/cba, and the measured dsmc/enskog; no unmeasured hsmc/none. */
	ok(a.n == 4 && a.est[0].method == SCENE_METHOD_ED && !strcmp(a.est[1].variant, "dsmc/none") &&
	   !strcmp(a.est[2].variant, "dsmc/enskog") && !strcmp(a.est[3].variant, "hsmc/cba"),
	   "candidates: ed, dsmc/none, dsmc/enskog, hsmc/cba (%d)", a.n);
	/* Biases 0.1 / 0.01 / 0.02 with a statistical part ~0.005: dsmc/none misses 0.05, dsmc/enskog and hsmc/cba
	 * meet it; hsmc costs more per move in this model. */
	check_choice(&a, "cooling");
	ok(a.choice == 2 && est(&a, "dsmc/none")->meets == 0, "target 0.05: dsmc/enskog chosen over the default dsmc/none");
	scene_t r = s;
	advice_apply(&a, &r);
	ok(r.method == SCENE_METHOD_DSMC && r.mc_correction == SCENE_MC_ENSKOG, "advice_apply: dsmc, correction enskog");
	for (double t = 0.5; t > 5e-4; t /= 3.3) {
		s.accuracy_temperature = t;
		advice_estimate(m, &s, 1, &a, err, sizeof err);
		check_choice(&a, "cooling");
	}
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
	int all = 1;
	for (int i = 1; i < a.n; i++)
		all &= (a.est[i].extrapolated & ADVICE_X_DENSITY) && a.est[i].meets == 0;
	ok(all && a.choice == 0, "volume fraction 0.6: every MC candidate extrapolated (%s), ed chosen", a.est[1].notes);
	/* Beyond the measured Haff time: clustering, MC bias at least the clustering error. */
	if (scene(&s, COOL, "ed", "", 2, 10000, 0.1, 0.0, 0.9, "\"collisions_per_particle\":200", 4,
	          "\"collisions_per_particle\":20") || estimate(m, &s, &a)) {
		ok(0, "long cooling scene");
		return;
	}
	const advice_estimate_t *h = est(&a, "hsmc/cba");
	ok(h && (h->extrapolated & ADVICE_X_CLUSTERING) && h->bias >= 0.2 && h->meets == -1,
	   "Haff time %.3g > 2: clustering flagged, hsmc bias %.3g >= the clustering error; no target for ed scenes",
	   a.haff_time, h ? h->bias : 0);
	/* The scene's own MC settings count, and flag the error as extrapolated; dsmc/none stays a candidate at
	 * its defaults. */
	if (scene(&s, "{\"method\":\"dsmc\",\"dimensions\":2,\"particles\":{\"count\":1000,\"volume_fraction\":0.1},"
	              "\"collisions\":{\"restitution\":0.9},\"run\":{\"until\":{\"time\":1}},"
	              "\"dsmc\":{\"correction\":\"enskog\",\"collisions_per_step\":0.1}}") || estimate(m, &s, &a)) {
		ok(0, "dsmc scene with settings");
		return;
	}
	const advice_estimate_t *de = est(&a, "dsmc/enskog"), *dn = est(&a, "dsmc/none");
	h = est(&a, "hsmc/cba");
	ok(de && de->collisions_per_step == 0.1 && (de->extrapolated & ADVICE_X_SETTINGS) && dn &&
	   dn->collisions_per_step == 0.2 && !dn->extrapolated && h && !h->extrapolated,
	   "dsmc with correction enskog: its settings assumed (%s); dsmc/none, hsmc at their defaults", de ? de->notes : "");
	/* A concrete scene with an unmeasured variant: estimated (added), its error unknown. */
	if (scene(&s, "{\"method\":\"hsmc\",\"dimensions\":2,\"particles\":{\"count\":1000,\"volume_fraction\":0.1},"
	              "\"collisions\":{\"restitution\":0.9},\"run\":{\"until\":{\"time\":1}},"
	              "\"hsmc\":{\"correction\":\"enskog\"}}") || estimate(m, &s, &a)) {
		ok(0, "hsmc/enskog scene");
		return;
	}
	h = est(&a, "hsmc/enskog");
	ok(a.n == 5 && h && (h->extrapolated & ADVICE_X_VARIANT) && isnan(h->error),
	   "hsmc/enskog (not in the model) estimated for its own scene, error unknown");
}

/* The resolved scene carries the chosen settings, and estimates as the choice did. */
static void resolve(const advice_model_t *m)
{
	const char *txt = "{\"method\":\"auto\",\"accuracy\":{\"temperature\":0.05},\"dimensions\":2,"
	                  "\"particles\":{\"count\":10000,\"volume_fraction\":0.1},\"collisions\":{\"restitution\":0.9},"
	                  "\"run\":{\"until\":{\"time\":5},\"replicas\":4}}";
	scene_t s, r, p;
	advice_t a, b;
	char err[256];
	json_t *doc = json_loads(txt, 0, NULL);
	char *out = NULL;
	if (!doc || scene(&s, "%s", txt) || estimate(m, &s, &a) || a.choice < 1) {
		ok(0, "resolve scene (an MC choice)");
		json_decref(doc);
		return;
	}
	const advice_estimate_t *c = &a.est[a.choice];
	int rc = advice_apply_json(&a, doc);
	out = json_dumps(doc, JSON_COMPACT | JSON_PRESERVE_ORDER);
	char want[64];
	snprintf(want, sizeof want, "\"%s\":{\"correction\":\"%s\"}", scene_method_name(c->method), strchr(c->variant, '/') + 1);
	ok(rc == ADVICE_OK && out && strstr(out, want) && !strstr(out, "accuracy") && !strstr(out, "auto"),
	   "resolved scene carries %s: %s", want, out ? out : "");
	r = s;
	advice_apply(&a, &r);
	int parsed = out && scene_parse(out, strlen(out), &p, err, sizeof err) == SCENE_OK;
	ok(parsed && p.method == r.method && p.mc_correction == r.mc_correction && p.method == c->method,
	   "it parses to what advice_apply gives (%s)", parsed ? "" : err);
	const advice_estimate_t *o = parsed && !estimate(m, &p, &b) ? est(&b, c->variant) : NULL;
	ok(o && o->cpu_seconds == c->cpu_seconds && o->error == c->error && o->extrapolated == c->extrapolated,
	   "the concrete scene's own estimate equals the chosen one (%.4g s, error %.4g)", o ? o->cpu_seconds : 0,
	   o ? o->error : 0);
	json_t *j = advice_json(&a);
	json_t *res = json_object_get(j, "resolved");
	ok(res && !strcmp(json_string_value(json_object_get(res, "method")), scene_method_name(c->method)) &&
	   !strcmp(json_string_value(json_object_get(j, "choice_variant")), c->variant),
	   "advice JSON: choice_variant %s and the resolved settings", c->variant);
	json_decref(j);
	free(out);
	json_decref(doc);
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
	ok(json_array_size(json_object_get(ja, "estimates")) == (size_t)a.n && a.n >= 3 &&
	   json_is_string(json_object_get(ja, "choice")) &&
	   json_is_object(json_object_get(json_array_get(json_object_get(ja, "estimates"), 1), "settings")),
	   "advice JSON: %d estimates with settings, a choice", a.n);
	free(ta);
	free(tb);
	json_decref(ja);
	json_decref(jb);
}

/* Bounded scenes (issue 13): the same gas with walls (and gravity). The MC estimates are flagged
 * ADVICE_X_BOUNDED, so none meets a target and auto takes ed, saying why; dsmc is refused where gravity
 * pulls the gas onto a wall (a bed), with the reason; without gravity (walls alone) it is not refused. */
static void bounded(const advice_model_t *m)
{
	static const char *const walls = "{\"method\":\"auto\",\"accuracy\":{\"temperature\":0.05},\"dimensions\":2,"
		"\"particles\":{\"count\":10000,\"volume_fraction\":0.1},\"collisions\":{\"restitution\":0.9,\"tc\":1e-4},"
		"\"boundaries\":{\"y\":{\"type\":\"walls\",\"lower\":{\"type\":\"specular\"},\"upper\":{\"type\":\"specular\"}}},"
		"%s\"run\":{\"until\":{\"time\":5}}}";
	scene_t s, periodic;
	advice_t a, p;
	if (scene(&s, walls, "\"gravity\":[0,-1],") || estimate(m, &s, &a) ||
	    scene(&periodic, COOL, "auto", "\"accuracy\":{\"temperature\":0.05},", 2, 10000, 0.1, 0.0, 0.9, "\"time\":5", 1,
	          "\"time\":1") || estimate(m, &periodic, &p)) {
		ok(0, "bounded scenes");
		return;
	}
	const advice_estimate_t *dn = est(&a, "dsmc/none"), *de = est(&a, "dsmc/enskog"), *h = est(&a, "hsmc/cba");
	ok(a.choice == 0 && dn && de && h && dn->refused && de->refused && !h->refused && !a.est[0].refused &&
	   (h->extrapolated & ADVICE_X_BOUNDED) && !h->meets && !(a.est[0].extrapolated & ADVICE_X_BOUNDED) &&
	   strstr(a.reason, "dsmc/none: refused: gravity pulls the particles onto a wall") &&
	   strstr(a.reason, "hsmc/cba: error not trusted on a bounded scene"),
	   "a bed under gravity: ed chosen, dsmc refused, hsmc not trusted: %s", a.reason);
	/* in the periodic gas the same target is met by an MC variant (the choice test above) */
	ok(p.choice > 0 && !est(&p, "dsmc/none")->refused && !(est(&p, "hsmc/cba")->extrapolated & ADVICE_X_BOUNDED),
	   "the same gas in a periodic box: %s chosen, nothing refused", p.est[p.choice].variant);
	json_t *j = advice_json(&a);
	json_t *e1 = j ? json_array_get(json_object_get(j, "estimates"), 1) : NULL;
	ok(e1 && json_is_true(json_object_get(e1, "refused")) && json_is_false(json_object_get(json_array_get(
	   json_object_get(j, "estimates"), 0), "refused")), "advice_json: each estimate says whether it is refused");
	json_decref(j);
	if (scene(&s, walls, "") || estimate(m, &s, &a)) {
		ok(0, "walls without gravity");
		return;
	}
	ok(a.choice == 0 && !est(&a, "dsmc/none")->refused && (est(&a, "dsmc/none")->extrapolated & ADVICE_X_BOUNDED),
	   "walls without gravity: dsmc not refused but not trusted, ed chosen: %s", a.reason);
}

/* md (issue 18): a candidate of md scenes only; its step is the core's (checked against the linear law's
 * contact time at the default stiffness, computed here from the scene: docs/md.md), its work R N steps
 * particle-steps at (a + b nu) s each, its error the model's md variant; non-default md settings flagged. */
static void md_estimates(const advice_model_t *m)
{
	static const char *const MD = "{\"method\":\"%s\",\"dimensions\":2,\"particles\":{\"count\":1000,"
		"\"volume_fraction\":0.2},\"collisions\":{\"restitution\":0.9},%s\"run\":{\"until\":{\"time\":2},\"replicas\":2}}";
	scene_t s;
	advice_t a;
	if (scene(&s, MD, "md", "") || estimate(m, &s, &a)) {
		ok(0, "md scene estimated");
		return;
	}
	const advice_estimate_t *e = est(&a, "md");
	const double v = 4 * sqrt(s.temperature / s.mass), d = 0.02 * s.radius, kn = s.mass * v * v / (d * d);
	const double pi = 3.14159265358979323846, le = log(0.9), beta = -le / sqrt(pi * pi + le * le);
	const double dt = pi / sqrt(kn / (s.mass / 2) * (1 - beta * beta)) / 50, steps = ceil(2 / dt);
	ok(e && fabs(e->time_step / dt - 1) < 1e-12 && e->moves == 2 * 1000 * steps &&
	   fabs(e->cpu_seconds / (e->moves * (3e-8 + 1e-8 * 0.2)) - 1) < 1e-12,
	   "md: step %.6g (contact time / 50: %.6g), %.6g particle-steps, %.6g CPU s", e ? e->time_step : NAN, dt,
	   e ? e->moves : NAN, e ? e->cpu_seconds : NAN);
	ok(e && fabs(e->bias - 0.005) < 1e-15 && fabs(e->statistical - 1 / sqrt(2000.0)) < 1e-15 &&
	   !(e->extrapolated & ADVICE_X_SETTINGS) && a.est[0].method == SCENE_METHOD_ED,
	   "md: bias %.3g from the md variant, statistical %.4g, default settings not flagged, ed listed first",
	   e ? e->bias : NAN, e ? e->statistical : NAN);
	if (!scene(&s, MD, "md", "\"md\":{\"friction\":0.5},") && !estimate(m, &s, &a)) {
		e = est(&a, "md");
		ok(e && (e->extrapolated & ADVICE_X_SETTINGS) && strstr(e->notes, "default stiffness"),
		   "md with friction: error flagged as measured at other settings (%s)", e ? e->notes : "none");
	} else
		ok(0, "md scene with friction estimated");
	if (!scene(&s, MD, "ed", "") && !estimate(m, &s, &a))
		ok(!est(&a, "md"), "no md estimate for an ed scene (%d estimates)", a.n);
	else
		ok(0, "ed scene estimated");
	/* a model without md costs (before bench/tradeoff.py --md): cost unknown, said so */
	char buf[8192], err[256];
	const char *at = strstr(MODEL, ",          \"md\": {"), *end = at ? strstr(at, "}}},") : NULL;
	snprintf(buf, sizeof buf, "%.*s%s", at ? (int)(at - MODEL) : 0, MODEL, end ? end + 2 : "");
	advice_model_t *m2 = advice_model_create(buf, strlen(buf), err, sizeof err);
	if (m2 && !scene(&s, MD, "md", "") && !estimate(m2, &s, &a)) {
		e = est(&a, "md");
		ok(e && isnan(e->cpu_seconds) && strstr(e->notes, "no md cost"), "model without md costs: cost NaN (%s)",
		   e ? e->notes : "none");
	} else
		ok(0, "model without md costs parses: %s", m2 ? "" : err);
	advice_model_destroy(m2);
}

int main(void)
{
	advice_model_t *m = model();
	ok(m != NULL, "synthetic model parses");
	model_errors();
	if (m) {
		haff(m);
		scaling(m);
		growth(m);
		builtin_growth();
		choice(m);
		resolve(m);
		determinism(m);
		bounded(m);
		md_estimates(m);
	}
	advice_model_destroy(m);
	plan(tap_n);
	return done_testing();
}
