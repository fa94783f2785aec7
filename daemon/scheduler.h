/* Job supervisor: claims queued jobs within the slot budget, launches the engine through MPI, follows it to its end. */
#pragma once

#include <stdint.h>
#include "cfg.h"
#include "hub.h"
#include "jobq.h"

/*
 * Contract
 * - One thread owns every child process: it launches, reads progress lines
 *   (the engine's stdout through mpirun) and stderr, reaps, signals. Other
 *   threads only ask (sched_wake, sched_cancel); nothing else touches pids.
 * - The thread never waits on one job: each turn reads at most 64 KiB per
 *   pipe, then serves requests, deadlines and reaping. Progress records are
 *   thinned to cfg progress_rate/progress_burst per job and stored in one
 *   transaction per job every progress_flush seconds (ingest.h), then
 *   published; so a cancel is acted on within one turn whatever the engines
 *   write.
 * - Each launch is its own session and process group (setsid), so signals
 *   reach mpirun and every rank.
 * - Outcomes are written to the job queue first, then published on the hub.
 * - sched_recover() runs before sched_start(): jobs the database calls
 *   running belong to a previous daemon; a live process with the recorded
 *   pid and start time is stopped (SIGTERM, then SIGKILL) and waited for,
 *   then the job is requeued. So a job never runs twice at once.
 * - launcher = slurm (slurm.h): an attempt is a Slurm job submitted with
 *   sbatch, its id stored with the attempt before it is followed; its
 *   stdout/stderr are files in the job directory (shared file system),
 *   tailed each turn into the same ingestion. Its state is asked for every
 *   slurm_poll seconds (one squeue for all); cancel and output limits are scancel;
 *   a Slurm end that is not the engine's (time limit, node failure,
 *   preemption, a cancel from outside) is retried from the checkpoint
 *   within max_attempts. Slurm jobs outlive the daemon: sched_stop() leaves
 *   them running, and sched_recover() follows them again (reading their
 *   output on from the last record stored), or finds one whose id was not
 *   stored by its job name. So no job is lost and none runs twice.
 */

typedef struct sched sched_t;

typedef struct {
	jobq_t *q;
	hub_t *hub;
	const cfg_t *cfg;
	const char *engine;      /* resolved granular-engine path */
	const char *jobs_dir;    /* STATE/jobs */
} sched_conf_t;

sched_t *sched_create(const sched_conf_t *conf);
void sched_destroy(sched_t *s);

int sched_recover(sched_t *s, char *log, size_t loglen);
int sched_start(sched_t *s);
/* Stop launching, SIGTERM running jobs (they checkpoint), wait up to grace
 * seconds, SIGKILL what is left, requeue them all, join the thread. Slurm
 * jobs are left running (the next daemon follows them). */
void sched_stop(sched_t *s, double grace);

void sched_wake(sched_t *s);
void sched_cancel(sched_t *s, int64_t id);

typedef struct {
	int slots, used, running;
	double events_per_second;   /* summed over running jobs, from their progress */
} sched_stats_t;
void sched_stats(sched_t *s, sched_stats_t *out);

/* Publish the job's current row as a "state" event (used by the API too). */
void sched_publish_state(jobq_t *q, hub_t *hub, int64_t id);
