/* Parallel event-driven hard disks/spheres: one rank's share of one periodic system (cells of a Morton range, ghosts, border updates, rollback); pure, no MPI. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include <limits.h>
#include <stdio.h>

#include "par/decomp.h"
#include "par/ped.h"
#include "scene.h"

/* Cell roles on a rank: not seen, ghost, own interior, own border (seen by
 * another rank), own guard (next to a border cell). Events touching
 * border or guard cells are processed in global time order. */
enum { R_FOREIGN = 0, R_GHOST = 1, R_INNER = 2, R_BORDER = 3, R_GUARD = 4 };

typedef struct {
	double r[3], v[3], t, tlast, tev;   /* position at t, velocity, TC time, last event */
	double tloc;                        /* its last event processed by this rank (-INFINITY: none) */
	double pv[3], tcol, pcol;           /* velocity before its last collision at tcol, the one before at pcol
	                                     * (own particles; pcol INFINITY: history unknown) */
	uint64_t count;                     /* collisions of this particle */
	uint32_t gid;
	int32_t cc[3];
	int32_t next;                       /* cell list link (free list link when free) */
	int32_t own;                        /* 1 own, 0 ghost, -1 free */
} rec_t;

typedef struct {
	double t_coll, t_cross, key;
	uint64_t pcount;
	int32_t partner;
	uint32_t pgid;
	int32_t cross;                      /* 2 axis + up, -1 none */
	int32_t pad;
} pev_t;

/* Calendar entry: the key and the tie-break id kept in the heap itself, so
 * that sifting reads no particle record. */
typedef struct {
	double key;
	uint32_t gid;
	int32_t i;
} hent_t;

/* The part of the state a rollback restores besides the arrays. */
typedef struct {
	size_t hn;
	int32_t free_head;
	uint64_t collisions, tc_elastic, nlog, owned, events;
	double lt, virial;
	double tmax;        /* the latest event time of any own particle (tev), -INFINITY: none */
	double dek, dekt;   /* since ped_mark(): sum of the collisions' kinetic energy changes, and of each times (t - tref) */
} scal_t;

struct msgbuf {
	ped_msg_t *m;
	size_t n, cap;
};

struct ped {
	ped_params_t p;
	int rank, D;
	double halfL[3], cw[3], sigma2;
	size_t ncells, cap;
	decomp_t *dc;
	uint8_t *role;
	int32_t *head, *head_s;
	rec_t *rec, *rec_s;
	pev_t *ev, *ev_s;
	hent_t *heap, *heap_s;
	int32_t *hpos, *hpos_s;
	scal_t s, s_saved;
	double tref;        /* ped_mark()'s time */
	double err;
	uint64_t events_done;
	struct msgbuf *out;
	int logging;
	ped_coll_t *log;
	size_t logcap;
	int oom;
	int *nb, nnb;       /* ranks owning a cell within two cells of an own cell: the only ones sent to */
	uint32_t *cev;      /* events processed per cell (rolled-back ones included) since the balance window's start */
	uint64_t win0;      /* events_done at the window's start */
};

/* ---- cells ---------------------------------------------------------------- */

static size_t cidx(const ped_t *pd, const int32_t *c)
{
	return ((size_t)c[2] * (size_t)pd->p.nc[1] + (size_t)c[1]) * (size_t)pd->p.nc[0] + (size_t)c[0];
}

/* The cell coordinates of cell index k (cidx()'s inverse). */
static void cell_coords(const ped_t *pd, size_t k, int32_t *c)
{
	c[0] = (int32_t)(k % (size_t)pd->p.nc[0]);
	c[1] = (int32_t)(k / (size_t)pd->p.nc[0] % (size_t)pd->p.nc[1]);
	c[2] = (int32_t)(k / ((size_t)pd->p.nc[0] * (size_t)pd->p.nc[1]));
}

static void cell_insert(ped_t *pd, int32_t i)
{
	size_t c = cidx(pd, pd->rec[i].cc);
	pd->rec[i].next = pd->head[c];
	pd->head[c] = i;
}

static void cell_remove(ped_t *pd, int32_t i)
{
	int32_t *link = &pd->head[cidx(pd, pd->rec[i].cc)];
	while (*link != i)
		link = &pd->rec[*link].next;
	*link = pd->rec[i].next;
}

/* The 3^D cells around c (c itself included) into out; returns how many. */
static int around(const ped_t *pd, const int32_t *c, int32_t out[27][3])
{
	int m = 0, zr = pd->D == 3 ? 1 : 0;
	for (int dz = -zr; dz <= zr; dz++)
		for (int dy = -1; dy <= 1; dy++)
			for (int dx = -1; dx <= 1; dx++) {
				int d[3] = {dx, dy, dz};
				for (int a = 0; a < 3; a++) {
					int32_t x = c[a] + (a < pd->D ? d[a] : 0);
					if (x < 0)
						x += pd->p.nc[a];
					else if (x >= pd->p.nc[a])
						x -= pd->p.nc[a];
					out[m][a] = x;
				}
				m++;
			}
	return m;
}

/* ---- calendar: indexed binary heap over own particles, (time, id) order ---- */

static int hless(const hent_t *a, const hent_t *b)
{
	return a->key < b->key || (a->key == b->key && a->gid < b->gid);
}

static void hswap(ped_t *pd, size_t x, size_t y)
{
	hent_t a = pd->heap[x];
	pd->heap[x] = pd->heap[y];
	pd->heap[y] = a;
	pd->hpos[pd->heap[x].i] = (int32_t)x;
	pd->hpos[pd->heap[y].i] = (int32_t)y;
}

static void hsift(ped_t *pd, size_t k)
{
	while (k > 0 && hless(&pd->heap[k], &pd->heap[(k - 1) / 2])) {
		hswap(pd, k, (k - 1) / 2);
		k = (k - 1) / 2;
	}
	for (;;) {
		size_t l = 2 * k + 1, r = l + 1, m = k;
		if (l < pd->s.hn && hless(&pd->heap[l], &pd->heap[m]))
			m = l;
		if (r < pd->s.hn && hless(&pd->heap[r], &pd->heap[m]))
			m = r;
		if (m == k)
			break;
		hswap(pd, k, m);
		k = m;
	}
}

static void schedule(ped_t *pd, int32_t i)
{
	pev_t *e = &pd->ev[i];
	e->key = e->t_coll <= e->t_cross ? e->t_coll : e->t_cross;
	if (pd->hpos[i] < 0) {
		pd->heap[pd->s.hn] = (hent_t){.key = e->key, .gid = pd->rec[i].gid, .i = i};
		pd->hpos[i] = (int32_t)pd->s.hn++;
	} else {
		pd->heap[pd->hpos[i]].key = e->key;
	}
	hsift(pd, (size_t)pd->hpos[i]);
}

static void hremove(ped_t *pd, int32_t i)
{
	int32_t k = pd->hpos[i];
	if (k < 0)
		return;
	size_t last = --pd->s.hn;
	if ((size_t)k != last) {
		hswap(pd, (size_t)k, last);
		pd->hpos[i] = -1;
		hsift(pd, (size_t)k);
	} else {
		pd->hpos[i] = -1;
	}
}

/* ---- dynamics -------------------------------------------------------------- */

static void advance(rec_t *p, double t)
{
	double dt = t - p->t;
	for (int a = 0; a < 3; a++)
		p->r[a] += p->v[a] * dt;
	p->t = t;
}

/* Earliest contact time of a and b, computed from the later of their
 * reference times with the lower id first: the same bits on every rank.
 * INFINITY also when it cannot come before `best` (dt >= c / (-2 b): no
 * square root for most candidates of a scan; INFINITY: no bound). */
static double pair_time_b(const ped_t *pd, int32_t ia, int32_t ib, double best)
{
	const rec_t *pi = &pd->rec[ia], *pj = &pd->rec[ib];
	if (pi->gid > pj->gid) {
		const rec_t *x = pi;
		pi = pj, pj = x;
	}
	double t0 = pi->t > pj->t ? pi->t : pj->t, dr[3] = {0, 0, 0}, dv[3] = {0, 0, 0};
	for (int a2 = 0; a2 < pd->D; a2++) {
		double xi = pi->r[a2] + pi->v[a2] * (t0 - pi->t), xj = pj->r[a2] + pj->v[a2] * (t0 - pj->t);
		double x = xi - xj;
		if (x > pd->halfL[a2])
			x -= pd->p.L[a2];
		else if (x < -pd->halfL[a2])
			x += pd->p.L[a2];
		dr[a2] = x;
		dv[a2] = pi->v[a2] - pj->v[a2];
	}
	double b = 0.0, r2 = 0.0, v2 = 0.0;
	for (int a2 = 0; a2 < pd->D; a2++) {
		b += dr[a2] * dv[a2];
		r2 += dr[a2] * dr[a2];
		v2 += dv[a2] * dv[a2];
	}
	double c = r2 - pd->sigma2;
	if (b >= 0.0)
		return INFINITY;
	if (c <= 0.0) {
		if (b * b <= 1e-20 * v2 * r2)
			return INFINITY;     /* touching at rounding level: as the serial engine */
		return t0;
	}
	if (!(c < (best - t0) * (-2.0 * b)))
		return INFINITY;
	double disc = b * b - v2 * c;
	if (disc <= 0.0)
		return INFINITY;
	return t0 + c / (-b + sqrt(disc));
}

