/* Unit tests of the request admission rules (guard): Host and Origin, repeated headers, read_auth, the token. */
#include <arpa/inet.h>
#include <netinet/in.h>
#include <string.h>
#include "guard.h"
#include "tap.h"

static int check(const guard_t *g, const char *host, const char *origin, const char *auth, int loopback,
                 int forwarded, guard_route_t route)
{
	char msg[256];
	guard_req_t r = {.host = host, .origin = origin, .authorization = auth, .peer_loopback = loopback,
	                 .forwarded = forwarded};
	return guard_check(g, &r, route, msg, sizeof(msg));
}

int main(void)
{
	char err[256];
	guard_t *g = guard_create("127.0.0.1", 8080, "sim.example.org, proxy.local:8443", GUARD_READ_AUTO, "s3cret",
	                          err, sizeof(err));
	ok(g != NULL, "guard_create: %s", g ? "ok" : err);
	if (!g)
		return 1;

	/* Host on every route, open ones included (DNS rebinding: any name may resolve to us). */
	ok(check(g, "127.0.0.1:8080", NULL, NULL, 1, 0, GUARD_ROUTE_OPEN) == 0, "open route, Host 127.0.0.1:8080: admitted");
	ok(check(g, "LocalHost:8080", NULL, NULL, 1, 0, GUARD_ROUTE_READ) == 0, "Host compared case-insensitively");
	ok(check(g, "[::1]:8080", NULL, NULL, 1, 0, GUARD_ROUTE_READ) == 0, "Host [::1]:8080: admitted");
	ok(check(g, "attacker.example:8080", NULL, NULL, 1, 0, GUARD_ROUTE_OPEN) == 403, "open route, foreign Host: 403");
	ok(check(g, "attacker.example:8080", NULL, "Bearer s3cret", 1, 0, GUARD_ROUTE_READ) == 403,
	   "foreign Host with the right token: still 403");
	ok(check(g, "127.0.0.1:8081", NULL, NULL, 1, 0, GUARD_ROUTE_READ) == 403, "our name on another port: 403");
	ok(check(g, "127.0.0.1", NULL, NULL, 1, 0, GUARD_ROUTE_READ) == 403, "bare name when the port is not 80: 403");
	ok(check(g, NULL, NULL, NULL, 1, 0, GUARD_ROUTE_OPEN) == 400, "no Host: 400");
	ok(check(g, "sim.example.org", NULL, "Bearer s3cret", 0, 1, GUARD_ROUTE_READ) == 0, "allowed_hosts entry: admitted");
	ok(check(g, "proxy.local:8443", NULL, "Bearer s3cret", 0, 1, GUARD_ROUTE_READ) == 0,
	   "allowed_hosts entry with a port: admitted");

	/* Origin, when sent. */
	ok(check(g, "127.0.0.1:8080", "http://127.0.0.1:8080", NULL, 1, 0, GUARD_ROUTE_READ) == 0, "own Origin: admitted");
	ok(check(g, "127.0.0.1:8080", "http://attacker.example", NULL, 1, 0, GUARD_ROUTE_READ) == 403, "foreign Origin: 403");
	ok(check(g, "127.0.0.1:8080", "null", NULL, 1, 0, GUARD_ROUTE_OPEN) == 403, "Origin null: 403");
	ok(check(g, "127.0.0.1:8080", "http://127.0.0.1:8080/x", NULL, 1, 0, GUARD_ROUTE_READ) == 403,
	   "Origin with a path: 403");
	ok(check(g, "127.0.0.1:8080", "ftp://127.0.0.1:8080", NULL, 1, 0, GUARD_ROUTE_READ) == 403, "Origin ftp://: 403");

	/* Repeated headers. */
	guard_req_t d = {.host = "127.0.0.1:8080", .duplicate = "Host", .peer_loopback = 1};
	ok(guard_check(g, &d, GUARD_ROUTE_OPEN, err, sizeof(err)) == 400 && strstr(err, "Host"),
	   "a repeated Host: 400 naming it (%s)", err);
	ok(guard_single_header("origin") && guard_single_header("HOST") && guard_single_header("Authorization") &&
	       guard_single_header("Content-Length") && !guard_single_header("Accept") && !guard_single_header("Cookie"),
	   "single-valued headers: Host, Origin, Authorization, Content-Length; not Accept or Cookie");

	/* read_auth auto: local means loopback peer, loopback Host, no proxy headers. */
	ok(check(g, "127.0.0.1:8080", NULL, NULL, 1, 0, GUARD_ROUTE_READ) == 0, "auto: local read without token: admitted");
	ok(check(g, "127.0.0.1:8080", NULL, NULL, 0, 0, GUARD_ROUTE_READ) == 401, "auto: remote peer, no token: 401");
	ok(check(g, "127.0.0.1:8080", NULL, NULL, 1, 1, GUARD_ROUTE_READ) == 401,
	   "auto: loopback peer through a proxy (X-Forwarded-For), no token: 401");
	ok(check(g, "sim.example.org", NULL, NULL, 1, 0, GUARD_ROUTE_READ) == 401,
	   "auto: loopback peer but a non-loopback Host, no token: 401");
	ok(check(g, "127.0.0.1:8080", NULL, NULL, 0, 0, GUARD_ROUTE_OPEN) == 0, "auto: open route from a remote peer: admitted");
	ok(check(g, "127.0.0.1:8080", NULL, "Bearer s3cret", 0, 0, GUARD_ROUTE_READ) == 0, "auto: remote peer with token: admitted");
	ok(check(g, "127.0.0.1:8080", NULL, "Bearer wrong", 0, 0, GUARD_ROUTE_READ) == 401, "wrong token: 401");
	ok(check(g, "127.0.0.1:8080", NULL, NULL, 1, 0, GUARD_ROUTE_MUTATES) == 401, "mutation without token, local: 401");
	ok(check(g, "127.0.0.1:8080", NULL, "bearer   s3cret", 1, 0, GUARD_ROUTE_MUTATES) == 0,
	   "scheme case-insensitive, spaces before the token");
	ok(check(g, "127.0.0.1:8080", NULL, "Bearer s3cretX", 1, 0, GUARD_ROUTE_MUTATES) == 401 &&
	       check(g, "127.0.0.1:8080", NULL, "Bearer s3cre", 1, 0, GUARD_ROUTE_MUTATES) == 401 &&
	       check(g, "127.0.0.1:8080", NULL, "Basic s3cret", 1, 0, GUARD_ROUTE_MUTATES) == 401,
	   "longer, shorter or non-Bearer tokens: 401");
	guard_destroy(g);

	g = guard_create("0.0.0.0", 80, "", GUARD_READ_TOKEN, "s3cret", err, sizeof(err));
	ok(g && check(g, "127.0.0.1:80", NULL, NULL, 1, 0, GUARD_ROUTE_READ) == 401 &&
	       check(g, "127.0.0.1:80", NULL, "Bearer s3cret", 1, 0, GUARD_ROUTE_READ) == 0,
	   "read_auth token: a local read needs the token");
	ok(g && check(g, "localhost", NULL, NULL, 1, 0, GUARD_ROUTE_OPEN) == 0, "port 80: the bare name is ours too");
	guard_destroy(g);
	g = guard_create("127.0.0.1", 8080, "", GUARD_READ_OPEN, "s3cret", err, sizeof(err));
	ok(g && check(g, "127.0.0.1:8080", NULL, NULL, 0, 1, GUARD_ROUTE_READ) == 0 &&
	       check(g, "127.0.0.1:8080", NULL, NULL, 0, 1, GUARD_ROUTE_MUTATES) == 401,
	   "read_auth open: reads open from anywhere, mutations still need the token");
	guard_destroy(g);
	guard_destroy(NULL);

	struct sockaddr_in a4 = {.sin_family = AF_INET};
	struct sockaddr_in6 a6 = {.sin6_family = AF_INET6};
	inet_pton(AF_INET, "127.3.2.1", &a4.sin_addr);
	int l4 = guard_addr_loopback((struct sockaddr *)&a4);
	inet_pton(AF_INET, "10.0.0.1", &a4.sin_addr);
	int r4 = guard_addr_loopback((struct sockaddr *)&a4);
	inet_pton(AF_INET6, "::1", &a6.sin6_addr);
	int l6 = guard_addr_loopback((struct sockaddr *)&a6);
	inet_pton(AF_INET6, "::ffff:127.0.0.1", &a6.sin6_addr);
	int m6 = guard_addr_loopback((struct sockaddr *)&a6);
	inet_pton(AF_INET6, "fe80::1", &a6.sin6_addr);
	int r6 = guard_addr_loopback((struct sockaddr *)&a6);
	ok(l4 && !r4 && l6 && m6 && !r6, "loopback: 127/8, ::1, ::ffff:127.0.0.1; not 10.0.0.1 or fe80::1");

	plan(tap_n);
	return tap_failed != 0;
}
