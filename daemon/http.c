/* libmicrohttpd glue: request bodies and limits, auth and Host/Origin checks, JSON and SSE responses. */
#define _GNU_SOURCE
#include <arpa/inet.h>
#include <errno.h>
#include <inttypes.h>
#include <microhttpd.h>
#include <netinet/in.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <sys/socket.h>
#include <unistd.h>
#include "http.h"
#include "log.h"
#include "util.h"

#define MAX_HOSTS 16

struct http {
	gd_t *gd;
	struct MHD_Daemon *d;
	int fd;
	int read_needs_token;
	char hosts[MAX_HOSTS][256];   /* accepted Host values on mutating requests */
	int nhosts;
};

typedef struct {
	char *body;
	size_t len, cap;
	int too_large;
} req_t;

typedef struct {
	gd_t *gd;
	int64_t job;
	uint64_t after;
	int started, done;
	char *buf;
	size_t len, off, cap;
} sse_t;

static const char *query_get(void *conn, const char *key)
{
	return MHD_lookup_connection_value(conn, MHD_GET_ARGUMENT_KIND, key);
}

static const char *header_get(void *conn, const char *key)
{
	return MHD_lookup_connection_value(conn, MHD_HEADER_KIND, key);
}

/* ---- server-sent events ------------------------------------------------------ */

static void sse_put(sse_t *s, const char *fmt, ...) __attribute__((format(printf, 2, 3)));
static void sse_put(sse_t *s, const char *fmt, ...)
{
	va_list ap;
	va_start(ap, fmt);
	int n = vsnprintf(NULL, 0, fmt, ap);
	va_end(ap);
	if (n < 0)
		return;
	if (s->len + (size_t)n + 1 > s->cap) {
		size_t cap = (s->len + (size_t)n + 1) * 2;
		char *b = realloc(s->buf, cap);
		if (!b)
			return;
		s->buf = b;
		s->cap = cap;
	}
	va_start(ap, fmt);
	vsnprintf(s->buf + s->len, (size_t)n + 1, fmt, ap);
	va_end(ap);
	s->len += (size_t)n;
}

static int terminal(const char *state)
{
	return state && (!strcmp(state, "succeeded") || !strcmp(state, "failed") || !strcmp(state, "cancelled"));
}

static ssize_t sse_read(void *cls, uint64_t pos, char *out, size_t max)
{
	sse_t *s = cls;
	while (s->off == s->len) {
		s->off = s->len = 0;
		if (s->done)
			return MHD_CONTENT_READER_END_OF_STREAM;
		if (!s->started) {
			s->started = 1;
			sse_put(s, "retry: 2000\n");
			if (s->job) {
				/* The current state first; later changes arrive as events
				 * (s->after was taken before this read, so none is missed). */
				json_t *j = NULL;
				char err[128];
				if (jobq_get(s->gd->q, s->job, 0, &j, err, sizeof(err)) != JOBQ_OK)
					return MHD_CONTENT_READER_END_WITH_ERROR;
				char *txt = json_dumps(j, JSON_COMPACT);
				sse_put(s, "id: %" PRIu64 "\nevent: state\ndata: %s\n\n", s->after, txt ? txt : "{}");
				if (terminal(json_string_value(json_object_get(j, "state"))))
					s->done = 1;
				free(txt);
				json_decref(j);
			} else {
				sse_put(s, "id: %" PRIu64 "\nevent: hello\ndata: {\"last\": %" PRIu64 "}\n\n", s->after, s->after);
			}
			continue;
		}
		hub_event_t ev;
		int r = hub_wait(s->gd->hub, &s->after, s->job, 15000, &ev);
		if (r == HUB_OK) {
			sse_put(s, "id: %" PRIu64 "\nevent: %s\ndata: %s\n\n", ev.seq, ev.type, ev.data);
			if (s->job && !strcmp(ev.type, "state")) {
				json_t *j = json_loads(ev.data, 0, NULL);
				if (terminal(json_string_value(json_object_get(j, "state"))))
					s->done = 1;
				json_decref(j);
			} else if (s->job && !strcmp(ev.type, "deleted")) {
				s->done = 1;
			}
			free(ev.data);
		} else if (r == HUB_ETIMEOUT) {
			sse_put(s, ": keep-alive\n\n");
		} else if (r == HUB_EGAP) {
			sse_put(s, "event: gap\ndata: {\"resume_after\": %" PRIu64 "}\n\n", s->after);
		} else {
			return MHD_CONTENT_READER_END_OF_STREAM;
		}
	}
	size_t n = s->len - s->off < max ? s->len - s->off : max;
	memcpy(out, s->buf + s->off, n);
	s->off += n;
	return (ssize_t)n;
}

