#!/usr/bin/env bash
# Rebuilds the default body model embedded in the program
# (host/estimator/models/default.tsm.gz): 400 generated bodies (seed 1) fitted to
# ANSUR II train-split subjects, measured with paper34, ansur and quick; the
# first 100 PCA components, basis rounded to f32, gzip-compressed (~18 MB).
# Deterministic: the same seed and code give the same population and model.
# Takes about 2 minutes on 2 cores (release build, generation ~50 s, training ~10 s).
# Also writes host/eval/data/default-population.csv (the population measured
# with the `ansur` set). See docs/prediction.md.
set -euo pipefail
cd "$(dirname "$0")/.."
work="${TAPESHAPE_WORK:-$(mktemp -d)}"
model=host/estimator/models/default.tsm.gz
# The estimator embeds the model file at build time: a missing file (first build)
# is created empty so the program can be built to train the real one.
[ -f "$model" ] || : > "$model"
cargo build --release -p tapeshape
./target/release/tapeshape dataset generate --n 400 --seed 1 --out "$work/pop400s1.tsd"
./target/release/tapeshape train --dataset "$work/pop400s1.tsd" \
    --set paper34 --set ansur --set quick --max-components 100 --f32 -o "$model"
# The population's ANSUR II dimensions as the mesh measures them, for the sex
# check's population axes (host/eval/src/poptable.rs); its CI test checks that
# the table names this model's sha256.
cargo run --release -p tapeshape-eval --example population_table -- \
    "$work/pop400s1.tsd" --out host/eval/data/default-population.csv --model "$model"
echo "rebuilt $model and host/eval/data/default-population.csv; rebuild the program (cargo build) to embed it"
