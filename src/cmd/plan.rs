//! `gloam plan SCENE [--json]` (implemented with the scene crate).

use std::path::PathBuf;

use clap::Args;

#[derive(Args)]
pub struct PlanArgs {
    /// The scene file (TOML).
    pub scene: PathBuf,
    /// Print `{"effects":[{"name","enabled","reason"}]}`.
    #[arg(long)]
    pub json: bool,
}

pub fn run(args: PlanArgs) -> anyhow::Result<()> {
    anyhow::bail!("{}: scene loading is not built yet", args.scene.display())
}