static void sse_free(void *cls)
{
	sse_t *s = cls;
	free(s->buf);
	free(s);
}

/* ---- responses ---------------------------------------------------------------- */

static void common_headers(struct MHD_Response *r)
{
	MHD_add_response_header(r, "X-Content-Type-Options", "nosniff");
	MHD_add_response_header(r, "Content-Security-Policy", "default-src 'self'");
	MHD_add_response_header(r, "Referrer-Policy", "no-referrer");
}

static enum MHD_Result reply(http_t *h, struct MHD_Connection *c, api_resp_t *rs, const char *allow)
{
	struct MHD_Response *r;
	char *txt = NULL;
	enum MHD_Result ret;
	if (rs->sse) {
		sse_t *s = calloc(1, sizeof(*s));
		if (!s)
			return MHD_NO;
		s->gd = h->gd;
		s->job = rs->sse_job;
		s->after = hub_last(h->gd->hub);
		const char *lei = MHD_lookup_connection_value(c, MHD_HEADER_KIND, "Last-Event-ID");
		if (lei) {
			char *end;
			unsigned long long v = strtoull(lei, &end, 10);
			if (!*end && v <= s->after)
				s->after = v;
		}
		r = MHD_create_response_from_callback(MHD_SIZE_UNKNOWN, 4096, sse_read, s, sse_free);
		if (!r) {
			sse_free(s);
			return MHD_NO;
		}
		MHD_add_response_header(r, "Content-Type", "text/event-stream");
		MHD_add_response_header(r, "Cache-Control", "no-cache");
		MHD_add_response_header(r, "X-Accel-Buffering", "no");
	} else if (rs->has_file) {
		/* MHD sends from the descriptor (sendfile) and closes it with the response. */
		r = MHD_create_response_from_fd_at_offset64(rs->file_len, rs->fd, rs->file_off);
		if (!r) {
			close(rs->fd);
			return MHD_NO;
		}
		MHD_add_response_header(r, "Content-Type", rs->ctype);
		MHD_add_response_header(r, "Accept-Ranges", "bytes");
		if (*rs->disposition)
			MHD_add_response_header(r, "Content-Disposition", rs->disposition);
		if (rs->status == 206) {
			char cr[96];
			snprintf(cr, sizeof(cr), "bytes %" PRIu64 "-%" PRIu64 "/%" PRIu64, rs->file_off,
			         rs->file_off + rs->file_len - 1, rs->file_size);
			MHD_add_response_header(r, "Content-Range", cr);
		}
	} else if (rs->json) {
		txt = json_dumps(rs->json, JSON_COMPACT | JSON_PRESERVE_ORDER);
		size_t n = txt ? strlen(txt) : 0;
		if (txt) {
			txt[n] = '\n';  /* json_dumps leaves room: replace the NUL, keep length n+1 */
		}
		r = MHD_create_response_from_buffer(txt ? n + 1 : 0, txt, MHD_RESPMEM_MUST_FREE);
		txt = NULL;
		MHD_add_response_header(r, "Content-Type", "application/json");
		MHD_add_response_header(r, "Cache-Control", "no-store");
	} else if (rs->owned) {
		r = MHD_create_response_from_buffer(rs->raw_len, rs->owned, MHD_RESPMEM_MUST_FREE);
		rs->owned = NULL;
		MHD_add_response_header(r, "Content-Type", rs->ctype);
	} else {
		r = MHD_create_response_from_buffer(rs->raw_len, (void *)rs->raw, MHD_RESPMEM_PERSISTENT);
		MHD_add_response_header(r, "Content-Type", rs->ctype ? rs->ctype : "text/plain");
	}
	json_decref(rs->json);
	rs->json = NULL;
	if (!r)
		return MHD_NO;
	common_headers(r);
	if (rs->status == 401)
		MHD_add_response_header(r, "WWW-Authenticate", "Bearer realm=\"granulard\"");
	if (rs->status == 405 && allow)
		MHD_add_response_header(r, "Allow", allow);
	if (rs->status == 416) {
		char cr[64];
		snprintf(cr, sizeof(cr), "bytes */%" PRIu64, rs->file_size);
		MHD_add_response_header(r, "Content-Range", cr);
	}
	if (rs->retry_after > 0) {
		char ra[16];
		snprintf(ra, sizeof(ra), "%d", rs->retry_after);
		MHD_add_response_header(r, "Retry-After", ra);
	}
	ret = MHD_queue_response(c, (unsigned)rs->status, r);
	MHD_destroy_response(r);
	int cls = rs->status / 100;
	if (cls >= 1 && cls <= 5)
		atomic_fetch_add(&h->gd->responses_by_class[cls], 1);
	free(txt);
	return ret;
}

