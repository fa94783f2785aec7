/* Human formatting for granularctl: ages, durations, SI numbers, progress bars (pure functions, caller buffers). */
#pragma once

#include <stddef.h>

/* Each writes a NUL-terminated string into buf (n bytes) and returns buf. */
char *fmt_age(double seconds, char *buf, size_t n);       /* "42s", "7m", "3h", "2d" */
char *fmt_duration(double seconds, char *buf, size_t n);  /* "0:42", "1:02:03", "?" when negative/NaN */
char *fmt_si(double v, char *buf, size_t n);              /* "950", "12.3k", "1.40M", "2.1G" */
char *fmt_bar(double frac, int width, char *buf, size_t n); /* "[#####-----]" with width cells */
