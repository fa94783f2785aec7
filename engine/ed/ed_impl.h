/* Dimension-specific event-driven kernels; included by ed.c once per dimension with D and FN() defined. */

/*
 * Expects: D (2 or 3), P_T (particle record type with r[D], v[D], t, next,
 * count), FN(name) (name mangling), and the variant flags WALLS (some axes
 * may have walls: no wrap there, wall events, cell mode only) and GRAV
 * (uniform gravity ed->g: ballistic flight; implies WALLS), plus the shared
 * declarations of ed.c. WALLS = GRAV = 0 is the periodic homogeneous engine;
 * the flags are compile-time, so it tests none of this per event. ROUGH
 * (rough particles: spins in ed->spin, the rough collision rule) is a
 * further flag on top of any of them. SPEC (mixtures: contact distance
 * from the particles' radii ed->prad, restitution and masses from the pair
 * tables by ed->spc; any variant, smooth or ROUGH) replaces ed->sigma2, ed->e
 * and ed->mass in predictions, collisions and energies; without it they are
 * the one species' constants. FILTG (with GRAV, one species or SPEC:
 * filters under gravity) lets frozen particles (ed->frozen) fly straight at their filter's
 * velocity while the others fall: their flights, boundary times and energy
 * skip g, and a pair of a frozen and a regular particle is predicted as a
 * particle meeting a moving obstacle under gravity (obstacle_time_grav in
 * the frozen one's frame). Without it none of this is compiled.
 */
#if FILTG && !GRAV
#error "FILTG is for the gravity variants"
#endif

/* Whether particle i flies straight under gravity (frozen by a filter):
 * constant 0 without FILTG, so the tests below fold away. */
static inline int FN(fz)(const struct ed *ed, uint32_t i)
{
#if FILTG
	return ed->frozen[i] != 0;
#else
	(void)ed;
	(void)i;
	return 0;
#endif
}

/* Flight of particle p to time t (lazy: only when the particle is touched). */
static inline void FN(advance)(const struct ed *ed, P_T *p, double t)
{
	double dt = t - p->t;
#if GRAV
	if (FN(fz)(ed, (uint32_t)(p - (const P_T *)ed->p))) {   /* frozen (FILTG): straight */
		FOR_AXES(a)
			p->r[a] += p->v[a] * dt;
		p->t = t;
		return;
	}
	const double hdt = 0.5 * dt * dt;
	FOR_AXES(a) {
		p->r[a] += p->v[a] * dt + ed->g[a] * hdt;
		p->v[a] += ed->g[a] * dt;
	}
#else
	(void)ed;
	FOR_AXES(a)
		p->r[a] += p->v[a] * dt;
#endif
	p->t = t;
}

/* Particle i was wrapped by dir box edges on axis a: count it where images are followed (ed->img; only
 * at a wrap, not per event). */
static inline void FN(image)(const struct ed *ed, uint32_t i, int a, int dir)
{
	if (ed->img)
		ed->img[(size_t)ed->id[i] * D + a] += dir;
}

/* Radius and mass of particle i: its own with species (SPEC), else the
 * one species' (compile-time: no test per event). */
static inline double FN(rad)(const struct ed *ed, uint32_t i)
{
#if SPEC
	return ed->prad[i];
#else
	(void)i;
	return ed->radius;
#endif
}

