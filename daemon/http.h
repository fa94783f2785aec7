/* HTTP front end of granulard on libmicrohttpd: limits, authentication, dispatch to the API, event streams. */
#pragma once

#include <stddef.h>
#include "api.h"
#include "guard.h"

/*
 * Contract
 * - http_start() binds cfg->listen (HOST:PORT, IPv4 or [IPv6]; port 0 picks
 *   a free port, reported in *port) and serves until http_stop().
 * - Thread per connection: handlers and event streams may block; event
 *   streams send a comment every 15 s and end when the hub closes.
 * - Mutating requests need the bearer token, an allowed Host, and (when
 *   sent) a same-origin Origin; read-only ones need the token only when
 *   read_auth says so. Bodies over max_body get 413 before they are read.
 */

typedef struct http http_t;

http_t *http_start(gd_t *gd, int *port, char *err, size_t errlen);
void http_stop(http_t *h);

/*
 * The request path below libmicrohttpd, callable without a socket (the
 * daemon calls it on each connection; tests/fuzz/http_fuzz.c on requests
 * built in memory). http_head_t is what libmicrohttpd hands over for one
 * request, behind accessors.
 */
enum { HTTP_EACH_HEADER = 0, HTTP_EACH_QUERY = 1 };

typedef struct {
	const char *method;
	const char *url;            /* path, percent-decoded by http_unescape() */
	void *conn;
	const char *(*header)(void *conn, const char *key);   /* first value (case-insensitive name) or NULL */
	const char *(*query)(void *conn, const char *key);    /* decoded query argument or NULL */
	/* fn(cls, key, value) for every header or query argument, in order, repeats included */
	void (*each)(void *conn, int kind, void (*fn)(void *cls, const char *key, const char *value), void *cls);
	int peer_loopback;          /* the TCP peer is a loopback address */
} http_head_t;

/* A complete head: request line and head size (414, 431), guard_check()
 * (400, 401, 403), the route (404, 405: allow lists the methods), an
 * announced body over max_body (413, *too_large = 1), shutting down (503).
 * 0: admitted, *rt and *ar set (params in store); else that status with the
 * error in rs (the caller sends it, with Allow when *allow). */
int http_admit(gd_t *gd, const guard_t *guard, const http_head_t *hd, const api_route_t **rt, api_req_t *ar,
               char store[][128], api_resp_t *rs, char *allow, size_t allowlen, int *too_large);

/* The body is in (len bytes; too_large: more than max_body came): 413, 415
 * (a body that is not application/json), 400 (a submission without a body),
 * with the error in rs; 0: run the route's handler on it. */
int http_body_check(const gd_t *gd, const api_route_t *rt, const http_head_t *hd, size_t len, int too_large,
                    api_resp_t *rs);

/* Percent-decoding in place, as libmicrohttpd applies to the path and the
 * query: %00 and %2F stay encoded. Returns the new length. */
size_t http_unescape(char *s);
