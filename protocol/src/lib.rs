//! Wire format shared by the tape firmware and the host: messages, COBS + CRC-16 framing, versions.
//!
//! Why a crate of its own: the firmware (no_std, no allocator, 64 KiB of flash) and the host
//! station (std, tokio) must agree byte for byte on what travels over the serial link. Both
//! depend on this one crate, so a message added on one side cannot be forgotten on the other.
//!
//! # Frame layout
//!
//! ```text
//! frame   = COBS( postcard(message) ++ crc16_le ) ++ 0x00
//! crc16   = CRC-16/IBM-SDLC (also called CRC-16/X-25: poly 0x1021, reflected,
//!           init 0xFFFF, xorout 0xFFFF, check("123456789") = 0x906E)
//!           over the postcard bytes only, appended least significant byte first
//! ```
//!
//! COBS removes every zero byte from the body, so `0x00` only ever appears as the frame
//! delimiter: a receiver that loses bytes, or starts listening mid-frame, throws away what it
//! has at the next `0x00` and is back in step for the frame after it. The CRC catches what
//! COBS cannot (flipped bits that keep the framing valid). A frame, delimiter included, is
//! at most [`MAX_FRAME`] bytes; a longer run of non-zero bytes is reported as
//! [`FrameError::Oversized`] and skipped up to the next delimiter.
//!
//! The full rules (handshake, versioning, sequence numbers, acknowledgements, what each side
//! does on a bad frame, a duplicate or a gap) are in `docs/wire-format.md`.
//!
//! # Example
//!
//! ```
//! use tapeshape_protocol::{encode, DeviceMsg, FrameDecoder, Live, UnitShown, MAX_FRAME};
//!
//! let msg = DeviceMsg::Live(Live { value_tenth_mm: 8520, unit_shown: UnitShown::Metric });
//! let mut buf = [0u8; MAX_FRAME];
//! let frame = encode(&msg, &mut buf).unwrap();
//! assert_eq!(frame.last(), Some(&0x00));
//!
//! let mut decoder = FrameDecoder::<DeviceMsg>::new();
//! let got: Vec<_> = decoder.feed(frame).collect();
//! assert_eq!(got, vec![Ok(msg)]);
//! ```
#![no_std]

#[cfg(test)]
extern crate std;

mod frame;
mod msg;
pub mod usb;

pub use frame::{
    encode, encode_payload, FeedIter, FrameDecoder, FrameError, CRC16, MAX_FRAME, MAX_PAYLOAD,
};
pub use msg::*;
