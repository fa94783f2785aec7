/* Tests for daemon/curves.c: one family's samples from observables.jsonl, first/last N, after, a line being written, errors. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>
#include <jansson.h>

#include "curves.h"
#include "tap.h"

static char dir[] = "/tmp/curves_test.XXXXXX";

static void write_file(const char *text)
{
	char p[200];
	snprintf(p, sizeof(p), "%s/observables.jsonl", dir);
	FILE *f = fopen(p, "w");
	fputs(text, f);
	fclose(f);
}

/* The sample indices of an answer, as "0,1,2". */
static const char *samples(json_t *j)
{
	static char s[200];
	size_t i;
	json_t *o;
	s[0] = '\0';
	json_array_foreach(json_object_get(j, "samples"), i, o)
		snprintf(s + strlen(s), sizeof(s) - strlen(s), "%s%lld", i ? "," : "",
		         (long long)json_integer_value(json_object_get(o, "sample")));
	return s;
}

int main(void)
{
	char err[600];
	json_t *j = NULL;
	plan(12);
	if (!mkdtemp(dir))
		return 1;

	ok(curves_read(dir, "impact_parameter", -1, 10, 0, &j, err, sizeof(err)) == CURVES_OK &&
	   json_array_size(json_object_get(j, "samples")) == 0 && json_integer_value(json_object_get(j, "next")) == -1,
	   "no file yet: no samples, next = after");
	json_decref(j);

	char text[4000] = "";
	for (int k = 0; k < 5; k++)
		snprintf(text + strlen(text), sizeof(text) - strlen(text),
		         "{\"name\":\"pair_correlation\",\"sample\":%d,\"tables\":[]}\n"
		         "{\"name\":\"impact_parameter\",\"sample\":%d,\"tables\":[{\"x\":\"b\"}]}\n", k, k);
	strcat(text, "{\"name\":\"impact_parameter\",\"sample\":5,\"tab");   /* being written */
	write_file(text);

	ok(curves_read(dir, "impact_parameter", -1, 100, 0, &j, err, sizeof(err)) == CURVES_OK &&
	   !strcmp(samples(j), "0,1,2,3,4") && json_is_false(json_object_get(j, "truncated")),
	   "all samples of the family, the line being written left out: %s", samples(j));
	json_decref(j);
	ok(curves_read(dir, "impact_parameter", 1, 2, 0, &j, err, sizeof(err)) == CURVES_OK && !strcmp(samples(j), "2,3") &&
	   json_is_true(json_object_get(j, "truncated")) && json_integer_value(json_object_get(j, "next")) == 3,
	   "after 1, the first 2: %s, truncated, next 3", samples(j));
	json_decref(j);
	ok(curves_read(dir, "impact_parameter", -1, 2, 1, &j, err, sizeof(err)) == CURVES_OK && !strcmp(samples(j), "3,4"),
	   "the last 2: %s", samples(j));
	json_decref(j);
	ok(curves_read(dir, "impact_parameter", 4, 2, 1, &j, err, sizeof(err)) == CURVES_OK && !strcmp(samples(j), "") &&
	   json_integer_value(json_object_get(j, "next")) == 4, "after the last: none, next stays 4");
	json_decref(j);
	ok(curves_read(dir, "pair_correlation", 3, 5, 0, &j, err, sizeof(err)) == CURVES_OK && !strcmp(samples(j), "4") &&
	   !strcmp(json_string_value(json_object_get(j, "name")), "pair_correlation"),
	   "another family from the same file: %s", samples(j));
	json_decref(j);
	j = NULL;
	ok(curves_read(dir, "temperature", -1, 5, 0, &j, err, sizeof(err)) == CURVES_ENAME && !j && strstr(err, "name:") &&
	   strstr(err, "impact_parameter"), "unknown family: CURVES_ENAME, '%s'", err);
	ok(curves_read(dir, NULL, -1, 5, 0, &j, err, sizeof(err)) == CURVES_ENAME, "no name: CURVES_ENAME");

	/* a damaged line of the family (not JSON) is skipped, the others read */
	write_file("{\"name\":\"clusters\",\"sample\":0}\n{\"name\":\"clusters\",garbage\n{\"name\":\"clusters\",\"sample\":2}\n");
	ok(curves_read(dir, "clusters", -1, 5, 0, &j, err, sizeof(err)) == CURVES_OK && !strcmp(samples(j), "0,2"),
	   "a damaged line skipped: %s", samples(j));
	json_decref(j);

	/* a line over the bound is refused, not read into memory as a sample */
	char p[200];
	snprintf(p, sizeof(p), "%s/observables.jsonl", dir);
	FILE *f = fopen(p, "w");
	fputs("{\"name\":\"clusters\",\"sample\":0,\"x\":\"", f);
	for (unsigned i = 0; i < CURVES_MAX_LINE / 64 + 1; i++)
		fputs("0123456789012345678901234567890123456789012345678901234567890123", f);
	fputs("\"}\n", f);
	fclose(f);
	ok(curves_read(dir, "clusters", -1, 5, 0, &j, err, sizeof(err)) == CURVES_EIO && strstr(err, "line"),
	   "a line over %u bytes: CURVES_EIO, '%s'", CURVES_MAX_LINE, err);
	/* ... but only for its own family: another family's samples are read past it (a large fields grid) */
	f = fopen(p, "a");
	fputs("{\"name\":\"fields\",\"sample\":0}\n", f);
	fclose(f);
	ok(curves_read(dir, "fields", -1, 5, 0, &j, err, sizeof(err)) == CURVES_OK && !strcmp(samples(j), "0"),
	   "another family's line over the bound is skipped: fields samples %s", samples(j));
	json_decref(j);
	ok(!strcmp(curves_strerror(CURVES_ENAME), "unknown observable"), "curves_strerror");
	unlink(p);
	rmdir(dir);
	return done_testing();
}
