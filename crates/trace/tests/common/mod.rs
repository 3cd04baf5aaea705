//! Shared by the photometry tests: a measured-luminaire file written from
//! a closed form.

/// An IES LM-63-2002 file of `i0_cd · cos^power γ`, rotationally
/// symmetric, on a vertical grid of `step_deg` over [0°, 90°].
pub fn cos_power_ies(step_deg: f64, power: f64, i0_cd: f64) -> String {
    let n = (90.0 / step_deg).round() as usize + 1;
    let g: Vec<f64> = (0..n).map(|k| k as f64 * step_deg).collect();
    let join = |v: &[f64]| {
        v.iter()
            .map(|x| format!("{x}"))
            .collect::<Vec<_>>()
            .join(" ")
    };
    let cd: Vec<f64> = g
        .iter()
        .map(|x| i0_cd * x.to_radians().cos().max(0.0).powf(power))
        .collect();
    format!(
        "IESNA:LM-63-2002\n[TEST] cos^{power}\nTILT=NONE\n1 -1 1 {n} 1 1 2 0 0 0\n1 1 1\n{}\n0\n{}\n",
        join(&g),
        join(&cd)
    )
}
