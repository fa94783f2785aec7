/* Dotted-path assignments on JSON documents ("run.until.time=5"), for granularctl submit --set. */
#pragma once

#include <stddef.h>
#include <jansson.h>

enum { JPATH_OK = 0, JPATH_EINVAL = -1, JPATH_ENOMEM = -2 };

/* Apply "a.b.c=VALUE" to root (an object), creating missing objects on the way.
 * VALUE is parsed as JSON (numbers, true/false/null, "strings", [..], {..});
 * anything that is not JSON is taken as a string. A path through a non-object
 * is an error. On error root may be unchanged and err holds one line. */
int jpath_set(json_t *root, const char *assignment, char *err, size_t errlen);
