/* Unit tests for scene_parse(): defaults, derived fields, and the one-line error for each kind of bad input. */
#include <dirent.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "run.h"
#include "scene.h"
#include "tap.h"

#define PI 3.14159265358979323846

/* Scenes are written with single quotes for legibility; none needs a real one. */
static int parse(const char *text, scene_t *s, char *err, size_t errlen)
{
	char buf[4096];
	size_t n = strlen(text);
	if (n >= sizeof buf)
		return -100;
	for (size_t i = 0; i <= n; i++)
		buf[i] = text[i] == '\'' ? '"' : text[i];
	return scene_parse(buf, n, s, err, errlen);
}

static int near(double a, double b) { return fabs(a - b) <= 1e-12 * fmax(1, fabs(b)); }

/* Message starts with "path: " and is one line. */
static int has_path(const char *err, const char *path)
{
	size_t n = strlen(path);
	return strncmp(err, path, n) == 0 && strncmp(err + n, ": ", 2) == 0 && strchr(err, '\n') == NULL;
}

#define HEAD "'method':'ed','dimensions':2"
#define PART "'particles':{'count':100,'volume_fraction':0.3}"
#define RUN "'run':{'until':{'collisions_per_particle':5}}"
#define BASE HEAD "," PART "," RUN
#define PART_WITH(x) "'particles':{'count':100,'volume_fraction':0.3," x "}"
#define RUN_WITH(x) "'run':{'until':{'collisions_per_particle':5}," x "}"

