/* libmicrohttpd glue: admission checks, request bodies, handlers on worker threads, JSON and SSE responses. */
#define _GNU_SOURCE
#include <arpa/inet.h>
#include <errno.h>
#include <inttypes.h>
#include <microhttpd.h>
#include <netinet/in.h>
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <sys/resource.h>
#include <sys/socket.h>
#include <time.h>
#include <unistd.h>
#include "conns.h"
#include "gate.h"
#include "guard.h"
#include "http.h"
#include "log.h"
#include "util.h"

#define LINE_MAX_BYTES 8192       /* request line (method, target, version) */
#define HEAD_MAX_BYTES 32768      /* the whole request head */
#define POOL_BYTES (128 * 1024)   /* libmicrohttpd's per-connection memory: above HEAD_MAX_BYTES, so our 431 comes first */
#define KEEPALIVE_SECONDS 15.0    /* comment line on a quiet event stream */
#define FD_RESERVE 256            /* descriptors kept for the database, job pipes, files */

enum { RQ_NEW = 0, RQ_QUEUED, RQ_DONE };

typedef struct sse sse_t;

typedef struct req {
	struct req *next;             /* worker queue */
	struct MHD_Connection *c;
	int fd;
	int state;                    /* RQ_*: a handler runs on a worker while the connection is suspended */
	char *body;
	size_t len, cap;
	int too_large;
	const api_route_t *rt;
	api_req_t ar;
	char store[4][128];
	api_resp_t rs;
	sse_t *sse;                   /* an event stream prepared by the worker */
} req_t;

struct sse {
	sse_t *prev, *next;           /* http_t.streams */
	http_t *h;
	struct MHD_Connection *c;
	int fd;
	int64_t job;
	uint64_t after;
	int done, suspended;
	char *final;                  /* a finished job's state, sent after the replay a Last-Event-ID asked for */
	double last_write;
	char *buf;
	size_t len, off, cap;
};

struct http {
	gd_t *gd;
	struct MHD_Daemon *d;
	guard_t *guard;
	conns_t *conns;
	gate_t *gate;
	int fd_cap;
	char resp408[1024], resp414[1024], resp431[1024];
	pthread_mutex_t lock;         /* queue, streams, counters below; never held while calling libmicrohttpd */
	pthread_cond_t wake, idle;
	req_t *qhead, *qtail;
	sse_t *streams;
	int closing, stop_workers, suspended;
	pthread_t *workers;
	int nworkers;
	pthread_t pump;
	int pump_started, stop_pump;
};

static double mono(void)
{
	struct timespec ts;
	clock_gettime(CLOCK_MONOTONIC, &ts);
	return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

static const char *query_get(void *conn, const char *key)
{
	return MHD_lookup_connection_value(conn, MHD_GET_ARGUMENT_KIND, key);
}

static const char *header_get(void *conn, const char *key)
{
	return MHD_lookup_connection_value(conn, MHD_HEADER_KIND, key);
}

static int conn_fd(struct MHD_Connection *c)
{
	const union MHD_ConnectionInfo *ci = MHD_get_connection_info(c, MHD_CONNECTION_INFO_CONNECTION_FD);
	return ci ? ci->connect_fd : -1;
}

/* Strict decimal: digits only, no sign, no leading zero (so one spelling per number). */
static int parse_u64(const char *s, uint64_t *v)
{
	uint64_t x = 0;
	if (!s || !*s || (s[0] == '0' && s[1]))
		return -1;
	for (; *s; s++) {
		if (*s < '0' || *s > '9' || x > (UINT64_MAX - 9) / 10)
			return -1;
		x = x * 10 + (uint64_t)(*s - '0');
	}
	*v = x;
	return 0;
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
	s->last_write = mono();
}

static int terminal(const char *state)
{
	return state && (!strcmp(state, "succeeded") || !strcmp(state, "failed") || !strcmp(state, "cancelled"));
}

/* The client closed its end (or reset it): nothing to read and EOF, or an error. */
static int peer_gone(int fd)
{
	char b;
	ssize_t r = recv(fd, &b, 1, MSG_PEEK | MSG_DONTWAIT);
	return r == 0 || (r < 0 && errno != EAGAIN && errno != EWOULDBLOCK && errno != EINTR);
}

/* Whatever the hub has for this stream now, without waiting. */
static void sse_fill(sse_t *s)
{
	for (int k = 0; k < 64 && !s->done; k++) {
		hub_event_t ev;
		int r = hub_wait(s->h->gd->hub, &s->after, s->job, 0, &ev);
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
		} else if (r == HUB_EGAP) {
			sse_put(s, "event: gap\ndata: {\"resume_after\": %" PRIu64 "}\n\n", s->after);
		} else if (r == HUB_ECLOSED) {
			s->done = 1;
		} else {
			/* replay over: a finished job's stream ends with its state, unless the replay carried it */
			if (s->final && !s->done) {
				sse_put(s, "id: %" PRIu64 "\nevent: state\ndata: %s\n\n", s->after, s->final);
				s->done = 1;
			}
			break;
		}
	}
	if (!s->len && !s->done && mono() - s->last_write >= KEEPALIVE_SECONDS)
		sse_put(s, ": keep-alive\n\n");
}

