//! `gloam bench accuracy|throughput|plan|scale`: dispatch and printing.
//! The arguments are [`gloam_bench::cli`], the measuring [`gloam_bench`],
//! whose docs say what each figure means.

use anyhow::Context;
pub use gloam_bench::cli::BenchCommand;
use gloam_bench::{accuracy, plan_check, scale, throughput};

use super::output::print_json;

pub fn run(c: BenchCommand) -> anyhow::Result<()> {
    match c {
        BenchCommand::Accuracy(a) => {
            let json = a.json;
            let report = accuracy::run(&a.options()?)?;
            if json {
                return print_json(&report.summary);
            }
            out!("{}", report.markdown);
        }
        BenchCommand::Throughput(a) => {
            let t = throughput::run(&a.scene(), a.quick, a.threads)?;
            if a.json {
                return print_json(&t);
            }
            out!("{}", t.text());
        }
        BenchCommand::Scale(a) => {
            if let Some((case, dir)) = a.case()? {
                let (w, h) = (a.width.unwrap_or(160), a.height.unwrap_or(120));
                let spp = a.spp.unwrap_or(4);
                return print_json(&scale::run_case(case, dir, w, h, spp, a.threads, &a.set)?);
            }
            let exe =
                std::env::current_exe().context("finding the gloam binary to run each case")?;
            let report = scale::run(&a.options(exe)?)?;
            if a.json {
                return print_json(&report);
            }
            out!("{}", report.text());
        }
        BenchCommand::Plan(a) => {
            let check = plan_check::run(
                &a.scenes()?,
                a.spp,
                a.share_spp,
                a.resolution_scale,
                a.threads,
            )?;
            if a.json {
                print_json(&check.json())?;
            } else {
                out!("{}", check.markdown());
            }
            check.verdict().context("gloam bench plan")?;
        }
    }
    Ok(())
}