static const struct bad {
	const char *name;
	const char *json;
	int code;
	const char *path;   /* the message must start with "path: " */
	const char *msg;    /* if set, the whole message */
} bad[] = {
	{ "not JSON", "{'method': 'ed',", SCENE_EJSON, "(root)", NULL },
	{ "empty text", "", SCENE_EJSON, "(root)", NULL },
	{ "top-level array", "[{" BASE "}]", SCENE_EJSON, "(root)", "(root): must be a JSON object, got array" },
	{ "top-level number", "3", SCENE_EJSON, "(root)", NULL },
	{ "duplicate key", "{'method':'ed'," BASE "}", SCENE_EJSON, "(root)", NULL },
	{ "unknown key, root", "{" BASE ",'colour':'red'}", SCENE_EINVAL, "colour", NULL },
	{ "unknown key, particles", "{" HEAD "," PART_WITH("'colour':'red'") "," RUN "}", SCENE_EINVAL,
	  "particles.colour", NULL },
	{ "unknown key, relax", "{" HEAD "," PART_WITH("'initial':{'relax':{'collisions_per_particle':1,'steps':3}}")
	  "," RUN "}", SCENE_EINVAL, "particles.initial.relax.steps", NULL },
	{ "unknown key, until", "{" HEAD "," PART ",'run':{'until':{'steps':10}}}", SCENE_EINVAL, "run.until.steps", NULL },
	{ "unknown key, ed", "{" BASE ",'ed':{'cells':3}}", SCENE_EINVAL, "ed.cells", NULL },
	{ "radius wrong type", "{" HEAD "," PART_WITH("'radius':'big'") "," RUN "}", SCENE_EINVAL, "particles.radius",
	  "particles.radius: must be a number, got string" },
	{ "radius 0", "{" HEAD "," PART_WITH("'radius':0") "," RUN "}", SCENE_EINVAL, "particles.radius",
	  "particles.radius: must be a number > 0, got 0" },
	{ "mass negative", "{" HEAD "," PART_WITH("'mass':-1") "," RUN "}", SCENE_EINVAL, "particles.mass", NULL },
	{ "restitution 1.5", "{" BASE ",'collisions':{'restitution':1.5}}", SCENE_EINVAL, "collisions.restitution",
	  "collisions.restitution: must be between 0 and 1, got 1.5" },
	{ "restitution -0.1", "{" BASE ",'collisions':{'restitution':-0.1}}", SCENE_EINVAL, "collisions.restitution", NULL },
	{ "restitution 0 without tc", "{" BASE ",'collisions':{'restitution':0}}", SCENE_EINVAL,
	  "collisions.restitution", NULL },
	{ "tc negative", "{" BASE ",'collisions':{'tc':-1}}", SCENE_EINVAL, "collisions.tc", NULL },
	{ "collisions not object", "{" BASE ",'collisions':null}", SCENE_EINVAL, "collisions",
	  "collisions: must be an object, got null" },
	{ "count 0", "{" HEAD ",'particles':{'count':0,'volume_fraction':0.3}," RUN "}", SCENE_EINVAL, "particles.count",
	  "particles.count: must be an integer >= 2, got 0" },
	{ "count 1", "{" HEAD ",'particles':{'count':1,'volume_fraction':0.3}," RUN "}", SCENE_EINVAL, "particles.count", NULL },
	{ "count 2.5", "{" HEAD ",'particles':{'count':2.5,'volume_fraction':0.3}," RUN "}", SCENE_EINVAL,
	  "particles.count", "particles.count: must be an integer >= 2, got 2.5" },
	{ "count 1000.0", "{" HEAD ",'particles':{'count':1000.0,'volume_fraction':0.3}," RUN "}", SCENE_EINVAL,
	  "particles.count", NULL },
	{ "count '10'", "{" HEAD ",'particles':{'count':'10','volume_fraction':0.3}," RUN "}", SCENE_EINVAL,
	  "particles.count", "particles.count: must be an integer, got string" },
	{ "count 2^31", "{" HEAD ",'particles':{'count':2147483648,'volume_fraction':0.3}," RUN "}", SCENE_EINVAL,
	  "particles.count", NULL },
	{ "count missing", "{" HEAD ",'particles':{'volume_fraction':0.3}," RUN "}", SCENE_EINVAL, "particles.count",
	  "particles.count: required key missing" },
	{ "volume fraction 0.95 in 2D", "{" HEAD ",'particles':{'count':100,'volume_fraction':0.95}," RUN "}",
	  SCENE_EINVAL, "particles.volume_fraction",
	  "particles.volume_fraction: 0.95 is above the close-packing limit 0.9069 of 2D disks" },
	{ "volume fraction 0.75 in 3D", "{'method':'ed','dimensions':3,'particles':{'count':100,'volume_fraction':0.75},"
	  RUN "}", SCENE_EINVAL, "particles.volume_fraction", NULL },
	{ "volume fraction 0", "{" HEAD ",'particles':{'count':100,'volume_fraction':0}," RUN "}", SCENE_EINVAL,
	  "particles.volume_fraction", NULL },
	{ "box beyond close packing", "{" HEAD ",'particles':{'count':100,'box':[8,8]}," RUN "}", SCENE_EINVAL,
	  "particles.box", NULL },
	{ "box edge below 2 diameters", "{" HEAD ",'particles':{'count':2,'box':[1.5,10]}," RUN "}", SCENE_EINVAL,
	  "particles.box[0]", NULL },
	{ "box edge exactly 2 diameters", "{" HEAD ",'particles':{'count':2,'box':[10,2]}," RUN "}", SCENE_EINVAL,
	  "particles.box[1]", NULL },
	{ "derived edge below 2 diameters", "{" HEAD ",'particles':{'count':2,'volume_fraction':0.5}," RUN "}",
	  SCENE_EINVAL, "particles.volume_fraction", NULL },
	{ "box and volume fraction", "{" HEAD "," PART_WITH("'box':[20,20]") "," RUN "}", SCENE_EINVAL, "particles",
	  "particles: exactly one of volume_fraction or box is required" },
	{ "neither box nor volume fraction", "{" HEAD ",'particles':{'count':100}," RUN "}", SCENE_EINVAL, "particles", NULL },
	{ "box of 2 in 3D", "{'method':'ed','dimensions':3,'particles':{'count':100,'box':[20,20]}," RUN "}",
	  SCENE_EINVAL, "particles.box", NULL },
	{ "box edge negative", "{" HEAD ",'particles':{'count':100,'box':[20,-1]}," RUN "}", SCENE_EINVAL,
	  "particles.box[1]", "particles.box[1]: must be a number > 0, got -1" },
	{ "box edge string", "{" HEAD ",'particles':{'count':100,'box':[20,'x']}," RUN "}", SCENE_EINVAL,
	  "particles.box[1]", NULL },
	{ "until missing", "{" HEAD "," PART ",'run':{}}", SCENE_EINVAL, "run.until", "run.until: required key missing" },
	{ "run missing", "{" HEAD "," PART "}", SCENE_EINVAL, "run", NULL },
	{ "until empty", "{" HEAD "," PART ",'run':{'until':{}}}", SCENE_EINVAL, "run.until", NULL },
	{ "until both", "{" HEAD "," PART ",'run':{'until':{'time':1,'collisions_per_particle':5}}}", SCENE_EINVAL,
	  "run.until", NULL },
	{ "until time 0", "{" HEAD "," PART ",'run':{'until':{'time':0}}}", SCENE_EINVAL, "run.until.time", NULL },
	{ "until number", "{" HEAD "," PART ",'run':{'until':5}}", SCENE_EINVAL, "run.until", NULL },
	{ "every negative", "{" BASE ",'output':{'every':{'collisions_per_particle':-1}}}", SCENE_EINVAL,
	  "output.every.collisions_per_particle", NULL },
	{ "every time 0", "{" BASE ",'output':{'every':{'time':0}}}", SCENE_EINVAL, "output.every.time", NULL },
	{ "every empty", "{" BASE ",'output':{'every':{}}}", SCENE_EINVAL, "output.every", NULL },
	{ "duplicate observable", "{" BASE ",'output':{'observables':['pressure','temperature','pressure']}}",
	  SCENE_EINVAL, "output.observables[2]", "output.observables[2]: duplicate observable \"pressure\"" },
	{ "unknown observable", "{" BASE ",'output':{'observables':['pressure','temperature','foo']}}", SCENE_EINVAL,
	  "output.observables[2]", NULL },
	{ "observable not string", "{" BASE ",'output':{'observables':[1]}}", SCENE_EINVAL, "output.observables[0]", NULL },
	{ "observables not array", "{" BASE ",'output':{'observables':'pressure'}}", SCENE_EINVAL, "output.observables",
	  NULL },
	{ "cluster delta 0", "{" BASE ",'output':{'clusters':{'delta':0}}}", SCENE_EINVAL, "output.clusters.delta", NULL },
	{ "method lbm", "{'method':'lbm','dimensions':2," PART "," RUN "}", SCENE_EINVAL, "method",
	  "method: must be one of \"ed\", \"dsmc\", \"hsmc\", \"auto\", \"md\", got \"lbm\"" },
	{ "method missing", "{'dimensions':2," PART "," RUN "}", SCENE_EINVAL, "method", NULL },
	{ "dimensions 4", "{'method':'ed','dimensions':4," PART "," RUN "}", SCENE_EINVAL, "dimensions",
	  "dimensions: must be 2 or 3, got 4" },
	{ "dimensions '2'", "{'method':'ed','dimensions':'2'," PART "," RUN "}", SCENE_EINVAL, "dimensions", NULL },
	{ "dimensions 2.0", "{'method':'ed','dimensions':2.0," PART "," RUN "}", SCENE_EINVAL, "dimensions",
	  "dimensions: must be 2 or 3, got 2.0" },
	{ "version 2", "{'version':2," BASE "}", SCENE_EINVAL, "version", NULL },
	{ "particles not object", "{" HEAD ",'particles':[100]," RUN "}", SCENE_EINVAL, "particles", NULL },
	{ "temperature negative", "{" HEAD "," PART_WITH("'initial':{'temperature':-1}") "," RUN "}", SCENE_EINVAL,
	  "particles.initial.temperature", NULL },
	{ "positions grid", "{" HEAD "," PART_WITH("'initial':{'positions':'grid'}") "," RUN "}", SCENE_EINVAL,
	  "particles.initial.positions", NULL },
	{ "relax without collisions_per_particle", "{" HEAD "," PART_WITH("'initial':{'relax':{}}") "," RUN "}",
	  SCENE_EINVAL, "particles.initial.relax.collisions_per_particle", NULL },
	{ "seed -1", "{" HEAD "," PART "," RUN_WITH("'seed':-1") "}", SCENE_EINVAL, "run.seed", NULL },
	{ "seed 2^53+1", "{" HEAD "," PART "," RUN_WITH("'seed':9007199254740993") "}", SCENE_EINVAL, "run.seed", NULL },
	{ "seed true", "{" HEAD "," PART "," RUN_WITH("'seed':true") "}", SCENE_EINVAL, "run.seed",
	  "run.seed: must be an integer, got boolean" },
	{ "cell size 0.5", "{" BASE ",'ed':{'cell_size':0.5}}", SCENE_EINVAL, "ed.cell_size", NULL },
	{ "newline in key", "{" BASE ",'a\\nb':1}", SCENE_EINVAL, "a?b", NULL },
};

