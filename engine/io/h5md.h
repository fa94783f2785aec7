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
 *   and is replaced atomically (write + rename) after each frame (ensembles:
 *   after the frames of one output time).
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
/* Particles groups of a trajectory of scene s: 1 (/particles/all) for a
 * single run; for an ensemble R (/particles/replica_K, K = 0..R-1) with
 * output.snapshots, else 0 (no frames). */
int h5md_groups(const scene_t *s);
/* Open an existing file for appending (resume): observables are truncated to
 * obs_rows rows and particles group k to frames[k] frames (h5md_groups(s)
 * entries; rows written after a checkpoint), and the XDMF is rewritten. */
h5md_t *h5md_open_append(const char *path, const scene_t *s, uint64_t obs_rows, const uint64_t *frames,
                         int *err, char *msg, size_t msglen);
/* Close; destroy(NULL) is a no-op. Returns the first error seen on close. */
int h5md_destroy(h5md_t *h);

int h5md_observables(h5md_t *h, const run_record_t *rec, char *msg, size_t msglen);
/* A frame of a single run into /particles/all: h5md_frame(h, 0) + h5md_frames_done(). */
int h5md_snapshot(h5md_t *h, const run_record_t *rec, char *msg, size_t msglen);
/* Append a frame (rec: RUN_SNAPSHOT, pos/vel N*D doubles) to particles group
 * `group` (0 .. h5md_groups()-1; ensembles: the replica index) without
 * flushing; h5md_frames_done() then flushes and rewrites the XDMF once for
 * the frames appended since (a no-op when there are none). */
int h5md_frame(h5md_t *h, int group, const run_record_t *rec, char *msg, size_t msglen);
int h5md_frames_done(h5md_t *h, char *msg, size_t msglen);
int h5md_flush(h5md_t *h, char *msg, size_t msglen);
/* The run ended in an inelastic collapse (run.h, RUN_COLLAPSED) at time:
 * attributes inelastic_collapse (message) and inelastic_collapse_time on
 * /observables (replacing earlier ones), flushed. */
int h5md_collapse(h5md_t *h, double time, const char *message, char *msg, size_t msglen);
/* fields (output.fields, single runs): a RUN_CURVES record's fields tables as one row of
 * /observables/fields_* (docs/output.md), and its density_spectrum as one row of
 * /observables/density_spectrum_*; a no-op without them. h5md_fields_cut(): after
 * h5md_open_append(), drop the rows after time t_ckpt (a resumed run writes them again). */
int h5md_fields(h5md_t *h, const run_record_t *rec, char *msg, size_t msglen);
int h5md_fields_cut(h5md_t *h, double t_ckpt, char *msg, size_t msglen);
/* Rows of observables and frames appended so far (frames: all groups together). */
void h5md_rows(const h5md_t *h, uint64_t *obs_rows, uint64_t *snap_rows);

const char *h5md_strerror(int code);