/* Runs on the server's polling thread: never blocks. With nothing to send the
 * connection is suspended; the pump thread resumes it on new events and once a
 * second (to see a closed client and to send keep-alives). */
static ssize_t sse_read(void *cls, uint64_t pos, char *out, size_t max)
{
	sse_t *s = cls;
	http_t *h = s->h;
	(void)pos;
	if (s->off == s->len) {
		s->off = s->len = 0;
		if (s->done)
			return MHD_CONTENT_READER_END_OF_STREAM;
		if (peer_gone(s->fd))
			return MHD_CONTENT_READER_END_WITH_ERROR;
		sse_fill(s);
		if (!s->len) {
			if (s->done)
				return MHD_CONTENT_READER_END_OF_STREAM;
			/* Suspend first, then let the pump see it: a resume never precedes its suspend. */
			MHD_suspend_connection(s->c);
			pthread_mutex_lock(&h->lock);
			int closing = h->closing;
			if (!closing) {
				s->suspended = 1;
				h->suspended++;
			}
			pthread_mutex_unlock(&h->lock);
			if (closing) {
				s->done = 1;
				MHD_resume_connection(s->c);
			}
			return 0;
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
	http_t *h = s->h;
	pthread_mutex_lock(&h->lock);
	if (s->prev)
		s->prev->next = s->next;
	else if (h->streams == s)
		h->streams = s->next;
	if (s->next)
		s->next->prev = s->prev;
	pthread_mutex_unlock(&h->lock);
	atomic_fetch_sub(&h->gd->open_streams, 1);
	free(s->final);
	free(s->buf);
	free(s);
}

/* On a worker: the stream's first event (the job's state, or hello), taken after
 * the position in the hub so that no later change is missed. */
static sse_t *sse_prepare(http_t *h, req_t *rq)
{
	sse_t *s = calloc(1, sizeof(*s));
	char err[128];
	uint64_t lei;
	if (!s)
		return NULL;
	s->h = h;
	s->c = rq->c;
	s->fd = rq->fd;
	s->job = rq->rs.sse_job;
	s->after = hub_last(h->gd->hub);
	int resume = 0;
	if (!parse_u64(MHD_lookup_connection_value(rq->c, MHD_HEADER_KIND, "Last-Event-ID"), &lei) && lei <= s->after) {
		resume = lei < s->after;
		s->after = lei;
	}
	sse_put(s, "retry: 2000\n");
	if (s->job) {
		json_t *j = NULL;
		if (jobq_get(h->gd->q, s->job, 0, &j, err, sizeof(err)) != JOBQ_OK) {
			free(s->buf);
			free(s);
			return NULL;
		}
		char *txt = json_dumps(j, JSON_COMPACT);
		/* A client resuming a finished job gets what it missed (still in the hub), then the
		 * final state; anyone else gets the state now, and a finished job's stream ends there. */
		if (resume && terminal(json_string_value(json_object_get(j, "state")))) {
			s->final = txt;
			txt = NULL;
			if (!s->final)
				s->done = 1;
		} else {
			sse_put(s, "id: %" PRIu64 "\nevent: state\ndata: %s\n\n", s->after, txt ? txt : "{}");
			if (terminal(json_string_value(json_object_get(j, "state"))))
				s->done = 1;
		}
		free(txt);
		json_decref(j);
	} else {
		sse_put(s, "id: %" PRIu64 "\nevent: hello\ndata: {\"last\": %" PRIu64 "}\n\n", s->after, s->after);
	}
	return s;
}

/* Resume every suspended stream (new events, the one-second tick, or shutdown). */
static void sweep(http_t *h)
{
	struct MHD_Connection *batch[256];
	for (;;) {
		int n = 0;
		pthread_mutex_lock(&h->lock);
		for (sse_t *s = h->streams; s && n < 256; s = s->next)
			if (s->suspended) {
				s->suspended = 0;
				batch[n++] = s->c;
			}
		pthread_mutex_unlock(&h->lock);
		for (int i = 0; i < n; i++)
			MHD_resume_connection(batch[i]);
		pthread_mutex_lock(&h->lock);
		h->suspended -= n;
		pthread_cond_broadcast(&h->idle);
		pthread_mutex_unlock(&h->lock);
		if (n < 256)
			return;
	}
}

static void evict_cb(void *arg, int fd)
{
	(void)arg;
	shutdown(fd, SHUT_RDWR);   /* its owner sees the end and closes it */
}

/* Streams, deadlines and gauges: wakes on each new hub event and at least once a second. */
static void *pump(void *arg)
{
	http_t *h = arg;
	gd_t *gd = h->gd;
	uint64_t seen = hub_last(gd->hub);
	double tick = mono();
	for (;;) {
		pthread_mutex_lock(&h->lock);
		int stop = h->stop_pump;
		pthread_mutex_unlock(&h->lock);
		if (stop)
			return NULL;
		uint64_t now_seq = hub_wait_newer(gd->hub, seen, 250);
		double now = mono();
		int closed = hub_closed(gd->hub);
		if (now_seq != seen || now - tick >= 1.0 || closed) {
			sweep(h);
			seen = now_seq;
		}
		if (now - tick >= 1.0) {
			tick = now;
			conns_expire(h->conns, now - (double)gd->cfg->header_timeout, now - (double)gd->cfg->request_timeout,
			             evict_cb, h);
			atomic_store(&gd->open_connections, conns_count(h->conns));
			atomic_store(&gd->evicted_connections, conns_evictions(h->conns));
		}
		if (closed)
			usleep(50000);
	}
}

/* ---- responses ---------------------------------------------------------------- */

/* On every answer, the gate's included (http_start renders those with the same list). */
static const char *const security_headers[][2] = {
	{"X-Content-Type-Options", "nosniff"},
	{"Content-Security-Policy", "default-src 'self'; frame-ancestors 'none'; base-uri 'none'; form-action 'self'"},
	{"X-Frame-Options", "DENY"},
	{"Referrer-Policy", "no-referrer"},
	{"Cross-Origin-Resource-Policy", "same-origin"},
};

static void count_status(gd_t *gd, int status)
{
	int cls = status / 100;
	if (cls >= 1 && cls <= 5)
		atomic_fetch_add(&gd->responses_by_class[cls], 1);
}

static enum MHD_Result reply(http_t *h, struct MHD_Connection *c, req_t *rq, const char *allow)
{
	api_resp_t *rs = &rq->rs;
	struct MHD_Response *r;
	enum MHD_Result ret;
	if (rs->sse && rq->sse) {
		sse_t *s = rq->sse;
		rq->sse = NULL;
		r = MHD_create_response_from_callback(MHD_SIZE_UNKNOWN, 4096, sse_read, s, sse_free);
		if (!r) {
			free(s->final);
			free(s->buf);
			free(s);
			return MHD_NO;
		}
		pthread_mutex_lock(&h->lock);
		s->next = h->streams;
		if (s->next)
			s->next->prev = s;
		h->streams = s;
		pthread_mutex_unlock(&h->lock);
		atomic_fetch_add(&h->gd->open_streams, 1);
		MHD_add_response_header(r, "Content-Type", "text/event-stream");
		MHD_add_response_header(r, "Cache-Control", "no-cache");
		MHD_add_response_header(r, "X-Accel-Buffering", "no");
	} else if (rs->has_file) {
		/* MHD sends from the descriptor (sendfile) and closes it with the response. */
		r = MHD_create_response_from_fd_at_offset64(rs->file_len, rs->fd, rs->file_off);
		rs->has_file = 0;
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
		char *txt = json_dumps(rs->json, JSON_COMPACT | JSON_PRESERVE_ORDER);
		size_t n = txt ? strlen(txt) : 0;
		if (txt)
			txt[n] = '\n';  /* json_dumps leaves room: replace the NUL, keep length n+1 */
		r = MHD_create_response_from_buffer(txt ? n + 1 : 0, txt, MHD_RESPMEM_MUST_FREE);
		if (r) {
			MHD_add_response_header(r, "Content-Type", "application/json");
			MHD_add_response_header(r, "Cache-Control", "no-store");
		} else {
			free(txt);
		}
	} else if (rs->owned) {
		r = MHD_create_response_from_buffer(rs->raw_len, rs->owned, MHD_RESPMEM_MUST_FREE);
		if (r)
			rs->owned = NULL;
		if (r)
			MHD_add_response_header(r, "Content-Type", rs->ctype);
	} else {
		r = MHD_create_response_from_buffer(rs->raw_len, (void *)rs->raw, MHD_RESPMEM_PERSISTENT);
		if (r)
			MHD_add_response_header(r, "Content-Type", rs->ctype ? rs->ctype : "text/plain");
	}
	json_decref(rs->json);
	rs->json = NULL;
	if (!r)
		return MHD_NO;
	for (size_t i = 0; i < sizeof(security_headers) / sizeof(security_headers[0]); i++)
		MHD_add_response_header(r, security_headers[i][0], security_headers[i][1]);
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
	count_status(h->gd, rs->status);
	return ret;
}

/* A complete response with a JSON error body, for the gate (which answers before libmicrohttpd sees a request). */
static void render_error(char *out, size_t n, int status, const char *reason, const char *code, const char *msg)
{
	char body[512];
	int bl = snprintf(body, sizeof(body), "{\"error\":{\"code\":\"%s\",\"message\":\"%s\"}}\n", code, msg);
	int o = snprintf(out, n, "HTTP/1.1 %d %s\r\nConnection: close\r\nContent-Type: application/json\r\n"
	                 "Cache-Control: no-store\r\nContent-Length: %d\r\n", status, reason, bl);
	for (size_t i = 0; i < sizeof(security_headers) / sizeof(security_headers[0]); i++)
		o += snprintf(out + o, n - (size_t)o, "%s: %s\r\n", security_headers[i][0], security_headers[i][1]);
	snprintf(out + o, n - (size_t)o, "\r\n%s", body);
}

/* ---- checks -------------------------------------------------------------------- */

typedef struct {
	guard_req_t g;
	const char *seen[8];
	int nseen;
	size_t bytes;
} heads_t;

static void collect(void *cls, const char *key, const char *value)
{
	heads_t *hs = cls;
	hs->bytes += strlen(key) + (value ? strlen(value) : 0) + 4;
	if (!strcasecmp(key, "Forwarded") || !strcasecmp(key, "X-Forwarded-For") || !strcasecmp(key, "X-Real-IP"))
		hs->g.forwarded = 1;
	if (!guard_single_header(key))
		return;
	for (int i = 0; i < hs->nseen; i++)
		if (!strcasecmp(hs->seen[i], key)) {
			if (!hs->g.duplicate)
				hs->g.duplicate = hs->seen[i];
			return;
		}
	if (hs->nseen < 8)
		hs->seen[hs->nseen++] = key;
	if (!strcasecmp(key, "Host"))
		hs->g.host = value;
	else if (!strcasecmp(key, "Origin"))
		hs->g.origin = value;
	else if (!strcasecmp(key, "Authorization"))
		hs->g.authorization = value;
}

static void count_args(void *cls, const char *key, const char *value)
{
	*(size_t *)cls += strlen(key) + (value ? strlen(value) : 0) + 2;
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

/* ---- workers -------------------------------------------------------------------- */

static void handle(http_t *h, req_t *rq)
{
	gd_t *gd = h->gd;
	pthread_mutex_lock(&h->lock);
	int closing = h->closing;
	pthread_mutex_unlock(&h->lock);
	if (closing) {
		api_error(&rq->rs, 503, "the daemon is shutting down");
		rq->rs.retry_after = 5;
		return;
	}
	rq->rt->fn(gd, &rq->ar, &rq->rs);
	if (!rq->rs.status)
		api_error(&rq->rs, 500, "handler gave no answer");
	if (rq->rs.sse && rq->rs.status == 200) {
		rq->sse = sse_prepare(h, rq);
		if (!rq->sse) {
			rq->rs.sse = 0;
			api_error(&rq->rs, 503, "cannot start the event stream");
		}
	}
}

static void *worker(void *arg)
{
	http_t *h = arg;
	pthread_mutex_lock(&h->lock);
	for (;;) {
		while (!h->qhead && !h->stop_workers)
			pthread_cond_wait(&h->wake, &h->lock);
		req_t *rq = h->qhead;
		if (!rq)
			break;
		h->qhead = rq->next;
		if (!h->qhead)
			h->qtail = NULL;
		pthread_mutex_unlock(&h->lock);
		handle(h, rq);
		rq->state = RQ_DONE;
		MHD_resume_connection(rq->c);   /* libmicrohttpd calls on_request again, which sends rq->rs */
		pthread_mutex_lock(&h->lock);
		h->suspended--;
		pthread_cond_broadcast(&h->idle);
	}
	pthread_mutex_unlock(&h->lock);
	return NULL;
}

/* ---- request handling ---------------------------------------------------------- */

/* libmicrohttpd's iteration over headers or arguments, for http_head_t.each. */
typedef struct {
	void (*fn)(void *cls, const char *key, const char *value);
	void *cls;
} each_t;

static enum MHD_Result each_cb(void *cls, enum MHD_ValueKind kind, const char *key, const char *value)
{
	each_t *e = cls;
	(void)kind;
	e->fn(e->cls, key, value);
	return MHD_YES;
}

static void conn_each(void *conn, int kind, void (*fn)(void *cls, const char *key, const char *value), void *cls)
{
	each_t e = {fn, cls};
	MHD_get_connection_values(conn, kind == HTTP_EACH_QUERY ? MHD_GET_ARGUMENT_KIND : MHD_HEADER_KIND, each_cb, &e);
}

int http_admit(gd_t *gd, const guard_t *guard, const http_head_t *hd, const api_route_t **rt, api_req_t *ar,
               char store[][128], api_resp_t *rs, char *allow, size_t allowlen, int *too_large)
{
	const char *method = hd->method, *url = hd->url;
	char msg[256];
	heads_t hs = {0};
	size_t line = strlen(method) + strlen(url) + 12;
	*rt = NULL;
	*allow = '\0';
	hd->each(hd->conn, HTTP_EACH_QUERY, count_args, &line);
	hd->each(hd->conn, HTTP_EACH_HEADER, collect, &hs);
	/* The gate checked the first request of a connection; these are the later ones. */
	if (line > LINE_MAX_BYTES) {
		snprintf(msg, sizeof(msg), "request line longer than %d bytes", LINE_MAX_BYTES);
		api_error(rs, 414, msg);
		return 414;
	}
	if (line + hs.bytes > HEAD_MAX_BYTES) {
		snprintf(msg, sizeof(msg), "request head longer than %d bytes", HEAD_MAX_BYTES);
		api_error(rs, 431, msg);
		return 431;
	}
	hs.g.peer_loopback = hd->peer_loopback;
	int known = 0;
	*ar = (api_req_t){.method = method, .path = url, .query = hd->query, .header = hd->header, .conn = hd->conn};
	*rt = api_match(method, url, ar, store, &known, allow, allowlen);
	guard_route_t kind = !*rt || ((*rt)->flags & API_OPEN) ? GUARD_ROUTE_OPEN
	                     : (*rt)->flags & API_MUTATES       ? GUARD_ROUTE_MUTATES
	                                                         : GUARD_ROUTE_READ;
	int st = guard_check(guard, &hs.g, kind, msg, sizeof(msg));
	if (st) {
		*allow = '\0';
		api_error(rs, st, msg);
		return st;
	}
	if (!*rt) {
		if (known) {
			snprintf(msg, sizeof(msg), "method %s not allowed on %.100s (allowed: %s)", method, url, allow);
			api_error(rs, 405, msg);
			return 405;
		}
		snprintf(msg, sizeof(msg), "no such resource: %.200s", url);
		api_error(rs, 404, msg);
		return 404;
	}
	/* Refuse an announced oversized body before reading any of it. */
	const char *cl = hd->header(hd->conn, "Content-Length");
	if (cl && strtoull(cl, NULL, 10) > (unsigned long long)gd->cfg->max_body) {
		*too_large = 1;
		snprintf(msg, sizeof(msg), "request body of %.20s bytes exceeds the limit of %ld", cl, gd->cfg->max_body);
		api_error(rs, 413, msg);
		return 413;
	}
	if (((*rt)->flags & API_MUTATES) && atomic_load(&gd->stopping)) {
		api_error(rs, 503, "the daemon is shutting down");
		rs->retry_after = 5;
		return 503;
	}
	return 0;
}

int http_body_check(const gd_t *gd, const api_route_t *rt, const http_head_t *hd, size_t len, int too_large,
                    api_resp_t *rs)
{
	char msg[256];
	if (too_large) {
		snprintf(msg, sizeof(msg), "request body exceeds the limit of %ld bytes", gd->cfg->max_body);
		api_error(rs, 413, msg);
		return 413;
	}
	if (len && !is_json(hd->header(hd->conn, "Content-Type"))) {
		api_error(rs, 415, "request body must be Content-Type: application/json");
		return 415;
	}
	if (!strcmp(hd->method, "POST") && !strcmp(rt->pattern, "/api/v1/jobs") && !len) {
		api_error(rs, 400, "body: empty; send a scene (application/json)");
		return 400;
	}
	return 0;
}

/* The head of the request on connection c, for http_admit() and http_body_check(). */
static http_head_t conn_head(struct MHD_Connection *c, const char *url, const char *method)
{
	const union MHD_ConnectionInfo *ci = MHD_get_connection_info(c, MHD_CONNECTION_INFO_CLIENT_ADDRESS);
	return (http_head_t){.method = method, .url = url, .conn = c, .header = header_get, .query = query_get,
	                     .each = conn_each, .peer_loopback = ci && guard_addr_loopback(ci->client_addr)};
}

/* First call for a request (its head is complete): limits and admission. Answers
 * at once when the request is refused; returns MHD_YES with rq->rs.status == 0 otherwise. */
static enum MHD_Result admit(http_t *h, struct MHD_Connection *c, req_t *rq, const char *url, const char *method)
{
	char allow[128];
	http_head_t hd = conn_head(c, url, method);
	if (http_admit(h->gd, h->guard, &hd, &rq->rt, &rq->ar, rq->store, &rq->rs, allow, sizeof(allow), &rq->too_large))
		return reply(h, c, rq, *allow ? allow : NULL);
	return MHD_YES;
}

static enum MHD_Result on_request(void *cls, struct MHD_Connection *c, const char *url, const char *method,
                                  const char *version, const char *upload, size_t *upload_size, void **con_cls)
{
	http_t *h = cls;
	gd_t *gd = h->gd;
	req_t *rq = *con_cls;
	(void)version;

	if (!rq) {
		rq = calloc(1, sizeof(*rq));
		if (!rq)
			return MHD_NO;
		*con_cls = rq;
		rq->c = c;
		rq->fd = conn_fd(c);
		atomic_fetch_add(&gd->requests, 1);
		const char *cl = MHD_lookup_connection_value(c, MHD_HEADER_KIND, "Content-Length");
		int body = (cl && strcmp(cl, "0")) || MHD_lookup_connection_value(c, MHD_HEADER_KIND, "Transfer-Encoding");
		conns_set_phase(h->conns, rq->fd, body ? CONN_BODY : CONN_BUSY, mono());
		return admit(h, c, rq, url, method);
	}
	if (rq->rs.status && rq->state == RQ_NEW)
		return MHD_YES;   /* answered by admit(); libmicrohttpd discards the rest of the body */
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
	if (rq->state == RQ_DONE)
		return reply(h, c, rq, NULL);
	if (rq->state == RQ_QUEUED)
		return MHD_YES;
	conns_set_phase(h->conns, rq->fd, CONN_BUSY, mono());
	http_head_t hd = conn_head(c, url, method);
	if (http_body_check(gd, rq->rt, &hd, rq->len, rq->too_large, &rq->rs))
		return reply(h, c, rq, NULL);
	rq->ar.body = rq->body ? rq->body : "";
	rq->ar.body_len = rq->len;
	if (rq->rt->flags & API_INLINE) {
		rq->rt->fn(gd, &rq->ar, &rq->rs);
		return reply(h, c, rq, NULL);
	}
	/* Everything else may block (database, files): a worker runs it while the
	 * connection is suspended, so a slow handler holds no polling thread. */
	MHD_suspend_connection(c);
	pthread_mutex_lock(&h->lock);
	if (h->closing) {
		pthread_mutex_unlock(&h->lock);
		api_error(&rq->rs, 503, "the daemon is shutting down");
		rq->rs.retry_after = 5;
		rq->state = RQ_DONE;
		MHD_resume_connection(c);
		return MHD_YES;
	}
	rq->state = RQ_QUEUED;
	rq->next = NULL;
	if (h->qtail)
		h->qtail->next = rq;
	else
		h->qhead = rq;
	h->qtail = rq;
	h->suspended++;
	pthread_cond_signal(&h->wake);
	pthread_mutex_unlock(&h->lock);
	return MHD_YES;
}

static void on_completed(void *cls, struct MHD_Connection *c, void **con_cls, enum MHD_RequestTerminationCode t)
{
	http_t *h = cls;
	req_t *rq = *con_cls;
	(void)t;
	if (rq) {
		conns_set_phase(h->conns, rq->fd, CONN_HEAD, mono());   /* kept alive: waiting for the next head */
		if (rq->rs.has_file)
			close(rq->rs.fd);
		json_decref(rq->rs.json);
		free(rq->rs.owned);
		if (rq->sse) {
			free(rq->sse->final);
			free(rq->sse->buf);
			free(rq->sse);
		}
		free(rq->body);
		free(rq);
	}
	*con_cls = NULL;
}

static void on_connection(void *cls, struct MHD_Connection *c, void **socket_context,
                          enum MHD_ConnectionNotificationCode code)
{
	http_t *h = cls;
	if (code == MHD_CONNECTION_NOTIFY_STARTED) {
		*socket_context = (void *)(intptr_t)(conn_fd(c) + 1);
	} else if (*socket_context) {
		/* Called before libmicrohttpd closes the descriptor: it cannot be reused yet. */
		conns_remove(h->conns, (int)(intptr_t)*socket_context - 1);
		*socket_context = NULL;
	}
}

static int handoff(void *arg, int fd, const struct sockaddr *sa, socklen_t salen)
{
	http_t *h = arg;
	return MHD_add_connection(h->d, fd, sa, salen) == MHD_YES ? 0 : -1;
}

static void gate_count(void *arg, int status)
{
	http_t *h = arg;
	if (status)
		count_status(h->gd, status);
	else
		atomic_fetch_add(&h->gd->refused_connections, 1);
}
/* Percent-decoding that leaves %00 and %2F encoded: a NUL would cut a name
 * short ("a.h5%00x" would serve a.h5) and a slash would invent path segments. */
size_t http_unescape(char *s)
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

static size_t unescape(void *cls, struct MHD_Connection *c, char *s)
{
	(void)cls;
	(void)c;
	return http_unescape(s);
}

static void mhd_log(void *cls, const char *fmt, va_list ap)
{
	char buf[512];
	(void)cls;
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

/* As many descriptors as the hard limit allows: each connection holds one. */
static int raise_nofile(void)
{
	struct rlimit rl;
	if (getrlimit(RLIMIT_NOFILE, &rl))
		return 1024;
	if (rl.rlim_cur < rl.rlim_max) {
		rlim_t want = rl.rlim_max == RLIM_INFINITY || rl.rlim_max > 1048576 ? 1048576 : rl.rlim_max;
		if (want > rl.rlim_cur) {
			struct rlimit n = {.rlim_cur = want, .rlim_max = rl.rlim_max};
			if (!setrlimit(RLIMIT_NOFILE, &n))
				rl.rlim_cur = want;
		}
	}
	return rl.rlim_cur == RLIM_INFINITY || rl.rlim_cur > 1048576 ? 1048576 : (int)rl.rlim_cur;
}

static unsigned poll_threads(void)
{
	long n = sysconf(_SC_NPROCESSORS_ONLN);
	return n < 2 ? 1u : n > 4 ? 4u : (unsigned)n;
}

http_t *http_start(gd_t *gd, int *port, char *err, size_t errlen)
{
	const cfg_t *cfg = gd->cfg;
	http_t *h = calloc(1, sizeof(*h));
	char host[256], msg[200];
	int lfd = -1;
	if (!h) {
		snprintf(err, errlen, "out of memory");
		return NULL;
	}
	h->gd = gd;
	pthread_mutex_init(&h->lock, NULL);
	pthread_cond_init(&h->wake, NULL);
	pthread_cond_init(&h->idle, NULL);
	lfd = bind_listen(cfg->listen, port, host, sizeof(host), err, errlen);
	if (lfd < 0)
		goto fail;
	const char *ra = cfg->read_auth;
	h->guard = guard_create(host, *port, cfg->allowed_hosts,
	                        !strcmp(ra, "open") ? GUARD_READ_OPEN : !strcmp(ra, "token") ? GUARD_READ_TOKEN : GUARD_READ_AUTO,
	                        gd->token, err, errlen);
	if (!h->guard)
		goto fail;
	h->fd_cap = raise_nofile();
	int max = (int)cfg->max_connections;
	if (max > h->fd_cap - FD_RESERVE) {
		max = h->fd_cap - FD_RESERVE > 16 ? h->fd_cap - FD_RESERVE : 16;
		log_warning("max_connections %ld lowered to %d: the descriptor limit (RLIMIT_NOFILE) is %d", cfg->max_connections,
		            max, h->fd_cap);
	}
	h->conns = conns_create(max, (int)cfg->per_ip_connections, h->fd_cap);
	if (!h->conns) {
		snprintf(err, errlen, "out of memory");
		goto fail;
	}
	snprintf(msg, sizeof(msg), "request head not complete within %ld s (header_timeout)", cfg->header_timeout);
	render_error(h->resp408, sizeof(h->resp408), 408, "Request Timeout", "request_timeout", msg);
	snprintf(msg, sizeof(msg), "request line longer than %d bytes", LINE_MAX_BYTES);
	render_error(h->resp414, sizeof(h->resp414), 414, "URI Too Long", "uri_too_long", msg);
	snprintf(msg, sizeof(msg), "request head longer than %d bytes", HEAD_MAX_BYTES);
	render_error(h->resp431, sizeof(h->resp431), 431, "Request Header Fields Too Large", "header_fields_too_large", msg);

	/* Polling threads only parse and move bytes (epoll; idle connections and event
	 * streams hold no thread); handlers run on the workers. */
	h->d = MHD_start_daemon(MHD_USE_INTERNAL_POLLING_THREAD | MHD_USE_EPOLL | MHD_ALLOW_SUSPEND_RESUME |
	                            MHD_USE_NO_LISTEN_SOCKET | MHD_USE_ERROR_LOG,
	                        0, NULL, NULL, on_request, h,
	                        MHD_OPTION_THREAD_POOL_SIZE, poll_threads(),
	                        MHD_OPTION_CONNECTION_LIMIT, (unsigned)(max + FD_RESERVE),
	                        MHD_OPTION_CONNECTION_TIMEOUT, (unsigned)cfg->request_timeout,
	                        MHD_OPTION_CONNECTION_MEMORY_LIMIT, (size_t)POOL_BYTES,
	                        MHD_OPTION_NOTIFY_COMPLETED, on_completed, h,
	                        MHD_OPTION_NOTIFY_CONNECTION, on_connection, h,
	                        MHD_OPTION_EXTERNAL_LOGGER, mhd_log, h,
	                        MHD_OPTION_UNESCAPE_CALLBACK, unescape, h,
	                        MHD_OPTION_END);
	if (!h->d) {
		snprintf(err, errlen, "cannot start the HTTP server on %s", cfg->listen);
		goto fail;
	}
	h->nworkers = (int)cfg->http_workers;
	h->workers = calloc((size_t)h->nworkers, sizeof(*h->workers));
	if (!h->workers) {
		snprintf(err, errlen, "out of memory");
		goto fail;
	}
	for (int i = 0; i < h->nworkers; i++)
		if (pthread_create(&h->workers[i], NULL, worker, h)) {
			h->nworkers = i;
			snprintf(err, errlen, "cannot start HTTP worker threads: %s", strerror(errno));
			goto fail;
		}
	if (pthread_create(&h->pump, NULL, pump, h)) {
		snprintf(err, errlen, "cannot start the event stream thread");
		goto fail;
	}
	h->pump_started = 1;
	gate_conf_t gc = {.listen_fd = lfd, .conns = h->conns, .fd_cap = h->fd_cap,
	                  .head_timeout = (double)cfg->header_timeout, .line_max = LINE_MAX_BYTES,
	                  .head_max = HEAD_MAX_BYTES, .resp_408 = h->resp408, .resp_414 = h->resp414,
	                  .resp_431 = h->resp431, .handoff = handoff, .count = gate_count, .arg = h};
	lfd = -1;   /* the gate owns it from here, also on failure */
	h->gate = gate_start(&gc, err, errlen);
	if (!h->gate)
		goto fail;
	return h;
fail:
	if (lfd >= 0)
		close(lfd);
	http_stop(h);
	return NULL;
}

void http_stop(http_t *h)
{
	if (!h)
		return;
	/* No new connections; then no new work: queued requests get 503, streams end. */
	gate_stop(h->gate);
	pthread_mutex_lock(&h->lock);
	h->closing = 1;
	pthread_mutex_unlock(&h->lock);
	if (h->pump_started)
		sweep(h);
	/* libmicrohttpd must not be stopped with suspended connections. */
	pthread_mutex_lock(&h->lock);
	while (h->suspended > 0) {
		struct timespec dl;
		clock_gettime(CLOCK_REALTIME, &dl);
		dl.tv_sec += 1;
		pthread_cond_timedwait(&h->idle, &h->lock, &dl);
		pthread_mutex_unlock(&h->lock);
		sweep(h);
		pthread_mutex_lock(&h->lock);
	}
	h->stop_workers = 1;
	h->stop_pump = 1;
	pthread_cond_broadcast(&h->wake);
	pthread_mutex_unlock(&h->lock);
	if (h->d)
		MHD_stop_daemon(h->d);
	for (int i = 0; i < h->nworkers; i++)
		pthread_join(h->workers[i], NULL);
	if (h->pump_started)
		pthread_join(h->pump, NULL);
	free(h->workers);
	conns_destroy(h->conns);
	guard_destroy(h->guard);
	pthread_mutex_destroy(&h->lock);
	pthread_cond_destroy(&h->wake);
	pthread_cond_destroy(&h->idle);
	free(h);
}
