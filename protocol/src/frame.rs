//! Framing: `COBS(postcard(msg) ++ CRC-16/IBM-SDLC little-endian) ++ 0x00`.
//!
//! Encoding and decoding use fixed buffers of [`MAX_FRAME`] bytes and never allocate, so the
//! same code runs in the firmware and on the host. The streaming [`FrameDecoder`] is written
//! here rather than taken from postcard's `CobsAccumulator` because the CRC sits inside the
//! COBS body and every failure (bad COBS, bad CRC, oversized, undecodable) must be reported
//! as its own typed error while the decoder resynchronises at the next delimiter; COBS itself
//! and the CRC come from the `cobs` and `crc` crates.

use core::marker::PhantomData;

use serde::{de::DeserializeOwned, Serialize};

/// Largest frame on the wire, trailing `0x00` delimiter included, in bytes.
pub const MAX_FRAME: usize = 128;

/// Largest `postcard(msg) ++ crc` payload before COBS, in bytes: COBS adds one byte per 254
/// (here exactly one), the delimiter one more.
pub const MAX_PAYLOAD: usize = MAX_FRAME - 2;

/// Largest postcard body of a message, in bytes.
const MAX_BODY: usize = MAX_PAYLOAD - 2;

/// The CRC used by the frame: CRC-16/IBM-SDLC (a.k.a. CRC-16/X-25, the HDLC frame check
/// sequence): poly 0x1021 reflected, init 0xFFFF, xorout 0xFFFF, check 0x906E.
pub const CRC16: crc::Crc<u16> = crc::Crc::<u16>::new(&crc::CRC_16_IBM_SDLC);

/// Why a frame could not be produced or accepted.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum FrameError {
    /// The message does not fit in a frame of [`MAX_FRAME`] bytes (or in the buffer given).
    #[error("message too large for a {MAX_FRAME}-byte frame or for the output buffer")]
    TooLarge,
    /// More than [`MAX_FRAME`] bytes arrived without a delimiter; they were discarded up to
    /// the next `0x00`.
    #[error("frame longer than {MAX_FRAME} bytes; skipped up to the next delimiter")]
    Oversized,
    /// The bytes between two delimiters are not valid COBS.
    #[error("invalid COBS encoding; frame dropped")]
    Cobs,
    /// The frame is too short to hold a CRC and a message.
    #[error("frame too short ({len} bytes after COBS decoding); frame dropped")]
    TooShort {
        /// Decoded length in bytes.
        len: u8,
    },
    /// The CRC does not match: the frame was corrupted on the way.
    #[error("CRC mismatch (frame says {received:#06x}, computed {computed:#06x}); frame dropped")]
    Crc {
        /// CRC carried by the frame.
        received: u16,
        /// CRC computed over the received body.
        computed: u16,
    },
    /// The CRC is right but the body is not a message of the expected type (e.g. a message
    /// from a newer minor version, or a host/device direction mix-up).
    #[error("valid frame that does not decode as a message of this protocol version; dropped")]
    Decode,
}

/// Encodes `msg` into `out` as one complete frame, trailing `0x00` included, and returns the
/// frame (a prefix of `out`), ready to write to the link.
///
/// `out` should be [`MAX_FRAME`] bytes; a smaller one works when the frame fits.
///
/// # Errors
/// [`FrameError::TooLarge`] if the message or its frame does not fit.
pub fn encode<'a, T: Serialize>(msg: &T, out: &'a mut [u8]) -> Result<&'a [u8], FrameError> {
    let mut payload = [0u8; MAX_PAYLOAD];
    let body_len = postcard::to_slice(msg, &mut payload[..MAX_BODY])
        .map_err(|_| FrameError::TooLarge)?
        .len();
    let n = encode_payload(&mut payload, body_len, out)?;
    Ok(&out[..n])
}

