/* Tests of the REST API layer below HTTP (daemon/api.c): error bodies, whatever bytes a request carries. */
#include <string.h>

#include "api.h"
#include "tap.h"

/* The standard error body {"error": {"code", "message"}} with both strings. */
static int error_body(const api_resp_t *rs, const char *code)
{
	json_t *e = json_object_get(rs->json, "error");
	const char *c = json_string_value(json_object_get(e, "code"));
	return c && !strcmp(c, code) && json_is_string(json_object_get(e, "message"));
}

static const char *query_state;
static const char *q_get(void *conn, const char *key) { return !strcmp(key, "state") ? query_state : NULL; }
static const char *h_get(void *conn, const char *key) { return NULL; }

int main(void)
{
	plan(5);
	api_resp_t rs = {0};

	api_error(&rs, 404, "no such file: caf\xc3\xa9");
	ok(rs.status == 404 && error_body(&rs, "not_found") &&
	   !strcmp(json_string_value(json_object_get(json_object_get(rs.json, "error"), "message")), "no such file: caf\xc3\xa9"),
	   "a UTF-8 message is kept as it is");
	json_decref(rs.json);
	rs.json = NULL;

	/* Found by tests/fuzz/api_fuzz (corpus/api/regress-static-nonutf8): a
	 * percent-decoded path with a byte that is not UTF-8 made the 404 body
	 * unencodable, and the answer went out without any body. */
	api_error(&rs, 404, "no such file: \xff\xfe");
	ok(rs.status == 404 && error_body(&rs, "not_found"), "a message with non-UTF-8 bytes still gives the error body");
	json_decref(rs.json);
	rs.json = NULL;

	char store[4][128], allow[128];
	int known = 0;
	api_req_t rq = {.method = "GET", .path = "/static/\xff.js", .query = q_get, .header = h_get};
	const api_route_t *rt = api_match(rq.method, rq.path, &rq, store, &known, allow, sizeof(allow));
	ok(rt != NULL, "GET /static/<non-UTF-8 name> is routed");
	if (rt)
		rt->fn(NULL, &rq, &rs);
	ok(rs.status == 404 && error_body(&rs, "not_found"), "and answers 404 with the error body");
	json_decref(rs.json);
	rs.json = NULL;

	/* A query value quoted at most 64 bytes: the cut may split a UTF-8 character. */
	char st[80];
	memset(st, 'a', 63);
	memcpy(st + 63, "\xc3\xa9", 3);
	query_state = st;
	api_req_t lq = {.method = "GET", .path = "/api/v1/jobs", .query = q_get, .header = h_get};
	rt = api_match(lq.method, lq.path, &lq, store, &known, allow, sizeof(allow));
	if (rt)
		rt->fn(NULL, &lq, &rs);
	ok(rs.status == 400 && error_body(&rs, "bad_request"), "a state filter cut inside a UTF-8 character gives a 400 body");
	json_decref(rs.json);
	return tap_failed != 0;
}
