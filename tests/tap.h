/* Minimal TAP producer for C unit tests (one plan, numbered ok lines, diagnostics). */
#pragma once

#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>

static int tap_n, tap_failed;

static inline void plan(int n) { printf("1..%d\n", n); fflush(stdout); }

static inline void diag(const char *fmt, ...)
{
	va_list ap;
	va_start(ap, fmt);
	printf("# ");
	vprintf(fmt, ap);
	printf("\n");
	va_end(ap);
	fflush(stdout);
}

/* ok(cond, fmt, ...): one test point; returns cond so callers can branch. */
static inline int ok(int cond, const char *fmt, ...)
{
	va_list ap;
	va_start(ap, fmt);
	tap_n++;
	if (!cond)
		tap_failed++;
	printf("%sok %d - ", cond ? "" : "not ", tap_n);
	vprintf(fmt, ap);
	printf("\n");
	va_end(ap);
	fflush(stdout);
	return cond;
}

static inline void skip(const char *why) { tap_n++; printf("ok %d # SKIP %s\n", tap_n, why); }

static inline int done_testing(void)
{
	return tap_failed ? EXIT_FAILURE : EXIT_SUCCESS;
}
