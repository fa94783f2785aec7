/* Slurm backend: batch scripts for sbatch, and sbatch/scontrol/scancel/sinfo/squeue run as programs with their output parsed. */
#pragma once

#include <stddef.h>
#include <stdint.h>
#include <jansson.h>
#include "cfg.h"

/*
 * Contract
 * - The Slurm commands are run as programs (the cfg keys sbatch, scontrol,
 *   scancel, sinfo, squeue), with the daemon's environment (SLURM_CONF
 *   included), never through a shell, each bounded by a timeout. So the
 *   daemon needs only Slurm's client tools, as a user does.
 * - Calls return 0 or a negative code with one line in err (the command and
 *   what it said).
 * - slurm_parse_* are pure (no I/O): tested on their own.
 * - Nothing here keeps state; the scheduler owns the jobs.
 */

enum { SLURM_OK = 0, SLURM_EFAIL = -1, SLURM_EGONE = -2 };

/* Slurm job states, as granulard names them (lower case, Slurm's words). */
typedef enum {
	SLURM_PENDING = 0,  /* PENDING, CONFIGURING, REQUEUED, RESV_DEL_HOLD, REQUEUE_HOLD, REQUEUE_FED */
	SLURM_RUNNING,      /* RUNNING, RESIZING, SIGNALING, STAGE_OUT */
	SLURM_SUSPENDED,    /* SUSPENDED, STOPPED */
	SLURM_COMPLETING,   /* COMPLETING */
	SLURM_COMPLETED,
	SLURM_FAILED,       /* FAILED, BOOT_FAIL, OUT_OF_MEMORY, DEADLINE, SPECIAL_EXIT */
	SLURM_TIMEOUT,
	SLURM_NODE_FAIL,
	SLURM_PREEMPTED,
	SLURM_CANCELLED,
	SLURM_GONE,         /* Slurm no longer knows the job (past MinJobAge) */
	SLURM_NSTATES
} slurm_state_t;

const char *slurm_state_name(slurm_state_t s);
/* Slurm's word (JobState=..., squeue %T; a "CANCELLED by 0" suffix is
 * ignored) to a state; SLURM_FAILED for a word it does not know. */
slurm_state_t slurm_state_parse(const char *word);
/* 1 for states after which the job will not run again. */
int slurm_state_final(slurm_state_t s);

typedef struct {
	slurm_state_t state;
	char word[32];          /* Slurm's own word */
	char reason[96];        /* Reason=... ("None" left out) */
	int exit_code, exit_signal;   /* ExitCode=code:signal of the batch script */
} slurm_job_t;

/* One job's line of `scontrol show job -o ID`. SLURM_EFAIL when it has no JobState. */
int slurm_parse_show_job(const char *text, slurm_job_t *out);

/* What a batch script is made of. */
typedef struct {
	const char *name;       /* --job-name */
	int ranks;              /* --ntasks */
	int nodes;              /* --nodes, 0 = Slurm's choice */
	long time_limit;        /* seconds, 0 = none given */
	const char *partition, *account;   /* "" or NULL = none given */
	const char *dir;        /* job directory: --chdir; out/err files live there */
	const char *out, *err;  /* file names (relative to dir) for the engine's stdout and stderr */
	const char *srun, *mpi; /* srun program, --mpi plugin */
	char *const *argv;      /* the engine's command line (NULL-terminated) */
} slurm_script_t;
/* The batch script text (malloc'd), or NULL when out of memory. Words are
 * single-quoted for the shell. */
char *slurm_script(const slurm_script_t *sc);

/* squeue -h -t all -j ID,... -o "%i|%T|%r" output: out[i] for ids[i]: state,
 * word and reason of the listed jobs; SLURM_GONE for ids not listed (Slurm
 * does not know them: to be confirmed with slurm_query()). Exit codes are
 * not in squeue's answer (0). */
void slurm_parse_squeue(const char *text, const int64_t *ids, size_t n, slurm_job_t *out);
/* The states of n jobs with one squeue (slurm_parse_squeue()). */
int slurm_states(const cfg_t *c, const int64_t *ids, size_t n, slurm_job_t *out, char *err, size_t errlen);

/* sbatch --parsable FILE: *job = the new job's id. */
int slurm_submit(const cfg_t *c, const char *script_path, int64_t *job, char *err, size_t errlen);
/* scontrol show job -o ID: SLURM_EGONE when Slurm does not know the id. */
int slurm_query(const cfg_t *c, int64_t job, slurm_job_t *out, char *err, size_t errlen);
/* scancel [--signal=SIG] ID (sig NULL: Slurm's cancel: SIGTERM to the steps, SIGKILL after KillWait). */
int slurm_cancel(const cfg_t *c, int64_t job, const char *sig, char *err, size_t errlen);
/* scancel --name=NAME: every job of that name (after an sbatch whose answer
 * was lost, e.g. past the timeout: it may have submitted). */
int slurm_cancel_name(const cfg_t *c, const char *name, char *err, size_t errlen);
/* squeue -h -n NAME -o %i: the id of a pending or running job of that name, 0 when none. */
int slurm_find(const cfg_t *c, const char *name, int64_t *job, char *err, size_t errlen);

/* sinfo -h -p P -o "%D|%T|%C" lines (node count, state, CPUs A/I/O/T) and
 * squeue -h -p P -t pending -o %i lines (pending job ids): the partition's
 * summary {"partition", "nodes": {"total", "idle", "allocated", "mixed",
 * "other"}, "cpus": {"allocated", "idle", "other", "total"}, "pending_jobs"}. */
json_t *slurm_parse_partition(const char *partition, const char *sinfo_out, const char *squeue_out);
/* The same from the commands. */
int slurm_partition(const cfg_t *c, json_t **out, char *err, size_t errlen);
