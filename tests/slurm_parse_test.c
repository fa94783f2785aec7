/* Unit tests of the Slurm backend's pure parts (daemon/slurm.c): state words, scontrol records, sinfo/squeue summaries, batch scripts. */
#include <stdlib.h>
#include <string.h>
#include "slurm.h"
#include "tap.h"

static long iget(const json_t *o, const char *a, const char *b)
{
	const json_t *v = b ? json_object_get(json_object_get(o, a), b) : json_object_get(o, a);
	return json_is_integer(v) ? (long)json_integer_value(v) : -1;
}

int main(void)
{
	/* 1. state words, as squeue/scontrol print them */
	static const struct {
		const char *w;
		slurm_state_t s;
		int final;
	} words[] = {
		{"PENDING", SLURM_PENDING, 0}, {"CONFIGURING", SLURM_PENDING, 0}, {"RUNNING", SLURM_RUNNING, 0},
		{"COMPLETING", SLURM_COMPLETING, 0}, {"SUSPENDED", SLURM_SUSPENDED, 0},
		{"COMPLETED", SLURM_COMPLETED, 1}, {"FAILED", SLURM_FAILED, 1}, {"OUT_OF_MEMORY", SLURM_FAILED, 1},
		{"TIMEOUT", SLURM_TIMEOUT, 1}, {"NODE_FAIL", SLURM_NODE_FAIL, 1}, {"PREEMPTED", SLURM_PREEMPTED, 1},
		{"CANCELLED by 0", SLURM_CANCELLED, 1}, {"CANCELLED", SLURM_CANCELLED, 1},
		{"SOMETHING_NEW", SLURM_FAILED, 1},
	};
	int good = 1;
	for (size_t i = 0; i < sizeof(words) / sizeof(words[0]); i++) {
		slurm_state_t s = slurm_state_parse(words[i].w);
		if (s != words[i].s || slurm_state_final(s) != words[i].final) {
			diag("%s -> %s", words[i].w, slurm_state_name(s));
			good = 0;
		}
	}
	ok(good, "Slurm state words map to granulard's names (pending, running, ..., an unknown word to failed)");
	ok(!strcmp(slurm_state_name(SLURM_NODE_FAIL), "node_fail") && !strcmp(slurm_state_name(SLURM_GONE), "gone"),
	   "names: node_fail, gone");

	/* 2. scontrol show job -o (a line as Slurm 22.05 prints it, shortened) */
	slurm_job_t j;
	const char *done = "JobId=9 JobName=granulard-3a0d3cec-4-1 UserId=root(0) JobState=COMPLETED Reason=None "
	                   "Dependency=(null) Requeue=0 Restarts=0 BatchFlag=1 ExitCode=0:0 RunTime=00:00:07\n";
	ok(slurm_parse_show_job(done, &j) == SLURM_OK && j.state == SLURM_COMPLETED && !*j.reason && j.exit_code == 0 &&
	   j.exit_signal == 0, "COMPLETED, Reason=None left out, ExitCode 0:0");
	const char *late = "JobId=12 JobName=x XJobState=RUNNING JobState=TIMEOUT Reason=TimeLimit Dependency=(null) "
	                   "ExitCode=4:15\n";
	ok(slurm_parse_show_job(late, &j) == SLURM_OK && j.state == SLURM_TIMEOUT && !strcmp(j.reason, "TimeLimit") &&
	   j.exit_code == 4 && j.exit_signal == 15, "TIMEOUT with reason TimeLimit, ExitCode 4:15 (a key inside another word, XJobState=, is not taken)");
	const char *wait = "JobId=13 JobName=x JobState=PENDING Reason=Resources Dependency=(null) ExitCode=0:0\n";
	ok(slurm_parse_show_job(wait, &j) == SLURM_OK && j.state == SLURM_PENDING && !strcmp(j.reason, "Resources"),
	   "PENDING (Resources)");
	ok(slurm_parse_show_job("slurm_load_jobs error: Invalid job id specified\n", &j) == SLURM_EFAIL,
	   "no JobState: an error");

	/* squeue -h -t all -j 7,8,9,10 -o "%i|%T|%r": job 10 is not listed (unknown to Slurm) */
	const int64_t ids[] = {7, 8, 9, 10};
	slurm_job_t js[4];
	slurm_parse_squeue("8|PENDING|Resources\n7|RUNNING|None\n9|TIMEOUT|TimeLimit\nnot a line\n", ids, 4, js);
	ok(js[0].state == SLURM_RUNNING && !*js[0].reason && js[1].state == SLURM_PENDING &&
	   !strcmp(js[1].reason, "Resources") && js[2].state == SLURM_TIMEOUT && !strcmp(js[2].word, "TIMEOUT") &&
	   js[3].state == SLURM_GONE, "squeue lines matched to ids in any order; an id not listed is gone");

	/* 3. sinfo -o "%P|%D|%T|%C" and squeue -t pending -o %P */
	const char *si = "debug*|2|mixed|6/2/0/8\n"
	                 "debug*|1|idle|0/4/0/4\n"
	                 "debug*|1|drained*|0/0/4/4\n"
	                 "big|3|allocated|48/0/0/48\n"
	                 "garbage line\n";
	const char *sq = "debug\nbig\ndebug\nbig\nbig\n";
	json_t *p = slurm_parse_partition("", si, sq);
	ok(p && !strcmp(json_string_value(json_object_get(p, "partition")), "debug") && iget(p, "nodes", "total") == 4 &&
	   iget(p, "nodes", "mixed") == 2 && iget(p, "nodes", "idle") == 1 && iget(p, "nodes", "other") == 1 &&
	   iget(p, "nodes", "allocated") == 0 && iget(p, "cpus", "allocated") == 6 && iget(p, "cpus", "idle") == 6 &&
	   iget(p, "cpus", "other") == 4 && iget(p, "cpus", "total") == 16 && iget(p, "pending_jobs", NULL) == 2,
	   "no partition configured: the default one (debug*), its 4 nodes and 16 CPUs summed, 2 pending jobs");
	json_decref(p);
	p = slurm_parse_partition("big", si, sq);
	ok(p && iget(p, "nodes", "allocated") == 3 && iget(p, "cpus", "allocated") == 48 &&
	   iget(p, "pending_jobs", NULL) == 3, "partition big: 3 allocated nodes, 48 CPUs, 3 pending jobs");
	json_decref(p);

	/* 4. the batch script */
	char *argv[] = {"/opt/granular engine", "run", "/shared/it's/scene.json", NULL};
	slurm_script_t sc = {.name = "granulard-0000abcd-7-2", .ranks = 8, .time_limit = 61, .partition = "",
	                     .account = "phys", .dir = "/shared/x", .out = "attempt-2.out", .err = "attempt-2.err",
	                     .srun = "srun", .mpi = "pmix", .argv = argv};
	char *t = slurm_script(&sc);
	ok(t && strstr(t, "#SBATCH --ntasks=8\n") && strstr(t, "#SBATCH --time=2\n") && !strstr(t, "--partition") &&
	   strstr(t, "#SBATCH --account=phys\n") && strstr(t, "#SBATCH --no-requeue\n") &&
	   strstr(t, "#SBATCH --output=attempt-2.out\n"), "script: --ntasks, --time in minutes rounded up, no empty partition");
	ok(t && strstr(t, "exec 'srun' --mpi=pmix --kill-on-bad-exit=1 '/opt/granular engine' 'run' "
	                  "'/shared/it'\\''s/scene.json'\n"), "script: srun line with every word single-quoted");
	free(t);
	plan(tap_n);
	return done_testing();
}
