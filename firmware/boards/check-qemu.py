#!/usr/bin/env python3
"""Smoke test of the real mps2-an386 firmware binary under QEMU, from the outside.

Why a script of its own: it checks the board glue (UART driver, timer driver, executor,
boot id, launch sequence) with nothing of ours on the host side but this file, so a fault
it finds is in the firmware or its launch, not in the host code under test elsewhere. The
full end-to-end test (station <-> firmware) lives in tests/. Python 3 standard library only.

What it checks (each is a hard failure with a message):
  1. the device hello arrives unprompted, names the build's device id and a boot id, and
     two launches get different boot ids (the per-launch seed works);
  2. the hello repeats at its interval while no host has answered (the timer driver works;
     the measured period must be within 20 % of the firmware's 1000 ms default);
  3. after a host hello, a confirmed tape line (`S`) becomes Reading seq 0 with the right
     value, and is retransmitted while unacknowledged;
  4. after the host's Ack, retransmission stops;
  5. a live line (`P`) becomes a Live message with the right value;
  6. bytes written to the tape port before `cont` are not lost (the paused start works);
  7. `system_reset` on the monitor gives a new boot id (the boot counter works).
The hello-period check spans the first wrap of the timer driver's 32-bit counter, which the
driver places 2 s after boot for this purpose.

Without qemu-system-arm it fails (exit 1) when the CI environment variable is set, since
CI must install it, and otherwise prints a SKIPPED line and exits 0.

Usage: check-qemu.py [--elf PATH] [--device-id N]   (builds nothing; run `cargo build
--release` in firmware/boards first, or use run-qemu.sh's default ELF)
"""

import argparse
import os
import select
import shutil
import socket
import subprocess
import sys
import time
import tty

HERE = os.path.dirname(os.path.abspath(__file__))
DEFAULT_DEVICE_ID = 0x4D50533200000386
# The RAM region of mps2-an386/memory.x: the stack grows down from RAM_TOP.
RAM_BASE = 0x20000000
RAM_TOP = 0x2000FFF0

# ---------------------------------------------------------------- wire format (protocol/)


def crc16_x25(data: bytes) -> int:
    """CRC-16/IBM-SDLC (X-25): reflected poly 0x1021, init and xorout 0xFFFF."""
    crc = 0xFFFF
    for b in data:
        crc ^= b
        for _ in range(8):
            crc = (crc >> 1) ^ 0x8408 if crc & 1 else crc >> 1
    return crc ^ 0xFFFF


assert crc16_x25(b"123456789") == 0x906E


def cobs_encode(data: bytes) -> bytes:
    out = bytearray()
    block = bytearray()
    for b in data:
        if b == 0:
            out.append(len(block) + 1)
            out += block
            block = bytearray()
        else:
            block.append(b)
            if len(block) == 254:
                out.append(255)
                out += block
                block = bytearray()
    out.append(len(block) + 1)
    out += block
    return bytes(out)


def cobs_decode(data: bytes) -> bytes:
    out = bytearray()
    i = 0
    while i < len(data):
        code = data[i]
        if code == 0 or i + code > len(data):
            raise ValueError("bad COBS")
        out += data[i + 1 : i + code]
        i += code
        if code < 255 and i < len(data):
            out.append(0)
    return bytes(out)


def frame(payload: bytes) -> bytes:
    crc = crc16_x25(payload)
    return cobs_encode(payload + bytes([crc & 0xFF, crc >> 8])) + b"\x00"


def unframe(body: bytes) -> bytes:
    raw = cobs_decode(body)
    payload, crc = raw[:-2], raw[-2] | (raw[-1] << 8)
    if crc16_x25(payload) != crc:
        raise ValueError("bad CRC")
    return payload


def varint(n: int) -> bytes:
    out = bytearray()
    while True:
        b = n & 0x7F
        n >>= 7
        if n:
            out.append(b | 0x80)
        else:
            out.append(b)
            return bytes(out)


class Reader:
    def __init__(self, data: bytes):
        self.data, self.i = data, 0

    def u8(self) -> int:
        self.i += 1
        return self.data[self.i - 1]

    def var(self) -> int:
        n, shift = 0, 0
        while True:
            b = self.u8()
            n |= (b & 0x7F) << shift
            shift += 7
            if not b & 0x80:
                return n


DEVICE_TAGS = ["Hello", "Live", "Reading", "Button", "Status", "Fault", "Pong"]


