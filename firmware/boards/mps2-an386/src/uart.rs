//! Interrupt-driven driver for the CMSDK APB UART (ARM DDI0479C, section 4.3), the UART of
//! the MPS2 FPGA images, exposed as `embedded_io_async::{Read, Write}`.
//!
//! Why written by hand: embassy has no HAL for the MPS2 boards and no crate on crates.io
//! drives this UART asynchronously. The device is small (five registers), so the driver is
//! too.
//!
//! Receive path: the RX interrupt moves each byte from `DATA` into a [`Pipe`] that the task
//! reads asynchronously. The UART itself holds one byte, so a polled driver would lose bytes
//! whenever the task is busy for longer than one character time; the interrupt does not.
//! When the pipe is full the handler leaves the byte in `DATA` and sets `stalled`; the next
//! `read` moves it on. Under QEMU nothing is lost even then: QEMU's model offers the next
//! byte only once `DATA` has been read, so the host's writes simply wait in the
//! pseudo-terminal. On silicon a byte arriving while `DATA` is full sets `RXOVERRUN`; the
//! handler clears it and the next `read` returns [`UartError::Overrun`] (the firmware logic
//! counts it as a tape I/O error; the damaged tape line fails its checks and is counted as
//! rejected, never forwarded).
//!
//! Transmit path: `write` puts bytes into `DATA` while `TXFULL` is clear and, when it is
//! set, enables the TX interrupt and sleeps until the byte has gone.

use core::future::poll_fn;
use core::ptr::{read_volatile, write_volatile};
use core::sync::atomic::{AtomicBool, AtomicU32, Ordering};
use core::task::Poll;

use embassy_sync::blocking_mutex::raw::CriticalSectionRawMutex;
use embassy_sync::pipe::Pipe;
use embassy_sync::waitqueue::AtomicWaker;

/// Capacity of each UART's receive buffer, bytes. A tape line is 20 bytes and a host frame
/// at most a few dozen; 128 bytes covers several of either while the task is busy.
pub const RX_BUFFER: usize = 128;

// Register offsets and bits (DDI0479C table 4-6 and QEMU's hw/char/cmsdk-apb-uart.c).
const DATA: usize = 0x00;
const STATE: usize = 0x04;
const CTRL: usize = 0x08;
const INTSTATUS: usize = 0x0C; // read: INTSTATUS, write 1 to clear: INTCLEAR
const BAUDDIV: usize = 0x10;

const STATE_TXFULL: u32 = 1 << 0;
const STATE_RXFULL: u32 = 1 << 1;
const STATE_TXOVERRUN: u32 = 1 << 2;
const STATE_RXOVERRUN: u32 = 1 << 3;

const CTRL_TX_EN: u32 = 1 << 0;
const CTRL_RX_EN: u32 = 1 << 1;
const CTRL_TX_INTEN: u32 = 1 << 2;
const CTRL_RX_INTEN: u32 = 1 << 3;

const INT_TX: u32 = 1 << 0;
const INT_RX: u32 = 1 << 1;

/// Shared between a UART's interrupt handlers and its driver.
pub struct UartState {
    rx: Pipe<CriticalSectionRawMutex, RX_BUFFER>,
    /// Set by the RX handler when it left a byte in `DATA` because `rx` was full.
    stalled: AtomicBool,
    tx_waker: AtomicWaker,
    /// Overruns not yet reported by `read`.
    overruns: AtomicU32,
}

impl UartState {
    /// An empty state, for a `static`.
    pub const fn new() -> Self {
        Self {
            rx: Pipe::new(),
            stalled: AtomicBool::new(false),
            tx_waker: AtomicWaker::new(),
            overruns: AtomicU32::new(0),
        }
    }
}

/// One CMSDK APB UART: its register block and its interrupt-shared state.
#[derive(Clone, Copy)]
pub struct Uart {
    base: usize,
    state: &'static UartState,
}

impl Uart {
    /// A handle on the UART whose registers start at `base`.
    ///
    /// # Safety
    /// `base` must be the address of a CMSDK APB UART, and `state` must be used with that UART
    /// only (its interrupt handlers must call [`Uart::on_rx_interrupt`] /
    /// [`Uart::on_tx_interrupt`] of a handle built from the same pair).
    pub const unsafe fn new(base: usize, state: &'static UartState) -> Self {
        Self { base, state }
    }

    fn read_reg(&self, offset: usize) -> u32 {
        // SAFETY: `base` is a CMSDK UART register block (contract of `new`).
        unsafe { read_volatile((self.base + offset) as *const u32) }
    }

    fn write_reg(&self, offset: usize, value: u32) {
        // SAFETY: as in `read_reg`.
        unsafe { write_volatile((self.base + offset) as *mut u32, value) }
    }