static double pair_time(const ped_t *pd, int32_t ia, int32_t ib)
{
	return pair_time_b(pd, ia, ib, INFINITY);
}

static void set_cross(ped_t *pd, int32_t i)
{
	const rec_t *p = &pd->rec[i];
	pev_t *e = &pd->ev[i];
	double best = INFINITY;
	int code = -1;
	for (int a = 0; a < pd->D; a++) {
		double v = p->v[a];
		if (v == 0.0)
			continue;
		int up = v > 0.0;
		double f = up ? (p->cc[a] + 1 == pd->p.nc[a] ? pd->p.L[a] : (p->cc[a] + 1) * pd->cw[a]) : p->cc[a] * pd->cw[a];
		double dt = (f - p->r[a]) / v;
		if (dt < 0.0)
			dt = 0.0;
		if (dt < best) {
			best = dt;
			code = 2 * a + up;
		}
	}
	e->t_cross = p->t + best;
	e->cross = code;
}

/* Earliest collision of own particle i with anything in its 3^D cells. */
static void scan(ped_t *pd, int32_t i)
{
	pev_t *e = &pd->ev[i];
	int32_t cells[27][3];
	int m = around(pd, pd->rec[i].cc, cells);
	double best = INFINITY;
	int32_t found = -1;
	for (int k = 0; k < m; k++)
		for (int32_t j = pd->head[cidx(pd, cells[k])]; j >= 0; j = pd->rec[j].next) {
			if (j == i)
				continue;
			double t = pair_time_b(pd, i, j, best);
			if (t < best || (t == best && found >= 0 && pd->rec[j].gid < pd->rec[found].gid)) {
				best = t;
				found = j;
			}
		}
	e->t_coll = best;
	e->partner = found;
	if (found >= 0) {
		e->pgid = pd->rec[found].gid;
		e->pcount = pd->rec[found].count;
	}
}

static void predict(ped_t *pd, int32_t i)
{
	set_cross(pd, i);
	scan(pd, i);
	schedule(pd, i);
}

/* Own particles next to changed ghost g: a collision with it may come
 * earlier than their own next event. Reports one before the local time. */
static void ghost_changed(ped_t *pd, int32_t g)
{
	int32_t cells[27][3];
	int m = around(pd, pd->rec[g].cc, cells);
	for (int k = 0; k < m; k++)
		for (int32_t p = pd->head[cidx(pd, cells[k])]; p >= 0; p = pd->rec[p].next) {
			if (pd->rec[p].own != 1)
				continue;
			double t = pair_time(pd, p, g);
			if (t == INFINITY)
				continue;
			pev_t *e = &pd->ev[p];
			if (t < e->t_coll) {
				e->t_coll = t;
				e->partner = g;
				e->pgid = pd->rec[g].gid;
				e->pcount = pd->rec[g].count;
				schedule(pd, p);
			}
		}
}

static void collide(ped_t *pd, int32_t a, int32_t b, double t)
{
	rec_t *pi = &pd->rec[a], *pj = &pd->rec[b];
	if (pi->gid > pj->gid) {
		rec_t *x = pi;
		pi = pj, pj = x;
	}
	advance(pi, t);
	advance(pj, t);
	memcpy(pi->pv, pi->v, sizeof pi->pv);
	memcpy(pj->pv, pj->v, sizeof pj->pv);
	pi->pcol = pi->tcol, pj->pcol = pj->tcol;
	pi->tcol = pj->tcol = t;
	double dr[3] = {0, 0, 0}, dv[3] = {0, 0, 0}, bb = 0.0, r2 = 0.0;
	for (int k = 0; k < pd->D; k++) {
		double x = pi->r[k] - pj->r[k];
		if (x > pd->halfL[k])
			x -= pd->p.L[k];
		else if (x < -pd->halfL[k])
			x += pd->p.L[k];
		dr[k] = x;
		dv[k] = pi->v[k] - pj->v[k];
		bb += x * dv[k];
		r2 += x * x;
	}
	if (bb < 0.0) {
		double e = pd->p.e;
		if (pd->p.tc > 0.0) {
			if (t - pi->tlast < pd->p.tc || t - pj->tlast < pd->p.tc) {
				e = 1.0;
				pd->s.tc_elastic++;
			}
			pi->tlast = pj->tlast = t;
		}
		double f = 0.5 * (1.0 + e) * bb / r2;
		for (int k = 0; k < pd->D; k++) {
			pi->v[k] -= f * dr[k];
			pj->v[k] += f * dr[k];
		}
		pd->s.virial -= 0.5 * (1.0 + e) * pd->p.mass * bb;
		if (e != 1.0) {   /* the serial engine's energy loss of the pair (ed_impl.h) */
			double de = -0.25 * (1.0 - e * e) * pd->p.mass * bb * bb / r2;
			pd->s.dek += de;
			pd->s.dekt += de * (t - pd->tref);
		}
	}
	pi->count++;
	pj->count++;
	pi->tev = pj->tev = t;
	pi->tloc = pj->tloc = t;
	pd->s.collisions++;
	if (pd->logging) {
		if (pd->s.nlog == pd->logcap) {
			size_t nc = pd->logcap ? 2 * pd->logcap : 1024;
			ped_coll_t *l = realloc(pd->log, nc * sizeof *l);
			if (!l) {
				pd->oom = 1;
				return;
			}
			pd->log = l, pd->logcap = nc;
		}
		pd->log[pd->s.nlog++] = (ped_coll_t){.t = t, .i = pi->gid, .j = pj->gid};
	}
}

/* ---- messages -------------------------------------------------------------- */

static void push(ped_t *pd, int dest, const ped_msg_t *m)
{
	struct msgbuf *b = &pd->out[dest];
	if (b->n == b->cap) {
		size_t nc = b->cap ? 2 * b->cap : 16;
		ped_msg_t *x = realloc(b->m, nc * sizeof *x);
		if (!x) {
			pd->oom = 1;
			return;
		}
		b->m = x, b->cap = nc;
	}
	b->m[b->n++] = *m;
}

/* Send particle i's state (changed at time tu) to every other rank that sees
 * its old cell oc or its new cell, or owns the new cell. */
static void send(ped_t *pd, int32_t i, const int32_t *oc, uint64_t pre_count, double tu)
{
	const rec_t *p = &pd->rec[i];
	ped_msg_t m;
	memset(&m, 0, sizeof m);
	memcpy(m.r, p->r, sizeof m.r);
	memcpy(m.v, p->v, sizeof m.v);
	m.t = p->t, m.tlast = p->tlast, m.tev = p->tev, m.tu = tu;
	m.count = p->count, m.pre_count = pre_count, m.gid = p->gid;
	memcpy(m.cc, p->cc, sizeof m.cc);
	memcpy(m.oc, oc, sizeof m.oc);
	int owner = decomp_owner(pd->dc, p->cc);
	char seen[4096];
	int P = pd->p.ranks;
	char *mark = P <= (int)sizeof seen ? seen : calloc((size_t)P, 1);
	if (!mark) {
		pd->oom = 1;
		return;
	}
	memset(mark, 0, (size_t)P);
	int32_t cells[27][3];
	for (int w = 0; w < 2; w++) {
		int n = around(pd, w ? p->cc : oc, cells);
		for (int k = 0; k < n; k++) {
			int o = decomp_owner(pd->dc, cells[k]);
			if (o == pd->rank || mark[o])
				continue;
			mark[o] = 1;
			m.apply = o == owner && p->own != 1;
			push(pd, o, &m);
		}
	}
	if (mark != seen)
		free(mark);
}

static void flag(ped_t *pd, double t)
{
	if (t < pd->err)
		pd->err = t;
}


/* ---- events ---------------------------------------------------------------- */

/* 0 interior, 1 border, 2 border but not ours to process (a collision with
 * a ghost of lower id: its owner processes it and sends the result). */
static int classify(const ped_t *pd, int32_t i)
{
	const pev_t *e = &pd->ev[i];
	const rec_t *p = &pd->rec[i];
	int ri = pd->role[cidx(pd, p->cc)];
	if (e->t_cross < e->t_coll) {
		int32_t c[3] = {p->cc[0], p->cc[1], p->cc[2]};
		int a = e->cross >> 1;
		c[a] += (e->cross & 1) ? 1 : -1;
		if (c[a] < 0)
			c[a] += pd->p.nc[a];
		else if (c[a] >= pd->p.nc[a])
			c[a] -= pd->p.nc[a];
		return ri != R_INNER || pd->role[cidx(pd, c)] != R_INNER;
	}
	int32_t j = e->partner;
	if (j < 0 || pd->rec[j].own < 0 || pd->rec[j].gid != e->pgid || pd->rec[j].count != e->pcount)
		return 0;   /* cancelled */
	if (pd->rec[j].own == 0)
		return pd->rec[j].gid < p->gid ? 2 : 1;
	return ri != R_INNER || pd->role[cidx(pd, pd->rec[j].cc)] != R_INNER;
}

