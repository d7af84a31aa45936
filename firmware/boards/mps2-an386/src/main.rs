//! Tape-station firmware for QEMU's `mps2-an386` machine (ARM MPS2 with the AN386 FPGA
//! image: one Cortex-M4), so that the real firmware binary runs in CI.
//!
//! Why this board: it is the Cortex-M4 machine `qemu-system-arm` emulates with plain UARTs,
//! so the same `thumbv7em-none-eabihf` code that runs on the nRF52840 runs here with its
//! serial lines on host pseudo-terminals. Embassy has no HAL for it; the glue is small and
//! lives in this crate:
//!
//! - [`uart`]: interrupt-driven CMSDK APB UART driver (`embedded_io_async` Read/Write).
//!   UART0 (0x4000_4000, RX IRQ 0, TX IRQ 1) = tape, 9600 baud 8N1;
//!   UART1 (0x4000_5000, RX IRQ 2, TX IRQ 3) = host link, 115200 baud 8N1.
//!   QEMU's first `-serial` is UART0, the second UART1.
//! - [`time`]: embassy-time driver on CMSDK TIMER0/TIMER1 (IRQ 8, 9).
//! - the tasks run in embassy's interrupt executor on an otherwise unused IRQ line (31), at
//!   the lowest priority, and the thread loop only sleeps with `WFI`. Embassy's thread
//!   executor sleeps with `WFE`, which QEMU runs as a busy yield: it would keep one host
//!   core at 100 % while the firmware idles in CI. `WFI` really halts the emulated CPU
//!   until an interrupt.
//! - interrupts: there is no device crate, so this crate writes the device part of the
//!   vector table itself (`__INTERRUPTS`; IRQ numbers from QEMU's `hw/arm/mps2.c`).
//!
//! Identity: the device id is fixed per build (`TAPESHAPE_DEVICE_ID`, decimal or `0x` hex,
//! at build time; default [`DEFAULT_DEVICE_ID`]). The boot id must differ on every boot,
//! but an emulated machine boots identically every time, so the entropy comes from the
//! host: `run-qemu.sh` writes a random 32-bit seed at [`BOOT_SEED_ADDR`] with QEMU's
//! generic loader device, and a boot counter kept in `.uninit` RAM separates resets within
//! one QEMU run (`system_reset` on the monitor). See `README.md`.
#![no_std]
#![no_main]

mod time;
mod uart;

use core::mem::MaybeUninit;
use core::ptr::{addr_of_mut, read_volatile, write_volatile};

use cortex_m::peripheral::NVIC;
use cortex_m_rt::entry;
use embassy_executor::InterruptExecutor;
use embassy_time::{Instant, Timer};
use panic_halt as _;
use tapeshape_firmware::{run, Clock, Config, Device};

use uart::{Uart, UartState};

/// Where `run-qemu.sh` puts the per-launch boot seed (outside the linker's RAM region, see
/// `memory.x`).
pub const BOOT_SEED_ADDR: usize = 0x2000_FFF0;

/// Device id used when `TAPESHAPE_DEVICE_ID` is not set at build time: "MPS2" then 0x0386.
pub const DEFAULT_DEVICE_ID: u64 = 0x4D50_5332_0000_0386;

/// The device id of this build.
pub const DEVICE_ID: u64 = match option_env!("TAPESHAPE_DEVICE_ID") {
    Some(text) => parse_u64(text),
    None => DEFAULT_DEVICE_ID,
};

/// Tape UART baud rate (the tape's own 9600 8N1).
const TAPE_BAUD: u32 = 9600;
/// Host link baud rate.
const HOST_BAUD: u32 = 115_200;

static TAPE_STATE: UartState = UartState::new();
static HOST_STATE: UartState = UartState::new();
// SAFETY (both): the MPS2 UART0/UART1 register blocks, each paired with its own state.
static TAPE: Uart = unsafe { Uart::new(0x4000_4000, &TAPE_STATE) };
static HOST: Uart = unsafe { Uart::new(0x4000_5000, &HOST_STATE) };

