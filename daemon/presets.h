/* Built-in scenes ("presets") served by the daemon, embedded at build time from presets/ *.json. */
#pragma once

#include <stddef.h>
#include <jansson.h>

/*
 * Contract
 * - The preset texts are compiled in (daemon/presets_json.h, generated from
 *   presets/ *.json by Makefile.am): no file lookups at run time.
 * - A preset's name is its file name without ".json". Every preset must pass
 *   scene_parse(); tests/presets_test.c checks that.
 * - Functions returning json_t give the caller a new reference (json_decref it).
 * - No global mutable state: safe to call from any HTTP thread.
 */

enum {
	PRESETS_OK = 0,
	PRESETS_ENOTFOUND = -1,   /* no preset of that name */
	PRESETS_EINVAL = -2,      /* an embedded preset does not parse (a build bug) */
	PRESETS_ENOMEM = -3,
};

/* Number of embedded presets and the name of preset i (i < presets_count()). */
size_t presets_count(void);
const char *presets_name(size_t i);

/* The embedded scene text of preset name, or NULL when there is none. */
const char *presets_text(const char *name);

/* One preset as {"name", "description", "dimensions", "method", "particles", "scene"}.
 * On error *out is NULL and err holds one line. */
int presets_get(const char *name, json_t **out, char *err, size_t errlen);

/* All presets as {"presets": [ ...as presets_get... ]}, in file order. */
int presets_list(json_t **out, char *err, size_t errlen);

const char *presets_strerror(int code);
