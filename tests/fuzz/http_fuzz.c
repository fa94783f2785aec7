/* libFuzzer harness: the daemon's HTTP request path from the raw bytes (gate, head limits, Host/Origin/token guard, routes, body checks, handlers). */
#include <arpa/inet.h>
#include <netinet/in.h>
#include <strings.h>

#include "fixture.h"
#include "gate.h"
#include "guard.h"
#include "http.h"
#include "request.h"

/*
 * Input: the bytes a client sends on a fresh connection (a raw HTTP/1.1
 * request: nc or curl --trace output seeds it). They go where the daemon
 * sends them, minus libmicrohttpd's own parsing of the head (third-party
 * code, emulated leniently by request.h) and the socket:
 * 1. gate_scan() (daemon/gate.c), the accept loop's check on the first
 *    bytes: an over-long request line or head is answered 414/431 there;
 *    an incomplete head waits (the input ends here).
 * 2. The head is split as libmicrohttpd does (request line, "Name: value"
 *    lines, repeats kept in order; path and query decoded with the daemon's
 *    own unescape callback, http_unescape()), the body is what follows
 *    (cut at Content-Length when that is shorter).
 * 3. http_admit() (daemon/http.c) with a guard for 127.0.0.1:8080 plus
 *    allowed_hosts "granulard.example", token "fuzz"; then
 *    http_body_check(), then the route's handler on the fixture queue
 *    (fixture.h).
 * Two pseudo-headers, which the daemon ignores, set what a socket would:
 * "X-Fuzz-Peer: ADDRESS" the peer's IPv4/IPv6 address (default 127.0.0.1)
 * and "X-Fuzz-Read-Auth: open|token|auto" the guard's read_auth (default
 * auto).
 * Checked beyond the sanitizers (an independent restatement of the rules
 * of guard.h): nothing is admitted without exactly one Host naming this
 * server, with a foreign Origin, or, on a mutating route, without
 * "Bearer fuzz"; every refusal carries an {"error"} body and a status from
 * the documented list; a 405 lists the allowed methods; fx_after() on every
 * handler's answer.
 */

#define LINE_MAX_BYTES 8192   /* as in daemon/http.c */
#define HEAD_MAX_BYTES 32768

static guard_t *guards[3];    /* by guard_read_t */
static int verbose;           /* HTTP_FUZZ_VERBOSE=1: one line per request (method, path, status) */

int LLVMFuzzerInitialize(int *argc, char ***argv)
{
	char err[256];
	(void)argc;
	(void)argv;
	fx_init("http_fuzz");
	verbose = getenv("HTTP_FUZZ_VERBOSE") != NULL;
	for (int i = 0; i < 3; i++)
		if (!(guards[i] = guard_create("127.0.0.1", 8080, "granulard.example", (guard_read_t)i, "fuzz", err, sizeof err)))
			abort();
	return 0;
}

/* libmicrohttpd turns '+' into a space in the query, then calls the daemon's unescape callback. */
static void decode(char *s, int plus)
{
	if (plus)
		for (char *p = s; *p; p++)
			if (*p == '+')
				*p = ' ';
	http_unescape(s);
}

static const char *q_get(void *conn, const char *key) { return fz_query(conn, key); }
static const char *h_get(void *conn, const char *key) { return fz_header(conn, key); }

static void each(void *conn, int kind, void (*fn)(void *cls, const char *key, const char *value), void *cls)
{
	const fz_req_t *r = conn;
	if (kind == HTTP_EACH_QUERY)
		for (int i = 0; i < r->nq; i++)
			fn(cls, r->qkey[i], r->qval[i]);
	else
		for (int i = 0; i < r->nh; i++)
			fn(cls, r->hname[i], r->hval[i]);
}

static int count_header(const fz_req_t *r, const char *name)
{
	int n = 0;
	for (int i = 0; i < r->nh; i++)
		n += !strcasecmp(r->hname[i], name);
	return n;
}

/* The rules of guard.h, restated: Host (and Origin after its scheme) is one of these, case-insensitively. */
static int served_here(const char *h)
{
	static const char *const ok[] = {"127.0.0.1:8080", "localhost:8080", "[::1]:8080", "granulard.example"};
	for (size_t i = 0; i < sizeof ok / sizeof ok[0]; i++)
		if (!strcasecmp(h, ok[i]))
			return 1;
	return 0;
}

static int token_ok(const char *a)
{
	if (!a || strncasecmp(a, "Bearer ", 7))
		return 0;
	for (a += 7; *a == ' '; a++)
		;
	return !strcmp(a, "fuzz");
}

