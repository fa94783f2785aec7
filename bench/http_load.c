/* HTTP load generator for granulard: C keep-alive clients for D seconds; requests/s and latency percentiles as JSON. */
#define _GNU_SOURCE
#include <arpa/inet.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <pthread.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>
#include <time.h>
#include <unistd.h>

/* usage: http_load HOST PORT CLIENTS SECONDS METHOD PATH [TOKEN BODYFILE]
 * Each client holds one keep-alive connection and sends requests back to back.
 * POST bodies get a unique submission_id per request when they contain the
 * placeholder @ID@ (so every request creates a job). */

typedef struct {
	int id;
	double *lat;
	size_t n, cap;
	long errors, non2xx;
} client_t;

static const char *host, *method, *path, *token, *body;
static int port;
static double stop_at;
static atomic_long seqno;

static double now(void)
{
	struct timespec ts;
	clock_gettime(CLOCK_MONOTONIC, &ts);
	return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

static int connect_to(void)
{
	struct sockaddr_in a = {.sin_family = AF_INET, .sin_port = htons((uint16_t)port)};
	inet_pton(AF_INET, host, &a.sin_addr);
	int fd = socket(AF_INET, SOCK_STREAM, 0), one = 1;
	setsockopt(fd, IPPROTO_TCP, TCP_NODELAY, &one, sizeof(one));
	if (connect(fd, (struct sockaddr *)&a, sizeof(a))) {
		close(fd);
		return -1;
	}
	return fd;
}

/* Read one response (headers + Content-Length body); returns the status or -1. */
static int read_response(int fd, char *buf, size_t cap)
{
	size_t n = 0;
	char *hdr_end = NULL;
	while (!hdr_end) {
		ssize_t r = read(fd, buf + n, cap - n - 1);
		if (r <= 0)
			return -1;
		n += (size_t)r;
		buf[n] = '\0';
		hdr_end = strstr(buf, "\r\n\r\n");
	}
	int status = atoi(buf + 9);
	char *cl = strcasestr(buf, "\r\nContent-Length:");
	size_t want = cl ? (size_t)atol(cl + 17) : 0, have = n - (size_t)(hdr_end + 4 - buf);
	while (have < want) {
		ssize_t r = read(fd, buf, cap - 1);
		if (r <= 0)
			return -1;
		have += (size_t)r;
	}
	return status;
}

static void *run(void *arg)
{
	client_t *c = arg;
	char *req = malloc(1 << 20), *resp = malloc(1 << 20);
	int fd = connect_to();
	while (fd >= 0 && now() < stop_at) {
		int len;
		if (body) {
			char b[65536];
			const char *at = strstr(body, "@ID@");
			if (at)
				snprintf(b, sizeof(b), "%.*s%ld-%d%s", (int)(at - body), body, atomic_fetch_add(&seqno, 1), c->id,
				         at + 4);
			else
				snprintf(b, sizeof(b), "%s", body);
			len = snprintf(req, 1 << 20,
			               "%s %s HTTP/1.1\r\nHost: %s:%d\r\nAuthorization: Bearer %s\r\n"
			               "Content-Type: application/json\r\nContent-Length: %zu\r\n\r\n%s",
			               method, path, host, port, token, strlen(b), b);
		} else {
			len = snprintf(req, 1 << 20, "%s %s HTTP/1.1\r\nHost: %s:%d\r\n\r\n", method, path, host, port);
		}
		double t0 = now();
		if (write(fd, req, (size_t)len) != len) {
			c->errors++;
			close(fd);
			fd = connect_to();
			continue;
		}
		int st = read_response(fd, resp, 1 << 20);
		double dt = now() - t0;
		if (st < 0) {
			c->errors++;
			close(fd);
			fd = connect_to();
			continue;
		}
		if (st / 100 != 2)
			c->non2xx++;
		if (c->n == c->cap) {
			c->cap = c->cap ? 2 * c->cap : 4096;
			c->lat = realloc(c->lat, c->cap * sizeof(double));
		}
		c->lat[c->n++] = dt;
	}
	if (fd >= 0)
		close(fd);
	free(req);
	free(resp);
	return NULL;
}

static int cmp(const void *a, const void *b)
{
	double x = *(const double *)a, y = *(const double *)b;
	return (x > y) - (x < y);
}

int main(int argc, char **argv)
{
	if (argc != 7 && argc != 9) {
		fprintf(stderr, "usage: http_load HOST PORT CLIENTS SECONDS METHOD PATH [TOKEN BODYFILE]\n");
		return 2;
	}
	host = argv[1];
	port = atoi(argv[2]);
	int nc = atoi(argv[3]);
	double secs = atof(argv[4]);
	method = argv[5];
	path = argv[6];
	if (argc == 9) {
		token = argv[7];
		FILE *f = fopen(argv[8], "r");
		static char b[65536];
		size_t n = f ? fread(b, 1, sizeof(b) - 1, f) : 0;
		if (f)
			fclose(f);
		b[n] = '\0';
		while (n && (b[n - 1] == '\n'))
			b[--n] = '\0';
		body = b;
	}
	client_t *c = calloc((size_t)nc, sizeof(*c));
	pthread_t *t = calloc((size_t)nc, sizeof(*t));
	double t0 = now();
	stop_at = t0 + secs;
	for (int i = 0; i < nc; i++) {
		c[i].id = i;
		pthread_create(&t[i], NULL, run, &c[i]);
	}
	size_t total = 0;
	long errors = 0, non2xx = 0;
	for (int i = 0; i < nc; i++) {
		pthread_join(t[i], NULL);
		total += c[i].n;
		errors += c[i].errors;
		non2xx += c[i].non2xx;
	}
	double wall = now() - t0;
	double *all = malloc((total + 1) * sizeof(double));
	size_t k = 0;
	for (int i = 0; i < nc; i++) {
		memcpy(all + k, c[i].lat, c[i].n * sizeof(double));
		k += c[i].n;
		free(c[i].lat);
	}
	qsort(all, total, sizeof(double), cmp);
	printf("{\"method\":\"%s\",\"path\":\"%s\",\"clients\":%d,\"seconds\":%.2f,\"requests\":%zu,\"requests_per_second\":%.1f,"
	       "\"p50_ms\":%.3f,\"p99_ms\":%.3f,\"max_ms\":%.3f,\"errors\":%ld,\"non_2xx\":%ld}\n",
	       method, path, nc, wall, total, (double)total / wall, total ? 1e3 * all[total / 2] : 0.0,
	       total ? 1e3 * all[(size_t)(0.99 * (double)(total - 1))] : 0.0, total ? 1e3 * all[total - 1] : 0.0, errors,
	       non2xx);
	free(all);
	free(c);
	free(t);
	return errors || non2xx ? 1 : 0;
}
