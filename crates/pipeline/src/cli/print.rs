//! What `gloam plan` and `gloam grabbers` print as text (their `--json`
//! is the serialised value): the lines are made here, beside the values
//! they read, and the binary only writes them out.

use gloam_scene::Scene;

/// `gloam plan`'s first line: the scene's size, sources, bands and units.
pub fn scene_line(path: &std::path::Path, scene: &Scene) -> String {
    let n = |k: usize, what: &str| format!("{k} {what}{}", if k == 1 { "" } else { "s" });
    let shared = scene.counts().shared_facets;
    format!(
        "{}: {}{}, {}{}, {}, units {}",
        path.display(),
        n(scene.facets.len(), "facet"),
        if shared > 0 {
            format!(" (+ {shared} placed by shared instances)")
        } else {
            String::new()
        },
        n(scene.point_sources.len(), "point source"),
        match scene.distant_sources.len() {
            0 => String::new(),
            k => format!(", {}", n(k, "distant source")),
        },
        n(scene.bands.len(), "band"),
        scene.units.as_str()
    )
}

/// One line: the camera target's estimate against the 2 % default.
pub fn estimate_line(e: &crate::camera_goal::CameraEstimate, sensor: &str) -> String {
    let (c, r) = (&e.camera, &e.default_2_percent);
    format!(
        "--target-error camera:{} through '{sensor}' (estimated from {}×{} trial renders): {:.1} spp vs {:.1} at the 2 % default, {:.1} vs {:.1} M rays (×{:.1}), {:.2} vs {:.2} s of tracing (×{:.1}) at full size",
        e.k,
        e.trial_width,
        e.trial_height,
        c.mean_spp,
        r.mean_spp,
        c.rays / 1e6,
        r.rays / 1e6,
        e.rays_saving,
        c.trace_seconds,
        r.trace_seconds,
        e.time_saving,
    )
}

/// One line: each preparation step's time (and peak memory), as `gloam
/// plan` ran them.
pub fn preparation_line(p: &gloam_trace::Preparation) -> String {
    let mib = |b: Option<u64>| {
        b.map_or(String::new(), |b| {
            format!(", {:.0} MiB", b as f64 / 1048576.0)
        })
    };
    let steps: Vec<String> = p
        .steps
        .iter()
        .map(|s| format!("{} {:.2} s{}", s.name, s.seconds, mib(s.peak_rss_bytes)))
        .collect();
    format!(
        "preparation {:.2} s ({}); {} object placements, {} triangles, {} emitting facets, peak {}",
        p.seconds,
        steps.join("; "),
        p.instances,
        p.triangles,
        p.area_emitters,
        p.peak_rss_bytes.map_or("unknown".into(), |b| format!(
            "{:.0} MiB",
            b as f64 / 1048576.0
        ))
    )
}

/// `gloam grabbers`' table: serial ports, USB devices, GenICam cameras,
/// simulated cameras, and how to reach the emulated and GigE devices.
pub fn grabber_lines(list: &gloam_grabber::GrabberList) -> Vec<String> {
    let mut out = vec!["serial ports:".to_string()];
    match &list.serial_error {
        Some(e) => out.push(format!("  (cannot list serial ports: {e})")),
        None if list.serial.is_empty() => out.push("  (none)".into()),
        None => {
            for p in &list.serial {
                let mut extra = vec![p.kind.clone()];
                extra.extend(p.vid_pid.clone());
                extra.extend(p.product.clone());
                extra.extend(p.serial_number.as_ref().map(|s| format!("serial {s}")));
                out.push(format!("  {:<32} {}", p.uri, extra.join(", ")));
            }
        }
    }
    out.push("USB devices:".into());
    match &list.usb_error {
        Some(e) => out.push(format!("  {e}")),
        None if list.usb.is_empty() => out.push("  (none)".into()),
        None => {
            for d in &list.usb {
                let name = [d.manufacturer.as_deref(), d.product.as_deref()]
                    .into_iter()
                    .flatten()
                    .collect::<Vec<_>>()
                    .join(" ");
                out.push(format!(
                    "  {:<32} bus {} addr {} {name}",
                    d.uri, d.bus, d.address
                ));
            }
        }
    }
    out.push("GenICam cameras:".into());
    match &list.genicam_error {
        Some(e) => out.push(format!("  ({e})")),
        None if list.genicam.is_empty() => out.push("  (none)".into()),
        None => {
            for d in &list.genicam {
                out.push(format!(
                    "  {:<32} {} {} ({}, {})",
                    d.uri, d.vendor, d.model, d.protocol, d.address
                ));
            }
        }
    }
    out.push("simulated cameras:".into());
    for s in &list.sim {
        out.push(format!("  {:<32} {}", s.uri, s.description));
    }
    out.push(
        "(emulated devices: run `gloam device --pty` and use the serial: URI it prints)".into(),
    );
    out.push(
        "(GigE Vision: `gloam device --gige ADDR` serves the simulated camera; any GenICam camera opens as genicam:DEVICE_ID or genicam:ADDR, with gloam built --features genicam, Debian packages libaravis-dev and libusb-1.0-0-dev)".into(),
    );
    out
}

/// `gloam probe --point`'s lines: the irradiance, its direct and
/// interreflected parts, the reflected radiance, the terms.
pub fn probe_lines(r: &gloam_trace::ProbeResult) -> Vec<String> {
    let mut out = vec![format!(
        "band {}: irradiance {:.6e} ± {:.2e} W m^-2",
        r.band, r.irradiance_w_m2, r.std_error_w_m2
    )];
    if let Some(i) = r.indirect_irradiance_w_m2 {
        out.push(format!(
            "  direct {:.6e} + interreflection {i:.6e} W m^-2",
            r.direct_irradiance_w_m2
        ));
    }
    if let Some(l) = r.radiance_w_m2_sr {
        out.push(format!("reflected radiance {l:.6e} W m^-2 sr^-1"));
    }
    out.push(format!("terms: {}", r.terms));
    out
}
