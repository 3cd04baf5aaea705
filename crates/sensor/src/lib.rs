//! gloam-sensor
