//! `gloam grabbers`: serial ports, USB devices, GenICam cameras and simulated cameras.

use clap::Args;

#[derive(Args)]
pub struct GrabbersArgs {
    /// Print JSON instead of a table.
    #[arg(long)]
    pub json: bool,
}

pub fn run(args: GrabbersArgs) -> anyhow::Result<()> {
    let list = gloam_simcam::list_grabbers();
    if args.json {
        return super::output::print_json(&list);
    }
    outln!("serial ports:");
    match &list.serial_error {
        Some(e) => outln!("  (cannot list serial ports: {e})"),
        None if list.serial.is_empty() => outln!("  (none)"),
        None => {
            for p in &list.serial {
                let mut extra = vec![p.kind.clone()];
                extra.extend(p.vid_pid.clone());
                extra.extend(p.product.clone());
                extra.extend(p.serial_number.as_ref().map(|s| format!("serial {s}")));
                outln!("  {:<32} {}", p.uri, extra.join(", "));
            }
        }
    }
    outln!("USB devices:");
    match &list.usb_error {
        Some(e) => outln!("  {e}"),
        None if list.usb.is_empty() => outln!("  (none)"),
        None => {
            for d in &list.usb {
                let name = [d.manufacturer.as_deref(), d.product.as_deref()]
                    .into_iter()
                    .flatten()
                    .collect::<Vec<_>>()
                    .join(" ");
                outln!("  {:<32} bus {} addr {} {name}", d.uri, d.bus, d.address);
            }
        }
    }
    outln!("GenICam cameras:");
    match &list.genicam_error {
        Some(e) => outln!("  ({e})"),
        None if list.genicam.is_empty() => outln!("  (none)"),
        None => {
            for d in &list.genicam {
                outln!(
                    "  {:<32} {} {} ({}, {})",
                    d.uri,
                    d.vendor,
                    d.model,
                    d.protocol,
                    d.address
                );
            }
        }
    }
    outln!("simulated cameras:");
    for s in &list.sim {
        outln!("  {:<32} {}", s.uri, s.description);
    }
    outln!("(emulated devices: run `gloam device --pty` and use the serial: URI it prints)");
    outln!(
        "(GigE Vision: `gloam device --gige ADDR` serves the simulated camera; any GenICam camera opens as genicam:DEVICE_ID or genicam:ADDR, with gloam built --features genicam, Debian packages libaravis-dev and libusb-1.0-0-dev)"
    );
    Ok(())
}