static void check_admitted(const fz_req_t *r, const api_route_t *rt)
{
	const char *host = fz_header(r, "Host"), *origin = fz_header(r, "Origin");
	if (count_header(r, "Host") != 1 || !served_here(host))
		__builtin_trap();   /* DNS rebinding: a foreign or missing Host got through */
	if (count_header(r, "Origin") > 1 || count_header(r, "Authorization") > 1)
		__builtin_trap();
	if (origin) {
		const char *p = !strncasecmp(origin, "http://", 7) ? origin + 7 : !strncasecmp(origin, "https://", 8) ? origin + 8 : NULL;
		if (!p || !served_here(p))
			__builtin_trap();   /* cross-site request admitted */
	}
	if ((rt->flags & API_MUTATES) && !token_ok(fz_header(r, "Authorization")))
		__builtin_trap();   /* a write without the token */
}

static int peer_loopback(const fz_req_t *r)
{
	const char *p = fz_header(r, "X-Fuzz-Peer");
	struct sockaddr_in a4 = {.sin_family = AF_INET};
	struct sockaddr_in6 a6 = {.sin6_family = AF_INET6};
	if (!p)
		return 1;
	if (inet_pton(AF_INET, p, &a4.sin_addr) == 1)
		return guard_addr_loopback((struct sockaddr *)&a4);
	if (inet_pton(AF_INET6, p, &a6.sin6_addr) == 1)
		return guard_addr_loopback((struct sockaddr *)&a6);
	return 0;
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
	fz_req_t r = {0};
	char *buf, *body = NULL, store[4][128], allow[128];
	api_resp_t rs = {0};
	api_req_t ar;
	const api_route_t *rt = NULL;
	size_t end;
	int too_large = 0, st;

	/* 1. The accept loop's look at the first bytes. */
	int g = gate_scan((const char *)data, size, LINE_MAX_BYTES, HEAD_MAX_BYTES, &end);
	if (g != GATE_HEAD) {
		if (g != GATE_WAIT && g != 414 && g != 431)
			__builtin_trap();
		return 0;
	}
	if (end > size || end > HEAD_MAX_BYTES)
		__builtin_trap();
	if (!(buf = malloc(size + 1)))
		return 0;
	memcpy(buf, data, size);
	/* 2. The head as libmicrohttpd hands it over (a head it would refuse ends here). */
	if (fz_parse_as(buf, size, &r, decode) || !*r.method || r.path[0] != '/')
		goto cleanup;
	const char *cl = fz_header(&r, "Content-Length");
	if (cl) {
		char *e;
		unsigned long long n = strtoull(cl, &e, 10);
		if (*e || *cl < '0' || *cl > '9')
			goto cleanup;   /* libmicrohttpd answers 400 itself */
		if (n < r.body_len)
			r.body_len = (size_t)n;
	}
	const char *ra = fz_header(&r, "X-Fuzz-Read-Auth");
	const guard_t *guard = guards[ra && !strcmp(ra, "open") ? GUARD_READ_OPEN : ra && !strcmp(ra, "token") ? GUARD_READ_TOKEN
	                                                                                                  : GUARD_READ_AUTO];
	http_head_t hd = {.method = r.method, .url = r.path, .conn = &r, .header = h_get, .query = q_get, .each = each,
	                  .peer_loopback = peer_loopback(&r)};
	fx_before();
	/* 3. Admission, the body, the handler. */
	st = http_admit(&gd, guard, &hd, &rt, &ar, store, &rs, allow, sizeof allow, &too_large);
	if (st) {
		static const int allowed[] = {400, 401, 403, 404, 405, 413, 414, 431, 503};
		int known = 0;
		for (size_t i = 0; i < sizeof allowed / sizeof allowed[0]; i++)
			known |= st == allowed[i];
		if (!known || rs.status != st || (st == 405 && !*allow))
			__builtin_trap();
		check_error_body(&rs);
		goto cleanup;
	}
	if (!rt)
		__builtin_trap();
	check_admitted(&r, rt);
	if (r.body_len > (size_t)cfg.max_body)
		too_large = 1;   /* more than max_body arrived: the daemon stops storing it */
	st = http_body_check(&gd, rt, &hd, too_large ? 0 : r.body_len, too_large, &rs);
	if (st) {
		if ((st != 400 && st != 413 && st != 415) || rs.status != st)
			__builtin_trap();
		check_error_body(&rs);
		goto cleanup;
	}
	/* A body of exactly its length, as the daemon stores it, so a read past it is caught. */
	if (!(body = malloc(r.body_len ? r.body_len : 1)))
		goto cleanup;
	memcpy(body, r.body, r.body_len);
	ar.body = body;
	ar.body_len = r.body_len;
	rt->fn(&gd, &ar, &rs);
	fx_after(rt, &ar, &rs);
cleanup:
	if (verbose)
		fprintf(stderr, "http_fuzz: %s %s -> %d %s\n", r.method, r.path, rs.status,
		        rs.json ? json_string_value(json_object_get(json_object_get(rs.json, "error"), "message")) : "");
	fx_release(&rs);
	free(body);
	free(buf);
	return 0;
}
