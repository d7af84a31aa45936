//! Tape-station firmware logic (no_std): tape line parsing, reading queue, host protocol; tested on the host.
#![no_std]
