/* Unit tests of the embedded dashboard (daemon/dashboard.c): bytes equal the source files, CSP-safe index, links resolve. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "dashboard.h"
#include "tap.h"

/* Read $SRCDIR/dashboard/NAME or $SRCDIR/dashboard/vendor/NAME; NULL when neither opens. */
static char *slurp(const char *name, size_t *len)
{
	const char *src = getenv("SRCDIR");
	static const char *const dirs[] = {"dashboard", "dashboard/vendor"};
	char path[4096];
	for (size_t d = 0; d < 2; d++) {
		snprintf(path, sizeof(path), "%s/%s/%s", src ? src : ".", dirs[d], name);
		FILE *f = fopen(path, "rb");
		if (!f)
			continue;
		fseek(f, 0, SEEK_END);
		long n = ftell(f);
		rewind(f);
		char *b = malloc((size_t)n + 1);
		if (b && fread(b, 1, (size_t)n, f) != (size_t)n) {
			free(b);
			b = NULL;
		}
		fclose(f);
		if (b)
			b[n] = '\0';
		*len = (size_t)n;
		return b;
	}
	return NULL;
}

int main(void)
{
	dashboard_file_t f, idx;
	size_t n = dashboard_count();
	ok(n >= 5, "%zu files embedded", n);
	for (size_t i = 0; i < n; i++) {
		size_t len = 0;
		dashboard_file(i, &f);
		char *src = slurp(f.name, &len);
		/* The embedding ends every line with \n: a file without a final newline gains one. */
		int same = src && (f.len == len || (f.len == len + 1 && f.data[len] == '\n')) && !memcmp(f.data, src, len);
		ok(same, "%s: embedded bytes equal the source file (%zu bytes, %s)", f.name, f.len, f.ctype);
		free(src);
	}
	ok(dashboard_find("index.html", &idx) == 0 && strstr(idx.ctype, "text/html"), "index.html is text/html");
	ok(dashboard_find("app.js", &f) == 0 && strstr(f.ctype, "javascript"), "app.js is JavaScript");
	ok(dashboard_find("nope.js", &f) == -1, "unknown file: -1");
	/* CSP default-src 'self': no inline script or handler, every script has a src. */
	int inline_js = 0, missing = 0;
	for (const char *p = idx.data; (p = strstr(p, "<script")); p++)
		inline_js += !strstr(p, "src=\"/static/") || strstr(p, "src=\"/static/") > strchr(p, '>');
	inline_js += strstr(idx.data, " onclick=") != NULL || strstr(idx.data, " onload=") != NULL;
	ok(!inline_js, "index.html has no inline scripts or handlers");
	for (const char *p = idx.data; (p = strstr(p, "\"/static/")); p++) {
		char name[128];
		if (sscanf(p + 9, "%127[^\"]", name) == 1 && dashboard_find(name, &f))
			missing++, diag("index.html links /static/%s, which is not embedded", name);
	}
	ok(!missing, "every /static/ link of index.html is embedded");
	plan(tap_n);
	return tap_failed != 0;
}
