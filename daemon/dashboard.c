/* Embedded dashboard files: lookup by name and Content-Type by extension. */
#include <config.h>
#include <string.h>
#include "dashboard.h"
#include "daemon/dashboard_files.h"   /* generated: dashboard_files[] = {{name, data, len}, ...} */

#define NFILES (sizeof(dashboard_files) / sizeof(dashboard_files[0]))

static const struct { const char *ext, *ctype; } types[] = {
	{.ext = ".html", .ctype = "text/html; charset=utf-8"},
	{.ext = ".js", .ctype = "text/javascript; charset=utf-8"},
	{.ext = ".css", .ctype = "text/css; charset=utf-8"},
};

size_t dashboard_count(void) { return NFILES; }

int dashboard_file(size_t i, dashboard_file_t *out)
{
	if (i >= NFILES)
		return -1;
	const char *dot = strrchr(dashboard_files[i].name, '.');
	out->name = dashboard_files[i].name;
	out->data = dashboard_files[i].data;
	out->len = dashboard_files[i].len;
	out->ctype = "application/octet-stream";
	for (size_t k = 0; dot && k < sizeof(types) / sizeof(types[0]); k++)
		if (!strcmp(dot, types[k].ext))
			out->ctype = types[k].ctype;
	return 0;
}

int dashboard_find(const char *name, dashboard_file_t *out)
{
	for (size_t i = 0; name && i < NFILES; i++)
		if (!strcmp(dashboard_files[i].name, name))
			return dashboard_file(i, out);
	return -1;
}
