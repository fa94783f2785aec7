/* Request admission rules of the HTTP front end: Host and Origin checks, repeated headers, who needs the token. */
#pragma once

#include <stddef.h>
#include <sys/socket.h>

/*
 * Contract
 * - Pure logic: the caller extracts the headers and the peer address; no I/O.
 * - Every request, whatever its route, must name this server in Host (one of
 *   127.0.0.1:PORT, localhost:PORT, [::1]:PORT, the listen address, or an
 *   allowed_hosts entry, compared case-insensitively; for port 80 also the
 *   bare names), and an Origin, when sent, must be http(s):// one of those.
 *   This is what stops DNS rebinding and cross-site requests.
 * - Headers that must come at most once (guard_single_header()) make a
 *   request a 400 when repeated: first-wins or last-wins parsing differs
 *   between us and any proxy in front.
 * - Token: mutating requests always need `Authorization: Bearer TOKEN`.
 *   Reads (routes not marked open) need it with read_auth "token", never with
 *   "open", and with "auto" unless the client is local: its TCP peer is a
 *   loopback address, its Host is a loopback name (127.0.0.1, localhost,
 *   [::1]) and it came through no proxy (no Forwarded, X-Forwarded-For or
 *   X-Real-IP header). So a daemon listening on all interfaces serves open
 *   reads to local tools only, and a reverse proxy on the same machine does
 *   not open reads to the world.
 * - guard_check() answers 0 (admit) or the HTTP status with one line in msg.
 */

typedef struct guard guard_t;

typedef enum { GUARD_READ_AUTO = 0, GUARD_READ_OPEN, GUARD_READ_TOKEN } guard_read_t;

/* What a route needs (route flags of api.h map onto these). */
typedef enum { GUARD_ROUTE_READ = 0, GUARD_ROUTE_OPEN, GUARD_ROUTE_MUTATES } guard_route_t;

typedef struct {
	const char *host;           /* header values, NULL when absent */
	const char *origin;
	const char *authorization;
	const char *duplicate;      /* name of a single-valued header that came twice, or NULL */
	int forwarded;              /* Forwarded, X-Forwarded-For or X-Real-IP present */
	int peer_loopback;          /* the TCP peer address is a loopback address */
} guard_req_t;

/* listen_host: the host part of the listen key (numeric, or "localhost");
 * allowed_hosts: comma/space-separated extra Host values; token: copied.
 * NULL when out of memory or more hosts than fit (err says). */
guard_t *guard_create(const char *listen_host, int port, const char *allowed_hosts, guard_read_t read_auth,
                      const char *token, char *err, size_t errlen);
void guard_destroy(guard_t *g);

/* 0 to admit, else 400 (repeated header, no Host), 401 (token missing or
 * wrong) or 403 (foreign Host or Origin); msg gets the reason. */
int guard_check(const guard_t *g, const guard_req_t *r, guard_route_t route, char *msg, size_t msglen);

/* The client counts as local (see above). */
int guard_local(const guard_t *g, const guard_req_t *r);

/* A read on this request would need the token (for 401 hints and tests). */
int guard_read_needs_token(const guard_t *g, const guard_req_t *r);

/* Header names that must not repeat (case-insensitive). */
int guard_single_header(const char *name);

/* The address is loopback: 127.0.0.0/8, ::1, or ::ffff:127.0.0.0/104. */
int guard_addr_loopback(const struct sockaddr *sa);

/* Parse "Bearer TOKEN" (scheme case-insensitive) and compare in constant time. */
int guard_token_ok(const guard_t *g, const char *authorization);
