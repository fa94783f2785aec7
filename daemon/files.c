/* Job output files: name checks, listings with cached SHA-256, Range parsing. */
#define _GNU_SOURCE
#include <dirent.h>
#include <errno.h>
#include <fcntl.h>
#include <gnutls/crypto.h>
#include <inttypes.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>
#include "files.h"
#include "util.h"

static int valid_name(const char *s)
{
	size_t n = strlen(s);
	if (n < 1 || n > 128 || s[0] == '.')
		return 0;
	for (size_t i = 0; i < n; i++) {
		char c = s[i];
		if (!((c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '.' || c == '_' ||
		      c == '-'))
			return 0;
	}
	return !(n > 4 && !strcmp(s + n - 4, ".tmp"));
}

static int sha256_file(int fd, char hex[65])
{
	gnutls_hash_hd_t h;
	unsigned char buf[1 << 16], dig[32];
	ssize_t r;
	if (gnutls_hash_init(&h, GNUTLS_DIG_SHA256) < 0)
		return -1;
	while ((r = read(fd, buf, sizeof(buf))) > 0)
		gnutls_hash(h, buf, (size_t)r);
	gnutls_hash_deinit(h, dig);
	if (r < 0)
		return -1;
	for (int i = 0; i < 32; i++)
		sprintf(hex + 2 * i, "%02x", dig[i]);
	return 0;
}

static int by_name(const void *a, const void *b)
{
	return strcmp(json_string_value(json_object_get(*(json_t *const *)a, "name")),
	              json_string_value(json_object_get(*(json_t *const *)b, "name")));
}

int files_list(const char *dir, json_t **out, char *err, size_t errlen)
{
	char path[4200], cache_path[4200];
	json_t *cache = NULL, *newcache = json_object(), *items[512];
	size_t n = 0;
	DIR *d = opendir(dir);
	*out = NULL;
	if (!d) {
		if (errno != ENOENT) {
			snprintf(err, errlen, "%s: %s", dir, strerror(errno));
			json_decref(newcache);
			return FILES_EIO;
		}
		*out = json_pack("{s:[]}", "files");
		json_decref(newcache);
		return FILES_OK;
	}
	snprintf(cache_path, sizeof(cache_path), "%s/.sha256", dir);
	cache = json_load_file(cache_path, 0, NULL);
	struct dirent *e;
	while ((e = readdir(d)) && n < sizeof(items) / sizeof(items[0])) {
		struct stat st;
		if (!valid_name(e->d_name))
			continue;
		snprintf(path, sizeof(path), "%s/%s", dir, e->d_name);
		if (lstat(path, &st) || !S_ISREG(st.st_mode))
			continue;
		char key[96], hex[65] = "";
		snprintf(key, sizeof(key), "%lld:%lld.%09ld", (long long)st.st_size, (long long)st.st_mtim.tv_sec,
		         st.st_mtim.tv_nsec);
		json_t *c = json_object_get(cache, e->d_name);
		if (c && !strcmp(json_string_value(json_object_get(c, "key")) ?: "", key)) {
			snprintf(hex, sizeof(hex), "%s", json_string_value(json_object_get(c, "sha256")));
		} else {
			/* O_NONBLOCK: the entry may have been swapped for a FIFO since lstat(). */
			int fd = open(path, O_RDONLY | O_CLOEXEC | O_NOFOLLOW | O_NONBLOCK);
			struct stat fst;
			if (fd < 0 || fstat(fd, &fst) || !S_ISREG(fst.st_mode) || sha256_file(fd, hex))
				hex[0] = '\0';
			if (fd >= 0)
				close(fd);
		}
		if (*hex)
			json_object_set_new(newcache, e->d_name, json_pack("{s:s, s:s}", "key", key, "sha256", hex));
		items[n++] = json_pack("{s:s, s:I, s:f, s:o}", "name", e->d_name, "size", (json_int_t)st.st_size,
		                       "modified", (double)st.st_mtim.tv_sec + 1e-9 * (double)st.st_mtim.tv_nsec, "sha256",
		                       *hex ? json_string(hex) : json_null());
	}
	closedir(d);
	qsort(items, n, sizeof(items[0]), by_name);
	json_t *arr = json_array();
	for (size_t i = 0; i < n; i++)
		json_array_append_new(arr, items[i]);
	*out = json_pack("{s:o}", "files", arr);
	/* The cache is an optimisation: failing to write it changes nothing. */
	if (!json_equal(cache, newcache)) {
		char *txt = json_dumps(newcache, JSON_COMPACT);
		char e2[256];
		if (txt)
			util_write_atomic(cache_path, txt, strlen(txt), e2, sizeof(e2));
		free(txt);
	}
	json_decref(cache);
	json_decref(newcache);
	return FILES_OK;
}

int files_open(const char *dir, const char *name, int *fd, uint64_t *size, char *err, size_t errlen)
{
	char path[4200];
	struct stat st;
	*fd = -1;
	if (!valid_name(name)) {
		snprintf(err, errlen, "file name '%.64s' is not allowed (letters, digits, . _ -; no leading dot)", name);
		return FILES_ENAME;
	}
	snprintf(path, sizeof(path), "%s/%s", dir, name);
	/* O_NONBLOCK: opening a FIFO for reading would otherwise wait for a
	 * writer, holding the handler thread forever; fstat() then refuses
	 * anything but a regular file (FIFOs, devices, sockets, directories). */
	int f = open(path, O_RDONLY | O_CLOEXEC | O_NOFOLLOW | O_NONBLOCK);
	if (f < 0 || fstat(f, &st) || !S_ISREG(st.st_mode)) {
		snprintf(err, errlen, "no file '%s' in this job", name);
		if (f >= 0)
			close(f);
		return FILES_ENOENT;
	}
	*fd = f;
	*size = (uint64_t)st.st_size;
	return FILES_OK;
}

int files_range(const char *h, uint64_t size, uint64_t *off, uint64_t *len)
{
	char *end;
	if (!h || strncmp(h, "bytes=", 6) || strchr(h, ','))
		return 0;   /* absent, another unit, or several ranges: send the whole file */
	h += 6;
	if (*h == '-') {
		unsigned long long n = strtoull(h + 1, &end, 10);
		if (*end || end == h + 1)
			return 0;
		if (n == 0 || size == 0)
			return -1;
		*len = n < size ? n : size;
		*off = size - *len;
		return 1;
	}
	unsigned long long a = strtoull(h, &end, 10), b;
	if (end == h || *end != '-')
		return 0;
	h = end + 1;
	if (*h) {
		b = strtoull(h, &end, 10);
		if (*end || b < a)
			return 0;
	} else {
		b = size ? size - 1 : 0;
	}
	if (a >= size)
		return -1;
	if (b >= size)
		b = size - 1;
	*off = a;
	*len = b - a + 1;
	return 1;
}

const char *files_content_type(const char *name)
{
	static const struct { const char *ext, *type; } types[] = {
		{".h5", "application/x-hdf5"}, {".json", "application/json"}, {".jsonl", "application/x-ndjson"},
		{".xdmf", "application/xml"}, {".txt", "text/plain; charset=utf-8"}, {".log", "text/plain; charset=utf-8"},
	};
	const char *dot = strrchr(name, '.');
	for (size_t i = 0; dot && i < sizeof(types) / sizeof(types[0]); i++)
		if (!strcmp(dot, types[i].ext))
			return types[i].type;
	return "application/octet-stream";
}
