/* Output limits of running jobs: the size of each job's directory, measured while it runs, against the job's limit. */
#pragma once

#include <stddef.h>
#include <stdint.h>
#include "jobq.h"

/*
 * Contract
 * - A job's output is the sum of the sizes of the regular files in its
 *   directory JOBS_DIR/ID (what GET /api/v1/jobs/{id}/files lists:
 *   trajectory.h5 and .xdmf, checkpoints, progress.jsonl, scene.json);
 *   its limit is jobq_output_limit() (the submission's max_output_bytes or
 *   the server's max_job_output).
 * - Measured, not trusted to the engine: it holds for any launch template
 *   and whatever the launcher writes. A job can overshoot its limit by what
 *   it writes between two measurements (at most one period apart) plus the
 *   checkpoint it writes when stopped; admission (budget.h) has refused the
 *   jobs whose estimated output exceeds the limit already.
 * - Used by the scheduler thread only (not thread-safe); no processes are
 *   touched here: the caller stops the job.
 */

typedef struct quota quota_t;

/* period: seconds between two measurements of one job (> 0). NULL on
 * allocation failure. jobs_dir is copied. */
quota_t *quota_create(jobq_t *q, const char *jobs_dir, double period);
void quota_destroy(quota_t *qt);

/* Whether running job id has outgrown its limit. Measures at most once per
 * period per job (now: monotonic seconds); otherwise, on any error, and for
 * a job without a limit returns 0. 1 with one line in msg: "output limit
 * exceeded: the job directory holds N bytes (largest: FILE, M bytes), more
 * than its limit of L bytes; ...". */
int quota_exceeded(quota_t *qt, int64_t id, double now, char *msg, size_t msglen);

/* Bytes of the regular files directly in dir (symbolic links not followed);
 * largest (may be NULL, largest_len bytes) gets the name of the largest and
 * *largest_bytes (may be NULL) its size. -1 when dir cannot be read. */
int64_t quota_dir_bytes(const char *dir, char *largest, size_t largest_len, int64_t *largest_bytes);
