/* Small system helpers for the daemon: time, files, processes, tokens. */
#pragma once

#include <stddef.h>
#include <stdint.h>
#include <sys/types.h>

double util_now(void);                     /* unix seconds, wall clock */
int util_mkdirs(const char *path, int mode);  /* mkdir -p; 0 or -1 with errno */
/* Write a file crash-safely: PATH.tmp, fsync, rename, fsync(dir). 0 or -1 (err). */
int util_write_atomic(const char *path, const char *data, size_t len, char *err, size_t errlen);
/* Remove a directory tree (job directories); 0 or -1 with errno. */
int util_rmtree(const char *path);
/* Start time of a process (clock ticks after boot, /proc/PID/stat field 22); 0 if unknown. */
uint64_t util_pid_start(pid_t pid);
/* The process exists, is not a zombie, and (when start != 0) started at start. */
int util_pid_alive(pid_t pid, uint64_t start);
/* Descendants of pid (children, grandchildren...) from /proc, with their start
 * times; at most max. mpirun puts ranks in process groups of their own, so a
 * group signal alone does not reach them. Returns the count. */
int util_descendants(pid_t pid, pid_t *out, uint64_t *start, int max);
/* n random bytes from the kernel as 2n hex digits into out (2n+1 bytes). 0 or -1. */
int util_random_hex(char *out, size_t nbytes);
/* Constant-time comparison of two strings (time depends only on lengths). */
int util_ct_equal(const char *a, const char *b);
/* Memory this process and its children may use, in bytes: the physical
 * memory, or the memory limit of our cgroup (v2 memory.max, v1
 * memory.limit_in_bytes: systemd's MemoryMax=) when smaller; 0 if unknown. */
uint64_t util_memory_total(void);
