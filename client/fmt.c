/* Human formatting helpers for granularctl's tables and progress bar. */
#include <math.h>
#include <stdio.h>
#include "fmt.h"

char *fmt_age(double s, char *buf, size_t n)
{
	if (!isfinite(s)) {
		snprintf(buf, n, "-");
		return buf;
	}
	if (s < 0)
		s = 0;   /* a clock slightly ahead of ours */
	if (s < 60)
		snprintf(buf, n, "%.0fs", floor(s));
	else if (s < 3600)
		snprintf(buf, n, "%.0fm", floor(s / 60));
	else if (s < 86400)
		snprintf(buf, n, "%.0fh", floor(s / 3600));
	else
		snprintf(buf, n, "%.0fd", floor(s / 86400));
	return buf;
}

char *fmt_duration(double s, char *buf, size_t n)
{
	if (!isfinite(s) || s < 0) {
		snprintf(buf, n, "?");
		return buf;
	}
	long t = lround(s);
	if (t >= 3600)
		snprintf(buf, n, "%ld:%02ld:%02ld", t / 3600, t / 60 % 60, t % 60);
	else
		snprintf(buf, n, "%ld:%02ld", t / 60, t % 60);
	return buf;
}

char *fmt_si(double v, char *buf, size_t n)
{
	static const char units[] = " kMGTP";
	int u = 0;
	if (!isfinite(v)) {
		snprintf(buf, n, "-");
		return buf;
	}
	while (fabs(v) >= 1000 && u < 5) {
		v /= 1000;
		u++;
	}
	if (u == 0)
		snprintf(buf, n, "%.0f", v);
	else
		snprintf(buf, n, fabs(v) < 10 ? "%.2f%c" : fabs(v) < 100 ? "%.1f%c" : "%.0f%c", v, units[u]);
	return buf;
}

char *fmt_bar(double frac, int width, char *buf, size_t n)
{
	if (!isfinite(frac) || frac < 0)
		frac = 0;
	if (frac > 1)
		frac = 1;
	int full = (int)(frac * width + 0.5);
	size_t o = 0;
	if (n < (size_t)width + 3) {
		if (n)
			buf[0] = '\0';
		return buf;
	}
	buf[o++] = '[';
	for (int i = 0; i < width; i++)
		buf[o++] = i < full ? '#' : '-';
	buf[o++] = ']';
	buf[o] = '\0';
	return buf;
}

char *fmt_num(double v, const char *conv, char *buf, size_t n)
{
	if (!isfinite(v))
		snprintf(buf, n, "-");
	else
		snprintf(buf, n, conv, v);
	return buf;
}
