/* JSON-lines serialisation of run records (the engine's progress protocol). */
#pragma once

#include <stddef.h>
#include "run.h"

/* Format rec as one JSON object followed by '\n' into buf. Returns the
 * length written (excluding the NUL), or -1 if buf is too small.
 * Doubles are printed with 17 significant digits (exact round trip);
 * non-finite values are written as null. REPORT_MAX bytes always suffice. */
int report_format(const run_record_t *rec, char *buf, size_t len);

#define REPORT_MAX 4096
