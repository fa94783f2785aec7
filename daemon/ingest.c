/* Progress ingestion of one engine run: lines from its stdout, thinned to a stated rate, batched for one commit per interval. */
#include <stdlib.h>
#include <string.h>
#include "ingest.h"

struct ingest {
	ingest_conf_t c;
	double tokens, t_refill, t_batch;
	uint64_t others;              /* records of other types accepted without a token */
	char *part;                   /* the current unterminated line (max_line bytes) */
	size_t npart;
	int cut;                      /* the current line went past max_line */
	char *held;                   /* the newest record waiting for a token */
	size_t nheld, capheld;
	json_t *held_r;               /* its parse, when classify() needed one */
	int has_held;
	ingest_record_t *pend;
	size_t npend, cappend;
	ingest_counts_t tot, last;
};

ingest_t *ingest_create(const ingest_conf_t *conf, double now)
{
	ingest_t *g = calloc(1, sizeof(*g));
	if (!g)
		return NULL;
	g->c = *conf;
	if (g->c.max_batch < 1)
		g->c.max_batch = 1;
	if (g->c.burst < 1)
		g->c.burst = 1;
	g->part = malloc(g->c.max_line + 1);
	if (!g->part) {
		free(g);
		return NULL;
	}
	g->tokens = g->c.burst;
	g->t_refill = g->t_batch = now;
	return g;
}

static void free_pending(ingest_t *g)
{
	for (size_t i = 0; i < g->npend; i++) {
		free(g->pend[i].line);
		json_decref(g->pend[i].r);
	}
	g->npend = 0;
}

void ingest_destroy(ingest_t *g)
{
	if (!g)
		return;
	free_pending(g);
	free(g->pend);
	free(g->part);
	free(g->held);
	json_decref(g->held_r);
	free(g);
}

static void refill(ingest_t *g, double now)
{
	if (now > g->t_refill) {
		g->tokens += (now - g->t_refill) * g->c.rate;
		if (g->tokens > g->c.burst)
			g->tokens = g->c.burst;
	}
	g->t_refill = now;
}

static void chatter(ingest_t *g, const char *line, size_t len)
{
	if (g->c.chatter)
		g->c.chatter(g->c.ctx, line, len);
}

/* Accept one record: parse it (unless r is given; takes r's reference) and
 * append it to the pending batch. */
static int accept(ingest_t *g, const char *line, size_t len, json_t *r, int is_progress)
{
	if (!r)
		r = json_loadb(line, len, 0, NULL);
	if (!json_is_object(r)) {
		json_decref(r);
		chatter(g, line, len);
		return 0;
	}
	if (g->npend == g->cappend) {
		size_t cap = g->cappend ? 2 * g->cappend : 64;
		ingest_record_t *p = realloc(g->pend, cap * sizeof(*p));
		if (!p) {
			json_decref(r);
			return -1;
		}
		g->pend = p;
		g->cappend = cap;
	}
	char *copy = malloc(len + 1);
	if (!copy) {
		json_decref(r);
		return -1;
	}
	memcpy(copy, line, len);
	copy[len] = '\0';
	g->pend[g->npend++] = (ingest_record_t){.line = copy, .r = r, .is_progress = is_progress};
	g->tot.accepted++;
	return 0;
}

static int accept_held(ingest_t *g)
{
	if (!g->has_held)
		return 0;
	g->has_held = 0;
	json_t *r = g->held_r;
	g->held_r = NULL;
	return accept(g, g->held, g->nheld, r, 1);
}

/* Hold a record back for the next token; a record already held is thinned. */
static int hold(ingest_t *g, const char *line, size_t len, json_t *r)
{
	if (g->has_held)
		g->tot.thinned++;
	json_decref(g->held_r);
	g->held_r = r;
	g->has_held = 0;
	if (len > g->capheld) {
		char *p = realloc(g->held, len);
		if (!p) {
			g->tot.thinned++;   /* the record is lost: count it as thinned, not silently */
			json_decref(g->held_r);
			g->held_r = NULL;
			return -1;
		}
		g->held = p;
		g->capheld = len;
	}
	memcpy(g->held, line, len);
	g->nheld = len;
	g->has_held = 1;
	return 0;
}