def decode_device(payload: bytes):
    """Decodes the DeviceMsg fields this check needs (postcard: varint ints, u8 raw)."""
    r = Reader(payload)
    tag = DEVICE_TAGS[r.var()]
    if tag == "Hello":
        proto = (r.u8(), r.u8())
        fw = (r.u8(), r.u8(), r.u8())
        return tag, dict(protocol=proto, firmware=fw, device_id=r.var(), boot_id=r.var(),
                         queue_capacity=r.var())
    if tag == "Live":
        return tag, dict(value_tenth_mm=r.var(), unit=r.var())
    if tag == "Reading":
        return tag, dict(boot_id=r.var(), seq=r.var(), value_tenth_mm=r.var(),
                         timestamp_ms=r.var(), unit=r.var())
    return tag, {}


def host_hello() -> bytes:
    return frame(bytes([0, 1, 0, 0, 1, 0]))  # Hello{protocol 1.0, software 0.1.0}


def host_ack(boot_id: int, seq: int) -> bytes:
    return frame(varint(1) + varint(boot_id) + varint(seq))


# ---------------------------------------------------------------- QEMU plumbing


class Board:
    def __init__(self, elf):
        state = os.path.join(os.environ.get("TMPDIR", "/tmp"), f"check-qemu.{os.getpid()}.env")
        cmd = [os.path.join(HERE, "run-qemu.sh"), "--no-build", state]
        if elf:
            cmd[2:2] = ["--elf", elf]
        launched = subprocess.run(cmd, stderr=subprocess.PIPE, text=True)
        if launched.returncode != 0:
            fail(f"run-qemu.sh failed (exit {launched.returncode}):\n{launched.stderr}")
        with open(state) as f:
            self.env = dict(line.rstrip("\n").split("=", 1) for line in f if "=" in line)
        os.unlink(state)
        self.tape = self._open(self.env["TAPE_PTY"])
        self.host = self._open(self.env["HOST_PTY"])
        self.buf = b""

    @staticmethod
    def _open(path):
        fd = os.open(path, os.O_RDWR | os.O_NOCTTY | os.O_NONBLOCK)
        tty.setraw(fd)
        return fd

    def monitor(self, command: str):
        with socket.socket(socket.AF_UNIX) as s:
            s.connect(self.env["MONITOR"])
            s.sendall(command.encode() + b"\n")
            time.sleep(0.1)

    def monitor_query(self, command: str) -> str:
        """Runs a monitor command and returns its output (up to the next prompt)."""
        with socket.socket(socket.AF_UNIX) as s:
            s.connect(self.env["MONITOR"])
            s.settimeout(5)
            out = b""
            while not out.endswith(b"(qemu) "):  # the banner and first prompt
                out += s.recv(65536)
            s.sendall(command.encode() + b"\n")
            out = b""
            while not out.endswith(b"(qemu) "):
                out += s.recv(65536)
            return out.decode(errors="replace")

    def stack_used(self) -> int:
        """Deepest stack use so far, bytes. The firmware is built with cortex-m-rt's
        `paint-stack`: the stack starts filled with 0xCCCCCCCC, and the lowest word that is
        no longer paint marks the deepest point the stack (interrupts included) reached.
        A lower bound of the true need: only the paths this check drove are measured."""
        words = []
        for line in self.monitor_query(f"xp /{(RAM_TOP - RAM_BASE) // 4}wx {RAM_BASE:#x}").splitlines():
            if ":" in line and line.strip().startswith("00"):
                words += [int(w, 16) for w in line.split(":", 1)[1].split()]
        # The painted area is the longest run of paint (a static may hold the value by
        # chance, but not for kilobytes); the word after it is the deepest one used.
        paint = 0xCCCCCCCC
        best_end, best_len, run = 0, 0, 0
        for i, word in enumerate(words):
            run = run + 1 if word == paint else 0
            if run > best_len:
                best_end, best_len = i + 1, run
        return RAM_TOP - (RAM_BASE + 4 * best_end)

    def frames(self, seconds: float):
        """Yields (time, tag, fields) for each frame from the device within `seconds`."""
        end = time.monotonic() + seconds
        while True:
            while b"\x00" in self.buf:
                body, self.buf = self.buf.split(b"\x00", 1)
                if body:
                    yield (time.monotonic(),) + decode_device(unframe(body))
            left = end - time.monotonic()
            if left <= 0:
                return
            ready, _, _ = select.select([self.host], [], [], left)
            if ready:
                self.buf += os.read(self.host, 4096)

    def close(self):
        try:
            self.monitor("quit")
        except OSError:
            pass
        os.close(self.tape)
        os.close(self.host)
        pid = int(self.env["QEMU_PID"])
        # QEMU quits on the monitor's "quit"; on a loaded machine that can
        # take seconds, and it may exit between the last look and the kill.
        for _ in range(100):
            try:
                os.kill(pid, 0)
            except OSError:
                return
            time.sleep(0.1)
        try:
            os.kill(pid, 9)
        except ProcessLookupError:
            pass


