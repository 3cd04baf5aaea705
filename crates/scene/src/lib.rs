//! gloam-scene
