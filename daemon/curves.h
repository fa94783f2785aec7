/* Curves of a job for the API: the samples of one observable family from DIR/observables.jsonl, read with bounded memory. */
#pragma once

#include <stddef.h>
#include <stdint.h>
#include <jansson.h>

/*
 * Contract
 * - DIR/observables.jsonl holds one JSON object per line and family
 *   ({"name": family, "sample": k, ...}; docs/output.md), appended by the
 *   engine while the job runs: a last line without its newline is being
 *   written and is not read.
 * - Memory: lines are read one at a time and only those of the family asked
 *   for are parsed; at most `count` samples are kept, and at most
 *   CURVES_MAX_BYTES of their text: beyond it the answer is cut
 *   ("truncated": true, "next" says where to go on). A line of the family
 *   longer than CURVES_MAX_LINE is an error (CURVES_EIO), not parsed; other
 *   families' lines are skipped whatever their length.
 * - No HTTP: the handler parses the query and serialises the result.
 */

#define CURVES_MAX_LINE (16u << 20)
#define CURVES_MAX_BYTES (32u << 20)

enum { CURVES_OK = 0, CURVES_ENAME = -1, CURVES_EIO = -2, CURVES_ENOMEM = -3 };

/* The observable families that write curves (output.observables names), NULL-terminated. */
extern const char *const curves_families[];
/* 1 when name is one of them. */
int curves_known(const char *name);

/*
 * The samples of family name with sample index > after: the first `count`
 * (tail = 0) or the last `count` (tail = 1), in file order, as
 * {"name", "samples": [...], "next": the largest sample index returned (or
 * after when none), "truncated": bool}. An absent file gives no samples (a
 * job that has not started, or asks for no curves). CURVES_ENAME for an
 * unknown family (err says which are known), CURVES_EIO, CURVES_ENOMEM.
 */
int curves_read(const char *dir, const char *name, long long after, int count, int tail, json_t **out, char *err,
                size_t errlen);

const char *curves_strerror(int code);
