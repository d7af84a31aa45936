#!/usr/bin/env bash
# Prints flash and static RAM of both board binaries (release builds).
#
#   flash      = text + data   (code and constants, plus the initial values of .data)
#   static RAM = data + bss    (.uninit included in bss; the stack is not counted)
#
# Targets (issue 2, item 3): flash <= 64 KiB, static RAM <= 32 KiB. Exits 1 if a binary
# misses them. Needs llvm-size: `rustup component add llvm-tools` (used from the rustc
# sysroot) or cargo-binutils / an llvm-size on PATH.
# Usage: size.sh [--no-build]
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
cd "$here"
if [ "${1:-}" != "--no-build" ]; then
    cargo build --release
fi
# Honours CARGO_TARGET_DIR and build.target-dir, like cargo itself.
target_dir="$(cargo metadata --format-version 1 --no-deps | sed -n 's/.*"target_directory":"\([^"]*\)".*/\1/p')"
host="$(rustc -vV | sed -n 's/^host: //p')"
size="$(rustc --print sysroot)/lib/rustlib/$host/bin/llvm-size"
if [ ! -x "$size" ]; then
    size="$(command -v llvm-size || true)"
fi
[ -n "$size" ] || { echo "size.sh: llvm-size not found (rustup component add llvm-tools)" >&2; exit 1; }

flash_max=$((64 * 1024))
ram_max=$((32 * 1024))
status=0
printf '%-22s %8s %8s %8s %10s %12s\n' binary text data bss flash static_ram
for bin in tapeshape-nrf52840 tapeshape-mps2-an386; do
    elf="$target_dir/thumbv7em-none-eabihf/release/$bin"
    # Berkeley format: text data bss dec hex filename
    read -r text data bss _ < <("$size" -B "$elf" | sed -n 2p)
    flash=$((text + data))
    ram=$((data + bss))
    printf '%-22s %8d %8d %8d %10d %12d\n' "$bin" "$text" "$data" "$bss" "$flash" "$ram"
    if [ "$flash" -gt "$flash_max" ] || [ "$ram" -gt "$ram_max" ]; then
        echo "size.sh: $bin misses the target (flash <= $flash_max, static RAM <= $ram_max bytes)" >&2
        status=1
    fi
done
exit $status
