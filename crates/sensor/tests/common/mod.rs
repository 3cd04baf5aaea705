#![allow(dead_code)]

use gloam_sensor::{Camera, Frame, SensorConfig};
use ndarray::Array2;

/// A preset with fixed patterns and persistence off, so that a uniform
/// field's frame statistics are the temporal noise alone.
pub fn clean(name: &str) -> SensorConfig {
    let mut c = SensorConfig::preset(name).unwrap().unwrap();
    c.ccd.prnu = 0.0;
    c.ccd.dsnu_e = 0.0;
    if let Some(cp) = &mut c.coupling {
        cp.chicken_wire_depth = 0.0;
    }
    if let Some(p) = &mut c.phosphor {
        p.lag_fraction = Some(0.0);
    }
    if let Some(a) = &mut c.agc {
        a.enabled = false;
    }
    c
}

pub fn camera(cfg: SensorConfig, gain: Option<f64>) -> Camera {
    let mut cam = Camera::new(cfg).unwrap();
    if let Some(g) = gain {
        cam.set_override_gain(Some(g)).unwrap();
    }
    cam
}

pub fn uniform(rows: usize, cols: usize, pe: f64) -> Array2<f64> {
    Array2::from_elem((rows, cols), pe)
}

/// Pixels of `f` inside a margin, as f64.
pub fn interior(f: &Frame, margin: usize) -> Vec<f64> {
    let (r, c) = f.view().unwrap().dim();
    let mut v = Vec::new();
    for y in margin..r - margin {
        for x in margin..c - margin {
            v.push(f.view().unwrap()[[y, x]] as f64);
        }
    }
    v
}

pub fn mean(v: &[f64]) -> f64 {
    v.iter().sum::<f64>() / v.len() as f64
}

pub fn variance(v: &[f64]) -> f64 {
    let m = mean(v);
    v.iter().map(|x| (x - m).powi(2)).sum::<f64>() / (v.len() - 1) as f64
}
