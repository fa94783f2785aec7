/* Daemon logging to stderr with syslog-style <N> priority prefixes that journald understands. */
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "log.h"

/* The one process-wide setting, written once at start-up before threads exist. */
static log_level_t level = LOG_INFO;

void log_set_level(log_level_t l) { level = l; }

int log_parse_level(const char *name)
{
	static const char *const names[] = {"error", "warning", "info", "debug"};
	for (int i = 0; i < 4; i++)
		if (!strcmp(name, names[i]))
			return i;
	return -1;
}

void log_msg(log_level_t l, const char *fmt, ...)
{
	static const int prio[] = {3, 4, 6, 7};
	static const char *const names[] = {"error", "warning", "info", "debug"};
	char buf[2048];
	va_list ap;
	if (l > level)
		return;
	va_start(ap, fmt);
	vsnprintf(buf, sizeof(buf), fmt, ap);
	va_end(ap);
	if (getenv("JOURNAL_STREAM"))   /* journald reads the <N> priority prefix */
		fprintf(stderr, "<%d>%s\n", prio[l], buf);
	else
		fprintf(stderr, "granulard: %s: %s\n", names[l], buf);
}
