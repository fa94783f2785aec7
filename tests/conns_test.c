/* Unit tests of the connection table (conns): per-address and total limits, who is evicted, timeouts, IPv6 /64. */
#include <arpa/inet.h>
#include <netinet/in.h>
#include <string.h>
#include "conns.h"
#include "tap.h"

static int evicted[64], nevicted;
static void on_evict(void *arg, int fd)
{
	(void)arg;
	if (nevicted < 64)
		evicted[nevicted++] = fd;
}

static struct sockaddr_in v4(const char *a)
{
	struct sockaddr_in s = {.sin_family = AF_INET};
	inet_pton(AF_INET, a, &s.sin_addr);
	return s;
}

static struct sockaddr_in6 v6(const char *a)
{
	struct sockaddr_in6 s = {.sin6_family = AF_INET6};
	inet_pton(AF_INET6, a, &s.sin6_addr);
	return s;
}
#define SA(x) ((const struct sockaddr *)&(x))

int main(void)
{
	struct sockaddr_in a = v4("10.0.0.1"), b = v4("10.0.0.2");
	conns_t *t = conns_create(16, 3, 1024);
	ok(t != NULL, "conns_create");
	if (!t)
		return 1;

	/* Per address: the fourth from a evicts a's connection that has waited longest for a head. */
	ok(conns_admit(t, 10, SA(a), 1.0, on_evict, NULL, NULL) == 0 && conns_admit(t, 11, SA(a), 2.0, on_evict, NULL, NULL) == 0 &&
	       conns_admit(t, 12, SA(a), 3.0, on_evict, NULL, NULL) == 0 && conns_admit(t, 20, SA(b), 0.5, on_evict, NULL, NULL) == 0,
	   "three from 10.0.0.1 and one from 10.0.0.2 admitted");
	ok(conns_count_addr(t, SA(a)) == 3 && conns_count(t) == 4, "counts: 3 from a, 4 in all");
	conns_set_phase(t, 10, CONN_BUSY, 4.0);   /* oldest, but busy: never evicted */
	int ev = 0;
	nevicted = 0;
	ok(conns_admit(t, 13, SA(a), 5.0, on_evict, NULL, &ev) == 0 && ev == 1 && nevicted == 1 && evicted[0] == 11,
	   "a fourth from a: the oldest waiting one of a (11, not busy 10, not b's older 20) evicted");
	ok(conns_count_addr(t, SA(a)) == 3 && conns_count_addr(t, SA(b)) == 1, "still 3 from a after the eviction");
	conns_remove(t, 11);   /* its owner closes it later: a no-op now */
	ok(conns_count(t) == 4, "removing an evicted descriptor changes nothing");
	conns_set_phase(t, 12, CONN_BUSY, 6.0);
	conns_set_phase(t, 13, CONN_BODY, 6.0);
	nevicted = 0;
	ok(conns_admit(t, 14, SA(a), 7.0, on_evict, NULL, NULL) == CONNS_EADDR && nevicted == 0,
	   "a's three are busy or reading a body: the next from a is refused, nothing evicted");
	ok(conns_admit(t, 21, SA(b), 7.0, on_evict, NULL, NULL) == 0, "b is not held back by a's limit");
	ok(conns_admit(t, 21, SA(b), 7.0, on_evict, NULL, NULL) == CONNS_EINVAL &&
	       conns_admit(t, 5000, SA(b), 7.0, on_evict, NULL, NULL) == CONNS_EINVAL,
	   "a descriptor already present or beyond fd_cap: CONNS_EINVAL");

	/* Timeouts: HEAD before head_before and BODY before body_before are evicted, BUSY and GATE are not. */
	conns_set_phase(t, 20, CONN_HEAD, 8.0);
	nevicted = 0;
	int n = conns_expire(t, 9.0, 6.5, on_evict, NULL);
	ok(n == 2 && nevicted == 2 && ((evicted[0] == 20 && evicted[1] == 13) || (evicted[0] == 13 && evicted[1] == 20)),
	   "expire: the idle keep-alive (20) and the slow body (13) evicted, %d in all", n);
	ok(conns_count(t) == 3, "3 left (10 and 12 busy, 21 at the gate)");
	conns_remove(t, 10);
	conns_remove(t, 12);
	conns_remove(t, 21);
	ok(conns_count(t) == 0, "all removed");
	conns_destroy(t);

	/* Total: when full, the connection waiting longest anywhere makes room; all busy: refused. */
	t = conns_create(16, 0, 1024);
	for (int i = 0; i < 16; i++) {
		struct sockaddr_in c = v4("10.0.1.1");
		c.sin_addr.s_addr = htonl(0x0a000100u + (unsigned)i);
		conns_admit(t, 100 + i, SA(c), (double)(i == 7 ? 0 : 1 + i), on_evict, NULL, NULL);
	}
	nevicted = 0;
	ok(conns_admit(t, 200, SA(a), 50.0, on_evict, NULL, NULL) == 0 && nevicted == 1 && evicted[0] == 107,
	   "table full (16): the one waiting longest (107) evicted for a new one");
	for (int i = 0; i < 16; i++)
		conns_set_phase(t, 100 + i, CONN_BUSY, 51.0);
	conns_set_phase(t, 200, CONN_BUSY, 51.0);
	ok(conns_admit(t, 201, SA(b), 52.0, on_evict, NULL, NULL) == CONNS_EFULL, "table full of busy connections: refused");
	ok(conns_evictions(t) == 1, "one eviction counted");
	conns_destroy(t);

	/* IPv6 counted per /64; IPv4-mapped as IPv4. */
	t = conns_create(16, 2, 1024);
	struct sockaddr_in6 x1 = v6("2001:db8:1:2::1"), x2 = v6("2001:db8:1:2:ffff::9"), y = v6("2001:db8:1:3::1");
	struct sockaddr_in6 m = v6("::ffff:10.0.0.1");
	conns_admit(t, 1, SA(x1), 1.0, on_evict, NULL, NULL);
	ok(conns_count_addr(t, SA(x2)) == 1 && conns_count_addr(t, SA(y)) == 0, "IPv6: same /64 counted together, another /64 not");
	conns_admit(t, 2, SA(a), 1.0, on_evict, NULL, NULL);
	ok(conns_count_addr(t, SA(m)) == 1, "::ffff:10.0.0.1 counts as 10.0.0.1");
	conns_destroy(t);
	conns_destroy(NULL);

	plan(tap_n);
	return tap_failed != 0;
}
