/* Dotted-path assignments on JSON objects: the --set KEY.PATH=VALUE overrides of granularctl. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "jpath.h"

int jpath_set(json_t *root, const char *assignment, char *err, size_t errlen)
{
	int rc = JPATH_OK;
	char *path = strdup(assignment), *eq, *key, *sp = NULL;
	json_t *value = NULL, *node = root;
	if (!path) {
		snprintf(err, errlen, "out of memory");
		return JPATH_ENOMEM;
	}
	if (!(eq = strchr(path, '=')) || eq == path) {
		snprintf(err, errlen, "--set '%s': expected KEY.PATH=VALUE", assignment);
		rc = JPATH_EINVAL;
		goto cleanup;
	}
	*eq = '\0';
	value = json_loads(eq + 1, JSON_DECODE_ANY, NULL);
	if (!value)
		value = json_string(eq + 1);
	if (!value) {
		snprintf(err, errlen, "--set '%s': value is not valid UTF-8", assignment);
		rc = JPATH_EINVAL;
		goto cleanup;
	}
	if (path[strlen(path) - 1] == '.' || strstr(path, "..") || path[0] == '.') {
		snprintf(err, errlen, "--set '%s': empty key in the path", assignment);
		rc = JPATH_EINVAL;
		goto cleanup;
	}
	key = strtok_r(path, ".", &sp);
	for (char *next; (next = strtok_r(NULL, ".", &sp)); key = next) {
		json_t *child = json_object_get(node, key);
		if (!child) {
			child = json_object();
			if (!child || json_object_set_new(node, key, child)) {
				rc = JPATH_ENOMEM;
				snprintf(err, errlen, "out of memory");
				goto cleanup;
			}
		} else if (!json_is_object(child)) {
			snprintf(err, errlen, "--set '%s': '%s' is not an object", assignment, key);
			rc = JPATH_EINVAL;
			goto cleanup;
		}
		node = child;
	}
	if (json_object_set(node, key, value)) {
		rc = JPATH_ENOMEM;
		snprintf(err, errlen, "out of memory");
	}
cleanup:
	json_decref(value);
	free(path);
	return rc;
}
