/* Helper of tests/ped_mpi_test.sh: the parallel ED core over MPI (pedmpi) against the same ranks simulated in one process (ped_sim_run), bit for bit. */
#include <math.h>
#include <mpi.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "ed/ed.h"
#include "par/ped.h"
#include "par/pedmpi.h"
#include "place.h"
#include "scene.h"

/* Prints "ok - ..." / "not ok - ..." lines on rank 0 (tests/tap_lib.sh report()). */

static int same_log(const ped_t *a, const ped_t *b)
{
	size_t na, nb;
	const ped_coll_t *la = ped_log(a, &na), *lb = ped_log(b, &nb);
	return na == nb && (na == 0 || !memcmp(la, lb, na * sizeof *la));
}

/* step > 0: the particles placed in the lower fraction step of the last axis (a density step) and the run load
 * balanced (ped.h: ped_sim_run_bal(), the sched's balance over MPI). */
static void check(int dim, long n, double phi, double e, double tc, double t_end, int rank, int P, double step)
{
	char json[768], err[256], init[200] = "";
	if (step > 0.0)
		snprintf(init, sizeof init, ",\"initial\":{\"positions\":\"random\"}");
	snprintf(json, sizeof json,
	         "{\"method\":\"ed\",\"dimensions\":%d,\"particles\":{\"count\":%ld,\"volume_fraction\":%g%s},"
	         "\"collisions\":{\"restitution\":%g,\"tc\":%g},\"run\":{\"until\":{\"time\":1}}}",
	         dim, n, phi, init, e, tc);
	scene_t sc;
	int rc = -1, good = 0;
	ped_t **sim = calloc((size_t)P, sizeof *sim), *mine = NULL;
	double *pos = malloc((size_t)n * (size_t)dim * sizeof(double)), *vel = malloc((size_t)n * (size_t)dim * sizeof(double));
	ed_t *ed = NULL;
	double *placed = NULL;
	if (!sim || !pos || !vel || scene_parse(json, strlen(json), &sc, err, sizeof err) != SCENE_OK)
		goto done;
	if (step > 0.0) {   /* particles.initial.region's lower part of the box, placed as run_create() does */
		sc.has_region = 1;
		for (int a = 0; a < 3; a++) {
			sc.region_lo[a] = 0.0;
			sc.region_hi[a] = a + 1 == dim ? step * sc.box[a] : sc.box[a];
		}
		if (!(placed = malloc((size_t)n * (size_t)dim * sizeof(double))) ||
		    place_region(&sc, sc.stream, placed, err, sizeof err) != PLACE_OK)
			goto done;
		sc.init_pos = placed;
	}
	if (!(ed = ed_create(&sc, &rc, err, sizeof err)))
		goto done;
	ed_state(ed, pos, vel);   /* every rank builds the same state from the scene */
	ped_params_t p = {.dim = dim, .sigma = 2.0 * sc.radius, .mass = sc.mass, .e = e, .tc = tc, .ranks = P};
	for (int a = 0; a < 3; a++)
		p.L[a] = a < dim ? sc.box[a] : 1.0;
	ped_grid(&p, (uint64_t)n);
	for (int r = 0; r < P; r++) {
		if (!(sim[r] = ped_create(&p, r, (size_t)n, &rc)))
			goto done;
		ped_log_on(sim[r]);
		ped_load(sim[r], (uint64_t)n, pos, vel);
	}
	ped_stats_t s1, s2;
	int rs = ped_sim_run_bal(sim, P, (uint64_t)n, t_end, t_end / 16, -1.0, 0, step > 0.0, &s1);
	if (!(mine = ped_create(&p, rank, (size_t)n, &rc)))
		goto done;
	ped_log_on(mine);
	ped_load(mine, (uint64_t)n, pos, vel);
	ped_sched_t sched;
	double reached;
	ped_sched_init(&sched, t_end, t_end / 16);
	sched.balance = step > 0.0;
	int rm = pedmpi_advance(mine, MPI_COMM_WORLD, &sched, 0.0, t_end, NULL, &reached);
	s2 = sched.st;
	ped_totals_t ta, tb;
	ped_totals(sim[rank], &ta);
	ped_totals(mine, &tb);
	good = rs == PED_OK && rm == PED_OK && same_log(sim[rank], mine) && ta.collisions > 0 && ta.ekin == tb.ekin &&
	       ta.owned == tb.owned && ta.events == tb.events && s1.rounds == s2.rounds && s1.rollbacks == s2.rollbacks &&
	       s1.rebalances == s2.rebalances && (step > 0.0) == (s2.rebalances > 0);
done:
	{
		int all;
		MPI_Allreduce(&good, &all, 1, MPI_INT, MPI_MIN, MPI_COMM_WORLD);
		uint64_t c = 0, call = 0;
		if (mine) {
			ped_totals_t t;
			ped_totals(mine, &t);
			c = t.collisions;
		}
		MPI_Reduce(&c, &call, 1, MPI_UINT64_T, MPI_SUM, 0, MPI_COMM_WORLD);
		if (rank == 0)
			printf("%s - %dD N=%ld e=%g%s: %d MPI ranks run the in-process simulation of %d ranks bit for bit "
			       "(%llu collisions, %.1f per particle)\n",
			       all ? "ok" : "not ok", dim, n, e, step > 0.0 ? " density step, balanced" : "", P, P,
			       (unsigned long long)call, 2.0 * (double)call / (double)n);
	}
	for (int r = 0; r < P; r++)
		ped_destroy(sim ? sim[r] : NULL);
	ped_destroy(mine);
	free(sim);
	free(pos);
	free(vel);
	free(placed);
	ed_destroy(ed);
}

#if defined(__SANITIZE_ADDRESS__)
/* As engine/main.c: Open MPI's components are dlclose'd at exit with allocations they keep, and the fast
 * unwinder's stacks name an "<unknown module>" that tests/lsan.supp cannot match; the slow one reaches libmpi. */
const char *__asan_default_options(void);
const char *__asan_default_options(void) { return "fast_unwind_on_malloc=0"; }
#endif

int main(int argc, char **argv)
{
	MPI_Init(&argc, &argv);
	int rank, P;
	MPI_Comm_rank(MPI_COMM_WORLD, &rank);
	MPI_Comm_size(MPI_COMM_WORLD, &P);
	check(2, 1500, 0.3, 0.9, 1e-3, 3.0, rank, P, 0.0);
	check(3, 1500, 0.25, 1.0, 0.0, 1.0, rank, P, 0.0);
	check(2, 1500, 0.15, 1.0, 0.0, 3.0, rank, P, 0.4);
	check(3, 1500, 0.1, 0.8, 1e-3, 2.0, rank, P, 0.4);
	MPI_Finalize();
	return 0;
}