/* The engine writes "type" first ({"type":"progress",...}): most records are
 * told apart without parsing. Others are parsed once (the parse is kept). */
static int classify(const char *line, size_t len, json_t **r)
{
	static const char fast[] = "{\"type\":\"progress\"";
	*r = NULL;
	if (len >= sizeof(fast) - 1 && !memcmp(line, fast, sizeof(fast) - 1))
		return 1;
	*r = json_loadb(line, len, 0, NULL);
	const char *t = json_string_value(json_object_get(*r, "type"));
	return t && !strcmp(t, "progress");
}

static int line_done(ingest_t *g, const char *line, size_t len, double now)
{
	if (len && line[len - 1] == '\r')
		len--;
	if (!len)
		return 0;
	if (line[0] != '{') {
		chatter(g, line, len);
		return 0;
	}
	g->tot.received++;
	json_t *r;
	int progress = classify(line, len, &r);
	if (!progress && g->others < (uint64_t)g->c.burst) {
		/* Summary, advice, ...: kept, after the progress record held back
		 * before it (the state the run ended in). */
		g->others++;
		int rc = accept_held(g);
		return accept(g, line, len, r, 0) | rc;
	}
	refill(g, now);
	if (g->tokens >= 1.0) {
		g->tokens -= 1.0;
		if (g->has_held) {
			/* Older than this one, which takes the token. */
			g->has_held = 0;
			json_decref(g->held_r);
			g->held_r = NULL;
			g->tot.thinned++;
		}
		return accept(g, line, len, r, progress);
	}
	return hold(g, line, len, r);
}

int ingest_feed(ingest_t *g, const char *buf, size_t n, double now)
{
	int rc = 0;
	while (n) {
		const char *nl = memchr(buf, '\n', n);
		size_t len = nl ? (size_t)(nl - buf) : n;
		if (nl && !g->npart && !g->cut) {
			/* A whole line inside buf: no copy. */
			if (len > g->c.max_line)
				len = g->c.max_line;
			rc |= line_done(g, buf, len, now);
		} else {
			size_t room = g->c.max_line - g->npart, take = len < room ? len : room;
			memcpy(g->part + g->npart, buf, take);
			g->npart += take;
			if (take < len)
				g->cut = 1;
			if (nl) {
				rc |= line_done(g, g->part, g->npart, now);
				g->npart = 0;
				g->cut = 0;
			}
		}
		if (!nl)
			break;
		size_t used = (size_t)(nl - buf) + 1;
		buf += used;
		n -= used;
	}
	return rc ? -1 : 0;
}

void ingest_tick(ingest_t *g, double now)
{
	refill(g, now);
	if (g->has_held && g->tokens >= 1.0) {
		g->tokens -= 1.0;
		accept_held(g);
	}
}

void ingest_finish(ingest_t *g, double now)
{
	if (g->npart) {
		line_done(g, g->part, g->npart, now);
		g->npart = 0;
		g->cut = 0;
	}
	accept_held(g);
}

int ingest_due(const ingest_t *g, double now)
{
	return g->npend >= g->c.max_batch || (g->npend && now - g->t_batch >= g->c.flush);
}

double ingest_wait(const ingest_t *g, double now)
{
	double w = 1e9;
	if (g->npend)
		w = g->npend >= g->c.max_batch ? 0.0 : g->t_batch + g->c.flush - now;
	if (g->has_held) {
		double tok = (1.0 - g->tokens) / g->c.rate;
		if (tok < w)
			w = tok;
	}
	return w < 0.0 ? 0.0 : w;
}

size_t ingest_batch(const ingest_t *g, const ingest_record_t **recs, ingest_counts_t *delta)
{
	*recs = g->pend;
	if (delta) {
		delta->received = g->tot.received - g->last.received;
		delta->thinned = g->tot.thinned - g->last.thinned;
		delta->accepted = g->tot.accepted - g->last.accepted;
	}
	return g->npend;
}

void ingest_taken(ingest_t *g, double now)
{
	free_pending(g);
	g->last = g->tot;
	g->t_batch = now;
}

void ingest_counts(const ingest_t *g, ingest_counts_t *out)
{
	*out = g->tot;
}
