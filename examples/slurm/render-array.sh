#!/usr/bin/env bash
# Render one lucent image on many Slurm nodes: a job array in which every task renders its own
# seed to its own checkpoint, and a dependent job that merges the checkpoints (weighted by
# sample count) into the final images. See docs/distributed.md.
#
# Submit from a login node; the script submits itself twice (the array, then the merge):
#
#   examples/slurm/render-array.sh SCENE.toml [TASKS [SPP_PER_TASK]]
#   examples/slurm/render-array.sh builtin 64 256        # the built-in Cornell box
#
# Environment (all optional):
#   LUCENT       the lucent binary                     (default: lucent on PATH)
#   RUN_DIR      shared folder for checkpoints/images  (default: ./lucent-run-DATE)
#   SEED_OFFSET  seed of task 0; task i renders seed SEED_OFFSET+i (default 0)
#   EXTRA_ARGS   more `lucent render` options, e.g. "--width 1024 --height 1024 --integrator path"
#
# Resubmitting with the same RUN_DIR resumes every task from its checkpoint (after a time-out,
# a preemption or a node failure); tasks already finished only rewrite their images.
#
#SBATCH --job-name=lucent
#SBATCH --cpus-per-task=8
#SBATCH --mem=4G
#SBATCH --time=02:00:00
#SBATCH --output=lucent-%A_%a.log
# Two minutes before the time limit Slurm sends SIGINT to this script, which passes it on to
# lucent: lucent finishes its pass, writes the checkpoint and images and exits 130.
#SBATCH --signal=B:INT@120

set -euo pipefail
LUCENT=${LUCENT:-lucent}

case "${LUCENT_PHASE:-submit}" in
submit)
    SCENE=${1:?usage: render-array.sh SCENE.toml|builtin [TASKS [SPP_PER_TASK]]}
    TASKS=${2:-16}
    SPP=${3:-256}
    RUN_DIR=${RUN_DIR:-$PWD/lucent-run-$(date +%Y%m%d-%H%M%S)}
    mkdir -p "$RUN_DIR"
    RUN_DIR=$(cd "$RUN_DIR" && pwd)
    if [[ "$SCENE" != builtin ]]; then
        SCENE=$(cd "$(dirname "$SCENE")" && pwd)/$(basename "$SCENE")
    fi
    # Everything the tasks need travels in the environment (sbatch --export=ALL keeps the rest).
    export LUCENT SCENE SPP RUN_DIR SEED_OFFSET=${SEED_OFFSET:-0} EXTRA_ARGS=${EXTRA_ARGS:-}
    array_job=$(LUCENT_PHASE=render sbatch --parsable --export=ALL --array="0-$((TASKS - 1))" \
        --chdir="$RUN_DIR" "$0")
    array_job=${array_job%%;*}
    merge_job=$(LUCENT_PHASE=merge sbatch --parsable --export=ALL --dependency="afterok:$array_job" \
        --cpus-per-task=1 --time=00:10:00 --job-name=lucent-merge --chdir="$RUN_DIR" "$0")
    merge_job=${merge_job%%;*}
    echo "render array: job $array_job ($TASKS tasks × $SPP spp, seeds $SEED_OFFSET..$((SEED_OFFSET + TASKS - 1)))"
    echo "merge:        job $merge_job (after the array succeeds)"
    echo "results in:   $RUN_DIR/merged.exr, merged.png, merged.ckpt"
    ;;

render)
    seed=$((SEED_OFFSET + SLURM_ARRAY_TASK_ID))
    ckpt="$RUN_DIR/seed-$seed.ckpt"
    args=(render)
    [[ "$SCENE" != builtin ]] && args+=("$SCENE")
    args+=(--spp "$SPP" --seed "$seed" --threads "${SLURM_CPUS_PER_TASK:-1}"
        --checkpoint "$ckpt" --out "$RUN_DIR/seed-$seed.exr" --quiet)
    # A checkpoint from an earlier attempt of this task: continue it instead of starting over.
    [[ -f "$ckpt" ]] && args+=(--resume "$ckpt")
    # shellcheck disable=SC2206  # EXTRA_ARGS is split into words on purpose
    args+=($EXTRA_ARGS)
    "$LUCENT" "${args[@]}" &
    pid=$!
    trap 'kill -INT "$pid" 2>/dev/null || true' INT TERM
    # `wait` returns early when a trapped signal arrives; keep waiting until lucent has exited.
    while true; do
        status=0
        wait "$pid" || status=$?
        kill -0 "$pid" 2>/dev/null || break
    done
    exit "$status"
    ;;

merge)
    shopt -s nullglob
    ckpts=("$RUN_DIR"/seed-*.ckpt)
    if [[ ${#ckpts[@]} -eq 0 ]]; then
        echo "no checkpoints in $RUN_DIR" >&2
        exit 1
    fi
    "$LUCENT" merge "${ckpts[@]}" --out "$RUN_DIR/merged.exr" --out "$RUN_DIR/merged.png" \
        --checkpoint "$RUN_DIR/merged.ckpt"
    ;;

*)
    echo "unknown LUCENT_PHASE=$LUCENT_PHASE" >&2
    exit 2
    ;;
esac
