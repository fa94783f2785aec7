/* Connection table: per-address counts and eviction of the connection that has waited longest for a request head. */
#include <netinet/in.h>
#include <pthread.h>
#include <stdlib.h>
#include <string.h>
#include "conns.h"

typedef struct {
	unsigned char addr[16];   /* IPv4 as ::ffff:a.b.c.d, IPv6 masked to /64 */
	double since;             /* entered its phase */
	int phase;
	int pos;                  /* index in live[], -1 when not present */
} entry_t;

struct conns {
	pthread_mutex_t lock;
	entry_t *e;               /* by descriptor */
	int *live;                /* descriptors present, dense (scanned on admit) */
	int nlive, fd_cap, max_total, max_per_addr;
	long evictions;
};

static void key_of(const struct sockaddr *sa, unsigned char k[16])
{
	memset(k, 0, 16);
	if (!sa)
		return;
	if (sa->sa_family == AF_INET) {
		k[10] = k[11] = 0xff;
		memcpy(k + 12, &((const struct sockaddr_in *)sa)->sin_addr, 4);
	} else if (sa->sa_family == AF_INET6) {
		const unsigned char *a = ((const struct sockaddr_in6 *)sa)->sin6_addr.s6_addr;
		static const unsigned char mapped[12] = {0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0xff, 0xff};
		if (!memcmp(a, mapped, 12))
			memcpy(k, a, 16);
		else
			memcpy(k, a, 8);   /* the /64 */
	}
}

conns_t *conns_create(int max_total, int max_per_addr, int fd_cap)
{
	conns_t *t = calloc(1, sizeof(*t));
	if (!t || max_total < 1 || fd_cap < 1)
		goto fail;
	t->e = calloc((size_t)fd_cap, sizeof(*t->e));
	t->live = calloc((size_t)max_total, sizeof(*t->live));
	if (!t->e || !t->live)
		goto fail;
	for (int i = 0; i < fd_cap; i++)
		t->e[i].pos = -1;
	t->fd_cap = fd_cap;
	t->max_total = max_total;
	t->max_per_addr = max_per_addr;
	pthread_mutex_init(&t->lock, NULL);
	return t;
fail:
	if (t) {
		free(t->e);
		free(t->live);
	}
	free(t);
	return NULL;
}

void conns_destroy(conns_t *t)
{
	if (!t)
		return;
	pthread_mutex_destroy(&t->lock);
	free(t->e);
	free(t->live);
	free(t);
}

static void drop(conns_t *t, int fd)
{
	int p = t->e[fd].pos;
	int last = t->live[--t->nlive];
	t->live[p] = last;
	t->e[last].pos = p;
	t->e[fd].pos = -1;
}

/* The descriptor that has waited longest in CONN_GATE or CONN_HEAD, among those from key (NULL: all); -1 if none. */
static int oldest_waiting(conns_t *t, const unsigned char *key)
{
	int best = -1;
	for (int i = 0; i < t->nlive; i++) {
		const entry_t *x = &t->e[t->live[i]];
		if ((x->phase != CONN_GATE && x->phase != CONN_HEAD) || (key && memcmp(x->addr, key, 16)))
			continue;
		if (best < 0 || x->since < t->e[best].since)
			best = t->live[i];
	}
	return best;
}

static int evict_one(conns_t *t, const unsigned char *key, conns_evict_fn evict, void *arg)
{
	int v = oldest_waiting(t, key);
	if (v < 0)
		return -1;
	drop(t, v);
	t->evictions++;
	if (evict)
		evict(arg, v);
	return 0;
}

int conns_admit(conns_t *t, int fd, const struct sockaddr *sa, double now, conns_evict_fn evict, void *arg,
                int *evicted)
{
	unsigned char k[16];
	int ret = CONNS_OK, ev = 0;
	if (fd < 0 || fd >= t->fd_cap)
		return CONNS_EINVAL;
	key_of(sa, k);
	pthread_mutex_lock(&t->lock);
	if (t->e[fd].pos >= 0) {
		ret = CONNS_EINVAL;
		goto out;
	}
	if (t->max_per_addr > 0) {
		int same = 0;
		for (int i = 0; i < t->nlive; i++)
			same += !memcmp(t->e[t->live[i]].addr, k, 16);
		if (same >= t->max_per_addr) {
			if (evict_one(t, k, evict, arg)) {
				ret = CONNS_EADDR;
				goto out;
			}
			ev++;
		}
	}
	if (t->nlive >= t->max_total) {
		if (evict_one(t, NULL, evict, arg)) {
			ret = CONNS_EFULL;
			goto out;
		}
		ev++;
	}
	entry_t *x = &t->e[fd];
	memcpy(x->addr, k, 16);
	x->since = now;
	x->phase = CONN_GATE;
	x->pos = t->nlive;
	t->live[t->nlive++] = fd;
out:
	pthread_mutex_unlock(&t->lock);
	if (evicted)
		*evicted = ev;
	return ret;
}

void conns_set_phase(conns_t *t, int fd, conn_phase_t phase, double now)
{
	if (fd < 0 || fd >= t->fd_cap)
		return;
	pthread_mutex_lock(&t->lock);
	if (t->e[fd].pos >= 0 && t->e[fd].phase != (int)phase) {
		t->e[fd].phase = phase;
		t->e[fd].since = now;
	}
	pthread_mutex_unlock(&t->lock);
}

int conns_expire(conns_t *t, double head_before, double body_before, conns_evict_fn evict, void *arg)
{
	int n = 0;
	pthread_mutex_lock(&t->lock);
	for (int i = t->nlive - 1; i >= 0; i--) {
		int fd = t->live[i];
		const entry_t *x = &t->e[fd];
		if ((x->phase == CONN_HEAD && x->since < head_before) || (x->phase == CONN_BODY && x->since < body_before)) {
			drop(t, fd);   /* moves the last entry to i: scanning downwards visits each once */
			t->evictions++;
			n++;
			if (evict)
				evict(arg, fd);
		}
	}
	pthread_mutex_unlock(&t->lock);
	return n;
}

void conns_remove(conns_t *t, int fd)
{
	if (fd < 0 || fd >= t->fd_cap)
		return;
	pthread_mutex_lock(&t->lock);
	if (t->e[fd].pos >= 0)
		drop(t, fd);
	pthread_mutex_unlock(&t->lock);
}

int conns_count(conns_t *t)
{
	pthread_mutex_lock(&t->lock);
	int n = t->nlive;
	pthread_mutex_unlock(&t->lock);
	return n;
}

int conns_count_addr(conns_t *t, const struct sockaddr *sa)
{
	unsigned char k[16];
	int n = 0;
	key_of(sa, k);
	pthread_mutex_lock(&t->lock);
	for (int i = 0; i < t->nlive; i++)
		n += !memcmp(t->e[t->live[i]].addr, k, 16);
	pthread_mutex_unlock(&t->lock);
	return n;
}

long conns_evictions(conns_t *t)
{
	pthread_mutex_lock(&t->lock);
	long n = t->evictions;
	pthread_mutex_unlock(&t->lock);
	return n;
}

const char *conns_strerror(int code)
{
	switch (code) {
	case CONNS_OK:
		return "ok";
	case CONNS_EFULL:
		return "too many connections, all busy";
	case CONNS_EADDR:
		return "too many connections from this address, all busy";
	default:
		return "invalid descriptor";
	}
}
