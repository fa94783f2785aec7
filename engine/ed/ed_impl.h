/* Dimension-specific event-driven kernels; included by ed.c once per dimension with D and FN() defined. */

/*
 * Expects: D (2 or 3), P_T (particle record type with r[D], v[D], t, next,
 * count) and FN(name) (name mangling), plus the shared declarations of ed.c.
 */

/* Free flight of particle p to time t (lazy: only when the particle is touched). */
static inline void FN(advance)(P_T *p, double t)
{
	double dt = t - p->t;
	FOR_AXES(a)
		p->r[a] += p->v[a] * dt;
	p->t = t;
}

static inline int32_t FN(cell_index)(const struct ed *ed, const int32_t *cc)
{
#if D == 2
	return cc[1] * ed->nc[0] + cc[0];
#else
	return (cc[2] * ed->nc[1] + cc[1]) * ed->nc[0] + cc[0];
#endif
}

/* Cell-list link of particle j: in the record in cell mode (a scan reads
 * the record anyway), in a small array of its own with neighbour lists (a
 * list rebuild walks cells without reading records). */
static inline int32_t *FN(link)(const struct ed *ed, int32_t j)
{
	return ed->nl ? &ed->next[j] : &((P_T *)ed->p)[j].next;
}

static void FN(cell_insert)(struct ed *ed, uint32_t i)
{
	int32_t c = FN(cell_index)(ed, ed->ev[i].cc);
	*FN(link)(ed, (int32_t)i) = ed->head[c];
	ed->head[c] = (int32_t)i;
	ed->occ[c >> 6] |= (uint64_t)1 << (c & 63);
}

static void FN(cell_remove)(struct ed *ed, uint32_t i)
{
	int32_t c = FN(cell_index)(ed, ed->ev[i].cc), *link = &ed->head[c];
	while (*link != (int32_t)i)
		link = FN(link)(ed, *link);
	*link = *FN(link)(ed, (int32_t)i);
	if (ed->head[c] < 0)
		ed->occ[c >> 6] &= ~((uint64_t)1 << (c & 63));
}

/* Time at which particle i (synchronised at time t) leaves its cell, and
 * through which face. A position a rounding error outside its cell gives a
 * crossing at once (dt clamped to 0), never a negative time. */
static void FN(set_cross)(struct ed *ed, uint32_t i)
{
	const P_T *p = &((P_T *)ed->p)[i];
	ev_t *e = &ed->ev[i];
	/* Written without branches on the velocity signs or on which axis
	 * comes first: those are coin tosses for the branch predictor. An axis
	 * with v = 0 never crosses (dt = INFINITY); ties go to the lower axis. */
	double dts[D];
	int up[D];
	FOR_AXES(a) {
		double v = p->v[a], f[2];
		int s = v > 0.0;
		f[0] = e->cc[a] * ed->cw[a];
		f[1] = (e->cc[a] + 1 == ed->nc[a]) ? ed->L[a] : (e->cc[a] + 1) * ed->cw[a];
		double dt = (f[s] - p->r[a]) / v;
		if (__builtin_expect(v == 0.0, 0))
			dt = INFINITY;
		dts[a] = dt < 0.0 ? 0.0 : dt;
		up[a] = s;
	}
	int k = dts[1] < dts[0];
	if (D == 3)
		k += (dts[D - 1] < dts[k]) * (D - 1 - k);
	double best = dts[k];
	e->t_cross = p->t + best;
	e->cross = best < INFINITY ? 2 * k + up[k] : -1;
}

/* One candidate partner j for particle i (own data ri, vi at time t): if
 * they collide within *horizon (relative to t), shrink it and record j.
 * minimg: some axis needs the minimum image (small grids, or a neighbour
 * list near the box edge). The lower bound dt >= c/(-2b) rejects most
 * candidates without a square root. Always inlined: it is the inner loop
 * of every scan (GCC's -O2 heuristics otherwise may not). */
