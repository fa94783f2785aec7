/* Built-in scenes: the embedded presets/ *.json texts, described and validated with the engine's scene parser. */
#include <config.h>
#include <stdio.h>
#include <string.h>
#include "presets.h"
#include "daemon/presets_json.h"   /* generated: presets_embedded[] = {{name, json}, ...} */
#include "scene.h"

/* One line per preset for humans; a preset without a row here is described as "". */
static const struct { const char *name, *description; } descriptions[] = {
	{.name = "cooling-2d", .description = "Homogeneous cooling of 10,000 disks (phi=0.2, e=0.9): Haff's law, "
	                                      "200 collisions per particle"},
	{.name = "clustering-2d", .description = "Clustering instability of 40,000 disks (phi=0.25, e=0.6): "
	                                         "Haff's law breaks down as clusters form, 400 collisions per particle"},
	{.name = "cooling-3d", .description = "Homogeneous cooling of 8,000 spheres (phi=0.2, e=0.9): Haff's law, "
	                                      "100 collisions per particle"},
	{.name = "clustering-3d", .description = "Clustering instability of 27,000 spheres (phi=0.2, e=0.6): "
	                                         "a system-spanning cluster, 200 collisions per particle"},
	{.name = "dilute-3d-auto", .description = "Dilute cooling of 100,000 spheres (phi=0.05, e=0.9) with method auto: "
	                                          "the cheapest method expected to keep T(t) within 2% of exact dynamics"},
	{.name = "bagnold-shear-2d", .description = "Couette shear of 400 disks (phi=0.1, e=0.9) between walls moving at "
	                                            "-+0.5: steady temperature and wall shear force (Bagnold: F ~ v^2)"},
	{.name = "thermostat-balance-2d", .description = "4,000 disks at phi=0.65, e=0.97, held at T=0.02 by seed 001's "
	                                                 "stochastic thermostat (T_th=0.0248, interval 3.48): thermostat balance"},
	{.name = "gravity-box-2d", .description = "100 disks (d=0.001, e=0.9) falling in a 0.02 x 0.04 box under gravity "
	                                          "(seed 000 Figs 2.6/2.7) with hsmc: centre-of-mass height; switch method "
	                                          "to ed or dsmc (and drop the hsmc object) to compare: dsmc piles onto the floor"},
	{.name = "vibrated-bed-2d", .description = "56 disks (d=0.001, e=0.9) in a 0.01-wide column on a floor vibrating "
	                                           "at 100 Hz with V = 2 pi f A = 1 m/s (seed 000 A11) with hsmc: "
	                                           "centre-of-mass height H(V); bench/vibrated_bed.sh sweeps V for ed, dsmc, hsmc"},
	{.name = "binary-mixture-2d", .description = "Homogeneous cooling of a binary mixture, 1,000 + 1,000 disks of masses "
	                                             "1 and 4 (phi=0.02, e=0.9): no equipartition, T_light/T_heavy settles "
	                                             "near 0.865 (Maxwellian theory; temperature_species)"},
	{.name = "pipe-flow-2d", .description = "Vertical 2D pipe, periodic along gravity, rough walls (p=0.1), "
	                                        "1935 disks at nu=0.38, r=0, hsmc (seed 000 A8/A9): density waves, the "
	                                        "density_spectrum slope alpha and the flux; bench/pipe.sh sweeps r and nu"},
	{.name = "obstacle-stream-2d", .description = "2D stream past a slip obstacle of diameter 74 (seed 001): "
	                                              "reservoir walls at both ends of x (eta=0.04, kT=0.02, U=0.05), y "
	                                              "periodic, 440 x 440 diameters, two flow-through times: drag "
	                                              "(obstacle_force), inflow and outflow"},
	{.name = "dense-stream-2d", .description = "Dense 2D stream (seed 001 anchor 4): eta=0.65, kT=0.02, U=0.1 in a "
	                                           "120 x 40 channel fed by a dispenser (piston and template layers) and "
	                                           "drained through a filter (frozen particles, turn-back), y periodic, "
	                                           "three flow-through times: density and temperature hold along the "
	                                           "channel (fields)"},
	{.name = "dense-front-2d", .description = "Inelastic dense stream (r=0.97, TC) against a no-slip obstacle of "
	                                          "diameter 30 (seed 001 anchor 11, scaled down): eta=0.65, kT=0.02, "
	                                          "U=0.1 from a dispenser, filter outlet, 200 x 100: a dense front builds "
	                                          "up before the obstacle (bench/front_bench)"},
	{.name = "heap-2d", .description = "Heap (seed 000 A10, scaled down): 2000 disks poured one per time unit, "
	                                   "4 diameters above the top, onto a 200-wide frictional table, r=0.9, hsmc (entry linear, "
	                                   "rejected_moves collide): a straight symmetric slope of 0.27; "
	                                   "surface_profile h(x) (tests/heap_test.sh, docs/engine.md)"},
};

