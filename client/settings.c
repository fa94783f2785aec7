/* Resolve granularctl's server URL and token from flags, environment and granulard's state directory. */
#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "settings.h"

/* The first line of a small file, trimmed; NULL when it cannot be read or is empty. */
static char *read_line(const char *path)
{
	char buf[1024];
	FILE *f = fopen(path, "r");
	if (!f)
		return NULL;
	char *r = fgets(buf, sizeof(buf), f);
	fclose(f);
	if (!r)
		return NULL;
	buf[strcspn(buf, "\r\n")] = '\0';
	return *buf ? strdup(buf) : NULL;
}

/* "host:port" or "http://host:port/" -> "http://host:port". */
static char *normalise(const char *u)
{
	size_t n = strlen(u) + 8;
	char *s = malloc(n);
	if (!s)
		return NULL;
	snprintf(s, n, "%s%s", strstr(u, "://") ? "" : "http://", u);
	for (size_t l = strlen(s); l > 0 && s[l - 1] == '/'; l--)
		s[l - 1] = '\0';
	return s;
}

int settings_init(settings_t *s, const char *url, const char *token, const char *token_file, const char *state_dir,
                  char *err, size_t errlen)
{
	char path[4096], *raw = NULL;
	const char *env;
	memset(s, 0, sizeof(*s));
	if (!state_dir)
		state_dir = (env = getenv("GRANULAR_STATE_DIR")) && *env ? env : "./var";

	if (url) {
		raw = strdup(url);
		snprintf(s->url_source, sizeof(s->url_source), "--url");
	} else if ((env = getenv("GRANULAR_URL")) && *env) {
		raw = strdup(env);
		snprintf(s->url_source, sizeof(s->url_source), "$GRANULAR_URL");
	} else {
		snprintf(path, sizeof(path), "%s/granulard.addr", state_dir);
		errno = 0;
		raw = read_line(path);
		snprintf(s->url_source, sizeof(s->url_source), "%s", path);
		if (!raw) {
			snprintf(err, errlen, "no server: pass --url, set GRANULAR_URL, or start granulard (%s: %s)", path,
			         errno ? strerror(errno) : "empty");
			return SETTINGS_ENOURL;
		}
	}
	s->url = raw ? normalise(raw) : NULL;
	free(raw);
	if (!s->url)
		goto nomem;

	if (token) {
		s->token = strdup(token);
		snprintf(s->token_source, sizeof(s->token_source), "--token");
	} else if (token_file) {
		/* A file keeps the token out of the command line, where ps shows it to every user. */
		errno = 0;
		if (!(s->token = read_line(token_file))) {
			snprintf(err, errlen, "--token-file %s: %s", token_file, errno ? strerror(errno) : "empty");
			settings_deinit(s);
			return SETTINGS_ETOKEN;
		}
		snprintf(s->token_source, sizeof(s->token_source), "--token-file %s", token_file);
	} else if ((env = getenv("GRANULAR_TOKEN")) && *env) {
		s->token = strdup(env);
		snprintf(s->token_source, sizeof(s->token_source), "$GRANULAR_TOKEN");
	} else {
		snprintf(path, sizeof(path), "%s/token", state_dir);
		s->token = read_line(path);
		snprintf(s->token_source, sizeof(s->token_source), "%s", s->token ? path : "none");
		return SETTINGS_OK;
	}
	if (!s->token)
		goto nomem;
	return SETTINGS_OK;
nomem:
	snprintf(err, errlen, "out of memory");
	settings_deinit(s);
	return SETTINGS_ENOMEM;
}

void settings_deinit(settings_t *s)
{
	if (!s)
		return;
	free(s->url);
	free(s->token);
	s->url = s->token = NULL;
}
