/* libFuzzer harness: the daemon's configuration (cfg_load_file on a fuzzed file, cfg_from_args on fuzzed argv). */
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "cfg.h"

/* Input: the config file's text, then optionally a line "--\n" followed by
 * NUL- or newline-separated arguments. "--config" is followed by the path of
 * the file written from the first part, so flags and the file meet. */
static char path[64];

int LLVMFuzzerInitialize(int *argc, char ***argv)
{
	/* tmpfs when there is one: one file write per input */
	snprintf(path, sizeof path, "%s/cfg_fuzz.%ld.conf", access("/dev/shm", W_OK) ? "/tmp" : "/dev/shm", (long)getpid());
	return 0;
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
	cfg_t c;
	char err[512], *text, *args = NULL, *argv[64];
	int argc = 0;
	if (size > 65536)
		return 0;
	text = malloc(size + 1);
	if (!text)
		return 0;
	memcpy(text, data, size);
	text[size] = '\0';
	char *sep = NULL;
	for (size_t i = 0; i + 3 <= size; i++)
		if ((i == 0 || text[i - 1] == '\n') && !memcmp(text + i, "--\n", 3)) {
			sep = text + i;
			break;
		}
	size_t flen = sep ? (size_t)(sep - text) : size;
	if (sep)
		args = sep + 3;
	FILE *f = fopen(path, "wb");
	if (!f || fwrite(text, 1, flen, f) != flen) {
		if (f)
			fclose(f);
		free(text);
		return 0;
	}
	fclose(f);

	if (cfg_init(&c)) {
		free(text);
		return 0;
	}
	memset(err, 0x55, sizeof err);
	int r = cfg_load_file(&c, path, err, sizeof err);
	if (r && (r != CFG_EINVAL || !memchr(err, '\0', sizeof err)))
		__builtin_trap();
	if (args) {
		char *end = text + size;
		argv[argc++] = "granulard";
		for (char *a = args; a < end && argc < 62;) {
			size_t n = strcspn(a, "\n");   /* a NUL ends a string too */
			a[n] = '\0';
			argv[argc++] = a;
			if (!strcmp(a, "--config") && argc < 62)
				argv[argc++] = path;
			a += n + 1;
		}
		argv[argc] = NULL;
		memset(err, 0x55, sizeof err);
		r = cfg_from_args(&c, argc, argv, err, sizeof err);
		if (r && r != CFG_EHELP && !memchr(err, '\0', sizeof err))
			__builtin_trap();
	}
	cfg_deinit(&c);
	free(text);
	return 0;
}