static inline __attribute__((always_inline)) void
FN(try_pair)(const struct ed *ed, const P_T *pj, int32_t j, const double *ri, const double *vi, double t, int minimg,
             double *horizon, int32_t *found)
{
	double dtj = t - pj->t, dr[D], dv[D], b, r2;
	FOR_AXES(a) {
		dv[a] = vi[a] - pj->v[a];
		double x = ri[a] - (pj->r[a] + pj->v[a] * dtj);
		if (minimg) {
			if (x > ed->halfL[a]) x -= ed->L[a];
			else if (x < -ed->halfL[a]) x += ed->L[a];
		}
		dr[a] = x;
	}
	/* Sums start at the first term (0.0 + x is not x for x = -0.0, so the
	 * compiler would keep an addition of 0.0). */
	b = dr[0] * dv[0];
	_Pragma("GCC unroll 3") for (int a = 1; a < D; a++)
		b += dr[a] * dv[a];
	r2 = dr[0] * dr[0];
	_Pragma("GCC unroll 3") for (int a = 1; a < D; a++)
		r2 += dr[a] * dr[a];
	double c = r2 - ed->sigma2, dt;
	if (__builtin_expect(c <= 0.0, 0)) {
		if (b >= 0.0)
			return;      /* separating (or itself): no collision */
		/* Overlapping by rounding. Clearly approaching: collide now. An
		 * approach at rounding level (|b| <= 1e-10 |dr||dv|, e.g. a pair
		 * just stopped by restitution 0) is a touching pair: colliding it
		 * would loop on zero-time events, since the collision rule's own
		 * arithmetic may see it receding. */
		double v2 = 0.0;
		FOR_AXES(a)
			v2 += dv[a] * dv[a];
		if (b * b <= 1e-20 * v2 * r2)
			return;
		dt = 0.0;
	} else {
		/* One test, rarely passed: separating (b >= 0 makes the right side
		 * <= 0 or NaN), or cannot beat the best (dt >= c/(-2b)). A test of
		 * b alone first would be a coin toss for the branch predictor. */
		if (!(c < *horizon * (-2.0 * b)))
			return;
		double v2 = dv[0] * dv[0];
		_Pragma("GCC unroll 3") for (int a = 1; a < D; a++)
			v2 += dv[a] * dv[a];
		double disc = b * b - v2 * c;
		if (disc <= 0.0)
			return;      /* misses */
		/* Stable root: c / (-b + sqrt(disc)) avoids cancellation. */
		dt = c / (-b + sqrt(disc));
	}
	if (dt < *horizon) {
		*horizon = dt;
		*found = j;
	}
}

/* Small grids (an axis with < 3 cells): one neighbour cell holds several
 * images of a partner, and the image that will meet i need not be the
 * nearest one now (two particles half a box apart approach through one
 * image while receding in the other). Try every image on those axes; the
 * raw difference lies in (-L, L), so shifts of -L, 0, +L cover them all. */
static void FN(try_images)(const struct ed *ed, const P_T *pj, int32_t j, const double *ri,
                           const double *vi, double t, double *horizon, int32_t *found)
{
	int k[3] = {0, 0, 0}, lo[3] = {0, 0, 0}, hi[3] = {0, 0, 0};
	FOR_AXES(a)
		if (ed->nc[a] < 3)
			lo[a] = -1, hi[a] = 1;
	for (k[2] = lo[2]; k[2] <= hi[2]; k[2]++)
		for (k[1] = lo[1]; k[1] <= hi[1]; k[1]++)
			for (k[0] = lo[0]; k[0] <= hi[0]; k[0]++) {
				double rk[D];
				FOR_AXES(a)
					rk[a] = ri[a] + k[a] * ed->L[a];
				FN(try_pair)(ed, pj, j, rk, vi, t, 0, horizon, found);
			}
}

/* Scan the cells at the given per-axis offsets around particle i (at its
 * time) for the earliest collision; keeps the stored one if earlier. Each
 * neighbour cell is one definite periodic image (shift) when every axis has
 * >= 3 cells; otherwise minimum image over all images (try_images). Cell
 * coordinates and shifts are worked out once per axis, and the occupancy
 * bitmap (a few bits per particle: in cache) spares reading the heads of
 * empty cells: most cells of a dilute system are empty, so the walk
 * itself is much of the cost. */
