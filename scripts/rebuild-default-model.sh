#!/usr/bin/env bash
# Rebuilds the default body model embedded in the program
# (host/estimator/models/default.tsm.gz): 2,100 generated bodies (seed 1; 1,041
# men and 1,059 women) each fitted to one ANSUR II train-split subject on every
# `ansur` dimension the standing mesh can take as ANSUR does (`--fit ansur`,
# issue 12), measured with paper34, ansur and quick; the first 100 PCA
# components, basis rounded to f32, gzip-compressed (~18.5 MB).
# Deterministic: the same seed and code give the same population and model.
# Takes about 10 minutes on 2 cores after the release build (generation ~6 min,
# training ~3 min and 2.4 GiB of memory).
# See docs/prediction.md.
set -euo pipefail
cd "$(dirname "$0")/.."
work="${TAPESHAPE_WORK:-$(mktemp -d)}"
model=host/estimator/models/default.tsm.gz
# The estimator embeds the model file at build time: a missing file (first build)
# is created empty so the program can be built to train the real one.
[ -f "$model" ] || : > "$model"
cargo build --release -p tapeshape
./target/release/tapeshape dataset generate --n 2100 --seed 1 --fit ansur --out "$work/pop2100s1a.tsd"
./target/release/tapeshape train --dataset "$work/pop2100s1a.tsd" \
    --set paper34 --set ansur --set quick --max-components 100 --f32 -o "$model"
echo "rebuilt $model; rebuild the program (cargo build) to embed it"