static void do_cross(ped_t *pd, int32_t i, double t)
{
	rec_t *p = &pd->rec[i];
	pev_t *e = &pd->ev[i];
	int a = e->cross >> 1, dir = (e->cross & 1) ? 1 : -1;
	int32_t oc[3] = {p->cc[0], p->cc[1], p->cc[2]};
	advance(p, t);
	cell_remove(pd, i);
	p->cc[a] += dir;
	if (p->cc[a] >= pd->p.nc[a]) {
		p->cc[a] = 0;
		p->r[a] -= pd->p.L[a];
	} else if (p->cc[a] < 0) {
		p->cc[a] = pd->p.nc[a] - 1;
		p->r[a] += pd->p.L[a];
	}
	p->tev = t;
	p->tloc = t;
	cell_insert(pd, i);
	if (pd->role[cidx(pd, p->cc)] >= R_INNER) {
		predict(pd, i);
	} else {   /* into another rank's cell: it is theirs now, a ghost here */
		hremove(pd, i);
		p->own = 0;
		pd->s.owned--;
		ghost_changed(pd, i);   /* the collisions it held with own particles go to them */
	}
	int ro = pd->role[cidx(pd, oc)], rn = pd->role[cidx(pd, p->cc)];
	if (ro == R_BORDER || rn == R_BORDER || rn == R_GHOST)
		send(pd, i, oc, p->count, t);
}

/* Whether record q had an event after t that matters here: an own
 * particle's last event (whoever made it), or the last event this rank
 * made of a ghost (a collision with an own particle of lower id, or a
 * crossing that took an own particle to another rank). */
static int later(const rec_t *q, double t)
{
	return q->own == 1 ? q->tev > t : (q->own == 0 && q->tloc > t);
}

/* Earliest contact at or after t0 of two straight courses (position ra at
 * time ta, velocity va; the same for b): t0 when they overlap approaching,
 * INFINITY when none. */
static double contact(const ped_t *pd, const double *ra, const double *va, double ta, const double *rb,
                      const double *vb, double tb, double t0)
{
	double b = 0.0, r2 = 0.0, v2 = 0.0;
	for (int a = 0; a < pd->D; a++) {
		double x = (ra[a] + va[a] * (t0 - ta)) - (rb[a] + vb[a] * (t0 - tb));
		if (x > pd->halfL[a])
			x -= pd->p.L[a];
		else if (x < -pd->halfL[a])
			x += pd->p.L[a];
		double dv = va[a] - vb[a];
		b += x * dv;
		r2 += x * x;
		v2 += dv * dv;
	}
	if (b >= 0.0)
		return INFINITY;
	double c = r2 - pd->sigma2;
	if (c <= 0.0)
		return t0;
	double disc = b * b - v2 * c;
	if (disc <= 0.0)
		return INFINITY;
	return t0 + c / (-b + sqrt(disc));
}

/* Whether record q's history after t may have met particle k's course from
 * t (k's record holds that course): q had an event after t (later()) and
 * either its history since t is not known here (a ghost, or more than one
 * collision since t, or a state received from another rank), or one of its
 * at most two courses since t touches k's before q's last event. */
static int met(const ped_t *pd, const rec_t *k, double t, const rec_t *q)
{
	if (!later(q, t))
		return 0;
	if (q->own != 1 || q->pcol > t)
		return 1;
	double s0 = q->tcol > t ? q->tcol : t;   /* the present course since s0 */
	if (contact(pd, k->r, k->v, k->t, q->r, q->v, q->t, s0) < q->tev)
		return 1;
	if (q->tcol > t) {   /* the course before the collision at tcol, from t */
		double rq[3];
		for (int a = 0; a < 3; a++)
			rq[a] = q->r[a] + q->v[a] * (q->tcol - q->t);
		if (contact(pd, k->r, k->v, k->t, rq, q->pv, q->tcol, t) < q->tcol)
			return 1;
	}
	return 0;
}

/* Particle i changed at time t: a particle around it that already had
 * a later event (processed before this one, out of time order) may have met
 * its new course: causality error. Only needed when some own particle has a
 * later event at all (t < tmax); in time order it never has. */
static void later_around(ped_t *pd, int32_t i, double t)
{
	if (!(t < pd->s.tmax))
		return;
	int32_t cells[27][3];
	int m = around(pd, pd->rec[i].cc, cells);
	for (int c = 0; c < m; c++)
		for (int32_t q = pd->head[cidx(pd, cells[c])]; q >= 0; q = pd->rec[q].next)
			if (q != i && met(pd, &pd->rec[i], t, &pd->rec[q])) {
				flag(pd, t);
				return;
			}
}

/* Carry out own particle i's next event at time t (classified as cls). */
static void process(ped_t *pd, int32_t i, double t, int cls)
{
	pev_t *e = &pd->ev[i];
	pd->events_done++;
	pd->cev[cidx(pd, pd->rec[i].cc)]++;
	pd->s.events++;
	pd->s.lt = t;
	if (e->t_cross < e->t_coll) {
		do_cross(pd, i, t);
		later_around(pd, i, t);
		if (t > pd->s.tmax)
			pd->s.tmax = t;
		return;
	}
	int32_t j = e->partner;
	if (j < 0 || pd->rec[j].own < 0 || pd->rec[j].gid != e->pgid || pd->rec[j].count != e->pcount) {
		scan(pd, i);       /* cancelled: the partner changed course */
		schedule(pd, i);
		return;
	}
	/* the pair's time afresh from the two particles' present records (their
	 * last events), not the calendar's value, which depends on when the pair
	 * was last predicted (the order in which changes arrived): the same bits
	 * whatever the order of processing */
	double tc = pair_time(pd, i, j);
	if (tc < INFINITY)
		t = tc;
	/* a particle that already had a later event (an interior one run ahead
	 * of this border event) has a wrong history: causality error */
	if (pd->rec[i].tev > t || pd->rec[j].tev > t)
		flag(pd, t);
	collide(pd, i, j, t);
	later_around(pd, i, t);
	later_around(pd, j, t);
	if (t > pd->s.tmax)
		pd->s.tmax = t;
	if (pd->rec[j].own == 1) {
		predict(pd, i);
		predict(pd, j);
	} else {
		predict(pd, i);
		ghost_changed(pd, j);
	}
	if (cls) {
		int32_t ic[3], jc[3];
		memcpy(ic, pd->rec[i].cc, sizeof ic);
		memcpy(jc, pd->rec[j].cc, sizeof jc);
		if (pd->role[cidx(pd, ic)] == R_BORDER)
			send(pd, i, ic, pd->rec[i].count - 1, t);
		if (pd->rec[j].own != 1 || pd->role[cidx(pd, jc)] == R_BORDER)
			send(pd, j, jc, pd->rec[j].count - 1, t);
	}
}

double ped_run(ped_t *pd, double horizon, double barrier, uint64_t *done)
{
	uint64_t n = 0;
	double next = INFINITY;
	while (pd->s.hn > 0) {
		int32_t i = pd->heap[0].i;
		double t = pd->heap[0].key;
		if (!(t < barrier))
			break;
		int cls = classify(pd, i);
		if (cls == 1 && t > horizon) {
			next = t;   /* a border event beyond the horizon */
			break;
		}
		if (cls == 2) {
			/* a collision with a ghost of lower id, which its owner
			 * processes and sends, at its own time for the pair, which may
			 * differ by rounding: ped_sched()'s horizon has a slack of
			 * PED_SLACK. So close to the barrier the owner's time may lie
			 * beyond it: then it is not a time to wait for (the pair comes
			 * after the sync). */
			if (t + PED_SLACK * fabs(t) < barrier)
				next = t;
			break;
		}
		process(pd, i, t, cls);
		n++;
	}
	if (done)
		*done = n;
	return next;
}

double ped_error(const ped_t *pd)
{
	return pd->err;
}

/* ---- receiving ------------------------------------------------------------- */

static int32_t find(const ped_t *pd, const int32_t *c, uint32_t gid)
{
	if (pd->role[cidx(pd, c)] == R_FOREIGN)
		return -1;
	for (int32_t j = pd->head[cidx(pd, c)]; j >= 0; j = pd->rec[j].next)
		if (pd->rec[j].gid == gid)
			return j;
	return -1;
}

/* A valid pending collision of own particle k before t, in k's calendar
 * entry or in an own neighbour's (the pair is kept by whichever predicted it
 * last): flagged at its time. */
static void pending_before(ped_t *pd, int32_t k, double t)
{
	const pev_t *e = &pd->ev[k];
	int32_t j = e->partner;
	if (pd->hpos[k] >= 0 && e->t_coll < t && j >= 0 && pd->rec[j].own >= 0 && pd->rec[j].gid == e->pgid &&
	    pd->rec[j].count == e->pcount)
		flag(pd, e->t_coll);
	int32_t cells[27][3];
	int n = around(pd, pd->rec[k].cc, cells);
	for (int c = 0; c < n; c++)
		for (int32_t q = pd->head[cidx(pd, cells[c])]; q >= 0; q = pd->rec[q].next) {
			const pev_t *f = &pd->ev[q];
			if (q != k && pd->rec[q].own == 1 && pd->hpos[q] >= 0 && f->partner == k && f->t_coll < t &&
			    f->pgid == pd->rec[k].gid && f->pcount == pd->rec[k].count)
				flag(pd, f->t_coll);
		}
}

