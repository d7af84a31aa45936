//! embassy-time driver on the two CMSDK APB timers of the MPS2 (ARM DDI0479C, section 4.4).
//!
//! Why written by hand: embassy has no HAL for the MPS2 boards. The `Driver` trait is
//! implemented as embassy-time-driver documents it, with the timer queue from
//! embassy-time-queue-utils.
//!
//! - TIMER0 (0x4000_0000, IRQ 8) free-runs down from `0xFFFF_FFFF` at PCLK (25 MHz); its
//!   interrupt counts the 2^32-cycle periods, so `now` is a 64-bit cycle count that never
//!   wraps in practice (2^64 cycles at 25 MHz is 23,000 years). The first period is cut
//!   short: the counter starts [`FIRST_WRAP_S`] seconds before its first wrap, so that every
//!   run, even a CI run of a few seconds, goes through the wrap handling (a wrap otherwise
//!   comes only every 171 s).
//! - TIMER1 (0x4000_1000, IRQ 9) is a one-shot alarm: armed for the cycles left until the
//!   earliest queued wake-up (at most 2^32 - 1 cycles, 171 s; a later wake-up re-arms).
//!
//! The tick rate is 32,768 Hz (embassy-time-driver feature `tick-hz-32_768`), the rate the
//! nRF52840 board's RTC driver uses too: both binaries share one workspace and cargo unifies
//! features across it, so they must agree. Ticks are cycles * 32768 / 25e6, which reduces
//! to cycles * 512 / 390625.

use core::cell::{Cell, RefCell};
use core::ptr::{read_volatile, write_volatile};

use critical_section::{CriticalSection, Mutex};
use embassy_time_driver::Driver;
use embassy_time_queue_utils::Queue;

/// APB clock of the MPS2 FPGA images (QEMU's `SYSCLK_FRQ`), Hz.
pub const PCLK_HZ: u32 = 25_000_000;

/// Seconds from `init` to TIMER0's first wrap.
pub const FIRST_WRAP_S: u32 = 2;
const FIRST_WRAP_CYCLES: u32 = FIRST_WRAP_S * PCLK_HZ;
/// The raw cycle count at `init` (the counter starts part-way into its first period), taken
/// off so that time starts at 0.
const START_CYCLES: u64 = (1 << 32) - FIRST_WRAP_CYCLES as u64;

const TIMER0: usize = 0x4000_0000;
const TIMER1: usize = 0x4000_1000;

// Register offsets and bits of the CMSDK APB timer.
const CTRL: usize = 0x0;
const VALUE: usize = 0x4;
const RELOAD: usize = 0x8;
const INTSTATUS: usize = 0xC; // write 1 to clear
const CTRL_EN: u32 = 1 << 0;
const CTRL_IRQEN: u32 = 1 << 3;

// ticks = cycles * TICK_NUM / TICK_DEN, with 32768 / 25_000_000 reduced.
const TICK_NUM: u64 = 512;
const TICK_DEN: u64 = 390_625;
const _: () = assert!(embassy_time_driver::TICK_HZ == 32_768);
const _: () = assert!(TICK_NUM * PCLK_HZ as u64 == TICK_DEN * 32_768);

fn read(addr: usize) -> u32 {
    // SAFETY: only called with the addresses of the MPS2 timer registers above.
    unsafe { read_volatile(addr as *const u32) }
}

fn write(addr: usize, value: u32) {
    // SAFETY: as in `read`.
    unsafe { write_volatile(addr as *mut u32, value) }
}

struct Mps2TimeDriver {
    /// Completed 2^32-cycle periods of TIMER0.
    periods: Mutex<Cell<u32>>,
    queue: Mutex<RefCell<Queue>>,
}

embassy_time_driver::time_driver_impl!(static DRIVER: Mps2TimeDriver = Mps2TimeDriver {
    periods: Mutex::new(Cell::new(0)),
    queue: Mutex::new(RefCell::new(Queue::new())),
});

