//! gloam-grabber
