/* Connection table of the HTTP front end: counts per client address, what each connection is doing, whom to evict when full. */
#pragma once

#include <stddef.h>
#include <sys/socket.h>

/*
 * Contract
 * - Connections are keyed by their socket descriptor (unique while open).
 *   Thread-safe (one mutex); no I/O of its own: eviction calls back.
 * - Addresses are counted per client: IPv4 per address, IPv6 per /64 (one
 *   host usually owns a whole /64), IPv4-mapped IPv6 as IPv4.
 * - Phases: CONN_GATE (new, its first request head not complete yet),
 *   CONN_HEAD (waiting for the next request head: an idle keep-alive
 *   connection, or one sending its head slowly), CONN_BODY (reading a request
 *   body) and CONN_BUSY (a request is handled or answered, or an event stream
 *   is open). conns_admit() enters CONN_GATE.
 * - conns_admit() takes a new connection when the table has room for it (at
 *   most max_total, at most max_per_addr from its address; 0 = no per-address
 *   limit). When one of the limits is reached it evicts the connection of
 *   that class (same address, or any) that has waited longest in CONN_GATE or
 *   CONN_HEAD,
 *   calling evict(fd) with the table locked (so fd cannot be closed and
 *   reused meanwhile: conns_remove() takes the same lock), and then takes
 *   the new one. A connection that is busy is never evicted; if none can be
 *   evicted the new one is refused. An evicted connection no longer counts
 *   and is forgotten by conns_remove().
 */

typedef struct conns conns_t;

typedef enum { CONN_GATE = 0, CONN_HEAD, CONN_BODY, CONN_BUSY } conn_phase_t;

enum { CONNS_OK = 0, CONNS_EFULL = -1, CONNS_EADDR = -2, CONNS_EINVAL = -3 };

typedef void (*conns_evict_fn)(void *arg, int fd);

/* fd_cap: descriptors are below it (the RLIMIT_NOFILE soft limit). NULL when out of memory. */
conns_t *conns_create(int max_total, int max_per_addr, int fd_cap);
void conns_destroy(conns_t *t);

/* Admit fd from sa at time now (seconds, any monotonic origin), in phase
 * CONN_GATE. CONNS_OK, CONNS_EFULL (table full of busy connections),
 * CONNS_EADDR (the address has max_per_addr busy ones), CONNS_EINVAL (fd out
 * of range or already present). evicted counts evictions (may be NULL). */
int conns_admit(conns_t *t, int fd, const struct sockaddr *sa, double now, conns_evict_fn evict, void *arg,
                int *evicted);

/* Set the phase of fd (no-op for unknown or evicted descriptors). */
void conns_set_phase(conns_t *t, int fd, conn_phase_t phase, double now);

/* Evict (as above) every connection in CONN_HEAD since before head_before
 * and every one in CONN_BODY since before body_before; returns how many. */
int conns_expire(conns_t *t, double head_before, double body_before, conns_evict_fn evict, void *arg);

/* Forget fd (no-op when unknown). Call before the descriptor is closed. */
void conns_remove(conns_t *t, int fd);

/* Connections counted now (evicted ones excluded), and from sa's address. */
int conns_count(conns_t *t);
int conns_count_addr(conns_t *t, const struct sockaddr *sa);

/* Evictions since creation. */
long conns_evictions(conns_t *t);

const char *conns_strerror(int code);
