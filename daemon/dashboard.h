/* The web dashboard's static files (dashboard/ *), embedded at build time and served at / and /static/{name}. */
#pragma once

#include <stddef.h>

/*
 * Contract
 * - The files are compiled in (daemon/dashboard_files.h, generated from
 *   dashboard/ by Makefile.am): no file lookups at run time. The data is
 *   static storage, never freed; no mutable state, safe from any thread.
 * - A file's name is its base name ("app.js", "uPlot.min.css").
 */

typedef struct {
	const char *name;
	const char *data;    /* len bytes (NUL-terminated as well) */
	size_t len;
	const char *ctype;   /* Content-Type from the extension */
} dashboard_file_t;

/* Fill *out with the file called name; returns 0, or -1 when there is none. */
int dashboard_find(const char *name, dashboard_file_t *out);

/* Number of files; file i (i < dashboard_count()) into *out, returns 0 or -1. */
size_t dashboard_count(void);
int dashboard_file(size_t i, dashboard_file_t *out);