static inline __attribute__((always_inline)) void
FN(scan_impl)(struct ed *ed, uint32_t i, const int *const offs[3], const int no[3], int use_occ)
{
	const P_T *restrict P = ed->p;
	ev_t *e = &ed->ev[i];
	const int minimg = ed->minimg;
	const int32_t *restrict head = ed->head;
	const uint64_t *restrict occ = ed->occ;
	int32_t cell[3][3] = {{0}};   /* per axis: contribution to the cell index */
	double sh[3][3] = {{0.0}};    /* per axis: periodic shift */
	int32_t stride = 1;
	for (int a = 0; a < D; a++) {
		const int32_t n = ed->nc[a];
		for (int k = 0; k < no[a]; k++) {
			int32_t c = e->cc[a] + offs[a][k];
			double s = 0.0;
			if (c < 0) c += n, s = -ed->L[a];
			else if (c >= n) c -= n, s = ed->L[a];
			if (n < 3)
				s = 0.0;          /* small axis: try_images covers the images */
			cell[a][k] = c * stride;
			sh[a][k] = s;
		}
		stride *= n;
	}
	/* Own data in locals: nothing in the loop can alias them. */
	const double t = P[i].t;
	double r0[D], vi[D];
	FOR_AXES(a) {
		r0[a] = P[i].r[a];
		vi[a] = P[i].v[a];
	}
	double horizon = e->t_coll - t;
	int32_t found = -1;
	/* First the non-empty cells, with their first particles' records
	 * requested at once (in a large system each is a cache miss, and the
	 * tests below would let only one or two be under way at a time); then
	 * the candidates, in the same cell order. */
	struct { int32_t j; uint8_t k[3]; } occd[27];
	int m = 0;
	const int nz = D == 3 ? no[2] : 1;
	for (int kz = 0; kz < nz; kz++)
		for (int ky = 0; ky < no[1]; ky++) {
			const int32_t row = cell[2][kz] + cell[1][ky];
			for (int kx = 0; kx < no[0]; kx++) {
				const int32_t c = row + cell[0][kx];
				if (use_occ && !((occ[c >> 6] >> (c & 63)) & 1))
					continue;     /* empty: its head need not be read */
				int32_t j = head[c];
				__builtin_prefetch(&P[j]);
				occd[m].j = j;
				occd[m].k[0] = (uint8_t)kx, occd[m].k[1] = (uint8_t)ky, occd[m].k[2] = (uint8_t)kz;
				m += j >= 0;
			}
		}
	for (int q = 0; q < m; q++) {
		double ri[D];
		FOR_AXES(a)
			ri[a] = r0[a] - sh[a][occd[q].k[a]];
		for (int32_t j = occd[q].j; j >= 0; j = P[j].next) {   /* cell mode: links in the records */
			if ((uint32_t)j == i)
				continue;
			if (minimg)
				FN(try_images)(ed, &P[j], j, ri, vi, t, &horizon, &found);
			else
				FN(try_pair)(ed, &P[j], j, ri, vi, t, 0, &horizon, &found);
		}
	}
	/* Only a partner found by this scan gets its counter recorded: a kept
	 * (possibly stale) prediction must keep the counter it was made with,
	 * or a cancelled collision would be taken for a valid one. */
	if (found >= 0) {
		e->t_coll = t + horizon;
		e->partner = found;
		e->pcount = P[found].count;
	}
}

/* The bitmap pays where the heads do not stay in cache (measured: a loss
 * of ~8% at 5e4 cells, a gain at 5e5). */
static void FN(scan)(struct ed *ed, uint32_t i, const int *const offs[3], const int no[3])
{
	if (ed->ncells > OCC_MIN_CELLS)
		FN(scan_impl)(ed, i, offs, no, 1);
	else
		FN(scan_impl)(ed, i, offs, no, 0);
}

static void FN(scan_full)(struct ed *ed, uint32_t i)
{
	ed->ev[i].t_coll = INFINITY;
	ed->ev[i].partner = -1;
	const int *offs[3] = {ed->off[0], ed->off[1], ed->off[2]};
	FN(scan)(ed, i, offs, ed->no);
}

static inline void FN(schedule)(struct ed *ed, uint32_t i)
{
	const ev_t *e = &ed->ev[i];
	cal_update(ed, i, e->t_coll <= e->t_cross ? e->t_coll : e->t_cross);
}

/* Neighbour-list mode. Rebuild time of particle i (at its time): when it
 * has drifted nl_d from its build position. */
static void FN(set_nl)(struct ed *ed, uint32_t i)
{
	const P_T *p = &((P_T *)ed->p)[i];
	const double *x = ed->xn + (size_t)i * D;
	double b = 0.0, c = -ed->nl_d2, v2 = 0.0, dt;
	FOR_AXES(a) {
		double d = p->r[a] - x[a];
		b += d * p->v[a];
		c += d * d;
		v2 += p->v[a] * p->v[a];
	}
	if (v2 == 0.0)
		dt = INFINITY;
	else if (c >= 0.0)
		dt = 0.0;     /* at the limit by rounding: rebuild now */
	else {
		/* larger root, no cancellation: (q - b) / v2 for b <= 0, else
		 * -c / (b + q); picked by index, not by a branch on the sign of b */
		double q = sqrt(b * b - v2 * c);
		const double num[2] = {q - b, -c}, den[2] = {v2, b + q};
		const int k = b > 0.0;
		dt = num[k] / den[k];
	}
	ed->ev[i].t_cross = p->t + dt;
}

/* Earliest collision of particle i (at its time) with a listed neighbour
 * before its rebuild: later ones are found by the rebuild's own scan. A
 * particle whose build cell is inside the grid needs no minimum image: its
 * neighbours' build positions are the direct images (cells >= nl_r). */
