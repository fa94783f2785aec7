/* Small HDF5 and file-system helpers shared by the H5MD writer and the checkpoint files. */
#pragma once

#include <hdf5.h>
#include <stddef.h>
#include <stdint.h>

/*
 * Contract: each returns 0 on success, -1 on failure (HDF5 or errno); no
 * output. Attributes are created on obj (a group or dataset); strings are
 * fixed-length, NUL-terminated, ASCII.
 */

/* Silence HDF5's automatic error-stack printing: callers report one line. */
void h5u_quiet(void);
/* Write a printf-style message into msg (msglen bytes, may be NULL) and return code. */
int h5u_fail(char *msg, size_t msglen, int code, const char *fmt, ...) __attribute__((format(printf, 4, 5)));
int h5u_attr_str(hid_t obj, const char *name, const char *value);
int h5u_attr_strs(hid_t obj, const char *name, const char *const *values, size_t n);
int h5u_attr_i64(hid_t obj, const char *name, const int64_t *values, size_t n);
int h5u_attr_u64(hid_t obj, const char *name, uint64_t value);
int h5u_attr_f64(hid_t obj, const char *name, const double *values, size_t n);
int h5u_read_attr_u64(hid_t obj, const char *name, uint64_t *value);
int h5u_read_attr_f64(hid_t obj, const char *name, double *value);
/* New group (with intermediate groups). Returns the id or H5I_INVALID_HID. */
hid_t h5u_group(hid_t loc, const char *path);
/* A scalar NUL-terminated string dataset holding text[0..len). 0 or -1. */
int h5u_write_string(hid_t loc, const char *name, const char *text, size_t len);
/* open(path) + fsync; and fsync of the directory holding path. */
int h5u_fsync_path(const char *path);

/* The superblock version of the HDF5 file at path, read from its bytes without HDF5 (so that a damaged file
 * of the unchecksummed formats 0 and 1 never reaches HDF5's parser), or -1 (no signature at 0, 512,
 * 1024, ... below 1 GiB, or unreadable). */
int h5u_superblock_version(const char *path);

/* The chunk index of dataset d is plausible for rows [row0, row0 + rows) of its first axis (rows
 * H5U_ALL_ROWS: the whole extent): every chunk of those rows that is stored lies inside the file (eof:
 * its size in bytes), has no filter skipped (mask 0), and has exactly its raw size plus Fletcher-32's
 * four bytes when no compressing filter is set, or at most what its raw bytes can become under deflate
 * (its worst case, 0.1% and 64 bytes) otherwise. Why: the HDF5 1.8 file format's chunk index (a
 * version-1 B-tree) has no checksum; HDF5 1.10.8 allocates a chunk's recorded size before it reads and
 * verifies the chunk, so a damaged index can make it allocate up to 4 GiB, and a chunk recorded shorter
 * than it is (whose all-zero bytes still pass Fletcher-32) overflows the buffer HDF5 unfilters it into
 * when a shrink prunes it (both found by ckpt_fuzz). Datasets that are not chunked pass. 0, or -1
 * (damaged or unreadable). */
#define H5U_ALL_ROWS ((hsize_t)-1)
int h5u_chunks_sane(hid_t d, hsize_t eof, hsize_t row0, hsize_t rows);
int h5u_fsync_dir_of(const char *path);
