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
	const char *warning;         /* dsmc/hsmc validity warning (first record only), or NULL */
	/* dsmc/hsmc diagnostics (totals; printed in the summary when non-zero) */
	uint64_t vmax_raised, cell_collisions, rejected_moves;
	/* Ensembles (run.replicas > 1): the observables above are means over the
	 * replicas and these their standard errors; replicas = 0 or 1 otherwise. */
	uint32_t replicas;
	struct {
		double time, collisions_per_particle, kinetic_energy, temperature, pressure,
		       compressibility, collision_rate, largest_fraction, mean_size;
	} se;
	/* summary only */
	run_status_t status;
	double events_per_second, collisions_per_second;
	uint64_t memory_bytes;
	int cells[3];
} run_record_t;

/* Called for each record; a non-zero return stops the run (RUN_EMIT). */
typedef int (*run_emit_fn)(const run_record_t *rec, void *ctx);

/* Step-wise form of run_scene(), used for ensembles: run_open() builds the
 * state of one replica (the scene with random stream `stream`); each
 * run_next() returns the next progress record (the first at time 0) and sets
 * *done on the last; run_summary() fills the summary record. stop (may be
 * NULL) is polled between chunks of work; when set the current record is
 * the last one and the status becomes RUN_INTERRUPTED. */
typedef struct run run_t;
run_t *run_open(const scene_t *s, uint64_t stream, int *err, char *msg, size_t msglen);
int run_next(run_t *r, const volatile sig_atomic_t *stop, run_record_t *rec, int *done);
void run_summary(run_t *r, run_record_t *sum);
void run_close(run_t *r);

/* Run the scene. stop (may be NULL) is polled between chunks of events; when
 * it becomes non-zero the run ends with a summary of status
 * RUN_INTERRUPTED. msg receives a one-line reason on failure. */
int run_scene(const scene_t *s, run_emit_fn emit, void *ctx,
              const volatile sig_atomic_t *stop, char *msg, size_t msglen);

const char *run_status_name(run_status_t st);
