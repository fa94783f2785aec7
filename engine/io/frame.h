/* Reading one frame of an earlier run's H5MD trajectory as the initial state of a scene (particles.initial.from). */
#pragma once

#include <stddef.h>
#include "scene.h"

/*
 * Contract
 * - frame_load() reads frame s->from_frame (negative: from the end, -1 the
 *   last) of /particles/all (s->from_replica >= 0: /particles/replica_K)
 *   of the H5MD file at path (written by granular-engine, docs/output.md):
 *   positions and velocities, N * dim doubles each, particle i at
 *   [i * dim], as stored (no unit conversion: the scene's own units).
 * - Checks, each a one-line "KEY: reason" in msg: the file readable and a
 *   trajectory (key: particles.initial.from.file, or .job when s->from_job),
 *   the frame in range (particles.initial.from.frame), the frame's
 *   dimension and particle count equal to the scene's, and the state usable
 *   (place_check_state(): finite, inside the box, no overlap for ed) (key:
 *   particles.initial.from).
 * - Rough particles (s->rough): also the frame's angular velocities
 *   (/angular_velocity, N * (1 in 2D, 3 in 3D)) into *spin; a frame
 *   without them is refused. Smooth scenes: *spin is NULL (a rough run's
 *   spins are not read).
 * - *pos, *vel (and *spin) are malloc()ed on success (caller frees), NULL
 *   otherwise.
 * - No output on stderr; HDF5's error printing is silenced.
 */

enum {
	FRAME_OK = 0,
	FRAME_EINVAL = -1,   /* missing or unusable file, frame, or state: the scene's error (exit 2) */
	FRAME_ENOMEM = -2,
};

int frame_load(const scene_t *s, const char *path, double **pos, double **vel, double **spin, char *msg,
               size_t msglen);

const char *frame_strerror(int code);
