/* Speed and communication of one dsmc system over MPI ranks (dsmcp.h, dsmcrun.h): time per step, migrants, bytes, messages, imbalance. */
#include <math.h>
#include <mpi.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "mc/dsmc.h"
#include "mc/dsmcp.h"
#include "par/dsmcrun.h"
#include "scene.h"

/*
 * usage: mpirun -np P dsmcp_bench DIM N STEPS [serial|split [hsmc]]
 * An elastic gas at volume fraction 0.05 (cells of one mean free path, the
 * default step of 0.2 mean free times), 2 warm-up steps, then STEPS timed
 * steps. One JSON line from rank 0: seconds per step (the slowest rank's
 * total / STEPS), moves per second, and per step over all ranks: migrants,
 * bytes and messages sent to other ranks; imbalance = max / mean over ranks
 * of the particles held and of the time outside MPI calls, and the
 * largest time outside MPI calls per step (compute_s_per_step_max: what the
 * step would cost if waiting in MPI cost nothing), and the CPU seconds
 * per step outside MPI calls, largest rank and all ranks (the work, apart
 * from how the shared cores were handed out); the largest peak resident
 * memory of a rank (set-up included) and rank 0's dsmcp_memory() per
 * particle it holds.
 * "serial" (one rank): dsmc.c's own step (dsmc_advance) on the same gas
 * (its CPU seconds per step and peak resident memory too),
 * for the ratio to the decomposed path. "hsmc": method hsmc at volume
 * fraction 0.5, cells of 2 diameters (full cells, cell-cell collisions).
 */
/* Peak resident memory of this process (VmHWM, /proc/self/status), bytes; 0 if unknown. */
static double peak_rss(void)
{
	char line[256];
	double kb = 0;
	FILE *f = fopen("/proc/self/status", "r");
	while (f && fgets(line, sizeof line, f))
		if (!strncmp(line, "VmHWM:", 6))
			kb = atof(line + 6);
	if (f)
		fclose(f);
	return kb * 1024;
}

