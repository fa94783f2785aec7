/* Ensembles of independent replicas: records packed into flat vectors (for MPI reductions) and combined into means and standard errors. */
#pragma once

#include <stddef.h>
#include "run.h"
#include "scene.h"

/*
 * Contract
 * - No I/O, no MPI: the caller moves the vectors and replica states (engine/main.c reduces them
 *   with MPI_Allreduce, each replica's slot filled by exactly one rank and
 *   zero elsewhere, so the sum is exact and independent of the rank count).
 * - ensemble_combine() visits replicas in index order: the result depends
 *   only on the replica records, never on which rank produced them.
 */

/* doubles per replica record: the scalars, the species' temperatures, the cluster histogram, then the
 * bounded scenes' observables (ENSEMBLE_NV_BOUNDED: walls, obstacles, gravity, open walls, rotation, flux) */
#define ENSEMBLE_NV_BOUNDED (10 + 6 + 6 * 3 + SCENE_OBSTACLES_MAX * 3 + 3 * 6)
#define ENSEMBLE_NV (36 + SCENE_SPECIES_MAX + CLUSTERS_MAX_BINS + ENSEMBLE_NV_BOUNDED)
/* Packed records of versions before the bounded scenes' observables (checkpoints' "@last"). */
#define ENSEMBLE_NV_V4 (36 + SCENE_SPECIES_MAX + CLUSTERS_MAX_BINS)
/* Packed records of versions before the mixtures' per-species temperatures (checkpoints' "@last"). */
#define ENSEMBLE_NV_V3 (35 + CLUSTERS_MAX_BINS)
/* Packed records of versions before mean_square_displacement (checkpoints' "@last"). */
#define ENSEMBLE_NV_V2 (33 + CLUSTERS_MAX_BINS)
/* Packed records of versions before the structure observables (checkpoints' "@last"). */
#define ENSEMBLE_NV_V1 (26 + CLUSTERS_MAX_BINS)

/* Pack rec (a progress or summary record of one replica) into v[ENSEMBLE_NV];
 * done says whether it was that replica's last progress record. */
void ensemble_pack(const run_record_t *rec, int done, double *v);

/* Combine R packed records (R * ENSEMBLE_NV doubles, replica-major) into *out:
 * observables are means over the replicas with standard errors in out->se
 * (sample standard deviation / sqrt(R)); mixtures' per-species temperatures
 * likewise, species by species; so are the bounded scenes' observables (the
 * force and pressure on each wall, the force on each obstacle, the
 * centre-of-mass height, the potential energy, the flux, the rotational
 * energy and temperature); events, collisions, the dsmc diagnostics and the
 * counts of wall and obstacle hits, of particles present, and of particles
 * that left or entered through each wall are totals over the replicas;
 * cluster counts and largest sizes
 * rounded means, histogram totals. proto (a record of the same kind from
 * any replica) supplies kind, dim, n and the observable flags. Returns the
 * number of replicas whose done flag is set. */
int ensemble_combine(const double *vals, int R, const run_record_t *proto, run_record_t *out);

/* Inverse of ensemble_pack() for the packed fields (kind RUN_PROGRESS; dim,
 * n and the observable flags from s). Exact for counts below 2^53. */
void ensemble_unpack(const double *v, const scene_t *s, run_record_t *rec);

/*
 * Replica state for ensemble checkpoints, as a byte string that can travel
 * between ranks: a list of fields (name, ed_type_t, count, native-endian
 * data): the engine's state fields (run_fields()), the replica's schedule
 * ("@started", "@k_out", ..., "@frames": run_state_t) and "@done", "@status", "@last"
 * (its last record, packed). A replica loaded from it continues exactly.
 */
/* Serialise replica run r; *buf is malloc'd (caller frees). 0 or -1 (no memory). */
int ensemble_save(const run_t *r, unsigned char **buf, size_t *len);
/* Restore a replica of scene s with random stream `stream` from buf: *out
 * receives a new run (run_destroy). RUN_OK, RUN_ENOMEM or RUN_ERESTORE with
 * a reason in msg (malformed, a field that does not fit, inconsistent). */
int ensemble_load(const scene_t *s, uint64_t stream, const unsigned char *buf, size_t len, run_t **out,
                  char *msg, size_t msglen);
/* Iterate the fields of buf: *pos starts at 0; returns 1 and fills *f and
 * *data (pointing into buf) for each field, 0 at the end, -1 if malformed. */
int ensemble_next_field(const unsigned char *buf, size_t len, size_t *pos, ed_field_t *f, const void **data);
/* The value of the one-element u64 field `name` of buf (e.g. "@frames"):
 * 0 found, 1 absent, -1 malformed or of another type. */
int ensemble_blob_u64(const unsigned char *buf, size_t len, const char *name, uint64_t *v);
/* Append one field to a growing buffer (*buf, *len, *cap; realloc'd). 0 or -1. */
int ensemble_put_field(unsigned char **buf, size_t *len, size_t *cap, const char *name, ed_type_t type,
                       size_t count, const void *data);
