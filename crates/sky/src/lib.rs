//! gloam-sky