/// Starts TIMER0 free-running and leaves TIMER1 stopped. Call once, before the NVIC lines
/// of IRQ 8 and 9 are unmasked.
pub fn init() {
    write(TIMER1 + CTRL, 0);
    write(TIMER1 + INTSTATUS, 1);
    write(TIMER0 + CTRL, 0);
    write(TIMER0 + INTSTATUS, 1);
    // Writing RELOAD also loads the counter; VALUE then moves it closer to the first wrap.
    write(TIMER0 + RELOAD, u32::MAX);
    write(TIMER0 + VALUE, FIRST_WRAP_CYCLES);
    write(TIMER0 + CTRL, CTRL_EN | CTRL_IRQEN);
}

/// TIMER0 interrupt: one more 2^32-cycle period has passed.
pub fn on_timer0_interrupt() {
    critical_section::with(|cs| {
        write(TIMER0 + INTSTATUS, 1);
        let periods = DRIVER.periods.borrow(cs);
        periods.set(periods.get().wrapping_add(1));
    });
}

/// TIMER1 interrupt: the alarm went off; wake what is due and arm the next one.
pub fn on_timer1_interrupt() {
    critical_section::with(|cs| {
        write(TIMER1 + CTRL, 0);
        write(TIMER1 + INTSTATUS, 1);
        DRIVER.rearm(cs);
    });
}

impl Mps2TimeDriver {
    /// Cycles since `init`. Never below `START_CYCLES` before the subtraction: the counter
    /// only counts on from where `init` put it.
    fn cycles(&self, cs: CriticalSection<'_>) -> u64 {
        let mut periods = self.periods.borrow(cs).get();
        // The period count and the counter must be read as one. With interrupts off, a wrap
        // that happened since the last interrupt shows as a pending INTSTATUS. A wrap between
        // reading `first` and INTSTATUS would pair the old period with a restarted counter;
        // reading the counter again after INTSTATUS avoids that.
        let first = read(TIMER0 + VALUE);
        let value = if read(TIMER0 + INTSTATUS) & 1 != 0 {
            periods = periods.wrapping_add(1);
            read(TIMER0 + VALUE)
        } else {
            first
        };
        // The interrupt fires as the counter reaches 0, so a period starts at 0 (elapsed 0),
        // goes on at 0xFFFF_FFFF after the reload (elapsed 1) and ends at 1 (elapsed
        // 2^32 - 1): elapsed = -value mod 2^32, monotonic across the wrap.
        ((u64::from(periods) << 32) | u64::from(value.wrapping_neg())).saturating_sub(START_CYCLES)
    }

    fn ticks(&self, cs: CriticalSection<'_>) -> u64 {
        self.cycles(cs) * TICK_NUM / TICK_DEN
    }

    /// Arms TIMER1 for the tick `at`. Returns false if `at` has already passed (the caller
    /// then processes the queue again).
    fn set_alarm(&self, cs: CriticalSection<'_>, at: u64) -> bool {
        write(TIMER1 + CTRL, 0);
        write(TIMER1 + INTSTATUS, 1);
        if at == u64::MAX {
            return true; // nothing queued
        }
        let now = self.cycles(cs);
        // First cycle at which the tick count reaches `at` (ceil). `at` is below 2^64 / 2^19
        // for any real schedule; saturate rather than overflow.
        let due = at.saturating_mul(TICK_DEN).div_ceil(TICK_NUM);
        if due <= now {
            return false;
        }
        let delta = u32::try_from(due - now).unwrap_or(u32::MAX);
        // One-shot: RELOAD = 0 stops the counter at zero after the interrupt.
        write(TIMER1 + RELOAD, 0);
        write(TIMER1 + VALUE, delta);
        write(TIMER1 + CTRL, CTRL_EN | CTRL_IRQEN);
        true
    }

    fn rearm(&self, cs: CriticalSection<'_>) {
        let mut queue = self.queue.borrow(cs).borrow_mut();
        let mut next = queue.next_expiration(self.ticks(cs));
        while !self.set_alarm(cs, next) {
            next = queue.next_expiration(self.ticks(cs));
        }
    }
}

impl Driver for Mps2TimeDriver {
    fn now(&self) -> u64 {
        critical_section::with(|cs| self.ticks(cs))
    }

    fn schedule_wake(&self, at: u64, waker: &core::task::Waker) {
        critical_section::with(|cs| {
            let changed = self.queue.borrow(cs).borrow_mut().schedule_wake(at, waker);
            if changed {
                self.rearm(cs);
            }
        });
    }
}