/// The board's interrupt lines (QEMU `hw/arm/mps2.c`, AN385/AN386 layout).
#[derive(Clone, Copy)]
#[repr(u16)]
enum Irq {
    Uart0Rx = 0,
    Uart0Tx = 1,
    Uart1Rx = 2,
    Uart1Tx = 3,
    Timer0 = 8,
    Timer1 = 9,
    /// No device drives line 31 on this machine; the executor pends it in software.
    Executor = 31,
}

// SAFETY: the numbers are valid IRQ numbers of this machine (it has 32).
unsafe impl cortex_m::interrupt::InterruptNumber for Irq {
    fn number(self) -> u16 {
        self as u16
    }
}

extern "C" fn uart0_rx() {
    TAPE.on_rx_interrupt();
}
extern "C" fn uart0_tx() {
    TAPE.on_tx_interrupt();
}
extern "C" fn uart1_rx() {
    HOST.on_rx_interrupt();
}
extern "C" fn uart1_tx() {
    HOST.on_tx_interrupt();
}
extern "C" fn timer0() {
    time::on_timer0_interrupt();
}
extern "C" fn timer1() {
    time::on_timer1_interrupt();
}
extern "C" fn executor() {
    // SAFETY: EXECUTOR was started on this line, and this is its only handler.
    unsafe { EXECUTOR.on_interrupt() }
}
/// Lines that are never unmasked; the handler only exists to fill the table.
extern "C" fn unused() {}

/// The device part of the vector table (IRQ 0..=31), which cortex-m-rt places after the
/// core exceptions. Written here because there is no device crate for this machine.
#[unsafe(link_section = ".vector_table.interrupts")]
#[unsafe(no_mangle)]
static __INTERRUPTS: [extern "C" fn(); 32] = {
    let mut table: [extern "C" fn(); 32] = [unused; 32];
    table[Irq::Uart0Rx as usize] = uart0_rx;
    table[Irq::Uart0Tx as usize] = uart0_tx;
    table[Irq::Uart1Rx as usize] = uart1_rx;
    table[Irq::Uart1Tx as usize] = uart1_tx;
    table[Irq::Timer0 as usize] = timer0;
    table[Irq::Timer1 as usize] = timer1;
    table[Irq::Executor as usize] = executor;
    table
};

/// Parses a decimal or `0x`-prefixed hexadecimal u64 at compile time; a malformed
/// `TAPESHAPE_DEVICE_ID` fails the build.
const fn parse_u64(text: &str) -> u64 {
    let bytes = text.as_bytes();
    let (radix, mut i) = if bytes.len() > 2 && bytes[0] == b'0' && (bytes[1] | 0x20) == b'x' {
        (16, 2)
    } else {
        (10, 0)
    };
    assert!(i < bytes.len(), "TAPESHAPE_DEVICE_ID is empty");
    let mut value: u64 = 0;
    while i < bytes.len() {
        let c = bytes[i];
        let digit = match c {
            b'0'..=b'9' => (c - b'0') as u64,
            b'a'..=b'f' if radix == 16 => (c - b'a' + 10) as u64,
            b'A'..=b'F' if radix == 16 => (c - b'A' + 10) as u64,
            b'_' => {
                i += 1;
                continue;
            }
            _ => panic!("TAPESHAPE_DEVICE_ID: not a decimal or 0x-hex number"),
        };
        value = match value.checked_mul(radix) {
            Some(v) => match v.checked_add(digit) {
                Some(v) => v,
                None => panic!("TAPESHAPE_DEVICE_ID does not fit in 64 bits"),
            },
            None => panic!("TAPESHAPE_DEVICE_ID does not fit in 64 bits"),
        };
        i += 1;
    }
    value
}

/// Boot counter kept across resets within one QEMU run: `[magic, count]`.
#[unsafe(link_section = ".uninit.BOOT_COUNT")]
static mut BOOT_COUNT: MaybeUninit<[u32; 2]> = MaybeUninit::uninit();
const BOOT_COUNT_MAGIC: u32 = 0x7A9E_B007;

