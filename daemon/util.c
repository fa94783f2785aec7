/* System helpers for the daemon: clocks, crash-safe file writes, process identity, random tokens. */
#define _GNU_SOURCE
#include <dirent.h>
#include <errno.h>
#include <fcntl.h>
#include <libgen.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/random.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>
#include "util.h"

double util_now(void)
{
	struct timespec ts;
	clock_gettime(CLOCK_REALTIME, &ts);
	return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

int util_mkdirs(const char *path, int mode)
{
	char buf[4096];
	if (snprintf(buf, sizeof(buf), "%s", path) >= (int)sizeof(buf)) {
		errno = ENAMETOOLONG;
		return -1;
	}
	for (char *p = buf + 1; *p; p++)
		if (*p == '/') {
			*p = '\0';
			if (mkdir(buf, (mode_t)mode) && errno != EEXIST)
				return -1;
			*p = '/';
		}
	if (mkdir(buf, (mode_t)mode) && errno != EEXIST)
		return -1;
	return 0;
}

int util_write_atomic(const char *path, const char *data, size_t len, char *err, size_t errlen)
{
	char tmp[4200], dir[4200];
	int fd = -1, ret = -1;
	snprintf(tmp, sizeof(tmp), "%s.tmp", path);
	snprintf(dir, sizeof(dir), "%s", path);
	fd = open(tmp, O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0640);
	if (fd < 0)
		goto fail;
	for (size_t o = 0; o < len;) {
		ssize_t w = write(fd, data + o, len - o);
		if (w < 0) {
			if (errno == EINTR)
				continue;
			goto fail;
		}
		o += (size_t)w;
	}
	if (fsync(fd) || close(fd)) {
		fd = -1;
		goto fail;
	}
	fd = -1;
	if (rename(tmp, path))
		goto fail;
	fd = open(dirname(dir), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
	if (fd >= 0) {
		fsync(fd);
		close(fd);
	}
	return 0;
fail:
	snprintf(err, errlen, "%s: %s", path, strerror(errno));
	if (fd >= 0)
		close(fd);
	unlink(tmp);
	return ret;
}

int util_rmtree(const char *path)
{
	DIR *d = opendir(path);
	struct dirent *e;
	char sub[4200];
	if (!d)
		return errno == ENOENT ? 0 : -1;
	while ((e = readdir(d))) {
		if (!strcmp(e->d_name, ".") || !strcmp(e->d_name, ".."))
			continue;
		snprintf(sub, sizeof(sub), "%s/%s", path, e->d_name);
		struct stat st;
		if (lstat(sub, &st) == 0 && S_ISDIR(st.st_mode))
			util_rmtree(sub);
		else
			unlink(sub);
	}
	closedir(d);
	return rmdir(path);
}

/* State, parent and start time of a process from /proc/PID/stat; any pointer may be NULL. */
static int read_stat(pid_t pid, char *state, pid_t *ppid, uint64_t *start)
{
	char path[64], buf[1024];
	snprintf(path, sizeof(path), "/proc/%d/stat", (int)pid);
	FILE *f = fopen(path, "re");
	if (!f)
		return -1;
	size_t n = fread(buf, 1, sizeof(buf) - 1, f);
	fclose(f);
	buf[n] = '\0';
	/* The command name may hold spaces and parentheses: fields start after the last ')'. */
	char *p = strrchr(buf, ')');
	if (!p)
		return -1;
	p += 2;
	if (state)
		*state = *p;
	if (ppid)
		*ppid = (pid_t)strtol(p + 2, NULL, 10);   /* field 4 */
	/* field 3 is state; starttime is field 22, i.e. 19 fields further */
	for (int f3 = 3; f3 < 22 && p; f3++) {
		p = strchr(p, ' ');
		if (p)
			p++;
	}
	if (start)
		*start = p ? strtoull(p, NULL, 10) : 0;
	return 0;
}


int util_descendants(pid_t pid, pid_t *out, uint64_t *start, int max)
{
	int n = 0, grew = 1;
	pid_t all[4096], par[4096];
	int na = 0;
	DIR *d = opendir("/proc");
	struct dirent *e;
	if (!d)
		return 0;
	while ((e = readdir(d)) && na < 4096) {
		char *end;
		long p = strtol(e->d_name, &end, 10);
		if (*end || p <= 0)
			continue;
		all[na] = (pid_t)p;
		if (read_stat((pid_t)p, NULL, &par[na], NULL))
			continue;
		na++;
	}
	closedir(d);
	/* Transitive closure over the parent links (trees are tiny). */
	while (grew && n < max) {
		grew = 0;
		for (int i = 0; i < na && n < max; i++) {
			int known = 0, under = par[i] == pid;
			for (int k = 0; k < n; k++) {
				known |= out[k] == all[i];
				under |= par[i] == out[k];
			}
			if (under && !known) {
				out[n] = all[i];
				start[n] = util_pid_start(all[i]);
				n++;
				grew = 1;
			}
		}
	}
	return n;
}

uint64_t util_pid_start(pid_t pid)
{
	char st;
	uint64_t s = 0;
	return read_stat(pid, &st, NULL, &s) ? 0 : s;
}

int util_pid_alive(pid_t pid, uint64_t start)
{
	char st;
	uint64_t s = 0;
	if (pid <= 0 || read_stat(pid, &st, NULL, &s))
		return 0;
	if (st == 'Z' || st == 'X')
		return 0;
	return start == 0 || s == start;
}

int util_random_hex(char *out, size_t nbytes)
{
	unsigned char b[64];
	if (nbytes > sizeof(b) || getrandom(b, nbytes, 0) != (ssize_t)nbytes)
		return -1;
	for (size_t i = 0; i < nbytes; i++)
		sprintf(out + 2 * i, "%02x", b[i]);
	return 0;
}

int util_ct_equal(const char *a, const char *b)
{
	size_t na = strlen(a), nb = strlen(b);
	unsigned char d = (unsigned char)(na != nb);
	for (size_t i = 0; i < na; i++)
		d |= (unsigned char)(a[i] ^ b[i % (nb ? nb : 1)]);
	return d == 0 && nb > 0;
}

/* A cgroup memory limit file: a number of bytes, or "max" / a huge value for none. */
static uint64_t read_limit(const char *path)
{
	char buf[64] = "";
	FILE *f = fopen(path, "re");
	if (!f)
		return 0;
	if (!fgets(buf, sizeof(buf), f))
		buf[0] = '\0';
	fclose(f);
	char *end;
	unsigned long long v = strtoull(buf, &end, 10);
	return end != buf && v > 0 && v < (1ull << 62) ? (uint64_t)v : 0;
}

uint64_t util_memory_total(void)
{
	long pages = sysconf(_SC_PHYS_PAGES), page = sysconf(_SC_PAGESIZE);
	uint64_t total = pages > 0 && page > 0 ? (uint64_t)pages * (uint64_t)page : 0;
	/* Our own cgroup (systemd's MemoryMax=): v2 "0::/path", v1 "N:memory:/path". */
	char line[512], path[1024];
	FILE *f = fopen("/proc/self/cgroup", "re");
	while (f && fgets(line, sizeof(line), f)) {
		line[strcspn(line, "\n")] = '\0';
		char *rel = NULL;
		if (!strncmp(line, "0::", 3)) {
			rel = line + 3;
			snprintf(path, sizeof(path), "/sys/fs/cgroup%s/memory.max", rel);
		} else if ((rel = strstr(line, ":memory:"))) {
			rel += 8;
			snprintf(path, sizeof(path), "/sys/fs/cgroup/memory%s/memory.limit_in_bytes", rel);
		} else {
			continue;
		}
		uint64_t lim = read_limit(path);
		if (lim && (!total || lim < total))
			total = lim;
	}
	if (f)
		fclose(f);
	return total;
}
