/* Fuzz-input form of an HTTP request for the API harness: parse "METHOD TARGET ...\n", "Name: value" lines, blank line, body. */
#pragma once

#include <ctype.h>
#include <stddef.h>
#include <string.h>
#include <strings.h>

/*
 * The text reads as a raw HTTP/1.1 request (curl --trace output or nc input
 * can seed it). Parsing is lenient (it is the fuzzer's input, not a
 * client's): CRLF or LF, at most FZ_MAXH headers and FZ_MAXQ query pairs;
 * whatever does not fit is dropped. All strings point into one copy of the
 * input owned by the caller, NUL-terminated in place.
 */

#define FZ_MAXH 16
#define FZ_MAXQ 16

typedef struct {
	const char *method, *path;
	const char *hname[FZ_MAXH], *hval[FZ_MAXH];
	int nh;
	const char *qkey[FZ_MAXQ], *qval[FZ_MAXQ];
	int nq;
	const char *body;
	size_t body_len;
} fz_req_t;

static int fz_hex(int c)
{
	return c >= '0' && c <= '9' ? c - '0' : c >= 'a' && c <= 'f' ? c - 'a' + 10 : c >= 'A' && c <= 'F' ? c - 'A' + 10 : -1;
}

/* Percent-decoding in place (with '+' as space for query strings), as a
 * server would; %00 is kept encoded so strings stay whole. */
static void fz_unescape(char *s, int plus)
{
	char *w = s;
	for (char *r = s; *r; r++) {
		if (r[0] == '%' && fz_hex(r[1]) >= 0 && fz_hex(r[2]) >= 0 && (fz_hex(r[1]) | fz_hex(r[2]))) {
			*w++ = (char)(fz_hex(r[1]) * 16 + fz_hex(r[2]));
			r += 2;
		} else {
			*w++ = plus && *r == '+' ? ' ' : *r;
		}
	}
	*w = '\0';
}

/* Cut the next line (LF or CRLF) from *p (< end); NULL at the end. */
static char *fz_line(char **p, char *end)
{
	if (*p >= end)
		return NULL;
	char *s = *p, *nl = memchr(s, '\n', (size_t)(end - s));
	char *e = nl ? nl : end;
	*p = nl ? nl + 1 : end;
	if (e > s && e[-1] == '\r')
		e--;
	*e = '\0';
	return s;
}

/* buf: len bytes plus one spare for a NUL; modified in place. 0, or -1
 * without a request line. decode(s, plus) percent-decodes the path (plus 0)
 * and each query key and value (plus 1: '+' is a space) in place. */
static int fz_parse_as(char *buf, size_t len, fz_req_t *r, void (*decode)(char *s, int plus))
{
	char *p = buf, *end = buf + len, *line;
	memset(r, 0, sizeof(*r));
	buf[len] = '\0';
	if (!(line = fz_line(&p, end)))
		return -1;
	char *sp = strchr(line, ' ');
	if (!sp)
		return -1;
	*sp = '\0';
	r->method = line;
	char *target = sp + 1, *v = strchr(target, ' ');
	if (v)
		*v = '\0';   /* the HTTP version is ignored */
	char *q = strchr(target, '?');
	if (q) {
		*q++ = '\0';
		for (char *save = NULL, *t = strtok_r(q, "&", &save); t && r->nq < FZ_MAXQ; t = strtok_r(NULL, "&", &save)) {
			char *eq = strchr(t, '=');
			if (eq)
				*eq++ = '\0';
			decode(t, 1);
			if (eq)
				decode(eq, 1);
			r->qkey[r->nq] = t;
			r->qval[r->nq++] = eq ? eq : "";
		}
	}
	decode(target, 0);
	r->path = target;
	while ((line = fz_line(&p, end)) && *line) {
		char *colon = strchr(line, ':');
		if (!colon || r->nh >= FZ_MAXH)
			continue;
		*colon++ = '\0';
		while (*colon == ' ' || *colon == '\t')
			colon++;
		r->hname[r->nh] = line;
		r->hval[r->nh++] = colon;
	}
	r->body = p < end ? p : "";
	r->body_len = p < end ? (size_t)(end - p) : 0;
	return 0;
}

static inline int fz_parse(char *buf, size_t len, fz_req_t *r)
{
	return fz_parse_as(buf, len, r, fz_unescape);
}

static const char *fz_header(const fz_req_t *r, const char *name)
{
	for (int i = 0; i < r->nh; i++)
		if (!strcasecmp(r->hname[i], name))
			return r->hval[i];
	return NULL;
}

static const char *fz_query(const fz_req_t *r, const char *key)
{
	for (int i = 0; i < r->nq; i++)
		if (!strcmp(r->qkey[i], key))
			return r->qval[i];
	return NULL;
}
