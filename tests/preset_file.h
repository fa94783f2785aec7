/* Where the unit tests that check a preset's published result find the preset: presets/FILE under $SRCDIR. */
#ifndef GRANULAR_TESTS_PRESET_FILE_H
#define GRANULAR_TESTS_PRESET_FILE_H

#include <stdio.h>
#include <stdlib.h>

/* path = $SRCDIR/presets/FILE (SRCDIR unset or empty: the current directory); returns path. */
static inline const char *preset_path(const char *file, char *path, size_t cap)
{
	const char *src = getenv("SRCDIR");
	snprintf(path, cap, "%s/presets/%s", src && *src ? src : ".", file);
	return path;
}

/* The preset's text into text[0 .. cap-1], NUL-terminated; its length, 0 when it cannot be read. */
static inline size_t preset_text(const char *file, char *text, size_t cap)
{
	char path[4096];
	FILE *f = fopen(preset_path(file, path, sizeof path), "r");
	size_t len = f ? fread(text, 1, cap - 1, f) : 0;
	if (f)
		fclose(f);
	text[len] = '\0';
	return len;
}

#endif