    /// Sets the baud rate and enables transmitter, receiver and the RX interrupt
    /// (8N1 is fixed in this UART). `pclk_hz` is the APB clock (25 MHz on MPS2).
    ///
    /// The NVIC lines are unmasked by the caller.
    pub fn enable(&self, pclk_hz: u32, baud: u32) {
        self.write_reg(CTRL, 0);
        // The UART needs BAUDDIV >= 16; QEMU ignores smaller values.
        self.write_reg(BAUDDIV, (pclk_hz / baud).max(16));
        self.write_reg(INTSTATUS, 0xF);
        self.write_reg(STATE, STATE_TXOVERRUN | STATE_RXOVERRUN);
        self.write_reg(CTRL, CTRL_TX_EN | CTRL_RX_EN | CTRL_RX_INTEN);
    }

    /// Moves bytes from `DATA` into the receive pipe while both allow; notes overruns.
    fn drain_hw(&self) {
        let state = self.read_reg(STATE);
        if state & STATE_RXOVERRUN != 0 {
            self.write_reg(STATE, STATE_RXOVERRUN);
            self.state.overruns.fetch_add(1, Ordering::Relaxed);
        }
        if self.read_reg(STATE) & STATE_RXFULL == 0 {
            self.state.stalled.store(false, Ordering::Relaxed);
            return;
        }
        // One byte at most: the UART has a single receive register.
        if self.state.rx.free_capacity() == 0 {
            self.state.stalled.store(true, Ordering::Relaxed);
            return;
        }
        let byte = self.read_reg(DATA) as u8;
        // Cannot fail: there is room (checked above) and only this code writes the pipe,
        // always inside an interrupt handler or a critical section.
        let _ = self.state.rx.try_write(&[byte]);
        self.state.stalled.store(false, Ordering::Relaxed);
    }

    /// RX interrupt handler body.
    pub fn on_rx_interrupt(&self) {
        self.write_reg(INTSTATUS, INT_RX);
        self.drain_hw();
    }

    /// TX interrupt handler body: the transmit register has room again.
    pub fn on_tx_interrupt(&self) {
        self.write_reg(INTSTATUS, INT_TX);
        let ctrl = self.read_reg(CTRL);
        self.write_reg(CTRL, ctrl & !CTRL_TX_INTEN);
        self.state.tx_waker.wake();
    }

    /// Waits until the transmit register is free.
    async fn tx_ready(&self) {
        poll_fn(|cx| {
            if self.read_reg(STATE) & STATE_TXFULL == 0 {
                return Poll::Ready(());
            }
            self.state.tx_waker.register(cx.waker());
            critical_section::with(|_| {
                let ctrl = self.read_reg(CTRL);
                self.write_reg(CTRL, ctrl | CTRL_TX_INTEN);
            });
            // The byte may have gone between the check and enabling the interrupt, and
            // the interrupt fires only on the full-to-empty edge: check again.
            if self.read_reg(STATE) & STATE_TXFULL == 0 {
                Poll::Ready(())
            } else {
                Poll::Pending
            }
        })
        .await
    }
}

/// A receive error of the UART.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum UartError {
    /// Bytes arrived while the receive register was still full and were lost (silicon only;
    /// QEMU holds bytes back instead). Reported once per burst of overruns, before the bytes
    /// that followed them.
    Overrun,
}

impl embedded_io_async::Error for UartError {
    fn kind(&self) -> embedded_io_async::ErrorKind {
        embedded_io_async::ErrorKind::Other
    }
}

impl core::fmt::Display for UartError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str("UART receive overrun: bytes were lost")
    }
}

impl core::error::Error for UartError {}

impl embedded_io_async::ErrorType for Uart {
    type Error = UartError;
}

impl embedded_io_async::Read for Uart {
    /// Waits for at least one received byte. Cancel-safe: no byte leaves the receive buffer
    /// unless this returns it.
    async fn read(&mut self, buf: &mut [u8]) -> Result<usize, UartError> {
        if self.state.overruns.swap(0, Ordering::Relaxed) != 0 {
            return Err(UartError::Overrun);
        }
        if buf.is_empty() {
            return Ok(0);
        }
        let n = self.state.rx.read(buf).await;
        if self.state.stalled.load(Ordering::Relaxed) {
            // The handler left a byte in DATA for want of room; there is room now.
            critical_section::with(|_| self.drain_hw());
        }
        Ok(n)
    }
}

impl embedded_io_async::Write for Uart {
    async fn write(&mut self, buf: &[u8]) -> Result<usize, UartError> {
        if buf.is_empty() {
            return Ok(0);
        }
        self.tx_ready().await;
        let mut sent = 0;
        for &byte in buf {
            if self.read_reg(STATE) & STATE_TXFULL != 0 {
                break;
            }
            self.write_reg(DATA, u32::from(byte));
            sent += 1;
        }
        Ok(sent)
    }

    async fn flush(&mut self) -> Result<(), UartError> {
        self.tx_ready().await;
        Ok(())
    }
}
