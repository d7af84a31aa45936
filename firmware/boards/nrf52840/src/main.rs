//! Tape-station firmware for the nRF52840 (built and pinned for the nRF52840-DK, PCA10056).
//!
//! Why this board: embassy supports it fully (embassy-nrf), it has a native USB device, so
//! the host link needs no USB-serial bridge, and a hardware RNG and a factory device id for
//! the hello message.
//!
//! - Tape: UARTE0 through embassy-nrf's `BufferedUarte` (interrupt + DMA into a ring, so
//!   bytes keep arriving while the task is busy), receive only, 9600 baud 8N1, RXD = P0.08.
//!   This is the DK's interface-MCU virtual COM port pin: with no tape attached, tape
//!   lines typed into the J-Link VCOM port reach the firmware, which is how the board is
//!   tested on the bench. A real tape's TX line (3.3 V logic) goes to P0.08, GND to GND.
//! - Host: USB CDC-ACM (embassy-usb) on the nRF USB connector (J3 on the DK), so the host
//!   sees `/dev/ttyACM*` and the link runs at USB speed, independent of the baud rate the
//!   host sets. A second UARTE would need a USB-serial bridge and would couple the link to
//!   a baud rate; USB is what the station PC has anyway.
//! - Identity: device id = FICR DEVICEID (64-bit factory id), also the USB serial number
//!   (16 hex digits); boot id = 32 bits from the RNG peripheral at boot.
//! - Time: RTC1 at 32,768 Hz (embassy-nrf `time-driver-rtc1`).
//! - Recovery: a station must come back by itself, so a panic resets the chip (instead of
//!   halting it until someone power-cycles the station), and the hardware watchdog (2 s)
//!   resets it if the cooperative executor stops running tasks: a task that never yields,
//!   or a fault (the HardFault handler loops). The host sees the new boot id and resumes;
//!   readings it has acknowledged are already stored on its side. (The mps2-an386 build
//!   halts on panic instead, so that a panic in CI shows as a failure, not as a reboot.)
#![no_std]
#![no_main]

use embassy_executor::Spawner;
use embassy_nrf::buffered_uarte::{self, BufferedUarteRx};
use embassy_nrf::usb::vbus_detect::HardwareVbusDetect;
use embassy_nrf::usb::{self, Driver};
use embassy_nrf::{bind_interrupts, config, pac, peripherals, rng, uarte, wdt, Peri};
use embassy_time::{with_timeout, Duration, Instant, Timer};
use embassy_usb::class::cdc_acm::{BufferedReceiver, CdcAcmClass, CdcAcmError, Sender, State};
use embassy_usb::UsbDevice;
use embedded_io_async::{Read, Write};
use static_cell::StaticCell;
// The USB vendor and product id, manufacturer and product strings: shared with the host,
// which finds the station's port by them (`tapeshape_protocol::usb`).
use tapeshape_firmware::protocol::usb as usb_id;
use tapeshape_firmware::{run, Clock, Config, Device};

bind_interrupts!(struct Irqs {
    UARTE0 => buffered_uarte::InterruptHandler<peripherals::UARTE0>;
    USBD => usb::InterruptHandler<peripherals::USBD>;
    CLOCK_POWER => usb::vbus_detect::InterruptHandler;
});

/// Full-speed bulk packet size of the CDC-ACM data endpoints, bytes.
const USB_PACKET: u16 = 64;

/// Tape UART receive buffer, bytes: 2.1 s of the tape at 9600 baud (102 lines). It must
/// hold what the tape sends while `run` is busy writing to the host, and a host that holds
/// DTR but has stopped reading makes each USB packet wait [`HOST_WRITE_TIMEOUT`]: one
/// retransmission round of a full queue (32 readings, about 600 bytes = 10 packets) then
/// takes about 1 s.
const TAPE_RX_BUFFER: usize = 2048;

type UsbDriver = Driver<'static, HardwareVbusDetect>;

/// The factory-programmed 64-bit device id (FICR DEVICEID[1]:DEVICEID[0]).
fn device_id() -> u64 {
    let low = pac::FICR.deviceid(0).read();
    let high = pac::FICR.deviceid(1).read();
    (u64::from(high) << 32) | u64::from(low)
}

