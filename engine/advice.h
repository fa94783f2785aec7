/* Method advice: estimated cost and expected error of ed, dsmc and hsmc for a scene, from a model fitted to the measured trade-off table. */
#pragma once

#include <stddef.h>
#include <jansson.h>
#include "scene.h"

/*
 * Contract
 * - Pure logic: no I/O, no globals. The model is a JSON text (version 2,
 *   format in docs/tradeoff-notes.md, fitted by bench/tradeoff.py);
 *   advice_model_builtin() returns the one shipped with the build
 *   (data/advice-model.json, embedded at build time).
 * - Cost (CPU seconds, all replicas, set-up included) = predicted work x
 *   fitted seconds per unit of work:
 *     ed:        collisions x (a_D + b_D / (nu chi(nu)))   (cell crossings ~ mean free path)
 *     dsmc/hsmc: moves x s_move + collisions x s_coll      (per method and D)
 *   Collisions per particle of the production run follow Haff's law for
 *   the gas each method simulates (collision frequency f0 with chi = g(sigma)
 *   for ed and the Enskog corrections, chi = 1 for dsmc/none):
 *     cpp(t) = (2D / lambda) ln(1 + lambda f0 t / (2D)),  lambda = 1 - e^2
 *   (f0 t when lambda = 0), or the stop condition itself; the elastic
 *   pre-run adds relax collisions per particle. MC steps = cpp /
 *   collisions_per_step (+ one per output time), moves = N x steps.
 * - Expected error of T(t) (relative RMS over the run's output times
 *   against exact hard-sphere dynamics) = sqrt(bias^2 + spread^2 / (N x
 *   replicas)); bias 0 for ed. Bias and spread are measured per grid point
 *   (volume fraction, lambda) as curves over the Haff time tau (model key
 *   haff_time) and evaluated at the tau the run reaches (advice_t.haff_time):
 *   linear between measured times, below the first the bias linear to 0 at
 *   tau = 0 and the spread constant, beyond the last clamped (flagged).
 *   Across the grid: bilinear in (chi(nu) - 1, lambda) (model key
 *   density_axis; "volume_fraction": in nu), clamped outside (flagged), and
 *   bias = spread = 0 at lambda = 0 (elastic: T is conserved exactly).
 * - Bounded scenes (walls, gravity): the MC estimates are flagged
 *   ADVICE_X_BOUNDED (their error model is the periodic gas's), so auto
 *   takes ed; dsmc is refused where gravity pulls the particles onto a wall
 *   (a bed forms): its point particles have no excluded volume and the bed
 *   collapses onto the floor (seed 000 A12; measured in docs/tradeoff.md).
 * - auto: the cheapest candidate (CPU seconds) whose expected error meets
 *   the target and is not extrapolated (ed always counts: exact up to its
 *   statistical error); none: ed, with the N x replicas that would meet it.
 * - Outside the measured range (volume fraction, lambda, Haff time beyond
 *   the measured cooling: clustering; non-default MC settings; validity
 *   warnings of dsmc_params(); N far above the measured size) an estimate
 *   is flagged extrapolated with a note; an MC estimate whose error is
 *   extrapolated never counts as meeting a target.
 * - Deterministic: same model and scene give the same advice.
 */

typedef struct advice_model advice_model_t;

enum {
	ADVICE_OK = 0,
	ADVICE_ENOMEM = -1,
	ADVICE_EMODEL = -2,    /* model text invalid (message names the key) */
	ADVICE_ESCENE = -3,    /* scene cannot be estimated (message says why) */
};

/* Why an estimate is extrapolated (bit set). The ERROR bits concern the
 * expected error, SIZE only the cost. */
enum {
	ADVICE_X_DENSITY = 1u << 0,     /* volume fraction outside the measured range */
	ADVICE_X_DISSIPATION = 1u << 1, /* 1 - e^2 above the measured range */
	ADVICE_X_CLUSTERING = 1u << 2,  /* run longer than the measured homogeneous cooling */
	ADVICE_X_SETTINGS = 1u << 3,    /* MC settings other than the measured defaults */
	ADVICE_X_VALIDITY = 1u << 4,    /* dsmc_params() validity warning */
	ADVICE_X_VARIANT = 1u << 5,     /* no measured error for this method/correction */
	ADVICE_X_SIZE = 1u << 6,        /* N more than 10x the measured size: cost per operation may grow */
	ADVICE_X_BOUNDED = 1u << 7,     /* walls or gravity: the error model is the periodic gas's (the trade on the
	                                 * seed's bounded scenes is measured, docs/tradeoff.md, not modelled) */
	ADVICE_X_ERROR = ADVICE_X_DENSITY | ADVICE_X_DISSIPATION | ADVICE_X_CLUSTERING | ADVICE_X_SETTINGS |
	                 ADVICE_X_VALIDITY | ADVICE_X_VARIANT | ADVICE_X_BOUNDED,
};

