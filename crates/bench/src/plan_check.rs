//! `gloam bench plan`: the time the effect plan saves, and whether its
//! decisions hold (each sim rendered with the plan, with every effect
//! forced on, with the interreflection decision flipped, and with each kept
//! effect dropped).

use std::path::PathBuf;
use std::time::Instant;

use gloam_scene::plan::names;
use gloam_trace::{RenderSettings, Tracer};
use ndarray::{Array3, Axis};

use super::BenchError;
use super::metrics::rel_rms_diff;
use super::truth::no_emitter_mask;

/// What `gloam bench plan` measured.
pub struct PlanCheck {
    pub spp: u32,
    /// Samples per pixel of the renders that measure the shares.
    pub share_spp: u32,
    /// One JSON object per scene.
    pub scenes: Vec<serde_json::Value>,
    pub total: serde_json::Value,
    pub all_agree: bool,
    pub interreflection_consistent: bool,
    /// Every other effect's decision held (kept: dropping it changes the
    /// signal by more than the tolerance; skipped: forcing it on, by less).
    pub effects_consistent: bool,
    /// Every pilot share lies within [`SHARE_RATIO_LIMIT`]× of the
    /// measured one, or, at or below the tolerance, the measured share
    /// within the pilot's bound (see [`share_check`]).
    pub shares_ok: bool,
}

