//! Wire format shared by the tape firmware and the host: messages, COBS + CRC-16 framing, versions.
#![no_std]
