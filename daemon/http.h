/* HTTP front end of granulard on libmicrohttpd: limits, authentication, dispatch to the API, event streams. */
#pragma once

#include <stddef.h>
#include "api.h"

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