static void test_defaults(void)
{
	scene_t s;
	char err[256] = "x";
	int ret = parse("{" BASE "}", &s, err, sizeof err);
	ok(ret == SCENE_OK && err[0] == '\0', "minimal scene parses (%d, %s)", ret, err);
	double edge = sqrt(100 * PI * 0.25 / 0.3);
	ok(s.method == SCENE_METHOD_ED && s.dim == 2 && s.count == 100, "method, dimensions, count");
	ok(s.radius == 0.5 && s.mass == 1, "default radius 0.5, mass 1");
	ok(s.volume_fraction == 0.3 && near(s.box[0], edge) && s.box[1] == s.box[0] && s.box[2] == 0,
	   "box derived from volume fraction: %g x %g x %g", s.box[0], s.box[1], s.box[2]);
	ok(s.positions == SCENE_POS_LATTICE && s.temperature == 1 && s.relax_cpp == 0,
	   "default lattice, temperature 1, no relax");
	ok(s.restitution == 1 && s.tc == 0, "default restitution 1, tc 0");
	ok(s.seed == 1 && s.max_events == 0, "default seed 1, max_events 0");
	ok(s.until.kind == SCENE_CLOCK_CPP && s.until.value == 5, "until 5 collisions per particle");
	ok(s.every.kind == SCENE_CLOCK_CPP && near(s.every.value, 0.05), "every defaults to until/100, same kind");
	ok(s.observables == (SCENE_OBS_ENERGY | SCENE_OBS_PRESSURE | SCENE_OBS_COLLISION_RATE),
	   "default observables");
	ok(s.cluster_delta == 0.1 && s.ed_cell_size == 0, "default cluster delta 0.1, automatic cells");
	ok(near(scene_box_volume(&s) * s.volume_fraction, s.count * scene_particle_volume(&s)),
	   "box volume and particle volume agree with the volume fraction");
	ok(s.snapshots.kind == SCENE_CLOCK_NONE && s.compression == 0 && s.checkpoint.kind == SCENE_CLOCK_NONE,
	   "default: no snapshot interval, compression 0, no checkpoints");
	ret = parse("{" BASE ",\"output\":{\"snapshots\":{\"every\":{\"time\":0.5},\"compression\":3},"
	            "\"checkpoint\":{\"every\":{\"wall_seconds\":30}}}}", &s, err, sizeof err);
	ok(ret == SCENE_OK && s.snapshots.kind == SCENE_CLOCK_TIME && s.snapshots.value == 0.5 && s.compression == 3 &&
	   s.checkpoint.kind == SCENE_CLOCK_WALL && s.checkpoint.value == 30,
	   "snapshots every time 0.5, compression 3, checkpoint every 30 wall seconds (%s)", err);
	ret = parse("{" BASE ",\"output\":{\"snapshots\":{\"every\":{\"collisions_per_particle\":2}},"
	            "\"checkpoint\":{\"every\":{\"time\":4}}}}", &s, err, sizeof err);
	ok(ret == SCENE_OK && s.snapshots.kind == SCENE_CLOCK_CPP && s.snapshots.value == 2 &&
	   s.checkpoint.kind == SCENE_CLOCK_TIME && s.checkpoint.value == 4,
	   "snapshots every 2 collisions per particle, checkpoint every simulated time 4 (%s)", err);
	ret = parse("{" BASE ",\"output\":{\"checkpoint\":{\"every\":{\"time\":1,\"wall_seconds\":1}}}}", &s, err, sizeof err);
	ok(ret == SCENE_EINVAL && !strcmp(err, "output.checkpoint.every: must have exactly one of time or wall_seconds"),
	   "checkpoint with both clocks: %s", err);
}

