//! The faulty-line scenario with the REAL board firmware: the `mps2-an386` ELF under
//! qemu-system-arm (UART0 = tape, UART1 = host link, both on ptys), 1 % of its device->host
//! bytes corrupted and the station's port unplugged 3 times; every reading must be stored
//! exactly once, in order.
//!
//! Without qemu-system-arm the test fails when `CI` is set and prints a loud SKIPPED line
//! otherwise. The firmware is built with `cargo build --release` in `firmware/boards` (needs
//! the `thumbv7em-none-eabihf` target) if needed.
//!
//! Reading count and pace: 1,000 readings, one every 100 ms (about two minutes). The board runs
//! the firmware's default retransmit interval (300 ms); with 1 % of the bytes corrupted about one
//! reading frame in six is lost, and go-back-N recovery must keep up with the tape, so the pace
//! stays at a few readings per retransmission round. `TAPESHAPE_E2E_QEMU_READINGS` overrides the
//! count.

use std::time::Duration;

use tapeshape_sim::qemu::{self, QemuBoard};
use tapeshape_tests::{faulty_line_run, DeviceUnderTest, FaultyLineRun};

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn readings_through_real_firmware_under_qemu_corrupted_and_unplugged() {
    if !qemu::available_or_skip("readings_through_real_firmware_under_qemu_corrupted_and_unplugged")
    {
        return;
    }
    let readings: usize = match std::env::var("TAPESHAPE_E2E_QEMU_READINGS") {
        Ok(v) => v
            .parse()
            .unwrap_or_else(|_| panic!("TAPESHAPE_E2E_QEMU_READINGS={v:?} is not a count")),
        Err(_) => 1000,
    };
    let board = QemuBoard::launch(0x0E2E_0003).expect("launching the board under QEMU");
    faulty_line_run(
        DeviceUnderTest::Qemu(board),
        FaultyLineRun {
            readings,
            seed: 0x5EED_0003,
            // A few readings per 300 ms retransmission round (see the module docs).
            pace: Duration::from_millis(100),
            unplug_down: Duration::from_millis(300),
            timeout: Duration::from_secs(60) + Duration::from_millis(300) * readings as u32,
        },
    )
    .await;
}
