/* Progress ingestion of one engine run: lines from its stdout, thinned to a stated rate, batched for one commit per interval. */
#pragma once

#include <stddef.h>
#include <stdint.h>
#include <jansson.h>

/*
 * Contract
 * - Pure logic: no I/O, no clock. The caller reads the engine's stdout and
 *   passes the bytes and the time (monotonic seconds) in; it takes the
 *   accepted records out in batches and stores them (one transaction per
 *   batch).
 * - A record is a line that starts with '{'. Other lines are launcher
 *   chatter, handed to conf.chatter (for the stderr tail) and not counted.
 * - Rate: records of type "progress" are accepted through a token bucket of
 *   `rate` tokens per second holding at most `burst`. A record that finds no
 *   token is held back; a newer record replaces it (the replaced one is
 *   thinned, i.e. counted and never stored). The held record is accepted
 *   when a token is free and nothing newer came (ingest_tick()), when a
 *   record of another type arrives (so the last progress record before a
 *   summary is kept), and at ingest_finish().
 * - Records of other types (summary, advice, resume, ...) are accepted
 *   without waiting for a token, up to `burst` of them per run; beyond that
 *   they are thinned like progress records (a runaway engine stays bounded).
 * - So at most burst + rate * t progress records and burst others are
 *   accepted in t seconds, whatever the engine writes; an engine within
 *   that rate loses nothing. Memory: the pending batch (the caller takes it
 *   at least every `flush` seconds or when it holds max_batch records) and
 *   one held line.
 * - Lines longer than max_line bytes are cut there; such a record will not
 *   parse and goes to chatter.
 * - Accepted records are parsed (jansson); one that is not a JSON object
 *   goes to chatter instead (counted as received, neither stored nor thinned).
 */

typedef struct ingest ingest_t;

typedef struct {
	double rate;          /* progress records accepted per second, > 0 */
	double burst;         /* bucket size (records), >= 1 */
	double flush;         /* seconds between batches (ingest_due) */
	size_t max_batch;     /* a batch is due when it holds this many records, >= 1 */
	size_t max_line;      /* longest line kept, bytes */
	void (*chatter)(void *ctx, const char *line, size_t len);
	void *ctx;
} ingest_conf_t;

typedef struct {
	char *line;           /* the record as received (NUL-terminated) */
	json_t *r;            /* parsed: an object */
	int is_progress;      /* "type": "progress" */
} ingest_record_t;

typedef struct {
	uint64_t received;    /* records seen (lines starting with '{') */
	uint64_t thinned;     /* records replaced while held back: never stored */
	uint64_t accepted;    /* records handed out in batches (or pending) */
} ingest_counts_t;

/* NULL when out of memory. now: monotonic seconds (the bucket starts full). */
ingest_t *ingest_create(const ingest_conf_t *conf, double now);
void ingest_destroy(ingest_t *g);

/* Feed n bytes of stdout at time now. 0, or -1 when out of memory (bytes
 * of the current line may then be lost; counts stay consistent). */
int ingest_feed(ingest_t *g, const char *buf, size_t n, double now);
/* Refill the bucket and accept the held record if a token is free. */
void ingest_tick(ingest_t *g, double now);
/* The end of the run: a final unterminated line is taken as a line, the
 * held record is accepted whatever the bucket says. */
void ingest_finish(ingest_t *g, double now);

/* 1 when the pending batch should be stored now: it is full, or it is not
 * empty and `flush` seconds passed since the last batch was taken. */
int ingest_due(const ingest_t *g, double now);
/* Seconds until ingest_due() may become true (for a poll timeout); INFINITY-free: a large number when nothing is pending. */
double ingest_wait(const ingest_t *g, double now);
/* The pending batch: *recs points to n records owned by g, valid until
 * ingest_taken(). delta: counts accumulated since the previous batch. */
size_t ingest_batch(const ingest_t *g, const ingest_record_t **recs, ingest_counts_t *delta);
/* The caller stored (or gave up on) the batch: free it, start the next interval. */
void ingest_taken(ingest_t *g, double now);
/* Totals since ingest_create(). */
void ingest_counts(const ingest_t *g, ingest_counts_t *out);