static int apply(ped_t *pd, const ped_msg_t *m)
{
	int fresh = 0;
	int32_t k = find(pd, m->oc, m->gid);
	if (k < 0 && memcmp(m->oc, m->cc, sizeof m->cc))
		k = find(pd, m->cc, m->gid);
	if (k >= 0) {
		if (pd->rec[k].count != m->pre_count)
			flag(pd, m->tu < pd->rec[k].tev ? m->tu : pd->rec[k].tev);
		if (pd->rec[k].tev > m->tu)
			flag(pd, m->tu);
		/* another rank changed an own particle at tu (a collision it made)
		 * while the particle still has a valid collision before tu, not yet
		 * processed here (pending_before()): the sender used a state that was not
		 * the particle's at tu (possible once border events run ahead of
		 * global time order). The pair the sender processed is no longer
		 * valid here: the sender's own particle came first in its messages
		 * (process()), so its count has changed; a pending crossing does not
		 * change the course. */
		if (pd->rec[k].own == 1)
			pending_before(pd, k, m->tu);
	}
	int nr = pd->role[cidx(pd, m->cc)];
	if (nr == R_FOREIGN) {
		if (k >= 0) {
			if (pd->rec[k].own == 1) {
				hremove(pd, k);
				pd->s.owned--;
			}
			cell_remove(pd, k);
			pd->rec[k].own = -1;
			pd->rec[k].next = pd->s.free_head;
			pd->s.free_head = k;
		}
		return PED_OK;
	}
	if (k < 0) {
		if (nr >= R_INNER)
			flag(pd, m->tu);   /* a particle moving in must have been a ghost here */
		if (pd->s.free_head < 0)
			return PED_EFULL;
		k = pd->s.free_head;
		pd->s.free_head = pd->rec[k].next;
		pd->rec[k].own = 0;
		pd->rec[k].tloc = -INFINITY;
		pd->hpos[k] = -1;
		fresh = 1;
	} else {
		cell_remove(pd, k);
	}
	rec_t *p = &pd->rec[k];
	memcpy(p->r, m->r, sizeof p->r);
	memcpy(p->v, m->v, sizeof p->v);
	if (fresh || p->count != m->count) {   /* a course whose history is not known here */
		p->tcol = m->tev;
		p->pcol = INFINITY;
	}
	p->t = m->t, p->tlast = m->tlast, p->tev = m->tev, p->count = m->count, p->gid = m->gid;
	memcpy(p->cc, m->cc, sizeof p->cc);
	cell_insert(pd, k);
	/* a neighbour that already had an event after the change (later()) may have met it */
	int32_t cells[27][3];
	int n = around(pd, p->cc, cells);
	for (int c = 0; c < n; c++)
		for (int32_t q = pd->head[cidx(pd, cells[c])]; q >= 0; q = pd->rec[q].next)
			if (q != k && met(pd, &pd->rec[k], m->tu, &pd->rec[q]))
				flag(pd, m->tu);
	if (nr >= R_INNER) {
		if (p->own != 1) {
			p->own = 1;
			pd->s.owned++;
		}
		if (p->tev > pd->s.tmax)
			pd->s.tmax = p->tev;
		predict(pd, k);
	} else {
		if (p->own == 1) {   /* ours moved into another rank's cell by someone else: inconsistent */
			hremove(pd, k);
			pd->s.owned--;
			p->own = 0;
			flag(pd, m->tu);
		}
		ghost_changed(pd, k);
	}
	return PED_OK;
}

int ped_inbox(ped_t *pd, const ped_msg_t *m, size_t n)
{
	for (size_t i = 0; i < n; i++) {
		int rc = apply(pd, &m[i]);
		if (rc)
			return rc;
	}
	return pd->oom ? PED_ENOMEM : PED_OK;
}

int ped_neighbours(const ped_t *pd, const int **ranks)
{
	*ranks = pd->nb;
	return pd->nnb;
}

const ped_msg_t *ped_outbox(const ped_t *pd, int dest, size_t *n)
{
	*n = pd->out[dest].n;
	return pd->out[dest].m;
}

void ped_outbox_clear(ped_t *pd)
{
	for (int r = 0; r < pd->p.ranks; r++)
		pd->out[r].n = 0;
}

/* ---- lifecycle ------------------------------------------------------------- */

void ped_grid(ped_params_t *p, uint64_t n)
{
	double vol = 1.0;
	for (int a = 0; a < p->dim; a++)
		vol *= p->L[a];
	double per = p->dim == 2 ? 1.5 : 8.0;
	double edge = pow(vol / (per * (double)n), 1.0 / p->dim);
	if (edge < p->sigma)
		edge = p->sigma;
	edge *= 1.0 + 1e-9;
	for (int a = 0; a < 3; a++) {
		double k = a < p->dim ? floor(p->L[a] / edge) : 1.0;
		p->nc[a] = k < 1.0 ? 1 : (k > 1e6 ? 1000000 : (int)k);
	}
}

void ped_destroy(ped_t *pd)
{
	if (!pd)
		return;
	decomp_destroy(pd->dc);
	free(pd->role);
	free(pd->head);
	free(pd->head_s);
	free(pd->rec);
	free(pd->rec_s);
	free(pd->ev);
	free(pd->ev_s);
	free(pd->heap);
	free(pd->hpos);
	free(pd->heap_s);
	free(pd->hpos_s);
	if (pd->out)
		for (int r = 0; r < pd->p.ranks; r++)
			free(pd->out[r].m);
	free(pd->out);
	free(pd->log);
	free(pd->nb);
	free(pd->cev);
	free(pd);
}

/* The cell roles and the neighbour ranks of the decomposition's present
 * bounds (ped_create(), ped_migrate_in()). */
static int build_roles(ped_t *pd)
{
	const int rank = pd->rank;
	decomp_rank_t v;
	memset(pd->role, 0, pd->ncells);
	if (decomp_rank_build(pd->dc, rank, &v) != DECOMP_OK)
		return PED_ENOMEM;
	int32_t c[3];
	for (size_t k = 0; k < v.ncells; k++)
		if (decomp_cell(pd->dc, v.cells[k], c))
			pd->role[cidx(pd, c)] = R_INNER;
	for (size_t k = 0; k < v.nborder; k++)
		if (decomp_cell(pd->dc, v.border[k], c))
			pd->role[cidx(pd, c)] = R_BORDER;
	for (size_t k = 0; k < v.nghost; k++)
		if (decomp_cell(pd->dc, v.ghost[k], c))
			pd->role[cidx(pd, c)] = R_GHOST;
	decomp_rank_free(&v);
	for (size_t k = 0; k < pd->ncells; k++) {
		if (pd->role[k] != R_INNER)
			continue;
		cell_coords(pd, k, c);
		int32_t nb[27][3];
		int m = around(pd, c, nb);
		for (int q = 0; q < m; q++)
			if (pd->role[cidx(pd, nb[q])] == R_BORDER)
				pd->role[k] = R_GUARD;
	}
	/* the ranks a send() may address: owners of the cells around the own and
	 * ghost cells (a changed ghost's cell, or a crossing's new cell, is at
	 * most one cell from an own one) */
	char *seen = calloc((size_t)pd->p.ranks, 1);
	if (!seen)
		return PED_ENOMEM;
	for (size_t k = 0; k < pd->ncells; k++) {
		if (pd->role[k] != R_GHOST)
			continue;
		cell_coords(pd, k, c);
		int32_t nb[27][3];
		int m = around(pd, c, nb);
		for (int q = 0; q < m; q++) {
			int o = decomp_owner(pd->dc, nb[q]);
			if (o != rank && o >= 0 && !seen[o])
				seen[o] = 1;
		}
	}
	pd->nnb = 0;
	for (int r = 0; r < pd->p.ranks; r++)
		if (seen[r])
			pd->nb[pd->nnb++] = r;
	free(seen);
	return PED_OK;
}

