/* REST API of granulard: the route table and its handlers (parse the request, call the queue, serialise). */
#pragma once

#include <stdatomic.h>
#include <stddef.h>
#include <stdint.h>
#include <jansson.h>
#include "cfg.h"
#include "hub.h"
#include "jobq.h"
#include "scheduler.h"

/* Everything a handler may use; owned by main.c, shared read-only by the HTTP threads. */
typedef struct gd {
	const cfg_t *cfg;
	jobq_t *q;
	hub_t *hub;
	sched_t *sched;
	const char *token;
	const char *jobs_dir;
	double started;             /* unix time of start */
	atomic_int stopping;        /* shutting down: mutating requests get 503 */
	atomic_long requests, responses_by_class[6];   /* [1..5] = 1xx..5xx */
	/* kept by the HTTP layer, for /metrics */
	atomic_int open_connections, open_streams;
	atomic_long refused_connections, evicted_connections;
} gd_t;

enum {
	API_MUTATES = 1u << 0,
	API_OPEN = 1u << 1,    /* never needs a token (Host and Origin are still checked) */
	API_INLINE = 1u << 2,  /* never blocks (no database, no files): runs on the polling thread */
};

typedef struct {
	const char *method;
	const char *path;
	const char *params[4];      /* values of {placeholders}, in order */
	int nparams;
	const char *body;
	size_t body_len;
	const char *last_event_id;  /* SSE reconnect header or NULL */
	/* query string and header lookup; NULL when absent */
	const char *(*query)(void *conn, const char *key);
	const char *(*header)(void *conn, const char *key);
	void *conn;
} api_req_t;

typedef struct {
	int status;
	json_t *json;               /* response body (handler's reference, freed by the HTTP layer) */
	const char *raw;            /* or a static body with its content type */
	size_t raw_len;
	char *owned;                /* or a malloc'd body (freed by the HTTP layer) */
	const char *ctype;
	int sse;                    /* start an event stream instead of a body */
	int64_t sse_job;            /* 0 = every job */
	int retry_after;            /* seconds, for 429/503 */
	int has_file;               /* send file_len bytes of fd from file_off (the HTTP layer closes fd) */
	int fd;
	uint64_t file_off, file_len, file_size;
	char disposition[200];      /* Content-Disposition value, or "" */
} api_resp_t;

typedef void (*api_handler_fn)(gd_t *gd, const api_req_t *rq, api_resp_t *rs);

typedef struct {
	const char *method;
	const char *pattern;        /* "/api/v1/jobs/{id}": {x} matches one path segment */
	api_handler_fn fn;
	unsigned flags;
} api_route_t;

extern const api_route_t api_routes[];
extern const size_t api_nroutes;

/* Find the route for method and path. Returns the route, or NULL with
 * *path_known = 1 when the path exists under another method (405; allow
 * lists them). Fills params (pointers into store). */
const api_route_t *api_match(const char *method, const char *path, api_req_t *rq, char store[][128],
                             int *path_known, char *allow, size_t allowlen);

/* Strict integer syntax: [-]digits, no leading zeros, no '+' or spaces. 0 or -1. */
int api_parse_int(const char *s, long long *v);

/* Fill rs with the standard error body {"error": {"code", "message"}}. */
void api_error(api_resp_t *rs, int status, const char *message);