static inline double FN(mass)(const struct ed *ed, uint32_t i)
{
#if SPEC
	return ed->mix->m[ed->spc[i]];
#else
	(void)i;
	return ed->mass;
#endif
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

#if !WALLS
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
#else
/* Time from now (particle i synchronised) to its contact with wall w, no
 * later than horizon (INFINITY if none before). Fixed walls: a quadratic
 * (linear without gravity); vibrating ones: walltime_vibrating(). */
static inline double FN(wall_time)(const struct ed *ed, const P_T *p, double rad, int w, double horizon)
{
	const wall_t *W = &ed->wall[w];
	const int a = w >> 1;
	const double s = (w & 1) ? -1.0 : 1.0;
	const double gam = GRAV && !FN(fz)(ed, (uint32_t)(p - (const P_T *)ed->p)) ? s * ed->g[a] : 0.0;
	double d = s * (p->r[a] - W->rest) - rad;
	if (W->A == 0.0)   /* a dispenser's piston moves at pu (0 for every other wall: the same numbers) */
		return walltime_plane(d - W->pu * (p->t - W->pt0), s * p->v[a] - W->pu, gam);
	const double th = W->ph + W->omega * p->t;
	d -= W->A * sin(th);
	if (!(horizon < INFINITY))
		horizon = 6.28318530717958647692 / W->omega;   /* only at rest along the axis: one period decides */
	return walltime_vibrating(d, s * p->v[a], gam, W->A, W->omega, th, horizon);
}

/* Particle p (synchronised) relative to obstacle k's centre: the minimum
 * image on periodic axes (one image is within reach: scene.c). */
static inline void FN(obst_rel)(const struct ed *ed, const P_T *p, int k, double *x)
{
	FOR_AXES(a) {
		double d = p->r[a] - ed->obst[k].c[a];
		if (ed->periodic[a])
			d -= ed->L[a] * nearbyint(d / ed->L[a]);
		x[a] = d;
	}
}

/* Time from now to particle p's contact with obstacle k, no later than
 * horizon with gravity (obstacle.h). */
static inline double FN(obst_time)(const struct ed *ed, const P_T *p, double S, int k, double horizon)
{
	double x[D];
	FN(obst_rel)(ed, p, k, x);
#if GRAV
	if (FN(fz)(ed, (uint32_t)(p - (const P_T *)ed->p)))
		return obstacle_time_free(x, p->v, D, S);
	return obstacle_time_grav(x, p->v, ed->g, D, S, horizon);
#else
	(void)horizon;
	return obstacle_time_free(x, p->v, D, S);
#endif
}

/* Contact distance of particle i from obstacle k's centre: the obstacle's
 * radius plus the particle's (S holds it for the largest radius). */
static inline double FN(obst_S)(const struct ed *ed, uint32_t i, int k)
{
#if SPEC
	return ed->obst[k].S - ed->radius + ed->prad[i];
#else
	(void)i;
	return ed->obst[k].S;
#endif
}

/* The particle's next boundary event: leaving its cell through a face
 * (walled axes have no face at their ends), or meeting a wall (particles
 * in the cells a wall can reach). With gravity each face is a quadratic
 * (walltime_plane: robust for grazing and resting particles). Code in
 * e->cross: 2 axis + (upper face), or ED_WALL0 + wall. */
static void FN(set_cross)(struct ed *ed, uint32_t i)
{
	const P_T *p = &((P_T *)ed->p)[i];
	ev_t *e = &ed->ev[i];
	double best = INFINITY;
	int code = -1;
	FOR_AXES(a) {
		const double x = p->r[a], v = p->v[a], g = GRAV && !FN(fz)(ed, i) ? ed->g[a] : 0.0;
		const int32_t c = e->cc[a], n = ed->nc[a];
		if (c > 0 || ed->periodic[a]) {
			double dt = walltime_plane(x - c * ed->cw[a], v, g);
			if (dt < best)
				best = dt, code = 2 * a;
		}
		if (c < n - 1 || ed->periodic[a]) {
			double f1 = c + 1 == n ? ed->L[a] : (c + 1) * ed->cw[a];
			double dt = walltime_plane(f1 - x, -v, -g);
			if (dt < best)
				best = dt, code = 2 * a + 1;
		}
	}
	FOR_AXES(a) {
		if (ed->periodic[a])
			continue;
		if (e->cc[a] < ed->nzone[2 * a]) {
			double dt = FN(wall_time)(ed, p, FN(rad)(ed, i), 2 * a, best);
			if (dt < best)
				best = dt, code = ED_WALL0 + 2 * a;
		}
		if (e->cc[a] >= ed->nc[a] - ed->nzone[2 * a + 1]) {
			double dt = FN(wall_time)(ed, p, FN(rad)(ed, i), 2 * a + 1, best);
			if (dt < best)
				best = dt, code = ED_WALL0 + 2 * a + 1;
		}
	}
	if (ed->ocell) {   /* NULL without obstacles */
		for (unsigned m = ed->ocell[FN(cell_index)(ed, e->cc)]; m; m &= m - 1) {
			const int k = __builtin_ctz(m);
			double dt = FN(obst_time)(ed, p, FN(obst_S)(ed, i, k), k, best);
			if (dt < best)
				best = dt, code = ED_OBST0 + k;
		}
	}
	if (ed->filt_on && !ed->frozen[i]) {   /* filters: a regular particle crossing a plane outwards */
		for (int w = 0; w < 6; w++) {
			if (!ed->fcell[w])
				continue;
			const int a = w >> 1;
			const double s = (w & 1) ? -1.0 : 1.0;
			if (s * (e->cc[a] - (ed->fcell[w] - 1)) > 0.0)
				continue;   /* not in a cell of the plane or beyond it */
			double dt = walltime_plane(s * (p->r[a] - ed->fplane[w]), s * p->v[a], GRAV ? s * ed->g[a] : 0.0);
			if (dt < best)
				best = dt, code = ED_FILT0 + w;
		}
	}
	e->t_cross = p->t + best;
	e->cross = best < INFINITY ? code : -1;
}
#endif

/* One candidate partner j for particle i (own data ri, vi at time t): if
 * they collide within *horizon (relative to t), shrink it and record j.
 * minimg: some axis needs the minimum image (small grids, or a neighbour
 * list near the box edge). The lower bound dt >= c/(-2b) rejects most
 * candidates without a square root. Always inlined: it is the inner loop
 * of every scan (GCC's -O2 heuristics otherwise may not). */
#if FILTG
/* try_pair() for a pair with a frozen particle (fz_i: i is): both frozen
 * never meet (one velocity per filter, and collide_frozen() leaves such a
 * pair alone); a regular one meets the frozen one as a particle meets an
 * obstacle moving straight at the filter's velocity, the relative motion
 * under gravity a quartic (obstacle_time_grav: bracketed roots on convex
 * and concave pieces, no contact missed or given twice). */
static void FN(try_frozen)(const struct ed *ed, const P_T *pj, int32_t j, const double *ri, const double *vi, double t,
                           int minimg, int fz_i, double rad_i, double *horizon, int32_t *found)
{
#if SPEC
	const double sig = rad_i + ed->prad[j];   /* the pair's contact distance */
#else
	const double sig = ed->sigma;
	(void)rad_i;
#endif
	const int fz_j = ed->frozen[j] != 0;
	if (fz_i && fz_j)
		return;
	const double dtj = t - pj->t, hj = 0.5 * dtj * dtj;
	double x[D], u[D];
	FOR_AXES(a) {
		double vj = pj->v[a], rj = pj->r[a] + pj->v[a] * dtj;
		if (!fz_j) {
			vj += ed->g[a] * dtj;
			rj += ed->g[a] * hj;
		}
		double d = ri[a] - rj;
		if (minimg) {
			if (d > ed->halfL[a]) d -= ed->L[a];
			else if (d < -ed->halfL[a]) d += ed->L[a];
		}
		/* the regular particle relative to the frozen one */
		x[a] = fz_i ? -d : d;
		u[a] = fz_i ? vj - vi[a] : vi[a] - vj;
	}
	const double dt = obstacle_time_grav(x, u, ed->g, D, sig, *horizon);
	if (dt < *horizon) {
		*horizon = dt;
		*found = j;
	}
}
#endif

static inline __attribute__((always_inline)) void
FN(try_pair)(const struct ed *ed, const P_T *pj, int32_t j, const double *ri, const double *vi, double t, int minimg,
             int fz_i, double rad_i, double *horizon, int32_t *found)
{
#if FILTG
	if (fz_i | ed->frozen[j]) {
		FN(try_frozen)(ed, pj, j, ri, vi, t, minimg, fz_i, rad_i, horizon, found);
		return;
	}
#else
	(void)fz_i;
#endif
	double dtj = t - pj->t, dr[D], dv[D], b, r2;
#if GRAV
	/* j's position and velocity now; the relative motion is then free
	 * flight (uniform gravity cancels), so the rest is unchanged */
	const double hj = 0.5 * dtj * dtj;
#endif
	FOR_AXES(a) {
#if GRAV
		dv[a] = vi[a] - (pj->v[a] + ed->g[a] * dtj);
		double x = ri[a] - (pj->r[a] + pj->v[a] * dtj + ed->g[a] * hj);
#else
		dv[a] = vi[a] - pj->v[a];
		double x = ri[a] - (pj->r[a] + pj->v[a] * dtj);
#endif
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
#if SPEC
	const double sij = rad_i + ed->prad[j];   /* the pair's contact distance */
	double c = r2 - sij * sij, dt;
#else
	(void)rad_i;
	double c = r2 - ed->sigma2, dt;
#endif
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
                           const double *vi, double t, int fz_i, double rad_i, double *horizon, int32_t *found)
{
	int k[3] = {0, 0, 0}, lo[3] = {0, 0, 0}, hi[3] = {0, 0, 0};
	FOR_AXES(a)
		if (ed->nc[a] < 3 && (!WALLS || ed->periodic[a]))
			lo[a] = -1, hi[a] = 1;
	for (k[2] = lo[2]; k[2] <= hi[2]; k[2]++)
		for (k[1] = lo[1]; k[1] <= hi[1]; k[1]++)
			for (k[0] = lo[0]; k[0] <= hi[0]; k[0]++) {
				double rk[D];
				FOR_AXES(a)
					rk[a] = ri[a] + k[a] * ed->L[a];
				FN(try_pair)(ed, pj, j, rk, vi, t, 0, fz_i, rad_i, horizon, found);
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
FN(scan_impl)(struct ed *ed, uint32_t i, const int *const offs[3], const int no[3], int use_occ, int minimg)
{
	const P_T *restrict P = ed->p;
	ev_t *e = &ed->ev[i];
	const int32_t *restrict head = ed->head;
	const uint64_t *restrict occ = ed->occ;
	int32_t cell[3][3] = {{0}};   /* per axis: contribution to the cell index */
	double sh[3][3] = {{0.0}};    /* per axis: periodic shift */
	int32_t stride = 1;
#if WALLS
	/* walled axes: neighbour cells beyond the ends do not exist */
	int nk[3] = {1, 1, 1};
	for (int a = 0; a < D; a++) {
		const int32_t n = ed->nc[a];
		int m = 0;
		for (int k = 0; k < no[a]; k++) {
			int32_t c = e->cc[a] + offs[a][k];
			double s = 0.0;
			if (!ed->periodic[a]) {
				if (c < 0 || c >= n)
					continue;
			} else if (c < 0) {
				c += n, s = -ed->L[a];
			} else if (c >= n) {
				c -= n, s = ed->L[a];
			}
			if (n < 3)
				s = 0.0;
			cell[a][m] = c * stride;
			sh[a][m] = s;
			m++;
		}
		nk[a] = m;
		stride *= n;
	}
	no = nk;
#else
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
#endif
	/* Own data in locals: nothing in the loop can alias them. */
	const double t = P[i].t;
	double r0[D], vi[D];
	FOR_AXES(a) {
		r0[a] = P[i].r[a];
		vi[a] = P[i].v[a];
	}
	double horizon = e->t_coll - t;
	int32_t found = -1;
	const double rad_i = SPEC ? ed->prad[i] : 0.0;
	const int fz_i = FN(fz)(ed, i);
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
				FN(try_images)(ed, &P[j], j, ri, vi, t, fz_i, rad_i, &horizon, &found);
			else
				FN(try_pair)(ed, &P[j], j, ri, vi, t, 0, fz_i, rad_i, &horizon, &found);
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
		FN(scan_impl)(ed, i, offs, no, 1, ed->minimg);
	else
		FN(scan_impl)(ed, i, offs, no, 0, ed->minimg);
}

#if !WALLS
/* Periodic grids of >= 3 cells a side (no minimum image): the stencil's
 * offsets and counts are constants here (the 3^D block, or the new layer
 * after a crossing), so the cell walk is unrolled; the same cells in the
 * same order as scan(), hence the same partner. */
static const int FN(off3)[3] = {-1, 0, 1};

static void FN(scan_block)(struct ed *ed, uint32_t i)
{
	const int *const offs[3] = {FN(off3), FN(off3), FN(off3)};
	const int no[3] = {3, 3, 3};
	if (ed->ncells > OCC_MIN_CELLS)
		FN(scan_impl)(ed, i, offs, no, 1, 0);
	else
		FN(scan_impl)(ed, i, offs, no, 0, 0);
}

/* The layer of cells newly adjacent after a crossing on axis a (dir: +-1). */
static void FN(scan_layer)(struct ed *ed, uint32_t i, int a, int dir)
{
	const int *const f = &FN(off3)[dir > 0 ? 2 : 0];
	const int occ = ed->ncells > OCC_MIN_CELLS;
	if (a == 0) {
		const int *const offs[3] = {f, FN(off3), FN(off3)};
		const int no[3] = {1, 3, 3};
		if (occ) FN(scan_impl)(ed, i, offs, no, 1, 0);
		else FN(scan_impl)(ed, i, offs, no, 0, 0);
	} else if (a == 1) {
		const int *const offs[3] = {FN(off3), f, FN(off3)};
		const int no[3] = {3, 1, 3};
		if (occ) FN(scan_impl)(ed, i, offs, no, 1, 0);
		else FN(scan_impl)(ed, i, offs, no, 0, 0);
	} else {
		const int *const offs[3] = {FN(off3), FN(off3), f};
		const int no[3] = {3, 3, 1};
		if (occ) FN(scan_impl)(ed, i, offs, no, 1, 0);
		else FN(scan_impl)(ed, i, offs, no, 0, 0);
	}
}

/* After a collision of i and j (periodic grid of >= 3 cells a side, both synchronised at time t, no
 * stored predictions: scan_full's start): both new predictions from one walk over the union of their
 * 3^D blocks, whose cells neighbour each other (a contact pair's cells differ by at most one on each
 * axis). The union is walked in the order of the offsets from i's cell, so each particle meets its own
 * cells in the order of its own scan_block() and, with the same strict test per candidate, finds the
 * same partner: bit-identical to two scan_full() calls. A cell of both blocks is read once. Returns 0
 * (nothing done) when the cells are further apart (a position a rounding error outside its cell). */
static int FN(scan_two_impl)(struct ed *ed, uint32_t i, uint32_t j)
{
	const P_T *restrict P = ed->p;
	ev_t *ei = &ed->ev[i], *ej = &ed->ev[j];
	const int32_t *restrict head = ed->head;
	const uint64_t *restrict occ = ed->occ;
	int32_t cell[3][4] = {{0}};    /* per axis and union offset: contribution to the cell index */
	double shi[3][4] = {{0.0}};    /* periodic shift seen from i's cell, from j's */
	double shj[3][4] = {{0.0}};
	uint8_t in[3][4] = {{0}};      /* bit 0: in i's block, bit 1: in j's */
	int no[3] = {1, 1, 1};
	int32_t stride = 1;
	for (int a = 0; a < D; a++) {
		const int32_t n = ed->nc[a], ci = ei->cc[a], cj = ej->cc[a];
		int32_t d = cj - ci;
		if (d == n - 1) d = -1;
		else if (d == 1 - n) d = 1;
		if (d < -1 || d > 1)
			return 0;
		const int lo = d < 0 ? -2 : -1;
		no[a] = 3 + (d != 0);
		for (int k = 0; k < no[a]; k++) {
			const int o = lo + k;
			int32_t c = ci + o;
			double s = 0.0;
			if (c < 0) c += n, s = -ed->L[a];
			else if (c >= n) c -= n, s = ed->L[a];
			cell[a][k] = c * stride;
			shi[a][k] = s;
			int32_t c2 = cj + (o - d);
			double s2 = 0.0;
			if (c2 < 0) s2 = -ed->L[a];
			else if (c2 >= n) s2 = ed->L[a];
			shj[a][k] = s2;
			in[a][k] = (uint8_t)((o >= -1 && o <= 1) | ((o - d >= -1 && o - d <= 1) << 1));
		}
		stride *= n;
	}
	ei->t_coll = INFINITY;
	ei->partner = -1;
	ej->t_coll = INFINITY;
	ej->partner = -1;
	const double ti = P[i].t, tj = P[j].t;
	double r0i[D], vi[D], r0j[D], vj[D];
	FOR_AXES(a) {
		r0i[a] = P[i].r[a];
		vi[a] = P[i].v[a];
		r0j[a] = P[j].r[a];
		vj[a] = P[j].v[a];
	}
	double hi = INFINITY, hj = INFINITY;
	int32_t fi = -1, fj = -1;
	const double rad_i = SPEC ? ed->prad[i] : 0.0, rad_j = SPEC ? ed->prad[j] : 0.0;
	struct { int32_t j; uint8_t k[3]; uint8_t in; } occd[64];
	int m = 0;
	const int nz = D == 3 ? no[2] : 1;
	for (int kz = 0; kz < nz; kz++)
		for (int ky = 0; ky < no[1]; ky++) {
			const int32_t row = cell[2][kz] + cell[1][ky];
			const int inzy = in[1][ky] & (D == 3 ? in[2][kz] : 3);
			if (!inzy)
				continue;
			for (int kx = 0; kx < no[0]; kx++) {
				const int inx = inzy & in[0][kx];
				if (!inx)
					continue;
				const int32_t c = row + cell[0][kx];
				if (!((occ[c >> 6] >> (c & 63)) & 1))
					continue;     /* empty: its head need not be read */
				int32_t q = head[c];
				__builtin_prefetch(&P[q]);
				occd[m].j = q;
				occd[m].k[0] = (uint8_t)kx, occd[m].k[1] = (uint8_t)ky, occd[m].k[2] = (uint8_t)kz;
				occd[m].in = (uint8_t)inx;
				m += q >= 0;
			}
		}
	for (int q = 0; q < m; q++) {
		double ri[D], rj[D];
		FOR_AXES(a) {
			ri[a] = r0i[a] - shi[a][occd[q].k[a]];
			rj[a] = r0j[a] - shj[a][occd[q].k[a]];
		}
		const int w = occd[q].in;
		if (w == 3) {
			for (int32_t k = occd[q].j; k >= 0; k = P[k].next) {
				if ((uint32_t)k != i)
					FN(try_pair)(ed, &P[k], k, ri, vi, ti, 0, 0, rad_i, &hi, &fi);
				if ((uint32_t)k != j)
					FN(try_pair)(ed, &P[k], k, rj, vj, tj, 0, 0, rad_j, &hj, &fj);
			}
		} else if (w == 1) {
			for (int32_t k = occd[q].j; k >= 0; k = P[k].next)
				if ((uint32_t)k != i)
					FN(try_pair)(ed, &P[k], k, ri, vi, ti, 0, 0, rad_i, &hi, &fi);
		} else {
			for (int32_t k = occd[q].j; k >= 0; k = P[k].next)
				if ((uint32_t)k != j)
					FN(try_pair)(ed, &P[k], k, rj, vj, tj, 0, 0, rad_j, &hj, &fj);
		}
	}
	if (fi >= 0) {
		ei->t_coll = ti + hi;
		ei->partner = fi;
		ei->pcount = P[fi].count;
	}
	if (fj >= 0) {
		ej->t_coll = tj + hj;
		ej->partner = fj;
		ej->pcount = P[fj].count;
	}
	return 1;
}

/* Only on grids of more than OCC_MIN_CELLS cells (with the occupancy bitmap), where the cells' heads and
 * records are cache misses: there reading the shared cells once pays (measured: +3-4% at N = 10^5 and
 * 10^6, volume fraction 0.1); on smaller grids, all in cache, the two scans of scan_full() were as fast
 * or faster (0.98). Returns 0 where it did nothing. */
static int FN(scan_two)(struct ed *ed, uint32_t i, uint32_t j)
{
	if (ed->ncells > OCC_MIN_CELLS)
		return FN(scan_two_impl)(ed, i, j);
	return 0;
}
#endif

static void FN(scan_full)(struct ed *ed, uint32_t i)
{
	ed->ev[i].t_coll = INFINITY;
	ed->ev[i].partner = -1;
#if !WALLS
	if (!ed->minimg) {
		FN(scan_block)(ed, i);
		return;
	}
#endif
	const int *offs[3] = {ed->off[0], ed->off[1], ed->off[2]};
	FN(scan)(ed, i, offs, ed->no);
}

static inline void FN(schedule)(struct ed *ed, uint32_t i)
{
	const ev_t *e = &ed->ev[i];
	cal_update(ed, i, e->t_coll <= e->t_cross ? e->t_coll : e->t_cross);
}

/* Put particle i (in the box) into the cell of its position. */
static void FN(place)(struct ed *ed, uint32_t i);

#if !WALLS   /* neighbour lists: periodic homogeneous scenes only */
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
	const double rad_i = SPEC ? ed->prad[i] : 0.0;
	if (edge)
		for (int k = 0; k < m; k++)
			FN(try_pair)(ed, &P[nb[k]], nb[k], ri, vi, t, 1, 0, rad_i, &horizon, &found);
	else
		for (int k = 0; k < m; k++)
			FN(try_pair)(ed, &P[nb[k]], nb[k], ri, vi, t, 0, 0, rad_i, &horizon, &found);
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
				if (hd[m] >= 0)   /* an empty cell (-1) has no address (UBSan: pointer overflow) */
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
	FN(advance)(ed, p, t);
	FN(cell_remove)(ed, i);
	FOR_AXES(a) {
		if (p->r[a] < 0.0) {
			p->r[a] += ed->L[a];
			FN(image)(ed, i, a, -1);
		} else if (p->r[a] >= ed->L[a]) {
			p->r[a] -= ed->L[a];
			FN(image)(ed, i, a, 1);
		}
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

#endif

/* A particle crosses a cell face: new cell, wrap at the box edge, then only
 * the newly adjacent layer of cells needs scanning (the stored collision,
 * even if stale, stays: a stale one is detected when it is popped). */
static void FN(do_cross)(struct ed *ed, uint32_t i, double t)
{
	P_T *p = &((P_T *)ed->p)[i];
	ev_t *e = &ed->ev[i];
	int a = e->cross >> 1, dir = (e->cross & 1) ? 1 : -1;

	FN(advance)(ed, p, t);
	FN(cell_remove)(ed, i);
	e->cc[a] += dir;
	if (e->cc[a] >= ed->nc[a]) {
		e->cc[a] = 0;
		p->r[a] -= ed->L[a];
		FN(image)(ed, i, a, 1);
	} else if (e->cc[a] < 0) {
		e->cc[a] = ed->nc[a] - 1;
		p->r[a] += ed->L[a];
		FN(image)(ed, i, a, -1);
	}
	FN(cell_insert)(ed, i);
	FN(set_cross)(ed, i);
#if !WALLS
	if (!ed->minimg) {
		FN(scan_layer)(ed, i, a, dir);
		FN(schedule)(ed, i);
		return;
	}
#endif
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

/* The running kinetic energy (and its time integral, for the interval
 * averages) brought to time t before an event changes it. Without gravity
 * E_kin is constant between events; with gravity E(t) = E + m g.P dt +
 * m N g^2 dt^2 / 2 with P the sum of the velocities (kept in ed->psum),
 * integrated exactly. */
static inline void FN(energy_to)(struct ed *ed, double t)
{
#if GRAV
#if SPEC
	/* mixtures: psum holds sum (m_i / m) v_i (m the mean mass), n the mass present over m (FILTG: less
	 * the frozen particles', nfzm) */
	const double dt = t - ed->t_mark, m = ed->mass, n = ed->mix->mpres / m - FILTG * ed->nfzm;
#else
	const double dt = t - ed->t_mark, m = ed->mass, n = (double)(ed->n - ed->n_gone - FILTG * ed->nfz);
#endif
	double gp = 0.0, g2 = 0.0;
	FOR_AXES(a) {
#if FILTG
		gp += ed->g[a] * (ed->psum[a] - ed->fzv[a]);   /* frozen particles: constant velocities (fzv their sum) */
#else
		gp += ed->g[a] * ed->psum[a];
#endif
		g2 += ed->g[a] * ed->g[a];
	}
	ed->ekin_int += dt * (ed->ekin_cur + dt * (0.5 * m * gp + dt * m * n * g2 / 6.0));
	ed->ekin_cur += dt * m * (gp + 0.5 * n * g2 * dt);
	FOR_AXES(a)
		ed->psum[a] += n * ed->g[a] * dt;
#else
	ed->ekin_int += ed->ekin_cur * (t - ed->t_mark);
#endif
	ed->t_mark = t;
}

#if ROUGH
/* Rough variant: the collision of i and j by the rough rule (rough.h) with
 * normal restitution e; elastic (TC model, pre-run): smooth and elastic.
 * dr = r_i - r_j, r2 = |dr|^2, b = dr . (v_i - v_j) < 0. */
static inline void FN(rough_kick)(struct ed *ed, P_T *pi, P_T *pj, uint32_t i, uint32_t j, const double *dr,
                                  double r2, double b, double e, int elastic)
{
	const double rn = sqrt(r2);
	double n[D];
	FOR_AXES(k)
		n[k] = dr[k] / rn;
	const int k = D == 2 ? 1 : 3;
#if SPEC
	/* mixtures: each particle's own mass, radius and moment of inertia q m a^2 */
	const rough_pair_t R = {.m1 = FN(mass)(ed, i), .m2 = FN(mass)(ed, j), .a1 = ed->prad[i], .a2 = ed->prad[j],
	                        .e = e, .beta = elastic ? -1.0 : ed->rbeta, .mu = elastic ? -1.0 : ed->rmu, .q = ed->rq};
	ed->ekin_cur += rough_collide_pair(D, &R, n, b / rn, pi->v, pj->v, &ed->spin[(size_t)i * k],
	                                   &ed->spin[(size_t)j * k]);
#else
	const rough_rule_t R = {.m = ed->mass, .a = 0.5 * ed->sigma, .e = e, .beta = elastic ? -1.0 : ed->rbeta,
	                        .mu = elastic ? -1.0 : ed->rmu, .q = ed->rq};
	ed->ekin_cur += rough_collide(D, &R, n, b / rn, pi->v, pj->v, &ed->spin[(size_t)i * k], &ed->spin[(size_t)j * k]);
#endif
}
#endif

/* Binary collision of i and j at time t with normal restitution (elastic
 * within the TC time of either partner's previous collision). */
static inline __attribute__((always_inline)) void FN(collide)(struct ed *ed, uint32_t i, uint32_t j, double t)
{
	P_T *P = ed->p, *pi = &P[i], *pj = &P[j];
	FN(advance)(ed, pi, t);
	FN(advance)(ed, pj, t);
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
	FN(energy_to)(ed, t);
	if (b < 0.0) {
#if SPEC
		/* the pair's restitution (elastic in the pre-run, which sets relaxing) */
		const int pq = ed->spc[i] * ed->nsp + ed->spc[j], qr = ed->spc[j] * ed->nsp + ed->spc[i];
		double e = ed->relaxing ? 1.0 : ed->mix->e[pq];
#else
		double e = ed->e;
#endif
#if ROUGH
		int elastic = ed->relaxing;   /* elastic pre-run: smooth and elastic */
		if (elastic)
			e = 1.0;
#endif
		if (ed->tlast) {
			if (t - ed->tlast[i] < ed->tc || t - ed->tlast[j] < ed->tc) {
				e = 1.0;
				ed->tc_elastic++;
#if ROUGH
				elastic = 1;
#endif
			}
			ed->tlast[i] = ed->tlast[j] = t;
		}
		if (ed->bcount) {
			/* impact parameter over |r| (before the kick, any rule): sqrt(1 - (r.g)^2 / (r^2 g^2)) */
			double g2 = 0.0;
			FOR_AXES(a)
				g2 += dv[a] * dv[a];
			double q = 1.0 - b * b / (r2 * g2);
			int k = (int)(sqrt(q > 0.0 ? q : 0.0) * ed->bnb);
			ed->bcount[k < ed->bnb ? k : ed->bnb - 1] += 1.0;
		}
#if ROUGH
		FN(rough_kick)(ed, pi, pj, i, j, dr, r2, b, e, elastic);
#if SPEC
		ed->virial -= (1.0 + e) * ed->mix->mu[pq] * b;   /* r . J: J_t is normal to r */
		(void)qr;
#else
		ed->virial -= 0.5 * (1.0 + e) * ed->mass * b;   /* r . J: J_t is normal to r */
#endif
#elif SPEC
		/* unequal masses: impulse J = -(1 + e) mu (b / r2) dr on i, mu the
		 * reduced mass; i's velocity changes by J / m_i = -(1 + e) w_ij
		 * (b / r2) dr with w_ij = m_j / (m_i + m_j), j's by the opposite
		 * impulse over m_j */
		double f = (1.0 + e) * b / r2, fi = f * ed->mix->w[pq], fj = f * ed->mix->w[qr];
		FOR_AXES(a) {
			pi->v[a] -= fi * dr[a];
			pj->v[a] += fj * dr[a];
		}
		ed->virial -= (1.0 + e) * ed->mix->mu[pq] * b;
		if (e != 1.0)
			ed->ekin_cur -= 0.5 * (1.0 - e * e) * ed->mix->mu[pq] * b * b / r2;
#else
		double f = 0.5 * (1.0 + e) * b / r2;
		FOR_AXES(a) {
			pi->v[a] -= f * dr[a];
			pj->v[a] += f * dr[a];
		}
		ed->virial -= 0.5 * (1.0 + e) * ed->mass * b;
		if (e != 1.0)
			ed->ekin_cur -= 0.25 * (1.0 - e * e) * ed->mass * b * b / r2;
#endif
	}
	/* A grazing pair that rounding made non-approaching is left alone, but
	 * still counts as an event of both so that stale predictions go away. */
	pi->count++;
	pj->count++;
	ed->collisions++;
}

#if WALLS
/* Particle i leaves through open wall w at time t: out of the cell lists
 * and the calendar, its energy and momentum out of the running sums, its
 * counter bumped (predictions with it as partner are cancelled). */
static void FN(leave)(struct ed *ed, uint32_t i, int w, double t)
{
	P_T *p = &((P_T *)ed->p)[i];
	ev_t *e = &ed->ev[i];
	FN(advance)(ed, p, t);
	FN(energy_to)(ed, t);
	double v2 = 0.0;
	const double m = FN(mass)(ed, i), mw = SPEC ? m / ed->mass : 1.0;
	FOR_AXES(a) {
		v2 += p->v[a] * p->v[a];
#if GRAV
		ed->psum[a] -= mw * p->v[a];
#endif
		p->v[a] = 0.0;
	}
	(void)mw;
#if SPEC
	mix_present(ed, ed->spc[i], -1);
#endif
	ed->ekin_cur -= 0.5 * m * v2;
#if ROUGH
	/* its spin leaves with it: rotational sums count the particles present */
	for (int k = 0; k < (D == 2 ? 1 : 3); k++)
		ed->spin[(size_t)i * (D == 2 ? 1 : 3) + k] = 0.0;
#endif
	FN(cell_remove)(ed, i);
	ed->gone[i] = 1;
	ed->n_gone++;
#if FILTG
	if (ed->frozen[i])
		frozen_count(ed, ed->frozen[i] - 1, SPEC ? ed->spc[i] : 0, -1);
#endif
	if (ed->frozen)
		ed->frozen[i] = 0;
	ed->wout[w]++;
	if (ed->freei) {   /* reservoir scenes: its slot is free, its row empty */
#if SPEC
		const int k = ed->spc[i];   /* mixtures (dispensers): on its species' stack */
		ed->freei[ed->mix->fs_off[k] + ed->mix->fs_n[k]++] = i;
#else
		ed->freei[ed->n_gone - 1] = i;
#endif
		ed->label[ed->id[i]] = -1;
	}
	p->count++;
	e->t_coll = e->t_cross = INFINITY;
	e->partner = -1;
	e->cross = -1;
	cal_update(ed, i, INFINITY);
}

/* Particle i meets wall w (its event code) at time t: the wall's rule
 * (wall_rule() in ed.c), with the TC model (the hit is elastic within tc of
 * the particle's previous collision, wall or particle) and the minimum
 * rebound; the momentum given to the wall is accumulated for its force. */
static void FN(do_wall)(struct ed *ed, uint32_t i, double t)
{
	P_T *p = &((P_T *)ed->p)[i];
	ev_t *e = &ed->ev[i];
	const int w = e->cross - ED_WALL0, a = w >> 1;
	const wall_t *W = &ed->wall[w];
	const double s = (w & 1) ? -1.0 : 1.0;
	if ((W->type == SCENE_WALL_OPEN || W->type == SCENE_WALL_RESERVOIR) && !ed->relaxing) {
		FN(leave)(ed, i, w, t);
		return;
	}
	if (W->pu != 0.0 && ed->frozen && ed->frozen[i]) {
		/* a frozen particle (outside the stream, infinite mass) that another axis' piston catches
		 * leaves through its filter's wall: a kick would give it a velocity of its own, and frozen
		 * particles must never meet (the layers refill the room, frozen where beyond the plane) */
		FN(leave)(ed, i, ed->frozen[i] - 1, t);
		return;
	}
	FN(advance)(ed, p, t);
	FN(energy_to)(ed, t);
	int elastic = 0;
	if (ed->tlast) {
		elastic = t - ed->tlast[i] < ed->tc;
		ed->tlast[i] = t;
	}
	double v0[D], de = 0.0;
	FOR_AXES(k)
		v0[k] = p->v[k];
	const double m = FN(mass)(ed, i);
	wall_rule(ed, w, p->v, t, elastic, SPEC ? sqrt(ed->mass / m) : 1.0);
	FOR_AXES(k) {
		const double dv = p->v[k] - v0[k];
		ed->wimp[w][k] -= m * dv;
		ed->wimp_tot[w][k] -= m * dv;
		de += dv * (p->v[k] + v0[k]);
#if GRAV
		ed->psum[k] += SPEC ? m / ed->mass * dv : dv;
#endif
	}
	ed->ekin_cur += 0.5 * m * de;
	/* Back on its side of the wall: rounding may leave the contact a hair beyond. */
	double lim = W->rest + s * FN(rad)(ed, i);
	if (W->A != 0.0)
		lim += s * W->A * sin(W->ph + W->omega * t);
	if (W->pu != 0.0)   /* a dispenser's moving piston */
		lim += s * W->pu * (t - W->pt0);
	if (s * (p->r[a] - lim) < 0.0)
		p->r[a] = lim;
	p->count++;
	ed->whits[w]++;
	ed->wall_collisions++;
	FN(set_cross)(ed, i);
	FN(scan_full)(ed, i);
	FN(schedule)(ed, i);
}

/* Particle i meets obstacle k (its event code) at time t: the obstacle's
 * rule (obst_rule() in ed.c) along the normal from the obstacle's centre,
 * with the TC model as for walls; the momentum given to the obstacle is
 * accumulated for its force (drag). */
static void FN(do_obstacle)(struct ed *ed, uint32_t i, double t)
{
	P_T *p = &((P_T *)ed->p)[i];
	ev_t *e = &ed->ev[i];
	const int k = e->cross - ED_OBST0;
	const double S = FN(obst_S)(ed, i, k);
	FN(advance)(ed, p, t);
	FN(energy_to)(ed, t);
	int elastic = 0;
	if (ed->tlast) {
		elastic = t - ed->tlast[i] < ed->tc;
		ed->tlast[i] = t;
	}
	double x[D], nrm[3] = {0.0, 0.0, 0.0}, r2 = 0.0;
	FN(obst_rel)(ed, p, k, x);
	FOR_AXES(a)
		r2 += x[a] * x[a];
	const double r = sqrt(r2);
	FOR_AXES(a)
		nrm[a] = x[a] / r;
	double v0[D], de = 0.0;
	FOR_AXES(a)
		v0[a] = p->v[a];
	const double m = FN(mass)(ed, i);
	obst_rule(ed, k, nrm, p->v, elastic, SPEC ? sqrt(ed->mass / m) : 1.0);
	FOR_AXES(a) {
		const double dv = p->v[a] - v0[a];
		ed->oimp[k][a] -= m * dv;
		ed->oimp_tot[k][a] -= m * dv;
		de += dv * (p->v[a] + v0[a]);
#if GRAV
		ed->psum[a] += SPEC ? m / ed->mass * dv : dv;
#endif
	}
	ed->ekin_cur += 0.5 * m * de;
	/* Back on the contact sphere: rounding may leave the centre a hair inside. */
	if (r < S)
		FOR_AXES(a)
			p->r[a] += (S - r) * nrm[a];
	p->count++;
	ed->ohits[k]++;
	ed->obst_collisions++;
	FN(set_cross)(ed, i);
	FN(scan_full)(ed, i);
	FN(schedule)(ed, i);
}

/* Filters (seed 001 outlet): particle i crosses the filter plane of wall
 * w (its event code) going out at time t: turned back, or frozen (velocity
 * exactly fu[w], no thermal part, infinite mass, until it leaves through
 * the wall) by filter_rule(). The kinetic energy it loses (or gains)
 * leaves the running sum. */
static void FN(do_filter)(struct ed *ed, uint32_t i, double t)
{
	P_T *p = &((P_T *)ed->p)[i];
	const int w = ed->ev[i].cross - ED_FILT0;
	FN(advance)(ed, p, t);
	FN(energy_to)(ed, t);
	double de = 0.0, v[3] = {0.0, 0.0, 0.0};
	FOR_AXES(a)
		v[a] = p->v[a];
#if SPEC
	const int freeze = filter_rule(ed, w, v, ed->mix->fback[w][ed->spc[i]], ed->mix->fsv[w][ed->spc[i]]);
#else
	const int freeze = filter_rule(ed, w, v, ed->fback[w], ed->fsv[w]);
#endif
	const double m = FN(mass)(ed, i);
	FOR_AXES(a) {
		de += v[a] * v[a] - p->v[a] * p->v[a];
#if GRAV
		ed->psum[a] += (SPEC ? m / ed->mass : 1.0) * (v[a] - p->v[a]);
#endif
		p->v[a] = v[a];
	}
	ed->ekin_cur += 0.5 * m * de;
#if ROUGH
	{
		/* rough particles: a frozen one stops spinning (no thermal part, as its velocity); one turned
		 * back gets the spin of the gas at the filter's temperature (variance T / I per component,
		 * I = q m a^2), drawn after its velocity */
		const int k = D == 2 ? 1 : 3;
#if SPEC
		const double sv = ed->mix->fsv[w][ed->spc[i]];
#else
		const double sv = ed->fsv[w];
#endif
		const double sw = sv / sqrt(ed->rq * FN(rad)(ed, i) * FN(rad)(ed, i));
		for (int c = 0; c < k; c++)
			ed->spin[(size_t)i * k + c] = freeze ? 0.0 : sw * rng_gauss(&ed->wrng);
	}
#endif
	if (freeze) {
		ed->frozen[i] = (uint8_t)(1 + w);
		ed->nfrozen[w]++;
#if FILTG
		frozen_count(ed, w, SPEC ? ed->spc[i] : 0, 1);
#endif
	} else {
		/* turned back: on the plane's inner side (rounding may leave it a hair beyond) */
		const int a = w >> 1;
		const double s = (w & 1) ? -1.0 : 1.0;
		if (s * (p->r[a] - ed->fplane[w]) < 0.0)
			p->r[a] = ed->fplane[w];
	}
	p->count++;
	FN(set_cross)(ed, i);
	FN(scan_full)(ed, i);
	FN(schedule)(ed, i);
}

/* Filters: the collision of i and j at time t when one of them is frozen:
 * the regular one meets a sphere of infinite mass moving at the frozen
 * velocity, its normal velocity relative to it reversed with the pair's
 * restitution (TC model: elastic within tc of its previous collision); the
 * momentum it gives goes to the filter's wall (wall_impulse). Two frozen
 * particles have the same velocity and are never predicted to meet; one met
 * here (a touching pair) is left alone. */
static void FN(collide_frozen)(struct ed *ed, uint32_t i, uint32_t j, double t)
{
	P_T *P = ed->p;
	if (ed->frozen[i] && !ed->frozen[j]) {   /* q (j here) is the regular one */
		uint32_t x = i;
		i = j;
		j = x;
	}
	P_T *pq = &P[i], *pf = &P[j];
	FN(advance)(ed, pq, t);
	FN(advance)(ed, pf, t);
	FN(energy_to)(ed, t);
	double dr[D], dv[D], b = 0.0, r2 = 0.0;
	FOR_AXES(a) {
		double x = pq->r[a] - pf->r[a];
		if (x > ed->halfL[a]) x -= ed->L[a];
		else if (x < -ed->halfL[a]) x += ed->L[a];
		dr[a] = x;
		dv[a] = pq->v[a] - pf->v[a];
		b += x * dv[a];
		r2 += x * x;
	}
	if (b < 0.0 && !ed->frozen[i]) {
#if SPEC
		double e = ed->mix->e[ed->spc[i] * ed->nsp + ed->spc[j]];   /* the pair's restitution */
#else
		double e = ed->e;
#endif
		const double m = FN(mass)(ed, i);
#if ROUGH
		int elastic = 0;
#endif
		if (ed->tlast) {
			if (t - ed->tlast[i] < ed->tc) {
				e = 1.0;
				ed->tc_elastic++;
#if ROUGH
				elastic = 1;   /* within tc: smooth and elastic, as between particles */
#endif
			}
			ed->tlast[i] = t;
		}
		const int w = ed->frozen[j] - 1;
#if ROUGH
		/* rough particles: the rough rule against a sphere of infinite mass and moment of inertia
		 * without spin moving at the filter's velocity (rough.h, rough_collide_fixed()) */
		{
			const int k = D == 2 ? 1 : 3;
			const double rn = sqrt(r2);
			double n[D], J[3], de = 0.0;
			FOR_AXES(a)
				n[a] = dr[a] / rn;
			const rough_pair_t R = {.m1 = m, .m2 = INFINITY, .a1 = FN(rad)(ed, i), .a2 = FN(rad)(ed, j), .e = e,
			                        .beta = elastic ? -1.0 : ed->rbeta, .mu = elastic ? -1.0 : ed->rmu, .q = ed->rq};
			FOR_AXES(a)
				de -= pq->v[a] * pq->v[a];
			rough_collide_fixed(D, &R, n, b / rn, pq->v, pf->v, &ed->spin[(size_t)i * k], J);
			FOR_AXES(a) {
				de += pq->v[a] * pq->v[a];
				ed->wimp[w][a] -= J[a];
				ed->wimp_tot[w][a] -= J[a];
#if GRAV
				ed->psum[a] += J[a] / ed->mass;
#endif
			}
			ed->ekin_cur += 0.5 * m * de;
		}
#else
		const double f = (1.0 + e) * b / r2;
		double de = 0.0;
		FOR_AXES(a) {
			const double v0 = pq->v[a];
			pq->v[a] -= f * dr[a];
			de += pq->v[a] * pq->v[a] - v0 * v0;
			ed->wimp[w][a] += m * f * dr[a];
			ed->wimp_tot[w][a] += m * f * dr[a];
#if GRAV
			ed->psum[a] -= (SPEC ? m / ed->mass : 1.0) * f * dr[a];
#endif
		}
		ed->ekin_cur += 0.5 * m * de;
#endif
	}
	pq->count++;
	pf->count++;
	ed->collisions++;
}

/* Cell mode only: a boundary event (face or wall), a collision or a
 * cancelled one. */
static void FN(step)(struct ed *ed)
{
	uint32_t i = ed->heap[0].i;
	double t = ed->heap[0].t;
	P_T *P = ed->p;
	ev_t *e = &ed->ev[i];

	if (ed->hn > 1) {
		uint32_t k = ed->hn > 2 && hless(&ed->heap[2], &ed->heap[1]) ? ed->heap[2].i : ed->heap[1].i;
		__builtin_prefetch(&P[k]);
		__builtin_prefetch(&ed->ev[k]);
	}
	cal_prefetch(ed);
	ed->t = t;
	ed->t_abs_valid = 0;
	ed->events++;
	if (e->t_cross < e->t_coll) {
		if (e->cross >= ED_FILT0)
			FN(do_filter)(ed, i, t);
		else if (e->cross >= ED_OBST0)
			FN(do_obstacle)(ed, i, t);
		else if (e->cross >= ED_WALL0)
			FN(do_wall)(ed, i, t);
		else
			FN(do_cross)(ed, i, t);
		return;
	}
	uint32_t j = (uint32_t)e->partner;
	FN(advance)(ed, &P[i], t);
	if (P[j].count != e->pcount) {
		FN(scan_full)(ed, i);
		FN(schedule)(ed, i);
		return;
	}
	if (ed->frozen && (ed->frozen[i] | ed->frozen[j]))   /* filters: a frozen partner has infinite mass */
		FN(collide_frozen)(ed, i, j, t);
	else
		FN(collide)(ed, i, j, t);
	FN(set_cross)(ed, i);
	FN(scan_full)(ed, i);
	FN(schedule)(ed, i);
	FN(set_cross)(ed, j);
	FN(scan_full)(ed, j);
	FN(schedule)(ed, j);
}
#else
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
		if (ed->nl) {
			FN(nl_rebuild)(ed, i, t);
		} else {
			ED_TRACE_EVENT(ed, ED_TRACE_CROSS, i, e->cross, t);
			FN(do_cross)(ed, i, t);
		}
		return;
	}
	uint32_t j = (uint32_t)e->partner;
	FN(advance)(ed, &P[i], t);
	if (P[j].count != e->pcount) {
		/* Cancelled: the partner changed course. Free flight, then rescan. */
		ED_TRACE_EVENT(ed, ED_TRACE_CANCELLED, i, (int32_t)j, t);
		if (ed->nl)
			FN(scan_nl)(ed, i);
		else
			FN(scan_full)(ed, i);
		FN(schedule)(ed, i);
		return;
	}
	ED_TRACE_EVENT(ed, ED_TRACE_COLLISION, i, (int32_t)j, t);
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
	FN(set_cross)(ed, j);
	if (!ed->minimg && FN(scan_two)(ed, i, j)) {
		FN(schedule)(ed, i);
		FN(schedule)(ed, j);
		return;
	}
	FN(scan_full)(ed, i);
	FN(schedule)(ed, i);
	FN(scan_full)(ed, j);
	FN(schedule)(ed, j);
}
#endif

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
#if WALLS
	if (ed->gone)
		permute(ed->gone, 1, newidx, n);
	if (ed->frozen)
		permute(ed->frozen, 1, newidx, n);
#if SPEC
	if (ed->freei)   /* mixtures: one stack per species */
		for (int s = 0; s < ed->nsp; s++)
			for (uint32_t k = ed->mix->fs_off[s]; k < ed->mix->fs_off[s] + ed->mix->fs_n[s]; k++)
				ed->freei[k] = newidx[ed->freei[k]];
#else
	if (ed->freei)
		for (uint64_t k = 0; k < ed->n_gone; k++)
			ed->freei[k] = newidx[ed->freei[k]];
#endif
#endif
#if ROUGH
	permute(ed->spin, (D == 2 ? 1 : 3) * sizeof(double), newidx, n);
#endif
#if SPEC
	permute(ed->spc, 1, newidx, n);
	permute(ed->prad, sizeof(double), newidx, n);
#endif
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
	for (uint32_t k = n; k-- > 0;) {
#if WALLS
		if (ed->gone && ed->gone[k])
			continue;
#endif
		FN(cell_insert)(ed, k);
	}
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
#if WALLS
		if (ed->gone && ed->gone[i]) {   /* left: nothing moves, no events */
			P[i].t = 0.0;
			continue;
		}
#endif
		FN(advance)(ed, &P[i], t);
		P[i].t = 0.0;
		ed->ev[i].t_coll -= t;
		ed->ev[i].t_cross -= t;
		if (ed->tlast)
			ed->tlast[i] -= t;
	}
#if WALLS
	walls_rebase(ed, t);
#endif
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

#if WALLS
/* Scene coordinates: periodic axes folded into the box, walled ones with
 * the origin at the lower wall's rest position; velocities now. */
static void FN(state)(const struct ed *ed, double *pos, double *vel)
{
	const P_T *P = ed->p;
	for (uint32_t i = 0; i < ed->n; i++) {
		const double dt = ed->t - P[i].t;
		if (ed->gone && ed->gone[i]) {   /* left through an open wall: NaN */
			FOR_AXES(a) {
				if (pos) pos[(size_t)ed->id[i] * D + a] = NAN;
				if (vel) vel[(size_t)ed->id[i] * D + a] = NAN;
			}
			continue;
		}
		FOR_AXES(a) {
			const double g = GRAV && !FN(fz)(ed, i) ? ed->g[a] : 0.0;
			if (pos) {
				double x = P[i].r[a] + P[i].v[a] * dt + 0.5 * g * dt * dt;
				if (ed->periodic[a]) {
					x = fmod(x, ed->L[a]);
					if (x < 0.0)
						x += ed->L[a];
					if (x >= ed->L[a])
						x = 0.0;
				} else {
					x -= ed->org[a];
				}
				pos[(size_t)ed->id[i] * D + a] = x;
			}
			if (vel)
				vel[(size_t)ed->id[i] * D + a] = P[i].v[a] + g * dt;
		}
	}
}

/* Kinetic energy and momentum now (with gravity, velocities brought to the
 * present). */
static double FN(ekin)(const struct ed *ed, double mom[3])
{
	const P_T *P = ed->p;
	double s = 0.0;
	mom[0] = mom[1] = mom[2] = 0.0;
	for (uint32_t i = 0; i < ed->n; i++) {
		const double dt = ed->t - P[i].t;
		if (ed->gone && ed->gone[i])
			continue;
#if SPEC
		const double m = FN(mass)(ed, i);
		FOR_AXES(a) {
			const double v = P[i].v[a] + (GRAV && !FN(fz)(ed, i) ? ed->g[a] * dt : 0.0);
			s += m * v * v;
			mom[a] += m * v;
		}
#else
		FOR_AXES(a) {
			const double v = P[i].v[a] + (GRAV && !FN(fz)(ed, i) ? ed->g[a] * dt : 0.0);
			s += v * v;
			mom[a] += v;
		}
#endif
	}
#if SPEC
	return 0.5 * s;
#else
	FOR_AXES(a)
		mom[a] *= ed->mass;
	return 0.5 * ed->mass * s;
#endif
}

/* Centre-of-mass height along -g (scene coordinates) and potential energy
 * -m sum g.r, now. */
static void FN(observe)(const struct ed *ed, double *height, double *epot)
{
	const P_T *P = ed->p;
	double sum[D], g2 = 0.0;
	FOR_AXES(a) {
		sum[a] = 0.0;
		g2 += ed->g[a] * ed->g[a];
	}
	double mp = 0.0;   /* mixtures: mass present; sums weighted by mass */
	for (uint32_t i = 0; i < ed->n; i++) {
		const double dt = ed->t - P[i].t;
		if (ed->gone && ed->gone[i])
			continue;
#if SPEC
		const double m = FN(mass)(ed, i);
		mp += m;
		FOR_AXES(a)
			sum[a] += m * (P[i].r[a] + P[i].v[a] * dt + (GRAV && !FN(fz)(ed, i) ? 0.5 * ed->g[a] * dt * dt : 0.0) -
			               ed->org[a]);
#else
		FOR_AXES(a)
			sum[a] += P[i].r[a] + P[i].v[a] * dt + (GRAV && !FN(fz)(ed, i) ? 0.5 * ed->g[a] * dt * dt : 0.0) - ed->org[a];
#endif
	}
	double gr = 0.0;
	FOR_AXES(a)
		gr += ed->g[a] * sum[a];
#if SPEC
	*epot = -gr;
	*height = g2 > 0.0 && mp > 0.0 ? -gr / (sqrt(g2) * mp) : NAN;
#else
	(void)mp;
	*epot = -ed->mass * gr;
	*height = g2 > 0.0 && ed->n > ed->n_gone ? -gr / (sqrt(g2) * (double)(ed->n - ed->n_gone)) : NAN;
#endif
}
#else
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
#if SPEC
	for (uint32_t i = 0; i < ed->n; i++) {
		const double m = ed->mix->m[ed->spc[i]];
		FOR_AXES(a) {
			s += m * P[i].v[a] * P[i].v[a];
			mom[a] += m * P[i].v[a];
		}
	}
	return 0.5 * s;
#else
	for (uint32_t i = 0; i < ed->n; i++)
		FOR_AXES(a) {
			s += P[i].v[a] * P[i].v[a];
			mom[a] += P[i].v[a];
		}
	FOR_AXES(a)
		mom[a] *= ed->mass;
	return 0.5 * ed->mass * s;
#endif
}
#endif

/* Position of p on axis a at the present time (no wrap). */
static inline double FN(pos_now)(const struct ed *ed, const P_T *p, int a)
{
	const double dt = ed->t - p->t;
#if GRAV
	if (FN(fz)(ed, (uint32_t)(p - (const P_T *)ed->p)))
		return p->r[a] + p->v[a] * dt;
	return p->r[a] + p->v[a] * dt + 0.5 * ed->g[a] * dt * dt;
#else
	return p->r[a] + p->v[a] * dt;
#endif
}

/* Minimum image of a difference on axis a (none on walled axes). */
static inline double FN(min_image)(const struct ed *ed, int a, double x)
{
#if WALLS
	if (!ed->periodic[a])
		return x;
#endif
	return x - ed->L[a] * nearbyint(x / ed->L[a]);
}

/* Cell c (base coordinate plus an offset) on axis a, wrapped on periodic
 * axes; -1 beyond the end of a walled axis. */
static inline int32_t FN(cell_at)(const struct ed *ed, int a, int32_t c)
{
#if WALLS
	if (!ed->periodic[a])
		return c >= 0 && c < ed->nc[a] ? c : -1;
#endif
	return (c + ed->nc[a]) % ed->nc[a];
}

/* Smallest surface gap over all neighbouring pairs at the current time
 * (and with walls, between particles and walls). */
static double FN(min_gap)(const struct ed *ed)
{
	const P_T *P = ed->p;
	double best = INFINITY;
	for (uint32_t i = 0; i < ed->n; i++) {
		const ev_t *e = &ed->ev[i];
		int32_t cc[3] = {0, 0, 0};
		double ri[D];
#if WALLS
		if (ed->gone && ed->gone[i])
			continue;
#endif
		FOR_AXES(a)
			ri[a] = FN(pos_now)(ed, &P[i], a);
#if WALLS
		FOR_AXES(a) {
			if (ed->periodic[a])
				continue;
			for (int w = 2 * a; w < 2 * a + 2; w++) {
				const wall_t *W = &ed->wall[w];
				const double s = (w & 1) ? -1.0 : 1.0;
				double g = s * (ri[a] - W->rest) - FN(rad)(ed, i);
				if (W->A != 0.0)
					g -= W->A * sin(W->ph + W->omega * ed->t);
				g -= W->pu * (ed->t - W->pt0);   /* a dispenser's piston (0 for other walls) */
				if (g < best)
					best = g;
			}
		}
		for (int k = 0; k < ed->nobst; k++) {
			double r2 = 0.0;
			FOR_AXES(a) {
				double x = FN(min_image)(ed, a, ri[a] - ed->obst[k].c[a]);
				r2 += x * x;
			}
			double g = sqrt(r2) - FN(obst_S)(ed, i, k);
			if (g < best)
				best = g;
		}
#endif
#if D == 3
		for (int kz = 0; kz < ed->no[2]; kz++) {
			if ((cc[2] = FN(cell_at)(ed, 2, e->cc[2] + ed->off[2][kz])) < 0)
				continue;
#endif
		for (int ky = 0; ky < ed->no[1]; ky++) {
			if ((cc[1] = FN(cell_at)(ed, 1, e->cc[1] + ed->off[1][ky])) < 0)
				continue;
			for (int kx = 0; kx < ed->no[0]; kx++) {
				if ((cc[0] = FN(cell_at)(ed, 0, e->cc[0] + ed->off[0][kx])) < 0)
					continue;
				for (int32_t j = ed->head[FN(cell_index)(ed, cc)]; j >= 0; j = *FN(link)(ed, j)) {
					if ((uint32_t)j <= i)
						continue;
					double r2 = 0.0;
					FOR_AXES(a) {
						double x = FN(min_image)(ed, a, ri[a] - FN(pos_now)(ed, &P[j], a));
						r2 += x * x;
					}
#if SPEC
					double g = sqrt(r2) - (ed->prad[i] + ed->prad[j]);
#else
					double g = sqrt(r2) - ed->sigma;
#endif
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

#if !WALLS
/* All particles to the present time, wrapped into the box, and filed in
 * the cells of their positions. */
static void FN(resync)(struct ed *ed)
{
	P_T *P = ed->p;
	cells_clear(ed);
	for (uint32_t i = 0; i < ed->n; i++) {
		FN(advance)(ed, &P[i], ed->t);
		FOR_AXES(a) {
			if (P[i].r[a] < 0.0) {
				P[i].r[a] += ed->L[a];
				FN(image)(ed, i, a, -1);
			} else if (P[i].r[a] >= ed->L[a]) {
				P[i].r[a] -= ed->L[a];
				FN(image)(ed, i, a, 1);
			}
		}
	}
	for (uint32_t i = ed->n; i-- > 0;)
		FN(place)(ed, i);
}

#endif

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
#if WALLS
			/* within reach of no wall (ed->plo, phi: the box on periodic axes) */
			FOR_AXES(a)
				P[i].r[a] = ed->plo[a] + rng_uniform(rng) * (ed->phi[a] - ed->plo[a]);
#else
			FOR_AXES(a)
				P[i].r[a] = rng_uniform(rng) * ed->L[a];
#endif
			P[i].t = 0.0;
			int32_t cc[3] = {0, 0, 0}, base[3] = {0, 0, 0};
			FOR_AXES(a) {
				base[a] = (int32_t)floor(P[i].r[a] / ed->cw[a]);
				if (base[a] >= ed->nc[a]) base[a] = ed->nc[a] - 1;
			}
			int clash = 0;
#if WALLS
			clash = !obst_clear(ed, P[i].r);
#endif
#if D == 3
			for (int kz = 0; kz < ed->no[2] && !clash; kz++) {
				if ((cc[2] = FN(cell_at)(ed, 2, base[2] + ed->off[2][kz])) < 0)
					continue;
#endif
			for (int ky = 0; ky < ed->no[1] && !clash; ky++) {
				if ((cc[1] = FN(cell_at)(ed, 1, base[1] + ed->off[1][ky])) < 0)
					continue;
				for (int kx = 0; kx < ed->no[0] && !clash; kx++) {
					if ((cc[0] = FN(cell_at)(ed, 0, base[0] + ed->off[0][kx])) < 0)
						continue;
					for (int32_t j = ed->head[FN(cell_index)(ed, cc)]; j >= 0; j = *FN(link)(ed, j)) {
						double r2 = 0.0;
						FOR_AXES(a) {
							double x = FN(min_image)(ed, a, P[i].r[a] - P[j].r[a]);
							r2 += x * x;
						}
#if SPEC
						const double sij = ed->prad[i] + ed->prad[j], s2 = sij * sij;
#else
						const double s2 = ed->sigma2;
#endif
						if (r2 < s2) {
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

#if WALLS
/* Reservoir walls (inlet_* in ed.c): empty slot i becomes a particle at r
 * (internal coordinates) with velocity v now, unless it would overlap an
 * obstacle or a particle present (then 1 and nothing changes). The
 * caller predicts its events (through the ops table, as for kicks). */
static int FN(enter_s2)(struct ed *ed, uint32_t i, const double *r, const double *v, double s2)
{
	P_T *P = ed->p, *p = &P[i];
	if (!obst_clear(ed, r))
		return 1;
	int32_t cc[3] = {0, 0, 0}, base[3] = {0, 0, 0};
	FOR_AXES(a) {
		base[a] = (int32_t)floor(r[a] / ed->cw[a]);
		if (base[a] < 0) base[a] = 0;
		if (base[a] >= ed->nc[a]) base[a] = ed->nc[a] - 1;
	}
#if D == 3
	for (int kz = 0; kz < ed->no[2]; kz++) {
		if ((cc[2] = FN(cell_at)(ed, 2, base[2] + ed->off[2][kz])) < 0)
			continue;
#endif
	for (int ky = 0; ky < ed->no[1]; ky++) {
		if ((cc[1] = FN(cell_at)(ed, 1, base[1] + ed->off[1][ky])) < 0)
			continue;
		for (int kx = 0; kx < ed->no[0]; kx++) {
			if ((cc[0] = FN(cell_at)(ed, 0, base[0] + ed->off[0][kx])) < 0)
				continue;
			for (int32_t j = ed->head[FN(cell_index)(ed, cc)]; j >= 0; j = *FN(link)(ed, j)) {
				double r2 = 0.0;
				FOR_AXES(a) {
					double x = FN(min_image)(ed, a, r[a] - FN(pos_now)(ed, &P[j], a));
					r2 += x * x;
				}
#if SPEC
				const double sij = ed->prad[i] + ed->prad[j];   /* mixtures: the pair's contact, scaled as s2 */
				if (r2 < s2 * (sij * sij / ed->sigma2))
					return 1;
#else
				if (r2 < s2)
					return 1;
#endif
			}
		}
	}
#if D == 3
	}
#endif
	FN(energy_to)(ed, ed->t);
	double v2 = 0.0;
	const double m = FN(mass)(ed, i);
	FOR_AXES(a) {
		p->r[a] = r[a];
		p->v[a] = v[a];
		v2 += v[a] * v[a];
#if GRAV
		ed->psum[a] += (SPEC ? m / ed->mass : 1.0) * v[a];
#endif
	}
	p->t = ed->t;
	ed->ekin_cur += 0.5 * m * v2;
#if SPEC
	mix_present(ed, ed->spc[i], 1);
#endif
	ed->gone[i] = 0;
	ed->n_gone--;
	if (ed->tlast)
		ed->tlast[i] = -INFINITY;
	p->count++;
	FN(place)(ed, i);
	return 0;
}

static int FN(enter)(struct ed *ed, uint32_t i, const double *r, const double *v)
{
	return FN(enter_s2)(ed, i, r, v, ed->sigma2);
}

/* Dispensers: the same for a particle of a template layer, whose pairs
 * may touch a rounding error inside contact (the template's own pairs, and
 * the particles the piston pushed, a rounding error beyond its plane):
 * refused only below (1 - 1e-9) sigma. */
static int FN(enter_layer)(struct ed *ed, uint32_t i, const double *r, const double *v)
{
	return FN(enter_s2)(ed, i, r, v, ed->sigma2 * (1.0 - 1e-9));
}
#endif

/* Driving (thermostats, drive_* in ed.c): particle i brought to the
 * present; its position (scene coordinates, periodic axes folded) and
 * velocity now. */
static void FN(kick_get)(struct ed *ed, uint32_t i, double *r, double *v)
{
	P_T *p = &((P_T *)ed->p)[i];
	FN(advance)(ed, p, ed->t);
	FOR_AXES(a) {
		double x = p->r[a];
#if WALLS
		if (!ed->periodic[a]) {
			r[a] = x - ed->org[a];
			v[a] = p->v[a];
			continue;
		}
#endif
		x = fmod(x, ed->L[a]);
		if (x < 0.0)
			x += ed->L[a];
		r[a] = x >= ed->L[a] ? 0.0 : x;
		v[a] = p->v[a];
	}
}

/* Particle i (at the present, kick_get()) gets velocity v: the running
 * energy follows, stale predictions of others go (its counter moves on). */
static void FN(kick_set)(struct ed *ed, uint32_t i, const double *v)
{
	P_T *p = &((P_T *)ed->p)[i];
	FN(energy_to)(ed, ed->t);
	double de = 0.0;
	const double m = FN(mass)(ed, i);
	FOR_AXES(a) {
		de += v[a] * v[a] - p->v[a] * p->v[a];
#if GRAV
		ed->psum[a] += (SPEC ? m / ed->mass : 1.0) * (v[a] - p->v[a]);
#endif
		p->v[a] = v[a];
	}
	ed->ekin_cur += 0.5 * m * de;
	p->count++;
	/* The caller (drive_kick()) predicts i's events afresh through the ops
	 * table: a direct call here would be one more caller of the hot
	 * kernels and could change GCC's inlining of them into the event loop. */
}