static const size_t npresets = sizeof(presets_embedded) / sizeof(presets_embedded[0]);

size_t presets_count(void) { return npresets; }

const char *presets_name(size_t i) { return i < npresets ? presets_embedded[i].name : NULL; }

const char *presets_text(const char *name)
{
	for (size_t i = 0; name && i < npresets; i++)
		if (!strcmp(presets_embedded[i].name, name))
			return presets_embedded[i].json;
	return NULL;
}

static const char *describe(const char *name)
{
	for (size_t i = 0; i < sizeof(descriptions) / sizeof(descriptions[0]); i++)
		if (!strcmp(descriptions[i].name, name))
			return descriptions[i].description;
	return "";
}

int presets_get(const char *name, json_t **out, char *err, size_t errlen)
{
	int rc = PRESETS_OK;
	json_t *scene = NULL;
	scene_t s;
	char perr[256];
	const char *text = presets_text(name);
	*out = NULL;
	if (!text) {
		snprintf(err, errlen, "preset '%.100s' not found (GET /api/v1/presets lists them)", name ? name : "");
		rc = PRESETS_ENOTFOUND;
		goto cleanup;
	}
	if (scene_parse(text, strlen(text), &s, perr, sizeof(perr)) != SCENE_OK ||
	    !(scene = json_loads(text, 0, NULL))) {
		snprintf(err, errlen, "preset '%s' is not a valid scene: %s", name, perr);
		rc = PRESETS_EINVAL;
		goto cleanup;
	}
	*out = json_pack("{s:s, s:s, s:i, s:s, s:I, s:O}", "name", name, "description", describe(name), "dimensions",
	                 s.dim, "method", scene_method_name(s.method), "particles", (json_int_t)s.count, "scene", scene);
	if (!*out) {
		snprintf(err, errlen, "out of memory");
		rc = PRESETS_ENOMEM;
	}
cleanup:
	json_decref(scene);
	return rc;
}

int presets_list(json_t **out, char *err, size_t errlen)
{
	int rc = PRESETS_OK;
	json_t *arr = json_array(), *p = NULL;
	*out = NULL;
	if (!arr) {
		rc = PRESETS_ENOMEM;
		snprintf(err, errlen, "out of memory");
		goto cleanup;
	}
	for (size_t i = 0; i < npresets; i++) {
		if ((rc = presets_get(presets_embedded[i].name, &p, err, errlen)) != PRESETS_OK)
			goto cleanup;
		json_array_append_new(arr, p);
	}
	*out = json_pack("{s:O}", "presets", arr);
	if (!*out) {
		rc = PRESETS_ENOMEM;
		snprintf(err, errlen, "out of memory");
	}
cleanup:
	json_decref(arr);
	return rc;
}

const char *presets_strerror(int code)
{
	switch (code) {
	case PRESETS_OK: return "ok";
	case PRESETS_ENOTFOUND: return "no such preset";
	case PRESETS_EINVAL: return "embedded preset is not a valid scene";
	case PRESETS_ENOMEM: return "out of memory";
	default: return "unknown error";
	}
}
