/* Tests of driving (thermostats) in the event-driven engine: seed 001's thermostat balance (preset), white-noise heating and balance, determinism, checkpoints, scene errors. */
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <jansson.h>

#include "ed/ed.h"
#include "scene.h"
#include "preset_file.h"
#include "tap.h"
#include "ed_util.h"

/* Time-averaged temperature and collision rate per particle over [t0, t1]
 * (exact integrals of E_kin dt and collision counts). */
static void average(ed_t *ed, const scene_t *sc, double t0, double t1, double *temp, double *rate)
{
	ed_sample_t sm;
	ed_advance(ed, t0, UINT64_MAX, UINT64_MAX);
	ed_sample(ed, &sm);
	ed_advance(ed, t1, UINT64_MAX, UINT64_MAX);
	ed_sample(ed, &sm);
	*temp = 2.0 * sm.ekin_time_integral / (sc->dim * (double)sc->count * sm.interval);
	*rate = 2.0 * (double)sm.interval_collisions / ((double)sc->count * sm.interval);
}

/*
 * Thermostat balance (seed 001 anchor 8; the preset thermostat-balance-2d).
 * A kick replaces a particle's velocity by the local mean plus a
 * Maxwellian at T_th, once per interval tau_th per particle: it brings
 * D (T_th - T)/2 per kick. A collision loses (1 - r^2) T on average
 * (collision-weighted <g_n^2> = 4T/m for Maxwellian velocities), and a
 * particle collides 1/tau_mft times per unit time, two particles per
 * collision. Balance: (T_th - T)/tau_th = (1 - r^2) T / (2 tau_mft) in
 * 2D, i.e. T_th = T [1 + (1 - r^2) tau_th / (2 tau_mft)], linear in tau_th.
 * With the thesis's tau_mft = 0.43 at T = 0.02 (eta = 0.65): T_th = 0.0248
 * (r = 0.97) and 0.0397 (r = 0.87) hold the gas at T = 0.02.
 * Checks: with those two T_th the measured T is 0.02 within 3% (the
 * issue's anchor; the thesis's tau_mft = 0.43 against the one measured
 * here, Enskog 0.41, is a 1-2% effect). Linear in tau_th: at r = 0.87 with
 * tau_th = 1.74, 3.48, 6.96 the balance T_th = T [1 + (1 - r^2) tau_th nu /
 * 2] holds with the measured T and collision rate nu = 1/tau_mft within 2%
 * (Maxwellian <g_n^2> is the approximation; a2 of a thermostatted gas is
 * small). Statistics: 4000 disks, T fluctuates ~1.6% per sample with a
 * correlation time ~tau_th; averaged over 250 time units (~70 correlation
 * times): ~0.2%.
 */
static void test_balance(void)
{
	char path[4096];
	preset_path("thermostat-balance-2d.json", path, sizeof path);
	json_error_t jerr;
	json_t *base = json_load_file(path, 0, &jerr);
	if (!base) {
		ok(0, "thermostat balance: preset %s (%s)", path, jerr.text);
		return;
	}
	static const struct { double r, tau; } cases[] = { {0.97, 3.48}, {0.87, 3.48}, {0.87, 1.74}, {0.87, 6.96} };
	for (size_t k = 0; k < sizeof cases / sizeof cases[0]; k++) {
		const double r = cases[k].r, tau = cases[k].tau, T = 0.02;
		const double tth = T * (1.0 + (1.0 - r * r) * tau / (2.0 * 0.43));
		json_t *j = json_deep_copy(base);
		json_object_set_new(json_object_get(j, "collisions"), "restitution", json_real(r));
		json_t *drv = json_object_get(j, "driving");
		json_object_set_new(drv, "temperature", json_real(tth));
		json_object_set_new(drv, "interval", json_real(tau));
		char *text = json_dumps(j, JSON_COMPACT);
		scene_t sc;
		ed_t *ed = make(text, &sc);
		free(text);
		json_decref(j);
		if (!ed) {
			ok(0, "thermostat balance r = %g, tau_th = %g: setup", r, tau);
			continue;
		}
		double temp, rate;
		average(ed, &sc, 50.0, 300.0, &temp, &rate);
		if (tau == 3.48)
			ok(fabs(temp / T - 1.0) < 0.03, "thermostat balance r = %g, tau_th = %g: T_th = %.4f holds T = %.5f (target "
			   "0.02, %+.1f%%; tolerance 3%%); mean free time %.3f (thesis 0.43)", r, tau, tth, temp,
			   100.0 * (temp / T - 1.0), 1.0 / rate);
		if (r == 0.87) {
			const double pred = temp * (1.0 + (1.0 - r * r) * tau * rate / 2.0);
			ok(fabs(pred / tth - 1.0) < 0.02, "thermostat balance r = %g, tau_th = %g: T_th = %.5f, balance with the "
			   "measured T and nu gives %.5f (%+.1f%%; tolerance 2%%)", r, tau, tth, pred, 100.0 * (pred / tth - 1.0));
		}
		ed_destroy(ed);
	}
	json_decref(base);
}

