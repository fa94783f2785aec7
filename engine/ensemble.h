/* Ensembles of independent replicas: records packed into flat vectors (for MPI reductions) and combined into means and standard errors. */
#pragma once

#include <stddef.h>
#include "run.h"

/*
 * Contract
 * - No I/O, no MPI: the caller moves the vectors (engine/main.c reduces them
 *   with MPI_Allreduce, each replica's slot filled by exactly one rank and
 *   zero elsewhere, so the sum is exact and independent of the rank count).
 * - ensemble_combine() visits replicas in index order: the result depends
 *   only on the replica records, never on which rank produced them.
 */

#define ENSEMBLE_NV (26 + CLUSTERS_MAX_BINS)   /* doubles per replica record */

/* Pack rec (a progress or summary record of one replica) into v[ENSEMBLE_NV];
 * done says whether it was that replica's last progress record. */
void ensemble_pack(const run_record_t *rec, int done, double *v);

/* Combine R packed records (R * ENSEMBLE_NV doubles, replica-major) into *out:
 * observables are means over the replicas with standard errors in out->se
 * (sample standard deviation / sqrt(R)); events, collisions and the dsmc
 * diagnostics are totals over the replicas; cluster counts and largest sizes
 * rounded means, histogram totals. proto (a record of the same kind from
 * any replica) supplies kind, dim, n and the observable flags. Returns the
 * number of replicas whose done flag is set. */
int ensemble_combine(const double *vals, int R, const run_record_t *proto, run_record_t *out);