static void test_derived(void)
{
	scene_t s;
	char err[256];
	int ret = parse("{" HEAD ",'particles':{'count':50,'box':[20,10]}," RUN "}", &s, err, sizeof err);
	ok(ret == 0 && near(s.volume_fraction, 50 * PI * 0.25 / 200) && s.box[0] == 20 && s.box[1] == 10 &&
	   s.box[2] == 0, "2D box given: volume fraction %g derived", s.volume_fraction);

	ret = parse("{'method':'ed','dimensions':3,'particles':{'count':1000,'radius':1,'volume_fraction':0.2}," RUN "}",
		    &s, err, sizeof err);
	double edge = cbrt(1000 * 4.0 / 3.0 * PI / 0.2);
	ok(ret == 0 && near(s.box[0], edge) && s.box[1] == s.box[0] && s.box[2] == s.box[0],
	   "3D volume fraction given: cube edge %g derived", s.box[0]);

	ret = parse("{'method':'ed','dimensions':3,'particles':{'count':128,'box':[8,8,8]}," RUN "}", &s, err, sizeof err);
	ok(ret == 0 && near(s.volume_fraction, 128 * PI / 6 / 512), "3D box given: volume fraction %g derived",
	   s.volume_fraction);
}

static void test_all_keys(void)
{
	scene_t s;
	char err[256];
	int ret = parse("{'version':1,'method':'dsmc','dimensions':3,"
			"'particles':{'count':2000,'radius':0.25,'mass':3,'volume_fraction':0.1,"
			"'initial':{'positions':'random','temperature':0,'relax':{'collisions_per_particle':2}}},"
			"'collisions':{'restitution':0,'tc':0.001},"
			"'run':{'seed':9007199254740992,'until':{'time':10}},"
			"'output':{'every':{'collisions_per_particle':0.5},"
			"'observables':['kinetic_energy','temperature','pressure','compressibility',"
			"'collision_rate','clusters','momentum'],'clusters':{'delta':0.3}},"
			"'ed':{'cell_size':1.5}}", &s, err, sizeof err);
	ok(ret == 0, "scene with every key parses (%s)", err);
	ok(s.method == SCENE_METHOD_DSMC && s.dim == 3 && s.count == 2000 && s.radius == 0.25 && s.mass == 3,
	   "method, dimensions, particles");
	ok(s.positions == SCENE_POS_RANDOM && s.temperature == 0 && s.relax_cpp == 2, "initial");
	ok(s.restitution == 0 && s.tc == 0.001, "restitution 0 allowed with tc > 0");
	ok(s.seed == 9007199254740992ULL, "seed 2^53");
	ok(s.until.kind == SCENE_CLOCK_TIME && s.until.value == 10 && s.every.kind == SCENE_CLOCK_CPP &&
	   s.every.value == 0.5, "until in time, every in collisions per particle");
	ok(s.observables == (SCENE_OBS_ENERGY | SCENE_OBS_PRESSURE | SCENE_OBS_COLLISION_RATE | SCENE_OBS_CLUSTERS |
			     SCENE_OBS_MOMENTUM), "all observables");
	ok(s.cluster_delta == 0.3 && s.ed_cell_size == 1.5, "cluster delta and cell size");

	ret = parse("{'method':'hsmc','dimensions':2," PART ",'run':{'seed':0,'until':{'time':4}},"
		    "'output':{'observables':['temperature','clusters']},'ed':{'cell_size':0}}", &s, err, sizeof err);
	ok(ret == 0 && s.method == SCENE_METHOD_HSMC && s.seed == 0 && s.ed_cell_size == 0,
	   "hsmc, seed 0, explicit automatic cell size");
	ok(s.observables == (SCENE_OBS_ENERGY | SCENE_OBS_CLUSTERS), "temperature maps to the energy bit");
	ok(s.every.kind == SCENE_CLOCK_TIME && near(s.every.value, 0.04), "every defaults to until time / 100");

	ret = parse("{" BASE ",'output':{'observables':[]}}", &s, err, sizeof err);
	ok(ret == 0 && s.observables == 0, "empty observable list");
}

