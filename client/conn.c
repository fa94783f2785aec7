/* HTTP connection of granularctl to granulard on libcurl: request/response, SSE parsing, error messages. */
#include <config.h>
#include <stdlib.h>
#include <string.h>
#include <curl/curl.h>
#include "conn.h"

struct conn {
	CURL *curl;
	char *url;              /* base, no trailing slash */
	char *auth;             /* "Authorization: Bearer ..." or NULL */
	long status;
	char error[1024];
	/* the body being received */
	char *buf;
	size_t len, cap;
	/* streams */
	conn_event_fn fn;
	void *ud;
	int stopped;
	FILE *sink;
	int sink_failed;
};

conn_t *conn_create(const char *url, const char *token)
{
	conn_t *c = calloc(1, sizeof(*c));
	if (!c)
		return NULL;
	c->curl = curl_easy_init();
	c->url = strdup(url);
	if (token && *token) {
		size_t n = strlen(token) + 32;
		if ((c->auth = malloc(n)))
			snprintf(c->auth, n, "Authorization: Bearer %s", token);
	}
	if (!c->curl || !c->url || (token && *token && !c->auth)) {
		conn_destroy(c);
		return NULL;
	}
	size_t l = strlen(c->url);
	while (l > 0 && c->url[l - 1] == '/')
		c->url[--l] = '\0';
	return c;
}

void conn_destroy(conn_t *c)
{
	if (!c)
		return;
	if (c->curl)
		curl_easy_cleanup(c->curl);
	free(c->url);
	free(c->auth);
	free(c->buf);
	free(c);
}

long conn_status(const conn_t *c) { return c->status; }
const char *conn_error(const conn_t *c) { return c->error; }
const char *conn_url(const conn_t *c) { return c->url; }

const char *conn_strerror(int code)
{
	switch (code) {
	case CONN_OK: return "ok";
	case CONN_ENET: return "cannot reach the server";
	case CONN_EHTTP: return "the server refused the request";
	case CONN_EPROTO: return "unexpected answer from the server";
	case CONN_ENOMEM: return "out of memory";
	case CONN_EIO: return "cannot write the output file";
	default: return "unknown error";
	}
}

static int append(conn_t *c, const char *p, size_t n)
{
	if (c->len + n + 1 > c->cap) {
		size_t cap = (c->len + n + 1) * 2;
		char *b = realloc(c->buf, cap);
		if (!b)
			return -1;
		c->buf = b;
		c->cap = cap;
	}
	memcpy(c->buf + c->len, p, n);
	c->len += n;
	c->buf[c->len] = '\0';
	return 0;
}

/* Dispatch every complete event ("...\n\n") in the buffer; keep the rest. */
static void sse_dispatch(conn_t *c)
{
	char *start = c->buf, *end;
	while (!c->stopped && (end = strstr(start, "\n\n"))) {
		*end = '\0';
		char event[64] = "message", *data = NULL;
		size_t dlen = 0;
		for (char *sp = NULL, *line = strtok_r(start, "\n", &sp); line; line = strtok_r(NULL, "\n", &sp)) {
			char *v = strchr(line, ':');
			if (line[0] == ':' || !v)
				continue;   /* comment (keep-alive) or a field without value */
			*v++ = '\0';
			if (*v == ' ')
				v++;
			if (!strcmp(line, "event")) {
				snprintf(event, sizeof(event), "%s", v);
			} else if (!strcmp(line, "data")) {
				size_t n = strlen(v);
				char *d = realloc(data, dlen + n + 2);
				if (!d)
					break;
				data = d;
				if (dlen)
					data[dlen++] = '\n';
				memcpy(data + dlen, v, n + 1);
				dlen += n;
			}
		}
		if (data && c->fn(event, data, c->ud))
			c->stopped = 1;
		free(data);
		start = end + 2;
	}
	size_t rest = c->len - (size_t)(start - c->buf);
	memmove(c->buf, start, rest + 1);
	c->len = rest;
}

static size_t on_body(char *p, size_t size, size_t n, void *ud)
{
	conn_t *c = ud;
	size_t len = size * n;
	if (c->sink && c->status < 400) {
		if (fwrite(p, 1, len, c->sink) != len) {
			c->sink_failed = 1;
			return 0;
		}
		return len;
	}
	if (append(c, p, len))
		return 0;
	if (c->fn && c->status < 400) {
		sse_dispatch(c);
		if (c->stopped)
			return 0;   /* makes curl abort the transfer */
	}
	return len;
}

/* The status is known before the body: it decides whether the body is data or an error document. */
static size_t on_header(char *p, size_t size, size_t n, void *ud)
{
	conn_t *c = ud;
	long code = 0;
	if (size * n > 9 && !strncmp(p, "HTTP/", 5) && sscanf(strchr(p, ' ') ? strchr(p, ' ') : p, "%ld", &code) == 1)
		c->status = code;
	return size * n;
}

