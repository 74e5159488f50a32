#!/bin/sh
# Runs each fuzz target for RUNS executions (default 10^6, at most MAX_SECONDS each),
# one target at a time, from its committed corpus plus the hand-written seeds, then
# minimises the corpus back into corpus/TARGET. Usage: fuzz/run.sh [TARGET…]
# Needs nightly and cargo-fuzz (`cargo install cargo-fuzz`).
set -eu
cd "$(dirname "$0")"
RUNS=${RUNS:-1000000}
MAX_SECONDS=${MAX_SECONDS:-3600}
TARGETS=${*:-"uai_model uai_evidence carmen relations leigh pair_json index_json weights_json bag mcap ros_message clear_mot"}
for t in $TARGETS; do
    # Bags are larger than text files: the seeds are 7-23 kB.
    LEN=8192
    { [ "$t" = bag ] || [ "$t" = mcap ]; } && LEN=32768
    mkdir -p "work/$t" "corpus/$t"
    cp seeds/"$t"/* "work/$t/" 2>/dev/null || true
    cp corpus/"$t"/* "work/$t/" 2>/dev/null || true
    cargo +nightly fuzz run -O "$t" "work/$t" -- \
        -runs="$RUNS" -max_total_time="$MAX_SECONDS" -max_len=$LEN -timeout=10 \
        -rss_limit_mb=2048 -print_final_stats=1 2>&1 | tee "work/$t.log" | grep -E "^(Done|#[0-9]+ *DONE|stat::)|ERROR|panicked" || true
    rm -rf "corpus/$t.new" && mkdir -p "corpus/$t.new"
    cargo +nightly fuzz cmin -O "$t" "work/$t" -- -max_len=$LEN >/dev/null 2>&1
    cp "work/$t"/* "corpus/$t.new/" && rm -rf "corpus/$t" && mv "corpus/$t.new" "corpus/$t"
    echo "$t: $(ls "corpus/$t" | wc -l) corpus files"
done