/// Renders each scene with the plan, with every effect forced on, with
/// another seed (the plan's own noise) and with the interreflection
/// decision flipped.
/// `resolution_scale` multiplies each camera's width and height (as the
/// render setting of that name does, the field of view kept).
pub fn run(
    scenes: &[PathBuf],
    spp: u32,
    share_spp: u32,
    resolution_scale: f64,
    threads: Option<usize>,
) -> Result<PlanCheck, BenchError> {
    let mut out = Vec::new();
    let (mut t_plan, mut t_all) = (0.0, 0.0);
    for path in scenes {
        let mut scene = gloam_scene::load(path, &crate::unlisted())?;
        if resolution_scale != 1.0 {
            // On the scene, not the settings: the masks below are the
            // scene camera's size.
            let cam = &mut scene.camera;
            let scaled = |n: u32| ((n as f64 * resolution_scale).round() as u32).max(1);
            cam.width = scaled(cam.width);
            cam.height = scaled(cam.height);
        }
        let base = RenderSettings {
            spp,
            threads,
            ..Default::default()
        };
        let mut forced = base.clone();
        forced
            .set("all_effects", "true")
            .map_err(BenchError::NoForcingSetting)?;
        let render = |s: &RenderSettings| -> Result<(Array3<f64>, f64), BenchError> {
            let t0 = Instant::now();
            let o = Tracer::new(&scene, s)?.render(&|_, _| {})?;
            Ok((o.radiance, t0.elapsed().as_secs_f64()))
        };
        let (a, ta) = render(&base)?;
        let (b, tb) = render(&forced)?;
        // The plan's own noise: the same render with another seed.
        let (a2, _) = render(&RenderSettings {
            seed: base.seed + 1,
            ..base.clone()
        })?;
        let noise = rel_rms_diff(&a2, &a);
        let diff = rel_rms_diff(&b, &a);
        // Shares are measured at `share_spp`: at one sample per pixel a
        // sub-pixel pool's change of the mean is itself noise
        // (`street-switch-on`'s lamps: 50 % at 1 spp, 36 % at 4, 88 % at
        // 16, 84 % at 64, 82 % at 256).
        let sbase = RenderSettings {
            spp: share_spp,
            ..base.clone()
        };
        let measured;
        let (sa, sb, sa2) = if share_spp == spp {
            (&a, &b, &a2)
        } else {
            measured = (
                render(&sbase)?.0,
                render(&RenderSettings {
                    spp: share_spp,
                    ..forced.clone()
                })?
                .0,
                render(&RenderSettings {
                    seed: base.seed + 1,
                    ..sbase.clone()
                })?
                .0,
            );
            (&measured.0, &measured.1, &measured.2)
        };
        // Interreflection, both directions: flip the plan's decision and
        // measure the change of the mean signal over the pixels that see a
        // surface and no emitter, nor one beside them (the set the pilot's
        // share is defined over, and the one `--target-error` governs),
        // against the tolerance.
        let tracer = Tracer::prepare(&scene, &base, false)?;
        let decision = tracer.interreflection().clone();
        let kept = decision.method != "off";
        let mut flipped = sbase.clone();
        flipped.set("indirect", if kept { "off" } else { "cache" })?;
        let (c, _) = render(&flipped)?;
        let mask = no_emitter_mask(&scene, &tracer, 2);
        let masked_mean = |img: &Array3<f64>| -> Vec<f64> {
            img.axis_iter(Axis(0))
                .map(|band| {
                    let (s, n) = mask
                        .indexed_iter()
                        .filter(|(_, m)| **m)
                        .fold((0.0, 0usize), |(s, n), ((r, cc), _)| {
                            (s + band[[r, cc]], n + 1)
                        });
                    s / n.max(1) as f64
                })
                .collect()
        };
        let (ma, mc, ma2) = (masked_mean(sa), masked_mean(&c), masked_mean(sa2));
        let with_ir = if kept { &ma } else { &mc };
        let change = (0..ma.len())
            .map(|b| {
                let d = with_ir[b].abs().max(1e-300);
                (ma[b] - mc[b]).abs() / d
            })
            .fold(0.0, f64::max);
        let mean_noise = (0..ma.len())
            .map(|b| (ma[b] - ma2[b]).abs() / ma[b].abs().max(1e-300))
            .fold(0.0, f64::max);
        let tol = base.tolerance;
        let ir_ok = if kept {
            change > tol
        } else {
            change <= tol + 3.0 * mean_noise
        };
        // Every other effect of the plan, both directions: a kept effect is
        // dropped (`--set drop=NAME`) and must change the signal by more
        // than the tolerance; the skipped ones, forced on together
        // (`all_effects`), by no more than the tolerance plus noise.
        let plan = gloam_trace::plan::effect_plan(&scene, &base)?;
        let whole_mean = |img: &Array3<f64>| -> Vec<f64> {
            img.axis_iter(Axis(0))
                .map(|b| b.mean().unwrap_or(0.0))
                .collect()
        };
        let rel_change = |x: &[f64], y: &[f64]| -> f64 {
            (0..x.len())
                .map(|b| (x[b] - y[b]).abs() / x[b].abs().max(1e-300))
                .fold(0.0, f64::max)
        };
        // The per-pixel view: the 90th percentile over the mask of
        // `|x − y| / max(x, 5 % of the mean)` (the floor keeps dark pixels
        // from dominating, as `--target-error` does). A source that lights
        // only part of the view (the Moon beyond the street lamps' pools)
        // is worth little in the mean, yet changes one pixel in ten by
        // more than the tolerance.
        let pixel_change = |x: &Array3<f64>, y: &Array3<f64>| -> f64 {
            (0..x.shape()[0])
                .map(|b| {
                    let floor = 0.05 * ma[b].abs();
                    let mut d: Vec<f64> = mask
                        .indexed_iter()
                        .filter(|(_, m)| **m)
                        .map(|((r, cc), _)| {
                            let xv = x[[b, r, cc]];
                            let den = xv.abs().max(floor).max(1e-300);
                            (xv - y[[b, r, cc]]).abs() / den
                        })
                        .collect();
                    if d.is_empty() {
                        return 0.0;
                    }
                    let k = ((d.len() - 1) as f64 * 0.9).round() as usize;
                    *d.select_nth_unstable_by(k, f64::total_cmp).1
                })
                .fold(0.0, f64::max)
        };
        let pixel_noise = pixel_change(sa, sa2);
        let (wa, wb) = (whole_mean(sa), whole_mean(sb));
        let forced_change = rel_change(&ma, &masked_mean(sb));
        let mut effects = Vec::new();
        let mut pixel_changes: Vec<(String, f64)> = Vec::new();
        for e in &plan.effects {
            let name = e.name.as_str();
            if name == names::INTERREFLECTION {
                continue;
            }
            let droppable = gloam_trace::Dropped::NAMES.contains(&name);
            // Emitters seen directly sit on the pixels the mask leaves out.
            let whole = name == names::DIRECT_VIEW;
            let (how, measured, ok) = if !droppable {
                (
                    "not separable (no setting leaves it out)".to_string(),
                    None,
                    None,
                )
            } else if e.enabled {
                let mut d = sbase.clone();
                d.set("drop", name)?;
                let (img, _) = render(&d)?;
                let m = if whole {
                    rel_change(&wa, &whole_mean(&img))
                } else {
                    rel_change(&ma, &masked_mean(&img))
                };
                // Kept: the mean moves by more than the tolerance, or one
                // pixel in ten does. A dropped term is computed and
                // discarded (`gloam_trace::Dropped`), so both renders share
                // every other random number: the change is the effect's,
                // not noise (the seed-to-seed figure is listed beside it).
                let px = pixel_change(sa, &img);
                let ok = m > tol || (!whole && px > tol);
                pixel_changes.push((name.to_string(), px));
                ("dropped".to_string(), Some(m), Some(ok))
            } else {
                let m = if whole {
                    rel_change(&wa, &wb)
                } else {
                    forced_change
                };
                (
                    "forced on (every skipped effect together)".to_string(),
                    Some(m),
                    Some(m <= tol + 3.0 * mean_noise),
                )
            };
            let px = pixel_changes
                .iter()
                .find(|(n, _)| n == name)
                .map(|(_, v)| *v);
            effects.push(serde_json::json!({
                "effect": name,
                "enabled": e.enabled,
                "estimated_share": e.estimated_share,
                "check": how,
                "measured_change": measured,
                "per_pixel_change": px,
                "per_pixel_noise": pixel_noise,
                "consistent": ok,
                "share_check": share_check(e.estimated_share, measured, tol, mean_noise),
            }));
        }
        let effects_ok = effects.iter().all(|v| v["consistent"] != false);
        // Two independent renders differ by √2 σ; forced vs plan shares
        // the seed, so agreement within noise is diff ≤ 1.5 × that + 1e-9.
        let agree = diff <= 1.5 * noise + 1e-9;
        t_plan += ta;
        t_all += tb;
        out.push(serde_json::json!({
            "scene": path.display().to_string(),
            "plan_s": ta,
            "all_effects_s": tb,
            "saved_s": tb - ta,
            "saved_fraction": 1.0 - ta / tb.max(1e-12),
            "rel_rms_difference": diff,
            "rel_rms_noise_between_seeds": noise,
            "agree_within_noise": agree,
            "interreflection": {
                "decision": decision.method,
                "estimated_share": decision.estimated_share,
                "measured_share": change,
                "share_check": share_check(decision.estimated_share, Some(change), tol, mean_noise),
                "tolerance": tol,
                "mean_noise_between_seeds": mean_noise,
                "consistent": ir_ok,
            },
            "effects": effects,
            "effects_consistent": effects_ok,
        }));
    }
    let all_agree = out.iter().all(|v| v["agree_within_noise"] == true);
    let ir_consistent = out
        .iter()
        .all(|v| v["interreflection"]["consistent"] == true);
    let effects_consistent = out.iter().all(|v| v["effects_consistent"] == true);
    let shares_ok = out.iter().all(|v| {
        v["interreflection"]["share_check"]["pass"] != false
            && v["effects"]
                .as_array()
                .into_iter()
                .flatten()
                .all(|e| e["share_check"]["pass"] != false)
    });
    let total = serde_json::json!({
        "effects_consistent": effects_consistent,
        "plan_s": t_plan,
        "all_effects_s": t_all,
        "saved_s": t_all - t_plan,
        "saved_fraction": 1.0 - t_plan / f64::max(t_all, 1e-12),
        "all_agree_within_noise": all_agree,
        "interreflection_decisions_consistent": ir_consistent,
        "shares_within_limit": shares_ok,
    });
    Ok(PlanCheck {
        spp,
        share_spp,
        scenes: out,
        total,
        all_agree,
        interreflection_consistent: ir_consistent,
        effects_consistent,
        shares_ok,
    })
}