ped_t *ped_create(const ped_params_t *p, int rank, size_t capacity, int *err)
{
	*err = PED_EINVAL;
	if ((p->dim != 2 && p->dim != 3) || p->ranks < 1 || rank < 0 || rank >= p->ranks || capacity < 1 ||
	    capacity > INT32_MAX || !(p->sigma > 0.0) || !(p->mass > 0.0) || !(p->e >= 0.0 && p->e <= 1.0) || !(p->tc >= 0.0))
		return NULL;
	for (int a = 0; a < p->dim; a++)
		if (p->nc[a] < 3 || !(p->L[a] / p->nc[a] >= p->sigma))
			return NULL;
	*err = PED_ENOMEM;
	ped_t *pd = calloc(1, sizeof *pd);
	if (!pd)
		return NULL;
	pd->p = *p;
	pd->rank = rank;
	pd->D = p->dim;
	for (int a = p->dim; a < 3; a++) {
		pd->p.nc[a] = 1;
		pd->p.L[a] = 1.0;
	}
	for (int a = 0; a < 3; a++) {
		pd->halfL[a] = 0.5 * pd->p.L[a];
		pd->cw[a] = pd->p.L[a] / pd->p.nc[a];
	}
	pd->sigma2 = p->sigma * p->sigma;
	pd->ncells = (size_t)pd->p.nc[0] * (size_t)pd->p.nc[1] * (size_t)pd->p.nc[2];
	pd->cap = capacity;
	pd->err = INFINITY;
	int periodic[3] = {1, 1, 1}, derr;
	pd->dc = decomp_create(pd->D, pd->p.nc, periodic, p->ranks, &derr);
	pd->role = calloc(pd->ncells, 1);
	pd->head = malloc(pd->ncells * sizeof *pd->head);
	pd->head_s = malloc(pd->ncells * sizeof *pd->head);
	pd->rec = calloc(capacity, sizeof *pd->rec);
	pd->rec_s = malloc(capacity * sizeof *pd->rec);
	pd->ev = calloc(capacity, sizeof *pd->ev);
	pd->ev_s = malloc(capacity * sizeof *pd->ev);
	pd->heap = malloc(capacity * sizeof *pd->heap);
	pd->hpos = malloc(capacity * sizeof *pd->hpos);
	pd->heap_s = malloc(capacity * sizeof *pd->heap);
	pd->hpos_s = malloc(capacity * sizeof *pd->hpos);
	pd->out = calloc((size_t)p->ranks, sizeof *pd->out);
	if (!pd->dc || !pd->role || !pd->head || !pd->head_s || !pd->rec || !pd->rec_s || !pd->ev || !pd->ev_s ||
	    !pd->heap || !pd->hpos || !pd->heap_s || !pd->hpos_s || !pd->out) {
		if (!pd->dc && derr == DECOMP_EINVAL)
			*err = PED_EINVAL;
		ped_destroy(pd);
		return NULL;
	}
	if (!(pd->nb = malloc((size_t)p->ranks * sizeof *pd->nb)) || !(pd->cev = calloc(pd->ncells, sizeof *pd->cev)) ||
	    build_roles(pd) != PED_OK) {
		ped_destroy(pd);
		return NULL;
	}
	for (size_t k = 0; k < pd->ncells; k++)
		pd->head[k] = -1;
	for (size_t k = 0; k < capacity; k++) {
		pd->rec[k].own = -1;
		pd->rec[k].next = k + 1 < capacity ? (int32_t)(k + 1) : -1;
		pd->hpos[k] = -1;
	}
	pd->s.free_head = 0;
	pd->s.lt = 0.0;
	*err = PED_OK;
	return pd;
}

static void cell_of(const ped_t *pd, const double *x, int32_t *c)
{
	c[0] = c[1] = c[2] = 0;
	for (int a = 0; a < pd->D; a++) {
		int32_t q = (int32_t)floor(x[a] / pd->cw[a]);
		c[a] = q < 0 ? 0 : (q >= pd->p.nc[a] ? pd->p.nc[a] - 1 : q);
	}
}

int ped_load(ped_t *pd, uint64_t n, const double *pos, const double *vel)
{
	return ped_load_at(pd, n, pos, vel, NULL, 0.0);
}

int ped_load_at(ped_t *pd, uint64_t n, const double *pos, const double *vel, const double *tlast, double t0)
{
	const int D = pd->D;
	/* the particles of the rank's cells, stored in cell order (neighbours
	 * close in memory), ties in id order: a counting sort over the cells */
	uint32_t *cnt = calloc(pd->ncells + 1, sizeof *cnt);
	uint32_t *order = NULL;
	uint64_t m = 0;
	int rc = PED_OK;
	if (!cnt)
		return PED_ENOMEM;
	for (uint64_t k = 0; k < n; k++) {
		int32_t c[3];
		cell_of(pd, &pos[k * (uint64_t)D], c);
		size_t ci = cidx(pd, c);
		if (pd->role[ci] != R_FOREIGN) {
			cnt[ci + 1]++;
			m++;
		}
	}
	if (m > pd->cap) {
		rc = PED_EFULL;
		goto cleanup;
	}
	for (size_t c = 0; c < pd->ncells; c++)
		cnt[c + 1] += cnt[c];
	order = malloc((m ? m : 1) * sizeof *order);
	if (!order) {
		rc = PED_ENOMEM;
		goto cleanup;
	}
	for (uint64_t k = 0; k < n; k++) {
		int32_t c[3];
		cell_of(pd, &pos[k * (uint64_t)D], c);
		size_t ci = cidx(pd, c);
		if (pd->role[ci] != R_FOREIGN)
			order[cnt[ci]++] = (uint32_t)k;
	}
	for (uint64_t q = 0; q < m; q++) {
		uint64_t k = order[q];
		int32_t c[3];
		cell_of(pd, &pos[k * (uint64_t)D], c);
		int32_t i = pd->s.free_head;
		pd->s.free_head = pd->rec[i].next;
		rec_t *p = &pd->rec[i];
		memset(p, 0, sizeof *p);
		for (int a = 0; a < D; a++) {
			p->r[a] = pos[k * (uint64_t)D + (uint64_t)a];
			p->v[a] = vel[k * (uint64_t)D + (uint64_t)a];
		}
		p->t = t0;
		p->tlast = tlast ? tlast[k] : -INFINITY;
		p->tev = p->tloc = p->tcol = p->pcol = -INFINITY;
		p->gid = (uint32_t)k;
		memcpy(p->cc, c, sizeof p->cc);
		p->own = pd->role[cidx(pd, c)] >= R_INNER;
		pd->s.owned += (uint64_t)p->own;
		cell_insert(pd, i);
	}
	for (size_t i = 0; i < pd->cap; i++)
		if (pd->rec[i].own == 1)
			predict(pd, (int32_t)i);
	pd->tref = t0;
	pd->s.lt = t0;
	pd->s.tmax = -INFINITY;
	ped_save(pd);
cleanup:
	free(cnt);
	free(order);
	return rc;
}

void ped_save(ped_t *pd)
{
	memcpy(pd->rec_s, pd->rec, pd->cap * sizeof *pd->rec);
	memcpy(pd->ev_s, pd->ev, pd->cap * sizeof *pd->ev);
	memcpy(pd->heap_s, pd->heap, pd->s.hn * sizeof *pd->heap);
	memcpy(pd->hpos_s, pd->hpos, pd->cap * sizeof *pd->hpos);
	memcpy(pd->head_s, pd->head, pd->ncells * sizeof *pd->head);
	pd->s_saved = pd->s;
	pd->err = INFINITY;
}

void ped_restore(ped_t *pd)
{
	pd->s = pd->s_saved;
	memcpy(pd->rec, pd->rec_s, pd->cap * sizeof *pd->rec);
	memcpy(pd->ev, pd->ev_s, pd->cap * sizeof *pd->ev);
	memcpy(pd->heap, pd->heap_s, pd->s.hn * sizeof *pd->heap);
	memcpy(pd->hpos, pd->hpos_s, pd->cap * sizeof *pd->hpos);
	memcpy(pd->head, pd->head_s, pd->ncells * sizeof *pd->head);
	pd->err = INFINITY;
	ped_outbox_clear(pd);
}

void ped_totals(const ped_t *pd, ped_totals_t *out)
{
	memset(out, 0, sizeof *out);
	out->collisions = pd->s.collisions;
	out->tc_elastic = pd->s.tc_elastic;
	out->events_done = pd->events_done;
	out->events = pd->s.events;
	out->owned = pd->s.owned;
	out->virial = pd->s.virial;
	out->dekin = pd->s.dek;
	out->dekin_t = pd->s.dekt;
	for (size_t i = 0; i < pd->cap; i++) {
		const rec_t *p = &pd->rec[i];
		if (p->own != 1)
			continue;
		for (int a = 0; a < pd->D; a++) {
			out->ekin += 0.5 * pd->p.mass * p->v[a] * p->v[a];
			out->mom[a] += pd->p.mass * p->v[a];
		}
	}
}

void ped_mark(ped_t *pd, double t)
{
	pd->tref = t;
	pd->s.virial = pd->s.dek = pd->s.dekt = 0.0;
	pd->s_saved.virial = pd->s_saved.dek = pd->s_saved.dekt = 0.0;
}

size_t ped_memory(const ped_t *pd)
{
	size_t per = 2 * (sizeof *pd->rec + sizeof *pd->ev + sizeof *pd->heap + sizeof *pd->hpos);
	size_t out = 0;
	for (int r = 0; r < pd->p.ranks; r++)
		out += pd->out[r].cap * sizeof(ped_msg_t);
	return sizeof *pd + pd->cap * per + pd->ncells * (1 + 2 * sizeof *pd->head + sizeof *pd->cev) + pd->logcap * sizeof(ped_coll_t) + out +
	       (size_t)pd->p.ranks * sizeof *pd->nb;
}

void ped_log_on(ped_t *pd)
{
	pd->logging = 1;
}

const ped_coll_t *ped_log(const ped_t *pd, size_t *n)
{
	*n = pd->s.nlog;
	return pd->log;
}

void ped_owned_tlast(const ped_t *pd, double *tlast)
{
	size_t m = 0;
	for (size_t i = 0; i < pd->cap; i++)
		if (pd->rec[i].own == 1)
			tlast[m++] = pd->rec[i].tlast;
}

