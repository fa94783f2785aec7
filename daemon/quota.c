/* Output limits: measure each running job's directory at most once per period and compare it with the job's limit. */
#define _GNU_SOURCE
#include <dirent.h>
#include <fcntl.h>
#include <inttypes.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include "quota.h"

/* When each job was last measured; entries of jobs not seen for a while are reused. */
typedef struct {
	int64_t id;
	double next;     /* monotonic time of the next measurement */
} slot_t;

struct quota {
	jobq_t *q;
	char *jobs_dir;
	double period;
	slot_t *slots;
	size_t n, cap;
};

quota_t *quota_create(jobq_t *q, const char *jobs_dir, double period)
{
	quota_t *qt = calloc(1, sizeof(*qt));
	if (!qt || !(qt->jobs_dir = strdup(jobs_dir))) {
		free(qt);
		return NULL;
	}
	qt->q = q;
	qt->period = period > 0 ? period : 1.0;
	return qt;
}

void quota_destroy(quota_t *qt)
{
	if (!qt)
		return;
	free(qt->slots);
	free(qt->jobs_dir);
	free(qt);
}

int64_t quota_dir_bytes(const char *dir, char *largest, size_t largest_len, int64_t *largest_bytes)
{
	DIR *d = opendir(dir);
	int64_t sum = 0, big = -1;
	struct dirent *e;
	if (!d)
		return -1;
	if (largest && largest_len)
		largest[0] = '\0';
	while ((e = readdir(d))) {
		struct stat st;
		if (fstatat(dirfd(d), e->d_name, &st, AT_SYMLINK_NOFOLLOW) != 0 || !S_ISREG(st.st_mode))
			continue;
		sum += st.st_size;
		if (st.st_size > big) {
			big = st.st_size;
			if (largest && largest_len)
				snprintf(largest, largest_len, "%s", e->d_name);
		}
	}
	closedir(d);
	if (largest_bytes)
		*largest_bytes = big < 0 ? 0 : big;
	return sum;
}

/* The slot of job id: found, a stale one reused, or a new one; NULL when out of memory. */
static slot_t *slot_of(quota_t *qt, int64_t id, double now)
{
	slot_t *stale = NULL;
	for (size_t i = 0; i < qt->n; i++) {
		if (qt->slots[i].id == id)
			return &qt->slots[i];
		if (!stale && qt->slots[i].next + 60 * qt->period < now)
			stale = &qt->slots[i];   /* not asked about for a minute of periods: the job has ended */
	}
	if (!stale) {
		if (qt->n == qt->cap) {
			size_t cap = qt->cap ? 2 * qt->cap : 16;
			slot_t *p = realloc(qt->slots, cap * sizeof(*p));
			if (!p)
				return NULL;
			qt->slots = p;
			qt->cap = cap;
		}
		stale = &qt->slots[qt->n++];
	}
	*stale = (slot_t){.id = id, .next = now};
	return stale;
}

int quota_exceeded(quota_t *qt, int64_t id, double now, char *msg, size_t msglen)
{
	char dir[4200], big[256];
	uint64_t limit = 0;
	int64_t bytes, big_bytes = 0;
	slot_t *sl = slot_of(qt, id, now);
	if (!sl || now < sl->next)
		return 0;
	sl->next = now + qt->period;
	if (jobq_output_limit(qt->q, id, &limit) != JOBQ_OK || !limit)
		return 0;
	snprintf(dir, sizeof(dir), "%s/%" PRId64, qt->jobs_dir, id);
	bytes = quota_dir_bytes(dir, big, sizeof(big), &big_bytes);
	if (bytes < 0 || (uint64_t)bytes <= limit)
		return 0;
	snprintf(msg, msglen, "output limit exceeded: the job directory holds %" PRId64 " bytes (largest: %s, %" PRId64
	         " bytes), more than its limit of %" PRIu64 " bytes; ask for fewer frames or records, or a larger "
	         "max_output_bytes", bytes, big, big_bytes, limit);
	return 1;
}