static void FN(scan_nl)(struct ed *ed, uint32_t i)
{
	const P_T *restrict P = ed->p;
	ev_t *e = &ed->ev[i];
	const int32_t *restrict nb = ed->nb + (size_t)i * ed->nlk;
	const int m = ed->nn[i];
	double ri[D], vi[D];
	const double t = P[i].t;
	int edge = 0;
	FOR_AXES(a) {
		ri[a] = P[i].r[a];
		vi[a] = P[i].v[a];
		edge |= e->cc[a] == 0 || e->cc[a] == ed->nc[a] - 1;
	}
	/* The neighbours' records are the scan's cache misses: ask for all of
	 * them at once rather than one per candidate behind unpredictable
	 * branches. */
	for (int k = 0; k < m; k++)
		__builtin_prefetch(&P[nb[k]]);
	double horizon = e->t_cross - t;
	int32_t found = -1;
	if (edge)
		for (int k = 0; k < m; k++)
			FN(try_pair)(ed, &P[nb[k]], nb[k], ri, vi, t, 1, &horizon, &found);
	else
		for (int k = 0; k < m; k++)
			FN(try_pair)(ed, &P[nb[k]], nb[k], ri, vi, t, 0, &horizon, &found);
	e->partner = found;
	if (found >= 0) {
		e->t_coll = t + horizon;
		e->pcount = P[found].count;
	} else {
		e->t_coll = INFINITY;
	}
}

/* Fill i's list (empty on entry) with every particle of the surrounding
 * cells whose build position is within nl_r of i's; a full list sets
 * nl_over. First the cells' first build positions are requested at once
 * (large systems wait on memory here), then the cells are walked in order. */
static void FN(nl_gather)(struct ed *ed, uint32_t i)
{
	const ev_t *e = &ed->ev[i];
	const uint32_t K = ed->nlk;
	int32_t *li = ed->nb + (size_t)i * K;
	const double *xi = ed->xn + (size_t)i * D;
	const double r2max = ed->nl_r2;
	int32_t cell[3][3] = {{0}}, stride = 1;
	double sh[3][3] = {{0.0}};
	for (int a = 0; a < D; a++) {
		for (int k = 0; k < 3; k++) {
			int32_t c = e->cc[a] + k - 1;
			double s = 0.0;
			if (c < 0) c += ed->nc[a], s = -ed->L[a];
			else if (c >= ed->nc[a]) c -= ed->nc[a], s = ed->L[a];
			cell[a][k] = c * stride;
			sh[a][k] = s;
		}
		stride *= ed->nc[a];
	}
	int32_t hd[27];
	int m = 0;
	const int nz = D == 3 ? 3 : 1;
	for (int kz = 0; kz < nz; kz++)
		for (int ky = 0; ky < 3; ky++)
			for (int kx = 0; kx < 3; kx++, m++) {
				hd[m] = ed->head[cell[2][kz] + cell[1][ky] + cell[0][kx]];
				__builtin_prefetch(ed->xn + (size_t)hd[m] * D);
			}
	m = 0;
	int n = ed->nn[i];
	for (int kz = 0; kz < nz; kz++)
		for (int ky = 0; ky < 3; ky++)
			for (int kx = 0; kx < 3; kx++, m++) {
				double xs[D];
				xs[0] = xi[0] - sh[0][kx];
				xs[1] = xi[1] - sh[1][ky];
				if (D == 3)
					xs[D - 1] = xi[D - 1] - sh[D - 1][kz];
				for (int32_t j = hd[m]; j >= 0; j = ed->next[j]) {   /* lists mode: links apart */
					const double *xj = ed->xn + (size_t)j * D;
					double x = xs[0] - xj[0], r2 = x * x;
					_Pragma("GCC unroll 3") for (int a = 1; a < D; a++) {
						x = xs[a] - xj[a];
						r2 += x * x;
					}
					if (r2 >= r2max || (uint32_t)j == i)
						continue;
					if ((uint32_t)n >= K) {
						ed->nl_over = 1;
						continue;
					}
					li[n++] = j;
				}
			}
	ed->nn[i] = (uint8_t)n;
}

/* Put particle i (in the box) into the cell of its position. */
static void FN(place)(struct ed *ed, uint32_t i);

/* Rebuild event of particle i at time t: new build position (wrapped into
 * the box), new cell, new list, new prediction. The lists stay symmetric:
 * most neighbours stay on the list (i drifted a fraction of the shell), and
 * only the lists of those that left or joined are edited (each one a
 * cache miss in a large system). */
