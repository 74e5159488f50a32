#!/usr/bin/env bash
# Instruction counts of belief propagation per iteration and per message, under
# callgrind (valgrind), which the host's load does not move.
#
#   tools/callgrind-bp.sh PGM MODEL.uai [SCHEDULE...]
#
# For each schedule (default: flooding sequential residual), runs
# `PGM map MODEL --schedule S --tolerance 0 --max-iters N` on one thread for N = 10 and
# N = 40 under `valgrind --tool=callgrind` and prints the instructions of the 30 extra
# iterations divided by 30 (so reading, decoding and writing drop out), and that
# divided by the model's number of factor-to-variable messages (edges).
set -euo pipefail
if [ $# -lt 2 ]; then
    echo "usage: $0 PGM MODEL.uai [SCHEDULE...]" >&2
    exit 2
fi
pgm=$1
model=$2
shift 2
schedules=("$@")
[ ${#schedules[@]} -gt 0 ] || schedules=(flooding sequential residual)
command -v valgrind >/dev/null || { echo "$0: valgrind not found" >&2; exit 1; }
[ -r "$model" ] || { echo "$0: $model: cannot read" >&2; exit 1; }
# Edges: the sum of the factors' scope sizes, from the UAI preamble (the type, the
# number of variables, their cardinalities, the number of factors, each factor's arity
# followed by its variables).
edges=$(tr -s ' \t\r' '\n\n\n' < "$model" | awk 'NF {
    t++
    if (t == 2) { n = $1; next }
    if (t <= 2 + n) next
    if (t == 3 + n) { m = $1; left = 0; next }
    if (done == m && left == 0) next
    if (left == 0) { left = $1; e += $1; done++ } else left--
} END { print e }')
ir() {
    RAYON_NUM_THREADS=1 valgrind --tool=callgrind --callgrind-out-file=/dev/null \
        "$pgm" map "$model" --schedule "$1" --tolerance 0 --max-iters "$2" 2>&1 >/dev/null |
        awk '/Collected/ {gsub(",", "", $4); print $4}'
}
printf '%-12s %22s %20s\n' schedule "instructions/iteration" "instructions/message"
for s in "${schedules[@]}"; do
    a=$(ir "$s" 10)
    b=$(ir "$s" 40)
    awk -v a="$a" -v b="$b" -v e="$edges" -v s="$s" \
        'BEGIN { it = (b - a) / 30; printf "%-12s %22.0f %20.1f\n", s, it, it / e }'
done