void ped_owned(const ped_t *pd, double t, uint32_t *gid, double *pos, double *vel)
{
	size_t m = 0;
	for (size_t i = 0; i < pd->cap; i++) {
		const rec_t *p = &pd->rec[i];
		if (p->own != 1)
			continue;
		if (gid)
			gid[m] = p->gid;
		for (int a = 0; a < pd->D; a++) {
			if (pos) {
				double x = fmod(p->r[a] + p->v[a] * (t - p->t), pd->p.L[a]);
				if (x < 0.0)
					x += pd->p.L[a];
				if (x >= pd->p.L[a])
					x = 0.0;
				pos[m * (size_t)pd->D + (size_t)a] = x;
			}
			if (vel)
				vel[m * (size_t)pd->D + (size_t)a] = p->v[a];
		}
		m++;
	}
}

/* ---- load balancing at a sync ----------------------------------------------- */

uint64_t ped_window_events(const ped_t *pd)
{
	return pd->events_done - pd->win0;
}

void ped_window_cost(const ped_t *pd, double *cost)
{
	for (size_t k = 0; k < pd->ncells; k++) {
		if (pd->role[k] < R_INNER || !pd->cev[k])
			continue;
		int32_t c[3];
		cell_coords(pd, k, c);
		cost[decomp_morton(pd->dc, c)] += (double)pd->cev[k];
	}
}

void ped_window_reset(ped_t *pd)
{
	memset(pd->cev, 0, pd->ncells * sizeof *pd->cev);
	pd->win0 = pd->events_done;
}

uint64_t ped_zsize(const ped_t *pd)
{
	return decomp_zsize(pd->dc);
}

const uint64_t *ped_bounds(const ped_t *pd)
{
	return decomp_bounds(pd->dc);
}

int ped_balance_due(const uint64_t *events, int P, uint64_t n, double *imbalance)
{
	double sum = 0.0, max = 0.0;
	for (int r = 0; r < P; r++) {
		sum += (double)events[r];
		if ((double)events[r] > max)
			max = (double)events[r];
	}
	double mean = sum / P;
	*imbalance = mean > 0.0 ? max / mean : 1.0;
	if (P < 2 || !(mean > 0.0))
		return 0;
	/* beyond the Poisson noise of the busiest of P counts of mean m, and
	 * saving at least one prediction per own particle, the rebuild's cost */
	return *imbalance > 1.0 + sqrt(2.0 * log((double)P) / mean) && max - mean >= (double)n / P;
}

int ped_balance_bounds(const ped_t *pd, const double *cost, uint64_t *newb)
{
	int P = pd->p.ranks, periodic[3] = {1, 1, 1}, err, rc = 0;
	decomp_t *d = decomp_create(pd->D, pd->p.nc, periodic, P, &err);
	if (!d)
		return err == DECOMP_EINVAL ? PED_EINVAL : PED_ENOMEM;
	const uint64_t *old = decomp_bounds(pd->dc);
	if (decomp_set_bounds(d, old) != DECOMP_OK || decomp_balance_prefix_keep(d, cost, PED_BALANCE_TOL) != DECOMP_OK) {
		rc = PED_ENOMEM;
		goto cleanup;
	}
	memcpy(newb, decomp_bounds(d), ((size_t)P + 1) * sizeof *newb);
	for (int r = 0; r <= P; r++)
		rc |= newb[r] != old[r];
cleanup:
	decomp_destroy(d);
	return rc;
}

int ped_migrate_out(ped_t *pd, const uint64_t *newb)
{
	const int P = pd->p.ranks;
	if (decomp_set_bounds(pd->dc, newb) != DECOMP_OK)
		return PED_EINVAL;
	ped_outbox_clear(pd);
	char *mark = malloc((size_t)P);
	if (!mark)
		return PED_ENOMEM;
	for (size_t i = 0; i < pd->cap; i++) {
		const rec_t *p = &pd->rec[i];
		if (p->own != 1)
			continue;
		ped_msg_t m;
		memset(&m, 0, sizeof m);
		memcpy(m.r, p->r, sizeof m.r);
		memcpy(m.v, p->v, sizeof m.v);
		m.t = p->t, m.tlast = p->tlast, m.tev = p->tev, m.tu = p->t;
		m.count = m.pre_count = p->count, m.gid = p->gid;
		memcpy(m.cc, p->cc, sizeof m.cc);
		memcpy(m.oc, p->cc, sizeof m.oc);
		int owner = decomp_owner(pd->dc, p->cc);
		memset(mark, 0, (size_t)P);
		int32_t cells[27][3];
		int n = around(pd, p->cc, cells);
		for (int k = 0; k < n; k++) {
			int o = decomp_owner(pd->dc, cells[k]);
			if (mark[o])
				continue;
			mark[o] = 1;
			m.apply = o == owner && o != pd->rank;   /* it changes owner */
			push(pd, o, &m);
		}
	}
	free(mark);
	return pd->oom ? PED_ENOMEM : PED_OK;
}

typedef struct {
	uint64_t cell;
	uint32_t gid;
	uint32_t k;
} mkey_t;

static int mkey_cmp(const void *a, const void *b)
{
	const mkey_t *x = a, *y = b;
	if (x->cell != y->cell)
		return x->cell < y->cell ? -1 : 1;
	return x->gid < y->gid ? -1 : (x->gid > y->gid);
}

int ped_migrate_in(ped_t *pd, const ped_msg_t *m, size_t n, uint64_t *moved_in)
{
	int rc = build_roles(pd);
	mkey_t *key = NULL;
	*moved_in = 0;
	if (rc != PED_OK)
		return rc;
	if (n > pd->cap)
		return PED_EFULL;
	key = malloc((n ? n : 1) * sizeof *key);
	if (!key)
		return PED_ENOMEM;
	for (size_t k = 0; k < pd->ncells; k++)
		pd->head[k] = -1;
	for (size_t k = 0; k < pd->cap; k++) {
		pd->rec[k].own = -1;
		pd->rec[k].next = k + 1 < pd->cap ? (int32_t)(k + 1) : -1;
		pd->hpos[k] = -1;
	}
	pd->s.free_head = 0;
	pd->s.hn = 0;
	pd->s.owned = 0;
	pd->s.tmax = -INFINITY;
	/* stored in cell order, ties in id order, as ped_load_at() */
	for (size_t q = 0; q < n; q++) {
		key[q] = (mkey_t){.cell = cidx(pd, m[q].cc), .gid = m[q].gid, .k = (uint32_t)q};
		if (pd->role[key[q].cell] == R_FOREIGN) {
			rc = PED_EINVAL;   /* cannot happen: ped_migrate_out() sends to the ranks that see the cell */
			goto cleanup;
		}
	}
	qsort(key, n, sizeof *key, mkey_cmp);
	for (size_t q = 0; q < n; q++) {
		const ped_msg_t *x = &m[key[q].k];
		int32_t i = pd->s.free_head;
		pd->s.free_head = pd->rec[i].next;
		rec_t *p = &pd->rec[i];
		memset(p, 0, sizeof *p);
		memcpy(p->r, x->r, sizeof p->r);
		memcpy(p->v, x->v, sizeof p->v);
		/* every event of every particle lies before the sync, every later one
		 * after it: the histories before it (tloc, tcol, pcol) matter no more */
		p->t = x->t, p->tlast = x->tlast, p->tev = x->tev;
		p->tloc = p->tcol = p->pcol = -INFINITY;
		p->count = x->count, p->gid = x->gid;
		memcpy(p->cc, x->cc, sizeof p->cc);
		p->own = pd->role[key[q].cell] >= R_INNER;
		pd->s.owned += (uint64_t)p->own;
		*moved_in += (uint64_t)(p->own && x->apply);
		cell_insert(pd, i);
	}
	for (size_t i = 0; i < pd->cap; i++)
		if (pd->rec[i].own == 1)
			predict(pd, (int32_t)i);
	ped_outbox_clear(pd);
	ped_save(pd);
	rc = pd->oom ? PED_ENOMEM : PED_OK;
cleanup:
	free(key);
	return rc;
}

/* ---- scenes ---------------------------------------------------------------- */