static void FN(nl_rebuild)(struct ed *ed, uint32_t i, double t)
{
	P_T *p = &((P_T *)ed->p)[i];
	const uint32_t K = ed->nlk;
	int32_t *li = ed->nb + (size_t)i * K, old[NL_KMAX];
	uint8_t *mark = ed->mark;
	const int m_old = ed->nn[i];
	memcpy(old, li, (size_t)m_old * sizeof(int32_t));
	FN(advance)(p, t);
	FN(cell_remove)(ed, i);
	FOR_AXES(a) {
		if (p->r[a] < 0.0) p->r[a] += ed->L[a];
		else if (p->r[a] >= ed->L[a]) p->r[a] -= ed->L[a];
		ed->xn[(size_t)i * D + a] = p->r[a];
	}
	FN(place)(ed, i);
	ed->nn[i] = 0;
	FN(nl_gather)(ed, i);
	for (int k = 0; k < m_old; k++)
		mark[old[k]] = 1;
	for (int k = 0; k < ed->nn[i]; k++) {
		uint32_t j = (uint32_t)li[k];
		if (mark[j]) {
			mark[j] = 2;          /* stays: its list keeps i */
		} else if (ed->nn[j] >= K) {
			ed->nl_over = 1;
		} else {
			ed->nb[(size_t)j * K + ed->nn[j]++] = (int32_t)i;
		}
	}
	for (int k = 0; k < m_old; k++) {
		uint32_t j = (uint32_t)old[k];
		if (mark[j] == 1) {       /* left: i off its list */
			int32_t *lj = ed->nb + (size_t)j * K;
			int q = 0, last = ed->nn[j] - 1;
			while (lj[q] != (int32_t)i)
				q++;
			lj[q] = lj[last];
			ed->nn[j] = (uint8_t)last;
		}
		mark[j] = 0;
	}
	if (ed->nl_over) {
		nl_abandon(ed);
		return;
	}
	FN(set_nl)(ed, i);
	FN(scan_nl)(ed, i);
	FN(schedule)(ed, i);
}

/* All lists from scratch (particles in their cells, synchronised). */
static void FN(nl_build_all)(struct ed *ed)
{
	const P_T *P = ed->p;
	for (uint32_t i = 0; i < ed->n; i++) {
		FOR_AXES(a)
			ed->xn[(size_t)i * D + a] = P[i].r[a];
		ed->nn[i] = 0;
	}
	/* each pair is met from both sides: one-sided adds give symmetric lists */
	for (uint32_t i = 0; i < ed->n; i++)
		FN(nl_gather)(ed, i);
}

/* A particle crosses a cell face: new cell, wrap at the box edge, then only
 * the newly adjacent layer of cells needs scanning (the stored collision,
 * even if stale, stays: a stale one is detected when it is popped). */
static void FN(do_cross)(struct ed *ed, uint32_t i, double t)
{
	P_T *p = &((P_T *)ed->p)[i];
	ev_t *e = &ed->ev[i];
	int a = e->cross >> 1, dir = (e->cross & 1) ? 1 : -1;

	FN(advance)(p, t);
	FN(cell_remove)(ed, i);
	e->cc[a] += dir;
	if (e->cc[a] >= ed->nc[a]) {
		e->cc[a] = 0;
		p->r[a] -= ed->L[a];
	} else if (e->cc[a] < 0) {
		e->cc[a] = ed->nc[a] - 1;
		p->r[a] += ed->L[a];
	}
	FN(cell_insert)(ed, i);
	FN(set_cross)(ed, i);
	if (ed->nc[a] >= 3) {
		const int *offs[3] = {ed->off[0], ed->off[1], ed->off[2]};
		int no[3] = {ed->no[0], ed->no[1], ed->no[2]};
		offs[a] = &ed->off[a][dir > 0 ? 2 : 0];
		no[a] = 1;
		FN(scan)(ed, i, offs, no);
	} else {
		FN(scan_full)(ed, i);
	}
	FN(schedule)(ed, i);
}

/* Binary collision of i and j at time t with normal restitution (elastic
 * within the TC time of either partner's previous collision). */
