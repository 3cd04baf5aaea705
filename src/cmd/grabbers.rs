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
        return super::print_json(&list);
    }
    for line in gloam_pipeline::cli::print::grabber_lines(&list) {
        outln!("{line}");
    }
    Ok(())
}
