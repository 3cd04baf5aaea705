//! `gloam ephem`: Moon and Sun positions and the lunar phase for one instant
//! and site, or (`--from/--to/--find`) the good collection nights in a date
//! range. The arguments and the query are [`gloam_sky::cli`], the search
//! and the report `gloam_sky::report`; this module only prints.

pub use gloam_sky::cli::EphemArgs;

use super::print_json;

pub fn run(args: EphemArgs) -> anyhow::Result<()> {
    let report = args.report()?;
    if args.json {
        return print_json(&report);
    }
    outln!("{report}");
    Ok(())
}