int ped_scene_check(const scene_t *s, int out, char *msg, size_t msglen)
{
	const char *key = NULL, *why = NULL;
	const unsigned ok_obs = SCENE_OBS_ENERGY | SCENE_OBS_PRESSURE | SCENE_OBS_COLLISION_RATE | SCENE_OBS_MOMENTUM;
	char grid[160];
	if (s->method != SCENE_METHOD_ED)
		key = "method", why = "a split ed run needs method ed";
	else if (scene_has_gravity(s))
		key = "gravity", why = "gravity over several ranks is not supported yet";
	else if (scene_has_walls(s))
		key = "boundaries", why = "walls over several ranks are not supported yet (periodic box only)";
	else if (s->n_obstacles > 0)
		key = "obstacles", why = "obstacles over several ranks are not supported yet";
	else if (scene_has_species(s))
		key = "particles.species", why = "mixtures over several ranks are not supported yet";
	else if (s->rough)
		key = "collisions.rough", why = "rough particles over several ranks are not supported yet";
	else if (s->drive != SCENE_DRIVE_NONE)
		key = "driving", why = "driven systems over several ranks are not supported yet";
	else if (s->restitution < 1.0 && !(s->tc > 0.0))
		key = "collisions.tc", why = "an inelastic run over several ranks needs the TC model (tc > 0): an inelastic "
		                             "collapse is not detected there yet";
	else if (s->until.kind != SCENE_CLOCK_TIME)
		key = "run.until", why = "over several ranks only a time (collision counts are not reached in order there)";
	else if (s->every.kind != SCENE_CLOCK_TIME)
		key = "output.every", why = "over several ranks only a time";
	else if (out && s->snapshots.kind != SCENE_CLOCK_NONE && s->snapshots.kind != SCENE_CLOCK_TIME)
		key = "output.snapshots", why = "over several ranks only a time";
	else if (s->observables & ~ok_obs)
		key = "output.observables", why = "over several ranks only kinetic_energy, temperature, pressure, "
		                                  "compressibility, collision_rate and momentum (sums over the particles)";
	else if (s->count > UINT32_MAX || (double)s->count * s->dim > (double)INT_MAX / 2)
		key = "particles.count", why = "at most 2^30 / dimensions particles over several ranks";
	if (!key) {
		ped_params_t p = {.dim = s->dim, .sigma = 2.0 * s->radius};
		for (int a = 0; a < 3; a++)
			p.L[a] = a < s->dim ? s->box[a] : 1.0;
		ped_grid(&p, s->count);
		for (int a = 0; a < s->dim; a++)
			if (p.nc[a] < 3) {
				snprintf(grid, sizeof grid, "the split run needs at least 3 cells of one diameter along each axis; "
				         "this box has %d along axis %d", p.nc[a], a);
				key = "particles.count", why = grid;
				break;
			}
	}
	if (!key)
		return 0;
	if (msg && msglen)
		snprintf(msg, msglen, "%s: %s", key, why);
	return -1;
}

uint64_t ped_scene_bytes(const scene_t *s, int P)
{
	ped_params_t p = {.dim = s->dim, .sigma = 2.0 * s->radius};
	for (int a = 0; a < 3; a++)
		p.L[a] = a < s->dim ? s->box[a] : 1.0;
	ped_grid(&p, s->count);
	uint64_t ncells = 1;
	for (int a = 0; a < s->dim; a++)
		ncells *= (uint64_t)p.nc[a];
	/* ped_create(): records, calendar entries, heap and heap positions, each with its saved copy; a role
	 * byte, two list heads and an event count per cell; the outboxes (ped_memory()) */
	const uint64_t per = 2 * (sizeof(rec_t) + sizeof(pev_t) + sizeof(hent_t) + sizeof(int32_t));
	uint64_t b = sizeof(struct ped) + s->count * per + ncells * (1 + 3 * sizeof(int32_t)) +
	             (uint64_t)P * (sizeof(struct msgbuf) + 16 * sizeof(ped_msg_t) + sizeof(int));
	/* run.balance: a rebalance's cost array over the Z space (at most 2^D ids per cell) and the moved
	 * records, sent and received (at most every particle, the capacity) */
	if (s->balance)
		b += ncells * ((uint64_t)1 << s->dim) * sizeof(double) + 2 * s->count * sizeof(ped_msg_t);
	return b;
}

/* ---- drivers --------------------------------------------------------------- */

void ped_sched_init(ped_sched_t *s, double t_end, double sync_dt)
{
	memset(s, 0, sizeof *s);
	s->t_end = t_end;
	s->sync_dt = sync_dt;
	s->window = sync_dt * PED_WINDOW;
	s->barrier = sync_dt < t_end ? sync_dt : t_end;
	s->horizon = s->window;
	s->st.sync_dt = sync_dt;
	s->st.window = s->window;
}

void ped_sched_next(ped_sched_t *s, double t0, double t_end)
{
	s->t_end = t_end;
	s->t_sync = t0;
	s->cons = 0;
	s->barrier = t0 + s->sync_dt < t_end ? t0 + s->sync_dt : t_end;
	s->horizon = t0 + s->window;
}

int ped_sched(ped_sched_t *s, double E, double T, int quiet)
{
	s->st.rounds++;
	if (E < INFINITY) {
		s->st.rollbacks++;
		if (E > s->t_sync) {
			s->barrier = E;
		} else {
			/* an error at the sync itself: run this section again with
			 * border events in global time order only (window 0) */
			if (s->cons)
				return -1;
			s->cons = 1;
		}
		s->sync_dt *= 0.5;
		s->window *= 0.5;
		s->st.sync_dt = s->sync_dt;
		s->st.window = s->window;
		s->horizon = s->t_sync + (s->cons ? 0.0 : s->window);
		return 1;
	}
	if (T == INFINITY && quiet) {
		s->st.syncs++;
		s->t_sync = s->barrier;
		s->cons = 0;
		if (s->barrier >= s->t_end)
			return 3;
		s->sync_dt *= 1.1;
		s->window *= 1.1;
		s->st.sync_dt = s->sync_dt;
		s->st.window = s->window;
		s->barrier = s->barrier + s->sync_dt < s->t_end ? s->barrier + s->sync_dt : s->t_end;
		s->horizon = s->t_sync + s->window;
		return 2;
	}
	s->horizon = T + (s->cons ? 0.0 : s->window) + PED_SLACK * fabs(T);
	return 0;
}

/* A rebalance of P ranks in one process (the MPI driver's balance(), pedmpi.c). */
static int sim_balance(ped_t **pd, int P, uint64_t n, ped_stats_t *st)
{
	uint64_t *ev = malloc((size_t)P * sizeof *ev), *newb = malloc(((size_t)P + 1) * sizeof *newb);
	double *cost = NULL, imb;
	struct msgbuf *in = calloc((size_t)P, sizeof *in);
	int rc = PED_ENOMEM;
	if (!ev || !newb || !in)
		goto cleanup;
	for (int r = 0; r < P; r++)
		ev[r] = ped_window_events(pd[r]);
	if (!ped_balance_due(ev, P, n, &imb)) {
		rc = PED_OK;
		goto cleanup;
	}
	if (!(cost = calloc(ped_zsize(pd[0]), sizeof *cost)))
		goto cleanup;
	for (int r = 0; r < P; r++)
		ped_window_cost(pd[r], cost);
	rc = ped_balance_bounds(pd[0], cost, newb);
	if (rc == 0)   /* judged: within the hysteresis */
		for (int r = 0; r < P; r++)
			ped_window_reset(pd[r]);
	if (rc <= 0)
		goto cleanup;
	for (int r = 0; r < P; r++)
		if ((rc = ped_migrate_out(pd[r], newb)) != PED_OK)
			goto cleanup;
	for (int d = 0; d < P; d++)
		for (int r = 0; r < P; r++) {
			size_t k;
			const ped_msg_t *m = ped_outbox(pd[r], d, &k);
			if (in[d].n + k > in[d].cap) {
				size_t nc = 2 * (in[d].n + k);
				ped_msg_t *x = realloc(in[d].m, nc * sizeof *x);
				if (!x) {
					rc = PED_ENOMEM;
					goto cleanup;
				}
				in[d].m = x, in[d].cap = nc;
			}
			if (k)
				memcpy(in[d].m + in[d].n, m, k * sizeof *m);
			in[d].n += k;
		}
	for (int r = 0; r < P; r++) {
		uint64_t moved;
		if ((rc = ped_migrate_in(pd[r], in[r].m, in[r].n, &moved)) != PED_OK)
			goto cleanup;
		st->migrated += moved;
		ped_window_reset(pd[r]);
	}
	st->rebalances++;
	rc = PED_OK;
cleanup:
	if (in)
		for (int r = 0; r < P; r++)
			free(in[r].m);
	free(in);
	free(ev);
	free(newb);
	free(cost);
	return rc;
}

int ped_sim_run(ped_t **pd, int P, double t_end, double sync_dt, double window, int force_every, ped_stats_t *st)
{
	return ped_sim_run_bal(pd, P, 0, t_end, sync_dt, window, force_every, 0, st);
}

