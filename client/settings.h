/* Where granularctl finds its server and token: flags, then environment, then the local state directory. */
#pragma once

#include <stddef.h>

/*
 * Contract
 * - Order: --url/--token flags (or --token-file FILE, the token's first line),
 *   then $GRANULAR_URL/$GRANULAR_TOKEN, then the state directory (--state-dir,
 *   $GRANULAR_STATE_DIR, default ./var): granulard.addr ("host:port") and
 *   token, as written by granulard.
 * - settings_t is filled in place (caller-owned); settings_deinit frees its
 *   strings. A missing token is not an error (reads need none on loopback).
 */

typedef struct {
	char *url;               /* "http://host:port", no trailing slash */
	char *token;             /* or NULL */
	char url_source[512];    /* for messages: "--url", "$GRANULAR_URL", "./var/granulard.addr" */
	char token_source[512];
} settings_t;

enum { SETTINGS_OK = 0, SETTINGS_ENOURL = -1, SETTINGS_ENOMEM = -2, SETTINGS_ETOKEN = -3 };

/* url, token, token_file, state_dir: the flags (NULL when not given). On SETTINGS_ENOURL err says what was
 * tried; SETTINGS_ETOKEN: --token-file cannot be read or is empty. */
int settings_init(settings_t *s, const char *url, const char *token, const char *token_file, const char *state_dir,
                  char *err, size_t errlen);
void settings_deinit(settings_t *s);