static void test_bad(void)
{
	for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) {
		const struct bad *b = &bad[i];
		char err[512] = "";
		scene_t s;
		int ret = parse(b->json, &s, err, sizeof err);
		int good = ret == b->code && has_path(err, b->path) && (b->msg == NULL || strcmp(err, b->msg) == 0);
		ok(good, "%s: %s", b->name, err);
		if (!good)
			diag("expected code %d (got %d), path %s, message %s", b->code, ret, b->path, b->msg ? b->msg : "-");
	}
}

/*
 * Validate means runnable: the engines' start checks (what granular-engine
 * run refuses after parsing: the cell grid, the initial placement) are
 * made by scene_parse() through scene_check_start(), so every scene the
 * parser accepts starts. For scenes at the edges of those checks the
 * parser's verdict and message equal the engine's (run_create(), the
 * constructor the engine runs): the geometry comes from an "auto" scene
 * (whose start checks wait for the method), the method and settings are
 * then set on the parsed scene. On main the parser accepted them all
 * (dsmc.cell_size 1e-9 and random placement at 0.6 among them).
 */
static void test_start_checks(void)
{
	static const struct { int dim; double phi; int n; const char *pos; scene_method_t m; double cell; } cases[] = {
		/* dsmc/hsmc cell grid: at most 64 cells per particle (+4096) */
		{2, 0.1, 1000, "lattice", SCENE_METHOD_DSMC, 1e-9}, {2, 0.1, 1000, "lattice", SCENE_METHOD_DSMC, 0.05},
		{2, 0.1, 1000, "lattice", SCENE_METHOD_DSMC, 0.1}, {2, 0.1, 1000, "lattice", SCENE_METHOD_DSMC, 1},
		{3, 0.3, 1000, "lattice", SCENE_METHOD_HSMC, 0.01}, {3, 0.3, 1000, "lattice", SCENE_METHOD_HSMC, 0.1},
		{3, 0.3, 1000, "lattice", SCENE_METHOD_HSMC, 0.2}, {3, 0.01, 1000, "lattice", SCENE_METHOD_DSMC, 0.05},
		{2, 0.1, 1000, "lattice", SCENE_METHOD_DSMC, 5}, {3, 0.3, 1000, "lattice", SCENE_METHOD_HSMC, 2},
		/* ed lattice near its densest fit */
		{2, 0.85, 1000, "lattice", SCENE_METHOD_ED, 0}, {2, 0.88, 1000, "lattice", SCENE_METHOD_ED, 0},
		{2, 0.89, 1000, "lattice", SCENE_METHOD_ED, 0}, {2, 0.89, 1024, "lattice", SCENE_METHOD_ED, 0},
		{2, 0.9, 1001, "lattice", SCENE_METHOD_ED, 0}, {3, 0.7, 1000, "lattice", SCENE_METHOD_ED, 0},
		{3, 0.72, 500, "lattice", SCENE_METHOD_ED, 0}, {3, 0.74, 4000, "lattice", SCENE_METHOD_ED, 0},
		/* ed random placement: refused at the jamming coverage of random sequential addition */
		{2, 0.3, 1000, "random", SCENE_METHOD_ED, 0}, {2, 0.6, 1000, "random", SCENE_METHOD_ED, 0},
		{3, 0.2, 1000, "random", SCENE_METHOD_ED, 0}, {3, 0.39, 1000, "random", SCENE_METHOD_ED, 0},
		/* ed cell grid: an explicit cell_size in a dilute box (64 per particle beyond a million) */
		{3, 1e-6, 1000, "lattice", SCENE_METHOD_ED, 1}, {3, 1e-3, 1000, "lattice", SCENE_METHOD_ED, 1},
		{2, 1e-6, 1000, "lattice", SCENE_METHOD_ED, 1},
	};
	int refused = 0, started = 0;
	for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
		char text[512], perr[512] = "", rerr[512] = "";
		scene_t s;
		snprintf(text, sizeof text, "{'method':'auto','accuracy':{'temperature':0.1},'dimensions':%d,"
		         "'particles':{'count':%d,'volume_fraction':%.17g,'initial':{'positions':'%s'}},"
		         "'run':{'until':{'time':0.001}}}", cases[i].dim, cases[i].n, cases[i].phi, cases[i].pos);
		if (parse(text, &s, perr, sizeof perr)) {
			ok(0, "start case %zu parses as auto: %s", i, perr);
			continue;
		}
		s.method = cases[i].m;
		if (s.method == SCENE_METHOD_ED)
			s.ed_cell_size = cases[i].cell;
		else
			s.mc_cell_size = cases[i].cell;
		int pv = scene_check_start(&s, perr, sizeof perr), e = 0;
		run_t *r = run_create(&s, NULL, &e, rerr, sizeof rerr);
		run_destroy(r);
		refused += pv != SCENE_OK;
		started += r != NULL;
		ok((pv == SCENE_OK) == (r != NULL) && (r || !strcmp(perr, rerr)),
		   "%s %dD N=%d phi=%g %s cell %g: parser %s, engine %s%s%s", scene_method_name(s.method), s.dim,
		   cases[i].n, cases[i].phi, cases[i].pos, cases[i].cell, pv == SCENE_OK ? "accepts" : "refuses",
		   r ? "starts" : "refuses", r ? "" : ": ", r ? "" : rerr);
	}
	ok(refused >= 8 && started >= 8, "both sides covered: %d refused, %d started", refused, started);

	/* Through scene_parse() itself, with the key of the check. */
	static const struct { const char *text, *key; } refused_by_engine[] = {
		{"{'method':'dsmc','dimensions':2,'particles':{'count':1000,'volume_fraction':0.1},"
		 "'run':{'until':{'time':1}},'dsmc':{'cell_size':1e-9}}", "dsmc.cell_size"},
		{"{'method':'ed','dimensions':2,'particles':{'count':1000,'volume_fraction':0.6,"
		 "'initial':{'positions':'random'}},'run':{'until':{'time':1}}}", "particles.initial.positions"},
		{"{'method':'ed','dimensions':2,'particles':{'count':1000,'volume_fraction':0.89},"
		 "'run':{'until':{'time':1}}}", "particles.initial.positions"},
		{"{'method':'ed','dimensions':3,'particles':{'count':1000,'volume_fraction':1e-6},"
		 "'run':{'until':{'time':1}},'ed':{'cell_size':1}}", "ed.cell_size"},
	};
	for (size_t i = 0; i < sizeof refused_by_engine / sizeof refused_by_engine[0]; i++) {
		char err[512] = "";
		scene_t s;
		int rc = parse(refused_by_engine[i].text, &s, err, sizeof err);
		ok(rc == SCENE_EINVAL && has_path(err, refused_by_engine[i].key), "scene_parse refuses what the engine would: %s",
		   err);
	}
}

