#!/usr/bin/env bash
# Starts the mps2-an386 firmware under QEMU, paused, with its two UARTs on pseudo-terminals.
#
# Why paused: QEMU discards what the guest sends to a pseudo-terminal that nobody has open,
# so the host must open both ports first and only then let the guest run (`cont` on the
# monitor socket). Bytes the host writes to the tape port before that wait in the
# pseudo-terminal until the firmware enables its UART.
#
# Usage: run-qemu.sh [--no-build] [--elf PATH] [--seed N] [STATE_FILE]
#   STATE_FILE (default: $TMPDIR/tapeshape-qemu.env) receives KEY=VALUE lines:
#     TAPE_PTY=/dev/pts/N    UART0: write tape lines here (9600 8N1 on the board)
#     HOST_PTY=/dev/pts/M    UART1: COBS/postcard frames from and to the firmware
#     MONITOR=/path/sock     QEMU human monitor (unix socket): send "cont\n" to start,
#                            "quit\n" to stop, "system_reset\n" to reboot the board
#     QEMU_PID=1234          QEMU's process id (kill it if the monitor is gone)
#     BOOT_SEED=0x...        seed written at 0x2000fff0 (the boot id derives from it)
#     LOG=/path/qemu.log     QEMU's output (stdout and stderr)
#     ELF=/path/to/elf
#   The script returns once QEMU is up and paused; QEMU keeps running in the background.
#
# Example:
#   ./run-qemu.sh /tmp/q.env && . /tmp/q.env
#   (open "$TAPE_PTY" and "$HOST_PTY" raw) ; echo cont | socat - "UNIX-CONNECT:$MONITOR"
set -euo pipefail

here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
build=1
elf=""
seed=""
state=""
while [ $# -gt 0 ]; do
    case "$1" in
        --no-build) build=0 ;;
        --elf) elf="$2"; shift ;;
        --seed) seed="$2"; shift ;;
        -h|--help) sed -n '2,25p' "$0"; exit 0 ;;
        -*) echo "run-qemu.sh: unknown option $1 (see --help)" >&2; exit 2 ;;
        *) state="$1" ;;
    esac
    shift
done
state="${state:-${TMPDIR:-/tmp}/tapeshape-qemu.env}"

command -v qemu-system-arm >/dev/null || {
    echo "run-qemu.sh: qemu-system-arm not found (Debian: apt-get install -y qemu-system-arm)" >&2
    exit 1
}
if [ -z "$elf" ]; then
    # Honours CARGO_TARGET_DIR and build.target-dir, like cargo itself.
    target_dir="$(cd "$here" && cargo metadata --format-version 1 --no-deps |
        sed -n 's/.*"target_directory":"\([^"]*\)".*/\1/p')"
    elf="$target_dir/thumbv7em-none-eabihf/release/tapeshape-mps2-an386"
fi
if [ "$build" = 1 ]; then
    (cd "$here" && cargo build --release -p tapeshape-board-mps2-an386)
fi
[ -f "$elf" ] || { echo "run-qemu.sh: no firmware at $elf (build it, or drop --no-build)" >&2; exit 1; }
if [ -z "$seed" ]; then
    seed="0x$(od -An -N4 -tx4 /dev/urandom | tr -d ' \n')"
fi

dir="$(mktemp -d "${TMPDIR:-/tmp}/tapeshape-qemu.XXXXXX")"
monitor="$dir/monitor.sock"
log="$dir/qemu.log"

qemu-system-arm -M mps2-an386 -display none -S \
    -kernel "$elf" \
    -chardev pty,id=tape -serial chardev:tape \
    -chardev pty,id=host -serial chardev:host \
    -monitor "unix:$monitor,server,nowait" \
    -device "loader,addr=0x2000fff0,data=$seed,data-len=4" \
    >"$log" 2>&1 &
pid=$!

# QEMU reports each pty as "char device redirected to /dev/pts/N (label ID)".
tape="" host=""
for _ in $(seq 100); do
    tape="$(sed -n 's/.*redirected to \(\/dev\/[^ ]*\) (label tape).*/\1/p' "$log")"
    host="$(sed -n 's/.*redirected to \(\/dev\/[^ ]*\) (label host).*/\1/p' "$log")"
    if [ -n "$tape" ] && [ -n "$host" ] && [ -S "$monitor" ]; then break; fi
    if ! kill -0 "$pid" 2>/dev/null; then
        echo "run-qemu.sh: QEMU exited:" >&2; cat "$log" >&2; exit 1
    fi
    sleep 0.1
done
if [ -z "$tape" ] || [ -z "$host" ] || [ ! -S "$monitor" ]; then
    echo "run-qemu.sh: QEMU did not report its ports within 10 s:" >&2; cat "$log" >&2
    kill "$pid" 2>/dev/null || true
    exit 1
fi

tmp="$state.tmp.$$"
cat >"$tmp" <<EOF
TAPE_PTY=$tape
HOST_PTY=$host
MONITOR=$monitor
QEMU_PID=$pid
BOOT_SEED=$seed
LOG=$log
ELF=$elf
EOF
mv "$tmp" "$state"
echo "QEMU paused (pid $pid): tape $tape, host $host, monitor $monitor; state in $state" >&2