def fail(msg):
    print("FAIL:", msg)
    sys.exit(1)


def require_qemu():
    """Returns if qemu-system-arm runs here; else fails in CI and skips elsewhere."""
    if shutil.which("qemu-system-arm"):
        return
    if "CI" in os.environ:
        fail("qemu-system-arm is not installed, and CI is set: CI must install it "
             "(apt-get install -y qemu-system-arm)")
    print("SKIPPED check-qemu.py: qemu-system-arm is not installed "
          "(apt-get install -y qemu-system-arm)")
    sys.exit(0)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--elf")
    ap.add_argument("--device-id", type=lambda s: int(s, 0), default=DEFAULT_DEVICE_ID)
    args = ap.parse_args()
    require_qemu()

    boot_ids = []
    for launch in range(2):
        board = Board(args.elf)
        try:
            # 6: written while the guest is still paused.
            os.write(board.tape, b"*01234;00000;0000PM\n")
            board.monitor("cont")
            first = list(board.frames(3.5))
            hellos = [f for f in first if f[1] == "Hello"]
            if len(hellos) < 3:
                fail(f"expected >= 3 unanswered hellos in 3.5 s, got {len(hellos)}")
            early = [f[2] for f in first if f[1] == "Live"]
            print("live before the host hello:", early)
            if not any(live["value_tenth_mm"] == 1234 for live in early):
                fail("the line written before `cont` was lost")
            hello = hellos[0][2]
            print("hello:", hello)
            if hello["device_id"] != args.device_id:
                fail(f"device id {hello['device_id']:#x}, expected {args.device_id:#x}")
            # The first hello may have waited in the pty while `monitor` slept: skip it.
            periods = [b[0] - a[0] for a, b in zip(hellos[1:], hellos[2:])]
            print("hello periods (s):", ", ".join(f"{p:.3f}" for p in periods))
            if not all(0.8 < p < 1.2 for p in periods):
                fail(f"hello period off the 1.0 s interval: {periods}")
            boot = hello["boot_id"]
            boot_ids.append(boot)
            if launch == 1:
                # 7: a reset within one QEMU run (same seed) must change the boot id too.
                board.monitor("system_reset")
                again = [f[2] for f in board.frames(1.5) if f[1] == "Hello"]
                again = [h for h in again if h["boot_id"] != boot]
                if not again:
                    fail("no hello with a new boot id after system_reset")
                print(f"boot id after system_reset: {again[0]['boot_id']:#010x}")
                break

            os.write(board.host, host_hello())
            os.write(board.tape, b"*01250;00000;0000PM\n")
            os.write(board.tape, b"*02050;00000;0000SM\n")
            got = list(board.frames(1.2))
            lives = [f[2] for f in got if f[1] == "Live"]
            readings = [f for f in got if f[1] == "Reading"]
            print("live:", lives)
            print(f"readings before ack: {len(readings)}", readings[:1])
            if not any(live["value_tenth_mm"] == 1250 for live in lives):
                fail("no Live 1250 after the P line")
            if len(readings) < 2:
                fail("the unacknowledged reading was not retransmitted")
            r = readings[0][2]
            if (r["seq"], r["value_tenth_mm"], r["boot_id"]) != (0, 2050, boot):
                fail(f"wrong reading {r}")
            os.write(board.host, host_ack(boot, 0))
            list(board.frames(0.2))  # frames already in flight
            after = [f for f in board.frames(1.5) if f[1] == "Reading"]
            print("readings after ack:", len(after))
            if after:
                fail("retransmission went on after the Ack")
            print(f"stack high-water mark: {board.stack_used()} bytes")
        finally:
            board.close()
    if boot_ids[0] == boot_ids[1]:
        fail(f"two launches got the same boot id {boot_ids[0]:#x}")
    print(f"boot ids of two launches: {boot_ids[0]:#010x} {boot_ids[1]:#010x}")
    print("OK")


if __name__ == "__main__":
    main()