/// Lower-level encoder: `payload[..body_len]` holds a postcard body; appends the CRC in
/// `payload[body_len..body_len + 2]` and COBS-encodes into `out` with the delimiter. Returns
/// the frame length. Exposed for tests that forge frames (e.g. a correct CRC around a body
/// that is not a message).
///
/// # Errors
/// [`FrameError::TooLarge`] if `payload` has no room for the CRC or `out` for the frame.
pub fn encode_payload(
    payload: &mut [u8],
    body_len: usize,
    out: &mut [u8],
) -> Result<usize, FrameError> {
    if body_len + 2 > payload.len() || body_len + 2 > MAX_PAYLOAD {
        return Err(FrameError::TooLarge);
    }
    let crc = CRC16.checksum(&payload[..body_len]);
    payload[body_len..body_len + 2].copy_from_slice(&crc.to_le_bytes());
    let with_crc = &payload[..body_len + 2];
    if out.len() < cobs::max_encoding_length(with_crc.len()) + 1 {
        return Err(FrameError::TooLarge);
    }
    let n = cobs::try_encode(with_crc, out).map_err(|_| FrameError::TooLarge)?;
    out[n] = 0;
    Ok(n + 1)
}

/// Streaming frame decoder for messages of type `T` ([`crate::DeviceMsg`] on the host,
/// [`crate::HostMsg`] in the firmware).
///
/// Feed it bytes as they arrive, one at a time ([`FrameDecoder::push`]) or a slice at a time
/// ([`FrameDecoder::feed`]). At each `0x00` it yields `Some(Ok(msg))` for a good frame or
/// `Some(Err(e))` for a bad one; either way it starts afresh after the delimiter, so one
/// corrupted frame never costs the next one. A run of more than [`MAX_FRAME`] bytes without a
/// delimiter yields one [`FrameError::Oversized`] as soon as it overflows, then the bytes are
/// skipped up to the next `0x00`. An empty frame (two delimiters in a row) yields nothing:
/// senders may send a lone `0x00` to force the receiver back in step.
///
/// Memory: [`MAX_FRAME`] bytes plus a few counters; no allocation.
#[derive(Debug, Clone)]
pub struct FrameDecoder<T> {
    buf: [u8; MAX_FRAME],
    len: usize,
    /// Skipping an oversized frame up to the next delimiter.
    skipping: bool,
    _msg: PhantomData<fn() -> T>,
}

impl<T: DeserializeOwned> Default for FrameDecoder<T> {
    fn default() -> Self {
        Self::new()
    }
}

impl<T: DeserializeOwned> FrameDecoder<T> {
    /// A decoder waiting for the first frame.
    pub const fn new() -> Self {
        Self {
            buf: [0; MAX_FRAME],
            len: 0,
            skipping: false,
            _msg: PhantomData,
        }
    }

    /// Forgets any partial frame (e.g. after the link was reopened).
    pub fn reset(&mut self) {
        self.len = 0;
        self.skipping = false;
    }

    /// Bytes of the current, not yet delimited frame.
    pub fn pending_len(&self) -> usize {
        self.len
    }

    /// Pushes one byte; returns the outcome of a frame completed by this byte, if any.
    pub fn push(&mut self, byte: u8) -> Option<Result<T, FrameError>> {
        if byte == 0 {
            if self.skipping {
                self.skipping = false;
                self.len = 0;
                return None;
            }
            if self.len == 0 {
                return None;
            }
            let len = self.len;
            self.len = 0;
            return Some(decode_body(&mut self.buf[..len]));
        }
        if self.skipping {
            return None;
        }
        // The COBS body of a frame is at most MAX_FRAME - 1 bytes.
        if self.len >= MAX_FRAME - 1 {
            self.skipping = true;
            self.len = 0;
            return Some(Err(FrameError::Oversized));
        }
        self.buf[self.len] = byte;
        self.len += 1;
        None
    }

