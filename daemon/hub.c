/* Live event fan-out: a mutex-protected ring of numbered events with a condition variable. */
#include <errno.h>
#include <pthread.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include "hub.h"

struct hub {
	pthread_mutex_t lock;
	pthread_cond_t cond;
	hub_event_t *ring;
	size_t cap;
	uint64_t last;   /* seq of the newest event; event s lives at ring[s % cap] */
	int closed;
};

hub_t *hub_create(size_t capacity)
{
	hub_t *h = calloc(1, sizeof(*h));
	if (!h)
		return NULL;
	h->ring = calloc(capacity, sizeof(*h->ring));
	if (!h->ring) {
		free(h);
		return NULL;
	}
	h->cap = capacity;
	pthread_mutex_init(&h->lock, NULL);
	pthread_condattr_t ca;
	pthread_condattr_init(&ca);
	pthread_condattr_setclock(&ca, CLOCK_MONOTONIC);
	pthread_cond_init(&h->cond, &ca);
	pthread_condattr_destroy(&ca);
	return h;
}

void hub_destroy(hub_t *h)
{
	if (!h)
		return;
	for (size_t i = 0; i < h->cap; i++)
		free(h->ring[i].data);
	free(h->ring);
	pthread_mutex_destroy(&h->lock);
	pthread_cond_destroy(&h->cond);
	free(h);
}

void hub_close(hub_t *h)
{
	pthread_mutex_lock(&h->lock);
	h->closed = 1;
	pthread_cond_broadcast(&h->cond);
	pthread_mutex_unlock(&h->lock);
}

uint64_t hub_publish(hub_t *h, int64_t job, const char *type, const char *data)
{
	char *copy = strdup(data);
	uint64_t seq;
	if (!copy)
		return 0;
	pthread_mutex_lock(&h->lock);
	seq = ++h->last;
	hub_event_t *e = &h->ring[seq % h->cap];
	free(e->data);
	e->seq = seq;
	e->job = job;
	strncpy(e->type, type, sizeof(e->type) - 1);
	e->type[sizeof(e->type) - 1] = '\0';
	e->data = copy;
	pthread_cond_broadcast(&h->cond);
	pthread_mutex_unlock(&h->lock);
	return seq;
}

uint64_t hub_last(hub_t *h)
{
	pthread_mutex_lock(&h->lock);
	uint64_t s = h->last;
	pthread_mutex_unlock(&h->lock);
	return s;
}

static struct timespec deadline(int timeout_ms)
{
	struct timespec dl;
	clock_gettime(CLOCK_MONOTONIC, &dl);
	dl.tv_sec += timeout_ms / 1000;
	dl.tv_nsec += (long)(timeout_ms % 1000) * 1000000L;
	if (dl.tv_nsec >= 1000000000L) {
		dl.tv_sec++;
		dl.tv_nsec -= 1000000000L;
	}
	return dl;
}

uint64_t hub_wait_newer(hub_t *h, uint64_t seen, int timeout_ms)
{
	struct timespec dl = deadline(timeout_ms);
	pthread_mutex_lock(&h->lock);
	while (!h->closed && h->last <= seen)
		if (pthread_cond_timedwait(&h->cond, &h->lock, &dl) == ETIMEDOUT)
			break;
	uint64_t s = h->last;
	pthread_mutex_unlock(&h->lock);
	return s;
}

int hub_closed(hub_t *h)
{
	pthread_mutex_lock(&h->lock);
	int c = h->closed;
	pthread_mutex_unlock(&h->lock);
	return c;
}

int hub_wait(hub_t *h, uint64_t *after, int64_t job, int timeout_ms, hub_event_t *ev)
{
	struct timespec dl = deadline(timeout_ms);
	int ret = HUB_ETIMEOUT;
	pthread_mutex_lock(&h->lock);
	for (;;) {
		if (h->closed) {
			ret = HUB_ECLOSED;
			break;
		}
		uint64_t oldest = h->last >= h->cap ? h->last - h->cap + 1 : 1;
		if (*after + 1 < oldest) {
			*after = oldest - 1;
			ret = HUB_EGAP;
			break;
		}
		for (; *after < h->last; (*after)++) {
			hub_event_t *e = &h->ring[(*after + 1) % h->cap];
			if (job == 0 || e->job == job) {
				*ev = *e;
				ev->data = strdup(e->data);
				(*after)++;
				ret = ev->data ? HUB_OK : HUB_ENOMEM;
				goto out;
			}
		}
		if (timeout_ms <= 0 || pthread_cond_timedwait(&h->cond, &h->lock, &dl) == ETIMEDOUT)
			break;
	}
out:
	pthread_mutex_unlock(&h->lock);
	return ret;
}
