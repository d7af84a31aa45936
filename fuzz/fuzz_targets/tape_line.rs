//! The tape's line parser and assembler (firmware), and the device state
//! machine behind them, on any byte stream: no panic; the assembler never
//! holds more than one line; a line accepted as a value is exactly what the
//! formatter writes for that value; after a terminator the next valid line
//! parses.
#![no_main]

use libfuzzer_sys::fuzz_target;
use tapeshape_firmware::protocol::UnitShown;
use tapeshape_firmware::tape::{
    format_fields, format_line, parse_line, Kind, Line, LineAssembler, LINE_LEN,
};
use tapeshape_firmware::{Config, Device};

fuzz_target!(|data: &[u8]| {
    // One line as given.
    if let Ok(Line::Value(l)) = parse_line(data) {
        let back = format_fields(
            l.value_hundredths_cm,
            l.field2,
            l.field3,
            l.kind,
            l.unit_shown,
        )
        .expect("a parsed value formats");
        assert_eq!(&back[..LINE_LEN], data);
    }
    // A stream.
    let mut assembler = LineAssembler::new();
    for &b in data {
        let _ = assembler.push(b);
        assert!(assembler.pending_len() <= LINE_LEN);
    }
    let good = format_line(1234, Kind::Confirmed, UnitShown::Metric).expect("formats");
    let out: Vec<_> = std::iter::once(b'\n')
        .chain(good)
        .filter_map(|b| assembler.push(b))
        .collect();
    assert_eq!(out.last(), Some(&parse_line(&good[..LINE_LEN])));
    // The device: the same bytes as tape input, then polled dry.
    let mut device = Device::new(Config::new(1, 2), 0);
    device.feed_tape(data, 10);
    let mut n = 0;
    while device.poll(20).is_some() {
        n += 1;
        assert!(n < 10_000, "the device never runs dry");
    }
});