/// This boot's id: the host's seed mixed with the boot count (see the crate docs).
fn boot_id() -> u32 {
    // SAFETY: BOOT_SEED_ADDR is RAM outside every linker section (memory.x); reading
    // whatever is there is fine. BOOT_COUNT is only touched here, before any interrupt or
    // task runs.
    let (seed, count) = unsafe {
        let seed = read_volatile(BOOT_SEED_ADDR as *const u32);
        // Volatile, so that the optimiser keeps the two words together in `.uninit`.
        let slot = addr_of_mut!(BOOT_COUNT).cast::<[u32; 2]>();
        let [magic, previous] = read_volatile(slot);
        let count = if magic == BOOT_COUNT_MAGIC {
            previous.wrapping_add(1)
        } else {
            0
        };
        write_volatile(slot, [BOOT_COUNT_MAGIC, count]);
        (seed, count)
    };
    mix32(seed ^ count.wrapping_mul(0x9E37_79B9))
}

/// A 32-bit bijective mixer (the finaliser of MurmurHash3), so that consecutive boot
/// counts give unrelated-looking ids.
fn mix32(mut x: u32) -> u32 {
    x ^= x >> 16;
    x = x.wrapping_mul(0x85EB_CA6B);
    x ^= x >> 13;
    x = x.wrapping_mul(0xC2B2_AE35);
    x ^ (x >> 16)
}

/// Runs all tasks, in the handler of [`Irq::Executor`].
static EXECUTOR: InterruptExecutor = InterruptExecutor::new();

#[entry]
fn main() -> ! {
    let boot_id = boot_id();
    time::init();
    TAPE.enable(time::PCLK_HZ, TAPE_BAUD);
    HOST.enable(time::PCLK_HZ, HOST_BAUD);
    for irq in [
        Irq::Uart0Rx,
        Irq::Uart0Tx,
        Irq::Uart1Rx,
        Irq::Uart1Tx,
        Irq::Timer0,
        Irq::Timer1,
    ] {
        // SAFETY: the handlers only touch their own device and state (no critical section
        // is broken by letting them run).
        unsafe { NVIC::unmask(irq) };
    }

    // SAFETY: only priorities are changed; the UART and timer handlers outrank the executor
    // so that a long poll never delays a received byte or a timer wrap.
    unsafe {
        let mut peripherals = cortex_m::Peripherals::steal();
        peripherals.NVIC.set_priority(Irq::Executor, 0xE0);
    }
    let spawner = EXECUTOR.start(Irq::Executor);
    match station(boot_id) {
        Ok(token) => spawner.spawn(token),
        // Unreachable: the task's pool holds one and it is spawned once.
        Err(_) => cortex_m::asm::udf(),
    }
    loop {
        // Everything happens in interrupt handlers; sleep until the next one.
        cortex_m::asm::wfi();
    }
}

/// The firmware's clock on embassy-time (32,768 Hz ticks, see [`time`]).
struct EmbassyClock;

impl Clock for EmbassyClock {
    fn now_ms(&self) -> u64 {
        Instant::now().as_millis()
    }

    async fn sleep_until(&self, deadline_ms: u64) {
        // Round up to whole ticks, so that `now_ms()` has reached the deadline when the
        // timer fires (rounding down would wake up to a millisecond early, again and again).
        let at = deadline_ms
            .checked_mul(embassy_time::TICK_HZ)
            .map_or(Instant::MAX, |ticks| {
                Instant::from_ticks(ticks.div_ceil(1000))
            });
        Timer::at(at).await
    }
}

#[embassy_executor::task]
async fn station(boot_id: u32) {
    let (mut tape, mut host_rx, mut host_tx) = (TAPE, HOST, HOST);
    let clock = EmbassyClock;
    let mut device = Device::new(Config::new(DEVICE_ID, boot_id), clock.now_ms());
    loop {
        // A UART read waits for at least one byte, so `run` never sees the end of a stream
        // here; should it return anyway, it resumes with the same device state.
        let _ = run(&mut device, &mut tape, &mut host_rx, &mut host_tx, &clock).await;
    }
}
