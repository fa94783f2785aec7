/* Initial states beyond the engines' own placement: a lattice or random packing in a region of the box, and the checks of a given state. */
#pragma once

#include <stddef.h>
#include <stdint.h>
#include "scene.h"

/*
 * Contract
 * - Pure: no I/O, no globals; msg (msglen bytes, may be NULL) receives one
 *   line "KEY.PATH: reason" on error.
 * - The region (scene.h, particles.initial.region) is in scene
 *   coordinates. Particles are placed whole inside it: centres in
 *   [lower + radius, upper - radius] per axis, and on a walled axis also
 *   out of the walls' reach (radius plus twice a vibration amplitude, as
 *   the engines place). An axis the region spans whole (lower 0, upper the
 *   edge) stays periodic when the box is.
 * - "lattice": the ed engine's lattice (rectangular with staggered rows in
 *   2D, FCC in 3D) chosen for N sites in the region's centre range, its
 *   vacancies spread by lattice.h. "random": random sequential addition
 *   without overlap for ed, uniform for dsmc/hsmc (point particles, as the
 *   engines place in the whole box).
 * - Deterministic: the draws come from the stream (seed, stream | 2^61),
 *   apart from the engines' own streams.
 * - Mixtures (scene_has_species(): several species or polydisperse radii;
 *   ed only): every particle has its own radius (scene_species_radii(), the
 *   engine's draws). "random" places the largest first, each centre its own
 *   radius from the region's faces, the walls and the obstacles, and pairs
 *   at least r_i + r_j apart; "lattice" is the lattice of the largest radius
 *   (s->radius), its sites shuffled among the particles so the species mix.
 *   The checks of a given state use the same per-particle radii.
 */

enum {
	PLACE_OK = 0,
	PLACE_EINVAL = -1,   /* the scene's region or the given state is not usable */
	PLACE_ENOMEM = -2,
	PLACE_EPLACE = -3,   /* random placement ran out of tries */
};

/* Largest overlap of two hard particles (and of a particle and a wall) a
 * given state may have, in diameters: rounding in an earlier run, not a
 * real overlap. */
#define PLACE_OVERLAP_TOL 1e-9

/* The start check of a scene with a region: the region inside the box and
 * wide enough, and N particles placeable there (lattice: nearest distance
 * >= one diameter for ed; random: below random sequential addition's
 * jamming coverage for ed; any method: below close packing). PLACE_OK for
 * a scene without a region. */
int place_check(const scene_t *s, char *msg, size_t msglen);

/* Place the N particles of s (with a region) in pos (N * dim doubles,
 * caller's). PLACE_OK, PLACE_EINVAL (place_check() fails), PLACE_EPLACE,
 * PLACE_ENOMEM. */
int place_region(const scene_t *s, uint64_t stream, double *pos, char *msg, size_t msglen);

/* Check a given state against scene s (from: an earlier run's frame):
 * every entry finite, every centre in the box (periodic axes [0, L]; a
 * centre at L is folded to 0 in pos) and at least a radius from the walls
 * where they are at time 0, and for ed no two particles closer than a
 * diameter, each up to PLACE_OVERLAP_TOL. key names the source in msg
 * ("particles.initial.from"). */
int place_check_state(const scene_t *s, double *pos, const double *vel, const char *key, char *msg,
                      size_t msglen);

const char *place_strerror(int code);