/* Candidates: ed, each MC method at its default correction, and every other
 * dsmc/hsmc variant the model has measured (at default cell and step). */
#define ADVICE_MAX_ESTIMATES 8

typedef struct {
	scene_method_t method;        /* ED, DSMC or HSMC */
	int correction;               /* SCENE_MC_NONE/_ENSKOG/_CBA; 0 for ed */
	char variant[16];             /* "ed", "dsmc/none", "hsmc/cba", ... */
	/* settings assumed: the scene's own for its method, else the defaults */
	double cell_size;             /* diameters (MC: resolved edge; ed: scene value, 0 = automatic) */
	double collisions_per_step;   /* MC adaptive step, or 0 */
	double time_step;             /* MC fixed step, or 0 */
	double max_volume_fraction;   /* hsmc */
	/* work and cost, totals over the replicas */
	double collisions;            /* binary collisions, relax included */
	double moves;                 /* MC particle moves, relax included; 0 for ed */
	double cpu_seconds;           /* total: relax + production */
	double setup_cpu_seconds;     /* the relax part */
	double wall_seconds;          /* with the ranks given: replicas spread, one replica runs serially */
	/* expected relative RMS error of T(t) */
	double bias, statistical, error;   /* error NAN when unknown */
	int meets;                    /* 1 / 0; -1 without a target */
	int refused;                  /* 1: the method cannot simulate this scene faithfully (why: the first note);
	                               * never chosen */
	unsigned extrapolated;        /* ADVICE_X_* */
	char notes[768];              /* "; "-separated, "" when none */
} advice_estimate_t;

typedef struct {
	scene_method_t requested;     /* the scene's method (AUTO or concrete) */
	int dim;
	uint64_t particles, replicas;
	int ranks;
	double volume_fraction, restitution;
	double haff_time;             /* lambda f0 t_end / (2D) reached by the run (hard-sphere gas) */
	double cpp;                   /* production collisions per particle of the hard-sphere gas */
	double target;                /* accuracy.temperature, 0 = none */
	int n;
	advice_estimate_t est[ADVICE_MAX_ESTIMATES]; /* ed first, then dsmc and hsmc variants (see advice_estimate) */
	int choice;                   /* index into est for "auto", -1 otherwise */
	char reason[768];             /* why the choice (auto), "" otherwise */
	char model_date[32];
	int model_version;
} advice_t;

/* Parse a model. NULL on error with the reason ("key.path: reason") in err. */
advice_model_t *advice_model_create(const char *json, size_t len, char *err, size_t errlen);
void advice_model_destroy(advice_model_t *m);
/* The model shipped with the build (NUL-terminated; static storage). */
const char *advice_model_builtin(size_t *len);
/* Size of the systems the model's costs were measured on. */
double advice_model_particles(const advice_model_t *m);

/* Estimate every candidate for s (method AUTO or concrete), with ranks MPI
 * ranks (>= 1) for the wall time; for AUTO also choose (out->choice,
 * out->reason). Candidates, in this order: ed; dsmc at its default
 * correction (none), then every other dsmc/CORRECTION the model measured;
 * hsmc likewise (default cba). Each at the default cell size and step,
 * except the scene's own method and correction, which is estimated with
 * the scene's settings (and added if the model lacks it).
 * ADVICE_OK or ADVICE_ESCENE with err. */
int advice_estimate(const advice_model_t *m, const scene_t *s, int ranks, advice_t *out, char *err, size_t errlen);

/* Resolve an AUTO scene in place: method and, for dsmc/hsmc, the correction
 * := the choice; the other settings stay the defaults, which the estimate
 * assumed. No-op for a concrete method. */
void advice_apply(const advice_t *a, scene_t *s);

/* The same on the scene's JSON object (an AUTO scene, which carries no
 * dsmc/hsmc object): "method" := the choice, "accuracy" removed, and for
 * dsmc/hsmc "<method>": {"correction": "<chosen>"}. The result parses to
 * what advice_apply() gives. ADVICE_OK, ADVICE_ENOMEM, or ADVICE_ESCENE
 * when a has no choice. */
int advice_apply_json(const advice_t *a, json_t *scene);

/* The advice as JSON (new reference; NULL on allocation failure). Schema in
 * docs/engine.md ("advise"). */
json_t *advice_json(const advice_t *a);

/* Haff's law: collisions per particle after time t of a gas with initial
 * collision frequency f0 per particle, lambda = 1 - e^2, dimension dim. */
double advice_haff_cpp(int dim, double f0, double lambda, double t);

const char *advice_strerror(int code);
