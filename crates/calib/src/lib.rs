//! gloam-calib
