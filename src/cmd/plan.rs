//! `gloam plan SCENE [--json]`: which effects a render of the scene simulates
//! and why (see `gloam_scene::plan`).

use std::path::PathBuf;

use clap::Args;

use super::output::print_json;

#[derive(Args)]
pub struct PlanArgs {
    /// The scene file (TOML).
    pub scene: PathBuf,
    /// Print `{"effects":[{"name","enabled","reason"}]}`.
    #[arg(long)]
    pub json: bool,
}

pub fn run(args: PlanArgs) -> anyhow::Result<()> {
    // The scene error already reads `file:line: field: message`.
    let scene = gloam_scene::load(&args.scene)?;
    let plan = gloam_scene::plan::plan(&scene);
    if args.json {
        print_json(&plan)?;
    } else {
        let n = |k: usize, what: &str| format!("{k} {what}{}", if k == 1 { "" } else { "s" });
        println!(
            "{}: {}, {}, {}, units {}",
            args.scene.display(),
            n(scene.facets.len(), "facet"),
            n(scene.point_sources.len(), "point source"),
            n(scene.bands.len(), "band"),
            scene.units.as_str()
        );
        println!();
        print!("{plan}");
    }
    Ok(())
}
