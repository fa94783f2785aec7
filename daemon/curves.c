/* Curves for the API: scan DIR/observables.jsonl line by line, keep the samples of one family within a memory bound. */
#include <config.h>
#include "curves.h"

#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/types.h>

const char *const curves_families[] = {
	"velocity_distribution", "pair_correlation", "structure_factor", "velocity_correlations", "clusters",
	"impact_parameter", "fields", "density_spectrum", "surface_profile", NULL,
};

int curves_known(const char *name)
{
	for (int i = 0; name && curves_families[i]; i++)
		if (!strcmp(name, curves_families[i]))
			return 1;
	return 0;
}

const char *curves_strerror(int code)
{
	switch (code) {
	case CURVES_OK: return "ok";
	case CURVES_ENAME: return "unknown observable";
	case CURVES_EIO: return "cannot read observables.jsonl";
	case CURVES_ENOMEM: return "out of memory";
	default: return "unknown error";
	}
}

/* Kept samples: a ring of at most cap parsed objects (tail) or a plain list (head). */
typedef struct {
	json_t **v;
	size_t *len;
	int cap, n, first;
	size_t bytes;
} keep_t;

static void keep_drop_first(keep_t *k)
{
	json_decref(k->v[k->first]);
	k->bytes -= k->len[k->first];
	k->first = (k->first + 1) % k->cap;
	k->n--;
}

int curves_read(const char *dir, const char *name, long long after, int count, int tail, json_t **out, char *err,
                size_t errlen)
{
	char path[4300], prefix[160];
	FILE *f = NULL;
	char *line = NULL;
	size_t lcap = 0;
	keep_t k = {0};
	int ret = CURVES_ENOMEM, truncated = 0;
	long long next = after;
	json_t *res = NULL, *arr = NULL;

	*out = NULL;
	if (!curves_known(name)) {
		char known[400] = "";
		for (int i = 0; curves_families[i]; i++)
			snprintf(known + strlen(known), sizeof(known) - strlen(known), "%s%s", i ? ", " : "",
			         curves_families[i]);
		snprintf(err, errlen, "name: '%.64s' is not an observable with curves (known: %s)", name ? name : "",
		         known);
		return CURVES_ENAME;
	}
	if (count < 1)
		count = 1;
	k.cap = count;
	k.v = calloc((size_t)count, sizeof(*k.v));
	k.len = calloc((size_t)count, sizeof(*k.len));
	if (!k.v || !k.len)
		goto cleanup;
	/* the engine writes each line as {"name":"FAMILY","sample":... */
	snprintf(prefix, sizeof(prefix), "{\"name\":\"%s\",", name);
	snprintf(path, sizeof(path), "%s/observables.jsonl", dir);
	f = fopen(path, "r");
	if (!f && errno != ENOENT) {
		snprintf(err, errlen, "observables.jsonl: %s", strerror(errno));
		ret = CURVES_EIO;
		goto cleanup;
	}
	for (ssize_t n; f && (n = getdelim(&line, &lcap, '\n', f)) > 0;) {
		if (line[n - 1] != '\n')
			break;                         /* being written */
		if (strncmp(line, prefix, strlen(prefix)))
			continue;                      /* another family's line, however long (a large fields grid) */
		if ((size_t)n > CURVES_MAX_LINE) {
			snprintf(err, errlen, "observables.jsonl: a line of %zd bytes (more than %u)", n, CURVES_MAX_LINE);
			ret = CURVES_EIO;
			goto cleanup;
		}
		json_error_t je;
		json_t *o = json_loadb(line, (size_t)n, 0, &je);
		json_t *s = o ? json_object_get(o, "sample") : NULL;
		if (!json_is_integer(s) || json_integer_value(s) <= after) {
			json_decref(o);                /* earlier, or not a sample (damaged: skipped) */
			continue;
		}
		if (!tail && (k.n == k.cap || k.bytes + (size_t)n > CURVES_MAX_BYTES)) {
			truncated = 1;                 /* more to come: the client asks again after next */
			json_decref(o);
			break;
		}
		if (tail && k.n == k.cap)
			keep_drop_first(&k);
		while (tail && k.n && k.bytes + (size_t)n > CURVES_MAX_BYTES) {
			keep_drop_first(&k);
			truncated = 1;
		}
		int slot = (k.first + k.n) % k.cap;
		k.v[slot] = o;
		k.len[slot] = (size_t)n;
		k.bytes += (size_t)n;
		k.n++;
	}
	if (f && ferror(f)) {
		snprintf(err, errlen, "observables.jsonl: %s", strerror(errno));
		ret = CURVES_EIO;
		goto cleanup;
	}
	arr = json_array();
	if (!arr)
		goto cleanup;
	for (int i = 0; i < k.n; i++) {
		int slot = (k.first + i) % k.cap;
		long long s = json_integer_value(json_object_get(k.v[slot], "sample"));
		next = s > next ? s : next;
		if (json_array_append_new(arr, k.v[slot]))
			goto cleanup;
		k.v[slot] = NULL;
	}
	k.n = 0;
	res = json_pack("{s:s, s:o, s:I, s:b}", "name", name, "samples", arr, "next", (json_int_t)next, "truncated",
	                truncated);
	arr = NULL;
	if (!res)
		goto cleanup;
	*out = res;
	ret = CURVES_OK;
cleanup:
	if (ret == CURVES_ENOMEM)
		snprintf(err, errlen, "out of memory");
	for (int i = 0; k.v && i < k.n; i++)
		json_decref(k.v[(k.first + i) % k.cap]);
	json_decref(arr);
	free(k.v);
	free(k.len);
	free(line);
	if (f)
		fclose(f);
	return ret;
}
