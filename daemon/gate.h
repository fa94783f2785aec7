/* Accept loop in front of libmicrohttpd: admission through the connection table, a deadline and size limits for the first request head. */
#pragma once

#include <stddef.h>
#include <sys/socket.h>
#include "conns.h"

/*
 * Contract
 * - One thread accepts on listen_fd, admits each connection with
 *   conns_admit() (refused ones are closed at once) and waits, without
 *   reading, until the first request head is in the socket (peeked, so
 *   libmicrohttpd later reads the same bytes). Then it hands the descriptor
 *   over with handoff() (which owns it from then on, and must conns_remove()
 *   it before closing it).
 * - A request line over line_max bytes gets resp_414, a head over head_max
 *   bytes resp_431, a head not complete within head_timeout seconds resp_408
 *   (a connection that sent nothing is closed without an answer). Each answer
 *   is followed by a half-close and a short drain of what the client still
 *   sends, so the client reads it rather than a reset. libmicrohttpd never
 *   sees these connections.
 * - Idle and slow connections cost a descriptor and a table entry here, no
 *   thread, and are the first evicted when the table is full.
 * - count(arg, status) is called for each answer the gate sends itself, and
 *   with status 0 for each connection refused by the table.
 */

typedef struct gate gate_t;

typedef struct {
	int listen_fd;               /* bound and listening; owned (closed by gate_stop) */
	conns_t *conns;
	int fd_cap;                  /* descriptors are below it */
	double head_timeout;         /* seconds */
	size_t line_max, head_max;   /* bytes */
	const char *resp_408, *resp_414, *resp_431;   /* complete HTTP responses, kept by the caller */
	int (*handoff)(void *arg, int fd, const struct sockaddr *sa, socklen_t salen);   /* 0 or -1 */
	void (*count)(void *arg, int status);
	void *arg;
} gate_conf_t;

/* Start the thread. NULL on error (err). The listen_fd is owned from here on, also on error. */
gate_t *gate_start(const gate_conf_t *conf, char *err, size_t errlen);

/* Stop accepting, close the connections still at the gate and the listening socket, join. */
void gate_stop(gate_t *g);

enum { GATE_WAIT = 0, GATE_HEAD = 1 };

/* The check on the first bytes of a connection (n of them, as peeked), pure:
 * 414 when the request line is over line_max bytes, 431 when the head is
 * (or, incomplete, already is) over head_max, GATE_HEAD when the head is
 * complete (*end: its length, blank line included), else GATE_WAIT. */
int gate_scan(const char *buf, size_t n, size_t line_max, size_t head_max, size_t *end);
