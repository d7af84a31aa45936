#!/usr/bin/env bash
# Drives the real `tapeshape demo` in a real terminal (tmux, 80x24) the way
# an operator would: start the demo, take over from the simulated operator,
# retake a reading, finish, estimate (the result shows the sizes on the
# example chart), export, write the customer's card (checked with pdftotext),
# quit, start again and find the
# session in the history and show its stored estimate; then kill the program
# mid-session (SIGKILL), check that the next start offers to resume it with its
# readings, finish and estimate it, kill the program again and check that the
# next start shows that estimate from the store (without estimating again) and
# exports it. Each step waits for text on the screen
# (capture-pane), fails with the screen shown if it does not appear, and
# saves the screen to $OUT/NN-step.txt.
#
# Usage: scripts/tmux-demo.sh [--release]
# Env:   OUT (captures folder, default target/tmux-demo), TAPESHAPE_BIN
#        (a built binary; default: cargo build -p tapeshape), STEP_TIMEOUT
#        (seconds per step, default 60). Needs tmux and poppler-utils
#        (apt-get install -y tmux poppler-utils).
set -euo pipefail

cd "$(dirname "$0")/.."
profile=debug
if [[ "${1:-}" == "--release" ]]; then profile=release; fi
command -v tmux >/dev/null || { echo "tmux is not installed (apt-get install -y tmux)" >&2; exit 2; }
command -v pdftotext >/dev/null || { echo "pdftotext is not installed (apt-get install -y poppler-utils)" >&2; exit 2; }
if [[ -z "${TAPESHAPE_BIN:-}" ]]; then
    if [[ $profile == release ]]; then cargo build --release -p tapeshape; else cargo build -p tapeshape; fi
    TAPESHAPE_BIN="$PWD/target/$profile/tapeshape"
