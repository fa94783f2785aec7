/* Live event fan-out for server-sent events: a bounded ring of numbered events and blocking readers. */
#pragma once

#include <stddef.h>
#include <stdint.h>

/*
 * Contract
 * - Events carry a global sequence number (1, 2, ...; the SSE id), a job id
 *   (0 = not about a job), a type ("progress", "state", ...) and a JSON
 *   text; hub_publish() copies them.
 * - The ring keeps the newest `capacity` events: a reader that falls further
 *   behind gets HUB_EGAP once and continues from the oldest kept event (the
 *   durable series in SQLite is the way to catch up, the hub is only live).
 * - hub_close() wakes every reader with HUB_ECLOSED (shutdown).
 */

typedef struct hub hub_t;

enum { HUB_OK = 0, HUB_ETIMEOUT = -1, HUB_ECLOSED = -2, HUB_EGAP = -3, HUB_ENOMEM = -4 };

typedef struct {
	uint64_t seq;
	int64_t job;
	char type[16];
	char *data;      /* malloc'd copy, caller frees */
} hub_event_t;

hub_t *hub_create(size_t capacity);
void hub_destroy(hub_t *h);
void hub_close(hub_t *h);

/* Publish; returns the event's sequence number (0 when out of memory). */
uint64_t hub_publish(hub_t *h, int64_t job, const char *type, const char *data);

/* Sequence number of the newest event (0 if none). */
uint64_t hub_last(hub_t *h);

/* Wait up to timeout_ms until an event newer than seen exists or the hub is
 * closed; returns the newest sequence number (== seen after a timeout). */
uint64_t hub_wait_newer(hub_t *h, uint64_t seen, int timeout_ms);

/* The hub was closed. */
int hub_closed(hub_t *h);

/* Wait up to timeout_ms (0: do not wait) for the first event with seq > *after that matches
 * job (0 = any job). On HUB_OK fills *ev and sets *after = ev->seq; on
 * HUB_EGAP moves *after to just before the oldest kept event. */
int hub_wait(hub_t *h, uint64_t *after, int64_t job, int timeout_ms, hub_event_t *ev);
