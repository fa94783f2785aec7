/* H5MD 1.1 trajectory writer: snapshots, observables and parameters of a run in one HDF5 file, plus an XDMF sidecar. */
#pragma once

#include <stddef.h>
#include <stdint.h>
#include "run.h"
#include "scene.h"

/*
 * Contract
 * - One writer per file, serial (HDF5 sec2 driver), rank 0 only. Layout,
 *   units and conventions: docs/output.md.
 * - Observables rows come from RUN_PROGRESS records, frames from
 *   RUN_SNAPSHOT records (run.h); both are appended (unlimited first
 *   dimension, chunked, shuffle + deflate at scene.compression).
 * - h5md_flush() makes everything appended so far durable (H5Fflush, then
 *   fsync of the file); call it before writing a checkpoint that records
 *   h5md_rows().
 * - The XDMF sidecar (same path with .xdmf instead of .h5) lists every frame
 *   and is replaced atomically (write + rename) after each frame.
 * - Functions return H5MD_OK or a negative H5MD_E* code with a one-line
 *   reason in msg (msglen bytes, may be NULL). No output on stderr.
 */

typedef struct h5md h5md_t;

enum {
	H5MD_OK = 0,
	H5MD_EIO = -1,        /* HDF5 or file-system failure */
	H5MD_ENOMEM = -2,
	H5MD_EFORMAT = -3,    /* existing file does not have the expected layout */
};

/* Create (truncate) path for scene s; scene_text (len bytes) is stored
 * verbatim under /parameters/scene. */
h5md_t *h5md_create(const char *path, const scene_t *s, const char *scene_text, size_t len,
                    int *err, char *msg, size_t msglen);
/* Open an existing file for appending (resume): observables are truncated to
 * obs_rows rows and frames to snap_rows (rows written after a checkpoint). */
h5md_t *h5md_open_append(const char *path, const scene_t *s, uint64_t obs_rows, uint64_t snap_rows,
                         int *err, char *msg, size_t msglen);
/* Close; destroy(NULL) is a no-op. Returns the first error seen on close. */
int h5md_destroy(h5md_t *h);

int h5md_observables(h5md_t *h, const run_record_t *rec, char *msg, size_t msglen);
int h5md_snapshot(h5md_t *h, const run_record_t *rec, char *msg, size_t msglen);
int h5md_flush(h5md_t *h, char *msg, size_t msglen);
/* Rows of observables and frames appended so far. */
void h5md_rows(const h5md_t *h, uint64_t *obs_rows, uint64_t *snap_rows);

const char *h5md_strerror(int code);
