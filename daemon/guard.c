/* Request admission rules: which Host and Origin values name this server, which headers may not repeat, who needs the token. */
#include <netinet/in.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include "guard.h"
#include "util.h"

#define MAX_HOSTS 32
#define HOST_LEN 256

struct guard {
	char hosts[MAX_HOSTS][HOST_LEN];
	int nhosts;
	int nlocal;              /* hosts[0..nlocal) are the loopback names */
	guard_read_t read_auth;
	char token[256];
};

static int add_host(guard_t *g, const char *fmt, const char *name, int port, char *err, size_t errlen)
{
	if (g->nhosts >= MAX_HOSTS) {
		snprintf(err, errlen, "allowed_hosts: more than %d names", MAX_HOSTS - 8);
		return -1;
	}
	int n = snprintf(g->hosts[g->nhosts], HOST_LEN, fmt, name, port);
	if (n < 0 || n >= HOST_LEN) {
		snprintf(err, errlen, "allowed_hosts: '%.64s...' is longer than %d characters", name, HOST_LEN - 1);
		return -1;
	}
	g->nhosts++;
	return 0;
}

/* name:port, and for port 80 (which browsers leave out) the bare name too. */
static int add_name(guard_t *g, const char *name, int port, char *err, size_t errlen)
{
	const char *fmt = strchr(name, ':') && name[0] != '[' ? "[%s]:%d" : "%s:%d";
	if (add_host(g, fmt, name, port, err, errlen))
		return -1;
	if (port == 80)
		return add_host(g, strchr(name, ':') && name[0] != '[' ? "[%s]" : "%s", name, 0, err, errlen);
	return 0;
}

guard_t *guard_create(const char *listen_host, int port, const char *allowed_hosts, guard_read_t read_auth,
                      const char *token, char *err, size_t errlen)
{
	guard_t *g = calloc(1, sizeof(*g));
	char extra[4096];
	if (!g) {
		snprintf(err, errlen, "out of memory");
		return NULL;
	}
	g->read_auth = read_auth;
	snprintf(g->token, sizeof(g->token), "%s", token ? token : "");
	static const char *const local[] = {"127.0.0.1", "localhost", "::1"};
	for (size_t i = 0; i < sizeof(local) / sizeof(local[0]); i++)
		if (add_name(g, local[i], port, err, errlen))
			goto fail;
	g->nlocal = g->nhosts;
	if (listen_host && *listen_host && add_name(g, listen_host, port, err, errlen))
		goto fail;
	snprintf(extra, sizeof(extra), "%s", allowed_hosts ? allowed_hosts : "");
	for (char *sp = NULL, *t = strtok_r(extra, ", ", &sp); t; t = strtok_r(NULL, ", ", &sp))
		if (add_host(g, "%s", t, 0, err, errlen))
			goto fail;
	return g;
fail:
	free(g);
	return NULL;
}

void guard_destroy(guard_t *g)
{
	free(g);
}

static int host_in(const guard_t *g, const char *host, size_t len, int n)
{
	for (int i = 0; i < n; i++)
		if (strlen(g->hosts[i]) == len && !strncasecmp(host, g->hosts[i], len))
			return 1;
	return 0;
}

static int host_ok(const guard_t *g, const char *host)
{
	return host && host_in(g, host, strlen(host), g->nhosts);
}

/* Origin is "scheme://host[:port]" with nothing after it. */
static int origin_ok(const guard_t *g, const char *origin)
{
	const char *p;
	if (!strncasecmp(origin, "http://", 7))
		p = origin + 7;
	else if (!strncasecmp(origin, "https://", 8))
		p = origin + 8;
	else
		return 0;
	return host_ok(g, p);
}

int guard_local(const guard_t *g, const guard_req_t *r)
{
	return r->peer_loopback && !r->forwarded && r->host && host_in(g, r->host, strlen(r->host), g->nlocal);
}

int guard_read_needs_token(const guard_t *g, const guard_req_t *r)
{
	switch (g->read_auth) {
	case GUARD_READ_OPEN:
		return 0;
	case GUARD_READ_TOKEN:
		return 1;
	default:
		return !guard_local(g, r);
	}
}

int guard_token_ok(const guard_t *g, const char *a)
{
	if (!a || strncasecmp(a, "Bearer ", 7) || !*g->token)
		return 0;
	a += 7;
	while (*a == ' ')
		a++;
	return util_ct_equal(a, g->token);
}

int guard_check(const guard_t *g, const guard_req_t *r, guard_route_t route, char *msg, size_t msglen)
{
	if (r->duplicate) {
		snprintf(msg, msglen, "header %s sent more than once", r->duplicate);
		return 400;
	}
	if (!r->host) {
		snprintf(msg, msglen, "missing Host header");
		return 400;
	}
	if (!host_ok(g, r->host)) {
		snprintf(msg, msglen, "Host '%.100s' is not served here (allowed_hosts)", r->host);
		return 403;
	}
	if (r->origin && !origin_ok(g, r->origin)) {
		snprintf(msg, msglen, "cross-origin request from '%.100s' refused", r->origin);
		return 403;
	}
	int need = route == GUARD_ROUTE_MUTATES || (route == GUARD_ROUTE_READ && guard_read_needs_token(g, r));
	if (need && !guard_token_ok(g, r->authorization)) {
		if (r->authorization)
			snprintf(msg, msglen, "wrong token");
		else if (route == GUARD_ROUTE_MUTATES)
			snprintf(msg, msglen, "missing Authorization: Bearer <token> (see STATE_DIR/token)");
		else
			snprintf(msg, msglen, "missing Authorization: Bearer <token> (see STATE_DIR/token); reads need it %s",
			         g->read_auth == GUARD_READ_TOKEN ? "(read_auth = token)"
			                                          : "from clients that are not local (read_auth = auto)");
		return 401;
	}
	return 0;
}

int guard_single_header(const char *name)
{
	static const char *const single[] = {"Host", "Origin", "Authorization", "Content-Length", "Content-Type",
	                                     "Transfer-Encoding", "Range", "Last-Event-ID"};
	for (size_t i = 0; i < sizeof(single) / sizeof(single[0]); i++)
		if (!strcasecmp(name, single[i]))
			return 1;
	return 0;
}

int guard_addr_loopback(const struct sockaddr *sa)
{
	if (!sa)
		return 0;
	if (sa->sa_family == AF_INET) {
		const struct sockaddr_in *a = (const struct sockaddr_in *)sa;
		return (ntohl(a->sin_addr.s_addr) >> 24) == 127;
	}
	if (sa->sa_family == AF_INET6) {
		const struct sockaddr_in6 *a = (const struct sockaddr_in6 *)sa;
		static const unsigned char mapped[12] = {0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0xff, 0xff};
		if (!memcmp(a->sin6_addr.s6_addr, mapped, 12))
			return a->sin6_addr.s6_addr[12] == 127;
		return !memcmp(&a->sin6_addr, &in6addr_loopback, sizeof(in6addr_loopback));
	}
	return 0;
}