fi
OUT="${OUT:-$PWD/target/tmux-demo}"
STEP_TIMEOUT="${STEP_TIMEOUT:-60}"
mkdir -p "$OUT"
rm -f "$OUT"/*.txt
DATA="$(mktemp -d -t tapeshape-tmux-XXXXXX)"
SESSION="tapeshape-demo"
# A tmux server of its own (-L), so nothing here touches anyone else's tmux.
SOCKET="tapeshape-demo-$$"
tmux() { command tmux -L "$SOCKET" "$@"; }
trap 'tmux kill-server 2>/dev/null || true; rm -rf "$DATA"' EXIT

screen() { tmux capture-pane -p -t "$SESSION"; }
save() { screen >"$OUT/$1.txt"; echo "saved $OUT/$1.txt"; }
fail() {
    echo "FAILED: $1" >&2
    echo "---- screen ----" >&2
    screen >&2 || true
    exit 1
}
# wait_for TEXT [TIMEOUT]: until the screen shows TEXT (fixed string).
wait_for() {
    local deadline=$((SECONDS + ${2:-$STEP_TIMEOUT}))
    until screen | grep -qF -- "$1"; do
        ((SECONDS < deadline)) || fail "no '$1' on the screen after ${2:-$STEP_TIMEOUT} s"
        sleep 0.2
    done
}
keys() { tmux send-keys -t "$SESSION" "$@"; }
# wait_dead: until the program in the pane has ended.
wait_dead() {
    local deadline=$((SECONDS + STEP_TIMEOUT))
    until [[ "$(tmux display -p -t "$SESSION" '#{pane_dead}')" == 1 ]]; do
        ((SECONDS < deadline)) || fail "the program did not end within $STEP_TIMEOUT s"
        sleep 0.2
    done
}
start_demo() {
    # remain-on-exit keeps the pane after the program ends, to read its last words.
    tmux new-session -d -s "$SESSION" -x 80 -y 24 \
        "TERM=xterm-256color '$TAPESHAPE_BIN' --data-dir '$DATA' demo --speedup 3"
    tmux set-option -t "$SESSION" remain-on-exit on >/dev/null
}

# A session that only holds the server open: killing the demo's last
# session ends the server, and a session started at that moment can reach
# the exiting server ("server exited unexpectedly": a CI run on a loaded
# machine, 2026-12-06, step 9).
tmux new-session -d -s keeper "sleep 86400"

echo "1. start the demo (data in $DATA)"
start_demo
wait_for "DEMO autopilot"
wait_for "Measuring"
save 01-autopilot-measuring

echo "2. take over once two readings are stored"
wait_for "2 of 9 taken"
keys Space
wait_for "You have the keyboard"
wait_for "DEMO manual"
save 02-taken-over

echo "3. retake the reading above the current one"
keys Up
keys r
wait_for "Retake"
keys m
wait_for "(retake; was"
save 03-retaken

echo "4. measure the rest with the simulated tape"
for _ in $(seq 1 20); do
    if screen | grep -qF "Every measurement is taken"; then break; fi
    if screen | grep -qF "Enter to keep"; then keys Enter; fi
    keys m
    sleep 1.5
done
wait_for "Every measurement is taken"
save 04-all-taken

echo "5. estimate: the result shows a size per garment (the demo's example chart)"
keys e
wait_for "Estimate ("
wait_for " Sizes "
wait_for "jacket: "
save 05-result

echo "6. export"
keys x
wait_for "Exported "
save 06-exported
ls "$DATA/exports" | grep -q '\.glb$' || fail "no .glb in $DATA/exports"
ls "$DATA/exports" | grep -q 'report\.json$' || fail "no report in $DATA/exports"

echo "6b. the customer's card"
keys p
wait_for "Card written to"
save 06b-card
card=$(ls "$DATA"/exports/*card.pdf 2>/dev/null | head -n 1)
[[ -n "$card" ]] || fail "no card PDF in $DATA/exports"
pdftotext -layout "$card" - >"$OUT/06b-card.txt"
for word in "Session: 1" "Measurements taken" "jacket: "; do
    grep -qF "$word" "$OUT/06b-card.txt" || fail "the card ($card) has no '$word' (its text: $OUT/06b-card.txt)"
done
echo "card $card: $(wc -l <"$OUT/06b-card.txt") lines of text"

echo "7. quit"
keys q
keys q
wait_dead
save 07-quit
tmux kill-session -t "$SESSION"

echo "8. start again and find the session in the history"
start_demo
wait_for "tape:"
keys Space        # take over at once
wait_for "You have the keyboard"
keys h
wait_for "Sessions ("
save 08-history
screen | grep -E '^\S*│1 +c-[0-9a-z]{6} +quick +done +9 ' >/dev/null \
    || screen | grep -E '1 +c-[0-9a-z]{6} +quick +done +9 ' >/dev/null \
    || fail "session 1 (done, 9 readings) is not in the history"
echo "8b. show its stored estimate (nothing is estimated again)"
wait_for "v result"
keys v
wait_for "Estimate stored"
wait_for "Estimate ("
save 08b-stored-result
keys q
keys q
wait_dead
tmux kill-session -t "$SESSION"

echo "9. kill the program mid-session (SIGKILL), start again: resume is offered"
start_demo
wait_for "Measuring"
deadline=$((SECONDS + STEP_TIMEOUT))
until screen | grep -qE '[3-8] of 9 taken'; do
    ((SECONDS < deadline)) || fail "the simulated operator did not take 3 readings"
    sleep 0.2
done
taken=$(screen | grep -oE '[0-9] of 9 taken' | head -1 | cut -d' ' -f1)
pane_pid=$(tmux display -p -t "$SESSION" '#{pane_pid}')
# The pane's process is the program, or a shell whose child it is.
if [[ "$(ps -o comm= -p "$pane_pid")" != tapeshape ]]; then pane_pid=$(pgrep -P "$pane_pid"); fi
kill -9 "$pane_pid"
wait_dead
save 09-killed
tmux kill-session -t "$SESSION"
start_demo
wait_for "Resume?" 30
save 10-resume-offered
offered=$(screen | grep -oE '[0-9]+ readings are stored' | head -1 | cut -d' ' -f1)
((offered >= taken)) || fail "resume offers $offered readings, $taken were on the screen before the kill"
# Take over and accept: the session opens with its readings.
keys Space
wait_for "You have the keyboard"
keys y
# The list shows the stored readings; the notice says so unless the check of
# the resumed readings flags one at once (with three readings the demo
# customer's chest is 3 SD from what the other two predict), whose flag
# then takes the notice line.
wait_for "$offered of 9 taken"
screen | grep -qE "opened with its $offered stored readings|SD (above|below) what the other readings predict" \
    || fail "the resumed session says neither that it opened with its $offered readings nor why not"
save 11-resumed

echo "12. finish the resumed session and estimate it, then kill the program (SIGKILL)"
for _ in $(seq 1 20); do
    if screen | grep -qF "Every measurement is taken"; then break; fi
    if screen | grep -qF "Enter to keep"; then keys Enter; fi
    keys m
    sleep 1.5
done
wait_for "Every measurement is taken"
keys e
wait_for "Estimate ("
save 12-estimated
pane_pid=$(tmux display -p -t "$SESSION" '#{pane_pid}')
if [[ "$(ps -o comm= -p "$pane_pid")" != tapeshape ]]; then pane_pid=$(pgrep -P "$pane_pid"); fi
kill -9 "$pane_pid"
wait_dead
tmux kill-session -t "$SESSION"

echo "13. start again: the estimate made before the kill is shown from the store and exported"
start_demo
wait_for "Resume?" 30
keys Space
wait_for "You have the keyboard"
keys n
wait_for "stays open"
keys h
wait_for "Sessions ("
wait_for "v result"
keys v
wait_for "Estimate stored"
wait_for "Estimate ("
save 13-stored-after-kill
keys x
wait_for "Exported "
save 14-exported-again
keys q
keys q
wait_dead

echo "15. everything the program wrote (store, log, exports) is its owner's only"
[[ -f "$DATA/tapeshape.log" ]] || fail "no log file $DATA/tapeshape.log"
open=$(find "$DATA" -mindepth 1 \( -type f ! -perm 0600 \) -o \( -type d ! -perm 0700 \) | head -n 5)
[[ -z "$open" ]] || fail "not owner-only (0600 files, 0700 folders): $(ls -ld $open)"
echo "owner-only: $(find "$DATA" -mindepth 1 | wc -l) files and folders"
echo "ok: captures in $OUT"