/* ---- checks -------------------------------------------------------------------- */

static int authorised(http_t *h, struct MHD_Connection *c)
{
	const char *a = MHD_lookup_connection_value(c, MHD_HEADER_KIND, "Authorization");
	if (!a || strncasecmp(a, "Bearer ", 7))
		return 0;
	a += 7;
	while (*a == ' ')
		a++;
	return util_ct_equal(a, h->gd->token);
}

static int host_ok(http_t *h, const char *host)
{
	if (!host)
		return 0;
	for (int i = 0; i < h->nhosts; i++)
		if (!strcasecmp(host, h->hosts[i]))
			return 1;
	return 0;
}

/* Origin "scheme://host[:port]" must name an accepted host. */
static int origin_ok(http_t *h, const char *origin)
{
	const char *p = strstr(origin, "://");
	return p && host_ok(h, p + 3);
}

static int is_json(const char *ct)
{
	if (!ct)
		return 0;
	size_t n = strcspn(ct, ";");
	while (n && ct[n - 1] == ' ')
		n--;
	return n == 16 && !strncasecmp(ct, "application/json", 16);
}

/* ---- request handling ---------------------------------------------------------- */

static enum MHD_Result on_request(void *cls, struct MHD_Connection *c, const char *url, const char *method,
                                  const char *version, const char *upload, size_t *upload_size, void **con_cls)
{
	http_t *h = cls;
	gd_t *gd = h->gd;
	req_t *rq = *con_cls;
	api_resp_t rs = {0};
	char allow[128], store[4][128], msg[256];

	if (!rq) {
		rq = calloc(1, sizeof(*rq));
		if (!rq)
			return MHD_NO;
		*con_cls = rq;
		atomic_fetch_add(&gd->requests, 1);
		/* Refuse an announced oversized body before reading any of it. */
		const char *cl = MHD_lookup_connection_value(c, MHD_HEADER_KIND, "Content-Length");
		if (cl && strtoull(cl, NULL, 10) > (unsigned long long)gd->cfg->max_body) {
			rq->too_large = 1;
			snprintf(msg, sizeof(msg), "request body of %s bytes exceeds the limit of %ld", cl, gd->cfg->max_body);
			api_error(&rs, 413, msg);
			return reply(h, c, &rs, NULL);
		}
		return MHD_YES;
	}
	if (*upload_size) {
		size_t n = *upload_size;
		*upload_size = 0;
		if (rq->too_large || rq->len + n > (size_t)gd->cfg->max_body) {
			rq->too_large = 1;   /* chunked bodies have no Content-Length: count and discard */
			return MHD_YES;
		}
		if (rq->len + n + 1 > rq->cap) {
			size_t cap = (rq->len + n + 1) * 2;
			if (cap > (size_t)gd->cfg->max_body + 1)
				cap = (size_t)gd->cfg->max_body + 1;
			char *b = realloc(rq->body, cap);
			if (!b)
				return MHD_NO;
			rq->body = b;
			rq->cap = cap;
		}
		memcpy(rq->body + rq->len, upload, n);
		rq->len += n;
		return MHD_YES;
	}

	api_req_t ar = {.method = method, .path = url, .body = rq->body ? rq->body : "", .body_len = rq->len,
	                .query = query_get, .header = header_get, .conn = c};
	int known = 0;
	const api_route_t *rt = api_match(method, url, &ar, store, &known, allow, sizeof(allow));
	if (!rt) {
		if (known) {
			snprintf(msg, sizeof(msg), "method %s not allowed on %s (allowed: %s)", method, url, allow);
			api_error(&rs, 405, msg);
		} else {
			snprintf(msg, sizeof(msg), "no such resource: %.200s", url);
			api_error(&rs, 404, msg);
		}
		return reply(h, c, &rs, allow);
	}
	int mut = (rt->flags & API_MUTATES) != 0;
	if ((mut || (h->read_needs_token && !(rt->flags & API_OPEN))) && !authorised(h, c)) {
		api_error(&rs, 401, MHD_lookup_connection_value(c, MHD_HEADER_KIND, "Authorization")
		                        ? "wrong token" : "missing Authorization: Bearer <token> (see STATE_DIR/token)");
		return reply(h, c, &rs, NULL);
	}
	if (mut) {
		const char *host = MHD_lookup_connection_value(c, MHD_HEADER_KIND, "Host");
		const char *origin = MHD_lookup_connection_value(c, MHD_HEADER_KIND, "Origin");
		if (!host_ok(h, host)) {
			snprintf(msg, sizeof(msg), "Host '%.100s' is not served here (allowed_hosts)", host ? host : "");
			api_error(&rs, 403, msg);
			return reply(h, c, &rs, NULL);
		}
		if (origin && !origin_ok(h, origin)) {
			snprintf(msg, sizeof(msg), "cross-origin request from '%.100s' refused", origin);
			api_error(&rs, 403, msg);
			return reply(h, c, &rs, NULL);
		}
		if (atomic_load(&gd->stopping)) {
			api_error(&rs, 503, "the daemon is shutting down");
			rs.retry_after = 5;
			return reply(h, c, &rs, NULL);
		}
	}
	if (rq->too_large) {
		snprintf(msg, sizeof(msg), "request body exceeds the limit of %ld bytes", gd->cfg->max_body);
		api_error(&rs, 413, msg);
		return reply(h, c, &rs, NULL);
	}
	if (rq->len && !is_json(MHD_lookup_connection_value(c, MHD_HEADER_KIND, "Content-Type"))) {
		api_error(&rs, 415, "request body must be Content-Type: application/json");
		return reply(h, c, &rs, NULL);
	}
	if (!strcmp(method, "POST") && !strcmp(rt->pattern, "/api/v1/jobs") && !rq->len) {
		api_error(&rs, 400, "body: empty; send a scene (application/json)");
		return reply(h, c, &rs, NULL);
	}
	rt->fn(gd, &ar, &rs);
	if (!rs.status)
		api_error(&rs, 500, "handler gave no answer");
	return reply(h, c, &rs, NULL);
}

