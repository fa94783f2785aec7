/* Unit tests of progress ingestion (daemon/ingest.c): line assembly, the rate bound, held records, batches, counts. */
#include <stdio.h>
#include <string.h>
#include "ingest.h"
#include "tap.h"

typedef struct {
	char text[4096];
	size_t n, lines;
} chat_t;

static void on_chatter(void *ctx, const char *line, size_t len)
{
	chat_t *c = ctx;
	if (c->n + len + 1 < sizeof(c->text)) {
		memcpy(c->text + c->n, line, len);
		c->n += len;
		c->text[c->n++] = '|';
		c->text[c->n] = '\0';
	}
	c->lines++;
}

static ingest_t *make(double rate, double burst, double flush, size_t max_batch, size_t max_line, chat_t *c)
{
	const ingest_conf_t conf = {.rate = rate, .burst = burst, .flush = flush, .max_batch = max_batch,
	                            .max_line = max_line, .chatter = on_chatter, .ctx = c};
	return ingest_create(&conf, 0.0);
}

static int rec(char *buf, size_t n, const char *type, int i)
{
	return snprintf(buf, n, "{\"type\":\"%s\",\"time\":%d}\n", type, i);
}

/* time of a record in the batch */
static int time_of(const ingest_record_t *r) { return (int)json_integer_value(json_object_get(r->r, "time")); }

