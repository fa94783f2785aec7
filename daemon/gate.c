/* Accept loop in front of libmicrohttpd: table admission, first request head peeked for completeness, size and time limits. */
#define _GNU_SOURCE
#include <errno.h>
#include <fcntl.h>
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/epoll.h>
#include <sys/eventfd.h>
#include <sys/socket.h>
#include <time.h>
#include <unistd.h>
#include "gate.h"
#include "log.h"

#define LINGER_SECONDS 1.0    /* drain after an answer the gate sends itself */
#define ACCEPT_PAUSE 0.1      /* seconds without accepting after EMFILE and the like */

typedef struct {
	double deadline;
	int closing;              /* answered: draining until EOF or the deadline */
	int got_bytes;            /* something arrived (a silent connection is closed without 408) */
	int pos;                  /* index in live[] */
	socklen_t salen;
	struct sockaddr_storage sa;
} pend_t;

struct gate {
	gate_conf_t c;
	pthread_t thread;
	int started;
	int ep, stopfd;
	pend_t **p;               /* by descriptor */
	int *live, nlive, cap;
	char *buf;                /* peek buffer, head_max + 1 bytes */
	double paused_until;
};

static double mono(void)
{
	struct timespec ts;
	clock_gettime(CLOCK_MONOTONIC, &ts);
	return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

static void forget(gate_t *g, int fd)
{
	pend_t *p = g->p[fd];
	int last = g->live[--g->nlive];
	g->live[p->pos] = last;
	g->p[last]->pos = p->pos;
	g->p[fd] = NULL;
	free(p);
}

static void close_now(gate_t *g, int fd)
{
	forget(g, fd);
	conns_remove(g->c.conns, fd);   /* before close: the number may be reused at once */
	close(fd);
}

static void answer(gate_t *g, int fd, const char *resp, int status)
{
	pend_t *p = g->p[fd];
	if (send(fd, resp, strlen(resp), MSG_NOSIGNAL | MSG_DONTWAIT) < 0)
		log_debug("gate: answer %d: %s", status, strerror(errno));
	shutdown(fd, SHUT_WR);
	p->closing = 1;
	p->deadline = mono() + LINGER_SECONDS;
	if (g->c.count)
		g->c.count(g->c.arg, status);
}

/* Called with the table locked: the descriptor stays valid while we use it. */
static void evict(void *arg, int fd)
{
	(void)arg;
	shutdown(fd, SHUT_RDWR);   /* the owner (we or libmicrohttpd) sees the end and closes it */
}

static const char *find_end(const char *b, size_t n, size_t *end)
{
	for (size_t i = 0; i + 1 < n; i++) {
		if (b[i] != '\n')
			continue;
		if (b[i + 1] == '\n') {
			*end = i + 2;
			return b + i;
		}
		if (b[i + 1] == '\r' && i + 2 < n && b[i + 2] == '\n') {
			*end = i + 3;
			return b + i;
		}
	}
	return NULL;
}

int gate_scan(const char *buf, size_t n, size_t line_max, size_t head_max, size_t *end)
{
	const char *nl = memchr(buf, '\n', n);
	*end = 0;
	if ((nl ? (size_t)(nl - buf) : n) > line_max)
		return 414;
	if (!find_end(buf, n, end))
		return n > head_max ? 431 : GATE_WAIT;
	return *end > head_max ? 431 : GATE_HEAD;
}

static void ready(gate_t *g, int fd)
{
	pend_t *p = g->p[fd];
	if (!p)
		return;
	if (p->closing) {
		char sink[16384];
		ssize_t r;
		while ((r = recv(fd, sink, sizeof(sink), MSG_DONTWAIT)) > 0)
			;
		if (r == 0 || (errno != EAGAIN && errno != EWOULDBLOCK))
			close_now(g, fd);
		return;
	}
	ssize_t n = recv(fd, g->buf, g->c.head_max + 1, MSG_PEEK | MSG_DONTWAIT);
	if (n == 0 || (n < 0 && errno != EAGAIN && errno != EWOULDBLOCK && errno != EINTR)) {
		close_now(g, fd);   /* gone, or evicted */
		return;
	}
	if (n <= 0)
		return;
	p->got_bytes = 1;
	size_t end;
	switch (gate_scan(g->buf, (size_t)n, g->c.line_max, g->c.head_max, &end)) {
	case GATE_WAIT:
		return;   /* wait for more (edge-triggered: the next arrival wakes us) */
	case 414:
		answer(g, fd, g->c.resp_414, 414);
		return;
	case 431:
		answer(g, fd, g->c.resp_431, 431);
		return;
	default:
		break;
	}
	struct sockaddr_storage sa = p->sa;
	socklen_t salen = p->salen;
	epoll_ctl(g->ep, EPOLL_CTL_DEL, fd, NULL);
	forget(g, fd);
	/* Before the handoff: the server's threads move it on (CONN_BODY, CONN_BUSY) from here. */
	conns_set_phase(g->c.conns, fd, CONN_HEAD, mono());
	if (g->c.handoff(g->c.arg, fd, (struct sockaddr *)&sa, salen))
		conns_remove(g->c.conns, fd);   /* closed by the server library; no eviction can run meanwhile (ours) */
}

static void accept_some(gate_t *g)
{
	for (int k = 0; k < 256; k++) {
		struct sockaddr_storage sa;
		socklen_t sl = sizeof(sa);
		int fd = accept4(g->c.listen_fd, (struct sockaddr *)&sa, &sl, SOCK_NONBLOCK | SOCK_CLOEXEC);
		if (fd < 0) {
			if (errno == EINTR || errno == ECONNABORTED)
				continue;
			if (errno == EMFILE || errno == ENFILE || errno == ENOBUFS || errno == ENOMEM) {
				log_warning("http: cannot accept: %s (pausing %.0f ms)", strerror(errno), 1e3 * ACCEPT_PAUSE);
				g->paused_until = mono() + ACCEPT_PAUSE;
				struct epoll_event ev = {.events = 0, .data.fd = g->c.listen_fd};
				epoll_ctl(g->ep, EPOLL_CTL_MOD, g->c.listen_fd, &ev);
			}
			return;
		}
		double now = mono();
		int r = fd < g->cap ? conns_admit(g->c.conns, fd, (struct sockaddr *)&sa, now, evict, g, NULL) : CONNS_EINVAL;
		pend_t *p = r == CONNS_OK ? calloc(1, sizeof(*p)) : NULL;
		if (!p) {
			if (r == CONNS_OK)
				conns_remove(g->c.conns, fd);
			if (g->c.count)
				g->c.count(g->c.arg, 0);
			close(fd);
			continue;
		}
		p->deadline = now + g->c.head_timeout;
		p->sa = sa;
		p->salen = sl;
		p->pos = g->nlive;
		g->live[g->nlive++] = fd;
		g->p[fd] = p;
		struct epoll_event ev = {.events = EPOLLIN | EPOLLRDHUP | EPOLLET, .data.fd = fd};
		if (epoll_ctl(g->ep, EPOLL_CTL_ADD, fd, &ev))
			close_now(g, fd);
	}
}

static void expire(gate_t *g, double now)
{
	for (int i = g->nlive - 1; i >= 0; i--) {
		int fd = g->live[i];
		pend_t *p = g->p[fd];
		if (now < p->deadline)
			continue;
		if (p->closing || !p->got_bytes)
			close_now(g, fd);
		else
			answer(g, fd, g->c.resp_408, 408);
	}
}

static void *run(void *arg)
{
	gate_t *g = arg;
	struct epoll_event evs[128];
	double next_scan = 0;
	for (;;) {
		int n = epoll_wait(g->ep, evs, 128, 100);
		double now = mono();
		for (int i = 0; i < n; i++) {
			int fd = evs[i].data.fd;
			if (fd == g->stopfd)
				return NULL;
			if (fd == g->c.listen_fd)
				accept_some(g);
			else if (fd >= 0 && fd < g->cap)
				ready(g, fd);
		}
		if (g->paused_until && now >= g->paused_until) {
			g->paused_until = 0;
			struct epoll_event ev = {.events = EPOLLIN, .data.fd = g->c.listen_fd};
			epoll_ctl(g->ep, EPOLL_CTL_MOD, g->c.listen_fd, &ev);
		}
		if (now >= next_scan) {
			expire(g, now);
			next_scan = now + 0.1;
		}
	}
}

gate_t *gate_start(const gate_conf_t *conf, char *err, size_t errlen)
{
	gate_t *g = calloc(1, sizeof(*g));
	if (!g) {
		snprintf(err, errlen, "out of memory");
		close(conf->listen_fd);
		return NULL;
	}
	g->c = *conf;
	g->ep = g->stopfd = -1;
	g->cap = conf->fd_cap;
	g->p = calloc((size_t)g->cap, sizeof(*g->p));
	g->live = calloc((size_t)g->cap, sizeof(*g->live));
	g->buf = malloc(conf->head_max + 1);
	g->ep = epoll_create1(EPOLL_CLOEXEC);
	g->stopfd = eventfd(0, EFD_CLOEXEC | EFD_NONBLOCK);
	struct epoll_event ls = {.events = EPOLLIN, .data.fd = conf->listen_fd}, st = {.events = EPOLLIN, .data.fd = g->stopfd};
	if (!g->p || !g->live || !g->buf || g->ep < 0 || g->stopfd < 0 ||
	    fcntl(conf->listen_fd, F_SETFL, fcntl(conf->listen_fd, F_GETFL) | O_NONBLOCK) ||
	    epoll_ctl(g->ep, EPOLL_CTL_ADD, conf->listen_fd, &ls) || epoll_ctl(g->ep, EPOLL_CTL_ADD, g->stopfd, &st) ||
	    pthread_create(&g->thread, NULL, run, g)) {
		snprintf(err, errlen, "cannot start the accept thread: %s", strerror(errno));
		gate_stop(g);
		return NULL;
	}
	g->started = 1;
	return g;
}

void gate_stop(gate_t *g)
{
	if (!g)
		return;
	if (g->started) {
		uint64_t one = 1;
		if (write(g->stopfd, &one, sizeof(one)) < 0)
			log_warning("gate: cannot wake the accept thread: %s", strerror(errno));
		pthread_join(g->thread, NULL);
	}
	while (g->nlive > 0)
		close_now(g, g->live[g->nlive - 1]);
	close(g->c.listen_fd);
	if (g->ep >= 0)
		close(g->ep);
	if (g->stopfd >= 0)
		close(g->stopfd);
	free(g->p);
	free(g->live);
	free(g->buf);
	free(g);
}