static void on_completed(void *cls, struct MHD_Connection *c, void **con_cls, enum MHD_RequestTerminationCode t)
{
	req_t *rq = *con_cls;
	if (rq) {
		free(rq->body);
		free(rq);
	}
	*con_cls = NULL;
}

/* Percent-decoding that leaves %00 and %2F encoded: a NUL would cut a name
 * short ("a.h5%00x" would serve a.h5) and a slash would invent path segments. */
static size_t unescape(void *cls, struct MHD_Connection *c, char *s)
{
	char *w = s;
	for (const char *r = s; *r; r++) {
		int hi, lo;
		if (r[0] == '%' && sscanf((char[3]){r[1], r[1] ? r[2] : 0, 0}, "%1x%1x", &hi, &lo) == 2) {
			int v = hi * 16 + lo;
			if (v != 0 && v != '/') {
				*w++ = (char)v;
				r += 2;
				continue;
			}
		}
		*w++ = *r;
	}
	*w = '\0';
	return (size_t)(w - s);
}

static void mhd_log(void *cls, const char *fmt, va_list ap)
{
	char buf[512];
	vsnprintf(buf, sizeof(buf), fmt, ap);
	buf[strcspn(buf, "\n")] = '\0';
	log_debug("http: %s", buf);
}

/* ---- start/stop ---------------------------------------------------------------- */