/// Ratio allowed between the pilot's share and the measured one.
pub const SHARE_RATIO_LIMIT: f64 = 1.5;

/// The pilot's share against the measured one: `{"ratio", "bound",
/// "pass", "within_noise"}`. A share above the tolerance must lie within
/// [`SHARE_RATIO_LIMIT`]× of the measured share, or of some share within
/// 3 × `noise` of it (`within_noise`: the measurement cannot tell; a
/// dropped term rebuilds the radiosity cache, so the two renders differ
/// by the cache's noise as well as by the term). At or below the tolerance
/// the pilot claims only that bound — `[0, tolerance]`, which is all a
/// decision needs and more than a coarse pilot resolves — and passes when
/// the measured share lies in it (within 3 × `noise`, the seed-to-seed
/// change of the mean). `null` when nothing was measured.
fn share_check(
    estimated: Option<f64>,
    measured: Option<f64>,
    tol: f64,
    noise: f64,
) -> serde_json::Value {
    let (Some(e), Some(m)) = (estimated, measured) else {
        return serde_json::Value::Null;
    };
    let ratio = if m > 0.0 { Some(e / m) } else { None };
    let mut within_noise = false;
    let (bound, pass) = if e <= tol {
        (Some([0.0, tol]), m <= tol + 3.0 * noise)
    } else {
        let by_ratio =
            ratio.is_some_and(|r| (1.0 / SHARE_RATIO_LIMIT..=SHARE_RATIO_LIMIT).contains(&r));
        within_noise = !by_ratio
            && noise > 0.0
            && e * SHARE_RATIO_LIMIT >= m - 3.0 * noise
            && e / SHARE_RATIO_LIMIT <= m + 3.0 * noise;
        (None, by_ratio || within_noise)
    };
    serde_json::json!({"ratio": ratio, "bound": bound, "pass": pass, "within_noise": within_noise})
}

