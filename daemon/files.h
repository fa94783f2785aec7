/* Job output files for the API: safe names, listing with sizes and SHA-256 checksums, byte ranges. */
#pragma once

#include <stddef.h>
#include <stdint.h>
#include <jansson.h>

/*
 * Contract
 * - Only regular files directly inside the job directory are visible, named
 *   by [A-Za-z0-9._-]{1,128} without a leading dot; no symlinks, no
 *   subdirectories, no "name.tmp" files (writes in progress). So no request
 *   can name anything outside the job's directory.
 * - Checksums are cached in DIR/.sha256 keyed by size and mtime, so a
 *   listing hashes each version of a file once.
 */

enum { FILES_OK = 0, FILES_ENAME = -1, FILES_ENOENT = -2, FILES_EIO = -3 };

/* {"files": [{"name", "size", "modified", "sha256"}...]} sorted by name; an absent directory lists nothing. */
int files_list(const char *dir, json_t **out, char *err, size_t errlen);

/* Open a file for reading (O_RDONLY|O_CLOEXEC|O_NOFOLLOW); the caller closes *fd. */
int files_open(const char *dir, const char *name, int *fd, uint64_t *size, char *err, size_t errlen);

/* Parse an HTTP Range header (one range: "bytes=a-b", "bytes=a-", "bytes=-n") against size.
 * 0: no usable range (send everything), 1: partial (*off, *len set), -1: unsatisfiable (416). */
int files_range(const char *header, uint64_t size, uint64_t *off, uint64_t *len);

/* Content type for a file name. */
const char *files_content_type(const char *name);