/*
 * White-noise thermostat: each kick adds a Gaussian step of variance
 * xi^2 tau per component, N/tau kicks per unit time, so <E_kin> grows by
 * N D m xi^2 / 2 per unit time: dT/dt = m xi^2 exactly in expectation (the
 * drift of the total momentum included, T = 2 E_kin/(D N)). Elastic gas:
 * T(t) = T0 + m xi^2 t. Inelastic: balance of the input with the
 * collisional loss (1 - r^2) T per collision, nu/2 collisions per particle
 * per unit time: D m xi^2 = (1 - r^2) T nu with the measured nu.
 * Statistics (4000 disks): the heating's random part is ~1% of the gain
 * at t = 100; the balance's T averaged over ~100 relaxation times: 0.3%;
 * Maxwellian <g_n^2> holds to the Sonine a2 of a driven gas (|a2| < 0.02,
 * van Noije & Ernst 1998: < 0.5% here). Tolerances 4% and 3%.
 */
static void test_white_noise(void)
{
	const char *heat = "{\"method\":\"ed\",\"dimensions\":2,\"particles\":{\"count\":4000,\"volume_fraction\":0.1,"
	                   "\"initial\":{\"positions\":\"random\",\"temperature\":1}},"
	                   "\"driving\":{\"type\":\"white_noise\",\"strength\":0.01,\"interval\":0.5},"
	                   "\"run\":{\"seed\":5,\"until\":{\"time\":1}}}";
	scene_t sc;
	ed_t *ed = make(heat, &sc);
	if (ed) {
		ed_sample_t sm;
		ed_advance(ed, 100.0, UINT64_MAX, UINT64_MAX);
		ed_sample(ed, &sm);
		double T = sm.kinetic_energy / (double)sc.count, th = 1.0 + 0.01 * 100.0;
		ok(fabs(T / th - 1.0) < 0.04, "white noise, elastic: T(100) = %.4f, theory T0 + m xi^2 t = %.4f (%+.1f%%; "
		   "tolerance 4%%)", T, th, 100.0 * (T / th - 1.0));
		ed_destroy(ed);
	} else {
		ok(0, "white noise heating: setup");
	}
	const char *bal = "{\"method\":\"ed\",\"dimensions\":2,\"particles\":{\"count\":4000,\"volume_fraction\":0.1,"
	                  "\"initial\":{\"positions\":\"random\",\"temperature\":1}},\"collisions\":{\"restitution\":0.95},"
	                  "\"driving\":{\"type\":\"white_noise\",\"strength\":0.05,\"interval\":0.2},"
	                  "\"run\":{\"seed\":6,\"until\":{\"time\":1}}}";
	ed = make(bal, &sc);
	if (ed) {
		double temp, rate;
		average(ed, &sc, 50.0, 400.0, &temp, &rate);
		const double lhs = 2.0 * 0.05, rhs = (1.0 - 0.95 * 0.95) * temp * rate;
		ok(fabs(rhs / lhs - 1.0) < 0.03, "white noise, r = 0.95: balance D m xi^2 = %.4f, (1 - r^2) T nu = %.4f "
		   "(T = %.4f, nu = %.4f; %+.1f%%; tolerance 3%%)", lhs, rhs, temp, rate, 100.0 * (rhs / lhs - 1.0));
		ed_destroy(ed);
	} else {
		ok(0, "white noise balance: setup");
	}
}

/* Kicks are outside the event calendar but at times fixed by the state:
 * a run stopped every 0.37 time units ends bit for bit where a run
 * straight through ends; and a checkpoint restored into a blank engine
 * continues bit for bit (stochastic thermostat with a grid; white noise
 * with walls and rough particles). */
