/* Unit tests of the built-in presets (daemon/presets.c): every one passes the engine's scene parser and is described. */
#include <dirent.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "presets.h"
#include "scene.h"
#include "tap.h"

/* Files in $SRCDIR/presets ending in .json; -1 when the directory cannot be read. */
static int count_files(void)
{
	const char *src = getenv("SRCDIR");
	char dir[4096];
	int n = 0;
	snprintf(dir, sizeof(dir), "%s/presets", src ? src : ".");
	DIR *d = opendir(dir);
	if (!d)
		return -1;
	for (struct dirent *e; (e = readdir(d));) {
		size_t l = strlen(e->d_name);
		n += l > 5 && !strcmp(e->d_name + l - 5, ".json");
	}
	closedir(d);
	return n;
}

int main(void)
{
	char err[256];
	size_t n = presets_count();
	int dims = 0, cooling = 0, clustering = 0;
	json_t *j = NULL;

	ok(n >= 4, "at least four presets embedded (%zu)", n);
	ok(count_files() == (int)n, "every presets/*.json is embedded (PRESETS in Makefile.am): %d files, %zu embedded",
	   count_files(), n);
	for (size_t i = 0; i < n; i++) {
		const char *name = presets_name(i), *text = presets_text(name);
		scene_t s;
		int r = scene_parse(text, strlen(text), &s, err, sizeof(err));
		ok(r == SCENE_OK, "preset %s passes scene_parse%s%s", name, r ? ": " : "", r ? err : "");
		if (r != SCENE_OK)
			continue;
		dims |= 1 << s.dim;
		cooling |= !strncmp(name, "cooling-", 8);
		clustering |= !strncmp(name, "clustering-", 11);
		r = presets_get(name, &j, err, sizeof(err));
		ok(r == PRESETS_OK && json_integer_value(json_object_get(j, "dimensions")) == s.dim &&
		       json_integer_value(json_object_get(j, "particles")) == (json_int_t)s.count &&
		       strlen(json_string_value(json_object_get(j, "description"))) > 10 &&
		       json_is_object(json_object_get(j, "scene")),
		   "presets_get(%s): dimensions, particles, a description and the scene", name);
		/* small enough for a demo on a laptop: at most 10^5 particles, a finite end */
		ok(s.count <= 100000 && s.until.kind != SCENE_CLOCK_NONE, "preset %s is demo-sized (N=%llu)", name,
		   (unsigned long long)s.count);
		json_decref(j);
		j = NULL;
	}
	ok(dims == ((1 << 2) | (1 << 3)) && cooling && clustering, "cooling and clustering presets, in 2D and 3D");
	ok(presets_get("no-such", &j, err, sizeof(err)) == PRESETS_ENOTFOUND && !j && strstr(err, "no-such"),
	   "unknown preset: PRESETS_ENOTFOUND naming it");
	ok(presets_list(&j, err, sizeof(err)) == PRESETS_OK && json_array_size(json_object_get(j, "presets")) == n,
	   "presets_list lists all %zu", n);
	json_decref(j);
	plan(tap_n);
	return tap_failed != 0;
}