int main(void)
{
	chat_t c = {0};
	const ingest_record_t *rs;
	ingest_counts_t d, tot;
	char buf[256];

	/* 1. Lines split across feeds, chatter, CRLF, a record that is not JSON. */
	ingest_t *g = make(1e9, 1e9, 1.0, 1000, 1024, &c);
	const char *parts[] = {"{\"type\":\"progr", "ess\",\"time\":1}\r\nmpirun says hi\n{\"type\":\"progress\",",
	                       "\"time\":2}\n{not json\n\n{\"type\":\"advice\"}\n"};
	for (size_t i = 0; i < 3; i++)
		ingest_feed(g, parts[i], strlen(parts[i]), 0.0);
	size_t n = ingest_batch(g, &rs, &d);
	ok(n == 3 && time_of(&rs[0]) == 1 && time_of(&rs[1]) == 2 && rs[0].is_progress && !rs[2].is_progress,
	   "records split over feeds are reassembled (%zu records)", n);
	ok(!strcmp(c.text, "mpirun says hi|{not json|"), "chatter and unparsable records go to the tail: '%s'", c.text);
	ok(d.received == 4 && d.thinned == 0 && d.accepted == 3, "counts: received %llu, thinned %llu, accepted %llu",
	   (unsigned long long)d.received, (unsigned long long)d.thinned, (unsigned long long)d.accepted);
	ingest_taken(g, 0.0);
	ingest_destroy(g);

	/* 2. The rate bound: 10^5 progress records in 2 s at rate 10/s, burst 5:
	 * at most 5 + 10 * 2 accepted, the rest thinned, the newest kept at the end. */
	g = make(10.0, 5.0, 0.25, 100000, 1024, &c);
	size_t acc = 0;
	int last_time = -1, monotone = 1;
	for (int i = 0; i < 100000; i++) {
		double now = 2.0 * i / 100000.0;
		int len = rec(buf, sizeof(buf), "progress", i);
		ingest_feed(g, buf, (size_t)len, now);
		ingest_tick(g, now);
		if (ingest_due(g, now)) {
			n = ingest_batch(g, &rs, NULL);
			for (size_t k = 0; k < n; k++) {
				monotone &= time_of(&rs[k]) > last_time;
				last_time = time_of(&rs[k]);
			}
			acc += n;
			ingest_taken(g, now);
		}
	}
	ingest_finish(g, 2.0);
	n = ingest_batch(g, &rs, NULL);
	for (size_t k = 0; k < n; k++) {
		monotone &= time_of(&rs[k]) > last_time;
		last_time = time_of(&rs[k]);
	}
	acc += n;
	ingest_counts(g, &tot);
	/* Tokens: 5 at start + 10/s * 2 s; the held record accepted at finish is one more. */
	ok(acc <= 5 + 20 + 1 && acc >= 20, "at rate 10/s, burst 5, %zu of 100000 records accepted in 2 s", acc);
	ok(monotone && last_time == 99999, "accepted records in order, the newest (99999) kept at the end");
	ok(tot.received == 100000 && tot.thinned + tot.accepted == 100000,
	   "every record counted: %llu accepted + %llu thinned = %llu received", (unsigned long long)tot.accepted,
	   (unsigned long long)tot.thinned, (unsigned long long)tot.received);
	ingest_taken(g, 2.0);
	ingest_destroy(g);

	/* 3. A held record is released by time alone, and before a summary. */
	g = make(1.0, 1.0, 0.25, 1000, 1024, &c);
	for (int i = 0; i < 3; i++) {
		int len = rec(buf, sizeof(buf), "progress", i);
		ingest_feed(g, buf, (size_t)len, 0.0);
	}
	n = ingest_batch(g, &rs, NULL);
	ok(n == 1 && time_of(&rs[0]) == 0, "burst 1: only the first record passes at once");
	ok(ingest_wait(g, 0.0) <= 0.25 + 1e-12, "a wait is due for the batch (%.3f s)", ingest_wait(g, 0.0));
	ingest_taken(g, 0.0);
	ingest_tick(g, 0.5);
	ok(ingest_batch(g, &rs, NULL) == 0, "half a token later the held record still waits");
	ok(ingest_wait(g, 0.5) > 0.49 && ingest_wait(g, 0.5) < 0.51, "the wait says when the next token comes (%.3f s)",
	   ingest_wait(g, 0.5));
	ingest_tick(g, 1.0);
	n = ingest_batch(g, &rs, NULL);
	ok(n == 1 && time_of(&rs[0]) == 2, "a second later the newest held record (2) is accepted, 1 thinned");
	ingest_taken(g, 1.0);
	int len = rec(buf, sizeof(buf), "progress", 3);
	ingest_feed(g, buf, (size_t)len, 1.0);
	len = rec(buf, sizeof(buf), "summary", 4);
	ingest_feed(g, buf, (size_t)len, 1.0);
	n = ingest_batch(g, &rs, &d);
	ok(n == 2 && time_of(&rs[0]) == 3 && time_of(&rs[1]) == 4,
	   "a summary takes the held progress record before it, without waiting for a token");
	ingest_counts(g, &tot);
	ok(d.thinned == 0 && d.received == 2 && tot.thinned == 1 && tot.received == 5,
	   "counts: this interval 2 received, none thinned; in all 5 received, 1 thinned (record 1)");
	ingest_taken(g, 1.0);
	ingest_destroy(g);

	/* 4. Records of other types are bounded too: burst of them, then the bucket. */
	g = make(1.0, 3.0, 0.25, 1000, 1024, &c);
	for (int i = 0; i < 10; i++) {
		len = rec(buf, sizeof(buf), "advice", i);
		ingest_feed(g, buf, (size_t)len, 0.0);
	}
	n = ingest_batch(g, &rs, NULL);
	ok(n == 6, "10 advice records at once, burst 3: 3 without tokens and 3 with the bucket's (%zu)", n);
	ingest_taken(g, 0.0);
	ingest_destroy(g);

	/* 5. Long lines are cut (and then do not parse: chatter), memory stays bounded. */
	c.n = c.lines = 0;
	c.text[0] = '\0';
	g = make(100.0, 100.0, 0.25, 1000, 64, &c);
	char big[1000];
	memset(big, 'x', sizeof(big));
	big[0] = '{';
	ingest_feed(g, big, sizeof(big), 0.0);
	ingest_feed(g, "\n", 1, 0.0);
	len = rec(buf, sizeof(buf), "progress", 7);
	ingest_feed(g, buf, (size_t)len, 0.0);
	n = ingest_batch(g, &rs, NULL);
	ok(n == 1 && time_of(&rs[0]) == 7 && c.lines == 1 && c.n == 65,
	   "a 1000-byte line is cut at 64 bytes and goes to chatter; the next record is intact");
	ingest_taken(g, 0.0);

	/* 6. Batches are due when full or after the flush interval. */
	ingest_t *h = make(1e9, 1e9, 0.25, 4, 1024, &c);
	for (int i = 0; i < 3; i++) {
		len = rec(buf, sizeof(buf), "progress", i);
		ingest_feed(h, buf, (size_t)len, 0.0);
	}
	ok(!ingest_due(h, 0.1) && ingest_due(h, 0.26), "3 records: due after the 0.25 s interval, not before");
	len = rec(buf, sizeof(buf), "progress", 3);
	ingest_feed(h, buf, (size_t)len, 0.1);
	ok(ingest_due(h, 0.1), "4 records: due at once (max_batch)");
	ingest_destroy(h);
	ingest_destroy(g);
	ingest_destroy(NULL);
	ok(1, "destroy with pending records and destroy(NULL) (leaks show under ASan)");

	/* A split ed run's record (engine/io/report.c: ranks > 1) at the most ranks it lists (RUN_RANKS_MAX 128),
	 * counts of 16 digits, fed in pieces of 1000 bytes at the scheduler's line limit (64 KiB): accepted whole as
	 * a progress record, every per-rank count and the rollbacks, syncs, sync interval and rebalances intact. */
	{
		static char srec[16384];
		size_t m = 0;
		m += (size_t)snprintf(srec + m, sizeof srec - m, "{\"type\":\"progress\",\"time\":5,\"ranks\":128");
		for (int w = 0; w < 2; w++) {
			m += (size_t)snprintf(srec + m, sizeof srec - m, ",\"%s\":[", w ? "rank_particles" : "rank_events");
			for (int k = 0; k < 128; k++)
				m += (size_t)snprintf(srec + m, sizeof srec - m, "%s%lld", k ? "," : "", 1000000000000000LL * (w + 1) + k);
			m += (size_t)snprintf(srec + m, sizeof srec - m, "]");
		}
		m += (size_t)snprintf(srec + m, sizeof srec - m, ",\"rollbacks\":17,\"syncs\":230,\"sync_interval\":0.0275,"
		                      "\"rebalances\":3,\"wall_seconds\":1.5}\n");
		chat_t c3 = {0};
		ingest_t *k = make(10.0, 5.0, 0.25, 64, 1 << 16, &c3);
		for (size_t off = 0; off < m; off += 1000)
			ingest_feed(k, srec + off, m - off < 1000 ? m - off : 1000, 0.0);
		n = ingest_batch(k, &rs, NULL);
		int intact = n == 1 && rs[0].is_progress && strlen(rs[0].line) == m - 1;
		for (int w = 0; w < 2 && intact; w++) {
			json_t *a = json_object_get(rs[0].r, w ? "rank_particles" : "rank_events");
			intact = json_array_size(a) == 128;
			for (int q = 0; q < 128 && intact; q++)
				intact = json_integer_value(json_array_get(a, (size_t)q)) == 1000000000000000LL * (w + 1) + q;
		}
		ok(intact && json_integer_value(json_object_get(rs[0].r, "rollbacks")) == 17 &&
		       json_integer_value(json_object_get(rs[0].r, "syncs")) == 230 &&
		       json_real_value(json_object_get(rs[0].r, "sync_interval")) == 0.0275 &&
		       json_integer_value(json_object_get(rs[0].r, "rebalances")) == 3 && c3.lines == 0,
		   "a split run's record of 128 ranks (%zu bytes) in pieces: accepted whole, per-rank counts and load fields intact",
		   m);
		ingest_destroy(k);
	}
	plan(tap_n);
	return done_testing();
}