impl PlanCheck {
    /// The JSON `gloam bench plan --json` prints.
    pub fn json(&self) -> serde_json::Value {
        serde_json::json!({"spp": self.spp, "share_spp": self.share_spp, "scenes": self.scenes, "total": self.total})
    }

    /// The tables `gloam bench plan` prints.
    pub fn markdown(&self) -> String {
        use std::fmt::Write as _;
        let (out, total) = (&self.scenes, &self.total);
        let t_plan = total["plan_s"].as_f64().unwrap_or(f64::NAN);
        let t_all = total["all_effects_s"].as_f64().unwrap_or(f64::NAN);
        let all_agree = self.all_agree;
        let mut m = String::new();
        let pct = |x: &serde_json::Value| match x.as_f64() {
            Some(v) => format!("{:.3} %", 100.0 * v),
            None => "-".into(),
        };

        let _ = writeln!(
            m,
            "| scene | plan (s) | all effects (s) | saved | rel RMS diff | noise (seed to seed) | agree |"
        );
        let _ = writeln!(m, "|---|---|---|---|---|---|---|");
        for v in out.iter() {
            let _ = writeln!(
                m,
                "| {} | {:.3} | {:.3} | {:.0} % | {:.2e} | {:.2e} | {} |",
                v["scene"].as_str().unwrap_or_default(),
                v["plan_s"].as_f64().unwrap_or(f64::NAN),
                v["all_effects_s"].as_f64().unwrap_or(f64::NAN),
                100.0 * v["saved_fraction"].as_f64().unwrap_or(f64::NAN),
                v["rel_rms_difference"].as_f64().unwrap_or(f64::NAN),
                v["rel_rms_noise_between_seeds"]
                    .as_f64()
                    .unwrap_or(f64::NAN),
                v["agree_within_noise"]
            );
        }
        let _ = writeln!(
            m,
            "| **total** | {t_plan:.3} | {t_all:.3} | {:.0} % | | | {all_agree} |",
            100.0 * (1.0 - t_plan / t_all.max(1e-12))
        );
        let _ = writeln!(
            m,
            "\n| scene | interreflection | estimated share | measured share (flipped) | tolerance | consistent |"
        );
        let _ = writeln!(m, "|---|---|---|---|---|---|");
        for v in out.iter() {
            let ir = &v["interreflection"];
            let _ = writeln!(
                m,
                "| {} | {} | {:.3e} | {:.3e} | {} | {} |",
                v["scene"].as_str().unwrap_or_default(),
                ir["decision"].as_str().unwrap_or_default(),
                ir["estimated_share"].as_f64().unwrap_or(f64::NAN),
                ir["measured_share"].as_f64().unwrap_or(f64::NAN),
                ir["tolerance"],
                ir["consistent"]
            );
        }
        let _ = writeln!(
            m,
            "\nShares measured at {} samples per pixel.\n\n| scene | effect | estimated share (pilot) | measured | ratio | pass |",
            self.share_spp
        );
        let _ = writeln!(m, "|---|---|---|---|---|---|");
        for v in out.iter() {
            let ir = std::iter::once((
                "interreflection",
                &v["interreflection"]["estimated_share"],
                &v["interreflection"]["measured_share"],
                &v["interreflection"]["share_check"],
            ));
            let rest = v["effects"].as_array().into_iter().flatten().map(|e| {
                (
                    e["effect"].as_str().unwrap_or_default(),
                    &e["estimated_share"],
                    &e["measured_change"],
                    &e["share_check"],
                )
            });
            for (name, est, meas, chk) in ir.chain(rest) {
                if chk.is_null() {
                    continue;
                }
                let estimated = match chk["bound"].as_array() {
                    Some(b) => format!(
                        "{} (≤ {})",
                        pct(est),
                        pct(b.get(1).unwrap_or(&serde_json::Value::Null))
                    ),
                    None => pct(est),
                };
                let _ = writeln!(
                    m,
                    "| {} | {name} | {estimated} | {} | {} | {} |",
                    v["scene"].as_str().unwrap_or_default(),
                    pct(meas),
                    chk["ratio"]
                        .as_f64()
                        .map_or("-".into(), |r| format!("{r:.2}")),
                    match (chk["pass"] == true, chk["within_noise"] == true) {
                        (true, true) => "yes (within 3 × the noise of the mean)",
                        (true, false) => "yes",
                        _ => "**no**",
                    },
                );
            }
        }
        let _ = writeln!(
            m,
            "\n| scene | effect | on | estimated share | check | measured change (mean) | per pixel (noise) | consistent |"
        );
        let _ = writeln!(m, "|---|---|---|---|---|---|---|---|");
        for v in out.iter() {
            for e in v["effects"].as_array().into_iter().flatten() {
                let _ = writeln!(
                    m,
                    "| {} | {} | {} | {} | {} | {} | {} | {} |",
                    v["scene"].as_str().unwrap_or_default(),
                    e["effect"].as_str().unwrap_or_default(),
                    if e["enabled"] == true { "yes" } else { "no" },
                    pct(&e["estimated_share"]),
                    e["check"].as_str().unwrap_or_default(),
                    pct(&e["measured_change"]),
                    if e["per_pixel_change"].is_null() {
                        "-".to_string()
                    } else {
                        format!(
                            "{} ({})",
                            pct(&e["per_pixel_change"]),
                            pct(&e["per_pixel_noise"])
                        )
                    },
                    match e["consistent"].as_bool() {
                        Some(b) => b.to_string(),
                        None => "-".into(),
                    }
                );
            }
        }
        m
    }