/* particles.initial.region and .from (docs/scene.md, "Initial state"). */
static void test_initial(void)
{
	scene_t s;
	char err[512] = "";
	int ret = parse("{" HEAD ",'particles':{'count':100,'box':[20,40],'initial':{'positions':'random',"
	                "'region':{'upper':[20,12]}}}," RUN "}", &s, err, sizeof err);
	ok(ret == 0 && s.has_region && s.region_lo[0] == 0 && s.region_lo[1] == 0 && s.region_hi[0] == 20 &&
	   s.region_hi[1] == 12 && !s.has_from, "region: lower defaults to 0, upper as given (%s)", err);
	ret = parse("{" HEAD ",'particles':{'count':100,'box':[20,40],'initial':{'region':{'lower':[0,5]}}}," RUN "}",
	            &s, err, sizeof err);
	ok(ret == 0 && s.has_region && s.region_lo[1] == 5 && s.region_hi[0] == 20 && s.region_hi[1] == 40,
	   "region: upper defaults to the box (%s)", err);
	ret = parse("{" BASE "}", &s, err, sizeof err);
	ok(ret == 0 && !s.has_region && !s.has_from && s.from_frame == -1 && s.from_replica == -1 && !s.init_pos &&
	   !s.init_vel, "no region, no from: the engines place as before");
	ret = parse("{" HEAD "," PART_WITH("'initial':{'from':{'file':'../run1/trajectory.h5'}}") "," RUN "}", &s, err,
	            sizeof err);
	ok(ret == 0 && s.has_from && !strcmp(s.from_file, "../run1/trajectory.h5") && s.from_job == 0 &&
	   s.from_frame == -1 && s.from_replica == -1, "from.file, frame defaults to -1 (the last) (%s)", err);
	ret = parse("{" HEAD "," PART_WITH("'initial':{'from':{'job':17,'frame':3,'replica':2},'relax':"
	            "{'collisions_per_particle':1}}") "," RUN "}", &s, err, sizeof err);
	ok(ret == 0 && s.has_from && !s.from_file[0] && s.from_job == 17 && s.from_frame == 3 && s.from_replica == 2 &&
	   s.relax_cpp == 1, "from.job, frame, replica; relax allowed beside from (%s)", err);
	ret = parse("{" HEAD "," PART_WITH("'initial':{'from':{'file':'a.h5','frame':-9007199254740992}}") "," RUN "}",
	            &s, err, sizeof err);
	ok(ret == 0 && s.from_frame == -9007199254740992LL, "frame -2^53 parses (range is the file's business)");

	static const struct { const char *name, *initial, *key; } bad_initial[] = {
		{ "from with file and job", "'from':{'file':'a.h5','job':3}", "particles.initial.from" },
		{ "from with neither", "'from':{'frame':-1}", "particles.initial.from" },
		{ "from unknown key", "'from':{'file':'a.h5','step':3}", "particles.initial.from.step" },
		{ "from.file empty", "'from':{'file':''}", "particles.initial.from.file" },
		{ "from.file a number", "'from':{'file':3}", "particles.initial.from.file" },
		{ "from.file with a control character", "'from':{'file':'a\\nb.h5'}", "particles.initial.from.file" },
		{ "from.job 0", "'from':{'job':0}", "particles.initial.from.job" },
		{ "from.job a string", "'from':{'job':'12'}", "particles.initial.from.job" },
		{ "from.frame 1.0", "'from':{'file':'a.h5','frame':1.0}", "particles.initial.from.frame" },
		{ "from.replica -1", "'from':{'file':'a.h5','replica':-1}", "particles.initial.from.replica" },
		{ "positions beside from", "'positions':'random','from':{'file':'a.h5'}", "particles.initial.positions" },
		{ "temperature beside from", "'temperature':2,'from':{'file':'a.h5'}", "particles.initial.temperature" },
		{ "region beside from", "'region':{'upper':[5,5]},'from':{'file':'a.h5'}", "particles.initial.region" },
		{ "velocity beside from", "'velocity':[1,0],'from':{'file':'a.h5'}", "particles.initial.velocity" },
		{ "rotational_temperature beside from", "'rotational_temperature':1,'from':{'file':'a.h5'}",
		  "particles.initial.rotational_temperature" },
		{ "region lower of 3 in 2D", "'region':{'lower':[0,0,0]}", "particles.initial.region.lower" },
		{ "region upper not numbers", "'region':{'upper':['a',1]}", "particles.initial.region.upper[0]" },
		{ "region unknown key", "'region':{'top':3}", "particles.initial.region.top" },
		{ "region below the box", "'region':{'lower':[-1,0]}", "particles.initial.region.lower[0]" },
		{ "region beyond the box", "'region':{'upper':[20,40.5]}", "particles.initial.region.upper[1]" },
		{ "region upper at lower", "'region':{'lower':[0,10],'upper':[20,10]}", "particles.initial.region.upper[1]" },
		{ "region too thin", "'region':{'upper':[20,0.9]}", "particles.initial.region" },
		{ "region too small for the lattice", "'region':{'upper':[20,5]}", "particles.initial.region" },
		{ "region too small for random placement", "'positions':'random','region':{'upper':[20,6]}",
		  "particles.initial.region" },
	};
	for (size_t i = 0; i < sizeof bad_initial / sizeof bad_initial[0]; i++) {
		char text[1024];
		snprintf(text, sizeof text, "{" HEAD ",'particles':{'count':100,'box':[20,40],'initial':{%s}}," RUN "}",
		         bad_initial[i].initial);
		ret = parse(text, &s, err, sizeof err);
		ok(ret == SCENE_EINVAL && has_path(err, bad_initial[i].key), "%s: %s", bad_initial[i].name, err);
	}
	ret = parse("{" HEAD "," PART_WITH("'initial':{'from':{'file':'a.h5'}}") ",'run':{'until':{'time':1},"
	            "'replicas':2}}", &s, err, sizeof err);
	ok(ret == SCENE_EINVAL && has_path(err, "particles.initial.from"), "from with replicas: %s", err);

	/* The parser's verdict on a region is the engine's (run_create() places
	 * it): a scene parsed without one gets it set, then both judge. */
	static const struct { const char *head; double lo[3], hi[3]; const char *pos; } region_cases[] = {
		{ "'method':'ed','dimensions':2", {0, 0}, {20, 5}, "lattice" },
		{ "'method':'ed','dimensions':2", {0, 0}, {20, 7}, "lattice" },
		{ "'method':'ed','dimensions':2", {0, 0}, {20, 6}, "random" },
		{ "'method':'ed','dimensions':2", {0, 0}, {20, 8}, "random" },
		{ "'method':'hsmc','dimensions':2", {0, 20}, {20, 40}, "random" },
		{ "'method':'dsmc','dimensions':2", {0, 0}, {20, 4}, "random" },
		{ "'method':'ed','dimensions':2", {0, 0}, {20, 0.5}, "lattice" },
	};
	int refused = 0, started = 0;
	for (size_t i = 0; i < sizeof region_cases / sizeof region_cases[0]; i++) {
		char text[1024], perr[512] = "", rerr[512] = "";
		snprintf(text, sizeof text, "{%s,'particles':{'count':100,'box':[20,40],'initial':{'positions':'%s'}},"
		         "'run':{'until':{'time':0.01}}}", region_cases[i].head, region_cases[i].pos);
		if (parse(text, &s, perr, sizeof perr)) {
			ok(0, "region case %zu parses without its region: %s", i, perr);
			continue;
		}
		s.has_region = 1;
		memcpy(s.region_lo, region_cases[i].lo, sizeof s.region_lo);
		memcpy(s.region_hi, region_cases[i].hi, sizeof s.region_hi);
		int pv = scene_check_start(&s, perr, sizeof perr), e = 0;
		run_t *r = run_create(&s, NULL, &e, rerr, sizeof rerr);
		run_destroy(r);
		refused += pv != SCENE_OK;
		started += r != NULL;
		ok((pv == SCENE_OK) == (r != NULL) && (r || (!strcmp(perr, rerr) && has_path(perr, "particles.initial.region"))),
		   "region case %zu (%s, %s, up to y = %g): parser %s, engine %s%s%s", i, scene_method_name(s.method),
		   region_cases[i].pos, region_cases[i].hi[1], pv == SCENE_OK ? "accepts" : "refuses",
		   r ? "starts" : "refuses", r ? "" : ": ", r ? "" : rerr);
	}
	ok(refused >= 3 && started >= 3, "region cases on both sides: %d refused, %d started", refused, started);
}