static void FN(collide)(struct ed *ed, uint32_t i, uint32_t j, double t)
{
	P_T *P = ed->p, *pi = &P[i], *pj = &P[j];
	FN(advance)(pi, t);
	FN(advance)(pj, t);
	double dr[D], dv[D], b = 0.0, r2 = 0.0;
	FOR_AXES(a) {
		double x = pi->r[a] - pj->r[a];
		if (x > ed->halfL[a]) x -= ed->L[a];
		else if (x < -ed->halfL[a]) x += ed->L[a];
		dr[a] = x;
		dv[a] = pi->v[a] - pj->v[a];
		b += x * dv[a];
		r2 += x * x;
	}
	ed->ekin_int += ed->ekin_cur * (t - ed->t_mark);
	ed->t_mark = t;
	if (b < 0.0) {
		double e = ed->e;
		if (ed->tlast) {
			if (t - ed->tlast[i] < ed->tc || t - ed->tlast[j] < ed->tc) {
				e = 1.0;
				ed->tc_elastic++;
			}
			ed->tlast[i] = ed->tlast[j] = t;
		}
		double f = 0.5 * (1.0 + e) * b / r2;
		FOR_AXES(a) {
			pi->v[a] -= f * dr[a];
			pj->v[a] += f * dr[a];
		}
		ed->virial -= 0.5 * (1.0 + e) * ed->mass * b;
		if (e != 1.0)
			ed->ekin_cur -= 0.25 * (1.0 - e * e) * ed->mass * b * b / r2;
	}
	/* A grazing pair that rounding made non-approaching is left alone, but
	 * still counts as an event of both so that stale predictions go away. */
	pi->count++;
	pj->count++;
	ed->collisions++;
}

static void FN(step)(struct ed *ed)
{
	uint32_t i = ed->heap[0].i;
	double t = ed->heap[0].t;
	P_T *P = ed->p;
	ev_t *e = &ed->ev[i];

	/* The probable next event (the earlier child of the heap's top): its
	 * particle's records are requested now, to arrive while this event is
	 * processed (large systems wait on memory at every event's start). */
	if (ed->hn > 1) {
		uint32_t k = ed->hn > 2 && hless(&ed->heap[2], &ed->heap[1]) ? ed->heap[2].i : ed->heap[1].i;
		__builtin_prefetch(&P[k]);
		__builtin_prefetch(&ed->ev[k]);
		if (ed->nl) {
			__builtin_prefetch(ed->nb + (size_t)k * ed->nlk);
			__builtin_prefetch(ed->xn + (size_t)k * D);
		}
	}
	cal_prefetch(ed);
	if (ed->nl && e->t_coll <= e->t_cross) {
		/* a collision (or a cancelled one): the partner's list is next */
		const uint32_t j = (uint32_t)e->partner;
		__builtin_prefetch(ed->nb + (size_t)j * ed->nlk);
		__builtin_prefetch(ed->xn + (size_t)j * D);
		__builtin_prefetch(&ed->cn[j]);
	}
	ed->t = t;
	ed->t_abs_valid = 0;
	ed->events++;
	if (e->t_cross < e->t_coll) {
		if (ed->nl)
			FN(nl_rebuild)(ed, i, t);
		else
			FN(do_cross)(ed, i, t);
		return;
	}
	uint32_t j = (uint32_t)e->partner;
	FN(advance)(&P[i], t);
	if (P[j].count != e->pcount) {
		/* Cancelled: the partner changed course. Free flight, then rescan. */
		if (ed->nl)
			FN(scan_nl)(ed, i);
		else
			FN(scan_full)(ed, i);
		FN(schedule)(ed, i);
		return;
	}
	FN(collide)(ed, i, j, t);
	if (ed->nl) {
		FN(set_nl)(ed, i);
		FN(scan_nl)(ed, i);
		FN(schedule)(ed, i);
		FN(set_nl)(ed, j);
		FN(scan_nl)(ed, j);
		FN(schedule)(ed, j);
		return;
	}
	FN(set_cross)(ed, i);
	FN(scan_full)(ed, i);
	FN(schedule)(ed, i);
	FN(set_cross)(ed, j);
	FN(scan_full)(ed, j);
	FN(schedule)(ed, j);
}

/* Renumber particles in cell order (counting sort, stable) so that the
 * particles of neighbouring cells lie close in memory: a neighbour scan then
 * reads a few contiguous runs instead of random cache lines. Deterministic;
 * ed->id keeps each particle's scene index for output. In place: no second
 * copy of the per-particle arrays. */
