#![no_std]
//! firmware-protocol
