/* Benchmark of the parallel ED core over MPI (engine/par/pedmpi) against the serial engine on the same initial state: wall time, rollbacks, messages, load balance (bench only). */
#include <math.h>
#include <mpi.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "ed/ed.h"
#include "par/ped.h"
#include "par/pedmpi.h"
#include "scene.h"

/*
 * Usage: ped_bench serial|par DIM N PHI E T_END [SYNC_DT [WINDOW]]
 *        ped_bench sim P DIM N PHI E T_END [SYNC_DT [WINDOW]]
 * (WINDOW: the first optimistic window, ped.h; default ped_sched_init()'s,
 * 0: border events in global time order)
 * serial: the serial engine (ed_create, ed_advance to T_END), one process.
 * par: under mpirun -np P: rank 0 builds the same initial state with
 * ed_create and broadcasts it; every rank loads its share and pedmpi_run()
 * runs to T_END. Timed: the runs only (not the set-up). One JSON line on
 * rank 0's stdout.
 * sim: P ranks in one process (ped_sim_run(), no MPI): the same rounds,
 * rollbacks, messages and bytes as par over P MPI ranks (tests/ped_mpi_test.sh
 * checks the runs are the same bit for bit), without MPI's latency: for the
 * counts at many ranks on a small machine. Its wall time means nothing.
 */