static void FN(reorder)(struct ed *ed)
{
	const uint32_t n = ed->n;
	uint32_t *newidx = ed->scratch_idx, *start = ed->scratch_cell;
	memset(start, 0, (ed->ncells + 1) * sizeof(uint32_t));
	for (uint32_t i = 0; i < n; i++)
		start[FN(cell_index)(ed, ed->ev[i].cc) + 1]++;
	for (size_t c = 0; c < ed->ncells; c++)
		start[c + 1] += start[c];
	for (uint32_t i = 0; i < n; i++)
		newidx[i] = start[FN(cell_index)(ed, ed->ev[i].cc)]++;
	for (uint32_t i = 0; i < n; i++)
		if (ed->ev[i].partner >= 0)
			ed->ev[i].partner = (int32_t)newidx[ed->ev[i].partner];
	permute(ed->p, sizeof(P_T), newidx, n);
	permute(ed->ev, sizeof(ev_t), newidx, n);
	permute(ed->id, sizeof(uint32_t), newidx, n);
	if (ed->tlast)
		permute(ed->tlast, sizeof(double), newidx, n);
	if (ed->nl) {
		const uint32_t K = ed->nlk;
		for (uint32_t i = 0; i < n; i++)
			for (int k = 0; k < ed->nn[i]; k++)
				ed->nb[(size_t)i * K + k] = (int32_t)newidx[ed->nb[(size_t)i * K + k]];
		permute(ed->nb, K * sizeof(int32_t), newidx, n);
		permute(ed->nn, 1, newidx, n);
		permute(ed->xn, D * sizeof(double), newidx, n);
	}
	cells_clear(ed);
	for (uint32_t k = n; k-- > 0;)
		FN(cell_insert)(ed, k);
}

/* Bring every particle to the current time and move the time origin there,
 * so that times stay small numbers (no lost digits in t - t_j however long
 * the run). Called after a fixed number of events: part of the dynamics,
 * identical in every run of the same scene. */
static void FN(rebase)(struct ed *ed)
{
	P_T *P = ed->p;
	double t = ed->t;
	for (uint32_t i = 0; i < ed->n; i++) {
		FN(advance)(&P[i], t);
		P[i].t = 0.0;
		ed->ev[i].t_coll -= t;
		ed->ev[i].t_cross -= t;
		if (ed->tlast)
			ed->tlast[i] -= t;
	}
	FN(reorder)(ed);
	cal_build(ed);
	ed->t_mark -= t;
	ed->t_int0 -= t;
	epoch_add(ed, t);
	ed->t = 0.0;
}

static int FN(run)(struct ed *ed, double t_stop, uint64_t max_coll, uint64_t max_events)
{
	uint64_t ev_end = ed->events + max_events < ed->events ? UINT64_MAX : ed->events + max_events;
	double local_stop = t_stop - ed->epoch;
	while (ed->collisions < max_coll && ed->events < ev_end) {
		double tn = cal_next_time(ed);
		if (tn == INFINITY)
			goto quiescent;
		if (tn > local_stop) {
			ed->t = local_stop;
			ed->t_abs = t_stop;
			ed->t_abs_valid = 1;
			return ED_OK;
		}
		FN(step)(ed);
		if (++ed->since_rebase >= ed->rebase_every) {
			double dt = ed->t;   /* the last rebase_every events took this long */
			ed->since_rebase = 0;
			FN(rebase)(ed);
			local_stop = t_stop - ed->epoch;
			if (collapse_check(ed, dt))
				return ED_COLLAPSE;
		}
	}
	return ED_OK;
quiescent:
	if (isfinite(t_stop)) {
		ed->t = local_stop;
		ed->t_abs = t_stop;
		ed->t_abs_valid = 1;
	}
	return ED_QUIESCENT;
}

static void FN(state)(const struct ed *ed, double *pos, double *vel)
{
	const P_T *P = ed->p;
	for (uint32_t i = 0; i < ed->n; i++) {
		FOR_AXES(a) {
			if (pos) {
				double x = P[i].r[a] + P[i].v[a] * (ed->t - P[i].t);
				x = fmod(x, ed->L[a]);
				if (x < 0.0)
					x += ed->L[a];
				if (x >= ed->L[a])
					x = 0.0;
				pos[(size_t)ed->id[i] * D + a] = x;
			}
			if (vel)
				vel[(size_t)ed->id[i] * D + a] = P[i].v[a];
		}
	}
}

static double FN(ekin)(const struct ed *ed, double mom[3])
{
	const P_T *P = ed->p;
	double s = 0.0;
	mom[0] = mom[1] = mom[2] = 0.0;
	for (uint32_t i = 0; i < ed->n; i++)
		FOR_AXES(a) {
			s += P[i].v[a] * P[i].v[a];
			mom[a] += P[i].v[a];
		}
	FOR_AXES(a)
		mom[a] *= ed->mass;
	return 0.5 * ed->mass * s;
}