static void test_exact(void)
{
	static const char *const scenes[] = {
		"{\"method\":\"ed\",\"dimensions\":2,\"particles\":{\"count\":1000,\"volume_fraction\":0.65,"
		"\"initial\":{\"temperature\":0.02}},\"collisions\":{\"restitution\":0.87},"
		"\"driving\":{\"type\":\"stochastic\",\"temperature\":0.0397,\"interval\":3.48,\"grid\":6,\"average_time\":5},"
		"\"run\":{\"seed\":2,\"until\":{\"time\":1}}}",
		"{\"method\":\"ed\",\"dimensions\":3,\"particles\":{\"count\":500,\"volume_fraction\":0.1,"
		"\"initial\":{\"positions\":\"random\",\"temperature\":1}},\"collisions\":{\"restitution\":0.9,"
		"\"rough\":{\"tangential_restitution\":0.3}},\"boundaries\":{\"z\":{\"type\":\"walls\",\"lower\":{\"type\":\"specular\"},"
		"\"upper\":{\"type\":\"specular\"}}},\"driving\":{\"type\":\"white_noise\",\"strength\":0.1,\"interval\":1},"
		"\"run\":{\"seed\":3,\"until\":{\"time\":1}}}",
	};
	for (int k = 0; k < 2; k++) {
		scene_t sc;
		ed_t *a = make(scenes[k], &sc), *b = make(scenes[k], &sc), *c = NULL;
		if (!a || !b) {
			ok(0, "driving exact %d: setup", k);
			ok(0, "driving exact %d: checkpoint", k);
			ed_destroy(a);
			ed_destroy(b);
			continue;
		}
		ed_advance(a, 20.0, UINT64_MAX, UINT64_MAX);
		for (double t = 0.37; t < 20.0; t += 0.37)
			ed_advance(b, t, UINT64_MAX, UINT64_MAX);
		ed_advance(b, 20.0, UINT64_MAX, UINT64_MAX);
		const size_t m = sc.count * sc.dim;
		double *p = malloc(sizeof(double) * 4 * m);
		ed_state(a, p, p + m);
		ed_state(b, p + 2 * m, p + 3 * m);
		ok(ed_events(a) == ed_events(b) && !memcmp(p, p + 2 * m, 2 * m * sizeof(double)),
		   "driving (%s): stopping every 0.37 changes nothing, bit for bit after %llu events",
		   k ? "white noise, walls, rough" : "stochastic, grid 6x6", (unsigned long long)ed_events(a));
		/* checkpoint of a into c */
		int good, has;
		char msg[256] = "";
		c = clone_fields(a, &sc, "drive_rng", 0, &has, msg, sizeof msg);
		good = c != NULL && has;
		if (good) {
			ed_advance(a, 45.0, UINT64_MAX, UINT64_MAX);
			ed_advance(c, 45.0, UINT64_MAX, UINT64_MAX);
			ed_state(a, p, p + m);
			ed_state(c, p + 2 * m, p + 3 * m);
			good = ed_events(a) == ed_events(c) && !memcmp(p, p + 2 * m, 2 * m * sizeof(double));
		}
		ok(good, "driving (%s): checkpoint restored, identical bit for bit after %llu events%s%s", k ? "white noise" : "stochastic",
		   (unsigned long long)ed_events(a), msg[0] ? ": " : "", msg);
		free(p);
		ed_destroy(a);
		ed_destroy(b);
		ed_destroy(c);
	}
}

static void test_scene_errors(void)
{
	static const struct { const char *frag, *key; } cases[] = {
		{ "\"driving\":{\"type\":\"stochastic\",\"interval\":1}", "driving.temperature: required" },
		{ "\"driving\":{\"type\":\"stochastic\",\"interval\":1,\"temperature\":1,\"strength\":1}", "driving.strength: not a key" },
		{ "\"driving\":{\"type\":\"white_noise\",\"strength\":1}", "driving.interval: required" },
		{ "\"driving\":{\"type\":\"white_noise\",\"interval\":1,\"strength\":1,\"grid\":4}", "driving.grid: not a key" },
		{ "\"driving\":{\"type\":\"heat\",\"interval\":1}", "driving.type: must be one of" },
		{ "\"driving\":{\"type\":\"white_noise\",\"interval\":0,\"strength\":1}", "driving.interval: must be" },
	};
	const char *base = "{\"method\":\"ed\",\"dimensions\":2,\"particles\":{\"count\":100,\"volume_fraction\":0.1},"
	                   "\"run\":{\"until\":{\"time\":1}},%s}";
	int bad = 0;
	for (size_t k = 0; k < sizeof cases / sizeof cases[0]; k++) {
		char json[1024], err[512] = "";
		scene_t sc;
		snprintf(json, sizeof json, base, cases[k].frag);
		if (scene_parse(json, strlen(json), &sc, err, sizeof err) != SCENE_EINVAL ||
		    strncmp(err, cases[k].key, strlen(cases[k].key))) {
			diag("case %zu: got \"%s\"", k, err);
			bad++;
		}
	}
	char err[512] = "";
	scene_t sc;
	const char *j = "{\"method\":\"dsmc\",\"dimensions\":2,\"particles\":{\"count\":100,\"volume_fraction\":0.1},"
	                "\"driving\":{\"type\":\"white_noise\",\"interval\":1,\"strength\":1},\"run\":{\"until\":{\"time\":1}}}";
	if (scene_parse(j, strlen(j), &sc, err, sizeof err) != SCENE_EINVAL || strncmp(err, "driving: method", 15)) {
		diag("dsmc driving: got \"%s\"", err);
		bad++;
	}
	ok(bad == 0, "scene: driving keys checked per type, errors name the key");
}

int main(void)
{
	plan(12);
	test_scene_errors();
	test_exact();
	test_white_noise();
	test_balance();
	return done_testing();
}