/// The device id as 16 upper-case hex digits, for the USB serial number string: the host
/// then names the port after the device (`/dev/serial/by-id/usb-tapeshape_..._<ID>-if00`),
/// so a station with two tapes, or a replaced one, is told apart without opening the port.
fn usb_serial(device_id: u64) -> &'static str {
    static SERIAL: StaticCell<[u8; 16]> = StaticCell::new();
    let digits = SERIAL.init([0; 16]);
    for (i, digit) in digits.iter_mut().enumerate() {
        let nibble = (device_id >> (60 - 4 * i)) & 0xF;
        *digit = b"0123456789ABCDEF"[nibble as usize];
    }
    // Hex digits are ASCII, so this cannot fail.
    core::str::from_utf8(digits).unwrap_or("")
}

/// 32 random bits from the RNG peripheral (bias correction on).
fn boot_id(rng: Peri<'static, peripherals::RNG>) -> u32 {
    let mut rng = rng::Rng::new_blocking(rng);
    rng.set_bias_correction(true);
    rng.blocking_next_u32()
}

/// The firmware's clock on embassy-time (RTC1, 32,768 Hz ticks).
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

/// Host link, device to host: the CDC-ACM sender, made never to block for long.
///
/// `run` requires that a write does not block forever when no host listens. A USB host
/// only collects IN packets while a program has the port open, so: nothing is sent while
/// the host has not raised DTR (Linux raises it when a program opens `/dev/ttyACM*`), and a
/// packet the host does not collect within [`HOST_WRITE_TIMEOUT`] is given up. Both are
/// reported as errors, which `run` counts in the status (`host_io_errors`); readings are
/// retransmitted until acknowledged, so nothing accepted is lost.
///
/// `flush` ends the USB transfer with a zero-length packet when the last packet was full:
/// otherwise the host's driver may hold a frame that ended exactly on a packet boundary
/// until more data arrives.
struct HostTx {
    sender: Sender<'static, UsbDriver>,
    /// The last packet sent was a full one (a transfer the host sees as unfinished).
    open_transfer: bool,
}

/// How long one USB packet may wait for the host to collect it.
const HOST_WRITE_TIMEOUT: Duration = Duration::from_millis(100);

impl embedded_io_async::ErrorType for HostTx {
    type Error = CdcAcmError;
}

impl Write for HostTx {
    async fn write(&mut self, buf: &[u8]) -> Result<usize, CdcAcmError> {
        if !self.sender.dtr() {
            return Err(CdcAcmError::NotConnected);
        }
        let n = with_timeout(HOST_WRITE_TIMEOUT, self.sender.write(buf))
            .await
            .unwrap_or(Err(CdcAcmError::NotConnected))?;
        self.open_transfer = n == usize::from(USB_PACKET);
        Ok(n)
    }

    async fn flush(&mut self) -> Result<(), CdcAcmError> {
        if self.open_transfer {
            self.open_transfer = false;
            return match with_timeout(HOST_WRITE_TIMEOUT, self.sender.write_packet(&[])).await {
                Ok(Ok(())) => Ok(()),
                _ => Err(CdcAcmError::NotConnected),
            };
        }
        Ok(())
    }
}