    /// Feeds a slice; the iterator yields one outcome per frame completed within it. Bytes
    /// the iterator has not reached when it is dropped are still consumed (pushed without
    /// reporting), so dropping it early never desynchronises the decoder — but it does lose
    /// the outcomes of frames it did not yield, so normally drain it.
    pub fn feed<'a>(&'a mut self, data: &'a [u8]) -> FeedIter<'a, T> {
        FeedIter {
            decoder: self,
            data,
        }
    }
}

/// Iterator returned by [`FrameDecoder::feed`].
#[derive(Debug)]
pub struct FeedIter<'a, T: DeserializeOwned> {
    decoder: &'a mut FrameDecoder<T>,
    data: &'a [u8],
}

impl<T: DeserializeOwned> Iterator for FeedIter<'_, T> {
    type Item = Result<T, FrameError>;

    fn next(&mut self) -> Option<Self::Item> {
        while let Some((&b, rest)) = self.data.split_first() {
            self.data = rest;
            if let Some(out) = self.decoder.push(b) {
                return Some(out);
            }
        }
        None
    }
}

impl<T: DeserializeOwned> Drop for FeedIter<'_, T> {
    fn drop(&mut self) {
        for &b in self.data {
            let _ = self.decoder.push(b);
        }
    }
}

/// Decodes one COBS body (without delimiter) in place and checks CRC and message.
fn decode_body<T: DeserializeOwned>(body: &mut [u8]) -> Result<T, FrameError> {
    let n = cobs::decode_in_place(body).map_err(|_| FrameError::Cobs)?;
    // A frame holds at least a one-byte postcard body (the enum tag) and the CRC.
    if n < 3 {
        return Err(FrameError::TooShort { len: n as u8 });
    }
    let (data, crc) = body[..n].split_at(n - 2);
    let received = u16::from_le_bytes([crc[0], crc[1]]);
    let computed = CRC16.checksum(data);
    if received != computed {
        return Err(FrameError::Crc { received, computed });
    }
    match postcard::take_from_bytes::<T>(data) {
        Ok((msg, [])) => Ok(msg),
        _ => Err(FrameError::Decode),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::*;
    use std::vec::Vec;

    #[test]
    fn crc_is_ibm_sdlc() {
        assert_eq!(CRC16.checksum(b"123456789"), 0x906E);
    }

    #[test]
    fn frame_layout_is_cobs_of_body_and_le_crc() {
        let msg = HostMsg::Ping { nonce: 5 };
        let mut buf = [0u8; MAX_FRAME];
        let frame = encode(&msg, &mut buf).unwrap().to_vec();
        // postcard: variant 2 (Ping), varint 5.
        let body = [2u8, 5];
        let crc = CRC16.checksum(&body).to_le_bytes();
        let mut raw = Vec::from(body);
        raw.extend_from_slice(&crc);
        let mut expect = std::vec![0u8; 16];
        let n = cobs::encode(&raw, &mut expect);
        expect.truncate(n);
        expect.push(0);
        assert_eq!(frame, expect);
        assert!(!frame[..frame.len() - 1].contains(&0));
    }

    #[test]
    fn largest_message_fits() {
        let status = Status {
            boot_id: u32::MAX,
            uptime_ms: u64::MAX,
            queue_len: u16::MAX,
            queue_capacity: u16::MAX,
            next_seq: u32::MAX,
            host_seen: true,
            tape_silent: true,
            lines_ok: u32::MAX,
            heartbeats: u32::MAX,
            rejected: RejectCounts {
                garbage: u32::MAX,
                partial: u32::MAX,
                overlong: u32::MAX,
                bad_field: u32::MAX,
                impossible: u32::MAX,
            },
            readings_refused: u32::MAX,
            confirm_repeats: u32::MAX,
            host_frames_bad: u32::MAX,
            acks_ignored: u32::MAX,
            tape_io_errors: u32::MAX,
            host_io_errors: u32::MAX,
            reports_dropped: u32::MAX,
        };
        let mut buf = [0u8; MAX_FRAME];
        let frame = encode(&DeviceMsg::Status(status), &mut buf).unwrap();
        assert!(frame.len() <= MAX_FRAME);
        let mut dec = FrameDecoder::<DeviceMsg>::new();
        let got: Vec<_> = dec.feed(frame).collect();
        assert_eq!(got, std::vec![Ok(DeviceMsg::Status(status))]);
    }

    #[test]
    fn small_output_buffer_is_an_error_not_a_panic() {
        let mut buf = [0u8; 3];
        assert_eq!(
            encode(&HostMsg::Ping { nonce: u32::MAX }, &mut buf),
            Err(FrameError::TooLarge)
        );
    }

    #[test]
    fn each_failure_is_typed() {
        let mut dec = FrameDecoder::<HostMsg>::new();
        let mut buf = [0u8; MAX_FRAME];
        let good = encode(&HostMsg::Ping { nonce: 77 }, &mut buf)
            .unwrap()
            .to_vec();

        // Flip a bit inside the body: COBS stays valid only if we avoid the code bytes;
        // byte 2 is payload here.
        let mut bad = good.clone();
        bad[2] ^= 0x10;
        let out: Vec<_> = dec.feed(&bad).collect();
        assert!(matches!(out[..], [Err(FrameError::Crc { .. })]), "{out:?}");

        // Too short.
        let out: Vec<_> = dec.feed(&[0x02, 0x07, 0x00]).collect();
        assert_eq!(out, std::vec![Err(FrameError::TooShort { len: 1 })]);

        // Invalid COBS: code byte claims more bytes than there are.
        let out: Vec<_> = dec.feed(&[0x09, 0x01, 0x02, 0x00]).collect();
        assert_eq!(out, std::vec![Err(FrameError::Cobs)]);

        // Valid CRC, body of the wrong direction's type (variant 9 does not exist).
        let mut payload = [0u8; MAX_PAYLOAD];
        payload[0] = 9;
        let mut out_buf = [0u8; MAX_FRAME];
        let n = encode_payload(&mut payload, 1, &mut out_buf).unwrap();
        let out: Vec<_> = dec.feed(&out_buf[..n]).collect();
        assert_eq!(out, std::vec![Err(FrameError::Decode)]);

        // Trailing bytes after a complete message are a decode error, not ignored.
        let mut payload = [0u8; MAX_PAYLOAD];
        payload[..3].copy_from_slice(&[2, 5, 1]);
        let n = encode_payload(&mut payload, 3, &mut out_buf).unwrap();
        let out: Vec<_> = dec.feed(&out_buf[..n]).collect();
        assert_eq!(out, std::vec![Err(FrameError::Decode)]);

        // Oversized, then the good frame right after the delimiter decodes.
        let mut stream = std::vec![0x41u8; MAX_FRAME + 50];
        stream.push(0);
        stream.extend_from_slice(&good);
        let out: Vec<_> = dec.feed(&stream).collect();
        assert_eq!(
            out,
            std::vec![Err(FrameError::Oversized), Ok(HostMsg::Ping { nonce: 77 })]
        );

        // Empty frames are not reported.
        let out: Vec<_> = dec.feed(&[0, 0, 0]).collect();
        assert!(out.is_empty());
    }

    #[test]
    fn frame_of_exactly_max_len_is_accepted_one_more_is_not() {
        // Build a raw COBS body of MAX_FRAME - 1 bytes: it is accepted as a frame (it fails
        // later checks, but not as Oversized).
        let mut dec = FrameDecoder::<HostMsg>::new();
        let mut stream = std::vec![0x01u8; MAX_FRAME - 1];
        stream.push(0);
        let out: Vec<_> = dec.feed(&stream).collect();
        assert_eq!(out.len(), 1);
        assert_ne!(out[0], Err(FrameError::Oversized));
        let mut stream = std::vec![0x01u8; MAX_FRAME];
        stream.push(0);
        let out: Vec<_> = dec.feed(&stream).collect();
        assert_eq!(out, std::vec![Err(FrameError::Oversized)]);
    }
}
