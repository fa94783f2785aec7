/* Crash-safe checkpoint files: the complete state of a run in HDF5, verified by a digest on load. */
#pragma once

#include <stddef.h>
#include <stdint.h>
#include "mc/dsmcp.h"
#include "run.h"
#include "scene.h"

/*
 * Contract
 * - A checkpoint holds the scene text, every engine state field (ed.h), the
 *   run's schedule position (run_state_t) and the output positions below,
 *   plus a 64-bit digest over all of them. Layout: docs/output.md.
 * - ckpt_write() writes DIR/checkpoint.tmp.h5, closes it, fsyncs it, keeps
 *   the previous DIR/checkpoint.h5 as DIR/checkpoint.prev.h5 (hard link, so
 *   checkpoint.h5 never disappears), renames the new file over
 *   DIR/checkpoint.h5 and fsyncs DIR.
 * - The file begins with a 512-byte HDF5 user block: a magic string, the
 *   file's length and a digest of the rest (written after HDF5 closed the
 *   file). ckpt_read() checks it before HDF5 reads the file, so a damaged or
 *   truncated file is refused without HDF5 parsing it (HDF5 1.10 crashes on
 *   some damaged files). A file crafted with a matching digest still reaches
 *   HDF5: the digest guards against damage, not against an attacker. Files
 *   of format 1 (no user block) are refused as CKPT_ECORRUPT.
 * - ckpt_read() refuses a file whose scene differs from the given one
 *   (CKPT_ESCENE: an intact file, digest verified against its own stored
 *   scene) and reports a damaged or truncated one as CKPT_ECORRUPT
 *   (unreadable HDF5, missing field, wrong digest, inconsistent state, a
 *   stored scene that was altered or no longer parses): callers fall back
 *   to DIR/checkpoint.prev.h5 on CKPT_ECORRUPT, never on CKPT_ESCENE.
 * - Serial (sec2 driver); no output on stderr: one-line reasons go to msg.
 */

enum {
	CKPT_OK = 0,
	CKPT_EIO = -1,        /* cannot write (disk full, permissions) */
	CKPT_ENOMEM = -2,
	CKPT_ECORRUPT = -3,   /* unreadable, truncated or altered file */
	CKPT_ESCENE = -4,     /* written for another scene */
	CKPT_EMISSING = -5,   /* no such file */
};

/* Where the outputs stood when the checkpoint was taken: a resumed run
 * truncates them back to this. */
typedef struct {
	uint64_t obs_rows;        /* observable rows in trajectory.h5 */
	uint64_t snap_rows;       /* frames in trajectory.h5 */
	uint64_t progress_bytes;  /* length of progress.jsonl */
} ckpt_output_t;

int ckpt_write(const char *dir, run_t *run, const char *scene_text, size_t len,
               const ckpt_output_t *out, char *msg, size_t msglen);

/* Load path into a new run for scene s (whose text is scene_text) with
 * options opts; *run_out receives it (caller destroys with run_destroy). */
int ckpt_read(const char *path, const scene_t *s, const char *scene_text, size_t len,
              const run_opts_t *opts, run_t **run_out, ckpt_output_t *out, char *msg, size_t msglen);

/* Ensembles (run.replicas > 1): one file, written by rank 0, holding every
 * replica's state string (ensemble.h: ensemble_save()) under /replica_K and
 * the ensemble's own schedule. ckpt_read_ensemble() fills blobs[R] and
 * lens[R] (malloc'd, caller frees) after checking the digest and that every
 * replica loads (ensemble_load()); same error codes as ckpt_read(). */
typedef struct {
	uint64_t k_ckpt;          /* index of the next simulated-time checkpoint */
	double wall_before;       /* wall seconds spent before this process */
} ckpt_ensemble_t;

int ckpt_write_ensemble(const char *dir, int R, unsigned char *const *blobs, const size_t *lens,
                        const ckpt_ensemble_t *es, const char *scene_text, size_t len, const ckpt_output_t *out,
                        char *msg, size_t msglen);
int ckpt_read_ensemble(const char *path, const scene_t *s, const char *scene_text, size_t len,
                       unsigned char **blobs, size_t *lens, ckpt_ensemble_t *es, ckpt_output_t *out,
                       char *msg, size_t msglen);

/* Split runs (one dsmc/hsmc system over MPI ranks, engine/par/dsmcrun.h):
 * rank 0 writes the state gathered in the 1-rank order (dsmcp.h) under
 * /dsmcp (docs/output.md), so that a run of any rank count resumes it.
 * ckpt_read_split() fills *ck (arrays malloc'd: dsmcp_saved_free()) after
 * the digest and dsmcp_saved_check(); same error codes as ckpt_read(). */
typedef struct {
	dsmcp_saved_t state;
	run_state_t sched;        /* started, k_out, k_snap, k_ckpt, snap_events (events at the last frame,
	                           * UINT64_MAX: none), wall_before */
	uint64_t coll_sample;     /* collisions at the last progress record */
} ckpt_split_t;
int ckpt_write_split(const char *dir, const ckpt_split_t *ck, const char *scene_text, size_t len,
                     const ckpt_output_t *out, char *msg, size_t msglen);
int ckpt_read_split(const char *path, const scene_t *s, const char *scene_text, size_t len, ckpt_split_t *ck,
                    ckpt_output_t *out, char *msg, size_t msglen);
/* Whether the checkpoint a resume from path would use (path, or CKPT_PREV
 * beside it when path does not verify) holds a split run's state: 1 yes,
 * 0 no (a run on one rank or an ensemble), -1 neither file verifies. */
int ckpt_is_split(const char *path);

/* File names inside an output directory. */
#define CKPT_FILE "checkpoint.h5"
#define CKPT_PREV "checkpoint.prev.h5"
#define CKPT_TMP "checkpoint.tmp.h5"

const char *ckpt_strerror(int code);
