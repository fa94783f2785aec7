/* JSON-lines serialisation of run records (the engine's progress protocol). */
#pragma once

#include <stddef.h>
#include "run.h"

/* Format rec as one JSON object followed by '\n' into buf. Returns the
 * length written (excluding the NUL), or -1 if buf is too small.
 * Doubles are printed with 17 significant digits (exact round trip);
 * non-finite values are written as null. REPORT_MAX bytes always suffice. */
int report_format(const run_record_t *rec, char *buf, size_t len);

#define REPORT_MAX 12288   /* 4096 and two arrays of RUN_RANKS_MAX 20-digit counts */

/* The curves of a RUN_CURVES record (rec->curves) as JSON lines, one per observable family, into buf
 * (format: docs/output.md, observables.jsonl); sample: the index of this sample in the run (0, 1, ...).
 * Curve values are printed with 9 significant digits, non-finite ones as null; ensembles
 * (rec->replicas > 1) add the standard errors. Returns the length written, or -1 if buf is too small:
 * report_curves_max() bytes always suffice for the curves of one scene. */
int report_curves(const run_record_t *rec, uint64_t sample, char *buf, size_t len);
size_t report_curves_max(const obs_curves_t *c);
