//! The command line's arguments for `gloam spectra` (feature `cli`).

use clap::{Args, Subcommand};

use crate::parse_band;

#[derive(Subcommand)]
pub enum SpectraCommand {
    /// List the built-in spectra with their provenance.
    List {
        /// Print JSON instead of a table.
        #[arg(long)]
        json: bool,
    },
    /// Integrate a spectrum over a band, optionally weighted by a response.
    Integrate(IntegrateArgs),
}

#[derive(Args)]
pub struct IntegrateArgs {
    /// A built-in name (see `gloam spectra list`) or a CSV file
    /// (`wavelength_nm,value` rows, `line,wavelength_nm,value` for lines).
    pub spectrum: String,
    /// The band, `LO:HI` in nm (half-open: lines at HI are excluded).
    /// (A value, even when it starts with `-`: `-100:500` was read as the
    /// flags `-1`….)
    #[arg(long, value_parser = parse_band, allow_hyphen_values = true)]
    pub band: (f64, f64),
    /// Weight by this response (built-in name or CSV), e.g. `v-photopic`;
    /// the product of the two is integrated exactly.
    #[arg(long)]
    pub weight: Option<String>,
    /// Print `{"integral": …, "units": …}`.
    #[arg(long)]
    pub json: bool,
}