static int bind_listen(const char *spec, int *port, char *host, size_t hostlen, char *err, size_t errlen)
{
	char buf[256];
	struct sockaddr_storage ss;
	socklen_t sl;
	int fd = -1, one = 1;
	snprintf(buf, sizeof(buf), "%s", spec);
	char *colon = strrchr(buf, ':'), *end;
	if (!colon) {
		snprintf(err, errlen, "listen: '%s' is not HOST:PORT", spec);
		return -1;
	}
	*colon = '\0';
	long p = strtol(colon + 1, &end, 10);
	if (*end || p < 0 || p > 65535) {
		snprintf(err, errlen, "listen: '%s' has no valid port", spec);
		return -1;
	}
	char *h = buf;
	if (*h == '[') {
		h++;
		h[strcspn(h, "]")] = '\0';
	}
	snprintf(host, hostlen, "%s", h);
	memset(&ss, 0, sizeof(ss));
	struct sockaddr_in *a4 = (struct sockaddr_in *)&ss;
	struct sockaddr_in6 *a6 = (struct sockaddr_in6 *)&ss;
	if (!strcmp(h, "localhost"))
		h = "127.0.0.1";
	if (inet_pton(AF_INET, h, &a4->sin_addr) == 1) {
		a4->sin_family = AF_INET;
		a4->sin_port = htons((uint16_t)p);
		sl = sizeof(*a4);
	} else if (inet_pton(AF_INET6, h, &a6->sin6_addr) == 1) {
		a6->sin6_family = AF_INET6;
		a6->sin6_port = htons((uint16_t)p);
		sl = sizeof(*a6);
	} else {
		snprintf(err, errlen, "listen: '%s' is not a numeric IPv4/IPv6 address", h);
		return -1;
	}
	fd = socket(ss.ss_family, SOCK_STREAM | SOCK_CLOEXEC, 0);
	if (fd < 0 || setsockopt(fd, SOL_SOCKET, SO_REUSEADDR, &one, sizeof(one)) ||
	    bind(fd, (struct sockaddr *)&ss, sl) || listen(fd, 1024)) {
		snprintf(err, errlen, "listen on %s: %s", spec, strerror(errno));
		if (fd >= 0)
			close(fd);
		return -1;
	}
	sl = sizeof(ss);
	getsockname(fd, (struct sockaddr *)&ss, &sl);
	*port = ntohs(ss.ss_family == AF_INET ? a4->sin_port : a6->sin6_port);
	return fd;
}

static int loopback(const char *host)
{
	return !strncmp(host, "127.", 4) || !strcmp(host, "::1") || !strcmp(host, "localhost");
}

http_t *http_start(gd_t *gd, int *port, char *err, size_t errlen)
{
	http_t *h = calloc(1, sizeof(*h));
	char host[256];
	if (!h) {
		snprintf(err, errlen, "out of memory");
		return NULL;
	}
	h->gd = gd;
	h->fd = bind_listen(gd->cfg->listen, port, host, sizeof(host), err, errlen);
	if (h->fd < 0) {
		free(h);
		return NULL;
	}
	const char *ra = gd->cfg->read_auth;
	h->read_needs_token = !strcmp(ra, "token") || (!strcmp(ra, "auto") && !loopback(host));
	const char *local[] = {"127.0.0.1", "localhost", "[::1]", NULL};
	for (int i = 0; local[i] && h->nhosts < MAX_HOSTS; i++)
		snprintf(h->hosts[h->nhosts++], 256, "%s:%d", local[i], *port);
	snprintf(h->hosts[h->nhosts++], 256, strchr(host, ':') ? "[%s]:%d" : "%s:%d", host, *port);
	char extra[1024];
	snprintf(extra, sizeof(extra), "%s", gd->cfg->allowed_hosts);
	for (char *sp = NULL, *t = strtok_r(extra, ", ", &sp); t && h->nhosts < MAX_HOSTS; t = strtok_r(NULL, ", ", &sp))
		snprintf(h->hosts[h->nhosts++], 256, "%s", t);

	h->d = MHD_start_daemon(
		MHD_USE_THREAD_PER_CONNECTION | MHD_USE_INTERNAL_POLLING_THREAD | MHD_USE_POLL | MHD_USE_ERROR_LOG, 0,
		NULL, NULL, on_request, h,
		MHD_OPTION_LISTEN_SOCKET, h->fd,
		MHD_OPTION_CONNECTION_LIMIT, (unsigned)gd->cfg->max_connections,
		MHD_OPTION_PER_IP_CONNECTION_LIMIT, (unsigned)gd->cfg->per_ip_connections,
		MHD_OPTION_CONNECTION_TIMEOUT, (unsigned)gd->cfg->request_timeout,
		MHD_OPTION_CONNECTION_MEMORY_LIMIT, (size_t)65536,
		MHD_OPTION_NOTIFY_COMPLETED, on_completed, h,
		MHD_OPTION_EXTERNAL_LOGGER, mhd_log, h,
		MHD_OPTION_UNESCAPE_CALLBACK, unescape, h,
		MHD_OPTION_END);
	if (!h->d) {
		snprintf(err, errlen, "cannot start the HTTP server on %s", gd->cfg->listen);
		close(h->fd);
		free(h);
		return NULL;
	}
	return h;
}

void http_stop(http_t *h)
{
	if (!h)
		return;
	MHD_stop_daemon(h->d);   /* closes the listening socket it was given */
	free(h);
}
