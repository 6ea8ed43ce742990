#!/bin/sh
# Process-level fuzzing of every loader (issue 38): seeded mutations of each file the demo reads, every run a
# separate `demo` process capped in memory and time (no abort, hang or panic text may show). Builds the release
# binaries, runs tools/fuzz/src/process.rs and writes its counts to docs/process-fuzz.md.
#
#   tools/process-fuzz.sh [--runs N] [--seed K] [--timeout S] [--memory-mib M] [--only PLACE]
#
# Defaults: 300 runs per place, seed 1, 30 s, 4096 MiB. Findings (the inputs) are saved in out/process-fuzz;
# the exit status is 1 when there is any.
set -eu
cd "$(dirname "$0")/.."
cargo build --release -p demos --bin demo -p engine-fuzz --bin process-fuzz
target="${CARGO_TARGET_DIR:-target}"
exec "$target/release/process-fuzz" --demo "$target/release/demo" --dir out/process-fuzz \
    --markdown docs/process-fuzz.md "$@"