/// Host link, host to device: the CDC-ACM receiver, waiting out the times when USB is
/// unplugged or not configured (instead of failing every read, which would make `run`
/// count an error every millisecond), and skipping zero-length packets (which `run` would
/// take for the end of the stream).
struct HostRx(BufferedReceiver<'static, UsbDriver>);

impl embedded_io_async::ErrorType for HostRx {
    type Error = CdcAcmError;
}

impl Read for HostRx {
    async fn read(&mut self, buf: &mut [u8]) -> Result<usize, CdcAcmError> {
        if buf.is_empty() {
            return Ok(0);
        }
        loop {
            match self.0.read(buf).await {
                Ok(0) => {}
                Ok(n) => return Ok(n),
                Err(CdcAcmError::NotConnected) => self.0.wait_connection().await,
            }
        }
    }
}

/// Watchdog period, in 32,768 Hz ticks (2 s).
const WATCHDOG_TICKS: u32 = 2 * 32_768;
/// How often the watchdog task pets the watchdog.
const WATCHDOG_PET: Duration = Duration::from_millis(500);

#[panic_handler]
fn panic(_info: &core::panic::PanicInfo) -> ! {
    cortex_m::peripheral::SCB::sys_reset()
}

/// Starts the watchdog, or finds it already running from before a soft reset (it survives
/// one) with the same settings. With other settings (a different firmware set it up) it
/// cannot be changed until it expires; it then resets the chip, and the next boot takes it
/// over.
fn start_watchdog(wdt_peripheral: Peri<'static, peripherals::WDT>) -> Option<wdt::WatchdogHandle> {
    let mut config = wdt::Config::default();
    config.timeout_ticks = WATCHDOG_TICKS;
    // Stopping at a breakpoint must not reset the chip under the debugger.
    config.action_during_debug_halt = wdt::HaltConfig::Pause;
    match wdt::Watchdog::try_new::<_, 1>(wdt_peripheral, config) {
        Ok((_watchdog, [handle])) => Some(handle),
        Err(_) => None,
    }
}

/// Pets the watchdog while the executor keeps running tasks.
#[embassy_executor::task]
async fn watchdog_task(mut handle: wdt::WatchdogHandle) -> ! {
    loop {
        handle.pet();
        Timer::after(WATCHDOG_PET).await;
    }
}

#[embassy_executor::main]
async fn main(spawner: Spawner) {
    let mut config = config::Config::default();
    // USB needs the 64 MHz crystal oscillator.
    config.hfclk_source = config::HfclkSource::ExternalXtal;
    let p = embassy_nrf::init(config);

    if let Some(handle) = start_watchdog(p.WDT) {
        match watchdog_task(handle) {
            Ok(token) => spawner.spawn(token),
            // Unreachable: the task's pool holds one and it is spawned once.
            Err(_) => cortex_m::asm::udf(),
        }
    }
    let boot_id = boot_id(p.RNG);
    let device_id = device_id();

    let mut uart_config = uarte::Config::default();
    uart_config.baudrate = uarte::Baudrate::Baud9600;
    uart_config.parity = uarte::Parity::Excluded;
    static TAPE_RX: StaticCell<[u8; TAPE_RX_BUFFER]> = StaticCell::new();
    // Receive only: the firmware never sends to the tape, so P0.06 stays free.
    let mut tape_rx = BufferedUarteRx::new(
        p.UARTE0,
        p.TIMER1,
        p.PPI_CH0,
        p.PPI_CH1,
        p.PPI_GROUP0,
        Irqs,
        p.P0_08,
        uart_config,
        TAPE_RX.init([0; TAPE_RX_BUFFER]),
    );

    let driver = Driver::new(p.USBD, Irqs, HardwareVbusDetect::new(Irqs));
    let mut usb_config = embassy_usb::Config::new(usb_id::VID, usb_id::PID);
    usb_config.manufacturer = Some(usb_id::MANUFACTURER);
    usb_config.product = Some(usb_id::PRODUCT);
    usb_config.serial_number = Some(usb_serial(device_id));
    usb_config.max_power = 100;
    usb_config.max_packet_size_0 = 64;

    static CONFIG_DESC: StaticCell<[u8; 128]> = StaticCell::new();
    static BOS_DESC: StaticCell<[u8; 16]> = StaticCell::new();
    static CONTROL_BUF: StaticCell<[u8; 64]> = StaticCell::new();
    static CDC_STATE: StaticCell<State> = StaticCell::new();
    static RX_PACKET: StaticCell<[u8; USB_PACKET as usize]> = StaticCell::new();
    let mut builder = embassy_usb::Builder::new(
        driver,
        usb_config,
        CONFIG_DESC.init([0; 128]),
        BOS_DESC.init([0; 16]),
        &mut [],
        CONTROL_BUF.init([0; 64]),
    );
    let class = CdcAcmClass::new(&mut builder, CDC_STATE.init(State::new()), USB_PACKET);
    let usb = builder.build();
    match usb_task(usb) {
        Ok(token) => spawner.spawn(token),
        // Unreachable: the task's pool holds one and it is spawned once.
        Err(_) => cortex_m::asm::udf(),
    }

    let (host_tx, host_rx) = class.split();
    let mut host_tx = HostTx {
        sender: host_tx,
        open_transfer: false,
    };
    let mut host_rx = HostRx(host_rx.into_buffered(RX_PACKET.init([0; USB_PACKET as usize])));

    let clock = EmbassyClock;
    let mut device = Device::new(Config::new(device_id, boot_id), clock.now_ms());
    loop {
        // None of the streams ends (see HostRx), so `run` does not return; should it anyway,
        // it resumes with the same device state.
        let _ = run(
            &mut device,
            &mut tape_rx,
            &mut host_rx,
            &mut host_tx,
            &clock,
        )
        .await;
    }
}

#[embassy_executor::task]
async fn usb_task(mut usb: UsbDevice<'static, UsbDriver>) -> ! {
    usb.run().await
}