static void test_api(void)
{
	scene_t s, keep;
	memset(&keep, 0xab, sizeof keep);
	s = keep;
	char err[8];
	ok(parse("{" BASE ",'colour':1}", &s, NULL, 0) == SCENE_EINVAL, "err NULL is safe");
	ok(parse("{" BASE ",'colour':1}", &s, err, 0) == SCENE_EINVAL, "errlen 0 is safe");
	ok(parse("{" BASE ",'colour':1}", &s, err, sizeof err) == SCENE_EINVAL && strlen(err) == sizeof err - 1,
	   "message truncated to errlen: %s", err);
	ok(parse("not json", &s, err, 1) == SCENE_EJSON && err[0] == '\0', "errlen 1 gives an empty string");
	ok(memcmp(&s, &keep, sizeof s) == 0, "output untouched on error");
	ok(scene_parse(NULL, 0, &s, NULL, 0) == SCENE_EJSON, "NULL text is not JSON");
	ok(parse("{" BASE "}", NULL, NULL, 0) == SCENE_OK, "out NULL validates only");

	ok(near(scene_close_packing(2), PI / (2 * sqrt(3))) && near(scene_close_packing(3), PI / (3 * sqrt(2))),
	   "close packing 2D %.4f, 3D %.4f", scene_close_packing(2), scene_close_packing(3));
	ok(strcmp(scene_method_name(SCENE_METHOD_ED), "ed") == 0 && strcmp(scene_method_name(SCENE_METHOD_DSMC), "dsmc") == 0 &&
	   strcmp(scene_method_name(SCENE_METHOD_HSMC), "hsmc") == 0, "method names");
	ok(strcmp(scene_strerror(SCENE_OK), scene_strerror(SCENE_EINVAL)) != 0 && scene_strerror(-99) != NULL &&
	   scene_strerror(SCENE_EJSON) != NULL && scene_strerror(SCENE_ENOMEM) != NULL, "error strings");
}

