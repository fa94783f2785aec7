/* HTTP connection of granularctl to granulard: JSON requests, server-sent event streams, downloads (libcurl). */
#pragma once

#include <stdio.h>
#include <jansson.h>

/*
 * Contract
 * - conn_create() copies url and token (token may be NULL: read-only use);
 *   conn_destroy(NULL) is a no-op. One conn_t per thread.
 * - Every call returns CONN_OK or a negative CONN_E* code. After an error,
 *   conn_error() is one line without newline for the user (the server's own
 *   message for HTTP errors; the URL tried and the reason for network errors)
 *   and conn_status() the HTTP status (0 when no answer came). Both stay
 *   valid until the next call on the same conn_t.
 * - JSON answers are returned as a new reference in *out (caller decrefs).
 */

typedef struct conn conn_t;

enum {
	CONN_OK = 0,
	CONN_ENET = -1,     /* no answer: connection refused, timeout, DNS... */
	CONN_EHTTP = -2,    /* the server answered with status >= 400 */
	CONN_EPROTO = -3,   /* the answer was not what the API promises (not JSON...) */
	CONN_ENOMEM = -4,
	CONN_EIO = -5,      /* writing a local file failed */
};

conn_t *conn_create(const char *url, const char *token);
void conn_destroy(conn_t *c);

/* method path [body]: send body (JSON text, may be NULL) and parse the JSON answer. */
int conn_request(conn_t *c, const char *method, const char *path, const char *body, json_t **out);

/* Called for each server-sent event; return nonzero to stop the stream (conn_stream then returns CONN_OK). */
typedef int (*conn_event_fn)(const char *event, const char *data, void *ud);

/* Follow the event stream at path until the server ends it or fn asks to stop. */
int conn_stream(conn_t *c, const char *path, conn_event_fn fn, void *ud);

/* GET path and write the body to out (not closed). */
int conn_download(conn_t *c, const char *path, FILE *out);

long conn_status(const conn_t *c);
const char *conn_error(const conn_t *c);
const char *conn_url(const conn_t *c);
const char *conn_strerror(int code);