/* The server's message from {"error": {"message"}}, or a generic line. */
static void http_error(conn_t *c, const char *url)
{
	json_t *j = c->buf ? json_loads(c->buf, 0, NULL) : NULL;
	const char *m = json_string_value(json_object_get(json_object_get(j, "error"), "message"));
	if (m)
		snprintf(c->error, sizeof(c->error), "%s", m);
	else
		snprintf(c->error, sizeof(c->error), "%s answered HTTP %ld", url, c->status);
	json_decref(j);
}

/* Run one transfer; body==NULL sends none. stream: no total timeout. */
static int perform(conn_t *c, const char *method, const char *path, const char *body, int stream)
{
	int rc = CONN_OK;
	struct curl_slist *h = NULL;
	char url[4096], cerr[CURL_ERROR_SIZE] = "";
	CURLcode cr;

	c->status = 0;
	c->error[0] = '\0';
	c->len = 0;
	c->stopped = 0;
	c->sink_failed = 0;
	if (c->buf)
		c->buf[0] = '\0';
	snprintf(url, sizeof(url), "%s%s", c->url, path);
	curl_easy_reset(c->curl);
	if (c->auth)
		h = curl_slist_append(h, c->auth);
	if (body)
		h = curl_slist_append(h, "Content-Type: application/json");
	if (stream)
		h = curl_slist_append(h, "Accept: text/event-stream");
	curl_easy_setopt(c->curl, CURLOPT_URL, url);
	curl_easy_setopt(c->curl, CURLOPT_CUSTOMREQUEST, method);
	curl_easy_setopt(c->curl, CURLOPT_HTTPHEADER, h);
	curl_easy_setopt(c->curl, CURLOPT_WRITEFUNCTION, on_body);
	curl_easy_setopt(c->curl, CURLOPT_WRITEDATA, c);
	curl_easy_setopt(c->curl, CURLOPT_HEADERFUNCTION, on_header);
	curl_easy_setopt(c->curl, CURLOPT_HEADERDATA, c);
	curl_easy_setopt(c->curl, CURLOPT_ERRORBUFFER, cerr);
	curl_easy_setopt(c->curl, CURLOPT_CONNECTTIMEOUT, 10L);
	curl_easy_setopt(c->curl, CURLOPT_NOSIGNAL, 1L);
	curl_easy_setopt(c->curl, CURLOPT_USERAGENT, "granularctl/" PACKAGE_VERSION);
	if (stream) {
		/* The daemon sends a keep-alive every 15 s: a minute of silence is a dead server. */
		curl_easy_setopt(c->curl, CURLOPT_LOW_SPEED_LIMIT, 1L);
		curl_easy_setopt(c->curl, CURLOPT_LOW_SPEED_TIME, 60L);
	} else if (!c->sink) {
		curl_easy_setopt(c->curl, CURLOPT_TIMEOUT, 120L);
	}
	if (body) {
		curl_easy_setopt(c->curl, CURLOPT_POSTFIELDS, body);
		curl_easy_setopt(c->curl, CURLOPT_POSTFIELDSIZE, (long)strlen(body));
	} else if (!strcmp(method, "POST")) {
		curl_easy_setopt(c->curl, CURLOPT_POSTFIELDS, "");
		curl_easy_setopt(c->curl, CURLOPT_POSTFIELDSIZE, 0L);
	}
	if (!strcmp(method, "HEAD"))
		curl_easy_setopt(c->curl, CURLOPT_NOBODY, 1L);
	cr = curl_easy_perform(c->curl);
	curl_easy_getinfo(c->curl, CURLINFO_RESPONSE_CODE, &c->status);
	if (cr != CURLE_OK && !(cr == CURLE_WRITE_ERROR && c->stopped)) {
		if (c->sink_failed) {
			snprintf(c->error, sizeof(c->error), "writing the download failed");
			rc = CONN_EIO;
		} else if (c->status >= 400) {
			http_error(c, url);
			rc = CONN_EHTTP;
		} else {
			snprintf(c->error, sizeof(c->error), "%s %s: %s", c->status ? "lost the connection to" : "cannot reach",
			         url, *cerr ? cerr : curl_easy_strerror(cr));
			rc = CONN_ENET;
		}
	} else if (c->status >= 400) {
		http_error(c, url);
		rc = CONN_EHTTP;
	}
	curl_slist_free_all(h);
	return rc;
}

int conn_request(conn_t *c, const char *method, const char *path, const char *body, json_t **out)
{
	json_error_t je;
	*out = NULL;
	int rc = perform(c, method, path, body, 0);
	if (rc != CONN_OK)
		return rc;
	if (!(*out = json_loads(c->buf ? c->buf : "", 0, &je))) {
		snprintf(c->error, sizeof(c->error), "%s%s: answer is not JSON (%s)", c->url, path, je.text);
		return CONN_EPROTO;
	}
	return CONN_OK;
}

int conn_stream(conn_t *c, const char *path, conn_event_fn fn, void *ud)
{
	c->fn = fn;
	c->ud = ud;
	int rc = perform(c, "GET", path, NULL, 1);
	c->fn = NULL;
	c->ud = NULL;
	return rc;
}

int conn_download(conn_t *c, const char *path, FILE *out)
{
	c->sink = out;
	int rc = perform(c, "GET", path, NULL, 0);
	c->sink = NULL;
	return rc;
}
