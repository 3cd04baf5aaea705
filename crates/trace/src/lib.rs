//! gloam-trace
