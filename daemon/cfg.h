/* Daemon configuration: one table of keys (type, range, default) read from flags and a config file. */
#pragma once

#include <stddef.h>

/*
 * Contract
 * - Every key is both a config-file line `key = value` and a flag
 *   `--key value` (underscores may be written as dashes). Precedence:
 *   defaults < config file < flags.
 * - cfg_* return 0 or CFG_EINVAL with one line in err naming the key (and
 *   FILE:LINE for files) and the reason.
 * - Strings in cfg_t are owned by it (cfg_deinit frees them).
 * - launch is checked when set: every {...} must be one of the
 *   placeholders, a word of its own (the scheduler substitutes whole words),
 *   so a daemon with a broken template refuses to start.
 */

enum { CFG_OK = 0, CFG_EINVAL = -1, CFG_EIO = -2, CFG_EHELP = -3 };

typedef struct {
	char *listen;            /* HOST:PORT (port 0 = ephemeral) */
	char *state_dir;         /* database, jobs/, token */
	char *config;            /* the file read, if any */
	long slots;              /* MPI ranks that may run at once */
	char *engine;            /* granular-engine path ("" = search) */
	char *mpirun;            /* launcher program */
	char *launch;            /* launch template, placeholders {mpirun} {ranks} {engine} {scene} {dir} */
	char *launcher;          /* mpirun | slurm */
	char *slurm_partition;   /* "" = the cluster's default */
	char *slurm_account;     /* "" = the user's default */
	long slurm_time_limit;   /* seconds per attempt, 0 = the partition's default */
	char *slurm_mpi;         /* srun --mpi plugin: pmix | pmi2 | none */
	double slurm_poll;       /* seconds between state queries of a job */
	char *sbatch, *srun, *squeue, *scontrol, *scancel, *sinfo;   /* Slurm programs */
	char *token;             /* bearer token ("" = state_dir/token, generated) */
	char *read_auth;         /* auto | open | token */
	char *allowed_hosts;     /* extra Host values this server answers to */
	long max_body;           /* bytes */
	long max_json_depth;
	long max_connections;
	long per_ip_connections; /* 0 = unlimited */
	long header_timeout;     /* seconds to a complete request head */
	long request_timeout;    /* seconds for a body; of silence while answering */
	long http_workers;       /* handler threads */
	long max_particles;
	long max_ranks;          /* 0 = slots */
	long max_wall_seconds;   /* per attempt, 0 = none */
	long max_queued;
	long max_progress_records;
	double progress_rate;    /* progress records stored per second per job (token bucket) */
	long progress_burst;     /* bucket size */
	double progress_flush;   /* seconds between a job's progress commits */
	long max_attempts;       /* launches per job (retries from checkpoints) */
	double cancel_grace;     /* seconds between SIGTERM and SIGKILL */
	double shutdown_grace;   /* seconds to let running jobs checkpoint at shutdown */
	char *log_level;         /* error | warning | info | debug */
	long disk_reserve;       /* bytes of ballast kept in the state dir for disk-full recovery, 0 = none */
	long memory_budget;      /* bytes running jobs may use together (estimates, budget.h); 0 = automatic */
	long max_replicas;       /* largest run.replicas of a job */
	long max_job_output;     /* bytes a job's directory may hold (default and cap of max_output_bytes) */
} cfg_t;

/* Defaults (slots = online CPUs; state_dir = $STATE_DIRECTORY or ./var). */
int cfg_init(cfg_t *c);
void cfg_deinit(cfg_t *c);

/* Apply flags (argv[1..]); --config FILE is read first wherever it appears.
 * CFG_EHELP for --help. */
int cfg_from_args(cfg_t *c, int argc, char **argv, char *err, size_t errlen);
int cfg_load_file(cfg_t *c, const char *path, char *err, size_t errlen);
int cfg_set(cfg_t *c, const char *key, const char *value, char *err, size_t errlen);

/* The table of keys (flag, value name, meaning, range, default; each default
 * once, numbers in digits) for --help, the man page (generated from it at
 * build time) and docs/daemon.md (a test keeps it equal). file is a FILE *.
 * CFG_EINVAL for an unknown format. */
typedef enum { CFG_FMT_TEXT = 0, CFG_FMT_ROFF, CFG_FMT_MARKDOWN } cfg_format_t;
int cfg_print_keys(void *file, cfg_format_t fmt);
/* "text", "man" or "markdown" to a cfg_format_t; CFG_EINVAL otherwise. */
int cfg_format_parse(const char *name);