static char *slurp(const char *path, size_t *len)
{
	FILE *f = fopen(path, "rb");
	if (f == NULL)
		return NULL;
	char *buf = malloc(1 << 16);
	*len = buf ? fread(buf, 1, 1 << 16, f) : 0;
	fclose(f);
	return buf;
}

/* The scene files shared with the CLI and schema tests, when SRCDIR says where they are. */
static void test_files(const char *srcdir)
{
	char path[4096], line[1024], err[512];
	size_t len;
	scene_t s;

	snprintf(path, sizeof path, "%s/tests/scenes/good", srcdir);
	DIR *d = opendir(path);
	ok(d != NULL, "open %s", path);
	for (struct dirent *e; d && (e = readdir(d));) {
		if (strstr(e->d_name, ".json") == NULL)
			continue;
		snprintf(path, sizeof path, "%s/tests/scenes/good/%s", srcdir, e->d_name);
		char *text = slurp(path, &len);
		ok(text && scene_parse(text, len, &s, err, sizeof err) == 0, "good/%s parses %s", e->d_name, err);
		free(text);
	}
	if (d)
		closedir(d);

	snprintf(path, sizeof path, "%s/tests/scenes/bad/expected.tsv", srcdir);
	FILE *tsv = fopen(path, "r");
	ok(tsv != NULL, "open %s", path);
	while (tsv && fgets(line, sizeof line, tsv)) {
		char *file = strtok(line, "\t\n"), *prefix = strtok(NULL, "\t\n");
		if (file == NULL || prefix == NULL)
			continue;
		snprintf(path, sizeof path, "%s/tests/scenes/bad/%s", srcdir, file);
		char *text = slurp(path, &len);
		int ret = text ? scene_parse(text, len, &s, err, sizeof err) : 0;
		ok(ret < 0 && has_path(err, prefix), "bad/%s: %s", file, err);
		free(text);
	}
	if (tsv)
		fclose(tsv);
}

int main(void)
{
	test_defaults();
	test_derived();
	test_all_keys();
	test_bad();
	test_start_checks();
	test_initial();
	test_api();
	const char *srcdir = getenv("SRCDIR");
	if (srcdir && *srcdir)
		test_files(srcdir);
	else
		skip("SRCDIR not set: scene files not checked");
	plan(tap_n);
	return done_testing();
}
