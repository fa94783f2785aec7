/* Run driver: a scene from start to stop condition, sampling observables on the output schedule. */
#pragma once

#include <signal.h>
#include <stdint.h>
#include "clusters.h"
#include "scene.h"

/*
 * Contract
 * - No I/O: records are handed to the caller's emit() callback, which
 *   serialises them (report.h) and writes them where it wants.
 * - Only the observables the scene asks for are computed; the flags in a
 *   record say which fields are valid.
 * - The dynamics do not depend on the output schedule (the engine never
 *   moves particles to sample them), so runs that differ only in
 *   output.every reach identical states at identical times.
 */

typedef enum { RUN_PROGRESS = 0, RUN_SUMMARY } run_kind_t;
typedef enum { RUN_COMPLETED = 0, RUN_QUIESCENT, RUN_INTERRUPTED } run_status_t;

enum {
	RUN_OK = 0,
	RUN_ESETUP = -1,     /* the engine could not build the initial state (msg says why) */
	RUN_EMIT = -2,       /* emit() returned non-zero (e.g. the output pipe broke) */
	RUN_ENOMEM = -3,
	RUN_EMETHOD = -4,    /* method not implemented yet */
};

typedef struct {
	run_kind_t kind;
	int dim;
	uint64_t n;
	double time;                 /* simulated time */
	uint64_t events, collisions;
	double collisions_per_particle;  /* 2C/N */
	double wall_seconds;         /* since the start of the production run */
	unsigned have;               /* SCENE_OBS_* bits valid in this record */
	int have_interval;           /* interval quantities (pressure, rate) valid */
	double kinetic_energy;       /* total */
	double temperature;          /* 2 E_kin / (D N) */
	double pressure;             /* collision virial over the interval */
	double compressibility;      /* P V / (N <T>) over the interval */
	double collision_rate;       /* 2 C / (N dt) over the interval */
	double momentum[3];
	clusters_stats_t clusters;
	uint64_t elastic_by_tc;      /* collisions made elastic by the TC model */
	/* summary only */
	run_status_t status;
	double events_per_second, collisions_per_second;
	uint64_t memory_bytes;
	int cells[3];
} run_record_t;

/* Called for each record; a non-zero return stops the run (RUN_EMIT). */
typedef int (*run_emit_fn)(const run_record_t *rec, void *ctx);

/* Run the scene. stop (may be NULL) is polled between chunks of events; when
 * it becomes non-zero the run ends with a summary of status
 * RUN_INTERRUPTED. msg receives a one-line reason on failure. */
int run_scene(const scene_t *s, run_emit_fn emit, void *ctx,
              const volatile sig_atomic_t *stop, char *msg, size_t msglen);

const char *run_status_name(run_status_t st);
