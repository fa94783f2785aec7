/* libFuzzer harness: the REST API below HTTP (api_match, every handler) on an in-memory job queue holding a few jobs. */
#include "fixture.h"
#include "request.h"

/*
 * Input: a request as text (request.h), given to api_match() and the
 * route's handler directly (no Host, token or body checks: those are
 * http_fuzz's). The queue: fixture.h. Checked beyond the sanitizers: a 405
 * lists the allowed methods, and fx_after() on every answer.
 */

int LLVMFuzzerInitialize(int *argc, char ***argv)
{
	(void)argc;
	(void)argv;
	fx_init("api_fuzz");
	return 0;
}

static const char *q_get(void *conn, const char *key) { return fz_query(conn, key); }
static const char *h_get(void *conn, const char *key) { return fz_header(conn, key); }

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
	fz_req_t r;
	char *buf = malloc(size + 1), store[4][128], allow[128];
	api_resp_t rs = {0};
	int known;
	if (!buf)
		return 0;
	memcpy(buf, data, size);
	if (fz_parse(buf, size, &r)) {
		free(buf);
		return 0;
	}
	fx_before();
	api_req_t ar = {.method = r.method, .path = r.path, .body = r.body, .body_len = r.body_len,
	                .last_event_id = fz_header(&r, "Last-Event-ID"), .query = q_get, .header = h_get, .conn = &r};
	const api_route_t *rt = api_match(r.method, r.path, &ar, store, &known, allow, sizeof allow);
	if (!rt) {
		if (known && !*allow)
			__builtin_trap();   /* 405 must list the allowed methods */
	} else {
		rt->fn(&gd, &ar, &rs);
		fx_after(rt, &ar, &rs);
	}
	fx_release(&rs);
	free(buf);
	return 0;
}