/* Smallest surface gap over all neighbouring pairs at the current time. */
static double FN(min_gap)(const struct ed *ed)
{
	const P_T *P = ed->p;
	double best = INFINITY;
	for (uint32_t i = 0; i < ed->n; i++) {
		const ev_t *e = &ed->ev[i];
		int32_t cc[3] = {0, 0, 0};
		double ri[D];
		FOR_AXES(a)
			ri[a] = P[i].r[a] + P[i].v[a] * (ed->t - P[i].t);
#if D == 3
		for (int kz = 0; kz < ed->no[2]; kz++) {
			cc[2] = (e->cc[2] + ed->off[2][kz] + ed->nc[2]) % ed->nc[2];
#endif
		for (int ky = 0; ky < ed->no[1]; ky++) {
			cc[1] = (e->cc[1] + ed->off[1][ky] + ed->nc[1]) % ed->nc[1];
			for (int kx = 0; kx < ed->no[0]; kx++) {
				cc[0] = (e->cc[0] + ed->off[0][kx] + ed->nc[0]) % ed->nc[0];
				for (int32_t j = ed->head[FN(cell_index)(ed, cc)]; j >= 0; j = *FN(link)(ed, j)) {
					if ((uint32_t)j <= i)
						continue;
					double r2 = 0.0;
					FOR_AXES(a) {
						double x = ri[a] - (P[j].r[a] + P[j].v[a] * (ed->t - P[j].t));
						x -= ed->L[a] * nearbyint(x / ed->L[a]);
						r2 += x * x;
					}
					double g = sqrt(r2) - ed->sigma;
					if (g < best)
						best = g;
				}
			}
		}
#if D == 3
		}
#endif
	}
	return best;
}

/* All particles to the present time, wrapped into the box, and filed in
 * the cells of their positions. */
static void FN(resync)(struct ed *ed)
{
	P_T *P = ed->p;
	cells_clear(ed);
	for (uint32_t i = 0; i < ed->n; i++) {
		FN(advance)(&P[i], ed->t);
		FOR_AXES(a) {
			if (P[i].r[a] < 0.0) P[i].r[a] += ed->L[a];
			else if (P[i].r[a] >= ed->L[a]) P[i].r[a] -= ed->L[a];
		}
	}
	for (uint32_t i = ed->n; i-- > 0;)
		FN(place)(ed, i);
}

/* Put particle i (position already set in P) into its cell; cell from the
 * position, clamped against rounding at the top edge. */
static void FN(place)(struct ed *ed, uint32_t i)
{
	P_T *p = &((P_T *)ed->p)[i];
	FOR_AXES(a) {
		int32_t c = (int32_t)floor(p->r[a] / ed->cw[a]);
		if (c < 0) c = 0;
		if (c >= ed->nc[a]) c = ed->nc[a] - 1;
		ed->ev[i].cc[a] = c;
	}
	FN(cell_insert)(ed, i);
}

/* Random sequential addition: candidate positions uniform in the box,
 * rejected when they overlap an already placed particle (checked through
 * the cell list). Jams near volume fraction 0.547 (2D) / 0.38 (3D). */
static int FN(place_random)(struct ed *ed, rng_t *rng)
{
	P_T *P = ed->p;
	uint64_t tries = 0, max_tries = 1000 + 2000ull * ed->n;
	for (uint32_t i = 0; i < ed->n; i++) {
		for (;;) {
			if (++tries > max_tries)
				return ED_EPLACE;
			FOR_AXES(a)
				P[i].r[a] = rng_uniform(rng) * ed->L[a];
			P[i].t = 0.0;
			int32_t cc[3] = {0, 0, 0}, base[3] = {0, 0, 0};
			FOR_AXES(a) {
				base[a] = (int32_t)floor(P[i].r[a] / ed->cw[a]);
				if (base[a] >= ed->nc[a]) base[a] = ed->nc[a] - 1;
			}
			int clash = 0;
#if D == 3
			for (int kz = 0; kz < ed->no[2] && !clash; kz++) {
				cc[2] = (base[2] + ed->off[2][kz] + ed->nc[2]) % ed->nc[2];
#endif
			for (int ky = 0; ky < ed->no[1] && !clash; ky++) {
				cc[1] = (base[1] + ed->off[1][ky] + ed->nc[1]) % ed->nc[1];
				for (int kx = 0; kx < ed->no[0] && !clash; kx++) {
					cc[0] = (base[0] + ed->off[0][kx] + ed->nc[0]) % ed->nc[0];
					for (int32_t j = ed->head[FN(cell_index)(ed, cc)]; j >= 0; j = *FN(link)(ed, j)) {
						double r2 = 0.0;
						FOR_AXES(a) {
							double x = P[i].r[a] - P[j].r[a];
							x -= ed->L[a] * nearbyint(x / ed->L[a]);
							r2 += x * x;
						}
						if (r2 < ed->sigma2) {
							clash = 1;
							break;
						}
					}
				}
			}
#if D == 3
			}
#endif
			if (!clash)
				break;
		}
		FN(place)(ed, i);
	}
	return ED_OK;
}
