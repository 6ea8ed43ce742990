#!/bin/sh
# One line of a report job file as one task of a Slurm job array (docs/sweeps.md):
#
#   refs=$(sbatch --parsable --array=1-$(wc -l < jobs.txt.references) tools/sweeps/slurm-array.sh jobs.txt.references)
#   sbatch --dependency=afterany:$refs --array=1-$(wc -l < jobs.txt) tools/sweeps/slurm-array.sh jobs.txt
#
# Task N runs line N (1-based) of the file. Without Slurm, set SLURM_ARRAY_TASK_ID by hand to run one line
# (the test demos/lab/tests/jobs.rs does). A finished point is skipped, so resubmitting the array (or only the
# failed indices, `--array=3,7`) re-runs just what is missing.
#SBATCH --job-name=report-point
#SBATCH --cpus-per-task=2
#SBATCH --time=02:00:00
#SBATCH --output=report-point-%A_%a.log
set -eu
jobs=${1:?usage: sbatch --array=1-N tools/sweeps/slurm-array.sh JOBFILE}
: "${SLURM_ARRAY_TASK_ID:?not a Slurm array task: set SLURM_ARRAY_TASK_ID to the line to run}"
line=$(sed -n "${SLURM_ARRAY_TASK_ID}p" "$jobs")
if [ -z "$line" ]; then
    echo "slurm-array.sh: no line $SLURM_ARRAY_TASK_ID in $jobs" >&2
    exit 2
fi
exec sh -c "$line"
