#!/usr/bin/env bash
# Submits a sharded probe bake to Slurm: the N shards as one array job
# (sbatch --array=0-(N-1)) writing into a shared directory, and the merge as a job that
# depends on the whole array (--dependency=afterok:<array job id>).
#
#   scripts/slurm/submit-bake.sh -n N -d SHARED_DIR [-b PROBES_BIN] [-s "SBATCH OPTIONS"]
#                                [-w] -- SCENE BAKE_OPTIONS...
#
#   -n N            shard count (at most the number of probes)
#   -d SHARED_DIR   a directory every node sees (NFS, Lustre...): shards go to
#                   SHARED_DIR/shards/shard-K, logs to SHARED_DIR/logs, the bake to
#                   SHARED_DIR/bake
#   -b PROBES_BIN   the probes binary, as the nodes see it (default: `probes` on PATH here,
#                   resolved to an absolute path)
#   -s OPTIONS      extra sbatch options for both jobs, e.g. "-p bake --cpus-per-task=32"
#   -w              wait for the merge job and exit with its status (sbatch --wait)
#   SCENE BAKE_OPTIONS...  what `probes bake` takes, without --shard and --out; the scene
#                   and a --probes file must be readable on every node (give them on the
#                   shared directory, by absolute paths)
#
# Prints the two job ids. Example, 8 shards of a 4,096-probe Sponza bake:
#   scripts/slurm/submit-bake.sh -n 8 -d /shared/sponza -s "--cpus-per-task=16" -- \
#       /shared/scenes/Sponza.gltf --probes /shared/sponza/probes.json --res 256
# A shard that failed can be re-run alone (its output is replaced whole):
#   sbatch --array=K scripts/slurm/bake-shard.sbatch PROBES_BIN N SHARED_DIR SCENE BAKE_OPTIONS...
set -euo pipefail

here=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
count='' shared='' probes='' extra='' wait=''
while getopts 'n:d:b:s:wh' option; do
    case "$option" in
        n) count=$OPTARG ;;
        d) shared=$OPTARG ;;
        b) probes=$OPTARG ;;
        s) extra=$OPTARG ;;
        w) wait=1 ;;
        h) sed -n '2,30p' "${BASH_SOURCE[0]}"; exit 0 ;;
        *) echo "usage: $0 -n N -d SHARED_DIR [-b PROBES_BIN] [-s OPTIONS] [-w] -- SCENE BAKE_OPTIONS..." >&2; exit 2 ;;
    esac
done
shift $((OPTIND - 1))
[[ "$count" =~ ^[1-9][0-9]*$ ]] || { echo "submit-bake.sh: -n N must be a positive whole number (got '$count')" >&2; exit 2; }
[ -n "$shared" ] || { echo "submit-bake.sh: -d SHARED_DIR is required" >&2; exit 2; }
[ $# -ge 1 ] || { echo "submit-bake.sh: give the scene and the bake options after --" >&2; exit 2; }
for argument in "$@"; do
    case "$argument" in
        --shard|--shard=*|--out|--out=*) echo "submit-bake.sh: leave out $argument: the script sets --shard and --out" >&2; exit 2 ;;
    esac
done
command -v sbatch >/dev/null || { echo "submit-bake.sh: sbatch not found (is this a Slurm submit host?)" >&2; exit 1; }
if [ -z "$probes" ]; then
    probes=$(command -v probes) || { echo "submit-bake.sh: no probes binary on PATH; pass -b PROBES_BIN" >&2; exit 1; }
fi
[ -x "$probes" ] || { echo "submit-bake.sh: $probes is not an executable" >&2; exit 1; }
mkdir -p "$shared/shards" "$shared/logs"
shared=$(cd "$shared" && pwd)
read -r -a sbatch_extra <<< "$extra"

array=$(sbatch --parsable --array="0-$((count - 1))" \
    --output="$shared/logs/shard-%a.out" "${sbatch_extra[@]}" \
    "$here/bake-shard.sbatch" "$probes" "$count" "$shared" "$@")
array=${array%%;*}
echo "shards: array job $array (tasks 0-$((count - 1))) -> $shared/shards"
merge_options=(--parsable --dependency="afterok:$array" --kill-on-invalid-dep=yes
    --output="$shared/logs/merge.out")
if [ -n "$wait" ]; then
    # sbatch --wait prints the id once the job ends, and exits with the job's status.
    echo "merge: waiting (depends on $array) -> $shared/bake"
    status=0
    merge=$(sbatch --wait "${merge_options[@]}" "${sbatch_extra[@]}" \
        "$here/bake-merge.sbatch" "$probes" "$count" "$shared") || status=$?
    echo "merge: job ${merge%%;*} ended with status $status"
    exit "$status"
fi
merge=$(sbatch "${merge_options[@]}" "${sbatch_extra[@]}" \
    "$here/bake-merge.sbatch" "$probes" "$count" "$shared")
echo "merge: job ${merge%%;*} (afterok:$array) -> $shared/bake"
