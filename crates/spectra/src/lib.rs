//! gloam-spectra