    /// An error when a check failed (the tables say which).
    pub fn verdict(&self) -> Result<(), BenchError> {
        let fail = |why| Err(BenchError::Check(why));
        if !self.all_agree {
            return fail("rendering with every effect forced on changed an image beyond its noise");
        }
        if !self.interreflection_consistent {
            return fail(
                "an interreflection decision disagrees with its measured share (see the table)",
            );
        }
        if !self.shares_ok {
            return fail(
                "a pilot share is not within 1.5× of the measured share, nor, when at most the tolerance, is the measured share (see the table)",
            );
        }
        if !self.effects_consistent {
            return fail(
                "an effect's decision disagrees with the change measured when it is dropped or forced on (see the table)",
            );
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::share_check;

    /// Above the tolerance the ratio decides (1.5× either way, inclusive);
    /// at or below it the estimate is the bound [0, tolerance] and the
    /// measured share must lie in it, within 3 × noise.
    #[test]
    fn share_check_ratio_and_bound() {
        let tol = 0.005;
        let c = share_check(Some(0.0174), Some(0.0198), tol, 0.0);
        assert_eq!(c["pass"], true);
        assert!((c["ratio"].as_f64().unwrap() - 0.0174 / 0.0198).abs() < 1e-12);
        assert!(c["bound"].is_null());
        // The old night figures: 0.85 % against 2.3 % fails; 1.45 %
        // against 0.12 % fails.
        assert_eq!(
            share_check(Some(0.0085), Some(0.023), tol, 0.0)["pass"],
            false
        );
        assert_eq!(
            share_check(Some(0.0145), Some(0.0012), tol, 0.0)["pass"],
            false
        );
        assert_eq!(share_check(Some(0.03), Some(0.02), tol, 0.0)["pass"], true);
        assert_eq!(
            share_check(Some(0.0301), Some(0.02), tol, 0.0)["pass"],
            false
        );
        // Below the tolerance: a bound.
        let b = share_check(Some(0.0018), Some(0.00004), tol, 0.0);
        assert_eq!(b["pass"], true);
        assert_eq!(b["bound"][1], tol);
        assert_eq!(
            share_check(Some(0.0018), Some(0.006), tol, 0.0)["pass"],
            false
        );
        assert_eq!(
            share_check(Some(0.0018), Some(0.006), tol, 0.001)["pass"],
            true
        );
        // Above the tolerance, outside 1.5×, but within 1.5× of a share
        // 3 × noise from the measured one (the night town's Moon was 0.82 %
        // against 1.24 %, noise 0.23 %): passes, flagged.
        let n = share_check(Some(0.0080), Some(0.0124), tol, 0.0023);
        assert_eq!(
            (n["pass"].clone(), n["within_noise"].clone()),
            (true.into(), true.into())
        );
        assert_eq!(
            share_check(Some(0.0080), Some(0.0124), tol, 0.0)["pass"],
            false
        );
        // Noise does not excuse a miss many times its size.
        assert_eq!(
            share_check(Some(0.0085), Some(0.023), tol, 0.0023)["pass"],
            false
        );
        // Measured zero and an estimate above the tolerance: no ratio, fail.
        let z = share_check(Some(0.01), Some(0.0), tol, 0.0);
        assert!(z["ratio"].is_null());
        assert_eq!(z["pass"], false);
        assert!(share_check(None, Some(0.01), tol, 0.0).is_null());
    }
}