int main(int argc, char **argv)
{
	int rank, P;
	MPI_Init(&argc, &argv);
	MPI_Comm_rank(MPI_COMM_WORLD, &rank);
	MPI_Comm_size(MPI_COMM_WORLD, &P);
	if (argc < 4) {
		if (rank == 0)
			fprintf(stderr, "usage: dsmcp_bench DIM N STEPS [serial]\n");
		MPI_Finalize();
		return 2;
	}
	const int dim = atoi(argv[1]), steps = atoi(argv[3]), serial = argc > 4 && !strcmp(argv[4], "serial");
	const int hsmc = argc > 5 && !strcmp(argv[5], "hsmc");
	const double N = atof(argv[2]);
	char json[512], msg[512];
	snprintf(json, sizeof json,
	         "{\"method\":\"%s\",\"dimensions\":%d,\"particles\":{\"count\":%.0f,\"volume_fraction\":%s,"
	         "\"initial\":{\"positions\":\"random\"}},\"collisions\":{\"restitution\":1},"
	         "\"run\":{\"seed\":9,\"until\":{\"time\":1e9}}%s}", hsmc ? "hsmc" : "dsmc", dim, N, hsmc ? "0.5" : "0.05",
	         hsmc ? ",\"hsmc\":{\"cell_size\":2}" : "");
	scene_t s;
	if (scene_parse(json, strlen(json), &s, msg, sizeof msg) != SCENE_OK) {
		fprintf(stderr, "%s\n", msg);
		MPI_Abort(MPI_COMM_WORLD, 2);
	}
	if (serial) {
		int err;
		dsmc_t *d = dsmc_create(&s, 0, &err, msg, sizeof msg);
		if (!d) {
			fprintf(stderr, "%s\n", msg);
			MPI_Abort(MPI_COMM_WORLD, 1);
		}
		dsmc_advance(d, INFINITY, UINT64_MAX, 2);
		struct timespec c0, c1;
		clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &c0);
		double t0 = MPI_Wtime();
		dsmc_advance(d, INFINITY, UINT64_MAX, (uint64_t)steps);
		double sec = (MPI_Wtime() - t0) / steps;
		clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &c1);
		double cpu = ((double)(c1.tv_sec - c0.tv_sec) + 1e-9 * (double)(c1.tv_nsec - c0.tv_nsec)) / steps;
		printf("{\"mode\":\"serial\",\"method\":\"%s\",\"dim\":%d,\"N\":%.0f,\"ranks\":1,\"steps\":%d,\"s_per_step\":%.6g,"
		       "\"moves_per_s\":%.4g,\"cpu_s_per_step\":%.6g,\"peak_rss_bytes_max\":%.0f}\n", hsmc ? "hsmc" : "dsmc", dim, N,
		       steps, sec, N / sec, cpu, peak_rss());
		dsmc_destroy(d);
		MPI_Finalize();
		return 0;
	}
	dsmcp_t *d = dsmcrun_create(&s, rank, P, msg, sizeof msg);
	if (!d) {
		fprintf(stderr, "%s\n", msg);
		MPI_Abort(MPI_COMM_WORLD, 1);
	}
	for (int k = 0; k < 2; k++)
		dsmcrun_step(d, INFINITY, NULL);
	dsmcrun_stats_t st;
	memset(&st, 0, sizeof st);
	MPI_Barrier(MPI_COMM_WORLD);
	for (int k = 0; k < steps; k++)
		if (dsmcrun_step(d, INFINITY, &st) != DSMCP_OK)
			MPI_Abort(MPI_COMM_WORLD, 1);
	double nl = (double)dsmcp_local(d, NULL, NULL, NULL), comp = st.seconds - st.comm_seconds;
	double sums[4] = {(double)st.migrants, (double)st.bytes, (double)st.messages, nl};
	double maxs[5] = {st.seconds, nl, comp, st.cpu_compute, peak_rss()}, comp_sum = comp, cpu_sum = st.cpu_compute;
	MPI_Allreduce(MPI_IN_PLACE, sums, 4, MPI_DOUBLE, MPI_SUM, MPI_COMM_WORLD);
	MPI_Allreduce(MPI_IN_PLACE, maxs, 5, MPI_DOUBLE, MPI_MAX, MPI_COMM_WORLD);
	MPI_Allreduce(MPI_IN_PLACE, &cpu_sum, 1, MPI_DOUBLE, MPI_SUM, MPI_COMM_WORLD);
	MPI_Allreduce(MPI_IN_PLACE, &comp_sum, 1, MPI_DOUBLE, MPI_SUM, MPI_COMM_WORLD);
	if (rank == 0) {
		int p0, p1, nc[3];
		dsmcp_slab(d, &p0, &p1, nc);
		double sec = maxs[0] / steps;
		printf("{\"mode\":\"split\",\"method\":\"%s\",\"dim\":%d,\"N\":%.0f,\"ranks\":%d,\"planes\":%d,\"steps\":%d,\"s_per_step\":%.6g,"
		       "\"moves_per_s\":%.4g,\"migrants_per_step\":%.1f,\"bytes_per_step\":%.0f,\"messages_per_step\":%.2f,"
		       "\"imbalance_particles\":%.4f,\"imbalance_compute\":%.3f,\"compute_s_per_step_max\":%.6g,\"cpu_compute_s_per_step_max\":%.6g,\"cpu_compute_s_per_step_sum\":%.6g,\"peak_rss_bytes_max\":%.0f,\"bytes_per_particle_held\":%.1f}\n",
		       hsmc ? "hsmc" : "dsmc", dim, N, P, nc[dim - 1], steps, sec, N / sec, sums[0] / steps, sums[1] / steps, sums[2] / steps,
		       maxs[1] / (sums[3] / P), comp_sum > 0 ? maxs[2] / (comp_sum / P) : 0.0, maxs[2] / steps, maxs[3] / steps, cpu_sum / steps, maxs[4], dsmcp_memory(d) / (nl > 0 ? nl : 1));
	}
	dsmcp_destroy(d);
	MPI_Finalize();
	return 0;
}
