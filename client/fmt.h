/* Human formatting for granularctl: ages, durations, SI numbers, progress bars (pure functions, caller buffers). */
#pragma once

#include <stddef.h>

/* Each writes a NUL-terminated string into buf (n bytes) and returns buf. */
char *fmt_age(double seconds, char *buf, size_t n);       /* "42s", "7m", "3h", "2d"; "-" when NaN */
char *fmt_duration(double seconds, char *buf, size_t n);  /* "0:42", "1:02:03", "?" when negative/NaN */
char *fmt_si(double v, char *buf, size_t n);              /* "950", "12.3k", "1.40M", "2.1G" */
char *fmt_bar(double frac, int width, char *buf, size_t n); /* "[#####-----]" with width cells */
/* v through conv, a printf conversion of one double ("%.3g", "%.1f%%"), or "-" when v is NaN or infinite:
 * what a field the server sent as null (or not at all) reads as, never "nan". */
char *fmt_num(double v, const char *conv, char *buf, size_t n);
/* fmt_num into a buffer that lives until the end of the enclosing block (for printf arguments). */
#define FMT_NUM(v, conv) fmt_num((v), (conv), (char[48]){""}, 48)