int ped_sim_run_bal(ped_t **pd, int P, uint64_t npart, double t_end, double sync_dt, double window, int force_every,
                    int balance, ped_stats_t *st)
{
	ped_sched_t s;
	ped_sched_init(&s, t_end, sync_dt);
	if (window >= 0.0) {
		s.window = s.st.window = window;
		s.horizon = window;
	}
	struct msgbuf *in = calloc((size_t)P, sizeof *in);
	int rc = PED_OK;
	if (!in)
		return PED_ENOMEM;
	for (;;) {
		for (int r = 0; r < P; r++) {
			rc = ped_inbox(pd[r], in[r].m, in[r].n);
			in[r].n = 0;
			if (rc)
				goto cleanup;
		}
		double E = INFINITY, T = INFINITY;
		uint64_t done = 0;
		for (int r = 0; r < P; r++) {
			uint64_t n;
			double tb = ped_run(pd[r], s.horizon, s.barrier, &n);
			T = tb < T ? tb : T;
			done += n;
		}
		/* the changed particles, to the inboxes of the next round (the
		 * neighbour exchange of pedmpi.c) */
		size_t nmsg = 0;
		for (int r = 0; r < P; r++) {
			const int *nb;
			int nn = ped_neighbours(pd[r], &nb);
			for (int d = 0; d < P; d++) {
				size_t n;
				const ped_msg_t *m = ped_outbox(pd[r], d, &n);
				int isnb = 0;
				for (int q = 0; q < nn; q++)
					isnb |= nb[q] == d;
				if (n && !isnb) {
					rc = PED_EINVAL;   /* cannot happen: send() addresses neighbours only */
					goto cleanup;
				}
				for (size_t k = 0; k < n; k++) {
					struct msgbuf *b = &in[d];
					if (b->n == b->cap) {
						size_t nc = b->cap ? 2 * b->cap : 16;
						ped_msg_t *x = realloc(b->m, nc * sizeof *x);
						if (!x) {
							rc = PED_ENOMEM;
							goto cleanup;
						}
						b->m = x, b->cap = nc;
					}
					b->m[b->n++] = m[k];
				}
				nmsg += n > 0;
				s.st.bytes += n * sizeof(ped_msg_t);
			}
			ped_outbox_clear(pd[r]);
		}
		s.st.messages += nmsg;
		for (int r = 0; r < P; r++) {
			double e = ped_error(pd[r]);
			E = e < E ? e : E;
		}
		if (force_every > 0 && E == INFINITY && T < INFINITY && T > s.t_sync && (s.st.rounds + 1) % (uint64_t)force_every == 0)
			E = s.t_sync + 0.5 * (T - s.t_sync);
		double hprev = s.horizon;
		int act = ped_sched(&s, E, T, nmsg == 0);

		if (act < 0) {
			rc = PED_ESTALL;   /* errors at the sync itself even in global time order: no progress possible */
			goto cleanup;
		}
		if (act == 1) {
			for (int r = 0; r < P; r++) {
				ped_restore(pd[r]);
				in[r].n = 0;
			}
			continue;
		}
		if (act >= 2) {
			if (act == 3 && !balance)
				break;
			for (int r = 0; r < P; r++)
				ped_save(pd[r]);
			/* also at t_end, as the MPI driver */
			if (balance && P > 1 && (rc = sim_balance(pd, P, npart, &s.st)) != PED_OK)
				goto cleanup;
			if (act == 3)
				break;
			continue;
		}
		if (!done && nmsg == 0 && T <= hprev) {
			rc = PED_ESTALL;   /* nothing moved anywhere though the next event was within reach: it never will */
			goto cleanup;
		}
	}
cleanup:
	for (int r = 0; r < P; r++)
		free(in[r].m);
	free(in);
	if (st)
		*st = s.st;
	return rc;
}

/* ---- the core's own state for a checkpoint (same rank count) ---------------- */

#define PED_IMAGE_MAGIC 0x31474d4944455000ULL   /* "\0PEDIMG1" */

typedef struct {
	uint64_t magic, rank, ranks, cap, ncells, nheld, nfree;
} img_head_t;

typedef struct {
	uint32_t slot;
	int32_t queued;     /* in the calendar */
	rec_t rec;
	pev_t ev;
} img_rec_t;

static void img_put(unsigned char **w, const void *x, size_t n)
{
	if (*w)
		memcpy(*w, x, n);
	if (*w)
		*w += n;
}

/* Writes the image to buf (NULL: only counts); returns its size. */
static size_t image_emit(const ped_t *pd, unsigned char *buf)
{
	const int P = pd->p.ranks;
	img_head_t h = {.magic = PED_IMAGE_MAGIC, .rank = (uint64_t)pd->rank, .ranks = (uint64_t)P,
	                .cap = pd->cap, .ncells = pd->ncells};
	size_t seen = 0;
	for (size_t i = 0; i < pd->cap; i++)
		h.nheld += pd->rec[i].own >= 0;
	for (size_t k = 0; k < pd->ncells; k++)
		seen += pd->role[k] != R_FOREIGN;
	h.nfree = pd->cap - h.nheld;
	size_t size = sizeof h + (size_t)(P + 1) * sizeof(uint64_t) + sizeof pd->s + sizeof pd->tref +
	              2 * sizeof(uint64_t) + seen * (sizeof(int32_t) + sizeof(uint32_t)) + h.nheld * sizeof(img_rec_t) +
	              h.nfree * sizeof(uint32_t);
	if (!buf)
		return size;
	unsigned char *w = buf;
	img_put(&w, &h, sizeof h);
	img_put(&w, decomp_bounds(pd->dc), (size_t)(P + 1) * sizeof(uint64_t));
	img_put(&w, &pd->s, sizeof pd->s);
	img_put(&w, &pd->tref, sizeof pd->tref);
	img_put(&w, &pd->events_done, sizeof pd->events_done);
	img_put(&w, &pd->win0, sizeof pd->win0);
	for (size_t k = 0; k < pd->ncells; k++)
		if (pd->role[k] != R_FOREIGN) {
			img_put(&w, &pd->head[k], sizeof pd->head[k]);
			img_put(&w, &pd->cev[k], sizeof pd->cev[k]);
		}
	for (size_t i = 0; i < pd->cap; i++)
		if (pd->rec[i].own >= 0) {
			img_rec_t x;
			memset(&x, 0, sizeof x);
			x.slot = (uint32_t)i;
			x.queued = pd->hpos[i] >= 0;
			x.rec = pd->rec[i];
			x.ev = pd->ev[i];
			img_put(&w, &x, sizeof x);
		}
	for (int32_t f = pd->s.free_head; f >= 0; f = pd->rec[f].next) {
		uint32_t u = (uint32_t)f;
		img_put(&w, &u, sizeof u);
	}
	return size;
}

size_t ped_image_size(const ped_t *pd)
{
	return image_emit(pd, NULL);
}

size_t ped_image_write(const ped_t *pd, unsigned char *buf)
{
	return image_emit(pd, buf);
}

static int img_get(const unsigned char **r, const unsigned char *end, void *x, size_t n)
{
	if ((size_t)(end - *r) < n)
		return -1;
	memcpy(x, *r, n);
	*r += n;
	return 0;
}

int ped_image_load(ped_t *pd, const unsigned char *buf, size_t len)
{
	const int P = pd->p.ranks;
	const unsigned char *r = buf, *end = buf + len;
	img_head_t h;
	uint64_t *b = malloc((size_t)(P + 1) * sizeof *b);
	int rc = PED_EINVAL;
	if (!b)
		return PED_ENOMEM;
	if (img_get(&r, end, &h, sizeof h) || h.magic != PED_IMAGE_MAGIC || h.rank != (uint64_t)pd->rank ||
	    h.ranks != (uint64_t)P || h.cap != pd->cap || h.ncells != pd->ncells || h.nheld + h.nfree != pd->cap ||
	    img_get(&r, end, b, (size_t)(P + 1) * sizeof *b) || decomp_set_bounds(pd->dc, b) != DECOMP_OK)
		goto cleanup;
	if ((rc = build_roles(pd)) != PED_OK)
		goto cleanup;
	rc = PED_EINVAL;
	scal_t s;
	if (img_get(&r, end, &s, sizeof s) || img_get(&r, end, &pd->tref, sizeof pd->tref) ||
	    img_get(&r, end, &pd->events_done, sizeof pd->events_done) || img_get(&r, end, &pd->win0, sizeof pd->win0))
		goto cleanup;
	for (size_t k = 0; k < pd->ncells; k++) {
		pd->head[k] = -1;
		pd->cev[k] = 0;
		if (pd->role[k] != R_FOREIGN &&
		    (img_get(&r, end, &pd->head[k], sizeof pd->head[k]) || img_get(&r, end, &pd->cev[k], sizeof pd->cev[k])))
			goto cleanup;
	}
	for (size_t i = 0; i < pd->cap; i++) {
		pd->rec[i].own = -1;
		pd->rec[i].next = -1;
		pd->hpos[i] = -1;
	}
	pd->s = s;
	pd->s.hn = 0;
	pd->s.nlog = 0;   /* the collision log (ped_log_on(), tests) is not in the image: it starts again here */
	for (uint64_t q = 0; q < h.nheld; q++) {
		img_rec_t x;
		if (img_get(&r, end, &x, sizeof x) || x.slot >= pd->cap || x.rec.own < 0 || pd->rec[x.slot].own >= 0)
			goto cleanup;
		pd->rec[x.slot] = x.rec;
		pd->ev[x.slot] = x.ev;
		if (x.queued && x.rec.own == 1)
			schedule(pd, (int32_t)x.slot);
	}
	int32_t *link = &pd->s.free_head;
	for (uint64_t q = 0; q < h.nfree; q++) {
		uint32_t u;
		if (img_get(&r, end, &u, sizeof u) || u >= pd->cap || pd->rec[u].own >= 0)
			goto cleanup;
		*link = (int32_t)u;
		link = &pd->rec[u].next;
	}
	*link = -1;
	if (r != end || pd->s.hn != s.hn)
		goto cleanup;
	ped_outbox_clear(pd);
	ped_save(pd);
	rc = PED_OK;
cleanup:
	free(b);
	return rc;
}