static double now(void)
{
	struct timespec ts;
	clock_gettime(CLOCK_MONOTONIC, &ts);
	return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

static int sim_main(const scene_t *sc, int P, int dim, long n, double e, double t_end, double sync_dt, double window)
{
	int rc;
	char err[256];
	size_t nd = (size_t)n * (size_t)dim;
	double *pos = malloc(nd * sizeof(double)), *vel = malloc(nd * sizeof(double));
	ed_t *ed = ed_create(sc, &rc, err, sizeof err);
	if (!ed || !pos || !vel) {
		fprintf(stderr, "%s\n", ed ? "no memory" : err);
		return 1;
	}
	ed_state(ed, pos, vel);
	ed_destroy(ed);
	ped_params_t p = {.dim = dim, .sigma = 2.0 * sc->radius, .mass = sc->mass, .e = e, .tc = 0.0, .ranks = P};
	for (int a = 0; a < 3; a++)
		p.L[a] = a < dim ? sc->box[a] : 1.0;
	ped_grid(&p, (uint64_t)n);
	size_t cap = (size_t)(2.0 * (double)n / P) + 50000;
	if (cap > (size_t)n)
		cap = (size_t)n;
	ped_t **pd = calloc((size_t)P, sizeof *pd);
	for (int r = 0; r < P; r++)
		if (!(pd[r] = ped_create(&p, r, cap, &rc)) || ped_load(pd[r], (uint64_t)n, pos, vel) != PED_OK) {
			fprintf(stderr, "rank %d: ped_create/ped_load failed (%d)\n", r, rc);
			return 1;
		}
	free(pos);
	free(vel);
	ped_stats_t st;
	double t0 = now();
	rc = ped_sim_run(pd, P, t_end, sync_dt, window, 0, &st);
	double wall = now() - t0;
	double sum[3] = {0, 0, 0}, maxdone = 0;
	for (int r = 0; r < P; r++) {
		ped_totals_t tt;
		ped_totals(pd[r], &tt);
		sum[0] += (double)tt.collisions;
		sum[1] += (double)tt.events;
		sum[2] += (double)tt.events_done;
		maxdone = (double)tt.events_done > maxdone ? (double)tt.events_done : maxdone;
		ped_destroy(pd[r]);
	}
	free(pd);
	printf("{\"mode\":\"sim\",\"P\":%d,\"dim\":%d,\"N\":%ld,\"t_end\":%g,\"window\":%g,\"rc\":%d,\"collisions\":%.0f,\"events\":%.0f,"
	       "\"events_done\":%.0f,\"wall\":%.4f,\"rounds\":%llu,\"syncs\":%llu,\"rollbacks\":%llu,"
	       "\"done_per_committed\":%.4f,\"events_per_round\":%.2f,\"messages_per_event\":%.5f,"
	       "\"bytes_per_event\":%.3f,\"imbalance\":%.4f}\n",
	       P, dim, n, t_end, window, rc, sum[0], sum[1], sum[2], wall, (unsigned long long)st.rounds,
	       (unsigned long long)st.syncs, (unsigned long long)st.rollbacks, sum[2] / sum[1], sum[1] / (double)st.rounds,
	       (double)st.messages / sum[1], (double)st.bytes / sum[1], maxdone / (sum[2] / P));
	return rc == PED_OK ? 0 : 1;
}

int main(int argc, char **argv)
{
	int simP = 0;
	if (argc > 2 && !strcmp(argv[1], "sim")) {
		simP = atoi(argv[2]);
		argv++;
		argc--;
	}
	if (argc < 7) {
		fprintf(stderr, "usage: %s serial|par|sim P DIM N PHI E T_END [SYNC_DT [WINDOW]]\n", argv[0]);
		return 2;
	}
	int par = simP > 0 || !strcmp(argv[1], "par"), dim = atoi(argv[2]);
	long n = atol(argv[3]);
	double phi = atof(argv[4]), e = atof(argv[5]), t_end = atof(argv[6]);
	double sync_dt = argc > 7 ? atof(argv[7]) : 0.05, window = argc > 8 ? atof(argv[8]) : -1.0;
	char json[512], err[256];
	snprintf(json, sizeof json,
	         "{\"method\":\"ed\",\"dimensions\":%d,\"particles\":{\"count\":%ld,\"volume_fraction\":%g},"
	         "\"collisions\":{\"restitution\":%g},\"run\":{\"until\":{\"time\":1}}}",
	         dim, n, phi, e);
	scene_t sc;
	if (scene_parse(json, strlen(json), &sc, err, sizeof err) != SCENE_OK) {
		fprintf(stderr, "%s\n", err);
		return 2;
	}
	int rc;
	if (!par) {
		ed_t *ed = ed_create(&sc, &rc, err, sizeof err);
		if (!ed) {
			fprintf(stderr, "%s\n", err);
			return 1;
		}
		double t0 = now();
		ed_advance(ed, t_end, UINT64_MAX, UINT64_MAX);
		double wall = now() - t0;
		printf("{\"mode\":\"serial\",\"P\":1,\"dim\":%d,\"N\":%ld,\"t_end\":%g,\"collisions\":%llu,\"events\":%llu,\"wall\":%.4f}\n",
		       dim, n, t_end, (unsigned long long)ed_collisions(ed), (unsigned long long)ed_events(ed), wall);
		ed_destroy(ed);
		return 0;
	}
	if (simP > 0)
		return sim_main(&sc, simP, dim, n, e, t_end, sync_dt, window);
	MPI_Init(&argc, &argv);
	int rank, P;
	MPI_Comm_rank(MPI_COMM_WORLD, &rank);
	MPI_Comm_size(MPI_COMM_WORLD, &P);
	size_t nd = (size_t)n * (size_t)dim;
	double *pos = malloc(nd * sizeof(double)), *vel = malloc(nd * sizeof(double));
	if (rank == 0) {
		ed_t *ed = ed_create(&sc, &rc, err, sizeof err);
		if (!ed) {
			fprintf(stderr, "%s\n", err);
			MPI_Abort(MPI_COMM_WORLD, 1);
		}
		ed_state(ed, pos, vel);
		ed_destroy(ed);
	}
	MPI_Bcast(pos, (int)nd, MPI_DOUBLE, 0, MPI_COMM_WORLD);
	MPI_Bcast(vel, (int)nd, MPI_DOUBLE, 0, MPI_COMM_WORLD);
	ped_params_t p = {.dim = dim, .sigma = 2.0 * sc.radius, .mass = sc.mass, .e = e, .tc = 0.0, .ranks = P};
	for (int a = 0; a < 3; a++)
		p.L[a] = a < dim ? sc.box[a] : 1.0;
	ped_grid(&p, (uint64_t)n);
	size_t cap = (size_t)(2.0 * (double)n / P) + 50000;
	if (cap > (size_t)n)
		cap = (size_t)n;
	ped_t *pd = ped_create(&p, rank, cap, &rc);
	if (!pd || ped_load(pd, (uint64_t)n, pos, vel) != PED_OK) {
		fprintf(stderr, "rank %d: ped_create/ped_load failed (%d)\n", rank, rc);
		MPI_Abort(MPI_COMM_WORLD, 1);
	}
	free(pos);
	free(vel);
	ped_stats_t st;
	MPI_Barrier(MPI_COMM_WORLD);
	double t0 = now();
	rc = pedmpi_run(pd, MPI_COMM_WORLD, t_end, sync_dt, window, &st);
	double wall = now() - t0;
	ped_totals_t tt;
	ped_totals(pd, &tt);
	double mine[5] = {(double)tt.collisions, (double)tt.events, (double)tt.events_done, (double)st.messages, (double)st.bytes};
	double sum[5], maxdone, maxwall;
	MPI_Reduce(mine, sum, 5, MPI_DOUBLE, MPI_SUM, 0, MPI_COMM_WORLD);
	MPI_Reduce(&mine[2], &maxdone, 1, MPI_DOUBLE, MPI_MAX, 0, MPI_COMM_WORLD);
	MPI_Reduce(&wall, &maxwall, 1, MPI_DOUBLE, MPI_MAX, 0, MPI_COMM_WORLD);
	if (rank == 0)
		printf("{\"mode\":\"par\",\"P\":%d,\"dim\":%d,\"N\":%ld,\"t_end\":%g,\"rc\":%d,\"collisions\":%.0f,\"events\":%.0f,"
		       "\"events_done\":%.0f,\"wall\":%.4f,\"rounds\":%llu,\"syncs\":%llu,\"rollbacks\":%llu,"
		       "\"done_per_committed\":%.4f,\"events_per_rollback\":%.0f,\"events_per_round\":%.2f,"
		       "\"messages_per_event\":%.5f,\"bytes_per_event\":%.3f,\"imbalance\":%.4f}\n",
		       P, dim, n, t_end, rc, sum[0], sum[1], sum[2], maxwall, (unsigned long long)st.rounds,
		       (unsigned long long)st.syncs, (unsigned long long)st.rollbacks, sum[2] / sum[1],
		       st.rollbacks ? sum[1] / (double)st.rollbacks : -1.0, sum[1] / (double)st.rounds, sum[3] / sum[1],
		       sum[4] / sum[1], maxdone / (sum[2] / P));
	ped_destroy(pd);
	MPI_Finalize();
	return rc == PED_OK ? 0 : 1;
}
