//! The serial frame decoder (COBS + CRC-16 + postcard), in both directions,
//! on any byte stream: no panic; the decoder never holds more than a frame;
//! every message it accepts encodes to a frame that decodes to the same
//! message; and after a delimiter it is back in step (a valid frame sent next
//! decodes), whatever came before.
#![no_main]

use std::fmt::Debug;

use libfuzzer_sys::fuzz_target;
use serde::{de::DeserializeOwned, Serialize};
use tapeshape_protocol::{encode, DeviceMsg, FrameDecoder, HostMsg, MAX_FRAME};

fn check<T>(data: &[u8], probe: T)
where
    T: Serialize + DeserializeOwned + PartialEq + Debug,
{
    let mut decoder = FrameDecoder::<T>::new();
    // Bytes in two pieces (the first byte says where to cut): `feed` and
    // `push` must agree with one another across any split.
    let cut = data.first().map_or(0, |&b| usize::from(b)).min(data.len());
    let mut accepted = Vec::new();
    for piece in [&data[..cut], &data[cut..]] {
        for out in decoder.feed(piece) {
            if let Ok(msg) = out {
                accepted.push(msg);
            }
        }
        assert!(decoder.pending_len() < MAX_FRAME);
    }
    let mut byte_by_byte = FrameDecoder::<T>::new();
    let again: Vec<T> = data
        .iter()
        .filter_map(|&b| byte_by_byte.push(b))
        .filter_map(Result::ok)
        .collect();
    assert_eq!(again, accepted, "feed and push disagree");
    for msg in accepted {
        let mut buf = [0u8; MAX_FRAME];
        let frame = encode(&msg, &mut buf).expect("an accepted message fits a frame");
        let mut fresh = FrameDecoder::<T>::new();
        let back: Vec<_> = fresh.feed(frame).collect();
        assert_eq!(back, [Ok(msg)]);
    }
    // Back in step after a delimiter.
    let mut buf = [0u8; MAX_FRAME];
    let mut tail = vec![0u8];
    tail.extend_from_slice(encode(&probe, &mut buf).expect("the probe fits"));
    let last = decoder.feed(&tail).last();
    assert_eq!(last, Some(Ok(probe)));
}

fuzz_target!(|data: &[u8]| {
    check::<DeviceMsg>(data, DeviceMsg::Pong { nonce: 0x5EED });
    check::<HostMsg>(data, HostMsg::Ping { nonce: 0x5EED });
});
